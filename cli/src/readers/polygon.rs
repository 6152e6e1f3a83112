//! Polygons into triangles. A model's faces may be concave (a wall around a window opening
//! written as one polygon that goes round the opening and back along a seam): a fan from
//! the first corner covers the opening. Faces are projected onto their plane (Newell's
//! normal) and cut by ear clipping (the `earcut` crate, a port of mapbox/earcut), and each
//! triangle keeps the face's winding. A face that is not flat is measured, so a reader can
//! say so; one that ear clipping cannot cut (it crosses itself) keeps its fan and is
//! counted.

use glam::DVec3;

/// How a polygon was cut.
pub struct Cut {
    /// Triangles as corner positions in the polygon (0-based), wound as the polygon.
    pub triangles: Vec<[usize; 3]>,
    /// The largest distance of a corner from the polygon's plane, over its longest extent.
    pub non_planar: f64,
    /// Ear clipping could not cut it (a polygon that crosses itself): a fan was kept.
    pub fan: bool,
}

/// A face whose corners lie further than this share of its size from its plane is
/// reported as not flat.
pub const FLAT: f64 = 1e-3;

/// What cutting a file's polygons found, for its warnings.
#[derive(Debug, Default)]
pub struct Faces {
    /// Polygons of four or more corners cut.
    pub polygons: usize,
    /// Those not flat, the largest departure (share of the face's size), and the line of
    /// the first.
    pub warped: usize,
    pub worst: f64,
    pub first_warped: usize,
    /// Those that cross themselves (split as fans), and the line of the first.
    pub crossing: usize,
    pub first_crossing: usize,
}

impl Faces {
    /// Counts a cut polygon found at `line` (0 when the format has no lines).
    pub fn note(&mut self, c: &Cut, line: usize) {
        self.polygons += 1;
        if c.non_planar > FLAT {
            if self.warped == 0 {
                self.first_warped = line;
            }
            self.warped += 1;
            self.worst = self.worst.max(c.non_planar);
        }
        if c.fan {
            if self.crossing == 0 {
                self.first_crossing = line;
            }
            self.crossing += 1;
        }
    }

    /// The warnings for a file (`path`).
    pub fn warn(&self, path: &std::path::Path, diag: &mut crate::diag::Diagnostics) {
        let at = |line: usize| {
            if line > 0 {
                format!("{}:{line}", path.display())
            } else {
                path.display().to_string()
            }
        };
        if self.warped > 0 {
            diag.warn(format!(
                "{}: {} of {} polygons are not flat (corners up to {:.2} % of the face's size off its plane): each is cut in its best-fit plane, and its triangles follow the corners",
                at(self.first_warped),
                self.warped,
                self.polygons,
                100.0 * self.worst
            ));
        }
        if self.crossing > 0 {
            diag.warn(format!(
                "{}: {} polygon(s) cross themselves and were split as fans from their first corner (check them: a fan may cover an opening)",
                at(self.first_crossing),
                self.crossing
            ));
        }
    }
}

/// Newell's normal of a polygon (twice its area vector; zero for a degenerate one).
pub fn newell(points: &[DVec3]) -> DVec3 {
    let n = points.len();
    let mut v = DVec3::ZERO;
    for i in 0..n {
        let (a, b) = (points[i], points[(i + 1) % n]);
        v.x += (a.y - b.y) * (a.z + b.z);
        v.y += (a.z - b.z) * (a.x + b.x);
        v.z += (a.x - b.x) * (a.y + b.y);
    }
    v
}

fn fan(n: usize) -> Vec<[usize; 3]> {
    (1..n - 1).map(|k| [0, k, k + 1]).collect()
}

/// Cuts the polygon with corners `points` (in order, at least 3) into triangles. `holes`
/// are the positions where inner rings start (empty for a plain polygon): corners from
/// `holes[k]` to the next start (or the end) form a hole.
pub fn triangulate(points: &[DVec3], holes: &[usize]) -> Cut {
    let n = points.len();
    if n == 3 && holes.is_empty() {
        return Cut {
            triangles: vec![[0, 1, 2]],
            non_planar: 0.0,
            fan: false,
        };
    }
    let outer = holes.first().copied().unwrap_or(n);
    let normal = newell(&points[..outer]);
    let Some(unit) = normal.try_normalize() else {
        // No net area: a line or a point (the fan's triangles have none either), or a
        // polygon whose crossing lobes cancel.
        let crossing = fan(outer).iter().any(|t| {
            (points[t[1]] - points[t[0]]).cross(points[t[2]] - points[t[0]]) != DVec3::ZERO
        });
        return Cut {
            triangles: fan(outer),
            non_planar: 0.0,
            fan: crossing,
        };
    };
    // Flatness: distances from the plane through the centroid.
    let centroid = points.iter().copied().sum::<DVec3>() / n as f64;
    let (lo, hi) = points.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let extent = (hi - lo).max_element();
    let off = points
        .iter()
        .map(|&p| (p - centroid).dot(unit).abs())
        .fold(0.0, f64::max);
    let non_planar = if extent > 0.0 { off / extent } else { 0.0 };
    // Into the plane: an orthonormal frame with the normal as its third axis.
    let u = unit.any_orthonormal_vector();
    let v = unit.cross(u);
    let flat: Vec<[f64; 2]> = points
        .iter()
        .map(|&p| {
            let d = p - centroid;
            [d.dot(u), d.dot(v)]
        })
        .collect();
    // A convex face keeps its fan (the triangles every reader made of it before).
    let turn = |k: usize| {
        let [a, b, c] = [k, (k + 1) % n, (k + 2) % n].map(|i| flat[i]);
        (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
    };
    if holes.is_empty() && (0..n).all(|k| turn(k) > 0.0) {
        return Cut {
            triangles: fan(n),
            non_planar,
            fan: false,
        };
    }
    let mut out: Vec<u32> = Vec::new();
    let holes32: Vec<u32> = holes.iter().map(|&h| h as u32).collect();
    earcut::Earcut::new().earcut(flat.iter().copied(), &holes32, &mut out);
    let mut triangles: Vec<[usize; 3]> = out
        .chunks_exact(3)
        .map(|t| [t[0] as usize, t[1] as usize, t[2] as usize])
        .collect();
    // Ear clipping covers the polygon exactly: its triangles' area is the polygon's.
    let area = |t: &[usize; 3]| {
        let [a, b, c] = t.map(|i| flat[i]);
        0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
    };
    let ring_area = |r: std::ops::Range<usize>| {
        let m = r.len();
        let s: f64 = (0..m)
            .map(|k| {
                let (a, b) = (flat[r.start + k], flat[r.start + (k + 1) % m]);
                a[0] * b[1] - b[0] * a[1]
            })
            .sum();
        0.5 * s.abs()
    };
    let mut starts: Vec<usize> = vec![0];
    starts.extend(holes);
    starts.push(n);
    let want: f64 = ring_area(0..outer)
        - starts
            .windows(2)
            .skip(1)
            .map(|w| ring_area(w[0]..w[1]))
            .sum::<f64>();
    let got: f64 = triangles.iter().map(|t| area(t).abs()).sum();
    let expected = n - 2 + 2 * holes.len();
    let wrong = triangles.is_empty()
        || (got - want).abs() > 1e-9 * want.max(f64::MIN_POSITIVE) * expected as f64;
    if wrong && holes.is_empty() {
        return Cut {
            triangles: fan(n),
            non_planar,
            fan: true,
        };
    }
    // Each triangle wound as the polygon (its normal along Newell's).
    for t in &mut triangles {
        if area(t) < 0.0 {
            t.swap(1, 2);
        }
    }
    Cut {
        triangles,
        non_planar,
        fan: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(xy: &[[f64; 2]]) -> Vec<DVec3> {
        xy.iter().map(|p| DVec3::new(p[0], p[1], 0.0)).collect()
    }

    fn area(p: &[DVec3], t: &[[usize; 3]]) -> f64 {
        t.iter()
            .map(|t| 0.5 * (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).z)
            .sum()
    }

    /// A wall with a window, written as one polygon around the opening and back along a
    /// seam (how Honeybee exports it): its triangles cover the wall and not the opening,
    /// all wound as the wall.
    #[test]
    fn a_wall_around_its_window_is_cut_without_covering_the_window() {
        // Outer 0..4 × 0..3 counter-clockwise, seam to the window at (1, 1)–(3, 2),
        // round the window clockwise, back along the seam.
        let p = pts(&[
            [0.0, 0.0],
            [4.0, 0.0],
            [4.0, 3.0],
            [0.0, 3.0],
            [0.0, 0.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [3.0, 2.0],
            [3.0, 1.0],
            [1.0, 1.0],
        ]);
        let c = triangulate(&p, &[]);
        assert!(!c.fan);
        let a = area(&p, &c.triangles);
        assert!((a - (12.0 - 2.0)).abs() < 1e-9, "area {a}");
        for t in &c.triangles {
            assert!(area(&p, &[*t]) >= 0.0, "every triangle faces +z");
            // No triangle's centroid lies in the window.
            let m = (p[t[0]] + p[t[1]] + p[t[2]]) / 3.0;
            assert!(!(m.x > 1.0 && m.x < 3.0 && m.y > 1.0 && m.y < 2.0), "{m}");
        }
        // A fan from the first corner would have covered the window: it does.
        let f = fan(p.len());
        let covers = f.iter().any(|t| {
            let m = (p[t[0]] + p[t[1]] + p[t[2]]) / 3.0;
            m.x > 1.0 && m.x < 3.0 && m.y > 1.0 && m.y < 2.0
        });
        assert!(covers || area(&p, &f).abs() > 10.0 + 1e-9);
    }

    /// An L, clockwise in its plane seen from -z: the triangles keep the face's winding,
    /// and the area is the L's.
    #[test]
    fn concave_faces_keep_their_area_and_winding() {
        let mut p = pts(&[[0., 0.], [2., 0.], [2., 1.], [1., 1.], [1., 2.], [0., 2.]]);
        let c = triangulate(&p, &[]);
        assert_eq!(c.triangles.len(), 4);
        assert!((area(&p, &c.triangles) - 3.0).abs() < 1e-12);
        p.reverse();
        let c = triangulate(&p, &[]);
        assert!(
            (area(&p, &c.triangles) + 3.0).abs() < 1e-12,
            "wound the other way"
        );
        // Tilted into 3D: the same.
        let q: Vec<DVec3> = p.iter().map(|v| DVec3::new(v.x, 0.3 * v.y, v.y)).collect();
        let c = triangulate(&q, &[]);
        let n = newell(&q);
        for t in &c.triangles {
            let tn = (q[t[1]] - q[t[0]]).cross(q[t[2]] - q[t[0]]);
            assert!(tn.dot(n) > 0.0);
        }
        assert!(c.non_planar < 1e-12);
    }

    /// A hole given as an inner ring; a warped quad is measured as not flat; a polygon that
    /// crosses itself keeps its fan, flagged.
    #[test]
    fn holes_warps_and_self_crossings() {
        let p = pts(&[
            [0., 0.],
            [4., 0.],
            [4., 4.],
            [0., 4.],
            [1., 1.],
            [1., 3.],
            [3., 3.],
            [3., 1.],
        ]);
        let c = triangulate(&p, &[4]);
        assert!((area(&p, &c.triangles) - 12.0).abs() < 1e-9);
        let warped = vec![
            DVec3::new(0., 0., 0.),
            DVec3::new(1., 0., 0.),
            DVec3::new(1., 1., 0.2),
            DVec3::new(0., 1., 0.),
        ];
        assert!(triangulate(&warped, &[]).non_planar > 0.04);
        let bow = pts(&[[0., 0.], [2., 2.], [2., 0.], [0., 2.]]);
        assert!(triangulate(&bow, &[]).fan);
        let lopsided = pts(&[[0., 0.], [3., 3.], [3., 0.], [0., 1.]]);
        assert!(triangulate(&lopsided, &[]).fan);
    }
}

//! Emitters seen straight from the camera, by the exact share of each pixel they cover
//! (issue 37).
//!
//! A pixel on an emitting mesh's outline is a coverage fraction of a very bright source:
//! with jittered camera rays its value is L·k/n for the k of n rays that met the emitter,
//! and its relative variance (1 − c)/(c·n) for coverage c dominates a whole image's error
//! long after the rest has converged. A pinhole camera's pixel is a square of the image
//! plane, and a triangle projects onto that plane as a polygon, so the share c of a pixel a
//! triangle covers is an exact polygon area.
//!
//! It enters as a control variate, which keeps every estimate unbiased whatever lies in
//! front of the emitter: for the pixel's pairs (triangle t, share cₜ), each camera sample
//! adds Σₜ Lₜ·(cₜ − [the sample's ray crosses t]). Where nothing hides the emitter, the
//! crossing term cancels the emission the path finds and the pixel's direct part is
//! Σₜ Lₜ·cₜ exactly; where something does, the estimate stays unbiased (the crossing term's
//! mean is cₜ) and only its variance is what it was. Any subset of pairs is a valid
//! control, chosen before the render. So pairs a triangle covers whole (nothing to gain)
//! are left out, and so are pixels one lamp's triangles cover whole between them (a
//! tessellated lamp's inner edges); so are pairs where the camera does not see the triangle itself first
//! through each corner and the centre of its part of the pixel (something in front, glass
//! included: there a sample that crosses the hidden emitter would go below zero); and a
//! cap on the pairs' memory only leaves some out. An occluder thin enough to pass between
//! those five rays leaves the pixel unbiased but lets a single sample go below zero.
//!
//! Kept only where a camera ray's first segment is not attenuated (no medium around the
//! camera, no scene medium) and for emitting meshes of uniform radiance (all of them). A
//! scene none of whose emitting meshes the camera sees keeps no pair and pays one branch
//! per camera ray.

use super::camera::Camera;
use crate::scene::PreparedScene;
use glam::DVec3;

/// One triangle's share of one pixel.
#[derive(Clone, Copy, Debug)]
struct Pair {
    /// The triangle's first corner and its two edges from it (local scene units).
    v0: DVec3,
    e1: DVec3,
    e2: DVec3,
    /// The emitter (index into the eye tracer's lights).
    emitter: u32,
    /// The share of the pixel the triangle covers, in (0, 1).
    share: f64,
}

/// The partly covered pixels of a render and their pairs.
#[derive(Debug, Default)]
pub struct Coverage {
    /// Pixels with pairs, ascending.
    pixels: Vec<u32>,
    /// `starts[i]..starts[i + 1]` are pixel `pixels[i]`'s pairs.
    starts: Vec<u32>,
    pairs: Vec<Pair>,
}

/// Bytes of pairs a render keeps at most: beyond, further pairs are left out (each pair is
/// an independent part of the control, so fewer pairs only reduce less variance).
const MAX_PAIRS_BYTES: usize = 8 << 20;

impl Coverage {
    /// The pairs of every triangle of the emitting meshes `emitters` (mesh index, emitter
    /// index, whether it emits from both sides) that `camera` sees part of a pixel of.
    /// `sees(pixel x, y, jitter jx, jy, mesh, triangle)`: whether the camera ray through
    /// that point of the pixel meets that triangle first.
    pub fn new(
        scene: &PreparedScene,
        camera: &Camera,
        emitters: &[(usize, u32, bool)],
        sees: impl Fn(u32, u32, f64, f64, usize, usize) -> bool,
    ) -> Self {
        let (w, h) = (camera.desc.width, camera.desc.height);
        let most = (MAX_PAIRS_BYTES / std::mem::size_of::<Found>()).min(4 * camera.pixels() + 4096);
        // Every pair first; then the pixels covered whole go (`compact`, also whenever the
        // memory is full), and only then are the rest's rays cast.
        let mut found: Vec<Found> = Vec::new();
        'meshes: for &(mesh, emitter, two_sided) in emitters {
            let m = &scene.meshes[mesh];
            for (t, tri) in m.triangles.iter().enumerate() {
                let [a, b, c] = tri.map(|i| m.vertices[i as usize].as_dvec3());
                let n = m.normals[t].as_dvec3();
                // The side the camera sees must emit (`EyeTracer::emission_of`: a ray
                // meets the front when it runs against the normal).
                let facing = (camera.origin - a).dot(n);
                if n == DVec3::ZERO || facing == 0.0 || (facing < 0.0 && !two_sided) {
                    continue;
                }
                let Some(poly) = project(camera, [a, b, c]) else {
                    continue;
                };
                let pair = Pair {
                    v0: a,
                    e1: b - a,
                    e2: c - a,
                    emitter,
                    share: 0.0,
                };
                let (x0, x1, y0, y1) = bounds(&poly, w, h);
                for y in y0..y1 {
                    for x in x0..x1 {
                        // Most of a large triangle's pixels are inside it or outside it
                        // whole: told without clipping.
                        if !straddles(&poly, x as f64, y as f64) {
                            continue;
                        }
                        let share = area(&clip_to_pixel(&poly, x as f64, y as f64)).min(1.0);
                        if !(share > 0.0 && share < 1.0 - 1e-12) {
                            continue;
                        }
                        if found.len() >= most {
                            compact(&mut found);
                            if found.len() >= most {
                                break 'meshes;
                            }
                        }
                        found.push(Found {
                            pixel: y * w + x,
                            mesh: mesh as u32,
                            tri: t as u32,
                            pair: Pair { share, ..pair },
                        });
                    }
                }
            }
        }
        compact(&mut found);
        // What the camera does not see first through the corners (a little inside) and the
        // centre of the triangle's part of the pixel goes too.
        found.retain(|f| {
            let (x, y) = (f.pixel % w, f.pixel / w);
            let p = &f.pair;
            let Some(poly) = project(camera, [p.v0, p.v0 + p.e1, p.v0 + p.e2]) else {
                return false;
            };
            let part = clip_to_pixel(&poly, x as f64, y as f64);
            if part.is_empty() {
                return false;
            }
            let n = part.len() as f64;
            let c = part
                .iter()
                .fold((0.0, 0.0), |a, q| (a.0 + q.0 / n, a.1 + q.1 / n));
            part.iter()
                .map(|q| (c.0 + 0.98 * (q.0 - c.0), c.1 + 0.98 * (q.1 - c.1)))
                .chain([c])
                .all(|(px, py)| {
                    let (jx, jy) = (
                        (px - x as f64).clamp(0.0, 1.0 - 1e-9),
                        (py - y as f64).clamp(0.0, 1.0 - 1e-9),
                    );
                    sees(x, y, jx, jy, f.mesh as usize, f.tri as usize)
                })
        });
        let mut cov = Coverage::default();
        for f in found {
            if cov.pixels.last() != Some(&f.pixel) {
                cov.pixels.push(f.pixel);
                cov.starts.push(cov.pairs.len() as u32);
            }
            cov.pairs.push(f.pair);
        }
        cov.starts.push(cov.pairs.len() as u32);
        cov
    }

    /// Whether no pixel has a pair.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// For each pair of `pixel` whose emitter is `e`, `f(e, share − crossed)`: the control
    /// term of a camera ray from `origin` along `dir` (unit) through the pixel.
    #[inline]
    pub fn terms(&self, pixel: u32, origin: DVec3, dir: DVec3, mut f: impl FnMut(u32, f64)) {
        let Ok(i) = self.pixels.binary_search(&pixel) else {
            return;
        };
        let (s, e) = (self.starts[i] as usize, self.starts[i + 1] as usize);
        for p in &self.pairs[s..e] {
            let crossed = crosses(origin, dir, p);
            f(p.emitter, p.share - if crossed { 1.0 } else { 0.0 });
        }
    }
}

/// A pair while the pairs are collected: its pixel and its triangle.
#[derive(Clone, Copy, Debug)]
struct Found {
    pixel: u32,
    mesh: u32,
    tri: u32,
    pair: Pair,
}

/// Sorts the pairs by pixel (triangle order kept within a pixel) and drops the pixels that
/// one emitter's triangles cover whole between them (a tessellated lamp's inner edges):
/// every ray through such a pixel that meets one of them meets the lamp, so its direct
/// part has next to no variance to take away, and its pairs would only hold memory and
/// rays the outline needs. (Any pairs may go: what stays is still an exact control.)
fn compact(found: &mut Vec<Found>) {
    found.sort_by_key(|f| f.pixel);
    let mut kept = Vec::with_capacity(found.len());
    for group in found.chunk_by(|a, b| a.pixel == b.pixel) {
        let one_emitter = group
            .iter()
            .all(|f| f.pair.emitter == group[0].pair.emitter);
        let whole = (group.iter().map(|f| f.pair.share).sum::<f64>() - 1.0).abs() < 1e-9;
        if !(one_emitter && whole) {
            kept.extend_from_slice(group);
        }
    }
    *found = kept;
}

/// Whether the ray from `o` along `d` crosses the pair's triangle ahead (Möller–Trumbore;
/// either side).
#[inline]
fn crosses(o: DVec3, d: DVec3, p: &Pair) -> bool {
    let q = d.cross(p.e2);
    let det = p.e1.dot(q);
    if det == 0.0 {
        return false;
    }
    let inv = 1.0 / det;
    let s = o - p.v0;
    let u = s.dot(q) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let r = s.cross(p.e1);
    let v = d.dot(r) * inv;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    p.e2.dot(r) * inv > 0.0
}

/// The triangle's visible part (in front of the eye) on the image plane, in pixel
/// coordinates (x right, y down, pixel (i, j) the unit square from (i, j)); None when no
/// part is in front.
fn project(camera: &Camera, tri: [DVec3; 3]) -> Option<Vec<(f64, f64)>> {
    let depth = tri.map(|p| camera.depth(p));
    let far = depth.iter().fold(0.0f64, |a, &z| a.max(z));
    if far <= 0.0 {
        return None;
    }
    // Cut off what is behind (or nearly at) the eye's plane: such points project beyond
    // any image; 1e-9 of the triangle's depth keeps the projection finite.
    let near = 1e-9 * far;
    let mut poly = Vec::with_capacity(4);
    for i in 0..3 {
        let (p, q) = (tri[i], tri[(i + 1) % 3]);
        let (zp, zq) = (depth[i], depth[(i + 1) % 3]);
        if zp >= near {
            poly.push(p);
        }
        if (zp >= near) != (zq >= near) {
            poly.push(p + (q - p) * ((near - zp) / (zq - zp)));
        }
    }
    if poly.len() < 3 {
        return None;
    }
    Some(counter_clockwise(
        poly.into_iter().map(|p| camera.image_point(p)).collect(),
    ))
}

/// The polygon with its corners in the order that makes its signed area positive (what
/// `straddles` expects).
fn counter_clockwise(mut poly: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    if area_signed(&poly) < 0.0 {
        poly.reverse();
    }
    poly
}

/// The pixels the polygon's bounding box overlaps, clamped to the image: x0..x1, y0..y1.
fn bounds(poly: &[(f64, f64)], w: u32, h: u32) -> (u32, u32, u32, u32) {
    let (mut lo, mut hi) = (
        (f64::INFINITY, f64::INFINITY),
        (f64::NEG_INFINITY, f64::NEG_INFINITY),
    );
    for &(x, y) in poly {
        lo = (lo.0.min(x), lo.1.min(y));
        hi = (hi.0.max(x), hi.1.max(y));
    }
    let clamp = |v: f64, n: u32| v.clamp(0.0, n as f64) as u32;
    (
        clamp(lo.0.floor(), w),
        clamp(hi.0.ceil(), w),
        clamp(lo.1.floor(), h),
        clamp(hi.1.ceil(), h),
    )
}

/// Whether a convex polygon's outline (corners in `counter_clockwise` order, as `project`
/// gives them) may cross pixel (x, y): false when the pixel's four corners are all inside
/// the polygon, or all outside one of its edges.
fn straddles(poly: &[(f64, f64)], x: f64, y: f64) -> bool {
    let corners = [(x, y), (x + 1.0, y), (x + 1.0, y + 1.0), (x, y + 1.0)];
    let mut all_inside = true;
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        let mut outside = 0;
        for c in corners {
            let side = (q.0 - p.0) * (c.1 - p.1) - (q.1 - p.1) * (c.0 - p.0);
            if side < 0.0 {
                outside += 1;
                all_inside = false;
            }
        }
        if outside == 4 {
            return false;
        }
    }
    !all_inside
}

/// Twice a polygon's signed area (positive counter-clockwise in x right, y up).
fn area_signed(poly: &[(f64, f64)]) -> f64 {
    (0..poly.len())
        .map(|i| {
            let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
            p.0 * q.1 - q.0 * p.1
        })
        .sum()
}

/// The part of a convex polygon inside pixel (x, y) (the unit square from there):
/// Sutherland–Hodgman by the square's four sides; empty when none.
fn clip_to_pixel(poly: &[(f64, f64)], x: f64, y: f64) -> Vec<(f64, f64)> {
    let mut cur: Vec<(f64, f64)> = poly.to_vec();
    let mut next = Vec::with_capacity(cur.len() + 4);
    let sides: [(usize, f64, bool); 4] = [
        (0, x, true),
        (0, x + 1.0, false),
        (1, y, true),
        (1, y + 1.0, false),
    ];
    for (axis, at, keep_above) in sides {
        next.clear();
        let coord = |p: (f64, f64)| if axis == 0 { p.0 } else { p.1 };
        let inside = |p: (f64, f64)| {
            if keep_above {
                coord(p) >= at
            } else {
                coord(p) <= at
            }
        };
        for i in 0..cur.len() {
            let (p, q) = (cur[i], cur[(i + 1) % cur.len()]);
            if inside(p) {
                next.push(p);
            }
            if inside(p) != inside(q) {
                let s = (at - coord(p)) / (coord(q) - coord(p));
                let mut r = (p.0 + (q.0 - p.0) * s, p.1 + (q.1 - p.1) * s);
                if axis == 0 {
                    r.0 = at;
                } else {
                    r.1 = at;
                }
                next.push(r);
            }
        }
        std::mem::swap(&mut cur, &mut next);
        if cur.len() < 3 {
            return Vec::new();
        }
    }
    cur
}

/// A polygon's area (shoelace).
fn area(poly: &[(f64, f64)]) -> f64 {
    area_signed(poly).abs() * 0.5
}

/// The share of pixel (x, y) a convex polygon covers.
#[cfg(test)]
fn pixel_share(poly: &[(f64, f64)], x: f64, y: f64) -> f64 {
    area(&clip_to_pixel(poly, x, y)).min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square's share of pixels it half covers, covers whole, and misses.
    #[test]
    fn shares_of_a_square() {
        let square = [(0.5, 0.0), (2.0, 0.0), (2.0, 2.0), (0.5, 2.0)];
        assert!((pixel_share(&square, 0.0, 0.0) - 0.5).abs() < 1e-12);
        assert!((pixel_share(&square, 1.0, 1.0) - 1.0).abs() < 1e-12);
        assert_eq!(pixel_share(&square, 3.0, 0.0), 0.0);
        // The quick test: the outline crosses the first, not the second or the third.
        assert!(straddles(&square, 0.0, 0.0));
        assert!(!straddles(&square, 1.0, 1.0));
        assert!(!straddles(&square, 3.0, 0.0));
        let reversed = counter_clockwise(square.iter().rev().copied().collect());
        assert!(area_signed(&reversed) > 0.0);
        assert!(straddles(&reversed, 0.0, 0.0) && !straddles(&reversed, 1.0, 1.0));
        assert!(!straddles(&reversed, 3.0, 0.0));
    }

    /// A triangle's shares over the pixels it touches add up to its area (in pixels²),
    /// whatever its winding.
    #[test]
    fn shares_add_up_to_the_area() {
        let tris: [[(f64, f64); 3]; 2] = [
            [(0.3, 0.2), (7.9, 1.4), (2.2, 5.7)],
            [(2.2, 5.7), (7.9, 1.4), (0.3, 0.2)],
        ];
        for tri in tris {
            let area = 0.5
                * ((tri[1].0 - tri[0].0) * (tri[2].1 - tri[0].1)
                    - (tri[2].0 - tri[0].0) * (tri[1].1 - tri[0].1))
                    .abs();
            let (x0, x1, y0, y1) = bounds(&tri, 100, 100);
            let mut sum = 0.0;
            for y in y0..y1 {
                for x in x0..x1 {
                    sum += pixel_share(&tri, x as f64, y as f64);
                }
            }
            assert!((sum - area).abs() < 1e-9, "{sum} against {area}");
        }
    }

    /// The crossing test agrees with the barycentric definition on both sides and behind.
    #[test]
    fn crossing() {
        let p = Pair {
            v0: DVec3::new(0.0, 0.0, 1.0),
            e1: DVec3::new(1.0, 0.0, 0.0),
            e2: DVec3::new(0.0, 1.0, 0.0),
            emitter: 0,
            share: 0.5,
        };
        let o = DVec3::ZERO;
        assert!(crosses(o, DVec3::new(0.2, 0.2, 1.0).normalize(), &p));
        assert!(!crosses(o, DVec3::new(0.6, 0.6, 1.0).normalize(), &p));
        assert!(!crosses(o, DVec3::new(0.2, 0.2, -1.0).normalize(), &p));
        let o2 = DVec3::new(0.0, 0.0, 2.0);
        assert!(crosses(o2, DVec3::new(0.2, 0.2, -1.0).normalize(), &p));
    }
}

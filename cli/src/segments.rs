//! Where short segments first meet a model's triangles: a calculation grid's guard ring
//! must stop at the walls around it (`grids`), and a grid whose neighbouring points are
//! parted by a surface is told of it. The segments are few and short (a grid spacing), so
//! they are hashed into cells of that size and every triangle is tested only against the
//! segments of the cells its bounding box overlaps (or against all, when it overlaps more
//! cells than there are segments).

use glam::DVec3;
use std::collections::HashMap;

/// The first crossing of segment `a`→`b` with triangle `t`, as a share of the segment
/// in (0, 1], if any (Möller–Trumbore, both sides; grazing and parallel: none).
fn crossing(a: DVec3, b: DVec3, t: &[DVec3; 3]) -> Option<f64> {
    let d = b - a;
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let p = d.cross(e2);
    let det = e1.dot(p);
    let scale = e1.length() * e2.length() * d.length();
    if det.abs() <= 1e-12 * scale {
        return None;
    }
    let inv = 1.0 / det;
    let s = a - t[0];
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let x = e2.dot(q) * inv;
    (x > 0.0 && x <= 1.0).then_some(x)
}

/// For each segment (from, to), the share of it before it first meets a triangle: 1 when
/// it meets none.
pub fn first_crossings(
    segments: &[(DVec3, DVec3)],
    triangles: impl IntoIterator<Item = [DVec3; 3]>,
) -> Vec<f64> {
    let mut first = vec![1.0f64; segments.len()];
    if segments.is_empty() {
        return first;
    }
    let cell = segments
        .iter()
        .map(|(a, b)| (*b - *a).length())
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let key = |p: DVec3| (p / cell).floor().as_i64vec3().to_array();
    let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for (i, (a, b)) in segments.iter().enumerate() {
        let (s0, s1) = (key(a.min(*b)), key(a.max(*b)));
        lo = lo.min(a.min(*b));
        hi = hi.max(a.max(*b));
        for x in s0[0]..=s1[0] {
            for y in s0[1]..=s1[1] {
                for z in s0[2]..=s1[2] {
                    cells.entry([x, y, z]).or_default().push(i as u32);
                }
            }
        }
    }
    let mut seen: Vec<u32> = Vec::new();
    for t in triangles {
        let (tlo, thi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
        if tlo.cmpgt(hi).any() || thi.cmplt(lo).any() {
            continue;
        }
        let (c0, c1) = (key(tlo.max(lo)), key(thi.min(hi)));
        let span: i128 = (0..3).map(|k| (c1[k] - c0[k] + 1) as i128).product();
        let mut test = |i: usize| {
            if let Some(x) = crossing(segments[i].0, segments[i].1, &t) {
                first[i] = first[i].min(x);
            }
        };
        if span > segments.len() as i128 {
            (0..segments.len()).for_each(&mut test);
            continue;
        }
        seen.clear();
        for x in c0[0]..=c1[0] {
            for y in c0[1]..=c1[1] {
                for z in c0[2]..=c1[2] {
                    if let Some(list) = cells.get(&[x, y, z]) {
                        seen.extend(list);
                    }
                }
            }
        }
        seen.sort_unstable();
        seen.dedup();
        for &i in &seen {
            test(i as usize);
        }
    }
    first
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_stop_at_the_first_triangle_they_cross() {
        let wall = |x: f64| {
            [
                [
                    DVec3::new(x, -1.0, -1.0),
                    DVec3::new(x, 1.0, -1.0),
                    DVec3::new(x, 0.0, 2.0),
                ],
                // A large floor far below: its box overlaps many cells.
                [
                    DVec3::new(-1e3, -1e3, -5.0),
                    DVec3::new(1e3, -1e3, -5.0),
                    DVec3::new(0.0, 1e3, -5.0),
                ],
            ]
        };
        let mut tris: Vec<[DVec3; 3]> = wall(0.5).to_vec();
        tris.extend(wall(0.25));
        let segs = [
            (DVec3::ZERO, DVec3::new(1.0, 0.0, 0.0)),
            (DVec3::new(0.6, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0)),
            (DVec3::new(1.0, 0.0, 0.0), DVec3::ZERO),
        ];
        let f = first_crossings(&segs, tris.iter().copied());
        assert!((f[0] - 0.25).abs() < 1e-12, "{f:?}");
        assert_eq!(f[1], 1.0);
        assert!((f[2] - 0.5).abs() < 1e-12, "{f:?}");
    }
}

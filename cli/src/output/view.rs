//! The view: the camera (given, or chosen to show the lit model best) and the model drawn
//! from it with its map's colours, in bounded strips.

use super::maps::{luminance, vertex_colours, MeshMap, ToneMap};
use crate::diag::printable;
use crate::error::{fail, CliError, Result};
use crate::raster::{colour_map, draw_legend, nice_ceiling};
use crate::scene::{load, LoadedScene};
use crate::settings::{CameraSettings, Settings};
use glam::DVec3;
use imap::Context;
use std::path::Path;

impl CameraSettings {
    /// The up vector: the camera's, or +y for a camera made without settings.
    pub fn up(&self) -> [f64; 3] {
        self.up.unwrap_or([0.0, 1.0, 0.0])
    }

    /// The camera's projection (None: a name that is none).
    pub fn projection(&self) -> Option<imap::Projection> {
        match self.projection.as_deref() {
            None | Some("perspective") => Some(imap::Projection::Perspective),
            Some("angular") => Some(imap::Projection::AngularFisheye),
            Some("hemispherical") => Some(imap::Projection::Hemispherical),
            Some(_) => None,
        }
    }

    /// Checks the camera before any work is done.
    pub fn validate(&self) -> Result<()> {
        let (w, h) = (self.width as usize, self.height as usize);
        if w == 0 || h == 0 || w > 8192 || h > 8192 {
            fail!("camera: image size {w}×{h} is not in 1..=8192");
        }
        let (ok, range) = match self.projection() {
            Some(imap::Projection::Perspective) => (self.fov_deg < 180.0, "(0, 180)"),
            Some(imap::Projection::AngularFisheye) => (self.fov_deg <= 360.0, "(0, 360] for an angular fisheye"),
            Some(imap::Projection::Hemispherical) => (self.fov_deg <= 180.0, "(0, 180] for a hemispherical fisheye"),
            None => fail!(
                "camera: projection = {:?} is not \"perspective\", \"angular\" or \"hemispherical\"",
                self.projection.as_deref().unwrap_or_default()
            ),
        };
        if !(self.fov_deg > 0.0 && ok) {
            fail!("camera: fov_deg = {} is not in {range}", self.fov_deg);
        }
        let eye = DVec3::from(self.position);
        let Some(fwd) = (DVec3::from(self.look_at) - eye).try_normalize() else {
            fail!("camera: look_at must differ from position (and both be finite)");
        };
        if fwd.cross(DVec3::from(self.up())).try_normalize().is_none() {
            fail!("camera: up is zero or parallel to the view direction");
        }
        Ok(())
    }
}

/// The model's up (unit), its front — −y for z-up models, −z for the others — and the
/// side, up × front.
fn model_axes(up: [f64; 3]) -> (DVec3, DVec3, DVec3) {
    let up = DVec3::from(up).normalize();
    let front = if up.z.abs() > 0.5 {
        DVec3::NEG_Y
    } else {
        DVec3::NEG_Z
    };
    (up, front, up.cross(front).normalize())
}

/// A camera that frames the whole model (its bounding sphere fills the 40° view) from the
/// side of its lights, looking down at about 20° to the model's `up`: from the lights'
/// power-weighted centre as seen horizontally from the model's centre, or, when they are
/// (nearly) straight above or below it, from the front of the model (−z for y-up models,
/// −y for z-up ones) turned 17° about the up axis.
pub fn default_camera(scene: &LoadedScene, up: [f64; 3]) -> CameraSettings {
    let (lo, hi) = scene.bounds();
    let (lo, hi) = (DVec3::from(lo), DVec3::from(hi));
    let c = 0.5 * (lo + hi);
    let radius = (0.5 * (hi - lo).length()).max(1e-9);
    let (up, front, side) = model_axes(up);
    let mut horizontal = (front + 0.3 * side).normalize();
    let mut lit = DVec3::ZERO;
    let mut power = 0.0;
    for l in scene.lights.iter().filter(|l| !l.distant) {
        lit += l.watts * DVec3::from(l.position);
        power += l.watts;
    }
    for m in scene.meshes.iter().filter(|m| m.emission.is_some()) {
        let n = (m.positions.len() / 3).max(1) as f64;
        let p: DVec3 = m
            .positions
            .chunks_exact(3)
            .map(|p| DVec3::new(p[0], p[1], p[2]))
            .sum();
        let w: f64 = m.emission.as_ref().map_or(0.0, |e| e.iter().sum());
        lit += w * p / n;
        power += w;
    }
    let mut elevation: f64 = 0.35;
    if power > 0.0 && (lit / power).is_finite() {
        let to = lit / power - c;
        let h = to - up * to.dot(up);
        if h.length() > 0.2 * radius {
            horizontal = h.normalize();
        }
        if to.dot(up) < -0.2 * radius {
            elevation = -0.35; // lit from below: look from below
        }
    }
    let dir = (horizontal + elevation * up).normalize();
    let fov: f64 = 40.0;
    let dist = radius / (fov.to_radians() / 2.0).sin();
    CameraSettings {
        position: (c + dir * dist).to_array(),
        look_at: c.to_array(),
        up: Some(up.to_array()),
        fov_deg: fov,
        width: 640,
        height: 640,
        projection: None,
    }
}

/// The share of a camera's picture that shows lit, recorded sides facing it (`score_view`)
/// that a candidate must beat the default view's by to replace it.
const BETTER_VIEW: f64 = 1.25;

/// The default view after a run: of the default camera (`default_camera`) and views from
/// the other sides, from above, and from inside the model's box (from near each upper
/// corner toward the opposite lower one, 70°), the one whose picture shows the most lit,
/// recorded surface facing the camera — so a room lit inside is seen from inside, not as
/// the outer faces of its walls, and a mesh recorded on one side is seen from that side.
/// The default camera is kept unless another shows `BETTER_VIEW` times as much. Returns
/// the camera and the share of its picture that shows lit recorded sides.
pub fn choose_camera(
    scene: &LoadedScene,
    maps: &[Option<MeshMap>],
    up: [f64; 3],
) -> Result<(CameraSettings, f64)> {
    let first = default_camera(scene, up);
    let (lo, hi) = scene.bounds();
    let (lo, hi) = (DVec3::from(lo), DVec3::from(hi));
    let c = 0.5 * (lo + hi);
    let (up_v, front, side) = model_axes(up);
    let half = 0.5 * (hi - lo);
    let (h_front, h_side) = (
        half.dot(front).abs().max(1e-9),
        half.dot(side).abs().max(1e-9),
    );
    let height = half.dot(up_v).abs();
    let mut candidates = vec![first.clone()];
    let radius = (half.length()).max(1e-9);
    for k in 1..4 {
        // The default's view turned by 90°, 180°, 270° about the up axis.
        let a = k as f64 * std::f64::consts::FRAC_PI_2;
        let d = DVec3::from(first.position) - c;
        let (h, v) = (d - up_v * d.dot(up_v), up_v * d.dot(up_v));
        let turned = h * a.cos() + up_v.cross(h) * a.sin() + v;
        candidates.push(CameraSettings {
            position: (c + turned).to_array(),
            ..first.clone()
        });
    }
    // From above, looking down (a plan).
    let dist = radius / (20f64.to_radians()).sin();
    candidates.push(CameraSettings {
        position: (c + up_v * dist).to_array(),
        up: Some((-front).to_array()),
        ..first.clone()
    });
    // From inside, near each upper corner toward the opposite lower one.
    for (sf, ss) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
        let corner = front * (sf * h_front) + side * (ss * h_side);
        let eye = c + 0.8 * corner + up_v * (0.5 * height);
        let target = c - 0.6 * corner - up_v * (0.6 * height);
        candidates.push(CameraSettings {
            position: eye.to_array(),
            look_at: target.to_array(),
            fov_deg: 70.0,
            ..first.clone()
        });
    }
    let attrs = lit_side_attributes(scene, maps);
    let mut best: (CameraSettings, f64) = (first.clone(), -1.0);
    for (k, cam) in candidates.into_iter().enumerate() {
        let small = CameraSettings {
            width: 96,
            height: 96,
            ..cam.clone()
        };
        if small.validate().is_err() {
            continue;
        }
        let score = score_view(scene, &attrs, &small)?;
        let better = if k == 0 {
            true
        } else {
            score > BETTER_VIEW * best.1.max(0.0) + 0.02 && score > best.1
        };
        if better {
            best = (cam, score);
        }
    }
    Ok(best)
}

/// Per mesh and side: 1 where the side is recorded and lit, 0 elsewhere (and on the
/// unrecorded back of a one-sided recorded mesh, and on surfaces that do not record:
/// they only hide what is behind them).
fn lit_side_attributes(scene: &LoadedScene, maps: &[Option<MeshMap>]) -> Vec<ViewAttrs> {
    scene
        .meshes
        .iter()
        .zip(maps)
        .map(|(m, map)| {
            let nv = m.positions.len() / 3;
            let flags = |lux: Option<&Vec<f64>>| -> Vec<ViewAttr> {
                (0..nv)
                    .map(|v| {
                        let lit = lux.is_some_and(|l| l[v] > 0.0 && l[v].is_finite());
                        [f64::from(u8::from(lit)), 0.0, 0.0, 1.0]
                    })
                    .collect()
            };
            ViewAttrs {
                front: flags(map.as_ref().map(|mm| &mm.lux)),
                back: Some(flags(map.as_ref().and_then(|mm| mm.lux_back.as_ref()))),
            }
        })
        .collect()
}

/// The share of the picture of `cam` that shows lit, recorded sides facing the camera.
fn score_view(scene: &LoadedScene, attrs: &[ViewAttrs], cam: &CameraSettings) -> Result<f64> {
    let mut sum = 0.0;
    rasterize_rows(scene, attrs, cam, &mut |_, row| {
        sum += row.iter().map(|a| a[0]).sum::<f64>();
    })?;
    Ok(sum / (cam.width as f64 * cam.height as f64))
}

/// What the view interpolates per vertex: illuminance (lx), the luminance of the reflected
/// light (for surfaces that do not record), 1 on recording meshes, 1 (coverage).
type ViewAttr = [f64; 4];

/// A mesh's view attributes per vertex: of its front, and of its back when both sides are
/// recorded (a triangle shows the side that faces the camera).
struct ViewAttrs {
    front: Vec<ViewAttr>,
    back: Option<Vec<ViewAttr>>,
}

fn view_attributes(scene: &LoadedScene, maps: &[Option<MeshMap>]) -> Vec<ViewAttrs> {
    let colours = vertex_colours(scene, maps);
    scene
        .meshes
        .iter()
        .zip(maps)
        .zip(colours)
        .map(|((m, map), cols)| {
            let nv = m.positions.len() / 3;
            let side = |lux: Option<&Vec<f64>>| -> Vec<ViewAttr> {
                (0..nv)
                    .map(|v| match lux {
                        Some(l) => [l[v], luminance(cols[v]), 1.0, 1.0],
                        None => [0.0, luminance(cols[v]), 0.0, 1.0],
                    })
                    .collect()
            };
            ViewAttrs {
                front: side(map.as_ref().map(|mm| &mm.lux)),
                back: map
                    .as_ref()
                    .and_then(|mm| mm.lux_back.as_ref())
                    .map(|b| side(Some(b))),
            }
        })
        .collect()
}

/// The view: recording surfaces in false colour by illuminance (lx), the others grey by
/// the light they reflect, with a legend in lux along the bottom; RGB bytes.
pub fn render_view(
    scene: &LoadedScene,
    maps: &[Option<MeshMap>],
    cam: &CameraSettings,
) -> Result<Vec<u8>> {
    let attrs = view_attributes(scene, maps);
    let mut lux: Vec<f64> = maps
        .iter()
        .flatten()
        .flat_map(|m| m.lux.iter().copied())
        .filter(|x| x.is_finite())
        .collect();
    lux.sort_by(f64::total_cmp);
    // The scale ends at a round number above the 95th percentile (brighter spots, such as
    // surfaces right under a lamp, saturate to the top colour).
    let top = nice_ceiling(
        lux.get((lux.len() as f64 * 0.95) as usize)
            .copied()
            .unwrap_or(0.0),
    );
    let tone = ToneMap::new(
        attrs
            .iter()
            .flat_map(|a| &a.front)
            .filter(|a| a[2] < 0.5)
            .map(|a| a[1]),
    );
    let mut out = Vec::with_capacity(cam.width as usize * cam.height as usize * 3);
    let drawn = rasterize_rows(scene, &attrs, cam, &mut |_, row| {
        for a in row {
            let c = if a[3] < 0.5 {
                [24, 24, 28]
            } else if a[2] >= 0.5 {
                colour_map(a[0] / a[2] / top)
            } else {
                let g = tone.apply([a[1]; 3])[0];
                [g, g, g]
            };
            out.extend(c);
        }
    })?;
    if drawn.cut {
        eprintln!(
            "imap: warning: view.png: the model hides its surfaces behind each other more than {MAX_OVERDRAW} times over (overlapping copies?); the picture was cut short and may miss surfaces"
        );
    }
    draw_legend(&mut out, cam.width, cam.height, top);
    Ok(out)
}

/// Draws every mesh with a z-buffer, per-vertex attributes interpolated
/// perspective-correctly (2×2 supersampled, averaged), and the number of pixels the
/// rasteriser visited (its cost).
/// How the view was drawn.
pub struct Drawn {
    /// Supersampled pixels the triangles' spans visited.
    pub visited: u64,
    /// The drawing stopped at `MAX_OVERDRAW` (surfaces behind others may be missing).
    pub cut: bool,
}

/// The most times over the view's pixels the triangles may be drawn: past it the
/// picture is cut short (a model of a million copies of one surface must not take
/// minutes to draw).
pub const MAX_OVERDRAW: u64 = 256;

/// Memory a strip of the view may take, bytes (its depths and attributes): any image
/// size draws in bounded memory.
const STRIP_BYTES: usize = 64 << 20;

/// Rasterizes every mesh (2×2 supersampled, perspective-correct, depth-tested) and hands
/// each output row's averaged attributes to `emit`, top row first. Strips of rows are
/// drawn one at a time, each with the triangles that reach it; triangles with the same
/// three corners as one drawn before are drawn once.
fn rasterize_rows(
    scene: &LoadedScene,
    attrs: &[ViewAttrs],
    cam: &CameraSettings,
    emit: &mut dyn FnMut(usize, &[ViewAttr]),
) -> Result<Drawn> {
    use std::hash::{Hash, Hasher};
    cam.validate()?;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let eye = DVec3::from(cam.position);
    let fwd = (DVec3::from(cam.look_at) - eye).normalize();
    let right = fwd.cross(DVec3::from(cam.up())).normalize();
    let up = right.cross(fwd);
    let f = 1.0 / (cam.fov_deg.to_radians() / 2.0).tan();
    let aspect = w as f64 / h as f64;
    let (sw, sh) = (2 * w, 2 * h);
    // The near plane: triangles that cross it are clipped there (a camera inside a room
    // sees the whole ceiling, not the triangles whose corners are all in front of it).
    let (blo, bhi) = scene.bounds();
    let near = 1e-4 * (DVec3::from(bhi) - DVec3::from(blo)).length().max(1e-9);
    let screen = |d: DVec3| -> [f64; 3] {
        let depth = d.dot(fwd);
        let x = d.dot(right) * f / (depth * aspect);
        let y = d.dot(up) * f / depth;
        [
            (x + 1.0) * 0.5 * sw as f64,
            (1.0 - y) * 0.5 * sh as f64,
            depth,
        ]
    };
    let project = |p: &[f64]| -> Option<[f64; 3]> {
        let d = DVec3::new(p[0], p[1], p[2]) - eye;
        (d.dot(fwd) >= near).then(|| screen(d))
    };
    // Project every vertex once, and list the triangles in view by their first row.
    let pts: Vec<Vec<Option<[f64; 3]>>> = scene
        .meshes
        .iter()
        .map(|m| m.positions.chunks_exact(3).map(project).collect())
        .collect();
    struct Tri {
        mesh: u32,
        first: u32,
        y0: u32,
        y1: u32,
        /// Index into `clipped` + 1 for a piece of a triangle cut at the near plane; 0
        /// for a whole triangle.
        piece: u32,
    }
    /// A piece of a triangle cut at the near plane: its corners on the screen and each
    /// corner's barycentric weights on the original triangle's corners.
    struct Piece {
        pts: [[f64; 3]; 3],
        bary: [[f64; 3]; 3],
    }
    let mut clipped: Vec<Piece> = Vec::new();
    let mut tris = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for (mi, m) in scene.meshes.iter().enumerate() {
        for (ti, t) in m.indices.chunks_exact(3).enumerate() {
            let corners = [0, 1, 2].map(|i| pts[mi][t[i] as usize]);
            // At most two pieces (a quadrilateral after clipping); no allocation per
            // triangle.
            let mut pieces = [(0usize, [[0.0f64; 3]; 3]); 2];
            let mut np = 0;
            match corners {
                [Some(a), Some(b), Some(c)] => {
                    pieces[0] = (0, [a, b, c]);
                    np = 1;
                }
                [None, None, None] => continue,
                _ => {
                    // Sutherland–Hodgman against depth ≥ near, in camera space, keeping
                    // each new corner's weights on the original corners.
                    let cam = [0, 1, 2].map(|i| {
                        let p = &m.positions[3 * t[i] as usize..][..3];
                        DVec3::new(p[0], p[1], p[2]) - eye
                    });
                    let unit = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
                    let mut poly: Vec<(DVec3, [f64; 3])> = Vec::with_capacity(4);
                    for i in 0..3 {
                        let j = (i + 1) % 3;
                        let (di, dj) = (cam[i].dot(fwd) - near, cam[j].dot(fwd) - near);
                        if di >= 0.0 {
                            poly.push((cam[i], unit[i]));
                        }
                        if (di >= 0.0) != (dj >= 0.0) {
                            let s = di / (di - dj);
                            let w = [0, 1, 2].map(|k| unit[i][k] * (1.0 - s) + unit[j][k] * s);
                            poly.push((cam[i] + (cam[j] - cam[i]) * s, w));
                        }
                    }
                    for k in 1..poly.len().saturating_sub(1) {
                        let tri = [poly[0], poly[k], poly[k + 1]];
                        clipped.push(Piece {
                            pts: tri.map(|(d, _)| screen(d)),
                            bary: tri.map(|(_, w)| w),
                        });
                        pieces[np] = (clipped.len(), clipped.last().unwrap().pts);
                        np += 1;
                    }
                }
            }
            for &(piece, [a, b, c]) in &pieces[..np] {
                let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
                if area.is_nan() || area.abs() < 1e-12 {
                    continue;
                }
                let ylo = a[1].min(b[1]).min(c[1]).floor().max(0.0);
                let yhi = a[1].max(b[1]).max(c[1]).ceil().min(sh as f64);
                let xlo = a[0].min(b[0]).min(c[0]);
                let xhi = a[0].max(b[0]).max(c[0]);
                if ylo >= yhi || ylo.is_nan() || xhi < 0.0 || xlo > sw as f64 {
                    continue;
                }
                // The same three corners (in any order) as a triangle already listed.
                if piece == 0 {
                    let mut corners = [t[0], t[1], t[2]].map(|v| {
                        let p = &m.positions[3 * v as usize..][..3];
                        [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()]
                    });
                    corners.sort_unstable();
                    let mut hasher = std::collections::hash_map::DefaultHasher::new();
                    corners.hash(&mut hasher);
                    if !seen.insert(hasher.finish()) {
                        continue;
                    }
                }
                tris.push(Tri {
                    mesh: mi as u32,
                    first: 3 * ti as u32,
                    y0: ylo as u32,
                    y1: yhi as u32,
                    piece: piece as u32,
                });
            }
        }
    }
    drop(seen);
    tris.sort_by_key(|t| t.y0);
    let per_row = sw * (8 + std::mem::size_of::<ViewAttr>());
    let rows = (STRIP_BYTES / per_row / 2).clamp(1, h) * 2; // supersampled, even
    let budget = MAX_OVERDRAW.saturating_mul((sw * sh) as u64);
    let mut drawn = Drawn {
        visited: 0,
        cut: false,
    };
    let mut z = vec![f64::INFINITY; sw * rows];
    let mut img = vec![[0.0f64; 4]; sw * rows];
    let mut active: Vec<usize> = Vec::new();
    let mut next = 0;
    let mut out_row = vec![[0.0f64; 4]; w];
    for ys in (0..sh).step_by(rows) {
        let ye = (ys + rows).min(sh);
        z[..sw * (ye - ys)].fill(f64::INFINITY);
        img[..sw * (ye - ys)].fill([0.0; 4]);
        active.retain(|&k| tris[k].y1 as usize > ys);
        while next < tris.len() && (tris[next].y0 as usize) < ye {
            active.push(next);
            next += 1;
        }
        for &k in &active {
            if drawn.cut {
                break;
            }
            let tri = &tris[k];
            let m = &scene.meshes[tri.mesh as usize];
            let t = &m.indices[tri.first as usize..][..3];
            let (a, b, c) = match tri.piece {
                0 => {
                    let p = &pts[tri.mesh as usize];
                    (
                        p[t[0] as usize].expect("in view"),
                        p[t[1] as usize].expect("in view"),
                        p[t[2] as usize].expect("in view"),
                    )
                }
                k => {
                    let q = &clipped[k as usize - 1].pts;
                    (q[0], q[1], q[2])
                }
            };
            let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            // A two-sided mesh shows the side that faces the camera (seen from its front, a
            // triangle runs clockwise on the screen, whose y points down; a piece keeps
            // its triangle's winding).
            let va = &attrs[tri.mesh as usize];
            let shown = match &va.back {
                Some(back) if area > 0.0 => back,
                _ => &va.front,
            };
            let whole = [0, 1, 2].map(|i| shown[t[i] as usize]);
            let cols = match tri.piece {
                0 => whole,
                k => clipped[k as usize - 1].bary.map(|w| {
                    [0, 1, 2, 3]
                        .map(|q| w[0] * whole[0][q] + w[1] * whole[1][q] + w[2] * whole[2][q])
                }),
            };
            let y0 = (tri.y0 as usize).max(ys);
            let y1 = (tri.y1 as usize).min(ye);
            for y in y0..y1 {
                // The row's span inside the triangle: where the pixel-centre line crosses
                // its edges. Only those pixels are visited, so a long thin triangle costs
                // its rows and its pixels, not its bounding box.
                let py = y as f64 + 0.5;
                let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                for (p, q) in [(a, b), (b, c), (c, a)] {
                    if (p[1] <= py) != (q[1] <= py) {
                        let x = p[0] + (py - p[1]) / (q[1] - p[1]) * (q[0] - p[0]);
                        lo = lo.min(x);
                        hi = hi.max(x);
                    }
                }
                if lo > hi {
                    continue;
                }
                let x0 = (lo - 0.5).ceil().max(0.0) as usize;
                let x1 = ((hi - 0.5).floor() + 1.0).clamp(0.0, sw as f64) as usize;
                drawn.visited += (x1.saturating_sub(x0)) as u64;
                let row = (y - ys) * sw;
                for x in x0..x1 {
                    let px = x as f64 + 0.5;
                    let w0 = ((b[0] - px) * (c[1] - py) - (b[1] - py) * (c[0] - px)) / area;
                    let w1 = ((c[0] - px) * (a[1] - py) - (c[1] - py) * (a[0] - px)) / area;
                    let w2 = 1.0 - w0 - w1;
                    // On the span already; the weights only clip rounding at its ends.
                    let (w0, w1, w2) = (w0.max(0.0), w1.max(0.0), w2.max(0.0));
                    // Perspective-correct interpolation.
                    let iz = w0 / a[2] + w1 / b[2] + w2 / c[2];
                    let depth = 1.0 / iz;
                    let i = row + x;
                    if depth >= z[i] {
                        continue;
                    }
                    z[i] = depth;
                    let (p0, p1, p2) = (w0 / a[2] * depth, w1 / b[2] * depth, w2 / c[2] * depth);
                    img[i] =
                        [0, 1, 2, 3].map(|k| p0 * cols[0][k] + p1 * cols[1][k] + p2 * cols[2][k]);
                }
            }
            drawn.cut = drawn.visited > budget;
        }
        for oy in ys / 2..ye / 2 {
            for (x, o) in out_row.iter_mut().enumerate() {
                let mut c = [0.0; 4];
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let p = img[(2 * oy + dy - ys) * sw + 2 * x + dx];
                    for k in 0..4 {
                        c[k] += 0.25 * p[k];
                    }
                }
                *o = c;
            }
            emit(oy, &out_row);
        }
    }
    Ok(drawn)
}

/// `load`, with the settings' camera checked first (a mistake found after an hour's run
/// would throw the hour away) and the load's warnings printed; the camera is the
/// settings' or the default one (`default_camera`), for the caller to check.
pub fn load_with_camera(
    path: &Path,
    settings: &Settings,
) -> Result<(Context, LoadedScene, CameraSettings)> {
    if let Some(c) = &settings.camera {
        c.validate()?;
    }
    let up = settings.up()?;
    let (ctx, scene) = load(path, settings)?;
    for w in &scene.warnings {
        eprintln!("imap: warning: {}", printable(w));
    }
    let cam = settings
        .camera
        .clone()
        .unwrap_or_else(|| default_camera(&scene, up));
    Ok((ctx, scene, cam))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::LoadedMesh;

    /// A fan of long thin triangles costs the pixels it covers, not its triangles' bounding
    /// boxes: 200 000 triangles around a disk filling the view visit about the disk's
    /// pixels (2×2 supersampled), where bounding boxes would be ~10^10.
    #[test]
    fn a_fan_costs_its_pixels() {
        let n = 200_000usize;
        let mut positions = vec![0.0, 0.0, 0.0];
        for i in 0..n {
            let a = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
            positions.extend([a.cos(), a.sin(), 0.0]);
        }
        let indices: Vec<u32> = (0..n as u32)
            .flat_map(|i| [0, 1 + i, 1 + (i + 1) % n as u32])
            .collect();
        let nv = n + 1;
        let scene = LoadedScene {
            meshes: vec![LoadedMesh {
                name: "fan".into(),
                positions,
                indices,
                file_vertex: (0..nv as u32).collect(),
                id: Some(0),
                mesh: 0,
                diffuse: vec![vec![0.5; 3]; nv],
                emission: None,
            }],
            band_nm: vec![612.0, 549.0, 465.0],
            rgb: true,
            warnings: vec![],
            lights: vec![],
            grids: Vec::new(),
            observers: Vec::new(),
            format: "OBJ",
            triangles_read: n,
            material_variants: 0,
            two_sided: false,
        };
        let maps = vec![Some(MeshMap {
            e: vec![vec![1.0; nv]; 3],
            rel_error: vec![0.01; nv],
            lux: vec![300.0; nv],
            xyz: vec![[285.0, 300.0, 327.0]; nv],
            areas: vec![1.0; nv],
            lux_back: None,
        })];
        let cam = CameraSettings {
            position: [0.0, 0.0, 3.0],
            look_at: [0.0, 0.0, 0.0],
            up: Some([0.0, 1.0, 0.0]),
            fov_deg: 40.0,
            width: 640,
            height: 640,
            projection: None,
        };
        let attrs = view_attributes(&scene, &maps);
        let mut px = Vec::new();
        let drawn = rasterize_rows(&scene, &attrs, &cam, &mut |_, row| {
            px.extend_from_slice(row)
        })
        .unwrap();
        let visited = drawn.visited;
        // The disk: radius 1 at distance 3 with a 40° field: 1/(3 tan 20°) of the half
        // width, 0.916 × 640 = 586 supersampled pixels of radius.
        let r = 1.0 / (3.0 * 20f64.to_radians().tan()) * 640.0;
        let disk = std::f64::consts::PI * r * r;
        eprintln!("fan: {visited} pixels visited for a disk of {disk:.0}");
        assert!((visited as f64) < 1.1 * disk, "{visited} visited");
        assert!((visited as f64) > 0.9 * disk, "{visited} visited");
        // The centre pixel shows the recorded illuminance.
        assert_eq!(
            px[320 * 640 + 320],
            [300.0, px[320 * 640 + 320][1], 1.0, 1.0]
        );
        // In the view, 300 lx is 0.6 of a 0–500 lx scale; the background is dark grey.
        let img = render_view(&scene, &maps, &cam).unwrap();
        assert_eq!(img[(320 * 640 + 320) * 3..][..3], colour_map(0.6));
        assert_eq!(img[..3], [24, 24, 28]);
    }

    /// A mesh that records both sides shows, in the view, the side that faces the camera
    /// (the back's values seen from behind: `two_sided = true` drew the front everywhere).
    #[test]
    fn two_sided_meshes_show_the_side_facing_the_camera() {
        let scene = LoadedScene {
            meshes: vec![LoadedMesh {
                name: "card".into(),
                positions: vec![-1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 0.0, 1.0, 0.0],
                indices: vec![0, 1, 2],
                file_vertex: vec![0, 1, 2],
                id: Some(0),
                mesh: 0,
                diffuse: vec![vec![0.5; 3]; 3],
                emission: None,
            }],
            band_nm: vec![612.0, 549.0, 465.0],
            rgb: true,
            warnings: vec![],
            lights: vec![],
            grids: Vec::new(),
            observers: Vec::new(),
            format: "OBJ",
            triangles_read: 1,
            material_variants: 0,
            two_sided: true,
        };
        let maps = vec![Some(MeshMap {
            e: vec![vec![1.0; 3]; 3],
            rel_error: vec![0.01; 3],
            lux: vec![100.0; 3],
            xyz: vec![[95.0, 100.0, 109.0]; 3],
            areas: vec![1.0; 3],
            lux_back: Some(vec![300.0; 3]),
        })];
        let attrs = view_attributes(&scene, &maps);
        for (z, want) in [(3.0, 100.0), (-3.0, 300.0)] {
            let cam = CameraSettings {
                position: [0.0, 0.0, z],
                look_at: [0.0, 0.0, 0.0],
                up: Some([0.0, 1.0, 0.0]),
                fov_deg: 40.0,
                width: 32,
                height: 32,
                projection: None,
            };
            let mut px = Vec::new();
            rasterize_rows(&scene, &attrs, &cam, &mut |_, row| {
                px.extend_from_slice(row)
            })
            .unwrap();
            assert_eq!(px[16 * 32 + 16][0], want, "seen from z = {z}");
        }
    }

    #[test]
    fn the_lux_scale_ends_on_a_round_number() {
        assert_eq!(nice_ceiling(0.0), 1.0);
        assert_eq!(nice_ceiling(480.0), 500.0);
        assert_eq!(nice_ceiling(500.0), 500.0);
        assert_eq!(nice_ceiling(2100.0), 2500.0);
        assert_eq!(nice_ceiling(0.013), 0.02);
        assert_eq!(colour_map(0.0), [68, 1, 84]);
    }
}

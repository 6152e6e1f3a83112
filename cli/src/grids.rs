//! Calculation grids (`[[grid]]`): rectangles of points recorded as sensor meshes (they
//! change no light path), each written as a CSV table of points with lux and error, a
//! false-colour picture with isolux lines, and summarised (Eavg, Emin, Emax, U0, Ud with
//! their errors) in report.json and on the terminal.

use crate::error::{fail, CliError, Result};
use crate::raster::{colour_map, draw_legend_in, fmt_lux, nice_ceiling, write_png, LEGEND_MAX_PX};
use crate::settings::GridSettings;
use glam::DVec3;
use imap::{Context, MeshDesc};
use std::io::Write;
use std::path::Path;

/// Part labels of a grid's sensor: the triangles between its points, and the guard ring.
pub const POINTS_PART: u32 = 0;
const GUARD_PART: u32 = 1;

/// A grid as added: its points (cell centres, row-major along u then v) and sensor id.
pub struct Grid {
    pub name: String,
    pub id: u32,
    pub nu: usize,
    pub nv: usize,
    /// Spacing along u and v, scene units.
    pub step: [f64; 2],
    /// Guard vertices that stop at the model's surfaces (`add_grids`).
    pub clipped: usize,
    pub positions: Vec<f64>,
    pub settings: GridSettings,
    /// A point file's directions (then nu = the points, nv = 1, and each point is the
    /// centre of its own small sensor of five vertices).
    pub normals: Option<Vec<f64>>,
}

/// Most points a grid may have.
const MAX_POINTS: usize = 4_000_000;
/// Grids of up to this many points are checked for surfaces between their points.
const MAX_CHECKED_POINTS: usize = 250_000;

/// EN 12464-1's maximum grid spacing for a dimension of `d` metres: p = 0.2 · 5^log10(d),
/// at most 10 m.
pub fn en12464_spacing_m(d: f64) -> f64 {
    (0.2 * 5f64.powf(d.log10())).min(10.0)
}

fn finite3(v: [f64; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// A rectangle's origin, u, v and size.
type Rectangle = ([f64; 3], [f64; 3], [f64; 3], [f64; 2]);

impl GridSettings {
    /// The rectangle's origin, axes and size.
    fn rectangle(&self, what: &str) -> Result<Rectangle> {
        match (self.origin, self.u, self.v, self.size) {
            (Some(o), Some(u), Some(v), Some(s)) => Ok((o, u, v, s)),
            _ => fail!("{what}: a grid needs origin, u, v and size (a rectangle), or points (a sensor point file)"),
        }
    }

    /// The edge lengths, for the picture.
    pub fn extent(&self) -> [f64; 2] {
        self.size.unwrap_or([1.0, 1.0])
    }

    fn checked_axes(&self, what: &str) -> Result<(DVec3, DVec3)> {
        let (origin, u, v, size) = self.rectangle(what)?;
        if !(finite3(origin) && finite3(u) && finite3(v)) {
            fail!("{what}: origin, u and v must be finite");
        }
        let (Some(u), Some(v)) = (
            DVec3::from(u).try_normalize(),
            DVec3::from(v).try_normalize(),
        ) else {
            fail!("{what}: u and v must not be zero");
        };
        if u.dot(v).abs() > 1e-6 {
            fail!(
                "{what}: u and v must be perpendicular (their angle is {:.3}°)",
                u.dot(v).clamp(-1.0, 1.0).acos().to_degrees()
            );
        }
        if !size.iter().all(|s| s.is_finite() && *s > 0.0) {
            fail!("{what}: size = {size:?} must be two positive lengths");
        }
        Ok((u, v))
    }
}

/// Refuses an output name (a grid's, an observer's) that is empty or holds other than
/// letters, digits, space and - _ . (it names files and CSV rows).
pub fn check_name(what: &str, name: &str) -> Result<()> {
    if name.is_empty()
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_. ".contains(c))
    {
        fail!("{what}: a name may hold letters, digits, space and - _ . only (it names files)");
    }
    Ok(())
}

/// The grids' meshes: checked, laid out and added to `ctx` as one-sided sensors.
pub fn add_grids(
    ctx: &mut Context,
    grids: &[GridSettings],
    unit_m: f64,
    base_dir: &Path,
    label: &dyn Fn(usize, &str) -> String,
    model: &[[DVec3; 3]],
    diag: &mut crate::diag::Diagnostics,
) -> Result<Vec<Grid>> {
    let mut out: Vec<Grid> = Vec::new();
    for (k, g) in grids.iter().enumerate() {
        let name = g.name.clone().unwrap_or_else(|| format!("grid{}", k + 1));
        let what = label(k, &format!("grid '{name}'"));
        check_name(&what, &name)?;
        if out.iter().any(|o| o.name == name) {
            fail!("{what}: two grids have this name");
        }
        if let Some(file) = &g.points {
            if g.origin.is_some() || g.u.is_some() || g.v.is_some() || g.size.is_some() {
                fail!("{what}: give either points (a file) or origin, u, v and size, not both");
            }
            if g.side.is_some() || g.spacing.is_some() {
                fail!("{what}: a point file's directions say which light each point measures; side and spacing do not apply");
            }
            out.push(add_point_set(
                ctx,
                g,
                name,
                &what,
                &base_dir.join(file),
                unit_m,
                model,
            )?);
            continue;
        }
        if g.radius.is_some() {
            fail!("{what}: radius applies to a point file (points = \"...\")");
        }
        let (u, v) = g.checked_axes(&what)?;
        let (origin, _, _, size) = g.rectangle(&what)?;
        let back = match g.side.as_deref() {
            None | Some("front") => false,
            Some("back") => true,
            Some(s) => fail!("{what}: side = \"{s}\": use \"front\" or \"back\""),
        };
        let spacing = match g.spacing {
            Some(s) if s.is_finite() && s > 0.0 => s,
            Some(s) => fail!("{what}: spacing = {s} must be a positive length"),
            None => en12464_spacing_m(size[0].max(size[1]) * unit_m) / unit_m,
        };
        // EN 12464-1: the nearest whole number of d/p points per edge, at the cells' centres
        // (at least two, so that the points span a surface).
        // Counted in floating point: a size of 1e300 at a spacing of 1e-10 must not wrap
        // around to a small count.
        let n = |d: f64| (d / spacing).round().max(2.0);
        let (fu, fv) = (n(size[0]), n(size[1]));
        let points = fu * fv;
        if points.is_nan() || points > MAX_POINTS as f64 {
            fail!(
                "{what}: {fu:e} × {fv:e} points (size {size:?} at spacing {spacing:e}) are too many (at most {MAX_POINTS})"
            );
        }
        let (nu, nv) = (fu as usize, fv as usize);
        let step = [size[0] / nu as f64, size[1] / nv as f64];
        let o = DVec3::from(origin);
        let at = |i: f64, j: f64| o + u * ((i + 0.5) * step[0]) + v * ((j + 0.5) * step[1]);
        let mut positions = Vec::with_capacity(3 * nu * nv);
        for j in 0..nv {
            for i in 0..nu {
                positions.extend(at(i as f64, j as f64).to_array());
            }
        }
        // The sensor: the points, and a ring of guard vertices one spacing outside them, so
        // that every point's value is the light averaged symmetrically around it (a point
        // on the edge of a mesh would average only inwards: first-order biased). Triangles
        // between points are part POINTS, those touching the ring part GUARD.
        // The ring stops at the model's surfaces: an edge point beside a wall averages the
        // light on its own side of the wall only (a ring beyond an outside wall read the
        // daylight outside: 820–960 lx where the next points in read 150–215).
        let (mu, mv) = (nu + 2, nv + 2);
        let mut mesh_positions = Vec::with_capacity(3 * mu * mv);
        let mut ring = Vec::new();
        for j in 0..mv {
            for i in 0..mu {
                let p = at(i as f64 - 1.0, j as f64 - 1.0);
                if i == 0 || j == 0 || i == mu - 1 || j == mv - 1 {
                    // From the nearest point of the grid.
                    let (ci, cj) = (i.clamp(1, nu) - 1, j.clamp(1, nv) - 1);
                    ring.push((mesh_positions.len(), at(ci as f64, cj as f64), p));
                }
                mesh_positions.extend(p.to_array());
            }
        }
        let segments: Vec<(DVec3, DVec3)> = ring.iter().map(|r| (r.1, r.2)).collect();
        let mut clipped = 0;
        for ((at_index, _, _), end) in ring.iter().zip(stop_at_surfaces(&segments, model)) {
            if let Some(p) = end {
                mesh_positions[*at_index..*at_index + 3].copy_from_slice(&p.to_array());
                clipped += 1;
            }
        }
        // Neighbouring points parted by a surface: a grid through a wall reads both rooms.
        if nu * nv <= MAX_CHECKED_POINTS {
            let point = |i: usize, j: usize| DVec3::from_slice(&positions[3 * (j * nu + i)..]);
            let mut pairs = Vec::new();
            for j in 0..nv {
                for i in 0..nu {
                    if i + 1 < nu {
                        pairs.push((point(i, j), point(i + 1, j)));
                    }
                    if j + 1 < nv {
                        pairs.push((point(i, j), point(i, j + 1)));
                    }
                }
            }
            let hit = crate::segments::first_crossings(&pairs, model.iter().copied());
            let crossed: Vec<usize> = (0..pairs.len()).filter(|&k| hit[k] < 1.0).collect();
            if let Some(&k) = crossed.first() {
                let x = pairs[k].0 + (pairs[k].1 - pairs[k].0) * hit[k];
                diag.warn(format!(
                    "{what}: {} of its point-to-point spacings cross the model's surfaces (the first at [{:.3}, {:.3}, {:.3}]): its points there read light from both sides; keep a grid within one room",
                    crossed.len(),
                    x.x,
                    x.y,
                    x.z
                ));
            }
        }
        let mut indices = Vec::with_capacity(6 * (mu - 1) * (mv - 1));
        let mut parts = Vec::with_capacity(2 * (mu - 1) * (mv - 1));
        for j in 0..mv - 1 {
            for i in 0..mu - 1 {
                let a = (j * mu + i) as u32;
                let (b, c, d) = (a + 1, a + mu as u32 + 1, a + mu as u32);
                // Counter-clockwise seen from u × v: the front faces it.
                let tris = if back {
                    [a, c, b, a, d, c]
                } else {
                    [a, b, c, a, c, d]
                };
                indices.extend(tris);
                let inner = (1..nu).contains(&i) && (1..nv).contains(&j);
                let part = if inner { POINTS_PART } else { GUARD_PART };
                parts.extend([part, part]);
            }
        }
        let id = ctx
            .add_mesh(&MeshDesc {
                triangle_materials: Some(&parts),
                sensor: true,
                ..MeshDesc::new(&mesh_positions, &indices, POINTS_PART)
            })
            .map_err(|e| CliError(format!("{what}: {}", e.message)))?;
        out.push(Grid {
            name,
            id,
            nu,
            nv,
            step,
            positions,
            settings: g.clone(),
            clipped,
            normals: None,
        });
    }
    Ok(out)
}

/// Where each segment (from a point outward to a guard vertex) stops at the model's
/// surfaces: just short of the first it crosses, and never onto the point itself; None
/// when it crosses none.
fn stop_at_surfaces(segments: &[(DVec3, DVec3)], model: &[[DVec3; 3]]) -> Vec<Option<DVec3>> {
    let reach = segments.iter().fold(
        (DVec3::INFINITY, DVec3::NEG_INFINITY),
        |(lo, hi), (a, b)| (lo.min(a.min(*b)), hi.max(a.max(*b))),
    );
    let near = |t: &[DVec3; 3]| {
        let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
        !(lo.cmpgt(reach.1).any() || hi.cmplt(reach.0).any())
    };
    let first =
        crate::segments::first_crossings(segments, model.iter().filter(|t| near(t)).copied());
    segments
        .iter()
        .zip(first)
        .map(|((from, to), t)| (t < 1.0).then(|| *from + (*to - *from) * (t - 1e-6).max(0.01)))
        .collect()
}

/// Reads a sensor point file: `x y z dx dy dz` per line (more numbers are ignored, as
/// rtrace does; `#` starts a comment). Positions and directions, the directions unit.
fn read_points(path: &Path) -> Result<(Vec<DVec3>, Vec<DVec3>)> {
    let bytes = crate::diag::read_input(path).map_err(CliError)?;
    let shown = crate::diag::printable(&path.display().to_string());
    let (mut p, mut n) = (Vec::new(), Vec::new());
    for (line, text) in crate::diag::logical_lines(&bytes) {
        let words: Vec<&str> = text.split_whitespace().collect();
        if words.is_empty() {
            continue;
        }
        let nums: Vec<f64> = words
            .iter()
            .take(6)
            .map(|w| {
                w.parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite() && x.abs() <= crate::model::MAX_COORDINATE)
            })
            .collect::<Option<_>>()
            .unwrap_or_default();
        if nums.len() < 6 {
            fail!("{shown}:{line}: a sensor point needs six finite numbers, x y z dx dy dz");
        }
        let Some(d) = DVec3::new(nums[3], nums[4], nums[5]).try_normalize() else {
            fail!("{shown}:{line}: the point's direction dx dy dz is zero");
        };
        p.push(DVec3::new(nums[0], nums[1], nums[2]));
        n.push(d);
        if p.len() > MAX_POINTS {
            fail!("{shown}: more than {MAX_POINTS} points");
        }
    }
    if p.is_empty() {
        fail!("{shown}: no sensor points");
    }
    Ok((p, n))
}

/// A point file's sensor: each point the centre of a small square (corners at `radius`
/// along two axes of its plane) facing its direction, whose four corners stop short of the
/// model's surfaces as a grid's guard ring does; the centre vertex's value is the light
/// averaged symmetrically around the point.
fn add_point_set(
    ctx: &mut Context,
    g: &GridSettings,
    name: String,
    what: &str,
    path: &Path,
    unit_m: f64,
    model: &[[DVec3; 3]],
) -> Result<Grid> {
    let (points, dirs) = read_points(path).map_err(|e| CliError(format!("{what}: {}", e.0)))?;
    let radius: Vec<f64> = match g.radius {
        Some(r) if r.is_finite() && r > 0.0 => vec![r; points.len()],
        Some(r) => fail!("{what}: radius = {r} must be a positive length"),
        None => nearest_distances(&points)
            .into_iter()
            .map(|d| d.map_or(0.1 / unit_m, |d| d / 2.0).min(0.25 / unit_m))
            .collect(),
    };
    let mut positions = Vec::with_capacity(15 * points.len());
    let mut segments = Vec::with_capacity(4 * points.len());
    for ((p, d), r) in points.iter().zip(&dirs).zip(&radius) {
        if *r <= 0.0 {
            fail!(
                "{what}: two points are at the same place ({:.4}, {:.4}, {:.4}); give radius",
                p.x,
                p.y,
                p.z
            );
        }
        let (a, b) = d.any_orthonormal_pair();
        positions.extend(p.to_array());
        for c in [a, b, -a, -b] {
            let q = *p + c * *r;
            segments.push((*p, q));
            positions.extend(q.to_array());
        }
    }
    let mut clipped = 0;
    for (k, end) in stop_at_surfaces(&segments, model).into_iter().enumerate() {
        if let Some(q) = end {
            let at = 3 * (5 * (k / 4) + 1 + k % 4);
            positions[at..at + 3].copy_from_slice(&q.to_array());
            clipped += 1;
        }
    }
    let mut indices = Vec::with_capacity(12 * points.len());
    for k in 0..points.len() as u32 {
        let c = 5 * k;
        // a × b = d: counter-clockwise seen from the point's direction.
        for i in 0..4 {
            indices.extend([c, c + 1 + i, c + 1 + (i + 1) % 4]);
        }
    }
    let parts = vec![POINTS_PART; indices.len() / 3];
    let id = ctx
        .add_mesh(&MeshDesc {
            triangle_materials: Some(&parts),
            sensor: true,
            ..MeshDesc::new(&positions, &indices, POINTS_PART)
        })
        .map_err(|e| CliError(format!("{what}: {}", e.message)))?;
    let mean_r = radius.iter().sum::<f64>() / radius.len() as f64;
    Ok(Grid {
        name,
        id,
        nu: points.len(),
        nv: 1,
        step: [mean_r, mean_r],
        clipped,
        positions: points.iter().flat_map(|p| p.to_array()).collect(),
        settings: g.clone(),
        normals: Some(dirs.iter().flat_map(|d| d.to_array()).collect()),
    })
}

/// Each point's distance to its nearest other point (None for a lone point), by a grid of
/// cells (points of real files are spread evenly).
fn nearest_distances(points: &[DVec3]) -> Vec<Option<f64>> {
    let n = points.len();
    if n < 2 {
        return vec![None; n];
    }
    let (lo, hi) = points
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let ext = (hi - lo).max(DVec3::splat(1e-12));
    // About one point per cell.
    let cell = (ext.x * ext.y.max(ext.x * 1e-3) * ext.z.max(ext.x * 1e-3) / n as f64)
        .cbrt()
        .max(ext.max_element() / 1e4)
        .max(1e-12);
    let key = |p: &DVec3| ((*p - lo) / cell).floor().as_ivec3();
    let mut cells: std::collections::HashMap<glam::IVec3, Vec<usize>> = Default::default();
    for (i, p) in points.iter().enumerate() {
        cells.entry(key(p)).or_default().push(i);
    }
    points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let k = key(p);
            let mut best = f64::INFINITY;
            let mut ring: i32 = 0;
            // Grow the search until a neighbour is found and the next ring cannot be nearer.
            loop {
                for dz in -ring..=ring {
                    for dy in -ring..=ring {
                        for dx in -ring..=ring {
                            if dx.abs().max(dy.abs()).max(dz.abs()) != ring {
                                continue;
                            }
                            if let Some(v) = cells.get(&(k + glam::IVec3::new(dx, dy, dz))) {
                                for &j in v {
                                    if j != i {
                                        best = best.min(p.distance(points[j]));
                                    }
                                }
                            }
                        }
                    }
                }
                if best <= ring as f64 * cell || ring > 1000 {
                    break;
                }
                ring += 1;
            }
            best.is_finite().then_some(best)
        })
        .collect()
}

/// A grid's results after the run.
pub struct GridResult {
    pub lux: Vec<f64>,
    pub rel_error: Vec<f64>,
    pub stats: imap::RegionStats,
}

/// Each of the grid's points' positions and the direction its measuring side faces: a
/// point file's own, or the rectangle's u × v (its reverse for side = "back").
pub fn point_frames(g: &Grid) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let count = g.positions.len() / 3;
    let positions = (0..count)
        .map(|k| {
            [
                g.positions[3 * k],
                g.positions[3 * k + 1],
                g.positions[3 * k + 2],
            ]
        })
        .collect();
    let normals = match &g.normals {
        Some(n) => (0..count)
            .map(|k| [n[3 * k], n[3 * k + 1], n[3 * k + 2]])
            .collect(),
        None => {
            let (u, v) = (
                DVec3::from(g.settings.u.unwrap_or([1.0, 0.0, 0.0])),
                DVec3::from(g.settings.v.unwrap_or([0.0, 1.0, 0.0])),
            );
            let mut n = u.cross(v).normalize_or_zero();
            if g.settings.side.as_deref() == Some("back") {
                n = -n;
            }
            vec![n.to_array(); count]
        }
    };
    (positions, normals)
}

/// The sensor mesh's vertex of each of the grid's points.
pub fn point_vertices(g: &Grid) -> Vec<usize> {
    if g.normals.is_some() {
        return (0..g.nu).map(|k| 5 * k).collect();
    }
    let mu = g.nu + 2;
    (0..g.nv)
        .flat_map(|j| (0..g.nu).map(move |i| (j + 1) * mu + i + 1))
        .collect()
}

pub fn read(ctx: &Context, g: &Grid) -> Result<GridResult> {
    let points = point_vertices(g);
    let pick = |all: &[f64]| -> Vec<f64> { points.iter().map(|&k| all[k]).collect() };
    if g.normals.is_some() {
        let n = 5 * g.nu;
        let (mut all_lux, mut all_rel) = (vec![0.0; n], vec![0.0; n]);
        ctx.illuminance(g.id, 0, &mut all_lux)?;
        ctx.rel_error(g.id, 0, &mut all_rel)?;
        let (lux, rel_error) = (pick(&all_lux), pick(&all_rel));
        // The figures of the points themselves (the region's would count the squares'
        // corners): the arithmetic mean, as for a rectangle's points, and the extremes
        // with the same correction for noise. The mean's error treats the points as
        // independent: at the default radius their squares do not overlap, so no photon
        // lands on two (one photon's later bounces may still land on several).
        let sigma: Vec<f64> = lux.iter().zip(&rel_error).map(|(l, r)| l * r).collect();
        let mut stats = ctx.region_stats(g.id, 0, Some(POINTS_PART))?;
        let weights = imap::lit_weights(&lux, &vec![1.0; lux.len()]);
        stats.unlit_vertices = lux.len() - weights.iter().filter(|&&w| w > 0.0).count();
        stats.average = imap::Estimate {
            value: lux.iter().sum::<f64>() / lux.len() as f64,
            sigma: sigma.iter().map(|s| s * s).sum::<f64>().sqrt() / lux.len() as f64,
        };
        stats.extremes = imap::extremes(&lux, &sigma, &weights, stats.average);
        return Ok(GridResult {
            lux,
            rel_error,
            stats,
        });
    }
    let (mu, mv) = (g.nu + 2, g.nv + 2);
    let (mut all_lux, mut all_rel) = (vec![0.0; mu * mv], vec![0.0; mu * mv]);
    ctx.illuminance(g.id, 0, &mut all_lux)?;
    ctx.rel_error(g.id, 0, &mut all_rel)?;
    // The points: the sensor's vertices inside its guard ring.
    let (lux, rel_error) = (pick(&all_lux), pick(&all_rel));
    let stats = ctx.region_stats(g.id, 0, Some(POINTS_PART))?;
    Ok(GridResult {
        lux,
        rel_error,
        stats,
    })
}

fn est(e: imap::Estimate) -> serde_json::Value {
    serde_json::json!({"value": e.value, "sigma": e.sigma})
}

/// report.json's entry of a grid.
pub fn summary_json(g: &Grid, r: &GridResult, unit_m: f64) -> serde_json::Value {
    let s = &r.stats;
    let x = s.extremes.unwrap_or_default();
    let mut j = serde_json::json!({
        "name": g.name,
        "points": [g.nu, g.nv],
        "spacing_m": [g.step[0] * unit_m, g.step[1] * unit_m],
        "area_m2": s.area_m2,
        "csv": format!("grid_{}.csv", g.name),
        "picture": format!("grid_{}.png", g.name),
        "flux_lm": est(s.flux_lm),
        "average_lx": est(s.average),
        "min_lx": est(x.min),
        "max_lx": est(x.max),
        "min_observed_lx": x.min_observed,
        "max_observed_lx": x.max_observed,
        "u0": est(x.u0),
        "ud": est(x.ud),
        "max_point_rel_error": r.rel_error.iter().cloned().fold(0.0, f64::max),
        "guard_vertices_at_surfaces": g.clipped,
        "unlit_points": s.unlit_vertices,
    });
    if g.normals.is_some() {
        j["points"] = serde_json::json!(g.nu);
        j["file"] = serde_json::json!(g.settings.points);
        j["mean_radius_m"] = serde_json::json!(g.step[0] * unit_m);
        j["average_of"] = serde_json::json!("the points' values (arithmetic mean)");
        if let Some(o) = j.as_object_mut() {
            o.remove("spacing_m");
            o.remove("area_m2");
            o.remove("flux_lm");
        }
    }
    j
}

/// The terminal's line for a grid.
pub fn summary_line(g: &Grid, r: &GridResult) -> String {
    let s = &r.stats;
    let size = if g.normals.is_some() {
        format!("{} points", g.nu)
    } else {
        format!("{} × {} points", g.nu, g.nv)
    };
    if s.average.value.is_nan() || s.average.value <= 0.0 || s.extremes.is_none() {
        return format!("grid '{}' ({size}): no light reached it", g.name);
    }
    let x = s.extremes.unwrap_or_default();
    let unlit = if s.unlit_vertices > 0 {
        format!(
            "; {} point(s) received no light at all and are left out of Emin and U0",
            s.unlit_vertices
        )
    } else {
        String::new()
    };
    format!(
        "{}{unlit}",
        format_args!(
        "grid '{}' ({size}): Eavg {} ± {} lx, Emin {} ± {} lx, Emax {} ± {} lx, U0 {:.3} ± {:.3}, Ud {:.3} ± {:.3}",
        g.name,
        fmt_lux(s.average.value),
        fmt_lux(s.average.sigma),
        fmt_lux(x.min.value),
        fmt_lux(x.min.sigma),
        fmt_lux(x.max.value),
        fmt_lux(x.max.sigma),
        x.u0.value,
        x.u0.sigma,
        x.ud.value,
        x.ud.sigma
        )
    )
}

/// What a stop on the grids' average (`grid_error_measure = "average"`) leaves unsaid: the
/// relative errors Emin and U0 still have, when they are figures at all.
pub fn average_stop_note(r: &GridResult) -> Option<String> {
    let s = &r.stats;
    let x = s.extremes?;
    let rel = |e: imap::Estimate| {
        (e.value > 0.0 && e.sigma.is_finite()).then(|| 100.0 * e.sigma / e.value)
    };
    let (min, u0) = (rel(x.min)?, rel(x.u0)?);
    Some(format!(
        "the run stopped when Eavg reached its target error ({:.2} %); Emin is still at ± {min:.1} % and U0 at ± {u0:.1} % (grid_error_measure = \"uniformity\" stops on them)",
        100.0 * s.average.sigma / s.average.value
    ))
}

/// The points as a CSV table: indices along u and v, position (scene units), lux, its
/// standard error and relative error.
pub fn write_csv(path: &Path, g: &Grid, r: &GridResult) -> Result<()> {
    let io = |e: std::io::Error| CliError(format!("{}: {e}", path.display()));
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
    if let Some(n) = &g.normals {
        // A point file: its points in its order, with their directions.
        writeln!(f, "index,x,y,z,dx,dy,dz,lux,lux_sigma,rel_error").map_err(io)?;
        for k in 0..g.nu {
            let (p, d) = (&g.positions[3 * k..3 * k + 3], &n[3 * k..3 * k + 3]);
            writeln!(
                f,
                "{k},{},{},{},{},{},{},{},{},{}",
                p[0],
                p[1],
                p[2],
                d[0],
                d[1],
                d[2],
                r.lux[k],
                r.lux[k] * r.rel_error[k],
                r.rel_error[k]
            )
            .map_err(io)?;
        }
        return f.flush().map_err(io);
    }
    writeln!(f, "i,j,x,y,z,lux,lux_sigma,rel_error").map_err(io)?;
    for j in 0..g.nv {
        for i in 0..g.nu {
            let k = j * g.nu + i;
            let p = &g.positions[3 * k..3 * k + 3];
            writeln!(
                f,
                "{i},{j},{},{},{},{},{},{}",
                p[0],
                p[1],
                p[2],
                r.lux[k],
                r.lux[k] * r.rel_error[k],
                r.rel_error[k]
            )
            .map_err(io)?;
        }
    }
    f.flush().map_err(io)
}

/// The grid seen from its measured side: u to the right, v up, false colour by lux
/// (bilinear between the points), isolux lines at the legend's ticks and halfway between
/// them, and the colour bar in lux along the bottom.
pub fn write_picture(path: &Path, g: &Grid, r: &GridResult) -> Result<()> {
    write_values_picture(path, g, &r.lux, "lx", None)
}

/// `write_picture` of any per-point `values` in `unit`, the colour scale up to `top` (None:
/// a round number above the largest value).
pub fn write_values_picture(
    path: &Path,
    g: &Grid,
    values_at: &[f64],
    unit: &str,
    top: Option<f64>,
) -> Result<()> {
    if g.normals.is_some() {
        return write_point_picture(path, g, values_at, unit, top);
    }
    let [du, dv] = g.settings.extent();
    let long = 640.0;
    let scale = long / du.max(dv);
    let w = ((du * scale).round() as u32).max(160);
    let plot_h = ((dv * scale).round() as u32).max(100);
    // Room for the colour bar below the plot (its strip is at most LEGEND_MAX_PX high).
    let h = plot_h + LEGEND_MAX_PX;
    let top = top.unwrap_or_else(|| {
        nice_ceiling(
            values_at
                .iter()
                .cloned()
                .filter(|x| x.is_finite())
                .fold(0.0, f64::max),
        )
    });
    // The field at a point of the rectangle (s, t ∈ [0, 1]): bilinear between the cell
    // centres, held constant in the outer half cells.
    let field = |s: f64, t: f64| {
        let x = (s * g.nu as f64 - 0.5).clamp(0.0, (g.nu - 1) as f64);
        let y = (t * g.nv as f64 - 0.5).clamp(0.0, (g.nv - 1) as f64);
        let (i, j) = ((x as usize).min(g.nu - 2), (y as usize).min(g.nv - 2));
        let (fx, fy) = (x - i as f64, y - j as f64);
        let at = |i: usize, j: usize| values_at[j * g.nu + i];
        (at(i, j) * (1.0 - fx) + at(i + 1, j) * fx) * (1.0 - fy)
            + (at(i, j + 1) * (1.0 - fx) + at(i + 1, j + 1) * fx) * fy
    };
    let (wu, hu) = (w as usize, plot_h as usize);
    let mut values = vec![0.0; wu * hu];
    for py in 0..hu {
        for px in 0..wu {
            let s = (px as f64 + 0.5) / wu as f64;
            let t = 1.0 - (py as f64 + 0.5) / hu as f64; // v up
            values[py * wu + px] = field(s, t);
        }
    }
    let levels: Vec<f64> = (1..8).map(|k| top * k as f64 / 8.0).collect();
    let level_of = |x: f64| levels.iter().filter(|&&l| x >= l).count();
    let mut img: Vec<u8> = [24u8, 24, 28].repeat((w * h) as usize);
    for py in 0..hu {
        for px in 0..wu {
            let v = values[py * wu + px];
            let l = level_of(v);
            let edge = (px + 1 < wu && level_of(values[py * wu + px + 1]) != l)
                || (py + 1 < hu && level_of(values[(py + 1) * wu + px]) != l);
            let c = if edge {
                [250, 250, 250]
            } else {
                colour_map(v / top)
            };
            img[3 * (py * wu + px)..3 * (py * wu + px) + 3].copy_from_slice(&c);
        }
    }
    // The points as small dark dots.
    for j in 0..g.nv {
        for i in 0..g.nu {
            let px = (((i as f64 + 0.5) / g.nu as f64) * wu as f64) as usize;
            let py = ((1.0 - (j as f64 + 0.5) / g.nv as f64) * hu as f64) as usize;
            if px < wu && py < hu {
                img[3 * (py * wu + px)..3 * (py * wu + px) + 3].copy_from_slice(&[20, 20, 20]);
            }
        }
    }
    draw_legend_in(&mut img, w, h, top, unit);
    write_png(path, w, h, &img)
}

/// A point file's points seen along their mean direction (or from above their plane of
/// least spread), each a square coloured by its lux, with the colour bar.
fn write_point_picture(
    path: &Path,
    g: &Grid,
    values: &[f64],
    unit: &str,
    top: Option<f64>,
) -> Result<()> {
    let pts: Vec<DVec3> = (0..g.nu)
        .map(|k| DVec3::from_slice(&g.positions[3 * k..]))
        .collect();
    let normals = g.normals.as_deref().unwrap_or_default();
    let mean = (0..g.nu)
        .map(|k| DVec3::from_slice(&normals[3 * k..]))
        .sum::<DVec3>();
    let axis = mean.try_normalize().unwrap_or(DVec3::Z);
    let (a, b) = axis.any_orthonormal_pair();
    let uv: Vec<(f64, f64)> = pts.iter().map(|p| (p.dot(a), p.dot(b))).collect();
    let (mut lo, mut hi) = (
        (f64::INFINITY, f64::INFINITY),
        (f64::NEG_INFINITY, f64::NEG_INFINITY),
    );
    for &(u, v) in &uv {
        lo = (lo.0.min(u), lo.1.min(v));
        hi = (hi.0.max(u), hi.1.max(v));
    }
    let pad = g.step[0].max(1e-9);
    let (du, dv) = (hi.0 - lo.0 + 2.0 * pad, hi.1 - lo.1 + 2.0 * pad);
    let scale = 640.0 / du.max(dv);
    let w = ((du * scale).round() as u32).max(160);
    let plot_h = ((dv * scale).round() as u32).max(100);
    let h = plot_h + LEGEND_MAX_PX;
    let top = top.unwrap_or_else(|| {
        nice_ceiling(
            values
                .iter()
                .cloned()
                .filter(|x| x.is_finite())
                .fold(0.0, f64::max),
        )
    });
    let mut img: Vec<u8> = [24u8, 24, 28].repeat((w * h) as usize);
    let half = ((pad * scale * 0.7) as i64).clamp(1, 40);
    for (k, &(u, v)) in uv.iter().enumerate() {
        let cx = ((u - lo.0 + pad) * scale) as i64;
        let cy = plot_h as i64 - ((v - lo.1 + pad) * scale) as i64;
        let c = colour_map(values[k] / top);
        for y in (cy - half).max(0)..(cy + half).min(plot_h as i64) {
            for x in (cx - half).max(0)..(cx + half).min(w as i64) {
                let i = 3 * (y as usize * w as usize + x as usize);
                img[i..i + 3].copy_from_slice(&c);
            }
        }
    }
    draw_legend_in(&mut img, w, h, top, unit);
    write_png(path, w, h, &img)
}

#[cfg(test)]
mod tests {
    use super::en12464_spacing_m;

    #[test]
    fn spacing_follows_en12464() {
        // The standard's table: d = 1 m → 0.2 m, 5 m → 0.6 m, 10 m → 1 m, 50 m → 3 m,
        // 100 m → 5 m.
        for (d, p) in [
            (1.0, 0.2),
            (5.0, 0.6),
            (10.0, 1.0),
            (50.0, 3.0),
            (100.0, 5.0),
        ] {
            let got = en12464_spacing_m(d);
            assert!(
                (got - p).abs() < 0.03 * p,
                "d = {d} m: {got} m, not about {p} m"
            );
        }
    }
}

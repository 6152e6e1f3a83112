//! The maps as files: per-vertex irradiance, illuminance and error (CSV), the lit model
//! (PLY with vertex colours), and the photometric summary of the report.

use crate::error::Result;
use crate::raster::{create, io};
use crate::scene::LoadedScene;
use imap::Context;
use std::io::Write;
use std::path::Path;

/// Per-vertex results of one recorded mesh, front side.
pub struct MeshMap {
    /// Irradiance, W/m², per band: `e[band][vertex]`.
    pub e: Vec<Vec<f64>>,
    pub rel_error: Vec<f64>,
    /// Illuminance, lx, per vertex.
    pub lux: Vec<f64>,
    /// CIE 1931 X, Y, Z per vertex (Y = lux).
    pub xyz: Vec<[f64; 3]>,
    /// Each vertex's area (a third of each adjacent triangle's), m².
    pub areas: Vec<f64>,
    /// Illuminance of the back side, lx, when the meshes record both sides.
    pub lux_back: Option<Vec<f64>>,
}

/// Recorded meshes (one side) whose recorded side gets almost no light while the surface
/// absorbs light arriving on its other side: a mesh wound inside out, whose map reads
/// nearly zero without it being wrong by any other sign. One warning per mesh, with the
/// numbers: the flux on the recorded side, and the flux that reaches the surface (its
/// absorbed power over its absorptance).
pub fn back_lit(
    ctx: &Context,
    scene: &LoadedScene,
    maps: &[Option<MeshMap>],
    emitted_w: f64,
) -> Vec<String> {
    let mut out = Vec::new();
    if scene.two_sided {
        return out;
    }
    for (m, map) in scene.meshes.iter().zip(maps) {
        let (Some(id), Some(map)) = (m.id, map) else {
            continue;
        };
        let front: f64 = map
            .e
            .iter()
            .map(|band| band.iter().zip(&map.areas).map(|(e, a)| e * a).sum::<f64>())
            .sum();
        let Ok(absorbed) = ctx.absorbed_w(id) else {
            continue;
        };
        let nv = m.diffuse.len().max(1) as f64;
        let rho = m
            .diffuse
            .iter()
            .map(|d| d.iter().sum::<f64>() / d.len().max(1) as f64)
            .sum::<f64>()
            / nv;
        let reaching = absorbed / (1.0 - rho).max(0.05);
        if reaching > 1e-3 * emitted_w && front < 0.1 * reaching {
            out.push(format!(
                "object '{}': its recorded side receives {front:.4e} W, but {reaching:.4e} W reach the surface (it absorbs {absorbed:.4e} W): the light arrives on its back, so its map reads almost nothing. Its normals may point the wrong way: flip_normals = [\"{}\"] records the other side (two_sided = true records both)",
                m.name, m.name
            ));
        }
    }
    out
}

/// Reads the map of every recorded mesh.
pub fn read_maps(ctx: &Context, scene: &LoadedScene) -> Result<Vec<Option<MeshMap>>> {
    let nb = scene.band_nm.len();
    scene
        .meshes
        .iter()
        .map(|m| {
            let Some(id) = m.id else { return Ok(None) };
            let nv = m.positions.len() / 3;
            let mut e = vec![vec![0.0; nv]; nb];
            for (b, e) in e.iter_mut().enumerate() {
                ctx.irradiance(id, 0, b as u32, e)?;
            }
            let mut rel_error = vec![0.0; nv];
            ctx.rel_error(id, 0, &mut rel_error)?;
            let mut lux = vec![0.0; nv];
            ctx.illuminance(id, 0, &mut lux)?;
            let mut flat = vec![0.0; 3 * nv];
            ctx.tristimulus(id, 0, &mut flat)?;
            let xyz = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            let mut areas = vec![0.0; nv];
            ctx.vertex_areas(id, &mut areas)?;
            let lux_back = if scene.two_sided {
                let mut b = vec![0.0; nv];
                ctx.illuminance(id, 1, &mut b)?;
                Some(b)
            } else {
                None
            };
            Ok(Some(MeshMap {
                e,
                rel_error,
                lux,
                xyz,
                areas,
                lux_back,
            }))
        })
        .collect()
}

/// What report.json says in photometric terms.
pub struct PhotometricSummary {
    /// Per mesh: mean (area-weighted), minimum and maximum illuminance of a recorded mesh.
    pub meshes: Vec<serde_json::Value>,
    /// Chromaticity and CCT of the area-weighted mean light on the recorded surfaces.
    pub colour: serde_json::Value,
}

/// Area-weighted mean, minimum and maximum of a side's illuminance over the vertices that
/// have area.
fn lux_stats(lux: &[f64], areas: &[f64]) -> serde_json::Value {
    let a: f64 = areas.iter().sum();
    let mean = if a > 0.0 {
        lux.iter().zip(areas).map(|(l, w)| l * w).sum::<f64>() / a
    } else {
        0.0
    };
    let used = areas.iter().zip(lux).filter(|(w, _)| **w > 0.0);
    let min = used.clone().map(|(_, l)| *l).fold(f64::INFINITY, f64::min);
    let max = used.map(|(_, l)| *l).fold(0.0, f64::max);
    serde_json::json!({"mean": mean, "min": if min.is_finite() { min } else { 0.0 }, "max": max})
}

pub fn photometric_summary(maps: &[Option<MeshMap>]) -> PhotometricSummary {
    let mut total = [0.0; 3];
    let mut area_sum = 0.0;
    let meshes = maps
        .iter()
        .map(|map| {
            let Some(map) = map else {
                return serde_json::Value::Null;
            };
            let areas = map.areas.as_slice();
            let a: f64 = areas.iter().sum();
            for (x, w) in map.xyz.iter().zip(areas) {
                for k in 0..3 {
                    total[k] += x[k] * w;
                }
            }
            area_sum += a;
            let mut stats = lux_stats(&map.lux, areas);
            if let Some(back) = &map.lux_back {
                stats["back"] = lux_stats(back, areas);
            }
            stats
        })
        .collect();
    let colour = match imap::photometry::chromaticity(total) {
        Some(xy) => {
            let cct = imap::photometry::cct(total).filter(|c| c.1.abs() <= 0.05);
            serde_json::json!({
                "mean_lx": if area_sum > 0.0 { total[1] / area_sum } else { 0.0 },
                "x": xy[0], "y": xy[1],
                "cct_k": cct.map(|c| c.0), "duv": cct.map(|c| c.1)
            })
        }
        None => serde_json::Value::Null,
    };
    PhotometricSummary { meshes, colour }
}

/// The map as CSV: one row per recorded vertex, in the order of the file's `v`
/// statements (`vertex` is that 1-based index; a vertex two objects share has a row for
/// each), coordinates as the file wrote them.
pub fn write_csv(path: &Path, scene: &LoadedScene, maps: &[Option<MeshMap>]) -> Result<()> {
    let mut f = create(path)?;
    let err = io(path);
    let bands: Vec<String> = scene
        .band_nm
        .iter()
        .enumerate()
        .map(|(i, nm)| {
            if scene.rgb {
                format!("E_{}", ["r", "g", "b"][i])
            } else {
                format!("E_{nm}nm")
            }
        })
        .collect();
    let back = if scene.two_sided { ",lux_back" } else { "" };
    writeln!(
        f,
        "mesh,vertex,x,y,z,{},rel_error,lux{back}",
        bands.join(",")
    )
    .map_err(&err)?;
    let mut rows: Vec<(u32, usize, usize)> = Vec::new();
    for (mi, (m, map)) in scene.meshes.iter().zip(maps).enumerate() {
        if map.is_some() {
            rows.extend(m.file_vertex.iter().enumerate().map(|(v, &fv)| (fv, mi, v)));
        }
    }
    rows.sort_unstable();
    for (fv, mi, v) in rows {
        let (m, map) = (&scene.meshes[mi], maps[mi].as_ref().expect("recorded"));
        let p = &m.positions[3 * v..3 * v + 3];
        write!(
            f,
            "{},{},{},{},{}",
            csv_field(&m.name),
            fv + 1,
            p[0],
            p[1],
            p[2]
        )
        .map_err(&err)?;
        for e in &map.e {
            write!(f, ",{}", e[v]).map_err(&err)?;
        }
        write!(f, ",{},{}", map.rel_error[v], map.lux[v]).map_err(&err)?;
        if let Some(b) = &map.lux_back {
            write!(f, ",{}", b[v]).map_err(&err)?;
        }
        writeln!(f).map_err(&err)?;
    }
    f.flush().map_err(&err)
}

/// A CSV field, quoted when it holds a comma, a quote or a line break.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Band values → linear RGB: RGB runs as they are, spectral runs averaged over the
/// wavelength ranges the loader uses for RGB materials.
pub fn to_rgb(values: &[f64], band_nm: &[f64], rgb: bool) -> [f64; 3] {
    if rgb {
        return [values[0], values[1], values[2]];
    }
    let mut sum = [0.0; 3];
    let mut n = [0usize; 3];
    for (&v, &nm) in values.iter().zip(band_nm) {
        let c = crate::settings::channel(nm);
        sum[c] += v;
        n[c] += 1;
    }
    let mean: f64 = values.iter().sum::<f64>() / values.len() as f64;
    [0, 1, 2].map(|c| if n[c] > 0 { sum[c] / n[c] as f64 } else { mean })
}

/// A tone map from the scene's values: exposure puts the 97th percentile of luminance at
/// 0.8 on a 1.6·x/(1 + x) shoulder (white from 1.67× that percentile); sRGB encoding.
pub struct ToneMap {
    scale: f64,
}

impl ToneMap {
    pub fn new(luminances: impl Iterator<Item = f64>) -> Self {
        let mut l: Vec<f64> = luminances.filter(|x| *x > 0.0 && x.is_finite()).collect();
        if l.is_empty() {
            return ToneMap { scale: 1.0 };
        }
        l.sort_by(f64::total_cmp);
        let p = l[(l.len() as f64 * 0.97) as usize % l.len()];
        ToneMap { scale: 1.0 / p }
    }

    pub fn apply(&self, c: [f64; 3]) -> [u8; 3] {
        c.map(|x| {
            let x = (x * self.scale).max(0.0);
            let y = (1.6 * x / (1.0 + x)).min(1.0);
            let s = if y <= 0.0031308 {
                12.92 * y
            } else {
                1.055 * y.powf(1.0 / 2.4) - 0.055
            };
            (s * 255.0 + 0.5) as u8
        })
    }
}

pub(super) fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// The colour a vertex shows in the view and the PLY: what a viewer sees of a Lambertian
/// surface, ρ·E (per band), plus the exitance of emitting surfaces.
pub(super) fn vertex_colours(scene: &LoadedScene, maps: &[Option<MeshMap>]) -> Vec<Vec<[f64; 3]>> {
    scene
        .meshes
        .iter()
        .zip(maps)
        .map(|(m, map)| {
            let nv = m.positions.len() / 3;
            (0..nv)
                .map(|v| {
                    let nb = scene.band_nm.len();
                    let vals: Vec<f64> = (0..nb)
                        .map(|b| {
                            let e = map.as_ref().map_or(0.0, |mm| mm.e[b][v]);
                            let emit = m.emission.as_ref().map_or(0.0, |x| x[b]);
                            m.diffuse[v][b] * e + emit
                        })
                        .collect();
                    to_rgb(&vals, &scene.band_nm, scene.rgb)
                })
                .collect()
        })
        .collect()
}

pub fn write_ply(path: &Path, scene: &LoadedScene, maps: &[Option<MeshMap>]) -> Result<()> {
    let colours = vertex_colours(scene, maps);
    let tone = ToneMap::new(colours.iter().flatten().map(|&c| luminance(c)));
    let recorded: Vec<usize> = (0..scene.meshes.len())
        .filter(|&i| maps[i].is_some())
        .collect();
    let nv: usize = recorded
        .iter()
        .map(|&i| scene.meshes[i].positions.len() / 3)
        .sum();
    let nf: usize = recorded
        .iter()
        .map(|&i| scene.meshes[i].indices.len() / 3)
        .sum();
    let mut f = create(path)?;
    let err = io(path);
    write!(
        f,
        "ply\nformat ascii 1.0\ncomment libimap illumination map: irradiance = band-mean E in W/m2, illuminance in lx, colour = tone-mapped reflected light\nelement vertex {nv}\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty float irradiance\nproperty float rel_error\nproperty float illuminance\nelement face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    .map_err(&err)?;
    for &i in &recorded {
        let (m, map) = (&scene.meshes[i], maps[i].as_ref().unwrap());
        for (v, p) in m.positions.chunks_exact(3).enumerate() {
            let c = tone.apply(colours[i][v]);
            let mean = map.e.iter().map(|e| e[v]).sum::<f64>() / map.e.len() as f64;
            writeln!(
                f,
                "{} {} {} {} {} {} {} {} {}",
                p[0],
                p[1],
                p[2],
                c[0],
                c[1],
                c[2],
                mean as f32,
                map.rel_error[v] as f32,
                map.lux[v] as f32
            )
            .map_err(&err)?;
        }
    }
    let mut base = 0;
    for &i in &recorded {
        let m = &scene.meshes[i];
        for t in m.indices.chunks_exact(3) {
            writeln!(
                f,
                "3 {} {} {}",
                base + t[0] as usize,
                base + t[1] as usize,
                base + t[2] as usize
            )
            .map_err(&err)?;
        }
        base += m.positions.len() / 3;
    }
    f.flush().map_err(&err)
}

//! Outputs: per-vertex irradiance and error (CSV, PLY), the convergence plot and the
//! rendered view.

use crate::scene::{fail, CameraSettings, CliError, LoadedScene, Result};
use glam::DVec3;
use imap::{Context, Progress};
use std::io::Write;
use std::path::{Path, PathBuf};

/// A set of output files that appear together or not at all: each is written into a
/// fresh staging folder inside the output folder (`.imap-out-PID-N`), and `commit` then
/// (1) marks the staging folder complete, (2) removes the previous outputs of the same kind
/// (the manifest, `report.json` or `render.json`, first; then every file it listed), and
/// (3) renames the new files in, the manifest last. Whatever the moment of a kill, the
/// folder holds one run's files and never a mix of two: the manifest is there only when
/// its whole set is. A later command finishes a commit that a kill interrupted (the
/// complete staging folder of a process that is gone, when no manifest is there) and
/// removes every other staging folder and temporary file such a process left.
pub struct Outputs {
    dir: PathBuf,
    staging: PathBuf,
    manifest: String,
    files: Vec<String>,
    committed: bool,
}

/// The name of the marker that says a staging folder holds a whole set.
const COMPLETE: &str = ".complete";

/// Whether process `pid` is gone.
fn process_gone(pid: i32) -> bool {
    pid > 0 && !Path::new(&format!("/proc/{pid}")).exists()
}

/// The pid in a name `PREFIX<pid>-…` or `PREFIX<pid>.…`.
fn pid_in(name: &str, prefix: &str) -> Option<i32> {
    let rest = name.strip_prefix(prefix)?;
    let end = rest
        .find(|c: char| !c.is_ascii_digit())
        .unwrap_or(rest.len());
    rest[..end].parse().ok()
}

impl Outputs {
    /// Outputs into `dir`; `manifest` is the file written last (it lists the others under
    /// "outputs").
    pub fn new(dir: &Path, manifest: &str) -> Result<Self> {
        recover(dir);
        static N: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let staging = dir.join(format!(".imap-out-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&staging);
        std::fs::create_dir_all(&staging)
            .map_err(|e| CliError(format!("{}: {e}", staging.display())))?;
        Ok(Outputs {
            dir: dir.to_path_buf(),
            staging,
            manifest: manifest.to_string(),
            files: Vec::new(),
            committed: false,
        })
    }

    /// The path to write `name` to (in the staging folder, under its own name: writers
    /// that choose a format by extension keep working).
    pub fn temp(&mut self, name: &str) -> Result<PathBuf> {
        self.files.push(name.to_string());
        Ok(self.staging.join(name))
    }

    /// Puts the whole set in place (see the type's description).
    pub fn commit(mut self) -> Result<()> {
        fault("kill-before-commit");
        let io = |p: &Path, e: std::io::Error| CliError(format!("{}: {e}", p.display()));
        // The marker names the new set and the previous one, so that a commit cut short
        // can be finished by the next command whatever was done of it.
        let old = listed_outputs(&self.dir.join(&self.manifest));
        let marker = self.staging.join(COMPLETE);
        let plan = serde_json::json!({
            "manifest": self.manifest, "files": self.files, "old": old
        });
        std::fs::write(&marker, plan.to_string()).map_err(|e| io(&marker, e))?;
        install(&self.dir, &self.staging, &self.manifest, &self.files, &old)?;
        self.committed = true;
        let _ = std::fs::remove_dir_all(&self.staging);
        Ok(())
    }
}

impl Drop for Outputs {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

/// The outputs a manifest lists (plain names inside its folder only: a manifest is data
/// and names no other path); none when there is no readable manifest.
fn listed_outputs(manifest: &Path) -> Vec<String> {
    let mut old: Vec<String> = std::fs::read(manifest)
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .and_then(|v| {
            v.get("outputs")?.as_array().map(|a| {
                a.iter()
                    .filter_map(|x| x.as_str().map(str::to_string))
                    .collect()
            })
        })
        .unwrap_or_default();
    old.retain(|n| plain_name(n));
    old
}

fn plain_name(n: &str) -> bool {
    !n.is_empty() && !n.contains('/') && !n.contains('\\') && !n.starts_with('.')
}

/// Removes the previous set (the manifest first, then the files it listed and those the
/// new set replaces) and renames the files of `staging` into `dir`, the manifest last.
/// Finishing a commit that was cut short is the same walk: files already moved are not
/// in `staging` any more, and stay.
fn install(
    dir: &Path,
    staging: &Path,
    manifest: &str,
    files: &[String],
    old: &[String],
) -> Result<()> {
    let io = |p: &Path, e: std::io::Error| CliError(format!("{}: {e}", p.display()));
    let remove = |name: &str| match std::fs::remove_file(dir.join(name)) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(io(&dir.join(name), e)),
        _ => Ok(()),
    };
    // A file of the new set that has left staging is in place already, and stays.
    let replaced = |name: &String| !files.contains(name) || staging.join(name).exists();
    if staging.join(manifest).exists() {
        remove(manifest)?;
    }
    for name in old.iter().chain(files).filter(|n| *n != manifest) {
        if replaced(name) {
            remove(name)?;
        }
    }
    let last = files.iter().filter(|n| *n == manifest);
    for (k, name) in files
        .iter()
        .filter(|n| *n != manifest)
        .chain(last)
        .enumerate()
    {
        fault(&format!("kill-after-renames={k}"));
        let (from, to) = (staging.join(name), dir.join(name));
        if from.exists() {
            std::fs::rename(&from, &to).map_err(|e| io(&to, e))?;
        }
    }
    Ok(())
}

/// Cleans up after commands that were killed while writing into `dir`: finishes a commit
/// that was cut short (a complete staging folder), and removes staging folders and
/// temporary files of processes that are gone.
fn recover(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let path = e.path();
        if let Some(pid) = pid_in(&name, ".imap-out-") {
            if !process_gone(pid) {
                continue;
            }
            let plan = std::fs::read(path.join(COMPLETE))
                .ok()
                .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok());
            if let Some(plan) = plan {
                let list = |k: &str| -> Vec<String> {
                    plan[k]
                        .as_array()
                        .map(|a| {
                            a.iter()
                                .filter_map(|x| x.as_str())
                                .filter(|n| plain_name(n))
                                .map(str::to_string)
                                .collect()
                        })
                        .unwrap_or_default()
                };
                if let Some(m) = plan["manifest"].as_str().filter(|m| plain_name(m)) {
                    let _ = install(dir, &path, m, &list("files"), &list("old"));
                }
            }
            let _ = std::fs::remove_dir_all(&path);
        } else if name.starts_with('.') && name.contains(".tmp-") {
            // Temporary files of earlier versions (`.NAME.tmp-PID.EXT`).
            let pid = name.split(".tmp-").nth(1).and_then(|r| pid_in(r, ""));
            if pid.is_some_and(process_gone) {
                let _ = std::fs::remove_file(&path);
            }
        }
    }
}

/// Fault injection for the tests of interrupted outputs: the process kills itself
/// (SIGKILL, as a crash or the OOM killer would) at `point` when `IMAP_TEST_FAULT` names
/// it. Unset in normal use.
fn fault(point: &str) {
    static F: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    let f = F.get_or_init(|| std::env::var("IMAP_TEST_FAULT").unwrap_or_default());
    if !f.is_empty() && f.split(',').any(|x| x.trim() == point) {
        // SAFETY: sending a signal to this process.
        unsafe { libc::kill(libc::getpid(), libc::SIGKILL) };
    }
}

impl CameraSettings {
    /// The up vector: the camera's, or +y for a camera made without settings.
    pub fn up(&self) -> [f64; 3] {
        self.up.unwrap_or([0.0, 1.0, 0.0])
    }

    /// Checks the camera before any work is done.
    pub fn validate(&self) -> Result<()> {
        let (w, h) = (self.width as usize, self.height as usize);
        if w == 0 || h == 0 || w > 8192 || h > 8192 {
            fail!("camera: image size {w}×{h} is not in 1..=8192");
        }
        if !(self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            fail!("camera: fov_deg = {} is not in (0, 180)", self.fov_deg);
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

fn create(path: &Path) -> Result<std::io::BufWriter<std::fs::File>> {
    std::fs::File::create(path)
        .map(std::io::BufWriter::new)
        .map_err(|e| CliError(format!("{}: {e}", path.display())))
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> CliError + '_ {
    move |e| CliError(format!("{}: {e}", path.display()))
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
        let c = crate::scene::channel(nm);
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

fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// The colour a vertex shows in the view and the PLY: what a viewer sees of a Lambertian
/// surface, ρ·E (per band), plus the exitance of emitting surfaces.
fn vertex_colours(scene: &LoadedScene, maps: &[Option<MeshMap>]) -> Vec<Vec<[f64; 3]>> {
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

pub fn write_png(path: &Path, w: u32, h: u32, rgb: &[u8]) -> Result<()> {
    let f = create(path)?;
    let mut enc = png::Encoder::new(f, w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut wr = enc
        .write_header()
        .map_err(|e| CliError(format!("{}: {e}", path.display())))?;
    wr.write_image_data(rgb)
        .map_err(|e| CliError(format!("{}: {e}", path.display())))
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

/// The viridis colour map at t ∈ [0, 1] (piecewise linear through five of its colours).
pub(crate) fn colour_map(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 5] = [
        [68.0, 1.0, 84.0],
        [59.0, 82.0, 139.0],
        [33.0, 145.0, 140.0],
        [94.0, 201.0, 98.0],
        [253.0, 231.0, 37.0],
    ];
    let x = t.clamp(0.0, 1.0) * 4.0;
    let i = (x as usize).min(3);
    let f = x - i as f64;
    [0, 1, 2].map(|k| (STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f).round() as u8)
}

/// The smallest of 1, 2, 2.5, 5 × 10^k at or above `x`.
pub(crate) fn nice_ceiling(x: f64) -> f64 {
    if !(x > 0.0 && x.is_finite()) {
        return 1.0;
    }
    let p = 10f64.powf(x.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|&v| v >= x * (1.0 - 1e-12))
        .unwrap_or(10.0 * p)
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

/// The tallest the legend's strip gets, pixels.
pub(crate) const LEGEND_MAX_PX: u32 = 24 + 3 * 12 + 22;

/// The colour scale 0 … `top` lx along the bottom of the image (labels when a font is
/// found).
pub(crate) fn draw_legend(img: &mut [u8], w: u32, h: u32, top: f64) {
    use plotters::prelude::*;
    let bar_h = (h / 40).clamp(6, 24);
    let pad = (h / 60).clamp(3, 12);
    let label_h = (h / 28).clamp(9, 22);
    let strip = bar_h + 3 * pad + label_h;
    if h < 2 * strip || w < 60 {
        return; // too small for a legend
    }
    let font = register_font();
    let mut draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::with_buffer(img, (w, h)).into_drawing_area();
        let y0 = (h - strip) as i32;
        root.draw(&Rectangle::new(
            [(0, y0), (w as i32, h as i32)],
            RGBColor(24, 24, 28).filled(),
        ))?;
        let (x0, x1) = ((w / 20) as i32, (w - w / 20) as i32);
        let by = y0 + pad as i32;
        for x in x0..x1 {
            let c = colour_map((x - x0) as f64 / (x1 - x0 - 1).max(1) as f64);
            root.draw(&Rectangle::new(
                [(x, by), (x + 1, by + bar_h as i32)],
                RGBColor(c[0], c[1], c[2]).filled(),
            ))?;
        }
        if font {
            let style = ("sans-serif", label_h as f64)
                .into_font()
                .color(&RGBColor(230, 230, 230));
            use plotters::style::text_anchor::{HPos, Pos, VPos};
            for k in 0..=4 {
                let x = x0 + (x1 - x0) * k / 4;
                let v = top * k as f64 / 4.0;
                let (text, h) = match k {
                    0 => (fmt_lux(v), HPos::Left),
                    4 => (format!("{} lx", fmt_lux(v)), HPos::Right),
                    _ => (fmt_lux(v), HPos::Center),
                };
                root.draw(&Text::new(
                    text,
                    (x, by + (bar_h + pad) as i32),
                    style.clone().pos(Pos::new(h, VPos::Top)),
                ))?;
            }
        }
        root.present()?;
        Ok(())
    };
    // The legend is a courtesy: a drawing failure leaves the view without it.
    let _ = draw();
}

pub(crate) fn fmt_lux(v: f64) -> String {
    if v == 0.0 || v >= 10.0 {
        format!("{v:.0}")
    } else if v >= 1.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
    }
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

/// convergence.png: the estimated global error against run time, log–log, with the
/// t^-1/2 reference through the last point.
pub fn plot_convergence(path: &Path, history: &[Progress]) -> Result<()> {
    use plotters::prelude::*;
    // Points a plot can show: from a microsecond to 30 000 years (a state file may hold
    // any finite number; a log axis over 300 decades is no plot).
    let pts: Vec<(f64, f64)> = history
        .iter()
        .filter(|p| (1e-6..=1e12).contains(&p.elapsed_s))
        // 1 exactly is the library's "no data yet"; errors above 100 % are estimates too.
        .filter(|p| (1e-12..1e6).contains(&p.rel_error) && p.rel_error != 1.0)
        .map(|p| (p.elapsed_s, p.rel_error))
        .collect();
    let font = register_font();
    if pts.is_empty() {
        // Nothing to plot (no recorded surface got light yet): a plot that says so, rather
        // than failing a run that may be right (a recorded side facing away from the light).
        let draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
            let root = BitMapBackend::new(path, (800, 560)).into_drawing_area();
            root.fill(&WHITE)?;
            if font {
                root.draw(&Text::new(
                    "no error estimate yet: no recorded surface received light",
                    (120, 270),
                    ("sans-serif", 22),
                ))?;
            }
            root.present()?;
            Ok(())
        };
        return draw().map_err(|e| CliError(format!("{}: {e}", path.display())));
    }
    let (t0, t1) = (pts[0].0 * 0.8, pts.last().unwrap().0 * 1.25);
    let emin = pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min) * 0.7;
    let emax = pts.iter().map(|p| p.1).fold(0.0, f64::max) * 1.4;
    let draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::new(path, (800, 560)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut builder = ChartBuilder::on(&root);
        builder.margin(20);
        if font {
            builder
                .caption(
                    "estimated global error against run time",
                    ("sans-serif", 22),
                )
                .x_label_area_size(45)
                .y_label_area_size(70);
        }
        let mut chart =
            builder.build_cartesian_2d((t0..t1).log_scale(), (emin..emax).log_scale())?;
        let mut mesh = chart.configure_mesh();
        if font {
            mesh.x_desc("run time (s)")
                .y_desc("relative error")
                .y_label_formatter(&|y| format!("{:.1}%", y * 100.0));
        } else {
            mesh.disable_x_mesh().disable_y_mesh();
        }
        mesh.draw()?;
        let (tl, el) = *pts.last().unwrap();
        let reference = [t0, t1].map(|t| (t, el * (tl / t).sqrt()));
        let s = chart.draw_series(LineSeries::new(
            reference,
            ShapeStyle::from(&RGBColor(150, 150, 150)).stroke_width(2),
        ))?;
        if font {
            s.label("t^-1/2 reference")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RGBColor(150, 150, 150)));
        }
        let s = chart.draw_series(LineSeries::new(
            pts.iter().copied(),
            ShapeStyle::from(&BLUE).stroke_width(2),
        ))?;
        if font {
            s.label("estimated error")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLUE));
        }
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, BLUE.filled())))?;
        if font {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()?;
        }
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| CliError(format!("{}: {e}", path.display())))
}

/// Registers a system sans-serif font with plotters (DejaVu on Debian); false when none
/// is found, and the plot goes without text.
fn register_font() -> bool {
    use std::sync::OnceLock;
    static DONE: OnceLock<bool> = OnceLock::new();
    *DONE.get_or_init(|| {
        for p in [
            "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
        ] {
            if let Ok(bytes) = std::fs::read(p) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font(
                    "sans-serif",
                    plotters::style::FontStyle::Normal,
                    bytes,
                )
                .is_ok()
                {
                    return true;
                }
            }
        }
        false
    })
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
                diffuse: vec![vec![0.5; 3]; nv],
                emission: None,
            }],
            band_nm: vec![612.0, 549.0, 465.0],
            rgb: true,
            warnings: vec![],
            lights: vec![],
            grids: Vec::new(),
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
                diffuse: vec![vec![0.5; 3]; 3],
                emission: None,
            }],
            band_nm: vec![612.0, 549.0, 465.0],
            rgb: true,
            warnings: vec![],
            lights: vec![],
            grids: Vec::new(),
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

//! Scenes in: OBJ + MTL through `tobj`, and the TOML settings file.
//!
//! MTL mapping: `Kd` → Lambertian reflectance, `Ks` → specular reflectance, `Ni` with
//! `d` < 1 or a `Tf` → dielectric (index `Ni`; `Tf` is the internal transmittance of 1 m of
//! the material), `Ke` → self-emitting surface with exitance `Ke` W/m² per band. RGB values
//! become spectra for spectral runs by band: below 490 nm the blue value, 490–580 nm green,
//! above red. The TOML file can override any material with spectra of its own.

use imap::{Bands, Config, Context, IorModel, MaterialDesc, MeshDesc, SchedulerKind};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

/// A one-line error for the user: what, and where when a file is to blame.
#[derive(Debug)]
pub struct CliError(pub String);

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl From<imap::Error> for CliError {
    fn from(e: imap::Error) -> Self {
        CliError(format!("libimap: {}", e.message))
    }
}

pub type Result<T> = std::result::Result<T, CliError>;

macro_rules! fail {
    ($($arg:tt)*) => { return Err(CliError(format!($($arg)*))) };
}
pub(crate) use fail;

/// A per-band value in TOML: one number (grey) or a list (one per band).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(untagged)]
pub enum Spectrum {
    Grey(f64),
    Bands(Vec<f64>),
}

impl Spectrum {
    fn values(&self) -> Vec<f64> {
        match self {
            Spectrum::Grey(x) => vec![*x],
            Spectrum::Bands(v) => v.clone(),
        }
    }
}

#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SpectralSettings {
    pub bands: u32,
    #[serde(default = "default_min_nm")]
    pub min_nm: f64,
    #[serde(default = "default_max_nm")]
    pub max_nm: f64,
}

fn default_min_nm() -> f64 {
    380.0
}
fn default_max_nm() -> f64 {
    780.0
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RunSettings {
    /// Photons to trace; 0 = no limit.
    #[serde(default)]
    pub photons: u64,
    /// Seconds; 0 = no limit.
    #[serde(default)]
    pub time_s: f64,
    /// Target global relative error; 0 = none.
    #[serde(default)]
    pub target_error: f64,
    #[serde(default)]
    pub threads: usize,
    #[serde(default = "default_scheduler")]
    pub scheduler: String,
    #[serde(default)]
    pub seed: u64,
    #[serde(default = "default_interval")]
    pub progress_interval_s: f64,
}

fn default_scheduler() -> String {
    "dynamic".into()
}
fn default_interval() -> f64 {
    0.25
}

impl Default for RunSettings {
    fn default() -> Self {
        RunSettings {
            photons: 0,
            time_s: 60.0,
            target_error: 0.02,
            threads: 0,
            scheduler: default_scheduler(),
            seed: 0,
            progress_interval_s: default_interval(),
        }
    }
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LightSettings {
    /// "point" or "spot".
    pub kind: String,
    pub position: [f64; 3],
    #[serde(default)]
    pub direction: Option<[f64; 3]>,
    #[serde(default)]
    pub half_angle_deg: Option<f64>,
    /// W per band.
    pub power: Spectrum,
}

#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSettings {
    pub diffuse: Option<Spectrum>,
    pub specular: Option<Spectrum>,
    pub transmit: Option<Spectrum>,
    pub ior: Option<f64>,
    /// Sellmeier coefficients (λ in µm): b and c, three each.
    pub sellmeier: Option<[[f64; 3]; 2]>,
    pub absorption_per_m: Option<Spectrum>,
    /// Exitance, W/m² per band.
    pub emission: Option<Spectrum>,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSettings {
    pub position: [f64; 3],
    pub look_at: [f64; 3],
    #[serde(default = "default_up")]
    pub up: [f64; 3],
    #[serde(default = "default_fov")]
    pub fov_deg: f64,
    #[serde(default = "default_size")]
    pub width: u32,
    #[serde(default = "default_size")]
    pub height: u32,
}

fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f64 {
    40.0
}
fn default_size() -> u32 {
    640
}

/// The TOML settings file.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    /// Metres per scene unit.
    #[serde(default)]
    pub unit_m: Option<f64>,
    #[serde(default)]
    pub spectral: Option<SpectralSettings>,
    #[serde(default)]
    pub run: RunSettings,
    #[serde(default, rename = "light")]
    pub lights: Vec<LightSettings>,
    /// Overrides by MTL material name.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialSettings>,
    /// OBJ object/group names whose irradiance is recorded; empty = all.
    #[serde(default)]
    pub record: Vec<String>,
    /// Record both sides of every mesh (default: the side the normals face).
    #[serde(default)]
    pub two_sided: bool,
    #[serde(default)]
    pub camera: Option<CameraSettings>,
}

impl Settings {
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| CliError(format!("{}: {e}", path.display())))?;
        toml::from_str(&text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start].matches('\n').count() + 1)
                .unwrap_or(0);
            let msg = e.message().replace('\n', " ");
            CliError(format!("{}:{line}: {msg}", path.display()))
        })
    }

    pub fn bands(&self) -> Result<Bands> {
        Ok(match &self.spectral {
            None => Bands::rgb(),
            Some(s) => Bands::spectral(s.bands, s.min_nm, s.max_nm)?,
        })
    }

    pub fn scheduler(&self) -> Result<SchedulerKind> {
        match self.run.scheduler.as_str() {
            "dynamic" => Ok(SchedulerKind::Dynamic),
            "classic" => Ok(SchedulerKind::Classic),
            s => fail!("run.scheduler = \"{s}\": use \"dynamic\" or \"classic\""),
        }
    }
}

/// One mesh as loaded, kept for the outputs.
pub struct LoadedMesh {
    pub name: String,
    pub positions: Vec<f64>,
    pub indices: Vec<u32>,
    /// libimap's mesh id when recorded.
    pub id: Option<u32>,
    /// Diffuse reflectance per band (for the rendered view) and exitance if emitting.
    pub diffuse: Vec<f64>,
    pub emission: Option<Vec<f64>>,
}

/// The scene handed to libimap, and what the outputs need of it.
pub struct LoadedScene {
    pub meshes: Vec<LoadedMesh>,
    pub band_nm: Vec<f64>,
    pub rgb: bool,
}

impl LoadedScene {
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for m in &self.meshes {
            for p in m.positions.chunks_exact(3) {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        (lo, hi)
    }
}

/// Checks the OBJ's statements that tobj would reject or silently accept (non-finite
/// numbers, bad indices, unknown materials) and names the line.
fn check_obj(path: &Path, text: &str, known_materials: Option<&[String]>) -> Result<()> {
    let mut vertices = 0i64;
    for (i, line) in text.lines().enumerate() {
        let at = || format!("{}:{}", path.display(), i + 1);
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        let rest: Vec<&str> = words.collect();
        let numbers = |n_min: usize| -> Result<()> {
            if rest.len() < n_min {
                fail!("{}: '{key}' needs {n_min} numbers: {line}", at());
            }
            for w in &rest {
                match w.parse::<f64>() {
                    Ok(x) if x.is_finite() => {}
                    _ => fail!("{}: '{w}' is not a finite number", at()),
                }
            }
            Ok(())
        };
        match key {
            "v" => {
                numbers(3)?;
                vertices += 1;
            }
            "vn" => numbers(3)?,
            "vt" => numbers(1)?,
            "f" => {
                if rest.len() < 3 {
                    fail!("{}: a face needs at least 3 vertices: {line}", at());
                }
                for w in &rest {
                    let v = w.split('/').next().unwrap_or("");
                    let idx: i64 = v
                        .parse()
                        .map_err(|_| CliError(format!("{}: '{w}' is not a vertex index", at())))?;
                    let resolved = if idx < 0 { vertices + 1 + idx } else { idx };
                    if resolved < 1 || resolved > vertices {
                        fail!(
                            "{}: vertex index {idx} is out of range (1..={vertices} so far)",
                            at()
                        );
                    }
                }
            }
            "usemtl" => {
                let name = rest.join(" ");
                if let Some(known) = known_materials {
                    if !known.contains(&name) {
                        fail!("{}: unknown material '{name}'", at());
                    }
                } else {
                    fail!("{}: material '{name}' used but no mtllib was given", at());
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Checks an MTL file's numeric statements.
fn check_mtl(path: &Path, text: &str) -> Result<Vec<String>> {
    let mut names = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        let rest: Vec<&str> = words.collect();
        match key {
            "newmtl" => names.push(rest.join(" ")),
            "Kd" | "Ks" | "Ke" | "Tf" | "Ka" | "Ni" | "d" | "Ns" | "Tr" | "illum" => {
                for w in &rest {
                    match w.parse::<f64>() {
                        Ok(x) if x.is_finite() => {}
                        _ => fail!(
                            "{}:{}: '{w}' in '{key}' is not a finite number",
                            path.display(),
                            i + 1
                        ),
                    }
                }
            }
            _ => {}
        }
    }
    Ok(names)
}

/// The RGB channel (0 red, 1 green, 2 blue) that stands for a wavelength: below 490 nm
/// blue, 490–580 nm green, above red.
pub fn channel(nm: f64) -> usize {
    if nm < 490.0 {
        2
    } else if nm < 580.0 {
        1
    } else {
        0
    }
}

/// RGB → per-band values (the band's colour channel by wavelength).
fn expand_rgb(rgb: [f64; 3], band_nm: &[f64], is_rgb: bool) -> Vec<f64> {
    if is_rgb {
        return rgb.to_vec();
    }
    band_nm.iter().map(|&nm| rgb[channel(nm)]).collect()
}

fn per_band(s: &Spectrum, nb: usize, what: &str) -> Result<Vec<f64>> {
    let v = s.values();
    match v.len() {
        1 => Ok(vec![v[0]; nb]),
        n if n == nb => Ok(v),
        n => fail!("{what} has {n} values; give 1 or {nb} (one per band)"),
    }
}

/// Builds the libimap context from an OBJ file and settings.
pub fn load(obj: &Path, settings: &Settings) -> Result<(Context, LoadedScene)> {
    let text =
        std::fs::read_to_string(obj).map_err(|e| CliError(format!("{}: {e}", obj.display())))?;
    // The MTL libraries the OBJ names, checked first so usemtl lines can be checked.
    let dir = obj.parent().unwrap_or(Path::new("."));
    let mut mtl_names: Option<Vec<String>> = None;
    for (i, line) in text.lines().enumerate() {
        if let Some(rest) = line.trim().strip_prefix("mtllib") {
            for file in rest.split_whitespace() {
                let p: PathBuf = dir.join(file);
                let mtext = std::fs::read_to_string(&p).map_err(|e| {
                    CliError(format!(
                        "{}:{}: material library {}: {e}",
                        obj.display(),
                        i + 1,
                        p.display()
                    ))
                })?;
                mtl_names
                    .get_or_insert_with(Vec::new)
                    .extend(check_mtl(&p, &mtext)?);
            }
        }
    }
    check_obj(obj, &text, mtl_names.as_deref())?;
    let (models, materials) = tobj::load_obj(
        obj,
        &tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ignore_points: true,
            ignore_lines: true,
        },
    )
    .map_err(|e| CliError(format!("{}: {e}", obj.display())))?;
    let materials = materials.map_err(|e| CliError(format!("{}: MTL: {e}", obj.display())))?;
    for name in settings.materials.keys() {
        if !materials.iter().any(|m| &m.name == name) {
            fail!(
                "settings: [materials.{name}] names no material of {}",
                obj.display()
            );
        }
    }

    let bands = settings.bands()?;
    let band_nm = bands.wavelengths_nm.clone();
    let rgb = bands.rgb;
    let nb = band_nm.len();
    let mut ctx = Context::new(Config {
        bands,
        threads: settings.run.threads,
        seed: settings.run.seed,
        scheduler: settings.scheduler()?,
        unit_m: settings.unit_m.unwrap_or(1.0),
        ..Default::default()
    })?;

    // Materials: MTL first, then the settings' overrides.
    struct Mat {
        id: u32,
        diffuse: Vec<f64>,
        emission: Option<Vec<f64>>,
    }
    let mut mats = Vec::new();
    for m in &materials {
        let get = |v: Option<[f32; 3]>| v.map(|c| c.map(|x| x as f64));
        let ke = get(m.emissive).filter(|k| k.iter().any(|&x| x > 0.0));
        let tf = m.unknown_param.get("Tf").map(|s| {
            let v: Vec<f64> = s
                .split_whitespace()
                .filter_map(|w| w.parse().ok())
                .collect();
            if v.len() >= 3 {
                [v[0], v[1], v[2]]
            } else {
                [v.first().copied().unwrap_or(1.0); 3]
            }
        });
        let dissolve = m.dissolve.map_or(1.0, |d| d as f64);
        let dielectric = m.optical_density.is_some() && (dissolve < 1.0 || tf.is_some());
        let o = settings.materials.get(&m.name).cloned().unwrap_or_default();
        let what = |k: &str| format!("material '{}' {k}", m.name);
        let diffuse = match &o.diffuse {
            Some(s) => per_band(s, nb, &what("diffuse"))?,
            None if dielectric => vec![0.0; nb],
            None => expand_rgb(get(m.diffuse).unwrap_or([0.0; 3]), &band_nm, rgb),
        };
        let specular = match &o.specular {
            Some(s) => per_band(s, nb, &what("specular"))?,
            None if dielectric => vec![0.0; nb],
            None => expand_rgb(get(m.specular).unwrap_or([0.0; 3]), &band_nm, rgb),
        };
        let transmit = match &o.transmit {
            Some(s) => per_band(s, nb, &what("transmit"))?,
            None => vec![0.0; nb],
        };
        let ior = if let Some([b, c]) = o.sellmeier {
            Some(IorModel::Sellmeier { b, c })
        } else if let Some(n) = o.ior {
            Some(IorModel::Constant(n))
        } else if dielectric {
            Some(IorModel::Constant(m.optical_density.unwrap() as f64))
        } else {
            None
        };
        let absorption = match (&o.absorption_per_m, tf) {
            (Some(s), _) => per_band(s, nb, &what("absorption_per_m"))?,
            (None, Some(t)) if ior.is_some() => {
                expand_rgb(t.map(|x| -(x.max(1e-12)).ln()), &band_nm, rgb)
            }
            _ => vec![],
        };
        let emission = match (&o.emission, ke) {
            (Some(s), _) => Some(per_band(s, nb, &what("emission"))?),
            (None, Some(k)) => Some(expand_rgb(k, &band_nm, rgb)),
            _ => None,
        };
        // Energy: an opaque surface cannot reflect more than it receives.
        let sum: Vec<f64> = (0..nb)
            .map(|b| diffuse[b] + specular[b] + transmit[b])
            .collect();
        if ior.is_none() {
            if let Some(b) = sum.iter().position(|&s| s > 1.0 + 1e-9) {
                fail!(
                    "material '{}': Kd + Ks (+ transmit) = {} > 1 in band {b}",
                    m.name,
                    sum[b]
                );
            }
        }
        let id = ctx
            .add_material(&MaterialDesc {
                diffuse_reflect: diffuse.clone(),
                specular_reflect: specular,
                diffuse_transmit: transmit,
                ior,
                absorption_per_m: absorption,
            })
            .map_err(|e| CliError(format!("material '{}': {}", m.name, e.message)))?;
        mats.push(Mat {
            id,
            diffuse,
            emission,
        });
    }
    // Meshes without a material: grey 0.5.
    let default_mat = ctx.add_material(&MaterialDesc {
        diffuse_reflect: vec![0.5],
        ..Default::default()
    })?;

    let mut meshes = Vec::new();
    for model in &models {
        let m = &model.mesh;
        if m.indices.is_empty() {
            continue;
        }
        let positions: Vec<f64> = m.positions.iter().map(|&x| x as f64).collect();
        let (mat_id, diffuse, emission) = match m.material_id.and_then(|i| mats.get(i)) {
            Some(mt) => (mt.id, mt.diffuse.clone(), mt.emission.clone()),
            None => (default_mat, vec![0.5; nb], None),
        };
        let record = settings.record.is_empty() || settings.record.contains(&model.name);
        let desc = MeshDesc {
            positions: &positions,
            indices: &m.indices,
            material: mat_id,
            triangle_materials: None,
            two_sided: settings.two_sided,
            record,
            exitance: emission.as_deref(),
        };
        let id = ctx.add_mesh(&desc).map_err(|e| {
            CliError(format!(
                "{}: object '{}': {}",
                obj.display(),
                model.name,
                e.message
            ))
        })?;
        meshes.push(LoadedMesh {
            name: model.name.clone(),
            indices: m.indices.clone(),
            positions,
            id: record.then_some(id),
            diffuse,
            emission,
        });
    }
    if meshes.is_empty() {
        fail!("{}: no triangles", obj.display());
    }
    for n in &settings.record {
        if !models.iter().any(|m| &m.name == n) {
            fail!(
                "settings: record names '{n}', which is no object or group of {}",
                obj.display()
            );
        }
    }
    for (i, l) in settings.lights.iter().enumerate() {
        let what = format!("settings: light {}", i + 1);
        let power = l.power.values();
        match l.kind.as_str() {
            "point" => ctx.add_point_light(l.position, &power),
            "spot" => {
                let (Some(d), Some(a)) = (l.direction, l.half_angle_deg) else {
                    fail!("{what}: a spot needs direction and half_angle_deg");
                };
                ctx.add_spot_light(l.position, d, a.to_radians(), &power)
            }
            k => fail!("{what}: kind = \"{k}\": use \"point\" or \"spot\""),
        }
        .map_err(|e| CliError(format!("{what}: {}", e.message)))?;
    }
    Ok((
        ctx,
        LoadedScene {
            meshes,
            band_nm,
            rgb,
        },
    ))
}

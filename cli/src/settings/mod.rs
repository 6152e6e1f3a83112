//! The settings file (TOML): every section's fields as the user writes them, with their
//! defaults, and where in the file each key stands (for messages). What the settings do
//! is elsewhere: scene assembly (`scene`), lights (`lights`), grids (`grids`), daylight
//! (`daylight`), materials (`materials`) and renders (`render_cmd`).

pub mod daylight;
pub mod grids;
pub mod lights;
pub mod materials;
pub mod observers;
pub mod render;

pub use daylight::{EnvironmentSettings, SkySettings, SunSettings};
pub use grids::GridSettings;
pub use lights::{LightSettings, LuminaireSettings, SpectrumSettings};
pub use materials::{MaterialSettings, RoughnessSetting};
pub use observers::ObserverSettings;
pub use render::RenderSettings;

use crate::diag::printable;
use crate::error::{fail, CliError, Result};
use imap::{Bands, SchedulerKind};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// A per-band value in TOML: one number (grey) or a list (one per band).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(untagged)]
pub enum Spectrum {
    Grey(f64),
    Bands(Vec<f64>),
}

impl Spectrum {
    pub fn values(&self) -> Vec<f64> {
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
    /// Stop when the grids' error is at or below this (0 = no grid target); the global
    /// `target_error` is then not used.
    #[serde(default)]
    pub grid_error: f64,
    /// What `grid_error` measures: "points" (default: the largest, or the
    /// `grid_error_percentile`-th percentile, of the points' relative errors), "average"
    /// (each grid's Eavg) or "uniformity" (each grid's U0).
    #[serde(default)]
    pub grid_error_measure: Option<String>,
    /// Percentile of the points' errors for "points", in (0, 100]; default 100.
    #[serde(default)]
    pub grid_error_percentile: Option<f64>,
    /// Aim point-like lights outside the model at it (exact; default true). False traces
    /// every direction, as the paper's method does.
    #[serde(default = "yes")]
    pub aim_lights: bool,
    /// "light-sampling" (default: direct light by shadow rays from the vertices, photons
    /// for the indirect part), "gather" (light sampling, and paths from the vertices gather
    /// diffusely reflected light too) or "photons" (photons bring everything: the first
    /// paper's method). All are unbiased.
    #[serde(default = "default_estimator")]
    pub estimator: String,
}

fn default_estimator() -> String {
    "light-sampling".into()
}

fn yes() -> bool {
    true
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
            grid_error: 0.0,
            grid_error_measure: None,
            grid_error_percentile: None,
            aim_lights: true,
            estimator: default_estimator(),
        }
    }
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSettings {
    pub position: [f64; 3],
    pub look_at: [f64; 3],
    /// Default: the settings' `up_axis` (filled in by `Settings::load`).
    #[serde(default)]
    pub up: Option<[f64; 3]>,
    #[serde(default = "default_fov")]
    pub fov_deg: f64,
    #[serde(default = "default_size")]
    pub width: u32,
    #[serde(default = "default_size")]
    pub height: u32,
    /// "perspective" (the default), "angular" (an angular fisheye, Radiance's -vta) or
    /// "hemispherical" (-vth). A fisheye of 180° or more gets its daylight glare
    /// probability rated (render.json "glare", glare.png).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub projection: Option<String>,
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
    /// The model's up direction: "y" (OBJ and glTF convention, the default), "z" (most CAD
    /// and STL files), "x", or with a sign ("-z"). Used by the default camera and as the
    /// camera's default `up`.
    #[serde(default)]
    pub up_axis: Option<String>,
    /// The longest edge, metres, the recorded objects' triangles keep: longer ones are
    /// split (`Model::refine`), so a wall drawn as two triangles gets a map with a point
    /// every `refine` metres instead of its four corners. Default: as drawn (with a warning
    /// for objects far coarser than EN 12464-1's grid spacing).
    #[serde(default)]
    pub refine: Option<f64>,
    #[serde(default)]
    pub spectral: Option<SpectralSettings>,
    #[serde(default)]
    pub run: RunSettings,
    #[serde(default, rename = "light")]
    pub lights: Vec<LightSettings>,
    #[serde(default, rename = "luminaire")]
    pub luminaires: Vec<LuminaireSettings>,
    #[serde(default)]
    pub sky: Option<SkySettings>,
    #[serde(default)]
    pub environment: Option<EnvironmentSettings>,
    #[serde(default)]
    pub sun: Option<SunSettings>,
    /// The settings file's folder: luminaire files are relative to it.
    #[serde(skip)]
    pub base_dir: std::path::PathBuf,
    /// The settings file and its text, for messages that name a line of it.
    #[serde(skip)]
    pub source: Option<(std::path::PathBuf, std::sync::Arc<str>)>,
    /// Overrides by MTL material name.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialSettings>,
    /// OBJ object/group names whose irradiance is recorded; empty = all.
    #[serde(default)]
    pub record: Vec<String>,
    /// Record both sides of every mesh (default: the side the normals face).
    #[serde(default)]
    pub two_sided: bool,
    /// Objects whose triangles are turned round (their normals reversed): a model wound
    /// inside out records its outside then.
    #[serde(default)]
    pub flip_normals: Vec<String>,
    /// Objects that are the model's openings to the sky (windows, skylights): most of the
    /// daylight's photons come in through them (`Context::set_portals`, unbiased), far
    /// faster for rooms lit through windows. Each triangle is taken facing away from the
    /// model's centre; a pane's triangles facing the centre (its back) are left out.
    #[serde(default)]
    pub portals: Vec<String>,
    /// Every object wholly of glass (a transparent material with an index of refraction:
    /// Radiance `glass`, an MTL `d < 1` with `Ni`) is a portal too.
    #[serde(default)]
    pub glass_portals: bool,
    #[serde(default)]
    pub camera: Option<CameraSettings>,
    /// `imap render`: method and stop criteria.
    #[serde(default)]
    pub render: Option<RenderSettings>,
    /// Calculation grids, recorded as sensors.
    #[serde(default, rename = "grid")]
    pub grids: Vec<GridSettings>,
    /// Observers: `imap run` reports their vertical illuminance, UGR and DGPs.
    #[serde(default, rename = "observer", skip_serializing_if = "Vec::is_empty")]
    pub observers: Vec<ObserverSettings>,
    /// A medium filling the space around the model (haze, fog): `[medium]`.
    #[serde(default)]
    pub medium: Option<MediumSettings>,
    /// `imap annual`'s window groups: `[[window_group]]`.
    #[serde(default, rename = "window_group")]
    pub window_groups: Vec<WindowGroupSettings>,
    /// Objects given a material before the materials are mapped (`imap annual` sets them
    /// for a window group's state; never read from a file).
    #[serde(skip)]
    pub assign: Vec<Assignment>,
}

/// Objects given a material (`Settings::assign`).
#[derive(Clone, Debug, Default)]
pub struct Assignment {
    pub objects: Vec<String>,
    pub material: String,
    /// Where the settings ask for it, and what asks (for messages).
    pub at: (std::path::PathBuf, usize),
    pub what: String,
}

/// `[[window_group]]` (`imap annual`): a set of the model's openings whose state (blinds,
/// shades, switchable glazing) changes hour by hour.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct WindowGroupSettings {
    /// Names the group in the outputs.
    pub name: String,
    /// The model's objects (OBJ `o`/`g` names) that make up its openings.
    pub objects: Vec<String>,
    /// Its states, most open first: "as-drawn" (the objects' own materials) or the name of
    /// a material (one of the model's, or a `[materials.NAME]` of these settings).
    pub states: Vec<String>,
    /// "direct-sun" (IES LM-83's rule, the default), "illuminance" (with `rule_lx`),
    /// "schedule" (with `schedule`) or "glare" (with `rule_dgp`, at `observers`).
    #[serde(default)]
    pub rule: Option<String>,
    /// The glare rule's simplified DGP (default 0.40): the group closes by a state in the
    /// hours in which an observer's DGPs would be above it.
    #[serde(default)]
    pub rule_dgp: Option<f64>,
    /// The glare rule's `[[observer]]`s by name (default: every observer).
    #[serde(default)]
    pub observers: Option<Vec<String>>,
    /// The illuminance rule's threshold, lx.
    #[serde(default)]
    pub rule_lx: Option<f64>,
    /// The schedule rule's file: one state index per row of the weather file, relative to
    /// the settings file.
    #[serde(default)]
    pub schedule: Option<String>,
}

/// `[medium]`: the scene's medium, outside every object (`Context::set_scene_medium`):
/// absorption and scattering per band (1/m) and the scattering's phase function.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MediumSettings {
    pub absorption_per_m: Option<Spectrum>,
    pub scattering_per_m: Option<Spectrum>,
    /// Henyey–Greenstein asymmetry in (−1, 1) (default 0: isotropic).
    pub phase_g: Option<Spectrum>,
    /// A tabulated phase function instead: rows of [angle in degrees, value], 0 to 180.
    pub phase_table: Option<Vec<[f64; 2]>>,
}

impl Settings {
    pub fn load(path: &Path) -> Result<Self> {
        let bytes = crate::diag::read_input(path).map_err(CliError)?;
        let text = crate::diag::decode(&bytes);
        let mut s: Settings = toml::from_str(&text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start].matches('\n').count() + 1)
                .unwrap_or(0);
            let msg = printable(&e.message().replace('\n', " "));
            CliError(format!("{}:{line}: {msg}", path.display()))
        })?;
        s.base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        s.source = Some((path.to_path_buf(), std::sync::Arc::from(&text[..])));
        // A camera without its own `up` takes the model's.
        let up = s.up()?;
        if let Some(c) = s.camera.as_mut() {
            c.up.get_or_insert(up);
        }
        Ok(s)
    }

    /// Where the `n`-th (from 0) line starting with `header` is: the settings file and
    /// the line (0 when there is none).
    pub fn locate_nth(&self, header: &str, n: usize) -> (std::path::PathBuf, usize) {
        match &self.source {
            Some((path, text)) => {
                let line = text
                    .lines()
                    .enumerate()
                    .filter(|(_, l)| l.trim_start().starts_with(header))
                    .nth(n)
                    .map_or(0, |(i, _)| i + 1);
                (path.clone(), line)
            }
            None => ("settings".into(), 0),
        }
    }

    /// A message's prefix for the `n`-th `header` entry of the settings, `what`:
    /// "FILE:LINE: what", or "settings: what" when the settings came from no file.
    pub fn label(&self, header: &str, n: usize, what: &str) -> String {
        match self.locate_nth(header, n) {
            (p, line) if line > 0 => format!("{}:{line}: {what}", p.display()),
            _ => format!("settings: {what}"),
        }
    }

    /// Where a message about the settings points: the settings file and the first line
    /// whose text starts with `key` (a key or a table header such as `[materials.x]`),
    /// line 0 when none does; `settings` when the settings came from no file.
    pub fn locate(&self, key: &str) -> (std::path::PathBuf, usize) {
        match &self.source {
            Some((path, text)) => {
                let line = text
                    .lines()
                    .position(|l| l.trim_start().starts_with(key))
                    .map_or(0, |i| i + 1);
                (path.clone(), line)
            }
            None => ("settings".into(), 0),
        }
    }

    /// The up direction from `up_axis`.
    pub fn up(&self) -> Result<[f64; 3]> {
        let a = self
            .up_axis
            .as_deref()
            .unwrap_or("y")
            .trim()
            .to_ascii_lowercase();
        let (sign, axis) = match a.strip_prefix('-') {
            Some(r) => (-1.0, r),
            None => (1.0, a.strip_prefix('+').unwrap_or(&a)),
        };
        let k = match axis {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => fail!(
                "up_axis = \"{}\": use \"x\", \"y\" or \"z\" (optionally with a sign)",
                printable(&a)
            ),
        };
        let mut u = [0.0; 3];
        u[k] = sign;
        Ok(u)
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

    /// The grids' stop criterion, if any.
    pub fn grid_measure(&self) -> Result<imap::RegionMeasure> {
        use imap::RegionMeasure;
        let r = &self.run;
        let percentile = r.grid_error_percentile.unwrap_or(100.0);
        if !(percentile > 0.0 && percentile <= 100.0) {
            fail!("run.grid_error_percentile = {percentile} is not in (0, 100]");
        }
        Ok(match r.grid_error_measure.as_deref() {
            None | Some("points") => RegionMeasure::Vertices { percentile },
            Some("average") => RegionMeasure::Average,
            Some("uniformity") => RegionMeasure::Uniformity,
            Some(s) => fail!(
                "run.grid_error_measure = \"{s}\": use \"points\", \"average\" or \"uniformity\""
            ),
        })
    }
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

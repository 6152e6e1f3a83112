//! `[[light]]`, `[[luminaire]]` and their arrays, and the spectra lights are given in.

use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// The colour of a light: `spectrum = "equal" | "A" | "D65" | "3000K"`, or `rgb`, or a
/// `spectrum_table` of [nm, relative power] pairs.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SpectrumSettings {
    #[serde(default)]
    pub spectrum: Option<String>,
    #[serde(default)]
    pub rgb: Option<[f64; 3]>,
    #[serde(default)]
    pub spectrum_table: Option<Vec<[f64; 2]>>,
}

/// A `[[light]]`: point, spot, cosine or beam, in W per band (`power`) or in `unit`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LightSettings {
    /// "point", "spot", "cosine" or "beam".
    pub kind: String,
    pub position: [f64; 3],
    #[serde(default)]
    pub direction: Option<[f64; 3]>,
    #[serde(default)]
    pub half_angle_deg: Option<f64>,
    /// W per band (one number for every band, or one per band).
    #[serde(default)]
    pub power: Option<super::Spectrum>,
    /// How much light in `unit`: "lm", "cd", "W", "W/sr", "lx" or "W/m2".
    #[serde(default)]
    pub amount: Option<f64>,
    #[serde(default)]
    pub unit: Option<String>,
    /// Beams: "disk" (with `diameter`) or "rectangle" (with `size` = [along up, across]).
    #[serde(default)]
    pub aperture: Option<String>,
    #[serde(default)]
    pub diameter: Option<f64>,
    #[serde(default)]
    pub size: Option<[f64; 2]>,
    #[serde(default)]
    pub aperture_up: Option<[f64; 3]>,
    #[serde(flatten)]
    pub colour: SpectrumSettings,
}

/// A `[[luminaire]]`: a photometric file placed once, at each of `positions`, or as an
/// `array`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LuminaireSettings {
    /// An IES LM-63 (.ies) or EULUMDAT (.ldt) file, relative to the settings file.
    pub file: PathBuf,
    /// The TILT file an IES file names, when not beside the IES file.
    #[serde(default)]
    pub tilt_file: Option<PathBuf>,
    #[serde(default)]
    pub position: Option<[f64; 3]>,
    #[serde(default)]
    pub positions: Option<Vec<[f64; 3]>>,
    #[serde(default)]
    pub array: Option<ArraySettings>,
    /// The photometric axis (type C: the luminaire's nadir). Default [0, 0, −1].
    #[serde(default = "default_aim")]
    pub aim: [f64; 3],
    /// The C0 direction (type B: the luminaire's up) before `rotation_deg`. Default: +x,
    /// or +y when the aim is along x.
    #[serde(default)]
    pub reference: Option<[f64; 3]>,
    /// Turns the luminaire about its aim (right-handed), degrees.
    #[serde(default)]
    pub rotation_deg: f64,
    /// The world's up, for TILT. Default [0, 0, 1].
    #[serde(default = "default_up")]
    pub up: [f64; 3],
    #[serde(default = "default_scale")]
    pub flux_scale: f64,
    /// The luminaire's flux in lm instead of the file's.
    #[serde(default)]
    pub lumens: Option<f64>,
    /// Emit from the file's luminous opening instead of a point.
    #[serde(default)]
    pub use_opening: bool,
    #[serde(flatten)]
    pub colour: SpectrumSettings,
}

/// Positions `start + i·step_a + j·step_b` for i < `count[0]`, j < `count[1]`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ArraySettings {
    pub start: [f64; 3],
    pub count: [u32; 2],
    pub step_a: [f64; 3],
    #[serde(default)]
    pub step_b: [f64; 3],
}

fn default_aim() -> [f64; 3] {
    [0.0, 0.0, -1.0]
}

fn default_up() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}

fn default_scale() -> f64 {
    1.0
}

//! `[[material]]`: materials given in the settings, by name.

use super::Spectrum;
use serde::{Deserialize, Serialize};

/// Overrides of one material from the settings file.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSettings {
    pub diffuse: Option<Spectrum>,
    pub specular: Option<Spectrum>,
    pub transmit: Option<Spectrum>,
    /// Make (true) or unmake (false) a dielectric, whatever the MTL says.
    pub dielectric: Option<bool>,
    pub ior: Option<f64>,
    /// Sellmeier coefficients (λ in µm): b and c, three each.
    pub sellmeier: Option<[[f64; 3]; 2]>,
    pub absorption_per_m: Option<Spectrum>,
    /// A dielectric's scattering coefficient inside, 1/m (a homogeneous medium).
    pub scattering_per_m: Option<Spectrum>,
    /// The Henyey–Greenstein asymmetry of that scattering, in (−1, 1) (default 0).
    pub phase_g: Option<Spectrum>,
    /// A tabulated phase function instead: rows of [scattering angle in degrees, value],
    /// from 0 to 180, increasing (any scale: normalised).
    pub phase_table: Option<Vec<[f64; 2]>>,
    /// Fluorescence of a Lambertian surface (spectral runs).
    pub fluorescence: Option<FluorescenceSettings>,
    /// Exitance, W/m² per band.
    pub emission: Option<Spectrum>,
    /// The surface model: "ideal" (Lambert, mirror, smooth glass by the fields above),
    /// "conductor", "plastic", "rough-dielectric", "table" or "bsdf-xml".
    pub kind: Option<String>,
    /// kind = "bsdf-xml": the window BSDF file (LBNL WINDOW / Radiance XML, Klems basis),
    /// relative to the settings file.
    pub file: Option<std::path::PathBuf>,
    /// kind = "table": the grid's counts [θ in, φ in, θ out, φ out] (φ in = 1: isotropic).
    pub grid: Option<[u32; 4]>,
    /// kind = "table": a text file of the BRDF's values (1/sr; numbers separated by spaces,
    /// commas or line ends, `#` comments), `[band][θi][φi][θo][φo]`, relative to the
    /// settings file.
    pub brdf: Option<std::path::PathBuf>,
    /// kind = "table": the BTDF's values in the same form (optional).
    pub btdf: Option<std::path::PathBuf>,
    /// kind = "bsdf-xml": the file's up direction (model coordinates; default +z).
    pub up: Option<[f64; 3]>,
    /// GGX α, one number (isotropic) or two (along the tangent, across it), each in (0, 1].
    pub roughness: Option<RoughnessSetting>,
    /// A conductor's metal: "aluminium", "silver", "gold", "copper", "chromium".
    pub metal: Option<String>,
    /// A conductor's measured index instead: rows of [wavelength nm, n, k].
    pub nk: Option<Vec<[f64; 3]>>,
    /// The direction the first roughness runs along (model coordinates).
    pub tangent: Option<[f64; 3]>,
}

/// `[materials.NAME.fluorescence]`: the share of the light arriving in each band that is
/// absorbed to fluoresce, the quantum yield (photons out per photon absorbed) and the
/// emission spectrum in photons per band (any scale).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FluorescenceSettings {
    pub excitation: Spectrum,
    pub quantum_yield: f64,
    pub emission: Spectrum,
}

/// `roughness = 0.2` or `roughness = [0.1, 0.4]`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(untagged)]
pub enum RoughnessSetting {
    One(f64),
    Two([f64; 2]),
}

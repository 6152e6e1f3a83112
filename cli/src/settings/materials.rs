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
    /// Exitance, W/m² per band.
    pub emission: Option<Spectrum>,
}

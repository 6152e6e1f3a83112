//! `[sky]`, `[environment]` and `[sun]`.

use super::lights::SpectrumSettings;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// `[sky]`: `kind = "uniform" | "uniform_sphere" | "cie"` (with `cie_type` 1–15) `|
/// "perez"` (with `clearness` and `brightness`, or an hour's irradiances), one amount (a
/// Perez sky of irradiances has its own), the sky's orientation and colour (default D65).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SkySettings {
    pub kind: String,
    #[serde(default)]
    pub cie_type: Option<u32>,
    /// The CIE sky's sun; default: the `[sun]`'s position.
    #[serde(default)]
    pub sun_azimuth_deg: Option<f64>,
    #[serde(default)]
    pub sun_zenith_deg: Option<f64>,
    /// A Perez sky's clearness ε and brightness Δ.
    #[serde(default)]
    pub clearness: Option<f64>,
    #[serde(default)]
    pub brightness: Option<f64>,
    /// A Perez sky of an hour's weather: its direct normal and diffuse horizontal
    /// irradiance, W/m² (the whole solar spectrum, as weather files give them).
    #[serde(default)]
    pub direct_normal_irradiance: Option<f64>,
    #[serde(default)]
    pub diffuse_horizontal_irradiance: Option<f64>,
    /// The hour's dew point, °C (default: 2 cm of precipitable water, as gendaylit).
    #[serde(default)]
    pub dew_point_c: Option<f64>,
    /// The hour's day of the year, 1–366 (default: the `[sun]`'s date).
    #[serde(default)]
    pub day_of_year: Option<u32>,
    /// A Perez sky of an hour of a weather file (EPW, or Radiance .wea by its extension;
    /// relative to the settings file): `weather_hour = "MM-DD HH"`, HH the hour as the
    /// file counts it (EPW: 1–24, the hour that ends then). Its site places the sun.
    #[serde(default)]
    pub weather: Option<PathBuf>,
    #[serde(default)]
    pub weather_hour: Option<String>,
    /// cd/m² (a CIE sky's at the zenith).
    #[serde(default)]
    pub luminance: Option<f64>,
    /// W/(m² sr) over all bands.
    #[serde(default)]
    pub radiance: Option<f64>,
    /// lx on an unobstructed horizontal plane.
    #[serde(default)]
    pub horizontal_illuminance: Option<f64>,
    /// W/m² on an unobstructed horizontal plane.
    #[serde(default)]
    pub horizontal_irradiance: Option<f64>,
    /// Default: the settings' `up_axis`.
    #[serde(default)]
    pub zenith: Option<[f64; 3]>,
    /// Default: +y, or −z when `up_axis` is y.
    #[serde(default)]
    pub north: Option<[f64; 3]>,
    #[serde(default)]
    pub rotation_deg: f64,
    /// The ground's glow below the horizon (Radiance's ground glow): ρ E_h / π of this sky
    /// and the `[sun]`.
    #[serde(default)]
    pub ground_reflectance: Option<f64>,
    #[serde(flatten)]
    pub colour: SpectrumSettings,
}

/// `[environment]`: an equirectangular Radiance HDR or OpenEXR file (relative to the
/// settings file), its pixels × `scale` W/(m² sr), or scaled to a horizontal amount.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentSettings {
    pub file: PathBuf,
    #[serde(default)]
    pub scale: Option<f64>,
    #[serde(default)]
    pub horizontal_illuminance: Option<f64>,
    #[serde(default)]
    pub horizontal_irradiance: Option<f64>,
    /// Default: the settings' `up_axis`.
    #[serde(default)]
    pub zenith: Option<[f64; 3]>,
    /// Default: +y, or −z when `up_axis` is y.
    #[serde(default)]
    pub north: Option<[f64; 3]>,
    #[serde(default)]
    pub rotation_deg: f64,
}

/// `[sun]`: at `azimuth_deg`/`zenith_deg`, or at `date` (`"YYYY-MM-DD HH:MM[:SS]"`, local
/// time `utc_offset_hours` from UTC) and `latitude_deg`/`longitude_deg`; its direct normal
/// illuminance (lx) or irradiance (W/m²).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SunSettings {
    #[serde(default)]
    pub azimuth_deg: Option<f64>,
    #[serde(default)]
    pub zenith_deg: Option<f64>,
    #[serde(default)]
    pub date: Option<String>,
    #[serde(default)]
    pub utc_offset_hours: f64,
    #[serde(default)]
    pub latitude_deg: Option<f64>,
    #[serde(default)]
    pub longitude_deg: Option<f64>,
    #[serde(default)]
    pub elevation_m: f64,
    /// The site's air pressure (hPa) and temperature (°C) for refraction (both, or the
    /// standard atmosphere: 1013.25 hPa, 10 °C), and ΔT = TT − UT1 in s (default:
    /// estimated from the date). With a date only.
    #[serde(default)]
    pub pressure_hpa: Option<f64>,
    #[serde(default)]
    pub temperature_c: Option<f64>,
    #[serde(default)]
    pub delta_t_s: Option<f64>,
    #[serde(default)]
    pub normal_illuminance: Option<f64>,
    #[serde(default)]
    pub normal_irradiance: Option<f64>,
    /// Default: the settings' `up_axis`.
    #[serde(default)]
    pub zenith: Option<[f64; 3]>,
    /// Default: +y, or −z when `up_axis` is y.
    #[serde(default)]
    pub north: Option<[f64; 3]>,
    #[serde(flatten)]
    pub colour: SpectrumSettings,
}

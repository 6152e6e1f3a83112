//! The settings' `[sky]`, `[environment]` and `[sun]` tables: a uniform or CIE standard
//! general sky, an HDR environment image, and the sun at given angles or at a date, time
//! and place.

use crate::diag::printable;
use crate::lights::{PlacedLight, SpectrumSettings};
use crate::scene::{fail, CliError, Result};
use imap::photometry::Spectrum;
use imap::Context;
use imap::{sun_position_with, SunTime, STANDARD_ATMOSPHERE};
use imap::{SkyAmount, SkyDesc, SkyKind, SunDesc};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The sky's zenith and north: as given, else the settings' up axis and a horizontal
/// north (+y when up is ±z or ±x, −z when up is ±y: the model's "into the screen").
fn frame(zenith: Option<[f64; 3]>, north: Option<[f64; 3]>, up: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let z = zenith.unwrap_or(up);
    let n = north.unwrap_or(if up[1] != 0.0 {
        [0.0, 0.0, -1.0]
    } else {
        [0.0, 1.0, 0.0]
    });
    (z, n)
}

/// `[sky]`: `kind = "uniform" | "uniform_sphere" | "cie"` (with `cie_type` 1–15), one
/// amount, the sky's orientation and colour (default D65).
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

/// A named amount in the settings: its key, its value if given, and what it means.
type NamedAmount<'a> = (&'a str, Option<f64>, fn(f64) -> SkyAmount);

/// Exactly one of the named amounts.
fn one_amount(what: &str, given: &[NamedAmount]) -> Result<SkyAmount> {
    let set: Vec<_> = given.iter().filter(|g| g.1.is_some()).collect();
    match set.as_slice() {
        [(_, Some(x), make)] => Ok(make(*x)),
        _ => fail!(
            "{what}: give one of {}",
            given.iter().map(|g| g.0).collect::<Vec<_>>().join(", ")
        ),
    }
}

/// "YYYY-MM-DD HH:MM[:SS[.s]]" (or with a T between date and time).
fn parse_date(s: &str, what: &str) -> Result<(i32, u32, u32, u32, u32, f64)> {
    let bad = || {
        CliError(format!(
            "{what}: date = \"{}\": write it as \"YYYY-MM-DD HH:MM\" or \"YYYY-MM-DD HH:MM:SS\" (local time; utc_offset_hours gives its zone)",
            printable(s)
        ))
    };
    let (d, t) = s.trim().split_once([' ', 'T']).ok_or_else(bad)?;
    let d: Vec<&str> = d.split('-').collect();
    let t: Vec<&str> = t.trim().split(':').collect();
    if d.len() != 3 || !(2..=3).contains(&t.len()) {
        return Err(bad());
    }
    let year = d[0].parse().map_err(|_| bad())?;
    let month = d[1].parse().map_err(|_| bad())?;
    let day = d[2].parse().map_err(|_| bad())?;
    let hour = t[0].parse().map_err(|_| bad())?;
    let minute = t[1].parse().map_err(|_| bad())?;
    let second = match t.get(2) {
        Some(x) => x.parse().map_err(|_| bad())?,
        None => 0.0,
    };
    Ok((year, month, day, hour, minute, second))
}

/// The `[sun]`'s (azimuth, zenith angle), degrees.
fn sun_angles(s: &SunSettings) -> Result<(f64, f64)> {
    let what = "settings: sun";
    match (s.azimuth_deg, s.zenith_deg, &s.date) {
        (Some(a), Some(z), None) => Ok((a, z)),
        (None, None, Some(date)) => {
            let (Some(lat), Some(lon)) = (s.latitude_deg, s.longitude_deg) else {
                fail!("{what}: a date needs latitude_deg and longitude_deg");
            };
            let (year, month, day, hour, minute, second) = parse_date(date, what)?;
            let atmosphere = match (s.pressure_hpa, s.temperature_c) {
                (Some(p), Some(c)) => (p, c),
                (None, None) => STANDARD_ATMOSPHERE,
                _ => fail!("{what}: give pressure_hpa and temperature_c together"),
            };
            sun_position_with(&SunTime {
                year,
                month,
                day,
                hour,
                minute,
                second,
                utc_offset_hours: s.utc_offset_hours,
                latitude_deg: lat,
                longitude_deg: lon,
                elevation_m: s.elevation_m,
            }, s.delta_t_s, Some(atmosphere))
            .map_err(|e| CliError(format!("{what}: {}", printable(&e.message))))
        }
        _ => fail!("{what}: give azimuth_deg and zenith_deg, or a date with latitude_deg and longitude_deg"),
    }
}

fn spectrum(c: &SpectrumSettings, what: &str) -> Result<Spectrum> {
    if c.spectrum.is_none() && c.rgb.is_none() && c.spectrum_table.is_none() {
        return Ok(Spectrum::CieD65);
    }
    c.resolve(what)
}

/// Adds the sky, the environment and the sun.
pub fn add_daylight(
    ctx: &mut Context,
    sky: Option<&SkySettings>,
    environment: Option<&EnvironmentSettings>,
    sun: Option<&SunSettings>,
    base_dir: &Path,
    up: [f64; 3],
    out: &mut Vec<PlacedLight>,
) -> Result<()> {
    let sun_at = sun.map(sun_angles).transpose()?;
    let mut push = |ctx: &Context, id: u32, name: String| -> Result<()> {
        let (w, lm) = ctx.light_flux(id)?;
        out.push(PlacedLight {
            name,
            position: [0.0; 3],
            lumens: lm,
            watts: w.iter().sum(),
            distant: true,
        });
        Ok(())
    };
    if let Some(s) = sky {
        let what = "settings: sky";
        let kind = match s.kind.trim() {
            "uniform" => SkyKind::Uniform { sphere: false },
            "uniform_sphere" => SkyKind::Uniform { sphere: true },
            "cie" => {
                let Some(kind) = s.cie_type else {
                    fail!("{what}: a CIE sky needs cie_type (1–15)");
                };
                let (a, z) = match (s.sun_azimuth_deg, s.sun_zenith_deg, sun_at) {
                    (Some(a), Some(z), _) => (a, z),
                    (None, None, Some((a, z))) => (a, z.min(90.0)),
                    (None, None, None) if [1, 3, 5].contains(&kind) => (180.0, 45.0),
                    _ => fail!("{what}: a CIE sky of type {kind} needs its sun: sun_azimuth_deg and sun_zenith_deg, or a [sun]"),
                };
                SkyKind::Cie {
                    kind,
                    sun_azimuth_deg: a,
                    sun_zenith_deg: z,
                }
            }
            k => fail!(
                "{what}: kind = \"{}\": use \"uniform\", \"uniform_sphere\" or \"cie\" (an image goes in [environment])",
                printable(k)
            ),
        };
        let amount = one_amount(
            what,
            &[
                ("luminance", s.luminance, SkyAmount::Luminance),
                ("radiance", s.radiance, SkyAmount::Radiance),
                (
                    "horizontal_illuminance",
                    s.horizontal_illuminance,
                    SkyAmount::HorizontalIlluminance,
                ),
                (
                    "horizontal_irradiance",
                    s.horizontal_irradiance,
                    SkyAmount::HorizontalIrradiance,
                ),
            ],
        )?;
        let (zenith, north) = frame(s.zenith, s.north, up);
        let id = ctx
            .add_sky(&SkyDesc {
                kind,
                amount,
                spectrum: spectrum(&s.colour, what)?,
                zenith,
                north,
                rotation_deg: s.rotation_deg,
            })
            .map_err(|e| CliError(format!("{what}: {}", printable(&e.message))))?;
        push(ctx, id, format!("sky ({})", s.kind.trim()))?;
    }
    if let Some(e) = environment {
        let what = "settings: environment";
        let amount = one_amount(
            what,
            &[
                ("scale", e.scale, SkyAmount::Scale),
                (
                    "horizontal_illuminance",
                    e.horizontal_illuminance,
                    SkyAmount::HorizontalIlluminance,
                ),
                (
                    "horizontal_irradiance",
                    e.horizontal_irradiance,
                    SkyAmount::HorizontalIrradiance,
                ),
            ],
        )?;
        let path = base_dir.join(&e.file);
        let (zenith, north) = frame(e.zenith, e.north, up);
        let id = ctx
            .add_sky_file(
                &path,
                &SkyDesc {
                    amount,
                    zenith,
                    north,
                    rotation_deg: e.rotation_deg,
                    ..SkyDesc::default()
                },
            )
            .map_err(|err| CliError(format!("{what}: {}", printable(&err.message))))?;
        push(ctx, id, format!("environment ({})", e.file.display()))?;
    }
    if let (Some(s), Some((a, z))) = (sun, sun_at) {
        let what = "settings: sun";
        if z > 90.0 {
            fail!("{what}: the sun is {:.2}° below the horizon then: it lights nothing (leave [sun] out)", z - 90.0);
        }
        let amount = one_amount(
            what,
            &[
                (
                    "normal_illuminance",
                    s.normal_illuminance,
                    SkyAmount::NormalIlluminance,
                ),
                (
                    "normal_irradiance",
                    s.normal_irradiance,
                    SkyAmount::NormalIrradiance,
                ),
            ],
        )?;
        let (zenith, north) = frame(s.zenith, s.north, up);
        let id = ctx
            .add_sun(&SunDesc {
                azimuth_deg: a,
                zenith_deg: z,
                amount,
                spectrum: spectrum(&s.colour, what)?,
                zenith,
                north,
            })
            .map_err(|e| CliError(format!("{what}: {}", printable(&e.message))))?;
        push(ctx, id, format!("sun (azimuth {a:.2}°, zenith {z:.2}°)"))?;
    }
    if let Some((s, rho)) = sky.and_then(|s| s.ground_reflectance.map(|r| (s, r))) {
        let what = "settings: sky";
        if !(0.0..=1.0).contains(&rho) {
            fail!("{what}: ground_reflectance = {rho} must be in [0, 1]");
        }
        if rho > 0.0 {
            let (zenith, _) = frame(s.zenith, s.north, up);
            let id = ctx.add_ground(&[rho], zenith).map_err(|e| {
                CliError(format!(
                    "{what}: ground_reflectance: {}",
                    printable(&e.message)
                ))
            })?;
            push(ctx, id, format!("ground (reflectance {rho})"))?;
        }
    }
    Ok(())
}

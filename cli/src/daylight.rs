//! The settings' `[sky]`, `[environment]` and `[sun]` tables: a uniform or CIE standard
//! general sky, an HDR environment image, and the sun at given angles or at a date, time
//! and place.

use crate::diag::printable;
use crate::error::{fail, CliError, Result};
use crate::lights::PlacedLight;
use crate::settings::{EnvironmentSettings, SkySettings, SpectrumSettings, SunSettings};
use imap::photometry::Spectrum;
use imap::Context;
use imap::{perez_sky, precipitable_water, PerezSky};
use imap::{sun_position_with, SunTime, STANDARD_ATMOSPHERE};
use imap::{SkyAmount, SkyDesc, SkyKind, SunDesc};
use std::path::Path;

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

/// The `[sky]`'s hour of its weather file, and the sun's (azimuth, zenith angle) then.
fn weather_hour(
    s: &SkySettings,
    base_dir: &Path,
) -> Result<(imap::weather::WeatherHour, (f64, f64))> {
    let what = "settings: sky";
    let file = s.weather.as_ref().expect("a weather file");
    let Some(when) = s.weather_hour.as_deref() else {
        fail!("{what}: weather needs weather_hour = \"MM-DD HH\" (the file's hour)");
    };
    let bad = || {
        CliError(format!(
            "{what}: weather_hour = \"{}\": write it as \"MM-DD HH\" (EPW hours 1–24 end then)",
            printable(when)
        ))
    };
    let (d, h) = when.trim().split_once(' ').ok_or_else(bad)?;
    let (m, d) = d.split_once('-').ok_or_else(bad)?;
    let (m, d, h): (u32, u32, f64) = (
        m.parse().map_err(|_| bad())?,
        d.parse().map_err(|_| bad())?,
        h.trim().parse().map_err(|_| bad())?,
    );
    let path = base_dir.join(file);
    let wea = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("wea"));
    let w = imap::weather::read(&path)
        .map_err(|e| CliError(format!("{what}: weather: {}", printable(&e.message))))?;
    // An EPW hour h is stored at h − 0.5; a .wea row at its own decimal hour.
    let at = if wea { h } else { h - 0.5 };
    let Some(hour) = w
        .hours
        .iter()
        .find(|x| x.month == m && x.day == d && (x.hour - at).abs() < 0.26)
    else {
        fail!(
            "{what}: weather_hour = \"{}\": {} has no such hour",
            printable(when),
            path.display()
        );
    };
    let sun = hour
        .sun_position(&w.site)
        .map_err(|e| CliError(format!("{what}: weather: {}", printable(&e.message))))?;
    Ok((*hour, sun))
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
    if let Some(s) = sky.filter(|s| s.weather_hour.is_some() || s.weather.is_some()) {
        if s.kind.trim() != "perez" {
            fail!("settings: sky: weather and weather_hour make a perez sky: set kind = \"perez\"");
        }
        if s.weather.is_none() {
            fail!("settings: sky: weather_hour needs weather = \"FILE.epw\"");
        }
    }
    let weather = sky
        .filter(|s| s.weather.is_some())
        .map(|s| weather_hour(s, base_dir))
        .transpose()?;
    // A [sun] without a position under a weather file's sky is that hour's sun.
    let sun_at = match (sun, weather) {
        (Some(s), Some((_, at)))
            if s.azimuth_deg.is_none() && s.zenith_deg.is_none() && s.date.is_none() =>
        {
            Some(at)
        }
        _ => sun.map(sun_angles).transpose()?,
    };
    // A Perez sky of an hour's irradiances: its conditions and illuminances.
    let mut hour: Option<PerezSky> = None;
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
            "perez" => {
                let (a, z) = match (s.sun_azimuth_deg, s.sun_zenith_deg, weather, sun_at) {
                    (Some(a), Some(z), None, _) => (a, z),
                    (None, None, Some((_, at)), _) => at,
                    (None, None, None, Some((a, z))) => (a, z),
                    (_, _, Some(_), _) => fail!("{what}: a weather file's sky has its own sun: leave sun_azimuth_deg and sun_zenith_deg out"),
                    _ => fail!("{what}: a perez sky needs its sun: sun_azimuth_deg and sun_zenith_deg, or a [sun]"),
                };
                let (clearness, brightness) = match (
                    s.clearness,
                    s.brightness,
                    s.direct_normal_irradiance,
                    s.diffuse_horizontal_irradiance,
                ) {
                    (None, None, None, None) if weather.is_some() => {
                        let (h, _) = weather.expect("a weather hour");
                        let p = h
                            .perez_sky(z)
                            .map_err(|e| CliError(format!("{what}: weather: {}", printable(&e.message))))?;
                        let Some(p) = p else {
                            fail!(
                                "{what}: weather_hour: line {} of the weather file has {}: no sky then",
                                h.line,
                                if h.direct_normal_w.is_none() || h.diffuse_horizontal_w.is_none() {
                                    "its irradiance missing (9999)"
                                } else {
                                    "no diffuse light"
                                }
                            );
                        };
                        hour = Some(p);
                        (p.clearness, p.brightness)
                    }
                    (Some(c), Some(b), None, None) if weather.is_none() => (c, b),
                    (None, None, Some(dni), Some(dhi)) if weather.is_none() => {
                        let from_sun = sun
                            .and_then(|s| s.date.as_deref())
                            .map(|d| parse_date(d, "settings: sun"))
                            .transpose()?
                            .map(|(y, m, d, ..)| imap::weather::day_of_year(y, m, d));
                        let Some(day) = s.day_of_year.or(from_sun) else {
                            fail!("{what}: a perez sky of irradiances needs day_of_year (or a [sun] with a date)");
                        };
                        let water = s.dew_point_c.map(precipitable_water).unwrap_or(2.0);
                        let p = perez_sky(dni, dhi, z, day, water)
                            .map_err(|e| CliError(format!("{what}: {}", printable(&e.message))))?;
                        let Some(p) = p else {
                            fail!("{what}: diffuse_horizontal_irradiance = 0: an hour without diffuse light has no sky (leave [sky] out)");
                        };
                        hour = Some(p);
                        (p.clearness, p.brightness)
                    }
                    _ => fail!("{what}: a perez sky needs clearness and brightness, or direct_normal_irradiance and diffuse_horizontal_irradiance (W/m², as a weather file gives them), or a weather file and weather_hour (alone)"),
                };
                SkyKind::Perez {
                    sun_azimuth_deg: a,
                    sun_zenith_deg: z,
                    clearness,
                    brightness,
                }
            }
            k => fail!(
                "{what}: kind = \"{}\": use \"uniform\", \"uniform_sphere\", \"cie\" or \"perez\" (an image goes in [environment])",
                printable(k)
            ),
        };
        let given = [
            s.luminance,
            s.radiance,
            s.horizontal_illuminance,
            s.horizontal_irradiance,
        ];
        let amount = match hour {
            // An hour's Perez sky: its diffuse horizontal illuminance by the efficacy model.
            Some(p) if given.iter().all(Option::is_none) => {
                SkyAmount::HorizontalIlluminance(p.diffuse_horizontal_lx)
            }
            _ => one_amount(
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
            )?,
        };
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
        if z > 90.0 && weather.is_some() {
            // A weather file's night or twilight hour: no sun.
            return add_ground(ctx, sky, up, &mut push);
        }
        if z > 90.0 {
            fail!("{what}: the sun is {:.2}° below the horizon then: it lights nothing (leave [sun] out)", z - 90.0);
        }
        let amount = match hour {
            // The hour's sun: its direct normal illuminance by the efficacy model; an
            // hour without direct light has none.
            Some(p) if s.normal_illuminance.is_none() && s.normal_irradiance.is_none() => {
                if p.direct_normal_lx <= 0.0 {
                    return add_ground(ctx, sky, up, &mut push);
                }
                SkyAmount::NormalIlluminance(p.direct_normal_lx)
            }
            _ => one_amount(
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
            )?,
        };
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
    add_ground(ctx, sky, up, &mut push)
}

/// The `[sky]`'s ground glow, after the sky and the sun.
fn add_ground(
    ctx: &mut Context,
    sky: Option<&SkySettings>,
    up: [f64; 3],
    push: &mut impl FnMut(&Context, u32, String) -> Result<()>,
) -> Result<()> {
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

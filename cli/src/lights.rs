//! The settings' `[[light]]` and `[[luminaire]]` tables: simple lights in any unit with a
//! spectrum, and goniometric luminaires from IES and EULUMDAT files, placed one by one, at a
//! list of positions or as an array.

use crate::diag::printable;
use crate::error::{fail, CliError, Result};
use crate::settings::{LightSettings, LuminaireSettings, SpectrumSettings};
use imap::photometry::Spectrum as LightSpectrum;
use imap::Context;
use imap::{Amount, LightDesc, LightKind, Placement};
use serde::Serialize;
use std::path::Path;

impl SpectrumSettings {
    pub fn resolve(&self, what: &str) -> Result<LightSpectrum> {
        let given = [
            self.spectrum.is_some(),
            self.rgb.is_some(),
            self.spectrum_table.is_some(),
        ];
        if given.iter().filter(|g| **g).count() > 1 {
            fail!("{what}: give one of spectrum, rgb and spectrum_table");
        }
        if let Some(c) = self.rgb {
            return Ok(LightSpectrum::Rgb(c));
        }
        if let Some(t) = &self.spectrum_table {
            return Ok(LightSpectrum::Table(
                t.iter().map(|p| (p[0], p[1])).collect(),
            ));
        }
        let Some(s) = &self.spectrum else {
            return Ok(LightSpectrum::Equal);
        };
        let t = s.trim();
        Ok(match t.to_ascii_lowercase().as_str() {
            "equal" | "white" => LightSpectrum::Equal,
            "a" | "cie a" | "cie_a" => LightSpectrum::CieA,
            "d65" | "cie d65" | "cie_d65" => LightSpectrum::CieD65,
            k => match k.strip_suffix('k').and_then(|n| n.trim().parse::<f64>().ok()) {
                Some(kelvin) => LightSpectrum::Blackbody(kelvin),
                None => fail!(
                    "{what}: spectrum = \"{}\": use \"equal\", \"A\", \"D65\" or a colour temperature such as \"3000K\"",
                    printable(t)
                ),
            },
        })
    }
}

/// Most luminaires one `[[luminaire]]` table may place.
const MAX_PLACED: u64 = 100_000;

/// What the report says of each light.
#[derive(Clone, Debug, Serialize)]
pub struct PlacedLight {
    pub name: String,
    pub position: [f64; 3],
    /// lm and W; of a sky or the sun (`distant`): lx and W/m² on an open horizontal plane.
    pub lumens: f64,
    pub watts: f64,
    /// A sky, an environment or the sun: infinitely far, no position.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub distant: bool,
}

fn unit_amount(unit: &str, x: f64, what: &str) -> Result<Amount> {
    Ok(match unit.trim() {
        "lm" => Amount::Lumens(x),
        "cd" => Amount::Candela(x),
        "W" | "w" => Amount::Watts(x),
        "W/sr" | "w/sr" => Amount::WattsPerSr(x),
        "lx" | "lux" => Amount::Lux(x),
        "W/m2" | "W/m²" | "w/m2" => Amount::WattsPerM2(x),
        u => fail!(
            "{what}: unit = \"{}\": use \"lm\", \"cd\", \"W\", \"W/sr\", \"lx\" or \"W/m2\"",
            printable(u)
        ),
    })
}

/// Adds the `[[light]]` tables.
pub fn add_lights(
    ctx: &mut Context,
    lights: &[LightSettings],
    label: &dyn Fn(usize) -> String,
    out: &mut Vec<PlacedLight>,
) -> Result<()> {
    for (i, l) in lights.iter().enumerate() {
        let what = label(i);
        let dir = || -> Result<[f64; 3]> {
            match l.direction {
                Some(d) => Ok(d),
                None => fail!("{what}: a {} light needs a direction", l.kind),
            }
        };
        let kind = match l.kind.as_str() {
            "point" => LightKind::Point,
            "spot" => {
                let Some(a) = l.half_angle_deg else {
                    fail!("{what}: a spot needs half_angle_deg");
                };
                LightKind::Spot {
                    direction: dir()?,
                    half_angle_rad: a.to_radians(),
                }
            }
            "cosine" => LightKind::Cosine { direction: dir()? },
            "beam" => {
                let (disk, size) = match l.aperture.as_deref().unwrap_or("disk") {
                    "disk" => match l.diameter {
                        Some(d) => (true, [d, d]),
                        None => fail!("{what}: a beam through a disk needs its diameter"),
                    },
                    "rectangle" => match l.size {
                        Some(s) => (false, s),
                        None => fail!("{what}: a beam through a rectangle needs size = [w, h]"),
                    },
                    a => fail!(
                        "{what}: aperture = \"{}\": use \"disk\" or \"rectangle\"",
                        printable(a)
                    ),
                };
                LightKind::Beam {
                    direction: dir()?,
                    disk,
                    size,
                    up: l.aperture_up.unwrap_or([0.0, 0.0, 1.0]),
                }
            }
            k => fail!(
                "{what}: kind = \"{}\": use \"point\", \"spot\", \"cosine\" or \"beam\"",
                printable(k)
            ),
        };
        let amount = match (&l.power, l.amount, &l.unit) {
            (Some(p), None, None) => Amount::WattsPerBand(p.values()),
            (None, Some(x), Some(u)) => unit_amount(u, x, &what)?,
            _ => fail!("{what}: give either power (W per band) or amount with its unit"),
        };
        let spectrum = l.colour.resolve(&what)?;
        let id = ctx
            .add_light_desc(&LightDesc {
                kind,
                position: l.position,
                amount,
                spectrum,
            })
            .map_err(|e| CliError(format!("{what}: {}", printable(&e.message))))?;
        let (w, lm) = ctx.light_flux(id)?;
        out.push(PlacedLight {
            name: format!("light {} ({})", i + 1, l.kind),
            position: l.position,
            lumens: lm,
            watts: w.iter().sum(),
            distant: false,
        });
    }
    Ok(())
}

/// The C0 reference turned by `deg` about the aim.
fn reference(l: &LuminaireSettings) -> [f64; 3] {
    let a = glam::DVec3::from(l.aim).normalize_or_zero();
    let r = glam::DVec3::from(l.reference.unwrap_or(if a.x.abs() > 0.9 {
        [0.0, 1.0, 0.0]
    } else {
        [1.0, 0.0, 0.0]
    }));
    let (s, c) = l.rotation_deg.to_radians().sin_cos();
    // Rodrigues' rotation about the unit aim.
    (r * c + a.cross(r) * s + a * a.dot(r) * (1.0 - c)).to_array()
}

fn positions(l: &LuminaireSettings, what: &str) -> Result<Vec<[f64; 3]>> {
    match (&l.position, &l.positions, &l.array) {
        (Some(p), None, None) => Ok(vec![*p]),
        (None, Some(ps), None) if !ps.is_empty() => Ok(ps.clone()),
        (None, None, Some(a)) => {
            let n = a.count[0] as u64 * a.count[1] as u64;
            if n == 0 || n > MAX_PLACED {
                fail!(
                    "{what}: array.count = {:?} places {n} luminaires: give 1 to {MAX_PLACED}",
                    a.count
                );
            }
            let mut out = Vec::with_capacity(n as usize);
            for j in 0..a.count[1] {
                for i in 0..a.count[0] {
                    out.push(
                        [0, 1, 2]
                            .map(|k| a.start[k] + i as f64 * a.step_a[k] + j as f64 * a.step_b[k]),
                    );
                }
            }
            Ok(out)
        }
        _ => fail!("{what}: give one of position, positions (a non-empty list) and array"),
    }
}

/// Reads a photometric file (any bytes: Latin-1 and UTF-8 alike; a regular file only).
fn read_text(path: &Path, what: &str) -> Result<String> {
    let bytes = crate::diag::read_input(path).map_err(|e| CliError(format!("{what}: {e}")))?;
    Ok(crate::diag::decode(&bytes))
}

/// Adds the `[[luminaire]]` tables; file names are relative to `base` (the settings
/// file's folder).
pub fn add_luminaires(
    ctx: &mut Context,
    luminaires: &[LuminaireSettings],
    base: &Path,
    label: &dyn Fn(usize) -> String,
    out: &mut Vec<PlacedLight>,
) -> Result<()> {
    for (i, l) in luminaires.iter().enumerate() {
        let what = label(i);
        let path = base.join(&l.file);
        let shown = printable(&path.display().to_string());
        let text = read_text(&path, &what)?;
        let is_ldt = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("ldt"));
        // An IES file naming a TILT file: the given one, or the named one beside it.
        let tilt = if is_ldt {
            None
        } else {
            match &l.tilt_file {
                Some(t) => Some(read_text(&base.join(t), &what)?),
                None => tilt_name(&text)
                    .map(|name| read_text(&path.with_file_name(name), &what))
                    .transpose()?,
            }
        };
        let spectrum = l.colour.resolve(&what)?;
        let reference = reference(l);
        let fail_with =
            |e: imap::Error| CliError(format!("{what}: {shown}: {}", printable(&e.message)));
        let distribution = if is_ldt {
            ctx.distribution_ldt(&text)
        } else {
            ctx.distribution_ies(&text, tilt.as_deref())
        }
        .map_err(fail_with)?;
        for p in positions(l, &what)? {
            let place = Placement {
                position: p,
                aim: l.aim,
                reference,
                up: l.up,
                flux_scale: l.flux_scale,
                lumens: l.lumens.unwrap_or(0.0),
                use_opening: l.use_opening,
            };
            let id = ctx
                .add_distribution(&distribution, &place, &spectrum)
                .map_err(fail_with)?;
            let (w, lm) = ctx.light_flux(id)?;
            out.push(PlacedLight {
                name: format!("{} ({})", l.file.display(), i + 1),
                position: p,
                lumens: lm,
                watts: w.iter().sum(),
                distant: false,
            });
        }
    }
    Ok(())
}

/// The TILT file an IES file names (`TILT=<name>`, other than NONE and INCLUDE).
fn tilt_name(text: &str) -> Option<String> {
    let line = text
        .lines()
        .map(str::trim)
        .find(|l| l.to_ascii_uppercase().starts_with("TILT"))?;
    let v = line.split_once('=')?.1.trim();
    (!v.eq_ignore_ascii_case("NONE") && !v.eq_ignore_ascii_case("INCLUDE") && !v.is_empty())
        .then(|| v.to_string())
}

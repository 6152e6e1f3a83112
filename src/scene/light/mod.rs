//! Lights: point, spot, cosine (Lambertian point) and collimated-beam sources, and
//! goniometric luminaires; how much light they give (watts per band, watts, lumens,
//! candela, W/sr, lux, W/m²) and in which spectrum.
//!
//! Every light ends up as a radiant flux per band (`Light::power`, W) and a shape: the
//! relative distribution of that flux over directions (and over an aperture or luminous
//! opening). docs/photometry.md states the conversions.

//!
//! Each kind of light has its file: `shape` (point, spot, cosine, beam and how a shape
//! spreads its flux), `luminaire` (goniometric distributions placed in the world),
//! `distant` (what every distant source shares), `sky` (uniform, CIE and image skies and
//! the ground's glow), `sun`, `cie` (the CIE standard general skies' formula) and `perez` (the Perez
//! all-weather sky and the Perez sky conditions of a weather file's hour).

mod cie;
mod direction;
mod distant;
mod luminaire;
mod patches;
mod perez;
mod shape;
mod sky;
mod sun;

pub use cie::{cie_luminance, CIE_SKY_PARAMETERS};
pub use direction::unit_vector;
use direction::{direction, perpendicular};
pub use distant::{Distant, DistantPart, Radiance, SkyAmount, SkyFrame};
pub use luminaire::Luminaire;
pub use patches::{SkyPatches, MAX_REINHART_MF};
pub use perez::{
    air_mass, eccentricity, perez_bin, perez_parameters, perez_relative, perez_sky,
    precipitable_water, PerezSky, PEREZ_CLEARNESS_BINS, PEREZ_DIFFUSE_EFFICACY,
    PEREZ_DIRECT_EFFICACY, PEREZ_SKY_COEFFICIENTS, SOLAR_CONSTANT_W_PER_M2,
};
pub use shape::{Aperture, LightShape};
pub use sky::{sky_patch_radiance, SkyDesc, SkyKind};
pub use sun::{SunDesc, SUN_DIAMETER_DEG};

use crate::error::{bail, check_coordinates, check_finite, check_finite_scalar, Result};
use crate::photometry::colour::scale_spectrum;
use crate::photometry::{Goniometric, Opening, PhotometricData, PhotometricType, Spectrum};
use crate::sampling::warp;
use crate::spectral::Bands;
use glam::DVec3;
use std::f64::consts::PI;
use std::sync::Arc;

/// The amount of light, in the unit the caller chose.
#[derive(Clone, Debug, PartialEq)]
pub enum Amount {
    /// Radiant flux per band, W (one value per band, or one for every band).
    WattsPerBand(Vec<f64>),
    /// Radiant flux over all bands, W.
    Watts(f64),
    /// Luminous flux, lm.
    Lumens(f64),
    /// Luminous intensity, cd: of a point or spot light in every direction it lights; of a
    /// cosine source along its axis.
    Candela(f64),
    /// Radiant intensity over all bands, W/sr (as `Candela`).
    WattsPerSr(f64),
    /// Illuminance of a beam on a plane perpendicular to it, lx.
    Lux(f64),
    /// Irradiance of a beam on a plane perpendicular to it, W/m² over all bands.
    WattsPerM2(f64),
}

impl Amount {
    fn value(&self) -> Option<f64> {
        match *self {
            Amount::WattsPerBand(_) => None,
            Amount::Watts(x)
            | Amount::Lumens(x)
            | Amount::Candela(x)
            | Amount::WattsPerSr(x)
            | Amount::Lux(x)
            | Amount::WattsPerM2(x) => Some(x),
        }
    }

    fn photometric(&self) -> bool {
        matches!(
            self,
            Amount::Lumens(_) | Amount::Candela(_) | Amount::Lux(_)
        )
    }

    fn name(&self) -> &'static str {
        match self {
            Amount::WattsPerBand(_) => "W per band",
            Amount::Watts(_) => "W",
            Amount::Lumens(_) => "lm",
            Amount::Candela(_) => "cd",
            Amount::WattsPerSr(_) => "W/sr",
            Amount::Lux(_) => "lx",
            Amount::WattsPerM2(_) => "W/m²",
        }
    }
}

/// What kind of simple light, with its geometry.
#[derive(Clone, Debug, PartialEq)]
pub enum LightKind {
    Point,
    Spot {
        direction: [f64; 3],
        half_angle_rad: f64,
    },
    Cosine {
        direction: [f64; 3],
    },
    Beam {
        direction: [f64; 3],
        /// Disk (diameter `size[0]`) or rectangle (`size[0]` along `up` projected onto the
        /// aperture's plane, `size[1]` across), scene units.
        disk: bool,
        size: [f64; 2],
        up: [f64; 3],
    },
}

/// A simple light as the caller describes it.
#[derive(Clone, Debug, PartialEq)]
pub struct LightDesc {
    pub kind: LightKind,
    pub position: [f64; 3],
    pub amount: Amount,
    pub spectrum: Spectrum,
}

/// A photometric distribution ready to place any number of times (its tables are shared
/// by every placement).
#[derive(Clone, Debug)]
pub struct Distribution {
    pub data: Arc<PhotometricData>,
    pub dist: Arc<Goniometric>,
}

impl Distribution {
    /// Checks and expands `data` (IMAP_ERR_PARSE for an inconsistent table,
    /// IMAP_ERR_NO_LIGHT for one of zeros).
    pub fn new(data: &PhotometricData) -> Result<Self> {
        Ok(Distribution {
            dist: Arc::new(Goniometric::new(data, 1.0)?),
            data: Arc::new(data.clone()),
        })
    }
}

/// How a goniometric luminaire is placed.
#[derive(Clone, Debug, PartialEq)]
pub struct Placement {
    pub position: [f64; 3],
    /// The photometric axis: γ = 0 (type C, the luminaire's nadir) or V = H = 0 (type B).
    pub aim: [f64; 3],
    /// Type C: the C0 direction; type B: the luminaire's up (V = 90°). Its component
    /// along `aim` is ignored.
    pub reference: [f64; 3],
    /// The world's up, for the TILT angle (between `aim` and straight down).
    pub up: [f64; 3],
    /// Multiplies the file's intensities (lamp count, maintenance, dimming).
    pub flux_scale: f64,
    /// When > 0, the luminaire's total luminous flux, lm, instead of the file's.
    pub lumens: f64,
    /// Emit from the file's luminous opening instead of a point.
    pub use_opening: bool,
}

impl Default for Placement {
    fn default() -> Self {
        Placement {
            position: [0.0; 3],
            aim: [0.0, 0.0, -1.0],
            reference: [1.0, 0.0, 0.0],
            up: [0.0, 0.0, 1.0],
            flux_scale: 1.0,
            lumens: 0.0,
            use_opening: false,
        }
    }
}

/// A light: where it is, how its flux is distributed, and its radiant flux per band.
#[derive(Clone, Debug)]
pub struct Light {
    pub position: DVec3,
    pub shape: LightShape,
    /// Radiant flux per band, W.
    pub power: Vec<f64>,
    /// Light group (`Scene::layers`): which layer of the map its photons go to when light
    /// groups are kept; 0 by default.
    pub group: u32,
}

impl Light {
    /// An isotropic point light with radiant flux `power` per band, W.
    pub fn point(position: [f64; 3], power: &[f64], bands: &Bands) -> Result<Self> {
        Self::new(
            &LightDesc {
                kind: LightKind::Point,
                position,
                amount: Amount::WattsPerBand(power.to_vec()),
                spectrum: Spectrum::Equal,
            },
            bands,
            1.0,
        )
    }

    /// A spot light with radiant flux `power` per band, W.
    pub fn spot(
        position: [f64; 3],
        direction: [f64; 3],
        half_angle_rad: f64,
        power: &[f64],
        bands: &Bands,
    ) -> Result<Self> {
        Self::new(
            &LightDesc {
                kind: LightKind::Spot {
                    direction,
                    half_angle_rad,
                },
                position,
                amount: Amount::WattsPerBand(power.to_vec()),
                spectrum: Spectrum::Equal,
            },
            bands,
            1.0,
        )
    }

    /// A simple light. `unit_m` (metres per scene unit) converts a beam's aperture to m².
    pub fn new(desc: &LightDesc, bands: &Bands, unit_m: f64) -> Result<Self> {
        check_coordinates("position", &desc.position)?;
        let shape =
            match &desc.kind {
                LightKind::Point => LightShape::Point,
                LightKind::Spot {
                    direction: d,
                    half_angle_rad,
                } => {
                    let axis = direction("direction", *d)?;
                    check_finite_scalar("half_angle_rad", *half_angle_rad)?;
                    if !(*half_angle_rad > 0.0 && *half_angle_rad <= PI) {
                        bail!(
                            ImapErrInvalidArgument,
                            "half_angle_rad = {half_angle_rad} is not in (0, π]"
                        );
                    }
                    LightShape::Spot {
                        axis,
                        cos_half_angle: half_angle_rad.cos(),
                    }
                }
                LightKind::Cosine { direction: d } => LightShape::Cosine {
                    axis: direction("direction", *d)?,
                },
                LightKind::Beam {
                    direction: d,
                    disk,
                    size,
                    up,
                } => {
                    let axis = direction("direction", *d)?;
                    check_finite("aperture_size", size)?;
                    let (a, b) = if *disk {
                        (size[0], size[0])
                    } else {
                        (size[0], size[1])
                    };
                    if !(a > 0.0 && b > 0.0 && a <= 1e30 && b <= 1e30) {
                        bail!(
                        ImapErrInvalidArgument,
                        "aperture_size = {size:?}: a beam's aperture needs a positive {} (≤ 1e30)",
                        if *disk { "diameter" } else { "width and height" }
                    );
                    }
                    let (u, v) = if *disk {
                        let (t, b) = warp::basis(axis);
                        (t, b)
                    } else {
                        let u = perpendicular("aperture_up", *up, axis, "direction")?;
                        (u, axis.cross(u))
                    };
                    LightShape::Beam {
                        axis,
                        aperture: Aperture {
                            u: u * (0.5 * a),
                            v: v * (0.5 * b),
                            elliptic: *disk,
                        },
                    }
                }
            };
        let power = match &desc.amount {
            Amount::WattsPerBand(p) => {
                if desc.spectrum != Spectrum::Equal {
                    bail!(
                        ImapErrInvalidArgument,
                        "a light given in W per band takes its colour from those values: leave its spectrum at the default (equal)"
                    );
                }
                bands.expand_emission("power", p)?
            }
            amount => {
                let x = amount.value().expect("not per band");
                check_finite_scalar("amount", x)?;
                if x <= 0.0 {
                    bail!(
                        ImapErrInvalidArgument,
                        "amount = {x} {}: a light's amount must be positive",
                        amount.name()
                    );
                }
                let flux = flux_of(&shape, amount, x, unit_m)?;
                scale_spectrum(&desc.spectrum, bands, flux, amount.photometric())?
            }
        };
        Ok(Light {
            position: DVec3::from(desc.position),
            shape,
            power,
            group: 0,
        })
    }

    /// A goniometric luminaire placed from a prepared distribution.
    pub fn placed(
        distribution: &Distribution,
        place: &Placement,
        spectrum: &Spectrum,
        bands: &Bands,
        unit_m: f64,
    ) -> Result<Self> {
        check_coordinates("position", &place.position)?;
        check_finite_scalar("flux_scale", place.flux_scale)?;
        check_finite_scalar("lumens", place.lumens)?;
        if place.flux_scale <= 0.0 || place.flux_scale > 1e30 {
            bail!(
                ImapErrInvalidArgument,
                "flux_scale = {} must be positive (≤ 1e30)",
                place.flux_scale
            );
        }
        if place.lumens < 0.0 || place.lumens > 1e30 {
            bail!(
                ImapErrInvalidArgument,
                "lumens = {} must be 0 (the file's flux) or positive (≤ 1e30)",
                place.lumens
            );
        }
        let aim = direction("aim", place.aim)?;
        let reference = perpendicular("reference", place.reference, aim, "aim")?;
        let up = direction("up", place.up)?;
        let data = &*distribution.data;
        let frame = match data.kind {
            PhotometricType::C => [reference, reference.cross(aim), aim],
            PhotometricType::B => [aim, reference, aim.cross(reference)],
        };
        let dist = distribution.dist.clone();
        let tilt_deg = aim.dot(-up).clamp(-1.0, 1.0).acos().to_degrees();
        let tilt_factor = data.tilt_factor(tilt_deg);
        let lumens = if place.lumens > 0.0 {
            place.lumens
        } else {
            dist.flux() * place.flux_scale * tilt_factor
        };
        if !(lumens > 0.0 && lumens.is_finite()) {
            bail!(
                ImapErrNoLight,
                "the luminaire gives {lumens} lm (the file's flux {} lm × flux_scale {} × TILT factor {tilt_factor} at {tilt_deg:.1}°)",
                dist.flux(),
                place.flux_scale
            );
        }
        let opening = if place.use_opening {
            // Length along C0–C180 (type C) / the luminaire's up (type B), width across.
            let (along, across) = (frame[0], frame[1]);
            let (along, across) = match data.kind {
                PhotometricType::C => (along, across),
                PhotometricType::B => (across, frame[2]),
            };
            let k = 0.5 / unit_m;
            match data.opening {
                Opening::Point => None,
                Opening::Solid { what, .. } => bail!(
                    ImapErrUnsupported,
                    "the file's luminous opening is a {what}: emission from a three-dimensional opening is not supported (place the luminaire as a point: use_opening = 0)"
                ),
                Opening::Rectangle { width, length } => Some(Aperture {
                    u: along * (length * k),
                    v: across * (width * k),
                    elliptic: false,
                }),
                Opening::Ellipse { width, length } => Some(Aperture {
                    u: along * (length * k),
                    v: across * (width * k),
                    elliptic: true,
                }),
            }
        } else {
            None
        };
        let luminous = luminous_parts(&data.opening, data.kind, frame);
        let power = scale_spectrum(spectrum, bands, lumens, true)?;
        let inv_flux = 1.0 / dist.flux();
        Ok(Light {
            position: DVec3::from(place.position),
            shape: LightShape::Luminaire(Arc::new(Luminaire {
                dist,
                frame,
                opening,
                inv_flux,
                luminous,
            })),
            power,
            group: 0,
        })
    }

    /// A sky or environment (`super::sky`).
    pub fn sky(desc: &SkyDesc, bands: &Bands) -> Result<Self> {
        Ok(Self::distant(Distant::sky(desc, bands)?))
    }

    /// The sun (`super::sky`).
    pub fn sun(desc: &SunDesc, bands: &Bands) -> Result<Self> {
        Ok(Self::distant(Distant::sun(desc, bands)?))
    }

    /// The ground's glow of radiance `per_band` below the horizon of `zenith`
    /// (`super::sky::Distant::ground`).
    pub fn ground(zenith: [f64; 3], per_band: Vec<f64>) -> Result<Self> {
        Ok(Self::distant(Distant::ground(zenith, per_band)?))
    }

    fn distant(d: Distant) -> Self {
        let mut power = vec![0.0; d.parts[0].per_band.len()];
        for p in &d.parts {
            for (o, x) in power.iter_mut().zip(&p.per_band) {
                *o += x * p.integral;
            }
        }
        Light {
            position: DVec3::ZERO,
            shape: LightShape::Distant(Arc::new(d)),
            power,
            group: 0,
        }
    }

    /// What `imap_light_flux` reports: radiant flux per band, W, or for a distant light
    /// the irradiance per band it gives an unobstructed horizontal plane, W/m².
    pub fn reported_flux(&self) -> Vec<f64> {
        match &self.shape {
            LightShape::Distant(d) => d.horizontal(),
            _ => self.power.clone(),
        }
    }

    /// Total radiant flux, W.
    #[cfg(test)]
    pub fn watts(&self) -> f64 {
        self.power.iter().sum()
    }
}

/// The total flux (W or lm, as the amount) of a light of `shape` given `amount` = `x`.
fn flux_of(shape: &LightShape, amount: &Amount, x: f64, unit_m: f64) -> Result<f64> {
    let intensity = matches!(amount, Amount::Candela(_) | Amount::WattsPerSr(_));
    let areal = matches!(amount, Amount::Lux(_) | Amount::WattsPerM2(_));
    let flux = match shape {
        LightShape::Beam { aperture, .. } => {
            if intensity {
                bail!(
                    ImapErrInvalidArgument,
                    "a collimated beam has no finite intensity: give it in lx, W/m², lm or W"
                );
            }
            if areal {
                x * aperture.area() * unit_m * unit_m
            } else {
                x
            }
        }
        _ if areal => bail!(
            ImapErrInvalidArgument,
            "{} is an amount for beams: give this light in lm, cd, W or W/sr",
            amount.name()
        ),
        LightShape::Point if intensity => x * 4.0 * PI,
        LightShape::Spot { cos_half_angle, .. } if intensity => {
            x * 2.0 * PI * (1.0 - cos_half_angle)
        }
        LightShape::Cosine { .. } if intensity => x * PI,
        _ => x,
    };
    if !(flux > 0.0 && flux.is_finite()) {
        bail!(
            ImapErrInvalidArgument,
            "amount = {x} {} gives a total flux of {flux}: not a usable amount",
            amount.name()
        );
    }
    Ok(flux)
}

/// The luminous parts of a file's opening in a placed luminaire's `frame` (as
/// `Light::placed` lays out its emitting aperture).
fn luminous_parts(
    opening: &Opening,
    kind: PhotometricType,
    frame: [DVec3; 3],
) -> luminaire::Luminous {
    let (along, across, normal) = match kind {
        PhotometricType::C => (frame[0], frame[1], frame[2]),
        PhotometricType::B => (frame[1], frame[2], frame[0]),
    };
    luminaire::Luminous {
        opening: *opening,
        along,
        across,
        normal,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photometry::BandPhotometry;
    use crate::sampling::PhotonRng;

    fn rgb() -> Bands {
        Bands::rgb()
    }

    #[test]
    fn amounts_become_the_stated_flux() {
        let b = rgb();
        let k = BandPhotometry::new(&b);
        let mk = |kind: LightKind, amount: Amount| {
            Light::new(
                &LightDesc {
                    kind,
                    position: [0.0; 3],
                    amount,
                    spectrum: Spectrum::Equal,
                },
                &b,
                0.5,
            )
            .unwrap()
        };
        let l = mk(LightKind::Point, Amount::Lumens(1000.0));
        assert!((k.luminous(&l.power) - 1000.0).abs() < 1e-9);
        let l = mk(LightKind::Point, Amount::Candela(100.0));
        assert!((k.luminous(&l.power) - 400.0 * PI).abs() < 1e-9);
        let l = mk(
            LightKind::Cosine {
                direction: [0.0, 0.0, -1.0],
            },
            Amount::Candela(1000.0),
        );
        assert!((k.luminous(&l.power) - 1000.0 * PI).abs() < 1e-9);
        let l = mk(
            LightKind::Spot {
                direction: [0.0, 0.0, -1.0],
                half_angle_rad: PI / 3.0,
            },
            Amount::WattsPerSr(2.0),
        );
        assert!((l.watts() - 2.0 * PI).abs() < 1e-12);
        // A 2 × 4 scene-unit aperture at 0.5 m per unit is 2 m²: 100 lx gives 200 lm.
        let l = mk(
            LightKind::Beam {
                direction: [1.0, 0.0, 0.0],
                disk: false,
                size: [2.0, 4.0],
                up: [0.0, 0.0, 1.0],
            },
            Amount::Lux(100.0),
        );
        assert!((k.luminous(&l.power) - 200.0).abs() < 1e-9);
        // Intensities integrate to one watt.
        let shapes = [
            LightShape::Point,
            LightShape::Spot {
                axis: DVec3::Z,
                cos_half_angle: 0.3,
            },
            LightShape::Cosine { axis: DVec3::Z },
        ];
        for s in shapes {
            let mut rng = PhotonRng::new(3, 4);
            let n = 400_000;
            let mut sum = 0.0;
            for _ in 0..n {
                sum += s.intensity_per_watt(warp::uniform_sphere(rng.uniform(), rng.uniform()));
            }
            let total = sum / n as f64 * 4.0 * PI;
            assert!((total - 1.0).abs() < 0.01, "{s:?}: {total}");
        }
    }

    #[test]
    fn bad_amounts_are_refused_by_name() {
        let b = rgb();
        let mk = |kind: LightKind, amount: Amount, spectrum: Spectrum| {
            Light::new(
                &LightDesc {
                    kind,
                    position: [0.0; 3],
                    amount,
                    spectrum,
                },
                &b,
                1.0,
            )
            .unwrap_err()
            .to_string()
        };
        assert!(mk(LightKind::Point, Amount::Lux(1.0), Spectrum::Equal).contains("beams"));
        assert!(mk(LightKind::Point, Amount::Lumens(-1.0), Spectrum::Equal).contains("positive"));
        assert!(mk(LightKind::Point, Amount::Lumens(f64::NAN), Spectrum::Equal).contains("amount"));
        let beam = LightKind::Beam {
            direction: [0.0, 0.0, 1.0],
            disk: true,
            size: [1.0, 0.0],
            up: [0.0; 3],
        };
        assert!(mk(beam, Amount::Candela(1.0), Spectrum::Equal).contains("intensity"));
        assert!(mk(
            LightKind::Point,
            Amount::WattsPerBand(vec![1.0]),
            Spectrum::CieA
        )
        .contains("spectrum"));
    }
}

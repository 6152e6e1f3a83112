//! Distant light: environments (a uniform sky, the CIE standard general skies, an
//! equirectangular HDR image) and the sun, all infinitely far away.
//!
//! A distant source is a radiance L_b(ω) = `per_band[b]` · f(ω) arriving from direction ω
//! (pointing *toward* the source), with f a relative radiance: 1 for a uniform sky and the
//! sun's disk, L/L_z for a CIE sky, the pixel's value for an image channel. Its photons
//! start on a disk of the scene's bounding-sphere radius R perpendicular to ω, outside the
//! sphere, and travel along −ω: every point inside then receives L_b(ω) dω from each
//! direction, whatever the scene's size or position, and the source's flux through the
//! sphere is π R² ∫ L_b dω (`PreparedScene`). Directions are sampled from a table of cells
//! (equal steps in zenith angle and azimuth) by each cell's mean of f; a photon carries
//! f(ω) / (p(ω) ∫f), so the light is exact even where the table is coarse (an image's
//! table is its pixels: the weight is 1).

use super::bands::Bands;
use crate::error::{bail, check_finite, check_finite_scalar, Result};
use crate::photometry::colour::{spectrum_bands, BandPhotometry};
use crate::photometry::Spectrum;
use crate::sampling::{warp, AliasTable};
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};
use std::fmt;
use std::sync::Arc;

/// The sun's angular diameter, degrees.
pub const SUN_DIAMETER_DEG: f64 = 0.53;

/// Rows and columns of an analytic sky's sampling table (over the upper hemisphere), and
/// the sub-samples per cell side its means take.
const SKY_ROWS: usize = 64;
const SKY_COLS: usize = 128;
const SKY_SUB: usize = 4;

/// The CIE standard general sky's gradation (a, b) and indicatrix (c, d, e) parameters,
/// types 1–15 (ISO 15469:2004 / CIE S 011/E:2003, table 1).
pub const CIE_SKY_PARAMETERS: [[f64; 5]; 15] = [
    [4.0, -0.70, 0.0, -1.0, 0.00],
    [4.0, -0.70, 2.0, -1.5, 0.15],
    [1.1, -0.80, 0.0, -1.0, 0.00],
    [1.1, -0.80, 2.0, -1.5, 0.15],
    [0.0, -1.00, 0.0, -1.0, 0.00],
    [0.0, -1.00, 2.0, -1.5, 0.15],
    [0.0, -1.00, 5.0, -2.5, 0.30],
    [0.0, -1.00, 10.0, -3.0, 0.45],
    [-1.0, -0.55, 2.0, -1.5, 0.15],
    [-1.0, -0.55, 5.0, -2.5, 0.30],
    [-1.0, -0.55, 10.0, -3.0, 0.45],
    [-1.0, -0.32, 10.0, -3.0, 0.45],
    [-1.0, -0.32, 16.0, -3.0, 0.30],
    [-1.0, -0.15, 16.0, -3.0, 0.30],
    [-1.0, -0.15, 24.0, -2.8, 0.15],
];

/// The sky's orientation in the scene: the zenith, north and east (unit, orthogonal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyFrame {
    pub zenith: DVec3,
    pub north: DVec3,
    pub east: DVec3,
}

impl SkyFrame {
    /// The frame of `zenith` and `north` (its part along the zenith is ignored).
    pub fn new(zenith: [f64; 3], north: [f64; 3]) -> Result<Self> {
        check_finite("zenith", &zenith)?;
        check_finite("north", &north)?;
        let Some(z) = super::light::unit_vector(zenith) else {
            bail!(ImapErrInvalidArgument, "zenith is the zero vector");
        };
        let Some(n) = super::light::unit_vector(north) else {
            bail!(ImapErrInvalidArgument, "north is the zero vector");
        };
        let n = n - z * n.dot(z);
        if n.length() < 1e-6 {
            bail!(
                ImapErrInvalidArgument,
                "north is parallel to zenith: it must give a horizontal direction"
            );
        }
        let north = n.normalize();
        Ok(SkyFrame {
            zenith: z,
            north,
            east: north.cross(z),
        })
    }

    /// The direction at `azimuth` (radians from north toward east) and `zenith_angle`.
    pub fn direction(&self, azimuth: f64, zenith_angle: f64) -> DVec3 {
        let s = zenith_angle.sin();
        (self.north * (s * azimuth.cos())
            + self.east * (s * azimuth.sin())
            + self.zenith * zenith_angle.cos())
        .normalize()
    }

    /// (azimuth in [0, 2π), cos of the zenith angle) of unit direction `d`.
    #[inline]
    fn angles(&self, d: DVec3) -> (f64, f64) {
        let a = d.dot(self.east).atan2(d.dot(self.north));
        let a = if a < 0.0 { a + 2.0 * PI } else { a };
        (a, d.dot(self.zenith).clamp(-1.0, 1.0))
    }
}

/// The relative radiance f of a distant source.
#[derive(Clone)]
pub enum Radiance {
    /// 1 over the upper hemisphere (`sphere`: over every direction).
    Uniform { sphere: bool },
    /// L/L_z of a CIE standard general sky: `p` its (a, b, c, d, e), `sun` the direction
    /// toward the sun; 0 below the horizon.
    Cie { kind: u8, p: [f64; 5], sun: DVec3 },
    /// One channel of an equirectangular image, rows from the zenith down, its centre
    /// column toward north (before `rotation`, radians toward east); the pixel's value
    /// over the pixel's solid angle.
    Image {
        width: usize,
        height: usize,
        values: Arc<Vec<f32>>,
        rotation: f64,
    },
    /// 1 inside the sun's disk around `axis` (1 − cos of its angular radius
    /// `one_minus_cos`).
    Sun { axis: DVec3, one_minus_cos: f64 },
    /// 1 below the horizon: the ground's glow (Radiance's), a uniform lower hemisphere.
    Ground,
}

/// The sampling table of a sky: cells of equal zenith-angle and azimuth steps.
#[derive(Clone, Debug)]
struct Table {
    rows: usize,
    cols: usize,
    /// Zenith angle the rows span ([0, `theta_max`]).
    theta_max: f64,
    /// Azimuth of the first column's left edge.
    azimuth0: f64,
    /// cos of each row's upper and lower edges (rows + 1 values).
    cos_edges: Vec<f64>,
    cells: AliasTable,
}

/// A distant source with its table, f's integrals and radiance per band per unit of f.
#[derive(Clone)]
pub struct DistantPart {
    pub frame: SkyFrame,
    pub radiance: Radiance,
    table: Option<Table>,
    /// ∫ f dω, sr.
    pub integral: f64,
    /// ∫ f max(cos Z, 0) dω: the horizontal irradiance per unit of f's radiance, sr.
    pub horizontal: f64,
    /// Radiance per band per unit of f, W/(m² sr).
    pub per_band: Vec<f64>,
}

impl DistantPart {
    /// Whether this part is the sun's disk.
    pub fn is_sun(&self) -> bool {
        matches!(self.radiance, Radiance::Sun { .. })
    }
}

impl fmt::Debug for DistantPart {
    // An image's pixels are summarised by a hash: the scene's description (state
    // fingerprints) must tell different images apart without printing megapixels.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut d = f.debug_struct("DistantPart");
        d.field("frame", &self.frame);
        match &self.radiance {
            Radiance::Uniform { sphere } => d.field("uniform_sphere", sphere),
            Radiance::Cie { kind, sun, .. } => d.field("cie", &(kind, sun)),
            Radiance::Image {
                width,
                height,
                values,
                rotation,
            } => {
                let mut h = xxhash_rust::xxh3::Xxh3::new();
                for v in values.iter() {
                    h.update(&v.to_le_bytes());
                }
                d.field("image", &(width, height, rotation, h.digest()))
            }
            Radiance::Sun {
                axis,
                one_minus_cos,
            } => d.field("sun", &(axis, one_minus_cos)),
            Radiance::Ground => d.field("ground", &true),
        };
        d.field("per_band", &self.per_band).finish()
    }
}

/// L/L_z of CIE standard general sky `kind` (1–15) at an element of zenith angle `z`
/// and angular distance `chi` from the sun, the sun at zenith angle `zs` (radians); 0
/// below the horizon.
pub fn cie_luminance(kind: u32, z: f64, chi: f64, zs: f64) -> f64 {
    let p = &CIE_SKY_PARAMETERS[(kind.clamp(1, 15) - 1) as usize];
    let cz = z.cos();
    if cz <= 0.0 {
        return 0.0;
    }
    cie_relative(p, cz, chi, zs)
}

/// The CIE sky's L/L_z at zenith angle `z` (cos `cz`) and angle `chi` from the sun, for
/// the sun at zenith angle `zs`.
fn cie_relative(p: &[f64; 5], cz: f64, chi: f64, zs: f64) -> f64 {
    let [a, b, c, d, e] = *p;
    let gradation = |cz: f64| {
        if cz <= 0.0 {
            1.0
        } else {
            1.0 + a * (b / cz).exp()
        }
    };
    let indicatrix =
        |x: f64| 1.0 + c * ((d * x).exp() - (d * FRAC_PI_2).exp()) + e * x.cos().powi(2);
    indicatrix(chi) * gradation(cz) / (indicatrix(zs) * gradation(1.0))
}

impl DistantPart {
    /// A sky (sampled by a table), not the sun.
    #[inline]
    pub fn is_sky(&self) -> bool {
        self.table.is_some()
    }

    /// f toward unit direction `d`.
    #[inline]
    pub fn value(&self, d: DVec3) -> f64 {
        match &self.radiance {
            Radiance::Uniform { sphere } => {
                if *sphere || d.dot(self.frame.zenith) > 0.0 {
                    1.0
                } else {
                    0.0
                }
            }
            Radiance::Cie { p, sun, .. } => {
                let cz = d.dot(self.frame.zenith);
                if cz <= 0.0 {
                    return 0.0;
                }
                let chi = d.dot(*sun).clamp(-1.0, 1.0).acos();
                let zs = sun.dot(self.frame.zenith).clamp(-1.0, 1.0).acos();
                cie_relative(p, cz, chi, zs)
            }
            Radiance::Image { width, values, .. } => {
                let t = self.table.as_ref().expect("an image has a table");
                let (i, j) = t.cell(&self.frame, d);
                values[i * width + j] as f64
            }
            Radiance::Sun {
                axis,
                one_minus_cos,
            } => {
                // 1 − cos α without cancellation: |d − axis|²/2.
                if (d - *axis).length_squared() * 0.5 <= *one_minus_cos {
                    1.0
                } else {
                    0.0
                }
            }
            Radiance::Ground => {
                if d.dot(self.frame.zenith) < 0.0 {
                    1.0
                } else {
                    0.0
                }
            }
        }
    }

    /// ∫ f(ω) max(ω·n, 0) dω over every direction, sr: the irradiance per unit of f's
    /// radiance on an open plane facing unit `n` (what a window portal facing `n` lets
    /// in). Exact for uniform skies and the ground, for the sun's disk wherever it lies
    /// wholly in front of the plane (0 where it does not: at most a grazing sliver), and
    /// for tabulated skies by 4 × 4 points per cell of their table (an analytic sky's
    /// 64 × 128 cells, as its own integral; 2 × 2 per pixel of an image).
    pub fn cos_integral(&self, n: DVec3) -> f64 {
        let up = n.dot(self.frame.zenith).clamp(-1.0, 1.0);
        match &self.radiance {
            Radiance::Uniform { sphere: true } => PI,
            Radiance::Uniform { sphere: false } => PI * (1.0 + up) / 2.0,
            Radiance::Ground => PI * (1.0 - up) / 2.0,
            Radiance::Sun {
                axis,
                one_minus_cos,
            } => {
                // The mean direction over a cap is axis (1 + cos δ)/2.
                let cos_d = 1.0 - one_minus_cos;
                let sin_d = (one_minus_cos * (1.0 + cos_d)).sqrt();
                let c = axis.dot(n);
                if c > sin_d {
                    self.integral * c * (1.0 + cos_d) / 2.0
                } else {
                    0.0
                }
            }
            Radiance::Cie { .. } | Radiance::Image { .. } => {
                let t = self.table.as_ref().expect("a tabulated sky");
                let sub = match &self.radiance {
                    Radiance::Image { .. } => 2,
                    _ => SKY_SUB,
                };
                let mut sum = 0.0;
                for i in 0..t.rows {
                    let omega = t.solid_angle(i);
                    for j in 0..t.cols {
                        let f_cos = |d: DVec3| self.value(d) * d.dot(n).max(0.0);
                        sum += t.means_sub(&self.frame, i, j, sub, f_cos).0 * omega;
                    }
                }
                sum
            }
        }
    }

    /// The sampling density of direction `d`, 1/sr.
    #[inline]
    pub fn pdf(&self, d: DVec3) -> f64 {
        match &self.table {
            Some(t) => {
                let (i, j) = t.cell(&self.frame, d);
                t.cells.pdf(i * t.cols + j) / t.solid_angle(i)
            }
            None => match &self.radiance {
                Radiance::Sun { one_minus_cos, .. } => {
                    if self.value(d) > 0.0 {
                        1.0 / (2.0 * PI * one_minus_cos)
                    } else {
                        0.0
                    }
                }
                _ => unreachable!("only the sun has no table"),
            },
        }
    }

    /// A direction toward the source and its weight f / (p ∫f) (mean 1).
    #[inline]
    pub fn sample(&self, u: [f64; 3]) -> (DVec3, f64) {
        let d = match (&self.table, &self.radiance) {
            (
                None,
                Radiance::Sun {
                    axis,
                    one_minus_cos,
                },
            ) => {
                return (
                    warp::uniform_narrow_cone(*axis, *one_minus_cos, u[0], u[1]),
                    1.0,
                )
            }
            (Some(t), _) => t.sample(&self.frame, u),
            (None, _) => unreachable!("only the sun has no table"),
        };
        let p = self.pdf(d);
        let w = if p > 0.0 {
            self.value(d) / (p * self.integral)
        } else {
            0.0
        };
        (d, w)
    }
}

impl Table {
    fn solid_angle(&self, row: usize) -> f64 {
        (self.cos_edges[row] - self.cos_edges[row + 1]) * 2.0 * PI / self.cols as f64
    }

    /// The cell of unit direction `d`.
    #[inline]
    fn cell(&self, frame: &SkyFrame, d: DVec3) -> (usize, usize) {
        let (a, cz) = frame.angles(d);
        let z = cz.acos();
        let i = ((z / self.theta_max * self.rows as f64) as usize).min(self.rows - 1);
        let mut a = (a - self.azimuth0) / (2.0 * PI);
        a -= a.floor();
        let j = ((a * self.cols as f64) as usize).min(self.cols - 1);
        (i, j)
    }

    fn sample(&self, frame: &SkyFrame, u: [f64; 3]) -> DVec3 {
        let k = self.cells.sample(u[0]);
        let (i, j) = (k / self.cols, k % self.cols);
        let a = self.azimuth0 + 2.0 * PI * (j as f64 + u[1]) / self.cols as f64;
        let cz = self.cos_edges[i] + (self.cos_edges[i + 1] - self.cos_edges[i]) * u[2];
        let s = (1.0 - cz * cz).max(0.0).sqrt();
        (frame.north * (s * a.cos()) + frame.east * (s * a.sin()) + frame.zenith * cz).normalize()
    }

    /// A table over `rows` × `cols` cells spanning zenith angles [0, `theta_max`] with
    /// weights `w(i, j)` (the cell's mean f; any positive floor is the caller's).
    fn new(
        rows: usize,
        cols: usize,
        theta_max: f64,
        azimuth0: f64,
        w: impl Fn(usize, usize) -> f64,
    ) -> Result<Self> {
        let cos_edges: Vec<f64> = (0..=rows)
            .map(|i| {
                if i == rows && (theta_max - FRAC_PI_2).abs() < 1e-15 {
                    0.0
                } else {
                    (theta_max * i as f64 / rows as f64).cos()
                }
            })
            .collect();
        let mut t = Table {
            rows,
            cols,
            theta_max,
            azimuth0,
            cos_edges,
            cells: AliasTable::new(&[1.0]).expect("one cell"),
        };
        let mut weights = Vec::with_capacity(rows * cols);
        for i in 0..rows {
            let omega = t.solid_angle(i);
            for j in 0..cols {
                weights.push(w(i, j) * omega);
            }
        }
        t.cells = AliasTable::new(&weights).map_err(|why| {
            crate::error::Error::new(
                crate::error::ImapStatus::ImapErrNoLight,
                format!("the sky's directions cannot be sampled ({why})"),
            )
        })?;
        Ok(t)
    }

    /// Means of `f` and of f·max(cos Z, 0) over cell (i, j): `SKY_SUB`² points equally
    /// spaced in azimuth and cos Z (equal solid angle).
    fn means(&self, frame: &SkyFrame, i: usize, j: usize, f: impl Fn(DVec3) -> f64) -> (f64, f64) {
        self.means_sub(frame, i, j, SKY_SUB, f)
    }

    /// `means` with `sub`² points per cell.
    fn means_sub(
        &self,
        frame: &SkyFrame,
        i: usize,
        j: usize,
        sub: usize,
        f: impl Fn(DVec3) -> f64,
    ) -> (f64, f64) {
        let (mut m, mut h) = (0.0, 0.0);
        for a in 0..sub {
            for b in 0..sub {
                let u = [(a as f64 + 0.5) / sub as f64, (b as f64 + 0.5) / sub as f64];
                let az = self.azimuth0 + 2.0 * PI * (j as f64 + u[0]) / self.cols as f64;
                let cz = self.cos_edges[i] + (self.cos_edges[i + 1] - self.cos_edges[i]) * u[1];
                let s = (1.0 - cz * cz).max(0.0).sqrt();
                let d =
                    frame.north * (s * az.cos()) + frame.east * (s * az.sin()) + frame.zenith * cz;
                let v = f(d.normalize());
                m += v;
                h += v * cz.max(0.0);
            }
        }
        let n = (sub * sub) as f64;
        (m / n, h / n)
    }
}

/// How bright a sky or the sun is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SkyAmount {
    /// Radiance over all bands, W/(m² sr): a uniform sky's, a CIE sky's at the zenith.
    Radiance(f64),
    /// Luminance, cd/m² (as `Radiance`).
    Luminance(f64),
    /// The irradiance it gives an unobstructed horizontal plane, W/m² over all bands.
    HorizontalIrradiance(f64),
    /// The illuminance it gives an unobstructed horizontal plane, lx.
    HorizontalIlluminance(f64),
    /// The sun's direct normal irradiance, W/m² over all bands.
    NormalIrradiance(f64),
    /// The sun's direct normal illuminance, lx.
    NormalIlluminance(f64),
    /// An image's pixel values times this factor are radiance per channel, W/(m² sr).
    Scale(f64),
}

impl SkyAmount {
    fn value(self) -> f64 {
        match self {
            SkyAmount::Radiance(x)
            | SkyAmount::Luminance(x)
            | SkyAmount::HorizontalIrradiance(x)
            | SkyAmount::HorizontalIlluminance(x)
            | SkyAmount::NormalIrradiance(x)
            | SkyAmount::NormalIlluminance(x)
            | SkyAmount::Scale(x) => x,
        }
    }

    fn photometric(self) -> bool {
        matches!(
            self,
            SkyAmount::Luminance(_)
                | SkyAmount::HorizontalIlluminance(_)
                | SkyAmount::NormalIlluminance(_)
        )
    }

    fn name(self) -> &'static str {
        match self {
            SkyAmount::Radiance(_) => "radiance (W/(m² sr))",
            SkyAmount::Luminance(_) => "luminance (cd/m²)",
            SkyAmount::HorizontalIrradiance(_) => "horizontal irradiance (W/m²)",
            SkyAmount::HorizontalIlluminance(_) => "horizontal illuminance (lx)",
            SkyAmount::NormalIrradiance(_) => "direct normal irradiance (W/m²)",
            SkyAmount::NormalIlluminance(_) => "direct normal illuminance (lx)",
            SkyAmount::Scale(_) => "scale",
        }
    }
}

/// What kind of sky.
#[derive(Clone, Debug, PartialEq)]
pub enum SkyKind {
    /// Uniform radiance over the upper hemisphere, or over every direction (`sphere`).
    Uniform { sphere: bool },
    /// CIE standard general sky `kind` (1–15) with the sun at `sun_azimuth_deg` (from
    /// north toward east) and `sun_zenith_deg` (0–90). Both NaN: no sun given, which only
    /// types 1, 3 and 5 (flat indicatrix) accept; the others are refused.
    Cie {
        kind: u32,
        sun_azimuth_deg: f64,
        sun_zenith_deg: f64,
    },
    /// An equirectangular image, `rgb` holding `width × height` linear RGB triples, rows
    /// from the zenith down, the centre column toward north (before the rotation).
    Image {
        width: usize,
        height: usize,
        rgb: Arc<Vec<f32>>,
    },
}

/// A sky as the caller describes it.
#[derive(Clone, Debug, PartialEq)]
pub struct SkyDesc {
    pub kind: SkyKind,
    pub amount: SkyAmount,
    /// Colour of a uniform or CIE sky (an image has its own).
    pub spectrum: Spectrum,
    pub zenith: [f64; 3],
    pub north: [f64; 3],
    /// Turns the sky about the zenith, degrees toward east (an image's content at
    /// azimuth a appears at a + rotation).
    pub rotation_deg: f64,
}

impl Default for SkyDesc {
    fn default() -> Self {
        SkyDesc {
            kind: SkyKind::Uniform { sphere: false },
            amount: SkyAmount::Luminance(0.0),
            spectrum: Spectrum::CieD65,
            zenith: [0.0, 0.0, 1.0],
            north: [0.0, 1.0, 0.0],
            rotation_deg: 0.0,
        }
    }
}

/// The sun as the caller describes it.
#[derive(Clone, Debug, PartialEq)]
pub struct SunDesc {
    pub azimuth_deg: f64,
    pub zenith_deg: f64,
    /// `NormalIrradiance` or `NormalIlluminance`.
    pub amount: SkyAmount,
    pub spectrum: Spectrum,
    pub zenith: [f64; 3],
    pub north: [f64; 3],
}

impl Default for SunDesc {
    /// The sun at the zenith of a z-up scene (north +y), D65, no amount yet.
    fn default() -> Self {
        SunDesc {
            azimuth_deg: 0.0,
            zenith_deg: 0.0,
            amount: SkyAmount::NormalIrradiance(0.0),
            spectrum: Spectrum::CieD65,
            zenith: [0.0, 0.0, 1.0],
            north: [0.0, 1.0, 0.0],
        }
    }
}

/// A distant light: one part per colour channel (one for everything but a colour image).
#[derive(Debug)]
pub struct Distant {
    pub parts: Vec<Arc<DistantPart>>,
}

impl Distant {
    /// Pixels over the parts' images (0 for analytic skies and the sun).
    pub fn image_pixels(&self) -> u64 {
        self.parts
            .iter()
            .map(|p| match &p.radiance {
                Radiance::Image { values, .. } => values.len() as u64,
                _ => 0,
            })
            .sum()
    }

    /// Irradiance per band on an unobstructed horizontal plane, W/m².
    pub fn horizontal(&self) -> Vec<f64> {
        let nb = self.parts[0].per_band.len();
        let mut out = vec![0.0; nb];
        for p in &self.parts {
            for (o, x) in out.iter_mut().zip(&p.per_band) {
                *o += x * p.horizontal;
            }
        }
        out
    }
}

fn check_angle(name: &str, x: f64, lo: f64, hi: f64) -> Result<()> {
    check_finite_scalar(name, x)?;
    if !(lo..=hi).contains(&x) {
        bail!(
            ImapErrInvalidArgument,
            "{name} = {x} is not in [{lo}, {hi}]"
        );
    }
    Ok(())
}

/// The per-band radiance per unit of f of `spectrum` for a total `x` (W or lm) per unit
/// of `denominator` (the integral the amount refers to).
fn per_band(
    spectrum: &Spectrum,
    bands: &Bands,
    x: f64,
    photometric: bool,
    denominator: f64,
) -> Result<Vec<f64>> {
    let out = super::light::scale_spectrum(spectrum, bands, x / denominator, photometric)?;
    if out.iter().any(|v| !v.is_finite()) {
        bail!(
            ImapErrInvalidArgument,
            "amount = {x}: the radiance per band is not representable"
        );
    }
    Ok(out)
}

fn check_amount(amount: SkyAmount) -> Result<f64> {
    let x = amount.value();
    check_finite_scalar("amount", x)?;
    if !(x > 0.0 && x <= 1e30) {
        bail!(
            ImapErrInvalidArgument,
            "amount = {x} ({}): it must be positive (≤ 1e30)",
            amount.name()
        );
    }
    Ok(x)
}

impl Distant {
    /// A sky.
    pub fn sky(desc: &SkyDesc, bands: &Bands) -> Result<Self> {
        let frame = SkyFrame::new(desc.zenith, desc.north)?;
        check_angle("rotation_deg", desc.rotation_deg, -360.0, 360.0)?;
        let x = check_amount(desc.amount)?;
        let rotation = desc.rotation_deg.to_radians();
        let mut parts = Vec::new();
        match &desc.kind {
            SkyKind::Uniform { sphere } => {
                let t = Table::new(
                    if *sphere { 2 } else { 1 },
                    1,
                    if *sphere { PI } else { FRAC_PI_2 },
                    0.0,
                    |_, _| 1.0,
                )?;
                let integral = if *sphere { 4.0 * PI } else { 2.0 * PI };
                let part = DistantPart {
                    frame,
                    radiance: Radiance::Uniform { sphere: *sphere },
                    table: Some(t),
                    integral,
                    horizontal: PI,
                    per_band: Vec::new(),
                };
                parts.push(part);
            }
            SkyKind::Cie {
                kind,
                sun_azimuth_deg,
                sun_zenith_deg,
            } => {
                if !(1..=15).contains(kind) {
                    bail!(
                        ImapErrInvalidArgument,
                        "cie_type = {kind}: the CIE standard general skies are types 1–15"
                    );
                }
                // No sun (both NaN): only the types whose indicatrix is flat (1, 3, 5)
                // do not depend on where it is.
                let (sun_azimuth_deg, sun_zenith_deg) =
                    match (sun_azimuth_deg.is_nan() && sun_zenith_deg.is_nan(), kind) {
                        (true, 1 | 3 | 5) => (&0.0, &0.0),
                        (true, _) => bail!(
                            ImapErrInvalidArgument,
                            "sun_azimuth_deg and sun_zenith_deg are not set: a CIE sky of type {kind} needs its sun's position (only types 1, 3 and 5 do not depend on it)"
                        ),
                        (false, _) => (sun_azimuth_deg, sun_zenith_deg),
                    };
                check_angle("sun_azimuth_deg", *sun_azimuth_deg, -360.0, 360.0)?;
                check_angle("sun_zenith_deg", *sun_zenith_deg, 0.0, 90.0)?;
                let sun = frame.direction(
                    sun_azimuth_deg.to_radians() + rotation,
                    sun_zenith_deg.to_radians(),
                );
                let radiance = Radiance::Cie {
                    kind: *kind as u8,
                    p: CIE_SKY_PARAMETERS[*kind as usize - 1],
                    sun,
                };
                parts.push(DistantPart::tabulated(frame, radiance, rotation)?);
            }
            SkyKind::Image { width, height, rgb } => {
                let (w, h) = (*width, *height);
                if w == 0 || h == 0 || w > 1 << 16 || h > 1 << 16 {
                    bail!(
                        ImapErrInvalidArgument,
                        "the image is {w} × {h} pixels: each side must be 1–65536"
                    );
                }
                if rgb.len() != w * h * 3 {
                    bail!(
                        ImapErrInvalidArgument,
                        "the image holds {} values; {w} × {h} RGB pixels need {}",
                        rgb.len(),
                        w * h * 3
                    );
                }
                if let Some(i) = rgb.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
                    bail!(
                        ImapErrNonFinite,
                        "pixel ({}, {}) channel {} of the image is {}: radiance must be finite and ≥ 0",
                        (i / 3) % w,
                        i / 3 / w,
                        i % 3,
                        rgb[i]
                    );
                }
                let mut channels: Vec<Vec<f32>> = (0..3)
                    .map(|c| rgb.iter().skip(c).step_by(3).copied().collect())
                    .collect();
                let grey = channels[0] == channels[1] && channels[1] == channels[2];
                let used: Vec<usize> = if grey {
                    vec![0]
                } else {
                    (0..3)
                        .filter(|&c| channels[c].iter().any(|&v| v > 0.0))
                        .collect()
                };
                for c in used {
                    let values = Arc::new(std::mem::take(&mut channels[c]));
                    if values.iter().all(|&v| v == 0.0) {
                        continue;
                    }
                    let radiance = Radiance::Image {
                        width: w,
                        height: h,
                        values: values.clone(),
                        rotation,
                    };
                    let azimuth0 = -PI + rotation;
                    let t = Table::new(h, w, PI, azimuth0, |i, j| values[i * w + j] as f64)?;
                    let mut integral = 0.0;
                    let mut horizontal = 0.0;
                    for i in 0..h {
                        let row: f64 = values[i * w..(i + 1) * w].iter().map(|&v| v as f64).sum();
                        let omega = t.solid_angle(i);
                        integral += row * omega;
                        // ∫ cos Z dω over the row's part above the horizon.
                        let (c0, c1) = (t.cos_edges[i].max(0.0), t.cos_edges[i + 1].max(0.0));
                        horizontal += row * (c0 * c0 - c1 * c1) * 0.5 * 2.0 * PI / w as f64;
                    }
                    // A grey image's one part carries the three channels' bands.
                    let mut per_band = vec![0.0; bands.count()];
                    for k in 0..3 {
                        if grey || k == c {
                            let mut rgb = [0.0; 3];
                            rgb[k] = 1.0;
                            let cb = channel_bands(&Spectrum::Rgb(rgb), bands);
                            per_band.iter_mut().zip(cb).for_each(|(p, x)| *p += x);
                        }
                    }
                    if per_band.iter().all(|&x| x == 0.0) {
                        continue;
                    }
                    parts.push(DistantPart {
                        frame,
                        radiance,
                        table: Some(t),
                        integral,
                        horizontal,
                        per_band,
                    });
                }
                if parts.is_empty() {
                    bail!(
                        ImapErrNoLight,
                        "the image is black in the context's bands: it gives no light"
                    );
                }
            }
        }
        // Scale to the amount.
        let image = matches!(desc.kind, SkyKind::Image { .. });
        match desc.amount {
            SkyAmount::Scale(k) if image => {
                for p in &mut parts {
                    p.per_band.iter_mut().for_each(|v| *v *= k);
                }
            }
            SkyAmount::Radiance(_) | SkyAmount::Luminance(_) if !image => {
                let p = &mut parts[0];
                p.per_band = per_band(&desc.spectrum, bands, x, desc.amount.photometric(), 1.0)?;
            }
            SkyAmount::HorizontalIrradiance(_) | SkyAmount::HorizontalIlluminance(_) => {
                if !image {
                    let p = &mut parts[0];
                    p.per_band = per_band(
                        &desc.spectrum,
                        bands,
                        x,
                        desc.amount.photometric(),
                        p.horizontal,
                    )?;
                } else {
                    let phot = BandPhotometry::new(bands);
                    let now: f64 = parts
                        .iter()
                        .map(|p| {
                            let e: Vec<f64> = p.per_band.iter().map(|v| v * p.horizontal).collect();
                            if desc.amount.photometric() {
                                phot.luminous(&e)
                            } else {
                                e.iter().sum()
                            }
                        })
                        .sum();
                    if !(now > 0.0 && now.is_finite()) {
                        bail!(
                            ImapErrNoLight,
                            "the image gives no {} above the horizon: it cannot be scaled to a horizontal amount",
                            if desc.amount.photometric() { "visible light" } else { "light" }
                        );
                    }
                    for p in &mut parts {
                        p.per_band.iter_mut().for_each(|v| *v *= x / now);
                    }
                }
            }
            a => bail!(
                ImapErrInvalidArgument,
                "{} cannot be given by its {}: {}",
                match desc.kind {
                    SkyKind::Uniform { .. } => "a uniform sky",
                    SkyKind::Cie { .. } => "a CIE sky",
                    SkyKind::Image { .. } => "an image sky",
                },
                a.name(),
                if image {
                    "give an image a scale or a horizontal irradiance or illuminance"
                } else {
                    "give it a radiance, a luminance, or a horizontal irradiance or illuminance"
                }
            ),
        }
        if parts
            .iter()
            .any(|p| p.per_band.iter().any(|v| !v.is_finite()))
        {
            bail!(
                ImapErrInvalidArgument,
                "amount = {x}: the sky's radiance is not representable"
            );
        }
        Ok(Distant {
            parts: parts.into_iter().map(Arc::new).collect(),
        })
    }

    /// The sun: a disk of `SUN_DIAMETER_DEG`, uniformly bright.
    pub fn sun(desc: &SunDesc, bands: &Bands) -> Result<Self> {
        let frame = SkyFrame::new(desc.zenith, desc.north)?;
        check_angle("azimuth_deg", desc.azimuth_deg, -360.0, 360.0)?;
        check_angle("zenith_deg", desc.zenith_deg, 0.0, 90.0)?;
        let x = check_amount(desc.amount)?;
        if !matches!(
            desc.amount,
            SkyAmount::NormalIrradiance(_) | SkyAmount::NormalIlluminance(_)
        ) {
            bail!(
                ImapErrInvalidArgument,
                "the sun cannot be given by its {}: give its direct normal irradiance (W/m²) or illuminance (lx)",
                desc.amount.name()
            );
        }
        let axis = frame.direction(desc.azimuth_deg.to_radians(), desc.zenith_deg.to_radians());
        let delta = (0.5 * SUN_DIAMETER_DEG).to_radians();
        let (s, c) = delta.sin_cos();
        let one_minus_cos = s * s / (1.0 + c);
        // E_n = ∫ L cos α dω over the disk = L π sin²δ.
        let normal = PI * s * s;
        let per_band = per_band(&desc.spectrum, bands, x, desc.amount.photometric(), normal)?;
        Ok(Distant {
            parts: vec![Arc::new(DistantPart {
                frame,
                radiance: Radiance::Sun {
                    axis,
                    one_minus_cos,
                },
                table: None,
                integral: 2.0 * PI * one_minus_cos,
                horizontal: normal * axis.dot(frame.zenith),
                per_band,
            })],
        })
    }
}

impl Distant {
    /// The ground's glow below the horizon of `zenith` (north is immaterial): a uniform
    /// radiance per band `per_band`, W/(m² sr). As Radiance's ground glow it stands for
    /// an open, diffusely reflecting ground of reflectance ρ lit by the sky and the sun:
    /// L = ρ E_h / π (`Context::add_ground`). It gives an open horizontal plane nothing
    /// from above and π L on its underside.
    pub fn ground(zenith: [f64; 3], per_band: Vec<f64>) -> Result<Self> {
        let z = DVec3::from(zenith);
        check_finite("zenith", &zenith)?;
        let north = if z.normalize_or_zero().x.abs() < 0.9 {
            DVec3::X
        } else {
            DVec3::Y
        };
        let north = (north - z.normalize_or_zero() * north.dot(z.normalize_or_zero())).to_array();
        let frame = SkyFrame::new(zenith, north)?;
        // Two rows over [0, π]: only the lower one is sampled.
        let table = Table::new(2, 1, PI, 0.0, |i, _| if i == 1 { 1.0 } else { 0.0 })?;
        Ok(Distant {
            parts: vec![Arc::new(DistantPart {
                frame,
                radiance: Radiance::Ground,
                table: Some(table),
                integral: 2.0 * PI,
                horizontal: 0.0,
                per_band,
            })],
        })
    }
}

/// Radiance per band per unit of an image channel's value: the channel's value is its
/// radiance summed over the bands it covers (zeros when it covers none).
fn channel_bands(spectrum: &Spectrum, bands: &Bands) -> Vec<f64> {
    let rel = spectrum_bands(spectrum, bands);
    let sum: f64 = rel.iter().sum();
    if sum > 0.0 {
        rel.iter().map(|r| r / sum).collect()
    } else {
        rel.iter().map(|_| 0.0).collect()
    }
}

impl DistantPart {
    /// An analytic sky with its table over the upper hemisphere.
    fn tabulated(frame: SkyFrame, radiance: Radiance, rotation: f64) -> Result<Self> {
        let mut part = DistantPart {
            frame,
            radiance,
            table: None,
            integral: 0.0,
            horizontal: 0.0,
            per_band: Vec::new(),
        };
        let probe = Table::new(SKY_ROWS, SKY_COLS, FRAC_PI_2, rotation, |_, _| 1.0)?;
        let mut means = Vec::with_capacity(SKY_ROWS * SKY_COLS);
        let (mut integral, mut horizontal) = (0.0, 0.0);
        for i in 0..SKY_ROWS {
            let omega = probe.solid_angle(i);
            for j in 0..SKY_COLS {
                let (m, h) = probe.means(&frame, i, j, |d| part.value(d));
                means.push(m);
                integral += m * omega;
                horizontal += h * omega;
            }
        }
        // A floor keeps every cell sampled: the weights stay bounded wherever f is.
        let floor = 0.01 * integral / (2.0 * PI);
        part.table = Some(Table::new(
            SKY_ROWS,
            SKY_COLS,
            FRAC_PI_2,
            rotation,
            |i, j| means[i * SKY_COLS + j].max(floor),
        )?);
        part.integral = integral;
        part.horizontal = horizontal;
        Ok(part)
    }
}

/// Reads an equirectangular environment image (Radiance RGBE `.hdr`/`.pic` or OpenEXR
/// `.exr`, by content): (width, height, linear RGB triples). The file must be a regular
/// file of at most `limit` bytes; `check(width, height, file bytes)` decides from the
/// header, before any pixel is decoded (a memory budget). IMAP_ERR_IO when the file
/// cannot be read, IMAP_ERR_PARSE naming the file when it is not such an image,
/// IMAP_ERR_MEMORY_BUDGET past `limit`.
pub fn read_image(
    path: &std::path::Path,
    limit: u64,
    check: &dyn Fn(usize, usize, u64) -> Result<()>,
) -> Result<(usize, usize, Vec<f32>)> {
    use crate::error::{Error, ImapStatus};
    use crate::files::{read_regular, ReadError};
    use image::ImageDecoder;
    let shown = path.display();
    let bytes = read_regular(path, limit).map_err(|e| match e {
        ReadError::TooLarge { .. } => Error::new(
            ImapStatus::ImapErrMemoryBudget,
            format!("{shown}: {e}: over the memory budget"),
        ),
        e => Error::new(ImapStatus::ImapErrIo, format!("{shown}: {e}")),
    })?;
    let file_bytes = bytes.len() as u64;
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| Error::new(ImapStatus::ImapErrIo, format!("{shown}: {e}")))?;
    match reader.format() {
        Some(image::ImageFormat::Hdr) | Some(image::ImageFormat::OpenExr) => {}
        other => bail!(
            ImapErrParse,
            "{shown}: not a Radiance HDR or OpenEXR image ({})",
            other.map_or("format not recognised".to_string(), |f| format!("{f:?}"))
        ),
    }
    // The budget decides from the header, before a pixel is decoded; the decoder's own
    // allocations are held to what the budget leaves.
    reader.no_limits();
    let decode_error = |e: image::ImageError| match e {
        image::ImageError::IoError(e) => Error::new(ImapStatus::ImapErrIo, format!("{shown}: {e}")),
        image::ImageError::Limits(e) => {
            Error::new(ImapStatus::ImapErrMemoryBudget, format!("{shown}: {e}"))
        }
        e => Error::new(ImapStatus::ImapErrParse, format!("{shown}: {e}")),
    };
    let mut decoder = reader.into_decoder().map_err(decode_error)?;
    let (w, h) = decoder.dimensions();
    check(w as usize, h as usize, file_bytes)?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(limit);
    decoder.set_limits(limits).map_err(decode_error)?;
    let img = image::DynamicImage::from_decoder(decoder).map_err(decode_error)?;
    let rgb = img.into_rgb32f();
    let (w, h) = (rgb.width() as usize, rgb.height() as usize);
    Ok((w, h, rgb.into_raw()))
}

/// A moment and a place on Earth, for the sun's position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunTime {
    pub year: i32,
    pub month: u32,
    pub day: u32,
    pub hour: u32,
    pub minute: u32,
    pub second: f64,
    /// Local time's offset from UTC, hours (e.g. +1 for CET).
    pub utc_offset_hours: f64,
    /// Degrees north.
    pub latitude_deg: f64,
    /// Degrees east.
    pub longitude_deg: f64,
    /// Metres above sea level.
    pub elevation_m: f64,
}

/// The sun's apparent position (azimuth from north toward east, zenith angle; degrees)
/// by NREL's Solar Position Algorithm (Reda & Andreas 2004, ±0.0003°; the
/// `solar-positioning` crate), with ΔT estimated from the date (Espenak & Meeus) and the
/// refraction of a standard atmosphere (1013.25 hPa, 10 °C; none below the horizon).
pub fn sun_position(t: &SunTime) -> Result<(f64, f64)> {
    sun_position_with(t, None, Some(STANDARD_ATMOSPHERE))
}

/// The atmosphere refraction is computed for unless a caller gives its own: (pressure
/// hPa, temperature °C).
pub const STANDARD_ATMOSPHERE: (f64, f64) = (1013.25, 10.0);

/// `sun_position` with ΔT (s) given, and refraction for (pressure hPa, temperature °C)
/// or none.
pub fn sun_position_with(
    t: &SunTime,
    delta_t: Option<f64>,
    refraction: Option<(f64, f64)>,
) -> Result<(f64, f64)> {
    use solar_positioning::{spa, time::DeltaT, time::JulianDate, RefractionCorrection};
    check_finite_scalar("second", t.second)?;
    check_angle("utc_offset_hours", t.utc_offset_hours, -14.0, 14.0)?;
    check_angle("latitude_deg", t.latitude_deg, -90.0, 90.0)?;
    check_angle("longitude_deg", t.longitude_deg, -180.0, 180.0)?;
    check_angle("elevation_m", t.elevation_m, -1000.0, 10_000.0)?;
    let bad = |what: String| {
        crate::error::Error::new(crate::error::ImapStatus::ImapErrInvalidArgument, what)
    };
    if !(-2000..=6000).contains(&t.year) {
        bail!(
            ImapErrInvalidArgument,
            "year = {}: the solar position algorithm covers −2000 to 6000",
            t.year
        );
    }
    if let Some(d) = delta_t {
        check_angle("delta_t_s", d, -1e6, 1e6)?;
    }
    if let Some((p, c)) = refraction {
        check_angle("pressure_hpa", p, 1.0, 2000.0)?;
        check_angle("temperature_c", c, -100.0, 100.0)?;
    }
    let dt = match delta_t {
        Some(d) => d,
        None => DeltaT::estimate_from_date(t.year, t.month.clamp(1, 12))
            .map_err(|e| bad(format!("ΔT for {}-{}: {e}", t.year, t.month)))?,
    };
    // Local civil time to UTC: validate the local fields, then shift by whole days.
    let stamp = format!(
        "{:04}-{:02}-{:02} {:02}:{:02}:{:06.3}",
        t.year, t.month, t.day, t.hour, t.minute, t.second
    );
    JulianDate::from_utc(t.year, t.month, t.day, t.hour, t.minute, t.second, dt)
        .map_err(|e| bad(format!("{stamp}: {e}")))?;
    let secs =
        t.hour as f64 * 3600.0 + t.minute as f64 * 60.0 + t.second - t.utc_offset_hours * 3600.0;
    let shift = (secs / 86_400.0).floor();
    let secs = (secs - shift * 86_400.0).clamp(0.0, 86_399.999_999);
    let (y, m, d) = civil_from_days(days_from_civil(t.year, t.month, t.day) + shift as i64);
    let (h, rest) = ((secs / 3600.0) as u32, secs % 3600.0);
    let (mi, sec) = ((rest / 60.0) as u32, (rest % 60.0).min(59.999_999));
    let jd = JulianDate::from_utc(y, m, d, h.min(23), mi.min(59), sec, dt)
        .map_err(|e| bad(format!("{stamp} as UTC: {e}")))?;
    let refraction = match refraction {
        Some((p, c)) => Some(
            RefractionCorrection::new(p, c)
                .map_err(|e| bad(format!("refraction ({p} hPa, {c} °C): {e}")))?,
        ),
        None => None,
    };
    let pos = spa::solar_position_from_julian(
        jd,
        t.latitude_deg,
        t.longitude_deg,
        t.elevation_m,
        refraction,
    )
    .map_err(|e| bad(format!("the solar position: {e}")))?;
    Ok((pos.azimuth(), pos.zenith_angle()))
}

/// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's algorithm).
fn days_from_civil(y: i32, m: u32, d: u32) -> i64 {
    let y = y as i64 - if m <= 2 { 1 } else { 0 };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let m = m as i64;
    let doy = (153 * (if m > 2 { m - 3 } else { m + 9 }) + 2) / 5 + d as i64 - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// The date of `days` since 1970-01-01 (inverse of `days_from_civil`).
fn civil_from_days(days: i64) -> (i32, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + if m <= 2 { 1 } else { 0 };
    (y as i32, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::PhotonRng;

    fn rgb() -> Bands {
        Bands::rgb()
    }

    /// Monte Carlo ∫ g dω by the part's own sampling (weights included), and the mean
    /// weight.
    fn integrate(p: &DistantPart, n: usize, g: impl Fn(DVec3) -> f64) -> (f64, f64) {
        let mut rng = PhotonRng::new(1, 2);
        let (mut s, mut w_sum) = (0.0, 0.0);
        for _ in 0..n {
            let (d, w) = p.sample([rng.uniform(), rng.uniform(), rng.uniform()]);
            s += w * p.integral * g(d);
            w_sum += w;
        }
        (s / n as f64, w_sum / n as f64)
    }

    #[test]
    fn cie_sky_is_one_at_the_zenith_and_matches_its_formula() {
        let b = rgb();
        for kind in 1..=15u32 {
            let d = Distant::sky(
                &SkyDesc {
                    kind: SkyKind::Cie {
                        kind,
                        sun_azimuth_deg: 135.0,
                        sun_zenith_deg: 40.0,
                    },
                    amount: SkyAmount::Radiance(1.0),
                    ..SkyDesc::default()
                },
                &b,
            )
            .unwrap();
            let p = &d.parts[0];
            assert!((p.value(DVec3::Z) - 1.0).abs() < 1e-12, "type {kind}");
            // The integral by sampling agrees with the quadrature; weights average 1.
            let (i, w) = integrate(p, 200_000, |_| 1.0);
            assert!(
                (i / p.integral - 1.0).abs() < 0.01,
                "type {kind}: {i} vs {}",
                p.integral
            );
            assert!((w - 1.0).abs() < 0.01, "type {kind}: mean weight {w}");
            let (h, _) = integrate(p, 200_000, |d| d.z.max(0.0));
            assert!((h / p.horizontal - 1.0).abs() < 0.01, "type {kind}");
            assert_eq!(p.value(DVec3::new(1.0, 0.0, -0.1).normalize()), 0.0);
        }
        // Type 16-like check of the formula: overcast type 1 at the horizon is 1/φ(0).
        let d = Distant::sky(
            &SkyDesc {
                kind: SkyKind::Cie {
                    kind: 1,
                    sun_azimuth_deg: 0.0,
                    sun_zenith_deg: 0.0,
                },
                amount: SkyAmount::Radiance(1.0),
                ..SkyDesc::default()
            },
            &b,
        )
        .unwrap();
        let horizon = d.parts[0].value(DVec3::new(0.0, 1.0, 1e-9).normalize());
        assert!(
            (horizon - 1.0 / (1.0 + 4.0 * (-0.7f64).exp())).abs() < 1e-6,
            "{horizon}"
        );
    }

    #[test]
    fn amounts_set_the_radiance_and_horizontal_light() {
        let b = rgb();
        let k = BandPhotometry::new(&b);
        let d = Distant::sky(
            &SkyDesc {
                amount: SkyAmount::Luminance(1000.0),
                ..SkyDesc::default()
            },
            &b,
        )
        .unwrap();
        let p = &d.parts[0];
        assert!((k.luminous(&p.per_band) - 1000.0).abs() < 1e-9);
        assert!((k.luminous(&d.horizontal()) - 1000.0 * PI).abs() < 1e-6);
        let d = Distant::sky(
            &SkyDesc {
                kind: SkyKind::Cie {
                    kind: 12,
                    sun_azimuth_deg: 180.0,
                    sun_zenith_deg: 30.0,
                },
                amount: SkyAmount::HorizontalIlluminance(10_000.0),
                ..SkyDesc::default()
            },
            &b,
        )
        .unwrap();
        assert!((k.luminous(&d.horizontal()) - 10_000.0).abs() < 1e-6);
        let sun = Distant::sun(
            &SunDesc {
                azimuth_deg: 180.0,
                zenith_deg: 60.0,
                amount: SkyAmount::NormalIlluminance(80_000.0),
                ..SunDesc::default()
            },
            &b,
        )
        .unwrap();
        assert!((k.luminous(&sun.horizontal()) - 40_000.0).abs() < 1e-6);
        let s = &sun.parts[0];
        // South is −y with north +y and zenith +z.
        let axis = match s.radiance {
            Radiance::Sun { axis, .. } => axis,
            _ => unreachable!(),
        };
        assert!(
            (axis - DVec3::new(0.0, -0.75f64.sqrt(), 0.5)).length() < 1e-12,
            "{axis}"
        );
    }

    #[test]
    fn an_image_is_sampled_by_its_pixels() {
        let b = rgb();
        let (w, h) = (16usize, 8usize);
        let mut rgb = vec![0f32; w * h * 3];
        for i in 0..w * h {
            rgb[3 * i] = (i % 7) as f32;
            rgb[3 * i + 1] = 1.0;
            rgb[3 * i + 2] = if i == 5 { 100.0 } else { 0.0 };
        }
        let d = Distant::sky(
            &SkyDesc {
                kind: SkyKind::Image {
                    width: w,
                    height: h,
                    rgb: Arc::new(rgb.clone()),
                },
                amount: SkyAmount::Scale(2.0),
                rotation_deg: 30.0,
                ..SkyDesc::default()
            },
            &b,
        )
        .unwrap();
        assert_eq!(d.parts.len(), 3);
        for p in &d.parts {
            let (i, wm) = integrate(p, 100_000, |_| 1.0);
            assert!((i / p.integral - 1.0).abs() < 1e-9 && (wm - 1.0).abs() < 1e-9);
        }
        // The blue channel's only pixel (5, 0) is at the top row, column 5: azimuth
        // −180° + 30° + (5.5/16)·360°.
        let p = &d.parts[2];
        let a = (-180.0f64 + 30.0 + 5.5 / 16.0 * 360.0).to_radians();
        let dir = p.frame.direction(a, (0.5 / 8.0 * 180.0f64).to_radians());
        assert_eq!(p.value(dir), 100.0);
        assert_eq!(p.per_band, vec![0.0, 0.0, 2.0]);
        let dir = p
            .frame
            .direction(a + 0.5, (0.5 / 8.0 * 180.0f64).to_radians());
        assert_eq!(p.value(dir), 0.0);
    }

    #[test]
    fn the_sun_position_matches_the_spa_papers_example() {
        // Reda & Andreas (2004), table A4.1: 2003-10-17 12:30:30 at UTC−7, 39.742476° N,
        // 105.1786° W, 1830.14 m, 820 hPa, 11 °C, ΔT = 67 s: topocentric zenith angle
        // 50.11162°, azimuth (from north, eastward) 194.34024°.
        let t = SunTime {
            year: 2003,
            month: 10,
            day: 17,
            hour: 12,
            minute: 30,
            second: 30.0,
            utc_offset_hours: -7.0,
            latitude_deg: 39.742476,
            longitude_deg: -105.1786,
            elevation_m: 1830.14,
        };
        let (az, zen) = sun_position_with(&t, Some(67.0), Some((820.0, 11.0))).unwrap();
        assert!((zen - 50.11162).abs() < 2e-5, "{zen}");
        assert!((az - 194.34024).abs() < 2e-5, "{az}");
        // The same moment given in UTC, and across a date line: 2003-10-18 04:30:30 at
        // UTC+9 is 2003-10-17 19:30:30 UTC.
        let utc = SunTime {
            hour: 19,
            utc_offset_hours: 0.0,
            ..t
        };
        let east = SunTime {
            day: 18,
            hour: 4,
            utc_offset_hours: 9.0,
            ..t
        };
        for t in [utc, east] {
            let (a, z) = sun_position_with(&t, Some(67.0), Some((820.0, 11.0))).unwrap();
            assert!((a - az).abs() < 1e-9 && (z - zen).abs() < 1e-9, "{t:?}");
        }
        assert_eq!(
            civil_from_days(days_from_civil(2000, 2, 29) + 1),
            (2000, 3, 1)
        );
        assert_eq!(
            civil_from_days(days_from_civil(2024, 1, 1) - 1),
            (2023, 12, 31)
        );
        let e = sun_position(&SunTime { month: 13, ..t })
            .unwrap_err()
            .to_string();
        assert!(e.contains("2003-13-17"), "{e}");
        let e = sun_position(&SunTime {
            latitude_deg: 91.0,
            ..t
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains("latitude_deg"), "{e}");
    }

    #[test]
    fn bad_skies_are_refused_by_name() {
        let b = rgb();
        let e = |desc: SkyDesc| Distant::sky(&desc, &b).unwrap_err().to_string();
        assert!(e(SkyDesc {
            kind: SkyKind::Cie {
                kind: 16,
                sun_azimuth_deg: 0.0,
                sun_zenith_deg: 0.0
            },
            amount: SkyAmount::Luminance(1.0),
            ..SkyDesc::default()
        })
        .contains("cie_type"));
        assert!(e(SkyDesc::default()).contains("amount"));
        assert!(e(SkyDesc {
            amount: SkyAmount::Scale(1.0),
            ..SkyDesc::default()
        })
        .contains("uniform"));
        assert!(e(SkyDesc {
            amount: SkyAmount::Luminance(1.0),
            north: [0.0, 0.0, 2.0],
            ..SkyDesc::default()
        })
        .contains("north"));
        assert!(e(SkyDesc {
            kind: SkyKind::Image {
                width: 2,
                height: 1,
                rgb: Arc::new(vec![0.0, 1.0, 2.0, f32::NAN, 0.0, 0.0]),
            },
            amount: SkyAmount::Scale(1.0),
            ..SkyDesc::default()
        })
        .contains("pixel (1, 0)"));
    }
}

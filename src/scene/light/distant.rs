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

use super::cie::cie_relative;
use crate::error::{bail, check_finite, check_finite_scalar, Result};
use crate::photometry::colour::spectrum_bands;
use crate::photometry::Spectrum;
use crate::sampling::{warp, AliasTable};
use crate::spectral::Bands;
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};
use std::fmt;
use std::sync::Arc;

/// Rows and columns of an analytic sky's sampling table (over the upper hemisphere), and
/// the sub-samples per cell side its means take.
pub(super) const SKY_ROWS: usize = 64;
pub(super) const SKY_COLS: usize = 128;
pub(super) const SKY_SUB: usize = 4;

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
        let Some(z) = super::direction::unit_vector(zenith) else {
            bail!(ImapErrInvalidArgument, "zenith is the zero vector");
        };
        let Some(n) = super::direction::unit_vector(north) else {
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
    pub(super) fn angles(&self, d: DVec3) -> (f64, f64) {
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
    /// l/l_z of a Perez all-weather sky: `p` its (a, b, c, d, e), `sun` the direction
    /// toward the sun, `zenith` l at the zenith; 0 below the horizon.
    Perez {
        p: [f64; 5],
        sun: DVec3,
        zenith: f64,
    },
    /// A sky of one value per patch of `patches` (its sky patches; the ground's is a
    /// `Ground` part), turned by `rotation` (radians toward east); 0 below the horizon.
    Patches {
        patches: Arc<super::SkyPatches>,
        values: Arc<Vec<f64>>,
        rotation: f64,
    },
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
pub(super) struct Table {
    pub(super) rows: usize,
    pub(super) cols: usize,
    /// Zenith angle the rows span ([0, `theta_max`]).
    pub(super) theta_max: f64,
    /// Azimuth of the first column's left edge.
    pub(super) azimuth0: f64,
    /// cos of each row's upper and lower edges (rows + 1 values).
    pub(super) cos_edges: Vec<f64>,
    pub(super) cells: AliasTable,
}

/// Uniform directions over one sky patch: sin(altitude) in [`sin_lo`, `sin_hi`], azimuth
/// (from north toward east) in [`az0`, `az0` + `width`].
#[derive(Clone, Copy, Debug)]
pub(super) struct PatchSampler {
    sin_lo: f64,
    sin_hi: f64,
    az0: f64,
    width: f64,
}

impl PatchSampler {
    fn solid_angle(&self) -> f64 {
        self.width * (self.sin_hi - self.sin_lo)
    }

    fn sample(&self, frame: &SkyFrame, u: [f64; 3]) -> DVec3 {
        let cz = self.sin_lo + (self.sin_hi - self.sin_lo) * u[1];
        let a = self.az0 + self.width * u[2];
        let s = (1.0 - cz * cz).max(0.0).sqrt();
        (frame.north * (s * a.cos()) + frame.east * (s * a.sin()) + frame.zenith * cz).normalize()
    }
}

/// A distant source with its table, f's integrals and radiance per band per unit of f.
#[derive(Clone)]
pub struct DistantPart {
    pub frame: SkyFrame,
    pub radiance: Radiance,
    pub(super) table: Option<Table>,
    /// A sky lit over one patch (a daylight coefficient's) samples that patch exactly,
    /// not its table's cells: a Reinhart patch is smaller than a cell near the zenith.
    pub(super) patch: Option<PatchSampler>,
    /// ∫ f dω, sr.
    pub integral: f64,
    /// ∫ f max(cos Z, 0) dω: the horizontal irradiance per unit of f's radiance, sr.
    pub horizontal: f64,
    /// Radiance per band per unit of f, W/(m² sr).
    pub per_band: Vec<f64>,
}

impl DistantPart {
    /// Whether its light samples (and a portal's photons) draw half their directions by
    /// its radiance and half cosine-distributed: a sky's do, to follow the receiver's
    /// cosine too; a one-patch sky's do not (its patch is sampled exactly, and a cosine
    /// direction would nearly always miss a patch of 0.04 sr or less).
    pub fn mixes_cosine(&self) -> bool {
        self.is_sky() && self.patch.is_none()
    }

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
            Radiance::Perez { p, sun, .. } => d.field("perez", &(p, sun)),
            Radiance::Patches {
                patches,
                values,
                rotation,
            } => d.field("patches", &(patches.mf(), values, rotation)),
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
            Radiance::Patches {
                patches,
                values,
                rotation,
            } => {
                let (a, cz) = self.frame.angles(d);
                if cz <= 0.0 {
                    return 0.0;
                }
                values[patches.patch(cz.asin(), a - rotation)]
            }
            Radiance::Perez { p, sun, zenith } => {
                let cz = d.dot(self.frame.zenith);
                if cz <= 0.0 {
                    return 0.0;
                }
                let gamma = d.dot(*sun).clamp(-1.0, 1.0).acos();
                super::perez::perez_relative(p, cz, gamma) / zenith
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
            Radiance::Cie { .. }
            | Radiance::Perez { .. }
            | Radiance::Patches { .. }
            | Radiance::Image { .. } => {
                let t = self.table.as_ref().expect("a tabulated sky");
                let sub = match &self.radiance {
                    Radiance::Image { .. } => 2,
                    _ => SKY_SUB,
                };
                let lit = LitPatches::of(&self.radiance, t);
                let mut sum = 0.0;
                for i in 0..t.rows {
                    let omega = t.solid_angle(i);
                    for j in 0..t.cols {
                        if lit.as_ref().is_some_and(|l| !l.may_reach(t, i, j)) {
                            continue;
                        }
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
        if let Some(p) = &self.patch {
            return if self.value(d) > 0.0 {
                1.0 / p.solid_angle()
            } else {
                0.0
            };
        }
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
        if let Some(p) = &self.patch {
            let d = p.sample(&self.frame, u);
            // f is the patch's value over its solid angle: weight 1 (0 for a direction that
            // rounding puts just outside the patch).
            let w = self.value(d) * p.solid_angle() / self.integral;
            return (d, w);
        }
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
    pub(super) fn solid_angle(&self, row: usize) -> f64 {
        (self.cos_edges[row] - self.cos_edges[row + 1]) * 2.0 * PI / self.cols as f64
    }

    /// The cell of unit direction `d`.
    #[inline]
    pub(super) fn cell(&self, frame: &SkyFrame, d: DVec3) -> (usize, usize) {
        let (a, cz) = frame.angles(d);
        let z = cz.acos();
        let i = ((z / self.theta_max * self.rows as f64) as usize).min(self.rows - 1);
        let mut a = (a - self.azimuth0) / (2.0 * PI);
        a -= a.floor();
        let j = ((a * self.cols as f64) as usize).min(self.cols - 1);
        (i, j)
    }

    pub(super) fn sample(&self, frame: &SkyFrame, u: [f64; 3]) -> DVec3 {
        let k = self.cells.sample(u[0]);
        let (i, j) = (k / self.cols, k % self.cols);
        let a = self.azimuth0 + 2.0 * PI * (j as f64 + u[1]) / self.cols as f64;
        let cz = self.cos_edges[i] + (self.cos_edges[i + 1] - self.cos_edges[i]) * u[2];
        let s = (1.0 - cz * cz).max(0.0).sqrt();
        (frame.north * (s * a.cos()) + frame.east * (s * a.sin()) + frame.zenith * cz).normalize()
    }

    /// A table over `rows` × `cols` cells spanning zenith angles [0, `theta_max`] with
    /// weights `w(i, j)` (the cell's mean f; any positive floor is the caller's).
    pub(super) fn new(
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
    pub(super) fn means(
        &self,
        frame: &SkyFrame,
        i: usize,
        j: usize,
        f: impl Fn(DVec3) -> f64,
    ) -> (f64, f64) {
        self.means_sub(frame, i, j, SKY_SUB, f)
    }

    /// `means` with `sub`² points per cell.
    pub(super) fn means_sub(
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
    pub(super) fn value(self) -> f64 {
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

    pub(super) fn photometric(self) -> bool {
        matches!(
            self,
            SkyAmount::Luminance(_)
                | SkyAmount::HorizontalIlluminance(_)
                | SkyAmount::NormalIlluminance(_)
        )
    }

    pub(super) fn name(self) -> &'static str {
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

    /// The mean radiance per band over each patch of `patches` (W/(m² sr); patch 0 the
    /// ground, which a sky leaves dark and the ground's glow fills), by `sub` × `sub`
    /// points of equal solid angle per patch. The sun's disk is left out.
    pub fn patch_radiance(&self, patches: &super::SkyPatches, sub: usize) -> Vec<Vec<f64>> {
        let nb = self.parts[0].per_band.len();
        let mut out = vec![vec![0.0; nb]; patches.count()];
        for part in self.parts.iter().filter(|p| !p.is_sun()) {
            for (p, o) in out.iter_mut().enumerate() {
                let f = patches.mean(p, sub, |alt, az| {
                    part.value(part.frame.direction(az, FRAC_PI_2 - alt))
                });
                if f > 0.0 {
                    for (o, x) in o.iter_mut().zip(&part.per_band) {
                        *o += x * f;
                    }
                }
            }
        }
        out
    }
}

/// The per-band radiance per unit of f of `spectrum` for a total `x` (W or lm) per unit
/// of `denominator` (the integral the amount refers to).
pub(super) fn per_band(
    spectrum: &Spectrum,
    bands: &Bands,
    x: f64,
    photometric: bool,
    denominator: f64,
) -> Result<Vec<f64>> {
    let out =
        crate::photometry::colour::scale_spectrum(spectrum, bands, x / denominator, photometric)?;
    if out.iter().any(|v| !v.is_finite()) {
        bail!(
            ImapErrInvalidArgument,
            "amount = {x}: the radiance per band is not representable"
        );
    }
    Ok(out)
}

pub(super) fn check_amount(amount: SkyAmount) -> Result<f64> {
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

/// Radiance per band per unit of an image channel's value: the channel's value is its
/// radiance summed over the bands it covers (zeros when it covers none).
pub(super) fn channel_bands(spectrum: &Spectrum, bands: &Bands) -> Vec<f64> {
    let rel = spectrum_bands(spectrum, bands);
    let sum: f64 = rel.iter().sum();
    if sum > 0.0 {
        rel.iter().map(|r| r / sum).collect()
    } else {
        rel.iter().map(|_| 0.0).collect()
    }
}

/// The bounds of the few lit patches of a patch sky (a daylight coefficient's sky lights
/// one patch of up to 2306): the table's cells outside them are 0 and need no means.
struct LitPatches {
    bounds: Vec<(f64, f64, f64, f64)>,
    /// The table's rows' altitude ranges, radians.
    rows: Vec<(f64, f64)>,
}

impl LitPatches {
    /// Most lit patches worth testing a cell against.
    const MAX: usize = 8;

    /// Those of `radiance` over the rows of `table`.
    fn of(radiance: &Radiance, table: &Table) -> Option<Self> {
        let Radiance::Patches {
            patches, values, ..
        } = radiance
        else {
            return None;
        };
        let lit: Vec<usize> = (0..values.len()).filter(|&p| values[p] != 0.0).collect();
        (lit.len() <= Self::MAX).then(|| LitPatches {
            bounds: lit.iter().map(|&p| patches.bounds(p)).collect(),
            rows: table
                .cos_edges
                .windows(2)
                .map(|c| {
                    let lo = c[0].min(c[1]).clamp(-1.0, 1.0).asin();
                    (lo, c[0].max(c[1]).clamp(-1.0, 1.0).asin())
                })
                .collect(),
        })
    }

    /// Whether cell (`i`, `j`) of `table` (the one they were made for; its azimuths
    /// counted from the patches' own, as `tabulated`'s are) may overlap a lit patch:
    /// conservative by a margin.
    fn may_reach(&self, table: &Table, i: usize, j: usize) -> bool {
        const EPS: f64 = 1e-6;
        let (lo, hi) = self.rows[i];
        let cw = 2.0 * PI / table.cols as f64;
        let centre = (j as f64 + 0.5) * cw;
        self.bounds.iter().any(|&(alt_lo, alt_hi, az, w)| {
            if hi < alt_lo - EPS || lo > alt_hi + EPS {
                return false;
            }
            if w >= 2.0 * PI - EPS {
                return true;
            }
            let d = (centre - (az + 0.5 * w)).rem_euclid(2.0 * PI);
            d.min(2.0 * PI - d) <= 0.5 * (cw + w) + EPS
        })
    }
}

impl DistantPart {
    /// An analytic sky with its table over the upper hemisphere.
    pub(super) fn tabulated(frame: SkyFrame, radiance: Radiance, rotation: f64) -> Result<Self> {
        let mut part = DistantPart {
            frame,
            radiance,
            table: None,
            patch: None,
            integral: 0.0,
            horizontal: 0.0,
            per_band: Vec::new(),
        };
        let probe = Table::new(SKY_ROWS, SKY_COLS, FRAC_PI_2, rotation, |_, _| 1.0)?;
        let lit = LitPatches::of(&part.radiance, &probe);
        let mut means = Vec::with_capacity(SKY_ROWS * SKY_COLS);
        let (mut integral, mut horizontal) = (0.0, 0.0);
        for i in 0..SKY_ROWS {
            let omega = probe.solid_angle(i);
            for j in 0..SKY_COLS {
                if lit.as_ref().is_some_and(|l| !l.may_reach(&probe, i, j)) {
                    means.push(0.0);
                    continue;
                }
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
        if let Some(lit) = &lit {
            if let [(alt_lo, alt_hi, az, width)] = lit.bounds[..] {
                if alt_lo >= 0.0 {
                    part.patch = Some(PatchSampler {
                        sin_lo: alt_lo.sin(),
                        sin_hi: alt_hi.sin(),
                        az0: az + rotation,
                        width,
                    });
                }
            }
        }
        Ok(part)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A one-patch sky's table skips the cells its patch does not reach and sums exactly
    /// as the means over every cell do: every other Tregenza patch and every ninth of MF:2's,
    /// unrotated and rotated so that patch edges cut through cells.
    #[test]
    fn a_patch_sky_skips_only_cells_its_patch_does_not_reach() {
        let frame = SkyFrame::new([0.0, 0.0, 1.0], [0.3, 1.0, 0.0]).unwrap();
        let mut skipped = 0;
        for (mf, step) in [(1u32, 2usize), (2, 9)] {
            let patches = super::super::SkyPatches::reinhart(mf).unwrap();
            for rotation in [0.0, 0.37] {
                for p in (1..patches.count()).step_by(step) {
                    let mut values = vec![0.0; patches.count()];
                    values[p] = 1.0;
                    let radiance = Radiance::Patches {
                        patches: Arc::new(patches.clone()),
                        values: Arc::new(values),
                        rotation,
                    };
                    let part = DistantPart::tabulated(frame, radiance.clone(), rotation).unwrap();
                    let probe =
                        Table::new(SKY_ROWS, SKY_COLS, FRAC_PI_2, rotation, |_, _| 1.0).unwrap();
                    let lit = LitPatches::of(&radiance, &probe).unwrap();
                    let (mut integral, mut horizontal) = (0.0, 0.0);
                    for i in 0..SKY_ROWS {
                        let omega = probe.solid_angle(i);
                        for j in 0..SKY_COLS {
                            let (m, h) = probe.means(&frame, i, j, |d| part.value(d));
                            integral += m * omega;
                            horizontal += h * omega;
                            skipped += usize::from(!lit.may_reach(&probe, i, j));
                            if !lit.may_reach(&probe, i, j) {
                                assert_eq!(m, 0.0, "MF:{mf} patch {p} cell {i},{j}");
                            }
                        }
                    }
                    assert!(integral > 0.0);
                    assert_eq!(part.integral, integral, "MF:{mf} patch {p}");
                    assert_eq!(part.horizontal, horizontal, "MF:{mf} patch {p}");
                    if mf == 2 {
                        // A portal's cosine integral skips the same cells.
                        let n = DVec3::new(0.2, -0.9, 0.3).normalize();
                        let t = part.table.as_ref().unwrap();
                        let mut want = 0.0;
                        for i in 0..t.rows {
                            let omega = t.solid_angle(i);
                            for j in 0..t.cols {
                                let f_cos = |d: DVec3| part.value(d) * d.dot(n).max(0.0);
                                want += t.means_sub(&frame, i, j, SKY_SUB, f_cos).0 * omega;
                            }
                        }
                        assert_eq!(part.cos_integral(n), want, "MF:{mf} patch {p}");
                    }
                }
            }
        }
        assert!(skipped > 1_000_000, "{skipped} cells skipped");
    }

    /// A one-patch sky samples its patch exactly: every direction lies in the patch with
    /// weight 1 and density 1/Ω, and the directions' mean cos Z times Ω is the patch's
    /// exact cosine integral (MF:1 and MF:4, a cap, rows near the zenith and the
    /// horizon, the row's first patch that straddles north; rotated).
    #[test]
    fn a_patch_sky_samples_its_patch_with_weight_one() {
        let frame = SkyFrame::new([0.0, 0.0, 1.0], [0.3, 1.0, 0.0]).unwrap();
        for (mf, p) in [
            (1u32, 145usize),
            (1, 1),
            (1, 131),
            (4, 2305),
            (4, 2290),
            (4, 1),
            (4, 400),
        ] {
            let patches = super::super::SkyPatches::reinhart(mf).unwrap();
            let mut values = vec![0.0; patches.count()];
            values[p] = 2.5;
            let radiance = Radiance::Patches {
                patches: Arc::new(patches.clone()),
                values: Arc::new(values),
                rotation: 0.37,
            };
            let mut part = DistantPart::tabulated(frame, radiance, 0.37).unwrap();
            part.integral = 2.5 * patches.solid_angle(p);
            let omega = patches.solid_angle(p);
            let n = 4000;
            let (mut sum, mut sum2) = (0.0, 0.0);
            for k in 0..n {
                let u = [
                    0.5,
                    (k as f64 + 0.5) / n as f64,
                    ((k * 7919) % n) as f64 / n as f64 + 0.1 / n as f64,
                ];
                let (d, w) = part.sample(u);
                assert!((w - 1.0).abs() < 1e-12, "MF:{mf} patch {p}: weight {w}");
                assert!((part.pdf(d) * omega - 1.0).abs() < 1e-12);
                let c = d.dot(frame.zenith);
                sum += c;
                sum2 += c * c;
            }
            let mean = sum / n as f64;
            let sd = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
            let want = patches.horizontal(p) / omega;
            assert!(
                (mean - want).abs() <= 4.0 * sd + 1e-9,
                "MF:{mf} patch {p}: mean cos Z {mean} ± {sd}, exact {want}"
            );
        }
    }
}

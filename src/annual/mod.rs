//! Annual daylight from sky-patch coefficients: each hour's sky vector from a weather
//! file (the Perez sky over Tregenza or Reinhart patches), the hourly illuminance at
//! every sensor as coefficients × sky vector with its standard error, and the
//! climate-based metrics (DA, cDA, UDI, sDA) with their confidence.
//!
//! The coefficients are an illuminance per patch luminance (lx per cd/m²) at each sensor,
//! with a standard error per coefficient; one run of patch skies (docs/daylight.md,
//! "Daylight coefficients") makes them. The patches' errors are independent (each patch's
//! photons are its own), so an hour's variance is Σ_p L_p² σ_p². A metric, a threshold
//! function of many hours, is not: every hour uses the same coefficients. Its confidence
//! comes from drawing the coefficients within their errors (a parametric bootstrap: C_p
//! + σ_p N(0, 1) per sensor and patch) and computing the metric for each draw.

pub mod glare;
pub mod lighting;
pub mod shading;
pub mod trace;

pub use glare::{annual_glare, ObserverYear, DGP_CLASSES};
pub use shading::{Shading, ShadingRule, WindowGroup};

use crate::error::{bail, Result};
use crate::sampling::PhotonRng;
use crate::scene::light::{perez_parameters, perez_relative, SkyPatches};
use crate::weather::Weather;
use std::f64::consts::FRAC_PI_2;

/// One hour of an annual sky.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnnualHour {
    /// The weather file's row (0-based among its hours).
    pub row: usize,
    pub month: u32,
    pub day: u32,
    /// Decimal hours of local standard time (the middle of the row's step).
    pub hour: f64,
    /// The sun's azimuth (from north toward east) and zenith angle, degrees.
    pub sun_azimuth_deg: f64,
    pub sun_zenith_deg: f64,
    /// The Perez efficacies' diffuse horizontal and direct normal illuminance, lx (0 for
    /// a night, a missing hour, or an hour without diffuse light).
    pub diffuse_horizontal_lx: f64,
    pub direct_normal_lx: f64,
    /// The sky patch that holds the sun (0: the sun is down).
    pub sun_patch: usize,
}

/// A year of sky vectors: per hour, the mean luminance of each patch, cd/m².
#[derive(Clone, Debug)]
pub struct AnnualSky {
    pub patches: SkyPatches,
    /// How its vectors hold the sun.
    pub sun: SunInVectors,
    pub hours: Vec<AnnualHour>,
    /// `hours.len()` × `patches.count()` luminances, hour by hour (patch 0 the ground).
    pub luminance: Vec<f64>,
}

/// How the sun enters the sky vectors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SunInVectors {
    /// Not at all (a caller adds the direct sun by its own, exact, path).
    Left,
    /// Its direct normal illuminance spread over the patch that holds it (Radiance's
    /// 2-phase method does so, over the nearest four): exact in flux, smeared in
    /// direction by a patch's size (12° for Tregenza's).
    InItsPatch,
}

impl AnnualSky {
    /// The sky vectors of every hour of `weather` over Reinhart's MF:`mf` patches: the
    /// hour's Perez sky (`WeatherHour::perez_sky`, its sun by the SPA at the step's
    /// middle) averaged over each patch by 8 × 8 points of equal solid angle and scaled
    /// to the hour's diffuse horizontal illuminance (by the same points' ∫ l cos dω), the
    /// sun as `sun` says, and the ground patch ρ E_h / π with E_h the hour's global
    /// horizontal illuminance and ρ `ground_reflectance`.
    pub fn from_weather(
        weather: &Weather,
        mf: u32,
        sun: SunInVectors,
        ground_reflectance: f64,
    ) -> Result<Self> {
        crate::error::check_range("ground_reflectance", ground_reflectance, 0.0, 1.0)?;
        let patches = SkyPatches::reinhart(mf)?;
        let n = patches.count();
        let mut hours = Vec::with_capacity(weather.hours.len());
        let mut luminance = vec![0.0; weather.hours.len() * n];
        const SUB: usize = 8;
        for (row, h) in weather.hours.iter().enumerate() {
            let (az, zen) = h.sun_position(&weather.site)?;
            let sky = h.perez_sky(zen)?;
            let (dh, dn) = sky.map_or((0.0, 0.0), |s| {
                (s.diffuse_horizontal_lx, s.direct_normal_lx)
            });
            let dn = if zen < 90.0 { dn } else { 0.0 };
            let sun_patch = if zen < 90.0 {
                patches.patch(FRAC_PI_2 - zen.to_radians(), az.to_radians())
            } else {
                0
            };
            hours.push(AnnualHour {
                row,
                month: h.month,
                day: h.day,
                hour: h.hour,
                sun_azimuth_deg: az,
                sun_zenith_deg: zen,
                diffuse_horizontal_lx: dh,
                direct_normal_lx: dn,
                sun_patch,
            });
            let out = &mut luminance[row * n..(row + 1) * n];
            if let Some(s) = sky {
                let zs = zen.to_radians();
                let p = perez_parameters(s.clearness, s.brightness, zs);
                let (sa, ca) = (az.to_radians().sin(), az.to_radians().cos());
                let sun_dir = [zs.sin() * sa, zs.sin() * ca, zs.cos()];
                let l = |alt: f64, a: f64| {
                    let d = [alt.cos() * a.sin(), alt.cos() * a.cos(), alt.sin()];
                    let c = (d[0] * sun_dir[0] + d[1] * sun_dir[1] + d[2] * sun_dir[2])
                        .clamp(-1.0, 1.0);
                    perez_relative(&p, d[2], c.acos())
                };
                let mut horizontal = 0.0;
                for (q, o) in out.iter_mut().enumerate().skip(1) {
                    let (mean, mean_cos) = patches.means(q, SUB, |alt, a| {
                        let x = l(alt, a);
                        (x, x * alt.sin())
                    });
                    *o = mean;
                    horizontal += mean_cos * patches.solid_angle(q);
                }
                if horizontal > 0.0 {
                    let k = dh / horizontal;
                    out.iter_mut().skip(1).for_each(|v| *v *= k);
                }
                if sun == SunInVectors::InItsPatch && dn > 0.0 {
                    out[sun_patch] += dn / patches.solid_angle(sun_patch);
                }
                let global = dh + dn * zs.cos().max(0.0);
                out[0] = ground_reflectance * global / std::f64::consts::PI;
            }
        }
        Ok(AnnualSky {
            patches,
            sun,
            hours,
            luminance,
        })
    }

    /// Hour `h`'s vector.
    pub fn vector(&self, h: usize) -> &[f64] {
        let n = self.patches.count();
        &self.luminance[h * n..(h + 1) * n]
    }
}

/// Daylight coefficients: at each sensor, the illuminance per cd/m² of each patch, lx,
/// with its standard error.
#[derive(Clone, Debug, PartialEq)]
pub struct Coefficients {
    pub sensors: usize,
    /// Patches per sensor (the scheme's count, the ground's first).
    pub patches: usize,
    /// `sensors` × `patches`, sensor by sensor.
    pub value: Vec<f64>,
    pub sigma: Vec<f64>,
}

impl Coefficients {
    /// Checks the shapes and values.
    pub fn check(&self) -> Result<()> {
        self.view().check()
    }

    /// The sum of `parts`' coefficients (light that adds: window groups' states), with
    /// their errors combined as independent.
    pub fn sum(parts: &[CoefficientsView]) -> Result<Coefficients> {
        let Some(first) = parts.first() else {
            bail!(ImapErrInvalidArgument, "no coefficients to add");
        };
        let (mut value, mut var) = (vec![0.0; first.value.len()], vec![0.0; first.value.len()]);
        for (i, p) in parts.iter().enumerate() {
            p.check()?;
            if (p.sensors, p.patches) != (first.sensors, first.patches) {
                bail!(
                    ImapErrInvalidArgument,
                    "coefficients {i} are of {} sensors × {} patches; the first of {} × {}",
                    p.sensors,
                    p.patches,
                    first.sensors,
                    first.patches
                );
            }
            for ((v, w), (x, s)) in value
                .iter_mut()
                .zip(&mut var)
                .zip(p.value.iter().zip(p.sigma))
            {
                *v += x;
                *w += s * s;
            }
        }
        Ok(Coefficients {
            sensors: first.sensors,
            patches: first.patches,
            value,
            sigma: var.into_iter().map(f64::sqrt).collect(),
        })
    }

    /// The coefficients borrowed.
    pub fn view(&self) -> CoefficientsView<'_> {
        CoefficientsView {
            sensors: self.sensors,
            patches: self.patches,
            value: &self.value,
            sigma: &self.sigma,
        }
    }
}

/// The light group of patch `p` of `count` (`add_sky_patches`): patch p ≥ 1 in group p,
/// the ground (patch 0) in group `count`, so that group 0 keeps the model's own emitters.
pub fn patch_group(p: usize, count: usize) -> u32 {
    if p == 0 {
        count as u32
    } else {
        p as u32
    }
}

/// Adds Reinhart MF:`mf`'s patches to `ctx` as skies of 1 cd/m² each (CIE D65; the
/// ground's below the horizon), oriented by `zenith` and `north`, each in its light group
/// (`patch_group`), and turns the per-group layers on: a run then makes each patch's
/// coefficients as its group's layer (`coefficients` reads them). Returns the first
/// patch's light id. MF:2 and finer need more than the 254 light groups: refused
/// (`trace::PatchRun` traces them in batches).
pub fn add_sky_patches(
    ctx: &mut crate::context::Context,
    mf: u32,
    zenith: [f64; 3],
    north: [f64; 3],
) -> Result<u32> {
    let n = SkyPatches::reinhart(mf)?.count();
    if n > 255 {
        bail!(
            ImapErrInvalidArgument,
            "mf = {mf}: MF:{mf}'s {n} patches need more light groups than the 254 a context has: trace them in batches with imap_annual_trace_coefficients (annual::trace::PatchRun)"
        );
    }
    ctx.set_layers(crate::scene::LayerRequest {
        groups: true,
        direct: ctx.layers().1,
    })?;
    let mut first = None;
    for p in 0..n {
        let id = ctx.add_sky(&crate::scene::light::SkyDesc {
            kind: crate::scene::light::SkyKind::single_patch(mf, p)?,
            amount: crate::scene::light::SkyAmount::Luminance(1.0),
            zenith,
            north,
            ..Default::default()
        })?;
        ctx.set_light_group(id, patch_group(p, n))?;
        first.get_or_insert(id);
    }
    Ok(first.unwrap_or(0))
}

/// The coefficients at vertices `vertices` of mesh `mesh` (`side` 0 front, 1 back) after a
/// run with `add_sky_patches(…, mf, …)`: each patch's layer as illuminance, lx per cd/m²,
/// with its standard error.
pub fn coefficients(
    ctx: &crate::context::Context,
    mesh: u32,
    side: u32,
    vertices: &[usize],
    mf: u32,
) -> Result<Coefficients> {
    let n = SkyPatches::reinhart(mf)?.count();
    let all = ctx.vertex_count(mesh)?;
    if let Some(i) = vertices.iter().position(|&v| v >= all) {
        bail!(
            ImapErrIndexOutOfRange,
            "vertices[{i}] = {}: mesh {mesh} has {all} vertices",
            vertices[i]
        );
    }
    let (mut lux, mut rel) = (vec![0.0; all], vec![0.0; all]);
    let mut value = vec![0.0; vertices.len() * n];
    let mut sigma = vec![0.0; vertices.len() * n];
    for p in 0..n {
        let layer = crate::context::Layer::Group(patch_group(p, n));
        ctx.illuminance_layer(mesh, side, layer, &mut lux)?;
        ctx.rel_error_layer(mesh, side, layer, &mut rel)?;
        for (k, &v) in vertices.iter().enumerate() {
            value[k * n + p] = lux[v];
            sigma[k * n + p] = lux[v] * rel[v];
        }
    }
    Ok(Coefficients {
        sensors: vertices.len(),
        patches: n,
        value,
        sigma,
    })
}

/// Coefficients borrowed from elsewhere (a host's arrays), laid out as `Coefficients`;
/// every function that takes coefficients takes either.
#[derive(Clone, Copy, Debug)]
pub struct CoefficientsView<'a> {
    pub sensors: usize,
    pub patches: usize,
    pub value: &'a [f64],
    pub sigma: &'a [f64],
}

impl<'a> From<&'a Coefficients> for CoefficientsView<'a> {
    fn from(c: &'a Coefficients) -> Self {
        c.view()
    }
}

impl CoefficientsView<'_> {
    /// Checks them and that they are of `sky`'s patches; returns the patch count.
    fn check_against(&self, sky: &AnnualSky) -> Result<usize> {
        self.check()?;
        let n = sky.patches.count();
        if self.patches != n {
            bail!(
                ImapErrInvalidArgument,
                "coefficients of {} patches for sky vectors of {n} (MF:{})",
                self.patches,
                sky.patches.mf()
            );
        }
        Ok(n)
    }

    /// Checks the shapes and values.
    pub fn check(&self) -> Result<()> {
        let n = self.sensors.checked_mul(self.patches);
        if n != Some(self.value.len()) || n != Some(self.sigma.len()) {
            bail!(
                ImapErrInvalidArgument,
                "coefficients: {} values and {} errors for {} sensors × {} patches",
                self.value.len(),
                self.sigma.len(),
                self.sensors,
                self.patches
            );
        }
        for (what, v) in [("value", self.value), ("sigma", self.sigma)] {
            if let Some(i) = v.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
                bail!(
                    ImapErrNonFinite,
                    "coefficients: {what}[{i}] (sensor {}, patch {}) = {}: must be finite and ≥ 0",
                    i / self.patches,
                    i % self.patches,
                    v[i]
                );
            }
        }
        Ok(())
    }
}

/// The sun's direct light at the sensors, computed along its true line for every hour
/// (docs/daylight.md, "The direct sun"): the part of an hour's light the patches would
/// smear over 12° or more, and the light IES LM-83's ASE counts.
///
/// With it, an hour's illuminance at sensor k is
/// Σ_p L_p C_kp + l (C_kq − D_kq) + E_k: the sky's patches (vectors without the sun,
/// `SunInVectors::Left`), the sun's inter-reflected light through the coefficient of the
/// patch q that holds it at the luminance l = E_n / Ω_q its direct normal illuminance
/// E_n spreads over it, less that patch's direct-only coefficient D_kq (what C_kq holds of
/// light that came in a straight line), and the sun's direct illuminance E_k = E_n T cos θ
/// on its true line (T the straight line's transmittance, `Context::straight_transmittance`).
#[derive(Clone, Debug, PartialEq)]
pub struct DirectSun {
    pub sensors: usize,
    pub patches: usize,
    /// Per sensor, the hours the sun reaches it: `hours[offsets[k]..offsets[k + 1]]` index
    /// the sky's hours, `lux` the sun's direct illuminance in them.
    pub offsets: Vec<usize>,
    pub hours: Vec<u32>,
    pub lux: Vec<f32>,
    /// `sensors` × `patches`: each patch's direct-only coefficient, lx per cd/m² (only the
    /// patches the sun crosses in the year; 0 elsewhere), and its standard error.
    pub patch_direct: Vec<f64>,
    pub patch_direct_sigma: Vec<f64>,
}

/// Directions per patch, per side, for the direct-only coefficients (jittered, one per
/// cell of equal solid angle).
const DIRECT_SUB: usize = 8;

impl DirectSun {
    /// Traces the sun's lines for `sky`'s hours and the direct-only coefficients of the
    /// patches it crosses, at `points` (scene units) whose measuring sides face `normals`,
    /// in the scene of `ctx`, its sky oriented by `zenith` and `north` (as the patch skies
    /// of the coefficients). `spectrum`: the sun's and the patch skies' (the transmittance
    /// is luminous: weighted by the spectrum's luminous power per band). `seed` jitters
    /// the patches' directions.
    pub fn new(
        ctx: &mut crate::context::Context,
        sky: &AnnualSky,
        (zenith, north): ([f64; 3], [f64; 3]),
        (points, normals): (&[[f64; 3]], &[[f64; 3]]),
        spectrum: &crate::photometry::Spectrum,
        seed: u64,
    ) -> Result<Self> {
        let bands = ctx.config().bands.clone();
        spectrum.validate(&bands)?;
        let weights: Vec<f64> = crate::photometry::spectrum::band_powers(spectrum, &bands)
            .iter()
            .zip(&ctx.photometry().efficacy)
            .map(|(p, e)| p * e)
            .collect();
        if points.len() != normals.len() {
            bail!(
                ImapErrInvalidArgument,
                "{} points and {} normals",
                points.len(),
                normals.len()
            );
        }
        let mut units = Vec::with_capacity(normals.len());
        for (i, n) in normals.iter().enumerate() {
            crate::error::check_finite(&format!("normals[{i}]"), n)?;
            let Some(u) = glam::DVec3::from(*n).try_normalize() else {
                bail!(ImapErrInvalidArgument, "normals[{i}] is the zero vector");
            };
            units.push(u);
        }
        let frame = crate::scene::light::SkyFrame::new(zenith, north)?;
        let np = sky.patches.count();
        // The hours of sun, and the patches it crosses.
        let sun_hours: Vec<usize> = (0..sky.hours.len())
            .filter(|&h| sky.hours[h].direct_normal_lx > 0.0 && sky.hours[h].sun_patch > 0)
            .collect();
        let mut dirs: Vec<[f64; 3]> = sun_hours
            .iter()
            .map(|&h| {
                let a = &sky.hours[h];
                frame
                    .direction(
                        a.sun_azimuth_deg.to_radians(),
                        a.sun_zenith_deg.to_radians(),
                    )
                    .to_array()
            })
            .collect();
        let mut crossed = vec![false; np];
        for &h in &sun_hours {
            crossed[sky.hours[h].sun_patch] = true;
        }
        let patch_list: Vec<usize> = (1..np).filter(|&p| crossed[p]).collect();
        let m = DIRECT_SUB * DIRECT_SUB;
        let mut rng = PhotonRng::new(seed, 0x5d1_7ec7);
        for &p in &patch_list {
            let (lo, hi, a0, w) = sky.patches.bounds(p);
            let (s0, s1) = (lo.sin(), hi.sin());
            for i in 0..DIRECT_SUB {
                for j in 0..DIRECT_SUB {
                    let alt =
                        (s0 + (s1 - s0) * (i as f64 + rng.uniform()) / DIRECT_SUB as f64).asin();
                    let az = a0 + w * (j as f64 + rng.uniform()) / DIRECT_SUB as f64;
                    dirs.push(frame.direction(az, FRAC_PI_2 - alt).to_array());
                }
            }
        }
        let unit_dirs: Vec<glam::DVec3> = dirs.iter().map(|d| glam::DVec3::from(*d)).collect();
        let ns = sun_hours.len();
        let mut out = DirectSun {
            sensors: points.len(),
            patches: np,
            offsets: vec![0],
            hours: Vec::new(),
            lux: Vec::new(),
            patch_direct: vec![0.0; points.len() * np],
            patch_direct_sigma: vec![0.0; points.len() * np],
        };
        if dirs.is_empty() {
            // No hour of sun.
            out.offsets = vec![0; points.len() + 1];
            return Ok(out);
        }
        // A few hundred points at a time: the lines of one batch stay small.
        const BATCH: usize = 256;
        for (b, batch) in points.chunks(BATCH).enumerate() {
            let t = ctx.straight_transmittance(batch, &dirs, &weights)?;
            for (i, row) in t.chunks(dirs.len()).enumerate() {
                let k = b * BATCH + i;
                let n = units[k];
                for (j, &h) in sun_hours.iter().enumerate() {
                    let c = n.dot(unit_dirs[j]);
                    if row[j] > 0.0 && c > 0.0 {
                        out.hours.push(h as u32);
                        out.lux
                            .push((sky.hours[h].direct_normal_lx * row[j] as f64 * c) as f32);
                    }
                }
                out.offsets.push(out.hours.len());
                for (pi, &p) in patch_list.iter().enumerate() {
                    let base = ns + pi * m;
                    let f: Vec<f64> = (0..m)
                        .map(|s| row[base + s] as f64 * n.dot(unit_dirs[base + s]).max(0.0))
                        .collect();
                    // One jittered direction per cell of equal solid angle: the mean, and
                    // the variance by pairs of neighbouring cells (collapsed strata, an
                    // upper bound).
                    let wgt = sky.patches.solid_angle(p) / m as f64;
                    let sum: f64 = f.iter().sum();
                    let var: f64 = f
                        .chunks(2)
                        .map(|c| (c[0] - c.get(1).copied().unwrap_or(c[0])).powi(2))
                        .sum::<f64>()
                        * wgt
                        * wgt;
                    out.patch_direct[k * np + p] = wgt * sum;
                    out.patch_direct_sigma[k * np + p] = var.sqrt();
                }
            }
        }
        Ok(out)
    }

    /// Sensor `k`'s direct sun in hour `h`, lx (0 when the sun does not reach it).
    pub fn lux_at(&self, k: usize, h: usize) -> f64 {
        let r = self.offsets[k]..self.offsets[k + 1];
        self.hours[r.clone()]
            .binary_search(&(h as u32))
            .map_or(0.0, |i| self.lux[r.start + i] as f64)
    }

    /// Sensor `k`'s hours of direct sun and their illuminance, lx.
    pub fn at(&self, k: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let r = self.offsets[k]..self.offsets[k + 1];
        self.hours[r.clone()]
            .iter()
            .zip(&self.lux[r])
            .map(|(&h, &x)| (h as usize, x as f64))
    }
}

/// What the metrics count and against what.
#[derive(Clone, Debug, PartialEq)]
pub struct MetricOptions {
    /// Per hour of the sky: whether it is occupied (counted). Empty: every hour whose sun
    /// is up (zenith angle < 90°) is.
    pub occupied: Vec<bool>,
    /// DA's and cDA's threshold, lx (LM-83's sDA: 300).
    pub threshold_lx: f64,
    /// The share of occupied hours a sensor must reach the threshold in for sDA (0.5).
    pub sda_share: f64,
    /// UDI's bands: below `udi_low` (100 lx) it falls short, above `udi_high` (3000 lx) it
    /// exceeds.
    pub udi_low: f64,
    pub udi_high: f64,
    /// Draws of the coefficients for the confidence (0: none), and their seed.
    pub draws: usize,
    pub seed: u64,
    /// ASE's direct-sun illuminance, lx, and the occupied hours a sensor must exceed it
    /// in (IES LM-83: 1000 lx, more than 250 hours).
    pub ase_lx: f64,
    pub ase_hours: usize,
    /// EN 17037's daylight hours, per hour of the sky (empty: `brightest_half`).
    pub daylight_hours: Vec<bool>,
    /// LM-83's blinds rule (`metrics_with_blinds`): the blinds close in an hour in which
    /// more than this share of the points get direct sun above `ase_lx` (0.02).
    pub blinds_share: f64,
}

impl Default for MetricOptions {
    fn default() -> Self {
        MetricOptions {
            occupied: Vec::new(),
            threshold_lx: 300.0,
            sda_share: 0.5,
            udi_low: 100.0,
            udi_high: 3000.0,
            draws: 100,
            seed: 1,
            ase_lx: 1000.0,
            ase_hours: 250,
            daylight_hours: Vec::new(),
            blinds_share: 0.02,
        }
    }
}

/// A sensor's annual metrics (shares of the occupied hours, 0–1).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorMetrics {
    /// Daylight autonomy: the share of occupied hours at or above the threshold.
    pub da: f64,
    /// Continuous DA: the mean of min(E / threshold, 1).
    pub cda: f64,
    /// UDI: the shares below `udi_low`, between the bounds, above `udi_high`.
    pub udi_below: f64,
    pub udi_useful: f64,
    pub udi_above: f64,
    /// The probability that the sensor's DA reaches `sda_share` (the share of draws in
    /// which it does; 0 or 1 without draws).
    pub sda_pass_probability: f64,
    /// The occupied hours in which its direct sun exceeds `ase_lx` (0 without the direct
    /// sun).
    pub ase_hours: usize,
}

/// A grid's annual metrics.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GridMetrics {
    /// Spatial daylight autonomy: the share of sensors whose DA reaches `sda_share`.
    pub sda: f64,
    /// Its standard deviation over the draws, and the 2.5 % and 97.5 % quantiles of the
    /// draws' sDA (the 95 % interval); NaN without draws.
    pub sda_sigma: f64,
    pub sda_interval: (f64, f64),
    /// UDI's three bands (below, useful, above) as the grid's mean share of occupied
    /// hours, their standard deviations over the draws and their 95 % intervals (NaN
    /// without draws).
    pub udi: [f64; 3],
    pub udi_sigma: [f64; 3],
    pub udi_interval: [(f64, f64); 3],
    /// Annual sunlight exposure: the share of sensors whose direct sun exceeds `ase_lx`
    /// in more than `ase_hours` occupied hours (None without the direct sun). The direct
    /// sun is traced along its line, not sampled: it carries no Monte Carlo error.
    pub ase: Option<f64>,
    /// Occupied hours in which LM-83's rule closed the blinds (0 without a shaded model);
    /// with window groups, the occupied hours in which any group was out of its state 0.
    pub blinds_closed_hours: usize,
    /// Per window group (`metrics_with_shading`; the blinds of `metrics_with_blinds` are
    /// one group of two states), the occupied hours it spent in each of its states.
    pub group_state_hours: Vec<Vec<usize>>,
    /// EN 17037's criteria over the daylight hours (None when there are none).
    pub en17037: Option<En17037>,
    /// Occupied hours counted.
    pub occupied_hours: usize,
    pub sensors: Vec<SensorMetrics>,
}

/// The hourly illuminance at every sensor (lx, hour by hour: `hours × sensors`) and its
/// standard error.
///
/// With `sun`, the sky's vectors must leave the sun out (`SunInVectors::Left`) and the
/// sun comes in as `DirectSun` says.
pub fn hourly<'a>(
    c: impl Into<CoefficientsView<'a>>,
    sky: &AnnualSky,
    sun: Option<&DirectSun>,
) -> Result<(Vec<f64>, Vec<f64>)> {
    hourly_range(c, sky, sun, 0..sky.hours.len())
}

/// `hourly` for the sky's hours `range` only (`range.len() × sensors` values): a year
/// streamed a part at a time.
pub fn hourly_range<'a>(
    c: impl Into<CoefficientsView<'a>>,
    sky: &AnnualSky,
    sun: Option<&DirectSun>,
    range: std::ops::Range<usize>,
) -> Result<(Vec<f64>, Vec<f64>)> {
    hourly_with_shading(
        &Shading::blinds(c.into(), sun, None),
        sky,
        &MetricOptions::default(),
        range,
    )
}

/// `hourly_range` of a grid whose light is `shading`'s parts, each window group in the
/// state its rule (read with `o`'s `blinds_share` and `ase_lx`) picks for the hour.
pub fn hourly_with_shading(
    shading: &Shading,
    sky: &AnnualSky,
    o: &MetricOptions,
    range: std::ops::Range<usize>,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let (sensors, n) = shading.check(sky, o)?;
    if range.start > range.end || range.end > sky.hours.len() {
        bail!(
            ImapErrIndexOutOfRange,
            "hours {}..{} are not within the sky's {}",
            range.start,
            range.end,
            sky.hours.len()
        );
    }
    let counted: Vec<bool> = (0..sky.hours.len()).map(|h| range.contains(&h)).collect();
    let threads = std::thread::available_parallelism().map_or(1, |x| x.get());
    let states = shading.states(sky, o, &counted, threads);
    let hours = range.len();
    let mut e = vec![0.0; hours * sensors];
    let mut s = vec![0.0; hours * sensors];
    let mut scratch = shading.scratch(sky.hours.len());
    for k in 0..sensors {
        let parts = shading::SensorParts::new(shading, k, n, &mut scratch);
        for (i, h) in range.clone().enumerate() {
            let (x, sx) = parts.hour(sky, h, &states);
            e[i * sensors + k] = x;
            s[i * sensors + k] = sx;
        }
    }
    Ok((e, s))
}

/// Each window group's state in every hour of the sky, by its rule (read with `o`'s
/// `blinds_share` and `ase_lx`) on `shading`'s sensors: what the metrics and the hourly
/// illuminance use, for a host to apply to other sensors (a glare rule decided at the
/// observers, given to the grids as `ShadingRule::Schedule`).
pub fn shading_states(
    shading: &Shading,
    sky: &AnnualSky,
    o: &MetricOptions,
) -> Result<Vec<Vec<u16>>> {
    shading.check(sky, o)?;
    let threads = std::thread::available_parallelism().map_or(1, |x| x.get());
    Ok(shading.states(sky, o, &vec![true; sky.hours.len()], threads))
}

/// Checks that `sun` (if any) belongs to `c` and `sky`.
fn check_sun(c: CoefficientsView, sky: &AnnualSky, sun: Option<&DirectSun>) -> Result<()> {
    let Some(s) = sun else {
        return Ok(());
    };
    if sky.sun != SunInVectors::Left {
        bail!(
            ImapErrInvalidArgument,
            "the sky's vectors hold the sun in its patch already: with the direct sun, make them with SunInVectors::Left"
        );
    }
    if s.sensors != c.sensors || s.patches != c.patches || s.offsets.len() != s.sensors + 1 {
        bail!(
            ImapErrInvalidArgument,
            "the direct sun is of {} sensors × {} patches; the coefficients of {} × {}",
            s.sensors,
            s.patches,
            c.sensors,
            c.patches
        );
    }
    if s.hours.iter().any(|&h| h as usize >= sky.hours.len()) {
        bail!(
            ImapErrInvalidArgument,
            "the direct sun holds hours beyond the sky's {}",
            sky.hours.len()
        );
    }
    Ok(())
}

/// One sensor's coefficients, their errors, and (with the direct sun) its direct-only
/// patch coefficients and its hours of direct sun (`direct`, one per sky hour).
struct Sensor<'a> {
    c: &'a [f64],
    sigma: &'a [f64],
    sun: Option<(&'a [f64], &'a [f64], &'a [f64])>,
}

impl<'a> Sensor<'a> {
    fn new(
        c: CoefficientsView<'a>,
        sun: Option<&'a DirectSun>,
        k: usize,
        n: usize,
        direct: &'a mut [f64],
    ) -> Self {
        let row = k * n..(k + 1) * n;
        let sun = sun.map(|s| {
            direct.iter_mut().for_each(|x| *x = 0.0);
            for (h, x) in s.at(k) {
                direct[h] = x;
            }
            (
                &s.patch_direct[row.clone()],
                &s.patch_direct_sigma[row.clone()],
                &*direct,
            )
        });
        Sensor {
            c: &c.value[row.clone()],
            sigma: &c.sigma[row],
            sun,
        }
    }

    /// The sun of hour `h`: the patch q that holds it, its luminance l = E_n / Ω_q spread
    /// over it, and its direct illuminance at the sensor (None without the direct sun or
    /// a sun).
    fn sun_of(&self, sky: &AnnualSky, h: usize) -> Option<(usize, f64, f64)> {
        let (_, _, direct) = self.sun?;
        let a = &sky.hours[h];
        (a.direct_normal_lx > 0.0 && a.sun_patch > 0).then(|| {
            let q = a.sun_patch;
            (
                q,
                a.direct_normal_lx / sky.patches.solid_angle(q),
                direct[h],
            )
        })
    }

    /// Hour `h`'s illuminance and its standard error: Σ L_p C_p and √Σ (L_p σ_p)² under
    /// the hour's vector, with the sun's parts (`DirectSun`).
    fn hour(&self, sky: &AnnualSky, h: usize) -> (f64, f64) {
        let v = sky.vector(h);
        let (mut x, mut var) = (0.0, 0.0);
        for ((l, c), s) in v.iter().zip(self.c).zip(self.sigma) {
            x += l * c;
            var += (l * s).powi(2);
        }
        if let (Some((q, l, e)), Some((d, ds, _))) = (self.sun_of(sky, h), self.sun) {
            x += l * (self.c[q] - d[q]) + e;
            var += ((v[q] + l).powi(2) - v[q] * v[q]) * self.sigma[q].powi(2) + (l * ds[q]).powi(2);
        }
        (x, var.sqrt())
    }
}

/// A sensor's coefficients as a draw moves them: the patches with an error, and the
/// draw's offsets.
struct Drawn<'a> {
    sensor: Sensor<'a>,
    lit: Vec<usize>,
    lit_direct: Vec<usize>,
    delta: Vec<f64>,
    delta_direct: Vec<f64>,
}

impl<'a> Drawn<'a> {
    fn new(sensor: Sensor<'a>) -> Self {
        let n = sensor.c.len();
        let lit = (0..n).filter(|&p| sensor.sigma[p] > 0.0).collect();
        // The patches whose direct-only coefficient has an error (the sun's).
        let lit_direct = sensor
            .sun
            .map_or(Vec::new(), |s| (0..n).filter(|&p| s.1[p] > 0.0).collect());
        Drawn {
            sensor,
            lit,
            lit_direct,
            delta: vec![0.0; n],
            delta_direct: vec![0.0; n],
        }
    }

    /// Draws the offsets: C_p + σ_p N(0, 1), D_p + σ_Dp N(0, 1).
    fn draw(&mut self, rng: &mut PhotonRng) {
        for &p in &self.lit {
            self.delta[p] = self.sensor.sigma[p] * normal(rng);
        }
        if let Some(s) = self.sensor.sun {
            for &p in &self.lit_direct {
                self.delta_direct[p] = s.1[p] * normal(rng);
            }
        }
    }

    /// How far the draw moves hour `h`'s illuminance from the estimate's.
    fn offset(&self, sky: &AnnualSky, h: usize) -> f64 {
        let v = sky.vector(h);
        let mut x = self.lit.iter().map(|&p| v[p] * self.delta[p]).sum::<f64>();
        if let Some((q, l, _)) = self.sensor.sun_of(sky, h) {
            x += l * (self.delta[q] - self.delta_direct[q]);
        }
        x
    }
}

/// One sensor's metrics from its hourly illuminance over the occupied hours.
fn sensor_metrics(e: impl Iterator<Item = f64>, o: &MetricOptions, count: usize) -> SensorMetrics {
    let mut m = SensorMetrics::default();
    for x in e {
        if x >= o.threshold_lx {
            m.da += 1.0;
        }
        m.cda += (x / o.threshold_lx).min(1.0);
        if x < o.udi_low {
            m.udi_below += 1.0;
        } else if x > o.udi_high {
            m.udi_above += 1.0;
        } else {
            m.udi_useful += 1.0;
        }
    }
    let k = 1.0 / count.max(1) as f64;
    m.da *= k;
    m.cda *= k;
    m.udi_below *= k;
    m.udi_useful *= k;
    m.udi_above *= k;
    m
}

/// UDI's band of an illuminance: 0 below `udi_low`, 2 above `udi_high`, 1 between (as
/// `sensor_metrics` counts them).
fn udi_band(x: f64, o: &MetricOptions) -> usize {
    if x < o.udi_low {
        0
    } else if x > o.udi_high {
        2
    } else {
        1
    }
}

/// A standard normal number (Box–Muller).
fn normal(rng: &mut PhotonRng) -> f64 {
    let u1 = rng.uniform().max(1e-300);
    let u2 = rng.uniform();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// The annual metrics of a grid of sensors with coefficients `c` under `sky` (and the
/// direct sun `sun`, as `hourly` takes it; ASE needs it), with their confidence from
/// `o.draws` draws of the coefficients.
pub fn metrics<'a>(
    c: impl Into<CoefficientsView<'a>>,
    sky: &AnnualSky,
    sun: Option<&DirectSun>,
    o: &MetricOptions,
) -> Result<GridMetrics> {
    metrics_with_blinds(c, sky, sun, None, o)
}

/// One thread's share of `metrics_with_blinds`: its points' metrics, its sums over the
/// draws and the hours, and its scratch.
struct Chunk {
    sensors: Vec<SensorMetrics>,
    draws_sda: Vec<f64>,
    /// Per draw and UDI band, the sensors' hours in the band (whole counts).
    draws_udi: Vec<u64>,
    en_base: Vec<u32>,
    en_draws: Vec<u32>,
    ase_sensors: usize,
}

impl Chunk {
    fn new(draws: usize, en: usize) -> Self {
        Chunk {
            sensors: Vec::new(),
            draws_sda: vec![0.0; draws],
            draws_udi: vec![0; 3 * draws],
            en_base: vec![0; en],
            en_draws: vec![0; draws * en],
            ase_sensors: 0,
        }
    }
}

/// A model state's coefficients at the sensors and its direct sun (None: it lets no sun
/// through in a line): the model with its blinds closed (IES LM-83's operable shading,
/// `metrics_with_blinds`), or a window group's state or the base of a `Shading`.
#[derive(Clone, Copy, Debug)]
pub struct Shaded<'a> {
    pub coefficients: CoefficientsView<'a>,
    pub sun: Option<&'a DirectSun>,
}

/// `metrics` with LM-83's rule for operable blinds: in every hour in which more than
/// `o.blinds_share` (2 %) of the points get direct sun above `o.ase_lx` with the blinds
/// open, the blinds close and every point's illuminance is the `shaded` model's. ASE
/// counts the blinds open, as LM-83 defines it. The rule reads the direct sun: `sun` is
/// needed with `shaded`.
pub fn metrics_with_blinds<'a>(
    c: impl Into<CoefficientsView<'a>>,
    sky: &AnnualSky,
    sun: Option<&DirectSun>,
    shaded: Option<Shaded>,
    o: &MetricOptions,
) -> Result<GridMetrics> {
    metrics_with_shading(&Shading::blinds(c.into(), sun, shaded), sky, o)
}

/// The annual metrics of a grid whose light is `shading`'s parts: the light through no
/// window group and each group in the state its rule picks every hour (`ShadingRule`).
/// ASE counts every group in its state 0 (open); `GridMetrics::group_state_hours` says
/// how many occupied hours each group spent in each state.
pub fn metrics_with_shading(
    shading: &Shading,
    sky: &AnnualSky,
    o: &MetricOptions,
) -> Result<GridMetrics> {
    let threads = std::thread::available_parallelism().map_or(1, |x| x.get());
    metrics_on(shading, sky, o, threads)
}

/// `metrics_with_shading` on `threads` threads (the same metrics for any count).
fn metrics_on(
    shading: &Shading,
    sky: &AnnualSky,
    o: &MetricOptions,
    threads: usize,
) -> Result<GridMetrics> {
    let (sensors_count, n) = shading.check(sky, o)?;
    if !(o.threshold_lx > 0.0 && o.threshold_lx.is_finite()) {
        bail!(
            ImapErrInvalidArgument,
            "threshold_lx = {}: must be > 0",
            o.threshold_lx
        );
    }
    if !(0.0..=1.0).contains(&o.sda_share) {
        bail!(
            ImapErrInvalidArgument,
            "sda_share = {}: must be in [0, 1]",
            o.sda_share
        );
    }
    if !(o.udi_low >= 0.0 && o.udi_low < o.udi_high && o.udi_high.is_finite()) {
        bail!(
            ImapErrInvalidArgument,
            "udi_low = {}, udi_high = {}: need 0 ≤ low < high",
            o.udi_low,
            o.udi_high
        );
    }
    if !o.daylight_hours.is_empty() && o.daylight_hours.len() != sky.hours.len() {
        bail!(
            ImapErrInvalidArgument,
            "daylight_hours holds {} hours; the sky has {}",
            o.daylight_hours.len(),
            sky.hours.len()
        );
    }
    let occupied = occupied_hours(sky, o)?;
    let count = occupied.iter().filter(|&&x| x).count();
    let daylight = if o.daylight_hours.is_empty() {
        brightest_half(sky)
    } else {
        o.daylight_hours.clone()
    };
    // The hours either set counts, with their places among the daylight hours.
    let day_index: Vec<Option<usize>> = {
        let mut next = 0;
        daylight
            .iter()
            .map(|&d| {
                d.then(|| {
                    next += 1;
                    next - 1
                })
            })
            .collect()
    };
    let day_count = daylight.iter().filter(|&&x| x).count();
    let hours: Vec<usize> = (0..sky.hours.len())
        .filter(|&h| occupied[h] || daylight[h])
        .collect();
    // EN 17037's illuminances: per hour, how many sensors reach each (the estimate's, and
    // each draw's).
    let en = EN17037_LX;
    let passes = |m: &SensorMetrics| m.da >= o.sda_share;
    let counted: Vec<bool> = (0..sky.hours.len())
        .map(|h| occupied[h] || daylight[h])
        .collect();
    let states = shading.states(sky, o, &counted, threads);
    let sun = shading.has_sun();
    // The points are independent of each other (a point's draws are its own): taken in
    // chunks on every core, each with its own sums, added in chunk order (whole counts:
    // the same for any split).
    let one_chunk = |range: std::ops::Range<usize>| -> Chunk {
        let mut acc = Chunk::new(o.draws, en.len() * day_count);
        let mut scratch = shading.scratch(sky.hours.len());
        for k in range {
            let mut parts = shading::SensorParts::new(shading, k, n, &mut scratch);
            // Each counted hour's illuminance and standard error.
            let e: Vec<(f64, f64)> = hours.iter().map(|&h| parts.hour(sky, h, &states)).collect();
            let mut m = sensor_metrics(
                e.iter()
                    .zip(&hours)
                    .filter(|(_, &h)| occupied[h])
                    .map(|(x, _)| x.0),
                o,
                count,
            );
            if sun {
                m.ase_hours = hours
                    .iter()
                    .filter(|&&h| occupied[h] && parts.open_direct(h) > o.ase_lx)
                    .count();
                if m.ase_hours > o.ase_hours {
                    acc.ase_sensors += 1;
                }
            }
            // A draw can move an hour across a threshold only where it lies within a few of
            // its errors of it (beyond 6 σ: less than 10⁻⁹ per hour): the rest are fixed.
            let near = |x: f64, s: f64, t: f64| (x - t).abs() <= 6.0 * s;
            let udi_near = |x: f64, s: f64| near(x, s, o.udi_low) || near(x, s, o.udi_high);
            let (mut open, mut fixed) = (Vec::new(), 0usize);
            let mut udi_fixed = [0u64; 3];
            for (i, &(x, s)) in e.iter().enumerate() {
                let h = hours[i];
                if let Some(d) = day_index[h] {
                    for (t, lx) in en.iter().enumerate() {
                        if x >= *lx {
                            acc.en_base[t * day_count + d] += 1;
                        }
                    }
                }
                let sda_open = occupied[h] && near(x, s, o.threshold_lx);
                let en_open = day_index[h].is_some() && en.iter().any(|&t| near(x, s, t));
                let udi_open = occupied[h] && udi_near(x, s);
                if sda_open || en_open || udi_open {
                    open.push(i);
                }
                if occupied[h] && !sda_open && x >= o.threshold_lx {
                    fixed += 1;
                }
                if occupied[h] && !udi_open {
                    udi_fixed[udi_band(x, o)] += 1;
                }
            }
            // In a draw, the EN counts of the open hours are redrawn: take the estimate's out.
            let en_fixed: Vec<(usize, usize)> = open
                .iter()
                .filter_map(|&i| day_index[hours[i]].map(|d| (i, d)))
                .collect();
            let mut pass = 0usize;
            for (j, sum) in acc.draws_sda.iter_mut().enumerate() {
                // The draw's stream: one per (sensor, draw), so any sensor subset or order
                // gives the same draws (the shaded model's after the open one's).
                let mut rng = PhotonRng::new(o.seed, ((k as u64) << 20) | j as u64);
                parts.draw(&mut rng);
                let counts =
                    &mut acc.en_draws[j * en.len() * day_count..(j + 1) * en.len() * day_count];
                let mut above = fixed;
                let mut udi = udi_fixed;
                for &i in &open {
                    let h = hours[i];
                    let x = parts.drawn(sky, h, e[i].0, &states);
                    if occupied[h] && near(e[i].0, e[i].1, o.threshold_lx) && x >= o.threshold_lx {
                        above += 1;
                    }
                    if occupied[h] && udi_near(e[i].0, e[i].1) {
                        udi[udi_band(x, o)] += 1;
                    }
                    if let Some(d) = day_index[h] {
                        for (t, lx) in en.iter().enumerate() {
                            if x >= *lx {
                                counts[t * day_count + d] += 1;
                            }
                        }
                    }
                }
                // The hours not redrawn count as the estimate's: added to every draw below,
                // less the open ones' estimate (`en_fixed`), which the draw replaced.
                for &(i, d) in &en_fixed {
                    for (t, lx) in en.iter().enumerate() {
                        if e[i].0 >= *lx {
                            counts[t * day_count + d] = counts[t * day_count + d].wrapping_sub(1);
                        }
                    }
                }
                if above as f64 >= o.sda_share * count as f64 {
                    pass += 1;
                    *sum += 1.0;
                }
                for (b, n) in udi.iter().enumerate() {
                    acc.draws_udi[3 * j + b] += n;
                }
            }
            m.sda_pass_probability = if o.draws > 0 {
                pass as f64 / o.draws as f64
            } else if passes(&m) {
                1.0
            } else {
                0.0
            };
            acc.sensors.push(m);
        }
        acc
    };
    // Each chunk keeps its own per-draw, per-hour counts: no more chunks than keep them
    // within 256 MiB together.
    let chunk_bytes =
        4 * o.draws * en.len() * day_count + 8 * sky.hours.len() * (1 + shading.parts().len());
    let threads = threads.min((256 << 20) / chunk_bytes.max(1));
    let chunks: Vec<Chunk> = in_chunks(sensors_count, threads, one_chunk);
    let mut sensors = Vec::with_capacity(sensors_count);
    let mut draws_sda = vec![0.0; o.draws];
    let mut draws_udi = vec![0u64; 3 * o.draws];
    let mut en_base = vec![0u32; en.len() * day_count];
    let mut en_draws = vec![0u32; o.draws * en.len() * day_count];
    let mut ase_sensors = 0usize;
    for ch in chunks {
        sensors.extend(ch.sensors);
        draws_sda
            .iter_mut()
            .zip(&ch.draws_sda)
            .for_each(|(a, b)| *a += b);
        draws_udi
            .iter_mut()
            .zip(&ch.draws_udi)
            .for_each(|(a, b)| *a += b);
        en_base
            .iter_mut()
            .zip(&ch.en_base)
            .for_each(|(a, b)| *a += b);
        en_draws
            .iter_mut()
            .zip(&ch.en_draws)
            .for_each(|(a, b)| *a = a.wrapping_add(*b));
        ase_sensors += ch.ase_sensors;
    }
    // Each draw's counts: the estimate's, with the open hours' replaced.
    for j in 0..o.draws {
        let counts = &mut en_draws[j * en.len() * day_count..(j + 1) * en.len() * day_count];
        for (c, b) in counts.iter_mut().zip(&en_base) {
            *c = c.wrapping_add(*b);
        }
    }
    let total = sensors_count.max(1) as f64;
    let sda = sensors.iter().filter(|m| passes(m)).count() as f64 / total;
    let (sda_sigma, sda_interval) =
        spread(&draws_sda.iter().map(|x| x / total).collect::<Vec<_>>());
    // UDI's grid means: the sensors' shares, and each draw's from its whole counts. A
    // grid's mean share is known far better than any sensor's, so the draws' bias (a
    // threshold's share moves with the errors where the hours crowd on one side of it)
    // is no longer small against their spread: the interval is the draws' quantiles less
    // that bias (the draws' mean less the estimate), within [0, 1].
    let mean = |f: fn(&SensorMetrics) -> f64| sensors.iter().map(f).sum::<f64>() / total;
    let udi = [
        mean(|m| m.udi_below),
        mean(|m| m.udi_useful),
        mean(|m| m.udi_above),
    ];
    let (mut udi_sigma, mut udi_interval) = ([f64::NAN; 3], [(f64::NAN, f64::NAN); 3]);
    for b in 0..3 {
        let d: Vec<f64> = (0..o.draws)
            .map(|j| draws_udi[3 * j + b] as f64 / (count as f64 * total))
            .collect();
        (udi_sigma[b], udi_interval[b]) = debiased_spread(&d, udi[b]);
    }
    let en17037 = (day_count > 0).then(|| {
        let share = |counts: &[u32], t: usize, plane: f64| -> f64 {
            let need = plane * sensors_count as f64;
            counts[t * day_count..(t + 1) * day_count]
                .iter()
                .filter(|&&x| x as f64 >= need)
                .count() as f64
                / day_count as f64
        };
        let levels = EN17037_LEVELS.map(|(name, target, minimum)| {
            let (ti, mi) = (lx_index(target), lx_index(minimum));
            let time = |counts: &[u32]| {
                (
                    share(counts, ti, EN17037_TARGET_PLANE),
                    share(counts, mi, EN17037_MINIMUM_PLANE),
                )
            };
            let (target_share, minimum_share) = time(&en_base);
            let ok = |(a, b): (f64, f64)| a >= EN17037_TIME && b >= EN17037_TIME;
            let draws: Vec<(f64, f64)> = (0..o.draws)
                .map(|j| time(&en_draws[j * en.len() * day_count..(j + 1) * en.len() * day_count]))
                .collect();
            let pass_probability = if o.draws > 0 {
                draws.iter().filter(|&&x| ok(x)).count() as f64 / o.draws as f64
            } else if ok((target_share, minimum_share)) {
                1.0
            } else {
                0.0
            };
            En17037Level {
                name,
                target_lx: target,
                minimum_lx: minimum,
                target_share,
                target_interval: spread(&draws.iter().map(|x| x.0).collect::<Vec<_>>()).1,
                minimum_share,
                minimum_interval: spread(&draws.iter().map(|x| x.1).collect::<Vec<_>>()).1,
                passes: ok((target_share, minimum_share)),
                pass_probability,
            }
        });
        En17037 {
            daylight_hours: day_count,
            levels,
        }
    });
    Ok(GridMetrics {
        sda,
        sda_sigma,
        sda_interval,
        udi,
        udi_sigma,
        udi_interval,
        blinds_closed_hours: hours
            .iter()
            .filter(|&&h| occupied[h] && states.iter().any(|s| s[h] != 0))
            .count(),
        group_state_hours: shading
            .groups
            .iter()
            .zip(&states)
            .map(|(g, s)| {
                let mut n = vec![0; g.states.len()];
                for &h in &hours {
                    if occupied[h] {
                        n[s[h] as usize] += 1;
                    }
                }
                n
            })
            .collect(),
        ase: sun.then(|| ase_sensors as f64 / total),
        en17037,
        occupied_hours: count,
        sensors,
    })
}

/// `f` over `0..sensors` in up to `threads` contiguous chunks, each on a thread of its
/// own; the chunks' results in order (a chunk's panic goes on here).
fn in_chunks<T: Send>(
    sensors: usize,
    threads: usize,
    f: impl Fn(std::ops::Range<usize>) -> T + Sync,
) -> Vec<T> {
    let threads = threads.clamp(1, sensors.max(1));
    let per = sensors.div_ceil(threads).max(1);
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let r = (t * per).min(sensors)..((t + 1) * per).min(sensors);
                let f = &f;
                s.spawn(move || f(r))
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
            .collect()
    })
}

/// The hours `o` counts: `o.occupied`, or (empty) every hour whose sun is up; an error
/// when it counts none.
fn occupied_hours(sky: &AnnualSky, o: &MetricOptions) -> Result<Vec<bool>> {
    if !o.occupied.is_empty() && o.occupied.len() != sky.hours.len() {
        bail!(
            ImapErrInvalidArgument,
            "occupied holds {} hours; the sky has {}",
            o.occupied.len(),
            sky.hours.len()
        );
    }
    let occupied: Vec<bool> = (0..sky.hours.len())
        .map(|h| {
            if o.occupied.is_empty() {
                sky.hours[h].sun_zenith_deg < 90.0
            } else {
                o.occupied[h]
            }
        })
        .collect();
    if !occupied.contains(&true) {
        bail!(
            ImapErrInvalidArgument,
            "no occupied hour: the metrics count none"
        );
    }
    Ok(occupied)
}

/// The daylight factor at each sensor and its standard error: the illuminance under the
/// CIE standard overcast sky (Moon and Spencer's L(Z) ∝ 1 + 2 cos Z, as Radiance's
/// `gensky -c`) with the ground glowing ρ E_h / π below the horizon, over that sky's
/// unobstructed horizontal illuminance E_h: Σ_p v_p C_p with the patches' mean luminance
/// v_p (8 × 8 points of equal solid angle) scaled so that the patch sky itself gives
/// E_h = 1 (Σ v_p ∫_p cos dω: an open horizontal point reads exactly 100 %; the patches'
/// uniform luminance gives 0.4 % less than the sky they stand for).
pub fn daylight_factor<'a>(
    c: impl Into<CoefficientsView<'a>>,
    patches: &SkyPatches,
    ground_reflectance: f64,
) -> Result<Vec<(f64, f64)>> {
    let c = c.into();
    c.check()?;
    crate::error::check_range("ground_reflectance", ground_reflectance, 0.0, 1.0)?;
    let n = patches.count();
    if c.patches != n {
        bail!(
            ImapErrInvalidArgument,
            "coefficients of {} patches for MF:{}'s {n}",
            c.patches,
            patches.mf()
        );
    }
    let mut v = vec![0.0; n];
    let mut horizontal = 0.0;
    for (q, o) in v.iter_mut().enumerate().skip(1) {
        *o = patches.means(q, 8, |alt, _| (1.0 + 2.0 * alt.sin(), 0.0)).0;
        horizontal += *o * patches.horizontal(q);
    }
    v.iter_mut().skip(1).for_each(|x| *x /= horizontal);
    v[0] = ground_reflectance / std::f64::consts::PI;
    Ok((0..c.sensors)
        .map(|k| {
            let row = k * n..(k + 1) * n;
            let (mut x, mut var) = (0.0, 0.0);
            for ((l, c), s) in v.iter().zip(&c.value[row.clone()]).zip(&c.sigma[row]) {
                x += l * c;
                var += (l * s).powi(2);
            }
            (x, var.sqrt())
        })
        .collect())
}

/// The standard deviation and the 2.5 % and 97.5 % quantiles of draws `d` (NaN without).
/// `spread` of draws of a share whose estimate is `estimate`, the interval less the draws'
/// bias (their mean less the estimate) and kept within [0, 1]: for shares of threshold
/// crossings, whose draws move with the errors where the hours crowd on one side.
fn debiased_spread(d: &[f64], estimate: f64) -> (f64, (f64, f64)) {
    let (s, (lo, hi)) = spread(d);
    let bias = d.iter().sum::<f64>() / d.len().max(1) as f64 - estimate;
    (
        s,
        ((lo - bias).clamp(0.0, 1.0), (hi - bias).clamp(0.0, 1.0)),
    )
}

fn spread(d: &[f64]) -> (f64, (f64, f64)) {
    if d.is_empty() {
        return (f64::NAN, (f64::NAN, f64::NAN));
    }
    let mut d = d.to_vec();
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (d.len().max(2) - 1) as f64;
    d.sort_by(f64::total_cmp);
    let q = |f: f64| d[((f * (d.len() - 1) as f64).round() as usize).min(d.len() - 1)];
    (var.sqrt(), (q(0.025), q(0.975)))
}

/// EN 17037's daylight hours by default: the half of the sky's hours with the most global
/// horizontal illuminance (E_dh + E_n cos Z; ties by order), as the standard defines them
/// ("the half of the year with the largest quantity of daylight": 4380 of 8760).
pub fn brightest_half(sky: &AnnualSky) -> Vec<bool> {
    let global = |a: &AnnualHour| {
        a.diffuse_horizontal_lx + a.direct_normal_lx * a.sun_zenith_deg.to_radians().cos().max(0.0)
    };
    let mut order: Vec<usize> = (0..sky.hours.len()).collect();
    order.sort_by(|&a, &b| {
        global(&sky.hours[b])
            .total_cmp(&global(&sky.hours[a]))
            .then(a.cmp(&b))
    });
    let mut out = vec![false; sky.hours.len()];
    for &h in order.iter().take(sky.hours.len() / 2) {
        out[h] = true;
    }
    out
}

/// The illuminances EN 17037's criteria use, lx.
const EN17037_LX: [f64; 4] = [100.0, 300.0, 500.0, 750.0];

fn lx_index(lx: f64) -> usize {
    EN17037_LX
        .iter()
        .position(|&x| x == lx)
        .expect("an EN 17037 illuminance")
}

/// EN 17037's recommendation levels for daylight through vertical and inclined openings:
/// (name, target E_T, minimum target E_TM), lx.
const EN17037_LEVELS: [(&str, f64, f64); 3] = [
    ("minimum", 300.0, 100.0),
    ("medium", 500.0, 300.0),
    ("high", 750.0, 500.0),
];
/// The reference plane's shares for E_T and E_TM, and the daylight hours' share.
const EN17037_TARGET_PLANE: f64 = 0.5;
const EN17037_MINIMUM_PLANE: f64 = 0.95;
const EN17037_TIME: f64 = 0.5;

/// EN 17037 (daylight provision, vertical and inclined openings, by hourly illuminance):
/// a level is met when E_T is reached over half the reference plane and E_TM over 95 % of
/// it, each in at least half the daylight hours.
#[derive(Clone, Debug, PartialEq)]
pub struct En17037 {
    pub daylight_hours: usize,
    /// Minimum, medium and high.
    pub levels: [En17037Level; 3],
}

impl En17037 {
    /// The highest level met (None: not even the minimum).
    pub fn level(&self) -> Option<&'static str> {
        self.levels.iter().rev().find(|l| l.passes).map(|l| l.name)
    }
}

/// One EN 17037 level's figures: the shares of daylight hours in which E_T reaches half
/// the points and E_TM 95 % of them, with their 95 % intervals over the draws, whether the
/// level is met and the probability that it is.
#[derive(Clone, Debug, PartialEq)]
pub struct En17037Level {
    pub name: &'static str,
    pub target_lx: f64,
    pub minimum_lx: f64,
    pub target_share: f64,
    pub target_interval: (f64, f64),
    pub minimum_share: f64,
    pub minimum_interval: (f64, f64),
    pub passes: bool,
    pub pass_probability: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::weather::{WeatherHour, WeatherSite};

    fn site() -> WeatherSite {
        WeatherSite {
            name: "t".into(),
            latitude_deg: 48.0,
            longitude_deg: 11.0,
            utc_offset_hours: 1.0,
            elevation_m: 500.0,
        }
    }

    fn hour(month: u32, day: u32, hour: f64, dni: f64, dhi: f64) -> WeatherHour {
        WeatherHour {
            year: 2001,
            month,
            day,
            hour,
            direct_normal_w: Some(dni),
            diffuse_horizontal_w: Some(dhi),
            dew_point_c: None,
            line: 0,
        }
    }

    #[test]
    fn sky_vectors_hold_the_hours_light() {
        let w = Weather {
            site: site(),
            hours: vec![
                hour(6, 21, 12.5, 700.0, 120.0),
                hour(12, 21, 9.5, 0.0, 60.0),
                hour(3, 1, 2.5, 0.0, 0.0),
                hour(9, 15, 16.5, 300.0, 200.0),
            ],
        };
        let rho = 0.2;
        let left = AnnualSky::from_weather(&w, 1, SunInVectors::Left, rho).unwrap();
        let with = AnnualSky::from_weather(&w, 1, SunInVectors::InItsPatch, rho).unwrap();
        let ps = &left.patches;
        for (h, a) in left.hours.iter().enumerate() {
            let (v, s) = (left.vector(h), with.vector(h));
            // The sky's patches give the hour's diffuse horizontal illuminance (to the
            // patches' discretisation of ∫ l cos dω).
            let e: f64 = (1..ps.count()).map(|p| v[p] * ps.horizontal(p)).sum();
            if a.diffuse_horizontal_lx == 0.0 {
                assert!(v.iter().all(|&x| x == 0.0), "night {h}");
                continue;
            }
            assert!(
                (e / a.diffuse_horizontal_lx - 1.0).abs() < 0.01,
                "hour {h}: {e}"
            );
            // Against the sky's own vector (the Distant path): the same to 1 %.
            let (az, zen) = (a.sun_azimuth_deg, a.sun_zenith_deg);
            let p = w.hours[h].perez_sky(zen).unwrap().unwrap();
            let desc = crate::scene::light::SkyDesc {
                kind: crate::scene::light::SkyKind::Perez {
                    sun_azimuth_deg: az,
                    sun_zenith_deg: zen,
                    clearness: p.clearness,
                    brightness: p.brightness,
                },
                amount: crate::scene::light::SkyAmount::HorizontalIlluminance(
                    p.diffuse_horizontal_lx,
                ),
                spectrum: crate::photometry::Spectrum::Equal,
                ..crate::scene::light::SkyDesc::default()
            };
            let b = crate::spectral::Bands::rgb();
            let k = crate::photometry::BandPhotometry::new(&b);
            let other = crate::scene::light::sky_patch_radiance(&desc, &b, 1).unwrap();
            for q in 1..ps.count() {
                let o = k.luminous(&other[q]);
                assert!(
                    (v[q] / o - 1.0).abs() < 0.01,
                    "hour {h} patch {q}: {} vs {o}",
                    v[q]
                );
            }
            // The sun in its patch carries the direct normal illuminance.
            let sun_flux: f64 = (1..ps.count())
                .map(|q| (s[q] - v[q]) * ps.solid_angle(q))
                .sum();
            assert!(
                (sun_flux / a.direct_normal_lx - 1.0).abs() < 1e-9 || a.direct_normal_lx == 0.0
            );
            // The ground glows with ρ E_h / π.
            let global = a.diffuse_horizontal_lx + a.direct_normal_lx * zen.to_radians().cos();
            assert!((v[0] - rho * global / std::f64::consts::PI).abs() < 1e-9);
        }
        // The overcast hour's sun is below nothing: no direct light.
        assert_eq!(left.hours[1].direct_normal_lx, 0.0);
    }

    /// A sky of `hours` hours lit over patches 1–3 only, luminance `l(h, p)`.
    pub(super) fn toy_sky(hours: usize, l: impl Fn(usize, usize) -> f64) -> AnnualSky {
        let patches = SkyPatches::reinhart(1).unwrap();
        let n = patches.count();
        let mut luminance = vec![0.0; hours * n];
        for h in 0..hours {
            for p in 1..4 {
                luminance[h * n + p] = l(h, p);
            }
        }
        AnnualSky {
            patches,
            sun: SunInVectors::Left,
            hours: (0..hours)
                .map(|h| AnnualHour {
                    row: h,
                    month: 1,
                    day: 1,
                    hour: h as f64,
                    sun_azimuth_deg: 180.0,
                    sun_zenith_deg: 45.0,
                    diffuse_horizontal_lx: 1.0,
                    direct_normal_lx: 0.0,
                    sun_patch: 0,
                })
                .collect(),
            luminance,
        }
    }

    /// `toy_sky` at 100 cd/m², with a sun of 50 klx in patch 2 every hour.
    pub(super) fn sunny_toy_sky(hours: usize) -> AnnualSky {
        let mut sky = toy_sky(hours, |_, _| 100.0);
        for a in &mut sky.hours {
            a.direct_normal_lx = 50_000.0;
            a.sun_patch = 2;
        }
        sky
    }

    #[test]
    fn a_constant_overcast_year_gives_the_known_metrics() {
        // Every hour the same sky: each sensor's illuminance is constant, 50–950 lx.
        let sky = toy_sky(100, |_, _| 1000.0);
        let sensors = 10;
        let n = sky.patches.count();
        let mut value = vec![0.0; sensors * n];
        for k in 0..sensors {
            // 3 patches × 1000 cd/m² × c = 50 + 100 k lx.
            for p in 1..4 {
                value[k * n + p] = (50.0 + 100.0 * k as f64) / 3000.0;
            }
        }
        let c = Coefficients {
            sensors,
            patches: n,
            value,
            sigma: vec![0.0; sensors * n],
        };
        let (e, s) = hourly(&c, &sky, None).unwrap();
        assert!((e[3] - 350.0).abs() < 1e-9 && s[3] == 0.0);
        let m = metrics(&c, &sky, None, &MetricOptions::default()).unwrap();
        assert_eq!(m.occupied_hours, 100);
        for (k, s) in m.sensors.iter().enumerate() {
            let x = 50.0 + 100.0 * k as f64;
            assert_eq!(s.da, if x >= 300.0 { 1.0 } else { 0.0 }, "sensor {k}");
            assert!((s.cda - (x / 300.0).min(1.0)).abs() < 1e-12);
            assert_eq!(s.udi_below, if x < 100.0 { 1.0 } else { 0.0 });
            assert_eq!(s.udi_useful + s.udi_below + s.udi_above, 1.0);
            assert_eq!(s.sda_pass_probability, s.da);
        }
        // 350, 450, …, 950 lx: 7 of 10 sensors.
        assert!((m.sda - 0.7).abs() < 1e-12);
        assert_eq!(m.sda_interval, (0.7, 0.7));
        // UDI over the grid: one sensor of ten below 100 lx, none above 3000 lx; no error.
        for (b, x) in [0.1, 0.9, 0.0].into_iter().enumerate() {
            let (lo, hi) = m.udi_interval[b];
            assert!(
                (m.udi[b] - x).abs() < 1e-12 && (lo - x).abs() < 1e-12 && (hi - x).abs() < 1e-12,
                "band {b}: {:?} {:?}",
                m.udi,
                m.udi_interval
            );
        }
        // Occupancy: only the first 40 hours, and a threshold of 500 lx.
        let o = MetricOptions {
            occupied: (0..100).map(|h| h < 40).collect(),
            threshold_lx: 500.0,
            ..MetricOptions::default()
        };
        let m = metrics(&c, &sky, None, &o).unwrap();
        assert_eq!(m.occupied_hours, 40);
        assert!((m.sda - 0.5).abs() < 1e-12);
    }

    #[test]
    fn the_direct_sun_adds_its_line_and_its_inter_reflection_and_counts_for_ase() {
        let hours = 100;
        let sky = sunny_toy_sky(hours);
        let n = sky.patches.count();
        let sensors = 3;
        let mut value = vec![0.0; sensors * n];
        let mut sigma = vec![0.0; sensors * n];
        for k in 0..sensors {
            for p in 1..4 {
                value[k * n + p] = 0.01;
                sigma[k * n + p] = 0.001;
            }
        }
        let c = Coefficients {
            sensors,
            patches: n,
            value,
            sigma,
        };
        // Sensor 0 in the sun 2000 lx for 60 hours, sensor 1 1500 lx for 30, sensor 2 never.
        let (mut offsets, mut hs, mut lux) = (vec![0], Vec::new(), Vec::new());
        for (count, x) in [(60, 2000.0f32), (30, 1500.0), (0, 0.0)] {
            for h in 0..count {
                hs.push(h as u32);
                lux.push(x);
            }
            offsets.push(hs.len());
        }
        let mut patch_direct = vec![0.0; sensors * n];
        let mut patch_direct_sigma = vec![0.0; sensors * n];
        for k in 0..sensors {
            patch_direct[k * n + 2] = 0.004;
            patch_direct_sigma[k * n + 2] = 0.0002;
        }
        let sun = DirectSun {
            sensors,
            patches: n,
            offsets,
            hours: hs,
            lux,
            patch_direct,
            patch_direct_sigma,
        };
        let (e, s) = hourly(&c, &sky, Some(&sun)).unwrap();
        let l = 50_000.0 / sky.patches.solid_angle(2);
        for h in [0, 45, 99] {
            for k in 0..sensors {
                let direct = match k {
                    0 if h < 60 => 2000.0,
                    1 if h < 30 => 1500.0,
                    _ => 0.0,
                };
                let want = 3.0 * 100.0 * 0.01 + l * (0.01 - 0.004) + direct;
                let got = e[h * sensors + k];
                assert!(
                    (got - want).abs() < 1e-6 * want,
                    "hour {h} sensor {k}: {got} vs {want}"
                );
                // Patch 2's error counts at its sky and sun luminance together, the
                // direct-only coefficient's at the sun's.
                let var = 2.0 * (100.0 * 0.001f64).powi(2)
                    + ((100.0 + l) * 0.001f64).powi(2)
                    + (l * 0.0002f64).powi(2);
                assert!((s[h * sensors + k] - var.sqrt()).abs() < 1e-6 * var.sqrt());
            }
        }
        // ASE: more than 50 hours above 1000 lx: sensor 0 alone.
        let o = MetricOptions {
            ase_hours: 50,
            draws: 20,
            ..MetricOptions::default()
        };
        let m = metrics(&c, &sky, Some(&sun), &o).unwrap();
        let counts: Vec<usize> = m.sensors.iter().map(|s| s.ase_hours).collect();
        assert_eq!(counts, vec![60, 30, 0]);
        assert_eq!(m.ase, Some(1.0 / 3.0));
        // Above 1800 lx only sensor 0 counts; over the first 40 hours it has 40.
        let o2 = MetricOptions {
            ase_lx: 1800.0,
            occupied: (0..hours).map(|h| h < 40).collect(),
            ..o.clone()
        };
        let m = metrics(&c, &sky, Some(&sun), &o2).unwrap();
        assert_eq!(m.sensors[0].ase_hours, 40);
        assert_eq!(m.sensors[1].ase_hours, 0);
        assert_eq!(m.ase, Some(0.0));
        assert_eq!(metrics(&c, &sky, None, &o).unwrap().ase, None);
        // The sun twice is refused: vectors that hold it already, or a direct sun of
        // other sensors.
        let mut twice = sky.clone();
        twice.sun = SunInVectors::InItsPatch;
        let err = hourly(&c, &twice, Some(&sun)).unwrap_err();
        assert!(
            err.message.contains("SunInVectors::Left"),
            "{}",
            err.message
        );
        let mut other = sun.clone();
        other.sensors = 2;
        assert!(metrics(&c, &sky, Some(&other), &o).is_err());
        let bad = MetricOptions {
            ase_lx: f64::NAN,
            ..o
        };
        assert!(metrics(&c, &sky, Some(&sun), &bad).is_err());
    }

    #[test]
    fn the_daylight_factor_is_the_overcast_skys_share_of_its_horizontal_light() {
        let patches = SkyPatches::reinhart(1).unwrap();
        let n = patches.count();
        // Sensor 0 open to the whole sky (C_p = ∫_p cos dω): DF 1. Sensor 1 sees the
        // zenith cap alone: ∫_cap (1 + 2 cos Z) cos dω / (7π/3). Sensor 2 faces down onto
        // the ground (C_0 = π): DF ρ.
        let mut value = vec![0.0; 3 * n];
        let mut sigma = vec![0.0; 3 * n];
        for p in 1..n {
            value[p] = patches.horizontal(p);
            sigma[p] = 0.01 * patches.horizontal(p);
        }
        let cap = patches.cap();
        value[n + cap] = patches.horizontal(cap);
        value[2 * n] = std::f64::consts::PI;
        let c = Coefficients {
            sensors: 3,
            patches: n,
            value,
            sigma,
        };
        let df = daylight_factor(&c, &patches, 0.2).unwrap();
        assert!((df[0].0 - 1.0).abs() < 1e-4, "{:?}", df[0]);
        // Independent errors of 1 %: √Σ (v_p σ_p)² over the patches.
        assert!(df[0].1 > 0.0005 && df[0].1 < 0.01, "{:?}", df[0]);
        let (lo, _, _, _) = patches.bounds(cap);
        let cz = lo.sin();
        let want =
            2.0 * std::f64::consts::PI * ((1.0 - cz * cz) / 2.0 + 2.0 * (1.0 - cz.powi(3)) / 3.0)
                / (7.0 * std::f64::consts::PI / 3.0);
        // To the patches' discretisation: their uniform luminance gives the whole sky
        // 0.4 % less horizontal light than the sky's own, which the scaling gives back.
        assert!(
            (df[1].0 / want - 1.0).abs() < 0.006,
            "{} vs {want}",
            df[1].0
        );
        assert!((df[2].0 - 0.2).abs() < 1e-12);
        assert!(daylight_factor(&c, &patches, 1.5).is_err());
        assert!(daylight_factor(&c, &SkyPatches::reinhart(2).unwrap(), 0.2).is_err());
    }

    #[test]
    fn lm_83s_blinds_close_when_more_than_2_percent_of_points_get_direct_sun() {
        // 50 points; the sky gives each 400 lx blinds open, 100 lx closed. Points 0 and 1
        // (4 %) get 2000 lx of direct sun in hours 0–29, point 2 alone (2 %, not more)
        // in hours 30–59: the blinds close in hours 0–29 only.
        let hours = 100;
        let sky = sunny_toy_sky(hours);
        let n = sky.patches.count();
        let sensors = 50;
        let coefficients = |c: f64| {
            let mut value = vec![0.0; sensors * n];
            for k in 0..sensors {
                for p in 1..4 {
                    value[k * n + p] = c / 300.0;
                }
            }
            Coefficients {
                sensors,
                patches: n,
                value,
                sigma: vec![0.0; sensors * n],
            }
        };
        let (open, shut) = (coefficients(400.0), coefficients(100.0));
        let (mut offsets, mut hs, mut lux) = (vec![0], Vec::new(), Vec::new());
        for k in 0..sensors {
            let lit = match k {
                0 | 1 => 0..30,
                2 => 30..60,
                _ => 0..0,
            };
            for h in lit {
                hs.push(h as u32);
                lux.push(2000.0f32);
            }
            offsets.push(hs.len());
        }
        // The sun's patch holds no inter-reflected sun (C_2 = D_2).
        let mut patch_direct = vec![0.0; sensors * n];
        for k in 0..sensors {
            patch_direct[k * n + 2] = 400.0 / 300.0;
        }
        let sun = DirectSun {
            sensors,
            patches: n,
            offsets,
            hours: hs,
            lux,
            patch_direct,
            patch_direct_sigma: vec![0.0; sensors * n],
        };
        let o = MetricOptions {
            ase_hours: 20,
            draws: 10,
            ..MetricOptions::default()
        };
        let shaded = Shaded {
            coefficients: shut.view(),
            sun: None,
        };
        let m = metrics_with_blinds(&open, &sky, Some(&sun), Some(shaded), &o).unwrap();
        assert_eq!(m.blinds_closed_hours, 30);
        // Point 10: 100 lx in the 30 closed hours, 400 lx in the other 70.
        assert!(
            (m.sensors[10].da - 0.7).abs() < 1e-12,
            "{:?}",
            m.sensors[10]
        );
        // Point 2's sun comes in hours 30–59 with the blinds open: 2400 lx then.
        assert!((m.sensors[2].da - 0.7).abs() < 1e-12);
        assert_eq!(m.sensors[2].udi_above, 0.0);
        // ASE counts the blinds open: points 0–2, 30 hours each, more than 20.
        assert_eq!(m.ase, Some(3.0 / 50.0));
        // Without the blinds: every hour 400 lx or more.
        let plain = metrics(&open, &sky, Some(&sun), &o).unwrap();
        assert_eq!(plain.blinds_closed_hours, 0);
        assert_eq!(plain.sensors[10].da, 1.0);
        // Electric light with daylight reads the blinds too: a photosensor at point 10 (no
        // sun), 500 lx from the lights, kept at 500 lx by dimming to nothing: 80 % output
        // in the 30 closed hours, 20 % in the 70 open ones (38 kWh at 1 kW); 20 kWh
        // without the blinds.
        let zone = lighting::Dimming {
            target_lx: 500.0,
            sensor: 10,
            control: lighting::Control::Continuous,
            min_output: 0.0,
            min_power: 0.0,
            power_w: 1000.0,
        };
        let electric = vec![(500.0, 0.0); sensors];
        let l = lighting::lighting(&open, &sky, Some(&sun), Some(shaded), &electric, &zone, &o)
            .unwrap();
        assert!((l.energy_kwh - 38.0).abs() < 1e-9, "{}", l.energy_kwh);
        let l = lighting::lighting(&open, &sky, Some(&sun), None, &electric, &zone, &o).unwrap();
        assert!((l.energy_kwh - 20.0).abs() < 1e-9, "{}", l.energy_kwh);
        // A share of 4 % or more keeps them open.
        let lax = MetricOptions {
            blinds_share: 0.04,
            ..o.clone()
        };
        let m = metrics_with_blinds(&open, &sky, Some(&sun), Some(shaded), &lax).unwrap();
        assert_eq!(m.blinds_closed_hours, 0);
        // The rule needs the open model's direct sun; shapes must agree.
        assert!(metrics_with_blinds(&open, &sky, None, Some(shaded), &o).is_err());
        let few = Coefficients {
            sensors: 1,
            patches: n,
            value: vec![0.0; n],
            sigma: vec![0.0; n],
        };
        let bad = Shaded {
            coefficients: few.view(),
            sun: None,
        };
        assert!(metrics_with_blinds(&open, &sky, Some(&sun), Some(bad), &o).is_err());
    }

    #[test]
    fn en_17037_levels_follow_the_shares_of_plane_and_daylight_hours() {
        // 20 sensors at constant illuminance whenever the sky is lit: 10 at 800 lx, 9 at
        // 400 lx, one at 150 lx. Per lit hour E ≥ 300 lx on 95 % of the plane and
        // ≥ 500 lx on 50 %: the medium level (500 / 300) is met, the high one (750 / 500)
        // is not (500 lx on 50 % only).
        let sensors = 20;
        let want = |k: usize| match k {
            0..=9 => 800.0,
            10..=18 => 400.0,
            _ => 150.0,
        };
        for (lit_hours, level, share) in [
            (60, Some("medium"), 1.0),
            (40, Some("medium"), 0.8),
            (20, None, 0.4),
        ] {
            let mut sky = toy_sky(100, |h, _| if h < lit_hours { 1000.0 } else { 0.0 });
            for (h, a) in sky.hours.iter_mut().enumerate() {
                a.diffuse_horizontal_lx = if h < lit_hours { 3000.0 } else { 0.0 };
            }
            let n = sky.patches.count();
            let mut value = vec![0.0; sensors * n];
            for k in 0..sensors {
                for p in 1..4 {
                    value[k * n + p] = want(k) / 3000.0;
                }
            }
            let c = Coefficients {
                sensors,
                patches: n,
                value,
                sigma: vec![0.0; sensors * n],
            };
            let m = metrics(&c, &sky, None, &MetricOptions::default()).unwrap();
            let en = m.en17037.unwrap();
            assert_eq!(en.daylight_hours, 50);
            assert_eq!(en.level(), level, "{lit_hours} lit hours: {en:?}");
            let medium = &en.levels[1];
            assert!((medium.target_share - share).abs() < 1e-12, "{medium:?}");
            assert!((medium.minimum_share - share).abs() < 1e-12);
            assert_eq!(en.levels[2].target_share, share);
            assert_eq!(en.levels[2].minimum_share, 0.0);
            assert_eq!(
                medium.pass_probability,
                if level.is_some() { 1.0 } else { 0.0 }
            );
            assert_eq!(medium.target_interval, (share, share));
        }
        // Daylight hours given: the first 10 only, of which the sky lights all.
        let sky = toy_sky(100, |_, _| 1000.0);
        let n = sky.patches.count();
        let c = Coefficients {
            sensors: 1,
            patches: n,
            value: (0..n)
                .map(|p| if (1..4).contains(&p) { 0.1 } else { 0.0 })
                .collect(),
            sigma: vec![0.0; n],
        };
        let o = MetricOptions {
            daylight_hours: (0..100).map(|h| h < 10).collect(),
            ..MetricOptions::default()
        };
        let en = metrics(&c, &sky, None, &o).unwrap().en17037.unwrap();
        assert_eq!(en.daylight_hours, 10);
        assert_eq!(en.level(), Some("minimum"));
        let bad = MetricOptions {
            daylight_hours: vec![true; 3],
            ..MetricOptions::default()
        };
        assert!(metrics(&c, &sky, None, &bad).is_err());
    }

    #[test]
    fn the_sda_interval_covers_the_long_run_value() {
        // Sensors whose illuminance swings over the year around the threshold: the true
        // coefficients give the long-run sDA; runs' estimates scatter by their σ (5–15 %).
        let hours = 120;
        let sky = toy_sky(hours, |h, p| {
            500.0 * (1.0 + 0.8 * ((h as f64 * 0.37 + p as f64).sin()))
        });
        let n = sky.patches.count();
        let sensors = 60;
        let mut truth = vec![0.0; sensors * n];
        let mut sigma = vec![0.0; sensors * n];
        for k in 0..sensors {
            for p in 1..4 {
                let c = 0.05 + 0.25 * k as f64 / sensors as f64 + 0.02 * p as f64;
                truth[k * n + p] = c;
                sigma[k * n + p] = c * (0.05 + 0.1 * ((k * 7 + p) % 5) as f64 / 4.0);
            }
        }
        let true_c = Coefficients {
            sensors,
            patches: n,
            value: truth.clone(),
            sigma: vec![0.0; sensors * n],
        };
        // (UDI's bounds at 150 and 450 lx: each band holds a share of the hours.)
        let o = MetricOptions {
            draws: 200,
            udi_low: 150.0,
            udi_high: 450.0,
            ..MetricOptions::default()
        };
        let truth_m = metrics(
            &true_c,
            &sky,
            None,
            &MetricOptions {
                draws: 0,
                ..o.clone()
            },
        )
        .unwrap();
        let long_run = truth_m.sda;
        assert!(long_run > 0.2 && long_run < 0.8, "{long_run}");
        // And EN 17037's share of daylight hours in which 300 lx reach half the plane.
        let long_run_en = truth_m.en17037.unwrap().levels[0].target_share;
        assert!(long_run_en > 0.1 && long_run_en < 0.9, "{long_run_en}");
        // And UDI's grid means.
        let long_run_udi = truth_m.udi;
        assert!(
            long_run_udi.iter().all(|&x| x > 0.1 && x < 0.9),
            "{long_run_udi:?}"
        );
        let runs = 100;
        let (mut covered, mut covered_en) = (0, 0);
        let mut covered_udi = [0; 3];
        for r in 0..runs {
            let mut rng = PhotonRng::new(99, r);
            let value: Vec<f64> = truth
                .iter()
                .zip(&sigma)
                .map(|(c, s)| (c + s * normal(&mut rng)).max(0.0))
                .collect();
            let est = Coefficients {
                sensors,
                patches: n,
                value,
                sigma: sigma.clone(),
            };
            let m = metrics(
                &est,
                &sky,
                None,
                &MetricOptions {
                    seed: r + 1,
                    ..o.clone()
                },
            )
            .unwrap();
            if m.sda_interval.0 <= long_run && long_run <= m.sda_interval.1 {
                covered += 1;
            }
            for (b, (lo, hi)) in m.udi_interval.iter().enumerate() {
                // A band no hour reaches: the interval is the point 0.
                if lo <= &long_run_udi[b] && &long_run_udi[b] <= hi {
                    covered_udi[b] += 1;
                }
            }
            let (lo, hi) = m.en17037.unwrap().levels[0].target_interval;
            if lo <= long_run_en && long_run_en <= hi {
                covered_en += 1;
            }
        }
        eprintln!(
            "covered {covered} of {runs}; EN 17037's time share {covered_en}; UDI's bands {covered_udi:?}"
        );
        // The metrics are the same on any number of threads (each point's draws are its
        // own, the sums whole counts).
        let est = Coefficients {
            sensors,
            patches: n,
            value: truth.clone(),
            sigma: sigma.clone(),
        };
        let one = metrics_on(&Shading::blinds(est.view(), None, None), &sky, &o, 1).unwrap();
        for t in [2, 3, 7, 64] {
            assert_eq!(
                metrics_on(&Shading::blinds(est.view(), None, None), &sky, &o, t).unwrap(),
                one,
                "{t} threads"
            );
        }
        assert!(covered_en >= 90, "EN 17037: {covered_en} of {runs}");
        for (b, n) in covered_udi.iter().enumerate() {
            assert!(*n >= 90, "UDI band {b}: {n} of {runs}");
        }
        assert!(
            covered >= 90,
            "the 95 % interval covered the long-run sDA in {covered} of {runs} runs"
        );
    }
}

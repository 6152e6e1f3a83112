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
}

/// A year of sky vectors: per hour, the mean luminance of each patch, cd/m².
#[derive(Clone, Debug)]
pub struct AnnualSky {
    pub patches: SkyPatches,
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
            hours.push(AnnualHour {
                row,
                month: h.month,
                day: h.day,
                hour: h.hour,
                sun_azimuth_deg: az,
                sun_zenith_deg: zen,
                diffuse_horizontal_lx: dh,
                direct_normal_lx: dn,
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
                    let q = patches.patch(FRAC_PI_2 - zs, az.to_radians());
                    out[q] += dn / patches.solid_angle(q);
                }
                let global = dh + dn * zs.cos().max(0.0);
                out[0] = ground_reflectance * global / std::f64::consts::PI;
            }
        }
        Ok(AnnualSky {
            patches,
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
        for (what, v) in [("value", &self.value), ("sigma", &self.sigma)] {
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
    /// Occupied hours counted.
    pub occupied_hours: usize,
    pub sensors: Vec<SensorMetrics>,
}

/// The hourly illuminance at every sensor (lx, hour by hour: `hours × sensors`) and its
/// standard error.
pub fn hourly(c: &Coefficients, sky: &AnnualSky) -> Result<(Vec<f64>, Vec<f64>)> {
    let n = c.check_against(sky)?;
    let hours = sky.hours.len();
    let mut e = vec![0.0; hours * c.sensors];
    let mut s = vec![0.0; hours * c.sensors];
    for h in 0..hours {
        let v = sky.vector(h);
        for k in 0..c.sensors {
            let row = k * n..(k + 1) * n;
            let (x, sx) = hour_value(v, &c.value[row.clone()], &c.sigma[row]);
            e[h * c.sensors + k] = x;
            s[h * c.sensors + k] = sx;
        }
    }
    Ok((e, s))
}

/// An hour's illuminance Σ L_p C_p under sky vector `v` from one sensor's coefficients `c`
/// and their errors `sigma`, and its standard error √Σ (L_p σ_p)².
fn hour_value(v: &[f64], c: &[f64], sigma: &[f64]) -> (f64, f64) {
    let (mut x, mut var) = (0.0, 0.0);
    for ((l, c), s) in v.iter().zip(c).zip(sigma) {
        x += l * c;
        var += (l * s).powi(2);
    }
    (x, var.sqrt())
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

/// A standard normal number (Box–Muller).
fn normal(rng: &mut PhotonRng) -> f64 {
    let u1 = rng.uniform().max(1e-300);
    let u2 = rng.uniform();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// The annual metrics of a grid of sensors with coefficients `c` under `sky`, with their
/// confidence from `o.draws` draws of the coefficients.
pub fn metrics(c: &Coefficients, sky: &AnnualSky, o: &MetricOptions) -> Result<GridMetrics> {
    let n = c.check_against(sky)?;
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
    if !o.occupied.is_empty() && o.occupied.len() != sky.hours.len() {
        bail!(
            ImapErrInvalidArgument,
            "occupied holds {} hours; the sky has {}",
            o.occupied.len(),
            sky.hours.len()
        );
    }
    let hours: Vec<usize> = (0..sky.hours.len())
        .filter(|&h| {
            if o.occupied.is_empty() {
                sky.hours[h].sun_zenith_deg < 90.0
            } else {
                o.occupied[h]
            }
        })
        .collect();
    let count = hours.len();
    if count == 0 {
        bail!(
            ImapErrInvalidArgument,
            "no occupied hour: the metrics count none"
        );
    }
    let passes = |m: &SensorMetrics| m.da >= o.sda_share;
    let mut sensors = Vec::with_capacity(c.sensors);
    let mut draws_sda = vec![0.0; o.draws];
    for k in 0..c.sensors {
        let cv = &c.value[k * n..(k + 1) * n];
        let cs = &c.sigma[k * n..(k + 1) * n];
        // Each occupied hour's illuminance and standard error.
        let e: Vec<(f64, f64)> = hours
            .iter()
            .map(|&h| hour_value(sky.vector(h), cv, cs))
            .collect();
        let mut m = sensor_metrics(e.iter().map(|x| x.0), o, count);
        // A draw can move an hour across the threshold only where it lies within a few
        // of its errors of it (beyond 6 σ: less than 10⁻⁹ per hour): the rest are fixed.
        let (mut open, mut fixed) = (Vec::new(), 0usize);
        for (i, &(x, s)) in e.iter().enumerate() {
            if (x - o.threshold_lx).abs() <= 6.0 * s {
                open.push(i);
            } else if x >= o.threshold_lx {
                fixed += 1;
            }
        }
        let lit: Vec<usize> = (0..n).filter(|&p| cs[p] > 0.0).collect();
        let mut delta = vec![0.0; lit.len()];
        let mut pass = 0usize;
        for (j, sum) in draws_sda.iter_mut().enumerate() {
            // The draw's stream: one per (sensor, draw), so any sensor subset or order
            // gives the same draws.
            let mut rng = PhotonRng::new(o.seed, ((k as u64) << 20) | j as u64);
            for (d, &p) in delta.iter_mut().zip(&lit) {
                *d = cs[p] * normal(&mut rng);
            }
            let mut above = fixed;
            for &i in &open {
                let v = sky.vector(hours[i]);
                let x = e[i].0 + lit.iter().zip(&delta).map(|(&p, d)| v[p] * d).sum::<f64>();
                if x >= o.threshold_lx {
                    above += 1;
                }
            }
            if above as f64 >= o.sda_share * count as f64 {
                pass += 1;
                *sum += 1.0;
            }
        }
        m.sda_pass_probability = if o.draws > 0 {
            pass as f64 / o.draws as f64
        } else if passes(&m) {
            1.0
        } else {
            0.0
        };
        sensors.push(m);
    }
    let total = c.sensors.max(1) as f64;
    let sda = sensors.iter().filter(|m| passes(m)).count() as f64 / total;
    let (sda_sigma, sda_interval) = if o.draws > 0 {
        let mut d: Vec<f64> = draws_sda.iter().map(|x| x / total).collect();
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (d.len().max(2) - 1) as f64;
        d.sort_by(f64::total_cmp);
        let q = |f: f64| d[((f * (d.len() - 1) as f64).round() as usize).min(d.len() - 1)];
        (var.sqrt(), (q(0.025), q(0.975)))
    } else {
        (f64::NAN, (f64::NAN, f64::NAN))
    };
    Ok(GridMetrics {
        sda,
        sda_sigma,
        sda_interval,
        occupied_hours: count,
        sensors,
    })
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
    fn toy_sky(hours: usize, l: impl Fn(usize, usize) -> f64) -> AnnualSky {
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
                })
                .collect(),
            luminance,
        }
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
        let (e, s) = hourly(&c, &sky).unwrap();
        assert!((e[3] - 350.0).abs() < 1e-9 && s[3] == 0.0);
        let m = metrics(&c, &sky, &MetricOptions::default()).unwrap();
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
        // Occupancy: only the first 40 hours, and a threshold of 500 lx.
        let o = MetricOptions {
            occupied: (0..100).map(|h| h < 40).collect(),
            threshold_lx: 500.0,
            ..MetricOptions::default()
        };
        let m = metrics(&c, &sky, &o).unwrap();
        assert_eq!(m.occupied_hours, 40);
        assert!((m.sda - 0.5).abs() < 1e-12);
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
        let o = MetricOptions {
            draws: 200,
            ..MetricOptions::default()
        };
        let long_run = metrics(
            &true_c,
            &sky,
            &MetricOptions {
                draws: 0,
                ..o.clone()
            },
        )
        .unwrap()
        .sda;
        assert!(long_run > 0.2 && long_run < 0.8, "{long_run}");
        let runs = 100;
        let mut covered = 0;
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
                &MetricOptions {
                    seed: r + 1,
                    ..o.clone()
                },
            )
            .unwrap();
            if m.sda_interval.0 <= long_run && long_run <= m.sda_interval.1 {
                covered += 1;
            }
        }
        eprintln!("covered {covered} of {runs}");
        assert!(
            covered >= 90,
            "the 95 % interval covered the long-run sDA in {covered} of {runs} runs"
        );
    }
}

//! Electric light with daylight: a zone's luminaires dimmed hour by hour against the
//! daylight its photosensor reads, and the annual lighting energy that follows.
//!
//! The zone is a grid of sensors; its luminaires give `electric[k]` lx at sensor k at full
//! output (a run of the model's own lights, each value with its standard error). In every
//! occupied hour the control reads the daylight at its photosensor (one of the sensors)
//! and sets the light output fraction f so that daylight + f × electric reaches the
//! target there, as EnergyPlus's `Daylighting:Controls` do (with r = (target − E_day) /
//! E_el, at most 1, the output the target asks for):
//! - `Continuous`: f = max(r, f_min); the power fraction falls linearly from 1 at full
//!   output to p_min at f_min, and stays at p_min however bright the daylight;
//! - `ContinuousOff`: the same, but off (f = 0, no power) once r ≤ f_min;
//! - `Stepped(n)`: f the first of n equal steps at or above r (off when r ≤ 0), the power
//!   in proportion.
//!
//! The control is ideal: it knows the daylight at its photosensor, as an open-loop sensor
//! calibrated to it would. The energy is Σ over the occupied hours of the power fraction ×
//! the installed power × the time step. Its confidence comes from the metrics' draws: the
//! photosensor's coefficients drawn within their errors (the same draws as `metrics`
//! makes for that sensor) and the electric light at it too.

use super::shading::SensorParts;
use super::{
    in_chunks, normal, occupied_hours, spread, AnnualSky, CoefficientsView, DirectSun,
    MetricOptions, Shaded, Shading,
};
use crate::error::{bail, Result};
use crate::sampling::PhotonRng;

/// How the light output follows the daylight (EnergyPlus's lighting control types).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    /// Dims continuously down to the minimum output, where it stays on.
    Continuous,
    /// Dims continuously, and switches off where the minimum output would do.
    ContinuousOff,
    /// `n` equal steps of output (and power), and off.
    Stepped(u32),
}

/// A zone's dimming control and its installed power.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dimming {
    /// The illuminance the control keeps at its photosensor, lx.
    pub target_lx: f64,
    /// The photosensor: the index of the sensor (grid point) whose daylight it reads.
    pub sensor: usize,
    pub control: Control,
    /// The lowest light output fraction the continuous controls dim to (0–1, below 1).
    pub min_output: f64,
    /// The power fraction drawn at `min_output` (0–1).
    pub min_power: f64,
    /// The zone's installed lighting power at full output, W.
    pub power_w: f64,
}

impl Dimming {
    fn check(&self, sensors: usize) -> Result<()> {
        if !(self.target_lx > 0.0 && self.target_lx.is_finite()) {
            bail!(
                ImapErrInvalidArgument,
                "target_lx = {}: must be a positive illuminance",
                self.target_lx
            );
        }
        if self.sensor >= sensors {
            bail!(
                ImapErrIndexOutOfRange,
                "sensor = {}: the photosensor must be one of the {} sensors",
                self.sensor,
                sensors
            );
        }
        if !(0.0..1.0).contains(&self.min_output) {
            bail!(
                ImapErrInvalidArgument,
                "min_output = {}: must be in [0, 1)",
                self.min_output
            );
        }
        if !(0.0..=1.0).contains(&self.min_power) {
            bail!(
                ImapErrInvalidArgument,
                "min_power = {}: must be in [0, 1]",
                self.min_power
            );
        }
        if !(self.power_w >= 0.0 && self.power_w.is_finite()) {
            bail!(
                ImapErrInvalidArgument,
                "power_w = {}: must be a power, W, ≥ 0",
                self.power_w
            );
        }
        if let Control::Stepped(n) = self.control {
            if !(1..=1000).contains(&n) {
                bail!(
                    ImapErrInvalidArgument,
                    "Stepped({n}): between 1 and 1000 steps"
                );
            }
        }
        Ok(())
    }

    /// The light output and power fractions with `daylight` lx at the photosensor and
    /// `electric` lx there from the luminaires at full output.
    pub fn level(&self, daylight: f64, electric: f64) -> (f64, f64) {
        let r = if daylight >= self.target_lx {
            0.0
        } else if electric > 0.0 {
            ((self.target_lx - daylight) / electric).min(1.0)
        } else {
            1.0
        };
        let power = |f: f64| {
            self.min_power
                + (1.0 - self.min_power) * (f - self.min_output) / (1.0 - self.min_output)
        };
        match self.control {
            Control::Continuous => {
                let f = r.max(self.min_output);
                (f, power(f))
            }
            Control::ContinuousOff if r <= self.min_output => (0.0, 0.0),
            Control::ContinuousOff => (r, power(r)),
            Control::Stepped(n) => {
                // The first step at or above r (a rounding error's leeway).
                let f = ((r * n as f64 - 1e-9).ceil() / n as f64).clamp(0.0, 1.0);
                (f, f)
            }
        }
    }
}

/// A zone's annual electric lighting.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Lighting {
    /// Occupied hours counted, and the weather's time step, hours.
    pub occupied_hours: usize,
    pub step_hours: f64,
    /// The energy with the daylight control, kWh, its standard deviation over the draws
    /// and their 2.5 % and 97.5 % quantiles (NaN without draws).
    pub energy_kwh: f64,
    pub energy_sigma: f64,
    pub energy_interval: (f64, f64),
    /// The energy without it (full output every occupied hour), kWh.
    pub full_kwh: f64,
    /// The mean light output fraction over the occupied hours.
    pub mean_output: f64,
    /// Occupied hours with the lights off, and at full output.
    pub hours_off: usize,
    pub hours_full: usize,
    /// Per sensor, the share of occupied hours in which daylight and the dimmed electric
    /// light together reach the target.
    pub at_target: Vec<f64>,
}

/// The weather's time step: the shortest step between a day's rows (1 h when none).
fn step_hours(sky: &AnnualSky) -> f64 {
    let step = sky
        .hours
        .windows(2)
        .filter(|w| w[0].month == w[1].month && w[0].day == w[1].day)
        .map(|w| w[1].hour - w[0].hour)
        .filter(|&d| d > 1e-6)
        .fold(f64::INFINITY, f64::min);
    if step.is_finite() {
        step.min(1.0)
    } else {
        1.0
    }
}

/// The annual lighting of a zone: sensors with daylight coefficients `c` under `sky` (and
/// the direct sun `sun`, the blinds-closed model `shaded` with LM-83's rule, as
/// `metrics_with_blinds` takes them), its luminaires' illuminance at full output
/// `electric` (per sensor, lx and its standard error), dimmed by `dimming` in the hours
/// `o` counts, with `o.draws` draws for the energy's confidence.
pub fn lighting<'a>(
    c: impl Into<CoefficientsView<'a>>,
    sky: &AnnualSky,
    sun: Option<&DirectSun>,
    shaded: Option<Shaded>,
    electric: &[(f64, f64)],
    dimming: &Dimming,
    o: &MetricOptions,
) -> Result<Lighting> {
    let shading = Shading::blinds(c.into(), sun, shaded);
    lighting_with_shading(&shading, sky, electric, dimming, o)
}

/// `lighting` of a zone whose daylight is `shading`'s parts, each window group in the
/// state its rule picks every hour (as `metrics_with_shading` reads them).
pub fn lighting_with_shading(
    shading: &Shading,
    sky: &AnnualSky,
    electric: &[(f64, f64)],
    dimming: &Dimming,
    o: &MetricOptions,
) -> Result<Lighting> {
    let (sensors, n) = shading.check(sky, o)?;
    if electric.len() != sensors {
        bail!(
            ImapErrInvalidArgument,
            "electric holds {} sensors' illuminance; the coefficients are of {}",
            electric.len(),
            sensors
        );
    }
    if let Some(k) = electric
        .iter()
        .position(|&(x, s)| !(x >= 0.0 && x.is_finite() && s >= 0.0 && s.is_finite()))
    {
        bail!(
            ImapErrInvalidArgument,
            "electric[{k}] = {} ± {}: must be an illuminance, lx, ≥ 0, with a finite error",
            electric[k].0,
            electric[k].1
        );
    }
    dimming.check(sensors)?;
    let occupied = occupied_hours(sky, o)?;
    let threads = std::thread::available_parallelism().map_or(1, |x| x.get());
    let states = shading.states(sky, o, &occupied, threads);
    let hours: Vec<usize> = (0..sky.hours.len()).filter(|&h| occupied[h]).collect();
    let step = step_hours(sky);
    let kwh = |p: f64| p * dimming.power_w * step / 1000.0;

    // The photosensor's daylight each occupied hour, the levels it sets.
    let ks = dimming.sensor;
    let mut scratch = shading.scratch(sky.hours.len());
    let mut photosensor = SensorParts::new(shading, ks, n, &mut scratch);
    let daylight: Vec<f64> = hours
        .iter()
        .map(|&h| photosensor.hour(sky, h, &states).0)
        .collect();
    let levels: Vec<(f64, f64)> = daylight
        .iter()
        .map(|&x| dimming.level(x, electric[ks].0))
        .collect();
    let energy_kwh = levels.iter().map(|l| kwh(l.1)).sum::<f64>();
    let count = hours.len().max(1) as f64;

    // The draws: the photosensor's coefficients as `metrics` draws them (the same stream
    // for the same sensor and draw), then its electric light.
    let draws: Vec<f64> = (0..o.draws)
        .map(|j| {
            let mut rng = PhotonRng::new(o.seed, ((ks as u64) << 20) | j as u64);
            photosensor.draw(&mut rng);
            let e_el = (electric[ks].0 + electric[ks].1 * normal(&mut rng)).max(0.0);
            hours
                .iter()
                .zip(&daylight)
                .map(|(&h, &x)| kwh(dimming.level(photosensor.drawn(sky, h, x, &states), e_el).1))
                .sum::<f64>()
        })
        .collect();
    let (energy_sigma, energy_interval) = spread(&draws);

    // Every sensor's daylight with the zone's light as the photosensor sets it: on every
    // core, a chunk of sensors each.
    let at_target: Vec<f64> = in_chunks(sensors, threads, |r| {
        let mut scratch = shading.scratch(sky.hours.len());
        r.map(|k| {
            let parts = SensorParts::new(shading, k, n, &mut scratch);
            let reached = hours
                .iter()
                .zip(&levels)
                .filter(|(&h, l)| {
                    let x = parts.hour(sky, h, &states).0;
                    // The photosensor's own sum meets the target up to rounding.
                    x + l.0 * electric[k].0 >= dimming.target_lx * (1.0 - 1e-9)
                })
                .count();
            reached as f64 / count
        })
        .collect::<Vec<f64>>()
    })
    .into_iter()
    .flatten()
    .collect();
    Ok(Lighting {
        occupied_hours: hours.len(),
        step_hours: step,
        energy_kwh,
        energy_sigma,
        energy_interval,
        full_kwh: kwh(1.0) * hours.len() as f64,
        mean_output: levels.iter().map(|l| l.0).sum::<f64>() / count,
        hours_off: levels.iter().filter(|l| l.0 == 0.0).count(),
        hours_full: levels.iter().filter(|l| l.0 >= 1.0).count(),
        at_target,
    })
}

#[cfg(test)]
mod tests {
    use super::super::tests::toy_sky;
    use super::super::Coefficients;
    use super::*;

    fn dimming(control: Control, min_output: f64, min_power: f64) -> Dimming {
        Dimming {
            target_lx: 500.0,
            sensor: 0,
            control,
            min_output,
            min_power,
            power_w: 1000.0,
        }
    }

    #[test]
    fn each_control_sets_the_output_energyplus_defines() {
        // 400 lx of electric light at full output, a target of 500 lx.
        let d = dimming(Control::Continuous, 0.1, 0.2);
        let p = |f: f64| 0.2 + 0.8 * (f - 0.1) / 0.9;
        assert_eq!(d.level(0.0, 400.0), (1.0, 1.0));
        assert_eq!(d.level(50.0, 400.0), (1.0, 1.0)); // r = 1.125: full, short of the target
        let (f, w) = d.level(300.0, 400.0);
        assert!((f - 0.5).abs() < 1e-12 && (w - p(0.5)).abs() < 1e-12);
        assert_eq!(d.level(480.0, 400.0), (0.1, 0.2)); // r = 0.05: the minimum, on
        assert_eq!(d.level(5000.0, 400.0), (0.1, 0.2));
        let d = dimming(Control::ContinuousOff, 0.1, 0.2);
        assert_eq!(d.level(480.0, 400.0), (0.0, 0.0));
        assert_eq!(d.level(5000.0, 400.0), (0.0, 0.0));
        let (f, w) = d.level(300.0, 400.0);
        assert!((f - 0.5).abs() < 1e-12 && (w - p(0.5)).abs() < 1e-12);
        let d = dimming(Control::Stepped(4), 0.1, 0.2);
        assert_eq!(d.level(300.0, 400.0), (0.5, 0.5)); // r = 0.5 exactly: that step
        assert_eq!(d.level(296.0, 400.0), (0.75, 0.75)); // r = 0.51
        assert_eq!(d.level(499.0, 400.0), (0.25, 0.25));
        assert_eq!(d.level(500.0, 400.0), (0.0, 0.0));
        // No electric light at the photosensor: full output whenever daylight is short.
        assert_eq!(d.level(100.0, 0.0), (1.0, 1.0));
    }

    /// A year of 100 hours whose daylight at sensor 0 rises by 5 lx an hour (0–495 lx),
    /// sensor 1 twice and sensor 2 half as bright; the zone's light gives 500 lx at each.
    fn rising_year() -> (crate::annual::AnnualSky, Coefficients) {
        let sky = toy_sky(100, |h, _| h as f64);
        let n = sky.patches.count();
        let mut value = vec![0.0; 3 * n];
        for (k, scale) in [1.0, 2.0, 0.5].into_iter().enumerate() {
            for p in 1..4 {
                value[k * n + p] = scale * 5.0 / 3.0;
            }
        }
        let c = Coefficients {
            sensors: 3,
            patches: n,
            value,
            sigma: vec![0.0; 3 * n],
        };
        (sky, c)
    }

    #[test]
    fn a_year_of_rising_daylight_costs_the_energy_the_dimming_leaves() {
        let (sky, c) = rising_year();
        let electric = [(500.0, 0.0); 3];
        let run = |d: &Dimming| {
            lighting(
                &c,
                &sky,
                None,
                None,
                &electric,
                d,
                &MetricOptions::default(),
            )
            .unwrap()
        };
        // Dimming to nothing at no power: output 1 − h/100, Σ = 50.5 h at 1 kW.
        let d = dimming(Control::Continuous, 0.0, 0.0);
        let l = run(&d);
        assert_eq!(l.occupied_hours, 100);
        assert_eq!(l.step_hours, 1.0);
        assert!((l.energy_kwh - 50.5).abs() < 1e-9, "{}", l.energy_kwh);
        assert!((l.full_kwh - 100.0).abs() < 1e-12);
        assert!((l.mean_output - 0.505).abs() < 1e-12);
        assert_eq!((l.hours_full, l.hours_off), (1, 0));
        // The photosensor and the brighter sensor meet the target every hour; the dimmer
        // one (2.5 h + 500 − 5 h lx) only in the first.
        assert_eq!(l.at_target, vec![1.0, 1.0, 0.01]);
        // No error in the coefficients: every draw gives the estimate.
        assert!(l.energy_sigma.abs() < 1e-9);
        // Stepped in halves: full while r > ½ (h < 50), half after: 50 + 25 kWh.
        let d = dimming(Control::Stepped(2), 0.0, 0.0);
        let l = run(&d);
        assert!((l.energy_kwh - 75.0).abs() < 1e-9, "{}", l.energy_kwh);
        // Only the first 40 hours occupied: Σ_{h<40} (1 − h/100) = 40 − 7.8.
        let o = MetricOptions {
            occupied: (0..100).map(|h| h < 40).collect(),
            ..MetricOptions::default()
        };
        let d = dimming(Control::Continuous, 0.0, 0.0);
        let l = lighting(&c, &sky, None, None, &electric, &d, &o).unwrap();
        assert!((l.energy_kwh - 32.2).abs() < 1e-9, "{}", l.energy_kwh);
        assert!((l.full_kwh - 40.0).abs() < 1e-12);
    }

    #[test]
    fn the_energys_interval_covers_the_long_run_value() {
        // The photosensor's coefficients and electric light known to 10 % (the daylight to
        // 5.8 %: three patches): each run's estimate drawn around the truth, its interval
        // from draws around the estimate.
        let (sky, truth) = rising_year();
        let electric = [(500.0, 0.0); 3];
        let d = dimming(Control::Continuous, 0.2, 0.3);
        let o = MetricOptions::default();
        let exact = lighting(&truth, &sky, None, None, &electric, &d, &o)
            .unwrap()
            .energy_kwh;
        const REL: f64 = 0.1;
        let mut rng = PhotonRng::new(5, 0);
        let mut covered = 0;
        let runs = 1000;
        for run in 0..runs {
            let mut est = truth.clone();
            for p in 0..est.patches {
                let v = truth.value[p];
                if v > 0.0 {
                    est.value[p] = v * (1.0 + REL * normal(&mut rng));
                    est.sigma[p] = REL * v;
                }
            }
            let e = 500.0 * (1.0 + REL * normal(&mut rng));
            let mut el = electric;
            el[0] = (e, REL * 500.0);
            // Each run its own draws, as separate runs with their own seeds would have.
            let o = MetricOptions {
                seed: run + 1,
                ..MetricOptions::default()
            };
            let l = lighting(&est, &sky, None, None, &el, &d, &o).unwrap();
            assert!(l.energy_sigma > 0.0);
            if (l.energy_interval.0..=l.energy_interval.1).contains(&exact) {
                covered += 1;
            }
        }
        eprintln!(
            "the energy's 95 % interval covered its long-run value in {covered} of {runs} runs"
        );
        assert!(covered >= 920, "covered {covered} of {runs}");
    }

    #[test]
    fn bad_zones_are_refused_by_name() {
        let (sky, c) = rising_year();
        let o = MetricOptions::default();
        let good = dimming(Control::Continuous, 0.1, 0.2);
        let el = [(500.0, 1.0); 3];
        let err = |d: Dimming, el: &[(f64, f64)]| {
            lighting(&c, &sky, None, None, el, &d, &o)
                .unwrap_err()
                .message
        };
        assert!(err(Dimming { sensor: 3, ..good }, &el).contains("sensor = 3"));
        assert!(err(
            Dimming {
                target_lx: 0.0,
                ..good
            },
            &el
        )
        .contains("target_lx"));
        assert!(err(
            Dimming {
                min_output: 1.0,
                ..good
            },
            &el
        )
        .contains("min_output"));
        assert!(err(
            Dimming {
                min_power: -0.1,
                ..good
            },
            &el
        )
        .contains("min_power"));
        assert!(err(
            Dimming {
                power_w: f64::NAN,
                ..good
            },
            &el
        )
        .contains("power_w"));
        let stepped = Dimming {
            control: Control::Stepped(0),
            ..good
        };
        assert!(err(stepped, &el).contains("Stepped(0)"));
        assert!(err(good, &el[..2]).contains("electric holds 2"));
        assert!(err(good, &[(500.0, 1.0), (f64::NAN, 0.0), (1.0, 0.0)]).contains("electric[1]"));
    }
}

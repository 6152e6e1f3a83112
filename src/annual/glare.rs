//! Annual glare at observers, imageless: each hour's vertical illuminance at the eye, Ev,
//! from the observer's daylight coefficients (an observer's sensor faces its view: its
//! coefficients are Ev per patch luminance) and its direct sun, the simplified daylight
//! glare probability DGPs = 6.22·10⁻⁵ Ev + 0.184 (Wienold 2009), and the shares of the
//! occupied hours at or above Wienold's classes 0.35 (perceptible), 0.40 (disturbing) and
//! 0.45 (intolerable), with their confidence drawn as the grids' metrics' are.
//!
//! DGPs reads Ev alone: it holds where no bright source (the sun's disc, a specular
//! reflection of it) is in view, and then rates the glare of a bright window. With the
//! sun in view it rates only the sun's Ev, not its luminance; a picture's DGP
//! (`glare::picture_glare`) rates both.

use super::shading::{SensorParts, Shading};
use super::{debiased_spread, in_chunks, occupied_hours, AnnualSky, MetricOptions};
use crate::error::Result;
use crate::glare::dgps;
use crate::sampling::PhotonRng;

/// Wienold's DGP classes: at or above 0.35 glare is perceptible, 0.40 disturbing, 0.45
/// intolerable.
pub const DGP_CLASSES: [f64; 3] = [0.35, 0.40, 0.45];

/// One observer's year of glare (`annual_glare`).
#[derive(Clone, Debug, PartialEq)]
pub struct ObserverYear {
    /// The occupied hours counted.
    pub occupied_hours: usize,
    /// Per `DGP_CLASSES`: the occupied hours with DGPs at or above the class's value,
    /// their share of the occupied hours, its standard deviation over the draws and its
    /// 95 % interval (the draws' quantiles less their bias: the draws' mean less the
    /// estimate, within [0, 1]; NaN without draws).
    pub hours_above: [usize; 3],
    pub share_above: [f64; 3],
    pub share_sigma: [f64; 3],
    pub share_interval: [(f64, f64); 3],
    /// The mean Ev over the occupied hours, lx, and the largest hour's DGPs (capped at 1).
    pub mean_ev_lx: f64,
    pub max_dgps: f64,
}

/// DGPs of an hour's Ev, capped at 1 (a probability): what the shares and the hourly
/// outputs rate.
pub fn hour_dgps(ev: f64) -> f64 {
    dgps(ev).min(1.0)
}

/// The year of glare of every sensor of `shading` (observers' sensors, each facing its
/// view), each window group in the state its rule picks every hour (`ShadingRule`), in the
/// occupied hours of `o` (its `draws` and `seed` for the confidence, its `blinds_share`
/// and `ase_lx` for the rules).
pub fn annual_glare(
    shading: &Shading,
    sky: &AnnualSky,
    o: &MetricOptions,
) -> Result<Vec<ObserverYear>> {
    let threads = std::thread::available_parallelism().map_or(1, |x| x.get());
    annual_glare_on(shading, sky, o, threads)
}

/// `annual_glare` on `threads` threads (the same for any count).
pub(super) fn annual_glare_on(
    shading: &Shading,
    sky: &AnnualSky,
    o: &MetricOptions,
    threads: usize,
) -> Result<Vec<ObserverYear>> {
    let (sensors, n) = shading.check(sky, o)?;
    let occupied = occupied_hours(sky, o)?;
    let hours: Vec<usize> = (0..sky.hours.len()).filter(|&h| occupied[h]).collect();
    let count = hours.len();
    let states = shading.states(sky, o, &occupied, threads);
    // The Ev at which DGPs reaches each class.
    let ev_at = DGP_CLASSES.map(crate::glare::dgps_ev);
    let one = |range: std::ops::Range<usize>| -> Vec<ObserverYear> {
        let mut scratch = shading.scratch(sky.hours.len());
        let mut out = Vec::with_capacity(range.len());
        for k in range {
            let mut parts = SensorParts::new(shading, k, n, &mut scratch);
            let e: Vec<(f64, f64)> = hours.iter().map(|&h| parts.hour(sky, h, &states)).collect();
            let mut hours_above = [0usize; 3];
            for (x, _) in &e {
                for (c, t) in ev_at.iter().enumerate() {
                    if *x >= *t {
                        hours_above[c] += 1;
                    }
                }
            }
            // Only hours within 6 σ of a class's Ev can cross it in a draw.
            let open: Vec<usize> = (0..e.len())
                .filter(|&i| ev_at.iter().any(|t| (e[i].0 - t).abs() <= 6.0 * e[i].1))
                .collect();
            let mut draws = vec![[0.0f64; 3]; o.draws];
            for (j, d) in draws.iter_mut().enumerate() {
                // One stream per (observer, draw), as the grids' metrics draw theirs.
                let mut rng = PhotonRng::new(o.seed, ((k as u64) << 20) | j as u64);
                parts.draw(&mut rng);
                let mut above = hours_above;
                for &i in &open {
                    let x = parts.drawn(sky, hours[i], e[i].0, &states);
                    for (c, t) in ev_at.iter().enumerate() {
                        match (e[i].0 >= *t, x >= *t) {
                            (true, false) => above[c] -= 1,
                            (false, true) => above[c] += 1,
                            _ => {}
                        }
                    }
                }
                *d = above.map(|a| a as f64 / count as f64);
            }
            let share_above = hours_above.map(|a| a as f64 / count as f64);
            let (mut share_sigma, mut share_interval) = ([f64::NAN; 3], [(f64::NAN, f64::NAN); 3]);
            for c in 0..3 {
                if o.draws == 0 {
                    continue;
                }
                let d: Vec<f64> = draws.iter().map(|x| x[c]).collect();
                (share_sigma[c], share_interval[c]) = debiased_spread(&d, share_above[c]);
            }
            out.push(ObserverYear {
                occupied_hours: count,
                hours_above,
                share_above,
                share_sigma,
                share_interval,
                mean_ev_lx: e.iter().map(|x| x.0).sum::<f64>() / count as f64,
                max_dgps: e.iter().map(|x| hour_dgps(x.0)).fold(0.0, f64::max),
            });
        }
        out
    };
    Ok(in_chunks(sensors, threads, one)
        .into_iter()
        .flatten()
        .collect())
}

#[cfg(test)]
mod tests {
    use super::super::tests::toy_sky;
    use super::super::{normal, shading_states, Coefficients, Shaded, ShadingRule, WindowGroup};
    use super::*;

    /// `sensors` observers reading `ev(k)` lx per 100 cd/m² of each of the toy sky's three
    /// patches, with a relative error `rel(k)` per coefficient.
    fn observers(
        sensors: usize,
        ev: impl Fn(usize) -> f64,
        rel: impl Fn(usize) -> f64,
    ) -> Coefficients {
        let n = toy_sky(1, |_, _| 0.0).patches.count();
        let mut value = vec![0.0; sensors * n];
        let mut sigma = vec![0.0; sensors * n];
        for k in 0..sensors {
            for p in 1..4 {
                value[k * n + p] = ev(k) / 300.0;
                sigma[k * n + p] = ev(k) / 300.0 * rel(k);
            }
        }
        Coefficients {
            sensors,
            patches: n,
            value,
            sigma,
        }
    }

    fn every_hour(hours: usize) -> MetricOptions {
        MetricOptions {
            occupied: vec![true; hours],
            ..MetricOptions::default()
        }
    }

    #[test]
    fn the_shares_count_the_hours_above_each_class() {
        // Ev = 1000 + 100 h lx in hour h (100 cd/m² × (1 + h/10) on each patch): DGPs
        // reaches 0.35 at 2668.8 lx (hour 17 on), 0.40 at 3472.7 (25 on), 0.45 at 4276.5
        // (33 on).
        let hours = 100;
        let sky = toy_sky(hours, |h, _| 100.0 * (1.0 + h as f64 / 10.0));
        let c = observers(2, |k| 1000.0 * (1 + k) as f64, |_| 0.0);
        let y = annual_glare(
            &Shading::blinds(c.view(), None, None),
            &sky,
            &every_hour(hours),
        )
        .unwrap();
        assert_eq!(y[0].occupied_hours, 100);
        assert_eq!(y[0].hours_above, [83, 75, 67]);
        assert_eq!(y[0].share_above, [0.83, 0.75, 0.67]);
        // No error: every draw is the estimate.
        assert_eq!(y[0].share_interval[1], (0.75, 0.75));
        assert!((y[0].mean_ev_lx - 5950.0).abs() < 1e-9);
        assert_eq!(y[0].max_dgps, 1.0f64.min(dgps(10_900.0)));
        // Twice the light: 2000 + 200 h lx.
        assert_eq!(y[1].hours_above, [96, 92, 88]);
        // Only the occupied hours count.
        let mut o = every_hour(hours);
        o.occupied[50..].iter_mut().for_each(|x| *x = false);
        let y = annual_glare(&Shading::blinds(c.view(), None, None), &sky, &o).unwrap();
        assert_eq!(y[0].occupied_hours, 50);
        assert_eq!(y[0].hours_above, [33, 25, 17]);
    }

    #[test]
    fn the_glare_rule_closes_a_group_on_the_whole_light_at_the_eye() {
        // Group A: open lets 2000 + 40 h lx reach the eye, closed 10 % of it; group B (one
        // state) 1000 + 20 h lx. With A open the eye gets 3000 + 60 h: DGPs above 0.40
        // from hour 8 on (3472.7 lx), while A's own light passes 3472.7 only from hour 37.
        let hours = 60;
        let sky = toy_sky(hours, |h, _| 100.0 * (1.0 + h as f64 / 50.0));
        let a_open = observers(1, |_| 2000.0, |_| 0.0);
        let a_closed = observers(1, |_| 200.0, |_| 0.0);
        let b = observers(1, |_| 1000.0, |_| 0.0);
        let shading = Shading {
            base: None,
            groups: vec![
                WindowGroup {
                    states: vec![
                        Shaded {
                            coefficients: a_open.view(),
                            sun: None,
                        },
                        Shaded {
                            coefficients: a_closed.view(),
                            sun: None,
                        },
                    ],
                    rule: ShadingRule::Glare { dgp: 0.40 },
                },
                WindowGroup {
                    states: vec![Shaded {
                        coefficients: b.view(),
                        sun: None,
                    }],
                    rule: ShadingRule::Schedule(vec![0; hours]),
                },
            ],
        };
        let o = every_hour(hours);
        let states = shading_states(&shading, &sky, &o).unwrap();
        let want: Vec<u16> = (0..hours)
            .map(|h| u16::from(3000.0 + 60.0 * h as f64 > 3472.7))
            .collect();
        assert_eq!(states[0], want);
        assert_eq!(states[0].iter().filter(|&&s| s == 0).count(), 8);
        // With A closed from hour 8 the eye gets 1200 + 24 h lx: no hour reaches 0.35
        // (2668.8 lx); hours 0–7 are open at 3000–3420 lx, at or above 0.35 and below 0.40.
        let y = annual_glare(&shading, &sky, &o).unwrap();
        assert_eq!(y[0].hours_above, [8, 0, 0]);
        // Out of range: refused, named.
        let mut bad = shading.clone();
        bad.groups[0].rule = ShadingRule::Glare { dgp: 0.1 };
        let e = annual_glare(&bad, &sky, &o).unwrap_err();
        assert!(e.message.contains("window group 0") && e.message.contains("dgp = 0.1"));
    }

    #[test]
    fn the_shares_intervals_cover_the_long_run_shares() {
        // Observers whose Ev swings over the year across the three classes; runs' estimates
        // scatter by their σ (4–12 % per coefficient).
        let hours = 150;
        let sky = toy_sky(hours, |h, p| {
            100.0 * (1.0 + 0.9 * (h as f64 * 0.31 + p as f64).sin())
        });
        let sensors = 20;
        let truth = observers(
            sensors,
            |k| 3000.0 + 150.0 * k as f64,
            |k| 0.04 + 0.08 * (k % 5) as f64 / 4.0,
        );
        let exact = Coefficients {
            sigma: vec![0.0; truth.sigma.len()],
            ..truth.clone()
        };
        let o = MetricOptions {
            draws: 200,
            ..every_hour(hours)
        };
        let long_run = annual_glare(&Shading::blinds(exact.view(), None, None), &sky, &o).unwrap();
        for y in &long_run {
            assert!(y.share_above.iter().all(|&s| s > 0.05 && s < 0.95), "{y:?}");
        }
        let runs = 100;
        let mut covered = [0usize; 3];
        let mut total = 0;
        for r in 0..runs {
            let mut rng = PhotonRng::new(77, r);
            let est = Coefficients {
                value: truth
                    .value
                    .iter()
                    .zip(&truth.sigma)
                    .map(|(c, s)| (c + s * normal(&mut rng)).max(0.0))
                    .collect(),
                ..truth.clone()
            };
            let o = MetricOptions {
                seed: r + 1,
                ..o.clone()
            };
            let y = annual_glare(&Shading::blinds(est.view(), None, None), &sky, &o).unwrap();
            for (got, want) in y.iter().zip(&long_run) {
                for (c, n) in covered.iter_mut().enumerate() {
                    let (lo, hi) = got.share_interval[c];
                    if lo <= want.share_above[c] && want.share_above[c] <= hi {
                        *n += 1;
                    }
                }
                total += 1;
            }
        }
        eprintln!("the 95 % intervals covered the long-run shares in {covered:?} of {total}");
        for c in covered {
            assert!(c as f64 >= 0.9 * total as f64, "{covered:?} of {total}");
        }
        // Any number of threads gives the same years.
        let one = annual_glare_on(&Shading::blinds(truth.view(), None, None), &sky, &o, 1);
        for t in [2, 3, 64] {
            assert_eq!(
                annual_glare_on(&Shading::blinds(truth.view(), None, None), &sky, &o, t),
                one
            );
        }
    }
}

//! The figures a lighting engineer reads off a region: incident flux, average, minimum and
//! maximum illuminance and the uniformities U0 = Emin/Eavg and Ud = Emin/Emax, each with a
//! standard error. docs/results.md states the methods.
//!
//! Flux and Eavg come from the region's photon tallies (`regions`): exact Monte Carlo
//! errors. The minimum and maximum of noisy vertex values are biased (the lowest of many
//! noisy values is lower than the lowest true value), so they are corrected and given an
//! error by a parametric bootstrap around an estimate of the true field:
//!
//! 1. the observed values Êᵥ (area weights aᵥ, standard errors σᵥ) are shrunk towards their
//!    weighted mean m by λ = max(0, 1 − σ̄²/V), V their weighted variance and σ̄² the
//!    weighted mean of σᵥ² (empirical Bayes: in a flat field the spread is noise and the
//!    estimate of the true field is flat; where the field varies much more than the noise,
//!    it is left nearly as observed): Ẽᵥ = m + λ(Êᵥ − m);
//! 2. `RESAMPLES` fields Eᵥ* = Ẽᵥ + σᵥ zᵥ (z standard normal, a fixed seed: the same map
//!    gives the same figures) give min*, max*, avg*, U0* = min*/avg*, Ud* = min*/max*;
//! 3. each figure's bias is mean(x*) − x(Ẽ); the reported value is the observed one minus
//!    that bias, and its standard error the standard deviation of x*.
//!
//! Vertex noise is taken as independent (neighbouring vertices share photons, so the
//! errors of min and max are somewhat overstated).

use crate::sampling::PhotonRng;

/// Resamples of the bootstrap.
pub const RESAMPLES: usize = 256;
/// The bootstrap's seed.
const SEED: u64 = 0x005e_ed0f_e11a;

/// A value and its standard error.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    pub value: f64,
    pub sigma: f64,
}

/// Minimum, maximum and uniformities of a field, bias-corrected.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Extremes {
    pub min: Estimate,
    pub max: Estimate,
    /// The uncorrected minimum and maximum of the observed values.
    pub min_observed: f64,
    pub max_observed: f64,
    pub u0: Estimate,
    pub ud: Estimate,
}

/// `weights` with the vertices that received no light at all (value exactly 0) left out:
/// a point under or inside an object, where no photon and no light sample arrives, is no
/// point of the lit surface (EN 12464-1 leaves such points out of Emin and U0), and it is
/// counted apart (`RegionStats::unlit_vertices`).
pub fn lit_weights(values: &[f64], weights: &[f64]) -> Vec<f64> {
    values
        .iter()
        .zip(weights)
        .map(|(&v, &w)| if v > 0.0 { w } else { 0.0 })
        .collect()
}

/// Standard normal pairs by Box–Muller.
fn normals(rng: &mut PhotonRng, out: &mut [f64]) {
    for pair in out.chunks_mut(2) {
        let u1 = rng.uniform().max(1e-300);
        let u2 = rng.uniform();
        let r = (-2.0 * u1.ln()).sqrt();
        let (s, c) = (2.0 * std::f64::consts::PI * u2).sin_cos();
        pair[0] = r * c;
        if pair.len() > 1 {
            pair[1] = r * s;
        }
    }
}

fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let v = x.iter().map(|a| (a - m) * (a - m)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, v.sqrt())
}

/// The extremes of `values` (their standard errors `sigma`, area weights `weights`; only
/// entries with weight > 0 count), with `average`, the field's mean and its error (from
/// the photon tallies), for the uniformities. None when no entry has weight.
pub fn extremes(
    values: &[f64],
    sigma: &[f64],
    weights: &[f64],
    average: Estimate,
) -> Option<Extremes> {
    let idx: Vec<usize> = (0..values.len()).filter(|&i| weights[i] > 0.0).collect();
    if idx.is_empty() {
        return None;
    }
    let w_sum: f64 = idx.iter().map(|&i| weights[i]).sum();
    let m = idx.iter().map(|&i| weights[i] * values[i]).sum::<f64>() / w_sum;
    let var = idx
        .iter()
        .map(|&i| weights[i] * (values[i] - m).powi(2))
        .sum::<f64>()
        / w_sum;
    let noise = idx
        .iter()
        .map(|&i| weights[i] * sigma[i] * sigma[i])
        .sum::<f64>()
        / w_sum;
    let lambda = if var > 0.0 {
        (1.0 - noise / var).max(0.0)
    } else {
        0.0
    };
    let truth: Vec<f64> = idx.iter().map(|&i| m + lambda * (values[i] - m)).collect();
    let sig: Vec<f64> = idx.iter().map(|&i| sigma[i]).collect();
    let minmax = |v: &mut dyn Iterator<Item = f64>| {
        v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        })
    };
    let (t_min, t_max) = minmax(&mut truth.iter().copied());
    let t_avg = average.value.max(f64::MIN_POSITIVE);
    let (o_min, o_max) = minmax(&mut idx.iter().map(|&i| values[i]));
    let mut rng = PhotonRng::new(SEED, idx.len() as u64);
    let mut z = vec![0.0; truth.len() + 1];
    let (mut mins, mut maxs, mut u0s, mut uds) = (
        Vec::with_capacity(RESAMPLES),
        Vec::with_capacity(RESAMPLES),
        Vec::with_capacity(RESAMPLES),
        Vec::with_capacity(RESAMPLES),
    );
    for _ in 0..RESAMPLES {
        normals(&mut rng, &mut z);
        let (lo, hi) = minmax(&mut truth.iter().zip(&sig).zip(&z).map(|((t, s), z)| t + s * z));
        let avg = (t_avg + average.sigma * z[truth.len()]).max(f64::MIN_POSITIVE);
        mins.push(lo);
        maxs.push(hi);
        u0s.push(lo / avg);
        uds.push(if hi > 0.0 { lo / hi } else { 0.0 });
    }
    let corrected = |observed: f64, truth: f64, sample: &[f64]| {
        let (mean, sd) = mean_sd(sample);
        Estimate {
            value: observed - (mean - truth),
            sigma: sd,
        }
    };
    let o_avg = average.value.max(f64::MIN_POSITIVE);
    Some(Extremes {
        min: corrected(o_min, t_min, &mins),
        max: corrected(o_max, t_max, &maxs),
        min_observed: o_min,
        max_observed: o_max,
        u0: corrected(o_min / o_avg, t_min / t_avg, &u0s),
        ud: corrected(
            if o_max > 0.0 { o_min / o_max } else { 0.0 },
            if t_max > 0.0 { t_min / t_max } else { 0.0 },
            &uds,
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Noisy observations of a known field: the corrected extremes are unbiased (their mean
    /// over trials is within a few standard errors of the truth, where the raw extremes
    /// are off by many) and their stated errors match their spread.
    #[test]
    fn extremes_are_corrected_and_their_errors_calibrated() {
        let n = 400;
        // A flat field (the hard case: every vertex competes for the minimum) and a smooth
        // one with a clear minimum and maximum.
        let field = |smooth: bool, i: usize| {
            let x = i as f64 / n as f64;
            if smooth {
                300.0 + 200.0 * (3.0 * x).sin()
            } else {
                500.0
            }
        };
        for (what, smooth) in [("flat", false), ("smooth", true)] {
            let truth: Vec<f64> = (0..n).map(|i| field(smooth, i)).collect();
            let w = vec![1.0; n];
            let t_min = truth.iter().cloned().fold(f64::INFINITY, f64::min);
            let t_max = truth.iter().cloned().fold(0.0, f64::max);
            let t_avg = truth.iter().sum::<f64>() / n as f64;
            let trials = 300;
            let (mut raw, mut cor, mut z2, mut u0_z2, mut sd) = (0.0, 0.0, 0.0, 0.0, 0.0);
            let mut rng = PhotonRng::new(99, 1);
            for _ in 0..trials {
                let mut z = vec![0.0; n];
                normals(&mut rng, &mut z);
                let sigma: Vec<f64> = truth.iter().map(|t| 0.03 * t).collect();
                let obs: Vec<f64> = truth
                    .iter()
                    .zip(&sigma)
                    .zip(&z)
                    .map(|((t, s), z)| t + s * z)
                    .collect();
                let avg = Estimate {
                    value: obs.iter().sum::<f64>() / n as f64,
                    sigma: 0.03 * t_avg / (n as f64).sqrt(),
                };
                let e = extremes(&obs, &sigma, &w, avg).unwrap();
                raw += e.min_observed - t_min;
                cor += e.min.value - t_min;
                z2 += ((e.min.value - t_min) / e.min.sigma).powi(2);
                sd += e.min.sigma;
                u0_z2 += ((e.u0.value - t_min / t_avg) / e.u0.sigma).powi(2);
                let _ = t_max;
            }
            let (raw, cor, sd) = (raw / trials as f64, cor / trials as f64, sd / trials as f64);
            let (rms_z, rms_u0) = ((z2 / trials as f64).sqrt(), (u0_z2 / trials as f64).sqrt());
            eprintln!("{what}: min bias raw {raw:.2}, corrected {cor:.2} (σ {sd:.2}); rms z {rms_z:.2}, U0 {rms_u0:.2}");
            // In the flat field the raw minimum of 400 values with 3 % noise is ~3 noise σ
            // low; corrected, the bias is a fraction of the stated error, and the errors
            // are neither far too small nor far too large.
            if what == "flat" {
                assert!(raw < -2.0 * 0.03 * t_min, "{what}: raw bias {raw}");
            }
            assert!(
                raw < 0.0 && cor.abs() < 0.6 * sd,
                "{what}: corrected bias {cor} (σ {sd}) vs raw {raw}"
            );
            assert!(
                cor.abs() < 0.5 * raw.abs(),
                "{what}: corrected bias {cor} vs raw {raw}"
            );
            assert!((0.6..1.6).contains(&rms_z), "{what}: rms z of Emin {rms_z}");
            assert!((0.6..1.6).contains(&rms_u0), "{what}: rms z of U0 {rms_u0}");
        }
    }
}

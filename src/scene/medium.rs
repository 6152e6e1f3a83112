//! Scattering inside a dielectric: a homogeneous medium of absorption σa and scattering σs
//! per band (1/m) with a Henyey–Greenstein phase function of asymmetry g per band.
//!
//! One free flight serves every band at once, unbiased per band (spectral tracking with
//! the path's own weights): the distance is drawn from the mixture Σ w_b σt_b e^(−σt_b t)
//! of the bands' exponentials, w_b the path's colour share of band b; each band is then
//! re-weighted by its own density over the mixture's, so that the colour's total does not
//! change (a photon carries the power it left its light with, as at surfaces). A collision
//! is a scattering with the colour-weighted single-scattering albedo, and the colour is
//! re-weighted by the bands' albedos over it; otherwise the path is absorbed there. A
//! grey medium takes exactly the one-band free flight and weights of 1; with no
//! scattering it is Beer–Lambert absorption.

use crate::spectral::pick_band;
use glam::DVec3;
use std::f64::consts::PI;

/// The scattering part of a dielectric's medium (its absorption is the dielectric's
/// `absorption_per_m`).
#[derive(Clone, Debug, PartialEq)]
pub struct Scattering {
    /// σt = σa + σs per band, 1/m.
    pub sigma_t: Vec<f64>,
    /// The single-scattering albedo σs / σt per band (0 where σt is 0).
    pub albedo: Vec<f64>,
    /// Henyey–Greenstein asymmetry per band, in (−1, 1).
    pub g: Vec<f64>,
    /// Whether every band has the same g (a direction then needs no re-weighting).
    pub one_g: bool,
}

/// What a free flight of a path inside a medium ended with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Flight {
    /// The path reaches the surface it was going to (colour re-weighted by transmittance).
    Surface,
    /// It scatters `t_m` metres along its direction (colour re-weighted).
    Scatter(f64),
    /// It is absorbed in the medium.
    Absorbed,
}

impl Scattering {
    /// Per-band σs, σa (σa may be None: clear) and g, already checked.
    pub fn new(sigma_s: Vec<f64>, sigma_a: Option<&[f64]>, g: Vec<f64>) -> Scattering {
        let sigma_t: Vec<f64> = sigma_s
            .iter()
            .enumerate()
            .map(|(b, s)| s + sigma_a.map_or(0.0, |a| a[b]))
            .collect();
        let albedo = sigma_s
            .iter()
            .zip(&sigma_t)
            .map(|(s, t)| if *t > 0.0 { s / t } else { 0.0 })
            .collect();
        let one_g = g.iter().all(|&x| x == g[0]);
        Scattering {
            sigma_t,
            albedo,
            g,
            one_g,
        }
    }

    /// A free flight toward a surface `dist_m` metres away (infinite: none) for a path of
    /// per-band weights `c`, with uniform numbers `u`: the band whose exponential draws the
    /// distance, the distance, and the scattering-or-absorption choice.
    pub fn flight(&self, c: &mut [f64], dist_m: f64, u: [f64; 3]) -> Flight {
        let total: f64 = c.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return Flight::Absorbed;
        }
        // The band that draws the distance, by the colour.
        let st = self.sigma_t[pick_band(c, total, u[0])];
        let t = if st > 0.0 {
            -(1.0 - u[1]).ln() / st
        } else {
            f64::INFINITY
        };
        if t >= dist_m {
            // Through to the surface: each band by its transmittance over the mixture's.
            let tr = |b: usize| match self.sigma_t[b] {
                0.0 => 1.0,
                s => (-s * dist_m).exp(),
            };
            return match reweigh(c, total, tr) {
                Some(_) => Flight::Surface,
                None => Flight::Absorbed,
            };
        }
        // A collision at t: each band by its collision density over the mixture's, then
        // scattered with the colour-weighted albedo (each band by its albedo over it), or
        // absorbed (the path ends, whatever its weights).
        let density = |b: usize| self.sigma_t[b] * (-self.sigma_t[b] * t).exp();
        if reweigh(c, total, density).is_none() {
            return Flight::Absorbed;
        }
        match reweigh(c, total, |b| self.albedo[b]) {
            Some(w) if u[2] < w => Flight::Scatter(t),
            _ => Flight::Absorbed,
        }
    }

    /// A new direction at a scattering event of a path travelling along `dir` with
    /// per-band weights `c` (re-weighted when the bands' g differ), from uniforms `u`.
    pub fn scatter(&self, dir: DVec3, c: &mut [f64], u: [f64; 3]) -> DVec3 {
        let g = if self.one_g {
            self.g[0]
        } else {
            // The band whose phase function draws the direction, by the colour.
            self.g[pick_band(c, c.iter().sum(), u[2])]
        };
        let cos = hg_sample_cos(g, u[0]);
        if !self.one_g {
            // Each band by its phase function's density over the mixture's (all positive).
            reweigh(c, c.iter().sum(), |b| hg_pdf(self.g[b], cos));
        }
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = 2.0 * PI * u[1];
        let (t, b) = dir.any_orthonormal_pair();
        (dir * cos + t * (sin * phi.cos()) + b * (sin * phi.sin())).normalize()
    }
}

/// Multiplies each band of `c` (of sum `total`) by `k(band)` over the colour-weighted mean
/// of k, so that the sum is kept, and returns that mean; None (with `c` left scaled by k
/// alone) when the mean is not positive and finite.
fn reweigh(c: &mut [f64], total: f64, k: impl Fn(usize) -> f64) -> Option<f64> {
    let mut sum = 0.0;
    for (b, x) in c.iter_mut().enumerate() {
        *x *= k(b);
        sum += *x;
    }
    let mean = sum / total;
    if !(mean > 0.0 && mean.is_finite()) {
        return None;
    }
    c.iter_mut().for_each(|x| *x /= mean);
    Some(mean)
}

/// The Henyey–Greenstein phase function's density (1/sr) at cosine `cos` between the
/// travel directions before and after.
#[inline]
pub fn hg_pdf(g: f64, cos: f64) -> f64 {
    let d = 1.0 + g * g - 2.0 * g * cos;
    (1.0 - g * g) / (4.0 * PI * d * d.sqrt())
}

/// A cosine drawn from the Henyey–Greenstein phase function of asymmetry `g` (its inverse
/// CDF; isotropic when |g| < 1e-4, where the closed form loses precision).
#[inline]
pub fn hg_sample_cos(g: f64, u: f64) -> f64 {
    if g.abs() < 1e-4 {
        return 1.0 - 2.0 * u;
    }
    let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hg_integrates_to_one_and_has_mean_cosine_g() {
        for g in [-0.8, -0.3, 0.0, 0.5, 0.9] {
            let n = 200_000;
            let (mut s, mut m) = (0.0, 0.0);
            for i in 0..n {
                let c = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                let p = hg_pdf(g, c) * 2.0 * PI * 2.0 / n as f64;
                s += p;
                m += p * c;
            }
            assert!((s - 1.0).abs() < 1e-3, "g {g}: ∫p = {s}");
            assert!((m - g).abs() < 2e-3, "g {g}: mean cosine {m}");
        }
    }

    /// χ² of the drawn cosines against the density over 20 bins.
    #[test]
    fn hg_draws_follow_their_density() {
        for g in [-0.6, 0.0, 0.3, 0.85] {
            let bins = 20;
            let n = 200_000;
            let mut h = vec![0.0; bins];
            let mut state = 0x9E37_79B9_7F4A_7C15u64;
            for _ in 0..n {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let u = (state >> 11) as f64 / (1u64 << 53) as f64;
                let c = hg_sample_cos(g, u);
                let k = (((c + 1.0) / 2.0 * bins as f64) as usize).min(bins - 1);
                h[k] += 1.0;
            }
            let mut chi2 = 0.0;
            for (k, &o) in h.iter().enumerate() {
                // Expected: the density's integral over the bin (fine midpoint rule).
                let (a, b) = (
                    -1.0 + 2.0 * k as f64 / bins as f64,
                    -1.0 + 2.0 * (k + 1) as f64 / bins as f64,
                );
                let m = 200;
                let e: f64 = (0..m)
                    .map(|j| {
                        let c = a + (b - a) * (j as f64 + 0.5) / m as f64;
                        hg_pdf(g, c) * 2.0 * PI * (b - a) / m as f64
                    })
                    .sum::<f64>()
                    * n as f64;
                chi2 += (o - e) * (o - e) / e;
            }
            // 19 degrees of freedom: χ² above 43.8 has probability 0.001.
            assert!(chi2 < 43.8, "g {g}: χ² {chi2}");
        }
    }

    #[test]
    fn a_grey_flight_has_unit_weights_and_absorption_is_beer_lambert() {
        // Grey: weights stay 1, and the share that reaches the surface is e^(−σt d).
        let m = Scattering::new(vec![3.0; 3], Some(&[1.0; 3]), vec![0.2; 3]);
        let n = 100_000;
        let mut through = 0;
        for i in 0..n {
            let mut c = [1.0; 3];
            let u = [
                (i as f64 + 0.5) / n as f64,
                ((i * 7919) % n) as f64 / n as f64,
                ((i * 104_729) % n) as f64 / n as f64,
            ];
            match m.flight(&mut c, 0.5, u) {
                Flight::Surface => through += 1,
                Flight::Scatter(t) => assert!(t < 0.5),
                Flight::Absorbed => {}
            }
            assert!(c.iter().all(|&x| (x - 1.0).abs() < 1e-12), "{c:?}");
        }
        let expected = (-4.0f64 * 0.5).exp();
        let got = through as f64 / n as f64;
        assert!((got - expected).abs() < 0.005, "{got} against {expected}");
    }

    #[test]
    fn chromatic_weights_keep_each_band_unbiased() {
        // Per band, the expected weight that reaches the surface equals e^(−σt d), and the
        // colour's total is conserved on every draw.
        let m = Scattering::new(vec![0.0, 2.0, 8.0], Some(&[1.0, 0.5, 0.0]), vec![0.0; 3]);
        let d = 0.3;
        let n = 400_000;
        let mut sum = [0.0; 3];
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..n {
            let mut c = [1.0; 3];
            let f = m.flight(&mut c, d, [next(), next(), next()]);
            if f != Flight::Absorbed {
                assert!((c.iter().sum::<f64>() - 3.0).abs() < 1e-9);
            }
            if f == Flight::Surface {
                for (s, x) in sum.iter_mut().zip(c) {
                    *s += x;
                }
            }
        }
        for (b, (s, st)) in sum.iter().zip(&m.sigma_t).enumerate() {
            let expected = (-st * d).exp();
            let got = s / n as f64;
            assert!(
                (got - expected).abs() < 0.01,
                "band {b}: {got} against {expected}"
            );
        }
    }
}

//! A photon's colour vector: per-band weights with band mean exactly 1 (unit energy).
//! After dispersion the photon is collapsed to one band and the vector is that band alone.

/// A medium's transmittance per band over a path: e^(−σ_b d) for extinction `sigma` per
/// band (1/m) over `d_m` metres. `CLEAR`: 1 in every band (no medium on the path).
#[derive(Clone, Copy, Debug)]
pub struct Transmittance<'s> {
    pub sigma: &'s [f64],
    pub d_m: f64,
}

impl Transmittance<'_> {
    pub const CLEAR: Transmittance<'static> = Transmittance {
        sigma: &[],
        d_m: 0.0,
    };

    /// Whether it is 1 in every band.
    #[inline]
    pub fn is_clear(&self) -> bool {
        self.sigma.is_empty() || self.d_m <= 0.0
    }

    /// Band `band`'s transmittance.
    #[inline]
    pub fn at(&self, band: usize) -> f64 {
        match self.sigma.get(band) {
            Some(&s) if s != 0.0 && self.d_m > 0.0 => (-s * self.d_m).exp(),
            _ => 1.0,
        }
    }
}

/// The colour of a photon in flight.
#[derive(Clone, Debug)]
pub struct Colour {
    c: Vec<f64>,
    band: Option<usize>,
    energy: f64,
    /// `energy` at emission (after an aimed light's weight).
    emitted: f64,
}

impl Colour {
    pub fn new(bands: usize) -> Self {
        Colour {
            c: vec![1.0; bands],
            band: None,
            energy: 1.0,
            emitted: 1.0,
        }
    }

    /// Starts a new photon with an emitter's colour.
    pub fn reset(&mut self, emitted: &[f64]) {
        self.c.copy_from_slice(emitted);
        self.band = None;
        self.energy = self.mean();
        self.emitted = self.energy;
    }

    /// Scales the photon by `w` (an aimed photon's weight): its colour and its energy,
    /// which weighs its squared deposits.
    pub fn scale(&mut self, w: f64) {
        self.c.iter_mut().for_each(|c| *c *= w);
        self.energy *= w;
    }

    /// Marks the current energy as the photon's energy at emission (after an aimed
    /// light's weight).
    pub fn emitted_now(&mut self) {
        self.emitted = self.energy;
    }

    /// The photon's energy in photon units as it left its emitter: the band mean, which
    /// every event keeps (1 with a single light; the emitter's power share over its
    /// selection probability in general).
    #[inline]
    pub fn energy(&self) -> f64 {
        self.energy
    }

    /// The energy the photon left its emitter with (before any weighted bounce).
    #[inline]
    pub fn energy_at_emission(&self) -> f64 {
        self.emitted
    }

    /// Per-band values to re-weight in place (a medium's free flights and scattering, which
    /// keep their total).
    pub(crate) fn values_mut(&mut self) -> &mut [f64] {
        &mut self.c
    }

    /// Per-band values (all bands; after a collapse only `band()` is non-zero).
    pub fn values(&self) -> &[f64] {
        &self.c
    }

    /// The band the photon was collapsed to, if any.
    pub fn band(&self) -> Option<usize> {
        self.band
    }

    /// Band mean of the colour: the photon's energy in photon units (1 up to rounding).
    pub fn mean(&self) -> f64 {
        match self.band {
            Some(b) => self.c[b] / self.c.len() as f64,
            None => self.c.iter().sum::<f64>() / self.c.len() as f64,
        }
    }

    /// Colour-weighted mean of per-band coefficients: Σ c·k / Σ c, the probability of the
    /// event whose per-band probabilities are `k`.
    #[inline]
    pub fn weighted_mean(&self, k: &[f64]) -> f64 {
        match self.band {
            Some(b) => k[b],
            None => {
                let (mut ck, mut cs) = (0.0, 0.0);
                for (c, k) in self.c.iter().zip(k) {
                    ck += c * k;
                    cs += c;
                }
                ck / cs
            }
        }
    }

    /// Re-weights the colour after an event of probability `p` with per-band probabilities
    /// `k`: c ← c·k/p. Keeps the band mean unchanged when p = weighted_mean(k).
    #[inline]
    pub fn reweight(&mut self, k: &[f64], p: f64) {
        let inv = 1.0 / p;
        match self.band {
            Some(b) => self.c[b] *= k[b] * inv,
            None => {
                for (c, k) in self.c.iter_mut().zip(k) {
                    *c *= k * inv;
                }
            }
        }
    }

    /// Replaces the per-band values by `v` (a fluorescent surface's: light moved between
    /// bands, so a collapsed photon spreads again); the photon's energy follows its mean.
    pub(crate) fn replace(&mut self, v: &[f64]) {
        let before = self.mean();
        self.c.copy_from_slice(v);
        self.band = None;
        if before > 0.0 {
            self.energy *= self.mean() / before;
        }
    }

    /// Becomes `from` times `tr` per band: the expected colour of `from` after that much
    /// of a medium (what a sensor crossed there reads).
    pub(crate) fn transmitted(&mut self, from: &Colour, tr: Transmittance) {
        self.clone_from(from);
        self.attenuate(tr);
    }

    /// Each band times its transmittance `tr`: a throughput through a medium.
    pub(crate) fn attenuate(&mut self, tr: Transmittance) {
        if tr.is_clear() {
            return;
        }
        for (b, c) in self.c.iter_mut().enumerate() {
            *c *= tr.at(b);
        }
    }

    /// Collapses to one band chosen with probability proportional to its weight, keeping
    /// unit energy: the chosen band gets the whole mean times the band count.
    pub fn collapse(&mut self, u: f64) {
        if self.band.is_some() {
            return;
        }
        self.band = Some(collapse_weights(&mut self.c, u));
    }

    /// Beer–Lambert over `dist_m` metres with per-band coefficients `alpha` (1/m): survives
    /// with the colour-weighted transmittance and is re-weighted; `None` when absorbed.
    pub fn survive_absorption(&mut self, alpha: &[f64], dist_m: f64, u: f64) -> Option<f64> {
        let t = |a: f64| if a == 0.0 { 1.0 } else { (-a * dist_m).exp() };
        let p = match self.band {
            Some(b) => t(alpha[b]),
            None => {
                let (mut ct, mut cs) = (0.0, 0.0);
                for (c, &a) in self.c.iter().zip(alpha) {
                    ct += c * t(a);
                    cs += c;
                }
                ct / cs
            }
        };
        if u >= p {
            return None;
        }
        match self.band {
            Some(_) => {}
            None => {
                for (c, &a) in self.c.iter_mut().zip(alpha) {
                    *c *= t(a) / p;
                }
            }
        }
        Some(p)
    }
}

/// A band chosen with probability proportional to its weight in `w` (of sum `total`; `u`
/// uniform in [0, 1)); a zero-weight band never, even at the rounding edge.
pub fn pick_band(w: &[f64], total: f64, u: f64) -> usize {
    let mut target = u * total;
    let mut chosen = w.len() - 1;
    for (i, &c) in w.iter().enumerate() {
        if target < c {
            chosen = i;
            break;
        }
        target -= c;
    }
    while w[chosen] == 0.0 && chosen > 0 {
        chosen -= 1;
    }
    chosen
}

/// Collapses per-band weights `w` to one band chosen with probability proportional to its
/// weight (`u` uniform in [0, 1)), which gets the total: every band keeps its expectation.
/// Returns the band.
pub fn collapse_weights(w: &mut [f64], u: f64) -> usize {
    let total: f64 = w.iter().sum();
    let chosen = pick_band(w, total, u);
    w.iter_mut().for_each(|c| *c = 0.0);
    w[chosen] = total;
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reweighting_keeps_unit_energy() {
        let mut c = Colour::new(4);
        c.reset(&[0.5, 1.5, 1.0, 1.0]);
        let k = [0.9, 0.1, 0.5, 0.0];
        let p = c.weighted_mean(&k);
        c.reweight(&k, p);
        assert!((c.mean() - 1.0).abs() < 1e-15);
        assert_eq!(c.values()[3], 0.0);
        c.survive_absorption(&[1.0, 2.0, 0.0, 5.0], 0.3, 0.0)
            .unwrap();
        assert!((c.mean() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn collapse_picks_bands_by_weight_and_keeps_energy() {
        let mut counts = [0usize; 3];
        let n = 30_000;
        for i in 0..n {
            let mut c = Colour::new(3);
            c.reset(&[0.0, 1.0, 2.0]);
            c.collapse((i as f64 + 0.5) / n as f64);
            counts[c.band().unwrap()] += 1;
            assert!((c.mean() - 1.0).abs() < 1e-15);
        }
        assert_eq!(counts[0], 0);
        assert!((counts[1] as f64 / n as f64 - 1.0 / 3.0).abs() < 1e-3);
    }
}

//! Counter-based random streams: photon `k`'s numbers depend only on `(seed, k)`.
//!
//! As in pbrt-v4's SPPM photon pass, randomness follows the work, not the thread: every
//! scheduler and thread count traces exactly the same photons and so deposits the same set
//! of contributions. The stream is SplitMix64 (Steele et al. 2014) started from a hash of
//! `(seed, k)`; the i-th number is `mix(start + (i + 1)·γ)`, a pure function of the counter.

const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

#[inline]
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The random stream of one photon.
#[derive(Clone, Debug)]
pub struct PhotonRng {
    state: u64,
}

impl PhotonRng {
    /// The stream of photon `index` for run seed `seed`.
    pub fn new(seed: u64, index: u64) -> Self {
        // Two rounds of mixing decorrelate neighbouring (seed, index) pairs.
        let start = mix(mix(seed ^ 0x6A09_E667_F3BC_C909).wrapping_add(index.wrapping_mul(GAMMA)));
        PhotonRng { state: start }
    }

    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(GAMMA);
        mix(self.state)
    }

    /// A uniform number in [0, 1) with 53 random bits.
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_depend_only_on_seed_and_index() {
        let a: Vec<u64> = (0..4)
            .map(|_| 0)
            .scan(PhotonRng::new(7, 42), |r, _: u64| Some(r.next_u64()))
            .collect();
        let b: Vec<u64> = (0..4)
            .map(|_| 0)
            .scan(PhotonRng::new(7, 42), |r, _: u64| Some(r.next_u64()))
            .collect();
        assert_eq!(a, b);
        assert_ne!(PhotonRng::new(7, 43).next_u64(), a[0]);
        assert_ne!(PhotonRng::new(8, 42).next_u64(), a[0]);
    }

    #[test]
    fn uniform_is_in_unit_interval_with_right_mean() {
        let mut sum = 0.0;
        let n = 200_000;
        for k in 0..n {
            let u = PhotonRng::new(1, k).uniform();
            assert!((0.0..1.0).contains(&u));
            sum += u;
        }
        // Standard error of the mean of U(0,1) is 0.2887/sqrt(n) = 6.5e-4.
        assert!((sum / n as f64 - 0.5).abs() < 4.0 * 0.2887 / (n as f64).sqrt());
    }
}

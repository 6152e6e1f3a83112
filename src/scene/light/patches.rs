//! Sky patches: the Tregenza sky (145 patches) and Reinhart's subdivisions of it (MF:n,
//! 144 n² + 1 patches), numbered as Radiance numbers them (reinhart.cal, gendaymtx):
//! patch 0 is the ground (the whole lower hemisphere), then rows of equal altitude steps
//! from the horizon up, each row's patches from north toward east, the first centred on
//! north, and last the cap around the zenith.
//!
//! Row r (0-based) of MF:n spans altitudes [r α, (r + 1) α] with α = 90° / (7 n + 0.5);
//! its patch count is the Tregenza row's (30, 30, 24, 24, 18, 12, 6) × n; the cap spans
//! the last α/2.

use crate::error::{bail, Result};
use std::f64::consts::{FRAC_PI_2, PI};

/// The Tregenza rows' patch counts, from the horizon up (the cap not counted).
const TREGENZA_ROWS: [usize; 7] = [30, 30, 24, 24, 18, 12, 6];

/// A subdivision of the sky into patches: Reinhart MF:`mf` (MF:1 is Tregenza's).
#[derive(Clone, Debug, PartialEq)]
pub struct SkyPatches {
    mf: usize,
    /// Per row: its first patch number and its patch count.
    rows: Vec<(usize, usize)>,
    /// The altitude step α, radians.
    alpha: f64,
}

/// The largest Reinhart subdivision taken: MF:16 has 36 865 sky patches.
pub const MAX_REINHART_MF: u32 = 16;

impl SkyPatches {
    /// Reinhart's MF:`mf` subdivision (1 = Tregenza's 145 patches; 2: 577; 4: 2305).
    pub fn reinhart(mf: u32) -> Result<Self> {
        if !(1..=MAX_REINHART_MF).contains(&mf) {
            bail!(
                ImapErrInvalidArgument,
                "mf = {mf}: Reinhart subdivisions MF:1 (Tregenza, 145 patches) to MF:{MAX_REINHART_MF} are supported"
            );
        }
        let mf = mf as usize;
        let mut rows = Vec::with_capacity(7 * mf);
        let mut first = 1;
        for r in 0..7 * mf {
            let n = TREGENZA_ROWS[r / mf] * mf;
            rows.push((first, n));
            first += n;
        }
        Ok(SkyPatches {
            mf,
            rows,
            alpha: FRAC_PI_2 / (7.0 * mf as f64 + 0.5),
        })
    }

    /// The subdivision's MF.
    pub fn mf(&self) -> u32 {
        self.mf as u32
    }

    /// The number of patches, the ground (patch 0) included: 146 for Tregenza.
    pub fn count(&self) -> usize {
        self.cap() + 1
    }

    /// The zenith cap's patch number (the last).
    pub fn cap(&self) -> usize {
        let (first, n) = *self.rows.last().expect("rows");
        first + n
    }

    /// The patch holding the direction of altitude `alt` and azimuth `az` (radians, from
    /// north toward east): 0 below the horizon.
    pub fn patch(&self, alt: f64, az: f64) -> usize {
        if alt < 0.0 {
            return 0;
        }
        let r = (alt / self.alpha) as usize;
        if r >= self.rows.len() {
            return self.cap();
        }
        let (first, n) = self.rows[r];
        // Patch j is centred on azimuth 2π j / n.
        let mut t = az / (2.0 * PI) * n as f64 + 0.5;
        t -= (t / n as f64).floor() * n as f64;
        first + (t as usize).min(n - 1)
    }

    /// Patch `p`'s bounds: (altitude low, altitude high, azimuth start, azimuth width),
    /// radians; the ground spans the lower hemisphere.
    pub fn bounds(&self, p: usize) -> (f64, f64, f64, f64) {
        if p == 0 {
            return (-FRAC_PI_2, 0.0, 0.0, 2.0 * PI);
        }
        if p >= self.cap() {
            return (
                self.rows.len() as f64 * self.alpha,
                FRAC_PI_2,
                0.0,
                2.0 * PI,
            );
        }
        let r = self.rows.partition_point(|&(first, _)| first <= p) - 1;
        let (first, n) = self.rows[r];
        let w = 2.0 * PI / n as f64;
        (
            r as f64 * self.alpha,
            (r + 1) as f64 * self.alpha,
            (p - first) as f64 * w - w / 2.0,
            w,
        )
    }

    /// Patch `p`'s solid angle, sr (exact).
    pub fn solid_angle(&self, p: usize) -> f64 {
        let (lo, hi, _, w) = self.bounds(p);
        w * (hi.sin() - lo.sin())
    }

    /// ∫ cos Z dω over patch `p` (sky patches; 0 for the ground), sr: the horizontal
    /// irradiance of unit radiance over it.
    pub fn horizontal(&self, p: usize) -> f64 {
        if p == 0 {
            return 0.0;
        }
        let (lo, hi, _, w) = self.bounds(p);
        w * (hi.sin().powi(2) - lo.sin().powi(2)) / 2.0
    }

    /// Patch `p`'s centre (altitude, azimuth), radians, as Radiance places it; the ground's
    /// is the nadir.
    pub fn centre(&self, p: usize) -> (f64, f64) {
        let (lo, hi, a0, w) = self.bounds(p);
        if p == 0 {
            return (-FRAC_PI_2, 0.0);
        }
        if p >= self.cap() {
            return (FRAC_PI_2, 0.0);
        }
        ((lo + hi) / 2.0, a0 + w / 2.0)
    }

    /// The mean of `f(alt, az)` over patch `p`: `sub` × `sub` points equally spaced in
    /// azimuth and in sin(altitude) (equal solid angle), 4 × `sub` in azimuth over the cap
    /// and the ground.
    pub fn mean(&self, p: usize, sub: usize, f: impl Fn(f64, f64) -> f64) -> f64 {
        self.means(p, sub, |alt, az| (f(alt, az), 0.0)).0
    }

    /// The means of two functions over patch `p` by the points of `mean`, in one pass.
    pub fn means(&self, p: usize, sub: usize, f: impl Fn(f64, f64) -> (f64, f64)) -> (f64, f64) {
        let (lo, hi, a0, w) = self.bounds(p);
        let (na, ns) = if p == 0 || p >= self.cap() {
            (4 * sub, sub)
        } else {
            (sub, sub)
        };
        let (s0, s1) = (lo.sin(), hi.sin());
        let (mut a, mut b) = (0.0, 0.0);
        for i in 0..ns {
            let alt = (s0 + (s1 - s0) * (i as f64 + 0.5) / ns as f64).asin();
            for j in 0..na {
                let (x, y) = f(alt, a0 + w * (j as f64 + 0.5) / na as f64);
                a += x;
                b += y;
            }
        }
        let k = 1.0 / (na * ns) as f64;
        (a * k, b * k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reinhart_counts_are_radiances() {
        for (mf, n) in [(1, 146), (2, 578), (4, 2306), (6, 5186)] {
            let s = SkyPatches::reinhart(mf).unwrap();
            assert_eq!(s.count(), n, "MF:{mf}");
        }
        assert!(SkyPatches::reinhart(0).is_err() && SkyPatches::reinhart(17).is_err());
    }

    #[test]
    fn patches_tile_the_sky() {
        for mf in [1, 2, 4] {
            let s = SkyPatches::reinhart(mf).unwrap();
            let omega: f64 = (1..s.count()).map(|p| s.solid_angle(p)).sum();
            assert!((omega - 2.0 * PI).abs() < 1e-9, "MF:{mf}: {omega}");
            let h: f64 = (1..s.count()).map(|p| s.horizontal(p)).sum();
            assert!((h - PI).abs() < 1e-9, "MF:{mf}: {h}");
            assert!((s.solid_angle(0) - 2.0 * PI).abs() < 1e-12);
            // Every patch's centre lies in it; its corners' neighbours in others.
            for p in 0..s.count() {
                let (alt, az) = s.centre(p);
                let alt = alt.clamp(-1.4, FRAC_PI_2 - 1e-4);
                assert_eq!(s.patch(alt, az), p, "MF:{mf} patch {p}");
                let (lo, hi, a0, w) = s.bounds(p);
                if p > 0 && p < s.cap() {
                    let inside = s.patch(lo + 1e-9, a0 + 1e-9);
                    assert_eq!(inside, p);
                    assert_ne!(s.patch(hi + 1e-9, a0 + w / 2.0), p);
                    assert_ne!(s.patch(lo + 1e-9, a0 + w + 1e-9), p);
                }
            }
        }
        // Tregenza: patch 1 is centred on north at the horizon row, patch 2 12° east of it,
        // 145 the zenith.
        let t = SkyPatches::reinhart(1).unwrap();
        assert_eq!(t.patch(0.1, 0.0), 1);
        assert_eq!(t.patch(0.1, 12f64.to_radians()), 2);
        assert_eq!(t.patch(0.1, -5f64.to_radians()), 1);
        assert_eq!(t.patch(0.1, 355f64.to_radians()), 1);
        assert_eq!(t.patch(1.5, 0.0), 145);
        assert_eq!(t.patch(-0.1, 0.0), 0);
    }
}

//! Spectra of lights and their powers per band.
//!
//! A band's value is the power in the band (W per band, W/m² per band), so a spectrum
//! `S(λ)` (relative power per nm) gives band `i` the power ∫ S over the band's interval:
//! `[λ_i − Δ/2, λ_i + Δ/2]` for bands `Δ` apart, `[min, max]` for a single band over a range,
//! the one wavelength for a single monochromatic band (`Bands::interval`).

use super::tables::{CMF_START_NM, CMF_X, CMF_Y, CMF_Z, D65_10NM, D65_START_NM};
use crate::error::{bail, check_finite, Result};
use crate::spectral::Bands;

/// Second radiation constant, m·K (the value CIE 15:2004 uses for Planckian radiators).
pub const C2: f64 = 1.4388e-2;

/// The colour of a light.
#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    /// The same power in every band (grey).
    Equal,
    /// A linear Rec. 709 colour (RGB contexts: the bands themselves; spectral contexts:
    /// each band takes the channel of its wavelength, < 490 nm blue, 490–580 nm green,
    /// above red).
    Rgb([f64; 3]),
    /// Planck's law at a temperature in kelvin.
    Blackbody(f64),
    /// CIE standard illuminant A (ISO/CIE 11664-2).
    CieA,
    /// CIE standard illuminant D65 (ISO/CIE 11664-2).
    CieD65,
    /// A table of (wavelength nm, relative power per nm), linear in between, 0 outside.
    Table(Vec<(f64, f64)>),
    /// Relative power per band, one value per band.
    Bands(Vec<f64>),
}

impl Spectrum {
    /// Checks the spectrum's numbers.
    pub fn validate(&self, bands: &Bands) -> Result<()> {
        match self {
            Spectrum::Equal | Spectrum::CieA | Spectrum::CieD65 => {}
            Spectrum::Rgb(c) => {
                check_finite("spectrum.rgb", c)?;
                if c.iter().any(|&x| x < 0.0) || c.iter().all(|&x| x == 0.0) {
                    bail!(
                        ImapErrInvalidArgument,
                        "spectrum.rgb = {c:?} must be non-negative and not all 0"
                    );
                }
            }
            Spectrum::Blackbody(t) => {
                crate::error::check_finite_scalar("spectrum.cct_k", *t)?;
                if !(100.0..=1e6).contains(t) {
                    bail!(
                        ImapErrInvalidArgument,
                        "spectrum.cct_k = {t} K is not in [100, 1e6] K"
                    );
                }
            }
            Spectrum::Table(t) => {
                if t.len() < 2 {
                    bail!(
                        ImapErrInvalidArgument,
                        "spectrum table has {} entries: give at least 2",
                        t.len()
                    );
                }
                for (i, &(nm, v)) in t.iter().enumerate() {
                    check_finite("spectrum table", &[nm, v])?;
                    if v < 0.0 || nm <= 0.0 {
                        bail!(
                            ImapErrInvalidArgument,
                            "spectrum table entry {i}: ({nm} nm, {v}) must have a positive wavelength and a non-negative value"
                        );
                    }
                    if i > 0 && nm <= t[i - 1].0 {
                        bail!(
                            ImapErrInvalidArgument,
                            "spectrum table wavelengths must increase: entry {i} ({nm} nm) follows {} nm",
                            t[i - 1].0
                        );
                    }
                }
            }
            Spectrum::Bands(v) => {
                if v.len() != bands.count() {
                    bail!(
                        ImapErrInvalidArgument,
                        "spectrum has {} band values; the context has {} bands",
                        v.len(),
                        bands.count()
                    );
                }
                check_finite("spectrum band values", v)?;
                if v.iter().any(|&x| x < 0.0) {
                    bail!(
                        ImapErrInvalidArgument,
                        "spectrum band values must be non-negative"
                    );
                }
            }
        }
        Ok(())
    }

    /// Relative power per nm at `nm` (not for `Equal`, `Rgb`, `Bands`).
    pub fn at(&self, nm: f64) -> f64 {
        match self {
            Spectrum::Blackbody(t) => planck(nm, *t),
            Spectrum::CieA => illuminant_a(nm),
            Spectrum::CieD65 => d65(nm),
            Spectrum::Table(t) => table_at(t, nm),
            Spectrum::Equal | Spectrum::Rgb(_) | Spectrum::Bands(_) => 1.0,
        }
    }
}

/// Linear interpolation in a table of (x, y), 0 outside it.
fn table_at(t: &[(f64, f64)], x: f64) -> f64 {
    if t.is_empty() || x < t[0].0 || x > t[t.len() - 1].0 {
        return 0.0;
    }
    let i = t.partition_point(|p| p.0 <= x).clamp(1, t.len() - 1);
    let (a, b) = (t[i - 1], t[i]);
    if b.0 == a.0 {
        return a.1;
    }
    a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0)
}

/// Planck's spectral radiant exitance at `nm` for temperature `t` K, relative (the c1 and
/// unit factors are left out: only shapes matter here).
pub fn planck(nm: f64, t: f64) -> f64 {
    let l = nm * 1e-9;
    let x = C2 / (l * t);
    if x > 700.0 {
        return 0.0;
    }
    1.0 / (l.powi(5) * x.exp_m1()) * 1e-30
}

/// CIE standard illuminant A, relative spectral power (ISO/CIE 11664-2:2022 formula, 100 at
/// 560 nm).
pub fn illuminant_a(nm: f64) -> f64 {
    let c: f64 = 1.435e7 / 2848.0;
    100.0 * (560.0 / nm).powi(5) * (c / 560.0).exp_m1() / (c / nm).exp_m1()
}

/// CIE standard illuminant D65, relative spectral power (100 at 560 nm), 300–830 nm.
pub fn d65(nm: f64) -> f64 {
    let x = (nm - D65_START_NM) / 10.0;
    if !(0.0..=(D65_10NM.len() - 1) as f64).contains(&x) {
        return 0.0;
    }
    let i = (x as usize).min(D65_10NM.len() - 2);
    let f = x - i as f64;
    D65_10NM[i] * (1.0 - f) + D65_10NM[i + 1] * f
}

/// The CIE 1931 2° colour-matching functions at `nm` (linear between the 1 nm values, 0
/// outside 360–830 nm). `cmf(nm)[1]` is V(λ).
pub fn cmf(nm: f64) -> [f64; 3] {
    let x = nm - CMF_START_NM;
    let last = (CMF_Y.len() - 1) as f64;
    if !(0.0..=last).contains(&x) {
        return [0.0; 3];
    }
    let i = (x as usize).min(CMF_Y.len() - 2);
    let f = x - i as f64;
    let lerp = |t: &[f64]| t[i] * (1.0 - f) + t[i + 1] * f;
    [lerp(&CMF_X), lerp(&CMF_Y), lerp(&CMF_Z)]
}

/// V(λ), the CIE photopic luminous efficiency.
pub fn v(nm: f64) -> f64 {
    cmf(nm)[1]
}

/// ∫ f over [lo, hi] nm by the trapezoid rule on a grid of at most 0.25 nm (exact for the
/// piecewise-linear tables, and well below 1e-5 relative for smooth spectra); f(lo) for a
/// zero-width interval.
pub fn integrate(lo: f64, hi: f64, f: impl Fn(f64) -> f64) -> f64 {
    if hi <= lo {
        return f(lo);
    }
    let n = ((hi - lo) / 0.25).ceil().max(1.0) as usize;
    let h = (hi - lo) / n as f64;
    let mut s = 0.5 * (f(lo) + f(hi));
    for k in 1..n {
        s += f(lo + k as f64 * h);
    }
    s * h
}

/// Relative power of `spectrum` in each band (spectral contexts): ∫ S over the band's
/// interval, the given value per band, or the channel by wavelength for an RGB colour.
pub fn band_powers(spectrum: &Spectrum, bands: &Bands) -> Vec<f64> {
    let n = bands.count();
    (0..n)
        .map(|i| {
            let (lo, hi) = bands.interval(i);
            let width = if hi > lo { hi - lo } else { 1.0 };
            match spectrum {
                Spectrum::Equal => width,
                Spectrum::Rgb(c) => c[rgb_channel(bands.wavelengths_nm[i])] * width,
                Spectrum::Bands(v) => v[i],
                s => integrate(lo, hi, |nm| s.at(nm)),
            }
        })
        .collect()
}

/// The RGB channel (0 red, 1 green, 2 blue) that stands for a wavelength in spectral
/// contexts: below 490 nm blue, 490–580 nm green, above red.
pub fn rgb_channel(nm: f64) -> usize {
    if nm < 490.0 {
        2
    } else if nm < 580.0 {
        1
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cie_tables_have_their_published_checksums() {
        // CIE 15:2004: sums of the 1 nm tables, 360–830 nm.
        let sums = [
            CMF_X.iter().sum::<f64>(),
            CMF_Y.iter().sum(),
            CMF_Z.iter().sum(),
        ];
        for (s, want) in sums.iter().zip([106.865469, 106.856917, 106.892251]) {
            assert!((s - want).abs() < 2e-6, "{s} vs {want}");
        }
        assert_eq!(v(555.0), 1.0);
        assert_eq!(d65(560.0), 100.0);
        assert!(
            (d65(301.0) - 0.36014).abs() < 1e-9,
            "the 1 nm table's value"
        );
        assert!((illuminant_a(560.0) - 100.0).abs() < 1e-9);
        // Illuminant A at 300 and 780 nm (ISO/CIE 11664-2 table): 0.930483, 241.675.
        assert!((illuminant_a(300.0) - 0.930483).abs() < 1e-5);
        assert!((illuminant_a(780.0) - 241.675).abs() < 1e-3);
    }
}

//! Colour bands: RGB (3 bands) or N spectral bands sampled over a wavelength range.

use crate::error::{bail, check_finite, Result};

/// Representative wavelengths (nm) of the R, G and B bands, used by dispersion and by
/// wavelength-dependent indices of refraction in RGB mode.
pub(crate) const RGB_WAVELENGTHS_NM: [f64; 3] = [612.0, 549.0, 465.0];

/// The wavelengths a spectral context may cover, nm: far ultraviolet to far infrared. Band
/// powers are integrated on a 0.25 nm grid, so the range also bounds the work a spectrum
/// costs (at most 400 000 points).
pub const SPECTRAL_RANGE_NM: (f64, f64) = (100.0, 100_000.0);

/// The band layout of a context.
#[derive(Clone, Debug, PartialEq)]
pub struct Bands {
    /// Centre wavelength of each band in nanometres.
    pub wavelengths_nm: Vec<f64>,
    pub rgb: bool,
    /// The configured wavelength range (spectral), nm.
    pub range_nm: (f64, f64),
}

impl Bands {
    pub fn rgb() -> Self {
        Bands {
            wavelengths_nm: RGB_WAVELENGTHS_NM.to_vec(),
            rgb: true,
            range_nm: (380.0, 780.0),
        }
    }

    /// `count` bands whose wavelengths run from `min_nm` to `max_nm` inclusive (41 bands over
    /// 380–780 nm are the 10 nm steps of the paper; one band sits at the range's middle).
    pub fn spectral(count: u32, min_nm: f64, max_nm: f64) -> Result<Self> {
        if count == 0 {
            bail!(
                ImapErrBadBands,
                "band_count is 0: a map needs at least one band"
            );
        }
        if count > 4096 {
            bail!(
                ImapErrBadBands,
                "band_count {count} is larger than the supported 4096"
            );
        }
        check_finite("wavelength range", &[min_nm, max_nm])?;
        if !(min_nm > 0.0 && max_nm >= min_nm) || (count > 1 && max_nm <= min_nm) {
            bail!(
                ImapErrBadBands,
                "wavelength range [{min_nm}, {max_nm}] nm is not a positive, non-empty range"
            );
        }
        let (lo, hi) = SPECTRAL_RANGE_NM;
        if min_nm < lo {
            bail!(
                ImapErrBadBands,
                "wavelength_min_nm = {min_nm} nm is below the {lo} nm that spectral contexts cover ({lo}–{hi} nm)"
            );
        }
        if max_nm > hi {
            bail!(
                ImapErrBadBands,
                "wavelength_max_nm = {max_nm} nm is above the {hi} nm that spectral contexts cover ({lo}–{hi} nm)"
            );
        }
        let wavelengths_nm = if count == 1 {
            vec![0.5 * (min_nm + max_nm)]
        } else {
            let step = (max_nm - min_nm) / (count - 1) as f64;
            (0..count).map(|i| min_nm + step * i as f64).collect()
        };
        Ok(Bands {
            wavelengths_nm,
            rgb: false,
            range_nm: (min_nm, max_nm),
        })
    }

    /// The wavelength interval band `i` stands for, nm: `[λ_i − Δ/2, λ_i + Δ/2]` for bands
    /// `Δ` apart; the whole range for a single band (a point when the range is one
    /// wavelength: a monochromatic band). RGB bands: the wavelengths each channel stands
    /// for in spectral contexts, B 380–490, G 490–580, R 580–780 nm.
    pub fn interval(&self, i: usize) -> (f64, f64) {
        if self.rgb {
            return [(580.0, 780.0), (490.0, 580.0), (380.0, 490.0)][i];
        }
        let n = self.count();
        if n == 1 {
            return self.range_nm;
        }
        let half = 0.5 * (self.range_nm.1 - self.range_nm.0) / (n - 1) as f64;
        let l = self.wavelengths_nm[i];
        (l - half, l + half)
    }

    pub fn count(&self) -> usize {
        self.wavelengths_nm.len()
    }

    /// Expands a caller's per-band array: one value means "the same in every band", otherwise
    /// the length must equal the band count.
    pub fn expand(&self, name: &str, values: &[f64]) -> Result<Vec<f64>> {
        check_finite(name, values)?;
        match values.len() {
            1 => Ok(vec![values[0]; self.count()]),
            n if n == self.count() => Ok(values.to_vec()),
            n => bail!(
                ImapErrInvalidArgument,
                "{name} has {n} values; give 1 (grey) or {} (one per band)",
                self.count()
            ),
        }
    }
}

impl Bands {
    /// Expands a per-band emission (power or exitance) and checks it is non-negative and
    /// not zero in every band.
    pub fn expand_emission(&self, name: &str, values: &[f64]) -> Result<Vec<f64>> {
        let v = self.expand(name, values)?;
        if let Some(i) = v.iter().position(|&x| x < 0.0) {
            bail!(ImapErrInvalidArgument, "{name}[{i}] = {} is negative", v[i]);
        }
        if v.iter().all(|&x| x == 0.0) {
            bail!(
                ImapErrNoLight,
                "{name} is 0 in every band: the light emits nothing"
            );
        }
        let total: f64 = v.iter().sum();
        if !total.is_finite() {
            bail!(
                ImapErrInvalidArgument,
                "{name} sums to {total} over the bands (too large to represent)"
            );
        }
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spectral_steps_match_the_paper() {
        let b = Bands::spectral(41, 380.0, 780.0).unwrap();
        assert_eq!(b.count(), 41);
        assert!((b.wavelengths_nm[1] - 390.0).abs() < 1e-12);
        assert!((b.wavelengths_nm[40] - 780.0).abs() < 1e-12);
        let b = Bands::spectral(81, 380.0, 780.0).unwrap();
        assert!((b.wavelengths_nm[1] - 385.0).abs() < 1e-12);
    }

    #[test]
    fn bad_bands_are_refused() {
        use crate::error::ImapStatus::*;
        assert_eq!(
            Bands::spectral(0, 380.0, 780.0).unwrap_err().status,
            ImapErrBadBands
        );
        assert_eq!(
            Bands::spectral(4, 500.0, 400.0).unwrap_err().status,
            ImapErrBadBands
        );
        assert_eq!(
            Bands::spectral(4, f64::NAN, 400.0).unwrap_err().status,
            ImapErrNonFinite
        );
        let b = Bands::rgb();
        assert_eq!(
            b.expand("x", &[1.0, 2.0]).unwrap_err().status,
            ImapErrInvalidArgument
        );
        assert_eq!(b.expand("x", &[0.5]).unwrap(), vec![0.5; 3]);
    }
}

//! The sun: a uniformly bright disk of `SUN_DIAMETER_DEG` (`Distant::sun`), given by its
//! direct normal irradiance or illuminance.

use super::distant::*;
use crate::error::{bail, check_range, Result};
use crate::photometry::Spectrum;
use crate::spectral::Bands;
use std::f64::consts::PI;
use std::sync::Arc;

/// The sun's angular diameter, degrees.
pub const SUN_DIAMETER_DEG: f64 = 0.53;

/// The sun as the caller describes it.
#[derive(Clone, Debug, PartialEq)]
pub struct SunDesc {
    pub azimuth_deg: f64,
    pub zenith_deg: f64,
    /// `NormalIrradiance` or `NormalIlluminance`.
    pub amount: SkyAmount,
    pub spectrum: Spectrum,
    pub zenith: [f64; 3],
    pub north: [f64; 3],
}

impl Default for SunDesc {
    /// The sun at the zenith of a z-up scene (north +y), D65, no amount yet.
    fn default() -> Self {
        SunDesc {
            azimuth_deg: 0.0,
            zenith_deg: 0.0,
            amount: SkyAmount::NormalIrradiance(0.0),
            spectrum: Spectrum::CieD65,
            zenith: [0.0, 0.0, 1.0],
            north: [0.0, 1.0, 0.0],
        }
    }
}

impl Distant {
    /// The sun: a disk of `SUN_DIAMETER_DEG`, uniformly bright.
    pub fn sun(desc: &SunDesc, bands: &Bands) -> Result<Self> {
        let frame = SkyFrame::new(desc.zenith, desc.north)?;
        check_range("azimuth_deg", desc.azimuth_deg, -360.0, 360.0)?;
        check_range("zenith_deg", desc.zenith_deg, 0.0, 90.0)?;
        let x = check_amount(desc.amount)?;
        if !matches!(
            desc.amount,
            SkyAmount::NormalIrradiance(_) | SkyAmount::NormalIlluminance(_)
        ) {
            bail!(
                ImapErrInvalidArgument,
                "the sun cannot be given by its {}: give its direct normal irradiance (W/m²) or illuminance (lx)",
                desc.amount.name()
            );
        }
        let axis = frame.direction(desc.azimuth_deg.to_radians(), desc.zenith_deg.to_radians());
        let delta = (0.5 * SUN_DIAMETER_DEG).to_radians();
        let (s, c) = delta.sin_cos();
        let one_minus_cos = s * s / (1.0 + c);
        // E_n = ∫ L cos α dω over the disk = L π sin²δ.
        let normal = PI * s * s;
        let per_band = per_band(&desc.spectrum, bands, x, desc.amount.photometric(), normal)?;
        Ok(Distant {
            parts: vec![Arc::new(DistantPart {
                frame,
                radiance: Radiance::Sun {
                    axis,
                    one_minus_cos,
                },
                table: None,
                patch: None,
                integral: 2.0 * PI * one_minus_cos,
                horizontal: normal * axis.dot(frame.zenith),
                per_band,
            })],
        })
    }
}

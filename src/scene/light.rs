//! Point and spot lights.

use super::bands::Bands;
use crate::error::{bail, check_finite, Result};
use glam::DVec3;

#[derive(Clone, Debug)]
pub enum LightShape {
    /// Isotropic point source.
    Point,
    /// Uniform intensity inside a cone of half-angle `acos(cos_half_angle)` around `axis`.
    Spot { axis: DVec3, cos_half_angle: f64 },
}

/// A point-like light with a radiant flux per band in watts.
#[derive(Clone, Debug)]
pub struct Light {
    pub position: DVec3,
    pub shape: LightShape,
    pub power: Vec<f64>,
}

impl Light {
    pub fn point(position: [f64; 3], power: &[f64], bands: &Bands) -> Result<Self> {
        check_finite("position", &position)?;
        let power = bands.expand_emission("power", power)?;
        Ok(Light {
            position: DVec3::from(position),
            shape: LightShape::Point,
            power,
        })
    }

    pub fn spot(
        position: [f64; 3],
        direction: [f64; 3],
        half_angle_rad: f64,
        power: &[f64],
        bands: &Bands,
    ) -> Result<Self> {
        check_finite("position", &position)?;
        check_finite("direction", &direction)?;
        check_finite("half_angle", &[half_angle_rad])?;
        let axis = DVec3::from(direction);
        if axis.length() < 1e-300 {
            bail!(ImapErrInvalidArgument, "spot direction is the zero vector");
        }
        if !(half_angle_rad > 0.0 && half_angle_rad <= std::f64::consts::PI) {
            bail!(
                ImapErrInvalidArgument,
                "spot half angle {half_angle_rad} rad is not in (0, π]"
            );
        }
        let power = bands.expand_emission("power", power)?;
        Ok(Light {
            position: DVec3::from(position),
            shape: LightShape::Spot {
                axis: axis.normalize(),
                cos_half_angle: half_angle_rad.cos(),
            },
            power,
        })
    }
}

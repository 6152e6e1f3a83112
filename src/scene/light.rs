//! Point and spot lights.

use super::bands::Bands;
use crate::error::{bail, check_coordinates, check_finite, Result};
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
        check_coordinates("position", &position)?;
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
        check_coordinates("position", &position)?;
        check_finite("direction", &direction)?;
        crate::error::check_finite_scalar("half_angle_rad", half_angle_rad)?;
        let Some(axis) = unit_vector(direction) else {
            bail!(ImapErrInvalidArgument, "direction is the zero vector");
        };
        if !(half_angle_rad > 0.0 && half_angle_rad <= std::f64::consts::PI) {
            bail!(
                ImapErrInvalidArgument,
                "half_angle_rad = {half_angle_rad} is not in (0, π]"
            );
        }
        let power = bands.expand_emission("power", power)?;
        Ok(Light {
            position: DVec3::from(position),
            shape: LightShape::Spot {
                axis,
                cos_half_angle: half_angle_rad.cos(),
            },
            power,
        })
    }
}

/// `v` scaled to unit length, for any finite non-zero `v` (huge and tiny components
/// included: it is scaled by its largest component first), or None for the zero vector.
pub fn unit_vector(v: [f64; 3]) -> Option<DVec3> {
    let v = DVec3::from(v);
    let m = v.abs().max_element();
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    Some((v / m).normalize())
}

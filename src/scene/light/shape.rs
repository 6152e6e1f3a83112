//! The shapes of lights: how a light's flux is spread over directions and over its
//! aperture (point, spot, cosine, beam, goniometric luminaire, distant source).

use super::distant::Distant;
use super::luminaire::Luminaire;
use crate::sampling::{warp, PhotonRng};
use glam::DVec3;
use std::f64::consts::PI;
use std::sync::Arc;

/// How a light's direction and origin are distributed.
#[derive(Clone, Debug)]
pub enum LightShape {
    /// Isotropic point source.
    Point,
    /// Uniform intensity inside a cone of half-angle `acos(cos_half_angle)` around `axis`.
    Spot { axis: DVec3, cos_half_angle: f64 },
    /// I = I0 cos γ into the hemisphere around `axis` (a Lambertian point source).
    Cosine { axis: DVec3 },
    /// Parallel rays along `axis`, leaving an aperture centred on the light's position.
    Beam { axis: DVec3, aperture: Aperture },
    /// A goniometric luminaire.
    Luminaire(Arc<Luminaire>),
    /// A sky, an environment image or the sun, infinitely far (`super::sky`). Its light's
    /// `power` is per m² of cross-section: the flux through the scene's bounding sphere
    /// follows from the sphere (`PreparedScene`).
    Distant(Arc<Distant>),
}

/// A flat disk, ellipse or rectangle: centre ± `u` ± `v` (half-extent vectors, scene
/// units, perpendicular to each other).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aperture {
    pub u: DVec3,
    pub v: DVec3,
    /// Elliptic (a disk when |u| = |v|) rather than rectangular.
    pub elliptic: bool,
}

impl Aperture {
    /// Area, scene units².
    pub fn area(&self) -> f64 {
        let a = 4.0 * self.u.length() * self.v.length();
        if self.elliptic {
            a * PI / 4.0
        } else {
            a
        }
    }

    /// A uniformly distributed offset from the centre.
    #[inline]
    pub fn sample(&self, u1: f64, u2: f64) -> DVec3 {
        if self.elliptic {
            let r = u1.sqrt();
            let phi = 2.0 * PI * u2;
            self.u * (r * phi.cos()) + self.v * (r * phi.sin())
        } else {
            self.u * (2.0 * u1 - 1.0) + self.v * (2.0 * u2 - 1.0)
        }
    }

    /// Whether the offset `d` from the centre (in the aperture's plane) lies inside.
    #[inline]
    pub fn contains(&self, d: DVec3) -> bool {
        let a = d.dot(self.u) / self.u.length_squared();
        let b = d.dot(self.v) / self.v.length_squared();
        if self.elliptic {
            a * a + b * b <= 1.0
        } else {
            a.abs() <= 1.0 && b.abs() <= 1.0
        }
    }
}

impl LightShape {
    /// Intensity toward unit direction `d` per watt of the light's flux, 1/sr (its
    /// distribution over directions; 0 for a beam, whose light is not a point's).
    #[inline]
    pub fn intensity_per_watt(&self, d: DVec3) -> f64 {
        match self {
            LightShape::Point => 0.25 / PI,
            LightShape::Spot {
                axis,
                cos_half_angle,
            } => {
                if d.dot(*axis) >= *cos_half_angle {
                    1.0 / (2.0 * PI * (1.0 - cos_half_angle))
                } else {
                    0.0
                }
            }
            LightShape::Cosine { axis } => d.dot(*axis).max(0.0) / PI,
            LightShape::Beam { .. } | LightShape::Distant(_) => 0.0,
            LightShape::Luminaire(l) => l.candela(d) * l.inv_flux,
        }
    }

    /// Samples where a photon leaves (an offset from the light's position) and its
    /// direction, distributed as the light's flux.
    #[inline]
    pub fn sample(&self, rng: &mut PhotonRng) -> (DVec3, DVec3) {
        let (u1, u2) = (rng.uniform(), rng.uniform());
        match self {
            LightShape::Point => (DVec3::ZERO, warp::uniform_sphere(u1, u2)),
            LightShape::Spot {
                axis,
                cos_half_angle,
            } => (
                DVec3::ZERO,
                warp::uniform_cone(*axis, *cos_half_angle, u1, u2),
            ),
            LightShape::Cosine { axis } => (DVec3::ZERO, warp::cosine_hemisphere(*axis, u1, u2)),
            LightShape::Beam { axis, aperture } => (aperture.sample(u1, u2), *axis),
            LightShape::Luminaire(l) => {
                let (phi, theta) = l.dist.sample(u1, u2, rng.uniform());
                let at = match &l.opening {
                    Some(o) => o.sample(rng.uniform(), rng.uniform()),
                    None => DVec3::ZERO,
                };
                (at, l.direction(phi, theta))
            }
            LightShape::Distant(_) => unreachable!("distant lights are emitted by the scene"),
        }
    }

    /// The luminous opening or aperture light leaves from, if not a point.
    pub fn aperture(&self) -> Option<&Aperture> {
        match self {
            LightShape::Beam { aperture, .. } => Some(aperture),
            LightShape::Luminaire(l) => l.opening.as_ref(),
            _ => None,
        }
    }
}

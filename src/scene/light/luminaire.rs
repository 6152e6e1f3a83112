//! A goniometric luminaire placed in the scene: its distribution in the world's frame.

use super::shape::Aperture;
use crate::photometry::Goniometric;
use glam::DVec3;
use std::sync::Arc;

/// A placed goniometric distribution.
#[derive(Debug)]
pub struct Luminaire {
    pub dist: Arc<Goniometric>,
    /// The distribution's frame in the world: a direction at azimuth φ and polar angle θ
    /// is `sin θ (cos φ x + sin φ y) + cos θ z`. Type C: z = the aim (γ = 0, nadir of the
    /// luminaire), x = the C0 direction, y = C90. Type B: z = the lateral axis (H = 90°),
    /// x = the aim (V = H = 0), y = the luminaire's up (V = 90°).
    pub frame: [DVec3; 3],
    /// The luminous opening light leaves from, if emission from it was asked for.
    pub opening: Option<Aperture>,
    /// Intensity per watt of flux: `dist.intensity / dist.flux`.
    pub(super) inv_flux: f64,
}

impl Luminaire {
    /// The distribution's (φ, θ) of a world direction.
    #[inline]
    pub(super) fn angles(&self, d: DVec3) -> (f64, f64) {
        let [x, y, z] = self.frame;
        let c = d.dot(z).clamp(-1.0, 1.0);
        (d.dot(y).atan2(d.dot(x)), c.acos())
    }

    /// World direction of (φ, θ).
    #[inline]
    pub(super) fn direction(&self, phi: f64, theta: f64) -> DVec3 {
        let [x, y, z] = self.frame;
        let s = theta.sin();
        (x * (s * phi.cos()) + y * (s * phi.sin()) + z * theta.cos()).normalize()
    }

    /// Intensity in candela toward world direction `d` (unit), the placement's flux
    /// scale and TILT factor not included.
    pub fn candela(&self, d: DVec3) -> f64 {
        let (phi, theta) = self.angles(d);
        self.dist.intensity(phi, theta)
    }
}

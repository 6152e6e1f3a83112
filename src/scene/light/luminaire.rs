//! A goniometric luminaire placed in the scene: its distribution in the world's frame.

use super::shape::Aperture;
use crate::photometry::{Goniometric, Opening};
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
    /// The luminous parts as an observer sees them (the file's opening, whether or not the
    /// light is emitted from it): what `crate::glare` divides the intensity by.
    pub luminous: Luminous,
}

/// A luminaire's luminous parts in the world: the file's opening (a point, a flat
/// rectangle or disk, an LM-63 box, cylinder or sphere) and its frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Luminous {
    pub opening: Opening,
    /// The opening's length direction (C0–C180 for type C), its width direction and its
    /// normal (the photometric axis), unit.
    pub along: DVec3,
    pub across: DVec3,
    pub normal: DVec3,
}

impl Luminous {
    /// The area the luminous parts show toward unit direction `d`, m² (0 for a point).
    pub fn projected_area_m2(&self, d: DVec3) -> f64 {
        self.opening
            .projected_area_m2(d.dot(self.along), d.dot(self.across), d.dot(self.normal))
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn shape(opening: Opening) -> Luminous {
        Luminous {
            opening,
            along: DVec3::X,
            across: DVec3::Y,
            normal: DVec3::NEG_Z,
        }
    }

    #[test]
    fn luminous_parts_show_their_projected_area() {
        let d = DVec3::new(1.0, 1.0, -1.0).normalize();
        let c = 1.0 / 3f64.sqrt();
        let rect = shape(Opening::Rectangle {
            width: 0.3,
            length: 0.6,
        });
        assert!((rect.projected_area_m2(DVec3::NEG_Z) - 0.18).abs() < 1e-12);
        assert!((rect.projected_area_m2(d) - 0.18 * c).abs() < 1e-12);
        assert_eq!(rect.projected_area_m2(DVec3::X), 0.0);
        let disk = shape(Opening::Ellipse {
            width: 0.4,
            length: 0.4,
        });
        assert!((disk.projected_area_m2(DVec3::Z) - PI * 0.04).abs() < 1e-12);
        let solid = |width, length, height| {
            shape(Opening::Solid {
                what: "test",
                width,
                length,
                height,
            })
        };
        // A box shows its bottom (l w), its long side (l h) and its end (w h).
        let b = solid(0.3, 0.6, 0.1);
        assert!((b.projected_area_m2(DVec3::NEG_Z) - 0.18).abs() < 1e-12);
        assert!((b.projected_area_m2(DVec3::Y) - 0.06).abs() < 1e-12);
        assert!((b.projected_area_m2(DVec3::X) - 0.03).abs() < 1e-12);
        assert!((b.projected_area_m2(d) - (0.18 + 0.06 + 0.03) * c).abs() < 1e-12);
        // A vertical cylinder: its disk from below, its side (D h) from the side.
        let cyl = solid(-0.2, 0.0, 0.5);
        assert!((cyl.projected_area_m2(DVec3::NEG_Z) - PI * 0.01).abs() < 1e-12);
        assert!((cyl.projected_area_m2(DVec3::X) - 0.1).abs() < 1e-12);
        let s = solid(-0.3, -0.3, -0.3);
        assert!((s.projected_area_m2(d) - PI * 0.0225).abs() < 1e-12);
        assert_eq!(shape(Opening::Point).projected_area_m2(d), 0.0);
    }
}

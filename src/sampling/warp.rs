//! Warps from uniform numbers to directions and points.

use glam::DVec3;
use std::f64::consts::PI;

/// An orthonormal basis (t, b) around unit vector `n` (Duff et al. 2017, branchless).
#[inline]
pub fn basis(n: DVec3) -> (DVec3, DVec3) {
    let s = 1.0f64.copysign(n.z);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + s * n.x * n.x * a, s * b, -s * n.x),
        DVec3::new(b, s + n.y * n.y * a, -n.y),
    )
}

/// Cosine-weighted direction in the hemisphere around unit normal `n` (Malley's method).
#[inline]
pub fn cosine_hemisphere(n: DVec3, u1: f64, u2: f64) -> DVec3 {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let z = (1.0 - u1).max(0.0).sqrt();
    let (t, b) = basis(n);
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * z).normalize()
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn uniform_sphere(u1: f64, u2: f64) -> DVec3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform direction in the cone of half-angle with cosine `cos_max` around unit `axis`.
#[inline]
pub fn uniform_cone(axis: DVec3, cos_max: f64, u1: f64, u2: f64) -> DVec3 {
    let z = 1.0 - u1 * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    let (t, b) = basis(axis);
    (t * (r * phi.cos()) + b * (r * phi.sin()) + axis * z).normalize()
}

/// Uniform direction in the cone around unit `axis` whose half-angle θ has
/// 1 − cos θ = `one_minus_cos`, precise however narrow the cone: the sine of the angle to
/// the axis comes from 1 − cos directly, never from a cosine rounded near 1.
#[inline]
pub fn uniform_narrow_cone(axis: DVec3, one_minus_cos: f64, u1: f64, u2: f64) -> DVec3 {
    let v = u1 * one_minus_cos; // 1 − cos of the angle to the axis
    let r = (v * (2.0 - v)).max(0.0).sqrt();
    let z = 1.0 - v;
    let phi = 2.0 * PI * u2;
    let (t, b) = basis(axis);
    (t * (r * phi.cos()) + b * (r * phi.sin()) + axis * z).normalize()
}

/// Uniform barycentric coordinates (b1, b2) on a triangle.
#[inline]
pub fn uniform_triangle(u1: f64, u2: f64) -> (f64, f64) {
    let s = u1.sqrt();
    (1.0 - s, u2 * s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::PhotonRng;

    #[test]
    fn cosine_hemisphere_has_cosine_moments() {
        // For a cosine-weighted density, E[cos θ] = 2/3 and E[cos² θ] = 1/2.
        let n = DVec3::new(0.3, -0.5, 0.81).normalize();
        let mut rng = PhotonRng::new(11, 5);
        let (mut m1, mut m2) = (0.0, 0.0);
        let count = 200_000;
        for _ in 0..count {
            let d = cosine_hemisphere(n, rng.uniform(), rng.uniform());
            assert!((d.length() - 1.0).abs() < 1e-12);
            let c = d.dot(n);
            assert!(c >= 0.0);
            m1 += c;
            m2 += c * c;
        }
        let c = count as f64;
        assert!((m1 / c - 2.0 / 3.0).abs() < 0.003);
        assert!((m2 / c - 0.5).abs() < 0.003);
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [
            DVec3::Z,
            -DVec3::Z,
            DVec3::X,
            DVec3::new(1.0, 2.0, -3.0).normalize(),
        ] {
            let (t, b) = basis(n);
            assert!(t.dot(b).abs() < 1e-12 && t.dot(n).abs() < 1e-12 && b.dot(n).abs() < 1e-12);
            assert!((t.length() - 1.0).abs() < 1e-12 && (b.length() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn cone_stays_in_cone() {
        let axis = DVec3::new(0.0, 1.0, 1.0).normalize();
        let mut rng = PhotonRng::new(2, 9);
        for _ in 0..10_000 {
            let d = uniform_cone(axis, 0.8, rng.uniform(), rng.uniform());
            assert!(d.dot(axis) >= 0.8 - 1e-12);
        }
    }
}

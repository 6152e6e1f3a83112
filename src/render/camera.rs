//! The pinhole camera of a render.

use crate::error::{bail, check_finite, Result};
use crate::scene::light::unit_vector;
use glam::DVec3;

/// Largest image side accepted.
pub(crate) const MAX_IMAGE_SIDE: u32 = 16384;

/// What the caller describes, in scene units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraDesc {
    pub position: [f64; 3],
    /// Viewing direction (need not be unit length).
    pub direction: [f64; 3],
    /// Up vector; only its component across `direction` is used.
    pub up: [f64; 3],
    /// Full vertical field of view in degrees, in (0, 180).
    pub fov_y_deg: f64,
    pub width: u32,
    pub height: u32,
}

/// A validated camera with its orthonormal frame (local, recentred coordinates).
#[derive(Clone, Debug)]
pub struct Camera {
    pub desc: CameraDesc,
    pub origin: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    tan_half: f64,
    aspect: f64,
}

impl Camera {
    /// Validates `desc`; `scene_origin` is the point the prepared scene was recentred on.
    pub fn new(desc: &CameraDesc, scene_origin: DVec3) -> Result<Self> {
        check_finite("camera position", &desc.position)?;
        check_finite("camera direction", &desc.direction)?;
        check_finite("camera up", &desc.up)?;
        crate::error::check_finite_scalar("camera fov_y_deg", desc.fov_y_deg)?;
        if !(desc.fov_y_deg > 0.0 && desc.fov_y_deg < 180.0) {
            bail!(
                ImapErrInvalidArgument,
                "camera fov_y_deg = {} is not in (0, 180)",
                desc.fov_y_deg
            );
        }
        for (name, v) in [("width", desc.width), ("height", desc.height)] {
            if v == 0 || v > MAX_IMAGE_SIDE {
                bail!(
                    ImapErrInvalidArgument,
                    "camera {name} = {v} is not in 1..={MAX_IMAGE_SIDE}"
                );
            }
        }
        let Some(forward) = unit_vector(desc.direction) else {
            bail!(
                ImapErrInvalidArgument,
                "camera direction is the zero vector"
            );
        };
        let Some(up_in) = unit_vector(desc.up) else {
            bail!(ImapErrInvalidArgument, "camera up is the zero vector");
        };
        let right = forward.cross(up_in);
        if right.length() < 1e-9 {
            bail!(
                ImapErrInvalidArgument,
                "camera up is parallel to the viewing direction"
            );
        }
        let right = right.normalize();
        let up = right.cross(forward);
        Ok(Camera {
            desc: *desc,
            origin: DVec3::from(desc.position) - scene_origin,
            forward,
            right,
            up,
            tan_half: (desc.fov_y_deg.to_radians() * 0.5).tan(),
            aspect: desc.width as f64 / desc.height as f64,
        })
    }

    pub fn pixels(&self) -> usize {
        self.desc.width as usize * self.desc.height as usize
    }

    /// Unit direction through the point (x + jx, y + jy) of the image, pixel (0, 0) at the
    /// top left, jx and jy in [0, 1).
    #[inline]
    pub fn ray(&self, x: u32, y: u32, jx: f64, jy: f64) -> DVec3 {
        let sx =
            (2.0 * (x as f64 + jx) / self.desc.width as f64 - 1.0) * self.tan_half * self.aspect;
        let sy = (1.0 - 2.0 * (y as f64 + jy) / self.desc.height as f64) * self.tan_half;
        (self.forward + self.right * sx + self.up * sy).normalize()
    }

    /// The pixel that sees point `p` (local scene units) and the cosine between its ray and
    /// the viewing direction, or None when `p` is behind the camera or outside the image.
    #[inline]
    pub fn project(&self, p: DVec3) -> Option<(u32, f64)> {
        let z = self.depth(p);
        if z <= 0.0 {
            return None;
        }
        let (x, y) = self.image_point(p);
        if !(x >= 0.0 && y >= 0.0 && x < self.desc.width as f64 && y < self.desc.height as f64) {
            return None;
        }
        let pixel = y as u32 * self.desc.width + x as u32;
        Some((pixel, z / (p - self.origin).length()))
    }

    /// How far in front of the eye point `p` (local scene units) lies, along the viewing
    /// direction.
    #[inline]
    pub fn depth(&self, p: DVec3) -> f64 {
        (p - self.origin).dot(self.forward)
    }

    /// Where point `p` (in front of the eye: `depth(p) > 0`) falls on the image, in pixel
    /// coordinates: x to the right, y down, pixel (i, j) the unit square from (i, j); the
    /// inverse of `ray` (`ray(i, j, jx, jy)` passes through (i + jx, j + jy)).
    #[inline]
    pub fn image_point(&self, p: DVec3) -> (f64, f64) {
        let d = p - self.origin;
        let z = d.dot(self.forward);
        let sx = d.dot(self.right) / z / (self.tan_half * self.aspect);
        let sy = d.dot(self.up) / z / self.tan_half;
        (
            (sx + 1.0) * 0.5 * self.desc.width as f64,
            (1.0 - sy) * 0.5 * self.desc.height as f64,
        )
    }

    /// A pixel's area on the image plane at unit distance from the eye.
    pub fn pixel_area(&self) -> f64 {
        let a = 2.0 * self.tan_half / self.desc.height as f64;
        a * a
    }

    /// Angular size of a pixel at the image centre (radians): a surface at distance d shows
    /// a pixel footprint of about d times this.
    pub fn pixel_angle(&self) -> f64 {
        2.0 * self.tan_half / self.desc.height as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `project` is the inverse of `ray`: a point along a pixel's ray projects back to that
    /// pixel, with the cosine of the ray to the axis.
    #[test]
    fn project_inverts_ray() {
        let cam = Camera::new(
            &CameraDesc {
                position: [1.0, 2.0, 3.0],
                direction: [0.3, -1.0, 0.2],
                up: [0.0, 0.0, 1.0],
                fov_y_deg: 70.0,
                width: 40,
                height: 30,
            },
            DVec3::new(0.5, 0.0, 0.0),
        )
        .unwrap();
        for (x, y) in [(0, 0), (39, 29), (17, 5), (3, 28)] {
            let d = cam.ray(x, y, 0.25, 0.75);
            let (p, cos) = cam.project(cam.origin + 7.0 * d).unwrap();
            assert_eq!(p, y * 40 + x);
            assert!((cos - d.dot(cam.forward)).abs() < 1e-12);
        }
        assert!(cam.project(cam.origin - cam.forward).is_none());
        assert!(cam
            .project(cam.origin + cam.forward + 10.0 * cam.up)
            .is_none());
    }

    fn desc() -> CameraDesc {
        CameraDesc {
            position: [0.0, 0.0, 5.0],
            direction: [0.0, 0.0, -1.0],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 90.0,
            width: 200,
            height: 100,
        }
    }

    #[test]
    fn rays_span_the_field_of_view() {
        let c = Camera::new(&desc(), DVec3::ZERO).unwrap();
        let centre = c.ray(100, 50, 0.0, 0.0);
        assert!((centre - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12);
        // Top edge: 45° up; left edge: atan(2) to the left (aspect 2).
        let top = c.ray(100, 0, 0.0, 0.0);
        assert!((top.y / -top.z - 1.0).abs() < 1e-12);
        let left = c.ray(0, 50, 0.0, 0.0);
        assert!((left.x / left.z - 2.0).abs() < 1e-12);
    }

    #[test]
    fn huge_and_tiny_direction_vectors_are_directions() {
        let mut d = desc();
        d.direction = [0.0, 0.0, -1e300];
        d.up = [0.0, 1e-300, 0.0];
        let c = Camera::new(&d, DVec3::ZERO).unwrap();
        let u = Camera::new(&desc(), DVec3::ZERO).unwrap();
        assert!((c.ray(3, 4, 0.5, 0.5) - u.ray(3, 4, 0.5, 0.5)).length() < 1e-15);
    }

    #[test]
    fn bad_cameras_are_refused() {
        let mut d = desc();
        d.up = [0.0, 0.0, 3.0];
        assert!(Camera::new(&d, DVec3::ZERO).is_err());
        let mut d = desc();
        d.fov_y_deg = 180.0;
        assert!(Camera::new(&d, DVec3::ZERO).is_err());
        let mut d = desc();
        d.width = 0;
        assert!(Camera::new(&d, DVec3::ZERO).is_err());
        let mut d = desc();
        d.position[1] = f64::NAN;
        assert_eq!(
            Camera::new(&d, DVec3::ZERO).unwrap_err().status,
            crate::error::ImapStatus::ImapErrNonFinite
        );
    }
}

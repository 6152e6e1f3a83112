//! The camera of a render: a pinhole (perspective) camera, or a fisheye in the angular
//! (equidistant) or hemispherical (orthographic) projection, as Radiance's `-vta` and
//! `-vth` views draw them, for glare pictures (`glare::picture_glare`).

use crate::error::{bail, check_finite, Result};
use crate::scene::light::unit_vector;
use glam::DVec3;
use std::f64::consts::PI;

/// Largest image side accepted.
pub(crate) const MAX_IMAGE_SIDE: u32 = 16384;

/// How directions map onto the image. In every projection the image is square in angle
/// at its centre: a pixel spans the same angle across and up there.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Projection {
    /// A pinhole camera: straight lines stay straight; `fov_y_deg` in (0, 180).
    #[default]
    Perspective,
    /// Angular (equidistant) fisheye, Radiance's `-vta`: the distance from the image
    /// centre is proportional to the angle θ from the viewing direction; `fov_y_deg` in
    /// (0, 360] is the full angle the image's height spans. Pixels more than 180° off the
    /// axis (a wide image's corners) see nothing and stay black.
    AngularFisheye,
    /// Hemispherical (orthographic) fisheye, Radiance's `-vth`: the distance from the
    /// centre is proportional to sin θ; `fov_y_deg` in (0, 180]. Pixels outside the
    /// hemisphere's circle see nothing and stay black.
    Hemispherical,
}

/// What the caller describes, in scene units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraDesc {
    pub position: [f64; 3],
    /// Viewing direction (need not be unit length).
    pub direction: [f64; 3],
    /// Up vector; only its component across `direction` is used.
    pub up: [f64; 3],
    /// Full vertical field of view in degrees: in (0, 180) for a perspective camera,
    /// (0, 360] for an angular fisheye, (0, 180] for a hemispherical one.
    pub fov_y_deg: f64,
    pub width: u32,
    pub height: u32,
    pub projection: Projection,
}

/// A validated camera with its orthonormal frame (local, recentred coordinates).
#[derive(Clone, Debug)]
pub struct Camera {
    pub desc: CameraDesc,
    pub origin: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    /// Perspective: tan(fov/2); angular: fov/2 in radians; hemispherical: sin(fov/2) — the
    /// image's half height in the projection's own measure.
    scale: f64,
    aspect: f64,
}

impl Camera {
    /// Validates `desc`; `scene_origin` is the point the prepared scene was recentred on.
    pub fn new(desc: &CameraDesc, scene_origin: DVec3) -> Result<Self> {
        check_finite("camera position", &desc.position)?;
        check_finite("camera direction", &desc.direction)?;
        check_finite("camera up", &desc.up)?;
        crate::error::check_finite_scalar("camera fov_y_deg", desc.fov_y_deg)?;
        let fov = desc.fov_y_deg;
        let (ok, range) = match desc.projection {
            Projection::Perspective => (
                fov > 0.0 && fov < 180.0,
                "(0, 180) for a perspective camera",
            ),
            Projection::AngularFisheye => {
                (fov > 0.0 && fov <= 360.0, "(0, 360] for an angular fisheye")
            }
            Projection::Hemispherical => (
                fov > 0.0 && fov <= 180.0,
                "(0, 180] for a hemispherical fisheye",
            ),
        };
        if !ok {
            bail!(
                ImapErrInvalidArgument,
                "camera fov_y_deg = {fov} is not in {range}"
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
        let half = 0.5 * fov.to_radians();
        Ok(Camera {
            desc: *desc,
            origin: DVec3::from(desc.position) - scene_origin,
            forward,
            right,
            up,
            scale: match desc.projection {
                Projection::Perspective => half.tan(),
                Projection::AngularFisheye => half,
                Projection::Hemispherical => half.sin(),
            },
            aspect: desc.width as f64 / desc.height as f64,
        })
    }

    pub fn pixels(&self) -> usize {
        self.desc.width as usize * self.desc.height as usize
    }

    /// The viewing direction (unit).
    pub fn forward(&self) -> DVec3 {
        self.forward
    }

    /// The camera's up (unit, across the viewing direction).
    pub fn up(&self) -> DVec3 {
        self.up
    }

    /// Whether this is a pinhole camera (straight edges project to straight edges).
    pub fn is_perspective(&self) -> bool {
        self.desc.projection == Projection::Perspective
    }

    /// Unit direction through the point (x + jx, y + jy) of the image, pixel (0, 0) at the
    /// top left, jx and jy in [0, 1); None where a fisheye's image sees nothing.
    #[inline]
    pub fn ray(&self, x: u32, y: u32, jx: f64, jy: f64) -> Option<DVec3> {
        if self.is_perspective() {
            // As the pinhole camera always computed it, to the bit.
            let k = self.scale;
            let sx = (2.0 * (x as f64 + jx) / self.desc.width as f64 - 1.0) * k * self.aspect;
            let sy = (1.0 - 2.0 * (y as f64 + jy) / self.desc.height as f64) * k;
            return Some((self.forward + self.right * sx + self.up * sy).normalize());
        }
        let sx = (2.0 * (x as f64 + jx) / self.desc.width as f64 - 1.0) * self.aspect;
        let sy = 1.0 - 2.0 * (y as f64 + jy) / self.desc.height as f64;
        self.direction_at(sx, sy)
    }

    /// The direction at image-plane point (sx, sy): the image's height spans [-1, 1].
    #[inline]
    fn direction_at(&self, sx: f64, sy: f64) -> Option<DVec3> {
        let k = self.scale;
        match self.desc.projection {
            Projection::Perspective => {
                Some((self.forward + self.right * (sx * k) + self.up * (sy * k)).normalize())
            }
            Projection::AngularFisheye => {
                let r = (sx * sx + sy * sy).sqrt();
                let theta = k * r;
                if theta > PI {
                    return None;
                }
                if r == 0.0 {
                    return Some(self.forward);
                }
                let (s, c) = theta.sin_cos();
                Some(self.forward * c + (self.right * sx + self.up * sy) * (s / r))
            }
            Projection::Hemispherical => {
                let (a, b) = (sx * k, sy * k);
                let s2 = a * a + b * b;
                if s2 > 1.0 {
                    return None;
                }
                Some(self.forward * (1.0 - s2).sqrt() + self.right * a + self.up * b)
            }
        }
    }

    /// The image-plane point (sx, sy) that sees unit-free direction `d` (from the eye),
    /// or None where the projection cannot show it.
    #[inline]
    fn plane_point(&self, d: DVec3) -> Option<(f64, f64)> {
        let (z, a, b) = (d.dot(self.forward), d.dot(self.right), d.dot(self.up));
        let k = self.scale;
        match self.desc.projection {
            Projection::Perspective => (z > 0.0).then(|| (a / z / k, b / z / k)),
            Projection::AngularFisheye => {
                let across = (a * a + b * b).sqrt();
                if across == 0.0 {
                    // On the axis: in front the centre; behind, no single point.
                    return (z > 0.0).then_some((0.0, 0.0));
                }
                let theta = across.atan2(z);
                let r = theta / k;
                Some((a / across * r, b / across * r))
            }
            Projection::Hemispherical => {
                if z <= 0.0 {
                    return None;
                }
                let n = d.length();
                Some((a / n / k, b / n / k))
            }
        }
    }

    /// How much solid angle a unit of image-plane area spans in unit direction `d`
    /// (sr per plane area, the height spanning [-1, 1]).
    #[inline]
    fn solid_angle_density(&self, d: DVec3) -> f64 {
        let k = self.scale;
        let c = d.dot(self.forward).clamp(-1.0, 1.0);
        match self.desc.projection {
            Projection::Perspective => k * k * c * c * c,
            Projection::AngularFisheye => {
                let theta = c.acos();
                if theta < 1e-6 {
                    k * k
                } else {
                    k * k * theta.sin() / theta
                }
            }
            Projection::Hemispherical => k * k / c.max(1e-12),
        }
    }

    /// The pixel that sees point `p` (local scene units) and that pixel's solid angle in
    /// the direction of `p` as two factors whose product it is (sr: the projection's
    /// density there, and the pixel's plane area; a pinhole's: cos³ θ and its area at unit
    /// distance), or None when `p` is outside the image (or behind a perspective camera).
    #[inline]
    pub fn project(&self, p: DVec3) -> Option<(u32, f64, f64)> {
        if self.is_perspective() {
            // As the pinhole camera always computed it, to the bit.
            let z = self.depth(p);
            if z <= 0.0 {
                return None;
            }
            let (x, y) = self.image_point(p);
            if !(x >= 0.0 && y >= 0.0 && x < self.desc.width as f64 && y < self.desc.height as f64)
            {
                return None;
            }
            let pixel = y as u32 * self.desc.width + x as u32;
            let cos = z / (p - self.origin).length();
            let a = 2.0 * self.scale / self.desc.height as f64;
            return Some((pixel, cos.powi(3), a * a));
        }
        let d = (p - self.origin).try_normalize()?;
        let (sx, sy) = self.plane_point(d)?;
        let (w, h) = (self.desc.width as f64, self.desc.height as f64);
        let x = (sx / self.aspect + 1.0) * 0.5 * w;
        let y = (1.0 - sy) * 0.5 * h;
        if !(x >= 0.0 && y >= 0.0 && x < w && y < h) {
            return None;
        }
        if self.desc.projection == Projection::Hemispherical
            && (sx * sx + sy * sy) * self.scale * self.scale > 1.0
        {
            return None;
        }
        let pixel = y as u32 * self.desc.width + x as u32;
        Some((pixel, self.solid_angle_density(d), self.plane_pixel_area()))
    }

    /// The direction through pixel (x, y)'s centre and the pixel's solid angle there, or
    /// None where a fisheye's image sees nothing.
    pub fn pixel_direction(&self, x: u32, y: u32) -> Option<(DVec3, f64)> {
        let d = self.ray(x, y, 0.5, 0.5)?;
        Some((d, self.plane_pixel_area() * self.solid_angle_density(d)))
    }

    /// A pixel's area on the image plane (the height spanning [-1, 1]).
    fn plane_pixel_area(&self) -> f64 {
        let a = 2.0 / self.desc.height as f64;
        a * a
    }

    /// How far in front of the eye point `p` (local scene units) lies, along the viewing
    /// direction.
    #[inline]
    pub fn depth(&self, p: DVec3) -> f64 {
        (p - self.origin).dot(self.forward)
    }

    /// Where point `p` (in front of the eye: `depth(p) > 0`) falls on a perspective
    /// camera's image, in pixel coordinates: x to the right, y down, pixel (i, j) the unit
    /// square from (i, j); the inverse of `ray` (`ray(i, j, jx, jy)` passes through
    /// (i + jx, j + jy)). Perspective cameras only (the emitters' coverage).
    #[inline]
    pub fn image_point(&self, p: DVec3) -> (f64, f64) {
        debug_assert!(self.is_perspective());
        let d = p - self.origin;
        let z = d.dot(self.forward);
        let sx = d.dot(self.right) / z / (self.scale * self.aspect);
        let sy = d.dot(self.up) / z / self.scale;
        (
            (sx + 1.0) * 0.5 * self.desc.width as f64,
            (1.0 - sy) * 0.5 * self.desc.height as f64,
        )
    }

    /// Angular size of a pixel at the image centre (radians): a surface at distance d shows
    /// a pixel footprint of about d times this.
    pub fn pixel_angle(&self) -> f64 {
        2.0 * self.scale / self.desc.height as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `project` is the inverse of `ray`: a point along a pixel's ray projects back to that
    /// pixel, with the pixel's solid angle there (a perspective pixel: its plane area
    /// times cos³ of its ray to the axis).
    #[test]
    fn project_inverts_ray() {
        for projection in [
            Projection::Perspective,
            Projection::AngularFisheye,
            Projection::Hemispherical,
        ] {
            let cam = Camera::new(
                &CameraDesc {
                    position: [1.0, 2.0, 3.0],
                    direction: [0.3, -1.0, 0.2],
                    up: [0.0, 0.0, 1.0],
                    fov_y_deg: 70.0,
                    width: 40,
                    height: 30,
                    projection,
                },
                DVec3::new(0.5, 0.0, 0.0),
            )
            .unwrap();
            for (x, y) in [(0, 0), (39, 29), (17, 5), (3, 28)] {
                let d = cam.ray(x, y, 0.25, 0.75).unwrap();
                let (p, f, a) = cam.project(cam.origin + 7.0 * d).unwrap();
                let omega = f * a;
                assert_eq!(p, y * 40 + x, "{projection:?}");
                if projection == Projection::Perspective {
                    let want = (2.0 * cam.scale / 30.0).powi(2) * d.dot(cam.forward).powi(3);
                    assert!((omega / want - 1.0).abs() < 1e-12);
                }
            }
            assert!(cam.project(cam.origin - cam.forward).is_none());
            assert!(cam
                .project(cam.origin + cam.forward + 10.0 * cam.up)
                .is_none());
        }
    }

    fn fisheye(projection: Projection, fov: f64, size: u32) -> Camera {
        Camera::new(
            &CameraDesc {
                position: [0.0, 0.0, 0.0],
                direction: [0.0, 1.0, 0.0],
                up: [0.0, 0.0, 1.0],
                fov_y_deg: fov,
                width: size,
                height: size,
                projection,
            },
            DVec3::ZERO,
        )
        .unwrap()
    }

    /// A 180° fisheye's pixels tile the front hemisphere: their solid angles sum to 2π
    /// and their projected solid angles to π (an illuminance of πL from luminance L), and
    /// each pixel's stated solid angle is the one its four corner rays enclose.
    #[test]
    fn fisheye_pixels_tile_the_hemisphere() {
        for projection in [Projection::AngularFisheye, Projection::Hemispherical] {
            let cam = fisheye(projection, 180.0, 400);
            let (mut omega, mut proj) = (0.0, 0.0);
            for y in 0..400 {
                for x in 0..400 {
                    if let Some((d, w)) = cam.pixel_direction(x, y) {
                        if d.dot(cam.forward) > 0.0 {
                            omega += w;
                            proj += w * d.dot(cam.forward);
                        }
                    }
                }
            }
            // The circle's rim is cut by square pixels: a few tenths of a percent.
            assert!(
                (omega / (2.0 * PI) - 1.0).abs() < 0.01,
                "{projection:?}: {omega}"
            );
            assert!((proj / PI - 1.0).abs() < 0.005, "{projection:?}: {proj}");
            // A pixel's solid angle against its corners' spherical quadrilateral.
            for (x, y) in [(200, 200), (300, 120), (50, 210), (390, 200)] {
                let c = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
                    .map(|(jx, jy)| cam.ray(x, y, jx, jy).unwrap());
                let tri = |a: DVec3, b: DVec3, c: DVec3| {
                    2.0 * a
                        .dot(b.cross(c))
                        .abs()
                        .atan2(1.0 + a.dot(b) + b.dot(c) + c.dot(a))
                };
                let quad = tri(c[0], c[1], c[2]) + tri(c[0], c[2], c[3]);
                let (_, w) = cam.pixel_direction(x, y).unwrap();
                assert!(
                    (w / quad - 1.0).abs() < 0.02,
                    "{projection:?} ({x}, {y}): {w} vs {quad}"
                );
            }
        }
    }

    /// What each fisheye shows where: the angular one's radius grows with the angle off
    /// the axis, the hemispherical one's with its sine; outside the circle nothing.
    #[test]
    fn fisheyes_place_directions_by_their_rules() {
        let a = fisheye(Projection::AngularFisheye, 180.0, 100);
        // 45° up: a quarter of the height above the centre.
        let d = a.ray(50, 25, 0.0, 0.0).unwrap();
        assert!((d.z - (PI / 4.0).sin()).abs() < 1e-12 && (d.y - (PI / 4.0).cos()).abs() < 1e-12);
        // The corner of a 180° angular fisheye looks 127° off the axis, behind the eye.
        let corner = a.ray(0, 0, 0.0, 0.0).unwrap();
        assert!((corner.y.acos().to_degrees() - 90.0 * 2f64.sqrt()).abs() < 1e-9);
        // A 360° angular fisheye's corners are beyond 180°: black.
        assert!(fisheye(Projection::AngularFisheye, 360.0, 100)
            .ray(0, 0, 0.0, 0.0)
            .is_none());
        let h = fisheye(Projection::Hemispherical, 180.0, 100);
        let d = h.ray(50, 25, 0.0, 0.0).unwrap();
        assert!((d.z - 0.5).abs() < 1e-12);
        assert!(h.ray(0, 0, 0.0, 0.0).is_none());
        assert!(h.project(DVec3::new(0.0, -1.0, 0.1)).is_none());
        // Behind the eye an angular fisheye of 360° still sees.
        let full = fisheye(Projection::AngularFisheye, 360.0, 100);
        let (p, _, _) = full.project(DVec3::new(0.0, -1.0, 0.5)).unwrap();
        let (px, py) = (p % 100, p / 100);
        let back = full.ray(px, py, 0.5, 0.5).unwrap();
        assert!(back.dot(DVec3::new(0.0, -1.0, 0.5).normalize()) > 0.999);
    }

    fn desc() -> CameraDesc {
        CameraDesc {
            position: [0.0, 0.0, 5.0],
            direction: [0.0, 0.0, -1.0],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 90.0,
            width: 200,
            height: 100,
            projection: Projection::Perspective,
        }
    }

    #[test]
    fn rays_span_the_field_of_view() {
        let c = Camera::new(&desc(), DVec3::ZERO).unwrap();
        let centre = c.ray(100, 50, 0.0, 0.0).unwrap();
        assert!((centre - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12);
        // Top edge: 45° up; left edge: atan(2) to the left (aspect 2).
        let top = c.ray(100, 0, 0.0, 0.0).unwrap();
        assert!((top.y / -top.z - 1.0).abs() < 1e-12);
        let left = c.ray(0, 50, 0.0, 0.0).unwrap();
        assert!((left.x / left.z - 2.0).abs() < 1e-12);
    }

    #[test]
    fn huge_and_tiny_direction_vectors_are_directions() {
        let mut d = desc();
        d.direction = [0.0, 0.0, -1e300];
        d.up = [0.0, 1e-300, 0.0];
        let c = Camera::new(&d, DVec3::ZERO).unwrap();
        let u = Camera::new(&desc(), DVec3::ZERO).unwrap();
        assert!((c.ray(3, 4, 0.5, 0.5).unwrap() - u.ray(3, 4, 0.5, 0.5).unwrap()).length() < 1e-15);
    }

    #[test]
    fn bad_cameras_are_refused() {
        let mut d = desc();
        d.up = [0.0, 0.0, 3.0];
        assert!(Camera::new(&d, DVec3::ZERO).is_err());
        let mut d = desc();
        d.fov_y_deg = 180.0;
        assert!(Camera::new(&d, DVec3::ZERO).is_err());
        d.projection = Projection::Hemispherical;
        assert!(Camera::new(&d, DVec3::ZERO).is_ok());
        d.fov_y_deg = 181.0;
        assert!(Camera::new(&d, DVec3::ZERO).is_err());
        d.projection = Projection::AngularFisheye;
        assert!(Camera::new(&d, DVec3::ZERO).is_ok());
        d.fov_y_deg = 361.0;
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

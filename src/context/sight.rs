//! What an observer at a point of the scene sees of it (`crate::glare`): the scene as
//! described, and straight lines through its prepared geometry.

use super::Context;
use crate::accel::Accel;
use crate::error::Result;
use crate::photometry::BandPhotometry;
use crate::scene::{PreparedScene, Scene};
use glam::DVec3;

/// The scene and its BVH, for lines of sight in world (scene-unit) coordinates. Sensors
/// are not in it: they block nothing.
pub struct Sight<'a> {
    pub scene: &'a Scene,
    prepared: &'a PreparedScene,
    accel: &'a Accel,
    /// The bands' photometric weights (`BandPhotometry::luminous`: lm of W per band).
    pub photometry: &'a BandPhotometry,
}

/// The first surface a line of sight meets.
#[derive(Clone, Copy, Debug)]
pub struct SightHit {
    pub mesh: u32,
    /// Whether the line meets the triangle's front (the side its normal points to).
    pub front: bool,
}

impl Sight<'_> {
    /// Whether nothing stands between world points `a` and `b` (each end left out by the
    /// scene's ray offset there, so a light on a surface is not hidden by it).
    pub fn clear(&self, a: DVec3, b: DVec3) -> bool {
        let o = self.prepared.origin;
        let (a, b) = (a - o, b - o);
        let d = b - a;
        let len = d.length();
        if len <= 0.0 {
            return true;
        }
        let dir = d / len;
        let (ea, eb) = (
            2.0 * self.prepared.offset_at(a),
            2.0 * self.prepared.offset_at(b),
        );
        let reach = len - ea - eb;
        reach <= 0.0 || !self.accel.occluded(a + dir * ea, dir, reach)
    }

    /// The first surface along the ray from world point `from` in unit direction `dir`.
    pub fn first_hit(&self, from: DVec3, dir: DVec3) -> Option<SightHit> {
        let a = from - self.prepared.origin;
        let h = self.accel.intersect(a, dir)?;
        let m = &self.prepared.meshes[h.mesh as usize];
        let n = m.normals[h.prim as usize].as_dvec3();
        Some(SightHit {
            mesh: h.mesh,
            front: n.dot(dir) < 0.0,
        })
    }
}

impl Context {
    /// Lines of sight through the scene (its BVH built on first use after a change).
    pub(crate) fn sight(&mut self) -> Result<Sight<'_>> {
        self.prepare_geometry()?;
        let p = self.prepared.as_ref().expect("prepared above");
        Ok(Sight {
            scene: &self.scene,
            prepared: &p.scene,
            accel: &p.accel,
            photometry: &self.photometry,
        })
    }
}

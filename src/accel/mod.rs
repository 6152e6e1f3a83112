//! Every Embree call of the library: device, scene build, and `intersect`.
//!
//! `embree4-sys` 0.0.12 carries the Embree 4.2 headers, whose `RTCHit` lacks the
//! `instPrimID` field that Embree 4.3+ (built with instance arrays, like the 4.4 library we
//! provision) writes. Passing the crate's 80-byte `RTCRayHit` would let the library write 4
//! bytes past it. We therefore hand Embree our own `RayHit` with the 4.3+ layout and
//! spare room after it (checked by a test with a guard word), pass NULL for the optional
//! intersect arguments, and check the library's version at start-up.

use crate::error::{Error, ImapStatus, Result};
use crate::scene::PreparedMesh;
use embree4_sys as rtc;
use glam::DVec3;
use std::ffi::{c_char, c_void, CStr};
use std::sync::Mutex;

/// Embree's `RTCRay`.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
struct Ray {
    org: [f32; 3],
    tnear: f32,
    dir: [f32; 3],
    time: f32,
    tfar: f32,
    mask: u32,
    id: u32,
    flags: u32,
}

/// Embree 4.3+'s `RTCHit` (with `instPrimID`, one instance level).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
struct HitRecord {
    ng: [f32; 3],
    u: f32,
    v: f32,
    prim_id: u32,
    geom_id: u32,
    inst_id: [u32; 1],
    inst_prim_id: [u32; 1],
}

/// `RTCRayHit` with the 4.3+ layout, aligned to 16 and followed by a guard that a test
/// checks is never written.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug)]
struct RayHit {
    ray: Ray,
    hit: HitRecord,
    guard: [u32; 3],
}

const INVALID_ID: u32 = u32::MAX;
const GUARD: u32 = 0xDEAD_BEEF;

/// A ray–triangle hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub mesh: u32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
    pub t: f64,
}

struct ErrorSink {
    last: Mutex<(String, bool)>,
}

unsafe extern "C" fn on_error(user: *mut c_void, code: rtc::RTCError, msg: *const c_char) {
    // SAFETY: `user` is the `ErrorSink` owned by the `Device`, alive as long as the device;
    // `msg` is NULL or a NUL-terminated string valid during the callback.
    let (sink, text) = unsafe {
        let text = if msg.is_null() {
            String::new()
        } else {
            CStr::from_ptr(msg).to_string_lossy().into_owned()
        };
        (&*(user as *const ErrorSink), text)
    };
    if let Ok(mut last) = sink.last.lock() {
        *last = (
            format!("{code:?}: {text}"),
            code == rtc::RTCError::OUT_OF_MEMORY,
        );
    }
}

/// An Embree device and its error channel.
pub struct Device {
    raw: rtc::RTCDevice,
    errors: Box<ErrorSink>,
    version: i64,
}

// SAFETY: Embree devices may be used from any thread (Embree API: all functions are
// thread-safe except where a scene or geometry is being modified, which we do only from
// the thread that owns the context).
unsafe impl Send for Device {}
// SAFETY: as above; shared access only reads.
unsafe impl Sync for Device {}

impl Device {
    pub fn new() -> Result<Self> {
        // SAFETY: a NULL config selects Embree's defaults.
        let raw = unsafe { rtc::rtcNewDevice(std::ptr::null()) };
        if raw.is_null() {
            // SAFETY: rtcGetDeviceError accepts NULL and reports the creation error.
            let code = unsafe { rtc::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(Error::new(
                ImapStatus::ImapErrEmbree,
                format!("rtcNewDevice failed: {code:?}"),
            ));
        }
        let errors = Box::new(ErrorSink {
            last: Mutex::new((String::new(), false)),
        });
        // SAFETY: `raw` is a live device; the sink outlives it (released in Drop first).
        let version = unsafe {
            rtc::rtcSetDeviceErrorFunction(
                raw,
                Some(on_error),
                &*errors as *const ErrorSink as *mut c_void,
            );
            rtc::rtcGetDeviceProperty(raw, rtc::RTCDeviceProperty::VERSION) as i64
        };
        let device = Device {
            raw,
            errors,
            version,
        };
        if version < 40000 {
            return Err(Error::new(
                ImapStatus::ImapErrEmbree,
                format!("Embree {version} is too old: libimap needs Embree 4"),
            ));
        }
        Ok(device)
    }

    /// Embree's version as major·10000 + minor·100 + patch.
    pub fn version(&self) -> i64 {
        self.version
    }

    fn error(&self, what: &str) -> Error {
        let (msg, oom) = self
            .errors
            .last
            .lock()
            .map(|s| s.clone())
            .unwrap_or_default();
        let status = if oom {
            ImapStatus::ImapErrOutOfMemory
        } else {
            ImapStatus::ImapErrEmbree
        };
        Error::new(status, format!("{what} failed: {msg}"))
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: the device is live; after release no callback uses the sink.
        unsafe { rtc::rtcReleaseDevice(self.raw) };
    }
}

/// A committed Embree scene of triangle meshes; geometry id = mesh index.
pub struct Accel {
    scene: rtc::RTCScene,
    /// The box around its vertices (lo, hi), for `crossings` to pass by a segment that
    /// misses it without a query (a photon's segments inside a light guide never come near
    /// the sensor over it).
    bounds: [DVec3; 2],
}

// SAFETY: a committed Embree scene is immutable and `rtcIntersect1` may be called on it from
// any number of threads at once.
unsafe impl Send for Accel {}
// SAFETY: as above.
unsafe impl Sync for Accel {}

impl Accel {
    /// Builds the BVH over `meshes` (vertices already recentred).
    /// The BVH of the meshes that are not sensors (mesh ids kept as geometry ids).
    pub fn build(device: &Device, meshes: &[PreparedMesh]) -> Result<Self> {
        Self::build_where(device, meshes, |m| !m.sensor)
    }

    /// The BVH of the sensor meshes, or None without any.
    pub fn build_sensors(device: &Device, meshes: &[PreparedMesh]) -> Result<Option<Self>> {
        if meshes.iter().any(|m| m.sensor) {
            Self::build_where(device, meshes, |m| m.sensor).map(Some)
        } else {
            Ok(None)
        }
    }

    fn build_where(
        device: &Device,
        meshes: &[PreparedMesh],
        keep: impl Fn(&PreparedMesh) -> bool,
    ) -> Result<Self> {
        // SAFETY: all handles below come from the live `device`; buffers returned by
        // rtcSetNewGeometryBuffer have exactly the requested element count and stride and
        // are written before commit.
        unsafe {
            let scene = rtc::rtcNewScene(device.raw);
            if scene.is_null() {
                return Err(device.error("rtcNewScene"));
            }
            let mut accel = Accel {
                scene,
                bounds: [DVec3::INFINITY, DVec3::NEG_INFINITY],
            };
            rtc::rtcSetSceneFlags(scene, rtc::RTCSceneFlags::ROBUST);
            rtc::rtcSetSceneBuildQuality(scene, rtc::RTCBuildQuality::MEDIUM);
            for (id, m) in meshes.iter().enumerate().filter(|(_, m)| keep(m)) {
                let geom = rtc::rtcNewGeometry(device.raw, rtc::RTCGeometryType::TRIANGLE);
                if geom.is_null() {
                    return Err(device.error("rtcNewGeometry"));
                }
                let vb = rtc::rtcSetNewGeometryBuffer(
                    geom,
                    rtc::RTCBufferType::VERTEX,
                    0,
                    rtc::RTCFormat::FLOAT3,
                    12,
                    m.vertices.len(),
                ) as *mut f32;
                let ib = rtc::rtcSetNewGeometryBuffer(
                    geom,
                    rtc::RTCBufferType::INDEX,
                    0,
                    rtc::RTCFormat::UINT3,
                    12,
                    m.triangles.len(),
                ) as *mut u32;
                if vb.is_null() || ib.is_null() {
                    rtc::rtcReleaseGeometry(geom);
                    return Err(device.error("allocating geometry buffers"));
                }
                let vs = std::slice::from_raw_parts_mut(vb, 3 * m.vertices.len());
                for (d, v) in vs.chunks_exact_mut(3).zip(&m.vertices) {
                    d.copy_from_slice(&v.to_array());
                    accel.bounds[0] = accel.bounds[0].min(v.as_dvec3());
                    accel.bounds[1] = accel.bounds[1].max(v.as_dvec3());
                }
                let is = std::slice::from_raw_parts_mut(ib, 3 * m.triangles.len());
                for (d, t) in is.chunks_exact_mut(3).zip(&m.triangles) {
                    d.copy_from_slice(t);
                }
                rtc::rtcCommitGeometry(geom);
                rtc::rtcAttachGeometryByID(scene, geom, id as u32);
                rtc::rtcReleaseGeometry(geom);
            }
            rtc::rtcCommitScene(scene);
            if rtc::rtcGetDeviceError(device.raw) != rtc::RTCError::NONE {
                return Err(device.error("building the BVH (rtcCommitScene)"));
            }
            Ok(accel)
        }
    }

    #[inline]
    fn trace_range(&self, org: DVec3, dir: DVec3, tnear: f32, tfar: f32) -> RayHit {
        let mut rh = RayHit {
            ray: Ray {
                org: org.as_vec3().to_array(),
                tnear,
                dir: dir.as_vec3().to_array(),
                time: 0.0,
                tfar,
                mask: u32::MAX,
                id: 0,
                flags: 0,
            },
            hit: HitRecord {
                ng: [0.0; 3],
                u: 0.0,
                v: 0.0,
                prim_id: INVALID_ID,
                geom_id: INVALID_ID,
                inst_id: [INVALID_ID],
                inst_prim_id: [INVALID_ID],
            },
            guard: [GUARD; 3],
        };
        // SAFETY: the scene is committed; `rh` has the layout Embree 4.0–4.4 writes (with
        // room to spare), is 16-byte aligned, and NULL arguments select the defaults.
        unsafe {
            rtc::rtcIntersect1(
                self.scene,
                &mut rh as *mut RayHit as *mut rtc::RTCRayHit,
                std::ptr::null_mut(),
            )
        };
        rh
    }

    /// The closest hit along `org + t·dir`, t in (0, ∞), in local scene units.
    #[inline]
    pub fn intersect(&self, org: DVec3, dir: DVec3) -> Option<Hit> {
        self.intersect_within(org, dir, f64::INFINITY)
    }

    /// The nearest hit along `org + t·dir` with t in [0, `t_max`] (the traversal leaves out
    /// everything farther: a short segment costs less than a whole ray).
    #[inline]
    pub fn intersect_within(&self, org: DVec3, dir: DVec3, t_max: f64) -> Option<Hit> {
        let rh = self.trace_range(org, dir, 0.0, t_max as f32);
        debug_assert_eq!(rh.guard, [GUARD; 3], "Embree wrote past the hit record");
        (rh.hit.geom_id != INVALID_ID).then_some(Hit {
            mesh: rh.hit.geom_id,
            prim: rh.hit.prim_id,
            u: rh.hit.u,
            v: rh.hit.v,
            t: rh.ray.tfar as f64,
        })
    }

    /// Every hit along `org + t·dir` with t in [0, `t_max`], nearest first, handed to `f`
    /// (sensors: a few crossings per segment, each found by one more query starting just
    /// past the last).
    #[inline]
    pub fn crossings(&self, org: DVec3, dir: DVec3, t_max: f64, mut f: impl FnMut(Hit)) {
        if t_max <= 0.0 || !self.segment_meets_bounds(org, dir, t_max) {
            return;
        }
        let tfar = t_max as f32;
        let mut tnear = 0.0f32;
        // At most this many crossings of one segment (a ray grazing a fine sensor mesh).
        for _ in 0..4096 {
            let rh = self.trace_range(org, dir, tnear, tfar);
            if rh.hit.geom_id == INVALID_ID {
                return;
            }
            let t = rh.ray.tfar;
            f(Hit {
                mesh: rh.hit.geom_id,
                prim: rh.hit.prim_id,
                u: rh.hit.u,
                v: rh.hit.v,
                t: t as f64,
            });
            // Just past this crossing: 16 f32 steps of t (2e-6 of it), so one surface is
            // counted once.
            tnear = f32::from_bits(t.max(f32::MIN_POSITIVE).to_bits() + 16);
            if tnear > tfar {
                return;
            }
        }
    }

    /// Whether the segment `org + t·dir`, t in [0, `t_max`], may meet the box around the
    /// vertices (slabs, with the box widened by a margin far above f32 rounding: a false
    /// yes only costs a query).
    #[inline]
    fn segment_meets_bounds(&self, org: DVec3, dir: DVec3, t_max: f64) -> bool {
        let [lo, hi] = self.bounds;
        let pad = 1e-4 * (hi - lo).max_element().max(1e-30) + 1e-6 * org.abs().max_element();
        let (lo, hi) = (lo - DVec3::splat(pad), hi + DVec3::splat(pad));
        let (mut t0, mut t1) = (0.0f64, t_max);
        for k in 0..3 {
            let (o, d) = (org[k], dir[k]);
            if d == 0.0 {
                if o < lo[k] || o > hi[k] {
                    return false;
                }
                continue;
            }
            let (a, b) = ((lo[k] - o) / d, (hi[k] - o) / d);
            let (a, b) = if a < b { (a, b) } else { (b, a) };
            t0 = t0.max(a);
            t1 = t1.min(b);
            if t0 > t1 {
                return false;
            }
        }
        true
    }

    /// Whether anything blocks the segment `org + t·dir`, t in (0, `t_max`) (shadow rays).
    #[inline]
    pub fn occluded(&self, org: DVec3, dir: DVec3, t_max: f64) -> bool {
        #[repr(C, align(16))]
        struct AlignedRay(Ray);
        let mut r = AlignedRay(Ray {
            org: org.as_vec3().to_array(),
            tnear: 0.0,
            dir: dir.as_vec3().to_array(),
            time: 0.0,
            tfar: t_max as f32,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        });
        // SAFETY: the scene is committed; `Ray` has the layout of `RTCRay` (checked by
        // `layout_matches_embree_4_3`), is 16-byte aligned, and a NULL argument selects the
        // defaults. Embree sets tfar to -inf when it finds a hit.
        unsafe {
            rtc::rtcOccluded1(
                self.scene,
                &mut r.0 as *mut Ray as *mut rtc::RTCRay,
                std::ptr::null_mut(),
            )
        };
        r.0.tfar < 0.0
    }

    /// Traces one ray and returns the guard words after the hit record (test support).
    #[cfg(test)]
    pub fn guard_after_intersect(&self, org: DVec3, dir: DVec3) -> ([u32; 3], bool) {
        let rh = self.trace_range(org, dir, 0.0, f32::INFINITY);
        (rh.guard, rh.hit.geom_id != INVALID_ID)
    }
}

impl Drop for Accel {
    fn drop(&mut self) {
        // SAFETY: the scene is live and no intersect call is running (runs borrow `self`).
        unsafe { rtc::rtcReleaseScene(self.scene) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Bands, Light, Mesh, MeshDesc, PreparedScene, Scene};

    #[test]
    fn layout_matches_embree_4_3() {
        assert_eq!(std::mem::size_of::<Ray>(), 48);
        assert_eq!(std::mem::size_of::<HitRecord>(), 40 - 4);
        assert_eq!(std::mem::offset_of!(RayHit, hit), 48);
        assert_eq!(std::mem::align_of::<RayHit>(), 16);
    }

    #[test]
    fn embree_never_writes_past_the_hit_record() {
        let device = Device::new().unwrap();
        assert!(device.version() >= 40000);
        let mut scene = Scene::new(Bands::rgb(), 1.0);
        scene
            .materials
            .push(crate::scene::Material::new(&Default::default(), &scene.bands).unwrap());
        let desc = MeshDesc::new(&[-1., -1., 0., 1., -1., 0., 0., 1., 0.], &[0, 1, 2], 0);
        scene
            .meshes
            .push(Mesh::new(&desc, 1, &scene.bands).unwrap());
        scene
            .lights
            .push(Light::point([0.0, 0.0, 1.0], &[1.0], &scene.bands).unwrap());
        let prepared = PreparedScene::new(&scene, &[1.0], true).unwrap();
        let accel = Accel::build(&device, &prepared.meshes).unwrap();
        let o = DVec3::new(0.0, 0.0, 1.0) - prepared.origin;
        let (guard, hit) = accel.guard_after_intersect(o, DVec3::new(0.0, 0.0, -1.0));
        assert!(hit);
        assert_eq!(guard, [GUARD; 3]);
        let h = accel.intersect(o, DVec3::new(0.0, 0.0, -1.0)).unwrap();
        assert_eq!((h.mesh, h.prim), (0, 0));
        assert!((h.t - 1.0).abs() < 1e-6);
        assert!(accel.intersect(o, DVec3::new(0.0, 0.0, 1.0)).is_none());
        let down = DVec3::new(0.0, 0.0, -1.0);
        assert!(accel.occluded(o, down, 1.5));
        assert!(!accel.occluded(o, down, 0.9));
        assert!(!accel.occluded(o, DVec3::new(0.0, 0.0, 1.0), 10.0));
    }
}

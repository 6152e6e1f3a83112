//! The host's own BSDF: a surface whose evaluation, sampling and density the caller
//! computes (a C callback material, or a Rust implementation of `HostBsdf`), so a package
//! keeps its measured models and gets the library's estimators.
//!
//! Directions are in the local frame at the hit: z the normal on the side light arrives
//! from (`wo.z > 0`), x the material's tangent projected onto the surface (a fixed one
//! without a tangent), y = z × x. `wo` points back to where the light came from, `wi`
//! where it goes on (`wi.z < 0`: through to the other side); `front` says whether light
//! arrives on the side the mesh's normals point to. `f` is in 1/sr per band (the photon's
//! kernel: the light arriving from `wo` leaving along `wi`).
//!
//! Failures never panic or abort: a call that reports one, returns a NaN, infinite or
//! negative value, or a direction that is not a unit vector on an allowed side is recorded
//! on the surface (the first message and a count), the event ends the photon or path there,
//! and the run (or render) returns `IMAP_ERR_HOST_BSDF` naming the material. Energy gain is
//! checked once, when the material is added, by the host's own sampling.

use crate::error::{bail, Result};
use crate::sampling::PhotonRng;
use glam::DVec3;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// A BSDF the caller computes. Called from many threads at once.
pub trait HostBsdf: Send + Sync {
    /// f(wo → wi) per band into `f` (1/sr).
    fn eval(
        &self,
        wo: [f64; 3],
        wi: [f64; 3],
        front: bool,
        f: &mut [f64],
    ) -> std::result::Result<(), String>;
    /// A direction for light from `wo` drawn from three uniform numbers, with its density
    /// per solid angle; None when the surface sends nothing on.
    fn sample(
        &self,
        wo: [f64; 3],
        u: [f64; 3],
        front: bool,
    ) -> std::result::Result<Option<([f64; 3], f64)>, String>;
    /// The density per solid angle with which `sample` draws `wi` from `wo`.
    fn pdf(&self, wo: [f64; 3], wi: [f64; 3], front: bool) -> std::result::Result<f64, String>;
    /// Whether light can leave on the other side.
    fn transmits(&self) -> bool;
    /// The largest value f takes (1/sr), or 0 when unknown: lobes at most
    /// `TABLE_GATHER_PEAK` are gathered at, sharper or unknown ones are the photons'.
    fn peak(&self) -> f64;
}

/// A shared handle on a host BSDF, compared by identity.
#[derive(Clone)]
pub struct HostBsdfRef(pub Arc<dyn HostBsdf>);

impl std::fmt::Debug for HostBsdfRef {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "HostBsdf@{:p}", Arc::as_ptr(&self.0))
    }
}

impl PartialEq for HostBsdfRef {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// A host BSDF in a scene, with the failures its calls reported.
pub struct HostSurface {
    bsdf: Arc<dyn HostBsdf>,
    failures: AtomicU64,
    first: Mutex<Option<String>>,
    /// What the check at adding found: the largest directional albedo, and the worst
    /// |f(a, b) − f(b, a)| over their mean among its reflected draws.
    pub check: crate::scene::TableCheck,
}

// What states fingerprint (`context::state`): what the check at adding measured, which
// the same BSDF gives in any process (its callbacks' addresses do not), and never the
// failure count.
impl std::fmt::Debug for HostSurface {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HostSurface")
            .field("check", &self.check)
            .field("peak", &self.peak())
            .field("transmits", &self.transmits())
            .finish()
    }
}

/// Incident directions the check at adding draws from: cosines × azimuths.
const CHECK_MU: [f64; 4] = [1.0, 0.7, 0.4, 0.15];
const CHECK_PHI_DEG: [f64; 3] = [0.0, 100.0, 230.0];
/// Draws per checked direction.
const CHECK_DRAWS: u64 = 512;

impl HostSurface {
    /// Wraps `bsdf` for `bands` bands after checking it: at 12 incident directions on each
    /// side, 512 of its own draws each, every value finite and ≥ 0, each draw's density as
    /// `pdf` gives it (to 1e-3), and the directional albedo (mean f cos / pdf) at most 1.05.
    pub fn new(bsdf: Arc<dyn HostBsdf>, bands: usize) -> Result<HostSurface> {
        let s = HostSurface {
            bsdf,
            failures: AtomicU64::new(0),
            first: Mutex::new(None),
            check: Default::default(),
        };
        let mut f = vec![0.0; bands];
        let mut back = vec![0.0; bands];
        let mut worst = 0.0f64;
        let mut worst_recip = 0.0f64;
        let mut rng = PhotonRng::new(0x5eed, 0);
        for front in [true, false] {
            for mu in CHECK_MU {
                for phi in CHECK_PHI_DEG {
                    let (sin, p) = ((1.0 - mu * mu).sqrt(), phi.to_radians());
                    let wo = DVec3::new(sin * p.cos(), sin * p.sin(), mu);
                    let at = format!(
                        "light arriving at θ {:.1}° φ {phi}° on the {} side",
                        mu.acos().to_degrees(),
                        if front { "front" } else { "back" }
                    );
                    let mut sum = vec![0.0; bands];
                    for _ in 0..CHECK_DRAWS {
                        let u = [rng.uniform(), rng.uniform(), rng.uniform()];
                        let Some((wi, pdf)) = s.checked_sample(wo, u, front).map_err(|m| {
                            crate::error::Error::new(
                                crate::error::ImapStatus::ImapErrBadMaterial,
                                format!("host BSDF, {at}: {m}"),
                            )
                        })?
                        else {
                            continue;
                        };
                        let check = |r: std::result::Result<(), String>| {
                            r.map_err(|m| {
                                crate::error::Error::new(
                                    crate::error::ImapStatus::ImapErrBadMaterial,
                                    format!("host BSDF, {at}: {m}"),
                                )
                            })
                        };
                        check(s.checked_eval(wo, wi, front, &mut f))?;
                        let again = s.bsdf.pdf(wo.to_array(), wi.to_array(), front);
                        let ok = matches!(again, Ok(q) if (q - pdf).abs() <= 1e-3 * pdf);
                        if !ok {
                            bail!(
                                ImapErrBadMaterial,
                                "host BSDF, {at}: sample gave the direction {wi:?} density {pdf} but pdf gives {again:?}"
                            );
                        }
                        for (a, v) in sum.iter_mut().zip(&f) {
                            *a += v * wi.z.abs() / pdf;
                        }
                        if wi.z > 0.0 {
                            check(s.checked_eval(wi, wo, front, &mut back))?;
                            for (x, y) in f.iter().zip(&back) {
                                if x + y > 1e-9 {
                                    worst_recip = worst_recip.max((x - y).abs() / (0.5 * (x + y)));
                                }
                            }
                        }
                    }
                    for (b, a) in sum.iter().enumerate() {
                        let albedo = a / CHECK_DRAWS as f64;
                        worst = worst.max(albedo);
                        if albedo > 1.05 {
                            bail!(
                                ImapErrBadMaterial,
                                "host BSDF, {at}: it sends on {albedo:.3} of the light in band {b} (its own sampling, {CHECK_DRAWS} draws): energy would be created"
                            );
                        }
                    }
                }
            }
        }
        Ok(HostSurface {
            check: crate::scene::TableCheck {
                worst_reciprocity: worst_recip,
                worst_albedo: worst,
            },
            ..s
        })
    }

    /// Notes a failure (the first message is kept).
    fn fail(&self, message: String) {
        if self.failures.fetch_add(1, Ordering::Relaxed) == 0 {
            if let Ok(mut m) = self.first.lock() {
                m.get_or_insert(message);
            }
        }
    }

    /// How many calls failed, and the first failure's message.
    pub fn failures(&self) -> Option<(u64, String)> {
        let n = self.failures.load(Ordering::Relaxed);
        (n > 0).then(|| {
            let m = self.first.lock().ok().and_then(|m| m.clone());
            (n, m.unwrap_or_default())
        })
    }

    /// Whether any call failed.
    #[inline]
    pub fn failed(&self) -> bool {
        self.failures.load(Ordering::Relaxed) > 0
    }

    /// Forgets failures (a new run starts clean).
    pub fn clear(&self) {
        self.failures.store(0, Ordering::Relaxed);
        if let Ok(mut m) = self.first.lock() {
            *m = None;
        }
    }

    #[inline]
    pub fn transmits(&self) -> bool {
        self.bsdf.transmits()
    }

    #[inline]
    pub fn peak(&self) -> f64 {
        self.bsdf.peak()
    }

    fn checked_eval(
        &self,
        wo: DVec3,
        wi: DVec3,
        front: bool,
        out: &mut [f64],
    ) -> std::result::Result<(), String> {
        out.iter_mut().for_each(|x| *x = 0.0);
        self.bsdf
            .eval(wo.to_array(), wi.to_array(), front, out)
            .map_err(|m| format!("eval failed: {m}"))?;
        if let Some(b) = out.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
            return Err(format!(
                "eval gave f[{b}] = {} for wo {wo:?}, wi {wi:?} (values must be finite and >= 0)",
                out[b]
            ));
        }
        Ok(())
    }

    fn checked_sample(
        &self,
        wo: DVec3,
        u: [f64; 3],
        front: bool,
    ) -> std::result::Result<Option<(DVec3, f64)>, String> {
        let Some((wi, pdf)) = self
            .bsdf
            .sample(wo.to_array(), u, front)
            .map_err(|m| format!("sample failed: {m}"))?
        else {
            return Ok(None);
        };
        let wi = DVec3::from(wi);
        if !(wi.is_finite() && (wi.length() - 1.0).abs() <= 1e-3 && wi.z != 0.0) {
            return Err(format!(
                "sample gave the direction {wi:?} for wo {wo:?}: not a unit vector off the surface"
            ));
        }
        if wi.z < 0.0 && !self.transmits() {
            return Err(format!(
                "sample sent light through ({wi:?}) but the BSDF does not transmit"
            ));
        }
        if !(pdf.is_finite() && pdf > 0.0) {
            return Err(format!("sample gave the density {pdf} for {wi:?}"));
        }
        Ok(Some((wi.normalize(), pdf)))
    }

    /// f into `out` (zeros after a failure, which is recorded).
    pub fn eval(&self, wo: DVec3, wi: DVec3, front: bool, out: &mut [f64]) {
        if let Err(m) = self.checked_eval(wo, wi, front, out) {
            out.iter_mut().for_each(|x| *x = 0.0);
            self.fail(m);
        }
    }

    /// The density (0 after a failure, which is recorded).
    pub fn pdf(&self, wo: DVec3, wi: DVec3, front: bool) -> f64 {
        match self.bsdf.pdf(wo.to_array(), wi.to_array(), front) {
            Ok(p) if p.is_finite() && p >= 0.0 => p,
            Ok(p) => {
                self.fail(format!("pdf gave {p} for wo {wo:?}, wi {wi:?}"));
                0.0
            }
            Err(m) => {
                self.fail(format!("pdf failed: {m}"));
                0.0
            }
        }
    }

    /// A direction and its density (None after a failure, which is recorded).
    pub fn sample(&self, wo: DVec3, u: [f64; 3], front: bool) -> Option<(DVec3, f64)> {
        match self.checked_sample(wo, u, front) {
            Ok(s) => s,
            Err(m) => {
                self.fail(m);
                None
            }
        }
    }
}

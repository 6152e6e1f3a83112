//! Light that arrives unscattered from a distant source: the sun's direct component as
//! IES LM-83 and the 5-phase method define it (no inter-reflection), through the smooth
//! dielectric panes of a window.
//!
//! From each point a ray goes toward the source. At a smooth dielectric interface it
//! refracts (Snell) and keeps the transmitted share of each polarisation, 1 − |r_s|² and
//! 1 − |r_p|², against the medium around the surface (nested media as the photons see
//! them); total internal reflection ends it. Between surfaces it loses what the medium it
//! lies in takes (extinction: absorption, and scattering, which sends the light elsewhere),
//! and what the scene's haze takes. Any other surface stops it: what a diffuse, glossy,
//! measured or window-BSDF surface sends on is scattered light, which the photons bring.
//! When the ray leaves the scene its direction must be the source's to within the sun's
//! radius (a pane of parallel faces gives it back; a prism does not, and its light then
//! comes from elsewhere: none along this line). The s and p shares multiply at each
//! interface relative to that interface's plane of incidence, which is exact for parallel
//! panes (every glazing) and for one interface; the transmittance is their mean.

use super::Context;
use crate::error::{bail, Result};
use crate::scene::material::fresnel_amplitudes;
use crate::scene::medium::MediumStack;
use crate::scene::texture::TintScratch;
use glam::DVec3;

/// Surfaces a ray may cross before it is taken as stopped (a stack of 16 panes).
const MAX_CROSSINGS: usize = 32;

impl Context {
    /// For every point of `points` (scene units, outside every mesh's medium) and every
    /// direction of `dirs` (toward a distant source, any length but 0), the share of the
    /// source's light that arrives at the point unscattered along that line (module doc),
    /// weighted over the bands by `weights` (the source's luminous power per band: a
    /// luminous transmittance; empty: equal weights). Point-major: `points.len()` ×
    /// `dirs.len()` values. The rays run on the context's threads.
    ///
    /// Fails with `IMAP_ERR_NON_FINITE` or `IMAP_ERR_INVALID_ARGUMENT` naming the point or
    /// direction, and as a run's preparation does (no mesh or light).
    pub fn straight_transmittance(
        &mut self,
        points: &[[f64; 3]],
        dirs: &[[f64; 3]],
        weights: &[f64],
    ) -> Result<Vec<f32>> {
        let nb = self.scene.bands.count();
        if !weights.is_empty() && weights.len() != nb {
            bail!(
                ImapErrInvalidArgument,
                "weights holds {} values for {nb} bands",
                weights.len()
            );
        }
        if let Some(i) = weights.iter().position(|w| !(w.is_finite() && *w >= 0.0)) {
            bail!(
                ImapErrNonFinite,
                "weights[{i}] = {}: must be finite and ≥ 0",
                weights[i]
            );
        }
        let w: Vec<f64> = if weights.iter().sum::<f64>() > 0.0 {
            let s: f64 = weights.iter().sum();
            weights.iter().map(|x| x / s).collect()
        } else {
            vec![1.0 / nb as f64; nb]
        };
        for (i, p) in points.iter().enumerate() {
            crate::error::check_finite(&format!("points[{i}]"), p)?;
        }
        let mut units = Vec::with_capacity(dirs.len());
        for (i, d) in dirs.iter().enumerate() {
            crate::error::check_finite(&format!("dirs[{i}]"), d)?;
            let Some(u) = DVec3::from(*d).try_normalize() else {
                bail!(ImapErrInvalidArgument, "dirs[{i}] is the zero vector");
            };
            units.push(u);
        }
        self.prepare_geometry()?;
        let threads = self.worker_threads().max(1);
        let p = self.prepared.as_ref().expect("prepared above");
        let tracer = Straight {
            ctx: self,
            scene: &p.scene,
            accel: &p.accel,
            weights: &w,
            dispersive: self.scene.materials.iter().any(|m| {
                m.dielectric
                    .as_ref()
                    .is_some_and(|d| d.ior.windows(2).any(|x| x[0] != x[1]))
            }),
        };
        let nd = units.len();
        let mut out = vec![0.0f32; points.len() * nd];
        if nd == 0 {
            return Ok(out);
        }
        let per = points.len().div_ceil(threads).max(1);
        std::thread::scope(|s| {
            for (chunk, rows) in out.chunks_mut(per * nd).enumerate() {
                let (tracer, units) = (&tracer, &units);
                s.spawn(move || {
                    let mut work = Work::default();
                    for (k, row) in rows.chunks_mut(nd).enumerate() {
                        let q = DVec3::from(points[chunk * per + k]) - tracer.scene.origin;
                        for (o, &d) in row.iter_mut().zip(units) {
                            *o = tracer.luminous(q, d, &mut work) as f32;
                        }
                    }
                });
            }
        });
        Ok(out)
    }
}

struct Straight<'a> {
    ctx: &'a Context,
    scene: &'a crate::scene::PreparedScene,
    accel: &'a crate::accel::Accel,
    weights: &'a [f64],
    dispersive: bool,
}

/// Parallel interfaces and the media between them as one element for intensities
/// (incoherent: multiple reflections add in power): transmittance and reflectance from
/// the side the ray came from (f) and from the other (b).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Stack {
    tf: f64,
    tb: f64,
    rf: f64,
    rb: f64,
}

impl Stack {
    const CLEAR: Stack = Stack {
        tf: 1.0,
        tb: 1.0,
        rf: 0.0,
        rb: 0.0,
    };

    /// A lossless interface of reflectance `r` (Fresnel's is the same from both sides at
    /// Snell's pair of angles).
    fn interface(r: f64) -> Stack {
        Stack {
            tf: 1.0 - r,
            tb: 1.0 - r,
            rf: r,
            rb: r,
        }
    }

    /// A medium's one-way transmittance `tau`.
    fn medium(tau: f64) -> Stack {
        Stack {
            tf: tau,
            tb: tau,
            rf: 0.0,
            rb: 0.0,
        }
    }

    /// `self` followed by `o` along the ray, every reflection between them summed.
    fn then(self, o: Stack) -> Stack {
        let d = 1.0 - self.rb * o.rf;
        if d <= 0.0 {
            return Stack {
                tf: 0.0,
                tb: 0.0,
                rf: 1.0,
                rb: 1.0,
            };
        }
        Stack {
            tf: self.tf * o.tf / d,
            tb: o.tb * self.tb / d,
            rf: self.rf + self.tf * self.tb * o.rf / d,
            rb: o.rb + o.tb * o.tf * self.rb / d,
        }
    }
}

/// Per-band state of one ray, kept between rays: per polarisation (s, p), the product of
/// the closed stacks' transmittances and the open stack of parallel interfaces.
#[derive(Default)]
struct Work {
    done: Vec<[f64; 2]>,
    open: Vec<[Stack; 2]>,
    tint: TintScratch,
}

/// Two interfaces whose normals differ by more than this (1 − cos) are not parallel:
/// light reflected between them leaves the line.
const PARALLEL: f64 = 1e-6;

impl Straight<'_> {
    /// The weighted transmittance from local point `q` toward unit `d`.
    fn luminous(&self, q: DVec3, d: DVec3, work: &mut Work) -> f64 {
        let nb = self.weights.len();
        if self.dispersive {
            // Each band refracts its own way.
            (0..nb)
                .filter(|&b| self.weights[b] > 0.0)
                .map(|b| self.trace(q, d, b..b + 1, work))
                .sum()
        } else {
            self.trace(q, d, 0..nb, work)
        }
    }

    /// Σ over `bands` of weight × transmittance from `q` toward `d` (the bands refract
    /// alike: their geometry is the first's). Interfaces in a row that are parallel (the
    /// faces of a pane, the panes of a glazing unit) form one stack whose reflections
    /// between them stay on the line and are summed; light reflected between surfaces
    /// that are not leaves it.
    fn trace(&self, q: DVec3, d: DVec3, bands: std::ops::Range<usize>, w: &mut Work) -> f64 {
        let materials = &self.ctx.scene.materials;
        let unit_m = self.ctx.scene.unit_m;
        let nb = self.weights.len();
        let g = bands.start;
        w.done.clear();
        w.done.resize(nb, [1.0; 2]);
        w.open.clear();
        w.open.resize(nb, [Stack::CLEAR; 2]);
        let mut normal: Option<DVec3> = None;
        let mut stack = MediumStack::default();
        let (mut org, mut dir) = (q, d);
        // The ray goes from the point toward the source; light runs the other way, and a
        // stack's transmittance is the same both ways.
        for _ in 0..MAX_CROSSINGS {
            let hit = self.accel.intersect(org, dir);
            let seg = hit.as_ref().map_or(f64::INFINITY, |h| h.t);
            let sigma = match stack.current() {
                Some((_, m)) => materials[m as usize].extinction().map(|s| (s, seg)),
                None => self.scene.haze.as_ref().map(|h| {
                    let (t0, t1) = h.span(org, dir, seg);
                    (&h.sigma[..], t1 - t0)
                }),
            };
            if let Some((sigma, t)) = sigma {
                for b in bands.clone() {
                    let tau = (-sigma[b] * t * unit_m).exp();
                    for o in &mut w.open[b] {
                        *o = o.then(Stack::medium(tau));
                    }
                }
            }
            let Some(h) = hit else {
                // Out of the scene: along the source's direction, or not at all.
                let cos_sun = (0.5 * crate::scene::light::SUN_DIAMETER_DEG)
                    .to_radians()
                    .cos();
                if dir.dot(d) < cos_sun {
                    return 0.0;
                }
                return bands
                    .map(|b| {
                        let t = |i: usize| w.done[b][i] * w.open[b][i].tf;
                        self.weights[b] * 0.5 * (t(0) + t(1))
                    })
                    .sum();
            };
            let mesh = &self.scene.meshes[h.mesh as usize];
            let m =
                self.scene
                    .material_at(materials, h.mesh, h.prim as usize, (h.u, h.v), &mut w.tint);
            let Some(diel) = m.bsdf().interface() else {
                return 0.0;
            };
            let material = mesh.material(h.prim as usize);
            let ng = mesh.normals[h.prim as usize].as_dvec3();
            if normal.is_some_and(|n| 1.0 - n.dot(ng).abs() > PARALLEL) {
                // Not parallel to the stack so far: close it.
                for b in bands.clone() {
                    for i in 0..2 {
                        w.done[b][i] *= w.open[b][i].tf;
                        w.open[b][i] = Stack::CLEAR;
                    }
                }
            }
            normal = Some(ng);
            let front = dir.dot(ng) < 0.0;
            let out = stack.around(h.mesh, front, materials);
            let n_in = if front { ng } else { -ng };
            let cos_i = (-dir.dot(n_in)).clamp(0.0, 1.0);
            let indices = |b: usize| {
                let (n, n_out) = (diel.ior[b], out.map_or(1.0, |o| o.ior[b]));
                if front {
                    (n_out, n)
                } else {
                    (n, n_out)
                }
            };
            for b in bands.clone() {
                let (n1, n2) = indices(b);
                let (rs, rp) = fresnel_amplitudes(cos_i, n1, n2);
                let r = [rs[0] * rs[0] + rs[1] * rs[1], rp[0] * rp[0] + rp[1] * rp[1]];
                for (o, r) in w.open[b].iter_mut().zip(r) {
                    *o = o.then(Stack::interface(r.min(1.0)));
                }
            }
            let (n1, n2) = indices(g);
            if (n1 / n2).powi(2) * (1.0 - cos_i * cos_i) >= 1.0 {
                // Totally reflected: nothing goes on along a transmitted line.
                return 0.0;
            }
            stack.cross(h.mesh, material, front);
            let p_hit = org + dir * h.t;
            dir = crate::scene::bsdf::refract(dir, n_in, cos_i, n1 / n2);
            org = p_hit + dir * self.scene.offset_at(p_hit);
        }
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::Stack;

    #[test]
    fn a_pane_of_two_faces_passes_one_minus_r_over_one_plus_r() {
        for r in [0.0, 0.04, 0.3, 0.9] {
            let s = Stack::interface(r).then(Stack::interface(r));
            assert!((s.tf - (1.0 - r) / (1.0 + r)).abs() < 1e-12, "{r}");
            assert!((s.rf - 2.0 * r / (1.0 + r)).abs() < 1e-12, "{r}");
            assert!((s.tf + s.rf - 1.0).abs() < 1e-12);
        }
        // With absorption τ inside: T = (1 − R)² τ / (1 − R² τ²); from both sides alike.
        let (r, tau) = (0.05, 0.8);
        let s = Stack::interface(r)
            .then(Stack::medium(tau))
            .then(Stack::interface(r));
        let want = (1.0 - r).powi(2) * tau / (1.0 - r * r * tau * tau);
        assert!((s.tf - want).abs() < 1e-12 && (s.tb - want).abs() < 1e-12);
        // Two panes: the stack is associative (the same from either grouping).
        let pane = s;
        let air = Stack::medium(1.0);
        let a = pane.then(air).then(pane);
        let b = pane.then(air.then(pane));
        assert!((a.tf - b.tf).abs() < 1e-12 && (a.rf - b.rf).abs() < 1e-12);
        assert!(a.tf < pane.tf * pane.tf * 1.01 && a.tf > pane.tf * pane.tf);
    }
}

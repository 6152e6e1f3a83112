//! Scattering inside a dielectric: a homogeneous medium of absorption σa and scattering σs
//! per band (1/m) with a Henyey–Greenstein phase function of asymmetry g per band, or a
//! tabulated phase function (`PhaseTable`) shared by all bands.
//!
//! One free flight serves every band at once, unbiased per band (spectral tracking with
//! the path's own weights): the distance is drawn from the mixture Σ w_b σt_b e^(−σt_b t)
//! of the bands' exponentials, w_b the path's colour share of band b; each band is then
//! re-weighted by its own density over the mixture's, so that the colour's total does not
//! change (a photon carries the power it left its light with, as at surfaces). A collision
//! is a scattering with the colour-weighted single-scattering albedo, and the colour is
//! re-weighted by the bands' albedos over it; otherwise the path is absorbed there. A
//! grey medium takes exactly the one-band free flight and weights of 1; with no
//! scattering it is Beer–Lambert absorption.
//!
//! A fluorescent medium (spectral runs) re-emits, isotropically, the share m_ij of what it
//! absorbs in band i in band j (`Fluorescence`, the matrix a fluorescent surface has). A
//! collision there is a scattering, a re-emission or an absorption, chosen by the path's
//! weights toward each (a photon's power, `flight`, or an eye path's importance, for which
//! the matrix is read backward, `eye_flight`), and the weights are divided by the chance
//! of the choice.

use crate::scene::material::{Dielectric, Fluorescence, Material};
use crate::spectral::pick_band;
use glam::DVec3;
use std::f64::consts::PI;
use std::sync::Arc;

/// The scattering part of a dielectric's medium (its absorption is the dielectric's
/// `absorption_per_m`).
#[derive(Clone, PartialEq)]
pub struct Scattering {
    /// σt = σa + σs per band, 1/m.
    pub sigma_t: Vec<f64>,
    /// The single-scattering albedo σs / σt per band (0 where σt is 0).
    pub albedo: Vec<f64>,
    /// Henyey–Greenstein asymmetry per band, in (−1, 1).
    pub g: Vec<f64>,
    /// Whether every band has the same g (a direction then needs no re-weighting).
    pub one_g: bool,
    /// Whether every band has the same σt and albedo (a free flight then changes no
    /// weight: `flight` takes the one-band path).
    pub grey: bool,
    /// A tabulated phase function for all bands, in place of Henyey–Greenstein's.
    pub table: Option<std::sync::Arc<PhaseTable>>,
    /// What the medium re-emits of what it absorbs (spectral runs): of band i's absorbed
    /// power, the share m_ij in band j, isotropically (`set_fluorescence`).
    pub fluorescence: Option<Arc<Reemission>>,
}

/// A fluorescent medium's matrix with what its collisions read of it, per band: the share
/// of band i's absorbed power re-emitted in all (Σ_j m_ij, photons), and κ_b = Σ_a σa_a m_ab
/// (1/m), how densely light absorbed in other bands is re-emitted into band b (eye paths).
#[derive(Clone, PartialEq)]
pub struct Reemission {
    pub matrix: Fluorescence,
    reemitted: Vec<f64>,
    kappa: Vec<f64>,
}

/// As derived, but `table` only when present: the state fingerprint hashes this text, and
/// a medium without a table keeps the fingerprint it had before tables existed.
impl std::fmt::Debug for Scattering {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut d = f.debug_struct("Scattering");
        d.field("sigma_t", &self.sigma_t)
            .field("albedo", &self.albedo)
            .field("g", &self.g)
            .field("one_g", &self.one_g);
        if let Some(t) = &self.table {
            d.field("table", t);
        }
        if let Some(f) = &self.fluorescence {
            d.field("fluorescence", &f.matrix);
        }
        d.finish()
    }
}

/// The dielectric meshes a path is inside, innermost last, each with its material: media
/// nest (a glass ball in a fog box, a bubble in a light guide). Crossing a mesh's surface
/// from its front enters it; from its back leaves it, whichever mesh was innermost (a path
/// that leaves a mesh it never entered — a lamp inside a glass globe starts outside it —
/// changes nothing).
#[derive(Clone, Debug, Default)]
pub struct MediumStack {
    inside: Vec<(u32, u32)>,
}

impl MediumStack {
    /// The stack of a path that starts inside the meshes `outermost_first` (each with its
    /// medium's material): a camera inside a fog box (`Enclosures::at`).
    pub fn starting_in(outermost_first: Vec<(u32, u32)>) -> MediumStack {
        MediumStack {
            inside: outermost_first,
        }
    }

    pub fn clear(&mut self) {
        self.inside.clear();
    }

    /// Crosses the surface of `mesh` (material `material`) into it (`front`) or out of it.
    #[inline]
    pub fn cross(&mut self, mesh: u32, material: u32, front: bool) {
        if front {
            self.inside.push((mesh, material));
        } else if let Some(i) = self.inside.iter().rposition(|&(m, _)| m == mesh) {
            self.inside.remove(i);
        }
    }

    /// The innermost mesh and its material; None outside every mesh.
    #[inline]
    pub fn current(&self) -> Option<(u32, u32)> {
        self.inside.last().copied()
    }

    /// The dielectric around the surface of `mesh` that a path meets from its front
    /// (entering: the innermost mesh it is in) or its back (leaving: the innermost one it is
    /// in but `mesh`), its material read from `materials`; None: air (or the scene's
    /// medium). Leaving a mesh it never entered (a slab drawn as two open sheets, a lamp's
    /// globe) is into air, as before media nested.
    #[inline]
    pub fn around<'m>(
        &self,
        mesh: u32,
        front: bool,
        materials: &'m [Material],
    ) -> Option<&'m Dielectric> {
        let outer = if front {
            self.current()
        } else {
            let i = self.inside.iter().rposition(|&(m, _)| m == mesh)?;
            self.inside
                .iter()
                .enumerate()
                .rev()
                .find(|&(k, _)| k != i)
                .map(|(_, &e)| e)
        };
        outer.and_then(|(_, m)| materials[m as usize].dielectric.as_ref())
    }
}

/// What a free flight of a path inside a medium ended with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Flight {
    /// The path reaches the surface it was going to (colour re-weighted by transmittance).
    Surface,
    /// It scatters `t_m` metres along its direction (colour re-weighted).
    Scatter(f64),
    /// A fluorescent medium re-emits what it absorbs `t_m` metres along (the first field),
    /// isotropically; the second is one over the chance of that choice. The colour is the
    /// colliding colour still: `emit_light` or `emit_importance` turns it into the
    /// re-emitted one.
    Fluoresce(f64, f64),
    /// It is absorbed in the medium.
    Absorbed,
}

impl Scattering {
    /// Per-band σs, σa (σa may be None: clear) and g, already checked.
    pub fn new(sigma_s: Vec<f64>, sigma_a: Option<&[f64]>, g: Vec<f64>) -> Scattering {
        let sigma_t: Vec<f64> = sigma_s
            .iter()
            .enumerate()
            .map(|(b, s)| s + sigma_a.map_or(0.0, |a| a[b]))
            .collect();
        let albedo: Vec<f64> = sigma_s
            .iter()
            .zip(&sigma_t)
            .map(|(s, t)| if *t > 0.0 { s / t } else { 0.0 })
            .collect();
        let one_g = g.iter().all(|&x| x == g[0]);
        let grey =
            sigma_t.iter().all(|&x| x == sigma_t[0]) && albedo.iter().all(|&x| x == albedo[0]);
        Scattering {
            sigma_t,
            albedo,
            g,
            one_g,
            grey,
            table: None,
            fluorescence: None,
        }
    }

    /// Makes the medium re-emit `matrix` of what it absorbs (after its coefficients are set).
    pub fn set_fluorescence(&mut self, matrix: Fluorescence) {
        let nb = matrix.bands;
        let m = &matrix.m;
        let reemitted = (0..nb)
            .map(|i| m[i * nb..(i + 1) * nb].iter().sum())
            .collect();
        let kappa = (0..nb)
            .map(|b| (0..nb).map(|a| self.sigma_a(a) * m[a * nb + b]).sum())
            .collect();
        self.fluorescence = Some(Arc::new(Reemission {
            matrix,
            reemitted,
            kappa,
        }));
    }

    /// A photon's free flight toward a surface `dist_m` metres away (infinite: none), its
    /// per-band weights `c` its power (a fluorescent medium re-emits mᵀ((1 − albedo)∘c)),
    /// with uniform numbers `u`: the band whose exponential draws the distance, the
    /// distance, and the scattering-or-absorption choice.
    pub fn flight(&self, c: &mut [f64], dist_m: f64, u: [f64; 3]) -> Flight {
        let t = self.distance(c, u);
        self.flight_to(c, t, dist_m, u)
    }

    /// An eye path's free flight: `flight`, but its weights `c` are importance per band of
    /// the light it reads, so a fluorescent medium's matrix is read backward (light of band
    /// i re-emitted here reaches it with Σ_b β_b σa_i m_ib / σt_b: `flight_importance`).
    pub fn eye_flight(&self, c: &mut [f64], dist_m: f64, u: [f64; 3]) -> Flight {
        match &self.fluorescence {
            Some(fl) => self.flight_importance(fl, c, dist_m, u),
            None => self.flight(c, dist_m, u),
        }
    }

    /// Where a free flight of weights `c` collides, metres (∞: never), from the numbers
    /// `flight` takes: the band that draws it (by the colour; a grey medium has one), then
    /// the distance. It does not depend on the surface ahead, so a photon may draw it
    /// before it looks for the surface (`Tracer::trace`). Not for an eye path in a
    /// fluorescent medium (`flight_importance` draws its own).
    #[inline]
    pub fn distance(&self, c: &[f64], u: [f64; 3]) -> f64 {
        let st = if self.grey {
            self.sigma_t[0]
        } else {
            let total: f64 = c.iter().sum();
            if !(total > 0.0 && total.is_finite()) {
                // (`flight_to` absorbs it.)
                return f64::INFINITY;
            }
            self.sigma_t[pick_band(c, total, u[0])]
        };
        if st > 0.0 {
            -(1.0 - u[1]).ln() / st
        } else {
            f64::INFINITY
        }
    }

    /// The rest of `flight` once `distance` has drawn `t`: through to the surface (each band
    /// re-weighted by its transmittance over the mixture's), or a collision at t (each band
    /// by its collision density over the mixture's, then scattered with the colour-weighted
    /// albedo, each band by its albedo over it, or re-emitted, or absorbed). A grey medium
    /// changes no weight (every band's density and albedo over the mixture's is 1).
    #[inline]
    pub fn flight_to(&self, c: &mut [f64], t: f64, dist_m: f64, u: [f64; 3]) -> Flight {
        let total: f64 = c.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return Flight::Absorbed;
        }
        if self.grey && self.fluorescence.is_none() {
            return if t >= dist_m {
                Flight::Surface
            } else if self.sigma_t[0] > 0.0 && u[2] < self.albedo[0] {
                Flight::Scatter(t)
            } else {
                Flight::Absorbed
            };
        }
        if t >= dist_m {
            let tr = |b: usize| match self.sigma_t[b] {
                0.0 => 1.0,
                s => (-s * dist_m).exp(),
            };
            return match reweigh(c, total, tr) {
                Some(_) => Flight::Surface,
                None => Flight::Absorbed,
            };
        }
        let density = |b: usize| self.sigma_t[b] * (-self.sigma_t[b] * t).exp();
        if reweigh(c, total, density).is_none() {
            return Flight::Absorbed;
        }
        if let Some(fl) = &self.fluorescence {
            return self.collide_fluorescent(fl, c, total, (t, u[2]));
        }
        match reweigh(c, total, |b| self.albedo[b]) {
            Some(w) if u[2] < w => Flight::Scatter(t),
            _ => Flight::Absorbed,
        }
    }

    /// A photon's collision at `t` metres in a fluorescent medium, its colour `c` of total
    /// `total`: s = Σ_b c_b albedo_b goes on scattered, f = Σ_i c_i (1 − albedo_i) Σ_j m_ij
    /// re-emitted. The photon scatters with chance s/total (its colour albedo∘c over that
    /// chance), is re-emitted with chance f/total (`Flight::Fluoresce` with one over it),
    /// or is absorbed: its colour keeps its total, as elsewhere.
    #[cold]
    #[inline(never)]
    fn collide_fluorescent(
        &self,
        fl: &Reemission,
        c: &mut [f64],
        total: f64,
        (t, u): (f64, f64),
    ) -> Flight {
        let s: f64 = c.iter().zip(&self.albedo).map(|(x, a)| x * a).sum();
        let f: f64 = c
            .iter()
            .zip(&self.albedo)
            .zip(&fl.reemitted)
            .map(|((x, a), r)| x * (1.0 - a) * r)
            .sum();
        if u * total < s {
            let k = total / s;
            c.iter_mut()
                .zip(&self.albedo)
                .for_each(|(x, a)| *x *= a * k);
            Flight::Scatter(t)
        } else if u * total < s + f {
            Flight::Fluoresce(t, total / f)
        } else {
            Flight::Absorbed
        }
    }

    /// σa of band `b` (1/m).
    #[inline]
    fn sigma_a(&self, b: usize) -> f64 {
        self.sigma_t[b] * (1.0 - self.albedo[b])
    }

    /// An eye path's free flight through a fluorescent medium toward a surface `dist_m`
    /// metres away, its weights `c` (importance per band), uniforms `u`.
    ///
    /// Light of band b reaching the path here is e^(−σt_b D) L_b(D) from the surface plus
    /// ∫ e^(−σt_b t) (σs_b L^s_b + κ_b ψ_b) dt along the way: in-scattered light, and light
    /// re-emitted from the other bands (ψ_b = Σ_a σa_a m_ab φ_a / (4π κ_b)). The emission
    /// can be where band b itself is clear (σt_b = 0), so the collisions cannot be drawn
    /// from σt alone. Per band the surface term has weight P_b = e^(−σt_b D) and the
    /// collisions C_b = (σs_b + κ_b)(1 − e^(−σt_b D))/σt_b (κ_b D when σt_b is 0). The path
    /// reaches the surface with chance P/(P + C), P = Σ c_b P_b, C = Σ c_b C_b, each band
    /// then c_b P_b (P + C)/P; otherwise it collides at t drawn from the bands' truncated
    /// exponentials mixed by c_b C_b, each band then c_b e^(−σt_b t)(σs_b + κ_b)(P + C)/M(t),
    /// M(t) = Σ c_b (σs_b + κ_b) e^(−σt_b t), and scatters or is re-emitted by the bands'
    /// shares σs_b : κ_b of that weight (`Flight::Fluoresce` with the weights toward ψ_b:
    /// `emit_importance` takes them on). Unbiased per band; absorption is in the weights.
    #[cold]
    #[inline(never)]
    fn flight_importance(
        &self,
        fl: &Reemission,
        c: &mut [f64],
        dist_m: f64,
        u: [f64; 3],
    ) -> Flight {
        if !dist_m.is_finite() {
            return Flight::Surface;
        }
        let sigma_s = |b: usize| self.sigma_t[b] * self.albedo[b];
        // What collides in band b, per metre: scattering and re-emission into it.
        let on = |b: usize| sigma_s(b) + fl.kappa[b];
        let pass = |b: usize| (-self.sigma_t[b] * dist_m).exp();
        let collide = |b: usize| match self.sigma_t[b] {
            0.0 => on(b) * dist_m,
            st => on(b) * -(-st * dist_m).exp_m1() / st,
        };
        let p: f64 = c.iter().enumerate().map(|(b, x)| x * pass(b)).sum();
        let cw: Vec<f64> = c
            .iter()
            .enumerate()
            .map(|(b, &x)| if x != 0.0 { x * collide(b) } else { 0.0 })
            .collect();
        let cc: f64 = cw.iter().sum();
        let all = p + cc;
        if !(all > 0.0 && all.is_finite()) {
            return Flight::Absorbed;
        }
        if u[0] * all < p {
            c.iter_mut()
                .enumerate()
                .for_each(|(b, x)| *x *= pass(b) * all / p);
            return Flight::Surface;
        }
        // The band whose truncated exponential draws the distance, by its collision weight.
        let k = pick_band(&cw, cc, u[1]);
        let st = self.sigma_t[k];
        let t = if st > 0.0 {
            // Inverse of (1 − e^(−σt t)) / (1 − e^(−σt D)) = u.
            -(u[2] * (-st * dist_m).exp_m1()).ln_1p() / st
        } else {
            u[2] * dist_m
        }
        .clamp(0.0, dist_m);
        // Each band's weight at the collision, x (σs_b + κ_b) e^(−σt_b t), over M(t).
        let (mut m, mut s_part) = (0.0, 0.0);
        for (b, x) in c.iter_mut().enumerate() {
            let w = *x * on(b) * (-self.sigma_t[b] * t).exp();
            m += w;
            if w > 0.0 {
                s_part += w * sigma_s(b) / on(b);
            }
            *x = w;
        }
        if !(m > 0.0 && m.is_finite()) {
            return Flight::Absorbed;
        }
        // Scattered (chance s_part/m, the σs shares) or re-emitted (the κ shares); each
        // band's weight x (P + C)/M of its share, over the chance of the choice.
        let scattered = u[0] * all < p + cc * s_part / m;
        let part = if scattered { s_part } else { m - s_part };
        let scale = all / part;
        for (b, x) in c.iter_mut().enumerate() {
            let share = if scattered { sigma_s(b) } else { fl.kappa[b] };
            *x = if *x > 0.0 {
                *x * share / on(b) * scale
            } else {
                0.0
            };
        }
        if scattered {
            Flight::Scatter(t)
        } else {
            Flight::Fluoresce(t, 1.0)
        }
    }

    /// A photon's colour `c` at a re-emission (`Flight::Fluoresce` with `k`): what the
    /// medium re-emits of it, k mᵀ((1 − albedo)∘c), into `scratch` and back into `c`.
    pub fn emit_light(&self, c: &mut [f64], k: f64, scratch: &mut Vec<f64>) {
        let fl = &self
            .fluorescence
            .as_ref()
            .expect("a fluorescent medium")
            .matrix;
        let nb = fl.bands;
        scratch.clear();
        scratch.resize(nb, 0.0);
        for (i, &ci) in c.iter().enumerate() {
            let absorbed = ci * (1.0 - self.albedo[i]) * k;
            if absorbed == 0.0 {
                continue;
            }
            for (e, m) in scratch.iter_mut().zip(&fl.m[i * nb..(i + 1) * nb]) {
                *e += absorbed * m;
            }
        }
        c.copy_from_slice(scratch);
    }

    /// An eye path's weights `beta` at a re-emission (`Flight::Fluoresce`; `beta` then
    /// holds each path band b's weight toward ψ_b): per band a of the light arriving here,
    /// its weight toward what the path reads, Σ_b β_b σa_a m_ab / κ_b. A path that still
    /// reads each band into its own pixel band (`pick` None) first picks the pixel band j
    /// it will read into from now on, with chance β_j / Σβ, which takes the whole weight.
    pub fn emit_importance(&self, beta: &mut [f64], pick: &mut Option<usize>, u: f64) {
        let fl = self.fluorescence.as_ref().expect("a fluorescent medium");
        let (m, nb) = (&fl.matrix.m, fl.matrix.bands);
        let mut from = beta.to_vec();
        if pick.is_none() {
            let total: f64 = from.iter().sum();
            let j = pick_band(&from, total, u);
            from.iter_mut().for_each(|x| *x = 0.0);
            from[j] = total;
            *pick = Some(j);
        }
        for (a, x) in beta.iter_mut().enumerate() {
            let sa = self.sigma_a(a);
            *x = (0..nb)
                .filter(|&b| from[b] != 0.0 && fl.kappa[b] > 0.0)
                .map(|b| from[b] * sa * m[a * nb + b] / fl.kappa[b])
                .sum::<f64>();
        }
    }

    /// The phase function of band `b` (1/sr) at the cosine `cos` of the scattering angle
    /// (between the directions of travel before and after).
    #[inline]
    pub fn phase(&self, b: usize, cos: f64) -> f64 {
        match &self.table {
            Some(t) => t.pdf(cos),
            None => hg_pdf(self.g[b], cos),
        }
    }

    /// A new direction at a scattering event of a path travelling along `dir` with
    /// per-band weights `c` (re-weighted when the bands' g differ), from uniforms `u`.
    pub fn scatter(&self, dir: DVec3, c: &mut [f64], u: [f64; 3]) -> DVec3 {
        if let Some(t) = &self.table {
            return turn(dir, t.sample_cos(u[0]), u[1]);
        }
        let g = if self.one_g {
            self.g[0]
        } else {
            // The band whose phase function draws the direction, by the colour.
            self.g[pick_band(c, c.iter().sum(), u[2])]
        };
        let cos = hg_sample_cos(g, u[0]);
        if !self.one_g {
            // Each band by its phase function's density over the mixture's (all positive).
            reweigh(c, c.iter().sum(), |b| hg_pdf(self.g[b], cos));
        }
        turn(dir, cos, u[1])
    }
}

/// `dir` turned by the angle of cosine `cos`, about it by 2π `u`.
fn turn(dir: DVec3, cos: f64, u: f64) -> DVec3 {
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = 2.0 * PI * u;
    let (t, b) = dir.any_orthonormal_pair();
    (dir * cos + t * (sin * phi.cos()) + b * (sin * phi.sin())).normalize()
}

/// A phase function given as values at scattering angles from 0 to π (a measured or Mie
/// table), linear in the angle between them, normalised over the sphere. Drawn exactly:
/// the segment by the table's cumulative integral, the angle in it by inverting the
/// segment's closed-form integral ∫ p(θ) 2π sin θ dθ (Newton steps kept inside a
/// bisection bracket).
#[derive(Clone, Debug, PartialEq)]
pub struct PhaseTable {
    /// The angles, radians: 0 first, π last, increasing.
    theta: Vec<f64>,
    /// The density at each angle, 1/sr (the given values over their integral).
    p: Vec<f64>,
    /// The integral up to each angle (0 first, 1 last).
    cdf: Vec<f64>,
}

impl PhaseTable {
    /// From angles in degrees (0 first, 180 last, increasing) and values (finite, ≥ 0,
    /// some positive), already checked by the caller.
    pub fn new(angles_deg: &[f64], values: &[f64]) -> PhaseTable {
        let theta: Vec<f64> = angles_deg.iter().map(|a| a.to_radians()).collect();
        let mut cdf = vec![0.0; theta.len()];
        for i in 1..theta.len() {
            cdf[i] = cdf[i - 1]
                + segment_integral(
                    theta[i - 1],
                    theta[i] - theta[i - 1],
                    values[i - 1],
                    values[i],
                    theta[i] - theta[i - 1],
                );
        }
        let total = *cdf.last().unwrap();
        let p = values.iter().map(|v| v / total).collect();
        cdf.iter_mut().for_each(|c| *c /= total);
        *cdf.last_mut().unwrap() = 1.0;
        PhaseTable { theta, p, cdf }
    }

    /// The density (1/sr) at cosine `cos` of the scattering angle.
    pub fn pdf(&self, cos: f64) -> f64 {
        let th = cos.clamp(-1.0, 1.0).acos();
        let i = self
            .theta
            .partition_point(|&t| t <= th)
            .clamp(1, self.theta.len() - 1)
            - 1;
        let (t0, t1) = (self.theta[i], self.theta[i + 1]);
        let x = ((th - t0) / (t1 - t0)).clamp(0.0, 1.0);
        self.p[i] + (self.p[i + 1] - self.p[i]) * x
    }

    /// The cosine of a scattering angle drawn from the table with uniform `u`.
    pub fn sample_cos(&self, u: f64) -> f64 {
        let n = self.theta.len();
        let i = self.cdf.partition_point(|&c| c <= u).clamp(1, n - 1) - 1;
        let (t0, h) = (self.theta[i], self.theta[i + 1] - self.theta[i]);
        let (p0, p1) = (self.p[i], self.p[i + 1]);
        let target = u - self.cdf[i];
        let whole = self.cdf[i + 1] - self.cdf[i];
        if whole <= 0.0 {
            return t0.cos();
        }
        // Solve F(x) = target on [0, h], F increasing, F(0) = 0, F(h) = whole.
        let (mut lo, mut hi) = (0.0, h);
        let mut x = h * (target / whole).clamp(0.0, 1.0);
        for _ in 0..60 {
            let f = segment_integral(t0, x, p0, p1, h) - target;
            if f.abs() <= 1e-16 || hi - lo <= 1e-15 * h {
                break;
            }
            if f > 0.0 {
                hi = x;
            } else {
                lo = x;
            }
            let d = 2.0 * PI * (p0 + (p1 - p0) * x / h) * (t0 + x).sin();
            let next = x - f / d;
            x = if d > 0.0 && next > lo && next < hi {
                next
            } else {
                0.5 * (lo + hi)
            };
        }
        (t0 + x).cos()
    }
}

/// ∫ over θ from `t0` to `t0 + x` of p(θ) 2π sin θ, p linear from `p0` at t0 to `p1` at
/// t0 + `h` (in forms that keep their precision for small angles and steps).
fn segment_integral(t0: f64, x: f64, p0: f64, p1: f64, h: f64) -> f64 {
    let s = if h > 0.0 { (p1 - p0) / h } else { 0.0 };
    let half = (0.5 * x).sin();
    let mid = t0 + 0.5 * x;
    // cos t0 − cos(t0 + x), and sin(t0 + x) − sin t0.
    let dcos = 2.0 * mid.sin() * half;
    let dsin = 2.0 * mid.cos() * half;
    // ∫ x' sin(t0 + x') dx' over [0, x] = sin(t0 + x) − sin t0 − x cos(t0 + x).
    let lin = dsin - x * (t0 + x).cos();
    2.0 * PI * (p0 * dcos + s * lin)
}

/// Multiplies each band of `c` (of sum `total`) by `k(band)` over the colour-weighted mean
/// of k, so that the sum is kept, and returns that mean; None (with `c` left scaled by k
/// alone) when the mean is not positive and finite.
fn reweigh(c: &mut [f64], total: f64, k: impl Fn(usize) -> f64) -> Option<f64> {
    let mut sum = 0.0;
    for (b, x) in c.iter_mut().enumerate() {
        *x *= k(b);
        sum += *x;
    }
    let mean = sum / total;
    if !(mean > 0.0 && mean.is_finite()) {
        return None;
    }
    c.iter_mut().for_each(|x| *x /= mean);
    Some(mean)
}

/// The Henyey–Greenstein phase function's density (1/sr) at cosine `cos` between the
/// travel directions before and after.
#[inline]
pub fn hg_pdf(g: f64, cos: f64) -> f64 {
    let d = 1.0 + g * g - 2.0 * g * cos;
    (1.0 - g * g) / (4.0 * PI * d * d.sqrt())
}

/// A cosine drawn from the Henyey–Greenstein phase function of asymmetry `g` (its inverse
/// CDF; isotropic when |g| < 1e-4, where the closed form loses precision).
#[inline]
pub fn hg_sample_cos(g: f64, u: f64) -> f64 {
    if g.abs() < 1e-4 {
        return 1.0 - 2.0 * u;
    }
    let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hg_integrates_to_one_and_has_mean_cosine_g() {
        for g in [-0.8, -0.3, 0.0, 0.5, 0.9] {
            let n = 200_000;
            let (mut s, mut m) = (0.0, 0.0);
            for i in 0..n {
                let c = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                let p = hg_pdf(g, c) * 2.0 * PI * 2.0 / n as f64;
                s += p;
                m += p * c;
            }
            assert!((s - 1.0).abs() < 1e-3, "g {g}: ∫p = {s}");
            assert!((m - g).abs() < 2e-3, "g {g}: mean cosine {m}");
        }
    }

    /// χ² of the drawn cosines against the density over 20 bins.
    #[test]
    fn hg_draws_follow_their_density() {
        for g in [-0.6, 0.0, 0.3, 0.85] {
            let bins = 20;
            let n = 200_000;
            let mut h = vec![0.0; bins];
            let mut state = 0x9E37_79B9_7F4A_7C15u64;
            for _ in 0..n {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let u = (state >> 11) as f64 / (1u64 << 53) as f64;
                let c = hg_sample_cos(g, u);
                let k = (((c + 1.0) / 2.0 * bins as f64) as usize).min(bins - 1);
                h[k] += 1.0;
            }
            let mut chi2 = 0.0;
            for (k, &o) in h.iter().enumerate() {
                // Expected: the density's integral over the bin (fine midpoint rule).
                let (a, b) = (
                    -1.0 + 2.0 * k as f64 / bins as f64,
                    -1.0 + 2.0 * (k + 1) as f64 / bins as f64,
                );
                let m = 200;
                let e: f64 = (0..m)
                    .map(|j| {
                        let c = a + (b - a) * (j as f64 + 0.5) / m as f64;
                        hg_pdf(g, c) * 2.0 * PI * (b - a) / m as f64
                    })
                    .sum::<f64>()
                    * n as f64;
                chi2 += (o - e) * (o - e) / e;
            }
            // 19 degrees of freedom: χ² above 43.8 has probability 0.001.
            assert!(chi2 < 43.8, "g {g}: χ² {chi2}");
        }
    }

    /// A table of Henyey–Greenstein g = 0.9 at every degree: it integrates to one, its
    /// density is the interpolated table's, and its draws follow that density (χ² over
    /// bins equal in angle, the forward peak included).
    #[test]
    fn a_phase_table_is_normalised_and_drawn_by_its_density() {
        let g = 0.9;
        let angles: Vec<f64> = (0..=180).map(f64::from).collect();
        // Values in arbitrary units: the table is normalised.
        let values: Vec<f64> = angles
            .iter()
            .map(|a: &f64| 7.0 * hg_pdf(g, a.to_radians().cos()))
            .collect();
        let t = PhaseTable::new(&angles, &values);
        let n = 400_000;
        let (mut s, mut m) = (0.0, 0.0);
        for i in 0..n {
            let th = PI * (i as f64 + 0.5) / n as f64;
            let w = t.pdf(th.cos()) * 2.0 * PI * th.sin() * PI / n as f64;
            s += w;
            m += w * th.cos();
        }
        assert!((s - 1.0).abs() < 1e-6, "∫p = {s}");
        // The interpolated table's mean cosine is HG's to the table's resolution.
        assert!((m - g).abs() < 0.01, "mean cosine {m}");
        for a in [0.0, 0.5, 10.0, 90.0, 179.5] {
            let c = f64::to_radians(a).cos();
            let rel = t.pdf(c) / hg_pdf(g, c) - 1.0;
            assert!(
                rel.abs() < 0.02,
                "at {a}°: table {} against HG {}",
                t.pdf(c),
                hg_pdf(g, c)
            );
        }
        let bins = 36;
        let mut h = vec![0.0; bins];
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let draws = 400_000;
        for _ in 0..draws {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (state >> 11) as f64 / (1u64 << 53) as f64;
            let c = t.sample_cos(u);
            assert!((-1.0..=1.0).contains(&c));
            let k = ((c.acos() / PI * bins as f64) as usize).min(bins - 1);
            h[k] += 1.0;
        }
        let mut chi2 = 0.0;
        for (k, &o) in h.iter().enumerate() {
            let (a, b) = (
                PI * k as f64 / bins as f64,
                PI * (k + 1) as f64 / bins as f64,
            );
            let m = 400;
            let e: f64 = (0..m)
                .map(|j| {
                    let th = a + (b - a) * (j as f64 + 0.5) / m as f64;
                    t.pdf(th.cos()) * 2.0 * PI * th.sin() * (b - a) / m as f64
                })
                .sum::<f64>()
                * draws as f64;
            chi2 += (o - e) * (o - e) / e;
        }
        // 35 degrees of freedom: χ² above 66.6 has probability 0.001.
        assert!(chi2 < 66.6, "χ² {chi2}");
        // A flat table is isotropic: cos = 1 − 2u.
        let flat = PhaseTable::new(&[0.0, 45.0, 180.0], &[1.0, 1.0, 1.0]);
        for u in [0.0, 0.1, 0.25, 0.5, 0.9, 0.999_999] {
            let c = flat.sample_cos(u);
            assert!((c - (1.0 - 2.0 * u)).abs() < 1e-9, "u {u}: {c}");
        }
        assert!((flat.pdf(0.3) - 0.25 / PI).abs() < 1e-12);
    }

    #[test]
    fn a_grey_flight_has_unit_weights_and_absorption_is_beer_lambert() {
        // Grey: weights stay 1, and the share that reaches the surface is e^(−σt d).
        let m = Scattering::new(vec![3.0; 3], Some(&[1.0; 3]), vec![0.2; 3]);
        let n = 100_000;
        let mut through = 0;
        for i in 0..n {
            let mut c = [1.0; 3];
            let u = [
                (i as f64 + 0.5) / n as f64,
                ((i * 7919) % n) as f64 / n as f64,
                ((i * 104_729) % n) as f64 / n as f64,
            ];
            match m.flight(&mut c, 0.5, u) {
                Flight::Surface => through += 1,
                Flight::Scatter(t) => assert!(t < 0.5),
                Flight::Absorbed => {}
                Flight::Fluoresce(..) => unreachable!("the medium does not fluoresce"),
            }
            assert!(c.iter().all(|&x| (x - 1.0).abs() < 1e-12), "{c:?}");
        }
        let expected = (-4.0f64 * 0.5).exp();
        let got = through as f64 / n as f64;
        assert!((got - expected).abs() < 0.005, "{got} against {expected}");
    }

    #[test]
    fn chromatic_weights_keep_each_band_unbiased() {
        // Per band, the expected weight that reaches the surface equals e^(−σt d), and the
        // colour's total is conserved on every draw.
        let m = Scattering::new(vec![0.0, 2.0, 8.0], Some(&[1.0, 0.5, 0.0]), vec![0.0; 3]);
        let d = 0.3;
        let n = 400_000;
        let mut sum = [0.0; 3];
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..n {
            let mut c = [1.0; 3];
            let f = m.flight(&mut c, d, [next(), next(), next()]);
            if f != Flight::Absorbed {
                assert!((c.iter().sum::<f64>() - 3.0).abs() < 1e-9);
            }
            if f == Flight::Surface {
                for (s, x) in sum.iter_mut().zip(c) {
                    *s += x;
                }
            }
        }
        for (b, (s, st)) in sum.iter().zip(&m.sigma_t).enumerate() {
            let expected = (-st * d).exp();
            let got = s / n as f64;
            assert!(
                (got - expected).abs() < 0.01,
                "band {b}: {got} against {expected}"
            );
        }
    }

    #[test]
    fn an_eye_paths_flight_through_a_fluorescent_medium_is_unbiased_per_band() {
        // Three bands: 0 absorbs (σa 6, σs 1) and re-emits into 1 (m 0.5) and 2 (m 0.25);
        // 1 scatters (σs 2) and is otherwise clear; 2 is clear (σt 0). Per band b, over
        // the draws, the weight that reaches the surface has mean e^(−σt_b d); the weight
        // that scatters, σs_b (1 − e^(−σt_b d))/σt_b; the weight toward re-emission,
        // κ_b (1 − e^(−σt_b d))/σt_b (κ_b d where σt_b is 0), κ_b = Σ_a σa_a m_ab. Then
        // an eye path's weights through the re-emission read band 0 with Σ_b β_b σa_0 m_0b
        // / κ_b.
        let mut m = Scattering::new(vec![1.0, 2.0, 0.0], Some(&[6.0, 0.0, 0.0]), vec![0.0; 3]);
        m.set_fluorescence(Fluorescence {
            bands: 3,
            m: vec![0.0, 0.5, 0.25, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        });
        let kappa = [0.0, 3.0, 1.5];
        let d = 0.4;
        let n = 400_000;
        let mut state = 99u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut pass, mut scatter, mut emit) = ([0.0; 3], [0.0; 3], [0.0; 3]);
        let mut read = 0.0;
        for _ in 0..n {
            let mut c = [1.0; 3];
            let f = m.eye_flight(&mut c, d, [next(), next(), next()]);
            let into = match f {
                Flight::Surface => &mut pass,
                Flight::Scatter(t) => {
                    assert!((0.0..=d).contains(&t));
                    &mut scatter
                }
                Flight::Fluoresce(t, k) => {
                    assert!((0.0..=d).contains(&t) && k == 1.0);
                    for (s, x) in emit.iter_mut().zip(c) {
                        *s += x;
                    }
                    let mut pick = Some(0);
                    m.emit_importance(&mut c, &mut pick, 0.5);
                    read += c[0];
                    assert_eq!((c[1], c[2]), (0.0, 0.0), "only band 0 re-emits");
                    continue;
                }
                Flight::Absorbed => continue,
            };
            for (s, x) in into.iter_mut().zip(c) {
                *s += x;
            }
        }
        let sigma_t = [7.0, 2.0, 0.0];
        let sigma_s = [1.0, 2.0, 0.0];
        let collided = |b: usize| {
            if sigma_t[b] > 0.0 {
                (1.0 - f64::exp(-sigma_t[b] * d)) / sigma_t[b]
            } else {
                d
            }
        };
        for b in 0..3 {
            let want = [
                (-sigma_t[b] * d).exp(),
                sigma_s[b] * collided(b),
                kappa[b] * collided(b),
            ];
            let got = [pass[b], scatter[b], emit[b]].map(|s| s / n as f64);
            for (k, (g, w)) in got.iter().zip(want).enumerate() {
                assert!(
                    (g - w).abs() < 0.01 * w.max(0.1),
                    "band {b}, part {k}: {g} against {w}"
                );
            }
        }
        // Its mean: Σ_b (the weight toward ψ_b) σa_0 m_0b / κ_b.
        let want_read: f64 = (1..3)
            .map(|b| kappa[b] * collided(b) * 6.0 * [0.0, 0.5, 0.25][b] / kappa[b])
            .sum();
        let got = read / n as f64;
        assert!(
            (got - want_read).abs() < 0.01 * want_read,
            "{got} against {want_read}"
        );
    }
}

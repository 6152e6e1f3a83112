//! Direct light by light sampling at the vertices (the light-sampling estimator).
//!
//! A vertex's map value is the hat-weighted mean of the irradiance over its support (the
//! triangles around it, weighted by the vertex's barycentric coordinate): what a photon
//! deposit with barycentric weights estimates. Its direct part is estimated here without
//! photons: points x are drawn over the support with exactly that density (a triangle by
//! area, then the vertex's barycentric coordinate from its Beta(2, 2) marginal by the
//! inverse CDF λ = ½ − sin(asin(1 − 2u)/3), the other two split uniformly), a light is
//! chosen by power (the photons' table), a point on it by area, and a shadow ray decides
//! visibility.
//!
//! Every estimate is unbiased. The samples of one vertex in one *pass* are the first
//! `samples` points of an Owen-scrambled Sobol sequence (`sobol_burley`) whose scramble is
//! seeded by (seed, pass, slot): stratified within the pass, independent between passes,
//! so the variance over passes is an exact estimate of the error (`imap::DirectAcc`).
//!
//! Passes ride on photon indices, so everything that composes photon sets (ranges, shards,
//! resumes, merges) composes the direct part too: photon k with j = k mod R < C (R photons
//! per pass, C chunks of `CHUNK_SLOTS` map slots) also computes pass ⌊k / R⌋ of chunk j,
//! once its own path has ended. What photon k adds depends only on (seed, k).
//!
//! Photons bring the direct part too, and the two are combined by multiple importance
//! sampling over the pair (point x on the surface, point y on the light): a photon's first
//! deposit (and sensor crossings before its first surface event) is weighted, per vertex,
//! by w_P = P² / (P² + L²), and a light sample of vertex v by w_L = L² / (P² + L²), where
//! P = R·p(x | y) is the photons' density of landing at x per pass (p: the light's
//! direction density at y times cos θx / r²) and L = G·S·λv(x)/Av the light samples' (λv
//! the vertex's hat at x, Av its area, G = `LIGHT_SAMPLE_GAIN`). The weights add up to 1
//! at every (x, y), so the sum is unbiased whatever they are; they hand the direct light
//! to photons where light sampling is poor (a narrow spot or beam; a vertex whose support
//! is large against its distance to the light, or right next to an emitting surface: the
//! photons play the part a cosine-distributed ray from x would, which was measured and cost
//! more than it brought, BENCHMARKS.md) and to the light samples everywhere else. Photon
//! deposits after the first surface event are the indirect part, weight 1.

use crate::accel::Accel;
use crate::imap::DirectAcc;
use crate::sampling::warp;
use crate::scene::{EmitterKind, LightShape, PreparedScene};
use glam::DVec3;
use std::f64::consts::PI;

/// Map slots per chunk of a pass: the direct work photon k takes on.
pub const CHUNK_SLOTS: usize = 16;
/// Samples per vertex per pass unless a run says.
pub const DEFAULT_SAMPLES: u32 = 4;
/// Most samples per vertex per pass, a sensor's included: a photon's share of a pass (16
/// vertices) then takes at most ~16 k shadow rays, a few milliseconds, which a stop or a
/// cancel waits for at worst.
pub const MAX_SAMPLES: u32 = 1024;
/// How much more a stratified light sample counts than a photon landing at the same point
/// in the multiple-importance weights: any positive value keeps the map unbiased. A light
/// sample of smooth direct light has a small variance, a photon's landing in a vertex's
/// support the variance of a count; the balance of sample densities alone handed the
/// direct light of coarse calculation grids to photons (BENCHMARKS.md).
pub const LIGHT_SAMPLE_GAIN: f64 = 64.0;

/// Which estimator a map is made with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Estimator {
    /// Photons deposit everything they bring (the first paper's method).
    Photons,
    /// Direct light by light sampling at the vertices, photons the indirect part.
    LightSampling {
        /// Samples per vertex per pass.
        samples: u32,
        /// Photons per pass (R).
        pass_photons: u64,
    },
}

impl Estimator {
    /// Light sampling with automatic settings.
    pub const DEFAULT: Estimator = Estimator::LightSampling {
        samples: 0,
        pass_photons: 0,
    };

    pub fn is_light_sampling(&self) -> bool {
        matches!(self, Estimator::LightSampling { .. })
    }

    pub fn name(&self) -> String {
        match self {
            Estimator::Photons => "the photons-only estimator".into(),
            Estimator::LightSampling {
                samples,
                pass_photons,
            } => format!(
                "light sampling ({samples} samples per vertex per pass, {pass_photons} photons per pass)"
            ),
        }
    }
}

/// Photons per pass when a run does not say, for a map of `slots` slots of which `lit`
/// have area and are not sensors: a pass's shadow rays about half as many as its photons (whose paths take
/// several rays each: measured best on the benchmark scenes, BENCHMARKS.md), at least one
/// photon per chunk, a multiple of 64.
pub fn auto_pass_photons(lit: usize, slots: usize, samples: u32) -> u64 {
    let chunks = chunks(slots);
    let rays = lit as u64 * samples as u64;
    (rays * 2).max(chunks).max(64).div_ceil(64) * 64
}

/// Chunks of a pass (C) over `slots` map slots.
pub fn chunks(slots: usize) -> u64 {
    slots.div_ceil(CHUNK_SLOTS) as u64
}

/// Map slots with area (those passes visit) of the sensor meshes, or of the others.
pub fn lit_slots(scene: &PreparedScene, sensors: bool) -> usize {
    scene
        .meshes
        .iter()
        .filter(|m| m.slot_base.is_some() && m.sensor == sensors)
        .map(|m| m.vertex_area.iter().filter(|&&a| a > 0.0).count() * m.sides())
        .sum()
}

/// A vertex's triangles with their area shares, per recording mesh (CSR).
#[derive(Debug, Default)]
struct Adjacency {
    first: Vec<u32>,
    tris: Vec<u32>,
    /// Cumulative area fraction within the vertex's list (the last is 1).
    cdf: Vec<f32>,
}

/// What the direct passes need of a prepared scene, built once per scene.
#[derive(Debug)]
pub struct DirectPlan {
    adjacency: Vec<Option<Adjacency>>,
    /// Per mesh whose regions have parts (triangles of several materials, tallied): the
    /// vertices on a border between parts. Their direct light is left to the photons
    /// (no light samples): a part's flux then stays exact, its photon tallies holding
    /// the border and the vertices inside it holding only their part's light.
    border: Vec<Option<Vec<bool>>>,
    /// The passes' order of the map's slots: (first index in that order, mesh), meshes
    /// that are not sensors first, so sensors leave every other mesh's passes as they are.
    bases: Vec<(usize, u32)>,
    pub slots: usize,
    /// Chunks of a pass (C).
    pub chunks: u64,
    /// How many times a run's samples per pass a sensor's vertex takes: calculation grids
    /// are few points with large supports, which a few samples per pass serve poorly; their
    /// passes may take up to a quarter of the other vertices' (1 to `MAX_SENSOR_FACTOR`).
    pub sensor_factor: u32,
}

/// Most samples per pass a sensor's vertex takes, in run samples (`sensor_factor`).
pub const MAX_SENSOR_FACTOR: u32 = 64;

impl DirectPlan {
    pub fn new(scene: &PreparedScene) -> Self {
        let mut bases = Vec::new();
        let mut at = 0;
        for sensors in [false, true] {
            for (i, m) in scene.meshes.iter().enumerate() {
                if m.slot_base.is_some() && m.sensor == sensors {
                    bases.push((at, i as u32));
                    at += m.vertex_area.len() * m.sides();
                }
            }
        }
        let adjacency = scene
            .meshes
            .iter()
            .map(|m| {
                m.slot_base?;
                let nv = m.vertices.len();
                let mut count = vec![0u32; nv + 1];
                for (t, tri) in m.triangles.iter().enumerate() {
                    if m.area(t) > 0.0 {
                        for &v in tri {
                            count[v as usize + 1] += 1;
                        }
                    }
                }
                for v in 0..nv {
                    count[v + 1] += count[v];
                }
                let mut at = count.clone();
                let total = count[nv] as usize;
                let (mut tris, mut area) = (vec![0u32; total], vec![0f64; total]);
                for (t, tri) in m.triangles.iter().enumerate() {
                    let a = m.area(t);
                    if a > 0.0 {
                        for &v in tri {
                            let k = at[v as usize] as usize;
                            tris[k] = t as u32;
                            area[k] = a;
                            at[v as usize] += 1;
                        }
                    }
                }
                let mut cdf = vec![0f32; total];
                for v in 0..nv {
                    let r = count[v] as usize..count[v + 1] as usize;
                    let sum: f64 = area[r.clone()].iter().sum();
                    let mut c = 0.0;
                    for k in r.clone() {
                        c += area[k];
                        cdf[k] = (c / sum) as f32;
                    }
                    if let Some(last) = r.last() {
                        cdf[last] = 1.0;
                    }
                }
                Some(Adjacency {
                    first: count,
                    tris,
                    cdf,
                })
            })
            .collect();
        let slots = scene.slots;
        let border = scene
            .meshes
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let r = scene.regions.meshes.get(i)?.as_ref()?;
                if r.parts.is_empty() {
                    return None;
                }
                let mut first = vec![u32::MAX; m.vertices.len()];
                let mut border = vec![false; m.vertices.len()];
                for (t, tri) in m.triangles.iter().enumerate() {
                    let mat = m.material(t);
                    for &v in tri {
                        let f = &mut first[v as usize];
                        if *f == u32::MAX {
                            *f = mat;
                        } else if *f != mat {
                            border[v as usize] = true;
                        }
                    }
                }
                Some(border)
            })
            .collect();
        let (others, sensors) = (lit_slots(scene, false), lit_slots(scene, true));
        let sensor_factor = if sensors == 0 {
            1
        } else {
            (others / (4 * sensors)).clamp(1, MAX_SENSOR_FACTOR as usize) as u32
        };
        DirectPlan {
            border,
            adjacency,
            bases,
            slots,
            chunks: chunks(slots),
            sensor_factor,
        }
    }

    /// The mesh, vertex, side and map slot of index `i` of the passes' order.
    #[inline]
    fn locate(&self, scene: &PreparedScene, i: usize) -> (usize, usize, usize, usize) {
        let k = self.bases.partition_point(|b| b.0 <= i) - 1;
        let (base, mesh) = self.bases[k];
        let m = &scene.meshes[mesh as usize];
        let sides = m.sides();
        let (v, side) = ((i - base) / sides, (i - base) % sides);
        let slot = m.slot(v as u32, side).expect("recording mesh");
        (mesh as usize, v, side, slot)
    }
}

/// The direct passes of one run.
pub struct DirectSampler<'a> {
    pub plan: &'a DirectPlan,
    pub scene: &'a PreparedScene,
    pub accel: &'a Accel,
    pub acc: &'a DirectAcc,
    pub seed: u64,
    pub samples: u32,
    pub pass_photons: u64,
    pub unit_m: f64,
}

#[inline]
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The scramble seed of (run seed, pass, index of the vertex side in the passes' order).
#[inline]
fn scramble(seed: u64, pass: u64, i: usize) -> u32 {
    let h = mix(mix(mix(seed ^ 0xD1B5_4A32_D192_ED03).wrapping_add(pass)) ^ i as u64);
    (h >> 32) as u32
}

/// The vertex's barycentric coordinate, Beta(2, 2)-distributed, from u in [0, 1).
#[inline]
fn hat_coordinate(u: f64) -> f64 {
    (0.5 - ((1.0 - 2.0 * u).asin() / 3.0).sin()).clamp(0.0, 1.0)
}

/// The power heuristic's weight of the strategy of density `a` against one of `b`.
#[inline]
fn power(a: f64, b: f64) -> f64 {
    if a == b {
        // Both 0 or both ∞ (degenerate): halves, which still add up to 1.
        return 0.5;
    }
    if a.is_infinite() || b == 0.0 {
        return 1.0;
    }
    if b.is_infinite() || a == 0.0 {
        return 0.0;
    }
    let r = b / a;
    1.0 / (1.0 + r * r)
}

impl DirectSampler<'_> {
    /// The photons' density P (per pass) of landing at x from y on emitter `e` along unit
    /// `dir` (from y to x), r² = |x − y|², cos θx = `cos_x`, and for an emitting mesh
    /// cos θy = `cos_y`.
    #[inline]
    fn photon_density(&self, e: usize, dir: DVec3, r2: f64, cos_x: f64, cos_y: f64) -> f64 {
        let r = self.pass_photons as f64;
        match &self.scene.emitters[e].kind {
            EmitterKind::Light(LightShape::Beam { aperture, .. }) => r * cos_x / aperture.area(),
            EmitterKind::Light(shape) => r * shape.intensity_per_watt(dir) * cos_x / r2,
            EmitterKind::Mesh { two_sided, .. } => {
                let sides = if *two_sided { 2.0 } else { 1.0 };
                r * cos_y * cos_x / (PI * sides * r2)
            }
        }
    }

    /// Samples per pass of vertex `v` of mesh `mi`: a sensor's take `sensor_factor` times
    /// the run's; a border vertex's none (`DirectPlan::border`).
    #[inline]
    fn samples_at(&self, mi: usize, v: usize) -> u32 {
        if self.plan.border[mi].as_ref().is_some_and(|b| b[v]) {
            0
        } else if self.scene.meshes[mi].sensor {
            (self.samples * self.plan.sensor_factor).min(MAX_SAMPLES)
        } else {
            self.samples
        }
    }

    /// The light samples' density L of vertex `v` of mesh `mi` at a point where its hat is
    /// `hat`.
    #[inline]
    fn light_density(&self, mi: usize, v: usize, hat: f64) -> f64 {
        let a = self.scene.meshes[mi].vertex_area[v];
        if a > 0.0 {
            LIGHT_SAMPLE_GAIN * self.samples_at(mi, v) as f64 * hat / a
        } else {
            0.0
        }
    }

    /// The weights of a photon's direct deposit at barycentric (u, v) of triangle `prim`
    /// of recording mesh `mesh`, from emitter `e`'s point `y` along unit `dir`, for the
    /// triangle's three vertices. `cos_y`: the photon's cosine at an emitting mesh.
    #[allow(clippy::too_many_arguments)]
    pub fn photon_weights(
        &self,
        e: usize,
        y: DVec3,
        cos_y: f64,
        dir: DVec3,
        mesh: u32,
        prim: u32,
        u: f32,
        v: f32,
    ) -> [f32; 3] {
        let m = &self.scene.meshes[mesh as usize];
        let x = m.point(prim as usize, u, v);
        let n = m.normals[prim as usize].as_dvec3();
        let cos_x = dir.dot(n).abs();
        let p = self.photon_density(e, dir, (x - y).length_squared(), cos_x, cos_y.abs());
        let (u, v) = (u as f64, v as f64);
        let tri = m.triangles[prim as usize];
        let mut w = [1.0f32; 3];
        for (k, hat) in [1.0 - u - v, u, v].into_iter().enumerate() {
            let l = self.light_density(mesh as usize, tri[k] as usize, hat);
            w[k] = power(p, l) as f32;
        }
        w
    }

    /// Photon `k`'s share of the direct passes (nothing for most photons).
    pub fn photon_done(&self, k: u64) {
        let j = k % self.pass_photons;
        if j >= self.plan.chunks {
            return;
        }
        let mut sums = Vec::new();
        let sums = &mut sums;
        let pass = k / self.pass_photons;
        let scene = self.scene;
        let nb = scene.emitters.first().map_or(0, |e| e.colour.len());
        let layers = scene.layers;
        let groups = layers.groups as usize;
        sums.clear();
        sums.resize(nb * (groups + 1), 0.0);
        let lo = j as usize * CHUNK_SLOTS;
        let hi = (lo + CHUNK_SLOTS).min(self.plan.slots);
        let unit2 = self.unit_m * self.unit_m;
        for i in lo..hi {
            let (mi, v, side, slot) = self.plan.locate(scene, i);
            let mesh = &scene.meshes[mi];
            let area = mesh.vertex_area[v];
            if area <= 0.0 {
                continue;
            }
            // A border vertex's passes are empty, but counted.
            let samples = self.samples_at(mi, v);
            sums[..nb * groups].fill(0.0);
            let seed = scramble(self.seed, pass, i);
            let adj = self.plan.adjacency[mi].as_ref().expect("recording mesh");
            let list = adj.first[v] as usize..adj.first[v + 1] as usize;
            for i in 0..samples {
                let a = sobol_burley::sample_4d(i, 0, seed).map(f64::from);
                let b = sobol_burley::sample_4d(i, 1, seed).map(f64::from);
                // The point on the support: a triangle by area, then the hat's density.
                let k = list.start
                    + adj.cdf[list.clone()]
                        .iter()
                        .position(|&c| (a[0] as f32) < c)
                        .unwrap_or(list.len() - 1);
                let t = adj.tris[k] as usize;
                let tri = mesh.triangles[t];
                let c = tri.iter().position(|&x| x as usize == v).unwrap_or(0);
                let p = |o: usize| mesh.vertices[tri[(c + o) % 3] as usize].as_dvec3();
                let lv = hat_coordinate(a[1]);
                let rest = 1.0 - lv;
                let x = p(0) * lv + p(1) * (rest * a[2]) + p(2) * (rest * (1.0 - a[2]));
                let mut n = mesh.normals[t].as_dvec3();
                if side == 1 {
                    n = -n;
                }
                let l = self.light_density(mi, v, lv);
                let at = Point {
                    on: x,
                    x: x + n * scene.offset_at(x),
                    n,
                    l,
                };
                self.light_sample(&at, a[3], [b[0], b[1], b[2]], sums, nb);
            }
            // Irradiance (W/m²) times the vertex's area (m²): the pass's flux estimate.
            let k = area * unit2 / samples.max(1) as f64;
            let (per_group, total) = sums.split_at_mut(nb * groups);
            total.fill(0.0);
            for g in 0..groups {
                let s = &mut per_group[g * nb..(g + 1) * nb];
                s.iter_mut().for_each(|x| *x *= k);
                for (t, x) in total.iter_mut().zip(s.iter()) {
                    *t += x;
                }
                self.acc.add_pass(layers.cell(slot, g as u8), s);
            }
            if groups > 1 {
                let m = total.iter().sum::<f64>() / nb as f64;
                self.acc.add_total_square(layers.cell(slot, 0), m * m);
            }
            if let Some(d) = layers.direct_layer() {
                self.acc.add_pass(layers.cell(slot, d), total);
            }
        }
    }

    /// Adds `weight` (W/m² per unit of the emitter's colour) of emitter `e` to `sums`.
    #[inline]
    fn add(&self, e: usize, weight: f64, sums: &mut [f64], nb: usize) {
        if !(weight > 0.0 && weight.is_finite()) {
            return;
        }
        let em = &self.scene.emitters[e];
        let g = em.layer as usize;
        let k = weight * self.scene.total_power / nb as f64 / (self.unit_m * self.unit_m);
        for (s, c) in sums[g * nb..(g + 1) * nb].iter_mut().zip(&em.colour) {
            *s += k * c;
        }
    }

    /// Whether the segment from `x` to `y` is free (y's own surface excluded).
    #[inline]
    fn visible(&self, x: DVec3, y: DVec3) -> Option<(DVec3, f64)> {
        let d = y - x;
        let r = d.length();
        if !(r > 0.0 && r.is_finite()) {
            return None;
        }
        let dir = d / r;
        // Stop short of y by a few hundred f32 steps of the largest of the coordinates and
        // the distance (the ray's own precision): the offset at y alone is too small for
        // a light near the scene's centre seen from afar.
        let eps = self
            .scene
            .offset_at(y)
            .max(self.scene.offset_at(x))
            .max(4e-6 * r);
        let t_max = r - 2.0 * eps;
        if t_max > 0.0 && self.accel.occluded(x, dir, t_max) {
            return None;
        }
        Some((dir, r))
    }

    /// One light sample at `at`.
    fn light_sample(&self, at: &Point, u: f64, w: [f64; 3], sums: &mut [f64], nb: usize) {
        let scene = self.scene;
        let (x, n) = (at.x, at.n);
        let e = scene.emitter_table.sample(u);
        let em = &scene.emitters[e];
        match &em.kind {
            EmitterKind::Light(LightShape::Beam { axis, aperture }) => {
                let cos_x = -axis.dot(n);
                let t = (x - em.position).dot(*axis);
                if cos_x <= 0.0 || t <= 0.0 {
                    return;
                }
                let q = x - *axis * t;
                if !aperture.contains(q - em.position) {
                    return;
                }
                if self.visible(x, q).is_none() {
                    return;
                }
                let mis = power(at.l, self.photon_density(e, *axis, t * t, cos_x, 1.0));
                self.add(e, mis * cos_x / aperture.area(), sums, nb);
            }
            EmitterKind::Light(shape) => {
                let y = match shape.aperture() {
                    Some(a) => em.position + a.sample(w[0], w[1]),
                    None => em.position,
                };
                let Some((dir, r)) = self.visible(x, y) else {
                    return;
                };
                let cos_x = dir.dot(n);
                if cos_x <= 0.0 {
                    return;
                }
                let r2 = (at.on - y).length_squared();
                let mis = power(at.l, self.photon_density(e, -dir, r2, cos_x, 1.0));
                let g = shape.intensity_per_watt(-dir) * cos_x / (r * r);
                self.add(e, mis * g, sums, nb);
            }
            EmitterKind::Mesh {
                mesh,
                triangles,
                two_sided,
            } => {
                let m = &scene.meshes[*mesh];
                let t = triangles.sample(w[2]);
                let [a, b, c] = m.triangles[t].map(|i| m.vertices[i as usize].as_dvec3());
                let (b1, b2) = warp::uniform_triangle(w[0], w[1]);
                let y = a + (b - a) * b1 + (c - a) * b2;
                let ny = m.normals[t].as_dvec3();
                let Some((dir, r)) = self.visible(x, y) else {
                    return;
                };
                let cos_x = dir.dot(n);
                let mut cos_y = -dir.dot(ny);
                if *two_sided {
                    cos_y = cos_y.abs();
                }
                if cos_x <= 0.0 || cos_y <= 0.0 {
                    return;
                }
                let sides = if *two_sided { 2.0 } else { 1.0 };
                let r2 = (at.on - y).length_squared();
                let mis = power(at.l, self.photon_density(e, -dir, r2, cos_x, cos_y));
                self.add(e, mis * cos_x * cos_y / (PI * sides * r * r), sums, nb);
            }
        }
    }
}

/// A light-sample point: `on` the surface, `x` moved off it along the side's normal `n`,
/// and the light samples' density there (`light_density`).
struct Point {
    on: DVec3,
    x: DVec3,
    n: DVec3,
    l: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hat_coordinate_inverts_the_beta_2_2_cdf() {
        for i in 0..=100 {
            let u = i as f64 / 100.0;
            let l = hat_coordinate(u);
            assert!(
                (3.0 * l * l - 2.0 * l * l * l - u).abs() < 1e-12,
                "u {u}: λ {l}"
            );
        }
    }
}

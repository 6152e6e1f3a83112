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
//!
//! With `gather` each sample's point x also starts a gathering path (`gather`) that takes a
//! light sample at every diffuse surface z it meets: the light → z → … → x paths whose
//! first surface event z is diffuse and that meet no dielectric. Photons on such paths
//! weight their deposits against it by the same power heuristic, p being their landing
//! density at z (`landing_density`) and L the samples' density at x times `GATHER_GAIN`;
//! photons bring the rest (caustics) alone (`Tracer::follow`).

use super::{Colour, WEIGHTED_BOUNCES_DOWN_TO};
use crate::accel::Accel;
use crate::sampling::{warp, PhotonRng};
use crate::scene::bsdf::Lobe;
use crate::scene::{LightSample, Material, PreparedScene, Receiver};
use crate::spectral::Transmittance;
use glam::DVec3;
use std::f64::consts::PI;

/// Map slots per chunk of a pass: the direct work photon k takes on.
pub const CHUNK_SLOTS: usize = 16;
/// Samples per vertex per pass unless a run says: light sampling alone, and gathering
/// (whose paths' integrand is rougher: more samples per pass stratify it better).
pub const DEFAULT_SAMPLES: u32 = 4;
pub const GATHER_SAMPLES: u32 = 16;
/// Most samples per vertex per pass, a sensor's included: a photon's share of a pass (16
/// vertices) then takes at most ~16 k shadow rays, a few milliseconds (gathering: as many
/// paths of at most `GATHER_DEPTH` surfaces, a few more on average), which a stop or a
/// cancel waits for at worst.
pub const MAX_SAMPLES: u32 = 1024;
/// How much more a stratified light sample counts than a photon landing at the same point
/// in the multiple-importance weights: any positive value keeps the map unbiased. A light
/// sample of smooth direct light has a small variance, a photon's landing in a vertex's
/// support the variance of a count; the balance of sample densities alone handed the
/// direct light of coarse calculation grids to photons (BENCHMARKS.md).
pub const LIGHT_SAMPLE_GAIN: f64 = 64.0;
/// The same for a gathering path's light sample at a surface z against a photon whose first
/// surface event was at z (`DirectSampler::gather`): measured on the benchmark room, where
/// 2 to 32 gave the same time to 1 % (BENCHMARKS.md).
pub const GATHER_GAIN: f64 = 8.0;
/// Most surfaces a gathering path takes a light sample at: light that reaches x after more
/// surface events than this is the photons' alone (a photon's deposit after its
/// `GATHER_DEPTH`-th surface event keeps weight 1), so a path in a box of mirrors ends.
pub const GATHER_DEPTH: u32 = 32;

/// Which estimator a map is made with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Estimator {
    /// Photons deposit everything they bring (the first paper's method).
    Photons,
    /// Direct light by light sampling at the vertices, photons the indirect part; with
    /// `gather`, the passes gather the diffusely reflected light too (`DirectSampler::
    /// gather`), combined with the photons' by multiple importance sampling.
    LightSampling {
        /// Samples per vertex per pass (0: automatic).
        samples: u32,
        /// Photons per pass (R; 0: automatic).
        pass_photons: u64,
        /// Whether the passes gather indirect light.
        gather: bool,
    },
}

impl Estimator {
    /// Light sampling with automatic settings.
    pub const DEFAULT: Estimator = Estimator::LightSampling {
        samples: 0,
        pass_photons: 0,
        gather: false,
    };
    /// Light sampling and gathering with automatic settings.
    pub const GATHER: Estimator = Estimator::LightSampling {
        samples: 0,
        pass_photons: 0,
        gather: true,
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
                gather,
            } => format!(
                "light sampling{} ({samples} samples per vertex per pass, {pass_photons} photons per pass)",
                if *gather { " and gathering" } else { "" }
            ),
        }
    }
}

/// Photons per pass when a run does not say, for a map of `slots` slots of which `lit`
/// have area and are not sensors, at least one photon per chunk, a multiple of 64.
/// Light sampling alone: a pass's shadow rays about half as many as its photons (whose
/// paths take several rays each). Gathering: one photon per `SAMPLES_PER_PHOTON` samples
/// (light samples and gathering paths bring direct and diffusely reflected light far
/// cheaper than photons, which keep what they do best: narrow beams, light near its
/// source), or per `CAUSTIC_SAMPLES_PER_PHOTON` when the scene has `caustics` (specular
/// reflectance or dielectrics: light through them is the photons' alone). Measured best
/// on the benchmark scenes (BENCHMARKS.md).
pub fn auto_pass_photons(
    lit: usize,
    slots: usize,
    samples: u32,
    gather: bool,
    caustics: bool,
) -> u64 {
    let rays = lit as u64 * samples as u64;
    let r = match (gather, caustics) {
        (false, _) => rays * 2,
        (true, false) => rays / SAMPLES_PER_PHOTON,
        (true, true) => rays / CAUSTIC_SAMPLES_PER_PHOTON,
    };
    r.max(chunks(slots)).max(64).div_ceil(64) * 64
}

/// Samples of a pass per photon of `auto_pass_photons` (measured on the benchmark room,
/// BENCHMARKS.md).
pub const SAMPLES_PER_PHOTON: u64 = 64;
/// The same in a scene with specular surfaces or dielectrics.
pub const CAUSTIC_SAMPLES_PER_PHOTON: u64 = 4;
/// Samples per pass of a sensor's vertex, in run samples: calculation grids are few points
/// with large supports.
pub const SENSOR_SAMPLES: u32 = 4;
/// The sensors' passes take this share of the work of the other vertices' per photon:
/// sensors run on their own schedule of passes (`sensor_pass_photons`), so a calculation
/// grid converges in many short passes and changes no other vertex's.
pub const SENSOR_SHARE: f64 = 0.125;

/// Photons per pass of the sensors' passes, for `pass_photons` per pass of the other
/// vertices, `samples` per vertex per pass and the plan's lit slots and chunks.
pub fn sensor_pass_photons(pass_photons: u64, samples: u32, lit: [usize; 2], chunks: u64) -> u64 {
    if lit[0] == 0 || lit[1] == 0 {
        return pass_photons.max(2 * chunks).max(1);
    }
    let sensor_samples = (samples * SENSOR_SAMPLES).min(MAX_SAMPLES) as f64;
    let r = pass_photons as f64 * (lit[1] as f64 * sensor_samples)
        / (lit[0] as f64 * samples as f64 * SENSOR_SHARE);
    (r as u64).max(2 * chunks).max(1)
}

/// The sensors' pass and chunk photon `k` computes, if any, for `rs` photons per sensor
/// pass (at least 2·`c`) and `c` chunks: passes 0 and 1 at once (photons 0 … 2c − 1: a
/// grid has two passes, so an error estimate, from the start), then pass q + 1 at photons
/// q·rs … q·rs + c − 1.
#[inline]
pub fn sensor_pass(k: u64, rs: u64, c: u64) -> Option<(u64, u64)> {
    let (q, j) = (k / rs, k % rs);
    if j < c {
        Some((if q == 0 { 0 } else { q + 1 }, j))
    } else if q == 0 && j < 2 * c {
        Some((1, j - c))
    } else {
        None
    }
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
    /// Slots of the passes' order that are not sensors' (sensors' follow them).
    pub regular: usize,
    /// Chunks of a pass (C): of the other vertices, of the sensors'.
    pub chunks: [u64; 2],
    /// Lit slots (`lit_slots`): of the other vertices, of the sensors'.
    pub lit: [usize; 2],
    /// The recording meshes by their first map slot, in slot order (slot → mesh).
    slot_meshes: Vec<(usize, u32)>,
}

impl DirectPlan {
    /// The slots of the vertices that share a triangle with slot `slot`'s vertex, on its
    /// side (each once per shared triangle).
    pub fn neighbour_slots(&self, scene: &PreparedScene, slot: usize, f: &mut dyn FnMut(usize)) {
        let k = self.slot_meshes.partition_point(|b| b.0 <= slot);
        let Some(&(base, mesh)) = k.checked_sub(1).and_then(|k| self.slot_meshes.get(k)) else {
            return;
        };
        let m = &scene.meshes[mesh as usize];
        let sides = m.sides();
        let (v, side) = ((slot - base) / sides, (slot - base) % sides);
        let Some(adj) = &self.adjacency[mesh as usize] else {
            return;
        };
        let (Some(&a), Some(&b)) = (adj.first.get(v), adj.first.get(v + 1)) else {
            return;
        };
        for &t in &adj.tris[a as usize..b as usize] {
            for &u in &m.triangles[t as usize] {
                if u as usize != v {
                    if let Some(s) = m.slot(u, side) {
                        f(s);
                    }
                }
            }
        }
    }
}

/// Where the direct passes put their estimates: the map's direct accumulators, per vertex
/// slot and layer (`imap::DirectCells`). The passes know nothing else of the map.
pub trait DirectSink: Sync {
    /// Light-group layers (1 without groups).
    fn groups(&self) -> usize;
    /// The layer of the direct component alone, if the map keeps one.
    fn direct_layer(&self) -> Option<u8>;
    /// One pass's estimate per band at `slot` in `layer`.
    fn add_pass(&self, slot: usize, layer: u8, values: &[f64]);
    /// With several groups: the square of the pass's band-mean total at `slot`.
    fn add_total_square(&self, slot: usize, x: f64);
}

impl DirectPlan {
    /// The plan for `scene`; `parts[i]`: whether mesh i's map is split into material
    /// parts (its vertices on a border between parts take no light samples).
    pub fn new(scene: &PreparedScene, parts: &[bool]) -> Self {
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
                if !parts.get(i).copied().unwrap_or(false) {
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
        let regular = bases
            .iter()
            .find(|b| scene.meshes[b.1 as usize].sensor)
            .map_or(slots, |b| b.0);
        let slot_meshes = scene
            .meshes
            .iter()
            .enumerate()
            .filter_map(|(i, m)| Some((m.slot_base?, i as u32)))
            .collect();
        DirectPlan {
            border,
            adjacency,
            bases,
            slots,
            regular,
            chunks: [chunks(regular), chunks(slots - regular)],
            lit: [lit_slots(scene, false), lit_slots(scene, true)],
            slot_meshes,
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
    pub acc: &'a dyn DirectSink,
    pub seed: u64,
    pub samples: u32,
    pub pass_photons: u64,
    /// Photons per pass of the sensors' passes (`sensor_pass_photons`).
    pub sensor_pass_photons: u64,
    pub unit_m: f64,
    pub materials: &'a [Material],
    /// Whether the passes gather indirect light (`gather`).
    pub gather: bool,
    /// Safety limit on a gathering path's surface events (the tracer's; at most
    /// `GATHER_DEPTH`).
    pub max_events: u32,
}

/// First Sobol dimension of a sample's gathering path (0 to 7: the direct sample's).
const GATHER_DIM: u32 = 8;
/// Sobol dimensions a gathering path takes before it goes on with a random stream.
const SOBOL_DIMS: u32 = 32;
// `SampleDims` draws the Sobol dimensions in sets of four.
const _: () = assert!(GATHER_DIM % 4 == 0 && SOBOL_DIMS % 4 == 0);

/// The numbers of one sample: Owen-scrambled Sobol dimensions, four at a time
/// (`sample_4d`, the same numbers as one by one), then a random stream.
struct SampleDims {
    index: u32,
    seed: u32,
    dim: u32,
    four: [f32; 4],
    rng: PhotonRng,
}

impl SampleDims {
    #[inline]
    fn next(&mut self) -> f64 {
        if self.dim < SOBOL_DIMS {
            let k = (self.dim % 4) as usize;
            if k == 0 {
                self.four = sobol_burley::sample_4d(self.index, self.dim / 4, self.seed);
            }
            self.dim += 1;
            f64::from(self.four[k])
        } else {
            self.rng.uniform()
        }
    }
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
    /// The density p of one photon's landing at x from y on emitter `e` along unit `dir`
    /// (from y to x), r² = |x − y|², cos θx = `cos_x`, and for an emitting mesh cos θy =
    /// `cos_y` (P = R·p per pass; `light_density` holds the 1/R): the emitter's own
    /// (`Emitter::photon_density`), a sky's scaled by the light samples' gain.
    #[inline]
    fn photon_density(&self, e: usize, dir: DVec3, r2: f64, cos_x: f64, cos_y: f64) -> f64 {
        // Against the light samples' directions (`sample_light`): a sky's are half by its
        // radiance, half cosine-distributed.
        // A sky's direct light samples get no gain over the photons (the plain balance of
        // densities): through a window most of them find the roof, and photons entering
        // through it reach the floor as well (daylight_bench: 1 % in 4.1 instead of 7.0
        // s). The sun's, smooth and nearly certain, keep it. The factor scales the photon
        // density itself, which both sides of every comparison read, so it applies to
        // gathering too: there a sky's secondary light samples weigh GATHER_GAIN /
        // LIGHT_SAMPLE_GAIN = 1/8 against the photons (unbiased either way; measured only
        // as daylight_bench's gathering row).
        // A one-patch sky's light samples follow its density alone (`mixes_cosine`).
        self.scene.emitters[e].photon_density(dir, r2, cos_x, cos_y, |part, toward| {
            if !part.mixes_cosine() {
                return LIGHT_SAMPLE_GAIN;
            }
            let p = part.pdf(toward);
            LIGHT_SAMPLE_GAIN * p / (0.5 * p + 0.5 * cos_x / PI)
        })
    }

    /// Samples per pass of vertex `v` of mesh `mi`: a sensor's take `SENSOR_SAMPLES` times
    /// the run's; a border vertex's none (`DirectPlan::border`).
    #[inline]
    fn samples_at(&self, mi: usize, v: usize) -> u32 {
        if self.plan.border[mi].as_ref().is_some_and(|b| b[v]) {
            0
        } else if self.scene.meshes[mi].sensor {
            (self.samples * SENSOR_SAMPLES).min(MAX_SAMPLES)
        } else {
            self.samples
        }
    }

    /// The samples' density of vertex `v` of mesh `mi` at a point where its hat is `hat`,
    /// over the photons per pass of the vertex's schedule (R): compared with one photon's
    /// density, as L against P = R·p (times a gain).
    #[inline]
    fn light_density(&self, mi: usize, v: usize, hat: f64) -> f64 {
        let m = &self.scene.meshes[mi];
        let a = m.vertex_area[v];
        if a > 0.0 {
            let r = if m.sensor {
                self.sensor_pass_photons
            } else {
                self.pass_photons
            };
            self.samples_at(mi, v) as f64 * hat / (a * r as f64)
        } else {
            0.0
        }
    }

    /// The density p of one photon from emitter `e`'s point `y` (cosine `cos_y` there for
    /// an emitting mesh) along unit `dir` landing at `z` (geometric normal `n`). `dir` is
    /// the photon's own: recomputed from z, which holds the f32 barycentric coordinates'
    /// rounding, it could leave a narrow spot's cone.
    #[inline]
    pub fn landing_density(
        &self,
        e: usize,
        y: DVec3,
        cos_y: f64,
        dir: DVec3,
        z: DVec3,
        n: DVec3,
    ) -> f64 {
        let r2 = (z - y).length_squared();
        self.photon_density(e, dir, r2, dir.dot(n).abs(), cos_y.abs())
    }

    /// The weights of a photon's deposit at barycentric (u, v) of triangle `prim` of
    /// recording mesh `mesh` for the triangle's three vertices, against the light samples
    /// (`gain` `LIGHT_SAMPLE_GAIN`: direct light, `p` the photon's landing density there) or
    /// the gathering paths (`GATHER_GAIN`: `p` its landing density at its first surface
    /// event).
    pub fn vertex_weights(
        &self,
        p: f64,
        gain: f64,
        mesh: u32,
        prim: u32,
        u: f32,
        v: f32,
    ) -> [f32; 3] {
        let m = &self.scene.meshes[mesh as usize];
        let (u, v) = (u as f64, v as f64);
        let tri = m.triangles[prim as usize];
        let mut w = [1.0f32; 3];
        for (k, hat) in [1.0 - u - v, u, v].into_iter().enumerate() {
            let l = gain * self.light_density(mesh as usize, tri[k] as usize, hat);
            w[k] = power(p, l) as f32;
        }
        w
    }

    /// Photon `k`'s share of the passes (nothing for most photons): chunk k mod R of pass
    /// ⌊k / R⌋ of the vertices that are not sensors', and the same on the sensors' own
    /// schedule (`sensor_pass`).
    pub fn photon_done(&self, k: u64) {
        let plan = self.plan;
        let j = k % self.pass_photons;
        if j < plan.chunks[0] {
            let lo = j as usize * CHUNK_SLOTS;
            self.chunk(
                k / self.pass_photons,
                lo..(lo + CHUNK_SLOTS).min(plan.regular),
            );
        }
        if let Some((pass, j)) = sensor_pass(k, self.sensor_pass_photons, plan.chunks[1]) {
            let lo = plan.regular + j as usize * CHUNK_SLOTS;
            self.chunk(pass, lo..(lo + CHUNK_SLOTS).min(plan.slots));
        }
    }

    /// Pass `pass` of the slots `range` of the passes' order.
    fn chunk(&self, pass: u64, range: std::ops::Range<usize>) {
        let scene = self.scene;
        let nb = scene.emitters.first().map_or(0, |e| e.colour.len());
        let groups = self.acc.groups();
        // Per group: the direct sums, then the gathered (indirect) sums; then a total.
        let mut sums = vec![0.0; nb * (2 * groups + 1)];
        let white = vec![1.0; nb];
        let mut through = Colour::new(nb);
        let unit2 = self.unit_m * self.unit_m;
        for i in range {
            let (mi, v, side, slot) = self.plan.locate(scene, i);
            let mesh = &scene.meshes[mi];
            let area = mesh.vertex_area[v];
            if area <= 0.0 {
                continue;
            }
            // A border vertex's passes are empty, but counted.
            let samples = self.samples_at(mi, v);
            sums[..2 * nb * groups].fill(0.0);
            let seed = scramble(self.seed, pass, i);
            let adj = self.plan.adjacency[mi].as_ref().expect("recording mesh");
            let list = adj.first[v] as usize..adj.first[v + 1] as usize;
            let (direct, gathered) = sums.split_at_mut(nb * groups);
            for s in 0..samples {
                let a = sobol_burley::sample_4d(s, 0, seed).map(f64::from);
                let b = sobol_burley::sample_4d(s, 1, seed).map(f64::from);
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
                let density = self.light_density(mi, v, lv);
                let at = Point {
                    on: x,
                    x: x + n * scene.offset_at(x),
                    n,
                    l: LIGHT_SAMPLE_GAIN * density,
                };
                if let Some((e, g, _, tr)) = self.sample_light(&at, a[3], [b[0], b[1], b[2]]) {
                    self.add(e, (g, tr), None, direct, nb);
                }
                if self.gather {
                    let index = (pass.wrapping_mul(self.plan.slots as u64) + i as u64)
                        .wrapping_mul(MAX_SAMPLES as u64)
                        .wrapping_add(s as u64);
                    let mut dims = SampleDims {
                        index: s,
                        seed,
                        dim: GATHER_DIM,
                        four: [0.0; 4],
                        rng: PhotonRng::new(self.seed ^ 0x2545_F491_4F6C_DD1D, index),
                    };
                    through.reset(&white);
                    let l = GATHER_GAIN * density;
                    self.gather(&at, l, &mut dims, &mut through, gathered, nb);
                }
            }
            // Irradiance (W/m²) times the vertex's area (m²): the pass's flux estimate.
            let k = area * unit2 / samples.max(1) as f64;
            let (parts, total) = sums.split_at_mut(2 * nb * groups);
            let (direct, gathered) = parts.split_at_mut(nb * groups);
            total.fill(0.0);
            for g in 0..groups {
                let d = &mut direct[g * nb..(g + 1) * nb];
                d.iter_mut().for_each(|x| *x *= k);
                for (t, x) in total.iter_mut().zip(d.iter()) {
                    *t += x;
                }
            }
            if let Some(dl) = self.acc.direct_layer() {
                // The direct layer: the direct sums alone.
                self.acc.add_pass(slot, dl, total);
            }
            let mut sum = 0.0;
            for g in 0..groups {
                let d = &mut direct[g * nb..(g + 1) * nb];
                for (x, y) in d.iter_mut().zip(&gathered[g * nb..(g + 1) * nb]) {
                    *x += y * k;
                    sum += *x;
                }
                self.acc.add_pass(slot, g as u8, d);
            }
            if groups > 1 {
                let m = sum / nb as f64;
                self.acc.add_total_square(slot, m * m);
            }
        }
    }

    /// Adds `weight` (W/m² per unit of the emitter's colour) of emitter `e` to `sums`,
    /// per band times `through` (a gathering path's throughput) and `k` (the reflectance
    /// or transmittance that sends the light on), when given, and times the scene
    /// medium's transmittance `tr` on the light's way.
    #[inline]
    fn add(
        &self,
        e: usize,
        (weight, tr): (f64, Transmittance),
        path: Option<(&Colour, &[f64])>,
        sums: &mut [f64],
        nb: usize,
    ) {
        if !(weight > 0.0 && weight.is_finite()) {
            return;
        }
        let em = &self.scene.emitters[e];
        let g = em.layer as usize;
        let k = weight * self.scene.total_power / nb as f64 / (self.unit_m * self.unit_m);
        let s = &mut sums[g * nb..(g + 1) * nb];
        if !tr.is_clear() {
            // Through the scene's medium: per band, its own transmittance (cold: a scene
            // without one never comes here).
            return add_through_haze(&em.colour, k, tr, path, s);
        }
        match path {
            None => {
                for (s, c) in s.iter_mut().zip(&em.colour) {
                    *s += k * c;
                }
            }
            Some((through, coefficient)) => {
                for (((s, c), t), r) in s
                    .iter_mut()
                    .zip(&em.colour)
                    .zip(through.values())
                    .zip(coefficient)
                {
                    *s += k * c * t * r;
                }
            }
        }
    }

    /// The scene medium's transmittance on the segment from `x` along unit `dir` over `t`
    /// scene units (infinite: out of the scene); clear without one.
    #[inline]
    fn haze_tr(&self, x: DVec3, dir: DVec3, t: f64) -> Transmittance<'_> {
        self.scene.haze.as_ref().map_or(Transmittance::CLEAR, |h| {
            h.transmittance(x, dir, t, self.unit_m)
        })
    }

    /// The indirect light at a sample's point `at`, added to `sums` (W/m² per group): a
    /// path from x, cosine-distributed over the side (so its estimate of the irradiance is
    /// π times the radiance it finds), that at each surface it meets takes a light sample
    /// for the diffusely reflected and transmitted light toward x and goes on as a photon
    /// would (the same events, weighted while it keeps half its throughput, then Russian
    /// roulette). It ends at a dielectric: light through smooth interfaces (caustics) stays
    /// the photons' (`Tracer::follow` keeps those deposits), as does light whose first
    /// surface event was specular, and light from a fluorescent surface.
    #[allow(clippy::too_many_arguments)]
    fn gather(
        &self,
        at: &Point,
        l: f64,
        d: &mut SampleDims,
        t: &mut Colour,
        sums: &mut [f64],
        nb: usize,
    ) {
        let scene = self.scene;
        let mut dir = warp::cosine_hemisphere(at.n, d.next(), d.next());
        let mut org = at.x;
        let mut weights: Option<Vec<f64>> = None;
        let mut tint = crate::scene::texture::TintScratch::default();
        for _ in 0..self.max_events.min(GATHER_DEPTH) {
            let Some(hit) = self.accel.intersect(org, dir) else {
                return;
            };
            // Through the scene's medium, unscattered (light scattered in it is the photons').
            t.attenuate(self.haze_tr(org, dir, hit.t));
            let mesh = &scene.meshes[hit.mesh as usize];
            let prim = hit.prim as usize;
            let material =
                scene.material_at(self.materials, hit.mesh, prim, (hit.u, hit.v), &mut tint);
            let bsdf = material.bsdf();
            // A dielectric or a fluorescent surface ends the path: the light through or
            // from it is the photons' (`Tracer::follow` keeps those deposits whole).
            if bsdf.interface().is_some() || material.fluorescence.is_some() {
                return;
            }
            let ng = mesh.normals[prim].as_dvec3();
            let n_in = if dir.dot(ng) < 0.0 { ng } else { -ng };
            let (p, eps) = scene.leaving_point(mesh, prim, hit.u, hit.v);
            if let Some(g) = bsdf.glossy() {
                // A rough dielectric ends the path as a smooth one does; a glossy
                // reflector takes a light sample weighed by π f toward x when rough enough
                // (`Bsdf::gathers`, as the photons' first events there), and the path goes
                // on by its sampling.
                if g.transmits() {
                    return;
                }
                let front = dir.dot(ng) < 0.0;
                let frame = bsdf.frame(n_in);
                let to_x = frame.to_local(-dir);
                let w = weights.get_or_insert_with(|| vec![0.0; nb]);
                if bsdf.gathers() {
                    let y = Point {
                        on: p,
                        x: p + n_in * eps,
                        n: n_in,
                        l,
                    };
                    let u = d.next();
                    let v = [d.next(), d.next(), d.next()];
                    if let Some((e, gl, from, tr)) = self.sample_light(&y, u, v) {
                        g.eval(frame.to_local(from), to_x, 0, front, w);
                        w.iter_mut().for_each(|x| *x *= PI);
                        self.add(e, (gl, tr), Some((t, w)), sums, nb);
                    }
                }
                let u = [d.next(), d.next(), d.next()];
                let u_survive = d.next();
                // A direction drawn from x's side, f read the way light travels: from it
                // toward x.
                let Some((wi, _)) = bsdf.sample_against_light(n_in, front, -dir, u, w) else {
                    return;
                };
                let mean = t.weighted_mean(w);
                if !(mean > 0.0 && mean.is_finite()) {
                    return;
                }
                if t.mean() >= WEIGHTED_BOUNCES_DOWN_TO {
                    t.reweight(w, 1.0);
                } else {
                    let q = mean.min(1.0);
                    if u_survive >= q {
                        return;
                    }
                    t.reweight(w, q);
                }
                dir = wi;
                org = p + n_in * eps;
                continue;
            }
            // Light scattered diffusely toward x: reflected from the side the path arrived
            // on, transmitted from the other.
            for lobe in [Lobe::DiffuseReflection, Lobe::DiffuseTransmission] {
                if !bsdf.has(lobe) {
                    continue;
                }
                let n = lobe.leaving_normal(n_in);
                let y = Point {
                    on: p,
                    x: p + n * eps,
                    n,
                    l,
                };
                let u = d.next();
                let w = [d.next(), d.next(), d.next()];
                if let Some((e, g, _, tr)) = self.sample_light(&y, u, w) {
                    self.add(e, (g, tr), Some((t, bsdf.albedo(lobe))), sums, nb);
                }
            }
            // Go on as a photon would.
            let mut u = d.next();
            let weigh = t.mean() >= WEIGHTED_BOUNCES_DOWN_TO;
            let mut survive = 1.0;
            if weigh {
                survive = bsdf.survival(|k| t.weighted_mean(k));
                if survive.is_nan() || survive <= 0.0 {
                    return;
                }
                u *= survive;
            }
            let chosen = bsdf.choose(u, |k| t.weighted_mean(k));
            if let Some((_, k, p)) = chosen {
                t.reweight(k, p);
            }
            if weigh {
                t.scale(survive);
            }
            let (u1, u2) = (d.next(), d.next());
            let Some((lobe, _, _)) = chosen else {
                return;
            };
            dir = lobe.direction(dir, n_in, u1, u2);
            org = p + lobe.leaving_normal(n_in) * eps;
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

    /// One light sample at `at`: the emitter, its irradiance at x per unit of its colour
    /// (W/m² before `add`'s conversion), MIS-weighted against photons unless `at.l` is
    /// infinite, the direction it arrives from, and the scene medium's transmittance on its
    /// way (clear without one). The MIS weights leave the medium out on both sides (the
    /// photons' `deposit` too): they stay a partition of unity.
    fn sample_light(
        &self,
        at: &Point,
        u: f64,
        w: [f64; 3],
    ) -> Option<(usize, f64, DVec3, Transmittance<'_>)> {
        let scene = self.scene;
        let (x, n) = (at.x, at.n);
        let e = scene.emitter_table.sample(u);
        let em = &scene.emitters[e];
        if !em.media.is_empty() {
            // A light inside a scattering medium: its light is the photons' alone.
            return None;
        }
        let receiver = Receiver { n, p_front: 1.0 };
        match em.sample_toward(&scene.meshes, x, receiver, w, || true)? {
            LightSample::Beam {
                foot,
                t,
                axis,
                area,
            } => {
                let cos_x = -axis.dot(n);
                if cos_x <= 0.0 {
                    return None;
                }
                let (_, r) = self.visible(x, foot)?;
                let mis = power(at.l, self.photon_density(e, axis, t * t, cos_x, 1.0));
                let tr = self.haze_tr(x, -axis, r);
                Some((e, mis * cos_x / area, -axis, tr))
            }
            LightSample::Direction {
                toward,
                pdf: q,
                value: f,
                reach,
                norm,
            } => {
                let cos_x = toward.dot(n);
                if cos_x <= 0.0 || f <= 0.0 || q <= 0.0 {
                    return None;
                }
                if self.accel.occluded(x, toward, reach) {
                    return None;
                }
                let mis = power(at.l, self.photon_density(e, -toward, 1.0, cos_x, 1.0));
                // L cos / q per watt of the source (L = f / norm per watt).
                let g = f * cos_x / (q * norm);
                Some((e, mis * g, toward, self.haze_tr(x, toward, f64::INFINITY)))
            }
            LightSample::Point(y) => {
                let (dir, r) = self.visible(x, y)?;
                let cos_x = dir.dot(n);
                if cos_x <= 0.0 {
                    return None;
                }
                let r2 = (at.on - y).length_squared();
                let mis = power(at.l, self.photon_density(e, -dir, r2, cos_x, 1.0));
                let g = em.intensity_per_watt(-dir) * cos_x / (r * r);
                Some((e, mis * g, dir, self.haze_tr(x, dir, r)))
            }
            LightSample::Area { point: y, normal } => {
                let two_sided = em.two_sided();
                let (dir, r) = self.visible(x, y)?;
                let cos_x = dir.dot(n);
                let mut cos_y = -dir.dot(normal);
                if two_sided {
                    cos_y = cos_y.abs();
                }
                if cos_x <= 0.0 || cos_y <= 0.0 {
                    return None;
                }
                let sides = if two_sided { 2.0 } else { 1.0 };
                let r2 = (at.on - y).length_squared();
                let mis = power(at.l, self.photon_density(e, -dir, r2, cos_x, cos_y));
                let g = mis * cos_x * cos_y / (PI * sides * r * r);
                Some((e, g, dir, self.haze_tr(x, dir, r)))
            }
        }
    }
}

/// `DirectSampler::add` for light of colour `colour` (`k` W/m² per unit of it) that
/// crossed the scene's medium with transmittance `tr`.
#[cold]
#[inline(never)]
fn add_through_haze(
    colour: &[f64],
    k: f64,
    tr: Transmittance,
    path: Option<(&Colour, &[f64])>,
    s: &mut [f64],
) {
    for (b, (s, c)) in s.iter_mut().zip(colour).enumerate() {
        let p = path.map_or(1.0, |(t, r)| t.values()[b] * r[b]);
        *s += k * c * tr.at(b) * p;
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
    fn sensor_passes_come_once_each_two_at_the_start() {
        for (rs, c) in [(2, 1), (10, 3), (64, 7), (1000, 1)] {
            let mut seen = std::collections::BTreeMap::new();
            for k in 0..50 * rs {
                if let Some((pass, j)) = sensor_pass(k, rs, c) {
                    assert!(j < c, "rs {rs} c {c} k {k}");
                    assert!(seen.insert((pass, j), k).is_none(), "rs {rs} c {c}: twice");
                }
            }
            // Every chunk of passes 0 … 50 exactly once; passes 0 and 1 within the first
            // 2c photons, pass q + 1 from photon q·rs.
            assert_eq!(seen.len() as u64, 51 * c, "rs {rs} c {c}");
            for (&(pass, j), &k) in &seen {
                let start = if pass < 2 { pass * c } else { (pass - 1) * rs };
                assert_eq!(k, start + j, "rs {rs} c {c} pass {pass} chunk {j}");
            }
        }
    }

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

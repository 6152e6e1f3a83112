//! Forward light tracing with unit-energy photons (Khodulev & Kopylov 1996; the first paper,
//! §1): every photon carries a colour vector whose band mean is exactly 1. At each event
//! the probability of an outcome is the colour-weighted band average of its coefficient,
//! and the colour is re-weighted by coefficient / probability, which keeps the mean at 1 and
//! the estimate unbiased. Paths end by absorption (Russian roulette by the material's own
//! albedo), never by a silent depth cut: the safety limit on events reports what it drops.

pub mod direct;
pub mod volumes;

use crate::spectral::Colour;

use crate::accel::Accel;
use crate::sampling::PhotonRng;
use crate::scene::bsdf::{reflect, refract, Lobe};
use crate::scene::material::Polarisation;
use crate::scene::medium::Flight;
use crate::scene::{Material, PreparedScene};
use crate::spectral::Transmittance;
use glam::DVec3;
use std::sync::atomic::{AtomicBool, Ordering};

/// Surface events between two looks at the stop flag.
const STOP_POLL_EVENTS: u32 = 256;

/// Where the tracer sends the photon's hits on recording surfaces.
pub trait HitSink {
    /// A photon of colour `colour` arrived on `side` (0 front, 1 back) of triangle `prim`
    /// of mesh `mesh` at barycentric coordinates (u, v); with `weights`, the triangle's
    /// three vertices' shares are scaled by them (the light-sampling estimator's weights
    /// of a direct deposit, `direct`).
    fn deposit(
        &mut self,
        at: (u32, u32, u8),
        uv: (f32, f32),
        colour: &Colour,
        weights: Option<[f32; 3]>,
    );

    /// Whether the sink wants `surface` calls (renders do; i-map sinks compile them out).
    const SURFACES: bool = false;

    /// Every surface the photon reaches, before it scatters there, with its colour on
    /// arrival.
    fn surface(&mut self, _event: &SurfaceEvent, _colour: &Colour) {}

    /// The photon scattered in the scene's medium (`Scene::medium`; renders' sinks, with
    /// `SURFACES`); `wants_more` is asked after it.
    fn scattered_in_haze(&mut self) {}

    /// After `surface`: whether the photon's path is still of use to the sink (false ends
    /// it there, counted as escaped; a render's sink that wants only some paths).
    fn wants_more(&self) -> bool {
        true
    }

    /// Called when photon tracing starts, with its emitter (`PreparedScene::emitters`).
    fn begin_photon(&mut self, _emitter: usize) {}

    /// Called once the photon's first surface event is over: what it deposits from then on
    /// is indirect light (until then, its deposits — sensors crossed on the way and the
    /// first surface it reaches — are the direct component).
    fn direct_done(&mut self) {}

    /// Called when a photon's path has ended (absorbed, escaped or dropped).
    fn end_photon(&mut self) {}

    /// Called instead of `end_photon` when the run stopped in the middle of the photon's
    /// path: everything it deposited must be forgotten (it will be traced again).
    fn abort_photon(&mut self) {}

    /// Called after each batch of photons.
    fn batch_done(&mut self) {}
}

/// A photon arriving at a surface (for `HitSink::surface`).
pub struct SurfaceEvent<'m> {
    /// Hit point, local scene units.
    pub point: DVec3,
    /// Unit geometric normal on the side the photon came from.
    pub n_in: DVec3,
    pub material: &'m Material,
    /// Surface events before this one: 0 for the first hit after emission (direct light).
    pub bounce: u32,
    /// The photon's direction of travel as it arrives.
    pub dir: DVec3,
    /// Whether it arrives on the side the mesh's normals point to.
    pub front: bool,
}

/// Per-thread tallies of a run; merged after the threads finish.
#[derive(Clone, Debug, Default)]
pub struct PathStats {
    pub photons: u64,
    pub hits: u64,
    /// Energy the photons left their emitters with (units of one photon; one per photon on
    /// average).
    pub emitted: f64,
    /// Photon energy (units of one photon) absorbed by each mesh, at its surface or inside
    /// its medium.
    pub absorbed: Vec<f64>,
    pub escaped: f64,
    /// Photons that left the scene (each ends with one ray that hits nothing).
    pub escaped_photons: u64,
    /// Energy of photons stopped by the event safety limit.
    pub dropped: f64,
    pub dropped_photons: u64,
    /// The same balance per band (photon units; each photon's band values over the band
    /// count, so the bands sum to the totals above): emitted, absorbed, escaped, dropped,
    /// and what fluorescent surfaces re-emitted (emitted + fluoresced = absorbed + escaped
    /// + dropped per band; absorbed includes what fluoresced). Sized on the first photon.
    pub bands: [Vec<f64>; 5],
    /// The photon in flight's absorption at its weighted bounces (`Tracer::direct`),
    /// added to the tallies when its path ends.
    pub(crate) bounces: WeightedBounces,
    /// A tinted hit's material (`scene::texture`), reused from hit to hit.
    pub(crate) tint: crate::scene::texture::TintScratch,
    /// What media absorbed, per mesh and band, with its squares (`volumes`).
    pub volumes: volumes::VolumeTally,
}

/// What a photon left at its weighted bounces (light sampling: the photon goes on with the
/// reflected share of its colour), tallied when its path ends.
#[derive(Clone, Debug, Default)]
pub(crate) struct WeightedBounces {
    /// (mesh, energy it absorbed), per weighted bounce.
    meshes: Vec<(u32, f64)>,
    /// Per band: Σ (before − after) over the weighted bounces.
    delta: Vec<f64>,
    /// Per band: a glossy surface's weights (scratch).
    weights: Vec<f64>,
    /// The photon in flight's changes in media, per mesh (`volumes`).
    media: volumes::PhotonVolumes,
    /// Per band: what fluorescent surfaces re-emitted along the photon's path (sized on
    /// first use, emptied when the path's tallies are taken).
    fluoresced: Vec<f64>,
    /// Per band: a fluorescent surface's re-emission (scratch).
    emitted: Vec<f64>,
    /// The colour as a segment through a medium began, and as a sensor crossed on it
    /// reads it (scratch, with sensors in media only).
    before: Option<(Colour, Colour)>,
    /// The dielectric meshes the photon is inside (scratch: allocated at the first one).
    media_in: crate::scene::medium::MediumStack,
}

impl WeightedBounces {
    /// A weighted bounce at `mesh`: `colour` goes on times the glossy weights held in
    /// `weights`, and what it loses (or gains) is tallied as the mesh's absorption.
    fn weigh(&mut self, mesh: u32, colour: &mut Colour) {
        self.shift(mesh, colour, |c, w| c.reweight(w, 1.0));
    }

    /// `f` re-weights the colour's bands keeping their total (a medium's free flight,
    /// scattering or Beer–Lambert survival, inside `mesh`); each band's change is tallied
    /// as absorbed, by the mesh and by its medium (`volumes`).
    fn moved<T>(&mut self, mesh: u32, colour: &mut Colour, f: impl FnOnce(&mut Colour) -> T) -> T {
        self.media.add(mesh, colour.values(), 1.0);
        let out = self.shift(mesh, colour, |c, _| f(c));
        self.media.add(mesh, colour.values(), -1.0);
        out
    }

    /// A fluorescent Lambertian reflector at `mesh` (diffuse reflectance `rho`): the photon
    /// goes on with what the surface sends on (ρ∘c + mᵀc), whole with a weighted bounce
    /// (`weigh`), else with probability p, its colour-weighted share, divided by p (`u`
    /// uniform). Each band's change plus its re-emission is tallied as the mesh's
    /// absorption, the re-emission as fluoresced. False: absorbed here.
    fn fluoresce(
        &mut self,
        mesh: u32,
        (fl, rho): (&crate::scene::material::Fluorescence, &[f64]),
        colour: &mut Colour,
        weigh: bool,
        u: f64,
    ) -> bool {
        let nb = colour.values().len();
        self.weights.resize(nb, 0.0);
        self.emitted.resize(nb, 0.0);
        fl.send_on(rho, colour.values(), &mut self.weights, &mut self.emitted);
        let had: f64 = colour.values().iter().sum();
        let p = self.weights.iter().sum::<f64>() / had;
        if !(p > 0.0 && p.is_finite()) {
            return false;
        }
        let k = if weigh {
            1.0
        } else if u < p {
            1.0 / p
        } else {
            return false;
        };
        if self.delta.len() != nb {
            self.delta.clear();
            self.delta.resize(nb, 0.0);
        }
        if self.fluoresced.len() != nb {
            self.fluoresced.clear();
            self.fluoresced.resize(nb, 0.0);
        }
        let before = colour.mean();
        let mut re = 0.0;
        for b in 0..nb {
            let (o, e) = (self.weights[b] * k, self.emitted[b] * k);
            self.delta[b] += colour.values()[b] - o + e;
            self.fluoresced[b] += e;
            self.weights[b] = o;
            re += e;
        }
        colour.replace(&self.weights);
        self.meshes
            .push((mesh, before - colour.mean() + re / nb as f64));
        true
    }

    /// A fluorescent medium in `mesh` re-emits the colliding `colour`: `f` turns it into the
    /// re-emitted colour (given a scratch vector). All the colliding colour is tallied as
    /// absorbed there (by the mesh, per band and by its medium), the re-emitted as
    /// fluoresced, as at a fluorescent surface.
    fn re_emitted(
        &mut self,
        mesh: u32,
        colour: &mut Colour,
        f: impl FnOnce(&mut [f64], &mut Vec<f64>),
    ) {
        let mut scratch = std::mem::take(&mut self.emitted);
        self.moved(mesh, colour, |c| f(c.values_mut(), &mut scratch));
        self.emitted = scratch;
        let nb = colour.values().len();
        if self.fluoresced.len() != nb {
            self.fluoresced.clear();
            self.fluoresced.resize(nb, 0.0);
        }
        for ((d, e), c) in self
            .delta
            .iter_mut()
            .zip(&mut self.fluoresced)
            .zip(colour.values())
        {
            *d += c;
            *e += c;
        }
        self.media.add(mesh, colour.values(), 1.0);
        self.meshes.push((mesh, colour.mean()));
    }

    /// The path ends absorbed in `mesh`'s medium with `colour`.
    fn absorbed_in(&mut self, mesh: u32, colour: &Colour) {
        self.media.add(mesh, colour.values(), 1.0);
    }

    /// `f` changes `colour` at `mesh` (given the glossy weights): what the colour loses in
    /// total is tallied as the mesh's absorption and each band's change in `delta` (a gain
    /// as a negative absorption), so that the run's balance stays exact per band. Sizes
    /// `delta` on first use; the path's end tallies both when a mesh is listed.
    fn shift<T>(
        &mut self,
        mesh: u32,
        colour: &mut Colour,
        f: impl FnOnce(&mut Colour, &[f64]) -> T,
    ) -> T {
        let nb = colour.values().len();
        if self.delta.len() != nb {
            self.delta.clear();
            self.delta.resize(nb, 0.0);
        }
        let before = colour.mean();
        for (d, c) in self.delta.iter_mut().zip(colour.values()) {
            *d += c;
        }
        let out = f(colour, &self.weights);
        for (d, c) in self.delta.iter_mut().zip(colour.values()) {
            *d -= c;
        }
        let lost = before - colour.mean();
        if lost != 0.0 || self.meshes.is_empty() {
            self.meshes.push((mesh, lost));
        }
        out
    }
}

/// With light sampling, bounces do not end paths while the photon keeps at least this
/// share of its energy (Russian roulette takes over below it).
pub const WEIGHTED_BOUNCES_DOWN_TO: f64 = 0.5;

/// Indices of `PathStats::bands`.
pub const BAND_EMITTED: usize = 0;
pub const BAND_ABSORBED: usize = 1;
pub const BAND_ESCAPED: usize = 2;
pub const BAND_DROPPED: usize = 3;
pub const BAND_FLUORESCED: usize = 4;

impl PathStats {
    pub fn new(meshes: usize) -> Self {
        PathStats {
            absorbed: vec![0.0; meshes],
            ..Default::default()
        }
    }

    pub fn merge(&mut self, o: &PathStats) {
        self.photons += o.photons;
        self.hits += o.hits;
        self.emitted += o.emitted;
        for (a, b) in self.absorbed.iter_mut().zip(&o.absorbed) {
            *a += b;
        }
        self.escaped += o.escaped;
        self.escaped_photons += o.escaped_photons;
        self.dropped += o.dropped;
        self.dropped_photons += o.dropped_photons;
        self.volumes.merge(&o.volumes);
        for (a, b) in self.bands.iter_mut().zip(&o.bands) {
            if a.len() < b.len() {
                a.resize(b.len(), 0.0);
            }
            for (x, y) in a.iter_mut().zip(b) {
                *x += y;
            }
        }
    }

    /// Adds `share` of an emitted colour to the per-band escaped flux.
    #[inline]
    fn tally_escaped_share(&mut self, emitted: &[f64], share: f64) {
        let k = share / emitted.len() as f64;
        for (a, e) in self.bands[BAND_ESCAPED].iter_mut().zip(emitted) {
            *a += e * k;
        }
    }

    /// Adds a finished photon's emitted and final colour to the per-band balance.
    #[inline]
    fn tally_bands(&mut self, end: usize, emitted: &[f64], last: &[f64]) {
        let nb = emitted.len();
        if self.bands[0].len() != nb {
            self.bands.iter_mut().for_each(|b| b.resize(nb, 0.0));
        }
        let k = 1.0 / nb as f64;
        for (a, e) in self.bands[BAND_EMITTED].iter_mut().zip(emitted) {
            *a += e * k;
        }
        for (a, c) in self.bands[end].iter_mut().zip(last) {
            *a += c * k;
        }
    }
}

/// The read-only state every tracing thread shares.
pub struct Tracer<'a> {
    pub scene: &'a PreparedScene,
    pub accel: &'a Accel,
    /// The sensor meshes' BVH: every ray segment is checked for crossings (None: no
    /// sensors, or a caller that does not record them).
    pub sensors: Option<&'a Accel>,
    pub materials: &'a [Material],
    pub bands: usize,
    pub seed: u64,
    /// Metres per scene unit (Beer–Lambert coefficients are per metre).
    pub unit_m: f64,
    /// Safety limit on events (surface events and scatterings in a medium) per path.
    pub max_events: u32,
    /// The light-sampling estimator's direct passes: photons then deposit only indirect
    /// light (from their second surface event on), and each photon that ends does its
    /// share of the passes (`direct`). None: photons deposit everything.
    pub direct: Option<&'a direct::DirectSampler<'a>>,
}

/// The mesh id that stands for the scene's medium (`Scene::medium`) in the media's tally
/// (`volumes`) and at a path's end.
pub const SCENE_MEDIUM: u32 = u32::MAX;

/// The medium a photon travels in: air, the scene's medium (`SCENE_MEDIUM`), or the
/// inside of a dielectric mesh.
#[derive(Clone, Copy)]
struct Medium {
    mesh: u32,
    material: u32,
}

/// A photon as its light gave it out.
struct Emission {
    emitter: usize,
    /// The aimed photon's weight (`PreparedScene::emit`); 1 otherwise.
    weight: f64,
    /// Its energy in photon units before the weight: what its light emitted.
    energy: f64,
}

/// How a photon's deposits are weighted under the light-sampling estimator.
#[derive(Clone, Copy)]
enum Weigh<'d> {
    /// Photons deposit everything (photons only, or light that is neither kind below).
    Not,
    /// Direct light: weighted against the light samples.
    Direct(&'d direct::DirectSampler<'d>, &'d Origin),
    /// Light the passes gather too: weighted against them (`p`: the photon's landing
    /// density at its first surface event).
    Gathered(&'d direct::DirectSampler<'d>, f64),
}

/// A deposit on (mesh, prim, side) at barycentric (u, v) of a photon going along `dir`,
/// weighted as `weigh` says.
#[inline]
fn deposit<S: HitSink>(
    sink: &mut S,
    weigh: Weigh,
    at: (u32, u32, u8),
    (u, v): (f32, f32),
    dir: DVec3,
    colour: &Colour,
) {
    let weights = match weigh {
        Weigh::Not => None,
        Weigh::Direct(d, o) => {
            let m = &d.scene.meshes[at.0 as usize];
            let x = m.point(at.1 as usize, u, v);
            let n = m.normals[at.1 as usize].as_dvec3();
            let p = d.landing_density(o.emitter, o.y, o.cos_y, dir, x, n);
            Some(d.vertex_weights(p, direct::LIGHT_SAMPLE_GAIN, at.0, at.1, u, v))
        }
        Weigh::Gathered(d, p) => {
            let w = d.vertex_weights(p, direct::GATHER_GAIN, at.0, at.1, u, v);
            if w == [0.0; 3] {
                return;
            }
            Some(w)
        }
    };
    sink.deposit(at, (u, v), colour, weights);
}

/// Where a photon left its light (for the weights of its direct deposits).
struct Origin {
    emitter: usize,
    y: DVec3,
    /// Cosine at an emitting mesh (1 for lights).
    cos_y: f64,
}

/// How a photon's path ended, for the tallies that are kept only for whole photons.
enum PathEnd {
    /// Absorbed by mesh `mesh` (at its surface or inside its medium).
    Absorbed(u32),
    Escaped,
    /// Stopped by the event safety limit.
    Dropped,
    /// The run stopped while the photon was in flight.
    Aborted,
}

/// How a photon's segment inside a dielectric's medium ended (`Tracer::through_medium`).
enum Segment<'m> {
    /// It reaches the surface it was going to.
    Through,
    Absorbed,
    /// It scatters this many scene units along (true: a fluorescent medium re-emits it
    /// there, isotropically).
    Scatter(&'m crate::scene::medium::Scattering, f64, bool),
}

impl<'a> Tracer<'a> {
    /// A photon's segment inside medium `m` up to its surface `t` scene units away (None:
    /// none): a scattering medium's free flight (which may end before the surface), or
    /// Beer–Lambert: survive the segment with the colour-weighted transmittance,
    /// re-weighting the colour by band. Kept out of the path loop, which scenes without
    /// dielectrics run.
    #[inline(never)]
    fn through_medium(
        &self,
        m: Medium,
        (org, dir, t): (DVec3, DVec3, Option<f64>),
        colour: &mut Colour,
        (rng, drawn): (&mut PhotonRng, Option<([f64; 3], f64)>),
        bounces: &mut WeightedBounces,
    ) -> Segment<'a> {
        let d = self.materials[m.material as usize].dielectric.as_ref();
        // The scene's medium: the part of the segment inside its ball (all of it but for
        // a distant light's photon still on its way in, or one leaving the scene).
        let (t0, t) = match self.scene.haze.as_ref().filter(|_| m.mesh == SCENE_MEDIUM) {
            Some(h) => {
                let (t0, t1) = h.span(org, dir, t.unwrap_or(f64::INFINITY));
                (t0, Some(t1 - t0))
            }
            None => (0.0, t),
        };
        let dist_m = t.unwrap_or(f64::INFINITY) * self.unit_m;
        if let Some(sc) = d
            .and_then(|d| d.scattering.as_ref())
            .filter(|_| t.is_some())
        {
            // (No surface ahead: the photon has slipped out of its closed mesh through a
            // crack; it leaves the scene rather than wander in an unbounded medium.)
            // (Drawn before the ray was traced: `trace`'s early free flight.)
            let (u, t_m) = drawn.unwrap_or_else(|| {
                let u = [rng.uniform(), rng.uniform(), rng.uniform()];
                (u, sc.distance(colour.values(), u))
            });
            let flight = if sc.grey && sc.fluorescence.is_none() {
                // (A grey flight changes no weight: nothing to tally.)
                sc.flight_to(colour.values_mut(), t_m, dist_m, u)
            } else {
                bounces.moved(m.mesh, colour, |c| {
                    sc.flight_to(c.values_mut(), t_m, dist_m, u)
                })
            };
            return match flight {
                Flight::Surface => Segment::Through,
                Flight::Absorbed => Segment::Absorbed,
                Flight::Scatter(t_m) => Segment::Scatter(sc, t0 + t_m / self.unit_m, false),
                Flight::Fluoresce(t_m, k) => {
                    bounces.re_emitted(m.mesh, colour, |c, scratch| sc.emit_light(c, k, scratch));
                    Segment::Scatter(sc, t0 + t_m / self.unit_m, true)
                }
            };
        }
        if let Some(alpha) = d.and_then(|d| d.absorption_per_m.as_ref()) {
            let u = rng.uniform();
            if bounces
                .moved(m.mesh, colour, |c| c.survive_absorption(alpha, dist_m, u))
                .is_none()
            {
                return Segment::Absorbed;
            }
        }
        Segment::Through
    }
}

impl Tracer<'_> {
    /// Whether a bounce is weighed (the photon goes on with what the surface sends on, and
    /// what it keeps is tallied as absorbed): with light sampling, while the photon keeps
    /// at least `WEIGHTED_BOUNCES_DOWN_TO` of its energy; otherwise Russian roulette.
    #[inline]
    fn weighs(&self, colour: &Colour) -> bool {
        self.direct.is_some()
            && colour.mean() >= WEIGHTED_BOUNCES_DOWN_TO * colour.energy_at_emission()
    }

    /// Traces photon `k` from its emission to its end and returns true, or returns false
    /// when `stop` was raised during the path: then the sink was told to forget the photon
    /// and `stats` are unchanged. `colour` is scratch space reused between photons.
    pub fn trace(
        &self,
        k: u64,
        colour: &mut Colour,
        sink: &mut impl HitSink,
        stats: &mut PathStats,
        stop: &AtomicBool,
    ) -> bool {
        let mut hits = 0u64;
        let (end, emission) = self.trace_path(
            k,
            colour,
            sink,
            &mut hits,
            stop,
            (&mut stats.bounces, &mut stats.tint),
        );
        let e = colour.mean();
        let band_end = match end {
            PathEnd::Aborted => {
                stats.bounces.meshes.clear();
                stats.bounces.media.clear();
                stats.bounces.fluoresced.clear();
                sink.abort_photon();
                return false;
            }
            PathEnd::Absorbed(m) => {
                // (The scene's medium has no mesh: its tally is the media's, `volumes`.)
                if let Some(a) = stats.absorbed.get_mut(m as usize) {
                    *a += e;
                }
                BAND_ABSORBED
            }
            PathEnd::Escaped => {
                stats.escaped += e;
                stats.escaped_photons += 1;
                BAND_ESCAPED
            }
            PathEnd::Dropped => {
                stats.dropped += e;
                stats.dropped_photons += 1;
                BAND_DROPPED
            }
        };
        let emitted = &self.scene.emitters[emission.emitter].colour;
        stats.tally_bands(band_end, emitted, colour.values());
        if !stats.bounces.meshes.is_empty() {
            // The shares weighted bounces absorbed (the photon went on with the rest).
            for &(m, e) in &stats.bounces.meshes {
                if let Some(a) = stats.absorbed.get_mut(m as usize) {
                    *a += e;
                }
            }
            stats.bounces.meshes.clear();
            let k = 1.0 / stats.bounces.delta.len() as f64;
            for (a, d) in stats.bands[BAND_ABSORBED]
                .iter_mut()
                .zip(&stats.bounces.delta)
            {
                *a += d * k;
            }
        }
        if !stats.bounces.fluoresced.is_empty() {
            let k = 1.0 / stats.bounces.fluoresced.len() as f64;
            for (a, f) in stats.bands[BAND_FLUORESCED]
                .iter_mut()
                .zip(&stats.bounces.fluoresced)
            {
                *a += f * k;
            }
            stats.bounces.fluoresced.clear();
        }
        if !stats.bounces.media.is_empty() {
            stats
                .volumes
                .add_photon(&stats.bounces.media, &self.scene.efficacy);
            stats.bounces.media.clear();
        }
        if emission.weight != 1.0 {
            // An aimed photon: its light sent the rest of its flux outside the cone, where
            // it met nothing.
            let miss = 1.0 - emission.weight;
            stats.escaped += miss * emission.energy;
            stats.tally_escaped_share(emitted, miss);
        }
        stats.photons += 1;
        stats.hits += hits;
        stats.emitted += emission.energy;
        sink.end_photon();
        if let Some(d) = self.direct {
            d.photon_done(k);
        }
        true
    }

    fn trace_path<S: HitSink>(
        &self,
        k: u64,
        colour: &mut Colour,
        sink: &mut S,
        hits: &mut u64,
        stop: &AtomicBool,
        (bounces, tint): (
            &mut WeightedBounces,
            &mut crate::scene::texture::TintScratch,
        ),
    ) -> (PathEnd, Emission) {
        let mut rng = PhotonRng::new(self.seed, k);
        // Emit: choose a light by power, then a point and a direction on it.
        let (emitter, photon) = self.scene.emit(&mut rng);
        let mut weight = photon.weight;
        colour.reset(&self.scene.emitters[emitter].colour);
        if self.scene.emitters[emitter].is_distant() {
            // A distant photon's weight is its share of the source's radiance (mean 1): it
            // emits that much, none of it escaping at emission.
            colour.scale(weight);
            colour.emitted_now();
            if weight == 0.0 {
                sink.begin_photon(emitter);
                return (
                    PathEnd::Escaped,
                    Emission {
                        emitter,
                        weight: 1.0,
                        energy: 0.0,
                    },
                );
            }
            weight = 1.0;
        }
        let emission = Emission {
            emitter,
            weight,
            energy: colour.energy(),
        };
        sink.begin_photon(emitter);
        if weight != 1.0 {
            colour.scale(weight);
            colour.emitted_now();
            if weight == 0.0 {
                return (PathEnd::Escaped, emission);
            }
        }
        let from = Origin {
            emitter,
            y: photon.origin,
            cos_y: photon.cos,
        };
        (
            self.follow(
                &from,
                photon.direction,
                &mut rng,
                colour,
                sink,
                hits,
                stop,
                (bounces, tint),
            ),
            emission,
        )
    }

    /// Follows a photon from its emission at `org` along `dir` to the end of its path.
    #[allow(clippy::too_many_arguments)]
    fn follow<S: HitSink>(
        &self,
        from: &Origin,
        mut dir: DVec3,
        rng: &mut PhotonRng,
        colour: &mut Colour,
        sink: &mut S,
        hits: &mut u64,
        stop: &AtomicBool,
        (bounces, tint): (
            &mut WeightedBounces,
            &mut crate::scene::texture::TintScratch,
        ),
    ) -> PathEnd {
        // A light far outside the geometry: start where the ray meets its bounding sphere.
        let Some(mut org) = self.scene.enter(from.y, dir) else {
            return PathEnd::Escaped;
        };
        // Outside every mesh: air, or the scene's medium.
        let outside = self.scene.haze.as_ref().map(|h| Medium {
            mesh: SCENE_MEDIUM,
            material: h.material,
        });
        let mut medium = outside;
        bounces.media_in.clear();
        // A light inside meshes with a scattering medium starts its photons in them; light
        // sampling and gathering leave its light to the photons (`DirectSampler::
        // sample_light` takes none of it), so its deposits are not weighed.
        let held = &self.scene.emitters[from.emitter].media;
        for &(mesh, material) in held {
            bounces.media_in.cross(mesh, material, true);
            medium = Some(Medium { mesh, material });
        }
        let sampled = held.is_empty();
        // The medium after crossing the surface of `mesh` (material `material`) into it
        // (`front`) or out of it: the innermost mesh the photon is in, or `outside`.
        let cross = |media_in: &mut crate::scene::medium::MediumStack, mesh, material, front| {
            media_in.cross(mesh, material, front);
            match media_in.current() {
                Some((mesh, material)) => Some(Medium { mesh, material }),
                None => outside,
            }
        };
        // Unpolarised until a dielectric interface (`Polarisation`); diffuse and
        // coefficient (mirror) surfaces depolarise.
        let mut pol: Option<Polarisation> = None;
        // Whether the passes gather what the photon brings from here on: its first surface
        // event was a diffuse one and it has met no dielectric since (the paths a gathering
        // path from a vertex follows back to its light sample, `direct::DirectSampler::gather`).
        let mut gathered = None;
        let gathering = self.direct.filter(|d| d.gather && sampled);
        bounces.meshes.clear();
        bounces.media.clear();
        // (A glossy bounce or a medium sizes `delta` on first use: `WeightedBounces::shift`.)
        if self.direct.is_some() || !bounces.delta.is_empty() {
            bounces.delta.clear();
            bounces.delta.resize(colour.values().len(), 0.0);
        }

        for event in 0..self.max_events {
            // A long path must not hold up a stop: look at the flag now and then.
            if event % STOP_POLL_EVENTS == STOP_POLL_EVENTS - 1 && stop.load(Ordering::Relaxed) {
                return PathEnd::Aborted;
            }
            // In a scattering mesh medium the free flight's distance does not depend on the
            // surface ahead: it is drawn first, and a surface looked for only that far (the
            // traversal leaves out the rest of the scene), when the collision point lies
            // inside the mesh's box (else the photon has slipped out through a crack and
            // the whole ray decides, as below). The same numbers, the same outcome. Not
            // where sensors reach into the mesh's box (`PreparedScene::early_flight_bounds`):
            // they read each segment to its surface, which a second, whole ray would then
            // have to find (it cost a fog box with a sensor inside 8 %).
            let mut early = None;
            if let Some(m) = medium.filter(|m| m.mesh != SCENE_MEDIUM) {
                let sc = self.materials[m.material as usize]
                    .dielectric
                    .as_ref()
                    .and_then(|d| d.scattering.as_ref());
                let bounds = self.scene.early_flight_bounds.get(m.mesh as usize);
                if let (Some(sc), Some(&Some([lo, hi]))) = (sc, bounds) {
                    let u = [rng.uniform(), rng.uniform(), rng.uniform()];
                    let t_m = sc.distance(colour.values(), u);
                    let t = t_m / self.unit_m;
                    let p = org + dir * t;
                    let inside = t.is_finite() && p.cmpge(lo).all() && p.cmple(hi).all();
                    early = Some(((u, t_m), t, inside));
                }
            }
            let hit = match early {
                Some((_, t, true)) => self.accel.intersect_within(org, dir, t),
                _ => self.accel.intersect(org, dir),
            };
            // The distance to the surface the flight is weighed against: none found within
            // an early flight's reach is "farther".
            let surface_t = match early {
                Some((_, _, true)) => Some(hit.map_or(f64::INFINITY, |h| h.t)),
                _ => hit.map(|h| h.t),
            };

            // Sensors in a medium read the light that crosses them by its expected value:
            // the colour the segment began with times each band's transmittance to the
            // crossing, whatever the free flight below draws (its draw could not tell
            // the crossings before its end from those after).
            let attenuating = match (self.sensors, medium) {
                (Some(_), Some(m)) => self.materials[m.material as usize].extinction(),
                _ => None,
            };
            if attenuating.is_some() {
                let n = colour.values().len();
                let (b, _) = bounces
                    .before
                    .get_or_insert_with(|| (Colour::new(n), Colour::new(n)));
                b.clone_from(colour);
            }

            // Inside a dielectric or the scene's medium: a scattering medium's free flight
            // (which may end before the surface), or Beer–Lambert: survive the segment
            // through an absorbing medium with the colour-weighted transmittance,
            // re-weighting the colour by band.
            let mut scattered_at = None;
            let mut absorbed_in = None;
            if let Some(m) = medium {
                let drawn = early.map(|e| e.0);
                let segment = (org, dir, surface_t);
                match self.through_medium(m, segment, colour, (rng, drawn), bounces) {
                    Segment::Through => {}
                    Segment::Absorbed => absorbed_in = Some(m.mesh),
                    Segment::Scatter(sc, t, iso) => scattered_at = Some((sc, t, m.mesh, iso)),
                }
            }

            // With light sampling at the vertices, deposits before the first surface
            // event is over are direct light: weighted against the light samples.
            let weigh = match (self.direct, gathering, gathered) {
                (Some(d), _, _) if event == 0 && sampled => Weigh::Direct(d, from),
                // A deposit after `event` surface events (the first diffuse): a gathering
                // path from x takes its light sample at its `event`-th surface.
                (_, Some(d), Some(p)) if event <= direct::GATHER_DEPTH => Weigh::Gathered(d, p),
                _ => Weigh::Not,
            };
            if let Some(sensors) = self.sensors {
                // Sensors on the segment, up to and including the surface it ends on (a
                // sensor laid on a floor sees the light arriving there), or, in air, up to
                // where it scatters in a medium.
                let surface_end = |h: crate::accel::Hit| {
                    let m = &self.scene.meshes[h.mesh as usize];
                    h.t + 2.0 * self.scene.offset_at(m.point(h.prim as usize, h.u, h.v))
                };
                let t_end = match (scattered_at.filter(|_| attenuating.is_none()), hit, early) {
                    (Some((_, t, _, _)), _, _) => t,
                    (None, Some(h), _) => surface_end(h),
                    // An early flight that ended before the surface: the surface lies
                    // inside the mesh's box, which no sensor reaches (else the flight is
                    // not drawn early): nothing to read.
                    (None, None, Some((_, _, true))) => 0.0,
                    (None, None, _) => f64::INFINITY,
                };
                // (Where the segment lies in the medium: the scene's medium fills a ball.)
                let span = match (attenuating, medium) {
                    (Some(_), Some(m)) if m.mesh == SCENE_MEDIUM => self
                        .scene
                        .haze
                        .as_ref()
                        .map_or((0.0, 0.0), |h| h.span(org, dir, f64::INFINITY)),
                    _ => (0.0, f64::INFINITY),
                };
                let unit_m = self.unit_m;
                let mut before = bounces.before.as_mut();
                sensors.crossings(org, dir, t_end, |c| {
                    let mesh = &self.scene.meshes[c.mesh as usize];
                    let front = dir.dot(mesh.normals[c.prim as usize].as_dvec3()) < 0.0;
                    if front || mesh.two_sided {
                        let side = u8::from(!front);
                        let at = (c.mesh, c.prim, side);
                        match (attenuating, before.as_deref_mut()) {
                            (Some(sigma), Some((from, read))) => {
                                let inside = c.t.clamp(span.0, span.1) - span.0;
                                let d_m = inside * unit_m;
                                read.transmitted(from, Transmittance { sigma, d_m });
                                deposit(sink, weigh, at, (c.u, c.v), dir, read);
                            }
                            _ => deposit(sink, weigh, at, (c.u, c.v), dir, colour),
                        }
                    }
                });
            }
            if let Some(mesh) = absorbed_in {
                bounces.absorbed_in(mesh, colour);
                return PathEnd::Absorbed(mesh);
            }
            if let Some((sc, t, mesh, iso)) = scattered_at {
                // A scattering event in the medium: a new direction by the phase function
                // (a re-emission: any direction).
                if event == 0 {
                    sink.direct_done();
                }
                pol = None;
                // Light scattered in a medium is the photons' in every estimator.
                gathered = None;
                if S::SURFACES && mesh == SCENE_MEDIUM {
                    sink.scattered_in_haze();
                    if !sink.wants_more() {
                        return PathEnd::Escaped;
                    }
                }
                org += dir * t;
                let u = [rng.uniform(), rng.uniform(), rng.uniform()];
                dir = if iso {
                    crate::sampling::warp::uniform_sphere(u[0], u[1])
                } else if sc.one_g || sc.table.is_some() {
                    // (One phase function for all bands: the direction changes no weight.)
                    sc.scatter(dir, colour.values_mut(), u)
                } else {
                    bounces.moved(mesh, colour, |c| sc.scatter(dir, c.values_mut(), u))
                };
                continue;
            }
            let Some(hit) = hit else {
                return PathEnd::Escaped;
            };
            *hits += 1;
            let mesh = &self.scene.meshes[hit.mesh as usize];
            let prim = hit.prim as usize;
            let ng = mesh.normals[prim].as_dvec3();
            let cos_in = dir.dot(ng);
            let front = cos_in < 0.0;
            // The normal on the side the photon came from.
            let n_in = if front { ng } else { -ng };

            // Deposit on the hit triangle's vertices (the sink applies barycentric weights).
            if mesh.slot_base.is_some() && (front || mesh.two_sided) {
                let side = u8::from(!front);
                let at = (hit.mesh, hit.prim, side);
                deposit(sink, weigh, at, (hit.u, hit.v), dir, colour);
            }
            if event == 0 {
                sink.direct_done();
            }

            let (p_hit, eps) = self.scene.leaving_point(mesh, prim, hit.u, hit.v);
            // The photon's landing density at its first surface event (the gathering
            // paths' weights against it), taken when its event there is diffuse.
            let landing = || {
                gathering
                    .filter(|_| event == 0)
                    .map(|d| d.landing_density(from.emitter, from.y, from.cos_y, dir, p_hit, ng))
            };
            let material_id = mesh.material(prim);
            let material =
                self.scene
                    .material_at(self.materials, hit.mesh, prim, (hit.u, hit.v), tint);
            if S::SURFACES {
                sink.surface(
                    &SurfaceEvent {
                        point: p_hit,
                        n_in,
                        material,
                        bounce: event,
                        dir,
                        front,
                    },
                    colour,
                );
                if !sink.wants_more() {
                    return PathEnd::Escaped;
                }
            }

            let bsdf = material.bsdf();
            if let Some(g) = bsdf.glossy() {
                // A rough dielectric refracts against the dielectric around it (nested
                // media), else air.
                let mut nested = None;
                let out = g
                    .refracts()
                    .then(|| bounces.media_in.around(hit.mesh, front, self.materials));
                let g = match out.flatten() {
                    Some(out) => g.against(&out.ior, &mut nested),
                    None => g,
                };
                // A microfacet surface: a direction drawn from it, each band weighed by
                // f cos / pdf. Polarisation is not followed through rough surfaces.
                pol = None;
                if g.transmits() {
                    gathered = None;
                } else if bsdf.gathers() {
                    gathered = gathered.or_else(landing);
                }
                if g.dispersive() {
                    colour.collapse(rng.uniform());
                }
                let band = colour.band().unwrap_or(0);
                let frame = bsdf.frame(n_in);
                let wo = frame.to_local(-dir);
                let u = [rng.uniform(), rng.uniform(), rng.uniform()];
                let u_survive = rng.uniform();
                let w = &mut bounces.weights;
                w.resize(colour.values().len(), 0.0);
                let Some(sample) = g.sample_weighted(wo, u, band, front, w) else {
                    return PathEnd::Absorbed(hit.mesh);
                };
                let mean = colour.weighted_mean(w);
                if !(mean > 0.0 && mean.is_finite()) {
                    return PathEnd::Absorbed(hit.mesh);
                }
                let weigh_bounce = self.weighs(colour);
                if weigh_bounce {
                    // The photon goes on with what the surface sends on; the rest is
                    // tallied as absorbed here.
                    bounces.weigh(hit.mesh, colour);
                } else if mean <= 1.0 {
                    if u_survive >= mean {
                        return PathEnd::Absorbed(hit.mesh);
                    }
                    colour.reweight(w, mean);
                } else {
                    // This draw sends on more than arrived (f cos / pdf above 1): the
                    // difference is tallied as a negative absorption here, so that the
                    // absorbed power stays unbiased.
                    bounces.weigh(hit.mesh, colour);
                }
                dir = frame.to_world(sample.wi);
                if sample.wi.z > 0.0 {
                    org = p_hit + n_in * eps;
                } else {
                    org = p_hit - n_in * eps;
                    medium = cross(&mut bounces.media_in, hit.mesh, material_id, front);
                }
                continue;
            }
            if let Some(d) = bsdf.interface() {
                gathered = None;
                // Smooth dielectric interface: Fresnel reflection or Snell refraction,
                // against the dielectric around it (nested media), else air.
                let out = bounces.media_in.around(hit.mesh, front, self.materials);
                if d.dispersive || out.is_some_and(|o| o.dispersive) {
                    colour.collapse(rng.uniform());
                }
                let b = colour.band().unwrap_or(0);
                let (n, n_out) = (d.ior[b], out.map_or(1.0, |o| o.ior[b]));
                let (n1, n2) = if front { (n_out, n) } else { (n, n_out) };
                let cos_i = (-dir.dot(n_in)).clamp(0.0, 1.0);
                // Polarisation: the s and p parts reflect by their own Fresnel
                // coefficients, so the photon's state decides the reflectance and the
                // outcome changes the state (a slab's second face sees light the first
                // one polarised).
                let reflected =
                    Polarisation::interface(&mut pol, dir, n_in, cos_i, n1, n2, rng.uniform());
                if reflected {
                    dir = reflect(dir, n_in);
                    org = p_hit + n_in * eps;
                } else {
                    dir = refract(dir, n_in, cos_i, n1 / n2);
                    org = p_hit - n_in * eps;
                    medium = cross(&mut bounces.media_in, hit.mesh, material_id, front);
                }
                continue;
            }

            if let Some(fl) = &material.fluorescence {
                // A fluorescent Lambertian reflector: light of every band goes on in a
                // Lambertian direction, each band's share reflected and what the other
                // bands re-emit into it. What follows is the photons' alone in every
                // estimator (gathering paths end here, as at a dielectric).
                pol = None;
                gathered = None;
                let weigh = self.weighs(colour);
                let u = rng.uniform();
                let rho = &material.diffuse_reflect;
                if !bounces.fluoresce(hit.mesh, (fl, rho), colour, weigh, u) {
                    return PathEnd::Absorbed(hit.mesh);
                }
                dir = Lobe::DiffuseReflection.direction(dir, n_in, rng.uniform(), rng.uniform());
                org = p_hit + n_in * eps;
                continue;
            }
            // Opaque or translucent surface: choose the lobe by colour-weighted albedos,
            // spending no per-band work on lobes this surface does not have.
            pol = None;
            let mut u = rng.uniform();
            // With light sampling the first bounce does not end paths: the photon goes on
            // with the reflected (or transmitted) share of its colour, so every photon
            // brings indirect light (the photons' whole task then); what the surface
            // absorbed is tallied when the path ends.
            let weigh_bounce = self.weighs(colour);
            let mut survive = 1.0;
            if weigh_bounce {
                survive = bsdf.survival(|k| colour.weighted_mean(k));
                if survive.is_nan() || survive <= 0.0 {
                    return PathEnd::Absorbed(hit.mesh);
                }
                u *= survive;
                bounces.meshes.push((hit.mesh, colour.mean()));
                for (d, c) in bounces.delta.iter_mut().zip(colour.values()) {
                    *d += c;
                }
            }
            if let Some((lobe, k, p)) = bsdf.choose(u, |k| colour.weighted_mean(k)) {
                colour.reweight(k, p);
                // After a weighted bounce: the colour is scaled by the survival share and
                // the absorbed share is recorded.
                if weigh_bounce {
                    colour.scale(survive);
                    if let Some(last) = bounces.meshes.last_mut() {
                        last.1 -= colour.mean();
                    }
                    for (d, c) in bounces.delta.iter_mut().zip(colour.values()) {
                        *d -= c;
                    }
                }
                if lobe.is_diffuse() {
                    gathered = gathered.or_else(landing);
                    dir = lobe.direction(dir, n_in, rng.uniform(), rng.uniform());
                } else {
                    dir = lobe.direction(dir, n_in, 0.0, 0.0);
                }
                let n = lobe.leaving_normal(n_in);
                org = p_hit + n * eps;
                if lobe == Lobe::DiffuseTransmission && medium.is_some_and(|m| m.mesh == hit.mesh) {
                    // Through a translucent triangle of the dielectric it was inside (a
                    // print on a light guide that transmits): out of its medium.
                    medium = cross(&mut bounces.media_in, hit.mesh, material_id, false);
                }
                continue;
            }
            // Absorbed: the path ends here (after a weighted bounce only by rounding: then
            // nothing was taken from the colour and the photon ends here whole).
            if weigh_bounce {
                bounces.meshes.pop();
                for (d, c) in bounces.delta.iter_mut().zip(colour.values()) {
                    *d -= c;
                }
            }
            return PathEnd::Absorbed(hit.mesh);
        }
        PathEnd::Dropped
    }
}

//! Final gathering from the illumination map (`RenderMethod::FinalGather`): eye paths as
//! the path tracer's, ended at their second diffuse vertex on a recorded mesh, where the
//! map's light is read (`EyeTracer::path_sample` with a `MapIndirect`).
//!
//! This module holds the pixels' accumulators and the passes over them: the image is cut
//! into chunks of pixels; a work item is one sample for every pixel of a chunk that has
//! fewer than the item's pass count. A pixel's k-th sample draws from the stream (seed,
//! pixel, k), so an image depends on the seed and on the map each sample read, not on the
//! thread count. The driver (`driver`) alternates these passes with runs of the map.

pub mod driver;

use super::backward::{EyeStats, EyeTracer};
use super::Image;
use crate::sampling::PhotonRng;
use crate::spectral::Colour;
use crate::transport::{HitSink, PathStats, SurfaceEvent, Tracer};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Random streams of final gathering's eye paths.
const GATHER_DOMAIN: u64 = 0x7A7E_5EED_0000_0001;
/// Most pixels of a chunk (one work item traces one sample of each).
const MAX_CHUNK: usize = 256;

/// Buckets of a pixel's sketch of the map's error (`Chunk::sketch`).
const SKETCH: usize = 8;

/// The accumulators of a run of pixels.
struct Chunk {
    first: usize,
    /// Per pixel and band: the sum of the samples.
    sum: Vec<f64>,
    /// Per pixel: the sums of the band mean and of its square, over samples.
    s1: Vec<f64>,
    s2: Vec<f64>,
    /// Per pixel, `SKETCH` buckets: the map's error of what the samples read, each read's
    /// standard error times √(the map's photons then) — a per-photon scale that stays as
    /// the map grows — added with a sign and into a bucket both drawn from a hash of the
    /// vertex (a count sketch): Σ bucket² estimates Σ over vertices of (Σ of its reads)²,
    /// so reads of one vertex add up as correlated and reads of different vertices as
    /// independent.
    sketch: Vec<f64>,
    /// Samples per pixel.
    n: Vec<u32>,
}

/// The image's accumulators: chunks of pixels, each behind its own lock (a worker holds
/// one while it traces its samples; the monitor reads them one at a time).
pub struct GatherStore {
    bands: usize,
    pixels: usize,
    chunks: Vec<Mutex<Chunk>>,
    /// Samples taken so far.
    samples: AtomicU64,
}

/// Which maps the samples read: (the map's photons, samples that read it), in order.
#[derive(Clone, Debug, Default)]
pub struct Schedule {
    versions: Vec<(u64, u64)>,
}

impl Schedule {
    /// `samples` more samples read a map of `photons` photons.
    pub fn add(&mut self, photons: u64, samples: u64) {
        match self.versions.last_mut() {
            Some((n, s)) if *n == photons => *s += samples,
            _ => self.versions.push((photons, samples)),
        }
    }

    /// The variance of the samples' mean of one map read per photon² of its per-photon
    /// variance: Σ_j w_j² over the photons j, where photon j's weight in the mean is the
    /// share of samples that read a map holding it, each divided by that map's photons.
    /// 1/N when every sample read the same map of N photons; more when earlier samples read
    /// smaller maps (their errors are correlated with the later ones: the photons nest).
    fn q(&self) -> f64 {
        let total: u64 = self.versions.iter().map(|v| v.1).sum();
        if total == 0 {
            return 0.0;
        }
        let mut q = 0.0;
        let mut tail = 0.0;
        // From the last map back: tail = Σ over maps from k on of (share / photons).
        for (i, &(n, s)) in self.versions.iter().enumerate().rev() {
            if n == 0 {
                continue;
            }
            tail += s as f64 / total as f64 / n as f64;
            let before = if i > 0 { self.versions[i - 1].0 } else { 0 };
            q += n.saturating_sub(before) as f64 * tail * tail;
        }
        q
    }
}

/// The error of an image and its parts, relative to the image's mean luminance.
#[derive(Clone, Copy, Debug, Default)]
pub struct GatherError {
    /// The estimate reported: RMS of the pixels' standard errors over the mean luminance.
    pub rel_error: f64,
    /// The eye samples' part, squared (falls as 1/samples).
    pub eye_var: f64,
    /// The map's part, squared, were every sample to read the map as it is now, times that
    /// map's photons (falls as 1/photons).
    pub map_per_photon: f64,
    /// The caustics' part, squared (falls as 1/rounds).
    pub caustic_var: f64,
    /// The fewest samples of any pixel.
    pub min_samples: u32,
    pub samples: u64,
}

impl GatherStore {
    /// Bytes a store of `pixels` pixels and `bands` bands takes.
    pub fn bytes(pixels: usize, bands: usize) -> usize {
        pixels * (8 * (bands + 2 + SKETCH) + 4)
    }

    pub fn new(pixels: usize, bands: usize, threads: usize) -> Self {
        // Enough chunks that every thread has work on a small image.
        let len = (pixels / (8 * threads.max(1))).clamp(1, MAX_CHUNK);
        let chunks = (0..pixels.div_ceil(len))
            .map(|c| {
                let first = c * len;
                let n = len.min(pixels - first);
                Mutex::new(Chunk {
                    first,
                    sum: vec![0.0; n * bands],
                    s1: vec![0.0; n],
                    s2: vec![0.0; n],
                    sketch: vec![0.0; n * SKETCH],
                    n: vec![0; n],
                })
            })
            .collect();
        GatherStore {
            bands,
            pixels,
            chunks,
            samples: AtomicU64::new(0),
        }
    }

    /// Samples taken so far.
    pub fn samples(&self) -> u64 {
        self.samples.load(Ordering::Relaxed)
    }

    /// The image's error (and, with `image`, the image: each pixel's mean and relative
    /// standard error), with the caustics' rounds if any. `schedule` says which maps the
    /// samples read.
    pub fn estimate(
        &self,
        schedule: &Schedule,
        caustics: Option<&Mutex<Caustics>>,
        mut image: Option<&mut Image>,
    ) -> GatherError {
        let nb = self.bands;
        let q = schedule.q();
        let caustics = caustics.map(|c| c.lock().unwrap_or_else(|e| e.into_inner()));
        let (mut mean_sum, mut var_sum) = (0.0, 0.0);
        let (mut eye_var, mut map_now, mut caustic_var) = (0.0, 0.0, 0.0);
        let mut min_samples = u32::MAX;
        let mut samples = 0u64;
        for c in &self.chunks {
            let c = c.lock().unwrap_or_else(|e| e.into_inner());
            for i in 0..c.n.len() {
                let p = c.first + i;
                let n = c.n[i];
                min_samples = min_samples.min(n);
                samples += n as u64;
                let mut img = image.as_deref_mut();
                if let Some(img) = img.as_deref_mut() {
                    img.radiance[p * nb..(p + 1) * nb].fill(0.0);
                }
                let (cm, cvar) = caustics.as_ref().map_or((0.0, 0.0), |k| {
                    k.pixel(
                        p,
                        img.as_deref_mut()
                            .map(|im| &mut im.radiance[p * nb..(p + 1) * nb]),
                    )
                });
                if n == 0 {
                    if let Some(img) = img {
                        img.rel_error[p] = crate::imap::NO_DATA_REL_ERROR;
                    }
                    continue;
                }
                let nf = n as f64;
                let m = c.s1[i] / nf;
                let var = if n >= 2 {
                    (c.s2[i] / nf - m * m).max(0.0) / (nf - 1.0)
                } else {
                    m * m
                };
                let sk = c.sketch[i * SKETCH..(i + 1) * SKETCH]
                    .iter()
                    .map(|b| b * b)
                    .sum::<f64>()
                    / (nf * nf);
                let se2 = var + q * sk + cvar;
                let m = m + cm;
                mean_sum += m;
                var_sum += se2;
                eye_var += var;
                map_now += sk;
                caustic_var += cvar;
                if let Some(img) = img {
                    for (o, s) in img.radiance[p * nb..][..nb]
                        .iter_mut()
                        .zip(&c.sum[i * nb..])
                    {
                        *o += s / nf;
                    }
                    img.rel_error[p] = if n >= 2 && m > 0.0 {
                        se2.sqrt() / m
                    } else {
                        crate::imap::NO_DATA_REL_ERROR
                    };
                }
            }
        }
        let px = self.pixels as f64;
        let min_samples = if self.pixels == 0 { 0 } else { min_samples };
        if mean_sum <= 0.0 {
            return GatherError {
                rel_error: crate::imap::NO_DATA_REL_ERROR,
                min_samples,
                samples,
                ..Default::default()
            };
        }
        let l2 = (mean_sum / px).powi(2);
        GatherError {
            rel_error: (var_sum / px / l2).sqrt(),
            eye_var: eye_var / px / l2,
            map_per_photon: map_now / px / l2,
            caustic_var: caustic_var / px / l2,
            min_samples,
            samples,
        }
    }
}

/// The sketch bucket and sign of a map vertex side (`Chunk::sketch`).
#[inline]
fn bucket(key: u64) -> (usize, f64) {
    let mut z = key.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (
        (z % SKETCH as u64) as usize,
        if z >> 63 == 0 { 1.0 } else { -1.0 },
    )
}

/// A batch of passes: until every pixel has `up_to` samples, `stop` is raised, or the
/// deadline passes (checked by the monitor).
pub struct Batch<'a> {
    pub up_to: u32,
    pub deadline: Option<Instant>,
    pub stop: &'a AtomicBool,
    /// The photons of the map the samples read (0: none).
    pub map_photons: u64,
}

/// Tallies of a batch.
#[derive(Clone, Debug, Default)]
pub struct BatchTally {
    pub stats: EyeStats,
    /// Why the batch ended early: the deadline or `stop`.
    pub cut: bool,
}

/// Runs a batch of passes on `threads` workers; the calling thread runs `monitor` every
/// `tick` until the batch ends (it returns true to stop the batch). Returns the tallies and
/// a message if a worker thread was lost (its chunk keeps what it had).
pub fn passes(
    eye: &EyeTracer,
    store: &GatherStore,
    seed: u64,
    threads: usize,
    batch: &Batch,
    tick: Duration,
    monitor: &mut dyn FnMut() -> bool,
) -> (BatchTally, Option<String>) {
    let nc = store.chunks.len();
    let first_pass = {
        // Items start at the pass the slowest pixel is on.
        let mut least = u32::MAX;
        for c in &store.chunks {
            let c = c.lock().unwrap_or_else(|e| e.into_inner());
            least = least.min(c.n.iter().copied().min().unwrap_or(u32::MAX));
        }
        least
    };
    if first_pass >= batch.up_to {
        return (BatchTally::default(), None);
    }
    let items = (batch.up_to - first_pass) as u64 * nc as u64;
    let next = AtomicU64::new(0);
    let tally = Mutex::new(EyeStats::default());
    let seed = seed ^ GATHER_DOMAIN;
    let nb = store.bands;
    let mut cut = false;
    let work = |_: usize| {
        let mut stats = EyeStats::default();
        let (mut beta, mut scratch) = (Vec::new(), Vec::new());
        let mut one = vec![0.0; nb];
        let mut reads = Vec::new();
        let scale = (batch.map_photons as f64).sqrt();
        while !batch.stop.load(Ordering::Relaxed) {
            let i = next.fetch_add(1, Ordering::Relaxed);
            if i >= items {
                break;
            }
            let target = first_pass + (i / nc as u64) as u32 + 1;
            let mut c = store.chunks[(i % nc as u64) as usize]
                .lock()
                .unwrap_or_else(|e| e.into_inner());
            let first = c.first;
            let before = stats.paths;
            // Every pixel of the chunk up to `target` samples (an item of a later pass may
            // have taken the lock first and done this one's).
            let mut k = 0;
            while k < c.n.len() {
                if c.n[k] >= target {
                    k += 1;
                    continue;
                }
                let p = first + k;
                let mut rng = PhotonRng::new(seed, ((p as u64) << 32) | c.n[k] as u64);
                one.fill(0.0);
                reads.clear();
                eye.path_sample(
                    p as u32,
                    &mut rng,
                    &mut one,
                    &mut beta,
                    &mut scratch,
                    &mut reads,
                    &mut stats,
                );
                let m = one.iter().sum::<f64>() / nb as f64;
                c.s1[k] += m;
                c.s2[k] += m * m;
                for r in &reads {
                    let (b, sign) = bucket(r.key);
                    c.sketch[k * SKETCH + b] += sign * r.sigma * scale;
                }
                c.n[k] += 1;
                for (a, x) in c.sum[k * nb..(k + 1) * nb].iter_mut().zip(&one) {
                    *a += x;
                }
            }
            store
                .samples
                .fetch_add(stats.paths - before, Ordering::Relaxed);
        }
        let mut t = tally.lock().unwrap_or_else(|e| e.into_inner());
        t.paths += stats.paths;
        t.rays += stats.rays;
        t.dropped += stats.dropped;
    };
    let mut ticks = crate::progress::Schedule::every(Instant::now(), tick);
    let lost = run_workers("imap-gather", threads, batch.stop, work, || {
        if batch.stop.load(Ordering::Relaxed) {
            cut = true;
            return;
        }
        let now = Instant::now();
        if batch.deadline.is_some_and(|d| now >= d) {
            cut = true;
            batch.stop.store(true, Ordering::Relaxed);
            return;
        }
        if ticks.next().is_some_and(|t| now >= t) {
            let t0 = Instant::now();
            if monitor() {
                cut = true;
                batch.stop.store(true, Ordering::Relaxed);
            }
            // The next tick: one interval on, or later when the monitor was slow.
            ticks.done(t0.elapsed());
        }
    });
    let stats = tally.into_inner().unwrap_or_else(|e| e.into_inner());
    (BatchTally { stats, cut }, lost)
}

/// Runs `work(t)` on `threads` scoped worker threads named `name-t`; the calling thread
/// calls `idle` every 2 ms until they have all finished. A worker that panics (or cannot
/// be started) raises `stop` and its message is returned.
fn run_workers(
    name: &str,
    threads: usize,
    stop: &AtomicBool,
    work: impl Fn(usize) + Sync,
    mut idle: impl FnMut(),
) -> Option<String> {
    let finished = AtomicUsize::new(0);
    let lost: Mutex<Option<String>> = Mutex::new(None);
    let lose = |why: String| {
        *lost.lock().unwrap_or_else(|e| e.into_inner()) = Some(why);
        stop.store(true, Ordering::Relaxed);
    };
    std::thread::scope(|s| {
        let mut spawned = 0;
        for t in 0..threads.max(1) {
            let (work, finished, lose) = (&work, &finished, &lose);
            let r = std::thread::Builder::new()
                .name(format!("{name}-{t}"))
                .spawn_scoped(s, move || {
                    crate::error::quiet_thread();
                    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        crate::fault::at(crate::fault::Point::Render);
                        work(t)
                    }));
                    if let Err(e) = r {
                        let msg = crate::error::panic_message(&*e);
                        lose(format!("render thread {t} panicked: {msg}"));
                    }
                    finished.fetch_add(1, Ordering::Release);
                });
            match r {
                Ok(_) => spawned += 1,
                Err(e) => lose(format!("could not start a render thread: {e}")),
            }
        }
        while finished.load(Ordering::Acquire) < spawned {
            std::thread::sleep(Duration::from_millis(2));
            idle();
        }
    });
    lost.into_inner().unwrap_or_else(|e| e.into_inner())
}

/// Photons per round of caustic light tracing (`Caustics`).
pub const CAUSTIC_ROUND: u64 = 4096;
/// Random streams of the caustic photons.
const CAUSTIC_DOMAIN: u64 = 0xCA05_71C5_0000_0005;

/// The caustics of point-like lights seen directly (light → specular surfaces → a diffuse
/// surface → camera), which eye paths cannot reach (no ray meets a point): photons from
/// those lights are traced through specular surfaces to their first diffuse surface and
/// connected to the camera there (light tracing), each landing adding its diffuse
/// reflection toward the eye to the pixel that sees it. Rounds of `CAUSTIC_ROUND` photons
/// are independent estimates, so their spread per pixel is the estimate's error.
pub struct Caustics {
    bands: usize,
    /// Per pixel and band: the sum of the rounds' estimates.
    sum: Vec<f64>,
    /// Per pixel: the sum of the squares of its landings' band means. Landings in a pixel
    /// are rare events (a Poisson count per round), so a round's variance is the expected
    /// sum of its landings' squares: this over rounds² is the variance of the mean, stable
    /// even after a few rounds (the rounds' own spread is not: a pixel's landings are much
    /// alike, and two rounds with as many of them would show none).
    sq: Vec<f64>,
    rounds: u64,
}

impl Caustics {
    pub fn bytes(pixels: usize, bands: usize) -> usize {
        pixels * 8 * (bands + 1)
    }

    pub fn new(pixels: usize, bands: usize) -> Self {
        Caustics {
            bands,
            sum: vec![0.0; pixels * bands],
            sq: vec![0.0; pixels],
            rounds: 0,
        }
    }

    /// Adds a round's landings: (pixel, radiance per band), in any order (sorted here, so
    /// the sums do not depend on the order the threads found them in).
    fn add_round(&mut self, mut splats: Vec<(u32, Vec<f64>)>) {
        let nb = self.bands;
        splats.sort_by_key(|s| s.0);
        let mut i = 0;
        while i < splats.len() {
            let p = splats[i].0 as usize;
            while i < splats.len() && splats[i].0 as usize == p {
                let v = &splats[i].1;
                let m = v.iter().sum::<f64>() / nb as f64;
                self.sq[p] += m * m;
                self.sum[p * nb..(p + 1) * nb]
                    .iter_mut()
                    .zip(v)
                    .for_each(|(a, x)| *a += x);
                i += 1;
            }
        }
        self.rounds += 1;
    }

    /// Pixel `p`'s mean per band added to `out`, and the variance of its band mean.
    fn pixel(&self, p: usize, out: Option<&mut [f64]>) -> (f64, f64) {
        let nb = self.bands;
        if self.rounds == 0 {
            return (0.0, 0.0);
        }
        let r = self.rounds as f64;
        let s = &self.sum[p * nb..(p + 1) * nb];
        if let Some(o) = out {
            o.iter_mut().zip(s).for_each(|(a, x)| *a += x / r);
        }
        let m = s.iter().sum::<f64>() / nb as f64 / r;
        (m, self.sq[p] / (r * r))
    }
}

/// A caustic photon's path: alive while its light is point-like and every surface so far
/// was specular; at its first diffuse surface after at least one specular one it lands.
struct CausticSink<'a> {
    eye: &'a EyeTracer<'a>,
    /// Per emitter: whether it is point-like (a light, not a mesh or a distant source).
    delta: &'a [bool],
    /// W per photon-colour unit of a round's photon, per band: total power / (bands · photons).
    flux: f64,
    alive: bool,
    /// Whether the photon has met a surface (a specular one: a diffuse one ends it).
    after_surface: bool,
    splats: Vec<(u32, Vec<f64>)>,
}

impl HitSink for CausticSink<'_> {
    const SURFACES: bool = true;

    fn deposit(&mut self, _: (u32, u32, u8), _: (f32, f32), _: &Colour, _: Option<[f32; 3]>) {}

    fn begin_photon(&mut self, emitter: usize) {
        self.alive = self.delta.get(emitter).copied().unwrap_or(false);
        self.after_surface = false;
    }

    fn scattered_in_haze(&mut self) {
        // Light scattered in the scene's medium straight from its light: the eye paths'
        // light samples at their scattering points have it, and what follows from it.
        // (After specular surfaces the photon goes on: no eye path sees its light.)
        if !self.after_surface {
            self.alive = false;
        }
    }

    fn wants_more(&self) -> bool {
        self.alive
    }

    fn surface(&mut self, ev: &SurfaceEvent, colour: &Colour) {
        if !self.alive {
            return;
        }
        self.after_surface = true;
        let m = ev.material;
        let bsdf = m.bsdf();
        if bsdf.is_glossy() {
            if ev.bounce == 0 {
                // Light straight onto a glossy reflector: the eye paths' light samples
                // there have it, and all that follows from it.
                self.alive = false;
                return;
            }
            // After a specular start: what the reflector sends to the camera (eye paths
            // through it do not count the delta light behind the specular surfaces), and
            // the photon goes on.
            if let Some(s) = self.eye.caustic_splat(ev, colour.values(), self.flux) {
                self.splats.push(s);
            }
            return;
        }
        if !bsdf.is_diffuse() {
            // Specular: the path goes on.
            return;
        }
        self.alive = false;
        if ev.bounce == 0 {
            return; // direct light: the eye paths' light samples have it
        }
        if let Some(s) = self.eye.caustic_splat(ev, colour.values(), self.flux) {
            self.splats.push(s);
        }
    }
}

/// Traces caustic rounds `first..first + count` on `threads` workers into `caustics`,
/// until done or `stop`. Returns the rounds added and a message if a worker was lost.
#[allow(clippy::too_many_arguments)]
pub fn caustic_rounds(
    eye: &EyeTracer,
    fwd: &Tracer,
    delta: &[bool],
    caustics: &Mutex<Caustics>,
    first: u64,
    count: u64,
    threads: usize,
    stop: &AtomicBool,
) -> (u64, Option<String>) {
    let next = AtomicU64::new(0);
    let done = AtomicU64::new(0);
    let fwd = Tracer {
        seed: fwd.seed ^ CAUSTIC_DOMAIN,
        ..*fwd
    };
    let flux = eye.scene.total_power / (eye.bands as f64 * CAUSTIC_ROUND as f64);
    let work = |_: usize| {
        let mut colour = Colour::new(eye.bands);
        let mut stats = PathStats::new(eye.scene.meshes.len());
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            if i >= count || stop.load(Ordering::Relaxed) {
                break;
            }
            let round = first + i;
            let mut sink = CausticSink {
                eye,
                delta,
                flux,
                alive: false,
                after_surface: false,
                splats: Vec::new(),
            };
            let whole = (0..CAUSTIC_ROUND).all(|k| {
                fwd.trace(
                    round * CAUSTIC_ROUND + k,
                    &mut colour,
                    &mut sink,
                    &mut stats,
                    stop,
                )
            });
            if whole {
                caustics
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .add_round(sink.splats);
                done.fetch_add(1, Ordering::Relaxed);
            }
        }
    };
    let lost = run_workers("imap-caustic", threads, stop, work, || {});
    (done.load(Ordering::Relaxed), lost)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One map read by every sample: the mean's variance per unit photon variance is 1/N.
    /// Samples spread evenly over maps of N, 2N, …, KN photons: their mean is a weighted sum
    /// of the photons whose weights follow from the nesting — checked against the same sum
    /// written out photon batch by photon batch; for many steps it tends to 2/(KN) (the
    /// mixture's variance is twice the last map's).
    #[test]
    fn the_schedule_weighs_nested_maps() {
        let mut one = Schedule::default();
        one.add(1000, 64);
        one.add(1000, 36);
        assert!((one.q() - 1e-3).abs() < 1e-15);
        let k = 400u64;
        let n = 10u64;
        let mut s = Schedule::default();
        for i in 1..=k {
            s.add(i * n, 1);
        }
        // Batch b (photons (b−1)n..bn) is in the maps of steps b..k, each read by 1/k of
        // the samples: weight Σ_{i ≥ b} 1/(k · i n).
        let direct: f64 = (1..=k)
            .map(|b| {
                let w: f64 = (b..=k).map(|i| 1.0 / (k as f64 * (i * n) as f64)).sum();
                n as f64 * w * w
            })
            .sum();
        assert!(
            (s.q() / direct - 1.0).abs() < 1e-12,
            "{} vs {direct}",
            s.q()
        );
        let last = 1.0 / (k * n) as f64;
        assert!((s.q() / last - 2.0).abs() < 0.03, "{}", s.q() / last);
        assert_eq!(Schedule::default().q(), 0.0);
    }

    /// The sketch's buckets and signs are spread evenly, so Σ bucket² has the expectation
    /// Σ over vertices of (its reads' sum)² for any set of vertices.
    #[test]
    fn the_sketch_spreads_vertices_evenly() {
        let mut count = [0u32; SKETCH];
        let mut plus = 0;
        let n = 80_000u64;
        for key in 0..n {
            let (b, s) = bucket(((key % 7) << 40) | key);
            count[b] += 1;
            plus += (s > 0.0) as u32;
        }
        let each = n as f64 / SKETCH as f64;
        for c in count {
            assert!((c as f64 - each).abs() < 5.0 * each.sqrt(), "{count:?}");
        }
        assert!((plus as f64 - n as f64 / 2.0).abs() < 5.0 * (n as f64 / 4.0).sqrt());
        // Σ bucket² over many random key sets averages Σ value² (independent vertices).
        let (mut got, mut want) = (0.0, 0.0);
        for set in 0..2000u64 {
            let mut b = [0.0; SKETCH];
            for v in 0..20u64 {
                let x = 1.0 + (v % 3) as f64;
                let (k, s) = bucket(set * 1000 + v);
                b[k] += s * x;
                want += x * x;
            }
            got += b.iter().map(|x| x * x).sum::<f64>();
        }
        assert!((got / want - 1.0).abs() < 0.03, "{}", got / want);
    }
}

//! The photon-map renderer's engine: groups of threads, their phases (backward paths,
//! backward photon maps, forward photons, pixel updates), and the calling thread's
//! monitor loop (the module's description is `render`'s).

use super::backward::{EyeStats, EyeTracer};
use super::barrier::Barrier;
use super::bmap::{BackwardMap, PixelStore, SampleBuf};
use super::gate::Gate;
use super::{Image, RenderMethod, RenderMonitor, RenderParams, RenderReport};
use crate::progress::{CostClock, Progress, StopReason};
use crate::sampling::PhotonRng;
use crate::spectral::Colour;
use crate::transport::{HitSink, PathStats, SurfaceEvent, Tracer};
use std::cell::UnsafeCell;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Mutex, RwLock};
use std::time::{Duration, Instant};

/// Side of a mask tile, pixels.
pub const TILE: u32 = 32;
/// Forward photons per claim (and per acquisition of the other groups' maps).
pub const FORWARD_BATCH: u64 = 32;
/// Random streams of the backward paths and of the forward photons.
const EYE_DOMAIN: u64 = 0xB4C1_0000_0000_0001;
const FORWARD_DOMAIN: u64 = 0xF0A2_0000_0000_0002;

#[derive(Default)]
struct GroupTally {
    phases: u64,
    t_backward: f64,
    t_build: f64,
    t_forward: f64,
    t_close: f64,
    t_finalize: f64,
    map_bytes: usize,
}

/// One group of threads and its backward photon maps.
struct Group {
    gate: Gate,
    /// Odd while the maps are open, even while the owner rebuilds them.
    epoch: AtomicU64,
    map: UnsafeCell<BackwardMap>,
    barrier: Barrier,
    bufs: Vec<Mutex<SampleBuf>>,
    /// The mask: tile indices (row-major over the tile grid).
    tiles: RwLock<Vec<u32>>,
    store: usize,
    go: AtomicBool,
    forward_ok: AtomicBool,
    next_tile: AtomicUsize,
    next_photon: AtomicU64,
    quota: AtomicU64,
    tally: Mutex<GroupTally>,
}

// SAFETY: `map` is written only by the group's leader while the gate is closed and the
// group's other threads wait at its barrier; it is read by the group's threads between
// barriers and by other groups' threads only between a successful `Gate::try_join` and the
// matching `leave` (see `gate`). Everything else is atomics or locks.
unsafe impl Sync for Group {}

impl Group {
    /// # Safety
    /// No `map_mut` borrow may be alive: see the `Sync` impl.
    unsafe fn map(&self) -> &BackwardMap {
        &*self.map.get()
    }

    /// # Safety
    /// Only the leader, with the gate closed and the group's other threads at a barrier.
    #[allow(clippy::mut_from_ref)]
    unsafe fn map_mut(&self) -> &mut BackwardMap {
        &mut *self.map.get()
    }
}

/// A forward photon's path gathering into a set of maps.
struct ForwardSink<'m> {
    maps: &'m [&'m BackwardMap],
    gathers: u64,
}

impl HitSink for ForwardSink<'_> {
    const SURFACES: bool = true;

    fn deposit(&mut self, _: (u32, u32, u8), _: (f32, f32), _: &Colour, _: Option<[f32; 3]>) {}

    #[inline]
    fn surface(&mut self, ev: &SurfaceEvent, colour: &Colour) {
        // The first hit is direct light (the backward paths' light sampling has it); only
        // diffuse surfaces hold backward photons.
        let m = ev.material;
        if ev.bounce == 0 || !m.bsdf().is_diffuse() {
            return;
        }
        let (y, n) = (ev.point.as_vec3(), ev.n_in.as_vec3());
        for map in self.maps {
            self.gathers += map.gather(y, n, colour.values(), colour.band()) as u64;
        }
    }
}

#[derive(Default)]
struct Totals {
    backward_paths: AtomicU64,
    backward_rays: AtomicU64,
    dropped_paths: AtomicU64,
    forward_photons: AtomicU64,
    forward_rays: AtomicU64,
    gathers: AtomicU64,
    joins: AtomicU64,
    close_retries: AtomicU64,
    violations: AtomicU64,
}

struct Engine<'a> {
    eye: &'a EyeTracer<'a>,
    fwd: Tracer<'a>,
    groups: Vec<Group>,
    stores: Vec<PixelStore>,
    threads_per_group: usize,
    share: bool,
    remask: u32,
    alpha: f64,
    /// Forward photons per mask pixel per phase.
    forward_per_pixel: f64,
    seed: u64,
    tiles_x: u32,
    tiles_y: u32,
    /// Power per unit of gathered value: total power / (bands · π · m² per unit²).
    power_scale: f64,
    stop: AtomicBool,
    poison: AtomicBool,
    photon_next: AtomicU64,
    pass_budget: u64,
    pass_claimed: AtomicU64,
    global: Barrier,
    decision: AtomicBool,
    remask_round: AtomicU64,
    totals: Totals,
}

impl Engine<'_> {
    fn pixels(&self) -> usize {
        self.eye.camera.pixels()
    }

    fn tile_pixels(&self, tile: u32) -> impl Iterator<Item = u32> {
        let (w, h) = (self.eye.camera.desc.width, self.eye.camera.desc.height);
        let (tx, ty) = (tile % self.tiles_x, tile / self.tiles_x);
        let (x0, y0) = (tx * TILE, ty * TILE);
        let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
        (y0..y1).flat_map(move |y| (x0..x1).map(move |x| y * w + x))
    }

    fn mask_pixels(&self, tiles: &[u32]) -> u64 {
        tiles
            .iter()
            .map(|&t| self.tile_pixels(t).count() as u64)
            .sum()
    }

    /// Deals the tiles at random to the groups: disjoint masks covering the image.
    fn deal_masks(&self, round: u64) {
        let n = self.tiles_x * self.tiles_y;
        let mut order: Vec<u32> = (0..n).collect();
        let mut rng = PhotonRng::new(self.seed ^ 0x3A5C_0000_0000_0003, round);
        for i in (1..order.len()).rev() {
            let j = (rng.uniform() * (i + 1) as f64) as usize;
            order.swap(i, j.min(i));
        }
        let g = self.groups.len();
        for (k, grp) in self.groups.iter().enumerate() {
            let mut t = grp.tiles.write().unwrap_or_else(|e| e.into_inner());
            t.clear();
            t.extend(order.iter().skip(k).step_by(g));
        }
    }

    fn claim_pass(&self, pixels: u64) -> bool {
        self.pass_claimed.fetch_add(pixels, Ordering::Relaxed) < self.pass_budget
    }

    fn exhausted(&self) -> bool {
        self.pass_claimed.load(Ordering::Relaxed) >= self.pass_budget
    }

    /// All group leaders meet; the first group's leader decides whether to go on and deals
    /// new masks. None when poisoned.
    fn global_sync(&self, g: usize) -> Option<bool> {
        if !self.global.wait(&self.poison) {
            return None;
        }
        if g == 0 {
            let go = !self.stop.load(Ordering::Relaxed) && !self.exhausted();
            self.decision.store(go, Ordering::Relaxed);
            if go {
                self.deal_masks(self.remask_round.fetch_add(1, Ordering::Relaxed) + 1);
            }
        }
        if !self.global.wait(&self.poison) {
            return None;
        }
        Some(self.decision.load(Ordering::Relaxed))
    }

    /// The leader's decision at the start of a phase.
    fn phase_start(&self, g: usize, since_remask: &mut u32) -> bool {
        let semi = self.share;
        loop {
            if semi
                && (*since_remask >= self.remask
                    || self.stop.load(Ordering::Relaxed)
                    || self.exhausted())
            {
                match self.global_sync(g) {
                    Some(true) => *since_remask = 0,
                    _ => return false,
                }
            }
            if self.stop.load(Ordering::Relaxed) {
                if semi {
                    continue;
                }
                return false;
            }
            let tiles = self.groups[g]
                .tiles
                .read()
                .unwrap_or_else(|e| e.into_inner());
            if self.claim_pass(self.mask_pixels(&tiles)) {
                return true;
            }
            if !semi {
                return false;
            }
        }
    }

    /// Traces forward photons `start..start+n` gathering into `maps`.
    fn trace_forward(
        &self,
        start: u64,
        n: u64,
        maps: &[&BackwardMap],
        colour: &mut Colour,
        stats: &mut PathStats,
    ) {
        let mut sink = ForwardSink { maps, gathers: 0 };
        let before = (stats.hits, stats.escaped_photons);
        let mut done = 0;
        for k in start..start + n {
            if !self.fwd.trace(k, colour, &mut sink, stats, &self.stop) {
                // Abandoned mid-path: its gathers are in these maps, so their phase goes.
                for m in maps {
                    m.interrupted.store(true, Ordering::Relaxed);
                }
                break;
            }
            done += 1;
        }
        for m in maps {
            m.forward.fetch_add(done, Ordering::Relaxed);
        }
        let t = &self.totals;
        t.forward_photons.fetch_add(done, Ordering::Relaxed);
        t.forward_rays.fetch_add(
            (stats.hits - before.0) + (stats.escaped_photons - before.1),
            Ordering::Relaxed,
        );
        t.gathers.fetch_add(sink.gathers, Ordering::Relaxed);
    }

    fn worker(&self, g: usize, tid: usize) {
        let grp = &self.groups[g];
        let leader = tid == 0;
        let nb = self.eye.bands;
        let store = &self.stores[grp.store];
        let mut colour = Colour::new(nb);
        let mut beta = Vec::with_capacity(nb);
        let mut value = vec![0.0; nb];
        let mut pstats = PathStats::new(self.eye.scene.meshes.len());
        let mut since_remask = 0u32;
        let poison = &self.poison;
        let eye_seed =
            self.seed ^ EYE_DOMAIN ^ (grp.store as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        loop {
            // --- Start: the leader decides; everyone learns it at the barrier.
            if leader {
                let go = self.phase_start(g, &mut since_remask);
                grp.go.store(go, Ordering::Relaxed);
                grp.next_tile.store(0, Ordering::Relaxed);
                grp.next_photon.store(0, Ordering::Relaxed);
            }
            if !grp.barrier.wait(poison) || !grp.go.load(Ordering::Relaxed) {
                return;
            }
            // --- 1. Backward paths for the mask's pixels.
            let t_start = Instant::now();
            {
                let tiles = grp.tiles.read().unwrap_or_else(|e| e.into_inner());
                let mut buf = grp.bufs[tid].lock().unwrap_or_else(|e| e.into_inner());
                let mut es = EyeStats::default();
                loop {
                    let i = grp.next_tile.fetch_add(1, Ordering::Relaxed);
                    if i >= tiles.len() || self.stop.load(Ordering::Relaxed) {
                        break;
                    }
                    for pixel in self.tile_pixels(tiles[i]) {
                        let p = pixel as usize;
                        let mut rng =
                            PhotonRng::new(eye_seed, (store.count(p) as u64) << 32 | pixel as u64);
                        self.eye.trace(
                            pixel,
                            &mut rng,
                            store.r2(p),
                            store.probe(p),
                            &mut buf,
                            &mut beta,
                            &mut es,
                            &self.stop,
                        );
                    }
                }
                let t = &self.totals;
                t.backward_paths.fetch_add(es.paths, Ordering::Relaxed);
                t.backward_rays.fetch_add(es.rays, Ordering::Relaxed);
                t.dropped_paths.fetch_add(es.dropped, Ordering::Relaxed);
            }
            if !grp.barrier.wait(poison) {
                return;
            }
            // --- 2. The leader builds the maps and opens them.
            let t_backward = Instant::now();
            if leader {
                let ok = !self.stop.load(Ordering::Relaxed);
                grp.forward_ok.store(ok, Ordering::Relaxed);
                if ok {
                    let tiles = grp.tiles.read().unwrap_or_else(|e| e.into_inner());
                    let quota = (self.mask_pixels(&tiles) as f64 * self.forward_per_pixel).ceil();
                    grp.quota.store(quota as u64, Ordering::Relaxed);
                    // SAFETY: the gate is closed (opened below) and the group waits at the
                    // barrier; no other group can enter (counter 0).
                    let map = unsafe { grp.map_mut() };
                    let mut guards: Vec<_> = grp
                        .bufs
                        .iter()
                        .map(|b| b.lock().unwrap_or_else(|e| e.into_inner()))
                        .collect();
                    map.build(guards.iter_mut().map(|g| &mut **g));
                    let bytes = map.bytes();
                    let mut tally = grp.tally.lock().unwrap_or_else(|e| e.into_inner());
                    tally.map_bytes = tally.map_bytes.max(bytes);
                    grp.epoch.fetch_add(1, Ordering::Relaxed);
                    if self.share {
                        grp.gate.open();
                    }
                }
            }
            if !grp.barrier.wait(poison) {
                return;
            }
            let t_build = Instant::now();
            if !grp.forward_ok.load(Ordering::Relaxed) {
                grp.bufs[tid]
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .clear();
                continue;
            }
            // --- 3. Forward photons into the own maps and the other groups' open maps.
            // SAFETY: built above; the leader mutates it again only after the next barrier.
            let own = unsafe { grp.map() };
            let quota = grp.quota.load(Ordering::Relaxed);
            let mut joined: Vec<usize> = Vec::with_capacity(self.groups.len());
            let mut maps: Vec<&BackwardMap> = Vec::with_capacity(self.groups.len());
            loop {
                let q = grp.next_photon.fetch_add(FORWARD_BATCH, Ordering::Relaxed);
                if q >= quota || self.stop.load(Ordering::Relaxed) {
                    break;
                }
                let n = FORWARD_BATCH.min(quota - q);
                let start = self.photon_next.fetch_add(n, Ordering::Relaxed);
                joined.clear();
                maps.push(own);
                if self.share {
                    for (h, other) in self.groups.iter().enumerate() {
                        if h != g && other.gate.try_join() {
                            if other.epoch.load(Ordering::Relaxed) % 2 == 0 {
                                self.totals.violations.fetch_add(1, Ordering::Relaxed);
                            }
                            joined.push(h);
                            // SAFETY: joined: the owner cannot close until we leave.
                            maps.push(unsafe { other.map() });
                        }
                    }
                }
                let guard = LeaveOnDrop {
                    groups: &self.groups,
                    joined: &joined,
                };
                self.trace_forward(start, n, &maps, &mut colour, &mut pstats);
                for &h in &joined {
                    if self.groups[h].epoch.load(Ordering::Relaxed) % 2 == 0 {
                        self.totals.violations.fetch_add(1, Ordering::Relaxed);
                    }
                }
                self.totals
                    .joins
                    .fetch_add(joined.len() as u64, Ordering::Relaxed);
                // No reference to another group's maps outlives the join.
                maps.clear();
                drop(guard);
            }
            // The owner closes its maps: while others are inside, it keeps tracing forward
            // photons into its own maps only (so it never holds another group's maps).
            let t_forward = Instant::now();
            if leader {
                if self.share {
                    while !grp.gate.try_close() {
                        if poison.load(Ordering::Relaxed) {
                            return;
                        }
                        if self.stop.load(Ordering::Relaxed) {
                            std::thread::yield_now();
                            continue;
                        }
                        let start = self.photon_next.fetch_add(FORWARD_BATCH, Ordering::Relaxed);
                        self.trace_forward(start, FORWARD_BATCH, &[own], &mut colour, &mut pstats);
                        self.totals.close_retries.fetch_add(1, Ordering::Relaxed);
                    }
                }
                grp.epoch.fetch_add(1, Ordering::Relaxed);
            }
            let t_closed = Instant::now();
            if !grp.barrier.wait(poison) {
                return;
            }
            // --- 4. Every entry becomes one more sample of its pixel (entries split among
            // the group's threads; masks are disjoint, so each pixel has one writer).
            let forward = own.forward.load(Ordering::Relaxed);
            if forward > 0 && !own.interrupted.load(Ordering::Relaxed) {
                let scale = self.power_scale / forward as f64;
                let e = own.entries();
                let k = self.threads_per_group;
                let chunk = e.div_ceil(k);
                for i in (tid * chunk)..((tid + 1) * chunk).min(e) {
                    let (pixel, gathered) = own.sample(i, scale, &mut value);
                    store.add_sample(pixel as usize, &value, gathered, self.alpha);
                }
            }
            if !grp.barrier.wait(poison) {
                return;
            }
            if leader {
                since_remask += 1;
                let mut t = grp.tally.lock().unwrap_or_else(|e| e.into_inner());
                t.phases += u64::from(forward > 0);
                t.t_backward += (t_backward - t_start).as_secs_f64();
                t.t_build += (t_build - t_backward).as_secs_f64();
                t.t_forward += (t_forward - t_build).as_secs_f64();
                t.t_close += (t_closed - t_forward).as_secs_f64();
                t.t_finalize += t_closed.elapsed().as_secs_f64();
            }
        }
    }

    /// The merged estimate: global relative error and, if asked, the image.
    fn estimate(&self, mut image: Option<&mut Image>) -> f64 {
        let nb = self.eye.bands;
        let pixels = self.pixels();
        let mut sum = vec![0.0; nb];
        let (mut var_sum, mut mean_sum, mut covered) = (0.0, 0.0, true);
        for p in 0..pixels {
            let (mut n, mut q, mut bias) = (0u64, 0.0, 0.0);
            sum.iter_mut().for_each(|s| *s = 0.0);
            for s in &self.stores {
                s.read(p, &mut n, &mut sum, &mut q);
                s.read_bias(p, &mut bias);
            }
            let nf = n.max(1) as f64;
            let m = sum.iter().sum::<f64>() / (nb as f64 * nf);
            // The samples' spread, and the boundary bias they all share (`PixelStore`).
            let bias = bias / nf;
            let se2 = if n >= 2 {
                ((q - nf * m * m) / (nf - 1.0)).max(0.0) / nf + bias * bias
            } else {
                covered = false;
                f64::INFINITY
            };
            var_sum += se2;
            mean_sum += m;
            if let Some(img) = image.as_deref_mut() {
                for (o, s) in img.radiance[p * nb..][..nb].iter_mut().zip(&sum) {
                    *o = s / nf;
                }
                img.rel_error[p] = if n >= 2 && m > 0.0 {
                    se2.sqrt() / m
                } else {
                    crate::imap::NO_DATA_REL_ERROR
                };
            }
        }
        if !covered || mean_sum <= 0.0 {
            return crate::imap::NO_DATA_REL_ERROR;
        }
        (var_sum / pixels as f64).sqrt() / (mean_sum / pixels as f64)
    }
}

/// Leaves the joined maps when a forward batch ends, also on unwinding.
struct LeaveOnDrop<'g> {
    groups: &'g [Group],
    joined: &'g [usize],
}

impl Drop for LeaveOnDrop<'_> {
    fn drop(&mut self) {
        for &h in self.joined {
            self.groups[h].gate.leave();
        }
    }
}

/// How `method` arranges `threads` workers: (threads per group, groups, whether groups
/// read each other's maps, pixel stores).
fn layout(
    method: RenderMethod,
    group_threads: usize,
    threads: usize,
) -> (usize, usize, bool, usize) {
    let threads = threads.max(1);
    match method {
        RenderMethod::Synchronous | RenderMethod::FinalGather => (threads, 1, false, 1),
        RenderMethod::Asynchronous => (1, threads, false, threads),
        RenderMethod::SemiSynchronous => {
            let k = group_threads.clamp(1, threads);
            let g = (threads / k).max(1);
            (k, g, g > 1, 1)
        }
    }
}

/// The most memory a render of `pixels` pixels can take: its pixel stores and its maps
/// (one whole-image map per store; semi-synchronous groups split the image between them).
pub fn bytes_needed(
    method: RenderMethod,
    group_threads: usize,
    threads: usize,
    pixels: usize,
    bands: usize,
) -> u128 {
    let (_, _, _, stores) = layout(method, group_threads, threads);
    stores as u128
        * pixels as u128
        * (PixelStore::bytes(1, bands) + BackwardMap::bytes_per_entry(bands)) as u128
}

/// Renders the camera's image. `threads` worker threads plus the calling thread (monitor).
/// Returns the image, the report, and a message if a worker thread was lost.
pub fn render(
    eye: &EyeTracer,
    fwd: Tracer,
    params: &mut RenderParams,
    threads: usize,
    seed: u64,
) -> (Image, RenderReport, Option<String>) {
    let nb = eye.bands;
    let (k, g, share, stores) = layout(params.method, params.group_threads, threads);
    let pixels = eye.camera.pixels();
    let desc = &eye.camera.desc;
    let tiles_x = desc.width.div_ceil(TILE);
    let tiles_y = desc.height.div_ceil(TILE);
    let all_tiles: Vec<u32> = (0..tiles_x * tiles_y).collect();
    let forward_per_pass = match params.forward_per_pass {
        0 => pixels as u64,
        f => f,
    };
    let alpha = if params.alpha > 0.0 {
        params.alpha
    } else {
        2.0 / 3.0
    };
    let unit2 = eye.unit_m * eye.unit_m;
    let engine = Engine {
        eye,
        fwd: Tracer {
            seed: seed ^ FORWARD_DOMAIN,
            ..fwd
        },
        groups: (0..g)
            .map(|i| Group {
                gate: Gate::new(),
                epoch: AtomicU64::new(0),
                map: UnsafeCell::new(BackwardMap::new(nb, eye.transmit)),
                barrier: Barrier::new(k),
                bufs: (0..k).map(|_| Mutex::new(SampleBuf::default())).collect(),
                tiles: RwLock::new(all_tiles.clone()),
                store: if stores > 1 { i } else { 0 },
                go: AtomicBool::new(false),
                forward_ok: AtomicBool::new(false),
                next_tile: AtomicUsize::new(0),
                next_photon: AtomicU64::new(0),
                quota: AtomicU64::new(0),
                tally: Mutex::new(GroupTally::default()),
            })
            .collect(),
        stores: (0..stores).map(|_| PixelStore::new(pixels, nb)).collect(),
        threads_per_group: k,
        share,
        remask: match params.remask_phases {
            0 => 4,
            r => r,
        },
        alpha,
        forward_per_pixel: forward_per_pass as f64 / pixels as f64,
        seed,
        tiles_x,
        tiles_y,
        power_scale: eye.scene.total_power / (nb as f64 * std::f64::consts::PI * unit2),
        stop: AtomicBool::new(false),
        poison: AtomicBool::new(false),
        photon_next: AtomicU64::new(0),
        pass_budget: match params.passes {
            0 => u64::MAX,
            p => p.saturating_mul(pixels as u64),
        },
        pass_claimed: AtomicU64::new(0),
        global: Barrier::new(g),
        decision: AtomicBool::new(true),
        remask_round: AtomicU64::new(0),
        totals: Totals::default(),
    };
    if share {
        engine.deal_masks(0);
    }

    let start = Instant::now();
    let finished = AtomicUsize::new(0);
    let lost: Mutex<Option<String>> = Mutex::new(None);
    let mut mon = RenderMonitor::new(params, start);
    let interval = mon.interval();
    std::thread::scope(|s| {
        let mut spawned = 0;
        for gi in 0..g {
            for tid in 0..k {
                let (engine, finished, lost) = (&engine, &finished, &lost);
                let r = std::thread::Builder::new()
                    .name(format!("imap-render-{gi}.{tid}"))
                    .spawn_scoped(s, move || {
                        crate::error::quiet_thread();
                        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                            crate::fault::at(crate::fault::Point::Render);
                            engine.worker(gi, tid)
                        }));
                        if let Err(e) = r {
                            let msg = crate::error::panic_message(&*e);
                            *lost.lock().unwrap_or_else(|e| e.into_inner()) =
                                Some(format!("render thread {gi}.{tid} panicked: {msg}"));
                            engine.poison.store(true, Ordering::Relaxed);
                            engine.stop.store(true, Ordering::Relaxed);
                        }
                        finished.fetch_add(1, Ordering::Release);
                    });
                match r {
                    Ok(_) => spawned += 1,
                    Err(e) => {
                        *lost.lock().unwrap_or_else(|e| e.into_inner()) =
                            Some(format!("could not start a render thread: {e}"));
                        engine.poison.store(true, Ordering::Relaxed);
                        engine.stop.store(true, Ordering::Relaxed);
                    }
                }
            }
        }
        // The monitor.
        while finished.load(Ordering::Acquire) < spawned {
            std::thread::sleep(Duration::from_millis(2).min(interval));
            let now = Instant::now();
            if engine.stop.load(Ordering::Relaxed) {
                continue;
            }
            // The time budget is checked at every wake-up, not only at progress ticks.
            if let Some(why) = mon.criteria(1.0, false, now.duration_since(start).as_secs_f64()) {
                mon.stop = Some(why);
                engine.stop.store(true, Ordering::Relaxed);
                continue;
            }
            if !mon.due() {
                continue;
            }
            let cost = CostClock::start();
            let p = progress_of(&engine, start);
            if mon.tick(p, true, cost.spent()) {
                engine.stop.store(true, Ordering::Relaxed);
            }
        }
    });
    let wall_s = start.elapsed().as_secs_f64();
    let mut image = Image::new(desc.width, desc.height, nb);
    let rel_error = engine.estimate(Some(&mut image));
    let t = &engine.totals;
    let last = Progress {
        region_rel_error: 0.0,
        elapsed_s: wall_s,
        photons: t.forward_photons.load(Ordering::Relaxed),
        hits: t.backward_paths.load(Ordering::Relaxed),
        rel_error,
    };
    mon.finish(last);
    let stop = mon.stop.unwrap_or(StopReason::PhotonCount);
    let mut report = RenderReport {
        threads: g * k,
        groups: g,
        threads_per_group: k,
        wall_s,
        stop: Some(stop),
        rel_error,
        backward_paths: last.hits,
        backward_rays: t.backward_rays.load(Ordering::Relaxed),
        forward_photons: last.photons,
        forward_rays: t.forward_rays.load(Ordering::Relaxed),
        gathers: t.gathers.load(Ordering::Relaxed),
        joins: t.joins.load(Ordering::Relaxed),
        close_retries: t.close_retries.load(Ordering::Relaxed),
        gate_violations: t.violations.load(Ordering::Relaxed),
        dropped_paths: t.dropped_paths.load(Ordering::Relaxed),
        pixel_bytes: (stores * PixelStore::bytes(pixels, nb)) as u64,
        history: mon.history,
        ..Default::default()
    };
    let mut samples = 0u64;
    for s in &engine.stores {
        samples += (0..pixels).map(|p| s.count(p) as u64).sum::<u64>();
    }
    report.passes = samples as f64 / pixels as f64;
    let mut maps_total = 0u64;
    for grp in &engine.groups {
        let tally = grp.tally.lock().unwrap_or_else(|e| e.into_inner());
        report.phases += tally.phases;
        report.time_backward_s += tally.t_backward;
        report.time_build_s += tally.t_build;
        report.time_forward_s += tally.t_forward;
        report.time_close_s += tally.t_close;
        report.time_finalize_s += tally.t_finalize;
        report.map_bytes_per_group = report.map_bytes_per_group.max(tally.map_bytes as u64);
        maps_total += tally.map_bytes as u64;
    }
    report.total_bytes = maps_total + report.pixel_bytes;
    let lost = lost.into_inner().unwrap_or_else(|e| e.into_inner());
    (image, report, lost)
}

fn progress_of(engine: &Engine, start: Instant) -> Progress {
    Progress {
        region_rel_error: 0.0,
        elapsed_s: start.elapsed().as_secs_f64(),
        photons: engine.totals.forward_photons.load(Ordering::Relaxed),
        hits: engine.totals.backward_paths.load(Ordering::Relaxed),
        rel_error: engine.estimate(None),
    }
}

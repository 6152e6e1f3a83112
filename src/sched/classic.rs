//! The classic scheduler (the first paper, Fig. 1): calculating threads fill portions of
//! intersection records and push them on a shared stack; the thread that called `imap_run`
//! takes them off, computes each record's vertex contributions and accumulates them. Only
//! that thread writes the map, so accumulation needs no locks; it is also the bottleneck the
//! dynamic scheduler removes.
//!
//! Tuned as a fair baseline: portions come from a fixed pool (no allocation in the loop),
//! each calculating thread sorts its portion by (mesh, triangle) before handing it over so
//! the accumulator walks the map in memory order, photons collapsed to one band carry one
//! value instead of a full colour, and the hand-over is a pointer move on a channel.

use super::{Counters, PhotonSource, RunContext, RunMonitor, RunOutcome, RunParams, StopGuard};
use crate::imap::MapLayout;
use crate::imap::{grey_index, BufferedHit, IMap, PhotonBuffer, PhotonOut};
use crate::scene::PreparedScene;
use crate::spectral::Colour;
use crate::transport::{HitSink, PathStats};
use crossbeam::channel::{self, Receiver, RecvTimeoutError, Sender};
use std::time::Instant;

/// Records per portion.
const PORTION_RECORDS: usize = 2048;
/// Portions in the pool per calculating thread.
const PORTIONS_PER_THREAD: usize = 4;

/// One ray–surface intersection as the paper's classic scheme stores it.
#[derive(Clone, Copy, Debug)]
struct HitRec {
    /// mesh << 32 | triangle: the sort key.
    key: u64,
    u: f32,
    v: f32,
    /// Offset of the colour in the portion's colour arena.
    colour_at: u32,
    band: u16,
    side: u8,
    layer: u8,
}

/// A portion of intersection records (the paper's IOP).
struct Portion {
    recs: Vec<HitRec>,
    colours: Vec<f32>,
    /// (slot, a photon's squared contribution to it), for the error estimate.
    squares: Vec<(u32, f64)>,
    /// (slot, colour offset): whole contributions of photons folded per slot.
    slot_values: Vec<(u32, u32)>,
}

impl Portion {
    fn new(bands: usize) -> Self {
        Portion {
            recs: Vec::with_capacity(PORTION_RECORDS),
            colours: Vec::with_capacity(PORTION_RECORDS * bands),
            squares: Vec::new(),
            slot_values: Vec::new(),
        }
    }

    fn clear(&mut self) {
        self.recs.clear();
        self.colours.clear();
        self.squares.clear();
        self.slot_values.clear();
    }

    fn is_empty(&self) -> bool {
        self.recs.is_empty() && self.squares.is_empty() && self.slot_values.is_empty()
    }

    fn full(&self) -> bool {
        self.recs.len() + self.slot_values.len() >= PORTION_RECORDS
            || self.squares.len() >= PORTION_RECORDS
    }
}

/// The calculating thread's side: holds each photon's hits until its path ends, then
/// fills portions and hands them over.
struct PortionSink<'a> {
    scene: &'a PreparedScene,
    layout: &'a MapLayout,
    /// Sort portions by triangle before handing them over (`IMap::worth_sorting`).
    sort: bool,
    photon: PhotonBuffer,
    current: Option<Portion>,
    free: Receiver<Portion>,
    full: Sender<Portion>,
    wait_s: f64,
    regions: super::RegionSink<'a>,
}

impl PortionSink<'_> {
    /// The open portion, taking a free one when needed (the wait is counted).
    fn portion(&mut self) -> Option<&mut Portion> {
        if self.current.is_none() {
            let t = Instant::now();
            self.current = self.free.recv().ok();
            self.wait_s += t.elapsed().as_secs_f64();
        }
        self.current.as_mut()
    }

    fn send(&mut self) {
        if let Some(mut p) = self.current.take() {
            if p.is_empty() {
                self.current = Some(p);
                return;
            }
            if self.sort {
                p.recs.sort_unstable_by_key(|r| r.key);
            }
            // The receiver only goes away when the driving thread unwinds; the run is
            // lost then anyway.
            let _ = self.full.send(p);
        }
    }
}

impl PhotonOut for PortionSink<'_> {
    fn hit(&mut self, h: &BufferedHit, _cells: [usize; 3], colour: &[f32]) {
        // The accumulating thread finds the cells itself, after sorting by triangle.
        let Some(p) = self.portion() else {
            return;
        };
        let colour_at = p.colours.len() as u32;
        p.colours.extend_from_slice(colour);
        p.recs.push(HitRec {
            key: (h.mesh as u64) << 32 | h.prim as u64,
            u: h.u,
            v: h.v,
            colour_at,
            band: h.band,
            side: h.side,
            layer: h.layer,
        });
        if p.full() {
            self.send();
        }
    }

    fn square(&mut self, slot: usize, s2: f64) {
        if let Some(p) = self.portion() {
            p.squares.push((slot as u32, s2));
            if p.full() {
                self.send();
            }
        }
    }

    fn slot_value(&mut self, slot: usize, colour: &[f32]) {
        if let Some(p) = self.portion() {
            let at = p.colours.len() as u32;
            p.colours.extend_from_slice(colour);
            p.slot_values.push((slot as u32, at));
            if p.full() {
                self.send();
            }
        }
    }

    fn regions(&mut self, ids: &[u32], values: &[f64]) {
        self.regions.add(ids, values);
    }
}

impl HitSink for PortionSink<'_> {
    fn deposit(
        &mut self,
        at: (u32, u32, u8),
        (u, v): (f32, f32),
        colour: &Colour,
        weights: Option<[f32; 3]>,
    ) {
        self.photon
            .deposit(self.scene, self.layout, at, u, v, colour, weights);
    }

    fn begin_photon(&mut self, emitter: usize) {
        self.photon.begin(self.scene, self.layout, emitter);
    }

    fn direct_done(&mut self) {
        self.photon.direct_done();
    }

    fn end_photon(&mut self) {
        let mut photon = std::mem::replace(&mut self.photon, PhotonBuffer::new(0));
        photon.finish(self.scene, self.layout, self);
        self.photon = photon;
    }

    fn abort_photon(&mut self) {
        self.photon.abort();
    }

    fn batch_done(&mut self) {
        self.regions.flush();
    }
}

/// Applies a sorted portion to the map: the accumulating thread's work.
fn accumulate(map: &mut IMap, scene: &PreparedScene, layout: &MapLayout, p: &Portion) {
    let layers = layout.layers;
    // Spectral cells span many cache lines: fetch the cells of a hit a few hits ahead (8:
    // with most deposits one grey number, 2 left most fetches late; BENCHMARKS.md).
    let ahead = if map.bands() > 8 { 8 } else { 0 };
    for (i, r) in p.recs.iter().enumerate() {
        if let Some(n) = p.recs.get(i + ahead).filter(|_| ahead > 0) {
            let mesh = &scene.meshes[(n.key >> 32) as usize];
            for vertex in mesh.triangles[(n.key & 0xFFFF_FFFF) as usize] {
                if let Some(slot) = mesh.slot(vertex, n.side as usize) {
                    let cell = layers.cell(slot, n.layer);
                    if let Some((g, _)) = grey_index(n.band) {
                        map.prefetch_grey(cell, g);
                    } else {
                        map.prefetch(cell);
                    }
                }
            }
        }
        let mesh = &scene.meshes[(r.key >> 32) as usize];
        let cells = mesh.triangles[(r.key & 0xFFFF_FFFF) as usize].map(|vertex| {
            let slot = mesh
                .slot(vertex, r.side as usize)
                .expect("deposit on a recording mesh");
            layers.cell(slot, r.layer)
        });
        map.add_hit(
            cells,
            r.band,
            (r.u, r.v),
            &p.colours[r.colour_at as usize..],
        );
    }
    for &(slot, s2) in &p.squares {
        map.add_square(slot as usize, s2);
    }
    for &(slot, at) in &p.slot_values {
        let at = at as usize;
        map.add_colour(slot as usize, 1.0, &p.colours[at..at + map.bands()]);
    }
}

/// Bytes a run's buffers take at most: the pool of portions and each calculating thread's
/// photon buffer.
pub fn run_bytes(threads: usize, bands: usize) -> u64 {
    let portion = PORTION_RECORDS * (std::mem::size_of::<HitRec>() + 4 * bands + 16);
    let pool = (PORTIONS_PER_THREAD * threads + 2) * portion;
    pool as u64 + threads as u64 * PhotonBuffer::max_bytes(bands)
}

/// Runs the classic scheduler until a stop criterion is met.
pub fn run(rc: &RunContext, map: &mut IMap, params: &mut RunParams) -> RunOutcome {
    let source = PhotonSource::new(rc.plan.clone(), rc.selection);
    let bands = map.bands();
    let pool = PORTIONS_PER_THREAD * rc.threads + 2;
    let (free_tx, free_rx) = channel::bounded::<Portion>(pool);
    let (full_tx, full_rx) = channel::unbounded::<Portion>();
    for _ in 0..pool {
        free_tx
            .send(Portion::new(bands))
            .expect("pool fits its channel");
    }

    let sort = map.worth_sorting();
    let mut monitor = RunMonitor::new(params, rc);
    let mut counters = Counters {
        groups: 1,
        ..Default::default()
    };
    let mut stats = PathStats::new(rc.scene.meshes.len());
    let mut thread_lost = None;
    let mut busy_s = 0.0;

    std::thread::scope(|s| {
        // Should this thread unwind, the calculating threads must still stop.
        let _stop = StopGuard(&source);
        let mut handles = Vec::new();
        for t in 0..rc.threads {
            let (free, full, source, tracer, regions, layout) = (
                free_rx.clone(),
                full_tx.clone(),
                &source,
                &rc.tracer,
                rc.regions,
                rc.layout,
            );
            let spawned = std::thread::Builder::new()
                .name(format!("imap-calc-{t}"))
                .spawn_scoped(s, move || {
                    crate::error::quiet_thread();
                    let mut sink = PortionSink {
                        scene: tracer.scene,
                        layout,
                        sort,
                        photon: PhotonBuffer::new(tracer.bands),
                        current: None,
                        free,
                        full,
                        wait_s: 0.0,
                        regions: super::RegionSink::new(
                            regions,
                            tracer.scene,
                            layout,
                            tracer.bands,
                        ),
                    };
                    let mut stats = PathStats::new(tracer.scene.meshes.len());
                    let mut colour = Colour::new(tracer.bands);
                    super::trace_all(source, tracer, &mut colour, &mut sink, &mut stats);
                    sink.send();
                    sink.regions.flush();
                    (stats, sink.wait_s)
                });
            match spawned {
                Ok(h) => handles.push(h),
                Err(e) => {
                    thread_lost = Some(format!("could not start calculating thread {t}: {e}"));
                    source.stop();
                }
            }
        }
        drop(full_tx);

        // The accumulating (calling) thread: apply portions until every calculating thread
        // has finished and the stack is empty; watch the clock in between.
        loop {
            match full_rx.recv_timeout(monitor.timeout()) {
                Ok(mut p) => {
                    counters.peak_queue = counters.peak_queue.max(full_rx.len() as u64 + 1);
                    let t = Instant::now();
                    accumulate(map, rc.scene, rc.layout, &p);
                    busy_s += t.elapsed().as_secs_f64();
                    counters.portions += 1;
                    p.clear();
                    let _ = free_tx.send(p);
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            monitor.poll(
                &source,
                rc,
                &|n| super::global_error(map, rc, n),
                map,
                &super::target::Exclusive,
            );
        }
        for (t, h) in handles.into_iter().enumerate() {
            match h.join() {
                Ok((st, wait)) => {
                    stats.merge(&st);
                    counters.calc_wait_s += wait;
                }
                Err(_) => thread_lost = Some(format!("calculating thread {t} panicked")),
            }
        }
    });

    let wall_s = monitor.wall_s();
    counters.accum_busy_fraction = if wall_s > 0.0 { busy_s / wall_s } else { 0.0 };
    counters.accum_busy_s = busy_s;
    monitor.outcome(&source, map, rc, stats, counters, thread_lost)
}

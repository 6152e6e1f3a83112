//! Schedulers: how calculating threads, portions of hits and the map's accumulation are
//! organised during a run. Every scheduler traces exactly the photons `[start, end)` it
//! claims from a shared counter, so the set of deposits does not depend on the scheduler
//! or the thread count.

pub mod classic;
pub mod doze;
pub mod dynamic;
pub mod groups;
pub mod photons;
pub mod target;
pub mod trace_only;

pub use photons::{PhotonSource, RangeSet, Selection};

use crate::imap::regions::{RegionShared, RegionTally};
use crate::imap::MapLayout;
use crate::imap::{IMap, Readout};
use crate::scene::PreparedScene;
use crate::spectral::Colour;
use crate::transport::{HitSink, PathStats, Tracer};
use std::ops::Range;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use crate::progress::{deadline, push_history, CostClock, Schedule};
pub use crate::progress::{Progress, StopReason};

/// What a run is asked to do.
pub struct RunParams<'a> {
    /// Photons to trace in this run; 0 for no limit.
    pub photons: u64,
    /// Seconds this run may take; 0 for no limit.
    pub time_budget_s: f64,
    /// Stop when the global relative error is at or below this; 0 for no target.
    pub target_rel_error: f64,
    /// Stop when a measure of chosen meshes' error is at or below a target.
    pub region: Option<target::RegionTarget>,
    /// Seconds between progress reports (and target checks).
    pub progress_interval_s: f64,
    /// Safety limit on events per path; photons reaching it are dropped and reported.
    pub max_path_events: u32,
    /// Called at each progress interval and once at the end; returning false cancels.
    pub progress: Option<&'a mut dyn FnMut(&Progress) -> bool>,
    /// Which photon indices the run may trace (default: all; ranges and shards for runs
    /// split over processes).
    pub selection: Selection,
    /// The estimator (`transport::direct`); None: the one the map's photons were made
    /// with, or light sampling for an empty map. A map holds the photons of one estimator:
    /// another one needs a reset first.
    pub estimator: Option<crate::transport::direct::Estimator>,
}

impl Default for RunParams<'_> {
    /// Every photon, no stop criterion (set one), progress every 0.5 s, 2²⁰ events.
    fn default() -> Self {
        RunParams {
            photons: 0,
            time_budget_s: 0.0,
            target_rel_error: 0.0,
            region: None,
            progress_interval_s: 0.5,
            max_path_events: 1 << 20,
            progress: None,
            selection: Selection::ALL,
            estimator: None,
        }
    }
}

/// Scheduler instrumentation, in the run report.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Counters {
    /// Seconds the calculating threads together waited for a free portion.
    pub calc_wait_s: f64,
    /// Fraction of the run the accumulating thread(s) spent applying portions.
    pub accum_busy_fraction: f64,
    /// Seconds the accumulating thread (classic) or the processing threads together
    /// (dynamic) spent applying portions; portions a calculating thread applied itself are
    /// not timed. The benchmark's scaling model reads a per-hit cost from it.
    pub accum_busy_s: f64,
    /// Largest number of filled portions waiting to be applied.
    pub peak_queue: u64,
    /// Portions applied.
    pub portions: u64,
    /// Of those, portions a calculating thread applied itself because the group's owner was
    /// idle (dynamic scheduler).
    pub inline_portions: u64,
    /// Vertex-group splits (dynamic scheduler).
    pub splits: u64,
    /// Vertex groups at the end (dynamic scheduler); 1 for the classic scheduler's map.
    pub groups: u64,
}

/// What a scheduler hands back.
pub struct RunOutcome {
    pub stats: PathStats,
    pub wall_s: f64,
    pub stop: StopReason,
    pub counters: Counters,
    pub history: Vec<Progress>,
    /// A thread was lost (panicked or could not start); the text says which.
    pub thread_lost: Option<String>,
    /// The photon indices the run traced to their end.
    pub traced: RangeSet,
}

/// Everything a scheduler needs for one run.
pub struct RunContext<'a> {
    pub tracer: Tracer<'a>,
    pub scene: &'a PreparedScene,
    /// The map's layout for the scene.
    pub layout: &'a MapLayout,
    pub threads: usize,
    pub unit_m: f64,
    /// The local indices of `selection` this run may trace, in order
    /// (`photons::continue_plan`).
    pub plan: Vec<Range<u64>>,
    pub selection: Selection,
    /// Photons in the map before this run (the error estimate's count adds this run's).
    pub photons_before: u64,
    /// Bytes the run's growing buffers (the dynamic scheduler's pool) may take, on top of
    /// `run_bytes`: what the memory budget leaves.
    pub pool_bytes: u64,
    pub hits_before: u64,
    pub elapsed_before_s: f64,
    /// The run's region tallies (one slot per calculating thread).
    pub regions: &'a RegionShared,
    /// The region tallies of the photons before this run.
    pub regions_before: &'a RegionTally,
    /// Per mesh of the region target (in its order): each vertex's share of the target's
    /// triangles (scene units²; 0 outside it). Empty without a target.
    pub region_weights: &'a [Vec<f64>],
    /// The scene's host BSDFs: a failure in one of their calls stops the run at the next
    /// check (the context then returns IMAP_ERR_HOST_BSDF).
    pub host_bsdfs: &'a [std::sync::Arc<crate::scene::host::HostSurface>],
}

/// A calculating thread's region tallies: photons' totals added locally, handed to the
/// run's shared slot once per batch.
pub struct RegionSink<'a> {
    shared: &'a RegionShared,
    slot: usize,
    local: RegionTally,
    efficacy: &'a [f64],
}

impl<'a> RegionSink<'a> {
    pub fn new(
        rc_regions: &'a RegionShared,
        scene: &'a PreparedScene,
        layout: &MapLayout,
        bands: usize,
    ) -> Self {
        RegionSink {
            shared: rc_regions,
            slot: rc_regions.claim(),
            local: RegionTally::new(layout.regions.count, bands),
            efficacy: &scene.efficacy,
        }
    }

    #[inline]
    pub fn add(&mut self, ids: &[u32], values: &[f64]) {
        self.local.add_photon(ids, values, self.efficacy);
    }

    pub fn flush(&mut self) {
        self.shared.flush(self.slot, &mut self.local);
    }
}

/// Stops the photon source when dropped: a driving thread that unwinds still ends the
/// run's threads (the scope would otherwise wait for them for ever).
pub struct StopGuard<'s>(pub &'s PhotonSource);

impl Drop for StopGuard<'_> {
    fn drop(&mut self) {
        self.0.stop();
    }
}

/// Traces batches from `source` until it is exhausted or stopped. A photon cut short by a
/// stop, and the rest of its batch, are handed back to the source untraced.
pub fn trace_all(
    source: &PhotonSource,
    tracer: &Tracer,
    colour: &mut Colour,
    sink: &mut impl HitSink,
    stats: &mut PathStats,
) {
    let stop = source.stop_flag();
    while let Some(batch) = source.claim() {
        crate::fault::at(crate::fault::Point::Calc);
        let (photons, hits) = (stats.photons, stats.hits);
        for k in batch.clone() {
            if stop.load(Ordering::Relaxed) || !tracer.trace(k, colour, sink, stats, stop) {
                source.give_back(k..batch.end);
                break;
            }
        }
        source.add_done(stats.photons - photons, stats.hits - hits);
        sink.batch_done();
    }
}

impl RunContext<'_> {
    /// Each slot's neighbours, for the direct part's error (light sampling).
    pub fn neighbours(&self) -> Option<&dyn crate::imap::Neighbours> {
        self.tracer
            .direct
            .map(|d| d.plan as &dyn crate::imap::Neighbours)
    }
}

/// The global error of `map` after `photons` photons (the caller excludes writers).
pub fn global_error(map: &IMap, rc: &RunContext, photons: u64) -> Option<f64> {
    Readout {
        map,
        scene: rc.scene,
        photons,
        unit_m: rc.unit_m,
        layer: None,
        plan: rc.neighbours(),
    }
    .global_error()
}

/// The clock, stop criteria and progress reports of a run, driven by the thread that
/// calls `imap_run`.
pub struct RunMonitor<'p, 'a> {
    params: &'p mut RunParams<'a>,
    start: Instant,
    schedule: Schedule,
    /// When the time budget runs out (None: no budget, or beyond the clock's range).
    end: Option<Instant>,
    elapsed_before_s: f64,
    photons_before: u64,
    pub history: Vec<Progress>,
    pub stop: Option<StopReason>,
}

impl<'p, 'a> RunMonitor<'p, 'a> {
    pub fn new(params: &'p mut RunParams<'a>, rc: &RunContext) -> Self {
        let start = Instant::now();
        let schedule = Schedule::new(start, params.progress_interval_s);
        let end = if params.time_budget_s > 0.0 {
            deadline(start, params.time_budget_s)
        } else {
            None
        };
        RunMonitor {
            params,
            start,
            schedule,
            end,
            elapsed_before_s: rc.elapsed_before_s,
            photons_before: rc.photons_before,
            history: Vec::new(),
            stop: None,
        }
    }

    /// How long the driving thread may block before it must call `poll` again.
    pub fn timeout(&self) -> Duration {
        let until = match (self.schedule.next(), self.end) {
            (Some(a), Some(b)) => a.min(b),
            (Some(a), None) | (None, Some(a)) => a,
            (None, None) => return Duration::from_millis(100),
        };
        until
            .saturating_duration_since(Instant::now())
            .min(Duration::from_millis(100))
    }

    pub fn wall_s(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// Checks the clock; at a progress tick evaluates the error (`error` gets the photon
    /// count) and calls the callback. Returns true when the run must stop.
    /// `map` and `access` read the chosen meshes for a region target.
    pub fn poll(
        &mut self,
        source: &PhotonSource,
        rc: &RunContext,
        error: &dyn Fn(u64) -> Option<f64>,
        map: &IMap,
        access: &dyn target::SlotAccess,
    ) -> bool {
        let now = Instant::now();
        if self.stop.is_none() && self.end.is_some_and(|end| now >= end) {
            self.stop = Some(StopReason::TimeBudget);
        }
        if self.stop.is_none() && rc.host_bsdfs.iter().any(|h| h.failed()) {
            self.stop = Some(StopReason::Cancelled);
        }
        if self.stop.is_none() && self.schedule.next().is_some_and(|t| now >= t) {
            let cost = CostClock::start();
            let hits = rc.hits_before + source.hits();
            let photons = self.photons_before + source.traced();
            let err = error(photons);
            let region = self.region_error(map, rc, photons, access);
            let p = self.record(photons, hits, err, region);
            self.schedule.done(cost.spent());
            let region_met = self
                .params
                .region
                .as_ref()
                .is_some_and(|t| region.flatten().is_some_and(|e| e <= t.target));
            if self.params.target_rel_error > 0.0 && p.rel_error <= self.params.target_rel_error {
                self.stop = Some(StopReason::TargetError);
            } else if region_met {
                self.stop = Some(StopReason::RegionTarget);
            }
            // The callback sees every check, the one that met a target too (its answer
            // then no longer matters).
            if let Some(cb) = self.params.progress.as_mut() {
                if !cb(&p) && self.stop.is_none() {
                    self.stop = Some(StopReason::Cancelled);
                }
            }
        }
        if self.stop.is_some() {
            source.stop();
        }
        self.stop.is_some()
    }

    /// The region target's measure: None without a target, Some(None) before the chosen
    /// meshes received anything.
    fn region_error(
        &self,
        map: &IMap,
        rc: &RunContext,
        photons: u64,
        access: &dyn target::SlotAccess,
    ) -> Option<Option<f64>> {
        let t = self.params.region.as_ref()?;
        Some(target::region_error(t, map, rc, photons, access))
    }

    /// Records a history point.
    fn record(
        &mut self,
        photons: u64,
        hits: u64,
        rel_error: Option<f64>,
        region: Option<Option<f64>>,
    ) -> Progress {
        let p = Progress {
            elapsed_s: self.elapsed_before_s + self.wall_s(),
            photons,
            hits,
            rel_error: rel_error.unwrap_or(crate::imap::NO_DATA_REL_ERROR),
            region_rel_error: region.map_or(0.0, |r| r.unwrap_or(crate::imap::NO_DATA_REL_ERROR)),
        };
        push_history(&mut self.history, p);
        p
    }

    /// Ends the run: the final report (the callback sees it too), and the outcome.
    pub fn outcome(
        mut self,
        source: &PhotonSource,
        map: &IMap,
        rc: &RunContext,
        stats: PathStats,
        counters: Counters,
        thread_lost: Option<String>,
    ) -> RunOutcome {
        let wall_s = self.wall_s();
        let photons = self.photons_before + stats.photons;
        let p = self.record(
            photons,
            rc.hits_before + stats.hits,
            global_error(map, rc, photons),
            self.region_error(map, rc, photons, &target::Exclusive),
        );
        if let Some(cb) = self.params.progress.as_mut() {
            // The final report: its answer no longer matters.
            cb(&p);
        }
        RunOutcome {
            stats,
            wall_s,
            stop: self.stop.unwrap_or(StopReason::PhotonCount),
            counters,
            history: self.history,
            thread_lost,
            traced: source.traced_set(),
        }
    }
}

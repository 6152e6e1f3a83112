//! Schedulers: how calculating threads, portions of hits and the map's accumulation are
//! organised during a run. Every scheduler traces exactly the photons `[start, end)` it
//! claims from a shared counter, so the set of deposits does not depend on the scheduler
//! or the thread count.

pub mod classic;
pub mod dynamic;
pub mod groups;
pub mod trace_only;

use crate::imap::{IMap, Readout};
use crate::scene::PreparedScene;
use crate::transport::{PathStats, Tracer};
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// One point of the error-against-time history.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Run time in seconds, summed over all runs since the map was last reset.
    pub elapsed_s: f64,
    /// Photons traced since the last reset.
    pub photons: u64,
    /// Ray–surface intersections since the last reset.
    pub hits: u64,
    /// Estimated global relative error (see `imap::Readout::global_error`); 1 before any
    /// deposit.
    pub rel_error: f64,
}

/// Why a run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    PhotonCount,
    TimeBudget,
    TargetError,
    Cancelled,
}

/// What a run is asked to do.
pub struct RunParams<'a> {
    /// Photons to trace in this run; 0 for no limit.
    pub photons: u64,
    /// Seconds this run may take; 0 for no limit.
    pub time_budget_s: f64,
    /// Stop when the global relative error is at or below this; 0 for no target.
    pub target_rel_error: f64,
    /// Seconds between progress reports (and target checks).
    pub progress_interval_s: f64,
    /// Safety limit on events per path; photons reaching it are dropped and reported.
    pub max_path_events: u32,
    /// Called at each progress interval and once at the end; returning false cancels.
    pub progress: Option<&'a mut dyn FnMut(&Progress) -> bool>,
}

/// Scheduler instrumentation, in the run report.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Counters {
    /// Seconds the calculating threads together waited for a free portion.
    pub calc_wait_s: f64,
    /// Fraction of the run the accumulating thread(s) spent applying portions.
    pub accum_busy_fraction: f64,
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
}

/// Everything a scheduler needs for one run.
pub struct RunContext<'a> {
    pub tracer: Tracer<'a>,
    pub scene: &'a PreparedScene,
    pub threads: usize,
    pub unit_m: f64,
    /// Photons traced before this run: the run's photons are `first_photon..`.
    pub first_photon: u64,
    pub hits_before: u64,
    pub elapsed_before_s: f64,
}

/// Photons handed out in batches from one counter. A claimed batch is always traced to the
/// end, so the photons traced are exactly `start..min(next, end)`.
pub struct PhotonSource {
    next: AtomicU64,
    end: u64,
    stop: AtomicBool,
    /// Hits of finished batches, for progress reports.
    hits: AtomicU64,
}

/// Photons per claim: small enough to stop quickly, large enough that the counter is cold.
pub const BATCH: u64 = 64;

impl PhotonSource {
    pub fn new(start: u64, photons: u64) -> Self {
        let end = if photons == 0 {
            u64::MAX
        } else {
            start.saturating_add(photons)
        };
        PhotonSource {
            next: AtomicU64::new(start),
            end,
            stop: AtomicBool::new(false),
            hits: AtomicU64::new(0),
        }
    }

    pub fn claim(&self) -> Option<Range<u64>> {
        if self.stop.load(Ordering::Relaxed) {
            return None;
        }
        let s = self.next.fetch_add(BATCH, Ordering::Relaxed);
        (s < self.end).then(|| s..(s + BATCH).min(self.end))
    }

    /// Traces a batch at a time until the source is exhausted or stopped.
    pub fn trace_all(
        &self,
        tracer: &Tracer,
        colour: &mut crate::transport::Colour,
        sink: &mut impl crate::transport::HitSink,
        stats: &mut PathStats,
    ) {
        while let Some(batch) = self.claim() {
            let before = stats.hits;
            for k in batch {
                tracer.trace(k, colour, sink, stats);
            }
            self.hits.fetch_add(stats.hits - before, Ordering::Relaxed);
            sink.batch_done();
        }
    }

    /// Hits of the batches finished so far in this run.
    pub fn hits(&self) -> u64 {
        self.hits.load(Ordering::Relaxed)
    }

    pub fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
    }

    /// Photons claimed so far (all traced once the threads have finished).
    pub fn claimed(&self) -> u64 {
        self.next.load(Ordering::Relaxed).min(self.end)
    }
}

/// The global error of `map` after `photons` photons (the caller excludes writers).
pub fn global_error(map: &IMap, rc: &RunContext, photons: u64) -> Option<f64> {
    Readout {
        map,
        scene: rc.scene,
        photons,
        unit_m: rc.unit_m,
    }
    .global_error()
}

/// The clock, stop criteria and progress reports of a run, driven by the thread that
/// calls `imap_run`.
pub struct Monitor<'p, 'a> {
    params: &'p mut RunParams<'a>,
    start: Instant,
    next_tick: Instant,
    elapsed_before_s: f64,
    pub history: Vec<Progress>,
    pub stop: Option<StopReason>,
}

impl<'p, 'a> Monitor<'p, 'a> {
    pub fn new(params: &'p mut RunParams<'a>, elapsed_before_s: f64) -> Self {
        let start = Instant::now();
        let next_tick = start + Duration::from_secs_f64(params.progress_interval_s);
        Monitor {
            params,
            start,
            next_tick,
            elapsed_before_s,
            history: Vec::new(),
            stop: None,
        }
    }

    /// How long the driving thread may block before it must call `poll` again.
    pub fn timeout(&self) -> Duration {
        let mut until = self.next_tick;
        if self.params.time_budget_s > 0.0 {
            until = until.min(self.start + Duration::from_secs_f64(self.params.time_budget_s));
        }
        until.saturating_duration_since(Instant::now())
    }

    pub fn wall_s(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// Checks the clock; at a progress tick evaluates the error (`error` gets the photon
    /// count) and calls the callback. Returns true when the run must stop.
    pub fn poll(
        &mut self,
        source: &PhotonSource,
        rc: &RunContext,
        error: &dyn Fn(u64) -> Option<f64>,
    ) -> bool {
        let hits = rc.hits_before + source.hits();
        let now = Instant::now();
        if self.stop.is_none()
            && self.params.time_budget_s > 0.0
            && self.wall_s() >= self.params.time_budget_s
        {
            self.stop = Some(StopReason::TimeBudget);
        }
        if now >= self.next_tick && self.stop.is_none() {
            while self.next_tick <= now {
                self.next_tick += Duration::from_secs_f64(self.params.progress_interval_s);
            }
            let photons = source.claimed();
            let p = self.record(photons, hits, error(photons));
            if self.params.target_rel_error > 0.0 && p.rel_error <= self.params.target_rel_error {
                self.stop = Some(StopReason::TargetError);
            } else if let Some(cb) = self.params.progress.as_mut() {
                if !cb(&p) {
                    self.stop = Some(StopReason::Cancelled);
                }
            }
        }
        if self.stop.is_some() {
            source.stop();
        }
        self.stop.is_some()
    }

    /// Records a history point.
    fn record(&mut self, photons: u64, hits: u64, rel_error: Option<f64>) -> Progress {
        let p = Progress {
            elapsed_s: self.elapsed_before_s + self.wall_s(),
            photons,
            hits,
            rel_error: rel_error.unwrap_or(crate::imap::NO_DATA_REL_ERROR),
        };
        self.history.push(p);
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
        let stop = self.finish(source.claimed(), rc.hits_before + stats.hits, map, rc);
        RunOutcome {
            stats,
            wall_s,
            stop,
            counters,
            history: self.history,
            thread_lost,
        }
    }

    /// The final report of the run; the callback sees it too (its answer no longer matters).
    fn finish(&mut self, photons: u64, hits: u64, map: &IMap, rc: &RunContext) -> StopReason {
        let p = self.record(photons, hits, global_error(map, rc, photons));
        if let Some(cb) = self.params.progress.as_mut() {
            cb(&p);
        }
        self.stop.unwrap_or(StopReason::PhotonCount)
    }
}

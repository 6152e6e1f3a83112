//! Progress of runs and renders alike: the error-against-time history (`Progress`, kept
//! bounded by `push_history`), why a job stopped (`StopReason`), and when the next
//! progress point falls due (`Schedule`): every interval, later when evaluating the last
//! point cost more than a twentieth of it in CPU time (`CostClock`). The run's monitor
//! (`sched`), the renderer's and final gathering's build on these.

use std::time::{Duration, Instant};

/// Shortest progress interval: below it the checks would cost more than they tell.
pub const MIN_PROGRESS_INTERVAL_S: f64 = 1e-3;
/// Most points a history keeps; past it, every other old point is dropped.
pub const MAX_HISTORY: usize = 4096;
/// Largest share of the wall time the progress evaluations may take: the interval is
/// lengthened when the last evaluation cost (in CPU time) more than this share of it.
const MAX_PROGRESS_SHARE: f64 = 0.05;

/// What a progress evaluation costs: the CPU time the calling thread spends on it. The wall
/// clock would also count the time the thread waited for a core, so on a loaded machine a
/// preempted evaluation would look slow and stretch the interval (20 × the wait) for nothing.
pub struct CostClock {
    wall: Instant,
    cpu: Option<Duration>,
}

impl CostClock {
    pub fn start() -> Self {
        CostClock {
            wall: Instant::now(),
            cpu: thread_cpu_time(),
        }
    }

    /// The CPU time spent since `start` (the wall time where the clock is unavailable).
    pub fn spent(&self) -> Duration {
        match (self.cpu, thread_cpu_time()) {
            (Some(a), Some(b)) => b.saturating_sub(a),
            _ => self.wall.elapsed(),
        }
    }
}

/// When the next progress point is due: one interval on, or later when the last
/// evaluation cost more than `MAX_PROGRESS_SHARE` of it (maps and renders alike).
fn next_tick(interval: Duration, cost: Duration) -> Option<Instant> {
    Instant::now().checked_add(interval.max(cost.mul_f64(1.0 / MAX_PROGRESS_SHARE)))
}

use crate::platform::thread_cpu_time;

/// A duration of `s` seconds (any non-negative number; huge values saturate).
pub fn duration_s(s: f64) -> Duration {
    Duration::try_from_secs_f64(s.max(0.0)).unwrap_or(Duration::MAX)
}

/// `start + s` seconds, or None when that is beyond what the clock can represent (as good
/// as never).
pub fn deadline(start: Instant, s: f64) -> Option<Instant> {
    start.checked_add(duration_s(s))
}

/// Appends `p` to a history of at most `MAX_HISTORY` points: when full, every other point
/// (the first and the newest kept) is dropped, so old points thin out evenly.
pub fn push_history(history: &mut Vec<Progress>, p: Progress) {
    if history.len() >= MAX_HISTORY {
        let mut i = 0;
        let last = history.len() - 1;
        history.retain(|_| {
            let keep = i % 2 == 0 || i == last;
            i += 1;
            keep
        });
    }
    history.push(p);
}

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
    /// The region target's measure (`RunParams::region`); 0 when the run has none, 1
    /// before the chosen meshes received anything.
    pub region_rel_error: f64,
}

/// Why a run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    PhotonCount,
    TimeBudget,
    TargetError,
    Cancelled,
    /// The region target's measure reached its target.
    RegionTarget,
}

/// When progress points fall due: one interval after the start, then one interval after
/// each evaluation, or later when it cost more than `MAX_PROGRESS_SHARE` of the interval.
#[derive(Clone, Copy, Debug)]
pub struct Schedule {
    interval: Duration,
    next: Option<Instant>,
}

impl Schedule {
    /// Points every `interval_s` seconds (at least `MIN_PROGRESS_INTERVAL_S`) from `start`.
    pub fn new(start: Instant, interval_s: f64) -> Self {
        Self::every(start, duration_s(interval_s.max(MIN_PROGRESS_INTERVAL_S)))
    }

    /// Points every `interval` from `start`, as given.
    pub fn every(start: Instant, interval: Duration) -> Self {
        Schedule {
            interval,
            next: start.checked_add(interval),
        }
    }

    pub fn interval(&self) -> Duration {
        self.interval
    }

    /// When the next point is due (None: beyond the clock's range).
    pub fn next(&self) -> Option<Instant> {
        self.next
    }

    /// Reschedules after an evaluation that cost `cost`.
    pub fn done(&mut self, cost: Duration) {
        self.next = next_tick(self.interval, cost);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_evaluation_costs_its_cpu_time_not_its_waits() {
        // A thread that waits (as a preempted monitor does) spends no CPU time: the
        // progress interval must not grow with it.
        let clock = CostClock::start();
        std::thread::sleep(Duration::from_millis(60));
        let waited = clock.spent();
        assert!(waited < Duration::from_millis(30), "{waited:?}");
        // Work is counted.
        let clock = CostClock::start();
        let t = Instant::now();
        let mut x = 1u64;
        while t.elapsed() < Duration::from_millis(20) {
            x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
        }
        assert!(clock.spent() > Duration::ZERO, "{x}");
    }

    #[test]
    fn durations_saturate_and_histories_stay_bounded() {
        assert_eq!(duration_s(1e300), Duration::MAX);
        assert_eq!(duration_s(-1.0), Duration::ZERO);
        assert!(deadline(Instant::now(), 1e19).is_none());
        assert!(deadline(Instant::now(), 1.0).is_some());
        let mut h = Vec::new();
        for i in 0..100_000u64 {
            push_history(
                &mut h,
                Progress {
                    elapsed_s: i as f64,
                    photons: i,
                    hits: 0,
                    rel_error: 1.0,
                    region_rel_error: 0.0,
                },
            );
            assert!(h.len() <= MAX_HISTORY);
        }
        assert_eq!(h[0].photons, 0);
        assert_eq!(h.last().unwrap().photons, 99_999);
        assert!(h.windows(2).all(|w| w[0].photons < w[1].photons));
    }
}

//! A render's progress points on the calling thread (`progress::Schedule` and the
//! criteria).

use super::RenderParams;
use crate::progress::{push_history, Progress, Schedule, StopReason};
use std::time::{Duration, Instant};

/// A render's progress points (on the calling thread): the history, the callback and the
/// time and error criteria, at `progress_interval_s` (lengthened while an estimate would
/// take more than a twentieth of it).
pub struct RenderMonitor<'p, 'a> {
    pub params: &'p mut RenderParams<'a>,
    pub start: Instant,
    schedule: Schedule,
    pub history: Vec<Progress>,
    pub stop: Option<StopReason>,
}

impl<'p, 'a> RenderMonitor<'p, 'a> {
    pub fn new(params: &'p mut RenderParams<'a>, start: Instant) -> Self {
        let schedule = Schedule::new(start, params.progress_interval_s);
        RenderMonitor {
            params,
            start,
            schedule,
            history: Vec::new(),
            stop: None,
        }
    }

    pub fn interval(&self) -> Duration {
        self.schedule.interval()
    }

    /// Whether a progress point is due.
    pub fn due(&self) -> bool {
        self.schedule.next().is_none_or(|t| Instant::now() >= t)
    }

    /// Records progress point `p` (its estimate cost `took` of CPU time), calls the
    /// callback, checks the criteria (the error only when `settled`: every pixel has an
    /// estimate) and schedules the next point. True: stop.
    pub fn tick(&mut self, p: Progress, settled: bool, took: Duration) -> bool {
        push_history(&mut self.history, p);
        let mut why = None;
        if let Some(cb) = self.params.progress.as_mut() {
            if !cb(&p) {
                why = Some(StopReason::Cancelled);
            }
        }
        why = why.or(self.criteria(p.rel_error, settled, p.elapsed_s));
        self.stop = self.stop.or(why);
        self.schedule.done(took);
        self.stop.is_some()
    }

    /// The time and error criteria.
    pub fn criteria(&self, rel_error: f64, settled: bool, elapsed_s: f64) -> Option<StopReason> {
        let p = &*self.params;
        if p.time_budget_s > 0.0 && elapsed_s >= p.time_budget_s {
            Some(StopReason::TimeBudget)
        } else if p.target_rel_error > 0.0 && settled && rel_error <= p.target_rel_error {
            Some(StopReason::TargetError)
        } else {
            None
        }
    }

    /// The last progress point: recorded and given to the callback.
    pub fn finish(&mut self, last: Progress) {
        push_history(&mut self.history, last);
        if let Some(cb) = self.params.progress.as_mut() {
            cb(&last);
        }
    }
}

//! Which photons a run traces, and which the map holds.
//!
//! Photon k's random stream depends only on (seed, k), so the map is a function of the
//! *set* of photon indices traced to their end. The context keeps that set (`RangeSet`);
//! a run is given a plan (the lowest indices not yet traced, or an explicit range) and
//! hands photons out in batches from one counter (`PhotonSource`). When a run is stopped
//! (time budget, target, cancel) in the middle of a path, the photon in flight is
//! abandoned with everything it deposited, and it and the rest of its batch go back to the
//! untraced set: the next run traces them from their start. So the map is always the sum
//! of whole photons, and a run stopped and resumed gives the map of an uninterrupted one.

use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;

/// A set of photon indices as sorted, disjoint, non-adjacent half-open ranges.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RangeSet {
    ranges: Vec<Range<u64>>,
}

impl RangeSet {
    pub fn new() -> Self {
        RangeSet::default()
    }

    /// The ranges, in increasing order.
    pub fn ranges(&self) -> &[Range<u64>] {
        &self.ranges
    }

    /// Number of indices in the set.
    pub fn len(&self) -> u64 {
        self.ranges.iter().map(|r| r.end - r.start).sum()
    }

    pub fn is_empty(&self) -> bool {
        self.ranges.is_empty()
    }

    pub fn clear(&mut self) {
        self.ranges.clear();
    }

    /// Adds `r` (overlaps and neighbours merge).
    pub fn insert(&mut self, r: Range<u64>) {
        if r.start >= r.end {
            return;
        }
        // First range that ends at or after r.start (could merge), last that starts at or
        // before r.end.
        let lo = self.ranges.partition_point(|x| x.end < r.start);
        let hi = self.ranges.partition_point(|x| x.start <= r.end);
        let (mut start, mut end) = (r.start, r.end);
        if lo < hi {
            start = start.min(self.ranges[lo].start);
            end = end.max(self.ranges[hi - 1].end);
        }
        self.ranges.splice(lo..hi, std::iter::once(start..end));
    }

    /// Whether any index of `r` is in the set.
    pub fn intersects(&self, r: &Range<u64>) -> bool {
        let i = self.ranges.partition_point(|x| x.end <= r.start);
        self.ranges.get(i).is_some_and(|x| x.start < r.end)
    }

    /// The parts of `within` that are not in the set, in increasing order.
    pub fn gaps(&self, within: Range<u64>) -> Vec<Range<u64>> {
        let mut out = Vec::new();
        let mut at = within.start;
        let first = self.ranges.partition_point(|x| x.end <= within.start);
        for x in &self.ranges[first..] {
            if x.start >= within.end {
                break;
            }
            if x.start > at {
                out.push(at..x.start);
            }
            at = at.max(x.end);
        }
        if at < within.end {
            out.push(at..within.end);
        }
        out
    }
}

/// Photons per claim: small enough to stop quickly, large enough that the counter is cold.
pub(crate) const BATCH: u64 = 64;

/// Photons handed out in batches from one counter over a plan of ranges. Each range takes
/// a whole number of batches of the counter's space, so a batch never spans two ranges.
pub struct PhotonSource {
    plan: Vec<Range<u64>>,
    /// Counter position where each range starts (multiples of BATCH), and the end.
    starts: Vec<u64>,
    next: AtomicU64,
    stop: AtomicBool,
    /// Hits of finished batches, for progress reports.
    hits: AtomicU64,
    /// Photons traced to their end.
    traced: AtomicU64,
    /// Claimed photons that were not traced (stopped mid-batch), returned to the plan.
    returned: Mutex<Vec<Range<u64>>>,
}

impl PhotonSource {
    /// A source over `plan` (increasing, disjoint ranges).
    pub fn new(plan: Vec<Range<u64>>) -> Self {
        let mut starts = Vec::with_capacity(plan.len() + 1);
        let mut at = 0u64;
        for r in &plan {
            starts.push(at);
            let batches = (r.end - r.start).div_ceil(BATCH);
            at = at.saturating_add(batches.saturating_mul(BATCH));
        }
        starts.push(at);
        PhotonSource {
            plan,
            starts,
            next: AtomicU64::new(0),
            stop: AtomicBool::new(false),
            hits: AtomicU64::new(0),
            traced: AtomicU64::new(0),
            returned: Mutex::new(Vec::new()),
        }
    }

    /// The next batch of photon indices, or None when the plan is done or the run stopped.
    pub fn claim(&self) -> Option<Range<u64>> {
        if self.stop.load(Ordering::Relaxed) {
            return None;
        }
        let end = *self.starts.last().expect("starts has the end");
        let v = self.next.fetch_add(BATCH, Ordering::Relaxed);
        if v >= end {
            return None;
        }
        let i = self.starts.partition_point(|&s| s <= v) - 1;
        let r = &self.plan[i];
        let first = r.start + (v - self.starts[i]);
        Some(first..(first + BATCH).min(r.end))
    }

    /// The stop flag: set when the run must end; paths in flight poll it and are abandoned.
    pub fn stop_flag(&self) -> &AtomicBool {
        &self.stop
    }

    pub fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
    }

    pub fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// Records that the photons of `r` were claimed but not traced.
    pub fn give_back(&self, r: Range<u64>) {
        if r.start < r.end {
            self.returned
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .push(r);
        }
    }

    /// Counts finished photons and their hits.
    pub fn add_done(&self, photons: u64, hits: u64) {
        self.traced.fetch_add(photons, Ordering::Relaxed);
        self.hits.fetch_add(hits, Ordering::Relaxed);
    }

    /// Hits of the photons finished so far in this run.
    pub fn hits(&self) -> u64 {
        self.hits.load(Ordering::Relaxed)
    }

    /// Photons traced to their end so far in this run.
    pub fn traced(&self) -> u64 {
        self.traced.load(Ordering::Relaxed)
    }

    /// After the run: the photon indices it traced to their end.
    pub fn traced_set(&self) -> RangeSet {
        let cursor = self.next.load(Ordering::Relaxed);
        let mut set = RangeSet::new();
        for (i, r) in self.plan.iter().enumerate() {
            if cursor <= self.starts[i] {
                break;
            }
            let claimed = (cursor - self.starts[i]).min(r.end - r.start);
            set.insert(r.start..r.start + claimed);
        }
        let returned = self.returned.lock().unwrap_or_else(|p| p.into_inner());
        let mut out = RangeSet::new();
        // set − returned (returned ranges are disjoint sub-ranges of claimed ones).
        let mut holes = RangeSet::new();
        for r in returned.iter() {
            holes.insert(r.clone());
        }
        for r in set.ranges() {
            for g in holes.gaps(r.clone()) {
                out.insert(g);
            }
        }
        out
    }
}

/// The plan of a run asked for `photons` photons (0 = no limit): the lowest indices not in
/// `traced`.
pub fn continue_plan(traced: &RangeSet, photons: u64) -> Vec<Range<u64>> {
    let mut plan = Vec::new();
    let mut left = if photons == 0 { u64::MAX } else { photons };
    for g in traced.gaps(0..u64::MAX) {
        if left == 0 {
            break;
        }
        let n = (g.end - g.start).min(left);
        plan.push(g.start..g.start + n);
        left -= n;
    }
    plan
}

#[cfg(test)]
#[allow(clippy::single_range_in_vec_init)]
mod tests {
    use super::*;

    #[test]
    fn range_sets_merge_and_find_gaps() {
        let mut s = RangeSet::new();
        s.insert(10..20);
        s.insert(30..40);
        s.insert(20..25); // touches: merges
        assert_eq!(s.ranges(), &[10..25, 30..40]);
        s.insert(5..35); // swallows both
        assert_eq!(s.ranges(), &[5..40]);
        s.insert(50..60);
        assert_eq!(s.gaps(0..100), vec![0..5, 40..50, 60..100]);
        assert_eq!(s.gaps(45..55), vec![45..50]);
        assert_eq!(s.len(), 45);
        assert!(s.intersects(&(39..41)) && !s.intersects(&(40..50)));
        assert_eq!(continue_plan(&s, 10), vec![0..5, 40..45]);
    }

    #[test]
    fn a_source_never_spans_ranges_and_returns_what_it_did_not_trace() {
        let src = PhotonSource::new(vec![0..100, 200..230]);
        let mut got = Vec::new();
        while let Some(b) = src.claim() {
            got.push(b);
        }
        assert_eq!(got, vec![0..64, 64..100, 200..230]);
        src.give_back(70..100);
        assert_eq!(src.traced_set().ranges(), &[0..70, 200..230]);
        // A stopped source hands out nothing more; unclaimed parts are not traced.
        let src = PhotonSource::new(vec![0..1000]);
        assert_eq!(src.claim(), Some(0..64));
        src.stop();
        assert_eq!(src.claim(), None);
        assert_eq!(src.traced_set().ranges(), &[0..64]);
    }
}

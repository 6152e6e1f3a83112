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
        self.overlap(r).is_some()
    }

    /// The first part of `r` that is in the set, if any.
    pub fn overlap(&self, r: &Range<u64>) -> Option<Range<u64>> {
        let i = self.ranges.partition_point(|x| x.end <= r.start);
        let x = self.ranges.get(i).filter(|x| x.start < r.end)?;
        Some(x.start.max(r.start)..x.end.min(r.end))
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

/// Photons per block of a strided selection (`Selection::block`) unless a caller says.
pub const DEFAULT_BLOCK: u64 = 1 << 16;

/// Which photon indices a run may trace: `[first, end)`, or of it only the blocks of
/// `block` photons that fall to shard `shard` of `shards` (blocks dealt round robin:
/// block `c·shards + shard` of the range, for c = 0, 1, …). Processes that each run one
/// shard of the same selection trace every photon of `[first, end)` exactly once between
/// them, whatever each one's photon count, time budget or target: the union of what they
/// traced is always a set of whole, distinct photons, and the merged map is the map of
/// that set. A run traces the lowest indices of its selection that the map does not hold
/// yet ("local" order: the shard's photons numbered 0, 1, … in increasing index order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Selection {
    pub first: u64,
    /// One past the last index; `u64::MAX` for no end.
    pub end: u64,
    pub shards: u64,
    pub shard: u64,
    /// Photons per block: a positive multiple of 64 (`BATCH`).
    pub block: u64,
}

impl Default for Selection {
    fn default() -> Self {
        Selection::ALL
    }
}

impl Selection {
    /// Every photon index.
    pub const ALL: Selection = Selection {
        first: 0,
        end: u64::MAX,
        shards: 1,
        shard: 0,
        block: DEFAULT_BLOCK,
    };

    /// The indices `[first, end)`.
    pub fn range(first: u64, end: u64) -> Self {
        Selection {
            first,
            end,
            ..Selection::ALL
        }
    }

    /// Shard `shard` of `shards` of every photon index, in blocks of `DEFAULT_BLOCK`.
    pub fn shard(shard: u64, shards: u64) -> Self {
        Selection {
            shards,
            shard,
            ..Selection::ALL
        }
    }

    /// Why the selection is unusable (naming the field), if it is.
    pub fn check(&self) -> Option<String> {
        if self.first > self.end {
            return Some(format!(
                "photon_first = {} is after the selection's end {}",
                self.first, self.end
            ));
        }
        if self.shards == 0 {
            return Some("shard_count is 0: give 1 for no sharding".into());
        }
        if self.shard >= self.shards {
            return Some(format!(
                "shard_index = {} is not below shard_count = {}",
                self.shard, self.shards
            ));
        }
        if self.block == 0 || self.block % BATCH != 0 {
            return Some(format!(
                "shard_block = {} is not a positive multiple of {BATCH}",
                self.block
            ));
        }
        if self.block.checked_mul(self.shards).is_none() {
            return Some(format!(
                "shard_block × shard_count = {} × {} overflows",
                self.block, self.shards
            ));
        }
        None
    }

    fn cycle(&self) -> u64 {
        self.block * self.shards
    }

    /// How many indices the selection holds (local indices are `0 .. local_len()`).
    pub fn local_len(&self) -> u64 {
        let span = self.end - self.first;
        if self.shards == 1 {
            return span;
        }
        let (cycles, rem) = (span / self.cycle(), span % self.cycle());
        let own = rem.saturating_sub(self.shard * self.block).min(self.block);
        cycles * self.block + own
    }

    /// The global index of local index `j` (`j < local_len()`).
    #[inline]
    pub fn global(&self, j: u64) -> u64 {
        if self.shards == 1 {
            return self.first + j;
        }
        self.first + (j / self.block) * self.cycle() + self.shard * self.block + j % self.block
    }

    /// The global ranges of the local range `r` (one per block it touches).
    pub fn global_ranges(&self, r: Range<u64>, mut f: impl FnMut(Range<u64>)) {
        if r.start >= r.end {
            return;
        }
        if self.shards == 1 {
            return f(self.global(r.start)..self.global(r.end - 1) + 1);
        }
        let mut j = r.start;
        while j < r.end {
            let block_end = (j / self.block + 1) * self.block;
            let e = block_end.min(r.end);
            let g = self.global(j);
            f(g..g + (e - j));
            j = e;
        }
    }

    /// The local indices of the part of global range `r` that is in the selection.
    pub fn local_ranges(&self, r: Range<u64>, mut f: impl FnMut(Range<u64>)) {
        let (a, b) = (r.start.max(self.first), r.end.min(self.end));
        if a >= b {
            return;
        }
        let (a, b) = (a - self.first, b - self.first);
        if self.shards == 1 {
            return f(a..b);
        }
        let cycle = self.cycle();
        for c in a / cycle..=(b - 1) / cycle {
            let s = c * cycle + self.shard * self.block;
            let (x, y) = (a.max(s), b.min(s + self.block));
            if x < y {
                f(c * self.block + (x - s)..c * self.block + (y - s));
            }
        }
    }
}

/// Photons handed out in batches from one counter over a plan of local ranges
/// (`Selection`). Batches are the 64-aligned windows of local indices, so a batch never
/// spans two ranges nor two blocks of a strided selection: its photons are one global
/// range.
pub struct PhotonSource {
    plan: Vec<Range<u64>>,
    selection: Selection,
    /// Counter position (in batches) where each range starts, and the end.
    starts: Vec<u64>,
    next: AtomicU64,
    stop: AtomicBool,
    /// Hits of finished batches, for progress reports.
    hits: AtomicU64,
    /// Photons traced to their end.
    traced: AtomicU64,
    /// Claimed photons that were not traced (stopped mid-batch), returned to the plan
    /// (global indices).
    returned: Mutex<Vec<Range<u64>>>,
}

/// The 64-aligned windows local range `r` touches.
fn windows(r: &Range<u64>) -> u64 {
    r.end.div_ceil(BATCH) - r.start / BATCH
}

impl PhotonSource {
    /// A source over `plan` (increasing, disjoint local ranges of `selection`).
    pub fn new(plan: Vec<Range<u64>>, selection: Selection) -> Self {
        let mut starts = Vec::with_capacity(plan.len() + 1);
        let mut at = 0u64;
        for r in &plan {
            starts.push(at);
            at = at.saturating_add(windows(r));
        }
        starts.push(at);
        PhotonSource {
            plan,
            selection,
            starts,
            next: AtomicU64::new(0),
            stop: AtomicBool::new(false),
            hits: AtomicU64::new(0),
            traced: AtomicU64::new(0),
            returned: Mutex::new(Vec::new()),
        }
    }

    /// The local range of the batch at counter position `v` (`v` below the end).
    fn local_batch(&self, v: u64) -> Range<u64> {
        let i = self.starts.partition_point(|&s| s <= v) - 1;
        let r = &self.plan[i];
        let w = r.start / BATCH + (v - self.starts[i]);
        (w * BATCH).max(r.start)..((w + 1) * BATCH).min(r.end)
    }

    /// The next batch of photon indices, or None when the plan is done or the run stopped.
    pub fn claim(&self) -> Option<Range<u64>> {
        if self.stop.load(Ordering::Relaxed) {
            return None;
        }
        let end = *self.starts.last().expect("starts has the end");
        let v = self.next.fetch_add(1, Ordering::Relaxed);
        if v >= end {
            return None;
        }
        let l = self.local_batch(v);
        let g = self.selection.global(l.start);
        Some(g..g + (l.end - l.start))
    }

    /// The stop flag: set when the run must end; paths in flight poll it and are abandoned.
    pub fn stop_flag(&self) -> &AtomicBool {
        &self.stop
    }

    pub fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
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
        let end = *self.starts.last().expect("starts has the end");
        let cursor = self.next.load(Ordering::Relaxed).min(end);
        let mut set = RangeSet::new();
        for (i, r) in self.plan.iter().enumerate() {
            if cursor <= self.starts[i] {
                break;
            }
            // The claimed part of r: its windows before the cursor.
            let claimed_end = if cursor >= self.starts[i + 1] {
                r.end
            } else {
                self.local_batch(cursor).start
            };
            self.selection
                .global_ranges(r.start..claimed_end, |g| set.insert(g));
        }
        let returned = self.returned.lock().unwrap_or_else(|p| p.into_inner());
        if returned.is_empty() {
            return set;
        }
        // set − returned (returned ranges are disjoint sub-ranges of claimed ones).
        let mut holes = RangeSet::new();
        for r in returned.iter() {
            holes.insert(r.clone());
        }
        let mut out = RangeSet::new();
        for r in set.ranges() {
            for g in holes.gaps(r.clone()) {
                out.insert(g);
            }
        }
        out
    }
}

/// The plan of a run asked for `photons` photons (0 = no limit) of `selection`: the lowest
/// local indices whose photons are not in `traced`.
pub fn continue_plan(traced: &RangeSet, photons: u64, selection: &Selection) -> Vec<Range<u64>> {
    let mut local = RangeSet::new();
    for r in traced.ranges() {
        selection.local_ranges(r.clone(), |l| local.insert(l));
    }
    let mut plan = Vec::new();
    let mut left = if photons == 0 { u64::MAX } else { photons };
    for g in local.gaps(0..selection.local_len()) {
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
        assert_eq!(s.overlap(&(38..70)), Some(38..40));
        assert_eq!(s.overlap(&(45..55)), Some(50..55));
        assert_eq!(continue_plan(&s, 10, &Selection::ALL), vec![0..5, 40..45]);
    }

    #[test]
    fn a_source_never_spans_ranges_and_returns_what_it_did_not_trace() {
        let src = PhotonSource::new(vec![0..100, 200..230], Selection::ALL);
        let mut got = Vec::new();
        while let Some(b) = src.claim() {
            got.push(b);
        }
        assert_eq!(got, vec![0..64, 64..100, 200..230]);
        src.give_back(70..100);
        assert_eq!(src.traced_set().ranges(), &[0..70, 200..230]);
        // A stopped source hands out nothing more; unclaimed parts are not traced.
        let src = PhotonSource::new(vec![0..1000], Selection::ALL);
        assert_eq!(src.claim(), Some(0..64));
        src.stop();
        assert_eq!(src.claim(), None);
        assert_eq!(src.traced_set().ranges(), &[0..64]);
    }

    /// Every photon a source hands out, as a sorted list.
    fn drain(src: &PhotonSource) -> Vec<u64> {
        let mut got = Vec::new();
        while let Some(b) = src.claim() {
            got.extend(b);
        }
        got.sort_unstable();
        got
    }

    #[test]
    fn shards_of_a_range_trace_every_photon_once() {
        // 3 shards of [100, 100 + 1000) in blocks of 128, each run in pieces of odd sizes
        // (some stopped mid-batch): together exactly the range, each photon once.
        let mut all = Vec::new();
        for k in 0..3 {
            let sel = Selection {
                first: 100,
                end: 1100,
                shards: 3,
                shard: k,
                block: 128,
            };
            assert!(sel.check().is_none());
            let mut traced = RangeSet::new();
            for (i, n) in [70u64, 1, 200, 0].into_iter().enumerate() {
                let src = PhotonSource::new(continue_plan(&traced, n, &sel), sel);
                if i == 1 {
                    // A run stopped after its first batch, half of which it gave back.
                    let b = src.claim().unwrap();
                    src.give_back(b.start + (b.end - b.start) / 2..b.end);
                    src.stop();
                } else {
                    drain(&src);
                }
                for r in src.traced_set().ranges() {
                    assert!(!traced.intersects(r), "shard {k} traced {r:?} twice");
                    traced.insert(r.clone());
                }
            }
            assert_eq!(traced.len(), sel.local_len());
            for r in traced.ranges() {
                all.extend(r.clone());
            }
        }
        all.sort_unstable();
        assert_eq!(all, (100..1100).collect::<Vec<_>>());
        // Blocks are dealt round robin: shard 1's photons start at 100 + 128.
        let sel = Selection {
            first: 100,
            end: 1100,
            shards: 3,
            shard: 1,
            block: 128,
        };
        let got = drain(&PhotonSource::new(
            continue_plan(&RangeSet::new(), 0, &sel),
            sel,
        ));
        assert_eq!(got[0], 228);
        assert_eq!(got.len() as u64, sel.local_len());
        assert_eq!(got.len(), 128 * 2 + 104); // blocks 1, 4 and the first 104 of 7 (996 … 1100)
    }

    #[test]
    fn open_ended_shards_and_bad_selections() {
        let sel = Selection::shard(2, 4);
        let src = PhotonSource::new(continue_plan(&RangeSet::new(), 100_000, &sel), sel);
        let got = drain(&src);
        assert_eq!(got.len(), 100_000);
        assert_eq!(got[0], 2 * DEFAULT_BLOCK);
        assert!(got
            .iter()
            .all(|&g| (g / DEFAULT_BLOCK) % 4 == 2 && g < 9 * DEFAULT_BLOCK));
        assert_eq!(src.traced_set().len(), 100_000);
        let bad = |f: fn(&mut Selection)| {
            let mut s = Selection::ALL;
            f(&mut s);
            s.check().expect("refused")
        };
        assert!(bad(|s| s.shards = 0).contains("shard_count"));
        assert!(bad(|s| s.shard = 1).contains("shard_index"));
        assert!(bad(|s| s.block = 100).contains("shard_block"));
        assert!(bad(|s| {
            s.first = 10;
            s.end = 5
        })
        .contains("photon_first"));
    }
}

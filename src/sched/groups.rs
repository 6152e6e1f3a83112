//! Vertex groups of the dynamic scheduler (the first paper, §3): the `VertexLevelSubd`
//! table, the recursive group lookup, splitting into `subd` subgroups, and the protocol that
//! keeps one writer per vertex while groups split under load.
//!
//! Protocol (checked by the loom model in `loom/tests/loom_groups.rs`):
//! 1. Publication: `split` writes the children's fields, then sets the parent's
//!    `subd_state` with release; `lookup` reads `subd_state` with acquire before it reads
//!    the children's fields.
//! 2. No portion opened for a group after its split: a calculating thread that wants a new
//!    portion for group g increments g's `pending` and then re-reads `subd_state`; `split`
//!    sets `subd_state` before anyone reads `pending`. All four accesses are SeqCst
//!    read-modify-writes (a read is `fetch_add(0)`), which always see the latest value in
//!    their location's modification order: either the thread sees the split (and backs off)
//!    or the reader sees its increment (Dekker). Plain SeqCst loads would be enough in C11,
//!    but loom models them like acquire loads; RMWs are exact in both, and this path runs
//!    once per portion, not per hit.
//! 3. Hand-over: `pending` counts portions of a group that are open, queued or being
//!    applied; the writer decrements it (release) after applying. A group's slots are
//!    written only once every ancestor's `pending` is 0 (acquire): the last portion of each
//!    ancestor has been applied before the first of the child.
//! 4. One writer at a time: whoever applies a portion of group g — g's processing thread, or
//!    a calculating thread that finds g idle and applies its own portion on the spot —
//!    holds g's `busy` flag (acquire on taking, release on leaving).

#[cfg(loom)]
use loom::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};
#[cfg(not(loom))]
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};

use crossbeam::utils::CachePadded;
use std::ops::Range;

const NONE: usize = usize::MAX;

/// One group: the paper's `VertexLevelSubd`, plus the parent link and the pending count.
#[derive(Debug)]
pub struct VertexLevelSubd {
    /// 0 = not subdivided, 1 = subdivided.
    subd_state: AtomicU32,
    /// First slot of the group.
    vert_indx: AtomicUsize,
    /// Slots in the group.
    vert_number: AtomicUsize,
    /// Index of the first subgroup once split.
    first_thread_indx: AtomicUsize,
    parent: AtomicUsize,
    /// Portions of this group open in calculating threads, queued, or being applied.
    pending: AtomicUsize,
    /// Held by the thread applying a portion of this group.
    busy: AtomicBool,
}

impl VertexLevelSubd {
    fn empty() -> Self {
        VertexLevelSubd {
            subd_state: AtomicU32::new(0),
            vert_indx: AtomicUsize::new(0),
            vert_number: AtomicUsize::new(0),
            first_thread_indx: AtomicUsize::new(NONE),
            parent: AtomicUsize::new(NONE),
            pending: AtomicUsize::new(0),
            busy: AtomicBool::new(false),
        }
    }
}

/// The group table, preallocated to its maximum size so it never moves while read.
#[derive(Debug)]
pub struct GroupTable {
    groups: Box<[CachePadded<VertexLevelSubd>]>,
    /// Groups in use (written only by the splitting thread).
    count: AtomicUsize,
    initial_size: usize,
    subd: usize,
}

impl GroupTable {
    /// `slots` slots in `initial` equal groups (by natural numbering), room for `max`.
    pub fn new(slots: usize, initial: usize, max: usize, subd: usize) -> Self {
        let initial = initial.clamp(1, slots.max(1));
        let initial_size = slots.div_ceil(initial).max(1);
        let initial = slots.div_ceil(initial_size).max(1);
        let groups: Box<[CachePadded<VertexLevelSubd>]> = (0..max.max(initial))
            .map(|_| CachePadded::new(VertexLevelSubd::empty()))
            .collect();
        for g in 0..initial {
            let start = g * initial_size;
            groups[g].vert_indx.store(start, Ordering::Relaxed);
            groups[g]
                .vert_number
                .store(initial_size.min(slots - start), Ordering::Relaxed);
        }
        GroupTable {
            groups,
            count: AtomicUsize::new(initial),
            initial_size,
            subd,
        }
    }

    /// Groups created so far (leaves and split ones).
    pub fn count(&self) -> usize {
        self.count.load(Ordering::Acquire)
    }

    pub fn capacity(&self) -> usize {
        self.groups.len()
    }

    /// The group that owns `slot` now: the paper's recursive lookup,
    /// `indx = (iglob − vert_indx) / (vert_number / subd + 1) + first_thread_indx`.
    #[inline]
    pub fn lookup(&self, slot: usize) -> usize {
        let mut g = slot / self.initial_size;
        loop {
            let e = &self.groups[g];
            if e.subd_state.load(Ordering::Acquire) == 0 {
                return g;
            }
            let start = e.vert_indx.load(Ordering::Relaxed);
            let n = e.vert_number.load(Ordering::Relaxed);
            g = (slot - start) / (n / self.subd + 1) + e.first_thread_indx.load(Ordering::Relaxed);
        }
    }

    pub fn is_split(&self, g: usize) -> bool {
        self.groups[g].subd_state.load(Ordering::Acquire) != 0
    }

    /// The slots of group `g`.
    pub fn range(&self, g: usize) -> Range<usize> {
        let e = &self.groups[g];
        let start = e.vert_indx.load(Ordering::Relaxed);
        start..start + e.vert_number.load(Ordering::Relaxed)
    }

    /// Whether `g` may be split: a leaf, at least `min_slots` slots per subgroup, room left.
    pub fn can_split(&self, g: usize, min_slots: usize) -> bool {
        !self.is_split(g)
            && self.range(g).len() >= self.subd * min_slots.max(1)
            && self.count() + self.subd <= self.capacity()
    }

    /// Splits leaf `g` into `subd` subgroups and returns their indices. Only one thread
    /// (the monitor) may split.
    pub fn split(&self, g: usize) -> Range<usize> {
        let first = self.count.load(Ordering::Relaxed);
        let range = self.range(g);
        let chunk = range.len() / self.subd + 1;
        for i in 0..self.subd {
            let c = &self.groups[first + i];
            let start = (range.start + i * chunk).min(range.end);
            c.vert_indx.store(start, Ordering::Relaxed);
            c.vert_number
                .store(chunk.min(range.end - start), Ordering::Relaxed);
            c.parent.store(g, Ordering::Relaxed);
        }
        self.groups[g]
            .first_thread_indx
            .store(first, Ordering::Relaxed);
        self.count.store(first + self.subd, Ordering::Release);
        // Publishes every store above to whoever acquires subd_state == 1.
        self.groups[g].subd_state.swap(1, Ordering::SeqCst);
        first..first + self.subd
    }

    /// A calculating thread opens a portion for `g`: false when `g` was split meanwhile
    /// (look the slot up again).
    #[inline]
    pub fn try_open(&self, g: usize) -> bool {
        let e = &self.groups[g];
        e.pending.fetch_add(1, Ordering::SeqCst);
        if e.subd_state.fetch_add(0, Ordering::SeqCst) != 0 {
            e.pending.fetch_sub(1, Ordering::SeqCst);
            return false;
        }
        true
    }

    /// The owner has applied a portion of `g` (or a calculating thread dropped one).
    #[inline]
    pub fn close(&self, g: usize) {
        self.groups[g].pending.fetch_sub(1, Ordering::Release);
    }

    /// Takes the right to write `g`'s slots if nobody holds it.
    #[inline]
    pub fn try_lock(&self, g: usize) -> bool {
        let b = &self.groups[g].busy;
        !b.load(Ordering::Relaxed)
            && b.compare_exchange(false, true, Ordering::Acquire, Ordering::Relaxed)
                .is_ok()
    }

    /// Gives the right to write `g`'s slots back.
    #[inline]
    pub fn unlock(&self, g: usize) {
        self.groups[g].busy.store(false, Ordering::Release);
    }

    pub fn pending(&self, g: usize) -> usize {
        self.groups[g].pending.load(Ordering::Acquire)
    }

    /// The group `g` was split from, if any.
    pub fn parent(&self, g: usize) -> Option<usize> {
        let p = self.groups[g].parent.load(Ordering::Relaxed);
        (p != NONE).then_some(p)
    }

    /// Takes the locks of `g` and all its ancestors, root first, for reading `g`'s slots
    /// while writers may run: every possible writer of those slots holds one of them.
    /// Writers hold at most one lock and never wait while holding it, so this cannot
    /// deadlock. `chain` is scratch space; pass it to `unlock_chain`.
    pub fn lock_chain(&self, g: usize, chain: &mut Vec<usize>) {
        chain.clear();
        let mut a = Some(g);
        while let Some(x) = a {
            chain.push(x);
            a = self.parent(x);
        }
        for &x in chain.iter().rev() {
            while !self.try_lock(x) {
                #[cfg(loom)]
                loom::thread::yield_now();
                #[cfg(not(loom))]
                std::thread::yield_now();
            }
        }
    }

    /// Releases what `lock_chain` took.
    pub fn unlock_chain(&self, chain: &[usize]) {
        for &x in chain {
            self.unlock(x);
        }
    }

    /// True when no ancestor of `g` has a portion left: `g`'s owner may write.
    pub fn ancestors_done(&self, g: usize) -> bool {
        let mut a = self.groups[g].parent.load(Ordering::Relaxed);
        while a != NONE {
            if self.groups[a].pending.fetch_add(0, Ordering::SeqCst) != 0 {
                return false;
            }
            a = self.groups[a].parent.load(Ordering::Relaxed);
        }
        true
    }
}

#[cfg(all(test, not(loom)))]
mod tests {
    use super::*;

    #[test]
    fn lookup_follows_recursive_splits() {
        let t = GroupTable::new(1000, 3, 64, 4);
        assert_eq!(t.count(), 3);
        assert_eq!(t.range(0), 0..334);
        assert_eq!(t.range(2), 668..1000);
        let kids = t.split(1);
        assert_eq!(kids, 3..7);
        // 334 slots, chunk 334/4 + 1 = 84.
        assert_eq!(t.range(3), 334..418);
        assert_eq!(t.range(6), 586..668);
        let grandkids = t.split(5);
        assert_eq!(grandkids, 7..11);
        // Every slot is found in exactly the leaf whose range holds it.
        let mut owned = vec![0; 1000];
        for g in 0..t.count() {
            if !t.is_split(g) {
                for s in t.range(g) {
                    owned[s] += 1;
                    assert_eq!(t.lookup(s), g, "slot {s}");
                }
            }
        }
        assert!(owned.iter().all(|&c| c == 1));
    }

    #[test]
    fn a_split_group_refuses_new_portions_and_children_wait() {
        let t = GroupTable::new(100, 1, 16, 4);
        assert!(t.try_open(0));
        let kids = t.split(0);
        assert!(!t.try_open(0));
        assert_eq!(t.pending(0), 1);
        for k in kids.clone() {
            assert!(!t.ancestors_done(k));
        }
        t.close(0);
        for k in kids {
            assert!(t.ancestors_done(k));
        }
        assert!(!t.can_split(0, 1));
    }
}

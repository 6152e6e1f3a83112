//! The dynamic scheduler (the first paper, §2–3, Fig. 3): calculating threads turn hits
//! into per-vertex contributions themselves and sort them into portions by vertex group (a
//! hit whose three vertices share a group, nearly every hit, travels as one record); a
//! fixed pool of free portions is the input stack; each group has an output stack and one
//! processing thread that alone writes the group's slots. The thread that called
//! `imap_run` is the monitor: when the input stack runs low (calculating threads are about
//! to wait) it splits the group with the longest output stack into `subd` subgroups with
//! new processing threads, while the calculating threads keep running. The protocol that
//! keeps one writer per slot through a split is in `groups.rs`; how a processing thread
//! waits for portions without costing their senders a system call, in `doze.rs`.

use super::doze::Doze;
use super::groups::GroupTable;
use super::{Counters, PhotonSource, RunContext, RunMonitor, RunOutcome, RunParams};
use crate::error::{bail, Result};
use crate::imap::MapLayout;
use crate::imap::{
    grey_index, shares, split_colour, BufferedHit, IMap, PhotonBuffer, PhotonOut, Readout, FULL,
    GREY, WEIGHTED,
};
use crate::scene::PreparedScene;
use crate::spectral::Colour;
use crate::transport::{HitSink, PathStats};
use crossbeam::channel::{self, Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// Settings of the dynamic scheduler.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DynamicParams {
    /// Groups at the start; 0 = one per calculating thread.
    pub initial_groups: usize,
    /// Most groups ever (the table is preallocated to this); 0 = 64 per calculating thread,
    /// at most `DEFAULT_MAX_GROUPS`; 1 = one group that never splits.
    pub max_groups: usize,
    /// Subgroups per split (the paper's `subd`).
    pub subd: usize,
    /// Split only while fewer free portions than this wait in the input stack; 0 = the
    /// number of calculating threads.
    pub low_threshold: usize,
    /// Split only a group with at least this many queued portions (0: split at every
    /// check, for tests).
    pub high_threshold: usize,
    /// Smallest subgroup a split may create, in slots.
    pub min_group_slots: usize,
    /// Least time between two splits, so that a split can take effect before the next.
    pub split_interval: Duration,
    /// Whether a calculating thread applies a full portion itself when the group's owner is
    /// idle. `None` (automatic): when the calculating threads alone fill the cores, so that
    /// handing over would only add a context switch; otherwise the processing threads use
    /// the spare cores.
    pub inline_apply: Option<bool>,
}

impl Default for DynamicParams {
    fn default() -> Self {
        DynamicParams {
            initial_groups: 0,
            max_groups: 0,
            subd: 4,
            low_threshold: 0,
            high_threshold: 3,
            min_group_slots: 256,
            split_interval: Duration::from_millis(1),
            inline_apply: None,
        }
    }
}

impl DynamicParams {
    /// Checks the settings (also when they are changed between runs).
    pub fn validate(&self) -> Result<()> {
        if !(2..=64).contains(&self.subd) {
            bail!(
                ImapErrInvalidArgument,
                "subd = {} must be between 2 and 64",
                self.subd
            );
        }
        if self.max_groups > MAX_GROUPS_LIMIT || self.initial_groups > MAX_GROUPS_LIMIT {
            bail!(
                ImapErrInvalidArgument,
                "initial_groups = {} and max_groups = {} must be at most {MAX_GROUPS_LIMIT}",
                self.initial_groups,
                self.max_groups
            );
        }
        if self.max_groups != 0 && self.initial_groups > self.max_groups {
            bail!(
                ImapErrInvalidArgument,
                "initial_groups {} exceeds max_groups {}",
                self.initial_groups,
                self.max_groups
            );
        }
        Ok(())
    }
}

/// Most groups a configuration may ask for.
const MAX_GROUPS_LIMIT: usize = 1 << 16;
/// Most groups by default (64 per calculating thread up to this): every calculating thread
/// keeps 4 bytes per group, and each group a queue.
const DEFAULT_MAX_GROUPS: usize = 4096;
/// Bytes a portion aims at: small enough to stay in cache while it is applied.
const PORTION_BYTES: usize = 32 << 10;
/// Most bytes all portions together may take.
const POOL_BYTES: usize = 256 << 20;

/// Bytes per contribution for `bands` bands (a hit's colour is shared by the up to three
/// contributions it makes to one group).
fn contribution_bytes(bands: usize) -> usize {
    std::mem::size_of::<Contribution>() + 4 * bands / 3 + 1
}

/// Contributions per portion for `bands` bands.
fn portion_capacity(bands: usize) -> usize {
    (PORTION_BYTES / contribution_bytes(bands)).clamp(64, 2048)
}

/// Colour values a portion of `capacity` holds at most: as many as half its capacity in
/// whole hits of full colour need.
fn colour_capacity(capacity: usize, bands: usize) -> usize {
    capacity * bands / 2 + bands + 3
}

/// Bytes a portion of `bands` bands takes (what it reserves; it never grows beyond).
fn portion_bytes(bands: usize) -> usize {
    let capacity = portion_capacity(bands);
    capacity * std::mem::size_of::<Contribution>()
        + capacity.div_ceil(2) * std::mem::size_of::<WholeHit>()
        + 4 * colour_capacity(capacity, bands)
}
/// `Contribution::band` of a photon's squared scalar contribution (in `w`); `FULL` (from
/// the photon buffer) marks a full-colour contribution.
const SQUARE: u16 = u16::MAX - 1;

/// One vertex's share of one hit.
#[derive(Clone, Copy, Debug)]
struct Contribution {
    w: f64,
    /// The map cell (`LayerLayout::cell`).
    slot: u32,
    colour_at: u32,
    band: u16,
}

/// A whole hit whose three cells all belong to the portion's group (the common case: a
/// triangle's vertices are neighbours in slot order): one record instead of three
/// contributions, its shares computed where it is applied.
#[derive(Clone, Copy, Debug)]
struct WholeHit {
    cells: [u32; 3],
    u: f32,
    v: f32,
    /// Where its colour starts in the portion's arena (`BufferedHit`'s layout: the colour or
    /// the one value, then the weights when its band code says so).
    colour_at: u32,
    band: u16,
}

/// A portion of contributions for one group.
struct Portion {
    hits: Vec<WholeHit>,
    items: Vec<Contribution>,
    colours: Vec<f32>,
    /// Colour values it may hold before a hit could make `colours` grow.
    colour_room: usize,
    /// The hit whose colour was stored last (contributions of one hit share it), and where.
    stamp: u64,
    stamp_at: u32,
}

impl Portion {
    fn new(capacity: usize, bands: usize) -> Self {
        let colours = colour_capacity(capacity, bands);
        Portion {
            hits: Vec::with_capacity(capacity.div_ceil(2)),
            items: Vec::with_capacity(capacity),
            colours: Vec::with_capacity(colours),
            colour_room: colours - bands - 3,
            stamp: u64::MAX,
            stamp_at: 0,
        }
    }

    /// Whether it holds `capacity` contributions' worth (a whole hit counts two: its record
    /// and colour take about as many bytes), or its colours fill what it reserved.
    #[inline]
    fn full(&self, capacity: usize) -> bool {
        self.items.len() + 2 * self.hits.len() >= capacity || self.colours.len() > self.colour_room
    }

    fn clear(&mut self) {
        self.hits.clear();
        self.items.clear();
        self.colours.clear();
        self.stamp = u64::MAX;
    }
}

/// What a calculating thread shares with the others.
struct Shared<'a> {
    table: &'a GroupTable,
    map: &'a IMap,
    scene: &'a PreparedScene,
    layout: &'a MapLayout,
    free: Receiver<Portion>,
    recycle: Sender<Portion>,
    outputs: &'a [Sender<Portion>],
    /// Each group's processing thread's sleep flag: a sender wakes it only when it sleeps.
    dozes: &'a [Doze],
    capacity: usize,
    inline_apply: bool,
    /// A processing thread was lost: waiting for free portions would never end.
    poisoned: &'a AtomicBool,
}

/// Counts a calculating thread out when it ends, also by a panic (then the run stops);
/// the last one out wakes the monitor.
struct LiveGuard<'a>(&'a AtomicUsize, &'a PhotonSource, &'a std::thread::Thread);

impl Drop for LiveGuard<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.1.stop();
        }
        if self.0.fetch_sub(1, Ordering::Release) == 1 {
            self.2.unpark();
        }
    }
}

/// Stops the source and releases the processing threads when the monitor's scope ends,
/// also by unwinding.
struct Teardown<'a> {
    source: &'a PhotonSource,
    finished: &'a AtomicBool,
    dozes: &'a [Doze],
}

impl Drop for Teardown<'_> {
    fn drop(&mut self) {
        self.source.stop();
        finish(self.finished, self.dozes);
    }
}

/// Tells the processing threads that no portion can arrive any more, and wakes those that
/// sleep.
fn finish(finished: &AtomicBool, dozes: &[Doze]) {
    finished.store(true, Ordering::Release);
    for d in dozes {
        d.wake();
    }
}

/// `GroupSink::open_at` of a group without an open portion.
const NOT_OPEN: u32 = u32::MAX;

/// A calculating thread's side: holds each photon's hits until its path ends, then sorts
/// its contributions into one open portion per group it has touched.
struct GroupSink<'a> {
    shared: &'a Shared<'a>,
    /// Where in `open` each group's open portion is (`NOT_OPEN`: none): 4 bytes per group
    /// of the table, so a thread's cost does not grow with the table.
    open_at: Vec<u32>,
    /// The open portions and their groups.
    open: Vec<(usize, Portion)>,
    spare: Option<Portion>,
    hit: u64,
    wait_s: f64,
    /// The leaf group found last and its slots: most lookups hit it again.
    last: (usize, usize, usize),
    /// Portions this thread applied itself (their group's owner was idle).
    applied: u64,
    /// The current photon's deposits, handed over when its path ends.
    photon: PhotonBuffer,
    regions: super::RegionSink<'a>,
}

impl<'a> GroupSink<'a> {
    fn new(shared: &'a Shared<'a>, bands: usize, regions: super::RegionSink<'a>) -> Self {
        GroupSink {
            shared,
            open_at: vec![NOT_OPEN; shared.table.capacity()],
            open: Vec::new(),
            spare: None,
            hit: 0,
            wait_s: 0.0,
            last: (0, 0, 0),
            applied: 0,
            photon: PhotonBuffer::new(bands),
            regions,
        }
    }

    /// Group `g`'s open portion.
    #[inline]
    fn open_mut(&mut self, g: usize) -> &mut Portion {
        &mut self.open[self.open_at[g] as usize].1
    }

    /// Applies group `g`'s open portion on the spot when the group may be written and
    /// nobody is writing it; otherwise hands it to the group's processing thread.
    fn send(&mut self, g: usize) {
        let at = self.open_at[g];
        if at == NOT_OPEN {
            return;
        }
        let (_, mut p) = self.open.swap_remove(at as usize);
        if let Some(&(moved, _)) = self.open.get(at as usize) {
            self.open_at[moved] = at;
        }
        self.open_at[g] = NOT_OPEN;
        // Portions are applied in arrival order: sorting them by slot (as the classic
        // scheduler sorts by triangle) cost more than it saved, applying inline or on a
        // processing thread, RGB and 81 bands (BENCHMARKS.md, 2026-11-24).
        let table = self.shared.table;
        if self.shared.inline_apply && table.try_lock(g) {
            if table.ancestors_done(g) {
                // SAFETY: we hold g's lock and its ancestors are done.
                unsafe { apply(self.shared.map, &p) };
                self.applied += 1;
                table.close(g);
                table.unlock(g);
                p.clear();
                if self.spare.is_none() {
                    self.spare = Some(p);
                } else {
                    let _ = self.shared.recycle.send(p);
                }
                return;
            }
            table.unlock(g);
        }
        // The receiver is gone only when the run is being torn down after a panic.
        if self.shared.outputs[g].send(p).is_err() {
            table.close(g);
        } else {
            self.shared.dozes[g].wake();
        }
    }

    fn send_all(&mut self) {
        while let Some(&(g, _)) = self.open.last() {
            self.send(g);
        }
    }

    /// A free portion from the input stack. While none is free, the partly filled open
    /// portions are handed over so that their groups can return portions (without this,
    /// threads holding open portions could all wait for each other).
    fn free_portion(&mut self) -> Option<Portion> {
        if let Some(p) = self.spare.take() {
            return Some(p);
        }
        match self.shared.free.try_recv() {
            Ok(p) => return Some(p),
            Err(TryRecvError::Disconnected) => return None,
            Err(TryRecvError::Empty) => {}
        }
        let t = Instant::now();
        let p = loop {
            match self.shared.free.recv_timeout(Duration::from_micros(500)) {
                Ok(p) => break Some(p),
                Err(RecvTimeoutError::Disconnected) => break None,
                Err(RecvTimeoutError::Timeout) if self.shared.poisoned.load(Ordering::Relaxed) => {
                    break None
                }
                Err(RecvTimeoutError::Timeout) => self.send_all(),
            }
        };
        self.wait_s += t.elapsed().as_secs_f64();
        p
    }

    /// The leaf group of `slot`: the last one found when it still holds the slot.
    #[inline]
    fn group_of(&mut self, slot: usize) -> usize {
        let (g, start, end) = self.last;
        let table = self.shared.table;
        if slot >= start && slot < end && !table.is_split(g) {
            return g;
        }
        let g = table.lookup(slot);
        let r = table.range(g);
        self.last = (g, r.start, r.end);
        g
    }

    /// The open portion for `slot`'s group, opening one when needed.
    fn portion_for(&mut self, slot: usize) -> Option<usize> {
        loop {
            let g = self.group_of(slot);
            if self.open_at[g] != NOT_OPEN {
                return Some(g);
            }
            let p = self.free_portion()?;
            // The group may have split while we waited: look again before opening.
            let g = self.group_of(slot);
            if self.open_at[g] != NOT_OPEN {
                self.spare = Some(p);
                return Some(g);
            }
            if self.shared.table.try_open(g) {
                self.open_at[g] = self.open.len() as u32;
                self.open.push((g, p));
                return Some(g);
            }
            self.spare = Some(p);
        }
    }

    /// Adds one contribution to map cell `cell`, in its slot's group (groups are ranges of
    /// slots, so a slot's layers share its group); `colour` is stored once per hit (the
    /// contributions of hit `self.hit` share it).
    #[inline]
    fn contribute(&mut self, cell: usize, w: f64, band: u16, colour: &[f32]) {
        let Some(g) = self.portion_for(self.shared.layout.layers.slot_of(cell)) else {
            return;
        };
        let hit = self.hit;
        let capacity = self.shared.capacity;
        let p = self.open_mut(g);
        if band != SQUARE && p.stamp != hit {
            p.stamp = hit;
            p.stamp_at = p.colours.len() as u32;
            p.colours.extend_from_slice(colour);
        }
        let colour_at = if band == SQUARE { 0 } else { p.stamp_at };
        p.items.push(Contribution {
            w,
            slot: cell as u32,
            colour_at,
            band,
        });
        if p.full(capacity) {
            self.send(g);
        }
    }

    /// Adds a hit as one record when its three cells share a group; false when they do not
    /// (then each gets a contribution) or when the run is ending.
    #[inline]
    fn whole_hit(&mut self, h: &BufferedHit, cells: [usize; 3], colour: &[f32]) -> bool {
        let slots = cells.map(|c| self.shared.layout.layers.slot_of(c));
        let within =
            |(_, start, end): (usize, usize, usize)| slots.iter().all(|s| (start..end).contains(s));
        // Most hits land in the group of the last one, whose portion is open: a portion
        // opened before its group split may still be filled (its group's `pending` holds
        // the subgroups back until it is applied).
        let g = if self.open_at[self.last.0] != NOT_OPEN && within(self.last) {
            self.last.0
        } else {
            let Some(g) = self.portion_for(slots[0]) else {
                return true;
            };
            // `portion_for` left g's range in `last`.
            if !within(self.last) {
                return false;
            }
            g
        };
        let capacity = self.shared.capacity;
        let p = self.open_mut(g);
        let colour_at = p.colours.len() as u32;
        p.colours.extend_from_slice(colour);
        p.hits.push(WholeHit {
            cells: cells.map(|c| c as u32),
            u: h.u,
            v: h.v,
            colour_at,
            band: h.band,
        });
        if p.full(capacity) {
            self.send(g);
        }
        true
    }
}

impl PhotonOut for GroupSink<'_> {
    fn hit(&mut self, h: &BufferedHit, cells: [usize; 3], colour: &[f32]) {
        self.hit += 1;
        if self.whole_hit(h, cells, colour) {
            return;
        }
        // Each vertex's contribution carries its share: the weights are dropped from the
        // band code.
        let (values, weights) = split_colour(h.band, self.shared.map.bands(), colour);
        let w = shares(h.band, h.u, h.v, weights);
        let band = match grey_index(h.band) {
            _ if h.band == WEIGHTED => FULL,
            Some((g, true)) => GREY + g as u16,
            _ => h.band,
        };
        for (cell, w) in cells.into_iter().zip(w) {
            self.contribute(cell, w, band, values);
        }
    }

    fn square(&mut self, cell: usize, s2: f64) {
        self.contribute(cell, s2, SQUARE, &[]);
    }

    fn slot_value(&mut self, cell: usize, colour: &[f32]) {
        self.hit += 1;
        self.contribute(cell, 1.0, FULL, colour);
    }

    fn regions(&mut self, ids: &[u32], values: &[f64]) {
        self.regions.add(ids, values);
    }
}

impl HitSink for GroupSink<'_> {
    fn deposit(
        &mut self,
        at: (u32, u32, u8),
        (u, v): (f32, f32),
        colour: &Colour,
        weights: Option<[f32; 3]>,
    ) {
        self.photon.deposit(
            self.shared.scene,
            self.shared.layout,
            at,
            u,
            v,
            colour,
            weights,
        );
    }

    fn begin_photon(&mut self, emitter: usize) {
        self.photon
            .begin(self.shared.scene, self.shared.layout, emitter);
    }

    fn direct_done(&mut self) {
        self.photon.direct_done();
    }

    fn end_photon(&mut self) {
        let mut photon = std::mem::replace(&mut self.photon, PhotonBuffer::new(0));
        photon.finish(self.shared.scene, self.shared.layout, self);
        self.photon = photon;
    }

    fn abort_photon(&mut self) {
        self.photon.abort();
    }

    fn batch_done(&mut self) {
        self.regions.flush();
        // Portions of groups that split must reach their owner, or the subgroups would
        // wait for them.
        let table = self.shared.table;
        let split: Vec<usize> = self
            .open
            .iter()
            .map(|&(g, _)| g)
            .filter(|&g| table.is_split(g))
            .collect();
        for g in split {
            self.send(g);
        }
    }
}

/// Applies a portion to its group's slots.
///
/// # Safety
/// The caller holds the lock of the portion's group and every ancestor of the group is
/// done (`GroupTable::ancestors_done`).
unsafe fn apply(map: &IMap, p: &Portion) {
    let bands = map.bands();
    let prefetch = |cell: u32, band: u16| {
        if let Some((g, _)) = grey_index(band) {
            map.prefetch_grey(cell as usize, g);
        } else {
            map.prefetch(cell as usize);
        }
    };
    // Spectral cells span many cache lines: fetch a few hits ahead (4, the 12 contributions
    // below).
    let ahead = if bands > 8 { 4 } else { 0 };
    for (i, h) in p.hits.iter().enumerate() {
        if let Some(n) = p.hits.get(i + ahead).filter(|_| ahead > 0) {
            n.cells.iter().for_each(|&c| prefetch(c, n.band));
        }
        // SAFETY: the hit's cells belong to the portion's group, which the caller alone may
        // write now; readers take the group's lock too.
        unsafe {
            map.add_hit_exclusive(
                h.cells.map(|c| c as usize),
                h.band,
                (h.u, h.v),
                &p.colours[h.colour_at as usize..],
            )
        };
    }
    // Spectral cells span many cache lines: fetch a few contributions ahead (12: with most
    // contributions one grey number, 6 left most fetches late; BENCHMARKS.md).
    let ahead = 3 * ahead;
    for (i, c) in p.items.iter().enumerate() {
        if let Some(n) = p.items.get(i + ahead).filter(|_| ahead > 0) {
            prefetch(n.slot, n.band);
        }
        let at = c.colour_at as usize;
        // SAFETY: the portion's slots belong to its group, which the caller alone may write
        // now; readers take the group's lock too.
        unsafe {
            if c.band == FULL {
                map.add_colour_exclusive(c.slot as usize, c.w, &p.colours[at..at + bands]);
            } else if c.band == SQUARE {
                map.add_square_exclusive(c.slot as usize, c.w);
            } else if let Some((g, _)) = grey_index(c.band) {
                map.add_grey_exclusive(c.slot as usize, c.w, g, p.colours[at]);
            } else {
                map.add_band_exclusive(c.slot as usize, c.w, c.band as usize, p.colours[at]);
            }
        }
    }
}

/// The global error while writers run: each leaf group's slots are read under the locks
/// of the group and its ancestors. Only the monitor calls it (it is also the only thread
/// that splits, so the leaves do not change meanwhile).
fn locked_error(table: &GroupTable, map: &IMap, rc: &RunContext, photons: u64) -> Option<f64> {
    let readout = Readout {
        map,
        scene: rc.scene,
        photons,
        unit_m: rc.unit_m,
        layer: None,
        plan: rc.neighbours(),
    };
    let (mut num, mut den) = (0.0, 0.0);
    let mut chain = Vec::new();
    for g in (0..table.count()).filter(|&g| !table.is_split(g)) {
        table.lock_chain(g, &mut chain);
        let (n, d) = readout.error_sums(table.range(g));
        table.unlock_chain(&chain);
        num += n;
        den += d;
    }
    (den > 0.0).then_some(num / den)
}

/// Reads slots while writers run: each leaf group's part of the range under the locks of
/// the group and its ancestors (the monitor only: it alone splits).
struct Locked<'a>(&'a GroupTable);

impl super::target::SlotAccess for Locked<'_> {
    fn visit(&self, slots: std::ops::Range<usize>, f: &mut dyn FnMut(usize)) {
        let table = self.0;
        let mut chain = Vec::new();
        for g in (0..table.count()).filter(|&g| !table.is_split(g)) {
            let r = table.range(g);
            let (lo, hi) = (r.start.max(slots.start), r.end.min(slots.end));
            if lo >= hi {
                continue;
            }
            table.lock_chain(g, &mut chain);
            (lo..hi).for_each(&mut *f);
            table.unlock_chain(&chain);
        }
    }
}

/// A processing thread: waits until no ancestor of its group has work left, then applies
/// its group's portions until its group is split and drained, or the run ends.
/// What every processing thread shares.
struct Owners<'a> {
    table: &'a GroupTable,
    map: &'a IMap,
    /// The calculating threads have all finished: no portion can arrive any more.
    finished: &'a AtomicBool,
    poisoned: &'a AtomicBool,
    dozes: &'a [Doze],
    /// Whether a processing thread naps before it sleeps (when the calculating threads
    /// leave cores free; `Doze`).
    nap: bool,
}

/// A processing thread's first nap when its queue runs empty; each next one is twice as
/// long, up to `LAST_NAP`, until it has napped `DOZE_AFTER` in all and sleeps until woken.
const FIRST_NAP: Duration = Duration::from_micros(20);
const LAST_NAP: Duration = Duration::from_micros(100);
const DOZE_AFTER: Duration = Duration::from_millis(2);
/// The monitor's first and longest interval between two looks at the stacks.
const WATCH_FIRST: Duration = Duration::from_micros(250);
const WATCH_LAST: Duration = Duration::from_millis(2);
/// Longest sleep without a wake-up (a safety net: a split group's thread notices it is
/// drained, a lost thread's poison is seen).
const DEEP_SLEEP: Duration = Duration::from_millis(5);

fn process(
    g: usize,
    rx: Receiver<Portion>,
    recycle: &Sender<Portion>,
    o: &Owners,
) -> (f64, f64, u64) {
    let Owners {
        table,
        map,
        finished,
        poisoned,
        dozes,
        nap,
    } = *o;
    let born = Instant::now();
    while !table.ancestors_done(g) {
        if poisoned.load(Ordering::Relaxed) {
            // An ancestor's owner was lost: its portions will never be applied.
            return (0.0, born.elapsed().as_secs_f64(), 0);
        }
        std::thread::sleep(Duration::from_micros(50));
    }
    let (mut busy, mut applied) = (0.0, 0);
    // Napped since the queue last held a portion, and the next nap.
    let (mut napped, mut next_nap) = (Duration::ZERO, FIRST_NAP);
    // Done when split and drained, or when the calculating threads have all finished (after
    // which no portion can arrive) and the queue is empty.
    let over = || (table.is_split(g) && table.pending(g) == 0) || finished.load(Ordering::Acquire);
    loop {
        match rx.try_recv() {
            Ok(mut p) => {
                (napped, next_nap) = (Duration::ZERO, FIRST_NAP);
                crate::fault::at(crate::fault::Point::Process);
                // A calculating thread may be applying a portion of this group right now.
                while !table.try_lock(g) {
                    std::thread::yield_now();
                }
                let t = Instant::now();
                // SAFETY: we hold g's lock and waited for its ancestors above.
                unsafe { apply(map, &p) };
                busy += t.elapsed().as_secs_f64();
                applied += 1;
                table.close(g);
                table.unlock(g);
                p.clear();
                let _ = recycle.send(p);
                continue;
            }
            Err(TryRecvError::Empty) => {}
            Err(TryRecvError::Disconnected) => break,
        }
        if poisoned.load(Ordering::Relaxed) || (rx.is_empty() && over()) {
            break;
        }
        // The queue is empty: nap (while cores are free), then sleep until a sender, the
        // end of the run or the safety net wakes this thread.
        if nap && napped < DOZE_AFTER {
            std::thread::sleep(next_nap);
            napped += next_nap;
            next_nap = (next_nap * 2).min(LAST_NAP);
        } else {
            dozes[g].sleep(
                || !rx.is_empty() || over() || poisoned.load(Ordering::Relaxed),
                DEEP_SLEEP,
            );
        }
    }
    (busy, born.elapsed().as_secs_f64(), applied)
}

/// The most groups a run with these settings can have.
fn max_groups(threads: usize, dp: &DynamicParams) -> usize {
    let max = if dp.max_groups == 0 {
        (64 * threads).min(DEFAULT_MAX_GROUPS)
    } else {
        dp.max_groups
    };
    max.max(dp.initial_groups)
}

/// Bytes a run's buffers take at least (the pool grows from there within the budget the
/// context leaves, `RunContext::pool_bytes`): the smallest pool, the group table, every
/// calculating thread's group index and photon buffer.
pub fn run_bytes(threads: usize, bands: usize, dp: &DynamicParams) -> u64 {
    let groups = max_groups(threads, dp) as u64;
    let portion = portion_bytes(bands) as u64;
    let t = threads as u64;
    8 * t * portion + groups * (128 + 64) + t * groups * 4 + t * PhotonBuffer::max_bytes(bands)
}

/// Runs the dynamic scheduler until a stop criterion is met.
pub fn run(
    rc: &RunContext,
    map: &mut IMap,
    params: &mut RunParams,
    dp: &DynamicParams,
) -> RunOutcome {
    let threads = rc.threads;
    let source = PhotonSource::new(rc.plan.clone(), rc.selection);
    let bands = map.bands();
    let max_groups = max_groups(threads, dp);
    let initial = if dp.initial_groups == 0 {
        threads.min(max_groups)
    } else {
        dp.initial_groups
    };
    let low = if dp.low_threshold == 0 {
        threads
    } else {
        dp.low_threshold
    };
    let table = GroupTable::new(map.slots(), initial, max_groups, dp.subd);

    // The input stack: two portions per calculating thread and group to begin with, more
    // with every split, within a memory cap.
    let capacity = portion_capacity(bands);
    let portion_bytes = portion_bytes(bands);
    let (least, most) = (
        8 * threads,
        (2 * threads * (max_groups + 2)).max(8 * threads),
    );
    let pool_bytes = POOL_BYTES.min(usize::try_from(rc.pool_bytes).unwrap_or(usize::MAX));
    let pool_cap = (pool_bytes / portion_bytes).clamp(least, most);
    let (free_tx, free_rx) = channel::bounded::<Portion>(pool_cap);
    let mut pool = 0;
    let grow_pool = |n: usize, pool: &mut usize| {
        for _ in 0..n.min(pool_cap - *pool) {
            let _ = free_tx.send(Portion::new(capacity, bands));
            *pool += 1;
        }
    };
    // At least 8 a thread: with 4 (one thread, one group), a processing thread's nap let the
    // free portions run out and the group split for nothing.
    grow_pool((2 * threads * (table.count() + 1)).max(least), &mut pool);
    let (out_tx, out_rx): (Vec<Sender<Portion>>, Vec<Receiver<Portion>>) =
        (0..max_groups).map(|_| channel::unbounded()).unzip();
    let mut out_rx: Vec<Option<Receiver<Portion>>> = out_rx.into_iter().map(Some).collect();

    let mut monitor = RunMonitor::new(params, rc);
    let mut counters = Counters::default();
    let mut stats = PathStats::new(rc.scene.meshes.len());
    let mut thread_lost = None;
    let live = AtomicUsize::new(threads);
    let finished = AtomicBool::new(false);
    let poisoned = AtomicBool::new(false);
    let shared_map: &IMap = map;
    let dozes: Vec<Doze> = (0..max_groups).map(|_| Doze::new()).collect();
    // Whether the calculating threads leave cores free (for processing threads, and for
    // their naps).
    let spare_cores = threads < std::thread::available_parallelism().map_or(1, |n| n.get());
    let shared = Shared {
        table: &table,
        map: shared_map,
        scene: rc.scene,
        layout: rc.layout,
        free: free_rx.clone(),
        recycle: free_tx.clone(),
        outputs: &out_tx,
        dozes: &dozes,
        capacity,
        inline_apply: dp.inline_apply.unwrap_or(!spare_cores),
        poisoned: &poisoned,
    };
    let (mut busy_s, mut alive_s) = (0.0, 0.0);

    let monitor_thread = &std::thread::current();
    let owners = Owners {
        table: &table,
        map: shared_map,
        finished: &finished,
        poisoned: &poisoned,
        dozes: &dozes,
        nap: spare_cores,
    };
    std::thread::scope(|s| {
        // Should this (monitoring) thread unwind, every other thread must still end.
        let _teardown = Teardown {
            source: &source,
            finished: &finished,
            dozes: &dozes,
        };
        let mut calc = Vec::new();
        for t in 0..threads {
            let (shared, source, tracer, live, regions) =
                (&shared, &source, &rc.tracer, &live, rc.regions);
            let spawned = std::thread::Builder::new()
                .name(format!("imap-calc-{t}"))
                .spawn_scoped(s, move || {
                    crate::error::quiet_thread();
                    // Counted out even if this thread panics, so the monitor never waits
                    // for a thread that is gone.
                    let _live = LiveGuard(live, source, monitor_thread);
                    let mut sink = GroupSink::new(
                        shared,
                        tracer.bands,
                        super::RegionSink::new(regions, tracer.scene, shared.layout, tracer.bands),
                    );
                    let mut stats = PathStats::new(tracer.scene.meshes.len());
                    let mut colour = Colour::new(tracer.bands);
                    super::trace_all(source, tracer, &mut colour, &mut sink, &mut stats);
                    sink.regions.flush();
                    sink.send_all();
                    if let Some(p) = sink.spare.take() {
                        let _ = shared.recycle.send(p);
                    }
                    (stats, sink.wait_s, sink.applied)
                });
            match spawned {
                Ok(h) => calc.push(h),
                Err(e) => {
                    thread_lost = Some(format!("could not start calculating thread {t}: {e}"));
                    live.fetch_sub(1, Ordering::Release);
                    source.stop();
                }
            }
        }
        let mut processors = Vec::new();
        let table = &table;
        let spawn_processor = |g: usize, out_rx: &mut Vec<Option<Receiver<Portion>>>| {
            let rx = out_rx[g].take().expect("one processing thread per group");
            let recycle = free_tx.clone();
            let (owners, source, poisoned) = (&owners, &source, &poisoned);
            std::thread::Builder::new()
                .name(format!("imap-group-{g}"))
                .spawn_scoped(s, move || {
                    crate::error::quiet_thread();
                    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        process(g, rx, &recycle, owners)
                    }));
                    // A lost owner: its group's portions never come back, so nobody may
                    // wait for free portions any more.
                    r.inspect_err(|_| {
                        poisoned.store(true, Ordering::Relaxed);
                        source.stop();
                    })
                })
                .map_err(|e| format!("could not start the processing thread of group {g}: {e}"))
        };
        let mut start =
            |g: usize, out_rx: &mut Vec<Option<Receiver<Portion>>>, processors: &mut Vec<_>| {
                match spawn_processor(g, out_rx) {
                    Ok(h) => processors.push(h),
                    Err(e) => {
                        // Without an owner the group's portions never come back: stop the run.
                        thread_lost = Some(e);
                        source.stop();
                    }
                }
            };
        for g in 0..table.count() {
            start(g, &mut out_rx, &mut processors);
        }

        // The monitor: watch the stacks, split overloaded groups, report progress.
        let mut last_split = Instant::now() - Duration::from_secs(1);
        let mut watch = WATCH_FIRST;
        while live.load(Ordering::Acquire) > 0 {
            crate::fault::at(crate::fault::Point::Monitor);
            // Woken early by the last calculating thread to finish.
            std::thread::park_timeout(watch.min(monitor.timeout()));
            monitor.poll(
                &source,
                rc,
                &|n| locked_error(table, shared_map, rc, n),
                shared_map,
                &Locked(table),
            );
            let free = free_rx.len();
            // Look often while the input stack runs low, seldom while it does not: every
            // look takes a core from a calculating thread when they fill the cores (four
            // looks a millisecond cost the hall 5 % on two threads).
            watch = if free < low {
                WATCH_FIRST
            } else {
                (watch * 2).min(WATCH_LAST)
            };
            let mut hottest: Option<(usize, usize)> = None;
            for (g, out) in out_tx.iter().enumerate().take(table.count()) {
                if !table.is_split(g) {
                    let q = out.len();
                    counters.peak_queue = counters.peak_queue.max(q as u64);
                    if hottest.is_none_or(|(_, best)| q > best)
                        && table.can_split(g, dp.min_group_slots)
                    {
                        hottest = Some((g, q));
                    }
                }
            }
            let split = hottest.filter(|&(_, q)| {
                free < low && q >= dp.high_threshold && last_split.elapsed() >= dp.split_interval
            });
            if let Some((g, _)) = split {
                for child in table.split(g) {
                    start(child, &mut out_rx, &mut processors);
                }
                grow_pool(threads * dp.subd, &mut pool);
                counters.splits += 1;
                last_split = Instant::now();
            }
        }
        for (t, h) in calc.into_iter().enumerate() {
            match h.join() {
                Ok((st, wait, applied)) => {
                    stats.merge(&st);
                    counters.calc_wait_s += wait;
                    counters.portions += applied;
                    counters.inline_portions += applied;
                }
                Err(e) => {
                    let what = crate::error::panic_message(&*e);
                    thread_lost = Some(format!("calculating thread {t} panicked: {what}"));
                }
            }
        }
        // Every calculating thread has handed over all its portions: the processing
        // threads drain their queues and finish.
        finish(&finished, &dozes);
        for h in processors {
            match h.join() {
                Ok(Ok((b, a, n))) => {
                    busy_s += b;
                    alive_s += a;
                    counters.portions += n;
                }
                Ok(Err(e)) | Err(e) => {
                    let what = crate::error::panic_message(&*e);
                    thread_lost = Some(format!("a processing thread panicked: {what}"));
                }
            }
        }
    });

    counters.groups = (0..table.count()).filter(|&g| !table.is_split(g)).count() as u64;
    counters.accum_busy_fraction = if alive_s > 0.0 { busy_s / alive_s } else { 0.0 };
    counters.accum_busy_s = busy_s;
    monitor.outcome(&source, map, rc, stats, counters, thread_lost)
}

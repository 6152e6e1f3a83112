//! The schedulers' many-core scaling model (issue 37). A model, not a measurement: it
//! predicts the hits per second of the classic and the dynamic scheduler with T calculating
//! threads on C cores from per-hit costs measured on one thread, and says which limit
//! binds. It is what the benchmark prints for thread counts this machine does not have; a
//! device's measurements validate it (`bench --validate`, BENCHMARKS.md).
//!
//! The rate R (hits per second) of a run is the least of these limits, each a work
//! balance over the threads that do it:
//! - classic: the T calculating threads, R·(τ + c_c) ≤ T; the one accumulating thread,
//!   R·a_c ≤ 1; all of it on the cores, R·(τ + c_c + a_c) ≤ C.
//! - dynamic: the calculating threads, R·(τ + c_d) ≤ T (plus a_d when the calculating
//!   threads alone fill the cores and apply portions themselves); the cores,
//!   R·(τ + c_d + a_d) ≤ C; and each vertex group, which one thread at a time applies,
//!   R·a_d·share(g) ≤ 1. Groups start as T equal slot ranges and, as the scheduler does,
//!   the busiest one splits into `subd` while it is the limit, within the scheduler's
//!   bounds (64 groups per thread, at most 4096; subgroups of at least 256 slots).
//!
//! τ, c and a are seconds per hit. τ at T threads is the trace-only rate measured at T
//! threads where it was measured, and the largest measured thread count's per-thread rate
//! beyond that; the other costs scale with τ(T)/τ(1) (a core that traces faster under load
//! also accumulates faster). share(g) is the group's part of the map's work, from each
//! slot's effective number of hits (1/rel_error², read after a photons-only run).
//! Left out: memory bandwidth, cache lines moving between cores, and the monitor's reaction
//! time (the scheduler splits only when free portions run low, and waits a millisecond
//! between splits).

/// Per-hit costs measured with one calculating thread, seconds per hit.
#[derive(Clone, Copy, Debug)]
pub struct Costs {
    /// Tracing alone (the trace-only scheduler).
    pub trace: f64,
    /// The classic calculating thread's work beyond tracing: records, sorting, hand-over.
    pub classic_calc: f64,
    /// The classic accumulating thread's work.
    pub classic_accum: f64,
    /// The dynamic calculating thread's work beyond tracing: contributions, group
    /// lookups, hand-over.
    pub dynamic_calc: f64,
    /// The dynamic processing threads' work (applying portions under the group's lock).
    pub dynamic_accum: f64,
}

/// How the map's work is spread over its slots (cumulative, in slot order).
pub struct Load {
    prefix: Vec<f64>,
}

impl Load {
    /// From each slot's work (any unit).
    pub fn new(per_slot: &[f64]) -> Self {
        let mut prefix = Vec::with_capacity(per_slot.len() + 1);
        let mut sum = 0.0;
        prefix.push(0.0);
        for &w in per_slot {
            sum += w.max(0.0);
            prefix.push(sum);
        }
        Load { prefix }
    }

    pub fn slots(&self) -> usize {
        self.prefix.len() - 1
    }

    /// The part of all work in slots `start..end`.
    fn share(&self, start: usize, end: usize) -> f64 {
        let total = self.prefix[self.slots()];
        if total > 0.0 {
            (self.prefix[end] - self.prefix[start]) / total
        } else {
            (end - start) as f64 / self.slots().max(1) as f64
        }
    }
}

/// The limit that sets a predicted rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bound {
    /// The calculating threads.
    Calc,
    /// The cores.
    Cores,
    /// The classic scheduler's one accumulating thread.
    Accumulator,
    /// The dynamic scheduler's busiest vertex group.
    Group,
}

impl Bound {
    pub fn label(self) -> &'static str {
        match self {
            Bound::Calc => "calc",
            Bound::Cores => "cores",
            Bound::Accumulator => "accum",
            Bound::Group => "group",
        }
    }
}

/// A prediction for one thread count.
#[derive(Clone, Copy, Debug)]
pub struct Prediction {
    /// Hits per second.
    pub classic: f64,
    pub dynamic: f64,
    pub classic_bound: Bound,
    pub dynamic_bound: Bound,
    /// The dynamic scheduler's leaf groups after the modelled splits.
    pub groups: usize,
}

/// The least of `limits` and which one it is.
fn least(limits: &[(f64, Bound)]) -> (f64, Bound) {
    limits.iter().copied().fold(
        (f64::INFINITY, Bound::Calc),
        |a, b| if b.0 < a.0 { b } else { a },
    )
}

/// The dynamic scheduler's group bounds (`DynamicParams::default()`).
const SUBD: usize = 4;
const MIN_GROUP_SLOTS: usize = 256;
const GROUPS_PER_THREAD: usize = 64;
const MOST_GROUPS: usize = 4096;

/// Leaf groups as the scheduler makes them: `threads` equal slot ranges, then the busiest
/// split into `SUBD` while `limits(busiest share)` says it binds and the bounds allow.
fn groups(load: &Load, threads: usize, binds: impl Fn(f64) -> bool) -> Vec<(usize, usize)> {
    let slots = load.slots().max(1);
    let size = slots.div_ceil(threads.clamp(1, slots)).max(1);
    let mut leaves: Vec<(usize, usize)> = (0..slots.div_ceil(size))
        .map(|g| (g * size, ((g + 1) * size).min(slots)))
        .collect();
    let capacity = (GROUPS_PER_THREAD * threads).min(MOST_GROUPS);
    let mut count = leaves.len();
    loop {
        let (i, &(s, e)) = leaves
            .iter()
            .enumerate()
            .max_by(|a, b| {
                load.share(a.1 .0, a.1 .1)
                    .total_cmp(&load.share(b.1 .0, b.1 .1))
            })
            .expect("at least one group");
        if !binds(load.share(s, e)) || e - s < SUBD * MIN_GROUP_SLOTS || count + SUBD > capacity {
            return leaves;
        }
        // As `GroupTable::split`: chunks of len / subd + 1 slots.
        let chunk = (e - s) / SUBD + 1;
        leaves.swap_remove(i);
        for k in 0..SUBD {
            let (a, b) = ((s + k * chunk).min(e), (s + (k + 1) * chunk).min(e));
            if a < b {
                leaves.push((a, b));
            }
        }
        count += SUBD;
    }
}

/// Predicted rates with `threads` calculating threads on `cores` cores, where tracing alone
/// costs `trace_t` seconds per hit per thread at that thread count.
pub fn predict(c: &Costs, load: &Load, threads: usize, cores: usize, trace_t: f64) -> Prediction {
    let t = threads.max(1) as f64;
    let n = cores.max(1) as f64;
    let speed = if c.trace > 0.0 {
        trace_t / c.trace
    } else {
        1.0
    };
    let (cc, ac) = (c.classic_calc * speed, c.classic_accum * speed);
    let (cd, ad) = (c.dynamic_calc * speed, c.dynamic_accum * speed);

    let (classic, classic_bound) = least(&[
        (t / (trace_t + cc), Bound::Calc),
        (1.0 / ac, Bound::Accumulator),
        (n / (trace_t + cc + ac), Bound::Cores),
    ]);

    // The calculating threads apply portions themselves when they alone fill the cores
    // (`DynamicParams::inline_apply`, automatic).
    let inline = threads >= cores;
    let calc = t / (trace_t + cd + if inline { ad } else { 0.0 });
    let (other, other_bound) =
        least(&[(calc, Bound::Calc), (n / (trace_t + cd + ad), Bound::Cores)]);
    let leaves = groups(load, threads, |share| share * ad * other > 1.0);
    let busiest = leaves
        .iter()
        .map(|&(s, e)| load.share(s, e))
        .fold(0.0, f64::max);
    let (dynamic, dynamic_bound) =
        least(&[(other, other_bound), (1.0 / (busiest * ad), Bound::Group)]);
    Prediction {
        classic,
        dynamic,
        classic_bound,
        dynamic_bound,
        groups: leaves.len(),
    }
}

/// One row of a device's benchmark table (`bench`'s own output): its scene, band count,
/// one-thread costs (µs per hit), thread count and measured rates (M hits/s).
#[derive(Clone, Debug)]
pub struct DeviceRow {
    pub scene: String,
    pub bands: u32,
    pub trace_us: f64,
    pub accum_us: f64,
    pub threads: usize,
    pub trace_t: f64,
    pub classic: f64,
    pub dynamic: f64,
}

/// The table rows of a saved `bench` output (lines that are not rows are skipped).
pub fn device_rows(text: &str) -> Vec<DeviceRow> {
    text.lines()
        .filter_map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            if f.len() < 9 || f[0].starts_with('#') {
                return None;
            }
            Some(DeviceRow {
                scene: f[0].to_owned(),
                bands: f[1].parse().ok()?,
                trace_us: f[3].parse().ok()?,
                accum_us: f[4].parse().ok()?,
                threads: f[5].parse().ok()?,
                trace_t: f[6].parse().ok()?,
                classic: f[7].parse().ok()?,
                dynamic: f[8].parse().ok()?,
            })
        })
        .collect()
}

//! Stop criteria on chosen meshes (regions): the error of the vertices of a calculation
//! grid, of its average or of its uniformity, evaluated by the monitor at each progress
//! tick while the writers go on (each scheduler says how its slots are read safely).

use super::RunContext;
use crate::imap::readout::std_error;
use crate::imap::regions::RegionTally;
use crate::imap::stats::{self, Estimate};
use crate::imap::{IMap, Readout};
use crate::scene::PreparedMesh;
use std::ops::Range;

/// What a region target measures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RegionMeasure {
    /// The given percentile (0 < p ≤ 100; 100 = the largest) of the vertices' relative
    /// standard errors (band mean, as `rel_error`). Vertices that received nothing at all
    /// are left out (under or inside an object, they never will); with light sampling,
    /// no measure while a vertex waits for its first direct pass.
    Vertices { percentile: f64 },
    /// The relative standard error of each chosen mesh side's average illuminance (the
    /// largest over them), once its other figures are estimates (`sane`: Emin, Emax and
    /// U0 known to 25 %, Emin ≤ Eavg ≤ Emax and U0 ≤ 1 within their errors).
    Average,
    /// The relative standard error of each chosen mesh side's uniformity U0 = Emin/Eavg
    /// (the largest over them), under the same condition as `Average`.
    Uniformity,
}

/// Stop when `measure` over `meshes` is at or below `target`.
#[derive(Clone, Debug, PartialEq)]
pub struct RegionTarget {
    /// Indices of recording meshes in the prepared scene.
    pub meshes: Vec<usize>,
    /// Only the triangles of this material (a part, e.g. a grid's points without its guard
    /// ring), and the vertices they touch; None: whole meshes.
    pub part: Option<u32>,
    pub measure: RegionMeasure,
    pub target: f64,
}

/// Reading slots while the run's writers go on: `visit` calls `f` on every slot of
/// `slots` while no writer can change them.
pub trait SlotAccess {
    fn visit(&self, slots: Range<usize>, f: &mut dyn FnMut(usize));
}

/// Slots nobody else writes now (the classic scheduler's accumulating thread reads its
/// own map).
pub struct Exclusive;

impl SlotAccess for Exclusive {
    fn visit(&self, slots: Range<usize>, f: &mut dyn FnMut(usize)) {
        slots.for_each(f);
    }
}

/// The measure of `t` after `photons` photons; None while any chosen side has nothing.
pub fn region_error(
    t: &RegionTarget,
    map: &IMap,
    rc: &RunContext,
    photons: u64,
    access: &dyn SlotAccess,
) -> Option<f64> {
    if photons == 0 {
        return None;
    }
    let scene = rc.scene;
    let readout = Readout {
        map,
        scene,
        photons,
        unit_m: rc.unit_m,
        layer: None,
        plan: rc.neighbours(),
    };
    let targets = t.meshes.iter().zip(rc.region_weights);
    match t.measure {
        RegionMeasure::Vertices { percentile } => {
            let mut rel = Vec::new();
            for (&i, weights) in targets {
                let m = &scene.meshes[i];
                let base = m.slot_base?;
                let sides = m.sides();
                // With light sampling, a vertex whose first direct pass is still to come
                // has a value of unknown size: no measure yet.
                for side in 0..sides {
                    if readout
                        .region_direct(m, side, weights)
                        .is_some_and(|d| d.waiting > 0)
                    {
                        return None;
                    }
                }
                access.visit(base..base + m.vertex_area.len() * sides, &mut |slot| {
                    // A vertex that received nothing at all (no photon, no light sample:
                    // under or inside an object) is left out: it would hold the measure at
                    // 1 for ever. `RegionStats::unlit_vertices` reports such vertices.
                    if weights[(slot - base) / sides] > 0.0 && readout.sigma(slot).1 > 0.0 {
                        rel.push(readout.slot_rel_error(slot));
                    }
                });
            }
            percentile_of(&mut rel, percentile)
        }
        RegionMeasure::Average | RegionMeasure::Uniformity => {
            let mut tally = rc.regions_before.clone();
            tally.merge(&rc.regions.total());
            let mut worst: f64 = 0.0;
            for (&i, weights) in targets {
                let m = &scene.meshes[i];
                let regions = rc.layout.regions.meshes[i].as_ref()?;
                for side in 0..m.sides() {
                    let r = regions.region(side, t.part) as usize;
                    let avg = luminous(&tally, r, &readout, m, side, weights)?;
                    // Every figure the region reports must make sense before its average
                    // or uniformity may end a run: Emin ≤ Eavg ≤ Emax, 0 < U0 ≤ 1 (an
                    // early stop reported U0 = 1.18 ± 0.58).
                    let u0 = uniformity_error(m, weights, side, &readout, avg, access)?;
                    let e = if t.measure == RegionMeasure::Average {
                        avg.sigma / avg.value
                    } else {
                        u0?
                    };
                    worst = worst.max(e);
                }
            }
            Some(worst)
        }
    }
}

/// The `p`-th percentile (nearest rank) of `x`; None for no values.
fn percentile_of(x: &mut [f64], p: f64) -> Option<f64> {
    if x.is_empty() {
        return None;
    }
    x.sort_unstable_by(f64::total_cmp);
    let rank = ((p / 100.0) * x.len() as f64).ceil() as usize;
    Some(x[rank.clamp(1, x.len()) - 1])
}

/// The luminous flux of region `r` (photon units): the photons' tallies and, with light
/// sampling, the direct part of its vertices (`Readout::region_direct`, as
/// `Context::region_stats` reads it); None while it has nothing or while a vertex of it waits
/// for its first direct pass (its direct light unknown, the region's error with it).
fn luminous(
    t: &RegionTally,
    r: usize,
    readout: &Readout,
    m: &PreparedMesh,
    side: usize,
    weights: &[f64],
) -> Option<Estimate> {
    if t.regions() <= r {
        return None;
    }
    let nb = t.bands;
    let efficacy = &readout.scene.efficacy;
    let mut s: f64 = (0..nb).map(|b| t.sum[r * nb + b] * efficacy[b]).sum();
    let mut sigma = std_error(s, t.sq_lum[r], readout.photons as f64);
    if let Some(d) = readout.region_direct(m, side, weights) {
        if d.waiting > 0 {
            return None;
        }
        let k = readout.units_per_watt();
        s += d.lum * k;
        sigma = sigma.hypot(d.var_lum.sqrt() * k);
    }
    (s > 0.0).then_some(Estimate { value: s, sigma })
}

/// The relative standard error of U0 of mesh `m`'s `side`, its vertices weighted by
/// `weights` (the target's share of them), given its luminous sum `avg` (photon units):
/// None while the region's figures do not make sense together (`sane`), Some(None) when
/// U0 is 0 (a vertex no light reaches: no relative error).
fn uniformity_error(
    m: &PreparedMesh,
    weights: &[f64],
    side: usize,
    readout: &Readout,
    avg: Estimate,
    access: &dyn SlotAccess,
) -> Option<Option<f64>> {
    let base = m.slot_base?;
    let sides = m.sides();
    let nv = m.vertex_area.len();
    let map = readout.map;
    let eff = &readout.scene.efficacy;
    // Everything in photon units per scene unit²: U0 is a ratio.
    let mut lux = vec![0.0; nv];
    let mut sigma = vec![0.0; nv];
    access.visit(base..base + nv * sides, &mut |slot| {
        let v = (slot - base) / sides;
        let a = m.vertex_area[v];
        if (slot - base) % sides != side || a <= 0.0 {
            return;
        }
        let l: f64 = (0..map.bands())
            .map(|b| readout.value(slot, b) * eff[b])
            .sum();
        lux[v] = l / a;
        sigma[v] = lux[v] * readout.slot_rel_error(slot);
    });
    let area: f64 = weights.iter().sum();
    let average = Estimate {
        value: avg.value / area,
        sigma: avg.sigma / area,
    };
    // Vertices no light reached are left out of the extremes, as `region_stats` does.
    let lit = stats::lit_weights(&lux, weights);
    let x = stats::extremes(&lux, &sigma, &lit, average)?;
    sane(&x, average.value).then(|| (x.u0.value > 0.0).then(|| x.u0.sigma / x.u0.value))
}

/// The largest relative error a region's Emin, Emax or U0 may have when its average or
/// uniformity ends a run: past it they are no estimate yet, whatever the average's error.
pub const MAX_FIGURE_ERROR: f64 = 0.25;

/// Whether a region's figures are estimates worth reporting: finite, Emin, Emax and U0
/// known to `MAX_FIGURE_ERROR` (a figure of 0 is exact), and consistent within twice their
/// errors: Emin ≤ Eavg ≤ Emax, U0 ≤ 1 (an early stop on the average reported
/// U0 = 1.18 ± 0.58, an Emin above its Eavg).
pub(crate) fn sane(x: &stats::Extremes, average: f64) -> bool {
    let known = |e: &Estimate| {
        e.value.is_finite()
            && e.sigma.is_finite()
            && e.value >= 0.0
            && e.sigma <= MAX_FIGURE_ERROR * e.value
    };
    [x.min, x.max, x.u0].iter().all(known)
        && x.min.value <= average + 2.0 * x.min.sigma
        && x.max.value >= average - 2.0 * x.max.sigma
        && x.u0.value <= 1.0 + 2.0 * x.u0.sigma
}

#[cfg(test)]
mod tests {
    use super::{percentile_of, sane};
    use crate::imap::stats::{Estimate, Extremes};

    fn e(value: f64, sigma: f64) -> Estimate {
        Estimate { value, sigma }
    }

    /// The early stop users met (U0 = 1.18 ± 0.58, Emin above Eavg) is no estimate; the
    /// same figures known to a few percent are; an unlit point (Emin = U0 = 0) is exact.
    #[test]
    fn region_figures_must_be_estimates_before_a_target_is_met() {
        let early = Extremes {
            min: e(118.0, 58.0),
            max: e(160.0, 30.0),
            min_observed: 90.0,
            max_observed: 170.0,
            u0: e(1.18, 0.58),
            ud: e(0.74, 0.4),
        };
        assert!(!sane(&early, 100.0));
        let later = Extremes {
            min: e(62.0, 1.5),
            max: e(141.0, 2.0),
            u0: e(0.62, 0.015),
            ud: e(0.44, 0.012),
            ..early
        };
        assert!(sane(&later, 100.0));
        // Emin above Eavg by more than twice its error.
        assert!(!sane(
            &Extremes {
                min: e(104.0, 1.0),
                ..later
            },
            100.0
        ));
        let dark = Extremes {
            min: e(0.0, 0.0),
            u0: e(0.0, 0.0),
            ud: e(0.0, 0.0),
            ..later
        };
        assert!(sane(&dark, 100.0));
    }

    #[test]
    fn percentiles_by_nearest_rank() {
        let mut x: Vec<f64> = (1..=20).rev().map(f64::from).collect();
        assert_eq!(percentile_of(&mut x, 100.0), Some(20.0));
        assert_eq!(percentile_of(&mut x, 95.0), Some(19.0));
        assert_eq!(percentile_of(&mut x, 50.0), Some(10.0));
        assert_eq!(percentile_of(&mut x, 0.1), Some(1.0));
        assert_eq!(percentile_of(&mut [], 50.0), None);
    }
}

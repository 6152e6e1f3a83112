//! Stop criteria on chosen meshes (regions): the error of the vertices of a calculation
//! grid, of its average or of its uniformity, evaluated by the monitor at each progress
//! tick while the writers go on (each scheduler says how its slots are read safely).

use super::RunContext;
use crate::imap::readout::NO_DATA_REL_ERROR;
use crate::imap::regions::RegionTally;
use crate::imap::stats::{self, Estimate};
use crate::imap::IMap;
use std::ops::Range;

/// What a region target measures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RegionMeasure {
    /// The given percentile (0 < p ≤ 100; 100 = the largest) of the vertices' relative
    /// standard errors (band mean, as `rel_error`); a vertex that received nothing counts
    /// as 1.
    Vertices { percentile: f64 },
    /// The relative standard error of each chosen mesh side's average illuminance (the
    /// largest over them).
    Average,
    /// The relative standard error of each chosen mesh side's uniformity U0 = Emin/Eavg
    /// (the largest over them).
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
    let n = photons as f64;
    let scene = rc.scene;
    let nb = map.bands();
    match t.measure {
        RegionMeasure::Vertices { percentile } => {
            let mut rel = Vec::new();
            for &i in &t.meshes {
                let m = &scene.meshes[i];
                let base = m.slot_base?;
                let sides = m.sides();
                let weights = part_weights(m, t.part);
                access.visit(base..base + m.vertex_area.len() * sides, &mut |slot| {
                    if weights[(slot - base) / sides] > 0.0 {
                        let (s, q) = map.scalar(slot);
                        rel.push(if s > 0.0 {
                            (q - s * s / n).max(0.0).sqrt() / s
                        } else {
                            NO_DATA_REL_ERROR
                        });
                    }
                });
            }
            percentile_of(&mut rel, percentile)
        }
        RegionMeasure::Average | RegionMeasure::Uniformity => {
            let mut tally = rc.regions_before.clone();
            tally.merge(&rc.regions.total());
            let mut worst: f64 = 0.0;
            for &i in &t.meshes {
                let m = &scene.meshes[i];
                let regions = scene.regions.meshes[i].as_ref()?;
                for side in 0..m.sides() {
                    let r = match t.part {
                        None => regions.mesh_region(side),
                        Some(p) => regions
                            .part_region(side, p)
                            .unwrap_or(regions.mesh_region(side)),
                    } as usize;
                    let avg = luminous(&tally, r, nb, &scene.efficacy, n)?;
                    let e = if t.measure == RegionMeasure::Average {
                        avg.sigma / avg.value
                    } else {
                        uniformity_error(m, t.part, side, map, rc, photons, avg, access)?
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

/// Region `r`'s luminous sum and its standard error in photon units; None before it
/// received anything.
fn luminous(t: &RegionTally, r: usize, nb: usize, efficacy: &[f64], n: f64) -> Option<Estimate> {
    if t.regions() <= r {
        return None;
    }
    let s: f64 = (0..nb).map(|b| t.sum[r * nb + b] * efficacy[b]).sum();
    (s > 0.0).then(|| Estimate {
        value: s,
        sigma: (t.sq_lum[r] - s * s / n).max(0.0).sqrt(),
    })
}

/// Each vertex's share of the area of mesh `m`'s triangles of material `part` (all
/// triangles for None), scene units².
fn part_weights(m: &crate::scene::PreparedMesh, part: Option<u32>) -> Vec<f64> {
    let Some(p) = part else {
        return m.vertex_area.clone();
    };
    let mut w = vec![0.0; m.vertex_area.len()];
    for (t, tri) in m.triangles.iter().enumerate() {
        if m.material(t) == p {
            let a = m.area(t) / 3.0;
            for &v in tri {
                w[v as usize] += a;
            }
        }
    }
    w
}

/// The relative standard error of U0 of mesh `m`'s `side` (or its part), given its
/// luminous sum `avg` (photon units).
#[allow(clippy::too_many_arguments)]
fn uniformity_error(
    m: &crate::scene::PreparedMesh,
    part: Option<u32>,
    side: usize,
    map: &IMap,
    rc: &RunContext,
    photons: u64,
    avg: Estimate,
    access: &dyn SlotAccess,
) -> Option<f64> {
    let base = m.slot_base?;
    let sides = m.sides();
    let nv = m.vertex_area.len();
    let n = photons as f64;
    let eff = &rc.scene.efficacy;
    // Everything in photon units per scene unit²: U0 is a ratio.
    let mut lux = vec![0.0; nv];
    let mut sigma = vec![0.0; nv];
    access.visit(base..base + nv * sides, &mut |slot| {
        let (v, s_side) = ((slot - base) / sides, (slot - base) % sides);
        let a = m.vertex_area[v];
        if s_side != side || a <= 0.0 {
            return;
        }
        let l: f64 = (0..map.bands()).map(|b| map.value(slot, b) * eff[b]).sum();
        let (s, q) = map.scalar(slot);
        lux[v] = l / a;
        sigma[v] = if s > 0.0 {
            lux[v] * (q - s * s / n).max(0.0).sqrt() / s
        } else {
            lux[v]
        };
    });
    let weights = part_weights(m, part);
    let area: f64 = weights.iter().sum();
    let average = Estimate {
        value: avg.value / area,
        sigma: avg.sigma / area,
    };
    let x = stats::extremes(&lux, &sigma, &weights, average)?;
    (x.u0.value > 0.0).then(|| x.u0.sigma / x.u0.value)
}

#[cfg(test)]
mod tests {
    use super::percentile_of;

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

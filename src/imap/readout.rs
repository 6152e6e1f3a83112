//! From accumulators to physical values: irradiance in W/m² per band and the relative
//! standard error per vertex, plus the global error figure.
//!
//! A photon carries Φ/N watts summed over bands (Φ: total emitted power, N: photons), so one
//! unit of band value is Φ/(N·B) watts; a vertex's irradiance is its energy divided by its
//! share of the adjacent triangles' area (a third of each), converted to m².
//!
//! Error: the scalar estimate of a slot is S = Σ_k X_k, where X_k is photon k's total
//! contribution to the slot over its whole path (deposits of unit-energy photons). With
//! Q = Σ_k X_k² (summed per photon before squaring), N·Var(X) is estimated by Q − S²/N and
//! the relative standard error is √(Q − S²/N) / S. `tests/calibration.rs` checks it against
//! the spread over independent seeds, up to ρ = 0.99 in a closed sphere.

use super::{DirectAcc, IMap};
use crate::scene::{PreparedMesh, PreparedScene};

/// Relative error reported for a vertex that received nothing or has no area: 1 (100 %).
pub(crate) const NO_DATA_REL_ERROR: f64 = 1.0;

/// The standard error of a sum `sum` of `n` independent photon contributions whose squares
/// sum to `sq`: √(Q − S²/N) (the module's formula; 0 when rounding makes it negative).
#[inline]
pub(crate) fn std_error(sum: f64, sq: f64, n: f64) -> f64 {
    (sq - sum * sum / n).max(0.0).sqrt()
}

/// A total of `n` photons' contributions (their sum and the sum of their squares) in
/// units of `unit` each, with its standard error.
#[inline]
pub(crate) fn photon_total(sum: f64, sq: f64, n: f64, unit: f64) -> super::stats::Estimate {
    super::stats::Estimate {
        value: sum * unit,
        sigma: std_error(sum, sq, n) * unit,
    }
}

/// The direct part of a region (the light-sampling estimator's vertex passes), in the
/// direct accumulators' unit (W): per band and luminous (weighted by the bands' efficacies),
/// its flux and variance.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct RegionDirect {
    pub flux: Vec<f64>,
    pub var: Vec<f64>,
    pub lum: f64,
    pub var_lum: f64,
    /// Vertices of the region that no pass has reached yet: their direct light is unknown
    /// (passes reach every vertex with area; photon k's pass, so early in a run only).
    pub waiting: usize,
}

/// What turns map values into physical ones.
pub struct Readout<'a> {
    pub map: &'a IMap,
    pub scene: &'a PreparedScene,
    pub photons: u64,
    pub unit_m: f64,
    /// One layer of the map (`LayerLayout`), or None: the combined values.
    pub layer: Option<u8>,
    /// Each slot's neighbours (the light-sampling estimator's plan knows its vertices'
    /// triangles), for the direct part's error (`neighbours_spread`); None: each slot's own
    /// spread alone.
    pub plan: Option<&'a dyn Neighbours>,
}

/// Who lists a map slot's neighbours: the slots of the vertices that share a triangle
/// with its vertex, on the same side (a neighbour may come twice).
pub trait Neighbours: Sync {
    fn neighbour_slots(&self, scene: &PreparedScene, slot: usize, f: &mut dyn FnMut(usize));
}

impl Neighbours for crate::transport::direct::DirectPlan {
    fn neighbour_slots(&self, scene: &PreparedScene, slot: usize, f: &mut dyn FnMut(usize)) {
        crate::transport::direct::DirectPlan::neighbour_slots(self, scene, slot, f)
    }
}

impl Readout<'_> {
    /// Photon units per watt of direct flux: N·B/Φ.
    #[inline]
    pub(crate) fn units_per_watt(&self) -> f64 {
        if self.scene.total_power > 0.0 {
            self.photons as f64 * self.map.bands() as f64 / self.scene.total_power
        } else {
            0.0
        }
    }

    /// A slot's value in `band`, photon units: the photons' deposits plus, with the
    /// light-sampling estimator, the direct estimate (its mean over passes) converted.
    #[inline]
    pub(crate) fn value(&self, slot: usize, band: usize) -> f64 {
        let photons = match self.layer {
            None => self.map.value(slot, band),
            Some(l) => self.map.layer_value(slot, l, band),
        };
        let Some(d) = self.map.direct() else {
            return photons;
        };
        let cells = self.map.layout().cells(slot, self.layer);
        let direct: f64 = cells.map(|c| d.band_mean(c, band).0).sum();
        photons + direct * self.units_per_watt()
    }

    /// Watts per unit of band value.
    fn watts_per_unit(&self) -> f64 {
        if self.photons == 0 {
            return 0.0;
        }
        self.scene.total_power / (self.photons as f64 * self.map.bands() as f64)
    }

    /// Irradiance (W/m²) in `band` at every vertex of `mesh` on `side`, into `out`.
    /// Vertices with zero area (used by no triangle, or only by zero-area ones) get 0.
    pub fn irradiance(&self, mesh: &PreparedMesh, side: usize, band: usize, out: &mut [f64]) {
        let k = self.watts_per_unit() / (self.unit_m * self.unit_m);
        for (v, o) in out.iter_mut().enumerate() {
            let slot = mesh.slot(v as u32, side).expect("recording mesh");
            let a = mesh.vertex_area[v];
            *o = if a > 0.0 {
                self.value(slot, band) * k / a
            } else {
                0.0
            };
        }
    }

    /// Σ_b w_b E_b at every vertex of `mesh` on `side` for each of the weight rows in
    /// `weights` (one row of band weights per output quantity), into `out` (vertex-major:
    /// `out[v * rows + r]`): lux with the bands' luminous efficacies, X Y Z with the
    /// colour-matching weights.
    pub fn weighted(&self, mesh: &PreparedMesh, side: usize, weights: &[&[f64]], out: &mut [f64]) {
        let k = self.watts_per_unit() / (self.unit_m * self.unit_m);
        let rows = weights.len();
        for v in 0..mesh.vertex_area.len() {
            let slot = mesh.slot(v as u32, side).expect("recording mesh");
            let a = mesh.vertex_area[v];
            for (r, w) in weights.iter().enumerate() {
                out[v * rows + r] = if a > 0.0 {
                    w.iter()
                        .enumerate()
                        .map(|(b, w)| w * self.value(slot, b))
                        .sum::<f64>()
                        * k
                        / a
                } else {
                    0.0
                };
            }
        }
    }

    /// The standard error of a slot's scalar estimate, in photon units, and the estimate.
    #[inline]
    pub(crate) fn sigma(&self, slot: usize) -> (f64, f64) {
        let (s, q) = match self.layer {
            None => self.map.scalar(slot),
            Some(l) => self.map.layer_scalar(slot, l),
        };
        let n = self.photons.max(1) as f64;
        let sigma = std_error(s, q, n);
        let Some(d) = self.map.direct() else {
            return (sigma, s);
        };
        // The direct part: independent of the photons, so the variances add.
        let k = self.units_per_watt();
        let cells = self.map.layout().cells(slot, self.layer);
        let (mean, mut var, passes) = d.scalar_of(cells.clone(), cells.len() > 1);
        if let (Some(plan), true) = (self.plan, passes >= 2.0 && mean > 0.0) {
            var = var.max(mean * mean * self.neighbours_spread(plan, d, slot, mean, var, passes));
        }
        let total = s + mean * k;
        if passes == 0.0 && total > 0.0 {
            // No pass has reached the vertex yet: its direct part is unknown.
            return (total, total);
        }
        ((sigma * sigma + var * k * k).sqrt(), total)
    }

    /// A floor for slot `slot`'s direct relative variance of the mean (its direct part's
    /// `mean`, `var` and `passes`): the upper quartile of the relative spread of the passes
    /// (variance per pass over the mean²) over the slot and those of its neighbours (the
    /// vertices sharing a triangle with it, same side) that read more than it does, over
    /// `passes`.
    ///
    /// With few passes a slot's own spread is itself noisy, and smallest exactly when its
    /// passes missed what lights part of its support (a luminaire's lobe or edge): value
    /// and error then correlate negatively, and a slot claims a small error for a value
    /// far below the truth. Its brighter neighbours' spread is independent of its own luck.
    /// Dimmer neighbours are left out: across a step in the light (the edge of a sun patch
    /// or a beam) their spread is the step's, not this slot's. On a EULUMDAT wall washer in
    /// a black sphere, values beyond 3 estimated errors at 100 000 photons fell from 2.0 %
    /// to 1.2 % and the correlation of value and error from −0.36 to −0.10 (docs/estimators).
    fn neighbours_spread(
        &self,
        plan: &dyn Neighbours,
        d: &DirectAcc,
        slot: usize,
        mean: f64,
        var: f64,
        passes: f64,
    ) -> f64 {
        let mut cv2 = [0.0f64; 16];
        cv2[0] = var * passes / (mean * mean);
        let mut k = 1;
        plan.neighbour_slots(self.scene, slot, &mut |u| {
            let c = self.map.layout().cells(u, self.layer);
            let (mu, vu, nu) = d.scalar_of(c.clone(), c.len() > 1);
            if nu >= 2.0 && mu >= mean && k < cv2.len() {
                cv2[k] = vu * nu / (mu * mu);
                k += 1;
            }
        });
        let cv2 = &mut cv2[..k];
        cv2.sort_unstable_by(f64::total_cmp);
        cv2[(3 * k) / 4] / passes
    }

    /// The direct part of the region of `mesh`'s `side` whose vertices have the area shares
    /// `shares` (scene units², as `vertex_area`; a vertex counts with `shares[v]` over its
    /// area), or None without light sampling. A vertex's direct flux is the mean over its
    /// passes and its variance their sample variance over the count; vertices are
    /// independent (each pass has its own point set), so the variances add. Reads only
    /// the direct accumulators (atomic): safe while the run's writers go on.
    pub(crate) fn region_direct(
        &self,
        mesh: &PreparedMesh,
        side: usize,
        shares: &[f64],
    ) -> Option<RegionDirect> {
        let d = self.map.direct()?;
        let nb = self.map.bands();
        let eff = &self.scene.efficacy;
        let mut out = RegionDirect {
            flux: vec![0.0; nb],
            var: vec![0.0; nb],
            lum: 0.0,
            var_lum: 0.0,
            waiting: 0,
        };
        for (v, &w) in shares.iter().enumerate() {
            let a = mesh.vertex_area[v];
            let Some(slot) = mesh.slot(v as u32, side) else {
                continue;
            };
            if w <= 0.0 || a <= 0.0 {
                continue;
            }
            let k = w / a;
            let cells = self.map.layout().cells(slot, self.layer);
            let (mean, var, passes) = d.scalar_of(cells.clone(), cells.len() > 1);
            if passes == 0.0 {
                out.waiting += 1;
                continue;
            }
            let mut l = 0.0;
            for (b, (flux, band_var)) in out.flux.iter_mut().zip(&mut out.var).enumerate() {
                let f: f64 = cells.clone().map(|c| d.band_mean(c, b).0).sum();
                *flux += k * f;
                if mean > 0.0 {
                    *band_var += k * k * var * (f / mean).powi(2);
                }
                l += f * eff[b];
            }
            out.lum += k * l;
            if mean > 0.0 {
                out.var_lum += k * k * var * (l / mean).powi(2);
            }
        }
        Some(out)
    }

    /// Relative standard error of every vertex of `mesh` on `side`, into `out`.
    pub fn rel_error(&self, mesh: &PreparedMesh, side: usize, out: &mut [f64]) {
        for (v, o) in out.iter_mut().enumerate() {
            let slot = mesh.slot(v as u32, side).expect("recording mesh");
            *o = if mesh.vertex_area[v] > 0.0 {
                self.slot_rel_error(slot)
            } else {
                NO_DATA_REL_ERROR
            };
        }
    }

    /// Relative standard error of one slot's estimate (`NO_DATA_REL_ERROR` before anything
    /// arrived).
    #[inline]
    pub fn slot_rel_error(&self, slot: usize) -> f64 {
        let (sigma, s) = self.sigma(slot);
        if s > 0.0 {
            sigma / s
        } else {
            NO_DATA_REL_ERROR
        }
    }

    /// Σ σ(E_v) and Σ E_v (in photon units per scene unit²) over the slots in `slots`
    /// that have area: the two sums of the global error figure, for part of the map.
    pub fn error_sums(&self, slots: std::ops::Range<usize>) -> (f64, f64) {
        let (mut num, mut den) = (0.0, 0.0);
        for mesh in &self.scene.meshes {
            let Some(base) = mesh.slot_base else { continue };
            let sides = mesh.sides();
            let end = base + mesh.vertex_area.len() * sides;
            for slot in slots.start.max(base)..slots.end.min(end) {
                let a = mesh.vertex_area[(slot - base) / sides];
                if a > 0.0 {
                    let (sigma, s) = self.sigma(slot);
                    num += sigma / a;
                    den += s / a;
                }
            }
        }
        (num, den)
    }

    /// The global error figure: the irradiance-weighted mean of the vertices' relative
    /// standard errors, Σ σ(E_v) / Σ E_v over every recorded slot with area. `None` before
    /// any deposit.
    pub fn global_error(&self) -> Option<f64> {
        let (num, den) = self.error_sums(0..usize::MAX);
        (den > 0.0).then_some(num / den)
    }
}

//! The illumination map: per (vertex, recorded side) slot, one f64 accumulator per band
//! plus the sum over photons of the square of each photon's scalar contribution to the
//! slot (the paper's fourth value) for the Monte Carlo error. A photon that reaches a slot
//! several times along its path contributes (Σ w)², not Σ w²: each deposit adds its w², and
//! at the path's end the cross terms (Σ w)² − Σ w² of slots reached more than once are
//! added (`PhotonSquares`). In a closed, highly reflective scene photons return to a vertex
//! many times; squaring single deposits alone underestimated the variance (at ρ = 0.99 it
//! gave 0 for some vertices), and the cross terms cost nothing where paths do not return.
//! Slots exist only for recording meshes and only for their recorded sides; a slot's
//! values are contiguous so one deposit touches one cache line or a few.
//!
//! Layers (on request, `LayerLayout`): a slot then holds one such record per light group,
//! side by side (cell = slot · per_slot + layer), plus one for the direct component. A photon
//! comes from one light, so it writes one group layer: the combined value is the sum of the
//! group layers, and so is the combined sum of squares, exactly (no photon has a cross term
//! between two groups). The direct layer repeats the first-surface deposits and is not part
//! of the sum. Without layers a slot has one cell and the cell index is the slot.
//!
//! The values are f64 bit patterns in `AtomicU64`s (same layout as f64). Writers use plain
//! f64 arithmetic: the classic accumulator through its exclusive `&mut`, the dynamic
//! scheduler's writers through `*_exclusive` while holding their vertex group's lock; the
//! progress readout during a dynamic run takes the same locks, and reads with relaxed
//! atomic loads. No access to a slot is ever concurrent with a write to it.
//!
//! Grey sums (spectral maps, `scene::GreySpectra`): a cell also has, in an array of their
//! own, one sum per kept spectrum (an emitter's, or that times a tinted material's
//! reflectance) of the multiples deposited by photons whose colour was a multiple of that
//! spectrum: one number written instead of one per band, the square going to the cell's
//! sum of squares as usual. Every read adds them times their spectra; `raw_mut` and
//! `values_mut` first fold them into the band sums, so the accumulators' array (states,
//! `map_accumulators`) keeps its layout.

pub mod direct;
mod grey;
mod layout;
mod photon;
pub(crate) mod readout;
pub mod regions;
pub mod stats;

pub use direct::{DirectAcc, DirectCells};
pub use grey::{most_grey, GreySpectra};
pub use layout::{LayerLayout, MapLayout, MAX_LIGHT_GROUPS};
pub use photon::{
    grey_index, shares, split_colour, BufferedHit, PhotonBuffer, PhotonOut, FULL, GREY, WEIGHTED,
};
pub(crate) use readout::NO_DATA_REL_ERROR;
pub use readout::{Neighbours, Readout};

use crate::error::{Error, ImapStatus, Result};
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::sync::Arc;

/// The accumulators.
#[derive(Debug)]
pub struct IMap {
    bands: usize,
    stride: usize,
    layout: LayerLayout,
    data: Vec<AtomicU64>,
    /// Per cell, the grey sums (`grey_spectra.count()` of them; none for most maps).
    grey: Vec<AtomicU64>,
    grey_spectra: GreySpectra,
    /// The light-sampling estimator's direct accumulators (one record per cell), shared
    /// with the calculating threads during a run; None for the photons-only estimator.
    direct: Option<Arc<DirectAcc>>,
}

/// A colour's band sum: of a few bands in order, of more in four interleaved partial sums
/// (one serial chain of 81 adds was the slowest part of a full-colour deposit, and this
/// form vectorises; at 1 or 3 bands the plain sum is cheaper). Every deposit path uses it,
/// so all schedulers write the same bits.
#[inline]
fn band_sum(colour: &[f32]) -> f64 {
    if colour.len() <= 8 {
        return colour.iter().fold(0.0, |s, &c| s + c as f64);
    }
    let mut s = [0.0f64; 4];
    let mut quads = colour.chunks_exact(4);
    for q in &mut quads {
        for (s, &c) in s.iter_mut().zip(q) {
            *s += c as f64;
        }
    }
    let rest: f64 = quads.remainder().iter().map(|&c| c as f64).sum();
    (s[0] + s[1]) + (s[2] + s[3]) + rest
}

impl IMap {
    /// Allocates a zeroed map of `slots` slots of `layout.per_slot()` cells each, reporting
    /// allocation failure instead of aborting. Cells are indexed by u32 in the run's
    /// buffers: a map of more cells is refused.
    #[cfg(test)]
    pub fn try_new(slots: usize, bands: usize, layout: LayerLayout) -> Result<Self> {
        Self::try_new_with(slots, bands, layout, false, GreySpectra::default())
    }

    /// `try_new`, with the direct accumulators of the light-sampling estimator when
    /// `direct`, and grey sums for `grey`'s spectra.
    pub fn try_new_with(
        slots: usize,
        bands: usize,
        layout: LayerLayout,
        direct: bool,
        grey: GreySpectra,
    ) -> Result<Self> {
        let stride = bands + 1;
        let cells = slots
            .checked_mul(layout.per_slot())
            .filter(|&c| c <= u32::MAX as usize)
            .ok_or_else(|| {
                Error::new(
                    ImapStatus::ImapErrOutOfMemory,
                    format!(
                        "the map would have {slots} slots × {} layers: more than {} cells",
                        layout.per_slot(),
                        u32::MAX
                    ),
                )
            })?;
        let len = cells
            .checked_mul(stride)
            .ok_or_else(|| Error::new(ImapStatus::ImapErrOutOfMemory, "map size overflows"))?;
        let mut data = Vec::new();
        data.try_reserve_exact(len).map_err(|_| {
            Error::new(
                ImapStatus::ImapErrOutOfMemory,
                format!("could not allocate the map ({} MiB)", (len * 8) >> 20),
            )
        })?;
        data.resize_with(len, || AtomicU64::new(0));
        let grey_len = cells * grey.count();
        let mut grey_sums = crate::error::try_with_capacity(grey_len, "the map's grey sums")?;
        grey_sums.resize_with(grey_len, || AtomicU64::new(0));
        let direct = if direct {
            Some(Arc::new(DirectAcc::try_new(cells, bands)?))
        } else {
            None
        };
        Ok(IMap {
            bands,
            stride,
            layout,
            data,
            grey: grey_sums,
            grey_spectra: grey,
            direct,
        })
    }

    pub fn bands(&self) -> usize {
        self.bands
    }

    pub fn layout(&self) -> LayerLayout {
        self.layout
    }

    /// Slots (vertex, side) of the map.
    pub fn slots(&self) -> usize {
        self.data.len() / (self.stride * self.layout.per_slot())
    }

    /// Bytes of the accumulators.
    pub fn bytes(&self) -> u64 {
        (self.data.len() + self.grey.len() + self.direct.as_ref().map_or(0, |d| d.len())) as u64 * 8
    }

    /// Grey sums per cell (K, `scene::GreySpectra`).
    #[inline]
    pub fn grey_count(&self) -> usize {
        self.grey_spectra.count()
    }

    /// Folds the grey sums into the band sums (exclusive access): the values read stay the
    /// same, the grey sums become 0.
    fn fold_grey(&mut self) {
        let k = self.grey_count();
        if k == 0 {
            return;
        }
        let (bands, stride) = (self.bands, self.stride);
        let IMap {
            data,
            grey,
            grey_spectra,
            ..
        } = self;
        for (cell, sums) in grey.chunks_exact_mut(k).enumerate() {
            for (g, sum) in sums.iter_mut().enumerate() {
                let a = f64::from_bits(*sum.get_mut());
                if a == 0.0 {
                    continue;
                }
                *sum.get_mut() = 0;
                let values = &mut data[cell * stride..cell * stride + bands];
                for (v, s) in values.iter_mut().zip(grey_spectra.spectrum(g)) {
                    let x = v.get_mut();
                    *x = (f64::from_bits(*x) + a * s).to_bits();
                }
            }
        }
    }

    /// The direct accumulators (light-sampling estimator), if the map has them.
    #[inline]
    pub fn direct(&self) -> Option<&Arc<DirectAcc>> {
        self.direct.as_ref()
    }

    /// The direct accumulators for exclusive access (no run in progress).
    pub(crate) fn direct_mut(&mut self) -> Option<&mut DirectAcc> {
        self.direct
            .as_mut()
            .map(|d| Arc::get_mut(d).expect("no run holds the direct accumulators"))
    }

    /// Whether sorting a portion by vertex before applying it pays: only when the map does
    /// not fit in cache (measured: up to 20 % cheaper accumulation on maps of 90+ MB, pure
    /// overhead on the Cornell box's 128 kB).
    pub fn worth_sorting(&self) -> bool {
        self.data.len() * 8 > 4 << 20
    }

    /// The values as plain f64s, for a thread that holds the map exclusively (the classic
    /// scheduler's accumulator): no atomics, so the band loop vectorises.
    #[inline]
    fn plain(&mut self) -> &mut [f64] {
        // SAFETY: AtomicU64 has the size and alignment of u64, and so of f64; the exclusive
        // borrow rules out any other access while the slice lives.
        unsafe {
            std::slice::from_raw_parts_mut(self.data.as_mut_ptr() as *mut f64, self.data.len())
        }
    }

    /// Every accumulator, in storage order (per cell: the band sums, then the sum of
    /// squares), for a caller that holds the map while no run writes it.
    /// The direct accumulators follow the photon ones.
    /// The band sums include the grey sums (as read).
    pub(crate) fn values(&self) -> impl Iterator<Item = f64> + '_ {
        let stride = self.stride;
        self.data
            .iter()
            .enumerate()
            .map(move |(i, a)| {
                let (cell, b) = (i / stride, i % stride);
                if b < self.bands {
                    self.cell_value(cell, b)
                } else {
                    f64::from_bits(a.load(Relaxed))
                }
            })
            .chain(self.direct.iter().flat_map(|d| d.values()))
    }

    /// Every accumulator, photon part then direct part, mutably (exclusive access; the
    /// grey sums folded into the band sums first).
    pub(crate) fn values_mut(&mut self) -> impl Iterator<Item = &mut f64> + '_ {
        self.fold_grey();
        let IMap { data, direct, .. } = self;
        // SAFETY: AtomicU64 has the layout of f64; `&mut self` makes the access exclusive.
        let photon =
            unsafe { std::slice::from_raw_parts_mut(data.as_mut_ptr() as *mut f64, data.len()) };
        let direct = direct.as_mut().map(|d| {
            Arc::get_mut(d)
                .expect("no run holds the direct accumulators")
                .raw_mut()
        });
        photon.iter_mut().chain(direct.into_iter().flatten())
    }

    /// Every accumulator as one mutable array (`values` order, the grey sums folded into
    /// the band sums; exclusive access).
    pub(crate) fn raw_mut(&mut self) -> &mut [f64] {
        self.fold_grey();
        self.plain()
    }

    /// Adds a deposit of barycentric weight `w` of a full-colour photon to cell `slot`
    /// (`LayerLayout::cell`; exclusive access). The `add_*` calls take cells.
    #[inline]
    pub fn add_colour(&mut self, slot: usize, w: f64, colour: &[f32]) {
        // SAFETY: `&mut self` makes the access exclusive.
        unsafe { self.add_colour_exclusive(slot, w, colour) }
    }

    /// Adds a deposit of weight `w` of a photon collapsed to `band` (exclusive access; the
    /// schedulers add whole hits, `add_hit`).
    #[cfg(test)]
    pub fn add_band(&mut self, slot: usize, w: f64, band: usize, value: f32) {
        // SAFETY: `&mut self` makes the access exclusive.
        unsafe { self.add_band_exclusive(slot, w, band, value) }
    }

    /// Adds a deposit of weight `w` of a photon whose colour is `a` times grey spectrum `g`
    /// (exclusive access; the schedulers add whole hits, `add_hit`).
    #[cfg(test)]
    pub fn add_grey(&mut self, slot: usize, w: f64, g: usize, a: f32) {
        // SAFETY: `&mut self` makes the access exclusive.
        unsafe { self.add_grey_exclusive(slot, w, g, a) }
    }

    /// `add_grey` under the rule of `add_colour_exclusive`.
    ///
    /// # Safety
    /// As `add_colour_exclusive`.
    #[inline]
    pub unsafe fn add_grey_exclusive(&self, slot: usize, w: f64, g: usize, a: f32) {
        let x = w * a as f64;
        let e = x * self.grey_spectra.means[g];
        // SAFETY: as in add_colour_exclusive; both indices are inside the cell's records.
        unsafe {
            Self::add_raw(&self.grey[slot * self.grey_count() + g], x);
            Self::add_raw(&self.data[slot * self.stride + self.bands], e * e);
        }
    }

    /// Adds a hit's deposits to its three cells (`BufferedHit::cells`; exclusive access):
    /// `band` is the hit's band code, `(u, v)` its barycentric coordinates and `colour` its
    /// colour as the photon buffer's arena holds it (the colour or the one value, then the
    /// three weights when the code says so).
    #[inline]
    pub fn add_hit(&mut self, cells: [usize; 3], band: u16, (u, v): (f32, f32), colour: &[f32]) {
        // SAFETY: `&mut self` makes the access exclusive.
        unsafe { self.add_hit_exclusive(cells, band, (u, v), colour) }
    }

    /// `add_hit` under the rule of `add_colour_exclusive`, for each of the three cells.
    ///
    /// # Safety
    /// As `add_colour_exclusive`, for every cell of `cells`.
    #[inline]
    pub unsafe fn add_hit_exclusive(
        &self,
        cells: [usize; 3],
        band: u16,
        (u, v): (f32, f32),
        colour: &[f32],
    ) {
        let grey = grey_index(band);
        let (values, weights) = split_colour(band, self.bands, colour);
        let w = shares(band, u, v, weights);
        for (cell, w) in cells.into_iter().zip(w) {
            // SAFETY: the caller's guarantee, cell by cell.
            unsafe {
                if let Some((g, _)) = grey {
                    self.add_grey_exclusive(cell, w, g, values[0]);
                } else if band >= WEIGHTED {
                    self.add_colour_exclusive(cell, w, values);
                } else {
                    self.add_band_exclusive(cell, w, band as usize, values[0]);
                }
            }
        }
    }

    /// Adds to a slot's sum of squares (a photon's cross terms; exclusive access).
    #[inline]
    pub fn add_square(&mut self, slot: usize, s2: f64) {
        // SAFETY: `&mut self` makes the access exclusive.
        unsafe { self.add_square_exclusive(slot, s2) }
    }

    /// `add_colour` through a shared map, with plain (vectorised) arithmetic.
    ///
    /// # Safety
    /// No other thread may access `slot` during the call: the caller holds the lock of the
    /// slot's vertex group and every ancestor of that group is done (`sched::groups`), and
    /// readers take the same locks.
    #[inline]
    pub unsafe fn add_colour_exclusive(&self, slot: usize, w: f64, colour: &[f32]) {
        let s = &self.data[slot * self.stride..(slot + 1) * self.stride];
        // SAFETY: AtomicU64 has the layout of f64; the caller guarantees exclusive access
        // to this slot's values for the duration of the call.
        let values = unsafe { std::slice::from_raw_parts_mut(s.as_ptr() as *mut f64, self.stride) };
        let (values, sq) = values.split_at_mut(self.bands);
        for (a, &c) in values.iter_mut().zip(colour) {
            *a += w * c as f64;
        }
        // The photon's scalar energy is its band mean: this deposit's share of the photon's
        // squared contribution is (w·energy)² (cross terms: `PhotonSquares`).
        let x = w * band_sum(colour) / self.bands as f64;
        sq[0] += x * x;
    }

    /// `add_band` under the rule of `add_colour_exclusive`.
    ///
    /// # Safety
    /// As `add_colour_exclusive`.
    #[inline]
    pub unsafe fn add_band_exclusive(&self, slot: usize, w: f64, band: usize, value: f32) {
        let base = slot * self.stride;
        // SAFETY: as in add_colour_exclusive; both indices are inside the slot.
        unsafe {
            Self::add_raw(&self.data[base + band], w * value as f64);
            // A collapsed photon's energy is its one band's value over the band count.
            let x = w * value as f64 / self.bands as f64;
            Self::add_raw(&self.data[base + self.bands], x * x);
        }
    }

    /// `add_square` under the rule of `add_colour_exclusive`.
    ///
    /// # Safety
    /// As `add_colour_exclusive`.
    #[inline]
    pub unsafe fn add_square_exclusive(&self, slot: usize, s2: f64) {
        // SAFETY: as in add_colour_exclusive; the index is inside the slot.
        unsafe { Self::add_raw(&self.data[slot * self.stride + self.bands], s2) };
    }

    /// Asks the processor to fetch cell `cell`'s values into its cache (accumulation walks
    /// a portion whose cells are known ahead: a spectral cell is many cache lines, read
    /// from anywhere in a map larger than the cache).
    #[inline]
    pub fn prefetch(&self, cell: usize) {
        #[cfg(target_arch = "x86_64")]
        {
            let start = cell * self.stride;
            if start + self.stride <= self.data.len() {
                let p = self.data[start..].as_ptr() as *const i8;
                let mut off = 0;
                while off < self.stride * 8 {
                    // SAFETY: a prefetch is a hint: it reads nothing and never faults; the
                    // addresses lie inside the map anyway.
                    unsafe {
                        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                            p.add(off),
                        )
                    };
                    off += 64;
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = cell;
    }

    /// `prefetch` for a grey deposit to kept spectrum `g`: the cell's sum of squares and its
    /// sum for `g` (a cell's grey sums may span more than one cache line).
    #[inline]
    pub fn prefetch_grey(&self, cell: usize, g: usize) {
        #[cfg(target_arch = "x86_64")]
        {
            let sq = cell * self.stride + self.bands;
            let g = cell * self.grey_count() + g;
            if sq < self.data.len() && g < self.grey.len() {
                // SAFETY: prefetches are hints that never fault; the addresses are inside
                // the arrays.
                unsafe {
                    use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
                    _mm_prefetch::<_MM_HINT_T0>(self.data[sq..].as_ptr() as *const i8);
                    _mm_prefetch::<_MM_HINT_T0>(self.grey[g..].as_ptr() as *const i8);
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (cell, g);
    }

    /// Adds to one value without atomics.
    ///
    /// # Safety
    /// No other thread accesses `a` during the call.
    #[inline]
    unsafe fn add_raw(a: &AtomicU64, x: f64) {
        let p = a.as_ptr();
        // SAFETY: the caller guarantees exclusive access; the pointer is valid and aligned.
        unsafe { *p = (f64::from_bits(*p) + x).to_bits() };
    }

    /// Accumulated band value (photon units) of a slot: the sum of its group layers.
    #[inline]
    pub fn value(&self, slot: usize, band: usize) -> f64 {
        if self.layout == LayerLayout::SINGLE {
            return self.cell_value(slot, band);
        }
        self.layout
            .cells(slot, None)
            .map(|c| self.cell_value(c, band))
            .sum()
    }

    /// (Σ deposits of the scalar energy, Σ squares) of a slot: the sums of its group layers.
    #[inline]
    pub fn scalar(&self, slot: usize) -> (f64, f64) {
        if self.layout == LayerLayout::SINGLE {
            return self.cell_scalar(slot);
        }
        self.layout
            .cells(slot, None)
            .map(|c| self.cell_scalar(c))
            .fold((0.0, 0.0), |(s, q), (a, b)| (s + a, q + b))
    }

    /// The value of one layer of a slot (`layout().groups` for the direct layer).
    #[inline]
    pub fn layer_value(&self, slot: usize, layer: u8, band: usize) -> f64 {
        self.cell_value(self.layout.cell(slot, layer), band)
    }

    /// `scalar` of one layer of a slot.
    #[inline]
    pub fn layer_scalar(&self, slot: usize, layer: u8) -> (f64, f64) {
        self.cell_scalar(self.layout.cell(slot, layer))
    }

    #[inline]
    fn cell_value(&self, cell: usize, band: usize) -> f64 {
        let v = f64::from_bits(self.data[cell * self.stride + band].load(Relaxed));
        let k = self.grey_count();
        if k == 0 {
            return v;
        }
        let sums = &self.grey[cell * k..(cell + 1) * k];
        v + sums
            .iter()
            .enumerate()
            .map(|(g, a)| f64::from_bits(a.load(Relaxed)) * self.grey_spectra.spectrum(g)[band])
            .sum::<f64>()
    }

    #[inline]
    fn cell_scalar(&self, cell: usize) -> (f64, f64) {
        let s = &self.data[cell * self.stride..(cell + 1) * self.stride];
        let get = |a: &AtomicU64| f64::from_bits(a.load(Relaxed));
        let sum: f64 = s[..self.bands].iter().map(get).sum();
        let k = self.grey_count();
        let grey: f64 = self.grey[cell * k..(cell + 1) * k]
            .iter()
            .zip(&self.grey_spectra.means)
            .map(|(a, m)| get(a) * m)
            .sum();
        (sum / self.bands as f64 + grey, get(&s[self.bands]))
    }

    pub fn clear(&mut self) {
        self.data.iter_mut().for_each(|x| *x.get_mut() = 0);
        self.grey.iter_mut().for_each(|x| *x.get_mut() = 0);
        if let Some(d) = self.direct_mut() {
            d.clear();
        }
    }
}

/// One photon's deposits along its path, for the cross terms of its squared total
/// contribution per slot. A photon with fewer than two deposits has none (a triangle's three
/// vertices are distinct), so most paths in open scenes cost one push per deposit.
#[derive(Debug, Default)]
pub struct PhotonSquares {
    deposits: Vec<([u32; 3], [f64; 3])>,
    pairs: Vec<(u32, f64)>,
}

impl PhotonSquares {
    /// Records a deposit of weights `w` (barycentric weight times the photon's energy) on
    /// the three slots `slots`.
    #[inline]
    pub fn add(&mut self, slots: [usize; 3], w: [f64; 3]) {
        self.deposits.push((slots.map(|s| s as u32), w));
    }

    /// Hands out (slot, (Σ w)² − Σ w²) for every slot the photon reached more than once,
    /// and forgets the photon.
    pub fn drain_cross_terms(&mut self, mut out: impl FnMut(usize, f64)) {
        if self.deposits.len() < 2 {
            self.deposits.clear();
            return;
        }
        self.pairs.clear();
        for (slots, w) in self.deposits.drain(..) {
            self.pairs.extend(slots.into_iter().zip(w));
        }
        if self.pairs.len() <= 48 {
            // A few deposits (the usual case): a quadratic scan beats a sort.
            let n = self.pairs.len();
            for i in 0..n {
                let slot = self.pairs[i].0;
                if slot == u32::MAX {
                    continue;
                }
                let (mut sum, mut squares, mut count) =
                    (self.pairs[i].1, self.pairs[i].1 * self.pairs[i].1, 1);
                for j in i + 1..n {
                    if self.pairs[j].0 == slot {
                        let w = self.pairs[j].1;
                        sum += w;
                        squares += w * w;
                        count += 1;
                        self.pairs[j].0 = u32::MAX;
                    }
                }
                if count > 1 {
                    out(slot as usize, sum * sum - squares);
                }
            }
            return;
        }
        self.pairs.sort_unstable_by_key(|p| p.0);
        let mut i = 0;
        while i < self.pairs.len() {
            let (slot, start) = (self.pairs[i].0, i);
            let (mut sum, mut squares) = (0.0, 0.0);
            while i < self.pairs.len() && self.pairs[i].0 == slot {
                let w = self.pairs[i].1;
                sum += w;
                squares += w * w;
                i += 1;
            }
            if i - start > 1 {
                out(slot as usize, sum * sum - squares);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::rng::PhotonRng;

    #[test]
    fn band_sums_are_the_sum_of_the_bands() {
        let mut rng = PhotonRng::new(1, 2);
        for n in [1, 3, 8, 9, 41, 81, 83] {
            let c: Vec<f32> = (0..n).map(|_| rng.uniform() as f32).collect();
            let serial = c.iter().fold(0.0, |s, &x| s + x as f64);
            let got = band_sum(&c);
            if n <= 8 {
                // Few bands: in order, as every map summed them before (the same bits).
                assert_eq!(got.to_bits(), serial.to_bits(), "{n} bands");
            } else {
                assert!(
                    (got - serial).abs() <= 1e-14 * serial,
                    "{n} bands: {got} vs {serial}"
                );
            }
        }
        assert_eq!(band_sum(&[]), 0.0);
    }

    #[test]
    fn grey_deposits_read_as_their_full_colours_and_fold_into_the_band_sums() {
        let nb = 12;
        // Scaled to a largest value of 1, as `GreySpectra::new` keeps them.
        let shapes: Vec<Vec<f64>> = vec![
            (0..nb)
                .map(|b| (0.2 + b as f64) / (0.2 + (nb - 1) as f64))
                .collect(),
            (0..nb).map(|b| 1.0 - 0.05 * b as f64).collect(),
        ];
        let grey = GreySpectra::of_shapes(nb, &shapes);
        let layout = LayerLayout::SINGLE;
        let mut full = IMap::try_new_with(3, nb, layout, false, GreySpectra::default()).unwrap();
        let mut kept = IMap::try_new_with(3, nb, layout, false, grey.clone()).unwrap();
        assert_eq!(kept.grey_count(), 2);
        let mut rng = PhotonRng::new(5, 0);
        for _ in 0..1000 {
            let slot = (rng.uniform() * 3.0) as usize;
            let g = (rng.uniform() * 2.0) as usize;
            let a = (0.5 + rng.uniform()) as f32;
            let w = rng.uniform();
            let exact: Vec<f64> = grey.spectrum(g).iter().map(|s| a as f64 * s).collect();
            assert_eq!(grey.multiple(g, &exact), Some(a as f64));
            let colour: Vec<f32> = exact.iter().map(|&c| c as f32).collect();
            full.add_colour(slot, w, &colour);
            kept.add_grey(slot, w, g, a);
        }
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-6 * y.abs().max(1e-300);
        let values = |m: &IMap| {
            (0..3)
                .flat_map(|s| (0..nb).map(move |b| (s, b)))
                .map(|(s, b)| m.value(s, b))
                .collect::<Vec<_>>()
        };
        for slot in 0..3 {
            for b in 0..nb {
                assert!(
                    close(kept.value(slot, b), full.value(slot, b)),
                    "slot {slot} band {b}"
                );
            }
            let (x, y) = (kept.scalar(slot), full.scalar(slot));
            assert!(
                close(x.0, y.0) && close(x.1, y.1),
                "slot {slot}: {x:?} vs {y:?}"
            );
        }
        // The array read out (states) already holds the grey sums in the band sums.
        for (x, y) in kept.values().zip(full.values()) {
            assert!(close(x, y), "{x} vs {y}");
        }
        let before = values(&kept);
        let raw = kept.raw_mut().to_vec();
        assert_eq!(
            raw.len(),
            full.data.len(),
            "the accumulators' layout is the plain one"
        );
        for (x, y) in raw.iter().zip(full.values()) {
            assert!(close(*x, y), "{x} vs {y}");
        }
        assert!(kept.grey.iter_mut().all(|g| *g.get_mut() == 0));
        for (x, y) in values(&kept).iter().zip(&before) {
            assert!(close(*x, *y));
        }
        // A colour off the spectrum by more than rounding is not a multiple.
        let mut off: Vec<f64> = grey.spectrum(0).to_vec();
        off[3] *= 1.001;
        assert!(grey.multiple(0, &off).is_none());
        off[3] = f64::NAN;
        assert!(grey.multiple(0, &off).is_none());
    }

    /// Neumaier's compensated sum: the reference the plain map sum is checked against.
    struct Compensated {
        sum: f64,
        c: f64,
    }

    impl Compensated {
        #[inline]
        fn add(&mut self, x: f64) {
            let t = self.sum + x;
            let (big, small) = if self.sum.abs() >= x.abs() {
                (self.sum, x)
            } else {
                (x, self.sum)
            };
            self.c += (big - t) + small;
            self.sum = t;
        }
    }

    /// Accumulates `n` deposits the way the tracer makes them — barycentric weight
    /// 1 − u − v from Embree's f32 (u, v) times an f32 colour value — into one map slot
    /// with the map's own plain f64 additions, next to a compensated sum of the same
    /// values. Returns the relative difference of the value and of the sum of squares.
    fn plain_vs_compensated(n: u64, seed: u64, colours: &[f32]) -> (f64, f64) {
        assert!(colours.len().is_power_of_two());
        let mask = colours.len() as u64 - 1;
        let mut map = IMap::try_new(1, 1, LayerLayout::SINGLE).unwrap();
        let (mut sum, mut sq) = (
            Compensated { sum: 0.0, c: 0.0 },
            Compensated { sum: 0.0, c: 0.0 },
        );
        let mut rng = PhotonRng::new(seed, 0);
        for _ in 0..n {
            let r = rng.next_u64();
            let u = (r >> 40) as f32 * (1.0 / (1u64 << 24) as f32);
            let v = ((r >> 16) & 0xff_ffff) as f32 * (1.0 / (1u64 << 24) as f32);
            // Fold (u, v) into the triangle without a branch: |1 − u − v|.
            let w = (1.0 - u as f64 - v as f64).abs();
            let c = colours[(r & mask) as usize];
            map.add_band(0, w, 0, c);
            let x = w * c as f64;
            sum.add(x);
            sq.add(x * x);
        }
        let (value, squares) = (map.value(0, 0), map.scalar(0).1);
        let exact = (sum.sum + sum.c, sq.sum + sq.c);
        (
            (value - exact.0).abs() / exact.0,
            (squares - exact.1).abs() / exact.1,
        )
    }

    #[test]
    fn billions_of_plain_f64_deposits_stay_within_1e9_of_a_compensated_sum() {
        // Rounding errors of continuous deposits have mean 0, so they add up like a random
        // walk: ~ε·√n relative (1e-11 at n = 1e10), far below 1e-9. The worst case of plain
        // summation, n·ε/2 ≈ 6e-7 at 1e10, needs every rounding to go the same way, which
        // only a constant deposit value produces (shown at the end) and the tracer never
        // makes: its deposits carry continuous barycentric weights. So the map keeps plain
        // sums, which cost nothing, instead of doubling its memory for compensation terms.
        //
        // Measured at 1e10 (this test with IMAP_PRECISION_DEPOSITS=10000000000, 50 s on two
        // cores; the test command runs 1e9, whose error bound is the same): values 1e-12
        // (grey) and 1.6e-12 (spread colours).
        // The sum of squares, whose terms spread over twelve decades, drifts further (5e-11
        // at 1e9, 1.5e-9 at 1e10 with spread colours); it only feeds the error estimate,
        // whose own statistical uncertainty at that count is ~1/√n ≥ 1e-5, so it is held
        // to 1e-6.
        let n: u64 = std::env::var("IMAP_PRECISION_DEPOSITS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(1_000_000_000);
        let half = n / 2;
        // Two slots on two threads, n deposits each: a white photon's value, and colour
        // values spread over three decades as reweighted spectral photons carry.
        let grey = std::thread::spawn(move || plain_vs_compensated(n, 1, &[3.0]));
        let table: Vec<f32> = (0..1 << 16)
            .map(|i| 10f32.powf(i as f32 / 21845.0 - 1.5))
            .collect();
        let spread = plain_vs_compensated(n, 2, &table);
        let grey = grey.join().unwrap();
        eprintln!(
            "{n} deposits: relative error of plain f64 sums vs compensated: grey value {:.1e}, squares {:.1e}; spread colours value {:.1e}, squares {:.1e}",
            grey.0, grey.1, spread.0, spread.1
        );
        for e in [grey.0, spread.0] {
            assert!(e < 1e-9, "irradiance sum: plain summation error {e}");
        }
        for e in [grey.1, spread.1] {
            assert!(e < 1e-6, "sum of squares: plain summation error {e}");
        }
        // The contrast: a constant deposit rounds the same way in every binade.
        let mut plain = 0.0f64;
        let mut comp = Compensated { sum: 0.0, c: 0.0 };
        for _ in 0..half.min(100_000_000) {
            plain += 0.1;
            comp.add(0.1);
        }
        let drift = (plain - (comp.sum + comp.c)).abs() / (comp.sum + comp.c);
        eprintln!(
            "{} constant deposits of 0.1: relative drift {drift:.1e}",
            half.min(100_000_000)
        );
    }
}

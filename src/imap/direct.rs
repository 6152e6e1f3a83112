//! The direct-light accumulators of the light-sampling estimator (`transport::direct`).
//!
//! Per map cell (`LayerLayout::cell`): the sums over direct passes of the pass's estimate
//! of the direct flux the vertex's hat support receives, per band (W), the sum of the
//! squares of each pass's band mean, the number of passes, and (in a slot's first cell)
//! the sum of the squares of the pass's total over the slot's group layers: one light's
//! sample lights one group, so the groups' estimates of a pass are correlated and the
//! combined error needs the square of their sum. Passes of one vertex are
//! independent (each has its own scrambled point set), so the direct estimate is the mean
//! over passes and its variance the sample variance over passes divided by their count:
//! exactly what the map needs to add the direct part to the photons' indirect part
//! (`Readout`).
//!
//! Passes are written by the calculating threads directly (they are a few per vertex per
//! pass, against hundreds of photon deposits), with atomic additions: two passes of one
//! vertex may run at once on two threads. The array is separate from the photon
//! accumulators so the classic scheduler's exclusive borrow of those never covers it.

use super::layout::LayerLayout;
use crate::error::{Error, ImapStatus, Result};
use crate::transport::direct::DirectSink;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

/// The direct accumulators of every cell of a map.
#[derive(Debug)]
pub struct DirectAcc {
    bands: usize,
    data: Box<[AtomicU64]>,
}

impl DirectAcc {
    /// Zeroed accumulators for `cells` cells of `bands` bands (allocation failure reported).
    pub fn try_new(cells: usize, bands: usize) -> Result<Self> {
        let len = cells.checked_mul(bands + 3).ok_or_else(|| {
            Error::new(ImapStatus::ImapErrOutOfMemory, "direct map size overflows")
        })?;
        let mut data = Vec::new();
        data.try_reserve_exact(len).map_err(|_| {
            Error::new(
                ImapStatus::ImapErrOutOfMemory,
                format!(
                    "could not allocate the direct-light map ({} MiB)",
                    (len * 8) >> 20
                ),
            )
        })?;
        data.resize_with(len, || AtomicU64::new(0));
        Ok(DirectAcc {
            bands,
            data: data.into_boxed_slice(),
        })
    }

    /// Values per cell: the band sums, the sum of squares, the pass count, the sum of
    /// squares of the slot's total.
    #[inline]
    pub fn stride(&self) -> usize {
        self.bands + 3
    }

    pub fn len(&self) -> usize {
        self.data.len()
    }

    #[inline]
    fn add(a: &AtomicU64, x: f64) {
        let mut cur = a.load(Relaxed);
        loop {
            let new = (f64::from_bits(cur) + x).to_bits();
            match a.compare_exchange_weak(cur, new, Relaxed, Relaxed) {
                Ok(_) => return,
                Err(v) => cur = v,
            }
        }
    }

    /// Adds one pass's estimate `values` (W per band) of cell `cell`.
    #[inline]
    pub fn add_pass(&self, cell: usize, values: &[f64]) {
        let s = &self.data[cell * self.stride()..(cell + 1) * self.stride()];
        let mut mean = 0.0;
        for (a, &x) in s.iter().zip(values) {
            if x != 0.0 {
                Self::add(a, x);
            }
            mean += x;
        }
        mean /= self.bands as f64;
        if mean != 0.0 {
            Self::add(&s[self.bands], mean * mean);
        }
        Self::add(&s[self.bands + 1], 1.0);
    }

    #[inline]
    fn get(&self, i: usize) -> f64 {
        f64::from_bits(self.data[i].load(Relaxed))
    }

    /// The mean over passes of cell `cell`'s band `band` (W), and the pass count.
    #[inline]
    pub fn band_mean(&self, cell: usize, band: usize) -> (f64, f64) {
        let base = cell * self.stride();
        let n = self.get(base + self.bands + 1);
        if n > 0.0 {
            (self.get(base + band) / n, n)
        } else {
            (0.0, 0.0)
        }
    }

    /// Adds the square of one pass's total over the slot's group layers to its first cell.
    #[inline]
    pub fn add_total_square(&self, first_cell: usize, x: f64) {
        if x != 0.0 {
            Self::add(&self.data[first_cell * self.stride() + self.bands + 2], x);
        }
    }

    /// The band mean of the estimate (W) of the sum of cells `cells` (one cell, or a slot's
    /// group layers, whose first holds the squares of their total: `total`), its variance
    /// (W²) and the pass count. With fewer than two passes the variance is unknown and
    /// taken as the square of the estimate (a relative error of 100 %).
    #[inline]
    pub fn scalar_of(&self, cells: std::ops::Range<usize>, total: bool) -> (f64, f64, f64) {
        let first = cells.start * self.stride();
        let n = self.get(first + self.bands + 1);
        if n <= 0.0 {
            return (0.0, 0.0, 0.0);
        }
        let s: f64 = cells
            .map(|c| {
                let base = c * self.stride();
                (0..self.bands).map(|b| self.get(base + b)).sum::<f64>()
            })
            .sum::<f64>()
            / self.bands as f64;
        let q = self.get(first + self.bands + usize::from(total) * 2);
        let mean = s / n;
        if n < 2.0 {
            return (mean, mean * mean, n);
        }
        // The sample variance of the passes over n: the variance of their mean.
        let var = ((q - s * s / n) / (n - 1.0)).max(0.0) / n;
        (mean, var, n)
    }

    /// Every value, in storage order (exclusive readers).
    pub(crate) fn values(&self) -> impl Iterator<Item = f64> + '_ {
        self.data.iter().map(|a| f64::from_bits(a.load(Relaxed)))
    }

    /// Every value as one mutable array.
    pub(crate) fn raw_mut(&mut self) -> &mut [f64] {
        // SAFETY: AtomicU64 has the size and alignment of f64; the exclusive borrow rules
        // out any other access while the slice lives.
        unsafe {
            std::slice::from_raw_parts_mut(self.data.as_mut_ptr() as *mut f64, self.data.len())
        }
    }

    pub fn clear(&mut self) {
        self.data.iter_mut().for_each(|x| *x.get_mut() = 0);
    }
}

/// The map's direct accumulators with its layer layout: what the light-sampling passes
/// write to (`transport::direct::DirectSink`).
pub struct DirectCells<'a> {
    pub acc: &'a DirectAcc,
    pub layers: LayerLayout,
}

impl DirectSink for DirectCells<'_> {
    #[inline]
    fn groups(&self) -> usize {
        self.layers.groups as usize
    }

    #[inline]
    fn direct_layer(&self) -> Option<u8> {
        self.layers.direct_layer()
    }

    #[inline]
    fn add_pass(&self, slot: usize, layer: u8, values: &[f64]) {
        self.acc.add_pass(self.layers.cell(slot, layer), values);
    }

    #[inline]
    fn add_total_square(&self, slot: usize, x: f64) {
        self.acc.add_total_square(self.layers.cell(slot, 0), x);
    }
}

//! The illumination map: per (vertex, recorded side) slot, one f64 accumulator per band
//! plus the sum over photons of the square of each photon's scalar contribution to the
//! slot (the paper's fourth value) for the Monte Carlo error. A photon's contributions to
//! one slot along its whole path are summed before squaring (`PhotonSquares`): in a closed,
//! highly reflective scene a photon returns to a vertex many times, and squaring single
//! deposits would underestimate the variance (at ρ = 0.99 it even gave 0 for some vertices).
//! Slots exist only for recording meshes and only for their recorded sides; a slot's
//! values are contiguous so one deposit touches one cache line or a few.
//!
//! The values are f64 bit patterns in `AtomicU64`s (same layout as f64). Writers use plain
//! f64 arithmetic: the classic accumulator through its exclusive `&mut`, the dynamic
//! scheduler's writers through `*_exclusive` while holding their vertex group's lock; the
//! progress readout during a dynamic run takes the same locks, and reads with relaxed
//! atomic loads. No access to a slot is ever concurrent with a write to it.

mod readout;

pub use readout::{Readout, NO_DATA_REL_ERROR};

use crate::error::{Error, ImapStatus, Result};
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

/// The accumulators.
#[derive(Debug)]
pub struct IMap {
    bands: usize,
    stride: usize,
    data: Vec<AtomicU64>,
}

impl IMap {
    /// Allocates a zeroed map, reporting allocation failure instead of aborting.
    pub fn try_new(slots: usize, bands: usize) -> Result<Self> {
        let stride = bands + 1;
        let len = slots
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
        Ok(IMap {
            bands,
            stride,
            data,
        })
    }

    pub fn bands(&self) -> usize {
        self.bands
    }

    pub fn slots(&self) -> usize {
        self.data.len() / self.stride
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

    /// Adds a deposit of barycentric weight `w` of a full-colour photon (exclusive access).
    #[inline]
    pub fn add_colour(&mut self, slot: usize, w: f64, colour: &[f32]) {
        let (bands, stride) = (self.bands, self.stride);
        let values = &mut self.plain()[slot * stride..slot * stride + bands];
        for (a, &c) in values.iter_mut().zip(colour) {
            *a += w * c as f64;
        }
    }

    /// Adds a deposit of weight `w` of a photon collapsed to `band` (exclusive access).
    #[inline]
    pub fn add_band(&mut self, slot: usize, w: f64, band: usize, value: f32) {
        let at = slot * self.stride + band;
        self.plain()[at] += w * value as f64;
    }

    /// Adds one photon's squared scalar contribution to a slot (exclusive access).
    #[inline]
    pub fn add_square(&mut self, slot: usize, s2: f64) {
        let at = slot * self.stride + self.bands;
        self.plain()[at] += s2;
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
        for (a, &c) in values[..self.bands].iter_mut().zip(colour) {
            *a += w * c as f64;
        }
    }

    /// `add_band` under the rule of `add_colour_exclusive`.
    ///
    /// # Safety
    /// As `add_colour_exclusive`.
    #[inline]
    pub unsafe fn add_band_exclusive(&self, slot: usize, w: f64, band: usize, value: f32) {
        // SAFETY: as in add_colour_exclusive; the index is inside the slot.
        unsafe { Self::add_raw(&self.data[slot * self.stride + band], w * value as f64) };
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

    /// Accumulated band value (photon units) of a slot.
    #[inline]
    pub fn value(&self, slot: usize, band: usize) -> f64 {
        f64::from_bits(self.data[slot * self.stride + band].load(Relaxed))
    }

    /// (Σ deposits of the scalar energy, Σ squares) of a slot.
    #[inline]
    pub fn scalar(&self, slot: usize) -> (f64, f64) {
        let s = &self.data[slot * self.stride..(slot + 1) * self.stride];
        let get = |a: &AtomicU64| f64::from_bits(a.load(Relaxed));
        let sum: f64 = s[..self.bands].iter().map(get).sum();
        (sum / self.bands as f64, get(&s[self.bands]))
    }

    pub fn clear(&mut self) {
        self.data.iter_mut().for_each(|x| *x.get_mut() = 0);
    }
}

/// One photon's scalar contributions per slot, summed along its path and squared at its end.
#[derive(Debug, Default)]
pub struct PhotonSquares {
    pairs: Vec<(u32, f64)>,
}

impl PhotonSquares {
    /// Records weight `w` of the photon on `slot`.
    #[inline]
    pub fn add(&mut self, slot: usize, w: f64) {
        self.pairs.push((slot as u32, w));
    }

    /// Hands out (slot, (Σ w)²) for every slot the photon reached, and forgets them.
    pub fn drain(&mut self, mut out: impl FnMut(usize, f64)) {
        self.pairs.sort_unstable_by_key(|p| p.0);
        let mut i = 0;
        while i < self.pairs.len() {
            let slot = self.pairs[i].0;
            let mut sum = 0.0;
            while i < self.pairs.len() && self.pairs[i].0 == slot {
                sum += self.pairs[i].1;
                i += 1;
            }
            out(slot as usize, sum * sum);
        }
        self.pairs.clear();
    }
}

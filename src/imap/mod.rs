//! The illumination map: per (vertex, recorded side) slot, one f64 accumulator per band
//! plus the sum of squared scalar deposits (the paper's fourth value) for the Monte Carlo
//! error. Slots exist only for recording meshes and only for their recorded sides; a slot's
//! values are contiguous so one deposit touches one cache line or a few.
//!
//! The values are f64 bit patterns in `AtomicU64`s, updated with a relaxed load and a
//! relaxed store (plain moves on x86, no locked instruction). Schedulers guarantee one
//! writer per slot at a time (the accumulating thread, or a vertex group's processing
//! thread); the atomics make concurrent *reading* (progress reports during a run) and
//! sharing the map between processing threads safe Rust, and turn a broken single-writer
//! invariant into lost updates that the determinism tests see, instead of undefined
//! behaviour.

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

/// Adds `x` to the f64 in `a`; the caller is the slot's only writer.
#[inline(always)]
fn add(a: &AtomicU64, x: f64) {
    a.store((f64::from_bits(a.load(Relaxed)) + x).to_bits(), Relaxed);
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
        let s = &mut self.plain()[slot * stride..(slot + 1) * stride];
        let (values, sq) = s.split_at_mut(bands);
        for (a, &c) in values.iter_mut().zip(colour) {
            *a += w * c as f64;
        }
        // The photon's scalar energy is its band mean, 1 by construction: the squared
        // scalar deposit is w².
        sq[0] += w * w;
    }

    /// Adds a deposit of weight `w` of a photon collapsed to `band` (exclusive access).
    #[inline]
    pub fn add_band(&mut self, slot: usize, w: f64, band: usize, value: f32) {
        let (bands, base) = (self.bands, slot * self.stride);
        let m = self.plain();
        m[base + band] += w * value as f64;
        m[base + bands] += w * w;
    }

    /// `add_colour` through a shared map: the caller must be the slot's only writer (a
    /// vertex group's processing thread); readers may run concurrently.
    #[inline]
    pub fn add_colour_shared(&self, slot: usize, w: f64, colour: &[f32]) {
        let s = &self.data[slot * self.stride..(slot + 1) * self.stride];
        let (values, sq) = s.split_at(self.bands);
        for (a, &c) in values.iter().zip(colour) {
            add(a, w * c as f64);
        }
        add(&sq[0], w * w);
    }

    /// `add_band` through a shared map, under the same rule as `add_colour_shared`.
    #[inline]
    pub fn add_band_shared(&self, slot: usize, w: f64, band: usize, value: f32) {
        let base = slot * self.stride;
        add(&self.data[base + band], w * value as f64);
        add(&self.data[base + self.bands], w * w);
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

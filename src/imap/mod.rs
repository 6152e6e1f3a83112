//! The illumination map: per (vertex, recorded side) slot, one f64 accumulator per band
//! plus the sum of squared scalar deposits (the paper's fourth value) for the Monte Carlo
//! error. Slots exist only for recording meshes and only for their recorded sides; a slot's
//! values are contiguous so one deposit touches one cache line or a few.

mod readout;

pub use readout::{Readout, NO_DATA_REL_ERROR};

use crate::error::{Error, ImapStatus, Result};

/// The accumulators.
#[derive(Debug)]
pub struct IMap {
    bands: usize,
    stride: usize,
    data: Vec<f64>,
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
        data.resize(len, 0.0);
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

    /// Adds a deposit of barycentric weight `w` of a full-colour photon.
    #[inline]
    pub fn add_colour(&mut self, slot: usize, w: f64, colour: &[f32]) {
        let s = &mut self.data[slot * self.stride..(slot + 1) * self.stride];
        let (values, sq) = s.split_at_mut(self.bands);
        for (a, &c) in values.iter_mut().zip(colour) {
            *a += w * c as f64;
        }
        // The photon's scalar energy is its band mean, 1 by construction: the squared
        // scalar deposit is w².
        sq[0] += w * w;
    }

    /// Adds a deposit of weight `w` of a photon collapsed to `band` with value `value`.
    #[inline]
    pub fn add_band(&mut self, slot: usize, w: f64, band: usize, value: f32) {
        let base = slot * self.stride;
        self.data[base + band] += w * value as f64;
        self.data[base + self.bands] += w * w;
    }

    /// Accumulated band value (photon units) of a slot.
    #[inline]
    pub fn value(&self, slot: usize, band: usize) -> f64 {
        self.data[slot * self.stride + band]
    }

    /// (Σ deposits of the scalar energy, Σ squares) of a slot.
    #[inline]
    pub fn scalar(&self, slot: usize) -> (f64, f64) {
        let s = &self.data[slot * self.stride..(slot + 1) * self.stride];
        let sum: f64 = s[..self.bands].iter().sum();
        (sum / self.bands as f64, s[self.bands])
    }

    pub fn clear(&mut self) {
        self.data.iter_mut().for_each(|x| *x = 0.0);
    }
}

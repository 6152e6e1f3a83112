//! Regions: each recorded side of a recording mesh, and each part (triangles of one
//! material) of a mesh with several. For every photon the tracer sums what it brought to
//! each region it reached (per band, over all its deposits there), and the run keeps, per
//! region, the sums of those photon totals and of their squares: the region's incident flux
//! and the Monte Carlo variance of it, exactly as for one vertex (the correlation between a
//! region's vertices, which a sum of vertex variances would miss, is inside each photon's
//! total).
//!
//! Threads keep their own tallies and add them to a per-thread slot once per batch; the
//! monitor reads the slots (one uncontended lock each) for a stop criterion on a region.

use crate::scene::PreparedMesh;
use std::sync::{Mutex, MutexGuard};

/// Which region a deposit belongs to.
#[derive(Clone, Debug, Default)]
pub struct RegionLayout {
    /// Tallies in all: the regions, then, when the map keeps layers, each region's layers
    /// (`layered`).
    pub count: usize,
    /// The regions (mesh sides and parts).
    pub regions: usize,
    /// Map layers each region is also tallied in (`LayerLayout::per_slot` when layers are
    /// kept, else 0): a light group's or the direct part's Eavg, Emin and U0 get the exact
    /// errors the whole region's do.
    pub layers: usize,
    /// Per mesh: its first region (recording meshes only), its parts' material ids (sorted;
    /// empty for a mesh of one material), and the regions per side (1 + parts).
    pub meshes: Vec<Option<MeshRegions>>,
}

#[derive(Clone, Debug)]
pub struct MeshRegions {
    pub base: u32,
    pub parts: Vec<u32>,
}

impl MeshRegions {
    fn per_side(&self) -> u32 {
        1 + self.parts.len() as u32
    }

    /// The region of the whole mesh on `side`.
    #[inline]
    pub fn mesh_region(&self, side: usize) -> u32 {
        self.base + side as u32 * self.per_side()
    }

    /// The region of the part of material `part` on `side`, or of the whole side (for None,
    /// or a mesh of one material).
    #[inline]
    pub fn region(&self, side: usize, part: Option<u32>) -> u32 {
        part.and_then(|p| self.part_region(side, p))
            .unwrap_or_else(|| self.mesh_region(side))
    }

    /// The region of the part of material `material` on `side`, if the mesh has parts.
    #[inline]
    pub fn part_region(&self, side: usize, material: u32) -> Option<u32> {
        let i = self.parts.binary_search(&material).ok()?;
        Some(self.mesh_region(side) + 1 + i as u32)
    }
}

impl RegionLayout {
    /// The tally of region `r` in map layer `layer` (with layers kept).
    #[inline]
    pub fn layered(&self, r: u32, layer: u8) -> u32 {
        (self.regions + r as usize * self.layers + layer as usize) as u32
    }

    /// Regions of `meshes`, tallied also per layer of `layers` when it keeps more than the
    /// combined values.
    pub fn new(meshes: &[PreparedMesh], layers: super::LayerLayout) -> Self {
        let mut count = 0u32;
        let meshes = meshes
            .iter()
            .map(|m| {
                m.slot_base?;
                if !m.tally {
                    return None;
                }
                let mut parts = m.materials.clone();
                parts.sort_unstable();
                parts.dedup();
                if parts.len() == 1 {
                    parts.clear();
                }
                let r = MeshRegions { base: count, parts };
                count += r.per_side() * m.sides() as u32;
                Some(r)
            })
            .collect();
        let regions = count as usize;
        let layers = if layers.per_slot() > 1 {
            layers.per_slot()
        } else {
            0
        };
        RegionLayout {
            count: regions * (1 + layers),
            regions,
            layers,
            meshes,
        }
    }
}

/// Per region: Σ over photons of the photon's total per band (photon units), of its square
/// per band, and of the square of its luminous value.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RegionTally {
    pub bands: usize,
    pub sum: Vec<f64>,
    pub sq: Vec<f64>,
    pub sq_lum: Vec<f64>,
}

impl RegionTally {
    pub fn new(regions: usize, bands: usize) -> Self {
        RegionTally {
            bands,
            sum: vec![0.0; regions * bands],
            sq: vec![0.0; regions * bands],
            sq_lum: vec![0.0; regions],
        }
    }

    pub fn regions(&self) -> usize {
        self.sq_lum.len()
    }

    /// Adds one photon's totals: `values[k * bands ..]` for region `ids[k]`; `efficacy`
    /// weighs the bands into the luminous value.
    pub fn add_photon(&mut self, ids: &[u32], values: &[f64], efficacy: &[f64]) {
        let nb = self.bands;
        for (k, &r) in ids.iter().enumerate() {
            let v = &values[k * nb..(k + 1) * nb];
            let r = r as usize;
            let mut lum = 0.0;
            for b in 0..nb {
                self.sum[r * nb + b] += v[b];
                self.sq[r * nb + b] += v[b] * v[b];
                lum += v[b] * efficacy[b];
            }
            self.sq_lum[r] += lum * lum;
        }
    }

    /// Adds another tally of the same layout (an empty default one takes `o`'s).
    pub fn merge(&mut self, o: &RegionTally) {
        if self.sq_lum.is_empty() {
            *self = o.clone();
            return;
        }
        debug_assert_eq!(self.sum.len(), o.sum.len(), "tallies of different layouts");
        for (mine, theirs) in [
            (&mut self.sum, &o.sum),
            (&mut self.sq, &o.sq),
            (&mut self.sq_lum, &o.sq_lum),
        ] {
            mine.iter_mut().zip(theirs).for_each(|(a, b)| *a += b);
        }
    }

    pub fn clear(&mut self) {
        for v in [&mut self.sum, &mut self.sq, &mut self.sq_lum] {
            v.iter_mut().for_each(|x| *x = 0.0);
        }
    }
}

/// One photon's totals per region, gathered while it travels.
#[derive(Debug, Default)]
pub struct RegionScratch {
    pub ids: Vec<u32>,
    pub values: Vec<f64>,
}

impl RegionScratch {
    /// The values of region `r` for this photon (`bands` of them), opened at 0.
    #[inline]
    pub fn slot(&mut self, r: u32, bands: usize) -> &mut [f64] {
        let k = match self.ids.iter().position(|&x| x == r) {
            Some(k) => k,
            None => {
                self.ids.push(r);
                self.values.resize(self.values.len() + bands, 0.0);
                self.ids.len() - 1
            }
        };
        &mut self.values[k * bands..(k + 1) * bands]
    }

    pub fn clear(&mut self) {
        self.ids.clear();
        self.values.clear();
    }
}

/// The run's tallies, one slot per calculating thread.
#[derive(Debug, Default)]
pub struct RegionShared {
    slots: Vec<Mutex<RegionTally>>,
    next: std::sync::atomic::AtomicUsize,
}

impl RegionShared {
    pub fn new(threads: usize, regions: usize, bands: usize) -> Self {
        RegionShared {
            slots: (0..threads.max(1))
                .map(|_| Mutex::new(RegionTally::new(regions, bands)))
                .collect(),
            next: Default::default(),
        }
    }

    /// A slot for one calculating thread (threads beyond the slots share the last).
    pub fn claim(&self) -> usize {
        let i = self.next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        i.min(self.slots.len() - 1)
    }

    fn lock(&self, i: usize) -> MutexGuard<'_, RegionTally> {
        self.slots[i].lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Adds a thread's local tally to its slot and clears it.
    pub fn flush(&self, slot: usize, local: &mut RegionTally) {
        if local.regions() == 0 {
            return;
        }
        self.lock(slot).merge(local);
        local.clear();
    }

    /// Everything tallied so far.
    pub fn total(&self) -> RegionTally {
        let mut t = RegionTally::default();
        for i in 0..self.slots.len() {
            t.merge(&self.lock(i));
        }
        t
    }
}

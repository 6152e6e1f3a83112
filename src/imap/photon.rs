//! One photon's deposits, held by the calculating thread until the photon's path ends.
//!
//! A run may be stopped while a photon is in flight; the map must then not hold part of
//! that photon (it is traced again, whole, by the next run). So the i-map sinks buffer a
//! photon's hits here and hand them to the scheduler only when the path has ended
//! (`finish`), or forget them (`abort`). Most photons hit a few surfaces; a photon in a
//! nearly lossless enclosure can bounce a million times, so past `MERGE_AFTER` hits the
//! buffer folds its hits per map slot: its size is then bounded by the slots the photon
//! reached, and each reached slot receives one full-colour deposit of weight 1 whose
//! square is exactly the photon's squared contribution to that slot.

use super::grey::MAX_GREY;
use super::layout::MapLayout;
use super::regions::RegionScratch;
use super::PhotonSquares;
use crate::scene::PreparedScene;
use crate::spectral::Colour;
use std::collections::HashMap;

/// Hits kept one by one before the buffer folds them per slot.
const MERGE_AFTER: usize = 4096;

/// `BufferedHit::band` of a full-colour hit.
pub const FULL: u16 = u16::MAX;
/// `BufferedHit::band` of a full-colour hit whose three vertices' shares are scaled by
/// weights (a direct deposit of the light-sampling estimator): the colour arena holds the
/// colour and then the three weights.
pub const WEIGHTED: u16 = u16::MAX - 1;
/// `BufferedHit::band` of a hit whose colour is a multiple of grey spectrum g
/// (`scene::GreySpectra`; the colour arena holds the multiple): `GREY` + g, and with the
/// three vertices' weights (after the multiple) `GREY_WEIGHTED` + g.
pub const GREY: u16 = u16::MAX - 2 - 2 * MAX_GREY as u16;
pub const GREY_WEIGHTED: u16 = GREY + MAX_GREY as u16;

/// The grey spectrum of a hit's (or contribution's) `band` code, and whether it has
/// weights.
#[inline]
pub fn grey_index(band: u16) -> Option<(usize, bool)> {
    (GREY..GREY + 2 * MAX_GREY as u16).contains(&band).then(|| {
        let i = (band - GREY) as usize;
        (i % MAX_GREY, i >= MAX_GREY)
    })
}

/// Whether a hit's colour arena holds the three vertices' weights after its colour.
#[inline]
fn weighted(band: u16) -> bool {
    band == WEIGHTED || grey_index(band).is_some_and(|(_, w)| w)
}

/// A hit's colour as its arena holds it, split into its values (every band, or the one
/// value of a collapsed or grey hit) and the three vertices' weights that follow them when
/// its band code says so (empty otherwise).
#[inline]
pub fn split_colour(band: u16, bands: usize, colour: &[f32]) -> (&[f32], &[f32]) {
    let values = if band >= WEIGHTED { bands } else { 1 };
    let weights = if weighted(band) { 3 } else { 0 };
    (&colour[..values], &colour[values..values + weights])
}

/// The per-vertex shares of a hit at (u, v): barycentric weights, times the hit's weights
/// when it has them (`WEIGHTED`, `GREY_WEIGHTED`; `extra` holds them after the colour).
#[inline]
pub fn shares(band: u16, u: f32, v: f32, extra: &[f32]) -> [f64; 3] {
    let (u, v) = (u as f64, v as f64);
    let w = [1.0 - u - v, u, v];
    if weighted(band) {
        [
            w[0] * extra[0] as f64,
            w[1] * extra[1] as f64,
            w[2] * extra[2] as f64,
        ]
    } else {
        w
    }
}

/// A hit of a buffered photon on a recording surface.
#[derive(Clone, Copy, Debug)]
pub struct BufferedHit {
    pub mesh: u32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
    /// Offset of its colour in the buffer's colour arena (one value when `band` is a band).
    pub colour_at: u32,
    /// The band of a photon collapsed to one band, or `FULL`.
    pub band: u16,
    pub side: u8,
    /// The map layer (`LayerLayout`): the photon's light group, or the direct layer.
    pub layer: u8,
}

impl BufferedHit {
    /// The map cells of the hit triangle's three vertices.
    #[inline]
    pub fn cells(&self, scene: &PreparedScene, layout: &MapLayout) -> [usize; 3] {
        let m = &scene.meshes[self.mesh as usize];
        m.triangles[self.prim as usize].map(|vertex| {
            let slot = m
                .slot(vertex, self.side as usize)
                .expect("deposit on a recording mesh");
            layout.layers.cell(slot, self.layer)
        })
    }
}

/// Where a finished photon's deposits go (the scheduler's portions).
pub trait PhotonOut {
    /// A hit, with the map cells of its triangle's vertices (`BufferedHit::cells`) and its
    /// colour (`bands` values, one value for a collapsed photon, or for `WEIGHTED` the
    /// `bands` values and the three vertices' weights: `shares`).
    fn hit(&mut self, hit: &BufferedHit, cells: [usize; 3], colour: &[f32]);
    /// The cross terms of the photon's squared contribution to map cell `cell`
    /// (`LayerLayout::cell`).
    fn square(&mut self, cell: usize, s2: f64);
    /// A folded photon's whole contribution to map cell `cell` (full colour, weight 1): its
    /// square is the photon's squared contribution.
    fn slot_value(&mut self, cell: usize, colour: &[f32]);
    /// The photon's totals per region it reached (`regions::RegionScratch`).
    fn regions(&mut self, _ids: &[u32], _values: &[f64]) {}
}

/// The current photon's deposits.
#[derive(Debug)]
pub struct PhotonBuffer {
    bands: usize,
    energy: f64,
    /// Whether the photon's energy changed along its path (a weighted first bounce): its
    /// hits' squares then take each hit's own energy.
    varying: bool,
    hits: Vec<BufferedHit>,
    colours: Vec<f32>,
    /// Folded hits: map cell → offset of its `bands` values in `folded_values`.
    folded: HashMap<u32, usize>,
    folded_values: Vec<f64>,
    squares: PhotonSquares,
    scratch: Vec<f32>,
    /// The photon's totals per region.
    regions: RegionScratch,
    /// The current photon's layer (its light group's).
    layer: u8,
    /// The current photon's emitter's grey spectrum, if the map keeps one for it, and the
    /// spectrum its colour should be a multiple of at its next hit (`GreySpectra::after`).
    base: Option<u8>,
    grey: Option<u8>,
    /// The direct layer, while the current photon has had no surface event and the map
    /// keeps one.
    direct: Option<u8>,
}

impl PhotonBuffer {
    /// Bytes one buffer holds at most before it folds (its hits and their colours).
    pub fn max_bytes(bands: usize) -> u64 {
        (MERGE_AFTER * (std::mem::size_of::<BufferedHit>() + 4 * bands)) as u64
    }

    pub fn new(bands: usize) -> Self {
        PhotonBuffer {
            bands,
            energy: 0.0,
            varying: false,
            hits: Vec::new(),
            colours: Vec::new(),
            folded: HashMap::new(),
            folded_values: Vec::new(),
            squares: PhotonSquares::default(),
            scratch: Vec::new(),
            regions: RegionScratch::default(),
            layer: 0,
            base: None,
            grey: None,
            direct: None,
        }
    }

    /// A new photon from `emitter` starts (its deposits go to the emitter's layer).
    #[inline]
    pub fn begin(&mut self, scene: &PreparedScene, layout: &MapLayout, emitter: usize) {
        self.layer = scene.emitters[emitter].layer;
        self.base = layout.grey.of_emitter.get(emitter).copied().flatten();
        self.grey = self.base;
        self.direct = layout.layers.direct_layer();
    }

    /// The current photon's first surface event is over.
    #[inline]
    pub fn direct_done(&mut self) {
        self.direct = None;
    }

    /// Records a hit of the current photon (with its vertices' weights, if any).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn deposit(
        &mut self,
        scene: &PreparedScene,
        layout: &MapLayout,
        (mesh, prim, side): (u32, u32, u8),
        u: f32,
        v: f32,
        colour: &Colour,
        weights: Option<[f32; 3]>,
    ) {
        let e = colour.energy();
        if self.hits.is_empty() && self.folded.is_empty() {
            self.varying = false;
        } else if e != self.energy {
            self.varying = true;
        }
        self.energy = e;
        if let Some(r) = &layout.regions.meshes[mesh as usize] {
            // The share of the photon the hit's vertices receive in all (1 unless weighted).
            let kept: f64 = weights.map_or(1.0, |w| shares(WEIGHTED, u, v, &w).iter().sum());
            let material = scene.meshes[mesh as usize].material(prim as usize);
            let regions = [
                Some(r.mesh_region(side as usize)),
                r.part_region(side as usize, material),
            ];
            // With layers, each region's tally in the photon's group layer (when several
            // groups are kept; with one the group's figures are the region's) and, before
            // its first surface event, in the direct layer.
            let regions_layout = &layout.regions;
            let group =
                (regions_layout.layers > 0 && layout.layers.groups > 1).then_some(self.layer);
            let mut ids = [0u32; 6];
            let mut n = 0;
            for id in regions.into_iter().flatten() {
                ids[n] = id;
                n += 1;
                for l in [group, self.direct].into_iter().flatten() {
                    ids[n] = regions_layout.layered(id, l);
                    n += 1;
                }
            }
            for &id in &ids[..n] {
                let s = self.regions.slot(id, self.bands);
                match colour.band() {
                    Some(b) => s[b] += colour.values()[b] * kept,
                    None => s
                        .iter_mut()
                        .zip(colour.values())
                        .for_each(|(a, c)| *a += c * kept),
                }
            }
        }
        let colour_at = self.colours.len() as u32;
        let band = match colour.band() {
            Some(b) => {
                self.colours.push(colour.values()[b] as f32);
                b as u16
            }
            None => {
                let grey = self.grey.and_then(|g| {
                    let a = layout.grey.multiple(g as usize, colour.values())?;
                    Some((g as u16, a))
                });
                // The spectrum of the photon's next hit, if it reflects diffusely here.
                self.grey = match (grey, self.base) {
                    (Some((g, _)), Some(base)) => {
                        let material = scene.meshes[mesh as usize].material(prim as usize);
                        layout.grey.after(g as u8, base, material as usize)
                    }
                    _ => None,
                };
                let band = match grey {
                    Some((g, a)) => {
                        // A multiple of a kept spectrum: one number.
                        self.colours.push(a as f32);
                        g
                    }
                    None => {
                        self.colours
                            .extend(colour.values().iter().map(|&c| c as f32));
                        FULL
                    }
                };
                match (weights, band) {
                    (Some(w), FULL) => {
                        self.colours.extend(w);
                        WEIGHTED
                    }
                    (Some(w), g) => {
                        self.colours.extend(w);
                        GREY_WEIGHTED + g
                    }
                    (None, FULL) => FULL,
                    (None, g) => GREY + g,
                }
            }
        };
        let hit = BufferedHit {
            mesh,
            prim,
            u,
            v,
            colour_at,
            band,
            side,
            layer: self.layer,
        };
        self.hits.push(hit);
        if let Some(layer) = self.direct {
            // The direct layer holds the same deposit again (not part of the sum).
            self.hits.push(BufferedHit { layer, ..hit });
        }
        if self.hits.len() >= MERGE_AFTER {
            self.fold(scene, layout);
        }
    }

    /// Folds the buffered hits into the per-slot sums.
    fn fold(&mut self, scene: &PreparedScene, layout: &MapLayout) {
        let nb = self.bands;
        for h in &self.hits {
            let c = h.colour_at as usize;
            let grey = grey_index(h.band);
            let extra = if grey.is_some() { c + 1 } else { c + nb };
            let w = shares(h.band, h.u, h.v, self.colours.get(extra..).unwrap_or(&[]));
            for (cell, w) in h.cells(scene, layout).into_iter().zip(w) {
                let next = self.folded_values.len();
                let at = *self.folded.entry(cell as u32).or_insert(next);
                if at == next {
                    self.folded_values.resize(next + nb, 0.0);
                }
                let values = &mut self.folded_values[at..at + nb];
                if let Some((g, _)) = grey {
                    let a = w * self.colours[c] as f64;
                    for (x, s) in values.iter_mut().zip(layout.grey.spectrum(g)) {
                        *x += a * s;
                    }
                } else if h.band >= WEIGHTED {
                    for (x, &c) in values.iter_mut().zip(&self.colours[c..c + nb]) {
                        *x += w * c as f64;
                    }
                } else {
                    values[h.band as usize] += w * self.colours[c] as f64;
                }
            }
        }
        self.hits.clear();
        self.colours.clear();
    }

    /// Forgets the current photon.
    pub fn abort(&mut self) {
        self.regions.clear();
        self.hits.clear();
        self.colours.clear();
        self.folded.clear();
        self.folded_values.clear();
    }

    /// The current photon has ended: hands its deposits to `out` and forgets them.
    pub fn finish(&mut self, scene: &PreparedScene, layout: &MapLayout, out: &mut impl PhotonOut) {
        if !self.regions.ids.is_empty() {
            out.regions(&self.regions.ids, &self.regions.values);
            self.regions.clear();
        }
        if !self.folded.is_empty() {
            self.fold(scene, layout);
            let nb = self.bands;
            // In cell order: the same sequence of additions whatever the hash map's order.
            let mut cells: Vec<(u32, usize)> = self.folded.drain().collect();
            cells.sort_unstable();
            for (cell, at) in cells {
                self.scratch.clear();
                self.scratch
                    .extend(self.folded_values[at..at + nb].iter().map(|&x| x as f32));
                out.slot_value(cell as usize, &self.scratch);
            }
            self.folded_values.clear();
            return;
        }
        let e = self.energy;
        let nb = self.bands;
        for h in &self.hits {
            let cells = h.cells(scene, layout);
            let c = h.colour_at as usize;
            let grey = grey_index(h.band);
            let (values, weights) = split_colour(h.band, nb, &self.colours[c..]);
            let colour = &self.colours[c..c + values.len() + weights.len()];
            let w = shares(h.band, h.u, h.v, weights);
            let e = if self.varying {
                // This hit's energy: its colour's band mean.
                match grey {
                    Some((g, _)) => values[0] as f64 * layout.grey.means[g],
                    None => values.iter().map(|&x| x as f64).sum::<f64>() / nb as f64,
                }
            } else {
                e
            };
            self.squares.add(cells, w.map(|w| w * e));
            out.hit(h, cells, colour);
        }
        self.squares
            .drain_cross_terms(|slot, s2| out.square(slot, s2));
        self.hits.clear();
        self.colours.clear();
    }
}

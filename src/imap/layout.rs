//! How a map is laid out for a scene: its layers (light groups, the direct component),
//! the regions whose totals photons tally, and the grey spectra of a spectral map. The
//! context builds it from the scene and its prepared form; the schedulers and photon
//! buffers read it beside the prepared scene.

use super::grey::GreySpectra;
use super::regions::RegionLayout;
use crate::scene::{LayerRequest, PreparedScene, Scene};

/// Most light groups a map can keep as layers (group ids 0 … `MAX_LIGHT_GROUPS` − 1): a
/// buffered hit names its layer in one byte, the direct layer included.
pub const MAX_LIGHT_GROUPS: usize = 254;

/// How many cells (accumulator records) each slot has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LayerLayout {
    /// Group layers, summed into the combined map (1 when groups are not kept).
    pub groups: u8,
    /// A direct-component layer after the group layers.
    pub direct: bool,
}

impl Default for LayerLayout {
    fn default() -> Self {
        LayerLayout::SINGLE
    }
}

impl LayerLayout {
    /// No layers: one cell per slot.
    pub const SINGLE: LayerLayout = LayerLayout {
        groups: 1,
        direct: false,
    };

    /// The layers of `request` when the largest light group in use is `largest`.
    pub fn new(request: LayerRequest, largest: Option<u32>) -> Self {
        LayerLayout {
            // Group ids are checked when set (< MAX_LIGHT_GROUPS).
            groups: match largest {
                Some(g) if request.groups => g as u8 + 1,
                _ => 1,
            },
            direct: request.direct,
        }
    }

    /// Cells per slot.
    #[inline]
    pub fn per_slot(self) -> usize {
        self.groups as usize + usize::from(self.direct)
    }

    /// The direct layer's index, if kept.
    #[inline]
    pub fn direct_layer(self) -> Option<u8> {
        self.direct.then_some(self.groups)
    }

    /// The cell of `layer` in `slot`.
    #[inline]
    pub fn cell(self, slot: usize, layer: u8) -> usize {
        slot * self.per_slot() + layer as usize
    }

    /// The cells a value of `slot` sums: its group layers (`layer` None: the combined
    /// value), or the one layer `layer`.
    #[inline]
    pub fn cells(self, slot: usize, layer: Option<u8>) -> std::ops::Range<usize> {
        match layer {
            None => {
                let first = self.cell(slot, 0);
                first..first + self.groups as usize
            }
            Some(l) => {
                let c = self.cell(slot, l);
                c..c + 1
            }
        }
    }

    /// The slot a cell belongs to.
    #[inline]
    pub fn slot_of(self, cell: usize) -> usize {
        if self == LayerLayout::SINGLE {
            cell
        } else {
            cell / self.per_slot()
        }
    }
}

/// The map's layout for one prepared scene.
#[derive(Debug)]
pub struct MapLayout {
    /// The map's layers.
    pub layers: LayerLayout,
    /// The regions photons' totals are tallied for (`regions`).
    pub regions: RegionLayout,
    /// The spectra a spectral map keeps grey sums for (`GreySpectra`).
    pub grey: GreySpectra,
}

impl MapLayout {
    /// The layout of `scene`'s map once prepared as `prepared`.
    pub fn new(scene: &Scene, prepared: &PreparedScene) -> Self {
        let layers = LayerLayout::of_scene(scene);
        MapLayout {
            layers,
            regions: RegionLayout::new(&prepared.meshes, layers),
            grey: GreySpectra::new(
                &prepared.emitters,
                &scene.materials,
                prepared.efficacy.len(),
            ),
        }
    }
}

impl MapLayout {
    /// Per mesh: whether its map is split into material parts (`RegionLayout`).
    pub fn parts(&self) -> Vec<bool> {
        self.regions
            .meshes
            .iter()
            .map(|r| r.as_ref().is_some_and(|r| !r.parts.is_empty()))
            .collect()
    }
}

impl LayerLayout {
    /// The layers of `scene`'s map: as requested, with as many group layers as the
    /// largest group of a light or emitting mesh needs.
    pub fn of_scene(scene: &Scene) -> Self {
        LayerLayout::new(scene.layers, scene.largest_light_group())
    }
}

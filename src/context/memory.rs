//! What a context holds in memory, estimated from counts alone so that the budget
//! (`Config::memory_budget`) is checked before anything is allocated.
//!
//! The model, per mesh of nv vertices and nt triangles:
//! - the copy the context keeps: 24·nv + 12·nt, and 4·nt with per-triangle materials;
//! - its prepared form (f32 vertices, triangles, normals): 12·nv + 24·nt, and 8·nv when it
//!   records, 4·nt with per-triangle materials, 28·nt for an emitting mesh's triangles;
//! - the prepared form's transient f64 vertices: 24·nv;
//! - Embree's copy and BVH: `BVH_BYTES_PER_TRIANGLE`·nt and `BVH_BYTES_PER_VERTEX`·nv,
//!   measured with the medium-quality builder on the 4.4 library (`tests/memory.rs`
//!   checks the whole model against the process's peak).
//!
//! Then the map (slots × (bands + 1) × 8, and up to bands / 4 grey sums per slot for a
//! spectral map), and per run or render its own buffers.

use crate::photometry::gonio::table_bytes;
use crate::scene::{Light, LightShape, Mesh, MeshDesc, Scene};

/// Embree's share per triangle: its index buffer and the BVH (nodes and leaves).
pub const BVH_BYTES_PER_TRIANGLE: u64 = 96;
/// Embree's share per vertex: its vertex buffer (with padding).
pub const BVH_BYTES_PER_VERTEX: u64 = 16;

/// Bytes of one mesh from its counts: (held, transient while preparing).
pub fn mesh_bytes(
    nv: u64,
    nt: u64,
    per_triangle_materials: bool,
    record: bool,
    emits: bool,
) -> (u64, u64) {
    let copy = 24 * nv + 12 * nt + if per_triangle_materials { 4 * nt } else { 0 };
    let prepared = 12 * nv
        + 24 * nt
        + if record { 8 * nv } else { 0 }
        + if per_triangle_materials { 4 * nt } else { 0 }
        + if emits { 28 * nt } else { 0 };
    let bvh = BVH_BYTES_PER_TRIANGLE * nt + BVH_BYTES_PER_VERTEX * nv;
    (copy + prepared + bvh, 24 * nv)
}

/// `mesh_bytes` of a description before it is copied.
pub fn desc_bytes(d: &MeshDesc) -> (u64, u64) {
    mesh_bytes(
        (d.positions.len() / 3) as u64,
        (d.indices.len() / 3) as u64,
        d.triangle_materials.is_some(),
        d.record,
        d.exitance.is_some(),
    )
}

fn held_mesh_bytes(m: &Mesh) -> (u64, u64) {
    mesh_bytes(
        m.positions.len() as u64,
        m.triangles.len() as u64,
        m.triangle_materials.is_some(),
        m.record,
        m.exitance.is_some(),
    )
}

/// Running figures of a scene, kept as meshes and lights are added so that the memory
/// model costs the same for the 5000th mesh as for the first (summing over the scene on
/// every addition made loading quadratic, and per recording mesh cubic).
#[derive(Clone, Debug, Default)]
pub struct Footprint {
    /// Bytes the meshes (prepared) and the lights hold.
    pub held: u64,
    /// The most any one mesh needs on top while it is being prepared.
    pub transient: u64,
    /// Map slots: recorded sides of the recording meshes' vertices.
    pub slots: u64,
    /// The light-sampling estimator's adjacency of the recording meshes (per triangle
    /// corner an entry, per vertex its list's start).
    pub adjacency: u64,
    /// The largest light group of a light or emitting mesh.
    pub largest_group: Option<u32>,
    /// The luminaires' distributions counted (by address: placements share one).
    tables: std::collections::HashSet<usize>,
}

impl Footprint {
    /// Counts a mesh just added.
    pub fn add_mesh(&mut self, m: &Mesh) {
        let (held, transient) = held_mesh_bytes(m);
        self.held = self.held.saturating_add(held);
        self.transient = self.transient.max(transient);
        self.slots = self.slots.saturating_add(m.map_slots() as u64);
        if m.record {
            self.adjacency = self
                .adjacency
                .saturating_add(adjacency_bytes(m.triangles.len(), m.positions.len()));
        }
        if m.exitance.is_some() {
            self.raise_group(m.light_group);
        }
    }

    /// Counts a light just added. A luminaire's table is counted once however often it
    /// is placed (its placements share it).
    pub fn add_light(&mut self, l: &Light) {
        let bytes = match &l.shape {
            LightShape::Distant(d) => SKY_HELD_PER_CHANNEL_PIXEL.saturating_mul(d.image_pixels()),
            LightShape::Luminaire(lum)
                if self
                    .tables
                    .insert(std::sync::Arc::as_ptr(&lum.dist) as usize) =>
            {
                table_bytes(0, lum.dist.values() as u64).1
            }
            _ => 0,
        };
        self.held = self.held.saturating_add(bytes);
        self.raise_group(l.group);
    }

    /// Uncounts a light just removed (its group: `regroup`). A luminaire's table stays
    /// counted: other placements may share it.
    pub fn remove_light(&mut self, l: &Light) {
        if let LightShape::Distant(d) = &l.shape {
            let bytes = SKY_HELD_PER_CHANNEL_PIXEL.saturating_mul(d.image_pixels());
            self.held = self.held.saturating_sub(bytes);
        }
    }

    /// A light's group changed: the largest group again.
    pub fn regroup(&mut self, scene: &Scene) {
        self.largest_group = scene.largest_light_group();
    }

    fn raise_group(&mut self, g: u32) {
        self.largest_group = self.largest_group.max(Some(g));
    }
}

/// Bytes an environment image holds per channel and pixel: its value (f32) and its
/// sampling table's entry (probability, alias, density).
pub const SKY_HELD_PER_CHANNEL_PIXEL: u64 = 4 + 20;

/// Bytes adding an environment image of `pixels` pixels takes: held (three channels), and
/// while it is built (the RGB copy, the channels, the table's weights and work lists).
pub fn sky_image_bytes(pixels: u64) -> (u64, u64) {
    (
        pixels.saturating_mul(3 * SKY_HELD_PER_CHANNEL_PIXEL),
        pixels.saturating_mul(12 + 12 + 8 + 16),
    )
}

/// Bytes of a map of `slots` slots and `bands` bands: with a spectral map's grey sums
/// (`scene::GreySpectra`) at the most there can be.
pub fn map_bytes(slots: u64, bands: u64) -> u64 {
    let grey = crate::imap::most_grey(bands as usize) as u64;
    slots.saturating_mul(bands + 1 + grey).saturating_mul(8)
}

/// Bytes the light-sampling estimator adds for a recording mesh of (triangles, vertices)
/// `corners` and `cells` map cells: per cell its direct record (bands, sums of squares,
/// pass count), per triangle corner its adjacency entry, per vertex its list's start.
pub fn direct_bytes((triangles, vertices): (usize, usize), cells: u64, bands: u64) -> u64 {
    direct_record_bytes(cells, bands).saturating_add(adjacency_bytes(triangles, vertices))
}

/// Bytes of the light-sampling estimator's adjacency of a mesh of `triangles` and
/// `vertices`: per triangle corner its entry, per vertex its list's start.
pub fn adjacency_bytes(triangles: usize, vertices: usize) -> u64 {
    (3 * triangles as u64 * 8).saturating_add(4 * (vertices as u64 + 1))
}

/// Bytes of `cells` cells' direct records (`imap::DirectAcc`: bands, two sums of squares,
/// the pass count).
pub fn direct_record_bytes(cells: u64, bands: u64) -> u64 {
    cells.saturating_mul(bands + 3).saturating_mul(8)
}

/// `direct_bytes` of a mesh about to be added.
pub fn direct_desc_bytes(desc: &crate::scene::MeshDesc, cells: u64, bands: u64) -> u64 {
    direct_bytes(
        (desc.indices.len() / 3, desc.positions.len() / 3),
        cells,
        bands,
    )
}

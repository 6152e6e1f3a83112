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

use crate::scene::{Mesh, MeshDesc, Scene};

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

/// Bytes the scene's meshes take once prepared (held), and the most any one of them needs
/// on top while it is being prepared.
pub fn scene_bytes(scene: &Scene) -> (u64, u64) {
    let (held, transient) = scene
        .meshes
        .iter()
        .map(held_mesh_bytes)
        .fold((0u64, 0u64), |(h, t), (mh, mt)| {
            (h.saturating_add(mh), t.max(mt))
        });
    let skies: u64 = scene
        .lights
        .iter()
        .filter_map(|l| match &l.shape {
            crate::scene::LightShape::Distant(d) => Some(d.image_pixels()),
            _ => None,
        })
        .map(|px| SKY_HELD_PER_CHANNEL_PIXEL.saturating_mul(px))
        .fold(0, u64::saturating_add);
    (held.saturating_add(skies), transient)
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
    let grey = crate::scene::most_grey(bands as usize) as u64;
    slots.saturating_mul(bands + 1 + grey).saturating_mul(8)
}

/// Bytes the light-sampling estimator adds for a recording mesh of (triangles, vertices)
/// `corners` and `cells` map cells: per cell its direct record (bands, sums of squares,
/// pass count), per triangle corner its adjacency entry, per vertex its list's start.
pub fn direct_bytes((triangles, vertices): (usize, usize), cells: u64, bands: u64) -> u64 {
    let adjacency = 3 * triangles as u64 * 8 + 4 * (vertices as u64 + 1);
    direct_record_bytes(cells, bands).saturating_add(adjacency)
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

//! The scene: bands, materials, meshes and lights as plain Rust data, and its prepared
//! (frozen) form that tracing reads.

pub mod bands;
pub mod light;
pub mod material;
pub mod mesh;
mod prepared;

pub use bands::Bands;
pub use light::{Light, LightShape};
pub use material::{IorModel, Material, MaterialDesc};
pub use mesh::{Mesh, MeshDesc};
pub use prepared::{Emitter, EmitterKind, PreparedMesh, PreparedScene};

/// Everything the caller has described.
#[derive(Clone, Debug)]
pub struct Scene {
    pub bands: Bands,
    pub materials: Vec<Material>,
    pub meshes: Vec<Mesh>,
    pub lights: Vec<Light>,
    /// Metres per scene unit: irradiance is reported in W/m².
    pub unit_m: f64,
}

impl Scene {
    pub fn new(bands: Bands, unit_m: f64) -> Self {
        Scene {
            bands,
            materials: Vec::new(),
            meshes: Vec::new(),
            lights: Vec::new(),
            unit_m,
        }
    }

    /// Number of (vertex, side) slots the map needs: recorded sides of recording meshes.
    pub fn slot_count(&self) -> usize {
        self.meshes.iter().map(Mesh::map_slots).sum()
    }

    /// Bytes the map needs for `slots` slots: one f64 per band plus the sum of squares.
    pub fn map_bytes(&self, slots: usize) -> u128 {
        slots as u128 * (self.bands.count() as u128 + 1) * 8
    }
}

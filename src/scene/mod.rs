//! The scene: bands, materials, meshes and lights as plain Rust data, and its prepared
//! (frozen) form that tracing reads.

pub mod bsdf;
pub(crate) mod emitter;
pub mod host;
pub mod klems;
pub mod light;
pub mod material;
pub mod medium;
pub mod mesh;
mod metals;
pub mod microfacet;
mod prepared;
mod prepared_mesh;
pub mod table;
pub mod texture;

pub use crate::spectral::Bands;
pub use emitter::{Emitter, Extent, LightSample, Receiver};
pub use light::{Light, LightShape};
pub use material::{
    ConductorIndex, IorModel, Material, MaterialDesc, Metal, SurfaceModel, LOBE_DIFFUSE_REFLECT,
    LOBE_DIFFUSE_TRANSMIT, LOBE_ROUGHNESS, LOBE_SPECULAR_REFLECT,
};
pub use mesh::{Mesh, MeshDesc};
pub use prepared::{Enclosures, PreparedScene};
pub use prepared_mesh::PreparedMesh;
pub use table::{TableCheck, TableDesc};

/// Everything the caller has described.
#[derive(Clone, Debug)]
pub struct Scene {
    pub bands: Bands,
    pub materials: Vec<Material>,
    pub meshes: Vec<Mesh>,
    pub lights: Vec<Light>,
    /// Metres per scene unit: irradiance is reported in W/m².
    pub unit_m: f64,
    /// The layers the map keeps besides the combined values.
    pub layers: LayerRequest,
    /// Window portals (scene units, each triangle's normal facing out): when there are
    /// any, distant light enters only through them (`prepared::Portals`).
    pub portals: Vec<[[f64; 3]; 3]>,
    /// Textures of materials (`scene::texture`).
    pub textures: Vec<std::sync::Arc<texture::Texture>>,
    /// The material whose medium fills the space outside every closed mesh that holds
    /// one (haze in a room, fog in a tunnel): an index-1 dielectric that absorbs or
    /// scatters (`Context::set_scene_medium`). It fills the bounding sphere of the
    /// geometry and the lights (`PreparedScene::haze`).
    pub medium: Option<u32>,
}

/// Which layers a map keeps (the map lays them out: `imap::LayerLayout`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LayerRequest {
    /// One layer per light group (groups 0 … the largest group of a light or emitting mesh).
    pub groups: bool,
    /// The direct component: what photons deposit before their first surface event.
    pub direct: bool,
}

impl Scene {
    pub fn new(bands: Bands, unit_m: f64) -> Self {
        Scene {
            bands,
            materials: Vec::new(),
            meshes: Vec::new(),
            lights: Vec::new(),
            unit_m,
            layers: LayerRequest::default(),
            portals: Vec::new(),
            textures: Vec::new(),
            medium: None,
        }
    }

    /// The largest light group of a light or emitting mesh.
    pub fn largest_light_group(&self) -> Option<u32> {
        let lights = self.lights.iter().map(|l| l.group);
        let meshes = self
            .meshes
            .iter()
            .filter(|m| m.exitance.is_some())
            .map(|m| m.light_group);
        lights.chain(meshes).max()
    }

    /// Number of (vertex, side) slots the map needs: recorded sides of recording meshes.
    pub fn slot_count(&self) -> usize {
        self.meshes.iter().map(Mesh::map_slots).sum()
    }
}

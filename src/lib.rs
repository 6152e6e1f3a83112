//! libimap: illumination maps (irradiance at every mesh vertex, RGB or spectral) by forward
//! Monte Carlo light tracing on Intel Embree 4, with a C ABI (`include/imap.h`).
//!
//! The Rust API is what this page lists: the `Context` and what it takes and gives
//! (settings, scene descriptions, lights, skies, reports, images), the photometry toolkit
//! (`photometry`) and the C ABI (`ffi`). Everything else is the engine's and private to
//! the crate.
//!
//! The engine's floors, top to bottom (`tests/floors.rs` holds every import to them):
//! `ffi` (the C ABI only) → `annual` (annual daylight from sky-patch coefficients, the
//! direct sun traced through a context's scene), `glare` (observers: what the eye sees of
//! the lights through a context's scene) → `context` (the safe API) → `render` (the
//! camera renderers) → `sched` (the schedulers) → `imap` (the map, its layout and
//! readout) → `transport` (the photon path and light
//! sampling) → `accel` (every Embree call), `weather` (weather files) → `scene` (plain
//! data: the scene, its lights, emitters and BSDFs, and its prepared form) →
//! `photometry`, `images`
//! → `spectral`, `sampling`, `solar`, `progress` → `error`, `files`, `fault`.

#![warn(clippy::undocumented_unsafe_blocks)]

// `include/imap.h` is generated from `ffi` (and `ImapStatus` in `error`) alone: every
// other module is hidden from cbindgen, so no internal name can leak into the header.

/// cbindgen:ignore
mod accel;
/// cbindgen:ignore
pub mod annual;
/// cbindgen:ignore
mod context;
mod error;
/// cbindgen:ignore
mod fault;
pub mod ffi;
/// cbindgen:ignore
mod files;
/// cbindgen:ignore
pub mod glare;
/// cbindgen:ignore
mod images;
/// cbindgen:ignore
mod imap;
/// cbindgen:ignore
pub mod photometry;
/// cbindgen:ignore
mod platform;
/// cbindgen:ignore
mod progress;
/// cbindgen:ignore
mod render;
/// cbindgen:ignore
mod sampling;
/// cbindgen:ignore
mod scene;
/// cbindgen:ignore
mod sched;
/// cbindgen:ignore
mod solar;
/// cbindgen:ignore
mod spectral;
/// cbindgen:ignore
mod transport;
/// cbindgen:ignore
pub mod weather;

// The context and its settings and reports.
pub use context::state::{read_state_file, state_info, Fingerprint, StateInfo, FLAG_NO_MAP};
pub use context::{
    default_memory_budget, Config, Context, Layer, MediumAbsorbed, MeshInfo, RegionStats, Report,
    SchedulerKind,
};
pub use error::{Error, ImapStatus, Result, Subject};
pub use files::{read_regular, ReadError};
pub use imap::stats::{extremes, lit_weights, Estimate, Extremes};
pub use platform::is_device_name_here;
pub use progress::{Progress, StopReason, MAX_HISTORY};
pub use sched::dynamic::DynamicParams;
pub use sched::target::{RegionMeasure, RegionTarget};
pub use sched::{Counters, RangeSet, RunParams, Selection};
pub use transport::direct::Estimator;
pub use transport::SCENE_MEDIUM;
// The scene: bands, materials, meshes, lights, skies and the sun.
pub use scene::host::{HostBsdf, HostBsdfRef};
pub use scene::light::{
    air_mass, cie_luminance, eccentricity, perez_bin, perez_parameters, perez_relative, perez_sky,
    precipitable_water, sky_patch_radiance, Amount, Distribution, LightDesc, LightKind, PerezSky,
    Placement, SkyAmount, SkyDesc, SkyKind, SkyPatches, SunDesc, CIE_SKY_PARAMETERS,
    MAX_REINHART_MF, PEREZ_CLEARNESS_BINS, PEREZ_DIFFUSE_EFFICACY, PEREZ_DIRECT_EFFICACY,
    PEREZ_SKY_COEFFICIENTS, SOLAR_CONSTANT_W_PER_M2, SUN_DIAMETER_DEG,
};
pub use scene::texture::TextureDesc;
pub use scene::{
    ConductorIndex, IorModel, LayerRequest, MaterialDesc, MeshDesc, Metal, SurfaceModel,
    TableCheck, TableDesc, LOBE_DIFFUSE_REFLECT, LOBE_DIFFUSE_TRANSMIT, LOBE_ROUGHNESS,
    LOBE_SPECULAR_REFLECT,
};
pub use solar::{sun_position, sun_position_with, SunTime, STANDARD_ATMOSPHERE};
pub use spectral::Bands;
// Camera renders.
pub use render::{
    CameraDesc, Image, Projection, RenderMethod, RenderParams, RenderReport,
    OMITS_CAUSTICS_ON_GLOSSY, OMITS_REFRACTED_INTO_MEDIUM,
};

//! libimap: illumination maps (irradiance at every mesh vertex, RGB or spectral) by forward
//! Monte Carlo light tracing on Intel Embree 4, with a C ABI (`include/imap.h`).
//!
//! Layout: `scene` (plain data), `accel` (every Embree call), `sampling`, `transport` (the
//! photon path), `imap` (the map and its readout), `sched` (schedulers), `context` (the safe
//! API) and `ffi` (the C ABI only).

#![warn(clippy::undocumented_unsafe_blocks)]

// `include/imap.h` is generated from `ffi` (and `ImapStatus` in `error`) alone: every
// other module is hidden from cbindgen, so no internal name can leak into the header.

/// cbindgen:ignore
pub mod accel;
/// cbindgen:ignore
pub mod context;
pub mod error;
/// cbindgen:ignore
mod fault;
pub mod ffi;
/// cbindgen:ignore
pub mod files;
/// cbindgen:ignore
pub mod images;
/// cbindgen:ignore
pub mod imap;
/// cbindgen:ignore
pub mod photometry;
/// cbindgen:ignore
pub mod progress;
/// cbindgen:ignore
pub mod render;
/// cbindgen:ignore
pub mod sampling;
/// cbindgen:ignore
pub mod scene;
/// cbindgen:ignore
pub mod scenes;
/// cbindgen:ignore
pub mod sched;
/// cbindgen:ignore
pub mod solar;
/// cbindgen:ignore
pub mod spectral;
/// cbindgen:ignore
pub mod transport;

pub use context::{Config, Context, Layer, RegionStats, Report, SchedulerKind};
pub use error::{Error, ImapStatus, Result, Subject};
pub use render::{CameraDesc, Image, RenderMethod, RenderParams, RenderReport};
pub use scene::{IorModel, LayerRequest, MaterialDesc, MeshDesc};
pub use sched::{Progress, RunParams, Selection, StopReason};
pub use spectral::Bands;
pub use transport::direct::Estimator;

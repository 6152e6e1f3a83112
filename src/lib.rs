//! libimap: illumination maps (irradiance at every mesh vertex, RGB or spectral) by forward
//! Monte Carlo light tracing on Intel Embree 4, with a C ABI (`include/imap.h`).
//!
//! Layout: `scene` (plain data), `accel` (every Embree call), `sampling`, `transport` (the
//! photon path), `imap` (the map and its readout), `sched` (schedulers), `context` (the safe
//! API) and `ffi` (the C ABI only).

#![warn(clippy::undocumented_unsafe_blocks)]

pub mod accel;
pub mod context;
pub mod error;
pub mod ffi;
pub mod imap;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod scenes;
pub mod sched;
pub mod transport;

pub use context::{Config, Context, Report, SchedulerKind};
pub use error::{Error, ImapStatus, Result};
pub use render::{CameraDesc, Image, RenderMethod, RenderParams, RenderReport};
pub use scene::{Bands, IorModel, MaterialDesc, MeshDesc};
pub use sched::{Progress, RunParams, StopReason};

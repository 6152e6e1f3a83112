//! The second system: camera luminance by stochastic progressive backward photon mapping,
//! with the synchronous, asynchronous and two-level semi-synchronous parallelizations of
//! our second paper (Zhdanov & Zhdanov, "The Two-Level Semi-Synchronous Parallelization
//! Method for the Caustic and Indirect Luminance Calculation in Realistic Rendering",
//! CEUR-WS Vol-2744, paper 7).
//!
//! A **phase** of a group of threads: (1) backward paths from the camera for the pixels of
//! the group's mask, with direct light (`backward`); (2) the backward photon maps are built
//! (`bmap`); (3) forward photons from the lights gather into them (indirect and caustic
//! light); (4) every covered pixel gets one more sample, and its radius shrinks.
//!
//! * Synchronous: one group of all threads, one set of maps covering the image.
//! * Asynchronous: one group per thread, each rendering the whole image into private maps
//!   and a private pixel store; the calling thread merges the stores.
//! * Semi-synchronous: groups of `group_threads` threads, each with a random mask of 32×32
//!   tiles (disjoint, covering the image, re-dealt every `remask_phases` phases at a global
//!   synchronisation), its own maps, and lock-free access to the other groups' open maps
//!   through the active-thread counter (`gate`).
//!
//! The calling thread is the monitor: it reports progress, merges the estimate and decides
//! when to stop. The synchronous method, and any method on one thread, gives the same image
//! for the same seed whatever the thread count (up to the order of additions); with several
//! groups, which maps a forward photon reaches depends on timing, and the methods agree
//! statistically.

pub mod backward;
mod barrier;
pub mod bmap;
pub mod camera;
pub mod coverage;
mod engine;
pub mod gate;
pub mod gather;
mod monitor;
mod types;

pub use backward::EyeTracer;
pub use camera::{Camera, CameraDesc, Projection};
pub use engine::{bytes_needed, render};
pub use monitor::RenderMonitor;
pub use types::{
    Image, RenderMethod, RenderParams, RenderReport, OMITS_CAUSTICS_ON_GLOSSY,
    OMITS_REFRACTED_INTO_MEDIUM,
};

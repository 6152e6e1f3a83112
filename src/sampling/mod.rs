//! Random numbers and sampling: a counter-based per-photon generator, alias tables for
//! choosing lights and triangles, and the warps from the unit square to directions.

pub mod alias;
pub mod rng;
pub mod warp;

pub use alias::AliasTable;
pub use rng::PhotonRng;

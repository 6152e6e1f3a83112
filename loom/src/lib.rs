//! The loom models' view of libimap's three lock-free protocols, compiled from the
//! library's own source files (`RUSTFLAGS="--cfg loom"` only; otherwise empty). The models
//! are in `tests/`.
#![cfg(loom)]
// The library's other users of these types are not here.
#![allow(dead_code)]

#[path = "../../src/sched/doze.rs"]
mod doze;
#[path = "../../src/render/gate.rs"]
mod gate;
#[path = "../../src/sched/groups.rs"]
mod groups;

pub use doze::Doze;
pub use gate::Gate;
pub use groups::GroupTable;

//! The ground floor: how the spectrum is cut into bands (`Bands`) and a photon's colour over
//! them (`Colour`). Everything above reads these; they read nothing of the engine.

mod bands;
mod colour;

pub use bands::Bands;
pub use colour::{collapse_weights, pick_band, Colour, Transmittance};

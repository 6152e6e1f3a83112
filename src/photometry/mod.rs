//! Photometry and colour: the CIE tables (V(λ), the 1931 colour-matching functions, D65),
//! spectra of lights and their powers per band, the photometric and colorimetric value of
//! band values (lumens, lux, XYZ, chromaticity, CCT), and goniometric luminaires (IES
//! LM-63 and EULUMDAT files, or a table of angles and candelas).
//!
//! docs/photometry.md states every rule.

pub mod alpha_opic;
pub mod colour;
pub mod gonio;
pub mod ies;
pub mod ldt;
pub mod spectrum;
mod tables;
pub mod ugr_table;

pub use colour::{cct, chromaticity, BandPhotometry, KM};
pub use gonio::{Goniometric, Opening, PhotometricData, PhotometricType, Symmetry};
pub use spectrum::Spectrum;

//! The UGR table of a luminaire (the tabular method of CIE 117:1995 as CIE 190:2010 lays
//! it out): the unified glare rating of an array of the luminaire in 19 standard rooms, for
//! five combinations of reflectances, seen crosswise and endwise.
//!
//! The rooms are X × Y with X across the observer's line of sight and Y along it, both in
//! multiples of H = 2 m, the height of the luminaires above the eye. The observer sits at
//! the middle of a wall of length X and looks horizontally along the room. The luminaires
//! fill the ceiling on a square grid of spacing 0.25 H (the catalogue's spacing-to-height
//! ratio), each emitting the flux the file gives it:
//! - **Crosswise**: the luminaire's C0 plane lies along the line of sight, so a linear
//!   luminaire is seen across its length. **Endwise**: turned 90°.
//! - A luminaire counts when T/R ≤ 3 and γ ≤ 85°. Here R is its distance along the line of
//!   sight, T its distance across it, and γ = atan(√(R² + T²) / H).
//! - It counts with L²ω/p², where:
//!   - L = I(C, γ) / A_p is its luminance toward the eye, C = atan(T/R) crosswise and
//!     90° − atan(T/R) endwise;
//!   - ω = A_p / r² its solid angle;
//!   - p is Guth's index from CIE 117's table 4.1 at H/R and T/R, bilinear, and a
//!     luminaire next to a cell the table leaves empty does not count.
//! - The background luminance is CIE 190's: Lb = E_WID / π, from the walls' indirect
//!   illuminance. E_WID = N Φ / A_w · (F_DF F_T,FW + F_DW F_T,WW−1 + F_DC F_T,CW), where:
//!   - A_w = 2H(X + Y) is the walls' area between the eye and the luminaires;
//!   - the flux fractions F_DF, F_DW and F_DC come from the luminaire's zonal fluxes in
//!     10° zones (the stored C planes averaged at the zones' middles, scaled to the file's
//!     flux) through the factors F_GL of CIE 190's table 4 for the room's index;
//!   - F_T are the transfer factors of its table 5.
//!
//! The factors are the standards' own numbers, data and not code, as eulumdat-ugr 1.0.2
//! (MIT) transcribes them. One cell of its Guth table, p = 7.50 at T/R = 2.7 and H/R =
//! 0.6, breaks the table's rise along the row (6.50, 7.50, 7.70) and down the column
//! (7.00 above, 7.08 below). It is taken here as 7.05, a presumed transcription error;
//! tests/data/eulumdat_ugr.txt shows where that matters.

use super::gonio::{Goniometric, Opening, PhotometricData, PhotometricType};
use crate::error::{bail, Result};
use std::f64::consts::PI;

const N: f64 = f64::NAN;

/// The luminaires' height above the eye, m.
pub const H_M: f64 = 2.0;
/// The spacing of the luminaires over H.
pub const SPACING_TO_HEIGHT: f64 = 0.25;

/// The 19 rooms: (X, Y) in multiples of H, X across the line of sight.
pub const ROOMS: [(f64, f64); 19] = [
    (2.0, 2.0),
    (2.0, 3.0),
    (2.0, 4.0),
    (2.0, 6.0),
    (2.0, 8.0),
    (2.0, 12.0),
    (4.0, 2.0),
    (4.0, 3.0),
    (4.0, 4.0),
    (4.0, 6.0),
    (4.0, 8.0),
    (4.0, 12.0),
    (8.0, 4.0),
    (8.0, 6.0),
    (8.0, 8.0),
    (8.0, 12.0),
    (12.0, 4.0),
    (12.0, 6.0),
    (12.0, 8.0),
];

/// The five reflectance combinations: (ceiling, walls, floor).
pub const REFLECTANCES: [(f64, f64, f64); 5] = [
    (0.7, 0.5, 0.2),
    (0.7, 0.3, 0.2),
    (0.5, 0.5, 0.2),
    (0.5, 0.3, 0.2),
    (0.3, 0.3, 0.2),
];

/// CIE 117:1995 table 4.1: Guth's position index p at T/R = 0, 0.1, …, 3.0 (rows) and
/// H/R = 0, 0.1, …, 1.9 (columns); NaN where the table has none.
#[rustfmt::skip]
const GUTH: [[f64; 20]; 31] = [
    [1.00, 1.26, 1.53, 1.90, 2.35, 2.86, 3.50, 4.20, 5.00, 6.00, 7.00, 8.10, 9.25, 10.35, 11.70, 13.15, 14.70, 16.20, N, N],
    [1.05, 1.22, 1.46, 1.80, 2.20, 2.75, 3.40, 4.10, 4.80, 5.80, 6.80, 8.00, 9.10, 10.30, 11.60, 13.00, 14.60, 16.10, N, N],
    [1.12, 1.30, 1.50, 1.80, 2.20, 2.66, 3.18, 3.88, 4.60, 5.50, 6.50, 7.60, 8.75, 9.85, 11.20, 12.70, 14.00, 15.70, N, N],
    [1.22, 1.38, 1.60, 1.97, 2.25, 2.70, 3.25, 3.90, 4.60, 5.45, 6.45, 7.40, 8.40, 9.50, 10.85, 12.10, 13.70, 15.00, N, N],
    [1.32, 1.47, 1.70, 1.96, 2.35, 2.80, 3.30, 3.90, 4.60, 5.40, 6.40, 7.30, 8.30, 9.40, 10.60, 11.90, 13.20, 14.60, 16.00, N],
    [1.43, 1.60, 1.82, 2.10, 2.48, 2.91, 3.40, 3.98, 4.70, 5.50, 6.40, 7.30, 8.30, 9.40, 10.50, 11.75, 13.00, 14.40, 15.70, N],
    [1.55, 1.72, 1.98, 2.30, 2.65, 3.10, 3.60, 4.10, 4.80, 5.50, 6.40, 7.35, 8.40, 9.40, 10.50, 11.70, 13.00, 14.10, 15.40, N],
    [1.70, 1.88, 2.12, 2.48, 2.87, 3.30, 3.78, 4.30, 4.88, 5.60, 6.50, 7.40, 8.50, 9.50, 10.50, 11.70, 12.85, 14.00, 15.20, N],
    [1.82, 2.00, 2.32, 2.70, 3.08, 3.50, 3.92, 4.50, 5.10, 5.75, 6.60, 7.50, 8.60, 9.50, 10.60, 11.75, 12.80, 14.00, 15.10, N],
    [1.96, 2.20, 2.54, 2.90, 3.30, 3.70, 4.20, 4.75, 5.30, 6.00, 6.75, 7.70, 8.70, 9.65, 10.75, 11.80, 12.90, 14.00, 15.00, 16.00],
    [2.11, 2.40, 2.75, 3.10, 3.50, 3.91, 4.40, 5.00, 5.60, 6.20, 7.00, 7.90, 8.80, 9.75, 10.80, 11.90, 12.95, 14.00, 15.00, 16.00],
    [2.30, 2.55, 2.92, 3.30, 3.72, 4.20, 4.70, 5.25, 5.80, 6.55, 7.20, 8.15, 9.00, 9.90, 10.95, 12.00, 13.00, 14.00, 15.00, 16.00],
    [2.40, 2.75, 3.12, 3.50, 3.90, 4.35, 4.85, 5.50, 6.05, 6.70, 7.50, 8.30, 9.20, 10.00, 11.02, 12.10, 13.10, 14.00, 15.00, 16.00],
    [2.55, 2.90, 3.30, 3.70, 4.20, 4.65, 5.20, 5.70, 6.30, 7.00, 7.70, 8.55, 9.35, 10.20, 11.20, 12.25, 13.20, 14.00, 15.00, 16.00],
    [2.70, 3.10, 3.50, 3.90, 4.35, 4.85, 5.35, 5.85, 6.50, 7.25, 8.00, 8.70, 9.50, 10.40, 11.40, 12.40, 13.25, 14.05, 15.00, 16.00],
    [2.85, 3.15, 3.65, 4.10, 4.55, 5.00, 5.50, 6.20, 6.80, 7.50, 8.20, 8.85, 9.70, 10.55, 11.50, 12.50, 13.30, 14.05, 15.02, 16.00],
    [2.95, 3.40, 3.80, 4.25, 4.75, 5.20, 5.75, 6.30, 7.00, 7.65, 8.40, 9.00, 9.80, 10.80, 11.75, 12.60, 13.40, 14.20, 15.10, 16.00],
    [3.10, 3.55, 4.00, 4.50, 4.90, 5.40, 5.95, 6.50, 7.20, 7.80, 8.50, 9.20, 10.00, 10.85, 11.85, 12.75, 13.45, 14.20, 15.10, 16.00],
    [3.25, 3.70, 4.20, 4.65, 5.10, 5.60, 6.10, 6.75, 7.40, 8.00, 8.65, 9.35, 10.10, 11.00, 11.90, 12.80, 13.50, 14.20, 15.10, 16.00],
    [3.43, 3.86, 4.30, 4.75, 5.20, 5.70, 6.30, 6.90, 7.50, 8.17, 8.80, 9.50, 10.20, 11.00, 12.00, 12.82, 13.55, 14.20, 15.10, 16.00],
    [3.50, 4.00, 4.50, 4.90, 5.35, 5.80, 6.40, 7.10, 7.70, 8.30, 8.90, 9.60, 10.40, 11.10, 12.00, 12.85, 13.60, 14.30, 15.10, 16.00],
    [3.60, 4.17, 4.65, 5.05, 5.50, 6.00, 6.60, 7.20, 7.82, 8.45, 9.00, 9.75, 10.50, 11.20, 12.10, 12.90, 13.70, 14.35, 15.10, 16.00],
    [3.75, 4.25, 4.72, 5.20, 5.60, 6.10, 6.70, 7.35, 8.00, 8.55, 9.15, 9.85, 10.60, 11.30, 12.10, 12.90, 13.70, 14.40, 15.15, 16.00],
    [3.85, 4.35, 4.80, 5.25, 5.70, 6.22, 6.80, 7.40, 8.10, 8.65, 9.30, 9.90, 10.70, 11.40, 12.20, 12.95, 13.70, 14.40, 15.20, 16.00],
    [3.95, 4.40, 4.90, 5.35, 5.80, 6.30, 6.90, 7.50, 8.20, 8.80, 9.40, 10.00, 10.80, 11.50, 12.25, 13.00, 13.75, 14.45, 15.20, 16.00],
    [4.00, 4.50, 4.96, 5.40, 5.85, 6.40, 6.95, 7.55, 8.25, 8.85, 9.50, 10.05, 10.85, 11.55, 12.30, 13.00, 13.80, 14.50, 15.25, 16.00],
    [4.07, 4.55, 5.05, 5.47, 5.95, 6.46, 7.00, 7.65, 8.35, 8.95, 9.55, 10.10, 10.90, 11.60, 12.32, 13.00, 13.80, 14.50, 15.25, 16.00],
    [4.10, 4.60, 5.10, 5.53, 6.00, 6.50, 7.05, 7.70, 8.40, 9.00, 9.60, 10.16, 10.92, 11.63, 12.35, 13.00, 13.80, 14.50, 15.25, 16.00],
    [4.15, 4.62, 5.15, 5.56, 6.05, 6.55, 7.08, 7.73, 8.45, 9.05, 9.65, 10.20, 10.95, 11.65, 12.35, 13.00, 13.80, 14.50, 15.25, 16.00],
    [4.20, 4.65, 5.17, 5.60, 6.07, 6.57, 7.12, 7.75, 8.50, 9.10, 9.70, 10.23, 10.95, 11.65, 12.35, 13.00, 13.80, 14.50, 15.25, 16.00],
    [4.22, 4.67, 5.20, 5.65, 6.12, 6.60, 7.15, 7.80, 8.55, 9.12, 9.70, 10.23, 10.95, 11.65, 12.35, 13.00, 13.80, 14.50, 15.25, 16.00],
];
/// CIE 190:2010 table 4: F_GL1…4 by room index k.
const FGL: [(f64, [f64; 4]); 13] = [
    (1.00, [0.690, 0.109, 0.085, -0.016]),
    (1.20, [0.578, 0.200, 0.127, -0.018]),
    (1.33, [0.528, 0.218, 0.170, -0.017]),
    (1.50, [0.485, 0.215, 0.222, -0.012]),
    (1.60, [0.466, 0.207, 0.249, -0.006]),
    (1.71, [0.448, 0.198, 0.272, 0.005]),
    (2.00, [0.338, 0.257, 0.351, -0.018]),
    (2.40, [0.296, 0.203, 0.449, -0.006]),
    (2.67, [0.280, 0.165, 0.499, 0.006]),
    (3.00, [0.264, 0.125, 0.541, 0.027]),
    (3.43, [0.248, 0.058, 0.628, 0.032]),
    (4.00, [0.239, -0.012, 0.690, 0.058]),
    (4.80, [0.232, -0.084, 0.740, 0.098]),
];
/// CIE 190:2010 table 5: F_T of the walls' illuminance (FW, WW − 1, CW) for each
/// reflectance combination and room.
#[rustfmt::skip]
const FT: [[[f64; 3]; 19]; 5] = [
    // 70/50/20
    [
        [0.220, 0.422, 0.646],
        [0.199, 0.376, 0.571],
        [0.187, 0.351, 0.531],
        [0.174, 0.322, 0.488],
        [0.167, 0.307, 0.466],
        [0.160, 0.290, 0.443],
        [0.187, 0.351, 0.531],
        [0.158, 0.295, 0.439],
        [0.142, 0.265, 0.389],
        [0.124, 0.230, 0.335],
        [0.115, 0.211, 0.307],
        [0.105, 0.190, 0.279],
        [0.115, 0.211, 0.307],
        [0.094, 0.175, 0.247],
        [0.083, 0.155, 0.215],
        [0.071, 0.133, 0.183],
        [0.105, 0.190, 0.279],
        [0.083, 0.153, 0.216],
        [0.071, 0.133, 0.183],
    ],
    // 70/30/20
    [
        [0.188, 0.217, 0.553],
        [0.173, 0.196, 0.497],
        [0.164, 0.184, 0.465],
        [0.154, 0.171, 0.432],
        [0.149, 0.164, 0.415],
        [0.143, 0.156, 0.397],
        [0.164, 0.184, 0.465],
        [0.142, 0.159, 0.393],
        [0.129, 0.144, 0.351],
        [0.114, 0.127, 0.307],
        [0.106, 0.117, 0.283],
        [0.098, 0.106, 0.259],
        [0.106, 0.117, 0.283],
        [0.088, 0.098, 0.231],
        [0.078, 0.088, 0.203],
        [0.067, 0.076, 0.174],
        [0.098, 0.106, 0.259],
        [0.078, 0.086, 0.204],
        [0.067, 0.076, 0.174],
    ],
    // 50/50/20
    [
        [0.198, 0.380, 0.445],
        [0.178, 0.338, 0.393],
        [0.166, 0.314, 0.365],
        [0.154, 0.287, 0.335],
        [0.147, 0.273, 0.320],
        [0.141, 0.257, 0.304],
        [0.166, 0.314, 0.364],
        [0.140, 0.263, 0.301],
        [0.125, 0.235, 0.267],
        [0.108, 0.204, 0.230],
        [0.100, 0.187, 0.211],
        [0.091, 0.167, 0.191],
        [0.100, 0.187, 0.211],
        [0.081, 0.154, 0.169],
        [0.071, 0.137, 0.147],
        [0.061, 0.117, 0.125],
        [0.091, 0.167, 0.191],
        [0.071, 0.134, 0.148],
        [0.061, 0.117, 0.125],
    ],
    // 50/30/20
    [
        [0.172, 0.198, 0.386],
        [0.157, 0.179, 0.346],
        [0.148, 0.167, 0.324],
        [0.138, 0.155, 0.301],
        [0.133, 0.147, 0.288],
        [0.128, 0.140, 0.276],
        [0.148, 0.167, 0.324],
        [0.126, 0.143, 0.272],
        [0.114, 0.129, 0.244],
        [0.100, 0.113, 0.212],
        [0.093, 0.104, 0.196],
        [0.085, 0.094, 0.179],
        [0.093, 0.104, 0.196],
        [0.076, 0.087, 0.158],
        [0.067, 0.078, 0.140],
        [0.058, 0.067, 0.120],
        [0.085, 0.094, 0.179],
        [0.068, 0.077, 0.140],
        [0.058, 0.067, 0.120],
    ],
    // 30/30/20
    [
        [0.157, 0.181, 0.227],
        [0.141, 0.162, 0.203],
        [0.132, 0.151, 0.190],
        [0.123, 0.139, 0.176],
        [0.118, 0.132, 0.169],
        [0.113, 0.124, 0.161],
        [0.132, 0.151, 0.190],
        [0.112, 0.128, 0.159],
        [0.100, 0.115, 0.142],
        [0.087, 0.101, 0.124],
        [0.081, 0.092, 0.114],
        [0.074, 0.083, 0.104],
        [0.081, 0.092, 0.114],
        [0.066, 0.077, 0.092],
        [0.058, 0.069, 0.081],
        [0.049, 0.059, 0.069],
        [0.074, 0.083, 0.104],
        [0.058, 0.067, 0.081],
        [0.049, 0.059, 0.069],
    ],
];
const ROOM_K: [f64; 19] = [
    1.00, 1.20, 1.33, 1.50, 1.60, 1.71, 1.33, 1.71, 2.00, 2.40, 2.67, 3.00, 2.67, 3.43, 4.00, 4.80,
    3.00, 4.00, 4.80,
];

/// A luminaire's UGR table: per room (`ROOMS`) and reflectance combination
/// (`REFLECTANCES`), seen crosswise and endwise. NaN where no luminaire counts.
#[derive(Clone, Debug, PartialEq)]
pub struct UgrTable {
    pub crosswise: [[f64; 5]; 19],
    pub endwise: [[f64; 5]; 19],
    /// The luminaire's flux the table is for, lm.
    pub flux_lm: f64,
}

/// Guth's index of CIE 117's table at H/R and T/R (bilinear), or None outside it or next
/// to a cell it leaves empty.
pub fn guth_table(h_r: f64, t_r: f64) -> Option<f64> {
    let (x, y) = (h_r.abs() / 0.1, t_r.abs() / 0.1);
    if x > 19.0 + 1e-9 || y > 30.0 + 1e-9 || x.is_nan() || y.is_nan() {
        return None;
    }
    let (i, j) = ((y.floor() as usize).min(29), (x.floor() as usize).min(18));
    let (s, t) = (y - i as f64, x - j as f64);
    let v = (1.0 - s) * ((1.0 - t) * GUTH[i][j] + t * GUTH[i][j + 1])
        + s * ((1.0 - t) * GUTH[i + 1][j] + t * GUTH[i + 1][j + 1]);
    v.is_finite().then_some(v)
}

/// Intensity (cd) of stored plane `h` at γ `deg`, linear in γ, 0 outside the table.
fn plane_at(data: &PhotometricData, h: usize, deg: f64) -> f64 {
    let (g, v) = (&data.vertical, &data.candela[h]);
    if deg < g[0] || deg > g[g.len() - 1] {
        return 0.0;
    }
    let k = g.partition_point(|&a| a <= deg).clamp(1, g.len() - 1) - 1;
    let t = (deg - g[k]) / (g[k + 1] - g[k]).max(1e-300);
    v[k] * (1.0 - t) + v[k + 1] * t
}

/// The UGR table of a type C distribution `data` (candela, absolute) emitting `flux_lm`
/// (its luminaire's flux: what the background's transfer is scaled to). Refused without
/// a luminous area (IMAP_ERR_INVALID_ARGUMENT: the luminance needs one) and for type B
/// files (IMAP_ERR_UNSUPPORTED).
pub fn ugr_table(data: &PhotometricData, flux_lm: f64) -> Result<UgrTable> {
    data.validate()?;
    if data.kind != PhotometricType::C {
        bail!(
            ImapErrUnsupported,
            "a UGR table needs type C photometry (CIE 190's luminaires); this file is type B"
        );
    }
    if matches!(data.opening, Opening::Point) {
        bail!(
            ImapErrInvalidArgument,
            "the file gives no luminous area (its opening is a point): a UGR table needs the luminaires' luminance, intensity over luminous area"
        );
    }
    if !(flux_lm.is_finite() && flux_lm > 0.0) {
        bail!(
            ImapErrInvalidArgument,
            "flux_lm = {flux_lm} must be positive (the luminaire's flux, lm)"
        );
    }
    // Zonal fluxes at the 10° zones' middles, the stored planes averaged.
    let dz = 10f64.to_radians();
    let mut zone = [0.0; 18];
    for (m, z) in zone.iter_mut().enumerate() {
        let g = 5.0 + 10.0 * m as f64;
        let mean = (0..data.horizontal.len())
            .map(|h| plane_at(data, h, g))
            .sum::<f64>()
            / data.horizontal.len() as f64;
        *z = mean * 2.0 * PI * g.to_radians().sin() * dz;
    }
    let total: f64 = zone.iter().sum();
    if total <= 0.0 {
        bail!(ImapErrNoLight, "the distribution gives no light");
    }
    zone.iter_mut().for_each(|z| *z *= flux_lm / total);
    let down: f64 = zone[..9].iter().sum();
    let up: f64 = zone[9..].iter().sum();
    let cumulative = [
        zone[..4].iter().sum::<f64>() + 0.130 * zone[4],
        zone[..6].iter().sum::<f64>(),
        zone[..7].iter().sum::<f64>() + 0.547 * zone[7],
        down,
    ];
    // The distribution on the whole sphere (the file's symmetry applied), bilinear in C
    // and γ: for type C its azimuth is C and its polar angle γ.
    let dist = Goniometric::new(data, 1.0)?;
    let mut table = UgrTable {
        crosswise: [[N; 5]; 19],
        endwise: [[N; 5]; 19],
        flux_lm,
    };
    let s = SPACING_TO_HEIGHT * H_M;
    for (room, &(xh, yh)) in ROOMS.iter().enumerate() {
        let (x, y) = (xh * H_M, yh * H_M);
        let fgl = FGL
            .iter()
            .find(|(k, _)| (k - ROOM_K[room]).abs() < 1e-9)
            .expect("every room's index has its factors")
            .1;
        let direct_floor: f64 = cumulative.iter().zip(&fgl).map(|(c, f)| c * f).sum();
        let direct_walls = down - direct_floor;
        let across = (x / s / 2.0).round() as usize;
        let along = (y / s).round() as usize;
        let count = (2 * across * along) as f64;
        let walls = 2.0 * H_M * (x + y);
        let mut lb = [0.0; 5];
        for (k, l) in lb.iter_mut().enumerate() {
            let [fw, ww, cw] = FT[k][room];
            let e_wid = count / walls * (direct_floor * fw + direct_walls * ww + up * cw);
            *l = e_wid / PI;
        }
        for (crosswise, out) in [(true, &mut table.crosswise), (false, &mut table.endwise)] {
            let mut sum = 0.0;
            for i in 0..across {
                let t = (i as f64 + 0.5) * s;
                for j in 0..along {
                    let r = (j as f64 + 0.5) * s;
                    let horizontal = (r * r + t * t).sqrt();
                    let gamma = horizontal.atan2(H_M).to_degrees();
                    if t / r > 3.0 || gamma > 85.0 {
                        continue;
                    }
                    let beside = t.atan2(r).to_degrees();
                    let c = if crosswise { beside } else { 90.0 - beside };
                    let (cr, gr) = (c.to_radians(), gamma.to_radians());
                    let area = data.opening.projected_area_m2(
                        gr.sin() * cr.cos(),
                        gr.sin() * cr.sin(),
                        gr.cos(),
                    );
                    let i_cd = dist.intensity(cr, gr);
                    let Some(p) = guth_table(H_M / r, t / r) else {
                        continue;
                    };
                    if area <= 0.0 || i_cd <= 0.0 {
                        continue;
                    }
                    let r2 = horizontal * horizontal + H_M * H_M;
                    let l = i_cd / area;
                    // Both sides of the line of sight.
                    sum += 2.0 * l * l * (area / r2) / (p * p);
                }
            }
            for (k, o) in out[room].iter_mut().enumerate() {
                if sum > 0.0 && lb[k] > 0.0 {
                    *o = 8.0 * (0.25 / lb[k] * sum).log10();
                }
            }
        }
    }
    Ok(table)
}

/// The UGR table of an EULUMDAT file, for its light output ratio times its first lamp
/// set's flux.
pub fn ugr_table_ldt(text: &str) -> Result<UgrTable> {
    let f = super::ldt::parse(text)?;
    ugr_table(&f.data, f.lor_percent / 100.0 * f.lamp_flux)
}

/// The UGR table of an IES LM-63 file, for its table's own flux.
pub fn ugr_table_ies(text: &str) -> Result<UgrTable> {
    let f = super::ies::parse(text, None)?;
    let flux = Goniometric::new(&f.data, 1.0)?.flux();
    ugr_table(&f.data, flux)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guths_table_reads_at_its_cells_and_between_them() {
        assert_eq!(guth_table(0.0, 0.0), Some(1.0));
        assert!((guth_table(1.0, 0.0).unwrap() - 7.0).abs() < 1e-12);
        assert!((guth_table(0.5, 1.0).unwrap() - 3.91).abs() < 1e-12);
        // Halfway between 1.00 and 1.26, and between the two rows' means.
        assert!((guth_table(0.05, 0.0).unwrap() - 1.13).abs() < 1e-12);
        assert!(guth_table(1.85, 0.0).is_none(), "next to an empty cell");
        assert!(guth_table(0.5, 3.2).is_none() && guth_table(2.0, 0.5).is_none());
        // The table rises away from the line of sight along every row it fills.
        for row in GUTH.iter() {
            let filled: Vec<f64> = row.iter().copied().filter(|v| v.is_finite()).collect();
            assert!(filled.windows(2).all(|w| w[1] >= w[0]), "{row:?}");
        }
    }
}

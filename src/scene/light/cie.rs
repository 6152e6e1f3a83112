//! The CIE standard general skies (ISO 15469:2004 / CIE S 011/E:2003): each type's
//! gradation and indicatrix parameters and its relative luminance L/L_z.

use std::f64::consts::FRAC_PI_2;

/// The CIE standard general sky's gradation (a, b) and indicatrix (c, d, e) parameters,
/// types 1–15 (ISO 15469:2004 / CIE S 011/E:2003, table 1).
pub const CIE_SKY_PARAMETERS: [[f64; 5]; 15] = [
    [4.0, -0.70, 0.0, -1.0, 0.00],
    [4.0, -0.70, 2.0, -1.5, 0.15],
    [1.1, -0.80, 0.0, -1.0, 0.00],
    [1.1, -0.80, 2.0, -1.5, 0.15],
    [0.0, -1.00, 0.0, -1.0, 0.00],
    [0.0, -1.00, 2.0, -1.5, 0.15],
    [0.0, -1.00, 5.0, -2.5, 0.30],
    [0.0, -1.00, 10.0, -3.0, 0.45],
    [-1.0, -0.55, 2.0, -1.5, 0.15],
    [-1.0, -0.55, 5.0, -2.5, 0.30],
    [-1.0, -0.55, 10.0, -3.0, 0.45],
    [-1.0, -0.32, 10.0, -3.0, 0.45],
    [-1.0, -0.32, 16.0, -3.0, 0.30],
    [-1.0, -0.15, 16.0, -3.0, 0.30],
    [-1.0, -0.15, 24.0, -2.8, 0.15],
];

/// L/L_z of CIE standard general sky `kind` (1–15) at an element of zenith angle `z`
/// and angular distance `chi` from the sun, the sun at zenith angle `zs` (radians); 0
/// below the horizon.
pub fn cie_luminance(kind: u32, z: f64, chi: f64, zs: f64) -> f64 {
    let p = &CIE_SKY_PARAMETERS[(kind.clamp(1, 15) - 1) as usize];
    let cz = z.cos();
    if cz <= 0.0 {
        return 0.0;
    }
    cie_relative(p, cz, chi, zs)
}

/// The CIE sky's L/L_z at zenith angle `z` (cos `cz`) and angle `chi` from the sun, for
/// the sun at zenith angle `zs`.
pub(super) fn cie_relative(p: &[f64; 5], cz: f64, chi: f64, zs: f64) -> f64 {
    let [a, b, c, d, e] = *p;
    let gradation = |cz: f64| {
        if cz <= 0.0 {
            1.0
        } else {
            1.0 + a * (b / cz).exp()
        }
    };
    let indicatrix =
        |x: f64| 1.0 + c * ((d * x).exp() - (d * FRAC_PI_2).exp()) + e * x.cos().powi(2);
    indicatrix(chi) * gradation(cz) / (indicatrix(zs) * gradation(1.0))
}

//! The Perez all-weather sky (Perez, Seals & Michalsky 1993) and the sky conditions and
//! luminous efficacies of Perez, Ineichen, Seals, Michalsky & Stewart (1990) that drive
//! it from a weather file's direct-normal and diffuse-horizontal irradiance.
//!
//! The relative luminance of a sky element at zenith angle ζ and angle γ from the sun is
//!
//!   l(ζ, γ) = [1 + a exp(b / cos ζ)] · [1 + c exp(d γ) + e cos² γ],
//!
//! its five parameters functions of the sky's clearness ε (one of eight bins), its
//! brightness Δ and the sun's zenith angle Z (radians): x = x₁ + x₂ Z + Δ (x₃ + x₄ Z), but
//! for c and d in the first (overcast) bin, c = exp((Δ (c₁ + c₂ Z))^c₃) − c₄ and
//! d = −exp(Δ (d₁ + d₂ Z)) + d₃ + Δ d₄.

use crate::error::{bail, check_finite_scalar, check_range, Result};
use std::f64::consts::{FRAC_PI_2, PI};

/// The lower edges of the eight clearness (ε) bins of Perez et al. 1990, table 1; the
/// last bin has no upper edge.
pub const PEREZ_CLEARNESS_BINS: [f64; 8] = [1.0, 1.065, 1.23, 1.5, 1.95, 2.8, 4.5, 6.2];

/// The all-weather model's coefficients (Perez, Seals & Michalsky 1993, Solar Energy
/// 50(3), table 1): per clearness bin, a₁…a₄, b₁…b₄, c₁…c₄, d₁…d₄, e₁…e₄.
pub const PEREZ_SKY_COEFFICIENTS: [[f64; 20]; 8] = [
    [
        1.3525, -0.2576, -0.2690, -1.4366, -0.7670, 0.0007, 1.2734, -0.1233, 2.8000, 0.6004,
        1.2375, 1.0000, 1.8734, 0.6297, 0.9738, 0.2809, 0.0356, -0.1246, -0.5718, 0.9938,
    ],
    [
        -1.2219, -0.7730, 1.4148, 1.1016, -0.2054, 0.0367, -3.9128, 0.9156, 6.9750, 0.1774, 6.4477,
        -0.1239, -1.5798, -0.5081, -1.7812, 0.1080, 0.2624, 0.0672, -0.2190, -0.4285,
    ],
    [
        -1.1000, -0.2515, 0.8952, 0.0156, 0.2782, -0.1812, -4.5000, 1.1766, 24.7219, -13.0812,
        -37.7000, 34.8438, -5.0000, 1.5218, 3.9229, -2.6204, -0.0156, 0.1597, 0.4199, -0.5562,
    ],
    [
        -0.5484, -0.6654, -0.2672, 0.7117, 0.7234, -0.6219, -5.6812, 2.6297, 33.3389, -18.3000,
        -62.2500, 52.0781, -3.5000, 0.0016, 1.1477, 0.1062, 0.4659, -0.3296, -0.0876, -0.0329,
    ],
    [
        -0.6000, -0.3566, -2.5000, 2.3250, 0.2937, 0.0496, -5.6812, 1.8415, 21.0000, -4.7656,
        -21.5906, 7.2492, -3.5000, -0.1554, 1.4062, 0.3988, 0.0032, 0.0766, -0.0656, -0.1294,
    ],
    [
        -1.0156, -0.3670, 1.0078, 1.4051, 0.2875, -0.5328, -3.8500, 3.3750, 14.0000, -0.9999,
        -7.1406, 7.5469, -3.4000, -0.1078, -1.0750, 1.5702, -0.0672, 0.4016, 0.3017, -0.4844,
    ],
    [
        -1.0000, 0.0211, 0.5025, -0.5119, -0.3000, 0.1922, 0.7023, -1.6317, 19.0000, -5.0000,
        1.2438, -1.9094, -4.0000, 0.0250, 0.3844, 0.2656, 1.0468, -0.3788, -2.4517, 1.4656,
    ],
    [
        -1.0500, 0.0289, 0.4260, 0.3590, -0.3250, 0.1156, 0.7781, 0.0025, 31.0625, -14.5000,
        -46.1148, 55.3750, -7.2312, 0.4050, 13.3500, 0.6234, 1.5000, -0.6426, 1.8564, 0.5636,
    ],
];

/// The diffuse luminous efficacy model (Perez et al. 1990, table 4, eq. 7): per clearness
/// bin a, b, c, d of K = a + b W + c cos Z + d ln Δ, lm/W.
pub const PEREZ_DIFFUSE_EFFICACY: [[f64; 4]; 8] = [
    [97.24, -0.46, 12.00, -8.91],
    [107.22, 1.15, 0.59, -3.95],
    [104.97, 2.96, -5.53, -8.77],
    [102.39, 5.59, -13.95, -13.90],
    [100.71, 5.94, -22.75, -23.74],
    [106.42, 3.83, -36.15, -28.83],
    [141.88, 1.90, -53.24, -14.03],
    [152.23, 0.35, -45.27, -7.98],
];

/// The direct luminous efficacy model (Perez et al. 1990, table 4, eq. 8): per clearness
/// bin a, b, c, d of K = max(0, a + b W + c exp(5.73 Z − 5) + d Δ), lm/W.
pub const PEREZ_DIRECT_EFFICACY: [[f64; 4]; 8] = [
    [57.20, -4.55, -2.98, 117.12],
    [98.99, -3.46, -1.21, 12.38],
    [109.83, -4.90, -1.71, -8.81],
    [110.34, -5.84, -1.99, -4.56],
    [106.36, -3.97, -1.75, -6.16],
    [107.19, -1.25, -1.51, -26.73],
    [105.75, 0.77, -1.26, -34.44],
    [101.18, 1.58, -1.10, -8.29],
];

/// The solar constant the clearness and brightness are defined with, W/m² (Perez et al.
/// 1990).
pub const SOLAR_CONSTANT_W_PER_M2: f64 = 1367.0;

/// The clearness bin (0–7) of clearness `epsilon` (values below 1 fall in the first).
pub fn perez_bin(epsilon: f64) -> usize {
    PEREZ_CLEARNESS_BINS
        .iter()
        .rposition(|&lo| epsilon >= lo)
        .unwrap_or(0)
}

/// The Perez sky's (a, b, c, d, e) for clearness `epsilon` ≥ 1, brightness `delta` > 0
/// and the sun at zenith angle `sun_zenith` (radians; the model's fit covers 0–π/2, and
/// a sun below the horizon is taken at the horizon). As in Radiance's gendaylit and
/// gendaymtx, Δ is raised to 0.2 in the bins of ε 1.065–2.8, where the fit is not made
/// for darker skies. One guard of ours: b is limited to ≤ 0. Where the fit gives b > 0
/// (overcast skies with Δ > 0.6, clear skies with Δ < 0.08) the gradation grows without
/// bound toward the horizon, or, with a < 0, falls below zero; with b ≤ 0 it stays
/// between 1 + a and 1.
pub fn perez_parameters(epsilon: f64, delta: f64, sun_zenith: f64) -> [f64; 5] {
    let bin = perez_bin(epsilon);
    let z = sun_zenith.clamp(0.0, FRAC_PI_2);
    let delta = if (1..=4).contains(&bin) {
        delta.max(0.2)
    } else {
        delta
    };
    let x = &PEREZ_SKY_COEFFICIENTS[bin];
    let linear = |k: usize| {
        let q = &x[4 * k..4 * k + 4];
        q[0] + q[1] * z + delta * (q[2] + q[3] * z)
    };
    let mut p = [linear(0), linear(1), linear(2), linear(3), linear(4)];
    if bin == 0 {
        p[2] = (delta * (x[8] + x[9] * z)).powf(x[10]).exp() - x[11];
        p[3] = -(delta * (x[12] + x[13] * z)).exp() + x[14] + delta * x[15];
    }
    p[1] = p[1].min(0.0);
    p
}

/// The Perez sky's relative luminance l(ζ, γ) at an element whose zenith angle has cosine
/// `cos_zeta` (> 0) at angle `gamma` (radians) from the sun; clipped at 0 (the fit can
/// dip below it near the horizon of a clear sky).
#[inline]
pub fn perez_relative(p: &[f64; 5], cos_zeta: f64, gamma: f64) -> f64 {
    let [a, b, c, d, e] = *p;
    let cg = gamma.cos();
    let gradation = 1.0 + a * (b / cos_zeta.max(1e-9)).exp();
    let indicatrix = 1.0 + c * (d * gamma).exp() + e * cg * cg;
    (gradation * indicatrix).max(0.0)
}

/// An hour's sky as the Perez models describe it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PerezSky {
    /// The sky's clearness ε (1 for a fully overcast sky, up to ~12 for the clearest).
    pub clearness: f64,
    /// The sky's brightness Δ = E_dh · m / E₀.
    pub brightness: f64,
    /// The clearness bin, 0–7.
    pub bin: usize,
    /// The atmosphere's precipitable water, cm.
    pub precipitable_water_cm: f64,
    /// The diffuse horizontal illuminance, lx (the diffuse irradiance times the diffuse
    /// efficacy).
    pub diffuse_horizontal_lx: f64,
    /// The direct normal illuminance, lx (the direct irradiance times the direct
    /// efficacy).
    pub direct_normal_lx: f64,
}

/// Air mass by Kasten (1966) for the sun at zenith angle `z` (radians, ≤ π/2).
pub fn air_mass(z: f64) -> f64 {
    let z = z.clamp(0.0, FRAC_PI_2);
    1.0 / (z.cos() + 0.15 * (93.885 - z.to_degrees()).powf(-1.253))
}

/// The Earth's orbital eccentricity correction (E₀ / mean) on day `day_of_year` (1–366),
/// by Spencer's series as Perez et al. use it.
pub fn eccentricity(day_of_year: u32) -> f64 {
    let g = 2.0 * PI * (day_of_year as f64 - 1.0) / 365.0;
    1.00011
        + 0.034221 * g.cos()
        + 0.00128 * g.sin()
        + 0.000719 * (2.0 * g).cos()
        + 0.000077 * (2.0 * g).sin()
}

/// The atmosphere's precipitable water, cm, from the surface dew point (°C), by Perez et
/// al. 1990, eq. 3 (Wright, Perez & Michalsky 1989).
pub fn precipitable_water(dew_point_c: f64) -> f64 {
    (0.07 * dew_point_c - 0.075).exp()
}

/// The Perez sky of an hour from its direct normal and diffuse horizontal irradiance
/// (W/m², the whole solar spectrum, as weather files give them), the sun's zenith angle
/// (degrees; one beyond 90° — twilight — is taken at the horizon), the day of the year
/// and the precipitable water (cm; `precipitable_water` makes it from a dew point).
/// `None` when the sky gives no diffuse light (E_dh ≤ 0).
pub fn perez_sky(
    direct_normal_w: f64,
    diffuse_horizontal_w: f64,
    sun_zenith_deg: f64,
    day_of_year: u32,
    precipitable_water_cm: f64,
) -> Result<Option<PerezSky>> {
    check_finite_scalar("direct_normal_irradiance", direct_normal_w)?;
    check_finite_scalar("diffuse_horizontal_irradiance", diffuse_horizontal_w)?;
    check_range("direct_normal_irradiance", direct_normal_w, 0.0, 2000.0)?;
    check_range(
        "diffuse_horizontal_irradiance",
        diffuse_horizontal_w,
        0.0,
        2000.0,
    )?;
    check_range("sun_zenith_deg", sun_zenith_deg, 0.0, 180.0)?;
    check_range("precipitable_water_cm", precipitable_water_cm, 0.0, 20.0)?;
    if !(1..=366).contains(&day_of_year) {
        bail!(
            ImapErrInvalidArgument,
            "day_of_year = {day_of_year}: it must be 1–366"
        );
    }
    if diffuse_horizontal_w <= 0.0 {
        return Ok(None);
    }
    let z = sun_zenith_deg.to_radians().min(FRAC_PI_2);
    let z3 = 1.041 * z.powi(3);
    let clearness =
        ((diffuse_horizontal_w + direct_normal_w) / diffuse_horizontal_w + z3) / (1.0 + z3);
    let brightness =
        diffuse_horizontal_w * air_mass(z) / (SOLAR_CONSTANT_W_PER_M2 * eccentricity(day_of_year));
    let bin = perez_bin(clearness);
    let w = precipitable_water_cm;
    let [a, b, c, d] = PEREZ_DIFFUSE_EFFICACY[bin];
    let diffuse_efficacy = (a + b * w + c * z.cos() + d * brightness.ln()).max(0.0);
    let [a, b, c, d] = PEREZ_DIRECT_EFFICACY[bin];
    let direct_efficacy = (a + b * w + c * (5.73 * z - 5.0).exp() + d * brightness).max(0.0);
    Ok(Some(PerezSky {
        clearness,
        brightness,
        bin,
        precipitable_water_cm: w,
        diffuse_horizontal_lx: diffuse_horizontal_w * diffuse_efficacy,
        direct_normal_lx: direct_normal_w * direct_efficacy,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_follow_the_clearness_table() {
        assert_eq!(perez_bin(0.9), 0);
        assert_eq!(perez_bin(1.0), 0);
        assert_eq!(perez_bin(1.0649), 0);
        assert_eq!(perez_bin(1.065), 1);
        assert_eq!(perez_bin(2.8), 5);
        assert_eq!(perez_bin(6.19), 6);
        assert_eq!(perez_bin(40.0), 7);
    }

    #[test]
    fn an_overcast_sky_is_brighter_at_the_zenith_and_a_clear_one_around_the_sun() {
        let z = 40f64.to_radians();
        // Overcast: ε 1.02, Δ 0.3. Clear: ε 8, Δ 0.15.
        let o = perez_parameters(1.02, 0.3, z);
        let zenith = perez_relative(&o, 1.0, z);
        let horizon = perez_relative(&o, 0.02, z + 0.5);
        assert!(zenith > 1.5 * horizon, "{zenith} {horizon}");
        let c = perez_parameters(8.0, 0.15, z);
        let near_sun = perez_relative(&c, z.cos(), 0.05);
        let away = perez_relative(&c, z.cos(), 2.0);
        assert!(near_sun > 10.0 * away, "{near_sun} {away}");
    }

    #[test]
    fn b_never_lets_the_gradation_grow_toward_the_horizon() {
        for (bin, lo) in PEREZ_CLEARNESS_BINS.iter().enumerate() {
            let eps = lo + 0.01;
            for delta in [0.01, 0.05, 0.3, 0.6, 1.0] {
                for zd in [0.0, 30.0, 60.0, 89.0] {
                    let p = perez_parameters(eps, delta, f64::to_radians(zd));
                    assert!(p[1] <= 0.0);
                    let l = perez_relative(&p, 1e-6, 1.0);
                    assert!(l.is_finite() && l >= 0.0, "{bin} {delta} {zd}: {l}");
                }
            }
        }
    }

    #[test]
    fn conditions_follow_their_definitions() {
        // ε of a sky with no direct light is 1, whatever the sun's height.
        let s = perez_sky(0.0, 100.0, 30.0, 172, 2.0).unwrap().unwrap();
        assert!((s.clearness - 1.0).abs() < 1e-12 && s.bin == 0);
        assert_eq!(s.direct_normal_lx, 0.0);
        // Δ at the zenith: E_dh / (1367 E₀) × m(0).
        let m0 = 1.0 / (1.0 + 0.15 * 93.885f64.powf(-1.253));
        let s = perez_sky(500.0, 100.0, 0.0, 1, 2.0).unwrap().unwrap();
        let e0 = 1.00011 + 0.034221 + 0.000719;
        assert!((s.brightness - 100.0 * m0 / (1367.0 * e0)).abs() < 1e-12);
        assert!((s.clearness - 6.0).abs() < 1e-12 && s.bin == 6);
        // No diffuse light, no sky.
        assert_eq!(perez_sky(800.0, 0.0, 30.0, 100, 2.0).unwrap(), None);
        // The efficacies are daylight's: 90–150 lm/W.
        let s = perez_sky(600.0, 150.0, 40.0, 172, 2.0).unwrap().unwrap();
        let kd = s.diffuse_horizontal_lx / 150.0;
        let kb = s.direct_normal_lx / 600.0;
        assert!(
            (90.0..150.0).contains(&kd) && (80.0..120.0).contains(&kb),
            "{kd} {kb}"
        );
        // Twilight: the sun below the horizon is taken at it.
        let t = perez_sky(0.0, 5.0, 93.0, 172, 2.0).unwrap().unwrap();
        let h = perez_sky(0.0, 5.0, 90.0, 172, 2.0).unwrap().unwrap();
        assert_eq!(t, h);
    }

    #[test]
    fn bad_conditions_are_refused_by_name() {
        let e = |r: Result<Option<PerezSky>>| r.unwrap_err().to_string();
        assert!(e(perez_sky(f64::NAN, 1.0, 0.0, 1, 2.0)).contains("direct_normal"));
        assert!(e(perez_sky(1.0, -1.0, 0.0, 1, 2.0)).contains("diffuse_horizontal"));
        assert!(e(perez_sky(1.0, 1.0, 190.0, 1, 2.0)).contains("sun_zenith_deg"));
        assert!(e(perez_sky(1.0, 1.0, 10.0, 0, 2.0)).contains("day_of_year"));
        assert!(e(perez_sky(1.0, 1.0, 10.0, 1, -1.0)).contains("precipitable_water"));
    }
}

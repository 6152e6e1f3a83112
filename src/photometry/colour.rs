//! From band values to photometric and colorimetric ones: luminous efficacy per band,
//! tristimulus values, chromaticity and correlated colour temperature.
//!
//! The rules (docs/photometry.md):
//! - Spectral contexts: a band's luminous efficacy is Km = 683 lm/W times the mean of V(λ)
//!   over the band's interval (the band's power taken as spread evenly across it), and its
//!   X, Y, Z weights likewise with x̄, ȳ, z̄. So E_v = 683 Σ_i E_i V̄_i, the band-sum form of
//!   683 ∫ E(λ) V(λ) dλ; light outside the bands' intervals is not simulated and not counted.
//! - RGB contexts: the three bands are linear Rec. 709 (sRGB) primaries, and R = G = B is
//!   D65 white: E_v = K_rgb (Y_R R + Y_G G + Y_B B) with (Y_R, Y_G, Y_B) the Y row of the
//!   Rec. 709 → XYZ matrix (0.2126, 0.7152, 0.0722) and K_rgb = 3 × the luminous efficacy
//!   of D65 radiation between 380 and 780 nm: one watt in each band is three watts of D65
//!   light in the visible range.

use super::spectrum::{cmf, d65, integrate, Spectrum, C2};
use crate::error::{bail, Result};
use crate::spectral::Bands;
use std::sync::OnceLock;

/// Maximum luminous efficacy for photopic vision, lm/W.
pub const KM: f64 = 683.0;

/// The Rec. 709 / sRGB primaries and white (D65) chromaticities.
const PRIMARIES: [[f64; 2]; 3] = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]];
const WHITE_D65: [f64; 2] = [0.3127, 0.3290];

/// The linear Rec. 709 → CIE XYZ matrix (rows X, Y, Z), derived from the primaries' and
/// the white point's chromaticities (white → Y = 1).
pub fn rgb_to_xyz() -> [[f64; 3]; 3] {
    let xyz = |c: [f64; 2]| [c[0] / c[1], 1.0, (1.0 - c[0] - c[1]) / c[1]];
    let p = PRIMARIES.map(xyz);
    let w = xyz(WHITE_D65);
    // Solve P · s = w for the primaries' scales s (P's columns are the primaries).
    let m = [
        [p[0][0], p[1][0], p[2][0]],
        [p[0][1], p[1][1], p[2][1]],
        [p[0][2], p[1][2], p[2][2]],
    ];
    let s = solve3(m, w);
    let mut out = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            out[r][c] = m[r][c] * s[c];
        }
    }
    out
}

/// CIE XYZ → linear Rec. 709.
pub fn xyz_to_rgb(xyz: [f64; 3]) -> [f64; 3] {
    solve3(rgb_to_xyz(), xyz)
}

fn det3(m: [[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Cramer's rule for a 3 × 3 system.
fn solve3(m: [[f64; 3]; 3], b: [f64; 3]) -> [f64; 3] {
    let d = det3(m);
    let mut out = [0.0; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let mut mc = m;
        for r in 0..3 {
            mc[r][c] = b[r];
        }
        *o = det3(mc) / d;
    }
    out
}

/// Luminous efficacy of D65 radiation between 380 and 780 nm, lm/W.
pub fn d65_visible_efficacy() -> f64 {
    static K: OnceLock<f64> = OnceLock::new();
    *K.get_or_init(|| {
        let lum = integrate(380.0, 780.0, |nm| d65(nm) * cmf(nm)[1]);
        let pow = integrate(380.0, 780.0, d65);
        KM * lum / pow
    })
}

/// K_rgb: lumens per watt of R = G = B light in an RGB context, per unit of Y weight.
pub fn rgb_efficacy_scale() -> f64 {
    3.0 * d65_visible_efficacy()
}

/// What a watt in each band is worth: lumens, and X, Y, Z (in lumens: Y is the lumens).
#[derive(Clone, Debug, PartialEq)]
pub struct BandPhotometry {
    /// lm per W of each band.
    pub efficacy: Vec<f64>,
    /// X, Y, Z per W of each band (Y = efficacy).
    pub xyz: Vec<[f64; 3]>,
}

impl BandPhotometry {
    pub fn new(bands: &Bands) -> Self {
        let xyz: Vec<[f64; 3]> = if bands.rgb {
            let m = rgb_to_xyz();
            let k = rgb_efficacy_scale();
            (0..3)
                .map(|c| [k * m[0][c], k * m[1][c], k * m[2][c]])
                .collect()
        } else {
            (0..bands.count())
                .map(|i| {
                    let (lo, hi) = bands.interval(i);
                    let w = if hi > lo { hi - lo } else { 1.0 };
                    let mut out = [0.0; 3];
                    for (k, o) in out.iter_mut().enumerate() {
                        *o = KM * integrate(lo, hi, |nm| cmf(nm)[k]) / w;
                    }
                    out
                })
                .collect()
        };
        BandPhotometry {
            efficacy: xyz.iter().map(|c| c[1]).collect(),
            xyz,
        }
    }

    /// Lumens (or lux, for W/m²) of band values.
    pub fn luminous(&self, values: &[f64]) -> f64 {
        values.iter().zip(&self.efficacy).map(|(v, k)| v * k).sum()
    }

    /// X, Y, Z of band values (Y in lm or lx).
    pub fn tristimulus(&self, values: &[f64]) -> [f64; 3] {
        let mut out = [0.0; 3];
        for (v, w) in values.iter().zip(&self.xyz) {
            for k in 0..3 {
                out[k] += v * w[k];
            }
        }
        out
    }
}

/// Relative power per band of `spectrum` in a context with `bands`: for RGB contexts the
/// linear Rec. 709 colour of the spectrum (negative components, colours outside the
/// Rec. 709 gamut, clipped to 0).
pub fn spectrum_bands(spectrum: &Spectrum, bands: &Bands) -> Vec<f64> {
    if !bands.rgb {
        return super::spectrum::band_powers(spectrum, bands);
    }
    match spectrum {
        Spectrum::Equal => vec![1.0; 3],
        Spectrum::Rgb(c) => c.to_vec(),
        Spectrum::Bands(v) => v.clone(),
        s => {
            let xyz = [0, 1, 2].map(|k| integrate(360.0, 830.0, |nm| s.at(nm) * cmf(nm)[k]));
            xyz_to_rgb(xyz).iter().map(|&c| c.max(0.0)).collect()
        }
    }
}

/// Chromaticity (x, y) of tristimulus values; None for black.
pub fn chromaticity(xyz: [f64; 3]) -> Option<[f64; 2]> {
    let s = xyz[0] + xyz[1] + xyz[2];
    (s > 0.0 && s.is_finite()).then(|| [xyz[0] / s, xyz[1] / s])
}

/// CIE 1960 (u, v) of (x, y).
fn uv(xy: [f64; 2]) -> [f64; 2] {
    let d = -2.0 * xy[0] + 12.0 * xy[1] + 3.0;
    [4.0 * xy[0] / d, 6.0 * xy[1] / d]
}

/// (u, v) of a Planckian radiator at `t` K, from the 1 nm colour-matching functions.
fn planck_uv(t: f64) -> [f64; 2] {
    let xyz = [0, 1, 2].map(|k| {
        (0..=470)
            .map(|i| {
                let nm = 360.0 + i as f64;
                let l = nm * 1e-9;
                let x = C2 / (l * t);
                let m = if x > 700.0 {
                    0.0
                } else {
                    1.0 / (l.powi(5) * x.exp_m1())
                };
                m * cmf(nm)[k]
            })
            .sum::<f64>()
    });
    uv(chromaticity(xyz).expect("a Planckian radiator has colour"))
}

/// The Planckian locus, (T, u, v), at temperatures 0.25 % apart from 1000 K to 100 000 K.
fn locus() -> &'static [(f64, [f64; 2])] {
    static L: OnceLock<Vec<(f64, [f64; 2])>> = OnceLock::new();
    L.get_or_init(|| {
        let mut v = Vec::new();
        let mut t = 1000.0;
        while t <= 100_000.0 * 1.0025 {
            v.push((t, planck_uv(t)));
            t *= 1.0025;
        }
        v
    })
}

/// Correlated colour temperature (K) and Duv (signed distance from the Planckian locus in
/// CIE 1960 (u, v), positive above it) of tristimulus values: the temperature of the
/// nearest point of the locus computed from the CIE tables, found on a table 0.25 % apart
/// in T and refined on the exact locus, between 1000 K and 100 000 K. Meaningful where |Duv| ≤ 0.05 (CIE 15); None for black.
pub fn cct(xyz: [f64; 3]) -> Option<(f64, f64)> {
    let p = uv(chromaticity(xyz)?);
    let d = |q: [f64; 2]| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
    let l = locus();
    let i = (0..l.len())
        .min_by(|&a, &b| d(l[a].1).total_cmp(&d(l[b].1)))
        .expect("the locus has points")
        .clamp(1, l.len() - 2);
    // The nearest point lies between the neighbours of the nearest table point: golden
    // section on the exact locus there (the bracket shrinks to 3e-8 of T).
    let dist = |t: f64| d(planck_uv(t));
    let (mut a, mut b) = (l[i - 1].0, l[i + 1].0);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut e) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fe) = (dist(c), dist(e));
    for _ in 0..30 {
        if fc < fe {
            b = e;
            e = c;
            fe = fc;
            c = b - g * (b - a);
            fc = dist(c);
        } else {
            a = c;
            c = e;
            fc = fe;
            e = a + g * (b - a);
            fe = dist(e);
        }
    }
    let t = 0.5 * (a + b);
    let q = planck_uv(t);
    // Above the locus (towards green) is positive: compare with the locus's direction.
    let q2 = planck_uv(t * 1.001);
    let (tx, ty) = (q2[0] - q[0], q2[1] - q[1]);
    let side = (tx * (p[1] - q[1]) - ty * (p[0] - q[0])).signum();
    Some((t, -side * d(q)))
}

/// Radiant flux per band of `spectrum` scaled so that its total is `flux` in the amount's
/// kind (radiant W or luminous lm).
pub fn scale_spectrum(
    spectrum: &Spectrum,
    bands: &Bands,
    flux: f64,
    photometric: bool,
) -> Result<Vec<f64>> {
    spectrum.validate(bands)?;
    let rel = spectrum_bands(spectrum, bands);
    let norm = if photometric {
        BandPhotometry::new(bands).luminous(&rel)
    } else {
        rel.iter().sum()
    };
    if !(norm > 0.0 && norm.is_finite()) {
        bail!(
            ImapErrInvalidArgument,
            "the light's spectrum has no {} in the context's bands ({:.0}–{:.0} nm): it cannot carry a {}",
            if photometric { "visible power" } else { "power" },
            bands.interval(bands.count() - 1).0.min(bands.interval(0).0),
            bands.interval(0).1.max(bands.interval(bands.count() - 1).1),
            if photometric { "luminous amount" } else { "radiant amount" }
        );
    }
    Ok(rel.iter().map(|r| r * flux / norm).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn xyz_of(s: &Spectrum) -> [f64; 3] {
        [0, 1, 2].map(|k| integrate(360.0, 830.0, |nm| s.at(nm) * cmf(nm)[k]))
    }

    #[test]
    fn illuminants_have_their_published_chromaticities_and_temperatures() {
        // CIE 15:2004 Table T.3: A (0.44757, 0.40745), D65 (0.31271, 0.32902).
        for (s, xy, t) in [
            (Spectrum::CieA, [0.44757, 0.40745], 2856.0),
            (Spectrum::CieD65, [0.31271, 0.32902], 6504.0),
        ] {
            let c = chromaticity(xyz_of(&s)).unwrap();
            assert!(
                (c[0] - xy[0]).abs() < 5e-5 && (c[1] - xy[1]).abs() < 5e-5,
                "{s:?}: {c:?}"
            );
            let (cct_k, duv) = cct(xyz_of(&s)).unwrap();
            assert!((cct_k - t).abs() < 3.0, "{s:?}: CCT {cct_k}");
            assert!(duv.abs() < 0.004, "{s:?}: Duv {duv}");
        }
        // A blackbody is on the locus.
        let (t, duv) = cct(xyz_of(&Spectrum::Blackbody(4000.0))).unwrap();
        assert!((t - 4000.0).abs() < 0.5 && duv.abs() < 1e-6, "{t} {duv}");
    }

    #[test]
    fn rec709_matrix_and_rgb_photometry() {
        let m = rgb_to_xyz();
        for (got, want) in m[1].iter().zip([0.2126, 0.7152, 0.0722]) {
            assert!((got - want).abs() < 1e-4, "{got} vs {want}");
        }
        // White (1, 1, 1) is D65's chromaticity.
        let w = [
            m[0].iter().sum::<f64>(),
            m[1].iter().sum(),
            m[2].iter().sum(),
        ];
        let c = chromaticity(w).unwrap();
        assert!((c[0] - 0.3127).abs() < 1e-12 && (c[1] - 0.3290).abs() < 1e-12);
        // One watt in each RGB band is three watts of visible D65 light.
        let p = BandPhotometry::new(&Bands::rgb());
        let white = p.luminous(&[1.0, 1.0, 1.0]);
        assert!((white - 3.0 * d65_visible_efficacy()).abs() < 1e-9);
    }

    #[test]
    fn a_narrow_band_at_555_nm_is_683_lumens_per_watt() {
        let b = Bands::spectral(1, 555.0, 555.0).unwrap();
        assert_eq!(BandPhotometry::new(&b).efficacy, vec![683.0]);
    }
}

//! A goniometric intensity distribution: the candela table of a luminaire, expanded to the
//! whole sphere by its symmetry, evaluated by bilinear interpolation in the two angles, and
//! sampled *exactly* as evaluated.
//!
//! Both photometric types become one form: an azimuth φ around a polar axis and a polar
//! angle θ from it, on a grid of φ (degrees, increasing, covering 0–360 or a part) and θ
//! (0–180, increasing). Type C: the axis is nadir (γ = θ), φ is the C angle. Type B: the
//! axis is the luminaire's lateral (horizontal) axis, θ = 90° − H and φ = V.
//!
//! Inside a cell the intensity is bilinear in (φ, θ); with the solid angle sin θ dθ dφ the
//! cell's flux is exact in closed form (∫(a + bθ) sin θ dθ = −a cos θ + b (sin θ − θ cos θ)),
//! photons pick a cell by flux (alias table), then θ by inverting that integral (Newton with
//! bisection) and φ from the cell's linear profile at that θ. The photons' distribution is
//! therefore the evaluated intensity itself, and the total flux is the table's exact
//! integral.

use crate::error::{bail, Result};
use crate::sampling::AliasTable;
use std::f64::consts::PI;

/// A photometric table as a file gives it, angles in degrees, intensities in candela
/// (multipliers applied).
#[derive(Clone, Debug, PartialEq)]
pub struct PhotometricData {
    pub kind: PhotometricType,
    /// Vertical angles (γ for type C, V for type B).
    pub vertical: Vec<f64>,
    /// Horizontal angles (C for type C, H for type B).
    pub horizontal: Vec<f64>,
    /// Candela, one row per horizontal angle, one value per vertical angle.
    pub candela: Vec<Vec<f64>>,
    /// How the given planes extend to the whole sphere.
    pub symmetry: Symmetry,
    /// TILT: (angles in degrees, multiplying factors), when the file has one.
    pub tilt: Option<(Vec<f64>, Vec<f64>)>,
    /// The luminous opening.
    pub opening: Opening,
    /// A colour temperature the file states, K (EULUMDAT's lamp data), if any.
    pub cct_k: Option<f64>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhotometricType {
    C,
    B,
}

/// The symmetry the given planes imply.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Symmetry {
    /// One plane, the same in every direction around the axis.
    Rotational,
    /// C0–C90 given; mirrored to every quadrant.
    Quadrant,
    /// C0–C180 given; mirrored about the C0–C180 plane.
    C0C180,
    /// C90–C270 given; mirrored about the C90–C270 plane.
    C90C270,
    /// Type B: H 0–90 given; mirrored to negative H.
    LateralB,
    /// Every plane given.
    None,
}

/// The luminous opening, metres (width across, length along the C0–C180 direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Opening {
    Point,
    Rectangle {
        width: f64,
        length: f64,
    },
    Ellipse {
        width: f64,
        length: f64,
    },
    /// A three-dimensional luminous shape (box, cylinder, sphere): the file describes it,
    /// libimap cannot emit from it; glare (`crate::glare`) sees its projected area. The
    /// file's signed width, length and height, m (LM-63's codes of shapes).
    Solid {
        what: &'static str,
        width: f64,
        length: f64,
        height: f64,
    },
}

impl Opening {
    /// The luminous area the opening shows toward a direction of components `along` (the
    /// length's direction: C0–C180 for type C), `across` (the width's) and `axis` (the
    /// photometric axis, the flat opening's normal), m² (0 for a point).
    ///
    /// A rectangle or ellipse shows its area times |cos| to the axis. A box (LM-63: width,
    /// length and height positive) shows its bottom and the two sides the direction sees.
    /// A vertical cylinder (width < 0 its diameter, length 0, height > 0) its disk and its
    /// side; a sphere (all three negative) its disk. Every other three-dimensional shape
    /// LM-63 codes is taken as the box of its dimensions' magnitudes.
    pub fn projected_area_m2(&self, along: f64, across: f64, axis: f64) -> f64 {
        let cz = axis.abs();
        match *self {
            Opening::Point => 0.0,
            Opening::Rectangle { width, length } => width * length * cz,
            Opening::Ellipse { width, length } => PI / 4.0 * width * length * cz,
            Opening::Solid {
                width,
                length,
                height,
                ..
            } => {
                if width < 0.0 && length < 0.0 && height < 0.0 {
                    PI / 4.0 * width * width
                } else if width < 0.0 && length == 0.0 && height > 0.0 {
                    PI / 4.0 * width * width * cz - width * height * (1.0 - cz * cz).max(0.0).sqrt()
                } else {
                    let (w, l, h) = (width.abs(), length.abs(), height.abs());
                    l * w * cz + l * h * across.abs() + w * h * along.abs()
                }
            }
        }
    }

    /// The length and width of its footprint, m (0 for a point; a cylinder's or sphere's
    /// diameter).
    pub fn extent_m(&self) -> (f64, f64) {
        match *self {
            Opening::Point => (0.0, 0.0),
            Opening::Rectangle { width, length } | Opening::Ellipse { width, length } => {
                (length, width)
            }
            Opening::Solid {
                width,
                length,
                height,
                ..
            } => {
                if width < 0.0 && ((length < 0.0 && height < 0.0) || length == 0.0) {
                    (-width, -width)
                } else {
                    (length.abs(), width.abs())
                }
            }
        }
    }
}

impl Symmetry {
    /// The symmetry LM-63 reads from the horizontal angles (increasing): type C one angle
    /// (rotational), 0–90° (quadrants), 0–180°, 90–270°, 0° to more than 180° (none); type
    /// B 0–90° (lateral) or −90–90° (none). Otherwise the reason it is none of them.
    pub fn infer(kind: PhotometricType, horizontal: &[f64]) -> std::result::Result<Self, String> {
        let n = horizontal.len();
        let (h0, h1) = (horizontal[0], horizontal[n - 1]);
        match kind {
            PhotometricType::C if n == 1 => Ok(Symmetry::Rotational),
            PhotometricType::C if h0 == 0.0 && h1 == 90.0 => Ok(Symmetry::Quadrant),
            PhotometricType::C if h0 == 0.0 && h1 == 180.0 => Ok(Symmetry::C0C180),
            PhotometricType::C if h0 == 90.0 && h1 == 270.0 => Ok(Symmetry::C90C270),
            PhotometricType::C if h0 == 0.0 && h1 > 180.0 && h1 <= 360.0 => Ok(Symmetry::None),
            PhotometricType::C => Err(format!(
                "type C horizontal angles from {h0}° to {h1}°: LM-63 allows one plane, 0–90°, 0–180°, 90–270° or 0 to 360°"
            )),
            PhotometricType::B if h0 == 0.0 && h1 == 90.0 => Ok(Symmetry::LateralB),
            PhotometricType::B if h0 == -90.0 && h1 == 90.0 => Ok(Symmetry::None),
            PhotometricType::B => Err(format!(
                "type B horizontal angles from {h0}° to {h1}°: LM-63 allows 0–90° (laterally symmetric) or −90–90°"
            )),
        }
    }
}

impl PhotometricData {
    /// The TILT factor for a luminaire tilted `deg` degrees from its measured position:
    /// linear in the table, the end values beyond it; 1 without a table.
    pub fn tilt_factor(&self, deg: f64) -> f64 {
        let Some((a, f)) = &self.tilt else {
            return 1.0;
        };
        if deg <= a[0] {
            return f[0];
        }
        for i in 1..a.len() {
            if deg <= a[i] {
                let t = (deg - a[i - 1]) / (a[i] - a[i - 1]);
                return f[i - 1] + t * (f[i] - f[i - 1]);
            }
        }
        f[f.len() - 1]
    }

    /// Checks counts, ranges, monotonic angles and values.
    pub fn validate(&self) -> Result<()> {
        let (nv, nh) = (self.vertical.len(), self.horizontal.len());
        if nv < 2 {
            bail!(
                ImapErrParse,
                "{nv} vertical angle(s): a distribution needs at least 2"
            );
        }
        if nh == 0 || self.candela.len() != nh || self.candela.iter().any(|r| r.len() != nv) {
            bail!(
                ImapErrParse,
                "the candela table is not {nh} × {nv} (horizontal × vertical angles)"
            );
        }
        for (name, a) in [
            ("vertical", &self.vertical),
            ("horizontal", &self.horizontal),
        ] {
            if let Some(i) = a.iter().position(|x| !x.is_finite()) {
                bail!(ImapErrParse, "{name} angle {} is not a number", i + 1);
            }
            if let Some(i) = (1..a.len()).find(|&i| a[i] <= a[i - 1]) {
                bail!(
                    ImapErrParse,
                    "{name} angles must increase: angle {} ({}°) follows {}°",
                    i + 1,
                    a[i],
                    a[i - 1]
                );
            }
        }
        let (vlo, vhi) = (self.vertical[0], self.vertical[nv - 1]);
        let (hlo, hhi) = (self.horizontal[0], self.horizontal[nh - 1]);
        match self.kind {
            PhotometricType::C => {
                if vlo < 0.0 || vhi > 180.0 {
                    bail!(
                        ImapErrParse,
                        "type C vertical angles run from {vlo}° to {vhi}°: they must lie in 0–180°"
                    );
                }
                if hlo < 0.0 || hhi > 360.0 {
                    bail!(
                        ImapErrParse,
                        "horizontal angles run from {hlo}° to {hhi}°: they must lie in 0–360°"
                    );
                }
            }
            PhotometricType::B => {
                if vlo < -180.0 || vhi > 180.0 || hlo < -90.0 || hhi > 90.0 {
                    bail!(
                        ImapErrParse,
                        "type B angles must lie in V −180–180°, H −90–90° (got V {vlo}–{vhi}°, H {hlo}–{hhi}°)"
                    );
                }
            }
        }
        for (h, row) in self.candela.iter().enumerate() {
            if let Some(v) = row.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
                bail!(
                    ImapErrParse,
                    "candela value {} of horizontal angle {}° is {}: intensities are finite and non-negative",
                    v + 1,
                    self.horizontal[h],
                    row[v]
                );
            }
        }
        if let Some((a, f)) = &self.tilt {
            if a.is_empty() || a.len() != f.len() {
                bail!(
                    ImapErrParse,
                    "the TILT table has {} angles and {} factors",
                    a.len(),
                    f.len()
                );
            }
            if (1..a.len()).any(|i| a[i] <= a[i - 1])
                || f.iter().any(|x| !(x.is_finite() && *x >= 0.0))
            {
                bail!(
                    ImapErrParse,
                    "TILT angles must increase and its factors be non-negative"
                );
            }
        }
        Ok(())
    }
}

/// Bytes a distribution holds per value of its expanded table (`Goniometric`): the
/// intensity, and its cell's entry in the sampling table (probability, alias, flux).
pub const HELD_PER_VALUE: u64 = 8 + 16;
/// Bytes the expansion needs on top per value while it runs: the mirrored planes, the
/// cells' fluxes and the sampling table's work lists.
pub const EXPANDING_PER_VALUE: u64 = 8 + 8 + 16;
/// Bytes a parsed table takes per candela value: the values read and the table
/// (`PhotometricData`) made of them.
pub const PARSED_PER_VALUE: u64 = 16;

impl Symmetry {
    /// How many planes the expansion makes of one given plane (at most).
    fn copies(self) -> u64 {
        match self {
            Symmetry::Rotational | Symmetry::None | Symmetry::LateralB => 1,
            Symmetry::C0C180 | Symmetry::C90C270 => 2,
            Symmetry::Quadrant => 4,
        }
    }
}

/// Values of the expanded table (`Goniometric`) of `vertical` × `horizontal` given angles
/// with `symmetry`: the most the expansion can make, from the counts alone (so that a
/// file's memory is known before its values are read).
pub fn expanded_values(
    kind: PhotometricType,
    symmetry: Symmetry,
    vertical: usize,
    horizontal: usize,
) -> u64 {
    let (v, h) = (vertical as u64, horizontal as u64);
    match kind {
        PhotometricType::C if symmetry == Symmetry::Rotational => 2 * v,
        // Mirrored planes, and up to two more to wrap around 360°.
        PhotometricType::C => (symmetry.copies() * h + 2).saturating_mul(v),
        // φ = V, θ = 90° − H, H mirrored when laterally symmetric.
        PhotometricType::B if symmetry == Symmetry::LateralB => v.saturating_mul(2 * h),
        PhotometricType::B => v.saturating_mul(h),
    }
}

/// Bytes a table of `given` values expanding to `expanded` values needs while it is read
/// and expanded (the parsed table, the expansion's work), and keeps afterwards.
pub fn table_bytes(given: u64, expanded: u64) -> (u64, u64) {
    let held = expanded.saturating_mul(HELD_PER_VALUE);
    let peak = given
        .saturating_mul(PARSED_PER_VALUE)
        .saturating_add(expanded.saturating_mul(HELD_PER_VALUE + EXPANDING_PER_VALUE));
    (peak, held)
}

/// The distribution on the whole sphere, ready to evaluate and sample.
#[derive(Debug)]
pub struct Goniometric {
    kind: PhotometricType,
    /// Azimuths (radians, increasing); `periodic` when they wrap around 2π.
    phi: Vec<f64>,
    periodic: bool,
    /// Polar angles (radians, increasing).
    theta: Vec<f64>,
    /// Intensity at (phi[i], theta[j]): i * theta.len() + j, candela.
    values: Vec<f64>,
    cells: AliasTable,
    /// Total flux, lumens (cd·sr).
    flux: f64,
}

/// The mirror images of an azimuth (degrees) under a symmetry.
fn mirrors(s: Symmetry, a: f64) -> Vec<f64> {
    let m = |x: f64| x.rem_euclid(360.0);
    match s {
        Symmetry::Rotational | Symmetry::None | Symmetry::LateralB => vec![a],
        Symmetry::C0C180 => vec![a, m(360.0 - a)],
        Symmetry::C90C270 => vec![a, m(180.0 - a)],
        Symmetry::Quadrant => vec![a, m(180.0 - a), m(180.0 + a), m(360.0 - a)],
    }
}

impl Goniometric {
    /// Expands `d` (validated) to the sphere. Intensities are scaled by `scale`.
    pub fn new(d: &PhotometricData, scale: f64) -> Result<Self> {
        d.validate()?;
        // Planes as (azimuth in degrees, intensities over the polar grid).
        let (mut planes, theta_deg): (Vec<(f64, Vec<f64>)>, Vec<f64>) = match d.kind {
            PhotometricType::C => {
                let mut p = Vec::new();
                if d.symmetry == Symmetry::Rotational {
                    p.push((0.0, d.candela[0].clone()));
                    p.push((360.0, d.candela[0].clone()));
                } else {
                    for (h, row) in d.horizontal.iter().zip(&d.candela) {
                        for a in mirrors(d.symmetry, *h) {
                            p.push((a, row.clone()));
                        }
                    }
                }
                (p, d.vertical.clone())
            }
            PhotometricType::B => {
                // φ = V (the vertical angles), θ = 90° − H: transpose, and mirror H.
                let mut hs: Vec<(f64, usize)> = d.horizontal.iter().copied().zip(0..).collect();
                if d.symmetry == Symmetry::LateralB {
                    let neg: Vec<(f64, usize)> = hs
                        .iter()
                        .filter(|h| h.0 > 0.0)
                        .map(|&(h, i)| (-h, i))
                        .collect();
                    hs.extend(neg);
                }
                hs.sort_by(|a, b| b.0.total_cmp(&a.0)); // decreasing H = increasing θ
                let theta: Vec<f64> = hs.iter().map(|h| 90.0 - h.0).collect();
                let p = d
                    .vertical
                    .iter()
                    .enumerate()
                    .map(|(v, &va)| (va, hs.iter().map(|&(_, i)| d.candela[i][v]).collect()))
                    .collect();
                (p, theta)
            }
        };
        planes.sort_by(|a, b| a.0.total_cmp(&b.0));
        planes.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-9);
        let periodic = d.kind == PhotometricType::C;
        if periodic {
            // Wrap around: the plane at 0° again at 360°, or interpolate across the seam.
            if planes[0].0 > 1e-9 || planes[planes.len() - 1].0 < 360.0 - 1e-9 {
                let first = planes[0].clone();
                let last = planes[planes.len() - 1].clone();
                if (last.0 - 360.0).abs() < 1e-9 {
                    planes.insert(0, (0.0, last.1));
                } else if first.0.abs() < 1e-9 {
                    planes.push((360.0, first.1));
                } else {
                    planes.insert(0, (last.0 - 360.0, last.1.clone()));
                    planes.push((first.0 + 360.0, first.1));
                }
            }
        }
        let phi: Vec<f64> = planes.iter().map(|p| p.0.to_radians()).collect();
        let theta: Vec<f64> = theta_deg.iter().map(|t| t.to_radians()).collect();
        let nt = theta.len();
        let mut values = Vec::with_capacity(phi.len() * nt);
        for p in &planes {
            values.extend(p.1.iter().map(|v| v * scale));
        }
        // Cell fluxes, exactly.
        let mut fluxes = Vec::with_capacity((phi.len() - 1) * (nt - 1));
        for i in 0..phi.len() - 1 {
            for j in 0..nt - 1 {
                let c = Cell::new(&values, nt, i, j, &phi, &theta);
                fluxes.push(c.flux());
            }
        }
        let flux: f64 = fluxes.iter().sum();
        if !(flux > 0.0 && flux.is_finite()) {
            bail!(
                ImapErrNoLight,
                "the distribution's flux is {flux} lm: every intensity is 0"
            );
        }
        let cells = AliasTable::new(&fluxes).map_err(|why| {
            crate::error::Error::new(
                crate::error::ImapStatus::ImapErrParse,
                format!("the distribution cannot be sampled ({why})"),
            )
        })?;
        Ok(Goniometric {
            kind: d.kind,
            phi,
            periodic,
            theta,
            values,
            cells,
            flux,
        })
    }

    /// Values of the expanded table.
    pub fn values(&self) -> usize {
        self.values.len()
    }

    /// Total flux, lumens.
    pub fn flux(&self) -> f64 {
        self.flux
    }

    pub fn kind(&self) -> PhotometricType {
        self.kind
    }

    /// Intensity (cd) at azimuth `phi` and polar angle `theta` (radians), bilinear on the
    /// grid, 0 outside it.
    pub fn intensity(&self, phi: f64, theta: f64) -> f64 {
        let nt = self.theta.len();
        let (t0, t1) = (self.theta[0], self.theta[nt - 1]);
        if !(theta >= t0 && theta <= t1) {
            return 0.0;
        }
        let phi = if self.periodic {
            let p = phi.rem_euclid(2.0 * PI);
            // The grid may start below 0 (a seam plane at a negative azimuth).
            if p < self.phi[0] {
                p + 2.0 * PI
            } else {
                p
            }
        } else {
            phi
        };
        let np = self.phi.len();
        if !(phi >= self.phi[0] && phi <= self.phi[np - 1]) {
            return 0.0;
        }
        let i = self.phi.partition_point(|&p| p <= phi).clamp(1, np - 1) - 1;
        let j = self.theta.partition_point(|&t| t <= theta).clamp(1, nt - 1) - 1;
        let s = (phi - self.phi[i]) / (self.phi[i + 1] - self.phi[i]);
        let t = (theta - self.theta[j]) / (self.theta[j + 1] - self.theta[j]);
        let v = |a: usize, b: usize| self.values[a * nt + b];
        (1.0 - s) * ((1.0 - t) * v(i, j) + t * v(i, j + 1))
            + s * ((1.0 - t) * v(i + 1, j) + t * v(i + 1, j + 1))
    }

    /// A direction's (φ, θ), radians, drawn in proportion to the intensity.
    pub fn sample(&self, u_cell: f64, u_theta: f64, u_phi: f64) -> (f64, f64) {
        let nt = self.theta.len();
        let c = self.cells.sample(u_cell);
        let (i, j) = (c / (nt - 1), c % (nt - 1));
        let cell = Cell::new(&self.values, nt, i, j, &self.phi, &self.theta);
        let theta = cell.sample_theta(u_theta);
        let phi = cell.sample_phi(theta, u_phi);
        (phi, theta)
    }
}

/// One grid cell: corners I00 (φ0, θ0), I10 (φ1, θ0), I01 (φ0, θ1), I11 (φ1, θ1).
struct Cell {
    phi: (f64, f64),
    theta: (f64, f64),
    i: [f64; 4],
}

impl Cell {
    fn new(values: &[f64], nt: usize, i: usize, j: usize, phi: &[f64], theta: &[f64]) -> Self {
        let v = |a: usize, b: usize| values[a * nt + b];
        Cell {
            phi: (phi[i], phi[i + 1]),
            theta: (theta[j], theta[j + 1]),
            i: [v(i, j), v(i + 1, j), v(i, j + 1), v(i + 1, j + 1)],
        }
    }

    /// The intensity integrated over φ, as a + b·θ.
    fn marginal(&self) -> (f64, f64) {
        let dphi = self.phi.1 - self.phi.0;
        let a0 = 0.5 * (self.i[0] + self.i[1]) * dphi;
        let a1 = 0.5 * (self.i[2] + self.i[3]) * dphi;
        let b = (a1 - a0) / (self.theta.1 - self.theta.0);
        (a0 - b * self.theta.0, b)
    }

    /// ∫ (a + bθ) sin θ dθ's antiderivative.
    fn antiderivative(a: f64, b: f64, t: f64) -> f64 {
        -a * t.cos() + b * (t.sin() - t * t.cos())
    }

    fn flux(&self) -> f64 {
        let (a, b) = self.marginal();
        (Self::antiderivative(a, b, self.theta.1) - Self::antiderivative(a, b, self.theta.0))
            .max(0.0)
    }

    fn sample_theta(&self, u: f64) -> f64 {
        let (a, b) = self.marginal();
        let (lo, hi) = self.theta;
        let f0 = Self::antiderivative(a, b, lo);
        let target = f0 + u * (Self::antiderivative(a, b, hi) - f0);
        // Newton on a monotone function, kept inside a shrinking bracket.
        let (mut l, mut h) = (lo, hi);
        let mut t = lo + u * (hi - lo);
        for _ in 0..60 {
            let f = Self::antiderivative(a, b, t) - target;
            if f > 0.0 {
                h = t;
            } else {
                l = t;
            }
            let df = (a + b * t) * t.sin();
            let next = t - f / df;
            t = if df > 0.0 && next > l && next < h {
                next
            } else {
                0.5 * (l + h)
            };
            if h - l < 1e-15 * (1.0 + hi) {
                break;
            }
        }
        t.clamp(lo, hi)
    }

    fn sample_phi(&self, theta: f64, u: f64) -> f64 {
        let t = (theta - self.theta.0) / (self.theta.1 - self.theta.0);
        let l = (1.0 - t) * self.i[0] + t * self.i[2];
        let r = (1.0 - t) * self.i[1] + t * self.i[3];
        // Density ∝ (1 − s) l + s r on [0, 1].
        let s = if (r - l).abs() <= 1e-12 * (r + l) {
            u
        } else {
            ((l * l + u * (r * r - l * l)).max(0.0).sqrt() - l) / (r - l)
        };
        self.phi.0 + s.clamp(0.0, 1.0) * (self.phi.1 - self.phi.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::PhotonRng;

    fn table(h: &[f64], v: &[f64], f: impl Fn(f64, f64) -> f64, sym: Symmetry) -> PhotometricData {
        PhotometricData {
            kind: PhotometricType::C,
            vertical: v.to_vec(),
            horizontal: h.to_vec(),
            candela: h
                .iter()
                .map(|&c| v.iter().map(|&g| f(c, g)).collect())
                .collect(),
            symmetry: sym,
            tilt: None,
            opening: Opening::Point,
            cct_k: None,
        }
    }

    #[test]
    fn a_cosine_distribution_has_pi_i0_lumens_and_samples_cosine_weighted() {
        let v: Vec<f64> = (0..=18).map(|i| i as f64 * 5.0).collect();
        let d = table(
            &[0.0],
            &v,
            |_, g| 1000.0 * g.to_radians().cos(),
            Symmetry::Rotational,
        );
        let g = Goniometric::new(&d, 1.0).unwrap();
        // Piecewise-linear cos on 5° steps: the exact integral of the interpolant is within
        // 0.1 % of π I0.
        assert!(
            (g.flux() / (PI * 1000.0) - 1.0).abs() < 1e-3,
            "{}",
            g.flux()
        );
        // Sampled cos θ has the interpolant's mean (≈ 2/3).
        let mut rng = PhotonRng::new(1, 2);
        let n = 200_000;
        let mut m = 0.0;
        for _ in 0..n {
            let (_, t) = g.sample(rng.uniform(), rng.uniform(), rng.uniform());
            assert!((0.0..=PI / 2.0 + 1e-12).contains(&t));
            m += t.cos();
        }
        assert!((m / n as f64 - 2.0 / 3.0).abs() < 0.004, "{}", m / n as f64);
    }

    #[test]
    fn symmetries_expand_to_the_same_sphere() {
        // An asymmetric-looking but quadrant-symmetric function given four ways.
        let f = |c: f64, g: f64| 100.0 + 50.0 * (2.0 * c.to_radians()).cos() * g.to_radians().sin();
        let v: Vec<f64> = (0..=36).map(|i| i as f64 * 5.0).collect();
        let full: Vec<f64> = (0..=24).map(|i| i as f64 * 15.0).collect();
        let half: Vec<f64> = (0..=12).map(|i| i as f64 * 15.0).collect();
        let quarter: Vec<f64> = (0..=6).map(|i| i as f64 * 15.0).collect();
        let c90: Vec<f64> = (6..=18).map(|i| i as f64 * 15.0).collect();
        let a = Goniometric::new(&table(&full, &v, f, Symmetry::None), 1.0).unwrap();
        for (h, s) in [
            (&half, Symmetry::C0C180),
            (&quarter, Symmetry::Quadrant),
            (&c90, Symmetry::C90C270),
        ] {
            let b = Goniometric::new(&table(h, &v, f, s), 1.0).unwrap();
            assert!((a.flux() - b.flux()).abs() < 1e-9 * a.flux(), "{s:?}");
            for k in 0..50 {
                let (p, t) = (k as f64 * 0.37, (k as f64 * 0.11) % PI);
                assert!(
                    (a.intensity(p, t) - b.intensity(p, t)).abs() < 1e-9,
                    "{s:?} at {p} {t}"
                );
            }
        }
    }
}

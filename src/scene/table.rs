//! Measured BSDF tables: a BRDF (and optionally a BTDF) per band over incident and
//! outgoing directions, isotropic (3-D: the outgoing azimuth relative to the incident one)
//! or anisotropic (4-D: both azimuths from the surface's tangent).
//!
//! Grid: polar angles θ_j = 90° · j / (n_θ − 1), j = 0 … n_θ − 1 (normal to grazing,
//! both ends included); azimuths φ_k = 360° · k / n_φ, k = 0 … n_φ − 1 (periodic).
//! Values f in 1/sr, laid out as `[band][θi][φi][θo][φo]` (φi has one point for an
//! isotropic table, and φo is then φo − φi). A BTDF's outgoing θ is measured from the
//! other side's normal. Values are read linearly in θi (and φi) and bilinearly in (θo, φo).
//!
//! Sampling: the incident direction picks one of its neighbouring incident rows with its
//! interpolation weight; each row holds a distribution over its outgoing cells ∝ the cell's
//! band-mean value (the mean of its corners) × ∫cos dω over the cell, and a direction is
//! drawn ∝ cos within the cell. The density is that mixture, so f cos / pdf is exact and a
//! narrow lobe costs no more photons than a broad one.

use crate::error::{bail, Result};
use crate::sampling::AliasTable;
use glam::DVec3;
use std::f64::consts::PI;

/// What the caller gives.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TableDesc {
    pub theta_in: usize,
    /// 1 for an isotropic table.
    pub phi_in: usize,
    pub theta_out: usize,
    pub phi_out: usize,
    /// bands × θi × φi × θo × φo values, 1/sr (or one band's, for every band).
    pub brdf: Vec<f64>,
    /// The same for transmission, or empty.
    pub btdf: Vec<f64>,
}

/// What checking a table found: the worst reciprocity difference of the BRDF (|f(a, b) −
/// f(b, a)| over their mean, at grid directions both ways) and the largest directional
/// albedo (reflected and transmitted, at an incident grid direction).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TableCheck {
    pub worst_reciprocity: f64,
    pub worst_albedo: f64,
}

/// A checked table with its sampling distributions.
#[derive(Debug)]
pub struct BsdfTable {
    ti: usize,
    pi: usize,
    to: usize,
    po: usize,
    bands: usize,
    /// Per side (reflection, transmission): values, or empty.
    sides: [Vec<f64>; 2],
    /// Per incident row (θi, φi): the distribution over outgoing cells (side, θo cell, φo
    /// cell), ∝ the cell's band-mean value × ∫cos dω; None when the row sends nothing.
    rows: Vec<Option<AliasTable>>,
    /// Each outgoing θ cell's ∫cos dω: (sin²θ_{j+1} − sin²θ_j)/2 · Δφ.
    cosint: Vec<f64>,
    /// The largest value: how sharp its lobes are.
    pub peak: f64,
    pub check: TableCheck,
}

/// Most values a table may hold.
const MAX_VALUES: usize = 1 << 27;

fn theta(j: usize, n: usize) -> f64 {
    0.5 * PI * j as f64 / (n - 1) as f64
}

impl BsdfTable {
    /// Checks `desc` for `bands` bands and builds its sampling; the table's own name in
    /// messages is `name`.
    pub fn new(desc: &TableDesc, bands: usize, name: &str) -> Result<BsdfTable> {
        let (ti, pi, to, po) = (desc.theta_in, desc.phi_in, desc.theta_out, desc.phi_out);
        if ti < 2 || to < 2 || pi < 1 || po < 1 {
            bail!(
                ImapErrInvalidArgument,
                "{name}: theta_in_count = {ti}, theta_out_count = {to} (each at least 2), phi_in_count = {pi}, phi_out_count = {po} (each at least 1)"
            );
        }
        let per_band = ti
            .checked_mul(pi)
            .and_then(|x| x.checked_mul(to))
            .and_then(|x| x.checked_mul(po))
            .filter(|&x| x.saturating_mul(bands) <= MAX_VALUES);
        let Some(per_band) = per_band else {
            bail!(
                ImapErrInvalidArgument,
                "{name}: {ti} × {pi} × {to} × {po} directions × {bands} bands is more than {MAX_VALUES} values"
            );
        };
        let mut sides = [Vec::new(), Vec::new()];
        for (s, (what, v)) in [("brdf", &desc.brdf), ("btdf", &desc.btdf)]
            .into_iter()
            .enumerate()
        {
            if s == 1 && v.is_empty() {
                continue;
            }
            let full = if v.len() == per_band * bands {
                v.clone()
            } else if v.len() == per_band {
                (0..bands).flat_map(|_| v.iter().copied()).collect()
            } else {
                bail!(
                    ImapErrInvalidArgument,
                    "{name}.{what} has {} values: a table of {ti} × {pi} × {to} × {po} directions needs {per_band} (one band for all) or {} ({bands} bands)",
                    v.len(),
                    per_band * bands
                );
            };
            if let Some(i) = full.iter().position(|x| !x.is_finite()) {
                bail!(
                    ImapErrNonFinite,
                    "{name}.{what}[{i}] = {} is not finite",
                    full[i]
                );
            }
            if let Some(i) = full.iter().position(|&x| x < 0.0) {
                bail!(
                    ImapErrBadMaterial,
                    "{name}.{what}[{i}] = {} is negative",
                    full[i]
                );
            }
            sides[s] = full;
        }
        let peak = sides.iter().flatten().cloned().fold(0.0, f64::max);
        let dphi = 2.0 * PI / po as f64;
        let cosint: Vec<f64> = (0..to - 1)
            .map(|j| {
                let (a, b) = (theta(j, to).sin(), theta(j + 1, to).sin());
                0.5 * (b * b - a * a) * dphi
            })
            .collect();
        let mut t = BsdfTable {
            ti,
            pi,
            to,
            po,
            bands,
            sides,
            rows: Vec::new(),
            cosint,
            peak,
            check: TableCheck::default(),
        };
        let cosint = &t.cosint;
        let mut rows = Vec::with_capacity(ti * pi);
        let cells = (to - 1) * po;
        let mut worst_albedo: f64 = 0.0;
        for i in 0..ti {
            for k in 0..pi {
                // Each cell's weight, and the directional albedo per band by the same
                // quadrature (the cells' mean values × ∫cos dω).
                let mut weights = vec![0.0; 2 * cells];
                let mut albedo = vec![0.0; bands];
                for (s, side) in t.sides.iter().enumerate() {
                    if side.is_empty() {
                        continue;
                    }
                    for (j, ci) in cosint.iter().enumerate() {
                        for l in 0..po {
                            let mut band_sum = 0.0;
                            for (b, a) in albedo.iter_mut().enumerate() {
                                let m = t.cell_mean(side, b, i, k, j, l);
                                band_sum += m;
                                *a += m * ci;
                            }
                            weights[s * cells + j * po + l] = band_sum / bands as f64 * ci;
                        }
                    }
                }
                for (b, &a) in albedo.iter().enumerate() {
                    worst_albedo = worst_albedo.max(a);
                    if a > 1.0 + 0.01 {
                        bail!(
                            ImapErrBadMaterial,
                            "{name}: at incidence θ = {:.1}°, φ = {:.1}° it reflects and transmits {a:.4} of what it receives in band {b} (more than 1: energy would be created)",
                            theta(i, ti).to_degrees(),
                            360.0 * k as f64 / pi as f64
                        );
                    }
                }
                let total: f64 = weights.iter().sum();
                rows.push(
                    (total > 0.0)
                        .then(|| AliasTable::new(&weights).ok())
                        .flatten(),
                );
            }
        }
        t.rows = rows;
        t.check = TableCheck {
            worst_reciprocity: t.reciprocity(),
            worst_albedo,
        };
        Ok(t)
    }

    #[inline]
    fn index(&self, b: usize, i: usize, k: usize, j: usize, l: usize) -> usize {
        (((b * self.ti + i) * self.pi + k) * self.to + j) * self.po + l
    }

    /// The mean of outgoing cell (j, l)'s four corners on `side`, band `b`, incident row
    /// (i, k).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn cell_mean(&self, side: &[f64], b: usize, i: usize, k: usize, j: usize, l: usize) -> f64 {
        let l1 = (l + 1) % self.po;
        [(j, l), (j + 1, l), (j, l1), (j + 1, l1)]
            .iter()
            .map(|&(jj, ll)| side[self.index(b, i, k, jj, ll)])
            .sum::<f64>()
            / 4.0
    }

    /// The worst relative reciprocity difference of the BRDF at grid directions (where the
    /// incident and outgoing grids share points).
    fn reciprocity(&self) -> f64 {
        let side = &self.sides[0];
        let mut worst: f64 = 0.0;
        for b in 0..self.bands {
            for i in 0..self.ti {
                for j in 0..self.to {
                    let (ta, tb) = (theta(i, self.ti), theta(j, self.to));
                    for l in 0..self.po {
                        let phi = 2.0 * PI * l as f64 / self.po as f64;
                        let a = dir(ta, 0.0);
                        let c = dir(tb, phi);
                        let f1 = self.value(side, b, a, c);
                        let f2 = self.value(side, b, c, a);
                        let m = 0.5 * (f1 + f2);
                        if m > 1e-9 * self.peak.max(1e-300) {
                            worst = worst.max((f1 - f2).abs() / m);
                        }
                    }
                }
            }
        }
        worst
    }

    /// Whether it transmits.
    #[inline]
    pub fn transmits(&self) -> bool {
        !self.sides[1].is_empty()
    }

    /// The incident rows around local direction `w` with their interpolation weights.
    #[inline]
    fn rows_of(&self, w: DVec3) -> [(usize, usize, f64); 4] {
        let th = w.z.clamp(-1.0, 1.0).acos().min(0.5 * PI);
        let x = th / (0.5 * PI) * (self.ti - 1) as f64;
        let i = (x as usize).min(self.ti - 2);
        let fi = x - i as f64;
        if self.pi == 1 {
            return [(i, 0, 1.0 - fi), (i + 1, 0, fi), (0, 0, 0.0), (0, 0, 0.0)];
        }
        let phi = w.y.atan2(w.x).rem_euclid(2.0 * PI);
        let y = phi / (2.0 * PI) * self.pi as f64;
        let k = (y as usize).min(self.pi - 1);
        let fk = y - k as f64;
        let k1 = (k + 1) % self.pi;
        [
            (i, k, (1.0 - fi) * (1.0 - fk)),
            (i + 1, k, fi * (1.0 - fk)),
            (i, k1, (1.0 - fi) * fk),
            (i + 1, k1, fi * fk),
        ]
    }

    /// The outgoing (θ cell position, φ) of `wi` relative to incident `wo` (azimuth
    /// relative for an isotropic table).
    #[inline]
    fn out_coords(&self, wo: DVec3, wi: DVec3) -> (f64, f64) {
        let th = wi.z.abs().clamp(0.0, 1.0).acos();
        let mut phi = wi.y.atan2(wi.x);
        if self.pi == 1 {
            phi -= wo.y.atan2(wo.x);
        }
        (
            th / (0.5 * PI) * (self.to - 1) as f64,
            phi.rem_euclid(2.0 * PI) / (2.0 * PI) * self.po as f64,
        )
    }

    /// f on `side` in band `b` for light from `wo` leaving along `wi` (local frame; `wi`
    /// on the side's hemisphere, its z sign ignored).
    fn value(&self, side: &[f64], b: usize, wo: DVec3, wi: DVec3) -> f64 {
        let (x, y) = self.out_coords(wo, wi);
        let j = (x as usize).min(self.to - 2);
        let fj = x - j as f64;
        let l = (y as usize).min(self.po - 1);
        let fl = y - l as f64;
        let l1 = (l + 1) % self.po;
        let mut f = 0.0;
        for (i, k, w) in self.rows_of(wo) {
            if w == 0.0 {
                continue;
            }
            let v = |jj: usize, ll: usize| side[self.index(b, i, k, jj, ll)];
            let bil = (1.0 - fj) * ((1.0 - fl) * v(j, l) + fl * v(j, l1))
                + fj * ((1.0 - fl) * v(j + 1, l) + fl * v(j + 1, l1));
            f += w * bil;
        }
        f
    }

    /// f(wo → wi) per band into `out`.
    pub fn eval(&self, wo: DVec3, wi: DVec3, out: &mut [f64]) {
        let s = usize::from(wi.z < 0.0);
        if wo.z <= 0.0 || wi.z == 0.0 || self.sides[s].is_empty() {
            out.iter_mut().for_each(|x| *x = 0.0);
            return;
        }
        for (b, o) in out.iter_mut().enumerate() {
            *o = self.value(&self.sides[s], b.min(self.bands - 1), wo, wi);
        }
    }

    /// The density of `sample`'s direction `wi` from `wo`.
    pub fn pdf(&self, wo: DVec3, wi: DVec3) -> f64 {
        let s = usize::from(wi.z < 0.0);
        if wo.z <= 0.0 || wi.z == 0.0 || self.sides[s].is_empty() {
            return 0.0;
        }
        let (x, y) = self.out_coords(wo, wi);
        let j = (x as usize).min(self.to - 2);
        let l = (y as usize).min(self.po - 1);
        let cell = s * (self.to - 1) * self.po + j * self.po + l;
        let mut p = 0.0;
        for (i, k, w) in self.rows_of(wo) {
            if w == 0.0 {
                continue;
            }
            if let Some(row) = &self.rows[i * self.pi + k] {
                p += w * row.pdf(cell);
            }
        }
        p * wi.z.abs() / self.cosint[j]
    }

    /// A direction for light from `wo`, from three uniform numbers.
    pub fn sample(&self, wo: DVec3, u: [f64; 3]) -> Option<DVec3> {
        if wo.z <= 0.0 {
            return None;
        }
        // The incident row by its interpolation weight (u[0] is reused, rescaled).
        let rows = self.rows_of(wo);
        let mut acc = 0.0;
        let mut chosen = None;
        let mut u0 = u[0];
        for (i, k, w) in rows {
            if w > 0.0 && u0 < acc + w {
                chosen = Some((i, k));
                u0 = ((u0 - acc) / w).clamp(0.0, 1.0 - 1e-16);
                break;
            }
            acc += w;
        }
        let (i, k) =
            chosen.or_else(|| rows.iter().rev().find(|r| r.2 > 0.0).map(|r| (r.0, r.1)))?;
        let cell = self.rows[i * self.pi + k].as_ref()?.sample(u0);
        let cells = (self.to - 1) * self.po;
        let s = cell / cells;
        let (j, l) = ((cell % cells) / self.po, cell % self.po);
        // ∝ cos within the cell: sin²θ uniform between its ends, φ uniform.
        let (a, c) = (theta(j, self.to).sin(), theta(j + 1, self.to).sin());
        let s2 = a * a + (c * c - a * a) * u[1];
        let sin = s2.sqrt();
        let cos = (1.0 - s2).max(0.0).sqrt();
        let mut phi = 2.0 * PI * (l as f64 + u[2]) / self.po as f64;
        if self.pi == 1 {
            phi += wo.y.atan2(wo.x);
        }
        let z = if s == 0 { cos } else { -cos };
        let wi = DVec3::new(sin * phi.cos(), sin * phi.sin(), z);
        (wi.z != 0.0).then_some(wi)
    }
}

/// The local direction at polar angle `t`, azimuth `p`.
#[inline]
fn dir(t: f64, p: f64) -> DVec3 {
    DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::PhotonRng;

    /// A table of f(θi, φi; θo, φo) on an isotropic grid.
    fn isotropic(f: impl Fn(DVec3, DVec3) -> f64, ti: usize, to: usize, po: usize) -> TableDesc {
        let mut v = Vec::new();
        for i in 0..ti {
            let a = dir(theta(i, ti), 0.0);
            for j in 0..to {
                for l in 0..po {
                    let c = dir(theta(j, to), 2.0 * PI * l as f64 / po as f64);
                    v.push(f(a, c));
                }
            }
        }
        TableDesc {
            theta_in: ti,
            phi_in: 1,
            theta_out: to,
            phi_out: po,
            brdf: v,
            btdf: vec![],
        }
    }

    /// A normalised Phong lobe about the mirror direction: (n + 2)/(2π) cosⁿ α, times ρ.
    fn phong(rho: f64, n: f64) -> impl Fn(DVec3, DVec3) -> f64 {
        move |a: DVec3, c: DVec3| {
            let r = DVec3::new(-a.x, -a.y, a.z);
            rho * (n + 2.0) / (2.0 * PI) * r.dot(c).max(0.0).powf(n)
        }
    }

    fn albedo(t: &BsdfTable, wo: DVec3, n: usize) -> f64 {
        let mut rng = PhotonRng::new(4, 4);
        let mut f = vec![0.0];
        let mut s = 0.0;
        for _ in 0..n {
            if let Some(wi) = t.sample(wo, [rng.uniform(), rng.uniform(), rng.uniform()]) {
                t.eval(wo, wi, &mut f);
                let p = t.pdf(wo, wi);
                assert!(p > 0.0, "sampled where the density is 0");
                s += f[0] * wi.z.abs() / p;
            }
        }
        s / n as f64
    }

    /// A Lambertian table reflects ρ and is reciprocal; its samples weigh ρ each (the
    /// density is ∝ f cos exactly).
    #[test]
    fn a_lambertian_table_is_lambert() {
        let t = BsdfTable::new(&isotropic(|_, _| 0.6 / PI, 10, 19, 36), 1, "t").unwrap();
        assert!(t.check.worst_reciprocity < 1e-12);
        assert!((t.check.worst_albedo - 0.6).abs() < 1e-3, "{:?}", t.check);
        for mu in [1.0f64, 0.6, 0.2] {
            let wo = DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let a = albedo(&t, wo, 20_000);
            assert!((a - 0.6).abs() < 2e-3, "μ {mu}: {a}");
        }
    }

    /// A Phong table's albedo matches the lobe's, sampling follows it, and the density is
    /// consistent with the draws (χ² over the cells).
    #[test]
    fn a_phong_table_is_sampled_by_its_lobe() {
        let t = BsdfTable::new(&isotropic(phong(0.8, 20.0), 19, 46, 72), 1, "t").unwrap();
        let wo = dir(30f64.to_radians(), 0.7);
        // The lobe's albedo at 30°: ρ ∫ (n+2)/2π cosⁿα cos θ dω, by fine quadrature.
        let mut exact = 0.0;
        let m = 800;
        for a in 0..m {
            for b in 0..2 * m {
                let th = 0.5 * PI * (a as f64 + 0.5) / m as f64;
                let ph = 2.0 * PI * (b as f64 + 0.5) / (2 * m) as f64;
                let c = dir(th, ph);
                exact += phong(0.8, 20.0)(wo, c)
                    * c.z
                    * th.sin()
                    * (0.5 * PI / m as f64)
                    * (2.0 * PI / (2 * m) as f64);
            }
        }
        let a = albedo(&t, wo, 100_000);
        assert!((a - exact).abs() < 0.02 * exact, "{a} vs {exact}");
        // Draws land where the lobe is: cos²² of 30° leaves 4 % of the lobe's energy
        // outside 30° of the mirror direction.
        let mut rng = PhotonRng::new(2, 2);
        let r = DVec3::new(-wo.x, -wo.y, wo.z);
        let mut near = 0;
        for _ in 0..10_000 {
            let wi = t
                .sample(wo, [rng.uniform(), rng.uniform(), rng.uniform()])
                .unwrap();
            if wi.dot(r) > 30f64.to_radians().cos() {
                near += 1;
            }
        }
        assert!(
            near > 9_300,
            "{near} of 10 000 within 30° of the mirror direction"
        );
    }

    /// Bad tables: a wrong size, a NaN, a negative value, one reflecting more than it
    /// receives (named by its direction), and a non-reciprocal one reported.
    #[test]
    fn bad_tables_are_refused_by_name() {
        let mut d = isotropic(|_, _| 0.3, 5, 7, 8);
        d.brdf.pop();
        let e = BsdfTable::new(&d, 3, "tab").unwrap_err();
        assert!(
            e.message.contains("tab.brdf") && e.message.contains("needs"),
            "{e}"
        );
        let mut d = isotropic(|_, _| 0.1, 5, 7, 8);
        d.brdf[3] = f64::NAN;
        assert_eq!(
            BsdfTable::new(&d, 1, "t").unwrap_err().status,
            crate::error::ImapStatus::ImapErrNonFinite
        );
        d.brdf[3] = -0.1;
        assert_eq!(
            BsdfTable::new(&d, 1, "t").unwrap_err().status,
            crate::error::ImapStatus::ImapErrBadMaterial
        );
        let e = BsdfTable::new(&isotropic(|_, _| 0.5, 5, 7, 8), 1, "t").unwrap_err();
        assert!(
            e.message.contains("θ = 0.0°") && e.message.contains("more than 1"),
            "{e}"
        );
        // f depends on the incident angle alone: not reciprocal.
        let t = BsdfTable::new(&isotropic(|a, _| 0.1 + 0.1 * a.z, 5, 5, 8), 1, "t").unwrap();
        assert!(t.check.worst_reciprocity > 0.5, "{:?}", t.check);
    }
}

//! Microfacet surfaces: the Trowbridge–Reitz (GGX) distribution of normals with Smith's
//! height-correlated masking-shadowing, sampled by its visible normals (Heitz 2018), and
//! the three surfaces built on it (`Glossy`):
//! - a rough conductor with a complex index n + ik per band, its single-scattering loss at
//!   high roughness given back by a Kulla–Conty multiple-scattering lobe;
//! - a rough dielectric interface (frosted glass), reflecting or refracting at the
//!   microfacet by unpolarised Fresnel; its multiple-scattering loss is not given back
//!   (`tests::rough_dielectric_loss_is_what_the_docs_say` measures it);
//! - a coated diffuse base ("plastic"): a rough dielectric coat over a Lambertian base,
//!   the light the coat does not reflect entering, scattering in the base and between base
//!   and coat (a geometric series), and leaving through the coat. Light lost to the coat's
//!   multiple scattering reaches the base instead: a white base under any coat reflects
//!   everything.
//!
//! Directions here are in the surface's local frame (z along the normal of the side light
//! arrives on). `wo` points back toward where the light came from (a photon's source, or
//! an eye path's camera), `wi` where it goes on. Values are per band, and `eval` is the
//! kernel a photon's power goes by (the adjoint BSDF; for reflection the BSDF itself): its
//! integral over `wi` of f |cos θi| is the share of the power that leaves. Eye paths use the
//! same kernel (their transmitted radiance then misses the factor n² inside a medium, which
//! cancels on the way out of a closed one, as for the smooth dielectric).

use super::host::HostSurface;
use super::klems::KlemsBsdf;
use super::material::fresnel_dielectric;
use super::table::BsdfTable;
use glam::DVec3;
use std::f64::consts::PI;
use std::sync::{Arc, OnceLock};

/// The GGX roughness α along the tangent and the bitangent (α = 0.01 is nearly a mirror,
/// α = 1 very rough; Mitsuba's and pbrt's `alpha`, the square of glTF's
/// "perceptual roughness").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Roughness {
    pub ax: f64,
    pub ay: f64,
}

impl Roughness {
    /// The distribution of normals D(h), 1/sr (projected area per solid angle).
    #[inline]
    pub fn d(&self, h: DVec3) -> f64 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let (x, y) = (h.x / self.ax, h.y / self.ay);
        let t = x * x + y * y + h.z * h.z;
        1.0 / (PI * self.ax * self.ay * t * t)
    }

    /// Smith's Λ(w).
    #[inline]
    fn lambda(&self, w: DVec3) -> f64 {
        let z2 = w.z * w.z;
        if z2 <= 0.0 {
            return f64::INFINITY;
        }
        let a2 = (self.ax * self.ax * w.x * w.x + self.ay * self.ay * w.y * w.y) / z2;
        0.5 * ((1.0 + a2).sqrt() - 1.0)
    }

    /// Masking G1(w).
    #[inline]
    pub fn g1(&self, w: DVec3) -> f64 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing G2(wo, wi).
    #[inline]
    pub fn g2(&self, wo: DVec3, wi: DVec3) -> f64 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// A microfacet normal drawn from the normals visible from `wo` (wo.z > 0), from two
    /// uniform numbers.
    #[inline]
    pub fn sample_visible(&self, wo: DVec3, u1: f64, u2: f64) -> DVec3 {
        // The view direction in the stretched frame where the distribution is a hemisphere.
        let v = DVec3::new(self.ax * wo.x, self.ay * wo.y, wo.z).normalize();
        let len2 = v.x * v.x + v.y * v.y;
        let t1 = if len2 > 0.0 {
            DVec3::new(-v.y, v.x, 0.0) / len2.sqrt()
        } else {
            DVec3::X
        };
        let t2 = v.cross(t1);
        let r = u1.sqrt();
        let phi = 2.0 * PI * u2;
        let p1 = r * phi.cos();
        let s = 0.5 * (1.0 + v.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
        let n = t1 * p1 + t2 * p2 + v * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        DVec3::new(self.ax * n.x, self.ay * n.y, n.z.max(1e-12)).normalize()
    }

    /// The density of `sample_visible`'s normal h seen from `wo`: G1(wo) max(0, wo·h)
    /// D(h) / wo.z.
    #[inline]
    pub fn pdf_visible(&self, wo: DVec3, h: DVec3) -> f64 {
        let c = wo.dot(h);
        if c <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        self.g1(wo) * c * self.d(h) / wo.z
    }

    /// The roughness a texture's factor `f` (in [0, 1]) makes: α times f, at least
    /// `MIN_TEXTURED_ALPHA`.
    #[inline]
    pub fn scaled(&self, f: f64) -> Roughness {
        Roughness {
            ax: (self.ax * f).max(MIN_TEXTURED_ALPHA),
            ay: (self.ay * f).max(MIN_TEXTURED_ALPHA),
        }
    }

    /// One α for the isotropic tables (the geometric mean).
    #[inline]
    fn mean(&self) -> f64 {
        (self.ax * self.ay).sqrt()
    }
}

/// Unpolarised Fresnel reflectance of a conductor with complex relative index n + ik at
/// incidence cosine `c` (the exact expression for |r_s|² and |r_p|²).
pub fn fresnel_conductor(c: f64, n: f64, k: f64) -> f64 {
    let c = c.clamp(0.0, 1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let t0 = n * n - k * k - s2;
    let a2b2 = (t0 * t0 + 4.0 * n * n * k * k).sqrt();
    let a = (0.5 * (a2b2 + t0)).max(0.0).sqrt();
    let t1 = a2b2 + c2;
    let t2 = 2.0 * c * a;
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = c2 * a2b2 + s2 * s2;
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    0.5 * (rs + rp)
}

/// Points in each direction of the albedo tables.
const TABLE: usize = 32;
/// The least α a roughness texture makes (its factor 0 is a near mirror, not a delta).
pub const MIN_TEXTURED_ALPHA: f64 = 1e-3;
/// Coat tables of a plastic whose roughness a texture varies, over α in [0, its α].
const COATS: usize = 17;
/// Stratified points per table entry (per axis).
const QUAD: usize = 48;

/// A function of the incidence cosine μ (grid μ_i = i / (TABLE − 1)) and, for anisotropic
/// roughness, of the azimuth from the tangent folded into [0, π/2] (grid of `phis`
/// points; the distribution is symmetric about both axes), read linearly.
#[derive(Debug, PartialEq)]
pub struct CosineTable {
    values: Vec<f64>,
    phis: usize,
    /// Its cosine-weighted mean over the hemisphere, 2∫ f(μ) μ dμ (azimuths averaged).
    pub average: f64,
}

impl Clone for CosineTable {
    fn clone(&self) -> Self {
        CosineTable {
            values: self.values.clone(),
            phis: self.phis,
            average: self.average,
        }
    }

    /// Reuses the values' allocation (a tinted hit's copy, `Glossy::tint_into`).
    fn clone_from(&mut self, source: &Self) {
        self.values.clone_from(&source.values);
        self.phis = source.phis;
        self.average = source.average;
    }
}

impl CosineTable {
    /// `a` and `b` (the same shape) mixed: (1 − f) a + f b, into `self`.
    fn mix_from(&mut self, a: &CosineTable, b: &CosineTable, f: f64) {
        self.values.clear();
        self.values.extend(
            a.values
                .iter()
                .zip(&b.values)
                .map(|(x, y)| x * (1.0 - f) + y * f),
        );
        self.phis = a.phis;
        self.average = a.average * (1.0 - f) + b.average * f;
    }

    fn build(f: impl Fn(f64) -> f64) -> Self {
        Self::build_2d(1, |mu, _| f(mu))
    }

    fn build_2d(phis: usize, f: impl Fn(f64, f64) -> f64) -> Self {
        let mut values = Vec::with_capacity(TABLE * phis);
        for i in 0..TABLE {
            let mu = (i as f64 / (TABLE - 1) as f64).max(1e-4);
            for j in 0..phis {
                let phi = if phis == 1 {
                    0.0
                } else {
                    0.5 * PI * j as f64 / (phis - 1) as f64
                };
                values.push(f(mu, phi));
            }
        }
        let mut t = CosineTable {
            values,
            phis,
            average: 0.0,
        };
        // 2∫ f μ dμ by Simpson's rule on a finer grid of the linear reading, the
        // azimuths averaged by the trapezoid rule.
        let n = 256;
        let m = 4 * phis.saturating_sub(1);
        let mut s = 0.0;
        for j in 0..=n {
            let mu = j as f64 / n as f64;
            let w = if j == 0 || j == n {
                1.0
            } else if j % 2 == 1 {
                4.0
            } else {
                2.0
            };
            let a = if phis == 1 {
                t.at_phi(mu, 0.0)
            } else {
                let sum: f64 = (0..=m)
                    .map(|k| {
                        let wk = if k == 0 || k == m { 0.5 } else { 1.0 };
                        wk * t.at_phi(mu, 0.5 * PI * k as f64 / m as f64)
                    })
                    .sum();
                sum / m as f64
            };
            s += w * a * mu;
        }
        t.average = 2.0 * s / (3.0 * n as f64);
        t
    }

    /// Its value at cosine `mu` (azimuth 0).
    #[inline]
    pub fn at(&self, mu: f64) -> f64 {
        self.at_phi(mu, 0.0)
    }

    /// Its value at the local direction `w`.
    #[inline]
    pub fn at_dir(&self, w: DVec3) -> f64 {
        if self.phis == 1 {
            return self.at(w.z.abs());
        }
        self.at_phi(w.z.abs(), w.y.abs().atan2(w.x.abs()))
    }

    /// Its value at cosine `mu` and azimuth `phi` in [0, π/2].
    #[inline]
    fn at_phi(&self, mu: f64, phi: f64) -> f64 {
        let x = mu.clamp(0.0, 1.0) * (TABLE - 1) as f64;
        let i = (x as usize).min(TABLE - 2);
        let f = x - i as f64;
        let row = |i: usize| -> f64 {
            let r = &self.values[i * self.phis..(i + 1) * self.phis];
            if self.phis == 1 {
                return r[0];
            }
            let y = (phi / (0.5 * PI)).clamp(0.0, 1.0) * (self.phis - 1) as f64;
            let j = (y as usize).min(self.phis - 2);
            let g = y - j as f64;
            r[j] * (1.0 - g) + r[j + 1] * g
        };
        row(i) * (1.0 - f) + row(i + 1) * f
    }
}

/// The directional albedo of single-scattering GGX reflection with Fresnel factor `fresnel`
/// (of the microfacet cosine), by stratified visible-normal quadrature: E(μ) = E[F G2/G1].
fn single_scattering_albedo(r: Roughness, mu: f64, phi: f64, fresnel: impl Fn(f64) -> f64) -> f64 {
    let s = (1.0 - mu * mu).max(0.0).sqrt();
    let wo = DVec3::new(s * phi.cos(), s * phi.sin(), mu);
    let mut s = 0.0;
    for i in 0..QUAD {
        for j in 0..QUAD {
            let h = r.sample_visible(
                wo,
                (i as f64 + 0.5) / QUAD as f64,
                (j as f64 + 0.5) / QUAD as f64,
            );
            let c = wo.dot(h);
            let wi = h * (2.0 * c) - wo;
            if wi.z > 0.0 && c > 0.0 {
                s += fresnel(c) * r.g2(wo, wi) / r.g1(wo);
            }
        }
    }
    s / (QUAD * QUAD) as f64
}

/// Isotropic GGX's white directional albedo E(μ, α) on a grid of α_j = j / (TABLE − 1) (α
/// above 1 reads α = 1), built once.
fn white_albedo() -> &'static [CosineTable] {
    static TABLES: OnceLock<Vec<CosineTable>> = OnceLock::new();
    TABLES.get_or_init(|| {
        (0..TABLE)
            .map(|j| {
                let a = (j as f64 / (TABLE - 1) as f64).max(1e-3);
                let r = Roughness { ax: a, ay: a };
                CosineTable::build(|mu| single_scattering_albedo(r, mu, 0.0, |_| 1.0))
            })
            .collect()
    })
}

/// E(μ) and its cosine-weighted mean for roughness `r` (its mean α), read from the white
/// tables.
fn white(r: Roughness, mu: f64) -> (f64, f64) {
    let t = white_albedo();
    let x = r.mean().clamp(0.0, 1.0) * (TABLE - 1) as f64;
    let j = (x as usize).min(TABLE - 2);
    let f = x - j as f64;
    let e = t[j].at(mu) * (1.0 - f) + t[j + 1].at(mu) * f;
    let avg = t[j].average * (1.0 - f) + t[j + 1].average * f;
    (e.min(1.0), avg.min(1.0))
}

/// A microfacet surface with its per-band constants.
#[derive(Clone, Debug)]
pub enum Glossy {
    /// A rough conductor: complex index `eta` + i`k` per band.
    Conductor {
        rough: Roughness,
        eta: Vec<f64>,
        k: Vec<f64>,
        /// The white albedo E(μ, φ) of anisotropic roughness (isotropic reads the shared
        /// tables).
        white: Option<CosineTable>,
        /// The multiple-scattering lobe that gives back what single scattering loses, when
        /// there is one.
        ms: Option<MultipleScattering>,
        /// Each band's Fresnel reflectance averaged over the hemisphere (`F_avg`), when
        /// the lobe is given back (empty otherwise): a roughness texture's hit rebuilds
        /// the lobe from it.
        f_avg: Vec<f64>,
        /// A texture's factor of its reflectance per band (empty: none).
        tint: Vec<f64>,
    },
    /// A rough dielectric interface: index `ior` per band inside (the side the normals
    /// point away from), air outside.
    Dielectric { rough: Roughness, ior: Vec<f64> },
    /// A diffuse base of albedo ρ per band under a rough coat of index `ior`: `coat` is
    /// the coat's directional albedo E(μ) seen from outside, `base_factor` per band
    /// ρ / (1 − ρ F_int) / n² (the light's series between base and coat), `base_max` the
    /// largest ρ (for the choice between coat and base); `base` is ρ itself and `coats`
    /// the coat's albedo over α when a texture varies its roughness.
    Plastic {
        rough: Roughness,
        ior: f64,
        coat: CosineTable,
        base_max: f64,
        base_factor: Vec<f64>,
        base: Vec<f64>,
        coats: Option<Arc<CoatStack>>,
    },
    /// A measured table (`scene::table`).
    Table(Arc<BsdfTable>),
    /// A window BSDF in a Klems basis (`scene::klems`): front and back differ.
    Klems(Arc<KlemsBsdf>),
    /// The host's own BSDF (`scene::host`).
    Host(Arc<HostSurface>),
}

/// The largest value (1/sr) of a measured table whose light the map's gathering paths
/// sample: about a GGX lobe's peak at α = 0.1 (`bsdf::GATHER_MIN_ALPHA`).
pub const TABLE_GATHER_PEAK: f64 = 8.0;

/// A conductor's Kulla–Conty lobe: the white albedo's hemispherical average E_avg and, per
/// band, F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)) (F_avg the Fresnel reflectance's
/// hemispherical average).
#[derive(Clone, Debug)]
pub struct MultipleScattering {
    e_avg: f64,
    f_ms: Vec<f64>,
}

impl MultipleScattering {
    /// Sets `ms` to the lobe of white albedo average `e_avg` and Fresnel averages `f_avg`
    /// (none when nothing is lost or nothing is given back), reusing its allocation.
    fn set(ms: &mut Option<MultipleScattering>, e_avg: f64, f_avg: &[f64]) {
        if f_avg.is_empty() || e_avg >= 1.0 - 1e-6 {
            *ms = None;
            return;
        }
        let m = ms.get_or_insert_with(|| MultipleScattering {
            e_avg,
            f_ms: Vec::with_capacity(f_avg.len()),
        });
        m.e_avg = e_avg;
        m.f_ms.clear();
        m.f_ms.extend(
            f_avg
                .iter()
                .map(|&fa| fa * fa * e_avg / (1.0 - fa * (1.0 - e_avg))),
        );
    }
}

/// A plastic's coat albedo tables at α_j = α j / (COATS − 1) (the least
/// `MIN_TEXTURED_ALPHA`), for hits whose roughness a texture scales down from α.
#[derive(Debug)]
pub struct CoatStack {
    alpha: f64,
    tables: Vec<CosineTable>,
}

/// A direction drawn from a glossy surface (`Glossy::sample`).
#[derive(Clone, Copy, Debug)]
pub struct GlossySample {
    /// Where light goes on (local frame).
    pub wi: DVec3,
    /// The density it was drawn with (1/sr).
    pub pdf: f64,
}

impl Glossy {
    /// A rough conductor with index `eta` + i`k` per band, its single-scattering loss given
    /// back (the tests' shorthand).
    #[cfg(test)]
    pub fn conductor(rough: Roughness, eta: Vec<f64>, k: Vec<f64>) -> Glossy {
        Self::conductor_with(rough, eta, k, true)
    }

    /// A rough conductor, with or without the multiple-scattering lobe (`compensate`).
    pub fn conductor_with(
        rough: Roughness,
        eta: Vec<f64>,
        k: Vec<f64>,
        compensate: bool,
    ) -> Glossy {
        let white = (rough.ax != rough.ay).then(|| {
            CosineTable::build_2d(9, |mu, phi| {
                single_scattering_albedo(rough, mu, phi, |_| 1.0)
            })
        });
        let e_avg = Self::white_at(rough, &white, DVec3::Z).1;
        let f_avg: Vec<f64> = if compensate {
            eta.iter()
                .zip(&k)
                .map(|(&n, &k)| CosineTable::build(|mu| fresnel_conductor(mu, n, k)).average)
                .collect()
        } else {
            Vec::new()
        };
        let mut ms = None;
        MultipleScattering::set(&mut ms, e_avg, &f_avg);
        Glossy::Conductor {
            rough,
            eta,
            k,
            white,
            ms,
            f_avg,
            tint: Vec::new(),
        }
    }

    /// A coated diffuse base: albedo `base` per band under a coat of index `ior`; with
    /// the coat's tables over α when a texture varies its (isotropic) roughness.
    pub fn plastic(rough: Roughness, ior: f64, base: Vec<f64>, rough_varies: bool) -> Glossy {
        let coat = Self::coat_albedo(rough, ior);
        let coats = rough_varies.then(|| {
            Arc::new(CoatStack {
                alpha: rough.ax,
                tables: (0..COATS)
                    .map(|j| {
                        let a = (rough.ax * j as f64 / (COATS - 1) as f64).max(MIN_TEXTURED_ALPHA);
                        Self::coat_albedo(Roughness { ax: a, ay: a }, ior)
                    })
                    .collect(),
            })
        });
        let mut base_factor = Vec::with_capacity(base.len());
        let base_max = Self::plastic_base(coat.average, ior, &base, None, &mut base_factor);
        Glossy::Plastic {
            rough,
            ior,
            coat,
            base_max,
            base_factor,
            base,
            coats,
        }
    }

    /// A coat's directional albedo E(μ) (and over the azimuth when anisotropic: 9
    /// azimuths over a quadrant).
    fn coat_albedo(rough: Roughness, ior: f64) -> CosineTable {
        let phis = if rough.ax == rough.ay { 1 } else { 9 };
        CosineTable::build_2d(phis, |mu, phi| {
            single_scattering_albedo(rough, mu, phi, |c| fresnel_dielectric(c, 1.0, ior))
        })
    }

    /// A plastic's base factor per band into `out` (its albedo `base` times `tint` when
    /// given) under a coat of albedo average `coat_avg`, and the largest albedo.
    fn plastic_base(
        coat_avg: f64,
        ior: f64,
        base: &[f64],
        tint: Option<&[f64]>,
        out: &mut Vec<f64>,
    ) -> f64 {
        // Light inside the coat meets it from below diffusely: what does not leave is
        // reflected back, 1 − (1 − E_avg) / n² (the coat's outside transmittance seen from
        // inside, by reciprocity).
        let f_int = 1.0 - (1.0 - coat_avg) / (ior * ior);
        out.clear();
        let mut max = 0.0f64;
        for (b, &r) in base.iter().enumerate() {
            let r = tint.map_or(r, |t| r * t[b]);
            max = max.max(r);
            out.push(r / (1.0 - r * f_int) / (ior * ior));
        }
        max
    }

    /// Whether a texture can vary it (`tint_into`): a conductor, a plastic or a rough
    /// dielectric; not a measured table, a window BSDF or the host's.
    #[inline]
    pub fn tintable(&self) -> bool {
        matches!(
            self,
            Glossy::Conductor { .. } | Glossy::Plastic { .. } | Glossy::Dielectric { .. }
        )
    }

    /// Makes `dst` this surface as a texture varies it at a hit: its colour coefficient
    /// (a conductor's reflectance, a plastic's base albedo) times `colour` per band, and
    /// its α times `alpha` (factors in [0, 1], so no energy is made; `Roughness::scaled`).
    /// `dst` may hold any earlier copy: its allocations are reused. Varying the roughness
    /// needs isotropic roughness (a conductor's shared tables, a plastic's `coats`), which
    /// `Material::new` has checked.
    pub fn tint_into(&self, colour: Option<&[f64]>, alpha: Option<f64>, dst: &mut Glossy) {
        let same = std::mem::discriminant(self) == std::mem::discriminant(&*dst);
        if !same || !self.tintable() {
            *dst = self.clone();
        }
        match (self, dst) {
            (
                Glossy::Conductor {
                    rough,
                    eta,
                    k,
                    white,
                    ms,
                    f_avg,
                    ..
                },
                Glossy::Conductor {
                    rough: r2,
                    eta: eta2,
                    k: k2,
                    white: white2,
                    ms: ms2,
                    f_avg: f2,
                    tint: t2,
                },
            ) => {
                eta2.clone_from(eta);
                k2.clone_from(k);
                white2.clone_from(white);
                f2.clone_from(f_avg);
                match alpha {
                    Some(a) => {
                        *r2 = rough.scaled(a);
                        MultipleScattering::set(ms2, self::white(*r2, 1.0).1, f_avg);
                    }
                    None => {
                        *r2 = *rough;
                        match ms {
                            Some(m) => MultipleScattering::set(ms2, m.e_avg, f_avg),
                            None => *ms2 = None,
                        }
                    }
                }
                t2.clear();
                if let Some(c) = colour {
                    t2.extend_from_slice(c);
                }
            }
            (
                Glossy::Plastic {
                    rough,
                    ior,
                    coat,
                    base,
                    coats,
                    ..
                },
                Glossy::Plastic {
                    rough: r2,
                    ior: ior2,
                    coat: coat2,
                    base_max: max2,
                    base_factor: bf2,
                    base: base2,
                    coats: coats2,
                },
            ) => {
                *ior2 = *ior;
                base2.clone_from(base);
                coats2.clone_from(coats);
                match (alpha, coats) {
                    (Some(a), Some(stack)) => {
                        *r2 = rough.scaled(a);
                        let x = (r2.ax / stack.alpha).clamp(0.0, 1.0) * (COATS - 1) as f64;
                        let j = (x as usize).min(COATS - 2);
                        coat2.mix_from(&stack.tables[j], &stack.tables[j + 1], x - j as f64);
                    }
                    _ => {
                        *r2 = *rough;
                        coat2.clone_from(coat);
                    }
                }
                *max2 = Self::plastic_base(coat2.average, *ior, base, colour, bf2);
            }
            (
                Glossy::Dielectric { rough, ior },
                Glossy::Dielectric {
                    rough: r2,
                    ior: ior2,
                },
            ) => {
                ior2.clone_from(ior);
                *r2 = alpha.map_or(*rough, |a| rough.scaled(a));
            }
            _ => {}
        }
    }

    /// Whether its lobes are sharper than the map's gathering paths take light samples at:
    /// an α below `min_alpha`, or a table peaking above `TABLE_GATHER_PEAK`.
    #[inline]
    pub fn sharper_than(&self, min_alpha: f64) -> bool {
        match self {
            Glossy::Conductor { rough, .. }
            | Glossy::Dielectric { rough, .. }
            | Glossy::Plastic { rough, .. } => rough.ax.min(rough.ay) < min_alpha,
            Glossy::Table(t) => t.peak > TABLE_GATHER_PEAK,
            Glossy::Klems(k) => k.peak > TABLE_GATHER_PEAK,
            Glossy::Host(h) => !(h.peak() > 0.0 && h.peak() <= TABLE_GATHER_PEAK),
        }
    }

    /// Whether light can leave on the other side.
    #[inline]
    pub fn transmits(&self) -> bool {
        match self {
            Glossy::Dielectric { .. } => true,
            Glossy::Table(t) => t.transmits(),
            Glossy::Klems(k) => k.transmits(),
            Glossy::Host(h) => h.transmits(),
            _ => false,
        }
    }

    /// Whether it is a rough dielectric interface (a medium's boundary that refracts): eye
    /// paths cross it by sampling alone, as a smooth one. Every other glossy surface,
    /// transmitting tables, window BSDFs and host BSDFs too, is evaluated by light samples.
    #[inline]
    pub fn refracts(&self) -> bool {
        matches!(self, Glossy::Dielectric { .. })
    }

    /// A rough dielectric as an interface against the dielectric of index `outside` (per
    /// band, or one for all) around it, in `dst`: the index ratio is all its Fresnel
    /// terms, refraction and radiance scaling read (a frosted part in an encapsulant, a
    /// bubble in a guide). Anything else is itself.
    pub fn against<'s>(&'s self, outside: &[f64], dst: &'s mut Option<Glossy>) -> &'s Glossy {
        let Glossy::Dielectric { rough, ior } = self else {
            return self;
        };
        let n = ior.len().max(outside.len());
        let at = |v: &[f64], b: usize| v[b.min(v.len() - 1)];
        let relative = (0..n).map(|b| at(ior, b) / at(outside, b));
        match dst {
            Some(Glossy::Dielectric { rough: r, ior: i }) => {
                *r = *rough;
                i.clear();
                i.extend(relative);
            }
            _ => {
                *dst = Some(Glossy::Dielectric {
                    rough: *rough,
                    ior: relative.collect(),
                })
            }
        }
        dst.as_ref().expect("just set")
    }

    /// Whether the dielectric's index differs between bands (a photon then collapses to
    /// one band, as at a smooth one).
    #[inline]
    pub fn dispersive(&self) -> bool {
        match self {
            Glossy::Dielectric { ior, .. } => ior.iter().any(|&n| n != ior[0]),
            _ => false,
        }
    }

    /// The indices on `wo`'s side and the other for band `band`: light arrives from
    /// outside when `front`.
    #[inline]
    fn indices(ior: &[f64], band: usize, front: bool) -> (f64, f64) {
        let n = ior[band.min(ior.len() - 1)];
        if front {
            (1.0, n)
        } else {
            (n, 1.0)
        }
    }

    /// The share of the conductor's sampling given to the multiple-scattering lobe at
    /// local direction `w`: what single scattering loses there.
    #[inline]
    fn conductor_split(
        rough: Roughness,
        table: &Option<CosineTable>,
        ms: &Option<MultipleScattering>,
        w: DVec3,
    ) -> f64 {
        if ms.is_some() {
            1.0 - Self::white_at(rough, table, w).0
        } else {
            0.0
        }
    }

    /// The white albedo E(w) and its average: an anisotropic conductor's own table, or
    /// the shared isotropic ones.
    #[inline]
    fn white_at(rough: Roughness, table: &Option<CosineTable>, w: DVec3) -> (f64, f64) {
        match table {
            Some(t) => (t.at_dir(w).min(1.0), t.average.min(1.0)),
            None => white(rough, w.z.abs()),
        }
    }

    /// The probability of sampling the coat's reflection rather than the base.
    #[inline]
    fn plastic_split(coat: &CosineTable, base_max: f64, wo: DVec3) -> f64 {
        let e = coat.at_dir(wo);
        let d = (1.0 - e) * base_max;
        if e + d <= 0.0 {
            1.0
        } else {
            (e / (e + d)).clamp(0.05, 1.0)
        }
    }

    /// f(wo → wi) per band into `out` (1/sr; the photon's kernel, module docs); `band`
    /// picks the dielectric's index, `front` whether `wo` is outside it.
    pub fn eval(&self, wo: DVec3, wi: DVec3, band: usize, front: bool, out: &mut [f64]) {
        if let Glossy::Table(t) = self {
            return t.eval(wo, wi, out);
        }
        if let Glossy::Klems(k) = self {
            return k.eval(wo, wi, front, out);
        }
        if let Glossy::Host(h) = self {
            return h.eval(wo, wi, front, out);
        }
        out.iter_mut().for_each(|x| *x = 0.0);
        if wo.z <= 0.0 {
            return;
        }
        match self {
            Glossy::Table(_) | Glossy::Klems(_) | Glossy::Host(_) => unreachable!("read above"),
            Glossy::Conductor {
                rough,
                eta,
                k,
                white,
                ms,
                tint,
                ..
            } => {
                if wi.z <= 0.0 {
                    return;
                }
                let h = (wo + wi).normalize();
                let d = rough.d(h) * rough.g2(wo, wi) / (4.0 * wo.z * wi.z);
                let c = wo.dot(h);
                for (b, o) in out.iter_mut().enumerate() {
                    *o = fresnel_conductor(c, eta[b], k[b]) * d;
                }
                if let Some(ms) = ms {
                    let e_o = Self::white_at(*rough, white, wo).0;
                    let e_i = Self::white_at(*rough, white, wi).0;
                    let lobe = (1.0 - e_o) * (1.0 - e_i) / (PI * (1.0 - ms.e_avg));
                    for (o, f) in out.iter_mut().zip(&ms.f_ms) {
                        *o += f * lobe;
                    }
                }
                for (o, t) in out.iter_mut().zip(tint) {
                    *o *= t;
                }
            }
            Glossy::Plastic {
                rough,
                ior,
                coat,
                base_factor,
                ..
            } => {
                if wi.z <= 0.0 {
                    return;
                }
                let h = (wo + wi).normalize();
                let spec = fresnel_dielectric(wo.dot(h), 1.0, *ior) * rough.d(h) * rough.g2(wo, wi)
                    / (4.0 * wo.z * wi.z);
                let t = (1.0 - coat.at_dir(wo)) * (1.0 - coat.at_dir(wi)) / PI;
                for (o, k) in out.iter_mut().zip(base_factor) {
                    *o = spec + k * t;
                }
            }
            Glossy::Dielectric { rough, ior } => {
                let (n_o, n_i) = Self::indices(ior, band, front);
                let v = if wi.z > 0.0 {
                    let h = (wo + wi).normalize();
                    fresnel_dielectric(wo.dot(h), n_o, n_i) * rough.d(h) * rough.g2(wo, wi)
                        / (4.0 * wo.z * wi.z)
                } else if wi.z < 0.0 {
                    let Some(h) = refraction_half(wo, wi, n_o, n_i) else {
                        return;
                    };
                    let (co, ci) = (wo.dot(h), wi.dot(h));
                    let denom = n_o * co + n_i * ci;
                    (1.0 - fresnel_dielectric(co, n_o, n_i))
                        * rough.d(h)
                        * rough.g2(wo, wi)
                        * co
                        * (-ci)
                        * n_i
                        * n_i
                        / (wo.z * (-wi.z) * denom * denom)
                } else {
                    0.0
                };
                out.iter_mut().for_each(|x| *x = v);
            }
        }
    }

    /// The density (1/sr) with which `sample` draws `wi` from `wo`.
    pub fn pdf(&self, wo: DVec3, wi: DVec3, band: usize, front: bool) -> f64 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        match self {
            Glossy::Table(t) => t.pdf(wo, wi),
            Glossy::Klems(k) => k.pdf(wo, wi, front),
            Glossy::Host(h) => h.pdf(wo, wi, front),
            Glossy::Conductor {
                rough, white, ms, ..
            } => {
                if wi.z <= 0.0 {
                    return 0.0;
                }
                let h = (wo + wi).normalize();
                let p_ms = Self::conductor_split(*rough, white, ms, wo);
                (1.0 - p_ms) * rough.pdf_visible(wo, h) / (4.0 * wo.dot(h)) + p_ms * wi.z / PI
            }
            Glossy::Plastic {
                rough,
                coat,
                base_max,
                ..
            } => {
                if wi.z <= 0.0 {
                    return 0.0;
                }
                let h = (wo + wi).normalize();
                let p = Self::plastic_split(coat, *base_max, wo);
                p * rough.pdf_visible(wo, h) / (4.0 * wo.dot(h)) + (1.0 - p) * wi.z / PI
            }
            Glossy::Dielectric { rough, ior } => {
                let (n_o, n_i) = Self::indices(ior, band, front);
                if wi.z > 0.0 {
                    let h = (wo + wi).normalize();
                    let f = fresnel_dielectric(wo.dot(h), n_o, n_i);
                    f * rough.pdf_visible(wo, h) / (4.0 * wo.dot(h))
                } else if wi.z < 0.0 {
                    let Some(h) = refraction_half(wo, wi, n_o, n_i) else {
                        return 0.0;
                    };
                    let (co, ci) = (wo.dot(h), wi.dot(h));
                    let denom = n_o * co + n_i * ci;
                    let f = fresnel_dielectric(co, n_o, n_i);
                    (1.0 - f) * rough.pdf_visible(wo, h) * n_i * n_i * (-ci) / (denom * denom)
                } else {
                    0.0
                }
            }
        }
    }

    /// A direction `wi` for light arriving from `wo`, from three uniform numbers (the
    /// first chooses the lobe or the side). None when the draw leaves nothing (a normal
    /// that sends it below the surface).
    pub fn sample(&self, wo: DVec3, u: [f64; 3], band: usize, front: bool) -> Option<GlossySample> {
        if wo.z <= 0.0 {
            return None;
        }
        if let Glossy::Host(h) = self {
            // The host gives the density with the direction (checked there).
            let (wi, pdf) = h.sample(wo, u, front)?;
            return Some(GlossySample { wi, pdf });
        }
        // Whether the draw sends light through (a dielectric's refraction).
        let mut through = false;
        let wi = match self {
            Glossy::Table(t) => {
                let wi = t.sample(wo, u)?;
                through = wi.z < 0.0;
                wi
            }
            Glossy::Klems(k) => {
                let wi = k.sample(wo, u, front)?;
                through = wi.z < 0.0;
                wi
            }
            Glossy::Host(_) => unreachable!("drawn above"),
            Glossy::Conductor {
                rough, white, ms, ..
            } => {
                let p_ms = Self::conductor_split(*rough, white, ms, wo);
                if u[0] < p_ms {
                    cosine_local(u[1], u[2])
                } else {
                    let h = rough.sample_visible(wo, u[1], u[2]);
                    h * (2.0 * wo.dot(h)) - wo
                }
            }
            Glossy::Plastic {
                rough,
                coat,
                base_max,
                ..
            } => {
                if u[0] < Self::plastic_split(coat, *base_max, wo) {
                    let h = rough.sample_visible(wo, u[1], u[2]);
                    h * (2.0 * wo.dot(h)) - wo
                } else {
                    cosine_local(u[1], u[2])
                }
            }
            Glossy::Dielectric { rough, ior } => {
                let (n_o, n_i) = Self::indices(ior, band, front);
                let h = rough.sample_visible(wo, u[1], u[2]);
                let c = wo.dot(h);
                if u[0] < fresnel_dielectric(c, n_o, n_i) {
                    h * (2.0 * c) - wo
                } else {
                    // Snell at the microfacet (TIR has Fresnel 1: never here).
                    let eta = n_o / n_i;
                    let s2 = eta * eta * (1.0 - c * c);
                    if s2 >= 1.0 {
                        return None;
                    }
                    let ct = (1.0 - s2).sqrt();
                    through = true;
                    (h * (eta * c - ct) - wo * eta).normalize()
                }
            }
        };
        // A microfacet can send the light to the wrong side of the surface: nothing then.
        if through != (wi.z < 0.0) || wi.z == 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi, band, front);
        (pdf > 0.0 && pdf.is_finite()).then_some(GlossySample { wi, pdf })
    }

    /// `sample`, and each band's weight f cos / pdf of the drawn direction into `w` (what
    /// light going on along it carries per unit arriving): every estimator's step. A rough
    /// dielectric of index ratio 1 is no interface: straight on, weight 1, density infinite.
    pub fn sample_weighted(
        &self,
        wo: DVec3,
        u: [f64; 3],
        band: usize,
        front: bool,
        w: &mut [f64],
    ) -> Option<GlossySample> {
        if let Glossy::Dielectric { ior, .. } = self {
            let (n_o, n_i) = Self::indices(ior, band, front);
            if n_o == n_i && wo.z > 0.0 {
                // Index matched (a frosted part in a medium of its own index, or of index
                // 1 in air): no interface, light goes straight on whole (a delta: its
                // density is infinite).
                w.iter_mut().for_each(|x| *x = 1.0);
                return Some(GlossySample {
                    wi: -wo,
                    pdf: f64::INFINITY,
                });
            }
        }
        let s = self.sample(wo, u, band, front)?;
        self.eval(wo, s.wi, band, front, w);
        let k = s.wi.z.abs() / s.pdf;
        w.iter_mut().for_each(|x| *x *= k);
        Some(s)
    }
}

/// The microfacet normal (z > 0) that refracts `wo` (index `n_o` side, z > 0) into `wi`
/// (index `n_i`, z < 0); None when no normal does.
#[inline]
fn refraction_half(wo: DVec3, wi: DVec3, n_o: f64, n_i: f64) -> Option<DVec3> {
    let h = -(wo * n_o + wi * n_i);
    let len = h.length();
    if len.is_nan() || len <= 0.0 || n_o == n_i {
        return None;
    }
    let mut h = h / len;
    if h.z < 0.0 {
        h = -h;
    }
    (wo.dot(h) > 0.0 && wi.dot(h) < 0.0).then_some(h)
}

/// A cosine-distributed direction about +z.
#[inline]
fn cosine_local(u1: f64, u2: f64) -> DVec3 {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt())
}

/// A surface's local frame: the normal of the side light arrives on and a tangent.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub t: DVec3,
    pub b: DVec3,
    pub n: DVec3,
}

impl Frame {
    /// The frame about unit `n` whose tangent is `tangent` projected onto the surface (a
    /// fixed one when it is none; along the normal, +y projected, else +x: the same on
    /// both sides, as a window BSDF's up needs).
    #[inline]
    pub fn new(n: DVec3, tangent: Option<DVec3>) -> Frame {
        let project = |t: DVec3| Some(t - n * t.dot(n)).filter(|t| t.length_squared() > 1e-12);
        let t = match tangent {
            None => n.any_orthonormal_vector(),
            Some(t) => project(t)
                .or_else(|| project(DVec3::Y))
                .or_else(|| project(DVec3::X))
                .unwrap_or(DVec3::X)
                .normalize(),
        };
        Frame {
            t,
            b: n.cross(t),
            n,
        }
    }

    #[inline]
    pub fn to_local(self, v: DVec3) -> DVec3 {
        DVec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    #[inline]
    pub fn to_world(self, v: DVec3) -> DVec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::PhotonRng;

    fn direction(mu: f64, phi: f64) -> DVec3 {
        let s = (1.0 - mu * mu).max(0.0).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), mu)
    }

    /// A conductor that reflects everything (k ≫ n: Fresnel 1).
    fn white_conductor(ax: f64, ay: f64) -> Glossy {
        Glossy::conductor(Roughness { ax, ay }, vec![1e-4], vec![1e4])
    }

    /// The directional albedo by sampling: the mean of f cos / pdf per band (band 0),
    /// with its standard error.
    fn albedo(g: &Glossy, wo: DVec3, front: bool, n: usize, seed: u64) -> (f64, f64, f64) {
        let mut rng = PhotonRng::new(seed, 3);
        let mut f = vec![0.0];
        let (mut s, mut s2, mut t) = (0.0, 0.0, 0.0);
        for _ in 0..n {
            let u = [rng.uniform(), rng.uniform(), rng.uniform()];
            let mut w = 0.0;
            if let Some(x) = g.sample(wo, u, 0, front) {
                g.eval(wo, x.wi, 0, front, &mut f);
                w = f[0] * x.wi.z.abs() / x.pdf;
                if x.wi.z < 0.0 {
                    t += w;
                }
            }
            s += w;
            s2 += w * w;
        }
        let m = s / n as f64;
        (
            m,
            ((s2 / n as f64 - m * m).max(0.0) / n as f64).sqrt(),
            t / n as f64,
        )
    }

    /// The white furnace: a lossless conductor and a white plastic reflect everything at
    /// every roughness and angle (multiple scattering given back), anisotropic ones too.
    #[test]
    fn white_furnace_is_one_for_the_compensated_models() {
        for &(ax, ay) in &[
            (0.02, 0.02),
            (0.1, 0.1),
            (0.3, 0.3),
            (0.6, 0.6),
            (1.0, 1.0),
            (0.1, 0.6),
        ] {
            let tol = 0.015;
            for &mu in &[0.15, 0.4, 0.7, 0.98] {
                let wo = direction(mu, 0.7);
                let (e, se, _) = albedo(&white_conductor(ax, ay), wo, true, 40_000, 1);
                assert!(
                    (e - 1.0).abs() < tol + 4.0 * se,
                    "conductor α ({ax}, {ay}) μ {mu}: albedo {e} ± {se}"
                );
                let p = Glossy::plastic(Roughness { ax, ay }, 1.5, vec![1.0], false);
                let (e, se, _) = albedo(&p, wo, true, 40_000, 2);
                assert!(
                    (e - 1.0).abs() < tol + 4.0 * se,
                    "white plastic α ({ax}, {ay}) μ {mu}: albedo {e} ± {se}"
                );
            }
        }
    }

    /// Every model's albedo stays at most 1, coloured and rough dielectric ones included.
    #[test]
    fn no_model_reflects_more_than_it_receives() {
        for &a in &[0.05, 0.3, 1.0] {
            let r = Roughness { ax: a, ay: a };
            let models = [
                Glossy::conductor(r, vec![1.2], vec![7.0]),
                Glossy::conductor(r, vec![0.2], vec![3.0]),
                Glossy::plastic(r, 1.5, vec![0.5], false),
                Glossy::plastic(r, 1.9, vec![0.9], false),
                Glossy::Dielectric {
                    rough: r,
                    ior: vec![1.5],
                },
            ];
            for g in &models {
                for &front in &[true, false] {
                    for &mu in &[0.1, 0.5, 0.95] {
                        let (e, se, _) = albedo(g, direction(mu, 0.3), front, 20_000, 5);
                        assert!(e <= 1.0 + 4.0 * se + 1e-3, "{g:?} μ {mu}: {e} ± {se}");
                        assert!(e > 0.0);
                    }
                }
            }
        }
    }

    /// The rough dielectric loses what multiple scattering between microfacets would
    /// return, and no more than the docs say (docs/materials.md): at normal incidence from
    /// outside, n = 1.5, 0.1 % at α = 0.1, 1.2 % at 0.3, 4.5 % at 0.6, 10.7 % at 1.
    #[test]
    fn rough_dielectric_loss_is_what_the_docs_say() {
        for &(a, most) in &[(0.1, 0.002), (0.3, 0.014), (0.6, 0.05), (1.0, 0.115)] {
            let g = Glossy::Dielectric {
                rough: Roughness { ax: a, ay: a },
                ior: vec![1.5],
            };
            let (e, se, _) = albedo(&g, direction(1.0, 0.0), true, 100_000, 9);
            assert!(1.0 - e < most + 3.0 * se, "α {a}: R + T = {e} ± {se}");
        }
    }

    /// f is reciprocal: f(a, b) = f(b, a) for reflection, f(a, b) / n_b² = f(b, a) / n_a²
    /// through the rough dielectric (the kernel photons carry power by).
    #[test]
    fn evaluation_is_reciprocal() {
        let r = Roughness { ax: 0.2, ay: 0.5 };
        let mut f1 = vec![0.0; 2];
        let mut f2 = vec![0.0; 2];
        let a = direction(0.8, 0.3);
        let b = direction(0.35, 2.0);
        let c = direction(0.85, 2.0);
        for g in [
            Glossy::conductor(r, vec![1.2, 0.3], vec![7.0, 3.0]),
            Glossy::plastic(r, 1.5, vec![0.5, 0.8], false),
            Glossy::Dielectric {
                rough: r,
                ior: vec![1.5, 1.5],
            },
        ] {
            g.eval(a, b, 0, true, &mut f1);
            g.eval(b, a, 0, true, &mut f2);
            for k in 0..2 {
                assert!(
                    (f1[k] - f2[k]).abs() <= 1e-12 * f1[k].abs().max(1.0),
                    "{g:?}"
                );
                assert!(f1[k] > 0.0);
            }
        }
        let g = Glossy::Dielectric {
            rough: r,
            ior: vec![1.5],
        };
        let below = DVec3::new(c.x, c.y, -c.z);
        // a outside (front), `below` inside; and back from inside.
        g.eval(a, below, 0, true, &mut f1);
        let flip = |v: DVec3| DVec3::new(v.x, v.y, -v.z);
        g.eval(flip(below), flip(a), 0, false, &mut f2);
        assert!(f1[0] > 0.0);
        assert!(
            (f1[0] / (1.5 * 1.5) - f2[0]).abs() < 1e-9 * f2[0],
            "{} / n² vs {}",
            f1[0],
            f2[0]
        );
    }

    /// The sampled directions' histogram matches `pdf` (χ² over 8 × 16 cells of (cos θ, φ)
    /// on each side), for every model and anisotropic roughness.
    #[test]
    fn sampled_directions_follow_the_density() {
        let r = Roughness { ax: 0.15, ay: 0.45 };
        let models = [
            (
                Glossy::conductor(Roughness { ax: 0.4, ay: 0.4 }, vec![1e-4], vec![1e4]),
                true,
            ),
            (Glossy::conductor(r, vec![1.2], vec![7.0]), true),
            (Glossy::plastic(r, 1.5, vec![0.6], false), true),
            (
                Glossy::Dielectric {
                    rough: r,
                    ior: vec![1.5],
                },
                true,
            ),
            (
                Glossy::Dielectric {
                    rough: r,
                    ior: vec![1.5],
                },
                false,
            ),
        ];
        let (nt, np) = (8usize, 16usize);
        let n = 200_000;
        for (g, front) in &models {
            let wo = direction(0.6, 0.4);
            let mut counts = vec![0.0; 2 * nt * np];
            let mut rng = PhotonRng::new(17, 5);
            let cell = |w: DVec3| {
                let side = usize::from(w.z < 0.0);
                let t = ((w.z.abs() * nt as f64) as usize).min(nt - 1);
                let p = ((w.y.atan2(w.x) + PI) / (2.0 * PI) * np as f64) as usize;
                (side * nt + t) * np + p.min(np - 1)
            };
            for _ in 0..n {
                let u = [rng.uniform(), rng.uniform(), rng.uniform()];
                if let Some(s) = g.sample(wo, u, 0, *front) {
                    counts[cell(s.wi)] += 1.0;
                }
            }
            // Expected counts: the pdf integrated over each cell (16 × 16 midpoints).
            let mut chi2 = 0.0;
            let mut dof = 0;
            for side in 0..2 {
                for t in 0..nt {
                    for p in 0..np {
                        let mut e = 0.0;
                        let m = 16;
                        for i in 0..m {
                            for j in 0..m {
                                let mu = (t as f64 + (i as f64 + 0.5) / m as f64) / nt as f64;
                                let phi =
                                    (p as f64 + (j as f64 + 0.5) / m as f64) / np as f64 * 2.0 * PI
                                        - PI;
                                let mut w = direction(mu, phi);
                                if side == 1 {
                                    w.z = -w.z;
                                }
                                // dω = dμ dφ.
                                e += g.pdf(wo, w, 0, *front);
                            }
                        }
                        e *= (1.0 / nt as f64) * (2.0 * PI / np as f64) / (m * m) as f64 * n as f64;
                        let o = counts[(side * nt + t) * np + p];
                        if e > 20.0 {
                            chi2 += (o - e) * (o - e) / e;
                            dof += 1;
                        }
                    }
                }
            }
            assert!(dof > 10, "{g:?}: {dof} cells");
            let limit = dof as f64 + 6.0 * (2.0 * dof as f64).sqrt();
            assert!(
                chi2 < limit,
                "{g:?} front {front}: χ² {chi2:.0} over {dof} cells"
            );
        }
    }

    /// α → 0: the conductor is the mirror with the conductor's Fresnel reflectance, the
    /// rough dielectric the smooth one's reflectance and transmittance.
    #[test]
    fn the_smooth_limit_is_the_mirror_and_the_smooth_dielectric() {
        let r = Roughness { ax: 1e-3, ay: 1e-3 };
        for &mu in &[0.3, 0.8] {
            let wo = direction(mu, 1.1);
            let (n, k) = (1.2, 7.0);
            let (e, se, _) = albedo(&Glossy::conductor(r, vec![n], vec![k]), wo, true, 20_000, 4);
            let f = fresnel_conductor(mu, n, k);
            assert!(
                (e - f).abs() < 0.003 + 3.0 * se,
                "μ {mu}: {e} vs Fresnel {f}"
            );
            let s = Glossy::conductor(r, vec![n], vec![k])
                .sample(wo, [0.5, 0.3, 0.6], 0, true)
                .unwrap();
            let mirror = DVec3::new(-wo.x, -wo.y, wo.z);
            assert!((s.wi - mirror).length() < 0.01, "{:?} vs {mirror:?}", s.wi);
            let g = Glossy::Dielectric {
                rough: r,
                ior: vec![1.5],
            };
            let (e, se, t) = albedo(&g, wo, true, 40_000, 6);
            let fr = fresnel_dielectric(mu, 1.0, 1.5);
            assert!((e - 1.0).abs() < 0.002 + 3.0 * se, "μ {mu}: R + T = {e}");
            assert!(
                (t - (1.0 - fr)).abs() < 0.01,
                "μ {mu}: T {t} vs {}",
                1.0 - fr
            );
        }
    }

    /// The conductor's Fresnel reflectance meets the dielectric one at k = 0 and the known
    /// normal-incidence value ((n−1)² + k²) / ((n+1)² + k²).
    #[test]
    fn conductor_fresnel_is_right() {
        for &c in &[0.1, 0.5, 0.9, 1.0] {
            let a = fresnel_conductor(c, 1.5, 0.0);
            let b = fresnel_dielectric(c, 1.0, 1.5);
            assert!((a - b).abs() < 1e-9, "cos {c}: {a} vs {b}");
        }
        let (n, k): (f64, f64) = (1.2, 7.0);
        let r0 = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
        assert!((fresnel_conductor(1.0, n, k) - r0).abs() < 1e-12);
        assert!((fresnel_conductor(0.0, n, k) - 1.0).abs() < 1e-12);
    }

    /// Against Mitsuba 3 (`scripts/mitsuba_bsdf.py`, tests/data/mitsuba_bsdf.txt): the
    /// single-scattering conductor's and the rough dielectric's albedo at normal incidence,
    /// where Mitsuba's separable masking and our height-correlated one are the same.
    #[test]
    fn albedos_match_mitsuba_at_normal_incidence() {
        let text = include_str!("../../tests/data/mitsuba_bsdf.txt");
        let mut rows = 0;
        for line in text.lines().filter(|l| !l.starts_with('#')) {
            let w: Vec<&str> = line.split_whitespace().collect();
            let a: f64 = w[1].parse().unwrap();
            let front = w[2] == "1";
            let (mi, se): (f64, f64) = (w[3].parse().unwrap(), w[4].parse().unwrap());
            let r = Roughness { ax: a, ay: a };
            let (ours, our_se) = match w[0] {
                "conductor" => (
                    single_scattering_albedo(r, 1.0, 0.0, |c| fresnel_conductor(c, 1.2, 7.0)),
                    0.0,
                ),
                _ => {
                    let g = Glossy::Dielectric {
                        rough: r,
                        ior: vec![1.5],
                    };
                    let (e, s, _) = albedo(&g, DVec3::Z, front, 100_000, 21);
                    (e, s)
                }
            };
            let tol = 4.0 * (se * se + our_se * our_se).sqrt() + 0.002;
            assert!(
                (ours - mi).abs() < tol,
                "{line}: ours {ours} ± {our_se}, Mitsuba {mi} ± {se}"
            );
            rows += 1;
        }
        assert_eq!(rows, 12);
    }

    /// A texture's factors: a conductor's α × f is the conductor built at that α (its
    /// multiple-scattering lobe rebuilt), its reflectance × c scales f by c; a plastic's
    /// α × f between its coat tables stays within the white furnace and near the plastic
    /// built at that α; a copy holding another surface is overwritten whole.
    #[test]
    fn tinted_copies_are_the_surfaces_they_describe() {
        let dirs = [
            (direction(0.9, 0.3), direction(0.7, 3.0)),
            (direction(0.3, 1.0), direction(0.35, 4.0)),
            (direction(0.1, 0.0), direction(0.95, 2.0)),
        ];
        let eval = |g: &Glossy, wo, wi| {
            let mut f = vec![0.0; 2];
            g.eval(wo, wi, 0, true, &mut f);
            f
        };
        let (eta, k) = (vec![1.2, 0.9], vec![7.0, 6.0]);
        let rough = |a| Roughness { ax: a, ay: a };
        let base = Glossy::conductor(rough(0.6), eta.clone(), k.clone());
        let mut copy = Glossy::plastic(rough(0.2), 1.5, vec![0.5, 0.5], false);
        base.tint_into(None, Some(0.25), &mut copy);
        let at = Glossy::conductor(rough(0.15), eta.clone(), k.clone());
        for &(wo, wi) in &dirs {
            let (a, b) = (eval(&copy, wo, wi), eval(&at, wo, wi));
            for (x, y) in a.iter().zip(&b) {
                assert!((x - y).abs() <= 1e-12 * y.abs(), "{a:?} / {b:?}");
            }
            assert_eq!(copy.pdf(wo, wi, 0, true), at.pdf(wo, wi, 0, true));
        }
        base.tint_into(Some(&[0.5, 0.25]), None, &mut copy);
        for &(wo, wi) in &dirs {
            let (a, b) = (eval(&copy, wo, wi), eval(&base, wo, wi));
            assert!((a[0] - 0.5 * b[0]).abs() <= 1e-15 * b[0], "{a:?} / {b:?}");
            assert!((a[1] - 0.25 * b[1]).abs() <= 1e-15 * b[1], "{a:?} / {b:?}");
        }
        // A white plastic at α 0.5 × 0.37 (between two coat tables).
        let plastic = Glossy::plastic(rough(0.5), 1.5, vec![1.0], true);
        let mut copy = base.clone();
        plastic.tint_into(None, Some(0.37), &mut copy);
        let at = Glossy::plastic(rough(0.5 * 0.37), 1.5, vec![1.0], false);
        for (i, mu) in [0.1, 0.5, 0.95].into_iter().enumerate() {
            let wo = direction(mu, 0.4);
            let (a, sa, _) = albedo(&copy, wo, true, 40_000, 7 + i as u64);
            let (b, sb, _) = albedo(&at, wo, true, 40_000, 7 + i as u64);
            assert!(
                a <= 1.0 + 4.0 * sa && (a - b).abs() < 5.0 * (sa * sa + sb * sb).sqrt() + 0.01,
                "μ {mu}: {a} ± {sa} / {b} ± {sb}"
            );
        }
    }
}

//! What a surface does to light arriving on it: the one interface every estimator asks
//! (the photon tracer, the map's light samples and gathering paths, the renderer's eye
//! paths and the path tracer).
//!
//! A surface's `Bsdf` is seen in the frame of the side light arrives on: `n_in` is the
//! unit normal on that side, and directions are world directions measured against it (a
//! reflected direction has ω·n_in > 0, a transmitted one < 0). It is either
//! - a set of lobes, each with an albedo per band: Lambertian reflection, mirror
//!   reflection and Lambertian transmission today (`Lobe`); what no lobe takes is
//!   absorbed; or
//! - a smooth dielectric interface (`Dielectric`), which reflects or refracts by Fresnel.
//!
//! Estimators choose a lobe by their own weighting of the albedos (`Bsdf::choose` by a
//! photon's colour, the renderer by its path weight) and then its direction
//! (`Lobe::direction`); light sampling evaluates the BSDF (`Bsdf::eval`) and the density
//! of its directions (`Bsdf::pdf`). Each band's value stays exact: a lobe's weight per
//! band is its albedo over the chosen probability.

use super::material::{Dielectric, Material};
use super::microfacet::{Frame, Glossy};
use crate::sampling::warp;
use glam::DVec3;
use std::f64::consts::PI;

/// The least GGX α of a glossy surface the map's gathering paths take light samples at
/// (`Bsdf::gathers`).
pub const GATHER_MIN_ALPHA: f64 = 0.1;

/// One way a surface scatters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobe {
    /// Lambertian reflection: f = ρ/π on the side light came from.
    DiffuseReflection,
    /// Mirror reflection (a delta lobe).
    SpecularReflection,
    /// Lambertian transmission: f = τ/π on the other side.
    DiffuseTransmission,
}

impl Lobe {
    /// Every lobe, in the order estimators try them.
    pub const ALL: [Lobe; 3] = [
        Lobe::DiffuseReflection,
        Lobe::SpecularReflection,
        Lobe::DiffuseTransmission,
    ];

    /// Whether its directions spread over a hemisphere (light sampling and gathering can
    /// evaluate it), not a delta.
    #[inline]
    pub fn is_diffuse(self) -> bool {
        !matches!(self, Lobe::SpecularReflection)
    }

    /// Whether light leaves on the other side of the surface.
    #[inline]
    pub fn transmits(self) -> bool {
        matches!(self, Lobe::DiffuseTransmission)
    }

    /// The normal of the side light leaves on: `n_in`, or −`n_in` for transmission.
    #[inline]
    pub fn leaving_normal(self, n_in: DVec3) -> DVec3 {
        if self.transmits() {
            -n_in
        } else {
            n_in
        }
    }

    /// The direction light arriving along `dir` leaves in, from two uniform numbers (the
    /// mirror needs none): cosine-distributed about the leaving side's normal for the
    /// diffuse lobes.
    #[inline]
    pub fn direction(self, dir: DVec3, n_in: DVec3, u1: f64, u2: f64) -> DVec3 {
        match self {
            Lobe::DiffuseReflection => warp::cosine_hemisphere(n_in, u1, u2),
            Lobe::SpecularReflection => reflect(dir, n_in),
            Lobe::DiffuseTransmission => warp::cosine_hemisphere(-n_in, u1, u2),
        }
    }

    /// Its index among `ALL`.
    #[inline]
    fn index(self) -> usize {
        self as usize
    }
}

/// A surface's scattering (`Material::bsdf`).
#[derive(Clone, Copy, Debug)]
pub struct Bsdf<'a> {
    material: &'a Material,
}

impl Material {
    /// Its scattering.
    #[inline]
    pub fn bsdf(&self) -> Bsdf<'_> {
        Bsdf { material: self }
    }
}

// `eval` and `pdf` are the interface's evaluation: its tests use them today, and the
// rough and measured surfaces' light sampling next.
#[cfg_attr(not(test), allow(dead_code))]
impl<'a> Bsdf<'a> {
    /// The smooth dielectric interface it is, if it is one.
    #[inline]
    pub fn interface(&self) -> Option<&'a Dielectric> {
        if self.material.glossy.is_some() {
            return None;
        }
        self.material.dielectric.as_ref()
    }

    /// The microfacet surface it is, if it is one.
    #[inline]
    pub fn glossy(&self) -> Option<&'a Glossy> {
        self.material.glossy.as_ref()
    }

    /// A glossy surface that light sampling evaluates (a rough conductor, a coated diffuse
    /// base, a table, a window BSDF or a host BSDF, reflecting or transmitting; not a rough
    /// dielectric): eye paths take light samples there, on both sides when it transmits,
    /// and the map's gathering paths too when it only reflects and is rough enough
    /// (`gathers`).
    #[inline]
    pub fn is_glossy(&self) -> bool {
        self.glossy().is_some_and(|g| !g.refracts())
    }

    /// f per band into `out` for light arriving from world direction `from` (pointing
    /// away from the surface, toward where the light comes from) and leaving along world
    /// direction `to`, at a point whose normal on `to`'s side is `n_to` (`front_to`: that
    /// side is the one the normals point to). The BSDF is read in the frame of the side
    /// light arrives on, so surfaces whose two sides differ (window BSDFs, host BSDFs) are
    /// read the right way round. Zeros when it is not glossy.
    #[inline]
    pub fn eval_toward(
        &self,
        n_to: DVec3,
        front_to: bool,
        from: DVec3,
        to: DVec3,
        out: &mut [f64],
    ) {
        let Some(g) = self.glossy() else {
            out.iter_mut().for_each(|x| *x = 0.0);
            return;
        };
        let (n, front) = if from.dot(n_to) >= 0.0 {
            (n_to, front_to)
        } else {
            (-n_to, !front_to)
        };
        let frame = self.frame(n);
        g.eval(frame.to_local(from), frame.to_local(to), 0, front, out);
    }

    /// Whether the map's gathering paths take light samples here and a photon's first
    /// event here counts as gathered: diffuse lobes, and glossy reflectors with every α at
    /// least `GATHER_MIN_ALPHA` (tables: peaking at most `TABLE_GATHER_PEAK`; a sharper lobe
    /// makes light samples spiky: photons bring its light, as a mirror's).
    #[inline]
    pub fn gathers(&self) -> bool {
        match self.glossy() {
            Some(g) => !g.transmits() && !g.sharper_than(GATHER_MIN_ALPHA),
            None => self.is_diffuse(),
        }
    }

    /// The local frame at a point with normal `n_in` on the arriving side.
    #[inline]
    pub fn frame(&self, n_in: DVec3) -> Frame {
        Frame::new(n_in, self.material.tangent)
    }

    /// A direction for a path travelling against the light (an eye or gathering path) that
    /// reached this glossy surface from world direction `to` (normal `n_to` on its side,
    /// `front_to` as in `eval_toward`): drawn by the surface's sampling, with each band's
    /// f cos / pdf, f read the way light travels (from the drawn direction toward `to`),
    /// into `out`. The drawn world direction and its density; None when the draw leaves
    /// nothing or the surface is not glossy.
    #[inline]
    pub fn sample_against_light(
        &self,
        n_to: DVec3,
        front_to: bool,
        to: DVec3,
        u: [f64; 3],
        out: &mut [f64],
    ) -> Option<(DVec3, f64)> {
        let frame = self.frame(n_to);
        let s = self.glossy()?.sample(frame.to_local(to), u, 0, front_to)?;
        let wi = frame.to_world(s.wi);
        self.eval_toward(n_to, front_to, wi, to, out);
        let k = s.wi.z.abs() / s.pdf;
        out.iter_mut().for_each(|x| *x *= k);
        Some((wi, s.pdf))
    }

    /// Whether it has lobe `lobe` (some band's albedo above 0).
    #[inline]
    pub fn has(&self, lobe: Lobe) -> bool {
        self.material.events[lobe.index()]
    }

    /// A fluorescent Lambertian reflector's re-emission (`Material::fluorescence`).
    #[inline]
    pub fn fluorescence(&self) -> Option<&'a super::material::Fluorescence> {
        self.material.fluorescence.as_deref()
    }

    /// The albedo per band of `lobe` (0 in every band for one it lacks, and for an
    /// interface).
    #[inline]
    pub fn albedo(&self, lobe: Lobe) -> &'a [f64] {
        let m = self.material;
        match lobe {
            Lobe::DiffuseReflection => &m.diffuse_reflect,
            Lobe::SpecularReflection => &m.specular_reflect,
            Lobe::DiffuseTransmission => &m.diffuse_transmit,
        }
    }

    /// Whether it scatters diffusely (reflects or transmits by a hemisphere lobe): where
    /// light can be gathered and light samples evaluated.
    #[inline]
    pub fn is_diffuse(&self) -> bool {
        self.interface().is_none()
            && self.glossy().is_none()
            && (self.has(Lobe::DiffuseReflection) || self.has(Lobe::DiffuseTransmission))
    }

    /// Whether eye paths cross it by sampling alone (a mirror, a smooth interface or a
    /// rough dielectric): where caustics form.
    #[inline]
    pub fn is_specular(&self) -> bool {
        self.interface().is_some()
            || self.has(Lobe::SpecularReflection)
            || self.glossy().is_some_and(Glossy::refracts)
    }

    /// The lobes it has, in `Lobe::ALL`'s order, with their albedos.
    #[inline]
    pub fn lobes(&self) -> impl Iterator<Item = (Lobe, &'a [f64])> + 'a {
        let b = *self;
        Lobe::ALL
            .into_iter()
            .filter(move |&l| b.has(l))
            .map(move |l| (l, b.albedo(l)))
    }

    /// The share of light that leaves at all, each lobe's albedo weighed by `weigh` (a
    /// photon's colour-weighted band mean): the survival probability.
    #[inline]
    pub fn survival(&self, weigh: impl Fn(&[f64]) -> f64) -> f64 {
        self.lobes().map(|(_, k)| weigh(k)).sum::<f64>()
    }

    /// Chooses a lobe for uniform `u` with probability `weigh(albedo)` each, in
    /// `Lobe::ALL`'s order: (lobe, its albedo, its probability); None (absorbed) past
    /// their sum.
    #[inline]
    pub fn choose(&self, u: f64, weigh: impl Fn(&[f64]) -> f64) -> Option<(Lobe, &'a [f64], f64)> {
        let mut cumulative = 0.0;
        for (lobe, k) in self.lobes() {
            let p = weigh(k);
            cumulative += p;
            if u < cumulative {
                return Some((lobe, k, p));
            }
        }
        None
    }

    /// f(ω_o → ω_i) in band `band`, 1/sr, for light arriving on the side of `n_in` and
    /// leaving along `wi`: ρ/π on that side, τ/π on the other; the mirror's delta and an
    /// interface are 0 here (they are sampled, never evaluated).
    #[inline]
    pub fn eval(&self, n_in: DVec3, wi: DVec3, band: usize) -> f64 {
        let lobe = if wi.dot(n_in) > 0.0 {
            Lobe::DiffuseReflection
        } else {
            Lobe::DiffuseTransmission
        };
        if self.interface().is_some() || !self.has(lobe) {
            return 0.0;
        }
        self.albedo(lobe)[band] / PI
    }

    /// The density (1/sr) of `wi` when a lobe is chosen by `weigh` (`choose`) and its
    /// direction drawn by `Lobe::direction`: the diffuse lobes' part (the mirror's delta
    /// has none), a sub-density whose integral is the diffuse lobes' probability.
    #[inline]
    pub fn pdf(&self, n_in: DVec3, wi: DVec3, weigh: impl Fn(&[f64]) -> f64) -> f64 {
        if self.interface().is_some() {
            return 0.0;
        }
        let cos = wi.dot(n_in);
        let lobe = if cos > 0.0 {
            Lobe::DiffuseReflection
        } else {
            Lobe::DiffuseTransmission
        };
        if !self.has(lobe) {
            return 0.0;
        }
        weigh(self.albedo(lobe)) * cos.abs() / PI
    }
}

/// Mirror reflection of `d` about unit normal `n`.
#[inline]
pub fn reflect(d: DVec3, n: DVec3) -> DVec3 {
    (d - n * (2.0 * d.dot(n))).normalize()
}

/// Refraction of `d` through a surface with unit normal `n` on the incident side, incidence
/// cosine `cos_i` and relative index `eta` = n1/n2 (the caller handled total internal
/// reflection: Fresnel is 1 there).
#[inline]
pub fn refract(d: DVec3, n: DVec3, cos_i: f64, eta: f64) -> DVec3 {
    let sin_t2 = eta * eta * (1.0 - cos_i * cos_i);
    let cos_t = (1.0 - sin_t2).max(0.0).sqrt();
    (d * eta + n * (eta * cos_i - cos_t)).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::PhotonRng;
    use crate::scene::MaterialDesc;
    use crate::spectral::Bands;

    fn material(d: f64, s: f64, t: f64) -> Material {
        Material::new(
            &MaterialDesc {
                diffuse_reflect: vec![d],
                specular_reflect: vec![s],
                diffuse_transmit: vec![t],
                ..Default::default()
            },
            &Bands::rgb(),
        )
        .unwrap()
    }

    #[test]
    fn refraction_obeys_snell() {
        let n = DVec3::Z;
        let theta: f64 = 0.6;
        let d = DVec3::new(theta.sin(), 0.0, -theta.cos());
        let t = refract(d, n, theta.cos(), 1.0 / 1.5);
        let sin_t = t.x;
        assert!((sin_t * 1.5 - theta.sin()).abs() < 1e-12);
        assert!(t.z < 0.0);
        let r = reflect(d, n);
        assert!((r - DVec3::new(theta.sin(), 0.0, theta.cos())).length() < 1e-12);
    }

    /// Sampling a lobe and a direction and weighing by albedo / probability gives, on
    /// average, the BSDF's integral f cos over each side: the albedos (a furnace of one
    /// bounce); the density `pdf` matches the sampled directions' histogram by side.
    #[test]
    fn sampled_lobes_give_each_albedo_and_the_density_matches() {
        let m = material(0.5, 0.2, 0.25);
        let b = m.bsdf();
        let n = DVec3::new(0.3, -0.2, 0.9).normalize();
        let dir = DVec3::new(0.1, 0.4, -1.0).normalize();
        let mean = |k: &[f64]| k.iter().sum::<f64>() / k.len() as f64;
        let mut rng = PhotonRng::new(9, 1);
        let (mut up, mut down, mut mirror) = (0.0, 0.0, 0.0);
        let n_samples = 200_000;
        let mut pdf_ratio: f64 = 0.0;
        for _ in 0..n_samples {
            let Some((lobe, k, p)) = b.choose(rng.uniform(), mean) else {
                continue;
            };
            let wi = lobe.direction(dir, n, rng.uniform(), rng.uniform());
            let w = k[0] / p;
            match lobe {
                Lobe::SpecularReflection => mirror += w,
                _ if wi.dot(n) > 0.0 => up += w,
                _ => down += w,
            }
            if lobe.is_diffuse() {
                // f cos / pdf is the weight k / p the sample carries.
                let r = b.eval(n, wi, 0) * wi.dot(n).abs() / b.pdf(n, wi, mean);
                pdf_ratio = pdf_ratio.max((r - w).abs());
            }
        }
        let f = n_samples as f64;
        assert!((up / f - 0.5).abs() < 0.01, "reflected {}", up / f);
        assert!((down / f - 0.25).abs() < 0.01, "transmitted {}", down / f);
        assert!((mirror / f - 0.2).abs() < 0.01, "mirror {}", mirror / f);
        assert!(
            pdf_ratio < 1e-12,
            "f cos / pdf differs from k / p by {pdf_ratio}"
        );
        assert!(b.survival(mean) <= 1.0 + 1e-12);
    }

    /// f is reciprocal and zero where a lobe is missing; an interface is sampled, never
    /// evaluated.
    #[test]
    fn eval_is_reciprocal_and_zero_without_the_lobe() {
        let n = DVec3::Z;
        let a = DVec3::new(0.3, 0.1, 0.9).normalize();
        let c = DVec3::new(-0.5, 0.2, 0.7).normalize();
        let m = material(0.6, 0.0, 0.0);
        assert_eq!(m.bsdf().eval(n, a, 1), m.bsdf().eval(n, c, 1));
        assert!((m.bsdf().eval(n, a, 0) - 0.6 / PI).abs() < 1e-15);
        assert_eq!(m.bsdf().eval(n, -a, 0), 0.0);
        let glass = Material::new(
            &MaterialDesc {
                ior: Some(crate::scene::IorModel::Constant(1.5)),
                ..Default::default()
            },
            &Bands::rgb(),
        )
        .unwrap();
        assert!(glass.bsdf().interface().is_some());
        assert_eq!(glass.bsdf().eval(n, a, 0), 0.0);
        assert_eq!(glass.bsdf().lobes().count(), 0);
        assert!(glass.bsdf().choose(0.0, |_| 1.0).is_none());
    }
}

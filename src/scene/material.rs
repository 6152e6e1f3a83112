//! Materials: what happens to a photon at a surface.
//!
//! A non-dielectric surface has per-band probabilities of diffuse (Lambertian) reflection,
//! specular (mirror) reflection and diffuse (Lambertian) transmission; the rest is absorbed.
//! A dielectric surface is a smooth interface between air (outside, the side the normals
//! point to) and a medium with a wavelength-dependent index of refraction (constant, Cauchy
//! or Sellmeier) and Beer–Lambert absorption inside; it reflects or refracts by Fresnel.

use super::klems::KlemsBsdf;
use super::microfacet::{Glossy, Roughness};
use super::table::{BsdfTable, TableDesc};
use crate::error::{bail, check_finite, Result};
use crate::spectral::Bands;
use glam::DVec3;

/// What kind of surface a material is (`MaterialDesc::surface`).
#[derive(Clone, Debug, Default, PartialEq)]
pub enum SurfaceModel {
    /// Lambertian reflection and transmission and a mirror by their coefficients, or a
    /// smooth dielectric when an index is given.
    #[default]
    Ideal,
    /// A rough conductor (GGX) of complex index n + ik.
    Conductor(ConductorIndex),
    /// A rough dielectric interface (GGX): the index and absorption as a smooth one's.
    RoughDielectric,
    /// A Lambertian base (`diffuse_reflect`) under a rough dielectric coat of constant
    /// index (`ior`).
    Plastic,
    /// A measured BRDF (and BTDF) table (`scene::table`).
    Table(TableDesc),
    /// A window BSDF file (LBNL WINDOW / Radiance XML, Klems basis; `scene::klems`): the
    /// mesh's normals point to its front side, `tangent` is its up direction (default +z).
    Klems(std::path::PathBuf),
    /// The host's own BSDF (`scene::host`), checked when added.
    Host(super::host::HostBsdfRef),
}

/// A conductor's complex index.
#[derive(Clone, Debug, PartialEq)]
pub enum ConductorIndex {
    /// One of the shipped metals (`scene::metals`).
    Metal(Metal),
    /// Rows of (wavelength nm, n, k), wavelengths increasing; read linearly.
    Table(Vec<[f64; 3]>),
}

/// The metals whose measured index ships with the library.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metal {
    Aluminium,
    Silver,
    Gold,
    Copper,
    Chromium,
}

impl Metal {
    /// Its (nm, n, k) rows.
    pub fn table(self) -> &'static [[f64; 3]] {
        use super::metals::*;
        match self {
            Metal::Aluminium => ALUMINIUM,
            Metal::Silver => SILVER,
            Metal::Gold => GOLD,
            Metal::Copper => COPPER,
            Metal::Chromium => CHROMIUM,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Metal::Aluminium => "aluminium",
            Metal::Silver => "silver",
            Metal::Gold => "gold",
            Metal::Copper => "copper",
            Metal::Chromium => "chromium",
        }
    }
}

/// How the index of refraction depends on the wavelength λ.
#[derive(Clone, Debug, PartialEq)]
pub enum IorModel {
    /// n(λ) = n.
    Constant(f64),
    /// n(λ) = A + B/λ² + C/λ⁴, λ in micrometres.
    Cauchy { a: f64, b: f64, c: f64 },
    /// n²(λ) = 1 + Σ Bᵢλ²/(λ² − Cᵢ), λ in micrometres, Cᵢ in µm² (Schott's form).
    Sellmeier { b: [f64; 3], c: [f64; 3] },
}

impl IorModel {
    /// The index at wavelength `nm` nanometres.
    pub fn ior(&self, nm: f64) -> f64 {
        let l = nm * 1e-3;
        let l2 = l * l;
        match *self {
            IorModel::Constant(n) => n,
            IorModel::Cauchy { a, b, c } => a + b / l2 + c / (l2 * l2),
            IorModel::Sellmeier { b, c } => {
                let s: f64 = (0..3).map(|i| b[i] * l2 / (l2 - c[i])).sum();
                (1.0 + s).sqrt()
            }
        }
    }
}

/// A dielectric medium bounded by the mesh's surface.
#[derive(Clone)]
pub struct Dielectric {
    /// Index of refraction per band.
    pub ior: Vec<f64>,
    /// True when the index differs between bands: photons then collapse to one band.
    pub dispersive: bool,
    /// Beer–Lambert absorption coefficient per band, in 1/m. `None` when clear.
    pub absorption_per_m: Option<Vec<f64>>,
    /// Scattering inside (`None`: none).
    pub scattering: Option<crate::scene::medium::Scattering>,
}

/// As derived, but `scattering` only when present: the state fingerprint hashes this text,
/// and a scene without scattering keeps the fingerprint it had before scattering existed.
impl std::fmt::Debug for Dielectric {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut d = f.debug_struct("Dielectric");
        d.field("ior", &self.ior)
            .field("dispersive", &self.dispersive)
            .field("absorption_per_m", &self.absorption_per_m);
        if let Some(s) = &self.scattering {
            d.field("scattering", s);
        }
        d.finish()
    }
}

/// A surface material, with per-band coefficients.
#[derive(Clone)]
pub struct Material {
    pub diffuse_reflect: Vec<f64>,
    pub specular_reflect: Vec<f64>,
    pub diffuse_transmit: Vec<f64>,
    pub dielectric: Option<Dielectric>,
    /// Which of the three non-dielectric events can happen (some band above 0): the tracer
    /// spends no per-band work on the others.
    pub events: [bool; 3],
    /// A microfacet surface (then the coefficients above are 0 and `dielectric` holds a
    /// rough dielectric's medium).
    pub glossy: Option<Glossy>,
    /// The direction the roughness `ax` runs along (projected onto each triangle).
    pub tangent: Option<DVec3>,
    /// The texture (`Scene::textures`) that multiplies its coefficients, read at the
    /// mesh's texture coordinates (`scene::texture`).
    pub texture: Option<u32>,
    /// Which coefficients a texture and a mesh's vertex factors multiply: 1 diffuse
    /// reflectance (a plastic's base), 2 specular reflectance (a conductor's
    /// reflectance), 4 diffuse transmittance, 8 roughness (a microfacet surface's α), or-ed.
    pub tint_lobes: u8,
    /// Its tangent is each triangle's direction of increasing texture coordinate u
    /// (`tangent` where the coordinates are degenerate).
    pub uv_tangent: bool,
    /// A Lambertian surface's fluorescence (spectral runs): what it re-emits diffusely in
    /// longer-wavelength bands.
    pub fluorescence: Option<std::sync::Arc<Fluorescence>>,
}

/// Fluorescence of a Lambertian surface: of the power arriving in band i, the share
/// `m[i][j]` is re-emitted diffusely (Lambertian, on the side it arrived) in band j, only
/// for bands of longer wavelength. With the diffuse reflectance ρ the surface sends on, per
/// band j, ρ_j c_j + Σ_i m[i][j] c_i of an arriving colour c (`send_on`); read backward (an
/// eye path's weights β), it takes ρ_i β_i + Σ_j m[i][j] β_j from band i (`take_from`).
#[derive(Clone, Debug, PartialEq)]
pub struct Fluorescence {
    /// Band count; `m` is bands × bands, row i the excitation band.
    pub bands: usize,
    pub m: Vec<f64>,
}

impl Fluorescence {
    /// What the surface of diffuse reflectance `rho` sends on per band for arriving `c`:
    /// `out` = ρ∘c + mᵀc, and the re-emitted part alone, mᵀc, into `emitted`.
    #[inline]
    pub fn send_on(&self, rho: &[f64], c: &[f64], out: &mut [f64], emitted: &mut [f64]) {
        let nb = self.bands;
        emitted.iter_mut().for_each(|x| *x = 0.0);
        for (i, &ci) in c.iter().enumerate() {
            if ci == 0.0 {
                continue;
            }
            for (e, m) in emitted.iter_mut().zip(&self.m[i * nb..(i + 1) * nb]) {
                *e += ci * m;
            }
        }
        for j in 0..nb {
            out[j] = rho[j] * c[j] + emitted[j];
        }
    }

    /// The adjoint, for eye paths: `beta` ← ρ∘β + mβ (the weight each band of arriving
    /// light has toward what the path carries), using `scratch`.
    #[inline]
    pub fn take_from(&self, rho: &[f64], beta: &mut [f64], scratch: &mut Vec<f64>) {
        let nb = self.bands;
        scratch.clear();
        scratch.extend((0..nb).map(|i| {
            let row = &self.m[i * nb..(i + 1) * nb];
            rho[i] * beta[i] + row.iter().zip(beta.iter()).map(|(m, b)| m * b).sum::<f64>()
        }));
        beta.copy_from_slice(scratch);
    }
}

/// As derived, but `uv_tangent` only when set: the state fingerprint hashes this text, and a
/// scene that does not use a feature keeps the fingerprint it had before the feature
/// existed (a state saved before it still resumes).
impl std::fmt::Debug for Material {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut d = f.debug_struct("Material");
        d.field("diffuse_reflect", &self.diffuse_reflect)
            .field("specular_reflect", &self.specular_reflect)
            .field("diffuse_transmit", &self.diffuse_transmit)
            .field("dielectric", &self.dielectric)
            .field("events", &self.events)
            .field("glossy", &self.glossy)
            .field("tangent", &self.tangent)
            .field("texture", &self.texture)
            .field("tint_lobes", &self.tint_lobes);
        if self.uv_tangent {
            d.field("uv_tangent", &self.uv_tangent);
        }
        if let Some(f) = &self.fluorescence {
            d.field("fluorescence", f);
        }
        d.finish()
    }
}

impl Material {
    /// Whether it is a dielectric whose inside scatters.
    pub fn scatters(&self) -> bool {
        self.dielectric
            .as_ref()
            .is_some_and(|d| d.scattering.is_some())
    }

    /// A medium's extinction coefficient σt per band (1/m): its scattering medium's, or
    /// its absorption; None for anything else (a clear dielectric too).
    #[inline]
    pub fn extinction(&self) -> Option<&[f64]> {
        let d = self.dielectric.as_ref()?;
        match &d.scattering {
            Some(sc) => Some(&sc.sigma_t),
            None => d.absorption_per_m.as_deref(),
        }
    }

    /// Whether the material fluoresces: a fluorescent surface, or a dielectric whose
    /// medium re-emits what it absorbs.
    pub fn fluoresces(&self) -> bool {
        self.fluorescence.is_some()
            || self
                .dielectric
                .as_ref()
                .and_then(|d| d.scattering.as_ref())
                .is_some_and(|s| s.fluorescence.is_some())
    }

    /// Whether it is a dielectric whose inside absorbs or scatters: a medium.
    pub fn holds_medium(&self) -> bool {
        self.dielectric
            .as_ref()
            .is_some_and(|d| d.absorption_per_m.is_some() || d.scattering.is_some())
    }
}

/// `tint_lobes`: the diffuse reflectance (a plastic's base albedo).
pub const LOBE_DIFFUSE_REFLECT: u8 = 1;
/// `tint_lobes`: the specular reflectance (a conductor's reflectance).
pub const LOBE_SPECULAR_REFLECT: u8 = 2;
/// `tint_lobes`: the diffuse transmittance.
pub const LOBE_DIFFUSE_TRANSMIT: u8 = 4;
/// `tint_lobes`: a microfacet surface's roughness α.
pub const LOBE_ROUGHNESS: u8 = 8;

/// What the caller describes; the per-band arrays hold 0 values (none), 1 (grey) or one per
/// band.
#[derive(Clone, Debug, Default)]
pub struct MaterialDesc {
    pub diffuse_reflect: Vec<f64>,
    pub specular_reflect: Vec<f64>,
    pub diffuse_transmit: Vec<f64>,
    pub ior: Option<IorModel>,
    pub absorption_per_m: Vec<f64>,
    /// A dielectric's scattering coefficient per band, 1/m (empty: none).
    pub scattering_per_m: Vec<f64>,
    /// The Henyey–Greenstein asymmetry of its scattering per band, in (−1, 1) (empty: 0,
    /// isotropic).
    pub phase_g: Vec<f64>,
    /// A tabulated phase function instead, for all bands: scattering angles in degrees (0
    /// first, 180 last, increasing) and the function's values there (≥ 0, any scale: it is
    /// normalised), linear in the angle between them. Both empty: none.
    pub phase_angles_deg: Vec<f64>,
    pub phase_values: Vec<f64>,
    /// Fluorescence of a Lambertian surface (spectral runs only): bands × bands shares,
    /// row i the excitation band, column j the emission band, of the power arriving in
    /// band i that the surface re-emits diffusely in band j (0 unless band j's wavelength
    /// is longer). For a dielectric with `absorption_per_m` (smooth or rough): of the power
    /// its medium absorbs in band i, the share it re-emits isotropically in band j (each
    /// row's sum at most 1). Empty: none.
    pub fluorescence: Vec<f64>,
    /// The kind of surface.
    pub surface: SurfaceModel,
    /// GGX α along the tangent and the bitangent (a microfacet surface's; [0, 0] for an
    /// ideal one); α_y = 0 means α_y = α_x.
    pub roughness: [f64; 2],
    /// The tangent direction of anisotropic roughness (world), or None (any).
    pub tangent: Option<[f64; 3]>,
    /// A conductor without its multiple-scattering lobe: single scattering only, as
    /// Mitsuba 3's `roughconductor` and most renderers compute it (it then loses energy at
    /// high roughness: 3 % at α 0.15, docs/materials.md). For comparisons.
    pub single_scattering: bool,
    /// A texture (an id from `Context::add_texture`) that multiplies the coefficients
    /// `texture_lobes` names, read at the mesh's texture coordinates.
    pub texture: Option<u32>,
    /// Which coefficients the texture and a mesh's vertex factors multiply (`LOBE_*`,
    /// or-ed): 1 diffuse reflectance (a plastic's base albedo), 2 specular reflectance (a
    /// rough conductor's reflectance), 4 diffuse transmittance, 8 roughness (a
    /// microfacet surface's α, by the mean of the bands' factors); 0 means the surface's
    /// colour (1; a conductor's 2; a rough dielectric's roughness, 8).
    pub texture_lobes: u8,
    /// The tangent of a microfacet, measured or host surface (the direction of
    /// `roughness[0]`, a table's φ = 0, a window BSDF's up) is each triangle's direction of
    /// increasing texture coordinate u (the mesh then needs `uvs`); `tangent`, when given,
    /// where a triangle's coordinates are degenerate.
    pub tangent_from_uvs: bool,
}

impl Material {
    /// Validates a description against the band layout.
    pub fn new(desc: &MaterialDesc, bands: &Bands) -> Result<Self> {
        if desc.single_scattering && !matches!(desc.surface, SurfaceModel::Conductor(_)) {
            bail!(
                ImapErrBadMaterial,
                "single scattering is a conductor's option: this surface has no multiple-scattering lobe to leave out"
            );
        }
        if desc.texture_lobes > 15 {
            bail!(
                ImapErrInvalidArgument,
                "texture_lobes = {} is not an or of 1 (diffuse reflectance), 2 (specular reflectance), 4 (diffuse transmittance) and 8 (roughness)",
                desc.texture_lobes
            );
        }
        let medium = !desc.scattering_per_m.is_empty()
            || !desc.phase_g.is_empty()
            || !desc.phase_angles_deg.is_empty()
            || !desc.phase_values.is_empty();
        if medium
            && !(desc.ior.is_some()
                && matches!(
                    desc.surface,
                    SurfaceModel::Ideal | SurfaceModel::RoughDielectric
                ))
        {
            bail!(
                ImapErrBadMaterial,
                "scattering_per_m, phase_g or a phase table is given but the material is not a dielectric (smooth or rough, with an index of refraction): a medium is the inside of a dielectric"
            );
        }
        if !desc.fluorescence.is_empty()
            && !matches!(
                desc.surface,
                SurfaceModel::Ideal | SurfaceModel::RoughDielectric
            )
        {
            bail!(
                ImapErrBadMaterial,
                "fluorescence is given but the surface is neither a Lambertian reflector nor a dielectric (whose medium would fluoresce)"
            );
        }
        let lobes = Self::tint_lobes(desc)?;
        if desc.surface != SurfaceModel::Ideal {
            let mut m = Self::microfacet(desc, bands)?;
            m.texture = desc.texture;
            m.tint_lobes = lobes;
            m.uv_tangent = desc.tangent_from_uvs;
            return Ok(m);
        }
        if desc.tangent_from_uvs {
            bail!(
                ImapErrBadMaterial,
                "tangent_from_uvs is set but the surface is ideal (Lambertian, mirror or smooth dielectric): it has no tangent"
            );
        }
        if desc.roughness != [0.0, 0.0] || desc.tangent.is_some() {
            bail!(
                ImapErrBadMaterial,
                "roughness = {:?} is given but the surface is ideal (Lambertian, mirror or smooth dielectric): choose a microfacet surface",
                desc.roughness
            );
        }
        if !desc.fluorescence.is_empty() && desc.ior.is_none() {
            return Self::fluorescent(desc, bands);
        }
        Self::ideal(desc, bands)
    }

    /// A fluorescent Lambertian reflector, checked: a spectral run, an ideal surface
    /// without index, specular reflectance, transmittance or texture, bands × bands finite
    /// shares ≥ 0, none toward a band of shorter or equal wavelength, and per excitation
    /// band the reflectance and the re-emitted shares at most 1.
    fn fluorescent(desc: &MaterialDesc, bands: &Bands) -> Result<Self> {
        if desc.surface != SurfaceModel::Ideal || desc.ior.is_some() {
            bail!(
                ImapErrBadMaterial,
                "fluorescence is given but the surface is not a Lambertian reflector (an ideal surface without an index of refraction)"
            );
        }
        let any = |v: &[f64]| v.iter().any(|&x| x != 0.0);
        if any(&desc.specular_reflect) || any(&desc.diffuse_transmit) {
            bail!(
                ImapErrBadMaterial,
                "fluorescence is given with a specular reflectance or diffuse transmittance: a fluorescent surface is a Lambertian reflector"
            );
        }
        if desc.texture.is_some() {
            bail!(
                ImapErrUnsupported,
                "fluorescence with a texture is not supported: give the fluorescent part its own material"
            );
        }
        let m = Self::fluorescence_matrix(desc, bands)?;
        let nb = bands.count();
        let nm = &bands.wavelengths_nm;
        let mut mat = Self::ideal(desc, bands)?;
        for i in 0..nb {
            let total = mat.diffuse_reflect[i] + m[i * nb..(i + 1) * nb].iter().sum::<f64>();
            if total > 1.0 + 1e-12 {
                bail!(
                    ImapErrBadMaterial,
                    "band {i} ({} nm): the diffuse reflectance {} and the shares re-emitted from it (fluorescence[{}..{}]) add up to {total}, above 1",
                    nm[i],
                    mat.diffuse_reflect[i],
                    i * nb,
                    (i + 1) * nb
                );
            }
        }
        // Diffuse even where ρ is 0 everywhere: the surface sends light on.
        mat.events[0] = true;
        mat.fluorescence = Some(std::sync::Arc::new(Fluorescence {
            bands: nb,
            m: m.to_vec(),
        }));
        Ok(mat)
    }

    /// A fluorescent medium's re-emission (a dielectric with absorption), checked as a
    /// surface's matrix (`fluorescence_matrix`), and per excitation band the shares
    /// re-emitted of what the medium absorbs at most 1.
    fn medium_fluorescence(
        desc: &MaterialDesc,
        bands: &Bands,
        absorption: Option<&[f64]>,
    ) -> Result<Fluorescence> {
        let m = Self::fluorescence_matrix(desc, bands)?;
        if absorption.is_none() {
            bail!(
                ImapErrBadMaterial,
                "fluorescence is given to a dielectric whose medium absorbs nothing (absorption is 0 in every band): a medium re-emits what it absorbs"
            );
        }
        let nb = bands.count();
        for i in 0..nb {
            let total = m[i * nb..(i + 1) * nb].iter().sum::<f64>();
            if total > 1.0 + 1e-12 {
                bail!(
                    ImapErrBadMaterial,
                    "band {i} ({} nm): the shares of what the medium absorbs that it re-emits (fluorescence[{}..{}]) add up to {total}, above 1",
                    bands.wavelengths_nm[i],
                    i * nb,
                    (i + 1) * nb
                );
            }
        }
        Ok(Fluorescence {
            bands: nb,
            m: m.to_vec(),
        })
    }

    /// A fluorescence matrix, checked: a spectral run, bands × bands finite shares ≥ 0,
    /// none toward a band of shorter or equal wavelength.
    fn fluorescence_matrix<'d>(desc: &'d MaterialDesc, bands: &Bands) -> Result<&'d [f64]> {
        if bands.rgb {
            bail!(
                ImapErrUnsupported,
                "fluorescence needs a spectral run: RGB bands have no wavelengths for light to shift between (configure spectral bands)"
            );
        }
        let nb = bands.count();
        let m = &desc.fluorescence;
        if m.len() != nb * nb {
            bail!(
                ImapErrBadMaterial,
                "fluorescence has {} values: it needs bands × bands = {nb} × {nb} = {} (row: the excitation band, column: the emission band)",
                m.len(),
                nb * nb
            );
        }
        let nm = &bands.wavelengths_nm;
        for (k, &x) in m.iter().enumerate() {
            let (i, j) = (k / nb, k % nb);
            if !x.is_finite() {
                bail!(ImapErrNonFinite, "fluorescence[{k}] = {x} is not finite");
            }
            if x < 0.0 {
                bail!(
                    ImapErrBadMaterial,
                    "fluorescence[{k}] = {x} (excitation band {i}, emission band {j}) must be >= 0"
                );
            }
            if x > 0.0 && nm[j] <= nm[i] {
                bail!(
                    ImapErrBadMaterial,
                    "fluorescence[{k}] = {x} re-emits band {i} ({} nm) in band {j} ({} nm): fluorescence re-emits at longer wavelengths only",
                    nm[i],
                    nm[j]
                );
            }
        }
        Ok(m)
    }

    /// A dielectric's scattering: σs per band (finite, ≥ 0; all 0 or none: `None`) and g
    /// per band (finite, in (−1, 1); none: 0).
    fn scattering(
        desc: &MaterialDesc,
        bands: &Bands,
        absorption: Option<&[f64]>,
    ) -> Result<Option<crate::scene::medium::Scattering>> {
        let table = !desc.phase_angles_deg.is_empty() || !desc.phase_values.is_empty();
        let fluorescent = !desc.fluorescence.is_empty();
        if desc.scattering_per_m.is_empty() {
            if !desc.phase_g.is_empty() || table {
                bail!(
                    ImapErrBadMaterial,
                    "{} is given but scattering_per_m is not: a phase function needs scattering",
                    if table {
                        "a phase table (phase_angles_deg, phase_values)"
                    } else {
                        "phase_g"
                    }
                );
            }
            if !fluorescent {
                return Ok(None);
            }
        }
        let table = if table {
            if !desc.phase_g.is_empty() {
                bail!(
                    ImapErrBadMaterial,
                    "phase_g and a phase table (phase_angles_deg, phase_values) are both given: give one phase function"
                );
            }
            Some(std::sync::Arc::new(Self::phase_table(desc)?))
        } else {
            None
        };
        let s = if desc.scattering_per_m.is_empty() {
            // A fluorescent medium that only absorbs: its collisions re-emit.
            vec![0.0; bands.count()]
        } else {
            bands.expand("scattering_per_m", &desc.scattering_per_m)?
        };
        if let Some(i) = s.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
            bail!(
                ImapErrBadMaterial,
                "scattering_per_m[{i}] = {} must be finite and >= 0 (1/m)",
                s[i]
            );
        }
        let g = if desc.phase_g.is_empty() {
            vec![0.0; bands.count()]
        } else {
            bands.expand("phase_g", &desc.phase_g)?
        };
        if let Some(i) = g.iter().position(|x| !(x.is_finite() && x.abs() < 1.0)) {
            bail!(
                ImapErrBadMaterial,
                "phase_g[{i}] = {} must be inside (-1, 1) (Henyey-Greenstein asymmetry)",
                g[i]
            );
        }
        if s.iter().all(|&x| x == 0.0) && !fluorescent {
            return Ok(None);
        }
        let mut sc = crate::scene::medium::Scattering::new(s, absorption, g);
        sc.table = table;
        if fluorescent {
            let fl = Self::medium_fluorescence(desc, bands, absorption)?;
            sc.set_fluorescence(fl);
        }
        Ok(Some(sc))
    }

    /// The most points a phase table may have.
    const MAX_PHASE_POINTS: usize = 100_000;

    /// A tabulated phase function, checked: as many values as angles (2 … 100 000), the
    /// angles from 0 to 180 degrees increasing, the values finite, ≥ 0, not all 0.
    fn phase_table(desc: &MaterialDesc) -> Result<crate::scene::medium::PhaseTable> {
        let (a, v) = (&desc.phase_angles_deg, &desc.phase_values);
        if a.len() != v.len() || a.len() < 2 || a.len() > Self::MAX_PHASE_POINTS {
            bail!(
                ImapErrBadMaterial,
                "the phase table has {} angles (phase_angles_deg) and {} values (phase_values): give as many of each, 2 to {}",
                a.len(),
                v.len(),
                Self::MAX_PHASE_POINTS
            );
        }
        if a[0] != 0.0 || a[a.len() - 1] != 180.0 {
            bail!(
                ImapErrBadMaterial,
                "the phase table's angles (phase_angles_deg) run from {} to {}: they must run from 0 to 180 (degrees)",
                a[0],
                a[a.len() - 1]
            );
        }
        if let Some(i) = (1..a.len()).find(|&i| !(a[i] > a[i - 1] && a[i].is_finite())) {
            bail!(
                ImapErrBadMaterial,
                "the phase table's angle {i} (phase_angles_deg[{i}]) = {} does not follow angle {} = {}: the angles must increase",
                a[i],
                i - 1,
                a[i - 1]
            );
        }
        if let Some(i) = v.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
            bail!(
                ImapErrBadMaterial,
                "the phase table's value {i} (phase_values[{i}]) = {} must be finite and >= 0",
                v[i]
            );
        }
        if v.iter().all(|&x| x == 0.0) {
            bail!(
                ImapErrBadMaterial,
                "the phase table's values (phase_values) are all 0: a phase function must scatter somewhere"
            );
        }
        Ok(crate::scene::medium::PhaseTable::new(a, v))
    }

    /// An ideal surface's description.
    fn ideal(desc: &MaterialDesc, bands: &Bands) -> Result<Self> {
        let per_band = |name: &str, v: &[f64]| -> Result<Vec<f64>> {
            if v.is_empty() {
                return Ok(vec![0.0; bands.count()]);
            }
            let v = bands.expand(name, v)?;
            if let Some(i) = v.iter().position(|x| !(0.0..=1.0).contains(x)) {
                bail!(
                    ImapErrBadMaterial,
                    "{name}[{i}] = {} is outside [0, 1]",
                    v[i]
                );
            }
            Ok(v)
        };
        let diffuse_reflect = per_band("diffuse_reflectance", &desc.diffuse_reflect)?;
        let specular_reflect = per_band("specular_reflectance", &desc.specular_reflect)?;
        let diffuse_transmit = per_band("diffuse_transmittance", &desc.diffuse_transmit)?;
        for b in 0..bands.count() {
            let sum = diffuse_reflect[b] + specular_reflect[b] + diffuse_transmit[b];
            if sum > 1.0 + 1e-12 {
                bail!(
                    ImapErrBadMaterial,
                    "band {b}: reflectances and transmittance sum to {sum} > 1 (energy would be created)"
                );
            }
        }
        let dielectric = match &desc.ior {
            None => {
                if !desc.absorption_per_m.is_empty() {
                    bail!(ImapErrBadMaterial, "absorption is given but the material is not a dielectric (no index of refraction)");
                }
                None
            }
            Some(model) => {
                if diffuse_reflect
                    .iter()
                    .chain(&specular_reflect)
                    .chain(&diffuse_transmit)
                    .any(|&x| x != 0.0)
                {
                    bail!(ImapErrBadMaterial, "a dielectric reflects and refracts by Fresnel: its diffuse/specular coefficients must be 0");
                }
                let params: Vec<f64> = match model {
                    IorModel::Constant(n) => vec![*n],
                    IorModel::Cauchy { a, b, c } => vec![*a, *b, *c],
                    IorModel::Sellmeier { b, c } => b.iter().chain(c).copied().collect(),
                };
                check_finite("ior coefficients", &params)?;
                let ior: Vec<f64> = bands.wavelengths_nm.iter().map(|&l| model.ior(l)).collect();
                if let Some(i) = ior
                    .iter()
                    .position(|n| !(n.is_finite() && *n >= 1.0 && *n < 100.0))
                {
                    bail!(
                        ImapErrBadMaterial,
                        "index of refraction at {} nm is {} (must be finite, >= 1 and < 100)",
                        bands.wavelengths_nm[i],
                        ior[i]
                    );
                }
                let dispersive = ior.iter().any(|&n| n != ior[0]);
                let absorption_per_m = if desc.absorption_per_m.is_empty() {
                    None
                } else {
                    let a = bands.expand("absorption", &desc.absorption_per_m)?;
                    if let Some(i) = a.iter().position(|&x| x < 0.0) {
                        bail!(ImapErrBadMaterial, "absorption[{i}] = {} is negative", a[i]);
                    }
                    a.iter().any(|&x| x > 0.0).then_some(a)
                };
                let scattering = Self::scattering(desc, bands, absorption_per_m.as_deref())?;
                Some(Dielectric {
                    ior,
                    dispersive,
                    absorption_per_m,
                    scattering,
                })
            }
        };
        let any = |v: &[f64]| v.iter().any(|&x| x > 0.0);
        let events = [
            any(&diffuse_reflect),
            any(&specular_reflect),
            any(&diffuse_transmit),
        ];
        Ok(Material {
            diffuse_reflect,
            specular_reflect,
            diffuse_transmit,
            dielectric,
            events,
            glossy: None,
            tangent: None,
            texture: desc.texture,
            tint_lobes: Self::tint_lobes(desc)?,
            uv_tangent: false,
            fluorescence: None,
        })
    }

    /// The coefficients a texture and vertex factors vary on the surface `desc` describes
    /// (`MaterialDesc::texture_lobes` resolved): refused with IMAP_ERR_BAD_MATERIAL when
    /// it names one the surface does not have, or a texture is given to a surface with
    /// none (a dielectric, a measured table, a window BSDF, the host's).
    fn tint_lobes(desc: &MaterialDesc) -> Result<u8> {
        let (what, has, default) = match &desc.surface {
            SurfaceModel::Ideal if desc.ior.is_some() => ("a smooth dielectric", 0, 0),
            SurfaceModel::Ideal => (
                "an ideal surface",
                LOBE_DIFFUSE_REFLECT | LOBE_SPECULAR_REFLECT | LOBE_DIFFUSE_TRANSMIT,
                LOBE_DIFFUSE_REFLECT,
            ),
            SurfaceModel::Conductor(_) => (
                "a rough conductor",
                LOBE_SPECULAR_REFLECT | LOBE_ROUGHNESS,
                LOBE_SPECULAR_REFLECT,
            ),
            SurfaceModel::Plastic => (
                "a plastic (coated diffuse) surface",
                LOBE_DIFFUSE_REFLECT | LOBE_ROUGHNESS,
                LOBE_DIFFUSE_REFLECT,
            ),
            SurfaceModel::RoughDielectric => ("a rough dielectric", LOBE_ROUGHNESS, LOBE_ROUGHNESS),
            SurfaceModel::Table(_) | SurfaceModel::Klems(_) | SurfaceModel::Host(_) => {
                ("a measured table, window BSDF or host BSDF", 0, 0)
            }
        };
        if has == 0 {
            if desc.texture.is_some() {
                bail!(
                    ImapErrBadMaterial,
                    "texture: this material is {what}, which has no coefficient a texture can vary"
                );
            }
            return Ok(0);
        }
        let lobes = if desc.texture_lobes == 0 {
            default
        } else {
            desc.texture_lobes
        };
        if lobes & !has != 0 {
            let names = [
                (LOBE_DIFFUSE_REFLECT, "diffuse reflectance"),
                (LOBE_SPECULAR_REFLECT, "specular reflectance"),
                (LOBE_DIFFUSE_TRANSMIT, "diffuse transmittance"),
                (LOBE_ROUGHNESS, "roughness"),
            ];
            let (_, name) = names
                .iter()
                .find(|(bit, _)| lobes & !has & bit != 0)
                .expect("a bit outside `has`");
            bail!(
                ImapErrBadMaterial,
                "texture_lobes = {lobes} names the {name}, which {what} does not have to vary"
            );
        }
        if lobes & LOBE_ROUGHNESS != 0
            && matches!(
                desc.surface,
                SurfaceModel::Conductor(_) | SurfaceModel::Plastic
            )
            && desc.roughness[1] != 0.0
            && desc.roughness[1] != desc.roughness[0]
        {
            bail!(
                ImapErrUnsupported,
                "texture_lobes names the roughness of anisotropic roughness {:?}: a texture varies the roughness of isotropic conductors and plastics (and of any rough dielectric)",
                desc.roughness
            );
        }
        Ok(lobes)
    }

    /// A microfacet surface's (or a measured table's) description.
    fn microfacet(desc: &MaterialDesc, bands: &Bands) -> Result<Self> {
        let nb = bands.count();
        let tangent = match desc.tangent {
            None => None,
            Some(t) => {
                check_finite("tangent", &t)?;
                let v = DVec3::from(t);
                if v.length() <= 0.0 {
                    bail!(ImapErrBadMaterial, "tangent = {t:?} has no direction");
                }
                Some(v.normalize())
            }
        };
        if let SurfaceModel::Table(_) | SurfaceModel::Klems(_) | SurfaceModel::Host(_) =
            &desc.surface
        {
            let given = [
                ("diffuse_reflectance", desc.diffuse_reflect.is_empty()),
                ("specular_reflectance", desc.specular_reflect.is_empty()),
                ("diffuse_transmittance", desc.diffuse_transmit.is_empty()),
                ("absorption", desc.absorption_per_m.is_empty()),
                ("ior_model", desc.ior.is_none()),
                ("roughness", desc.roughness == [0.0, 0.0]),
            ];
            if let Some((name, _)) = given.iter().find(|g| !g.1) {
                bail!(
                    ImapErrBadMaterial,
                    "{name} is given but a measured table or BSDF file takes none (its values are the surface)"
                );
            }
            let (glossy, tangent) = match &desc.surface {
                SurfaceModel::Table(t) => (
                    Glossy::Table(std::sync::Arc::new(BsdfTable::new(t, nb, "table")?)),
                    tangent,
                ),
                SurfaceModel::Klems(path) => (
                    Glossy::Klems(std::sync::Arc::new(KlemsBsdf::read(path)?)),
                    // Its up direction: +z unless given (a fixed one where it is along a
                    // triangle's normal: `Frame::new`).
                    Some(tangent.unwrap_or(DVec3::Z)),
                ),
                SurfaceModel::Host(h) => (
                    Glossy::Host(std::sync::Arc::new(super::host::HostSurface::new(
                        h.0.clone(),
                        nb,
                    )?)),
                    tangent,
                ),
                _ => unreachable!("matched above"),
            };
            return Ok(Material {
                diffuse_reflect: vec![0.0; nb],
                specular_reflect: vec![0.0; nb],
                diffuse_transmit: vec![0.0; nb],
                dielectric: None,
                events: [false; 3],
                glossy: Some(glossy),
                tangent,
                texture: None,
                tint_lobes: 1,
                uv_tangent: false,
                fluorescence: None,
            });
        }
        let [ax, ay] = desc.roughness;
        for (name, a) in [("roughness[0]", ax), ("roughness[1]", ay)] {
            if !a.is_finite() {
                bail!(ImapErrNonFinite, "{name} = {a} is not finite");
            }
        }
        if !(ax > 0.0 && ax <= 1.0 && (0.0..=1.0).contains(&ay)) {
            bail!(
                ImapErrBadMaterial,
                "roughness = [{ax}, {ay}]: GGX α must lie in (0, 1] (roughness[1] = 0 means the same as roughness[0]); for a perfect mirror or smooth glass use an ideal surface"
            );
        }
        let rough = Roughness {
            ax,
            ay: if ay == 0.0 { ax } else { ay },
        };
        let zero = |name: &str, v: &[f64]| -> Result<()> {
            if v.iter().any(|&x| x != 0.0) {
                bail!(
                    ImapErrBadMaterial,
                    "{name} is given but a {} takes none",
                    match desc.surface {
                        SurfaceModel::Conductor(_) => "rough conductor",
                        SurfaceModel::Plastic => "plastic (coated diffuse) surface",
                        _ => "rough dielectric",
                    }
                );
            }
            Ok(())
        };
        zero("specular_reflectance", &desc.specular_reflect)?;
        zero("diffuse_transmittance", &desc.diffuse_transmit)?;
        let mut dielectric = None;
        let glossy = match &desc.surface {
            SurfaceModel::Ideal
            | SurfaceModel::Table(_)
            | SurfaceModel::Klems(_)
            | SurfaceModel::Host(_) => {
                unreachable!("ideal surfaces and tables are read above")
            }
            SurfaceModel::Conductor(index) => {
                zero("diffuse_reflectance", &desc.diffuse_reflect)?;
                zero("absorption", &desc.absorption_per_m)?;
                if desc.ior.is_some() {
                    bail!(
                        ImapErrBadMaterial,
                        "a conductor's index is its n, k table: ior_model must be none"
                    );
                }
                let (eta, k) = conductor_index(index, bands)?;
                Glossy::conductor_with(rough, eta, k, !desc.single_scattering)
            }
            SurfaceModel::RoughDielectric => {
                zero("diffuse_reflectance", &desc.diffuse_reflect)?;
                let Some(_) = &desc.ior else {
                    bail!(
                        ImapErrBadMaterial,
                        "a rough dielectric needs an index of refraction (ior_model)"
                    );
                };
                let smooth = Self::ideal(
                    &MaterialDesc {
                        ior: desc.ior.clone(),
                        absorption_per_m: desc.absorption_per_m.clone(),
                        scattering_per_m: desc.scattering_per_m.clone(),
                        phase_g: desc.phase_g.clone(),
                        phase_angles_deg: desc.phase_angles_deg.clone(),
                        phase_values: desc.phase_values.clone(),
                        fluorescence: desc.fluorescence.clone(),
                        ..Default::default()
                    },
                    bands,
                )?;
                let d = smooth.dielectric.expect("an index makes a dielectric");
                let g = Glossy::Dielectric {
                    rough,
                    ior: d.ior.clone(),
                };
                dielectric = Some(d);
                g
            }
            SurfaceModel::Plastic => {
                zero("absorption", &desc.absorption_per_m)?;
                let n = match desc.ior {
                    Some(IorModel::Constant(n)) if n.is_finite() && (1.0..100.0).contains(&n) => n,
                    Some(IorModel::Constant(n)) => bail!(
                        ImapErrBadMaterial,
                        "the plastic's coat index {n} must be finite, >= 1 and < 100"
                    ),
                    _ => bail!(
                        ImapErrBadMaterial,
                        "a plastic (coated diffuse) surface needs its coat's constant index (ior_model constant, ior[0], e.g. 1.5)"
                    ),
                };
                let base = if desc.diffuse_reflect.is_empty() {
                    vec![0.0; nb]
                } else {
                    bands.expand("diffuse_reflectance", &desc.diffuse_reflect)?
                };
                if let Some(i) = base.iter().position(|x| !(0.0..=1.0).contains(x)) {
                    bail!(
                        ImapErrBadMaterial,
                        "diffuse_reflectance[{i}] = {} is outside [0, 1]",
                        base[i]
                    );
                }
                Glossy::plastic(
                    rough,
                    n,
                    base,
                    Self::tint_lobes(desc)? & LOBE_ROUGHNESS != 0,
                )
            }
        };
        Ok(Material {
            diffuse_reflect: vec![0.0; nb],
            specular_reflect: vec![0.0; nb],
            diffuse_transmit: vec![0.0; nb],
            dielectric,
            events: [false; 3],
            glossy: Some(glossy),
            tangent,
            texture: None,
            tint_lobes: 1,
            uv_tangent: false,
            fluorescence: None,
        })
    }
}

/// A conductor's n and k at every band's wavelength, read linearly from its table.
fn conductor_index(index: &ConductorIndex, bands: &Bands) -> Result<(Vec<f64>, Vec<f64>)> {
    let (rows, what): (&[[f64; 3]], String) = match index {
        ConductorIndex::Metal(m) => (m.table(), m.name().to_string()),
        ConductorIndex::Table(t) => (t.as_slice(), "the conductor's n, k table".to_string()),
    };
    if rows.len() < 2 {
        bail!(
            ImapErrBadMaterial,
            "{what} has {} rows: it needs at least 2 (wavelength nm, n, k)",
            rows.len()
        );
    }
    for (i, r) in rows.iter().enumerate() {
        if !r.iter().all(|x| x.is_finite()) {
            bail!(ImapErrNonFinite, "{what}: row {i} = {r:?} is not finite");
        }
        if !(r[0] > 0.0 && r[1] > 0.0 && r[2] >= 0.0) {
            bail!(
                ImapErrBadMaterial,
                "{what}: row {i} = {r:?} needs wavelength > 0, n > 0 and k >= 0"
            );
        }
        if i > 0 && r[0] <= rows[i - 1][0] {
            bail!(
                ImapErrBadMaterial,
                "{what}: row {i}'s wavelength {} nm does not increase",
                r[0]
            );
        }
    }
    let (lo, hi) = (rows[0][0], rows[rows.len() - 1][0]);
    let mut eta = Vec::with_capacity(bands.count());
    let mut k = Vec::with_capacity(bands.count());
    for (b, &nm) in bands.wavelengths_nm.iter().enumerate() {
        if !(lo..=hi).contains(&nm) {
            bail!(
                ImapErrBadMaterial,
                "{what} covers {lo}–{hi} nm but band {b} is at {nm} nm"
            );
        }
        let j = rows
            .partition_point(|r| r[0] <= nm)
            .clamp(1, rows.len() - 1);
        let (a, c) = (rows[j - 1], rows[j]);
        let f = (nm - a[0]) / (c[0] - a[0]);
        eta.push(a[1] + (c[1] - a[1]) * f);
        k.push(a[2] + (c[2] - a[2]) * f);
    }
    Ok((eta, k))
}

/// Real Fresnel amplitude coefficients (r_s, r_p) for a ray going from index `n1` into
/// `n2` with `cos_i` = cosine of the incidence angle (> 0); None beyond the critical angle.
fn real_amplitudes(cos_i: f64, n1: f64, n2: f64) -> Option<(f64, f64)> {
    let eta = n1 / n2;
    let sin_t2 = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin_t2 >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin_t2).sqrt();
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    Some((rs, rp))
}

/// Unpolarised Fresnel reflectance for a ray going from index `n1` into `n2` with
/// `cos_i` = cosine of the incidence angle (> 0). Returns 1 for total internal reflection.
pub fn fresnel_dielectric(cos_i: f64, n1: f64, n2: f64) -> f64 {
    real_amplitudes(cos_i, n1, n2).map_or(1.0, |(rs, rp)| 0.5 * (rs * rs + rp * rp))
}

/// Fresnel amplitude coefficients (r_s, r_p) as complex numbers (re, im), in the convention
/// of `fresnel_dielectric` (|r_s|² + |r_p|² over 2 is its value). Beyond the critical angle
/// both have modulus 1 and differ in phase.
pub fn fresnel_amplitudes(cos_i: f64, n1: f64, n2: f64) -> ([f64; 2], [f64; 2]) {
    if let Some((rs, rp)) = real_amplitudes(cos_i, n1, n2) {
        return ([rs, 0.0], [rp, 0.0]);
    }
    // cos θt = i·k: r = (a − i·b) / (a + i·b) = ((a² − b²) − 2i·a·b) / (a² + b²).
    let eta = n1 / n2;
    let k = (eta * eta * (1.0 - cos_i * cos_i) - 1.0).max(0.0).sqrt();
    let ratio = |a: f64, b: f64| {
        let d = a * a + b * b;
        [(a * a - b * b) / d, -2.0 * a * b / d]
    };
    (ratio(n1 * cos_i, n2 * k), ratio(n2 * cos_i, n1 * k))
}

/// |r|² of a complex amplitude.
#[inline]
fn power(r: [f64; 2]) -> f64 {
    r[0] * r[0] + r[1] * r[1]
}

/// The polarisation of a photon as a normalised Stokes vector (Q, U, V over I) in the
/// frame of `s`, a unit vector perpendicular to its direction (Q = 1: all its power
/// oscillates along `s`, Q = −1: perpendicular to it). Light leaves its source
/// unpolarised (None); smooth dielectric interfaces polarise it (Fresnel's s and p
/// coefficients as a Mueller matrix, `interface`); diffuse and coefficient (mirror)
/// surfaces depolarise it.
#[derive(Clone, Copy, Debug)]
pub struct Polarisation {
    pub s: glam::DVec3,
    pub q: f64,
    pub u: f64,
    pub v: f64,
}

impl Polarisation {
    /// A photon going along unit `dir` meets a smooth interface (unit normal `n_in` on its
    /// side, incidence cosine `cos_i`, from index `n1` into `n2`) in polarisation `state`:
    /// reflects when `u` (uniform in [0, 1)) is below its reflectance, and `state` becomes
    /// the reflected or transmitted light's. Returns whether it reflected.
    pub fn interface(
        state: &mut Option<Polarisation>,
        dir: glam::DVec3,
        n_in: glam::DVec3,
        cos_i: f64,
        n1: f64,
        n2: f64,
        u: f64,
    ) -> bool {
        let (rs, rp) = fresnel_amplitudes(cos_i, n1, n2);
        let s_hat = dir.cross(n_in);
        let len = s_hat.length();
        if len <= 1e-9 {
            // Normal incidence: s and p are the same, the state does not change.
            return u < 0.5 * (power(rs) + power(rp));
        }
        let s_hat = s_hat / len;
        let (r, quv) = Self::reflectance(state, s_hat, dir, rs, rp);
        let reflected = u < r;
        *state = Some(Self::after(s_hat, quv, r, reflected, rs, rp));
        reflected
    }

    /// The reflectance of `state` at an interface whose plane of incidence has unit normal
    /// `s_hat`, and the state's (Q, U, V) in that frame (rotated from `s` to `s_hat`).
    fn reflectance(
        state: &Option<Polarisation>,
        s_hat: glam::DVec3,
        dir: glam::DVec3,
        rs: [f64; 2],
        rp: [f64; 2],
    ) -> (f64, [f64; 3]) {
        let quv = match state {
            None => [0.0; 3],
            Some(p) => {
                let (c, sn) = (p.s.dot(s_hat), p.s.cross(s_hat).dot(dir));
                let (c2, s2) = (c * c - sn * sn, 2.0 * sn * c);
                [p.q * c2 + p.u * s2, -p.q * s2 + p.u * c2, p.v]
            }
        };
        let (r_s, r_p) = (power(rs), power(rp));
        (0.5 * (r_s + r_p) + 0.5 * (r_s - r_p) * quv[0], quv)
    }

    /// The state after the interface, `reflected` or transmitted, from `reflectance`'s
    /// `quv` and `p_reflect`, in the frame of `s_hat` (still perpendicular to the new
    /// direction: it lies in the plane of incidence).
    fn after(
        s_hat: glam::DVec3,
        quv: [f64; 3],
        p_reflect: f64,
        reflected: bool,
        rs: [f64; 2],
        rp: [f64; 2],
    ) -> Polarisation {
        let (r_s, r_p) = (power(rs), power(rp));
        let [q, u, v] = quv;
        let (a, b, c, d, p) = if reflected {
            // r_s·conj(r_p): its real part keeps U and V, its imaginary part turns one
            // into the other (total internal reflection's phase difference).
            let re = rs[0] * rp[0] + rs[1] * rp[1];
            let im = rs[1] * rp[0] - rs[0] * rp[1];
            (0.5 * (r_s + r_p), 0.5 * (r_s - r_p), re, im, p_reflect)
        } else {
            let (t_s, t_p) = (1.0 - r_s, 1.0 - r_p);
            (
                0.5 * (t_s + t_p),
                0.5 * (t_s - t_p),
                (t_s * t_p).max(0.0).sqrt(),
                0.0,
                1.0 - p_reflect,
            )
        };
        let k = if p > 0.0 { 1.0 / p } else { 0.0 };
        Polarisation {
            s: s_hat,
            q: ((b + a * q) * k).clamp(-1.0, 1.0),
            u: (c * u + d * v) * k,
            v: (-d * u + c * v) * k,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_amplitudes_agree_with_the_unpolarised_reflectance() {
        for (cos_i, n1, n2) in [
            (1.0, 1.0, 1.5),
            (0.7, 1.0, 1.52),
            (0.2, 1.0, 1.52),
            (0.9, 1.5, 1.0),
            (0.5, 1.5, 1.0),
        ] {
            let (rs, rp) = fresnel_amplitudes(cos_i, n1, n2);
            let r = 0.5 * (power(rs) + power(rp));
            assert!(
                (r - fresnel_dielectric(cos_i, n1, n2)).abs() < 1e-12,
                "{cos_i} {n1} {n2}"
            );
        }
        // Beyond the critical angle: both moduli 1, phases differ.
        let (rs, rp) = fresnel_amplitudes(0.3, 1.5, 1.0);
        assert!(
            (rs[0].hypot(rs[1]) - 1.0).abs() < 1e-12 && (rp[0].hypot(rp[1]) - 1.0).abs() < 1e-12
        );
        assert!((rs[1] - rp[1]).abs() > 0.1);
        // Light polarised along s at Brewster's angle (r_p = 0) reflects R_s; along p, nothing.
        let tb = 1.5f64.atan();
        let (rs, rp) = fresnel_amplitudes(tb.cos(), 1.0, 1.5);
        assert!(rp[0].abs() < 1e-12);
        let dir = glam::DVec3::new(tb.sin(), 0.0, -tb.cos());
        let s_hat = glam::DVec3::Y;
        for (q, want) in [(1.0, rs[0] * rs[0]), (-1.0, 0.0)] {
            let state = Some(Polarisation {
                s: s_hat,
                q,
                u: 0.0,
                v: 0.0,
            });
            let (p, _) = Polarisation::reflectance(&state, s_hat, dir, rs, rp);
            assert!((p - want).abs() < 1e-12, "{q}: {p} vs {want}");
        }
        // Unpolarised light reflected at Brewster's angle is polarised along s.
        let (p, quv) = Polarisation::reflectance(&None, s_hat, dir, rs, rp);
        let after = Polarisation::after(s_hat, quv, p, true, rs, rp);
        assert!((after.q - 1.0).abs() < 1e-12);
    }

    #[test]
    fn fresnel_at_normal_incidence_and_brewster() {
        let r = fresnel_dielectric(1.0, 1.0, 1.5);
        assert!((r - 0.04).abs() < 1e-12);
        // Brewster: tan θB = n2/n1, rp = 0, R = rs²/2.
        let tb = 1.5f64.atan();
        let r = fresnel_dielectric(tb.cos(), 1.0, 1.5);
        let (ci, ct) = (tb.cos(), (std::f64::consts::FRAC_PI_2 - tb).cos());
        let rs = (ci - 1.5 * ct) / (ci + 1.5 * ct);
        assert!((r - 0.5 * rs * rs).abs() < 1e-12);
        // Total internal reflection beyond the critical angle from glass to air.
        assert_eq!(fresnel_dielectric(0.5, 1.5, 1.0), 1.0);
    }

    #[test]
    fn sellmeier_nbk7_matches_schott_catalogue() {
        // Schott N-BK7: nd = 1.5168 at 587.6 nm, nF = 1.5224 at 486.1 nm, nC = 1.5143 at 656.3 nm.
        let bk7 = IorModel::Sellmeier {
            b: [1.039_612_12, 0.231_792_344, 1.010_469_45],
            c: [0.006_000_698_67, 0.020_017_914_4, 103.560_653],
        };
        assert!((bk7.ior(587.56) - 1.5168).abs() < 1e-4);
        assert!((bk7.ior(486.13) - 1.5224).abs() < 1e-4);
        assert!((bk7.ior(656.27) - 1.5143).abs() < 1e-4);
    }

    #[test]
    fn material_validation() {
        use crate::error::ImapStatus::*;
        let bands = Bands::rgb();
        let bad = MaterialDesc {
            diffuse_reflect: vec![0.7],
            specular_reflect: vec![0.5],
            ..Default::default()
        };
        assert_eq!(
            Material::new(&bad, &bands).unwrap_err().status,
            ImapErrBadMaterial
        );
        let bad = MaterialDesc {
            diffuse_reflect: vec![f64::NAN],
            ..Default::default()
        };
        assert_eq!(
            Material::new(&bad, &bands).unwrap_err().status,
            ImapErrNonFinite
        );
        let glass = MaterialDesc {
            ior: Some(IorModel::Cauchy {
                a: 1.5046,
                b: 0.00420,
                c: 0.0,
            }),
            ..Default::default()
        };
        let m = Material::new(&glass, &bands).unwrap();
        let d = m.dielectric.unwrap();
        assert!(d.dispersive && d.ior[2] > d.ior[0]);
    }
}

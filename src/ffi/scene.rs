//! The scene: materials, meshes and lights.

use super::{
    boundary, check_out, read_versioned, slice, with_context, write_defaults, write_out,
    ImapContext, Versioned,
};
use crate::context::Context;
use crate::error::{bail, ImapStatus, Result};
use crate::scene::host::{HostBsdf, HostBsdfRef};
use crate::scene::{
    ConductorIndex, IorModel, MaterialDesc, MeshDesc, Metal, SurfaceModel, TableDesc,
};
use std::ffi::c_void;

/// `ImapMaterial::ior_model`: not a dielectric.
pub const IMAP_IOR_NONE: u32 = 0;
/// `n = ior[0]`.
pub const IMAP_IOR_CONSTANT: u32 = 1;
/// `n = ior[0] + ior[1]/λ² + ior[2]/λ⁴`, λ in µm.
pub const IMAP_IOR_CAUCHY: u32 = 2;
/// `n² = 1 + Σ ior[i]·λ²/(λ² − ior[i+3])`, i = 0..2, λ in µm (Schott's B1..B3, C1..C3).
pub const IMAP_IOR_SELLMEIER: u32 = 3;

/// `ImapMaterial::surface`: Lambertian reflection and transmission and a mirror by their
/// coefficients, or a smooth dielectric when `ior_model` is not NONE (the default).
pub const IMAP_SURFACE_IDEAL: u32 = 0;
/// `ImapMaterial::surface`: a rough conductor (GGX, Smith, visible-normal sampling) of
/// complex index n + ik (`metal`, or `conductor_nk` with `IMAP_METAL_CUSTOM`), its
/// multiple-scattering energy given back (Kulla–Conty): a white conductor reflects
/// everything at every roughness. The three coefficients and `ior_model` must be 0/NONE.
pub const IMAP_SURFACE_CONDUCTOR: u32 = 1;
/// `ImapMaterial::surface`: a rough dielectric interface (frosted glass; GGX): `ior_model`,
/// `ior` and `absorption_per_m` as a smooth dielectric's, the three coefficients 0. Light
/// reflects or refracts at each microfacet by unpolarised Fresnel (the photon's
/// polarisation is dropped there); the energy that multiple scattering between microfacets
/// would return is not (at most 1 % up to α = 0.3, 7 % at α = 1 for n = 1.5, normal
/// incidence: docs/materials.md).
pub const IMAP_SURFACE_ROUGH_DIELECTRIC: u32 = 2;
/// `ImapMaterial::surface`: a Lambertian base (`diffuse_reflectance`) under a rough
/// dielectric coat (GGX) of constant index (`ior_model` CONSTANT, `ior[0]`, e.g. 1.5):
/// "plastic", paint, a semi-gloss floor. Light the coat does not reflect reaches the base and
/// bounces between base and coat; a white base reflects everything at every roughness.
pub const IMAP_SURFACE_PLASTIC: u32 = 3;

/// `ImapMaterial::surface`: a measured BRDF (and optionally BTDF) table, per band, over
/// incident and outgoing directions (`table_*` fields). Grid: polar angles θ_j = 90° ·
/// j / (count − 1) from the normal (both ends included), azimuths φ_k = 360° · k / count
/// from the tangent (periodic). Values f in 1/sr at the grid's points, laid out as
/// `[band][θi][φi][θo][φo]` (row-major: φo varies fastest); one band's values stand for
/// every band. `table_phi_in_count` = 1 makes an isotropic (3-D) table whose φo is the
/// azimuth relative to the incident one; more makes it anisotropic (4-D), both azimuths
/// from `tangent`. A BTDF's θo is measured from the other side's normal. Values are read
/// linearly in θi and φi and bilinearly in (θo, φo); photons, gathering paths and eye paths
/// draw directions by the table (each incident row's outgoing cells ∝ value × ∫cos dω), so a
/// narrow lobe costs no more than a broad one. The same table serves both sides of the
/// surface. Checked on input: a NaN (IMAP_ERR_NON_FINITE), a negative value or a
/// directional albedo above 1.01 at any incident grid direction and band
/// (IMAP_ERR_BAD_MATERIAL, naming the direction) are refused; the worst reciprocity
/// difference is kept for `imap_get_table_check`. The three coefficients, `ior_model`,
/// `absorption_per_m` and `roughness` must be 0/NONE. (Since 0.2.3.)
pub const IMAP_SURFACE_TABLE: u32 = 4;

/// `ImapMaterial::surface`: a window BSDF file (`bsdf_xml_path`): LBNL WINDOW / Radiance
/// BSDF XML in a Klems basis (full 145, half, quarter, or one the file defines), front and
/// back, reflection and transmission; a blind, a fabric or a glazing system as one flat
/// pane. The mesh's normals point to the file's front side (WINDOW's front: a window's
/// exterior; Radiance's BSDF primitive points the other way). `tangent` is the file's up
/// direction (0, 0, 0: +z; where up lies along a triangle's normal, +y projected onto it):
/// a direction's patch is that of its direction of travel in the frame whose y is up and
/// whose x is normal × up, as Radiance reads these files, so light travelling straight
/// through a clear pane keeps its patch. Values are constant over each pair of patches and
/// directions are drawn inside a patch uniformly in projected solid angle. Only `Visible`
/// data are read, the same value in every band (Solar, NIR and Radiance's CIE-X/CIE-Z
/// blocks are skipped); without "Transmission Back" the back transmits the front's by
/// reciprocity (rows that would then send on more than arrives scaled down), without a
/// reflection matrix that side reflects nothing. Checked against Radiance 6.0a's reading
/// of an asymmetric file (docs/materials.md). Refused: a file
/// that cannot be read (IMAP_ERR_IO) or is over 64 MiB (IMAP_ERR_INVALID_ARGUMENT), does
/// not parse or lacks Visible data
/// (IMAP_ERR_PARSE, with file and line), a tensor-tree file or an unknown basis
/// (IMAP_ERR_UNSUPPORTED), a negative value or a patch sending on more than 1.01 of what
/// arrives (IMAP_ERR_BAD_MATERIAL, naming side and direction); `imap_get_table_check` gives
/// the worst reciprocity difference and the largest albedo. The three coefficients,
/// `ior_model`, `absorption_per_m` and `roughness` must be 0/NONE. (Since 0.2.3.)
pub const IMAP_SURFACE_BSDF_XML: u32 = 5;

/// `ImapMaterial::surface`: the host's own BSDF (`host_bsdf`: an `ImapHostBsdf` of
/// callbacks that evaluate, sample and give the density), used by every estimator and
/// renderer as a measured table is. Checked when added: at 12 incident directions on each
/// side, 512 of its own draws each, every value must be finite and ≥ 0, each draw's density
/// what `pdf` gives (to 1e-3), and the directional albedo (mean f cos / pdf) at most 1.05
/// (IMAP_ERR_BAD_MATERIAL otherwise, naming the direction); `imap_get_table_check` gives
/// the largest albedo and the worst reciprocity difference among those draws. During a run
/// or render a callback that fails or gives an invalid value ends that photon or path there
/// and stops the run at its next progress check; the run or render then returns
/// IMAP_ERR_HOST_BSDF naming the material, with the count and the first failure (the map
/// keeps what was accumulated). The three coefficients, `ior_model`, `absorption_per_m`
/// and `roughness` must be 0/NONE. (Since 0.2.3.)
pub const IMAP_SURFACE_HOST: u32 = 6;

/// `ImapHostBsdf::flags`: light can leave on the other side (`sample` may return
/// directions with z < 0). (Since 0.2.3.)
pub const IMAP_HOST_BSDF_TRANSMITS: u32 = 1;

/// `ImapHostBsdf::eval`: f(wo → wi) per band into `f[0 .. bands)`, in 1/sr (the light
/// arriving from `wo` that leaves along `wi`, per unit projected solid angle). Directions
/// are unit vectors in the local frame at the hit: z the normal on the side light arrives
/// from (`wo[2] > 0`), x the material's `tangent` projected onto the surface (a fixed
/// direction without one), y = z × x; `wo` points back to where the light came from, `wi`
/// where it goes on (`wi[2] < 0`: through to the other side); `front` is 1 when light arrives
/// on the side the mesh's normals point to. Returns 0, or anything else for a failure.
/// Called from many threads at once: it must be thread-safe and must not call libimap.
pub type ImapBsdfEvalFn = Option<
    unsafe extern "C" fn(
        user: *mut c_void,
        wo: *const f64,
        wi: *const f64,
        front: i32,
        f: *mut f64,
        bands: u32,
    ) -> i32,
>;

/// `ImapHostBsdf::sample`: draws a direction `wi` (written to `wi[0..3)`, a unit vector)
/// for light from `wo` from the three uniform numbers `u` the library draws (so the map
/// stays the same for a seed) and writes its density per solid angle (1/sr, > 0) to
/// `*pdf`. Returns 0, 1 when nothing goes on (the light is absorbed), anything else for a
/// failure. Frame and threads as for `ImapBsdfEvalFn`.
pub type ImapBsdfSampleFn = Option<
    unsafe extern "C" fn(
        user: *mut c_void,
        wo: *const f64,
        u: *const f64,
        front: i32,
        wi: *mut f64,
        pdf: *mut f64,
    ) -> i32,
>;

/// `ImapHostBsdf::pdf`: the density per solid angle with which `sample` draws `wi` from
/// `wo`, to `*pdf`. Returns 0, or anything else for a failure. Frame and threads as for
/// `ImapBsdfEvalFn`.
pub type ImapBsdfPdfFn = Option<
    unsafe extern "C" fn(
        user: *mut c_void,
        wo: *const f64,
        wi: *const f64,
        front: i32,
        pdf: *mut f64,
    ) -> i32,
>;

/// The host's own BSDF (`IMAP_SURFACE_HOST`). Initialise with
/// `imap_host_bsdf_default(&b, sizeof b)`. The library keeps the callbacks and `user`
/// (not the struct) for the context's lifetime: they must stay valid until
/// `imap_destroy`, and are called from many threads at once. (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapHostBsdf {
    /// `sizeof(ImapHostBsdf)` as the program was compiled; set by `imap_host_bsdf_default`.
    pub struct_size: u32,
    /// `IMAP_HOST_BSDF_*` flags, or-ed (0: it only reflects).
    pub flags: u32,
    pub eval: ImapBsdfEvalFn,
    pub sample: ImapBsdfSampleFn,
    pub pdf: ImapBsdfPdfFn,
    /// Passed to every callback.
    pub user: *mut c_void,
    /// The largest value f takes (1/sr), or 0 when unknown: the map's gathering paths take
    /// light samples at a reflector peaking at most 8/sr; sharper or unknown lobes are the
    /// photons' alone, as a mirror's.
    pub peak: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers, function pointers and a raw pointer.
unsafe impl Versioned for ImapHostBsdf {
    const NAME: &'static str = "ImapHostBsdf";
    const INIT: &'static str = "imap_host_bsdf_default";
    fn defaults() -> Self {
        ImapHostBsdf {
            struct_size: std::mem::size_of::<Self>() as u32,
            flags: 0,
            eval: None,
            sample: None,
            pdf: None,
            user: std::ptr::null_mut(),
            peak: 0.0,
        }
    }
}

/// Fills the `size` bytes at `out` with an empty host BSDF (no callbacks, flags 0, peak 0)
/// and sets `struct_size = size`. Pass `sizeof *out`. Returns IMAP_ERR_NULL_POINTER,
/// IMAP_ERR_INVALID_ARGUMENT (size too small). Thread-safe. (Since 0.2.3.)
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_host_bsdf_default(out: *mut ImapHostBsdf, size: usize) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// `ImapMaterial::texture`: no texture. (Since 0.2.3.)
pub const IMAP_NO_TEXTURE: u32 = u32::MAX;
/// `ImapMaterial::texture_lobes`: the diffuse reflectance (an IMAP_SURFACE_PLASTIC's base
/// albedo). (Since 0.2.3.)
pub const IMAP_LOBE_DIFFUSE_REFLECTION: u32 = 1;
/// `ImapMaterial::texture_lobes`: the specular (mirror) reflectance (an
/// IMAP_SURFACE_CONDUCTOR's reflectance: its Fresnel factor times the texture's value).
/// (Since 0.2.3.)
pub const IMAP_LOBE_SPECULAR_REFLECTION: u32 = 2;
/// `ImapMaterial::texture_lobes`: the diffuse transmittance. (Since 0.2.3.)
pub const IMAP_LOBE_DIFFUSE_TRANSMISSION: u32 = 4;
/// `ImapMaterial::texture_lobes`: a microfacet surface's roughness: α times the mean of
/// the bands' factors, at least 0.001 (conductors and plastics of isotropic roughness,
/// rough dielectrics). (Since 0.2.3.)
pub const IMAP_LOBE_ROUGHNESS: u32 = 8;
/// `ImapTexture::flags`: read the nearest texel (default: bilinear between texel
/// centres). (Since 0.2.3.)
pub const IMAP_TEXTURE_NEAREST: u32 = 1;
/// `ImapTexture::flags`: coordinates outside [0, 1] clamp to the edge (default: repeat).
/// (Since 0.2.3.)
pub const IMAP_TEXTURE_CLAMP: u32 = 2;

/// An image of factors in [0, 1] that a material names (`ImapMaterial::texture`): its
/// values, read at the mesh's texture coordinates, multiply the material's coefficients
/// (`texture_lobes`), so the tinted coefficients stay within [0, 1] and their sum within
/// the material's (set the material's coefficient to 1 to give the texture's values
/// themselves). Initialise with `imap_texture_default(&t, sizeof t)`. (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapTexture {
    /// `sizeof(ImapTexture)` as the program was compiled; set by `imap_texture_default`.
    pub struct_size: u32,
    /// `IMAP_TEXTURE_*` flags, or-ed.
    pub flags: u32,
    pub width: u32,
    pub height: u32,
    /// 1 (every band), 3 (red, green, blue: RGB runs band by band, spectral runs by each
    /// band's wavelength, blue below 490 nm, green below 580 nm, red above) or the band
    /// count.
    pub channels: u32,
    /// width · height · channels values in [0, 1], linear (not sRGB-encoded): rows from
    /// v = 0 to v = 1, texels from u = 0 to 1 in a row, channels innermost. Copied.
    pub values: *const f64,
    pub value_count: usize,
}

// SAFETY: repr(C), u32 struct_size first, numbers and a raw pointer.
unsafe impl Versioned for ImapTexture {
    const NAME: &'static str = "ImapTexture";
    const INIT: &'static str = "imap_texture_default";
    fn defaults() -> Self {
        ImapTexture {
            struct_size: std::mem::size_of::<Self>() as u32,
            flags: 0,
            width: 0,
            height: 0,
            channels: 1,
            values: std::ptr::null(),
            value_count: 0,
        }
    }
}

/// Fills the `size` bytes at `out` with an empty one-channel texture (no values, flags 0)
/// and sets `struct_size = size`. Pass `sizeof *out`. Returns IMAP_ERR_NULL_POINTER,
/// IMAP_ERR_INVALID_ARGUMENT (size too small). Thread-safe. (Since 0.2.3.)
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_texture_default(out: *mut ImapTexture, size: usize) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// Adds a texture; `*out_id` receives its id (0, 1, ... in order of addition), for
/// `ImapMaterial::texture`. The values are copied. Returns IMAP_ERR_NULL_POINTER,
/// IMAP_ERR_NON_FINITE, IMAP_ERR_INVALID_ARGUMENT (a size, channel count or value count
/// that does not fit, a value outside [0, 1], an unknown flag), IMAP_ERR_MEMORY_BUDGET,
/// IMAP_ERR_BUSY, IMAP_ERR_OUT_OF_ORDER. (Since 0.2.3.)
///
/// # Safety
/// `ctx` is a live handle; `texture` points to an `ImapTexture` whose `values` hold
/// `value_count` doubles; `out_id` points to writable storage.
#[no_mangle]
pub unsafe extern "C" fn imap_add_texture(
    ctx: *mut ImapContext,
    texture: *const ImapTexture,
    out_id: *mut u32,
) -> ImapStatus {
    add_with(ctx, out_id, |c| {
        let t = read_versioned("texture", texture)?;
        if t.flags & !(IMAP_TEXTURE_NEAREST | IMAP_TEXTURE_CLAMP) != 0 {
            bail!(
                ImapErrInvalidArgument,
                "texture.flags = {:#x} sets a bit that is not an IMAP_TEXTURE_* flag",
                t.flags
            );
        }
        let values = slice("texture.values", t.values, t.value_count)?;
        c.add_texture(&crate::scene::texture::TextureDesc {
            width: t.width as usize,
            height: t.height as usize,
            channels: t.channels as usize,
            values,
            nearest: t.flags & IMAP_TEXTURE_NEAREST != 0,
            clamp: t.flags & IMAP_TEXTURE_CLAMP != 0,
        })
    })
}

/// A C host BSDF: its callbacks behind `HostBsdf`.
struct CHostBsdf {
    eval: unsafe extern "C" fn(*mut c_void, *const f64, *const f64, i32, *mut f64, u32) -> i32,
    sample:
        unsafe extern "C" fn(*mut c_void, *const f64, *const f64, i32, *mut f64, *mut f64) -> i32,
    pdf: unsafe extern "C" fn(*mut c_void, *const f64, *const f64, i32, *mut f64) -> i32,
    user: *mut c_void,
    flags: u32,
    peak: f64,
}

// SAFETY: the header requires the callbacks and `user` to be thread-safe and valid for the
// context's lifetime (`ImapHostBsdf`).
unsafe impl Send for CHostBsdf {}
// SAFETY: as above.
unsafe impl Sync for CHostBsdf {}

impl HostBsdf for CHostBsdf {
    fn eval(
        &self,
        a: [f64; 3],
        b: [f64; 3],
        front: bool,
        f: &mut [f64],
    ) -> std::result::Result<(), String> {
        // SAFETY: valid pointers to 3 doubles each and `f.len()` writable doubles; the
        // callback's validity is the caller's promise (`ImapHostBsdf`).
        let rc = unsafe {
            (self.eval)(
                self.user,
                a.as_ptr(),
                b.as_ptr(),
                i32::from(front),
                f.as_mut_ptr(),
                f.len() as u32,
            )
        };
        if rc == 0 {
            Ok(())
        } else {
            Err(format!("eval returned {rc}"))
        }
    }

    fn sample(
        &self,
        a: [f64; 3],
        u: [f64; 3],
        front: bool,
    ) -> std::result::Result<Option<([f64; 3], f64)>, String> {
        let (mut wi, mut pdf) = ([f64::NAN; 3], f64::NAN);
        // SAFETY: as in `eval`: 3 readable doubles each, 3 and 1 writable.
        let rc = unsafe {
            (self.sample)(
                self.user,
                a.as_ptr(),
                u.as_ptr(),
                i32::from(front),
                wi.as_mut_ptr(),
                &mut pdf,
            )
        };
        match rc {
            0 => Ok(Some((wi, pdf))),
            1 => Ok(None),
            _ => Err(format!("sample returned {rc}")),
        }
    }

    fn pdf(&self, a: [f64; 3], b: [f64; 3], front: bool) -> std::result::Result<f64, String> {
        let mut pdf = f64::NAN;
        // SAFETY: as in `eval`.
        let rc = unsafe {
            (self.pdf)(
                self.user,
                a.as_ptr(),
                b.as_ptr(),
                i32::from(front),
                &mut pdf,
            )
        };
        if rc == 0 {
            Ok(pdf)
        } else {
            Err(format!("pdf returned {rc}"))
        }
    }

    fn transmits(&self) -> bool {
        self.flags & IMAP_HOST_BSDF_TRANSMITS != 0
    }

    fn peak(&self) -> f64 {
        self.peak
    }
}

/// The host BSDF `ptr` describes, checked for its callbacks.
fn host_bsdf(ptr: *const ImapHostBsdf) -> Result<HostBsdfRef> {
    let h = read_versioned("material.host_bsdf", ptr)?;
    let (Some(eval), Some(sample), Some(pdf)) = (h.eval, h.sample, h.pdf) else {
        bail!(
            ImapErrNullPointer,
            "material.host_bsdf: eval, sample and pdf must all be set"
        );
    };
    if h.flags & !IMAP_HOST_BSDF_TRANSMITS != 0 {
        bail!(
            ImapErrInvalidArgument,
            "material.host_bsdf.flags = {:#x} sets a bit that is not an IMAP_HOST_BSDF_* flag",
            h.flags
        );
    }
    if !(h.peak.is_finite() && h.peak >= 0.0) {
        bail!(
            ImapErrInvalidArgument,
            "material.host_bsdf.peak = {} must be finite and >= 0 (0: unknown)",
            h.peak
        );
    }
    Ok(HostBsdfRef(std::sync::Arc::new(CHostBsdf {
        eval,
        sample,
        pdf,
        user: h.user,
        flags: h.flags,
        peak: h.peak,
    })))
}

/// `ImapMaterial::flags`: a conductor without its multiple-scattering lobe (single
/// scattering only, as Mitsuba 3's `roughconductor` and most renderers compute it; it then
/// loses energy at high roughness, 3 % at α 0.15). For comparisons with such tools.
/// (Since 0.2.3.)
pub const IMAP_MATERIAL_SINGLE_SCATTERING: u32 = 1;
/// `ImapMaterial::flags`: a microfacet, measured or host surface's tangent (the direction of
/// `roughness[0]`, a table's φ = 0, a window BSDF's up) is each triangle's direction of
/// increasing texture coordinate u; the mesh then needs `uvs`, and `tangent` (when not
/// zero) serves where a triangle's coordinates are degenerate. An ideal surface has no
/// tangent: IMAP_ERR_BAD_MATERIAL. (Since 0.2.3.)
pub const IMAP_MATERIAL_TANGENT_FROM_UVS: u32 = 2;

/// `ImapMaterial::metal`: the conductor's index is `conductor_nk`.
pub const IMAP_METAL_CUSTOM: u32 = 0;
/// `ImapMaterial::metal`: measured n + ik (Palik's handbook via the luxpop.com database,
/// 299–886 nm; docs/materials.md).
pub const IMAP_METAL_ALUMINIUM: u32 = 1;
pub const IMAP_METAL_SILVER: u32 = 2;
pub const IMAP_METAL_GOLD: u32 = 3;
pub const IMAP_METAL_COPPER: u32 = 4;
/// Chromium: 300–886 nm.
pub const IMAP_METAL_CHROMIUM: u32 = 5;

/// `ImapMesh::flags`: both sides record (and emit) separately.
pub const IMAP_MESH_TWO_SIDED: u32 = 1;
/// `ImapMesh::flags`: the mesh's vertices accumulate irradiance.
pub const IMAP_MESH_RECORD: u32 = 2;
/// `ImapMesh::flags`: a sensor (calculation surface): it records the photons crossing it
/// from its recorded side(s) (front, or both with IMAP_MESH_TWO_SIDED) and changes nothing
/// else: photons pass as if it were not there, cameras do not see it. Needs
/// IMAP_MESH_RECORD; cannot emit; its material is not used. (Since 0.2.1.)
pub const IMAP_MESH_SENSOR: u32 = 4;
/// `ImapMesh::flags`: keep per-photon tallies of the mesh's regions (its sides, and its
/// parts by material), so `imap_get_region_stats` gives its flux and Eavg exact standard
/// errors; without it they get an upper bound (docs/results.md). Sensors always have them.
/// Costs work at every photon deposit on the mesh. (Since 0.2.1.)
pub const IMAP_MESH_TALLY: u32 = 8;
/// `ImapMesh::flags`: leave out the triangles that repeat a vertex (CAD exports hold many;
/// they have no area) instead of refusing the mesh with IMAP_ERR_DEGENERATE_TRIANGLE;
/// `imap_get_mesh_dropped_triangles` says how many. `triangle_materials` is still given
/// for every input triangle. A mesh with no triangle left is refused. (Since 0.2.1.)
pub const IMAP_MESH_SKIP_DEGENERATE: u32 = 16;

/// A material. Initialise with `imap_material_default(&m, sizeof m)` (no reflection, no
/// transmission: black). Per-band arrays hold 1 value (the same in every band) or one per
/// band; a count of 0 (pointer may be NULL) means 0 in every band. The library copies them.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapMaterial {
    /// `sizeof(ImapMaterial)` as the program was compiled; set by `imap_material_default`.
    pub struct_size: u32,
    /// `IMAP_IOR_*`. Anything but NONE makes a smooth dielectric (Fresnel reflection and
    /// Snell refraction; the three coefficients below must then be 0). Its mesh should be
    /// closed with normals pointing out; the outside is air (n = 1). Illumination maps
    /// carry polarisation through dielectric interfaces (since 0.2.2): light leaves its
    /// source unpolarised, each interface reflects and transmits its s and p parts by their
    /// own Fresnel coefficients (a Mueller matrix on the photon's Stokes vector, phase
    /// included beyond the critical angle), so a slab transmits what polarised Fresnel
    /// with incoherent multiple reflections gives at every angle (0.4 % more at 45°,
    /// 1.5 % at 60°, 3.9 % at 75° for n = 1.52 than an unpolarised model); Lambertian and
    /// specular-coefficient surfaces depolarise. The renderer's backward paths use the
    /// unpolarised reflectance (R_s + R_p)/2.
    pub ior_model: u32,
    /// Probability of Lambertian reflection, [0, 1].
    pub diffuse_reflectance: *const f64,
    pub diffuse_reflectance_count: usize,
    /// Probability of mirror reflection, [0, 1].
    pub specular_reflectance: *const f64,
    pub specular_reflectance_count: usize,
    /// Probability of Lambertian transmission to the other side, [0, 1].
    pub diffuse_transmittance: *const f64,
    pub diffuse_transmittance_count: usize,
    /// Coefficients of the index model (see `IMAP_IOR_*`).
    pub ior: [f64; 6],
    /// Beer–Lambert absorption coefficient inside a dielectric, 1/m, per band.
    pub absorption_per_m: *const f64,
    pub absorption_count: usize,
    /// `IMAP_SURFACE_*` (0: IDEAL). (Since 0.2.3.)
    pub surface: u32,
    /// `IMAP_METAL_*`, for IMAP_SURFACE_CONDUCTOR. (Since 0.2.3.)
    pub metal: u32,
    /// GGX α along the tangent and the bitangent, each in (0, 1] (α is the square of
    /// glTF's perceptual roughness; 0.01 nearly a mirror, 1 very rough); `roughness[1]` = 0
    /// means isotropic (= `roughness[0]`). Must be 0, 0 for IMAP_SURFACE_IDEAL. (Since 0.2.3.)
    pub roughness: [f64; 2],
    /// The direction `roughness[0]` runs along (world coordinates, projected onto each
    /// triangle); 0, 0, 0: any (enough for isotropic roughness). (Since 0.2.3.)
    pub tangent: [f64; 3],
    /// With IMAP_METAL_CUSTOM: `conductor_nk_count` rows of (wavelength nm, n, k),
    /// wavelengths increasing, covering every band's wavelength; read linearly.
    /// (Since 0.2.3.)
    pub conductor_nk: *const f64,
    pub conductor_nk_count: usize,
    /// IMAP_SURFACE_TABLE: the grid's polar angles of incidence (at least 2), azimuths of
    /// incidence (1: isotropic), outgoing polar angles (at least 2) and outgoing azimuths.
    /// (Since 0.2.3.)
    pub table_theta_in_count: u32,
    pub table_phi_in_count: u32,
    pub table_theta_out_count: u32,
    pub table_phi_out_count: u32,
    /// The BRDF's values (see IMAP_SURFACE_TABLE), 1/sr. (Since 0.2.3.)
    pub table_brdf: *const f64,
    pub table_brdf_count: usize,
    /// The BTDF's values, or NULL/0 for an opaque surface. (Since 0.2.3.)
    pub table_btdf: *const f64,
    pub table_btdf_count: usize,
    /// `IMAP_MATERIAL_*` flags, or-ed (0: none). (Since 0.2.3.)
    pub flags: u32,
    /// IMAP_SURFACE_BSDF_XML: the file's path, NUL-terminated (the bytes as the system
    /// takes them). The library reads it during `imap_add_material`. (Since 0.2.3.)
    pub bsdf_xml_path: *const std::ffi::c_char,
    /// IMAP_SURFACE_HOST: the host's BSDF (its callbacks and `user` are kept, the struct
    /// itself is copied). (Since 0.2.3.)
    pub host_bsdf: *const ImapHostBsdf,
    /// A texture (an id from `imap_add_texture`) whose values, read at the mesh's `uvs`,
    /// multiply the coefficients `texture_lobes` names; IMAP_NO_TEXTURE (the default):
    /// none. Ideal non-dielectric surfaces, conductors, plastics and rough dielectrics
    /// (not smooth dielectrics, tables, window or host BSDFs: IMAP_ERR_BAD_MATERIAL).
    /// (Since 0.2.3.)
    pub texture: u32,
    /// `IMAP_LOBE_*`, or-ed: which coefficients the texture and a mesh's
    /// `vertex_factors` multiply; 0, the default: the surface's colour (the diffuse
    /// reflectance; a conductor's reflectance; a rough dielectric's roughness). A lobe the
    /// surface does not have is IMAP_ERR_BAD_MATERIAL; the roughness of anisotropic
    /// conductors and plastics IMAP_ERR_UNSUPPORTED. (Since 0.2.3.)
    pub texture_lobes: u32,
    /// A dielectric's (smooth or rough) scattering coefficient σs inside, 1/m, per band,
    /// ≥ 0: a homogeneous scattering medium (an opal diffuser, a light guide's bulk, a
    /// volume of haze behind an index-1 boundary). Its absorption is `absorption_per_m`;
    /// free flights are drawn per band without bias. Photons scatter in it (so do the
    /// renderer's eye paths); light through a dielectric is the photons' in every
    /// estimator, so light sampling and gathering stay unbiased. Another material gets
    /// IMAP_ERR_BAD_MATERIAL. (Since 0.2.3.)
    pub scattering_per_m: *const f64,
    pub scattering_count: usize,
    /// The Henyey–Greenstein asymmetry g of that scattering per band, in (−1, 1); 0 values:
    /// isotropic. Needs `scattering_per_m`. (Since 0.2.3.)
    pub phase_g: *const f64,
    pub phase_g_count: usize,
    /// A tabulated phase function instead of `phase_g`, for all bands (a measured or Mie
    /// table): `phase_table_count` scattering angles in degrees, 0 first, 180 last,
    /// increasing, and the function's values at them (finite, ≥ 0, any scale: normalised
    /// over the sphere), linear in the angle between them; 2 to 100 000 points. Drawn
    /// exactly (no rejection). Needs `scattering_per_m`; with `phase_g` too, or bad
    /// points: IMAP_ERR_BAD_MATERIAL naming the field. (Since 0.2.3.)
    pub phase_angles_deg: *const f64,
    pub phase_values: *const f64,
    pub phase_table_count: usize,
    /// Fluorescence of a Lambertian reflector (spectral runs only; RGB:
    /// IMAP_ERR_UNSUPPORTED): `fluorescence_count` = bands × bands shares, row-major, row i
    /// the excitation band and column j the emission band: of the power arriving in band
    /// i, the share re-emitted diffusely (Lambertian, on the side it arrived) in band j.
    /// Only toward longer wavelengths; per band, the diffuse reflectance plus the shares
    /// re-emitted from it at most 1. From an excitation spectrum a_i (the absorbed share
    /// that fluoresces), a quantum yield Φ and an emission spectrum in photons e_j (sum 1):
    /// m_ij = a_i Φ e_j λ_i / λ_j. Not with specular reflectance, transmittance or a
    /// texture, nor on microfacet, measured or host surfaces (IMAP_ERR_BAD_MATERIAL /
    /// IMAP_ERR_UNSUPPORTED naming the field). On a dielectric (smooth or rough) with
    /// `absorption_per_m` it is its medium's: of the power the medium
    /// absorbs in band i, the share re-emitted isotropically in band j, each row's sum at
    /// most 1 (a_i is then the share of the absorption that excites the fluorophore); a
    /// medium without absorption is refused, and so is a fluorescent scene medium
    /// (`imap_set_scene_medium`: IMAP_ERR_UNSUPPORTED). What a medium re-emits counts in
    /// what it absorbed (`imap_get_medium_absorbed`). Every estimator and renderer carries
    /// it; the run's balance gains IMAP_BALANCE_FLUORESCED. (Since 0.2.3.)
    pub fluorescence: *const f64,
    pub fluorescence_count: usize,
}

// SAFETY: repr(C), u32 struct_size first, numbers and raw pointers only.
unsafe impl Versioned for ImapMaterial {
    const NAME: &'static str = "ImapMaterial";
    const INIT: &'static str = "imap_material_default";
    /// The 0.2.2 layout, before the surface models.
    const BASE_SIZE: usize = std::mem::offset_of!(ImapMaterial, surface);
    fn defaults() -> Self {
        ImapMaterial {
            struct_size: std::mem::size_of::<Self>() as u32,
            ior_model: IMAP_IOR_NONE,
            diffuse_reflectance: std::ptr::null(),
            diffuse_reflectance_count: 0,
            specular_reflectance: std::ptr::null(),
            specular_reflectance_count: 0,
            diffuse_transmittance: std::ptr::null(),
            diffuse_transmittance_count: 0,
            ior: [0.0; 6],
            absorption_per_m: std::ptr::null(),
            absorption_count: 0,
            surface: IMAP_SURFACE_IDEAL,
            metal: IMAP_METAL_CUSTOM,
            roughness: [0.0; 2],
            tangent: [0.0; 3],
            conductor_nk: std::ptr::null(),
            conductor_nk_count: 0,
            table_theta_in_count: 0,
            table_phi_in_count: 0,
            table_theta_out_count: 0,
            table_phi_out_count: 0,
            table_brdf: std::ptr::null(),
            table_brdf_count: 0,
            table_btdf: std::ptr::null(),
            table_btdf_count: 0,
            flags: 0,
            bsdf_xml_path: std::ptr::null(),
            host_bsdf: std::ptr::null(),
            texture: IMAP_NO_TEXTURE,
            texture_lobes: 0,
            scattering_per_m: std::ptr::null(),
            scattering_count: 0,
            phase_g: std::ptr::null(),
            phase_g_count: 0,
            phase_angles_deg: std::ptr::null(),
            phase_values: std::ptr::null(),
            phase_table_count: 0,
            fluorescence: std::ptr::null(),
            fluorescence_count: 0,
        }
    }
}

/// A triangle mesh. Initialise with `imap_mesh_default(&m, sizeof m)`. The library
/// copies every array.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapMesh {
    /// `sizeof(ImapMesh)` as the program was compiled; set by `imap_mesh_default`.
    pub struct_size: u32,
    /// `IMAP_MESH_*` flags, or-ed.
    pub flags: u32,
    /// x, y, z of each vertex (3·vertex_count doubles), scene units, |x| ≤ 1e30.
    pub positions: *const f64,
    pub vertex_count: usize,
    /// Three vertex indices per triangle (3·triangle_count).
    pub indices: *const u32,
    pub triangle_count: usize,
    /// Optional per-triangle material ids (the mesh's parts), triangle_count of them;
    /// NULL = all triangles use `material`.
    pub triangle_materials: *const u32,
    /// Radiant exitance of a self-emitting mesh (a lamp), W/m² per band, Lambertian, from
    /// the front side (both sides if two-sided); NULL/0 = not emitting.
    pub exitance: *const f64,
    pub exitance_count: usize,
    /// Material id (from `imap_add_material`) of every triangle.
    pub material: u32,
    /// Texture coordinates: u and v of each vertex (2·vertex_count doubles), or NULL.
    /// Needed by triangles of a textured material. (Since 0.2.3.)
    pub uvs: *const f64,
    /// Per-vertex factors in [0, 1] of the coefficients its materials' `texture_lobes`
    /// name (vertex_count · vertex_factor_channels doubles), mixed barycentrically over
    /// each triangle, or NULL. (Since 0.2.3.)
    pub vertex_factors: *const f64,
    /// 1 (every band), 3 (red, green, blue; spectral runs by each band's wavelength) or
    /// the band count. (Since 0.2.3.)
    pub vertex_factor_channels: u32,
}

// SAFETY: repr(C), u32 struct_size first, numbers and raw pointers only.
unsafe impl Versioned for ImapMesh {
    const NAME: &'static str = "ImapMesh";
    const INIT: &'static str = "imap_mesh_default";
    /// The 0.2.2 layout, before texture coordinates.
    const BASE_SIZE: usize = std::mem::offset_of!(ImapMesh, uvs);
    fn defaults() -> Self {
        ImapMesh {
            struct_size: std::mem::size_of::<Self>() as u32,
            flags: 0,
            positions: std::ptr::null(),
            vertex_count: 0,
            indices: std::ptr::null(),
            triangle_count: 0,
            triangle_materials: std::ptr::null(),
            exitance: std::ptr::null(),
            exitance_count: 0,
            material: 0,
            uvs: std::ptr::null(),
            vertex_factors: std::ptr::null(),
            vertex_factor_channels: 1,
        }
    }
}

/// Fills the `size` bytes at `out` with a black, non-dielectric material and sets
/// `struct_size = size`. Pass `sizeof *out`. Returns IMAP_ERR_NULL_POINTER,
/// IMAP_ERR_INVALID_ARGUMENT (size too small). Thread-safe.
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_material_default(out: *mut ImapMaterial, size: usize) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// Fills the `size` bytes at `out` with an empty mesh (no arrays, material 0, flags 0) and
/// sets `struct_size = size`. Pass `sizeof *out`. Returns IMAP_ERR_NULL_POINTER,
/// IMAP_ERR_INVALID_ARGUMENT (size too small). Thread-safe.
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_mesh_default(out: *mut ImapMesh, size: usize) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// The frame of every `imap_add_*`: `out_id` is checked before anything is added, `add`
/// runs on the context, and its id is written only on success.
pub(super) fn add_with(
    ctx: *mut ImapContext,
    out_id: *mut u32,
    add: impl FnOnce(&mut Context) -> Result<u32>,
) -> ImapStatus {
    with_context(ctx, |c| {
        check_out("out_id", out_id)?;
        let id = add(c)?;
        write_out("out_id", out_id, id)
    })
}

/// Three doubles from C.
pub(super) fn vec3(name: &str, ptr: *const f64) -> Result<[f64; 3]> {
    let v = slice(name, ptr, 3)?;
    Ok([v[0], v[1], v[2]])
}

fn per_band(name: &str, ptr: *const f64, count: usize) -> Result<Vec<f64>> {
    let s = slice(name, ptr, count)?;
    let mut v = Vec::new();
    v.try_reserve_exact(s.len()).map_err(|_| {
        crate::error::Error::new(
            ImapStatus::ImapErrOutOfMemory,
            format!("{name}: could not copy {count} values"),
        )
    })?;
    v.extend_from_slice(s);
    Ok(v)
}

/// Adds a material; `*out_id` receives its id (0, 1, ... in order of addition). Materials
/// may be added at any time. The arrays are copied.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_NON_FINITE, IMAP_ERR_INVALID_ARGUMENT (an array
/// count other than 0, 1 or the band count; unknown ior_model; struct_size),
/// IMAP_ERR_BAD_MATERIAL (coefficients outside [0, 1], sum over 1, index below 1),
/// IMAP_ERR_BUSY.
///
/// # Safety
/// `ctx` is a live handle; `material` points to an `ImapMaterial` whose arrays hold their
/// counts of values; `out_id` points to writable storage.
#[no_mangle]
pub unsafe extern "C" fn imap_add_material(
    ctx: *mut ImapContext,
    material: *const ImapMaterial,
    out_id: *mut u32,
) -> ImapStatus {
    add_with(ctx, out_id, |c| {
        let m = read_versioned("material", material)?;
        let i = m.ior;
        let ior = match m.ior_model {
            IMAP_IOR_NONE => None,
            IMAP_IOR_CONSTANT => Some(IorModel::Constant(i[0])),
            IMAP_IOR_CAUCHY => Some(IorModel::Cauchy {
                a: i[0],
                b: i[1],
                c: i[2],
            }),
            IMAP_IOR_SELLMEIER => Some(IorModel::Sellmeier {
                b: [i[0], i[1], i[2]],
                c: [i[3], i[4], i[5]],
            }),
            other => bail!(
                ImapErrInvalidArgument,
                "material.ior_model = {other} is not one of IMAP_IOR_NONE, _CONSTANT, _CAUCHY, _SELLMEIER"
            ),
        };
        let desc = MaterialDesc {
            diffuse_reflect: per_band(
                "material.diffuse_reflectance",
                m.diffuse_reflectance,
                m.diffuse_reflectance_count,
            )?,
            specular_reflect: per_band(
                "material.specular_reflectance",
                m.specular_reflectance,
                m.specular_reflectance_count,
            )?,
            diffuse_transmit: per_band(
                "material.diffuse_transmittance",
                m.diffuse_transmittance,
                m.diffuse_transmittance_count,
            )?,
            ior,
            absorption_per_m: per_band(
                "material.absorption_per_m",
                m.absorption_per_m,
                m.absorption_count,
            )?,
            scattering_per_m: per_band(
                "material.scattering_per_m",
                m.scattering_per_m,
                m.scattering_count,
            )?,
            phase_g: per_band("material.phase_g", m.phase_g, m.phase_g_count)?,
            phase_angles_deg: per_band(
                "material.phase_angles_deg",
                m.phase_angles_deg,
                m.phase_table_count,
            )?,
            phase_values: per_band(
                "material.phase_values",
                m.phase_values,
                m.phase_table_count,
            )?,
            fluorescence: per_band(
                "material.fluorescence",
                m.fluorescence,
                m.fluorescence_count,
            )?,
            surface: match m.surface {
                IMAP_SURFACE_IDEAL => SurfaceModel::Ideal,
                IMAP_SURFACE_CONDUCTOR => SurfaceModel::Conductor(match m.metal {
                    IMAP_METAL_CUSTOM => {
                        let rows = m.conductor_nk_count;
                        let v = per_band(
                            "material.conductor_nk",
                            m.conductor_nk,
                            rows.checked_mul(3).ok_or_else(|| {
                                crate::error::Error::new(
                                    ImapStatus::ImapErrInvalidArgument,
                                    format!("material.conductor_nk_count = {rows} is too large"),
                                )
                            })?,
                        )?;
                        ConductorIndex::Table(v.chunks_exact(3).map(|r| [r[0], r[1], r[2]]).collect())
                    }
                    IMAP_METAL_ALUMINIUM => ConductorIndex::Metal(Metal::Aluminium),
                    IMAP_METAL_SILVER => ConductorIndex::Metal(Metal::Silver),
                    IMAP_METAL_GOLD => ConductorIndex::Metal(Metal::Gold),
                    IMAP_METAL_COPPER => ConductorIndex::Metal(Metal::Copper),
                    IMAP_METAL_CHROMIUM => ConductorIndex::Metal(Metal::Chromium),
                    other => bail!(
                        ImapErrInvalidArgument,
                        "material.metal = {other} is not one of IMAP_METAL_CUSTOM, _ALUMINIUM, _SILVER, _GOLD, _COPPER, _CHROMIUM"
                    ),
                }),
                IMAP_SURFACE_ROUGH_DIELECTRIC => SurfaceModel::RoughDielectric,
                IMAP_SURFACE_PLASTIC => SurfaceModel::Plastic,
                IMAP_SURFACE_TABLE => SurfaceModel::Table(TableDesc {
                    theta_in: m.table_theta_in_count as usize,
                    phi_in: m.table_phi_in_count as usize,
                    theta_out: m.table_theta_out_count as usize,
                    phi_out: m.table_phi_out_count as usize,
                    brdf: per_band("material.table_brdf", m.table_brdf, m.table_brdf_count)?,
                    btdf: per_band("material.table_btdf", m.table_btdf, m.table_btdf_count)?,
                }),
                IMAP_SURFACE_HOST => SurfaceModel::Host(host_bsdf(m.host_bsdf)?),
                IMAP_SURFACE_BSDF_XML => SurfaceModel::Klems(
                    super::state::path_arg("material.bsdf_xml_path", m.bsdf_xml_path)?.to_path_buf(),
                ),
                other => bail!(
                    ImapErrInvalidArgument,
                    "material.surface = {other} is not one of IMAP_SURFACE_IDEAL, _CONDUCTOR, _ROUGH_DIELECTRIC, _PLASTIC, _TABLE, _BSDF_XML, _HOST"
                ),
            },
            roughness: m.roughness,
            tangent: (m.tangent != [0.0; 3]).then_some(m.tangent),
            single_scattering: m.flags & IMAP_MATERIAL_SINGLE_SCATTERING != 0,
            tangent_from_uvs: m.flags & IMAP_MATERIAL_TANGENT_FROM_UVS != 0,
            texture: (m.texture != IMAP_NO_TEXTURE).then_some(m.texture),
            texture_lobes: if m.texture_lobes & !15 != 0 {
                bail!(
                    ImapErrInvalidArgument,
                    "material.texture_lobes = {:#x} sets a bit that is not an IMAP_LOBE_* flag",
                    m.texture_lobes
                );
            } else {
                m.texture_lobes as u8
            },
        };
        if m.flags & !(IMAP_MATERIAL_SINGLE_SCATTERING | IMAP_MATERIAL_TANGENT_FROM_UVS) != 0 {
            bail!(
                ImapErrInvalidArgument,
                "material.flags = {:#x} sets a bit that is not an IMAP_MATERIAL_* flag",
                m.flags
            );
        }
        if m.surface != IMAP_SURFACE_HOST && !m.host_bsdf.is_null() {
            bail!(
                ImapErrBadMaterial,
                "material.host_bsdf is given but material.surface is not IMAP_SURFACE_HOST"
            );
        }
        if m.surface != IMAP_SURFACE_BSDF_XML && !m.bsdf_xml_path.is_null() {
            bail!(
                ImapErrBadMaterial,
                "material.bsdf_xml_path is given but material.surface is not IMAP_SURFACE_BSDF_XML"
            );
        }
        if m.surface != IMAP_SURFACE_TABLE && (m.table_brdf_count != 0 || m.table_btdf_count != 0) {
            bail!(
                ImapErrBadMaterial,
                "material.table_brdf / table_btdf are given but material.surface is not IMAP_SURFACE_TABLE"
            );
        }
        if m.surface != IMAP_SURFACE_CONDUCTOR && (m.metal != 0 || m.conductor_nk_count != 0) {
            bail!(
                ImapErrBadMaterial,
                "material.metal / conductor_nk are given but material.surface is not IMAP_SURFACE_CONDUCTOR"
            );
        }
        c.add_material(&desc)
    })
}

/// What checking measured table material `material` (IMAP_SURFACE_TABLE or
/// IMAP_SURFACE_BSDF_XML) found: `*worst_reciprocity` receives the largest |f(a, b) −
/// f(b, a)| over their mean at the grid's directions (0 for a reciprocal BRDF; measured
/// tables differ by their noise; for a BSDF file, over its reflections and between its
/// front and back transmissions, values above 1 % of the largest), and `*worst_albedo` the
/// largest directional albedo (reflected plus transmitted) at an incident grid direction
/// or patch. Either pointer may be NULL. Returns IMAP_ERR_NULL_POINTER (ctx),
/// IMAP_ERR_INDEX_OUT_OF_RANGE (no such material), IMAP_ERR_INVALID_ARGUMENT (neither).
/// (Since 0.2.3.)
///
/// # Safety
/// `ctx` is a live handle; the out pointers are NULL or point to writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_get_table_check(
    ctx: *const ImapContext,
    material: u32,
    worst_reciprocity: *mut f64,
    worst_albedo: *mut f64,
) -> ImapStatus {
    with_context(ctx, |c| {
        let check = c.table_check(material)?;
        if !worst_reciprocity.is_null() {
            write_out(
                "worst_reciprocity",
                worst_reciprocity,
                check.worst_reciprocity,
            )?;
        }
        if !worst_albedo.is_null() {
            write_out("worst_albedo", worst_albedo, check.worst_albedo)?;
        }
        Ok(())
    })
}

/// Adds a triangle mesh; `*out_id` receives its id (0, 1, ... in order). The arrays are
/// copied. The memory the mesh needs (its copy, its prepared form, its share of the BVH
/// and its map) is checked against the budget before anything is copied.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_EMPTY_MESH (no vertex or no triangle),
/// IMAP_ERR_NON_FINITE (a NaN/Inf coordinate or exitance), IMAP_ERR_PRECISION (a
/// coordinate beyond ±1e30), IMAP_ERR_INDEX_OUT_OF_RANGE (a vertex index ≥ vertex_count),
/// IMAP_ERR_DEGENERATE_TRIANGLE (a triangle repeating a vertex, unless
/// IMAP_MESH_SKIP_DEGENERATE; or no triangle left), IMAP_ERR_UNKNOWN_MATERIAL,
/// IMAP_ERR_INVALID_ARGUMENT, IMAP_ERR_NO_LIGHT (an emitting mesh with zero exitance or
/// zero area), IMAP_ERR_MEMORY_BUDGET, IMAP_ERR_OUT_OF_MEMORY, IMAP_ERR_OUT_OF_ORDER
/// (after a run: call `imap_reset` first), IMAP_ERR_BUSY. Nothing is added on failure.
///
/// # Safety
/// `ctx` is a live handle; `mesh` points to an `ImapMesh` whose arrays hold their counts of
/// values; `out_id` points to writable storage.
#[no_mangle]
pub unsafe extern "C" fn imap_add_mesh(
    ctx: *mut ImapContext,
    mesh: *const ImapMesh,
    out_id: *mut u32,
) -> ImapStatus {
    add_with(ctx, out_id, |c| {
        let m = read_versioned("mesh", mesh)?;
        if m.vertex_count == 0 || m.triangle_count == 0 {
            bail!(
                ImapErrEmptyMesh,
                "mesh has {} vertices and {} triangles: a mesh needs at least one triangle",
                m.vertex_count,
                m.triangle_count
            );
        }
        let positions = slice(
            "mesh.positions",
            m.positions,
            m.vertex_count.saturating_mul(3),
        )?;
        let indices = slice(
            "mesh.indices",
            m.indices,
            m.triangle_count.saturating_mul(3),
        )?;
        let triangle_materials = if m.triangle_materials.is_null() {
            None
        } else {
            Some(slice(
                "mesh.triangle_materials",
                m.triangle_materials,
                m.triangle_count,
            )?)
        };
        let exitance = if m.exitance_count == 0 {
            None
        } else {
            Some(slice("mesh.exitance", m.exitance, m.exitance_count)?)
        };
        let known = IMAP_MESH_TWO_SIDED
            | IMAP_MESH_RECORD
            | IMAP_MESH_SENSOR
            | IMAP_MESH_TALLY
            | IMAP_MESH_SKIP_DEGENERATE;
        if m.flags & !known != 0 {
            bail!(
                ImapErrInvalidArgument,
                "mesh.flags = 0x{:x} has bits that are no IMAP_MESH_* flag",
                m.flags
            );
        }
        let desc = MeshDesc {
            positions,
            indices,
            material: m.material,
            triangle_materials,
            two_sided: m.flags & IMAP_MESH_TWO_SIDED != 0,
            record: m.flags & IMAP_MESH_RECORD != 0,
            exitance,
            sensor: m.flags & IMAP_MESH_SENSOR != 0,
            tally: m.flags & IMAP_MESH_TALLY != 0,
            skip_degenerate: m.flags & IMAP_MESH_SKIP_DEGENERATE != 0,
            uvs: if m.uvs.is_null() {
                None
            } else {
                Some(slice("mesh.uvs", m.uvs, m.vertex_count.saturating_mul(2))?)
            },
            vertex_factors: if m.vertex_factors.is_null() {
                None
            } else {
                let c = m.vertex_factor_channels as usize;
                Some(slice(
                    "mesh.vertex_factors",
                    m.vertex_factors,
                    m.vertex_count.saturating_mul(c),
                )?)
            },
            vertex_factor_channels: m.vertex_factor_channels as usize,
        };
        c.add_mesh(&desc)
    })
}

/// Adds an isotropic point light at `position` (scene units, |x| ≤ 1e30) with radiant flux
/// `power` in W per band (1 value = the same in every band, or one per band; the sum over
/// bands must be finite); `*out_id` receives its id. Lights are chosen by power during the
/// run.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_NON_FINITE, IMAP_ERR_INVALID_ARGUMENT,
/// IMAP_ERR_PRECISION, IMAP_ERR_NO_LIGHT (zero power), IMAP_ERR_OUT_OF_ORDER,
/// IMAP_ERR_BUSY.
///
/// # Safety
/// `ctx` is a live handle; `position` points to 3 doubles; `power` to `power_count`;
/// `out_id` to writable storage.
#[no_mangle]
pub unsafe extern "C" fn imap_add_point_light(
    ctx: *mut ImapContext,
    position: *const f64,
    power: *const f64,
    power_count: usize,
    out_id: *mut u32,
) -> ImapStatus {
    add_with(ctx, out_id, |c| {
        c.add_point_light(
            vec3("position", position)?,
            slice("power", power, power_count)?,
        )
    })
}

/// Adds a spot light: uniform intensity inside the cone of `half_angle_rad` (0, π] around
/// `direction`, total flux `power` W per band.
///
/// Returns as `imap_add_point_light`, plus IMAP_ERR_INVALID_ARGUMENT for a zero direction
/// or an angle out of range.
///
/// # Safety
/// As `imap_add_point_light`; `direction` points to 3 doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_add_spot_light(
    ctx: *mut ImapContext,
    position: *const f64,
    direction: *const f64,
    half_angle_rad: f64,
    power: *const f64,
    power_count: usize,
    out_id: *mut u32,
) -> ImapStatus {
    add_with(ctx, out_id, |c| {
        let power = slice("power", power, power_count)?;
        c.add_spot_light(
            vec3("position", position)?,
            vec3("direction", direction)?,
            half_angle_rad,
            power,
        )
    })
}

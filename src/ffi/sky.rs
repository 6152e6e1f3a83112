//! Skies, environment images and the sun through the C ABI (Since 0.2.2).

use super::light::spectrum_from_c;
use super::scene::add_with;
use super::state::path_arg;
use super::{
    boundary, read_versioned, slice, with_context, write_defaults, write_out, ImapContext,
    Versioned,
};
use crate::context::Context;
use crate::error::{bail, ImapStatus, Result};
use crate::photometry::Spectrum;
use crate::scene::light::{SkyAmount, SkyDesc, SkyKind, SunDesc};
use crate::solar::{self, SunTime};
use std::ffi::c_char;
use std::sync::Arc;

/// Uniform radiance over the upper hemisphere. (Since 0.2.2.)
pub const IMAP_SKY_UNIFORM: u32 = 0;
/// Uniform radiance over every direction (an environment lighting from below too).
/// (Since 0.2.2.)
pub const IMAP_SKY_UNIFORM_SPHERE: u32 = 1;
/// A CIE standard general sky (ISO 15469 / CIE S 011), `cie_type` 1–15, with the sun at
/// `sun_azimuth_deg`, `sun_zenith_deg`. (Since 0.2.2.)
pub const IMAP_SKY_CIE: u32 = 2;
/// An equirectangular image (`image_rgb`, or a file given to `imap_add_sky_file`).
/// (Since 0.2.2.)
pub const IMAP_SKY_IMAGE: u32 = 3;
/// The Perez all-weather sky (Perez, Seals & Michalsky 1993) of clearness
/// `perez_clearness` and brightness `perez_brightness` (`imap_perez_sky` computes both, and
/// the diffuse horizontal illuminance to give as its amount, from a weather file's hour),
/// with the sun at `sun_azimuth_deg`, `sun_zenith_deg` (0–180°: a sun below the horizon
/// shapes a twilight sky as one at the horizon). (Since 0.2.3.)
pub const IMAP_SKY_PEREZ: u32 = 4;

/// A sky's amount: its radiance over all bands, W/(m² sr) (a CIE sky's at the zenith).
/// (Since 0.2.2.)
pub const IMAP_SKY_UNIT_RADIANCE: u32 = 0;
/// Its luminance, cd/m² (a CIE sky's at the zenith). (Since 0.2.2.)
pub const IMAP_SKY_UNIT_LUMINANCE: u32 = 1;
/// The irradiance it gives an unobstructed horizontal plane, W/m² over all bands.
/// (Since 0.2.2.)
pub const IMAP_SKY_UNIT_HORIZONTAL_W_PER_M2: u32 = 2;
/// The illuminance it gives an unobstructed horizontal plane, lx. (Since 0.2.2.)
pub const IMAP_SKY_UNIT_HORIZONTAL_LX: u32 = 3;
/// An image's pixel values times `amount` are radiance per channel, W/(m² sr).
/// (Since 0.2.2.)
pub const IMAP_SKY_UNIT_SCALE: u32 = 4;

/// A sky or environment. Initialise with `imap_sky_default(&s, sizeof s)`: a uniform sky
/// (amount 0 cd/m²: set it), no sun (NaN angles), zenith +z, north +y, not rotated.
/// (Since 0.2.2.)
///
/// Directions: azimuths are measured from `north` toward east (`north` × `zenith`),
/// zenith angles from `zenith`. An image is equirectangular: its rows run from the zenith
/// (top) to the nadir, its columns over azimuths with the centre column toward north and
/// east to the right of it (as seen from inside); each pixel's value is the radiance over
/// its solid angle. Its photons enter through the scene's bounding sphere, so the sky
/// lights any scene exactly whatever its size and position.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapSky {
    pub struct_size: u32,
    /// `IMAP_SKY_*`.
    pub kind: u32,
    /// CIE: the sky type, 1–15.
    pub cie_type: u32,
    /// `IMAP_SKY_UNIT_*` of `amount`. Uniform and CIE skies: RADIANCE, LUMINANCE or a
    /// horizontal amount; images: SCALE or a horizontal amount.
    pub unit: u32,
    /// How bright, in `unit`.
    pub amount: f64,
    /// CIE: the sun's azimuth (degrees from north toward east) and zenith angle (0–90°).
    /// The defaults are NaN, "not set": types 1, 3 and 5 do not depend on the sun, every
    /// other type is refused without it (IMAP_ERR_INVALID_ARGUMENT), as the command
    /// refuses it. (Before 0.2.3 the defaults placed the sun at azimuth 180°, zenith 45°.)
    pub sun_azimuth_deg: f64,
    pub sun_zenith_deg: f64,
    /// The sky's zenith and north in scene coordinates (any length but 0; north's part
    /// along the zenith is ignored).
    pub zenith: [f64; 3],
    pub north: [f64; 3],
    /// Turns the sky about the zenith, degrees toward east (−360 to 360).
    pub rotation_deg: f64,
    /// IMAGE (imap_add_sky): `image_width × image_height` linear RGB triples, rows from
    /// the zenith down. The library copies them.
    pub image_rgb: *const f32,
    pub image_width: usize,
    pub image_height: usize,
    /// PEREZ: the sky's clearness ε (1–1000; 1 is fully overcast) and brightness Δ
    /// (10⁻⁶–10). Default 0: not set. (Since 0.2.3.)
    pub perez_clearness: f64,
    pub perez_brightness: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers and raw pointers only.
unsafe impl Versioned for ImapSky {
    const NAME: &'static str = "ImapSky";
    const INIT: &'static str = "imap_sky_default";
    /// The layout of 0.2.2, before the Perez sky's fields.
    const BASE_SIZE: usize = std::mem::offset_of!(ImapSky, perez_clearness);
    fn defaults() -> Self {
        let d = SkyDesc::default();
        ImapSky {
            struct_size: std::mem::size_of::<Self>() as u32,
            kind: IMAP_SKY_UNIFORM,
            cie_type: 0,
            unit: IMAP_SKY_UNIT_LUMINANCE,
            amount: 0.0,
            sun_azimuth_deg: f64::NAN,
            sun_zenith_deg: f64::NAN,
            zenith: d.zenith,
            north: d.north,
            rotation_deg: 0.0,
            image_rgb: std::ptr::null(),
            image_width: 0,
            image_height: 0,
            perez_clearness: 0.0,
            perez_brightness: 0.0,
        }
    }
}

/// The sun: a uniformly bright disk of 0.53°. Initialise with `imap_sun_default(&s,
/// sizeof s)`: due south at 45° zenith angle, `unit` IMAP_UNIT_LX, amount 0 (set it),
/// zenith +z, north +y. (Since 0.2.2.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapSun {
    pub struct_size: u32,
    /// `IMAP_UNIT_LX` (direct normal illuminance) or `IMAP_UNIT_W_PER_M2` (direct normal
    /// irradiance over all bands).
    pub unit: u32,
    pub amount: f64,
    /// Degrees from north toward east; the zenith angle 0–90° (`imap_sun_position` gives
    /// both for a date, time and place).
    pub azimuth_deg: f64,
    pub zenith_deg: f64,
    /// As `ImapSky`.
    pub zenith: [f64; 3],
    pub north: [f64; 3],
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapSun {
    const NAME: &'static str = "ImapSun";
    const INIT: &'static str = "imap_sun_default";
    fn defaults() -> Self {
        ImapSun {
            struct_size: std::mem::size_of::<Self>() as u32,
            unit: super::light::IMAP_UNIT_LX,
            amount: 0.0,
            azimuth_deg: 180.0,
            zenith_deg: 45.0,
            zenith: [0.0, 0.0, 1.0],
            north: [0.0, 1.0, 0.0],
        }
    }
}

/// A moment and a place for `imap_sun_position`. Initialise with
/// `imap_sun_time_default(&t, sizeof t)` (2000-06-21 12:00 UTC at 0° N 0° E, sea level).
/// (Since 0.2.2.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapSunTime {
    pub struct_size: u32,
    pub year: i32,
    pub month: u32,
    pub day: u32,
    pub hour: u32,
    pub minute: u32,
    pub second: f64,
    /// Local time's offset from UTC, hours (+1 for CET).
    pub utc_offset_hours: f64,
    /// Degrees north, degrees east, metres above sea level.
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    pub elevation_m: f64,
    /// `IMAP_SUN_TIME_*` flags: which of the fields below are given (0: a standard
    /// atmosphere of 1013.25 hPa and 10 °C for refraction, ΔT estimated from the date).
    /// (Since 0.2.3.)
    pub flags: u32,
    /// The air's pressure at the site, hPa, with `IMAP_SUN_TIME_ATMOSPHERE`.
    pub pressure_hpa: f64,
    /// The air's temperature at the site, °C, with `IMAP_SUN_TIME_ATMOSPHERE`.
    pub temperature_c: f64,
    /// ΔT = TT − UT1, s, with `IMAP_SUN_TIME_DELTA_T` (the SPA paper's example: 67).
    pub delta_t_s: f64,
}

/// `ImapSunTime::flags`: `pressure_hpa` and `temperature_c` are given. (Since 0.2.3.)
pub const IMAP_SUN_TIME_ATMOSPHERE: u32 = 1;
/// `ImapSunTime::flags`: no atmospheric refraction (the true, geometric position).
/// (Since 0.2.3.)
pub const IMAP_SUN_TIME_NO_REFRACTION: u32 = 2;
/// `ImapSunTime::flags`: `delta_t_s` is given. (Since 0.2.3.)
pub const IMAP_SUN_TIME_DELTA_T: u32 = 4;

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapSunTime {
    const NAME: &'static str = "ImapSunTime";
    const INIT: &'static str = "imap_sun_time_default";
    /// The layout of 0.2.2, before `flags`.
    const BASE_SIZE: usize = std::mem::offset_of!(ImapSunTime, flags);
    fn defaults() -> Self {
        ImapSunTime {
            struct_size: std::mem::size_of::<Self>() as u32,
            year: 2000,
            month: 6,
            day: 21,
            hour: 12,
            minute: 0,
            second: 0.0,
            utc_offset_hours: 0.0,
            latitude_deg: 0.0,
            longitude_deg: 0.0,
            elevation_m: 0.0,
            flags: 0,
            pressure_hpa: 0.0,
            temperature_c: 0.0,
            delta_t_s: 0.0,
        }
    }
}

/// Fills `size` bytes at `out` with a sky's defaults (see `ImapSky`). (Since 0.2.2.)
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_sky_default(out: *mut ImapSky, size: usize) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// Fills `size` bytes at `out` with the sun's defaults (see `ImapSun`). (Since 0.2.2.)
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_sun_default(out: *mut ImapSun, size: usize) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// Fills `size` bytes at `out` with a `ImapSunTime`'s defaults. (Since 0.2.2.)
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_sun_time_default(out: *mut ImapSunTime, size: usize) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// The sky's spectrum: NULL means CIE D65 (daylight).
fn daylight_spectrum(s: *const super::light::ImapSpectrum) -> Result<Spectrum> {
    if s.is_null() {
        Ok(Spectrum::CieD65)
    } else {
        spectrum_from_c(s)
    }
}

fn sky_from_c(c: &Context, s: &ImapSky, image: bool) -> Result<SkyDesc> {
    let x = s.amount;
    let amount = match s.unit {
        IMAP_SKY_UNIT_RADIANCE => SkyAmount::Radiance(x),
        IMAP_SKY_UNIT_LUMINANCE => SkyAmount::Luminance(x),
        IMAP_SKY_UNIT_HORIZONTAL_W_PER_M2 => SkyAmount::HorizontalIrradiance(x),
        IMAP_SKY_UNIT_HORIZONTAL_LX => SkyAmount::HorizontalIlluminance(x),
        IMAP_SKY_UNIT_SCALE => SkyAmount::Scale(x),
        u => bail!(
            ImapErrInvalidArgument,
            "sky.unit = {u} is not an IMAP_SKY_UNIT_* value (0–4)"
        ),
    };
    let kind = match s.kind {
        _ if image => SkyKind::Uniform { sphere: false },
        IMAP_SKY_UNIFORM => SkyKind::Uniform { sphere: false },
        IMAP_SKY_UNIFORM_SPHERE => SkyKind::Uniform { sphere: true },
        IMAP_SKY_CIE => SkyKind::Cie {
            kind: s.cie_type,
            sun_azimuth_deg: s.sun_azimuth_deg,
            sun_zenith_deg: s.sun_zenith_deg,
        },
        IMAP_SKY_PEREZ => {
            if s.sun_azimuth_deg.is_nan() || s.sun_zenith_deg.is_nan() {
                bail!(
                    ImapErrInvalidArgument,
                    "sky.sun_azimuth_deg and sky.sun_zenith_deg are not set: a Perez sky needs its sun's position"
                );
            }
            SkyKind::Perez {
                sun_azimuth_deg: s.sun_azimuth_deg,
                sun_zenith_deg: s.sun_zenith_deg,
                clearness: s.perez_clearness,
                brightness: s.perez_brightness,
            }
        }
        IMAP_SKY_IMAGE => {
            let n = s
                .image_width
                .checked_mul(s.image_height)
                .and_then(|n| n.checked_mul(3))
                .filter(|&n| n > 0)
                .ok_or_else(|| {
                    crate::error::Error::new(
                        ImapStatus::ImapErrInvalidArgument,
                        format!(
                            "sky.image_width × image_height = {} × {}: not a usable image size",
                            s.image_width, s.image_height
                        ),
                    )
                })?;
            c.check_sky_image(s.image_width, s.image_height)?;
            let rgb = slice("sky.image_rgb", s.image_rgb, n)?;
            SkyKind::Image {
                width: s.image_width,
                height: s.image_height,
                rgb: Arc::new(rgb.to_vec()),
            }
        }
        k => bail!(
            ImapErrInvalidArgument,
            "sky.kind = {k} is not an IMAP_SKY_* value (0–4)"
        ),
    };
    Ok(SkyDesc {
        kind,
        amount,
        spectrum: Spectrum::CieD65,
        zenith: s.zenith,
        north: s.north,
        rotation_deg: s.rotation_deg,
    })
}

/// Adds a sky or environment (`ImapSky`) in `spectrum` (NULL: CIE D65; an image has its
/// own colours and ignores it); `*out_id` receives its light id (a light group can be set
/// on it like any light's). Works with every estimator and the renderer.
/// `imap_get_light_flux` reports the irradiance and illuminance it gives an unobstructed
/// horizontal plane.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_NON_FINITE (naming the field, or the pixel),
/// IMAP_ERR_INVALID_ARGUMENT (naming the field: an unknown kind or unit, a unit the kind
/// cannot take, a CIE type outside 1–15, a sun below the horizon, north parallel to the
/// zenith, an amount ≤ 0), IMAP_ERR_NO_LIGHT (a black image), IMAP_ERR_MEMORY_BUDGET (an
/// image that would take the context past its budget, refused before it is copied: about
/// 120 bytes per pixel while it is added, 72 held), IMAP_ERR_BUSY. The context is
/// unchanged on any error. (Since 0.2.2.)
///
/// # Safety
/// `ctx` is a live handle; `sky` points to an initialised `ImapSky` whose image (kind
/// IMAGE) holds `3 × image_width × image_height` floats; `spectrum` is NULL or
/// initialised; `out_id` is writable.
#[no_mangle]
pub unsafe extern "C" fn imap_add_sky(
    ctx: *mut ImapContext,
    sky: *const ImapSky,
    spectrum: *const super::light::ImapSpectrum,
    out_id: *mut u32,
) -> ImapStatus {
    add_with(ctx, out_id, |c| {
        let s = read_versioned("sky", sky)?;
        let mut desc = sky_from_c(c, &s, false)?;
        desc.spectrum = daylight_spectrum(spectrum)?;
        c.add_sky(&desc)
    })
}

/// Adds an environment from an equirectangular Radiance HDR (.hdr, .pic) or OpenEXR
/// (.exr) file at NUL-terminated `path` (recognised by content), oriented and scaled by
/// `sky` (its kind and image fields are ignored; `unit` SCALE or a horizontal amount).
/// Returns IMAP_ERR_IO (the file cannot be read), IMAP_ERR_PARSE (not such an image; the
/// message names the file), and as `imap_add_sky`. (Since 0.2.2.)
///
/// # Safety
/// As `imap_add_sky`; `path` is NUL-terminated.
#[no_mangle]
pub unsafe extern "C" fn imap_add_sky_file(
    ctx: *mut ImapContext,
    path: *const c_char,
    sky: *const ImapSky,
    out_id: *mut u32,
) -> ImapStatus {
    add_with(ctx, out_id, |c| {
        let path = path_arg("path", path)?;
        let s = read_versioned("sky", sky)?;
        let desc = sky_from_c(c, &s, true)?;
        c.add_sky_file(path, &desc)
    })
}

/// Adds the sun (`ImapSun`) in `spectrum` (NULL: CIE D65). Returns as `imap_add_sky`
/// (IMAP_ERR_INVALID_ARGUMENT for a unit other than LX or W_PER_M2). (Since 0.2.2.)
///
/// # Safety
/// `ctx` is a live handle; `sun` points to an initialised `ImapSun`; `spectrum` is NULL or
/// initialised; `out_id` is writable.
#[no_mangle]
pub unsafe extern "C" fn imap_add_sun(
    ctx: *mut ImapContext,
    sun: *const ImapSun,
    spectrum: *const super::light::ImapSpectrum,
    out_id: *mut u32,
) -> ImapStatus {
    add_with(ctx, out_id, |c| {
        let s = read_versioned("sun", sun)?;
        let amount = match s.unit {
            super::light::IMAP_UNIT_LX => SkyAmount::NormalIlluminance(s.amount),
            super::light::IMAP_UNIT_W_PER_M2 => SkyAmount::NormalIrradiance(s.amount),
            u => bail!(
                ImapErrInvalidArgument,
                "sun.unit = {u}: the sun takes IMAP_UNIT_LX or IMAP_UNIT_W_PER_M2 (its direct normal illuminance or irradiance)"
            ),
        };
        c.add_sun(&SunDesc {
            azimuth_deg: s.azimuth_deg,
            zenith_deg: s.zenith_deg,
            amount,
            spectrum: daylight_spectrum(spectrum)?,
            zenith: s.zenith,
            north: s.north,
        })
    })
}

/// Adds the ground's glow (Radiance's ground glow): a uniform radiance ρ E_h / π below
/// the horizon of `zenith` (3 doubles, the scene's up), with E_h the horizontal
/// irradiance of the skies and suns added before it and ρ `reflectance` (`count` = 1
/// grey value or one per band, each in [0, 1]). It stands for an open ground reflecting
/// what the sky and sun give it; every estimator and the renderer see it below the
/// horizon. `imap_light_flux` reports 0 for it. IMAP_ERR_INVALID_ARGUMENT before any sky
/// or sun, for a second ground, a reflectance outside [0, 1] or a glow of 0.
/// (Since 0.2.3.)
///
/// # Safety
/// `ctx` is a live handle; `reflectance` holds `count` doubles; `zenith` holds 3;
/// `out_id` is writable.
#[no_mangle]
pub unsafe extern "C" fn imap_add_ground(
    ctx: *mut ImapContext,
    reflectance: *const f64,
    count: usize,
    zenith: *const f64,
    out_id: *mut u32,
) -> ImapStatus {
    add_with(ctx, out_id, |c| {
        let rho = slice("reflectance", reflectance, count)?;
        let z = slice("zenith", zenith, 3)?;
        c.add_ground(rho, [z[0], z[1], z[2]])
    })
}

/// Sets the window portals: `triangle_count` triangles of `indices` (3 each) into
/// `vertex_count` vertices of `positions` (xyz, scene units), each facing out of the model
/// (its normal by the right-hand rule toward the sky). With portals three quarters of
/// every sky's, the sun's and the ground's photons come in through them and a quarter
/// from the whole sky, each weighted by the mixture's density of its line: unbiased for
/// every surface, and far fewer photons wasted on the rest of the sky when daylight enters
/// a building by its windows (docs/daylight.md). A portal facing away gathers nothing.
/// Replaces earlier portals; 0 triangles removes them. IMAP_ERR_INVALID_ARGUMENT for an
/// index out of range or only degenerate triangles, IMAP_ERR_NON_FINITE for a coordinate.
/// (Since 0.2.3.)
///
/// # Safety
/// `ctx` is a live handle; `positions` holds 3 × `vertex_count` doubles and `indices`
/// 3 × `triangle_count` indices (either may be NULL when its count is 0).
#[no_mangle]
pub unsafe extern "C" fn imap_set_portals(
    ctx: *mut ImapContext,
    positions: *const f64,
    vertex_count: usize,
    indices: *const u32,
    triangle_count: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        let p = slice("positions", positions, vertex_count.saturating_mul(3))?;
        let i = slice("indices", indices, triangle_count.saturating_mul(3))?;
        c.set_portals(p, i)
    })
}

/// `material` argument of `imap_set_scene_medium`: no medium outside the meshes (air).
/// (Since 0.2.3.)
pub const IMAP_NO_MEDIUM: u32 = u32::MAX;

/// Fills the space outside every closed mesh that holds a medium with the medium of
/// material `material` (haze in a room, fog in a tunnel or on a stage), or empties it
/// (IMAP_NO_MEDIUM). The material (`imap_add_material`) must be a smooth dielectric of
/// index 1 in every band (IMAP_IOR_CONSTANT with `ior[0]` = 1) with `absorption_per_m`
/// or `scattering_per_m` (and its `phase_g` or phase table). The medium fills the sphere
/// around the geometry's centre that holds the geometry and every light but the distant
/// ones; a sky's and the sun's light crosses it from its surface, and lights inside it
/// shine from their own position.
/// - Photons scatter and are absorbed in it, so surfaces and sensors receive what
///   arrives through it (light scattered in it included).
/// - Light sampling and gathering attenuate their light samples and paths by its
///   transmittance, per band; light scattered in it is the photons' there.
/// - Sensors read the light that crosses them (by its expected value along each photon's
///   segment).
/// - `imap_get_medium_absorbed(ctx, IMAP_SCENE_MEDIUM, ...)`: what it absorbed, per band
///   and in lm, with errors.
/// - `imap_render` (every method) and the path tracer show it: eye paths are attenuated
///   and scattered by it, and where they scatter they take a light sample of the lights
///   no path can meet (points, spots, beams, luminaires and the sun: a lamp's glow and a
///   beam in fog), attenuated by it; emitting meshes and skies are met by the paths.
///
/// Changing it discards the prepared scene, like adding a mesh. (Since 0.2.3.)
///
/// Returns IMAP_ERR_INVALID_ARGUMENT naming the material (no such material, not a
/// medium, index not 1, rough), IMAP_ERR_UNSUPPORTED for a fluorescent medium (a mesh's
/// medium may fluoresce; the scene's may not), IMAP_ERR_OUT_OF_ORDER after photons were
/// traced (call imap_reset first).
///
/// # Safety
/// `ctx` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn imap_set_scene_medium(ctx: *mut ImapContext, material: u32) -> ImapStatus {
    with_context(ctx, |c| {
        c.set_scene_medium((material != IMAP_NO_MEDIUM).then_some(material))
    })
}

/// An hour's Perez sky (`imap_perez_sky`). (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapPerezSky {
    pub struct_size: u32,
    /// The clearness bin, 0 (overcast, ε < 1.065) to 7 (clear, ε ≥ 6.2).
    pub bin: u32,
    /// The sky's clearness ε and brightness Δ: `ImapSky::perez_clearness` and
    /// `perez_brightness`.
    pub clearness: f64,
    pub brightness: f64,
    /// The precipitable water the efficacies were computed with, cm.
    pub precipitable_water_cm: f64,
    /// The diffuse horizontal illuminance, lx: the Perez sky's amount
    /// (`IMAP_SKY_UNIT_HORIZONTAL_LX`).
    pub diffuse_horizontal_lx: f64,
    /// The direct normal illuminance, lx: the sun's amount (`IMAP_UNIT_LX`).
    pub direct_normal_lx: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapPerezSky {
    const NAME: &'static str = "ImapPerezSky";
    const INIT: &'static str = "sizeof(ImapPerezSky)";
    fn defaults() -> Self {
        ImapPerezSky {
            struct_size: std::mem::size_of::<Self>() as u32,
            bin: 0,
            clearness: 0.0,
            brightness: 0.0,
            precipitable_water_cm: 0.0,
            diffuse_horizontal_lx: 0.0,
            direct_normal_lx: 0.0,
        }
    }
}

/// The Perez sky of an hour of weather (Perez, Ineichen, Seals, Michalsky & Stewart 1990):
/// from its direct normal and diffuse horizontal irradiance (W/m², the whole solar
/// spectrum, as weather files give them: an EPW file's fields 15 and 16), the sun's
/// zenith angle (degrees, 0–180; a sun below the horizon is taken at it), the day of the
/// year (1–366) and the precipitable water (cm, 0–20; from a dew point Td in °C it is
/// exp(0.07 Td − 0.075); Radiance's gendaylit takes 2). Writes the sky's clearness and
/// brightness, and the diffuse horizontal and direct normal illuminance by the Perez
/// luminous efficacy models, into `out` (`out_size` = sizeof(ImapPerezSky)). Returns
/// IMAP_ERR_NO_LIGHT when the diffuse irradiance is 0 (no sky: add none, nor a sun),
/// IMAP_ERR_NON_FINITE or IMAP_ERR_INVALID_ARGUMENT naming the argument. Thread-safe.
/// (Since 0.2.3.)
///
/// # Safety
/// `out` points to `out_size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_perez_sky(
    direct_normal_irradiance: f64,
    diffuse_horizontal_irradiance: f64,
    sun_zenith_deg: f64,
    day_of_year: u32,
    precipitable_water_cm: f64,
    out: *mut ImapPerezSky,
    out_size: usize,
) -> ImapStatus {
    boundary(None, || {
        super::check_out("out", out)?;
        let Some(s) = crate::scene::light::perez_sky(
            direct_normal_irradiance,
            diffuse_horizontal_irradiance,
            sun_zenith_deg,
            day_of_year,
            precipitable_water_cm,
        )?
        else {
            bail!(
                ImapErrNoLight,
                "diffuse_horizontal_irradiance = 0: an hour without diffuse light has no sky"
            );
        };
        super::write_versioned(
            "out",
            out,
            out_size,
            ImapPerezSky {
                struct_size: 0,
                bin: s.bin as u32,
                clearness: s.clearness,
                brightness: s.brightness,
                precipitable_water_cm: s.precipitable_water_cm,
                diffuse_horizontal_lx: s.diffuse_horizontal_lx,
                direct_normal_lx: s.direct_normal_lx,
            },
        )
    })
}

/// The sun's apparent position at a local date and time and a place: azimuth (degrees from
/// north toward east) into `*out_azimuth_deg`, zenith angle (degrees; above 90 when it is
/// below the horizon) into `*out_zenith_deg`. NREL's Solar Position Algorithm (±0.0003°,
/// years −2000 to 6000). ΔT is estimated from the date and refraction is a standard
/// atmosphere's (1013.25 hPa, 10 °C) unless `time->flags` gives them
/// (`IMAP_SUN_TIME_DELTA_T`, `IMAP_SUN_TIME_ATMOSPHERE`, `IMAP_SUN_TIME_NO_REFRACTION`):
/// the SPA paper's example (2003-10-17 12:30:30 at −7 h, 39.742476° N, 105.1786° W,
/// 1830.14 m, 820 hPa, 11 °C, ΔT = 67 s) gives azimuth 194.34024°, zenith 50.11162°.
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_NON_FINITE, IMAP_ERR_INVALID_ARGUMENT (naming
/// the field: a date that does not exist, a latitude outside ±90°, a pressure or
/// temperature out of range, unknown flags, …). Thread-safe. (Since 0.2.2.)
///
/// # Safety
/// `time` points to an initialised `ImapSunTime`; the outputs are writable.
#[no_mangle]
pub unsafe extern "C" fn imap_sun_position(
    time: *const ImapSunTime,
    out_azimuth_deg: *mut f64,
    out_zenith_deg: *mut f64,
) -> ImapStatus {
    boundary(None, || {
        super::check_out("out_azimuth_deg", out_azimuth_deg)?;
        super::check_out("out_zenith_deg", out_zenith_deg)?;
        let t = read_versioned("time", time)?;
        let known = IMAP_SUN_TIME_ATMOSPHERE | IMAP_SUN_TIME_NO_REFRACTION | IMAP_SUN_TIME_DELTA_T;
        if t.flags & !known != 0 {
            bail!(
                ImapErrInvalidArgument,
                "time.flags = {:#x} sets bits no IMAP_SUN_TIME_* flag has",
                t.flags
            );
        }
        let delta_t = (t.flags & IMAP_SUN_TIME_DELTA_T != 0).then_some(t.delta_t_s);
        let refraction = if t.flags & IMAP_SUN_TIME_NO_REFRACTION != 0 {
            None
        } else if t.flags & IMAP_SUN_TIME_ATMOSPHERE != 0 {
            Some((t.pressure_hpa, t.temperature_c))
        } else {
            Some(solar::STANDARD_ATMOSPHERE)
        };
        let (a, z) = solar::sun_position_with(
            &SunTime {
                year: t.year,
                month: t.month,
                day: t.day,
                hour: t.hour,
                minute: t.minute,
                second: t.second,
                utc_offset_hours: t.utc_offset_hours,
                latitude_deg: t.latitude_deg,
                longitude_deg: t.longitude_deg,
                elevation_m: t.elevation_m,
            },
            delta_t,
            refraction,
        )?;
        write_out("out_azimuth_deg", out_azimuth_deg, a)?;
        write_out("out_zenith_deg", out_zenith_deg, z)
    })
}

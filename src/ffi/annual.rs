//! Annual daylight for C (`imap::annual`, docs/daylight.md "Annual daylight"): a year of
//! sky vectors from a weather file, the Tregenza patches as light groups of a context and
//! their coefficients at chosen vertices, the direct sun along its lines, the hourly
//! illuminance and the metrics with their confidence, and the daylight factor.
//!
//! The sky vectors and the direct sun are opaque objects the library owns
//! (`ImapAnnualSky`, `ImapDirectSun`), each freed by its own `*_free`. Like contexts they
//! are looked up in a table of live objects before use: a freed or made-up handle is an
//! error, never a read of freed memory. The coefficients are the caller's arrays (sensors
//! × patches, sensor by sensor, lx per cd/m²) so that a host can keep, merge or store
//! them.

use super::{
    boundary, read_versioned, slice, slice_mut, with_context, write_defaults, write_out,
    write_versioned, Versioned,
};
use crate::annual::lighting::{Control, Dimming};
use crate::annual::{
    AnnualSky, CoefficientsView, DirectSun, MetricOptions, Shaded, Shading, ShadingRule,
    SunInVectors, WindowGroup,
};
use crate::error::{bail, Error, ImapStatus, Result};
use std::any::Any;
use std::collections::HashMap;
use std::os::raw::c_char;
use std::sync::{Arc, LazyLock, RwLock};

/// A year of sky vectors (`imap_annual_sky_read`). Opaque. (Since 0.2.3.)
pub struct ImapAnnualSky {
    sky: AnnualSky,
}

/// The direct sun at a set of points (`imap_direct_sun_new`). Opaque. (Since 0.2.3.)
pub struct ImapDirectSun {
    sun: DirectSun,
}

type Live = HashMap<usize, Arc<dyn Any + Send + Sync>>;

/// The live objects by the address handed to C.
static OBJECTS: LazyLock<RwLock<Live>> = LazyLock::new(Default::default);

fn register<T: Any + Send + Sync>(value: T) -> *mut T {
    let a: Arc<dyn Any + Send + Sync> = Arc::new(value);
    let ptr = Arc::as_ptr(&a) as *const () as *mut T;
    OBJECTS
        .write()
        .unwrap_or_else(|p| p.into_inner())
        .insert(ptr as usize, a);
    ptr
}

fn lookup<T: Any + Send + Sync>(name: &str, ptr: *const T) -> Result<Arc<T>> {
    if ptr.is_null() {
        bail!(ImapErrNullPointer, "{name} is NULL");
    }
    let found = OBJECTS
        .read()
        .unwrap_or_else(|p| p.into_inner())
        .get(&(ptr as usize))
        .cloned();
    found.and_then(|a| a.downcast::<T>().ok()).ok_or_else(|| {
        Error::new(
            ImapStatus::ImapErrInvalidArgument,
            format!("{name} is not a live object of its kind: it was freed, or did not come from this library"),
        )
    })
}

fn free<T: Any + Send + Sync>(name: &str, ptr: *mut T) -> Result<()> {
    if ptr.is_null() {
        return Ok(());
    }
    lookup(name, ptr as *const T)?;
    OBJECTS
        .write()
        .unwrap_or_else(|p| p.into_inner())
        .remove(&(ptr as usize));
    Ok(())
}

/// One hour of an annual sky (`imap_annual_sky_hour`). (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapAnnualHour {
    pub struct_size: u32,
    pub month: u32,
    pub day: u32,
    /// The sky patch that holds the sun (0: the sun is down).
    pub sun_patch: u32,
    /// Decimal hours of local standard time (the middle of the row's step).
    pub hour: f64,
    /// The sun's azimuth (from north toward east) and zenith angle, degrees.
    pub sun_azimuth_deg: f64,
    pub sun_zenith_deg: f64,
    /// The hour's diffuse horizontal and direct normal illuminance by the Perez
    /// efficacies, lx (0 at night, for missing data, or without diffuse light).
    pub diffuse_horizontal_lx: f64,
    pub direct_normal_lx: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapAnnualHour {
    const NAME: &'static str = "ImapAnnualHour";
    const INIT: &'static str = "sizeof(ImapAnnualHour)";
    fn defaults() -> Self {
        ImapAnnualHour {
            struct_size: std::mem::size_of::<Self>() as u32,
            month: 0,
            day: 0,
            sun_patch: 0,
            hour: 0.0,
            sun_azimuth_deg: 0.0,
            sun_zenith_deg: 0.0,
            diffuse_horizontal_lx: 0.0,
            direct_normal_lx: 0.0,
        }
    }
}

/// Reads a weather file (EnergyPlus .epw, or Radiance .wea by its extension) and makes
/// every hour's sky vector over Reinhart's MF:`mf` patches (1: Tregenza's 145 and the
/// ground): the hour's Perez sky averaged over each patch, the ground ρ E_h / π with ρ =
/// `ground_reflectance`; the sun is left out (the direct sun and its patch's share come in
/// through `ImapDirectSun`). Returns IMAP_ERR_IO for a file that cannot be read,
/// IMAP_ERR_PARSE naming the file, line and field of a bad one, IMAP_ERR_INVALID_ARGUMENT
/// for an unsupported `mf`
/// or a reflectance outside [0, 1]. Thread-safe. (Since 0.2.3.)
///
/// # Safety
/// `path` is NUL-terminated; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn imap_annual_sky_read(
    path: *const c_char,
    mf: u32,
    ground_reflectance: f64,
    out: *mut *mut ImapAnnualSky,
) -> ImapStatus {
    boundary(None, || {
        super::check_out("out", out)?;
        let path = super::state::path_arg("path", path)?;
        let weather = crate::weather::read(path)?;
        let sky = AnnualSky::from_weather(&weather, mf, SunInVectors::Left, ground_reflectance)?;
        write_out("out", out, register(ImapAnnualSky { sky }))
    })
}

/// Frees a sky from `imap_annual_sky_read` (NULL: nothing). IMAP_ERR_INVALID_ARGUMENT
/// for a handle that is not a live sky. (Since 0.2.3.)
///
/// # Safety
/// `sky` is NULL or came from `imap_annual_sky_read`.
#[no_mangle]
pub unsafe extern "C" fn imap_annual_sky_free(sky: *mut ImapAnnualSky) -> ImapStatus {
    boundary(None, || free("sky", sky))
}

/// The sky's hour count and patch count (the ground's included: 146 for MF:1).
/// (Since 0.2.3.)
///
/// # Safety
/// `sky` is a live sky; the outputs are writable.
#[no_mangle]
pub unsafe extern "C" fn imap_annual_sky_size(
    sky: *const ImapAnnualSky,
    out_hours: *mut usize,
    out_patches: *mut usize,
) -> ImapStatus {
    boundary(None, || {
        let s = lookup("sky", sky)?;
        super::check_out("out_hours", out_hours)?;
        super::check_out("out_patches", out_patches)?;
        write_out("out_hours", out_hours, s.sky.hours.len())?;
        write_out("out_patches", out_patches, s.sky.patches.count())
    })
}

/// Hour `hour` (0-based, as the file's rows) of the sky into `out` (`out_size` =
/// sizeof(ImapAnnualHour)). IMAP_ERR_INDEX_OUT_OF_RANGE past the last. (Since 0.2.3.)
///
/// # Safety
/// `sky` is a live sky; `out` points to `out_size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_annual_sky_hour(
    sky: *const ImapAnnualSky,
    hour: usize,
    out: *mut ImapAnnualHour,
    out_size: usize,
) -> ImapStatus {
    boundary(None, || {
        let s = lookup("sky", sky)?;
        let a = hour_of(&s.sky, hour)?;
        write_versioned(
            "out",
            out,
            out_size,
            ImapAnnualHour {
                struct_size: 0,
                month: a.month,
                day: a.day,
                sun_patch: a.sun_patch as u32,
                hour: a.hour,
                sun_azimuth_deg: a.sun_azimuth_deg,
                sun_zenith_deg: a.sun_zenith_deg,
                diffuse_horizontal_lx: a.diffuse_horizontal_lx,
                direct_normal_lx: a.direct_normal_lx,
            },
        )
    })
}

fn hour_of(sky: &AnnualSky, hour: usize) -> Result<&crate::annual::AnnualHour> {
    sky.hours.get(hour).ok_or_else(|| {
        Error::new(
            ImapStatus::ImapErrIndexOutOfRange,
            format!("hour = {hour}: the sky has {} hours", sky.hours.len()),
        )
    })
}

/// Hour `hour`'s sky vector: each patch's mean luminance, cd/m², into `out[0 .. count)`
/// (`count` = the patch count). (Since 0.2.3.)
///
/// # Safety
/// `sky` is a live sky; `out` holds `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_annual_sky_vector(
    sky: *const ImapAnnualSky,
    hour: usize,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    boundary(None, || {
        let s = lookup("sky", sky)?;
        hour_of(&s.sky, hour)?;
        let n = s.sky.patches.count();
        if count != n {
            bail!(
                ImapErrInvalidArgument,
                "count = {count}: the sky has {n} patches"
            );
        }
        slice_mut("out", out, count)?.copy_from_slice(s.sky.vector(hour));
        Ok(())
    })
}

/// Adds Reinhart MF:`mf`'s patches as skies of 1 cd/m² each (CIE D65; the ground's below
/// the horizon), oriented by `zenith` and `north` (NULL: +z and +y), patch p ≥ 1 in light
/// group p and the ground in group `count` (the patch count: 146 for MF:1), so that group
/// 0 keeps the model's own emitters. A run then makes each patch's daylight coefficients
/// as its group's layer (`imap_annual_coefficients` reads them). Turns on the per-group
/// layers. The first patch's light id goes to `out_first_light` (NULL: not wanted).
/// Returns IMAP_ERR_INVALID_ARGUMENT for MF:2 and finer (more patches than the 254 light
/// groups: `imap_annual_trace_coefficients` traces them in batches), or as `imap_add_sky`.
/// (Since 0.2.3.)
///
/// # Safety
/// `ctx` is a live handle; `zenith` and `north` are NULL or point to 3 doubles;
/// `out_first_light` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn imap_add_sky_patches(
    ctx: *mut super::ImapContext,
    mf: u32,
    zenith: *const f64,
    north: *const f64,
    out_first_light: *mut u32,
) -> ImapStatus {
    with_context(ctx, |c| {
        let zenith = vec3("zenith", zenith, [0.0, 0.0, 1.0])?;
        let north = vec3("north", north, [0.0, 1.0, 0.0])?;
        let first = crate::annual::add_sky_patches(c, mf, zenith, north)?;
        super::write_optional(out_first_light, first)
    })
}

/// The daylight coefficients at vertices `vertices[0 .. count)` of mesh `mesh` (`side`
/// 0 front, 1 back) after a run with `imap_add_sky_patches(…, mf, …)`: per vertex and
/// patch the illuminance per cd/m² of the patch, lx, into `out_value` and its standard
/// error into `out_sigma` (each `count × patches` doubles, vertex by vertex, the ground's
/// first). Returns IMAP_ERR_INDEX_OUT_OF_RANGE for a vertex or mesh out of range,
/// IMAP_ERR_INVALID_ARGUMENT when the context has no such layers. (Since 0.2.3.)
///
/// # Safety
/// `ctx` is a live handle; `vertices` holds `count` indices; the outputs hold `count ×
/// patches` writable doubles each.
#[no_mangle]
pub unsafe extern "C" fn imap_annual_coefficients(
    ctx: *mut super::ImapContext,
    mesh: u32,
    side: u32,
    vertices: *const u32,
    count: usize,
    mf: u32,
    out_value: *mut f64,
    out_sigma: *mut f64,
) -> ImapStatus {
    with_context(ctx, |c| {
        let n = crate::scene::light::SkyPatches::reinhart(mf)?.count();
        let (vertices, value, sigma) =
            coefficient_args((vertices, count), n, (out_value, out_sigma))?;
        let got = crate::annual::coefficients(c, mesh, side, &vertices, mf)?;
        value.copy_from_slice(&got.value);
        sigma.copy_from_slice(&got.sigma);
        Ok(())
    })
}

/// Traces the daylight coefficients of Reinhart MF:`mf` (1: Tregenza's 145 patches, 2:
/// 577, 4: 2305, … 16; each with the ground as patch 0) at vertices `vertices[0 ..
/// count)` of mesh `mesh` (`side` 0 front, 1 back): each patch a sky of 1 cd/m² (CIE
/// D65) oriented by `zenith` and `north` (NULL: +z and +y), traced in runs of at most
/// 253 patches (one light group each; docs/daylight.md, "Reinhart's finer patches"),
/// `photons` over all runs (0: no limit) and at most `time_s` seconds (0: no limit; one of
/// the two is needed), with `estimator` (an `IMAP_ESTIMATOR_*`; `IMAP_ESTIMATOR_DEFAULT`:
/// gathering, which reaches a small sensor's coefficient of every patch). Per vertex and patch the illuminance
/// per cd/m² of the patch, lx, goes to `out_value` and its standard error to `out_sigma`
/// (each `count × patches` doubles, vertex by vertex, the ground's first), and the photons
/// traced to `out_photons` (NULL: not wanted). The context's own lights are traced too
/// and kept out of the coefficients. The context must have no photons (IMAP_ERR_OUT_OF_ORDER);
/// it is left as it was, with the per-group layers on. Returns IMAP_ERR_MEMORY_BUDGET
/// when the coefficients do not fit the budget, IMAP_ERR_INDEX_OUT_OF_RANGE for a vertex
/// or mesh out of range, IMAP_ERR_INVALID_ARGUMENT for an `mf` out of range or no limit.
/// (Since 0.2.3.)
///
/// # Safety
/// `ctx` is a live handle; `zenith` and `north` NULL or 3 doubles; `vertices` holds
/// `count` indices; the outputs hold `count × patches` writable doubles each;
/// `out_photons` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn imap_annual_trace_coefficients(
    ctx: *mut super::ImapContext,
    mf: u32,
    zenith: *const f64,
    north: *const f64,
    photons: u64,
    time_s: f64,
    estimator: u32,
    mesh: u32,
    side: u32,
    vertices: *const u32,
    count: usize,
    out_value: *mut f64,
    out_sigma: *mut f64,
    out_photons: *mut u64,
) -> ImapStatus {
    with_context(ctx, |c| {
        use crate::annual::trace::{PatchRound, PatchRun, PatchTarget};
        let n = crate::scene::light::SkyPatches::reinhart(mf)?.count();
        use crate::transport::direct::Estimator;
        let estimator = match estimator {
            super::run::IMAP_ESTIMATOR_DEFAULT | super::run::IMAP_ESTIMATOR_GATHER => {
                Estimator::GATHER
            }
            super::run::IMAP_ESTIMATOR_PHOTONS => Estimator::Photons,
            super::run::IMAP_ESTIMATOR_LIGHT_SAMPLING => Estimator::DEFAULT,
            e => bail!(
                ImapErrInvalidArgument,
                "estimator = {e} is not an IMAP_ESTIMATOR_* value"
            ),
        };
        if !(time_s.is_finite() && time_s >= 0.0) {
            bail!(
                ImapErrInvalidArgument,
                "time_s = {time_s}: give seconds ≥ 0 (0: no time limit)"
            );
        }
        let frame = (
            vec3("zenith", zenith, [0.0, 0.0, 1.0])?,
            vec3("north", north, [0.0, 1.0, 0.0])?,
        );
        let (vertices, value, sigma) =
            coefficient_args((vertices, count), n, (out_value, out_sigma))?;
        let all = c.vertex_count(mesh)?;
        if let Some(i) = vertices.iter().position(|&v| v >= all) {
            bail!(
                ImapErrIndexOutOfRange,
                "vertices[{i}] = {}: mesh {mesh} has {all} vertices",
                vertices[i]
            );
        }
        let target = PatchTarget {
            mesh,
            side,
            vertices,
        };
        let round = PatchRound {
            photons,
            time_s,
            estimator: Some(estimator),
        };
        if photons == 0 && time_s == 0.0 {
            bail!(
                ImapErrInvalidArgument,
                "photons = 0 and time_s = 0: give a photon count or seconds"
            );
        }
        let mut run = PatchRun::new(c, mf, frame, vec![target], 0)?;
        // The context is given back whether the round went through or not.
        let traced = run.trace(c, round, &mut |_| true);
        let got = run.release(c);
        let report = traced?;
        let got = got?;
        value.copy_from_slice(&got[0].value);
        sigma.copy_from_slice(&got[0].sigma);
        super::write_optional(out_photons, report.photons)
    })
}

/// The coefficient calls' point list and output arrays: `count` vertex indices, and
/// `count` × `patches` doubles for the values and for the errors (read as `slice` and
/// `slice_mut` read them).
fn coefficient_args<'a>(
    (vertices, count): (*const u32, usize),
    patches: usize,
    (out_value, out_sigma): (*mut f64, *mut f64),
) -> Result<(Vec<usize>, &'a mut [f64], &'a mut [f64])> {
    let vertices: Vec<usize> = slice("vertices", vertices, count)?
        .iter()
        .map(|&v| v as usize)
        .collect();
    let total = count.checked_mul(patches).ok_or_else(|| {
        Error::new(
            ImapStatus::ImapErrInvalidArgument,
            "count × patches overflows",
        )
    })?;
    let value = slice_mut("out_value", out_value, total)?;
    let sigma = slice_mut("out_sigma", out_sigma, total)?;
    Ok((vertices, value, sigma))
}

/// A 3-vector argument (NULL: `default`).
fn vec3(name: &str, p: *const f64, default: [f64; 3]) -> Result<[f64; 3]> {
    if p.is_null() {
        return Ok(default);
    }
    super::scene::vec3(name, p)
}

/// Traces the sun's lines of every hour of `sky` from `points` (`count` × 3 doubles, scene
/// units) whose measuring sides face `normals`, in the context's scene (its sky oriented by
/// `zenith` and `north`, NULL: +z and +y, as `imap_add_sky_patches` was), and each patch's
/// direct-only coefficient (the sun's patches; lines jittered by `seed`); the sun's
/// spectrum CIE D65. The result goes to `*out`, to free with `imap_direct_sun_free`.
/// (Since 0.2.3.)
///
/// # Safety
/// `ctx` is a live handle; `sky` a live sky; `points` and `normals` hold `3 × count`
/// doubles; `zenith`, `north` NULL or 3 doubles; `out` writable.
#[no_mangle]
pub unsafe extern "C" fn imap_direct_sun_new(
    ctx: *mut super::ImapContext,
    sky: *const ImapAnnualSky,
    points: *const f64,
    normals: *const f64,
    count: usize,
    zenith: *const f64,
    north: *const f64,
    seed: u64,
    out: *mut *mut ImapDirectSun,
) -> ImapStatus {
    with_context(ctx, |c| {
        super::check_out("out", out)?;
        let s = lookup("sky", sky)?;
        let p = slice("points", points, count.saturating_mul(3))?;
        let nm = slice("normals", normals, count.saturating_mul(3))?;
        let p: Vec<[f64; 3]> = p.chunks(3).map(|x| [x[0], x[1], x[2]]).collect();
        let nm: Vec<[f64; 3]> = nm.chunks(3).map(|x| [x[0], x[1], x[2]]).collect();
        let frame = (
            vec3("zenith", zenith, [0.0, 0.0, 1.0])?,
            vec3("north", north, [0.0, 1.0, 0.0])?,
        );
        let sun = DirectSun::new(
            c,
            &s.sky,
            frame,
            (&p, &nm),
            &crate::photometry::Spectrum::CieD65,
            seed,
        )?;
        write_out("out", out, register(ImapDirectSun { sun }))
    })
}

/// Frees a direct sun (NULL: nothing). (Since 0.2.3.)
///
/// # Safety
/// `sun` is NULL or came from `imap_direct_sun_new`.
#[no_mangle]
pub unsafe extern "C" fn imap_direct_sun_free(sun: *mut ImapDirectSun) -> ImapStatus {
    boundary(None, || free("sun", sun))
}

/// The sun's direct illuminance, lx, at every point in hour `hour` of its sky into
/// `out[0 .. count)` (`count` = the points). (Since 0.2.3.)
///
/// # Safety
/// `sun` is a live direct sun; `out` holds `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_direct_sun_hour(
    sun: *const ImapDirectSun,
    hour: usize,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    boundary(None, || {
        let s = lookup("sun", sun)?;
        if count != s.sun.sensors {
            bail!(
                ImapErrInvalidArgument,
                "count = {count}: the direct sun is of {} points",
                s.sun.sensors
            );
        }
        let out = slice_mut("out", out, count)?;
        for (k, o) in out.iter_mut().enumerate() {
            *o = s.sun.lux_at(k, hour);
        }
        Ok(())
    })
}

/// The caller's coefficients as a view (checked by the functions that take them).
fn view<'a>(
    value: *const f64,
    sigma: *const f64,
    sensors: usize,
    patches: usize,
) -> Result<CoefficientsView<'a>> {
    let total = sensors.checked_mul(patches).ok_or_else(|| {
        Error::new(
            ImapStatus::ImapErrInvalidArgument,
            "sensors × patches overflows",
        )
    })?;
    Ok(CoefficientsView {
        sensors,
        patches,
        value: slice("value", value, total)?,
        sigma: slice("sigma", sigma, total)?,
    })
}

/// The illuminance at `sensors` sensors in hours `first_hour .. first_hour + hours` of
/// `sky`, lx, with its standard error: coefficients `value` and `sigma` (`sensors ×
/// patches`, from `imap_annual_coefficients`), the sun by `sun` (NULL: none) into
/// `out_value` and `out_sigma` (`hours × sensors` each, hour by hour): a year streamed a
/// part at a time. (Since 0.2.3.)
///
/// # Safety
/// `sky` is a live sky, `sun` NULL or a live direct sun of `sensors` points; `value` and
/// `sigma` hold `sensors × patches` doubles; the outputs `hours × sensors`.
#[no_mangle]
pub unsafe extern "C" fn imap_annual_hourly(
    sky: *const ImapAnnualSky,
    value: *const f64,
    sigma: *const f64,
    sensors: usize,
    sun: *const ImapDirectSun,
    first_hour: usize,
    hours: usize,
    out_value: *mut f64,
    out_sigma: *mut f64,
) -> ImapStatus {
    boundary(None, || {
        let s = lookup("sky", sky)?;
        let c = view(value, sigma, sensors, s.sky.patches.count())?;
        let d = (!sun.is_null()).then(|| lookup("sun", sun)).transpose()?;
        let shading = crate::annual::Shading::blinds(c, d.as_ref().map(|d| &d.sun), None);
        let o = MetricOptions::default();
        write_hours(
            &s.sky,
            &shading,
            &o,
            (first_hour, hours, sensors),
            (out_value, out_sigma),
        )
    })
}

/// Hours `first_hour .. first_hour + hours` of `sensors` sensors lit as `shading`, into
/// `out_value` and `out_sigma` (`hours × sensors` each).
fn write_hours(
    sky: &AnnualSky,
    shading: &Shading,
    o: &MetricOptions,
    (first_hour, hours, sensors): (usize, usize, usize),
    (out_value, out_sigma): (*mut f64, *mut f64),
) -> Result<()> {
    let end = first_hour.checked_add(hours).ok_or_else(|| {
        Error::new(
            ImapStatus::ImapErrInvalidArgument,
            "first_hour + hours overflows",
        )
    })?;
    let total = hours.saturating_mul(sensors);
    let ov = slice_mut("out_value", out_value, total)?;
    let os = slice_mut("out_sigma", out_sigma, total)?;
    let (e, sd) = crate::annual::hourly_with_shading(shading, sky, o, first_hour..end)?;
    ov.copy_from_slice(&e);
    os.copy_from_slice(&sd);
    Ok(())
}

/// What the annual metrics count (`imap_annual_metrics`). Initialise with
/// `imap_annual_options_default(&o, sizeof o)`: LM-83's 300 lx and 50 %, UDI 100–3000 lx,
/// 100 draws, ASE 1000 lx over 250 hours, the blinds rule's 2 %, every hour with the sun up
/// occupied, EN 17037's daylight hours the brightest half. (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapAnnualOptions {
    pub struct_size: u32,
    /// Draws of the coefficients for the confidence (0: none).
    pub draws: u32,
    pub seed: u64,
    /// DA's and sDA's threshold, lx, and the share of occupied hours sDA asks.
    pub threshold_lx: f64,
    pub sda_share: f64,
    /// UDI's bands, lx.
    pub udi_low: f64,
    pub udi_high: f64,
    /// ASE's direct-sun illuminance, lx, and the hours a point must exceed it in.
    pub ase_lx: f64,
    pub ase_hours: u64,
    /// LM-83's blinds rule: the share of points with direct sun above `ase_lx` above
    /// which the blinds close (with `shaded_value`).
    pub blinds_share: f64,
    /// Per hour of the sky, nonzero when occupied (NULL: the hours with the sun up), and
    /// its length (the sky's hours).
    pub occupied: *const u8,
    pub occupied_count: usize,
    /// Per hour, nonzero for EN 17037's daylight hours (NULL: the brightest half).
    pub daylight_hours: *const u8,
    pub daylight_count: usize,
    /// The blinds-closed model's coefficients (`sensors × patches` each) and direct sun
    /// (NULL: none); NULL values: no blinds.
    pub shaded_value: *const f64,
    pub shaded_sigma: *const f64,
    pub shaded_sun: *const ImapDirectSun,
    /// Window groups, each with its states and the rule that picks one every hour:
    /// `window_group_count` pointers to initialised `ImapWindowGroup`s (NULL: none). With
    /// them the call's `value`, `sigma` and `sun` are the base, the light that comes in
    /// through no group (the model with every group's openings black; NULL `value`: no
    /// such light), an hour's light is the base's and each group's in its state, and
    /// `shaded_value` must be NULL (a blinds-closed model is one group of two states).
    /// (Appended in 0.2.3: a struct_size up to `shaded_sun` reads none.)
    pub window_groups: *const *const ImapWindowGroup,
    pub window_group_count: usize,
}

// SAFETY: repr(C), u32 struct_size first, numbers and pointers (NULL when zeroed).
unsafe impl Versioned for ImapAnnualOptions {
    const NAME: &'static str = "ImapAnnualOptions";
    const INIT: &'static str = "imap_annual_options_default";
    const BASE_SIZE: usize = std::mem::offset_of!(ImapAnnualOptions, window_groups);
    fn defaults() -> Self {
        let d = MetricOptions::default();
        ImapAnnualOptions {
            struct_size: std::mem::size_of::<Self>() as u32,
            draws: d.draws as u32,
            seed: d.seed,
            threshold_lx: d.threshold_lx,
            sda_share: d.sda_share,
            udi_low: d.udi_low,
            udi_high: d.udi_high,
            ase_lx: d.ase_lx,
            ase_hours: d.ase_hours as u64,
            blinds_share: d.blinds_share,
            occupied: std::ptr::null(),
            occupied_count: 0,
            daylight_hours: std::ptr::null(),
            daylight_count: 0,
            shaded_value: std::ptr::null(),
            shaded_sigma: std::ptr::null(),
            shaded_sun: std::ptr::null(),
            window_groups: std::ptr::null(),
            window_group_count: 0,
        }
    }
}

/// Writes the default `ImapAnnualOptions` into `out` (`size` = sizeof *out). (Since 0.2.3.)
///
/// # Safety
/// `out` points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_annual_options_default(
    out: *mut ImapAnnualOptions,
    size: usize,
) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// `ImapWindowGroup::rule`: IES LM-83's rule for operable blinds, per group: the first
/// state (from 0, the most open) in which no more than `blinds_share` of the sensors get
/// direct sun above `ase_lx` through the group, the last when none is (two states: closed
/// when the open group lets direct sun above 1000 lx onto more than 2 % of them). State
/// 0 needs its direct sun. (Since 0.2.3.)
pub const IMAP_SHADING_DIRECT_SUN: u32 = 0;
/// `ImapWindowGroup::rule`: the first state in which no more than `blinds_share` of the
/// sensors get more than `rule_lx` from the group (its coefficients under the hour's sky
/// and its direct sun, as estimated), the last when none is. (Since 0.2.3.)
pub const IMAP_SHADING_ILLUMINANCE: u32 = 1;
/// `ImapWindowGroup::rule`: the state of every hour given in `schedule`. (Since 0.2.3.)
pub const IMAP_SHADING_SCHEDULE: u32 = 2;
/// `ImapWindowGroup::rule`: the first state in which no more than `blinds_share` of the
/// sensors (observers' sensors, each facing its view) have a simplified DGP above
/// `rule_dgp`, with the group in the state, the base and every other group in its state 0;
/// the last when none is (`imap_annual_glare`). (Since 0.2.3.)
pub const IMAP_SHADING_GLARE: u32 = 3;

/// A window group of `ImapAnnualOptions::window_groups`: its states' coefficients at the
/// call's sensors (each traced with the group's openings in that state and every other
/// group's black), their direct sun, and the rule that picks a state every hour. States
/// are ordered from the most open (state 0: ASE counts it) to the most closed. Initialise
/// with `imap_window_group_default(&g, sizeof g)`. (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapWindowGroup {
    pub struct_size: u32,
    /// IMAP_SHADING_*.
    pub rule: u32,
    /// The states, 1 to 65535.
    pub state_count: usize,
    /// `state_count` pointers, each to `sensors × patches` doubles: the state's
    /// coefficients and their standard errors.
    pub value: *const *const f64,
    pub sigma: *const *const f64,
    /// `state_count` direct suns (`imap_direct_sun_new` in the state's model; a NULL
    /// entry: the state lets no sun through in a line); NULL: no state has one.
    pub sun: *const *const ImapDirectSun,
    /// IMAP_SHADING_ILLUMINANCE's illuminance, lx.
    pub rule_lx: f64,
    /// IMAP_SHADING_SCHEDULE's state of every hour of the sky, and its length (the sky's
    /// hours).
    pub schedule: *const u16,
    pub schedule_count: usize,
    /// Written on success when not NULL: `state_count` counts of the occupied hours the
    /// group spent in each state.
    pub state_hours: *mut u64,
    /// IMAP_SHADING_GLARE's simplified DGP, above 0.184 and at most 1 (default 0.40).
    /// (Appended in 0.2.3's glare round: a caller built before it passes the shorter
    /// struct_size and gets the default.)
    pub rule_dgp: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers and pointers (NULL when zeroed).
unsafe impl Versioned for ImapWindowGroup {
    const NAME: &'static str = "ImapWindowGroup";
    const INIT: &'static str = "imap_window_group_default";
    const BASE_SIZE: usize = std::mem::offset_of!(ImapWindowGroup, rule_dgp);
    fn defaults() -> Self {
        ImapWindowGroup {
            struct_size: std::mem::size_of::<Self>() as u32,
            rule: IMAP_SHADING_DIRECT_SUN,
            state_count: 0,
            value: std::ptr::null(),
            sigma: std::ptr::null(),
            sun: std::ptr::null(),
            rule_lx: 0.0,
            schedule: std::ptr::null(),
            schedule_count: 0,
            state_hours: std::ptr::null_mut(),
            rule_dgp: 0.40,
        }
    }
}

/// Writes the default `ImapWindowGroup` into `out` (`size` = sizeof *out): LM-83's rule,
/// no states. (Since 0.2.3.)
///
/// # Safety
/// `out` points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_window_group_default(
    out: *mut ImapWindowGroup,
    size: usize,
) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// A grid's annual metrics (`imap_annual_metrics`). (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapAnnualMetrics {
    pub struct_size: u32,
    /// EN 17037's highest level met: 0 minimum, 1 medium, 2 high; −1 none met.
    pub en17037_level: i32,
    pub occupied_hours: u64,
    pub daylight_hours: u64,
    pub blinds_closed_hours: u64,
    /// sDA, its standard deviation over the draws and its 95 % interval (NaN without
    /// draws).
    pub sda: f64,
    pub sda_sigma: f64,
    pub sda_low: f64,
    pub sda_high: f64,
    /// ASE (NaN without the direct sun).
    pub ase: f64,
    /// Per EN 17037 level (minimum, medium, high): the shares of daylight hours in which
    /// E_T reaches half the points and E_TM 95 % of them, and the probability the level
    /// is met.
    pub en17037_target_share: [f64; 3],
    pub en17037_minimum_share: [f64; 3],
    pub en17037_pass_probability: [f64; 3],
    /// UDI's three bands (below, useful, above) as the grid's mean share of occupied
    /// hours, their standard deviations over the draws and their 95 % intervals (NaN
    /// without draws). (Appended in 0.2.3: a struct_size up to `en17037_pass_probability`
    /// is read without them.)
    pub udi: [f64; 3],
    pub udi_sigma: [f64; 3],
    pub udi_interval_low: [f64; 3],
    pub udi_interval_high: [f64; 3],
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapAnnualMetrics {
    const NAME: &'static str = "ImapAnnualMetrics";
    const INIT: &'static str = "sizeof(ImapAnnualMetrics)";
    const BASE_SIZE: usize = std::mem::offset_of!(ImapAnnualMetrics, udi);
    fn defaults() -> Self {
        ImapAnnualMetrics {
            struct_size: std::mem::size_of::<Self>() as u32,
            en17037_level: -1,
            occupied_hours: 0,
            daylight_hours: 0,
            blinds_closed_hours: 0,
            sda: 0.0,
            sda_sigma: f64::NAN,
            sda_low: f64::NAN,
            sda_high: f64::NAN,
            ase: f64::NAN,
            en17037_target_share: [0.0; 3],
            en17037_minimum_share: [0.0; 3],
            en17037_pass_probability: [0.0; 3],
            udi: [0.0; 3],
            udi_sigma: [f64::NAN; 3],
            udi_interval_low: [f64::NAN; 3],
            udi_interval_high: [f64::NAN; 3],
        }
    }
}

/// One sensor's annual metrics (`imap_annual_metrics`), shares of the occupied hours.
/// (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapSensorMetrics {
    pub struct_size: u32,
    pub reserved: u32,
    pub ase_hours: u64,
    pub da: f64,
    pub cda: f64,
    pub udi_below: f64,
    pub udi_useful: f64,
    pub udi_above: f64,
    /// The probability that its DA reaches the sDA share.
    pub sda_pass_probability: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapSensorMetrics {
    const NAME: &'static str = "ImapSensorMetrics";
    const INIT: &'static str = "sizeof(ImapSensorMetrics)";
    fn defaults() -> Self {
        ImapSensorMetrics {
            struct_size: std::mem::size_of::<Self>() as u32,
            reserved: 0,
            ase_hours: 0,
            da: 0.0,
            cda: 0.0,
            udi_below: 0.0,
            udi_useful: 0.0,
            udi_above: 0.0,
            sda_pass_probability: 0.0,
        }
    }
}

/// A part of a grid's light: coefficients and the direct sun.
type Part<'a> = (CoefficientsView<'a>, Option<Arc<ImapDirectSun>>);

/// A window group as read: its states, its rule and where its state hours go.
struct Group<'a> {
    states: Vec<Part<'a>>,
    rule: ShadingRule,
    state_hours: *mut u64,
}

/// The arguments every annual metric call reads: the sky, the coefficients, the direct sun
/// and the options with the blinds-closed model or the window groups, looked up and
/// checked.
struct Annual<'a> {
    sky: Arc<ImapAnnualSky>,
    base: Option<Part<'a>>,
    groups: Vec<Group<'a>>,
    options: MetricOptions,
}

impl Annual<'_> {
    /// Reads `imap_annual_metrics`'s arguments of the same names.
    fn read(
        sky: *const ImapAnnualSky,
        value: *const f64,
        sigma: *const f64,
        sensors: usize,
        sun: *const ImapDirectSun,
        options: *const ImapAnnualOptions,
    ) -> Result<Self> {
        let s = lookup("sky", sky)?;
        let patches = s.sky.patches.count();
        let sun = (!sun.is_null()).then(|| lookup("sun", sun)).transpose()?;
        let o = if options.is_null() {
            ImapAnnualOptions::defaults()
        } else {
            read_versioned("options", options)?
        };
        let hours = s.sky.hours.len();
        let mo = MetricOptions {
            occupied: flags("occupied", o.occupied, o.occupied_count, hours)?,
            threshold_lx: o.threshold_lx,
            sda_share: o.sda_share,
            udi_low: o.udi_low,
            udi_high: o.udi_high,
            draws: o.draws as usize,
            seed: o.seed,
            ase_lx: o.ase_lx,
            ase_hours: usize::try_from(o.ase_hours).unwrap_or(usize::MAX),
            daylight_hours: flags("daylight_hours", o.daylight_hours, o.daylight_count, hours)?,
            blinds_share: o.blinds_share,
        };
        let shaded_sun = (!o.shaded_sun.is_null())
            .then(|| lookup("options->shaded_sun", o.shaded_sun))
            .transpose()?;
        let groups = if o.window_groups.is_null() {
            Vec::new()
        } else {
            let list = slice(
                "options->window_groups",
                o.window_groups,
                o.window_group_count,
            )?;
            let mut groups = Vec::with_capacity(list.len());
            for (g, &p) in list.iter().enumerate() {
                let name = format!("options->window_groups[{g}]");
                groups.push(read_group(&name, p, sensors, patches)?);
            }
            groups
        };
        if !groups.is_empty() && !o.shaded_value.is_null() {
            bail!(
                ImapErrInvalidArgument,
                "options->shaded_value and options->window_groups: give one (a blinds-closed model is a window group of two states)"
            );
        }
        // With window groups, NULL coefficients are a base of no light.
        let base = if groups.is_empty() || !value.is_null() {
            Some((view(value, sigma, sensors, patches)?, sun))
        } else if sun.is_some() {
            bail!(
                ImapErrInvalidArgument,
                "sun is the base's direct sun, and value is NULL (no base): pass NULL for both, or the base's coefficients"
            );
        } else {
            None
        };
        let (base, groups) = if o.shaded_value.is_null() {
            (base, groups)
        } else {
            let shaded = (
                view(o.shaded_value, o.shaded_sigma, sensors, patches)?,
                shaded_sun,
            );
            let open = base.expect("the base is read without window groups");
            let blinds = Group {
                states: vec![open, shaded],
                rule: ShadingRule::DirectSun,
                state_hours: std::ptr::null_mut(),
            };
            (None, vec![blinds])
        };
        Ok(Annual {
            sky: s,
            base,
            groups,
            options: mo,
        })
    }

    /// The parts as the metrics take them.
    fn shading(&self) -> Shading<'_> {
        fn part<'b>((c, s): &'b Part) -> Shaded<'b> {
            Shaded {
                coefficients: *c,
                sun: s.as_ref().map(|x| &x.sun),
            }
        }
        Shading {
            base: self.base.as_ref().map(part),
            groups: self
                .groups
                .iter()
                .map(|g| WindowGroup {
                    states: g.states.iter().map(part).collect(),
                    rule: g.rule.clone(),
                })
                .collect(),
        }
    }

    /// Writes each group's hours per state where the host asked for them.
    fn write_state_hours(&self, hours: &[Vec<usize>]) -> Result<()> {
        for (g, h) in self.groups.iter().zip(hours) {
            if !g.state_hours.is_null() {
                let out = slice_mut("state_hours", g.state_hours, h.len())?;
                for (o, &x) in out.iter_mut().zip(h) {
                    *o = x as u64;
                }
            }
        }
        Ok(())
    }
}

/// Reads window group `name` at `p` of coefficients of `sensors` × `patches`.
fn read_group<'a>(
    name: &str,
    p: *const ImapWindowGroup,
    sensors: usize,
    patches: usize,
) -> Result<Group<'a>> {
    let w = read_versioned(name, p)?;
    if w.state_count == 0 || w.state_count > u16::MAX as usize {
        bail!(
            ImapErrInvalidArgument,
            "{name}->state_count = {}: give 1 to {}",
            w.state_count,
            u16::MAX
        );
    }
    let values = slice(&format!("{name}->value"), w.value, w.state_count)?;
    let sigmas = slice(&format!("{name}->sigma"), w.sigma, w.state_count)?;
    let suns = if w.sun.is_null() {
        vec![std::ptr::null(); w.state_count]
    } else {
        slice(&format!("{name}->sun"), w.sun, w.state_count)?.to_vec()
    };
    let mut states = Vec::with_capacity(w.state_count);
    for s in 0..w.state_count {
        let c = view(values[s], sigmas[s], sensors, patches).map_err(|mut e| {
            e.message = format!("{name} state {s}: {}", e.message);
            e
        })?;
        let sun = (!suns[s].is_null())
            .then(|| lookup(&format!("{name}->sun[{s}]"), suns[s]))
            .transpose()?;
        states.push((c, sun));
    }
    let rule = match w.rule {
        IMAP_SHADING_DIRECT_SUN => ShadingRule::DirectSun,
        IMAP_SHADING_ILLUMINANCE => ShadingRule::Illuminance { lx: w.rule_lx },
        IMAP_SHADING_SCHEDULE => ShadingRule::Schedule(
            slice(&format!("{name}->schedule"), w.schedule, w.schedule_count)?.to_vec(),
        ),
        IMAP_SHADING_GLARE => ShadingRule::Glare { dgp: w.rule_dgp },
        r => bail!(
            ImapErrInvalidArgument,
            "{name}->rule = {r}: use IMAP_SHADING_DIRECT_SUN, IMAP_SHADING_ILLUMINANCE, IMAP_SHADING_SCHEDULE or IMAP_SHADING_GLARE"
        ),
    };
    Ok(Group {
        states,
        rule,
        state_hours: w.state_hours,
    })
}

/// A per-hour flag array of the options (NULL: none).
fn flags(name: &str, p: *const u8, count: usize, hours: usize) -> Result<Vec<bool>> {
    if p.is_null() {
        return Ok(Vec::new());
    }
    if count != hours {
        bail!(
            ImapErrInvalidArgument,
            "{name}_count = {count}: the sky has {hours} hours"
        );
    }
    Ok(slice(name, p, count)?.iter().map(|&x| x != 0).collect())
}

/// The annual metrics of `sensors` sensors (DA, cDA, UDI, sDA with its confidence, ASE
/// with the direct sun `sun`, EN 17037's levels, LM-83's blinds with
/// `options->shaded_value`) into `out` (`out_size` = sizeof(ImapAnnualMetrics)), and per
/// sensor into `per_sensor` (NULL: not wanted; else `sensors` elements of
/// `per_sensor_size` = sizeof(ImapSensorMetrics) bytes each). Returns
/// IMAP_ERR_INVALID_ARGUMENT or IMAP_ERR_NON_FINITE naming what is wrong (coefficients'
/// shapes or values, options out of range, no occupied hour). (Since 0.2.3.)
///
/// # Safety
/// As `imap_annual_hourly`; `options` is NULL (defaults) or initialised, its arrays as
/// documented; `out` holds `out_size` bytes; `per_sensor` NULL or `sensors ×
/// per_sensor_size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_annual_metrics(
    sky: *const ImapAnnualSky,
    value: *const f64,
    sigma: *const f64,
    sensors: usize,
    sun: *const ImapDirectSun,
    options: *const ImapAnnualOptions,
    out: *mut ImapAnnualMetrics,
    out_size: usize,
    per_sensor: *mut ImapSensorMetrics,
    per_sensor_size: usize,
) -> ImapStatus {
    boundary(None, || {
        super::check_out("out", out)?;
        let a = Annual::read(sky, value, sigma, sensors, sun, options)?;
        let m = crate::annual::metrics_with_shading(&a.shading(), &a.sky.sky, &a.options)?;
        a.write_state_hours(&m.group_state_hours)?;
        if !per_sensor.is_null() {
            if per_sensor_size < std::mem::size_of::<u32>() {
                bail!(
                    ImapErrInvalidArgument,
                    "per_sensor_size = {per_sensor_size}: pass sizeof(ImapSensorMetrics)"
                );
            }
            for (k, x) in m.sensors.iter().enumerate() {
                // SAFETY: the caller provides `sensors × per_sensor_size` bytes.
                let at = unsafe { (per_sensor as *mut u8).add(k * per_sensor_size) }
                    as *mut ImapSensorMetrics;
                write_versioned(
                    "per_sensor",
                    at,
                    per_sensor_size,
                    ImapSensorMetrics {
                        struct_size: 0,
                        reserved: 0,
                        ase_hours: x.ase_hours as u64,
                        da: x.da,
                        cda: x.cda,
                        udi_below: x.udi_below,
                        udi_useful: x.udi_useful,
                        udi_above: x.udi_above,
                        sda_pass_probability: x.sda_pass_probability,
                    },
                )?;
            }
        }
        let mut r = ImapAnnualMetrics::defaults();
        r.occupied_hours = m.occupied_hours as u64;
        r.blinds_closed_hours = m.blinds_closed_hours as u64;
        r.sda = m.sda;
        r.sda_sigma = m.sda_sigma;
        (r.sda_low, r.sda_high) = m.sda_interval;
        r.ase = m.ase.unwrap_or(f64::NAN);
        r.udi = m.udi;
        r.udi_sigma = m.udi_sigma;
        for (b, (lo, hi)) in m.udi_interval.iter().enumerate() {
            (r.udi_interval_low[b], r.udi_interval_high[b]) = (*lo, *hi);
        }
        if let Some(en) = &m.en17037 {
            r.daylight_hours = en.daylight_hours as u64;
            r.en17037_level = en
                .levels
                .iter()
                .rposition(|l| l.passes)
                .map_or(-1, |i| i as i32);
            for (i, l) in en.levels.iter().enumerate() {
                r.en17037_target_share[i] = l.target_share;
                r.en17037_minimum_share[i] = l.minimum_share;
                r.en17037_pass_probability[i] = l.pass_probability;
            }
        }
        write_versioned("out", out, out_size, r)
    })
}

/// `imap_annual_hourly` with the blinds or the window groups of `options` (NULL:
/// defaults, no shading), each in the state its rule picks every hour, as
/// `imap_annual_metrics` reads them: with `options->window_groups`, `value`, `sigma` and
/// `sun` are the base (NULL `value`: none). Returns IMAP_ERR_INVALID_ARGUMENT,
/// IMAP_ERR_INDEX_OUT_OF_RANGE or IMAP_ERR_NON_FINITE naming what is wrong. (Since 0.2.3.)
///
/// # Safety
/// As `imap_annual_metrics`; the outputs hold `hours × sensors` doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_annual_hourly_shaded(
    sky: *const ImapAnnualSky,
    value: *const f64,
    sigma: *const f64,
    sensors: usize,
    sun: *const ImapDirectSun,
    options: *const ImapAnnualOptions,
    first_hour: usize,
    hours: usize,
    out_value: *mut f64,
    out_sigma: *mut f64,
) -> ImapStatus {
    boundary(None, || {
        let a = Annual::read(sky, value, sigma, sensors, sun, options)?;
        write_hours(
            &a.sky.sky,
            &a.shading(),
            &a.options,
            (first_hour, hours, sensors),
            (out_value, out_sigma),
        )
    })
}

/// One observer's year of glare (`imap_annual_glare`), per DGP class (0.35, 0.40, 0.45:
/// perceptible, disturbing, intolerable): the occupied hours with the simplified DGP at
/// or above it, their share of the occupied hours, its standard deviation over the draws
/// and its 95 % interval (NaN without draws); the mean vertical illuminance at the eye over
/// the occupied hours and the largest hour's DGPs. (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapObserverYear {
    pub struct_size: u32,
    pub reserved: u32,
    pub occupied_hours: u64,
    pub hours_above: [u64; 3],
    pub share_above: [f64; 3],
    pub share_sigma: [f64; 3],
    pub share_low: [f64; 3],
    pub share_high: [f64; 3],
    pub mean_ev_lx: f64,
    pub max_dgps: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapObserverYear {
    const NAME: &'static str = "ImapObserverYear";
    const INIT: &'static str = "sizeof(ImapObserverYear)";
    fn defaults() -> Self {
        ImapObserverYear {
            struct_size: std::mem::size_of::<Self>() as u32,
            reserved: 0,
            occupied_hours: 0,
            hours_above: [0; 3],
            share_above: [0.0; 3],
            share_sigma: [f64::NAN; 3],
            share_low: [f64::NAN; 3],
            share_high: [f64::NAN; 3],
            mean_ev_lx: 0.0,
            max_dgps: 0.0,
        }
    }
}

/// Annual glare, imageless, at `sensors` observers' sensors (`imap_add_observer_sensor`:
/// each faces its view, so its coefficients are the vertical illuminance at the eye per
/// patch luminance; passed, with their direct sun and options, as `imap_annual_metrics`
/// takes a grid's): each occupied hour's Ev with the window groups in the states their
/// rules pick, its simplified DGP (6.22·10⁻⁵ Ev + 0.184; it does not rate the sun's disc
/// in view), and per observer the shares of the occupied hours at or above 0.35, 0.40 and
/// 0.45 with their confidence into `out`: `sensors` elements of `element_size` =
/// sizeof(ImapObserverYear) bytes each. Returns IMAP_ERR_INVALID_ARGUMENT or
/// IMAP_ERR_NON_FINITE naming what is wrong. (Since 0.2.3.)
///
/// # Safety
/// As `imap_annual_metrics`; `out` holds `sensors × element_size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_annual_glare(
    sky: *const ImapAnnualSky,
    value: *const f64,
    sigma: *const f64,
    sensors: usize,
    sun: *const ImapDirectSun,
    options: *const ImapAnnualOptions,
    out: *mut ImapObserverYear,
    element_size: usize,
) -> ImapStatus {
    boundary(None, || {
        super::check_out("out", out)?;
        super::check_elements("out", out, sensors, element_size)?;
        let a = Annual::read(sky, value, sigma, sensors, sun, options)?;
        let years = crate::annual::annual_glare(&a.shading(), &a.sky.sky, &a.options)?;
        for (k, y) in years.iter().enumerate() {
            // SAFETY: the caller provides `sensors × element_size` bytes.
            let at = unsafe { (out as *mut u8).add(k * element_size) } as *mut ImapObserverYear;
            write_versioned(
                "out",
                at,
                element_size,
                ImapObserverYear {
                    struct_size: 0,
                    reserved: 0,
                    occupied_hours: y.occupied_hours as u64,
                    hours_above: y.hours_above.map(|x| x as u64),
                    share_above: y.share_above,
                    share_sigma: y.share_sigma,
                    share_low: y.share_interval.map(|x| x.0),
                    share_high: y.share_interval.map(|x| x.1),
                    mean_ev_lx: y.mean_ev_lx,
                    max_dgps: y.max_dgps,
                },
            )?;
        }
        Ok(())
    })
}

/// Every window group's state in every hour of the sky, as the rules of `options` pick
/// them on these `sensors` (arguments as `imap_annual_metrics`), into `out`: window
/// groups × the sky's hours states, group by group (`out_count` at least that). A host decides a
/// glare rule at its observers this way and gives the grids the verdicts as
/// IMAP_SHADING_SCHEDULE. Returns IMAP_ERR_INVALID_ARGUMENT naming what is wrong, or
/// IMAP_ERR_BUFFER_TOO_SMALL. (Since 0.2.3.)
///
/// # Safety
/// As `imap_annual_metrics`; `out` holds `out_count` writable `uint16_t`.
#[no_mangle]
pub unsafe extern "C" fn imap_annual_states(
    sky: *const ImapAnnualSky,
    value: *const f64,
    sigma: *const f64,
    sensors: usize,
    sun: *const ImapDirectSun,
    options: *const ImapAnnualOptions,
    out: *mut u16,
    out_count: usize,
) -> ImapStatus {
    boundary(None, || {
        let a = Annual::read(sky, value, sigma, sensors, sun, options)?;
        let states = crate::annual::shading_states(&a.shading(), &a.sky.sky, &a.options)?;
        let need = states.len() * a.sky.sky.hours.len();
        if out_count < need {
            bail!(
                ImapErrBufferTooSmall,
                "out_count = {out_count}: {} window groups × {} hours need {need}",
                states.len(),
                a.sky.sky.hours.len()
            );
        }
        let dst = slice_mut("out", out, out_count)?;
        for (d, x) in dst.iter_mut().zip(states.iter().flatten()) {
            *d = *x;
        }
        Ok(())
    })
}

/// The lighting controls of `ImapDimming::control` (EnergyPlus's types): dims
/// continuously to `min_output` and stays on there; the same, and switches off there; in
/// `steps` equal steps of output and power, and off. (Since 0.2.3.)
pub const IMAP_LIGHTING_CONTINUOUS: u32 = 0;
/// See `IMAP_LIGHTING_CONTINUOUS`.
pub const IMAP_LIGHTING_CONTINUOUS_OFF: u32 = 1;
/// See `IMAP_LIGHTING_CONTINUOUS`.
pub const IMAP_LIGHTING_STEPPED: u32 = 2;

/// A zone's dimming control and installed power (`imap_annual_lighting`). Initialise
/// with `imap_dimming_default(&d, sizeof d)`: continuous dimming to 20 % output at 30 %
/// power (EnergyPlus's defaults), 500 lx at sensor 0, 0 W. (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapDimming {
    pub struct_size: u32,
    /// IMAP_LIGHTING_*.
    pub control: u32,
    /// IMAP_LIGHTING_STEPPED's steps (1–1000).
    pub steps: u32,
    pub reserved: u32,
    /// The photosensor: the index of the sensor whose daylight the control reads.
    pub sensor: u64,
    /// The illuminance the control keeps at its photosensor, lx.
    pub target_lx: f64,
    /// The continuous controls' lowest light output fraction (below 1), and the power
    /// fraction drawn there.
    pub min_output: f64,
    pub min_power: f64,
    /// The zone's installed lighting power at full output, W.
    pub power_w: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapDimming {
    const NAME: &'static str = "ImapDimming";
    const INIT: &'static str = "imap_dimming_default";
    fn defaults() -> Self {
        ImapDimming {
            struct_size: std::mem::size_of::<Self>() as u32,
            control: IMAP_LIGHTING_CONTINUOUS,
            steps: 1,
            reserved: 0,
            sensor: 0,
            target_lx: 500.0,
            min_output: 0.2,
            min_power: 0.3,
            power_w: 0.0,
        }
    }
}

/// Writes the default `ImapDimming` into `out` (`size` = sizeof *out). (Since 0.2.3.)
///
/// # Safety
/// `out` points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_dimming_default(out: *mut ImapDimming, size: usize) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// A zone's annual electric lighting (`imap_annual_lighting`). (Since 0.2.3.)
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapLighting {
    pub struct_size: u32,
    pub reserved: u32,
    pub occupied_hours: u64,
    /// Occupied hours with the lights off, and at full output.
    pub hours_off: u64,
    pub hours_full: u64,
    /// The weather's time step, hours.
    pub step_hours: f64,
    /// The energy with the daylight control, kWh, its standard deviation over the draws
    /// and its 95 % interval (NaN without draws).
    pub energy_kwh: f64,
    pub energy_sigma: f64,
    pub energy_low: f64,
    pub energy_high: f64,
    /// The energy at full output every occupied hour, kWh.
    pub full_kwh: f64,
    /// The mean light output fraction over the occupied hours.
    pub mean_output: f64,
}

// SAFETY: repr(C), u32 struct_size first, numbers only.
unsafe impl Versioned for ImapLighting {
    const NAME: &'static str = "ImapLighting";
    const INIT: &'static str = "sizeof(ImapLighting)";
    fn defaults() -> Self {
        ImapLighting {
            struct_size: std::mem::size_of::<Self>() as u32,
            reserved: 0,
            occupied_hours: 0,
            hours_off: 0,
            hours_full: 0,
            step_hours: 1.0,
            energy_kwh: 0.0,
            energy_sigma: f64::NAN,
            energy_low: f64::NAN,
            energy_high: f64::NAN,
            full_kwh: 0.0,
            mean_output: 0.0,
        }
    }
}

/// Electric light with daylight: a zone of `sensors` sensors (their daylight
/// coefficients, direct sun and options as `imap_annual_metrics` takes them, the blinds
/// included), its luminaires' illuminance at full output at each sensor (`electric`, lx,
/// and its standard error `electric_sigma`, `sensors` each: a run of the model's own
/// lights), dimmed by `dimming` at its photosensor in the occupied hours. The annual
/// energy with its confidence into `out` (`out_size` = sizeof(ImapLighting)), and per
/// sensor the share of occupied hours in which daylight and the dimmed light reach the
/// target into `at_target` (NULL: not wanted; else `sensors` doubles). Returns
/// IMAP_ERR_INVALID_ARGUMENT, IMAP_ERR_INDEX_OUT_OF_RANGE (the photosensor) or
/// IMAP_ERR_NON_FINITE naming what is wrong. (Since 0.2.3.)
///
/// # Safety
/// As `imap_annual_metrics`; `electric` and `electric_sigma` hold `sensors` doubles;
/// `dimming` is initialised; `out` holds `out_size` bytes; `at_target` NULL or `sensors`
/// writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_annual_lighting(
    sky: *const ImapAnnualSky,
    value: *const f64,
    sigma: *const f64,
    sensors: usize,
    sun: *const ImapDirectSun,
    options: *const ImapAnnualOptions,
    electric: *const f64,
    electric_sigma: *const f64,
    dimming: *const ImapDimming,
    out: *mut ImapLighting,
    out_size: usize,
    at_target: *mut f64,
) -> ImapStatus {
    boundary(None, || {
        super::check_out("out", out)?;
        let a = Annual::read(sky, value, sigma, sensors, sun, options)?;
        let el: Vec<(f64, f64)> = slice("electric", electric, sensors)?
            .iter()
            .zip(slice("electric_sigma", electric_sigma, sensors)?)
            .map(|(&x, &s)| (x, s))
            .collect();
        let d = read_versioned("dimming", dimming)?;
        let control = match d.control {
            IMAP_LIGHTING_CONTINUOUS => Control::Continuous,
            IMAP_LIGHTING_CONTINUOUS_OFF => Control::ContinuousOff,
            IMAP_LIGHTING_STEPPED => Control::Stepped(d.steps),
            other => bail!(
                ImapErrInvalidArgument,
                "dimming->control = {other}: use IMAP_LIGHTING_CONTINUOUS, IMAP_LIGHTING_CONTINUOUS_OFF or IMAP_LIGHTING_STEPPED"
            ),
        };
        let zone = Dimming {
            target_lx: d.target_lx,
            sensor: usize::try_from(d.sensor).unwrap_or(usize::MAX),
            control,
            min_output: d.min_output,
            min_power: d.min_power,
            power_w: d.power_w,
        };
        let at = if at_target.is_null() {
            None
        } else {
            Some(slice_mut("at_target", at_target, sensors)?)
        };
        let l = crate::annual::lighting::lighting_with_shading(
            &a.shading(),
            &a.sky.sky,
            &el,
            &zone,
            &a.options,
        )?;
        if let Some(at) = at {
            at.copy_from_slice(&l.at_target);
        }
        let mut r = ImapLighting::defaults();
        r.occupied_hours = l.occupied_hours as u64;
        r.hours_off = l.hours_off as u64;
        r.hours_full = l.hours_full as u64;
        r.step_hours = l.step_hours;
        r.energy_kwh = l.energy_kwh;
        r.energy_sigma = l.energy_sigma;
        (r.energy_low, r.energy_high) = l.energy_interval;
        r.full_kwh = l.full_kwh;
        r.mean_output = l.mean_output;
        write_versioned("out", out, out_size, r)
    })
}

/// The daylight factor (0–1) at `sensors` sensors and its standard error, from their
/// coefficients over MF:`mf`'s patches (`sensors × patches` each): the CIE standard
/// overcast sky with the ground glowing ρ E_h / π, ρ = `ground_reflectance`, into
/// `out_df[0 .. sensors)` and `out_sigma`. (Since 0.2.3.)
///
/// # Safety
/// `value` and `sigma` hold `sensors × patches` doubles; the outputs `sensors` each.
#[no_mangle]
pub unsafe extern "C" fn imap_daylight_factor(
    value: *const f64,
    sigma: *const f64,
    sensors: usize,
    mf: u32,
    ground_reflectance: f64,
    out_df: *mut f64,
    out_sigma: *mut f64,
) -> ImapStatus {
    boundary(None, || {
        let patches = crate::scene::light::SkyPatches::reinhart(mf)?;
        let c = view(value, sigma, sensors, patches.count())?;
        let od = slice_mut("out_df", out_df, sensors)?;
        let os = slice_mut("out_sigma", out_sigma, sensors)?;
        let df = crate::annual::daylight_factor(c, &patches, ground_reflectance)?;
        for ((d, s), x) in od.iter_mut().zip(os.iter_mut()).zip(df) {
            *d = x.0;
            *s = x.1;
        }
        Ok(())
    })
}

//! The camera renderer: camera, render parameters, report and history.

use super::run::{
    callback, check_report_out, copy_history, stop_to_c, ImapProgress, ImapProgressFn,
};
use super::{
    boundary, read_versioned, slice_mut, with_context, write_defaults, write_versioned,
    ImapContext, Versioned,
};
use crate::error::{bail, ImapStatus};
use crate::render::{CameraDesc, RenderMethod, RenderParams, RenderReport};
use std::ffi::c_void;

/// `ImapRenderParams::method`: all threads share one set of backward photon maps, phase
/// by phase (paper §2.2, synchronous).
pub const IMAP_RENDER_SYNC: u32 = 0;
/// Each thread renders the whole image with private maps and pixel store; the stores are
/// merged at the end (memory grows with the thread count).
pub const IMAP_RENDER_ASYNC: u32 = 1;
/// Two-level semi-synchronous method (paper §2.3, the default): groups of
/// `group_threads` threads, each with its own random mask of 32×32-pixel tiles and its own
/// maps, and lock-free access to the other groups' maps through their active-thread
/// counters.
pub const IMAP_RENDER_SEMI_SYNC: u32 = 2;
/// Final gathering from the illumination map (Since 0.2.2): path-traced eye paths that end
/// at their second diffuse vertex on a recorded mesh and read the context's map there (its
/// whole irradiance; with the direct layer kept, its indirect part, and the direct light is
/// sampled there); where that vertex lies within 0.75 of its triangle's size of the one
/// before (a corner, where the map's interpolation would read high), at the next that
/// does not, the fourth at the latest. No
/// photon-map radius, so no blur and no gathering bias at edges and corners; each pixel's
/// error includes the map's. Emitting meshes seen directly (every render method) are taken
/// at their exact share of each pixel on their outline where nothing stands in front. **The render extends the context's map** (it runs it
/// in slices between passes, starting it when empty), so the map is there to read
/// afterwards; a map holding a shard's or a range's photons (not 0..N) is read as it is.
/// `forward_per_pass` > 0: before pass k the map holds at least (k + 1) ×
/// forward_per_pass photons, and the image is the same for a seed on any thread count
/// (up to rounding); 0: the map's time is balanced against the eye paths' by their
/// measured errors. `group_threads`, `remask_phases`, `initial_radius` and `alpha` are not
/// used. Surfaces that do not record are path traced on. Caustics of point-like lights
/// seen directly (light → specular surfaces → diffuse → camera) come from photons traced
/// through the specular surfaces and connected to the camera (scenes with such lights and
/// specular surfaces only); seen through a specular surface, or after a surface that is
/// both diffuse and specular, they are missing.
pub const IMAP_RENDER_FINAL_GATHER: u32 = 3;

/// A camera, pinhole or fisheye (`projection`), in scene units. Pixel rows run from the
/// top of the image down.
/// Initialise with `imap_camera_default(&c, sizeof c)`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct ImapCamera {
    /// `sizeof(ImapCamera)` as the program was compiled; set by `imap_camera_default`.
    pub struct_size: u32,
    /// Image size in pixels, each side in 1..=16384.
    pub width: u32,
    pub height: u32,
    /// Eye point.
    pub position: [f64; 3],
    /// Viewing direction (any non-zero finite length).
    pub direction: [f64; 3],
    /// Up vector; only its part across `direction` counts, and it must not be parallel.
    pub up: [f64; 3],
    /// Full vertical field of view, degrees: in (0, 180) for `IMAP_PROJECTION_PERSPECTIVE`,
    /// (0, 360] for `IMAP_PROJECTION_ANGULAR_FISHEYE`, (0, 180] for
    /// `IMAP_PROJECTION_HEMISPHERICAL`.
    pub fov_y_deg: f64,
    /// `IMAP_PROJECTION_*` (0: perspective, what programs built before it get). A fisheye
    /// image's pixels that see nothing (outside a hemispherical image's circle, beyond 180°
    /// of an angular one's axis) are black with no error.
    pub projection: u32,
}

/// `ImapCamera::projection`: a pinhole camera.
pub const IMAP_PROJECTION_PERSPECTIVE: u32 = 0;
/// `ImapCamera::projection`: an angular (equidistant) fisheye, Radiance's `-vta`; the
/// distance from the image centre is proportional to the angle off the viewing direction.
pub const IMAP_PROJECTION_ANGULAR_FISHEYE: u32 = 1;
/// `ImapCamera::projection`: a hemispherical (orthographic) fisheye, Radiance's `-vth`;
/// the distance from the centre is proportional to the sine of the angle off the view.
pub const IMAP_PROJECTION_HEMISPHERICAL: u32 = 2;

/// The camera an ImapCamera describes (validated when it is used).
pub(crate) fn camera_from_c(cam: &ImapCamera) -> crate::error::Result<CameraDesc> {
    Ok(CameraDesc {
        position: cam.position,
        direction: cam.direction,
        up: cam.up,
        fov_y_deg: cam.fov_y_deg,
        width: cam.width,
        height: cam.height,
        projection: projection_of(cam.projection)?,
    })
}

/// The projection of `ImapCamera::projection`, or IMAP_ERR_INVALID_ARGUMENT naming it.
pub(crate) fn projection_of(code: u32) -> crate::error::Result<crate::render::Projection> {
    use crate::render::Projection;
    Ok(match code {
        IMAP_PROJECTION_PERSPECTIVE => Projection::Perspective,
        IMAP_PROJECTION_ANGULAR_FISHEYE => Projection::AngularFisheye,
        IMAP_PROJECTION_HEMISPHERICAL => Projection::Hemispherical,
        other => bail!(
            ImapErrInvalidArgument,
            "camera.projection = {other} is not an IMAP_PROJECTION_* value (0 perspective, 1 angular fisheye, 2 hemispherical)"
        ),
    })
}

// SAFETY: repr(C), u32 struct_size first, plain numbers only.
unsafe impl Versioned for ImapCamera {
    const NAME: &'static str = "ImapCamera";
    const INIT: &'static str = "imap_camera_default";
    const BASE_SIZE: usize = std::mem::offset_of!(ImapCamera, projection);
    fn defaults() -> Self {
        ImapCamera {
            struct_size: std::mem::size_of::<Self>() as u32,
            width: 512,
            height: 512,
            position: [0.0, 0.0, 0.0],
            direction: [0.0, 0.0, -1.0],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 60.0,
            projection: IMAP_PROJECTION_PERSPECTIVE,
        }
    }
}

/// What `imap_render` does. Initialise with `imap_render_params_default(&p, sizeof p)`;
/// at least one stop criterion (passes, time budget, target error) or a callback is
/// required.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapRenderParams {
    /// `sizeof(ImapRenderParams)` as the program was compiled; set by
    /// `imap_render_params_default`.
    pub struct_size: u32,
    /// `IMAP_RENDER_*`.
    pub method: u32,
    /// Semi-synchronous: threads per group (0 = 1; groups = threads / group_threads).
    pub group_threads: u32,
    /// Semi-synchronous: phases between re-randomised tile masks (0 = 4).
    pub remask_phases: u32,
    /// Safety limit on events (surface events and scatterings in a medium) per path (≥ 1);
    /// longer paths are dropped and counted in `ImapRenderReport::dropped_paths`.
    pub max_path_events: u32,
    /// Forward photons per pass over the image (0 = one per pixel). Final gathering: the
    /// map's photons per pass (`IMAP_RENDER_FINAL_GATHER`; 0 = balanced by time).
    pub forward_per_pass: u64,
    /// Stop after this many samples per pixel, on average (0 = no limit; final gathering:
    /// every pixel).
    pub passes: u64,
    /// First gathering radius, scene units (0 = four pixel footprints at the first
    /// diffuse vertex); otherwise between 1e-6 and 2 times the scene's bounding radius.
    pub initial_radius: f64,
    /// Progressive radius reduction α in (0, 1) (0 = 2/3).
    pub alpha: f64,
    /// Wall-clock seconds the render may take; 0 = no limit.
    pub time_budget_s: f64,
    /// Stop when the estimated global relative error of the image is at or below this;
    /// 0 = none.
    pub target_rel_error: f64,
    /// Seconds between progress reports and stop checks (> 0; raised to at least 0.001 s
    /// and lengthened while the estimate would cost more than 5 % of it in CPU time; the
    /// history keeps at most 4096 points).
    pub progress_interval_s: f64,
    /// Called as for `imap_run`; in the `ImapProgress` it receives, `photons` counts
    /// forward photons, `hits` backward paths (one per pixel sample) and `rel_error` is
    /// the image's estimated global relative error.
    pub progress: ImapProgressFn,
    /// Passed to `progress` unchanged.
    pub user_data: *mut c_void,
}

// SAFETY: repr(C), u32 struct_size first, numbers, an Option<fn> and a raw pointer.
unsafe impl Versioned for ImapRenderParams {
    const NAME: &'static str = "ImapRenderParams";
    const INIT: &'static str = "imap_render_params_default";
    fn defaults() -> Self {
        ImapRenderParams {
            struct_size: std::mem::size_of::<Self>() as u32,
            method: IMAP_RENDER_SEMI_SYNC,
            group_threads: 1,
            remask_phases: 4,
            max_path_events: 1 << 20,
            forward_per_pass: 0,
            passes: 0,
            initial_radius: 0.0,
            alpha: 2.0 / 3.0,
            time_budget_s: 0.0,
            target_rel_error: 0.0,
            progress_interval_s: 0.5,
            progress: None,
            user_data: std::ptr::null_mut(),
        }
    }
}

/// Figures of the last render.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct ImapRenderReport {
    /// Bytes of this struct the library filled.
    pub struct_size: u32,
    /// `IMAP_STOP_*`: why the render stopped (`IMAP_STOP_PHOTONS` = the passes limit).
    pub stop_reason: u32,
    /// Worker threads, groups of them, threads per group.
    pub threads: u32,
    pub groups: u32,
    pub threads_per_group: u32,
    /// Group phases completed; each adds one sample to the pixels of its group's mask
    /// (final gathering: batches of passes between slices of the map).
    pub phases: u64,
    /// Samples per pixel, averaged over the image.
    pub passes: f64,
    /// Backward paths (pixel samples) and the rays they traced (shadow rays included).
    pub backward_paths: u64,
    pub backward_rays: u64,
    /// Forward photons from the lights and the rays they traced (final gathering: the
    /// photons the render added to the map; rays 0).
    pub forward_photons: u64,
    pub forward_rays: u64,
    /// Forward photon hits that fell within a backward photon's radius (final gathering:
    /// the caustic photons traced).
    pub gathers: u64,
    /// Backward paths dropped at `max_path_events`.
    pub dropped_paths: u64,
    /// Wall time, s.
    pub wall_s: f64,
    /// Estimated global relative error of the image: RMS of the pixels' standard errors
    /// over their mean luminance (the photon-map methods: each pixel's with a first-order
    /// estimate of its boundary bias near edges and corners, docs/rendering.md).
    pub rel_error: f64,
    /// Seconds summed over groups (each measured by its leader thread): backward paths,
    /// building the maps, forward photons, closing the maps (tracing on while other groups
    /// still read them), finalizing the phase's samples. Final gathering: the eye paths,
    /// reading the map's values, running the map, the caustic photons (`time_close_s`).
    pub time_backward_s: f64,
    pub time_build_s: f64,
    pub time_forward_s: f64,
    pub time_close_s: f64,
    pub time_finalize_s: f64,
    /// Semi-synchronous: batches of forward photons traced into another group's maps.
    pub joins: u64,
    /// Extra forward batches owners traced while others still used their maps.
    pub close_retries: u64,
    /// Joins that found maps being rebuilt; the counter protocol keeps this 0.
    pub gate_violations: u64,
    /// Largest backward-photon-map memory of one group, bytes (final gathering: the copy
    /// of the map's values it reads).
    pub map_bytes_per_group: u64,
    /// Pixel stores, bytes (one per thread for the asynchronous method; final gathering:
    /// with the caustics' per-pixel sums).
    pub pixel_bytes: u64,
    /// All maps and pixel stores, bytes.
    pub total_bytes: u64,
    /// Points in the accuracy history (`imap_get_render_history`).
    pub history_len: u64,
    /// What the scene has that this method cannot show: `IMAP_RENDER_OMITS_*` flags,
    /// or-ed; 0 when nothing is known to be missing. Told from the scene's lights and
    /// materials, so a flag means such light may be missing wherever the geometry lets it
    /// through. (Since 0.2.3.)
    pub omitted: u32,
}

/// `ImapRenderReport::omitted`: the scene has point-like lights (or the sun) outside a
/// scattering medium whose light can enter it only through a refracting surface (an opal
/// cover or a light guide lit by LEDs, a sunbeam in haze through a window). What the medium
/// scatters of that light toward the camera is missing from the picture, in every method:
/// a shadow ray cannot follow the refraction, and no photon map holds volume photons. The
/// illumination map has it (photons follow every path). (Since 0.2.3.)
pub const IMAP_RENDER_OMITS_REFRACTED_INTO_MEDIUM: u32 = 1;

/// `ImapRenderReport::omitted`: the backward photon map's methods (sync, async,
/// semi-sync), in a scene with point-like lights (or the sun), specular surfaces and glossy
/// reflectors: light that reaches a glossy reflector through specular surfaces (a caustic
/// on a rough metal or a plastic floor) is missing, as its backward photons sit at diffuse
/// vertices only. `IMAP_RENDER_FINAL_GATHER` shows it. (Since 0.2.3.)
pub const IMAP_RENDER_OMITS_CAUSTICS_ON_GLOSSY: u32 = 2;

// SAFETY: repr(C), u32 struct_size first, plain numbers only.
unsafe impl Versioned for ImapRenderReport {
    const NAME: &'static str = "ImapRenderReport";
    // (0.2.2's size: programs built then get the report without `omitted`.)
    const BASE_SIZE: usize = std::mem::offset_of!(ImapRenderReport, omitted);
    const INIT: &'static str = "sizeof";
    fn defaults() -> Self {
        ImapRenderReport::default()
    }
}

/// Fills the `size` bytes at `out` with a camera at the origin looking down −z, up +y,
/// 60° vertical field of view, 512 × 512 pixels, and sets `struct_size = size`. Pass
/// `sizeof *out`. Thread-safe.
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_camera_default(out: *mut ImapCamera, size: usize) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

/// Fills the `size` bytes at `out` with render defaults and sets `struct_size = size`:
/// semi-synchronous, one thread per group, masks re-randomised every 4 phases, one
/// forward photon per pixel per pass, radius of four pixel footprints reduced with
/// α = 2/3, no stop criterion set (set at least one), progress every 0.5 s, at most 2^20
/// events per path, no callback. Pass `sizeof *out`. Thread-safe.
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_render_params_default(
    out: *mut ImapRenderParams,
    size: usize,
) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

fn render_report_to_c(r: &RenderReport) -> ImapRenderReport {
    ImapRenderReport {
        struct_size: std::mem::size_of::<ImapRenderReport>() as u32,
        threads: r.threads as u32,
        groups: r.groups as u32,
        threads_per_group: r.threads_per_group as u32,
        stop_reason: stop_to_c(r.stop),
        phases: r.phases,
        passes: r.passes,
        backward_paths: r.backward_paths,
        backward_rays: r.backward_rays,
        forward_photons: r.forward_photons,
        forward_rays: r.forward_rays,
        gathers: r.gathers,
        dropped_paths: r.dropped_paths,
        wall_s: r.wall_s,
        rel_error: r.rel_error,
        time_backward_s: r.time_backward_s,
        time_build_s: r.time_build_s,
        time_forward_s: r.time_forward_s,
        time_close_s: r.time_close_s,
        time_finalize_s: r.time_finalize_s,
        joins: r.joins,
        close_retries: r.close_retries,
        gate_violations: r.gate_violations,
        map_bytes_per_group: r.map_bytes_per_group,
        pixel_bytes: r.pixel_bytes,
        total_bytes: r.total_bytes,
        history_len: r.history.len() as u64,
        omitted: r.omitted,
    }
}

/// Renders what `camera` sees: radiance (luminance per band) in W/(m²·sr) — the lights'
/// power unit per m² (`ImapConfig::unit_m`) per steradian — by stochastic progressive
/// backward photon mapping (or, with `IMAP_RENDER_FINAL_GATHER`, final gathering from the
/// illumination map), until a stop criterion of `params` is met. Blocks the calling
/// thread, which runs the progress callback. Uses the context's scene, thread count and
/// seed; the photon-map methods neither read nor change the illumination map, final
/// gathering reads and extends it. Every call starts a new image.
///
/// `out_radiance` receives `width × height × bands` doubles, pixel by pixel from the top
/// left, row by row, the bands of a pixel together (`radiance_count` must be at least
/// that). `out_rel_error` (may be NULL) receives `width × height` relative standard
/// errors of each pixel's band-mean radiance (1 where nothing was seen; the photon-map
/// methods' include the pixel's estimated boundary bias). `report` (may be
/// NULL) receives the report (`report_size` = `sizeof(ImapRenderReport)`), which
/// `imap_get_render_report` also keeps.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_INVALID_ARGUMENT (camera, method, no stop
/// criterion, negative values; the message names the field), IMAP_ERR_NON_FINITE,
/// IMAP_ERR_BUFFER_TOO_SMALL (checked before any work), IMAP_ERR_NO_GEOMETRY,
/// IMAP_ERR_NO_LIGHT, IMAP_ERR_PRECISION, IMAP_ERR_MEMORY_BUDGET, IMAP_ERR_OUT_OF_MEMORY,
/// IMAP_ERR_EMBREE, IMAP_ERR_BUSY, IMAP_ERR_THREAD_LOST (a worker thread panicked: the
/// render stopped, the buffers and the report still hold what was rendered until then).
///
/// # Safety
/// `ctx` is a live handle; `camera` and `params` point to initialised structs;
/// `out_radiance` holds `radiance_count` writable doubles; `out_rel_error` is NULL or
/// holds `rel_error_count` writable doubles; `report` is NULL or holds `report_size`
/// writable bytes; the callback, if any, is callable with `user_data`.
#[no_mangle]
pub unsafe extern "C" fn imap_render(
    ctx: *mut ImapContext,
    camera: *const ImapCamera,
    params: *const ImapRenderParams,
    out_radiance: *mut f64,
    radiance_count: usize,
    out_rel_error: *mut f64,
    rel_error_count: usize,
    report: *mut ImapRenderReport,
    report_size: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        let cam = read_versioned("camera", camera)?;
        let p = read_versioned("params", params)?;
        check_report_out("report", report, report_size)?;
        let method = match p.method {
            IMAP_RENDER_SYNC => RenderMethod::Synchronous,
            IMAP_RENDER_ASYNC => RenderMethod::Asynchronous,
            IMAP_RENDER_SEMI_SYNC => RenderMethod::SemiSynchronous,
            IMAP_RENDER_FINAL_GATHER => RenderMethod::FinalGather,
            m => bail!(
                ImapErrInvalidArgument,
                "params.method = {m} is not IMAP_RENDER_SYNC, _ASYNC, _SEMI_SYNC or _FINAL_GATHER"
            ),
        };
        let pixels = cam.width as usize * cam.height as usize;
        let bands = c.scene().bands.count();
        let want = pixels * bands;
        if radiance_count < want {
            bail!(
                ImapErrBufferTooSmall,
                "radiance_count {radiance_count} < {want} (width {} × height {} × {} bands)",
                cam.width,
                cam.height,
                bands
            );
        }
        let radiance = slice_mut("out_radiance", out_radiance, radiance_count)?;
        let rel_error = if out_rel_error.is_null() {
            None
        } else {
            if rel_error_count < pixels {
                bail!(
                    ImapErrBufferTooSmall,
                    "rel_error_count {rel_error_count} < {pixels} (width × height)"
                );
            }
            Some(slice_mut("out_rel_error", out_rel_error, rel_error_count)?)
        };
        let mut call = callback(p.progress, p.user_data);
        let mut rp = RenderParams {
            method,
            group_threads: p.group_threads as usize,
            remask_phases: p.remask_phases,
            forward_per_pass: p.forward_per_pass,
            initial_radius: p.initial_radius,
            alpha: p.alpha,
            passes: p.passes,
            time_budget_s: p.time_budget_s,
            target_rel_error: p.target_rel_error,
            progress_interval_s: p.progress_interval_s,
            max_path_events: p.max_path_events,
            progress: if p.progress.is_some() {
                Some(&mut call)
            } else {
                None
            },
        };
        let desc = camera_from_c(&cam)?;
        let (image, r, lost) = c.render_partial(&desc, &mut rp)?;
        radiance[..want].copy_from_slice(&image.radiance);
        if let Some(dst) = rel_error {
            dst[..pixels].copy_from_slice(&image.rel_error);
        }
        if !report.is_null() {
            write_versioned("report", report, report_size, render_report_to_c(&r))?;
        }
        lost.map_or(Ok(()), Err)
    })
}

/// The report of the last render (since the last reset) into `*out`; `size` =
/// `sizeof(ImapRenderReport)`.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_INVALID_ARGUMENT (size), IMAP_ERR_OUT_OF_ORDER
/// (no render yet), IMAP_ERR_BUSY.
///
/// # Safety
/// `ctx` is a live handle; `out` points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_get_render_report(
    ctx: *const ImapContext,
    out: *mut ImapRenderReport,
    size: usize,
) -> ImapStatus {
    with_context(ctx, |c| match c.render_report() {
        Some(r) => write_versioned("out", out, size, render_report_to_c(r)),
        None => bail!(
            ImapErrOutOfOrder,
            "no render since the context was created or reset"
        ),
    })
}

/// Copies up to `capacity` points of the last render's accuracy-against-time history
/// (oldest first; `photons` = forward photons, `hits` = backward paths, `rel_error` = the
/// image's estimated global relative error) into `out` (elements of `element_size` =
/// `sizeof(ImapProgress)` bytes; may be NULL when `capacity` is 0) and writes the total
/// number of points to `*out_count` (0 before any render).
///
/// # Safety
/// `ctx` is a live handle; `out` holds `capacity` writable elements; `out_count` is
/// writable.
#[no_mangle]
pub unsafe extern "C" fn imap_get_render_history(
    ctx: *const ImapContext,
    out: *mut ImapProgress,
    capacity: usize,
    element_size: usize,
    out_count: *mut usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        let h = c.render_report().map_or(&[][..], |r| &r.history[..]);
        copy_history(h, out, capacity, element_size, out_count)
    })
}

// The C flags are the render's own.
const _: () = assert!(
    IMAP_RENDER_OMITS_REFRACTED_INTO_MEDIUM == crate::render::OMITS_REFRACTED_INTO_MEDIUM
        && IMAP_RENDER_OMITS_CAUSTICS_ON_GLOSSY == crate::render::OMITS_CAUSTICS_ON_GLOSSY
);

//! Every `#[no_mangle]` function of the C ABI.

use super::types::*;
use super::{
    boundary, check_out, reference, slice, slice_mut, with_context, write_out, ImapContext,
};
use crate::context::{Config, Context, Report, SchedulerKind};
use crate::error::{bail, ImapStatus, Result};
use crate::render::{CameraDesc, RenderMethod, RenderParams, RenderReport};
use crate::scene::{Bands, IorModel, MaterialDesc, MeshDesc};
use crate::sched::dynamic::DynamicParams;
use crate::sched::{Progress, RunParams, StopReason};
use std::ffi::{c_char, CStr};
use std::sync::Mutex;

/// Fills `out` with the defaults: RGB, all cores, seed 0, dynamic scheduler with subd 4 and
/// automatic group counts and thresholds, no memory limit, 1 m per scene unit (spectral
/// range preset to 380–780 nm).
///
/// Returns IMAP_ERR_NULL_POINTER when `out` is NULL. Thread-safe.
#[no_mangle]
pub extern "C" fn imap_config_default(out: *mut ImapConfig) -> ImapStatus {
    boundary(None, || {
        write_out(
            "out",
            out,
            ImapConfig {
                band_mode: IMAP_BANDS_RGB,
                band_count: 3,
                wavelength_min_nm: 380.0,
                wavelength_max_nm: 780.0,
                threads: 0,
                scheduler: IMAP_SCHEDULER_DYNAMIC,
                seed: 0,
                memory_budget_bytes: 0,
                unit_m: 1.0,
                initial_groups: 0,
                max_groups: 0,
                subd: 4,
                split_low_threshold: 0,
                split_high_threshold: 0,
                min_group_slots: 0,
                inline_apply: IMAP_INLINE_AUTO,
            },
        )
    })
}

fn config_from_c(c: &ImapConfig) -> Result<Config> {
    let bands = match c.band_mode {
        IMAP_BANDS_RGB => {
            if c.band_count != 3 {
                bail!(
                    ImapErrBadBands,
                    "RGB mode has 3 bands, but band_count is {}",
                    c.band_count
                );
            }
            Bands::rgb()
        }
        IMAP_BANDS_SPECTRAL => {
            Bands::spectral(c.band_count, c.wavelength_min_nm, c.wavelength_max_nm)?
        }
        m => bail!(
            ImapErrInvalidArgument,
            "band_mode {m} is neither IMAP_BANDS_RGB nor IMAP_BANDS_SPECTRAL"
        ),
    };
    let scheduler = match c.scheduler {
        IMAP_SCHEDULER_CLASSIC => SchedulerKind::Classic,
        IMAP_SCHEDULER_DYNAMIC => SchedulerKind::Dynamic,
        s => bail!(ImapErrInvalidArgument, "scheduler {s} is unknown"),
    };
    let defaults = DynamicParams::default();
    let or = |v: u32, d: usize| if v == 0 { d } else { v as usize };
    let dynamic = DynamicParams {
        initial_groups: c.initial_groups as usize,
        max_groups: c.max_groups as usize,
        subd: or(c.subd, defaults.subd),
        low_threshold: c.split_low_threshold as usize,
        high_threshold: or(c.split_high_threshold, defaults.high_threshold),
        min_group_slots: or(c.min_group_slots, defaults.min_group_slots),
        split_interval: defaults.split_interval,
        inline_apply: match c.inline_apply {
            IMAP_INLINE_AUTO => None,
            IMAP_INLINE_ALWAYS => Some(true),
            IMAP_INLINE_NEVER => Some(false),
            v => bail!(
                ImapErrInvalidArgument,
                "inline_apply {v} is not IMAP_INLINE_AUTO, _ALWAYS or _NEVER"
            ),
        },
    };
    Ok(Config {
        bands,
        threads: c.threads as usize,
        seed: c.seed,
        scheduler,
        dynamic,
        memory_budget: c.memory_budget_bytes,
        unit_m: c.unit_m,
    })
}

/// Creates a context. `config` is copied (NULL = defaults). On success `*out` receives a
/// handle that the caller owns and frees with `imap_destroy`; on failure `*out` is not
/// written and `imap_last_error(NULL)` says why.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_BAD_BANDS, IMAP_ERR_INVALID_ARGUMENT,
/// IMAP_ERR_NON_FINITE or IMAP_ERR_EMBREE. Thread-safe.
///
/// # Safety
/// `config` is NULL or points to an `ImapConfig`; `out` points to writable storage.
#[no_mangle]
pub unsafe extern "C" fn imap_create(
    config: *const ImapConfig,
    out: *mut *mut ImapContext,
) -> ImapStatus {
    boundary(None, || {
        check_out("out", out)?;
        let config = if config.is_null() {
            Config::default()
        } else {
            config_from_c(reference("config", config)?)?
        };
        let ctx = Context::new(config)?;
        let handle = Box::new(ImapContext {
            inner: Mutex::new(ctx),
            last_error: Mutex::new(Default::default()),
        });
        write_out("out", out, Box::into_raw(handle))
    })
}

/// Destroys a context and everything it owns. NULL is a no-op. The context must not be in
/// use by another thread.
///
/// # Safety
/// `ctx` is NULL or a handle from `imap_create` not yet destroyed.
#[no_mangle]
pub unsafe extern "C" fn imap_destroy(ctx: *mut ImapContext) {
    if !ctx.is_null() {
        let _ = std::panic::catch_unwind(|| {
            // SAFETY: the handle came from Box::into_raw in imap_create.
            drop(unsafe { Box::from_raw(ctx) });
        });
    }
}

/// The message of the most recent failing call on `ctx`, or, with `ctx` NULL, of the most
/// recent failing call on the calling thread (the only way to learn why `imap_create`
/// failed). Never NULL; "" when nothing failed. The string is owned by the library and
/// valid until the next failing call on the same context (or thread).
///
/// # Safety
/// `ctx` is NULL or a live handle.
#[no_mangle]
pub unsafe extern "C" fn imap_last_error(ctx: *const ImapContext) -> *const c_char {
    let r = std::panic::catch_unwind(|| {
        if ctx.is_null() {
            super::THREAD_ERROR.with(|t| t.borrow().as_ptr())
        } else {
            // SAFETY: a live handle per the contract.
            let h = unsafe { &*ctx };
            let s = h.last_error.lock().unwrap_or_else(|p| p.into_inner());
            // The CString's buffer stays put until the slot is overwritten.
            s.as_ptr()
        }
    });
    r.unwrap_or(c"internal error".as_ptr())
}

/// A static name for a status ("IMAP_OK", "IMAP_ERR_NULL_POINTER", ...). Thread-safe.
#[no_mangle]
pub extern "C" fn imap_status_name(status: ImapStatus) -> *const c_char {
    use ImapStatus::*;
    let s: &'static CStr = match status {
        ImapOk => c"IMAP_OK",
        ImapErrNullPointer => c"IMAP_ERR_NULL_POINTER",
        ImapErrInvalidArgument => c"IMAP_ERR_INVALID_ARGUMENT",
        ImapErrNonFinite => c"IMAP_ERR_NON_FINITE",
        ImapErrIndexOutOfRange => c"IMAP_ERR_INDEX_OUT_OF_RANGE",
        ImapErrDegenerateTriangle => c"IMAP_ERR_DEGENERATE_TRIANGLE",
        ImapErrBadBands => c"IMAP_ERR_BAD_BANDS",
        ImapErrNoGeometry => c"IMAP_ERR_NO_GEOMETRY",
        ImapErrEmptyMesh => c"IMAP_ERR_EMPTY_MESH",
        ImapErrUnknownMaterial => c"IMAP_ERR_UNKNOWN_MATERIAL",
        ImapErrNoLight => c"IMAP_ERR_NO_LIGHT",
        ImapErrBadMaterial => c"IMAP_ERR_BAD_MATERIAL",
        ImapErrOutOfOrder => c"IMAP_ERR_OUT_OF_ORDER",
        ImapErrMemoryBudget => c"IMAP_ERR_MEMORY_BUDGET",
        ImapErrBusy => c"IMAP_ERR_BUSY",
        ImapErrEmbree => c"IMAP_ERR_EMBREE",
        ImapErrThreadLost => c"IMAP_ERR_THREAD_LOST",
        ImapErrInternal => c"IMAP_ERR_INTERNAL",
        ImapErrOutOfMemory => c"IMAP_ERR_OUT_OF_MEMORY",
        ImapErrNotRecorded => c"IMAP_ERR_NOT_RECORDED",
        ImapErrBufferTooSmall => c"IMAP_ERR_BUFFER_TOO_SMALL",
    };
    s.as_ptr()
}

/// The library version as "major.minor.patch", static. Thread-safe.
#[no_mangle]
pub extern "C" fn imap_version() -> *const c_char {
    const V: &CStr =
        match CStr::from_bytes_with_nul(concat!(env!("CARGO_PKG_VERSION"), "\0").as_bytes()) {
            Ok(v) => v,
            Err(_) => panic!("version has no NUL"),
        };
    V.as_ptr()
}

/// Embree's version (major·10000 + minor·100 + patch) into `*out`.
///
/// # Safety
/// `ctx` is a live handle; `out` points to writable storage.
#[no_mangle]
pub unsafe extern "C" fn imap_embree_version(ctx: *const ImapContext, out: *mut i64) -> ImapStatus {
    with_context(ctx, |c| write_out("out", out, c.embree_version()))
}

/// The frame of every `imap_add_*`: `out_id` is checked before anything is added, `add`
/// runs on the context, and its id is written only on success.
fn add_with(
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
fn vec3(name: &str, ptr: *const f64) -> Result<[f64; 3]> {
    let v = slice(name, ptr, 3)?;
    Ok([v[0], v[1], v[2]])
}

fn per_band(name: &str, ptr: *const f64, count: usize) -> Result<Vec<f64>> {
    Ok(slice(name, ptr, count)?.to_vec())
}

/// Adds a material; `*out_id` receives its id (0, 1, ... in order of addition). Materials
/// may be added at any time. The arrays are copied.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_NON_FINITE, IMAP_ERR_INVALID_ARGUMENT (an array
/// count other than 0, 1 or the band count; unknown ior_model), IMAP_ERR_BAD_MATERIAL
/// (coefficients outside [0, 1], sum over 1, index below 1), IMAP_ERR_BUSY.
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
        let m = reference("material", material)?;
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
            other => bail!(ImapErrInvalidArgument, "ior_model {other} is unknown"),
        };
        let desc = MaterialDesc {
            diffuse_reflect: per_band(
                "diffuse_reflectance",
                m.diffuse_reflectance,
                m.diffuse_reflectance_count,
            )?,
            specular_reflect: per_band(
                "specular_reflectance",
                m.specular_reflectance,
                m.specular_reflectance_count,
            )?,
            diffuse_transmit: per_band(
                "diffuse_transmittance",
                m.diffuse_transmittance,
                m.diffuse_transmittance_count,
            )?,
            ior,
            absorption_per_m: per_band("absorption_per_m", m.absorption_per_m, m.absorption_count)?,
        };
        c.add_material(&desc)
    })
}

/// Adds a triangle mesh; `*out_id` receives its id (0, 1, ... in order). The arrays are
/// copied. Memory for the map of a recording mesh is checked against the budget here.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_EMPTY_MESH (no vertex or no triangle),
/// IMAP_ERR_NON_FINITE (a NaN/Inf coordinate or exitance), IMAP_ERR_INDEX_OUT_OF_RANGE
/// (a vertex index ≥ vertex_count), IMAP_ERR_DEGENERATE_TRIANGLE (a triangle repeating a
/// vertex), IMAP_ERR_UNKNOWN_MATERIAL, IMAP_ERR_INVALID_ARGUMENT, IMAP_ERR_NO_LIGHT (an
/// emitting mesh with zero exitance), IMAP_ERR_MEMORY_BUDGET, IMAP_ERR_OUT_OF_ORDER (after a
/// run: call `imap_reset` first), IMAP_ERR_BUSY. Nothing is added on failure.
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
        let m = reference("mesh", mesh)?;
        if m.vertex_count == 0 || m.triangle_count == 0 {
            bail!(
                ImapErrEmptyMesh,
                "mesh has {} vertices and {} triangles: a mesh needs at least one triangle",
                m.vertex_count,
                m.triangle_count
            );
        }
        let positions = slice("positions", m.positions, m.vertex_count.saturating_mul(3))?;
        let indices = slice("indices", m.indices, m.triangle_count.saturating_mul(3))?;
        let triangle_materials = if m.triangle_materials.is_null() {
            None
        } else {
            Some(slice(
                "triangle_materials",
                m.triangle_materials,
                m.triangle_count,
            )?)
        };
        let exitance = if m.exitance_count == 0 {
            None
        } else {
            Some(slice("exitance", m.exitance, m.exitance_count)?)
        };
        if m.flags & !(IMAP_MESH_TWO_SIDED | IMAP_MESH_RECORD) != 0 {
            bail!(ImapErrInvalidArgument, "unknown mesh flags 0x{:x}", m.flags);
        }
        let desc = MeshDesc {
            positions,
            indices,
            material: m.material,
            triangle_materials,
            two_sided: m.flags & IMAP_MESH_TWO_SIDED != 0,
            record: m.flags & IMAP_MESH_RECORD != 0,
            exitance,
        };
        c.add_mesh(&desc)
    })
}

/// Adds an isotropic point light at `position` (scene units) with radiant flux `power` in
/// W per band (1 value = the same in every band, or one per band); `*out_id` receives its
/// id. Lights are chosen by power during the run.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_NON_FINITE, IMAP_ERR_INVALID_ARGUMENT,
/// IMAP_ERR_NO_LIGHT (zero power), IMAP_ERR_OUT_OF_ORDER, IMAP_ERR_BUSY.
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

/// Fills `out` with run defaults: no stop criterion set (set at least one), progress every
/// 0.5 s, at most 2^20 events per path, no callback.
///
/// Returns IMAP_ERR_NULL_POINTER when `out` is NULL. Thread-safe.
#[no_mangle]
pub extern "C" fn imap_run_params_default(out: *mut ImapRunParams) -> ImapStatus {
    boundary(None, || {
        write_out(
            "out",
            out,
            ImapRunParams {
                photons: 0,
                time_budget_s: 0.0,
                target_rel_error: 0.0,
                progress_interval_s: 0.5,
                max_path_events: 1 << 20,
                progress: None,
                user_data: std::ptr::null_mut(),
            },
        )
    })
}

fn progress_to_c(p: &Progress) -> ImapProgress {
    ImapProgress {
        elapsed_s: p.elapsed_s,
        photons: p.photons,
        hits: p.hits,
        rel_error: p.rel_error,
    }
}

fn stop_to_c(stop: Option<StopReason>) -> u32 {
    match stop {
        None => IMAP_STOP_NONE,
        Some(StopReason::PhotonCount) => IMAP_STOP_PHOTONS,
        Some(StopReason::TimeBudget) => IMAP_STOP_TIME,
        Some(StopReason::TargetError) => IMAP_STOP_TARGET_ERROR,
        Some(StopReason::Cancelled) => IMAP_STOP_CANCELLED,
    }
}

fn report_to_c(r: &Report, history_len: usize) -> ImapReport {
    ImapReport {
        photons: r.photons,
        hits: r.hits,
        elapsed_s: r.elapsed_s,
        rel_error: r.rel_error,
        run_photons: r.run_photons,
        run_hits: r.run_hits,
        run_wall_s: r.run_wall_s,
        stop_reason: stop_to_c(r.stop),
        threads: r.threads as u32,
        emitted_w: r.emitted_w,
        absorbed_w: r.absorbed_w,
        escaped_w: r.escaped_w,
        dropped_w: r.dropped_w,
        dropped_photons: r.dropped_photons,
        calc_wait_s: r.counters.calc_wait_s,
        accum_busy_fraction: r.counters.accum_busy_fraction,
        peak_queue: r.counters.peak_queue,
        portions: r.counters.portions,
        inline_portions: r.counters.inline_portions,
        splits: r.counters.splits,
        groups: r.counters.groups,
        map_bytes: r.map_bytes,
        history_len: history_len as u64,
    }
}

/// Traces photons into the map until a stop criterion of `params` is met; blocks the
/// calling thread, which also runs the progress callback. The first run builds the BVH and
/// allocates the map. A later run continues the photon sequence and adds to the same map
/// (a run stopped by the callback can be resumed). `report` (may be NULL) receives the
/// report on success.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_INVALID_ARGUMENT (no stop criterion, negative
/// values), IMAP_ERR_NON_FINITE, IMAP_ERR_NO_GEOMETRY, IMAP_ERR_NO_LIGHT,
/// IMAP_ERR_MEMORY_BUDGET, IMAP_ERR_OUT_OF_MEMORY, IMAP_ERR_EMBREE, IMAP_ERR_BUSY,
/// IMAP_ERR_THREAD_LOST (a worker thread panicked; the photons of its unfinished batch are
/// missing from the map; the message says how many at most).
///
/// # Safety
/// `ctx` is a live handle; `params` points to an `ImapRunParams`; `report` is NULL or
/// points to writable storage; the callback, if any, is callable with `user_data`.
#[no_mangle]
pub unsafe extern "C" fn imap_run(
    ctx: *mut ImapContext,
    params: *const ImapRunParams,
    report: *mut ImapReport,
) -> ImapStatus {
    with_context(ctx, |c| {
        let p = reference("params", params)?;
        let (cb, user) = (p.progress, p.user_data);
        let mut call = move |pr: &Progress| -> bool {
            let cp = progress_to_c(pr);
            // SAFETY: the caller supplied a callable function pointer and its user data.
            cb.is_none_or(|f| unsafe { f(&cp, user) } == 0)
        };
        let mut rp = RunParams {
            photons: p.photons,
            time_budget_s: p.time_budget_s,
            target_rel_error: p.target_rel_error,
            progress_interval_s: p.progress_interval_s,
            max_path_events: p.max_path_events,
            progress: if cb.is_some() { Some(&mut call) } else { None },
        };
        let r = c.run(&mut rp)?;
        if !report.is_null() {
            write_out("report", report, report_to_c(&r, c.history().len()))?;
        }
        Ok(())
    })
}

/// Copies up to `capacity` points of `h` into `out` and the total count into `*out_count`.
fn copy_history(
    h: &[Progress],
    out: *mut ImapProgress,
    capacity: usize,
    out_count: *mut usize,
) -> Result<()> {
    check_out("out_count", out_count)?;
    if capacity > 0 {
        let dst = slice_mut("out", out, capacity)?;
        for (d, p) in dst.iter_mut().zip(h) {
            *d = progress_to_c(p);
        }
    }
    write_out("out_count", out_count, h.len())
}

/// The report of the context: totals since the last reset and the last run's figures.
///
/// # Safety
/// `ctx` is a live handle; `out` points to writable storage.
#[no_mangle]
pub unsafe extern "C" fn imap_get_report(
    ctx: *const ImapContext,
    out: *mut ImapReport,
) -> ImapStatus {
    with_context(ctx, |c| {
        write_out("out", out, report_to_c(&c.report(), c.history().len()))
    })
}

/// Copies up to `capacity` points of the error-against-time history (oldest first) into
/// `out` (may be NULL when `capacity` is 0) and writes the total number of points to
/// `*out_count`.
///
/// # Safety
/// `ctx` is a live handle; `out` holds `capacity` writable points; `out_count` is writable.
#[no_mangle]
pub unsafe extern "C" fn imap_get_history(
    ctx: *const ImapContext,
    out: *mut ImapProgress,
    capacity: usize,
    out_count: *mut usize,
) -> ImapStatus {
    with_context(ctx, |c| copy_history(c.history(), out, capacity, out_count))
}

/// The number of vertices of mesh `mesh` into `*out`.
///
/// # Safety
/// `ctx` is a live handle; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn imap_get_vertex_count(
    ctx: *const ImapContext,
    mesh: u32,
    out: *mut usize,
) -> ImapStatus {
    with_context(ctx, |c| write_out("out", out, c.vertex_count(mesh)?))
}

/// Irradiance in W/m² in band `band` at every vertex of mesh `mesh` on `side`
/// (`IMAP_SIDE_FRONT`, or `IMAP_SIDE_BACK` on two-sided meshes), written to `out[0 ..
/// vertex_count)`. Before the first run: zeros. Vertices used by no triangle of non-zero
/// area get 0.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_INDEX_OUT_OF_RANGE (mesh, side or band),
/// IMAP_ERR_NOT_RECORDED, IMAP_ERR_BUFFER_TOO_SMALL (`count` < vertex count), IMAP_ERR_BUSY.
///
/// # Safety
/// `ctx` is a live handle; `out` holds `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_get_vertex_energy(
    ctx: *const ImapContext,
    mesh: u32,
    side: u32,
    band: u32,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        c.irradiance(mesh, side, band, slice_mut("out", out, count)?)
    })
}

/// Relative standard error (σ/E, dimensionless) of the band-mean irradiance at every vertex
/// of `mesh` on `side`, from the per-vertex sum over photons of each photon's squared
/// total contribution (calibrated against independent runs). 1 where nothing has arrived or
/// the vertex has no area. Statuses as `imap_get_vertex_energy`.
///
/// # Safety
/// `ctx` is a live handle; `out` holds `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_get_vertex_error(
    ctx: *const ImapContext,
    mesh: u32,
    side: u32,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        c.rel_error(mesh, side, slice_mut("out", out, count)?)
    })
}

/// Power absorbed by mesh `mesh` (at its surface, or inside it for an absorbing
/// dielectric), W summed over bands, into `*out_w`.
///
/// # Safety
/// `ctx` is a live handle; `out_w` is writable.
#[no_mangle]
pub unsafe extern "C" fn imap_get_mesh_absorbed(
    ctx: *const ImapContext,
    mesh: u32,
    out_w: *mut f64,
) -> ImapStatus {
    with_context(ctx, |c| write_out("out_w", out_w, c.absorbed_w(mesh)?))
}

/// Clears the map, the totals and the history. The scene stays and may be changed again
/// (adding meshes or lights after a run requires this).
///
/// # Safety
/// `ctx` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn imap_reset(ctx: *mut ImapContext) -> ImapStatus {
    with_context(ctx, |c| {
        c.reset();
        Ok(())
    })
}

/// Fills `out` with render defaults: semi-synchronous, one thread per group, masks
/// re-randomised every 4 phases, one forward photon per pixel per pass, radius of four
/// pixel footprints reduced with α = 2/3, no stop criterion set (set at least one),
/// progress every 0.5 s, at most 2^20 events per path, no callback.
///
/// Returns IMAP_ERR_NULL_POINTER when `out` is NULL. Thread-safe.
#[no_mangle]
pub extern "C" fn imap_render_params_default(out: *mut ImapRenderParams) -> ImapStatus {
    boundary(None, || {
        write_out(
            "out",
            out,
            ImapRenderParams {
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
            },
        )
    })
}

fn render_report_to_c(r: &RenderReport) -> ImapRenderReport {
    ImapRenderReport {
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
    }
}

/// Renders what `camera` sees: radiance (luminance per band) in W/(m²·sr) — the lights'
/// power unit per m² (`ImapConfig::unit_m`) per steradian — by stochastic progressive
/// backward photon mapping, until a stop criterion of `params` is met. Blocks the calling
/// thread, which runs the progress callback. Uses the context's scene, thread count and
/// seed; neither reads nor changes the illumination map. Every call starts a new image.
///
/// `out_radiance` receives `width × height × bands` doubles, pixel by pixel from the top
/// left, row by row, the bands of a pixel together (`radiance_count` must be at least
/// that). `out_rel_error` (may be NULL) receives `width × height` relative standard
/// errors of each pixel's band-mean radiance (1 where nothing was seen). `report` (may be
/// NULL) receives the report, which `imap_get_render_report` also keeps.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_INVALID_ARGUMENT (camera, method, no stop
/// criterion, negative values), IMAP_ERR_NON_FINITE, IMAP_ERR_BUFFER_TOO_SMALL (checked
/// before any work), IMAP_ERR_NO_GEOMETRY, IMAP_ERR_NO_LIGHT, IMAP_ERR_MEMORY_BUDGET,
/// IMAP_ERR_EMBREE, IMAP_ERR_BUSY, IMAP_ERR_THREAD_LOST (a worker thread panicked: the
/// render stopped, the buffers and the report still hold what was rendered until then).
///
/// # Safety
/// `ctx` is a live handle; `camera` and `params` point to initialised structs;
/// `out_radiance` holds `radiance_count` writable doubles; `out_rel_error` is NULL or
/// holds `rel_error_count` writable doubles; `report` is NULL or writable; the callback,
/// if any, is callable with `user_data`.
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
) -> ImapStatus {
    with_context(ctx, |c| {
        let cam = reference("camera", camera)?;
        let p = reference("params", params)?;
        let method = match p.method {
            IMAP_RENDER_SYNC => RenderMethod::Synchronous,
            IMAP_RENDER_ASYNC => RenderMethod::Asynchronous,
            IMAP_RENDER_SEMI_SYNC => RenderMethod::SemiSynchronous,
            m => bail!(
                ImapErrInvalidArgument,
                "render method {m} is not IMAP_RENDER_SYNC, _ASYNC or _SEMI_SYNC"
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
        let (cb, user) = (p.progress, p.user_data);
        let mut call = move |pr: &Progress| -> bool {
            let cp = progress_to_c(pr);
            // SAFETY: the caller supplied a callable function pointer and its user data.
            cb.is_none_or(|f| unsafe { f(&cp, user) } == 0)
        };
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
            progress: if cb.is_some() { Some(&mut call) } else { None },
        };
        let desc = CameraDesc {
            position: cam.position,
            direction: cam.direction,
            up: cam.up,
            fov_y_deg: cam.fov_y_deg,
            width: cam.width,
            height: cam.height,
        };
        let (image, r, lost) = c.render_partial(&desc, &mut rp)?;
        radiance[..want].copy_from_slice(&image.radiance);
        if let Some(dst) = rel_error {
            dst[..pixels].copy_from_slice(&image.rel_error);
        }
        if !report.is_null() {
            write_out("report", report, render_report_to_c(&r))?;
        }
        lost.map_or(Ok(()), Err)
    })
}

/// The report of the last render (since the last reset) into `*out`.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_OUT_OF_ORDER (no render yet), IMAP_ERR_BUSY.
///
/// # Safety
/// `ctx` is a live handle; `out` points to writable storage.
#[no_mangle]
pub unsafe extern "C" fn imap_get_render_report(
    ctx: *const ImapContext,
    out: *mut ImapRenderReport,
) -> ImapStatus {
    with_context(ctx, |c| match c.render_report() {
        Some(r) => write_out("out", out, render_report_to_c(r)),
        None => bail!(
            ImapErrOutOfOrder,
            "no render since the context was created or reset"
        ),
    })
}

/// Copies up to `capacity` points of the last render's accuracy-against-time history
/// (oldest first; `photons` = forward photons, `hits` = backward paths, `rel_error` = the
/// image's estimated global relative error) into `out` (may be NULL when `capacity` is 0)
/// and writes the total number of points to `*out_count` (0 before any render).
///
/// # Safety
/// `ctx` is a live handle; `out` holds `capacity` writable points; `out_count` is writable.
#[no_mangle]
pub unsafe extern "C" fn imap_get_render_history(
    ctx: *const ImapContext,
    out: *mut ImapProgress,
    capacity: usize,
    out_count: *mut usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        let h = c.render_report().map_or(&[][..], |r| &r.history[..]);
        copy_history(h, out, capacity, out_count)
    })
}

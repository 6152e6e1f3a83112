//! Runs and their results: run parameters, progress, the report, the history and the map's
//! readout.

use super::{
    boundary, check_out, read_versioned, with_context, write_defaults, write_out, write_versioned,
    ImapContext, Versioned,
};
use crate::context::Report;
use crate::error::{bail, ImapStatus, Result};
use crate::sched::target::{RegionMeasure, RegionTarget};
use crate::sched::{Progress, RunParams, StopReason};
use crate::transport::direct::Estimator;
use std::ffi::c_void;

/// Side index of `imap_get_vertex_energy`: the side the normal (v1−v0)×(v2−v0) points to.
pub const IMAP_SIDE_FRONT: u32 = 0;
/// The other side (two-sided meshes only).
pub const IMAP_SIDE_BACK: u32 = 1;

/// `ImapReport::stop_reason` values: no run yet.
pub const IMAP_STOP_NONE: u32 = 0;
/// The run traced its photon count.
pub const IMAP_STOP_PHOTONS: u32 = 1;
/// The run used its time budget.
pub const IMAP_STOP_TIME: u32 = 2;
/// The estimated error reached the target.
pub const IMAP_STOP_TARGET_ERROR: u32 = 3;
/// The progress callback asked to stop.
pub const IMAP_STOP_CANCELLED: u32 = 4;
/// The region target (`ImapRunParams::region_target`) was reached. (Since 0.2.1.)
pub const IMAP_STOP_REGION_TARGET: u32 = 5;

/// `ImapRunParams::region_measure`: the `region_percentile`-th percentile (default 100:
/// the largest) of the relative standard errors of the chosen meshes' vertices (band mean,
/// as `imap_get_vertex_error`; a vertex that received nothing counts as 1). (Since
/// 0.2.1.)
pub const IMAP_REGION_VERTICES: u32 = 0;
/// The relative standard error of each chosen mesh side's average illuminance, the
/// largest over them (`ImapRegionStats::average_lx_sigma / average_lx`).
pub const IMAP_REGION_AVERAGE: u32 = 1;
/// The relative standard error of each chosen mesh side's uniformity U0 = Emin/Eavg, the
/// largest over them (`ImapRegionStats::u0_sigma / u0`).
pub const IMAP_REGION_UNIFORMITY: u32 = 2;

/// One point of the error-against-time history. Filled by the library (`struct_size` says
/// how many bytes of it are valid).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct ImapProgress {
    /// Bytes of this struct the library filled.
    pub struct_size: u32,
    /// Run time, s, summed over the runs since the last reset.
    pub elapsed_s: f64,
    /// Photons traced since the last reset.
    pub photons: u64,
    /// Ray–surface intersections since the last reset.
    pub hits: u64,
    /// Estimated global relative error: Σ σ(E_v) / Σ E_v over all recorded vertex sides
    /// (the irradiance-weighted mean of the per-vertex relative standard errors); 1 before
    /// anything arrived.
    pub rel_error: f64,
    /// The region target's measure (`ImapRunParams::region_measure`); 0 when the run has
    /// no region target, 1 before the chosen meshes received anything. (Since 0.2.1.)
    pub region_rel_error: f64,
}

// SAFETY: repr(C), u32 struct_size first, plain numbers only.
unsafe impl Versioned for ImapProgress {
    const NAME: &'static str = "ImapProgress";
    const INIT: &'static str = "sizeof";
    /// The 0.2 layout, before `region_rel_error`.
    const BASE_SIZE: usize = std::mem::offset_of!(ImapProgress, region_rel_error);
    fn defaults() -> Self {
        ImapProgress {
            struct_size: std::mem::size_of::<Self>() as u32,
            ..Default::default()
        }
    }
}

/// Progress callback: called from the thread inside `imap_run` at each progress interval
/// and once at the end. Return 0 to continue, non-zero to stop the run (the map keeps
/// every photon traced to its end; a later `imap_run` continues). It must not call the same
/// context (that returns IMAP_ERR_BUSY) and must not throw C++ exceptions.
pub type ImapProgressFn =
    Option<unsafe extern "C" fn(progress: *const ImapProgress, user_data: *mut c_void) -> i32>;

/// What `imap_run` does. Initialise with `imap_run_params_default(&p, sizeof p)`; at least
/// one stop criterion (photons, time budget, target error) or a callback is required.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapRunParams {
    /// `sizeof(ImapRunParams)` as the program was compiled; set by `imap_run_params_default`.
    pub struct_size: u32,
    /// Safety limit on events (surface events and scatterings in a medium) per photon path
    /// (≥ 1); photons reaching it are counted in `ImapReport::dropped_w` (never silently).
    pub max_path_events: u32,
    /// Photons to trace in this run; 0 = no limit.
    pub photons: u64,
    /// Wall-clock seconds this run may take, ≥ 0; 0 = no limit. Any finite value works
    /// (1e300 is "no limit" too).
    pub time_budget_s: f64,
    /// Stop when the estimated global relative error is at or below this; 0 = none.
    pub target_rel_error: f64,
    /// Seconds between progress reports and stop checks, > 0. Values below 0.001 s are
    /// raised to 0.001 s, and the interval is lengthened while evaluating the error would
    /// cost more than 5 % of it in CPU time; the history keeps at most 4096 points (older
    /// ones are thinned out evenly).
    pub progress_interval_s: f64,
    pub progress: ImapProgressFn,
    /// Passed to `progress` unchanged.
    pub user_data: *mut c_void,
    /// Stop when `region_measure` over the meshes `region_meshes[0 .. region_mesh_count)`
    /// (recording meshes: a calculation grid's sensor, a floor) is at or below this; 0 =
    /// none. Checked at each progress interval. (Since 0.2.1.)
    pub region_target: f64,
    /// `IMAP_REGION_VERTICES` (default), `IMAP_REGION_AVERAGE` or `IMAP_REGION_UNIFORMITY`.
    pub region_measure: u32,
    /// Meshes in `region_meshes`.
    pub region_mesh_count: u32,
    /// Mesh ids; read during `imap_run` only.
    pub region_meshes: *const u32,
    /// The percentile of `IMAP_REGION_VERTICES`, in (0, 100]; 0 = 100 (the largest error).
    pub region_percentile: f64,
    /// Non-zero: only the meshes' triangles of material `region_part` (a part: e.g. a
    /// grid's points without a guard ring around them) and the vertices they touch.
    pub region_part_only: u32,
    pub region_part: u32,
    /// The photon indices this run may trace (since 0.2.2): `[photon_first, photon_first +
    /// photon_count)` (`photon_count` 0 = no end), and of those only shard `shard_index` of
    /// `shard_count`: blocks of `shard_block` photons (a multiple of 64; 0 = 65536) dealt
    /// round robin. Photon k's path depends only on the seed and k, so processes running
    /// the shards 0 … N−1 of one range trace each of its photons exactly once, whatever
    /// each one's stop criterion, and their states merge (`imap_state_merge`) into the map
    /// of one process tracing the same photons (equal up to summation order, ~1e-15
    /// relative). A run traces the lowest indices of its selection the map does not hold
    /// yet; `photons` still counts this run's photons. Defaults: 0, 0, 1, 0, 0 (every
    /// photon, one process).
    pub photon_first: u64,
    pub photon_count: u64,
    pub shard_count: u64,
    pub shard_index: u64,
    pub shard_block: u64,
    /// How the map is estimated (since 0.2.2): `IMAP_ESTIMATOR_DEFAULT` (0: the estimator
    /// of the photons the map holds, light sampling for an empty map),
    /// `IMAP_ESTIMATOR_PHOTONS` (the first paper's method: photons deposit everything),
    /// `IMAP_ESTIMATOR_LIGHT_SAMPLING` (direct light by shadow rays from points spread over
    /// each vertex's support to points on the lights, chosen by power, with multiple
    /// importance sampling against the photons; photons then bring the indirect part) or
    /// `IMAP_ESTIMATOR_GATHER` (light sampling, and the passes also gather diffusely
    /// reflected light by paths from the vertices with a light sample at every diffuse
    /// surface they meet, combined with the photons' by multiple importance sampling;
    /// photons alone bring light through dielectrics and light whose first surface event
    /// is specular). All are unbiased and give the same map in expectation; light sampling
    /// reaches a given error several times sooner where direct light dominates; gathering
    /// is fastest on finely meshed scenes of moderate reflectance and slower than light
    /// sampling alone on coarse, highly reflective ones (docs/estimators.md). A map holds
    /// the photons of one estimator: changing it needs `imap_reset` (IMAP_ERR_OUT_OF_ORDER
    /// otherwise). The estimator is part of a state's settings.
    pub estimator: u32,
    /// Light sampling and gathering: samples per vertex per pass (stratified: an
    /// Owen-scrambled Sobol set of its own per vertex and pass; at most 1024); 0 = 4 (16
    /// when gathering). Vertices of sensor meshes take 4 times as many (at most 1024), on
    /// passes of their own whose work is an eighth of the others' per photon.
    pub direct_samples: u32,
    /// Light sampling and gathering: photons per pass (each vertex gets one pass of
    /// `direct_samples` samples per this many photons; photon k does its share of pass
    /// k / this, so the passes belong to photon indices like the rest of the map); at least
    /// the vertex sides over 16; 0 = chosen from the scene (light sampling: about half as
    /// many samples as photons; gathering: one photon per 64 samples, per 4 in scenes with
    /// specular surfaces or dielectrics).
    pub direct_pass_photons: u64,
}

/// `ImapRunParams::estimator`: the map's (light sampling for an empty map). (Since 0.2.2.)
pub const IMAP_ESTIMATOR_DEFAULT: u32 = 0;
/// `ImapRunParams::estimator`: photons only (the first paper's method). (Since 0.2.2.)
pub const IMAP_ESTIMATOR_PHOTONS: u32 = 1;
/// `ImapRunParams::estimator`: direct light by light sampling at the vertices, photons for
/// the indirect part. (Since 0.2.2.)
pub const IMAP_ESTIMATOR_LIGHT_SAMPLING: u32 = 2;
/// `ImapRunParams::estimator`: light sampling, and the passes gather diffusely reflected
/// light too. (Since 0.2.2.)
pub const IMAP_ESTIMATOR_GATHER: u32 = 3;

// SAFETY: repr(C), u32 struct_size first, numbers, an Option<fn> and a raw pointer.
unsafe impl Versioned for ImapRunParams {
    const NAME: &'static str = "ImapRunParams";
    const INIT: &'static str = "imap_run_params_default";
    /// The 0.2 layout, before the region target.
    const BASE_SIZE: usize = std::mem::offset_of!(ImapRunParams, region_target);
    fn defaults() -> Self {
        ImapRunParams {
            struct_size: std::mem::size_of::<Self>() as u32,
            max_path_events: 1 << 20,
            photons: 0,
            time_budget_s: 0.0,
            target_rel_error: 0.0,
            progress_interval_s: 0.5,
            progress: None,
            user_data: std::ptr::null_mut(),
            region_target: 0.0,
            region_measure: IMAP_REGION_VERTICES,
            region_mesh_count: 0,
            region_meshes: std::ptr::null(),
            region_percentile: 0.0,
            region_part_only: 0,
            region_part: 0,
            photon_first: 0,
            photon_count: 0,
            shard_count: 1,
            shard_index: 0,
            shard_block: 0,
            estimator: IMAP_ESTIMATOR_DEFAULT,
            direct_samples: 0,
            direct_pass_photons: 0,
        }
    }
}

/// The estimator of C run parameters (None: the map's, `current`, which settings given
/// with `IMAP_ESTIMATOR_DEFAULT` tune).
fn estimator(p: &ImapRunParams, current: Estimator) -> Result<Option<Estimator>> {
    let ls = |gather| Estimator::LightSampling {
        samples: p.direct_samples,
        pass_photons: p.direct_pass_photons,
        gather,
    };
    let tuned = p.direct_samples != 0 || p.direct_pass_photons != 0;
    Ok(match p.estimator {
        IMAP_ESTIMATOR_DEFAULT if tuned => Some(ls(matches!(
            current,
            Estimator::LightSampling { gather: true, .. }
        ))),
        IMAP_ESTIMATOR_DEFAULT => None,
        IMAP_ESTIMATOR_PHOTONS if tuned => bail!(
            ImapErrInvalidArgument,
            "params.direct_samples / direct_pass_photons are for IMAP_ESTIMATOR_LIGHT_SAMPLING and IMAP_ESTIMATOR_GATHER, not IMAP_ESTIMATOR_PHOTONS"
        ),
        IMAP_ESTIMATOR_PHOTONS => Some(Estimator::Photons),
        IMAP_ESTIMATOR_LIGHT_SAMPLING => Some(ls(false)),
        IMAP_ESTIMATOR_GATHER => Some(ls(true)),
        e => bail!(
            ImapErrInvalidArgument,
            "params.estimator = {e} is not an IMAP_ESTIMATOR_* value"
        ),
    })
}

/// The photon selection of run parameters (`ImapRunParams::photon_first` …).
fn selection(p: &ImapRunParams) -> crate::sched::Selection {
    crate::sched::Selection {
        first: p.photon_first,
        end: match p.photon_count {
            0 => u64::MAX,
            n => p.photon_first.saturating_add(n),
        },
        shards: p.shard_count,
        shard: p.shard_index,
        block: match p.shard_block {
            0 => crate::sched::photons::DEFAULT_BLOCK,
            b => b,
        },
    }
}

/// Totals since the last reset, the last run's own figures and the scheduler's counters.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct ImapReport {
    /// Bytes of this struct the library filled.
    pub struct_size: u32,
    /// `IMAP_STOP_*`: why the last run stopped.
    pub stop_reason: u32,
    /// Calculating threads of the last run.
    pub threads: u32,
    /// Photons traced since the last reset.
    pub photons: u64,
    /// Ray–surface intersections since the last reset.
    pub hits: u64,
    /// Run time since the last reset, s.
    pub elapsed_s: f64,
    /// Estimated global relative error (see `ImapProgress::rel_error`).
    pub rel_error: f64,
    /// Photons of the last run.
    pub run_photons: u64,
    /// Intersections of the last run.
    pub run_hits: u64,
    /// Wall time of the last run, s.
    pub run_wall_s: f64,
    /// Radiant power the traced photons carried from the lights, W: the sum over the bands
    /// of their watts (a light of 12.57 W in each of 3 bands emits 37.7 W). Its expectation
    /// is the lights' total power, which it equals exactly with one light.
    pub emitted_w: f64,
    /// Power absorbed by all surfaces and media, W (estimate from the photons traced;
    /// with fluorescent surfaces it includes what they re-emit: emitted + fluoresced =
    /// absorbed + escaped + dropped).
    pub absorbed_w: f64,
    /// Power leaving the scene, W.
    pub escaped_w: f64,
    /// Power of photons stopped by `max_path_events`, W.
    pub dropped_w: f64,
    /// Photons stopped by `max_path_events`.
    pub dropped_photons: u64,
    /// Seconds the calculating threads together waited for a free portion (last run).
    pub calc_wait_s: f64,
    /// Classic: fraction of the last run the accumulating thread spent applying portions.
    /// Dynamic: time spent applying portions over the processing threads' lifetime.
    pub accum_busy_fraction: f64,
    /// Largest number of filled portions waiting to be applied (last run).
    pub peak_queue: u64,
    /// Portions applied (last run).
    pub portions: u64,
    /// Of those, portions a calculating thread applied itself because the group was idle
    /// (dynamic scheduler, last run).
    pub inline_portions: u64,
    /// Vertex-group splits (dynamic scheduler; 0 for classic).
    pub splits: u64,
    /// Vertex groups at the end of the last run (1 for classic).
    pub groups: u64,
    /// Bytes held by the map.
    pub map_bytes: u64,
    /// Points in the error-against-time history (`imap_get_history`).
    pub history_len: u64,
    /// The balance above in lumens: each band's watts times its luminous efficacy
    /// (docs/photometry.md). Per band: `imap_get_band_balance`. (Since 0.2.1.)
    pub emitted_lm: f64,
    pub absorbed_lm: f64,
    pub escaped_lm: f64,
    pub dropped_lm: f64,
    /// The context's band count.
    pub bands: u64,
    /// What fluorescent surfaces re-emitted (`ImapMaterial::fluorescence`), W and lm; 0
    /// without them. Per band: `imap_get_band_balance` with IMAP_BALANCE_FLUORESCED.
    /// (Since 0.2.3.)
    pub fluoresced_w: f64,
    pub fluoresced_lm: f64,
}

// SAFETY: repr(C), u32 struct_size first, plain numbers only.
unsafe impl Versioned for ImapReport {
    const NAME: &'static str = "ImapReport";
    const INIT: &'static str = "sizeof";
    /// The 0.2 layout, before the luminous balance was appended.
    const BASE_SIZE: usize = std::mem::offset_of!(ImapReport, emitted_lm);
    fn defaults() -> Self {
        ImapReport::default()
    }
}

/// Fills the `size` bytes at `out` with run defaults and sets `struct_size = size`: no stop
/// criterion set (set at least one), progress every 0.5 s, at most 2^20 events per path,
/// no callback. Pass `sizeof *out`.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_INVALID_ARGUMENT (size too small). Thread-safe.
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_run_params_default(
    out: *mut ImapRunParams,
    size: usize,
) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

pub(crate) fn progress_to_c(p: &Progress) -> ImapProgress {
    ImapProgress {
        struct_size: std::mem::size_of::<ImapProgress>() as u32,
        elapsed_s: p.elapsed_s,
        photons: p.photons,
        hits: p.hits,
        rel_error: p.rel_error,
        region_rel_error: p.region_rel_error,
    }
}

pub(crate) fn stop_to_c(stop: Option<StopReason>) -> u32 {
    match stop {
        None => IMAP_STOP_NONE,
        Some(StopReason::PhotonCount) => IMAP_STOP_PHOTONS,
        Some(StopReason::TimeBudget) => IMAP_STOP_TIME,
        Some(StopReason::TargetError) => IMAP_STOP_TARGET_ERROR,
        Some(StopReason::Cancelled) => IMAP_STOP_CANCELLED,
        Some(StopReason::RegionTarget) => IMAP_STOP_REGION_TARGET,
    }
}

fn report_to_c(r: &Report, history_len: usize) -> ImapReport {
    ImapReport {
        struct_size: std::mem::size_of::<ImapReport>() as u32,
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
        emitted_lm: r.emitted_lm,
        absorbed_lm: r.absorbed_lm,
        escaped_lm: r.escaped_lm,
        dropped_lm: r.dropped_lm,
        bands: r.band_w[0].len() as u64,
        fluoresced_w: r.fluoresced_w,
        fluoresced_lm: r.fluoresced_lm,
    }
}

/// Checks a report out-pointer and its size before a call's work.
pub(crate) fn check_report_out<T: Versioned>(name: &str, out: *mut T, size: usize) -> Result<()> {
    if !out.is_null() && size < T::BASE_SIZE {
        bail!(
            ImapErrInvalidArgument,
            "{name}_size = {size} is smaller than {} ({} bytes): pass sizeof({})",
            T::NAME,
            T::BASE_SIZE,
            T::NAME
        );
    }
    Ok(())
}

/// The C view of the progress callback.
pub(crate) fn callback(cb: ImapProgressFn, user: *mut c_void) -> impl FnMut(&Progress) -> bool {
    move |pr: &Progress| -> bool {
        let cp = progress_to_c(pr);
        // SAFETY: the caller supplied a callable function pointer and its user data.
        cb.is_none_or(|f| unsafe { f(&cp, user) } == 0)
    }
}

/// Traces photons into the map until a stop criterion of `params` is met; blocks the
/// calling thread, which also runs the progress callback. The first run builds the BVH and
/// allocates the map. A later run continues the photon sequence and adds to the same map
/// (a run stopped by the callback or the clock can be resumed: photons cut short by the
/// stop are traced again from their start by the next run, so the map is always a sum of
/// whole photons). `report` (may be NULL) receives the report on success, `report_size` =
/// `sizeof(ImapReport)`.
///
/// The run stops within about two progress intervals of its time budget or of a cancel,
/// whatever the path length.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_INVALID_ARGUMENT (no stop criterion, negative
/// values, struct sizes; the message names the field), IMAP_ERR_NON_FINITE,
/// IMAP_ERR_NO_GEOMETRY, IMAP_ERR_NO_LIGHT, IMAP_ERR_PRECISION, IMAP_ERR_MEMORY_BUDGET,
/// IMAP_ERR_OUT_OF_MEMORY, IMAP_ERR_EMBREE, IMAP_ERR_BUSY, IMAP_ERR_THREAD_LOST (a worker
/// thread panicked — a bug, please report it: what it had not yet handed over is missing
/// from the map while its photons are counted; reset and run again for an exact map).
///
/// # Safety
/// `ctx` is a live handle; `params` points to an `ImapRunParams`; `report` is NULL or
/// points to `report_size` writable bytes; the callback, if any, is callable with
/// `user_data`.
#[no_mangle]
pub unsafe extern "C" fn imap_run(
    ctx: *mut ImapContext,
    params: *const ImapRunParams,
    report: *mut ImapReport,
    report_size: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        let p = read_versioned("params", params)?;
        check_report_out("report", report, report_size)?;
        let region = region_target(&p)?;
        let mut call = callback(p.progress, p.user_data);
        let mut rp = RunParams {
            region,
            photons: p.photons,
            time_budget_s: p.time_budget_s,
            target_rel_error: p.target_rel_error,
            progress_interval_s: p.progress_interval_s,
            max_path_events: p.max_path_events,
            progress: if p.progress.is_some() {
                Some(&mut call)
            } else {
                None
            },
            selection: selection(&p),
            estimator: estimator(&p, c.estimator())?,
        };
        let r = c.run(&mut rp)?;
        if !report.is_null() {
            write_versioned(
                "report",
                report,
                report_size,
                report_to_c(&r, c.history().len()),
            )?;
        }
        Ok(())
    })
}

/// The region target of C run parameters.
fn region_target(p: &ImapRunParams) -> Result<Option<RegionTarget>> {
    crate::error::check_finite_scalar("params.region_target", p.region_target)?;
    if p.region_target == 0.0 {
        return Ok(None);
    }
    if p.region_target < 0.0 {
        bail!(
            ImapErrInvalidArgument,
            "params.region_target = {} is negative (0 means no region target)",
            p.region_target
        );
    }
    let measure = match p.region_measure {
        IMAP_REGION_VERTICES => RegionMeasure::Vertices {
            percentile: if p.region_percentile == 0.0 {
                100.0
            } else {
                p.region_percentile
            },
        },
        IMAP_REGION_AVERAGE => RegionMeasure::Average,
        IMAP_REGION_UNIFORMITY => RegionMeasure::Uniformity,
        m => bail!(
            ImapErrInvalidArgument,
            "params.region_measure = {m} is not an IMAP_REGION_* value (0–2)"
        ),
    };
    let meshes = super::slice(
        "params.region_meshes",
        p.region_meshes,
        p.region_mesh_count as usize,
    )?;
    Ok(Some(RegionTarget {
        meshes: meshes.iter().map(|&m| m as usize).collect(),
        part: (p.region_part_only != 0).then_some(p.region_part),
        measure,
        target: p.region_target,
    }))
}

/// Copies up to `capacity` points of `h` into `out` (elements of `element_size` bytes)
/// and the total count into `*out_count`.
pub(crate) fn copy_history(
    h: &[Progress],
    out: *mut ImapProgress,
    capacity: usize,
    element_size: usize,
    out_count: *mut usize,
) -> Result<()> {
    check_out("out_count", out_count)?;
    super::check_elements("out", out, capacity, element_size)?;
    if capacity > 0 {
        for (i, p) in h.iter().take(capacity).enumerate() {
            // SAFETY: the caller provides capacity × element_size writable bytes at out.
            let dst = unsafe { (out as *mut u8).add(i * element_size) } as *mut ImapProgress;
            write_versioned("out", dst, element_size, progress_to_c(p))?;
        }
    }
    write_out("out_count", out_count, h.len())
}

/// The report of the context: totals since the last reset and the last run's figures.
/// `size` = `sizeof(ImapReport)`.
///
/// # Safety
/// `ctx` is a live handle; `out` points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_get_report(
    ctx: *const ImapContext,
    out: *mut ImapReport,
    size: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        write_versioned(
            "out",
            out,
            size,
            report_to_c(&c.report(), c.history().len()),
        )
    })
}

/// Copies up to `capacity` points of the error-against-time history (oldest first) into
/// `out` (elements of `element_size` = `sizeof(ImapProgress)` bytes; `out` may be NULL
/// when `capacity` is 0) and writes the total number of points to `*out_count`.
///
/// # Safety
/// `ctx` is a live handle; `out` holds `capacity` writable elements; `out_count` is
/// writable.
#[no_mangle]
pub unsafe extern "C" fn imap_get_history(
    ctx: *const ImapContext,
    out: *mut ImapProgress,
    capacity: usize,
    element_size: usize,
    out_count: *mut usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        copy_history(c.history(), out, capacity, element_size, out_count)
    })
}

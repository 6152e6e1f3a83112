//! C-layout types of the API. Enumerated values travel as `uint32_t` with `#define`d
//! constants, so a wrong value from C is an error, never undefined behaviour.

use std::ffi::c_void;

/// Library version, major.
pub const IMAP_VERSION_MAJOR: u32 = 0;
/// Library version, minor.
pub const IMAP_VERSION_MINOR: u32 = 1;
/// Library version, patch.
pub const IMAP_VERSION_PATCH: u32 = 0;

/// `ImapConfig::band_mode`: three bands, R, G, B.
pub const IMAP_BANDS_RGB: u32 = 0;
/// `ImapConfig::band_mode`: `band_count` wavelengths from `wavelength_min_nm` to
/// `wavelength_max_nm` inclusive (41 over 380–780 nm are 10 nm steps).
pub const IMAP_BANDS_SPECTRAL: u32 = 1;

/// `ImapConfig::scheduler`: the classic scheme (calculating threads, one accumulating thread).
pub const IMAP_SCHEDULER_CLASSIC: u32 = 0;
/// `ImapConfig::scheduler`: vertex groups with one processing thread each, split into
/// `subd` subgroups under load (the default).
pub const IMAP_SCHEDULER_DYNAMIC: u32 = 1;

/// `ImapConfig::inline_apply`: a calculating thread applies a full portion itself when
/// the group's processing thread is idle, if the calculating threads alone fill the cores.
pub const IMAP_INLINE_AUTO: u32 = 0;
/// Always apply full portions on the spot when the group is idle.
pub const IMAP_INLINE_ALWAYS: u32 = 1;
/// Always hand portions to the processing threads (the paper's scheme as published).
pub const IMAP_INLINE_NEVER: u32 = 2;

/// `ImapMaterial::ior_model`: not a dielectric.
pub const IMAP_IOR_NONE: u32 = 0;
/// `n = ior[0]`.
pub const IMAP_IOR_CONSTANT: u32 = 1;
/// `n = ior[0] + ior[1]/λ² + ior[2]/λ⁴`, λ in µm.
pub const IMAP_IOR_CAUCHY: u32 = 2;
/// `n² = 1 + Σ ior[i]·λ²/(λ² − ior[i+3])`, i = 0..2, λ in µm (Schott's B1..B3, C1..C3).
pub const IMAP_IOR_SELLMEIER: u32 = 3;

/// `ImapMesh::flags`: both sides record (and emit) separately.
pub const IMAP_MESH_TWO_SIDED: u32 = 1;
/// `ImapMesh::flags`: the mesh's vertices accumulate irradiance.
pub const IMAP_MESH_RECORD: u32 = 2;

/// Side index of `imap_get_vertex_energy`: the side the normal (v1−v0)×(v2−v0) points to.
pub const IMAP_SIDE_FRONT: u32 = 0;
/// The other side (two-sided meshes only).
pub const IMAP_SIDE_BACK: u32 = 1;

/// `ImapReport::stop_reason` values.
pub const IMAP_STOP_NONE: u32 = 0;
/// The run traced its photon count.
pub const IMAP_STOP_PHOTONS: u32 = 1;
/// The run used its time budget.
pub const IMAP_STOP_TIME: u32 = 2;
/// The estimated error reached the target.
pub const IMAP_STOP_TARGET_ERROR: u32 = 3;
/// The progress callback asked to stop.
pub const IMAP_STOP_CANCELLED: u32 = 4;

/// Context settings, fixed at creation. Initialise with `imap_config_default`.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapConfig {
    /// `IMAP_BANDS_RGB` or `IMAP_BANDS_SPECTRAL`.
    pub band_mode: u32,
    /// Number of spectral bands (≥ 1); must be 3 in RGB mode.
    pub band_count: u32,
    /// Wavelength of the first spectral band, nm.
    pub wavelength_min_nm: f64,
    /// Wavelength of the last spectral band, nm.
    pub wavelength_max_nm: f64,
    /// Calculating threads; 0 = one per core.
    pub threads: u32,
    /// `IMAP_SCHEDULER_*`.
    pub scheduler: u32,
    /// Seed of the photons' random streams: the same seed gives the same map with any
    /// scheduler and thread count.
    pub seed: u64,
    /// Largest map in bytes; 0 = the default, 3/4 of physical memory. Checked when a mesh
    /// is added and before a run allocates anything (IMAP_ERR_MEMORY_BUDGET).
    pub memory_budget_bytes: u64,
    /// Metres per scene unit (irradiance is reported in W/m²).
    pub unit_m: f64,
    /// Dynamic scheduler: vertex groups at the start; 0 = one per calculating thread.
    pub initial_groups: u32,
    /// Dynamic scheduler: most groups ever (preallocated); 0 = 64 per calculating thread.
    pub max_groups: u32,
    /// Dynamic scheduler: subgroups per split, 2..=64 (the paper's 4).
    pub subd: u32,
    /// Dynamic scheduler: consider splitting while fewer free portions than this wait in
    /// the input stack; 0 = the number of calculating threads.
    pub split_low_threshold: u32,
    /// Dynamic scheduler: split only a group with at least this many queued portions;
    /// 0 = 3.
    pub split_high_threshold: u32,
    /// Dynamic scheduler: smallest subgroup a split may create, in vertex sides; 0 = 256.
    pub min_group_slots: u32,
    /// Dynamic scheduler: `IMAP_INLINE_*`.
    pub inline_apply: u32,
}

/// A material. Per-band arrays hold 1 value (the same in every band) or one per band;
/// a count of 0 (pointer may be NULL) means 0 in every band. The library copies them.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapMaterial {
    /// Probability of Lambertian reflection, [0, 1].
    pub diffuse_reflectance: *const f64,
    pub diffuse_reflectance_count: usize,
    /// Probability of mirror reflection, [0, 1].
    pub specular_reflectance: *const f64,
    pub specular_reflectance_count: usize,
    /// Probability of Lambertian transmission to the other side, [0, 1].
    pub diffuse_transmittance: *const f64,
    pub diffuse_transmittance_count: usize,
    /// `IMAP_IOR_*`. Anything but NONE makes a smooth dielectric (Fresnel reflection and
    /// Snell refraction; the three coefficients above must then be 0). Its mesh should be
    /// closed with normals pointing out; the outside is air (n = 1).
    pub ior_model: u32,
    /// Coefficients of the index model (see `IMAP_IOR_*`).
    pub ior: [f64; 6],
    /// Beer–Lambert absorption coefficient inside a dielectric, 1/m, per band.
    pub absorption_per_m: *const f64,
    pub absorption_count: usize,
}

/// A triangle mesh. The library copies every array.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapMesh {
    /// x, y, z of each vertex (3·vertex_count doubles), scene units.
    pub positions: *const f64,
    pub vertex_count: usize,
    /// Three vertex indices per triangle (3·triangle_count).
    pub indices: *const u32,
    pub triangle_count: usize,
    /// Material id (from `imap_add_material`) of every triangle.
    pub material: u32,
    /// Optional per-triangle material ids (the mesh's parts), triangle_count of them;
    /// NULL = all triangles use `material`.
    pub triangle_materials: *const u32,
    /// `IMAP_MESH_TWO_SIDED` | `IMAP_MESH_RECORD`.
    pub flags: u32,
    /// Radiant exitance of a self-emitting mesh (a lamp), W/m² per band, Lambertian, from
    /// the front side (both sides if two-sided); NULL/0 = not emitting.
    pub exitance: *const f64,
    pub exitance_count: usize,
}

/// One point of the error-against-time history.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct ImapProgress {
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
}

/// Progress callback: called from the thread inside `imap_run` at each progress interval
/// and once at the end. Return 0 to continue, non-zero to stop the run (the map keeps
/// everything traced; a later `imap_run` continues). It must not call the same context
/// (that returns IMAP_ERR_BUSY) and must not throw C++ exceptions.
pub type ImapProgressFn =
    Option<unsafe extern "C" fn(progress: *const ImapProgress, user_data: *mut c_void) -> i32>;

/// What `imap_run` does. Initialise with `imap_run_params_default`; at least one stop
/// criterion (photons, time budget, target error) or a callback is required.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapRunParams {
    /// Photons to trace in this run; 0 = no limit.
    pub photons: u64,
    /// Wall-clock seconds this run may take; 0 = no limit.
    pub time_budget_s: f64,
    /// Stop when the estimated global relative error is at or below this; 0 = none.
    pub target_rel_error: f64,
    /// Seconds between progress reports and target checks (> 0).
    pub progress_interval_s: f64,
    /// Safety limit on surface events per photon path; photons reaching it are counted
    /// in `ImapReport::dropped_w` (never silently).
    pub max_path_events: u32,
    pub progress: ImapProgressFn,
    /// Passed to `progress` unchanged.
    pub user_data: *mut c_void,
}

/// Totals since the last reset, the last run's own figures and the scheduler's counters.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct ImapReport {
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
    /// `IMAP_STOP_*`: why the last run stopped.
    pub stop_reason: u32,
    /// Calculating threads of the last run.
    pub threads: u32,
    /// Power the traced photons carried from the lights, W (summed over bands); its
    /// expectation is the lights' total power, which it equals exactly with one light.
    pub emitted_w: f64,
    /// Power absorbed by all surfaces and media, W (estimate from the photons traced).
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
}

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

/// A pinhole camera, in scene units. Pixel rows run from the top of the image down.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct ImapCamera {
    /// Eye point.
    pub position: [f64; 3],
    /// Viewing direction (any non-zero length).
    pub direction: [f64; 3],
    /// Up vector; only its part across `direction` counts, and it must not be parallel.
    pub up: [f64; 3],
    /// Full vertical field of view, degrees, in (0, 180).
    pub fov_y_deg: f64,
    /// Image size in pixels, each side in 1..=16384.
    pub width: u32,
    pub height: u32,
}

/// What `imap_render` does. Initialise with `imap_render_params_default`; at least one
/// stop criterion (passes, time budget, target error) or a callback is required.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapRenderParams {
    /// `IMAP_RENDER_*`.
    pub method: u32,
    /// Semi-synchronous: threads per group (0 = 1; groups = threads / group_threads).
    pub group_threads: u32,
    /// Semi-synchronous: phases between re-randomised tile masks (0 = 4).
    pub remask_phases: u32,
    /// Safety limit on surface events per path (≥ 1); longer paths are dropped and counted
    /// in `ImapRenderReport::dropped_paths`.
    pub max_path_events: u32,
    /// Forward photons per pass over the image (0 = one per pixel).
    pub forward_per_pass: u64,
    /// Stop after this many samples per pixel, on average (0 = no limit).
    pub passes: u64,
    /// First gathering radius, scene units (0 = four pixel footprints at the first
    /// diffuse vertex).
    pub initial_radius: f64,
    /// Progressive radius reduction α in (0, 1) (0 = 2/3).
    pub alpha: f64,
    /// Wall-clock seconds the render may take; 0 = no limit.
    pub time_budget_s: f64,
    /// Stop when the estimated global relative error of the image is at or below this;
    /// 0 = none.
    pub target_rel_error: f64,
    /// Seconds between progress reports and stop checks (> 0).
    pub progress_interval_s: f64,
    /// Called as for `imap_run`; in the `ImapProgress` it receives, `photons` counts
    /// forward photons, `hits` backward paths (one per pixel sample) and `rel_error` is
    /// the image's estimated global relative error.
    pub progress: ImapProgressFn,
    /// Passed to `progress` unchanged.
    pub user_data: *mut c_void,
}

/// Figures of the last render.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct ImapRenderReport {
    /// Worker threads, groups of them, threads per group.
    pub threads: u32,
    pub groups: u32,
    pub threads_per_group: u32,
    /// `IMAP_STOP_*`: why the render stopped (`IMAP_STOP_PHOTONS` = the passes limit).
    pub stop_reason: u32,
    /// Group phases completed; each adds one sample to the pixels of its group's mask.
    pub phases: u64,
    /// Samples per pixel, averaged over the image.
    pub passes: f64,
    /// Backward paths (pixel samples) and the rays they traced (shadow rays included).
    pub backward_paths: u64,
    pub backward_rays: u64,
    /// Forward photons from the lights and the rays they traced.
    pub forward_photons: u64,
    pub forward_rays: u64,
    /// Forward photon hits that fell within a backward photon's radius.
    pub gathers: u64,
    /// Backward paths dropped at `max_path_events`.
    pub dropped_paths: u64,
    /// Wall time, s.
    pub wall_s: f64,
    /// Estimated global relative error of the image: RMS of the pixels' standard errors
    /// over their mean luminance.
    pub rel_error: f64,
    /// Seconds summed over groups (each measured by its leader thread): backward paths,
    /// building the maps, forward photons, closing the maps (tracing on while other groups
    /// still read them), finalizing the phase's samples.
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
    /// Largest backward-photon-map memory of one group, bytes.
    pub map_bytes_per_group: u64,
    /// Pixel stores, bytes (one per thread for the asynchronous method).
    pub pixel_bytes: u64,
    /// All maps and pixel stores, bytes.
    pub total_bytes: u64,
    /// Points in the accuracy history (`imap_get_render_history`).
    pub history_len: u64,
}

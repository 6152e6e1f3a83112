//! Region results: a mesh side's (or a part's) incident flux, average, minimum and maximum
//! illuminance and uniformities with their standard errors, and the vertices' areas.
//! docs/results.md states what each figure means and how its error is computed.

use super::{
    copy_bands, slice_mut, with_context, write_out, write_versioned, ImapContext, Versioned,
};
use crate::context::RegionStats;
use crate::error::{bail, ImapStatus};

/// `part` argument of the region functions: the whole mesh side, all its materials.
pub const IMAP_ALL_PARTS: u32 = u32::MAX;

/// `mesh` argument of `imap_get_medium_absorbed`: the scene's medium, outside the meshes
/// (`imap_set_scene_medium`). (Since 0.2.3.)
pub const IMAP_SCENE_MEDIUM: u32 = u32::MAX;
const _: () = assert!(IMAP_SCENE_MEDIUM == crate::transport::SCENE_MEDIUM);

/// A region's figures (`imap_get_region_stats`), each with its standard error (`*_sigma`,
/// the same unit). Filled by the library; `struct_size` says how many bytes are valid.
/// (Since 0.2.1.)
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct ImapRegionStats {
    /// Bytes of this struct the library filled.
    pub struct_size: u32,
    /// Vertices with a share of the region's triangles.
    pub vertices: u32,
    /// Photons the figures are made of (0: no run yet; every figure below is then 0).
    pub photons: u64,
    /// The region's area, m².
    pub area_m2: f64,
    /// Incident luminous flux, lm, summed photon by photon over the region (its error is
    /// the exact Monte Carlo error of that sum).
    pub flux_lm: f64,
    pub flux_lm_sigma: f64,
    /// Average illuminance Eavg = flux_lm / area_m2, lx.
    pub average_lx: f64,
    pub average_lx_sigma: f64,
    /// Minimum and maximum vertex illuminance, lx, corrected for the bias of the extremes
    /// of noisy values (parametric bootstrap around a shrunk field; docs/results.md).
    pub min_lx: f64,
    pub min_lx_sigma: f64,
    pub max_lx: f64,
    pub max_lx_sigma: f64,
    /// Uniformity U0 = Emin / Eavg and Ud = Emin / Emax (corrected likewise).
    pub u0: f64,
    pub u0_sigma: f64,
    pub ud: f64,
    pub ud_sigma: f64,
    /// The smallest and largest vertex illuminance as observed (uncorrected), lx.
    pub min_observed_lx: f64,
    pub max_observed_lx: f64,
    /// 1: `flux_lm_sigma` and `average_lx_sigma` are exact Monte Carlo errors (a sensor,
    /// or a mesh added with IMAP_MESH_TALLY); 0: an upper bound, Σ over the vertices of
    /// area × standard error (the region's flux is then summed from its vertices).
    pub errors_exact: u32,
    /// Vertices that received no light at all (no photon, no light sample: under or
    /// inside an object). They are left out of the minimum, maximum and uniformities, and
    /// of region targets on the vertices' errors. (Since 0.2.3.)
    pub unlit_vertices: u64,
}

// SAFETY: repr(C), u32 struct_size first, plain numbers only.
unsafe impl Versioned for ImapRegionStats {
    const NAME: &'static str = "ImapRegionStats";
    const INIT: &'static str = "sizeof";
    /// The layout of 0.2.1, before `unlit_vertices`.
    const BASE_SIZE: usize = std::mem::offset_of!(ImapRegionStats, unlit_vertices);
    fn defaults() -> Self {
        ImapRegionStats::default()
    }
}

pub(super) fn part_of(part: u32) -> Option<u32> {
    (part != IMAP_ALL_PARTS).then_some(part)
}

pub(super) fn stats_to_c(s: &RegionStats) -> ImapRegionStats {
    let x = s.extremes.unwrap_or_default();
    ImapRegionStats {
        struct_size: std::mem::size_of::<ImapRegionStats>() as u32,
        vertices: s.vertices.min(u32::MAX as usize) as u32,
        photons: s.photons,
        area_m2: s.area_m2,
        flux_lm: s.flux_lm.value,
        flux_lm_sigma: s.flux_lm.sigma,
        average_lx: s.average.value,
        average_lx_sigma: s.average.sigma,
        min_lx: x.min.value,
        min_lx_sigma: x.min.sigma,
        max_lx: x.max.value,
        max_lx_sigma: x.max.sigma,
        u0: x.u0.value,
        u0_sigma: x.u0.sigma,
        ud: x.ud.value,
        ud_sigma: x.ud.sigma,
        min_observed_lx: x.min_observed,
        max_observed_lx: x.max_observed,
        errors_exact: u32::from(s.exact_errors),
        unlit_vertices: s.unlit_vertices as u64,
    }
}

/// The figures of recording mesh `mesh` on `side` (`IMAP_SIDE_FRONT`/`_BACK`), of the
/// whole side (`part` = `IMAP_ALL_PARTS`) or of its triangles of material `part`.
/// `size` = `sizeof(ImapRegionStats)`. Before any photon only `area_m2` and `vertices`
/// are set. Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_INVALID_ARGUMENT (size),
/// IMAP_ERR_INDEX_OUT_OF_RANGE (mesh, side, or a material the mesh has no triangle of),
/// IMAP_ERR_NOT_RECORDED, IMAP_ERR_BUSY.
///
/// # Safety
/// `ctx` is a live handle; `out` points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_get_region_stats(
    ctx: *const ImapContext,
    mesh: u32,
    side: u32,
    part: u32,
    out: *mut ImapRegionStats,
    size: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        super::check_out("out", out)?;
        let s = c.region_stats(mesh, side, part_of(part))?;
        write_versioned("out", out, size, stats_to_c(&s))
    })
}

/// The region's incident radiant flux per band, W, and its standard error:
/// `out[2b]` = flux of band b, `out[2b + 1]` = its standard error, for b < band count
/// (`count` ≥ 2 × band count). Arguments and statuses as `imap_get_region_stats`
/// (IMAP_ERR_BUFFER_TOO_SMALL when `count` is short). Zeros before any photon.
///
/// # Safety
/// `ctx` is a live handle; `out` holds `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_get_region_band_flux(
    ctx: *const ImapContext,
    mesh: u32,
    side: u32,
    part: u32,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        let out = slice_mut("out", out, count)?;
        let s = c.region_stats(mesh, side, part_of(part))?;
        let need = 2 * s.flux_w.len();
        if out.len() < need {
            bail!(
                ImapErrBufferTooSmall,
                "out holds {} values but the region's band fluxes and errors need {need} (2 × {} bands)",
                out.len(),
                s.flux_w.len()
            );
        }
        for (o, e) in out.chunks_exact_mut(2).zip(&s.flux_w) {
            o[0] = e.value;
            o[1] = e.sigma;
        }
        Ok(())
    })
}

/// `imap_get_band_balance`: what the photons carried from the lights.
pub const IMAP_BALANCE_EMITTED: u32 = 0;

/// `imap_get_band_balance`: what all surfaces and media absorbed.
pub const IMAP_BALANCE_ABSORBED: u32 = 1;

/// `imap_get_band_balance`: what left the scene.
pub const IMAP_BALANCE_ESCAPED: u32 = 2;

/// `imap_get_band_balance`: what `max_path_events` dropped.
pub const IMAP_BALANCE_DROPPED: u32 = 3;

/// `imap_get_band_balance`: what fluorescent surfaces re-emitted into each band (then
/// emitted + fluoresced = absorbed + escaped + dropped per band, and absorbed includes what
/// the surfaces took to re-emit). (Since 0.2.3.)
pub const IMAP_BALANCE_FLUORESCED: u32 = 4;

/// The power balance per band since the last reset, W per band, into `out[0 .. band
/// count)`: `IMAP_BALANCE_EMITTED`, `_ABSORBED`, `_ESCAPED`, `_DROPPED` or `_FLUORESCED` (their sums are
/// `ImapReport`'s `emitted_w` …, their luminous values its `emitted_lm` …). Zeros before
/// the first run.
///
/// # Safety
/// `ctx` is a live handle; `out` holds `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_get_band_balance(
    ctx: *const ImapContext,
    kind: u32,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        if kind > IMAP_BALANCE_FLUORESCED {
            bail!(
                ImapErrInvalidArgument,
                "kind = {kind} is not an IMAP_BALANCE_* value (0–4)"
            );
        }
        copy_bands(out, count, &c.report().band_w[kind as usize])
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

/// What the medium inside mesh `mesh` absorbed since the last reset (a dielectric with
/// `absorption_per_m` or `scattering_per_m`: light guides, diffusers, haze in a box), with
/// standard errors from the photons' own totals there. Into `out`, 2 × (bands + 1) doubles:
/// per band its power, W, and that power's standard error; then the same in lm. What the
/// mesh's surfaces absorb (a print on a light guide) does not count here;
/// `imap_get_mesh_absorbed` has both, summed over bands. `mesh` = IMAP_SCENE_MEDIUM: what
/// the scene's medium absorbed (`imap_set_scene_medium`; the report's `absorbed_w`
/// includes it). (Since 0.2.3.)
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_INDEX_OUT_OF_RANGE (no such mesh),
/// IMAP_ERR_INVALID_ARGUMENT (none of its materials holds a medium; IMAP_SCENE_MEDIUM
/// without a scene medium),
/// IMAP_ERR_BUFFER_TOO_SMALL. Zeros before the first run.
///
/// # Safety
/// `ctx` is a live handle; `out` holds `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_get_medium_absorbed(
    ctx: *const ImapContext,
    mesh: u32,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        let out = slice_mut("out", out, count)?;
        let a = c.medium_absorbed(mesh)?;
        let need = 2 * (a.band_w.len() + 1);
        if out.len() < need {
            bail!(
                ImapErrBufferTooSmall,
                "out holds {} values but the medium's band powers, its lm and their errors need {need} (2 × ({} bands + 1))",
                out.len(),
                a.band_w.len()
            );
        }
        for (o, e) in out.chunks_exact_mut(2).zip(a.band_w.iter().chain([&a.lm])) {
            o[0] = e.value;
            o[1] = e.sigma;
        }
        Ok(())
    })
}

/// How many triangles of mesh `mesh` were left out because they repeat a vertex (added
/// with IMAP_MESH_SKIP_DEGENERATE; 0 otherwise), into `*out_count`. (Since 0.2.1.)
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_INVALID_ARGUMENT (no such mesh).
///
/// # Safety
/// `ctx` is a live handle; `out_count` is writable.
#[no_mangle]
pub unsafe extern "C" fn imap_get_mesh_dropped_triangles(
    ctx: *const ImapContext,
    mesh: u32,
    out_count: *mut usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        write_out("out_count", out_count, c.dropped_triangles(mesh)?)
    })
}

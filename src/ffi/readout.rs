//! Per-vertex readouts of the map: counts, irradiance, illuminance, tristimulus values,
//! relative errors and vertex areas, of the combined map or of one layer.

use super::layers::layer_arg;
use super::{slice_mut, with_context, write_out, ImapContext};
use crate::error::ImapStatus;

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
/// vertex_count)`; `count` may be larger (the rest of `out` is left as it was). Before the
/// first run: zeros. Vertices used by no triangle of non-zero area get 0.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_INDEX_OUT_OF_RANGE (mesh, side or band),
/// IMAP_ERR_NOT_RECORDED, IMAP_ERR_BUFFER_TOO_SMALL (`count` < vertex count), IMAP_ERR_BUSY;
/// nothing is written then.
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
/// the vertex has no area. Buffer and statuses as `imap_get_vertex_energy`.
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

/// Illuminance in lux at every vertex of mesh `mesh` on `side`: Σ over bands of the
/// irradiance times the band's luminous efficacy (docs/photometry.md), into `out[0 ..
/// vertex_count)`. Its relative error is `imap_get_vertex_error`'s (exact for spectrally
/// neutral surfaces). Buffer and statuses as `imap_get_vertex_energy`.
///
/// # Safety
/// `ctx` is a live handle; `out` holds `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_get_vertex_illuminance(
    ctx: *const ImapContext,
    mesh: u32,
    side: u32,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        c.illuminance(mesh, side, slice_mut("out", out, count)?)
    })
}

/// CIE 1931 X, Y, Z of the light arriving at every vertex of mesh `mesh` on `side`, three
/// values per vertex (Y = illuminance, lx), into `out[0 .. 3 × vertex_count)`. Give them to
/// `imap_xyz_to_cct` / `imap_xyz_chromaticity`. Statuses as `imap_get_vertex_energy`
/// (IMAP_ERR_BUFFER_TOO_SMALL when `count` < 3 × vertex count).
///
/// # Safety
/// `ctx` is a live handle; `out` holds `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_get_vertex_xyz(
    ctx: *const ImapContext,
    mesh: u32,
    side: u32,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        c.tristimulus(mesh, side, slice_mut("out", out, count)?)
    })
}

/// Each vertex's area of mesh `mesh` — a third of the area of every triangle it belongs
/// to, m² — into `out[0 .. vertex count)`: E × area summed over a mesh's vertices is the
/// flux it receives. Any mesh (recording or not). Returns IMAP_ERR_NULL_POINTER,
/// IMAP_ERR_INDEX_OUT_OF_RANGE, IMAP_ERR_BUFFER_TOO_SMALL, IMAP_ERR_BUSY.
///
/// # Safety
/// `ctx` is a live handle; `out` holds `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_get_vertex_areas(
    ctx: *const ImapContext,
    mesh: u32,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    with_context(ctx, |c| c.vertex_areas(mesh, slice_mut("out", out, count)?))
}

/// Irradiance in W/m² in band `band` of one layer of the map — `layer` a light group,
/// IMAP_LAYER_DIRECT or IMAP_LAYER_ALL — at every vertex of `mesh` on `side`, as
/// `imap_get_vertex_energy`. Summed over the group layers it is the whole map's (to
/// rounding, a few units in the last place).
///
/// Returns as `imap_get_vertex_energy`, and IMAP_ERR_NOT_RECORDED when the layer is not
/// kept (imap_set_layers), IMAP_ERR_INDEX_OUT_OF_RANGE for a group past the largest.
/// (Since 0.2.1.)
///
/// # Safety
/// `ctx` is a live handle; `out` holds `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_get_layer_energy(
    ctx: *const ImapContext,
    mesh: u32,
    side: u32,
    band: u32,
    layer: u32,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        c.irradiance_layer(
            mesh,
            side,
            band,
            layer_arg(layer),
            slice_mut("out", out, count)?,
        )
    })
}

/// Illuminance in lux of one layer at every vertex, as `imap_get_vertex_illuminance` and
/// `imap_get_layer_energy`. (Since 0.2.1.)
///
/// # Safety
/// `ctx` is a live handle; `out` holds `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_get_layer_illuminance(
    ctx: *const ImapContext,
    mesh: u32,
    side: u32,
    layer: u32,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        c.illuminance_layer(mesh, side, layer_arg(layer), slice_mut("out", out, count)?)
    })
}

/// The relative standard error of one layer's band-mean irradiance at every vertex, as
/// `imap_get_vertex_error` and `imap_get_layer_energy`. A recombination Σ_g d_g E_g has the
/// error σ² = Σ_g d_g² (σ_g² + E_g²/N) − (Σ_g d_g E_g)²/N, with σ_g = rel_g·E_g and N the
/// photons traced (every photon belongs to one group; docs/results.md). (Since 0.2.1.)
///
/// # Safety
/// `ctx` is a live handle; `out` holds `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_get_layer_error(
    ctx: *const ImapContext,
    mesh: u32,
    side: u32,
    layer: u32,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        c.rel_error_layer(mesh, side, layer_arg(layer), slice_mut("out", out, count)?)
    })
}

//! Light groups and the map's layers (docs/results.md, "Light groups and layers").

use super::results::{part_of, stats_to_c, ImapRegionStats};
use super::{with_context, write_optional, write_versioned, ImapContext};
use crate::context::Layer;
use crate::error::{bail, ImapStatus};
use crate::scene::LayerRequest;

/// `imap_set_layers` flag: keep one layer per light group. (Since 0.2.1.)
pub const IMAP_KEEP_LIGHT_GROUPS: u32 = 1;
/// `imap_set_layers` flag: keep the direct component as its own layer. (Since 0.2.1.)
pub const IMAP_KEEP_DIRECT: u32 = 2;
/// `layer` argument of the layer read-outs: the whole map (the sum of the group layers).
pub const IMAP_LAYER_ALL: u32 = u32::MAX;
/// `layer` argument of the layer read-outs: the direct layer.
pub const IMAP_LAYER_DIRECT: u32 = u32::MAX - 1;
/// Light groups are 0 … IMAP_MAX_LIGHT_GROUPS − 1. (Since 0.2.1.)
pub const IMAP_MAX_LIGHT_GROUPS: u32 = 254;
const _: () = assert!(IMAP_MAX_LIGHT_GROUPS as usize == crate::imap::MAX_LIGHT_GROUPS);

pub(super) fn layer_arg(layer: u32) -> Layer {
    match layer {
        IMAP_LAYER_ALL => Layer::Combined,
        IMAP_LAYER_DIRECT => Layer::Direct,
        g => Layer::Group(g),
    }
}

/// Chooses the layers the map keeps, from the flags `IMAP_KEEP_LIGHT_GROUPS` (one layer
/// per light group: 0 … the largest group given to a light or emitting mesh) and
/// `IMAP_KEEP_DIRECT` (the direct component: what photons deposit before their first
/// surface event — the first surface they reach and sensors crossed on the way; light
/// through glass is not direct). 0 keeps none (the default). The group layers sum to the
/// whole map, so a host recombines E = Σ_g d_g E_g for any dimming d without a rerun. Each
/// layer costs the memory of a map; a scene that keeps none pays nothing. Only before any
/// photon is traced (IMAP_ERR_OUT_OF_ORDER after a run: call imap_reset first).
///
/// Returns IMAP_ERR_INVALID_ARGUMENT (unknown flag), IMAP_ERR_OUT_OF_ORDER,
/// IMAP_ERR_MEMORY_BUDGET (the layers would not fit), IMAP_ERR_BUSY. (Since 0.2.1.)
///
/// # Safety
/// `ctx` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn imap_set_layers(ctx: *mut ImapContext, flags: u32) -> ImapStatus {
    with_context(ctx, |c| {
        if flags & !(IMAP_KEEP_LIGHT_GROUPS | IMAP_KEEP_DIRECT) != 0 {
            bail!(
                ImapErrInvalidArgument,
                "flags = {flags:#x} has unknown bits (IMAP_KEEP_LIGHT_GROUPS | IMAP_KEEP_DIRECT = 3)"
            );
        }
        c.set_layers(LayerRequest {
            groups: flags & IMAP_KEEP_LIGHT_GROUPS != 0,
            direct: flags & IMAP_KEEP_DIRECT != 0,
        })
    })
}

/// Puts light `light` (an id from imap_add_light, imap_add_point_light, imap_add_spot_light
/// or imap_add_luminaire_*) in light group `group` (0 … IMAP_MAX_LIGHT_GROUPS − 1; every
/// light starts in group 0). Only before any photon is traced.
///
/// Returns IMAP_ERR_INDEX_OUT_OF_RANGE (light), IMAP_ERR_INVALID_ARGUMENT (group),
/// IMAP_ERR_OUT_OF_ORDER, IMAP_ERR_MEMORY_BUDGET (groups are kept and the new layers would
/// not fit), IMAP_ERR_BUSY. (Since 0.2.1.)
///
/// # Safety
/// `ctx` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn imap_set_light_group(
    ctx: *mut ImapContext,
    light: u32,
    group: u32,
) -> ImapStatus {
    with_context(ctx, |c| c.set_light_group(light, group))
}

/// Puts emitting mesh `mesh` in light group `group`, as `imap_set_light_group`.
/// IMAP_ERR_INVALID_ARGUMENT when the mesh does not emit. (Since 0.2.1.)
///
/// # Safety
/// `ctx` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn imap_set_mesh_light_group(
    ctx: *mut ImapContext,
    mesh: u32,
    group: u32,
) -> ImapStatus {
    with_context(ctx, |c| c.set_mesh_light_group(mesh, group))
}

/// The layers the map keeps for the scene as it is: `*groups` group layers (0 when groups
/// are not kept) and `*direct` 1 when the direct layer is kept. Either pointer may be NULL.
/// (Since 0.2.1.)
///
/// # Safety
/// `ctx` is a live handle; non-NULL pointers are writable.
#[no_mangle]
pub unsafe extern "C" fn imap_get_layers(
    ctx: *const ImapContext,
    groups: *mut u32,
    direct: *mut u32,
) -> ImapStatus {
    with_context(ctx, |c| {
        let (g, d) = c.layers();
        write_optional(groups, g)?;
        write_optional(direct, u32::from(d))
    })
}

/// The figures of a region (as `imap_get_region_stats`) in one layer of the map — `layer`
/// a light group, IMAP_LAYER_DIRECT or IMAP_LAYER_ALL: a light group's or the direct
/// component's flux, average, minimum and uniformity with their standard errors. On a
/// recording mesh with tallies (a sensor, or added with IMAP_MESH_TALLY) the flux and
/// average errors are exact per layer too (each layer keeps its own photon tallies); the
/// group layers' fluxes sum to the region's.
///
/// Returns as `imap_get_region_stats`, and IMAP_ERR_NOT_RECORDED when the layer is not kept
/// (imap_set_layers), IMAP_ERR_INDEX_OUT_OF_RANGE for a group past the largest.
/// (Since 0.2.3.)
///
/// # Safety
/// `ctx` is a live handle; `out` points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_get_layer_region_stats(
    ctx: *const ImapContext,
    mesh: u32,
    side: u32,
    part: u32,
    layer: u32,
    out: *mut ImapRegionStats,
    size: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        super::check_out("out", out)?;
        let s = c.region_stats_layer(mesh, side, part_of(part), layer_arg(layer))?;
        write_versioned("out", out, size, stats_to_c(&s))
    })
}

//! Colour conversions: the bands' luminous efficacies, chromaticity and correlated colour
//! temperature of tristimulus values.

use super::{
    boundary, check_out, copy_bands, slice, slice_mut, with_context, write_optional, write_out,
    ImapContext,
};
use crate::error::{bail, ImapStatus, Result};
use crate::photometry;

/// The luminous efficacy of each band, lm/W (lux per W/m²), into `out[0 .. band count)`.
///
/// # Safety
/// `ctx` is a live handle; `out` holds `count` writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_get_band_efficacy(
    ctx: *const ImapContext,
    out: *mut f64,
    count: usize,
) -> ImapStatus {
    with_context(ctx, |c| copy_bands(out, count, &c.photometry().efficacy))
}

fn xyz_in(xyz: *const f64) -> Result<[f64; 3]> {
    let v = slice("xyz", xyz, 3)?;
    crate::error::check_finite("xyz", v)?;
    Ok([v[0], v[1], v[2]])
}

/// Chromaticity (x, y) of CIE 1931 tristimulus values into `out_xy[0..2]`. Returns
/// IMAP_ERR_NULL_POINTER, IMAP_ERR_NON_FINITE, IMAP_ERR_INVALID_ARGUMENT (black: X + Y + Z
/// ≤ 0). Thread-safe.
///
/// # Safety
/// `xyz` points to 3 doubles, `out_xy` to 2 writable doubles.
#[no_mangle]
pub unsafe extern "C" fn imap_xyz_chromaticity(xyz: *const f64, out_xy: *mut f64) -> ImapStatus {
    boundary(None, || {
        let v = xyz_in(xyz)?;
        let out = slice_mut("out_xy", out_xy, 2)?;
        let Some(c) = photometry::chromaticity(v) else {
            bail!(
                ImapErrInvalidArgument,
                "xyz = {v:?} is black: it has no chromaticity"
            );
        };
        out.copy_from_slice(&c);
        Ok(())
    })
}

/// Correlated colour temperature (K) of CIE 1931 tristimulus values, and Duv (the signed
/// distance from the Planckian locus in CIE 1960 uv, positive above it), by search along
/// the locus (1000–100 000 K). `out_duv` may be NULL. Returns IMAP_ERR_NULL_POINTER,
/// IMAP_ERR_NON_FINITE, IMAP_ERR_INVALID_ARGUMENT (black, or farther than 0.05 from the
/// locus: no meaningful CCT). Thread-safe.
///
/// # Safety
/// `xyz` points to 3 doubles; `out_k` is writable; `out_duv` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn imap_xyz_to_cct(
    xyz: *const f64,
    out_k: *mut f64,
    out_duv: *mut f64,
) -> ImapStatus {
    boundary(None, || {
        let v = xyz_in(xyz)?;
        check_out("out_k", out_k)?;
        let Some((t, duv)) = photometry::cct(v).filter(|c| c.1.abs() <= 0.05) else {
            bail!(
                ImapErrInvalidArgument,
                "xyz = {v:?} has no correlated colour temperature (black, or more than 0.05 from the Planckian locus)"
            );
        };
        write_out("out_k", out_k, t)?;
        write_optional(out_duv, duv)
    })
}

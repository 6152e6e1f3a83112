//! Map state out and in: checkpoints, resume, shards and MPI ranks (docs/distributed.md).

use super::{boundary, slice, with_context, write_optional, write_out, ImapContext};
use crate::context::state;
use crate::error::{bail, ImapStatus, Result};
use std::ffi::{c_char, c_void, CStr};
use std::path::Path;

/// `imap_state_write` flag: leave the map's accumulators out (an MPI rank's "ledger": the
/// caller sums the maps itself, see `imap_map_accumulators`). (Since 0.2.2.)
pub const IMAP_STATE_NO_MAP: u32 = 1;
const _: () = assert!(IMAP_STATE_NO_MAP == state::FLAG_NO_MAP);
/// The state format version this library writes. (Since 0.2.2; 2 since 0.2.3, which adds
/// what media absorbed. It reads version 1 too, but for a scene with media.)
pub const IMAP_STATE_FORMAT_VERSION: u32 = 2;
const _: () = assert!(IMAP_STATE_FORMAT_VERSION == state::FORMAT_VERSION);

/// A path from a NUL-terminated C string (bytes as the system takes them).
pub(super) fn path_arg<'a>(name: &str, p: *const c_char) -> Result<&'a Path> {
    if p.is_null() {
        bail!(ImapErrNullPointer, "{name} is NULL");
    }
    // SAFETY: the caller passes a NUL-terminated string.
    let bytes = unsafe { CStr::from_ptr(p) }.to_bytes();
    if bytes.is_empty() {
        bail!(ImapErrInvalidArgument, "{name} is empty");
    }
    match crate::platform::path_from_c(bytes) {
        Some(p) => Ok(p),
        None => bail!(
            ImapErrInvalidArgument,
            "{name} is not UTF-8: on Windows pass a path as its UTF-8 bytes"
        ),
    }
}

/// A writer into a caller's buffer that counts every byte, keeping those that fit.
struct Bounded<'a> {
    buf: &'a mut [u8],
    at: usize,
}

impl std::io::Write for Bounded<'_> {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        if let Some(room) = self.buf.get_mut(self.at..) {
            let n = room.len().min(b.len());
            room[..n].copy_from_slice(&b[..n]);
        }
        self.at += b.len();
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Writes everything the context has accumulated — the map's sums and squares in every
/// layer, the photon indices it holds, the energy and region tallies, the run time and the
/// error history — with a fingerprint of the scene and settings and `meta_len` bytes of
/// the caller's own `meta` (any bytes, e.g. which job this is; NULL with 0), as one
/// versioned, checksummed state (IMAP_STATE_FORMAT_VERSION; little-endian) into `buffer`
/// of `capacity` bytes. `*size` receives the state's size: with `buffer` NULL or
/// `capacity` too small the call returns IMAP_ERR_BUFFER_TOO_SMALL, writes nothing useful
/// and sets `*size`; call again with a buffer that large. A context that has not run
/// writes a state of zeros (its map is allocated). `flags`: 0, or `IMAP_STATE_NO_MAP`.
///
/// Returns IMAP_ERR_NULL_POINTER (`size`), IMAP_ERR_INVALID_ARGUMENT (unknown flag),
/// IMAP_ERR_BUFFER_TOO_SMALL, IMAP_ERR_NO_GEOMETRY / IMAP_ERR_NO_LIGHT (nothing to
/// prepare), IMAP_ERR_BUSY. (Since 0.2.2.)
///
/// # Safety
/// `ctx` is a live handle; `meta` points to `meta_len` readable bytes; `buffer` to
/// `capacity` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_state_write(
    ctx: *mut ImapContext,
    flags: u32,
    meta: *const c_void,
    meta_len: usize,
    buffer: *mut c_void,
    capacity: usize,
    size: *mut usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        let meta = slice("meta", meta as *const u8, meta_len)?;
        super::check_out("size", size)?;
        let buf: &mut [u8] = if buffer.is_null() || capacity == 0 {
            &mut []
        } else {
            super::slice_mut("buffer", buffer as *mut u8, capacity)?
        };
        let mut w = Bounded { buf, at: 0 };
        let n = c.write_state(&mut w, flags, meta)? as usize;
        write_out("size", size, n)?;
        if n > capacity {
            bail!(
                ImapErrBufferTooSmall,
                "the state needs {n} bytes; buffer holds {capacity} (*size is set)"
            );
        }
        Ok(())
    })
}

/// Writes the whole state (`imap_state_write` without flags) to the file `path` (UTF-8 or
/// the system's bytes, NUL-terminated) atomically: into a temporary file beside it
/// (`path` + ".tmp-" + the process id and a count), flushed to the disk, then renamed over
/// `path`; temporary files of writers that were killed are removed. A
/// crash or SIGKILL at any moment leaves either the previous file or the new one whole,
/// never a part: a checkpoint written this way can always be resumed from.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_IO (the message names the path and the system's
/// reason), IMAP_ERR_BUSY. (Since 0.2.2.)
///
/// # Safety
/// `ctx` is a live handle; `path` is NUL-terminated; `meta` points to `meta_len` bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_state_save(
    ctx: *mut ImapContext,
    path: *const c_char,
    meta: *const c_void,
    meta_len: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        let path = path_arg("path", path)?;
        let meta = slice("meta", meta as *const u8, meta_len)?;
        c.save_state(path, meta).map(|_| ())
    })
}

/// Replaces what the context has accumulated by a state (resume after a crash): the map,
/// the photons it holds, the tallies, the run time and the history. The context must hold
/// the same scene and settings as the one that wrote it (same meshes, materials, lights,
/// bands, seed, units, layers, light aiming), added in the same order; the next imap_run
/// continues with the photons the state does not hold. On any error the context is
/// unchanged.
///
/// Returns IMAP_ERR_STATE_CORRUPT (not a state, truncated, checksum fails, or a number no
/// run writes — NaN, infinite, negative or beyond 1e100 where sums, squares and times
/// stand, a fraction of a pass, light samples past 1024: the message names the field),
/// IMAP_ERR_UNSUPPORTED (a newer format version), IMAP_ERR_STATE_MISMATCH
/// (another scene or settings: the message names what differs), IMAP_ERR_INVALID_ARGUMENT
/// (a state written with IMAP_STATE_NO_MAP), IMAP_ERR_BUSY. (Since 0.2.2.)
///
/// # Safety
/// `ctx` is a live handle; `buffer` points to `size` readable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_state_load(
    ctx: *mut ImapContext,
    buffer: *const c_void,
    size: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        let b = slice("buffer", buffer as *const u8, size)?;
        c.load_state(b).map(|_| ())
    })
}

/// `imap_state_load` from the file `path`; errors name the file. Also IMAP_ERR_IO (cannot
/// read it, or it is no regular file: a device such as /dev/zero, a FIFO or a folder is
/// refused before a byte is read) and IMAP_ERR_MEMORY_BUDGET (the file does not fit beside
/// the map). (Since 0.2.2.)
///
/// # Safety
/// `ctx` is a live handle; `path` is NUL-terminated.
#[no_mangle]
pub unsafe extern "C" fn imap_state_load_file(
    ctx: *mut ImapContext,
    path: *const c_char,
) -> ImapStatus {
    with_context(ctx, |c| {
        let path = path_arg("path", path)?;
        c.load_state_file(path).map(|_| ())
    })
}

/// Adds a state to what the context holds: the states of shards or ranges of the same
/// scene (same conditions as `imap_state_load`) that hold disjoint photons. Every sum adds
/// — the map, the sums of squares (so the merged error estimate is exact), the energy and
/// region tallies, the photon counts; the run times add; the history gains one point with
/// the combined error. The result equals one run of all the photons up to summation order
/// (~1e-15 relative). A state written with IMAP_STATE_NO_MAP adds everything but the map:
/// use it after summing the maps yourself (`imap_map_accumulators`, e.g. `MPI_Reduce`).
/// On any error the context is unchanged.
///
/// Returns the errors of `imap_state_load` and IMAP_ERR_STATE_OVERLAP (the state holds
/// photons the context holds too: they would count twice). (Since 0.2.2.)
///
/// # Safety
/// `ctx` is a live handle; `buffer` points to `size` readable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_state_merge(
    ctx: *mut ImapContext,
    buffer: *const c_void,
    size: usize,
) -> ImapStatus {
    with_context(ctx, |c| {
        let b = slice("buffer", buffer as *const u8, size)?;
        c.merge_state(b).map(|_| ())
    })
}

/// `imap_state_merge` from the file `path`; errors name the file. (Since 0.2.2.)
///
/// # Safety
/// `ctx` is a live handle; `path` is NUL-terminated.
#[no_mangle]
pub unsafe extern "C" fn imap_state_merge_file(
    ctx: *mut ImapContext,
    path: *const c_char,
) -> ImapStatus {
    with_context(ctx, |c| {
        let path = path_arg("path", path)?;
        c.merge_state_file(path).map(|_| ())
    })
}

/// Checks a state in memory (frame, version, checksum) without a context, and tells its
/// photon count (`photons`, may be NULL) and where the caller's metadata lies inside
/// `buffer` (`meta`, `meta_len`, may be NULL). Returns the errors of the format
/// (IMAP_ERR_STATE_CORRUPT, IMAP_ERR_UNSUPPORTED). Thread-safe. (Since 0.2.2.)
///
/// # Safety
/// `buffer` points to `size` readable bytes; the out-pointers are NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn imap_state_info(
    buffer: *const c_void,
    size: usize,
    photons: *mut u64,
    meta: *mut *const c_void,
    meta_len: *mut usize,
) -> ImapStatus {
    boundary(None, || {
        let b = slice("buffer", buffer as *const u8, size)?;
        let s = state::parse(b)?;
        write_optional(photons, s.photons())?;
        write_optional(meta, s.meta.as_ptr() as *const c_void)?;
        write_optional(meta_len, s.meta.len())
    })
}

/// The context's map accumulators as one contiguous array of `*count` doubles, owned by
/// the context (allocated, zeroed, if it has not run): per map cell, one value per band
/// then the sum of squares. Contexts of the same scene (same fingerprint) have arrays of
/// the same length and order, so summing them element by element — `MPI_Reduce(…,
/// MPI_DOUBLE, MPI_SUM, …)` straight on this pointer, `MPI_IN_PLACE` at the root — and
/// then merging each other rank's state written with `IMAP_STATE_NO_MAP` into the root
/// (`imap_state_merge`) gives the root exactly the merged state. Sum first, then merge
/// (the merge's history point reads the summed map). The pointer stays valid until the
/// scene changes, `imap_destroy`; read or write it only between calls on the context (never
/// during imap_run), and call this again after a run before reading it: a spectral map
/// keeps some deposits in sums of its own until this call folds them into the array.
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_NO_GEOMETRY / IMAP_ERR_NO_LIGHT, IMAP_ERR_BUSY.
/// With the light-sampling estimator (`IMAP_ESTIMATOR_LIGHT_SAMPLING`, the default, or
/// `IMAP_ESTIMATOR_GATHER`) the map has a second array, `imap_map_direct_accumulators`: sum
/// it the same way. (Since 0.2.2.)
///
/// # Safety
/// `ctx` is a live handle; `data` and `count` are writable.
#[no_mangle]
pub unsafe extern "C" fn imap_map_accumulators(
    ctx: *mut ImapContext,
    data: *mut *mut f64,
    count: *mut u64,
) -> ImapStatus {
    with_context(ctx, |c| out_array(data, count, || c.map_accumulators()))
}

/// The light-sampling estimator's records of its passes (direct light, and gathered light
/// with `IMAP_ESTIMATOR_GATHER`) as one contiguous array of `*count` doubles owned by the
/// context (`*count` = 0 and `*data` NULL with `IMAP_ESTIMATOR_PHOTONS`): per map cell the
/// band sums, the sum of squares, the pass
/// count and the sum of squares of the vertex's total over light groups. Sum it over
/// ranks exactly like `imap_map_accumulators` (both, before merging the ledgers); the
/// estimator is the one of the next run or of the photons the map holds. Same validity
/// and errors as `imap_map_accumulators`. (Since 0.2.2.)
///
/// # Safety
/// `ctx` is a live handle; `data` and `count` are writable.
#[no_mangle]
pub unsafe extern "C" fn imap_map_direct_accumulators(
    ctx: *mut ImapContext,
    data: *mut *mut f64,
    count: *mut u64,
) -> ImapStatus {
    with_context(ctx, |c| out_array(data, count, || c.direct_accumulators()))
}

/// Hands out an array the context owns (`get`, called once the out-pointers are checked):
/// its first element (NULL when empty) and its length.
fn out_array<'a>(
    data: *mut *mut f64,
    count: *mut u64,
    get: impl FnOnce() -> Result<&'a mut [f64]>,
) -> Result<()> {
    super::check_out("data", data)?;
    super::check_out("count", count)?;
    let a = get()?;
    let p = if a.is_empty() {
        std::ptr::null_mut()
    } else {
        a.as_mut_ptr()
    };
    write_out("data", data, p)?;
    write_out("count", count, a.len() as u64)
}

//! The C ABI. Only conversions and calls into the safe API live here, one file per C
//! object or concept (`context`, `scene`, `light`, `sky`, `layers`, `run`, `readout`,
//! `results`, `colour`, `render`, `state`); every export goes through `boundary`:
//! panics are caught (and never printed), pointers checked, statuses returned and the
//! message kept for `imap_last_error`.
//!
//! Versioned structs: every struct the caller fills or receives starts with
//! `uint32_t struct_size`. The `imap_*_default(out, sizeof *out)` functions set it; the
//! library reads only the fields inside it (later fields take their defaults) and writes
//! only what fits. New fields are only ever appended, with 0 meaning "default", so a
//! program built against an older `imap.h` keeps working with a newer library, and a newer
//! program that sets a field an older library does not know is refused, never ignored.

mod annual;
mod colour;
mod context;
mod errors;
mod glare;
mod layers;
mod light;
mod readout;
mod render;
mod results;
mod run;
mod scene;
mod sky;
mod state;

pub use annual::*;
pub use colour::*;
pub use context::*;
pub use layers::*;
pub use light::*;
pub use readout::*;
pub use render::*;
pub use results::*;
pub use run::*;
pub use scene::*;
pub use sky::*;
pub use state::*;

use crate::context::Context;
use crate::error::{bail, Error, ImapStatus, Result};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::{Arc, Mutex, TryLockError};

use errors::{record, ErrorSlots};

/// An illumination-map context: the scene, the map and the run history. Opaque to C.
pub struct ImapContext {
    inner: Mutex<Context>,
    errors: Arc<ErrorSlots>,
}

/// The live contexts, by the address handed to C. Every call looks its handle up here
/// before touching it, so a destroyed or made-up handle is an error, never a read of freed
/// memory; `imap_destroy` removes a context only when no call holds it (IMAP_ERR_BUSY
/// otherwise), and a call that found it before keeps it alive until it returns.
static LIVE: std::sync::LazyLock<
    std::sync::RwLock<std::collections::HashMap<usize, Arc<ImapContext>>>,
> = std::sync::LazyLock::new(Default::default);

/// Registers a new context; its handle for C.
pub(crate) fn register(ctx: ImapContext) -> *mut ImapContext {
    let ctx = Arc::new(ctx);
    let ptr = Arc::as_ptr(&ctx) as *mut ImapContext;
    LIVE.write()
        .unwrap_or_else(|p| p.into_inner())
        .insert(ptr as usize, ctx);
    ptr
}

/// The live context behind a handle.
pub(crate) fn live(ctx: *const ImapContext) -> Option<Arc<ImapContext>> {
    LIVE.read()
        .unwrap_or_else(|p| p.into_inner())
        .get(&(ctx as usize))
        .cloned()
}

fn not_live() -> Error {
    Error::new(
        ImapStatus::ImapErrInvalidArgument,
        "ctx is not a live context: it was destroyed, or did not come from imap_create",
    )
}

/// Removes a context that no call is using: IMAP_ERR_BUSY while one is (a run in
/// progress, or this call made from a run's progress callback), and nothing happens.
pub(crate) fn unregister(ctx: *mut ImapContext) -> Result<()> {
    let mut live = LIVE.write().unwrap_or_else(|p| p.into_inner());
    let Some(handle) = live.get(&(ctx as usize)) else {
        return Err(not_live());
    };
    if let Err(TryLockError::WouldBlock) = handle.inner.try_lock() {
        return Err(Error::new(
            ImapStatus::ImapErrBusy,
            "imap_destroy: the context is in use (imap_run or imap_render in progress, or a call from its progress callback); destroy it after that call returns",
        ));
    }
    let handle = live.remove(&(ctx as usize));
    drop(live);
    drop(handle);
    Ok(())
}

/// Runs `f` behind the API boundary: panics become `IMAP_ERR_INTERNAL` (the panic message
/// goes into the error, nothing is printed), errors are recorded on the context for the
/// calling thread (when there is a context) and on the calling thread.
pub(crate) fn boundary(ctx: Option<&ImapContext>, f: impl FnOnce() -> Result<()>) -> ImapStatus {
    let _quiet = errors::QuietGuard::enter();
    let result = catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|panic| {
        let what = crate::error::panic_message(&*panic);
        Err(Error::new(
            ImapStatus::ImapErrInternal,
            format!("internal error (please report): {what}"),
        ))
    });
    match result {
        Ok(()) => ImapStatus::ImapOk,
        Err(e) => {
            record(ctx.map(|c| &c.errors), &e);
            e.status
        }
    }
}

/// Runs `f` on the context behind `ctx`, which must not be in use by another call.
pub(crate) fn with_context(
    ctx: *const ImapContext,
    f: impl FnOnce(&mut Context) -> Result<()>,
) -> ImapStatus {
    if ctx.is_null() {
        return boundary(None, || {
            Err(Error::new(ImapStatus::ImapErrNullPointer, "ctx is NULL"))
        });
    }
    let Some(handle) = live(ctx) else {
        return boundary(None, || Err(not_live()));
    };
    let handle = &*handle;
    boundary(Some(handle), || {
        let mut guard = match handle.inner.try_lock() {
            Ok(g) => g,
            Err(TryLockError::WouldBlock) => {
                return Err(Error::new(
                    ImapStatus::ImapErrBusy,
                    "the context is in use by another call (imap_run or imap_render in progress, or a call from its progress callback)",
                ))
            }
            // A panic inside an earlier call was caught; the context's data stayed valid
            // Rust data, so it can go on being used.
            Err(TryLockError::Poisoned(p)) => p.into_inner(),
        };
        f(&mut guard)
    })
}

/// Refuses counts whose byte size cannot be a Rust slice.
fn check_count<T>(name: &str, count: usize) -> Result<()> {
    if count > isize::MAX as usize / std::mem::size_of::<T>().max(1) {
        return Err(Error::new(
            ImapStatus::ImapErrInvalidArgument,
            format!("{name}'s count {count} is too large"),
        ));
    }
    Ok(())
}

/// A slice from a C pointer + count; NULL is allowed only with count 0.
pub(crate) fn slice<'a, T>(name: &str, ptr: *const T, count: usize) -> Result<&'a [T]> {
    if count == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err(Error::new(
            ImapStatus::ImapErrNullPointer,
            format!("{name} is NULL but its count is {count}"),
        ));
    }
    check_count::<T>(name, count)?;
    // SAFETY: the caller guarantees `ptr` points to `count` readable elements (the
    // documented contract of every pointer + count pair).
    Ok(unsafe { std::slice::from_raw_parts(ptr, count) })
}

/// A mutable slice from a C pointer + count.
pub(crate) fn slice_mut<'a, T>(name: &str, ptr: *mut T, count: usize) -> Result<&'a mut [T]> {
    if ptr.is_null() {
        return Err(Error::new(
            ImapStatus::ImapErrNullPointer,
            format!("{name} is NULL"),
        ));
    }
    check_count::<T>(name, count)?;
    // SAFETY: the caller guarantees `ptr` points to `count` writable elements.
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, count) })
}

/// Writes an out-parameter (only on success, per the API conventions).
pub(crate) fn write_out<T>(name: &str, ptr: *mut T, value: T) -> Result<()> {
    check_out(name, ptr)?;
    // SAFETY: non-NULL out-pointers from the caller point to writable storage for a T.
    unsafe { ptr.write(value) };
    Ok(())
}

/// Writes an out-parameter the caller may leave NULL (then nothing is written).
pub(crate) fn write_optional<T>(ptr: *mut T, value: T) -> Result<()> {
    if ptr.is_null() {
        return Ok(());
    }
    // SAFETY: non-NULL out-pointers from the caller point to writable storage for a T.
    unsafe { ptr.write(value) };
    Ok(())
}

/// Checks an out-pointer before work whose result it will receive.
pub(crate) fn check_out<T>(name: &str, ptr: *mut T) -> Result<()> {
    if ptr.is_null() {
        return Err(Error::new(
            ImapStatus::ImapErrNullPointer,
            format!("{name} is NULL"),
        ));
    }
    Ok(())
}

/// Largest `struct_size` taken seriously: anything larger is garbage, not a newer layout.
const MAX_STRUCT_SIZE: usize = 1 << 16;

/// A C struct that starts with `uint32_t struct_size` and grows only by appending fields
/// whose value 0 means "default".
///
/// # Safety
/// The type is `#[repr(C)]`, its first field is a `u32` `struct_size`, and every bit
/// pattern of zeroed bytes followed by a valid prefix is a valid value (plain numbers,
/// pointers, `Option<fn>`).
pub(crate) unsafe trait Versioned: Copy {
    /// The struct's name in C.
    const NAME: &'static str;
    /// The `imap_*_default` function that initialises it (for messages).
    const INIT: &'static str;
    /// Size of its first published layout: the smallest `struct_size` accepted. When a
    /// field is appended, this stays the size of the layout before it.
    const BASE_SIZE: usize = std::mem::size_of::<Self>();
    /// Every field's default, `struct_size` included.
    fn defaults() -> Self;
}

fn struct_size_error(name: &str, init: &str, size: usize, base: usize) -> Error {
    if size == 0 {
        Error::new(
            ImapStatus::ImapErrInvalidArgument,
            format!("{name}.struct_size is 0: initialise the struct with {init}(&s, sizeof s) before setting its fields"),
        )
    } else {
        Error::new(
            ImapStatus::ImapErrInvalidArgument,
            format!("{name}.struct_size = {size} is not a size of {name} (at least {base}, at most {MAX_STRUCT_SIZE}): initialise it with {init}(&s, sizeof s)"),
        )
    }
}

/// `imap_*_default(out, size)`: the defaults written into the caller's `size` bytes (the
/// bytes past this library's layout zeroed), `struct_size` = `size`.
pub(crate) fn write_defaults<T: Versioned>(out: *mut T, size: usize) -> Result<()> {
    check_out("out", out)?;
    if size < T::BASE_SIZE || size > MAX_STRUCT_SIZE {
        bail_size::<T>(size)?;
    }
    let mut value = T::defaults();
    // SAFETY: the first field of a Versioned struct is its u32 struct_size.
    unsafe { (&mut value as *mut T as *mut u32).write(size as u32) };
    let known = std::mem::size_of::<T>();
    // SAFETY: the caller provides `size` writable bytes at `out`; `value` is a valid T
    // whose first min(size, known) bytes are copied, the rest of the caller's bytes zeroed.
    unsafe {
        let dst = out as *mut u8;
        std::ptr::copy_nonoverlapping(&value as *const T as *const u8, dst, size.min(known));
        if size > known {
            std::ptr::write_bytes(dst.add(known), 0, size - known);
        }
    }
    Ok(())
}

fn bail_size<T: Versioned>(size: usize) -> Result<()> {
    Err(struct_size_error(T::NAME, T::INIT, size, T::BASE_SIZE))
}

/// Reads an input struct of the caller's `struct_size`: fields past it take their
/// defaults; fields past this library's layout must be 0 (a newer program asking for
/// something this library cannot do is refused, not ignored).
pub(crate) fn read_versioned<T: Versioned>(name: &str, ptr: *const T) -> Result<T> {
    if ptr.is_null() {
        return Err(Error::new(
            ImapStatus::ImapErrNullPointer,
            format!("{name} is NULL"),
        ));
    }
    // SAFETY: a non-NULL pointer to a Versioned struct starts with its u32 struct_size.
    let size = unsafe { (ptr as *const u32).read_unaligned() } as usize;
    if size < T::BASE_SIZE || size > MAX_STRUCT_SIZE {
        return Err(struct_size_error(T::NAME, T::INIT, size, T::BASE_SIZE));
    }
    let known = std::mem::size_of::<T>();
    if size > known {
        // SAFETY: the caller declares `size` readable bytes at `ptr`.
        let extra =
            unsafe { std::slice::from_raw_parts((ptr as *const u8).add(known), size - known) };
        if let Some(i) = extra.iter().position(|&b| b != 0) {
            return Err(Error::new(
                ImapStatus::ImapErrInvalidArgument,
                format!(
                    "{name} ({}) sets byte {} past the {known} bytes this library knows (libimap {}): the program was built against a newer imap.h and uses a field this library does not have",
                    T::NAME,
                    known + i,
                    env!("CARGO_PKG_VERSION")
                ),
            ));
        }
    }
    let mut value = T::defaults();
    // SAFETY: min(size, known) bytes are readable at `ptr` and form a valid prefix of a T
    // (Versioned contract); the rest of `value` keeps its defaults.
    unsafe {
        std::ptr::copy_nonoverlapping(
            ptr as *const u8,
            &mut value as *mut T as *mut u8,
            size.min(known),
        );
    }
    Ok(value)
}

/// Writes an output struct into the caller's `size` bytes: the fields that fit (fields of
/// a newer `imap.h` are zeroed), `struct_size` = the bytes written.
pub(crate) fn write_versioned<T: Versioned>(
    name: &str,
    out: *mut T,
    size: usize,
    mut value: T,
) -> Result<()> {
    check_out(name, out)?;
    if size < T::BASE_SIZE || size > MAX_STRUCT_SIZE {
        return Err(Error::new(
            ImapStatus::ImapErrInvalidArgument,
            format!(
                "{name}_size = {size} is not a size of {} (at least {}): pass sizeof({})",
                T::NAME,
                T::BASE_SIZE,
                T::NAME
            ),
        ));
    }
    let known = std::mem::size_of::<T>();
    let n = size.min(known);
    // SAFETY: the first field of a Versioned struct is its u32 struct_size.
    unsafe { (&mut value as *mut T as *mut u32).write(n as u32) };
    // SAFETY: the caller provides `size` writable bytes at `out`.
    unsafe {
        let dst = out as *mut u8;
        std::ptr::copy_nonoverlapping(&value as *const T as *const u8, dst, n);
        if size > known {
            std::ptr::write_bytes(dst.add(known), 0, size - known);
        }
    }
    Ok(())
}

/// Checks an output array of `capacity` versioned elements of `element_size` bytes each
/// (`name` NULL only with capacity 0) before the work that fills it.
pub(crate) fn check_elements<T: Versioned>(
    name: &str,
    out: *mut T,
    capacity: usize,
    element_size: usize,
) -> Result<()> {
    if capacity == 0 {
        return Ok(());
    }
    if out.is_null() {
        bail!(
            ImapErrNullPointer,
            "{name} is NULL but capacity is {capacity}"
        );
    }
    if !(T::BASE_SIZE..=MAX_STRUCT_SIZE).contains(&element_size) {
        bail!(
            ImapErrInvalidArgument,
            "element_size = {element_size} is not a size of {} (at least {}): pass sizeof({})",
            T::NAME,
            T::BASE_SIZE,
            T::NAME
        );
    }
    if capacity
        .checked_mul(element_size)
        .is_none_or(|b| b > isize::MAX as usize)
    {
        bail!(ImapErrInvalidArgument, "capacity {capacity} is too large");
    }
    Ok(())
}

/// Copies per-band values into the caller's `out[0 .. count)`.
pub(crate) fn copy_bands(out: *mut f64, count: usize, values: &[f64]) -> Result<()> {
    let out = slice_mut("out", out, count)?;
    if out.len() < values.len() {
        bail!(
            ImapErrBufferTooSmall,
            "the output holds {count} values; the context has {} bands",
            values.len()
        );
    }
    out[..values.len()].copy_from_slice(values);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[repr(C)]
    #[derive(Clone, Copy, Debug, PartialEq)]
    struct V2 {
        struct_size: u32,
        pad: u32,
        a: f64,
        b: u64,
    }
    // SAFETY: repr(C), u32 struct_size first, plain numbers.
    unsafe impl Versioned for V2 {
        const NAME: &'static str = "V2";
        const INIT: &'static str = "v2_default";
        const BASE_SIZE: usize = 16; // struct_size + a: the layout before b was appended
        fn defaults() -> Self {
            V2 {
                struct_size: 24,
                pad: 0,
                a: 1.5,
                b: 7,
            }
        }
    }

    /// Every published struct accepts the size it had in the ABI baseline (abi/layout.txt):
    /// a program built against that header keeps working after fields are appended.
    #[test]
    fn every_struct_accepts_its_baseline_size() {
        let baseline = include_str!("../../abi/layout.txt");
        let size_of = |name: &str| {
            baseline.lines().find_map(|l| {
                let mut w = l.split_whitespace();
                (w.next() == Some("struct") && w.next() == Some(name))
                    .then(|| w.next().and_then(|s| s.parse::<usize>().ok()))
                    .flatten()
            })
        };
        fn base<T: Versioned>() -> (&'static str, usize) {
            (T::NAME, T::BASE_SIZE)
        }
        let all = [
            base::<scene::ImapMaterial>(),
            base::<scene::ImapMesh>(),
            base::<sky::ImapSky>(),
            base::<sky::ImapSun>(),
            base::<sky::ImapSunTime>(),
            base::<scene::ImapHostBsdf>(),
            base::<scene::ImapTexture>(),
            base::<context::ImapConfig>(),
            base::<results::ImapRegionStats>(),
            base::<run::ImapProgress>(),
            base::<run::ImapRunParams>(),
            base::<run::ImapReport>(),
            base::<light::ImapSpectrum>(),
            base::<light::ImapLight>(),
            base::<light::ImapLuminaire>(),
            base::<light::ImapPhotometry>(),
            base::<render::ImapCamera>(),
            base::<render::ImapRenderParams>(),
            base::<render::ImapRenderReport>(),
        ];
        let mut seen = 0;
        for (name, base) in all {
            if let Some(published) = size_of(name) {
                seen += 1;
                assert!(
                    base <= published,
                    "{name}: BASE_SIZE {base} refuses programs built with its published {published} bytes"
                );
            }
        }
        assert!(seen >= 12, "{seen} structs found in the baseline");
    }

    #[test]
    fn versioned_structs_grow_both_ways() {
        // An old program (16 bytes) gets the default of the field it does not know.
        let old: [u64; 2] = [16, 2.5f64.to_bits()];
        let v = read_versioned("cfg", old.as_ptr() as *const V2).unwrap();
        assert_eq!((v.a, v.b), (2.5, 7));
        // A newer program (32 bytes) with its new field left 0 is fine; set, it is refused.
        let mut newer: [u64; 4] = [32, 2.5f64.to_bits(), 9, 0];
        assert_eq!(
            read_versioned("cfg", newer.as_ptr() as *const V2)
                .unwrap()
                .b,
            9
        );
        newer[3] = 1;
        let e = read_versioned("cfg", newer.as_ptr() as *const V2).unwrap_err();
        assert_eq!(e.status, ImapStatus::ImapErrInvalidArgument);
        assert!(e.message.contains("newer imap.h"), "{}", e.message);
        // A zeroed struct is refused with the name of its initialiser.
        let zero = [0u64; 3];
        let e = read_versioned("cfg", zero.as_ptr() as *const V2).unwrap_err();
        assert!(e.message.contains("v2_default"), "{}", e.message);
        // Defaults into a larger struct zero the unknown tail; outputs are cut to size.
        let mut big = [u64::MAX; 4];
        write_defaults(big.as_mut_ptr() as *mut V2, 32).unwrap();
        assert_eq!(big, [32, 1.5f64.to_bits(), 7, 0]);
        let mut small = [u64::MAX; 3];
        let val = V2::defaults();
        write_versioned("out", small.as_mut_ptr() as *mut V2, 16, val).unwrap();
        assert_eq!(small, [16, 1.5f64.to_bits(), u64::MAX]);
        assert!(write_versioned("out", small.as_mut_ptr() as *mut V2, 8, val).is_err());
    }
}

//! The C ABI. Only conversions and calls into the safe API live here; every export goes
//! through `boundary`: panics are caught, pointers checked, statuses returned and the
//! message kept for `imap_last_error`.

mod exports;
mod types;

pub use exports::*;
pub use types::*;

use crate::context::Context;
use crate::error::{Error, ImapStatus, Result};
use std::cell::RefCell;
use std::ffi::CString;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::{Mutex, TryLockError};

/// An illumination-map context: the scene, the map and the run history. Opaque to C.
pub struct ImapContext {
    inner: Mutex<Context>,
    last_error: Mutex<CString>,
}

thread_local! {
    static THREAD_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn to_cstring(s: &str) -> CString {
    CString::new(s.replace('\0', " ")).expect("NULs removed")
}

fn record(ctx: Option<&ImapContext>, e: &Error) {
    let text = to_cstring(&e.message);
    if let Some(ctx) = ctx {
        let mut slot = ctx.last_error.lock().unwrap_or_else(|p| p.into_inner());
        *slot = text.clone();
    }
    THREAD_ERROR.with(|t| *t.borrow_mut() = text);
}

/// Runs `f` behind the API boundary: panics become `IMAP_ERR_INTERNAL`, errors are recorded
/// on the context (when there is one) and on the calling thread.
pub(crate) fn boundary(ctx: Option<&ImapContext>, f: impl FnOnce() -> Result<()>) -> ImapStatus {
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
            record(ctx, &e);
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
    // SAFETY: the caller passes a pointer returned by imap_create and not yet destroyed.
    let handle = unsafe { &*ctx };
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

/// A reference from a C pointer, or a NULL-pointer error naming it.
pub(crate) fn reference<'a, T>(name: &str, ptr: *const T) -> Result<&'a T> {
    if ptr.is_null() {
        return Err(Error::new(
            ImapStatus::ImapErrNullPointer,
            format!("{name} is NULL"),
        ));
    }
    // SAFETY: non-NULL pointers from the caller point to a valid, initialised T.
    Ok(unsafe { &*ptr })
}

/// Writes an out-parameter (only on success, per the API conventions).
pub(crate) fn write_out<T>(name: &str, ptr: *mut T, value: T) -> Result<()> {
    if ptr.is_null() {
        return Err(Error::new(
            ImapStatus::ImapErrNullPointer,
            format!("{name} is NULL"),
        ));
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

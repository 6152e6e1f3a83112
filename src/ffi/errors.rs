//! Where `imap_last_error` messages live, and the panic hook that keeps the library quiet.
//!
//! Lifetime of a message (README, header): `imap_last_error(ctx)` is the message of the
//! most recent failing call on `ctx` *made by the calling thread*; the string stays valid
//! until that thread's next failing call on `ctx`, `imap_destroy(ctx)`, or the thread's
//! exit. `imap_last_error(NULL)` is the calling thread's most recent failure on any
//! context or none, valid until its next failing call or its exit. So a thread reading its
//! message can never have it freed by another thread, and the `IMAP_ERR_BUSY` another
//! thread gets while a run holds the context never replaces the running thread's message.
//!
//! Each context keeps one message per thread that failed on it; a thread's messages are
//! removed from every context still alive when the thread exits, so the storage is bounded
//! by the live threads.

use crate::error::Error;
use crate::error::QUIET;
use std::cell::RefCell;
use std::collections::HashMap;
use std::ffi::{c_char, CString};
use std::sync::{Arc, Mutex, Once, Weak};
use std::thread::ThreadId;

/// One context's messages, by thread.
#[derive(Debug, Default)]
pub struct ErrorSlots {
    by_thread: Mutex<HashMap<ThreadId, CString>>,
}

impl ErrorSlots {
    /// The calling thread's message on this context, "" when it has none.
    pub fn current(&self) -> *const c_char {
        let map = self.by_thread.lock().unwrap_or_else(|p| p.into_inner());
        // The CString's heap buffer does not move when the map rehashes, and only this
        // thread replaces or removes its own entry.
        map.get(&std::thread::current().id())
            .map_or(c"".as_ptr(), |s| s.as_ptr())
    }
}

/// The contexts the calling thread has a message on; its entries are removed at exit.
#[derive(Default)]
struct ThreadEntries {
    contexts: Vec<Weak<ErrorSlots>>,
}

impl Drop for ThreadEntries {
    fn drop(&mut self) {
        let me = std::thread::current().id();
        for slots in self.contexts.iter().filter_map(Weak::upgrade) {
            let mut map = slots.by_thread.lock().unwrap_or_else(|p| p.into_inner());
            map.remove(&me);
        }
    }
}

thread_local! {
    static THREAD_ERROR: RefCell<CString> = RefCell::new(CString::default());
    static ENTRIES: RefCell<ThreadEntries> = RefCell::new(ThreadEntries::default());
}

fn to_cstring(s: &str) -> CString {
    // Control characters (from file contents, say) become spaces: a message is one line of
    // plain text.
    let clean: String = s
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect();
    CString::new(clean).unwrap_or_default()
}

/// Records `e` for the calling thread, on the context's slots when there are some.
pub fn record(ctx: Option<&Arc<ErrorSlots>>, e: &Error) {
    let text = to_cstring(&e.message);
    if let Some(slots) = ctx {
        let me = std::thread::current().id();
        slots
            .by_thread
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .insert(me, text.clone());
        // Register the context so the entry goes away with the thread.
        let _ = ENTRIES.try_with(|entries| {
            let mut entries = entries.borrow_mut();
            let known = entries
                .contexts
                .iter()
                .any(|w| std::ptr::eq(w.as_ptr(), Arc::as_ptr(slots)));
            if !known {
                entries.contexts.retain(|w| w.strong_count() > 0);
                entries.contexts.push(Arc::downgrade(slots));
            }
        });
    }
    let _ = THREAD_ERROR.try_with(|t| *t.borrow_mut() = text);
}

/// The calling thread's most recent message (any context or none).
pub fn thread_message() -> *const c_char {
    THREAD_ERROR
        .try_with(|t| t.borrow().as_ptr())
        .unwrap_or(c"".as_ptr())
}

/// Marks the calling thread as running library code for as long as the guard lives:
/// panics there are caught and reported as statuses, so the hook prints nothing.
pub struct QuietGuard;

impl QuietGuard {
    pub fn enter() -> Self {
        install_hook();
        QUIET.with(|q| q.set(q.get() + 1));
        QuietGuard
    }
}

impl Drop for QuietGuard {
    fn drop(&mut self) {
        QUIET.with(|q| q.set(q.get().saturating_sub(1)));
    }
}

/// Installs, once, a panic hook that is silent on quiet threads and otherwise hands over
/// to the hook that was there before. In the C library the Rust runtime is private to
/// libimap, so the host never sees it; a Rust program linking the rlib keeps its own
/// hook for its own threads.
fn install_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if QUIET.try_with(|q| q.get()).unwrap_or(0) == 0 {
                previous(info);
            }
        }));
    });
}

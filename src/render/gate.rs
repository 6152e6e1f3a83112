//! The backward photon maps' active-thread counter (the second paper, §2.3, Figs. 6–7): how
//! a group opens its maps to the other groups during its forward-ray step and closes them
//! again without locks and without ever freeing maps another thread still reads.
//!
//! Protocol (checked by the loom model in `loom/tests/loom_gate.rs`):
//! 1. Counter 0: the maps are closed (being built, finalized or rebuilt); only the owner
//!    touches them. Only the owner moves the counter away from 0, with an increment
//!    (`open`, release: the built maps are published with it).
//! 2. Another thread joins only while the counter is above 0, by compare-and-swap x → x + 1
//!    (acquire: it then sees the maps as they were built). A failed CAS means "not now": the
//!    maps are skipped for this batch of forward rays.
//! 3. A joiner leaves with a decrement (release: its accumulations happen-before the owner's
//!    close).
//! 4. The owner closes with compare-and-swap 1 → 0 (acquire), which succeeds only when no
//!    joiner is inside; while it fails the owner keeps tracing forward rays into its own
//!    maps and tries again.
//!
//! A joiner's CAS can succeed on a counter that went 1 → 0 → 1 in between (the maps of the
//! next phase): that is harmless, because the joiner reads the maps only after its CAS and
//! the owner reopens only maps that are complete.

#[cfg(loom)]
use loom::sync::atomic::{AtomicUsize, Ordering};
#[cfg(not(loom))]
use std::sync::atomic::{AtomicUsize, Ordering};

/// The active-thread counter of one group's backward photon maps.
#[derive(Debug, Default)]
pub struct Gate {
    active: AtomicUsize,
}

impl Gate {
    pub fn new() -> Self {
        Gate {
            active: AtomicUsize::new(0),
        }
    }

    /// Owner: opens the (complete) maps to other threads. The counter must be 0.
    pub fn open(&self) {
        let before = self.active.fetch_add(1, Ordering::Release);
        debug_assert_eq!(before, 0, "open on a gate that is not closed");
    }

    /// Owner: tries to close; true when no other thread is inside (counter 1 → 0).
    pub fn try_close(&self) -> bool {
        self.active
            .compare_exchange(1, 0, Ordering::Acquire, Ordering::Relaxed)
            .is_ok()
    }

    /// Another thread: tries to enter; true when the maps were open and it is now counted.
    /// Never waits for the owner: it gives up as soon as it reads 0. (The paper gives up on
    /// the first failed CAS; retrying while the count stays above 0 loses fewer connections
    /// when several joiners race, and is still lock-free.)
    pub fn try_join(&self) -> bool {
        let mut n = self.active.load(Ordering::Relaxed);
        while n > 0 {
            match self
                .active
                .compare_exchange_weak(n, n + 1, Ordering::Acquire, Ordering::Relaxed)
            {
                Ok(_) => return true,
                Err(now) => n = now,
            }
        }
        false
    }

    /// Another thread: leaves after a successful `try_join`.
    pub fn leave(&self) {
        let before = self.active.fetch_sub(1, Ordering::Release);
        debug_assert!(before > 1, "leave without a join");
    }

    /// Current count (for tests and the loom model).
    #[cfg(any(test, loom))]
    pub fn active(&self) -> usize {
        self.active.load(Ordering::Relaxed)
    }
}

#[cfg(all(test, not(loom)))]
mod tests {
    use super::*;

    #[test]
    fn the_counter_follows_the_protocol() {
        let g = Gate::new();
        assert!(!g.try_join(), "closed maps cannot be joined");
        g.open();
        assert!(g.try_join());
        assert!(g.try_join());
        assert_eq!(g.active(), 3);
        assert!(!g.try_close(), "two joiners are inside");
        g.leave();
        assert!(!g.try_close());
        g.leave();
        assert!(g.try_close());
        assert_eq!(g.active(), 0);
        assert!(!g.try_join());
    }
}

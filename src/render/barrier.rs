//! The groups' barrier: it gives up when the render is poisoned by a lost thread.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

/// A barrier that gives up (returns false) when the render is poisoned by a lost thread.
pub(super) struct Barrier {
    n: usize,
    state: Mutex<(usize, u64)>,
    cv: Condvar,
}

impl Barrier {
    pub(super) fn new(n: usize) -> Self {
        Barrier {
            n,
            state: Mutex::new((0, 0)),
            cv: Condvar::new(),
        }
    }

    pub(super) fn wait(&self, poison: &AtomicBool) -> bool {
        if self.n == 1 {
            return !poison.load(Ordering::Relaxed);
        }
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        s.0 += 1;
        if s.0 == self.n {
            s.0 = 0;
            s.1 += 1;
            self.cv.notify_all();
            return !poison.load(Ordering::Relaxed);
        }
        let generation = s.1;
        while s.1 == generation {
            if poison.load(Ordering::Relaxed) {
                return false;
            }
            s = self
                .cv
                .wait_timeout(s, Duration::from_millis(20))
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
        !poison.load(Ordering::Relaxed)
    }
}

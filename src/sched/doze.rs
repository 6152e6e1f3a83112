//! How a processing thread of the dynamic scheduler waits for portions without making the
//! threads that hand them over pay a system call per portion.
//!
//! A blocking channel receive registers the waiting thread, and every send then wakes it
//! through the kernel: on one calculating thread that cost 10 % of its time (the hall at 81
//! bands, `perf`; BENCHMARKS.md), because a processing thread applies a portion in a fifth
//! of the time the next one takes to fill, so it was asleep at every send. Now a processing
//! thread whose queue is empty naps for short, growing intervals (its own system calls, on
//! a core the calculating threads leave free), and only after a longer idle spell announces
//! that it sleeps; a sender wakes it only then.
//!
//! Protocol (checked by the loom model in `loom/tests/loom_doze.rs`), a Dekker handshake:
//! - the sleeper sets `asleep`, then (SeqCst fence) looks at its queue once more and parks
//!   only if it is still empty and nothing else asks it to go on;
//! - a sender queues its portion, then (SeqCst fence) reads `asleep`, and unparks the
//!   sleeper if it was set.
//!
//! Of the two fences one comes first in their single total order: either the sleeper's
//! second look sees the portion, or the sender sees `asleep`. A wake-up cannot be lost; an
//! unpark that arrives before the park makes the park return at once.

#[cfg(loom)]
use loom::sync::atomic::{fence, AtomicBool, Ordering};
#[cfg(loom)]
use loom::thread::{self, Thread};
#[cfg(not(loom))]
use std::sync::atomic::{fence, AtomicBool, Ordering};
use std::sync::OnceLock;
#[cfg(not(loom))]
use std::thread::{self, Thread};

/// One processing thread's sleep flag and handle.
#[derive(Debug, Default)]
pub struct Doze {
    asleep: AtomicBool,
    /// The sleeping thread, set by itself before it first announces sleep (a sender reads
    /// it only after it saw the announcement).
    sleeper: OnceLock<Thread>,
}

impl Doze {
    /// A flag nobody sleeps on yet.
    pub fn new() -> Self {
        Doze::default()
    }

    /// The sleeper's side: announce sleep, then park unless `ready()` (its queue holds work,
    /// or it must end) is true after the announcement. Returns after a wake-up or, outside
    /// the loom model, after `timeout` at most (a safety net, not the mechanism).
    pub fn sleep(&self, ready: impl Fn() -> bool, timeout: std::time::Duration) {
        self.sleeper.get_or_init(thread::current);
        self.asleep.store(true, Ordering::SeqCst);
        fence(Ordering::SeqCst);
        if !ready() {
            #[cfg(loom)]
            {
                let _ = timeout;
                thread::park();
            }
            #[cfg(not(loom))]
            thread::park_timeout(timeout);
        }
        self.asleep.store(false, Ordering::Relaxed);
    }

    /// The sender's side, after it made `ready()` true (queued a portion, or asked the
    /// sleeper to end): wakes the sleeper if it announced sleep. Costs a fence and a load
    /// when nobody sleeps.
    pub fn wake(&self) {
        fence(Ordering::SeqCst);
        if self.asleep.load(Ordering::Relaxed) && self.asleep.swap(false, Ordering::AcqRel) {
            if let Some(t) = self.sleeper.get() {
                t.unpark();
            }
        }
    }
}

#[cfg(all(test, not(loom)))]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicUsize;
    use std::sync::Arc;
    use std::time::{Duration, Instant};

    /// A sender's wake-up ends a sleep long before its safety net would; a sleep whose
    /// `ready` already holds does not park at all.
    #[test]
    fn a_wake_up_ends_the_sleep_at_once() {
        let doze = Arc::new(Doze::new());
        let queued = Arc::new(AtomicUsize::new(0));
        let t0 = Instant::now();
        let sender = {
            let (doze, queued) = (doze.clone(), queued.clone());
            std::thread::spawn(move || {
                std::thread::sleep(Duration::from_millis(20));
                queued.fetch_add(1, Ordering::Relaxed);
                doze.wake();
            })
        };
        while queued.load(Ordering::Relaxed) == 0 {
            doze.sleep(
                || queued.load(Ordering::Relaxed) > 0,
                Duration::from_secs(30),
            );
        }
        sender.join().unwrap();
        let waited = t0.elapsed();
        assert!(waited < Duration::from_secs(5), "woken after {waited:?}");

        let t1 = Instant::now();
        doze.sleep(|| true, Duration::from_secs(30));
        assert!(t1.elapsed() < Duration::from_secs(5));
        // Nobody sleeps now: a wake costs a fence and a load and unparks nothing.
        assert!(!doze.asleep.load(Ordering::Relaxed));
        doze.wake();
    }
}

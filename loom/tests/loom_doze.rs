//! Exhaustive interleavings (loom) of the processing threads' sleep handshake in
//! `src/sched/doze.rs`. Run with:
//!
//!     RUSTFLAGS="--cfg loom" cargo test --release -p imap-loom --test loom_doze
//!
//! A lost wake-up leaves the sleeper parked for good, which loom reports as a deadlock
//! (the model parks without the timeout the library keeps as a safety net).
#![cfg(loom)]

use imap_loom::Doze;
use loom::sync::atomic::{AtomicUsize, Ordering};
use loom::sync::Arc;
use loom::thread;
use std::time::Duration;

/// `senders` threads each queue one portion (a relaxed count, as weak as the channel's own
/// ordering can be) and wake the owner; the owner sleeps until it has seen them all.
fn owner_sees_every_portion(senders: usize, preemption_bound: Option<usize>) {
    let mut model = loom::model::Builder::new();
    model.preemption_bound = preemption_bound;
    model.check(move || {
        let doze = Arc::new(Doze::new());
        let queued = Arc::new(AtomicUsize::new(0));
        let handles: Vec<_> = (0..senders)
            .map(|_| {
                let (doze, queued) = (doze.clone(), queued.clone());
                thread::spawn(move || {
                    queued.fetch_add(1, Ordering::Relaxed);
                    doze.wake();
                })
            })
            .collect();
        while queued.load(Ordering::Relaxed) < senders {
            doze.sleep(|| queued.load(Ordering::Relaxed) == senders, Duration::ZERO);
        }
        for h in handles {
            h.join().unwrap();
        }
    });
}

#[test]
fn a_queued_portion_always_wakes_its_sleeping_owner() {
    owner_sees_every_portion(1, None);
}

#[test]
fn two_senders_never_lose_the_owner_a_wake_up() {
    // Every interleaving with up to 3 preemptions (all of them take 110 s).
    owner_sees_every_portion(2, Some(3));
}

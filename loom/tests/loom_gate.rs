//! Exhaustive interleavings (loom) of the backward photon maps' active-thread counter in
//! `src/render/gate.rs`. Run with:
//!
//!     RUSTFLAGS="--cfg loom" cargo test --release -p imap-loom --test loom_gate
//!
//! The maps are a loom `UnsafeCell`: loom fails the model if the owner rebuilds them
//! (writes) while a joiner reads them without a happens-before between the two.
#![cfg(loom)]

use imap_loom::Gate;
use loom::cell::UnsafeCell;
use loom::sync::Arc;
use loom::thread;

/// The owner runs two phases (build, open, close with retries, rebuild); a joiner tries to
/// read the maps once and must see a complete phase's contents, never a rebuild.
fn owner_and_joiners(joiners: usize, preemption_bound: Option<usize>) {
    let mut model = loom::model::Builder::new();
    model.preemption_bound = preemption_bound;
    model.check(move || {
        let gate = Arc::new(Gate::new());
        // Maps: (phase, checksum) written together; a reader must see checksum = 10·phase.
        let maps = Arc::new(UnsafeCell::new((1u32, 10u32)));
        let handles: Vec<_> = (0..joiners)
            .map(|_| {
                let (gate, maps) = (gate.clone(), maps.clone());
                thread::spawn(move || {
                    if gate.try_join() {
                        // SAFETY (model): loom checks this read against the owner's writes.
                        let (phase, sum) = maps.with(|m| unsafe { *m });
                        assert_eq!(sum, 10 * phase, "read maps being rebuilt");
                        gate.leave();
                    }
                })
            })
            .collect();
        for phase in 1..=2u32 {
            // SAFETY (model): the owner writes only while the gate is closed.
            maps.with_mut(|m| unsafe { *m = (phase, 10 * phase) });
            gate.open();
            // Forward rays; then close, tracing more while joiners are inside.
            while !gate.try_close() {
                thread::yield_now();
            }
        }
        for h in handles {
            h.join().unwrap();
        }
        assert_eq!(gate.active(), 0);
    });
}

#[test]
fn a_joiner_never_reads_maps_being_rebuilt() {
    owner_and_joiners(1, None);
}

#[test]
fn two_joiners_racing_for_one_map() {
    // Three threads with retry loops: bounded to 5 preemptions (loom's recommended
    // practice; every interleaving with up to 5 forced switches is explored).
    owner_and_joiners(2, Some(5));
}

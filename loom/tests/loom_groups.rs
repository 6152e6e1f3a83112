//! Exhaustive interleavings (loom) of the vertex-group split protocol in
//! `src/sched/groups.rs`. Run with:
//!
//!     RUSTFLAGS="--cfg loom" cargo test --release -p imap-loom --test loom_groups
//!
//! The map values of one slot are a loom `UnsafeCell`: loom fails the model if two threads
//! write it without a happens-before between them, i.e. if a subgroup's owner could start
//! writing while the split group's owner still applies a portion.
#![cfg(loom)]

use imap_loom::GroupTable;
use loom::cell::UnsafeCell;
use loom::sync::Arc;
use loom::thread;

/// 8 slots in one group; splitting into 4 gives children 1..5 of 3, 3, 2 and 0 slots.
fn table() -> Arc<GroupTable> {
    Arc::new(GroupTable::new(8, 1, 9, 4))
}

#[test]
fn a_split_never_lets_two_owners_write_one_slot() {
    loom::model(|| {
        let table = table();
        let value = Arc::new(UnsafeCell::new(0u64));

        // A calculating thread deposits on slot 1; if it found the unsplit group and could
        // open a portion there, that group's owner applies it (modelled in this thread).
        let t = {
            let (table, value) = (table.clone(), value.clone());
            thread::spawn(move || {
                let g = table.lookup(1);
                if g == 0 && table.try_open(0) {
                    // SAFETY (model): loom checks this access against the child's.
                    value.with_mut(|v| unsafe { *v += 1 });
                    table.close(0);
                } else {
                    // The split was seen: the lookup must lead to the subgroup, whose
                    // fields were published before subd_state.
                    assert_eq!(table.lookup(1), 1);
                }
            })
        };

        // The monitor splits group 0; the first subgroup's owner writes slot 1 once no
        // ancestor has a portion left.
        let kids = table.split(0);
        assert_eq!(kids, 1..5);
        assert_eq!(table.lookup(1), 1);
        while !table.ancestors_done(1) {
            thread::yield_now();
        }
        // SAFETY (model): as above.
        value.with_mut(|v| unsafe { *v += 10 });
        t.join().unwrap();
        assert!(matches!(value.with(|v| unsafe { *v }), 10 | 11));
    });
}

#[test]
fn lookups_during_nested_splits_find_a_published_group() {
    loom::model(|| {
        let table = Arc::new(GroupTable::new(8, 1, 9, 4));
        let reader = {
            let table = table.clone();
            thread::spawn(move || {
                for slot in [0, 2, 4] {
                    let g = table.lookup(slot);
                    // Whatever the interleaving, the group found holds the slot.
                    assert!(
                        table.range(g).contains(&slot),
                        "slot {slot} looked up in group {g} {:?}",
                        table.range(g)
                    );
                }
            })
        };
        table.split(0);
        table.split(1);
        reader.join().unwrap();
    });
}

#[test]
fn a_reader_holding_the_chain_never_overlaps_a_writer() {
    loom::model(|| {
        let table = table();
        let value = Arc::new(UnsafeCell::new(0u64));
        // A portion of group 0 was opened before the split and is still to be applied.
        assert!(table.try_open(0));
        table.split(0);

        // The parent's writer applies it under group 0's lock.
        let parent = {
            let (table, value) = (table.clone(), value.clone());
            thread::spawn(move || {
                while !table.try_lock(0) {
                    thread::yield_now();
                }
                // SAFETY (model): loom checks every access to the cell.
                value.with_mut(|v| unsafe { *v += 1 });
                table.close(0);
                table.unlock(0);
            })
        };
        // The subgroup's writer (a calculating thread applying inline, or its processing
        // thread) writes once the parent is done, under the subgroup's lock.
        let child = {
            let (table, value) = (table.clone(), value.clone());
            thread::spawn(move || {
                while !table.ancestors_done(1) {
                    thread::yield_now();
                }
                while !table.try_lock(1) {
                    thread::yield_now();
                }
                // SAFETY (model): as above.
                value.with_mut(|v| unsafe { *v += 10 });
                table.unlock(1);
            })
        };
        // The monitor reads the subgroup's slot for a progress report.
        let mut chain = Vec::new();
        table.lock_chain(1, &mut chain);
        // SAFETY (model): as above.
        let seen = value.with(|v| unsafe { *v });
        table.unlock_chain(&chain);
        assert!(
            matches!(seen, 0 | 1 | 11),
            "read {seen}: a write was torn or reordered"
        );
        parent.join().unwrap();
        child.join().unwrap();
        assert_eq!(value.with(|v| unsafe { *v }), 11);
    });
}

//! The strongest test of a scheduler: the same seed must give the same map with any
//! scheduler and thread count (up to summation order, relative 1e-12). A lost, doubled or
//! racing portion shows at once.

mod common;

use common::*;
use imap::DynamicParams;
use imap::SchedulerKind;
use imap::{Bands, Config, Context};
use std::time::Duration;

fn config(
    scheduler: SchedulerKind,
    threads: usize,
    dynamic: DynamicParams,
    bands: Bands,
) -> Config {
    Config {
        threads,
        seed: 77,
        scheduler,
        dynamic,
        bands,
        ..Default::default()
    }
}

/// Thresholds that split at every chance: hundreds of splits in a short run. Portions go
/// through the processing threads (`inline_apply` false) unless `inline` is set.
fn split_happy(inline: bool) -> DynamicParams {
    DynamicParams {
        initial_groups: 1,
        max_groups: 4096,
        low_threshold: usize::MAX,
        high_threshold: 0,
        min_group_slots: 1,
        split_interval: Duration::ZERO,
        inline_apply: Some(inline),
        ..Default::default()
    }
}

fn run_map(ctx: &mut Context, ids: &[u32], n: u64) -> (Vec<f64>, imap::Report) {
    let r = run_photons(ctx, n);
    (whole_map(ctx, ids), r)
}

#[test]
fn classic_dynamic_and_thread_counts_agree() {
    for bands in [Bands::rgb(), Bands::spectral(81, 380.0, 780.0).unwrap()] {
        let n = photons(40_000);
        let (mut ctx, ids) = mixed_room(config(
            SchedulerKind::Classic,
            1,
            DynamicParams::default(),
            bands.clone(),
        ));
        let (reference, _) = run_map(&mut ctx, &ids, n);
        for (kind, threads, dp, what) in [
            (
                SchedulerKind::Classic,
                2,
                DynamicParams::default(),
                "classic, 2 threads",
            ),
            (
                SchedulerKind::Dynamic,
                1,
                DynamicParams::default(),
                "dynamic, 1 thread",
            ),
            (
                SchedulerKind::Dynamic,
                2,
                DynamicParams::default(),
                "dynamic, 2 threads",
            ),
            (
                SchedulerKind::Dynamic,
                2,
                DynamicParams {
                    inline_apply: Some(true),
                    ..Default::default()
                },
                "dynamic, 2 threads, inline",
            ),
            (
                SchedulerKind::Dynamic,
                3,
                split_happy(false),
                "dynamic, 3 threads, forced splits",
            ),
            (
                SchedulerKind::Dynamic,
                3,
                split_happy(true),
                "dynamic, 3 threads, forced splits, inline",
            ),
        ] {
            let (mut ctx, ids) = mixed_room(config(kind, threads, dp, bands.clone()));
            let (map, r) = run_map(&mut ctx, &ids, n);
            eprintln!(
                "{} bands, {what}: {} splits, {} groups, peak queue {}",
                bands.count(),
                r.counters.splits,
                r.counters.groups,
                r.counters.peak_queue
            );
            assert_maps_agree(
                &reference,
                &map,
                &format!("{} bands, {what} vs classic 1 thread", bands.count()),
            );
        }
    }
}

/// A 100×100 grid (10 201 vertices) under a point light, with a sheet above it: enough
/// vertices for hundreds of splits.
fn lit_grid(kind: SchedulerKind, dp: DynamicParams) -> (Context, Vec<u32>) {
    let mut ctx = context(config(
        kind,
        2,
        dp,
        Bands::spectral(41, 380.0, 780.0).unwrap(),
    ));
    let grey = lambert(&mut ctx, 0.5);
    let floor = grid(100, 0.0, 10.0, 0.0, 10.0, 0.0);
    let id = ctx.add_mesh(&floor.desc(grey)).unwrap();
    let sheet = grid(10, 2.0, 8.0, 2.0, 8.0, 3.0).flipped();
    let id2 = ctx.add_mesh(&sheet.desc(grey)).unwrap();
    ctx.add_point_light([5.0, 5.0, 2.0], &[10.0]).unwrap();
    (ctx, vec![id, id2])
}

#[test]
fn hundreds_of_splits_lose_nothing() {
    let n = photons(600_000);
    let (mut ctx, ids) = lit_grid(SchedulerKind::Classic, DynamicParams::default());
    let (reference, _) = run_map(&mut ctx, &ids, n);
    let (mut ctx, ids) = lit_grid(SchedulerKind::Dynamic, split_happy(false));
    // Two runs, each starting from fresh groups and splitting under way; the second
    // continues the first's photons.
    let first = run_photons(&mut ctx, n / 2);
    let (map, second) = run_map(&mut ctx, &ids, n - n / 2);
    eprintln!(
        "splits per run: {} and {}; groups at the end {}",
        first.counters.splits, second.counters.splits, second.counters.groups
    );
    assert!(
        first.counters.splits >= 100 && second.counters.splits >= 100,
        "too few splits: {} and {}",
        first.counters.splits,
        second.counters.splits
    );
    assert_eq!(second.photons, n);
    assert_maps_agree(&reference, &map, "hundreds of splits vs classic");
}

#[test]
fn one_hot_group() {
    // A large receiving grid lit only in one corner by a narrow spot: nearly every photon
    // lands in the first group's vertices, which must split and split again.
    let n = photons(200_000);
    let build = |kind, dp| {
        let mut ctx = context(config(
            kind,
            2,
            dp,
            Bands::spectral(41, 380.0, 780.0).unwrap(),
        ));
        let grey = lambert(&mut ctx, 0.3);
        let g = grid(200, 0.0, 20.0, 0.0, 20.0, 0.0);
        let id = ctx.add_mesh(&g.desc(grey)).unwrap();
        ctx.add_spot_light([0.5, 0.3, 1.0], [0.0, 0.0, -1.0], 0.3, &[10.0])
            .unwrap();
        (ctx, vec![id])
    };
    let (mut classic, ids) = build(SchedulerKind::Classic, DynamicParams::default());
    let (reference, _) = run_map(&mut classic, &ids, n);
    let dp = DynamicParams {
        initial_groups: 8,
        max_groups: 512,
        min_group_slots: 16,
        ..split_happy(true)
    };
    let (mut dynamic, ids) = build(SchedulerKind::Dynamic, dp);
    let (map, r) = run_map(&mut dynamic, &ids, n);
    eprintln!(
        "hot corner: {} splits, {} groups",
        r.counters.splits, r.counters.groups
    );
    assert!(
        r.counters.splits >= 3,
        "the hot group was split {} times",
        r.counters.splits
    );
    assert_maps_agree(&reference, &map, "hot corner, dynamic vs classic");
}

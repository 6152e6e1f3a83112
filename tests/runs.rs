//! Runs: determinism across thread counts, resumption, energy bookkeeping, the memory
//! budget, stop criteria.

mod common;

use common::*;
use imap::{Config, ImapStatus, MaterialDesc, RunParams, StopReason};

fn spectral(bands: u32) -> imap::Bands {
    imap::Bands::spectral(bands, 380.0, 780.0).unwrap()
}

#[test]
fn same_seed_same_map_for_1_and_2_threads() {
    for bands in [imap::Bands::rgb(), spectral(41)] {
        let n = photons(60_000);
        let maps: Vec<Vec<f64>> = [1, 2]
            .iter()
            .map(|&threads| {
                let (mut ctx, ids) = mixed_room(Config {
                    threads,
                    seed: 42,
                    bands: bands.clone(),
                    ..Default::default()
                });
                run_photons(&mut ctx, n);
                whole_map(&ctx, &ids)
            })
            .collect();
        assert_maps_agree(
            &maps[0],
            &maps[1],
            &format!("{} bands, 1 vs 2 threads", bands.count()),
        );
        // A different seed gives a different map (the comparison above can fail).
        let (mut ctx, ids) = mixed_room(Config {
            threads: 2,
            seed: 43,
            bands: bands.clone(),
            ..Default::default()
        });
        run_photons(&mut ctx, n);
        let other = whole_map(&ctx, &ids);
        assert!(maps[0]
            .iter()
            .zip(&other)
            .any(|(a, b)| (a - b).abs() > 1e-6 * a.abs().max(1e-300)));
    }
}

#[test]
fn resumed_runs_equal_one_long_run() {
    let n = photons(40_000);
    let (mut one, ids) = mixed_room(Config {
        threads: 2,
        seed: 9,
        ..Default::default()
    });
    run_photons(&mut one, 3 * n);
    let (mut parts, _) = mixed_room(Config {
        threads: 2,
        seed: 9,
        ..Default::default()
    });
    for _ in 0..3 {
        run_photons(&mut parts, n);
    }
    assert_eq!(parts.report().photons, 3 * n);
    assert_maps_agree(
        &whole_map(&one, &ids),
        &whole_map(&parts, &ids),
        "3 runs vs 1",
    );
}

#[test]
fn energy_is_conserved_to_rounding() {
    for bands in [imap::Bands::rgb(), spectral(81)] {
        let (mut ctx, _) = mixed_room(Config {
            threads: 2,
            seed: 5,
            bands: bands.clone(),
            ..Default::default()
        });
        let r = run_photons(&mut ctx, photons(100_000));
        let balance = r.absorbed_w + r.escaped_w + r.dropped_w;
        eprintln!(
            "{} bands: emitted {} W, absorbed {} + escaped {} + dropped {} = {balance} (relative {:.1e})",
            bands.count(),
            r.emitted_w,
            r.absorbed_w,
            r.escaped_w,
            r.dropped_w,
            (balance - r.emitted_w).abs() / r.emitted_w
        );
        assert!((balance - r.emitted_w).abs() <= 1e-9 * r.emitted_w);
        assert_eq!(r.escaped_w, 0.0, "the room is closed");
        assert_eq!(r.dropped_photons, 0);
        let nb = bands.count() as f64;
        let ramp_sum = |a: f64, b: f64| (a + b) / 2.0 * nb;
        let expected = 0.36 * ramp_sum(50.0, 20.0) + ramp_sum(5.0, 9.0) + 3.0 * nb;
        // Lights are chosen by power mixed with a uniform share and the photons carry the
        // ratio, so the launched power matches the lights' within its sampling spread
        // (about 1e-4 relative here).
        assert!(
            (r.emitted_w - expected).abs() < 1e-3 * expected,
            "{} vs {expected}",
            r.emitted_w
        );
    }
}

#[test]
fn the_event_limit_reports_what_it_drops() {
    // Two facing perfect mirrors: a photon between them never ends by itself.
    let mut ctx = context(Config {
        threads: 2,
        seed: 1,
        ..Default::default()
    });
    let mirror = ctx
        .add_material(&MaterialDesc {
            specular_reflect: vec![1.0],
            ..Default::default()
        })
        .unwrap();
    let low = grid(1, -100.0, 100.0, -100.0, 100.0, 0.0);
    let high = grid(1, -100.0, 100.0, -100.0, 100.0, 1.0).flipped();
    ctx.add_mesh(&low.desc(mirror)).unwrap();
    ctx.add_mesh(&high.desc(mirror)).unwrap();
    ctx.add_spot_light([0.0, 0.0, 0.5], [0.0, 0.0, 1.0], 1e-4, &[1.0])
        .unwrap();
    let mut params = RunParams {
        region: None,
        photons: 100,
        time_budget_s: 0.0,
        target_rel_error: 0.0,
        progress_interval_s: 1.0,
        max_path_events: 1000,
        selection: Default::default(),
        estimator: None,
        progress: None,
    };
    let r = ctx.run(&mut params).unwrap();
    assert_eq!(r.dropped_photons, 100);
    assert!((r.dropped_w - r.emitted_w).abs() < 1e-12 * r.emitted_w);
}

#[test]
fn memory_budget_refuses_before_allocating() {
    let g = grid(100, 0.0, 1.0, 0.0, 1.0, 0.0); // 10 201 vertices, 20 000 triangles
    let mut ctx = context(Config {
        bands: spectral(81),
        memory_budget: 8 << 20,
        threads: 2,
        ..Default::default()
    });
    let m = lambert(&mut ctx, 0.5);
    // The map, 10 201 × 82 × 8 = 6 691 856 bytes, the light-sampling estimator's direct
    // records, 10 201 × 84 × 8 = 6 855 072, and vertex adjacency, 20 000 × 3 × 8 +
    // 10 202 × 4 = 520 808, plus the mesh's copy (484 824), prepared form (684 020), BVH
    // estimate (2 083 216), transient f64 vertices (244 824) and a run's buffers on two
    // threads: over 8 MiB.
    let err = ctx.add_mesh(&g.desc(m)).unwrap_err();
    assert_eq!(err.status, ImapStatus::ImapErrMemoryBudget);
    let needs: u64 = err
        .message
        .split("needs ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .expect("the message states the bytes");
    let fixed = 6_691_856 + 6_855_072 + 520_808 + 484_824 + 684_020 + 2_083_216 + 244_824;
    assert!(
        needs > fixed && needs < fixed + (8 << 20),
        "{}",
        err.message
    );
    // A mesh that records nothing costs no map memory and is accepted.
    let mut d = g.desc(m);
    d.record = false;
    ctx.add_mesh(&d).unwrap();
    // RGB needs 10 201 × (4 + 6) × 8 = 816 kB of map and direct records: accepted under
    // the same budget, and so is its run.
    let mut rgb = context(Config {
        memory_budget: 8 << 20,
        ..Default::default()
    });
    let m = lambert(&mut rgb, 0.5);
    rgb.add_mesh(&g.desc(m)).unwrap();
    rgb.add_point_light([0.5, 0.5, 1.0], &[1.0]).unwrap();
    let r = run_photons(&mut rgb, 1000);
    assert_eq!(r.map_bytes, 10_201 * (4 + 6) * 8);
}

#[test]
fn time_budget_and_target_error_stop_the_run() {
    let (mut ctx, _) = mixed_room(Config {
        threads: 2,
        seed: 3,
        ..Default::default()
    });
    let mut reports = Vec::new();
    let mut cb = |p: &imap::Progress| {
        reports.push(*p);
        true
    };
    let mut params = RunParams {
        region: None,
        photons: 0,
        time_budget_s: 0.6,
        target_rel_error: 0.0,
        progress_interval_s: 0.1,
        max_path_events: 1 << 20,
        selection: Default::default(),
        estimator: None,
        progress: Some(&mut cb),
    };
    let r = ctx.run(&mut params).unwrap();
    assert_eq!(r.stop, Some(StopReason::TimeBudget));
    assert!(
        r.run_wall_s >= 0.6 && r.run_wall_s < 1.5,
        "{}",
        r.run_wall_s
    );
    assert!(reports.len() >= 4, "{} progress reports", reports.len());
    // The error falls as the photons grow.
    assert!(reports.last().unwrap().rel_error < reports[0].rel_error);
    assert!(reports
        .windows(2)
        .all(|w| w[1].photons >= w[0].photons && w[1].elapsed_s >= w[0].elapsed_s));

    let target = 0.6 * r.rel_error;
    let mut params = RunParams {
        region: None,
        photons: 0,
        time_budget_s: 30.0,
        target_rel_error: target,
        progress_interval_s: 0.1,
        max_path_events: 1 << 20,
        selection: Default::default(),
        estimator: None,
        progress: None,
    };
    let r2 = ctx.run(&mut params).unwrap();
    assert_eq!(r2.stop, Some(StopReason::TargetError));
    assert!(
        r2.rel_error <= target * 1.05,
        "{} vs {target}",
        r2.rel_error
    );
    // The history keeps both runs, with time accumulated across them.
    let h = ctx.history();
    assert!(h.len() > reports.len());
    assert!((h.last().unwrap().elapsed_s - (r.run_wall_s + r2.run_wall_s)).abs() < 0.05);
}

/// The progress callback sees every check the run records, the one that met the target
/// error and the one that met a region target included (it saw every check but those: a
/// host plotting error against time never saw its target met).
#[test]
fn the_callback_sees_the_check_that_met_the_target() {
    for region in [false, true] {
        let (mut ctx, ids) = mixed_room(seeded(7));
        let mut seen = Vec::new();
        let mut cb = |p: &imap::Progress| {
            seen.push(*p);
            true
        };
        let r = ctx
            .run(&mut RunParams {
                target_rel_error: if region { 0.0 } else { 0.05 },
                region: region.then(|| imap::RegionTarget {
                    meshes: vec![ids[0] as usize],
                    part: None,
                    measure: imap::RegionMeasure::Vertices { percentile: 50.0 },
                    target: 0.05,
                }),
                time_budget_s: 60.0,
                progress_interval_s: 0.01,
                progress: Some(&mut cb),
                ..Default::default()
            })
            .unwrap();
        let want = if region {
            StopReason::RegionTarget
        } else {
            StopReason::TargetError
        };
        assert_eq!(r.stop, Some(want));
        let history = ctx.history().to_vec();
        assert_eq!(seen, history, "the callback's points against the history");
        let met = |p: &imap::Progress| {
            if region {
                p.region_rel_error <= 0.05
            } else {
                p.rel_error <= 0.05
            }
        };
        // The check that met it, before the final report.
        assert!(met(&seen[seen.len() - 2]), "{:?}", &seen[seen.len() - 2..]);
    }
}

//! Safe to embed: every defect a hostile integrator found, as a regression test.
//! Each test names its item. Hangs are caught by running the body on a thread with a
//! deadline; panics, aborts and printing are caught by running a child process.

mod common;

use common::*;
use imap::{
    CameraDesc, Config, Context, ImapStatus, MeshDesc, RenderMethod, RenderParams, RunParams,
    SchedulerKind, StopReason,
};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Runs `f` on a thread; fails when it does not finish within `secs` (a hang).
fn within<T: Send + 'static>(secs: f64, what: &str, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    match rx.recv_timeout(Duration::from_secs_f64(secs)) {
        Ok(v) => v,
        Err(_) => panic!("{what}: did not return within {secs} s"),
    }
}

fn params<'a>(photons: u64) -> RunParams<'a> {
    RunParams {
        region: None,
        photons,
        time_budget_s: 0.0,
        target_rel_error: 0.0,
        progress_interval_s: 0.5,
        max_path_events: 1 << 20,
        selection: Default::default(),
        estimator: None,
        progress: None,
    }
}

/// A floor 2 × 2 under a point light: the smallest scene that records something.
fn floor_scene(config: Config) -> (Context, u32) {
    let mut ctx = context(config);
    let grey = lambert(&mut ctx, 0.5);
    let g = grid(8, -1.0, 1.0, -1.0, 1.0, 0.0);
    let id = ctx.add_mesh(&g.desc(grey)).unwrap();
    ctx.add_point_light([0.1, 0.2, 1.0], &[10.0]).unwrap();
    (ctx, id)
}

fn map_of(ctx: &Context, id: u32) -> Vec<f64> {
    let n = ctx.vertex_count(id).unwrap();
    let mut e = vec![0.0; n];
    ctx.irradiance(id, 0, 0, &mut e).unwrap();
    e
}

fn schedulers() -> [SchedulerKind; 2] {
    [SchedulerKind::Classic, SchedulerKind::Dynamic]
}

fn config(scheduler: SchedulerKind) -> Config {
    Config {
        scheduler,
        threads: 2,
        ..Default::default()
    }
}

/// A huge finite time budget or progress interval (a natural "no limit") is taken
/// as no limit, on both schedulers; the run returns and later calls work.
#[test]
fn huge_time_budgets_and_intervals_are_no_limit() {
    for s in schedulers() {
        for big in [1e19, 1e100, 1e300] {
            let r = within(30.0, "huge time budget", move || {
                let (mut ctx, id) = floor_scene(config(s));
                let mut p = params(20_000);
                p.time_budget_s = big;
                let r = ctx.run(&mut p).map(|r| r.stop);
                let mut p = params(20_000);
                p.progress_interval_s = big;
                let r2 = ctx.run(&mut p).map(|r| r.photons);
                (r, r2, map_of(&ctx, id).iter().sum::<f64>())
            });
            assert_eq!(r.0, Ok(Some(StopReason::PhotonCount)), "{s:?} budget {big}");
            assert_eq!(r.1, Ok(40_000), "{s:?} interval {big}");
            assert!(r.2 > 0.0);
        }
    }
}

/// A progress interval of 1e-12 s neither spins for ever nor floods the history:
/// it is raised to 1 ms, the history keeps at most 4096 points, and the callback is called
/// at most once a millisecond.
#[test]
fn tiny_progress_intervals_are_raised_and_histories_bounded() {
    for s in schedulers() {
        let (calls, wall, hist) = within(20.0, "interval 1e-12", move || {
            let (mut ctx, _) = floor_scene(config(s));
            let mut calls = 0u64;
            let mut cb = |_: &imap::Progress| {
                calls += 1;
                true
            };
            let mut p = params(0);
            p.time_budget_s = 0.5;
            p.progress_interval_s = 1e-12;
            p.progress = Some(&mut cb);
            let t = Instant::now();
            ctx.run(&mut p).unwrap();
            let secs = t.elapsed().as_secs_f64();
            let hist = ctx.history().len();
            let _ = p;
            (calls, secs, hist)
        });
        eprintln!("{s:?}: {calls} callbacks in {wall:.2} s, history {hist}");
        assert!(
            calls as f64 <= wall / 1e-3 + 2.0,
            "{calls} callbacks in {wall} s"
        );
        assert!(hist <= imap::MAX_HISTORY);
    }
    // A render with the same interval: its history stays bounded too.
    let hist = within(30.0, "render interval 1e-12", || {
        let (mut ctx, _) = floor_scene(Config::default());
        let mut rp = render_params();
        rp.time_budget_s = 1.5;
        rp.progress_interval_s = 1e-12;
        let (_, report) = ctx.render(&camera(16), &mut rp).unwrap();
        report.history.len()
    });
    assert!(hist <= imap::MAX_HISTORY, "render history {hist}");
}

fn render_params<'a>() -> RenderParams<'a> {
    RenderParams {
        method: RenderMethod::SemiSynchronous,
        remask_phases: 4,
        ..Default::default()
    }
}

fn camera(size: u32) -> CameraDesc {
    CameraDesc {
        position: [0.0, -2.0, 1.5],
        direction: [0.0, 2.0, -1.5],
        up: [0.0, 0.0, 1.0],
        fov_y_deg: 60.0,
        width: size,
        height: size,
        projection: imap::Projection::Perspective,
    }
}

/// A caller buffer larger than the mesh gets the vertex values, and the rest of
/// it is left as it was.
#[test]
fn a_larger_buffer_gets_the_vertices_and_keeps_the_rest() {
    let (mut ctx, id) = floor_scene(Config::default());
    run_photons(&mut ctx, 10_000);
    let nv = ctx.vertex_count(id).unwrap();
    let mut out = vec![-7.0; nv + 13];
    ctx.irradiance(id, 0, 1, &mut out).unwrap();
    assert!(out[..nv].iter().all(|x| x.is_finite() && *x >= 0.0));
    assert!(out[..nv].iter().any(|x| *x > 0.0));
    assert!(out[nv..].iter().all(|x| *x == -7.0));
    let mut err = vec![-7.0; nv + 13];
    ctx.rel_error(id, 0, &mut err).unwrap();
    assert!(err[nv..].iter().all(|x| *x == -7.0));
    // Too small a buffer is refused and nothing is written.
    let mut small = vec![-7.0; nv - 1];
    let e = ctx.irradiance(id, 0, 0, &mut small).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrBufferTooSmall);
    assert!(small.iter().all(|x| *x == -7.0));
}

/// Vertices no triangle uses do not count; a scene whose extent leaves a mesh's
/// triangles unresolvable in f32 is refused naming the mesh, never silently wrong.
#[test]
fn far_unused_vertices_do_not_count_and_unresolvable_meshes_are_refused() {
    let (mut plain, id) = floor_scene(Config::default());
    run_photons(&mut plain, 20_000);
    let reference = map_of(&plain, id);
    // The same floor with one unused vertex at x = 1e9: the same map, bit for bit.
    let mut ctx = context(Config::default());
    let grey = lambert(&mut ctx, 0.5);
    let mut g = grid(8, -1.0, 1.0, -1.0, 1.0, 0.0);
    g.positions.extend([1e9, 0.0, 0.0]);
    let id = ctx.add_mesh(&g.desc(grey)).unwrap();
    ctx.add_point_light([0.1, 0.2, 1.0], &[10.0]).unwrap();
    run_photons(&mut ctx, 20_000);
    let got = map_of(&ctx, id);
    assert_maps_agree(&got[..reference.len()], &reference, "an unused far vertex");
    assert_eq!(got[reference.len()], 0.0, "the unused vertex has no area");
    // A small object 1e7 units away: the floor cannot be resolved next to it.
    let (mut far, _) = floor_scene(Config::default());
    let grey = lambert(&mut far, 0.5);
    let cube = cuboid([1e7, 0.0, 0.0], [1e7 + 1.0, 1.0, 1.0], 2, false);
    let far_id = far.add_mesh(&cube.desc(grey)).unwrap();
    let e = far.run(&mut params(1000)).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrPrecision, "{e}");
    assert!(e.message.starts_with("mesh 0:"), "{}", e.message);
    // The context stays usable: without the far object (after a reset and a new
    // context) the scene runs; the far object alone runs too.
    assert!(far.vertex_count(far_id).is_ok());
    // A far light is fine: its photons enter through the scene's bounding sphere, so the
    // floor keeps its precision. A spot 1e7 units above with a 1 µrad cone lights the
    // floor uniformly with E = P / (2π (1 − cos θ) h²) = 1 W/m² for P = 100π W.
    let mut ctx = context(Config::default());
    let grey = lambert(&mut ctx, 0.5);
    let g = grid(8, -1.0, 1.0, -1.0, 1.0, 0.0);
    let id = ctx.add_mesh(&g.desc(grey)).unwrap();
    let theta: f64 = 1e-6;
    let power = 2.0 * std::f64::consts::PI * (1.0 - theta.cos()) * 1e14;
    ctx.add_spot_light([0.0, 0.0, 1e7], [0.0, 0.0, -1.0], theta, &[power])
        .unwrap();
    run_photons(&mut ctx, 2_000_000);
    let e = map_of(&ctx, id);
    let mut err = vec![0.0; e.len()];
    ctx.rel_error(id, 0, &mut err).unwrap();
    let areas = vertex_areas(&g);
    let mean = e.iter().zip(&areas).map(|(e, a)| e * a).sum::<f64>() / 4.0;
    let sigma = (e
        .iter()
        .zip(&areas)
        .zip(&err)
        .map(|((e, a), r)| (e * a * r).powi(2))
        .sum::<f64>())
    .sqrt()
        / 4.0;
    assert!(
        (mean - 1.0).abs() < 4.0 * sigma + 1e-3,
        "mean {mean} ± {sigma}"
    );
    // Every vertex, edges and corners included, sees the same irradiance (a photon
    // origin rounded to f32 at 1e7 would smear them by half a unit).
    for (v, (x, r)) in e.iter().zip(&err).enumerate() {
        assert!(
            (x - 1.0).abs() < 5.0 * r * x + 1e-3,
            "vertex {v}: {x} ± {}",
            r * x
        );
    }
}

/// Zero or overflowing emitted power gets its own status naming the light or
/// mesh; unit_m must be a usable number of metres.
#[test]
fn zero_and_overflowing_powers_are_refused_by_name() {
    let mut ctx = context(Config::default());
    let grey = lambert(&mut ctx, 0.5);
    // A zero-area emitting mesh (all vertices on a line).
    let line = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0];
    let e = ctx
        .add_mesh(&MeshDesc {
            record: false,
            exitance: Some(&[100.0]),
            ..MeshDesc::new(&line, &[0, 1, 2], grey)
        })
        .unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrNoLight, "{e}");
    assert!(e.message.contains("zero total area"), "{e}");
    // 1e308 W in each of three bands overflows.
    let e = ctx.add_point_light([0.0, 0.0, 1.0], &[1e308]).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrInvalidArgument, "{e}");
    // An emitter at 1e200.
    let e = ctx.add_point_light([1e200, 0.0, 0.0], &[1.0]).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrPrecision, "{e}");
    let far = [1e200, 0.0, 0.0, 1e200, 1.0, 0.0, 1e200, 0.0, 1.0];
    let e = ctx
        .add_mesh(&MeshDesc {
            record: false,
            exitance: Some(&[1.0]),
            ..MeshDesc::new(&far, &[0, 1, 2], grey)
        })
        .unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrPrecision, "{e}");
    // Two lights that are each fine but overflow together: refused at the run, named.
    ctx.add_mesh(&grid(2, -1.0, 1.0, -1.0, 1.0, 0.0).desc(grey))
        .unwrap();
    ctx.add_point_light([0.0, 0.0, 1.0], &[1e308 / 3.0 * 2.0])
        .unwrap_err();
    ctx.add_point_light([0.0, 0.0, 1.0], &[5e307]).unwrap();
    ctx.add_point_light([0.0, 0.0, 2.0], &[5e307]).unwrap();
    let e = ctx.run(&mut params(100)).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrInvalidArgument, "{e}");
    assert!(e.message.contains("total power"), "{e}");
    // unit_m that makes areas underflow or irradiance overflow.
    for unit in [1e-300, 1e-200, 1e-10, 1e10, 1e300] {
        let e = Context::new(Config {
            unit_m: unit,
            ..Default::default()
        })
        .err()
        .unwrap_or_else(|| panic!("unit_m {unit} accepted"));
        assert_eq!(e.status, ImapStatus::ImapErrInvalidArgument, "{e}");
        assert!(e.message.contains("config.unit_m"), "{e}");
    }
    // The extremes of the range work and scale the irradiance exactly.
    for unit in [1e-9, 1e9] {
        let (mut ctx, id) = floor_scene(Config {
            unit_m: unit,
            ..Default::default()
        });
        run_photons(&mut ctx, 1000);
        assert!(map_of(&ctx, id).iter().all(|x| x.is_finite() && *x >= 0.0));
    }
}

/// Max_groups = 1 is one group that never splits, and runs like any other.
#[test]
fn max_groups_one_is_one_group() {
    let mut maps = Vec::new();
    for (s, max_groups) in [(SchedulerKind::Classic, 0), (SchedulerKind::Dynamic, 1)] {
        let mut cfg = config(s);
        cfg.dynamic.max_groups = max_groups;
        cfg.seed = 4;
        let (mut ctx, id) = floor_scene(cfg);
        let r = run_photons(&mut ctx, 30_000);
        if s == SchedulerKind::Dynamic {
            assert_eq!(r.counters.groups, 1);
            assert_eq!(r.counters.splits, 0);
        }
        maps.push(map_of(&ctx, id));
    }
    assert_maps_agree(&maps[0], &maps[1], "classic vs dynamic with max_groups = 1");
}

/// A closed box of reflectance 1 (allowed): a photon's path ends only at the event limit.
fn lossless_box(cfg: Config) -> (Context, u32) {
    let mut ctx = context(cfg);
    let white = lambert(&mut ctx, 1.0);
    let g = cuboid([0.0; 3], [1.0; 3], 4, true);
    let id = ctx.add_mesh(&g.desc(white)).unwrap();
    ctx.add_point_light([0.4, 0.5, 0.6], &[1.0]).unwrap();
    (ctx, id)
}

/// The time budget and cancel stop a run within about two progress intervals
/// however long the paths are, and the map stays a sum of whole photons: runs stopped
/// and resumed give the map of one uninterrupted run.
#[test]
fn long_paths_stop_on_time_and_resume_exactly() {
    for s in schedulers() {
        let (wall, stop, dropped) = within(20.0, "reflectance-1 box", move || {
            let (mut ctx, _) = lossless_box(config(s));
            let mut p = params(0);
            p.time_budget_s = 0.5;
            p.progress_interval_s = 0.1;
            let t = Instant::now();
            let r = ctx.run(&mut p).unwrap();
            (t.elapsed().as_secs_f64(), r.stop, r.dropped_photons)
        });
        eprintln!("{s:?}: 0.5 s budget, 2^20-event paths: returned after {wall:.2} s ({dropped} photons dropped at the limit)");
        assert_eq!(stop, Some(StopReason::TimeBudget));
        // The paper's default limit makes each photon ~1 s long here: before, a 0.5 s budget
        // returned after 39–55 s.
        assert!(wall < 3.0, "{s:?}: {wall} s");
        // Cancel from the callback, too.
        let wall = within(20.0, "cancel", move || {
            let (mut ctx, _) = lossless_box(config(s));
            let mut cb = |_: &imap::Progress| false;
            let mut p = params(0);
            p.progress_interval_s = 0.1;
            p.progress = Some(&mut cb);
            let t = Instant::now();
            let r = ctx.run(&mut p).unwrap();
            assert_eq!(r.stop, Some(StopReason::Cancelled));
            t.elapsed().as_secs_f64()
        });
        assert!(wall < 3.0, "{s:?}: cancel after {wall} s");
    }
    // Exactness: paths of up to 3000 events; one run of 3000 photons against runs cut
    // short by a 40 ms budget, resumed until 3000 photons are in the map.
    for s in schedulers() {
        let mut cfg = config(s);
        cfg.seed = 21;
        let (mut whole, id) = lossless_box(cfg.clone());
        let mut p = params(3000);
        p.max_path_events = 3000;
        whole.run(&mut p).unwrap();
        let (mut pieces, _) = lossless_box(cfg);
        let mut runs = 0;
        while pieces.report().photons < 3000 {
            let left = 3000 - pieces.report().photons;
            let mut p = params(left);
            p.max_path_events = 3000;
            p.time_budget_s = 0.04;
            p.progress_interval_s = 0.01;
            pieces.run(&mut p).unwrap();
            runs += 1;
        }
        eprintln!("{s:?}: 3000 photons in {runs} interrupted runs");
        assert!(runs > 2, "the runs were not interrupted");
        assert_eq!(pieces.traced().ranges(), std::slice::from_ref(&(0..3000)));
        assert_maps_agree(
            &map_of(&whole, id),
            &map_of(&pieces, id),
            "interrupted and resumed",
        );
        let (a, b) = (whole.report(), pieces.report());
        assert_eq!(a.hits, b.hits);
        assert!((a.absorbed_w - b.absorbed_w).abs() <= 1e-12 * a.emitted_w);
        assert!((a.dropped_w - b.dropped_w).abs() <= 1e-12 * a.emitted_w);
    }
}

/// A gathering radius too small for the scene is refused, not rendered as NaN.
#[test]
fn tiny_render_radii_are_refused() {
    let (mut ctx, _) = floor_scene(Config::default());
    for r in [1e-100, 1e-300, 1e-7] {
        let mut rp = render_params();
        rp.passes = 2;
        rp.initial_radius = r;
        let e = ctx.render(&camera(8), &mut rp).unwrap_err();
        assert_eq!(e.status, ImapStatus::ImapErrInvalidArgument, "{e}");
        assert!(e.message.contains("params.initial_radius"), "{e}");
    }
    let mut rp = render_params();
    rp.passes = 4;
    rp.initial_radius = 0.05;
    let (img, _) = ctx.render(&camera(8), &mut rp).unwrap();
    assert!(img.radiance.iter().all(|x| x.is_finite()));
}

/// More than 1024 threads are refused; 1024 threads on a small machine still
/// trace 100 000 photons without the per-thread cost of every possible group.
#[test]
fn thread_counts_are_bounded_and_many_threads_stay_cheap() {
    let e = Context::new(Config {
        threads: 4096,
        ..Default::default()
    })
    .err()
    .unwrap();
    assert_eq!(e.status, ImapStatus::ImapErrInvalidArgument);
    assert!(e.message.contains("config.threads = 4096"), "{e}");
    for s in schedulers() {
        let secs = within(60.0, "1024 threads", move || {
            let (mut ctx, id) = floor_scene(Config {
                scheduler: s,
                threads: 1024,
                ..Default::default()
            });
            let t = Instant::now();
            let r = run_photons(&mut ctx, 100_000);
            assert_eq!(r.photons, 100_000);
            assert!(map_of(&ctx, id).iter().sum::<f64>() > 0.0);
            t.elapsed().as_secs_f64()
        });
        eprintln!("{s:?}: 100 000 photons on 1024 threads in {secs:.2} s");
    }
}

/// Messages name the argument at fault, one message per range error.
#[test]
fn messages_name_the_argument() {
    let (mut ctx, _) = floor_scene(Config::default());
    type Set = fn(&mut RunParams);
    let cases: [(&str, Set); 6] = [
        ("params.time_budget_s", |p| p.time_budget_s = f64::NAN),
        ("params.target_rel_error", |p| {
            p.target_rel_error = f64::INFINITY
        }),
        ("params.progress_interval_s", |p| {
            p.progress_interval_s = f64::NAN
        }),
        ("params.time_budget_s", |p| p.time_budget_s = -1.0),
        ("params.target_rel_error", |p| p.target_rel_error = -0.1),
        ("params.progress_interval_s", |p| {
            p.progress_interval_s = 0.0
        }),
    ];
    for (name, set) in cases {
        let mut p = params(100);
        set(&mut p);
        let e = ctx.run(&mut p).unwrap_err();
        assert!(e.message.starts_with(name), "{name}: {}", e.message);
    }
    // A huge camera direction is a direction, not an error blamed on the up vector.
    let mut rp = render_params();
    rp.passes = 2;
    let mut cam = camera(8);
    cam.direction = [0.0, 2e300, -1.5e300];
    ctx.render(&cam, &mut rp).unwrap();
    cam.up = [0.0, 2.0, -1.5];
    let e = ctx.render(&cam, &mut rp).unwrap_err();
    assert!(e.message.contains("camera up is parallel"), "{e}");
}

/// Degenerate triangles (a repeated vertex index; CAD exports hold thousands): refused
/// with their code by default; with `skip_degenerate` left out and counted, the per-triangle
/// materials follow their triangles, and the map is the map of the mesh without them.
#[test]
fn degenerate_triangles_are_refused_or_skipped_on_request() {
    let cfg = || Config {
        threads: 2,
        seed: 7,
        ..Default::default()
    };
    let mut clean = grid(4, -1.0, 1.0, -1.0, 1.0, 0.0);
    let nt = clean.indices.len() / 3;
    // Triangle materials: the first half grey, the second half white.
    let mats_clean: Vec<u32> = (0..nt).map(|t| u32::from(t >= nt / 2)).collect();
    // The same mesh with degenerate triangles between its triangles; their material is one
    // that does not matter (black), so a misaligned material list would show in the map.
    let mut dirty = Geometry {
        positions: clean.positions.clone(),
        indices: Vec::new(),
    };
    let mut mats_dirty = Vec::new();
    for (t, (tri, &m)) in clean.indices.chunks_exact(3).zip(&mats_clean).enumerate() {
        if t % 3 == 0 {
            dirty.indices.extend([3, 3, 4]);
            mats_dirty.push(2);
        }
        dirty.indices.extend_from_slice(tri);
        mats_dirty.push(m);
    }
    let dropped = mats_dirty.len() - nt;
    let build = |g: &Geometry, mats: &[u32], skip: bool| -> imap::Result<(Context, u32)> {
        let mut ctx = context(cfg());
        lambert(&mut ctx, 0.5);
        lambert(&mut ctx, 0.9);
        lambert(&mut ctx, 0.0);
        // Something for the floor's reflection to reach the floor again.
        let roof = grid(2, -1.0, 1.0, -1.0, 1.0, 1.5).flipped();
        ctx.add_mesh(&MeshDesc {
            record: false,
            ..roof.desc(1)
        })?;
        let id = ctx.add_mesh(&MeshDesc {
            triangle_materials: Some(mats),
            skip_degenerate: skip,
            ..g.desc(0)
        })?;
        ctx.add_point_light([0.1, 0.2, 1.0], &[10.0])?;
        Ok((ctx, id))
    };
    let err = build(&dirty, &mats_dirty, false).err().expect("refused");
    assert_eq!(err.status, imap::ImapStatus::ImapErrDegenerateTriangle);
    assert!(err.message.contains("triangle 0"), "{}", err.message);

    let (mut a, ida) = build(&clean, &mats_clean, false).unwrap();
    let (mut b, idb) = build(&dirty, &mats_dirty, true).unwrap();
    assert_eq!(a.dropped_triangles(ida).unwrap(), 0);
    assert_eq!(b.dropped_triangles(idb).unwrap(), dropped);
    a.run(&mut params(200_000)).unwrap();
    b.run(&mut params(200_000)).unwrap();
    let (ma, mb) = (map_of(&a, ida), map_of(&b, idb));
    assert!(ma.iter().any(|&e| e > 0.0));
    assert_maps_agree(&ma, &mb, "degenerate triangles skipped");

    // Nothing left: refused, even when skipping.
    clean.indices = vec![0, 0, 1, 2, 2, 2];
    let err = build(&clean, &[0, 0], true).err().expect("refused");
    assert_eq!(err.status, imap::ImapStatus::ImapErrDegenerateTriangle);
    assert!(err.message.contains("nothing is left"), "{}", err.message);
}

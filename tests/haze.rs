//! The scene's medium (haze outside the meshes, `Context::set_scene_medium`): Beer–Lambert
//! per band under a point light and the sun in every estimator and on a sensor, each
//! vertex's error, a very large scattering medium around a point source that absorbs all
//! of its light, a ball of haze in a black world, estimators that agree in a hazy room,
//! determinism over threads, resume and shards; pictures through haze (exact lines of
//! sight, a lossless furnace, Mitsuba 3's volpath on a hazy room); and the statuses.

mod common;

use common::*;
use imap::{Estimator, ImapStatus, IorModel, MaterialDesc, SCENE_MEDIUM};

/// A haze material: index 1, absorbing `alpha` and scattering `sigma_s` per band (1/m).
fn haze(ctx: &mut imap::Context, alpha: &[f64], sigma_s: &[f64], g: f64) -> u32 {
    ctx.add_material(&MaterialDesc {
        ior: Some(IorModel::Constant(1.0)),
        absorption_per_m: alpha.to_vec(),
        scattering_per_m: sigma_s.to_vec(),
        phase_g: if sigma_s.is_empty() { vec![] } else { vec![g] },
        ..Default::default()
    })
    .unwrap()
}

/// Makes a haze material (`haze`) the scene's medium.
fn fill_with_haze(ctx: &mut imap::Context, alpha: &[f64], sigma_s: &[f64], g: f64) {
    let h = haze(ctx, alpha, sigma_s, g);
    ctx.set_scene_medium(Some(h)).unwrap();
}

/// The flux per band onto the square [−1, 1]² at z = 0 from an isotropic point source of 1 W
/// per band `h` above its centre, through a medium of extinction `sigma` per band (1/m):
/// Φ/(4π) ∫ h/r³ e^(−σr) dA, by the midpoint rule.
fn floor_flux(h: f64, sigma: &[f64]) -> Vec<f64> {
    let n = 600;
    let d = 2.0 / n as f64;
    let mut out = vec![0.0; sigma.len()];
    for i in 0..n {
        for j in 0..n {
            let x = -1.0 + (i as f64 + 0.5) * d;
            let y = -1.0 + (j as f64 + 0.5) * d;
            let r = (x * x + y * y + h * h).sqrt();
            for (o, s) in out.iter_mut().zip(sigma) {
                *o += h / (r * r * r) * (-s * r).exp() * d * d;
            }
        }
    }
    out.iter()
        .map(|v| v / (4.0 * std::f64::consts::PI))
        .collect()
}

/// A floor [−1, 1]² (black, tallied) in haze absorbing `alpha`, a point light of 1 W per band
/// 1 m above it, and optionally a sensor of the same square 0.5 m above the floor.
fn hazy_floor(seed: u64, alpha: &[f64], sensor: bool) -> (imap::Context, u32, Option<u32>) {
    let mut ctx = context(seeded(seed));
    let black = lambert(&mut ctx, 0.0);
    let floor = grid(8, -1.0, 1.0, -1.0, 1.0, 0.0);
    let mut d = floor.desc(black);
    d.tally = true;
    let f = ctx.add_mesh(&d).unwrap();
    let s = sensor.then(|| {
        let plane = grid(8, -1.0, 1.0, -1.0, 1.0, 0.5);
        let mut d = plane.desc(black);
        d.sensor = true;
        ctx.add_mesh(&d).unwrap()
    });
    fill_with_haze(&mut ctx, alpha, &[], 0.0);
    ctx.add_point_light([0.0, 0.0, 1.0], &[1.0, 1.0, 1.0])
        .unwrap();
    (ctx, f, s)
}

#[test]
fn an_absorbing_haze_attenuates_by_beer_lambert_per_band_in_every_estimator() {
    // Flux per band onto a black floor 1 m under a point light through haze absorbing
    // 0.3, 1 and 3 per metre: photons only, light sampling and gathering each within 4 σ
    // of the exact integral, and a sensor 0.5 m under the light reads its own.
    let alpha = [0.3, 1.0, 3.0];
    let exact = floor_flux(1.0, &alpha);
    let exact_sensor = floor_flux(0.5, &alpha);
    let clear = floor_flux(1.0, &[0.0, 0.0, 0.0]);
    for (name, estimator, n) in [
        ("photons only", Estimator::Photons, photons(300_000)),
        ("light sampling", Estimator::DEFAULT, photons(100_000)),
        ("gathering", Estimator::GATHER, photons(100_000)),
    ] {
        let (mut ctx, floor, sensor) = hazy_floor(3, &alpha, true);
        let report = run_with(&mut ctx, n, estimator);
        let r = ctx.region_stats(floor, 0, None).unwrap();
        let s = ctx.region_stats(sensor.unwrap(), 0, None).unwrap();
        for b in 0..3 {
            let (e, want) = (&r.flux_w[b], exact[b]);
            let z = (e.value - want) / e.sigma;
            eprintln!(
                "{name}: band {b} (α {}): floor {:.5} W, exact {want:.5} (clear {:.5}), {z:+.2} σ; sensor {:.5}, exact {:.5}",
                alpha[b], e.value, clear[b], s.flux_w[b].value, exact_sensor[b]
            );
            assert!(
                z.abs() < 4.0,
                "{name}, band {b}: {} against {want}",
                e.value
            );
            assert!(e.sigma < 0.02 * want, "{name}, band {b}: σ {}", e.sigma);
            let e = &s.flux_w[b];
            let z = (e.value - exact_sensor[b]) / e.sigma;
            assert!(z.abs() < 4.0, "{name}, sensor, band {b}: {z} σ");
        }
        // The balance per band: emitted = absorbed (floor and haze) + escaped, and what the
        // haze absorbed is in the report's absorbed power.
        let a = ctx.medium_absorbed(SCENE_MEDIUM).unwrap();
        for b in 0..3 {
            let (em, ab, es) = (
                report.band_w[0][b],
                report.band_w[1][b],
                report.band_w[2][b],
            );
            assert!((em - ab - es).abs() < 1e-9 * em, "{name}, band {b}");
            assert!(
                a.band_w[b].value > 0.0 && a.band_w[b].value < ab,
                "{name}, band {b}"
            );
        }
        let floor_w = ctx.absorbed_w(floor).unwrap();
        let haze_w: f64 = a.band_w.iter().map(|e| e.value).sum();
        assert!(
            (report.absorbed_w - floor_w - haze_w).abs() < 1e-9 * report.absorbed_w,
            "{name}: absorbed {} against floor {floor_w} + haze {haze_w}",
            report.absorbed_w
        );
    }
}

/// A context whose only geometry is two black specks 0.2 mm wide at x = ±1 (the haze's
/// ball then has radius 1.01 about the origin).
fn specks(seed: u64) -> imap::Context {
    let mut ctx = context(seeded(seed));
    let black = lambert(&mut ctx, 0.0);
    for x in [-1.0, 1.0] {
        let speck = quad([
            [x, -1e-4, -1e-4],
            [x, 1e-4, -1e-4],
            [x, 1e-4, 1e-4],
            [x, -1e-4, 1e-4],
        ]);
        let mut d = speck.desc(black);
        d.two_sided = true;
        ctx.add_mesh(&d).unwrap();
    }
    ctx
}

#[test]
fn a_very_large_scattering_medium_absorbs_all_of_a_point_source() {
    // An isotropic point source at the centre of a haze of albedo 0.9 whose radius is 100
    // mean free paths (two specks of geometry 1 m away set the ball): the diffusion
    // approximation leaves e^(−R √(3 σa σt)) ≈ e^(−55) to escape, so the medium absorbs
    // everything but what the specks take (their solid angle is 1e-7 of the sphere's).
    let mut ctx = specks(11);
    fill_with_haze(&mut ctx, &[10.0], &[90.0], 0.5);
    ctx.add_point_light([0.0, 0.0, 0.0], &[1.0, 2.0, 3.0])
        .unwrap();
    let report = run_photons_only(&mut ctx, photons(20_000));
    let a = ctx.medium_absorbed(SCENE_MEDIUM).unwrap();
    for b in 0..3 {
        let share = a.band_w[b].value / report.band_w[0][b];
        eprintln!("band {b}: the medium absorbed {share:.6} of the emitted power");
        assert!((share - 1.0).abs() < 1e-4, "band {b}: {share}");
    }
    assert!(
        report.escaped_w < 1e-6 * report.emitted_w,
        "{}",
        report.escaped_w
    );
    // Each photon scatters about 1/(1 − ω) = 10 times before it is absorbed.
    assert!(
        report.run_hits < report.photons / 100,
        "{}",
        report.run_hits
    );
}

/// A closed 2 m grey room (ρ 0.5, floor tallied) filled with chromatic scattering haze,
/// a point light near its ceiling and a sensor plane at mid-height.
fn hazy_room(seed: u64, threads: usize) -> (imap::Context, u32, u32) {
    let mut ctx = context(imap::Config {
        threads,
        ..seeded(seed)
    });
    let grey = lambert(&mut ctx, 0.5);
    let room = cuboid([0.0, 0.0, 0.0], [2.0, 2.0, 2.0], 6, true);
    let mut d = room.desc(grey);
    d.tally = true;
    let walls = ctx.add_mesh(&d).unwrap();
    let plane = grid(6, 0.2, 1.8, 0.2, 1.8, 1.0);
    let mut d = plane.desc(grey);
    d.sensor = true;
    let sensor = ctx.add_mesh(&d).unwrap();
    fill_with_haze(&mut ctx, &[0.1, 0.2, 0.3], &[0.8, 0.5, 0.2], 0.4);
    ctx.add_point_light([1.0, 1.0, 1.8], &[1.0, 1.0, 1.0])
        .unwrap();
    (ctx, walls, sensor)
}

#[test]
fn the_estimators_agree_in_a_hazy_room() {
    // Photons only is the analogue reference (every path as light takes it); light
    // sampling attenuates its shadow rays, gathering its paths too, and both leave light
    // scattered in the haze to the photons. Each band of the room's flux and of the
    // sensor's agrees within 4 combined σ.
    let run = |e: Estimator, n: u64| {
        let (mut ctx, walls, sensor) = hazy_room(21, 2);
        let report = run_with(&mut ctx, n, e);
        for b in 0..3 {
            let (em, ab, es) = (
                report.band_w[0][b],
                report.band_w[1][b],
                report.band_w[2][b],
            );
            assert!((em - ab - es).abs() < 1e-9 * em, "band {b}");
        }
        let w = ctx.region_stats(walls, 0, None).unwrap().flux_w;
        let s = ctx.region_stats(sensor, 0, None).unwrap().flux_w;
        (w, s)
    };
    let (w0, s0) = run(Estimator::Photons, photons(400_000));
    for (name, e) in [
        ("light sampling", Estimator::DEFAULT),
        ("gathering", Estimator::GATHER),
    ] {
        let (w, s) = run(e, photons(150_000));
        for b in 0..3 {
            for (what, a, r) in [("room", &w[b], &w0[b]), ("sensor", &s[b], &s0[b])] {
                let z = (a.value - r.value) / a.sigma.hypot(r.sigma);
                eprintln!(
                    "{name}, {what}, band {b}: {:.5} ± {:.5} W against photons' {:.5} ± {:.5} ({z:+.2} σ)",
                    a.value, a.sigma, r.value, r.sigma
                );
                assert!(z.abs() < 4.0, "{name}, {what}, band {b}: {z} σ");
            }
        }
    }
}

#[test]
fn a_hazy_map_does_not_depend_on_the_thread_count() {
    let map = |threads: usize| {
        let (mut ctx, walls, _) = hazy_room(5, threads);
        run_with(&mut ctx, 20_000, Estimator::GATHER);
        let mut e = vec![0.0; ctx.vertex_count(walls).unwrap()];
        ctx.illuminance(walls, 0, &mut e).unwrap();
        (e, ctx.medium_absorbed(SCENE_MEDIUM).unwrap().lm.value)
    };
    // (Deposits from different threads add in a different order: the last bits may move.)
    let (one, three) = (map(1), map(3));
    assert!(one.1 > 0.0, "{}", one.1);
    let worst = one
        .0
        .iter()
        .zip(&three.0)
        .map(|(a, b)| (a - b).abs() / a.abs().max(1e-300))
        .fold(0.0, f64::max);
    assert!(worst < 1e-12, "maps differ by {worst}");
    assert!((one.1 - three.1).abs() < 1e-12 * one.1);
}

#[test]
fn a_scene_medium_gets_a_status_naming_what_is_wrong() {
    let mut ctx = context(seeded(2));
    let grey = lambert(&mut ctx, 0.5);
    let glass = ctx
        .add_material(&MaterialDesc {
            ior: Some(IorModel::Constant(1.5)),
            absorption_per_m: vec![1.0],
            ..Default::default()
        })
        .unwrap();
    let clear = ctx
        .add_material(&MaterialDesc {
            ior: Some(IorModel::Constant(1.0)),
            ..Default::default()
        })
        .unwrap();
    for (id, want) in [
        (99, "material = 99: no such material"),
        (grey, "holds no medium"),
        (clear, "holds no medium"),
        (glass, "index 1 in every band"),
    ] {
        let e = ctx.set_scene_medium(Some(id)).unwrap_err();
        assert_eq!(e.status, ImapStatus::ImapErrInvalidArgument, "{e}");
        assert!(e.message.contains(want), "{e}");
    }
    let e = ctx.medium_absorbed(SCENE_MEDIUM).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrInvalidArgument, "{e}");
    assert!(e.message.contains("no medium outside its meshes"), "{e}");
    // Still usable: a run with a good medium; the medium cannot change under the photons
    // traced.
    let (mut ctx, floor, _) = hazy_floor(4, &[1.0], false);
    let n = 2000;
    run_photons_only(&mut ctx, n);
    let e = ctx.set_scene_medium(None).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrOutOfOrder, "{e}");
    assert_eq!(ctx.report().photons, n);
    assert!(ctx.region_stats(floor, 0, None).unwrap().flux_lm.value > 0.0);
    // After a reset it may go: the same floor in air then reads the clear flux.
    ctx.reset();
    ctx.set_scene_medium(None).unwrap();
    run_photons_only(&mut ctx, photons(100_000));
    let r = ctx.region_stats(floor, 0, None).unwrap();
    let clear = floor_flux(1.0, &[0.0])[0];
    let z = (r.flux_w[0].value - clear) / r.flux_w[0].sigma;
    assert!(z.abs() < 4.0, "{} against {clear}", r.flux_w[0].value);
}

#[test]
fn the_sun_through_haze_agrees_between_estimators() {
    // The sun's photons start outside the haze's ball and cross it from its surface; light
    // samples and gathering paths toward the sun are attenuated to the ball's edge. A
    // black floor under the sun at 30° reads the same per band in every estimator, less
    // than in clear air by at least the transmittance of the floor's own height (0) and
    // at most of the ball's diameter.
    let alpha = [0.2, 0.5, 1.0];
    let flux = |e: Estimator, n: u64, hazy: bool| {
        let mut ctx = context(seeded(31));
        let black = lambert(&mut ctx, 0.0);
        let floor = grid(8, -1.0, 1.0, -1.0, 1.0, 0.0);
        let mut d = floor.desc(black);
        d.tally = true;
        let f = ctx.add_mesh(&d).unwrap();
        if hazy {
            fill_with_haze(&mut ctx, &alpha, &[], 0.0);
        }
        ctx.add_sun(&imap::SunDesc {
            azimuth_deg: 40.0,
            zenith_deg: 30.0,
            amount: imap::SkyAmount::NormalIrradiance(300.0),
            spectrum: imap::photometry::Spectrum::Equal,
            ..imap::SunDesc::default()
        })
        .unwrap();
        run_with(&mut ctx, n, e);
        ctx.region_stats(f, 0, None).unwrap().flux_w
    };
    let clear = flux(Estimator::DEFAULT, photons(20_000), false);
    let reference = flux(Estimator::Photons, photons(300_000), true);
    // The ball holds the floor (radius √2 · 1.01).
    let diameter = 2.0 * 2f64.sqrt() * 1.01;
    for b in 0..3 {
        let r = reference[b].value / clear[b].value;
        eprintln!("band {b}: haze leaves {r:.4} of the sun's clear flux");
        assert!(r < 1.0 && r > (-alpha[b] * diameter).exp(), "band {b}: {r}");
    }
    for (name, e) in [
        ("light sampling", Estimator::DEFAULT),
        ("gathering", Estimator::GATHER),
    ] {
        let f = flux(e, photons(100_000), true);
        for b in 0..3 {
            let z = (f[b].value - reference[b].value) / f[b].sigma.hypot(reference[b].sigma);
            eprintln!(
                "{name}, band {b}: {:.4} against photons' {:.4} ({z:+.2} σ)",
                f[b].value, reference[b].value
            );
            assert!(z.abs() < 4.0, "{name}, band {b}: {z} σ");
        }
    }
}

#[test]
fn each_vertex_error_holds_in_haze_early_and_late() {
    // The error estimate is a promise per vertex: on the black floor under grey haze
    // (σa 1/m), each vertex's irradiance against its exact value (I cos θ e^(−σr)/r²
    // averaged over the vertex's hat function), early and late in a run of each estimator.
    // (Light sampling's and gathering's σ are on the safe side here, mean z² 0.6–0.85, as
    // on the same floor in clear air: the haze changes neither.)
    let floor = grid(8, -1.0, 1.0, -1.0, 1.0, 0.0);
    let intensity = 3.0 / (4.0 * std::f64::consts::PI);
    let truth: Vec<f64> = (0..floor.vertex_count())
        .map(|v| {
            hat_average_faces(&floor, v, |x, _| {
                let r = (x[0] * x[0] + x[1] * x[1] + 1.0).sqrt();
                intensity / 3.0 * (-r).exp() / (r * r * r)
            })
        })
        .collect();
    for (name, estimator, counts) in [
        ("photons only", Estimator::Photons, [40_000, 400_000]),
        ("light sampling", Estimator::DEFAULT, [2_000, 100_000]),
        ("gathering", Estimator::GATHER, [2_000, 100_000]),
    ] {
        for n in counts {
            let (mut ctx, id, _) = hazy_floor(40 + n, &[1.0], false);
            run_with(&mut ctx, photons(n), estimator);
            let nv = ctx.vertex_count(id).unwrap();
            let (mut e, mut r) = (vec![0.0; nv], vec![0.0; nv]);
            ctx.irradiance(id, 0, 0, &mut e).unwrap();
            ctx.rel_error(id, 0, &mut r).unwrap();
            // (A vertex no photon reached has no error to check: there are none here.)
            assert!(e.iter().all(|&x| x > 0.0), "{name}, {n}: an unlit vertex");
            let z: Vec<f64> = (0..nv).map(|v| (e[v] - truth[v]) / (r[v] * e[v])).collect();
            let z2 = z.iter().map(|z| z * z).sum::<f64>() / nv as f64;
            let worst = z.iter().fold(0.0f64, |a, z| a.max(z.abs()));
            eprintln!(
                "{name}, {n} photons: mean z² {z2:.2} over {nv} vertices, largest |z| {worst:.2}"
            );
            assert!((0.5..1.7).contains(&z2), "{name}, {n}: mean z² {z2}");
            assert!(worst < 5.0, "{name}, {n}: |z| {worst}");
        }
    }
}

/// A camera of one pixel 0.02° wide at `from` looking along `dir`: one line of sight.
fn line_of_sight(from: [f64; 3], dir: [f64; 3]) -> imap::CameraDesc {
    let up = if dir[2].abs() > 0.9 {
        [0.0, 1.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    imap::CameraDesc {
        position: from,
        direction: dir,
        up,
        fov_y_deg: 0.02,
        width: 1,
        height: 1,
        projection: imap::Projection::Perspective,
    }
}

/// The pixels' radiance per band with every renderer, and the root mean square of their
/// relative errors: the path tracer (`spp` paths), final gathering and the synchronous
/// photon-map renderer (`passes` each; final gathering after `photons` photons of the map).
fn render_all(
    ctx: &mut imap::Context,
    cam: &imap::CameraDesc,
    spp: u32,
    passes: u64,
    photons: u64,
) -> Vec<(&'static str, Vec<f64>, f64)> {
    // The root mean square of the pixels' relative errors.
    let rms = |r: &[f64]| (r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt();
    let pt = ctx.path_trace(cam, spp, 1000).unwrap();
    let mut out = vec![("path tracer", pt.radiance.clone(), rms(&pt.rel_error))];
    for (name, method) in [
        ("synchronous", imap::RenderMethod::Synchronous),
        ("final gathering", imap::RenderMethod::FinalGather),
    ] {
        if method == imap::RenderMethod::FinalGather {
            run_with(ctx, photons, Estimator::GATHER);
        }
        let img = render_passes(ctx, cam, method, passes);
        out.push((name, img.radiance.clone(), rms(&img.rel_error)));
    }
    out
}

/// A grey floor [−1, 1]² (ρ 0.6) with a point light of 1 W per band 1 m above its centre,
/// optionally an emitting panel (exitance 1 W/m² per band: radiance 1/π, facing −x) at
/// x = 1.5, and haze absorbing `alpha` and scattering `sigma_s` per band.
fn render_scene(seed: u64, alpha: &[f64], sigma_s: &[f64], g: f64, panel: bool) -> imap::Context {
    let mut ctx = context(seeded(seed));
    let grey = lambert(&mut ctx, 0.6);
    let floor = grid(4, -1.0, 1.0, -1.0, 1.0, 0.0);
    ctx.add_mesh(&floor.desc(grey)).unwrap();
    if panel {
        let black = lambert(&mut ctx, 0.0);
        let quad = quad([
            [1.5, -0.5, 0.2],
            [1.5, -0.5, 1.2],
            [1.5, 0.5, 1.2],
            [1.5, 0.5, 0.2],
        ]);
        let mut d = quad.desc(black);
        d.exitance = Some(&[1.0]);
        d.record = false;
        ctx.add_mesh(&d).unwrap();
    }
    fill_with_haze(&mut ctx, alpha, sigma_s, g);
    ctx.add_point_light([0.0, 0.0, 1.0], &[1.0, 1.0, 1.0])
        .unwrap();
    ctx
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

#[test]
fn renderers_see_through_absorbing_haze_by_beer_lambert() {
    // Haze absorbing 0.3, 1 and 2 per metre. A line of sight onto an emitting panel reads
    // its radiance 1/π times e^(−σ d) per band, and one onto the floor point (0.3, 0.2, 0)
    // under the point light alone ρ/π · I cos θ e^(−σ r)/r² · e^(−σ d) (the light sample
    // and the eye path attenuated), in every renderer.
    let alpha = [0.3, 1.0, 2.0];
    let eye = [0.0, -0.8, 0.9];
    // Onto the panel: exactly.
    let p = [1.5, 0.1, 0.7];
    let cam = line_of_sight(eye, sub(p, eye).map(|c| c / norm(sub(p, eye))));
    let mut ctx = render_scene(51, &alpha, &[], 0.0, true);
    for (name, l, rel) in render_all(&mut ctx, &cam, 64, 4, 20_000) {
        for b in 0..3 {
            let want = (-alpha[b] * norm(sub(p, eye))).exp() / std::f64::consts::PI;
            eprintln!(
                "{name}, panel, band {b}: {:.6} against {want:.6} (rel. error {rel:.1e})",
                l[b]
            );
            assert!(
                (l[b] / want - 1.0).abs() < 1e-3,
                "{name}, band {b}: {} against {want}",
                l[b]
            );
        }
    }
    // Onto the floor, without the panel.
    let x = [0.3, 0.2, 0.0];
    let cam = line_of_sight(eye, sub(x, eye).map(|c| c / norm(sub(x, eye))));
    let r = norm(sub([0.0, 0.0, 1.0], x));
    let d = norm(sub(x, eye));
    let mut ctx = render_scene(52, &alpha, &[], 0.0, false);
    let got = render_all(&mut ctx, &cam, 4096, 64, 200_000);
    for (name, l, rel) in &got {
        for b in 0..3 {
            let want = 0.6 / std::f64::consts::PI / (4.0 * std::f64::consts::PI) * (1.0 / r)
                / (r * r)
                * (-alpha[b] * (r + d)).exp();
            eprintln!(
                "{name}, floor, band {b}: {:.7} against {want:.7} (rel. error {rel:.1e})",
                l[b]
            );
            let z = (l[b] - want) / (want * rel).max(1e-4 * want);
            assert!(
                z.abs() < 4.0,
                "{name}, band {b}: {} against {want} ({z} σ)",
                l[b]
            );
        }
    }
}

#[test]
fn lossless_haze_leaves_a_furnace_uniform_in_every_renderer() {
    // A closed box whose grey walls (ρ 0.5) emit π W/m² per band: radiance 2 everywhere.
    // Filled with lossless scattering haze (σs 3/m, g 0.5) the field stays uniform: the
    // walls' irradiance stays 2π, and every renderer sees 2 along any line of sight.
    let build = |seed: u64| {
        let mut ctx = context(seeded(seed));
        let wall = lambert(&mut ctx, 0.5);
        let g = cuboid([0.0; 3], [1.0; 3], 4, true);
        let walls = ctx
            .add_mesh(&imap::MeshDesc {
                exitance: Some(&[std::f64::consts::PI]),
                ..g.desc(wall)
            })
            .unwrap();
        fill_with_haze(&mut ctx, &[], &[3.0], 0.5);
        (ctx, walls)
    };
    let (mut ctx, walls) = build(61);
    run_photons_only(&mut ctx, photons(100_000));
    let mut e = vec![0.0; ctx.vertex_count(walls).unwrap()];
    ctx.irradiance(walls, 0, 0, &mut e).unwrap();
    let mean = e.iter().sum::<f64>() / e.len() as f64;
    eprintln!("walls' mean irradiance {mean:.4} (2π = 6.2832)");
    assert!(
        (mean / (2.0 * std::f64::consts::PI) - 1.0).abs() < 0.01,
        "{mean}"
    );
    // (A view of 8 × 8 pixels: the photon-map renderers' gathering radius follows the
    // pixel's footprint, and a line of sight 0.02° wide finds almost no photons.)
    let cam = imap::CameraDesc {
        position: [0.5, 0.02, 0.5],
        direction: [0.0, 1.0, 0.0],
        up: [0.0, 0.0, 1.0],
        fov_y_deg: 40.0,
        width: 8,
        height: 8,
        projection: imap::Projection::Perspective,
    };
    let (mut ctx, _) = build(62);
    let pixels = 64.0;
    for (name, l, rel) in render_all(&mut ctx, &cam, 256, 64, 50_000) {
        let mean = l.iter().step_by(3).sum::<f64>() / pixels;
        // The path tracer's and final gathering's pixel errors are independent noise; the
        // photon-map renderer's hold its boundary bias, which all pixels share (eye paths
        // that scatter land anywhere on the walls, edges too, with wide discs: 1.84, 1.90,
        // 1.92 and 1.95 at 16, 64, 256 and 1024 passes, as in a scattering box inside the
        // furnace, so it is not the haze's).
        let err = match name {
            "synchronous" => 2.0 * rel,
            _ => 2.0 * rel / pixels.sqrt(),
        };
        let z = (mean - 2.0) / err;
        eprintln!("{name}: mean {mean:.4} (2), its error {err:.1e}, {z:+.2} σ");
        assert!(z.abs() < 4.0, "{name}: {mean} ({z} σ)");
    }
}

#[test]
fn a_hazy_room_renders_as_mitsuba_renders_it() {
    // scripts/mitsuba_haze.py: a closed grey room (ρ 0.5) filled with haze (σs 0.8, σa 0.2,
    // g 0.5) and lit by a point light of 1 W per band; Mitsuba 3's volpath picture of it,
    // 8 × 8 pixels. The light reaches the camera mostly through the haze: scattered toward
    // it (the light samples at scattering points) or reflected by walls through it. The path
    // tracer agrees pixel by pixel within the combined errors; final gathering and the
    // photon-map renderer on the whole picture.
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/mitsuba_haze.txt"
    ))
    .unwrap();
    let reference: Vec<(f64, f64)> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            (v[1], v[2])
        })
        .collect();
    assert_eq!(reference.len(), 64);
    let mut ctx = context(seeded(71));
    let grey = lambert(&mut ctx, 0.5);
    let room = cuboid([0.0; 3], [2.0; 3], 4, true);
    ctx.add_mesh(&room.desc(grey)).unwrap();
    fill_with_haze(&mut ctx, &[0.2], &[0.8], 0.5);
    ctx.add_point_light([1.0, 1.0, 1.6], &[1.0, 1.0, 1.0])
        .unwrap();
    let cam = imap::CameraDesc {
        position: [1.0, 0.1, 1.0],
        direction: [0.0, 1.0, 0.0],
        up: [0.0, 0.0, 1.0],
        fov_y_deg: 60.0,
        width: 8,
        height: 8,
        projection: imap::Projection::Perspective,
    };
    let total: f64 = reference.iter().map(|r| r.0).sum();
    for (name, l, rel) in render_all(&mut ctx, &cam, 8192, 256, 200_000) {
        let (mut z2, mut sum, mut worst) = (0.0, 0.0, 0.0f64);
        for (p, (want, se)) in reference.iter().enumerate() {
            let v = l[3 * p];
            sum += v;
            let z = (v - want) / (v * rel).hypot(*se);
            z2 += z * z / 64.0;
            worst = worst.max(z.abs());
        }
        eprintln!(
            "{name}: the picture's sum {:.5} against Mitsuba's {total:.5} ({:+.2} %); mean z² {z2:.2}, largest |z| {worst:.2} (rms rel. error {rel:.1e})",
            sum,
            100.0 * (sum / total - 1.0)
        );
        assert!(
            z2 < 2.0 && worst < 5.0,
            "{name}: mean z² {z2}, largest |z| {worst}"
        );
        // The sum's error, the pixels' taken as independent.
        let err = rel / 8.0;
        let z = (sum / total - 1.0) / err;
        assert!(z.abs() < 4.0, "{name}: {sum} against {total} ({z} σ)");
    }
}

#[test]
fn a_ball_of_haze_in_a_black_world_lets_out_what_it_does_not_absorb() {
    // Two black specks 1 m either side of a point light set the haze's ball: radius 1.01 m
    // (the bounds' half-diagonal, widened by 1 %, docs/materials.md). A purely absorbing
    // haze (σa 2/m) lets e^(−σa R) of the light out; one that also scatters (σs 2/m) lets
    // out more than e^(−σt R) and less than e^(−σa R), and what escapes and what the haze
    // absorbs make up what the light emitted, per band.
    let run = |sigma_s: &[f64], seed: u64| {
        let mut ctx = specks(seed);
        fill_with_haze(&mut ctx, &[2.0], sigma_s, 0.0);
        ctx.add_point_light([0.0, 0.0, 0.0], &[1.0, 1.0, 1.0])
            .unwrap();
        let report = run_photons_only(&mut ctx, photons(200_000));
        let a = ctx.medium_absorbed(SCENE_MEDIUM).unwrap();
        for b in 0..3 {
            let (em, es) = (report.band_w[0][b], report.band_w[2][b]);
            let off = em - es - a.band_w[b].value;
            // (The specks take about 1e-8 of it.)
            assert!(off.abs() < 1e-6 * em, "band {b}: {off} of {em}");
        }
        (report.escaped_w / report.emitted_w, report.photons)
    };
    let r = 1.01 * (1.0f64 + 2e-8).sqrt();
    let (out, n) = run(&[], 81);
    let want = (-2.0 * r).exp();
    let sigma = (want * (1.0 - want) / n as f64).sqrt();
    eprintln!("absorbing haze lets out {out:.5}, e^(−σa R) = {want:.5} (σ {sigma:.1e})");
    assert!((out - want).abs() < 4.0 * sigma, "{out} against {want}");
    let (out, _) = run(&[2.0], 82);
    eprintln!(
        "scattering haze lets out {out:.5}, between e^(−σt R) = {:.5} and e^(−σa R) = {want:.5}",
        (-4.0 * r).exp()
    );
    assert!(out > (-4.0 * r).exp() && out < want, "{out}");
}

#[test]
fn hazy_maps_and_the_haze_tally_survive_resume_and_shards() {
    // The hazy room's map, report and the haze's tally after a run resumed from a state
    // written half way, and after two halves merged, equal one run's (to rounding); a state
    // of the room without haze does not load into the hazy one.
    let n = 6000;
    let run = |ctx: &mut imap::Context, a: u64, b: u64| {
        ctx.run(&mut imap::RunParams {
            selection: imap::Selection::range(a, b),
            estimator: Some(Estimator::GATHER),
            progress_interval_s: 1.0,
            ..Default::default()
        })
        .expect("run");
    };
    let read = |ctx: &imap::Context, walls: u32| {
        let mut e = vec![0.0; ctx.vertex_count(walls).unwrap()];
        ctx.illuminance(walls, 0, &mut e).unwrap();
        let a = ctx.medium_absorbed(SCENE_MEDIUM).unwrap();
        (e, a, ctx.report().absorbed_w)
    };
    let (mut one, walls, _) = hazy_room(91, 2);
    run(&mut one, 0, n);
    let want = read(&one, walls);
    let (mut a, _, _) = hazy_room(91, 2);
    run(&mut a, 0, n / 2);
    let half = a.state_bytes(0, &[]).unwrap();
    let (mut b, _, _) = hazy_room(91, 2);
    b.load_state(&half).unwrap();
    run(&mut b, n / 2, n);
    let (mut c, _, _) = hazy_room(91, 2);
    run(&mut c, n / 2, n);
    let second = c.state_bytes(0, &[]).unwrap();
    let (mut merged, _, _) = hazy_room(91, 2);
    merged.load_state(&half).unwrap();
    merged.merge_state(&second).unwrap();
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-10 * y.abs().max(1e-300);
    for (what, ctx) in [("resumed", &b), ("merged", &merged)] {
        let got = read(ctx, walls);
        assert!(
            got.0.iter().zip(&want.0).all(|(x, y)| close(*x, *y)),
            "{what}: the map differs"
        );
        for (g, w) in got
            .1
            .band_w
            .iter()
            .chain([&got.1.lm])
            .zip(want.1.band_w.iter().chain([&want.1.lm]))
        {
            assert!(
                close(g.value, w.value) && close(g.sigma, w.sigma),
                "{what}: {g:?} against {w:?}"
            );
        }
        assert!(
            close(got.2, want.2),
            "{what}: absorbed {} against {}",
            got.2,
            want.2
        );
    }
    // The same room in clear air (the haze's material added, but not made the scene's
    // medium) has another fingerprint.
    let mut clear = context(seeded(91));
    let grey = lambert(&mut clear, 0.5);
    let room = cuboid([0.0, 0.0, 0.0], [2.0, 2.0, 2.0], 6, true);
    let mut d = room.desc(grey);
    d.tally = true;
    clear.add_mesh(&d).unwrap();
    let plane = grid(6, 0.2, 1.8, 0.2, 1.8, 1.0);
    let mut d = plane.desc(grey);
    d.sensor = true;
    clear.add_mesh(&d).unwrap();
    haze(&mut clear, &[0.1, 0.2, 0.3], &[0.8, 0.5, 0.2], 0.4);
    clear
        .add_point_light([1.0, 1.0, 1.8], &[1.0, 1.0, 1.0])
        .unwrap();
    let e = clear.load_state(&half).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrStateMismatch, "{e}");
}

//! The light-sampling estimator against analytic answers, with every light type:
//! a black plate (so everything is direct light) under a point, spot, cosine, collimated
//! beam and an emitting square; each vertex reads the hat average of the analytic
//! irradiance within its error (largest |z| bounded; mean |z| ≈ √(2/π) ≈ 0.8: the error
//! estimate is calibrated). A narrow spot whose footprint is smaller than the plate's
//! triangles stays unbiased (the photons take its direct light). In a closed grey room the
//! map agrees with the photons-only estimator's (indirect light included); the same seed
//! gives the same map for any thread count and scheduler; a map holds one estimator.
//! Gathering: every light type again, the integrating sphere's mean irradiance
//! Φ / (A (1 − ρ)), and agreement with photons only in a room of every material (coloured
//! walls, a mirror, two-sided translucent paper, absorbing dispersive glass; a point, a spot
//! and an emitting panel), where light through the glass and off the mirror stays the
//! photons' and the rest is shared by multiple importance sampling; states keep it.

mod common;

use common::*;
use imap::photometry::Spectrum;
use imap::{Amount, LightDesc, LightKind};
use imap::{Config, Context, Estimator, ImapStatus, MeshDesc, RunParams, SchedulerKind};
use std::f64::consts::PI;

const H: f64 = 1.0;
const POWER: f64 = 12.0;

/// A black 1 m plate at z = 0 of 12 × 12 cells.
fn plate(ctx: &mut Context) -> (u32, Geometry) {
    let black = lambert(ctx, 0.0);
    let g = grid(12, -0.5, 0.5, -0.5, 0.5, 0.0);
    (ctx.add_mesh(&g.desc(black)).unwrap(), g)
}

/// Largest and mean |z| of the map against `exact` (hat averages), over vertices where the
/// exact value is above `floor` of its largest.
fn z_scores(ctx: &Context, id: u32, g: &Geometry, exact: &dyn Fn([f64; 3]) -> f64) -> (f64, f64) {
    let nv = g.vertex_count();
    let (mut e, mut rel) = (vec![0.0; nv], vec![0.0; nv]);
    ctx.irradiance(id, 0, 0, &mut e).unwrap();
    ctx.rel_error(id, 0, &mut rel).unwrap();
    // A fine quadrature: the beam's edge is a step, which the 48 × 48 centroid rule misses
    // by more than the gathering runs' errors at the vertices it crosses.
    let want: Vec<f64> = (0..nv)
        .map(|v| hat_average_with(g, v, 192, |x, _| exact(x)))
        .collect();
    let top = want.iter().cloned().fold(0.0, f64::max);
    let (mut worst, mut sum, mut k) = (0.0f64, 0.0, 0.0);
    for v in 0..nv {
        if want[v] > 1e-3 * top {
            let z = (e[v] - want[v]) / (rel[v] * e[v]);
            worst = worst.max(z.abs());
            sum += z.abs();
            k += 1.0;
        }
    }
    (worst, sum / k)
}

/// Gathering on a plate with light sampling's automatic settings there (4 samples per
/// pass, 1408 photons per pass): the plate is black, so this checks that gathering leaves
/// the direct light and the photons' share of it as they are. (With gathering's own
/// settings, one photon per 64 samples, a beam's vertices read up to 5.7 σ off at 40 000
/// photons: the photons' sliver of the weights near each support's rim is then a handful
/// of landings, whose variance estimate is poor.)
const GATHER_PLATE: Estimator = Estimator::LightSampling {
    samples: 4,
    pass_photons: 1408,
    gather: true,
};

fn light(ctx: &mut Context, kind: LightKind, position: [f64; 3]) {
    ctx.add_light_desc(&LightDesc {
        kind,
        position,
        amount: Amount::WattsPerBand(vec![POWER]),
        spectrum: Spectrum::Equal,
    })
    .unwrap();
}

#[test]
fn every_light_type_reads_its_analytic_irradiance() {
    let r2 = |p: [f64; 3], l: [f64; 3]| {
        (p[0] - l[0]).powi(2) + (p[1] - l[1]).powi(2) + (p[2] - l[2]).powi(2)
    };
    let at = [0.1, -0.2, H];
    let point = move |p: [f64; 3]| {
        let r2 = r2(p, at);
        POWER / (4.0 * PI) * H / (r2 * r2.sqrt())
    };
    let half = 60f64.to_radians();
    let spot = move |p: [f64; 3]| {
        let r2 = r2(p, at);
        let cos = H / r2.sqrt();
        if cos >= half.cos() {
            POWER / (2.0 * PI * (1.0 - half.cos())) * cos / r2
        } else {
            0.0
        }
    };
    let cosine = move |p: [f64; 3]| {
        let r2 = r2(p, at);
        POWER / PI * H * H / (r2 * r2)
    };
    // A 0.6 m disk beam straight down: E = Φ / A inside.
    let beam = |p: [f64; 3]| {
        if p[0] * p[0] + p[1] * p[1] <= 0.09 {
            POWER / (PI * 0.09)
        } else {
            0.0
        }
    };
    let down = [0.0, 0.0, -1.0];
    type Field<'a> = &'a dyn Fn([f64; 3]) -> f64;
    let cases: Vec<(&str, LightKind, Field)> = vec![
        ("point", LightKind::Point, &point),
        (
            "spot",
            LightKind::Spot {
                direction: down,
                half_angle_rad: half,
            },
            &spot,
        ),
        ("cosine", LightKind::Cosine { direction: down }, &cosine),
        (
            "beam",
            LightKind::Beam {
                direction: down,
                disk: true,
                size: [0.6, 0.6],
                up: [0.0, 1.0, 0.0],
            },
            &beam,
        ),
    ];
    for ((what, kind, exact), est) in cases
        .iter()
        .flat_map(|c| [(c.clone(), Estimator::DEFAULT), (c.clone(), GATHER_PLATE)])
    {
        let mut ctx = context(seeded(5));
        let (id, g) = plate(&mut ctx);
        let position = if what == "beam" { [0.0, 0.0, H] } else { at };
        light(&mut ctx, kind, position);
        run_with(&mut ctx, photons(400_000), est);
        let what = format!("{what} ({})", ctx.estimator().name());
        let (worst, mean) = z_scores(&ctx, id, &g, exact);
        eprintln!("{what}: largest |z| {worst:.2}, mean |z| {mean:.2}");
        // The beam's edge crosses triangles: the photons take those vertices (a step in
        // the field), the rest is light sampling; every vertex within its error.
        assert!(worst < 4.5, "{what}: largest |z| {worst}");
        assert!((0.6..1.05).contains(&mean), "{what}: mean |z| {mean}");
    }
    // An emitting square 0.4 m wide at H facing down: Lambert's polygon formula.
    for est in [Estimator::DEFAULT, GATHER_PLATE] {
        let mut ctx = context(seeded(6));
        let (id, g) = plate(&mut ctx);
        let black = lambert(&mut ctx, 0.0);
        let lamp = grid(1, -0.2, 0.2, -0.2, 0.2, H).flipped();
        let m = 50.0;
        ctx.add_mesh(&MeshDesc {
            record: false,
            exitance: Some(&[m]),
            ..lamp.desc(black)
        })
        .unwrap();
        run_with(&mut ctx, photons(400_000), est);
        let square = [
            [-0.2, -0.2, H],
            [0.2, -0.2, H],
            [0.2, 0.2, H],
            [-0.2, 0.2, H],
        ];
        let exact = |x: [f64; 3]| polygon_irradiance(x, [0.0, 0.0, 1.0], &square, m / PI);
        let (worst, mean) = z_scores(&ctx, id, &g, &exact);
        eprintln!(
            "emitting square ({}): largest |z| {worst:.2}, mean |z| {mean:.2}",
            ctx.estimator().name()
        );
        assert!(worst < 4.5 && (0.6..1.05).contains(&mean), "{worst} {mean}");
    }
}

/// A spot of 0.5° whose footprint is smaller than the plate's triangles: light samples
/// would almost never find it, the weights give it to the photons; the flux onto the plate
/// is the spot's, over independent seeds.
#[test]
fn a_narrow_spot_stays_unbiased() {
    let mut fluxes = Vec::new();
    for seed in 0..8 {
        let mut ctx = context(seeded(100 + seed));
        let (id, g) = plate(&mut ctx);
        ctx.add_spot_light(
            [0.03, 0.02, H],
            [0.0, 0.0, -1.0],
            0.5f64.to_radians(),
            &[POWER],
        )
        .unwrap();
        run_with(&mut ctx, photons(20_000), Estimator::DEFAULT);
        let mut e = vec![0.0; g.vertex_count()];
        ctx.irradiance(id, 0, 0, &mut e).unwrap();
        fluxes.push(
            e.iter()
                .zip(vertex_areas(&g))
                .map(|(e, a)| e * a)
                .sum::<f64>(),
        );
    }
    assert_seed_mean(&fluxes, POWER, "narrow spot: flux (W)");
}

/// A closed grey room (ρ = 0.6, 6 × 6 cells a face) lit by a point light.
fn grey_room(seed: u64) -> (Context, Vec<u32>) {
    let mut ctx = context(seeded(seed));
    let grey = lambert(&mut ctx, 0.6);
    let id = ctx
        .add_mesh(&cuboid([0.0; 3], [1.0; 3], 6, true).desc(grey))
        .unwrap();
    ctx.add_point_light([0.3, 0.6, 0.8], &[10.0]).unwrap();
    (ctx, vec![id])
}

/// A closed grey room: light sampling and photons only give the same map within their
/// errors (z-scores of the difference with rms ≈ 1), indirect light included.
#[test]
fn light_sampling_and_photons_only_agree_in_a_grey_room() {
    let (mut a, ids) = grey_room(1);
    let (mut b, _) = grey_room(2);
    run_with(&mut a, photons(1_000_000), Estimator::DEFAULT);
    run_with(&mut b, photons(1_000_000), Estimator::Photons);
    let (ma, mb) = (map_with_errors(&a, &ids), map_with_errors(&b, &ids));
    let (rms, mean_z, n) = difference_z(&ma, &mb);
    eprintln!("grey room: rms z of the difference {rms:.2}, mean z {mean_z:.3} over {n} values");
    assert!((0.75..1.3).contains(&rms), "rms z {rms}");
    // Light sampling's error at the same photon count is below the photons' (direct light
    // dominates a room lit by a point light).
    let mean = |m: &[(f64, f64)]| m.iter().map(|x| x.1).sum::<f64>() / m.len() as f64;
    assert!(mean(&ma) < mean(&mb), "{} vs {}", mean(&ma), mean(&mb));
}

#[test]
fn the_same_seed_gives_the_same_map_with_any_scheduler_and_thread_count() {
    for est in [Estimator::DEFAULT, Estimator::GATHER] {
        let build = |threads, scheduler| {
            let mut ctx = context(Config {
                seed: 3,
                threads,
                scheduler,
                ..Default::default()
            });
            let grey = lambert(&mut ctx, 0.5);
            let id = ctx
                .add_mesh(&cuboid([0.0; 3], [1.0; 3], 5, true).desc(grey))
                .unwrap();
            let black = lambert(&mut ctx, 0.0);
            let lamp = grid(1, 0.4, 0.6, 0.4, 0.6, 0.95).flipped();
            ctx.add_mesh(&MeshDesc {
                record: false,
                exitance: Some(&[200.0]),
                ..lamp.desc(black)
            })
            .unwrap();
            // Gathering's passes come a hundred times as often per photon.
            let n = if est == Estimator::GATHER {
                10_000
            } else {
                200_000
            };
            run_with(&mut ctx, n, est);
            let nv = ctx.vertex_count(id).unwrap();
            let mut e = vec![0.0; nv];
            ctx.irradiance(id, 0, 1, &mut e).unwrap();
            e
        };
        let reference = build(1, SchedulerKind::Dynamic);
        for (t, s) in [(3, SchedulerKind::Dynamic), (2, SchedulerKind::Classic)] {
            assert_maps_agree(
                &build(t, s),
                &reference,
                &format!("{}: {t} threads, {s:?}", est.name()),
            );
        }
    }
}

#[test]
fn a_map_holds_one_estimator() {
    let mut ctx = context(seeded(1));
    let (_, _) = plate(&mut ctx);
    ctx.add_point_light([0.0, 0.0, 1.0], &[1.0]).unwrap();
    run_with(&mut ctx, 10_000, Estimator::DEFAULT);
    let e = ctx
        .run(&mut RunParams {
            photons: 1000,
            estimator: Some(Estimator::Photons),
            ..Default::default()
        })
        .unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrOutOfOrder);
    assert!(e.message.contains("params.estimator"), "{e}");
    // The map is as it was; after a reset the other estimator runs.
    assert_eq!(ctx.report().photons, 10_000);
    ctx.reset();
    run_with(&mut ctx, 1000, Estimator::Photons);
    assert_eq!(ctx.estimator(), Estimator::Photons);
    // Too few photons per pass for the scene's vertices is refused, naming the field.
    ctx.reset();
    let e = ctx
        .run(&mut RunParams {
            photons: 1000,
            estimator: Some(Estimator::LightSampling {
                samples: 4,
                pass_photons: 1,
                gather: false,
            }),
            ..Default::default()
        })
        .unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrInvalidArgument);
    assert!(e.message.contains("direct_pass_photons"), "{e}");
}

/// z-scores of the difference of two maps (`whole_map`-like: per value its estimate and
/// relative error): (rms, mean, count) over values both estimate (relative error < 1).
fn difference_z(a: &[(f64, f64)], b: &[(f64, f64)]) -> (f64, f64, usize) {
    let (mut z2, mut z1, mut n) = (0.0, 0.0, 0);
    for (&(ea, ra), &(eb, rb)) in a.iter().zip(b) {
        if ea <= 0.0 || eb <= 0.0 || ra >= 1.0 || rb >= 1.0 {
            continue;
        }
        let s = ((ea * ra).powi(2) + (eb * rb).powi(2)).sqrt();
        let z = (ea - eb) / s;
        z2 += z * z;
        z1 += z;
        n += 1;
    }
    ((z2 / n as f64).sqrt(), z1 / n as f64, n)
}

/// Gathering and photons only agree in a closed grey room and in a room of every material:
/// the gathering paths stop at dielectrics and light whose first surface event is specular
/// or through glass stays the photons' (a wrong partition would double or drop it: a bias of
/// many σ at the vertices it reaches).
#[test]
fn gathering_and_photons_only_agree() {
    let mixed = |seed| mixed_room(seeded(seed));
    type Build<'a> = &'a dyn Fn(u64) -> (Context, Vec<u32>);
    let cases: [(&str, Build, u64, u64); 2] = [
        ("grey room", &grey_room, 100_000, 1_000_000),
        ("room of every material", &mixed, 200_000, 2_000_000),
    ];
    for (what, build, n_gather, n_photons) in cases {
        let (mut a, ids) = build(1);
        let (mut b, _) = build(2);
        run_with(&mut a, photons(n_gather), Estimator::GATHER);
        run_with(&mut b, photons(n_photons), Estimator::Photons);
        let (rms, mean, n) = difference_z(&map_with_errors(&a, &ids), &map_with_errors(&b, &ids));
        eprintln!("{what}: rms z of the difference {rms:.2}, mean z {mean:.3} over {n} values");
        assert!((0.7..1.3).contains(&rms), "{what}: rms z {rms}");
        assert!(mean.abs() < 0.2, "{what}: mean z {mean}");
    }
}

/// The integrating sphere with gathering: the area-weighted mean irradiance is
/// Φ / (A (1 − ρ)) (A: the polyhedron's area), over independent seeds.
#[test]
fn gathering_reads_the_integrating_sphere() {
    let rho = 0.8;
    let power = 10.0;
    let mut means = Vec::new();
    let mut expected = 0.0;
    for seed in 0..4 {
        let mut ctx = context(seeded(40 + seed));
        let wall = lambert(&mut ctx, rho);
        let g = sphere_inward(1.0, 3);
        let id = ctx.add_mesh(&g.desc(wall)).unwrap();
        ctx.add_point_light([0.2, -0.1, 0.3], &[power]).unwrap();
        run_with(&mut ctx, photons(20_000), Estimator::GATHER);
        let mut e = vec![0.0; g.vertex_count()];
        ctx.irradiance(id, 0, 0, &mut e).unwrap();
        let area = vertex_areas(&g);
        let total: f64 = area.iter().sum();
        expected = power / (total * (1.0 - rho));
        means.push(e.iter().zip(&area).map(|(e, a)| e * a).sum::<f64>() / total);
    }
    assert_seed_mean(
        &means,
        expected,
        &format!("integrating sphere, ρ = {rho}: mean irradiance (W/m²)"),
    );
}

/// A state keeps the gathering estimator: a load adopts it, a merge with a light-sampling
/// state is refused naming both.
#[test]
fn states_keep_the_gathering_estimator() {
    let build = |seed| {
        let mut ctx = context(seeded(seed));
        let grey = lambert(&mut ctx, 0.5);
        ctx.add_mesh(&cuboid([0.0; 3], [1.0; 3], 3, true).desc(grey))
            .unwrap();
        ctx.add_point_light([0.5, 0.5, 0.8], &[1.0]).unwrap();
        ctx
    };
    let mut a = build(1);
    run_with(&mut a, 20_000, Estimator::GATHER);
    let bytes = a.state_bytes(0, &[]).unwrap();
    let mut b = build(1);
    b.load_state(&bytes).unwrap();
    assert_eq!(b.estimator(), a.estimator());
    assert!(matches!(
        b.estimator(),
        Estimator::LightSampling { gather: true, .. }
    ));
    let mut c = build(1);
    run_with(&mut c, 20_000, Estimator::DEFAULT);
    let e = c.merge_state(&bytes).unwrap_err();
    assert!(e.message.contains("gathering"), "{e}");
}

/// Gathering with everything a map can keep: two light groups and the direct layer, a
/// tallied plate of two materials (its border vertices leave their light to the photons),
/// a sensor grid on its own passes. The groups add up to the map; the direct layer, the
/// parts' fluxes and the grid agree with photons only within their errors.
#[test]
fn gathering_keeps_groups_the_direct_layer_parts_and_sensors() {
    let build = |seed| {
        let mut ctx = context(seeded(seed));
        let grey = lambert(&mut ctx, 0.5);
        let dark = lambert(&mut ctx, 0.2);
        let black = lambert(&mut ctx, 0.0);
        let room = ctx
            .add_mesh(&cuboid([-1.0, -1.0, 0.0], [1.0, 1.0, 2.0], 4, true).desc(grey))
            .unwrap();
        let g = grid(6, -0.6, 0.6, -0.6, 0.6, 0.3);
        let tm: Vec<u32> = (0..g.indices.len() / 3)
            .map(|t| if t % 12 < 6 { grey } else { dark })
            .collect();
        let plate = ctx
            .add_mesh(&MeshDesc {
                triangle_materials: Some(&tm),
                tally: true,
                ..g.desc(grey)
            })
            .unwrap();
        let s = grid(4, -0.8, 0.8, -0.8, 0.8, 1.0);
        let sensor = ctx
            .add_mesh(&MeshDesc {
                sensor: true,
                ..s.desc(black)
            })
            .unwrap();
        let p = ctx.add_point_light([0.2, -0.3, 1.7], &[8.0]).unwrap();
        let q = ctx
            .add_spot_light([-0.5, 0.4, 1.9], [0.3, -0.2, -1.0], 0.6, &[5.0])
            .unwrap();
        ctx.set_light_group(p, 0).unwrap();
        ctx.set_light_group(q, 1).unwrap();
        ctx.set_layers(imap::LayerRequest {
            groups: true,
            direct: true,
        })
        .unwrap();
        (ctx, [room, plate, sensor], [grey, dark])
    };
    let (mut a, ids, mats) = build(1);
    let (mut b, _, _) = build(2);
    run_with(&mut a, photons(60_000), Estimator::GATHER);
    run_with(&mut b, photons(1_500_000), Estimator::Photons);
    let layer = |c: &Context, m: u32, l: imap::Layer| {
        let n = c.vertex_count(m).unwrap();
        let (mut e, mut r) = (vec![0.0; n], vec![0.0; n]);
        c.irradiance_layer(m, 0, 0, l, &mut e).unwrap();
        c.rel_error_layer(m, 0, l, &mut r).unwrap();
        e.into_iter().zip(r).collect::<Vec<_>>()
    };
    for &m in &ids {
        // The groups add up to the map.
        let all = layer(&a, m, imap::Layer::Combined);
        let (g0, g1) = (
            layer(&a, m, imap::Layer::Group(0)),
            layer(&a, m, imap::Layer::Group(1)),
        );
        for v in 0..all.len() {
            let sum = g0[v].0 + g1[v].0;
            assert!(
                (sum - all[v].0).abs() <= 1e-9 * all[v].0.max(1e-30),
                "mesh {m} vertex {v}"
            );
        }
        for l in [imap::Layer::Combined, imap::Layer::Direct] {
            let (rms, mean, n) = difference_z(&layer(&a, m, l), &layer(&b, m, l));
            eprintln!("mesh {m}, {l:?}: rms z {rms:.2}, mean z {mean:.3} over {n} vertices");
            assert!((0.6..1.4).contains(&rms), "mesh {m} {l:?}: rms z {rms}");
            assert!(
                mean.abs() < 4.0 / (n as f64).sqrt(),
                "mesh {m} {l:?}: mean z {mean}"
            );
        }
    }
    for part in [None, Some(mats[0]), Some(mats[1])] {
        let (x, y) = (
            a.region_stats(ids[1], 0, part).unwrap(),
            b.region_stats(ids[1], 0, part).unwrap(),
        );
        let (fx, fy) = (&x.flux_w[0], &y.flux_w[0]);
        let z = (fx.value - fy.value) / fx.sigma.hypot(fy.sigma);
        eprintln!(
            "plate {part:?}: {:.5} ± {:.5} W (gathering) vs {:.5} ± {:.5} W: z {z:.2}",
            fx.value, fx.sigma, fy.value, fy.sigma
        );
        assert!(x.exact_errors && z.abs() < 4.0, "plate {part:?}: z {z}");
    }
}

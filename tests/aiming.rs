//! Point-like lights aimed at the geometry: a light outside the sphere that
//! holds the scene emits only toward it, each photon weighted by the light's flux share in
//! the cone. The map stays unbiased (against the analytic irradiance of a point and of a
//! cosine light on a small plate far away), the energy balance stays exact, the same seed
//! gives the same map for any thread count and scheduler, and the error for the same
//! photons is far below that of tracing every direction. (Photons only: aiming is about
//! photons; light sampling is checked against the same cases in tests/estimators.rs.)

mod common;

use common::*;
use imap::photometry::Spectrum;
use imap::{Amount, LightDesc, LightKind};
use imap::{Config, Context, SchedulerKind};

const H: f64 = 5.0;
const POWER: f64 = 12.0;

/// A black 0.2 m plate at z = 0 (so nothing is reflected) under a light of `kind` at
/// height H above its centre.
fn plate(kind: LightKind, cfg: Config) -> (Context, u32, Geometry) {
    let mut ctx = context(cfg);
    let black = lambert(&mut ctx, 0.0);
    let g = grid(6, -0.1, 0.1, -0.1, 0.1, 0.0);
    let id = ctx.add_mesh(&g.desc(black)).unwrap();
    ctx.add_light_desc(&LightDesc {
        kind,
        position: [0.0, 0.0, H],
        amount: Amount::WattsPerBand(vec![POWER]),
        spectrum: Spectrum::Equal,
    })
    .unwrap();
    (ctx, id, g)
}

fn cfg(aim: bool, threads: usize, scheduler: SchedulerKind) -> Config {
    Config {
        seed: 11,
        threads,
        scheduler,
        aim_lights: aim,
        ..Default::default()
    }
}

/// Area-weighted mean of the map against the analytic mean, in standard errors, and the
/// mean's relative standard error.
fn check(ctx: &Context, id: u32, g: &Geometry, exact: impl Fn([f64; 3]) -> f64) -> (f64, f64) {
    let n = g.vertex_count();
    let mut e = vec![0.0; n];
    ctx.irradiance(id, 0, 0, &mut e).unwrap();
    let mut rel = vec![0.0; n];
    ctx.rel_error(id, 0, &mut rel).unwrap();
    let a = vertex_areas(g);
    let total: f64 = a.iter().sum();
    let got: f64 = e.iter().zip(&a).map(|(e, a)| e * a).sum::<f64>() / total;
    let want: f64 = (0..n)
        .map(|v| hat_average(g, v, &exact) * a[v])
        .sum::<f64>()
        / total;
    // An upper bound of the mean's standard error (vertices' errors taken as correlated).
    let sigma = e
        .iter()
        .zip(&a)
        .zip(&rel)
        .map(|((e, a), r)| e * a * r)
        .sum::<f64>()
        / total;
    ((got - want) / sigma, sigma / want)
}

#[test]
fn aimed_point_light_is_exact_and_far_more_accurate() {
    let point = |p: [f64; 3]| {
        let r2 = p[0] * p[0] + p[1] * p[1] + H * H;
        POWER / (4.0 * std::f64::consts::PI) * H / (r2 * r2.sqrt())
    };
    let n = photons(400_000);
    let (mut aimed, id, g) = plate(LightKind::Point, cfg(true, 2, SchedulerKind::Dynamic));
    let ra = run_photons_only(&mut aimed, n);
    let (z, rel_aimed) = check(&aimed, id, &g, point);
    assert!(z.abs() < 4.0, "aimed: {z} σ from the analytic mean");
    assert!(rel_aimed < 0.01, "aimed: mean's error {rel_aimed}");
    // The balance: every watt is absorbed by the black plate or escapes, including the
    // flux outside the cone, counted at emission.
    assert!(
        (ra.emitted_w - 3.0 * POWER).abs() < 1e-9 * POWER,
        "{}",
        ra.emitted_w
    );
    assert!((ra.absorbed_w + ra.escaped_w - ra.emitted_w).abs() < 1e-9 * ra.emitted_w);
    let plate_share = ra.absorbed_w / ra.emitted_w;
    // The plate subtends about 0.04/H² of the 4π sr: 1.27e-4 of the flux.
    assert!((plate_share / 1.27e-4 - 1.0).abs() < 0.02, "{plate_share}");

    // Every direction traced, the same photons: an error many times larger.
    let (mut plain, id, g) = plate(LightKind::Point, cfg(false, 2, SchedulerKind::Dynamic));
    run_photons_only(&mut plain, n);
    let mut e = vec![0.0; g.vertex_count()];
    plain.irradiance(id, 0, 0, &mut e).unwrap();
    let hit = e.iter().filter(|&&x| x > 0.0).count();
    let (_, rel_plain) = check(&plain, id, &g, point);
    assert!(
        hit == 0 || rel_plain > 20.0 * rel_aimed,
        "plain {rel_plain} vs aimed {rel_aimed}"
    );

    // The same seed, the same map: any thread count and either scheduler.
    let map = |c: &Context| {
        let mut e = vec![0.0; g.vertex_count()];
        c.irradiance(id, 0, 0, &mut e).unwrap();
        e
    };
    let reference = map(&aimed);
    for (threads, scheduler) in [(1, SchedulerKind::Dynamic), (3, SchedulerKind::Classic)] {
        let (mut c, _, _) = plate(LightKind::Point, cfg(true, threads, scheduler));
        run_photons_only(&mut c, n);
        for (a, b) in map(&c).iter().zip(&reference) {
            assert!(
                (a - b).abs() <= 1e-12 * b.abs().max(1e-300),
                "{threads} {scheduler:?}"
            );
        }
    }
}

/// A cosine light aims with per-direction weights I(d)/Φ·Ω: still unbiased.
#[test]
fn aimed_cosine_light_is_exact() {
    // I(θ) = (Φ/π) cos θ; on the plate cos θ = H/r: E = Φ/π · H²/r⁴.
    let cosine = |p: [f64; 3]| {
        let r2 = p[0] * p[0] + p[1] * p[1] + H * H;
        POWER / std::f64::consts::PI * H * H / (r2 * r2)
    };
    let kind = || LightKind::Cosine {
        direction: [0.0, 0.0, -1.0],
    };
    let (mut c, id, g) = plate(kind(), cfg(true, 2, SchedulerKind::Dynamic));
    let r = run_photons_only(&mut c, photons(400_000));
    let (z, rel) = check(&c, id, &g, cosine);
    assert!(z.abs() < 4.0 && rel < 0.01, "{z} σ, error {rel}");
    assert!((r.absorbed_w + r.escaped_w - r.emitted_w).abs() < 1e-9 * r.emitted_w);
    // Tilted 40° away from the plate: the cone is off the axis, the weights vary; still
    // unbiased (E = I(θ)·cos(incidence)/r²).
    let t = 40f64.to_radians();
    let axis = [t.sin(), 0.0, -t.cos()];
    let tilted = |p: [f64; 3]| {
        let d = [p[0], p[1], p[2] - H];
        let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let r = r2.sqrt();
        let cos_out = (d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2]) / r;
        POWER / std::f64::consts::PI * cos_out.max(0.0) * (H / r) / r2
    };
    let (mut c, id, g) = plate(
        LightKind::Cosine { direction: axis },
        cfg(true, 2, SchedulerKind::Dynamic),
    );
    run_photons_only(&mut c, photons(400_000));
    let (z, rel) = check(&c, id, &g, tilted);
    assert!(z.abs() < 4.0 && rel < 0.01, "tilted: {z} σ, error {rel}");
}

/// The error estimate of aimed photons is that of their weights: at the same photon count
/// the standard error of a vertex is √F times that of tracing every direction (F: the
/// cone's share of the sphere of directions), and it matches the scatter over seeds. The
/// light shines from the side into the gap between two white plates, so a photon hits the
/// same vertex many times (the cross terms of its square count).
#[test]
fn aimed_errors_are_calibrated() {
    const NEAR: f64 = 0.3;
    const GAP: f64 = 0.04;
    let near = |aim: bool, seed: u64| {
        let mut ctx = context(Config {
            seed,
            threads: 2,
            aim_lights: aim,
            ..Default::default()
        });
        let white = lambert(&mut ctx, 0.9);
        let g = grid(6, -0.1, 0.1, -0.1, 0.1, 0.0);
        let id = ctx.add_mesh(&g.desc(white)).unwrap();
        let lid = grid(6, -0.1, 0.1, -0.1, 0.1, GAP).flipped();
        ctx.add_mesh(&imap::MeshDesc {
            record: false,
            ..lid.desc(white)
        })
        .unwrap();
        ctx.add_point_light([NEAR, 0.0, GAP / 2.0], &[1.0]).unwrap();
        run_photons_only(&mut ctx, 400_000);
        let v = 3 * 7 + 5; // near the open side the light faces
        let n = g.vertex_count();
        let (mut e, mut r) = (vec![0.0; n], vec![0.0; n]);
        ctx.irradiance(id, 0, 0, &mut e).unwrap();
        ctx.rel_error(id, 0, &mut r).unwrap();
        (e[v], e[v] * r[v])
    };
    // The sphere the light aims at: the plates' half-diagonal, 1 % wider.
    let radius = 0.5 * (0.2f64 * 0.2 + 0.2 * 0.2 + GAP * GAP).sqrt() * 1.01;
    let sin = radius / NEAR;
    let f = (1.0 - (1.0 - sin * sin).sqrt()) / 2.0;
    let (_, s_aimed) = near(true, 1);
    let (_, s_plain) = near(false, 1);
    let ratio = s_aimed / s_plain / f.sqrt();
    assert!((0.75..1.33).contains(&ratio), "σ ratio / √F = {ratio}");
    // Scatter over seeds against the estimate.
    let runs: Vec<(f64, f64)> = (10..22).map(|s| near(true, s)).collect();
    let mean = runs.iter().map(|r| r.0).sum::<f64>() / runs.len() as f64;
    let scatter =
        (runs.iter().map(|r| (r.0 - mean).powi(2)).sum::<f64>() / (runs.len() - 1) as f64).sqrt();
    let estimated = runs.iter().map(|r| r.1).sum::<f64>() / runs.len() as f64;
    assert!(
        (0.6..1.6).contains(&(scatter / estimated)),
        "scatter {scatter} vs estimated {estimated}"
    );
}

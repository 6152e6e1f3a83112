//! The per-vertex error estimate is calibrated: over independent seeds, the actual spread
//! of each vertex's irradiance matches the estimated standard error, also in stiff closed
//! scenes where a photon returns to the same vertex many times.

mod common;

use common::*;
use imap::Config;

/// Mean over vertices of (standard deviation across seeds) / (mean estimated σ), and the
/// number of vertices whose estimated σ was 0 in some seed.
fn calibration(rho: f64, photons_per_seed: u64, seeds: u64) -> (f64, usize) {
    let g = sphere_inward(1.0, 3);
    let nv = g.vertex_count();
    let mut values = vec![Vec::new(); nv];
    let mut estimated = vec![0.0; nv];
    let mut zero = 0;
    for seed in 0..seeds {
        let mut ctx = context(Config {
            threads: 2,
            seed,
            ..Default::default()
        });
        let wall = lambert(&mut ctx, rho);
        let id = ctx.add_mesh(&g.desc(wall)).unwrap();
        ctx.add_point_light([0.2, 0.1, -0.3], &[1.0]).unwrap();
        run_photons(&mut ctx, photons_per_seed);
        let (mut e, mut r) = (vec![0.0; nv], vec![0.0; nv]);
        ctx.irradiance(id, 0, 0, &mut e).unwrap();
        ctx.rel_error(id, 0, &mut r).unwrap();
        for v in 0..nv {
            values[v].push(e[v]);
            estimated[v] += r[v] * e[v] / seeds as f64;
            zero += usize::from(r[v] == 0.0);
        }
    }
    let ratio = (0..nv)
        .map(|v| {
            let mean = values[v].iter().sum::<f64>() / seeds as f64;
            let var =
                values[v].iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (seeds - 1) as f64;
            var.sqrt() / estimated[v]
        })
        .sum::<f64>()
        / nv as f64;
    (ratio, zero)
}

#[test]
fn error_estimate_matches_the_spread_over_seeds() {
    // ρ = 0.99: about 100 hits per photon, many returns to each vertex. Squaring single
    // deposits instead of each photon's total contribution gave σ = 0 on 24 of these 258
    // vertices and no usable estimate.
    for (rho, n) in [(0.5, 40_000), (0.9, 20_000), (0.99, 16_000)] {
        let (ratio, zero) = calibration(rho, n, 12);
        eprintln!("ρ = {rho}: actual / estimated σ = {ratio:.3}, vertices with σ = 0: {zero}");
        assert_eq!(zero, 0, "ρ = {rho}: some vertices report no error");
        assert!(
            (0.8..1.25).contains(&ratio),
            "ρ = {rho}: actual / estimated σ = {ratio}"
        );
    }
}

#[test]
fn global_error_falls_as_one_over_root_photons() {
    // The history of a run records (photons, estimated global error) at each progress
    // interval; at a constant photon rate, error ∝ t^-1/2 means slope −1/2 in log–log.
    let mut ctx = context(Config {
        threads: 2,
        seed: 21,
        ..Default::default()
    });
    let wall = lambert(&mut ctx, 0.5);
    let g = sphere_inward(1.0, 3);
    ctx.add_mesh(&g.desc(wall)).unwrap();
    ctx.add_point_light([0.1, 0.0, 0.2], &[1.0]).unwrap();
    // Ten runs of growing length give points over two decades of photons, independent of
    // how fast this machine is.
    let mut points = Vec::new();
    let mut total = 0;
    for k in 0..10 {
        let n = photons(4_000) * (1 << (k * 7 / 10));
        let r = run_photons(&mut ctx, n);
        total += n;
        assert_eq!(r.photons, total);
        points.push(((r.photons as f64).ln(), r.rel_error.ln()));
    }
    let m = points.len() as f64;
    let (mx, my) = (
        points.iter().map(|p| p.0).sum::<f64>() / m,
        points.iter().map(|p| p.1).sum::<f64>() / m,
    );
    let slope = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
        / points.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
    let span = (points.last().unwrap().0 - points[0].0) / std::f64::consts::LN_10;
    eprintln!("error vs photons over {span:.1} decades: slope {slope:.3}");
    assert!(span > 1.5);
    assert!((slope + 0.5).abs() < 0.05, "slope {slope}");
}

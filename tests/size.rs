//! A 10-million-triangle mesh: the RGB run's memory, and maps too large for the budget
//! refused before anything is allocated. One test in its own binary, so the process's
//! peak resident memory is this case's alone.

mod common;

use common::*;
use imap::{Bands, Config, ImapStatus};

/// Peak resident set size of this process, bytes (Linux: VmHWM).
fn peak_rss() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status.lines().find(|l| l.starts_with("VmHWM:")).unwrap();
    let kb: u64 = line.split_whitespace().nth(1).unwrap().parse().unwrap();
    kb * 1024
}

#[test]
fn ten_million_triangles_in_rgb_and_oversized_spectral_maps_refused() {
    let n = 2237; // 2·2237² = 10 008 338 triangles, 2238² = 5 008 644 vertices
    let g = grid(n, -50.0, 50.0, -50.0, 50.0, 0.0);
    let (tris, verts) = (g.indices.len() / 3, g.vertex_count());
    assert!(tris >= 10_000_000);
    let before = peak_rss();

    // 4096 bands would need 164 GB of map: the default budget (3/4 of physical memory)
    // refuses it when the mesh is added, before the mesh is even copied.
    let mut ctx = context(Config {
        bands: Bands::spectral(4096, 380.0, 780.0).unwrap(),
        ..Default::default()
    });
    let grey = lambert(&mut ctx, 0.5);
    let err = ctx.add_mesh(&g.desc(grey)).unwrap_err();
    eprintln!("4096 bands, default budget: {err}");
    assert_eq!(err.status, ImapStatus::ImapErrMemoryBudget);
    assert!(err.to_string().contains("3/4 of physical memory"), "{err}");
    // 81 bands (3.3 GB of map) under a 1 GiB budget: refused the same way.
    let mut ctx = context(Config {
        bands: Bands::spectral(81, 380.0, 780.0).unwrap(),
        memory_budget: 1 << 30,
        ..Default::default()
    });
    let grey = lambert(&mut ctx, 0.5);
    let err = ctx.add_mesh(&g.desc(grey)).unwrap_err();
    eprintln!("81 bands, 1 GiB budget: {err}");
    assert_eq!(err.status, ImapStatus::ImapErrMemoryBudget);
    // The context is still usable: a smaller mesh goes in and runs.
    let small = grid(8, -1.0, 1.0, -1.0, 1.0, 0.0);
    ctx.add_mesh(&small.desc(grey)).unwrap();
    ctx.add_point_light([0.0, 0.0, 1.0], &[1.0]).unwrap();
    run_photons(&mut ctx, 1000);
    drop(ctx);
    let refused = peak_rss() - before;
    eprintln!("peak memory added by the refusals: {} MiB", refused >> 20);
    assert!(refused < 64 << 20, "refusing allocated {refused} bytes");

    // RGB: the whole run, from adding the mesh to reading the map.
    let before = peak_rss();
    let mut ctx = context(Config {
        threads: 2,
        ..Default::default()
    });
    let grey = lambert(&mut ctx, 0.5);
    let id = ctx.add_mesh(&g.desc(grey)).unwrap();
    ctx.add_point_light([3.0, -7.0, 10.0], &[1000.0]).unwrap();
    let t0 = std::time::Instant::now();
    let report = run_photons(&mut ctx, photons(500_000));
    let secs = t0.elapsed().as_secs_f64();
    let mut e = vec![0.0; verts];
    ctx.irradiance(id, 0, 0, &mut e).unwrap();
    assert!(e.iter().all(|x| x.is_finite()));
    // The flux onto the square is Φ/4π times its solid angle from the light (exact).
    let share = vertex_areas(&g);
    let got: f64 = e.iter().zip(&share).map(|(e, a)| e * a).sum();
    let light = [3.0, -7.0, 10.0];
    let c = |x: f64, y: f64| [x, y, 0.0];
    let omega = solid_angle(light, [c(-50.0, -50.0), c(50.0, -50.0), c(50.0, 50.0)])
        + solid_angle(light, [c(-50.0, -50.0), c(50.0, 50.0), c(-50.0, 50.0)]);
    let p = omega / (4.0 * std::f64::consts::PI);
    let expected = 1000.0 * p;
    let sigma = expected * ((1.0 - p) / (p * report.photons as f64)).sqrt();
    eprintln!(
        "flux onto the mesh {got:.3} W, exact {expected:.3} W ({:.2} σ)",
        (got - expected) / sigma
    );
    assert!((got - expected).abs() <= 3.0 * sigma, "{got} vs {expected}");
    let peak = peak_rss() - before;
    let input = (g.positions.len() * 8 + g.indices.len() * 4) as u64;
    eprintln!(
        "{tris} triangles, {verts} vertices, RGB: map {} MiB, peak memory added by the context {} MiB ({:.0} bytes per triangle; the caller's own arrays, {} MiB, not counted), {:.1} s for {} photons",
        report.map_bytes >> 20,
        peak >> 20,
        peak as f64 / tris as f64,
        input >> 20,
        secs,
        report.photons
    );
    // Per vertex: the map's 3 bands and sum of squares, and the light-sampling
    // estimator's direct record (3 bands, two sums of squares, the pass count).
    assert_eq!(report.map_bytes, verts as u64 * (4 + 6) * 8);
    // The stated figure (README, docs/accuracy.md): at most 300 bytes per triangle.
    assert!(
        peak <= 300 * tris as u64,
        "{peak} bytes for {tris} triangles"
    );
}

//! Physics against analytic answers.

mod common;

use common::*;
use imap::{Config, IorModel, MaterialDesc};

#[test]
fn point_source_over_black_plane() {
    // An isotropic point source of 4π W per band (I = 1 W/sr) at height d over a black
    // plane: E = I cos θ / r² = I d / r³. A vertex's expected value is that field averaged
    // with the vertex's hat function (`hat_average`); symmetric vertices around the foot
    // of the source are averaged in rings to reduce the variance.
    let d = 1.0;
    let mut ctx = context(Config {
        threads: 2,
        seed: 1,
        ..Default::default()
    });
    let black = lambert(&mut ctx, 0.0);
    let n_cells = 16; // h = 0.25 d
    let g = grid(n_cells, -2.0, 2.0, -2.0, 2.0, 0.0);
    let mesh = ctx.add_mesh(&g.desc(black)).unwrap();
    let power = 4.0 * std::f64::consts::PI;
    ctx.add_point_light([0.0, 0.0, d], &[power]).unwrap();
    let n = photons(12_000_000);
    run_photons(&mut ctx, n);
    let nv = g.vertex_count();
    let (mut e, mut err) = (vec![0.0; nv], vec![0.0; nv]);
    ctx.rel_error(mesh, 0, &mut err).unwrap();
    let exact = |x: [f64; 3]| d / (x[0] * x[0] + x[1] * x[1] + d * d).powf(1.5);
    let c = n_cells as i64 / 2;
    let id = |i: i64, j: i64| ((c + j) * (n_cells as i64 + 1) + c + i) as usize;
    // Under the source, beside it, diagonal, and farther out at 51° incidence.
    let rings: [Vec<usize>; 4] = [
        vec![id(0, 0)],
        vec![id(2, 0), id(-2, 0), id(0, 2), id(0, -2)],
        vec![id(2, 2), id(-2, 2), id(2, -2), id(-2, -2)],
        vec![id(5, 0), id(-5, 0), id(0, 5), id(0, -5)],
    ];
    for band in 0..3 {
        ctx.irradiance(mesh, 0, band, &mut e).unwrap();
        for ring in &rings {
            let k = ring.len() as f64;
            let mean = ring.iter().map(|&v| e[v]).sum::<f64>() / k;
            let sigma = ring
                .iter()
                .map(|&v| (err[v] * e[v]).powi(2))
                .sum::<f64>()
                .sqrt()
                / k;
            // The triangulation's diagonals make ring vertices' hat functions differ: average
            // each one's own expectation.
            let expected = ring.iter().map(|&v| hat_average(&g, v, exact)).sum::<f64>() / k;
            let point = exact(g.vertex(ring[0]));
            let dev = (mean - expected).abs();
            eprintln!(
                "band {band}, vertex {:?}: E = {mean:.5} expected {expected:.5} (point value {point:.5}), rel σ {:.4}, {:.2} σ",
                g.vertex(ring[0]),
                sigma / mean,
                dev / sigma
            );
            assert!(
                dev <= 3.0 * sigma,
                "{:?}: {mean} vs {expected}, {:.2} σ",
                g.vertex(ring[0]),
                dev / sigma
            );
            assert!(
                dev <= 0.01 * expected,
                "{:?}: {mean} vs {expected}: more than 1%",
                g.vertex(ring[0])
            );
        }
    }
}

fn integrating_sphere(rho: f64, light: [f64; 3]) {
    let r = 1.0;
    let mut ctx = context(Config {
        threads: 2,
        seed: 7,
        ..Default::default()
    });
    let wall = lambert(&mut ctx, rho);
    let g = sphere_inward(r, 4);
    let mesh = ctx.add_mesh(&g.desc(wall)).unwrap();
    let power = 10.0;
    ctx.add_point_light(light, &[power]).unwrap();
    let n = photons(400_000);
    let report = run_photons(&mut ctx, n);
    assert_eq!(report.escaped_w, 0.0, "a closed sphere must not leak");
    // Area of the polyhedron and the area-weighted mean irradiance.
    let nv = g.vertex_count();
    let mut e = vec![0.0; nv];
    ctx.irradiance(mesh, 0, 1, &mut e).unwrap();
    let area = vertex_areas(&g);
    let total_area: f64 = area.iter().sum();
    let mean: f64 = e.iter().zip(&area).map(|(e, a)| e * a).sum::<f64>() / total_area;
    let expected = power / (total_area * (1.0 - rho));
    // Hits per photon are geometric with success 1 − ρ: the relative standard deviation of
    // the mean over N photons is √(ρ/N).
    let sigma = (rho / n as f64).sqrt();
    let dev = mean / expected - 1.0;
    eprintln!("ρ = {rho}, light at {light:?}: mean E = {mean:.5}, expected {expected:.5}, deviation {dev:.2e} ({:.2} σ)", dev / sigma);
    assert!(
        dev.abs() <= 4.0 * sigma,
        "ρ = {rho}: mean {mean} vs {expected}"
    );
}

#[test]
fn integrating_sphere_rho_0_5() {
    integrating_sphere(0.5, [0.0, 0.0, 0.0]);
}

#[test]
fn integrating_sphere_rho_0_9_off_centre() {
    integrating_sphere(0.9, [0.3, -0.2, 0.1]);
}

/// A narrow beam at normal incidence on a slab (index n, thickness 0.2 m, absorption α in
/// 1/m) over a black receiver; returns (transmitted fraction, its standard error, report).
fn slab_transmission(n_glass: f64, alpha: f64, photons_n: u64) -> (f64, f64, imap::Report) {
    let mut ctx = context(Config {
        threads: 2,
        seed: 3,
        ..Default::default()
    });
    let black = lambert(&mut ctx, 0.0);
    let absorption = if alpha > 0.0 { vec![alpha] } else { vec![] };
    let glass = ctx
        .add_material(&MaterialDesc {
            ior: Some(IorModel::Constant(n_glass)),
            absorption_per_m: absorption,
            ..Default::default()
        })
        .unwrap();
    let slab = cuboid([-1.0, -1.0, 0.0], [1.0, 1.0, 0.2], 2, false);
    let mut sd = slab.desc(glass);
    sd.record = false;
    ctx.add_mesh(&sd).unwrap();
    let receiver = grid(2, -1.0, 1.0, -1.0, 1.0, -0.5);
    let rmesh = ctx.add_mesh(&receiver.desc(black)).unwrap();
    ctx.add_spot_light([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], 1e-3, &[1.0])
        .unwrap();
    let report = run_photons(&mut ctx, photons_n);
    let t = ctx.absorbed_w(rmesh).unwrap() / report.emitted_w;
    (t, (t * (1.0 - t) / photons_n as f64).sqrt(), report)
}

#[test]
fn clear_slab_transmits_the_fresnel_fraction() {
    // Incoherent multiple reflections: T = (1 − R)² / (1 − R²) = (1 − R)/(1 + R).
    let n_glass = 1.5;
    let n = photons(1_000_000);
    let (t, sigma, report) = slab_transmission(n_glass, 0.0, n);
    let r = ((n_glass - 1.0) / (n_glass + 1.0)).powi(2);
    let t_expected = (1.0 - r) / (1.0 + r);
    eprintln!(
        "clear slab: T = {t:.5}, Fresnel {t_expected:.5}, {:.2} σ",
        (t - t_expected) / sigma
    );
    assert!((t - t_expected).abs() <= 4.0 * sigma);
    assert!((report.escaped_w / report.emitted_w - (1.0 - t_expected)).abs() <= 4.0 * sigma);
}

#[test]
fn absorbing_slab_follows_beer_lambert() {
    // Internal transmittance τ = exp(−α d): T = (1 − R)² τ / (1 − R² τ²).
    let (n_glass, alpha, d) = (1.7, 2.0, 0.2);
    let n = photons(1_000_000);
    let (t, sigma, _) = slab_transmission(n_glass, alpha, n);
    let r = ((n_glass - 1.0) / (n_glass + 1.0)).powi(2);
    let tau = (-alpha * d).exp();
    let t_expected = (1.0 - r).powi(2) * tau / (1.0 - r * r * tau * tau);
    eprintln!(
        "absorbing slab: T = {t:.5}, expected {t_expected:.5}, {:.2} σ",
        (t - t_expected) / sigma
    );
    assert!((t - t_expected).abs() <= 4.0 * sigma);
}

/// Polarisation-resolved Fresnel power reflectances (R_s, R_p) from index 1 into `n` at
/// incidence `theta` (radians), written out here independently of the library.
fn fresnel_s_p(theta: f64, n: f64) -> (f64, f64) {
    let (ci, si) = (theta.cos(), theta.sin());
    let ct = (1.0 - (si / n).powi(2)).sqrt();
    let rs = (ci - n * ct) / (ci + n * ct);
    let rp = (n * ci - ct) / (n * ci + ct);
    (rs * rs, rp * rp)
}

#[test]
fn an_oblique_beam_through_a_slab_follows_polarised_fresnel() {
    // A narrow beam at θ onto a clear 0.2 m slab (n = 1.52) over a black receiver. The first
    // face polarises what it transmits, so the second reflects less of it than unpolarised
    // light: with incoherent multiple reflections, each polarisation transmits
    // (1 − R)/(1 + R), and unpolarised light the mean of the two (the value an
    // unpolarised model gives, with R = (R_s + R_p)/2, is 0.4 % lower at 45°, 1.5 % at 60°
    // and 3.8 % at 75°).
    let n_glass = 1.52;
    let n = photons(600_000);
    for deg in [0.0f64, 30.0, 45.0, 60.0, 75.0, 80.0] {
        let theta = deg.to_radians();
        let mut ctx = context(Config {
            threads: 2,
            seed: 11,
            ..Default::default()
        });
        let black = lambert(&mut ctx, 0.0);
        let glass = ctx
            .add_material(&MaterialDesc {
                ior: Some(IorModel::Constant(n_glass)),
                ..Default::default()
            })
            .unwrap();
        let slab = cuboid([-10.0, -10.0, 0.0], [10.0, 10.0, 0.2], 2, false);
        let mut sd = slab.desc(glass);
        sd.record = false;
        ctx.add_mesh(&sd).unwrap();
        let receiver = grid(2, -30.0, 30.0, -30.0, 30.0, -0.5);
        let rmesh = ctx.add_mesh(&receiver.desc(black)).unwrap();
        let dir = [theta.sin(), 0.0, -theta.cos()];
        let from = [-2.0 * dir[0], 0.0, 0.2 - 2.0 * dir[2]];
        ctx.add_spot_light(from, dir, 1e-4, &[1.0]).unwrap();
        let report = run_photons(&mut ctx, n);
        let t = ctx.absorbed_w(rmesh).unwrap() / report.emitted_w;
        let sigma = (t * (1.0 - t) / n as f64).sqrt();
        let (rs, rp) = fresnel_s_p(theta, n_glass);
        let slab_t = |r: f64| (1.0 - r) / (1.0 + r);
        let polarised = 0.5 * (slab_t(rs) + slab_t(rp));
        let unpolarised = slab_t(0.5 * (rs + rp));
        eprintln!(
            "{deg}°: T = {t:.5} ± {sigma:.5}; polarised Fresnel {polarised:.5} ({:.2} σ), unpolarised {unpolarised:.5} ({:.2} σ)",
            (t - polarised) / sigma,
            (t - unpolarised) / sigma
        );
        assert!(
            (t - polarised).abs() <= 3.0 * sigma,
            "{deg}°: {t} vs {polarised}"
        );
        if deg >= 60.0 {
            // The test tells the two models apart where they differ.
            assert!((t - unpolarised).abs() > 6.0 * sigma, "{deg}°");
        }
    }
}

#[test]
fn answer_does_not_depend_on_scene_scale_or_position() {
    // A closed 2 m box (normals in, ρ = 0.8) with an off-centre point light, described at
    // 1e-4, 1 and 1e4 scene units per metre-sized feature and translated far from the
    // origin: the mean irradiance is Φ/(A(1 − ρ)) in W/m² every time and nothing leaks
    // through the seams and corners.
    let rho = 0.8;
    let power = 12.0;
    let n = photons(300_000);
    for (scale, shift) in [(1e-4, 0.0), (1.0, 1e5), (1e4, 1e5)] {
        let mut ctx = context(Config {
            threads: 2,
            seed: 17,
            unit_m: 1.0 / scale,
            ..Default::default()
        });
        let wall = lambert(&mut ctx, rho);
        let g = cuboid([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], 8, true)
            .scaled(scale)
            .translated([shift * scale, -shift * scale, shift * scale]);
        let mesh = ctx.add_mesh(&g.desc(wall)).unwrap();
        let light = [
            (0.3 + shift) * scale,
            (-0.6 - shift) * scale,
            (0.2 + shift) * scale,
        ];
        ctx.add_point_light(light, &[power]).unwrap();
        let report = run_photons(&mut ctx, n);
        assert_eq!(report.escaped_w, 0.0, "scale {scale}: photons leaked");
        let mut e = vec![0.0; g.vertex_count()];
        ctx.irradiance(mesh, 0, 0, &mut e).unwrap();
        // Shares in the box's own metres (the geometry before scaling).
        let share = vertex_areas(&cuboid([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], 8, true));
        let area = 24.0;
        let mean = e.iter().zip(&share).map(|(e, a)| e * a).sum::<f64>() / area;
        let expected = power / (area * (1.0 - rho));
        let sigma = (rho / n as f64).sqrt();
        eprintln!(
            "scale {scale}, shift {shift}: mean {mean:.5} W/m², expected {expected:.5} ({:.2} σ)",
            (mean / expected - 1.0) / sigma
        );
        assert!(
            (mean / expected - 1.0).abs() <= 4.0 * sigma,
            "scale {scale}: {mean} vs {expected}"
        );
    }
}

#[test]
fn dispersive_slab_separates_bands_by_snell() {
    // A collimated two-band beam at 60° onto a 1 m slab of dispersive glass (Cauchy, n =
    // 1.5 at 650 nm and 1.7 at 450 nm) over a black receiver 0.5 m below it. Each photon
    // collapses to one band at the first surface; its band's transmitted beams exit at
    // x = t·tan θt + 2k·t·tan θt (k internal round trips, weights R^2k for each of the s
    // and p parts) and travel on at
    // 60°. Barycentric deposits preserve first moments, so each band's irradiance
    // centroid on the receiver is the mean arrival position of its photons.
    let bands = imap::Bands::spectral(2, 450.0, 650.0).unwrap();
    let mut ctx = context(Config {
        threads: 2,
        seed: 8,
        bands,
        ..Default::default()
    });
    let black = lambert(&mut ctx, 0.0);
    let (b_coef, a_coef) = {
        let (x_r, x_b) = (1.0 / 0.65f64.powi(2), 1.0 / 0.45f64.powi(2));
        let b = 0.2 / (x_b - x_r);
        (b, 1.5 - b * x_r)
    };
    let glass = ctx
        .add_material(&MaterialDesc {
            ior: Some(IorModel::Cauchy {
                a: a_coef,
                b: b_coef,
                c: 0.0,
            }),
            ..Default::default()
        })
        .unwrap();
    let (t, depth, theta) = (1.0, 0.5, 60f64.to_radians());
    let slab = cuboid([-4.0, -3.0, -t], [9.0, 3.0, 0.0], 2, false);
    let mut sd = slab.desc(glass);
    sd.record = false;
    ctx.add_mesh(&sd).unwrap();
    let receiver = grid(60, -2.0, 8.0, -1.0, 1.0, -t - depth);
    let rmesh = ctx.add_mesh(&receiver.desc(black)).unwrap();
    let start = [-theta.tan(), 0.0, 1.0];
    ctx.add_spot_light(start, [theta.sin(), 0.0, -theta.cos()], 1e-5, &[1.0])
        .unwrap();
    let n = photons(400_000);
    run_photons(&mut ctx, n);

    let share = vertex_areas(&receiver);
    let mut e = vec![0.0; receiver.vertex_count()];
    let mut centroids = Vec::new();
    for (band, n_glass) in [(0u32, 1.7f64), (1, 1.5)] {
        ctx.irradiance(rmesh, 0, band, &mut e).unwrap();
        let (mut sx, mut sw) = (0.0, 0.0);
        for v in 0..e.len() {
            sx += receiver.vertex(v)[0] * e[v] * share[v];
            sw += e[v] * share[v];
        }
        let got = sx / sw;
        // Fresnel at the internal incidence angle θt (the same on every internal bounce),
        // per polarisation: light enters as an even mix of s and p, each part keeps its
        // own R on every face (the faces are parallel), so k round trips have weight
        // T²R^2k within each part.
        let sin_t = theta.sin() / n_glass;
        let cos_t = (1.0 - sin_t * sin_t).sqrt();
        let (rs, rp) = {
            let (ci, n1, n2) = (cos_t, n_glass, 1.0f64);
            let ct = theta.cos();
            let rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct);
            let rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct);
            (rs * rs, rp * rp)
        };
        let step = 2.0 * t * sin_t / cos_t;
        // Each part's transmitted power and the first two moments of its round trips.
        let part = |r: f64| {
            let q = r * r;
            let w = (1.0 - r).powi(2) / (1.0 - q);
            (w, q / (1.0 - q), q * (1.0 + q) / (1.0 - q).powi(2))
        };
        let ((ws, ks, k2s), (wp, kp, k2p)) = (part(rs), part(rp));
        let mean_k = (ws * ks + wp * kp) / (ws + wp);
        let mean_k2 = (ws * k2s + wp * k2p) / (ws + wp);
        let expected = t * sin_t / cos_t + step * mean_k + depth * theta.tan();
        // Spread of arrival positions: the internal round trips.
        let var = step * step * (mean_k2 - mean_k * mean_k);
        let sigma = (var / (n as f64 / 2.0)).sqrt() + 1e-4;
        eprintln!(
            "band {band} (n = {n_glass}): centroid x = {got:.5} m, Snell {expected:.5} m ({:.2} σ)",
            (got - expected) / sigma
        );
        assert!(
            (got - expected).abs() <= 5.0 * sigma,
            "band {band}: {got} vs {expected}"
        );
        centroids.push(got);
    }
    // The bands land 0.11 m apart: blue (higher index) bends more.
    assert!(centroids[1] - centroids[0] > 0.1);
}

/// The sphere `g` as a recorded wall of diffuse reflectance `rho` (one value per band of
/// `config`): the context and the mesh.
fn spectral_sphere(config: Config, g: &Geometry, rho: &[f64]) -> (imap::Context, u32) {
    let mut ctx = context(config);
    let wall = ctx
        .add_material(&MaterialDesc {
            diffuse_reflect: rho.to_vec(),
            ..Default::default()
        })
        .unwrap();
    let mesh = ctx.add_mesh(&g.desc(wall)).unwrap();
    (ctx, mesh)
}

/// The area-weighted mean of per-vertex values `e`.
fn area_mean(e: &[f64], area: &[f64]) -> f64 {
    e.iter().zip(area).map(|(e, a)| e * a).sum::<f64>() / area.iter().sum::<f64>()
}

/// A closed sphere at 41 bands lit by two point lights of different spectra (a spectral
/// map keeps one grey sum per emitter spectrum: a photon whose colour is still a multiple
/// of its light's deposits one number): with grey walls every deposit is such a multiple,
/// with walls whose albedo varies across the bands only first hits are. Either way, every
/// band's area-weighted mean irradiance is Φ_b / (A (1 − ρ_b)) (every photon of band b hits
/// a geometric number of times, mean 1 / (1 − ρ_b)), for both schedulers and both the
/// photons-only and the light-sampling estimators (whose photons' deposits carry
/// weights); the map's own error estimate of that mean is calibrated against the truth.
#[test]
fn a_spectral_sphere_holds_every_band_with_two_light_spectra() {
    let nb = 41;
    let bands = imap::Bands::spectral(nb as u32, 400.0, 700.0).unwrap();
    let flat = vec![0.5; nb];
    let tilted: Vec<f64> = (0..nb)
        .map(|b| 0.3 + 0.4 * b as f64 / (nb - 1) as f64)
        .collect();
    let p1: Vec<f64> = (0..nb).map(|b| 1.0 + b as f64 / 10.0).collect();
    let p2: Vec<f64> = (0..nb).map(|b| 6.0 - b as f64 / 10.0).collect();
    let g = sphere_inward(1.0, 3);
    let area = vertex_areas(&g);
    let total_area: f64 = area.iter().sum();
    let mut zs = Vec::new();
    for (rho, name) in [(&flat, "grey"), (&tilted, "tilted")] {
        for scheduler in [imap::SchedulerKind::Classic, imap::SchedulerKind::Dynamic] {
            for estimator in [imap::Estimator::Photons, imap::Estimator::DEFAULT] {
                let config = Config {
                    threads: 2,
                    seed: 91,
                    bands: bands.clone(),
                    scheduler,
                    ..Default::default()
                };
                let (mut ctx, mesh) = spectral_sphere(config, &g, rho);
                ctx.add_point_light([0.1, 0.0, 0.0], &p1).unwrap();
                ctx.add_point_light([-0.2, 0.1, 0.0], &p2).unwrap();
                let report = ctx
                    .run(&mut imap::RunParams {
                        photons: photons(200_000),
                        progress_interval_s: 1.0,
                        estimator: Some(estimator),
                        ..Default::default()
                    })
                    .unwrap();
                assert_eq!(report.escaped_w, 0.0);
                let mut rel = vec![0.0; g.vertex_count()];
                ctx.rel_error(mesh, 0, &mut rel).unwrap();
                let mut e = vec![0.0; g.vertex_count()];
                for b in 0..nb {
                    ctx.irradiance(mesh, 0, b as u32, &mut e).unwrap();
                    let mean = area_mean(&e, &area);
                    let expected = (p1[b] + p2[b]) / (total_area * (1.0 - rho[b]));
                    // The mean's error: the vertices' errors (independent photons' sums,
                    // correlated between neighbours: twice the independent figure).
                    let var: f64 = e
                        .iter()
                        .zip(&area)
                        .zip(&rel)
                        .map(|((e, a), r)| (e * a * r).powi(2))
                        .sum();
                    let sigma = 2.0 * var.sqrt() / total_area;
                    let z = (mean - expected) / sigma;
                    zs.push(z);
                    assert!(
                        z.abs() < 4.5 && (mean / expected - 1.0).abs() < 0.02,
                        "{name} walls, {scheduler:?}, {estimator:?}, band {b}: mean {mean} vs {expected} ({z:.2} σ)"
                    );
                }
            }
        }
    }
    // Not every band off the same way: the bands' deviations scatter.
    let rms = (zs.iter().map(|z| z * z).sum::<f64>() / zs.len() as f64).sqrt();
    assert!(rms < 2.0, "RMS deviation {rms:.2} σ");
}

/// More light spectra than a spectral map keeps grey sums for (41 bands: at most 10): forty
/// point lights of different spectra, some with dark bands, at the centre of a closed
/// sphere whose albedo varies across the bands. The lights past the cap deposit every band;
/// each band's area-weighted mean irradiance is still Φ_b / (A (1 − ρ_b)), and every
/// vertex holds that value (direct and indirect light are uniform on a sphere with its
/// light at the centre) within its own error and the polyhedron's 2 %: a deposit written to
/// another vertex's sums would show. For photons only and for gathering.
#[test]
fn a_spectral_sphere_holds_every_band_with_forty_light_spectra() {
    let nb = 41;
    let bands = imap::Bands::spectral(nb as u32, 400.0, 700.0).unwrap();
    let g = sphere_inward(1.0, 3);
    let area = vertex_areas(&g);
    let total_area: f64 = area.iter().sum();
    let rho: Vec<f64> = (0..nb).map(|b| 0.2 + 0.3 * (b % 7) as f64 / 7.0).collect();
    for estimator in [imap::Estimator::Photons, imap::Estimator::GATHER] {
        let config = Config {
            threads: 2,
            seed: 3,
            bands: bands.clone(),
            ..Default::default()
        };
        let (mut ctx, mesh) = spectral_sphere(config, &g, &rho);
        let mut phi = vec![0.0; nb];
        for l in 0..40 {
            let p: Vec<f64> = (0..nb)
                .map(|b| {
                    if (b + l) % 5 == 0 {
                        0.0
                    } else {
                        0.1 + ((b * 7 + l * 13) % 11) as f64 / 11.0
                    }
                })
                .collect();
            phi.iter_mut().zip(&p).for_each(|(f, p)| *f += p);
            ctx.add_point_light([0.0, 0.0, 0.0], &p).unwrap();
        }
        ctx.run(&mut imap::RunParams {
            photons: photons(200_000),
            progress_interval_s: 1.0,
            estimator: Some(estimator),
            ..Default::default()
        })
        .unwrap();
        let nv = g.vertex_count();
        let (mut e, mut rel) = (vec![0.0; nv], vec![0.0; nv]);
        ctx.rel_error(mesh, 0, &mut rel).unwrap();
        for b in 0..nb {
            ctx.irradiance(mesh, 0, b as u32, &mut e).unwrap();
            let mean = area_mean(&e, &area);
            let expected = phi[b] / (total_area * (1.0 - rho[b]));
            assert!(
                (mean / expected - 1.0).abs() < 0.02,
                "{estimator:?}, band {b}: mean {mean} vs {expected}"
            );
            for v in 0..nv {
                let dev = (e[v] / expected - 1.0).abs();
                assert!(
                    dev < 0.02 + 5.0 * rel[v],
                    "{estimator:?}, band {b}, vertex {v}: {} vs {expected} (error {:.3})",
                    e[v],
                    rel[v]
                );
            }
        }
    }
}

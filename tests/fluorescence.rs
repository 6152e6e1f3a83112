//! Fluorescent surfaces (spectral runs): a white-lit fluorescent plate in a black box
//! (what it re-emits, per band, against its matrix; the balance to 1e-9 per band), the
//! vertex estimators against photons only, every renderer against the closed form in a
//! furnace of emitting black walls, determinism over threads, and bad input.

mod common;

use common::*;
use imap::{Bands, Config, Estimator, IorModel, MaterialDesc};

/// Bands at 400, 450, …, 650 nm.
fn bands() -> Bands {
    Bands::spectral(6, 400.0, 650.0).unwrap()
}
const NM: [f64; 6] = [400.0, 450.0, 500.0, 550.0, 600.0, 650.0];
const NB: usize = 6;

/// An optical brightener: bands 0 and 1 (400, 450 nm) absorb 0.9 and 0.6, of which a
/// quantum yield of 0.8 is re-emitted over 500–650 nm with photon shares 0.1, 0.4, 0.3,
/// 0.2, each photon's energy scaled by λ_i/λ_j: m_ij = a_i Φ e_j λ_i/λ_j. Reflectance 0.05
/// in the excitation bands, 0.1 elsewhere (the shares plus ρ stay under 1).
fn brightener() -> (Vec<f64>, Vec<f64>) {
    let a = [0.9, 0.6, 0.0, 0.0, 0.0, 0.0];
    let e = [0.0, 0.0, 0.1, 0.4, 0.3, 0.2];
    let q = 0.8;
    let mut m = vec![0.0; NB * NB];
    for i in 0..NB {
        for j in 0..NB {
            m[i * NB + j] = a[i] * q * e[j] * NM[i] / NM[j];
        }
    }
    let rho = vec![0.05, 0.05, 0.1, 0.1, 0.1, 0.1];
    (m, rho)
}

fn fluorescent(ctx: &mut imap::Context) -> u32 {
    let (m, rho) = brightener();
    ctx.add_material(&MaterialDesc {
        diffuse_reflect: rho,
        fluorescence: m,
        ..Default::default()
    })
    .unwrap()
}

/// A black box 1 m wide (inward, recorded, region tallies on), a fluorescent plate on its
/// floor and a spot at its ceiling aimed at the plate's middle. Returns (walls, plate).
fn plate_in_black_box(config: Config) -> (imap::Context, u32, u32) {
    let mut ctx = context(config);
    let black = lambert(&mut ctx, 0.0);
    let fl = fluorescent(&mut ctx);
    let g = cuboid([-0.5, -0.5, 0.0], [0.5, 0.5, 1.0], 4, true);
    let mut d = g.desc(black);
    d.tally = true;
    let walls = ctx.add_mesh(&d).unwrap();
    let p = grid(4, -0.3, 0.3, -0.3, 0.3, 0.001);
    let mut d = p.desc(fl);
    d.tally = true;
    let plate = ctx.add_mesh(&d).unwrap();
    ctx.add_spot_light([0.0, 0.0, 0.95], [0.0, 0.0, -1.0], 0.2, &[1.0; NB])
        .unwrap();
    (ctx, walls, plate)
}

fn spectral(seed: u64, threads: usize) -> Config {
    Config {
        seed,
        threads,
        bands: bands(),
        ..Default::default()
    }
}

#[test]
fn a_white_lit_plate_re_emits_its_matrix_and_the_balance_holds_per_band() {
    let (m, rho) = brightener();
    for estimator in [Estimator::Photons, Estimator::DEFAULT] {
        let (mut ctx, walls, _) = plate_in_black_box(spectral(5, 2));
        let n = photons(200_000);
        let report = run_with(&mut ctx, n, estimator);
        let [emitted, absorbed, escaped, dropped, fluoresced] = &report.band_w;
        // Per band: emitted + fluoresced = absorbed + escaped + dropped, to rounding.
        let total: f64 = emitted.iter().sum();
        for b in 0..NB {
            let off = emitted[b] + fluoresced[b] - absorbed[b] - escaped[b] - dropped[b];
            assert!(off.abs() < 1e-9 * total, "band {b}: off by {off}");
        }
        assert!((report.fluoresced_w - fluoresced.iter().sum::<f64>()).abs() < 1e-9 * total);
        let scalar = report.emitted_w + report.fluoresced_w
            - report.absorbed_w
            - report.escaped_w
            - report.dropped_w;
        assert!(
            scalar.abs() < 1e-9 * total,
            "scalar balance off by {scalar}"
        );
        // All the spot's light lands on the plate (P per band): it re-emits Σ_i P_i m_ij
        // in band j and reflects ρ_j P_j, all of which reaches the black walls.
        let p = emitted[0];
        let want: Vec<f64> = (0..NB)
            .map(|j| (0..NB).map(|i| p * m[i * NB + j]).sum())
            .collect();
        let weighted = estimator != Estimator::Photons;
        for j in 0..NB {
            if weighted {
                // Light sampling weighs the first bounce: the photons' re-emission is the
                // matrix's exactly.
                assert!(
                    (fluoresced[j] - want[j]).abs() <= 1e-9 * p,
                    "band {j}: {} against {}",
                    fluoresced[j],
                    want[j]
                );
            } else {
                assert!(
                    (fluoresced[j] - want[j]).abs() <= 0.02 * p,
                    "band {j}: {} against {}",
                    fluoresced[j],
                    want[j]
                );
            }
        }
        // The quantum yield in photons: Σ_j F_j λ_j = Φ Σ_i a_i P_i λ_i.
        let out: f64 = (0..NB).map(|j| fluoresced[j] * NM[j]).sum();
        let expect = 0.8 * (0.9 * p * NM[0] + 0.6 * p * NM[1]);
        let tol = if weighted { 1e-9 } else { 0.02 };
        assert!(
            (out / expect - 1.0).abs() < tol,
            "photons out {out}, in × Φ {expect}"
        );
        // The walls receive it: their incident flux per band, with its exact error.
        let flux = ctx.region_stats(walls, 0, None).unwrap().flux_w;
        let mut z2 = 0.0;
        for j in 0..NB {
            let expected = want[j] + rho[j] * p;
            let z = (flux[j].value - expected) / flux[j].sigma.max(1e-12 * p);
            eprintln!(
                "{}: band {j} ({} nm) walls receive {:.5} W, expected {expected:.5} ({z:+.2} σ)",
                estimator.name(),
                NM[j],
                flux[j].value
            );
            z2 += z * z / NB as f64;
            assert!(z.abs() < 4.5, "band {j}: {z} σ");
        }
        eprintln!("{}: mean z² {z2:.2}", estimator.name());
    }
}

#[test]
fn the_vertex_estimators_agree_with_photons_only_on_light_a_fluorescent_floor_sends() {
    // A grey room (ρ 0.5) with a fluorescent floor, lit by a spot: the walls' and the
    // ceiling's map from light sampling and from gathering against photons only.
    let room = |estimator: Estimator, seed: u64| {
        let mut ctx = context(spectral(seed, 2));
        let grey = lambert(&mut ctx, 0.5);
        let fl = fluorescent(&mut ctx);
        let g = cuboid([-0.5, -0.5, 0.0], [0.5, 0.5, 1.0], 4, true);
        let walls = ctx.add_mesh(&g.desc(grey)).unwrap();
        let floor = grid(6, -0.5, 0.5, -0.5, 0.5, 0.001);
        ctx.add_mesh(&floor.desc(fl)).unwrap();
        ctx.add_spot_light([0.0, 0.0, 0.95], [0.0, 0.0, -1.0], 0.5, &[1.0; NB])
            .unwrap();
        run_with(&mut ctx, photons(150_000), estimator);
        let nv = ctx.vertex_count(walls).unwrap();
        let mut out = Vec::new();
        for b in [1u32, 3, 5] {
            let (mut e, mut r) = (vec![0.0; nv], vec![0.0; nv]);
            ctx.irradiance(walls, 0, b, &mut e).unwrap();
            ctx.rel_error(walls, 0, &mut r).unwrap();
            out.extend(e.into_iter().zip(r).map(|(e, r)| (e, e * r)));
        }
        out
    };
    let reference = room(Estimator::Photons, 1);
    for (est, name) in [
        (Estimator::DEFAULT, "light sampling"),
        (Estimator::GATHER, "gathering"),
    ] {
        let got = room(est, 2);
        let (mut sum_a, mut sum_b, mut z2, mut n) = (0.0, 0.0, 0.0, 0.0);
        for (a, b) in got.iter().zip(&reference) {
            sum_a += a.0;
            sum_b += b.0;
            // The map's relative error is of the band mean: 3 σ of room per band.
            let s = (a.1 * a.1 + b.1 * b.1).sqrt();
            if s > 0.0 {
                z2 += ((a.0 - b.0) / s).powi(2);
                n += 1.0;
            }
        }
        let ratio = sum_a / sum_b;
        eprintln!(
            "{name}: total {ratio:.4} of photons only, mean z² {:.2}",
            z2 / n
        );
        assert!((ratio - 1.0).abs() < 0.01, "{name}: {ratio}");
        assert!(z2 / n < 3.0, "{name}: mean z² {}", z2 / n);
    }
}

/// A closed box of black walls that emit radiance 1 in every band, a fluorescent plate on
/// its floor: the plate's irradiance is π per band, so its radiance is ρ_j + Σ_i m_ij.
fn fluorescent_furnace(seed: u64, threads: usize) -> imap::Context {
    let mut ctx = context(spectral(seed, threads));
    let black = lambert(&mut ctx, 0.0);
    let fl = fluorescent(&mut ctx);
    let g = cuboid([-0.5, -0.5, 0.0], [0.5, 0.5, 1.0], 4, true);
    ctx.add_mesh(&imap::MeshDesc {
        exitance: Some(&[std::f64::consts::PI]),
        ..g.desc(black)
    })
    .unwrap();
    let p = grid(4, -0.4, 0.4, -0.4, 0.4, 0.001);
    ctx.add_mesh(&p.desc(fl)).unwrap();
    ctx
}

#[test]
fn every_renderer_shows_a_fluorescent_plate_as_the_closed_form() {
    let (m, rho) = brightener();
    let want: Vec<f64> = (0..NB)
        .map(|j| rho[j] + (0..NB).map(|i| m[i * NB + j]).sum::<f64>())
        .collect();
    let cam = imap::CameraDesc {
        position: [0.0, 0.0, 0.6],
        direction: [0.0, 0.0, -1.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 30.0,
        width: 8,
        height: 8,
        projection: imap::Projection::Perspective,
    };
    let pixels = (cam.width * cam.height) as usize;
    // Each band's mean over the pixels against the closed form, within `tol` of it (or of
    // 0.05 for the bands with little light).
    let check = |name: &str, img: &imap::Image, tol: f64| {
        let mut bad = Vec::new();
        for j in 0..NB {
            let mean = (0..pixels).map(|p| img.radiance[p * NB + j]).sum::<f64>() / pixels as f64;
            eprintln!(
                "{name}: band {j} ({} nm) radiance {mean:.4}, closed form {:.4}",
                NM[j], want[j]
            );
            if (mean - want[j]).abs() > tol * want[j].max(0.05) {
                bad.push((j, mean));
            }
        }
        assert!(bad.is_empty(), "{name}: {bad:?} against {want:?}");
    };
    let mut ctx = fluorescent_furnace(3, 2);
    // Each path counts into one pixel band past the plate (chosen by its weights): 1 024
    // paths per pixel put a band's mean within about 1 % (1 σ).
    let img = ctx.path_trace(&cam, 1024, 1000).unwrap();
    check("path tracer", &img, 0.04);
    run_photons_only(&mut ctx, photons(100_000));
    for method in [
        imap::RenderMethod::FinalGather,
        imap::RenderMethod::Synchronous,
    ] {
        let img = render_passes(&mut ctx, &cam, method, 512);
        check(&format!("{method:?}"), &img, 0.05);
    }
    // The plate's irradiance in the map: π in every band (nothing comes back from the
    // black walls).
    let plate = 1;
    let nv = ctx.vertex_count(plate).unwrap();
    for b in 0..NB as u32 {
        let mut e = vec![0.0; nv];
        ctx.irradiance(plate, 0, b, &mut e).unwrap();
        let mean = e.iter().sum::<f64>() / nv as f64;
        assert!(
            (mean / std::f64::consts::PI - 1.0).abs() < 0.03,
            "band {b}: {mean}"
        );
    }
}

#[test]
fn fluorescent_maps_do_not_depend_on_the_thread_count() {
    let map = |threads: usize| {
        let (mut ctx, walls, plate) = plate_in_black_box(spectral(9, threads));
        run_with(&mut ctx, 20_000, Estimator::DEFAULT);
        whole_map(&ctx, &[walls, plate])
    };
    assert_maps_agree(&map(1), &map(2), "1 and 2 threads");
}

#[test]
fn bad_fluorescence_gets_a_status_naming_the_field() {
    let mut ctx = context(spectral(1, 1));
    let (m, rho) = brightener();
    let desc = |m: Vec<f64>| MaterialDesc {
        diffuse_reflect: rho.clone(),
        fluorescence: m,
        ..Default::default()
    };
    let mut upward = m.clone();
    upward[3 * NB + 1] = 0.1; // 550 nm re-emitted at 450 nm
    let mut over = m.clone();
    over[5] += 0.6; // band 0: 0.05 + 0.50 + 0.6 > 1
    let mut negative = m.clone();
    negative[NB + 2] = -0.1;
    let mut nan = m.clone();
    nan[4] = f64::NAN;
    let cases: Vec<(MaterialDesc, imap::ImapStatus, &str)> = vec![
        (
            desc(upward),
            imap::ImapStatus::ImapErrBadMaterial,
            "fluorescence[19] = 0.1 re-emits band 3 (550 nm) in band 1 (450 nm): fluorescence re-emits at longer wavelengths only",
        ),
        (desc(over), imap::ImapStatus::ImapErrBadMaterial, "band 0 (400 nm)"),
        (desc(negative), imap::ImapStatus::ImapErrBadMaterial, "fluorescence[8] = -0.1"),
        (desc(nan), imap::ImapStatus::ImapErrNonFinite, "fluorescence[4]"),
        (desc(m[..35].to_vec()), imap::ImapStatus::ImapErrBadMaterial, "it needs bands × bands = 6 × 6 = 36"),
        (
            MaterialDesc {
                specular_reflect: vec![0.1],
                ..desc(m.clone())
            },
            imap::ImapStatus::ImapErrBadMaterial,
            "a fluorescent surface is a Lambertian reflector",
        ),
        (
            MaterialDesc {
                ior: Some(IorModel::Constant(1.5)),
                diffuse_reflect: vec![],
                ..desc(m.clone())
            },
            imap::ImapStatus::ImapErrBadMaterial,
            "whose medium absorbs nothing",
        ),
        (
            MaterialDesc {
                ior: Some(IorModel::Constant(1.0)),
                diffuse_reflect: vec![],
                absorption_per_m: vec![10.0],
                fluorescence: {
                    let mut m = m.clone();
                    m[5] += 0.6; // band 0 re-emits 0.50 + 0.6 of what it absorbs
                    m
                },
                ..Default::default()
            },
            imap::ImapStatus::ImapErrBadMaterial,
            "the shares of what the medium absorbs that it re-emits (fluorescence[0..6]) add up to",
        ),
        (
            MaterialDesc {
                surface: imap::SurfaceModel::Plastic,
                roughness: [0.2, 0.0],
                ..desc(m.clone())
            },
            imap::ImapStatus::ImapErrBadMaterial,
            "neither a Lambertian reflector nor a dielectric",
        ),
    ];
    for (d, status, words) in cases {
        let e = ctx
            .add_material(&d)
            .expect_err(&format!("refused: {words}"));
        assert_eq!(e.status, status, "{e}");
        assert!(e.to_string().contains(words), "{e}");
    }
    // RGB runs refuse it: no wavelengths to shift between.
    let mut rgb = context(seeded(1));
    let e = rgb
        .add_material(&MaterialDesc {
            diffuse_reflect: vec![0.1],
            fluorescence: vec![0.0; 9],
            ..Default::default()
        })
        .unwrap_err();
    assert_eq!(e.status, imap::ImapStatus::ImapErrUnsupported, "{e}");
    assert!(e.to_string().contains("spectral"), "{e}");
    // A fluorescent medium is a mesh's: the scene's medium refuses it by name.
    let fl = fluorescent_medium(&mut ctx, &[10.0, 10.0, 0.0, 0.0, 0.0, 0.0], &[]);
    let e = ctx.set_scene_medium(Some(fl)).unwrap_err();
    assert_eq!(e.status, imap::ImapStatus::ImapErrUnsupported, "{e}");
    assert!(
        e.to_string()
            .contains(&format!("material = {fl} fluoresces")),
        "{e}"
    );
    // The context stays usable.
    assert!(ctx.add_material(&desc(m)).is_ok());
}

#[test]
fn what_fluoresced_survives_a_resume_bit_for_bit() {
    let run = |ctx: &mut imap::Context, a: u64, b: u64| {
        ctx.run(&mut imap::RunParams {
            selection: imap::Selection::range(a, b),
            estimator: Some(Estimator::Photons),
            progress_interval_s: 1.0,
            ..Default::default()
        })
        .unwrap()
    };
    let n = 20_000;
    let (mut one, _, _) = plate_in_black_box(spectral(4, 2));
    let want = run(&mut one, 0, n).band_w;
    assert!(want[4].iter().sum::<f64>() > 0.0);
    let (mut half, _, _) = plate_in_black_box(spectral(4, 2));
    run(&mut half, 0, n / 2);
    let state = half.state_bytes(0, &[]).unwrap();
    let (mut resumed, _, _) = plate_in_black_box(spectral(4, 2));
    resumed.load_state(&state).unwrap();
    let got = run(&mut resumed, n / 2, n).band_w;
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        for (b, (x, y)) in g.iter().zip(w).enumerate() {
            assert!(
                (x - y).abs() <= 1e-12 * y.abs().max(1e-300),
                "kind {k} band {b}: {x} against {y}"
            );
        }
    }
}

/// The brightener as a medium's matrix: of what the medium absorbs at 400 and 450 nm, the
/// shares 0.9 and 0.6 fluoresce with a quantum yield of 0.8 over 500–650 nm (photon
/// shares 0.1, 0.4, 0.3, 0.2): m_ij = a_i Φ e_j λ_i/λ_j.
fn medium_matrix() -> Vec<f64> {
    brightener().0
}

/// A fluorescent dielectric of index 1 (no Fresnel): absorbing `alpha` per band (1/m) and
/// scattering `sigma_s` (none: empty), re-emitting `medium_matrix`.
fn fluorescent_medium(ctx: &mut imap::Context, alpha: &[f64], sigma_s: &[f64]) -> u32 {
    ctx.add_material(&MaterialDesc {
        ior: Some(IorModel::Constant(1.0)),
        absorption_per_m: alpha.to_vec(),
        scattering_per_m: sigma_s.to_vec(),
        fluorescence: medium_matrix(),
        ..Default::default()
    })
    .unwrap()
}

#[test]
fn a_fluorescent_medium_re_emits_what_it_absorbs_per_band_in_every_estimator() {
    // A 0.2 m cube of index 1 in a black box (recorded, tallied), opaque at 400 and 450 nm
    // (σa 300/m: 60 optical depths) and clear but scattering (σs 5/m) at 500–650 nm, under
    // a spot aimed inside its top face. It absorbs the spot's 400 and 450 nm light whole
    // and re-emits Σ_i P_i m_ij in band j; the walls receive that, the spot's own
    // 500–650 nm light, and nothing at 400 or 450 nm. The balance holds per band to 1e-9.
    let m = medium_matrix();
    for estimator in [Estimator::Photons, Estimator::DEFAULT, Estimator::GATHER] {
        let mut ctx = context(spectral(21, 2));
        let black = lambert(&mut ctx, 0.0);
        let medium = fluorescent_medium(
            &mut ctx,
            &[300.0, 300.0, 0.0, 0.0, 0.0, 0.0],
            &[0.0, 0.0, 5.0, 5.0, 5.0, 5.0],
        );
        let g = cuboid([-0.5, -0.5, 0.0], [0.5, 0.5, 1.0], 4, true);
        let mut d = g.desc(black);
        d.tally = true;
        let walls = ctx.add_mesh(&d).unwrap();
        let cube = cuboid([-0.1, -0.1, 0.2], [0.1, 0.1, 0.4], 2, false);
        let mut d = cube.desc(medium);
        d.record = false;
        let cube = ctx.add_mesh(&d).unwrap();
        ctx.add_spot_light([0.0, 0.0, 0.95], [0.0, 0.0, -1.0], 0.1, &[1.0; NB])
            .unwrap();
        let report = run_with(&mut ctx, photons(200_000), estimator);
        let [emitted, absorbed, escaped, dropped, fluoresced] = &report.band_w;
        let total: f64 = emitted.iter().sum();
        for b in 0..NB {
            let off = emitted[b] + fluoresced[b] - absorbed[b] - escaped[b] - dropped[b];
            assert!(off.abs() < 1e-9 * total, "band {b}: off by {off}");
        }
        let p = emitted[0];
        let want: Vec<f64> = (0..NB)
            .map(|j| (0..NB).map(|i| p * m[i * NB + j]).sum())
            .collect();
        // What the medium re-emitted, per band, and the quantum yield in photons.
        for j in 0..NB {
            assert!(
                (fluoresced[j] - want[j]).abs() <= 0.02 * p,
                "{}: band {j} re-emitted {} against {}",
                estimator.name(),
                fluoresced[j],
                want[j]
            );
        }
        let out: f64 = (0..NB).map(|j| fluoresced[j] * NM[j]).sum();
        let expect = 0.8 * (0.9 * p * NM[0] + 0.6 * p * NM[1]);
        assert!(
            (out / expect - 1.0).abs() < 0.02,
            "photons out {out}, in × Φ {expect}"
        );
        // The medium's own tally: all of 400 and 450 nm (what it re-emits included),
        // nothing else, with its error.
        let a = ctx.medium_absorbed(cube).unwrap();
        for b in 0..NB {
            let expected = if b < 2 { p } else { 0.0 };
            let e = a.band_w[b];
            let z = (e.value - expected) / e.sigma.max(1e-9 * p);
            assert!(
                z.abs() < 4.5,
                "medium band {b}: {} ± {} against {expected}",
                e.value,
                e.sigma
            );
        }
        // The walls: per band, with the map's own error.
        let flux = ctx.region_stats(walls, 0, None).unwrap().flux_w;
        for j in 0..NB {
            let expected = if j < 2 { 0.0 } else { p + want[j] };
            let z = (flux[j].value - expected) / flux[j].sigma.max(1e-9 * p);
            eprintln!(
                "{}: band {j} ({} nm) walls receive {:.5} W, expected {expected:.5} ({z:+.2} σ); re-emitted {:.5} of {:.5}",
                estimator.name(),
                NM[j],
                flux[j].value,
                fluoresced[j],
                want[j]
            );
            assert!(z.abs() < 4.5, "{}: band {j}: {z} σ", estimator.name());
        }
    }
}

/// E₃(τ) = ∫₁^∞ e^(−τ t)/t³ dt (t = 1/μ: ∫₀¹ μ e^(−τ/μ) dμ), by the midpoint rule.
fn e3(tau: f64) -> f64 {
    let n = 200_000;
    (0..n)
        .map(|k| {
            let mu = (k as f64 + 0.5) / n as f64;
            mu * (-tau / mu).exp()
        })
        .sum::<f64>()
        / n as f64
}

#[test]
fn every_renderer_shows_a_fluorescent_slab_in_a_furnace_as_the_closed_form() {
    // A furnace of black walls of radiance 1 in every band around a 2 cm slab of index 1
    // that absorbs 100/m at 400 nm and 50/m at 450 nm (optical depths 2 and 1) and
    // re-emits as `medium_matrix`; clear at 500–650 nm. Seen from above along the normal
    // (θ from it): at 400 and 450 nm the floor's light through it, e^(−τ_i / cos θ); at
    // band j ≥ 2 the floor's 1 plus what the slab re-emits toward the eye. The slab absorbs
    // 2π (1 − 2 E₃(τ_i)) per m² of band i (both faces lit by radiance 1), and re-emits
    // m_ij of it isotropically, seen through 1/cos θ of its depth:
    // L_j = 1 + Σ_i m_ij (1 − 2 E₃(τ_i)) / (2 cos θ).
    let m = medium_matrix();
    let tau = [2.0, 1.0];
    let mut ctx = context(spectral(8, 2));
    let black = lambert(&mut ctx, 0.0);
    let g = cuboid([-1.0, -1.0, -0.5], [1.0, 1.0, 1.0], 4, true);
    ctx.add_mesh(&imap::MeshDesc {
        exitance: Some(&[std::f64::consts::PI]),
        ..g.desc(black)
    })
    .unwrap();
    let medium = fluorescent_medium(&mut ctx, &[100.0, 50.0, 0.0, 0.0, 0.0, 0.0], &[]);
    let slab = cuboid([-0.95, -0.95, -0.01], [0.95, 0.95, 0.01], 4, false);
    let mut d = slab.desc(medium);
    d.record = false;
    ctx.add_mesh(&d).unwrap();
    let cam = imap::CameraDesc {
        position: [0.0, 0.0, 0.5],
        direction: [0.0, 0.0, -1.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 10.0,
        width: 4,
        height: 4,
        projection: imap::Projection::Perspective,
    };
    // The image's mean of f(cos θ) over its plane, which the pixels sample uniformly.
    let mean_over_image = |f: &dyn Fn(f64) -> f64| {
        let h = (cam.fov_y_deg.to_radians() / 2.0).tan();
        let n = 200;
        let mut s = 0.0;
        for a in 0..n {
            for b in 0..n {
                let x = h * (2.0 * (a as f64 + 0.5) / n as f64 - 1.0);
                let y = h * (2.0 * (b as f64 + 0.5) / n as f64 - 1.0);
                s += f(1.0 / (1.0 + x * x + y * y).sqrt());
            }
        }
        s / (n * n) as f64
    };
    let absorbed: Vec<f64> = tau.iter().map(|&t| 1.0 - 2.0 * e3(t)).collect();
    let want: Vec<f64> = (0..NB)
        .map(|j| {
            if j < 2 {
                mean_over_image(&|c| (-tau[j] / c).exp())
            } else {
                let s: f64 = (0..2).map(|i| m[i * NB + j] * absorbed[i]).sum();
                1.0 + s * mean_over_image(&|c| 0.5 / c)
            }
        })
        .collect();
    let pixels = (cam.width * cam.height) as usize;
    let check = |name: &str, img: &imap::Image, tol: f64| {
        let mut bad = Vec::new();
        for j in 0..NB {
            let mean = (0..pixels).map(|p| img.radiance[p * NB + j]).sum::<f64>() / pixels as f64;
            eprintln!(
                "{name}: band {j} ({} nm) radiance {mean:.4}, closed form {:.4} ({:+.2} %)",
                NM[j],
                want[j],
                100.0 * (mean / want[j] - 1.0)
            );
            if (mean - want[j]).abs() > tol * want[j] {
                bad.push((j, mean));
            }
        }
        assert!(bad.is_empty(), "{name}: {bad:?} against {want:?}");
    };
    let img = ctx.path_trace(&cam, 4096, 1000).unwrap();
    check("path tracer", &img, 0.015);
    run_photons_only(&mut ctx, photons(50_000));
    for method in [
        imap::RenderMethod::FinalGather,
        imap::RenderMethod::Synchronous,
    ] {
        let img = render_passes(&mut ctx, &cam, method, 1024);
        check(&format!("{method:?}"), &img, 0.015);
    }
}

#[test]
fn fluorescent_media_give_the_same_map_on_any_thread_count() {
    let map = |threads: usize| {
        let mut ctx = context(spectral(13, threads));
        let grey = lambert(&mut ctx, 0.5);
        let medium = fluorescent_medium(&mut ctx, &[40.0, 20.0, 1.0, 0.0, 0.0, 0.0], &[3.0; NB]);
        let g = cuboid([-0.5, -0.5, 0.0], [0.5, 0.5, 1.0], 3, true);
        let walls = ctx.add_mesh(&g.desc(grey)).unwrap();
        let cube = cuboid([-0.2, -0.2, 0.1], [0.2, 0.2, 0.5], 1, false);
        let mut d = cube.desc(medium);
        d.record = false;
        ctx.add_mesh(&d).unwrap();
        ctx.add_spot_light([0.0, 0.0, 0.95], [0.0, 0.0, -1.0], 0.3, &[1.0; NB])
            .unwrap();
        run_with(&mut ctx, 20_000, Estimator::DEFAULT);
        whole_map(&ctx, &[walls])
    };
    assert_maps_agree(&map(1), &map(2), "1 and 2 threads");
}

#[test]
fn renderers_see_a_scattering_fluorescent_medium_as_the_photons_map_it() {
    // The furnace of radiance 1 with a 2 cm slab that scatters (σs 30/m, g 0.3) and
    // fluoresces (σa 100 and 50/m at 400 and 450 nm), and a white Lambertian plate facing
    // it 0.3 m above. The plate's radiance is its irradiance over π: the photons' map of
    // its middle (forward: the medium re-emits what it absorbs) against the renderers'
    // eye paths (backward: they read re-emitted light through the matrix's transpose).
    let mut ctx = context(spectral(17, 2));
    let black = lambert(&mut ctx, 0.0);
    let white = lambert(&mut ctx, 1.0);
    let g = cuboid([-1.0, -1.0, -0.5], [1.0, 1.0, 1.0], 4, true);
    let mut d = g.desc(black);
    d.record = false;
    ctx.add_mesh(&imap::MeshDesc {
        exitance: Some(&[std::f64::consts::PI]),
        ..d
    })
    .unwrap();
    let medium = fluorescent_medium(&mut ctx, &[100.0, 50.0, 0.0, 0.0, 0.0, 0.0], &[30.0; NB]);
    let slab = cuboid([-0.95, -0.95, -0.01], [0.95, 0.95, 0.01], 4, false);
    let mut d = slab.desc(medium);
    d.record = false;
    ctx.add_mesh(&d).unwrap();
    let plate = grid(20, -0.5, 0.5, -0.5, 0.5, 0.3).flipped();
    let plate_id = ctx.add_mesh(&plate.desc(white)).unwrap();
    let report = run_photons_only(&mut ctx, photons(6_000_000));
    assert!(report.fluoresced_w > 0.0);
    // The camera 0.25 m under the plate looks straight up at the square |x|, |y| ≤ 0.15 of
    // it: the image plane is parallel to the plate, so its pixels sample that square
    // uniformly. The map's mean over the square, per band: its vertices with trapezoid
    // weights (the integral of the map's linear interpolation).
    let nv = ctx.vertex_count(plate_id).unwrap();
    let weight = |v: usize| {
        let p = plate.vertex(v);
        let w = |x: f64| match (x.abs() / 0.05).round() as i32 {
            0..=2 => 1.0,
            3 => 0.5,
            _ => 0.0,
        };
        w(p[0]) * w(p[1])
    };
    let total: f64 = (0..nv).map(weight).sum();
    assert_eq!(total, 36.0);
    let mut map = Vec::new();
    for b in 0..NB as u32 {
        let mut e = vec![0.0; nv];
        ctx.irradiance(plate_id, 0, b, &mut e).unwrap();
        let mean = (0..nv).map(|v| weight(v) * e[v]).sum::<f64>() / total;
        map.push(mean / std::f64::consts::PI);
    }
    let cam = imap::CameraDesc {
        position: [0.0, 0.0, 0.05],
        direction: [0.0, 0.0, 1.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 2.0 * 0.6f64.atan().to_degrees(),
        width: 4,
        height: 4,
        projection: imap::Projection::Perspective,
    };
    let pixels = (cam.width * cam.height) as usize;
    let mean = |img: &imap::Image, j: usize| {
        (0..pixels).map(|p| img.radiance[p * NB + j]).sum::<f64>() / pixels as f64
    };
    let path = ctx.path_trace(&cam, 8192, 1000).unwrap();
    let fg = render_passes(&mut ctx, &cam, imap::RenderMethod::FinalGather, 512);
    // The map's mean is good to about 1.5 % per band at 6 M photons, the renderers' to
    // about 1 %; light re-emitted into bands 2–5 is 6–20 % of what the plate shows there.
    let (mut sum_p, mut sum_f) = (0.0, 0.0);
    for j in 0..NB {
        let (p, f) = (mean(&path, j) / map[j], mean(&fg, j) / map[j]);
        eprintln!(
            "band {j} ({} nm): map {:.4}, path tracer {:+.2} %, final gathering {:+.2} %",
            NM[j],
            map[j],
            100.0 * (p - 1.0),
            100.0 * (f - 1.0)
        );
        assert!(
            (p - 1.0).abs() < 0.05,
            "band {j}: path tracer {p} of the map's"
        );
        assert!(
            (f - 1.0).abs() < 0.05,
            "band {j}: final gathering {f} of the map's"
        );
        sum_p += p / NB as f64;
        sum_f += f / NB as f64;
    }
    eprintln!("over the bands: path tracer {sum_p:.4}, final gathering {sum_f:.4} of the map");
    assert!((sum_p - 1.0).abs() < 0.02 && (sum_f - 1.0).abs() < 0.02);
}

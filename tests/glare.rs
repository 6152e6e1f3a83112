//! Observers and glare (`imap::glare`): the vertical illuminance at an eye against closed
//! forms (a uniform sky, a point source), UGR of a luminaire of known luminance against
//! CIE 117's formula evaluated by hand, and the refusals.

mod common;

use common::*;
use imap::glare::{Observer, SourceKind};
use imap::photometry::Spectrum;
use imap::{Context, Estimator, ImapStatus, Placement, SkyAmount, SkyDesc, SkyKind};
use std::f64::consts::PI;

fn uniform_sky_lx(ctx: &mut Context, horizontal_lx: f64) {
    ctx.add_sky(&SkyDesc {
        kind: SkyKind::Uniform { sphere: false },
        amount: SkyAmount::HorizontalIlluminance(horizontal_lx),
        spectrum: Spectrum::Equal,
        ..SkyDesc::default()
    })
    .unwrap();
}

/// A large black floor at z = 0 (the ground: nothing comes from below).
fn black_floor(ctx: &mut Context) -> u32 {
    let black = lambert(ctx, 0.0);
    ctx.add_mesh(&grid(2, -50.0, 50.0, -50.0, 50.0, 0.0).desc(black))
        .unwrap()
}

/// The observer's Ev and its standard error from its sensor's vertex 0.
fn ev(ctx: &Context, mesh: u32) -> (f64, f64) {
    let (mut e, mut r) = (vec![0.0; 5], vec![0.0; 5]);
    ctx.illuminance(mesh, 0, &mut e).unwrap();
    ctx.rel_error(mesh, 0, &mut r).unwrap();
    (e[0], e[0] * r[0])
}

/// A type C luminaire with I(γ) = `i0` cos γ below its plane (a Lambertian emitter: the
/// same luminance i0 / A from every direction below) and a flat `side` × `side` m luminous
/// opening.
fn lambertian_panel(i0: f64, side: f64) -> String {
    let v: Vec<f64> = (0..=36).map(|k| 5.0 * k as f64).collect();
    let text = ies_text(
        1,
        &v,
        &[0.0],
        |_, g| {
            if g <= 90.0 {
                (i0 * g.to_radians().cos()).max(0.0)
            } else {
                0.0
            }
        },
        1.0,
        1.0,
        None,
    );
    text.replacen(" 2 0 0 0\n", &format!(" 2 {side} {side} 0\n"), 1)
}

/// Adds `lambertian_panel(1000, 0.5)` facing down at `at`; its light id.
fn add_panel(ctx: &mut Context, at: [f64; 3]) -> u32 {
    let place = Placement {
        position: at,
        ..Default::default()
    };
    ctx.add_luminaire_ies(
        &lambertian_panel(1000.0, 0.5),
        None,
        &place,
        &Spectrum::Equal,
    )
    .unwrap()
}

const LOOK_X: Observer = Observer {
    eye: [0.0, 0.0, 1.2],
    view: [1.0, 0.0, 0.0],
    up: [0.0, 0.0, 1.0],
};

#[test]
fn ev_is_pi_l_up_and_half_of_it_on_a_vertical_eye_under_a_uniform_sky() {
    // Light sampling reads the sky at the eye; gathering adds the light its surfaces
    // reflect (none here: the ground is black).
    for (estimator, seed) in [(Estimator::DEFAULT, 1), (Estimator::GATHER, 2)] {
        let mut ctx = context(seeded(seed));
        black_floor(&mut ctx);
        uniform_sky_lx(&mut ctx, 2000.0);
        let up = ctx
            .add_observer_sensor(
                &Observer {
                    view: [0.0, 0.0, 1.0],
                    up: [1.0, 0.0, 0.0],
                    ..LOOK_X
                },
                0.05,
            )
            .unwrap();
        let side = ctx.add_observer_sensor(&LOOK_X, 0.05).unwrap();
        run_with(&mut ctx, photons(400_000), estimator);
        // π L = the horizontal illuminance; a vertical plane sees half the sky.
        for (mesh, want) in [(up, 2000.0), (side, 1000.0)] {
            let (e, s) = ev(&ctx, mesh);
            assert!(s > 0.0 && s < 0.05 * want, "{estimator:?}: σ {s}");
            assert!(
                (e - want).abs() < 4.0 * s,
                "{estimator:?}: Ev {e} ± {s} lx, want {want}"
            );
            let g = ctx
                .observer_glare(
                    &if mesh == up {
                        Observer {
                            view: [0.0, 0.0, 1.0],
                            up: [1.0, 0.0, 0.0],
                            ..LOOK_X
                        }
                    } else {
                        LOOK_X
                    },
                    e,
                    s,
                )
                .unwrap();
            // No luminaire: nothing to rate, and the background is the whole Ev.
            assert!(g.sources.is_empty() && g.ugr_below_10 && g.ugr == 0.0);
            assert!((g.background_cd_m2 - e / PI).abs() < 1e-9 * e);
            assert!((g.dgps - (6.22e-5 * e + 0.184)).abs() < 1e-12);
        }
    }
}

#[test]
fn ev_from_a_point_source_is_i_cos_theta_over_d2() {
    // 1000 lm isotropic: I = 1000 / 4π cd, 2 m away at 40° off the eye's normal. Light
    // sampling reads it at the eye; photons alone need a wider sensor and more of them.
    let lm = 1000.0;
    let a = 40f64.to_radians();
    let at = [2.0 * a.cos(), 2.0 * a.sin(), 1.2];
    let want = lm / (4.0 * PI) * a.cos() / 4.0;
    let mut last = None;
    for (estimator, radius, n) in [
        (Estimator::DEFAULT, 0.02, 100_000),
        (Estimator::Photons, 0.1, 2_000_000),
    ] {
        let mut ctx = context(seeded(5));
        black_floor(&mut ctx);
        let id = ctx
            .add_light_desc(&imap::LightDesc {
                kind: imap::LightKind::Point,
                position: at,
                amount: imap::Amount::Lumens(lm),
                spectrum: Spectrum::Equal,
            })
            .unwrap();
        let mesh = ctx.add_observer_sensor(&LOOK_X, radius).unwrap();
        run_with(&mut ctx, photons(n), estimator);
        let (e, s) = ev(&ctx, mesh);
        assert!(
            (e - want).abs() < 4.0 * s && s < 0.05 * want,
            "{estimator:?}: Ev {e} ± {s}, want {want}"
        );
        last = Some((ctx, id, e, s));
    }
    let (mut ctx, id, e, s) = last.unwrap();
    let g = ctx.observer_glare(&LOOK_X, e, s).unwrap();
    assert_eq!(g.sources.len(), 1);
    let src = g.sources[0];
    assert_eq!(src.kind, SourceKind::Light(id));
    // A point: CIE 147's small source, and the glare's own direct Ev is exact.
    assert!(src.small && src.projected_area_m2 == 0.0);
    assert!((src.ev_lx - want).abs() < 1e-9 * want, "{}", src.ev_lx);
    assert!((src.intensity_cd - lm / (4.0 * PI)).abs() < 1e-9 * lm);
    // Nothing but the source lights the eye: the background is noise about 0.
    assert!(g.background_cd_m2 < 4.0 * s / PI, "{}", g.background_cd_m2);
}

#[test]
fn ugr_of_a_luminaire_of_known_luminance_is_cie_117s_formula() {
    let mut ctx = context(seeded(7));
    black_floor(&mut ctx);
    uniform_sky_lx(&mut ctx, 2000.0);
    // A 0.5 m square Lambertian panel facing down, 1 m above the eye and √3 m ahead: the
    // eye sees it 30° above its line of sight, at 60° from the panel's axis, 2 m away.
    let i0 = 1000.0;
    let id = add_panel(&mut ctx, [3f64.sqrt(), 0.0, 2.2]);
    let mesh = ctx.add_observer_sensor(&LOOK_X, 0.05).unwrap();
    run_with(&mut ctx, photons(300_000), Estimator::DEFAULT);
    let (e, s) = ev(&ctx, mesh);
    // By hand: I = i0 cos 60° = 500 cd toward the eye; the panel shows 0.25 cos 60° =
    // 0.125 m², so L = 4000 cd/m² and ω = 0.125 / 2² sr. Its direct Ev is I cos 30° / 4.
    let (l, omega) = (4.0 * i0, 0.125 / 4.0);
    let direct = 500.0 * 30f64.to_radians().cos() / 4.0;
    // Guth's index straight above the line of sight (τ = 0) at σ = 30°.
    let p = ((35.2 - 1.22) * 1e-3 * 30.0 + 21e-5 * 900.0f64).exp();
    // The sky gives the vertical eye half of its 2000 lx: that is the background.
    let want_ev = 1000.0 + direct;
    assert!(
        (e - want_ev).abs() < 4.0 * s,
        "Ev {e} ± {s}, want {want_ev}"
    );
    let g = ctx.observer_glare(&LOOK_X, e, s).unwrap();
    assert_eq!(g.sources.len(), 1, "{:?}", g.sources);
    let src = g.sources[0];
    assert_eq!(src.kind, SourceKind::Light(id));
    assert!(!src.small && src.visible == 1.0);
    // The table is linear in γ between its 5° angles and 60° is one of them.
    assert!(
        (src.luminance_cd_m2 - l).abs() < 1e-6 * l,
        "{}",
        src.luminance_cd_m2
    );
    assert!(
        (src.solid_angle_sr - omega).abs() < 1e-9,
        "{}",
        src.solid_angle_sr
    );
    assert!(
        (src.position_index - p).abs() < 1e-9,
        "{}",
        src.position_index
    );
    assert!((src.ev_lx - direct).abs() < 1e-6 * direct);
    assert!((g.direct_lx - direct).abs() < 1e-6 * direct);
    let lb = (e - direct) / PI;
    let want = 8.0 * (0.25 / lb * l * l * omega / (p * p)).log10();
    assert!((g.ugr - want).abs() < 1e-9, "UGR {} vs {want}", g.ugr);
    // And against the exact background 1000/π, within its error.
    let exact = 8.0 * (0.25 / (1000.0 / PI) * l * l * omega / (p * p)).log10();
    assert!(
        g.ugr_sigma > 0.0 && (g.ugr - exact).abs() < 4.0 * g.ugr_sigma,
        "UGR {} ± {} vs {exact}",
        g.ugr,
        g.ugr_sigma
    );
    assert!(!g.ugr_below_10 && exact > 10.0);

    // Turned away, the eye sees no source; a wall between hides it.
    let back = Observer {
        view: [-1.0, 0.0, 0.0],
        ..LOOK_X
    };
    let g = ctx.observer_glare(&back, e, s).unwrap();
    assert!(g.sources.is_empty() && g.ugr_below_10);
}

#[test]
fn a_wall_hides_a_luminaire_and_a_half_wall_half_of_it() {
    let mut ctx = context(seeded(8));
    black_floor(&mut ctx);
    let grey = lambert(&mut ctx, 0.0);
    add_panel(&mut ctx, [3.0, 0.0, 2.2]);
    // A two-sided screen at x = 1.5, halfway to the panel, covering y < −0.05. Of the five
    // points of the panel the eye's lines are tested to (its centre, and 0.2 m from it
    // along ±x and ±y), only the one at y = −0.2 crosses the screen's plane behind it
    // (at y = −0.1).
    let screen = quad([
        [1.5, -5.0, 0.0],
        [1.5, -0.05, 0.0],
        [1.5, -0.05, 5.0],
        [1.5, -5.0, 5.0],
    ]);
    ctx.add_mesh(&imap::MeshDesc {
        two_sided: true,
        ..screen.desc(grey)
    })
    .unwrap();
    let g = ctx.observer_glare(&LOOK_X, 500.0, 5.0).unwrap();
    assert_eq!(g.sources.len(), 1);
    let src = g.sources[0];
    assert!((src.visible - 0.8).abs() < 1e-12, "{}", src.visible);
    // The seen share scales its solid angle and direct light, not its luminance.
    assert!((src.luminance_cd_m2 - 4000.0).abs() < 2e-3 * 4000.0);
    let r2: f64 = 9.0 + 1.0;
    let shown = 0.25 * (1.0 / r2.sqrt());
    assert!((src.solid_angle_sr - 0.8 * shown / r2).abs() < 1e-9 * shown);
    // Behind a full wall it is not seen at all.
    let wall = quad([
        [1.0, -5.0, 0.0],
        [1.0, 5.0, 0.0],
        [1.0, 5.0, 5.0],
        [1.0, -5.0, 5.0],
    ]);
    let mut ctx2 = context(seeded(8));
    black_floor(&mut ctx2);
    let grey2 = lambert(&mut ctx2, 0.0);
    add_panel(&mut ctx2, [3.0, 0.0, 2.2]);
    ctx2.add_mesh(&imap::MeshDesc {
        two_sided: true,
        ..wall.desc(grey2)
    })
    .unwrap();
    let g = ctx2.observer_glare(&LOOK_X, 500.0, 5.0).unwrap();
    assert!(g.sources.is_empty() && g.ugr_below_10 && g.direct_lx == 0.0);
}

#[test]
fn an_emitting_mesh_is_a_source_of_its_luminance_and_solid_angle() {
    let mut ctx = context(seeded(9));
    black_floor(&mut ctx);
    uniform_sky_lx(&mut ctx, 2000.0);
    let black = lambert(&mut ctx, 0.0);
    // A 1 m square emitting downward (its normal −z) 1 m above the eye, centred 2 m ahead.
    let panel = quad([
        [1.5, -0.5, 2.2],
        [1.5, 0.5, 2.2],
        [2.5, 0.5, 2.2],
        [2.5, -0.5, 2.2],
    ]);
    // 1000 lm/m² of Lambertian exitance: L = 1000/π cd/m².
    let eff = ctx.photometry().efficacy.clone();
    let exitance = vec![1000.0 / eff.iter().sum::<f64>(); eff.len()];
    let id = ctx
        .add_mesh(&imap::MeshDesc {
            exitance: Some(&exitance),
            ..panel.desc(black)
        })
        .unwrap();
    let g = ctx.observer_glare(&LOOK_X, 1200.0, 10.0).unwrap();
    assert_eq!(g.sources.len(), 1);
    let src = g.sources[0];
    assert_eq!(src.kind, SourceKind::Mesh(id));
    assert!((src.luminance_cd_m2 - 1000.0 / PI).abs() < 1e-9);
    // The solid angle of the square, exactly (two triangles, van Oosterom–Strackee).
    let eye = LOOK_X.eye;
    let c = [
        [1.5, -0.5, 2.2],
        [1.5, 0.5, 2.2],
        [2.5, 0.5, 2.2],
        [2.5, -0.5, 2.2],
    ];
    let want = solid_angle(eye, [c[0], c[1], c[2]]) + solid_angle(eye, [c[0], c[2], c[3]]);
    assert!(
        (src.solid_angle_sr - want).abs() < 0.01 * want,
        "ω {} vs {want}",
        src.solid_angle_sr
    );
    // Its direct Ev: L times the solid angle projected on the eye's plane; by the
    // polygon formula (Lambert's) for the eye's normal +x.
    let e_exact = polygon_irradiance(eye, [1.0, 0.0, 0.0], &c, 1000.0 / PI);
    assert!(
        (src.ev_lx - e_exact).abs() < 0.01 * e_exact,
        "Ev {} vs {e_exact}",
        src.ev_lx
    );
}

#[test]
fn bad_observers_are_refused_by_name() {
    let mut ctx = context(seeded(3));
    black_floor(&mut ctx);
    uniform_sky_lx(&mut ctx, 1000.0);
    let zero = Observer {
        view: [0.0; 3],
        ..LOOK_X
    };
    let e = ctx.add_observer_sensor(&zero, 0.05).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrInvalidArgument);
    assert!(e.message.contains("observer.view"), "{}", e.message);
    let e = ctx.observer_glare(&zero, 100.0, 1.0).unwrap_err();
    assert!(e.message.contains("observer.view"), "{}", e.message);
    let e = ctx.add_observer_sensor(&LOOK_X, 0.0).unwrap_err();
    assert!(e.message.contains("radius"), "{}", e.message);
    let e = ctx.observer_glare(&LOOK_X, -1.0, 1.0).unwrap_err();
    assert!(e.message.contains("ev_lx"), "{}", e.message);
    let e = ctx.observer_glare(&LOOK_X, 1.0, f64::NAN).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrNonFinite);
    // An eye inside a closed box whose normals face out is named (inside a solid, or in a
    // room drawn inside out: the geometry cannot tell), not refused; with the normals in,
    // or from outside, nothing encloses it.
    let grey = lambert(&mut ctx, 0.5);
    let b = cuboid([-1.0, -1.0, 0.5], [1.0, 1.0, 2.0], 1, false);
    let boxed = ctx.add_mesh(&b.desc(grey)).unwrap();
    let g = ctx.observer_glare(&LOOK_X, 100.0, 1.0).unwrap();
    assert_eq!(g.enclosed_by, Some(boxed));
    let out = Observer {
        eye: [5.0, 0.0, 1.2],
        ..LOOK_X
    };
    assert_eq!(
        ctx.observer_glare(&out, 100.0, 1.0).unwrap().enclosed_by,
        None
    );
    let mut inward = context(seeded(3));
    black_floor(&mut inward);
    let grey = lambert(&mut inward, 0.5);
    inward
        .add_mesh(&cuboid([-1.0, -1.0, 0.5], [1.0, 1.0, 2.0], 1, true).desc(grey))
        .unwrap();
    assert_eq!(
        inward
            .observer_glare(&LOOK_X, 100.0, 1.0)
            .unwrap()
            .enclosed_by,
        None
    );
}

#[test]
fn an_observer_changes_no_other_result() {
    // One thread and the classic scheduler add deposits in the same order
    // (tests/results.rs): the grey plane's map is the same bit for bit with or without
    // the observer's sensor, with light sampling and with photons alone.
    for estimator in [Estimator::DEFAULT, Estimator::Photons] {
        let map = |with: bool| {
            let mut ctx = context(imap::Config {
                threads: 1,
                scheduler: imap::SchedulerKind::Classic,
                ..seeded(11)
            });
            black_floor(&mut ctx);
            let grey = lambert(&mut ctx, 0.5);
            let g = grid(8, -2.0, 2.0, -2.0, 2.0, 0.01);
            let id = ctx.add_mesh(&g.desc(grey)).unwrap();
            uniform_sky_lx(&mut ctx, 1000.0);
            if with {
                ctx.add_observer_sensor(&LOOK_X, 0.05).unwrap();
            }
            run_with(&mut ctx, photons(50_000), estimator);
            let mut e = vec![0.0; g.vertex_count()];
            ctx.illuminance(id, 0, &mut e).unwrap();
            e
        };
        let (a, b) = (map(false), map(true));
        assert!(a.iter().any(|x| *x > 0.0));
        assert!(
            a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
            "{estimator:?}"
        );
    }
}

#[test]
fn ugr_errors_are_calibrated_per_observer_at_low_and_high_counts() {
    // The panel of the UGR test over seeds: UGR's stated σ (from the background's) against
    // its spread about the exact value, at 20 000 photons and at ten times more. (Below
    // that, the eye's σ comes from a handful of the estimator's passes and is low: mean z²
    // 5.6 at 5000 photons, 2.1 at 10 000, the map's own per-vertex figure.)
    let (l, omega) = (4000.0, 0.125 / 4.0);
    let p = ((35.2 - 1.22) * 1e-3 * 30.0 + 21e-5 * 900.0f64).exp();
    let exact = 8.0 * (0.25 / (1000.0 / PI) * l * l * omega / (p * p)).log10();
    for n in [20_000, 200_000] {
        let (mut z2, seeds) = (0.0, 16);
        for seed in 0..seeds {
            let mut ctx = context(seeded(100 + seed));
            black_floor(&mut ctx);
            uniform_sky_lx(&mut ctx, 2000.0);
            add_panel(&mut ctx, [3f64.sqrt(), 0.0, 2.2]);
            let mesh = ctx.add_observer_sensor(&LOOK_X, 0.05).unwrap();
            run_with(&mut ctx, photons(n), Estimator::DEFAULT);
            let (e, s) = ev(&ctx, mesh);
            let g = ctx.observer_glare(&LOOK_X, e, s).unwrap();
            z2 += ((g.ugr - exact) / g.ugr_sigma).powi(2);
        }
        let chi2 = z2 / seeds as f64;
        assert!((0.3..2.6).contains(&chi2), "{n} photons: mean z² {chi2}");
    }
}

/// Each spectrum's α-opic daylight efficacy ratios (S, M, L, rhodopic, melanopic).
type Ratios = Vec<(String, [f64; 5])>;

/// luxpy's ratios of tests/data/luxpy_alpha_opic.txt, and LED-B2's spectrum.
fn luxpy_reference() -> (Ratios, Vec<(f64, f64)>) {
    let text = include_str!("data/luxpy_alpha_opic.txt");
    let (mut der, mut led) = (Vec::new(), Vec::new());
    for l in text.lines().filter(|l| !l.starts_with('#')) {
        let w: Vec<&str> = l.split_whitespace().collect();
        match w[0] {
            "der" => {
                let v: Vec<f64> = w[2..7].iter().map(|x| x.parse().unwrap()).collect();
                der.push((w[1].to_string(), [v[0], v[1], v[2], v[3], v[4]]));
            }
            "led_b2" => led.push((w[1].parse().unwrap(), w[2].parse().unwrap())),
            _ => panic!("{l}"),
        }
    }
    (der, led)
}

#[test]
fn melanopic_edi_of_d65_is_its_illuminance_and_of_a_and_an_led_luxpys() {
    let (der, led) = luxpy_reference();
    let cases = [
        ("D65", Spectrum::CieD65, [1.0; 5]),
        ("A", Spectrum::CieA, der[0].1),
        ("LED_B2", Spectrum::Table(led), der[1].1),
    ];
    for (name, spectrum, want) in cases {
        // 81 bands 5 nm apart over 380–780 nm; a uniform sky of 1000 lx of the spectrum over
        // a black ground, an eye looking up: Ev = 1000 lx.
        let mut ctx = context(imap::Config {
            bands: imap::Bands::spectral(81, 380.0, 780.0).unwrap(),
            ..seeded(21)
        });
        black_floor(&mut ctx);
        ctx.add_sky(&SkyDesc {
            kind: SkyKind::Uniform { sphere: false },
            amount: SkyAmount::HorizontalIlluminance(1000.0),
            spectrum,
            ..SkyDesc::default()
        })
        .unwrap();
        let eye = Observer {
            view: [0.0, 0.0, 1.0],
            up: [1.0, 0.0, 0.0],
            ..LOOK_X
        };
        let mesh = ctx.add_observer_sensor(&eye, 0.05).unwrap();
        run_with(&mut ctx, photons(50_000), Estimator::DEFAULT);
        let (ev, s) = ctx.observer_ev(mesh).unwrap();
        assert!((ev - 1000.0).abs() < 4.0 * s, "{name}: Ev {ev} ± {s}");
        let a = ctx.observer_alpha_opic(mesh).unwrap();
        // The ratios do not depend on the noise: one spectrum reaches the eye.
        for (k, w) in want.iter().enumerate() {
            let ratio = a.edi_lx[k] / ev;
            assert!(
                (ratio - w).abs() < 3e-3 * w,
                "{name} {}: EDI/Ev {ratio}, luxpy {w}",
                imap::photometry::alpha_opic::ALPHA_OPIC_NAMES[k],
            );
            assert!((a.edi_sigma_lx[k] / a.edi_lx[k] - s / ev).abs() < 1e-12);
        }
        assert!((a.melanopic_der - a.edi_lx[4] / ev).abs() < 1e-12);
    }
    // An RGB context has no wavelengths: refused, by its own status.
    let mut ctx = context(seeded(2));
    black_floor(&mut ctx);
    uniform_sky_lx(&mut ctx, 1000.0);
    let mesh = ctx.add_observer_sensor(&LOOK_X, 0.05).unwrap();
    run_with(&mut ctx, photons(5_000), Estimator::DEFAULT);
    let e = ctx.observer_alpha_opic(mesh).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrUnsupported);
    assert!(e.message.contains("RGB"), "{}", e.message);
}

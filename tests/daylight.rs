//! Daylight and environment light against analytic answers, with every
//! estimator (photons only, light sampling, gathering):
//! - a uniform sky of radiance L over an open black plane gives E = πL on it, at any scene
//!   scale and position; a uniform sphere lights both sides of a two-sided plane;
//! - a uniform sky through a square roof opening lights the floor of a black room by the
//!   view factor to the opening (Lambert's polygon formula);
//! - CIE standard general skies through the opening (CIE 171:2006 TC 5.9's set-up: the
//!   sky component under an unglazed roof opening): each floor vertex reads the integral of
//!   the sky's luminance over the opening, computed here from the ISO 15469 formula by
//!   quadrature over the opening's area;
//! - the sun's patch on the floor lies where the sun's angles put it and has E = E_n cos θ;
//! - HDR environment files (Radiance RGBE and OpenEXR) read back as the sky they hold.

mod common;

use common::*;
use imap::photometry::Spectrum;
use imap::{Config, Context, Estimator, MeshDesc};
use imap::{SkyAmount, SkyDesc, SkyKind, SunDesc};
use std::f64::consts::PI;

const ESTIMATORS: [Estimator; 3] = [Estimator::Photons, Estimator::DEFAULT, Estimator::GATHER];

/// The sun of an equal-energy spectrum at `azimuth_deg`/`zenith_deg` over a z-up scene,
/// direct normal irradiance `en` W/m² over all bands.
fn equal_sun(azimuth_deg: f64, zenith_deg: f64, en: f64) -> SunDesc {
    SunDesc {
        azimuth_deg,
        zenith_deg,
        amount: SkyAmount::NormalIrradiance(en),
        spectrum: Spectrum::Equal,
        ..SunDesc::default()
    }
}

/// (value, relative error) of every vertex of mesh `id` on `side`, band 0.
fn values(ctx: &Context, id: u32, side: u32) -> Vec<(f64, f64)> {
    let n = ctx.vertex_count(id).unwrap();
    let (mut e, mut r) = (vec![0.0; n], vec![0.0; n]);
    ctx.irradiance(id, side, 0, &mut e).unwrap();
    ctx.rel_error(id, side, &mut r).unwrap();
    e.into_iter().zip(r).collect()
}

/// Asserts each value agrees with `want` (largest |z| < 5, mean |z| near √(2/π) ≈ 0.8:
/// the error estimate is calibrated), skipping vertices where `want` is None.
fn assert_z(got: &[(f64, f64)], want: &[Option<f64>], what: &str) {
    let (mut worst, mut sum, mut k) = (0.0f64, 0.0, 0usize);
    let (mut got_sum, mut want_sum) = (0.0, 0.0);
    let mut at = String::new();
    for ((e, r), w) in got.iter().zip(want) {
        let Some(w) = w else { continue };
        if *w == 0.0 {
            assert_eq!(*e, 0.0, "{what}: a vertex the light cannot reach reads {e}");
            continue;
        }
        let z = (e - w) / (r * e).max(1e-300);
        if z.abs() > worst {
            at = format!("vertex {k}: {e:.5e} ± {:.2e} vs {w:.5e}", r * e);
        }
        worst = worst.max(z.abs());
        sum += z.abs();
        k += 1;
        got_sum += e;
        want_sum += w;
    }
    let mean = sum / k as f64;
    eprintln!(
        "{what}: {k} vertices, largest |z| {worst:.2} ({at}), mean |z| {mean:.2}, Σ got / Σ want {:.5}",
        got_sum / want_sum
    );
    assert!(k > 0, "{what}: nothing compared");
    assert!(worst < 5.0, "{what}: largest |z| {worst}");
    assert!(mean > 0.4 && mean < 1.3, "{what}: mean |z| {mean}");
}

fn uniform_sky(radiance: f64, sphere: bool) -> SkyDesc {
    SkyDesc {
        kind: SkyKind::Uniform { sphere },
        amount: SkyAmount::Radiance(radiance),
        spectrum: Spectrum::Equal,
        ..SkyDesc::default()
    }
}

#[test]
fn a_uniform_sky_gives_pi_l_on_an_open_plane_at_any_scale_and_place() {
    // 3 W/(m² sr) over the three bands, 1 per band: E = π per band.
    let l = 3.0;
    for (unit_m, offset, estimator) in [
        (1.0, [0.0; 3], Estimator::Photons),
        (0.01, [250.0, -40.0, 7.0], Estimator::DEFAULT),
        (1000.0, [0.0, 0.0, -3.0], Estimator::GATHER),
    ] {
        let mut ctx = context(Config {
            unit_m,
            ..seeded(3)
        });
        let black = lambert(&mut ctx, 0.0);
        let g = grid(6, -1.0, 1.0, -1.0, 1.0, 0.0).translated(offset);
        let id = ctx.add_mesh(&g.desc(black)).unwrap();
        ctx.add_sky(&uniform_sky(l, false)).unwrap();
        run_with(&mut ctx, photons(200_000), estimator);
        let want = vec![Some(PI); g.vertex_count()];
        assert_z(
            &values(&ctx, id, 0),
            &want,
            &format!("uniform sky, unit {unit_m} m, {estimator:?}"),
        );
    }
    // A uniform sphere of radiance lights both sides of a two-sided plane.
    let mut ctx = context(seeded(4));
    let black = lambert(&mut ctx, 0.0);
    let g = grid(4, -1.0, 1.0, -1.0, 1.0, 0.0);
    let id = ctx
        .add_mesh(&MeshDesc {
            two_sided: true,
            ..g.desc(black)
        })
        .unwrap();
    ctx.add_sky(&uniform_sky(l, true)).unwrap();
    run_with(&mut ctx, photons(200_000), Estimator::DEFAULT);
    let want = vec![Some(PI); g.vertex_count()];
    for side in 0..2 {
        assert_z(
            &values(&ctx, id, side),
            &want,
            &format!("uniform sphere, side {side}"),
        );
    }
}

/// A closed black room (2 × 2 m, 1 m high) whose roof has a 1 m square opening centred
/// over the floor; the floor (16 × 16 cells) records. Returns the context and the floor.
fn roof_room(seed: u64) -> (Context, u32, Geometry) {
    let mut ctx = context(seeded(seed));
    let black = lambert(&mut ctx, 0.0);
    let floor = grid(16, -1.0, 1.0, -1.0, 1.0, 0.0);
    let id = ctx.add_mesh(&floor.desc(black)).unwrap();
    let h = HEIGHT;
    let parts = [
        // Walls.
        quad([
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, -1.0, h],
            [-1.0, -1.0, h],
        ]),
        quad([
            [-1.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 1.0, h],
            [-1.0, 1.0, h],
        ]),
        quad([
            [-1.0, -1.0, 0.0],
            [-1.0, 1.0, 0.0],
            [-1.0, 1.0, h],
            [-1.0, -1.0, h],
        ]),
        quad([
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 1.0, h],
            [1.0, -1.0, h],
        ]),
        // The roof around the opening [−0.5, 0.5]².
        grid_rect(1, 1, [-1.0, 1.0], [0.5, 1.0], h),
        grid_rect(1, 1, [-1.0, 1.0], [-1.0, -0.5], h),
        grid_rect(1, 1, [-1.0, -0.5], [-0.5, 0.5], h),
        grid_rect(1, 1, [0.5, 1.0], [-0.5, 0.5], h),
    ];
    for p in &parts {
        ctx.add_mesh(&MeshDesc {
            record: false,
            ..p.desc(black)
        })
        .unwrap();
    }
    (ctx, id, floor)
}

const HEIGHT: f64 = 1.0;

/// The roof room with its opening glazed by a clear 2 mm pane of index `n_glass` (no
/// absorption): the context, the floor's id and geometry, and the glass material.
fn glazed_roof_room(seed: u64, n_glass: f64) -> (Context, u32, Geometry, u32) {
    let (mut ctx, id, floor) = roof_room(seed);
    let glass = ctx
        .add_material(&imap::MaterialDesc {
            ior: Some(imap::IorModel::Constant(n_glass)),
            ..Default::default()
        })
        .unwrap();
    let pane = cuboid([-0.5, -0.5, HEIGHT - 0.002], [0.5, 0.5, HEIGHT], 1, false);
    ctx.add_mesh(&MeshDesc {
        record: false,
        ..pane.desc(glass)
    })
    .unwrap();
    (ctx, id, floor, glass)
}

const OPENING: [[f64; 3]; 4] = [
    [-0.5, -0.5, HEIGHT],
    [0.5, -0.5, HEIGHT],
    [0.5, 0.5, HEIGHT],
    [-0.5, 0.5, HEIGHT],
];

#[test]
fn a_uniform_sky_through_a_roof_opening_gives_the_view_factor() {
    for (seed, estimator) in ESTIMATORS.into_iter().enumerate() {
        let (mut ctx, id, floor) = roof_room(10 + seed as u64);
        ctx.add_sky(&uniform_sky(3.0, false)).unwrap();
        run_with(&mut ctx, photons(400_000), estimator);
        // The floor's corners and edges see the opening too; every vertex is compared.
        let want: Vec<Option<f64>> = (0..floor.vertex_count())
            .map(|v| {
                Some(hat_average_with(&floor, v, 12, |x, _| {
                    polygon_irradiance(x, [0.0, 0.0, 1.0], &OPENING, 1.0)
                }))
            })
            .collect();
        assert_z(
            &values(&ctx, id, 0),
            &want,
            &format!("uniform sky through the roof, {estimator:?}"),
        );
    }
}

/// The CIE standard general sky's L/L_z (ISO 15469:2004), written out from the standard:
/// gradation φ(Z) = 1 + a exp(b / cos Z), indicatrix f(χ) = 1 + c (exp(dχ) − exp(dπ/2)) +
/// e cos² χ, L/L_z = f(χ) φ(Z) / (f(Z_s) φ(0)).
fn cie_luminance(abcde: [f64; 5], dir: [f64; 3], sun: [f64; 3]) -> f64 {
    let [a, b, c, d, e] = abcde;
    let cz = dir[2];
    if cz <= 0.0 {
        return 0.0;
    }
    let phi = |cz: f64| 1.0 + a * (b / cz).exp();
    let f =
        |chi: f64| 1.0 + c * ((d * chi).exp() - (d * PI / 2.0).exp()) + e * chi.cos() * chi.cos();
    let chi = dot(dir, sun).clamp(-1.0, 1.0).acos();
    let zs = sun[2].clamp(-1.0, 1.0).acos();
    f(chi) * phi(cz) / (f(zs) * phi(1.0))
}

/// Irradiance at floor point x from the sky seen through the opening: ∫ L(ω) cos θ dω as an
/// integral over the opening's area (cos θ_x cos θ_y / r² dA), n × n midpoints.
fn through_opening(x: [f64; 3], n: usize, l: &dyn Fn([f64; 3]) -> f64) -> f64 {
    let mut s = 0.0;
    let da = 1.0 / (n * n) as f64;
    for i in 0..n {
        for j in 0..n {
            let y = [
                -0.5 + (i as f64 + 0.5) / n as f64,
                -0.5 + (j as f64 + 0.5) / n as f64,
                HEIGHT,
            ];
            let d = sub(y, x);
            let r2 = dot(d, d);
            let r = r2.sqrt();
            let dir = [d[0] / r, d[1] / r, d[2] / r];
            // Both cosines are dir·z: the floor and the opening are horizontal.
            s += l(dir) * dir[2] * dir[2] / r2 * da;
        }
    }
    s
}

#[test]
fn cie_skies_through_a_roof_opening_give_the_sky_integral() {
    // (type, sun azimuth from north toward east, sun zenith angle), degrees; north +y,
    // east +x. Overcast, intermediate and clear skies with the sun to the south-west, low
    // in the east and high.
    let cases = [
        (1u32, 0.0, 45.0, Estimator::DEFAULT),
        (3, 0.0, 45.0, Estimator::Photons),
        (7, 225.0, 35.0, Estimator::DEFAULT),
        (12, 225.0, 35.0, Estimator::GATHER),
        (15, 80.0, 60.0, Estimator::DEFAULT),
    ];
    for (k, &(kind, az, zen, estimator)) in cases.iter().enumerate() {
        let (mut ctx, id, floor) = roof_room(20 + k as u64);
        let lz = 5000.0;
        ctx.add_sky(&SkyDesc {
            kind: SkyKind::Cie {
                kind,
                sun_azimuth_deg: az,
                sun_zenith_deg: zen,
            },
            amount: SkyAmount::Luminance(lz),
            spectrum: Spectrum::Equal,
            ..SkyDesc::default()
        })
        .unwrap();
        run_with(&mut ctx, photons(300_000), estimator);
        let (a, z) = (f64::to_radians(az), f64::to_radians(zen));
        let sun = [z.sin() * a.sin(), z.sin() * a.cos(), z.cos()];
        let abcde = imap::CIE_SKY_PARAMETERS[kind as usize - 1];
        // Luminance per band of an equal-energy spectrum whose luminance is L_z: the
        // context's efficacies give the band radiance.
        let eff: f64 = ctx.photometry().luminous(&[1.0, 1.0, 1.0]);
        let band_radiance = lz / eff;
        let want: Vec<Option<f64>> = (0..floor.vertex_count())
            .map(|v| {
                Some(
                    hat_average_with(&floor, v, 4, |x, _| {
                        through_opening(x, 24, &|d| cie_luminance(abcde, d, sun))
                    }) * band_radiance,
                )
            })
            .collect();
        assert_z(
            &values(&ctx, id, 0),
            &want,
            &format!("CIE sky type {kind}, sun {az}°/{zen}°, {estimator:?}"),
        );
    }
}

/// The Perez all-weather sky's relative luminance (Perez, Seals & Michalsky 1993, eq. 1),
/// written out from the paper: [1 + a exp(b / cos ζ)] [1 + c exp(dγ) + e cos² γ].
fn perez_luminance(abcde: [f64; 5], dir: [f64; 3], sun: [f64; 3]) -> f64 {
    let [a, b, c, d, e] = abcde;
    let cz = dir[2];
    if cz <= 0.0 {
        return 0.0;
    }
    let gamma = dot(dir, sun).clamp(-1.0, 1.0).acos();
    ((1.0 + a * (b / cz).exp()) * (1.0 + c * (d * gamma).exp() + e * gamma.cos().powi(2))).max(0.0)
}

#[test]
fn perez_skies_through_a_roof_opening_give_the_sky_integral() {
    // Hours of weather (direct normal, diffuse horizontal W/m², sun azimuth and zenith
    // angle, day of the year): overcast, intermediate, clear with the sun low in the east.
    let cases = [
        (0.0, 120.0, 200.0, 50.0, 350u32, Estimator::DEFAULT),
        (300.0, 220.0, 225.0, 35.0, 130, Estimator::Photons),
        (850.0, 90.0, 80.0, 60.0, 172, Estimator::GATHER),
    ];
    for (k, &(dni, dhi, az, zen, day, estimator)) in cases.iter().enumerate() {
        let (mut ctx, id, floor) = roof_room(40 + k as u64);
        let s = imap::perez_sky(dni, dhi, zen, day, 2.0).unwrap().unwrap();
        ctx.add_sky(&SkyDesc {
            kind: SkyKind::Perez {
                sun_azimuth_deg: az,
                sun_zenith_deg: zen,
                clearness: s.clearness,
                brightness: s.brightness,
            },
            amount: SkyAmount::HorizontalIlluminance(s.diffuse_horizontal_lx),
            spectrum: Spectrum::Equal,
            ..SkyDesc::default()
        })
        .unwrap();
        run_with(&mut ctx, photons(300_000), estimator);
        let (a, z) = (f64::to_radians(az), f64::to_radians(zen));
        let sun = [z.sin() * a.sin(), z.sin() * a.cos(), z.cos()];
        let abcde = imap::perez_parameters(s.clearness, s.brightness, z);
        // The sky's scale: its horizontal integral ∫ l cos dω by a midpoint rule, and the
        // band radiance of an equal-energy spectrum of E_dh.
        let n = 400;
        let mut h = 0.0;
        for i in 0..n {
            let t = (i as f64 + 0.5) * PI / 2.0 / n as f64;
            for j in 0..2 * n {
                let p = (j as f64 + 0.5) * PI / n as f64;
                let d = [t.sin() * p.sin(), t.sin() * p.cos(), t.cos()];
                h += perez_luminance(abcde, d, sun) * t.cos() * t.sin();
            }
        }
        h *= (PI / 2.0 / n as f64) * (PI / n as f64);
        let eff: f64 = ctx.photometry().luminous(&[1.0, 1.0, 1.0]);
        let band_radiance = s.diffuse_horizontal_lx / eff / h;
        let want: Vec<Option<f64>> = (0..floor.vertex_count())
            .map(|v| {
                Some(
                    hat_average_with(&floor, v, 4, |x, _| {
                        through_opening(x, 24, &|d| perez_luminance(abcde, d, sun))
                    }) * band_radiance,
                )
            })
            .collect();
        assert_z(
            &values(&ctx, id, 0),
            &want,
            &format!("Perez sky {dni}/{dhi} W/m², sun {az}°/{zen}°, {estimator:?}"),
        );
    }
}

#[test]
fn a_sky_of_patches_lights_as_its_patches_and_approaches_its_sky() {
    // CIE sky 12 (clear), the sun at 225°/35°, as a Tregenza and Reinhart MF:2 and MF:4
    // sky vector: each run reads its patches' light through the roof opening; the patch
    // sky's difference from the CIE sky's (its discretisation) shrinks with MF.
    let (az, zen) = (225.0, 35.0);
    let cie = SkyDesc {
        kind: SkyKind::Cie {
            kind: 12,
            sun_azimuth_deg: az,
            sun_zenith_deg: zen,
        },
        amount: SkyAmount::Luminance(5000.0),
        spectrum: Spectrum::Equal,
        ..SkyDesc::default()
    };
    let (a, z) = (f64::to_radians(az), f64::to_radians(zen));
    let sun = [z.sin() * a.sin(), z.sin() * a.cos(), z.cos()];
    let abcde = imap::CIE_SKY_PARAMETERS[11];
    let mut worst_before = f64::INFINITY;
    for (k, mf) in [1u32, 2, 4].into_iter().enumerate() {
        let (mut ctx, id, floor) = roof_room(60 + k as u64);
        let bands = imap::Bands::rgb();
        let vector = imap::sky_patch_radiance(&cie, &bands, mf).unwrap();
        let eff: f64 = ctx.photometry().luminous(&[1.0, 1.0, 1.0]);
        // Equal-energy bands: every band holds the same radiance; as luminance, cd/m².
        let lum: Vec<f64> = vector.iter().map(|v| v[0] * eff).collect();
        ctx.add_sky(&SkyDesc {
            kind: SkyKind::Patches {
                mf,
                values: std::sync::Arc::new(lum.clone()),
            },
            amount: SkyAmount::Luminance(1.0),
            spectrum: Spectrum::Equal,
            ..SkyDesc::default()
        })
        .unwrap();
        run_with(&mut ctx, photons(300_000), Estimator::DEFAULT);
        let patches = imap::SkyPatches::reinhart(mf).unwrap();
        let patch_l = |d: [f64; 3]| {
            let alt = d[2].clamp(-1.0, 1.0).asin();
            lum[patches.patch(alt, d[0].atan2(d[1]))] / 5000.0
        };
        let band = 5000.0 / eff;
        let want: Vec<Option<f64>> = (0..floor.vertex_count())
            .map(|v| {
                Some(hat_average_with(&floor, v, 4, |x, _| through_opening(x, 24, &patch_l)) * band)
            })
            .collect();
        assert_z(
            &values(&ctx, id, 0),
            &want,
            &format!("CIE 12 as MF:{mf} patches"),
        );
        // The discretisation: the patch sky against the CIE sky at every floor vertex.
        let mut worst: f64 = 0.0;
        for (v, w) in want.iter().enumerate() {
            let exact = hat_average_with(&floor, v, 4, |x, _| {
                through_opening(x, 24, &|d| cie_luminance(abcde, d, sun))
            }) * band;
            if exact > 0.05 * band {
                worst = worst.max((w.unwrap() / exact - 1.0).abs());
            }
        }
        eprintln!("MF:{mf}: worst lit vertex {:.2} %", 100.0 * worst);
        assert!(worst < worst_before, "MF:{mf}: {worst}");
        worst_before = worst;
    }
}

/// A sky lit over one Tregenza patch (unit relative radiance, 1 cd/m² of equal energy).
fn one_patch(p: usize) -> SkyDesc {
    SkyDesc {
        kind: SkyKind::single_patch(1, p).unwrap(),
        amount: SkyAmount::Luminance(1.0),
        spectrum: Spectrum::Equal,
        ..SkyDesc::default()
    }
}

/// Band 0 of a layer of the floor: (values, standard errors).
fn layer_band0(ctx: &Context, id: u32, layer: imap::Layer) -> (Vec<f64>, Vec<f64>) {
    let nv = ctx.vertex_count(id).unwrap();
    let (mut e, mut rel) = (vec![0.0; nv], vec![0.0; nv]);
    ctx.irradiance_layer(id, 0, 0, layer, &mut e).unwrap();
    ctx.rel_error_layer(id, 0, layer, &mut rel).unwrap();
    let sigma = e.iter().zip(&rel).map(|(e, r)| e * r).collect();
    (e, sigma)
}

#[test]
fn tregenza_patch_layers_are_their_skies_coefficients_with_errors() {
    // Each of the 145 Tregenza patches a sky of its own in its own light group: one run
    // keeps every patch's layer (the daylight coefficients, lx per cd/m², with errors).
    let (mut ctx, id, floor) = roof_room(70);
    ctx.set_layers(imap::LayerRequest {
        groups: true,
        direct: false,
    })
    .unwrap();
    for p in 1..146 {
        let light = ctx.add_sky(&one_patch(p)).unwrap();
        ctx.set_light_group(light, p as u32).unwrap();
    }
    run_with(&mut ctx, photons(3_000_000), Estimator::DEFAULT);
    // A patch's layer is the run of its sky alone (the cap, and a patch 66° high to the
    // south-east), vertex by vertex within the two runs' errors.
    for (k, p) in [145usize, 130].into_iter().enumerate() {
        let (mut alone, aid, _) = roof_room(71 + k as u64);
        alone.add_sky(&one_patch(p)).unwrap();
        run_with(&mut alone, photons(400_000), Estimator::DEFAULT);
        let (a, sa) = layer_band0(&ctx, id, imap::Layer::Group(p as u32));
        let (b, sb) = layer_band0(&alone, aid, imap::Layer::Combined);
        let (mut worst, mut sum, mut n) = (0.0f64, 0.0, 0);
        for v in 0..a.len() {
            // Where either run saw a handful of photons its σ means little (the penumbra
            // of the opening's edge, a few per cent of the light): compared where both
            // stated errors are within 30 %.
            if !(sa[v] <= 0.3 * a[v] && sb[v] <= 0.3 * b[v] && a[v] > 0.0) {
                continue;
            }
            let z = (a[v] - b[v]) / (sa[v] * sa[v] + sb[v] * sb[v]).sqrt().max(1e-300);
            worst = worst.max(z.abs());
            sum += z.abs();
            n += 1;
        }
        eprintln!(
            "patch {p}: {n} vertices, largest |z| {worst:.2}, mean |z| {:.2}",
            sum / n as f64
        );
        assert!(
            n > 50 && worst < 5.0 && (0.4..1.3).contains(&(sum / n as f64)),
            "patch {p}"
        );
    }
    // A sky vector times the layers is the sky of those patches, per vertex within the
    // errors combined as independent (σ² = Σ v_p² σ_p²): CIE sky 12 as Tregenza patches.
    let cie = SkyDesc {
        kind: SkyKind::Cie {
            kind: 12,
            sun_azimuth_deg: 225.0,
            sun_zenith_deg: 35.0,
        },
        amount: SkyAmount::Luminance(5000.0),
        spectrum: Spectrum::Equal,
        ..SkyDesc::default()
    };
    let vector = imap::sky_patch_radiance(&cie, &imap::Bands::rgb(), 1).unwrap();
    let eff: f64 = ctx.photometry().luminous(&[1.0, 1.0, 1.0]);
    let lum: Vec<f64> = vector.iter().map(|v| v[0] * eff).collect();
    let nv = floor.vertex_count();
    let (mut e, mut var) = (vec![0.0; nv], vec![0.0; nv]);
    for (p, l) in lum.iter().enumerate().skip(1) {
        let (x, s) = layer_band0(&ctx, id, imap::Layer::Group(p as u32));
        for v in 0..nv {
            e[v] += l * x[v];
            var[v] += (l * s[v]).powi(2);
        }
    }
    let got: Vec<(f64, f64)> = e
        .iter()
        .zip(&var)
        .map(|(e, v)| (*e, if *e > 0.0 { v.sqrt() / e } else { 0.0 }))
        .collect();
    let patches = imap::SkyPatches::reinhart(1).unwrap();
    let patch_l = |d: [f64; 3]| lum[patches.patch(d[2].clamp(-1.0, 1.0).asin(), d[0].atan2(d[1]))];
    let band = 1.0 / eff;
    let want: Vec<Option<f64>> = (0..nv)
        .map(|v| {
            Some(hat_average_with(&floor, v, 4, |x, _| through_opening(x, 24, &patch_l)) * band)
        })
        .collect();
    assert_z(&got, &want, "CIE 12 from the Tregenza layers");

    // The same layers as annual coefficients (lx per cd/m²: the equal-energy bands' band-0
    // irradiance times the luminous efficacy), under two hours of weather: the hourly
    // illuminance is the hour's sky vector read through the opening, with its error.
    let mut value = vec![0.0; nv * 146];
    let mut sigma = vec![0.0; nv * 146];
    for p in 1..146 {
        let (x, s) = layer_band0(&ctx, id, imap::Layer::Group(p as u32));
        for v in 0..nv {
            value[v * 146 + p] = x[v] * eff;
            sigma[v * 146 + p] = s[v] * eff;
        }
    }
    let coefficients = imap::annual::Coefficients {
        sensors: nv,
        patches: 146,
        value,
        sigma,
    };
    let weather = imap::weather::parse_wea(
        "place t\nlatitude 48\nlongitude -11\ntime_zone -15\nsite_elevation 0\n\
         weather_data_file_units 1\n6 21 12.5 700 120\n10 3 15.5 150 180\n",
        "t.wea",
    )
    .unwrap();
    let sky =
        imap::annual::AnnualSky::from_weather(&weather, 1, imap::annual::SunInVectors::Left, 0.0)
            .unwrap();
    let (e, s) = imap::annual::hourly(&coefficients, &sky, None).unwrap();
    for h in 0..2 {
        let v = sky.vector(h);
        let got: Vec<(f64, f64)> = (0..nv)
            .map(|k| {
                let (x, sx) = (e[h * nv + k], s[h * nv + k]);
                (x, if x > 0.0 { sx / x } else { 0.0 })
            })
            .collect();
        let l = |d: [f64; 3]| v[patches.patch(d[2].clamp(-1.0, 1.0).asin(), d[0].atan2(d[1]))];
        let want: Vec<Option<f64>> = (0..nv)
            .map(|k| {
                Some(hat_average_with(&floor, k, 4, |x, _| {
                    through_opening(x, 24, &l)
                }))
            })
            .collect();
        assert_z(
            &got,
            &want,
            &format!("hour {h} of the weather from the Tregenza layers"),
        );
    }
}

/// What each floor vertex of the roof room reads under the sun's patch (the opening moved
/// by `shift`): `e_band` where its support (0.125 m) lies wholly inside, nothing where
/// wholly outside; the penumbra's vertices are not compared (None).
fn sun_patch(floor: &Geometry, shift: [f64; 2], e_band: f64) -> Vec<Option<f64>> {
    (0..floor.vertex_count())
        .map(|v| {
            let p = floor.vertex(v);
            let d = (p[0] - shift[0]).abs().max((p[1] - shift[1]).abs());
            if d < 0.5 - 0.125 - 0.01 {
                Some(e_band)
            } else if d > 0.5 + 0.125 + 0.01 {
                Some(0.0)
            } else {
                None
            }
        })
        .collect()
}

#[test]
fn the_sun_patch_lies_where_the_sun_puts_it_with_en_cos_theta() {
    // The sun at azimuth 200° (south-south-west), zenith 20°, E_n = 900 W/m² over the
    // bands. Its patch: the opening moved by 1 m · tan 20° away from the sun (wholly on
    // the floor).
    let (az, zen) = (200f64.to_radians(), 20f64.to_radians());
    let toward = [zen.sin() * az.sin(), zen.sin() * az.cos(), zen.cos()];
    let shift = [
        -HEIGHT * toward[0] / toward[2],
        -HEIGHT * toward[1] / toward[2],
    ];
    let en = 900.0;
    for (seed, estimator) in ESTIMATORS.into_iter().enumerate() {
        let (mut ctx, id, floor) = roof_room(30 + seed as u64);
        ctx.add_sun(&equal_sun(200.0, 20.0, en)).unwrap();
        run_with(&mut ctx, photons(200_000), estimator);
        // A vertex's support reaches 0.125 m; the penumbra is 1 m · tan 0.265° / cos 20°
        // ≈ 0.5 cm wide: vertices whose support is wholly inside the patch read
        // E_n cos θ / 3 per band, wholly outside nothing; the rest are not compared.
        let e_band = en * zen.cos() / 3.0;
        let want = sun_patch(&floor, shift, e_band);
        assert!(want.iter().filter(|w| **w == Some(e_band)).count() >= 16);
        assert_z(
            &values(&ctx, id, 0),
            &want,
            &format!("sun patch, {estimator:?}"),
        );
        // Everything the patch holds: its flux is E_n cos θ × 1 m² (the hat averages over
        // the floor add up to it).
        let got = values(&ctx, id, 0);
        let areas = vertex_areas(&floor);
        let flux: f64 = got.iter().zip(&areas).map(|((e, _), a)| e * a).sum();
        assert!(
            (flux / e_band - 1.0).abs() < 0.02,
            "{estimator:?}: patch flux {flux} vs {e_band}"
        );
    }
}

#[test]
fn hdr_environment_files_read_back_as_the_sky_they_hold() {
    // An equirectangular image bright (2, 1, 0.5) above the horizon, black below: a
    // uniform coloured sky. Written as Radiance RGBE and as OpenEXR, loaded through the
    // file reader, it lights an open plane with E = π × (2, 1, 0.5) × scale.
    let (w, h) = (64u32, 32u32);
    let mut rgb = Vec::with_capacity((w * h * 3) as usize);
    for y in 0..h {
        for _ in 0..w {
            let c = if y < h / 2 {
                [2.0f32, 1.0, 0.5]
            } else {
                [0.0; 3]
            };
            rgb.extend(c);
        }
    }
    let dir = tempdir();
    let img = image::Rgb32FImage::from_raw(w, h, rgb.clone()).unwrap();
    let hdr = dir.join("sky.hdr");
    let exr = dir.join("sky.exr");
    image::DynamicImage::ImageRgb32F(img.clone())
        .save_with_format(&hdr, image::ImageFormat::Hdr)
        .unwrap();
    image::DynamicImage::ImageRgb32F(img)
        .save_with_format(&exr, image::ImageFormat::OpenExr)
        .unwrap();
    for (k, path) in [hdr, exr].iter().enumerate() {
        let mut ctx = context(seeded(40 + k as u64));
        let black = lambert(&mut ctx, 0.0);
        let g = grid(4, -1.0, 1.0, -1.0, 1.0, 0.0);
        let id = ctx.add_mesh(&g.desc(black)).unwrap();
        ctx.add_sky_file(
            path,
            &SkyDesc {
                amount: SkyAmount::Scale(1.5),
                rotation_deg: 77.0,
                ..SkyDesc::default()
            },
        )
        .unwrap();
        run_with(
            &mut ctx,
            photons(400_000),
            [Estimator::DEFAULT, Estimator::GATHER][k],
        );
        let n = g.vertex_count();
        // Each band's light comes from its own channel's photons and light samples, so a
        // vertex's error (of the bands' sum) is checked on the sum; each band's total
        // over the plane within 1.5 %.
        let mut total = vec![0.0; n];
        for (band, c) in [2.0, 1.0, 0.5].into_iter().enumerate() {
            let mut e = vec![0.0; n];
            ctx.irradiance(id, 0, band as u32, &mut e).unwrap();
            let mean = e.iter().sum::<f64>() / n as f64;
            // RGBE keeps 8 bits of mantissa: 2, 1 and 0.5 are exact in it.
            let want = PI * c * 1.5;
            eprintln!(
                "{} band {band}: mean {mean:.4} vs {want:.4}",
                path.display()
            );
            assert!(
                (mean / want - 1.0).abs() < 0.015,
                "{}: band {band}",
                path.display()
            );
            total.iter_mut().zip(&e).for_each(|(t, x)| *t += x);
        }
        let mut r = vec![0.0; n];
        ctx.rel_error(id, 0, &mut r).unwrap();
        let got: Vec<(f64, f64)> = total.into_iter().zip(r).collect();
        let want = vec![Some(PI * 3.5 * 1.5); n];
        assert_z(&got, &want, &format!("{} all bands", path.display()));
    }
    // An image past the memory budget is refused before it is copied, naming it; the
    // context is unchanged.
    let mut small = context(Config {
        memory_budget: 8 << 20,
        ..seeded(1)
    });
    let big = SkyDesc {
        kind: SkyKind::Image {
            width: 1024,
            height: 512,
            rgb: std::sync::Arc::new(vec![1.0; 1024 * 512 * 3]),
        },
        amount: SkyAmount::Scale(1.0),
        ..SkyDesc::default()
    };
    let e = small.add_sky(&big).unwrap_err();
    assert_eq!(e.status, imap::ImapStatus::ImapErrMemoryBudget, "{e}");
    assert!(e.to_string().contains("1024 × 512"), "{e}");
    assert!(small.light_count() == 0);
    // A file that is not an environment image is refused naming it.
    let mut ctx = context(seeded(1));
    let bogus = dir.join("sky.txt");
    std::fs::write(&bogus, "not an image").unwrap();
    let e = ctx.add_sky_file(&bogus, &SkyDesc::default()).unwrap_err();
    assert!(e.to_string().contains("sky.txt"), "{e}");
    let e = ctx
        .add_sky_file(&dir.join("missing.hdr"), &SkyDesc::default())
        .unwrap_err();
    assert_eq!(e.status, imap::ImapStatus::ImapErrIo, "{e}");
}

/// A fresh directory under the target's temporary folder.
fn tempdir() -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("imap-daylight-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn distant_light_keeps_its_energy_balance_and_light_groups() {
    // Sky + sun in a black room: every photon is absorbed or escapes; the report's
    // emitted flux is π R² ∫ L dω of each through the bounding sphere, and the two lights'
    // groups add up to the map.
    let (mut ctx, id, _) = roof_room(50);
    let sky = ctx.add_sky(&uniform_sky(3.0, false)).unwrap();
    let sun = ctx.add_sun(&equal_sun(180.0, 10.0, 300.0)).unwrap();
    // Reported "flux": the horizontal irradiance each gives an open plane.
    let (w, _) = ctx.light_flux(sky).unwrap();
    assert!((w.iter().sum::<f64>() - 3.0 * PI).abs() < 1e-9, "{w:?}");
    let (w, _) = ctx.light_flux(sun).unwrap();
    assert!((w.iter().sum::<f64>() - 300.0 * 10f64.to_radians().cos()).abs() < 1e-9);
    ctx.set_light_group(sun, 1).unwrap();
    ctx.set_layers(imap::LayerRequest {
        groups: true,
        direct: false,
    })
    .unwrap();
    let report = run_with(&mut ctx, photons(100_000), Estimator::DEFAULT);
    let b = &report;
    let total = b.absorbed_w + b.escaped_w + b.dropped_w;
    assert!(
        (total / b.emitted_w - 1.0).abs() < 1e-9,
        "emitted {} vs absorbed {} + escaped {} + dropped {}",
        b.emitted_w,
        b.absorbed_w,
        b.escaped_w,
        b.dropped_w
    );
    let n = ctx.vertex_count(id).unwrap();
    let mut all = vec![0.0; n];
    ctx.irradiance(id, 0, 0, &mut all).unwrap();
    let mut sum = vec![0.0; n];
    for g in 0..2 {
        let mut e = vec![0.0; n];
        ctx.irradiance_layer(id, 0, 0, imap::Layer::Group(g), &mut e)
            .unwrap();
        sum.iter_mut().zip(&e).for_each(|(s, x)| *s += x);
    }
    for (a, s) in all.iter().zip(&sum) {
        assert!((a - s).abs() <= 1e-9 * a.abs().max(1e-12), "{a} vs {s}");
    }
}

#[test]
fn the_renderer_sees_the_sky_and_a_floor_lit_by_it_and_the_sun() {
    // An open grey floor (ρ = 0.5) under a uniform sky of 1 W/(m² sr) per band and the sun
    // at 40° (E_n = 3 W/m² per band): every floor pixel shows ρ (π L + E_n cos 40°) / π;
    // a camera looking up shows the sky's L itself in every pixel.
    use imap::{CameraDesc, RenderMethod, RenderParams};
    let mut ctx = context(seeded(60));
    let rho = 0.5;
    let grey = lambert(&mut ctx, rho);
    ctx.add_mesh(&grid(8, -4.0, 4.0, -4.0, 4.0, 0.0).desc(grey))
        .unwrap();
    ctx.add_sky(&uniform_sky(3.0, false)).unwrap();
    ctx.add_sun(&equal_sun(30.0, 40.0, 9.0)).unwrap();
    let mut params = RenderParams {
        method: RenderMethod::Synchronous,
        passes: 64,
        progress_interval_s: 0.05,
        max_path_events: 10_000,
        ..Default::default()
    };
    let cam = |z: f64, dz: f64| CameraDesc {
        position: [0.0, 0.0, z],
        direction: [0.0, 0.0, dz],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 60.0,
        width: 32,
        height: 32,
        projection: imap::Projection::Perspective,
    };
    let want = rho * (PI + 3.0 * 40f64.to_radians().cos()) / PI;
    let (img, _) = ctx.render(&cam(3.0, -1.0), &mut params).unwrap();
    let nb = img.bands;
    let (mut dev, mut est) = (0.0f64, 0.0f64);
    for p in 0..(32 * 32) {
        let v = img.radiance[p * nb..][..nb].iter().sum::<f64>() / nb as f64;
        dev += ((v - want) / want).powi(2);
        est += img.rel_error[p].powi(2);
    }
    let (dev, est) = ((dev / 1024.0).sqrt(), (est / 1024.0).sqrt());
    eprintln!("floor under sky and sun: rms deviation {dev:.2e}, estimated {est:.2e}");
    assert!(est < 0.05 && dev < 1.5 * est + 1e-3, "{dev} vs {est}");
    let (img, _) = ctx.render(&cam(1.0, 1.0), &mut params).unwrap();
    for p in 0..(32 * 32) {
        for b in 0..nb {
            let v = img.radiance[p * nb + b];
            assert!((v - 1.0).abs() < 1e-9, "sky pixel {p} band {b}: {v}");
        }
    }
}

/// Fresnel reflectances (s, p) from air into glass of index `n` at incidence cos `c`.
fn fresnel_sp(c: f64, n: f64) -> (f64, f64) {
    let s = (1.0 - c * c).sqrt();
    let ct = (1.0 - (s / n).powi(2)).sqrt();
    let rs = ((c - n * ct) / (c + n * ct)).powi(2);
    let rp = ((ct - n * c) / (ct + n * c)).powi(2);
    (rs, rp)
}

#[test]
fn a_glazed_roof_opening_passes_the_sky_by_the_glass_transmittance() {
    // CIE 171:2006 TC 5.10's set-up: the roof opening of the room above glazed with a clear
    // 2 mm pane (n = 1.52, no absorption), under CIE sky type 1. Each floor vertex under
    // the opening reads the sky integral of the unglazed test with each direction weighted
    // by the pane's transmittance, multiple reflections included and polarisation
    // resolved: T = ½ [(1 − R_s)/(1 + R_s) + (1 − R_p)/(1 + R_p)] at the incidence angle
    // (the pane's faces are parallel, so light leaves it along the direction it came).
    // Light through glass is the photons' with every estimator.
    let n_glass = 1.52;
    let (mut ctx, id, floor, _) = glazed_roof_room(70, n_glass);
    let lz = 5000.0;
    ctx.add_sky(&SkyDesc {
        kind: SkyKind::Cie {
            kind: 1,
            sun_azimuth_deg: 180.0,
            sun_zenith_deg: 45.0,
        },
        amount: SkyAmount::Luminance(lz),
        spectrum: Spectrum::Equal,
        ..SkyDesc::default()
    })
    .unwrap();
    run_with(&mut ctx, photons(1_500_000), Estimator::DEFAULT);
    let sun = [0.0, -(45f64.to_radians().sin()), 45f64.to_radians().cos()];
    let abcde = imap::CIE_SKY_PARAMETERS[0];
    let band_radiance = lz / ctx.photometry().luminous(&[1.0, 1.0, 1.0]);
    let transmit = |d: [f64; 3]| {
        let (rs, rp) = fresnel_sp(d[2], n_glass);
        0.5 * ((1.0 - rs) / (1.0 + rs) + (1.0 - rp) / (1.0 + rp))
    };
    // The vertices under the opening and a cell around it.
    let want: Vec<Option<f64>> = (0..floor.vertex_count())
        .map(|v| {
            let p = floor.vertex(v);
            (p[0].abs() <= 0.625 && p[1].abs() <= 0.625).then(|| {
                hat_average_with(&floor, v, 4, |x, _| {
                    through_opening(x, 24, &|d| cie_luminance(abcde, d, sun) * transmit(d))
                }) * band_radiance
            })
        })
        .collect();
    assert_z(
        &values(&ctx, id, 0),
        &want,
        "glazed roof opening, CIE sky 1",
    );
    // The pane's share: against the unglazed sky component it passes 91–92 % here.
    let got = values(&ctx, id, 0);
    let (mut glazed, mut open) = (0.0, 0.0);
    for (v, w) in want.iter().enumerate() {
        if w.is_some() {
            glazed += got[v].0;
            let x = floor.vertex(v);
            open += through_opening(x, 24, &|d| cie_luminance(abcde, d, sun)) * band_radiance;
        }
    }
    eprintln!(
        "glazed / open sky component under the opening: {:.4}",
        glazed / open
    );
    assert!((0.88..0.93).contains(&(glazed / open)), "{}", glazed / open);
}

#[test]
fn a_cie_sky_without_its_sun_is_refused_unless_its_type_ignores_the_sun() {
    // No sun (NaN angles, the C default): types 1, 3 and 5 have a flat indicatrix and do not
    // depend on it; every other type is refused, as the command refuses it (a sun placed
    // by default would light the model from a direction nobody chose).
    for kind in 1..=15u32 {
        let (mut ctx, _, _) = roof_room(1);
        let r = ctx.add_sky(&SkyDesc {
            kind: SkyKind::Cie {
                kind,
                sun_azimuth_deg: f64::NAN,
                sun_zenith_deg: f64::NAN,
            },
            amount: SkyAmount::Luminance(5000.0),
            ..SkyDesc::default()
        });
        match kind {
            1 | 3 | 5 => assert!(r.is_ok(), "type {kind}: {r:?}"),
            _ => {
                let e = r.unwrap_err();
                assert_eq!(e.status, imap::ImapStatus::ImapErrInvalidArgument);
                assert!(e.message.contains("needs its sun"), "{}", e.message);
            }
        }
    }
}

/// The ground's glow (Radiance's ground glow): below the horizon a uniform
/// radiance ρ E_h / π, E_h the horizontal irradiance of the sky and the sun. Under a
/// uniform sky of 1 W/(m² sr) per band and the sun at 40° (E_n 3 W/m² per band), ρ 0.2:
/// an open two-sided plane reads E_h on top and ρ E_h below; a vertical plane facing −y,
/// the sun (azimuth 30°, toward +y) behind it, reads half the sky and half the ground,
/// π/2 + ρ E_h/2; with every estimator. A camera looking down at nothing sees ρ E_h / π.
/// Mistakes are refused.
#[test]
fn the_ground_glows_with_rho_e_h_over_pi_below_the_horizon() {
    let rho = 0.2;
    let sun_h = 3.0 * 40f64.to_radians().cos();
    let e_h = PI + sun_h;
    let daylight = |ctx: &mut Context| {
        ctx.add_sky(&uniform_sky(3.0, false)).unwrap();
        ctx.add_sun(&equal_sun(30.0, 40.0, 9.0)).unwrap();
        ctx.add_ground(&[rho], [0.0, 0.0, 1.0]).unwrap()
    };
    for (seed, estimator) in [
        (70, Estimator::Photons),
        (71, Estimator::DEFAULT),
        (72, Estimator::GATHER),
    ] {
        let mut ctx = context(seeded(seed));
        let black = lambert(&mut ctx, 0.0);
        let flat = grid(4, -1.0, 1.0, -1.0, 1.0, 0.0);
        let id = ctx
            .add_mesh(&MeshDesc {
                two_sided: true,
                ..flat.desc(black)
            })
            .unwrap();
        let g = daylight(&mut ctx);
        // It gives an open horizontal plane nothing from above.
        assert_eq!(ctx.light_flux(g).unwrap().0, vec![0.0; 3]);
        run_with(&mut ctx, photons(300_000), estimator);
        let n = flat.vertex_count();
        assert_z(
            &values(&ctx, id, 0),
            &vec![Some(e_h); n],
            &format!("top, {estimator:?}"),
        );
        assert_z(
            &values(&ctx, id, 1),
            &vec![Some(rho * e_h); n],
            &format!("underside, {estimator:?}"),
        );
        // Vertical, facing −y (the grid turned about x).
        let mut ctx = context(seeded(seed + 10));
        let black = lambert(&mut ctx, 0.0);
        let mut wall = grid(4, -1.0, 1.0, 0.0, 2.0, 0.0);
        for p in wall.positions.chunks_exact_mut(3) {
            let (y, z) = (p[1], p[2]);
            p[1] = -z;
            p[2] = y;
        }
        let wid = ctx.add_mesh(&wall.desc(black)).unwrap();
        daylight(&mut ctx);
        run_with(&mut ctx, photons(300_000), estimator);
        let want = PI / 2.0 + rho * e_h / 2.0;
        assert_z(
            &values(&ctx, wid, 0),
            &vec![Some(want); wall.vertex_count()],
            &format!("wall facing away from the sun, {estimator:?}"),
        );
    }
    // The renderer: looking down at nothing, every pixel is ρ E_h / π.
    use imap::{CameraDesc, RenderMethod, RenderParams};
    let mut ctx = context(seeded(73));
    let black = lambert(&mut ctx, 0.0);
    ctx.add_mesh(&grid(2, 50.0, 51.0, 50.0, 51.0, 0.0).desc(black))
        .unwrap();
    ctx.add_sky(&uniform_sky(3.0, false)).unwrap();
    ctx.add_sun(&equal_sun(30.0, 40.0, 9.0)).unwrap();
    ctx.add_ground(&[rho], [0.0, 0.0, 1.0]).unwrap();
    let mut params = RenderParams {
        method: RenderMethod::Synchronous,
        passes: 2,
        ..Default::default()
    };
    let cam = CameraDesc {
        position: [0.0, 0.0, 1.0],
        direction: [0.0, 0.0, -1.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 60.0,
        width: 16,
        height: 16,
        projection: imap::Projection::Perspective,
    };
    let (img, _) = ctx.render(&cam, &mut params).unwrap();
    for (i, v) in img.radiance.iter().enumerate() {
        assert!((v - rho * e_h / PI).abs() < 1e-9, "pixel value {i}: {v}");
    }
    // Mistakes: no sky yet, a reflectance beyond 1, a second ground.
    let mut ctx = context(seeded(74));
    let e = ctx.add_ground(&[rho], [0.0, 0.0, 1.0]).unwrap_err();
    assert!(e.message.contains("add them first"), "{}", e.message);
    ctx.add_sky(&uniform_sky(3.0, false)).unwrap();
    let e = ctx.add_ground(&[1.5], [0.0, 0.0, 1.0]).unwrap_err();
    assert!(e.message.contains("reflectance[0] = 1.5"), "{}", e.message);
    ctx.add_ground(&[rho], [0.0, 0.0, 1.0]).unwrap();
    let e = ctx.add_ground(&[rho], [0.0, 0.0, 1.0]).unwrap_err();
    assert!(e.message.contains("a ground already"), "{}", e.message);
}

/// Window portals: the roof opening declared as a portal, the sky's and the
/// sun's photons come in through it only. The floor under a uniform sky still reads the
/// view factor (every estimator), under CIE sky 12 the sky's integral over the opening, the
/// sun's patch E_n cos θ where it falls and nothing elsewhere; the same photons leave a
/// smaller error than without the portal; a sun behind the portal's plane gives nothing
/// and bad portals are refused.
#[test]
fn portals_bring_the_sky_and_the_sun_through_the_opening_unbiased() {
    let portal: Vec<f64> = OPENING.iter().flatten().copied().collect();
    let tris = [0u32, 1, 2, 0, 2, 3];
    let floor_want = |floor: &Geometry| -> Vec<Option<f64>> {
        (0..floor.vertex_count())
            .map(|v| {
                Some(hat_average_with(floor, v, 12, |x, _| {
                    polygon_irradiance(x, [0.0, 0.0, 1.0], &OPENING, 1.0)
                }))
            })
            .collect()
    };
    let mut mean_rel = Vec::new();
    for (seed, estimator) in ESTIMATORS.into_iter().enumerate() {
        for with_portal in [true, false] {
            let (mut ctx, id, floor) = roof_room(80 + seed as u64);
            ctx.add_sky(&uniform_sky(3.0, false)).unwrap();
            if with_portal {
                ctx.set_portals(&portal, &tris).unwrap();
            }
            run_with(&mut ctx, photons(200_000), estimator);
            let got = values(&ctx, id, 0);
            mean_rel.push(got.iter().map(|(_, r)| r).sum::<f64>() / got.len() as f64);
            if with_portal {
                assert_z(
                    &got,
                    &floor_want(&floor),
                    &format!("uniform sky through a portal, {estimator:?}"),
                );
            }
        }
    }
    eprintln!("mean relative error at equal photons, with / without the portal: {mean_rel:?}");
    // Photons only: the same photons, a smaller error.
    assert!(mean_rel[0] < 0.7 * mean_rel[1], "{mean_rel:?}");

    // CIE sky 12 through the portal.
    let (mut ctx, id, floor) = roof_room(94);
    let lz = 5000.0;
    ctx.add_sky(&SkyDesc {
        kind: SkyKind::Cie {
            kind: 12,
            sun_azimuth_deg: 225.0,
            sun_zenith_deg: 35.0,
        },
        amount: SkyAmount::Luminance(lz),
        spectrum: Spectrum::Equal,
        ..SkyDesc::default()
    })
    .unwrap();
    ctx.set_portals(&portal, &tris).unwrap();
    run_with(&mut ctx, photons(300_000), Estimator::Photons);
    let (a, z) = (225f64.to_radians(), 35f64.to_radians());
    let sun = [z.sin() * a.sin(), z.sin() * a.cos(), z.cos()];
    let abcde = imap::CIE_SKY_PARAMETERS[11];
    let band_radiance = lz / ctx.photometry().luminous(&[1.0, 1.0, 1.0]);
    let want: Vec<Option<f64>> = (0..floor.vertex_count())
        .map(|v| {
            Some(
                hat_average_with(&floor, v, 4, |x, _| {
                    through_opening(x, 24, &|d| cie_luminance(abcde, d, sun))
                }) * band_radiance,
            )
        })
        .collect();
    assert_z(&values(&ctx, id, 0), &want, "CIE sky 12 through a portal");

    // The sun through the portal: its patch, and its whole flux E_n cos θ × 1 m².
    let (az, zen) = (200f64.to_radians(), 20f64.to_radians());
    let toward = [zen.sin() * az.sin(), zen.sin() * az.cos(), zen.cos()];
    let shift = [-toward[0] / toward[2], -toward[1] / toward[2]];
    let en = 900.0;
    let (mut ctx, id, floor) = roof_room(91);
    ctx.add_sun(&equal_sun(200.0, 20.0, en)).unwrap();
    ctx.set_portals(&portal, &tris).unwrap();
    run_with(&mut ctx, photons(100_000), Estimator::DEFAULT);
    let e_band = en * zen.cos() / 3.0;
    let want = sun_patch(&floor, shift, e_band);
    assert_z(&values(&ctx, id, 0), &want, "sun patch through a portal");
    let got = values(&ctx, id, 0);
    let flux: f64 = got
        .iter()
        .zip(vertex_areas(&floor))
        .map(|((e, _), a)| e * a)
        .sum();
    assert!(
        (flux / e_band - 1.0).abs() < 0.01,
        "patch flux {flux} vs {e_band}"
    );

    // The renderer (its photon maps and its own light samples) through a portal over an
    // open grey floor under the sky and the sun: every floor pixel ρ (π L + E_n cos θ) / π.
    {
        use imap::{CameraDesc, RenderMethod, RenderParams};
        let mut ctx = context(seeded(95));
        let rho = 0.5;
        let grey = lambert(&mut ctx, rho);
        ctx.add_mesh(&grid(8, -4.0, 4.0, -4.0, 4.0, 0.0).desc(grey))
            .unwrap();
        ctx.add_sky(&uniform_sky(3.0, false)).unwrap();
        ctx.add_sun(&equal_sun(30.0, 40.0, 9.0)).unwrap();
        ctx.set_portals(
            &[
                -4.0, -4.0, 0.0, 4.0, -4.0, 0.0, 4.0, 4.0, 0.0, -4.0, 4.0, 0.0,
            ],
            &tris,
        )
        .unwrap();
        let want = rho * (PI + 3.0 * 40f64.to_radians().cos()) / PI;
        for method in [RenderMethod::Synchronous, RenderMethod::FinalGather] {
            let mut params = RenderParams {
                method,
                passes: 64,
                max_path_events: 10_000,
                ..Default::default()
            };
            let cam = CameraDesc {
                position: [0.0, 0.0, 3.0],
                direction: [0.0, 0.0, -1.0],
                up: [0.0, 1.0, 0.0],
                fov_y_deg: 60.0,
                width: 32,
                height: 32,
                projection: imap::Projection::Perspective,
            };
            let (img, _) = ctx.render(&cam, &mut params).unwrap();
            let nb = img.bands;
            let (mut dev, mut est, mut mean) = (0.0f64, 0.0f64, 0.0);
            for p in 0..(32 * 32) {
                let v = img.radiance[p * nb..][..nb].iter().sum::<f64>() / nb as f64;
                dev += ((v - want) / want).powi(2);
                est += img.rel_error[p].powi(2);
                mean += v / 1024.0;
            }
            let (dev, est) = ((dev / 1024.0).sqrt(), (est / 1024.0).sqrt());
            eprintln!("{method:?} through a portal: mean {mean:.4} vs {want:.4}, rms deviation {dev:.2e}, estimated {est:.2e}");
            assert!(
                (mean / want - 1.0).abs() < 0.01,
                "{method:?}: mean {mean} vs {want}"
            );
            assert!(dev < 1.5 * est + 2e-3, "{method:?}: {dev} vs {est}");
        }
    }

    // A portal facing down (its back to the sky and the sun) brings nothing through it:
    // the sun's light still comes, from the whole sky's photons, and the patch is whole.
    let (mut ctx, id, floor) = roof_room(92);
    ctx.add_sun(&equal_sun(200.0, 20.0, en)).unwrap();
    ctx.set_portals(&portal, &[0, 1, 2, 0, 2, 3]).unwrap();
    run_with(&mut ctx, photons(100_000), Estimator::DEFAULT);
    let flux: f64 = values(&ctx, id, 0)
        .iter()
        .zip(vertex_areas(&floor))
        .map(|((e, _), a)| e * a)
        .sum();
    assert!(
        (flux / e_band - 1.0).abs() < 0.02,
        "patch flux {flux} vs {e_band}"
    );
    // Bad portals.
    let (mut ctx, _, _) = roof_room(93);
    assert!(ctx.set_portals(&portal, &[0, 1, 7]).is_err());
    assert!(ctx
        .set_portals(
            &[0.0, 0.0, f64::NAN, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            &[0, 1, 2]
        )
        .is_err());
    assert!(ctx.set_portals(&portal, &[0, 0, 1]).is_err());
}

/// Portals miss nothing: a white wall standing on the roof beside the opening reflects sky
/// light down through it, light whose first line from the sky crosses no portal. The floor
/// reads the same with the opening as a portal (whose photons mix in a share from the
/// whole sky) as without, vertex by vertex, and the light that came off the wall is there:
/// the floor gets more than with the wall black.
#[test]
fn portals_keep_the_light_outside_surfaces_reflect_into_the_opening() {
    let portal: Vec<f64> = OPENING.iter().flatten().copied().collect();
    let run = |with_portal: bool, wall_rho: f64, seed: u64| -> (Vec<(f64, f64)>, f64) {
        let (mut ctx, id, floor) = roof_room(seed);
        let white = lambert(&mut ctx, wall_rho);
        // On the roof along the opening's edge y = 0.5, 1 m high, facing −y (the opening).
        let wall = [
            0.5,
            0.5,
            HEIGHT,
            -0.5,
            0.5,
            HEIGHT,
            -0.5,
            0.5,
            HEIGHT + 1.0,
            0.5,
            0.5,
            HEIGHT + 1.0,
        ];
        ctx.add_mesh(&MeshDesc {
            record: false,
            ..MeshDesc::new(&wall, &[0, 1, 2, 0, 2, 3], white)
        })
        .unwrap();
        ctx.add_sky(&uniform_sky(3.0, false)).unwrap();
        if with_portal {
            ctx.set_portals(&portal, &[0, 1, 2, 0, 2, 3]).unwrap();
        }
        run_with(&mut ctx, photons(400_000), Estimator::DEFAULT);
        let v = values(&ctx, id, 0);
        let areas = vertex_areas(&floor);
        let flux = v.iter().zip(&areas).map(|((e, _), a)| e * a).sum();
        (v, flux)
    };
    let (with, flux_with) = run(true, 0.9, 100);
    let (without, flux_without) = run(false, 0.9, 101);
    let (_, flux_black) = run(true, 0.0, 102);
    let (mut worst, mut sum) = (0.0f64, 0.0);
    for ((a, ra), (b, rb)) in with.iter().zip(&without) {
        let z = (a - b) / ((ra * a).powi(2) + (rb * b).powi(2)).sqrt().max(1e-300);
        worst = worst.max(z.abs());
        sum += z.abs();
    }
    let mean = sum / with.len() as f64;
    eprintln!(
        "portal vs none: largest |z| {worst:.2}, mean |z| {mean:.2}; floor flux {flux_with:.4} vs {flux_without:.4} (wall black: {flux_black:.4})"
    );
    assert!(
        worst < 5.0 && mean < 1.3,
        "largest |z| {worst}, mean {mean}"
    );
    assert!((flux_with / flux_without - 1.0).abs() < 0.02);
    assert!(flux_with > 1.05 * flux_black, "{flux_with} vs {flux_black}");
}

/// The side-lit office of scripts/radiance_office_dc.py: 4 × 6 × 3 m, its south wall
/// (y = 0) open in a window x 0.5–3.5, z 0.9–2.4; floor ρ 0.2, walls 0.5, ceiling 0.7.
/// Sensors: 0.1 m squares facing up at z 0.8 (their centres, vertices 5k, read) at the
/// script's 24 points. Every Tregenza patch and the ground a sky in its own group (patch
/// p in group p, the ground in group 146). Returns the context and the sensor mesh.
fn office(seed: u64) -> (Context, u32) {
    let (mut ctx, sensors) = office_with(seed, [0.2, 0.5, 0.7], None, 0.05);
    patch_skies(&mut ctx);
    (ctx, sensors)
}

/// The Tregenza patches and the ground as skies of unit luminance, each in its light group
/// (patch p in group p, the ground in 146).
fn patch_skies(ctx: &mut Context) {
    ctx.set_layers(imap::LayerRequest {
        groups: true,
        direct: false,
    })
    .unwrap();
    for p in 0..146 {
        let light = ctx.add_sky(&one_patch(p)).unwrap();
        ctx.set_light_group(light, if p == 0 { 146 } else { p as u32 })
            .unwrap();
    }
}

/// The office with reflectances `rho` (floor, walls, ceiling), its window glazed with a
/// pane of index `glass` (6 mm, y from −0.006 to 0) when given, its sensors squares of
/// half-size `h`.
fn office_with(seed: u64, rho: [f64; 3], glass: Option<f64>, h: f64) -> (Context, u32) {
    let mut ctx = context(seeded(seed));
    let (floor, wall, ceiling) = (
        lambert(&mut ctx, rho[0]),
        lambert(&mut ctx, rho[1]),
        lambert(&mut ctx, rho[2]),
    );
    if let Some(n) = glass {
        let m = ctx
            .add_material(&imap::MaterialDesc {
                ior: Some(imap::IorModel::Constant(n)),
                ..Default::default()
            })
            .unwrap();
        let pane = cuboid([0.5, -0.006, 0.9], [3.5, 0.0, 2.4], 1, false);
        ctx.add_mesh(&MeshDesc {
            record: false,
            ..pane.desc(m)
        })
        .unwrap();
    }
    let parts: Vec<(Geometry, u32)> = vec![
        (
            quad([
                [0.0, 0.0, 0.0],
                [0.0, 6.0, 0.0],
                [4.0, 6.0, 0.0],
                [4.0, 0.0, 0.0],
            ]),
            floor,
        ),
        (
            quad([
                [0.0, 0.0, 3.0],
                [4.0, 0.0, 3.0],
                [4.0, 6.0, 3.0],
                [0.0, 6.0, 3.0],
            ]),
            ceiling,
        ),
        (
            quad([
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 3.0],
                [0.0, 6.0, 3.0],
                [0.0, 6.0, 0.0],
            ]),
            wall,
        ),
        (
            quad([
                [4.0, 0.0, 0.0],
                [4.0, 6.0, 0.0],
                [4.0, 6.0, 3.0],
                [4.0, 0.0, 3.0],
            ]),
            wall,
        ),
        (
            quad([
                [0.0, 6.0, 0.0],
                [0.0, 6.0, 3.0],
                [4.0, 6.0, 3.0],
                [4.0, 6.0, 0.0],
            ]),
            wall,
        ),
        (
            quad([
                [0.0, 0.0, 0.0],
                [4.0, 0.0, 0.0],
                [4.0, 0.0, 0.9],
                [0.0, 0.0, 0.9],
            ]),
            wall,
        ),
        (
            quad([
                [0.0, 0.0, 2.4],
                [4.0, 0.0, 2.4],
                [4.0, 0.0, 3.0],
                [0.0, 0.0, 3.0],
            ]),
            wall,
        ),
        (
            quad([
                [0.0, 0.0, 0.9],
                [0.5, 0.0, 0.9],
                [0.5, 0.0, 2.4],
                [0.0, 0.0, 2.4],
            ]),
            wall,
        ),
        (
            quad([
                [3.5, 0.0, 0.9],
                [4.0, 0.0, 0.9],
                [4.0, 0.0, 2.4],
                [3.5, 0.0, 2.4],
            ]),
            wall,
        ),
    ];
    for (g, m) in &parts {
        ctx.add_mesh(&MeshDesc {
            record: false,
            two_sided: true,
            ..g.desc(*m)
        })
        .unwrap();
    }
    let (mut positions, mut indices) = (Vec::new(), Vec::new());
    for y in [0.5, 1.5, 2.5, 3.5, 4.5, 5.5] {
        for x in [0.5, 1.5, 2.5, 3.5] {
            let k = (positions.len() / 3) as u32;
            for (dx, dy) in [(0.0, 0.0), (-h, -h), (h, -h), (h, h), (-h, h)] {
                positions.extend([x + dx, y + dy, 0.8]);
            }
            for t in 0..4u32 {
                indices.extend([k, k + 1 + t, k + 1 + (t + 1) % 4]);
            }
        }
    }
    let black = lambert(&mut ctx, 0.0);
    let sensors = ctx
        .add_mesh(&MeshDesc {
            sensor: true,
            ..MeshDesc::new(&positions, &indices, black)
        })
        .unwrap();
    (ctx, sensors)
}

#[test]
fn office_daylight_coefficients_agree_with_radiance_rfluxmtx() {
    // Radiance's coefficients (two runs of 200 000 paths per sensor) and ours (gathering),
    // each under the sky vectors of the 21st of every month of a typical year at 45° N
    // 8° E, the sky only: the hourly illuminance at the 24 sensors agrees within the
    // combined errors. (With the sun in its patch one coefficient carries an hour; a
    // patch the sun grazes through the window is then under-sampled by the photons:
    // measured at 10⁶ photons, largest |z| 5.0, mean 0.93, the sum still 1.0008.)
    let text = include_str!("data/radiance_office_dc.txt");
    let radiance: Vec<(Vec<f64>, Vec<f64>)> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let f: Vec<Vec<f64>> = l
                .split('|')
                .map(|s| s.split_whitespace().map(|x| x.parse().unwrap()).collect())
                .collect();
            (f[1].clone(), f[2].clone())
        })
        .collect();
    assert_eq!(radiance.len(), 24);
    let (mut ctx, sensors) = office(90);
    let t = std::time::Instant::now();
    run_with(&mut ctx, photons(150_000), Estimator::GATHER);
    eprintln!("run {:.1} s", t.elapsed().as_secs_f64());
    let ours = office_coefficients(&ctx, sensors);
    let weather =
        imap::weather::parse_wea(include_str!("data/pvgis_45n_8e_21st.wea"), "pvgis.wea").unwrap();
    let sky =
        imap::annual::AnnualSky::from_weather(&weather, 1, imap::annual::SunInVectors::Left, 0.2)
            .unwrap();
    let (eo, so) = imap::annual::hourly(&ours, &sky, None).unwrap();
    let lit: Vec<usize> = (0..sky.hours.len())
        .filter(|&h| sky.hours[h].diffuse_horizontal_lx > 0.0)
        .collect();
    let radiance_hour =
        |h: usize, c: &[f64]| -> f64 { sky.vector(h).iter().zip(c).map(|(l, c)| l * c).sum() };
    // Radiance's relative error per sensor, pooled over the hours from its two runs'
    // differences (one pair alone says little).
    let radiance_rel: Vec<f64> = radiance
        .iter()
        .map(|(a, b)| {
            let s: f64 = lit
                .iter()
                .map(|&h| {
                    let (ra, rb) = (radiance_hour(h, a), radiance_hour(h, b));
                    ((ra - rb) / (ra + rb)).powi(2)
                })
                .sum();
            (s / lit.len() as f64).sqrt()
        })
        .collect();
    let (mut worst, mut sum_z, mut n) = (0.0f64, 0.0, 0usize);
    let (mut sum_o, mut sum_r) = (0.0, 0.0);
    for &h in &lit {
        for (k, (a, b)) in radiance.iter().enumerate() {
            let r = 0.5 * (radiance_hour(h, a) + radiance_hour(h, b));
            let sr = r * radiance_rel[k];
            let (x, sx) = (eo[h * 24 + k], so[h * 24 + k]);
            let z = (x - r) / (sx * sx + sr * sr).sqrt().max(1e-9);
            worst = worst.max(z.abs());
            sum_z += z.abs();
            n += 1;
            sum_o += x;
            sum_r += r;
        }
    }
    let mean = sum_z / n as f64;
    eprintln!(
        "{n} sensor-hours: largest |z| {worst:.2}, mean |z| {mean:.2}, Σ ours / Σ Radiance {:.4}",
        sum_o / sum_r
    );
    assert!(
        n > 3000 && worst < 5.0 && (0.4..1.3).contains(&mean),
        "{worst} {mean}"
    );
    assert!((sum_o / sum_r - 1.0).abs() < 0.01, "{}", sum_o / sum_r);
    // sDA at 1000 lx from Radiance's coefficients lies in ours' 95 % interval, and each
    // sensor's DA is within 5 % of the hours.
    let theirs = imap::annual::Coefficients {
        sensors: 24,
        patches: 146,
        value: radiance
            .iter()
            .flat_map(|(a, b)| {
                a.iter()
                    .zip(b)
                    .map(|(x, y)| 0.5 * (x + y))
                    .collect::<Vec<_>>()
            })
            .collect(),
        sigma: vec![0.0; 24 * 146],
    };
    let o = imap::annual::MetricOptions {
        threshold_lx: 1000.0,
        ..imap::annual::MetricOptions::default()
    };
    let mo = imap::annual::metrics(&ours, &sky, None, &o).unwrap();
    let mr = imap::annual::metrics(&theirs, &sky, None, &o).unwrap();
    eprintln!(
        "sDA ours {:.3} ({:.3}–{:.3}), Radiance's coefficients {:.3}",
        mo.sda, mo.sda_interval.0, mo.sda_interval.1, mr.sda
    );
    assert!(mo.sda_interval.0 <= mr.sda && mr.sda <= mo.sda_interval.1);
    assert!(mr.sda > 0.1 && mr.sda < 0.9, "{}", mr.sda);
    for (a, b) in mo.sensors.iter().zip(&mr.sensors) {
        assert!((a.da - b.da).abs() <= 0.05, "DA {} vs {}", a.da, b.da);
    }
}

/// The office's 24 sensors' coefficients after a run of `patch_skies` (lx per cd/m²: the
/// equal-energy bands' band-0 irradiance times the luminous efficacy), with their errors.
fn office_coefficients(ctx: &Context, sensors: u32) -> imap::annual::Coefficients {
    let nv = ctx.vertex_count(sensors).unwrap();
    let eff: f64 = ctx.photometry().luminous(&[1.0, 1.0, 1.0]);
    let (mut value, mut sigma) = (vec![0.0; 24 * 146], vec![0.0; 24 * 146]);
    let (mut e, mut rel) = (vec![0.0; nv], vec![0.0; nv]);
    for p in 0..146 {
        let layer = imap::Layer::Group(if p == 0 { 146 } else { p as u32 });
        ctx.irradiance_layer(sensors, 0, 0, layer, &mut e).unwrap();
        ctx.rel_error_layer(sensors, 0, layer, &mut rel).unwrap();
        for k in 0..24 {
            value[k * 146 + p] = e[5 * k] * eff;
            sigma[k * 146 + p] = e[5 * k] * eff * rel[5 * k];
        }
    }
    imap::annual::Coefficients {
        sensors: 24,
        patches: 146,
        value,
        sigma,
    }
}

/// The office's 24 sensor points and their (upward) normals.
fn office_points() -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let mut points = Vec::new();
    for y in [0.5, 1.5, 2.5, 3.5, 4.5, 5.5] {
        for x in [0.5, 1.5, 2.5, 3.5] {
            points.push([x, y, 0.8]);
        }
    }
    let n = points.len();
    (points, vec![[0.0, 0.0, 1.0]; n])
}

#[test]
fn the_straight_line_through_a_pane_passes_its_fresnel_share_and_nothing_else_does() {
    // The glazed roof opening: from a floor point through the 2 mm pane (n = 1.52, parallel
    // faces) the line keeps ½ [(1 − R_s)/(1 + R_s) + (1 − R_p)/(1 + R_p)] (the pane's
    // multiple reflections stay on the line); through the black roof, nothing.
    let n_glass = 1.52;
    let (mut ctx, _, _, glass) = glazed_roof_room(70, n_glass);
    // A prism: a wedge of glass over x > 2 (outside the room), faces 20° apart.
    let wedge_positions = [
        2.0, -1.0, 0.0, 3.0, -1.0, 0.0, 2.0, -1.0, 1.0, 2.0, 1.0, 0.0, 3.0, 1.0, 0.0, 2.0, 1.0, 1.0,
    ];
    let wedge_indices = [
        0u32, 2, 1, 3, 4, 5, 0, 1, 4, 0, 4, 3, 0, 3, 5, 0, 5, 2, 1, 2, 5, 1, 5, 4,
    ];
    ctx.add_mesh(&MeshDesc {
        record: false,
        ..MeshDesc::new(&wedge_positions, &wedge_indices, glass)
    })
    .unwrap();
    ctx.add_sky(&uniform_sky(1.0, false)).unwrap();
    let points = [[0.1, 0.05, 0.01], [2.3, 0.0, 0.05]];
    let dirs: Vec<[f64; 3]> = [0.0f64, 0.1, 0.2, 0.4]
        .iter()
        .map(|t| [0.0, *t, 1.0])
        .chain([[0.8, 0.0, 0.6], [0.0, 0.0, -1.0]])
        .collect();
    let t = ctx.straight_transmittance(&points, &dirs, &[]).unwrap();
    for (j, d) in dirs.iter().enumerate() {
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let c = d[2] / l;
        let want = if j < 4 {
            let (rs, rp) = fresnel_sp(c, n_glass);
            0.5 * ((1.0 - rs) / (1.0 + rs) + (1.0 - rp) / (1.0 + rp))
        } else {
            // Toward the black wall or the floor.
            0.0
        };
        let got = t[j] as f64;
        eprintln!("direction {j}: {got:.6} vs {want:.6}");
        assert!((got - want).abs() < 1e-5, "direction {j}: {got} vs {want}");
    }
    // Inside the wedge's reach: the line from under it comes out turned, so no light
    // arrives along it; the open sky beside it passes all.
    assert_eq!(t[dirs.len()], 0.0, "through the prism");
    let beside = ctx
        .straight_transmittance(&[[2.3, 1.5, 0.05]], &[[0.0, 0.0, 1.0]], &[])
        .unwrap();
    assert_eq!(beside[0], 1.0);
    // Bad arguments are named.
    let e = ctx
        .straight_transmittance(&[[0.0, 0.0, f64::NAN]], &dirs, &[])
        .unwrap_err();
    assert!(e.message.contains("points[0]"), "{}", e.message);
    let e = ctx
        .straight_transmittance(&points, &[[0.0, 0.0, 0.0]], &[])
        .unwrap_err();
    assert!(e.message.contains("dirs[0]"), "{}", e.message);
    let e = ctx
        .straight_transmittance(&points, &dirs, &[1.0, 2.0])
        .unwrap_err();
    assert!(e.message.contains("weights"), "{}", e.message);
}

#[test]
fn direct_only_patch_coefficients_are_what_photons_bring_where_nothing_reflects() {
    // A black office glazed with one 6 mm pane: every photon that reaches a sensor came
    // straight through the glass, so each patch's coefficient (photons) equals its
    // direct-only coefficient (lines through the pane), sensor by sensor within the errors.
    // Sensors of 0.8 m (the photons' error), compared with the lines' hat-weighted mean
    // over them (8 × 8 points each).
    let h = 0.4;
    let (mut ctx, sensors) = office_with(3, [0.0; 3], Some(1.52), h);
    patch_skies(&mut ctx);
    let portal = [0.5, 0.0, 0.9, 3.5, 0.0, 0.9, 3.5, 0.0, 2.4, 0.5, 0.0, 2.4];
    ctx.set_portals(&portal, &[0, 1, 2, 0, 2, 3]).unwrap();
    run_with(&mut ctx, photons(2_000_000), Estimator::Photons);
    let eff: f64 = ctx.photometry().luminous(&[1.0, 1.0, 1.0]);
    let nv = ctx.vertex_count(sensors).unwrap();
    let weather =
        imap::weather::parse_wea(include_str!("data/pvgis_45n_8e_21st.wea"), "pvgis.wea").unwrap();
    let sky =
        imap::annual::AnnualSky::from_weather(&weather, 1, imap::annual::SunInVectors::Left, 0.0)
            .unwrap();
    let (points, hat) = office_sensor_points(h);
    let normals = vec![[0.0, 0.0, 1.0]; points.len()];
    let d = SkyDesc::default();
    let fine = imap::annual::DirectSun::new(
        &mut ctx,
        &sky,
        (d.zenith, d.north),
        (&points, &normals),
        &Spectrum::Equal,
        1,
    )
    .unwrap();
    let sun = sensor_sun(&fine, &hat, sky.hours.len());
    let (mut worst, mut sum, mut n) = (0.0f64, 0.0, 0usize);
    let (mut total_c, mut total_d) = (0.0, 0.0);
    let (mut e, mut rel) = (vec![0.0; nv], vec![0.0; nv]);
    let mut crossed = 0;
    for p in 1..146 {
        if sun
            .patch_direct_sigma
            .iter()
            .skip(p)
            .step_by(146)
            .all(|&x| x == 0.0)
            && sun
                .patch_direct
                .iter()
                .skip(p)
                .step_by(146)
                .all(|&x| x == 0.0)
        {
            continue;
        }
        crossed += 1;
        let layer = imap::Layer::Group(p as u32);
        ctx.irradiance_layer(sensors, 0, 0, layer, &mut e).unwrap();
        ctx.rel_error_layer(sensors, 0, layer, &mut rel).unwrap();
        for k in 0..24 {
            let (c, sc) = (e[5 * k] * eff, e[5 * k] * eff * rel[5 * k]);
            let (x, sx) = (
                sun.patch_direct[k * 146 + p],
                sun.patch_direct_sigma[k * 146 + p],
            );
            total_c += c;
            total_d += x;
            if !(c > 0.0 && sc <= 0.3 * c) {
                continue;
            }
            let z = (c - x) / (sc * sc + sx * sx).sqrt();
            worst = worst.max(z.abs());
            sum += z.abs();
            n += 1;
        }
    }
    eprintln!(
        "{crossed} patches the sun crosses, {n} sensor-patches: largest |z| {worst:.2}, mean |z| {:.2}, Σ photons / Σ lines {:.4}",
        sum / n as f64,
        total_c / total_d
    );
    assert!(crossed > 20);
    assert!(n > 100 && worst < 5.0 && (0.4..1.3).contains(&(sum / n as f64)));
    assert!((total_c / total_d - 1.0).abs() < 0.02);
}

/// The direct sun of `points` grouped 64 by 64 (each sensor's 8 × 8 points) into one per
/// sensor, by the hat weights `hat`: what a sensor of that support reads.
fn sensor_sun(s: &imap::annual::DirectSun, hat: &[f64], hours: usize) -> imap::annual::DirectSun {
    let sensors = s.sensors / 64;
    let np = s.patches;
    let hat_sum: f64 = hat[..64].iter().sum();
    let mut out = imap::annual::DirectSun {
        sensors,
        patches: np,
        offsets: vec![0],
        hours: Vec::new(),
        lux: Vec::new(),
        patch_direct: vec![0.0; sensors * np],
        patch_direct_sigma: vec![0.0; sensors * np],
    };
    for k in 0..sensors {
        let mut lux = vec![0.0; hours];
        let mut var = vec![0.0; np];
        for (i, w) in hat[..64].iter().map(|x| x / hat_sum).enumerate() {
            let at = 64 * k + i;
            for (h, x) in s.at(at) {
                lux[h] += w * x;
            }
            let row = at * np..(at + 1) * np;
            let mine = &mut out.patch_direct[k * np..(k + 1) * np];
            for ((o, v), (d, sd)) in mine.iter_mut().zip(var.iter_mut()).zip(
                s.patch_direct[row.clone()]
                    .iter()
                    .zip(&s.patch_direct_sigma[row]),
            ) {
                *o += w * d;
                *v += (w * sd).powi(2);
            }
        }
        for (o, v) in out.patch_direct_sigma[k * np..(k + 1) * np]
            .iter_mut()
            .zip(&var)
        {
            *o = v.sqrt();
        }
        for (h, x) in lux.iter().enumerate() {
            if *x > 0.0 {
                out.hours.push(h as u32);
                out.lux.push(*x as f32);
            }
        }
        out.offsets.push(out.hours.len());
    }
    out
}

/// Each office sensor's 8 × 8 points over its half-size `h` and their hat weights.
fn office_sensor_points(h: f64) -> (Vec<[f64; 3]>, Vec<f64>) {
    let (centres, _) = office_points();
    let (mut points, mut hat) = (Vec::new(), Vec::new());
    for c in &centres {
        for i in 0..8 {
            for j in 0..8 {
                let (u, v) = ((i as f64 + 0.5) / 4.0 - 1.0, (j as f64 + 0.5) / 4.0 - 1.0);
                points.push([c[0] + u * h, c[1] + v * h, c[2]]);
                hat.push(1.0 - u.abs().max(v.abs()));
            }
        }
    }
    (points, hat)
}

#[test]
fn an_hour_from_coefficients_and_the_direct_sun_is_that_hours_sky_and_sun() {
    // The glazed office with reflecting walls. One run of the patch skies makes the
    // coefficients; the direct sun is traced along its lines. An afternoon hour of the
    // PVGIS year (sun to the south-west, its patch of light toward the room's east side)
    // from them equals a run of that hour's sky (its patches as a sky) and its sun, sensor
    // by sensor within the errors. A sky frame turned the wrong way would put the sun on
    // the west sensors.
    let h = 0.4;
    let (mut ctx, sensors) = office_with(5, [0.2, 0.5, 0.7], Some(1.52), h);
    patch_skies(&mut ctx);
    let portal = [0.5, 0.0, 0.9, 3.5, 0.0, 0.9, 3.5, 0.0, 2.4, 0.5, 0.0, 2.4];
    ctx.set_portals(&portal, &[0, 1, 2, 0, 2, 3]).unwrap();
    const RUN: u64 = 100_000;
    let t = std::time::Instant::now();
    run_with(&mut ctx, photons(RUN), Estimator::GATHER);
    eprintln!("coefficients' run {:.1} s", t.elapsed().as_secs_f64());
    let eff: f64 = ctx.photometry().luminous(&[1.0, 1.0, 1.0]);
    let c = office_coefficients(&ctx, sensors);
    let weather =
        imap::weather::parse_wea(include_str!("data/pvgis_45n_8e_21st.wea"), "pvgis.wea").unwrap();
    let sky =
        imap::annual::AnnualSky::from_weather(&weather, 1, imap::annual::SunInVectors::Left, 0.0)
            .unwrap();
    let hour = (0..sky.hours.len())
        .filter(|&h| {
            let a = &sky.hours[h];
            (200.0..240.0).contains(&a.sun_azimuth_deg) && a.sun_zenith_deg < 65.0
        })
        .max_by(|&a, &b| {
            sky.hours[a]
                .direct_normal_lx
                .total_cmp(&sky.hours[b].direct_normal_lx)
        })
        .expect("a sunny afternoon hour");
    let a = sky.hours[hour];
    eprintln!(
        "hour {hour}: sun azimuth {:.1}°, zenith {:.1}°, E_n {:.0} lx, E_dh {:.0} lx",
        a.sun_azimuth_deg, a.sun_zenith_deg, a.direct_normal_lx, a.diffuse_horizontal_lx
    );
    let (points, hat) = office_sensor_points(h);
    let normals = vec![[0.0, 0.0, 1.0]; points.len()];
    let d = SkyDesc::default();
    let fine = imap::annual::DirectSun::new(
        &mut ctx,
        &sky,
        (d.zenith, d.north),
        (&points, &normals),
        &Spectrum::Equal,
        2,
    )
    .unwrap();
    let sun = sensor_sun(&fine, &hat, sky.hours.len());
    // The two sensors wholly in the sun's patch read E_n T(θ) cos Z: the pane's
    // transmittance at the sun's incidence on the window (normal −y, north +y, east +x).
    let (z, az) = (
        a.sun_zenith_deg.to_radians(),
        a.sun_azimuth_deg.to_radians(),
    );
    let (rs, rp) = fresnel_sp(-(z.sin() * az.cos()), 1.52);
    let pane = 0.5 * ((1.0 - rs) / (1.0 + rs) + (1.0 - rp) / (1.0 + rp));
    let want = a.direct_normal_lx * pane * z.cos();
    for k in [1, 2] {
        let got: f64 = sun.at(k).filter(|e| e.0 == hour).map(|e| e.1).sum();
        assert!(
            (got / want - 1.0).abs() < 1e-4,
            "sensor {k}: {got} vs {want}"
        );
    }
    let (x, sx) = imap::annual::hourly(&c, &sky, Some(&sun)).unwrap();
    // The smeared sun (2-phase), for the record.
    let smeared = imap::annual::AnnualSky::from_weather(
        &weather,
        1,
        imap::annual::SunInVectors::InItsPatch,
        0.0,
    )
    .unwrap();
    let (xs, _) = imap::annual::hourly(&c, &smeared, None).unwrap();

    // The hour itself: its patches as a sky, and its sun.
    let (mut run, rs) = office_with(6, [0.2, 0.5, 0.7], Some(1.52), h);
    run.set_portals(&portal, &[0, 1, 2, 0, 2, 3]).unwrap();
    run.add_sky(&SkyDesc {
        kind: SkyKind::Patches {
            mf: 1,
            values: std::sync::Arc::new(sky.vector(hour).to_vec()),
        },
        amount: SkyAmount::Luminance(1.0),
        spectrum: Spectrum::Equal,
        ..SkyDesc::default()
    })
    .unwrap();
    run.add_sun(&SunDesc {
        azimuth_deg: a.sun_azimuth_deg,
        zenith_deg: a.sun_zenith_deg,
        amount: SkyAmount::NormalIlluminance(a.direct_normal_lx),
        spectrum: Spectrum::Equal,
        ..SunDesc::default()
    })
    .unwrap();
    run_with(&mut run, photons(RUN), Estimator::GATHER);
    let got = values(&run, rs, 0);
    let (mut worst, mut sum) = (0.0f64, 0.0);
    let (mut worst_smeared, mut sunlit) = (0.0f64, 0);
    for k in 0..24 {
        let (y, sy) = (got[5 * k].0 * eff, got[5 * k].0 * eff * got[5 * k].1);
        let (v, sv) = (x[hour * 24 + k], sx[hour * 24 + k]);
        let z = (v - y) / (sv * sv + sy * sy).sqrt();
        let zs = (xs[hour * 24 + k] - y) / (sv * sv + sy * sy).sqrt();
        let direct: f64 = sun.at(k).filter(|e| e.0 == hour).map(|e| e.1).sum();
        if direct > 0.0 {
            sunlit += 1;
        }
        eprintln!(
            "sensor {k}: hour {v:.0} ± {sv:.0} lx (direct sun {direct:.0}), run {y:.0} ± {sy:.0}: z {z:.2}; smeared sun {:.0}: z {zs:.2}",
            xs[hour * 24 + k]
        );
        worst = worst.max(z.abs());
        worst_smeared = worst_smeared.max(zs.abs());
        sum += z.abs();
    }
    eprintln!(
        "24 sensors ({sunlit} in the sun): largest |z| {worst:.2}, mean |z| {:.2}; the smeared sun's largest |z| {worst_smeared:.1}",
        sum / 24.0
    );
    assert!((2..=12).contains(&sunlit), "{sunlit}");
    assert!(worst < 5.0 && (0.3..1.4).contains(&(sum / 24.0)));
}

#[test]
fn under_the_open_sky_the_direct_sun_is_e_n_cos_z_and_a_patch_its_cosine_integral() {
    // A point above a small black plate, nothing else: each hour's sun gives E_n cos Z on
    // a horizontal sensor and nothing on one facing down; each patch's direct-only
    // coefficient is ∫ cos dω over it (within its stated error); a sensor facing north
    // sees no southern sun.
    let mut ctx = context(seeded(4));
    let black = lambert(&mut ctx, 0.0);
    ctx.add_mesh(&grid(1, -0.5, 0.5, -0.5, 0.5, 0.0).desc(black))
        .unwrap();
    ctx.add_sky(&uniform_sky(1.0, false)).unwrap();
    let weather =
        imap::weather::parse_wea(include_str!("data/pvgis_45n_8e_21st.wea"), "pvgis.wea").unwrap();
    let sky =
        imap::annual::AnnualSky::from_weather(&weather, 1, imap::annual::SunInVectors::Left, 0.0)
            .unwrap();
    let d = SkyDesc::default();
    let points = [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]];
    let normals = [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]];
    let sun = imap::annual::DirectSun::new(
        &mut ctx,
        &sky,
        (d.zenith, d.north),
        (&points, &normals),
        &Spectrum::Equal,
        9,
    )
    .unwrap();
    let sunny = sky
        .hours
        .iter()
        .filter(|a| a.direct_normal_lx > 0.0 && a.sun_zenith_deg < 90.0)
        .count();
    assert!(sunny > 50);
    assert_eq!(sun.at(0).count(), sunny);
    for (h, x) in sun.at(0) {
        let a = &sky.hours[h];
        let want = a.direct_normal_lx * a.sun_zenith_deg.to_radians().cos();
        assert!((x / want - 1.0).abs() < 1e-5, "hour {h}: {x} vs {want}");
    }
    assert_eq!(sun.at(1).count(), 0);
    // At 45° N the sun stands south of the east–west line from March to September's
    // noon hours; a north-facing sensor sees it only early and late in summer.
    assert!(sun.at(2).count() < sunny / 3, "{}", sun.at(2).count());
    let (mut worst, mut n) = (0.0f64, 0);
    let patches = &sky.patches;
    for p in 1..146 {
        let (x, s) = (sun.patch_direct[p], sun.patch_direct_sigma[p]);
        if x == 0.0 {
            continue;
        }
        n += 1;
        let want = patches.horizontal(p);
        worst = worst.max((x - want).abs() / s.max(1e-12));
        assert!(s < 0.02 * want, "patch {p}: σ {s} of {want}");
    }
    eprintln!("{n} patches the sun crosses: largest |z| against ∫ cos dω {worst:.2}");
    assert!(n > 30 && worst < 4.0);
    // Bad arguments are named; an overcast year has no sun to trace.
    let frame = (d.zenith, d.north);
    let e = imap::annual::DirectSun::new(
        &mut ctx,
        &sky,
        frame,
        (&points, &normals[..2]),
        &Spectrum::Equal,
        1,
    )
    .unwrap_err();
    assert!(
        e.message.contains("3 points and 2 normals"),
        "{}",
        e.message
    );
    let zero = [[0.0, 0.0, 0.0]; 3];
    let e =
        imap::annual::DirectSun::new(&mut ctx, &sky, frame, (&points, &zero), &Spectrum::Equal, 1)
            .unwrap_err();
    assert!(e.message.contains("normals[0]"), "{}", e.message);
    let overcast = imap::weather::parse_wea(
        "place t\nlatitude 48\nlongitude -11\ntime_zone -15\nsite_elevation 0\n\
         weather_data_file_units 1\n6 21 12.5 0 120\n",
        "t.wea",
    )
    .unwrap();
    let dull =
        imap::annual::AnnualSky::from_weather(&overcast, 1, imap::annual::SunInVectors::Left, 0.0)
            .unwrap();
    let none = imap::annual::DirectSun::new(
        &mut ctx,
        &dull,
        frame,
        (&points, &normals),
        &Spectrum::Equal,
        1,
    )
    .unwrap();
    assert!(none.hours.is_empty() && none.offsets == vec![0; 4]);
    assert!(none.patch_direct.iter().all(|&x| x == 0.0));
}

#[test]
fn the_direct_sun_in_the_glazed_office_agrees_with_radiance() {
    // scripts/radiance_office_sun.py: Radiance 6.0a's direct light (rtrace -ab 0) through
    // its `glass` (n 1.52, no absorption) at the office's 24 sensors for the 96 sunlit
    // hours of the PVGIS days, the sun placed by pvlib's NREL SPA. Ours: the same hours'
    // sun by our SPA (against pvlib's: within 0.01°) and its lines through a 6 mm pane of
    // index 1.52. Per sensor-hour T cos θ agrees where the line is clear of the window's
    // edges, and ASE's hours above 1000 lx are the same at every sensor.
    let text = include_str!("data/radiance_office_sun.txt");
    let rows: Vec<Vec<f64>> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split_whitespace().map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 96);
    let (mut ctx, _) = office_with(1, [0.2, 0.5, 0.7], Some(1.52), 0.05);
    ctx.add_sky(&uniform_sky(1.0, false)).unwrap();
    let weather =
        imap::weather::parse_wea(include_str!("data/pvgis_45n_8e_21st.wea"), "pvgis.wea").unwrap();
    let sky =
        imap::annual::AnnualSky::from_weather(&weather, 1, imap::annual::SunInVectors::Left, 0.0)
            .unwrap();
    let (points, normals) = office_points();
    let d = SkyDesc::default();
    let sun = imap::annual::DirectSun::new(
        &mut ctx,
        &sky,
        (d.zenith, d.north),
        (&points, &normals),
        &Spectrum::Equal,
        1,
    )
    .unwrap();
    let mut ours = vec![0.0; 24 * sky.hours.len()];
    for k in 0..24 {
        for (h, x) in sun.at(k) {
            ours[24 * h + k] = x / sky.hours[h].direct_normal_lx;
        }
    }
    let (mut worst_angle, mut compared, mut differ) = (0.0f64, 0, 0);
    let mut ase = [[0usize; 24]; 2];
    for r in &rows {
        let h = sky
            .hours
            .iter()
            .position(|a| a.month == r[0] as u32 && a.day == r[1] as u32 && a.hour == r[2])
            .expect("the hour");
        let a = &sky.hours[h];
        worst_angle = worst_angle
            .max((a.sun_zenith_deg - r[3]).abs())
            .max((a.sun_azimuth_deg - r[4]).abs() * a.sun_zenith_deg.to_radians().sin());
        for k in 0..24 {
            let (x, y) = (ours[24 * h + k], r[5 + k]);
            compared += 1;
            if (x - y).abs() > 2e-4 {
                differ += 1;
                eprintln!(
                    "{}/{} {}h sensor {k}: ours {x:.6}, Radiance {y:.6}",
                    r[1], r[0], r[2]
                );
            }
            let e_n = a.direct_normal_lx;
            ase[0][k] += usize::from(x * e_n > 1000.0);
            ase[1][k] += usize::from(y * e_n > 1000.0);
        }
    }
    eprintln!(
        "{compared} sensor-hours, {differ} differ by more than 2e-4; sun directions within {worst_angle:.4}°; hours above 1000 lx ours {:?}, Radiance {:?}",
        ase[0], ase[1]
    );
    // The one line that differs (21 August 15:30, sensor 1) crosses the window 1.9 mm
    // inside its west edge and leaves our 6 mm pane by its edge face (Radiance's glass
    // is a thin sheet): a thick pane's edge, not an error.
    assert!(worst_angle < 0.01, "{worst_angle}");
    assert!(differ * 200 <= compared, "{differ} of {compared}");
    for (k, (a, b)) in ase[0].iter().zip(&ase[1]).enumerate() {
        assert!(a.abs_diff(*b) <= 1, "sensor {k}");
    }
    assert!(ase[0].iter().sum::<usize>() > 200);
}

/// The floor's coefficients by `imap::annual::trace::PatchRun` (MF:`mf`, at most `batch`
/// patches per run) after `rounds` rounds of `n` photons each.
fn patch_run(
    seed: u64,
    threads: usize,
    mf: u32,
    batch: usize,
    rounds: &[u64],
) -> (
    imap::annual::trace::PatchRun,
    Vec<imap::annual::Coefficients>,
    Geometry,
) {
    use imap::annual::trace::{PatchRound, PatchRun, PatchTarget};
    let (mut ctx, id, floor) = roof_room(seed);
    ctx.set_threads(threads).unwrap();
    let target = PatchTarget {
        mesh: id,
        side: 0,
        vertices: (0..floor.vertex_count()).collect(),
    };
    let frame = ([0.0, 0.0, 1.0], [0.0, 1.0, 0.0]);
    let mut run = PatchRun::new(&mut ctx, mf, frame, vec![target], batch).unwrap();
    let mut after = Vec::new();
    for &n in rounds {
        let round = PatchRound {
            photons: n,
            // Gathering: light sampling and photons alone leave a floor vertex's few
            // photons of a patch with a skewed error (largest |z| 7–11 at 300 000 photons).
            estimator: Some(Estimator::GATHER),
            ..Default::default()
        };
        run.trace(&mut ctx, round, &mut |_| true).unwrap();
        after.push(run.coefficients(0).unwrap().clone());
    }
    (run, after, floor)
}

/// A smooth sky that varies with altitude and azimuth as MF:`mf` patch luminances, cd/m²:
/// (1 + 2 sin a)(1.5 + cos a sin φ) at each patch's centre (a altitude, φ azimuth from
/// north toward east), 1000 cd/m² at the zenith. No patch dominates, as the sun's do in a
/// clear sky (a patch's coefficient has few photons; a sum that one patch dominates has
/// the skewed error of a few photons), and every patch's value is its own, so a patch's
/// coefficient read into another patch's place shows.
fn smooth_patches(mf: u32) -> Vec<f64> {
    let patches = imap::SkyPatches::reinhart(mf).unwrap();
    (0..patches.count())
        .map(|p| {
            if p == 0 {
                return 0.0;
            }
            let (lo, hi, az, w) = patches.bounds(p);
            let (a, phi) = (0.5 * (lo + hi), az + 0.5 * w);
            1000.0 / 4.5 * (1.0 + 2.0 * a.sin()) * (1.5 + a.cos() * phi.sin())
        })
        .collect()
}

/// Asserts that `lum` × `c` at every floor vertex is the patch sky `lum` read through the
/// opening (lx, exact by quadrature), within the coefficients' combined errors.
fn assert_patch_sky(
    c: &imap::annual::Coefficients,
    lum: &[f64],
    floor: &Geometry,
    mf: u32,
    what: &str,
) {
    let patches = imap::SkyPatches::reinhart(mf).unwrap();
    let got: Vec<(f64, f64)> = (0..c.sensors)
        .map(|k| {
            let row = k * c.patches..(k + 1) * c.patches;
            let e: f64 = lum
                .iter()
                .zip(&c.value[row.clone()])
                .map(|(l, x)| l * x)
                .sum();
            let v: f64 = lum
                .iter()
                .zip(&c.sigma[row])
                .map(|(l, s)| (l * s).powi(2))
                .sum();
            (e, if e > 0.0 { v.sqrt() / e } else { 0.0 })
        })
        .collect();
    let l = |d: [f64; 3]| lum[patches.patch(d[2].clamp(-1.0, 1.0).asin(), d[0].atan2(d[1]))];
    let (mut se, mut sr) = (0.0, 0.0);
    for (e, r) in &got {
        se += e;
        sr += e * r;
    }
    eprintln!("{what}: weighted mean stated relative error {:.4}", sr / se);
    let want: Vec<Option<f64>> = (0..c.sensors)
        .map(|v| {
            Some(hat_average_with(floor, v, 4, |x, _| {
                through_opening(x, 24, &l)
            }))
        })
        .collect();
    assert_z(&got, &want, what);
}

#[test]
fn reinhart_patches_traced_in_batches_are_their_skies_at_every_subdivision() {
    // MF:1 in four batches of 40 patches, MF:2 in three and MF:4 in ten (253 patches per
    // run): a sky vector times each run's coefficients is the patch sky through the
    // roof opening, vertex by vertex within the combined errors (every batch's patches
    // present once, at their luminance, with errors independent between batches).
    for (mf, batch, batches) in [(1u32, 40usize, 4usize), (2, 0, 3), (4, 0, 10)] {
        let (run, c, floor) = patch_run(80 + mf as u64, 2, mf, batch, &[100_000]);
        assert_eq!(run.batches().len(), batches, "MF:{mf}");
        assert!(
            run.report().photons >= 100_000,
            "MF:{mf}: {:?}",
            run.report()
        );
        let c = &c[0];
        assert_eq!(c.patches, imap::SkyPatches::reinhart(mf).unwrap().count());
        // No light reaches the floor from below the horizon (the ground patch, 0).
        assert!((0..c.sensors).all(|k| c.value[k * c.patches] == 0.0));
        assert_patch_sky(
            c,
            &smooth_patches(mf),
            &floor,
            mf,
            &format!("a smooth sky, MF:{mf} in {batches} batches"),
        );
    }
}

#[test]
fn patch_rounds_merge_and_the_same_seed_gives_the_same_coefficients_on_any_thread_count() {
    // Two rounds of MF:2's three batches: the second round's photons are new ones (its
    // errors shrink by about √2) and the merged coefficients still read the sky.
    let (_, c, floor) = patch_run(90, 2, 2, 0, &[60_000, 60_000]);
    assert_patch_sky(
        &c[1],
        &smooth_patches(2),
        &floor,
        2,
        "a smooth sky, MF:2, two rounds",
    );
    let mut ratios: Vec<f64> = c[0]
        .sigma
        .iter()
        .zip(&c[1].sigma)
        .filter(|(a, _)| **a > 0.0)
        .map(|(a, b)| b / a)
        .collect();
    ratios.sort_by(f64::total_cmp);
    let median = ratios[ratios.len() / 2];
    eprintln!(
        "σ after two rounds / after one: median {median:.3} over {}",
        ratios.len()
    );
    assert!((0.62..0.80).contains(&median), "median σ ratio {median}");
    // Thread counts change a coefficient only by the order of its sums.
    let (_, one, _) = patch_run(91, 1, 2, 0, &[20_000]);
    let (_, three, _) = patch_run(91, 3, 2, 0, &[20_000]);
    let (a, b) = (&one[0], &three[0]);
    let apart = |x: &[f64], y: &[f64]| {
        x.iter()
            .zip(y)
            .map(|(x, y)| (x - y).abs() / x.abs().max(1e-300))
            .fold(0.0f64, f64::max)
    };
    let (dv, ds) = (apart(&a.value, &b.value), apart(&a.sigma, &b.sigma));
    let lit = a.value.iter().filter(|&&x| x > 0.0).count();
    eprintln!("1 and 3 threads: {lit} coefficients lit, values {dv:.1e} apart, errors {ds:.1e}");
    assert!(lit > 1000 && dv < 1e-9 && ds < 1e-9, "{dv} {ds}");
}

#[test]
fn a_patch_run_refuses_what_it_cannot_do_and_keeps_the_context_usable() {
    use imap::annual::trace::{PatchRound, PatchRun, PatchTarget};
    use imap::ImapStatus::*;
    let (mut ctx, id, floor) = roof_room(95);
    let frame = ([0.0, 0.0, 1.0], [0.0, 1.0, 0.0]);
    let target = |vertices: Vec<usize>| PatchTarget {
        mesh: id,
        side: 0,
        vertices,
    };
    let all: Vec<usize> = (0..floor.vertex_count()).collect();
    let bad = [
        (
            PatchRun::new(&mut ctx, 2, frame, vec![target(all.clone())], 254).unwrap_err(),
            ImapErrInvalidArgument,
            "batch = 254",
        ),
        (
            PatchRun::new(&mut ctx, 0, frame, vec![target(all.clone())], 0).unwrap_err(),
            ImapErrInvalidArgument,
            "mf = 0",
        ),
        (
            PatchRun::new(&mut ctx, 2, frame, vec![target(vec![0, 99_999])], 0).unwrap_err(),
            ImapErrIndexOutOfRange,
            "targets[0].vertices[1] = 99999",
        ),
        (
            PatchRun::new(&mut ctx, 2, frame, vec![], 0).unwrap_err(),
            ImapErrInvalidArgument,
            "targets",
        ),
    ];
    for (e, status, text) in bad {
        assert_eq!(e.status, status, "{}", e.message);
        assert!(e.message.contains(text), "{}", e.message);
    }
    let mut run = PatchRun::new(&mut ctx, 2, frame, vec![target(all.clone())], 0).unwrap();
    let e = run
        .trace(&mut ctx, PatchRound::default(), &mut |_| true)
        .unwrap_err();
    assert_eq!(e.status, ImapErrInvalidArgument, "{}", e.message);
    // Before a round, and after one cancelled in its first batch, the patches of the
    // batches not reached are not known: refused, not zeros.
    let e = run.coefficients(0).unwrap_err();
    assert!(
        e.status == ImapErrOutOfOrder && e.message.contains("patches 0 … 252"),
        "{}",
        e.message
    );
    let round = PatchRound {
        photons: 30_000,
        ..Default::default()
    };
    let r = run.trace(&mut ctx, round, &mut |_| false).unwrap();
    assert!(r.cancelled && r.photons > 0, "{r:?}");
    let e = run.coefficients(0).unwrap_err();
    assert!(
        e.status == ImapErrOutOfOrder && e.message.contains("patches 253 … 505"),
        "{}",
        e.message
    );
    assert_eq!(
        run.coefficients(1).unwrap_err().status,
        ImapErrIndexOutOfRange
    );
    // The next round completes it; a context with photons is refused a new run.
    run.trace(&mut ctx, round, &mut |_| true).unwrap();
    assert!(run.coefficients(0).is_ok());
    let e = PatchRun::new(&mut ctx, 2, frame, vec![target(all.clone())], 0).unwrap_err();
    assert_eq!(e.status, ImapErrOutOfOrder, "{}", e.message);
    // Released, the context is the model again: no light, no photon; a new run may start.
    let got = run.release(&mut ctx).unwrap();
    assert_eq!(got.len(), 1);
    assert_eq!((ctx.light_count(), ctx.report().photons), (0, 0));
    let one_sided = PatchTarget {
        side: 1,
        ..target(all.clone())
    };
    let e = PatchRun::new(&mut ctx, 2, frame, vec![one_sided], 0).unwrap_err();
    assert_eq!(e.status, ImapErrIndexOutOfRange, "{}", e.message);
    PatchRun::new(&mut ctx, 2, frame, vec![target(all)], 0).unwrap();
}

#[test]
fn a_one_patch_sky_lights_through_a_portal_as_its_patch_with_every_estimator() {
    // A one-patch sky samples its patch alone, for photons, light samples and a portal's
    // photons (no cosine half: `DistantPart::mixes_cosine`): Tregenza patch 130 (66° high
    // to the south-east), through the roof opening declared a portal, reads its exact
    // floor values (quadrature over the opening) vertex by vertex with every estimator (a
    // density that mixed in the cosine half but drew the patch alone, or the reverse, is
    // off by a factor near 2). An MF:4 patch's few-centimetre spot on the floor needs a
    // finer quadrature than a test can pay for: its gathering errors of 0.1 % showed the
    // quadrature's 2 %.
    let portal: Vec<f64> = OPENING.iter().flatten().copied().collect();
    let tris = [0u32, 1, 2, 0, 2, 3];
    for (mf, p) in [(1u32, 130usize)] {
        let patches = imap::SkyPatches::reinhart(mf).unwrap();
        for (k, estimator) in ESTIMATORS.into_iter().enumerate() {
            let (mut ctx, id, floor) = roof_room(700 + 10 * mf as u64 + k as u64);
            ctx.add_sky(&SkyDesc {
                kind: SkyKind::single_patch(mf, p).unwrap(),
                amount: SkyAmount::Luminance(1000.0),
                spectrum: Spectrum::Equal,
                ..SkyDesc::default()
            })
            .unwrap();
            ctx.set_portals(&portal, &tris).unwrap();
            run_with(&mut ctx, photons(100_000), estimator);
            let band = 1000.0 / ctx.photometry().luminous(&[1.0, 1.0, 1.0]);
            let l = |d: [f64; 3]| {
                let alt = d[2].clamp(-1.0, 1.0).asin();
                if patches.patch(alt, d[0].atan2(d[1])) == p {
                    band
                } else {
                    0.0
                }
            };
            let want: Vec<Option<f64>> = (0..floor.vertex_count())
                .map(|v| {
                    Some(hat_average_with(&floor, v, 8, |x, _| {
                        through_opening(x, 24 * mf as usize, &l)
                    }))
                })
                .collect();
            let got = values(&ctx, id, 0);
            // The edge of the lit patch on the floor (a few per cent of the brightest
            // vertex's light) is a penumbra of few photons: not compared.
            let top = want.iter().flatten().fold(0.0f64, |a, &b| a.max(b));
            let want: Vec<Option<f64>> = want
                .into_iter()
                .map(|w| w.filter(|&w| w > 0.05 * top))
                .collect();
            assert_z(&got, &want, &format!("MF:{mf} patch {p}, {estimator:?}"));
        }
    }
}

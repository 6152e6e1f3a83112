//! Calculation surfaces and the figures read from them: sensor meshes (CIE 171 TC 5.3
//! through sensor grids; sensors change no other map), region results with their errors,
//! per-region stop criteria, light layers.

mod common;

use common::*;
use imap::{Config, Context, MeshDesc, SchedulerKind};
use std::f64::consts::PI;

/// A vertical grid on the plane x = `x` over y ∈ `y`, z ∈ `z`, normals +x.
fn wall_grid(nx: usize, nz: usize, x: f64, y: [f64; 2], z: [f64; 2]) -> Geometry {
    let g = grid_rect(nx, nz, y, z, x);
    // grid_rect lays (y, z, x) out as (x, y, z) with normal +z: rotate to (x, y, z) =
    // (z', x', y'), which keeps the winding and turns the normal to +x.
    let positions = g
        .positions
        .chunks_exact(3)
        .flat_map(|p| [p[2], p[0], p[1]])
        .collect();
    Geometry {
        positions,
        indices: g.indices,
    }
}

fn sensor_desc(g: &Geometry, two_sided: bool) -> MeshDesc<'_> {
    MeshDesc {
        sensor: true,
        two_sided,
        ..g.desc(0)
    }
}

#[test]
fn cie171_tc53_area_source_through_sensor_grids() {
    // CIE 171:2006 test case 5.3: a Lambertian square area source under the ceiling of a
    // 4 × 4 × 3 m room; the illuminance on the floor and on a wall is Lambert's polygon
    // formula. Here the source is 1 × 1 m at the centre, 3 m up, and the floor and the wall
    // x = 0 are sensor grids (0.5 m): nothing else is in the scene, so the light they
    // record is the direct light, and each vertex reads the formula averaged over its hat
    // function.
    let mut ctx = context(Config {
        threads: 2,
        seed: 53,
        ..Default::default()
    });
    let black = lambert(&mut ctx, 0.0);
    let floor = grid(8, 0.0, 4.0, 0.0, 4.0, 0.0);
    let wall = wall_grid(8, 6, 0.0, [0.0, 4.0], [0.0, 3.0]);
    let lamp = grid(2, 1.5, 2.5, 1.5, 2.5, 3.0).flipped();
    let m = 100.0; // W/m² per band
    let fid = ctx.add_mesh(&sensor_desc(&floor, false)).unwrap();
    let wid = ctx.add_mesh(&sensor_desc(&wall, false)).unwrap();
    ctx.add_mesh(&MeshDesc {
        record: false,
        exitance: Some(&[m]),
        ..lamp.desc(black)
    })
    .unwrap();
    run_photons(&mut ctx, photons(4_000_000));
    let square = [
        [1.5, 1.5, 3.0],
        [2.5, 1.5, 3.0],
        [2.5, 2.5, 3.0],
        [1.5, 2.5, 3.0],
    ];
    for (what, id, g, n) in [
        ("floor", fid, &floor, [0.0, 0.0, 1.0]),
        ("wall", wid, &wall, [1.0, 0.0, 0.0]),
    ] {
        let nv = g.vertex_count();
        let (mut e, mut err) = (vec![0.0; nv], vec![0.0; nv]);
        ctx.irradiance(id, 0, 1, &mut e).unwrap();
        ctx.rel_error(id, 0, &mut err).unwrap();
        let mut worst: f64 = 0.0;
        for v in 0..nv {
            let expected = hat_average(g, v, |x| polygon_irradiance(x, n, &square, m / PI));
            if expected < 1e-9 {
                continue;
            }
            let dev = (e[v] - expected).abs() / (err[v] * e[v]);
            worst = worst.max(dev);
            assert!(
                dev <= 4.0 && (e[v] / expected - 1.0).abs() < 0.05,
                "{what} vertex {:?}: {} vs {expected} ({dev:.2} σ, σ = {:.2} %)",
                g.vertex(v),
                e[v],
                100.0 * err[v]
            );
        }
        eprintln!("{what}: {nv} vertices within {worst:.2} σ of Lambert's formula");
    }
}

/// A grey room with a recording floor and a point light; `sensor` adds a two-sided sensor
/// grid across the room at 0.8 m.
fn room(scheduler: SchedulerKind, threads: usize, sensor: bool) -> (Context, Vec<u32>) {
    let mut ctx = context(Config {
        threads,
        seed: 7,
        scheduler,
        ..Default::default()
    });
    let grey = lambert(&mut ctx, 0.6);
    let walls = cuboid([0.0, 0.0, 0.0], [4.0, 3.0, 2.5], 4, true);
    let floor = grid_rect(8, 6, [0.0, 4.0], [0.0, 3.0], 0.01);
    let ids = vec![
        ctx.add_mesh(&walls.desc(grey)).unwrap(),
        ctx.add_mesh(&floor.desc(grey)).unwrap(),
    ];
    ctx.add_point_light([1.3, 1.1, 2.2], &[50.0, 40.0, 30.0])
        .unwrap();
    if sensor {
        let plane = grid_rect(8, 6, [0.0, 4.0], [0.0, 3.0], 0.8);
        ctx.add_mesh(&sensor_desc(&plane, true)).unwrap();
    }
    (ctx, ids)
}

fn maps(ctx: &Context, ids: &[u32]) -> Vec<f64> {
    let mut out = Vec::new();
    for &id in ids {
        let nv = ctx.vertex_count(id).unwrap();
        for b in 0..3 {
            let mut e = vec![0.0; nv];
            ctx.irradiance(id, 0, b, &mut e).unwrap();
            out.extend(e);
        }
    }
    out
}

#[test]
fn sensors_change_no_other_map() {
    // One thread and the classic scheduler add deposits in the same order: the maps are
    // bit for bit the same; with two threads and the dynamic scheduler, the same up to the
    // order of the additions.
    for (scheduler, threads, tol) in [
        (SchedulerKind::Classic, 1, 0.0),
        (SchedulerKind::Dynamic, 2, 1e-12),
    ] {
        let (mut a, ids) = room(scheduler, threads, false);
        let (mut b, _) = room(scheduler, threads, true);
        let ra = run_photons(&mut a, 200_000);
        let rb = run_photons(&mut b, 200_000);
        assert_eq!(ra.hits, rb.hits, "sensors are not hits");
        assert!(
            (ra.absorbed_w - rb.absorbed_w).abs() <= 1e-12 * ra.absorbed_w,
            "{} vs {}",
            ra.absorbed_w,
            rb.absorbed_w
        );
        let (ma, mb) = (maps(&a, &ids), maps(&b, &ids));
        for (x, y) in ma.iter().zip(&mb) {
            assert!(
                (x - y).abs() <= tol * x.abs().max(1e-300),
                "{scheduler:?}: {x} vs {y}"
            );
        }
        // The sensor itself recorded light on both sides.
        let nv = b.vertex_count(2).unwrap();
        for side in 0..2 {
            let mut e = vec![0.0; nv];
            b.irradiance(2, side, 0, &mut e).unwrap();
            assert!(e.iter().all(|x| *x > 0.0), "side {side}");
        }
    }
}

/// A black sensor plane 1 m under a 1000 lm point light (RGB bands of different power):
/// its incident flux and average illuminance against the solid angle it subtends, over
/// seeds: the stated errors match the spread.
#[test]
fn region_flux_and_average_have_calibrated_errors() {
    use imap::photometry::Spectrum;
    use imap::{Amount, LightDesc, LightKind};
    // The flux through a 2 × 2 square 1 m below an isotropic point: Φ · Ω / 4π, with
    // Ω = 4 atan(a² / (h √(2a² + h²))) for the half-side a = 1.
    let (a, h) = (1.0f64, 1.0f64);
    let omega = 4.0 * (a * a / (h * (2.0 * a * a + h * h).sqrt())).atan();
    let lm_expected = 1000.0 * omega / (4.0 * PI);
    let (mut z2_lm, mut z2_band, mut n_z) = (0.0, 0.0, 0);
    let seeds = 24;
    for seed in 0..seeds {
        let mut ctx = context(Config {
            threads: 2,
            seed,
            ..Default::default()
        });
        let plane = grid(8, -a, a, -a, a, 0.0);
        let id = ctx.add_mesh(&sensor_desc(&plane, false)).unwrap();
        let l = ctx
            .add_light_desc(&LightDesc {
                kind: LightKind::Point,
                position: [0.0, 0.0, h],
                amount: Amount::Lumens(1000.0),
                spectrum: Spectrum::Rgb([1.0, 0.6, 0.2]),
            })
            .unwrap();
        let watts: Vec<f64> = ctx.light_flux(l).unwrap().0.to_vec();
        run_photons(&mut ctx, 20_000);
        let s = ctx.region_stats(id, 0, None).unwrap();
        assert!((s.area_m2 - 4.0).abs() < 1e-12);
        z2_lm += ((s.flux_lm.value - lm_expected) / s.flux_lm.sigma).powi(2);
        for (b, w) in watts.iter().enumerate() {
            let expected = w * omega / (4.0 * PI);
            z2_band += ((s.flux_w[b].value - expected) / s.flux_w[b].sigma).powi(2);
            n_z += 1;
        }
        assert!((s.average.value - s.flux_lm.value / 4.0).abs() < 1e-9 * s.average.value);
    }
    let (rms_lm, rms_band) = ((z2_lm / seeds as f64).sqrt(), (z2_band / n_z as f64).sqrt());
    eprintln!("flux z-scores over {seeds} seeds: rms {rms_lm:.2} (lm), {rms_band:.2} (per band)");
    assert!(
        (0.6..1.5).contains(&rms_lm),
        "lm errors miscalibrated: rms z {rms_lm}"
    );
    assert!(
        (0.7..1.35).contains(&rms_band),
        "band errors miscalibrated: rms z {rms_band}"
    );
}

/// A 500 lx beam covering a sensor plane lights it uniformly: Emin = Emax = 500 lx and
/// U0 = Ud = 1. The raw minimum of the noisy vertices is far too low; the corrected figures
/// agree with the truth within their errors.
#[test]
fn a_uniform_field_reads_its_true_minimum_and_uniformity() {
    use imap::photometry::Spectrum;
    use imap::{Amount, LightDesc, LightKind};
    let (mut raw_low, mut within) = (0, 0);
    let seeds = 12;
    for seed in 0..seeds {
        let mut ctx = context(Config {
            threads: 2,
            seed: 100 + seed,
            ..Default::default()
        });
        let plane = grid(12, 0.0, 2.0, 0.0, 2.0, 0.0);
        let id = ctx.add_mesh(&sensor_desc(&plane, false)).unwrap();
        ctx.add_light_desc(&LightDesc {
            kind: LightKind::Beam {
                direction: [0.0, 0.0, -1.0],
                disk: false,
                size: [2.2, 2.2],
                up: [1.0, 0.0, 0.0],
            },
            position: [1.0, 1.0, 1.0],
            amount: Amount::Lux(500.0),
            spectrum: Spectrum::Equal,
        })
        .unwrap();
        // Photons only: the test is about the bias of the minimum of noisy values, and light
        // sampling leaves a uniform beam's field nearly without noise.
        run_photons_only(&mut ctx, 60_000);
        let s = ctx.region_stats(id, 0, None).unwrap();
        let e = s.extremes.unwrap();
        let z = |x: imap::Estimate, truth: f64| (x.value - truth).abs() / x.sigma;
        if e.min_observed < 500.0 - 2.0 * e.min.sigma {
            raw_low += 1;
        }
        if z(e.min, 500.0) < 3.0
            && z(e.max, 500.0) < 3.0
            && z(e.u0, 1.0) < 3.0
            && z(e.ud, 1.0) < 3.0
        {
            within += 1;
        }
        eprintln!(
            "seed {seed}: Eavg {:.1} ± {:.1}, Emin raw {:.1} corrected {:.1} ± {:.1}, Emax {:.1} ± {:.1}, U0 {:.3} ± {:.3}, Ud {:.3} ± {:.3}",
            s.average.value, s.average.sigma, e.min_observed, e.min.value, e.min.sigma,
            e.max.value, e.max.sigma, e.u0.value, e.u0.sigma, e.ud.value, e.ud.sigma
        );
    }
    assert!(
        raw_low >= seeds * 3 / 4,
        "the raw minimum was low in only {raw_low} of {seeds}"
    );
    assert!(
        within >= seeds - 2,
        "corrected figures within 3σ of the truth in {within} of {seeds}"
    );
}

/// Parts: a plane of two materials; the parts' fluxes add up to the mesh's.
#[test]
fn parts_add_up_to_their_mesh() {
    let mut ctx = context(Config {
        threads: 2,
        ..Default::default()
    });
    let m0 = lambert(&mut ctx, 0.3);
    let m1 = lambert(&mut ctx, 0.7);
    let g = grid(4, -1.0, 1.0, -1.0, 1.0, 0.0);
    let tm: Vec<u32> = (0..g.indices.len() / 3)
        .map(|t| if t % 8 < 4 { m0 } else { m1 })
        .collect();
    let id = ctx
        .add_mesh(&MeshDesc {
            triangle_materials: Some(&tm),
            tally: true,
            ..g.desc(m0)
        })
        .unwrap();
    ctx.add_point_light([0.2, 0.1, 1.0], &[10.0]).unwrap();
    let box_ = cuboid([-1.0, -1.0, -0.5], [1.0, 1.0, 1.5], 2, true);
    ctx.add_mesh(&MeshDesc {
        record: false,
        ..box_.desc(m1)
    })
    .unwrap();
    run_photons(&mut ctx, 100_000);
    let all = ctx.region_stats(id, 0, None).unwrap();
    let a = ctx.region_stats(id, 0, Some(m0)).unwrap();
    let b = ctx.region_stats(id, 0, Some(m1)).unwrap();
    assert!(all.exact_errors && a.exact_errors && b.exact_errors);
    assert!((a.area_m2 + b.area_m2 - all.area_m2).abs() < 1e-12);
    for k in 0..3 {
        let sum = a.flux_w[k].value + b.flux_w[k].value;
        assert!((sum - all.flux_w[k].value).abs() < 1e-9 * sum, "band {k}");
    }
    // The mesh's flux is the sum over its vertices of irradiance × vertex area.
    let nv = g.vertex_count();
    let (mut e, mut area) = (vec![0.0; nv], vec![0.0; nv]);
    ctx.irradiance(id, 0, 0, &mut e).unwrap();
    ctx.vertex_areas(id, &mut area).unwrap();
    let from_vertices: f64 = e.iter().zip(&area).map(|(e, a)| e * a).sum();
    // To the rounding of the buffered colours (f32): a bounce that keeps a share of the
    // photon (light sampling) leaves colours that f32 does not hold exactly.
    assert!(
        (from_vertices / all.flux_w[0].value - 1.0).abs() < 1e-7,
        "{from_vertices} vs {}",
        all.flux_w[0].value
    );
    let e = ctx.region_stats(id, 0, Some(99)).unwrap_err();
    assert_eq!(e.status, imap::ImapStatus::ImapErrIndexOutOfRange);
}

/// A region target stops the run at the first progress tick where its measure is at the
/// target — not before (the previous tick was above it), not later — for each measure and
/// both schedulers, and the figures read afterwards agree with it.
#[test]
fn a_region_target_stops_within_one_progress_interval() {
    use imap::StopReason;
    use imap::{RegionMeasure, RegionTarget};
    let cases = [
        (RegionMeasure::Vertices { percentile: 100.0 }, 0.04),
        (RegionMeasure::Vertices { percentile: 90.0 }, 0.03),
        (RegionMeasure::Average, 0.004),
        (RegionMeasure::Uniformity, 0.02),
    ];
    for scheduler in [SchedulerKind::Classic, SchedulerKind::Dynamic] {
        for (measure, target) in cases {
            let (mut ctx, _) = room(scheduler, 2, true);
            let plane = 2; // the sensor grid
            let mut params = imap::RunParams {
                region: Some(RegionTarget {
                    meshes: vec![plane],
                    part: None,
                    measure,
                    target,
                }),
                photons: 0,
                time_budget_s: 60.0,
                target_rel_error: 0.0,
                progress_interval_s: 0.02,
                max_path_events: 1 << 20,
                selection: Default::default(),
                estimator: None,
                progress: None,
            };
            let r = ctx.run(&mut params).unwrap();
            let what = format!("{scheduler:?} {measure:?} {target}");
            assert_eq!(r.stop, Some(StopReason::RegionTarget), "{what}");
            let h = ctx.history();
            // The last point is the run's end; the one before it the tick that stopped it.
            let (before, stop) = (h[h.len() - 3], h[h.len() - 2]);
            assert!(stop.region_rel_error <= target, "{what}: {stop:?}");
            assert!(before.region_rel_error > target, "{what}: {before:?}");
            // Read back: the same measure from the map and the region figures.
            let end = h[h.len() - 1].region_rel_error;
            let mut rel = vec![0.0; ctx.vertex_count(plane as u32).unwrap()];
            let s = |side| ctx.region_stats(plane as u32, side, None).unwrap();
            let read = match measure {
                RegionMeasure::Vertices { percentile } => {
                    let mut all = Vec::new();
                    for side in 0..2 {
                        ctx.rel_error(plane as u32, side, &mut rel).unwrap();
                        all.extend_from_slice(&rel);
                    }
                    all.sort_by(f64::total_cmp);
                    let rank = (percentile / 100.0 * all.len() as f64).ceil() as usize;
                    all[rank - 1]
                }
                RegionMeasure::Average => (0..2)
                    .map(|side| s(side).average.sigma / s(side).average.value)
                    .fold(0.0, f64::max),
                RegionMeasure::Uniformity => (0..2)
                    .map(|side| {
                        let u0 = s(side).extremes.unwrap().u0;
                        u0.sigma / u0.value
                    })
                    .fold(0.0, f64::max),
            };
            eprintln!(
                "{what}: stopped at {:.4} after {} photons (previous tick {:.4}), end {end:.4}, read back {read:.4}",
                stop.region_rel_error, stop.photons, before.region_rel_error
            );
            assert!(
                (read / end - 1.0).abs() < 1e-9,
                "{what}: the run's measure {end} and the map's {read} differ"
            );
            assert!(read <= target * 1.1, "{what}: read back {read}");
        }
    }
}

/// A grey box (4 × 3 × 2.5 m, ρ = 0.6, recorded or not) under a point light with a tallied
/// floor just above its own (grey) or a sensor grid at 0.8 m: the context and the floor's id.
fn box_with_floor(threads: usize, seed: u64, record_walls: bool, sensor: bool) -> (Context, u32) {
    let mut ctx = context(Config {
        threads,
        seed,
        ..Default::default()
    });
    let grey = lambert(&mut ctx, 0.6);
    let walls = cuboid([0.0, 0.0, 0.0], [4.0, 3.0, 2.5], 4, true);
    ctx.add_mesh(&MeshDesc {
        record: record_walls,
        ..walls.desc(grey)
    })
    .unwrap();
    let z = if sensor { 0.8 } else { 0.01 };
    let g = grid_rect(8, 6, [0.0, 4.0], [0.0, 3.0], z);
    let id = ctx
        .add_mesh(&MeshDesc {
            sensor,
            tally: true,
            ..g.desc(if sensor { 0 } else { grey })
        })
        .unwrap();
    ctx.add_point_light([1.3, 1.1, 2.2], &[50.0, 40.0, 30.0])
        .unwrap();
    (ctx, id)
}

/// With light sampling a region's average and uniformity hold its vertices' direct passes:
/// the run's region measure and the figures read afterwards (`region_stats`) must take the
/// same part. (The run's measure read the photons' tallies alone: 0.0042 against the
/// figures' 0.0031 on this floor, and a direct part of larger error than the photons'
/// would have stopped a run before its target was reached.)
#[test]
fn region_targets_measure_the_direct_part_as_the_figures_read_it() {
    use imap::Estimator;
    use imap::{RegionMeasure, RegionTarget};
    let estimators = [
        Estimator::LightSampling {
            samples: 0,
            pass_photons: 0,
            gather: false,
        },
        Estimator::LightSampling {
            samples: 0,
            pass_photons: 0,
            gather: true,
        },
    ];
    for est in estimators {
        for sensor in [false, true] {
            for measure in [RegionMeasure::Average, RegionMeasure::Uniformity] {
                let (mut ctx, id) = box_with_floor(2, 7, true, sensor);
                let mut params = imap::RunParams {
                    region: Some(RegionTarget {
                        meshes: vec![id as usize],
                        part: None,
                        measure,
                        target: 1e-9,
                    }),
                    photons: 60_000,
                    estimator: Some(est),
                    ..Default::default()
                };
                ctx.run(&mut params).unwrap();
                let h = ctx.history();
                let end = h[h.len() - 1].region_rel_error;
                let s = ctx.region_stats(id, 0, None).unwrap();
                let read = match measure {
                    RegionMeasure::Uniformity => {
                        let u0 = s.extremes.unwrap().u0;
                        u0.sigma / u0.value
                    }
                    _ => s.average.sigma / s.average.value,
                };
                let what = format!("{est:?}, sensor {sensor}, {measure:?}");
                assert!(
                    (end / read - 1.0).abs() < 1e-9,
                    "{what}: the run's measure {end} and the figures' {read} differ"
                );
            }
        }
    }
}

/// A region whose vertices have not all had their first direct pass has no known average:
/// its measure reads as no data (1), not as the part known so far. The floor (63 vertices,
/// 4 chunks of passes) is the only recorded mesh and photon j < C does pass 0 of chunk j,
/// so after 2 photons half its vertices have their direct light and half wait.
#[test]
fn a_region_waiting_for_its_direct_passes_has_no_measure_yet() {
    use imap::{RegionMeasure, RegionTarget};
    let run = |photons: u64| {
        let (mut ctx, id) = box_with_floor(1, 3, false, false);
        let mut params = imap::RunParams {
            region: Some(RegionTarget {
                meshes: vec![id as usize],
                part: None,
                measure: RegionMeasure::Average,
                target: 1e-9,
            }),
            photons,
            ..Default::default()
        };
        ctx.run(&mut params).unwrap();
        let h = ctx.history();
        let s = ctx.region_stats(id, 0, None).unwrap();
        (h[h.len() - 1].region_rel_error, s)
    };
    let (early, s) = run(2);
    // The figures read what is known: some of the floor's direct light.
    assert!(s.average.value > 0.0, "{s:?}");
    assert_eq!(
        early, 1.0,
        "a region waiting for direct passes has a measure"
    );
    let (late, s) = run(20_000);
    assert!(late > 0.0 && late < 0.1, "{late}");
    assert!((late / (s.average.sigma / s.average.value) - 1.0).abs() < 1e-9);
}

//! Light-group layers and the direct layer: the layers sum to the combined map, a dimmed
//! recombination agrees with a rerun at the dimmed powers, the direct layer is the
//! first-surface light (analytic under a point light), and the memory is paid only on
//! request.

mod common;

use common::*;
use imap::{Config, Context, ImapStatus, Layer, LayerRequest, MeshDesc, SchedulerKind};
use std::f64::consts::PI;

const BOX: ([f64; 3], [f64; 3]) = ([0.0, 0.0, 0.0], [2.0, 2.0, 2.0]);

/// A closed grey box (ρ = 0.5, recorded, 8 × 8 cells a face) lit by two point lights and an
/// emitting panel under the ceiling; `scale` multiplies each emitter's power. Returns the
/// context and the box's mesh id.
fn lit_box(config: Config, scale: [f64; 3], groups: Option<[u32; 3]>) -> (Context, u32) {
    let mut ctx = context(config);
    let grey = lambert(&mut ctx, 0.5);
    let black = lambert(&mut ctx, 0.0);
    let walls = cuboid(BOX.0, BOX.1, 8, true);
    let id = ctx.add_mesh(&walls.desc(grey)).unwrap();
    let panel = grid(1, 0.8, 1.2, 0.8, 1.2, 1.95).flipped();
    let exitance = [200.0 * scale[2], 150.0 * scale[2], 100.0 * scale[2]];
    let pid = ctx
        .add_mesh(&MeshDesc {
            record: false,
            exitance: Some(&exitance),
            ..panel.desc(black)
        })
        .unwrap();
    let a = ctx
        .add_point_light([0.5, 0.5, 1.0], &[10.0 * scale[0]; 3])
        .unwrap();
    let b = ctx
        .add_point_light(
            [1.5, 1.4, 0.6],
            &[4.0 * scale[1], 8.0 * scale[1], 12.0 * scale[1]],
        )
        .unwrap();
    if let Some([ga, gb, gp]) = groups {
        ctx.set_layers(LayerRequest {
            groups: true,
            direct: true,
        })
        .unwrap();
        ctx.set_light_group(a, ga).unwrap();
        ctx.set_light_group(b, gb).unwrap();
        ctx.set_mesh_light_group(pid, gp).unwrap();
    }
    (ctx, id)
}

fn read(ctx: &Context, id: u32, layer: Layer) -> (Vec<[f64; 3]>, Vec<f64>) {
    let nv = ctx.vertex_count(id).unwrap();
    let mut bands = vec![[0.0; 3]; nv];
    let mut e = vec![0.0; nv];
    for b in 0..3 {
        ctx.irradiance_layer(id, 0, b, layer, &mut e).unwrap();
        bands
            .iter_mut()
            .zip(&e)
            .for_each(|(x, v)| x[b as usize] = *v);
    }
    let mut rel = vec![0.0; nv];
    ctx.rel_error_layer(id, 0, layer, &mut rel).unwrap();
    (bands, rel)
}

#[test]
fn group_layers_sum_to_the_combined_map_and_change_nothing_else() {
    let n = photons(400_000);
    let config = |scheduler, threads| Config {
        threads,
        seed: 7,
        scheduler,
        ..Default::default()
    };
    // Groups 0, 2 and 1: ids need not follow the order lights were added in.
    let (mut ctx, id) = lit_box(config(SchedulerKind::Dynamic, 2), [1.0; 3], Some([0, 2, 1]));
    assert_eq!(ctx.layers(), (3, true));
    run_photons(&mut ctx, n);
    let (combined, _) = read(&ctx, id, Layer::Combined);
    let layers: Vec<_> = (0..3).map(|g| read(&ctx, id, Layer::Group(g)).0).collect();
    let mut nonzero = [0usize; 3];
    for (v, c) in combined.iter().enumerate() {
        for b in 0..3 {
            let sum: f64 = layers.iter().map(|l| l[v][b]).sum();
            assert!(
                (sum - c[b]).abs() <= 1e-12 * c[b].abs(),
                "vertex {v} band {b}: layers sum to {sum}, combined {}",
                c[b]
            );
        }
        for (g, l) in layers.iter().enumerate() {
            nonzero[g] += usize::from(l[v][0] > 0.0);
        }
    }
    // Every group lights the box.
    assert!(
        nonzero.iter().all(|&k| k > combined.len() / 2),
        "{nonzero:?}"
    );

    // The same photons without layers, and with layers on the classic scheduler: the
    // same map (to rounding: the layers only group the same additions differently).
    let (mut plain, pid) = lit_box(config(SchedulerKind::Classic, 1), [1.0; 3], None);
    assert_eq!(plain.layers(), (0, false));
    run_photons(&mut plain, n);
    let (mut classic, cid) = lit_box(config(SchedulerKind::Classic, 3), [1.0; 3], Some([0, 2, 1]));
    run_photons(&mut classic, n);
    for (other, oid, what) in [(&plain, pid, "without layers"), (&classic, cid, "classic")] {
        let (o, rel_o) = read(other, oid, Layer::Combined);
        let (_, rel_c) = read(&ctx, id, Layer::Combined);
        for v in 0..o.len() {
            for b in 0..3 {
                assert!(
                    (o[v][b] - combined[v][b]).abs() <= 1e-12 * combined[v][b].abs(),
                    "{what}: vertex {v} band {b}: {} vs {}",
                    o[v][b],
                    combined[v][b]
                );
            }
            assert!(
                (rel_o[v] - rel_c[v]).abs() <= 1e-9 * rel_c[v],
                "{what}: error of vertex {v}"
            );
        }
    }
    // Memory: four cells a slot (three groups and the direct layer) against one.
    assert_eq!(ctx.report().map_bytes, 4 * plain.report().map_bytes);
    assert_eq!(classic.report().map_bytes, ctx.report().map_bytes);
}

#[test]
fn a_dimmed_recombination_equals_a_rerun_at_the_dimmed_powers() {
    let dim = [1.0, 0.25, 2.0];
    let n = photons(600_000);
    let config = |seed| Config {
        threads: 2,
        seed,
        ..Default::default()
    };
    let (mut layered, id) = lit_box(config(26), [1.0; 3], Some([0, 1, 2]));
    run_photons(&mut layered, n);
    let (mut rerun, rid) = lit_box(config(126), dim, None);
    run_photons(&mut rerun, n);
    let mut areas = vec![0.0; layered.vertex_count(id).unwrap()];
    layered.vertex_areas(id, &mut areas).unwrap();
    // Band means and their standard errors. The recombination's error follows from the
    // layers' own: every photon belongs to one group, so with c²Q_g = σ_g² + E_g²/N (c the
    // conversion to W/m², Q the sum of squared photon contributions),
    // σ² = Σ d_g² c²Q_g − (Σ d_g E_g)²/N.
    let mean = |x: &[f64; 3]| (x[0] + x[1] + x[2]) / 3.0;
    let layers: Vec<_> = (0..3)
        .map(|g| read(&layered, id, Layer::Group(g)))
        .collect();
    let (other, rel_r) = read(&rerun, rid, Layer::Combined);
    let nf = n as f64;
    let (mut z2, mut zsum, mut count) = (0.0, 0.0, 0);
    let (mut flux_l, mut flux_r) = (0.0, 0.0);
    for v in 0..areas.len() {
        let (mut e, mut q) = (0.0, 0.0);
        for (g, (vals, rel)) in layers.iter().enumerate() {
            let eg = mean(&vals[v]);
            let sg = rel[v] * eg;
            e += dim[g] * eg;
            q += dim[g] * dim[g] * (sg * sg + eg * eg / nf);
        }
        let sigma = (q - e * e / nf).max(0.0).sqrt();
        let r = mean(&other[v]);
        let sr = rel_r[v] * r;
        flux_l += e * areas[v];
        flux_r += r * areas[v];
        if e > 0.0 && r > 0.0 {
            let z = (e - r) / (sigma * sigma + sr * sr).sqrt();
            z2 += z * z;
            zsum += z;
            count += 1;
        }
    }
    let rms = (z2 / count as f64).sqrt();
    let mean_z = zsum / count as f64;
    eprintln!(
        "dimmed recombination vs rerun over {count} vertices: z RMS {rms:.3}, mean {mean_z:.3}; flux {flux_l:.4} vs {flux_r:.4} W"
    );
    assert!(count > 350, "{count} vertices compared");
    assert!((0.75..1.3).contains(&rms), "z RMS {rms}");
    assert!(mean_z.abs() < 0.25, "mean z {mean_z}");
    assert!(
        (flux_l / flux_r - 1.0).abs() < 0.01,
        "flux {flux_l} vs {flux_r}"
    );
}

#[test]
fn the_direct_layer_is_the_light_before_the_first_surface_event() {
    // A point light 2 m over a grey floor, a two-sided sensor between them: nothing sends
    // light back to the floor, so everything the floor receives is direct (the direct layer
    // equals the combined map), and so is what the sensor's top receives; its underside
    // sees only the floor's reflection (an empty direct layer). The floor reads I cos θ/r².
    let mut ctx = context(Config {
        threads: 2,
        seed: 3,
        ..Default::default()
    });
    let grey = lambert(&mut ctx, 0.6);
    let floor = grid(10, -2.0, 2.0, -2.0, 2.0, 0.0);
    let sensor = grid(4, -0.5, 0.5, -0.5, 0.5, 1.0);
    let fid = ctx.add_mesh(&floor.desc(grey)).unwrap();
    let sid = ctx
        .add_mesh(&MeshDesc {
            sensor: true,
            two_sided: true,
            ..sensor.desc(0)
        })
        .unwrap();
    let watts = 100.0;
    ctx.add_point_light([0.0, 0.0, 2.0], &[watts]).unwrap();
    ctx.set_layers(LayerRequest {
        groups: false,
        direct: true,
    })
    .unwrap();
    assert_eq!(ctx.layers(), (0, true));
    let e = ctx.irradiance_layer(fid, 0, 0, Layer::Group(0), &mut [0.0; 121]);
    assert_eq!(e.unwrap_err().status, ImapStatus::ImapErrNotRecorded);
    run_photons(&mut ctx, photons(2_000_000));

    let get = |id: u32, side: u32, layer: Layer, nv: usize| {
        let mut e = vec![0.0; nv];
        ctx.irradiance_layer(id, side, 0, layer, &mut e).unwrap();
        e
    };
    let nf = floor.vertex_count();
    let (all, direct) = (
        get(fid, 0, Layer::Combined, nf),
        get(fid, 0, Layer::Direct, nf),
    );
    let mut rel = vec![0.0; nf];
    ctx.rel_error_layer(fid, 0, Layer::Direct, &mut rel)
        .unwrap();
    let intensity = watts / (4.0 * PI);
    let mut worst: f64 = 0.0;
    for v in 0..nf {
        assert!(
            (all[v] - direct[v]).abs() <= 1e-12 * all[v],
            "floor vertex {v}: direct {} vs all {}",
            direct[v],
            all[v]
        );
        let expected = hat_average(&floor, v, |p| {
            let r2 = p[0] * p[0] + p[1] * p[1] + 4.0;
            intensity * 2.0 / r2.powf(1.5)
        });
        let z = (direct[v] - expected).abs() / (rel[v] * direct[v]);
        worst = worst.max(z);
    }
    eprintln!("direct layer on the floor vs I cos θ / r²: worst {worst:.2} σ");
    assert!(worst < 4.5, "worst {worst} σ");

    let ns = sensor.vertex_count();
    let (top, top_direct) = (
        get(sid, 0, Layer::Combined, ns),
        get(sid, 0, Layer::Direct, ns),
    );
    let (under, under_direct) = (
        get(sid, 1, Layer::Combined, ns),
        get(sid, 1, Layer::Direct, ns),
    );
    for v in 0..ns {
        // The top is the front (normal +z): light from the lamp arrives there first.
        assert!(
            (top[v] - top_direct[v]).abs() <= 1e-12 * top[v],
            "sensor top {v}"
        );
        assert!(under[v] > 0.0, "sensor underside {v} sees the floor");
        assert_eq!(
            under_direct[v], 0.0,
            "sensor underside {v}: no direct light"
        );
    }
}

#[test]
fn layer_settings_are_checked() {
    let (mut ctx, id) = lit_box(Config::default(), [1.0; 3], None);
    let status = |r: imap::Result<()>| r.unwrap_err().status;
    assert_eq!(
        status(ctx.set_light_group(9, 0)),
        ImapStatus::ImapErrIndexOutOfRange
    );
    assert_eq!(
        status(ctx.set_light_group(0, 254)),
        ImapStatus::ImapErrInvalidArgument
    );
    // Mesh 0 is the box: it does not emit.
    assert_eq!(
        status(ctx.set_mesh_light_group(0, 1)),
        ImapStatus::ImapErrInvalidArgument
    );
    ctx.set_light_group(0, 253).unwrap();
    // Groups not kept: the group ids change nothing.
    assert_eq!(ctx.layers(), (0, false));
    ctx.set_layers(LayerRequest {
        groups: true,
        direct: false,
    })
    .unwrap();
    assert_eq!(ctx.layers(), (254, false));
    ctx.set_light_group(0, 0).unwrap();
    ctx.set_light_group(1, 1).unwrap();
    assert_eq!(ctx.layers(), (2, false));
    run_photons(&mut ctx, 10_000);
    let mut out = vec![0.0; ctx.vertex_count(id).unwrap()];
    assert_eq!(
        status(ctx.irradiance_layer(id, 0, 0, Layer::Group(2), &mut out)),
        ImapStatus::ImapErrIndexOutOfRange
    );
    assert_eq!(
        status(ctx.irradiance_layer(id, 0, 0, Layer::Direct, &mut out)),
        ImapStatus::ImapErrNotRecorded
    );
    assert_eq!(
        status(ctx.set_light_group(0, 1)),
        ImapStatus::ImapErrOutOfOrder
    );
    assert_eq!(
        status(ctx.set_layers(LayerRequest::default())),
        ImapStatus::ImapErrOutOfOrder
    );
    // The map and what it holds are untouched by the refused calls.
    let before = out.clone();
    ctx.irradiance_layer(id, 0, 0, Layer::Group(1), &mut out)
        .unwrap();
    assert!(out.iter().any(|&x| x > 0.0));
    ctx.irradiance(id, 0, 0, &mut out).unwrap();
    assert_ne!(before, out);
}

#[test]
fn many_layers_over_the_memory_budget_are_refused() {
    let (mut ctx, _) = lit_box(
        Config {
            memory_budget: 3 << 20,
            ..Default::default()
        },
        [1.0; 3],
        None,
    );
    ctx.set_layers(LayerRequest {
        groups: true,
        direct: true,
    })
    .unwrap();
    // 486 slots × 32 bytes a cell: 255 layers need 4 MB.
    let status = ctx.set_light_group(0, 253).unwrap_err().status;
    assert_eq!(status, ImapStatus::ImapErrMemoryBudget);
    assert_eq!(ctx.layers(), (1, true));
    ctx.set_light_group(0, 20).unwrap();
    assert_eq!(ctx.layers(), (21, true));
}

/// A grey room (4 × 4 × 3 m, not recorded) over a tallied floor (12 × 12 cells, ρ = 0.3),
/// lit by lamp A (60 W, group 0) and lamp B (25 W, group 1), each if `lamps` says so;
/// groups and the direct layer kept when `layers`. Returns the context and the floor's id.
fn two_lamp_room(seed: u64, lamps: [bool; 2], layers: bool) -> (Context, u32) {
    let mut ctx = context(seeded(seed));
    let walls = lambert(&mut ctx, 0.5);
    let grey = lambert(&mut ctx, 0.3);
    let room = cuboid([0.0, 0.0, -0.01], [4.0, 4.0, 3.0], 6, true);
    ctx.add_mesh(&MeshDesc {
        record: false,
        ..room.desc(walls)
    })
    .unwrap();
    let floor = grid(12, 0.0, 4.0, 0.0, 4.0, 0.0);
    let id = ctx
        .add_mesh(&MeshDesc {
            tally: true,
            ..floor.desc(grey)
        })
        .unwrap();
    if layers {
        ctx.set_layers(LayerRequest {
            groups: true,
            direct: true,
        })
        .unwrap();
    }
    for (k, (p, w)) in LAMPS.iter().enumerate() {
        if lamps[k] {
            let l = ctx.add_point_light(*p, &[*w]).unwrap();
            if layers {
                ctx.set_light_group(l, k as u32).unwrap();
            }
        }
    }
    (ctx, id)
}

const LAMPS: [([f64; 3], f64); 2] = [([1.0, 1.0, 2.2], 60.0), ([3.2, 3.0, 2.5], 25.0)];

/// Solid angle of the rectangle [x0, x1] × [y0, y1] at z = 0 seen from `p` above it.
fn rectangle_solid_angle(p: [f64; 3], [x0, x1]: [f64; 2], [y0, y1]: [f64; 2]) -> f64 {
    // The four rectangles with a corner under p: atan(ab / (h √(a² + b² + h²))) each.
    let h = p[2];
    let corner = |a: f64, b: f64| (a * b / (h * (a * a + b * b + h * h).sqrt())).atan();
    let (ax, bx) = (p[0] - x0, x1 - p[0]);
    let (ay, by) = (p[1] - y0, y1 - p[1]);
    corner(ax, ay) + corner(ax, by) + corner(bx, ay) + corner(bx, by)
}

#[test]
fn a_layers_region_figures_have_exact_errors_and_agree_with_a_separate_run() {
    // Per-layer Eavg, Emin and U0 from one run: lamp A's layer of a run with
    // both lamps against a run of lamp A alone, and the direct layer's floor flux against
    // Φ Ω / 4π of each lamp; the group layers' fluxes sum to the floor's.
    let n = photons(600_000);
    let estimators = [
        imap::Estimator::Photons,
        imap::Estimator::LightSampling {
            samples: 0,
            pass_photons: 0,
            gather: false,
        },
    ];
    for e in estimators {
        let (mut both, id) = two_lamp_room(11, [true, true], true);
        run_with(&mut both, n, e);
        let (mut alone, aid) = two_lamp_room(12, [true, false], false);
        run_with(&mut alone, n, e);
        let stats =
            |c: &Context, id: u32, layer: Layer| c.region_stats_layer(id, 0, None, layer).unwrap();
        let all = stats(&both, id, Layer::Combined);
        let [a, b, direct] =
            [Layer::Group(0), Layer::Group(1), Layer::Direct].map(|l| stats(&both, id, l));
        let sep = stats(&alone, aid, Layer::Combined);
        assert!(a.exact_errors && direct.exact_errors && sep.exact_errors);
        let sum = a.flux_lm.value + b.flux_lm.value;
        assert!(
            (sum - all.flux_lm.value).abs() <= 1e-9 * all.flux_lm.value,
            "{e:?}: groups {sum} lm vs {} lm",
            all.flux_lm.value
        );
        assert!(all.flux_lm.sigma < a.flux_lm.sigma + b.flux_lm.sigma);
        let agree = |what: &str, x: imap::Estimate, y: imap::Estimate| {
            let z = (x.value - y.value).abs() / x.sigma.hypot(y.sigma);
            eprintln!(
                "{e:?} {what}: layer {:.4} ± {:.4}, alone {:.4} ± {:.4} ({z:.2} σ)",
                x.value, x.sigma, y.value, y.sigma
            );
            assert!(x.sigma > 0.0 && z < 4.0, "{e:?} {what}: {z} σ apart");
        };
        agree("Eavg", a.average, sep.average);
        let (xa, xs) = (a.extremes.unwrap(), sep.extremes.unwrap());
        agree("Emin", xa.min, xs.min);
        agree("U0", xa.u0, xs.u0);
        // Direct flux: photons' tallies are exact; light sampling's is summed from the
        // vertices (hat functions: a discretisation bias of a few 0.1 %).
        let analytic: f64 = LAMPS
            .iter()
            .map(|(p, w)| w / (4.0 * PI) * rectangle_solid_angle(*p, [0.0, 4.0], [0.0, 4.0]))
            .sum();
        let d = direct.flux_w[0];
        let z = (d.value - analytic).abs() / d.sigma;
        eprintln!(
            "{e:?} direct: {:.4} ± {:.4} W vs {analytic:.4} W ({z:.2} σ)",
            d.value, d.sigma
        );
        match e {
            imap::Estimator::Photons => assert!(z < 4.0, "direct {z} σ"),
            _ => assert!((d.value - analytic).abs() < 4.0 * d.sigma + 5e-3 * analytic),
        }
    }
}

#[test]
fn a_layers_region_error_is_the_spread_of_its_runs() {
    // The promise per value: lamp B's layer flux on the floor over 16 seeds spreads as its
    // stated σ says (a layer read from the combined tallies would state the whole floor's).
    let runs: Vec<imap::Estimate> = (0..16)
        .map(|s| {
            let (mut ctx, id) = two_lamp_room(100 + s, [true, true], true);
            run_photons_only(&mut ctx, photons(30_000));
            ctx.region_stats_layer(id, 0, None, Layer::Group(1))
                .unwrap()
                .flux_lm
        })
        .collect();
    let k = runs.len() as f64;
    let mean = runs.iter().map(|r| r.value).sum::<f64>() / k;
    let spread = (runs.iter().map(|r| (r.value - mean).powi(2)).sum::<f64>() / (k - 1.0)).sqrt();
    let stated = (runs.iter().map(|r| r.sigma * r.sigma).sum::<f64>() / k).sqrt();
    eprintln!("lamp B's floor flux {mean:.2} lm: spread {spread:.3}, stated σ {stated:.3}");
    assert!(
        spread > 0.6 * stated && spread < 1.6 * stated,
        "spread {spread} vs stated {stated}"
    );
}

//! The generated benchmark scenes: their statistics follow the paper's at a given scale,
//! they run, close their energy balance and agree between schedulers.

#[path = "../examples/common/scenes.rs"]
mod scenes;

mod common;

use common::*;
use imap::Config;
use imap::DynamicParams;
use imap::SchedulerKind;
use scenes::{build, SceneKind};

#[test]
fn scenes_have_the_paper_statistics_and_run() {
    let scale = 0.01;
    for kind in SceneKind::ALL {
        let mut ctx = context(Config {
            threads: 2,
            seed: 4,
            ..Default::default()
        });
        let b = build(&mut ctx, kind, scale).unwrap();
        let (objects, triangles, parts, vertices, lights) = kind.paper();
        let tri_ratio = b.triangles as f64 / (triangles as f64 * scale);
        let vert_ratio = b.vertices as f64 / (vertices as f64 * scale);
        eprintln!(
            "{:10} objects {:5} (paper {objects}), triangles {:7} ({tri_ratio:.2} of scaled paper), vertices {:7} ({vert_ratio:.2}), parts {}, lights {}",
            kind.name(),
            b.objects,
            b.triangles,
            b.vertices,
            b.parts,
            b.lights
        );
        assert!(
            (0.7..1.4).contains(&tri_ratio),
            "{}: {} triangles",
            kind.name(),
            b.triangles
        );
        assert!(
            (0.6..1.5).contains(&vert_ratio),
            "{}: {} vertices",
            kind.name(),
            b.vertices
        );
        assert_eq!(b.lights, lights);
        if kind != SceneKind::Hall {
            assert_eq!(b.objects, objects);
            assert_eq!(b.parts, parts);
        }
        let r = run_photons(&mut ctx, 20_000);
        // Vehicle is an open scene lit by its HDR environment as in the paper: many
        // photons escape, so ask only that most of the work is tracing.
        assert!(r.hits > 5_000, "{}: {} hits", kind.name(), r.hits);
        assert!(
            (r.absorbed_w + r.escaped_w + r.dropped_w - r.emitted_w).abs() <= 1e-9 * r.emitted_w
        );
    }
}

#[test]
fn dispersion_scene_concentrates_photons_on_the_screen() {
    let bands = imap::Bands::spectral(41, 380.0, 780.0).unwrap();
    let mut ctx = context(Config {
        threads: 2,
        seed: 4,
        bands,
        ..Default::default()
    });
    let b = build(&mut ctx, SceneKind::Dispersion, 0.005).unwrap();
    run_photons(&mut ctx, 100_000);
    // The screen (mesh 0) holds about half the vertices; the bright part of it is small.
    let screen = b.meshes[0];
    let n = ctx.vertex_count(screen).unwrap();
    let mut e = vec![0.0; n];
    ctx.irradiance(screen, 0, 20, &mut e).unwrap();
    let mut sorted = e.clone();
    sorted.sort_by(|a, b| b.partial_cmp(a).unwrap());
    let total: f64 = sorted.iter().sum();
    let top: f64 = sorted[..n / 20].iter().sum();
    eprintln!(
        "screen: {n} vertices; the brightest 5 % hold {:.0} % of the irradiance",
        100.0 * top / total
    );
    assert!(
        top > 0.5 * total,
        "the spectrum is not concentrated: {:.2}",
        top / total
    );
    // Red and blue land in different places: the prism disperses.
    let mut red = vec![0.0; n];
    let mut blue = vec![0.0; n];
    ctx.irradiance(screen, 0, 35, &mut red).unwrap();
    ctx.irradiance(screen, 0, 5, &mut blue).unwrap();
    let argmax = |v: &[f64]| {
        v.iter()
            .enumerate()
            .max_by(|a, b| a.1.partial_cmp(b.1).unwrap())
            .unwrap()
            .0
    };
    assert_ne!(argmax(&red), argmax(&blue));
}

#[test]
fn schedulers_agree_on_a_generated_scene() {
    let bands = imap::Bands::spectral(41, 380.0, 780.0).unwrap();
    let maps: Vec<Vec<f64>> = [SchedulerKind::Classic, SchedulerKind::Dynamic]
        .into_iter()
        .map(|s| {
            let dp = DynamicParams {
                low_threshold: usize::MAX,
                high_threshold: 0,
                min_group_slots: 16,
                ..Default::default()
            };
            let mut ctx = context(Config {
                threads: 2,
                seed: 4,
                scheduler: s,
                dynamic: dp,
                bands: bands.clone(),
                ..Default::default()
            });
            let b = build(&mut ctx, SceneKind::Dispersion, 0.002).unwrap();
            run_photons(&mut ctx, 60_000);
            whole_map(
                &ctx,
                &b.meshes
                    .iter()
                    .copied()
                    .filter(|&m| ctx.mesh_info(m).unwrap().records)
                    .collect::<Vec<_>>(),
            )
        })
        .collect();
    assert_maps_agree(&maps[0], &maps[1], "dispersion scene, classic vs dynamic");
}

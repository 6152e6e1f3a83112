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
        assert_eq!(ra.absorbed_w, rb.absorbed_w);
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

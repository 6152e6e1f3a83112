//! A measurement: the camera renderer against an independent reference, per
//! region of the image. The scene is the issue's room: a 1 m grey cube (ρ = 0.5), a 0.2 m
//! square emitter 2 cm under the ceiling, the camera at the floor's edge looking across
//! (90° field of view, 128 × 128 by default).
//!
//! The reference is `Context::path_trace` (plain path tracing on the same scene code,
//! another seed) run long; its own noise is taken out of every measured difference. Each
//! pixel is classed by what its centre ray meets: *near the emitter* (within 0.15 m of the
//! emitter's centre, or the emitter itself), *edges and corners* (within 0.05 m of two or
//! more walls), *interior* (the rest). For the semi-synchronous photon-map render (time
//! budgets doubling from 1 s) and the path tracer (samples per pixel doubling from 8) the
//! RMS relative error per region against the reference is printed with the RMS of the
//! method's own estimate, the mean signed error (a bias shows as a mean far from 0 beside
//! a small RMS), and the time.
//!
//! Then final gathering (`RenderMethod::FinalGather`) at the same budgets, each from an
//! empty context (the render runs the map itself): as is (light sampling, no direct
//! layer), and with the direct layer kept.
//!
//!     cargo run --release --example render_regions -- [--threads 2] [--size 128]
//!         [--reference-spp 4096] [--max-seconds 64] [--final-gather-only | --semi-only]
//!         [--view across|up] [--emitter-z 0.98] [--verbose]
//!
//! `--view up` puts the camera low in the room looking up at the emitter (at (0.5, 0.1,
//! 0.35), toward (0, 0.4, 0.63)), so that the lamp and its outline are in the picture, as
//! in the whole-image comparison; `--emitter-z 0.999` is the peers' room (the
//! emitter 1 mm under the ceiling).

#[path = "common/scenes.rs"]
mod scenes;

mod common;

use common::arg;
use imap::{CameraDesc, Config, Context, Image, LayerRequest, RenderMethod, RenderParams};
use scenes::{grey_room_at, GREY_ROOM_EMITTER_Z};
use std::time::Instant;

/// A render of `method` for `seconds`, defaults otherwise.
fn params(method: RenderMethod, seconds: f64) -> RenderParams<'static> {
    RenderParams {
        method,
        time_budget_s: seconds,
        progress_interval_s: 1.0,
        max_path_events: 10_000,
        ..Default::default()
    }
}

fn room(threads: usize, seed: u64, emitter_z: f64) -> Context {
    let mut ctx = Context::new(Config {
        threads,
        seed,
        ..Default::default()
    })
    .unwrap();
    grey_room_at(&mut ctx, 40, None, emitter_z).unwrap();
    ctx
}

/// The region of each pixel: 0 interior, 1 edges and corners, 2 near the emitter.
fn regions(cam: &CameraDesc, emitter_z: f64) -> Vec<usize> {
    let f = norm(cam.direction);
    let r = norm(cross(f, cam.up));
    let u = cross(r, f);
    let t = (cam.fov_y_deg.to_radians() / 2.0).tan();
    let a = cam.width as f64 / cam.height as f64;
    let mut out = Vec::new();
    for y in 0..cam.height {
        for x in 0..cam.width {
            let sx = (2.0 * (x as f64 + 0.5) / cam.width as f64 - 1.0) * t * a;
            let sy = (1.0 - 2.0 * (y as f64 + 0.5) / cam.height as f64) * t;
            let d = norm([0, 1, 2].map(|k| f[k] + r[k] * sx + u[k] * sy));
            let o = cam.position;
            // The emitter's plane first (it hangs inside the cube), then the cube's walls.
            let te = (emitter_z - o[2]) / d[2];
            let pe = [0, 1, 2].map(|k| o[k] + te * d[k]);
            if te > 0.0 && (0.4..=0.6).contains(&pe[0]) && (0.4..=0.6).contains(&pe[1]) {
                out.push(2);
                continue;
            }
            let mut tmin = f64::INFINITY;
            for k in 0..3 {
                for wall in [0.0, 1.0] {
                    let tw = (wall - o[k]) / d[k];
                    if tw > 1e-9 && tw < tmin {
                        tmin = tw;
                    }
                }
            }
            let q = [0, 1, 2].map(|k| o[k] + tmin * d[k]);
            let near_emitter =
                ((q[0] - 0.5).powi(2) + (q[1] - 0.5).powi(2) + (q[2] - emitter_z).powi(2)).sqrt()
                    < 0.15;
            let walls = q
                .iter()
                .map(|&c| (c < 0.05) as usize + (c > 0.95) as usize)
                .sum::<usize>();
            out.push(if near_emitter {
                2
            } else if walls >= 2 {
                1
            } else {
                0
            });
        }
    }
    out
}

fn norm(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|c| c / l)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Band-mean radiance of pixel p.
fn px(img: &Image, p: usize) -> f64 {
    img.radiance[p * img.bands..][..img.bands]
        .iter()
        .sum::<f64>()
        / img.bands as f64
}

/// Per region, then away from the emitter (interior, edges and corners) and the whole
/// image: (RMS relative error against the reference with the reference's noise taken out,
/// RMS estimated, mean signed relative error).
fn compare(img: &Image, reference: &Image, region: &[usize]) -> [(f64, f64, f64); 5] {
    let mut acc = [(0.0, 0.0, 0.0, 0.0); 5];
    for (p, &r) in region.iter().enumerate() {
        let truth = px(reference, p);
        if truth <= 0.0 {
            continue;
        }
        let d = px(img, p) / truth - 1.0;
        let away = if r < 2 { Some(3) } else { None };
        for k in [Some(r), away, Some(4)].into_iter().flatten() {
            let a = &mut acc[k];
            a.0 += d * d - reference.rel_error[p].powi(2);
            a.1 += img.rel_error[p].powi(2);
            a.2 += d;
            a.3 += 1.0;
        }
    }
    acc.map(|(d2, e2, d, n)| ((d2 / n).max(0.0).sqrt(), (e2 / n).sqrt(), d / n))
}

fn main() {
    let threads: usize = arg("--threads", 2);
    let size: u32 = arg("--size", 128);
    let ref_spp: u32 = arg("--reference-spp", 4096);
    let max_s: f64 = arg("--max-seconds", 64.0);
    let verbose = std::env::args().any(|a| a == "--verbose");
    let only_fg = std::env::args().any(|a| a == "--final-gather-only");
    let only_semi = std::env::args().any(|a| a == "--semi-only");
    let emitter_z: f64 = arg("--emitter-z", GREY_ROOM_EMITTER_Z);
    let view: String = arg("--view", "across".to_string());
    let (position, direction) = match view.as_str() {
        "across" => ([0.5, 0.01, 0.1], [0.0, 1.0, 0.25]),
        "up" => ([0.5, 0.1, 0.35], [0.0, 0.4, 0.63]),
        v => panic!("--view takes across or up, not {v}"),
    };
    let cam = CameraDesc {
        position,
        direction,
        up: [0.0, 0.0, 1.0],
        fov_y_deg: 90.0,
        width: size,
        height: size,
        projection: imap::Projection::Perspective,
    };
    let region = regions(&cam, emitter_z);
    let counts = [0, 1, 2].map(|r| region.iter().filter(|&&x| x == r).count());
    println!(
        "# render regions: the issue's room, {size}², {threads} threads; pixels interior {}, edges/corners {}, near the emitter {}",
        counts[0], counts[1], counts[2]
    );
    let t0 = Instant::now();
    let reference = room(threads, 1001, emitter_z)
        .path_trace(&cam, ref_spp, 10_000)
        .unwrap();
    let ref_err = {
        let e2: f64 = reference.rel_error.iter().map(|e| e * e).sum::<f64>()
            / reference.rel_error.len() as f64;
        e2.sqrt()
    };
    println!(
        "# reference: path tracing, {ref_spp} spp, {:.1} s, rms per-pixel error {:.3} %",
        t0.elapsed().as_secs_f64(),
        100.0 * ref_err
    );
    println!(
        "{:10} {:>8} {:>8}   {:>22} {:>22} {:>22} {:>15} {:>15}",
        "method",
        "setting",
        "time s",
        "interior rms/est/mean %",
        "edges rms/est/mean %",
        "emitter rms/est/mean %",
        "away rms/est %",
        "all rms/est %"
    );
    let show = |name: &str, setting: String, secs: f64, c: [(f64, f64, f64); 5]| {
        let f = |(a, e, m): (f64, f64, f64)| {
            format!("{:6.2} {:6.2} {:+6.2}", 100.0 * a, 100.0 * e, 100.0 * m)
        };
        let g = |(a, e, _): (f64, f64, f64)| format!("{:7.2} {:7.2}", 100.0 * a, 100.0 * e);
        println!(
            "{name:10} {setting:>8} {secs:>8.1}   {:>22} {:>22} {:>22} {:>15} {:>15}",
            f(c[0]),
            f(c[1]),
            f(c[2]),
            g(c[3]),
            g(c[4])
        );
    };
    let mut budget = 1.0;
    while budget <= max_s && !only_fg {
        let mut ctx = room(threads, 7, emitter_z);
        let mut p = params(RenderMethod::SemiSynchronous, budget);
        let t = Instant::now();
        let (img, _) = ctx.render(&cam, &mut p).unwrap();
        show(
            "semi",
            format!("{budget} s"),
            t.elapsed().as_secs_f64(),
            compare(&img, &reference, &region),
        );
        budget *= 2.0;
    }
    // Final gathering (`RenderMethod::FinalGather`) from an empty context: the render runs
    // the map itself (light sampling), balancing its time against the eye paths'; and with
    // the direct layer kept ("+direct": the map's indirect part is read, the direct light
    // sampled at the second vertex).
    for variant in ["fg", "fg+direct"].into_iter().filter(|_| !only_semi) {
        let mut budget = 1.0;
        while budget <= max_s {
            let mut ctx = room(threads, 7, emitter_z);
            let t = Instant::now();
            if variant != "fg" {
                ctx.set_layers(LayerRequest {
                    groups: false,
                    direct: true,
                })
                .unwrap();
            }
            let mut p = params(
                RenderMethod::FinalGather,
                budget - t.elapsed().as_secs_f64(),
            );
            let (img, rep) = ctx.render(&cam, &mut p).unwrap();
            show(
                variant,
                format!("{budget} s"),
                t.elapsed().as_secs_f64(),
                compare(&img, &reference, &region),
            );
            if verbose {
                println!(
                    "#   {:.0} spp, map {:.2} s ({} photons), eye {:.2} s, est {:.2} %",
                    rep.passes,
                    rep.time_forward_s,
                    ctx.report().photons,
                    rep.time_backward_s,
                    100.0 * rep.rel_error
                );
            }
            budget *= 2.0;
        }
    }
    let mut spp = 8;
    while !only_fg && !only_semi && spp <= ref_spp {
        let mut ctx = room(threads, 7, emitter_z);
        let t = Instant::now();
        let img = ctx.path_trace(&cam, spp, 10_000).unwrap();
        let secs = t.elapsed().as_secs_f64();
        show(
            "path",
            format!("{spp} spp"),
            secs,
            compare(&img, &reference, &region),
        );
        if secs * 2.0 > max_s {
            break;
        }
        spp *= 2;
    }
}

//! Time to a given *actual* error under daylight: a black room (2 × 2 m, 1 m high, its
//! 16 × 16-cell floor recorded) lit through a 1 m square roof opening by a CIE standard
//! general sky (type 12, clear, the sun's position shaping it at azimuth 225°, zenith 35°;
//! no sun disk). The exact floor irradiance is the sky's luminance integrated over the
//! opening (quadrature, averaged over each vertex's hat), so no reference run is needed.
//! The estimators — photons only, light sampling (a sky's samples half by its radiance,
//! half cosine-distributed), gathering — run side by side in segments; after each the
//! floor's actual error (irradiance-weighted mean of |E − E_exact| / E_exact) is compared
//! with the estimate, and the times at which it first reaches 5 %, 2 % and 1 % are
//! interpolated (log-log).
//!
//! `--open` leaves the walls and roof out: the floor then receives the sky's whole
//! horizontal irradiance. `--side` closes the roof and opens a 1 × 0.5 m window in the
//! wall y = −1 (x −0.5…0.5, z 0.25…0.75): a side-lit room. `--portal` declares the
//! opening a window portal (`Context::set_portals`); `--compare` runs each estimator
//! without and then with it.
//!
//! `--patches` (roof opening) times daylight coefficients instead: Reinhart MF:1, MF:2 and
//! MF:4 patch skies traced in batches (`imap::annual::trace::PatchRun`, gathering), the
//! floor read as the CIE sky's patch vector times the coefficients, against the exact
//! floor of that patch sky; beside the CIE sky's own gathering run, whose time it prints
//! as the ratio. `EST=p` or `EST=ls` in the environment runs both with photons only or
//! light sampling instead of gathering.
//!
//!     cargo run --release --example daylight_bench -- [--threads 2] [--max-seconds 20]
//!         [--cie-type 12] [--open | --side] [--portal | --compare] [--patches]

mod common;

use common::arg;
use imap::annual::trace::{PatchRound, PatchRun, PatchTarget};
use imap::photometry::Spectrum;
use imap::{cie_luminance, SkyAmount, SkyDesc, SkyKind};
use imap::{Config, Context, Estimator, MaterialDesc, MeshDesc, RunParams};
use std::time::Instant;

const N: usize = 16;
const HEIGHT: f64 = 1.0;

fn quad(ctx: &mut Context, m: u32, p: [[f64; 3]; 4]) {
    let pos: Vec<f64> = p.iter().flatten().copied().collect();
    ctx.add_mesh(&MeshDesc {
        record: false,
        ..MeshDesc::new(&pos, &[0, 1, 2, 0, 2, 3], m)
    })
    .unwrap();
}

/// The window of `--side`: x −0.5…0.5, z 0.25…0.75 in the wall y = −1, facing −y.
const WINDOW_Z: [f64; 2] = [0.25, 0.75];

/// The room (`open`: the floor alone; `side`: the opening in a wall, not the roof);
/// returns the floor's id, its vertex positions and triangles.
fn room(ctx: &mut Context, open: bool, side: bool) -> (u32, Vec<[f64; 3]>, Vec<u32>) {
    let black = ctx.add_material(&MaterialDesc::default()).unwrap();
    let (mut pos, mut idx) = (Vec::new(), Vec::new());
    for j in 0..=N {
        for i in 0..=N {
            pos.extend([
                -1.0 + 2.0 * i as f64 / N as f64,
                -1.0 + 2.0 * j as f64 / N as f64,
                0.0,
            ]);
        }
    }
    let id = |i: usize, j: usize| (j * (N + 1) + i) as u32;
    for j in 0..N {
        for i in 0..N {
            idx.extend([
                id(i, j),
                id(i + 1, j),
                id(i + 1, j + 1),
                id(i, j),
                id(i + 1, j + 1),
                id(i, j + 1),
            ]);
        }
    }
    let floor = ctx.add_mesh(&MeshDesc::new(&pos, &idx, black)).unwrap();
    let verts = pos.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    if open {
        return (floor, verts, idx);
    }
    let h = HEIGHT;
    if side {
        // The wall y = −1 around the window.
        let [z0, z1] = WINDOW_Z;
        for (x, z) in [
            ([-1.0, 1.0], [0.0, z0]),
            ([-1.0, 1.0], [z1, h]),
            ([-1.0, -0.5], [z0, z1]),
            ([0.5, 1.0], [z0, z1]),
        ] {
            quad(
                ctx,
                black,
                [
                    [x[0], -1.0, z[0]],
                    [x[1], -1.0, z[0]],
                    [x[1], -1.0, z[1]],
                    [x[0], -1.0, z[1]],
                ],
            );
        }
        quad(
            ctx,
            black,
            [
                [-1.0, -1.0, h],
                [1.0, -1.0, h],
                [1.0, 1.0, h],
                [-1.0, 1.0, h],
            ],
        );
    } else {
        quad(
            ctx,
            black,
            [
                [-1.0, -1.0, 0.0],
                [1.0, -1.0, 0.0],
                [1.0, -1.0, h],
                [-1.0, -1.0, h],
            ],
        );
    }
    quad(
        ctx,
        black,
        [
            [-1.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 1.0, h],
            [-1.0, 1.0, h],
        ],
    );
    quad(
        ctx,
        black,
        [
            [-1.0, -1.0, 0.0],
            [-1.0, 1.0, 0.0],
            [-1.0, 1.0, h],
            [-1.0, -1.0, h],
        ],
    );
    quad(
        ctx,
        black,
        [
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 1.0, h],
            [1.0, -1.0, h],
        ],
    );
    let roof_pieces: &[([f64; 2], [f64; 2])] = if side {
        &[]
    } else {
        &[
            ([-1.0, 1.0], [0.5, 1.0]),
            ([-1.0, 1.0], [-1.0, -0.5]),
            ([-1.0, -0.5], [-0.5, 0.5]),
            ([0.5, 1.0], [-0.5, 0.5]),
        ]
    };
    for &(x, y) in roof_pieces {
        quad(
            ctx,
            black,
            [
                [x[0], y[0], h],
                [x[1], y[0], h],
                [x[1], y[1], h],
                [x[0], y[1], h],
            ],
        );
    }
    (floor, verts, idx)
}

/// E at floor point x from the sky through the opening, per unit zenith luminance.
fn through_opening(x: [f64; 3], kind: u32, sun: [f64; 3], zs: f64) -> f64 {
    through_opening_l(x, &|dir| {
        let chi = (dir[0] * sun[0] + dir[1] * sun[1] + dir[2] * sun[2])
            .clamp(-1.0, 1.0)
            .acos();
        cie_luminance(kind, dir[2].acos(), chi, zs)
    })
}

/// E at floor point x through the opening from a sky of luminance `l(direction)`.
fn through_opening_l(x: [f64; 3], l: &dyn Fn([f64; 3]) -> f64) -> f64 {
    let n = 32;
    let mut s = 0.0;
    for i in 0..n {
        for j in 0..n {
            let y = [
                -0.5 + (i as f64 + 0.5) / n as f64,
                -0.5 + (j as f64 + 0.5) / n as f64,
                HEIGHT,
            ];
            let d = [y[0] - x[0], y[1] - x[1], y[2] - x[2]];
            let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let r = r2.sqrt();
            let dir = [d[0] / r, d[1] / r, d[2] / r];
            s += l(dir) * dir[2] * dir[2] / r2;
        }
    }
    s / (n * n) as f64
}

/// Times to 5, 2 and 1 % actual error (interpolated log-log between segments), the final
/// error and actual over estimated error, as a table row's cells, of `step`: traces a
/// segment of the given photons and returns the elapsed seconds, the actual error
/// (irradiance-weighted mean |E − exact| / exact) and the estimated one.
fn time_to_error(max_s: f64, mut step: impl FnMut(u64) -> (f64, f64, f64)) -> [String; 5] {
    let mut chunk = 20_000u64;
    let mut prev: Option<(f64, f64)> = None;
    let mut hit: [Option<f64>; 3] = [None; 3];
    let targets = [0.05, 0.02, 0.01];
    let (mut err, mut ratio): (f64, f64);
    loop {
        let (t, e, est) = step(chunk);
        err = e;
        ratio = e / est;
        for (k, &target) in targets.iter().enumerate() {
            if hit[k].is_none() && err <= target {
                hit[k] = Some(match prev {
                    Some((t0, e0)) if e0 > target => {
                        let f = (e0 / target).ln() / (e0 / err).ln();
                        (t0.ln() + f * (t / t0).ln()).exp()
                    }
                    _ => t,
                });
            }
        }
        prev = Some((t, err));
        chunk = chunk.saturating_mul(3) / 2;
        if t >= max_s || hit[2].is_some() {
            break;
        }
    }
    let show = |h: Option<f64>| h.map_or(format!("> {max_s:.0}"), |t| format!("{t:.2}"));
    [
        show(hit[0]),
        show(hit[1]),
        show(hit[2]),
        format!("{:.2}%", 100.0 * err),
        format!("{ratio:.2}"),
    ]
}

/// `--patches`: the CIE sky's gathering run, then its MF:1, 2 and 4 coefficients.
fn patches_bench(threads: usize, max_s: f64, kind: u32) {
    let (sa, sz) = (225f64.to_radians(), 35f64.to_radians());
    let sun = [sz.sin() * sa.sin(), sz.sin() * sa.cos(), sz.cos()];
    let cie = SkyDesc {
        kind: SkyKind::Cie {
            kind,
            sun_azimuth_deg: 225.0,
            sun_zenith_deg: 35.0,
        },
        amount: SkyAmount::Luminance(5000.0),
        spectrum: Spectrum::Equal,
        ..SkyDesc::default()
    };
    println!("# daylight bench --patches: CIE sky type {kind} through a 1 m roof opening, {threads} threads, up to {max_s} s each");
    println!(
        "{:18} {:>9} {:>9} {:>9} {:>10} {:>8} {:>12}",
        "run", "t(5%)", "t(2%)", "t(1%)", "final err", "act/est", "t(2%)/sky"
    );
    let context = || {
        Context::new(Config {
            threads,
            seed: 7,
            ..Default::default()
        })
        .unwrap()
    };
    // The sky itself, gathering: the baseline.
    let mut ctx = context();
    let (floor, verts, idx) = room(&mut ctx, false, false);
    ctx.add_sky(&cie).unwrap();
    let eff = ctx.photometry().luminous(&[1.0, 1.0, 1.0]);
    let exact: Vec<f64> = (0..verts.len())
        .map(|v| hat(&verts, &idx, v, &|x| through_opening(x, kind, sun, sz)) * 5000.0 / eff)
        .collect();
    let nv = verts.len();
    let start = Instant::now();
    let row = time_to_error(max_s, |n| {
        ctx.run(&mut RunParams {
            photons: n,
            progress_interval_s: 10.0,
            estimator: Some(bench_estimator()),
            ..Default::default()
        })
        .unwrap();
        let (mut e, mut rel) = (vec![0.0; nv], vec![0.0; nv]);
        ctx.irradiance(floor, 0, 0, &mut e).unwrap();
        ctx.rel_error(floor, 0, &mut rel).unwrap();
        errors(&e, &rel, &exact, start)
    });
    let sky_2 = row[1].parse::<f64>().ok();
    println!(
        "{:18} {:>9} {:>9} {:>9} {:>10} {:>8} {:>12}",
        "CIE sky, gather", row[0], row[1], row[2], row[3], row[4], "1"
    );
    for mf in [1u32, 2, 4] {
        let mut ctx = context();
        let (floor, verts, idx) = room(&mut ctx, false, false);
        let patches = imap::SkyPatches::reinhart(mf).unwrap();
        let lum: Vec<f64> = imap::sky_patch_radiance(&cie, &imap::Bands::rgb(), mf)
            .unwrap()
            .iter()
            .map(|v| v[0] * eff)
            .collect();
        let l = |d: [f64; 3]| lum[patches.patch(d[2].clamp(-1.0, 1.0).asin(), d[0].atan2(d[1]))];
        let exact: Vec<f64> = (0..verts.len())
            .map(|v| hat(&verts, &idx, v, &|x| through_opening_l(x, &l)))
            .collect();
        let target = PatchTarget {
            mesh: floor,
            side: 0,
            vertices: (0..nv).collect(),
        };
        let frame = ([0.0, 0.0, 1.0], [0.0, 1.0, 0.0]);
        let start = Instant::now();
        let mut run = PatchRun::new(&mut ctx, mf, frame, vec![target], 0).unwrap();
        let row = time_to_error(max_s, |n| {
            let round = PatchRound {
                photons: n,
                estimator: Some(bench_estimator()),
                ..Default::default()
            };
            run.trace(&mut ctx, round, &mut |_| true).unwrap();
            let c = run.coefficients(0).unwrap();
            let (mut e, mut rel) = (vec![0.0; nv], vec![0.0; nv]);
            for k in 0..nv {
                let row = k * c.patches..(k + 1) * c.patches;
                let x: f64 = lum
                    .iter()
                    .zip(&c.value[row.clone()])
                    .map(|(l, x)| l * x)
                    .sum();
                let v: f64 = lum
                    .iter()
                    .zip(&c.sigma[row])
                    .map(|(l, s)| (l * s).powi(2))
                    .sum();
                e[k] = x;
                rel[k] = if x > 0.0 { v.sqrt() / x } else { 0.0 };
            }
            errors(&e, &rel, &exact, start)
        });
        let ratio = match (row[1].parse::<f64>().ok(), sky_2) {
            (Some(a), Some(b)) => format!("{:.2}", a / b),
            _ => "-".into(),
        };
        println!(
            "{:18} {:>9} {:>9} {:>9} {:>10} {:>8} {:>12}",
            format!("MF:{mf} coefficients"),
            row[0],
            row[1],
            row[2],
            row[3],
            row[4],
            ratio
        );
    }
}

/// (elapsed s, actual error, estimated error) of values `e` with relative errors `rel`.
fn errors(e: &[f64], rel: &[f64], exact: &[f64], start: Instant) -> (f64, f64, f64) {
    let (mut num, mut den, mut est) = (0.0, 0.0, 0.0);
    for v in 0..e.len() {
        num += (e[v] - exact[v]).abs();
        den += exact[v];
        est += rel[v] * e[v];
    }
    (start.elapsed().as_secs_f64(), num / den, est / den)
}

/// E at floor point x from the sky through the side window, per unit zenith luminance.
fn through_window(x: [f64; 3], kind: u32, sun: [f64; 3], zs: f64) -> f64 {
    let n = 32;
    let [z0, z1] = WINDOW_Z;
    let mut s = 0.0;
    for i in 0..n {
        for j in 0..n {
            let y = [
                -0.5 + (i as f64 + 0.5) / n as f64,
                -1.0,
                z0 + (z1 - z0) * (j as f64 + 0.5) / n as f64,
            ];
            let d = [y[0] - x[0], y[1] - x[1], y[2] - x[2]];
            let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let r = r2.sqrt();
            let dir = [d[0] / r, d[1] / r, d[2] / r];
            if dir[2] <= 0.0 || dir[1] >= 0.0 {
                continue;
            }
            let chi = (dir[0] * sun[0] + dir[1] * sun[1] + dir[2] * sun[2])
                .clamp(-1.0, 1.0)
                .acos();
            s += cie_luminance(kind, dir[2].acos(), chi, zs) * dir[2] * (-dir[1]) / r2;
        }
    }
    s * (z1 - z0) / (n * n) as f64
}

/// The hat average of `e` at vertex v (a 6 × 6 sub-grid per adjacent triangle).
fn hat(verts: &[[f64; 3]], idx: &[u32], v: usize, e: &dyn Fn([f64; 3]) -> f64) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for t in idx.chunks_exact(3) {
        let Some(k) = t.iter().position(|&i| i as usize == v) else {
            continue;
        };
        let p: Vec<[f64; 3]> = (0..3).map(|j| verts[t[(k + j) % 3] as usize]).collect();
        let m = 6;
        let (mut sum, mut cnt) = (0.0, 0.0);
        for i in 0..m {
            for j in 0..m - i {
                let (b1, b2) = (
                    (i as f64 + 1.0 / 3.0) / m as f64,
                    (j as f64 + 1.0 / 3.0) / m as f64,
                );
                let w0 = 1.0 - b1 - b2;
                let x = [0, 1, 2].map(|c| w0 * p[0][c] + b1 * p[1][c] + b2 * p[2][c]);
                sum += e(x) * w0;
                cnt += 1.0;
            }
        }
        num += sum / cnt;
        den += 1.0 / 3.0;
    }
    num / den
}

fn main() {
    let threads: usize = arg("--threads", 2);
    let max_s: f64 = arg("--max-seconds", 20.0);
    let kind: u32 = arg("--cie-type", 12);
    let flag = |f: &str| std::env::args().any(|a| a == f);
    let (open, side, compare) = (flag("--open"), flag("--side"), flag("--compare"));
    if flag("--patches") {
        patches_bench(threads, max_s, kind);
        return;
    }
    let portals: &[bool] = if compare {
        &[false, true]
    } else if flag("--portal") {
        &[true]
    } else {
        &[false]
    };
    let (sa, sz) = (225f64.to_radians(), 35f64.to_radians());
    let sun = [sz.sin() * sa.sin(), sz.sin() * sa.cos(), sz.cos()];
    let lz = 5000.0;
    println!(
        "# daylight bench: CIE sky type {kind} {}, {threads} threads, up to {max_s} s each",
        if open {
            "over an open floor"
        } else if side {
            "through a 1 × 0.5 m side window"
        } else {
            "through a 1 m roof opening"
        }
    );
    println!(
        "{:10} {:>7} {:>9} {:>9} {:>9} {:>12} {:>10}",
        "estimator", "portal", "t(5%)", "t(2%)", "t(1%)", "final err", "act/est"
    );
    let runs = [
        ("photons", Estimator::Photons),
        ("ls", Estimator::DEFAULT),
        ("gather", Estimator::GATHER),
    ]
    .into_iter()
    .flat_map(|r| portals.iter().map(move |&p| (r.0, r.1, p)));
    for (name, est, portal) in runs {
        let mut ctx = Context::new(Config {
            threads,
            seed: 7,
            ..Default::default()
        })
        .unwrap();
        let (floor, verts, idx) = room(&mut ctx, open, side);
        if portal {
            let opening: Vec<f64> = if side {
                let [z0, z1] = WINDOW_Z;
                vec![-0.5, -1.0, z0, 0.5, -1.0, z0, 0.5, -1.0, z1, -0.5, -1.0, z1]
            } else {
                vec![
                    -0.5, -0.5, HEIGHT, 0.5, -0.5, HEIGHT, 0.5, 0.5, HEIGHT, -0.5, 0.5, HEIGHT,
                ]
            };
            ctx.set_portals(&opening, &[0, 1, 2, 0, 2, 3]).unwrap();
        }
        let sky = ctx
            .add_sky(&SkyDesc {
                kind: SkyKind::Cie {
                    kind,
                    sun_azimuth_deg: 225.0,
                    sun_zenith_deg: 35.0,
                },
                amount: SkyAmount::Luminance(lz),
                spectrum: Spectrum::Equal,
                ..SkyDesc::default()
            })
            .unwrap();
        let band = lz / ctx.photometry().luminous(&[1.0, 1.0, 1.0]);
        let exact: Vec<f64> = if open {
            // The whole sky: its horizontal irradiance, band 0.
            vec![ctx.light_flux(sky).unwrap().0[0]; verts.len()]
        } else if side {
            (0..verts.len())
                .map(|v| hat(&verts, &idx, v, &|x| through_window(x, kind, sun, sz)) * band)
                .collect()
        } else {
            (0..verts.len())
                .map(|v| hat(&verts, &idx, v, &|x| through_opening(x, kind, sun, sz)) * band)
                .collect()
        };
        let nv = verts.len();
        let (mut e, mut rel) = (vec![0.0; nv], vec![0.0; nv]);
        let start = Instant::now();
        let row = time_to_error(max_s, |n| {
            ctx.run(&mut RunParams {
                photons: n,
                progress_interval_s: 10.0,
                estimator: Some(est),
                ..Default::default()
            })
            .unwrap();
            ctx.irradiance(floor, 0, 0, &mut e).unwrap();
            ctx.rel_error(floor, 0, &mut rel).unwrap();
            errors(&e, &rel, &exact, start)
        });
        println!(
            "{name:10} {:>7} {:>9} {:>9} {:>9} {:>12} {:>10}",
            if portal { "yes" } else { "no" },
            row[0],
            row[1],
            row[2],
            row[3],
            row[4]
        );
    }
}

fn bench_estimator() -> Estimator {
    match std::env::var("EST").as_deref() {
        Ok("p") => Estimator::Photons,
        Ok("ls") => Estimator::DEFAULT,
        _ => Estimator::GATHER,
    }
}

//! Time to a given *actual* error: the photons-only estimator (the first paper's) against
//! light sampling at the vertices and light sampling with gathering, side by side in one
//! process, on the benchmark room (a
//! 1 m grey cube, ρ = 0.5, all six walls recorded as 40 × 40 grids: 10 086 vertices, a
//! 0.2 m square emitter 2 cm under the ceiling) and on the Cornell box, each with a 10 × 10
//! sensor grid just above its floor.
//!
//! For each scene a long light-sampling run with another seed is the reference; in the
//! room its direct layer is checked against Lambert's polygon formula averaged over each
//! vertex's hat (exact: the room is convex and empty); its indirect part is the photons',
//! so the gathering estimator is measured against an estimate that shares none of its
//! indirect light (a bias in it would show as a floor and an actual/estimated ratio
//! growing above 0.8). Each estimator then runs in
//! segments; after each the whole map and the grid are compared with the reference
//! (irradiance-weighted mean of |E − E_ref| / E_ref, band mean, the same measure as the
//! estimated global error) and the times at which the actual error first reaches 1 % and
//! 0.5 % are interpolated (log-log). The reference's own noise is taken out: a measured
//! difference m holds the reference's error r too (independent), so the run's is
//! √(m² − r²), r being √(2/π) times the reference's estimated error (calibrated, checked
//! here on its direct part). The ratio actual / estimated is printed too: it is
//! √(2/π) ≈ 0.8 for a calibrated estimate.
//!
//!     cargo run --release --example accuracy_bench -- [--threads 2] [--seeds 2]
//!         [--ref-seconds 60] [--max-seconds 40] [--scenes room,cornell]
//!         [--samples 0] [--pass-photons 0] [--estimators photons,ls,gather]
//!         [--scheduler dynamic|classic]   (the estimators' runs; the reference's stays dynamic)
//!         [--floor lambert|lambert:ρ|white|aluminium|chromium]   (the room's floor: ρ = 0.5, ρ, ρ = 0.9, or rough
//!         aluminium α 0.3, which reflects about as much as the white one, or rough chromium α 0.3,
//!         about as much as the grey one)

#[path = "common/scenes.rs"]
mod scenes;

use imap::SchedulerKind;
use imap::{Config, Context, Estimator, Layer, LayerRequest, MaterialDesc, MeshDesc, RunParams};
use scenes::{cornell_box, grey_room_with_floor, GREY_ROOM_EMITTER_Z, GREY_ROOM_EXITANCE};
use std::f64::consts::PI;

struct Args {
    threads: usize,
    scheduler: SchedulerKind,
    seeds: u64,
    ref_seconds: f64,
    max_seconds: f64,
    scenes: Vec<String>,
    samples: u32,
    pass_photons: u64,
    estimators: Vec<String>,
    floor: String,
}

fn parse() -> Args {
    let mut a = Args {
        threads: 2,
        scheduler: SchedulerKind::Dynamic,
        seeds: 2,
        ref_seconds: 60.0,
        max_seconds: 40.0,
        scenes: vec!["room".into(), "cornell".into()],
        samples: 0,
        pass_photons: 0,
        estimators: vec!["photons".into(), "ls".into(), "gather".into()],
        floor: "lambert".into(),
    };
    let argv: Vec<String> = std::env::args().skip(1).collect();
    for pair in argv.chunks(2) {
        let v = pair.get(1).cloned().expect("a value");
        match pair[0].as_str() {
            "--threads" => a.threads = v.parse().expect("--threads"),
            "--seeds" => a.seeds = v.parse().expect("--seeds"),
            "--ref-seconds" => a.ref_seconds = v.parse().expect("--ref-seconds"),
            "--max-seconds" => a.max_seconds = v.parse().expect("--max-seconds"),
            "--scenes" => a.scenes = v.split(',').map(str::to_owned).collect(),
            "--samples" => a.samples = v.parse().expect("--samples"),
            "--pass-photons" => a.pass_photons = v.parse().expect("--pass-photons"),
            "--scheduler" => {
                a.scheduler = match v.as_str() {
                    "dynamic" => SchedulerKind::Dynamic,
                    "classic" => SchedulerKind::Classic,
                    o => panic!("--scheduler takes dynamic or classic, not {o}"),
                }
            }
            "--estimators" => a.estimators = v.split(',').map(str::to_owned).collect(),
            "--floor" => a.floor = v,
            other => panic!("unknown argument {other}"),
        }
    }
    a
}

/// A grid of n × n cells over the rectangle o + s·u + t·v (s, t in [0, 1]), normal u × v.
fn quad(o: [f64; 3], u: [f64; 3], v: [f64; 3], n: usize, pos: &mut Vec<f64>, idx: &mut Vec<u32>) {
    let base = (pos.len() / 3) as u32;
    for j in 0..=n {
        for i in 0..=n {
            let (s, t) = (i as f64 / n as f64, j as f64 / n as f64);
            for k in 0..3 {
                pos.push(o[k] + s * u[k] + t * v[k]);
            }
        }
    }
    let w = n as u32 + 1;
    for j in 0..n as u32 {
        for i in 0..n as u32 {
            let a = base + j * w + i;
            idx.extend([a, a + 1, a + w + 1, a, a + w + 1, a + w]);
        }
    }
}

/// A scene: its context, the recorded meshes of the whole map, the floor grid.
struct Scene {
    ctx: Context,
    meshes: Vec<u32>,
    grid: u32,
    /// The room's emitter (for the analytic direct light): corners and radiance per band.
    emitter: Option<([[f64; 3]; 4], f64)>,
    room: Option<(Vec<f64>, Vec<u32>)>,
}

const ROOM_EMITTER_Z: f64 = GREY_ROOM_EMITTER_Z;
const ROOM_EXITANCE: f64 = GREY_ROOM_EXITANCE;

fn room(config: Config, floor: &str) -> Scene {
    let mut ctx = Context::new(config).unwrap();
    let rough = MaterialDesc {
        surface: imap::SurfaceModel::Conductor(imap::ConductorIndex::Metal(imap::Metal::Aluminium)),
        roughness: [0.3, 0.0],
        ..Default::default()
    };
    let white = MaterialDesc {
        diffuse_reflect: vec![0.9],
        ..Default::default()
    };
    let chromium = MaterialDesc {
        surface: imap::SurfaceModel::Conductor(imap::ConductorIndex::Metal(imap::Metal::Chromium)),
        ..rough.clone()
    };
    let lambert;
    let floor = match floor {
        "lambert" => None,
        "white" => Some(&white),
        "aluminium" => Some(&rough),
        "chromium" => Some(&chromium),
        f if f.starts_with("lambert:") => {
            lambert = MaterialDesc {
                diffuse_reflect: vec![f[8..].parse().expect("--floor lambert:ρ")],
                ..Default::default()
            };
            Some(&lambert)
        }
        other => {
            panic!("--floor takes lambert, lambert:ρ, white, aluminium or chromium, not {other}")
        }
    };
    let r = grey_room_with_floor(&mut ctx, 40, floor).unwrap();
    let grid = floor_grid(&mut ctx, [0.05, 0.95], 0.001, 1.0, r.black);
    Scene {
        ctx,
        meshes: vec![r.walls],
        grid,
        emitter: Some((r.emitter, ROOM_EXITANCE / PI)),
        room: Some((r.positions, r.indices)),
    }
}

/// A sensor grid of 10 × 10 points over [r0, r1]² on the floor, `h` above it (`up`: z = 1
/// for the room, y for the Cornell box given as −1).
fn floor_grid(ctx: &mut Context, r: [f64; 2], h: f64, up: f64, m: u32) -> u32 {
    let (mut p, mut t) = (Vec::new(), Vec::new());
    let s = r[1] - r[0];
    if up > 0.0 {
        quad(
            [r[0], r[0], h],
            [s, 0.0, 0.0],
            [0.0, s, 0.0],
            9,
            &mut p,
            &mut t,
        );
    } else {
        // The Cornell box: y up; u × v = +y.
        quad(
            [r[0], h, r[0]],
            [0.0, 0.0, s],
            [s, 0.0, 0.0],
            9,
            &mut p,
            &mut t,
        );
    }
    ctx.add_mesh(&MeshDesc {
        sensor: true,
        ..MeshDesc::new(&p, &t, m)
    })
    .unwrap()
}

fn cornell(config: Config) -> Scene {
    let mut ctx = Context::new(Config {
        unit_m: 0.001,
        ..config
    })
    .unwrap();
    let built = cornell_box(&mut ctx, false, 24).unwrap();
    let black = ctx.add_material(&MaterialDesc::default()).unwrap();
    let grid = floor_grid(&mut ctx, [27.75, 527.25], 0.5, -1.0, black);
    Scene {
        ctx,
        meshes: vec![built.meshes[0]],
        grid,
        emitter: None,
        room: None,
    }
}

fn build(name: &str, config: Config, floor: &str) -> Scene {
    match name {
        "room" => room(config, floor),
        "cornell" => cornell(config),
        other => panic!("unknown scene {other}"),
    }
}

/// Band-mean irradiance of every vertex of `meshes` (and their areas, for dropping
/// vertices without any).
fn read(ctx: &Context, meshes: &[u32], layer: Layer) -> Vec<f64> {
    let nb = ctx.config().bands.count();
    let mut all = Vec::new();
    for &m in meshes {
        let nv = ctx.vertex_count(m).unwrap();
        let mut sum = vec![0.0; nv];
        let mut e = vec![0.0; nv];
        for b in 0..nb as u32 {
            ctx.irradiance_layer(m, 0, b, layer, &mut e).unwrap();
            sum.iter_mut()
                .zip(&e)
                .for_each(|(s, x)| *s += x / nb as f64);
        }
        all.extend(sum);
    }
    all
}

/// Irradiance-weighted mean relative difference Σ|a − r| / Σ r.
fn actual(a: &[f64], r: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(r).map(|(a, r)| (a - r).abs()).sum();
    let den: f64 = r.iter().sum();
    num / den
}

/// Lambert's polygon formula: irradiance at x (normal n) from a polygon of radiance l.
fn polygon(x: [f64; 3], n: [f64; 3], poly: &[[f64; 3]; 4], l: f64) -> f64 {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let norm = |a: [f64; 3]| dot(a, a).sqrt();
    let mut s = 0.0;
    for i in 0..4 {
        let a = sub(poly[i], x);
        let b = sub(poly[(i + 1) % 4], x);
        let c = cross(a, b);
        let theta = (dot(a, b) / (norm(a) * norm(b))).clamp(-1.0, 1.0).acos();
        s += theta * dot(n, c) / norm(c);
    }
    l / 2.0 * s.abs()
}

/// The hat-function average of the emitter's direct irradiance at every vertex of a mesh
/// (centroid rule on a 12 × 12 subdivision of each triangle).
fn analytic_direct(pos: &[f64], idx: &[u32], poly: &[[f64; 3]; 4], l: f64) -> Vec<f64> {
    let nv = pos.len() / 3;
    let (mut num, mut den) = (vec![0.0; nv], vec![0.0; nv]);
    let m = 12;
    let p = |i: u32| [0, 1, 2].map(|k| pos[3 * i as usize + k]);
    for t in idx.chunks_exact(3) {
        let [a, b, c] = [p(t[0]), p(t[1]), p(t[2])];
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let cr = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let len = (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]).sqrt();
        let (area, n) = (0.5 * len, cr.map(|x| x / len));
        let mut sums = [0.0; 3];
        let mut count = 0.0;
        for i in 0..m {
            for j in 0..m - i {
                for up in [true, false] {
                    if !up && i + j + 1 >= m {
                        continue;
                    }
                    let off = if up { 1.0 / 3.0 } else { 2.0 / 3.0 };
                    let (b1, b2) = ((i as f64 + off) / m as f64, (j as f64 + off) / m as f64);
                    let b0 = 1.0 - b1 - b2;
                    let x = [0, 1, 2].map(|k| b0 * a[k] + b1 * b[k] + b2 * c[k]);
                    // The emitter faces down: points at or above its plane get nothing.
                    let e = if x[2] < ROOM_EMITTER_Z {
                        polygon(x, n, poly, l)
                    } else {
                        0.0
                    };
                    for (s, w) in sums.iter_mut().zip([b0, b1, b2]) {
                        *s += e * w;
                    }
                    count += 1.0;
                }
            }
        }
        for (k, &v) in t.iter().enumerate() {
            num[v as usize] += sums[k] / count * area;
            den[v as usize] += area / 3.0;
        }
    }
    num.iter().zip(&den).map(|(n, d)| n / d).collect()
}

struct Curve {
    /// (seconds, actual whole map, estimated whole map, actual grid)
    points: Vec<(f64, f64, f64, f64)>,
    hits_per_s: f64,
}

/// The first time the actual error reaches `x` (log-log interpolation), if it did.
fn time_to(points: &[(f64, f64)], x: f64) -> Option<f64> {
    let i = points.iter().position(|p| p.1 <= x)?;
    if i == 0 {
        return Some(points[0].0);
    }
    let (t0, e0) = points[i - 1];
    let (t1, e1) = points[i];
    let f = (x.ln() - e0.ln()) / (e1.ln() - e0.ln());
    Some((t0.ln() + f * (t1.ln() - t0.ln())).exp())
}

/// The reference's own estimated error of `meshes` (Σσ / ΣE).
fn estimated(ctx: &Context, meshes: &[u32], e: &[f64]) -> f64 {
    let mut rel = Vec::new();
    for &m in meshes {
        let mut r = vec![0.0; ctx.vertex_count(m).unwrap()];
        ctx.rel_error(m, 0, &mut r).unwrap();
        rel.extend(r);
    }
    let num: f64 = e.iter().zip(&rel).map(|(e, r)| e * r.min(1.0)).sum();
    num / e.iter().sum::<f64>()
}

/// What the reference's noise leaves of a measured difference `m` (`r`: the reference's
/// expected contribution).
fn corrected(m: f64, r: f64) -> f64 {
    (m * m - r * r).max(0.0).sqrt()
}

fn curve(
    scene: &str,
    config: Config,
    est: Estimator,
    (reference, ref_noise): (&[f64], f64),
    (grid_ref, grid_noise): (&[f64], f64),
    max_s: f64,
    floor: &str,
) -> Curve {
    let mut s = build(scene, config, floor);
    let mut seg = 0.05;
    let mut points = Vec::new();
    loop {
        let r = s
            .ctx
            .run(&mut RunParams {
                time_budget_s: seg,
                progress_interval_s: seg,
                estimator: Some(est),
                ..Default::default()
            })
            .unwrap();
        let map = read(&s.ctx, &s.meshes, Layer::Combined);
        let grid = read(&s.ctx, &[s.grid], Layer::Combined);
        let (a, g) = (
            corrected(actual(&map, reference), ref_noise),
            corrected(actual(&grid, grid_ref), grid_noise),
        );
        points.push((r.elapsed_s, a, r.rel_error, g));
        if (a <= 0.004 && g <= 0.004) || r.elapsed_s >= max_s {
            let hits_per_s = r.hits as f64 / r.elapsed_s;
            return Curve { points, hits_per_s };
        }
        seg = (seg * 1.3).min(2.0);
    }
}

fn fmt(t: Option<f64>) -> String {
    t.map_or("—".into(), |t| format!("{t:.2} s"))
}

fn main() {
    let args = parse();
    println!(
        "time to actual error, {} threads, {} seeds per estimator; light sampling and gathering: {} samples per vertex per pass, {} photons per pass (0 = automatic)",
        args.threads,
        args.seeds,
        args.samples,
        args.pass_photons
    );
    println!("estimators' scheduler: {:?}", args.scheduler);
    let ls = |gather| Estimator::LightSampling {
        samples: args.samples,
        pass_photons: args.pass_photons,
        gather,
    };
    for scene in &args.scenes {
        // The reference: a long light-sampling run with its own seed.
        let config = |seed| Config {
            threads: args.threads,
            seed,
            ..Default::default()
        };
        let mut r = build(scene, config(1_000_003), &args.floor);
        r.ctx
            .set_layers(LayerRequest {
                groups: false,
                direct: true,
            })
            .unwrap();
        let t0 = std::time::Instant::now();
        let rep = r
            .ctx
            .run(&mut RunParams {
                time_budget_s: args.ref_seconds,
                progress_interval_s: 1.0,
                target_rel_error: 0.0007,
                estimator: Some(ls(false)),
                ..Default::default()
            })
            .unwrap();
        let reference = read(&r.ctx, &r.meshes, Layer::Combined);
        let grid_ref = read(&r.ctx, &[r.grid], Layer::Combined);
        let nv = reference.len();
        let k = (2.0 / PI).sqrt();
        let ref_noise = k * estimated(&r.ctx, &r.meshes, &reference);
        let grid_noise = k * estimated(&r.ctx, &[r.grid], &grid_ref);
        println!(
            "\n## {scene}: {nv} vertices recorded + 100 grid points; reference: {} photons in {:.1} s, estimated error {:.3} % (whole map), {:.3} % (grid): expected actual {:.3} % and {:.3} %, taken out of the measured differences",
            rep.photons,
            t0.elapsed().as_secs_f64(),
            100.0 * rep.rel_error,
            100.0 * grid_noise / k,
            100.0 * ref_noise,
            100.0 * grid_noise
        );
        if let (Some((poly, l)), Some((pos, idx))) = (r.emitter, r.room.as_ref()) {
            let direct = read(&r.ctx, &r.meshes, Layer::Direct);
            let exact = analytic_direct(pos, idx, &poly, l);
            let mut rel = vec![0.0; nv];
            r.ctx
                .rel_error_layer(r.meshes[0], 0, Layer::Direct, &mut rel)
                .unwrap();
            let (mut z, mut k) = (0.0, 0.0);
            for v in 0..nv {
                if exact[v] > 1e-3 * ROOM_EXITANCE / PI && rel[v] < 1.0 {
                    z += (direct[v] - exact[v]).abs() / (rel[v] * direct[v]);
                    k += 1.0;
                }
            }
            println!(
                "reference's direct part vs Lambert's formula (hat averages): {:.3} % irradiance-weighted mean difference; mean |Δ|/σ over {k} lit vertices {:.2} (√(2/π) = 0.80 if unbiased and calibrated)",
                100.0 * actual(&direct, &exact),
                z / k
            );
        }
        println!(
            "\n| estimator | seed | hits/s | whole map: 1 % | 0.5 % | floor grid: 1 % | 0.5 % | actual/estimated (whole map) |"
        );
        println!("|---|---|---|---|---|---|---|---|");
        let mut sums: Vec<[f64; 4]> = Vec::new();
        let chosen = [
            ("photons only", "photons", Estimator::Photons),
            ("light sampling", "ls", ls(false)),
            ("light sampling + gathering", "gather", ls(true)),
        ];
        let mut names = Vec::new();
        for (name, _, est) in chosen
            .into_iter()
            .filter(|c| args.estimators.iter().any(|e| e == c.1))
        {
            let mut acc = [0.0f64; 4];
            let mut complete = [true; 4];
            for seed in 1..=args.seeds {
                let c = curve(
                    scene,
                    Config {
                        scheduler: args.scheduler,
                        ..config(seed)
                    },
                    est,
                    (&reference, ref_noise),
                    (&grid_ref, grid_noise),
                    args.max_seconds,
                    &args.floor,
                );
                let whole: Vec<(f64, f64)> = c.points.iter().map(|p| (p.0, p.1)).collect();
                let grid: Vec<(f64, f64)> = c.points.iter().map(|p| (p.0, p.3)).collect();
                let t = [
                    time_to(&whole, 0.01),
                    time_to(&whole, 0.005),
                    time_to(&grid, 0.01),
                    time_to(&grid, 0.005),
                ];
                let ratios: Vec<f64> = c
                    .points
                    .iter()
                    .filter(|p| p.1 < 0.05)
                    .map(|p| p.1 / p.2)
                    .collect();
                let calib = ratios.iter().sum::<f64>() / ratios.len().max(1) as f64;
                for i in 0..4 {
                    match t[i] {
                        Some(x) => acc[i] += x,
                        None => complete[i] = false,
                    }
                }
                println!(
                    "| {name} | {seed} | {:.2} M | {} | {} | {} | {} | {calib:.2} |",
                    c.hits_per_s / 1e6,
                    fmt(t[0]),
                    fmt(t[1]),
                    fmt(t[2]),
                    fmt(t[3])
                );
            }
            for i in 0..4 {
                if !complete[i] {
                    acc[i] = f64::NAN;
                }
            }
            sums.push(acc.map(|x| x / args.seeds as f64));
            names.push(name);
        }
        for k in 1..sums.len() {
            let speedup = |i: usize| sums[0][i] / sums[k][i];
            println!(
                "\n{scene}: {} is {:.1}× faster than {} to 1 % and {:.1}× to 0.5 % on the whole map, {:.1}× and {:.1}× on the floor grid (mean times; NaN: one did not get there within {} s)",
                names[k],
                speedup(0),
                names[0],
                speedup(1),
                speedup(2),
                speedup(3),
                args.max_seconds
            );
        }
    }
}

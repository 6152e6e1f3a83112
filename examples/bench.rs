//! The schedulers benchmark (the first paper's Tables 1–3, plus the limit): for each scene ×
//! band count × thread count, hits per second of the classic and the dynamic scheduler and
//! their ratio, the trace-only rate of the same threads, and each scheduler's efficiency
//! against the ideal rate T ÷ (trace cost + accumulate cost), both costs measured
//! single-threaded in the same run. Everything is measured side by side in one process.
//!
//!     cargo run --release --example bench -- [--scale 0.05] [--seconds 2]
//!         [--scenes dispersion,room,vehicle,hall,atrium,grey] [--bands 3,41,81] [--threads 1,2]
//!
//! `grey` is not one of the paper's scenes: it is the accuracy benchmark's grey room (the
//! unit cube's six walls at 40 × 40 cells, 10 086 vertices, ρ = 0.5), a map small enough
//! to stay in the cores' caches, where the schedulers differ most on few cores.
//!         [--reps 3]   (rounds alternating the schedulers; medians are printed)
//!         [--only classic|dynamic|trace]   (one scheduler alone, for profiling)
//!         [--model-threads 8,16,32,56] [--validate FILE[,FILE]] [--device-cores 16]
//!
//! After the measurements it prints the scaling model (`common/sched_model.rs`), labelled
//! as a model: the rates it predicts at the measured thread counts on this machine (beside
//! the measurements), and at `--model-threads` with as many cores, from this run's
//! one-thread costs. `--validate FILE` reads a device's saved `bench` output (as
//! `examples/data/device-*-bench.txt`) and, for its
//! rows of the scenes and band counts measured here, predicts each from the device's own
//! one-thread trace and accumulate costs and trace-only rate at that thread count (the
//! other costs in this run's proportions to them) beside what the device measured.

#[path = "common/scenes.rs"]
mod scenes;
#[path = "common/sched_model.rs"]
mod sched_model;

use imap::DynamicParams;
use imap::SchedulerKind;
use imap::{Bands, Config, Context, Report, RunParams};
use scenes::{build, grey_room, SceneKind};
use sched_model::{device_rows, predict, Costs, Load};

/// A scene of the benchmark: one of the paper's, or the grey room.
#[derive(Clone, Copy)]
enum Scene {
    Paper(SceneKind),
    Grey,
}

impl Scene {
    fn from_name(name: &str) -> Option<Self> {
        if name == "grey" {
            return Some(Scene::Grey);
        }
        SceneKind::from_name(name).map(Scene::Paper)
    }

    fn name(self) -> &'static str {
        match self {
            Scene::Paper(k) => k.name(),
            Scene::Grey => "grey",
        }
    }

    /// Builds the scene into `ctx`; its vertex count.
    fn build(self, ctx: &mut Context, scale: f64) -> usize {
        match self {
            Scene::Paper(k) => build(ctx, k, scale).expect("scene").vertices,
            Scene::Grey => grey_room(ctx, 40).expect("grey room").positions.len() / 3,
        }
    }
}

struct Args {
    scale: f64,
    seconds: f64,
    scenes: Vec<Scene>,
    bands: Vec<u32>,
    threads: Vec<usize>,
    /// Run only this scheduler for `seconds` per cell (for profiling), printing its rate.
    only: Option<SchedulerKind>,
    /// Rounds per cell: trace-only, classic and dynamic alternate in each round and the
    /// medians are reported (the machine's speed drifts by tens of percent).
    reps: usize,
    /// Thread counts (with as many cores) the model predicts.
    model_threads: Vec<usize>,
    /// A device's saved benchmark output to validate the model against, and its cores.
    validate: Option<String>,
    device_cores: usize,
}

fn parse() -> Args {
    let mut a = Args {
        scale: 0.05,
        seconds: 2.0,
        scenes: SceneKind::ALL
            .into_iter()
            .map(Scene::Paper)
            .chain([Scene::Grey])
            .collect(),
        bands: vec![3, 41, 81],
        threads: vec![
            1,
            std::thread::available_parallelism().map_or(1, |n| n.get()),
        ],
        only: None,
        reps: 3,
        model_threads: vec![8, 16, 32, 56],
        validate: None,
        device_cores: 16,
    };
    let argv: Vec<String> = std::env::args().skip(1).collect();
    let list = |s: &str| s.split(',').map(str::to_owned).collect::<Vec<_>>();
    fn numbers<T: std::str::FromStr>(s: &str, name: &str) -> Vec<T> {
        s.split(',')
            .map(|x| {
                x.parse()
                    .unwrap_or_else(|_| panic!("{name} takes numbers, not {x}"))
            })
            .collect()
    }
    for pair in argv.chunks(2) {
        let v = pair
            .get(1)
            .cloned()
            .unwrap_or_else(|| panic!("{} needs a value", pair[0]));
        match pair[0].as_str() {
            "--scale" => a.scale = v.parse().expect("--scale"),
            "--seconds" => a.seconds = v.parse().expect("--seconds"),
            "--scenes" => {
                a.scenes = list(&v)
                    .iter()
                    .map(|n| Scene::from_name(n).unwrap_or_else(|| panic!("unknown scene {n}")))
                    .collect()
            }
            "--bands" => a.bands = numbers(&v, "--bands"),
            "--threads" => a.threads = numbers(&v, "--threads"),
            "--reps" => a.reps = v.parse::<usize>().expect("--reps").max(1),
            "--model-threads" => a.model_threads = numbers(&v, "--model-threads"),
            "--validate" => {
                a.validate = Some(
                    list(&v)
                        .iter()
                        .map(|f| std::fs::read_to_string(f).unwrap_or_else(|e| panic!("{f}: {e}")))
                        .collect(),
                )
            }
            "--device-cores" => a.device_cores = v.parse().expect("--device-cores"),
            "--only" => {
                a.only = Some(match v.as_str() {
                    "classic" => SchedulerKind::Classic,
                    "dynamic" => SchedulerKind::Dynamic,
                    "trace" => SchedulerKind::TraceOnly,
                    o => panic!("--only takes classic, dynamic or trace, not {o}"),
                })
            }
            other => panic!("unknown option {other}"),
        }
    }
    a.threads.dedup();
    a
}

/// Runs `seconds` with the given scheduler and threads on a cleared map.
fn measure(ctx: &mut Context, kind: SchedulerKind, threads: usize, seconds: f64) -> Report {
    ctx.reset();
    ctx.set_scheduler(kind, DynamicParams::default())
        .expect("scheduler");
    ctx.set_threads(threads).expect("threads");
    let mut p = RunParams {
        region: None,
        photons: 0,
        time_budget_s: seconds,
        target_rel_error: 0.0,
        progress_interval_s: seconds,
        max_path_events: 1 << 20,
        selection: Default::default(),
        estimator: Some(imap::Estimator::Photons),
        progress: None,
    };
    ctx.run(&mut p).expect("run")
}

fn rate(r: &Report) -> f64 {
    r.run_hits as f64 / r.run_wall_s
}

/// The report with the median rate.
fn median(mut v: Vec<Report>) -> Report {
    v.sort_by(|a, b| rate(a).total_cmp(&rate(b)));
    v.swap_remove(v.len() / 2)
}

fn main() {
    let args = parse();
    println!(
        "# libimap scheduler benchmark: scale {}, {} s per measurement, medians of {} alternating rounds, threads {:?}",
        args.scale,
        args.seconds,
        args.reps,
        args.threads
    );
    println!("# hits/s in millions; ideal = T / (trace + accumulate cost, each measured on 1 thread); eff = rate / ideal");
    println!(
        "{:10} {:>5} {:>8} {:>8} {:>8} {:>3} {:>8} {:>8} {:>8} {:>7} {:>6} {:>6} {:>6} {:>7} {:>6} {:>7} {:>7} {:>7} {:>7}",
        "scene", "bands", "verts", "trace", "accum", "T", "trace-T", "classic", "dynamic", "dyn/cls", "ideal", "effC", "effD", "splits", "groups", "waitD", "mC", "mD", "m d/c"
    );
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let device = args
        .validate
        .as_deref()
        .map(device_rows)
        .unwrap_or_default();
    let (mut inputs, mut many, mut validated, mut checks) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for &kind in &args.scenes {
        for &nb in &args.bands {
            let bands = if nb == 3 {
                Bands::rgb()
            } else {
                Bands::spectral(nb, 380.0, 780.0).expect("bands")
            };
            let mut ctx = Context::new(Config {
                bands,
                seed: 1,
                ..Default::default()
            })
            .expect("context");
            let vertices = kind.build(&mut ctx, args.scale);
            if let Some(only) = args.only {
                for &t in &args.threads {
                    let r = measure(&mut ctx, only, t, args.seconds);
                    println!(
                        "{} {nb} bands, {only:?}, {t} threads: {:.3} M hits/s",
                        kind.name(),
                        rate(&r) / 1e6
                    );
                }
                continue;
            }
            // Warm-up: BVH build, map allocation, page faults.
            measure(&mut ctx, SchedulerKind::TraceOnly, 1, 0.2);
            // Single-thread costs per hit: tracing alone; the classic scheduler's calculating
            // thread (its time less its waits) and accumulator (its busy time); the same of
            // the dynamic scheduler with its processing threads. Medians of the rounds.
            let mut rounds: Vec<Costs> = Vec::new();
            for _ in 0..args.reps {
                let trace1 = measure(&mut ctx, SchedulerKind::TraceOnly, 1, args.seconds);
                let classic1 = measure(&mut ctx, SchedulerKind::Classic, 1, args.seconds);
                let dynamic1 = measure(&mut ctx, SchedulerKind::Dynamic, 1, args.seconds);
                let trace = 1.0 / rate(&trace1);
                let per_hit = |r: &Report, s: f64| s / r.run_hits.max(1) as f64;
                rounds.push(Costs {
                    trace,
                    classic_calc: per_hit(
                        &classic1,
                        classic1.run_wall_s - classic1.counters.calc_wait_s,
                    ) - trace,
                    classic_accum: per_hit(&classic1, classic1.counters.accum_busy_s),
                    dynamic_calc: per_hit(
                        &dynamic1,
                        dynamic1.run_wall_s - dynamic1.counters.calc_wait_s,
                    ) - trace,
                    dynamic_accum: per_hit(&dynamic1, dynamic1.counters.accum_busy_s),
                });
            }
            let med = |f: fn(&Costs) -> f64| {
                let mut v: Vec<f64> = rounds.iter().map(f).collect();
                v.sort_by(f64::total_cmp);
                v[v.len() / 2]
            };
            let costs = Costs {
                trace: med(|c| c.trace),
                classic_calc: med(|c| c.classic_calc).max(0.0),
                classic_accum: med(|c| c.classic_accum),
                dynamic_calc: med(|c| c.dynamic_calc).max(0.0),
                dynamic_accum: med(|c| c.dynamic_accum),
            };
            // The map's work per slot, from the last run (photons only).
            let load = Load::new(&slot_hits(&ctx));
            let (trace_cost, accum_cost) = (costs.trace, costs.classic_accum);
            // The per-thread trace cost at the largest thread count measured.
            let mut widest = (1usize, trace_cost);
            for &t in &args.threads {
                let (mut tr, mut cl, mut dy) = (Vec::new(), Vec::new(), Vec::new());
                for _ in 0..args.reps {
                    tr.push(measure(&mut ctx, SchedulerKind::TraceOnly, t, args.seconds));
                    cl.push(measure(&mut ctx, SchedulerKind::Classic, t, args.seconds));
                    dy.push(measure(&mut ctx, SchedulerKind::Dynamic, t, args.seconds));
                }
                let (trace, classic, dynamic) = (median(tr), median(cl), median(dy));
                let ideal = t as f64 / (trace_cost + accum_cost);
                let trace_t = t as f64 / rate(&trace);
                if t >= widest.0 {
                    widest = (t, trace_t);
                }
                let m = predict(&costs, &load, t, cores, trace_t);
                println!(
                    "{:10} {:>5} {:>8} {:>8.3} {:>8.3} {:>3} {:>8.3} {:>8.3} {:>8.3} {:>7.2} {:>6.3} {:>6.2} {:>6.2} {:>7} {:>6} {:>7.2} {:>7.3} {:>7.3} {:>7.2}",
                    kind.name(),
                    nb,
                    vertices,
                    trace_cost * 1e6,
                    accum_cost * 1e6,
                    t,
                    rate(&trace) / 1e6,
                    rate(&classic) / 1e6,
                    rate(&dynamic) / 1e6,
                    rate(&dynamic) / rate(&classic),
                    ideal / 1e6,
                    rate(&classic) / ideal,
                    rate(&dynamic) / ideal,
                    dynamic.counters.splits,
                    dynamic.counters.groups,
                    dynamic.counters.calc_wait_s,
                    m.classic / 1e6,
                    m.dynamic / 1e6,
                    m.dynamic / m.classic,
                );
            }
            inputs.push(format!(
                "{:10} {:>5} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>9.1}",
                kind.name(),
                nb,
                costs.trace * 1e6,
                costs.classic_calc * 1e6,
                costs.classic_accum * 1e6,
                costs.dynamic_calc * 1e6,
                costs.dynamic_accum * 1e6,
                load.slots() as f64 / 1e3,
            ));
            for &t in &args.model_threads {
                let m = predict(&costs, &load, t, t, widest.1);
                many.push(format!(
                    "{:10} {:>5} {:>3} {:>8.3} {:>8.3} {:>7.2} {:>6} {:>6} {:>6}",
                    kind.name(),
                    nb,
                    t,
                    m.classic / 1e6,
                    m.dynamic / 1e6,
                    m.dynamic / m.classic,
                    m.classic_bound.label(),
                    m.dynamic_bound.label(),
                    m.groups,
                ));
            }
            for row in device
                .iter()
                .filter(|r| r.scene == kind.name() && r.bands == nb)
            {
                // The device's own one-thread trace and accumulate costs and its trace-only
                // rate at the row's threads; the other costs in this run's proportions.
                let trace = row.trace_us * 1e-6;
                let accum = row.accum_us * 1e-6;
                let dev = Costs {
                    trace,
                    classic_calc: costs.classic_calc / costs.trace * trace,
                    classic_accum: accum,
                    dynamic_calc: costs.dynamic_calc / costs.trace * trace,
                    dynamic_accum: costs.dynamic_accum / costs.classic_accum * accum,
                };
                let trace_t = row.threads as f64 / (row.trace_t * 1e6);
                let m = predict(&dev, &load, row.threads, args.device_cores, trace_t);
                let (pc, pd) = (m.classic / 1e6, m.dynamic / 1e6);
                checks.push((
                    pc / row.classic,
                    pd / row.dynamic,
                    (pd / pc) / (row.dynamic / row.classic),
                ));
                validated.push(format!(
                    "{:10} {:>5} {:>3} {:>8.3} {:>8.3} {:>7.2} {:>8.3} {:>8.3} {:>7.2} {:>6.2} {:>6.2} {:>6.2} {:>6} {:>6}",
                    row.scene,
                    row.bands,
                    row.threads,
                    row.classic,
                    row.dynamic,
                    row.dynamic / row.classic,
                    pc,
                    pd,
                    pd / pc,
                    pc / row.classic,
                    pd / row.dynamic,
                    (pd / pc) / (row.dynamic / row.classic),
                    m.classic_bound.label(),
                    m.dynamic_bound.label(),
                ));
            }
        }
    }
    println!("# trace, accum: µs per hit on one thread; waitD: seconds the dynamic scheduler's calculating threads waited for free portions");
    println!("# mC, mD, m d/c: the scaling model's predicted rates on this machine's {cores} cores (a model, not a measurement; examples/common/sched_model.rs)");
    println!();
    println!("# scaling model inputs, µs per hit on one thread: trace alone; each scheduler's calculating thread beyond tracing (calc) and accumulating or processing (accum); the map's slots (thousands)");
    println!(
        "{:10} {:>5} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9}",
        "scene", "bands", "trace", "calcC", "accumC", "calcD", "accumD", "kslots"
    );
    for l in &inputs {
        println!("{l}");
    }
    println!();
    println!("# MODEL (not a measurement): T calculating threads on T cores, from the inputs above and the per-thread trace rate at the largest thread count measured; M hits/s; the limit that binds each; the dynamic scheduler's groups");
    println!(
        "{:10} {:>5} {:>3} {:>8} {:>8} {:>7} {:>6} {:>6} {:>6}",
        "scene", "bands", "T", "classic", "dynamic", "dyn/cls", "limC", "limD", "groups"
    );
    for l in &many {
        println!("{l}");
    }
    if !validated.is_empty() {
        println!();
        println!("# MODEL against the device's measurements ({} cores): measured, then predicted from the device's one-thread costs; pred/meas", args.device_cores);
        println!(
            "{:10} {:>5} {:>3} {:>8} {:>8} {:>7} {:>8} {:>8} {:>7} {:>6} {:>6} {:>6} {:>6} {:>6}",
            "scene",
            "bands",
            "T",
            "classic",
            "dynamic",
            "dyn/cls",
            "mC",
            "mD",
            "m d/c",
            "C",
            "D",
            "d/c",
            "limC",
            "limD"
        );
        for l in &validated {
            println!("{l}");
        }
        let summary = |f: fn(&(f64, f64, f64)) -> f64| {
            let mut v: Vec<f64> = checks.iter().map(f).collect();
            v.sort_by(f64::total_cmp);
            let gm = (v.iter().map(|x| x.ln()).sum::<f64>() / v.len() as f64).exp();
            format!("{:.2} ({:.2}-{:.2})", gm, v[0], v[v.len() - 1])
        };
        println!(
            "# predicted/measured over {} rows, geometric mean (range): classic {}, dynamic {}, dyn/cls {}",
            checks.len(),
            summary(|c| c.0),
            summary(|c| c.1),
            summary(|c| c.2),
        );
    }
}

/// Each map slot's effective number of hits (1 / rel_error², 0 where nothing arrived), in
/// slot order (meshes in order, each vertex's sides together), from the last run.
fn slot_hits(ctx: &Context) -> Vec<f64> {
    let mut out = Vec::new();
    let mut mesh = 0;
    while let Ok(info) = ctx.mesh_info(mesh) {
        if info.records {
            let sides: Vec<Vec<f64>> = (0..info.sides)
                .map(|side| {
                    let mut e = vec![1.0; info.vertices];
                    ctx.rel_error(mesh, side, &mut e).expect("rel_error");
                    e
                })
                .collect();
            for v in 0..info.vertices {
                for e in &sides {
                    out.push(if e[v] > 0.0 && e[v] < 1.0 {
                        1.0 / (e[v] * e[v])
                    } else {
                        0.0
                    });
                }
            }
        }
        mesh += 1;
    }
    out
}

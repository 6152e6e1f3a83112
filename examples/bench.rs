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

#[path = "common/scenes.rs"]
mod scenes;

use imap::DynamicParams;
use imap::SchedulerKind;
use imap::{Bands, Config, Context, Report, RunParams};
use scenes::{build, grey_room, SceneKind};

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
    };
    let argv: Vec<String> = std::env::args().skip(1).collect();
    let list = |s: &str| s.split(',').map(str::to_owned).collect::<Vec<_>>();
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
            "--bands" => {
                a.bands = list(&v)
                    .iter()
                    .map(|b| b.parse().expect("--bands"))
                    .collect()
            }
            "--threads" => {
                a.threads = list(&v)
                    .iter()
                    .map(|t| t.parse().expect("--threads"))
                    .collect()
            }
            "--reps" => a.reps = v.parse::<usize>().expect("--reps").max(1),
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
        "{:10} {:>5} {:>8} {:>8} {:>8} {:>3} {:>8} {:>8} {:>8} {:>7} {:>6} {:>6} {:>6} {:>7} {:>6} {:>7}",
        "scene", "bands", "verts", "trace", "accum", "T", "trace-T", "classic", "dynamic", "dyn/cls", "ideal", "effC", "effD", "splits", "groups", "waitD"
    );
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
            // Single-thread costs per hit: tracing alone, and the accumulator of the classic
            // scheduler with one calculating thread (its busy time over the run's hits).
            let mut costs: Vec<(f64, f64)> = (0..args.reps)
                .map(|_| {
                    let trace1 = measure(&mut ctx, SchedulerKind::TraceOnly, 1, args.seconds);
                    let classic1 = measure(&mut ctx, SchedulerKind::Classic, 1, args.seconds);
                    let accum = classic1.counters.accum_busy_fraction * classic1.run_wall_s
                        / classic1.run_hits as f64;
                    (1.0 / rate(&trace1), accum)
                })
                .collect();
            costs.sort_by(|a, b| (a.0 + a.1).total_cmp(&(b.0 + b.1)));
            let (trace_cost, accum_cost) = costs[costs.len() / 2];
            for &t in &args.threads {
                let (mut tr, mut cl, mut dy) = (Vec::new(), Vec::new(), Vec::new());
                for _ in 0..args.reps {
                    tr.push(measure(&mut ctx, SchedulerKind::TraceOnly, t, args.seconds));
                    cl.push(measure(&mut ctx, SchedulerKind::Classic, t, args.seconds));
                    dy.push(measure(&mut ctx, SchedulerKind::Dynamic, t, args.seconds));
                }
                let (trace, classic, dynamic) = (median(tr), median(cl), median(dy));
                let ideal = t as f64 / (trace_cost + accum_cost);
                println!(
                    "{:10} {:>5} {:>8} {:>8.3} {:>8.3} {:>3} {:>8.3} {:>8.3} {:>8.3} {:>7.2} {:>6.3} {:>6.2} {:>6.2} {:>7} {:>6} {:>7.2}",
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
                );
            }
        }
    }
    println!("# trace, accum: µs per hit on one thread; waitD: seconds the dynamic scheduler's calculating threads waited for free portions");
}

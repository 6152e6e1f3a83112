//! The second paper's comparison (Tables 1–3 and the accuracy after equal time): the
//! Cornell box rendered by backward photon maps with the synchronous, asynchronous and
//! semi-synchronous methods at each thread count, all in one process.
//!
//! For each thread count T and method: forward rays, forward photons and backward paths per
//! second, their speedup over the same method on one thread, the memory of the maps and
//! pixel stores, and the accuracy reached after the same wall time: the RMS deviation of
//! every pixel and band from a long reference render (semi-synchronous, all threads,
//! another seed), over the reference's mean radiance, beside the method's own estimate.
//!
//!     cargo run --release --example render_bench -- [--threads 1,2] [--seconds 10]
//!         [--reference-seconds 120] [--size 256] [--group-threads 1]
//!         [--methods sync,async,semi] [--reps 1]
//!
//! `--methods` may add `fg` (final gathering from the map; not the paper's): its
//! accuracy is measured against the same semi-synchronous reference, whose edges read low
//! (BENCHMARKS.md, "The renderer per region"), so its deviation there is partly the
//! reference's.

#[path = "common/scenes.rs"]
mod scenes;

use imap::RenderReport;
use imap::{Config, Context, Image, RenderMethod, RenderParams};
use scenes::{cornell_box, cornell_camera};

struct Args {
    threads: Vec<usize>,
    seconds: f64,
    reference_seconds: f64,
    size: u32,
    group_threads: usize,
    methods: Vec<RenderMethod>,
    reps: usize,
}

fn parse() -> Args {
    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut a = Args {
        threads: [1, 2, 4, 8, 12].into_iter().filter(|&t| t <= all).collect(),
        seconds: 10.0,
        reference_seconds: 120.0,
        size: 256,
        group_threads: 1,
        methods: vec![
            RenderMethod::Synchronous,
            RenderMethod::Asynchronous,
            RenderMethod::SemiSynchronous,
        ],
        reps: 1,
    };
    let argv: Vec<String> = std::env::args().skip(1).collect();
    for pair in argv.chunks(2) {
        let v = pair
            .get(1)
            .cloned()
            .unwrap_or_else(|| panic!("{} needs a value", pair[0]));
        match pair[0].as_str() {
            "--threads" => {
                a.threads = v
                    .split(',')
                    .map(|t| t.parse().expect("--threads"))
                    .collect()
            }
            "--seconds" => a.seconds = v.parse().expect("--seconds"),
            "--reference-seconds" => a.reference_seconds = v.parse().expect("--reference-seconds"),
            "--size" => a.size = v.parse().expect("--size"),
            "--group-threads" => a.group_threads = v.parse().expect("--group-threads"),
            "--reps" => a.reps = v.parse().expect("--reps"),
            "--methods" => {
                a.methods = v
                    .split(',')
                    .map(|m| match m {
                        "sync" => RenderMethod::Synchronous,
                        "async" => RenderMethod::Asynchronous,
                        "semi" => RenderMethod::SemiSynchronous,
                        "fg" => RenderMethod::FinalGather,
                        _ => panic!("unknown method {m} (sync, async, semi, fg)"),
                    })
                    .collect()
            }
            other => panic!("unknown option {other}"),
        }
    }
    a
}

fn name(m: RenderMethod) -> &'static str {
    match m {
        RenderMethod::Synchronous => "sync",
        RenderMethod::Asynchronous => "async",
        RenderMethod::SemiSynchronous => "semi",
        RenderMethod::FinalGather => "fg",
    }
}

/// A context holding the open Cornell box (RGB, millimetres) for `threads` threads.
fn scene(threads: usize, seed: u64) -> Context {
    let mut ctx = Context::new(Config {
        threads,
        seed,
        unit_m: 0.001,
        ..Default::default()
    })
    .expect("context");
    cornell_box(&mut ctx, true, 8).expect("Cornell box");
    ctx
}

fn render(
    ctx: &mut Context,
    method: RenderMethod,
    group_threads: usize,
    size: u32,
    seconds: f64,
) -> (Image, RenderReport) {
    let mut p = RenderParams {
        method,
        group_threads,
        time_budget_s: seconds,
        progress_interval_s: 0.25,
        ..Default::default()
    };
    ctx.render(&cornell_camera(size, size), &mut p)
        .expect("render")
}

/// RMS deviation over pixels and bands from the reference, over the reference's mean.
fn error_against(img: &Image, reference: &Image) -> f64 {
    let n = img.radiance.len() as f64;
    let sq: f64 = img
        .radiance
        .iter()
        .zip(&reference.radiance)
        .map(|(v, r)| (v - r) * (v - r))
        .sum();
    let mean: f64 = reference.radiance.iter().sum::<f64>() / n;
    (sq / n).sqrt() / mean
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let a = parse();
    let all = *a.threads.iter().max().expect("--threads is empty");
    println!(
        "Cornell box (open front, 8×8 cells per wall), {0}×{0} pixels, RGB; {1} s per render, \
         median of {2}; reference: semi-synchronous, {all} threads, {3} s, seed 7",
        a.size, a.seconds, a.reps, a.reference_seconds
    );
    let mut ctx = scene(all, 7);
    let (reference, rr) = render(
        &mut ctx,
        RenderMethod::SemiSynchronous,
        a.group_threads,
        a.size,
        a.reference_seconds,
    );
    println!(
        "reference: {:.0} samples per pixel, {} forward photons, estimated error {:.4}",
        rr.passes, rr.forward_photons, rr.rel_error
    );
    drop(ctx);
    println!(
        "\n{:>3} {:>6} {:>6} {:>11} {:>11} {:>11} {:>8} {:>8} {:>7} {:>9} {:>9} {:>9} {:>9} {:>9}",
        "T",
        "method",
        "groups",
        "fwd rays/s",
        "fwd phot/s",
        "bwd path/s",
        "speedup",
        "vs async",
        "spp",
        "MB/group",
        "MB total",
        "error",
        "estimate",
        "joins"
    );
    let mut base: Vec<Option<f64>> = vec![None; a.methods.len()];
    for &t in &a.threads {
        let mut async_rate = None;
        let mut rows = Vec::new();
        for (mi, &m) in a.methods.iter().enumerate() {
            // Each repetition its own seed: independent images, independent errors.
            let runs: Vec<_> = (0..a.reps as u64)
                .map(|rep| {
                    let mut ctx = scene(t, 2026 + rep);
                    render(&mut ctx, m, a.group_threads, a.size, a.seconds)
                })
                .collect();
            let rate = |f: &dyn Fn(&RenderReport) -> u64| {
                median(runs.iter().map(|(_, r)| f(r) as f64 / r.wall_s).collect())
            };
            let fwd = rate(&|r| r.forward_rays);
            let photons = rate(&|r| r.forward_photons);
            let paths = rate(&|r| r.backward_paths);
            let err = median(
                runs.iter()
                    .map(|(img, _)| error_against(img, &reference))
                    .collect(),
            );
            let est = median(runs.iter().map(|(_, r)| r.rel_error).collect());
            let spp = median(runs.iter().map(|(_, r)| r.passes).collect());
            let r = &runs[0].1;
            if m == RenderMethod::Asynchronous {
                async_rate = Some(fwd);
            }
            let speedup = fwd / *base[mi].get_or_insert(fwd);
            let memory = (r.map_bytes_per_group, r.total_bytes, r.joins);
            rows.push((
                m, r.groups, fwd, photons, paths, speedup, spp, memory, err, est,
            ));
        }
        let err_of = |want: RenderMethod| rows.iter().find(|r| r.0 == want).map(|r| r.8);
        let summary = (
            err_of(RenderMethod::SemiSynchronous),
            err_of(RenderMethod::Synchronous),
            err_of(RenderMethod::Asynchronous),
            rows.iter()
                .find(|r| r.0 == RenderMethod::SemiSynchronous)
                .map(|r| r.2),
        );
        for (m, groups, fwd, photons, paths, speedup, spp, (per_group, total, joins), err, est) in
            rows
        {
            let vs_async = async_rate.map_or(f64::NAN, |x| fwd / x);
            println!(
                "{t:>3} {:>6} {groups:>6} {:>11.3e} {:>11.3e} {:>11.3e} {speedup:>8.2} {vs_async:>8.2} {spp:>7.1} {:>9.2} {:>9.2} {err:>9.4} {est:>9.4} {:>9}",
                name(m),
                fwd,
                photons,
                paths,
                per_group as f64 / 1e6,
                total as f64 / 1e6,
                joins
            );
        }
        if let (Some(semi), Some(sync), Some(asy), Some(rate)) = summary {
            // Errors with the reference's own estimated error taken out (in quadrature).
            let own = |e: f64| (e * e - rr.rel_error * rr.rel_error).max(0.0).sqrt();
            println!(
                "{t:>3} semi/sync error {:.2} (reference's error removed: {:.2}), semi/async error {:.2}, semi/async forward rays/s {:.2}",
                semi / sync,
                own(semi) / own(sync),
                semi / asy,
                rate / async_rate.unwrap_or(f64::NAN)
            );
        }
    }
}

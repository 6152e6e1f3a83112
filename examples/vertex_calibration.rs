//! Per-vertex calibration of the error estimate: a luminaire (c_examples/data's EULUMDAT
//! wall washer or IES downlight) at the centre of a black sphere, every vertex's value
//! against a long photons-only reference, over seeds and photon counts: the share of
//! values beyond 2 and 3 estimated standard errors (1-in-20 and 3-in-1000 for a calibrated
//! normal estimate) and the correlation of value and σ.
//!
//! With `room`: the benchmark's grey room (its six walls at 40 × 40 cells) by light
//! sampling and by gathering, against a long gathering reference, also giving the mean of
//! z² per vertex (1 when calibrated); `REF=photons|ls|gather` and `REF_PHOTONS=n` choose
//! another reference, `COUNTS=a,b,…` the photon counts (0: until the estimated global
//! error is 1 %), `EMITTER_Z` the emitter's height (0.999: the peers' room of issue 37).
//!
//! usage: cargo run --release --example vertex_calibration [ldt|ies|room] [seeds]

// The tests' scene builders (the inward sphere).
#[path = "../tests/common/mod.rs"]
mod scenes;
// The benchmarks' (the grey room).
#[path = "common/scenes.rs"]
mod bench_scenes;

use imap::photometry::Spectrum;
use imap::Placement;
use imap::{Config, Context, Estimator, MaterialDesc, RunParams};

fn run(kind: &str, seed: u64, photons: u64, e: Estimator) -> (Vec<f64>, Vec<f64>) {
    if kind == "room" {
        return room(seed, photons, e);
    }
    let mut ctx = Context::new(Config {
        seed,
        threads: 2,
        ..Default::default()
    })
    .unwrap();
    let black = ctx.add_material(&MaterialDesc::default()).unwrap();
    let sphere = scenes::sphere_inward(1.0, 4);
    let id = ctx.add_mesh(&sphere.desc(black)).unwrap();
    let place = Placement {
        position: [0.05, -0.03, 0.02],
        aim: [0.3, -1.0, 0.2],
        ..Default::default()
    };
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/c_examples/data/");
    if kind == "ies" {
        let t = std::fs::read_to_string(format!("{dir}downlight.ies")).unwrap();
        ctx.add_luminaire_ies(&t, None, &place, &Spectrum::Equal)
            .unwrap();
    } else {
        let t = std::fs::read_to_string(format!("{dir}wallwasher.ldt")).unwrap();
        ctx.add_luminaire_ldt(&t, &place, &Spectrum::Equal).unwrap();
    }
    ctx.run(&mut RunParams {
        photons,
        progress_interval_s: 10.0,
        estimator: Some(e),
        ..Default::default()
    })
    .unwrap();
    let nv = sphere.vertex_count();
    let (mut x, mut r) = (vec![0.0; nv], vec![0.0; nv]);
    ctx.irradiance(id, 0, 0, &mut x).unwrap();
    ctx.rel_error(id, 0, &mut r).unwrap();
    let s = x.iter().zip(&r).map(|(x, r)| x * r).collect();
    (x, s)
}

/// The grey room's whole map (band mean) and its σ after `photons`.
fn room(seed: u64, photons: u64, e: Estimator) -> (Vec<f64>, Vec<f64>) {
    let mut ctx = Context::new(Config {
        seed,
        threads: 2,
        ..Default::default()
    })
    .unwrap();
    // EMITTER_Z: the emitter's height (0.98 by default; the peers' room of issue 37: 0.999).
    let z = std::env::var("EMITTER_Z")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(bench_scenes::GREY_ROOM_EMITTER_Z);
    let r = bench_scenes::grey_room_at(&mut ctx, 40, None, z).unwrap();
    // 0 photons: until the estimated (global) error is 1 %.
    ctx.run(&mut RunParams {
        photons: if photons == 0 { u64::MAX } else { photons },
        target_rel_error: if photons == 0 { 0.01 } else { 0.0 },
        progress_interval_s: if photons == 0 { 0.05 } else { 10.0 },
        estimator: Some(e),
        ..Default::default()
    })
    .unwrap();
    let nv = ctx.vertex_count(r.walls).unwrap();
    let (mut x, mut rel) = (vec![0.0; nv], vec![0.0; nv]);
    ctx.irradiance(r.walls, 0, 0, &mut x).unwrap();
    ctx.rel_error(r.walls, 0, &mut rel).unwrap();
    let s = x.iter().zip(&rel).map(|(x, r)| x * r).collect();
    (x, s)
}

fn main() {
    if std::env::var("TAILS").is_ok() {
        return tails("ldt");
    }
    let args: Vec<String> = std::env::args().collect();
    let kind = args.get(1).map_or("ldt", String::as_str).to_string();
    let seeds: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(6);
    // The reference's own error counts in every comparison.
    let (estimators, counts, ref_count, ref_e) = if kind == "room" {
        (
            vec![
                ("light sampling", Estimator::DEFAULT),
                ("gathering", Estimator::GATHER),
            ],
            match std::env::var("COUNTS") {
                Ok(c) => c.split(',').filter_map(|x| x.parse().ok()).collect(),
                Err(_) => vec![30_000u64, 100_000, 400_000, 0],
            },
            2_000_000,
            Estimator::GATHER,
        )
    } else {
        (
            vec![
                ("photons", Estimator::Photons),
                ("light sampling", Estimator::DEFAULT),
            ],
            vec![100_000u64, 1_000_000, 4_000_000],
            40_000_000,
            Estimator::Photons,
        )
    };
    // REF = photons | ls | gather and REF_PHOTONS choose another reference.
    let ref_e = match std::env::var("REF").as_deref() {
        Ok("photons") => Estimator::Photons,
        Ok("ls") => Estimator::DEFAULT,
        Ok("gather") => Estimator::GATHER,
        _ => ref_e,
    };
    let ref_count = std::env::var("REF_PHOTONS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(ref_count);
    let (reference, ref_sigma) = run(&kind, 999, ref_count, ref_e);
    for (name, e) in estimators {
        for &photons in &counts {
            let (mut beyond2, mut beyond3, mut n) = (0usize, 0usize, 0usize);
            let mut z2 = 0.0;
            let runs: Vec<(Vec<f64>, Vec<f64>)> = (0..seeds)
                .map(|seed| run(&kind, seed, photons, e))
                .collect();
            for (x, s) in &runs {
                for v in 0..x.len() {
                    // A vertex that got nothing claims nothing (its relative error is 1).
                    if reference[v] <= 0.0 || x[v] <= 0.0 {
                        continue;
                    }
                    let z = (x[v] - reference[v]).abs() / s[v].hypot(ref_sigma[v]).max(1e-300);
                    z2 += z * z;
                    beyond2 += usize::from(z > 2.0);
                    beyond3 += usize::from(z > 3.0);
                    n += 1;
                }
            }
            // Per vertex, the correlation over seeds of its value and its σ (a calibrated
            // estimate has none); the mean over vertices.
            let (mut corr, mut counted) = (0.0, 0);
            for v in 0..reference.len() {
                let xs: Vec<f64> = runs.iter().map(|r| r.0[v]).collect();
                let ss: Vec<f64> = runs.iter().map(|r| r.1[v]).collect();
                let (mx, ms) = (
                    xs.iter().sum::<f64>() / seeds as f64,
                    ss.iter().sum::<f64>() / seeds as f64,
                );
                let cov: f64 = xs.iter().zip(&ss).map(|(x, s)| (x - mx) * (s - ms)).sum();
                let vx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
                let vs: f64 = ss.iter().map(|s| (s - ms).powi(2)).sum();
                if vx > 0.0 && vs > 0.0 {
                    corr += cov / (vx * vs).sqrt();
                    counted += 1;
                }
            }
            println!(
                "{name:15} {photons:>9} photons: beyond 2σ {:.2} %, beyond 3σ {:.2} % (normal: 4.55, 0.27), mean z² {:.3}, corr(value, σ) over seeds {:+.2}",
                100.0 * beyond2 as f64 / n as f64,
                100.0 * beyond3 as f64 / n as f64,
                z2 / n as f64,
                corr / counted.max(1) as f64
            );
        }
    }
}

/// The dimmest vertices by both estimators at many photons: do they agree?
#[allow(dead_code)]
pub fn tails(kind: &str) {
    let (a, sa) = run(kind, 7, 40_000_000, Estimator::Photons);
    let (b, sb) = run(kind, 8, 40_000_000, Estimator::DEFAULT);
    let mut idx: Vec<usize> = (0..a.len()).filter(|&v| a[v] > 0.0).collect();
    idx.sort_by(|&x, &y| a[x].total_cmp(&a[y]));
    for &v in idx.iter().take(25) {
        println!(
            "v {v}: photons {:.3e} ± {:.1} %, light sampling {:.3e} ± {:.1} %, z {:.1}",
            a[v],
            100.0 * sa[v] / a[v],
            b[v],
            100.0 * sb[v] / b[v].max(1e-300),
            (a[v] - b[v]) / sa[v].hypot(sb[v])
        );
    }
}

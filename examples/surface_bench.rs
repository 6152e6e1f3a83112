//! What rough surfaces cost: photons and surface hits per second on the benchmark room
//! (`grey_room`, 40 × 40 cells a wall) with its floor Lambertian (ρ = 0.5), rough
//! aluminium (GGX α = 0.3), a plastic (ρ = 0.5 under a coat of n = 1.5, α = 0.2) or a
//! nearly smooth white metal (α = 0.05), photons only, side by side in one process:
//! rounds alternate the order of the floors, and each cell is the median over rounds.
//! The ratios to the Lambertian floor are printed (the target: at least 0.5).
//!
//!     cargo run --release --example surface_bench -- [--threads 2] [--bands 3,81]
//!         [--seconds 1.5] [--rounds 5]

#[path = "common/scenes.rs"]
mod scenes;

use imap::{
    Bands, ConductorIndex, Config, Context, Estimator, IorModel, MaterialDesc, Metal, RunParams,
    SurfaceModel,
};
use scenes::grey_room_with_floor;

fn floors() -> Vec<(&'static str, Option<MaterialDesc>)> {
    vec![
        ("lambert 0.5", None),
        (
            "aluminium α 0.3",
            Some(MaterialDesc {
                surface: SurfaceModel::Conductor(ConductorIndex::Metal(Metal::Aluminium)),
                roughness: [0.3, 0.0],
                ..Default::default()
            }),
        ),
        (
            "plastic α 0.2",
            Some(MaterialDesc {
                surface: SurfaceModel::Plastic,
                diffuse_reflect: vec![0.5],
                ior: Some(IorModel::Constant(1.5)),
                roughness: [0.2, 0.0],
                ..Default::default()
            }),
        ),
        (
            "white metal α 0.05",
            Some(MaterialDesc {
                surface: SurfaceModel::Conductor(ConductorIndex::Table(vec![
                    [300.0, 1e-4, 1e4],
                    [900.0, 1e-4, 1e4],
                ])),
                roughness: [0.05, 0.0],
                ..Default::default()
            }),
        ),
    ]
}

fn main() {
    let mut threads = 2;
    let mut bands = vec![3u32, 81];
    let mut seconds = 1.5;
    let mut rounds = 5;
    let argv: Vec<String> = std::env::args().skip(1).collect();
    for pair in argv.chunks(2) {
        let v = pair.get(1).cloned().expect("a value");
        match pair[0].as_str() {
            "--threads" => threads = v.parse().expect("--threads"),
            "--bands" => bands = v.split(',').map(|b| b.parse().expect("--bands")).collect(),
            "--seconds" => seconds = v.parse().expect("--seconds"),
            "--rounds" => rounds = v.parse().expect("--rounds"),
            other => panic!("unknown argument {other}"),
        }
    }
    let floors = floors();
    for &nb in &bands {
        // Per floor: (photons/s, hits/s) of every round.
        let mut rates: Vec<Vec<(f64, f64)>> = vec![Vec::new(); floors.len()];
        for round in 0..rounds {
            let mut order: Vec<usize> = (0..floors.len()).collect();
            if round % 2 == 1 {
                order.reverse();
            }
            for &f in &order {
                let b = if nb == 3 {
                    Bands::rgb()
                } else {
                    Bands::spectral(nb, 380.0, 780.0).unwrap()
                };
                let mut ctx = Context::new(Config {
                    threads,
                    seed: 1 + round as u64,
                    bands: b,
                    ..Default::default()
                })
                .unwrap();
                grey_room_with_floor(&mut ctx, 40, floors[f].1.as_ref()).unwrap();
                let r = ctx
                    .run(&mut RunParams {
                        time_budget_s: seconds,
                        progress_interval_s: 10.0,
                        estimator: Some(Estimator::Photons),
                        ..Default::default()
                    })
                    .unwrap();
                rates[f].push((
                    r.run_photons as f64 / r.run_wall_s,
                    r.run_hits as f64 / r.run_wall_s,
                ));
            }
        }
        let median = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let base = median(rates[0].iter().map(|r| r.0).collect());
        println!("{nb} bands, {threads} threads, {rounds} rounds of {seconds} s (medians):");
        println!("| floor | M photons/s | M hits/s | photons/s ÷ Lambertian's |");
        println!("|---|---|---|---|");
        for (f, (name, _)) in floors.iter().enumerate() {
            let p = median(rates[f].iter().map(|r| r.0).collect());
            let h = median(rates[f].iter().map(|r| r.1).collect());
            println!(
                "| {name} | {:.3} | {:.3} | {:.2} |",
                p / 1e6,
                h / 1e6,
                p / base
            );
        }
        println!();
    }
}

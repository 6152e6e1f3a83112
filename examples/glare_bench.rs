//! What observers cost: an office (6 × 4 × 3 m, grey ρ = 0.5, six 0.6 m Lambertian
//! ceiling panels) with a desk-height calculation grid (0.8 m, 0.2 m spacing), run with and
//! without ten seated observers. The observers' run also reads each one's Ev, UGR with its
//! sources, DGPs and, in spectral runs, the α-opic light. Each round builds both contexts
//! and times, in alternating order, the run (a fixed photon count) and the readout of what
//! each gives. The median over rounds of the time ratio is printed. The target is
//! less than 10 % extra.
//!
//!     cargo run --release --example glare_bench -- [--threads 2] [--bands 3,41]
//!         [--photons 400000] [--rounds 5] [--estimator gather|light]

use imap::glare::Observer;
use imap::photometry::Spectrum;
use imap::{Bands, Config, Context, Estimator, MaterialDesc, MeshDesc, Placement, RunParams};
use std::time::Instant;

const X: f64 = 6.0;
const Y: f64 = 4.0;
const Z: f64 = 3.0;

/// A quad from `o` along `u` and `v`, `n` × `m` cells, its normal u × v.
fn quad(
    o: [f64; 3],
    u: [f64; 3],
    v: [f64; 3],
    n: usize,
    m: usize,
    p: &mut Vec<f64>,
    t: &mut Vec<u32>,
) {
    let base = (p.len() / 3) as u32;
    for j in 0..=m {
        for i in 0..=n {
            let (a, b) = (i as f64 / n as f64, j as f64 / m as f64);
            for k in 0..3 {
                p.push(o[k] + a * u[k] + b * v[k]);
            }
        }
    }
    for j in 0..m as u32 {
        for i in 0..n as u32 {
            let a = base + j * (n as u32 + 1) + i;
            let (b, c, d) = (a + 1, a + n as u32 + 2, a + n as u32 + 1);
            t.extend([a, b, c, a, c, d]);
        }
    }
}

fn panel_ies() -> String {
    let mut s = String::from("IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 19 1 1 2 0.6 0.6 0\n1 1 40\n");
    for k in 0..19 {
        s.push_str(&format!("{} ", 5 * k));
    }
    s.push_str("\n0\n");
    for k in 0..19 {
        s.push_str(&format!(
            "{:.4} ",
            1500.0 * (5.0 * k as f64).to_radians().cos()
        ));
    }
    s.push('\n');
    s
}

struct Office {
    ctx: Context,
    grid: u32,
    grid_vertices: usize,
    observers: Vec<(Observer, u32)>,
}

fn office(bands: &Bands, threads: usize, with_observers: bool) -> Office {
    let mut ctx = Context::new(Config {
        bands: bands.clone(),
        threads,
        seed: 7,
        ..Default::default()
    })
    .expect("context");
    let grey = ctx
        .add_material(&MaterialDesc {
            diffuse_reflect: vec![0.5],
            ..Default::default()
        })
        .unwrap();
    let (mut p, mut t) = (Vec::new(), Vec::new());
    let c = 10;
    // Every face's normal points into the room.
    quad(
        [0.0, 0.0, 0.0],
        [X, 0.0, 0.0],
        [0.0, Y, 0.0],
        6 * c,
        4 * c,
        &mut p,
        &mut t,
    );
    quad(
        [0.0, 0.0, Z],
        [0.0, Y, 0.0],
        [X, 0.0, 0.0],
        4 * c,
        6 * c,
        &mut p,
        &mut t,
    );
    quad(
        [0.0, 0.0, 0.0],
        [0.0, 0.0, Z],
        [X, 0.0, 0.0],
        3 * c,
        6 * c,
        &mut p,
        &mut t,
    );
    quad(
        [0.0, Y, 0.0],
        [X, 0.0, 0.0],
        [0.0, 0.0, Z],
        6 * c,
        3 * c,
        &mut p,
        &mut t,
    );
    quad(
        [0.0, 0.0, 0.0],
        [0.0, Y, 0.0],
        [0.0, 0.0, Z],
        4 * c,
        3 * c,
        &mut p,
        &mut t,
    );
    quad(
        [X, 0.0, 0.0],
        [0.0, 0.0, Z],
        [0.0, Y, 0.0],
        3 * c,
        4 * c,
        &mut p,
        &mut t,
    );
    ctx.add_mesh(&MeshDesc::new(&p, &t, grey)).unwrap();
    // The desk-height grid: a sensor mesh of 0.2 m cells.
    let (mut gp, mut gt) = (Vec::new(), Vec::new());
    quad(
        [0.2, 0.2, 0.8],
        [X - 0.4, 0.0, 0.0],
        [0.0, Y - 0.4, 0.0],
        28,
        18,
        &mut gp,
        &mut gt,
    );
    let grid = ctx
        .add_mesh(&MeshDesc {
            sensor: true,
            ..MeshDesc::new(&gp, &gt, 0)
        })
        .unwrap();
    let text = panel_ies();
    for x in [1.5, 3.0, 4.5] {
        for y in [1.2, 2.8] {
            ctx.add_luminaire_ies(
                &text,
                None,
                &Placement {
                    position: [x, y, Z - 0.01],
                    ..Default::default()
                },
                &Spectrum::Blackbody(4000.0),
            )
            .unwrap();
        }
    }
    let mut observers = Vec::new();
    if with_observers {
        for k in 0..10 {
            let a = k as f64 / 10.0 * std::f64::consts::TAU;
            let o = Observer {
                eye: [
                    0.8 + 0.45 * k as f64,
                    if k % 2 == 0 { 1.0 } else { 3.0 },
                    1.2,
                ],
                view: [a.cos(), a.sin(), 0.0],
                up: [0.0, 0.0, 1.0],
            };
            let mesh = ctx.add_observer_sensor(&o, 0.05).unwrap();
            observers.push((o, mesh));
        }
    }
    Office {
        ctx,
        grid,
        grid_vertices: gp.len() / 3,
        observers,
    }
}

/// Runs and reads everything the office gives; seconds.
fn time(o: &mut Office, photons: u64, estimator: Estimator) -> f64 {
    let t0 = Instant::now();
    o.ctx
        .run(&mut RunParams {
            photons,
            progress_interval_s: 10.0,
            estimator: Some(estimator),
            ..Default::default()
        })
        .unwrap();
    let mut lux = vec![0.0; o.grid_vertices];
    o.ctx.illuminance(o.grid, 0, &mut lux).unwrap();
    let spectral = !o.ctx.config().bands.rgb;
    let mut sink = lux.iter().sum::<f64>();
    for (obs, mesh) in o.observers.clone() {
        let (ev, s) = o.ctx.observer_ev(mesh).unwrap();
        let g = o.ctx.observer_glare(&obs, ev, s).unwrap();
        sink += g.ugr.min(100.0) + g.dgps;
        if spectral {
            sink += o.ctx.observer_alpha_opic(mesh).unwrap().edi_lx[4];
        }
    }
    assert!(sink.is_finite());
    t0.elapsed().as_secs_f64()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str, default: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1).cloned())
            .unwrap_or_else(|| default.to_string())
    };
    let threads: usize = arg("--threads", "2").parse().unwrap();
    let photons: u64 = arg("--photons", "400000").parse().unwrap();
    let rounds: usize = arg("--rounds", "5").parse().unwrap();
    let estimator = match arg("--estimator", "gather").as_str() {
        "light" => Estimator::DEFAULT,
        _ => Estimator::GATHER,
    };
    println!(
        "office 6 × 4 × 3 m, 6 panels, grid of 29 × 19 points; {photons} photons, {threads} threads, {estimator:?}, {rounds} rounds (alternating)"
    );
    for b in arg("--bands", "3,41").split(',') {
        let n: u32 = b.parse().unwrap();
        let bands = if n == 3 {
            Bands::rgb()
        } else {
            Bands::spectral(n, 380.0, 780.0).unwrap()
        };
        let (mut plain, mut with, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
        for r in 0..rounds {
            let mut a = office(&bands, threads, false);
            let mut b = office(&bands, threads, true);
            let (ta, tb) = if r % 2 == 0 {
                let ta = time(&mut a, photons, estimator);
                (ta, time(&mut b, photons, estimator))
            } else {
                let tb = time(&mut b, photons, estimator);
                (time(&mut a, photons, estimator), tb)
            };
            plain.push(ta);
            with.push(tb);
            ratio.push(tb / ta);
        }
        println!(
            "{n:>2} bands: grid only {:.2} s, grid and 10 observers {:.2} s: ratio {:.3} (median of {rounds}; rounds {})",
            median(plain),
            median(with),
            median(ratio.clone()),
            ratio.iter().map(|r| format!("{r:.3}")).collect::<Vec<_>>().join(" ")
        );
    }
}

//! What states cost on a large map: a floor of about 1 M recording vertices at 81 bands
//! (656 MB of accumulators) split into two photon ranges, each context's state saved to a
//! file, and the two loaded and merged into a third context; also the in-memory merge and
//! the MPI path (summing the accumulator arrays, merging a ledger). Every figure is wall
//! time of this process on this machine; files are read back from the page cache.
//!
//!     cargo run --release --example state_bench -- [cells per side = 1000] [bands = 81]
//!         [photons = 200000] [folder = /tmp]

use imap::FLAG_NO_MAP;
use imap::{Bands, Config, Context, MaterialDesc, MeshDesc, RunParams, Selection};
use std::time::Instant;

fn context(n: usize, bands: u32) -> Context {
    let mut ctx = Context::new(Config {
        bands: Bands::spectral(bands, 380.0, 780.0).unwrap(),
        threads: 2,
        seed: 1,
        ..Config::default()
    })
    .unwrap();
    let grey = ctx
        .add_material(&MaterialDesc {
            diffuse_reflect: vec![0.5],
            ..Default::default()
        })
        .unwrap();
    let mut positions = Vec::with_capacity(3 * (n + 1) * (n + 1));
    for j in 0..=n {
        for i in 0..=n {
            positions.extend([i as f64 / n as f64, j as f64 / n as f64, 0.0]);
        }
    }
    let mut indices = Vec::with_capacity(6 * n * n);
    for j in 0..n {
        for i in 0..n {
            let a = (j * (n + 1) + i) as u32;
            let (b, c, d) = (a + 1, a + n as u32 + 2, a + n as u32 + 1);
            indices.extend([a, b, c, a, c, d]);
        }
    }
    ctx.add_mesh(&MeshDesc::new(&positions, &indices, grey))
        .unwrap();
    ctx.add_point_light([0.5, 0.5, 1.0], &[10.0]).unwrap();
    ctx
}

fn timed<T>(what: &str, f: impl FnOnce() -> T) -> (T, f64) {
    let t = Instant::now();
    let x = f();
    let s = t.elapsed().as_secs_f64();
    println!("{what:<58} {s:>8.3} s");
    (x, s)
}

fn main() {
    let arg = |i: usize| std::env::args().nth(i);
    let n: usize = arg(1).map_or(1000, |s| s.parse().expect("cells"));
    let bands: u32 = arg(2).map_or(81, |s| s.parse().expect("bands"));
    let photons: u64 = arg(3).map_or(200_000, |s| s.parse().expect("photons"));
    let dir = std::path::PathBuf::from(arg(4).unwrap_or_else(|| "/tmp".into()));
    let (fa, fb) = (
        dir.join("state_bench_a.imap"),
        dir.join("state_bench_b.imap"),
    );
    let run = |ctx: &mut Context, sel: Selection| {
        ctx.run(&mut RunParams {
            selection: sel,
            ..Default::default()
        })
        .unwrap()
    };
    let (mut a, _) = timed("build context A (scene, BVH)", || context(n, bands));
    run(&mut a, Selection::range(0, photons / 2));
    let mut b = context(n, bands);
    run(&mut b, Selection::range(photons / 2, photons));
    let vertices = (n + 1) * (n + 1);
    let map_mb = a.report().map_bytes as f64 / 1e6;
    println!(
        "{vertices} vertices × {bands} bands: map of {map_mb:.0} MB; {photons} photons in two ranges"
    );
    let (bytes, save_s) = timed("save A's state (write, fsync, rename)", || {
        a.save_state(&fa, &[]).unwrap()
    });
    b.save_state(&fb, &[]).unwrap();
    let (_, fp_s) = timed("fingerprint of the scene (hash of every vertex)", || {
        a.fingerprint()
    });
    let mut c = context(n, bands);
    timed("prepare a new context (BVH, zeroed map)", || {
        c.map_accumulators().unwrap();
    });
    let (_, load_s) = timed("load A's state from its file into a new context", || {
        c.load_state_file(&fa).unwrap()
    });
    let (_, merge_s) = timed("merge B's state from its file", || {
        c.merge_state_file(&fb).unwrap()
    });
    let sb = std::fs::read(&fb).unwrap();
    let mut d = context(n, bands);
    d.load_state_file(&fa).unwrap();
    let (_, mem_s) = timed("merge B's state from memory (no file)", || {
        d.merge_state(&sb).unwrap()
    });
    drop(sb);
    // The MPI path: sum the arrays (MPI_Reduce's work at the root), merge the ledger.
    let ledger = b.state_bytes(FLAG_NO_MAP, &[]).unwrap();
    let theirs = b.map_accumulators().unwrap().to_vec();
    let (_, sum_s) = timed(
        "sum two accumulator arrays (the reduction's arithmetic)",
        || {
            for (x, y) in a.map_accumulators().unwrap().iter_mut().zip(&theirs) {
                *x += y;
            }
        },
    );
    let (_, ledger_s) = timed(&format!("merge a ledger ({} bytes)", ledger.len()), || {
        a.merge_state(&ledger).unwrap()
    });
    assert_eq!(c.report().photons, photons);
    assert_eq!(a.report().photons, photons);
    println!(
        "| {vertices} | {bands} | {map_mb:.0} | {:.0} | {save_s:.2} | {load_s:.2} | {merge_s:.2} | {mem_s:.2} | {sum_s:.2} + {ledger_s:.3} | {fp_s:.3} |",
        bytes as f64 / 1e6
    );
    let _ = std::fs::remove_file(&fa);
    let _ = std::fs::remove_file(&fb);
}

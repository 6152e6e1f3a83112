//! Map state out and in: photon ranges and shards merged equal one run, resume equals an
//! uninterrupted run, merges refuse other scenes and shared photons, damaged states get
//! specific errors and leave the context as it was.
#![allow(clippy::single_range_in_vec_init)]

mod common;
use common::*;
use imap::FLAG_NO_MAP;
use imap::{Bands, Config, Context, ImapStatus, Layer, LayerRequest, RunParams, Selection};

/// The mixed room (dispersion, a spot, a point light and an emitting panel) with light
/// group layers, a direct layer and region tallies on the walls: every kind of state. At
/// 16 bands the map keeps grey sums (`scene::GreySpectra`), which states and the
/// accumulators' array fold into the band sums.
fn scene() -> (Context, Vec<u32>) {
    let (mut ctx, mut ids) = mixed_room(Config {
        bands: Bands::spectral(16, 400.0, 700.0).unwrap(),
        seed: 7,
        threads: 2,
        ..Config::default()
    });
    // A sensor: exact per-photon region tallies.
    let g = grid(4, -1.5, 1.5, -1.5, 1.5, 1.0);
    let mut d = g.desc(0);
    d.sensor = true;
    ids.push(ctx.add_mesh(&d).unwrap());
    ctx.set_layers(LayerRequest {
        groups: true,
        direct: true,
    })
    .unwrap();
    ctx.set_light_group(1, 2).unwrap();
    (ctx, ids)
}

fn run(ctx: &mut Context, photons: u64, selection: Selection) -> imap::Report {
    ctx.run(&mut RunParams {
        photons,
        selection,
        progress_interval_s: 0.05,
        ..Default::default()
    })
    .expect("run")
}

/// Everything a user reads: every layer's irradiance and error, the region statistics
/// and the energy balance.
fn everything(ctx: &Context, ids: &[u32]) -> Vec<f64> {
    let mut all = whole_map(ctx, ids);
    let (groups, direct) = ctx.layers();
    for &m in ids {
        let n = ctx.vertex_count(m).unwrap();
        let mut e = vec![0.0; n];
        let layers = (0..groups)
            .map(Layer::Group)
            .chain(direct.then_some(Layer::Direct));
        for layer in layers {
            ctx.irradiance_layer(m, 0, 0, layer, &mut e).unwrap();
            all.extend(&e);
            ctx.rel_error_layer(m, 0, layer, &mut e).unwrap();
            all.extend(&e);
        }
    }
    let r = ctx.region_stats(*ids.last().unwrap(), 0, None).unwrap();
    assert!(r.exact_errors);
    all.extend([
        r.flux_lm.value,
        r.flux_lm.sigma,
        r.average.value,
        r.average.sigma,
    ]);
    let rep = ctx.report();
    all.extend([
        rep.emitted_w,
        rep.absorbed_w,
        rep.escaped_w,
        rep.photons as f64,
    ]);
    for b in &rep.band_w {
        all.extend(b);
    }
    all
}

fn reference(n: u64) -> Vec<f64> {
    let (mut ctx, ids) = scene();
    run(&mut ctx, n, Selection::ALL);
    everything(&ctx, &ids)
}

#[test]
fn three_ranges_merged_equal_one_run() {
    let n = photons(60_000);
    let want = reference(n);
    let cuts = [0, n / 5, n / 2, n];
    let mut states = Vec::new();
    for w in cuts.windows(2) {
        let (mut ctx, _) = scene();
        let r = run(&mut ctx, 0, Selection::range(w[0], w[1]));
        assert_eq!(r.photons, w[1] - w[0]);
        states.push(ctx.state_bytes(0, b"range").unwrap());
    }
    let (mut ctx, ids) = scene();
    for s in &states {
        assert_eq!(ctx.merge_state(s).unwrap(), b"range");
    }
    assert_eq!(ctx.traced().ranges(), &[0..n]);
    assert_maps_agree(&everything(&ctx, &ids), &want, "3 ranges merged");
    // The merged history ends with the combined error, which is the one run's.
    let (mut one, _) = scene();
    let r = run(&mut one, n, Selection::ALL);
    let merged = ctx.history().last().unwrap().rel_error;
    assert!(
        (merged - r.rel_error).abs() <= 1e-12 * r.rel_error,
        "{merged} vs {}",
        r.rel_error
    );
}

#[test]
fn shards_stopped_anywhere_merge_into_one_run_of_their_photons() {
    let n = photons(40_000);
    let want = reference(n);
    let mut states = Vec::new();
    for k in 0..3 {
        let (mut ctx, _) = scene();
        let sel = Selection {
            end: n,
            shards: 3,
            shard: k,
            block: 1024,
            ..Selection::ALL
        };
        // Each shard in two runs of different lengths, the second to its end.
        run(&mut ctx, 1000 + 777 * k, sel);
        run(&mut ctx, 0, sel);
        states.push(ctx.state_bytes(0, &[]).unwrap());
    }
    let (mut ctx, ids) = scene();
    // Any order.
    for s in states.iter().rev() {
        ctx.merge_state(s).unwrap();
    }
    assert_eq!(ctx.traced().ranges(), &[0..n]);
    assert_maps_agree(&everything(&ctx, &ids), &want, "3 shards merged");
    // The same shard again would count its photons twice: refused, nothing changed.
    let e = ctx.merge_state(&states[1]).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrStateOverlap, "{e}");
    assert!(e.message.contains("twice"), "{e}");
    assert_maps_agree(&everything(&ctx, &ids), &want, "after a refused merge");
}

#[test]
fn resumed_runs_equal_an_uninterrupted_run() {
    let n = photons(40_000);
    let want = reference(n);
    let dir = tempdir("resume");
    let path = dir.join("state.imap");
    {
        let (mut ctx, _) = scene();
        run(&mut ctx, n / 3, Selection::ALL);
        ctx.save_state(&path, b"meta").unwrap();
    }
    let (mut ctx, ids) = scene();
    assert_eq!(ctx.load_state_file(&path).unwrap(), b"meta");
    assert_eq!(ctx.report().photons, n / 3);
    let before = ctx.history().to_vec();
    run(&mut ctx, n - n / 3, Selection::ALL);
    assert_maps_agree(&everything(&ctx, &ids), &want, "resumed");
    // The history goes on from the saved one.
    assert_eq!(&ctx.history()[..before.len()], &before[..]);
    assert!(ctx.history().last().unwrap().elapsed_s > before.last().unwrap().elapsed_s);
    // No temporary file is left beside it.
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["state.imap"]);
}

#[test]
fn an_mpi_style_reduction_equals_one_run() {
    // Rank r runs shard r; the maps are summed element by element (as MPI_Reduce does)
    // and rank 0 merges the other's state written without its map.
    let n = photons(30_000);
    let want = reference(n);
    let (mut r0, ids) = scene();
    let (mut r1, _) = scene();
    // Blocks of 1024 photons: both ranks trace some (the default blocks of 65 536 would
    // leave every photon to rank 0).
    let shard = |shard| Selection {
        end: n,
        shards: 2,
        shard,
        block: 1024,
        ..Selection::ALL
    };
    let (a, b) = (run(&mut r0, 0, shard(0)), run(&mut r1, 0, shard(1)));
    assert!(a.photons > 0 && b.photons > 0 && a.photons + b.photons == n);
    let ledger = r1.state_bytes(FLAG_NO_MAP, &[]).unwrap();
    let full = r1.state_bytes(0, &[]).unwrap();
    assert!(
        ledger.len() * 10 < full.len(),
        "{} vs {}",
        ledger.len(),
        full.len()
    );
    // Both arrays: the photons' and (light sampling, the default) the direct records.
    let theirs = r1.map_accumulators().unwrap().to_vec();
    for (a, b) in r0.map_accumulators().unwrap().iter_mut().zip(&theirs) {
        *a += b;
    }
    let theirs = r1.direct_accumulators().unwrap().to_vec();
    assert!(!theirs.is_empty());
    for (a, b) in r0.direct_accumulators().unwrap().iter_mut().zip(&theirs) {
        *a += b;
    }
    r0.merge_state(&ledger).unwrap();
    assert_maps_agree(&everything(&r0, &ids), &want, "reduced");
    // A ledger cannot be loaded as a whole state.
    let (mut c, _) = scene();
    let e = c.load_state(&ledger).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrInvalidArgument, "{e}");
}

#[test]
fn merges_refuse_other_scenes_and_settings() {
    let (mut a, _) = scene();
    run(&mut a, 2000, Selection::ALL);
    let s = a.state_bytes(0, &[]).unwrap();
    // Another seed: the settings differ.
    let (mut b, _) = mixed_room(Config {
        bands: Bands::spectral(16, 400.0, 700.0).unwrap(),
        seed: 8,
        ..Config::default()
    });
    b.set_layers(LayerRequest {
        groups: true,
        direct: true,
    })
    .unwrap();
    b.set_light_group(1, 2).unwrap();
    let e = b.merge_state(&s).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrStateMismatch, "{e}");
    assert!(
        e.message.contains("settings") && !e.message.contains("lights"),
        "{e}"
    );
    // A light of other power.
    let (mut c, _) = scene();
    c.add_point_light([0.0, 0.0, 1.0], &[1.0]).unwrap();
    let e = c.merge_state(&s).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrStateMismatch, "{e}");
    assert!(
        e.message.contains("lights") && !e.message.contains("geometry"),
        "{e}"
    );
    // A moved vertex.
    let (mut d, _) = scene();
    let g = grid(1, 0.0, 0.1, 0.0, 0.1, 1.0);
    d.add_mesh(&g.desc(0)).unwrap();
    let e = d.load_state(&s).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrStateMismatch, "{e}");
    assert!(e.message.contains("geometry"), "{e}");
    assert_eq!(d.report().photons, 0);
}

#[test]
fn damaged_states_get_specific_errors_and_change_nothing() {
    let (mut a, ids) = scene();
    run(&mut a, 3000, Selection::ALL);
    let good = a.state_bytes(0, b"x").unwrap();
    let (mut ctx, _) = scene();
    run(&mut ctx, 1000, Selection::range(10_000, 11_000));
    let before = everything(&ctx, &ids);
    let check = |ctx: &mut Context, bytes: &[u8], status: ImapStatus, words: &str| {
        for load in [true, false] {
            let e = if load {
                ctx.load_state(bytes).unwrap_err()
            } else {
                ctx.merge_state(bytes).unwrap_err()
            };
            assert_eq!(e.status, status, "{e}");
            assert!(e.message.contains(words), "{words}: {e}");
            assert_eq!(everything(ctx, &ids), before, "changed by a refused state");
        }
    };
    // Truncated anywhere: in the header, the tallies, the map, the checksum.
    for cut in [3, 20, 200, good.len() / 2, good.len() - 1] {
        let words = if cut < 8 {
            "not a libimap state"
        } else {
            "truncated"
        };
        check(
            &mut ctx,
            &good[..cut],
            ImapStatus::ImapErrStateCorrupt,
            words,
        );
    }
    // One bit flipped anywhere after the magic: the checksum or the length catches it.
    for at in [17, 100, good.len() / 2, good.len() - 20, good.len() - 3] {
        let mut bad = good.clone();
        bad[at] ^= 0x10;
        check(&mut ctx, &bad, ImapStatus::ImapErrStateCorrupt, "state is");
    }
    let mut bad = good.clone();
    bad[0] = b'J';
    check(
        &mut ctx,
        &bad,
        ImapStatus::ImapErrStateCorrupt,
        "not a libimap state",
    );
    let mut bad = good.clone();
    bad[8] = 9; // a future format version
    check(&mut ctx, &bad, ImapStatus::ImapErrUnsupported, "version 9");
    let mut long = good.clone();
    long.push(0);
    check(&mut ctx, &long, ImapStatus::ImapErrStateCorrupt, "trailing");
    // Files: a missing one names its path; saving into a missing folder fails cleanly.
    let e = ctx
        .merge_state_file(std::path::Path::new("/nonexistent/s.imap"))
        .unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrIo, "{e}");
    assert!(e.message.contains("/nonexistent/s.imap"), "{e}");
    let e = ctx
        .save_state(std::path::Path::new("/nonexistent/dir/s.imap"), &[])
        .unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrIo, "{e}");
    // And the good one still loads.
    ctx.load_state(&good).unwrap();
    assert_eq!(ctx.report().photons, 3000);
}

#[test]
fn saving_over_a_good_state_is_atomic() {
    let dir = tempdir("atomic");
    let path = dir.join("s.imap");
    let (mut ctx, _) = scene();
    run(&mut ctx, 1000, Selection::ALL);
    ctx.save_state(&path, &[]).unwrap();
    let first = std::fs::read(&path).unwrap();
    // A writer killed mid-way leaves only its temporary file; the state is the old one.
    std::fs::write(
        dir.join(format!("s.imap.tmp-{}", dead_pid())),
        &first[..first.len() / 2],
    )
    .unwrap();
    let (mut c, _) = scene();
    c.load_state_file(&path).unwrap();
    assert_eq!(c.report().photons, 1000);
    run(&mut ctx, 1000, Selection::ALL);
    ctx.save_state(&path, &[]).unwrap();
    let (mut c, _) = scene();
    c.load_state_file(&path).unwrap();
    assert_eq!(c.report().photons, 2000);
    // The dead writer's temporary file is gone with the next save.
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["s.imap"]);
}

/// A fresh folder under the target directory.
fn tempdir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("imap-state-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The id of a process that has ended.
fn dead_pid() -> u32 {
    let mut c = std::process::Command::new("true").spawn().unwrap();
    let pid = c.id();
    c.wait().unwrap();
    pid
}

/// The scene of `tests/data/state_v1_*.bin` (written by libimap 0.2.3 before the state
/// format kept media's tallies, commit 09dbe57): a grey floor under a spot light, with or
/// without a box of absorbing glass between them.
pub fn v1_scene(medium: bool) -> imap::Context {
    use imap::{IorModel, MaterialDesc, MeshDesc};
    let mut ctx = context(Config {
        seed: 3,
        threads: 1,
        ..Default::default()
    });
    let grey = lambert(&mut ctx, 0.5);
    let floor = [
        -1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0,
    ];
    ctx.add_mesh(&MeshDesc::new(&floor, &[0, 1, 2, 0, 2, 3], grey))
        .unwrap();
    if medium {
        let glass = ctx
            .add_material(&MaterialDesc {
                ior: Some(IorModel::Constant(1.5)),
                absorption_per_m: vec![3.0],
                ..Default::default()
            })
            .unwrap();
        let (lo, hi) = ([-0.5, -0.5, 0.2], [0.5, 0.5, 0.4]);
        let mut p = Vec::new();
        for k in 0..8 {
            p.extend([
                if k & 1 == 0 { lo[0] } else { hi[0] },
                if k & 2 == 0 { lo[1] } else { hi[1] },
                if k & 4 == 0 { lo[2] } else { hi[2] },
            ]);
        }
        // Outward faces of the box (corner k has bit 0 for x, 1 for y, 2 for z).
        let faces = [
            0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4, 2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6,
            2, 1, 3, 7, 1, 7, 5,
        ];
        let mut d = MeshDesc::new(&p, &faces, glass);
        d.record = false;
        ctx.add_mesh(&d).unwrap();
    }
    ctx.add_spot_light([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], 0.5, &[1.0])
        .unwrap();
    ctx
}

#[test]
fn a_state_of_the_format_before_media_tallies_resumes_a_scene_without_media() {
    // States written in format 1 (before the media's tallies) by the library of commit
    // 09dbe57: the scene without media resumes from one and goes on; the scene with a
    // box of absorbing glass refuses its own, saying why, and stays usable.
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let floor = std::fs::read(data.join("state_v1_floor.bin")).unwrap();
    assert_eq!(u32::from_le_bytes(floor[8..12].try_into().unwrap()), 1);
    let mut ctx = v1_scene(false);
    assert_eq!(ctx.load_state(&floor).unwrap(), b"v1");
    assert_eq!(ctx.report().photons, 2000);
    let before = ctx.report().absorbed_w;
    assert!(before > 0.0);
    run(&mut ctx, 2000, Selection::ALL);
    assert_eq!(ctx.report().photons, 4000);
    // The same 4000 photons in one run of this library: the same energy balance.
    let mut one = v1_scene(false);
    one.run(&mut RunParams {
        photons: 4000,
        estimator: Some(imap::Estimator::Photons),
        ..Default::default()
    })
    .unwrap();
    let (a, b) = (ctx.report().absorbed_w, one.report().absorbed_w);
    assert!((a - b).abs() <= 1e-12 * b, "{a} against {b}");
    // And it writes format 2.
    let again = ctx.state_bytes(0, &[]).unwrap();
    assert_eq!(u32::from_le_bytes(again[8..12].try_into().unwrap()), 2);

    let glass = std::fs::read(data.join("state_v1_glass.bin")).unwrap();
    let mut ctx = v1_scene(true);
    let e = ctx.load_state(&glass).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrUnsupported, "{e}");
    assert!(
        e.message.contains("state format 1") && e.message.contains("media (mesh 1)"),
        "{e}"
    );
    run(&mut ctx, 1000, Selection::ALL);
    assert!(ctx.medium_absorbed(1).unwrap().lm.value > 0.0);
}

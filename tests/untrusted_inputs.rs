//! Inputs a host cannot vouch for, through the Rust API: scenes of thousands of meshes,
//! wavelength ranges, luminaire files and environment images too large for the memory
//! budget, state files with impossible numbers or that are no files at all, and renders
//! with budgets shorter than their first step. Each must cost what its size says and no
//! more, and be refused by name before memory is spent on it.

mod common;

use common::*;
use imap::photometry::Spectrum;
use imap::Placement;
use imap::{
    Bands, CameraDesc, Config, Context, ImapStatus, MeshDesc, RenderMethod, RenderParams,
    StopReason,
};
use imap::{SkyAmount, SkyDesc};
use std::sync::mpsc;
use std::time::Duration;

/// Runs `f` on a thread; fails when it does not finish within `secs` (a hang, or work
/// that grows faster than its input).
fn within<T: Send + 'static>(secs: f64, what: &str, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    match rx.recv_timeout(Duration::from_secs_f64(secs)) {
        Ok(v) => v,
        Err(_) => panic!("{what}: did not return within {secs} s"),
    }
}

fn budget(bytes: u64) -> Config {
    Config {
        memory_budget: bytes,
        threads: 2,
        ..Default::default()
    }
}

/// Adding meshes costs the same for the last as for the first, and so does reading their
/// maps: 20 000 one-triangle recording meshes load, run and read back in seconds (the
/// memory model once summed over every mesh for every mesh added, per recording mesh, and
/// each read summed over every mesh again: 5 000 meshes took 34 s to load).
#[test]
fn thousands_of_meshes_load_and_read_in_linear_time() {
    within(60.0, "20 000 meshes", || {
        let mut ctx = context(budget(0));
        let grey = lambert(&mut ctx, 0.5);
        let n = 20_000usize;
        for i in 0..n {
            let (x, y) = ((i % 200) as f64, (i / 200) as f64);
            let p = [x, y, 0.0, x + 0.9, y, 0.0, x, y + 0.9, 0.0];
            ctx.add_mesh(&MeshDesc::new(&p, &[0, 1, 2], grey)).unwrap();
        }
        let held = ctx.memory_estimate();
        ctx.add_point_light([100.0, 50.0, 20.0], &[1000.0]).unwrap();
        run_photons(&mut ctx, 20_000);
        let mut e = [0.0; 3];
        for id in 0..n as u32 {
            ctx.illuminance(id, 0, &mut e).unwrap();
            ctx.rel_error(id, 0, &mut e).unwrap();
        }
        // The running figures are the model's: a mesh of 3 vertices and 1 triangle holds
        // its copy, prepared form, BVH share and map cells (checked in tests/memory.rs).
        assert!(held > 0);
    });
}

/// A wavelength range beyond what spectral contexts cover is refused at once with
/// IMAP_ERR_BAD_BANDS naming the bound (integrating a light's spectrum over [1, 1e308] nm
/// on a 0.25 nm grid never returned).
#[test]
fn wavelength_ranges_beyond_the_tables_are_refused_by_name() {
    within(10.0, "huge wavelength ranges", || {
        for (lo, hi, bound) in [
            (380.0, 1e9, "wavelength_max_nm"),
            (1.0, 1e308, "wavelength_min_nm"),
            (50.0, 780.0, "wavelength_min_nm"),
        ] {
            let e = Bands::spectral(41, lo, hi).unwrap_err();
            assert_eq!(e.status, ImapStatus::ImapErrBadBands, "{}", e.message);
            assert!(e.message.contains(bound), "{}", e.message);
        }
        // The widest range allowed still makes a context, with lights, at once.
        let mut ctx = context(Config {
            bands: Bands::spectral(81, 100.0, 100_000.0).unwrap(),
            ..Default::default()
        });
        let light = imap::LightDesc {
            kind: imap::LightKind::Point,
            position: [0.0, 0.0, 1.0],
            amount: imap::Amount::Watts(10.0),
            spectrum: imap::photometry::Spectrum::Blackbody(3000.0),
        };
        ctx.add_light_desc(&light).unwrap();
    });
}

/// An IES file whose counts promise more values than the budget holds: refused from its
/// counts (IMAP_ERR_MEMORY_BUDGET), before its values are read. The file here has its
/// angles but no candela at all: a parser that read first would report the missing values
/// (IMAP_ERR_PARSE) instead.
#[test]
fn luminaire_tables_are_refused_from_their_counts() {
    let mut ctx = context(budget(50 << 20));
    let (nv, nh) = (4000usize, 2000usize);
    let v: Vec<f64> = (0..nv)
        .map(|i| i as f64 * 180.0 / (nv - 1) as f64)
        .collect();
    let h: Vec<f64> = (0..nh)
        .map(|i| i as f64 * 360.0 / (nh - 1) as f64)
        .collect();
    let text = format!(
        "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 {nv} {nh} 1 2 0 0 0\n1 1 100\n{}{}",
        join(&v),
        join(&h)
    );
    let e = ctx
        .add_luminaire_ies(&text, None, &Placement::default(), &Spectrum::Equal)
        .unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrMemoryBudget, "{}", e.message);
    // EULUMDAT likewise: 3600 × 3600 intensities announced, none given.
    let c: Vec<f64> = (0..3600).map(|i| i as f64 * 0.1).collect();
    let g: Vec<f64> = (0..3600).map(|i| i as f64 * 0.05).collect();
    let mut ldt =
        String::from("maker\n1\n0\n3600\n0.1\n3600\n0.05\nreport\nluminaire\n1\nf.ldt\n2026\n");
    ldt += "100\n100\n50\n0\n0\n0\n0\n0\n0\n100\n100\n1\n0\n1\n1\nLED\n1000\n3000K\n1A\n10\n";
    ldt += &"0\n".repeat(10);
    ldt += &join(&c);
    ldt += &join(&g);
    let e = ctx
        .add_luminaire_ldt(&ldt, &Placement::default(), &Spectrum::Equal)
        .unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrMemoryBudget, "{}", e.message);
    // The context is usable and still empty of lights.
    assert_eq!(ctx.light_count(), 0);
}

/// A luminaire's table counts in the memory the context holds, once however often it is
/// placed.
#[test]
fn luminaire_tables_count_once_in_the_memory_held() {
    let mut ctx = context(budget(0));
    let v = steps(0.0, 180.0, 0.5);
    let h = steps(0.0, 360.0, 1.0);
    let text = ies_text(
        1,
        &v,
        &h,
        |_, g| 100.0 * (1.0 + g.to_radians().cos()),
        1.0,
        1.0,
        None,
    );
    let before = ctx.memory_estimate();
    let d = ctx.distribution_ies(&text, None).unwrap();
    ctx.add_distribution(&d, &Placement::default(), &Spectrum::Equal)
        .unwrap();
    let one = ctx.memory_estimate();
    let values = (v.len() * h.len()) as u64;
    assert!(
        one - before >= 24 * values,
        "{} bytes for {values} values",
        one - before
    );
    let place = Placement {
        position: [1.0, 0.0, 0.0],
        ..Default::default()
    };
    ctx.add_distribution(&d, &place, &Spectrum::Equal).unwrap();
    assert_eq!(
        ctx.memory_estimate(),
        one,
        "a second placement shares the table"
    );
}

/// An environment image is judged by its header: a 6000 × 6000 HDR that is a few bytes
/// on disk is refused under a 100 MB budget before a pixel is decoded (the file here has
/// a header and no pixels: decoding first would report the missing pixels instead), and a
/// path to a device is no image at all.
#[test]
fn environment_images_are_refused_from_their_headers() {
    let dir = std::env::temp_dir().join(format!("imap-env-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let hdr = dir.join("big.hdr");
    std::fs::write(
        &hdr,
        b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 6000 +X 6000\n\x02\x02\x17\x70",
    )
    .unwrap();
    let mut ctx = context(budget(100 << 20));
    let desc = SkyDesc {
        amount: SkyAmount::Scale(1.0),
        ..SkyDesc::default()
    };
    let e = ctx.add_sky_file(&hdr, &desc).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrMemoryBudget, "{}", e.message);
    assert!(e.message.contains("6000 × 6000"), "{}", e.message);
    let e = within(10.0, "/dev/zero as an image", move || {
        let mut ctx = context(budget(100 << 20));
        ctx.add_sky_file(std::path::Path::new("/dev/zero"), &desc)
            .unwrap_err()
    });
    assert_eq!(e.status, ImapStatus::ImapErrIo, "{}", e.message);
    assert!(e.message.contains("not a regular file"), "{}", e.message);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A floor under a point light, run a little: a state to tamper with.
fn lit_floor() -> Context {
    let mut ctx = context(seeded(3));
    let grey = lambert(&mut ctx, 0.5);
    let g = grid(6, 0.0, 1.0, 0.0, 1.0, 0.0);
    ctx.add_mesh(&g.desc(grey)).unwrap();
    ctx.add_point_light([0.5, 0.5, 1.0], &[10.0]).unwrap();
    ctx.run(&mut imap::RunParams {
        photons: 20_000,
        progress_interval_s: 0.001,
        ..Default::default()
    })
    .unwrap();
    ctx
}

/// Writes `x` at byte `at` of a state and makes its checksum match again (what a faulty
/// or hostile writer produces: the frame is sound, the numbers are not).
fn tamper(state: &[u8], at: usize, x: &[u8]) -> Vec<u8> {
    let mut s = state.to_vec();
    s[at..at + x.len()].copy_from_slice(x);
    let body = s.len() - 16;
    let sum = xxhash_rust::xxh3::xxh3_128(&s[..body]);
    s[body..].copy_from_slice(&sum.to_le_bytes());
    s
}

/// Byte offsets in a state (the layout in `context::state`): the run time, the first
/// history point, and the estimator's samples field.
fn offsets(state: &[u8]) -> (usize, usize, usize) {
    let u32_at = |i: usize| u32::from_le_bytes(state[i..i + 4].try_into().unwrap()) as usize;
    let u64_at = |i: usize| u64::from_le_bytes(state[i..i + 8].try_into().unwrap()) as usize;
    let lib = 24 + 64;
    let dims = lib + 4 + u32_at(lib);
    let samples = dims + 4 + 4 + 8 + 4 + 8;
    let ranges = dims + 40;
    let elapsed = ranges + 8 + 16 * u64_at(ranges);
    (elapsed, elapsed + 16, samples)
}

/// Numbers no run can write are refused on load and merge, naming the field
/// (IMAP_ERR_STATE_CORRUPT), and the context keeps what it had: a NaN map made every
/// result NaN, a run time of −1e300 made a time limit never end, 2³¹ − 1 light samples per
/// vertex made the next run ignore its budget.
#[test]
fn states_with_impossible_numbers_are_refused_by_field() {
    let mut ctx = lit_floor();
    let good = ctx.state_bytes(0, b"").unwrap();
    let (elapsed, history, samples) = offsets(&good);
    assert_eq!(
        f64::from_le_bytes(good[elapsed..elapsed + 8].try_into().unwrap()),
        ctx.report().elapsed_s,
        "the layout this test reads"
    );
    let map_end = good.len() - 16;
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("run time", tamper(&good, elapsed, &f64::NAN.to_le_bytes())),
        (
            "run time",
            tamper(&good, elapsed, &(-1e300f64).to_le_bytes()),
        ),
        (
            "history point 0",
            tamper(&good, history, &f64::INFINITY.to_le_bytes()),
        ),
        (
            "map's accumulator",
            tamper(&good, map_end - 8, &f64::NAN.to_le_bytes()),
        ),
        (
            "map's accumulator",
            tamper(&good, map_end - 8, &f64::NEG_INFINITY.to_le_bytes()),
        ),
        (
            "light samples",
            tamper(&good, samples, &0x7fff_ffffu32.to_le_bytes()),
        ),
    ];
    let before = map_with_errors(&ctx, &[0]);
    for (field, bad) in &cases {
        let mut fresh = lit_floor();
        fresh.reset();
        for e in [
            fresh.load_state(bad).unwrap_err(),
            ctx.merge_state(bad).unwrap_err(),
        ] {
            assert_eq!(
                e.status,
                ImapStatus::ImapErrStateCorrupt,
                "{field}: {}",
                e.message
            );
            assert!(e.message.contains(field), "{field}: {}", e.message);
        }
        assert_eq!(fresh.report().photons, 0, "a refused load changes nothing");
    }
    assert_eq!(
        map_with_errors(&ctx, &[0]),
        before,
        "refused merges change nothing"
    );
    // The untampered state still loads.
    let mut fresh = lit_floor();
    fresh.load_state(&good).unwrap();
}

/// A state "file" that is a device is refused before a byte is read (IMAP_ERR_IO); one
/// larger than the budget leaves is refused by its size.
#[test]
fn state_files_must_be_regular_files_within_the_budget() {
    let e = within(10.0, "/dev/zero as a state", || {
        let mut ctx = lit_floor();
        ctx.load_state_file(std::path::Path::new("/dev/zero"))
            .unwrap_err()
    });
    assert_eq!(e.status, ImapStatus::ImapErrIo, "{}", e.message);
    assert!(e.message.contains("not a regular file"), "{}", e.message);
    // A file of 100 MB (sparse: nothing is written) under a budget of 64 MB.
    let dir = std::env::temp_dir().join(format!("imap-state-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("s.imap");
    std::fs::File::create(&path)
        .unwrap()
        .set_len(100 << 20)
        .unwrap();
    let mut small = context(Config {
        memory_budget: 64 << 20,
        ..seeded(3)
    });
    let grey = lambert(&mut small, 0.5);
    small
        .add_mesh(&grid(6, 0.0, 1.0, 0.0, 1.0, 0.0).desc(grey))
        .unwrap();
    small.add_point_light([0.5, 0.5, 1.0], &[10.0]).unwrap();
    let e = small.load_state_file(&path).unwrap_err();
    assert_eq!(e.status, ImapStatus::ImapErrMemoryBudget, "{}", e.message);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Final gathering on a fresh context with budgets of 0.2–10 ms: every call gives the same
/// status (a map's first photons are traced whatever the budget, so the render always has
/// a map to read), and a context is left as a run would leave it. It used to fail 1 call
/// in 20 with "run it first", after changing the run time and the history.
#[test]
fn final_gathering_with_tiny_budgets_always_succeeds() {
    let camera = CameraDesc {
        position: [0.5, 0.5, 2.0],
        direction: [0.0, 0.0, -1.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 40.0,
        width: 16,
        height: 16,
        projection: imap::Projection::Perspective,
    };
    for k in 0..60 {
        let mut ctx = context(seeded(k));
        let grey = lambert(&mut ctx, 0.5);
        ctx.add_mesh(&grid(6, 0.0, 1.0, 0.0, 1.0, 0.0).desc(grey))
            .unwrap();
        ctx.add_point_light([0.5, 0.5, 1.0], &[10.0]).unwrap();
        let budget = 0.0002 * 1.08f64.powi(k as i32);
        let mut p = RenderParams {
            method: RenderMethod::FinalGather,
            time_budget_s: budget,
            ..Default::default()
        };
        let r = ctx.render(&camera, &mut p);
        let (_, report) = r.unwrap_or_else(|e| panic!("budget {budget} s: {}", e.message));
        assert!(
            report.forward_photons >= 4096,
            "budget {budget} s: {report:?}"
        );
        assert_eq!(ctx.report().photons, report.forward_photons);
        assert!(ctx
            .history()
            .iter()
            .all(|p| p.photons > 0 || p.elapsed_s == 0.0));
        assert!(matches!(
            report.stop,
            Some(StopReason::TimeBudget | StopReason::PhotonCount)
        ));
    }
}

/// A harness over the numbers of a state: 2 000 states of the lit floor, each with one
/// field overwritten by a hostile value (NaN, infinities, huge, tiny, negative, all ones)
/// at a random byte of its body and its checksum made to match. Each is loaded into a
/// fresh context: refused with a status of its own, or taken, and then every value read
/// back is finite and a run with a time budget ends in time.
#[test]
fn states_with_any_field_doctored_are_refused_or_harmless() {
    let mut ctx = lit_floor();
    let good = ctx.state_bytes(0, b"meta").unwrap();
    let hostile: [[u8; 8]; 9] = [
        f64::NAN.to_le_bytes(),
        f64::INFINITY.to_le_bytes(),
        f64::NEG_INFINITY.to_le_bytes(),
        (-1e300f64).to_le_bytes(),
        1e300f64.to_le_bytes(),
        5e-324f64.to_le_bytes(),
        u64::MAX.to_le_bytes(),
        (0x7fff_ffffu64).to_le_bytes(),
        0u64.to_le_bytes(),
    ];
    let mut rng = 0x5eed_u64;
    let mut next = || {
        rng = rng
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        rng >> 33
    };
    let body = good.len() - 16;
    let mut fresh = lit_floor();
    fresh.reset();
    let (mut refused, mut taken) = (0, 0);
    for _ in 0..2000 {
        let at = 24 + (next() as usize) % (body - 24 - 8);
        let bad = tamper(&good, at, &hostile[next() as usize % hostile.len()]);
        match fresh.load_state(&bad) {
            Err(e) => {
                refused += 1;
                assert_ne!(e.status, ImapStatus::ImapErrInternal, "{}", e.message);
                assert!(!e.message.is_empty());
            }
            Ok(_) => {
                taken += 1;
                for (e, s) in map_with_errors(&fresh, &[0]) {
                    assert!(e.is_finite() && s.is_finite(), "byte {at}: {e} ± {s}");
                }
                let r = fresh.report();
                assert!(
                    r.elapsed_s.is_finite() && r.rel_error.is_finite(),
                    "byte {at}: {r:?}"
                );
                // A run with a time budget on top of it ends in time.
                let t = std::time::Instant::now();
                fresh
                    .run(&mut imap::RunParams {
                        photons: 500,
                        time_budget_s: 1.0,
                        progress_interval_s: 0.01,
                        ..Default::default()
                    })
                    .unwrap_or_else(|e| panic!("byte {at}: {}", e.message));
                assert!(t.elapsed() < Duration::from_secs(10), "byte {at}");
                fresh.reset();
            }
        }
    }
    eprintln!("2000 doctored states: {refused} refused, {taken} taken (harmless)");
    assert!(refused > 500, "{refused} refused");
}

#[test]
fn weather_files_with_any_byte_changed_are_read_or_refused_by_line() {
    // A small EPW and a .wea, each byte in turn replaced by characters a broken or hostile
    // file holds: every result is a weather or an IMAP_ERR_PARSE naming the file (and a
    // line, for the data); nothing panics, and what is read stays in range.
    let epw = "LOCATION,Town,ST,XYZ,TMY3,123456,47.50,8.25,1.0,410.0\n\
        DESIGN CONDITIONS,0\nTYPICAL/EXTREME PERIODS,0\nGROUND TEMPERATURES,0\n\
        HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0\nCOMMENTS 1,x\nCOMMENTS 2,y\n\
        DATA PERIODS,1,1,Data,Sunday, 1/ 1,12/31\n\
        1999,6,21,13,60,x,12.0,14.2,70,96000,0,0,300,700,612,148,0,0,0,0,180,3.0\n\
        1999,6,21,14,60,x,12.0,99.9,70,96000,0,0,300,700,9999,120,0,0,0,0,180,3.0\n";
    let wea = "place t\nlatitude 47.5\nlongitude -8.25\ntime_zone -15\nsite_elevation 410\n\
        weather_data_file_units 1\n6 21 12.5 612 148\n12 31 23.5 0 80\n";
    let mut read = 0;
    for (text, parse) in [
        (
            epw,
            imap::weather::parse_epw as fn(&str, &str) -> imap::Result<imap::weather::Weather>,
        ),
        (wea, imap::weather::parse_wea),
    ] {
        let bytes = text.as_bytes();
        for i in 0..bytes.len() {
            for x in [b'9', b'-', b',', b'\n', b'e', b' ', b'.'] {
                let mut b = bytes.to_vec();
                b[i] = x;
                let t = String::from_utf8_lossy(&b);
                match parse(&t, "w") {
                    Ok(w) => {
                        read += 1;
                        assert!(w.site.latitude_deg.abs() <= 90.0);
                        for h in &w.hours {
                            assert!((1..=12).contains(&h.month) && (0.0..=24.0).contains(&h.hour));
                            for v in [h.direct_normal_w, h.diffuse_horizontal_w]
                                .into_iter()
                                .flatten()
                            {
                                assert!((0.0..=2000.0).contains(&v), "{v}");
                            }
                            // Each hour's sun and sky are computed or refused, never a panic.
                            if let Ok((_, z)) = h.sun_position(&w.site) {
                                let _ = h.perez_sky(z);
                            }
                        }
                    }
                    Err(e) => {
                        assert_eq!(e.status, imap::ImapStatus::ImapErrParse, "{e}");
                        assert!(e.message.starts_with("w"), "{e}");
                    }
                }
            }
        }
    }
    assert!(read > 100, "{read}");
}

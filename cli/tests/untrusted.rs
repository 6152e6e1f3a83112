//! The `imap` command on inputs nobody vouches for: nonsense limits, malformed and
//! malicious glTF, paths to devices, models whose size is a trap (a million copies of one
//! triangle, 160 000 objects, an 8192² picture, a grid of 1e300 m), damaged or doctored
//! states, kills while the outputs are written, and closed pipes. Each must end as an
//! `imap: error:` naming what is wrong, or as a result, in bounded time and memory: never a
//! panic, an abort, a hang or a mix of two runs' files.

mod common;

use common::{imap, stderr, write};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// A grey floor and a lamp above it (OBJ and MTL in `dir`); returns the OBJ's path.
fn scene(dir: &Path) -> String {
    write(
        dir,
        "s.mtl",
        "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl lamp\nKe 20 20 20\n",
    );
    let obj = "mtllib s.mtl\no floor\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n\
               o lamp\nusemtl lamp\nv 0.4 0.4 1\nv 0.6 0.4 1\nv 0.6 0.6 1\nv 0.4 0.6 1\nf 5 7 6\nf 5 8 7\n";
    write(dir, "s.obj", obj)
}

/// `imap` with `args`, failing the test when it runs past `secs`.
fn imap_within(secs: f64, args: &[&str]) -> Output {
    imap_env_within(secs, args, &[])
}

fn imap_env_within(secs: f64, args: &[&str], env: &[(&str, &str)]) -> Output {
    use std::io::Read;
    let mut child = Command::new(env!("CARGO_BIN_EXE_imap"))
        .args(args)
        .envs(env.iter().copied())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Both pipes drained while the command runs (a full pipe would stall it).
    let drain = |mut r: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut b = Vec::new();
            let _ = r.read_to_end(&mut b);
            b
        })
    };
    let out = drain(Box::new(child.stdout.take().unwrap()));
    let err = drain(Box::new(child.stderr.take().unwrap()));
    let t = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t.elapsed().as_secs_f64() > secs {
            let _ = child.kill();
            let _ = child.wait();
            let e = String::from_utf8_lossy(&err.join().unwrap()).into_owned();
            panic!("imap {args:?} ran past {secs} s: {e}");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Output {
        status,
        stdout: out.join().unwrap(),
        stderr: err.join().unwrap(),
    }
}

/// Refused as an error of the command (exit 2, `imap: error:` naming `what`), not a panic.
fn refused(o: &Output, what: &str) {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("imap: error:"), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    assert!(e.contains(what), "expected '{what}' in: {e}");
}

/// Time limits that are no number of seconds are refused, not read as "no limit".
#[test]
fn nonsense_time_limits_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let obj = scene(d.path());
    for args in [
        vec!["run", &obj, "--time", "nan"],
        vec!["run", &obj, "--time=-1"],
        vec!["run", &obj, "--target-error=-0.5"],
    ] {
        let o = imap_within(20.0, &args);
        refused(&o, "must be a positive number");
    }
    let toml = write(d.path(), "t.toml", "[run]\ntime_s = -5\n");
    let o = imap_within(20.0, &["run", &obj, "--config", &toml]);
    refused(&o, "time");
}

/// A wavelength range past what libimap covers is refused at once (it used to hang the
/// command while a light's spectrum was integrated over it).
#[test]
fn huge_wavelength_ranges_are_refused_at_once() {
    let d = tempfile::tempdir().unwrap();
    let obj = scene(d.path());
    let toml = write(
        d.path(),
        "w.toml",
        "[spectral]\nbands = 41\nmin_nm = 1\nmax_nm = 1e308\n",
    );
    let o = imap_within(20.0, &["run", &obj, "--config", &toml, "--photons", "100"]);
    refused(&o, "wavelength_min_nm");
}

/// A glTF 2.0 triangle under a lamp: JSON with its buffer as a data URI. `tweak` edits
/// the JSON before it is written.
fn gltf(dir: &Path, name: &str, tweak: impl FnOnce(&mut serde_json::Value)) -> String {
    let pos: [f32; 18] = [
        0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0, // floor, facing +y
        0.3, 1.0, -0.3, 0.3, 1.0, -0.6, 0.6, 1.0, -0.3, // lamp, facing -y
    ];
    let bytes: Vec<u8> = pos.iter().flat_map(|x| x.to_le_bytes()).collect();
    let b64 = base64(&bytes);
    let mut v = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0, "name": "floor"}, {"mesh": 1, "name": "lamp"}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]},
            {"primitives": [{"attributes": {"POSITION": 1}, "material": 1}]}
        ],
        "materials": [
            {"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0}},
            {"emissiveFactor": [1.0, 1.0, 1.0]}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, -1], "max": [1, 0, 0]},
            {"bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0.3, 1, -0.6], "max": [0.6, 1, -0.3]}
        ],
        "bufferViews": [{"buffer": 0, "byteLength": 72}],
        "buffers": [{"byteLength": 72, "uri": format!("data:application/octet-stream;base64,{b64}")}]
    });
    tweak(&mut v);
    write(dir, name, serde_json::to_vec(&v).unwrap())
}

fn base64(b: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in b.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// Malformed glTF is an error naming the file, never a panic inside the `gltf` crate (a
/// byteStride below the element size, an attribute naming a missing accessor), an
/// allocation of what a header claims (a 50-byte GLB that says 4 GiB), an exponential walk
/// (nodes whose children are [n+1, n+1] over 64 levels), or a read of a device.
#[test]
fn malformed_gltf_is_an_error_not_a_panic() {
    let d = tempfile::tempdir().unwrap();
    let good = gltf(d.path(), "good.gltf", |_| {});
    let o = imap_within(60.0, &["info", &good]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cases: Vec<(String, &str)> = vec![
        (
            gltf(d.path(), "stride.gltf", |v| {
                v["bufferViews"][0]["byteStride"] = 4.into();
            }),
            "byteStride",
        ),
        (
            gltf(d.path(), "accessor.gltf", |v| {
                v["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = 7.into();
            }),
            "accessor",
        ),
        (
            gltf(d.path(), "range.gltf", |v| {
                v["accessors"][1]["count"] = 300.into();
            }),
            "buffer view",
        ),
        (
            gltf(d.path(), "zero.gltf", |v| {
                v["buffers"][0]["uri"] = "/dev/zero".into();
            }),
            "not a regular file",
        ),
        (
            gltf(d.path(), "image.gltf", |v| {
                v["images"] = serde_json::json!([{"uri": "/dev/zero"}]);
                v["textures"] = serde_json::json!([{"source": 0}]);
                v["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] =
                    serde_json::json!({"index": 0});
            }),
            "not a regular file",
        ),
    ];
    for (path, what) in &cases {
        let o = imap_within(30.0, &["info", path]);
        refused(&o, what);
    }
    // A binary container that claims 4 GiB in 50 bytes.
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend(u32::MAX.to_le_bytes());
    glb.extend(u32::MAX.to_le_bytes());
    glb.extend(b"JSON");
    glb.resize(50, b' ');
    let p = write(d.path(), "huge.glb", &glb);
    refused(&imap_within(30.0, &["info", &p]), "GLB header says");
    // 64 levels of nodes, each naming the next twice: 2^64 paths to the mesh.
    let deep = gltf(d.path(), "deep.gltf", |v| {
        let mut nodes: Vec<serde_json::Value> = (0..64)
            .map(|i| serde_json::json!({"children": [i + 1, i + 1]}))
            .collect();
        nodes.push(serde_json::json!({"mesh": 0, "name": "floor"}));
        nodes.push(serde_json::json!({"mesh": 1, "name": "lamp"}));
        v["nodes"] = nodes.into();
        v["scenes"] = serde_json::json!([{"nodes": [0, 65]}]);
    });
    let o = imap_within(30.0, &["info", &deep]);
    let e = stderr(&o);
    assert!(!e.contains("panicked"), "{e}");
    assert!(
        o.status.code() == Some(0) || o.status.code() == Some(2),
        "{e}"
    );
}

/// Inputs the model names that are devices (an MTL library, a luminaire file) are refused
/// before a byte is read.
#[test]
fn inputs_that_are_devices_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let obj = write(
        d.path(),
        "dev.obj",
        "mtllib /dev/zero\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    refused(&imap_within(30.0, &["info", &obj]), "not a regular file");
    let obj = scene(d.path());
    let toml = write(
        d.path(),
        "l.toml",
        "[[luminaire]]\nfile = \"/dev/zero\"\nposition = [0.5, 0.5, 2]\n",
    );
    let o = imap_within(30.0, &["run", &obj, "--config", &toml, "--photons", "100"]);
    refused(&o, "not a regular file");
}

/// A million copies of one triangle draw in seconds (each drawn once), and `imap info` on
/// 160 000 objects is linear (it looked each object up among all before it).
#[test]
fn models_built_to_be_slow_are_not() {
    let d = tempfile::tempdir().unwrap();
    write(
        d.path(),
        "m.mtl",
        "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl lamp\nKe 100 100 100\n",
    );
    let mut obj = String::from("mtllib m.mtl\no thing\nusemtl grey\nv 0 0 0\nv 1 0 0\nv 0 1 0\n");
    obj += &"f 1 2 3\n".repeat(1_200_000);
    obj += "o lamp\nusemtl lamp\nv 0 0 2\nv 0.2 0 2\nv 0 0.2 2\nf 4 6 5\n";
    let p = write(d.path(), "copies.obj", obj);
    let out = d.path().join("copies");
    let o = imap_within(
        60.0,
        &[
            "run",
            &p,
            "--photons",
            "2000",
            "--target-error",
            "0",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.join("view.png").exists());
    let mut obj = String::from("mtllib m.mtl\n");
    for i in 0..160_000 {
        let (x, y) = ((i % 400) as f64, (i / 400) as f64);
        obj += &format!(
            "o o{i}\nusemtl grey\nv {x} {y} 0\nv {} {y} 0\nv {x} {} 0\nf -3 -2 -1\n",
            x + 0.5,
            y + 0.5
        );
    }
    let p = write(d.path(), "objects.obj", obj);
    let t = Instant::now();
    let o = imap_within(60.0, &["info", &p]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(t.elapsed() < Duration::from_secs(20), "{:?}", t.elapsed());
}

/// The largest picture the settings allow (8192²) is drawn in strips: the run writes its
/// outputs in bounded memory (it asked for 8 GiB after the run and aborted).
#[test]
fn the_largest_view_draws_in_bounded_memory() {
    let d = tempfile::tempdir().unwrap();
    let obj = scene(d.path());
    let toml = write(
        d.path(),
        "c.toml",
        "[camera]\nposition = [0.5, 3, 0.5]\nlook_at = [0.5, 0, 0.5]\nup = [0, 0, 1]\nwidth = 8192\nheight = 8192\n",
    );
    let out = d.path().join("big");
    let o = imap_within(
        240.0,
        &[
            "run",
            &obj,
            "--config",
            &toml,
            "--photons",
            "2000",
            "--target-error",
            "0",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // SAFETY: getrusage fills the struct.
    let peak_kb = unsafe {
        let mut r = std::mem::zeroed::<libc::rusage>();
        libc::getrusage(libc::RUSAGE_CHILDREN, &mut r);
        r.ru_maxrss
    };
    eprintln!("largest child's peak: {} MB", peak_kb / 1024);
    assert!(peak_kb < 3 << 20, "{peak_kb} kB");
    let png = png::Decoder::new(std::fs::File::open(out.join("view.png")).unwrap());
    let r = png.read_info().unwrap();
    assert_eq!((r.info().width, r.info().height), (8192, 8192));
}

/// A grid whose point count overflows is refused by its count, before anything is made.
#[test]
fn grids_of_astronomical_size_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let obj = scene(d.path());
    let toml = write(
        d.path(),
        "g.toml",
        "[[grid]]\norigin = [0, 0, 0.1]\nu = [1, 0, 0]\nv = [0, 1, 0]\nsize = [1e300, 1e300]\nspacing = 1e-10\n",
    );
    let o = imap_within(30.0, &["run", &obj, "--config", &toml, "--photons", "100"]);
    refused(&o, "too many");
}

/// Runs the floor with a checkpoint; returns (checkpoint path, output folder).
fn checkpointed(d: &Path) -> (PathBuf, PathBuf) {
    let obj = scene(d);
    let ck = d.join("run.imap");
    let out = d.join("out");
    let o = imap(&[
        "run",
        &obj,
        "--photons",
        "20000",
        "--target-error",
        "0",
        "--quiet",
        "--checkpoint",
        ck.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    (ck, out)
}

/// A checkpoint with one flipped bit is named as damaged, not read for its metadata (a
/// flip in the model's path reported "…/v.obj: No such file").
#[test]
fn damaged_checkpoints_are_reported_as_damaged() {
    let d = tempfile::tempdir().unwrap();
    let (ck, _) = checkpointed(d.path());
    let bytes = std::fs::read(&ck).unwrap();
    let at = bytes
        .windows(5)
        .position(|w| w == b"s.obj")
        .expect("the model's path in the metadata");
    let mut bad = bytes.clone();
    bad[at] ^= 0x01;
    std::fs::write(&ck, &bad).unwrap();
    let o = imap_within(30.0, &["resume", ck.to_str().unwrap(), "--quiet"]);
    refused(&o, "checksum");
    assert!(!stderr(&o).contains("No such file"), "{}", stderr(&o));
}

/// A checksum-valid state whose history holds an impossible time: infinity is refused by
/// name; 5e-324 s (finite) is taken, and its plot is drawn at once.
#[test]
fn doctored_histories_are_refused_or_plotted_quickly() {
    let d = tempfile::tempdir().unwrap();
    let (ck, out) = checkpointed(d.path());
    let good = std::fs::read(&ck).unwrap();
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    // The first history point's time, as the state stores it.
    let t0 = r["history"][0]["elapsed_s"].as_f64().unwrap();
    let at = good
        .windows(8)
        .position(|w| w == t0.to_le_bytes())
        .expect("the history's first time in the state");
    for (x, ok) in [(f64::INFINITY, false), (5e-324, true)] {
        let mut s = good.clone();
        s[at..at + 8].copy_from_slice(&x.to_le_bytes());
        let body = s.len() - 16;
        let sum = xxhash_rust::xxh3::xxh3_128(&s[..body]);
        s[body..].copy_from_slice(&sum.to_le_bytes());
        let p = d.path().join(format!("doctored-{ok}.imap"));
        std::fs::write(&p, &s).unwrap();
        let merged = d.path().join(format!("merged-{ok}"));
        let o = imap_within(
            30.0,
            &[
                "merge",
                p.to_str().unwrap(),
                "--out",
                merged.to_str().unwrap(),
            ],
        );
        if ok {
            assert!(o.status.success(), "{}", stderr(&o));
            assert!(merged.join("convergence.png").exists());
        } else {
            refused(&o, "history point 0");
        }
    }
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A kill at any moment of writing the outputs never leaves one run's files beside
/// another's: the previous set goes (its report first) before the new one comes in (its
/// report last), and the next command finishes or clears what a killed one left. No
/// hidden temporary outlives its process.
#[test]
fn kills_while_writing_outputs_never_mix_two_runs() {
    let d = tempfile::tempdir().unwrap();
    let obj = scene(d.path());
    let out = d.path().join("out");
    let run = |photons: &str, fault: &str| {
        imap_env_within(
            60.0,
            &[
                "run",
                &obj,
                "--photons",
                photons,
                "--target-error",
                "0",
                "--quiet",
                "--out",
                out.to_str().unwrap(),
            ],
            &[("IMAP_TEST_FAULT", fault)],
        )
    };
    let all = [
        "convergence.png",
        "irradiance.csv",
        "irradiance.ply",
        "report.json",
        "view.png",
    ];
    assert!(run("10000", "").status.success());
    assert_eq!(names(&out), all);
    let modified = |n: &str| {
        std::fs::metadata(out.join(n))
            .and_then(|m| m.modified())
            .ok()
    };
    for k in 0..5 {
        let first = all.iter().filter_map(|n| modified(n)).max().unwrap();
        let o = run("20000", &format!("kill-after-renames={k}"));
        assert_eq!(o.status.code(), None, "killed by its signal");
        let left = names(&out);
        assert!(!left.contains(&"report.json".to_string()), "{left:?}");
        // Every output file there was written by the killed run (renames keep the time
        // a file was written): none of the first run's is left beside them.
        for n in all {
            if let Some(t) = modified(n) {
                assert!(
                    t > first,
                    "{n} of the earlier run beside the killed run's files"
                );
            }
        }
        // The next run finishes: a whole set, nothing hidden left.
        assert!(run("10000", "").status.success());
        assert_eq!(names(&out), all);
    }
    // Killed while writing its files: the staging folder is cleared by the next command.
    let o = run("20000", "kill-before-commit");
    assert_eq!(o.status.code(), None);
    assert!(names(&out).iter().any(|n| n.starts_with(".imap-out-")));
    assert!(run("10000", "").status.success());
    assert_eq!(names(&out), all);
}

/// Library errors about a mesh or a light name what the user wrote: the object and its
/// file, the settings file and line (they said "mesh 1", "settings:0").
#[test]
fn library_errors_name_objects_and_settings_lines() {
    let d = tempfile::tempdir().unwrap();
    write(
        d.path(),
        "s.mtl",
        "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl lamp\nKe 20 20 20\n",
    );
    // A speck far from a large floor: single precision cannot place its triangles.
    let obj = write(
        d.path(),
        "far.obj",
        "mtllib s.mtl\no floor\nusemtl grey\nv -1e6 -1e6 0\nv 1e6 -1e6 0\nv 1e6 1e6 0\nf 1 2 3\n\
         o speck\nusemtl grey\nv 9e5 9e5 1\nv 9e5 900000.001 1\nv 900000.001 9e5 1\nf 4 5 6\n\
         o lamp\nusemtl lamp\nv 0 0 10\nv 1 0 10\nv 0 1 10\nf 7 9 8\n",
    );
    let o = imap_within(60.0, &["run", &obj, "--photons", "100"]);
    refused(&o, "object 'speck'");
    let toml = write(d.path(), "r.toml", "unit_m = 1\n\nrecord = [\"nope\"]\n");
    let o = imap_within(60.0, &["run", &obj, "--config", &toml, "--photons", "100"]);
    refused(&o, "r.toml:3:");
}

/// `imap info MODEL | head` ends quietly when the reader goes away.
#[test]
fn closed_pipes_end_the_command_quietly() {
    let d = tempfile::tempdir().unwrap();
    // Enough objects that the listing outgrows a pipe's buffer.
    let mut obj = String::new();
    for i in 0..5000 {
        obj += &format!("o object{i}\nv {i} 0 0\nv {i} 1 0\nv {i} 0 1\nf -3 -2 -1\n");
    }
    let obj = write(d.path(), "many.obj", obj);
    let mut child = Command::new(env!("CARGO_BIN_EXE_imap"))
        .args(["info", &obj])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    let e = stderr(&o);
    assert!(!e.contains("panicked"), "{e}");
    assert!(e.is_empty(), "{e}");
}

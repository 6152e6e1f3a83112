//! The `imap` command on hostile input: malformed MTL colours,
//! signals during a run, mistakes that used to be found only after the run, huge
//! coordinates and raw control bytes.

mod common;

use common::{imap, stderr, write};

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A lit floor: a grey 4 × 4 floor and a lamp above it.
fn scene(dir: &Path, mtl: &str) -> String {
    write(dir, "s.mtl", mtl.as_bytes());
    let mut obj = String::from("mtllib s.mtl\no floor\nusemtl grey\n");
    for j in 0..=4 {
        for i in 0..=4 {
            obj += &format!("v {} {} 0\n", i as f64 * 0.25, j as f64 * 0.25);
        }
    }
    for j in 0..4 {
        for i in 0..4 {
            let a = j * 5 + i + 1;
            obj += &format!("f {} {} {}\nf {} {} {}\n", a, a + 1, a + 6, a, a + 6, a + 5);
        }
    }
    obj += "o lamp\nusemtl lamp\nv 0.4 0.4 1\nv 0.6 0.4 1\nv 0.6 0.6 1\nv 0.4 0.6 1\nf 26 28 27\nf 26 29 28\n";
    write(dir, "s.obj", obj.as_bytes())
}

const MTL: &str = "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl lamp\nKe 20 20 20\n";

/// Colour lines with fewer than three numbers do not panic: one number is grey,
/// none or two are errors naming the line, and every error of the file is reported at once.
#[test]
fn short_mtl_colours_are_read_or_named_not_panicked_on() {
    let d = tempfile::tempdir().unwrap();
    let obj = scene(d.path(), "newmtl grey\nKd 0.5\nnewmtl lamp\nKe 20\n");
    let out = d.path().join("o1");
    let o = imap(&[
        "run",
        &obj,
        "--photons",
        "2000",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let obj = scene(
        d.path(),
        "newmtl grey\nKd\nnewmtl lamp\nKe 10 2\nKs 0.1 x 0.1\n",
    );
    let o = imap(&["run", &obj, "--photons", "2000", "--quiet"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    let lines: Vec<&str> = e
        .lines()
        .filter(|l| l.starts_with("imap: error:"))
        .collect();
    assert_eq!(lines.len(), 3, "{e}");
    for (l, at) in lines.iter().zip(["s.mtl:2:", "s.mtl:4:", "s.mtl:5:"]) {
        assert!(l.contains(at), "{l}");
    }
}

/// Waits for a child up to `secs`, killing it on a timeout.
fn wait(child: &mut std::process::Child, secs: f64) -> Option<i32> {
    let t = Instant::now();
    loop {
        if let Some(s) = child.try_wait().unwrap() {
            return s.code();
        }
        if t.elapsed().as_secs_f64() > secs {
            let _ = child.kill();
            panic!("imap did not exit within {secs} s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|r| {
            r.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// SIGINT or SIGTERM stops the run cleanly: complete outputs of what was computed,
/// marked interrupted, replacing an older run's; no temporary or truncated file is left.
#[test]
fn signals_stop_the_run_and_leave_complete_outputs() {
    let d = tempfile::tempdir().unwrap();
    let obj = scene(d.path(), MTL);
    for (sig, code) in [("-INT", 130), ("-TERM", 143)] {
        let out: PathBuf = d.path().join(format!("out{sig}"));
        std::fs::create_dir_all(&out).unwrap();
        // An older run's outputs.
        std::fs::write(out.join("report.json"), "{\"photons\": 1}").unwrap();
        std::fs::write(out.join("irradiance.csv"), "old").unwrap();
        let mut child = Command::new(env!("CARGO_BIN_EXE_imap"))
            .args([
                "run",
                &obj,
                "--time",
                "60",
                "--target-error",
                "0",
                "--quiet",
                "--out",
            ])
            .arg(&out)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(1500));
        let t = Instant::now();
        let k = Command::new("kill")
            .args([sig, &child.id().to_string()])
            .status()
            .unwrap();
        assert!(k.success());
        let status = wait(&mut child, 30.0);
        eprintln!(
            "{sig}: exited {status:?} {:.2} s after the signal",
            t.elapsed().as_secs_f64()
        );
        assert_eq!(status, Some(code));
        assert_eq!(
            files(&out),
            [
                "convergence.png",
                "irradiance.csv",
                "irradiance.ply",
                "report.json",
                "view.png"
            ]
        );
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        assert_eq!(report["interrupted"], true);
        assert_eq!(report["stop"], "Interrupted");
        let photons = report["photons"].as_u64().unwrap();
        assert!(photons > 1000, "{photons}");
        let csv = std::fs::read_to_string(out.join("irradiance.csv")).unwrap();
        assert_eq!(csv.lines().count(), 26, "header and 25 floor vertices");
        // The PNGs decode to the end.
        for name in ["view.png", "convergence.png"] {
            let dec = png::Decoder::new(std::fs::File::open(out.join(name)).unwrap());
            let mut r = dec.read_info().unwrap();
            let mut buf = vec![0; r.output_buffer_size()];
            r.next_frame(&mut buf).unwrap();
        }
    }
}

/// Camera mistakes are found before tracing (no outputs, fast), and runs with no
/// error history (nothing recorded got light, one photon) succeed.
#[test]
fn mistakes_are_found_before_tracing_and_empty_histories_are_fine() {
    let d = tempfile::tempdir().unwrap();
    let obj = scene(d.path(), MTL);
    for (camera, what) in [
        (
            "position = [0, 0, 5]\nlook_at = [0, 0, 0]\nwidth = 0",
            "image size",
        ),
        ("position = [0, 0, 5]\nlook_at = [0, 0, 5]", "look_at"),
        (
            "position = [0, 0, 5]\nlook_at = [0, 0, 0]\nup = [0, 0, 1]",
            "parallel",
        ),
    ] {
        let toml = write(
            d.path(),
            "c.toml",
            format!("[camera]\n{camera}\n").as_bytes(),
        );
        let out = d.path().join("never");
        let t = Instant::now();
        let o = imap(&[
            "run",
            &obj,
            "--config",
            &toml,
            "--time",
            "60",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2));
        assert!(stderr(&o).contains(what), "{}", stderr(&o));
        assert!(
            t.elapsed() < Duration::from_secs(10),
            "not found before the run"
        );
        assert!(!out.exists(), "outputs were written");
    }
    // The floor's recorded side faces away from the lamp: nothing recorded gets light.
    let flipped = std::fs::read_to_string(&obj)
        .unwrap()
        .lines()
        .map(|l| match l.strip_prefix("f ") {
            Some(f) if !l.contains("26") => {
                let v: Vec<&str> = f.split(' ').collect();
                format!("f {} {} {}", v[0], v[2], v[1])
            }
            _ => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n");
    let away = write(d.path(), "away.obj", flipped.as_bytes());
    for (scene, photons) in [(&away, "5000"), (&obj, "1")] {
        let out = d.path().join(format!("ok-{photons}"));
        let o = imap(&[
            "run",
            scene,
            "--photons",
            photons,
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(out.join("convergence.png").exists());
    }
}

/// Coordinates beyond what libimap traces are named with file and line when the
/// file is read; control bytes from an input never reach the terminal.
#[test]
fn huge_coordinates_and_control_bytes() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "s.mtl", MTL.as_bytes());
    let obj = write(
        d.path(),
        "big.obj",
        b"mtllib s.mtl\nv 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    let o = imap(&["run", &obj, "--photons", "10"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("big.obj:3"), "{}", stderr(&o));
    let obj = write(
        d.path(),
        "esc.obj",
        b"mtllib s.mtl\nv 0 0 0\nv 1 \x1b]0;pwned\x07 0\nv 0 1 0\nusemtl \x1b[2Jmat\nf 1 2 3\n",
    );
    let o = imap(&["run", &obj, "--photons", "10"]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.contains("esc.obj:3"), "{e}");
    assert!(
        !e.bytes().any(|b| b == 0x1b || b == 0x07),
        "raw control bytes echoed: {e:?}"
    );
}

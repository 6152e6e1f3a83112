//! Checkpoints, resume after SIGKILL, shards and merges through the command: each gives
//! the map of one uninterrupted run of the same photons (1e-12).

mod common;
use common::*;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A closed grey room (inward walls, 8×8 cells each) with a lamp panel under the ceiling,
/// and settings with a point light and 5 spectral bands: many bounces, two kinds of light.
fn room(dir: &Path) -> (String, String) {
    write(
        dir,
        "room.mtl",
        "newmtl grey\nKd 0.7 0.6 0.5\nnewmtl lamp\nKd 0 0 0\nKe 20 20 20\n",
    );
    let mut obj = String::from("mtllib room.mtl\n");
    let n = 8;
    let mut base = 1;
    // Each wall: axis a fixed at value w, the normal pointing into the unit cube.
    for (a, w) in [(0, 0.0), (0, 1.0), (1, 0.0), (1, 1.0), (2, 0.0), (2, 1.0)] {
        obj += &format!("o wall{a}{w}\nusemtl grey\n");
        let (u, v) = ((a + 1) % 3, (a + 2) % 3);
        for j in 0..=n {
            for i in 0..=n {
                let mut p = [0.0; 3];
                p[a] = w;
                p[u] = i as f64 / n as f64;
                p[v] = j as f64 / n as f64;
                obj += &format!("v {} {} {}\n", p[0], p[1], p[2]);
            }
        }
        let inward = w == 0.0;
        for j in 0..n {
            for i in 0..n {
                let q = base + j * (n + 1) + i;
                let (b, c, d) = (q + 1, q + n + 2, q + n + 1);
                if inward {
                    obj += &format!("f {q} {b} {c}\nf {q} {c} {d}\n");
                } else {
                    obj += &format!("f {q} {c} {b}\nf {q} {d} {c}\n");
                }
            }
        }
        base += (n + 1) * (n + 1);
    }
    obj += "o lamp\nusemtl lamp\n";
    for p in [
        [0.4, 0.4, 0.95],
        [0.6, 0.4, 0.95],
        [0.6, 0.6, 0.95],
        [0.4, 0.6, 0.95],
    ] {
        obj += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    obj += &format!(
        "f {} {} {}\nf {} {} {}\n",
        base,
        base + 2,
        base + 1,
        base,
        base + 3,
        base + 2
    );
    let model = write(dir, "room.obj", obj);
    let toml = write(
        dir,
        "room.toml",
        "up_axis = \"z\"\n[spectral]\nbands = 5\n[run]\nseed = 3\n\
         [[light]]\nkind = \"point\"\nposition = [0.2, 0.7, 0.5]\npower = 3\n",
    );
    (model, toml)
}

/// The CSV's numbers, row by row.
fn csv(out: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(out.join("irradiance.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').skip(1).map(|x| x.parse().unwrap()).collect())
        .collect()
}

fn assert_same_map(a: &Path, b: &Path, what: &str) {
    let (x, y) = (csv(a), csv(b));
    assert_eq!(x.len(), y.len(), "{what}");
    let mut worst: f64 = 0.0;
    for (r, s) in x.iter().zip(&y) {
        for (p, q) in r.iter().zip(s) {
            let scale = p.abs().max(q.abs());
            if scale > 0.0 {
                worst = worst.max((p - q).abs() / scale);
            }
        }
    }
    eprintln!("{what}: largest relative difference {worst:.2e}");
    assert!(worst <= 1e-12, "{what}: {worst:e}");
    assert!(x.iter().any(|r| r[4] > 0.0), "{what}: empty map");
}

/// Starts `imap args`, waits until `ck` exists (and was rewritten once when it existed
/// already), lets it run `ms` more milliseconds and kills it with SIGKILL.
fn kill_after_a_checkpoint(args: &[&str], ck: &Path, ms: u64) {
    let before = std::fs::metadata(ck).and_then(|m| m.modified()).ok();
    let mut child = Command::new(env!("CARGO_BIN_EXE_imap"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while std::fs::metadata(ck).and_then(|m| m.modified()).ok() == before {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "no checkpoint written"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    std::thread::sleep(Duration::from_millis(ms));
    child.kill().unwrap(); // SIGKILL
    let status = child.wait().unwrap();
    assert!(
        !status.success(),
        "the run finished before it was killed: use more photons"
    );
}

fn ok(o: &std::process::Output) {
    assert!(o.status.success(), "{}", stderr(o));
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn sigkill_then_resume_equals_the_uninterrupted_run() {
    let d = tempfile::tempdir().unwrap();
    let (model, toml) = room(d.path());
    let photons = 3_000_000u64;
    let whole = d.path().join("whole");
    ok(&run_photons(&model, &toml, &whole, photons));

    let ck = d.path().join("ck.imap");
    let killed = d.path().join("killed");
    let mut run = run_args(&model, &toml, &killed, photons);
    run.extend(["--checkpoint", s(&ck), "--checkpoint-every", "0.05"].map(String::from));
    // Killed three times at no particular moment (perhaps while writing a checkpoint):
    // the run, then twice its resumption.
    kill_after_a_checkpoint(
        &run.iter().map(String::as_str).collect::<Vec<_>>(),
        &ck,
        130,
    );
    let resume = ["resume", s(&ck), "--quiet", "--out", s(&killed)];
    for delay in [70, 210] {
        kill_after_a_checkpoint(&resume, &ck, delay);
    }
    assert!(!killed.join("irradiance.csv").exists());
    // No temporary files are left but the last killed writer's.
    let litter = std::fs::read_dir(d.path())
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .contains(".tmp-")
        })
        .count();
    assert!(litter <= 1, "{litter} temporary files left");

    let resumed = d.path().join("resumed");
    let o = imap(&[
        "resume",
        s(&ck),
        "--out",
        s(&resumed),
        "--quiet",
        "--threads",
        "1",
    ]);
    ok(&o);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(resumed.join("report.json")).unwrap())
            .unwrap();
    assert_eq!(report["photons"], photons);
    assert_same_map(&whole, &resumed, "killed and resumed");
    // The checkpoint now holds the finished run: resuming again changes nothing.
    let again = d.path().join("again");
    ok(&imap(&["resume", s(&ck), "--out", s(&again), "--quiet"]));
    assert_same_map(&whole, &again, "resumed twice");
}

#[test]
fn shards_merged_equal_one_run_and_bad_states_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let (model, toml) = room(d.path());
    let photons = 200_000u64;
    let whole = d.path().join("whole");
    ok(&run_photons(&model, &toml, &whole, photons));
    let mut states = Vec::new();
    for k in 0..3 {
        let out = d.path().join(format!("shard{k}"));
        let o = imap_with(
            &run_args(&model, &toml, &out, photons),
            &["--shard", &format!("{k}/3")],
        );
        ok(&o);
        let st = out.join(format!("shard-{k}-of-3.imap"));
        assert!(st.exists(), "{}", String::from_utf8_lossy(&o.stdout));
        assert!(
            !out.join("irradiance.csv").exists(),
            "a shard writes its state only"
        );
        states.push(st);
    }
    let merged = d.path().join("merged");
    let mut args = vec!["merge"];
    args.extend(states.iter().map(|p| s(p)));
    args.extend(["--out", s(&merged)]);
    ok(&imap(&args));
    assert_same_map(&whole, &merged, "3 shards merged");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(merged.join("report.json")).unwrap())
            .unwrap();
    assert_eq!(report["photons"], photons);
    assert_eq!(report["stop"], "Merged");

    // The same shard twice: its photons would count twice.
    let e = stderr(&imap(&[
        "merge",
        s(&states[0]),
        s(&states[0]),
        "--out",
        s(&merged),
    ]));
    assert!(e.contains("twice"), "{e}");
    // A state of another scene: a shard of the model with another seed.
    let other = d.path().join("other");
    ok(&imap(&[
        "run",
        &model,
        "--config",
        &toml,
        "--photons",
        "1000",
        "--seed",
        "4",
        "--quiet",
        "--out",
        s(&other),
        "--shard",
        "0/3",
    ]));
    let e = stderr(&imap(&[
        "merge",
        s(&states[1]),
        s(&other.join("shard-0-of-3.imap")),
        "--out",
        s(&merged),
    ]));
    assert!(e.contains("settings") && e.contains("differ"), "{e}");
    // Truncated and corrupted files: one line naming the file and the problem, exit 2.
    let bytes = std::fs::read(&states[2]).unwrap();
    let cut = write(d.path(), "cut.imap", &bytes[..bytes.len() - 100]);
    let mut flipped = bytes.clone();
    flipped[bytes.len() / 2] ^= 1;
    let flip = write(d.path(), "flip.imap", &flipped);
    for (f, words) in [(&cut, "truncated"), (&flip, "checksum")] {
        let o = imap(&["merge", s(&states[0]), f, "--out", s(&merged)]);
        assert_eq!(o.status.code(), Some(2));
        let e = stderr(&o);
        assert!(e.contains(f.as_str()) && e.contains(words), "{e}");
        assert!(!e.contains("panicked"), "{e}");
        let o = imap(&["resume", f]);
        assert_eq!(o.status.code(), Some(2));
        assert!(stderr(&o).contains(words), "{}", stderr(&o));
    }
    // The merged outputs are still those of the good merge (outputs are all or nothing).
    assert_same_map(&whole, &merged, "after refused merges");
    // Bad --shard values.
    for bad in ["3/3", "1", "a/b", "0/0"] {
        let e = stderr(&imap(&["run", &model, "--photons", "10", "--shard", bad]));
        assert!(e.contains("--shard"), "{bad}: {e}");
    }
}

#[test]
fn time_limited_checkpointed_runs_stop_on_time_and_resume_to_more() {
    let d = tempfile::tempdir().unwrap();
    let (model, toml) = room(d.path());
    let ck = d.path().join("t.imap");
    let out = d.path().join("t");
    let o = imap(&[
        "run",
        &model,
        "--config",
        &toml,
        "--time",
        "0.6",
        "--target-error",
        "0",
        "--quiet",
        "--out",
        s(&out),
        "--checkpoint",
        s(&ck),
        "--checkpoint-every",
        "0.2",
    ]);
    ok(&o);
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(r["stop"], "TimeBudget");
    let run_s = r["run_s"].as_f64().unwrap();
    assert!((0.6..1.5).contains(&run_s), "{run_s}");
    // Several checkpoints were written: the history crosses them without a gap.
    let h = r["history"].as_array().unwrap();
    assert!(h.len() >= 3, "{h:?}");
    // A finished run resumed stays finished: same photons.
    let again = d.path().join("again");
    ok(&imap(&["resume", s(&ck), "--out", s(&again), "--quiet"]));
    let r2: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(again.join("report.json")).unwrap()).unwrap();
    assert_eq!(r2["photons"], r["photons"]);
}

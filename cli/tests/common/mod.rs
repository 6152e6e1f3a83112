//! What the command's integration tests share: running `imap`, its stderr, writing inputs.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// Runs the `imap` binary under test with `args`.
pub fn imap(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_imap"))
        .args(args)
        .output()
        .expect("run imap")
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Writes `bytes` to `dir/name`; returns the path.
pub fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> String {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p.to_str().unwrap().to_string()
}

/// `imap run MODEL --config TOML` for exactly `photons` photons on 2 threads, quietly,
/// into `out`.
pub fn run_photons(model: &str, toml: &str, out: &Path, photons: u64) -> Output {
    imap(&[
        "run",
        model,
        "--config",
        toml,
        "--photons",
        &photons.to_string(),
        "--time",
        "0",
        "--target-error",
        "0",
        "--threads",
        "2",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ])
}

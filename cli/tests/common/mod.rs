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

/// The arguments of `imap run MODEL --config TOML` for exactly `photons` photons on 2
/// threads, quietly, into `out`.
pub fn run_args(model: &str, toml: &str, out: &Path, photons: u64) -> Vec<String> {
    [
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
    ]
    .map(String::from)
    .to_vec()
}

/// Runs `imap` with `args` and `extra` after them.
pub fn imap_with(args: &[String], extra: &[&str]) -> Output {
    let mut all: Vec<&str> = args.iter().map(String::as_str).collect();
    all.extend(extra);
    imap(&all)
}

/// `imap run MODEL --config TOML` for exactly `photons` photons on 2 threads, quietly,
/// into `out`.
pub fn run_photons(model: &str, toml: &str, out: &Path, photons: u64) -> Output {
    imap_with(&run_args(model, toml, out, photons), &[])
}

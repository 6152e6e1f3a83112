//! The library's floors: every module imports only modules below it, so no import runs
//! back up (the order of docs/architecture: ffi → context → render → sched → imap →
//! transport → accel → scene, over the ground floors). Read from the sources: every
//! `crate::module` a file names outside comments must be of a lower floor than the file's
//! own module.

use std::path::Path;

/// Floors from the top: a module may name only modules further down this list.
const FLOORS: &[&[&str]] = &[
    &["ffi"],
    &["scenes"],
    &["context"],
    &["render"],
    &["sched"],
    &["imap"],
    &["transport"],
    &["accel"],
    &["scene"],
    &["photometry", "images"],
    &["spectral", "sampling", "solar", "progress"],
    &["error", "files", "fault"],
];

fn floor(module: &str) -> Option<usize> {
    FLOORS.iter().position(|f| f.contains(&module))
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn no_import_runs_back_up() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut wrong = Vec::new();
    let mut checked = 0;
    for f in &files {
        let rel = f.strip_prefix(&src).unwrap();
        let first = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        let own = first.trim_end_matches(".rs").to_string();
        if own == "lib" {
            continue;
        }
        let Some(own_floor) = floor(&own) else {
            wrong.push(format!("{}: module {own} has no floor", rel.display()));
            continue;
        };
        let text = std::fs::read_to_string(f).unwrap();
        for (n, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            let mut rest = code;
            while let Some(i) = rest.find("crate::") {
                rest = &rest[i + "crate::".len()..];
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                    .collect();
                if name == own || name.is_empty() {
                    continue;
                }
                checked += 1;
                match floor(&name) {
                    Some(other) if other > own_floor => {}
                    _ => wrong.push(format!(
                        "{}:{}: {own} names crate::{name}",
                        rel.display(),
                        n + 1
                    )),
                }
            }
        }
    }
    assert!(checked > 100, "only {checked} imports read");
    assert!(
        wrong.is_empty(),
        "imports that run back up:\n{}",
        wrong.join("\n")
    );
}

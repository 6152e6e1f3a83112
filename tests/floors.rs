//! The library's floors: every module imports only modules below it, so no import runs
//! back up (the order `src/lib.rs` describes: ffi → context → render → sched → imap →
//! transport → accel → scene, over the ground floors). Read from the sources: every
//! `crate::module` a file names outside comments must be of a lower floor than the file's
//! own module.

#[path = "common/imports.rs"]
mod imports;

use std::path::Path;

/// Floors from the top: a module may name only modules further down this list.
const FLOORS: &[&[&str]] = &[
    &["ffi"],
    // Annual daylight traces the direct sun through a context's scene, and rates an
    // observer's hours by glare's DGPs; glare looks at the lights through a context.
    &["annual"],
    &["glare"],
    &["context"],
    &["render"],
    &["sched"],
    &["imap"],
    &["transport"],
    &["accel", "weather"],
    &["scene"],
    &["photometry", "images"],
    &["spectral", "sampling", "solar", "progress"],
    &["error", "files", "fault"],
    // What the library asks of the operating system (files asks it for device names).
    &["platform"],
];

fn floor(module: &str) -> Option<usize> {
    FLOORS.iter().position(|f| f.contains(&module))
}

#[test]
fn no_import_runs_back_up() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let imports = imports::crate_imports(&src);
    let mut wrong = Vec::new();
    for i in imports.iter().filter(|i| i.from != "lib") {
        match (floor(&i.from), floor(&i.to)) {
            (None, _) => wrong.push(format!(
                "{}: module {} has no floor",
                i.file.display(),
                i.from
            )),
            (Some(own), Some(other)) if other > own => {}
            _ => wrong.push(format!(
                "{}:{}: {} names crate::{}",
                i.file.display(),
                i.line,
                i.from,
                i.to
            )),
        }
    }
    assert!(imports.len() > 100, "only {} imports read", imports.len());
    assert!(
        wrong.is_empty(),
        "imports that run back up:\n{}",
        wrong.join("\n")
    );
}

//! The `crate::module` paths a crate's sources name, read as text (for the floor and loop
//! checks of `tests/floors.rs` and `cli/tests/structure.rs`).

use std::path::{Path, PathBuf};

/// One `crate::` path in a source file.
#[allow(dead_code)] // each check reads the fields it needs
pub struct Import {
    /// The top-level module of the file that names it (`scene` for src/scene/light/sky.rs).
    pub from: String,
    /// The file, relative to the source folder, and its line (from 1).
    pub file: PathBuf,
    pub line: usize,
    /// The module it names (`imap` for `crate::imap::MapLayout`).
    pub to: String,
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Every `crate::module` outside comments in the `.rs` files below `src`, but a module's
/// own name.
pub fn crate_imports(src: &Path) -> Vec<Import> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files.sort();
    let mut out = Vec::new();
    for f in &files {
        let rel = f.strip_prefix(src).unwrap().to_path_buf();
        let first = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        let own = first.trim_end_matches(".rs").to_string();
        let text = std::fs::read_to_string(f).unwrap();
        for (n, line) in text.lines().enumerate() {
            let mut rest = line.split("//").next().unwrap_or("");
            while let Some(i) = rest.find("crate::") {
                rest = &rest[i + "crate::".len()..];
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                    .collect();
                if !name.is_empty() && name != own {
                    out.push(Import {
                        from: own.clone(),
                        file: rel.clone(),
                        line: n + 1,
                        to: name,
                    });
                }
            }
        }
    }
    out
}

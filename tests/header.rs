//! `include/imap.h` must be exactly what cbindgen generates from the code, and its version
//! macros must match Cargo.toml.

use std::path::Path;

#[test]
fn header_matches_cbindgen_output() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(root.join("cbindgen.toml")).expect("cbindgen.toml");
    let bindings = cbindgen::Builder::new()
        .with_crate(root)
        .with_config(config)
        .generate()
        .expect("cbindgen runs");
    let mut generated = Vec::new();
    bindings.write(&mut generated);
    let path = root.join("include/imap.h");
    if std::env::var_os("IMAP_BLESS").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let committed = std::fs::read(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "include/imap.h differs from the code: regenerate it with `IMAP_BLESS=1 cargo test --test header` and commit it"
    );
}

#[test]
fn header_version_matches_cargo() {
    let header = include_str!("../include/imap.h");
    for (name, value) in [
        ("IMAP_VERSION_MAJOR", env!("CARGO_PKG_VERSION_MAJOR")),
        ("IMAP_VERSION_MINOR", env!("CARGO_PKG_VERSION_MINOR")),
        ("IMAP_VERSION_PATCH", env!("CARGO_PKG_VERSION_PATCH")),
    ] {
        assert!(
            header.contains(&format!("#define {name} {value}\n")),
            "{name} in include/imap.h is not {value}"
        );
    }
}

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
    let mut raw = Vec::new();
    bindings.write(&mut raw);
    let generated = c89(&String::from_utf8(raw).expect("UTF-8")).into_bytes();
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

/// cbindgen's output made C89-clean (`c_examples/c89_header.c` compiles it with
/// `-std=c89 -pedantic -Werror`): no comma after an enum's last enumerator, and block
/// comments after preprocessor directives instead of `//`.
fn c89(header: &str) -> String {
    let mut out = String::with_capacity(header.len());
    for line in header.lines() {
        match (line.starts_with('#'), line.find("//")) {
            (true, Some(i)) => {
                let (code, comment) = line.split_at(i);
                out.push_str(&format!("{}/* {} */", code, comment[2..].trim()));
            }
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    // The last enumerator's comma: the only ",\n}" in the header (struct fields end in ';').
    out.replace(",\n}", "\n}")
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

/// Every name `imap.h` declares at file scope — macros, types, struct and enum tags,
/// enumerators, functions — carries the library's prefix, so the header compiles beside
/// any legacy code (a host's `enum { BATCH = 1 }` must not collide with it;
/// `c_examples/legacy_names.c` compiles the header beside such names). Struct fields and
/// parameter names live in their own scopes and are not checked.
#[test]
fn every_name_in_the_header_is_prefixed() {
    let header = include_str!("../include/imap.h");
    // Strip comments.
    let mut code = String::new();
    let mut rest = header;
    while let Some(i) = rest.find("/*") {
        code.push_str(&rest[..i]);
        let j = rest[i..].find("*/").expect("closed comment");
        rest = &rest[i + j + 2..];
    }
    code.push_str(rest);
    let ident_at_end = |s: &str| -> String {
        let s = s.trim_end();
        let start = s
            .rfind(|c: char| !(c.is_alphanumeric() || c == '_'))
            .map_or(0, |i| i + 1);
        s[start..].to_string()
    };
    let mut names = Vec::new();
    let mut in_enum = false;
    let mut in_struct = false;
    for line in code.lines() {
        let t = line.split("//").next().unwrap_or("").trim();
        if t.is_empty() {
            continue;
        }
        if let Some(d) = t.strip_prefix("#define ") {
            names.push(ident_at_end(d.split_whitespace().next().unwrap()));
            continue;
        }
        if t.starts_with('#') || t.starts_with("extern \"C\"") || t == "}" {
            continue;
        }
        if let Some(body) = t.strip_prefix("typedef ") {
            if let Some(p) = body.find("(*") {
                // A function-pointer type: typedef R (*Name)(...);
                let end = body[p..].find(')').unwrap() + p;
                names.push(body[p + 2..end].to_string());
            } else if let Some(b) = body.strip_suffix('{') {
                // typedef struct Tag {  /  typedef enum Tag {
                names.push(ident_at_end(b));
                in_enum = b.trim_start().starts_with("enum");
                in_struct = !in_enum;
            } else {
                // typedef struct Tag Name;
                let b = body.trim_end_matches(';');
                names.push(ident_at_end(b));
                let tag = b.split_whitespace().nth(1).unwrap_or("");
                names.push(tag.to_string());
            }
            continue;
        }
        if let Some(b) = t.strip_prefix('}') {
            // } Name;
            names.push(ident_at_end(b.trim_end_matches(';')));
            in_enum = false;
            in_struct = false;
            continue;
        }
        if in_enum {
            let e: String = t
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            names.push(e);
            continue;
        }
        if in_struct {
            continue;
        }
        // A function declaration: the identifier before the first '('.
        if let Some(p) = t.find('(') {
            names.push(ident_at_end(&t[..p]));
        }
    }
    let prefixed =
        |n: &str| n.starts_with("IMAP_") || n.starts_with("Imap") || n.starts_with("imap_");
    let bad: Vec<&String> = names
        .iter()
        .filter(|n| !prefixed(n) && n.as_str() != "IMAP_H")
        .collect();
    assert!(
        names.len() > 80,
        "found only {} names: {names:?}",
        names.len()
    );
    assert!(
        bad.is_empty(),
        "names without the imap prefix in imap.h: {bad:?}"
    );
}

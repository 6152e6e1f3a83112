//! Problems found in input files: every error of a file is collected (up to a limit) and
//! reported at once with its file and line; warnings are counted and printed once each.

use std::fmt;
use std::path::Path;

/// Most errors reported for one load; past it the rest are counted.
pub const MAX_ERRORS: usize = 20;

/// Errors and warnings of one load.
#[derive(Debug, Default)]
pub struct Diagnostics {
    pub errors: Vec<String>,
    /// Errors past `MAX_ERRORS`.
    pub more: usize,
    pub warnings: Vec<String>,
    /// The warnings given, to give each once in constant time.
    seen: std::collections::HashSet<String>,
}

/// Reads an input file of the model (its geometry, material libraries, buffers, images,
/// settings, luminaires): only a regular file, and at most the default memory budget (3/4
/// of physical memory). A path to a device such as `/dev/zero`, a FIFO or a folder is
/// refused before anything is read. The error names the path.
pub fn read_input(path: &Path) -> Result<Vec<u8>, String> {
    imap::read_regular(path, imap::default_memory_budget())
        .map_err(|e| format!("{}: {e}", printable(&path.display().to_string())))
}

/// Whether `path` is a regular file `read_input` would read, or why not.
pub fn check_input(path: &Path) -> Result<(), String> {
    let shown = || printable(&path.display().to_string());
    if imap::is_device_name_here(path) {
        return Err(format!(
            "{}: not a regular file (a Windows device name: CON, NUL, AUX, PRN, COM1-9, LPT1-9)",
            shown()
        ));
    }
    let meta = std::fs::metadata(path).map_err(|e| format!("{}: {e}", shown()))?;
    if !meta.is_file() {
        return Err(format!(
            "{}: not a regular file (a device, FIFO or folder)",
            shown()
        ));
    }
    let limit = imap::default_memory_budget();
    if meta.len() > limit {
        return Err(format!(
            "{}: {} bytes, more than the {limit} bytes allowed",
            shown(),
            meta.len()
        ));
    }
    Ok(())
}

impl Diagnostics {
    /// An error at `path`:`line`.
    pub fn error(&mut self, path: &Path, line: usize, msg: impl fmt::Display) {
        let e = format!("{}:{line}: {}", path.display(), printable(&msg.to_string()));
        if self.errors.last() == Some(&e) {
            return; // the same problem again on the same line (every corner of a face)
        }
        if self.errors.len() < MAX_ERRORS {
            self.errors.push(e);
        } else {
            self.more += 1;
        }
    }

    /// A warning (printed once, even if it happens many times: count it first).
    pub fn warn(&mut self, msg: impl fmt::Display) {
        let m = printable(&msg.to_string());
        if self.seen.insert(m.clone()) {
            self.warnings.push(m);
        }
    }

    pub fn has_errors(&self) -> bool {
        !self.errors.is_empty()
    }
}

/// `text` with control characters (from a file's raw bytes, say) shown as escapes, so
/// nothing read from an input reaches the terminal as a control sequence.
pub fn printable(text: &str) -> String {
    let mut s = String::with_capacity(text.len());
    for c in text.chars() {
        if c.is_control() {
            s.extend(c.escape_default());
        } else {
            s.push(c);
        }
    }
    s
}

/// A line of a file as text: UTF-8 when it is, otherwise Latin-1 (each byte one
/// character), the encoding older exporters write names in.
pub fn decode(bytes: &[u8]) -> String {
    match std::str::from_utf8(bytes) {
        Ok(s) => s.to_string(),
        Err(_) => bytes.iter().map(|&b| b as char).collect(),
    }
}

/// The logical lines of a file: (line number of their first physical line, text), with
/// `\` continuations joined and comments removed (a `#` that starts a word starts a
/// comment; one inside a word, as in 3ds Max's `Material#25`, is part of it).
pub fn logical_lines(bytes: &[u8]) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut pending: Option<(usize, String)> = None;
    for (i, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let mut text = decode(raw);
        let comment = text
            .char_indices()
            .find(|&(i, c)| c == '#' && (i == 0 || text[..i].ends_with(char::is_whitespace)))
            .map(|(i, _)| i);
        if let Some(c) = comment {
            text.truncate(c);
        }
        let (start, mut acc) = pending.take().unwrap_or((i + 1, String::new()));
        if let Some(body) = text.trim_end().strip_suffix('\\') {
            acc.push_str(body);
            acc.push(' ');
            pending = Some((start, acc));
            continue;
        }
        acc.push_str(&text);
        out.push((start, acc));
    }
    if let Some(p) = pending {
        out.push(p);
    }
    out
}

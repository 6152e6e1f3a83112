//! The command's error: a message for the user (file and line where the input is at
//! fault), and `fail!` to return one.

use crate::diag::printable;
use std::fmt;

/// An error for the user, one line per problem: what, and where when a file is to blame.
#[derive(Debug)]
pub struct CliError(pub String);

impl CliError {
    /// Every error of a load at once (and how many more there were).
    pub fn from_diagnostics(d: &crate::diag::Diagnostics) -> Self {
        let mut lines = d.errors.clone();
        if d.more > 0 {
            lines.push(format!(
                "... and {} more error(s) (the first {} are shown)",
                d.more,
                crate::diag::MAX_ERRORS
            ));
        }
        CliError(lines.join("\n"))
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl From<imap::Error> for CliError {
    fn from(e: imap::Error) -> Self {
        let n = NAMES.lock().unwrap_or_else(|p| p.into_inner());
        let name = match e.subject {
            Some(imap::Subject::Mesh(i)) => n.meshes.get(i as usize),
            Some(imap::Subject::Light(i)) => n.lights.get(i as usize),
            _ => None,
        };
        match name.filter(|s| !s.is_empty()) {
            Some(name) => CliError(format!("{name}: libimap: {}", printable(&e.message))),
            None => CliError(format!("libimap: {}", printable(&e.message))),
        }
    }
}

pub type Result<T> = std::result::Result<T, CliError>;

macro_rules! fail {
    ($($arg:tt)*) => { return Err(CliError(format!($($arg)*))) };
}
pub(crate) use fail;

/// What the user calls the context's meshes and lights (the object and file, the
/// settings entry), by libimap id: a library error about mesh 3 names the object.
#[derive(Default)]
pub struct Names {
    pub meshes: Vec<String>,
    pub lights: Vec<String>,
}

pub static NAMES: std::sync::Mutex<Names> = std::sync::Mutex::new(Names {
    meshes: Vec::new(),
    lights: Vec::new(),
});

/// Records the user's name of mesh (or light) `id`.
pub fn name_item(list: fn(&mut Names) -> &mut Vec<String>, id: u32, name: String) {
    let mut n = NAMES.lock().unwrap_or_else(|p| p.into_inner());
    let v = list(&mut n);
    if v.len() <= id as usize {
        v.resize(id as usize + 1, String::new());
    }
    v[id as usize] = name;
}

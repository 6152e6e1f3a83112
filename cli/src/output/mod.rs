//! Outputs: the output folder, whose files appear together or not at all (`Outputs`);
//! the maps (`maps`: per-vertex irradiance and error as CSV and PLY, the photometric
//! summary), the view (`view`: the camera and the model drawn from it, with `raster`'s
//! PNG, colour scale and legend) and the convergence plot (`plot`).

pub mod maps;
pub mod plot;
pub mod view;

pub use crate::raster::write_png;
pub use maps::{back_lit, photometric_summary, read_maps, to_rgb, write_csv, write_ply, ToneMap};
pub use plot::plot_convergence;
pub use view::{choose_camera, load_with_camera, render_view};

use crate::error::{CliError, Result};
use std::path::{Path, PathBuf};

/// A set of output files that appear together or not at all: each is written into a
/// fresh staging folder inside the output folder (`.imap-out-PID-N`), and `commit` then
/// (1) marks the staging folder complete, (2) removes the previous outputs of the same kind
/// (the manifest, `report.json` or `render.json`, first; then every file it listed), and
/// (3) renames the new files in, the manifest last. Whatever the moment of a kill, the
/// folder holds one run's files and never a mix of two: the manifest is there only when
/// its whole set is. A later command finishes a commit that a kill interrupted (the
/// complete staging folder of a process that is gone, when no manifest is there) and
/// removes every other staging folder and temporary file such a process left.
pub struct Outputs {
    dir: PathBuf,
    staging: PathBuf,
    manifest: String,
    files: Vec<String>,
    committed: bool,
}

/// The name of the marker that says a staging folder holds a whole set.
const COMPLETE: &str = ".complete";

/// Whether process `pid` is gone.
fn process_gone(pid: i32) -> bool {
    pid > 0 && !Path::new(&format!("/proc/{pid}")).exists()
}

/// The pid in a name `PREFIX<pid>-…` or `PREFIX<pid>.…`.
fn pid_in(name: &str, prefix: &str) -> Option<i32> {
    let rest = name.strip_prefix(prefix)?;
    let end = rest
        .find(|c: char| !c.is_ascii_digit())
        .unwrap_or(rest.len());
    rest[..end].parse().ok()
}

/// Creates the output folder `out` (and its parents), or says why not; on Windows a device
/// name (`NUL`, `CON`, ...) is refused as one before anything is created.
pub fn create_out_dir(out: &Path) -> Result<()> {
    if imap::is_device_name_here(out) {
        return Err(CliError(format!(
            "{}: a Windows device name (CON, NUL, AUX, PRN, COM1-9, LPT1-9), not a folder for the outputs",
            crate::diag::printable(&out.display().to_string())
        )));
    }
    std::fs::create_dir_all(out).map_err(|e| CliError(format!("{}: {e}", out.display())))
}

impl Outputs {
    /// Outputs into `dir`; `manifest` is the file written last (it lists the others under
    /// "outputs").
    pub fn new(dir: &Path, manifest: &str) -> Result<Self> {
        recover(dir);
        static N: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let staging = dir.join(format!(".imap-out-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&staging);
        std::fs::create_dir_all(&staging)
            .map_err(|e| CliError(format!("{}: {e}", staging.display())))?;
        Ok(Outputs {
            dir: dir.to_path_buf(),
            staging,
            manifest: manifest.to_string(),
            files: Vec::new(),
            committed: false,
        })
    }

    /// The path to write `name` to (in the staging folder, under its own name: writers
    /// that choose a format by extension keep working).
    pub fn temp(&mut self, name: &str) -> Result<PathBuf> {
        self.files.push(name.to_string());
        Ok(self.staging.join(name))
    }

    /// Puts the whole set in place (see the type's description).
    pub fn commit(mut self) -> Result<()> {
        fault("kill-before-commit");
        let io = |p: &Path, e: std::io::Error| CliError(format!("{}: {e}", p.display()));
        // The marker names the new set and the previous one, so that a commit cut short
        // can be finished by the next command whatever was done of it.
        let old = listed_outputs(&self.dir.join(&self.manifest));
        let marker = self.staging.join(COMPLETE);
        let plan = serde_json::json!({
            "manifest": self.manifest, "files": self.files, "old": old
        });
        std::fs::write(&marker, plan.to_string()).map_err(|e| io(&marker, e))?;
        install(&self.dir, &self.staging, &self.manifest, &self.files, &old)?;
        self.committed = true;
        let _ = std::fs::remove_dir_all(&self.staging);
        Ok(())
    }
}

impl Drop for Outputs {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

/// The outputs a manifest lists (plain names inside its folder only: a manifest is data
/// and names no other path); none when there is no readable manifest.
fn listed_outputs(manifest: &Path) -> Vec<String> {
    let mut old: Vec<String> = std::fs::read(manifest)
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .and_then(|v| {
            v.get("outputs")?.as_array().map(|a| {
                a.iter()
                    .filter_map(|x| x.as_str().map(str::to_string))
                    .collect()
            })
        })
        .unwrap_or_default();
    old.retain(|n| plain_name(n));
    old
}

fn plain_name(n: &str) -> bool {
    !n.is_empty() && !n.contains('/') && !n.contains('\\') && !n.starts_with('.')
}

/// Removes the previous set (the manifest first, then the files it listed and those the
/// new set replaces) and renames the files of `staging` into `dir`, the manifest last.
/// Finishing a commit that was cut short is the same walk: files already moved are not
/// in `staging` any more, and stay.
fn install(
    dir: &Path,
    staging: &Path,
    manifest: &str,
    files: &[String],
    old: &[String],
) -> Result<()> {
    let io = |p: &Path, e: std::io::Error| CliError(format!("{}: {e}", p.display()));
    let remove = |name: &str| match std::fs::remove_file(dir.join(name)) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(io(&dir.join(name), e)),
        _ => Ok(()),
    };
    // A file of the new set that has left staging is in place already, and stays.
    let replaced = |name: &String| !files.contains(name) || staging.join(name).exists();
    if staging.join(manifest).exists() {
        remove(manifest)?;
    }
    for name in old.iter().chain(files).filter(|n| *n != manifest) {
        if replaced(name) {
            remove(name)?;
        }
    }
    let last = files.iter().filter(|n| *n == manifest);
    for (k, name) in files
        .iter()
        .filter(|n| *n != manifest)
        .chain(last)
        .enumerate()
    {
        fault(&format!("kill-after-renames={k}"));
        let (from, to) = (staging.join(name), dir.join(name));
        if from.exists() {
            std::fs::rename(&from, &to).map_err(|e| io(&to, e))?;
        }
    }
    Ok(())
}

/// Cleans up after commands that were killed while writing into `dir`: finishes a commit
/// that was cut short (a complete staging folder), and removes staging folders and
/// temporary files of processes that are gone.
fn recover(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let path = e.path();
        if let Some(pid) = pid_in(&name, ".imap-out-") {
            if !process_gone(pid) {
                continue;
            }
            let plan = std::fs::read(path.join(COMPLETE))
                .ok()
                .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok());
            if let Some(plan) = plan {
                let list = |k: &str| -> Vec<String> {
                    plan[k]
                        .as_array()
                        .map(|a| {
                            a.iter()
                                .filter_map(|x| x.as_str())
                                .filter(|n| plain_name(n))
                                .map(str::to_string)
                                .collect()
                        })
                        .unwrap_or_default()
                };
                if let Some(m) = plan["manifest"].as_str().filter(|m| plain_name(m)) {
                    let _ = install(dir, &path, m, &list("files"), &list("old"));
                }
            }
            let _ = std::fs::remove_dir_all(&path);
        } else if name.starts_with('.') && name.contains(".tmp-") {
            // Temporary files of earlier versions (`.NAME.tmp-PID.EXT`).
            let pid = name.split(".tmp-").nth(1).and_then(|r| pid_in(r, ""));
            if pid.is_some_and(process_gone) {
                let _ = std::fs::remove_file(&path);
            }
        }
    }
}

/// Fault injection for the tests of interrupted outputs: the process kills itself
/// (SIGKILL, as a crash or the OOM killer would) at `point` when `IMAP_TEST_FAULT` names
/// it. Unset in normal use.
fn fault(point: &str) {
    static F: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    let f = F.get_or_init(|| std::env::var("IMAP_TEST_FAULT").unwrap_or_default());
    if !f.is_empty() && f.split(',').any(|x| x.trim() == point) {
        // SAFETY: sending a signal to this process.
        #[cfg(unix)]
        unsafe {
            libc::kill(libc::getpid(), libc::SIGKILL)
        };
        // (Windows: ended at once, no handler or destructor run, as a crash would.)
        #[cfg(not(unix))]
        std::process::abort();
    }
}

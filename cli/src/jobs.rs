//! Runs beyond one process and one crash: checkpoints (`imap run --checkpoint`), resume
//! (`imap resume`), shards (`imap run --shard k/N`) and merges (`imap merge`).
//!
//! A state file written by the command carries, as its metadata, what the command needs to
//! go on: the model's path, the effective settings (stop criteria included) and the shard.
//! The library refuses a state whose scene or settings differ from the context's (its
//! fingerprint), so a model edited between a checkpoint and its resume is caught.

use crate::error::{fail, CliError, Result};
use crate::settings::Settings;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Default seconds between checkpoints.
pub const DEFAULT_EVERY_S: f64 = 60.0;

/// How a run keeps its state.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct StatePlan {
    /// Where checkpoints (and the final state) go.
    pub checkpoint: Option<PathBuf>,
    /// Seconds between checkpoints (None: one at the end).
    pub every_s: Option<f64>,
    /// Shard k of N: the run writes a state (no outputs).
    pub shard: Option<(u64, u64)>,
}

impl StatePlan {
    /// From the command line: `--checkpoint`, `--checkpoint-every`, `--shard k/N`.
    pub fn new(
        checkpoint: Option<&Path>,
        every_s: Option<f64>,
        shard: Option<&str>,
        out: &Path,
    ) -> Result<Self> {
        let shard = shard.map(parse_shard).transpose()?;
        if let Some(s) = every_s {
            if !(s.is_finite() && s > 0.0) {
                fail!("--checkpoint-every {s}: give a positive number of seconds");
            }
            if checkpoint.is_none() && shard.is_none() {
                fail!("--checkpoint-every needs --checkpoint FILE");
            }
        }
        // A shard always ends with its state; by default in the output folder.
        let checkpoint = checkpoint
            .map(absolute)
            .or_else(|| shard.map(|(k, n)| absolute(&out.join(format!("shard-{k}-of-{n}.imap")))));
        Ok(StatePlan {
            every_s: every_s
                .or((checkpoint.is_some() && shard.is_none()).then_some(DEFAULT_EVERY_S)),
            checkpoint,
            shard,
        })
    }
}

/// `k/N` with 0 ≤ k < N.
fn parse_shard(s: &str) -> Result<(u64, u64)> {
    let bad = || CliError(format!("--shard {s}: give k/N with 0 <= k < N, e.g. 0/4"));
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let (k, n): (u64, u64) = (
        k.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if n == 0 || k >= n {
        return Err(bad());
    }
    Ok((k, n))
}

/// The path made absolute (against the current folder), so a state names it from anywhere.
pub fn absolute(p: &Path) -> PathBuf {
    std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf())
}

/// What the command stores in a state besides the library's own data.
#[derive(Serialize, Deserialize)]
pub struct StateMeta {
    /// Always "imap command state".
    pub written_by: String,
    pub scene: PathBuf,
    pub settings: Settings,
    /// The settings' folder (luminaire files are relative to it).
    pub base_dir: PathBuf,
    pub out: PathBuf,
    pub plan: StatePlan,
}

const WRITTEN_BY: &str = "imap command state";

impl StateMeta {
    pub fn new(scene: &Path, settings: &Settings, out: &Path, plan: &StatePlan) -> Self {
        StateMeta {
            written_by: WRITTEN_BY.into(),
            scene: absolute(scene),
            settings: settings.clone(),
            base_dir: absolute(&settings.base_dir),
            out: absolute(out),
            plan: plan.clone(),
        }
    }

    pub fn bytes(&self) -> Vec<u8> {
        serde_json::to_vec(self).expect("settings serialise")
    }

    /// The settings with their folder.
    pub fn settings(&self) -> Settings {
        let mut s = self.settings.clone();
        s.base_dir = self.base_dir.clone();
        s
    }
}

/// A state file's bytes and the command's metadata. The whole state is checked (frame and
/// checksum) before its metadata is used: a damaged file is named as such, never as a
/// model path that its flipped bits made up.
pub fn read_state(path: &Path) -> Result<(Vec<u8>, StateMeta)> {
    let named = |e: imap::Error| CliError(format!("{}: {}", path.display(), e.message));
    let limit = imap::default_memory_budget();
    let bytes = imap::read_state_file(path, limit).map_err(|e| CliError(e.message))?;
    let meta = imap::state_info(&bytes).map_err(named)?.meta;
    let m = match serde_json::from_slice::<StateMeta>(meta) {
        Ok(m) if m.written_by == WRITTEN_BY => m,
        _ => fail!(
            "{}: a libimap state, but not one written by the imap command (it has no model and settings to go on with)",
            path.display()
        ),
    };
    Ok((bytes, m))
}

//! `[render]`: the camera render's method and stop criteria.

use serde::{Deserialize, Serialize};

/// `[render]` in the settings: how the image is computed.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RenderSettings {
    /// "final-gathering" (default), "semi-synchronous", "synchronous" or "asynchronous".
    #[serde(default)]
    pub method: Option<String>,
    /// Passes over the image (0 = no limit).
    #[serde(default)]
    pub passes: u64,
    /// Seconds (0 = no limit; with no criterion at all, 30 s).
    #[serde(default)]
    pub time_s: f64,
    /// Target relative error of the image (0 = none).
    #[serde(default)]
    pub target_error: f64,
    /// First gathering radius, scene units (0 = four pixel footprints).
    #[serde(default)]
    pub initial_radius: f64,
    /// Radius reduction α in (0, 1) (0 = 2/3).
    #[serde(default)]
    pub alpha: f64,
    /// Semi-synchronous: threads per group (0 = 1).
    #[serde(default)]
    pub group_threads: usize,
}

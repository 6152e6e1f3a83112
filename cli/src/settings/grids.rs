//! `[[grid]]`: calculation grids and sensor point files.

use serde::{Deserialize, Serialize};

/// A `[[grid]]` of the settings. Positions and sizes in scene units.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GridSettings {
    /// Names the outputs (`grid_<name>.csv`, `.png`); default "grid1", "grid2", …
    #[serde(default)]
    pub name: Option<String>,
    /// A corner of the rectangle.
    #[serde(default)]
    pub origin: Option<[f64; 3]>,
    /// Direction of its first edge (any length).
    #[serde(default)]
    pub u: Option<[f64; 3]>,
    /// Direction of its second edge, perpendicular to `u`.
    #[serde(default)]
    pub v: Option<[f64; 3]>,
    /// Lengths of the two edges.
    #[serde(default)]
    pub size: Option<[f64; 2]>,
    /// Instead of a rectangle: a sensor point file (`x y z dx dy dz` per line, as rtrace
    /// reads them), relative to the settings file.
    #[serde(default)]
    pub points: Option<String>,
    /// The radius each point of a point file averages over (scene units); default half
    /// the distance to its nearest neighbour (neighbours' squares touch, never overlap),
    /// at most 0.25 m, and 0.1 m for a lone point.
    #[serde(default)]
    pub radius: Option<f64>,
    /// Distance between points; default by EN 12464-1: p = 0.2 · 5^log10(d) m, d the longer
    /// edge in metres.
    #[serde(default)]
    pub spacing: Option<f64>,
    /// Which light is measured: "front" (default: light arriving from the side u × v points
    /// to, e.g. from above for u = x, v = y in a Z-up scene) or "back".
    #[serde(default)]
    pub side: Option<String>,
}

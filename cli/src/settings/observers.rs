//! `[[observer]]`: eyes whose light and glare `imap run` reports.

use serde::{Deserialize, Serialize};

/// An `[[observer]]` of the settings: an eye, where it looks and its up (scene units).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ObserverSettings {
    /// Names it in the outputs; default "observer1", "observer2", …
    #[serde(default)]
    pub name: Option<String>,
    /// The eye (e.g. 1.2 m above the floor for a seated person).
    pub eye: [f64; 3],
    /// The direction it looks in (any length).
    pub view: [f64; 3],
    /// Its up; default the model's up (`up_axis`).
    #[serde(default)]
    pub up: Option<[f64; 3]>,
    /// The radius of the sensor at the eye that measures its vertical illuminance (scene
    /// units); default 0.05 m.
    #[serde(default)]
    pub radius: Option<f64>,
}

//! What a render is asked (`RenderMethod`, `RenderParams`) and what it gives back
//! (`Image`, `RenderReport`).

use crate::progress::{Progress, StopReason};

/// How the threads share the work.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RenderMethod {
    Synchronous,
    Asynchronous,
    SemiSynchronous,
    /// Final gathering from the illumination map (`gather`): path-traced eye paths that
    /// read the map at their second diffuse vertex; the render extends the map as it goes.
    FinalGather,
}

/// What a render is asked to do.
pub struct RenderParams<'a> {
    pub method: RenderMethod,
    /// Semi-synchronous: threads per group (0 = 1).
    pub group_threads: usize,
    /// Semi-synchronous: phases between re-randomised masks (0 = 4).
    pub remask_phases: u32,
    /// Forward photons per pass over the image (0 = one per pixel); a group's phase traces
    /// its mask's share.
    pub forward_per_pass: u64,
    /// First gathering radius in scene units (0 = four pixel footprints).
    pub initial_radius: f64,
    /// Radius reduction α in (0, 1) (0 = 2/3).
    pub alpha: f64,
    /// Stop after this many passes over the image (0 = no limit).
    pub passes: u64,
    pub time_budget_s: f64,
    pub target_rel_error: f64,
    pub progress_interval_s: f64,
    pub max_path_events: u32,
    pub progress: Option<&'a mut dyn FnMut(&Progress) -> bool>,
}

impl Default for RenderParams<'_> {
    /// As `imap_render_params_default`: semi-synchronous, every automatic setting, no stop
    /// criterion (set one), progress every 0.5 s, 2²⁰ events.
    fn default() -> Self {
        RenderParams {
            method: RenderMethod::SemiSynchronous,
            group_threads: 1,
            remask_phases: 0,
            forward_per_pass: 0,
            initial_radius: 0.0,
            alpha: 0.0,
            passes: 0,
            time_budget_s: 0.0,
            target_rel_error: 0.0,
            progress_interval_s: 0.5,
            max_path_events: 1 << 20,
            progress: None,
        }
    }
}

/// Figures of a render.
#[derive(Clone, Debug, Default)]
pub struct RenderReport {
    pub threads: usize,
    pub groups: usize,
    pub threads_per_group: usize,
    /// Group phases completed (each adds a sample to its mask's pixels).
    pub phases: u64,
    /// Samples per pixel, averaged over the image.
    pub passes: f64,
    pub backward_paths: u64,
    pub backward_rays: u64,
    pub forward_photons: u64,
    pub forward_rays: u64,
    /// Forward photon hits that reached a backward photon.
    pub gathers: u64,
    pub wall_s: f64,
    pub stop: Option<StopReason>,
    pub rel_error: f64,
    /// Seconds summed over groups (measured by each group's leader): backward paths,
    /// map building, forward photons, waiting to close the maps, finalizing samples.
    pub time_backward_s: f64,
    pub time_build_s: f64,
    pub time_forward_s: f64,
    pub time_close_s: f64,
    pub time_finalize_s: f64,
    /// Batches of forward photons that entered another group's maps.
    pub joins: u64,
    /// Extra forward batches owners traced while other threads still used their maps.
    pub close_retries: u64,
    /// Joiners that found maps not in the open state (must be 0).
    pub gate_violations: u64,
    /// Largest backward-map memory of one group, bytes.
    pub map_bytes_per_group: u64,
    /// Pixel stores, bytes (one per thread for the asynchronous method).
    pub pixel_bytes: u64,
    /// All maps and stores, bytes.
    pub total_bytes: u64,
    pub dropped_paths: u64,
    pub history: Vec<Progress>,
    /// What the scene has that the method cannot show (`OMITS_*`, or-ed; 0: nothing known).
    pub omitted: u32,
}

/// `RenderReport::omitted`: the scene has point-like lights (or the sun) outside a scattering
/// medium whose light can only enter it through a refracting surface (an opal cover or a
/// light guide lit by LEDs, a sunbeam in haze through a window): what the medium scatters
/// of that light toward the camera is missing from the picture, in every method. (A
/// shadow ray cannot follow refraction, and no photon map holds volume photons.)
pub const OMITS_REFRACTED_INTO_MEDIUM: u32 = 1;
/// `RenderReport::omitted`: the backward photon map's methods, in a scene with point-like
/// lights (or the sun), specular surfaces and glossy reflectors: light that reaches a
/// glossy reflector through specular surfaces (a caustic on a rough metal or a plastic)
/// is missing (its backward photons sit at diffuse vertices only). Final gathering has it.
pub const OMITS_CAUSTICS_ON_GLOSSY: u32 = 2;

/// The rendered image: radiance per pixel and band (row-major from the top left), and the
/// relative standard error of each pixel's band mean.
#[derive(Clone, Debug)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub bands: usize,
    pub radiance: Vec<f64>,
    pub rel_error: Vec<f64>,
}

impl Image {
    /// A black image of `width × height` pixels and `bands` bands, every pixel's error
    /// still to be filled.
    pub fn new(width: u32, height: u32, bands: usize) -> Self {
        let pixels = width as usize * height as usize;
        Image {
            width,
            height,
            bands,
            radiance: vec![0.0; pixels * bands],
            rel_error: vec![0.0; pixels],
        }
    }
}

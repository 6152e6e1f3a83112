//! The context's camera renders (the second system).

use super::{check_threads, Context};
use crate::error::{bail, check_finite_scalar, Error, ImapStatus, Result};
use crate::render::{self, Camera, CameraDesc, EyeTracer, Image, RenderParams, RenderReport};
use crate::transport::Tracer;

impl Context {
    /// Renders the camera's view (camera luminance by backward photon maps). Independent of
    /// the illumination map: neither reads nor changes it, and allocates none. The report is
    /// also kept (`render_report`). When a worker thread is lost the render stops and this
    /// returns `ImapErrThreadLost`; `render_partial` gives the image rendered until then.
    pub fn render(
        &mut self,
        camera: &CameraDesc,
        params: &mut RenderParams,
    ) -> Result<(Image, RenderReport)> {
        let (image, report, lost) = self.render_partial(camera, params)?;
        match lost {
            Some(e) => Err(e),
            None => Ok((image, report)),
        }
    }

    /// The report of the last render since the last reset.
    pub fn render_report(&self) -> Option<&RenderReport> {
        self.last_render.as_ref()
    }

    /// As `render`, but a lost worker thread still yields the image rendered until the
    /// render stopped, with the error beside it.
    pub fn render_partial(
        &mut self,
        camera: &CameraDesc,
        params: &mut RenderParams,
    ) -> Result<(Image, RenderReport, Option<Error>)> {
        check_render_params(params)?;
        self.prepare_scene()?;
        let prepared = self.prepared.as_ref().expect("prepared above");
        let cam = Camera::new(camera, prepared.scene.origin)?;
        let r = params.initial_radius;
        let scene_radius = prepared.scene.radius;
        if r != 0.0 && !(r >= 1e-6 * scene_radius && r <= 2.0 * scene_radius) {
            bail!(
                ImapErrInvalidArgument,
                "params.initial_radius = {r:e} is not between 1e-6 and 2 times the scene's bounding radius ({scene_radius:e} scene units); 0 chooses it from the pixel size"
            );
        }
        let threads = self.worker_threads();
        let nb = self.scene.bands.count();
        let pixels = cam.pixels();
        let need = render::bytes_needed(params.method, params.group_threads, threads, pixels, nb);
        let need = u64::try_from(need).unwrap_or(u64::MAX);
        self.check_budget(
            self.memory_estimate(),
            need,
            &format!(
                "the render ({:?}, {threads} threads, {pixels} pixels × {nb} bands)",
                params.method
            ),
        )?;
        let eye = EyeTracer::new(
            &self.scene,
            &prepared.scene,
            &prepared.accel,
            &cam,
            params.max_path_events,
            params.initial_radius,
        );
        // The render's photons record nothing: sensors are left out (and cameras do not see
        // them: they are not in `accel`).
        let fwd = Tracer {
            scene: &prepared.scene,
            accel: &prepared.accel,
            sensors: None,
            materials: &self.scene.materials,
            bands: nb,
            seed: self.config.seed,
            unit_m: self.config.unit_m,
            max_events: params.max_path_events,
            direct: None,
        };
        let (image, report, lost) = render::render(&eye, fwd, params, threads, self.config.seed);
        self.last_render = Some(report.clone());
        let lost = lost.map(|why| {
            Error::new(
                ImapStatus::ImapErrThreadLost,
                format!("{why}; the render was stopped and its image holds what was rendered until then"),
            )
        });
        Ok((image, report, lost))
    }
}

/// Checks render parameters, naming the field at fault.
fn check_render_params(p: &RenderParams) -> Result<()> {
    check_finite_scalar("params.time_budget_s", p.time_budget_s)?;
    check_finite_scalar("params.target_rel_error", p.target_rel_error)?;
    check_finite_scalar("params.progress_interval_s", p.progress_interval_s)?;
    check_finite_scalar("params.initial_radius", p.initial_radius)?;
    check_finite_scalar("params.alpha", p.alpha)?;
    for (name, v) in [
        ("params.time_budget_s", p.time_budget_s),
        ("params.target_rel_error", p.target_rel_error),
        ("params.initial_radius", p.initial_radius),
    ] {
        if v < 0.0 {
            bail!(ImapErrInvalidArgument, "{name} = {v} is negative");
        }
    }
    if p.progress_interval_s <= 0.0 {
        bail!(
            ImapErrInvalidArgument,
            "params.progress_interval_s = {} must be positive",
            p.progress_interval_s
        );
    }
    if !(p.alpha == 0.0 || (p.alpha > 0.0 && p.alpha < 1.0)) {
        bail!(
            ImapErrInvalidArgument,
            "params.alpha = {} must be in (0, 1) (or 0 for the default 2/3)",
            p.alpha
        );
    }
    if p.max_path_events == 0 {
        bail!(
            ImapErrInvalidArgument,
            "params.max_path_events is 0: a path needs at least one event"
        );
    }
    check_threads("params.group_threads", p.group_threads)?;
    if p.passes == 0 && p.time_budget_s == 0.0 && p.target_rel_error == 0.0 && p.progress.is_none()
    {
        bail!(
            ImapErrInvalidArgument,
            "params sets no stop criterion: set passes, time_budget_s, target_rel_error or a progress callback"
        );
    }
    Ok(())
}

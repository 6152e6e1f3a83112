//! The context's camera renders (the second system).

use super::Layer;
use super::{check_threads, Context};
use crate::error::{bail, check_finite_scalar, Error, ImapStatus, Result};
use crate::progress::Progress;
use crate::render::backward::{MapIndirect, MeshIndirect};
use crate::render::gather::{self, driver, Batch, Caustics, GatherStore, Schedule};
use crate::render::{
    self, Camera, CameraDesc, EyeTracer, Image, RenderMethod, RenderParams, RenderReport,
};
use crate::scene::Extent;
use crate::sched::RunParams;
use crate::transport::Tracer;
use std::sync::atomic::AtomicBool;

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
        self.host_surfaces().iter().for_each(|(_, h)| h.clear());
        let (image, report, lost) = self.render_partial(camera, params)?;
        if let Some(e) = lost {
            return Err(e);
        }
        if let Some(e) = self.host_failure("camera paths and photons") {
            return Err(e);
        }
        Ok((image, report))
    }

    /// Renders the camera's view by plain path tracing, `samples` paths per pixel on the
    /// worker threads: an independent, unbiased reference for the photon-map renderer (its
    /// own code paths but the scene, the camera and `direct_light`'s light sampling; no
    /// photons, no radii). Deterministic for a seed, whatever the thread count. Rust API
    /// only. Light of point-like lights and the sun through specular surfaces (their
    /// caustics) cannot be path traced and is missing.
    pub fn path_trace(
        &mut self,
        camera: &CameraDesc,
        samples: u32,
        max_events: u32,
    ) -> Result<Image> {
        self.host_surfaces().iter().for_each(|(_, h)| h.clear());
        let image = self.trace_pixels(camera, samples, max_events)?;
        match self.host_failure("camera paths") {
            Some(e) => Err(e),
            None => Ok(image),
        }
    }

    /// What final gathering reads from the map per recorded vertex side, with its relative
    /// error: the indirect irradiance (combined minus the direct layer) when the direct
    /// layer is kept, else the whole irradiance (`MapIndirect::combined`).
    fn map_indirect(&self) -> Result<MapIndirect> {
        if self.photons() == 0 {
            bail!(
                ImapErrOutOfOrder,
                "final gathering reads the illumination map: run it first"
            );
        }
        let direct = self.scene.layers.direct;
        let nb = self.scene.bands.count();
        let mut meshes = Vec::new();
        for (i, m) in self.scene.meshes.iter().enumerate() {
            if !m.record {
                meshes.push(None);
                continue;
            }
            let nv = m.positions.len();
            let sides = if m.two_sided { 2 } else { 1 };
            let mut irradiance = vec![0.0; nv * sides * nb];
            let mut rel_error = vec![0.0; nv * sides];
            let (mut all, mut dir) = (vec![0.0; nv], vec![0.0; nv]);
            let (mut r_all, mut r_dir) = (vec![0.0; nv], vec![0.0; nv]);
            for side in 0..sides {
                let s = side as u32;
                self.rel_error(i as u32, s, &mut r_all)?;
                if direct {
                    self.rel_error_layer(i as u32, s, Layer::Direct, &mut r_dir)?;
                }
                let (mut m_all, mut m_dir) = (vec![0.0; nv], vec![0.0; nv]);
                for b in 0..nb {
                    self.irradiance(i as u32, s, b as u32, &mut all)?;
                    if direct {
                        self.irradiance_layer(i as u32, s, b as u32, Layer::Direct, &mut dir)?;
                    }
                    for v in 0..nv {
                        let x = (all[v] - dir[v]).max(0.0);
                        irradiance[(v * sides + side) * nb + b] = x;
                        m_all[v] += all[v] / nb as f64;
                        m_dir[v] += dir[v] / nb as f64;
                    }
                }
                for v in 0..nv {
                    // The difference's error: both parts' errors, taken as independent.
                    let ind = m_all[v] - m_dir[v];
                    let sigma = (m_all[v] * r_all[v]).hypot(m_dir[v] * r_dir[v]);
                    rel_error[v * sides + side] = if ind > 0.0 { sigma / ind } else { 0.0 };
                }
            }
            meshes.push(Some(MeshIndirect {
                sides,
                irradiance,
                rel_error,
            }));
        }
        Ok(MapIndirect {
            meshes,
            combined: !direct,
        })
    }

    fn trace_pixels(
        &mut self,
        camera: &CameraDesc,
        samples: u32,
        max_events: u32,
    ) -> Result<Image> {
        if samples == 0 || max_events == 0 {
            bail!(
                ImapErrInvalidArgument,
                "samples = {samples}, max_events = {max_events}: both must be positive"
            );
        }
        self.prepare_scene()?;
        let origin = self.prepared.as_ref().expect("prepared above").scene.origin;
        let cam = Camera::new(camera, origin)?;
        let eye = self.eye_tracer(&cam, max_events, 0.0);
        let nb = self.scene.bands.count();
        let pixels = cam.pixels();
        let threads = self.worker_threads().max(1);
        let store = GatherStore::new(pixels, nb, threads);
        let stop = AtomicBool::new(false);
        let batch = Batch {
            up_to: samples,
            deadline: None,
            stop: &stop,
            map_photons: 0,
        };
        let tick = std::time::Duration::from_secs(3600);
        let (_, lost) = gather::passes(
            &eye,
            &store,
            self.config.seed,
            threads,
            &batch,
            tick,
            &mut || false,
        );
        if let Some(why) = lost {
            bail!(ImapErrThreadLost, "{why}");
        }
        let mut image = Image::new(camera.width, camera.height, nb);
        store.estimate(&Schedule::default(), None, Some(&mut image));
        Ok(image)
    }

    /// The eye paths' tracer for `cam` on the prepared scene (no fixed first radius).
    fn eye_tracer<'a>(
        &'a self,
        cam: &'a Camera,
        max_events: u32,
        initial_radius: f64,
    ) -> EyeTracer<'a> {
        let prepared = self.prepared.as_ref().expect("prepared before a render");
        let mut eye = EyeTracer::new(
            &self.scene,
            &prepared.scene,
            &prepared.accel,
            cam,
            max_events,
            initial_radius,
        );
        let mut kept = prepared.coverage.lock().unwrap_or_else(|e| e.into_inner());
        let coverage = match &*kept {
            Some((desc, c)) if *desc == cam.desc => c.clone(),
            _ => {
                let c = std::sync::Arc::new(eye.build_coverage());
                *kept = Some((cam.desc, c.clone()));
                c
            }
        };
        eye.set_coverage(coverage);
        eye
    }

    /// A render's forward photon tracer: it records nothing (sensors are left out, and
    /// cameras do not see them: they are not in `accel`).
    fn render_tracer(&self, max_events: u32) -> Tracer<'_> {
        let prepared = self.prepared.as_ref().expect("prepared before a render");
        prepared.tracer(&self.scene, &self.config, max_events, None, None)
    }

    /// What a render by `method` of the prepared scene cannot show (`RenderReport::omitted`):
    /// told from the scene's lights and materials, so "may be missing where the geometry
    /// lets such light through".
    fn omissions(&self, method: RenderMethod) -> u32 {
        let prepared = &self.prepared.as_ref().expect("prepared").scene;
        let point_like = |e: &crate::scene::Emitter| e.extent() == Extent::PointLike;
        if !prepared.emitters.iter().any(point_like) {
            return 0;
        }
        // A surface that bends light: a smooth or rough dielectric whose index is not 1.
        let refracts = |m: &crate::scene::Material| {
            m.dielectric
                .as_ref()
                .is_some_and(|d| d.ior.iter().any(|&n| n != 1.0))
        };
        // Whether some mesh has a material that `is`.
        let any = |is: &dyn Fn(&crate::scene::Material) -> bool| {
            self.scene
                .meshes
                .iter()
                .any(|m| self.mesh_material(m, is).is_some())
        };
        let mut omitted = 0;
        // A scattering medium that a point-like light outside it reaches only through its
        // refracting boundary; the scene's haze, through any refracting surface.
        let into_mesh = self.scene.meshes.iter().enumerate().any(|(i, mesh)| {
            self.mesh_material(mesh, |m| m.scatters() && refracts(m))
                .is_some()
                && prepared
                    .emitters
                    .iter()
                    .any(|e| point_like(e) && !e.media.iter().any(|&(held, _)| held as usize == i))
        });
        let into_haze = self
            .scene
            .medium
            .is_some_and(|h| self.scene.materials[h as usize].scatters())
            && any(&refracts);
        if into_mesh || into_haze {
            omitted |= render::OMITS_REFRACTED_INTO_MEDIUM;
        }
        if method != RenderMethod::FinalGather
            && any(&|m| m.bsdf().is_specular())
            && any(&|m| m.bsdf().is_glossy())
        {
            omitted |= render::OMITS_CAUSTICS_ON_GLOSSY;
        }
        omitted
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
        if params.method == RenderMethod::FinalGather {
            return self.render_gather(camera, params);
        }
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
        let eye = self.eye_tracer(&cam, params.max_path_events, params.initial_radius);
        let fwd = self.render_tracer(params.max_path_events);
        let (image, mut report, lost) =
            render::render(&eye, fwd, params, threads, self.config.seed);
        report.omitted = self.omissions(params.method);
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

impl Context {
    /// `RenderMethod::FinalGather` (`render::gather::driver`): sizes and budgets the
    /// render, then drives it over this context's map.
    fn render_gather(
        &mut self,
        camera: &CameraDesc,
        params: &mut RenderParams,
    ) -> Result<(Image, RenderReport, Option<Error>)> {
        let origin = self.prepared.as_ref().expect("prepared").scene.origin;
        let cam = Camera::new(camera, origin)?;
        let threads = self.worker_threads().max(1);
        let nb = self.scene.bands.count();
        let pixels = cam.pixels();
        let slots: usize = self
            .scene
            .meshes
            .iter()
            .filter(|m| m.record)
            .map(|m| m.positions.len() * if m.two_sided { 2 } else { 1 })
            .sum();
        // Caustics of point-like lights and of the sun (a disk of 0.53°, which eye paths
        // through specular surfaces almost never find): only where there are both.
        let delta: Vec<bool> = {
            let prepared = &self.prepared.as_ref().expect("prepared").scene;
            prepared
                .emitters
                .iter()
                .map(|e| e.extent() == Extent::PointLike)
                .collect()
        };
        // (The materials meshes use: the scene's medium is a dielectric too, and light
        // scattered in it is the eye paths'.)
        let specular = self.scene.meshes.iter().any(|m| {
            self.mesh_material(m, |mat| mat.bsdf().is_specular())
                .is_some()
        });
        let with_caustics = specular && delta.iter().any(|&d| d);
        let read_bytes = (slots * (nb + 1) * 8) as u64;
        let caustic_bytes = if with_caustics {
            Caustics::bytes(pixels, nb) as u64
        } else {
            0
        };
        let store_bytes = GatherStore::bytes(pixels, nb) as u64;
        self.check_budget(
            self.memory_estimate(),
            store_bytes + read_bytes + caustic_bytes,
            &format!(
                "the render (final gathering, {pixels} pixels × {nb} bands, the map's {slots} vertex sides read)"
            ),
        )?;
        let job = driver::Job {
            cam,
            width: camera.width,
            height: camera.height,
            threads,
            bands: nb,
            slots,
            delta,
            with_caustics,
            read_bytes,
            store_bytes,
            caustic_bytes,
            seed: self.config.seed,
        };
        let before = Untouched::of(self);
        let mut host = Host {
            ctx: self,
            before: Some(before),
        };
        let (image, mut report, lost) = driver::render(&mut host, &job, params)?;
        report.omitted = self.omissions(params.method);
        self.last_render = Some(report.clone());
        Ok((image, report, lost))
    }
}

/// The context as final gathering's host (`driver::GatherHost`).
struct Host<'c> {
    ctx: &'c mut Context,
    /// What to put back should the render trace no photon (taken when put back).
    before: Option<Untouched>,
}

impl driver::GatherHost for Host<'_> {
    fn photons(&self) -> u64 {
        self.ctx.photons()
    }

    fn map_elapsed_s(&self) -> f64 {
        self.ctx.elapsed_s
    }

    fn map_sequential(&self) -> bool {
        match self.ctx.traced.ranges() {
            [] => true,
            [r] => r.start == 0,
            _ => false,
        }
    }

    fn run_map(&mut self, params: &mut RunParams) -> Result<()> {
        self.ctx.run(params).map(|_| ())
    }

    fn map_indirect(&self) -> Result<MapIndirect> {
        self.ctx.map_indirect()
    }

    fn eye_tracer<'a>(&'a self, cam: &'a Camera, max_events: u32) -> EyeTracer<'a> {
        self.ctx.eye_tracer(cam, max_events, 0.0)
    }

    fn forward_tracer(&self, max_events: u32) -> Tracer<'_> {
        self.ctx.render_tracer(max_events)
    }

    fn put_back(&mut self) {
        if let Some(before) = self.before.take() {
            before.restore(self.ctx);
        }
    }
}

/// What a final-gathering render may change of an empty map's context (its runs add time,
/// history and tallies), to put back when it fails or traces no photon.
struct Untouched {
    empty: bool,
    elapsed_s: f64,
    history: Vec<Progress>,
    stats: crate::transport::PathStats,
    last_run: Option<super::LastRun>,
}

impl Untouched {
    fn of(c: &Context) -> Self {
        let empty = c.photons() == 0;
        Untouched {
            empty,
            elapsed_s: c.elapsed_s,
            // Only an empty map's context is put back: its history is short.
            history: if empty { c.history.clone() } else { Vec::new() },
            stats: if empty {
                c.stats.clone()
            } else {
                Default::default()
            },
            last_run: c.last_run.clone(),
        }
    }

    fn restore(self, c: &mut Context) {
        if self.empty && c.photons() == 0 {
            c.elapsed_s = self.elapsed_s;
            c.history = self.history;
            c.stats = self.stats;
            c.last_run = self.last_run;
        }
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

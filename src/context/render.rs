//! The context's camera renders (the second system).

use super::Layer;
use super::{check_threads, Context};
use crate::error::{bail, check_finite_scalar, Error, ImapStatus, Result};
use crate::render::backward::{MapIndirect, MeshIndirect};
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
        self.trace_pixels(camera, samples, max_events, false)
    }

    /// Renders the camera's view by final gathering from the illumination map (issue 18,
    /// experimental; Rust API only): path tracing as `path_trace`, ended at each path's
    /// second diffuse vertex on a recorded mesh, where the direct light is sampled and the
    /// rest of the light arriving there is the map's (combined minus direct layer,
    /// interpolated over the triangle). Needs a map with the direct layer
    /// (`LayerRequest::direct`) and photons in it; surfaces the map does not record are
    /// traced on. Each pixel's error adds the map's error of what it read (taken as fully
    /// correlated) to the samples' own.
    pub fn render_final_gather(
        &mut self,
        camera: &CameraDesc,
        samples: u32,
        max_events: u32,
    ) -> Result<Image> {
        self.trace_pixels(camera, samples, max_events, true)
    }

    /// The map's indirect irradiance per recorded vertex side, with its relative error.
    fn map_indirect(&self) -> Result<MapIndirect> {
        if !self.scene.layers.direct {
            bail!(
                ImapErrOutOfOrder,
                "final gathering reads the map's indirect light: keep the direct layer (set_layers with direct) and run the map first"
            );
        }
        if self.photons() == 0 {
            bail!(
                ImapErrOutOfOrder,
                "final gathering reads the illumination map: run it first"
            );
        }
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
                self.rel_error_layer(i as u32, s, Layer::Direct, &mut r_dir)?;
                let (mut m_all, mut m_dir) = (vec![0.0; nv], vec![0.0; nv]);
                for b in 0..nb {
                    self.irradiance(i as u32, s, b as u32, &mut all)?;
                    self.irradiance_layer(i as u32, s, b as u32, Layer::Direct, &mut dir)?;
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
        Ok(MapIndirect { meshes })
    }

    fn trace_pixels(
        &mut self,
        camera: &CameraDesc,
        samples: u32,
        max_events: u32,
        gather: bool,
    ) -> Result<Image> {
        if samples == 0 || max_events == 0 {
            bail!(
                ImapErrInvalidArgument,
                "samples = {samples}, max_events = {max_events}: both must be positive"
            );
        }
        self.prepare_scene()?;
        let map = if gather {
            Some(self.map_indirect()?)
        } else {
            None
        };
        let prepared = self.prepared.as_ref().expect("prepared above");
        let cam = Camera::new(camera, prepared.scene.origin)?;
        let mut eye = EyeTracer::new(
            &self.scene,
            &prepared.scene,
            &prepared.accel,
            &cam,
            max_events,
            0.0,
        );
        eye.map = map.as_ref();
        let nb = self.scene.bands.count();
        let pixels = cam.pixels();
        let threads = self.worker_threads().max(1);
        let seed = self.config.seed ^ 0x7A7E_5EED_0000_0001;
        // Each thread takes every `threads`-th pixel: (pixel, mean per band, rel. error).
        let parts: Vec<Vec<(usize, Vec<f64>, f64)>> = std::thread::scope(|sc| {
            let handles: Vec<_> = (0..threads)
                .map(|t| {
                    let eye = &eye;
                    sc.spawn(move || {
                        let mut got = Vec::new();
                        let (mut beta, mut scratch) = (Vec::new(), Vec::new());
                        let mut stats = crate::render::backward::EyeStats::default();
                        let mut one = vec![0.0; nb];
                        for p in (t..pixels).step_by(threads) {
                            let mut sum = vec![0.0; nb];
                            let (mut s1, mut s2, mut map_err) = (0.0, 0.0, 0.0);
                            for s in 0..samples {
                                let mut rng = crate::sampling::PhotonRng::new(
                                    seed,
                                    ((p as u64) << 32) | s as u64,
                                );
                                one.fill(0.0);
                                eye.path_sample(
                                    p as u32,
                                    &mut rng,
                                    &mut one,
                                    &mut beta,
                                    &mut scratch,
                                    &mut map_err,
                                    &mut stats,
                                );
                                let m = one.iter().sum::<f64>() / nb as f64;
                                s1 += m;
                                s2 += m * m;
                                sum.iter_mut().zip(&one).for_each(|(a, x)| *a += x);
                            }
                            let n = samples as f64;
                            let mean = s1 / n;
                            let var = ((s2 / n - mean * mean).max(0.0)) / (n - 1.0).max(1.0);
                            let sigma = var.sqrt().hypot(map_err / n);
                            let rel = if mean > 0.0 { sigma / mean } else { 0.0 };
                            got.push((p, sum.iter().map(|x| x / n).collect(), rel));
                        }
                        got
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_default())
                .collect()
        });
        let mut radiance = vec![0.0; pixels * nb];
        let mut rel_error = vec![0.0; pixels];
        let mut done = 0;
        for (p, v, r) in parts.into_iter().flatten() {
            radiance[p * nb..(p + 1) * nb].copy_from_slice(&v);
            rel_error[p] = r;
            done += 1;
        }
        if done != pixels {
            bail!(
                ImapErrThreadLost,
                "a path-tracing thread was lost: {done} of {pixels} pixels rendered"
            );
        }
        Ok(Image {
            width: camera.width,
            height: camera.height,
            bands: nb,
            radiance,
            rel_error,
        })
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

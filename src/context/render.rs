//! The context's camera renders (the second system).

use super::Layer;
use super::{check_threads, Context};
use crate::error::{bail, check_finite_scalar, Error, ImapStatus, Result};
use crate::progress::{duration_s, Progress, StopReason};
use crate::render::backward::{MapIndirect, MeshIndirect};
use crate::render::gather::{self, Batch, Caustics, GatherError, GatherStore, Schedule};
use crate::render::{
    self, Camera, CameraDesc, EyeStats, EyeTracer, Image, RenderMethod, RenderMonitor,
    RenderParams, RenderReport,
};
use crate::scene::Extent;
use crate::sched::RunParams;
use crate::transport::Tracer;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

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
        self.trace_pixels(camera, samples, max_events)
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
        EyeTracer::new(
            &self.scene,
            &prepared.scene,
            &prepared.accel,
            cam,
            max_events,
            initial_radius,
        )
    }

    /// A render's forward photon tracer: it records nothing (sensors are left out, and
    /// cameras do not see them: they are not in `accel`).
    fn render_tracer(&self, max_events: u32) -> Tracer<'_> {
        let prepared = self.prepared.as_ref().expect("prepared before a render");
        Tracer {
            scene: &prepared.scene,
            accel: &prepared.accel,
            sensors: None,
            materials: &self.scene.materials,
            bands: self.scene.bands.count(),
            seed: self.config.seed,
            unit_m: self.config.unit_m,
            max_events,
            direct: None,
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

/// Shortest and longest slice of a final-gathering render between decisions, s.
const SLICE_MIN_S: f64 = 0.05;
const SLICE_MAX_S: f64 = 4.0;
/// Each part of a final-gathering render (eye paths, caustics) keeps at least this share
/// of its time, whatever their errors say (a part whose error is 0 so far, or a scene where
/// one part has nothing to do, must not stall the others).
const MIN_SHARE: f64 = 0.1;
/// A final-gathering render's slices grow with it: this share of the time so far.
const SLICE_SHARE: f64 = 0.25;
/// The first map slice of a render that finds the map empty (at most a tenth of a time
/// budget), s.
const FIRST_MAP_S: f64 = 0.5;
/// Photons a render that finds the map empty traces before anything else, whatever its
/// time budget: final gathering reads the map, so the shortest budget still gets one
/// (and the same status every time).
pub const FIRST_MAP_PHOTONS: u64 = 1 << 12;

/// A final-gathering render's progress point.
fn gather_point(start: Instant, err: &GatherError, photons: u64, paths: u64) -> Progress {
    Progress {
        region_rel_error: 0.0,
        elapsed_s: start.elapsed().as_secs_f64(),
        photons,
        hits: paths,
        rel_error: err.rel_error,
    }
}

/// What a final-gathering render does next.
enum GatherStep {
    /// Run the map: this many photons (0: for `secs` seconds).
    Map { photons: u64, secs: f64 },
    /// Trace this many caustic rounds.
    Caustic(u64),
    /// A batch of eye passes.
    Eye,
    /// The first photons of an empty map (`FIRST_MAP_PHOTONS`), whatever the time.
    FirstMap,
}

impl Context {
    /// `RenderMethod::FinalGather`: eye passes alternated with runs of the context's map
    /// (which the render extends) and, when the scene has point-like lights and specular
    /// surfaces, rounds of caustic photons, until a stop criterion.
    fn render_gather(
        &mut self,
        camera: &CameraDesc,
        params: &mut RenderParams,
    ) -> Result<(Image, RenderReport, Option<Error>)> {
        let start = Instant::now();
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
        let specular = self.scene.materials.iter().any(|m| m.bsdf().is_specular());
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
        let records = slots > 0;
        let fixed = params.forward_per_pass;
        let max_events = params.max_path_events;
        let store = GatherStore::new(pixels, nb, threads);
        let caustics = with_caustics.then(|| Mutex::new(Caustics::new(pixels, nb)));
        let seed = self.config.seed;
        let end = (params.time_budget_s > 0.0)
            .then(|| crate::progress::deadline(start, params.time_budget_s))
            .flatten();
        let photons_before = self.photons();
        let before_render = Untouched::of(self);
        let mut mon = RenderMonitor::new(params, start);
        let interval = mon.interval();
        let mut map: Option<MapIndirect> = None;
        // The render extends a map that is empty or holds photons 0..N: one that holds a
        // shard's or a range's photons is read as it is (continuing it with every photon
        // would take other shards' indices and count them twice in a merge).
        let sequential = match self.traced.ranges() {
            [] => true,
            [r] => r.start == 0,
            _ => false,
        };
        let mut map_frozen = !records || !sequential;
        let (mut t_eye, mut t_map, mut t_read, mut t_caustic) = (0.0f64, 0.0, 0.0, 0.0f64);
        let mut stats = EyeStats::default();
        let mut err = GatherError {
            rel_error: crate::imap::NO_DATA_REL_ERROR,
            ..Default::default()
        };
        let mut lost: Option<Error> = None;
        let mut batches = 0u64;
        let mut schedule = Schedule::default();
        let stop_flag = AtomicBool::new(false);
        // Caustic rounds traced whole, and the next round's index.
        let (mut done_rounds, mut next_round) = (0u64, 0u64);
        loop {
            let now = start.elapsed().as_secs_f64();
            let left = end.map(|e| e.saturating_duration_since(Instant::now()).as_secs_f64());
            if left.is_some_and(|l| l <= 0.0) {
                mon.stop = mon.stop.or(Some(StopReason::TimeBudget));
            }
            // An empty map gets its first photons even when the time is up: the shortest
            // budget leaves the context as every other does, with a map.
            let first = !map_frozen && self.photons() == 0;
            if mon.stop.is_some() && !(first && mon.stop == Some(StopReason::TimeBudget)) {
                break;
            }
            let slice = (SLICE_SHARE * now)
                .clamp(SLICE_MIN_S, SLICE_MAX_S)
                .min(left.unwrap_or(f64::MAX));
            let pass = err.min_samples as u64;
            let passes_done = mon.params.passes > 0 && pass >= mon.params.passes;
            if fixed > 0 && passes_done {
                mon.stop = Some(StopReason::PhotonCount);
                break;
            }
            let step = if first {
                GatherStep::FirstMap
            } else if fixed > 0 {
                // Before pass k (from 0) the map holds at least (k + 1) · fixed photons and
                // the caustics have k + 1 rounds.
                let want = (pass + 1).saturating_mul(fixed);
                let have = self.photons();
                if !map_frozen && have < want {
                    GatherStep::Map {
                        photons: want - have,
                        secs: 0.0,
                    }
                } else if with_caustics && done_rounds < pass + 1 {
                    GatherStep::Caustic(pass + 1 - done_rounds)
                } else {
                    GatherStep::Eye
                }
            } else if !map_frozen && self.photons() == FIRST_MAP_PHOTONS && photons_before == 0 {
                GatherStep::Map {
                    photons: 0,
                    secs: first_map_s(mon.params.time_budget_s).min(left.unwrap_or(f64::MAX)),
                }
            } else if with_caustics && done_rounds < 2 {
                GatherStep::Caustic(threads.max(2) as u64)
            } else if batches == 0 {
                GatherStep::Eye
            } else if passes_done {
                // Every pixel has its passes: the caustics at least one round per pass.
                if with_caustics && done_rounds < pass {
                    GatherStep::Caustic(pass - done_rounds)
                } else {
                    GatherStep::Eye
                }
            } else if t_eye < MIN_SHARE * now {
                GatherStep::Eye
            } else if with_caustics && t_caustic < MIN_SHARE * now {
                GatherStep::Caustic(threads as u64)
            } else {
                // Each part's error² falls as 1/(its time): the next slice goes where it
                // buys the most, the largest error² per second spent so far.
                let eye = err.eye_var / t_eye.max(1e-3);
                let photons = self.photons().max(1) as f64;
                let map_rate = if map_frozen {
                    0.0
                } else {
                    err.map_per_photon / photons / self.elapsed_s.max(1e-3)
                };
                let caustic = if with_caustics {
                    err.caustic_var / t_caustic.max(1e-3)
                } else {
                    0.0
                };
                if map_rate > eye && map_rate >= caustic {
                    GatherStep::Map {
                        photons: 0,
                        secs: slice,
                    }
                } else if caustic > eye {
                    let per_round = t_caustic / done_rounds.max(1) as f64 * threads as f64;
                    let n = (slice * threads as f64 / per_round.max(1e-6)) as u64;
                    GatherStep::Caustic(n.clamp(threads as u64, 1 << 20))
                } else {
                    GatherStep::Eye
                }
            };
            if passes_done && matches!(step, GatherStep::Eye) {
                // Every pixel has its passes, and the map and the caustics have their
                // shares of the time.
                mon.stop = Some(StopReason::PhotonCount);
                break;
            }
            match step {
                GatherStep::FirstMap => {
                    let t0 = Instant::now();
                    let paths = stats.paths;
                    // Only a cancel from the caller's callback stops these photons.
                    let mut cancel = |p: &Progress| {
                        !(mon.due()
                            && mon.tick(
                                gather_point(start, &err, p.photons, paths),
                                false,
                                Duration::ZERO,
                            ))
                    };
                    let r = self.run(&mut RunParams {
                        photons: FIRST_MAP_PHOTONS,
                        progress_interval_s: 0.05,
                        max_path_events: max_events,
                        progress: Some(&mut cancel),
                        ..Default::default()
                    });
                    t_map += t0.elapsed().as_secs_f64();
                    match r {
                        Err(e) if e.status == ImapStatus::ImapErrThreadLost => {
                            lost = Some(e);
                            break;
                        }
                        Err(e) => {
                            before_render.restore(self);
                            return Err(e);
                        }
                        Ok(_) => {}
                    }
                    if self.photons() == 0 {
                        // Cancelled before a photon was whole: nothing to gather from.
                        mon.stop = mon.stop.or(Some(StopReason::Cancelled));
                        break;
                    }
                    map = None;
                    continue;
                }
                GatherStep::Map { photons, secs } => {
                    let t0 = Instant::now();
                    let before = self.photons();
                    let until = end;
                    let paths = stats.paths;
                    // The map's progress points carry on the render's: its callback (which
                    // may cancel) and its time budget still rule during a slice.
                    let mut in_time = |p: &Progress| {
                        if until.is_some_and(|e| Instant::now() >= e) {
                            return false;
                        }
                        !(mon.due()
                            && mon.tick(
                                gather_point(start, &err, p.photons, paths),
                                err.min_samples >= 2,
                                Duration::ZERO,
                            ))
                    };
                    let r = self.run(&mut RunParams {
                        photons,
                        time_budget_s: if photons > 0 {
                            left.unwrap_or(0.0)
                        } else {
                            secs
                        },
                        progress_interval_s: 0.05,
                        max_path_events: max_events,
                        progress: Some(&mut in_time),
                        ..Default::default()
                    });
                    t_map += t0.elapsed().as_secs_f64();
                    match r {
                        Ok(_) => {}
                        Err(e) if e.status == ImapStatus::ImapErrThreadLost => {
                            lost = Some(e);
                            break;
                        }
                        Err(e) if self.photons() == 0 => {
                            before_render.restore(self);
                            return Err(e);
                        }
                        // The map cannot grow (its photon selection is spent, a budget): the
                        // render goes on with the map as it is.
                        Err(_) => map_frozen = true,
                    }
                    if self.photons() == before {
                        map_frozen = true;
                    }
                    map = None;
                    continue;
                }
                GatherStep::Caustic(n) => {
                    let eye = self.eye_tracer(&cam, max_events, 0.0);
                    let fwd = self.render_tracer(max_events);
                    let t0 = Instant::now();
                    stop_flag.store(false, Ordering::Relaxed);
                    let c = caustics.as_ref().expect("with caustics");
                    let (whole, gone) = gather::caustic_rounds(
                        &eye, &fwd, &delta, c, next_round, n, threads, &stop_flag,
                    );
                    done_rounds += whole;
                    next_round += n;
                    t_caustic += t0.elapsed().as_secs_f64();
                    if let Some(why) = gone {
                        lost = Some(thread_lost(why));
                        break;
                    }
                    err = store.estimate(&schedule, caustics.as_ref(), None);
                    self.gather_tick(&mut mon, &err, stats.paths);
                    continue;
                }
                GatherStep::Eye => {}
            }
            if map.is_none() && records {
                let t0 = Instant::now();
                map = Some(self.map_indirect()?);
                t_read += t0.elapsed().as_secs_f64();
            }
            // A batch of eye passes.
            let mut eye = self.eye_tracer(&cam, max_events, 0.0);
            eye.map = map.as_ref();
            // The sun through specular surfaces: the caustic rounds bring it.
            eye.sun_by_caustics = with_caustics;
            let up_to = if fixed > 0 {
                err.min_samples.saturating_add(1)
            } else {
                match mon.params.passes {
                    0 => u32::MAX,
                    p => u32::try_from(p).unwrap_or(u32::MAX),
                }
            };
            let batch_end = if fixed > 0 {
                end
            } else {
                Instant::now()
                    .checked_add(duration_s(slice))
                    .map(|b| end.map_or(b, |e| e.min(b)))
            };
            stop_flag.store(false, Ordering::Relaxed);
            let batch = Batch {
                up_to,
                deadline: batch_end,
                stop: &stop_flag,
                map_photons: if records { self.photons() } else { 0 },
            };
            let photons_now = batch.map_photons;
            let samples_before = store.samples();
            let t0 = Instant::now();
            let (tally, gone) =
                gather::passes(&eye, &store, seed, threads, &batch, interval, &mut || {
                    if !mon.due() {
                        return false;
                    }
                    let t1 = Instant::now();
                    let mut now = schedule.clone();
                    now.add(photons_now, store.samples() - samples_before);
                    let e = store.estimate(&now, caustics.as_ref(), None);
                    let p = gather_point(start, &e, photons_now, e.samples);
                    mon.tick(p, e.min_samples >= 2, t1.elapsed())
                });
            t_eye += t0.elapsed().as_secs_f64();
            batches += 1;
            stats.paths += tally.stats.paths;
            stats.rays += tally.stats.rays;
            stats.dropped += tally.stats.dropped;
            if let Some(why) = gone {
                lost = Some(thread_lost(why));
                break;
            }
            schedule.add(photons_now, store.samples() - samples_before);
            err = store.estimate(&schedule, caustics.as_ref(), None);
            self.gather_tick(&mut mon, &err, stats.paths);
            if tally.stats.paths == 0 && map_frozen && mon.stop.is_none() && !tally.cut {
                // Nothing left to do (cannot happen with a criterion set): stop.
                mon.stop = Some(StopReason::PhotonCount);
            }
        }
        if self.photons() == 0 {
            // No photon was traced: the map's run time and history stay as they were.
            before_render.restore(self);
        }
        let wall_s = start.elapsed().as_secs_f64();
        let mut image = Image::new(camera.width, camera.height, nb);
        let err = store.estimate(&schedule, caustics.as_ref(), Some(&mut image));
        let last = Progress {
            region_rel_error: 0.0,
            elapsed_s: wall_s,
            photons: self.photons(),
            hits: stats.paths,
            rel_error: err.rel_error,
        };
        mon.finish(last);
        let report = RenderReport {
            threads,
            groups: 1,
            threads_per_group: threads,
            phases: batches,
            passes: err.samples as f64 / pixels as f64,
            backward_paths: stats.paths,
            backward_rays: stats.rays,
            forward_photons: self.photons() - photons_before,
            gathers: done_rounds * gather::CAUSTIC_ROUND,
            wall_s,
            stop: Some(mon.stop.unwrap_or(StopReason::PhotonCount)),
            rel_error: err.rel_error,
            time_backward_s: t_eye,
            time_build_s: t_read,
            time_forward_s: t_map,
            time_close_s: t_caustic,
            dropped_paths: stats.dropped,
            map_bytes_per_group: read_bytes,
            pixel_bytes: store_bytes + caustic_bytes,
            total_bytes: read_bytes + store_bytes + caustic_bytes,
            history: mon.history,
            ..Default::default()
        };
        self.last_render = Some(report.clone());
        Ok((image, report, lost))
    }

    /// After a step of a final-gathering render: the stop criteria, and a progress point
    /// when one is due.
    fn gather_tick(&self, mon: &mut RenderMonitor, err: &GatherError, paths: u64) {
        let settled = err.min_samples >= 2;
        let why = mon.criteria(err.rel_error, settled, mon.start.elapsed().as_secs_f64());
        mon.stop = mon.stop.or(why);
        if mon.stop.is_none() && mon.due() {
            let p = gather_point(mon.start, err, self.photons(), paths);
            mon.tick(p, settled, Duration::ZERO);
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
    last_run: Option<(u64, u64, f64, StopReason, crate::sched::Counters, usize)>,
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
            last_run: c.last_run,
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

fn thread_lost(why: String) -> Error {
    Error::new(
        ImapStatus::ImapErrThreadLost,
        format!("{why}; the render was stopped and its image holds what was rendered until then"),
    )
}

/// The first map slice of a render that finds the map empty, s.
fn first_map_s(time_budget_s: f64) -> f64 {
    if time_budget_s > 0.0 {
        FIRST_MAP_S.min(0.1 * time_budget_s)
    } else {
        FIRST_MAP_S
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

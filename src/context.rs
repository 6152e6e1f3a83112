//! The safe Rust API: a context owns a scene, its prepared form, the map and the run
//! history. The C ABI in `ffi/` is a thin layer over this.

use crate::accel::{Accel, Device};
use crate::error::{bail, check_finite, Error, ImapStatus, Result};
use crate::imap::{IMap, Readout};
use crate::render::{self, Camera, CameraDesc, EyeTracer, Image, RenderParams, RenderReport};
use crate::scene::{Bands, Light, Material, MaterialDesc, Mesh, MeshDesc, PreparedScene, Scene};
use crate::sched::dynamic::DynamicParams;
use crate::sched::{self, Counters, Progress, RunContext, RunParams, StopReason};
use crate::transport::{PathStats, Tracer};

/// Which scheduler runs the photons.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SchedulerKind {
    /// Calculating threads, one accumulating thread (the paper's baseline).
    Classic,
    /// Vertex groups with one processing thread each, split under load (the paper's method).
    Dynamic,
    /// Benchmark limit: the same photons traced with every deposit discarded; the map and
    /// the photon count stay as they were (the run is not accumulated).
    TraceOnly,
}

/// Context settings fixed at creation.
#[derive(Clone, Debug)]
pub struct Config {
    pub bands: Bands,
    /// Calculating threads; 0 means one per available core.
    pub threads: usize,
    pub seed: u64,
    pub scheduler: SchedulerKind,
    /// Settings of the dynamic scheduler.
    pub dynamic: DynamicParams,
    /// Largest map, in bytes, the context may allocate; 0 for the default: three quarters
    /// of the machine's physical memory (so a map that cannot fit is refused with
    /// IMAP_ERR_MEMORY_BUDGET instead of driving the machine into swap or the OOM killer).
    pub memory_budget: u64,
    /// Metres per scene unit.
    pub unit_m: f64,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            bands: Bands::rgb(),
            threads: 0,
            seed: 0,
            scheduler: SchedulerKind::Dynamic,
            dynamic: DynamicParams::default(),
            memory_budget: 0,
            unit_m: 1.0,
        }
    }
}

/// Totals since the map was last reset, and the last run's own figures.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    pub photons: u64,
    pub hits: u64,
    pub elapsed_s: f64,
    pub rel_error: f64,
    pub run_photons: u64,
    pub run_hits: u64,
    pub run_wall_s: f64,
    pub stop: Option<StopReason>,
    pub threads: usize,
    pub scheduler: SchedulerKind,
    /// Energy balance in watts: emitted = absorbed + escaped + dropped (up to rounding).
    /// `emitted_w` is what the traced photons carried; its expectation is the lights' total
    /// power (equal to it exactly with a single light).
    pub emitted_w: f64,
    pub absorbed_w: f64,
    pub escaped_w: f64,
    pub dropped_w: f64,
    pub dropped_photons: u64,
    pub counters: Counters,
    pub map_bytes: u64,
}

struct Prepared {
    scene: PreparedScene,
    accel: Accel,
}

fn check_threads(threads: usize) -> Result<()> {
    if threads > 4096 {
        bail!(
            ImapErrInvalidArgument,
            "threads = {threads} is more than 4096"
        );
    }
    Ok(())
}

/// An illumination-map context.
pub struct Context {
    config: Config,
    device: Device,
    scene: Scene,
    prepared: Option<Prepared>,
    map: Option<IMap>,
    stats: PathStats,
    elapsed_s: f64,
    history: Vec<Progress>,
    last_run: Option<(u64, u64, f64, StopReason, Counters, usize)>,
    /// The last render's report (with its accuracy history); `None` before the first.
    last_render: Option<RenderReport>,
}

impl Context {
    pub fn new(config: Config) -> Result<Self> {
        check_finite("unit_m", &[config.unit_m])?;
        if config.unit_m <= 0.0 {
            bail!(
                ImapErrInvalidArgument,
                "unit_m = {} must be positive (metres per scene unit)",
                config.unit_m
            );
        }
        config.dynamic.validate()?;
        check_threads(config.threads)?;
        let device = Device::new()?;
        let scene = Scene::new(config.bands.clone(), config.unit_m);
        Ok(Context {
            config,
            device,
            scene,
            prepared: None,
            map: None,
            stats: PathStats::default(),
            elapsed_s: 0.0,
            history: Vec::new(),
            last_run: None,
            last_render: None,
        })
    }

    pub fn config(&self) -> &Config {
        &self.config
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Changes the scheduler (and its settings) for the next runs. Any scheduler continues
    /// the same map: the photons, and so the result, do not depend on it.
    pub fn set_scheduler(
        &mut self,
        scheduler: SchedulerKind,
        dynamic: DynamicParams,
    ) -> Result<()> {
        dynamic.validate()?;
        self.config.scheduler = scheduler;
        self.config.dynamic = dynamic;
        Ok(())
    }

    /// Changes the number of calculating threads for the next runs (0 = one per core).
    pub fn set_threads(&mut self, threads: usize) -> Result<()> {
        check_threads(threads)?;
        self.config.threads = threads;
        Ok(())
    }

    /// Embree's version (major·10000 + minor·100 + patch).
    pub fn embree_version(&self) -> i64 {
        self.device.version()
    }

    fn photons(&self) -> u64 {
        self.stats.photons
    }

    fn check_unlocked(&self, what: &str) -> Result<()> {
        if self.photons() > 0 {
            bail!(
                ImapErrOutOfOrder,
                "cannot {what} after photons were traced into the map: call imap_reset first"
            );
        }
        Ok(())
    }

    /// The map size limit in force: the configured budget, or by default three quarters of
    /// physical memory.
    pub fn memory_budget(&self) -> u64 {
        if self.config.memory_budget > 0 {
            return self.config.memory_budget;
        }
        physical_memory().map_or(u64::MAX, |m| m / 4 * 3)
    }

    fn check_budget(&self, slots: usize) -> Result<()> {
        let bytes = self.scene.map_bytes(slots);
        let budget = self.memory_budget();
        if bytes > budget as u128 {
            let why = if self.config.memory_budget > 0 {
                "the configured memory budget"
            } else {
                "the default budget, 3/4 of physical memory"
            };
            bail!(
                ImapErrMemoryBudget,
                "the map needs {bytes} bytes ({slots} vertex sides × ({} bands + 1) × 8 bytes), over {why} of {budget} bytes",
                self.scene.bands.count(),
            );
        }
        Ok(())
    }

    pub fn add_material(&mut self, desc: &MaterialDesc) -> Result<u32> {
        let m = Material::new(desc, &self.scene.bands)?;
        self.scene.materials.push(m);
        Ok(self.scene.materials.len() as u32 - 1)
    }

    pub fn add_mesh(&mut self, desc: &MeshDesc) -> Result<u32> {
        self.check_unlocked("add a mesh")?;
        // The map's size follows from the counts alone: refuse before copying anything.
        self.check_budget(self.scene.slot_count() + desc.map_slots())?;
        let mesh = Mesh::new(desc, self.scene.materials.len(), &self.scene.bands)?;
        self.scene.meshes.push(mesh);
        self.invalidate();
        Ok(self.scene.meshes.len() as u32 - 1)
    }

    pub fn add_light(&mut self, light: Light) -> Result<u32> {
        self.check_unlocked("add a light")?;
        self.scene.lights.push(light);
        self.invalidate();
        Ok(self.scene.lights.len() as u32 - 1)
    }

    pub fn add_point_light(&mut self, position: [f64; 3], power: &[f64]) -> Result<u32> {
        let l = Light::point(position, power, &self.scene.bands)?;
        self.add_light(l)
    }

    pub fn add_spot_light(
        &mut self,
        position: [f64; 3],
        direction: [f64; 3],
        half_angle_rad: f64,
        power: &[f64],
    ) -> Result<u32> {
        let l = Light::spot(
            position,
            direction,
            half_angle_rad,
            power,
            &self.scene.bands,
        )?;
        self.add_light(l)
    }

    fn invalidate(&mut self) {
        self.prepared = None;
        self.map = None;
    }

    /// Clears the map, the totals and the history; the scene stays and may be changed again.
    pub fn reset(&mut self) {
        if let Some(m) = self.map.as_mut() {
            m.clear();
        }
        self.stats = PathStats::default();
        self.elapsed_s = 0.0;
        self.history.clear();
        self.last_run = None;
        self.last_render = None;
    }

    /// The prepared scene and its BVH (built on first use after a change).
    fn prepare_scene(&mut self) -> Result<()> {
        if self.scene.meshes.is_empty() {
            bail!(
                ImapErrNoGeometry,
                "the scene has no mesh: add one with imap_add_mesh before imap_run"
            );
        }
        if self.prepared.is_none() {
            if self.scene.lights.is_empty()
                && self.scene.meshes.iter().all(|m| m.exitance.is_none())
            {
                bail!(
                    ImapErrNoLight,
                    "the scene has no light: add a point or spot light or an emitting mesh"
                );
            }
            let scene = PreparedScene::new(&self.scene);
            if !(scene.total_power > 0.0 && scene.total_power.is_finite()) {
                bail!(
                    ImapErrNoLight,
                    "the lights' total power is {} W (emitting meshes with zero area emit nothing)",
                    scene.total_power
                );
            }
            let accel = Accel::build(&self.device, &scene.meshes)?;
            self.prepared = Some(Prepared { scene, accel });
        }
        Ok(())
    }

    fn prepare(&mut self) -> Result<()> {
        self.prepare_scene()?;
        if self.map.is_none() {
            let slots = self.scene.slot_count();
            self.check_budget(slots)?;
            self.map = Some(IMap::try_new(slots, self.scene.bands.count())?);
        }
        if self.stats.absorbed.len() != self.scene.meshes.len() {
            self.stats = PathStats::new(self.scene.meshes.len());
        }
        Ok(())
    }

    /// Traces photons into the map until a stop criterion of `params` is met. A later run
    /// continues the same photon sequence and accumulates into the same map.
    pub fn run(&mut self, params: &mut RunParams) -> Result<Report> {
        check_finite(
            "run parameters",
            &[
                params.time_budget_s,
                params.target_rel_error,
                params.progress_interval_s,
            ],
        )?;
        if params.time_budget_s < 0.0
            || params.target_rel_error < 0.0
            || params.progress_interval_s <= 0.0
        {
            bail!(
                ImapErrInvalidArgument,
                "time_budget_s and target_rel_error must be >= 0 and progress_interval_s > 0"
            );
        }
        if params.max_path_events == 0 {
            bail!(ImapErrInvalidArgument, "max_path_events must be at least 1");
        }
        if params.photons == 0
            && params.time_budget_s == 0.0
            && params.target_rel_error == 0.0
            && params.progress.is_none()
        {
            bail!(ImapErrInvalidArgument, "no stop criterion: set photons, time_budget_s, target_rel_error or a progress callback");
        }
        self.prepare()?;
        let threads = self.worker_threads();
        let prepared = self.prepared.as_ref().expect("prepared above");
        let map = self.map.as_mut().expect("allocated above");
        let rc = RunContext {
            tracer: Tracer {
                scene: &prepared.scene,
                accel: &prepared.accel,
                materials: &self.scene.materials,
                bands: self.scene.bands.count(),
                seed: self.config.seed,
                unit_m: self.config.unit_m,
                max_events: params.max_path_events,
            },
            scene: &prepared.scene,
            threads,
            unit_m: self.config.unit_m,
            first_photon: self.stats.photons,
            hits_before: self.stats.hits,
            elapsed_before_s: self.elapsed_s,
        };
        let outcome = match self.config.scheduler {
            SchedulerKind::Classic => sched::classic::run(&rc, map, params),
            SchedulerKind::Dynamic => sched::dynamic::run(&rc, map, params, &self.config.dynamic),
            SchedulerKind::TraceOnly => sched::trace_only::run(&rc, map, params),
        };
        self.last_run = Some((
            outcome.stats.photons,
            outcome.stats.hits,
            outcome.wall_s,
            outcome.stop,
            outcome.counters,
            threads,
        ));
        if self.config.scheduler == SchedulerKind::TraceOnly {
            // Nothing was accumulated: the totals and the history stay as they were.
            return Ok(self.report());
        }
        self.stats.merge(&outcome.stats);
        self.elapsed_s += outcome.wall_s;
        self.history.extend_from_slice(&outcome.history);
        if let Some(why) = outcome.thread_lost {
            bail!(
                ImapErrThreadLost,
                "{why}; the photons of its unfinished batch (at most {}) are missing from the map",
                sched::BATCH
            );
        }
        Ok(self.report())
    }

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

    /// Worker threads of a run or render: the configured count, or one per core.
    fn worker_threads(&self) -> usize {
        match self.config.threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            t => t,
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
        check_finite(
            "render parameters",
            &[
                params.time_budget_s,
                params.target_rel_error,
                params.progress_interval_s,
                params.initial_radius,
                params.alpha,
            ],
        )?;
        if params.time_budget_s < 0.0
            || params.target_rel_error < 0.0
            || params.progress_interval_s <= 0.0
            || params.initial_radius < 0.0
        {
            bail!(
                ImapErrInvalidArgument,
                "time_budget_s, target_rel_error and initial_radius must be >= 0 and progress_interval_s > 0"
            );
        }
        if !(params.alpha == 0.0 || (params.alpha > 0.0 && params.alpha < 1.0)) {
            bail!(
                ImapErrInvalidArgument,
                "alpha = {} must be in (0, 1) (or 0 for the default 2/3)",
                params.alpha
            );
        }
        if params.max_path_events == 0 {
            bail!(ImapErrInvalidArgument, "max_path_events must be at least 1");
        }
        check_threads(params.group_threads)?;
        if params.passes == 0
            && params.time_budget_s == 0.0
            && params.target_rel_error == 0.0
            && params.progress.is_none()
        {
            bail!(ImapErrInvalidArgument, "no stop criterion: set passes, time_budget_s, target_rel_error or a progress callback");
        }
        self.prepare_scene()?;
        let prepared = self.prepared.as_ref().expect("prepared above");
        let cam = Camera::new(camera, prepared.scene.origin)?;
        let threads = self.worker_threads();
        let nb = self.scene.bands.count();
        let pixels = cam.pixels();
        let need = render::bytes_needed(params.method, params.group_threads, threads, pixels, nb);
        let budget = self.memory_budget();
        if need > budget as u128 {
            bail!(
                ImapErrMemoryBudget,
                "the render ({:?}, {threads} threads) needs up to {need} bytes for {pixels} pixels × {nb} bands, over the memory budget of {budget} bytes",
                params.method
            );
        }
        let eye = EyeTracer::new(
            &self.scene,
            &prepared.scene,
            &prepared.accel,
            &cam,
            params.max_path_events,
            params.initial_radius,
        );
        let fwd = Tracer {
            scene: &prepared.scene,
            accel: &prepared.accel,
            materials: &self.scene.materials,
            bands: nb,
            seed: self.config.seed,
            unit_m: self.config.unit_m,
            max_events: params.max_path_events,
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

    /// Totals since the last reset and the last run's figures.
    pub fn report(&self) -> Report {
        let n = self.photons();
        let total_power = self.prepared.as_ref().map_or(0.0, |p| p.scene.total_power);
        let w = if n > 0 { total_power / n as f64 } else { 0.0 };
        let (run_photons, run_hits, run_wall_s, stop, counters, threads) = self
            .last_run
            .unwrap_or((0, 0, 0.0, StopReason::PhotonCount, Counters::default(), 0));
        Report {
            photons: n,
            hits: self.stats.hits,
            elapsed_s: self.elapsed_s,
            rel_error: self
                .history
                .last()
                .map_or(crate::imap::NO_DATA_REL_ERROR, |p| p.rel_error),
            run_photons,
            run_hits,
            run_wall_s,
            stop: self.last_run.map(|_| stop),
            threads,
            scheduler: self.config.scheduler,
            emitted_w: self.stats.emitted * w,
            absorbed_w: self.stats.absorbed.iter().sum::<f64>() * w,
            escaped_w: self.stats.escaped * w,
            dropped_w: self.stats.dropped * w,
            dropped_photons: self.stats.dropped_photons,
            counters,
            map_bytes: self
                .map
                .as_ref()
                .map_or(0, |m| (m.slots() * (m.bands() + 1) * 8) as u64),
        }
    }

    /// The error-against-time history since the last reset.
    pub fn history(&self) -> &[Progress] {
        &self.history
    }

    /// Power absorbed by a mesh (at its surface or inside its medium), W.
    pub fn absorbed_w(&self, mesh: u32) -> Result<f64> {
        self.mesh_index(mesh)?;
        let n = self.photons();
        let total = self.prepared.as_ref().map_or(0.0, |p| p.scene.total_power);
        Ok(if n > 0 {
            self.stats
                .absorbed
                .get(mesh as usize)
                .copied()
                .unwrap_or(0.0)
                * total
                / n as f64
        } else {
            0.0
        })
    }

    fn mesh_index(&self, mesh: u32) -> Result<usize> {
        if mesh as usize >= self.scene.meshes.len() {
            bail!(
                ImapErrIndexOutOfRange,
                "mesh id {mesh} is out of range (the scene has {} meshes)",
                self.scene.meshes.len()
            );
        }
        Ok(mesh as usize)
    }

    /// Vertex count of a mesh.
    pub fn vertex_count(&self, mesh: u32) -> Result<usize> {
        Ok(self.scene.meshes[self.mesh_index(mesh)?].positions.len())
    }

    fn readout_args(
        &self,
        mesh: u32,
        side: u32,
        out_len: usize,
    ) -> Result<Option<(Readout<'_>, usize)>> {
        let i = self.mesh_index(mesh)?;
        let m = &self.scene.meshes[i];
        if !m.record {
            bail!(
                ImapErrNotRecorded,
                "mesh {mesh} does not record (it was added with record = 0)"
            );
        }
        if side as usize >= m.sides() {
            bail!(ImapErrIndexOutOfRange, "side {side} is out of range: mesh {mesh} is one-sided and records only side 0 (front)");
        }
        if out_len < m.positions.len() {
            bail!(
                ImapErrBufferTooSmall,
                "the output holds {out_len} values but mesh {mesh} has {} vertices",
                m.positions.len()
            );
        }
        Ok(match (&self.prepared, &self.map) {
            (Some(p), Some(map)) => Some((
                Readout {
                    map,
                    scene: &p.scene,
                    photons: self.photons(),
                    unit_m: self.config.unit_m,
                },
                i,
            )),
            _ => None,
        })
    }

    /// Irradiance in W/m² of `band` at each vertex of `mesh` on `side` (0 front, 1 back).
    /// All zeros before the first run.
    pub fn irradiance(&self, mesh: u32, side: u32, band: u32, out: &mut [f64]) -> Result<()> {
        if band as usize >= self.scene.bands.count() {
            bail!(
                ImapErrIndexOutOfRange,
                "band {band} is out of range (the context has {} bands)",
                self.scene.bands.count()
            );
        }
        match self.readout_args(mesh, side, out.len())? {
            Some((r, i)) => r.irradiance(&r.scene.meshes[i], side as usize, band as usize, out),
            None => out.iter_mut().for_each(|x| *x = 0.0),
        }
        Ok(())
    }

    /// Relative standard error of each vertex's irradiance (band mean); 1 where nothing has
    /// arrived yet or the vertex has no area.
    pub fn rel_error(&self, mesh: u32, side: u32, out: &mut [f64]) -> Result<()> {
        match self.readout_args(mesh, side, out.len())? {
            Some((r, i)) => r.rel_error(&r.scene.meshes[i], side as usize, out),
            None => out
                .iter_mut()
                .for_each(|x| *x = crate::imap::NO_DATA_REL_ERROR),
        }
        Ok(())
    }
}

/// Physical memory in bytes, if the system says.
fn physical_memory() -> Option<u64> {
    // SAFETY: sysconf only reads system configuration.
    let (pages, size) = unsafe {
        (
            libc::sysconf(libc::_SC_PHYS_PAGES),
            libc::sysconf(libc::_SC_PAGESIZE),
        )
    };
    (pages > 0 && size > 0).then(|| (pages as u64).saturating_mul(size as u64))
}

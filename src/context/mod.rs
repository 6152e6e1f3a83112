//! The safe Rust API: a context owns a scene, its prepared form, the map and the run
//! history. The C ABI in `ffi/` is a thin layer over this.

mod layers;
pub mod memory;
mod readout;
pub use layers::Layer;
pub use readout::{MeshInfo, RegionStats};
mod render;
mod sight;
pub use sight::Sight;
pub mod state;
mod straight;

use crate::accel::{Accel, Device};
use crate::error::{bail, check_finite_scalar, Error, ImapStatus, Result};
use crate::imap::regions::{RegionShared, RegionTally};
use crate::imap::{DirectCells, IMap, LayerLayout, MapLayout};
use crate::photometry::{gonio, BandPhotometry, PhotometricData, Spectrum};
use crate::progress::{push_history, Progress, StopReason};
use crate::render::RenderReport;
use crate::scene::light::{Distribution, LightDesc, Placement};
use crate::scene::light::{SkyDesc, SkyKind, SunDesc};
use crate::scene::{Light, Material, MaterialDesc, Mesh, MeshDesc, PreparedScene, Scene};
use crate::sched::dynamic::DynamicParams;
use crate::sched::{self, photons, Counters, RangeSet, RunContext, RunParams};
use crate::spectral::Bands;
use crate::transport::direct::{self as direct, DirectPlan, DirectSampler, Estimator};
use crate::transport::{
    PathStats, Tracer, BAND_ABSORBED, BAND_DROPPED, BAND_EMITTED, BAND_ESCAPED, BAND_FLUORESCED,
};

/// Most calculating threads a context accepts.
pub const MAX_THREADS: usize = 1024;
/// Range of `Config::unit_m`: nanometres to a million kilometres per scene unit.
pub const UNIT_M_RANGE: (f64, f64) = (1e-9, 1e9);

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
    /// Aim point-like lights outside the geometry's bounding sphere at it (exact; see
    /// `IMAP_CONFIG_NO_LIGHT_AIMING`). Default true.
    pub aim_lights: bool,
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
            aim_lights: true,
        }
    }
}

/// What a medium absorbed (`Context::medium_absorbed`): per band, W, and in lm, each with
/// its standard error.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MediumAbsorbed {
    pub band_w: Vec<crate::imap::stats::Estimate>,
    pub lm: crate::imap::stats::Estimate,
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
    /// Energy balance in watts: emitted + fluoresced = absorbed + escaped + dropped (up to
    /// rounding; fluoresced is 0 without fluorescent surfaces, and absorbed includes what
    /// they re-emitted).
    /// `emitted_w` is what the traced photons carried; its expectation is the lights' total
    /// power (equal to it exactly with a single light).
    pub emitted_w: f64,
    pub absorbed_w: f64,
    pub escaped_w: f64,
    pub dropped_w: f64,
    /// What fluorescent surfaces re-emitted, W (in longer-wavelength bands than they
    /// absorbed it in).
    pub fluoresced_w: f64,
    pub dropped_photons: u64,
    /// The same balance in lumens (the bands' luminous value).
    pub emitted_lm: f64,
    pub absorbed_lm: f64,
    pub escaped_lm: f64,
    pub dropped_lm: f64,
    pub fluoresced_lm: f64,
    /// The balance per band, W: emitted, absorbed, escaped, dropped, fluoresced
    /// (`IMAP_BALANCE_*` order).
    pub band_w: [Vec<f64>; 5],
    pub counters: Counters,
    pub map_bytes: u64,
}

/// What the last run did (`Report`'s run figures).
#[derive(Clone, Debug)]
struct LastRun {
    photons: u64,
    hits: u64,
    wall_s: f64,
    stop: StopReason,
    counters: Counters,
    threads: usize,
}

impl Default for LastRun {
    /// No run yet.
    fn default() -> Self {
        LastRun {
            photons: 0,
            hits: 0,
            wall_s: 0.0,
            stop: StopReason::PhotonCount,
            counters: Counters::default(),
            threads: 0,
        }
    }
}

struct Prepared {
    scene: PreparedScene,
    /// The map's layout for it.
    layout: MapLayout,
    accel: Accel,
    /// The sensor meshes' BVH, if any.
    sensors: Option<Accel>,
    /// What the light-sampling estimator needs of the scene (built on its first run).
    direct: Option<DirectPlan>,
    /// The emitting meshes' pixel shares for the last camera rendered
    /// (`render::coverage`), kept across the eye tracers of a render.
    coverage: std::sync::Mutex<
        Option<(
            crate::render::camera::CameraDesc,
            std::sync::Arc<crate::render::coverage::Coverage>,
        )>,
    >,
}

impl Prepared {
    /// The photon tracer over this scene (`sensors`: their BVH when the run records them;
    /// `direct`: the light-sampling passes it weighs its deposits against).
    fn tracer<'a>(
        &'a self,
        scene: &'a Scene,
        config: &Config,
        max_events: u32,
        sensors: Option<&'a Accel>,
        direct: Option<&'a DirectSampler<'a>>,
    ) -> Tracer<'a> {
        Tracer {
            scene: &self.scene,
            accel: &self.accel,
            sensors,
            materials: &scene.materials,
            bands: scene.bands.count(),
            seed: config.seed,
            unit_m: config.unit_m,
            max_events,
            direct,
        }
    }

    /// The light-sampling passes of `estimator` writing to `cells`; None for photons only
    /// (or before the plan is built).
    fn sampler<'a>(
        &'a self,
        scene: &'a Scene,
        config: &Config,
        estimator: Estimator,
        cells: &'a DirectCells<'a>,
        max_events: u32,
    ) -> Option<DirectSampler<'a>> {
        let (
            Estimator::LightSampling {
                samples,
                pass_photons,
                gather,
            },
            Some(plan),
        ) = (estimator, &self.direct)
        else {
            return None;
        };
        Some(DirectSampler {
            plan,
            scene: &self.scene,
            accel: &self.accel,
            acc: cells,
            seed: config.seed,
            samples,
            pass_photons,
            sensor_pass_photons: direct::sensor_pass_photons(
                pass_photons,
                samples,
                plan.lit,
                plan.chunks[1],
            ),
            unit_m: config.unit_m,
            materials: &scene.materials,
            gather,
            max_events,
        })
    }
}

fn check_threads(name: &str, threads: usize) -> Result<()> {
    if threads > MAX_THREADS {
        bail!(
            ImapErrInvalidArgument,
            "{name} = {threads} is more than {MAX_THREADS}"
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
    /// The photon indices whose contributions the map holds (whole photons only).
    traced: RangeSet,
    elapsed_s: f64,
    history: Vec<Progress>,
    last_run: Option<LastRun>,
    /// The last render's report (with its accuracy history); `None` before the first.
    last_render: Option<RenderReport>,
    /// Luminous efficacy and colour-matching weights of the bands.
    photometry: BandPhotometry,
    /// Photons' totals per region since the last reset (`imap::regions`).
    region_tally: RegionTally,
    /// The estimator of the map's photons (`pass_photons` 0 and `samples` 0: automatic).
    estimator: Estimator,
    /// The scene's running memory figures (`memory::Footprint`).
    footprint: memory::Footprint,
}

impl Context {
    pub fn new(config: Config) -> Result<Self> {
        check_finite_scalar("config.unit_m", config.unit_m)?;
        let (lo, hi) = UNIT_M_RANGE;
        if !(config.unit_m >= lo && config.unit_m <= hi) {
            bail!(
                ImapErrInvalidArgument,
                "config.unit_m = {:e} is not in [{lo:e}, {hi:e}] metres per scene unit",
                config.unit_m
            );
        }
        config.dynamic.validate()?;
        check_threads("config.threads", config.threads)?;
        let device = Device::new()?;
        let scene = Scene::new(config.bands.clone(), config.unit_m);
        let photometry = BandPhotometry::new(&config.bands);
        Ok(Context {
            region_tally: RegionTally::default(),
            photometry,
            config,
            device,
            scene,
            prepared: None,
            map: None,
            stats: PathStats::default(),
            traced: RangeSet::new(),
            elapsed_s: 0.0,
            history: Vec::new(),
            last_run: None,
            last_render: None,
            estimator: Estimator::DEFAULT,
            footprint: memory::Footprint::default(),
        })
    }

    /// The estimator the map is made with, its automatic settings resolved for the scene.
    pub fn estimator(&self) -> Estimator {
        match self.estimator {
            Estimator::Photons => Estimator::Photons,
            Estimator::LightSampling {
                samples,
                pass_photons,
                gather,
            } => {
                let samples = match (samples, gather) {
                    (0, false) => direct::DEFAULT_SAMPLES,
                    (0, true) => direct::GATHER_SAMPLES,
                    _ => samples,
                };
                let pass_photons = if pass_photons == 0 {
                    direct::auto_pass_photons(
                        self.lit_slots(),
                        self.scene.slot_count(),
                        samples,
                        gather,
                        self.scene.materials.iter().any(|m| m.bsdf().is_specular()),
                    )
                } else {
                    pass_photons
                };
                Estimator::LightSampling {
                    samples,
                    pass_photons,
                    gather,
                }
            }
        }
    }

    /// Map slots light sampling visits outside sensors (`direct::lit_slots`): vertices no
    /// triangle uses and sensors do not change the automatic settings. Before the scene is
    /// prepared (only an empty map's estimator is resolved then), every slot.
    fn lit_slots(&self) -> usize {
        self.prepared.as_ref().map_or(self.scene.slot_count(), |p| {
            direct::lit_slots(&p.scene, false)
        })
    }

    /// Chooses the estimator of the next runs (checked, and only while the map is empty
    /// or when it is the map's).
    pub fn set_estimator(&mut self, e: Estimator) -> Result<()> {
        if let Estimator::LightSampling {
            samples,
            pass_photons,
            ..
        } = e
        {
            if samples > direct::MAX_SAMPLES {
                bail!(
                    ImapErrInvalidArgument,
                    "params.direct_samples = {samples} is more than {}",
                    direct::MAX_SAMPLES
                );
            }
            let chunks = direct::chunks(self.scene.slot_count());
            if pass_photons != 0 && pass_photons < chunks {
                bail!(
                    ImapErrInvalidArgument,
                    "params.direct_pass_photons = {pass_photons} is below the {chunks} chunks of {} vertex sides a pass has in this scene (0 chooses)",
                    direct::CHUNK_SLOTS
                );
            }
        }
        if e == self.estimator {
            return Ok(());
        }
        let was = self.estimator();
        let old = std::mem::replace(&mut self.estimator, e);
        if self.estimator() == was {
            return Ok(());
        }
        if self.photons() > 0 {
            self.estimator = old;
            bail!(
                ImapErrOutOfOrder,
                "params.estimator: the map holds {} photons made with {}; call imap_reset before changing the estimator",
                self.photons(),
                was.name()
            );
        }
        self.map = None;
        Ok(())
    }

    pub fn config(&self) -> &Config {
        &self.config
    }

    pub(crate) fn scene(&self) -> &Scene {
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
        check_threads("threads", threads)?;
        self.config.threads = threads;
        Ok(())
    }

    /// Embree's version (major·10000 + minor·100 + patch).
    pub fn embree_version(&self) -> i64 {
        self.device.version()
    }

    fn photons(&self) -> u64 {
        self.traced.len()
    }

    /// The photon indices whose contributions the map holds.
    pub fn traced(&self) -> &RangeSet {
        &self.traced
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

    /// The memory limit in force: the configured budget, or by default three quarters of
    /// physical memory.
    pub fn memory_budget(&self) -> u64 {
        if self.config.memory_budget > 0 {
            return self.config.memory_budget;
        }
        default_memory_budget()
    }

    /// Bytes the context holds or will hold for its scene and map (`memory` model). Costs
    /// the same however large the scene: it reads the running figures.
    pub fn memory_estimate(&self) -> u64 {
        let f = &self.footprint;
        let per_slot = self.layer_layout().per_slot() as u64;
        let cells = f.slots.saturating_mul(per_slot);
        let bands = self.bands() as u64;
        let mut map = memory::map_bytes(cells, bands);
        if self.estimator.is_light_sampling() {
            map = map
                .saturating_add(memory::direct_record_bytes(cells, bands))
                .saturating_add(f.adjacency);
        }
        f.held.saturating_add(f.transient).saturating_add(map)
    }

    fn bands(&self) -> usize {
        self.scene.bands.count()
    }

    /// The map's layers for the scene (`Scene::layer_layout`, from the running figures:
    /// the same for any number of meshes).
    fn layer_layout(&self) -> LayerLayout {
        LayerLayout::new(self.scene.layers, self.footprint.largest_group)
    }

    /// Cells (accumulator records) of `slots` slots with the scene's layers.
    fn map_cells(&self, slots: usize) -> u64 {
        (slots as u64).saturating_mul(self.layer_layout().per_slot() as u64)
    }

    /// Refuses to go past the budget: `extra` more bytes on top of `base`, for `what`.
    fn check_budget(&self, base: u64, extra: u64, what: &str) -> Result<()> {
        let need = base.saturating_add(extra);
        let budget = self.memory_budget();
        if need > budget {
            let why = if self.config.memory_budget > 0 {
                "the configured memory budget"
            } else {
                "the default budget, 3/4 of physical memory"
            };
            bail!(
                ImapErrMemoryBudget,
                "{what} needs {extra} bytes; with the {base} bytes the context holds for its scene and map that is over {why} of {budget} bytes"
            );
        }
        Ok(())
    }

    pub fn add_material(&mut self, desc: &MaterialDesc) -> Result<u32> {
        if let Some(t) = desc.texture {
            if t as usize >= self.scene.textures.len() {
                bail!(
                    ImapErrIndexOutOfRange,
                    "texture {t} does not exist ({} textures): add it with add_texture first",
                    self.scene.textures.len()
                );
            }
        }
        let m = Material::new(desc, &self.scene.bands)?;
        self.scene.materials.push(m);
        Ok(self.scene.materials.len() as u32 - 1)
    }

    /// Adds a texture for materials to name (`MaterialDesc::texture`); returns its id.
    pub fn add_texture(&mut self, desc: &crate::scene::texture::TextureDesc) -> Result<u32> {
        self.check_unlocked("add a texture")?;
        let t = crate::scene::texture::Texture::new(desc, &self.scene.bands)?;
        self.check_budget(
            self.memory_estimate(),
            t.bytes() as u64,
            &format!("the texture ({} bytes)", t.bytes()),
        )?;
        self.footprint.held = self.footprint.held.saturating_add(t.bytes() as u64);
        self.scene.textures.push(std::sync::Arc::new(t));
        self.invalidate();
        Ok(self.scene.textures.len() as u32 - 1)
    }

    /// What checking measured table material `material` found: its worst reciprocity
    /// difference and its largest directional albedo.
    pub fn table_check(&self, material: u32) -> Result<crate::scene::TableCheck> {
        let Some(m) = self.scene.materials.get(material as usize) else {
            bail!(
                ImapErrIndexOutOfRange,
                "material {material} does not exist ({} materials)",
                self.scene.materials.len()
            );
        };
        match &m.glossy {
            Some(crate::scene::microfacet::Glossy::Table(t)) => Ok(t.check),
            Some(crate::scene::microfacet::Glossy::Klems(k)) => Ok(k.check),
            Some(crate::scene::microfacet::Glossy::Host(h)) => Ok(h.check),
            _ => bail!(
                ImapErrInvalidArgument,
                "material {material} is not a measured table, BSDF file or host BSDF (IMAP_SURFACE_TABLE, _BSDF_XML, _HOST)"
            ),
        }
    }

    /// Bytes a run's buffers take on `threads` threads with the configured scheduler.
    fn run_transient(&self, threads: usize) -> u64 {
        let nb = self.bands();
        match self.config.scheduler {
            SchedulerKind::Classic => sched::classic::run_bytes(threads, nb),
            SchedulerKind::Dynamic => sched::dynamic::run_bytes(threads, nb, &self.config.dynamic),
            SchedulerKind::TraceOnly => 0,
        }
    }

    pub fn add_mesh(&mut self, desc: &MeshDesc) -> Result<u32> {
        self.check_unlocked("add a mesh")?;
        // Everything the mesh costs follows from its counts: refuse before copying. A
        // scene admitted must also leave room for a run's buffers.
        let (held, transient) = memory::desc_bytes(desc);
        let transient = transient.saturating_add(self.run_transient(self.worker_threads()));
        let cells = self.map_cells(desc.map_slots());
        let mut map = memory::map_bytes(cells, self.bands() as u64);
        if self.estimator.is_light_sampling() && desc.map_slots() > 0 {
            map = map.saturating_add(memory::direct_desc_bytes(desc, cells, self.bands() as u64));
        }
        self.check_budget(
            self.memory_estimate(),
            held.saturating_add(transient).saturating_add(map),
            &format!(
                "the mesh ({} vertices, {} triangles: its copy, prepared form, BVH and map)",
                desc.positions.len() / 3,
                desc.indices.len() / 3
            ),
        )?;
        let mesh = Mesh::new(desc, self.scene.materials.len(), &self.scene.bands)?;
        if mesh.uvs.is_none() && !mesh.sensor {
            let needs = (0..mesh.triangles.len()).find_map(|t| {
                let m = mesh.material_of(t);
                let mat = &self.scene.materials[m as usize];
                if mat.texture.is_some() {
                    Some((m, "textured"))
                } else {
                    mat.uv_tangent
                        .then_some((m, "oriented by its texture coordinates (tangent_from_uvs)"))
                }
            });
            if let Some((m, why)) = needs {
                bail!(
                    ImapErrInvalidArgument,
                    "material {m} is {why}: the mesh needs texture coordinates (uvs)"
                );
            }
        }
        if let Some(m) = self.mesh_material(&mesh, Material::scatters) {
            if let Some((a, b)) = open_edge(&mesh) {
                bail!(
                    ImapErrInvalidArgument,
                    "mesh: material {m} holds a scattering medium, but the mesh that bounds it is not closed (the edge {a:?} to {b:?} is not shared by a triangle running the other way): a medium needs a closed mesh"
                );
            }
        }
        self.footprint.add_mesh(&mesh);
        self.scene.meshes.push(mesh);
        self.invalidate();
        Ok(self.scene.meshes.len() as u32 - 1)
    }

    /// Removes every light after the first `count` (their ids are free again); emitting
    /// meshes stay. Like adding one, only before photons are traced (after `reset`).
    /// `annual::PatchRun` traces a sky's patches in batches of light groups this way.
    pub fn truncate_lights(&mut self, count: usize) -> Result<()> {
        self.check_unlocked("remove lights")?;
        if count < self.scene.lights.len() {
            for l in self.scene.lights.drain(count..) {
                self.footprint.remove_light(&l);
            }
            self.footprint.regroup(&self.scene);
            self.invalidate();
        }
        Ok(())
    }

    pub(crate) fn add_light(&mut self, light: Light) -> Result<u32> {
        self.check_unlocked("add a light")?;
        self.footprint.add_light(&light);
        self.scene.lights.push(light);
        self.invalidate();
        Ok(self.scene.lights.len() as u32 - 1)
    }

    /// Adds a light described by kind, amount and spectrum.
    pub fn add_light_desc(&mut self, desc: &LightDesc) -> Result<u32> {
        self.check_unlocked("add a light")?;
        let l = Light::new(desc, &self.scene.bands, self.config.unit_m)?;
        self.add_light(l)
    }

    /// Adds a sky or environment (`scene::light`): a uniform sky, a CIE standard general
    /// sky or an equirectangular image. Its photons enter through the scene's bounding
    /// sphere.
    pub fn add_sky(&mut self, desc: &SkyDesc) -> Result<u32> {
        self.check_unlocked("add a sky")?;
        if let SkyKind::Image { width, height, .. } = &desc.kind {
            self.check_sky_image(*width, *height)?;
        }
        let l = Light::sky(desc, &self.scene.bands)?;
        self.add_light(l)
    }

    /// Refuses an environment image of `width` × `height` pixels that would take the
    /// context past its memory budget (IMAP_ERR_MEMORY_BUDGET), before anything is copied.
    pub fn check_sky_image(&self, width: usize, height: usize) -> Result<()> {
        let px = (width as u64).saturating_mul(height as u64);
        let (held, transient) = memory::sky_image_bytes(px);
        self.check_budget(
            self.memory_estimate(),
            held.saturating_add(transient),
            &format!("the environment image ({width} × {height} pixels)"),
        )
    }

    /// Adds an environment from a Radiance HDR or OpenEXR file: `desc` as `add_sky`, its
    /// kind replaced by the file's image.
    pub fn add_sky_file(&mut self, path: &std::path::Path, desc: &SkyDesc) -> Result<u32> {
        self.check_unlocked("add a sky")?;
        let left = self.memory_budget().saturating_sub(self.memory_estimate());
        // While it is read: the file, the decoded pixels and their RGB copy (f32), then what
        // the environment takes (`check_sky_image`).
        let check = |w: usize, h: usize, file: u64| {
            let px = (w as u64).saturating_mul(h as u64);
            self.check_budget(
                self.memory_estimate(),
                px.saturating_mul(24).saturating_add(file),
                &format!(
                    "decoding the environment image {} ({w} × {h} pixels)",
                    path.display()
                ),
            )?;
            self.check_sky_image(w, h)
        };
        let (width, height, rgb) = crate::images::read_image(path, left, &check)?;
        let desc = SkyDesc {
            kind: SkyKind::Image {
                width,
                height,
                rgb: std::sync::Arc::new(rgb),
            },
            ..desc.clone()
        };
        self.add_sky(&desc)
    }

    /// Adds the sun: a uniformly bright disk of 0.53°.
    pub fn add_sun(&mut self, desc: &SunDesc) -> Result<u32> {
        self.check_unlocked("add the sun")?;
        let l = Light::sun(desc, &self.scene.bands)?;
        self.add_light(l)
    }

    /// Sets the window portals (pbrt-v4's and Mitsuba's): triangles (`positions` xyz in
    /// scene units, `indices` three per triangle), each facing out of the model (its
    /// normal by the right-hand rule toward the sky). With portals, three quarters of every
    /// sky's, the sun's and the ground's photons come through them (chosen by each
    /// portal's share of the source's light) and a quarter from the whole sky, each
    /// weighted by the mixture's density of its line: unbiased everywhere, including light
    /// outside surfaces reflect into the openings, with far fewer photons wasted on the
    /// rest of the sky when light enters a building by its windows
    /// (`scene::prepared::Portals`). Lamps and emitting meshes are unchanged. Replaces earlier portals; no
    /// triangles removes them.
    pub fn set_portals(&mut self, positions: &[f64], indices: &[u32]) -> Result<()> {
        self.check_unlocked("set portals")?;
        if positions.len() % 3 != 0 || indices.len() % 3 != 0 {
            bail!(
                ImapErrInvalidArgument,
                "portals: {} coordinates and {} indices: both must be multiples of 3",
                positions.len(),
                indices.len()
            );
        }
        crate::error::check_finite("portals: positions", positions)?;
        let nv = positions.len() / 3;
        let mut tris = Vec::with_capacity(indices.len() / 3);
        for (k, t) in indices.chunks_exact(3).enumerate() {
            if let Some(&i) = t.iter().find(|&&i| i as usize >= nv) {
                bail!(
                    ImapErrInvalidArgument,
                    "portals: triangle {k} uses vertex {i}; there are {nv}"
                );
            }
            let p = [t[0], t[1], t[2]].map(|i| {
                let i = i as usize;
                [positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]]
            });
            let [a, b, c] = p.map(glam::DVec3::from);
            if (b - a).cross(c - a).length_squared() > 0.0 {
                tris.push(p);
            }
        }
        if tris.is_empty() && !indices.is_empty() {
            bail!(
                ImapErrInvalidArgument,
                "portals: every triangle has no area"
            );
        }
        self.scene.portals = tris;
        self.invalidate();
        Ok(())
    }

    /// Fills the space outside every closed mesh that holds a medium with the medium of
    /// material `material` (haze in a room, fog in a tunnel or on a stage), or empties it
    /// (None). The material must be a smooth dielectric of index 1 in every band (the
    /// space refracts nothing) with `absorption_per_m` or `scattering_per_m`; its phase
    /// function is its own. The medium fills the sphere around the geometry's centre that
    /// holds the geometry and every light but the distant ones (a sky's and the sun's
    /// light crosses it from its surface); lights inside it are followed from their own
    /// position. Photons scatter and are absorbed in it; light samples and gathering paths
    /// are attenuated by its transmittance (they never scatter in it: light scattered
    /// there is the photons'); sensors read the light that crosses them. The renderers'
    /// eye paths are attenuated and scattered by it and take a light sample where they
    /// scatter (`render::backward`). What it absorbed: `medium_absorbed(SCENE_MEDIUM)`.
    /// Fails with `IMAP_ERR_INVALID_ARGUMENT` naming the material when it is no such
    /// medium, and with `IMAP_ERR_UNSUPPORTED` when it fluoresces.
    pub fn set_scene_medium(&mut self, material: Option<u32>) -> Result<()> {
        self.check_unlocked("set the scene's medium")?;
        if let Some(id) = material {
            let Some(m) = self.scene.materials.get(id as usize) else {
                bail!(
                    ImapErrInvalidArgument,
                    "material = {id}: no such material ({} added)",
                    self.scene.materials.len()
                );
            };
            let Some(d) = m.dielectric.as_ref().filter(|_| m.holds_medium()) else {
                bail!(
                    ImapErrInvalidArgument,
                    "material = {id} holds no medium: the scene's medium is a dielectric of index 1 with absorption_per_m or scattering_per_m"
                );
            };
            if m.fluoresces() {
                bail!(
                    ImapErrUnsupported,
                    "material = {id} fluoresces: a fluorescent medium must be inside a mesh; the scene's medium does not re-emit (the renderers' light samples in it would miss the re-emitted light)"
                );
            }
            if m.glossy.is_some() || d.ior.iter().any(|&n| n != 1.0) {
                bail!(
                    ImapErrInvalidArgument,
                    "material = {id}: the scene's medium must be a smooth dielectric of index 1 in every band (IMAP_IOR_CONSTANT with ior[0] = 1, no roughness): the space around the meshes refracts nothing"
                );
            }
        }
        if self.scene.medium != material {
            self.scene.medium = material;
            self.invalidate();
        }
        Ok(())
    }

    /// Adds the ground's glow (Radiance's ground glow): a uniform radiance below the
    /// horizon of `zenith`, L = ρ E_h / π per band, with E_h the horizontal irradiance of
    /// the skies and suns added so far (add them first) and ρ `reflectance` (one grey
    /// value or one per band, in [0, 1]). It stands for an open ground that reflects
    /// diffusely what the sky and sun give it, as a distant source: photons come up from
    /// below the horizon into the scene's bounding sphere, the renderer sees it below the
    /// horizon, and every estimator samples it like a sky. `imap_light_flux` reports 0 for
    /// it (it gives an open horizontal plane nothing from above).
    pub fn add_ground(&mut self, reflectance: &[f64], zenith: [f64; 3]) -> Result<u32> {
        self.check_unlocked("add the ground")?;
        let rho = self.scene.bands.expand("reflectance", reflectance)?;
        if let Some(i) = rho.iter().position(|r| !(0.0..=1.0).contains(r)) {
            bail!(
                ImapErrInvalidArgument,
                "reflectance[{i}] = {} is outside [0, 1]",
                rho[i]
            );
        }
        let mut e_h = vec![0.0; rho.len()];
        let mut distant = 0;
        for l in &self.scene.lights {
            if let crate::scene::light::LightShape::Distant(d) = &l.shape {
                if d.parts
                    .iter()
                    .any(|p| matches!(p.radiance, crate::scene::light::Radiance::Ground))
                {
                    bail!(
                        ImapErrInvalidArgument,
                        "the scene has a ground already: add one ground"
                    );
                }
                distant += 1;
                for (o, x) in e_h.iter_mut().zip(d.horizontal()) {
                    *o += x;
                }
            }
        }
        if distant == 0 {
            bail!(
                ImapErrInvalidArgument,
                "no sky or sun has been added: the ground's glow is ρ E_h / π of the sky and sun, so add them first"
            );
        }
        let per_band: Vec<f64> = rho
            .iter()
            .zip(&e_h)
            .map(|(r, e)| r * e / std::f64::consts::PI)
            .collect();
        if !per_band.iter().any(|&x| x > 0.0) {
            bail!(
                ImapErrInvalidArgument,
                "the ground would not glow (reflectance 0, or the sky and sun give no horizontal light): leave it out"
            );
        }
        let l = Light::ground(zenith, per_band)?;
        self.add_light(l)
    }

    /// Adds a goniometric luminaire from photometric data.
    pub fn add_luminaire(
        &mut self,
        data: &PhotometricData,
        placement: &Placement,
        spectrum: &Spectrum,
    ) -> Result<u32> {
        self.check_unlocked("add a luminaire")?;
        let d = self.distribution(data)?;
        self.add_distribution(&d, placement, spectrum)
    }

    /// Checks and expands photometric data to a distribution that luminaires can be placed
    /// with (`add_distribution`), within the memory budget: IMAP_ERR_MEMORY_BUDGET before
    /// the table is expanded when it would not fit.
    pub fn distribution(&self, data: &PhotometricData) -> Result<Distribution> {
        let nh = data.candela.len();
        let nv = data.candela.first().map_or(0, Vec::len);
        let given = (nv as u64).saturating_mul(nh as u64);
        let expanded = gonio::expanded_values(data.kind, data.symmetry, nv, nh);
        self.reserve_table(gonio::table_bytes(given, expanded).0)?;
        Distribution::new(data)
    }

    /// The distribution of the text of an IES LM-63 file (`tilt`: the text of the TILT file
    /// it names, if it names one), read and expanded within the memory budget: a table too
    /// large for it is refused from its counts, before its values are read.
    pub fn distribution_ies(&self, text: &str, tilt: Option<&str>) -> Result<Distribution> {
        let reserve = |bytes| self.reserve_table(bytes);
        Distribution::new(&crate::photometry::ies::parse_within(text, tilt, &reserve)?.data)
    }

    /// The distribution of the text of a EULUMDAT file, as `distribution_ies`.
    pub fn distribution_ldt(&self, text: &str) -> Result<Distribution> {
        let reserve = |bytes| self.reserve_table(bytes);
        Distribution::new(&crate::photometry::ldt::parse_within(text, &reserve)?.data)
    }

    /// Refuses a luminaire table whose reading and expansion take `bytes` more than the
    /// budget leaves.
    fn reserve_table(&self, bytes: u64) -> Result<()> {
        self.check_budget(
            self.memory_estimate(),
            bytes,
            "the luminaire's candela table (read and expanded to the sphere)",
        )
    }

    /// Adds a luminaire from a prepared distribution (place one file many times without
    /// expanding its table each time).
    pub fn add_distribution(
        &mut self,
        distribution: &Distribution,
        placement: &Placement,
        spectrum: &Spectrum,
    ) -> Result<u32> {
        self.check_unlocked("add a luminaire")?;
        let l = Light::placed(
            distribution,
            placement,
            spectrum,
            &self.scene.bands,
            self.config.unit_m,
        )?;
        self.add_light(l)
    }

    /// Adds a luminaire from the text of an IES LM-63 file (`tilt`: the text of the TILT
    /// file it names, if it names one).
    pub fn add_luminaire_ies(
        &mut self,
        text: &str,
        tilt: Option<&str>,
        placement: &Placement,
        spectrum: &Spectrum,
    ) -> Result<u32> {
        self.check_unlocked("add a luminaire")?;
        let d = self.distribution_ies(text, tilt)?;
        self.add_distribution(&d, placement, spectrum)
    }

    /// Adds a luminaire from the text of a EULUMDAT file.
    pub fn add_luminaire_ldt(
        &mut self,
        text: &str,
        placement: &Placement,
        spectrum: &Spectrum,
    ) -> Result<u32> {
        self.check_unlocked("add a luminaire")?;
        let d = self.distribution_ldt(text)?;
        self.add_distribution(&d, placement, spectrum)
    }

    /// Radiant flux per band (W) of light `id`, and its luminous flux (lm); of a sky or
    /// the sun, the irradiance per band (W/m²) and illuminance (lx) it gives an
    /// unobstructed horizontal plane.
    pub fn light_flux(&self, id: u32) -> Result<(Vec<f64>, f64)> {
        let Some(l) = self.scene.lights.get(id as usize) else {
            bail!(
                ImapErrIndexOutOfRange,
                "light id {id} is out of range (the scene has {} lights)",
                self.scene.lights.len()
            );
        };
        let w = l.reported_flux();
        let lm = self.photometry.luminous(&w);
        Ok((w, lm))
    }

    /// What a watt in each band is worth in lumens and X, Y, Z.
    pub fn photometry(&self) -> &BandPhotometry {
        &self.photometry
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
        self.region_tally = RegionTally::default();
        self.traced.clear();
        self.elapsed_s = 0.0;
        self.history.clear();
        self.last_run = None;
        self.last_render = None;
    }

    /// The prepared scene and its BVH (built on first use after a change), for a run or
    /// a render: refused without a light.
    fn prepare_scene(&mut self) -> Result<()> {
        if self.prepared.is_none()
            && self.scene.lights.is_empty()
            && self.scene.meshes.iter().all(|m| m.exitance.is_none())
            && !self.scene.meshes.is_empty()
        {
            bail!(
                ImapErrNoLight,
                "the scene has no light: add a light, a luminaire or an emitting mesh"
            );
        }
        self.prepare_geometry()
    }

    /// The prepared scene and its BVH, with or without lights (straight lines need only
    /// the geometry).
    fn prepare_geometry(&mut self) -> Result<()> {
        if self.scene.meshes.is_empty() {
            bail!(
                ImapErrNoGeometry,
                "the scene has no mesh: add one with imap_add_mesh before imap_run"
            );
        }
        if self.prepared.is_none() {
            let scene = PreparedScene::new(
                &self.scene,
                &self.photometry.efficacy,
                self.config.aim_lights,
            )?;
            let accel = Accel::build(&self.device, &scene.meshes)?;
            let sensors = Accel::build_sensors(&self.device, &scene.meshes)?;
            let layout = MapLayout::new(&self.scene, &scene);
            self.prepared = Some(Prepared {
                layout,
                scene,
                accel,
                sensors,
                direct: None,
                coverage: Default::default(),
            });
        }
        Ok(())
    }

    fn prepare(&mut self) -> Result<()> {
        self.prepare_scene()?;
        if self.map.is_none() {
            self.map = Some(IMap::try_new_with(
                self.scene.slot_count(),
                self.bands(),
                self.layer_layout(),
                self.estimator.is_light_sampling(),
                self.prepared
                    .as_ref()
                    .expect("prepared above")
                    .layout
                    .grey
                    .clone(),
            )?);
            self.region_tally = RegionTally::default();
        }
        let p = self.prepared.as_mut().expect("prepared above");
        if self.estimator.is_light_sampling() && p.direct.is_none() {
            p.direct = Some(DirectPlan::new(&p.scene, &p.layout.parts()));
        }
        if self.stats.absorbed.len() != self.scene.meshes.len() {
            self.stats = PathStats::new(self.scene.meshes.len());
        }
        Ok(())
    }

    /// Traces photons into the map until a stop criterion of `params` is met. A later run
    /// continues the same photon sequence and accumulates into the same map; photons a
    /// stop cut short are traced again, whole, by the next run.
    pub fn run(&mut self, params: &mut RunParams) -> Result<Report> {
        check_run_params(params)?;
        if let Some(e) = params.estimator {
            self.set_estimator(e)?;
        }
        let region_weights = match &params.region {
            Some(t) => self.region_weights(t)?,
            None => Vec::new(),
        };
        let threads = self.worker_threads();
        let nb = self.bands();
        let transient = self.run_transient(threads);
        let held = self.memory_estimate();
        self.check_budget(
            held,
            transient,
            &format!("a run on {threads} threads (its portions and buffers)"),
        )?;
        let pool_bytes = self
            .memory_budget()
            .saturating_sub(held.saturating_add(transient));
        self.prepare()?;
        let hosts: Vec<_> = self.host_surfaces().into_iter().map(|(_, h)| h).collect();
        hosts.iter().for_each(|h| h.clear());
        let plan = photons::continue_plan(&self.traced, params.photons, &params.selection);
        let estimator = self.estimator();
        let prepared = self.prepared.as_ref().expect("prepared above");
        let map = self.map.as_mut().expect("allocated above");
        let direct_acc = map.direct().cloned();
        let direct_cells = direct_acc.as_deref().map(|acc| DirectCells {
            acc,
            layers: prepared.layout.layers,
        });
        let sampler = match &direct_cells {
            Some(cells) if self.config.scheduler != SchedulerKind::TraceOnly => prepared.sampler(
                &self.scene,
                &self.config,
                estimator,
                cells,
                params.max_path_events,
            ),
            _ => None,
        };
        let regions = RegionShared::new(threads, prepared.layout.regions.count, nb);
        let rc = RunContext {
            regions: &regions,
            regions_before: &self.region_tally,
            region_weights: &region_weights,
            tracer: prepared.tracer(
                &self.scene,
                &self.config,
                params.max_path_events,
                prepared.sensors.as_ref(),
                sampler.as_ref(),
            ),
            scene: &prepared.scene,
            layout: &prepared.layout,
            threads,
            unit_m: self.config.unit_m,
            plan,
            selection: params.selection,
            photons_before: self.traced.len(),
            pool_bytes,
            hits_before: self.stats.hits,
            elapsed_before_s: self.elapsed_s,
            host_bsdfs: &hosts,
        };
        let outcome = match self.config.scheduler {
            SchedulerKind::Classic => sched::classic::run(&rc, map, params),
            SchedulerKind::Dynamic => sched::dynamic::run(&rc, map, params, &self.config.dynamic),
            SchedulerKind::TraceOnly => sched::trace_only::run(&rc, map, params),
        };
        self.last_run = Some(LastRun {
            photons: outcome.stats.photons,
            hits: outcome.stats.hits,
            wall_s: outcome.wall_s,
            stop: outcome.stop,
            counters: outcome.counters,
            threads,
        });
        if self.config.scheduler == SchedulerKind::TraceOnly {
            // Nothing was accumulated: the totals and the history stay as they were.
            return Ok(self.report());
        }
        self.stats.merge(&outcome.stats);
        self.region_tally.merge(&regions.total());
        for r in outcome.traced.ranges() {
            self.traced.insert(r.clone());
        }
        debug_assert_eq!(self.stats.photons, self.traced.len());
        self.elapsed_s += outcome.wall_s;
        for p in outcome.history {
            push_history(&mut self.history, p);
        }
        if let Some(why) = outcome.thread_lost {
            bail!(
                ImapErrThreadLost,
                "{why}; what that thread had not yet handed over is missing from the map while its photons are counted, so the map may read low: call imap_reset and run again for an exact map"
            );
        }
        if let Some(e) = self.host_failure("photons") {
            return Err(e);
        }
        Ok(self.report())
    }

    /// The scene's host BSDFs (`IMAP_SURFACE_HOST`) with their material ids.
    pub(crate) fn host_surfaces(
        &self,
    ) -> Vec<(u32, std::sync::Arc<crate::scene::host::HostSurface>)> {
        self.scene
            .materials
            .iter()
            .enumerate()
            .filter_map(|(i, m)| match &m.glossy {
                Some(crate::scene::microfacet::Glossy::Host(h)) => Some((i as u32, h.clone())),
                _ => None,
            })
            .collect()
    }

    /// The error naming the first host BSDF whose calls failed since it was last cleared;
    /// `what` ended there (photons or camera paths).
    pub(crate) fn host_failure(&self, what: &str) -> Option<Error> {
        self.host_surfaces().into_iter().find_map(|(id, h)| {
            h.failures().map(|(n, first)| {
                Error::new(
                    ImapStatus::ImapErrHostBsdf,
                    format!(
                        "material {id}: its host BSDF failed {n} time(s) (first: {first}); the {what} there ended, so the result may read low and the run stopped: fix the BSDF, then imap_reset and run again"
                    ),
                )
                .about(crate::error::Subject::Material(id))
            })
        })
    }

    /// Worker threads of a run or render: the configured count, or one per core.
    pub(crate) fn worker_threads(&self) -> usize {
        match self.config.threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            t => t,
        }
    }

    /// Totals since the last reset and the last run's figures.
    pub fn report(&self) -> Report {
        let n = self.photons();
        let total_power = self.prepared.as_ref().map_or(0.0, |p| p.scene.total_power);
        let w = if n > 0 { total_power / n as f64 } else { 0.0 };
        let LastRun {
            photons: run_photons,
            hits: run_hits,
            wall_s: run_wall_s,
            stop,
            counters,
            threads,
        } = self.last_run.clone().unwrap_or_default();
        let band_w = self.stats.bands.clone().map(|mut b| {
            b.resize(self.bands(), 0.0);
            b.iter_mut().for_each(|x| *x *= w);
            b
        });
        let lm = |i: usize| self.photometry.luminous(&band_w[i]);
        Report {
            emitted_lm: lm(BAND_EMITTED),
            absorbed_lm: lm(BAND_ABSORBED),
            escaped_lm: lm(BAND_ESCAPED),
            dropped_lm: lm(BAND_DROPPED),
            fluoresced_lm: lm(BAND_FLUORESCED),
            fluoresced_w: band_w[BAND_FLUORESCED].iter().sum(),
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
            stop: self.last_run.as_ref().map(|_| stop),
            threads,
            scheduler: self.config.scheduler,
            emitted_w: self.stats.emitted * w,
            absorbed_w: (self.stats.absorbed.iter().sum::<f64>() + self.scene_medium_absorbed())
                * w,
            escaped_w: self.stats.escaped * w,
            dropped_w: self.stats.dropped * w,
            dropped_photons: self.stats.dropped_photons,
            band_w,
            counters,
            map_bytes: self.map.as_ref().map_or(0, IMap::bytes),
        }
    }

    /// The error-against-time history since the last reset.
    pub fn history(&self) -> &[Progress] {
        &self.history
    }

    /// Triangles of mesh `mesh` left out because they repeat a vertex
    /// (`MeshDesc::skip_degenerate`).
    pub fn dropped_triangles(&self, mesh: u32) -> Result<usize> {
        self.mesh_index(mesh)?;
        Ok(self.scene.meshes[mesh as usize].dropped_triangles)
    }

    /// The first material of `mesh`'s triangles that `is` holds for (a sensor's materials
    /// are part labels, never looked up: None).
    pub(crate) fn mesh_material(&self, mesh: &Mesh, is: impl Fn(&Material) -> bool) -> Option<u32> {
        let is = |id: u32| self.scene.materials.get(id as usize).is_some_and(&is);
        if mesh.sensor {
            return None;
        }
        match &mesh.triangle_materials {
            None => is(mesh.material).then_some(mesh.material),
            Some(ids) => ids.iter().copied().find(|&id| is(id)),
        }
    }

    /// Whether mesh `mesh` (an index that exists) has a triangle whose material holds a
    /// medium: a dielectric that absorbs or scatters inside.
    pub(crate) fn holds_medium(&self, mesh: usize) -> bool {
        self.mesh_material(&self.scene.meshes[mesh], Material::holds_medium)
            .is_some()
    }

    /// What the medium inside mesh `mesh` absorbed since the last reset: per band, W, and
    /// in lm, each with its standard error (from the photons' own totals there, exact as a
    /// region's flux error). What the mesh's surfaces absorb does not count
    /// (`absorbed_w` has both). Fails with `IMAP_ERR_INVALID_ARGUMENT` for a mesh whose
    /// materials hold no medium (no dielectric with `absorption_per_m` or
    /// `scattering_per_m`).
    pub fn medium_absorbed(&self, mesh: u32) -> Result<MediumAbsorbed> {
        if mesh == crate::transport::SCENE_MEDIUM {
            if self.scene.medium.is_none() {
                bail!(
                    ImapErrInvalidArgument,
                    "mesh = SCENE_MEDIUM ({mesh:#x}): the scene has no medium outside its meshes (set_scene_medium)"
                );
            }
        } else if !self
            .mesh_index(mesh)
            .map(|_| self.holds_medium(mesh as usize))?
        {
            bail!(
                ImapErrInvalidArgument,
                "mesh = {mesh} holds no medium: none of its materials is a dielectric with absorption_per_m or scattering_per_m"
            );
        }
        let nb = self.bands();
        let mut out = MediumAbsorbed {
            band_w: vec![Default::default(); nb],
            lm: Default::default(),
        };
        let n = self.photons();
        let (Some(p), Some((sum, sq, sq_lum))) = (&self.prepared, self.stats.volumes.of(mesh))
        else {
            return Ok(out);
        };
        if n == 0 {
            return Ok(out);
        }
        let nf = n as f64;
        let wpu = p.scene.total_power / (nf * nb as f64);
        let est = |s: f64, q: f64| crate::imap::readout::photon_total(s, q, nf, wpu);
        for (o, (&s, &q)) in out.band_w.iter_mut().zip(sum.iter().zip(sq)) {
            *o = est(s, q);
        }
        let lum: f64 = sum.iter().zip(&p.scene.efficacy).map(|(s, e)| s * e).sum();
        out.lm = est(lum, sq_lum);
        Ok(out)
    }

    /// What the scene's medium absorbed, in photon units (the mean over bands of its
    /// tally); 0 without one.
    fn scene_medium_absorbed(&self) -> f64 {
        self.stats
            .volumes
            .of(crate::transport::SCENE_MEDIUM)
            .map_or(0.0, |(sum, _, _)| {
                sum.iter().sum::<f64>() / sum.len().max(1) as f64
            })
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
}

/// The default memory budget: three quarters of physical memory (no limit when the system
/// does not say).
pub fn default_memory_budget() -> u64 {
    physical_memory().map_or(u64::MAX, |m| m / 4 * 3)
}

use crate::platform::physical_memory;

impl Context {
    /// Checks a region target against the scene; the weights of each target mesh's vertices
    /// (`RunContext::region_weights`).
    fn region_weights(&self, t: &sched::target::RegionTarget) -> Result<Vec<Vec<f64>>> {
        check_finite_scalar("params.region_target", t.target)?;
        if t.target <= 0.0 {
            bail!(
                ImapErrInvalidArgument,
                "params.region_target = {} must be positive",
                t.target
            );
        }
        if t.meshes.is_empty() {
            bail!(
                ImapErrInvalidArgument,
                "params.region_meshes is empty: a region target needs at least one mesh"
            );
        }
        if let sched::target::RegionMeasure::Vertices { percentile } = t.measure {
            if !(percentile > 0.0 && percentile <= 100.0) {
                bail!(
                    ImapErrInvalidArgument,
                    "params.region_percentile = {percentile} is not in (0, 100]"
                );
            }
        }
        for &m in &t.meshes {
            let i = self.mesh_index(m as u32).map_err(|e| {
                crate::error::Error::new(e.status, format!("params.region_meshes: {}", e.message))
            })?;
            if !self.scene.meshes[i].record {
                bail!(
                    ImapErrNotRecorded,
                    "params.region_meshes: mesh {m} does not record, so it has no error to reach"
                );
            }
            let on_tallies = matches!(
                t.measure,
                sched::target::RegionMeasure::Average | sched::target::RegionMeasure::Uniformity
            );
            if on_tallies && !self.scene.meshes[i].tally {
                bail!(
                    ImapErrInvalidArgument,
                    "params.region_meshes: mesh {m} keeps no region tallies, so its average has no exact error: add it as a sensor or with the tally flag (IMAP_MESH_TALLY) to stop on its average or uniformity"
                );
            }
            if let Some(p) = t.part {
                let mesh = &self.scene.meshes[i];
                if !(0..mesh.triangles.len()).any(|t| mesh.material_of(t) == p) {
                    bail!(
                        ImapErrIndexOutOfRange,
                        "params.region_part: mesh {m} has no triangle of material {p}"
                    );
                }
            }
        }
        // The vertices' weights the measure is taken with: their shares of the region.
        Ok(t.meshes
            .iter()
            .map(|&m| self.scene.meshes[m].area_shares(t.part))
            .collect())
    }
}

/// Checks run parameters, naming the field at fault.
fn check_run_params(p: &RunParams) -> Result<()> {
    check_finite_scalar("params.time_budget_s", p.time_budget_s)?;
    check_finite_scalar("params.target_rel_error", p.target_rel_error)?;
    check_finite_scalar("params.progress_interval_s", p.progress_interval_s)?;
    if p.time_budget_s < 0.0 {
        bail!(
            ImapErrInvalidArgument,
            "params.time_budget_s = {} is negative (0 means no limit)",
            p.time_budget_s
        );
    }
    if p.target_rel_error < 0.0 {
        bail!(
            ImapErrInvalidArgument,
            "params.target_rel_error = {} is negative (0 means no target)",
            p.target_rel_error
        );
    }
    if p.progress_interval_s <= 0.0 {
        bail!(
            ImapErrInvalidArgument,
            "params.progress_interval_s = {} must be positive",
            p.progress_interval_s
        );
    }
    if let Some(why) = p.selection.check() {
        bail!(ImapErrInvalidArgument, "params.{why}");
    }
    if p.max_path_events == 0 {
        bail!(
            ImapErrInvalidArgument,
            "params.max_path_events is 0: a path needs at least one event"
        );
    }
    if p.photons == 0
        && p.time_budget_s == 0.0
        && p.target_rel_error == 0.0
        && p.region.is_none()
        && p.progress.is_none()
        && p.selection.end == u64::MAX
    {
        bail!(
            ImapErrInvalidArgument,
            "params sets no stop criterion: set photons, time_budget_s, target_rel_error, a region target, a progress callback or a photon range with an end"
        );
    }
    Ok(())
}

/// An edge of `mesh` (its corners merged by position) that no triangle runs the other way
/// (or that too many run one way): the mesh is not a closed surface. None when closed.
fn open_edge(mesh: &crate::scene::Mesh) -> Option<([f64; 3], [f64; 3])> {
    let mut id: std::collections::HashMap<[u64; 3], u32> = std::collections::HashMap::new();
    let key: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            let n = id.len() as u32;
            *id.entry(p.map(f64::to_bits)).or_insert(n)
        })
        .collect();
    let mut edges: std::collections::HashMap<(u32, u32), i64> = std::collections::HashMap::new();
    for t in &mesh.triangles {
        for e in 0..3 {
            let (ka, kb) = (key[t[e] as usize], key[t[(e + 1) % 3] as usize]);
            *edges.entry((ka.min(kb), ka.max(kb))).or_default() += if ka < kb { 1 } else { -1 };
        }
    }
    edges.iter().find(|(_, c)| **c != 0).map(|(&(ka, kb), _)| {
        let at = |k: u32| mesh.positions[key.iter().position(|&x| x == k).unwrap_or(0)];
        (at(ka), at(kb))
    })
}

//! Backward paths: from the camera through specular and refracting surfaces to the first
//! diffuse surface, where the direct light is computed (light sampling and BSDF sampling,
//! combined by multiple importance sampling with the power heuristic) and a backward photon
//! is left for the forward photons to find (indirect and caustic light).
//!
//! Units: luminance is radiance per band, W/(m²·sr) (a band's share of the power, as the
//! i-map's irradiance is W/m² per band). Emitting meshes are Lambertian: radiance M/π.

use super::bmap::{BackwardPhoton, SampleBuf};
use super::camera::Camera;
use super::coverage::Coverage;
use crate::accel::Accel;
use crate::sampling::{warp, PhotonRng};
use crate::scene::bsdf::{reflect, refract};
use crate::scene::bsdf::{Bsdf, Lobe};
use crate::scene::light::DistantPart;
use crate::scene::material::fresnel_dielectric;
use crate::scene::medium::{Flight, MediumStack};
use crate::scene::texture::TintScratch;
use crate::scene::{Enclosures, LightSample, Material, PreparedScene, Receiver, Scene};
use crate::spectral::{collapse_weights, pick_band, Transmittance as Tr};
use crate::transport::SurfaceEvent;
use glam::DVec3;
use std::f64::consts::PI;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// What a light gives in the render's units, per band.
#[derive(Debug)]
enum LightValue {
    /// Radiant flux, W (lights: their shape gives the intensity per watt, or a beam's
    /// irradiance per watt).
    Power(Vec<f64>),
    /// Radiance of an emitting mesh, W/(m²·sr), and its emitting area (scene units²).
    Radiance { radiance: Vec<f64>, area: f64 },
}

/// Gathering radius of a pixel's first sample: this many pixel footprints.
pub(crate) const INITIAL_RADIUS_FOOTPRINTS: f64 = 4.0;

/// Final gathering reads the map at a path's second diffuse vertex unless the segment that
/// reached it is shorter than this many of its triangle's sizes (√(2·area), a cell's
/// side on a regular grid): in a corner, the map's interpolated hat averages read up to
/// 1 % high, and the path goes on (BENCHMARKS.md, "Final gathering in corners"). 0.75:
/// the corners' bias went from +0.60 to +0.26 % and their error estimate became
/// calibrated, for 8 % more time to 1 % in a view where corners are few.
const NEAR_READ_CELLS: f64 = 0.75;
/// A final-gathering path reads the map wherever it is once it has left this many diffuse
/// vertices behind (at its fourth).
const MAP_READ_BY: u32 = 3;

/// Read-only state of the backward pass.
pub struct EyeTracer<'a> {
    pub scene: &'a PreparedScene,
    pub accel: &'a Accel,
    pub materials: &'a [Material],
    pub camera: &'a Camera,
    pub bands: usize,
    pub unit_m: f64,
    pub max_events: u32,
    /// Fixed first radius (scene units), or 0 for a few pixel footprints.
    pub initial_radius: f64,
    /// Whether any material transmits diffusely (only then are BTDF weights kept).
    pub transmit: bool,
    lights: Vec<LightValue>,
    /// The distant sources, for paths that leave the scene (`EmitterKind::Distant`), with
    /// their emitter indices.
    distant: Vec<(usize, Arc<DistantPart>)>,
    /// Emitter index of each mesh that emits.
    emitter_of_mesh: Vec<Option<u32>>,
    /// The emitting meshes' exact shares of the pixels on their outlines, the camera
    /// samples' control variate (`coverage.rs`; empty until `set_coverage`).
    coverage: Arc<Coverage>,
    has_mesh_emitters: bool,
    /// The illumination map's indirect irradiance, for paths ended at their second
    /// diffuse vertex (`path_sample`); None: plain path tracing.
    pub map: Option<&'a MapIndirect>,
    /// The sun's light through specular surfaces onto diffuse ones comes from caustic
    /// photons (final gathering's caustic rounds): a path that left a diffuse vertex does
    /// not count the sun's disk when a specular chain shows it. (The disk is 0.53° wide: a
    /// cosine-sampled direction finds it once in 10⁵ paths, and a render's error with the
    /// sun through glass read 600–1400 %.)
    pub sun_by_caustics: bool,
    /// 1 in every band: the reflectance a fluorescent surface has for an eye path once its
    /// weights are taken through the surface (`through_fluorescent`).
    white: Vec<f64>,
    /// Whether some material fluoresces (backward photons then record their pixel band).
    fluorescent: bool,
    /// Whether some smooth dielectric has index 1 in every band (a fog box's walls): light
    /// samples in media then go through such surfaces (`shadow_through`).
    index_matched: bool,
    /// Whether some light is inside a mesh with a scattering medium (`Emitter::media`):
    /// eye paths then take light samples where they scatter in mesh media, and shadow
    /// rays inside such a mesh are attenuated by its medium (`light_tr`).
    lights_in_media: bool,
    /// The meshes with a medium (scattering or absorbing) around the camera, outermost
    /// first: every eye path starts inside them.
    camera_media: MediumStack,
}

/// The mesh an eye path is inside (innermost) and its medium's material; None: outside every
/// mesh (`MediumStack::current`).
type Inside = Option<(u32, u32)>;

/// Where an eye path's light goes (`EyeTracer::path_sample`): the pixel's bands, each into
/// its own; or, once a fluorescent surface has picked the pixel band `band` for the path,
/// per band of the arriving light into `arriving`, summed into that pixel band when the
/// path ends (dropped).
struct PathOut<'o> {
    out: &'o mut [f64],
    arriving: Vec<f64>,
    band: Option<usize>,
}

impl PathOut<'_> {
    #[inline]
    fn to(&mut self) -> &mut [f64] {
        if self.band.is_some() {
            &mut self.arriving
        } else {
            self.out
        }
    }
}

impl Drop for PathOut<'_> {
    fn drop(&mut self) {
        if let Some(j) = self.band {
            self.out[j] += self.arriving.iter().sum::<f64>();
        }
    }
}

/// The illumination map's indirect irradiance (combined minus direct layer) at every
/// recorded vertex side, with its error: what `path_sample` reads at a path's second
/// diffuse vertex instead of tracing it on.
#[derive(Debug, Default)]
pub struct MapIndirect {
    /// Per prepared mesh: None when it does not record.
    pub meshes: Vec<Option<MeshIndirect>>,
    /// The values are the map's whole irradiance, direct light included (a map without the
    /// direct layer): a path ending on them samples no direct light there.
    pub combined: bool,
}

#[derive(Debug)]
pub struct MeshIndirect {
    pub sides: usize,
    /// W/m² per band at ((vertex · sides + side) · bands + band).
    pub irradiance: Vec<f64>,
    /// Its standard error over the band mean, relative to the band mean, per vertex side.
    pub rel_error: Vec<f64>,
}

/// A vertex side a final-gathering sample read from the map, and the map's standard error
/// of what it read (band-mean radiance, the pixel's units).
#[derive(Clone, Copy, Debug)]
pub struct MapRead {
    /// (mesh << 40) | (vertex · sides + side).
    pub key: u64,
    pub sigma: f64,
}

/// Where an eye path meets a surface: the point, the normal on the side it came from, the
/// offset for new rays, whether it hit the front, and the material.
struct Surface {
    p: DVec3,
    /// The triangle's geometric normal.
    ng: DVec3,
    n_in: DVec3,
    eps: f64,
    front: bool,
    mesh: u32,
    material: u32,
}

/// What an eye path does at a surface (`EyeTracer::surface_step`).
enum Step {
    Specular,
    /// A glossy reflector (`EyeTracer::glossy_step` takes it on).
    Glossy,
    Diffuse(f64),
    End,
}

/// Tallies of the backward pass.
#[derive(Clone, Debug, Default)]
pub struct EyeStats {
    pub paths: u64,
    pub rays: u64,
    /// Paths stopped by the event safety limit.
    pub dropped: u64,
}

impl<'a> EyeTracer<'a> {
    pub fn new(
        source: &'a Scene,
        scene: &'a PreparedScene,
        accel: &'a Accel,
        camera: &'a Camera,
        max_events: u32,
        initial_radius: f64,
    ) -> Self {
        let mut emitter_of_mesh = vec![None; scene.meshes.len()];
        let lights = scene
            .emitters
            .iter()
            .enumerate()
            .map(|(e, em)| match em.mesh() {
                None => LightValue::Power(em.power.clone()),
                Some(mesh) => {
                    emitter_of_mesh[mesh] = Some(e as u32);
                    let m = &scene.meshes[mesh];
                    let area = (0..m.triangles.len()).map(|t| m.area(t)).sum();
                    let exitance = source.meshes[mesh].exitance.as_ref().expect("emits");
                    LightValue::Radiance {
                        radiance: exitance.iter().map(|x| x / PI).collect(),
                        area,
                    }
                }
            })
            .collect::<Vec<_>>();
        EyeTracer {
            scene,
            accel,
            materials: &source.materials,
            camera,
            bands: source.bands.count(),
            unit_m: source.unit_m,
            max_events,
            initial_radius,
            transmit: source
                .materials
                .iter()
                .any(|m| m.bsdf().has(Lobe::DiffuseTransmission)),
            has_mesh_emitters: emitter_of_mesh.iter().any(Option::is_some),
            distant: scene
                .emitters
                .iter()
                .enumerate()
                .filter_map(|(e, em)| em.distant_part().map(|p| (e, p.clone())))
                .collect(),
            lights,
            emitter_of_mesh,
            coverage: Arc::default(),
            map: None,
            sun_by_caustics: false,
            white: vec![1.0; source.bands.count()],
            fluorescent: source.materials.iter().any(Material::fluoresces),
            lights_in_media: scene.emitters.iter().any(|e| !e.media.is_empty()),
            // (Among the materials the meshes use: the scene medium's is one too.)
            camera_media: MediumStack::starting_in(
                Enclosures::new(source, |m| m.extinction().is_some())
                    .at(camera.origin + scene.origin, None),
            ),
            index_matched: scene.meshes.iter().any(|m| {
                m.materials.iter().any(|&id| {
                    source.materials[id as usize]
                        .bsdf()
                        .interface()
                        .is_some_and(|d| d.ior.iter().all(|&n| n == 1.0))
                })
            }),
        }
    }

    /// The emitting meshes' shares of the pixels they partly cover, for this tracer's
    /// camera: empty when no mesh emits, or when a camera ray's first segment may be
    /// attenuated (a medium around the camera, the scene's medium), where the exact share
    /// would not be the pixel's direct part.
    pub fn build_coverage(&self) -> Coverage {
        if !self.has_mesh_emitters
            || !self.camera.is_perspective()
            || self.camera_media.current().is_some()
            || self.scene.haze.is_some()
        {
            return Coverage::default();
        }
        let emitters: Vec<(usize, u32, bool)> = self
            .emitter_of_mesh
            .iter()
            .enumerate()
            .filter_map(|(mesh, e)| {
                let e = (*e)?;
                let lit = match &self.lights[e as usize] {
                    LightValue::Radiance { radiance, .. } => radiance.iter().any(|&l| l != 0.0),
                    LightValue::Power(_) => false,
                };
                lit.then(|| (mesh, e, self.scene.emitters[e as usize].two_sided()))
            })
            .collect();
        let sees = |x: u32, y: u32, jx: f64, jy: f64, mesh: usize, prim: usize| {
            let Some(dir) = self.camera.ray(x, y, jx, jy) else {
                return false;
            };
            self.scene
                .enter(self.camera.origin, dir)
                .and_then(|o| self.accel.intersect(o, dir))
                .is_some_and(|h| h.mesh as usize == mesh && h.prim as usize == prim)
        };
        Coverage::new(self.scene, self.camera, &emitters, sees)
    }

    /// Uses `coverage` (built by `build_coverage` for this camera and scene) for the camera
    /// samples' control variate.
    pub fn set_coverage(&mut self, coverage: Arc<Coverage>) {
        self.coverage = coverage;
    }

    /// Radiance of mesh `mesh`'s emitting side seen along `dir` on triangle normal `ng`,
    /// with the emitter's index, area and the cosine at the emitter.
    #[inline]
    fn emission(&self, mesh: u32, ng: DVec3, dir: DVec3) -> Option<(usize, &[f64], f64, f64)> {
        let e = self.emitter_of_mesh[mesh as usize]? as usize;
        self.emission_of(e, ng, dir)
    }

    /// `emission` of emitter `e` (an emitting mesh; None for others).
    #[inline]
    fn emission_of(&self, e: usize, ng: DVec3, dir: DVec3) -> Option<(usize, &[f64], f64, f64)> {
        let cos = -dir.dot(ng);
        if cos <= 0.0 && !self.scene.emitters[e].two_sided() {
            return None;
        }
        match &self.lights[e] {
            LightValue::Radiance { radiance, area } => Some((e, radiance, *area, cos.abs())),
            LightValue::Power(_) => None,
        }
    }

    /// Traces one backward path through pixel `pixel` and appends its sample to `buf`:
    /// the direct luminance, and a backward photon if the path found a diffuse surface.
    /// `r2_pixel` is the pixel's current gathering radius² (0 before its first photon).
    #[allow(clippy::too_many_arguments)]
    pub fn trace(
        &self,
        pixel: u32,
        rng: &mut PhotonRng,
        r2_pixel: f64,
        probe: bool,
        buf: &mut SampleBuf,
        beta: &mut Vec<f64>,
        stats: &mut EyeStats,
        stop: &AtomicBool,
    ) {
        let nb = self.bands;
        let entry = buf.pixels.len() as u32;
        buf.pixels.push(pixel);
        let d0 = buf.direct.len();
        buf.direct.resize(d0 + nb, 0.0);
        let (mut dir, mut org) =
            match self.start_path(pixel, rng, beta, stats, &mut buf.direct[d0..d0 + nb]) {
                Ok(ray) => ray,
                // A ray that passes the whole scene by sees the sky.
                Err(Some(dir)) => return self.add_sky(dir, beta, &mut buf.direct[d0..]),
                Err(None) => return,
            };
        // The pixel's bands, until a fluorescent medium or surface picks one for the path.
        let mut out = PathOut {
            out: &mut buf.direct[d0..d0 + nb],
            arriving: Vec::new(),
            band: None,
        };
        let mut band: Option<usize> = None;
        let mut path_len = (org - self.camera.origin).length();
        // The dielectrics the path is inside (`medium` is the innermost's material).
        let mut media = self.camera_media.clone();
        let mut medium = media.current().map(|(_, m)| m);
        // Whether the path's last event was a scattering in the scene's medium.
        let mut after_haze = false;
        // The density of the last glossy reflector's direction, while the path has met
        // nothing since (emission it finds is weighed against that vertex's light sample).
        let mut glossy_pdf: Option<(f64, Receiver)> = None;
        let mut glossy_scratch = Vec::new();
        let mut tint = TintScratch::default();

        for event in 0..self.max_events {
            // A long specular chain must not hold up a stop (the phase is discarded then).
            if event % 256 == 255 && stop.load(Ordering::Relaxed) {
                return;
            }
            stats.rays += 1;
            let hit = self.accel.intersect(org, dir);
            let t = hit.map_or(f64::INFINITY, |h| h.t);
            let path = ((&mut dir, &mut org), beta.as_mut_slice());
            match self.through_medium((medium, &media), t, path, rng, (out.to(), stats)) {
                Flight::Surface => {}
                Flight::Absorbed => return,
                Flight::Scatter(t) => {
                    path_len += t;
                    glossy_pdf = None;
                    after_haze = medium.is_none();
                    continue;
                }
                Flight::Fluoresce(t, _) => {
                    let at = (medium, &media, org);
                    self.re_emit(at, beta, (&mut band, &mut out), rng, stats);
                    path_len += t;
                    glossy_pdf = None;
                    after_haze = false;
                    continue;
                }
            }
            let Some(hit) = hit else {
                // The sky (and the sun) seen directly or through specular surfaces (the sun
                // straight after a scattering in the scene's medium is its light sample's).
                self.add_distant_weighted(dir, beta, out.to(), after_haze, glossy_pdf);
                return;
            };
            after_haze = false;
            path_len += hit.t;
            let at = self.surface(&hit, dir);
            // Emission seen directly or through specular surfaces.
            self.add_emission_weighted(&hit, at.ng, dir, beta, out.to(), glossy_pdf);
            glossy_pdf = None;
            let (p_hit, n_in, eps) = (at.p, at.n_in, at.eps);
            let bsdf = self.bsdf_at(&hit, &mut tint);
            let (rho, tau) = (
                bsdf.albedo(Lobe::DiffuseReflection),
                bsdf.albedo(Lobe::DiffuseTransmission),
            );
            let pd = match self.surface_step(
                &at,
                bsdf,
                &mut dir,
                &mut org,
                (&mut medium, &mut media),
                (&mut band, &mut glossy_scratch),
                beta,
                rng,
            ) {
                Step::Specular => continue,
                Step::Glossy => {
                    let step = (&mut dir, &mut org, beta.as_mut_slice());
                    let to = out.to();
                    let surface = (&at, bsdf, media.current());
                    match self.glossy_step(surface, step, &mut glossy_scratch, rng, to, stats) {
                        Some(pdf) => {
                            glossy_pdf = Some(pdf);
                            continue;
                        }
                        None => return,
                    }
                }
                Step::End => return,
                Step::Diffuse(pd) => pd,
            };
            let Some(rho) =
                self.through_fluorescent((bsdf, rho), beta, (&mut band, &mut out.band), rng)
            else {
                return;
            };
            let out_band = out.band;
            // The first diffuse vertex: direct light here, and a backward photon.
            let p0 = buf.w_reflect.len();
            buf.w_reflect
                .extend(beta.iter().zip(rho).map(|(b, k)| b * k / (pd * PI)));
            if self.transmit {
                buf.w_transmit
                    .extend(beta.iter().zip(tau).map(|(b, k)| b * k / (pd * PI)));
            }
            let wt = self.transmit.then(|| &buf.w_transmit[p0..p0 + nb]);
            let wr = &buf.w_reflect[p0..p0 + nb];
            match out_band {
                None => {
                    let at = (p_hit, media.current());
                    self.direct_light(at, n_in, eps, wr, wt, rng, out.out, stats)
                }
                // After a fluorescent surface or medium: each band of the arriving light
                // counts into the pixel band the path picked.
                Some(j) => {
                    let at = (p_hit, n_in, eps, media.current());
                    out.out[j] += self.direct_arriving(at, (wr, wt), rng, stats);
                }
            }
            if self.fluorescent {
                buf.out_band
                    .push(out_band.map_or(super::bmap::NO_BAND, |j| j as u32));
            }
            let r2 = if r2_pixel > 0.0 {
                r2_pixel
            } else if self.initial_radius > 0.0 {
                self.initial_radius * self.initial_radius
            } else {
                let r = INITIAL_RADIUS_FOOTPRINTS * path_len * self.camera.pixel_angle();
                (r * r).max(eps * eps * 100.0)
            };
            buf.photons.push(BackwardPhoton {
                pos: p_hit.as_vec3(),
                r2: r2 as f32,
                n: n_in.as_vec3(),
                entry,
            });
            buf.coverage.push(if probe {
                self.coverage(pixel, p_hit, n_in, eps, r2.sqrt(), stats) as f32
            } else {
                f32::NAN
            });
            return;
        }
        stats.dropped += 1;
    }

    /// One sample of pixel `pixel`'s radiance by plain path tracing (no photons: the
    /// independent, unbiased reference `Context::path_trace` renders), added to `out` (per
    /// band). At each diffuse vertex the direct light is `direct_light`'s (a light sample
    /// and a BSDF sample, MIS-weighted); the path goes on by cosine sampling with Russian
    /// roulette. Emission and the sky count where a path meets them directly from the
    /// camera or through specular surfaces only (after a diffuse vertex without a specular
    /// one since, `direct_light` has them). Light from point-like lights and the sun through
    /// specular surfaces (caustics of delta lights) cannot be path traced and is missing.
    /// With `map`, a path ends at its second diffuse vertex on a recorded mesh with the
    /// map's light there (`reads` gets the vertices it read, with their errors), unless it
    /// reached that vertex from close by (`NEAR_READ_CELLS`): then at the next diffuse
    /// vertex not reached from close by, and at the fourth in any case.
    #[allow(clippy::too_many_arguments)]
    pub fn path_sample(
        &self,
        pixel: u32,
        rng: &mut PhotonRng,
        out: &mut [f64],
        beta: &mut Vec<f64>,
        scratch: &mut Vec<f64>,
        reads: &mut Vec<MapRead>,
        stats: &mut EyeStats,
    ) {
        let nb = self.bands;
        let (mut dir, mut org) = match self.start_path(pixel, rng, beta, stats, out) {
            Ok(ray) => ray,
            Err(Some(dir)) => return self.add_sky(dir, beta, out),
            Err(None) => return,
        };
        // Where the path's light goes: each band into its own pixel band, until a
        // fluorescent surface picks one pixel band for all the arriving light's bands.
        let mut out = PathOut {
            out,
            arriving: Vec::new(),
            band: None,
        };
        let mut band: Option<usize> = None;
        // The dielectrics the path is inside (`medium` is the innermost's material).
        let mut media = self.camera_media.clone();
        let mut medium = media.current().map(|(_, m)| m);
        // Whether emission met now is counted: before the first diffuse vertex, or through
        // specular surfaces since the last one.
        let mut counts = true;
        let mut diffuse_vertices = 0u32;
        // As in `trace`: the last glossy reflector's density, straight after it.
        let mut glossy_pdf: Option<(f64, Receiver)> = None;
        let mut glossy_scratch = Vec::new();
        let mut tint = TintScratch::default();
        // Whether the path has left a glossy reflector: the sun through specular surfaces
        // behind it is then the caustic photons' too (they splat at glossy reflectors).
        let mut after_glossy = false;
        // Whether the path's last event was a scattering in the scene's medium.
        let mut after_haze = false;
        for _ in 0..self.max_events {
            stats.rays += 1;
            let hit = self.accel.intersect(org, dir);
            let t = hit.map_or(f64::INFINITY, |h| h.t);
            let path = ((&mut dir, &mut org), beta.as_mut_slice());
            match self.through_medium((medium, &media), t, path, rng, (out.to(), stats)) {
                Flight::Surface => {}
                Flight::Absorbed => return,
                Flight::Fluoresce(..) => {
                    // Re-emitted light: as after a scattering (there is no haze to
                    // fluoresce, so no light sample took the lights no path meets).
                    let at = (medium, &media, org);
                    self.re_emit(at, beta, (&mut band, &mut out), rng, stats);
                    counts = true;
                    glossy_pdf = None;
                    after_haze = false;
                    continue;
                }
                Flight::Scatter(_) => {
                    // Light met after a scattering event is found by this path alone (a
                    // light sample cannot cross the dielectric's surface), but for the
                    // lights no path meets and the sun, after a scattering in the scene's
                    // medium: their light samples there have them.
                    counts = true;
                    glossy_pdf = None;
                    after_haze = medium.is_none();
                    continue;
                }
            }
            let Some(hit) = hit else {
                if counts {
                    // The sun through specular surfaces after a diffuse vertex is the
                    // caustic photons'; straight after a glossy reflector, its light
                    // sample's and this direction's (weighed); straight after a scattering
                    // in the scene's medium, its light sample's there.
                    let no_sun = after_haze
                        || ((diffuse_vertices > 0 || after_glossy)
                            && self.sun_by_caustics
                            && glossy_pdf.is_none());
                    self.add_distant_weighted(dir, beta, out.to(), no_sun, glossy_pdf);
                }
                return;
            };
            after_haze = false;
            let at = self.surface(&hit, dir);
            if counts {
                self.add_emission_weighted(&hit, at.ng, dir, beta, out.to(), glossy_pdf);
            }
            glossy_pdf = None;
            let (p_hit, n_in, eps, front) = (at.p, at.n_in, at.eps, at.front);
            let bsdf = self.bsdf_at(&hit, &mut tint);
            let (rho, tau) = (
                bsdf.albedo(Lobe::DiffuseReflection),
                bsdf.albedo(Lobe::DiffuseTransmission),
            );
            let pd = match self.surface_step(
                &at,
                bsdf,
                &mut dir,
                &mut org,
                (&mut medium, &mut media),
                (&mut band, &mut glossy_scratch),
                beta,
                rng,
            ) {
                Step::Specular => {
                    counts = true;
                    continue;
                }
                Step::Glossy => {
                    let step = (&mut dir, &mut org, beta.as_mut_slice());
                    match self.glossy_step(
                        (&at, bsdf, media.current()),
                        step,
                        &mut glossy_scratch,
                        rng,
                        out.to(),
                        stats,
                    ) {
                        Some(pdf) => {
                            glossy_pdf = Some(pdf);
                            counts = true;
                            after_glossy = true;
                            continue;
                        }
                        None => return,
                    }
                }
                Step::End => return,
                Step::Diffuse(pd) => pd,
            };
            let Some(rho) =
                self.through_fluorescent((bsdf, rho), beta, (&mut band, &mut out.band), rng)
            else {
                return;
            };
            if out.band.is_some() && out.arriving.is_empty() {
                out.arriving.resize(nb, 0.0);
            }
            // A diffuse vertex: its direct light, then on by cosine sampling.
            scratch.clear();
            scratch.extend(beta.iter().zip(rho).map(|(b, k)| b * k / (pd * PI)));
            scratch.extend(beta.iter().zip(tau).map(|(b, k)| b * k / (pd * PI)));
            let (wr, wt) = scratch.split_at(nb);
            let wt = (self.transmit && wt.iter().any(|&x| x > 0.0)).then_some(wt);
            // The second diffuse vertex on a recorded mesh: the map's light here, and the end.
            let side = if front { 0 } else { 1 };
            // Not where the path came from close by (a corner): there the map's
            // hat-averaged values, interpolated, miss a kink in the irradiance within a
            // cell, and the path goes on to read the map further away (at most twice).
            let read = diffuse_vertices >= 1
                && self.map_has(hit.mesh, side, wt.is_some())
                && (diffuse_vertices >= MAP_READ_BY || {
                    let area = self.scene.meshes[hit.mesh as usize].area(hit.prim as usize);
                    hit.t >= NEAR_READ_CELLS * (2.0 * area).sqrt()
                });
            if !read || !self.map.is_some_and(|m| m.combined) {
                let at = (p_hit, media.current());
                self.direct_light(at, n_in, eps, wr, wt, rng, out.to(), stats);
            }
            if read {
                let (prim, uv) = (hit.prim as usize, (hit.u, hit.v));
                self.map_read(hit.mesh, prim, uv, side, wr, wt, out.to(), reads);
                return;
            }
            let sr: f64 = (0..nb).map(|b| beta[b] * rho[b]).sum();
            let st: f64 = (0..nb).map(|b| beta[b] * tau[b]).sum();
            let reflect_side = rng.uniform() * (sr + st) < sr;
            let (lobe, p_side) = if reflect_side {
                (Lobe::DiffuseReflection, sr / (sr + st))
            } else {
                (Lobe::DiffuseTransmission, st / (sr + st))
            };
            for (b, k) in beta.iter_mut().zip(if reflect_side { rho } else { tau }) {
                *b *= k / (pd * p_side);
            }
            let n = lobe.leaving_normal(n_in);
            dir = lobe.direction(dir, n_in, rng.uniform(), rng.uniform());
            org = p_hit + n * eps;
            if lobe == Lobe::DiffuseTransmission {
                // Through a translucent triangle from inside a dielectric: out of its medium
                // (the photons check that the triangle is the dielectric's own mesh; eye
                // paths take every translucent surface met inside a medium as its boundary).
                if let Some((mesh, material)) = media.current() {
                    media.cross(mesh, material, false);
                }
                medium = media.current().map(|(_, m)| m);
            }
            counts = false;
            diffuse_vertices += 1;
            // Russian roulette after two diffuse vertices, by the path's largest weight.
            if diffuse_vertices >= 2 {
                let q = beta.iter().cloned().fold(0.0, f64::max).min(0.95);
                if q <= 0.0 || rng.uniform() >= q {
                    return;
                }
                beta.iter_mut().for_each(|b| *b /= q);
            }
        }
        stats.dropped += 1;
    }

    /// The share of the disc of radius `r` about `p` (normal `n`, ray offset `eps`) that its
    /// surface covers — where photons can land to be gathered. Rays along the surface in
    /// `COVERAGE_RAYS` stratified directions (randomly turned, from a stream of the pixel
    /// and the radius: the path's own random numbers are left alone) stop at a wall (a
    /// surface the gathering would not take photons from: normals less alike than
    /// `SAME_SURFACE_COS`); one that meets a surface like its own (a concave surface curving
    /// up) counts whole; one that meets nothing looks for the surface under its end (down to
    /// r: a convex surface falls away by r²/2R) and, if there is none (an open edge), under
    /// points bisected toward the centre. The disc's area is Σ (π/M) tᵢ², its share
    /// Σ (tᵢ/r)²/M.
    fn coverage(
        &self,
        pixel: u32,
        p: DVec3,
        n: DVec3,
        eps: f64,
        r: f64,
        stats: &mut EyeStats,
    ) -> f64 {
        const COVERAGE_RAYS: usize = 8;
        if r <= 4.0 * eps {
            return 1.0;
        }
        let same = super::bmap::SAME_SURFACE_COS as f64;
        let t1 = n.any_orthonormal_vector();
        let t2 = n.cross(t1);
        let mut rng = PhotonRng::new(0xC0E5_A6E0_0000_0007 ^ pixel as u64, r.to_bits());
        let turn = rng.uniform();
        let lift = p + n * (2.0 * eps);
        let mut rays = 0u64;
        // Whether a surface is under the point `t` along `d`.
        let mut under = |d: DVec3, t: f64| {
            rays += 1;
            self.accel.occluded(lift + d * t, -n, r)
        };
        let mut share = 0.0;
        for i in 0..COVERAGE_RAYS {
            let a = 2.0 * PI * (i as f64 + turn) / COVERAGE_RAYS as f64;
            let d = t1 * a.cos() + t2 * a.sin();
            let mut t = r;
            let mut open = true;
            if let Some(h) = self.accel.intersect(lift, d) {
                if h.t < r {
                    let nh = self.scene.meshes[h.mesh as usize].normals[h.prim as usize].as_dvec3();
                    if nh.dot(n).abs() <= same {
                        t = h.t;
                    }
                    open = false;
                }
            }
            if open && !under(d, r) {
                let (mut lo, mut hi) = (0.0, r);
                for _ in 0..3 {
                    let mid = 0.5 * (lo + hi);
                    if under(d, mid) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                t = lo;
            }
            share += (t / r).powi(2);
        }
        stats.rays += COVERAGE_RAYS as u64 + rays;
        share / COVERAGE_RAYS as f64
    }

    /// A caustic photon of colour `colour` (W per band: each value times `flux`) at surface
    /// event `ev` (arriving along `ev.dir` at `ev.point`, normal `ev.n_in` on its side),
    /// seen by the camera: the pixel that sees the point and what the landing adds to its
    /// radiance — the diffuse reflection (or transmission), or a glossy surface's f toward
    /// the eye (through it when it transmits), spread over the pixel's footprint. None when
    /// the camera does not see the point.
    pub(crate) fn caustic_splat(
        &self,
        ev: &SurfaceEvent,
        colour: &[f64],
        flux: f64,
    ) -> Option<(u32, Vec<f64>)> {
        let (z, n_in, m) = (ev.point, ev.n_in, ev.material);
        let to = self.camera.origin - z;
        let dist = to.length();
        if dist <= 0.0 {
            return None;
        }
        let dir = to / dist;
        let c = dir.dot(n_in);
        let bsdf = m.bsdf();
        if let Some(g) = bsdf.glossy() {
            // A glossy surface: f (arriving → the camera) in place of k/π.
            if (-ev.dir).dot(n_in) <= 0.0 || c == 0.0 || (c < 0.0 && !g.transmits()) {
                return None;
            }
            let n_cam = if c > 0.0 { n_in } else { -n_in };
            let (pixel, den) = self.splat_at(z, n_cam, dir, dist)?;
            let mut f = vec![0.0; colour.len()];
            let front_cam = if c > 0.0 { ev.front } else { !ev.front };
            bsdf.eval_toward(n_cam, front_cam, -ev.dir, dir, &mut f);
            let k = c.abs() / den * flux;
            return Some((
                pixel,
                colour.iter().zip(&f).map(|(c, f)| c * f * k).collect(),
            ));
        }
        let (k, n) = if c > 0.0 {
            (bsdf.albedo(Lobe::DiffuseReflection), n_in)
        } else if bsdf.has(Lobe::DiffuseTransmission) {
            (bsdf.albedo(Lobe::DiffuseTransmission), -n_in)
        } else {
            return None;
        };
        let (pixel, den) = self.splat_at(z, n, dir, dist)?;
        // Radiance over the pixel: (k/π) Φ cos θz / (d² · the pixel's solid angle toward
        // z; a pinhole's pixel: cos³ θc times its area at unit distance), d in metres.
        let g = c.abs() / den / PI * flux;
        if let Some(fl) = bsdf.fluorescence() {
            // What a fluorescent surface sends on: reflected and re-emitted light.
            let (mut out, mut re) = (vec![0.0; colour.len()], vec![0.0; colour.len()]);
            fl.send_on(k, colour, &mut out, &mut re);
            return Some((pixel, out.iter().map(|x| x * g).collect()));
        }
        Some((
            pixel,
            colour.iter().zip(k).map(|(c, k)| c * k * g).collect(),
        ))
    }

    /// The pixel that sees `z` (leaving on the side of normal `n` toward the camera along
    /// `dir`, `dist` away) with nothing in between, and a splat's denominator there:
    /// d² · the pixel's solid angle toward `z` (`Camera::project`), d in metres.
    #[inline]
    fn splat_at(&self, z: DVec3, n: DVec3, dir: DVec3, dist: f64) -> Option<(u32, f64)> {
        let (pixel, density, area) = self.camera.project(z)?;
        let eps = self.scene.offset_at(z);
        if dist <= eps || self.accel.occluded(z + n * eps, dir, dist - eps) {
            return None;
        }
        let d_m = dist * self.unit_m;
        Some((pixel, d_m * d_m * density * area))
    }

    /// Whether the map holds light for side `side` of mesh `mesh` (and the other side too
    /// when `both`, for diffuse transmission).
    fn map_has(&self, mesh: u32, side: usize, both: bool) -> bool {
        let Some(m) = self
            .map
            .and_then(|map| map.meshes.get(mesh as usize))
            .and_then(Option::as_ref)
        else {
            return false;
        };
        side < m.sides && (!both || 1 - side < m.sides)
    }

    /// Adds the map's light at barycentric (u, v) of triangle `prim` of mesh `mesh` to
    /// `out`: the reflected part (weights `wr`) from side `side`, the transmitted part
    /// (`wt`) from the other. `reads` gets each vertex read and its error in `out`'s
    /// band-mean units (`MapRead`). The caller checked `map_has`.
    #[allow(clippy::too_many_arguments)]
    fn map_read(
        &self,
        mesh: u32,
        prim: usize,
        (u, v): (f32, f32),
        side: usize,
        wr: &[f64],
        wt: Option<&[f64]>,
        out: &mut [f64],
        reads: &mut Vec<MapRead>,
    ) {
        let Some(m) = self
            .map
            .and_then(|map| map.meshes.get(mesh as usize))
            .and_then(Option::as_ref)
        else {
            return;
        };
        let nb = self.bands;
        let tri = self.scene.meshes[mesh as usize].triangles[prim];
        let (u, v) = (u as f64, v as f64);
        let bary = [1.0 - u - v, u, v];
        let sides = [Some((side, wr)), wt.map(|w| (1 - side, w))];
        for (s, w) in sides.into_iter().flatten() {
            for (k, &vert) in tri.iter().enumerate() {
                let slot = vert as usize * m.sides + s;
                let mut c = 0.0;
                for ((o, w), e) in out
                    .iter_mut()
                    .zip(w)
                    .zip(&m.irradiance[slot * nb..(slot + 1) * nb])
                {
                    let x = bary[k] * w * e;
                    *o += x;
                    c += x;
                }
                reads.push(MapRead {
                    key: ((mesh as u64) << 40) | slot as u64,
                    sigma: c / nb as f64 * m.rel_error[slot],
                });
            }
        }
    }

    /// The scattering at `hit`: its material's, tinted where its coefficients vary.
    #[inline]
    fn bsdf_at<'s>(&'s self, hit: &crate::accel::Hit, tint: &'s mut TintScratch) -> Bsdf<'s> {
        let (prim, uv) = (hit.prim as usize, (hit.u, hit.v));
        self.scene
            .material_at(self.materials, hit.mesh, prim, uv, tint)
            .bsdf()
    }

    /// The surface an eye path travelling along `dir` meets at `hit`.
    #[inline]
    fn surface(&self, hit: &crate::accel::Hit, dir: DVec3) -> Surface {
        let mesh = &self.scene.meshes[hit.mesh as usize];
        let prim = hit.prim as usize;
        let ng = mesh.normals[prim].as_dvec3();
        let front = dir.dot(ng) < 0.0;
        let (p, eps) = self.scene.leaving_point(mesh, prim, hit.u, hit.v);
        Surface {
            p,
            ng,
            n_in: if front { ng } else { -ng },
            eps,
            front,
            mesh: hit.mesh,
            material: mesh.material(prim),
        }
    }

    /// The emission of mesh `mesh` (normal `ng`) seen along `dir`, times `beta`, added to
    /// `out` (nothing when it does not emit toward `dir`).
    #[inline]
    fn add_emission(&self, mesh: u32, ng: DVec3, dir: DVec3, beta: &[f64], out: &mut [f64]) {
        if let Some((_, radiance, _, _)) = self.emission(mesh, ng, dir) {
            for ((o, b), l) in out.iter_mut().zip(beta).zip(radiance) {
                *o += b * l;
            }
        }
    }

    /// `add_emission` for a ray that hit `hit`, weighed against the light sample of the
    /// glossy reflector it left when `glossy_pdf` is its density (power heuristic).
    #[inline]
    fn add_emission_weighted(
        &self,
        hit: &crate::accel::Hit,
        ng: DVec3,
        dir: DVec3,
        beta: &[f64],
        out: &mut [f64],
        glossy_pdf: Option<(f64, Receiver)>,
    ) {
        let Some((pb, _)) = glossy_pdf else {
            return self.add_emission(hit.mesh, ng, dir, beta, out);
        };
        if let Some((e, radiance, area, cos_l)) = self.emission(hit.mesh, ng, dir) {
            if cos_l <= 0.0 {
                return;
            }
            let pl = self.scene.emitter_table.pdf(e) * hit.t * hit.t / (area * cos_l);
            let w = pb * pb / (pb * pb + pl * pl);
            for ((o, b), l) in out.iter_mut().zip(beta).zip(radiance) {
                *o += b * l * w;
            }
        }
    }

    /// `add_distant`, each source weighed against a glossy reflector's light sample when
    /// `glossy_pdf` is the density the direction was drawn with.
    #[inline]
    fn add_distant_weighted(
        &self,
        dir: DVec3,
        beta: &[f64],
        out: &mut [f64],
        no_sun: bool,
        glossy_pdf: Option<(f64, Receiver)>,
    ) {
        let Some((pb, receiver)) = glossy_pdf else {
            return self.add_distant(dir, beta, out, no_sun);
        };
        // The glossy surface's light samples (`glossy_step`'s `Receiver`) draw `dir` with
        // the emitter's pick times its direction density.
        for (e, part) in &self.distant {
            let f = part.value(dir);
            if f <= 0.0 {
                continue;
            }
            let q = self.scene.emitters[*e].direction_density(dir, receiver);
            let pl = self.scene.emitter_table.pdf(*e) * q;
            let w = pb * pb / (pb * pb + pl * pl);
            for ((o, b), l) in out.iter_mut().zip(beta).zip(&part.per_band) {
                *o += b * l * f * w;
            }
        }
    }

    /// At a glossy surface `at` of scattering `bsdf` (tinted where a texture varies it: a
    /// reflector, or a table, window or host BSDF that also transmits): its direct light (one light sample weighed by f, from either side when
    /// it transmits, against the BSDF's own density by the power heuristic; point-like
    /// lights and beams by the light sample alone), added to `out`; then the path goes on
    /// by the BSDF's sampling (`dir`, `org`, `beta` × f cos / pdf, f read the way light
    /// travels: from the drawn direction toward the eye). Returns the density of that
    /// direction and the light samples' receiver, for the weight of the light it meets
    /// next; None when the path ends.
    fn glossy_step(
        &self,
        (at, bsdf, inside): (&Surface, Bsdf, Inside),
        (dir, org, beta): (&mut DVec3, &mut DVec3, &mut [f64]),
        f: &mut Vec<f64>,
        rng: &mut PhotonRng,
        out: &mut [f64],
        stats: &mut EyeStats,
    ) -> Option<(f64, Receiver)> {
        let g = bsdf.glossy().expect("a glossy surface");
        let n_in = at.n_in;
        let frame = bsdf.frame(n_in);
        let to_eye = -*dir;
        let wo = frame.to_local(to_eye);
        let nb = self.bands;
        f.resize(nb, 0.0);
        let p = at.p;
        let transmits = g.transmits();
        // Shadow rays leave from the side of the light they aim at.
        let lift = |toward: DVec3| {
            if toward.dot(n_in) >= 0.0 {
                p + n_in * at.eps
            } else {
                p - n_in * at.eps
            }
        };
        let table = &self.scene.emitter_table;

        // Light sampling.
        let e = table.sample(rng.uniform());
        let pe = table.pdf(e);
        let em = &self.scene.emitters[e];
        let u = [rng.uniform(), rng.uniform(), rng.uniform()];
        let receiver = Receiver {
            n: n_in,
            p_front: if transmits { 0.5 } else { 1.0 },
        };
        let power = |e: usize| match &self.lights[e] {
            LightValue::Power(power) => power.as_slice(),
            LightValue::Radiance { .. } => &[][..],
        };
        let sample = em.sample_toward(&self.scene.meshes, p, receiver, u, || true);
        let mut add = |wi: DVec3, k: f64, per_band: &[f64], light_pdf: Option<f64>, tr: Tr| {
            let cos = wi.dot(n_in);
            if (cos <= 0.0 && !transmits) || cos == 0.0 || k <= 0.0 {
                return;
            }
            bsdf.eval_toward(n_in, at.front, wi, to_eye, f);
            let w = light_pdf.map_or(1.0, |pl| {
                let pb = g.pdf(wo, frame.to_local(wi), 0, at.front);
                pl * pl / (pl * pl + pb * pb)
            });
            let k = cos.abs() * k * w;
            for (b, (((o, bt), fb), l)) in out
                .iter_mut()
                .zip(beta.iter())
                .zip(f.iter())
                .zip(per_band)
                .enumerate()
            {
                *o += bt * fb * l * k * tr.at(b);
            }
        };
        match sample {
            None => {}
            Some(LightSample::Beam { axis, area, .. }) => {
                let wi = -axis;
                let from = lift(wi);
                let dist = (from - em.position).dot(axis);
                stats.rays += 1;
                if dist > 0.0 && !self.accel.occluded(from, wi, dist) {
                    add(
                        wi,
                        1.0 / (area * self.unit_m * self.unit_m * pe),
                        power(e),
                        None,
                        self.light_tr(e, inside, from, wi, dist),
                    );
                }
            }
            Some(LightSample::Point(y)) => {
                let from = lift(y - p);
                let to = y - from;
                let d2 = to.length_squared();
                let d = d2.sqrt();
                let wi = to / d;
                let per_watt = em.intensity_per_watt(-wi);
                stats.rays += 1;
                let facing = transmits || wi.dot(n_in) > 0.0;
                if per_watt > 0.0 && facing && !self.accel.occluded(from, wi, d) {
                    let k = per_watt / (d2 * self.unit_m * self.unit_m * pe);
                    add(wi, k, power(e), None, self.light_tr(e, inside, from, wi, d));
                }
            }
            Some(LightSample::Area { point: q, normal }) => {
                let from = lift(q - p);
                let to = q - from;
                let d2 = to.length_squared();
                let d = d2.sqrt();
                let wi = to / d;
                if let Some((_, radiance, area, _)) = self.emission_of(e, normal, wi) {
                    let cos_l = wi.dot(normal).abs();
                    let t_max = d - 2.0 * self.scene.offset_at(q);
                    stats.rays += 1;
                    if cos_l > 0.0 && t_max > 0.0 && !self.accel.occluded(from, wi, t_max) {
                        let pl = pe * d2 / (area * cos_l);
                        add(
                            wi,
                            1.0 / pl,
                            radiance,
                            Some(pl),
                            self.light_tr(e, inside, from, wi, t_max),
                        );
                    }
                }
            }
            Some(LightSample::Direction {
                toward,
                pdf: q,
                value: fv,
                reach,
                norm,
            }) => {
                stats.rays += 1;
                let from = lift(toward);
                if fv > 0.0 && q > 0.0 && !self.accel.occluded(from, toward, reach) {
                    let cross = norm * self.unit_m * self.unit_m;
                    let tr = self.light_tr(e, inside, from, toward, f64::INFINITY);
                    add(toward, fv / (q * cross * pe), power(e), Some(q * pe), tr);
                }
            }
        }

        // The path goes on: f read from the drawn direction toward the eye.
        let u = [rng.uniform(), rng.uniform(), rng.uniform()];
        let (wi, pdf) = bsdf.sample_against_light(n_in, at.front, to_eye, u, f)?;
        let mut any = false;
        for (b, w) in beta.iter_mut().zip(f.iter()) {
            *b *= w;
            any |= *b > 0.0;
        }
        if !any {
            return None;
        }
        *dir = wi;
        *org = lift(wi);
        Some((pdf, receiver))
    }

    /// A new eye path through `pixel`: unit weight in every band, counted, and its first
    /// ray (its direction alone when it passes the scene's bounding sphere by; none where
    /// a fisheye's pixel sees nothing). The
    /// emitters' coverage control for this ray goes into `out` (`coverage.rs`).
    #[inline]
    fn start_path(
        &self,
        pixel: u32,
        rng: &mut PhotonRng,
        beta: &mut Vec<f64>,
        stats: &mut EyeStats,
        out: &mut [f64],
    ) -> Result<(DVec3, DVec3), Option<DVec3>> {
        beta.clear();
        beta.resize(self.bands, 1.0);
        stats.paths += 1;
        let ray = self.camera_ray(pixel, rng);
        if let (false, Ok((dir, _)) | Err(Some(dir))) = (self.coverage.is_empty(), ray) {
            self.coverage.terms(pixel, self.camera.origin, dir, |e, w| {
                if let LightValue::Radiance { radiance, .. } = &self.lights[e as usize] {
                    for (o, l) in out.iter_mut().zip(radiance) {
                        *o += w * l;
                    }
                }
            });
        }
        ray
    }

    /// A camera ray through `pixel` (jittered) and where it starts: at the camera, or where
    /// it enters the bounding sphere of a scene far away (Err with its direction: it misses
    /// the sphere, and sees only what is infinitely far; Err(None) where a fisheye's pixel
    /// sees nothing).
    #[inline]
    fn camera_ray(&self, pixel: u32, rng: &mut PhotonRng) -> Result<(DVec3, DVec3), Option<DVec3>> {
        let w = self.camera.desc.width;
        let dir = self
            .camera
            .ray(pixel % w, pixel / w, rng.uniform(), rng.uniform())
            .ok_or(None)?;
        self.scene
            .enter(self.camera.origin, dir)
            .map(|o| (dir, o))
            .ok_or(Some(dir))
    }

    /// The radiance of the distant sources along `dir`, times `beta`, added to `out`.
    #[inline]
    fn add_sky(&self, dir: DVec3, beta: &[f64], out: &mut [f64]) {
        self.add_distant(dir, beta, out, false);
    }

    /// `add_sky`, leaving the sun's disk out when `no_sun`.
    #[inline]
    fn add_distant(&self, dir: DVec3, beta: &[f64], out: &mut [f64], no_sun: bool) {
        for (_, part) in &self.distant {
            if no_sun && part.is_sun() {
                continue;
            }
            let f = part.value(dir);
            if f > 0.0 {
                for ((o, b), l) in out.iter_mut().zip(beta).zip(&part.per_band) {
                    *o += b * l * f;
                }
            }
        }
    }

    /// An eye path's segment toward a surface `t` scene units away inside `medium` (a
    /// dielectric's id; None: air): a scattering medium's free flight, which may end before
    /// the surface (`Flight::Scatter` with the distance in scene units: the path is then
    /// moved there and turned by the phase function), or Beer–Lambert attenuation.
    /// In the scene's medium (`medium` None with one: the part of the segment in its ball;
    /// `t` infinite, out of the scene, to the ball's edge), a scattering point takes a
    /// light sample of the lights no path meets (`haze_light`) into `out` before the path
    /// turns. Inside a mesh with no surface ahead (a crack: `t` infinite) the path leaves
    /// untouched.
    #[inline(always)]
    fn through_medium(
        &self,
        (medium, media): (Option<u32>, &MediumStack),
        t: f64,
        path: ((&mut DVec3, &mut DVec3), &mut [f64]),
        rng: &mut PhotonRng,
        out: (&mut [f64], &mut EyeStats),
    ) -> Flight {
        if medium.is_none() && self.scene.haze.is_none() {
            return Flight::Surface;
        }
        self.through_some_medium((medium, media), t, path, rng, out)
    }

    /// `through_medium` in a medium (out of line: the paths of most scenes meet none).
    #[inline(never)]
    fn through_some_medium(
        &self,
        (medium, media): (Option<u32>, &MediumStack),
        t: f64,
        ((dir, org), beta): ((&mut DVec3, &mut DVec3), &mut [f64]),
        rng: &mut PhotonRng,
        (out, stats): (&mut [f64], &mut EyeStats),
    ) -> Flight {
        let (d, t0, t) = match (medium, self.scene.haze.as_ref()) {
            (Some(_), _) if t == f64::INFINITY => return Flight::Surface,
            (Some(m), _) => (self.materials[m as usize].dielectric.as_ref(), 0.0, t),
            (None, Some(h)) => {
                let (t0, t1) = h.span(*org, *dir, t);
                let d = self.materials[h.material as usize].dielectric.as_ref();
                (d, t0, t1 - t0)
            }
            (None, None) => return Flight::Surface,
        };
        let Some(d) = d else {
            return Flight::Surface;
        };
        if let Some(sc) = &d.scattering {
            let u = [rng.uniform(), rng.uniform(), rng.uniform()];
            let flight = sc.eye_flight(beta, t * self.unit_m, u);
            if let Flight::Fluoresce(t_m, k) = flight {
                // (Only a mesh's medium fluoresces: the scene's may not.)
                let t = t0 + t_m / self.unit_m;
                *org += *dir * t;
                *dir = crate::sampling::warp::uniform_sphere(rng.uniform(), rng.uniform());
                return Flight::Fluoresce(t, k);
            }
            if let Flight::Scatter(t_m) = flight {
                let t = t0 + t_m / self.unit_m;
                *org += *dir * t;
                if medium.is_none() {
                    let outside = MediumStack::default();
                    self.haze_light((*org, &outside), (*dir, false), sc, beta, rng, out, stats);
                } else if self.lights_in_media || self.index_matched {
                    // In a mesh's medium: the lights inside the mesh, and those behind
                    // surfaces of matched index (others are behind a surface that bends
                    // their light, and their shadow rays end there).
                    self.haze_light((*org, media), (*dir, false), sc, beta, rng, out, stats);
                }
                let u = [rng.uniform(), rng.uniform(), rng.uniform()];
                *dir = sc.scatter(*dir, beta, u);
                return Flight::Scatter(t);
            }
            return flight;
        }
        if let Some(alpha) = &d.absorption_per_m {
            let dist_m = t * self.unit_m;
            for (b, a) in beta.iter_mut().zip(alpha) {
                *b *= (-a * dist_m).exp();
            }
        }
        Flight::Surface
    }

    /// The transmittance of emitter `e`'s light on a shadow ray from `org` along unit `dir`
    /// over `t` scene units, from a path inside the mesh `inside` (mesh, medium material;
    /// None: outside every mesh): the mesh's scattering medium's, e^(−σt d), when the
    /// light is inside that mesh too (an unoccluded ray then never left it); else the
    /// scene medium's (`haze_tr`).
    #[inline(always)]
    fn light_tr(&self, e: usize, inside: Inside, org: DVec3, dir: DVec3, t: f64) -> Tr<'_> {
        match inside {
            Some(at) if self.lights_in_media => self.held_light_tr(e, at, (org, dir, t)),
            _ => self.haze_tr(org, dir, t),
        }
    }

    /// `light_tr` from inside mesh `mesh` (medium `material`) in a scene with lights in
    /// media (out of line: most scenes have none).
    #[cold]
    #[inline(never)]
    fn held_light_tr(
        &self,
        e: usize,
        (mesh, material): (u32, u32),
        (org, dir, t): (DVec3, DVec3, f64),
    ) -> Tr<'_> {
        let held = self.scene.emitters[e].media.last().map(|h| h.0);
        match self.materials[material as usize].extinction() {
            Some(sigma) if held == Some(mesh) => Tr {
                sigma,
                d_m: t * self.unit_m,
            },
            _ => self.haze_tr(org, dir, t),
        }
    }

    /// The scene medium's transmittance on the segment from `org` along unit `dir` over `t`
    /// scene units (infinite: out of the scene): 1 in every band without one.
    #[inline]
    fn haze_tr(&self, org: DVec3, dir: DVec3, t: f64) -> Tr<'_> {
        self.scene
            .haze
            .as_ref()
            .map_or(Tr::CLEAR, |h| h.transmittance(org, dir, t, self.unit_m))
    }

    /// At a scattering point `p` of an eye path travelling along `dir` in the scene's
    /// medium `sc` (weights `beta`, the collision's already in them): one light sample of
    /// the lights no path can meet — points, spots, beams, luminaires and the sun — times
    /// the phase function toward the eye and the medium's transmittance, added to `out`.
    /// Emitting meshes and skies are left to the path, which meets them after the
    /// scattering (the light picked is then skipped: the pick's density divides the rest).
    #[cold]
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn haze_light(
        &self,
        (p, media): (DVec3, &MediumStack),
        (dir, re_emitted): (DVec3, bool),
        sc: &crate::scene::medium::Scattering,
        beta: &[f64],
        rng: &mut PhotonRng,
        out: &mut [f64],
        stats: &mut EyeStats,
    ) {
        let table = &self.scene.emitter_table;
        let e = table.sample(rng.uniform());
        let pe = table.pdf(e);
        let em = &self.scene.emitters[e];
        let u = [rng.uniform(), rng.uniform(), rng.uniform()];
        let u_side = rng.uniform();
        let LightValue::Power(power) = &self.lights[e] else {
            return;
        };
        let sun = match &em.kind {
            crate::scene::emitter::EmitterKind::Light(_) => false,
            crate::scene::emitter::EmitterKind::Distant { part, .. } if part.is_sun() => true,
            _ => return,
        };
        // (No surface here: the receiver's normal only shapes a luminaire's sampling.)
        let receiver = Receiver {
            n: -dir,
            p_front: 0.5,
        };
        let sample = em.sample_toward(&self.scene.meshes, p, receiver, u, || u_side < 0.5);
        let unit2 = self.unit_m * self.unit_m;
        let inside = media.current();
        // A point-like light: its direction, weight and distance (the sun's: infinite).
        let (wi, k, dist) = match sample {
            Some(LightSample::Beam { axis, area, .. }) if !sun => {
                let dist = (p - em.position).dot(axis);
                if dist <= 0.0 {
                    return;
                }
                (-axis, 1.0 / (area * unit2 * pe), dist)
            }
            Some(LightSample::Point(y)) if !sun => {
                let to = y - p;
                let d = to.length();
                if d.is_nan() || d <= 0.0 {
                    return;
                }
                let wi = to / d;
                let per_watt = em.intensity_per_watt(-wi);
                if per_watt <= 0.0 {
                    return;
                }
                (wi, per_watt / (d * d * unit2 * pe), d)
            }
            Some(LightSample::Direction {
                toward,
                pdf: q,
                value: f,
                reach,
                norm,
            }) if sun => {
                if f <= 0.0 || q <= 0.0 {
                    return;
                }
                stats.rays += 1;
                if self.accel.occluded(p, toward, reach) {
                    return;
                }
                let k = f / (q * norm * unit2 * pe);
                let tr = self.light_tr(e, inside, p, toward, f64::INFINITY);
                let cos = toward.dot(dir);
                return self.add_scattered(
                    sc,
                    (cos, re_emitted),
                    (beta, power),
                    k,
                    |b| tr.at(b),
                    out,
                );
            }
            _ => return,
        };
        if self.index_matched {
            // Through surfaces of matched index (a fog box's index-1 walls), each segment
            // by its own medium.
            let Some(tr) = self.shadow_through(p, wi, dist, media, stats) else {
                return;
            };
            self.add_scattered(
                sc,
                (wi.dot(dir), re_emitted),
                (beta, power),
                k,
                |b| tr[b],
                out,
            );
        } else {
            stats.rays += 1;
            if self.accel.occluded(p, wi, dist) {
                return;
            }
            let tr = self.light_tr(e, inside, p, wi, dist);
            self.add_scattered(
                sc,
                (wi.dot(dir), re_emitted),
                (beta, power),
                k,
                |b| tr.at(b),
                out,
            );
        }
    }

    /// Adds a medium's light sample to `out`: per band, the path's weight, the phase
    /// function at `cos` between the light's travel and the eye's (isotropic for a
    /// re-emission), the light's power, `k` and the transmittance `tr`.
    #[inline]
    fn add_scattered(
        &self,
        sc: &crate::scene::medium::Scattering,
        (cos, re_emitted): (f64, bool),
        (beta, power): (&[f64], &[f64]),
        k: f64,
        tr: impl Fn(usize) -> f64,
        out: &mut [f64],
    ) {
        for (b, ((o, bt), pw)) in out.iter_mut().zip(beta).zip(power).enumerate() {
            let phase = if re_emitted {
                0.25 / std::f64::consts::PI
            } else {
                sc.phase(b, cos)
            };
            *o += bt * phase * pw * k * tr(b);
        }
    }

    /// The transmittance per band of a shadow ray from `p` along unit `wi` over `dist`
    /// scene units, from a path inside `media`, through the smooth dielectric surfaces of
    /// matched index it meets (no refraction, no reflection: a fog box's index-1 walls),
    /// each segment by the medium it lies in (a mesh's scattering or absorbing medium, or
    /// the scene's); None when anything else is in the way.
    #[cold]
    #[inline(never)]
    fn shadow_through(
        &self,
        p: DVec3,
        wi: DVec3,
        dist: f64,
        media: &MediumStack,
        stats: &mut EyeStats,
    ) -> Option<Vec<f64>> {
        const MAX_CROSSINGS: usize = 32;
        let mut tr = vec![1.0; self.bands];
        let mut stack = media.clone();
        let (mut org, mut left) = (p, dist);
        for _ in 0..MAX_CROSSINGS {
            stats.rays += 1;
            let hit = self.accel.intersect(org, wi).filter(|h| h.t < left);
            let seg = hit.map_or(left, |h| h.t);
            // The segment's medium: the mesh's, or the scene's.
            let seg_tr = match stack.current() {
                Some((_, m)) => Tr {
                    sigma: self.materials[m as usize].extinction().unwrap_or(&[]),
                    d_m: seg * self.unit_m,
                },
                None => self.haze_tr(org, wi, seg),
            };
            for (b, t) in tr.iter_mut().enumerate() {
                *t *= seg_tr.at(b);
            }
            let Some(h) = hit else {
                return Some(tr);
            };
            let mesh = &self.scene.meshes[h.mesh as usize];
            let material = mesh.material(h.prim as usize);
            let d = self.materials[material as usize].bsdf().interface()?;
            let front = wi.dot(mesh.normals[h.prim as usize].as_dvec3()) < 0.0;
            let out = stack.around(h.mesh, front, self.materials);
            let matched = (0..self.bands).all(|b| d.ior[b] == out.map_or(1.0, |o| o.ior[b]));
            if !matched {
                return None;
            }
            stack.cross(h.mesh, material, front);
            let q = org + wi * h.t;
            let eps = self.scene.offset_at(q);
            org = q + wi * eps;
            left -= h.t + eps;
            if left <= 0.0 {
                return Some(tr);
            }
        }
        None
    }

    /// `direct_light` summed over the bands of the arriving light (a path on a fluorescent
    /// surface that counts them all into one pixel band).
    #[cold]
    #[inline(never)]
    fn direct_arriving(
        &self,
        (p, n_in, eps, inside): (DVec3, DVec3, f64, Inside),
        (wr, wt): (&[f64], Option<&[f64]>),
        rng: &mut PhotonRng,
        stats: &mut EyeStats,
    ) -> f64 {
        let mut arriving = vec![0.0; self.bands];
        self.direct_light((p, inside), n_in, eps, wr, wt, rng, &mut arriving, stats);
        arriving.iter().sum()
    }

    /// At a diffuse vertex: the reflectance `rho` the path reads there; for a fluorescent
    /// surface white, after taking the path's weights through it. A path that still counts
    /// each band into its own pixel band (`out_band` None) picks the pixel band j it will
    /// count into from now on, with probability β_j / Σβ, and its weights become, per band
    /// i of the arriving light, Σβ (ρ_i δ_ij + m_ij); a path that has picked one already
    /// takes β_i ← ρ_i β_i + Σ_j m_ij β_j. A path collapsed to one band spreads again. None:
    /// the path carries nothing.
    #[inline]
    fn through_fluorescent<'s>(
        &'s self,
        (bsdf, rho): (Bsdf<'s>, &'s [f64]),
        beta: &mut [f64],
        (band, out_band): (&mut Option<usize>, &mut Option<usize>),
        rng: &mut PhotonRng,
    ) -> Option<&'s [f64]> {
        let Some(fl) = bsdf.fluorescence() else {
            return Some(rho);
        };
        self.take_through(fl, rho, beta, (band, out_band), rng)
    }

    /// At a re-emission in the fluorescent medium of material `medium` (`Flight::Fluoresce`):
    /// the path's weights toward the light arriving there, its pixel band picked if it had
    /// none (`Scattering::emit_importance`). A path collapsed to one band by dispersion
    /// spreads again.
    #[cold]
    #[inline(never)]
    fn re_emit(
        &self,
        (medium, media, p): (Option<u32>, &MediumStack, DVec3),
        beta: &mut [f64],
        (band, out): (&mut Option<usize>, &mut PathOut<'_>),
        rng: &mut PhotonRng,
        stats: &mut EyeStats,
    ) {
        let sc = medium
            .and_then(|m| self.materials[m as usize].dielectric.as_ref())
            .and_then(|d| d.scattering.as_ref())
            .expect("a fluorescent medium re-emits");
        *band = None;
        sc.emit_importance(beta, &mut out.band, rng.uniform());
        if out.band.is_some() && out.arriving.is_empty() {
            out.arriving.resize(beta.len(), 0.0);
        }
        if self.lights_in_media || self.index_matched {
            // The lights inside the mesh, or behind surfaces of matched index, seen by the
            // re-emission (isotropic).
            self.haze_light((p, media), (DVec3::Z, true), sc, beta, rng, out.to(), stats);
        }
    }

    /// `through_fluorescent` at a fluorescent surface `fl` (out of line: most scenes have
    /// none).
    #[cold]
    #[inline(never)]
    fn take_through(
        &self,
        fl: &crate::scene::material::Fluorescence,
        rho: &[f64],
        beta: &mut [f64],
        (band, out_band): (&mut Option<usize>, &mut Option<usize>),
        rng: &mut PhotonRng,
    ) -> Option<&[f64]> {
        *band = None;
        if out_band.is_some() {
            let mut scratch = Vec::with_capacity(beta.len());
            fl.take_from(rho, beta, &mut scratch);
            return Some(&self.white);
        }
        let total: f64 = beta.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let j = pick_band(beta, total, rng.uniform());
        let nb = beta.len();
        for (i, b) in beta.iter_mut().enumerate() {
            let r = if i == j { rho[i] } else { 0.0 };
            *b = total * (r + fl.m[i * nb + j]);
        }
        *out_band = Some(j);
        Some(&self.white)
    }

    /// An eye path's event at a surface: a dielectric reflects or refracts it (Fresnel;
    /// a dispersive one first collapses it to one band) and a mirror reflects it — both
    /// move `dir`/`org` on (`Step::Specular`) — or the diffuse event is chosen with its
    /// probability (`Step::Diffuse(pd)`, `beta` not yet weighted), or nothing is left
    /// (`Step::End`). Diffuse and specular are chosen by their weighted albedos.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn surface_step(
        &self,
        at: &Surface,
        bsdf: Bsdf,
        dir: &mut DVec3,
        org: &mut DVec3,
        (medium, media): (&mut Option<u32>, &mut MediumStack),
        (band, w): (&mut Option<usize>, &mut Vec<f64>),
        beta: &mut [f64],
        rng: &mut PhotonRng,
    ) -> Step {
        let n_in = at.n_in;
        if let Some(g) = bsdf.glossy() {
            if !g.refracts() {
                return Step::Glossy;
            }
            // A rough dielectric: crossed by sampling alone, as a smooth one, against the
            // dielectric around it (nested media), else air.
            let mut nested = None;
            let g = match media.around(at.mesh, at.front, self.materials) {
                Some(out) => g.against(&out.ior, &mut nested),
                None => g,
            };
            if g.dispersive() && band.is_none() {
                *band = Some(collapse_weights(beta, rng.uniform()));
            }
            let frame = bsdf.frame(n_in);
            let wo = frame.to_local(-*dir);
            let u = [rng.uniform(), rng.uniform(), rng.uniform()];
            w.clear();
            w.resize(beta.len(), 0.0);
            let Some(s) = g.sample_weighted(wo, u, band.unwrap_or(0), at.front, w) else {
                return Step::End;
            };
            beta.iter_mut().zip(w.iter()).for_each(|(b, w)| *b *= w);
            *dir = frame.to_world(s.wi);
            if s.wi.z > 0.0 {
                *org = at.p + n_in * at.eps;
            } else {
                *org = at.p - n_in * at.eps;
                media.cross(at.mesh, at.material, at.front);
                *medium = media.current().map(|(_, m)| m);
            }
            return Step::Specular;
        }
        if let Some(d) = bsdf.interface() {
            // Against the dielectric around it (nested media), else air.
            let out = media.around(at.mesh, at.front, self.materials);
            if (d.dispersive || out.is_some_and(|o| o.dispersive)) && band.is_none() {
                *band = Some(collapse_weights(beta, rng.uniform()));
            }
            let b = band.unwrap_or(0);
            let (n, n_out) = (d.ior[b], out.map_or(1.0, |o| o.ior[b]));
            let (n1, n2) = if at.front { (n_out, n) } else { (n, n_out) };
            let cos_i = (-dir.dot(n_in)).clamp(0.0, 1.0);
            if rng.uniform() < fresnel_dielectric(cos_i, n1, n2) {
                *dir = reflect(*dir, n_in);
                *org = at.p + n_in * at.eps;
            } else {
                *dir = refract(*dir, n_in, cos_i, n1 / n2);
                *org = at.p - n_in * at.eps;
                media.cross(at.mesh, at.material, at.front);
                *medium = media.current().map(|(_, m)| m);
            }
            return Step::Specular;
        }
        if bsdf.fluorescence().is_some() {
            // A fluorescent Lambertian reflector: diffuse, whatever its reflectance (the
            // caller takes the path's weights through it).
            return Step::Diffuse(1.0);
        }
        let nb = self.bands;
        let (rho, tau) = (
            bsdf.albedo(Lobe::DiffuseReflection),
            bsdf.albedo(Lobe::DiffuseTransmission),
        );
        let wd: f64 = (0..nb).map(|b| beta[b] * (rho[b] + tau[b])).sum();
        let specular = bsdf.albedo(Lobe::SpecularReflection);
        let ws: f64 = if bsdf.has(Lobe::SpecularReflection) {
            (0..nb).map(|b| beta[b] * specular[b]).sum()
        } else {
            0.0
        };
        if wd + ws <= 0.0 {
            return Step::End;
        }
        let pd = wd / (wd + ws);
        if rng.uniform() >= pd {
            let ps = 1.0 - pd;
            for (b, k) in beta.iter_mut().zip(specular) {
                *b *= k / ps;
            }
            *dir = Lobe::SpecularReflection.direction(*dir, n_in, 0.0, 0.0);
            *org = at.p + n_in * at.eps;
            return Step::Specular;
        }
        Step::Diffuse(pd)
    }

    /// Direct light at a diffuse point: one light sample and (with emitting meshes) one
    /// BSDF sample, weighted by the power heuristic. `w_r`/`w_t`: path weight × BRDF/BTDF.
    #[allow(clippy::too_many_arguments)]
    fn direct_light(
        &self,
        (p, inside): (DVec3, Inside),
        n_in: DVec3,
        eps: f64,
        w_r: &[f64],
        w_t: Option<&[f64]>,
        rng: &mut PhotonRng,
        out: &mut [f64],
        stats: &mut EyeStats,
    ) {
        let sr: f64 = w_r.iter().sum();
        let st: f64 = w_t.map_or(0.0, |w| w.iter().sum());
        if sr + st <= 0.0 {
            return;
        }
        let p_reflect = sr / (sr + st);
        // The weights and hemisphere probability on the side of direction `wi`.
        let side = |cos: f64| -> Option<(&[f64], f64)> {
            if cos > 0.0 && sr > 0.0 {
                Some((w_r, p_reflect))
            } else if cos < 0.0 && st > 0.0 {
                Some((w_t.expect("st > 0"), 1.0 - p_reflect))
            } else {
                None
            }
        };
        let table = &self.scene.emitter_table;

        // Light sampling.
        let e = table.sample(rng.uniform());
        let pe = table.pdf(e);
        let em = &self.scene.emitters[e];
        let (u1, u2, u3) = (rng.uniform(), rng.uniform(), rng.uniform());
        let receiver = Receiver {
            n: n_in,
            p_front: p_reflect,
        };
        let sample = em.sample_toward(&self.scene.meshes, p, receiver, [u1, u2, u3], || {
            rng.uniform() < p_reflect
        });
        let power = || match &self.lights[e] {
            LightValue::Power(power) => power.as_slice(),
            LightValue::Radiance { .. } => unreachable!("emitting meshes sample areas"),
        };
        match sample {
            None => {}
            Some(LightSample::Beam { axis, area, .. }) => {
                // Lit when the point lies in the beam (`sample_toward`), with nothing in
                // between.
                let wi = -axis;
                let cos = wi.dot(n_in);
                if let Some((w, _)) = side(cos) {
                    let org = p + n_in * (eps * cos.signum());
                    let dist = (org - em.position).dot(axis);
                    stats.rays += 1;
                    if dist > 0.0 && !self.accel.occluded(org, wi, dist) {
                        let k = cos.abs() / (area * self.unit_m * self.unit_m * pe);
                        let tr = self.light_tr(e, inside, org, wi, dist);
                        for (b, ((o, w), pw)) in out.iter_mut().zip(w).zip(power()).enumerate() {
                            *o += w * pw * k * tr.at(b);
                        }
                    }
                }
            }
            Some(LightSample::Point(at)) => {
                // A point, or a point of the luminous opening (uniform over it).
                let to = at - p;
                let d2 = to.length_squared();
                let wi = to / d2.sqrt();
                let per_watt = em.intensity_per_watt(-wi);
                if per_watt <= 0.0 {
                    return self.bsdf_sample(
                        (p, inside),
                        n_in,
                        eps,
                        p_reflect,
                        &side,
                        rng,
                        out,
                        stats,
                    );
                }
                let cos = wi.dot(n_in);
                if let Some((w, _)) = side(cos) {
                    let org = p + n_in * (eps * cos.signum());
                    stats.rays += 1;
                    let to_light = at - org;
                    let dist = to_light.length();
                    if !self.accel.occluded(org, to_light / dist, dist) {
                        let k = per_watt * cos.abs() / (d2 * self.unit_m * self.unit_m * pe);
                        let tr = self.light_tr(e, inside, org, to_light / dist, dist);
                        for (b, ((o, w), pw)) in out.iter_mut().zip(w).zip(power()).enumerate() {
                            *o += w * pw * k * tr.at(b);
                        }
                    }
                }
            }
            Some(LightSample::Area {
                point: q,
                normal: ng,
            }) => {
                let to = q - p;
                let d2 = to.length_squared();
                let d = d2.sqrt();
                let wi = to / d;
                let cos = wi.dot(n_in);
                if let (Some((w, ps)), Some((_, radiance, area, _))) =
                    (side(cos), self.emission_of(e, ng, wi))
                {
                    let cos_l = wi.dot(ng).abs();
                    // The shadow ray leaves from the offset origin and aims at q itself.
                    let org = p + n_in * (eps * cos.signum());
                    let dist = (q - org).length();
                    let t_max = dist - 2.0 * self.scene.offset_at(q);
                    stats.rays += 1;
                    if cos_l > 0.0
                        && t_max > 0.0
                        && !self.accel.occluded(org, (q - org) / dist, t_max)
                    {
                        let pl = pe * d2 / (area * cos_l);
                        let pb = ps * cos.abs() / PI;
                        let k = cos.abs() / pl * pl * pl / (pl * pl + pb * pb);
                        let tr = self.light_tr(e, inside, org, (q - org) / dist, t_max);
                        for (b, ((o, w), l)) in out.iter_mut().zip(w).zip(radiance).enumerate() {
                            *o += w * l * k * tr.at(b);
                        }
                    }
                }
            }
            Some(LightSample::Direction {
                toward: wi,
                pdf: q,
                value: f,
                reach,
                norm,
            }) => {
                // A sky: half by its radiance, half cosine-distributed on the side the
                // weights favour (one-sample MIS by the mixture's density, as the map's
                // light samples); the sun: over its disk.
                let cos = wi.dot(n_in);
                if let (true, Some((w, _))) = (f > 0.0 && q > 0.0, side(cos)) {
                    let org = p + n_in * (eps * cos.signum());
                    stats.rays += 1;
                    if !self.accel.occluded(org, wi, reach) {
                        // L cos / q, with L = power / norm × f per band (norm: π R² ∫f,
                        // or the portals').
                        let cross = norm * self.unit_m * self.unit_m;
                        let k = f * cos.abs() / (q * cross * pe);
                        let tr = self.light_tr(e, inside, org, wi, f64::INFINITY);
                        for (b, ((o, w), pw)) in out.iter_mut().zip(w).zip(power()).enumerate() {
                            *o += w * pw * k * tr.at(b);
                        }
                    }
                }
            }
        }
        self.bsdf_sample((p, inside), n_in, eps, p_reflect, &side, rng, out, stats);
    }

    /// The BSDF-sampling half of the direct light: a cosine-distributed direction on the
    /// reflecting or transmitting side; counts only when it reaches an emitting mesh.
    #[allow(clippy::too_many_arguments)]
    fn bsdf_sample<'w>(
        &self,
        (p, inside): (DVec3, Inside),
        n_in: DVec3,
        eps: f64,
        p_reflect: f64,
        side: &dyn Fn(f64) -> Option<(&'w [f64], f64)>,
        rng: &mut PhotonRng,
        out: &mut [f64],
        stats: &mut EyeStats,
    ) {
        if !self.has_mesh_emitters {
            return;
        }
        let n = if rng.uniform() < p_reflect {
            n_in
        } else {
            -n_in
        };
        let wi = warp::cosine_hemisphere(n, rng.uniform(), rng.uniform());
        let cos = wi.dot(n_in);
        let Some((w, ps)) = side(cos) else {
            return;
        };
        stats.rays += 1;
        let from = p + n * eps;
        let Some(hit) = self.accel.intersect(from, wi) else {
            return;
        };
        let ng = self.scene.meshes[hit.mesh as usize].normals[hit.prim as usize].as_dvec3();
        let Some((e, radiance, area, cos_l)) = self.emission(hit.mesh, ng, wi) else {
            return;
        };
        if cos_l <= 0.0 {
            return;
        }
        let pl = self.scene.emitter_table.pdf(e) * hit.t * hit.t / (area * cos_l);
        let pb = ps * cos.abs() / PI;
        let k = cos.abs() / pb * pb * pb / (pb * pb + pl * pl);
        let tr = self.light_tr(e, inside, from, wi, hit.t);
        for (b, ((o, w), l)) in out.iter_mut().zip(w).zip(radiance).enumerate() {
            *o += w * l * k * tr.at(b);
        }
    }
}

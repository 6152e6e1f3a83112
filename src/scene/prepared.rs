//! The prepared scene: geometry recentred for f32 precision, per-triangle normals and
//! areas, per-vertex area shares, the map's slot layout, and the light-selection table.

use super::light::DistantPart;
use super::mesh::triangle_area;
use super::{LightShape, Material, Mesh, Scene};
use crate::error::{bail, try_collect, try_filled, Error, ImapStatus, Result, Subject};
use crate::imap::regions::RegionLayout;
use crate::imap::LayerLayout;
use crate::sampling::{warp, AliasTable, PhotonRng};
use glam::{DVec3, Vec3};
use std::sync::Arc;

/// Largest area-weighted relative distortion that f32 rounding of a mesh's vertices may
/// cause before the scene is refused (`IMAP_ERR_PRECISION`): 0.1 %.
pub const MAX_DISTORTION: f64 = 1e-3;

/// A mesh ready for tracing. Positions are in scene units relative to `PreparedScene::origin`.
#[derive(Debug)]
pub struct PreparedMesh {
    pub vertices: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Unit geometric normal of each triangle; zero for zero-area triangles.
    pub normals: Vec<Vec3>,
    /// Material id per triangle (one entry when the whole mesh shares one material).
    pub materials: Vec<u32>,
    pub two_sided: bool,
    /// First map slot of this mesh, `None` when it does not record.
    pub slot_base: Option<usize>,
    /// Each vertex's share of the adjacent triangles' area (a third of each), scene units².
    pub vertex_area: Vec<f64>,
    /// A sensor: traced in its own BVH, crossed by photons, never stopping them.
    pub sensor: bool,
    /// Its regions are tallied per photon (`Mesh::tally`).
    pub tally: bool,
}

impl PreparedMesh {
    #[inline]
    pub fn material(&self, prim: usize) -> u32 {
        if self.materials.len() == 1 {
            self.materials[0]
        } else {
            self.materials[prim]
        }
    }

    /// The point at barycentric (u, v) of triangle `prim` (more precise than org + t·dir).
    #[inline]
    pub fn point(&self, prim: usize, u: f32, v: f32) -> DVec3 {
        let [a, b, c] = self.triangles[prim].map(|i| self.vertices[i as usize].as_dvec3());
        a + (b - a) * u as f64 + (c - a) * v as f64
    }

    /// Area of triangle `prim`, scene units².
    pub fn area(&self, prim: usize) -> f64 {
        let [a, b, c] = self.triangles[prim].map(|i| self.vertices[i as usize].as_dvec3());
        0.5 * (b - a).cross(c - a).length()
    }

    /// The map slot of `vertex` on `side` (0 = front, 1 = back).
    #[inline]
    pub fn slot(&self, vertex: u32, side: usize) -> Option<usize> {
        let sides = if self.two_sided { 2 } else { 1 };
        self.slot_base.map(|b| b + vertex as usize * sides + side)
    }

    pub fn sides(&self) -> usize {
        if self.two_sided {
            2
        } else {
            1
        }
    }
}

#[derive(Debug)]
pub enum EmitterKind {
    /// A light: point, spot, cosine, beam or goniometric luminaire.
    Light(LightShape),
    /// A distant source (one channel of a sky, or the sun): photons start on a disk of
    /// `radius` (the bounding sphere's, scene units) perpendicular to their direction, or,
    /// with `portals`, mostly through them. Its radiance per band is power × f(ω) / `norm`
    /// (norm = π R² ∫f, scene units²·sr); `gain` is how much denser its photons are behind
    /// the portals than from the whole sky (1 without).
    Distant {
        part: Arc<DistantPart>,
        radius: f64,
        norm: f64,
        gain: f64,
        portals: Option<Arc<Portals>>,
    },
    /// A self-emitting mesh: triangles chosen by area, Lambertian emission.
    Mesh {
        mesh: usize,
        triangles: AliasTable,
        two_sided: bool,
    },
}

/// Share of a portal-lit distant source's photons that come through its portals; the rest
/// come from the whole sky as without portals.
pub const PORTAL_SHARE: f64 = 0.75;

/// Window portals of one distant source: the openings its light enters the model through
/// (as pbrt-v4's and Mitsuba's portals). A photon's line is drawn by one of two
/// strategies: with probability `PORTAL_SHARE` through a portal — a triangle k by
/// A_k J_k (J_k = ∫ f max(ω·n_k, 0) dω), a point on it uniformly, a direction ω toward the
/// source (a sky's half by its radiance and half cosine-distributed about n_k; the sun's
/// over its disk) — otherwise from the whole sky, as without portals. Either way it starts
/// beyond the bounding sphere, so overhangs and panes in front of an opening still meet
/// it, and it carries f(ω) / (p(line) ∫f π R²), p the mixture's density of that line (the
/// one-sample balance heuristic): mean 1, the source's power unchanged, and unbiased for
/// every surface — light reflected into the openings by outside surfaces (overhangs, light
/// shelves, neighbours) comes with the whole-sky photons — while the rooms behind the
/// portals get nearly all photons.
#[derive(Debug)]
pub struct Portals {
    /// Triangles (recentred scene units), their unit normals (facing out), areas and J_k.
    tris: Vec<[DVec3; 3]>,
    normals: Vec<DVec3>,
    areas: Vec<f64>,
    j: Vec<f64>,
    table: AliasTable,
    /// Σ A_k J_k, scene units²·sr.
    pub total: f64,
    /// The disk's radius (the bounding sphere's).
    radius: f64,
}

impl Portals {
    /// The portals `tris` (recentred) for `part`, the bounding sphere of `radius`; None
    /// when no light of it passes them.
    fn new(part: &DistantPart, tris: &[[DVec3; 3]], radius: f64) -> Option<Portals> {
        let mut cache: Vec<(DVec3, f64)> = Vec::new();
        let (mut keep, mut normals, mut areas, mut j, mut weights) =
            (vec![], vec![], vec![], vec![], vec![]);
        for t in tris {
            let c = (t[1] - t[0]).cross(t[2] - t[0]);
            let area = 0.5 * c.length();
            let Some(n) = c.try_normalize() else { continue };
            // Triangles of one window share their normal: integrate once per direction.
            let jk = match cache.iter().find(|(m, _)| m.dot(n) > 1.0 - 1e-12) {
                Some(&(_, v)) => v,
                None => {
                    let v = part.cos_integral(n);
                    cache.push((n, v));
                    v
                }
            };
            if jk > 0.0 && area > 0.0 {
                keep.push(*t);
                normals.push(n);
                areas.push(area);
                j.push(jk);
                weights.push(area * jk);
            }
        }
        let total: f64 = weights.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        Some(Portals {
            tris: keep,
            normals,
            areas,
            j,
            table: AliasTable::new(&weights).ok()?,
            total,
            radius,
        })
    }

    /// The density over directions toward the source of the portal strategy's portal k.
    #[inline]
    fn q(&self, part: &DistantPart, k: usize, toward: DVec3) -> f64 {
        let cos = toward.dot(self.normals[k]);
        if cos <= 0.0 {
            return 0.0;
        }
        if part.is_sky() {
            0.5 * part.pdf(toward) + 0.5 * cos / std::f64::consts::PI
        } else {
            part.pdf(toward)
        }
    }

    /// The mixture's density of the line through `x` toward `toward` (per unit area
    /// across it and per sr); `own`: the portal triangle `x` was drawn on.
    fn line_density(&self, part: &DistantPart, x: DVec3, toward: DVec3, own: Option<usize>) -> f64 {
        let mut portal = 0.0;
        for k in 0..self.tris.len() {
            let cos = toward.dot(self.normals[k]);
            if cos <= 0.0 {
                continue;
            }
            if own != Some(k) && !crosses(&self.tris[k], x, toward) {
                continue;
            }
            // P_k q_k / (A_k cos_k): the triangle's pick, its point, the direction.
            portal += self.j[k] * self.areas[k] / self.total * self.q(part, k, toward)
                / (self.areas[k] * cos);
        }
        // The whole sky's lines cross its disk of the sphere's radius (a portal beyond the
        // sphere may have lines that do not).
        let off_axis = (x - toward * x.dot(toward)).length();
        let disk = if off_axis <= self.radius {
            part.pdf(toward) / (std::f64::consts::PI * self.radius * self.radius)
        } else {
            0.0
        };
        PORTAL_SHARE * portal + (1.0 - PORTAL_SHARE) * disk
    }

    /// A photon's start, direction and weight (mean 1).
    fn emit(&self, part: &DistantPart, rng: &mut PhotonRng) -> (DVec3, DVec3, f64) {
        let r = self.radius;
        let (x, toward, own) = if rng.uniform() < PORTAL_SHARE {
            let k = self.table.sample(rng.uniform());
            let [a, b, c] = self.tris[k];
            let (b1, b2) = warp::uniform_triangle(rng.uniform(), rng.uniform());
            let x = a + (b - a) * b1 + (c - a) * b2;
            let n = self.normals[k];
            let (u0, u1, u2) = (rng.uniform(), rng.uniform(), rng.uniform());
            let toward = if part.is_sky() {
                if u0 < 0.5 {
                    part.sample([2.0 * u0, u1, u2]).0
                } else {
                    warp::cosine_hemisphere(n, 2.0 * u0 - 1.0, u1)
                }
            } else {
                part.sample([u0, u1, u2]).0
            };
            (x, toward, Some(k))
        } else {
            let (toward, _) = part.sample([rng.uniform(), rng.uniform(), rng.uniform()]);
            let (t, b) = warp::basis(toward);
            let rr = r * rng.uniform().sqrt();
            let phi = 2.0 * std::f64::consts::PI * rng.uniform();
            (t * (rr * phi.cos()) + b * (rr * phi.sin()), toward, None)
        };
        let f = part.value(toward);
        let p = self.line_density(part, x, toward, own);
        let w = if f > 0.0 && p > 0.0 {
            f / (p * part.integral * std::f64::consts::PI * r * r)
        } else {
            0.0
        };
        // Beyond the sphere on the line: x lies within it.
        let far = 2.0 * r + x.length();
        (x + toward * far, -toward, w)
    }
}

/// Whether the line through `x` along `d` crosses triangle `t` (Möller–Trumbore on the
/// whole line).
#[inline]
fn crosses(t: &[DVec3; 3], x: DVec3, d: DVec3) -> bool {
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-300 {
        return false;
    }
    let inv = 1.0 / det;
    let s = x - t[0];
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    v >= 0.0 && u + v <= 1.0
}

/// Share of photons spread evenly over the emitters, whatever their power.
pub(crate) const EMITTER_FLOOR: f64 = 0.1;

/// One light source as the tracer sees it.
#[derive(Debug)]
pub struct Emitter {
    pub kind: EmitterKind,
    /// Position (scene units, recentred) of a light: its point, or the centre of its
    /// aperture or luminous opening.
    pub position: DVec3,
    /// Colour of an emitted photon: per-band power share times the band count, scaled by
    /// the emitter's power share over its selection probability (mean 1 with one emitter).
    pub colour: Vec<f64>,
    /// Radiant flux per band, W (a distant source's: through the bounding sphere).
    pub power: Vec<f64>,
    /// The map layer its photons write (its light group when groups are kept, else 0).
    pub layer: u8,
    /// Where a point-like light's photons are aimed (`Aim`), if they are.
    pub aim: Option<Aim>,
}

/// A point-like light outside the sphere that holds the geometry (the one `enter` uses)
/// emits only into the cone of directions that meet the sphere: every other direction
/// meets nothing. Photons are sampled uniformly in the cone and weighted by the light's
/// flux share there, so the map is unchanged in expectation and the flux outside the cone
/// is counted as escaped at emission.
#[derive(Clone, Copy, Debug)]
pub struct Aim {
    /// From the light toward the sphere's centre.
    pub axis: DVec3,
    /// 1 − cos of the cone's half-angle, computed without cancellation (a light 10⁷ scene
    /// sizes away sees a cone of 10⁻¹⁴ here).
    pub one_minus_cos: f64,
    /// The cone's solid angle, 2π·one_minus_cos, sr.
    pub solid_angle: f64,
    /// The weight of every photon when the light's intensity is constant over the cone;
    /// None: I(d)/Φ times the solid angle, per direction.
    pub weight: Option<f64>,
}

/// Widest cone (half-angle) a light of non-uniform intensity is aimed into: beyond it,
/// weights I(d)·Ω/Φ spread too widely to pay for the photons saved.
const AIM_MAX_HALF_ANGLE_DEG: f64 = 30.0;

impl Aim {
    /// The aim of a light of `shape` at `position` (local units) toward the sphere of
    /// radius `r` around the origin; None when the light is inside it, is not point-like,
    /// or gains nothing.
    fn new(shape: &LightShape, position: DVec3, r: f64) -> Option<Aim> {
        let d = position.length();
        if !d.is_finite() || d <= r * (1.0 + 1e-9) {
            return None;
        }
        let axis = -position / d;
        let sin = r / d;
        let cos_max = (1.0 - sin * sin).max(0.0).sqrt();
        let one_minus_cos = sin * sin / (1.0 + cos_max);
        let solid_angle = 2.0 * std::f64::consts::PI * one_minus_cos;
        let aim = |weight| {
            Some(Aim {
                axis,
                one_minus_cos,
                solid_angle,
                weight,
            })
        };
        let narrow = cos_max >= AIM_MAX_HALF_ANGLE_DEG.to_radians().cos();
        match shape {
            LightShape::Point => aim(Some(solid_angle / (4.0 * std::f64::consts::PI))),
            LightShape::Spot {
                axis: a,
                cos_half_angle,
            } => {
                let beta = a.dot(axis).clamp(-1.0, 1.0).acos();
                let alpha = cos_half_angle.clamp(-1.0, 1.0).acos();
                let theta = cos_max.clamp(-1.0, 1.0).acos();
                if beta + theta <= alpha {
                    // The cone lies inside the spot: constant intensity over it.
                    let spot = 2.0 * std::f64::consts::PI * (1.0 - cos_half_angle);
                    aim(Some(solid_angle / spot))
                } else {
                    None
                }
            }
            LightShape::Cosine { .. } if narrow => aim(None),
            LightShape::Luminaire(l) if narrow && l.opening.is_none() => aim(None),
            _ => None,
        }
    }
}

/// The frozen scene a run reads.
#[derive(Debug)]
pub struct PreparedScene {
    /// The scene-unit point that became the local origin.
    pub origin: DVec3,
    /// Half the diagonal of the bounding box of the geometry (sensors left out), scene units.
    pub radius: f64,
    /// Radius around the origin of a sphere holding every recorded vertex, sensors included:
    /// where photons from far lights start (`enter`).
    pub enter_radius: f64,
    /// Whether any mesh is a sensor.
    pub has_sensors: bool,
    pub meshes: Vec<PreparedMesh>,
    pub emitters: Vec<Emitter>,
    pub emitter_table: AliasTable,
    /// Total emitted power, W, summed over bands.
    pub total_power: f64,
    pub slots: usize,
    /// The regions photons' totals are tallied for (`imap::regions`).
    pub regions: RegionLayout,
    /// Luminous efficacy of each band, lm/W.
    pub efficacy: Vec<f64>,
    /// The map's layers.
    pub layers: LayerLayout,
    /// The spectra a spectral map keeps grey sums for (`GreySpectra`).
    pub grey: GreySpectra,
}

/// Most spectra a map keeps grey sums for (`GreySpectra`).
pub const MAX_GREY: usize = 32;
/// Maps of at least this many bands keep grey sums (`GreySpectra`); at a few bands a cell
/// is a cache line or two anyway.
pub const GREY_MIN_BANDS: usize = 9;

/// The spectra for which a spectral map keeps, per cell, one sum of multiples
/// (`imap::IMap`): each emitter's spectrum, and each emitter's spectrum times the diffuse
/// reflectance of each material that reflects bands differently. A photon whose colour is
/// still a multiple of one of them (it met only surfaces whose coefficients are the same in
/// every band, or one tinted surface besides; every first hit) deposits one number instead
/// of one per band; the map's band values add each sum times its spectrum. Empty for maps
/// of fewer than `GREY_MIN_BANDS` bands; at most a quarter as many sums as bands (the
/// map's memory grows by at most a quarter) and `MAX_GREY`: spectra past those deposit
/// every band.
#[derive(Clone, Debug, Default)]
pub struct GreySpectra {
    pub bands: usize,
    /// The spectra, `bands` values each, each scaled so that its largest value is 1.
    pub spectra: Vec<f64>,
    /// Per spectrum: its band mean, and its largest band.
    pub means: Vec<f64>,
    pub peaks: Vec<usize>,
    /// Per emitter: its spectrum, if it has one here.
    pub of_emitter: Vec<Option<u8>>,
    /// Per (emitter spectrum, material): the tinted spectrum, if kept (`after`).
    tints: Vec<Option<u8>>,
    /// Per material: whether its diffuse reflectance is the same in every band.
    flat: Vec<bool>,
}

/// Most grey sums a map of `bands` bands keeps per cell (`GreySpectra`).
pub fn most_grey(bands: usize) -> usize {
    if bands < GREY_MIN_BANDS {
        0
    } else {
        MAX_GREY.min(bands / 4)
    }
}

impl GreySpectra {
    /// The distinct spectra of `emitters`' colours (up to scale), then of those times each
    /// tinted material's diffuse reflectance, for maps of `bands` bands.
    pub fn new(emitters: &[Emitter], materials: &[Material], bands: usize) -> Self {
        let mut g = GreySpectra {
            bands,
            of_emitter: vec![None; emitters.len()],
            ..Default::default()
        };
        let most = most_grey(bands);
        if most == 0 {
            return g;
        }
        let bases: Vec<Option<u8>> = emitters
            .iter()
            .map(|em| {
                if em.colour.len() == bands {
                    g.keep(em.colour.clone(), most)
                } else {
                    None
                }
            })
            .collect();
        g.of_emitter = bases;
        g.flat = materials
            .iter()
            .map(|m| {
                m.diffuse_reflect.len() != bands
                    || m.diffuse_reflect.iter().all(|r| *r == m.diffuse_reflect[0])
            })
            .collect();
        let spectra = g.count();
        g.tints = vec![None; spectra * materials.len()];
        for k in 0..spectra {
            for (i, m) in materials.iter().enumerate() {
                if g.flat[i] {
                    continue;
                }
                let tinted: Vec<f64> = g
                    .spectrum(k)
                    .iter()
                    .zip(&m.diffuse_reflect)
                    .map(|(s, r)| s * r)
                    .collect();
                g.tints[k * materials.len() + i] = g.keep(tinted, most);
            }
        }
        g
    }

    /// Spectra kept for `shapes` alone (no emitters, no materials): for tests.
    #[cfg(test)]
    pub(crate) fn of_shapes(bands: usize, shapes: &[Vec<f64>]) -> Self {
        let mut g = GreySpectra {
            bands,
            ..Default::default()
        };
        for s in shapes {
            g.keep(s.clone(), MAX_GREY);
        }
        g
    }

    /// The index of `colour`'s shape, added if new and there is room.
    fn keep(&mut self, colour: Vec<f64>, most: usize) -> Option<u8> {
        let (peak, max) =
            colour.iter().enumerate().fold(
                (0, 0.0),
                |(i, m), (j, &c)| if c > m { (j, c) } else { (i, m) },
            );
        if !(max > 0.0 && max.is_finite()) {
            return None;
        }
        let shape: Vec<f64> = colour.iter().map(|c| c / max).collect();
        let same = (0..self.count()).find(|&k| {
            self.spectrum(k)
                .iter()
                .zip(&shape)
                .all(|(a, b)| (a - b).abs() <= 1e-12)
        });
        match same {
            Some(k) => Some(k as u8),
            None if self.count() < most => {
                self.means
                    .push(shape.iter().sum::<f64>() / self.bands as f64);
                self.peaks.push(peak);
                self.spectra.extend(shape);
                Some((self.count() - 1) as u8)
            }
            None => None,
        }
    }

    /// The spectrum a photon's colour is a multiple of after a diffuse reflection off
    /// `material`, when it was one of spectrum `k` (an emitter's) before: `k` again off a
    /// material that reflects every band alike, the tinted spectrum off one that does not
    /// (if kept); None when `k` is not an emitter's or `material` is out of range.
    #[inline]
    pub fn after(&self, k: u8, base: u8, material: usize) -> Option<u8> {
        match self.flat.get(material)? {
            true => Some(k),
            false if k == base => self.tints[base as usize * self.flat.len() + material],
            false => None,
        }
    }

    /// Spectra kept (K).
    #[inline]
    pub fn count(&self) -> usize {
        self.means.len()
    }

    #[inline]
    pub fn spectrum(&self, k: usize) -> &[f64] {
        &self.spectra[k * self.bands..(k + 1) * self.bands]
    }

    /// The multiple of spectrum `k` that `colour` is, if it is one (to 1e-9 of its largest
    /// band).
    #[inline]
    pub fn multiple(&self, k: usize, colour: &[f64]) -> Option<f64> {
        let s = self.spectrum(k);
        let a = colour[self.peaks[k]];
        if !(a > 0.0 && a.is_finite()) {
            return None;
        }
        let tol = 1e-9 * a;
        // Every band checked (no early exit): the loop vectorises. A NaN band is off.
        let off = colour.iter().zip(s).fold(false, |off, (c, s)| {
            let d = (c - a * s).abs();
            off | (d > tol) | d.is_nan()
        });
        (!off).then_some(a)
    }
}

impl PreparedScene {
    /// Prepares `scene`, whose bands have the luminous efficacies `efficacy` (lm/W, the
    /// context's `BandPhotometry`). The caller has checked that it has meshes and lights.
    ///
    /// Fails with `IMAP_ERR_PRECISION` naming the mesh when the scene's extent makes a
    /// mesh's triangles too small for the f32 coordinates ray tracing uses, with
    /// `IMAP_ERR_NO_LIGHT` / `IMAP_ERR_INVALID_ARGUMENT` naming the light or mesh whose
    /// power is zero or not representable, and with `IMAP_ERR_OUT_OF_MEMORY`.
    /// `aim_lights`: aim point-like lights outside the geometry at it (`Aim`).
    pub fn new(scene: &Scene, efficacy: &[f64], aim_lights: bool) -> Result<Self> {
        // The bounds of the geometry that can be hit: vertices no triangle uses, and lights
        // (whose photons enter through the bounding sphere), do not widen them.
        // Sensors do not widen them either: a scene with sensors traces its other meshes
        // with the same f32 coordinates, and so the same photons, as without them.
        let (lo, hi) = bounds(scene, |m| !m.sensor).unwrap_or_else(|| {
            bounds(scene, |_| true).expect("the caller checked there are meshes")
        });
        let origin = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(f64::MIN_POSITIVE);
        let enter_radius = match bounds(scene, |m| m.sensor) {
            Some((slo, shi)) => {
                let far = |p: DVec3| (p - origin).abs();
                radius.max(far(slo).max(far(shi)).length())
            }
            None => radius,
        };
        let mut slots = 0usize;
        let mut meshes = Vec::with_capacity(scene.meshes.len());
        for (i, m) in scene.meshes.iter().enumerate() {
            let p = prepare_mesh(m, origin, m.record.then_some(slots))?;
            check_precision(i, m, &p, radius)?;
            slots += m.map_slots();
            meshes.push(p);
        }

        let nb = scene.bands.count() as f64;
        let unit2 = scene.unit_m * scene.unit_m;
        let layers = scene.layer_layout();
        let layer_of = |group: u32| if scene.layers.groups { group as u8 } else { 0 };
        let mut emitters = Vec::new();
        let mut powers = Vec::new();
        let colour_of = |power: &[f64]| -> (Vec<f64>, f64) {
            let total: f64 = power.iter().sum();
            (power.iter().map(|p| p * nb / total).collect(), total)
        };
        let sphere = sphere_radius(enter_radius, radius);
        let portal_tris: Vec<[DVec3; 3]> = scene
            .portals
            .iter()
            .map(|t| t.map(|p| DVec3::from(p) - origin))
            .collect();
        for (i, l) in scene.lights.iter().enumerate() {
            if let LightShape::Distant(d) = &l.shape {
                // Flux through the bounding sphere: π R² ∫ L dω per band; with portals,
                // through them: Σ A_k ∫ L cos⁺ dω.
                let disk = std::f64::consts::PI * sphere * sphere;
                for part in &d.parts {
                    let norm = part.integral * disk;
                    let portals = if portal_tris.is_empty() {
                        None
                    } else {
                        Portals::new(part, &portal_tris, sphere).map(Arc::new)
                    };
                    // Photons per unit area behind the portals, against the whole sky's
                    // (the light samples' MIS weights read it).
                    let gain = portals.as_ref().map_or(1.0, |p| {
                        PORTAL_SHARE * norm / p.total + (1.0 - PORTAL_SHARE)
                    });
                    let power: Vec<f64> = part.per_band.iter().map(|x| x * norm * unit2).collect();
                    let (colour, total) = colour_of(&power);
                    if !(total > 0.0 && total.is_finite()) {
                        return Err(Error::new(
                            ImapStatus::ImapErrInvalidArgument,
                            format!("light {i}: its flux into the scene's bounding sphere (radius {sphere:e} scene units) is {total} W: not a usable power"),
                        )
                        .about(Subject::Light(i as u32)));
                    }
                    emitters.push(Emitter {
                        kind: EmitterKind::Distant {
                            part: part.clone(),
                            radius: sphere,
                            norm,
                            gain,
                            portals,
                        },
                        position: DVec3::ZERO,
                        colour,
                        power,
                        layer: layer_of(l.group),
                        aim: None,
                    });
                    powers.push(total);
                }
                continue;
            }
            let (colour, total) = colour_of(&l.power);
            if !(total > 0.0 && total.is_finite()) {
                return Err(Error::new(
                    ImapStatus::ImapErrInvalidArgument,
                    format!("light {i}: its power sums to {total} W over the bands"),
                )
                .about(Subject::Light(i as u32)));
            }
            emitters.push(Emitter {
                kind: EmitterKind::Light(l.shape.clone()),
                position: l.position - origin,
                colour,
                power: l.power.clone(),
                layer: layer_of(l.group),
                aim: None,
            });
            powers.push(total);
        }
        for (i, m) in scene.meshes.iter().enumerate() {
            let Some(exitance) = &m.exitance else {
                continue;
            };
            let pm = &meshes[i];
            let areas: Vec<f64> = try_collect(
                pm.triangles.iter().map(|t| triangle_area(&m.positions, t)),
                "an emitting mesh's triangle areas",
            )?;
            let area: f64 = areas.iter().sum();
            let sides = m.sides() as f64;
            let power: Vec<f64> = exitance.iter().map(|e| e * area * unit2 * sides).collect();
            let (colour, total) = colour_of(&power);
            if !(total > 0.0 && total.is_finite()) {
                return Err(Error::new(
                    ImapStatus::ImapErrInvalidArgument,
                    format!("mesh {i} emits {total} W (exitance × area {area:e} scene units² × unit_m²): not a usable power"),
                )
                .about(Subject::Mesh(i as u32)));
            }
            let triangles = AliasTable::new(&areas).map_err(|why| {
                Error::new(
                    ImapStatus::ImapErrNoLight,
                    format!("mesh {i}: its emitting triangles cannot be sampled ({why})"),
                )
                .about(Subject::Mesh(i as u32))
            })?;
            emitters.push(Emitter {
                kind: EmitterKind::Mesh {
                    mesh: i,
                    triangles,
                    two_sided: m.two_sided,
                },
                position: DVec3::ZERO,
                colour,
                power,
                layer: layer_of(m.light_group),
                aim: None,
            });
            powers.push(total);
        }
        let total_power: f64 = powers.iter().sum();
        if !(total_power > 0.0 && total_power.is_finite()) {
            bail!(
                ImapErrInvalidArgument,
                "the lights' total power is {total_power} W: too large to represent"
            );
        }
        // Emitters are chosen in proportion to power mixed with a uniform share, so a light
        // 1e12 times dimmer than another still gets photons (at least EMITTER_FLOOR / L of
        // them) instead of reading zero for ever. Each photon's colour carries the ratio of
        // its emitter's power share to its selection probability, which keeps the estimate
        // unbiased and costs at most 1/(1 − EMITTER_FLOOR) in weight spread elsewhere.
        let l = powers.len() as f64;
        let select: Vec<f64> = powers
            .iter()
            .map(|&p| (1.0 - EMITTER_FLOOR) * p / total_power + EMITTER_FLOOR / l)
            .collect();
        for ((em, &p), &s) in emitters.iter_mut().zip(&powers).zip(&select) {
            let scale = p / total_power / s;
            em.colour.iter_mut().for_each(|c| *c *= scale);
        }
        let emitter_table = AliasTable::new(&select).map_err(|why| {
            Error::new(
                ImapStatus::ImapErrNoLight,
                format!("the lights cannot be sampled ({why})"),
            )
        })?;
        let regions = RegionLayout::new(&meshes, layers);
        let grey = GreySpectra::new(&emitters, &scene.materials, efficacy.len());
        let mut prepared = PreparedScene {
            grey,
            layers,
            regions,
            efficacy: efficacy.to_vec(),
            origin,
            radius,
            enter_radius,
            has_sensors: scene.meshes.iter().any(|m| m.sensor),
            meshes,
            emitters,
            emitter_table,
            total_power,
            slots,
        };
        if aim_lights {
            let r = prepared.sphere_radius();
            for em in &mut prepared.emitters {
                if let EmitterKind::Light(shape) = &em.kind {
                    em.aim = Aim::new(shape, em.position, r);
                }
            }
        }
        Ok(prepared)
    }

    /// Radius of the sphere around the origin that holds all the geometry, sensors
    /// included: rays that miss it meet nothing.
    #[inline]
    fn sphere_radius(&self) -> f64 {
        sphere_radius(self.enter_radius, self.radius)
    }

    /// Where a ray from `org` along unit `dir` (local units) can first meet the geometry:
    /// `org` itself when it is near the scene, otherwise the point where the ray enters
    /// the bounding sphere (rays from far lights and cameras would otherwise lose the
    /// geometry's precision in f32), or None when it misses the sphere.
    #[inline]
    pub fn enter(&self, org: DVec3, dir: DVec3) -> Option<DVec3> {
        let r = self.sphere_radius();
        let d2 = org.length_squared();
        if d2 <= 4.0 * r * r {
            return Some(org);
        }
        // |org + t·dir|² = r²: t² + 2bt + c = 0 with b = org·dir, c = |org|² − r².
        let b = org.dot(dir);
        let c = d2 - r * r;
        let disc = b * b - c;
        if b >= 0.0 || disc <= 0.0 {
            return None;
        }
        // The nearer root, computed without cancellation.
        let t = c / (-b + disc.sqrt());
        Some(org + dir * t)
    }

    /// Where a ray leaving triangle `prim` of `mesh` at hit (u, v) starts before its offset
    /// along the normal, and that offset (`offset_at`): the hit's barycentrics clamped
    /// into the triangle (the tracer's f32 ones can lie an ulp outside), then moved the
    /// offset toward the triangle's centroid. A hit on the edge where two walls meet
    /// otherwise left from the other wall's plane, or just beyond it, and a ray from there
    /// could pass out of a closed box (a beam at a white box's edge lost 0.46 % of its
    /// energy).
    #[inline]
    pub fn leaving_point(&self, mesh: &PreparedMesh, prim: usize, u: f32, v: f32) -> (DVec3, f64) {
        let [a, b, c] = mesh.triangles[prim].map(|i| mesh.vertices[i as usize].as_dvec3());
        let (mut u, mut v) = ((u as f64).max(0.0), (v as f64).max(0.0));
        let sum = u + v;
        if sum > 1.0 {
            u /= sum;
            v /= sum;
        }
        let p = a + (b - a) * u + (c - a) * v;
        let eps = self.offset_at(p);
        let to_centre = (a + b + c) / 3.0 - p;
        let d = to_centre.length();
        let p = if d > eps {
            p + to_centre * (eps / d)
        } else {
            p + to_centre
        };
        (p, eps)
    }

    /// Offset that moves a new ray's origin off the surface at local point `p`: a few
    /// hundred f32 ulps of the coordinates' magnitude, so it scales with the geometry and
    /// never with the scene's absolute position (which the recentring removed).
    #[inline]
    pub fn offset_at(&self, p: DVec3) -> f64 {
        4e-6 * p.abs().max_element().max(1e-4 * self.radius)
    }

    /// Samples an emitter and a photon's first ray: (emitter index, origin, direction,
    /// weight, cos). The weight multiplies the photon's colour: 1 but for aimed lights
    /// (`Aim`), whose photons carry their light's flux share in the cone. `cos` is the
    /// cosine of the direction to an emitting mesh's normal (1 for lights).
    pub fn emit(&self, rng: &mut PhotonRng) -> (usize, DVec3, DVec3, f64, f64) {
        let e = self.emitter_table.sample(rng.uniform());
        let em = &self.emitters[e];
        match &em.kind {
            EmitterKind::Light(shape) => match &em.aim {
                Some(a) => {
                    let (u1, u2) = (rng.uniform(), rng.uniform());
                    let d = warp::uniform_narrow_cone(a.axis, a.one_minus_cos, u1, u2);
                    let w = a
                        .weight
                        .unwrap_or_else(|| shape.intensity_per_watt(d) * a.solid_angle);
                    (e, em.position, d, w, 1.0)
                }
                None => {
                    let (at, d) = shape.sample(rng);
                    (e, em.position + at, d, 1.0, 1.0)
                }
            },
            EmitterKind::Distant {
                part,
                portals: Some(p),
                ..
            } => {
                let (org, dir, w) = p.emit(part, rng);
                (e, org, dir, w, 1.0)
            }
            EmitterKind::Distant { part, radius, .. } => {
                let (toward, w) = part.sample([rng.uniform(), rng.uniform(), rng.uniform()]);
                let (t, b) = warp::basis(toward);
                let r = radius * rng.uniform().sqrt();
                let phi = 2.0 * std::f64::consts::PI * rng.uniform();
                let org = toward * (radius * 1.001) + t * (r * phi.cos()) + b * (r * phi.sin());
                (e, org, -toward, w, 1.0)
            }
            EmitterKind::Mesh {
                mesh,
                triangles,
                two_sided,
            } => {
                let pm = &self.meshes[*mesh];
                let (u1, u2) = (rng.uniform(), rng.uniform());
                let t = triangles.sample(rng.uniform());
                let [a, b, c] = pm.triangles[t].map(|i| pm.vertices[i as usize].as_dvec3());
                let (b1, b2) = warp::uniform_triangle(u1, u2);
                let p = a + (b - a) * b1 + (c - a) * b2;
                let mut n = pm.normals[t].as_dvec3();
                if *two_sided && rng.uniform() < 0.5 {
                    n = -n;
                }
                let d = warp::cosine_hemisphere(n, rng.uniform(), rng.uniform());
                (e, p + n * self.offset_at(p), d, 1.0, d.dot(n))
            }
        }
    }
}

/// `PreparedScene::sphere_radius` of a scene of `enter_radius` and `radius` (its
/// `offset_at` the origin included).
#[inline]
fn sphere_radius(enter_radius: f64, radius: f64) -> f64 {
    enter_radius * 1.01 + 4e-6 * 1e-4 * radius
}

/// The bounding box of the vertices triangles use in the meshes `keep` accepts; None when
/// it accepts none.
fn bounds(scene: &Scene, keep: impl Fn(&Mesh) -> bool) -> Option<(DVec3, DVec3)> {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut any = false;
    for m in scene.meshes.iter().filter(|m| keep(m)) {
        any = true;
        for t in &m.triangles {
            for &i in t {
                let p = DVec3::from(m.positions[i as usize]);
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
    }
    any.then_some((lo, hi))
}

/// Refuses a mesh whose triangles f32 coordinates cannot resolve: each vertex of a
/// triangle moves by up to half an f32 ulp of its largest local coordinate, which changes
/// the triangle by about that over its smallest height. The area-weighted mean of that
/// ratio (capped at 1) is the relative error the rounding can cause in the mesh's map.
fn check_precision(i: usize, m: &Mesh, p: &PreparedMesh, radius: f64) -> Result<()> {
    let (mut weighted, mut total) = (0.0, 0.0);
    let mut worst_at = 0.0f64;
    for t in &p.triangles {
        let [a, b, c] = t.map(|v| DVec3::from(m.positions[v as usize]));
        let [la, lb, lc] = t.map(|v| p.vertices[v as usize].as_dvec3());
        let area = 0.5 * (b - a).cross(c - a).length();
        if area.is_nan() || area <= 0.0 {
            continue;
        }
        let longest = (b - a).length().max((c - b).length()).max((a - c).length());
        let height = 2.0 * area / longest;
        let magnitude = la.abs().max(lb.abs()).max(lc.abs()).max_element();
        let eps = magnitude * f32::EPSILON as f64 * 0.5 * 3f64.sqrt();
        weighted += area * (eps / height).min(1.0);
        total += area;
        worst_at = worst_at.max(magnitude);
    }
    if total > 0.0 && weighted / total > MAX_DISTORTION {
        return Err(Error::new(
            ImapStatus::ImapErrPrecision,
            format!("mesh {i}: at {worst_at:.3e} scene units from the centre of the scene's bounding box (radius {radius:.3e}), single-precision ray tracing moves its triangles by {:.2} % of their size on average (most allowed: {} %); the scene's extent is too large for this mesh's detail: trace far-apart parts in separate contexts, or leave distant geometry out",
            100.0 * weighted / total,
            100.0 * MAX_DISTORTION),
        )
        .about(Subject::Mesh(i as u32)));
    }
    Ok(())
}

fn prepare_mesh(m: &Mesh, origin: DVec3, slot_base: Option<usize>) -> Result<PreparedMesh> {
    let local: Vec<DVec3> = try_collect(
        m.positions.iter().map(|&p| DVec3::from(p) - origin),
        "the prepared mesh's vertices",
    )?;
    let mut vertex_area = if slot_base.is_some() {
        try_filled(local.len(), 0.0, "the vertices' areas")?
    } else {
        Vec::new()
    };
    let normals = try_collect(
        m.triangles.iter().map(|t| {
            let [a, b, c] = t.map(|i| local[i as usize]);
            let n = (b - a).cross(c - a);
            let area = 0.5 * n.length();
            if !vertex_area.is_empty() {
                for &i in t {
                    vertex_area[i as usize] += area / 3.0;
                }
            }
            if area > 0.0 {
                (n / (2.0 * area)).as_vec3()
            } else {
                Vec3::ZERO
            }
        }),
        "the triangles' normals",
    )?;
    let materials = match &m.triangle_materials {
        Some(ids) => try_collect(ids.iter().copied(), "the triangles' materials")?,
        None => vec![m.material],
    };
    Ok(PreparedMesh {
        vertices: try_collect(local.iter().map(|p| p.as_vec3()), "the mesh's f32 vertices")?,
        triangles: try_collect(m.triangles.iter().copied(), "the prepared triangles")?,
        normals,
        materials,
        two_sided: m.two_sided,
        slot_base,
        vertex_area,
        sensor: m.sensor,
        tally: m.tally,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Bands, MaterialDesc};

    fn point(colour: Vec<f64>) -> Emitter {
        Emitter {
            kind: EmitterKind::Light(LightShape::Point),
            position: DVec3::ZERO,
            power: colour.clone(),
            colour,
            layer: 0,
            aim: None,
        }
    }

    #[test]
    fn grey_spectra_keep_each_light_shape_once_and_each_tint_within_the_cap() {
        let nb = 12;
        let bands = Bands::spectral(nb as u32, 400.0, 700.0).unwrap();
        let ramp: Vec<f64> = (0..nb).map(|b| 1.0 + b as f64).collect();
        let emitters = [
            point(ramp.clone()),
            point(ramp.iter().map(|x| 3.0 * x).collect()), // the same shape
            point(vec![2.0; nb]),
        ];
        let material = |rho: Vec<f64>| {
            Material::new(
                &MaterialDesc {
                    diffuse_reflect: rho,
                    ..Default::default()
                },
                &bands,
            )
            .unwrap()
        };
        let materials = [
            material(vec![0.5]),                                        // flat
            material((0..nb).map(|b| 0.2 + 0.05 * b as f64).collect()), // tinted
        ];
        let g = GreySpectra::new(&emitters, &materials, nb);
        // 12 bands: at most 3 sums. The two light shapes, then the first tint.
        assert_eq!(g.count(), 3);
        assert_eq!(g.of_emitter, vec![Some(0), Some(0), Some(1)]);
        assert!(g.spectrum(0).iter().all(|&s| s > 0.0 && s <= 1.0));
        assert_eq!(g.spectrum(0)[nb - 1], 1.0);
        // Off the flat material a colour stays in its class; off the tinted one it moves
        // to the tint kept for the first light (the second light's tint had no room), and
        // a second tint leaves every class.
        assert_eq!(g.after(0, 0, 0), Some(0));
        assert_eq!(g.after(0, 0, 1), Some(2));
        assert_eq!(g.after(1, 1, 1), None);
        assert_eq!(g.after(2, 0, 1), None);
        assert_eq!(g.after(2, 0, 0), Some(2));
        assert_eq!(g.after(0, 0, 7), None, "no such material");
        let tinted: Vec<f64> = g
            .spectrum(0)
            .iter()
            .zip(&materials[1].diffuse_reflect)
            .map(|(s, r)| 0.37 * s * r)
            .collect();
        assert!(g.multiple(2, &tinted).is_some());
        assert!(g.multiple(0, &tinted).is_none());
        // Few bands: no sums at all.
        let rgb = GreySpectra::new(&emitters, &materials, 3);
        assert_eq!((rgb.count(), rgb.of_emitter[0]), (0, None));
    }
}

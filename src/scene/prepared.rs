//! The prepared scene: geometry recentred for f32 precision, per-triangle normals and
//! areas, per-vertex area shares, the map's slot layout, and the light-selection table.

use super::emitter::{Aim, Emitter, EmitterKind, Photon, Portals, EMITTER_FLOOR, PORTAL_SHARE};
use super::mesh::triangle_area;
use super::prepared_mesh::{check_precision, prepare_mesh, PreparedMesh};
use super::texture::{Texture, TintScratch};
use super::{Bands, LightShape, Material, Mesh, Scene};
use crate::error::{bail, try_collect, Error, ImapStatus, Result, Subject};
use crate::sampling::{AliasTable, PhotonRng};
use glam::DVec3;
use std::sync::Arc;

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
    pub meshes: Vec<PreparedMesh>,
    pub emitters: Vec<Emitter>,
    pub emitter_table: AliasTable,
    /// Total emitted power, W, summed over bands.
    pub total_power: f64,
    pub slots: usize,
    /// Luminous efficacy of each band, lm/W.
    pub efficacy: Vec<f64>,
    /// The materials' textures (`Scene::textures`) and the bands they are read for.
    pub textures: Vec<Arc<Texture>>,
    pub bands: Bands,
    /// The scene's medium (`Scene::medium`) and the ball it fills.
    pub haze: Option<Haze>,
    /// Per mesh, the box around its vertices (local coordinates) when one of its materials
    /// scatters and no sensor reaches into the box: a segment inside a closed mesh ends
    /// inside it, so a photon there may draw its free flight before it traces the ray
    /// (`Tracer::trace`). Empty when no material scatters.
    pub early_flight_bounds: Vec<Option<[DVec3; 2]>>,
}

/// The medium outside the meshes (`Scene::medium`): its material, and the ball around the
/// local origin it fills (the sphere rays enter the scene by, which then holds every light
/// but the distant ones too).
#[derive(Clone, Debug, PartialEq)]
pub struct Haze {
    pub material: u32,
    /// Local scene units.
    pub radius: f64,
    /// Its extinction σt per band, 1/m (`Material::extinction`).
    pub sigma: Vec<f64>,
}

impl Haze {
    /// Its transmittance on the part of the ray `org + t dir`, 0 ≤ t ≤ `t_max` (infinite:
    /// to the ball's edge), inside the ball; `unit_m` metres per scene unit.
    #[inline]
    pub fn transmittance(
        &self,
        org: DVec3,
        dir: DVec3,
        t_max: f64,
        unit_m: f64,
    ) -> crate::spectral::Transmittance<'_> {
        let (t0, t1) = self.span(org, dir, t_max);
        crate::spectral::Transmittance {
            sigma: &self.sigma,
            d_m: (t1 - t0) * unit_m,
        }
    }

    /// The part (t0, t1) of the ray `org + t dir` (unit `dir`), 0 ≤ t ≤ `t_max`, that lies
    /// inside the ball; t0 = t1 when none does.
    #[inline]
    pub fn span(&self, org: DVec3, dir: DVec3, t_max: f64) -> (f64, f64) {
        let b = org.dot(dir);
        let c = org.length_squared() - self.radius * self.radius;
        let disc = b * b - c;
        if disc.is_nan() || disc <= 0.0 {
            return (0.0, 0.0);
        }
        let s = disc.sqrt();
        let t0 = (-b - s).max(0.0);
        let t1 = (-b + s).min(t_max);
        if t1 > t0 {
            (t0, t1)
        } else {
            (t0, t0)
        }
    }
}

impl PreparedScene {
    /// The material at barycentric (u, v) of triangle `prim` of mesh `mesh`: `materials`'
    /// own, or a copy in `scratch` with the coefficients its texture and the mesh's vertex
    /// factors vary (`scene::texture`). A mesh with neither looks nothing up.
    #[inline]
    pub fn material_at<'s>(
        &'s self,
        materials: &'s [Material],
        mesh: u32,
        prim: usize,
        (u, v): (f32, f32),
        scratch: &'s mut TintScratch,
    ) -> &'s Material {
        let m = &self.meshes[mesh as usize];
        let base = &materials[m.material(prim) as usize];
        if !m.tinted() {
            return base;
        }
        scratch.material(base, &self.textures, &self.bands, &m.tint_at(prim, u, v))
    }

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
        let mut enter_radius = match bounds(scene, |m| m.sensor) {
            Some((slo, shi)) => {
                let far = |p: DVec3| (p - origin).abs();
                radius.max(far(slo).max(far(shi)).length())
            }
            None => radius,
        };
        if scene.medium.is_some() {
            // The scene's medium fills the entering sphere, which then holds every light
            // but the distant ones: their photons start in it, and their light samples'
            // shadow rays lie in it whole.
            for l in &scene.lights {
                let extent = match &l.shape {
                    LightShape::Distant(_) => continue,
                    LightShape::Beam { aperture, .. } => aperture.u.length() + aperture.v.length(),
                    LightShape::Luminaire(lum) => {
                        lum.opening.map_or(0.0, |a| a.u.length() + a.v.length())
                    }
                    _ => 0.0,
                };
                enter_radius = enter_radius.max((l.position - origin).length() + extent);
            }
        }
        let mut slots = 0usize;
        let mut meshes = Vec::with_capacity(scene.meshes.len());
        // Tangents from texture coordinates only where a material asks for them.
        let any_uv_tangent = scene.materials.iter().any(|m| m.uv_tangent);
        for (i, m) in scene.meshes.iter().enumerate() {
            let uv_tangents = any_uv_tangent
                && m.uvs.is_some()
                && (0..m.triangles.len())
                    .any(|t| scene.materials[m.material_of(t) as usize].uv_tangent);
            let p = prepare_mesh(m, origin, m.record.then_some(slots), uv_tangents)?;
            check_precision(i, m, &p, radius)?;
            slots += m.map_slots();
            meshes.push(p);
        }

        let nb = scene.bands.count() as f64;
        let unit2 = scene.unit_m * scene.unit_m;
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
                        media: Vec::new(),
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
                media: Vec::new(),
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
                media: Vec::new(),
            });
            powers.push(total);
        }
        hold_in_media(scene, origin, &mut emitters);
        let mut total_power: f64 = powers.iter().sum();
        if emitters.is_empty() {
            // A scene without light is prepared for its geometry (straight lines); a run or
            // a render refuses it before any emitter is sampled (IMAP_ERR_NO_LIGHT).
            powers.push(1.0);
            total_power = 1.0;
        } else if !(total_power > 0.0 && total_power.is_finite()) {
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
        let mut prepared = PreparedScene {
            textures: scene.textures.clone(),
            bands: scene.bands.clone(),
            efficacy: efficacy.to_vec(),
            origin,
            radius,
            enter_radius,
            meshes,
            emitters,
            emitter_table,
            total_power,
            slots,
            haze: None,
            early_flight_bounds: Vec::new(),
        };
        prepared.early_flight_bounds = early_flight_bounds(scene, &prepared.meshes);
        prepared.haze = scene.medium.map(|material| Haze {
            material,
            radius: prepared.sphere_radius(),
            // (`Context::set_scene_medium` took only a material that holds a medium.)
            sigma: scene.materials[material as usize]
                .extinction()
                .map_or_else(Vec::new, <[f64]>::to_vec),
        });
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

    /// Samples an emitter by the light-selection table and its photon's first ray.
    #[inline]
    pub fn emit(&self, rng: &mut PhotonRng) -> (usize, Photon) {
        let e = self.emitter_table.sample(rng.uniform());
        let photon = self.emitters[e].emit(&self.meshes, |p| self.offset_at(p), rng);
        (e, photon)
    }
}

/// The closed meshes whose material holds a medium of a kind (`Enclosures::new`), with what
/// tells whether a point is inside each: the media around a light or a camera.
pub struct Enclosures<'s> {
    /// (mesh, its medium's material, its bounding box's volume).
    holders: Vec<(u32, u32, f64)>,
    insides: Vec<Box<dyn Fn([f64; 3]) -> bool + 's>>,
}

impl<'s> Enclosures<'s> {
    /// The meshes (sensors left out) one of whose materials `holds` (the first such on a
    /// mesh of several).
    pub fn new(scene: &'s Scene, holds: impl Fn(&Material) -> bool) -> Enclosures<'s> {
        if !scene.materials.iter().any(&holds) {
            return Enclosures {
                holders: Vec::new(),
                insides: Vec::new(),
            };
        }
        let holds = |id: u32| scene.materials.get(id as usize).is_some_and(&holds);
        let holders: Vec<(u32, u32, f64)> = scene
            .meshes
            .iter()
            .enumerate()
            .filter(|(_, m)| !m.sensor)
            .filter_map(|(i, m)| {
                let material = match &m.triangle_materials {
                    None => holds(m.material).then_some(m.material),
                    Some(ids) => ids.iter().copied().find(|&id| holds(id)),
                }?;
                let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
                for p in &m.positions {
                    lo = lo.min(DVec3::from(*p));
                    hi = hi.max(DVec3::from(*p));
                }
                Some((i as u32, material, (hi - lo).element_product()))
            })
            .collect();
        let insides = holders
            .iter()
            .map(|&(i, _, _)| {
                Box::new(scene.meshes[i as usize].inside()) as Box<dyn Fn([f64; 3]) -> bool + 's>
            })
            .collect();
        Enclosures { holders, insides }
    }

    pub fn is_empty(&self) -> bool {
        self.holders.is_empty()
    }

    /// The meshes around `p` (the scene's own coordinates) but `own`, each with its
    /// medium's material, outermost first (by their bounding boxes' volumes).
    pub fn at(&self, p: DVec3, own: Option<u32>) -> Vec<(u32, u32)> {
        let mut held: Vec<(u32, u32, f64)> = self
            .holders
            .iter()
            .zip(&self.insides)
            .filter(|(h, inside)| Some(h.0) != own && inside(p.to_array()))
            .map(|(h, _)| *h)
            .collect();
        held.sort_by(|a, b| b.2.total_cmp(&a.2));
        held.into_iter().map(|(i, m, _)| (i, m)).collect()
    }
}

/// Fills each point-like light's and emitting mesh's `Emitter::media`: the closed meshes
/// with a scattering (or fluorescent) medium around its position (an emitting mesh's: its
/// first triangle's centroid), outermost first. (Only scattering media hold lights: a lamp
/// inside a closed clear or tinted dielectric is a lamp in a glass globe drawn as one
/// surface, and starts outside it.)
fn hold_in_media(scene: &Scene, origin: DVec3, emitters: &mut [Emitter]) {
    let enclosures = Enclosures::new(scene, Material::scatters);
    if enclosures.is_empty() {
        return;
    }
    for em in emitters.iter_mut() {
        let (p, own) = match &em.kind {
            EmitterKind::Light(_) => (em.position + origin, None),
            EmitterKind::Mesh { mesh, .. } => {
                let m = &scene.meshes[*mesh];
                let Some(t) = m.triangles.first() else {
                    continue;
                };
                let c = t
                    .iter()
                    .map(|&v| DVec3::from(m.positions[v as usize]))
                    .sum::<DVec3>();
                (c / 3.0, Some(*mesh as u32))
            }
            EmitterKind::Distant { .. } => continue,
        };
        em.media = enclosures.at(p, own);
    }
}

/// `PreparedScene::early_flight_bounds` of the prepared `meshes` of `scene`.
fn early_flight_bounds(scene: &Scene, meshes: &[PreparedMesh]) -> Vec<Option<[DVec3; 2]>> {
    if !scene.materials.iter().any(Material::scatters) {
        return Vec::new();
    }
    let box_of = |m: &PreparedMesh| {
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for v in &m.vertices {
            lo = lo.min(v.as_dvec3());
            hi = hi.max(v.as_dvec3());
        }
        [lo, hi]
    };
    // The sensors' box, widened as the sensors' own traversal widens it
    // (`Accel::segment_meets_bounds`: a sensor there reads each segment to its surface).
    let sensors = meshes
        .iter()
        .filter(|m| m.sensor)
        .map(box_of)
        .reduce(|a, b| [a[0].min(b[0]), a[1].max(b[1])]);
    let reached = |[lo, hi]: [DVec3; 2]| {
        sensors.is_some_and(|[a, b]| {
            let pad = 1e-4 * (b - a).max_element().max(1e-30)
                + 1e-6 * lo.abs().max(hi.abs()).max_element();
            lo.cmple(b + DVec3::splat(pad)).all() && hi.cmpge(a - DVec3::splat(pad)).all()
        })
    };
    meshes
        .iter()
        .map(|m| {
            let scatters = m.materials.iter().any(|&id| {
                scene
                    .materials
                    .get(id as usize)
                    .is_some_and(Material::scatters)
            });
            scatters
                .then(|| box_of(m))
                .filter(|&b| !m.sensor && !reached(b))
        })
        .collect()
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

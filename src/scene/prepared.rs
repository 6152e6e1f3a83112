//! The prepared scene: geometry recentred for f32 precision, per-triangle normals and
//! areas, per-vertex area shares, the map's slot layout, and the light-selection table.

use super::{LightShape, Mesh, Scene};
use crate::sampling::{warp, AliasTable, PhotonRng};
use glam::{DVec3, Vec3};

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
    Point,
    Spot {
        axis: DVec3,
        cos_max: f64,
    },
    /// A self-emitting mesh: triangles chosen by area, Lambertian emission.
    Mesh {
        mesh: usize,
        triangles: AliasTable,
        two_sided: bool,
    },
}

/// Share of photons spread evenly over the emitters, whatever their power.
pub const EMITTER_FLOOR: f64 = 0.1;

/// One light source as the tracer sees it.
#[derive(Debug)]
pub struct Emitter {
    pub kind: EmitterKind,
    /// Position (scene units, recentred) for point-like emitters.
    pub position: DVec3,
    /// Colour of an emitted photon: per-band power share times the band count, scaled by
    /// the emitter's power share over its selection probability (mean 1 with one emitter).
    pub colour: Vec<f64>,
}

/// The frozen scene a run reads.
#[derive(Debug)]
pub struct PreparedScene {
    /// The scene-unit point that became the local origin.
    pub origin: DVec3,
    /// Half the diagonal of the bounding box, scene units.
    pub radius: f64,
    pub meshes: Vec<PreparedMesh>,
    pub emitters: Vec<Emitter>,
    pub emitter_table: AliasTable,
    /// Total emitted power, W, summed over bands.
    pub total_power: f64,
    pub slots: usize,
}

impl PreparedScene {
    /// Prepares `scene`. The caller has checked that it has meshes and lights.
    pub fn new(scene: &Scene) -> Self {
        let (lo, hi) = bounds(scene);
        let origin = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(f64::MIN_POSITIVE);
        let mut slots = 0usize;
        let meshes: Vec<PreparedMesh> = scene
            .meshes
            .iter()
            .map(|m| {
                let p = prepare_mesh(m, origin, m.record.then_some(slots));
                slots += m.map_slots();
                p
            })
            .collect();

        let nb = scene.bands.count() as f64;
        let unit2 = scene.unit_m * scene.unit_m;
        let mut emitters = Vec::new();
        let mut powers = Vec::new();
        let colour_of = |power: &[f64]| -> (Vec<f64>, f64) {
            let total: f64 = power.iter().sum();
            (power.iter().map(|p| p * nb / total).collect(), total)
        };
        for l in &scene.lights {
            let (colour, total) = colour_of(&l.power);
            let kind = match l.shape {
                LightShape::Point => EmitterKind::Point,
                LightShape::Spot {
                    axis,
                    cos_half_angle,
                } => EmitterKind::Spot {
                    axis,
                    cos_max: cos_half_angle,
                },
            };
            emitters.push(Emitter {
                kind,
                position: l.position - origin,
                colour,
            });
            powers.push(total);
        }
        for (i, m) in scene.meshes.iter().enumerate() {
            let Some(exitance) = &m.exitance else {
                continue;
            };
            let pm = &meshes[i];
            let areas: Vec<f64> = pm
                .triangles
                .iter()
                .map(|t| tri_area(&m.positions, t))
                .collect();
            let area: f64 = areas.iter().sum();
            if area <= 0.0 {
                continue;
            }
            let sides = m.sides() as f64;
            let power: Vec<f64> = exitance.iter().map(|e| e * area * unit2 * sides).collect();
            let (colour, total) = colour_of(&power);
            emitters.push(Emitter {
                kind: EmitterKind::Mesh {
                    mesh: i,
                    triangles: AliasTable::new(&areas),
                    two_sided: m.two_sided,
                },
                position: DVec3::ZERO,
                colour,
            });
            powers.push(total);
        }
        let total_power: f64 = powers.iter().sum();
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
        let emitter_table = AliasTable::new(&select);
        PreparedScene {
            origin,
            radius,
            meshes,
            emitters,
            emitter_table,
            total_power,
            slots,
        }
    }

    /// Offset that moves a new ray's origin off the surface at local point `p`: a few
    /// hundred f32 ulps of the coordinates' magnitude, so it scales with the geometry and
    /// never with the scene's absolute position (which the recentring removed).
    #[inline]
    pub fn offset_at(&self, p: DVec3) -> f64 {
        4e-6 * p.abs().max_element().max(1e-4 * self.radius)
    }

    /// Samples an emitter and a photon's first ray: (emitter index, origin, direction).
    pub fn emit(&self, rng: &mut PhotonRng) -> (usize, DVec3, DVec3) {
        let e = self.emitter_table.sample(rng.uniform());
        let em = &self.emitters[e];
        let (u1, u2) = (rng.uniform(), rng.uniform());
        match &em.kind {
            EmitterKind::Point => (e, em.position, warp::uniform_sphere(u1, u2)),
            EmitterKind::Spot { axis, cos_max } => {
                (e, em.position, warp::uniform_cone(*axis, *cos_max, u1, u2))
            }
            EmitterKind::Mesh {
                mesh,
                triangles,
                two_sided,
            } => {
                let pm = &self.meshes[*mesh];
                let t = triangles.sample(rng.uniform());
                let [a, b, c] = pm.triangles[t].map(|i| pm.vertices[i as usize].as_dvec3());
                let (b1, b2) = warp::uniform_triangle(u1, u2);
                let p = a + (b - a) * b1 + (c - a) * b2;
                let mut n = pm.normals[t].as_dvec3();
                if *two_sided && rng.uniform() < 0.5 {
                    n = -n;
                }
                let d = warp::cosine_hemisphere(n, rng.uniform(), rng.uniform());
                (e, p + n * self.offset_at(p), d)
            }
        }
    }
}

fn bounds(scene: &Scene) -> (DVec3, DVec3) {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let points = scene
        .meshes
        .iter()
        .flat_map(|m| m.positions.iter().map(|&p| DVec3::from(p)));
    for p in points.chain(scene.lights.iter().map(|l| l.position)) {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    (lo, hi)
}

fn tri_area(pos: &[[f64; 3]], t: &[u32; 3]) -> f64 {
    let [a, b, c] = t.map(|i| DVec3::from(pos[i as usize]));
    0.5 * (b - a).cross(c - a).length()
}

fn prepare_mesh(m: &Mesh, origin: DVec3, slot_base: Option<usize>) -> PreparedMesh {
    let local: Vec<DVec3> = m
        .positions
        .iter()
        .map(|&p| DVec3::from(p) - origin)
        .collect();
    let mut vertex_area = if slot_base.is_some() {
        vec![0.0; local.len()]
    } else {
        Vec::new()
    };
    let normals = m
        .triangles
        .iter()
        .map(|t| {
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
        })
        .collect();
    PreparedMesh {
        vertices: local.iter().map(|p| p.as_vec3()).collect(),
        triangles: m.triangles.clone(),
        normals,
        materials: m
            .triangle_materials
            .clone()
            .unwrap_or_else(|| vec![m.material]),
        two_sided: m.two_sided,
        slot_base,
        vertex_area,
    }
}

//! Triangle meshes as the caller describes them, validated on entry.

use crate::error::{bail, check_coordinates, check_finite, try_collect, try_with_capacity, Result};
use crate::scene::texture::{check_channels, check_unit, VertexFactors};
use crate::spectral::Bands;

/// A validated mesh. Positions are kept in f64 as given; the prepared scene recentres them
/// before handing f32 copies to Embree.
#[derive(Clone, Debug)]
pub struct Mesh {
    pub positions: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
    /// The material of every triangle without a per-triangle id.
    pub material: u32,
    /// Optional per-triangle material ids (the mesh's parts).
    pub triangle_materials: Option<Vec<u32>>,
    /// Both sides record (and emit) separately; otherwise only the front side, the one the
    /// normal (v1 − v0) × (v2 − v0) points to.
    pub two_sided: bool,
    /// Whether the mesh's vertices accumulate irradiance. Lamps and glass usually do not.
    pub record: bool,
    /// Radiant exitance per band in W/m² of the emitting side(s); `None` when not emitting.
    pub exitance: Option<Vec<f64>>,
    /// A sensor: records the photons that cross it (from its recorded sides) and is
    /// otherwise not there: it neither blocks, reflects nor absorbs anything.
    pub sensor: bool,
    /// Keep per-photon tallies of the mesh's regions (its sides and parts), which give
    /// their flux and Eavg exact errors (docs/results.md); sensors always do. Costs work at
    /// every deposit on the mesh, so only on request.
    pub tally: bool,
    /// Light group of an emitting mesh's photons (see `Light::group`).
    pub light_group: u32,
    /// Triangles of the description left out because they repeat a vertex
    /// (`MeshDesc::skip_degenerate`).
    pub dropped_triangles: usize,
    /// Texture coordinates (u, v) per vertex, for textured materials.
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Per-vertex factors of the coefficients its materials' `tint_lobes` name.
    pub factors: Option<VertexFactors>,
}

/// What the caller passes to `add_mesh`.
#[derive(Clone, Copy, Debug)]
pub struct MeshDesc<'a> {
    /// x, y, z of each vertex, in scene units.
    pub positions: &'a [f64],
    /// Three vertex indices per triangle.
    pub indices: &'a [u32],
    pub material: u32,
    pub triangle_materials: Option<&'a [u32]>,
    pub two_sided: bool,
    pub record: bool,
    pub exitance: Option<&'a [f64]>,
    /// A sensor (see `Mesh::sensor`); it records whatever `record` says.
    pub sensor: bool,
    /// See `Mesh::tally`.
    pub tally: bool,
    /// Leave out (and count in `Mesh::dropped_triangles`) the triangles that repeat a
    /// vertex instead of refusing the mesh. CAD exports hold many of them; they have no
    /// area and carry no light, so dropping them changes nothing else.
    pub skip_degenerate: bool,
    /// Texture coordinates, u and v per vertex (textured materials need them).
    pub uvs: Option<&'a [f64]>,
    /// Factors in [0, 1] per vertex and channel (`vertex_factor_channels`: 1, 3 or the
    /// band count) of the coefficients its materials' `texture_lobes` name, mixed
    /// barycentrically over each triangle.
    pub vertex_factors: Option<&'a [f64]>,
    pub vertex_factor_channels: usize,
}

impl Mesh {
    /// Validates a description. `material_count` is the number of materials defined so far.
    pub fn new(desc: &MeshDesc, material_count: usize, bands: &Bands) -> Result<Self> {
        if desc.positions.len() % 3 != 0 {
            bail!(
                ImapErrInvalidArgument,
                "positions has {} values, not a multiple of 3",
                desc.positions.len()
            );
        }
        if desc.indices.len() % 3 != 0 {
            bail!(
                ImapErrInvalidArgument,
                "indices has {} values, not a multiple of 3",
                desc.indices.len()
            );
        }
        let nv = desc.positions.len() / 3;
        let nt = desc.indices.len() / 3;
        if nv == 0 || nt == 0 {
            bail!(
                ImapErrEmptyMesh,
                "mesh has {nv} vertices and {nt} triangles: a mesh needs at least one triangle"
            );
        }
        if nv > u32::MAX as usize / 2 || nt > u32::MAX as usize / 2 {
            bail!(
                ImapErrInvalidArgument,
                "mesh is too large ({nv} vertices, {nt} triangles; at most 2^31 each)"
            );
        }
        check_coordinates("positions", desc.positions)?;
        let positions: Vec<[f64; 3]> = try_collect(
            desc.positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]),
            "the mesh's positions",
        )?;
        let mut triangles = try_with_capacity(nt, "the mesh's triangles")?;
        // Input triangles kept (only built when some are dropped).
        let mut kept: Option<Vec<usize>> = None;
        for (t, tri) in desc.indices.chunks_exact(3).enumerate() {
            if let Some(&i) = tri.iter().find(|&&i| i as usize >= nv) {
                bail!(
                    ImapErrIndexOutOfRange,
                    "triangle {t} uses vertex {i}, but the mesh has {nv} vertices"
                );
            }
            if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] {
                if desc.skip_degenerate {
                    kept.get_or_insert_with(|| (0..t).collect());
                    continue;
                }
                bail!(
                    ImapErrDegenerateTriangle,
                    "triangle {t} uses a vertex twice ({}, {}, {})",
                    tri[0],
                    tri[1],
                    tri[2]
                );
            }
            if let Some(k) = kept.as_mut() {
                k.push(t);
            }
            triangles.push([tri[0], tri[1], tri[2]]);
        }
        let dropped_triangles = nt - triangles.len();
        if triangles.is_empty() {
            bail!(
                ImapErrDegenerateTriangle,
                "every one of the mesh's {nt} triangles uses a vertex twice: nothing is left"
            );
        }
        // A sensor's materials are only labels of its parts: no material need exist.
        let check_material = |what: &str, m: u32| -> Result<()> {
            if !desc.sensor && m as usize >= material_count {
                bail!(
                    ImapErrUnknownMaterial,
                    "{what} is material {m}, but only {material_count} materials are defined"
                );
            }
            Ok(())
        };
        check_material("the mesh material", desc.material)?;
        let triangle_materials = match desc.triangle_materials {
            None => None,
            Some(ids) => {
                if ids.len() != nt {
                    bail!(
                        ImapErrInvalidArgument,
                        "triangle_materials has {} ids for {nt} triangles",
                        ids.len()
                    );
                }
                if let Some(t) = ids.iter().position(|&m| m as usize >= material_count) {
                    check_material(&format!("triangle {t}'s material"), ids[t])?;
                }
                Some(match &kept {
                    None => try_collect(ids.iter().copied(), "the mesh's triangle materials")?,
                    Some(k) => {
                        try_collect(k.iter().map(|&t| ids[t]), "the mesh's triangle materials")?
                    }
                })
            }
        };
        if desc.sensor && desc.exitance.is_some() {
            bail!(
                ImapErrInvalidArgument,
                "a sensor mesh cannot emit: it is not there for the light (give it no exitance)"
            );
        }
        if desc.sensor && !desc.record {
            bail!(
                ImapErrInvalidArgument,
                "a sensor mesh must record (set the record flag): a sensor that records nothing does nothing"
            );
        }
        let exitance = match desc.exitance {
            None => None,
            Some(e) => {
                let e = bands.expand_emission("exitance", e)?;
                let area: f64 = triangles
                    .iter()
                    .map(|t: &[u32; 3]| triangle_area(&positions, t))
                    .sum();
                if area.is_nan() || area <= 0.0 {
                    bail!(
                        ImapErrNoLight,
                        "the mesh emits (exitance given) but its triangles have zero total area"
                    );
                }
                if !area.is_finite() {
                    bail!(
                        ImapErrPrecision,
                        "the emitting mesh's area overflows ({area}): its coordinates are too large"
                    );
                }
                Some(e)
            }
        };
        let uvs = match desc.uvs {
            None => None,
            Some(uv) => {
                if uv.len() != 2 * nv {
                    bail!(
                        ImapErrInvalidArgument,
                        "uvs has {} values for {nv} vertices (u and v per vertex: {})",
                        uv.len(),
                        2 * nv
                    );
                }
                check_finite("uvs", uv)?;
                Some(try_collect(
                    uv.chunks_exact(2).map(|c| [c[0] as f32, c[1] as f32]),
                    "the mesh's texture coordinates",
                )?)
            }
        };
        let factors = match desc.vertex_factors {
            None => None,
            Some(f) => {
                let c = desc.vertex_factor_channels;
                check_channels("vertex_factor_channels", c, bands)?;
                if f.len() != c * nv {
                    bail!(
                        ImapErrInvalidArgument,
                        "vertex_factors has {} values for {nv} vertices of {c} channels ({})",
                        f.len(),
                        c * nv
                    );
                }
                check_unit("vertex_factors", f)?;
                Some(VertexFactors {
                    channels: c,
                    values: try_collect(f.iter().map(|&x| x as f32), "the mesh's vertex factors")?,
                })
            }
        };
        if desc.sensor && (uvs.is_some() || factors.is_some()) {
            bail!(
                ImapErrInvalidArgument,
                "a sensor mesh has no surface to texture (give it no uvs or vertex factors)"
            );
        }
        Ok(Mesh {
            positions,
            triangles,
            material: desc.material,
            triangle_materials,
            two_sided: desc.two_sided,
            record: desc.record,
            exitance,
            sensor: desc.sensor,
            tally: desc.sensor || desc.tally,
            light_group: 0,
            dropped_triangles,
            uvs,
            factors,
        })
    }

    /// A test of whether a point lies inside the mesh, taken as closed: an odd number of
    /// its triangles cross a ray from the point in a fixed direction of no special
    /// alignment (a point outside its bounding box, found once, is outside).
    pub fn inside(&self) -> impl Fn([f64; 3]) -> bool + '_ {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for v in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        move |p| (0..3).all(|k| p[k] > lo[k] && p[k] < hi[k]) && self.crossings(p) % 2 == 1
    }

    /// How many triangles a ray from `p` along `inside`'s direction crosses.
    fn crossings(&self, p: [f64; 3]) -> u32 {
        let p = glam::DVec3::from(p);
        let d = glam::DVec3::new(0.5773, 0.6121, 0.5401).normalize();
        let mut crossings = 0u32;
        for t in &self.triangles {
            let [a, b, c] = t.map(|i| glam::DVec3::from(self.positions[i as usize]));
            // Möller–Trumbore, both sides.
            let (e1, e2) = (b - a, c - a);
            let q = d.cross(e2);
            let det = e1.dot(q);
            if det.abs() < 1e-300 {
                continue;
            }
            let s = p - a;
            let u = s.dot(q) / det;
            if !(0.0..=1.0).contains(&u) {
                continue;
            }
            let r = s.cross(e1);
            let v = d.dot(r) / det;
            if v < 0.0 || u + v > 1.0 {
                continue;
            }
            if e2.dot(r) / det > 0.0 {
                crossings += 1;
            }
        }
        crossings
    }

    /// The material (for a sensor: the part label) of triangle `t`.
    pub fn material_of(&self, t: usize) -> u32 {
        self.triangle_materials
            .as_ref()
            .map_or(self.material, |ids| ids[t])
    }

    /// Each vertex's share — a third of each — of the area of the triangles of material
    /// `part` (all triangles for None), scene units².
    pub fn area_shares(&self, part: Option<u32>) -> Vec<f64> {
        let mut out = vec![0.0; self.positions.len()];
        for (t, tri) in self.triangles.iter().enumerate() {
            if part.is_none_or(|p| self.material_of(t) == p) {
                let a = triangle_area(&self.positions, tri) / 3.0;
                for &v in tri {
                    out[v as usize] += a;
                }
            }
        }
        out
    }

    pub fn sides(&self) -> usize {
        if self.two_sided {
            2
        } else {
            1
        }
    }

    /// Map slots the mesh needs: one per vertex and recorded side; 0 when not recorded.
    pub fn map_slots(&self) -> usize {
        map_slots(self.positions.len(), self.two_sided, self.record)
    }
}

/// Area of triangle `t`, scene units².
pub fn triangle_area(pos: &[[f64; 3]], t: &[u32; 3]) -> f64 {
    let [a, b, c] = t.map(|i| glam::DVec3::from(pos[i as usize]));
    0.5 * (b - a).cross(c - a).length()
}

impl<'a> MeshDesc<'a> {
    /// A one-sided, recording, non-emitting mesh of one material; change the rest with
    /// struct update syntax (`MeshDesc { two_sided: true, ..MeshDesc::new(p, i, m) }`).
    pub fn new(positions: &'a [f64], indices: &'a [u32], material: u32) -> Self {
        MeshDesc {
            positions,
            indices,
            material,
            triangle_materials: None,
            two_sided: false,
            record: true,
            exitance: None,
            sensor: false,
            tally: false,
            skip_degenerate: false,
            uvs: None,
            vertex_factors: None,
            vertex_factor_channels: 1,
        }
    }

    /// `Mesh::map_slots` from the description alone, before anything is copied.
    pub fn map_slots(&self) -> usize {
        map_slots(self.positions.len() / 3, self.two_sided, self.record)
    }
}

fn map_slots(vertices: usize, two_sided: bool, record: bool) -> usize {
    if record {
        vertices * if two_sided { 2 } else { 1 }
    } else {
        0
    }
}

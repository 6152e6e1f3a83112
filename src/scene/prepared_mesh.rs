//! A mesh ready for tracing: vertices recentred for f32 precision, per-triangle normals,
//! per-vertex area shares and its map slots; the precision check that refuses what f32
//! cannot resolve.

use super::texture::{TintAt, VertexFactors};
use super::Mesh;
use crate::error::{try_collect, try_filled, Error, ImapStatus, Result, Subject};
use glam::{DVec3, Vec3};

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
    /// Texture coordinates and vertex factors (`Mesh::uvs`, `Mesh::factors`).
    pub uvs: Option<Vec<[f32; 2]>>,
    pub factors: Option<VertexFactors>,
    /// Each triangle's direction of increasing u (∂P/∂u, unit; zero where its texture
    /// coordinates are degenerate), when one of its materials takes its tangent from the
    /// texture coordinates (`Material::uv_tangent`).
    pub uv_tangents: Option<Vec<Vec3>>,
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

    /// Whether its coefficients vary over it (texture coordinates or vertex factors).
    #[inline]
    pub fn tinted(&self) -> bool {
        self.uvs.is_some() || self.factors.is_some()
    }

    /// What tinting needs of barycentric (u, v) of triangle `prim`.
    #[inline]
    pub fn tint_at(&self, prim: usize, u: f32, v: f32) -> TintAt<'_> {
        let tri = self.triangles[prim];
        let (u, v) = (u as f64, v as f64);
        TintAt {
            uvs: self.uvs.as_ref().map(|uv| tri.map(|i| uv[i as usize])),
            factors: self.factors.as_ref().map(|f| (f, tri)),
            tangent: self
                .uv_tangents
                .as_ref()
                .map(|t| t[prim])
                .filter(|t| *t != Vec3::ZERO)
                .map(|t| t.as_dvec3()),
            w: [1.0 - u - v, u, v],
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

/// Refuses a mesh whose triangles f32 coordinates cannot resolve: each vertex of a
/// triangle moves by up to half an f32 ulp of its largest local coordinate, which changes
/// the triangle by about that over its smallest height. The area-weighted mean of that
/// ratio (capped at 1) is the relative error the rounding can cause in the mesh's map.
pub(super) fn check_precision(i: usize, m: &Mesh, p: &PreparedMesh, radius: f64) -> Result<()> {
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

pub(super) fn prepare_mesh(
    m: &Mesh,
    origin: DVec3,
    slot_base: Option<usize>,
    uv_tangents: bool,
) -> Result<PreparedMesh> {
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
        uvs: m.uvs.clone(),
        factors: m.factors.clone(),
        uv_tangents: match (&m.uvs, uv_tangents) {
            (Some(uvs), true) => Some(try_collect(
                m.triangles.iter().map(|tri| {
                    let p = tri.map(|i| local[i as usize]);
                    let uv = tri.map(|i| uvs[i as usize].map(f64::from));
                    uv_tangent(p, uv)
                }),
                "the triangles' texture tangents",
            )?),
            _ => None,
        },
    })
}

/// The unit direction of increasing u over a triangle of corners `p` and texture
/// coordinates `uv`: ∂P/∂u from the two edges; zero where the coordinates are degenerate.
fn uv_tangent(p: [DVec3; 3], uv: [[f64; 2]; 3]) -> Vec3 {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let (du1, dv1) = (uv[1][0] - uv[0][0], uv[1][1] - uv[0][1]);
    let (du2, dv2) = (uv[2][0] - uv[0][0], uv[2][1] - uv[0][1]);
    let det = du1 * dv2 - du2 * dv1;
    if det == 0.0 {
        return Vec3::ZERO;
    }
    let t = (e1 * dv2 - e2 * dv1) / det;
    if !t.is_finite() || t.length_squared() == 0.0 {
        return Vec3::ZERO;
    }
    t.normalize().as_vec3()
}

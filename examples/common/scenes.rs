//! Benchmark scenes generated in code (shared by the examples and `tests/scenes.rs`; the
//! library does not carry them) with the statistics of the first paper's five test
//! scenes (§4): objects, triangles, parts (materials), vertices and lights. `scale`
//! multiplies the triangle (and so vertex) counts: 1 gives the paper's sizes, tests use
//! 0.001–0.01. Geometry is made of tessellated boxes, grids and spheres; what matters for
//! the schedulers is the number of vertices, how photons spread over them, the number of
//! lights and (for "dispersion") a dispersive prism that concentrates photons on a small
//! part of the map.

#![allow(dead_code)]

use imap::{Context, IorModel, MaterialDesc, MeshDesc, Result};

/// The five scenes of the paper.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneKind {
    Dispersion,
    Room,
    Vehicle,
    Hall,
    Atrium,
}

impl SceneKind {
    pub const ALL: [SceneKind; 5] = [
        SceneKind::Dispersion,
        SceneKind::Room,
        SceneKind::Vehicle,
        SceneKind::Hall,
        SceneKind::Atrium,
    ];

    pub fn name(self) -> &'static str {
        match self {
            SceneKind::Dispersion => "dispersion",
            SceneKind::Room => "room",
            SceneKind::Vehicle => "vehicle",
            SceneKind::Hall => "hall",
            SceneKind::Atrium => "atrium",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The paper's statistics: (objects, triangles, parts, vertices, lights).
    pub fn paper(self) -> (usize, usize, usize, usize, usize) {
        match self {
            SceneKind::Dispersion => (16, 3_988_110, 16, 2_002_795, 2),
            SceneKind::Room => (1, 5_645_608, 20, 2_925_375, 9),
            SceneKind::Vehicle => (205, 12_533_973, 213, 6_709_308, 7),
            SceneKind::Hall => (18_207, 387_975, 18_207, 423_419, 361),
            SceneKind::Atrium => (1, 4_543_887, 32, 2_380_261, 108),
        }
    }
}

/// What was built.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Built {
    pub meshes: Vec<u32>,
    pub objects: usize,
    pub triangles: usize,
    pub vertices: usize,
    pub parts: usize,
    pub lights: usize,
}

/// A mesh under construction, with a part (material slot) per triangle.
#[derive(Default)]
struct Tess {
    positions: Vec<f64>,
    indices: Vec<u32>,
    parts: Vec<u32>,
}

impl Tess {
    /// The quad o + s·u + t·v (s, t ∈ [0, 1]) as an n×m grid; normal u × v.
    fn quad(&mut self, o: [f64; 3], u: [f64; 3], v: [f64; 3], n: usize, m: usize, part: u32) {
        let base = (self.positions.len() / 3) as u32;
        for j in 0..=m {
            for i in 0..=n {
                let (s, t) = (i as f64 / n as f64, j as f64 / m as f64);
                self.positions
                    .extend((0..3).map(|k| o[k] + s * u[k] + t * v[k]));
            }
        }
        let id = |i: usize, j: usize| base + (j * (n + 1) + i) as u32;
        for j in 0..m {
            for i in 0..n {
                self.indices.extend([
                    id(i, j),
                    id(i + 1, j),
                    id(i + 1, j + 1),
                    id(i, j),
                    id(i + 1, j + 1),
                    id(i, j + 1),
                ]);
                self.parts.extend([part, part]);
            }
        }
    }

    /// An axis-aligned box, n×n cells per face, normals out (or in); part + face index
    /// when `part_per_face`.
    fn cuboid(
        &mut self,
        lo: [f64; 3],
        hi: [f64; 3],
        n: usize,
        inward: bool,
        part: u32,
        part_per_face: bool,
    ) {
        let d = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        for axis in 0..3 {
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            for (k, positive) in [false, true].into_iter().enumerate() {
                let mut o = lo;
                if positive {
                    o[axis] = hi[axis];
                }
                let mut u = [0.0; 3];
                let mut v = [0.0; 3];
                u[a] = d[a];
                v[b] = d[b];
                // u × v points along +axis; flip for the faces that must point the other way.
                let (u, v) = if positive != inward { (u, v) } else { (v, u) };
                let p = if part_per_face {
                    part + (2 * axis + k) as u32
                } else {
                    part
                };
                self.quad(o, u, v, n, n, p);
            }
        }
    }

    /// A closed box with shared corners (8 vertices, 12 triangles), normals out.
    fn solid_box(&mut self, lo: [f64; 3], hi: [f64; 3], part: u32) {
        let base = (self.positions.len() / 3) as u32;
        for k in 0..8 {
            self.positions.extend([
                if k & 1 == 0 { lo[0] } else { hi[0] },
                if k & 2 == 0 { lo[1] } else { hi[1] },
                if k & 4 == 0 { lo[2] } else { hi[2] },
            ]);
        }
        // Faces as (corner bits) quads, counter-clockwise seen from outside.
        for q in [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ] {
            self.indices
                .extend([q[0], q[1], q[2], q[0], q[2], q[3]].map(|i| base + i));
            self.parts.extend([part, part]);
        }
    }

    /// A UV sphere with `rings` rings and 2·rings segments, normals out.
    fn sphere(&mut self, c: [f64; 3], r: f64, rings: usize, part: u32) {
        let segs = 2 * rings;
        let base = (self.positions.len() / 3) as u32;
        self.positions.extend([c[0], c[1], c[2] + r]);
        for i in 1..rings {
            let th = std::f64::consts::PI * i as f64 / rings as f64;
            for j in 0..segs {
                let ph = 2.0 * std::f64::consts::PI * j as f64 / segs as f64;
                self.positions.extend([
                    c[0] + r * th.sin() * ph.cos(),
                    c[1] + r * th.sin() * ph.sin(),
                    c[2] + r * th.cos(),
                ]);
            }
        }
        self.positions.extend([c[0], c[1], c[2] - r]);
        let ring = |i: usize, j: usize| base + 1 + ((i - 1) * segs + j % segs) as u32;
        let south = base + 1 + ((rings - 1) * segs) as u32;
        for j in 0..segs {
            self.indices.extend([base, ring(1, j), ring(1, j + 1)]);
            self.indices
                .extend([south, ring(rings - 1, j + 1), ring(rings - 1, j)]);
            self.parts.extend([part, part]);
        }
        for i in 1..rings - 1 {
            for j in 0..segs {
                self.indices.extend([
                    ring(i, j),
                    ring(i + 1, j),
                    ring(i + 1, j + 1),
                    ring(i, j),
                    ring(i + 1, j + 1),
                    ring(i, j + 1),
                ]);
                self.parts.extend([part, part]);
            }
        }
    }

    fn triangles(&self) -> usize {
        self.indices.len() / 3
    }

    /// Adds the mesh; `materials[part]` maps parts to material ids.
    fn add(
        &self,
        ctx: &mut Context,
        materials: &[u32],
        record: bool,
        exitance: Option<&[f64]>,
        built: &mut Built,
    ) -> Result<u32> {
        let tm: Vec<u32> = self.parts.iter().map(|&p| materials[p as usize]).collect();
        let uniform = tm.iter().all(|&m| m == tm[0]);
        let desc = MeshDesc {
            triangle_materials: (!uniform).then_some(&tm[..]),
            record,
            exitance,
            ..MeshDesc::new(&self.positions, &self.indices, tm[0])
        };
        let id = ctx.add_mesh(&desc)?;
        built.meshes.push(id);
        built.objects += 1;
        built.triangles += self.triangles();
        built.vertices += self.positions.len() / 3;
        Ok(id)
    }
}

/// Cells per side of an n×n face that give about `tris` triangles over `faces` faces.
fn cells(tris: f64, faces: f64) -> usize {
    ((tris / (2.0 * faces)).sqrt().round() as usize).max(1)
}

/// `count` Lambertian materials with reflectances between 0.2 and 0.8 and a tint that
/// varies with the band (so spectral runs carry real spectra).
fn palette(ctx: &mut Context, count: usize) -> Result<Vec<u32>> {
    let bands = ctx.config().bands.count();
    (0..count)
        .map(|i| {
            let base = 0.2 + 0.6 * ((i * 7919) % 101) as f64 / 100.0;
            let tilt = ((i * 104_729) % 13) as f64 / 13.0 - 0.5;
            let rho: Vec<f64> = (0..bands)
                .map(|b| {
                    (base + 0.3 * tilt * (b as f64 / (bands.max(2) - 1) as f64 - 0.5))
                        .clamp(0.05, 0.9)
                })
                .collect();
            ctx.add_material(&MaterialDesc {
                diffuse_reflect: rho,
                ..Default::default()
            })
        })
        .collect()
}

/// Height of the grey room's emitter (`grey_room`), just under its ceiling.
pub const GREY_ROOM_EMITTER_Z: f64 = 0.98;
/// Exitance of the grey room's emitter, W/m² per band.
pub const GREY_ROOM_EXITANCE: f64 = 2500.0;

/// The benchmark room of the time-to-accuracy issues (16 and 18): its recorded walls'
/// mesh with their positions and triangles (for analytic answers), and the emitter's
/// corners.
pub struct GreyRoom {
    pub walls: u32,
    /// The emitter's black material (for further black surfaces).
    pub black: u32,
    pub positions: Vec<f64>,
    pub indices: Vec<u32>,
    pub emitter: [[f64; 3]; 4],
}

/// Builds the grey room into `ctx`: the unit cube's six inward faces as one recorded mesh
/// of ρ = 0.5 (each face `n` × `n` cells), and a black 0.2 m square emitter facing down at
/// `GREY_ROOM_EMITTER_Z`, exitance `GREY_ROOM_EXITANCE`, not recorded.
pub fn grey_room(ctx: &mut Context, n: usize) -> Result<GreyRoom> {
    grey_room_with_floor(ctx, n, None)
}

/// `grey_room` with its floor's triangles of material `floor` when given (the rest
/// Lambertian ρ = 0.5).
pub fn grey_room_with_floor(
    ctx: &mut Context,
    n: usize,
    floor: Option<&MaterialDesc>,
) -> Result<GreyRoom> {
    grey_room_at(ctx, n, floor, GREY_ROOM_EMITTER_Z)
}

/// `grey_room_with_floor` with the emitter at height `emitter_z` (the peers' comparison of
/// issue 37 put it 1 mm under the ceiling: 0.999).
pub fn grey_room_at(
    ctx: &mut Context,
    n: usize,
    floor: Option<&MaterialDesc>,
    emitter_z: f64,
) -> Result<GreyRoom> {
    let grey = ctx.add_material(&MaterialDesc {
        diffuse_reflect: vec![0.5],
        ..Default::default()
    })?;
    let floor_m = floor.map(|d| ctx.add_material(d)).transpose()?;
    let black = ctx.add_material(&MaterialDesc::default())?;
    // An n × n grid o + s·u + t·v with normal u × v.
    let quad = |o: [f64; 3],
                u: [f64; 3],
                v: [f64; 3],
                n: usize,
                pos: &mut Vec<f64>,
                idx: &mut Vec<u32>| {
        let base = (pos.len() / 3) as u32;
        for j in 0..=n {
            for i in 0..=n {
                let (s, t) = (i as f64 / n as f64, j as f64 / n as f64);
                pos.extend((0..3).map(|k| o[k] + s * u[k] + t * v[k]));
            }
        }
        let w = n as u32 + 1;
        for j in 0..n as u32 {
            for i in 0..n as u32 {
                let a = base + j * w + i;
                idx.extend([a, a + 1, a + w + 1, a, a + w + 1, a + w]);
            }
        }
    };
    let (mut p, mut t) = (Vec::new(), Vec::new());
    let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    quad([0.0; 3], x, y, n, &mut p, &mut t); // floor, +z
    quad(z, y, x, n, &mut p, &mut t); // ceiling, −z
    quad([0.0; 3], z, x, n, &mut p, &mut t); // y = 0, +y
    quad(y, x, z, n, &mut p, &mut t); // y = 1, −y
    quad([0.0; 3], y, z, n, &mut p, &mut t); // x = 0, +x
    quad(x, z, y, n, &mut p, &mut t); // x = 1, −x
                                      // The floor is the first n² cells (2n² triangles).
    let parts: Option<Vec<u32>> = floor_m.map(|f| {
        (0..t.len() / 3)
            .map(|i| if i < 2 * n * n { f } else { grey })
            .collect()
    });
    let walls = ctx.add_mesh(&MeshDesc {
        triangle_materials: parts.as_deref(),
        ..MeshDesc::new(&p, &t, grey)
    })?;
    let (a, b, h) = (0.4, 0.6, emitter_z);
    let (mut lp, mut lt) = (Vec::new(), Vec::new());
    quad(
        [a, a, h],
        [0.0, b - a, 0.0],
        [b - a, 0.0, 0.0],
        1,
        &mut lp,
        &mut lt,
    );
    ctx.add_mesh(&MeshDesc {
        record: false,
        exitance: Some(&[GREY_ROOM_EXITANCE]),
        ..MeshDesc::new(&lp, &lt, black)
    })?;
    Ok(GreyRoom {
        walls,
        black,
        positions: p,
        indices: t,
        emitter: [[a, a, h], [b, a, h], [b, b, h], [a, b, h]],
    })
}

/// A generated HDR environment, 256 × 128 linear RGB, like a photographed clear sky: a
/// bluish CIE type 12 sky (sun at azimuth 135°, 40° from the zenith), the sun's disk
/// widened to 2° and ~10⁴ times brighter than the sky next to it, and a dim brown ground
/// below the horizon.
pub fn vehicle_sky() -> (usize, usize, Vec<f32>) {
    use std::f64::consts::PI;
    let (w, h) = (256usize, 128usize);
    let (sa, sz) = (135f64.to_radians(), 40f64.to_radians());
    // Directions with azimuth from north (+y) toward east (+x), as the sky frame's default.
    let dir = |a: f64, z: f64| [z.sin() * a.sin(), z.sin() * a.cos(), z.cos()];
    let sun = dir(sa, sz);
    let mut rgb = Vec::with_capacity(w * h * 3);
    for i in 0..h {
        let z = (i as f64 + 0.5) / h as f64 * PI;
        for j in 0..w {
            // The centre column looks north.
            let a = -PI + (j as f64 + 0.5) / w as f64 * 2.0 * PI;
            let d = dir(a, z);
            let chi = (d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2])
                .clamp(-1.0, 1.0)
                .acos();
            let px = if z >= PI / 2.0 {
                [0.05, 0.04, 0.03]
            } else if chi < 1f64.to_radians() {
                [2.0e3, 1.9e3, 1.7e3]
            } else {
                let l = imap::cie_luminance(12, z, chi, sz);
                [0.6 * l, 0.8 * l, 1.2 * l]
            };
            rgb.extend(px.map(|v| v as f32));
        }
    }
    (w, h, rgb)
}

/// Builds scene `kind` at `scale` into `ctx` (which must have no meshes yet).
pub fn build(ctx: &mut Context, kind: SceneKind, scale: f64) -> Result<Built> {
    let (objects, triangles, parts, _, lights) = kind.paper();
    let t = (triangles as f64 * scale).max(200.0);
    let mut built = Built {
        parts,
        lights,
        ..Default::default()
    };
    match kind {
        SceneKind::Room => {
            // One object: the room (80 % of the triangles) and 8 pieces of furniture.
            let mats = palette(ctx, 20)?;
            let mut m = Tess::default();
            m.cuboid(
                [0.0, 0.0, 0.0],
                [10.0, 8.0, 3.0],
                cells(0.8 * t, 6.0),
                true,
                0,
                true,
            );
            // Each room face split into two parts by the part of its first half.
            let per_face = m.parts.len() / 6;
            for (i, p) in m.parts.iter_mut().enumerate() {
                *p = 2 * (i / per_face) as u32 + ((i % per_face) * 2 / per_face) as u32;
            }
            for k in 0..8 {
                let (x, y) = (1.0 + 2.2 * (k % 4) as f64, 1.5 + 4.0 * (k / 4) as f64);
                m.cuboid(
                    [x, y, 0.0],
                    [x + 1.2, y + 0.8, 0.5 + 0.2 * k as f64],
                    cells(0.2 * t / 8.0, 6.0),
                    false,
                    12 + k as u32,
                    false,
                );
            }
            m.add(ctx, &mats, true, None, &mut built)?;
            for i in 0..9 {
                ctx.add_point_light(
                    [2.0 + 3.0 * (i % 3) as f64, 1.5 + 2.5 * (i / 3) as f64, 2.8],
                    &[60.0],
                )?;
            }
        }
        SceneKind::Atrium => {
            // One object: a tall hall, three balcony floors (4 slabs each), 8 columns.
            let mats = palette(ctx, 32)?;
            let mut m = Tess::default();
            m.cuboid(
                [0.0, 0.0, 0.0],
                [30.0, 30.0, 20.0],
                cells(0.6 * t, 6.0),
                true,
                0,
                true,
            );
            let per_face = m.parts.len() / 6;
            for (i, p) in m.parts.iter_mut().enumerate() {
                *p = 2 * (i / per_face) as u32 + ((i % per_face) * 2 / per_face) as u32;
            }
            let slab = cells(0.3 * t / 12.0, 6.0);
            for floor in 0..3 {
                let z = 5.0 + 5.0 * floor as f64;
                let part = 12 + 4 * floor as u32;
                m.cuboid(
                    [0.0, 0.0, z],
                    [30.0, 6.0, z + 0.4],
                    slab,
                    false,
                    part,
                    false,
                );
                m.cuboid(
                    [0.0, 24.0, z],
                    [30.0, 30.0, z + 0.4],
                    slab,
                    false,
                    part + 1,
                    false,
                );
                m.cuboid(
                    [0.0, 6.0, z],
                    [6.0, 24.0, z + 0.4],
                    slab,
                    false,
                    part + 2,
                    false,
                );
                m.cuboid(
                    [24.0, 6.0, z],
                    [30.0, 24.0, z + 0.4],
                    slab,
                    false,
                    part + 3,
                    false,
                );
            }
            for c in 0..8 {
                let (x, y) = (7.0 + 5.0 * (c % 4) as f64, if c < 4 { 7.0 } else { 22.0 });
                m.cuboid(
                    [x, y, 0.0],
                    [x + 0.8, y + 0.8, 20.0],
                    cells(0.1 * t / 8.0, 6.0),
                    false,
                    24 + c as u32,
                    false,
                );
            }
            m.add(ctx, &mats, true, None, &mut built)?;
            for i in 0..108 {
                let (gx, gy, gz) = (i % 6, (i / 6) % 6, i / 36);
                ctx.add_point_light(
                    [
                        2.5 + 5.0 * gx as f64,
                        2.5 + 5.0 * gy as f64,
                        4.0 + 6.0 * gz as f64,
                    ],
                    &[8.0],
                )?;
            }
        }
        SceneKind::Hall => {
            // Many small objects, each its own mesh and part: a quarter subdivided boxes of
            // 48 triangles, the rest plain boxes of 12 with shared corners (21 triangles and
            // about 20 vertices per object on average; the paper has 21 and 23).
            let count = objects.min((t / 21.0).ceil() as usize).max(4);
            built.parts = count;
            let mats = palette(ctx, count)?;
            let side = ((count - 1) as f64).sqrt().ceil() as usize;
            let spacing = 2.0;
            let extent = side as f64 * spacing;
            // Object 0 is the hall itself, a closed room around the others.
            let mut hall = Tess::default();
            hall.cuboid(
                [-1.0, -1.0, -0.01],
                [extent + 1.0, extent + 1.0, 8.0],
                4,
                true,
                0,
                false,
            );
            hall.add(ctx, &[mats[0]], true, None, &mut built)?;
            for (k, &material) in mats.iter().enumerate().skip(1) {
                let (x, y) = (
                    ((k - 1) % side) as f64 * spacing,
                    ((k - 1) / side) as f64 * spacing,
                );
                let h = 0.3 + ((k * 37) % 17) as f64 / 10.0;
                let mut m = Tess::default();
                if k % 4 == 0 {
                    m.cuboid([x, y, 0.0], [x + 1.2, y + 1.2, h], 2, false, 0, false);
                } else {
                    m.solid_box([x, y, 0.0], [x + 1.2, y + 1.2, h], 0);
                }
                m.add(ctx, &[material], true, None, &mut built)?;
            }
            for i in 0..361 {
                ctx.add_point_light(
                    [
                        extent * ((i % 19) as f64 + 0.5) / 19.0,
                        extent * ((i / 19) as f64 + 0.5) / 19.0,
                        6.0,
                    ],
                    &[5.0],
                )?;
            }
        }
        SceneKind::Vehicle => {
            // A ground plane, a body and wheels made of 197 spheres and boxes, and 7 small
            // emitting spheres (lamps); 8 objects carry a second part.
            let mats = palette(ctx, 213)?;
            let mut ground = Tess::default();
            ground.quad(
                [-20.0, -20.0, 0.0],
                [40.0, 0.0, 0.0],
                [0.0, 40.0, 0.0],
                cells(0.1 * t, 1.0),
                cells(0.1 * t, 1.0),
                0,
            );
            ground.add(ctx, &mats, true, None, &mut built)?;
            let per_object = 0.9 * t / 197.0;
            let rings = (((per_object / 4.0).sqrt()).round() as usize).max(3);
            for k in 0..197 {
                let mut m = Tess::default();
                let (x, y) = (
                    -4.0 + 8.0 * (k % 20) as f64 / 19.0,
                    -1.8 + 3.6 * ((k / 20) % 10) as f64 / 9.0,
                );
                let z = 0.6 + 0.5 * ((k * 13) % 7) as f64 / 7.0;
                if k % 3 == 0 {
                    m.cuboid(
                        [x - 0.2, y - 0.2, z - 0.2],
                        [x + 0.2, y + 0.2, z + 0.2],
                        cells(per_object, 6.0),
                        false,
                        0,
                        false,
                    );
                } else {
                    m.sphere([x, y, z], 0.25, rings, 0);
                }
                // Objects 0..8 have a second part on their second half.
                if k < 8 {
                    let half = m.parts.len() / 2;
                    m.parts[half..].iter_mut().for_each(|p| *p = 1);
                }
                let own = [mats[1 + k], mats[205 + k.min(7)]];
                m.add(ctx, &own, true, None, &mut built)?;
            }
            let bands = ctx.config().bands.count();
            let warm: Vec<f64> = (0..bands)
                .map(|b| 2000.0 * (0.6 + 0.8 * b as f64 / (bands.max(2) - 1) as f64))
                .collect();
            for k in 0..7 {
                let mut lamp = Tess::default();
                lamp.sphere([-6.0 + 2.0 * k as f64, 3.5, 3.0], 0.1, 4, 0);
                lamp.add(ctx, &[mats[198 + k]], false, Some(&warm), &mut built)?;
            }
            // The paper's HDR environment (not counted among its 7 lights): a generated
            // equirectangular sky (`vehicle_sky`) giving 100 W/m² on open ground.
            let (w, h, rgb) = vehicle_sky();
            ctx.add_sky(&imap::SkyDesc {
                kind: imap::SkyKind::Image {
                    width: w,
                    height: h,
                    rgb: std::sync::Arc::new(rgb),
                },
                amount: imap::SkyAmount::HorizontalIrradiance(100.0),
                ..Default::default()
            })?;
        }
        SceneKind::Dispersion => {
            // A dark room; two small lamps shine into a large dense-flint prism that throws
            // a spectrum on a finely tessellated screen, which holds most vertices and gets
            // most photons: a strongly non-uniform photon distribution. 16 objects.
            let mut mats = palette(ctx, 14)?;
            let flint = ctx.add_material(&MaterialDesc {
                // Schott N-SF11 (Sellmeier).
                ior: Some(IorModel::Sellmeier {
                    b: [1.737_596_95, 0.313_747_346, 1.898_781_01],
                    c: [0.013_188_707, 0.062_306_814_2, 155.236_290],
                }),
                ..Default::default()
            })?;
            let dark = ctx.add_material(&MaterialDesc {
                diffuse_reflect: vec![0.1],
                ..Default::default()
            })?;
            mats.push(flint);
            mats.push(dark);
            let (flint_part, dark_part) = (14u32, 15u32);
            // The screen first: its vertices come first in the map.
            let mut screen = Tess::default();
            let n = cells(0.55 * t, 1.0);
            screen.quad([6.0, -3.0, 0.0], [0.0, 6.0, 0.0], [0.0, 0.0, 4.0], n, n, 0);
            // The screen faces −x (towards the prism).
            let flipped: Vec<u32> = screen
                .indices
                .chunks_exact(3)
                .flat_map(|c| [c[0], c[2], c[1]])
                .collect();
            screen.indices = flipped;
            screen.add(ctx, &mats, true, None, &mut built)?;
            // Six walls of a dark room, each an object.
            let wall = cells(0.35 * t / 6.0, 1.0);
            let (lo, hi) = ([-8.0, -8.0, -0.01], [8.0, 8.0, 6.0]);
            let mut room = Tess::default();
            room.cuboid(lo, hi, wall, true, dark_part, false);
            let per = room.indices.len() / 6;
            let per_v = room.positions.len() / 6;
            for f in 0..6 {
                let base = (f * per_v / 3) as u32;
                let face = Tess {
                    positions: room.positions[f * per_v..(f + 1) * per_v].to_vec(),
                    indices: room.indices[f * per..(f + 1) * per]
                        .iter()
                        .map(|i| i - base)
                        .collect(),
                    parts: vec![if f == 4 { 1 } else { dark_part }; per / 3],
                };
                face.add(ctx, &mats, true, None, &mut built)?;
            }
            // The prism: a triangular glass bar standing on the floor, closed, normals out,
            // with a 30° angle at `a` between the entry face a–b (facing the lamps) and the
            // exit face a–c: a beam entering a–b straight meets a–c at 30°, below N-SF11's
            // critical angle (34°), and leaves deviated by about 33°.
            let mut prism = Tess::default();
            let (a, c, b) = ([0.0, -1.0], [1.15, 0.99], [0.0, 1.0]);
            let k = cells(0.02 * t, 3.0).max(1);
            // Counter-clockwise a → c → b: (q − p) × z points out of every side.
            for (p, q) in [(a, c), (c, b), (b, a)] {
                prism.quad(
                    [p[0], p[1], 0.0],
                    [q[0] - p[0], q[1] - p[1], 0.0],
                    [0.0, 0.0, 3.0],
                    k,
                    k,
                    flint_part,
                );
            }
            let cap = (prism.positions.len() / 3) as u32;
            for z in [3.0, 0.0] {
                prism
                    .positions
                    .extend([a[0], a[1], z, c[0], c[1], z, b[0], b[1], z]);
            }
            // Top counter-clockwise seen from above (normal +z), bottom reversed (−z).
            prism
                .indices
                .extend([cap, cap + 1, cap + 2, cap + 3, cap + 5, cap + 4]);
            prism.parts.extend([flint_part, flint_part]);
            prism.add(ctx, &mats, false, None, &mut built)?;
            // Six small boxes in the corners.
            for q in 0..6 {
                let mut bx = Tess::default();
                let (x, y) = (-7.0 + 2.5 * q as f64, if q % 2 == 0 { -7.0 } else { 6.5 });
                bx.cuboid(
                    [x, y, 0.0],
                    [x + 0.5, y + 0.5, 0.5],
                    cells(0.08 * t / 36.0, 6.0),
                    false,
                    2 + q as u32,
                    false,
                );
                bx.add(ctx, &mats, true, None, &mut built)?;
            }
            // Two small lamps facing the prism's first face.
            let bands = ctx.config().bands.count();
            let white = vec![40_000.0; bands];
            for (i, y) in [-0.4, 0.3].into_iter().enumerate() {
                let mut lamp = Tess::default();
                lamp.quad(
                    [-0.9, y, 1.3],
                    [0.0, 0.0, 0.3],
                    [0.0, 0.3, 0.0],
                    1,
                    1,
                    8 + i as u32,
                );
                // Normal (0,0,.3)×(0,.3,0) = −x: turn it to +x, towards the prism.
                let flipped: Vec<u32> = lamp
                    .indices
                    .chunks_exact(3)
                    .flat_map(|c| [c[0], c[2], c[1]])
                    .collect();
                lamp.indices = flipped;
                lamp.add(ctx, &mats, false, Some(&white), &mut built)?;
            }
            built.parts = 16;
        }
    }
    Ok(built)
}

/// Side of the Cornell box, mm.
const CORNELL_SIDE_MM: f64 = 555.0;

/// Reflectance of a wall given at the R, G and B wavelengths (650, 550, 450 nm) in the
/// context's bands: RGB as is, spectral bands piecewise linear between them and constant
/// beyond (as `c_examples/cornell_scene.h` does).
fn rgb_in_bands(bands: &imap::Bands, rgb: [f64; 3]) -> Vec<f64> {
    if bands.rgb {
        return rgb.to_vec();
    }
    let [r, g, b] = rgb;
    let at = |nm: f64| match nm {
        nm if nm <= 450.0 => b,
        nm if nm <= 550.0 => b + (g - b) * (nm - 450.0) / 100.0,
        nm if nm <= 650.0 => g + (r - g) * (nm - 550.0) / 100.0,
        _ => r,
    };
    bands.wavelengths_nm.iter().map(|&nm| at(nm)).collect()
}

/// The Cornell box of the C examples (`c_examples/cornell_scene.h`), in millimetres (use
/// `unit_m = 0.001`): the 555 mm room with white floor, ceiling and back wall, the red wall
/// at x = 555 and the green one at x = 0, two white blocks, and a 130 × 105 mm lamp under
/// the ceiling emitting 17 W per band. Walls are n × n cells. With `open_front` the wall at
/// z = 0 is left out so that `cornell_camera` can look in; nothing records then (a render
/// needs no illumination map), otherwise every wall records.
pub fn cornell_box(ctx: &mut Context, open_front: bool, n: usize) -> Result<Built> {
    let n = n.max(1);
    let bands = ctx.config().bands.clone();
    let mut material = |rgb: [f64; 3]| {
        ctx.add_material(&MaterialDesc {
            diffuse_reflect: rgb_in_bands(&bands, rgb),
            ..Default::default()
        })
    };
    let white = material([0.73, 0.73, 0.73])?;
    let red = material([0.63, 0.065, 0.05])?;
    let green = material([0.14, 0.45, 0.091])?;
    let black = ctx.add_material(&MaterialDesc::default())?;
    let l = CORNELL_SIDE_MM;
    let mut room = Tess::default();
    room.quad([0.0; 3], [0.0, 0.0, l], [l, 0.0, 0.0], n, n, 0); // floor, +y
    room.quad([0.0, l, 0.0], [l, 0.0, 0.0], [0.0, 0.0, l], n, n, 0); // ceiling, −y
    room.quad([0.0, 0.0, l], [0.0, l, 0.0], [l, 0.0, 0.0], n, n, 0); // back, −z
    if !open_front {
        room.quad([0.0; 3], [l, 0.0, 0.0], [0.0, l, 0.0], n, n, 0); // front, +z
    }
    room.quad([l, 0.0, 0.0], [0.0, 0.0, l], [0.0, l, 0.0], n, n, 1); // red, −x
    room.quad([0.0; 3], [0.0, l, 0.0], [0.0, 0.0, l], n, n, 2); // green, +x
                                                                // Blocks: centre (x, z), half side, height, rotation about y; faces out.
    for (cx, cz, h, angle, cells) in [
        (185.0, 169.0, 165.0, -0.29_f64, (n / 4).max(1)),
        (368.0, 351.0, 330.0, 0.29, (n / 3).max(1)),
    ] {
        let (c, s) = (angle.cos(), angle.sin());
        let hx = 82.5;
        let ex = [2.0 * hx * c, 0.0, -2.0 * hx * s];
        let ez = [2.0 * hx * s, 0.0, 2.0 * hx * c];
        let ey = [0.0, h, 0.0];
        let corner = [cx - hx * c - hx * s, 0.0, cz + hx * s - hx * c];
        let add = |a: [f64; 3], b: [f64; 3]| [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
        let neg = |a: [f64; 3]| [-a[0], -a[1], -a[2]];
        let far_x = add(corner, ex);
        let far_xz = add(far_x, ez);
        let far_z = add(corner, ez);
        room.quad(add(corner, ey), ez, ex, cells, cells, 0); // top
        room.quad(corner, ey, ex, cells, cells, 0);
        room.quad(far_x, ey, ez, cells, cells, 0);
        room.quad(far_xz, ey, neg(ex), cells, cells, 0);
        room.quad(far_z, ey, neg(ez), cells, cells, 0);
    }
    let mats = [white, red, green];
    let triangle_materials: Vec<u32> = room.parts.iter().map(|&p| mats[p as usize]).collect();
    let walls = ctx.add_mesh(&MeshDesc {
        triangle_materials: Some(&triangle_materials),
        record: !open_front,
        ..MeshDesc::new(&room.positions, &room.indices, white)
    })?;
    let mut lamp = Tess::default();
    lamp.quad(
        [213.0, l - 0.5, 227.0],
        [130.0, 0.0, 0.0],
        [0.0, 0.0, 105.0],
        1,
        1,
        0,
    );
    let exitance = [17.0 / (0.130 * 0.105)];
    let lamp_id = ctx.add_mesh(&MeshDesc {
        record: false,
        exitance: Some(&exitance),
        ..MeshDesc::new(&lamp.positions, &lamp.indices, black)
    })?;
    Ok(Built {
        meshes: vec![walls, lamp_id],
        objects: 3,
        triangles: (room.indices.len() + lamp.indices.len()) / 3,
        vertices: (room.positions.len() + lamp.positions.len()) / 3,
        parts: 4,
        lights: 1,
    })
}

/// The classic view into the open Cornell box: from (278, 273, −800) mm along +z, 39.3°
/// vertical field of view.
pub fn cornell_camera(width: u32, height: u32) -> imap::CameraDesc {
    imap::CameraDesc {
        position: [278.0, 273.0, -800.0],
        direction: [0.0, 0.0, 1.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 39.3,
        width,
        height,
        projection: imap::Projection::Perspective,
    }
}

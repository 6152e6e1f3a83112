//! One model, whatever file it came from (the `readers`): positions in f64, objects of
//! triangles, materials as MTL-like records (`Mtl`), per-vertex colours and textures. The
//! scene builder (`scene`) turns it into libimap meshes and materials.

use crate::diag::{printable, Diagnostics};
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};

/// A diffuse colour texture (`map_Kd`, glTF baseColorTexture): sRGB 8-bit texels, looked up
/// with texture coordinates whose v points up (OBJ's convention; glTF's are flipped on
/// reading), repeating outside [0, 1].
pub struct Texture {
    pub name: String,
    width: u32,
    height: u32,
    rgb: Vec<u8>,
    /// The mean linear colour over the whole image.
    pub average: [f64; 3],
}

impl fmt::Debug for Texture {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Texture({}, {}×{})", self.name, self.width, self.height)
    }
}

/// sRGB-encoded 8-bit value → linear.
pub fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

pub fn linear_to_srgb(c: f64) -> f64 {
    if c <= 0.0031308 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

fn lut() -> &'static [f64; 256] {
    static LUT: std::sync::OnceLock<[f64; 256]> = std::sync::OnceLock::new();
    LUT.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f64 / 255.0)))
}

impl Texture {
    /// From `width` × `height` sRGB texels, row 0 at the top.
    pub fn from_rgb8(name: String, width: u32, height: u32, rgb: Vec<u8>) -> Result<Self, String> {
        if width == 0 || height == 0 || rgb.len() != 3 * width as usize * height as usize {
            return Err(format!(
                "{name}: an image of {width}×{height} texels is empty or short"
            ));
        }
        let l = lut();
        let mut sum = [0.0; 3];
        for p in rgb.chunks_exact(3) {
            for k in 0..3 {
                sum[k] += l[p[k] as usize];
            }
        }
        let n = (width as usize * height as usize) as f64;
        Ok(Texture {
            name,
            width,
            height,
            rgb,
            average: sum.map(|s| s / n),
        })
    }

    /// Decodes an image file (PNG, JPEG, TGA, BMP) with the `image` crate.
    pub fn load(path: &Path) -> Result<Self, String> {
        let name = printable(&path.display().to_string());
        let bytes = crate::diag::read_input(path)?;
        let img = image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| format!("{name}: {e}"))?
            .decode()
            .map_err(|e| format!("{name}: {e}"))?
            .to_rgb8();
        let (w, h) = img.dimensions();
        Texture::from_rgb8(name, w, h, img.into_raw())
    }

    /// The linear colour at (u, v), nearest texel, repeating.
    pub fn texel(&self, u: f64, v: f64) -> [f64; 3] {
        let wrap = |x: f64| {
            let f = x - x.floor();
            if f.is_finite() {
                f
            } else {
                0.0
            }
        };
        let (u, v) = (wrap(u), wrap(v));
        let x = ((u * self.width as f64) as u32).min(self.width - 1);
        let y = (((1.0 - v) * self.height as f64) as u32).min(self.height - 1);
        let i = 3 * (y as usize * self.width as usize + x as usize);
        let l = lut();
        [
            l[self.rgb[i] as usize],
            l[self.rgb[i + 1] as usize],
            l[self.rgb[i + 2] as usize],
        ]
    }

    /// The mean linear colour over a triangle of texture coordinates: the texels at the
    /// centroids of its 16 sub-triangles (the triangle cut in 4 along each edge), equally
    /// weighted. Every point is inside the triangle, so a triangle on a texture's colour
    /// boundary takes nothing from across its edges.
    pub fn footprint(&self, uv: [[f64; 2]; 3]) -> [f64; 3] {
        const N: usize = 4;
        let mut sum = [0.0; 3];
        let mut count = 0.0;
        let mut add = |a: f64, b: f64| {
            let c = 1.0 - a - b;
            let u = a * uv[0][0] + b * uv[1][0] + c * uv[2][0];
            let v = a * uv[0][1] + b * uv[1][1] + c * uv[2][1];
            let t = self.texel(u, v);
            for k in 0..3 {
                sum[k] += t[k];
            }
            count += 1.0;
        };
        let n = N as f64;
        for i in 0..N {
            for j in 0..N - i {
                add((i as f64 + 1.0 / 3.0) / n, (j as f64 + 1.0 / 3.0) / n);
                if i + j + 2 <= N {
                    add((i as f64 + 2.0 / 3.0) / n, (j as f64 + 2.0 / 3.0) / n);
                }
            }
        }
        debug_assert_eq!(count, (N * N) as f64);
        sum.map(|s| s / count)
    }
}

/// A colour made a material key: 6 bits per sRGB-encoded channel (steps of about 1.6 %
/// in lightness), so triangles of nearly the same colour share one libimap material.
pub fn colour_key(c: [f64; 3]) -> [u8; 3] {
    c.map(|x| (linear_to_srgb(x.clamp(0.0, 1.0)) * 63.0).round() as u8)
}

/// The linear colour a key stands for.
pub fn key_colour(k: [u8; 3]) -> [f64; 3] {
    k.map(|x| srgb_to_linear(x as f64 / 63.0))
}

/// A model as read from its file.
#[derive(Debug, Default)]
pub struct Model {
    pub positions: Vec<[f64; 3]>,
    /// Texture coordinates, v up.
    pub texcoords: Vec<[f64; 2]>,
    /// Linear colour of each position, when the file gives vertex colours.
    pub colours: Option<Vec<[f64; 3]>>,
    pub objects: Vec<Object>,
    /// The materials; `Triangle::material` indexes them (None: the default grey).
    pub materials: Vec<Mtl>,
    /// What kind of file (for messages and the report).
    pub format: &'static str,
    /// Triangles left out because they repeat a vertex.
    pub degenerate: usize,
}

impl Model {
    pub fn triangles(&self) -> usize {
        self.objects.iter().map(|o| o.triangles.len()).sum()
    }

    /// Whether object `o` is closed (every edge, its corners merged by position, is used by
    /// exactly two of its triangles in opposite directions), and its signed volume (scene
    /// units³): negative when its normals point inward.
    pub fn orientation(&self, o: usize) -> (bool, f64) {
        let obj = &self.objects[o];
        let mut id: HashMap<[u64; 3], u32> = HashMap::new();
        let mut key = |v: u32| {
            let p = self.positions[v as usize];
            let n = id.len() as u32;
            *id.entry(p.map(f64::to_bits)).or_insert(n)
        };
        let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
        let mut volume = 0.0;
        for t in &obj.triangles {
            let k = t.v.map(&mut key);
            for e in 0..3 {
                let (a, b) = (k[e], k[(e + 1) % 3]);
                // +1 for a → b, −1 for b → a, on the edge's undirected key.
                *edges.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
            }
            let [p, q, r] = t.v.map(|v| glam::DVec3::from(self.positions[v as usize]));
            volume += p.dot(q.cross(r)) / 6.0;
        }
        let closed = !obj.triangles.is_empty() && edges.values().all(|&c| c == 0);
        // A closed surface's edges balance; count the uses too (a fin of four would).
        let closed = closed && {
            let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
            let mut key2 = |v: u32| id[&self.positions[v as usize].map(f64::to_bits)];
            for t in &obj.triangles {
                let k = t.v.map(&mut key2);
                for e in 0..3 {
                    let (a, b) = (k[e], k[(e + 1) % 3]);
                    *uses.entry((a.min(b), a.max(b))).or_default() += 1;
                }
            }
            uses.values().all(|&u| u == 2)
        };
        (closed, volume)
    }

    /// Reverses the triangles of the objects named (their normals turn round).
    pub fn flip(&mut self, names: &[String]) {
        for o in self.objects.iter_mut().filter(|o| names.contains(&o.name)) {
            for t in &mut o.triangles {
                t.v.swap(1, 2);
                if let Some(vt) = t.vt.as_mut() {
                    vt.swap(1, 2);
                }
            }
        }
    }

    /// Splits the triangles of the objects `which` accepts until no edge is longer than
    /// `max_edge` (scene units): each round cuts every long edge at its midpoint, once for
    /// the triangles on both its sides (no cracks or T-junctions), and re-cuts each triangle
    /// by how many of its edges were cut (2, 3 or 4 pieces, the same winding). Texture
    /// coordinates and vertex colours are interpolated. Refused when the result would pass
    /// `max_triangles` in all. Returns the triangles added.
    pub fn refine(
        &mut self,
        which: &dyn Fn(&str) -> bool,
        max_edge: f64,
        max_triangles: usize,
    ) -> Result<usize, String> {
        type Corner = (u32, Option<u32>);
        if !(max_edge > 0.0 && max_edge.is_finite()) {
            return Err("it is not a length above 0".to_string());
        }
        let before = self.triangles();
        let len = |m: &Model, a: u32, b: u32| {
            let (p, q) = (m.positions[a as usize], m.positions[b as usize]);
            ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
        };
        // A triangle whose longest edge is k times the limit ends in at least k² pieces
        // (halving every edge quarters it): refuse before any work when that passes the cap.
        let at_least: f64 = self
            .objects
            .iter()
            .filter(|o| which(&o.name))
            .flat_map(|o| &o.triangles)
            .map(|t| {
                let longest = (0..3)
                    .map(|e| len(self, t.v[e], t.v[(e + 1) % 3]))
                    .fold(0.0, f64::max);
                (longest / max_edge).max(1.0).powi(2)
            })
            .sum::<f64>()
            + (self.triangles() as f64);
        if at_least > max_triangles as f64 {
            return Err(format!(
                "it would make more than {max_triangles} triangles (the recorded surfaces are too large for that edge length: choose a longer one)"
            ));
        }
        loop {
            // The long edges, each once.
            let mut cut: HashMap<(u32, u32), u32> = HashMap::new();
            let mut pieces = 0usize;
            for o in self.objects.iter().filter(|o| which(&o.name)) {
                for t in &o.triangles {
                    let mut n = 0;
                    for e in 0..3 {
                        let (a, b) = (t.v[e], t.v[(e + 1) % 3]);
                        if len(self, a, b) > max_edge {
                            cut.insert((a.min(b), a.max(b)), u32::MAX);
                            n += 1;
                        }
                    }
                    pieces += n;
                }
            }
            if cut.is_empty() {
                break;
            }
            let total = self.triangles().saturating_add(pieces);
            if total > max_triangles {
                return Err(format!(
                    "it would make more than {max_triangles} triangles (the recorded surfaces are too large for that edge length: choose a longer one)"
                ));
            }
            // Midpoints: positions (and colours), and texture coordinates by their pair.
            let mut keys: Vec<(u32, u32)> = cut.keys().copied().collect();
            keys.sort_unstable();
            for (a, b) in keys {
                let (p, q) = (self.positions[a as usize], self.positions[b as usize]);
                let i = self.positions.len() as u32;
                self.positions.push([0, 1, 2].map(|k| 0.5 * (p[k] + q[k])));
                if let Some(c) = self.colours.as_mut() {
                    let (x, y) = (c[a as usize], c[b as usize]);
                    c.push([0, 1, 2].map(|k| 0.5 * (x[k] + y[k])));
                }
                cut.insert((a, b), i);
            }
            let mut uv_mid: HashMap<(u32, u32), u32> = HashMap::new();
            let texcoords = &mut self.texcoords;
            let mut mid = |x: Corner, y: Corner| -> Corner {
                let v = cut[&(x.0.min(y.0), x.0.max(y.0))];
                let vt = match (x.1, y.1) {
                    (Some(a), Some(b)) => {
                        Some(*uv_mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                            let (p, q) = (texcoords[a as usize], texcoords[b as usize]);
                            texcoords.push([0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1])]);
                            texcoords.len() as u32 - 1
                        }))
                    }
                    _ => None,
                };
                (v, vt)
            };
            let positions = &self.positions;
            let dist = |a: Corner, b: Corner| {
                let (p, q) = (positions[a.0 as usize], positions[b.0 as usize]);
                (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>()
            };
            for o in self.objects.iter_mut().filter(|o| which(&o.name)) {
                let mut out = Vec::with_capacity(o.triangles.len() * 2);
                for t in &o.triangles {
                    let c: [Corner; 3] = [0, 1, 2].map(|i| (t.v[i], t.vt.map(|vt| vt[i])));
                    let split: [bool; 3] = [0, 1, 2].map(|e| {
                        let (a, b) = (t.v[e], t.v[(e + 1) % 3]);
                        cut.contains_key(&(a.min(b), a.max(b)))
                    });
                    let mut push = |x: Corner, y: Corner, z: Corner| {
                        out.push(Triangle {
                            v: [x.0, y.0, z.0],
                            vt: x.1.zip(y.1).zip(z.1).map(|((a, b), c)| [a, b, c]),
                            material: t.material,
                        });
                    };
                    match split.iter().filter(|&&x| x).count() {
                        0 => push(c[0], c[1], c[2]),
                        3 => {
                            let m = [0, 1, 2].map(|e| mid(c[e], c[(e + 1) % 3]));
                            push(c[0], m[0], m[2]);
                            push(m[0], c[1], m[1]);
                            push(m[2], m[1], c[2]);
                            push(m[0], m[1], m[2]);
                        }
                        1 => {
                            // Rotate so the cut edge is c0–c1.
                            let e = split.iter().position(|&x| x).unwrap();
                            let (a, b, d) = (c[e], c[(e + 1) % 3], c[(e + 2) % 3]);
                            let m = mid(a, b);
                            push(a, m, d);
                            push(m, b, d);
                        }
                        _ => {
                            // Rotate so the uncut edge is c2–c0: c0–c1 and c1–c2 are cut.
                            let e = split.iter().position(|&x| !x).unwrap();
                            let (a, b, d) = (c[(e + 1) % 3], c[(e + 2) % 3], c[e]);
                            let (m0, m1) = (mid(a, b), mid(b, d));
                            push(m0, b, m1);
                            // The quadrilateral a, m0, m1, d by its shorter diagonal.
                            if dist(a, m1) <= dist(m0, d) {
                                push(a, m0, m1);
                                push(a, m1, d);
                            } else {
                                push(a, m0, d);
                                push(m0, m1, d);
                            }
                        }
                    }
                }
                o.triangles = out;
            }
        }
        Ok(self.triangles() - before)
    }

    /// The objects that are closed with their normals pointing inward: (name, volume).
    pub fn inward(&self) -> Vec<(String, f64)> {
        (0..self.objects.len())
            .filter_map(|o| {
                let (closed, v) = self.orientation(o);
                (closed && v < 0.0).then(|| (self.objects[o].name.clone(), v))
            })
            .collect()
    }

    /// What the model's units and up axis look like from its geometry (`Guesses`).
    pub fn guesses(&self) -> Guesses {
        let (lo, hi) = self.bounds();
        let extent = [0, 1, 2].map(|k| (hi[k] - lo[k]).max(0.0));
        let largest = extent.iter().copied().fold(0.0, f64::max);
        // A room or a building is 2 … 200 m across: drawn in millimetres it reads as
        // thousands of metres, in centimetres as hundreds.
        let unit = if largest <= UNIT_GUESS_ABOVE || !largest.is_finite() {
            None
        } else if largest >= 2000.0 {
            Some(("millimetres", 0.001))
        } else {
            Some(("centimetres", 0.01))
        };
        // Floors, ceilings, roofs, tables and the ground face up or down: the axis that the
        // most area faces (within 10°) is the up axis of a built model, when it clearly
        // leads (a statue or a scan faces every way: no guess). glTF is y-up by its
        // specification.
        let up = if self.format == "glTF" {
            Some((1, "the glTF specification".to_string()))
        } else {
            let mut aligned = [0.0f64; 3];
            let mut total = 0.0;
            for t in self.objects.iter().flat_map(|o| &o.triangles) {
                let [a, b, c] = t.v.map(|v| glam::DVec3::from(self.positions[v as usize]));
                let n = (b - a).cross(c - a);
                let area = 0.5 * n.length();
                if !(area > 0.0 && area.is_finite()) {
                    continue;
                }
                total += area;
                let n = n.normalize().abs().to_array();
                for k in 0..3 {
                    if n[k] > 10f64.to_radians().cos() {
                        aligned[k] += area;
                    }
                }
            }
            let mut order = [0, 1, 2];
            order.sort_by(|&a, &b| aligned[b].total_cmp(&aligned[a]));
            let (k, second) = (order[0], aligned[order[1]]);
            (total > 0.0 && aligned[k] >= 0.2 * total && aligned[k] >= 1.3 * second).then(|| {
                (
                    k,
                    format!(
                        "{:.0} % of its area faces ±{} against {:.0} % ±{}",
                        100.0 * aligned[k] / total,
                        AXES[k],
                        100.0 * second / total,
                        AXES[order[1]]
                    ),
                )
            })
        };
        Guesses { extent, unit, up }
    }

    /// The box around the vertices the triangles use.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        bounds(
            self.objects
                .iter()
                .flat_map(|o| &o.triangles)
                .flat_map(|t| t.v)
                .map(|v| self.positions[v as usize]),
        )
    }

    /// Every position finite and within ±1e30, or one error naming the first that is not
    /// (the OBJ reader reports each with its line).
    pub fn check_positions(&self, path: &Path, diag: &mut Diagnostics) {
        let bad = |p: &&[f64; 3]| p.iter().any(|x| !x.is_finite() || x.abs() > MAX_COORDINATE);
        let mut far = self.positions.iter().enumerate().filter(|(_, p)| bad(p));
        if let Some((i, p)) = far.next() {
            let more = far.count();
            let others = if more > 0 {
                format!(" (and {more} more)")
            } else {
                String::new()
            };
            diag.error(
                path,
                0,
                format!("vertex {i} at {p:?} is not finite or beyond ±1e30{others}"),
            );
        }
    }
}

/// The box around `points`; infinite (lo > hi) when there are none.
pub fn bounds(points: impl Iterator<Item = [f64; 3]>) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// A model larger than this (scene units) is guessed to be drawn in millimetres or
/// centimetres when no `unit_m` is set.
pub const UNIT_GUESS_ABOVE: f64 = 200.0;

const AXES: [&str; 3] = ["x", "y", "z"];

/// What a model's geometry suggests (`Model::guesses`): shown by `imap info`, and warned
/// about by `imap run` when the settings leave the choice to a default that disagrees.
#[derive(Clone, Debug)]
pub struct Guesses {
    /// The bounding box's extent along x, y, z, scene units.
    pub extent: [f64; 3],
    /// The units the model looks drawn in (name, metres per unit), when metres look wrong.
    pub unit: Option<(&'static str, f64)>,
    /// The axis (0 x, 1 y, 2 z) that looks up, and why.
    pub up: Option<(usize, String)>,
}

impl Guesses {
    /// The extent as "a × b × c" in metres at `unit_m` metres per unit.
    pub fn size_at(&self, unit_m: f64) -> String {
        let e = self.extent.map(|x| x * unit_m);
        format!(
            "{} × {} × {} m",
            fmt_len(e[0]),
            fmt_len(e[1]),
            fmt_len(e[2])
        )
    }

    /// The up axis's name.
    pub fn up_name(&self) -> Option<&'static str> {
        self.up.as_ref().map(|(k, _)| AXES[*k])
    }
}

fn fmt_len(x: f64) -> String {
    if x >= 100.0 {
        format!("{x:.0}")
    } else if x >= 1.0 {
        format!("{x:.1}")
    } else {
        format!("{x:.3}")
    }
}

/// Appends a polygon's triangles (a fan from its first corner) to `tris`, leaving out and
/// counting those that repeat a vertex.
pub fn push_triangle(
    tris: &mut Vec<Triangle>,
    degenerate: &mut usize,
    v: [u32; 3],
    vt: Option<[u32; 3]>,
    material: Option<usize>,
) {
    if v[0] == v[1] || v[1] == v[2] || v[0] == v[2] {
        *degenerate += 1;
    } else {
        tris.push(Triangle { v, vt, material });
    }
}

/// Largest coordinate magnitude libimap takes (`IMAP_ERR_PRECISION` beyond).
pub const MAX_COORDINATE: f64 = 1e30;

/// A triangle of an object: global (0-based) vertex indices, texture coordinates when
/// every corner has one, and its material (index into the OBJ's `usemtl` names).
#[derive(Clone, Debug)]
pub struct Triangle {
    pub v: [u32; 3],
    pub vt: Option<[u32; 3]>,
    pub material: Option<usize>,
}

/// An object (`o` or `g` name) and its triangles.
#[derive(Clone, Debug)]
pub struct Object {
    pub name: String,
    pub triangles: Vec<Triangle>,
}

/// One `newmtl` block, as written (nothing mapped yet).
#[derive(Clone, Debug, Default)]
pub struct Mtl {
    pub name: String,
    /// Where it was defined (file, line).
    pub at: (PathBuf, usize),
    pub kd: Option<[f64; 3]>,
    pub ks: Option<[f64; 3]>,
    pub ke: Option<[f64; 3]>,
    pub tf: Option<[f64; 3]>,
    pub ni: Option<f64>,
    /// Dissolve (opacity), from `d` or 1 − `Tr`.
    pub d: Option<f64>,
    pub illum: Option<i64>,
    /// `map_Kd`, resolved against the MTL's directory.
    pub map_kd: Option<PathBuf>,
    /// The decoded diffuse texture (`map_Kd`, glTF baseColorTexture), when it could be read.
    pub texture: Option<std::sync::Arc<crate::model::Texture>>,
    /// The decoded emission texture (glTF emissiveTexture): it multiplies `ke` texel by
    /// texel.
    pub emission_texture: Option<std::sync::Arc<crate::model::Texture>>,
    /// Diffuse transmittance (Radiance's `trans`).
    pub kt: Option<[f64; 3]>,
    /// The luminance (cd/m²) the emission `ke` must show: it is scaled to it by the bands'
    /// efficacies (Radiance's `light` and `glow`).
    pub ke_luminance: Option<f64>,
    /// A thin pane read as a slab this thick (scene units): `tf` is its internal
    /// transmittance at normal incidence (Radiance's `glass`).
    pub pane: Option<f64>,
    /// Made by a reader for a file without materials (PLY, STL): vertex colours override it.
    pub implicit: bool,
    /// A glossy surface the file describes (glTF roughness/metallic, MTL `Pr`/`Pm`/`Ns`,
    /// Radiance's rough `plastic`/`metal`).
    pub gloss: Option<Gloss>,
    /// A window BSDF file (Radiance's `BSDF` and `aBSDF`) and its up direction: the
    /// reader has turned its surfaces to face the file's front (WINDOW's exterior).
    pub window_bsdf: Option<(PathBuf, [f64; 3])>,
}

/// What a file says of a surface's gloss.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gloss {
    /// GGX α (glTF's perceptual roughness squared; √(2 / (Ns + 2)) for a Phong exponent;
    /// Radiance's rms slope as it is).
    pub alpha: f64,
    /// 0: a dielectric coat over the diffuse colour (`ks` or 4 % its reflectance at normal
    /// incidence); 1: a metal whose reflectance at normal incidence is the colour.
    pub metallic: f64,
}

//! Scene builders shared by the integration tests.
#![allow(dead_code)]

use imap::{Config, Context, IorModel, MaterialDesc, MeshDesc};

/// A triangulated mesh: xyz positions and triangle indices.
pub struct Geometry {
    pub positions: Vec<f64>,
    pub indices: Vec<u32>,
}

impl Geometry {
    pub fn vertex_count(&self) -> usize {
        self.positions.len() / 3
    }

    pub fn vertex(&self, i: usize) -> [f64; 3] {
        [
            self.positions[3 * i],
            self.positions[3 * i + 1],
            self.positions[3 * i + 2],
        ]
    }

    pub fn translated(mut self, d: [f64; 3]) -> Self {
        for p in self.positions.chunks_exact_mut(3) {
            for k in 0..3 {
                p[k] += d[k];
            }
        }
        self
    }

    pub fn scaled(mut self, s: f64) -> Self {
        self.positions.iter_mut().for_each(|x| *x *= s);
        self
    }

    /// Reverses the winding (flips every normal).
    pub fn flipped(mut self) -> Self {
        for t in self.indices.chunks_exact_mut(3) {
            t.swap(1, 2);
        }
        self
    }

    pub fn desc(&self, material: u32) -> MeshDesc<'_> {
        MeshDesc::new(&self.positions, &self.indices, material)
    }
}

/// One quad of two triangles over its corners in order (its normal by their winding).
pub fn quad(p: [[f64; 3]; 4]) -> Geometry {
    Geometry {
        positions: p.iter().flatten().copied().collect(),
        indices: vec![0, 1, 2, 0, 2, 3],
    }
}

/// A planar grid z = `z` over [x0, x1] × [y0, y1] with n × n cells, normals +z.
pub fn grid(n: usize, x0: f64, x1: f64, y0: f64, y1: f64, z: f64) -> Geometry {
    grid_rect(n, n, [x0, x1], [y0, y1], z)
}

/// A planar grid z = `z` over x × y with nx × ny cells, normals +z.
pub fn grid_rect(nx: usize, ny: usize, x: [f64; 2], y: [f64; 2], z: f64) -> Geometry {
    let mut positions = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            positions.extend([
                x[0] + (x[1] - x[0]) * i as f64 / nx as f64,
                y[0] + (y[1] - y[0]) * j as f64 / ny as f64,
                z,
            ]);
        }
    }
    let mut indices = Vec::new();
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    for j in 0..ny {
        for i in 0..nx {
            indices.extend([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            indices.extend([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    Geometry { positions, indices }
}

/// A closed sphere of radius `r` (subdivided octahedron, `level` subdivisions), normals
/// pointing inward (the front side faces the centre).
pub fn sphere_inward(r: f64, level: u32) -> Geometry {
    let mut verts: Vec<[f64; 3]> = vec![
        [1., 0., 0.],
        [-1., 0., 0.],
        [0., 1., 0.],
        [0., -1., 0.],
        [0., 0., 1.],
        [0., 0., -1.],
    ];
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    let mut cache = std::collections::HashMap::new();
    for _ in 0..level {
        let mut next = Vec::new();
        for t in &tris {
            let mut mid = |a: u32, b: u32| -> u32 {
                *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let (pa, pb) = (verts[a as usize], verts[b as usize]);
                    let m = [
                        (pa[0] + pb[0]) / 2.,
                        (pa[1] + pb[1]) / 2.,
                        (pa[2] + pb[2]) / 2.,
                    ];
                    let l = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
                    verts.push([m[0] / l, m[1] / l, m[2] / l]);
                    verts.len() as u32 - 1
                })
            };
            let (ab, bc, ca) = (mid(t[0], t[1]), mid(t[1], t[2]), mid(t[2], t[0]));
            next.extend([[t[0], ab, ca], [ab, t[1], bc], [ca, bc, t[2]], [ab, bc, ca]]);
        }
        tris = next;
    }
    // Outward winding above; flip to face inward.
    Geometry {
        positions: verts.iter().flat_map(|v| v.map(|x| x * r)).collect(),
        indices: tris.iter().flat_map(|t| [t[0], t[2], t[1]]).collect(),
    }
}

/// An axis-aligned box [lo, hi] with `n` × `n` cells per face; `inward` chooses normals
/// pointing into the box (a room) or out of it (an object).
pub fn cuboid(lo: [f64; 3], hi: [f64; 3], n: usize, inward: bool) -> Geometry {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    // Each face: (axis, side) with the outward normal along ±axis.
    for axis in 0..3 {
        for &positive in &[false, true] {
            let (u_ax, v_ax) = ((axis + 1) % 3, (axis + 2) % 3);
            let base = (positions.len() / 3) as u32;
            for j in 0..=n {
                for i in 0..=n {
                    let mut p = [0.0; 3];
                    p[axis] = if positive { hi[axis] } else { lo[axis] };
                    p[u_ax] = lo[u_ax] + (hi[u_ax] - lo[u_ax]) * i as f64 / n as f64;
                    p[v_ax] = lo[v_ax] + (hi[v_ax] - lo[v_ax]) * j as f64 / n as f64;
                    positions.extend(p);
                }
            }
            let id = |i: usize, j: usize| base + (j * (n + 1) + i) as u32;
            // (u × v) = +axis: winding (i,j),(i+1,j),(i+1,j+1) gives normal +axis.
            let outward_is_ccw = positive;
            for j in 0..n {
                for i in 0..n {
                    let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                    if outward_is_ccw != inward {
                        indices.extend([a, b, c, a, c, d]);
                    } else {
                        indices.extend([a, c, b, a, d, c]);
                    }
                }
            }
        }
    }
    Geometry { positions, indices }
}

/// A context with the given config.
pub fn context(config: Config) -> Context {
    Context::new(config).expect("context")
}

/// A grey Lambertian material.
pub fn lambert(ctx: &mut Context, rho: f64) -> u32 {
    ctx.add_material(&MaterialDesc {
        diffuse_reflect: vec![rho],
        ..Default::default()
    })
    .unwrap()
}

/// Photons to trace in a test: `base`, scaled by IMAP_TEST_SCALE (default 1).
pub fn photons(base: u64) -> u64 {
    let s: f64 = std::env::var("IMAP_TEST_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
    ((base as f64) * s).max(1000.0) as u64
}

/// A picture of `cam` by the photon-map renderer `method` after `passes` passes (progress
/// every 0.05 s).
pub fn render_passes(
    ctx: &mut Context,
    cam: &imap::CameraDesc,
    method: imap::RenderMethod,
    passes: u64,
) -> imap::Image {
    ctx.render(
        cam,
        &mut imap::RenderParams {
            method,
            passes,
            progress_interval_s: 0.05,
            ..Default::default()
        },
    )
    .expect("render")
    .0
}

/// Runs `n` photons with no callback, with the photons-only estimator (the first paper's:
/// for tests of what photons do).
pub fn run_photons_only(ctx: &mut Context, n: u64) -> imap::Report {
    ctx.run(&mut imap::RunParams {
        photons: n,
        progress_interval_s: 1.0,
        estimator: Some(imap::Estimator::Photons),
        ..Default::default()
    })
    .expect("run")
}

/// A two-thread config with `seed`.
pub fn seeded(seed: u64) -> Config {
    Config {
        seed,
        threads: 2,
        ..Default::default()
    }
}

/// Runs `n` photons with estimator `e`, no callback.
pub fn run_with(ctx: &mut Context, n: u64, e: imap::Estimator) -> imap::Report {
    ctx.run(&mut imap::RunParams {
        photons: n,
        progress_interval_s: 1.0,
        estimator: Some(e),
        ..Default::default()
    })
    .expect("run")
}

/// Runs `n` photons with no callback.
pub fn run_photons(ctx: &mut Context, n: u64) -> imap::Report {
    let mut params = imap::RunParams {
        photons: n,
        progress_interval_s: 1.0,
        ..Default::default()
    };
    ctx.run(&mut params).expect("run")
}

/// Each vertex's share of the adjacent triangles' area (a third of each).
pub fn vertex_areas(g: &Geometry) -> Vec<f64> {
    let mut share = vec![0.0; g.vertex_count()];
    for t in g.indices.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|k| g.vertex(t[k] as usize));
        let (u, v) = (
            [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
            [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
        );
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let area = 0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        for &i in t {
            share[i as usize] += area / 3.0;
        }
    }
    share
}

/// A closed room with mixed materials: coloured Lambertian walls, a mirror, translucent
/// and absorbing glass, a spot and a point light and an emitting panel. Returns the context
/// and the recording meshes' ids.
pub fn mixed_room(config: Config) -> (Context, Vec<u32>) {
    mixed_room_lit(config, true)
}

/// `bands` values from `a` to `b`, evenly (a coloured coefficient).
pub fn ramp(bands: usize, a: f64, b: f64) -> Vec<f64> {
    (0..bands)
        .map(|i| a + (b - a) * i as f64 / (bands - 1).max(1) as f64)
        .collect()
}

/// `mixed_room`, with its point-like lights or lit by its emitting panel alone.
pub fn mixed_room_lit(config: Config, point_lights: bool) -> (Context, Vec<u32>) {
    let mut ctx = context(config);
    let bands = ctx.config().bands.count();
    let ramp = |a: f64, b: f64| ramp(bands, a, b);
    let walls = ctx
        .add_material(&MaterialDesc {
            diffuse_reflect: ramp(0.8, 0.3),
            ..Default::default()
        })
        .unwrap();
    let mirror = ctx
        .add_material(&MaterialDesc {
            specular_reflect: vec![0.95],
            diffuse_reflect: vec![0.02],
            ..Default::default()
        })
        .unwrap();
    let paper = ctx
        .add_material(&MaterialDesc {
            diffuse_reflect: vec![0.4],
            diffuse_transmit: ramp(0.2, 0.5),
            ..Default::default()
        })
        .unwrap();
    let glass = ctx
        .add_material(&MaterialDesc {
            ior: Some(IorModel::Sellmeier {
                b: [1.039_612_12, 0.231_792_344, 1.010_469_45],
                c: [0.006_000_698_67, 0.020_017_914_4, 103.560_653],
            }),
            absorption_per_m: ramp(0.5, 3.0),
            ..Default::default()
        })
        .unwrap();
    let mut ids = Vec::new();
    let room = cuboid([-2.0, -2.0, 0.0], [2.0, 2.0, 3.0], 6, true);
    ids.push(ctx.add_mesh(&room.desc(walls)).unwrap());
    let mirror_g = grid(3, -1.9, -0.5, -1.9, -0.5, 0.01);
    ids.push(ctx.add_mesh(&mirror_g.desc(mirror)).unwrap());
    let sheet = grid(4, -1.0, 1.0, -0.5, 0.5, 1.5);
    let mut sd = sheet.desc(paper);
    sd.two_sided = true;
    ids.push(ctx.add_mesh(&sd).unwrap());
    let prism = cuboid([0.5, 0.5, 0.2], [1.2, 1.5, 0.9], 2, false);
    let mut pd = prism.desc(glass);
    pd.record = false;
    ctx.add_mesh(&pd).unwrap();
    let panel = grid(1, -0.3, 0.3, -0.3, 0.3, 2.95).flipped();
    let mut lamp = panel.desc(walls);
    lamp.record = false;
    let exitance = ramp(50.0, 20.0);
    lamp.exitance = Some(&exitance);
    ctx.add_mesh(&lamp).unwrap();
    if point_lights {
        ctx.add_point_light([1.0, -1.0, 2.0], &ramp(5.0, 9.0))
            .unwrap();
        ctx.add_spot_light([-1.0, 1.0, 2.5], [0.2, 0.1, -1.0], 0.4, &[3.0])
            .unwrap();
    }
    (ctx, ids)
}

/// Every band and side of every recording mesh, in one vector (each value followed by its
/// vertex's relative error).
pub fn whole_map(ctx: &Context, ids: &[u32]) -> Vec<f64> {
    map_with_errors(ctx, ids)
        .into_iter()
        .flat_map(|(e, r)| [e, r])
        .collect()
}

/// Every band and side of every recording mesh: (irradiance, relative error) per value.
pub fn map_with_errors(ctx: &Context, ids: &[u32]) -> Vec<(f64, f64)> {
    let mut all = Vec::new();
    for &m in ids {
        let n = ctx.vertex_count(m).unwrap();
        let sides = if ctx.mesh_info(m).unwrap().sides == 2 {
            2
        } else {
            1
        };
        for side in 0..sides {
            let mut err = vec![0.0; n];
            ctx.rel_error(m, side, &mut err).unwrap();
            for band in 0..ctx.config().bands.count() as u32 {
                let mut e = vec![0.0; n];
                ctx.irradiance(m, side, band, &mut e).unwrap();
                all.extend(e.into_iter().zip(err.iter().copied()));
            }
        }
    }
    all
}

/// The mean of per-seed results `values` equals `expected` within 4 standard errors (their
/// spread), and they spread by less than 1 % of it.
pub fn assert_seed_mean(values: &[f64], expected: f64, what: &str) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let sd = (values.iter().map(|f| (f - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    eprintln!(
        "{what}: {mean:.6} ± {:.2e} (sd {sd:.2e} per seed) vs {expected:.6}",
        sd / n.sqrt()
    );
    assert!(
        (mean - expected).abs() <= 4.0 * sd / n.sqrt() + 1e-9 * expected.abs(),
        "{what}: {values:?} vs {expected}"
    );
    assert!(sd < 0.01 * expected.abs(), "{what}: {values:?}");
}

pub fn assert_maps_agree(a: &[f64], b: &[f64], what: &str) {
    assert_eq!(a.len(), b.len());
    let mut worst: f64 = 0.0;
    for (x, y) in a.iter().zip(b) {
        let scale = x.abs().max(y.abs());
        if scale > 0.0 {
            worst = worst.max((x - y).abs() / scale);
        }
    }
    eprintln!(
        "{what}: largest relative difference {worst:.2e} over {} values",
        a.len()
    );
    assert!(worst <= 1e-12, "{what}: maps differ by {worst:e}");
    assert!(a.iter().any(|&x| x > 0.0), "{what}: the map is empty");
}

/// Exact expected vertex value of the estimator for an irradiance field `e`: the
/// hat-function average ∫E·φ_v dA / ∫φ_v dA over the vertex's triangles (the map divides
/// the barycentric-weighted deposits by a third of each adjacent triangle's area).
pub fn hat_average(g: &Geometry, v: usize, e: impl Fn([f64; 3]) -> f64) -> f64 {
    hat_average_faces(g, v, |x, _| e(x))
}

/// `hat_average` of a field that depends on the point and the unit normal of the face it
/// lies on (e.g. I·cosθ/r² on a polyhedron).
pub fn hat_average_faces(g: &Geometry, v: usize, e: impl Fn([f64; 3], [f64; 3]) -> f64) -> f64 {
    hat_average_with(g, v, 48, e)
}

/// `hat_average_faces` on an m × m subdivision of each triangle (a field with a step, e.g. a
/// beam's edge, needs a fine one: the centroid rule's error there is of order 1/m).
pub fn hat_average_with(
    g: &Geometry,
    v: usize,
    m: usize,
    e: impl Fn([f64; 3], [f64; 3]) -> f64,
) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for t in g.indices.chunks_exact(3) {
        let Some(k) = t.iter().position(|&i| i as usize == v) else {
            continue;
        };
        let p: Vec<[f64; 3]> = (0..3).map(|j| g.vertex(t[(k + j) % 3] as usize)).collect();
        let area = {
            let (a, b) = (sub(p[1], p[0]), sub(p[2], p[0]));
            let c = [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ];
            let l = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
            (0.5 * l, [c[0] / l, c[1] / l, c[2] / l])
        };
        let (area, normal) = area;
        // Centroid rule on an m×m subdivision in barycentric coordinates.
        let mut sum = 0.0;
        let mut count = 0.0;
        for i in 0..m {
            for j in 0..m - i {
                for up in [true, false] {
                    if !up && i + j + 1 >= m {
                        continue;
                    }
                    let (b1, b2) = if up {
                        (
                            (i as f64 + 1.0 / 3.0) / m as f64,
                            (j as f64 + 1.0 / 3.0) / m as f64,
                        )
                    } else {
                        (
                            (i as f64 + 2.0 / 3.0) / m as f64,
                            (j as f64 + 2.0 / 3.0) / m as f64,
                        )
                    };
                    let w0 = 1.0 - b1 - b2;
                    let x = [0, 1, 2].map(|c| w0 * p[0][c] + b1 * p[1][c] + b2 * p[2][c]);
                    sum += e(x, normal) * w0;
                    count += 1.0;
                }
            }
        }
        num += sum / count * area;
        den += area / 3.0;
    }
    num / den
}

pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// One row of docs/accuracy.md, printed so a `--nocapture` run of the suite regenerates the
/// table: case, analytic value, ours, estimated and actual relative error, run time.
pub fn accuracy_row(case: &str, analytic: f64, ours: f64, estimated: f64, actual: f64, secs: f64) {
    let pct = |x: f64| {
        if x.is_nan() {
            "—".to_string()
        } else {
            format!("{:.2} %", 100.0 * x)
        }
    };
    eprintln!(
        "ACCURACY | {case} | {analytic:.6e} | {ours:.6e} | {} | {} | {secs:.1} s |",
        pct(estimated),
        pct(actual)
    );
}

pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// Solid angle of triangle (a, b, c) seen from p (Van Oosterom and Strackee).
pub fn solid_angle(p: [f64; 3], tri: [[f64; 3]; 3]) -> f64 {
    let [a, b, c] = tri.map(|x| sub(x, p));
    let num = dot(a, cross(b, c)).abs();
    let (la, lb, lc) = (norm(a), norm(b), norm(c));
    let den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    2.0 * num.atan2(den)
}

/// An LM-63-2002 file of `f(C, γ)` (type C) or `f(V, H)` (type B) on the given angles,
/// with a multiplier, a ballast factor and optional TILT=INCLUDE data.
pub fn ies_text(
    photometric_type: u32,
    vertical: &[f64],
    horizontal: &[f64],
    f: impl Fn(f64, f64) -> f64,
    multiplier: f64,
    ballast: f64,
    tilt: Option<(&[f64], &[f64])>,
) -> String {
    let mut s = String::from("IESNA:LM-63-2002\n[TEST] libimap photometry test\n[MANUFAC] none\n");
    match tilt {
        None => s.push_str("TILT=NONE\n"),
        Some((a, f)) => {
            s.push_str(&format!("TILT=INCLUDE\n1\n{}\n", a.len()));
            s.push_str(&join(a));
            s.push_str(&join(f));
        }
    }
    s.push_str(&format!(
        "1 -1 {multiplier} {} {} {photometric_type} 2 0 0 0\n{ballast} 1 100\n",
        vertical.len(),
        horizontal.len()
    ));
    s.push_str(&join(vertical));
    s.push_str(&join(horizontal));
    for &h in horizontal {
        let row: Vec<f64> = vertical.iter().map(|&v| f(h, v)).collect();
        s.push_str(&join(&row));
    }
    s
}

/// A type C LM-63 file of a given table: `rows[h][v]` candela at `horizontal[h]`,
/// `vertical[v]`.
pub fn ies_table(vertical: &[f64], horizontal: &[f64], rows: &[Vec<f64>]) -> String {
    let at = |a: &[f64], x: f64| a.iter().position(|&y| y == x).expect("a table angle");
    ies_text(
        1,
        vertical,
        horizontal,
        |h, v| rows[at(horizontal, h)][at(vertical, v)],
        1.0,
        1.0,
        None,
    )
}

pub fn join(v: &[f64]) -> String {
    let mut s = String::new();
    for (i, x) in v.iter().enumerate() {
        s.push_str(&format!("{x}"));
        s.push(if i % 10 == 9 { '\n' } else { ' ' });
    }
    s.push('\n');
    s
}

pub fn steps(from: f64, to: f64, step: f64) -> Vec<f64> {
    let n = ((to - from) / step).round() as usize;
    (0..=n).map(|i| from + step * i as f64).collect()
}

/// Bilinear interpolation of a type C table (planes `cs` over 0–360°, the 360° plane
/// implied by the 0° one) at (c, g): the test's own reading of "the file's interpolation".
pub fn bilinear(cs: &[f64], gs: &[f64], table: &[Vec<f64>], c: f64, g: f64) -> f64 {
    let c = c.rem_euclid(360.0);
    let nc = cs.len();
    let i = (0..nc).rev().find(|&i| cs[i] <= c).unwrap();
    let (c0, c1, r0, r1) = if i + 1 < nc {
        (cs[i], cs[i + 1], &table[i], &table[i + 1])
    } else {
        (cs[i], 360.0, &table[i], &table[0])
    };
    let j = (0..gs.len() - 1).rev().find(|&j| gs[j] <= g).unwrap_or(0);
    let (s, t) = ((c - c0) / (c1 - c0), (g - gs[j]) / (gs[j + 1] - gs[j]));
    let at = |r: &Vec<f64>| r[j] * (1.0 - t) + r[j + 1] * t;
    at(r0) * (1.0 - s) + at(r1) * s
}

/// Irradiance at `x` on a surface of unit normal `n` from a Lambertian polygon of radiance
/// `l` wholly in front of it: the polygon form of Lambert's formula,
/// E = L/2 · |Σ θᵢ n·(aᵢ×bᵢ)/|aᵢ×bᵢ||.
pub fn polygon_irradiance(x: [f64; 3], n: [f64; 3], poly: &[[f64; 3]], l: f64) -> f64 {
    let mut s = 0.0;
    for i in 0..poly.len() {
        let a = sub(poly[i], x);
        let b = sub(poly[(i + 1) % poly.len()], x);
        let c = cross(a, b);
        let theta = (dot(a, b) / (norm(a) * norm(b))).clamp(-1.0, 1.0).acos();
        s += theta * dot(n, c) / norm(c);
    }
    l / 2.0 * s.abs()
}

/// The Klems full basis: (lower θ°, upper θ°, azimuth patches) per ring.
pub const KLEMS_FULL: [(f64, f64, usize); 9] = [
    (0.0, 5.0, 1),
    (5.0, 15.0, 8),
    (15.0, 25.0, 16),
    (25.0, 35.0, 20),
    (35.0, 45.0, 24),
    (45.0, 55.0, 24),
    (55.0, 65.0, 24),
    (65.0, 75.0, 16),
    (75.0, 90.0, 12),
];

/// Each Klems full patch's ring (lower θ, upper θ in radians) and projected solid angle Λ.
pub fn klems_patches() -> Vec<(f64, f64, f64)> {
    KLEMS_FULL
        .iter()
        .flat_map(|&(lo, hi, n)| {
            let (a, b) = (lo.to_radians(), hi.to_radians());
            let lambda = std::f64::consts::PI * (a.cos().powi(2) - b.cos().powi(2)) / n as f64;
            std::iter::repeat_n((a, b, lambda), n)
        })
        .collect()
}

/// Writes a WINDOW BSDF XML file in the Klems full basis, incident data in columns as
/// WINDOW writes them: `blocks` are (direction, e.g. "Transmission Front", values
/// incident-major: v[i · 145 + o]).
pub fn write_klems_xml(path: &std::path::Path, blocks: &[(&str, Vec<f64>)]) {
    let n = 145;
    let mut s = String::from(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<WindowElement xmlns=\"http://windows.lbl.gov\">\n<FileType>BSDF</FileType>\n<Optical>\n<Layer>\n<Material><Name>test</Name></Material>\n<DataDefinition><IncidentDataStructure>Columns</IncidentDataStructure></DataDefinition>\n<WavelengthData><Wavelength unit=\"Integral\">Visible</Wavelength>\n",
    );
    for (dir, v) in blocks {
        s += &format!("<WavelengthDataBlock><WavelengthDataDirection>{dir}</WavelengthDataDirection><ColumnAngleBasis>LBNL/Klems Full</ColumnAngleBasis><RowAngleBasis>LBNL/Klems Full</RowAngleBasis><ScatteringDataType>BTDF</ScatteringDataType><ScatteringData>\n");
        for o in 0..n {
            let row: Vec<String> = (0..n).map(|i| format!("{}", v[i * n + o])).collect();
            s += &row.join(", ");
            s += ",\n";
        }
        s += "</ScatteringData></WavelengthDataBlock>\n";
    }
    s += "</WavelengthData>\n</Layer>\n</Optical>\n</WindowElement>\n";
    std::fs::write(path, s).unwrap();
}

/// A fresh file path in the system's temporary folder for this test process.
pub fn scratch_path(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("imap-test-{}-{name}", std::process::id()))
}

/// The rig of the Mitsuba comparisons (scripts/mitsuba_scenes.py, mitsuba_media.py): a
/// 1 × 1 m emitter of radiance `l` at z = 1 facing down, centred at (−0.6, 0), and a black
/// 0.4 × 0.4 m receiver beside it facing down, centred at (+0.6, 0), tallied (its id
/// returned); `ground`: a white ground (ρ 0.8) 6 × 6 m at z = −0.12 too.
pub fn mitsuba_rig(ctx: &mut Context, black: u32, l: f64, ground: bool) -> u32 {
    if ground {
        let white = lambert(ctx, 0.8);
        let g = grid(2, -3.0, 3.0, -3.0, 3.0, -0.12);
        let mut gd = g.desc(white);
        gd.record = false;
        ctx.add_mesh(&gd).unwrap();
    }
    let lamp = grid(1, -1.1, -0.1, -0.5, 0.5, 1.0).flipped();
    let mut ld = lamp.desc(black);
    ld.record = false;
    let exitance = [std::f64::consts::PI * l];
    ld.exitance = Some(&exitance);
    ctx.add_mesh(&ld).unwrap();
    let receiver = grid(2, 0.4, 0.8, -0.2, 0.2, 1.0).flipped();
    let mut rd = receiver.desc(black);
    rd.tally = true;
    ctx.add_mesh(&rd).unwrap()
}

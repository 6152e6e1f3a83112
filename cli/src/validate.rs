//! `imap validate`: analytic cases with their expected values, run through libimap.

use crate::error::Result;
use imap::{Config, Context, IorModel, MaterialDesc, MeshDesc, RunParams};
use std::f64::consts::PI;

/// A rectangle z = const over [x0, x1] × [y0, y1], n × n cells; normals +z or −z.
fn plane(n: usize, x: [f64; 2], y: [f64; 2], z: f64, up: bool) -> (Vec<f64>, Vec<u32>) {
    let mut p = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let s = i as f64 / n as f64;
            let t = j as f64 / n as f64;
            p.extend([x[0] + s * (x[1] - x[0]), y[0] + t * (y[1] - y[0]), z]);
        }
    }
    let mut idx = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = (j * (n + 1) + i) as u32;
            let (b, c, d) = (a + 1, a + n as u32 + 2, a + n as u32 + 1);
            if up {
                idx.extend([a, b, c, a, c, d]);
            } else {
                idx.extend([a, c, b, a, d, c]);
            }
        }
    }
    (p, idx)
}

fn run(ctx: &mut Context, photons: u64) -> Result<imap::Report> {
    Ok(ctx.run(&mut RunParams {
        photons,
        progress_interval_s: 1.0,
        ..Default::default()
    })?)
}

/// Flux onto a recorded mesh (Σ vertex area × E, band mean).
fn flux(ctx: &Context, id: u32, p: &[f64], idx: &[u32]) -> Result<f64> {
    let nv = p.len() / 3;
    let mut share = vec![0.0; nv];
    for t in idx.chunks_exact(3) {
        let v = |k: usize| {
            [
                p[3 * t[k] as usize],
                p[3 * t[k] as usize + 1],
                p[3 * t[k] as usize + 2],
            ]
        };
        let (a, b, c) = (v(0), v(1), v(2));
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let w = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            u[1] * w[2] - u[2] * w[1],
            u[2] * w[0] - u[0] * w[2],
            u[0] * w[1] - u[1] * w[0],
        ];
        let area = 0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        for &i in t {
            share[i as usize] += area / 3.0;
        }
    }
    let mut total = 0.0;
    let mut e = vec![0.0; nv];
    for band in 0..3 {
        ctx.irradiance(id, 0, band, &mut e)?;
        total += e.iter().zip(&share).map(|(e, a)| e * a).sum::<f64>() / 3.0;
    }
    Ok(total)
}

/// One row: name, expected, got, standard error of got.
pub struct Case {
    pub name: &'static str,
    pub expected: f64,
    pub got: f64,
    pub sigma: f64,
}

impl Case {
    /// Passes within 4 standard errors.
    pub fn pass(&self) -> bool {
        (self.got - self.expected).abs() <= 4.0 * self.sigma
    }
}

fn context(seed: u64) -> Result<Context> {
    Ok(Context::new(Config {
        seed,
        ..Default::default()
    })?)
}

fn black(ctx: &mut Context) -> Result<u32> {
    Ok(ctx.add_material(&MaterialDesc {
        diffuse_reflect: vec![0.0],
        ..Default::default()
    })?)
}

pub fn cases(photons: u64) -> Result<Vec<Case>> {
    let n = photons as f64;
    let mut out = Vec::new();

    // 1. Point source 1 m above the centre of a black 4 m × 4 m square: the flux it
    //    receives is Φ·Ω/4π with Ω = 4·atan(ab/(d·√(a² + b² + d²))), a = b = 2, d = 1.
    {
        let mut ctx = context(1)?;
        let m = black(&mut ctx)?;
        let (p, i) = plane(16, [-2.0, 2.0], [-2.0, 2.0], 0.0, true);
        let id = ctx.add_mesh(&MeshDesc::new(&p, &i, m))?;
        ctx.add_point_light([0.0, 0.0, 1.0], &[10.0])?;
        run(&mut ctx, photons)?;
        let f = 4.0 * (4.0f64 / 3.0).atan() / (4.0 * PI);
        out.push(Case {
            name: "point source over a black square: received flux (W)",
            expected: 10.0 * f,
            got: flux(&ctx, id, &p, &i)?,
            sigma: 10.0 * (f * (1.0 - f) / n).sqrt(),
        });
    }

    // 2. A Lambertian emitting square (1 m², exitance 5 W/m²) 0.5 m above an equal black
    //    square: received flux = M·A·F with the view factor of directly opposed parallel
    //    rectangles, X = a/c, Y = b/c:
    //    F = 2/(πXY)·[ln√((1+X²)(1+Y²)/(1+X²+Y²)) + X√(1+Y²)·atan(X/√(1+Y²))
    //                 + Y√(1+X²)·atan(Y/√(1+X²)) − X·atan X − Y·atan Y].
    {
        let mut ctx = context(2)?;
        let m = black(&mut ctx)?;
        let (p, i) = plane(12, [0.0, 1.0], [0.0, 1.0], 0.0, true);
        let id = ctx.add_mesh(&MeshDesc::new(&p, &i, m))?;
        let (pe, ie) = plane(1, [0.0, 1.0], [0.0, 1.0], 0.5, false);
        ctx.add_mesh(&MeshDesc {
            record: false,
            exitance: Some(&[5.0]),
            ..MeshDesc::new(&pe, &ie, m)
        })?;
        run(&mut ctx, photons)?;
        let (x, y) = (2.0f64, 2.0f64);
        let f = 2.0 / (PI * x * y)
            * ((((1.0 + x * x) * (1.0 + y * y)) / (1.0 + x * x + y * y))
                .sqrt()
                .ln()
                + x * (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan()
                + y * (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan()
                - x * x.atan()
                - y * y.atan());
        out.push(Case {
            name: "emitting square over an equal parallel one: received flux (W)",
            expected: 5.0 * f,
            got: flux(&ctx, id, &p, &i)?,
            sigma: 5.0 * (f * (1.0 - f) / n).sqrt(),
        });
    }

    // 3. Closed cube room, Lambertian ρ = 0.8 everywhere, point light inside: the mean
    //    irradiance is Φ/(A(1 − ρ)) (every photon hits 1/(1 − ρ) times on average).
    {
        let mut ctx = context(3)?;
        let rho = 0.8;
        let wall = ctx.add_material(&MaterialDesc {
            diffuse_reflect: vec![rho],
            ..Default::default()
        })?;
        let faces = [
            plane(6, [0.0, 1.0], [0.0, 1.0], 0.0, true),
            plane(6, [0.0, 1.0], [0.0, 1.0], 1.0, false),
        ];
        let mut all = Vec::new();
        for (p, i) in faces {
            // The floor and ceiling, and the same rotated onto the four walls.
            for rot in 0..3 {
                let q: Vec<f64> = p
                    .chunks_exact(3)
                    .flat_map(|v| match rot {
                        0 => [v[0], v[1], v[2]],
                        1 => [v[2], v[0], v[1]],
                        _ => [v[1], v[2], v[0]],
                    })
                    .collect();
                all.push((q, i.clone()));
            }
        }
        let mut ids = Vec::new();
        for (q, i) in &all {
            ids.push(ctx.add_mesh(&MeshDesc::new(q, i, wall))?);
        }
        ctx.add_point_light([0.3, 0.6, 0.45], &[6.0])?;
        run(&mut ctx, photons / 4)?;
        let mut total = 0.0;
        for (id, (q, i)) in ids.iter().zip(&all) {
            total += flux(&ctx, *id, q, i)?;
        }
        out.push(Case {
            name: "closed room ρ = 0.8: mean irradiance (W/m²)",
            expected: 6.0 / (6.0 * (1.0 - rho)),
            got: total / 6.0,
            sigma: 6.0 / (6.0 * (1.0 - rho)) * (rho / (n / 4.0)).sqrt(),
        });
    }

    // 4. A clear glass slab (n = 1.5, 0.2 m thick) in a narrow beam at normal incidence
    //    over a black receiver: transmittance (1 − R)/(1 + R), R = ((n − 1)/(n + 1))²,
    //    with every internal reflection summed.
    {
        let mut ctx = context(4)?;
        let m = black(&mut ctx)?;
        let glass = ctx.add_material(&MaterialDesc {
            ior: Some(IorModel::Constant(1.5)),
            ..Default::default()
        })?;
        let (top, it) = plane(1, [-2.0, 2.0], [-2.0, 2.0], 0.0, true);
        let (bottom, ib) = plane(1, [-2.0, 2.0], [-2.0, 2.0], -0.2, false);
        // Side walls close the slab.
        let c = [[-2.0, -2.0], [2.0, -2.0], [2.0, 2.0], [-2.0, 2.0]];
        let mut sp = Vec::new();
        let mut si = Vec::new();
        for k in 0..4 {
            let (a, b) = (c[k], c[(k + 1) % 4]);
            let base = (sp.len() / 3) as u32;
            sp.extend([
                a[0], a[1], -0.2, b[0], b[1], -0.2, b[0], b[1], 0.0, a[0], a[1], 0.0,
            ]);
            si.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
        }
        for (p, i) in [(&top, &it), (&bottom, &ib), (&sp, &si)] {
            ctx.add_mesh(&MeshDesc {
                record: false,
                ..MeshDesc::new(p, i, glass)
            })?;
        }
        let (p, i) = plane(4, [-1.0, 1.0], [-1.0, 1.0], -0.5, true);
        let id = ctx.add_mesh(&MeshDesc::new(&p, &i, m))?;
        ctx.add_spot_light([0.0, 0.0, 0.5], [0.0, 0.0, -1.0], 1e-3, &[1.0])?;
        run(&mut ctx, photons)?;
        let r = (0.5f64 / 2.5).powi(2);
        let t = (1.0 - r) / (1.0 + r);
        out.push(Case {
            name: "clear slab n = 1.5 at normal incidence: transmittance",
            expected: t,
            got: flux(&ctx, id, &p, &i)?,
            sigma: (t * (1.0 - t) / n).sqrt(),
        });
    }
    Ok(out)
}

//! Camera luminance by backward photon maps (the second paper), against analytic answers:
//! a Lambertian surface under known irradiance E has radiance ρE/π.
mod common;

use common::*;
use imap::{CameraDesc, Config, Context, Image, RenderMethod, RenderParams, RenderReport};
use std::f64::consts::PI;

fn params(method: RenderMethod, passes: u64) -> RenderParams<'static> {
    RenderParams {
        method,
        group_threads: 1,
        remask_phases: 0,
        forward_per_pass: 0,
        initial_radius: 0.0,
        alpha: 0.0,
        passes,
        time_budget_s: 0.0,
        target_rel_error: 0.0,
        progress_interval_s: 0.05,
        max_path_events: 10_000,
        progress: None,
    }
}

fn render(ctx: &mut Context, cam: &CameraDesc, p: &mut RenderParams) -> (Image, RenderReport) {
    ctx.render(cam, p).expect("render")
}

/// Pixels whose truth is known: (pixel, truth).
fn compare(img: &Image, truth: &[(usize, f64)], band_mean: bool) -> (f64, f64) {
    // Returns (RMS relative deviation from the truth, RMS estimated relative error).
    let nb = img.bands;
    let (mut dev, mut est) = (0.0, 0.0);
    for &(p, t) in truth {
        let v = if band_mean {
            img.radiance[p * nb..][..nb].iter().sum::<f64>() / nb as f64
        } else {
            img.radiance[p * nb]
        };
        dev += ((v - t) / t).powi(2);
        est += img.rel_error[p].powi(2);
    }
    let n = truth.len() as f64;
    ((dev / n).sqrt(), (est / n).sqrt())
}

/// Closed sphere (ρ uniform) with a point light at its centre: every wall point has
/// E = Φ/(4πR²) direct plus ρΦ/((1−ρ)A) indirect (uniform over a sphere), so every pixel
/// of a camera inside shows L = ρE/π: direct light by light sampling, the indirect part by
/// forward photons gathered in backward photon maps.
#[test]
fn integrating_sphere_radiance_is_rho_e_over_pi() {
    for method in [
        RenderMethod::Synchronous,
        RenderMethod::Asynchronous,
        RenderMethod::SemiSynchronous,
    ] {
        let mut ctx = context(Config {
            threads: 2,
            seed: 5,
            ..Default::default()
        });
        let rho = 0.6;
        let wall = lambert(&mut ctx, rho);
        let g = sphere_inward(1.0, 5);
        ctx.add_mesh(&g.desc(wall)).unwrap();
        let power = 10.0;
        ctx.add_point_light([0.0; 3], &[power]).unwrap();
        let area: f64 = vertex_areas(&g).iter().sum();
        let e = power / (4.0 * PI) + rho * power / ((1.0 - rho) * area);
        let truth = rho * e / PI;
        let cam = CameraDesc {
            position: [0.0, -0.5, 0.0],
            direction: [0.0, 1.0, 0.2],
            up: [0.0, 0.0, 1.0],
            fov_y_deg: 60.0,
            width: 64,
            height: 64,
        };
        let mut p = params(method, 24);
        p.forward_per_pass = 4 * 64 * 64;
        let (img, rep) = render(&mut ctx, &cam, &mut p);
        let truths: Vec<(usize, f64)> = (0..64 * 64).map(|p| (p, truth)).collect();
        let (dev, est) = compare(&img, &truths, false);
        let mean = img.radiance.iter().step_by(3).sum::<f64>() / (64.0 * 64.0);
        eprintln!(
            "{method:?}: mean {mean:.5} truth {truth:.5} ({:+.2} %), rms dev {dev:.4}, est {est:.4}, global {:.4}, {} phases, {} fwd photons, {} gathers",
            (mean / truth - 1.0) * 100.0,
            rep.rel_error,
            rep.phases,
            rep.forward_photons,
            rep.gathers
        );
        assert!(
            (mean / truth - 1.0).abs() < 0.015,
            "{method:?}: image mean {mean} against ρE/π = {truth}"
        );
        assert!(
            dev < 2.0 * est && dev > 0.5 * est,
            "{method:?}: per-pixel deviation {dev} against the estimate {est}"
        );
        assert_eq!(rep.gate_violations, 0);
    }
}

//! `imap render`: the camera image of a model through libimap's renderer (final gathering
//! from the illumination map by default; or backward photon maps with progressive radius
//! reduction, the second paper's three parallel methods),
//! written as a tone-mapped PNG, as radiance (PFM, linear, W/(m²·sr) per RGB channel) with
//! each pixel's relative error, and with the error history and its plot.

use crate::error::{fail, CliError, Result};
use crate::output::{self, ToneMap};
use crate::settings::Settings;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Command-line overrides of `[render]` and the camera's size.
#[derive(clap::Args, Clone)]
pub struct RenderOptions {
    /// Output folder (created if missing).
    #[arg(long, short, default_value = "imap-render")]
    pub out: PathBuf,
    /// "final-gathering" (default), "semi-synchronous", "synchronous" or "asynchronous".
    #[arg(long)]
    pub method: Option<String>,
    /// Image size, WIDTHxHEIGHT (overrides the camera's).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Passes over the image (0 = no limit).
    #[arg(long)]
    pub passes: Option<u64>,
    /// Seconds (0 = no limit).
    #[arg(long)]
    pub time: Option<f64>,
    /// Target relative error of the image, e.g. 0.02 (0 = none).
    #[arg(long)]
    pub target_error: Option<f64>,
    /// Threads (0 = one per core).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Seed of the random streams.
    #[arg(long)]
    pub seed: Option<u64>,
    /// No progress line.
    #[arg(long)]
    pub quiet: bool,
}

/// "640x480" → (640, 480).
pub fn parse_size(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X', '×'])
        .ok_or_else(|| format!("'{s}' is not WIDTHxHEIGHT"))?;
    let n = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("'{s}' is not WIDTHxHEIGHT"))
    };
    Ok((n(w)?, n(h)?))
}

fn method(name: Option<&str>) -> Result<imap::RenderMethod> {
    Ok(
        match name.unwrap_or("final-gathering").to_ascii_lowercase().as_str() {
            "final-gathering" | "final-gather" | "gather" => imap::RenderMethod::FinalGather,
            "semi-synchronous" | "semisynchronous" | "semi" => imap::RenderMethod::SemiSynchronous,
            "synchronous" | "sync" => imap::RenderMethod::Synchronous,
            "asynchronous" | "async" => imap::RenderMethod::Asynchronous,
            m => fail!(
                "render method \"{}\": use \"final-gathering\", \"semi-synchronous\", \"synchronous\" or \"asynchronous\"",
                crate::diag::printable(m)
            ),
        },
    )
}

/// Writes `values` (`channels` = 3 or 1 floats per pixel, rows from the top) as a PFM:
/// little-endian floats, rows from the bottom, as the format defines.
fn write_pfm(path: &Path, w: u32, h: u32, channels: usize, values: &[f32]) -> Result<()> {
    let err = |e: std::io::Error| CliError(format!("{}: {e}", path.display()));
    let f = std::fs::File::create(path).map_err(err)?;
    let mut f = std::io::BufWriter::new(f);
    let tag = if channels == 3 { "PF" } else { "Pf" };
    write!(f, "{tag}\n{w} {h}\n-1.0\n").map_err(err)?;
    let row = w as usize * channels;
    for y in (0..h as usize).rev() {
        for v in &values[y * row..(y + 1) * row] {
            f.write_all(&v.to_le_bytes()).map_err(err)?;
        }
    }
    f.flush().map_err(err)
}

/// Loads, renders and writes the image and its report; returns the report.
pub fn render(
    model: &Path,
    mut settings: Settings,
    opts: &RenderOptions,
) -> Result<serde_json::Value> {
    let out = opts.out.as_path();
    crate::observers::not_here(&mut settings, "render");
    if let Some(t) = opts.threads {
        settings.run.threads = t;
    }
    if let Some(s) = opts.seed {
        settings.run.seed = s;
    }
    let mut r = settings.render.clone().unwrap_or_default();
    if let Some(m) = &opts.method {
        r.method = Some(m.clone());
    }
    if let Some(p) = opts.passes {
        r.passes = p;
    }
    if let Some(t) = opts.time {
        r.time_s = t;
    }
    if let Some(e) = opts.target_error {
        r.target_error = e;
    }
    for (what, x) in [("time", r.time_s), ("target error", r.target_error)] {
        if !(x.is_finite() && x >= 0.0) {
            fail!("render {what} {x} must be a positive number (0 = none)");
        }
    }
    if r.passes == 0 && r.time_s == 0.0 && r.target_error == 0.0 {
        r.time_s = 30.0;
    }
    let m = method(r.method.as_deref())?;
    let (mut ctx, scene, mut cam) = output::load_with_camera(model, &settings)?;
    if let Some((w, h)) = opts.size {
        cam.width = w;
        cam.height = h;
    }
    cam.validate()?;
    crate::output::create_out_dir(out)?;
    let desc = imap::CameraDesc {
        position: cam.position,
        direction: [0, 1, 2].map(|k| cam.look_at[k] - cam.position[k]),
        up: cam.up(),
        fov_y_deg: cam.fov_deg,
        width: cam.width,
        height: cam.height,
        projection: cam.projection().unwrap_or_default(),
    };
    let interrupted = crate::Interrupts::get();
    let quiet = opts.quiet;
    let mut callback = |p: &imap::Progress| -> bool {
        if !quiet {
            eprint!(
                "\r{:7.1} s  error {:6.2} %   ",
                p.elapsed_s,
                100.0 * p.rel_error
            );
        }
        !interrupted.raised()
    };
    let (image, report) = ctx.render(
        &desc,
        &mut imap::RenderParams {
            method: m,
            group_threads: r.group_threads,
            remask_phases: 0,
            forward_per_pass: 0,
            initial_radius: r.initial_radius,
            alpha: r.alpha,
            passes: r.passes,
            time_budget_s: r.time_s,
            target_rel_error: r.target_error,
            progress_interval_s: settings.run.progress_interval_s,
            max_path_events: 1 << 20,
            progress: Some(&mut callback),
        },
    )?;
    if !quiet {
        eprintln!();
    }
    let was_interrupted = interrupted.raised();
    let (w, h, nb) = (image.width, image.height, image.bands);
    let px = w as usize * h as usize;
    let rgb: Vec<[f64; 3]> = (0..px)
        .map(|i| {
            output::to_rgb(
                &image.radiance[i * nb..(i + 1) * nb],
                &scene.band_nm,
                scene.rgb,
            )
        })
        .collect();
    let tone = ToneMap::new(
        rgb.iter()
            .map(|c| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]),
    );
    let png: Vec<u8> = rgb.iter().flat_map(|&c| tone.apply(c)).collect();
    let flat: Vec<f32> = rgb.iter().flat_map(|c| c.map(|x| x as f32)).collect();
    let errors: Vec<f32> = image.rel_error.iter().map(|&e| e as f32).collect();
    let history: Vec<serde_json::Value> = report
        .history
        .iter()
        .map(|p| serde_json::json!({"elapsed_s": p.elapsed_s, "rel_error": p.rel_error}))
        .collect();
    let stop = if was_interrupted {
        "Interrupted".to_string()
    } else {
        format!("{:?}", report.stop.unwrap_or(imap::StopReason::TimeBudget))
    };
    // What the method cannot show of this scene, said plainly.
    let mut omitted = Vec::new();
    if report.omitted & imap::OMITS_REFRACTED_INTO_MEDIUM != 0 {
        omitted.push(
            "light of point-like lights or the sun that enters a scattering medium through a refracting surface (an opal cover lit by LEDs) and is scattered toward the camera is missing from the picture (the illumination map has it)",
        );
    }
    if report.omitted & imap::OMITS_CAUSTICS_ON_GLOSSY != 0 {
        omitted.push(
            "light of point-like lights or the sun that reaches a glossy surface through specular ones is missing; method = \"final-gathering\" shows it",
        );
    }
    for o in &omitted {
        eprintln!("imap: warning: {o}");
    }
    // A fisheye's daylight glare probability, with its sources outlined on glare.png.
    let glare = if desc.projection == imap::Projection::Perspective {
        None
    } else {
        match ctx.picture_glare(&desc, &image, &imap::glare::SourceRules::default()) {
            Ok(g) => Some(g),
            Err(e) => {
                eprintln!("imap: warning: no DGP of this picture: {}", e.message);
                None
            }
        }
    };
    let mut outputs = vec![
        "render.png",
        "radiance.pfm",
        "rel_error.pfm",
        "convergence.png",
        "render.json",
    ];
    if glare.is_some() {
        outputs.push("glare.png");
    }
    let json = serde_json::json!({
        "scene": model.display().to_string(),
        "model": {
            "format": scene.format, "triangles_read": scene.triangles_read,
            "material_variants": scene.material_variants
        },
        "camera": cam,
        "method": format!("{m:?}"),
        "bands_nm": scene.band_nm,
        "units": {
            "radiance.pfm": "W/(m2 sr) per RGB channel (spectral runs: the bands' mean over each channel's wavelengths), linear, rows from the bottom (PFM)",
            "rel_error.pfm": "relative standard error of each pixel's band mean"
        },
        "warnings": scene.warnings,
        "omitted": omitted,
        "interrupted": was_interrupted,
        "stop": stop,
        "passes": report.passes,
        "rel_error": report.rel_error,
        "wall_s": report.wall_s,
        "threads": report.threads,
        "forward_photons": report.forward_photons,
        "map_photons": ctx.report().photons,
        "backward_paths": report.backward_paths,
        "history": history,
        "outputs": outputs,
        "glare": glare.as_ref().map(glare_json),
    });
    let mut files = output::Outputs::new(out, "render.json")?;
    output::write_png(&files.temp("render.png")?, w, h, &png)?;
    if let Some(g) = &glare {
        output::write_png(
            &files.temp("glare.png")?,
            w,
            h,
            &outlined(&png, w, h, &g.labels),
        )?;
    }
    write_pfm(&files.temp("radiance.pfm")?, w, h, 3, &flat)?;
    write_pfm(&files.temp("rel_error.pfm")?, w, h, 1, &errors)?;
    output::plot_convergence(&files.temp("convergence.png")?, &report.history)?;
    let path = files.temp("render.json")?;
    std::fs::write(&path, serde_json::to_string_pretty(&json).unwrap())
        .map_err(|e| CliError(format!("{}: {e}", path.display())))?;
    files.commit()?;
    println!(
        "{w}×{h}, {:.1} passes in {:.1} s ({stop}), estimated error {:.2} %; wrote {}/{{{}}}",
        report.passes,
        report.wall_s,
        100.0 * report.rel_error,
        out.display(),
        outputs.join(", ")
    );
    if let Some(g) = &glare {
        println!(
            "DGP {:.3} ± {:.3} (Ev {:.0} ± {:.0} lx, {} glare sources above {:.0} cd/m²; wrote glare.png)",
            g.dgp,
            g.dgp_sigma,
            g.ev_lx,
            g.ev_sigma_lx,
            g.sources.len(),
            g.threshold_cd_m2
        );
    }
    if let Some(code) = interrupted.status() {
        eprintln!("imap: interrupted: the outputs hold the image rendered until then");
        std::process::exit(code);
    }
    Ok(json)
}

/// render.json's "glare": DGP with its error and the sources evalglare's rules found.
fn glare_json(g: &imap::glare::PictureGlare) -> serde_json::Value {
    serde_json::json!({
        "dgp": g.dgp,
        "dgp_sigma": g.dgp_sigma,
        "ev_lx": g.ev_lx,
        "ev_sigma_lx": g.ev_sigma_lx,
        "threshold_cd_m2": g.threshold_cd_m2,
        "mean_luminance_cd_m2": g.mean_luminance_cd_m2,
        "background_cd_m2": g.background_cd_m2,
        "rules": "evalglare's defaults: 2000 cd/m², search 0.2 rad, peaks above 50 000 cd/m² split off, no low-light correction",
        "sources": g.sources.iter().enumerate().map(|(i, s)| serde_json::json!({
            "label": i + 1,
            "direction": s.direction,
            "centre_px": s.centre_px,
            "pixels": s.pixels,
            "solid_angle_sr": s.solid_angle_sr,
            "luminance_cd_m2": s.luminance_cd_m2,
            "position_index": s.position_index,
            "ev_lx": s.ev_lx,
        })).collect::<Vec<_>>(),
    })
}

/// Colours of the glare sources on glare.png, by label.
const SOURCE_COLOURS: [[u8; 3]; 6] = [
    [255, 40, 40],
    [40, 220, 40],
    [60, 110, 255],
    [255, 200, 0],
    [230, 60, 230],
    [0, 220, 220],
];

/// 3 × 5 pixel digits, a row per byte's low three bits.
const DIGITS: [[u8; 5]; 10] = [
    [7, 5, 5, 5, 7],
    [2, 6, 2, 2, 7],
    [7, 1, 7, 4, 7],
    [7, 1, 7, 1, 7],
    [5, 5, 7, 1, 1],
    [7, 4, 7, 1, 7],
    [7, 4, 7, 5, 7],
    [7, 1, 1, 1, 1],
    [7, 5, 7, 5, 7],
    [7, 5, 7, 1, 7],
];

/// The tone-mapped picture with every glare source tinted in its colour, outlined, and
/// labelled with its number (render.json's "label") beside its centre.
fn outlined(png: &[u8], w: u32, h: u32, labels: &[u32]) -> Vec<u8> {
    let mut out = png.to_vec();
    let (wi, hi) = (w as i64, h as i64);
    let at = |x: i64, y: i64| -> u32 {
        if x < 0 || y < 0 || x >= wi || y >= hi {
            0
        } else {
            labels[(y * wi + x) as usize]
        }
    };
    let mut centre: std::collections::BTreeMap<u32, (f64, f64, f64)> = Default::default();
    for y in 0..hi {
        for x in 0..wi {
            let l = at(x, y);
            if l == 0 {
                continue;
            }
            let c = SOURCE_COLOURS[(l as usize - 1) % SOURCE_COLOURS.len()];
            let edge = [(-1, 0), (1, 0), (0, -1), (0, 1)]
                .iter()
                .any(|&(dx, dy)| at(x + dx, y + dy) != l);
            let p = &mut out[(y * wi + x) as usize * 3..][..3];
            for k in 0..3 {
                p[k] = if edge {
                    c[k]
                } else {
                    ((p[k] as u16 + c[k] as u16) / 2) as u8
                };
            }
            let e = centre.entry(l).or_default();
            *e = (e.0 + x as f64, e.1 + y as f64, e.2 + 1.0);
        }
    }
    for (l, (sx, sy, n)) in centre {
        let text = l.to_string();
        let (x0, y0) = ((sx / n) as i64 + 3, (sy / n) as i64 - 2);
        for (i, ch) in text.bytes().enumerate() {
            let glyph = DIGITS[(ch - b'0') as usize];
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..3 {
                    let (x, y) = (x0 + i as i64 * 4 + col, y0 + row as i64);
                    if x < 0 || y < 0 || x >= wi || y >= hi {
                        continue;
                    }
                    let on = bits >> (2 - col) & 1 == 1;
                    let p = &mut out[(y * wi + x) as usize * 3..][..3];
                    p.copy_from_slice(if on { &[255, 255, 255] } else { &[0, 0, 0] });
                }
            }
        }
    }
    out
}

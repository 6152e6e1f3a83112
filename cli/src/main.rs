//! `imap`: runs libimap on OBJ/MTL scenes and writes the illumination map, pictures and the
//! error-against-time history.

mod cornell;
mod output;
mod scene;
mod validate;

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use scene::{fail, CameraSettings, CliError, Result, Settings};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Parser)]
#[command(name = "imap", version, about = "Illumination maps with libimap")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Args, Clone)]
struct RunOptions {
    /// Output folder (created if missing).
    #[arg(long, short, default_value = "imap-out")]
    out: PathBuf,
    /// Photons to trace (overrides the settings; 0 = no limit).
    #[arg(long)]
    photons: Option<u64>,
    /// Seconds to run (overrides the settings; 0 = no limit).
    #[arg(long)]
    time: Option<f64>,
    /// Target global relative error, e.g. 0.01 (overrides the settings; 0 = none).
    #[arg(long)]
    target_error: Option<f64>,
    /// Calculating threads (0 = one per core).
    #[arg(long)]
    threads: Option<usize>,
    /// "dynamic" or "classic".
    #[arg(long)]
    scheduler: Option<String>,
    /// Seed of the random streams.
    #[arg(long)]
    seed: Option<u64>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Compute the illumination map of an OBJ scene.
    Run {
        /// The scene (OBJ with its MTL libraries).
        scene: PathBuf,
        /// TOML settings: lights, spectra, recording, stop criteria, camera.
        #[arg(long, short)]
        config: Option<PathBuf>,
        #[command(flatten)]
        opts: RunOptions,
    },
    /// The Cornell box, built in memory, run to a target error; writes every output.
    Demo {
        #[command(flatten)]
        opts: RunOptions,
    },
    /// Run the analytic cases and print expected against computed values.
    Validate {
        /// Photons per case.
        #[arg(long, default_value_t = 2_000_000)]
        photons: u64,
    },
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run {
            scene,
            config,
            opts,
        } => (|| {
            let settings = match &config {
                Some(p) => Settings::load(p)?,
                None => Settings::default(),
            };
            run_scene(&scene, settings, &opts).map(|_| ())
        })(),
        Command::Demo { opts } => demo(&opts),
        Command::Validate { photons } => validate_cmd(photons),
    };
    if let Err(e) = result {
        eprintln!("imap: error: {e}");
        std::process::exit(2);
    }
}

fn apply_options(settings: &mut Settings, opts: &RunOptions) {
    let r = &mut settings.run;
    if let Some(x) = opts.photons {
        r.photons = x;
    }
    if let Some(x) = opts.time {
        r.time_s = x;
    }
    if let Some(x) = opts.target_error {
        r.target_error = x;
    }
    if let Some(x) = opts.threads {
        r.threads = x;
    }
    if let Some(x) = &opts.scheduler {
        r.scheduler = x.clone();
    }
    if let Some(x) = opts.seed {
        r.seed = x;
    }
}

/// Loads, runs with a progress bar, and writes the outputs; returns the report.
fn run_scene(obj: &Path, mut settings: Settings, opts: &RunOptions) -> Result<serde_json::Value> {
    apply_options(&mut settings, opts);
    let r = &settings.run;
    if !(r.photons > 0 || r.time_s > 0.0 || r.target_error > 0.0) {
        fail!("no stop criterion: give photons, time or target_error (settings [run] or --photons/--time/--target-error)");
    }
    let (mut ctx, scene) = scene::load(obj, &settings)?;
    std::fs::create_dir_all(&opts.out)
        .map_err(|e| CliError(format!("{}: {e}", opts.out.display())))?;

    let bar = if opts.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(1000)
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} {elapsed:>4} [{bar:30}] {msg}")
            .unwrap()
            .progress_chars("=> "),
    );
    let (target, time_s, photons) = (r.target_error, r.time_s, r.photons);
    let mut callback = |p: &imap::Progress| -> bool {
        let rate = if p.elapsed_s > 0.0 {
            p.hits as f64 / p.elapsed_s
        } else {
            0.0
        };
        // Error ∝ t^-1/2: the time to the target is t·(error/target)².
        let mut frac: f64 = 0.0;
        let mut eta = String::new();
        if target > 0.0 && p.rel_error < 1.0 {
            let t_target = p.elapsed_s * (p.rel_error / target).powi(2);
            frac = frac.max(p.elapsed_s / t_target);
            eta = format!(", ETA {:.0} s", (t_target - p.elapsed_s).max(0.0));
        }
        if time_s > 0.0 {
            frac = frac.max(p.elapsed_s / time_s);
        }
        if photons > 0 {
            frac = frac.max(p.photons as f64 / photons as f64);
        }
        bar.set_position((frac.min(1.0) * 1000.0) as u64);
        bar.set_message(format!(
            "{} photons, {:.2} M hits/s, error {:.2} %{eta}",
            p.photons,
            rate / 1e6,
            100.0 * p.rel_error
        ));
        true
    };
    let t0 = Instant::now();
    let report = ctx.run(&mut imap::RunParams {
        photons,
        time_budget_s: time_s,
        target_rel_error: target,
        progress_interval_s: r.progress_interval_s,
        max_path_events: 1 << 20,
        progress: Some(&mut callback),
    })?;
    let wall = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();

    let maps = output::read_maps(&ctx, &scene)?;
    let out = &opts.out;
    output::write_csv(&out.join("irradiance.csv"), &scene, &maps)?;
    output::write_ply(&out.join("irradiance.ply"), &scene, &maps)?;
    output::plot_convergence(&out.join("convergence.png"), ctx.history())?;
    let cam: CameraSettings = settings
        .camera
        .clone()
        .unwrap_or_else(|| output::default_camera(&scene));
    let img = output::render_view(&scene, &maps, &cam)?;
    output::write_png(&out.join("view.png"), cam.width, cam.height, &img)?;

    let history: Vec<serde_json::Value> = ctx
        .history()
        .iter()
        .map(|p| {
            serde_json::json!({
                "elapsed_s": p.elapsed_s, "photons": p.photons, "hits": p.hits,
                "rel_error": p.rel_error
            })
        })
        .collect();
    let c = report.counters;
    let json = serde_json::json!({
        "scene": obj.display().to_string(),
        "settings": settings,
        "bands_nm": scene.band_nm,
        "meshes": scene.meshes.iter().map(|m| serde_json::json!({
            "name": m.name, "vertices": m.positions.len() / 3,
            "triangles": m.indices.len() / 3, "recorded": m.id.is_some(),
            "emitting": m.emission.is_some()
        })).collect::<Vec<_>>(),
        "stop": format!("{:?}", report.stop.unwrap_or(imap::StopReason::PhotonCount)),
        "photons": report.photons,
        "hits": report.hits,
        "run_s": report.elapsed_s,
        "wall_s": wall,
        "photons_per_s": report.photons as f64 / report.elapsed_s.max(1e-9),
        "rel_error": report.rel_error,
        "threads": report.threads,
        "scheduler": format!("{:?}", report.scheduler),
        "energy_w": {
            "emitted": report.emitted_w, "absorbed": report.absorbed_w,
            "escaped": report.escaped_w, "dropped": report.dropped_w,
            "dropped_photons": report.dropped_photons
        },
        "counters": {
            "calc_wait_s": c.calc_wait_s, "accum_busy_fraction": c.accum_busy_fraction,
            "peak_queue": c.peak_queue, "portions": c.portions,
            "inline_portions": c.inline_portions, "splits": c.splits, "groups": c.groups
        },
        "map_bytes": report.map_bytes,
        "history": history,
        "outputs": ["irradiance.csv", "irradiance.ply", "report.json", "convergence.png", "view.png"],
    });
    let path = out.join("report.json");
    std::fs::write(&path, serde_json::to_string_pretty(&json).unwrap())
        .map_err(|e| CliError(format!("{}: {e}", path.display())))?;
    println!(
        "{} photons in {:.1} s ({:?}), estimated error {:.2} %; wrote {}/{{irradiance.csv, irradiance.ply, report.json, convergence.png, view.png}}",
        report.photons,
        report.elapsed_s,
        report.stop.unwrap_or(imap::StopReason::PhotonCount),
        100.0 * report.rel_error,
        out.display()
    );
    Ok(json)
}

fn demo(opts: &RunOptions) -> Result<()> {
    std::fs::create_dir_all(&opts.out)
        .map_err(|e| CliError(format!("{}: {e}", opts.out.display())))?;
    let (obj, mtl) = cornell::cornell_box("cornell_box.mtl");
    let obj_path = opts.out.join("cornell_box.obj");
    for (p, text) in [(&obj_path, &obj), (&opts.out.join("cornell_box.mtl"), &mtl)] {
        std::fs::write(p, text).map_err(|e| CliError(format!("{}: {e}", p.display())))?;
    }
    let settings = Settings {
        unit_m: Some(0.001),
        run: scene::RunSettings {
            target_error: 0.01,
            time_s: 50.0,
            ..Default::default()
        },
        camera: Some(CameraSettings {
            position: [278.0, 273.0, -800.0],
            look_at: [278.0, 273.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_deg: 39.3,
            width: 512,
            height: 512,
        }),
        ..Default::default()
    };
    println!(
        "Cornell box: {} (scene written there too)",
        opts.out.display()
    );
    run_scene(&obj_path, settings, opts).map(|_| ())
}

fn validate_cmd(photons: u64) -> Result<()> {
    let cases = validate::cases(photons)?;
    println!(
        "{:<62} {:>12} {:>12} {:>9} {:>7}  result",
        "case", "expected", "got", "error", "σ"
    );
    let mut failed = 0;
    for c in &cases {
        let rel = (c.got - c.expected) / c.expected;
        println!(
            "{:<62} {:>12.6} {:>12.6} {:>+8.3}% {:>6.2}σ  {}",
            c.name,
            c.expected,
            c.got,
            100.0 * rel,
            (c.got - c.expected) / c.sigma,
            if c.pass() { "pass" } else { "FAIL" }
        );
        failed += usize::from(!c.pass());
    }
    if failed > 0 {
        fail!(
            "{failed} of {} cases outside 4 standard errors",
            cases.len()
        );
    }
    Ok(())
}

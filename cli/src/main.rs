//! `imap`: runs libimap on OBJ/MTL scenes and writes the illumination map, pictures and the
//! error-against-time history.

mod annual;
mod cornell;
mod daylight;
mod diag;
mod error;
mod grids;
mod jobs;
mod lights;
mod materials;
mod model;
mod observers;
mod output;
mod raster;
mod readers;
mod render_cmd;
mod scene;
mod segments;
mod settings;
mod validate;

use clap::{Parser, Subcommand};
use error::{fail, CliError, Result};
use indicatif::{ProgressBar, ProgressStyle};
use settings::{CameraSettings, Settings};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
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
    /// Stop when the calculation grids' error is at or below this, e.g. 0.02 (the largest
    /// point error unless the settings' run.grid_error_measure says otherwise); the global target is
    /// then not used.
    #[arg(long)]
    until_grid_error: Option<f64>,
    /// Calculating threads (0 = one per core).
    #[arg(long)]
    threads: Option<usize>,
    /// "dynamic" or "classic".
    #[arg(long)]
    scheduler: Option<String>,
    /// "light-sampling" (default: direct light by shadow rays from the vertices, photons
    /// for the indirect part), "gather" (light sampling, and paths from the vertices gather
    /// diffusely reflected light too) or "photons" (photons only, the first paper's method).
    #[arg(long)]
    estimator: Option<String>,
    /// Seed of the random streams.
    #[arg(long)]
    seed: Option<u64>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Save the run's state to FILE every --checkpoint-every seconds and at the end
    /// (atomically: a crash never leaves a part); `imap resume FILE` goes on from it.
    #[arg(long, value_name = "FILE")]
    checkpoint: Option<PathBuf>,
    /// Seconds between checkpoints (default 60).
    #[arg(long, value_name = "SECONDS")]
    checkpoint_every: Option<f64>,
    /// Trace shard k of N (0 <= k < N) of the photons (of the first --photons, when given)
    /// and write the state (to --checkpoint, or OUT/shard-k-of-N.imap) instead of the
    /// outputs; `imap merge` adds the shards' states and writes every output.
    #[arg(long, value_name = "k/N")]
    shard: Option<String>,
}

#[derive(Subcommand)]
enum Command {
    /// Compute the illumination map of a model.
    Run {
        /// The model (.obj with its MTL libraries, .gltf, .glb, .ply, .stl).
        scene: PathBuf,
        /// TOML settings: lights, spectra, recording, stop criteria, camera.
        #[arg(long, short)]
        config: Option<PathBuf>,
        #[command(flatten)]
        opts: RunOptions,
    },
    /// Render the camera image of a model (backward photon maps): a tone-mapped PNG,
    /// radiance and per-pixel error as PFM, the error history and its plot.
    Render {
        /// The model (.obj with its MTL libraries, .gltf, .glb, .ply, .stl).
        scene: PathBuf,
        /// TOML settings: lights, spectra, camera, the render section.
        #[arg(long, short)]
        config: Option<PathBuf>,
        #[command(flatten)]
        opts: render_cmd::RenderOptions,
    },
    /// Go on with a run from its checkpoint or a shard's state (killed, rebooted, or to run
    /// further): the same model and settings, the rest of its photons; writes the outputs
    /// as the run would have.
    Resume {
        /// The state file (`imap run --checkpoint FILE` or `--shard`).
        state: PathBuf,
        /// Output folder (default: the run's).
        #[arg(long, short)]
        out: Option<PathBuf>,
        /// Calculating threads (0 = one per core; the map does not depend on it).
        #[arg(long)]
        threads: Option<usize>,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
    },
    /// Add the states of shards or separate runs of the same model and settings (disjoint
    /// photons) and write every output of the whole.
    Merge {
        /// State files (`imap run --shard k/N`, `--checkpoint`).
        #[arg(required = true)]
        states: Vec<PathBuf>,
        /// Output folder (default: the first state's run's).
        #[arg(long, short)]
        out: Option<PathBuf>,
    },
    /// Annual daylight: daylight coefficients at the grids' points from one run, a year of
    /// Perez skies from a weather file, and DA, cDA, UDI and sDA with their confidence
    /// (annual.json, annual_GRID.csv). The settings hold the model's materials and grids,
    /// no lights.
    Annual {
        /// The model (.obj with its MTL libraries, .gltf, .glb, .ply, .stl).
        scene: PathBuf,
        /// TOML settings: materials, grids, estimator.
        #[arg(long, short)]
        config: Option<PathBuf>,
        #[command(flatten)]
        opts: annual::AnnualOptions,
    },
    /// Read a model and print what was read, as JSON: format, objects, triangles,
    /// materials, bounds, warnings and errors (exit status 2 when it has errors).
    Info {
        /// The model (.obj with its MTL libraries, .gltf, .glb, .ply, .stl).
        scene: PathBuf,
    },
    /// The CIE 190 UGR table of a luminaire file (.ies or .ldt): 19 standard rooms, 5
    /// reflectance combinations, crosswise and endwise (docs/glare.md).
    UgrTable {
        /// The luminaire file.
        file: PathBuf,
        /// Write CSV (room X/H, Y/H, then the ten values) instead of the table.
        #[arg(long)]
        csv: bool,
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
    // A closed pipe (`imap info MODEL | head`) ends the command quietly, as it does other
    // Unix tools, instead of failing a print.
    // SAFETY: restoring the default disposition of SIGPIPE before any thread starts.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL)
    };
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run {
            scene,
            config,
            opts,
        } => (|| {
            let settings = settings_from(config.as_deref())?;
            run_scene(&scene, settings, &opts).map(|_| ())
        })(),
        Command::Render {
            scene,
            config,
            opts,
        } => settings_from(config.as_deref())
            .and_then(|settings| render_cmd::render(&scene, settings, &opts).map(|_| ())),
        Command::Resume {
            state,
            out,
            threads,
            quiet,
        } => resume(&state, out, threads, quiet).map(|_| ()),
        Command::Merge { states, out } => merge(&states, out),
        Command::Annual {
            scene,
            config,
            opts,
        } => settings_from(config.as_deref())
            .and_then(|settings| annual::annual(&scene, settings, &opts)),
        Command::Info { scene } => info(&scene),
        Command::UgrTable { file, csv } => observers::ugr_table_cmd(&file, csv),
        Command::Demo { opts } => demo(&opts),
        Command::Validate { photons } => validate_cmd(photons),
    };
    if let Err(e) = result {
        // Nothing read from an input reaches the terminal raw, whatever the message.
        for line in e.0.lines() {
            eprintln!("imap: error: {}", diag::printable(line));
        }
        std::process::exit(2);
    }
}

/// The settings file, or the defaults without one.
fn settings_from(config: Option<&Path>) -> Result<Settings> {
    match config {
        Some(p) => Settings::load(p),
        None => Ok(Settings::default()),
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
    if let Some(x) = opts.until_grid_error {
        r.grid_error = x;
    }
    if let Some(x) = opts.threads {
        r.threads = x;
    }
    if let Some(x) = &opts.scheduler {
        r.scheduler = x.clone();
    }
    if let Some(x) = &opts.estimator {
        r.estimator = x.clone();
    }
    if let Some(x) = opts.seed {
        r.seed = x;
    }
}

/// The estimator a settings' name stands for.
/// The command's progress bar of 1000 steps (hidden with --quiet).
fn progress_bar(quiet: bool) -> ProgressBar {
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(1000)
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} {elapsed:>4} [{bar:30}] {msg}")
            .expect("a valid template")
            .progress_chars("=> "),
    );
    bar
}

fn estimator(name: &str) -> Result<imap::Estimator> {
    match name {
        "light-sampling" => Ok(imap::Estimator::DEFAULT),
        "gather" => Ok(imap::Estimator::GATHER),
        "photons" => Ok(imap::Estimator::Photons),
        other => Err(CliError(format!(
            "estimator \"{other}\": use \"light-sampling\", \"gather\" or \"photons\""
        ))),
    }
}

/// SIGINT and SIGTERM: the first stops the run at its next progress check, and the
/// outputs of what was computed are written (marked interrupted) before the command exits
/// with 128 + the signal's number; a second signal exits at once.
pub(crate) struct Interrupts {
    any: Arc<AtomicBool>,
    int: Arc<AtomicBool>,
    term: Arc<AtomicBool>,
}

impl Interrupts {
    pub(crate) fn get() -> &'static Interrupts {
        static I: OnceLock<Interrupts> = OnceLock::new();
        I.get_or_init(|| {
            let i = Interrupts {
                any: Arc::new(AtomicBool::new(false)),
                int: Arc::new(AtomicBool::new(false)),
                term: Arc::new(AtomicBool::new(false)),
            };
            use signal_hook::consts::{SIGINT, SIGTERM};
            for (sig, own) in [(SIGINT, &i.int), (SIGTERM, &i.term)] {
                // Registered first, runs first: exits when a signal already came.
                let _ =
                    signal_hook::flag::register_conditional_shutdown(sig, 128 + sig, i.any.clone());
                let _ = signal_hook::flag::register(sig, i.any.clone());
                let _ = signal_hook::flag::register(sig, own.clone());
            }
            i
        })
    }

    pub(crate) fn raised(&self) -> bool {
        self.any.load(Ordering::Relaxed)
    }

    /// The exit status for the signal that came: 130 (SIGINT) or 143 (SIGTERM).
    pub(crate) fn status(&self) -> Option<i32> {
        if self.int.load(Ordering::Relaxed) {
            Some(130)
        } else if self.term.load(Ordering::Relaxed) {
            Some(143)
        } else {
            None
        }
    }
}

/// Loads, runs with a progress bar, and writes the outputs; returns the report.
fn run_scene(obj: &Path, mut settings: Settings, opts: &RunOptions) -> Result<serde_json::Value> {
    apply_options(&mut settings, opts);
    let plan = jobs::StatePlan::new(
        opts.checkpoint.as_deref(),
        opts.checkpoint_every,
        opts.shard.as_deref(),
        &opts.out,
    )?;
    execute(obj, settings, &opts.out, plan, None, opts.quiet)
}

/// Goes on from a checkpoint or a shard's state.
fn resume(
    path: &Path,
    out: Option<PathBuf>,
    threads: Option<usize>,
    quiet: bool,
) -> Result<serde_json::Value> {
    let (bytes, meta) = jobs::read_state(path)?;
    let mut settings = meta.settings();
    if let Some(t) = threads {
        settings.run.threads = t;
    }
    let mut plan = meta.plan.clone();
    // Checkpoints go on into the file resumed from.
    plan.checkpoint = Some(jobs::absolute(path));
    let out = out.unwrap_or_else(|| meta.out.clone());
    execute(
        &meta.scene,
        settings,
        &out,
        plan,
        Some((path, bytes)),
        quiet,
    )
}

/// Adds states and writes the outputs of the whole.
fn merge(paths: &[PathBuf], out: Option<PathBuf>) -> Result<()> {
    let t0 = Instant::now();
    let (bytes, meta) = jobs::read_state(&paths[0])?;
    let settings = meta.settings();
    let out = out.unwrap_or_else(|| meta.out.clone());
    let (mut ctx, scene, cam) = output::load_with_camera(&meta.scene, &settings)?;
    ctx.load_state(&bytes)
        .map_err(|e| CliError(format!("{}: {}", paths[0].display(), e.message)))?;
    drop(bytes);
    for p in &paths[1..] {
        ctx.merge_state_file(p).map_err(|e| CliError(e.message))?;
    }
    output::create_out_dir(&out)?;
    let report = ctx.report();
    let wall = t0.elapsed().as_secs_f64();
    write_outputs(
        &mut ctx,
        &scene,
        &cam,
        &settings,
        &meta.scene,
        &out,
        &report,
        "Merged",
        wall,
    )?;
    Ok(())
}

/// Checks, loads (and resumes from `state`), runs in segments with checkpoints, and
/// writes the outputs (a shard: its state).
fn execute(
    obj: &Path,
    settings: Settings,
    out: &Path,
    plan: jobs::StatePlan,
    state: Option<(&Path, Vec<u8>)>,
    quiet: bool,
) -> Result<serde_json::Value> {
    let r = &settings.run;
    for (what, x) in [
        ("time (--time, [run] time_s)", r.time_s),
        (
            "target error (--target-error, [run] target_error)",
            r.target_error,
        ),
        (
            "grid error target (--until-grid-error, [run] grid_error)",
            r.grid_error,
        ),
    ] {
        if !(x.is_finite() && x >= 0.0) {
            fail!("{what} {x} must be a positive number of seconds or a positive error (0 = none)");
        }
    }
    if !(r.progress_interval_s.is_finite() && r.progress_interval_s > 0.0) {
        fail!(
            "[run] progress_interval_s = {} must be a positive number of seconds",
            r.progress_interval_s
        );
    }
    if r.grid_error > 0.0 && settings.grids.is_empty() {
        fail!("a grid error target (--until-grid-error or [run] grid_error) needs at least one [[grid]]");
    }
    let grid_measure = settings.grid_measure()?;
    if !(r.photons > 0 || r.time_s > 0.0 || r.target_error > 0.0 || r.grid_error > 0.0) {
        fail!("no stop criterion: give photons, time, target_error or grid_error (settings [run] or --photons/--time/--target-error/--until-grid-error)");
    }
    // Everything that can be checked is checked before tracing: a mistake found after an
    // hour's run would throw the hour away.
    let (mut ctx, scene, cam) = output::load_with_camera(obj, &settings)?;
    cam.validate()?;
    if let Some((path, bytes)) = state {
        ctx.load_state(&bytes)
            .map_err(|e| CliError(format!("{}: {}", path.display(), e.message)))?;
    }
    output::create_out_dir(out)?;
    let interrupted = Interrupts::get();

    let bar = progress_bar(quiet);
    let grid_target = r.grid_error;
    let target = if grid_target > 0.0 {
        0.0
    } else {
        r.target_error
    };
    let (time_s, photons) = (r.time_s, r.photons);
    let region = (grid_target > 0.0).then(|| imap::RegionTarget {
        meshes: scene.grids.iter().map(|g| g.id as usize).collect(),
        part: Some(grids::POINTS_PART),
        measure: grid_measure,
        target: grid_target,
    });
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
        if grid_target > 0.0 && p.region_rel_error < 1.0 {
            let t_target = p.elapsed_s * (p.region_rel_error / grid_target).powi(2);
            frac = frac.max(p.elapsed_s / t_target);
            eta = format!(
                ", grid error {:.2} %, ETA {:.0} s",
                100.0 * p.region_rel_error,
                (t_target - p.elapsed_s).max(0.0)
            );
        }
        if time_s > 0.0 {
            frac = frac.max(p.elapsed_s / time_s);
        }
        if photons > 0 {
            let share = plan.shard.map_or(1.0, |(_, n)| 1.0 / n as f64);
            frac = frac.max(p.photons as f64 / (photons as f64 * share));
        }
        bar.set_position((frac.min(1.0) * 1000.0) as u64);
        bar.set_message(format!(
            "{} photons, {:.2} M hits/s, error {:.2} %{eta}",
            p.photons,
            rate / 1e6,
            100.0 * p.rel_error
        ));
        !interrupted.raised()
    };
    let meta = jobs::StateMeta::new(obj, &settings, out, &plan).bytes();
    let selection = match plan.shard {
        Some((k, n)) => imap::Selection {
            end: if photons > 0 { photons } else { u64::MAX },
            ..imap::Selection::shard(k, n)
        },
        None => imap::Selection::ALL,
    };
    let t0 = Instant::now();
    // In segments of plan.every_s seconds, the state saved after each: a kill loses at
    // most one segment.
    let report = loop {
        let done = ctx.report();
        let left_photons = match (plan.shard, photons) {
            (None, p) if p > 0 => p.saturating_sub(done.photons),
            _ => 0,
        };
        if plan.shard.is_none() && photons > 0 && left_photons == 0 {
            break done; // a state that is complete already
        }
        let left_time = if time_s > 0.0 {
            time_s - done.elapsed_s
        } else {
            f64::INFINITY
        };
        if left_time <= 0.0 {
            break done;
        }
        let segment = left_time.min(plan.every_s.unwrap_or(f64::INFINITY));
        let r = ctx.run(&mut imap::RunParams {
            region: region.clone(),
            photons: left_photons,
            time_budget_s: if segment.is_finite() { segment } else { 0.0 },
            target_rel_error: target,
            progress_interval_s: r.progress_interval_s,
            max_path_events: 1 << 20,
            progress: Some(&mut callback),
            selection,
            estimator: Some(estimator(&r.estimator)?),
        })?;
        if let Some(path) = &plan.checkpoint {
            ctx.save_state(path, &meta)
                .map_err(|e| CliError(e.message))?;
        }
        let time_left = time_s == 0.0 || r.elapsed_s < time_s;
        if r.stop == Some(imap::StopReason::TimeBudget) && time_left && !interrupted.raised() {
            continue;
        }
        break r;
    };
    let wall = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let was_interrupted = interrupted.raised();
    if let Some((k, n)) = plan.shard {
        println!(
            "shard {k}/{n}: {} photons in {:.1} s{}; state written to {}",
            report.photons,
            report.elapsed_s,
            if was_interrupted {
                " (interrupted)"
            } else {
                ""
            },
            plan.checkpoint
                .as_ref()
                .expect("shards keep a state")
                .display()
        );
        if let Some(code) = interrupted.status() {
            std::process::exit(code);
        }
        return Ok(serde_json::json!({"photons": report.photons}));
    }
    let stop = if was_interrupted {
        "Interrupted".to_string()
    } else {
        format!("{:?}", report.stop.unwrap_or(imap::StopReason::PhotonCount))
    };
    let json = write_outputs(
        &mut ctx, &scene, &cam, &settings, obj, out, &report, &stop, wall,
    )?;
    if let Some(code) = interrupted.status() {
        eprintln!(
            "imap: interrupted: the outputs hold the {} photons traced until then",
            report.photons
        );
        std::process::exit(code);
    }
    Ok(json)
}

/// Writes every output of the map the context holds to `out` (all or nothing), prints
/// the summary, and returns the report's JSON.
#[allow(clippy::too_many_arguments)]
fn write_outputs(
    ctx: &mut imap::Context,
    scene: &scene::LoadedScene,
    cam: &CameraSettings,
    settings: &Settings,
    obj: &Path,
    out: &Path,
    report: &imap::Report,
    stop: &str,
    wall: f64,
) -> Result<serde_json::Value> {
    let maps = output::read_maps(ctx, scene)?;
    let mut warnings = scene.warnings.clone();
    for w in output::back_lit(ctx, scene, &maps, report.emitted_w) {
        eprintln!("imap: warning: {}", diag::printable(&w));
        warnings.push(w);
    }
    // Without a [camera], the view that shows the most lit, recorded surface.
    let chosen;
    let cam = match &settings.camera {
        Some(_) => cam,
        None => {
            chosen = output::choose_camera(scene, &maps, settings.up()?)?.0;
            &chosen
        }
    };
    let img = output::render_view(scene, &maps, cam)?;
    let history: Vec<serde_json::Value> = ctx
        .history()
        .iter()
        .map(|p| {
            serde_json::json!({
                "elapsed_s": p.elapsed_s, "photons": p.photons, "hits": p.hits,
                "rel_error": p.rel_error, "grid_rel_error": p.region_rel_error
            })
        })
        .collect();
    let c = report.counters;
    let photometry = output::photometric_summary(&maps);
    let unit_m = settings.unit_m.unwrap_or(1.0);
    let grid_results = scene
        .grids
        .iter()
        .map(|g| grids::read(ctx, g))
        .collect::<Result<Vec<_>>>()?;
    // A stop on the grids' Eavg leaves their Emin and U0 at whatever error they had then.
    let on_average =
        stop == "RegionTarget" && matches!(settings.grid_measure()?, imap::RegionMeasure::Average);
    let notes: Vec<Option<String>> = grid_results
        .iter()
        .map(|r| on_average.then(|| grids::average_stop_note(r)).flatten())
        .collect();
    let grid_json: Vec<serde_json::Value> = scene
        .grids
        .iter()
        .zip(&grid_results)
        .zip(&notes)
        .map(|((g, r), note)| {
            let mut j = grids::summary_json(g, r, unit_m);
            if let Some(n) = note {
                j["note"] = serde_json::json!(n);
            }
            j
        })
        .collect();
    let observer_results = observers::read(ctx, &scene.observers)?;
    // A glare source's name: the light's or the mesh's as the scene names them.
    let source_name = |kind: imap::glare::SourceKind| match kind {
        imap::glare::SourceKind::Light(i) => scene
            .lights
            .get(i as usize)
            .map_or_else(|| format!("light {i}"), |l| l.name.clone()),
        imap::glare::SourceKind::Mesh(i) => scene
            .meshes
            .iter()
            .find(|m| m.mesh == i)
            .map_or_else(|| format!("mesh {i}"), |m| m.name.clone()),
    };
    let observer_json: Vec<serde_json::Value> = scene
        .observers
        .iter()
        .zip(&observer_results)
        .map(|(e, r)| observers::json(&source_name, e, r))
        .collect();
    let mut outputs: Vec<String> = [
        "irradiance.csv",
        "irradiance.ply",
        "report.json",
        "convergence.png",
        "view.png",
    ]
    .map(String::from)
    .to_vec();
    for g in &scene.grids {
        outputs.push(format!("grid_{}.csv", g.name));
        outputs.push(format!("grid_{}.png", g.name));
    }
    if !scene.observers.is_empty() {
        outputs.push("observers.csv".into());
    }
    let json = serde_json::json!({
        "scene": obj.display().to_string(),
        "model": {
            "format": scene.format, "triangles_read": scene.triangles_read,
            "material_variants": scene.material_variants
        },
        "settings": settings,
        "bands_nm": scene.band_nm,
        "meshes": scene.meshes.iter().zip(&photometry.meshes).map(|(m, lux)| {
            let mut j = serde_json::json!({
                "name": m.name, "vertices": m.positions.len() / 3,
                "triangles": m.indices.len() / 3, "recorded": m.id.is_some(),
                "emitting": m.emission.is_some(),
                "illuminance_lx": lux
            });
            // A mesh whose material holds a medium: what the medium absorbed.
            if let Ok(a) = ctx.medium_absorbed(m.mesh) {
                j["medium_absorbed"] = serde_json::json!({
                    "w_per_band": a.band_w.iter().map(|e| e.value).collect::<Vec<_>>(),
                    "w_per_band_sigma": a.band_w.iter().map(|e| e.sigma).collect::<Vec<_>>(),
                    "lm": a.lm.value, "lm_sigma": a.lm.sigma
                });
            }
            j
        }).collect::<Vec<_>>(),
        "lights": scene.lights,
        // The scene's medium ([medium]): what it absorbed.
        "scene_medium_absorbed": ctx.medium_absorbed(imap::SCENE_MEDIUM).ok().map(|a| serde_json::json!({
            "w_per_band": a.band_w.iter().map(|e| e.value).collect::<Vec<_>>(),
            "w_per_band_sigma": a.band_w.iter().map(|e| e.sigma).collect::<Vec<_>>(),
            "lm": a.lm.value, "lm_sigma": a.lm.sigma
        })),
        "units": {
            "energy_w": "W, radiant, summed over the bands",
            "energy_w_per_band": "W in each band (bands_nm)",
            "medium_absorbed": "what the medium inside a mesh absorbed (its surfaces' share left out): W per band and lm, each with its standard error (_sigma); scene_medium_absorbed: the same for [medium]",
            "luminous_lm": "lm",
            "illuminance_lx": "lx, area-weighted over the recorded vertices (front side)",
            "csv": "E_* in W/m2 per band, rel_error dimensionless, lux in lx"
        },
        "warnings": warnings,
        "interrupted": stop == "Interrupted",
        "stop": stop,
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
            "dropped_photons": report.dropped_photons, "fluoresced": report.fluoresced_w
        },
        "energy_w_per_band": {
            "emitted": report.band_w[0], "absorbed": report.band_w[1],
            "escaped": report.band_w[2], "dropped": report.band_w[3],
            "fluoresced": report.band_w[4]
        },
        "luminous_lm": {
            "emitted": report.emitted_lm, "absorbed": report.absorbed_lm,
            "escaped": report.escaped_lm, "dropped": report.dropped_lm,
            "fluoresced": report.fluoresced_lm
        },
        "light_on_recorded_surfaces": photometry.colour,
        "counters": {
            "calc_wait_s": c.calc_wait_s, "accum_busy_fraction": c.accum_busy_fraction,
            "peak_queue": c.peak_queue, "portions": c.portions,
            "inline_portions": c.inline_portions, "splits": c.splits, "groups": c.groups
        },
        "map_bytes": report.map_bytes,
        "history": history,
        "grids": grid_json,
        "observers": observer_json,
        "view_camera": cam,
        "outputs": outputs,
    });
    // Every output is written to a temporary file first and renamed into place once all
    // are complete: an interrupted write never leaves a truncated file, and the outputs
    // of one run are never mixed with an older run's.
    let mut files = output::Outputs::new(out, "report.json")?;
    output::write_csv(&files.temp("irradiance.csv")?, scene, &maps)?;
    output::write_ply(&files.temp("irradiance.ply")?, scene, &maps)?;
    output::plot_convergence(&files.temp("convergence.png")?, ctx.history())?;
    output::write_png(&files.temp("view.png")?, cam.width, cam.height, &img)?;
    for (g, r) in scene.grids.iter().zip(&grid_results) {
        grids::write_csv(&files.temp(&format!("grid_{}.csv", g.name))?, g, r)?;
        grids::write_picture(&files.temp(&format!("grid_{}.png", g.name))?, g, r)?;
    }
    if !scene.observers.is_empty() {
        observers::write_csv(
            &files.temp("observers.csv")?,
            &scene.observers,
            &observer_results,
        )?;
    }
    let path = files.temp("report.json")?;
    std::fs::write(&path, serde_json::to_string_pretty(&json).unwrap())
        .map_err(|e| CliError(format!("{}: {e}", path.display())))?;
    files.commit()?;
    println!(
        "{} photons in {:.1} s ({stop}), estimated error {:.2} %; wrote {}/{{{}}}",
        report.photons,
        report.elapsed_s,
        100.0 * report.rel_error,
        out.display(),
        outputs.join(", ")
    );
    for ((g, r), note) in scene.grids.iter().zip(&grid_results).zip(&notes) {
        println!("{}", grids::summary_line(g, r));
        if let Some(n) = note {
            println!("  {n}");
        }
    }
    for (e, r) in scene.observers.iter().zip(&observer_results) {
        println!("{}", observers::summary(e, r));
    }
    Ok(json)
}

fn info(path: &Path) -> Result<()> {
    let mut d = diag::Diagnostics::default();
    let m = readers::load(path, &mut d).map_err(CliError)?;
    for (name, v) in m.inward() {
        d.warn(scene::inward_warning(path, &name, v));
    }
    // The warnings `run` gives with no settings: the defaults' units and up axis, and the
    // materials as the default (RGB) bands read them.
    for w in scene::guess_warnings(&m, None, None) {
        d.warn(w);
    }
    for w in scene::coarse_warnings(&m, &|_| true, 1.0) {
        d.warn(w);
    }
    let bands = imap::Bands::rgb();
    let at = (std::path::PathBuf::from("settings"), 0);
    let efficacy = imap::photometry::BandPhotometry::new(&bands).efficacy;
    let units = materials::Units {
        efficacy: &efficacy,
        unit_m: 1.0,
    };
    for x in &m.materials {
        materials::resolve(
            x,
            None,
            &at,
            &bands.wavelengths_nm,
            bands.rgb,
            &units,
            &mut d,
        );
    }
    let guesses = m.guesses();
    let (lo, hi) = m.bounds();
    let json = serde_json::json!({
        "scene": path.display().to_string(),
        "format": m.format,
        "vertices": m.positions.len(),
        "triangles": m.triangles(),
        "degenerate_triangles_left_out": m.degenerate,
        "vertex_colours": m.colours.is_some(),
        "objects": m.objects.iter().enumerate().map(|(i, o)| {
            let (closed, volume) = m.orientation(i);
            serde_json::json!({
                "name": o.name, "triangles": o.triangles.len(), "closed": closed,
                "normals": if !closed { "open surface" } else if volume < 0.0 { "inward" } else { "outward" },
            })
        }).collect::<Vec<_>>(),
        "materials": m.materials.iter().map(|x| serde_json::json!({
            "name": x.name, "kd": x.kd, "ks": x.ks, "ke": x.ke, "ni": x.ni, "d": x.d,
            "texture": x.texture.as_ref().map(|t| t.name.clone()),
            "texture_average": x.texture.as_ref().map(|t| t.average),
            "emission_texture": x.emission_texture.as_ref().map(|t| t.name.clone()),
        })).collect::<Vec<_>>(),
        "bounds": if m.triangles() > 0 { serde_json::json!([lo, hi]) } else { serde_json::Value::Null },
        "units_guess": guesses.unit.map_or("metres", |u| u.0),
        "up_axis_guess": guesses.up_name().map(|axis| serde_json::json!({
            "axis": axis, "because": guesses.up.as_ref().map(|u| u.1.clone()),
        })),
        "warnings": d.warnings,
        "errors": d.errors,
    });
    println!("{}", serde_json::to_string_pretty(&json).unwrap());
    if d.has_errors() {
        return Err(CliError::from_diagnostics(&d));
    }
    Ok(())
}

fn demo(opts: &RunOptions) -> Result<()> {
    output::create_out_dir(&opts.out)?;
    let (obj, mtl) = cornell::cornell_box("cornell_box.mtl");
    let obj_path = opts.out.join("cornell_box.obj");
    for (p, text) in [(&obj_path, &obj), (&opts.out.join("cornell_box.mtl"), &mtl)] {
        std::fs::write(p, text).map_err(|e| CliError(format!("{}: {e}", p.display())))?;
    }
    let settings = Settings {
        unit_m: Some(0.001),
        run: settings::RunSettings {
            target_error: 0.01,
            time_s: 50.0,
            ..Default::default()
        },
        camera: Some(CameraSettings {
            position: [278.0, 273.0, -800.0],
            look_at: [278.0, 273.0, 0.0],
            up: Some([0.0, 1.0, 0.0]),
            fov_deg: 39.3,
            width: 512,
            height: 512,
            projection: None,
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

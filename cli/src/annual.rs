//! `imap annual MODEL --config S.toml --weather SITE.epw`: daylight coefficients at the
//! grids' points from one run (each Tregenza patch, and the ground, a sky of its own in
//! its own light group), a year of Perez sky vectors from the weather file, and the
//! climate-based metrics with their confidence (library `imap::annual`).

use crate::diag::printable;
use crate::error::{fail, CliError, Result};
use crate::grids::{self, Grid};
use crate::settings::Settings;
use imap::annual::lighting::{Control, Dimming};
use imap::annual::trace::{PatchReport, PatchRound, PatchRun, PatchTarget};
use imap::annual::{
    AnnualSky, Coefficients, DirectSun, MetricOptions, Shaded, Shading, ShadingRule, SunInVectors,
    WindowGroup,
};
use imap::SkyDesc;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The command's options.
#[derive(clap::Args, Clone, Debug)]
pub struct AnnualOptions {
    /// The weather file: EnergyPlus .epw, or Radiance .wea by its extension.
    #[arg(long)]
    pub weather: PathBuf,
    /// Output folder.
    #[arg(long, short, default_value = "imap-annual")]
    pub out: PathBuf,
    /// Photons to trace for the coefficients.
    #[arg(long)]
    pub photons: Option<u64>,
    /// Seconds to trace for the coefficients.
    #[arg(long)]
    pub time: Option<f64>,
    /// Calculating threads (0 = one per core).
    #[arg(long)]
    pub threads: Option<usize>,
    /// The run's seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// The ground's reflectance under the sky (its glow is ρ E_h / π).
    #[arg(long, default_value_t = 0.2)]
    pub ground_reflectance: f64,
    /// DA's and sDA's threshold, lx.
    #[arg(long, default_value_t = 300.0)]
    pub threshold: f64,
    /// Occupied hours of local standard time, "FROM-TO" (8-18: 8:00 to 18:00 every day,
    /// LM-83's; an hour is in when the middle of its time step is).
    #[arg(long, default_value = "8-18")]
    pub occupied: String,
    /// The estimator: gathering (default) reaches the small grid points' coefficient of
    /// every patch; with photons or light sampling alone a patch no photon brought to a
    /// point states no error.
    #[arg(long, default_value = "gather")]
    pub estimator: String,
    /// ASE's direct-sun illuminance, lx (IES LM-83: 1000).
    #[arg(long, default_value_t = 1000.0)]
    pub ase_lx: f64,
    /// ASE's hours: a point counts when its direct sun exceeds --ase-lx in more occupied
    /// hours than these (IES LM-83: 250).
    #[arg(long, default_value_t = 250)]
    pub ase_hours: usize,
    /// Stop when every grid's sDA is known to ± this (the half-width of its 95 % interval:
    /// 0.01 is one percentage point): after the first --photons (100 000 if not given),
    /// as many again each round until it is, or --time (needed) runs out.
    #[arg(long)]
    pub target_sda: Option<f64>,
    /// Stop when, on every grid, each EN 17037 level's two shares of daylight hours (at
    /// its target and at its minimum illuminance) are known to ± this (the half-width of
    /// their 95 % intervals); with --target-sda, when both are. Rounds as --target-sda's.
    #[arg(long)]
    pub target_en17037: Option<f64>,
    /// Stop when, on every grid, UDI's three bands (the grid's mean shares below, within
    /// and above the useful range) are known to ± this (the half-width of their 95 %
    /// intervals); with the other targets, when all are. Rounds as --target-sda's.
    #[arg(long)]
    pub target_udi: Option<f64>,
    /// The model with its blinds closed: TOML settings for the same model (a blind's
    /// material, or grids and materials as the open settings with the glazing a diffuse
    /// transmitter). Its coefficients are traced as the open model's, and IES LM-83's rule
    /// picks it in the hours in which more than 2 % of a grid's points get direct sun
    /// above --ase-lx.
    #[arg(long)]
    pub shaded: Option<PathBuf>,
    /// The sky's patches: Reinhart MF:N (1: Tregenza's 145, 2: 577, 4: 2305, each with the
    /// ground). Finer patches smear the sky's bright parts less (docs/daylight.md) and
    /// cost more photons for the same error per patch.
    #[arg(long, default_value_t = 1)]
    pub mf: u32,
    /// Electric light with daylight: the illuminance, lx, the zone's dimming control keeps
    /// at its photosensor. The settings' lights and luminaires (and the model's emitters)
    /// are the zone's, traced in a run of their own at full output; each grid is a zone,
    /// and its annual lighting energy is written with its confidence.
    #[arg(long)]
    pub lighting_target: Option<f64>,
    /// The zone's installed lighting power at full output, W (needed with
    /// --lighting-target).
    #[arg(long)]
    pub lighting_power: Option<f64>,
    /// The photosensor: the index of the grid point whose daylight the control reads
    /// (default: the point with the lowest daylight factor).
    #[arg(long)]
    pub lighting_sensor: Option<usize>,
    /// The control (EnergyPlus's types): "continuous" (dims to --lighting-min-output and
    /// stays on), "continuous-off" (and switches off there) or "stepped:N" (N equal steps
    /// and off).
    #[arg(long, default_value = "continuous")]
    pub lighting_control: String,
    /// The lowest light output fraction the continuous controls dim to (EnergyPlus: 0.2).
    #[arg(long, default_value_t = 0.2)]
    pub lighting_min_output: f64,
    /// The power fraction drawn at the lowest output (EnergyPlus: 0.3).
    #[arg(long, default_value_t = 0.3)]
    pub lighting_min_power: f64,
    /// Draws of the coefficients for the metrics' confidence.
    #[arg(long, default_value_t = 100)]
    pub draws: usize,
    /// No progress output.
    #[arg(long)]
    pub quiet: bool,
}

/// Settings an annual run takes: grids, and lights only for `--lighting-target`.
fn check_settings(settings: &Settings, what: &str, lighting: bool) -> Result<()> {
    if settings.sky.is_some() || settings.sun.is_some() || settings.environment.is_some() {
        fail!("{what}: the settings hold a [sky], [sun] or [environment]: an annual run makes its own skies from the weather file; leave them out");
    }
    if !lighting && (!settings.lights.is_empty() || !settings.luminaires.is_empty()) {
        fail!("{what}: the settings hold lights or luminaires: they are traced only as electric light with daylight (give --lighting-target and --lighting-power); leave them out otherwise");
    }
    if settings.grids.is_empty() {
        fail!("{what}: the metrics are computed at the points of [[grid]]s: give at least one");
    }
    Ok(())
}

/// `--lighting-*`: the control's kind and fractions (the photosensor is per grid), or
/// None without `--lighting-target`.
fn lighting_control(o: &AnnualOptions) -> Result<Option<Dimming>> {
    let Some(target) = o.lighting_target else {
        if o.lighting_power.is_some() || o.lighting_sensor.is_some() {
            fail!("--lighting-power and --lighting-sensor need --lighting-target");
        }
        return Ok(None);
    };
    if !(target.is_finite() && target > 0.0) {
        fail!("--lighting-target {target} must be a positive illuminance (lx)");
    }
    let Some(power) = o.lighting_power else {
        fail!("--lighting-target needs --lighting-power: the zone's installed lighting power, W");
    };
    if !(power.is_finite() && power >= 0.0) {
        fail!("--lighting-power {power} must be a power, W, ≥ 0");
    }
    let control = match o.lighting_control.as_str() {
        "continuous" => Control::Continuous,
        "continuous-off" => Control::ContinuousOff,
        s => match s.strip_prefix("stepped:").map(str::parse::<u32>) {
            Some(Ok(n)) if (1..=1000).contains(&n) => Control::Stepped(n),
            _ => fail!(
                "--lighting-control \"{}\": use \"continuous\", \"continuous-off\" or \"stepped:N\" (N from 1 to 1000)",
                printable(s)
            ),
        },
    };
    if !(0.0..1.0).contains(&o.lighting_min_output) {
        fail!(
            "--lighting-min-output {} must be in [0, 1)",
            o.lighting_min_output
        );
    }
    if !(0.0..=1.0).contains(&o.lighting_min_power) {
        fail!(
            "--lighting-min-power {} must be in [0, 1]",
            o.lighting_min_power
        );
    }
    Ok(Some(Dimming {
        target_lx: target,
        sensor: 0,
        control,
        min_output: o.lighting_min_output,
        min_power: o.lighting_min_power,
        power_w: power,
    }))
}

/// "FROM-TO" hours.
fn occupied_hours(s: &str) -> Result<(f64, f64)> {
    let bad = || {
        CliError(format!(
            "--occupied \"{}\": write it as FROM-TO in hours of local standard time, e.g. 8-18",
            printable(s)
        ))
    };
    let (a, b) = s.split_once('-').ok_or_else(bad)?;
    let (a, b): (f64, f64) = (
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    );
    if !((0.0..24.0).contains(&a) && a < b && b <= 24.0) {
        return Err(bad());
    }
    Ok((a, b))
}

pub fn annual(model: &Path, settings: Settings, o: &AnnualOptions) -> Result<()> {
    let lighting = lighting_control(o)?;
    check_settings(&settings, "annual", lighting.is_some())?;
    let (from, to) = occupied_hours(&o.occupied)?;
    if !(0.0..=1.0).contains(&o.ground_reflectance) {
        fail!(
            "--ground-reflectance {} must be in [0, 1]",
            o.ground_reflectance
        );
    }
    if !(o.threshold.is_finite() && o.threshold > 0.0) {
        fail!(
            "--threshold {} must be a positive illuminance (lx)",
            o.threshold
        );
    }
    if !(o.ase_lx.is_finite() && o.ase_lx > 0.0) {
        fail!("--ase-lx {} must be a positive illuminance (lx)", o.ase_lx);
    }
    let (photons, time) = (o.photons.unwrap_or(0), o.time.unwrap_or(0.0));
    if photons == 0 && (time.is_nan() || time <= 0.0) {
        fail!("annual: give --photons or --time for the coefficients' run");
    }
    for (flag, target, what) in [
        ("--target-sda", o.target_sda, "sDA's 95 % interval"),
        (
            "--target-en17037",
            o.target_en17037,
            "EN 17037's time shares' 95 % intervals",
        ),
        ("--target-udi", o.target_udi, "UDI's 95 % intervals"),
    ] {
        let Some(t) = target else { continue };
        if !(t > 0.0 && t < 1.0) {
            fail!("{flag} {t}: give the half-width of {what}, between 0 and 1 (0.01: one percentage point)");
        }
        if time.is_nan() || time <= 0.0 {
            fail!("{flag} needs --time: the longest the rounds may take");
        }
        if o.draws < 20 {
            fail!("{flag} reads {what} from the draws: give --draws 20 or more");
        }
    }
    let targeted = o.target_sda.is_some() || o.target_en17037.is_some() || o.target_udi.is_some();
    // The weather first: a bad file costs no run.
    let weather = imap::weather::read(&o.weather).map_err(|e| CliError(printable(&e.message)))?;
    let sky = AnnualSky::from_weather(&weather, o.mf, SunInVectors::Left, o.ground_reflectance)
        .map_err(|e| {
            CliError(format!(
                "{}: {}",
                o.weather.display(),
                printable(&e.message)
            ))
        })?;
    let groups = window_groups(&settings, weather.hours.len())?;
    if !groups.is_empty() && o.shaded.is_some() {
        fail!("--shaded and [[window_group]]s: give one (a blinds-closed model is a window group of two states: states = [\"as-drawn\", \"BLINDS\"])");
    }
    let missing = weather
        .hours
        .iter()
        .filter(|h| h.direct_normal_w.is_none() || h.diffuse_horizontal_w.is_none())
        .count();

    let mut settings = settings;
    if let Some(t) = o.threads {
        settings.run.threads = t;
    }
    if let Some(s) = o.seed {
        settings.run.seed = s;
    }
    let n = sky.patches.count();
    let up = settings.up()?;
    // The blinds-closed settings are checked before anything is traced.
    let shaded_settings = match &o.shaded {
        Some(path) => {
            let mut s = crate::settings_from(Some(path))?;
            check_settings(&s, &format!("--shaded {}", path.display()), false)?;
            s.run.threads = settings.run.threads;
            s.run.seed = settings.run.seed;
            if s.up()? != up {
                fail!(
                    "--shaded {}: its up_axis differs from the open model's",
                    path.display()
                );
            }
            if !s.observers.is_empty() {
                fail!(
                    "--shaded {}: it holds [[observer]]s: the observers are the open model's (give them in its settings)",
                    path.display()
                );
            }
            s.observers = settings.observers.clone();
            Some(s)
        }
        None => None,
    };
    let north = if up[1] != 0.0 {
        [0.0, 0.0, -1.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    if !o.quiet {
        eprintln!(
            "imap: annual: {} hours of {} ({missing} missing), {} patches and the ground",
            weather.hours.len(),
            printable(&weather.site.name),
            n - 1,
        );
    }
    let interrupted = crate::Interrupts::get();
    let clock = std::time::Instant::now();
    let first = if targeted {
        AnnualOptions {
            photons: Some(o.photons.unwrap_or(100_000)),
            ..o.clone()
        }
    } else {
        o.clone()
    };
    // The coefficients see the model without the settings' lights: the zone's electric
    // light is traced on its own, at full output.
    let daylit = Settings {
        lights: Vec::new(),
        luminaires: Vec::new(),
        ..settings.clone()
    };
    // With window groups, the first run has every group's openings black: what reaches the
    // grids then came through openings in no group, which each group's runs would count
    // again (checked per grid below).
    let open = if groups.is_empty() {
        coefficients_run(model, &daylit, (up, north), &first, "blinds open")?
    } else {
        // (A check, not a part of the light: photons alone, which die at the black
        // openings of a model whose every opening is in a group, cost little.)
        let s = group_settings(&daylit, &groups, None, 0);
        let check = AnnualOptions {
            estimator: "photons".into(),
            ..o.clone()
        };
        coefficients_run(model, &s, (up, north), &check, "every window group black")?
    };
    let mut group_runs = Vec::with_capacity(groups.len());
    for (g, w) in groups.iter().enumerate() {
        let mut states = Vec::with_capacity(w.states.len());
        for (k, state) in w.states.iter().enumerate() {
            if interrupted.raised() {
                break;
            }
            let s = group_settings(&daylit, &groups, Some(g), k);
            let what = format!(
                "window group {} {}",
                printable(&w.name),
                state.as_deref().unwrap_or("as-drawn")
            );
            states.push(coefficients_run(model, &s, (up, north), &first, &what)?);
        }
        group_runs.push(states);
    }
    let shaded = match shaded_settings {
        Some(s) if !interrupted.raised() => Some(coefficients_run(
            model,
            &s,
            (up, north),
            &first,
            "blinds closed",
        )?),
        _ => None,
    };
    let electric = match &lighting {
        // (With --target-sda and friends: the first round's photons.)
        Some(_) if !interrupted.raised() => Some(electric_run(model, &settings, &first)?),
        _ => None,
    };
    let (mut ctx, scene, mut run) = open;
    // An interrupt before every batch of patches had photons leaves patches unknown.
    let incomplete = run.coefficients(0).is_err()
        || shaded
            .as_ref()
            .is_some_and(|(_, _, r)| r.coefficients(0).is_err())
        || group_runs.iter().zip(&groups).any(|(r, w)| {
            r.len() < w.states.len() || r.iter().any(|(_, _, r)| r.coefficients(0).is_err())
        });
    if let (Some(code), true) = (interrupted.status(), incomplete) {
        eprintln!("imap: interrupted before every batch of patches had photons: no metrics");
        std::process::exit(code);
    }
    let mut shaded = shaded;
    // The photons of the runs that make the light (with window groups, the first state's;
    // the black check is not one of them).
    let mut report = match group_runs.first().and_then(|r| r.first()) {
        Some((_, _, r)) => r.report(),
        None => run.report(),
    };

    crate::output::create_out_dir(&o.out)?;
    // LM-83's occupied hours are every day's 8:00–18:00, dark or not; an hour whose
    // radiation the file marks missing is left out (and counted in annual.json).
    let occupied: Vec<bool> = sky
        .hours
        .iter()
        .zip(&weather.hours)
        .map(|(h, w)| {
            h.hour >= from
                && h.hour < to
                && w.direct_normal_w.is_some()
                && w.diffuse_horizontal_w.is_some()
        })
        .collect();
    let options = MetricOptions {
        occupied,
        threshold_lx: o.threshold,
        ase_lx: o.ase_lx,
        ase_hours: o.ase_hours,
        draws: o.draws,
        seed: settings.run.seed,
        ..MetricOptions::default()
    };
    // Each grid's direct sun through every model state: the lines do not change with the
    // photons.
    let mut suns = Vec::with_capacity(scene.grids.len());
    let mut shaded_suns = Vec::with_capacity(scene.grids.len());
    let mut group_suns = Vec::with_capacity(scene.grids.len());
    for g in &scene.grids {
        let (points, normals) = grids::point_frames(g);
        let direct_sun = |sctx: &mut imap::Context| {
            DirectSun::new(
                sctx,
                &sky,
                (up, north),
                (&points, &normals),
                &SkyDesc::default().spectrum,
                settings.run.seed,
            )
            .map_err(|e| CliError(format!("annual: grid {}: {}", g.name, e.message)))
        };
        suns.push(direct_sun(&mut ctx)?);
        // The blinds-closed model's grid of the same name and points.
        if let Some((sctx, sscene, _)) = &mut shaded {
            let Some(si) = sscene.grids.iter().position(|x| x.name == g.name) else {
                fail!("--shaded: its settings have no grid '{}'", g.name);
            };
            if sscene.grids[si].positions != g.positions {
                fail!(
                    "--shaded: grid '{}' has other points than the open model's",
                    g.name
                );
            }
            shaded_suns.push((si, direct_sun(sctx)?));
        }
        group_suns.push(each_state(&mut group_runs, direct_sun)?);
    }
    // Each observer's direct sun at the eye through every model state, as a grid's.
    let mut observers = Vec::with_capacity(settings.observers.len());
    for (i, (name, ob)) in observer_names(&settings)
        .into_iter()
        .zip(&settings.observers)
        .enumerate()
    {
        let (eye, view) = ([ob.eye], [ob.view]);
        let direct_sun = |sctx: &mut imap::Context| {
            DirectSun::new(
                sctx,
                &sky,
                (up, north),
                (&eye[..], &view[..]),
                &SkyDesc::default().spectrum,
                settings.run.seed,
            )
            .map_err(|e| CliError(format!("annual: observer {name}: {}", e.message)))
        };
        let sun = direct_sun(&mut ctx)?;
        let shaded_sun = match &mut shaded {
            Some((sctx, sscene, _)) => Some((sscene.grids.len() + i, direct_sun(sctx)?)),
            None => None,
        };
        let group_sun = each_state(&mut group_runs, direct_sun)?;
        observers.push(ObserverAt {
            what: format!("observer {name}"),
            name,
            eye: ob.eye,
            view: ob.view,
            target: scene.grids.len() + i,
            sun,
            shaded_sun,
            group_suns: group_sun,
        });
    }
    // With window groups, an opening in no group is refused before any round.
    if !groups.is_empty() {
        for (gi, g) in scene.grids.iter().enumerate() {
            let shading = grid_light(
                (gi, &grid_name(g)),
                (&run, &suns[gi]),
                None,
                (&groups, &group_runs, &group_suns[gi]),
            )?;
            if let Some(all_open) = &all_open(&shading, g)? {
                check_black(
                    g,
                    (coefficients(&run, gi, &grid_name(g))?, &suns[gi]),
                    (all_open, &group_suns[gi]),
                    (&sky.patches, o.ground_reflectance),
                )?;
            }
        }
    }
    // --target-sda, --target-en17037: as many photons again each round until every
    // grid's metrics are known.
    let mut rounds = 1;
    let mut reached = None;
    // The seconds from the first trace to the last round's check.
    let mut seconds = 0.0;
    if targeted {
        loop {
            // The widest half-interval of each targeted metric over the grids.
            let (mut sda, mut en, mut udi): (f64, f64, f64) = (0.0, 0.0, 0.0);
            let ruled = decide_glare(&groups, &observers, (&run, &group_runs), &sky, &options)?;
            for (gi, g) in scene.grids.iter().enumerate() {
                let closed = shaded
                    .as_ref()
                    .map(|(_, _, r)| (r, shaded_suns[gi].0, &shaded_suns[gi].1));
                let shading = grid_light(
                    (gi, &grid_name(g)),
                    (&run, &suns[gi]),
                    closed,
                    (&ruled, &group_runs, &group_suns[gi]),
                )?;
                let m = imap::annual::metrics_with_shading(&shading, &sky, &options)
                    .map_err(|e| CliError(format!("annual: grid {}: {}", g.name, e.message)))?;
                sda = sda.max(0.5 * (m.sda_interval.1 - m.sda_interval.0));
                for (lo, hi) in m.udi_interval {
                    udi = udi.max(0.5 * (hi - lo));
                }
                for l in m.en17037.iter().flat_map(|e| &e.levels) {
                    en = en
                        .max(0.5 * (l.target_interval.1 - l.target_interval.0))
                        .max(0.5 * (l.minimum_interval.1 - l.minimum_interval.0));
                }
            }
            let mut done = true;
            let mut said = Vec::new();
            for (name, worst, target) in [
                ("sDA", sda, o.target_sda),
                ("EN 17037's shares", en, o.target_en17037),
                ("UDI", udi, o.target_udi),
            ] {
                let Some(target) = target else { continue };
                done &= worst <= target;
                said.push(format!(
                    "{name} known to ± {:.2} % (target ± {:.2} %)",
                    100.0 * worst,
                    100.0 * target
                ));
            }
            if !o.quiet {
                eprintln!(
                    "imap: annual: round {rounds}: {} photons, {}",
                    report.photons,
                    said.join(", ")
                );
            }
            reached = Some(done);
            seconds = clock.elapsed().as_secs_f64();
            let left = time - seconds;
            if done || interrupted.raised() || left <= 0.0 {
                break;
            }
            // As many photons again in every run that makes the light, the time shared.
            let runs = usize::from(groups.is_empty())
                + usize::from(shaded.is_some())
                + group_runs.iter().map(Vec::len).sum::<usize>();
            let share = left / runs.max(1) as f64;
            if groups.is_empty() {
                report = trace(&mut ctx, &mut run, report.photons, share, o, "blinds open")?;
            }
            if let Some((sctx, _, srun)) = &mut shaded {
                let more = srun.report().photons;
                trace(sctx, srun, more, share, o, "blinds closed")?;
            }
            for (g, (w, states)) in groups.iter().zip(&mut group_runs).enumerate() {
                for (k, (sctx, _, srun)) in states.iter_mut().enumerate() {
                    let what = format!(
                        "window group {} {}",
                        printable(&w.name),
                        w.states[k].as_deref().unwrap_or("as-drawn")
                    );
                    let more = srun.report().photons;
                    let r = trace(sctx, srun, more, share, o, &what)?;
                    if (g, k) == (0, 0) {
                        report = r;
                    }
                }
            }
            rounds += 1;
        }
    }
    let ruled = decide_glare(&groups, &observers, (&run, &group_runs), &sky, &options)?;
    // The observers read every group in the states the first grid's rules pick (a glare
    // rule's: its observers' verdict).
    let mut first_states = None;
    let mut grids_json = Vec::new();
    for (gi, g) in scene.grids.iter().enumerate() {
        let (c, sun) = (coefficients(&run, gi, &grid_name(g))?, &suns[gi]);
        let grid_err = |e: imap::Error| CliError(format!("annual: grid {}: {}", g.name, e.message));
        let closed = shaded
            .as_ref()
            .map(|(_, _, r)| (r, shaded_suns[gi].0, &shaded_suns[gi].1));
        let shading = grid_light(
            (gi, &grid_name(g)),
            (&run, sun),
            closed,
            (&ruled, &group_runs, &group_suns[gi]),
        )?;
        if gi == 0 && !shading.groups.is_empty() {
            first_states =
                Some(imap::annual::shading_states(&shading, &sky, &options).map_err(grid_err)?);
        }
        let all_open = all_open(&shading, g)?;
        let df_c = all_open.as_ref().unwrap_or(c);
        let m = imap::annual::metrics_with_shading(&shading, &sky, &options).map_err(grid_err)?;
        let df = imap::annual::daylight_factor(df_c, &sky.patches, o.ground_reflectance)
            .map_err(grid_err)?;
        // Points whose light is poorly known: a daylight factor with a relative error over
        // 10 %, or 0 in a lit grid (no photon reached it: dark, or too few photons; its
        // stated error is then 0 too).
        let lit = df.iter().any(|x| x.0 > 0.0);
        let poor = df.iter().filter(|(v, s)| *v > 0.0 && s / v > 0.1).count();
        let unreached = if lit {
            df.iter().filter(|(v, _)| *v == 0.0).count()
        } else {
            0
        };
        if poor + unreached > 0 {
            eprintln!(
                "imap: warning: annual: grid {}: {poor} of {} points have daylight factors known only to worse than 10 %, and {unreached} read 0 (no photon reached them): their metrics are not to be trusted; trace more photons (--photons, --time, --target-sda)",
                g.name,
                df.len()
            );
        }
        // Electric light with daylight: the zone's luminaires dimmed at its photosensor.
        let zone = match (&lighting, &electric) {
            (Some(d), Some(el)) => {
                // (Checked against every grid before the coefficients were traced.)
                let sensor = match o.lighting_sensor {
                    Some(k) => k,
                    // The darkest point: where its target is met, the rest of an evenly
                    // lit zone meets it too.
                    None => (0..df.len())
                        .min_by(|&a, &b| df[a].0.total_cmp(&df[b].0))
                        .unwrap_or(0),
                };
                let d = Dimming { sensor, ..*d };
                let l = imap::annual::lighting::lighting_with_shading(
                    &shading, &sky, &el[gi], &d, &options,
                )
                .map_err(|e| CliError(format!("annual: grid {}: {}", g.name, e.message)))?;
                Some((d, l, &el[gi]))
            }
            _ => None,
        };
        write_csv(
            &o.out.join(format!("annual_{}.csv", g.name)),
            g,
            &m,
            &df,
            zone.as_ref().map(|z| (z.2.as_slice(), &z.1)),
        )?;
        write_pictures(&o.out, g, &m, &df)?;
        write_temporal_map(
            &o.out.join(format!("annual_{}_temporal.png", g.name)),
            &shading,
            &sky,
            &options,
            df.len(),
        )?;
        let ase = m.ase.unwrap_or(f64::NAN);
        if !o.quiet {
            println!(
                "grid {}: sDA{:.0}/{:.0}% = {:.1} % (95 % interval {:.1}–{:.1} %), ASE{:.0}/{} = {:.1} %, {} occupied hours",
                g.name,
                o.threshold,
                100.0 * options.sda_share,
                100.0 * m.sda,
                100.0 * m.sda_interval.0,
                100.0 * m.sda_interval.1,
                options.ase_lx,
                options.ase_hours,
                100.0 * ase,
                m.occupied_hours
            );
            if shaded.is_some() {
                println!(
                    "grid {}: the blinds closed in {} occupied hours (IES LM-83's rule)",
                    g.name, m.blinds_closed_hours
                );
            }
            for (w, hours) in groups.iter().zip(&m.group_state_hours) {
                let states: Vec<String> = w
                    .states
                    .iter()
                    .zip(hours)
                    .map(|(s, h)| format!("{} {h} h", s.as_deref().unwrap_or("as-drawn")))
                    .collect();
                println!(
                    "grid {}: window group {}: {} of the occupied hours",
                    g.name,
                    printable(&w.name),
                    states.join(", ")
                );
            }
            if let Some(en) = &m.en17037 {
                let p: Vec<String> = en
                    .levels
                    .iter()
                    .map(|l| format!("{} {:.0} %", l.name, 100.0 * l.pass_probability))
                    .collect();
                println!(
                    "grid {}: EN 17037 level {} over {} daylight hours (probability met: {})",
                    g.name,
                    en.level().unwrap_or("none"),
                    en.daylight_hours,
                    p.join(", ")
                );
            }
            if let Some((d, l, _)) = &zone {
                println!(
                    "grid {}: electric light to {:.0} lx at point {}: {:.1} kWh ({:.1}–{:.1}), {:.1} kWh without daylight control ({:.0} % saved)",
                    g.name,
                    d.target_lx,
                    d.sensor,
                    l.energy_kwh,
                    l.energy_interval.0,
                    l.energy_interval.1,
                    l.full_kwh,
                    100.0 * (1.0 - l.energy_kwh / l.full_kwh.max(f64::MIN_POSITIVE))
                );
            }
            let k = df.len().max(1) as f64;
            println!(
                "grid {}: daylight factor mean {:.2} ± {:.2} %",
                g.name,
                100.0 * df.iter().map(|x| x.0).sum::<f64>() / k,
                100.0 * df.iter().map(|x| x.1 * x.1).sum::<f64>().sqrt() / k
            );
        }
        let mean = |f: fn(&imap::annual::SensorMetrics) -> f64| {
            m.sensors.iter().map(f).sum::<f64>() / m.sensors.len().max(1) as f64
        };
        grids_json.push(serde_json::json!({
            "name": g.name,
            "points": m.sensors.len(),
            "sda": {"value": m.sda, "sigma": m.sda_sigma, "interval_95": [m.sda_interval.0, m.sda_interval.1]},
            "ase": {"value": ase, "lx": options.ase_lx, "hours": options.ase_hours},
            "blinds_closed_hours": shaded.as_ref().map(|_| m.blinds_closed_hours),
            "window_groups": groups.iter().zip(&m.group_state_hours).map(|(w, hours)| serde_json::json!({
                "name": w.name,
                "rule": rule_name(w, &observers),
                "states": w.states.iter().zip(hours).map(|(s, h)| serde_json::json!({
                    "state": s.as_deref().unwrap_or("as-drawn"),
                    "occupied_hours": h,
                })).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
            "en17037": m.en17037.as_ref().map(|en| serde_json::json!({
                "daylight_hours": en.daylight_hours,
                "level": en.level(),
                "levels": en.levels.iter().map(|l| serde_json::json!({
                    "name": l.name,
                    "target_lx": l.target_lx,
                    "minimum_lx": l.minimum_lx,
                    "target_share": l.target_share,
                    "target_interval_95": [l.target_interval.0, l.target_interval.1],
                    "minimum_share": l.minimum_share,
                    "minimum_interval_95": [l.minimum_interval.0, l.minimum_interval.1],
                    "passes": l.passes,
                    "pass_probability": l.pass_probability,
                })).collect::<Vec<_>>(),
            })),
            "daylight_factor": {
                "mean": df.iter().map(|x| x.0).sum::<f64>() / df.len().max(1) as f64,
                "min": df.iter().map(|x| x.0).fold(f64::INFINITY, f64::min),
                "max": df.iter().map(|x| x.0).fold(f64::NEG_INFINITY, f64::max),
                "points_over_10_percent_error": poor,
                "points_at_zero": unreached,
            },
            "lighting": zone.as_ref().map(|(d, l, el)| serde_json::json!({
                "target_lx": d.target_lx,
                "sensor": d.sensor,
                "control": o.lighting_control,
                "min_output": d.min_output,
                "min_power": d.min_power,
                "power_w": d.power_w,
                "electric_lx_at_sensor": el[d.sensor].0,
                "energy_kwh": {"value": l.energy_kwh, "sigma": l.energy_sigma, "interval_95": [l.energy_interval.0, l.energy_interval.1]},
                "full_kwh": l.full_kwh,
                "saved_share": if l.full_kwh > 0.0 { 1.0 - l.energy_kwh / l.full_kwh } else { 0.0 },
                "mean_output": l.mean_output,
                "hours_off": l.hours_off,
                "hours_full": l.hours_full,
                "step_hours": l.step_hours,
                "mean_at_target": l.at_target.iter().sum::<f64>() / l.at_target.len().max(1) as f64,
            })),
            "mean_da": mean(|s| s.da),
            "mean_cda": mean(|s| s.cda),
            "mean_udi": m.udi,
            "mean_udi_interval_95": m.udi_interval.iter().map(|(lo, hi)| [*lo, *hi]).collect::<Vec<_>>(),
            "occupied_hours": m.occupied_hours,
        }));
    }
    let observers_json = observer_years(
        &observers,
        (&run, shaded.as_ref().map(|x| &x.2)),
        (&ruled, &group_runs),
        first_states.as_deref(),
        (&sky, &options),
        o,
    )?;
    let json = serde_json::json!({
        "weather": {
            "file": o.weather.display().to_string(),
            "site": weather.site.name,
            "latitude_deg": weather.site.latitude_deg,
            "longitude_deg": weather.site.longitude_deg,
            "utc_offset_hours": weather.site.utc_offset_hours,
            "hours": weather.hours.len(),
            "missing_hours": missing,
        },
        "patches": if o.mf == 1 {
            "Tregenza (Reinhart MF:1, 145 + ground)".to_string()
        } else {
            format!("Reinhart MF:{} ({} + ground)", o.mf, n - 1)
        },
        "sun": "direct along its true line each hour (through smooth panes); inter-reflected through its patch's coefficient less that patch's direct part",
        "shaded": o.shaded.as_ref().map(|p| p.display().to_string()),
        "threshold_lx": o.threshold,
        "occupied": o.occupied,
        "ground_reflectance": o.ground_reflectance,
        "draws": o.draws,
        "photons": report.photons,
        "target_sda": o.target_sda.map(|t| serde_json::json!({
            "half_width_95": t,
            "reached": reached,
            "rounds": rounds,
            "seconds": seconds,
        })),
        "target_en17037": o.target_en17037.map(|t| serde_json::json!({
            "half_width_95": t,
            "reached": reached,
            "rounds": rounds,
            "seconds": seconds,
        })),
        "target_udi": o.target_udi.map(|t| serde_json::json!({
            "half_width_95": t,
            "reached": reached,
            "rounds": rounds,
            "seconds": seconds,
        })),
        // Interrupted: the coefficients of the photons traced until then, unbiased, and
        // the intervals say how much less is known.
        "interrupted": interrupted.raised(),
        "grids": grids_json,
        "observers": observers_json,
    });
    let path = o.out.join("annual.json");
    std::fs::write(&path, serde_json::to_string_pretty(&json).expect("json"))
        .map_err(|e| CliError(format!("{}: {e}", path.display())))?;
    let path = o.out.join("annual_report.md");
    std::fs::write(&path, report_text(&json))
        .map_err(|e| CliError(format!("{}: {e}", path.display())))?;
    if let Some(code) = interrupted.status() {
        eprintln!("imap: interrupted: the metrics are those of the coefficients traced until then");
        std::process::exit(code);
    }
    Ok(())
}

/// With window groups, what grid `g` gets with every group's openings black (`black`:
/// the check run's coefficients, `sun` its direct sun) is in every group's runs too:
/// refused unless negligible against every group as drawn (`all_open`, the states 0's
/// direct sun `open_suns`).
fn check_black(
    g: &Grid,
    (black, sun): (&Coefficients, &DirectSun),
    (all_open, open_suns): (&Coefficients, &[Vec<DirectSun>]),
    (patches, ground_reflectance): (&imap::SkyPatches, f64),
) -> Result<()> {
    let grid_err = |e: imap::Error| CliError(format!("annual: grid {}: {}", g.name, e.message));
    let df = |c: &Coefficients| {
        imap::annual::daylight_factor(c, patches, ground_reflectance).map_err(grid_err)
    };
    let mean = |d: &[(f64, f64)]| d.iter().map(|x| x.0).sum::<f64>() / d.len().max(1) as f64;
    let direct = |s: &DirectSun| s.lux.iter().map(|&x| x as f64).sum::<f64>();
    let open_direct: f64 = open_suns.iter().map(|s| direct(&s[0])).sum();
    let (share, direct_share) = (
        mean(&df(black)?) / mean(&df(all_open)?).max(f64::MIN_POSITIVE),
        direct(sun) / open_direct.max(f64::MIN_POSITIVE),
    );
    if share > 0.01 || direct_share > 0.01 {
        fail!(
            "annual: grid {}: with every window group's openings black it still gets {:.1} % of its daylight factor and {:.1} % of its direct sun: the model has openings in no [[window_group]], whose light each group's runs would count again; put them in a group (a fixed window is a group of one state: states = [\"as-drawn\"])",
            g.name,
            100.0 * share,
            100.0 * direct_share
        );
    }
    if share > 0.0 || direct_share > 0.0 {
        eprintln!(
            "imap: warning: annual: grid {}: with every window group's openings black it still gets {:.2} % of its daylight factor and {:.2} % of its direct sun (openings in no group, or gaps in the model): each group's runs count it again",
            g.name,
            100.0 * share,
            100.0 * direct_share
        );
    }
    Ok(())
}

/// An observer of an annual run: its name, eye and view, its target in the runs (the
/// shaded run's own index with it), and its direct sun through every model state.
struct ObserverAt {
    name: String,
    what: String,
    eye: [f64; 3],
    view: [f64; 3],
    target: usize,
    sun: DirectSun,
    shaded_sun: Option<(usize, DirectSun)>,
    group_suns: Vec<Vec<DirectSun>>,
}

/// The window groups with every glare rule decided: each glare-ruled group's state every
/// hour, the most closed any of its observers' rules picks (at each observer its DGPs with
/// the group in the state and every other group open: `ShadingRule::Glare`), as a
/// schedule that the grids and the observers then read.
fn decide_glare(
    groups: &[GroupSpec],
    observers: &[ObserverAt],
    (run, runs): (&PatchRun, &[Vec<StateRun>]),
    sky: &AnnualSky,
    options: &MetricOptions,
) -> Result<Vec<GroupSpec>> {
    let mut out = groups.to_vec();
    for (g, w) in groups.iter().enumerate() {
        let Some((dgp, at)) = &w.glare else { continue };
        let mut schedule = vec![0u16; sky.hours.len()];
        for &i in at {
            let ob = &observers[i];
            // Only this group's rule is read here: the others as drawn in their state 0.
            let mut one = groups.to_vec();
            for (k, x) in one.iter_mut().enumerate() {
                x.rule = if k == g {
                    ShadingRule::Glare { dgp: *dgp }
                } else {
                    ShadingRule::Schedule(vec![0; sky.hours.len()])
                };
            }
            let shading = grid_light(
                (ob.target, &ob.what),
                (run, &ob.sun),
                None,
                (&one, runs, &ob.group_suns),
            )?;
            let states = imap::annual::shading_states(&shading, sky, options)
                .map_err(|e| CliError(format!("annual: {}: {}", ob.what, e.message)))?;
            for (s, x) in schedule.iter_mut().zip(&states[g]) {
                *s = (*s).max(*x);
            }
        }
        out[g].rule = ShadingRule::Schedule(schedule);
    }
    Ok(out)
}

/// How annual.json names a group's rule.
fn rule_name(w: &GroupSpec, observers: &[ObserverAt]) -> String {
    if let Some((dgp, at)) = &w.glare {
        let names: Vec<&str> = at.iter().map(|&i| observers[i].name.as_str()).collect();
        return format!("glare: DGPs above {dgp} at {}", names.join(", "));
    }
    match &w.rule {
        ShadingRule::DirectSun => "direct-sun".to_string(),
        ShadingRule::Illuminance { lx } => format!("illuminance {lx} lx"),
        ShadingRule::Schedule(_) => "schedule".to_string(),
        ShadingRule::Glare { dgp } => format!("glare: DGPs above {dgp}"),
    }
}

/// Every observer's year of glare (imageless: its Ev each hour, DGPs, the shares of the
/// occupied hours in Wienold's classes), each window group in the states of the first
/// grid (`first_states`; the blinds-closed model as a group of two), written to
/// `annual_observers.csv` hour by hour and printed; the JSON of annual.json's
/// "observers".
fn observer_years(
    observers: &[ObserverAt],
    (run, shaded): (&PatchRun, Option<&PatchRun>),
    (groups, runs): (&[GroupSpec], &[Vec<StateRun>]),
    first_states: Option<&[Vec<u16>]>,
    (sky, options): (&AnnualSky, &MetricOptions),
    o: &AnnualOptions,
) -> Result<Vec<serde_json::Value>> {
    if observers.is_empty() {
        return Ok(Vec::new());
    }
    let hours = sky.hours.len();
    let mut json = Vec::with_capacity(observers.len());
    let mut columns: Vec<(Vec<f64>, Vec<f64>)> = Vec::with_capacity(observers.len());
    for ob in observers {
        let err = |e: imap::Error| CliError(format!("annual: {}: {}", ob.what, e.message));
        let mut ruled = groups.to_vec();
        if let Some(states) = first_states {
            for (w, s) in ruled.iter_mut().zip(states) {
                w.rule = ShadingRule::Schedule(s.clone());
            }
        }
        let closed = match (shaded, &ob.shaded_sun) {
            (Some(r), Some((si, sun))) => Some((r, *si, sun)),
            _ => None,
        };
        let mut shading = grid_light(
            (ob.target, &ob.what),
            (run, &ob.sun),
            closed,
            (&ruled, runs, &ob.group_suns),
        )?;
        // The blinds-closed model: closed in the first grid's hours.
        if let (Some(_), Some(states)) = (closed, first_states) {
            shading.groups[0].rule = ShadingRule::Schedule(states[0].clone());
        }
        let year = imap::annual::annual_glare(&shading, sky, options).map_err(err)?;
        let y = &year[0];
        let hourly =
            imap::annual::hourly_with_shading(&shading, sky, options, 0..hours).map_err(err)?;
        // An eye's sensor is small: say when its light is poorly known.
        let (mut sum, mut sigma) = (0.0, 0.0);
        for h in (0..hours).filter(|&h| options.occupied.get(h).copied().unwrap_or(false)) {
            sum += hourly.0[h];
            sigma += hourly.1[h];
        }
        if sum > 0.0 && sigma / sum > 0.1 {
            eprintln!(
                "imap: warning: annual: {}: its hours' Ev are known only to ± {:.0} % on average (its sensor at the eye is small): its DGPs shares are not to be trusted; trace more photons (--photons, --time)",
                ob.what,
                100.0 * sigma / sum
            );
        }
        if !o.quiet {
            let class: Vec<String> = imap::annual::DGP_CLASSES
                .iter()
                .enumerate()
                .map(|(c, d)| {
                    format!(
                        "≥ {d:.2} in {:.1} % ({:.1}–{:.1} %)",
                        100.0 * y.share_above[c],
                        100.0 * y.share_interval[c].0,
                        100.0 * y.share_interval[c].1
                    )
                })
                .collect();
            println!(
                "observer {}: DGPs {} of {} occupied hours; mean Ev {:.0} lx",
                ob.name,
                class.join(", "),
                y.occupied_hours,
                y.mean_ev_lx
            );
        }
        json.push(serde_json::json!({
            "name": ob.name,
            "eye": ob.eye,
            "view": ob.view,
            "occupied_hours": y.occupied_hours,
            "mean_ev_lx": y.mean_ev_lx,
            "max_dgps": y.max_dgps,
            "dgps_classes": imap::annual::DGP_CLASSES.iter().enumerate().map(|(c, d)| serde_json::json!({
                "at_or_above": d,
                "hours": y.hours_above[c],
                "share": y.share_above[c],
                "sigma": y.share_sigma[c],
                "interval_95": [y.share_interval[c].0, y.share_interval[c].1],
            })).collect::<Vec<_>>(),
        }));
        columns.push(hourly);
    }
    // Hour by hour: each observer's Ev, its standard error and DGPs.
    let path = o.out.join("annual_observers.csv");
    let mut text = String::from("month,day,hour,occupied");
    for ob in observers {
        let n = &ob.name;
        text.push_str(&format!(",{n}_ev_lx,{n}_ev_sigma,{n}_dgps"));
    }
    text.push('\n');
    for (h, a) in sky.hours.iter().enumerate() {
        let occupied = options.occupied.get(h).copied().unwrap_or(false);
        text.push_str(&format!(
            "{},{},{},{}",
            a.month,
            a.day,
            a.hour,
            u8::from(occupied)
        ));
        for (e, s) in &columns {
            text.push_str(&format!(
                ",{},{},{:.4}",
                e[h],
                s[h],
                imap::annual::glare::hour_dgps(e[h])
            ));
        }
        text.push('\n');
    }
    std::fs::write(&path, text).map_err(|e| CliError(format!("{}: {e}", path.display())))?;
    Ok(json)
}

/// `f` of every window group state's context, group by group.
fn each_state<T>(
    runs: &mut [Vec<StateRun>],
    mut f: impl FnMut(&mut imap::Context) -> Result<T>,
) -> Result<Vec<Vec<T>>> {
    runs.iter_mut()
        .map(|states| states.iter_mut().map(|(sctx, _, _)| f(sctx)).collect())
        .collect()
}

/// One model state's run: its context, its scene and its coefficients.
type StateRun = (imap::Context, crate::scene::LoadedScene, PatchRun);

/// Grid `gi`'s light as the metrics read it: the model's coefficients and direct sun
/// (`run`, `sun`), with the blinds-closed model (`closed`: its run, the grid's index there
/// and its direct sun) as one group of two states under LM-83's rule; or, with window
/// groups, each group's states (`runs`, `suns`: per group, per state).
fn grid_light<'a>(
    (gi, name): (usize, &str),
    (run, sun): (&'a PatchRun, &'a DirectSun),
    closed: Option<(&'a PatchRun, usize, &'a DirectSun)>,
    (groups, runs, suns): (&[GroupSpec], &'a [Vec<StateRun>], &'a [Vec<DirectSun>]),
) -> Result<Shading<'a>> {
    if groups.is_empty() {
        let c = coefficients(run, gi, name)?;
        let shaded = match closed {
            Some((r, si, s)) => Some(Shaded {
                coefficients: coefficients(r, si, name)?.view(),
                sun: Some(s),
            }),
            None => None,
        };
        return Ok(Shading::blinds(c.view(), Some(sun), shaded));
    }
    let mut parts = Vec::with_capacity(groups.len());
    for ((w, states), suns) in groups.iter().zip(runs).zip(suns) {
        let mut each = Vec::with_capacity(states.len());
        for ((_, _, r), s) in states.iter().zip(suns) {
            each.push(Shaded {
                coefficients: coefficients(r, gi, name)?.view(),
                sun: Some(s),
            });
        }
        parts.push(WindowGroup {
            states: each,
            rule: w.rule.clone(),
        });
    }
    Ok(Shading {
        base: None,
        groups: parts,
    })
}

/// With window groups, every group's state 0 added: the daylight factor's model (None
/// without groups: the model is its own). Points × patches: made only where it is read.
fn all_open(shading: &Shading, g: &Grid) -> Result<Option<Coefficients>> {
    if shading.groups.is_empty() {
        return Ok(None);
    }
    let open: Vec<_> = shading
        .groups
        .iter()
        .map(|w| w.states[0].coefficients)
        .collect();
    Coefficients::sum(&open)
        .map(Some)
        .map_err(|e| CliError(format!("annual: grid {}: {}", g.name, e.message)))
}

/// A `[[window_group]]` as read: its objects, states (material names; None: as drawn)
/// and rule, and where the settings give it.
#[derive(Clone)]
struct GroupSpec {
    name: String,
    objects: Vec<String>,
    states: Vec<Option<String>>,
    rule: ShadingRule,
    /// The glare rule's DGPs and its observers (indices among the settings' observers);
    /// `rule` is then `ShadingRule::Glare`, or the schedule decided at them.
    glare: Option<(f64, Vec<usize>)>,
    at: (PathBuf, usize),
}

/// The settings' window groups, checked (a schedule against the weather file's rows).
fn window_groups(settings: &Settings, rows: usize) -> Result<Vec<GroupSpec>> {
    let mut out: Vec<GroupSpec> = Vec::new();
    for (i, w) in settings.window_groups.iter().enumerate() {
        let at = settings.locate_nth("[[window_group]]", i);
        let label = settings.label(
            "[[window_group]]",
            i,
            &format!("window group '{}'", printable(&w.name)),
        );
        if w.name.is_empty() || out.iter().any(|g| g.name == w.name) {
            fail!("{label}: give each window group a name of its own");
        }
        if w.objects.is_empty() {
            fail!("{label}: objects = [...] names none of the model's objects");
        }
        if let Some(o) = w
            .objects
            .iter()
            .find(|o| out.iter().any(|g| g.objects.contains(o)))
        {
            fail!(
                "{label}: object '{}' is in an earlier window group too",
                printable(o)
            );
        }
        if w.states.is_empty() || w.states.len() > u16::MAX as usize {
            fail!("{label}: states = [...] gives {} states: give 1 or more, the most open first (\"as-drawn\" or a material's name)", w.states.len());
        }
        let states = w
            .states
            .iter()
            .map(|s| (s != "as-drawn").then(|| s.clone()))
            .collect();
        let mut glare = None;
        let rule = match w.rule.as_deref().unwrap_or("direct-sun") {
            "direct-sun" => ShadingRule::DirectSun,
            "illuminance" => match w.rule_lx {
                Some(lx) if lx.is_finite() && lx > 0.0 => ShadingRule::Illuminance { lx },
                x => fail!("{label}: rule = \"illuminance\" needs rule_lx, an illuminance > 0 (lx); it is {x:?}"),
            },
            "schedule" => {
                let Some(file) = &w.schedule else {
                    fail!("{label}: rule = \"schedule\" needs schedule = \"FILE\" (one state index per weather row)");
                };
                let path = settings.base_dir.join(file);
                ShadingRule::Schedule(read_schedule(&path, rows, w.states.len())?)
            }
            "glare" => {
                let dgp = w.rule_dgp.unwrap_or(0.40);
                if !(dgp > 0.184 && dgp <= 1.0) {
                    fail!("{label}: rule_dgp = {dgp}: give a simplified DGP above 0.184 (its value at Ev = 0) and at most 1 (0.40: disturbing glare)");
                }
                let names = observer_names(settings);
                if names.is_empty() {
                    fail!("{label}: rule = \"glare\" reads the DGPs at [[observer]]s: give at least one");
                }
                let at: Vec<usize> = match &w.observers {
                    None => (0..names.len()).collect(),
                    Some(list) if list.is_empty() => {
                        fail!("{label}: observers = [] names none: leave it out for every observer")
                    }
                    Some(list) => {
                        let mut at = Vec::with_capacity(list.len());
                        for n in list {
                            match names.iter().position(|x| x == n) {
                                Some(i) => at.push(i),
                                None => fail!(
                                    "{label}: observers = [...]: '{}' is no [[observer]] (they are {})",
                                    printable(n),
                                    names.join(", ")
                                ),
                            }
                        }
                        at
                    }
                };
                glare = Some((dgp, at));
                ShadingRule::Glare { dgp }
            }
            r => fail!(
                "{label}: rule = \"{}\": use \"direct-sun\" (IES LM-83), \"illuminance\", \"schedule\" or \"glare\"",
                printable(r)
            ),
        };
        if w.rule.as_deref() != Some("glare") && (w.rule_dgp.is_some() || w.observers.is_some()) {
            fail!("{label}: rule_dgp and observers are read with rule = \"glare\" only");
        }
        if w.rule.as_deref() != Some("illuminance") && w.rule_lx.is_some() {
            fail!("{label}: rule_lx is read with rule = \"illuminance\" only");
        }
        if w.rule.as_deref() != Some("schedule") && w.schedule.is_some() {
            fail!("{label}: schedule is read with rule = \"schedule\" only");
        }
        out.push(GroupSpec {
            name: w.name.clone(),
            objects: w.objects.clone(),
            states,
            rule,
            glare,
            at,
        });
    }
    Ok(out)
}

/// The settings' observers' names, as `imap run` gives them.
fn observer_names(settings: &Settings) -> Vec<String> {
    settings
        .observers
        .iter()
        .enumerate()
        .map(|(k, o)| {
            o.name
                .clone()
                .unwrap_or_else(|| format!("observer{}", k + 1))
        })
        .collect()
}

/// A window group's schedule file: one state index per weather row (blank lines and `#`
/// comments left out), each below `states`.
fn read_schedule(path: &Path, rows: usize, states: usize) -> Result<Vec<u16>> {
    let text =
        std::fs::read_to_string(path).map_err(|e| CliError(format!("{}: {e}", path.display())))?;
    let mut out = Vec::with_capacity(rows);
    for (i, line) in text.lines().enumerate() {
        let t = line.split('#').next().unwrap_or("").trim();
        if t.is_empty() {
            continue;
        }
        match t.parse::<u16>() {
            Ok(x) if (x as usize) < states => out.push(x),
            _ => fail!(
                "{}:{}: \"{}\": give a state index from 0 to {}",
                path.display(),
                i + 1,
                printable(t),
                states - 1
            ),
        }
    }
    if out.len() != rows {
        fail!(
            "{}: {} states for the weather file's {rows} rows: give one per row",
            path.display(),
            out.len()
        );
    }
    Ok(out)
}

/// The settings of one run of the window groups: group `g` (None: none) in its state `s`,
/// every other group's openings black. Every state's material is named to the loader so
/// that none reads as a stray `[materials.NAME]`.
fn group_settings(
    settings: &Settings,
    groups: &[GroupSpec],
    g: Option<usize>,
    s: usize,
) -> Settings {
    let mut out = Settings {
        window_groups: Vec::new(),
        ..settings.clone()
    };
    for (i, w) in groups.iter().enumerate() {
        let what = format!("window group '{}'", printable(&w.name));
        let material = if Some(i) == g {
            w.states[s].clone()
        } else {
            Some(crate::scene::BLACK.to_string())
        };
        if let Some(m) = material {
            out.assign.push(crate::settings::Assignment {
                objects: w.objects.clone(),
                material: m,
                at: w.at.clone(),
                what: what.clone(),
            });
        }
        for m in w.states.iter().flatten() {
            out.assign.push(crate::settings::Assignment {
                objects: Vec::new(),
                material: m.clone(),
                at: w.at.clone(),
                what: what.clone(),
            });
        }
    }
    out
}

/// The model with `settings`, its warnings printed once per command: the runs of the
/// model's states (blinds, window groups, electric light) load the same model.
fn load_once(
    model: &Path,
    settings: &Settings,
) -> Result<(imap::Context, crate::scene::LoadedScene)> {
    static SAID: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    let (ctx, scene) = crate::scene::load(model, settings)?;
    let mut said = SAID.lock().unwrap_or_else(|p| p.into_inner());
    for w in &scene.warnings {
        if !said.contains(w) {
            eprintln!("imap: warning: {}", printable(w));
            said.push(w.clone());
        }
    }
    Ok((ctx, scene))
}

/// The coefficients' run of one model state: the model with `settings`, the patch skies
/// (oriented by `frame`, in batches of light groups: `imap::annual::trace::PatchRun`) kept
/// at every grid's points, traced as `o` says (`what` names the state in the progress bar).
fn coefficients_run(
    model: &Path,
    settings: &Settings,
    (up, north): ([f64; 3], [f64; 3]),
    o: &AnnualOptions,
    what: &str,
) -> Result<(imap::Context, crate::scene::LoadedScene, PatchRun)> {
    let (photons, time) = (o.photons.unwrap_or(0), o.time.unwrap_or(0.0));
    let (mut ctx, scene) = load_once(model, settings)?;
    // A photosensor beyond a grid's points is named before anything is traced.
    if let (Some(k), Some(_)) = (o.lighting_sensor, o.lighting_target) {
        for g in &scene.grids {
            let points = g.positions.len() / 3;
            if k >= points {
                fail!(
                    "--lighting-sensor {k}: grid {} has {points} points (0 to {})",
                    g.name,
                    points.saturating_sub(1)
                );
            }
        }
    }
    // The observers' sensors (the loader adds them) after the grids: target grids.len() +
    // i is observer i, its vertex 0 the eye.
    let observers = &scene.observers;
    let targets = scene
        .grids
        .iter()
        .map(|g| PatchTarget {
            mesh: g.id,
            side: 0,
            vertices: grids::point_vertices(g),
        })
        .chain(observers.iter().map(|e| PatchTarget {
            mesh: e.mesh,
            side: 0,
            vertices: vec![0],
        }))
        .collect();
    let mut run = PatchRun::new(&mut ctx, o.mf, (up, north), targets, 0)
        .map_err(|e| CliError(format!("annual: {}", e.message)))?;
    if !o.quiet {
        eprintln!(
            "imap: annual: {what}: {} grid points, {} run{} of at most {} patches",
            scene
                .grids
                .iter()
                .map(|g| g.positions.len() / 3)
                .sum::<usize>(),
            run.batches().len(),
            if run.batches().len() == 1 { "" } else { "s" },
            imap::annual::trace::MAX_BATCH,
        );
    }
    trace(&mut ctx, &mut run, photons, time, o, what)?;
    Ok((ctx, scene, run))
}

/// A run's progress in the bar's 1000 steps: the larger of its shares of `photons` and of
/// `time` (either 0: no such limit) since `start` (photons and seconds when it began).
fn progress_steps(p: &imap::Progress, start: (u64, f64), photons: u64, time: f64) -> u64 {
    let mut frac: f64 = 0.0;
    if time > 0.0 {
        frac = frac.max((p.elapsed_s - start.1) / time);
    }
    if photons > 0 {
        frac = frac.max(p.photons.saturating_sub(start.0) as f64 / photons as f64);
    }
    (frac.min(1.0) * 1000.0) as u64
}

/// The zone's electric light at full output at every grid's points (lx and its standard
/// error): the model with the settings' lights and luminaires and no sky, traced with the
/// coefficients' photons, time and estimator.
fn electric_run(
    model: &Path,
    settings: &Settings,
    o: &AnnualOptions,
) -> Result<Vec<Vec<(f64, f64)>>> {
    let (photons, time) = (o.photons.unwrap_or(0), o.time.unwrap_or(0.0));
    let (mut ctx, scene) = load_once(model, settings)?;
    let bar = crate::progress_bar(o.quiet);
    let interrupted = crate::Interrupts::get();
    let mut progress = |p: &imap::Progress| -> bool {
        bar.set_position(progress_steps(p, (0, 0.0), photons, time));
        bar.set_message(format!("electric light: {} photons", p.photons));
        !interrupted.raised()
    };
    ctx.run(&mut imap::RunParams {
        photons,
        time_budget_s: time,
        progress: Some(&mut progress),
        estimator: Some(crate::estimator(&o.estimator)?),
        ..Default::default()
    })
    .map_err(|e| CliError(format!("annual: electric light: {}", e.message)))?;
    bar.finish_and_clear();
    scene
        .grids
        .iter()
        .map(|g| {
            let r = grids::read(&ctx, g)?;
            Ok(r.lux
                .iter()
                .zip(&r.rel_error)
                .map(|(l, e)| (*l, l * e))
                .collect())
        })
        .collect()
}

/// Traces `photons` more (and at most `time` seconds; either 0: no such limit) into the
/// coefficients of `run`, with a progress bar.
fn trace(
    ctx: &mut imap::Context,
    run: &mut PatchRun,
    photons: u64,
    time: f64,
    o: &AnnualOptions,
    what: &str,
) -> Result<PatchReport> {
    let first = run.report().photons;
    let bar = crate::progress_bar(o.quiet);
    let interrupted = crate::Interrupts::get();
    let elapsed_before = run.report().elapsed_s;
    let mut progress = |p: &imap::Progress| -> bool {
        bar.set_position(progress_steps(p, (first, elapsed_before), photons, time));
        bar.set_message(format!("coefficients, {what}: {} photons", p.photons));
        !interrupted.raised()
    };
    let round = PatchRound {
        photons,
        time_s: time,
        estimator: Some(crate::estimator(&o.estimator)?),
    };
    let report = run
        .trace(ctx, round, &mut progress)
        .map_err(|e| CliError(format!("annual: {}", e.message)))?;
    bar.finish_and_clear();
    Ok(report)
}

/// How messages name a grid.
fn grid_name(g: &Grid) -> String {
    format!("grid {}", g.name)
}

/// Grid `gi`'s points' coefficients (borrowed: at MF:4 they are points × 2306 × 16
/// bytes).
fn coefficients<'a>(run: &'a PatchRun, gi: usize, name: &str) -> Result<&'a Coefficients> {
    run.coefficients(gi)
        .map_err(|e| CliError(format!("annual: {name}: {}", e.message)))
}

/// A false-colour picture of each metric on the grid: DA, the probability of passing
/// sDA's share, UDI's useful share (in %, 0–100), the daylight factor (%) and ASE's hours.
fn write_pictures(
    out: &Path,
    g: &Grid,
    m: &imap::annual::GridMetrics,
    df: &[(f64, f64)],
) -> Result<()> {
    let pct = |f: fn(&imap::annual::SensorMetrics) -> f64| -> Vec<f64> {
        m.sensors.iter().map(|s| 100.0 * f(s)).collect()
    };
    let pictures: [(&str, Vec<f64>, &str, Option<f64>); 5] = [
        ("da", pct(|s| s.da), "%", Some(100.0)),
        (
            "sda_probability",
            pct(|s| s.sda_pass_probability),
            "%",
            Some(100.0),
        ),
        ("udi_useful", pct(|s| s.udi_useful), "%", Some(100.0)),
        ("df", df.iter().map(|x| 100.0 * x.0).collect(), "%", None),
        (
            "ase_hours",
            m.sensors.iter().map(|s| s.ase_hours as f64).collect(),
            "h",
            None,
        ),
    ];
    for (name, values, unit, top) in pictures {
        let path = out.join(format!("annual_{}_{name}.png", g.name));
        grids::write_values_picture(&path, g, &values, unit, top)?;
    }
    Ok(())
}

/// The temporal map: the grid's mean illuminance over the year, one column per day (2
/// pixels) and one row per hour of the day (10 pixels), local standard time; hours the
/// weather file does not have stay dark.
fn write_temporal_map(
    path: &Path,
    shading: &Shading,
    sky: &AnnualSky,
    options: &MetricOptions,
    sensors: usize,
) -> Result<()> {
    const DAY_PX: usize = 2;
    const HOUR_PX: usize = 10;
    let (w, plot_h) = (366 * DAY_PX, 24 * HOUR_PX);
    let h = plot_h + crate::raster::LEGEND_MAX_PX as usize;
    let err = |e: imap::Error| CliError(format!("annual: temporal map: {}", e.message));
    // The grid's mean per hour (the blinds and window groups as their rules set them), a
    // month of hours at a time.
    let mut mean = vec![f64::NAN; sky.hours.len()];
    let chunk = 24 * 31;
    let mut start = 0;
    while start < sky.hours.len() {
        let end = (start + chunk).min(sky.hours.len());
        let (e, _) =
            imap::annual::hourly_with_shading(shading, sky, options, start..end).map_err(err)?;
        for (i, m) in mean[start..end].iter_mut().enumerate() {
            let row = &e[i * sensors..(i + 1) * sensors];
            *m = row.iter().sum::<f64>() / sensors.max(1) as f64;
        }
        start = end;
    }
    let top = crate::raster::nice_ceiling(
        mean.iter()
            .cloned()
            .filter(|x| x.is_finite())
            .fold(0.0, f64::max),
    );
    let mut img: Vec<u8> = [24u8, 24, 28].repeat(w * h);
    for (k, a) in sky.hours.iter().enumerate() {
        // A typical year's months come from different years: placed on a common year's
        // days, so that a leap year's month leaves no gap.
        let day = imap::weather::day_of_year(2001, a.month, a.day) as usize - 1;
        let hour = (a.hour.floor() as usize).min(23);
        let colour = crate::raster::colour_map(if top > 0.0 { mean[k] / top } else { 0.0 });
        // Midnight at the top, so the day's light runs down the middle.
        for y in hour * HOUR_PX..(hour + 1) * HOUR_PX {
            for x in (day * DAY_PX..(day + 1) * DAY_PX).filter(|&x| x < w) {
                img[3 * (y * w + x)..3 * (y * w + x) + 3].copy_from_slice(&colour);
            }
        }
    }
    crate::raster::draw_legend_in(&mut img, w as u32, h as u32, top, "lx");
    crate::raster::write_png(path, w as u32, h as u32, &img)
}

/// The run's report for people (annual_report.md): what was computed from what, and per
/// grid every metric with its confidence and the pictures; read from annual.json's values.
fn report_text(json: &serde_json::Value) -> String {
    use std::fmt::Write as _;
    let f = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let pc = |v: &serde_json::Value| format!("{:.1} %", 100.0 * f(v));
    let interval =
        |v: &serde_json::Value| format!("{:.1}–{:.1} %", 100.0 * f(&v[0]), 100.0 * f(&v[1]));
    let w = &json["weather"];
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Annual daylight: {}\n",
        w["site"].as_str().unwrap_or("?")
    );
    let _ = writeln!(
        s,
        "- Weather: `{}`, {:.2}° N, {:.2}° E, UTC{:+}; {} hours, {} with missing radiation (left out).",
        w["file"].as_str().unwrap_or("?"),
        f(&w["latitude_deg"]),
        f(&w["longitude_deg"]),
        f(&w["utc_offset_hours"]),
        w["hours"],
        w["missing_hours"]
    );
    let _ = writeln!(
        s,
        "- Sky: {}; ground reflectance {}. Sun: {}.",
        json["patches"].as_str().unwrap_or("?"),
        json["ground_reflectance"],
        json["sun"].as_str().unwrap_or("?")
    );
    let _ = writeln!(
        s,
        "- Coefficients: {} photons. Confidence: {} draws of the coefficients within their errors (95 % intervals: their 2.5 % and 97.5 % quantiles).",
        json["photons"], json["draws"]
    );
    let _ = writeln!(
        s,
        "- Occupied hours {} (local standard time); DA and sDA at {:.0} lx.",
        json["occupied"].as_str().unwrap_or("?"),
        f(&json["threshold_lx"])
    );
    for key in ["target_sda", "target_en17037", "target_udi"] {
        let t = &json[key];
        if t.is_object() {
            let _ = writeln!(
                s,
                "- Stopping on `{key}` ± {}: {} after {} rounds.",
                pc(&t["half_width_95"]),
                if t["reached"] == true {
                    "reached"
                } else {
                    "not reached"
                },
                t["rounds"]
            );
        }
    }
    if json["interrupted"] == true {
        let _ = writeln!(
            s,
            "- Interrupted: the metrics of the photons traced until then."
        );
    }
    if let Some(shaded) = json["shaded"].as_str() {
        let _ = writeln!(s, "- Blinds (IES LM-83's rule): closed model `{shaded}`.");
    }
    for g in json["grids"].as_array().into_iter().flatten() {
        let name = g["name"].as_str().unwrap_or("?");
        let _ = writeln!(
            s,
            "\n## Grid {name}: {} points, {} occupied hours\n",
            g["points"], g["occupied_hours"]
        );
        let _ = writeln!(s, "| metric | value | 95 % interval |\n|---|---|---|");
        let _ = writeln!(
            s,
            "| sDA{:.0}/50 % | {} | {} |",
            f(&json["threshold_lx"]),
            pc(&g["sda"]["value"]),
            interval(&g["sda"]["interval_95"])
        );
        let ase = &g["ase"];
        let _ = writeln!(
            s,
            "| ASE{:.0}/{} h | {} | traced lines: no Monte Carlo error |",
            f(&ase["lx"]),
            ase["hours"],
            pc(&ase["value"])
        );
        if let Some(h) = g["blinds_closed_hours"].as_u64() {
            let _ = writeln!(s, "| hours with the blinds closed | {h} | |");
        }
        for w in g["window_groups"].as_array().into_iter().flatten() {
            let states: Vec<String> = w["states"]
                .as_array()
                .into_iter()
                .flatten()
                .map(|x| {
                    format!(
                        "{} {} h",
                        x["state"].as_str().unwrap_or(""),
                        x["occupied_hours"]
                    )
                })
                .collect();
            let _ = writeln!(
                s,
                "| window group {} ({}): occupied hours per state | {} | |",
                w["name"].as_str().unwrap_or(""),
                w["rule"].as_str().unwrap_or(""),
                states.join(", ")
            );
        }
        let _ = writeln!(s, "| mean DA | {} | |", pc(&g["mean_da"]));
        let _ = writeln!(s, "| mean cDA | {} | |", pc(&g["mean_cda"]));
        let (u, ui) = (&g["mean_udi"], &g["mean_udi_interval_95"]);
        let _ = writeln!(
            s,
            "| mean UDI below / useful / above | {} / {} / {} | {} / {} / {} |",
            pc(&u[0]),
            pc(&u[1]),
            pc(&u[2]),
            interval(&ui[0]),
            interval(&ui[1]),
            interval(&ui[2])
        );
        let df = &g["daylight_factor"];
        let _ = writeln!(
            s,
            "| daylight factor, mean (min–max) | {:.2} % ({:.2}–{:.2} %) | per point in the CSV |",
            100.0 * f(&df["mean"]),
            100.0 * f(&df["min"]),
            100.0 * f(&df["max"])
        );
        let (poor, zero) = (
            df["points_over_10_percent_error"].as_u64().unwrap_or(0),
            df["points_at_zero"].as_u64().unwrap_or(0),
        );
        if poor + zero > 0 {
            let _ = writeln!(
                s,
                "\n**Warning**: {poor} points have daylight factors known only to worse than 10 %, and {zero} read 0 (no photon reached them: dark, or too few photons). Their metrics are not to be trusted: trace more photons."
            );
        }
        let en = &g["en17037"];
        if en.is_object() {
            let _ = writeln!(
                s,
                "\nEN 17037 over {} daylight hours: level **{}**.\n",
                en["daylight_hours"],
                en["level"].as_str().unwrap_or("none")
            );
            let _ = writeln!(
                s,
                "| level | E_T | share of hours at E_T (95 %) | E_TM | share at E_TM (95 %) | probability met |\n|---|---|---|---|---|---|"
            );
            for l in en["levels"].as_array().into_iter().flatten() {
                let _ = writeln!(
                    s,
                    "| {} | {:.0} lx | {} ({}) | {:.0} lx | {} ({}) | {} |",
                    l["name"].as_str().unwrap_or("?"),
                    f(&l["target_lx"]),
                    pc(&l["target_share"]),
                    interval(&l["target_interval_95"]),
                    f(&l["minimum_lx"]),
                    pc(&l["minimum_share"]),
                    interval(&l["minimum_interval_95"]),
                    pc(&l["pass_probability"])
                );
            }
        }
        let l = &g["lighting"];
        if l.is_object() {
            let e = &l["energy_kwh"];
            let _ = writeln!(
                s,
                "\nElectric light with daylight: {:.0} W dimmed ({}, down to {:.0} % output at {:.0} % power) to keep {:.0} lx at point {} ({:.0} lx from the luminaires at full output): **{:.2} kWh** (95 % interval {:.2}–{:.2} kWh) against {:.2} kWh without daylight control, {} saved; off in {} and full in {} occupied hours; daylight and electric light reach the target in {} of the occupied hours on average over the points (per point in the CSV).",
                f(&l["power_w"]),
                l["control"].as_str().unwrap_or("?"),
                100.0 * f(&l["min_output"]),
                100.0 * f(&l["min_power"]),
                f(&l["target_lx"]),
                l["sensor"],
                f(&l["electric_lx_at_sensor"]),
                f(&e["value"]),
                f(&e["interval_95"][0]),
                f(&e["interval_95"][1]),
                f(&l["full_kwh"]),
                pc(&l["saved_share"]),
                l["hours_off"],
                l["hours_full"],
                pc(&l["mean_at_target"])
            );
        }
        let _ = writeln!(s, "\nPer point: `annual_{name}.csv`.\n");
        for (file, what) in [
            ("da", "DA"),
            ("sda_probability", "probability of DA ≥ 50 %"),
            ("udi_useful", "UDI useful"),
            ("df", "daylight factor"),
            ("ase_hours", "hours of ASE's direct sun"),
            ("temporal", "the grid's mean illuminance by day and hour"),
        ] {
            let _ = writeln!(s, "![{what}](annual_{name}_{file}.png)");
        }
    }
    let observers = json["observers"].as_array().into_iter().flatten();
    for (i, ob) in observers.enumerate() {
        if i == 0 {
            let _ = writeln!(
                s,
                "\n## Observers: glare from the vertical illuminance at the eye (DGPs, imageless)\n"
            );
            let _ = writeln!(
                s,
                "| observer | mean Ev | largest DGPs | DGPs ≥ 0.35 | ≥ 0.40 | ≥ 0.45 |\n|---|---|---|---|---|---|"
            );
        }
        let class = |c: usize| {
            let k = &ob["dgps_classes"][c];
            format!("{} ({})", pc(&k["share"]), interval(&k["interval_95"]))
        };
        let _ = writeln!(
            s,
            "| {} | {:.0} lx | {:.2} | {} | {} | {} |",
            ob["name"].as_str().unwrap_or("?"),
            f(&ob["mean_ev_lx"]),
            f(&ob["max_dgps"]),
            class(0),
            class(1),
            class(2)
        );
    }
    if json["observers"].as_array().is_some_and(|a| !a.is_empty()) {
        let _ = writeln!(
            s,
            "\nShares of the occupied hours (95 % intervals). DGPs = 6.22·10⁻⁵ Ev + 0.184 does not rate the sun's disc in view. Hour by hour: `annual_observers.csv`."
        );
    }
    s
}

fn write_csv(
    path: &Path,
    g: &Grid,
    m: &imap::annual::GridMetrics,
    df: &[(f64, f64)],
    zone: Option<(&[(f64, f64)], &imap::annual::lighting::Lighting)>,
) -> Result<()> {
    let io = |e: std::io::Error| CliError(format!("{}: {e}", path.display()));
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
    writeln!(
        f,
        "x,y,z,da,cda,udi_below,udi_useful,udi_above,sda_pass_probability,ase_hours,df,df_sigma{}",
        if zone.is_some() {
            ",electric_lx,electric_sigma,at_target"
        } else {
            ""
        }
    )
    .map_err(io)?;
    for (k, s) in m.sensors.iter().enumerate() {
        let q = &g.positions[3 * k..3 * k + 3];
        let lighting = zone.map_or(String::new(), |(el, l)| {
            format!(",{:.4},{:.4},{:.4}", el[k].0, el[k].1, l.at_target[k])
        });
        writeln!(
            f,
            "{},{},{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.3},{},{:.5},{:.5}{lighting}",
            q[0],
            q[1],
            q[2],
            s.da,
            s.cda,
            s.udi_below,
            s.udi_useful,
            s.udi_above,
            s.sda_pass_probability,
            s.ase_hours,
            df[k].0,
            df[k].1
        )
        .map_err(io)?;
    }
    f.flush().map_err(io)
}

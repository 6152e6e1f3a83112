//! Final gathering's driver (`RenderMethod::FinalGather`): eye passes alternated with
//! runs of the map it reads (which the render extends) and, when the scene has point-like
//! lights and specular surfaces, rounds of caustic photons, until a stop criterion. Each
//! slice goes where it buys the most: the largest error² per second spent so far. The
//! map is the host's (the context's): the driver reaches it only through `GatherHost`.

use super::{
    caustic_rounds, passes, Batch, Caustics, GatherError, GatherStore, Schedule, CAUSTIC_ROUND,
};
use crate::error::{Error, ImapStatus, Result};
use crate::progress::{duration_s, Progress, StopReason};
use crate::render::backward::{EyeStats, EyeTracer, MapIndirect};
use crate::render::{Camera, Image, RenderMonitor, RenderParams, RenderReport};
use crate::sched::RunParams;
use crate::transport::Tracer;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Shortest and longest slice of a final-gathering render between decisions, s.
const SLICE_MIN_S: f64 = 0.05;
const SLICE_MAX_S: f64 = 4.0;
/// Each part of a final-gathering render (eye paths, caustics) keeps at least this share
/// of its time, whatever their errors say (a part whose error is 0 so far, or a scene where
/// one part has nothing to do, must not stall the others).
const MIN_SHARE: f64 = 0.1;
/// A final-gathering render's slices grow with it: this share of the time so far.
const SLICE_SHARE: f64 = 0.25;
/// The first map slice of a render that finds the map empty (at most a tenth of a time
/// budget), s.
const FIRST_MAP_S: f64 = 0.5;
/// Photons a render that finds the map empty traces before anything else, whatever its
/// time budget: final gathering reads the map, so the shortest budget still gets one
/// (and the same status every time).
pub const FIRST_MAP_PHOTONS: u64 = 1 << 12;

/// A final-gathering render's progress point.
fn gather_point(start: Instant, err: &GatherError, photons: u64, paths: u64) -> Progress {
    Progress {
        region_rel_error: 0.0,
        elapsed_s: start.elapsed().as_secs_f64(),
        photons,
        hits: paths,
        rel_error: err.rel_error,
    }
}

/// What a final-gathering render does next.
enum GatherStep {
    /// Run the map: this many photons (0: for `secs` seconds).
    Map { photons: u64, secs: f64 },
    /// Trace this many caustic rounds.
    Caustic(u64),
    /// A batch of eye passes.
    Eye,
    /// The first photons of an empty map (`FIRST_MAP_PHOTONS`), whatever the time.
    FirstMap,
}

/// What final gathering needs of the map it reads and extends.
pub trait GatherHost {
    /// Photons in the map.
    fn photons(&self) -> u64;
    /// The map's run time so far, s.
    fn map_elapsed_s(&self) -> f64;
    /// Whether the map is empty or holds photons 0..N: only such a map is extended (one
    /// that holds a shard's or a range's photons is read as it is: continuing it with
    /// every photon would take other shards' indices and count them twice in a merge).
    fn map_sequential(&self) -> bool;
    /// Runs the map.
    fn run_map(&mut self, params: &mut RunParams) -> Result<()>;
    /// What gathering reads from the map.
    fn map_indirect(&self) -> Result<MapIndirect>;
    /// Eye paths through `cam`.
    fn eye_tracer<'a>(&'a self, cam: &'a Camera, max_events: u32) -> EyeTracer<'a>;
    /// The forward photon tracer of the caustic rounds (it records nothing).
    fn forward_tracer(&self, max_events: u32) -> Tracer<'_>;
    /// Puts back what the render's runs changed of an empty map's context (its run time,
    /// history and tallies) when it traced no photon whole.
    fn put_back(&mut self);
}

/// A final-gathering render's fixed figures (the host sized and budgeted them).
pub struct Job {
    pub cam: Camera,
    pub width: u32,
    pub height: u32,
    pub threads: usize,
    pub bands: usize,
    /// Recorded vertex sides the map holds.
    pub slots: usize,
    /// Per emitter: point-like (its caustics come from the caustic rounds).
    pub delta: Vec<bool>,
    /// Whether there are caustic rounds: point-like emitters and specular surfaces.
    pub with_caustics: bool,
    pub read_bytes: u64,
    pub store_bytes: u64,
    pub caustic_bytes: u64,
    pub seed: u64,
}

/// Renders `job` by final gathering from `host`'s map: the image, the report, and the
/// error of a lost worker thread (the image then holds what was rendered until then).
pub fn render(
    host: &mut impl GatherHost,
    job: &Job,
    params: &mut RenderParams,
) -> Result<(Image, RenderReport, Option<Error>)> {
    let start = Instant::now();
    let Job {
        ref cam,
        threads,
        bands: nb,
        slots,
        ref delta,
        with_caustics,
        read_bytes,
        store_bytes,
        caustic_bytes,
        ..
    } = *job;
    let pixels = cam.pixels();
    let records = slots > 0;
    let fixed = params.forward_per_pass;
    let max_events = params.max_path_events;
    let store = GatherStore::new(pixels, nb, threads);
    let caustics = with_caustics.then(|| Mutex::new(Caustics::new(pixels, nb)));
    let seed = job.seed;
    let end = (params.time_budget_s > 0.0)
        .then(|| crate::progress::deadline(start, params.time_budget_s))
        .flatten();
    let photons_before = host.photons();
    let mut mon = RenderMonitor::new(params, start);
    let interval = mon.interval();
    let mut map: Option<MapIndirect> = None;
    // The render extends a map that is empty or holds photons 0..N: one that holds a
    // shard's or a range's photons is read as it is (continuing it with every photon
    // would take other shards' indices and count them twice in a merge).
    let mut map_frozen = !records || !host.map_sequential();
    let (mut t_eye, mut t_map, mut t_read, mut t_caustic) = (0.0f64, 0.0, 0.0, 0.0f64);
    let mut stats = EyeStats::default();
    let mut err = GatherError {
        rel_error: crate::imap::NO_DATA_REL_ERROR,
        ..Default::default()
    };
    let mut lost: Option<Error> = None;
    let mut batches = 0u64;
    let mut schedule = Schedule::default();
    let stop_flag = AtomicBool::new(false);
    // Caustic rounds traced whole, and the next round's index.
    let (mut done_rounds, mut next_round) = (0u64, 0u64);
    loop {
        let now = start.elapsed().as_secs_f64();
        let left = end.map(|e| e.saturating_duration_since(Instant::now()).as_secs_f64());
        if left.is_some_and(|l| l <= 0.0) {
            mon.stop = mon.stop.or(Some(StopReason::TimeBudget));
        }
        // An empty map gets its first photons even when the time is up: the shortest
        // budget leaves the context as every other does, with a map.
        let first = !map_frozen && host.photons() == 0;
        if mon.stop.is_some() && !(first && mon.stop == Some(StopReason::TimeBudget)) {
            break;
        }
        let slice = (SLICE_SHARE * now)
            .clamp(SLICE_MIN_S, SLICE_MAX_S)
            .min(left.unwrap_or(f64::MAX));
        let pass = err.min_samples as u64;
        let passes_done = mon.params.passes > 0 && pass >= mon.params.passes;
        if fixed > 0 && passes_done {
            mon.stop = Some(StopReason::PhotonCount);
            break;
        }
        let step = if first {
            GatherStep::FirstMap
        } else if fixed > 0 {
            // Before pass k (from 0) the map holds at least (k + 1) · fixed photons and
            // the caustics have k + 1 rounds.
            let want = (pass + 1).saturating_mul(fixed);
            let have = host.photons();
            if !map_frozen && have < want {
                GatherStep::Map {
                    photons: want - have,
                    secs: 0.0,
                }
            } else if with_caustics && done_rounds < pass + 1 {
                GatherStep::Caustic(pass + 1 - done_rounds)
            } else {
                GatherStep::Eye
            }
        } else if !map_frozen && host.photons() == FIRST_MAP_PHOTONS && photons_before == 0 {
            GatherStep::Map {
                photons: 0,
                secs: first_map_s(mon.params.time_budget_s).min(left.unwrap_or(f64::MAX)),
            }
        } else if with_caustics && done_rounds < 2 {
            GatherStep::Caustic(threads.max(2) as u64)
        } else if batches == 0 {
            GatherStep::Eye
        } else if passes_done {
            // Every pixel has its passes: the caustics at least one round per pass.
            if with_caustics && done_rounds < pass {
                GatherStep::Caustic(pass - done_rounds)
            } else {
                GatherStep::Eye
            }
        } else if t_eye < MIN_SHARE * now {
            GatherStep::Eye
        } else if with_caustics && t_caustic < MIN_SHARE * now {
            GatherStep::Caustic(threads as u64)
        } else {
            // Each part's error² falls as 1/(its time): the next slice goes where it
            // buys the most, the largest error² per second spent so far.
            let eye = err.eye_var / t_eye.max(1e-3);
            let photons = host.photons().max(1) as f64;
            let map_rate = if map_frozen {
                0.0
            } else {
                err.map_per_photon / photons / host.map_elapsed_s().max(1e-3)
            };
            let caustic = if with_caustics {
                err.caustic_var / t_caustic.max(1e-3)
            } else {
                0.0
            };
            if map_rate > eye && map_rate >= caustic {
                GatherStep::Map {
                    photons: 0,
                    secs: slice,
                }
            } else if caustic > eye {
                let per_round = t_caustic / done_rounds.max(1) as f64 * threads as f64;
                let n = (slice * threads as f64 / per_round.max(1e-6)) as u64;
                GatherStep::Caustic(n.clamp(threads as u64, 1 << 20))
            } else {
                GatherStep::Eye
            }
        };
        if passes_done && matches!(step, GatherStep::Eye) {
            // Every pixel has its passes, and the map and the caustics have their
            // shares of the time.
            mon.stop = Some(StopReason::PhotonCount);
            break;
        }
        match step {
            GatherStep::FirstMap => {
                let t0 = Instant::now();
                let paths = stats.paths;
                // Only a cancel from the caller's callback stops these photons.
                let mut cancel = |p: &Progress| {
                    !(mon.due()
                        && mon.tick(
                            gather_point(start, &err, p.photons, paths),
                            false,
                            Duration::ZERO,
                        ))
                };
                let r = host.run_map(&mut RunParams {
                    photons: FIRST_MAP_PHOTONS,
                    progress_interval_s: 0.05,
                    max_path_events: max_events,
                    progress: Some(&mut cancel),
                    ..Default::default()
                });
                t_map += t0.elapsed().as_secs_f64();
                match r {
                    Err(e) if e.status == ImapStatus::ImapErrThreadLost => {
                        lost = Some(e);
                        break;
                    }
                    Err(e) => {
                        host.put_back();
                        return Err(e);
                    }
                    Ok(_) => {}
                }
                if host.photons() == 0 {
                    // Cancelled before a photon was whole: nothing to gather from.
                    mon.stop = mon.stop.or(Some(StopReason::Cancelled));
                    break;
                }
                map = None;
                continue;
            }
            GatherStep::Map { photons, secs } => {
                let t0 = Instant::now();
                let before = host.photons();
                let until = end;
                let paths = stats.paths;
                // The map's progress points carry on the render's: its callback (which
                // may cancel) and its time budget still rule during a slice.
                let mut in_time = |p: &Progress| {
                    if until.is_some_and(|e| Instant::now() >= e) {
                        return false;
                    }
                    !(mon.due()
                        && mon.tick(
                            gather_point(start, &err, p.photons, paths),
                            err.min_samples >= 2,
                            Duration::ZERO,
                        ))
                };
                let r = host.run_map(&mut RunParams {
                    photons,
                    time_budget_s: if photons > 0 {
                        left.unwrap_or(0.0)
                    } else {
                        secs
                    },
                    progress_interval_s: 0.05,
                    max_path_events: max_events,
                    progress: Some(&mut in_time),
                    ..Default::default()
                });
                t_map += t0.elapsed().as_secs_f64();
                match r {
                    Ok(_) => {}
                    Err(e) if e.status == ImapStatus::ImapErrThreadLost => {
                        lost = Some(e);
                        break;
                    }
                    Err(e) if host.photons() == 0 => {
                        host.put_back();
                        return Err(e);
                    }
                    // The map cannot grow (its photon selection is spent, a budget): the
                    // render goes on with the map as it is.
                    Err(_) => map_frozen = true,
                }
                if host.photons() == before {
                    map_frozen = true;
                }
                map = None;
                continue;
            }
            GatherStep::Caustic(n) => {
                let eye = host.eye_tracer(cam, max_events);
                let fwd = host.forward_tracer(max_events);
                let t0 = Instant::now();
                stop_flag.store(false, Ordering::Relaxed);
                let c = caustics.as_ref().expect("with caustics");
                let (whole, gone) =
                    caustic_rounds(&eye, &fwd, delta, c, next_round, n, threads, &stop_flag);
                done_rounds += whole;
                next_round += n;
                t_caustic += t0.elapsed().as_secs_f64();
                if let Some(why) = gone {
                    lost = Some(thread_lost(why));
                    break;
                }
                err = store.estimate(&schedule, caustics.as_ref(), None);
                gather_tick(host.photons(), &mut mon, &err, stats.paths);
                continue;
            }
            GatherStep::Eye => {}
        }
        if map.is_none() && records {
            let t0 = Instant::now();
            map = Some(host.map_indirect()?);
            t_read += t0.elapsed().as_secs_f64();
        }
        // A batch of eye passes.
        let mut eye = host.eye_tracer(cam, max_events);
        eye.map = map.as_ref();
        // The sun through specular surfaces: the caustic rounds bring it.
        eye.sun_by_caustics = with_caustics;
        let up_to = if fixed > 0 {
            err.min_samples.saturating_add(1)
        } else {
            match mon.params.passes {
                0 => u32::MAX,
                p => u32::try_from(p).unwrap_or(u32::MAX),
            }
        };
        let batch_end = if fixed > 0 {
            end
        } else {
            Instant::now()
                .checked_add(duration_s(slice))
                .map(|b| end.map_or(b, |e| e.min(b)))
        };
        stop_flag.store(false, Ordering::Relaxed);
        let batch = Batch {
            up_to,
            deadline: batch_end,
            stop: &stop_flag,
            map_photons: if records { host.photons() } else { 0 },
        };
        let photons_now = batch.map_photons;
        let samples_before = store.samples();
        let t0 = Instant::now();
        let (tally, gone) = passes(&eye, &store, seed, threads, &batch, interval, &mut || {
            if !mon.due() {
                return false;
            }
            let t1 = Instant::now();
            let mut now = schedule.clone();
            now.add(photons_now, store.samples() - samples_before);
            let e = store.estimate(&now, caustics.as_ref(), None);
            let p = gather_point(start, &e, photons_now, e.samples);
            mon.tick(p, e.min_samples >= 2, t1.elapsed())
        });
        t_eye += t0.elapsed().as_secs_f64();
        batches += 1;
        stats.paths += tally.stats.paths;
        stats.rays += tally.stats.rays;
        stats.dropped += tally.stats.dropped;
        if let Some(why) = gone {
            lost = Some(thread_lost(why));
            break;
        }
        schedule.add(photons_now, store.samples() - samples_before);
        err = store.estimate(&schedule, caustics.as_ref(), None);
        gather_tick(host.photons(), &mut mon, &err, stats.paths);
        if tally.stats.paths == 0 && map_frozen && mon.stop.is_none() && !tally.cut {
            // Nothing left to do (cannot happen with a criterion set): stop.
            mon.stop = Some(StopReason::PhotonCount);
        }
    }
    if host.photons() == 0 {
        // No photon was traced: the map's run time and history stay as they were.
        host.put_back();
    }
    let wall_s = start.elapsed().as_secs_f64();
    let mut image = Image::new(job.width, job.height, nb);
    let err = store.estimate(&schedule, caustics.as_ref(), Some(&mut image));
    let last = Progress {
        region_rel_error: 0.0,
        elapsed_s: wall_s,
        photons: host.photons(),
        hits: stats.paths,
        rel_error: err.rel_error,
    };
    mon.finish(last);
    let report = RenderReport {
        threads,
        groups: 1,
        threads_per_group: threads,
        phases: batches,
        passes: err.samples as f64 / pixels as f64,
        backward_paths: stats.paths,
        backward_rays: stats.rays,
        forward_photons: host.photons() - photons_before,
        gathers: done_rounds * CAUSTIC_ROUND,
        wall_s,
        stop: Some(mon.stop.unwrap_or(StopReason::PhotonCount)),
        rel_error: err.rel_error,
        time_backward_s: t_eye,
        time_build_s: t_read,
        time_forward_s: t_map,
        time_close_s: t_caustic,
        dropped_paths: stats.dropped,
        map_bytes_per_group: read_bytes,
        pixel_bytes: store_bytes + caustic_bytes,
        total_bytes: read_bytes + store_bytes + caustic_bytes,
        history: mon.history,
        ..Default::default()
    };
    Ok((image, report, lost))
}

/// After a step of a final-gathering render: the stop criteria, and a progress point
/// when one is due.
fn gather_tick(photons: u64, mon: &mut RenderMonitor, err: &GatherError, paths: u64) {
    let settled = err.min_samples >= 2;
    let why = mon.criteria(err.rel_error, settled, mon.start.elapsed().as_secs_f64());
    mon.stop = mon.stop.or(why);
    if mon.stop.is_none() && mon.due() {
        let p = gather_point(mon.start, err, photons, paths);
        mon.tick(p, settled, Duration::ZERO);
    }
}

fn thread_lost(why: String) -> Error {
    Error::new(
        ImapStatus::ImapErrThreadLost,
        format!("{why}; the render was stopped and its image holds what was rendered until then"),
    )
}

/// The first map slice of a render that finds the map empty, s.
fn first_map_s(time_budget_s: f64) -> f64 {
    if time_budget_s > 0.0 {
        FIRST_MAP_S.min(0.1 * time_budget_s)
    } else {
        FIRST_MAP_S
    }
}

//! Tracing the daylight coefficients of any Reinhart subdivision: MF:1's 146 patches fit in
//! one run's light groups, MF:2's 578 and MF:4's 2306 do not (a map keeps at most 254
//! group layers at every slot). `PatchRun` traces the patches in batches of light groups,
//! one run per batch, and keeps only the coefficients at the chosen vertices (the grids'
//! points): the memory of one batch's layers plus sensors × patches × 16 bytes, however
//! many patches there are (docs/daylight.md, "Reinhart's finer patches").
//!
//! Every batch draws its own photons: batch b traces the photon indices from b · 2⁴⁰ on,
//! so no two batches share a random sequence and the patches' errors stay independent. Its
//! photons are its share of the round's, in proportion to its patches' solid angle (the
//! share one run of every patch would give it without portals). A later round traces
//! further indices of every batch and merges them with the earlier ones by photon count.

use super::Coefficients;
use crate::context::{Context, Layer};
use crate::error::{bail, Result};
use crate::progress::Progress;
use crate::scene::light::{SkyAmount, SkyDesc, SkyKind, SkyPatches};
use crate::scene::LayerRequest;
use crate::transport::direct::Estimator;
use std::ops::Range;

/// Patches one batch holds at most: a map's light groups less group 0, which keeps the
/// model's own emitters.
pub const MAX_BATCH: usize = crate::imap::MAX_LIGHT_GROUPS - 1;

/// A patch sky's luminance, cd/m² (a coefficient is per cd/m²).
const PATCH_LUMINANCE_CD: f64 = 1.0;

/// Where a batch's photon indices start: batch b's are b · `BATCH_STRIDE` onwards.
const BATCH_STRIDE: u64 = 1 << 40;

/// The vertices whose coefficients a `PatchRun` keeps: of mesh `mesh`, side `side` (0
/// front, 1 back).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PatchTarget {
    pub mesh: u32,
    pub side: u32,
    pub vertices: Vec<usize>,
}

/// A round's limits: photons over every batch (0: none), seconds (0: none), and the
/// estimator (None: the context's).
#[derive(Clone, Copy, Debug, Default)]
pub struct PatchRound {
    pub photons: u64,
    pub time_s: f64,
    pub estimator: Option<Estimator>,
}

/// What the rounds so far traced.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PatchReport {
    /// Photons over every batch and round.
    pub photons: u64,
    /// Seconds the batches' runs took together.
    pub elapsed_s: f64,
    /// Whether the last round was cancelled (by its progress callback) before every batch
    /// had its share.
    pub cancelled: bool,
}

/// The daylight coefficients of Reinhart MF:`mf` at chosen vertices, traced in batches of
/// light groups (the module's text). The context holds the model: its own lights stay
/// (group 0, traced in every batch and kept out of the coefficients); the patch skies are
/// added and removed batch by batch. While a `PatchRun` is in use, the context's lights
/// and map are its.
#[derive(Clone, Debug)]
pub struct PatchRun {
    mf: u32,
    frame: ([f64; 3], [f64; 3]),
    /// The context's own lights (the patches' come after them).
    own_lights: usize,
    batches: Vec<Range<usize>>,
    /// Each batch's share of a round's photons and time.
    shares: Vec<f64>,
    /// Photons each batch has traced.
    traced: Vec<u64>,
    estimator: Estimator,
    targets: Vec<PatchTarget>,
    /// Per target, the coefficients merged over the rounds.
    merged: Vec<Coefficients>,
    report: PatchReport,
}

impl PatchRun {
    /// A run of MF:`mf`'s patches (1 cd/m² each, CIE D65; the ground's below the horizon,
    /// as `add_sky_patches`) oriented by `frame` = (zenith, north), keeping the
    /// coefficients at `targets`, at most `batch` patches per run (0: `MAX_BATCH`; fewer
    /// hold fewer layers at every slot of the map). The context must have no photons;
    /// it then keeps per-group layers.
    pub fn new(
        ctx: &mut Context,
        mf: u32,
        frame: ([f64; 3], [f64; 3]),
        targets: Vec<PatchTarget>,
        batch: usize,
    ) -> Result<Self> {
        let patches = SkyPatches::reinhart(mf)?;
        let n = patches.count();
        if batch > MAX_BATCH {
            bail!(
                ImapErrInvalidArgument,
                "batch = {batch}: a run holds at most {MAX_BATCH} patches (one light group each, group 0 the model's)"
            );
        }
        let batch = if batch == 0 { MAX_BATCH } else { batch };
        if ctx.report().photons > 0 {
            bail!(
                ImapErrOutOfOrder,
                "the context has traced photons: reset it before tracing the patches"
            );
        }
        if targets.is_empty() {
            bail!(
                ImapErrInvalidArgument,
                "targets: no vertices to keep coefficients at"
            );
        }
        let mut sensors = 0usize;
        for (t, target) in targets.iter().enumerate() {
            ctx.check_recorded_side(target.mesh, target.side)?;
            let all = ctx.vertex_count(target.mesh)?;
            if let Some(i) = target.vertices.iter().position(|&v| v >= all) {
                bail!(
                    ImapErrIndexOutOfRange,
                    "targets[{t}].vertices[{i}] = {}: mesh {} has {all} vertices",
                    target.vertices[i],
                    target.mesh
                );
            }
            sensors = sensors.saturating_add(target.vertices.len());
        }
        // The merged coefficients (value and σ) and one batch's read-out.
        let bytes = (sensors as u64)
            .saturating_mul(n as u64)
            .saturating_mul(16)
            .saturating_add((sensors as u64).saturating_mul(batch as u64 * 16));
        let free = ctx.memory_budget().saturating_sub(ctx.memory_estimate());
        if bytes > free {
            bail!(
                ImapErrMemoryBudget,
                "the coefficients of {sensors} points × {n} patches (MF:{mf}) need {:.1} MiB; the memory budget leaves {:.1} MiB",
                bytes as f64 / 1048576.0,
                free as f64 / 1048576.0
            );
        }
        let batches: Vec<Range<usize>> = (0..n)
            .step_by(batch)
            .map(|s| s..(s + batch).min(n))
            .collect();
        let total: f64 = (0..n).map(|p| patches.solid_angle(p)).sum();
        let shares = batches
            .iter()
            .map(|r| r.clone().map(|p| patches.solid_angle(p)).sum::<f64>() / total)
            .collect();
        ctx.set_layers(LayerRequest {
            groups: true,
            direct: ctx.layers().1,
        })?;
        let own_lights = ctx.light_count();
        let merged = targets
            .iter()
            .map(|t| Coefficients {
                sensors: t.vertices.len(),
                patches: n,
                value: vec![0.0; t.vertices.len() * n],
                sigma: vec![0.0; t.vertices.len() * n],
            })
            .collect();
        let run = PatchRun {
            mf,
            frame,
            own_lights,
            traced: vec![0; batches.len()],
            batches,
            shares,
            estimator: ctx.estimator(),
            targets,
            merged,
            report: PatchReport::default(),
        };
        if run.batches.len() == 1 {
            // One batch: its patches stay, and every round continues the one run.
            if let Err(e) = run.add_batch(ctx, 0) {
                ctx.truncate_lights(own_lights)?;
                return Err(e);
            }
        }
        Ok(run)
    }

    /// The batches (patch ranges, the ground patch 0 in the first).
    pub fn batches(&self) -> &[Range<usize>] {
        &self.batches
    }

    /// What the rounds so far traced.
    pub fn report(&self) -> PatchReport {
        self.report
    }

    /// Traces one round: every batch its share of `round`'s photons and time, added to
    /// what earlier rounds traced. `progress` sees the photons and seconds of every batch
    /// so far; returning false cancels the round (the batches not reached keep what
    /// earlier rounds gave them). Needs a photon or a time limit.
    pub fn trace(
        &mut self,
        ctx: &mut Context,
        round: PatchRound,
        progress: &mut dyn FnMut(&Progress) -> bool,
    ) -> Result<PatchReport> {
        if round.photons == 0 && !(round.time_s.is_finite() && round.time_s > 0.0) {
            bail!(
                ImapErrInvalidArgument,
                "a round of the patches needs photons > 0 or a time_s > 0 (photons = {}, time_s = {})",
                round.photons,
                round.time_s
            );
        }
        if let Some(e) = round.estimator {
            self.estimator = e;
        }
        self.report.cancelled = false;
        let single = self.batches.len() == 1;
        for b in 0..self.batches.len() {
            let share = self.shares[b];
            let photons = if round.photons == 0 {
                0
            } else {
                ((round.photons as f64 * share).ceil() as u64).max(1)
            };
            let time_s = if round.time_s > 0.0 {
                round.time_s * share
            } else {
                0.0
            };
            if !single {
                ctx.reset();
                ctx.truncate_lights(self.own_lights)?;
                self.add_batch(ctx, b)?;
            }
            let first = b as u64 * BATCH_STRIDE + self.traced[b];
            let before = self.report;
            let mut cancelled = false;
            let mut inner = |p: &Progress| -> bool {
                let mut q = *p;
                if !single {
                    q.photons = before.photons + p.photons;
                    q.elapsed_s = before.elapsed_s + p.elapsed_s;
                }
                let go = progress(&q);
                cancelled |= !go;
                go
            };
            let mut params = crate::sched::RunParams {
                photons,
                time_budget_s: time_s,
                estimator: Some(self.estimator),
                progress: Some(&mut inner),
                selection: if single {
                    crate::sched::photons::Selection::ALL
                } else {
                    crate::sched::photons::Selection::range(first, (b as u64 + 1) * BATCH_STRIDE)
                },
                ..Default::default()
            };
            let r = ctx.run(&mut params)?;
            drop(params);
            self.traced[b] += r.run_photons;
            self.report.photons += r.run_photons;
            self.report.elapsed_s += r.run_wall_s;
            self.read_batch(ctx, b, r.run_photons, single)?;
            if cancelled {
                self.report.cancelled = true;
                break;
            }
        }
        Ok(self.report)
    }

    /// Target `t`'s coefficients. Refused (IMAP_ERR_OUT_OF_ORDER) while a batch has no
    /// photons: its patches' coefficients are not known.
    pub fn coefficients(&self, t: usize) -> Result<&Coefficients> {
        let Some(c) = self.merged.get(t) else {
            bail!(
                ImapErrIndexOutOfRange,
                "target {t}: the run keeps {} targets",
                self.merged.len()
            );
        };
        if let Some(b) = self.traced.iter().position(|&n| n == 0) {
            let r = &self.batches[b];
            bail!(
                ImapErrOutOfOrder,
                "patches {} … {} of MF:{} have no photons yet (batch {b} of {}): trace a round first",
                r.start,
                r.end - 1,
                self.mf,
                self.batches.len()
            );
        }
        Ok(c)
    }

    /// Gives the context back as it was before `new` (its own lights, no photons; the
    /// per-group layers stay on) and returns every target's coefficients, refused as
    /// `coefficients` refuses them.
    pub fn release(self, ctx: &mut Context) -> Result<Vec<Coefficients>> {
        ctx.reset();
        ctx.truncate_lights(self.own_lights)?;
        if !self.merged.is_empty() {
            self.coefficients(0)?;
        }
        Ok(self.merged)
    }

    /// Adds batch `b`'s patch skies, patch p in light group p − start + 1.
    fn add_batch(&self, ctx: &mut Context, b: usize) -> Result<()> {
        let (zenith, north) = self.frame;
        let r = self.batches[b].clone();
        for p in r.clone() {
            let id = ctx.add_sky(&SkyDesc {
                kind: SkyKind::single_patch(self.mf, p)?,
                amount: SkyAmount::Luminance(PATCH_LUMINANCE_CD),
                zenith,
                north,
                ..Default::default()
            })?;
            ctx.set_light_group(id, (p - r.start + 1) as u32)?;
        }
        Ok(())
    }

    /// Reads batch `b`'s layers at every target after a run that traced `photons` more:
    /// replaces them (`single`: the run continued the whole) or merges them with what
    /// the earlier rounds gave, weighted by photons.
    fn read_batch(&mut self, ctx: &Context, b: usize, photons: u64, single: bool) -> Result<()> {
        let r = self.batches[b].clone();
        let n = self.merged.first().map_or(0, |c| c.patches);
        // Earlier photons' weight in the merge, the new ones'.
        let total = self.traced[b] as f64;
        let (w_old, w_new) = if single || total == 0.0 {
            (0.0, 1.0)
        } else {
            ((total - photons as f64) / total, photons as f64 / total)
        };
        if photons == 0 && !single {
            return Ok(());
        }
        for (t, target) in self.targets.iter().enumerate() {
            let all = ctx.vertex_count(target.mesh)?;
            let (mut lux, mut rel) = (vec![0.0; all], vec![0.0; all]);
            let c = &mut self.merged[t];
            for p in r.clone() {
                let layer = Layer::Group((p - r.start + 1) as u32);
                ctx.illuminance_layer(target.mesh, target.side, layer, &mut lux)?;
                ctx.rel_error_layer(target.mesh, target.side, layer, &mut rel)?;
                for (k, &v) in target.vertices.iter().enumerate() {
                    let i = k * n + p;
                    let (x, s) = (
                        lux[v] / PATCH_LUMINANCE_CD,
                        lux[v] * rel[v] / PATCH_LUMINANCE_CD,
                    );
                    c.value[i] = w_old * c.value[i] + w_new * x;
                    c.sigma[i] = ((w_old * c.sigma[i]).powi(2) + (w_new * s).powi(2)).sqrt();
                }
            }
        }
        Ok(())
    }
}

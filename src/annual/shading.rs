//! Window groups and their shading states: an hour's light at a sensor as the sum of
//! parts, the light that comes in through no group (`Shading::base`) and each window
//! group's light in the state its rule picks for the hour (honeybee's aperture groups,
//! Radiance's 2-phase method with dynamic shading).
//!
//! Each part is a set of coefficients (and its direct sun) of its own run: a group's
//! state is traced with the group's openings in that state and every other group's
//! openings black, so that the parts add up and none is counted twice. The parts' runs
//! are independent, so their errors are: an hour's variance is the sum of the parts', and
//! the metrics' draws draw every part on its own.

use super::{check_sun, AnnualSky, Drawn, MetricOptions, Sensor, Shaded};
use crate::error::{bail, Result};

/// How a window group picks its state each hour. A group's states are ordered from the
/// most open (state 0, the one ASE counts) to the most closed.
#[derive(Clone, Debug, PartialEq)]
pub enum ShadingRule {
    /// IES LM-83's rule for operable blinds, per window group: the first state (from 0)
    /// in which no more than `MetricOptions::blinds_share` (2 %) of the points get direct
    /// sun above `MetricOptions::ase_lx` (1000 lx) through the group; the last state when
    /// none is. With two states (open, closed) it is LM-83's rule: closed in the hours in
    /// which the open group lets direct sun above 1000 lx onto more than 2 % of the points.
    /// It reads the states' direct sun (state 0 needs one; a state without one lets none
    /// through).
    DirectSun,
    /// The first state in which no more than `MetricOptions::blinds_share` of the points
    /// get more than `lx` from the group (the state's coefficients under the hour's sky and
    /// its direct sun: the group's own light, as estimated); the last when none is. A
    /// glare-avoiding occupant's rule on illuminance.
    Illuminance { lx: f64 },
    /// The host's own choice: the state of every hour of the sky (a schedule, or a glare
    /// analysis' verdicts).
    Schedule(Vec<u16>),
    /// The first state in which no more than `MetricOptions::blinds_share` of the sensors
    /// (observers' sensors, each facing its view: `annual::glare`) have a simplified DGP
    /// above `dgp` (DGPs = 6.22·10⁻⁵ Ev + 0.184), the last when none is. Ev is the whole
    /// light at the eye: the base's, the group's in the state, and every other group's in
    /// its state 0 (open), so that no group's choice waits on another's. A glare-avoiding
    /// occupant's rule: 0.40 keeps disturbing glare out (EN 17037's medium level).
    Glare { dgp: f64 },
}

/// A window group: its states' coefficients (and direct sun) at the same sensors, and the
/// rule that picks one each hour.
#[derive(Clone, Debug)]
pub struct WindowGroup<'a> {
    pub states: Vec<Shaded<'a>>,
    pub rule: ShadingRule,
}

/// A grid's light as its parts: `base`, the light that comes in through no window group
/// (the model with every group's openings black; without groups, the whole model's), and
/// the window groups, each in one of its states every hour.
#[derive(Clone, Debug, Default)]
pub struct Shading<'a> {
    pub base: Option<Shaded<'a>>,
    pub groups: Vec<WindowGroup<'a>>,
}

impl<'a> Shading<'a> {
    /// The model's coefficients `c` and direct sun `sun`, and (with `shaded`) its
    /// blinds-closed model as one window group under LM-83's rule (`metrics_with_blinds`).
    pub fn blinds(
        c: super::CoefficientsView<'a>,
        sun: Option<&'a super::DirectSun>,
        shaded: Option<Shaded<'a>>,
    ) -> Self {
        let open = Shaded {
            coefficients: c,
            sun,
        };
        match shaded {
            None => Shading {
                base: Some(open),
                groups: Vec::new(),
            },
            Some(s) => Shading {
                base: None,
                groups: vec![WindowGroup {
                    states: vec![open, s],
                    rule: ShadingRule::DirectSun,
                }],
            },
        }
    }

    /// Every part in order: the base, then each group's states.
    pub(super) fn parts(&self) -> Vec<Shaded<'a>> {
        self.base
            .iter()
            .copied()
            .chain(self.groups.iter().flat_map(|g| g.states.iter().copied()))
            .collect()
    }

    /// Whether the open parts (the base and every group's state 0) have the direct sun.
    pub(super) fn has_sun(&self) -> bool {
        self.base
            .as_ref()
            .or(self.groups.first().and_then(|g| g.states.first()))
            .is_some_and(|p| p.sun.is_some())
    }

    /// Checks the parts against `sky` and each other, and the rules against `o`; gives the
    /// sensors' and the patches' counts.
    pub(super) fn check(&self, sky: &AnnualSky, o: &MetricOptions) -> Result<(usize, usize)> {
        for (g, w) in self.groups.iter().enumerate() {
            if w.states.is_empty() || w.states.len() > u16::MAX as usize {
                bail!(
                    ImapErrInvalidArgument,
                    "window group {g} has {} states: give 1 to {}",
                    w.states.len(),
                    u16::MAX
                );
            }
        }
        let parts = self.parts();
        let Some(first) = parts.first() else {
            bail!(
                ImapErrInvalidArgument,
                "no coefficients: give the base's or a window group's"
            );
        };
        let sensors = first.coefficients.sensors;
        let n = sky.patches.count();
        let name = |g: Option<(usize, usize)>| match g {
            None => "the base".to_string(),
            Some((g, s)) => format!("window group {g}'s state {s}"),
        };
        let labelled =
            self.base
                .iter()
                .map(|p| (None, p))
                .chain(self.groups.iter().enumerate().flat_map(|(g, w)| {
                    w.states
                        .iter()
                        .enumerate()
                        .map(move |(s, p)| (Some((g, s)), p))
                }));
        let sun = self.has_sun();
        for (at, p) in labelled {
            let what = name(at);
            p.coefficients
                .check_against(sky)
                .and_then(|_| check_sun(p.coefficients, sky, p.sun))
                .map_err(|mut e| {
                    // (The base's messages stay as a lone model's were.)
                    if at.is_some() {
                        e.message = format!("{what}: {}", e.message);
                    }
                    e
                })?;
            if p.coefficients.sensors != sensors {
                bail!(
                    ImapErrInvalidArgument,
                    "{what}: coefficients of {} sensors; {}'s of {sensors}",
                    p.coefficients.sensors,
                    name(if self.base.is_some() {
                        None
                    } else {
                        Some((0, 0))
                    })
                );
            }
            // The open parts all have the direct sun or none has: ASE adds theirs.
            let open = at.is_none_or(|(_, s)| s == 0);
            if open && p.sun.is_some() != sun {
                bail!(
                    ImapErrInvalidArgument,
                    "{what} {} the direct sun and the other open parts {}: give every open part's (the base's and each group's state 0) or none",
                    if p.sun.is_some() { "has" } else { "lacks" },
                    if sun { "have it" } else { "do not" }
                );
            }
        }
        for (g, w) in self.groups.iter().enumerate() {
            match &w.rule {
                ShadingRule::DirectSun => {
                    if w.states[0].sun.is_none() {
                        bail!(
                            ImapErrInvalidArgument,
                            "window group {g}: the blinds rule reads the direct sun: give its open state's (state 0)"
                        );
                    }
                }
                ShadingRule::Illuminance { lx } => {
                    if !(lx.is_finite() && *lx > 0.0) {
                        bail!(
                            ImapErrInvalidArgument,
                            "window group {g}: the illuminance rule's lx = {lx}: must be > 0"
                        );
                    }
                }
                ShadingRule::Glare { dgp } => {
                    if !(*dgp > crate::glare::DGPS_AT_DARK && *dgp <= 1.0) {
                        bail!(
                            ImapErrInvalidArgument,
                            "window group {g}: the glare rule's dgp = {dgp}: must be above 0.184 (DGPs at Ev = 0) and at most 1"
                        );
                    }
                }
                ShadingRule::Schedule(s) => {
                    if s.len() != sky.hours.len() {
                        bail!(
                            ImapErrInvalidArgument,
                            "window group {g}: its schedule holds {} hours; the sky has {}",
                            s.len(),
                            sky.hours.len()
                        );
                    }
                    if let Some(h) = s.iter().position(|&x| x as usize >= w.states.len()) {
                        bail!(
                            ImapErrIndexOutOfRange,
                            "window group {g}: its schedule's hour {h} asks for state {}; it has {}",
                            s[h],
                            w.states.len()
                        );
                    }
                }
            }
        }
        if !(0.0..1.0).contains(&o.blinds_share) {
            bail!(
                ImapErrInvalidArgument,
                "blinds_share = {}: must be in [0, 1)",
                o.blinds_share
            );
        }
        // ASE's and the blinds rule's direct-sun illuminance.
        if !(o.ase_lx > 0.0 && o.ase_lx.is_finite()) {
            bail!(ImapErrInvalidArgument, "ase_lx = {}: must be > 0", o.ase_lx);
        }
        Ok((sensors, n))
    }

    /// Each group's state in every hour of the sky, by its rule (state 0 in the hours
    /// `counted` leaves out). Call after `check`.
    pub(super) fn states(
        &self,
        sky: &AnnualSky,
        o: &MetricOptions,
        counted: &[bool],
        threads: usize,
    ) -> Vec<Vec<u16>> {
        let hours = sky.hours.len();
        let n = sky.patches.count();
        self.groups
            .iter()
            .enumerate()
            .map(|(gi, w)| {
                let sensors = w.states[0].coefficients.sensors;
                let most = o.blinds_share * sensors as f64;
                // Per state and hour, the points above the rule's illuminance.
                let above: Vec<Vec<u32>> = match &w.rule {
                    ShadingRule::Schedule(s) => return s.clone(),
                    ShadingRule::DirectSun => w
                        .states
                        .iter()
                        .map(|p| {
                            let mut lit = vec![0u32; hours];
                            if let Some(s) = p.sun {
                                for k in 0..s.sensors {
                                    for (h, x) in s.at(k) {
                                        if x > o.ase_lx {
                                            lit[h] += 1;
                                        }
                                    }
                                }
                            }
                            lit
                        })
                        .collect(),
                    ShadingRule::Illuminance { lx } => w
                        .states
                        .iter()
                        .map(|p| {
                            let counts =
                                super::in_chunks(sensors, threads, |r: std::ops::Range<usize>| {
                                    let mut lit = vec![0u32; hours];
                                    let mut direct = vec![0.0; hours];
                                    for k in r {
                                        let s =
                                            Sensor::new(p.coefficients, p.sun, k, n, &mut direct);
                                        for (h, l) in lit.iter_mut().enumerate() {
                                            if counted[h] && s.hour(sky, h).0 > *lx {
                                                *l += 1;
                                            }
                                        }
                                    }
                                    lit
                                });
                            let mut lit = vec![0u32; hours];
                            for c in counts {
                                lit.iter_mut().zip(c).for_each(|(a, b)| *a += b);
                            }
                            lit
                        })
                        .collect(),
                    ShadingRule::Glare { dgp } => self.above_glare(gi, *dgp, sky, counted, threads),
                };
                (0..hours)
                    .map(|h| {
                        if !counted[h] {
                            return 0;
                        }
                        let last = w.states.len() - 1;
                        (0..=last)
                            .find(|&s| above[s][h] as f64 <= most)
                            .unwrap_or(last) as u16
                    })
                    .collect()
            })
            .collect()
    }

    /// Group `gi`'s glare rule: per state and hour, the sensors whose DGPs exceeds `dgp`
    /// with the group in the state, the base, and every other group open.
    fn above_glare(
        &self,
        gi: usize,
        dgp: f64,
        sky: &AnnualSky,
        counted: &[bool],
        threads: usize,
    ) -> Vec<Vec<u32>> {
        let hours = sky.hours.len();
        let n = sky.patches.count();
        let w = &self.groups[gi];
        let sensors = w.states[0].coefficients.sensors;
        let ev = crate::glare::dgps_ev(dgp);
        let others: Vec<super::Shaded> = self
            .base
            .iter()
            .copied()
            .chain(
                self.groups
                    .iter()
                    .enumerate()
                    .filter(|(g, _)| *g != gi)
                    .map(|(_, g)| g.states[0]),
            )
            .collect();
        let counts = super::in_chunks(sensors, threads, |r: std::ops::Range<usize>| {
            let mut lit = vec![vec![0u32; hours]; w.states.len()];
            let mut direct = vec![0.0; hours];
            let mut rest = vec![0.0; hours];
            for k in r {
                rest.iter_mut().for_each(|x| *x = 0.0);
                for p in &others {
                    let s = Sensor::new(p.coefficients, p.sun, k, n, &mut direct);
                    for (h, x) in rest.iter_mut().enumerate() {
                        if counted[h] {
                            *x += s.hour(sky, h).0;
                        }
                    }
                }
                for (p, l) in w.states.iter().zip(&mut lit) {
                    let s = Sensor::new(p.coefficients, p.sun, k, n, &mut direct);
                    for (h, l) in l.iter_mut().enumerate() {
                        if counted[h] && rest[h] + s.hour(sky, h).0 > ev {
                            *l += 1;
                        }
                    }
                }
            }
            lit
        });
        let mut lit = vec![vec![0u32; hours]; w.states.len()];
        for c in counts {
            for (a, b) in lit.iter_mut().zip(c) {
                a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
            }
        }
        lit
    }

    /// The scratch `SensorParts::new` borrows: an hour's direct sun per part.
    pub(super) fn scratch(&self, hours: usize) -> Vec<Vec<f64>> {
        vec![vec![0.0; hours]; self.parts().len()]
    }
}

/// One sensor's parts (`Shading::parts`), each as a draw moves it.
pub(super) struct SensorParts<'a> {
    parts: Vec<Drawn<'a>>,
    /// The index of each group's state 0 in `parts`.
    first: Vec<usize>,
    base: bool,
}

impl<'a> SensorParts<'a> {
    /// Sensor `k`'s parts; `scratch` from `Shading::scratch`.
    pub(super) fn new(
        shading: &Shading<'a>,
        k: usize,
        n: usize,
        scratch: &'a mut [Vec<f64>],
    ) -> Self {
        let parts: Vec<Drawn<'a>> = shading
            .parts()
            .into_iter()
            .zip(scratch.iter_mut())
            .map(|(p, d)| Drawn::new(Sensor::new(p.coefficients, p.sun, k, n, d)))
            .collect();
        let mut first = Vec::with_capacity(shading.groups.len());
        let mut next = usize::from(shading.base.is_some());
        for g in &shading.groups {
            first.push(next);
            next += g.states.len();
        }
        SensorParts {
            parts,
            first,
            base: shading.base.is_some(),
        }
    }

    /// The parts hour `h` reads: the base and each group's state in `states`.
    fn active<'s>(
        &'s self,
        h: usize,
        states: &'s [Vec<u16>],
    ) -> impl Iterator<Item = &'s Drawn<'a>> {
        let base = self.base.then(|| &self.parts[0]);
        base.into_iter().chain(
            self.first
                .iter()
                .zip(states)
                .map(move |(&f, s)| &self.parts[f + s[h] as usize]),
        )
    }

    /// Hour `h`'s illuminance and standard error with the groups in `states`.
    pub(super) fn hour(&self, sky: &AnnualSky, h: usize, states: &[Vec<u16>]) -> (f64, f64) {
        if self.parts.len() == 1 {
            return self.parts[0].sensor.hour(sky, h);
        }
        let (mut x, mut var) = (0.0, 0.0);
        for p in self.active(h, states) {
            let (a, s) = p.sensor.hour(sky, h);
            x += a;
            var += s * s;
        }
        (x, var.sqrt())
    }

    /// Draws every part's offsets, in order.
    pub(super) fn draw(&mut self, rng: &mut crate::sampling::PhotonRng) {
        for p in &mut self.parts {
            p.draw(rng);
        }
    }

    /// Hour `h`'s illuminance in the draw, from the estimate's `e`.
    pub(super) fn drawn(&self, sky: &AnnualSky, h: usize, e: f64, states: &[Vec<u16>]) -> f64 {
        e + self
            .active(h, states)
            .map(|p| p.offset(sky, h))
            .sum::<f64>()
    }

    /// The direct sun of hour `h` with every group open (the base's and each group's
    /// state 0's), as ASE counts it.
    pub(super) fn open_direct(&self, h: usize) -> f64 {
        let base = self.base.then(|| &self.parts[0]);
        base.into_iter()
            .chain(self.first.iter().map(|&f| &self.parts[f]))
            .filter_map(|p| p.sensor.sun.map(|s| s.2[h]))
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::super::lighting::{self, Control, Dimming};
    use super::super::tests::{sunny_toy_sky, toy_sky};
    use super::super::{metrics, metrics_with_shading, Coefficients, DirectSun};
    use super::*;

    /// `sensors` sensors reading `lx` from the toy sky's three patches (100 cd/m² each),
    /// with a standard error of `rel` of each coefficient.
    fn flat(sensors: usize, n: usize, lx: f64, rel: f64) -> Coefficients {
        let mut value = vec![0.0; sensors * n];
        for k in 0..sensors {
            for p in 1..4 {
                value[k * n + p] = lx / 300.0;
            }
        }
        Coefficients {
            sensors,
            patches: n,
            sigma: value.iter().map(|v| v * rel).collect(),
            value,
        }
    }

    /// A direct sun of 2000 lx at sensors `lit` in `hours` (none elsewhere); the sun's
    /// patch (2) holds no inter-reflected sun (its direct-only coefficient is `lx`'s).
    fn sun(
        sensors: usize,
        n: usize,
        lx: f64,
        lit: std::ops::Range<usize>,
        hours: std::ops::Range<usize>,
    ) -> DirectSun {
        let (mut offsets, mut hs, mut lux) = (vec![0], Vec::new(), Vec::new());
        for k in 0..sensors {
            if lit.contains(&k) {
                for h in hours.clone() {
                    hs.push(h as u32);
                    lux.push(2000.0f32);
                }
            }
            offsets.push(hs.len());
        }
        let mut patch_direct = vec![0.0; sensors * n];
        for k in 0..sensors {
            patch_direct[k * n + 2] = lx / 300.0;
        }
        DirectSun {
            sensors,
            patches: n,
            offsets,
            hours: hs,
            lux,
            patch_direct,
            patch_direct_sigma: vec![0.0; sensors * n],
        }
    }

    fn part<'a>(c: &'a Coefficients, s: Option<&'a DirectSun>) -> Shaded<'a> {
        Shaded {
            coefficients: c.view(),
            sun: s,
        }
    }

    /// A shading of one window group and no base.
    fn one(states: Vec<Shaded<'_>>, rule: ShadingRule) -> Shading<'_> {
        Shading {
            base: None,
            groups: vec![WindowGroup { states, rule }],
        }
    }

    #[test]
    fn window_groups_add_up_and_each_follows_its_own_rule() {
        // 50 points and 100 sunny hours. The base (openings in no group) gives 10 lx;
        // group A 200 lx open, 50 closed, its sun on points 0–1 (4 %) in hours 0–29;
        // group B 100 lx open, 20 closed, its sun on points 10–12 (6 %) in hours 50–79
        // and on point 2 alone (2 %, not more) in hours 85–94.
        let hours = 100;
        let sky = sunny_toy_sky(hours);
        let n = sky.patches.count();
        let k = 50;
        let base = flat(k, n, 10.0, 0.0);
        let (a_open, a_shut) = (flat(k, n, 200.0, 0.0), flat(k, n, 50.0, 0.0));
        let (b_open, b_shut) = (flat(k, n, 100.0, 0.0), flat(k, n, 20.0, 0.0));
        let base_sun = sun(k, n, 10.0, 0..0, 0..0);
        let a_sun = sun(k, n, 200.0, 0..2, 0..30);
        let mut b_sun = sun(k, n, 100.0, 10..13, 50..80);
        // Point 2's ten hours of B's sun, at the end of its (empty) list.
        let b2 = sun(k, n, 100.0, 2..3, 85..95);
        b_sun = {
            let (mut offsets, mut hs, mut lux) = (vec![0], Vec::new(), Vec::new());
            for p in 0..k {
                for s in [&b_sun, &b2] {
                    let r = s.offsets[p]..s.offsets[p + 1];
                    hs.extend_from_slice(&s.hours[r.clone()]);
                    lux.extend_from_slice(&s.lux[r]);
                }
                offsets.push(hs.len());
            }
            DirectSun {
                offsets,
                hours: hs,
                lux,
                ..b_sun
            }
        };
        let group = |open, shut, rule| WindowGroup {
            states: vec![open, shut],
            rule,
        };
        let shading = Shading {
            base: Some(part(&base, Some(&base_sun))),
            groups: vec![
                group(
                    part(&a_open, Some(&a_sun)),
                    part(&a_shut, None),
                    ShadingRule::DirectSun,
                ),
                group(
                    part(&b_open, Some(&b_sun)),
                    part(&b_shut, None),
                    ShadingRule::DirectSun,
                ),
            ],
        };
        let o = MetricOptions {
            ase_hours: 20,
            draws: 0,
            ..MetricOptions::default()
        };
        let m = metrics_with_shading(&shading, &sky, &o).unwrap();
        // Each group closes for its own sun: A in hours 0–29, B in 50–79 (not for point
        // 2's 2 %).
        assert_eq!(m.group_state_hours, vec![vec![70, 30], vec![70, 30]]);
        assert_eq!(m.blinds_closed_hours, 60);
        // Point 20 (no sun): 310 lx with both open (40 hours), 160 with A closed, 230
        // with B closed.
        let p = m.sensors[20];
        assert!((p.da - 0.4).abs() < 1e-12, "{p:?}");
        let cda = (30.0 * 160.0 / 300.0 + 30.0 * 230.0 / 300.0 + 40.0) / 100.0;
        assert!((p.cda - cda).abs() < 1e-12, "{} {cda}", p.cda);
        // Hour by hour, the same states.
        let (e, _) = super::super::hourly_with_shading(&shading, &sky, &o, 0..hours).unwrap();
        for (h, want) in [(10, 160.0), (40, 310.0), (60, 230.0), (90, 310.0)] {
            assert!(
                (e[h * k + 20] - want).abs() < 1e-9,
                "hour {h}: {}",
                e[h * k + 20]
            );
        }
        // Every group open: the states 0 and the base add up (the daylight factor's model).
        let open = Coefficients::sum(&[base.view(), a_open.view(), b_open.view()]).unwrap();
        assert!((open.value[20 * n + 1] - 310.0 / 300.0).abs() < 1e-12);
        assert!(Coefficients::sum(&[base.view(), flat(3, n, 1.0, 0.0).view()]).is_err());
        // ASE counts every group open: points 0, 1 and 10–12, 30 hours each.
        assert_eq!(m.ase, Some(5.0 / 50.0));
        assert_eq!(m.sensors[2].ase_hours, 10);
        assert_eq!(m.sensors[11].ase_hours, 30);

        // The host's schedule: B closed every hour.
        let mut scheduled = shading.clone();
        scheduled.groups[1].rule = ShadingRule::Schedule(vec![1; hours]);
        let s = metrics_with_shading(&scheduled, &sky, &o).unwrap();
        assert_eq!(s.group_state_hours[1], vec![0, 100]);
        // The illuminance rule on A's own light: 200 + 2000 lx at points 0–1 (4 %) in
        // hours 0–29 is above 1500 lx; 200 lx elsewhere is not.
        let mut bright = shading.clone();
        bright.groups[0].rule = ShadingRule::Illuminance { lx: 1500.0 };
        let b = metrics_with_shading(&bright, &sky, &o).unwrap();
        assert_eq!(b.group_state_hours[0], vec![70, 30]);
        bright.groups[0].rule = ShadingRule::Illuminance { lx: 150.0 };
        let b = metrics_with_shading(&bright, &sky, &o).unwrap();
        assert_eq!(b.group_state_hours[0], vec![0, 100]);

        // Electric light at point 20, 500 lx at full output, dimmed to nothing: output
        // 0.38, 0.68 and 0.54 in the three kinds of hour, 51.8 kWh at 1 kW.
        let zone = Dimming {
            target_lx: 500.0,
            sensor: 20,
            control: Control::Continuous,
            min_output: 0.0,
            min_power: 0.0,
            power_w: 1000.0,
        };
        let electric = vec![(500.0, 0.0); k];
        let l = lighting::lighting_with_shading(&shading, &sky, &electric, &zone, &o).unwrap();
        assert!((l.energy_kwh - 51.8).abs() < 1e-9, "{}", l.energy_kwh);
    }

    #[test]
    fn one_group_of_one_state_is_its_coefficients_and_the_parts_errors_add() {
        let hours = 40;
        let sky = sunny_toy_sky(hours);
        let n = sky.patches.count();
        let k = 12;
        let c = flat(k, n, 350.0, 0.2);
        let s = sun(k, n, 350.0, 0..3, 0..20);
        let o = MetricOptions {
            draws: 30,
            ..MetricOptions::default()
        };
        let alone = metrics(&c, &sky, Some(&s), &o).unwrap();
        let grouped = Shading {
            base: None,
            groups: vec![WindowGroup {
                states: vec![Shaded {
                    coefficients: c.view(),
                    sun: Some(&s),
                }],
                rule: ShadingRule::DirectSun,
            }],
        };
        let g = metrics_with_shading(&grouped, &sky, &o).unwrap();
        assert_eq!(g.sensors, alone.sensors);
        assert_eq!(g.sda_interval, alone.sda_interval);
        assert_eq!(g.group_state_hours, vec![vec![40]]);
        // Two parts of independent errors: the hour's variance is the sum of theirs.
        let other = flat(k, n, 100.0, 0.5);
        let other_sun = sun(k, n, 100.0, 0..0, 0..0);
        let two = Shading {
            base: Some(Shaded {
                coefficients: other.view(),
                sun: Some(&other_sun),
            }),
            ..grouped.clone()
        };
        // (Under a sky without the sun: the sun's patch carries its own error.)
        let sky = toy_sky(hours, |_, _| 100.0);
        let mut scratch = two.scratch(hours);
        let parts = SensorParts::new(&two, 5, n, &mut scratch);
        let states = two.states(&sky, &o, &vec![true; hours], 1);
        let (x, sx) = parts.hour(&sky, 30, &states);
        assert!((x - 450.0).abs() < 1e-9, "{x}");
        let want = ((350.0f64 * 0.2).powi(2) / 3.0 + (100.0f64 * 0.5).powi(2) / 3.0).sqrt();
        assert!((sx - want).abs() < 1e-9 * want, "{sx} {want}");
    }

    #[test]
    fn bad_window_groups_are_refused_by_name() {
        let hours = 10;
        let sky = sunny_toy_sky(hours);
        let n = sky.patches.count();
        let c = flat(4, n, 100.0, 0.0);
        let few = flat(3, n, 100.0, 0.0);
        let s = sun(4, n, 100.0, 0..1, 0..2);
        let o = MetricOptions::default();
        let err = |sh: &Shading| metrics_with_shading(sh, &sky, &o).unwrap_err().message;
        assert!(err(&Shading::default()).contains("no coefficients"));
        assert!(err(&one(vec![], ShadingRule::DirectSun)).contains("window group 0 has 0 states"));
        let m = err(&one(
            vec![part(&c, Some(&s)), part(&few, None)],
            ShadingRule::DirectSun,
        ));
        assert!(m.contains("state 1") && m.contains("3 sensors"), "{m}");
        let m = err(&one(vec![part(&c, None)], ShadingRule::DirectSun));
        assert!(m.contains("reads the direct sun"), "{m}");
        let m = err(&one(
            vec![part(&c, None)],
            ShadingRule::Illuminance { lx: f64::NAN },
        ));
        assert!(m.contains("lx = NaN"), "{m}");
        let m = err(&one(
            vec![part(&c, None)],
            ShadingRule::Schedule(vec![0; 9]),
        ));
        assert!(m.contains("schedule holds 9 hours"), "{m}");
        let m = err(&one(
            vec![part(&c, None), part(&c, None)],
            ShadingRule::Schedule(vec![2; 10]),
        ));
        assert!(m.contains("asks for state 2"), "{m}");
        // An open part with the direct sun beside one without.
        let mixed = Shading {
            base: Some(part(&c, None)),
            groups: vec![WindowGroup {
                states: vec![part(&c, Some(&s))],
                rule: ShadingRule::DirectSun,
            }],
        };
        let m = err(&mixed);
        assert!(m.contains("the direct sun"), "{m}");
        // A closed state may lack it.
        let fine = one(
            vec![part(&c, Some(&s)), part(&c, None)],
            ShadingRule::DirectSun,
        );
        assert!(metrics_with_shading(&fine, &sky, &o).is_ok());
    }
}

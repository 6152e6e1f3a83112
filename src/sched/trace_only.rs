//! The limit for benchmarks: the same photons traced by the same threads with every deposit
//! discarded (Embree tracing and surface events alone, no portions, no map).

use super::{Counters, PhotonSource, RunContext, RunMonitor, RunOutcome, RunParams, StopGuard};
use crate::imap::IMap;
use crate::spectral::Colour;
use crate::transport::{HitSink, PathStats};

struct Discard;

impl HitSink for Discard {
    #[inline]
    fn deposit(&mut self, _: (u32, u32, u8), _: (f32, f32), _: &Colour, _: Option<[f32; 3]>) {}
}

/// Traces until a stop criterion is met; the map is not touched.
pub fn run(rc: &RunContext, map: &IMap, params: &mut RunParams) -> RunOutcome {
    let source = PhotonSource::new(rc.plan.clone(), rc.selection);
    let mut monitor = RunMonitor::new(params, rc);
    let mut stats = PathStats::new(rc.scene.meshes.len());
    let mut thread_lost = None;
    std::thread::scope(|s| {
        let _stop = StopGuard(&source);
        let handles: Vec<_> = (0..rc.threads)
            .map(|_| {
                let (source, tracer) = (&source, &rc.tracer);
                s.spawn(move || {
                    crate::error::quiet_thread();
                    let mut stats = PathStats::new(tracer.scene.meshes.len());
                    let mut colour = Colour::new(tracer.bands);
                    super::trace_all(source, tracer, &mut colour, &mut Discard, &mut stats);
                    stats
                })
            })
            .collect();
        while !handles.iter().all(|h| h.is_finished()) {
            std::thread::sleep(monitor.timeout().min(std::time::Duration::from_millis(1)));
            monitor.poll(
                &source,
                rc,
                &|n| super::global_error(map, rc, n),
                map,
                &super::target::Exclusive,
            );
        }
        for h in handles {
            match h.join() {
                Ok(st) => stats.merge(&st),
                Err(_) => thread_lost = Some("a tracing thread panicked".to_string()),
            }
        }
    });
    monitor.outcome(&source, map, rc, stats, Counters::default(), thread_lost)
}

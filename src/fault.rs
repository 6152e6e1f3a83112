//! Fault injection for tests of the library's failure paths (a worker thread that
//! panics, a monitor that unwinds), built only with the `fault-injection` feature (the
//! test command's): then read once from the environment variable `IMAP_TEST_FAULT`
//! (comma-separated points). Without the feature every check is nothing, and the library
//! reads no environment variable.
//!
//! Points: `calc-panic` (a calculating thread panics at its first batch), `process-panic`
//! (a dynamic scheduler's processing thread panics on its first portion), `monitor-panic`
//! (the thread driving a run panics at its first progress check), `render-panic` (a render
//! thread panics in its first phase).

#[cfg(feature = "fault-injection")]
use std::sync::OnceLock;

#[cfg(feature = "fault-injection")]
#[derive(Debug, Default)]
struct Faults {
    calc: bool,
    process: bool,
    monitor: bool,
    render: bool,
}

#[cfg(feature = "fault-injection")]
fn faults() -> &'static Faults {
    static F: OnceLock<Faults> = OnceLock::new();
    F.get_or_init(|| {
        let v = std::env::var("IMAP_TEST_FAULT").unwrap_or_default();
        let has = |p: &str| v.split(',').any(|x| x.trim() == p);
        Faults {
            calc: has("calc-panic"),
            process: has("process-panic"),
            monitor: has("monitor-panic"),
            render: has("render-panic"),
        }
    })
}

/// Panics when `IMAP_TEST_FAULT` names `point`.
#[cfg(feature = "fault-injection")]
#[inline]
pub(crate) fn at(point: Point) {
    let f = faults();
    let on = match point {
        Point::Calc => f.calc,
        Point::Process => f.process,
        Point::Monitor => f.monitor,
        Point::Render => f.render,
    };
    if on {
        panic!("injected fault ({point:?}, IMAP_TEST_FAULT)");
    }
}

/// Nothing: faults are injected only with the `fault-injection` feature.
#[cfg(not(feature = "fault-injection"))]
#[inline(always)]
pub(crate) fn at(_point: Point) {}

#[derive(Clone, Copy, Debug)]
#[cfg_attr(not(feature = "fault-injection"), allow(dead_code))]
pub(crate) enum Point {
    Calc,
    Process,
    Monitor,
    Render,
}

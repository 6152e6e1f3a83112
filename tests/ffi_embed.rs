//! Safe to embed, through the C ABI: error-message lifetimes under
//! concurrency, status names of any int, silence, lost threads and running out of memory.
//! Tests that need a fault injected or a memory limit run in a child process: this test
//! binary re-runs itself with `IMAP_EMBED_CHILD` set, so an abort or a print shows.

use imap::ffi::*;
use imap::ImapStatus;
use std::ffi::CStr;
use std::process::Command;
use std::time::{Duration, Instant};

/// A context handle that may cross threads (the C ABI allows calls from any thread).
#[derive(Clone, Copy)]
struct Handle(*mut ImapContext);
// SAFETY: libimap contexts may be used from any thread, one call at a time (the library
// answers IMAP_ERR_BUSY to the others).
unsafe impl Send for Handle {}
// SAFETY: as above.
unsafe impl Sync for Handle {}

fn message(ctx: *const ImapContext) -> String {
    // SAFETY: imap_last_error never returns NULL.
    unsafe { CStr::from_ptr(imap_last_error(ctx)) }
        .to_string_lossy()
        .into_owned()
}

fn ok(s: ImapStatus, ctx: *const ImapContext) {
    assert_eq!(s, ImapStatus::ImapOk, "{}", message(ctx));
}

/// A context with a recording floor under a point light (2 threads).
fn scene() -> (Handle, u32, usize) {
    scene_with(|_| {})
}

/// The defaults, from `imap_config_default`.
fn default_config() -> ImapConfig {
    let mut cfg = std::mem::MaybeUninit::<ImapConfig>::uninit();
    // SAFETY: the out-pointer holds sizeof(ImapConfig) bytes, which the call fills.
    unsafe {
        ok(
            imap_config_default(cfg.as_mut_ptr(), std::mem::size_of::<ImapConfig>()),
            std::ptr::null(),
        );
        cfg.assume_init()
    }
}

/// `scene` with the configuration adjusted by `tweak`.
fn scene_with(tweak: impl FnOnce(&mut ImapConfig)) -> (Handle, u32, usize) {
    let mut cfg = default_config();
    cfg.threads = 2;
    tweak(&mut cfg);
    let mut ctx = std::ptr::null_mut();
    // SAFETY: valid pointers throughout; arrays outlive the calls (the library copies).
    unsafe {
        ok(imap_create(&cfg, &mut ctx), std::ptr::null());
        let grey = 0.5;
        let mut m = std::mem::zeroed::<ImapMaterial>();
        ok(
            imap_material_default(&mut m, std::mem::size_of_val(&m)),
            ctx,
        );
        m.diffuse_reflectance = &grey;
        m.diffuse_reflectance_count = 1;
        let mut mat = 0;
        ok(imap_add_material(ctx, &m, &mut mat), ctx);
        let n = 16usize;
        let mut xyz = Vec::new();
        let mut idx = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                xyz.extend([i as f64 / n as f64, j as f64 / n as f64, 0.0]);
            }
        }
        for j in 0..n as u32 {
            for i in 0..n as u32 {
                let a = j * (n as u32 + 1) + i;
                idx.extend([
                    a,
                    a + 1,
                    a + n as u32 + 2,
                    a,
                    a + n as u32 + 2,
                    a + n as u32 + 1,
                ]);
            }
        }
        let mut d = std::mem::zeroed::<ImapMesh>();
        ok(imap_mesh_default(&mut d, std::mem::size_of_val(&d)), ctx);
        d.positions = xyz.as_ptr();
        d.vertex_count = xyz.len() / 3;
        d.indices = idx.as_ptr();
        d.triangle_count = idx.len() / 3;
        d.material = mat;
        d.flags = IMAP_MESH_RECORD;
        let mut mesh = 0;
        ok(imap_add_mesh(ctx, &d, &mut mesh), ctx);
        let (pos, w) = ([0.3, 0.6, 1.0], 10.0);
        let mut light = 0;
        ok(
            imap_add_point_light(ctx, pos.as_ptr(), &w, 1, &mut light),
            ctx,
        );
        (Handle(ctx), mesh, d.vertex_count)
    }
}

fn run_params() -> ImapRunParams {
    let mut p = std::mem::MaybeUninit::<ImapRunParams>::uninit();
    // SAFETY: the out-pointer holds sizeof(ImapRunParams) bytes.
    unsafe {
        ok(
            imap_run_params_default(p.as_mut_ptr(), std::mem::size_of::<ImapRunParams>()),
            std::ptr::null(),
        );
        p.assume_init()
    }
}

/// A thread's message is its own. While one thread runs, two others get
/// IMAP_ERR_BUSY over and over: each one's message pointer stays valid and unchanged
/// however often the other fails, and the running thread's own earlier message survives.
#[test]
fn error_messages_belong_to_the_calling_thread() {
    let (h, mesh, _) = scene();
    let ctx = h.0;
    // The running thread's own failure, before the run: a bad band.
    let mut out = [0.0; 512];
    // SAFETY: valid handle and buffer.
    let s = unsafe { imap_get_vertex_energy(ctx, mesh, 0, 9, out.as_mut_ptr(), out.len()) };
    assert_eq!(s, ImapStatus::ImapErrIndexOutOfRange);
    let mine = message(ctx);
    assert!(mine.contains("band 9"), "{mine}");
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let pollers: Vec<_> = (0..2)
        .map(|_| {
            let stop = stop.clone();
            std::thread::spawn(move || {
                // The whole handle moves in (a closure would capture only the raw field).
                let h = h;
                let ctx = h.0;
                let mut out = [0.0; 512];
                let mut first: Option<(usize, String)> = None;
                let mut busy = 0;
                while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                    // SAFETY: valid handle and buffer.
                    let s = unsafe {
                        imap_get_vertex_energy(ctx, mesh, 0, 0, out.as_mut_ptr(), out.len())
                    };
                    if s != ImapStatus::ImapErrBusy {
                        continue;
                    }
                    busy += 1;
                    let p = imap_last_error_ptr(ctx);
                    // SAFETY: the library keeps the string alive until this thread's next
                    // failing call on ctx.
                    let text = unsafe { CStr::from_ptr(p as *const _) }
                        .to_string_lossy()
                        .into_owned();
                    match &first {
                        None => first = Some((p, text.clone())),
                        // Our own next failure may replace it, but only with our own text.
                        Some((_, t0)) => assert_eq!(&text, t0),
                    }
                    // The pointer we hold stays readable while the other thread fails.
                    std::thread::yield_now();
                    let again = unsafe { CStr::from_ptr(p as *const _) }
                        .to_string_lossy()
                        .into_owned();
                    assert_eq!(again, text, "the message changed under this thread");
                }
                busy
            })
        })
        .collect();
    let mut p = run_params();
    p.time_budget_s = 1.0;
    // The pollers may hold the context at the moment the run starts: then the run is the
    // one that gets IMAP_ERR_BUSY (that is the contract), and tries again.
    let s = loop {
        // SAFETY: valid handle and params.
        let s = unsafe { imap_run(ctx, &p, std::ptr::null_mut(), 0) };
        if s != ImapStatus::ImapErrBusy {
            break s;
        }
    };
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    ok(s, ctx);
    let busy: Vec<u64> = pollers.into_iter().map(|t| t.join().unwrap()).collect();
    eprintln!("BUSY answers while the run held the context: {busy:?}");
    assert!(busy.iter().all(|&b| b > 0), "the pollers never saw the run");
    // The running thread's message is still its own (a BUSY of its own run, above, would
    // have been its own too: take the message again in that case).
    let now = message(ctx);
    assert!(
        now == mine || now.contains("in use by another call"),
        "{now}"
    );
    assert!(!now.is_empty());
    // SAFETY: no call is using the context any more.
    unsafe { imap_destroy(ctx) };
}

fn imap_last_error_ptr(ctx: *const ImapContext) -> usize {
    // SAFETY: a live handle.
    unsafe { imap_last_error(ctx) as usize }
}

/// Any int has a name, and the name of a status is its C name.
#[test]
fn every_int_has_a_status_name() {
    for v in [-1, 21, 22, 1_000_000, i32::MIN, i32::MAX, 14] {
        // SAFETY: the library returns a static string for any int.
        let name = unsafe { CStr::from_ptr(imap_status_name(v)) }
            .to_str()
            .unwrap();
        assert!(name.starts_with("IMAP_"), "{v}: {name}");
    }
    // SAFETY: as above.
    let busy = unsafe { CStr::from_ptr(imap_status_name(14)) };
    assert_eq!(busy.to_str().unwrap(), "IMAP_ERR_BUSY");
    // SAFETY: as above.
    let unknown = unsafe { CStr::from_ptr(imap_status_name(-1)) };
    assert_eq!(unknown.to_str().unwrap(), "IMAP_ERR_UNKNOWN_STATUS");
}

/// Versioned structs: a zeroed struct is refused with the name of its initialiser, a
/// struct from a "newer header" with an unknown field set is refused, one with it left 0
/// is accepted.
#[test]
fn versioned_structs_are_checked() {
    let (h, _, _) = scene();
    let ctx = h.0;
    // SAFETY: a zeroed struct of the right size.
    let zero: ImapRunParams = unsafe { std::mem::zeroed() };
    // SAFETY: valid pointers.
    let s = unsafe { imap_run(ctx, &zero, std::ptr::null_mut(), 0) };
    assert_eq!(s, ImapStatus::ImapErrInvalidArgument);
    assert!(
        message(ctx).contains("imap_run_params_default"),
        "{}",
        message(ctx)
    );
    // A newer program's larger struct.
    #[repr(C)]
    struct Newer {
        p: ImapRunParams,
        new_field: u64,
    }
    let mut n = Newer {
        p: run_params(),
        new_field: 0,
    };
    let size = std::mem::size_of::<Newer>();
    // SAFETY: `n` has `size` bytes.
    ok(
        unsafe { imap_run_params_default(&mut n.p, size) },
        std::ptr::null(),
    );
    assert_eq!(n.p.struct_size as usize, size);
    n.p.photons = 1000;
    // SAFETY: valid pointers; the library reads struct_size bytes.
    ok(unsafe { imap_run(ctx, &n.p, std::ptr::null_mut(), 0) }, ctx);
    n.new_field = 7;
    // SAFETY: as above.
    let s = unsafe { imap_run(ctx, &n.p, std::ptr::null_mut(), 0) };
    assert_eq!(s, ImapStatus::ImapErrInvalidArgument);
    assert!(message(ctx).contains("newer imap.h"), "{}", message(ctx));
    // An output struct too small for the first layout is refused before the run.
    let mut r = ImapReport::default();
    // SAFETY: as above.
    let s = unsafe { imap_run(ctx, &run_params_with(500), &mut r, 8) };
    assert_eq!(s, ImapStatus::ImapErrInvalidArgument);
    let mut rep = ImapReport::default();
    // SAFETY: as above.
    ok(
        unsafe { imap_get_report(ctx, &mut rep, std::mem::size_of_val(&rep)) },
        ctx,
    );
    assert_eq!(rep.photons, 1000, "the refused runs traced nothing");
    // SAFETY: no call is using the context any more.
    unsafe { imap_destroy(ctx) };
}

fn run_params_with(photons: u64) -> ImapRunParams {
    let mut p = run_params();
    p.photons = photons;
    p
}

/// Through the C ABI: a buffer larger than the mesh; out-parameters untouched on
/// failure.
#[test]
fn buffers_through_the_c_abi() {
    let (h, mesh, nv) = scene();
    let ctx = h.0;
    // SAFETY: valid handle and params.
    ok(
        unsafe { imap_run(ctx, &run_params_with(5000), std::ptr::null_mut(), 0) },
        ctx,
    );
    let mut out = vec![-1.0; nv + 100];
    // SAFETY: `out` holds out.len() doubles.
    ok(
        unsafe { imap_get_vertex_energy(ctx, mesh, 0, 0, out.as_mut_ptr(), out.len()) },
        ctx,
    );
    assert!(out[nv..].iter().all(|x| *x == -1.0));
    let mut small = vec![-1.0; nv - 1];
    // SAFETY: `small` holds small.len() doubles.
    let s = unsafe { imap_get_vertex_energy(ctx, mesh, 0, 0, small.as_mut_ptr(), small.len()) };
    assert_eq!(s, ImapStatus::ImapErrBufferTooSmall);
    assert!(small.iter().all(|x| *x == -1.0), "written on failure");
    // SAFETY: no call is using the context any more.
    unsafe { imap_destroy(ctx) };
}

/// Runs this test binary's `test` in a child process with `env`; returns (stdout, stderr,
/// exit status).
fn child(test: &str, env: &[(&str, &str)]) -> (String, String, Option<i32>) {
    let exe = std::env::current_exe().unwrap();
    let mut cmd = Command::new(exe);
    cmd.args(["--exact", test, "--nocapture", "--test-threads=1"])
        .env("IMAP_EMBED_CHILD", "1");
    for (k, v) in env {
        cmd.env(k, v);
    }
    let out = cmd.output().unwrap();
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        out.status.code(),
    )
}

fn is_child() -> bool {
    std::env::var_os("IMAP_EMBED_CHILD").is_some()
}

/// The child side of `lost_threads_return_a_status_and_print_nothing`: a run or render with a fault injected; prints the status
/// and whether the context answers afterwards.
#[test]
fn child_fault() {
    if !is_child() {
        return;
    }
    let what = std::env::var("IMAP_TEST_FAULT").unwrap();
    // Portions must reach the processing threads for one of them to fail.
    let (h, _, _) = scene_with(|c| c.inline_apply = IMAP_INLINE_NEVER);
    let ctx = h.0;
    let t = Instant::now();
    let s = if what == "render-panic" {
        let mut cam = std::mem::MaybeUninit::<ImapCamera>::uninit();
        let mut rp = std::mem::MaybeUninit::<ImapRenderParams>::uninit();
        // SAFETY: out-pointers hold their struct sizes; the buffers below are large enough.
        unsafe {
            ok(
                imap_camera_default(cam.as_mut_ptr(), std::mem::size_of::<ImapCamera>()),
                ctx,
            );
            ok(
                imap_render_params_default(
                    rp.as_mut_ptr(),
                    std::mem::size_of::<ImapRenderParams>(),
                ),
                ctx,
            );
            let mut cam = cam.assume_init();
            let mut rp = rp.assume_init();
            cam.position = [0.5, 0.5, 2.0];
            cam.width = 16;
            cam.height = 16;
            rp.passes = 4;
            let mut img = vec![0.0; 16 * 16 * 3];
            imap_render(
                ctx,
                &cam,
                &rp,
                img.as_mut_ptr(),
                img.len(),
                std::ptr::null_mut(),
                0,
                std::ptr::null_mut(),
                0,
            )
        }
    } else {
        let mut p = run_params();
        p.photons = 200_000;
        p.progress_interval_s = 0.01;
        // SAFETY: valid handle and params.
        unsafe { imap_run(ctx, &p, std::ptr::null_mut(), 0) }
    };
    let secs = t.elapsed().as_secs_f64();
    let mut rep = ImapReport::default();
    // SAFETY: valid handle and buffer.
    let after = unsafe { imap_get_report(ctx, &mut rep, std::mem::size_of_val(&rep)) };
    println!(
        "CHILD {what}: status {s:?} after {secs:.2} s, message \"{}\"; then imap_get_report: {after:?}",
        message(ctx)
    );
    // SAFETY: no call is using the context any more.
    unsafe { imap_destroy(ctx) };
}

/// and the lost-thread paths: a worker that panics (calculating thread,
/// processing thread, render thread) or a monitor that unwinds: the call returns a status
/// in bounded time, the context answers afterwards (not stuck BUSY), and nothing is
/// printed on stderr.
#[test]
#[cfg_attr(
    not(feature = "fault-injection"),
    ignore = "injects faults: needs --features fault-injection (the test command's)"
)]
fn lost_threads_return_a_status_and_print_nothing() {
    if is_child() {
        return;
    }
    for (fault, want) in [
        ("calc-panic", "ImapErrThreadLost"),
        ("process-panic", "ImapErrThreadLost"),
        ("monitor-panic", "ImapErrInternal"),
        ("render-panic", "ImapErrThreadLost"),
    ] {
        let t = Instant::now();
        let (out, err, code) = child("child_fault", &[("IMAP_TEST_FAULT", fault)]);
        let line = out
            .lines()
            .find_map(|l| l.find("CHILD").map(|i| &l[i..]))
            .unwrap_or_else(|| {
                panic!("{fault}: no result (exit {code:?}); stdout:\n{out}\nstderr:\n{err}")
            });
        eprintln!("{line}");
        assert!(line.contains(want), "{fault}: {line}");
        assert!(line.ends_with("imap_get_report: ImapOk"), "{fault}: {line}");
        assert!(t.elapsed() < Duration::from_secs(60), "{fault}: too slow");
        assert!(
            !err.contains("panicked"),
            "{fault}: the library printed on stderr:\n{err}"
        );
        assert_eq!(code, Some(0), "{fault}: child exit");
    }
}

fn vm_size() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status.lines().find(|l| l.starts_with("VmSize:")).unwrap();
    line.split_whitespace()
        .nth(1)
        .unwrap()
        .parse::<u64>()
        .unwrap()
        * 1024
}

fn limit_address_space(bytes: u64) {
    let lim = libc_rlimit(bytes);
    // SAFETY: setrlimit with a valid struct; the hard limit stays as it was.
    let r = unsafe {
        setrlimit(9 /* RLIMIT_AS */, &lim)
    };
    assert_eq!(r, 0, "setrlimit");
}

#[repr(C)]
struct RLimit {
    cur: u64,
    max: u64,
}

fn libc_rlimit(cur: u64) -> RLimit {
    RLimit { cur, max: u64::MAX }
}

extern "C" {
    fn setrlimit(resource: i32, rlim: *const RLimit) -> i32;
}

/// The child side of `out_of_memory_is_a_status`: under an address-space limit, adding a mesh whose copy
/// does not fit, and preparing a scene that does not fit, return IMAP_ERR_OUT_OF_MEMORY;
/// with the limit raised again the same context works.
#[test]
fn child_oom() {
    if !is_child() {
        return;
    }
    let (h, mesh, _) = scene();
    let ctx = h.0;
    // SAFETY: valid handle and params.
    ok(
        unsafe { imap_run(ctx, &run_params_with(2000), std::ptr::null_mut(), 0) },
        ctx,
    );
    // SAFETY: as above.
    ok(unsafe { imap_reset(ctx) }, ctx);
    // The caller's arrays: a 2449 × 2449 grid, 6 M vertices (144 MB) and 12 M triangles
    // (144 MB).
    let n = 2449u32;
    let nv = ((n + 1) * (n + 1)) as usize;
    let mut xyz = Vec::with_capacity(3 * nv);
    for j in 0..=n {
        for i in 0..=n {
            xyz.extend([i as f64 / n as f64, j as f64 / n as f64, 0.0]);
        }
    }
    let mut idx = Vec::with_capacity(6 * (n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            idx.extend([a, a + 1, a + n + 2, a, a + n + 2, a + n + 1]);
        }
    }
    let mut d = unsafe { std::mem::zeroed::<ImapMesh>() };
    // SAFETY: `d` holds sizeof(ImapMesh) bytes.
    ok(
        unsafe { imap_mesh_default(&mut d, std::mem::size_of_val(&d)) },
        ctx,
    );
    d.positions = xyz.as_ptr();
    d.vertex_count = nv;
    d.indices = idx.as_ptr();
    d.triangle_count = idx.len() / 3;
    d.flags = IMAP_MESH_RECORD;
    // 1. The copy cannot be made: 64 MB of room for a 216 MB copy.
    limit_address_space(vm_size() + (64 << 20));
    let mut id = u32::MAX;
    // SAFETY: valid pointers.
    let s = unsafe { imap_add_mesh(ctx, &d, &mut id) };
    println!("CHILD add_mesh under the limit: {s:?} \"{}\"", message(ctx));
    assert_eq!(id, u32::MAX, "out_id written on failure");
    // The context is intact and usable under the limit.
    let mut out = vec![0.0; 17 * 17];
    // SAFETY: valid pointers.
    let after = unsafe { imap_run(ctx, &run_params_with(2000), std::ptr::null_mut(), 0) };
    let read = unsafe { imap_get_vertex_energy(ctx, mesh, 0, 0, out.as_mut_ptr(), out.len()) };
    println!(
        "CHILD small run under the limit: {after:?}, read {read:?}, sum {}",
        out.iter().sum::<f64>()
    );
    // 2. With room, the mesh goes in; preparing it cannot, under the limit.
    limit_address_space(u64::MAX);
    // SAFETY: as above.
    ok(unsafe { imap_reset(ctx) }, ctx);
    ok(unsafe { imap_add_mesh(ctx, &d, &mut id) }, ctx);
    drop(xyz);
    drop(idx);
    limit_address_space(vm_size() + (64 << 20));
    // SAFETY: as above.
    let s = unsafe { imap_run(ctx, &run_params_with(2000), std::ptr::null_mut(), 0) };
    println!(
        "CHILD run (prepare) under the limit: {s:?} \"{}\"",
        message(ctx)
    );
    limit_address_space(u64::MAX);
    // SAFETY: as above.
    let s = unsafe { imap_run(ctx, &run_params_with(2000), std::ptr::null_mut(), 0) };
    println!("CHILD run with room again: {s:?}");
    // SAFETY: no call is using the context any more.
    unsafe { imap_destroy(ctx) };
}

/// Running out of memory is a status, never an abort, and the context survives.
#[test]
fn out_of_memory_is_a_status() {
    if is_child() {
        return;
    }
    // One malloc arena in the child: glibc creates an arena (a 64 MiB reservation of
    // address space) for a thread that finds the others' arenas locked, which happens only
    // when the machine is loaded; when ASLR happens to align that reservation it takes the
    // whole 64 MB of headroom, and the next thread the run starts cannot map its signal
    // stack, which std answers by aborting (seen once in a clean-clone rehearsal of the test
    // command; 0 of 50 runs on an idle machine). The arenas are the C library's, not
    // libimap's: with one, the limit measures what the library itself asks for.
    let (out, err, code) = child("child_oom", &[("MALLOC_ARENA_MAX", "1")]);
    let lines: Vec<&str> = out
        .lines()
        .filter_map(|l| l.find("CHILD").map(|i| &l[i..]))
        .collect();
    for l in &lines {
        eprintln!("{l}");
    }
    assert_eq!(
        code,
        Some(0),
        "child exit (an abort shows here)\n{out}\n{err}"
    );
    assert_eq!(lines.len(), 4, "{out}\n{err}");
    assert!(lines[0].contains("ImapErrOutOfMemory"), "{}", lines[0]);
    assert!(lines[1].contains("ImapOk, read ImapOk"), "{}", lines[1]);
    assert!(lines[2].contains("ImapErrOutOfMemory"), "{}", lines[2]);
    assert!(lines[3].ends_with("ImapOk"), "{}", lines[3]);
    assert!(!err.contains("memory allocation"), "{err}");
}

/// Through the C ABI: IMAP_MESH_SKIP_DEGENERATE leaves out (and counts) the
/// triangles that repeat a vertex; without it they are refused. IMAP_CONFIG_NO_LIGHT_AIMING
/// is taken, unknown config flags are refused.
#[test]
fn c_abi_skips_degenerate_triangles_and_takes_config_flags() {
    let (h, _, _) = scene_with(|c| c.flags = IMAP_CONFIG_NO_LIGHT_AIMING);
    let ctx = h.0;
    let xyz = [0.0, 0.0, 0.5, 1.0, 0.0, 0.5, 0.0, 1.0, 0.5];
    let idx = [0u32, 1, 2, 1, 1, 2, 0, 2, 2];
    let mats = [0u32, 7, 0];
    // SAFETY: valid pointers; the arrays outlive the calls.
    unsafe {
        let mut d = std::mem::zeroed::<ImapMesh>();
        ok(imap_mesh_default(&mut d, std::mem::size_of_val(&d)), ctx);
        d.positions = xyz.as_ptr();
        d.vertex_count = 3;
        d.indices = idx.as_ptr();
        d.triangle_count = 3;
        d.flags = IMAP_MESH_RECORD;
        let mut id = 99;
        assert_eq!(
            imap_add_mesh(ctx, &d, &mut id),
            ImapStatus::ImapErrDegenerateTriangle
        );
        assert!(message(ctx).contains("triangle 1"), "{}", message(ctx));
        d.flags |= IMAP_MESH_SKIP_DEGENERATE;
        d.triangle_materials = mats.as_ptr();
        // Every id is checked, a dropped triangle's too: material 7 does not exist.
        assert_eq!(
            imap_add_mesh(ctx, &d, &mut id),
            ImapStatus::ImapErrUnknownMaterial
        );
        d.triangle_materials = std::ptr::null();
        ok(imap_add_mesh(ctx, &d, &mut id), ctx);
        let mut dropped = 0usize;
        ok(imap_get_mesh_dropped_triangles(ctx, id, &mut dropped), ctx);
        assert_eq!(dropped, 2);
        let mut nv = 0usize;
        ok(imap_get_vertex_count(ctx, id, &mut nv), ctx);
        assert_eq!(nv, 3);
        imap_destroy(ctx);
    }
    let mut cfg = default_config();
    cfg.flags = 2;
    let mut out = std::ptr::null_mut();
    // SAFETY: valid pointers.
    let s = unsafe { imap_create(&cfg, &mut out) };
    assert_eq!(s, ImapStatus::ImapErrInvalidArgument);
    assert!(out.is_null());
    assert!(message(std::ptr::null()).contains("config.flags"));
}

/// Three photon ranges traced by three contexts through the C ABI, their states written
/// to buffers and merged into a fourth: the map and its error equal one context's run of
/// all the photons (1e-12); a state of a context with another seed is refused.
#[test]
fn c_abi_ranges_states_and_merges() {
    let n = 30_000u64;
    let map = |ctx: *mut ImapContext, mesh: u32, nv: usize| -> Vec<f64> {
        let (mut e, mut r) = (vec![0.0; nv], vec![0.0; nv]);
        // SAFETY: valid handle and buffers of nv values.
        unsafe {
            ok(
                imap_get_vertex_energy(ctx, mesh, 0, 0, e.as_mut_ptr(), nv),
                ctx,
            );
            ok(imap_get_vertex_error(ctx, mesh, 0, r.as_mut_ptr(), nv), ctx);
        }
        e.extend(r);
        e
    };
    let (one, mesh, nv) = scene();
    let mut p = run_params_with(n);
    // SAFETY: valid handle and params.
    ok(
        unsafe { imap_run(one.0, &p, std::ptr::null_mut(), 0) },
        one.0,
    );
    let want = map(one.0, mesh, nv);
    let (all, _, _) = scene();
    for (first, count) in [(0, n / 3), (n / 3, n / 2 - n / 3), (n / 2, n - n / 2)] {
        let (part, _, _) = scene();
        p.photons = 0;
        p.photon_first = first;
        p.photon_count = count;
        // SAFETY: valid handles, params and out-pointers; the buffer holds `size` bytes.
        unsafe {
            ok(imap_run(part.0, &p, std::ptr::null_mut(), 0), part.0);
            let buf = state_of(part.0);
            let size = buf.len();
            let mut photons = 0u64;
            ok(
                imap_state_info(
                    buf.as_ptr().cast(),
                    size,
                    &mut photons,
                    std::ptr::null_mut(),
                    std::ptr::null_mut(),
                ),
                std::ptr::null(),
            );
            assert_eq!(photons, count);
            ok(imap_state_merge(all.0, buf.as_ptr().cast(), size), all.0);
        }
    }
    let got = map(all.0, mesh, nv);
    let worst = |from: usize, to: usize| {
        want[from..to]
            .iter()
            .zip(&got[from..to])
            .map(|(a, b)| (a - b).abs() / a.abs().max(b.abs()).max(1e-300))
            .fold(0.0, f64::max)
    };
    let (map_diff, error_diff) = (worst(0, nv), worst(nv, 2 * nv));
    assert!(
        map_diff <= 1e-12,
        "merged ranges' map differs from one run by {map_diff:e}"
    );
    // The error is a difference of sums (Σx² − (Σx)²/n): a light-sampled vertex's passes
    // vary little, so it magnifies the sums' rounding (their order differs).
    assert!(
        error_diff <= 1e-8,
        "merged ranges' errors differ from one run by {error_diff:e}"
    );
    assert!(want.iter().any(|&x| x > 0.0));
    // Another seed: another fingerprint.
    let (other, _, _) = scene_with(|c| c.seed = 99);
    let buf = state_of(all.0);
    // SAFETY: as above.
    unsafe {
        let size = buf.len();
        let s = imap_state_merge(other.0, buf.as_ptr().cast(), size);
        assert_eq!(s, ImapStatus::ImapErrStateMismatch);
        assert!(
            message(other.0).contains("settings"),
            "{}",
            message(other.0)
        );
    }
}

/// The context's whole state through the C ABI: the size asked first (NULL buffer →
/// IMAP_ERR_BUFFER_TOO_SMALL with the size), then written.
fn state_of(ctx: *mut ImapContext) -> Vec<u8> {
    let mut size = 0usize;
    let null = std::ptr::null();
    // SAFETY: a valid handle; the buffer holds `size` bytes.
    unsafe {
        let s = imap_state_write(ctx, 0, null, 0, std::ptr::null_mut(), 0, &mut size);
        assert_eq!(s, ImapStatus::ImapErrBufferTooSmall);
        let mut buf = vec![0u8; size];
        let s = imap_state_write(ctx, 0, null, 0, buf.as_mut_ptr().cast(), size, &mut size);
        ok(s, ctx);
        assert_eq!(size, buf.len());
        buf
    }
}

/// What a progress callback that destroys its own context saw.
struct SelfDestroy {
    ctx: *mut ImapContext,
    statuses: Vec<ImapStatus>,
}

unsafe extern "C" fn destroy_from_callback(
    _: *const ImapProgress,
    user: *mut std::ffi::c_void,
) -> i32 {
    // SAFETY: `user` is the test's SelfDestroy, alive for the whole run.
    let s = unsafe { &mut *(user as *mut SelfDestroy) };
    // SAFETY: the context is live (the run is using it): the call must say so.
    s.statuses.push(unsafe { imap_destroy(s.ctx) });
    0
}

/// `imap_destroy` on a context in use is documented misuse, and it is detected: from the
/// run's own progress callback and from another thread during a run it returns
/// IMAP_ERR_BUSY and frees nothing; the run finishes with its map; afterwards the context
/// is destroyed once, and a second destroy (or any call on the stale handle) is
/// IMAP_ERR_INVALID_ARGUMENT, never a double free or a read of freed memory.
#[test]
fn destroying_a_context_in_use_is_refused_not_a_crash() {
    let (h, mesh, nv) = scene();
    let ctx = h.0;
    let mut me = SelfDestroy {
        ctx,
        statuses: Vec::new(),
    };
    let mut p = run_params();
    p.photons = 200_000;
    p.progress_interval_s = 0.001;
    p.progress = Some(destroy_from_callback);
    p.user_data = &mut me as *mut SelfDestroy as *mut std::ffi::c_void;
    // SAFETY: valid handle and params; `me` outlives the run.
    ok(unsafe { imap_run(ctx, &p, std::ptr::null_mut(), 0) }, ctx);
    assert!(!me.statuses.is_empty());
    assert!(
        me.statuses.iter().all(|&s| s == ImapStatus::ImapErrBusy),
        "{:?}",
        me.statuses
    );
    let busy = message(std::ptr::null());
    assert!(busy.contains("in use"), "{busy}");
    let mut e = vec![0.0; nv];
    // SAFETY: the context is live and unused; `e` holds nv values.
    ok(
        unsafe { imap_get_vertex_energy(ctx, mesh, 0, 0, e.as_mut_ptr(), nv) },
        ctx,
    );
    assert!(e.iter().sum::<f64>() > 0.0, "the run's map is there");

    // Another thread destroys while a run holds the context.
    let running = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(true));
    let destroyer = {
        let running = running.clone();
        std::thread::spawn(move || {
            let h = h;
            let mut busy = 0;
            while running.load(std::sync::atomic::Ordering::Relaxed) {
                // SAFETY: the handle is live until this call succeeds.
                match unsafe { imap_destroy(h.0) } {
                    ImapStatus::ImapErrBusy => busy += 1,
                    s => return (s, busy),
                }
            }
            (ImapStatus::ImapErrBusy, busy)
        })
    };
    let mut p = run_params();
    p.time_budget_s = 0.5;
    // SAFETY: valid handle and params. The destroyer may have held the context for the
    // instant of its check: then this run is the one told BUSY, and tries again.
    let s = loop {
        match unsafe { imap_run(ctx, &p, std::ptr::null_mut(), 0) } {
            ImapStatus::ImapErrBusy => continue,
            s => break s,
        }
    };
    // The destroyer may win the race before the run starts: then the run finds no
    // context, and that is an error, not a crash.
    running.store(false, std::sync::atomic::Ordering::Relaxed);
    let (last, busy) = destroyer.join().unwrap();
    eprintln!("destroy during a run: {busy} BUSY answers, then {last:?}; the run: {s:?}");
    if last == ImapStatus::ImapOk {
        assert!(
            s == ImapStatus::ImapOk || s == ImapStatus::ImapErrInvalidArgument,
            "{s:?}"
        );
    } else {
        ok(s, ctx);
        // SAFETY: nothing uses the context now.
        ok(unsafe { imap_destroy(ctx) }, std::ptr::null());
    }
    // The handle is dead: every call on it is refused by name.
    // SAFETY: a stale handle is what is being tested; the library never dereferences it.
    assert_eq!(
        unsafe { imap_destroy(ctx) },
        ImapStatus::ImapErrInvalidArgument
    );
    assert!(message(std::ptr::null()).contains("not a live context"));
    // SAFETY: as above.
    let s = unsafe { imap_get_vertex_energy(ctx, mesh, 0, 0, e.as_mut_ptr(), nv) };
    assert_eq!(s, ImapStatus::ImapErrInvalidArgument);
    assert!(
        message(ctx).contains("not a live context"),
        "{}",
        message(ctx)
    );
}

/// `imap_state_load_file` on a device refuses it before reading (a state of /dev/zero was
/// read until allocation failed, past a 100 MB budget).
#[test]
fn state_files_from_devices_are_refused() {
    let (h, _, _) = scene_with(|c| c.memory_budget_bytes = 100 << 20);
    let t = Instant::now();
    // SAFETY: live handle, NUL-terminated path.
    let s = unsafe { imap_state_load_file(h.0, c"/dev/zero".as_ptr()) };
    assert_eq!(s, ImapStatus::ImapErrIo, "{}", message(h.0));
    assert!(
        message(h.0).contains("not a regular file"),
        "{}",
        message(h.0)
    );
    assert!(t.elapsed() < Duration::from_secs(5));
    // SAFETY: nothing uses the context.
    ok(unsafe { imap_destroy(h.0) }, std::ptr::null());
}

/// `imap_sun_position` takes the site's pressure and temperature and ΔT, so a C caller
/// reproduces the SPA paper's example (Reda & Andreas 2004, table A5.1): azimuth
/// 194.34024°, zenith 50.11162°. Without them (standard atmosphere, ΔT estimated) it is off
/// by about 0.005°; an older caller's smaller struct still works.
#[test]
fn the_sun_position_reproduces_the_spa_example_through_c() {
    let mut t = std::mem::MaybeUninit::<ImapSunTime>::uninit();
    // SAFETY: the out-pointer holds sizeof(ImapSunTime) bytes.
    let mut t = unsafe {
        ok(
            imap_sun_time_default(t.as_mut_ptr(), std::mem::size_of::<ImapSunTime>()),
            std::ptr::null(),
        );
        t.assume_init()
    };
    (t.year, t.month, t.day, t.hour, t.minute, t.second) = (2003, 10, 17, 12, 30, 30.0);
    t.utc_offset_hours = -7.0;
    (t.latitude_deg, t.longitude_deg, t.elevation_m) = (39.742476, -105.1786, 1830.14);
    (t.pressure_hpa, t.temperature_c, t.delta_t_s) = (820.0, 11.0, 67.0);
    t.flags = IMAP_SUN_TIME_ATMOSPHERE | IMAP_SUN_TIME_DELTA_T;
    let (mut az, mut zen) = (0.0, 0.0);
    // SAFETY: valid struct and outputs.
    ok(
        unsafe { imap_sun_position(&t, &mut az, &mut zen) },
        std::ptr::null(),
    );
    assert!(
        (az - 194.34024).abs() < 2e-5 && (zen - 50.11162).abs() < 2e-5,
        "{az} {zen}"
    );
    // An older program's struct (the fields before `flags`): the standard atmosphere.
    let mut old = t;
    old.struct_size = std::mem::offset_of!(ImapSunTime, flags) as u32;
    // SAFETY: as above.
    ok(
        unsafe { imap_sun_position(&old, &mut az, &mut zen) },
        std::ptr::null(),
    );
    assert!(
        (zen - 50.11162).abs() > 1e-3 && (zen - 50.11162).abs() < 0.05,
        "{zen}"
    );
    // Out of range and unknown flags are refused by name.
    t.pressure_hpa = -3.0;
    // SAFETY: as above.
    let s = unsafe { imap_sun_position(&t, &mut az, &mut zen) };
    assert_eq!(s, ImapStatus::ImapErrInvalidArgument);
    assert!(message(std::ptr::null()).contains("pressure_hpa"));
    t.pressure_hpa = 820.0;
    t.flags |= 64;
    // SAFETY: as above.
    let s = unsafe { imap_sun_position(&t, &mut az, &mut zen) };
    assert_eq!(s, ImapStatus::ImapErrInvalidArgument);
    assert!(message(std::ptr::null()).contains("flags"));
}

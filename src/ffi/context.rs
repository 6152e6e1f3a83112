//! The context object: configuration, creation and destruction, errors, versions.

use super::{
    boundary, check_out, errors, read_versioned, with_context, write_defaults, write_out,
    ImapContext, Versioned,
};
use crate::context::{Config, Context, SchedulerKind};
use crate::error::{bail, ImapStatus, Result};
use crate::sched::dynamic::DynamicParams;
use crate::spectral::Bands;
use std::ffi::{c_char, CStr};
use std::sync::{Arc, Mutex};

/// Library version, major.
pub const IMAP_VERSION_MAJOR: u32 = 0;
/// Library version, minor. While the major version is 0, the minor version is the ABI
/// epoch: `libimap.so.0.<minor>` (see README, "ABI policy").
pub const IMAP_VERSION_MINOR: u32 = 2;
/// Library version, patch.
pub const IMAP_VERSION_PATCH: u32 = 3;

/// `ImapConfig::band_mode`: three bands, R, G, B.
pub const IMAP_BANDS_RGB: u32 = 0;
/// `ImapConfig::band_mode`: `band_count` wavelengths from `wavelength_min_nm` to
/// `wavelength_max_nm` inclusive (41 over 380–780 nm are 10 nm steps).
pub const IMAP_BANDS_SPECTRAL: u32 = 1;

/// `ImapConfig::scheduler`: the classic scheme (calculating threads, one accumulating thread).
pub const IMAP_SCHEDULER_CLASSIC: u32 = 0;
/// `ImapConfig::scheduler`: vertex groups with one processing thread each, split into
/// `subd` subgroups under load (the default).
pub const IMAP_SCHEDULER_DYNAMIC: u32 = 1;

/// `ImapConfig::inline_apply`: a calculating thread applies a full portion itself when
/// the group's processing thread is idle, if the calculating threads alone fill the cores.
pub const IMAP_INLINE_AUTO: u32 = 0;
/// Always apply full portions on the spot when the group is idle.
pub const IMAP_INLINE_ALWAYS: u32 = 1;
/// Always hand portions to the processing threads (the paper's scheme as published).
pub const IMAP_INLINE_NEVER: u32 = 2;
/// `ImapConfig::flags`: do not aim point-like lights at the geometry. By default a point,
/// spot, cosine or goniometric light (without a luminous opening) outside the sphere
/// around the scene's geometry emits only into the cone of directions toward that sphere,
/// each photon weighted by the light's flux share in the cone (for a point light, the
/// cone's solid angle over 4π; for cosine lights and luminaires, with the cone within 30°
/// of its axis, I(d)/Φ times the cone's solid angle): the directions left out meet
/// nothing, so the map and the energy balance stay exact (the flux left out is counted as
/// escaped) and no photon is spent on the void. Set this to trace every direction, as the
/// paper's method does. (Since 0.2.1.)
pub const IMAP_CONFIG_NO_LIGHT_AIMING: u32 = 1;

/// Context settings, fixed at creation (threads and scheduler settings can be changed
/// later). Initialise with `imap_config_default(&cfg, sizeof cfg)`.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ImapConfig {
    /// `sizeof(ImapConfig)` as the program was compiled; set by `imap_config_default`.
    pub struct_size: u32,
    /// `IMAP_BANDS_RGB` or `IMAP_BANDS_SPECTRAL`.
    pub band_mode: u32,
    /// Number of bands: 3 in RGB mode, 1..=4096 spectral.
    pub band_count: u32,
    /// Calculating threads, 0..=1024; 0 = one per core.
    pub threads: u32,
    /// Wavelength of the first spectral band, nm (at least 100 nm; IMAP_ERR_BAD_BANDS
    /// below).
    pub wavelength_min_nm: f64,
    /// Wavelength of the last spectral band, nm (at most 100 000 nm; IMAP_ERR_BAD_BANDS
    /// above).
    pub wavelength_max_nm: f64,
    /// Seed of the photons' random streams: the same seed gives the same map with any
    /// scheduler and thread count.
    pub seed: u64,
    /// Most bytes the context may hold (meshes, prepared scene, BVH estimate, map, render
    /// buffers); 0 = the default, 3/4 of physical memory. Checked before every allocation
    /// that depends on the input (IMAP_ERR_MEMORY_BUDGET).
    pub memory_budget_bytes: u64,
    /// Metres per scene unit, in [1e-9, 1e9] (irradiance is reported in W/m²).
    pub unit_m: f64,
    /// `IMAP_SCHEDULER_*`.
    pub scheduler: u32,
    /// Dynamic scheduler: vertex groups at the start; 0 = one per calculating thread.
    pub initial_groups: u32,
    /// Dynamic scheduler: most groups ever (preallocated); 0 = 64 per calculating thread,
    /// at most 4096. 1 means one group that never splits.
    pub max_groups: u32,
    /// Dynamic scheduler: subgroups per split, 2..=64 (the paper's 4).
    pub subd: u32,
    /// Dynamic scheduler: consider splitting while fewer free portions than this wait in
    /// the input stack; 0 = the number of calculating threads.
    pub split_low_threshold: u32,
    /// Dynamic scheduler: split only a group with at least this many queued portions;
    /// 0 = 3.
    pub split_high_threshold: u32,
    /// Dynamic scheduler: smallest subgroup a split may create, in vertex sides; 0 = 256.
    pub min_group_slots: u32,
    /// Dynamic scheduler: `IMAP_INLINE_*`.
    pub inline_apply: u32,
    /// `IMAP_CONFIG_*` flags, or-ed; 0 = the defaults. (Since 0.2.1.)
    pub flags: u32,
}

// SAFETY: repr(C), u32 struct_size first, plain numbers only.
unsafe impl Versioned for ImapConfig {
    const NAME: &'static str = "ImapConfig";
    const INIT: &'static str = "imap_config_default";
    fn defaults() -> Self {
        ImapConfig {
            struct_size: std::mem::size_of::<Self>() as u32,
            band_mode: IMAP_BANDS_RGB,
            band_count: 3,
            threads: 0,
            wavelength_min_nm: 380.0,
            wavelength_max_nm: 780.0,
            seed: 0,
            memory_budget_bytes: 0,
            unit_m: 1.0,
            scheduler: IMAP_SCHEDULER_DYNAMIC,
            initial_groups: 0,
            max_groups: 0,
            subd: 4,
            split_low_threshold: 0,
            split_high_threshold: 0,
            min_group_slots: 0,
            inline_apply: IMAP_INLINE_AUTO,
            flags: 0,
        }
    }
}

/// Fills the `size` bytes at `out` with the defaults and sets `struct_size = size`: RGB,
/// all cores, seed 0, dynamic scheduler with subd 4 and automatic group counts and
/// thresholds, the default memory budget, 1 m per scene unit (spectral range preset to
/// 380–780 nm). Pass `sizeof *out`.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_INVALID_ARGUMENT (a size smaller than the
/// struct). Thread-safe.
///
/// # Safety
/// `out` is NULL or points to `size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn imap_config_default(out: *mut ImapConfig, size: usize) -> ImapStatus {
    boundary(None, || write_defaults(out, size))
}

fn config_from_c(c: &ImapConfig) -> Result<Config> {
    let bands = match c.band_mode {
        IMAP_BANDS_RGB => {
            if c.band_count != 3 {
                bail!(
                    ImapErrBadBands,
                    "config.band_count = {} but RGB mode has 3 bands",
                    c.band_count
                );
            }
            Bands::rgb()
        }
        IMAP_BANDS_SPECTRAL => {
            Bands::spectral(c.band_count, c.wavelength_min_nm, c.wavelength_max_nm)?
        }
        m => bail!(
            ImapErrInvalidArgument,
            "config.band_mode = {m} is neither IMAP_BANDS_RGB nor IMAP_BANDS_SPECTRAL"
        ),
    };
    let scheduler = match c.scheduler {
        IMAP_SCHEDULER_CLASSIC => SchedulerKind::Classic,
        IMAP_SCHEDULER_DYNAMIC => SchedulerKind::Dynamic,
        s => bail!(
            ImapErrInvalidArgument,
            "config.scheduler = {s} is neither IMAP_SCHEDULER_CLASSIC nor IMAP_SCHEDULER_DYNAMIC"
        ),
    };
    let defaults = DynamicParams::default();
    let or = |v: u32, d: usize| if v == 0 { d } else { v as usize };
    let dynamic = DynamicParams {
        initial_groups: c.initial_groups as usize,
        max_groups: c.max_groups as usize,
        subd: or(c.subd, defaults.subd),
        low_threshold: c.split_low_threshold as usize,
        high_threshold: or(c.split_high_threshold, defaults.high_threshold),
        min_group_slots: or(c.min_group_slots, defaults.min_group_slots),
        split_interval: defaults.split_interval,
        inline_apply: match c.inline_apply {
            IMAP_INLINE_AUTO => None,
            IMAP_INLINE_ALWAYS => Some(true),
            IMAP_INLINE_NEVER => Some(false),
            v => bail!(
                ImapErrInvalidArgument,
                "config.inline_apply = {v} is not IMAP_INLINE_AUTO, _ALWAYS or _NEVER"
            ),
        },
    };
    if c.flags & !IMAP_CONFIG_NO_LIGHT_AIMING != 0 {
        bail!(
            ImapErrInvalidArgument,
            "config.flags = 0x{:x} has bits that are no IMAP_CONFIG_* flag",
            c.flags
        );
    }
    Ok(Config {
        bands,
        threads: c.threads as usize,
        seed: c.seed,
        scheduler,
        dynamic,
        memory_budget: c.memory_budget_bytes,
        unit_m: c.unit_m,
        aim_lights: c.flags & IMAP_CONFIG_NO_LIGHT_AIMING == 0,
    })
}

/// Creates a context. `config` is copied (NULL = defaults). On success `*out` receives a
/// handle that the caller owns and frees with `imap_destroy`; on failure `*out` is not
/// written and `imap_last_error(NULL)` says why.
///
/// Returns IMAP_ERR_NULL_POINTER, IMAP_ERR_BAD_BANDS, IMAP_ERR_INVALID_ARGUMENT,
/// IMAP_ERR_NON_FINITE or IMAP_ERR_EMBREE. Thread-safe.
///
/// # Safety
/// `config` is NULL or points to an `ImapConfig` of `config->struct_size` bytes; `out`
/// points to writable storage.
#[no_mangle]
pub unsafe extern "C" fn imap_create(
    config: *const ImapConfig,
    out: *mut *mut ImapContext,
) -> ImapStatus {
    boundary(None, || {
        check_out("out", out)?;
        let config = if config.is_null() {
            Config::default()
        } else {
            config_from_c(&read_versioned("config", config)?)?
        };
        let ctx = Context::new(config)?;
        let handle = super::register(ImapContext {
            inner: Mutex::new(ctx),
            errors: Arc::default(),
        });
        write_out("out", out, handle)
    })
}

/// Destroys a context and everything it owns, including its error messages. NULL is a
/// no-op (IMAP_OK).
///
/// Returns IMAP_ERR_BUSY, and destroys nothing, while another call is using the context (an
/// `imap_run` or `imap_render` in progress on another thread, or this call made from the
/// context's own progress callback): destroy it after that call returns. Returns
/// IMAP_ERR_INVALID_ARGUMENT for a handle that is not live (destroyed already, or not from
/// `imap_create`): such misuse is detected, never a double free. The message is the calling
/// thread's (`imap_last_error(NULL)`). Thread-safe. (Returns a status since 0.2.3; it
/// returned nothing before, and programs built against that header keep working.)
///
/// # Safety
/// `ctx` is NULL or a handle from `imap_create`.
#[no_mangle]
pub unsafe extern "C" fn imap_destroy(ctx: *mut ImapContext) -> ImapStatus {
    if ctx.is_null() {
        return ImapStatus::ImapOk;
    }
    boundary(None, || super::unregister(ctx))
}

/// The message of the calling thread's most recent failing call on `ctx`, or, with `ctx`
/// NULL, of the calling thread's most recent failing call on any context or none (the
/// only way to learn why `imap_create` failed). Never NULL; "" when nothing failed. One
/// line of plain text.
///
/// Lifetime: the string is owned by the library and stays valid until the calling thread
/// makes its next failing call on `ctx` (with NULL: its next failing call of any kind),
/// `ctx` is destroyed, or the thread exits. Other threads' calls never free it: the
/// IMAP_ERR_BUSY that a second thread gets while a run holds the context is that thread's
/// message, not the running thread's.
///
/// # Safety
/// `ctx` is NULL or a live handle.
#[no_mangle]
pub unsafe extern "C" fn imap_last_error(ctx: *const ImapContext) -> *const c_char {
    let r = std::panic::catch_unwind(|| {
        if ctx.is_null() {
            return errors::thread_message();
        }
        match super::live(ctx) {
            // The message lives in the context's slots, which live as long as the context.
            Some(c) => c.errors.current(),
            None => {
                c"ctx is not a live context: it was destroyed, or did not come from imap_create"
                    .as_ptr()
            }
        }
    });
    r.unwrap_or(c"internal error".as_ptr())
}

/// A static name for a status ("IMAP_OK", "IMAP_ERR_NULL_POINTER", ...), or
/// "IMAP_ERR_UNKNOWN_STATUS" for a value that is no status. Any int is accepted.
/// Thread-safe.
#[no_mangle]
pub extern "C" fn imap_status_name(status: i32) -> *const c_char {
    crate::error::status_name(status).as_ptr()
}

/// The library version as "major.minor.patch", static. Thread-safe.
#[no_mangle]
pub extern "C" fn imap_version() -> *const c_char {
    const V: &CStr =
        match CStr::from_bytes_with_nul(concat!(env!("CARGO_PKG_VERSION"), "\0").as_bytes()) {
            Ok(v) => v,
            Err(_) => panic!("version has no NUL"),
        };
    V.as_ptr()
}

/// Embree's version (major·10000 + minor·100 + patch) into `*out`.
///
/// # Safety
/// `ctx` is a live handle; `out` points to writable storage.
#[no_mangle]
pub unsafe extern "C" fn imap_embree_version(ctx: *const ImapContext, out: *mut i64) -> ImapStatus {
    with_context(ctx, |c| write_out("out", out, c.embree_version()))
}

/// Clears the map, the totals and the history. The scene stays and may be changed again
/// (adding meshes or lights after a run requires this).
///
/// # Safety
/// `ctx` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn imap_reset(ctx: *mut ImapContext) -> ImapStatus {
    with_context(ctx, |c| {
        c.reset();
        Ok(())
    })
}

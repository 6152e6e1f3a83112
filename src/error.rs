//! Status codes and the library's error type.
//!
//! Every fallible operation returns [`Error`], which carries an [`ImapStatus`] (what the C ABI
//! returns) and a human-readable message (what `imap_last_error` gives back).

use std::ffi::CStr;
use std::fmt;

/// Status returned by every `imap_*` call. `IMAP_OK` (0) is success; every other value names
/// one kind of failure, and the last-error message says which argument and why.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ImapStatus {
    /// Success.
    ImapOk = 0,
    /// A required pointer argument was NULL.
    ImapErrNullPointer = 1,
    /// An argument is out of its documented range (a negative size, an unknown enum value,
    /// an array length that matches neither 1 nor the band count, ...).
    ImapErrInvalidArgument = 2,
    /// A coordinate, coefficient or power is NaN or infinite.
    ImapErrNonFinite = 3,
    /// A vertex index, mesh id, light id, band or side is out of range.
    ImapErrIndexOutOfRange = 4,
    /// A triangle uses the same vertex twice.
    ImapErrDegenerateTriangle = 5,
    /// The band configuration is invalid (zero bands, RGB with a count other than 3, a
    /// wavelength range that is empty or not positive).
    ImapErrBadBands = 6,
    /// `imap_run` was called on a scene with no mesh.
    ImapErrNoGeometry = 7,
    /// A mesh with zero triangles or zero vertices.
    ImapErrEmptyMesh = 8,
    /// A material id that was never returned by `imap_add_material`.
    ImapErrUnknownMaterial = 9,
    /// A light or an emitting mesh with zero total power, or a scene with no light at all.
    ImapErrNoLight = 10,
    /// A material whose coefficients are outside [0, 1] or whose event probabilities sum
    /// to more than 1 in some band, or a dielectric with an invalid index of refraction.
    ImapErrBadMaterial = 11,
    /// The call is not allowed in the context's current state (e.g. adding a mesh after a
    /// run has accumulated photons: call `imap_reset` first).
    ImapErrOutOfOrder = 12,
    /// The map would exceed the configured memory budget; nothing was allocated.
    ImapErrMemoryBudget = 13,
    /// Another call is using this context right now (contexts are not re-entrant; calls
    /// from the progress callback on the same context get this status).
    ImapErrBusy = 14,
    /// Embree failed (device creation, unsupported CPU, version older than 4.0, out of
    /// memory in the BVH build). The message carries Embree's own text.
    ImapErrEmbree = 15,
    /// A thread of the run panicked or could not be started; the run's partial results are
    /// discarded and the map is the one before the run.
    ImapErrThreadLost = 16,
    /// An internal error (a panic caught at the API boundary). Please report it.
    ImapErrInternal = 17,
    /// Memory allocation failed.
    ImapErrOutOfMemory = 18,
    /// A mesh that does not record was asked for its map.
    ImapErrNotRecorded = 19,
    /// The output buffer is too small for the requested data.
    ImapErrBufferTooSmall = 20,
    /// The scene cannot be traced faithfully: a mesh's triangles are too small for the f32
    /// precision that ray tracing has at their distance from the scene's centre, or a
    /// coordinate is beyond ±1e30. The message names the mesh.
    ImapErrPrecision = 21,
    /// A photometric file (IES LM-63, EULUMDAT) or table is malformed: the message names
    /// the line (for files) and the problem.
    ImapErrParse = 22,
    /// The input is well formed but uses a feature libimap does not support (photometric
    /// type A, a three-dimensional luminous opening asked to emit): the message names it.
    ImapErrUnsupported = 23,
    /// A file could not be opened, read, written or renamed: the message names the path
    /// and the system's reason.
    ImapErrIo = 24,
    /// A state (`imap_state_load`, `imap_state_merge`) is not a libimap state, is
    /// truncated, or fails its checksum: the message says which.
    ImapErrStateCorrupt = 25,
    /// A state is of another scene or other settings (its fingerprint differs): the message
    /// names what differs (settings, geometry, materials, lights).
    ImapErrStateMismatch = 26,
    /// A state to merge holds photons the context holds too: they would count twice.
    ImapErrStateOverlap = 27,
    /// A host BSDF (IMAP_SURFACE_HOST) reported a failure or gave an invalid value during a
    /// run or render: the message names the material. (Since 0.2.3.)
    ImapErrHostBsdf = 28,
}

impl ImapStatus {
    /// Every status, in order of value.
    pub(crate) const ALL: [ImapStatus; 29] = [
        ImapStatus::ImapOk,
        ImapStatus::ImapErrNullPointer,
        ImapStatus::ImapErrInvalidArgument,
        ImapStatus::ImapErrNonFinite,
        ImapStatus::ImapErrIndexOutOfRange,
        ImapStatus::ImapErrDegenerateTriangle,
        ImapStatus::ImapErrBadBands,
        ImapStatus::ImapErrNoGeometry,
        ImapStatus::ImapErrEmptyMesh,
        ImapStatus::ImapErrUnknownMaterial,
        ImapStatus::ImapErrNoLight,
        ImapStatus::ImapErrBadMaterial,
        ImapStatus::ImapErrOutOfOrder,
        ImapStatus::ImapErrMemoryBudget,
        ImapStatus::ImapErrBusy,
        ImapStatus::ImapErrEmbree,
        ImapStatus::ImapErrThreadLost,
        ImapStatus::ImapErrInternal,
        ImapStatus::ImapErrOutOfMemory,
        ImapStatus::ImapErrNotRecorded,
        ImapStatus::ImapErrBufferTooSmall,
        ImapStatus::ImapErrPrecision,
        ImapStatus::ImapErrParse,
        ImapStatus::ImapErrUnsupported,
        ImapStatus::ImapErrIo,
        ImapStatus::ImapErrStateCorrupt,
        ImapStatus::ImapErrStateMismatch,
        ImapStatus::ImapErrStateOverlap,
        ImapStatus::ImapErrHostBsdf,
    ];

    /// The C name of the status.
    pub fn name(self) -> &'static CStr {
        use ImapStatus::*;
        match self {
            ImapOk => c"IMAP_OK",
            ImapErrNullPointer => c"IMAP_ERR_NULL_POINTER",
            ImapErrInvalidArgument => c"IMAP_ERR_INVALID_ARGUMENT",
            ImapErrNonFinite => c"IMAP_ERR_NON_FINITE",
            ImapErrIndexOutOfRange => c"IMAP_ERR_INDEX_OUT_OF_RANGE",
            ImapErrDegenerateTriangle => c"IMAP_ERR_DEGENERATE_TRIANGLE",
            ImapErrBadBands => c"IMAP_ERR_BAD_BANDS",
            ImapErrNoGeometry => c"IMAP_ERR_NO_GEOMETRY",
            ImapErrEmptyMesh => c"IMAP_ERR_EMPTY_MESH",
            ImapErrUnknownMaterial => c"IMAP_ERR_UNKNOWN_MATERIAL",
            ImapErrNoLight => c"IMAP_ERR_NO_LIGHT",
            ImapErrBadMaterial => c"IMAP_ERR_BAD_MATERIAL",
            ImapErrOutOfOrder => c"IMAP_ERR_OUT_OF_ORDER",
            ImapErrMemoryBudget => c"IMAP_ERR_MEMORY_BUDGET",
            ImapErrBusy => c"IMAP_ERR_BUSY",
            ImapErrEmbree => c"IMAP_ERR_EMBREE",
            ImapErrThreadLost => c"IMAP_ERR_THREAD_LOST",
            ImapErrInternal => c"IMAP_ERR_INTERNAL",
            ImapErrOutOfMemory => c"IMAP_ERR_OUT_OF_MEMORY",
            ImapErrNotRecorded => c"IMAP_ERR_NOT_RECORDED",
            ImapErrBufferTooSmall => c"IMAP_ERR_BUFFER_TOO_SMALL",
            ImapErrPrecision => c"IMAP_ERR_PRECISION",
            ImapErrParse => c"IMAP_ERR_PARSE",
            ImapErrUnsupported => c"IMAP_ERR_UNSUPPORTED",
            ImapErrIo => c"IMAP_ERR_IO",
            ImapErrStateCorrupt => c"IMAP_ERR_STATE_CORRUPT",
            ImapErrStateMismatch => c"IMAP_ERR_STATE_MISMATCH",
            ImapErrStateOverlap => c"IMAP_ERR_STATE_OVERLAP",
            ImapErrHostBsdf => c"IMAP_ERR_HOST_BSDF",
        }
    }
}

/// The name of a status value from C, which may be any int.
pub fn status_name(value: i32) -> &'static CStr {
    usize::try_from(value)
        .ok()
        .and_then(|i| ImapStatus::ALL.get(i))
        .map_or(c"IMAP_ERR_UNKNOWN_STATUS", |s| s.name())
}

/// An error: a status plus a message for `imap_last_error`, and the scene item it is
/// about when it is about one (so that a program that named its meshes and lights can say
/// which of them, where the message can only give the library's id).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error {
    pub status: ImapStatus,
    pub message: String,
    pub subject: Option<Subject>,
}

/// The scene item an error is about, by its id.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Subject {
    Mesh(u32),
    Light(u32),
    Material(u32),
}

impl Error {
    pub fn new(status: ImapStatus, message: impl Into<String>) -> Self {
        Error {
            status,
            message: message.into(),
            subject: None,
        }
    }

    /// The error, about `subject`.
    pub fn about(mut self, subject: Subject) -> Self {
        self.subject = Some(subject);
        self
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}: {}", self.status, self.message)
    }
}

impl std::error::Error for Error {}

pub type Result<T> = std::result::Result<T, Error>;

thread_local! {
    /// Non-zero while the thread runs library code whose panics are caught and reported as
    /// statuses: the C ABI's panic hook prints nothing for them (`ffi::errors`).
    pub(crate) static QUIET: std::cell::Cell<u32> = const { std::cell::Cell::new(0) };
}

/// Marks a worker thread the library started: its panics are caught by the library and
/// become `IMAP_ERR_THREAD_LOST`, so nothing is printed for them.
pub(crate) fn quiet_thread() {
    QUIET.with(|q| q.set(q.get() + 1));
}

/// The text of a caught panic's payload.
pub(crate) fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

/// Shorthand for an early return with an error.
macro_rules! bail {
    ($status:ident, $($fmt:tt)+) => {
        return Err($crate::error::Error::new($crate::error::ImapStatus::$status, format!($($fmt)+)))
    };
}
pub(crate) use bail;

/// Checks that every value is finite, naming the argument in the error.
pub(crate) fn check_finite(name: &str, values: &[f64]) -> Result<()> {
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        bail!(
            ImapErrNonFinite,
            "{name}[{i}] is {} (NaN or infinite values are not allowed)",
            values[i]
        );
    }
    Ok(())
}

/// An empty vector with room for `n` elements, or `IMAP_ERR_OUT_OF_MEMORY` naming `what`:
/// every allocation whose size depends on the input goes through here (or `try_filled`),
/// so running out of memory is a status, never an abort of the host.
pub(crate) fn try_with_capacity<T>(n: usize, what: &str) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| {
        Error::new(
            ImapStatus::ImapErrOutOfMemory,
            format!(
                "out of memory allocating {what} ({} MiB)",
                (n as u128 * std::mem::size_of::<T>() as u128) >> 20
            ),
        )
    })?;
    Ok(v)
}

/// `n` copies of `value`, allocated fallibly (see `try_with_capacity`).
pub(crate) fn try_filled<T: Clone>(n: usize, value: T, what: &str) -> Result<Vec<T>> {
    let mut v = try_with_capacity(n, what)?;
    v.resize(n, value);
    Ok(v)
}

/// Collects an exact-size iterator into a fallibly allocated vector.
pub(crate) fn try_collect<T>(it: impl ExactSizeIterator<Item = T>, what: &str) -> Result<Vec<T>> {
    let mut v = try_with_capacity(it.len(), what)?;
    v.extend(it);
    Ok(v)
}

/// Largest coordinate magnitude accepted: ray tracing runs in f32 (max 3.4e38), and the
/// prepared scene's differences of coordinates must stay finite there.
pub(crate) const MAX_COORDINATE: f64 = 1e30;

/// Checks that scene coordinates are finite and within ±`MAX_COORDINATE`.
pub(crate) fn check_coordinates(name: &str, values: &[f64]) -> Result<()> {
    check_finite(name, values)?;
    if let Some(i) = values.iter().position(|v| v.abs() > MAX_COORDINATE) {
        bail!(
            ImapErrPrecision,
            "{name}[{i}] = {:e} is beyond ±1e30 (ray tracing works in single precision; move the scene's origin or scale it with unit_m)",
            values[i]
        );
    }
    Ok(())
}

/// Checks that a scalar is finite, naming it.
pub(crate) fn check_finite_scalar(name: &str, value: f64) -> Result<()> {
    if !value.is_finite() {
        bail!(
            ImapErrNonFinite,
            "{name} is {value} (NaN or infinite values are not allowed)"
        );
    }
    Ok(())
}

/// `x` is finite and within [`lo`, `hi`], or an error naming `name`.
pub(crate) fn check_range(name: &str, x: f64, lo: f64, hi: f64) -> Result<()> {
    check_finite_scalar(name, x)?;
    if !(lo..=hi).contains(&x) {
        bail!(
            ImapErrInvalidArgument,
            "{name} = {x} is not in [{lo}, {hi}]"
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_int_has_a_status_name() {
        for (i, s) in ImapStatus::ALL.iter().enumerate() {
            assert_eq!(*s as i32, i as i32, "ALL is in value order");
            assert!(s.name().to_str().unwrap().starts_with("IMAP_"));
        }
        let unknown = ImapStatus::ALL.len() as i32;
        for v in [-1, unknown, 1_000_000, i32::MIN, i32::MAX] {
            assert_eq!(status_name(v), c"IMAP_ERR_UNKNOWN_STATUS");
        }
        assert_eq!(status_name(14), c"IMAP_ERR_BUSY");
    }
}

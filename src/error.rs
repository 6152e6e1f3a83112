//! Status codes and the library's error type.
//!
//! Every fallible operation returns [`Error`], which carries an [`ImapStatus`] (what the C ABI
//! returns) and a human-readable message (what `imap_last_error` gives back).

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
}

/// An error: a status plus a message for `imap_last_error`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error {
    pub status: ImapStatus,
    pub message: String,
}

impl Error {
    pub fn new(status: ImapStatus, message: impl Into<String>) -> Self {
        Error {
            status,
            message: message.into(),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}: {}", self.status, self.message)
    }
}

impl std::error::Error for Error {}

pub type Result<T> = std::result::Result<T, Error>;

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

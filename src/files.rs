//! Reading input files safely: only regular files, and never more than a bound. A path
//! that names a device (`/dev/zero`, or on Windows a reserved name such as `CON.obj`), a
//! FIFO or a folder, or a file that grows while it is read, is refused before its bytes
//! can exhaust memory.

use std::io::Read;
use std::path::Path;

/// Why a file could not be read.
#[derive(Debug)]
pub enum ReadError {
    /// Not a regular file: a device, FIFO, socket or folder.
    NotRegular,
    /// Larger than the bound (its size, or more than the bound when it grew while read).
    TooLarge {
        size: u64,
        limit: u64,
    },
    Io(std::io::Error),
}

impl std::fmt::Display for ReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReadError::NotRegular => {
                write!(f, "not a regular file (a device, FIFO or folder)")
            }
            ReadError::TooLarge { size, limit } => {
                write!(f, "{size} bytes, more than the {limit} bytes allowed")
            }
            ReadError::Io(e) => write!(f, "{e}"),
        }
    }
}

/// The whole of the regular file at `path` (symbolic links followed), at most `limit`
/// bytes: the size is checked before reading, and the read stops past the bound.
pub fn read_regular(path: &Path, limit: u64) -> Result<Vec<u8>, ReadError> {
    // Windows opens `CON`, `NUL`, `COM1` ... (with any extension) as devices.
    if crate::platform::is_device_name_here(path) {
        return Err(ReadError::NotRegular);
    }
    let file = std::fs::File::open(path).map_err(ReadError::Io)?;
    let meta = file.metadata().map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular);
    }
    if meta.len() > limit {
        return Err(ReadError::TooLarge {
            size: meta.len(),
            limit,
        });
    }
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(meta.len() as usize)
        .map_err(|_| ReadError::TooLarge {
            size: meta.len(),
            limit,
        })?;
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(ReadError::Io)?;
    if bytes.len() as u64 > limit {
        return Err(ReadError::TooLarge {
            size: bytes.len() as u64,
            limit,
        });
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_folders_and_files_over_the_bound_are_refused() {
        assert!(matches!(
            read_regular(Path::new("/dev/zero"), 1 << 20),
            Err(ReadError::NotRegular)
        ));
        assert!(matches!(
            read_regular(Path::new("/"), 1 << 20),
            Err(ReadError::NotRegular)
        ));
        let dir = std::env::temp_dir().join(format!("imap-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("ten");
        std::fs::write(&p, b"0123456789").unwrap();
        assert_eq!(read_regular(&p, 10).unwrap(), b"0123456789");
        assert!(matches!(
            read_regular(&p, 9),
            Err(ReadError::TooLarge { size: 10, limit: 9 })
        ));
        let _ = std::fs::remove_dir_all(&dir);
    }
}

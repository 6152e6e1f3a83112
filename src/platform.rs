//! What the library asks of the operating system, for Linux (and other Unix) and Windows:
//! whether a process still runs, the physical memory, the calling thread's CPU time,
//! replacing a file by another atomically, and a path from a C string.
//!
//! Windows (issue 35): the process check opens the process for its exit code
//! (`OpenProcess`, `GetExitCodeProcess`); the memory is `GlobalMemoryStatusEx`'s; the CPU
//! time `GetThreadTimes`' kernel and user times; the replacement `MoveFileExW` with
//! `MOVEFILE_REPLACE_EXISTING | MOVEFILE_WRITE_THROUGH` (the rename has reached the disk
//! when it returns: Windows has no folder to flush); and a C caller's path is UTF-8
//! (`docs/windows.md`: a non-ASCII name is passed as its UTF-8 bytes, not in the ANSI code
//! page).

use std::path::Path;
use std::time::Duration;

/// Whether process `pid` is known to have ended (false where it runs, or where the system
/// does not say).
pub fn process_gone(pid: u32) -> bool {
    #[cfg(unix)]
    {
        let Ok(pid) = libc::pid_t::try_from(pid) else {
            return false;
        };
        // SAFETY: signal 0 only asks whether the process exists.
        pid > 0
            && unsafe { libc::kill(pid, 0) } == -1
            && std::io::Error::last_os_error().raw_os_error() == Some(libc::ESRCH)
    }
    #[cfg(windows)]
    {
        use windows_sys::Win32::Foundation::{CloseHandle, ERROR_INVALID_PARAMETER, STILL_ACTIVE};
        use windows_sys::Win32::System::Threading::{
            GetExitCodeProcess, OpenProcess, PROCESS_QUERY_LIMITED_INFORMATION,
        };
        if pid == 0 {
            return false;
        }
        // SAFETY: OpenProcess takes plain values; a null handle is its failure.
        let h = unsafe { OpenProcess(PROCESS_QUERY_LIMITED_INFORMATION, 0, pid) };
        if h.is_null() {
            // No such process: ERROR_INVALID_PARAMETER. Access denied: it runs.
            return std::io::Error::last_os_error().raw_os_error()
                == Some(ERROR_INVALID_PARAMETER as i32);
        }
        let mut code = 0u32;
        // SAFETY: `h` is a valid process handle and `code` a writable u32.
        let ok = unsafe { GetExitCodeProcess(h, &mut code) } != 0;
        // SAFETY: `h` was opened above and is closed once.
        unsafe { CloseHandle(h) };
        ok && code != STILL_ACTIVE as u32
    }
    #[cfg(not(any(unix, windows)))]
    {
        let _ = pid;
        false
    }
}

/// Physical memory in bytes, if the system says.
pub fn physical_memory() -> Option<u64> {
    #[cfg(unix)]
    {
        // SAFETY: sysconf only reads system configuration.
        let (pages, size) = unsafe {
            (
                libc::sysconf(libc::_SC_PHYS_PAGES),
                libc::sysconf(libc::_SC_PAGESIZE),
            )
        };
        (pages > 0 && size > 0).then(|| (pages as u64).saturating_mul(size as u64))
    }
    #[cfg(windows)]
    {
        use windows_sys::Win32::System::SystemInformation::{GlobalMemoryStatusEx, MEMORYSTATUSEX};
        // SAFETY: MEMORYSTATUSEX is plain data; dwLength is set as the call requires.
        let mut m: MEMORYSTATUSEX = unsafe { std::mem::zeroed() };
        m.dwLength = std::mem::size_of::<MEMORYSTATUSEX>() as u32;
        // SAFETY: `m` is a valid, writable MEMORYSTATUSEX.
        let ok = unsafe { GlobalMemoryStatusEx(&mut m) } != 0;
        (ok && m.ullTotalPhys > 0).then_some(m.ullTotalPhys)
    }
    #[cfg(not(any(unix, windows)))]
    {
        None
    }
}

/// The CPU time the calling thread has used, where the system tells it.
pub fn thread_cpu_time() -> Option<Duration> {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid, writable timespec; the call only writes it.
        let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
        if rc == 0 && ts.tv_sec >= 0 && (0..1_000_000_000).contains(&ts.tv_nsec) {
            return Some(Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32));
        }
        None
    }
    #[cfg(windows)]
    {
        use windows_sys::Win32::Foundation::FILETIME;
        use windows_sys::Win32::System::Threading::{GetCurrentThread, GetThreadTimes};
        let zero = FILETIME {
            dwLowDateTime: 0,
            dwHighDateTime: 0,
        };
        let (mut created, mut exited, mut kernel, mut user) = (zero, zero, zero, zero);
        // SAFETY: the pseudo-handle of the calling thread and four writable FILETIMEs.
        let ok = unsafe {
            GetThreadTimes(
                GetCurrentThread(),
                &mut created,
                &mut exited,
                &mut kernel,
                &mut user,
            )
        } != 0;
        // FILETIME counts 100 ns.
        let ticks = |f: FILETIME| (u64::from(f.dwHighDateTime) << 32) | u64::from(f.dwLowDateTime);
        ok.then(|| Duration::from_nanos((ticks(kernel) + ticks(user)).saturating_mul(100)))
    }
    #[cfg(not(any(unix, windows)))]
    {
        None
    }
}

/// Replaces `to` by `from` in one step (a reader sees the old file or the new one, never
/// a part), durably where the system allows: on Windows the move is written through; on
/// Unix the caller flushes the folder after it.
pub fn replace_file(from: &Path, to: &Path) -> std::io::Result<()> {
    #[cfg(windows)]
    {
        use std::os::windows::ffi::OsStrExt;
        use windows_sys::Win32::Storage::FileSystem::{
            MoveFileExW, MOVEFILE_REPLACE_EXISTING, MOVEFILE_WRITE_THROUGH,
        };
        let wide = |p: &Path| -> Vec<u16> { p.as_os_str().encode_wide().chain([0]).collect() };
        let (a, b) = (wide(from), wide(to));
        // SAFETY: two NUL-terminated UTF-16 strings that outlive the call.
        let ok = unsafe {
            MoveFileExW(
                a.as_ptr(),
                b.as_ptr(),
                MOVEFILE_REPLACE_EXISTING | MOVEFILE_WRITE_THROUGH,
            )
        } != 0;
        if ok {
            Ok(())
        } else {
            Err(std::io::Error::last_os_error())
        }
    }
    #[cfg(not(windows))]
    {
        std::fs::rename(from, to)
    }
}

/// A path from a C string's bytes: on Unix the bytes as the system takes them; on Windows
/// UTF-8 (None where they are not).
pub fn path_from_c(bytes: &[u8]) -> Option<&Path> {
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        Some(Path::new(std::ffi::OsStr::from_bytes(bytes)))
    }
    #[cfg(not(unix))]
    {
        std::str::from_utf8(bytes).ok().map(Path::new)
    }
}

/// Whether the last component of `path` is one of Windows' reserved device names (CON,
/// PRN, AUX, NUL, COM1-9, LPT1-9, also with an extension or trailing spaces, in any case:
/// `con.obj`, `NUL `, `Lpt3.ies`): on Windows such a path opens a device, not a file.
/// Pure name logic, for any system; the readers ask it on Windows only.
pub fn windows_device_name(path: &Path) -> bool {
    let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
        return false;
    };
    let stem = name
        .split('.')
        .next()
        .unwrap_or("")
        .trim_end_matches([' ', '\t']);
    let upper = stem.to_ascii_uppercase();
    match upper.as_str() {
        "CON" | "PRN" | "AUX" | "NUL" | "CONIN$" | "CONOUT$" => true,
        _ => {
            let b = upper.as_bytes();
            b.len() == 4
                && (upper.starts_with("COM") || upper.starts_with("LPT"))
                && (b'1'..=b'9').contains(&b[3])
        }
    }
}

/// Whether reading `path` would open a Windows device by its reserved name (always false
/// elsewhere, where `CON` is a file name like any other).
pub fn is_device_name_here(path: &Path) -> bool {
    cfg!(windows) && windows_device_name(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_reserved_device_names_are_known_with_extensions_and_in_any_case() {
        for name in [
            "CON",
            "con.obj",
            "NUL",
            "nul.txt",
            "NUL ",
            "Aux.ies",
            "prn",
            "COM1",
            "com9.ldt",
            "LPT3.hdr",
            "CONIN$",
            "dir/CON.obj",
        ] {
            assert!(windows_device_name(Path::new(name)), "{name}");
        }
        for name in [
            "CONSOLE.obj",
            "con_room.obj",
            "COM0",
            "COM10",
            "LPT",
            "NULL",
            "icon.png",
            "model.con",
            "",
            "dir/",
        ] {
            assert!(!windows_device_name(Path::new(name)), "{name}");
        }
        assert_eq!(is_device_name_here(Path::new("CON")), cfg!(windows));
    }

    #[test]
    fn this_process_runs_and_an_ended_child_is_gone() {
        assert!(!process_gone(std::process::id()));
        // A child that has ended and been waited for is gone.
        #[cfg(unix)]
        let child = std::process::Command::new("true").spawn();
        #[cfg(windows)]
        let child = std::process::Command::new("cmd")
            .args(["/C", "exit"])
            .spawn();
        let mut child = child.expect("a child process");
        let pid = child.id();
        child.wait().unwrap();
        assert!(process_gone(pid), "pid {pid}");
    }

    #[test]
    fn memory_and_cpu_time_are_told() {
        let m = physical_memory().expect("the physical memory");
        assert!(m > 64 << 20, "{m}");
        let t0 = thread_cpu_time().expect("the thread's CPU time");
        // Busy work: the thread's CPU time grows.
        let mut x = 0u64;
        let start = std::time::Instant::now();
        while start.elapsed() < Duration::from_millis(50) {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        }
        std::hint::black_box(x);
        let t1 = thread_cpu_time().unwrap();
        assert!(t1 > t0, "{t0:?} {t1:?}");
    }

    #[test]
    fn a_file_is_replaced_whole_and_a_path_reads_from_utf8() {
        let dir = std::env::temp_dir().join(format!("imap-platform-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (a, b) = (dir.join("new ä.bin"), dir.join("old ä.bin"));
        std::fs::write(&a, b"new").unwrap();
        std::fs::write(&b, b"old").unwrap();
        replace_file(&a, &b).unwrap();
        assert_eq!(std::fs::read(&b).unwrap(), b"new");
        assert!(!a.exists());
        // Into a folder that is not there: an error, not a panic.
        assert!(replace_file(&b, &dir.join("no/such/dir/x")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
        let p = path_from_c("états/été.imap".as_bytes()).unwrap();
        assert_eq!(p, Path::new("états/été.imap"));
    }
}

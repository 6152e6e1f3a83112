//! The Windows version resource (issue 35): file version = the crate's version, embedded in
//! `imap.dll` and `imap.exe` so that Explorer's Properties, installers and a host's
//! `GetFileVersionInfoW` read it. Shared by the library's and the command's build scripts.
//!
//! Written here rather than taken from a crate (embed-resource, winresource): those bring
//! a TOML parser into every build script run, Linux builds included, for what is one
//! resource script and one `windres` call, made only when the target is Windows.
use std::env;
use std::path::PathBuf;
use std::process::Command;

/// What the resource describes: the DLL or the command.
#[allow(dead_code)] // each build script names one of them
pub enum Kind {
    Dll,
    Exe,
}

/// On a Windows target, compiles a VERSIONINFO resource of the crate's version with
/// `windres` (`$WINDRES`, else the target's MinGW `windres`) into a COFF object and hands
/// it to the linker of the cdylib (`Kind::Dll`) or of the binaries (`Kind::Exe`). Does
/// nothing for other targets. A missing resource compiler stops the build with its name:
/// a Windows package without its version would be a silent gap.
pub fn embed(kind: Kind, file_name: &str, description: &str) {
    println!("cargo:rerun-if-env-changed=WINDRES");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("windows") {
        return;
    }
    let version = env::var("CARGO_PKG_VERSION").unwrap();
    let number = |name: &str| env::var(name).unwrap().parse::<u16>().unwrap_or(0);
    let (major, minor, patch) = (
        number("CARGO_PKG_VERSION_MAJOR"),
        number("CARGO_PKG_VERSION_MINOR"),
        number("CARGO_PKG_VERSION_PATCH"),
    );
    // VFT_DLL = 2, VFT_APP = 1; VOS_NT_WINDOWS32 = 0x40004. Numbers, not winver.h's names:
    // the script then needs no Windows headers.
    let file_type = match kind {
        Kind::Dll => 2,
        Kind::Exe => 1,
    };
    let rc = format!(
        "1 VERSIONINFO\n\
         FILEVERSION {major},{minor},{patch},0\n\
         PRODUCTVERSION {major},{minor},{patch},0\n\
         FILEFLAGSMASK 0x3f\n\
         FILEFLAGS 0\n\
         FILEOS 0x40004\n\
         FILETYPE {file_type}\n\
         FILESUBTYPE 0\n\
         BEGIN\n\
         BLOCK \"StringFileInfo\"\n\
         BEGIN\n\
         BLOCK \"040904b0\"\n\
         BEGIN\n\
         VALUE \"CompanyName\", \"libimap\"\n\
         VALUE \"FileDescription\", \"{description}\"\n\
         VALUE \"FileVersion\", \"{version}\"\n\
         VALUE \"InternalName\", \"imap\"\n\
         VALUE \"LegalCopyright\", \"MIT OR Apache-2.0\"\n\
         VALUE \"OriginalFilename\", \"{file_name}\"\n\
         VALUE \"ProductName\", \"libimap\"\n\
         VALUE \"ProductVersion\", \"{version}\"\n\
         END\n\
         END\n\
         BLOCK \"VarFileInfo\"\n\
         BEGIN\n\
         VALUE \"Translation\", 0x409, 1200\n\
         END\n\
         END\n"
    );
    let out = PathBuf::from(env::var("OUT_DIR").unwrap());
    let script = out.join("version.rc");
    let object = out.join("version_resource.o");
    std::fs::write(&script, rc).unwrap();
    let arch = env::var("CARGO_CFG_TARGET_ARCH").unwrap();
    let windres = env::var("WINDRES").unwrap_or_else(|_| format!("{arch}-w64-mingw32-windres"));
    let target = if arch == "x86" {
        "pe-i386"
    } else {
        "pe-x86-64"
    };
    let status = Command::new(&windres)
        .args(["-J", "rc", "-O", "coff", "-F", target, "-i"])
        .arg(&script)
        .arg("-o")
        .arg(&object)
        .status()
        .unwrap_or_else(|e| {
            panic!(
                "the Windows version resource needs a resource compiler: '{windres}' did not \
                 start ({e}); install binutils-mingw-w64 or set WINDRES"
            )
        });
    assert!(status.success(), "{windres} failed on {}", script.display());
    match kind {
        Kind::Dll => println!("cargo:rustc-cdylib-link-arg={}", object.display()),
        Kind::Exe => println!("cargo:rustc-link-arg-bins={}", object.display()),
    }
}

//! Finds Embree 4 and sets the link flags of every artifact of the crate.
//!
//! Search order: `EMBREE_DIR` (a directory holding `libembree4.so`), then the project's own
//! `deps/embree4/lib` (written by `scripts/setup-embree.sh`), then the system linker path.
//! The directory found is also handed to dependents' build scripts (`links = "imap"`).
//! Artifacts get an rpath to `$ORIGIN` (an installed `libimap.so` finds the Embree and TBB
//! libraries installed beside it) and to the directory found here (so tests and examples run
//! from the build tree). The cdylib gets the SONAME of the ABI policy (README): while the
//! major version is 0, `libimap.so.0.<minor>` (each 0.x minor is an ABI epoch); from 1.0 on,
//! `libimap.so.<major>`. An installed `libimap.so` finds Embree and TBB in `$ORIGIN/imap`,
//! a private directory (so the bundled TBB never shadows the system's).
use std::env;
use std::path::PathBuf;

#[path = "build-support/version_resource.rs"]
mod version_resource;

fn main() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    let manifest = PathBuf::from(env::var("CARGO_MANIFEST_DIR").unwrap());
    let local = manifest.join("deps/embree4/lib");
    println!("cargo:rerun-if-changed={}", local.display());

    let dir = env::var_os("EMBREE_DIR")
        .map(PathBuf::from)
        .or_else(|| local.join("libembree4.so").exists().then_some(local));
    // Windows (scripts/build-windows.sh): the linker takes embree4.dll itself; a DLL has no
    // rpath or SONAME (Windows finds DLLs beside the executable); it carries a version
    // resource of the crate's version instead (build-support/version_resource.rs).
    let windows = env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("windows");
    if let Some(dir) = dir {
        println!("cargo:rustc-link-search=native={}", dir.display());
        if !windows {
            println!("cargo:rustc-link-arg=-Wl,-rpath,{}", dir.display());
        }
        // For dependents' build scripts (the `imap` command): DEP_IMAP_EMBREE_DIR.
        println!("cargo:embree_dir={}", dir.display());
    }
    if windows {
        version_resource::embed(
            version_resource::Kind::Dll,
            "imap.dll",
            "libimap: illumination maps by forward Monte Carlo light tracing",
        );
        return;
    }
    println!("cargo:rustc-link-arg=-Wl,-rpath,$ORIGIN/imap:$ORIGIN");
    let major = env::var("CARGO_PKG_VERSION_MAJOR").unwrap();
    let minor = env::var("CARGO_PKG_VERSION_MINOR").unwrap();
    let soname = if major == "0" {
        format!("libimap.so.0.{minor}")
    } else {
        format!("libimap.so.{major}")
    };
    println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,{soname}");
}

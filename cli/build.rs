//! Gives the `imap` binary and its tests an rpath to the Embree libraries libimap was linked against
//! (libimap's build script hands the directory over as DEP_IMAP_EMBREE_DIR).
//! On Windows the command carries a version resource of the crate's version instead.
#[path = "../build-support/version_resource.rs"]
mod version_resource;

fn main() {
    println!("cargo:rerun-if-env-changed=DEP_IMAP_EMBREE_DIR");
    let windows = std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("windows");
    if let (Ok(dir), false) = (std::env::var("DEP_IMAP_EMBREE_DIR"), windows) {
        println!("cargo:rustc-link-arg=-Wl,-rpath,{dir}");
    }
    version_resource::embed(
        version_resource::Kind::Exe,
        "imap.exe",
        "imap: illumination maps and renders from models (libimap's command)",
    );
}

//! Gives the `imap` binary and its tests an rpath to the Embree libraries libimap was linked against
//! (libimap's build script hands the directory over as DEP_IMAP_EMBREE_DIR).
fn main() {
    println!("cargo:rerun-if-env-changed=DEP_IMAP_EMBREE_DIR");
    if let Ok(dir) = std::env::var("DEP_IMAP_EMBREE_DIR") {
        println!("cargo:rustc-link-arg=-Wl,-rpath,{dir}");
    }
}

//! Puts the root `memory.x` where the linker finds it and passes the linker
//! scripts to the firmware binaries only when they are built for the board
//! (global rustflags would break crates without defmt; on the host the
//! binaries are stubs and the library is what the tests use).
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let manifest =
        PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let memory = manifest.join("..").join("memory.x");
    println!("cargo:rerun-if-changed={}", memory.display());
    if !env::var("TARGET").is_ok_and(|t| t.starts_with("thumb")) {
        return;
    }
    fs::copy(&memory, out.join("memory.x")).expect("copy memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}

//! Linker set-up for the thumb target only: cortex-m-rt's `link.x` (which includes the
//! workspace's `memory.x`) and defmt's `defmt.x`.
use std::{env, path::PathBuf};

fn main() {
    let target = env::var("TARGET").unwrap_or_default();
    if target.starts_with("thumb") {
        let root = PathBuf::from(env::var("CARGO_MANIFEST_DIR").unwrap()).join("..");
        println!("cargo:rustc-link-search={}", root.display());
        println!("cargo:rustc-link-arg=--nmagic");
        println!("cargo:rustc-link-arg=-Tlink.x");
        println!("cargo:rustc-link-arg=-Tdefmt.x");
    }
    println!("cargo:rerun-if-changed=../memory.x");
    println!("cargo:rerun-if-changed=build.rs");
}

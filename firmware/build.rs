//! Puts the chip's memory map on the linker search path as `memory.x` and adds the linker
//! scripts, as embassy's rp235x and rp2040 examples do (cortex-m-rt's link.x, defmt's
//! defmt.x, and for the RP2040 embassy-rp's link-rp.x, which places boot2).
//!
//! The chip is a cargo feature (`rp2350`, the default, or `rp2040`) and each chip has its own
//! target; a mismatch would link an image the chip cannot boot, so it is refused here with
//! the command that builds the wanted variant.
use std::{env, fs, path::PathBuf};

fn main() {
    let rp2350 = env::var_os("CARGO_FEATURE_RP2350").is_some();
    let rp2040 = env::var_os("CARGO_FEATURE_RP2040").is_some();
    let target = env::var("TARGET").expect("TARGET");
    let (memory_x, want_target): (&[u8], &str) = match (rp2350, rp2040) {
        (true, false) => (
            include_bytes!("memory-rp2350.x"),
            "thumbv8m.main-none-eabihf",
        ),
        (false, true) => (include_bytes!("memory-rp2040.x"), "thumbv6m-none-eabi"),
        _ => panic!(
            "enable exactly one chip feature: `rp2350` (the default) or \
             `--no-default-features --features rp2040`"
        ),
    };
    if target != want_target {
        panic!(
            "this chip feature builds for {want_target}, not {target}: for the RP2040 use \
             `cargo build --release --no-default-features --features rp2040 --target \
             thumbv6m-none-eabi`"
        );
    }

    let out = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR"));
    fs::write(out.join("memory.x"), memory_x).expect("write memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory-rp2350.x");
    println!("cargo:rerun-if-changed=memory-rp2040.x");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    if rp2040 {
        println!("cargo:rustc-link-arg-bins=-Tlink-rp.x");
    }
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}

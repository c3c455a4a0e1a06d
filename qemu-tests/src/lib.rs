//! Runs the core's test vectors and benchmarks on an emulated Cortex-M33 (QEMU `mps2-an505`).
//!
//! * [`cases`]: the test vectors, shared with the host (the build script runs them on the
//!   host and writes the results to `expected.rs` in `OUT_DIR`, see [`EXPECTED`]).
//! * [`rt`]: what the two binaries share on the target: panic handler, semihosting exit,
//!   the instruction counter (SysTick under `-icount shift=0`) and stack painting.
//!
//! Binaries: `qemu-tests` (vectors, ends with `N passed, M failed`) and `qemu-bench`
//! (instruction counts and peak stack). Run them with `cargo xtask qemu` / `cargo xtask
//! qemu-bench` from the workspace root.
#![no_std]

pub mod cases;
pub mod rt;

include!(concat!(env!("OUT_DIR"), "/expected.rs"));

/// The host's results for the case called `name`, as `f32` bit patterns.
pub fn expected(name: &str) -> Option<&'static [u32]> {
    EXPECTED.iter().find(|(n, _)| *n == name).map(|(_, v)| *v)
}

//! Runs the core's test vectors and benchmarks on an emulated Cortex-M33 (QEMU `mps2-an505`).
//!
//! * [`cases`]: the test vectors, shared with the host (the build script runs them on the
//!   host and writes the results to `expected.rs` in `OUT_DIR`, see [`EXPECTED`]).
//! * [`real_data`]: the real recordings the real-data cases use (read by the build script).
//! * [`rt`]: what the two binaries share on the target: panic handler, semihosting exit,
//!   the instruction counter (SysTick under `-icount shift=0`) and stack painting.
//!
//! Binaries: `qemu-tests` (vectors, ends with `N passed, M failed`) and `qemu-bench`
//! (instruction counts and peak stack). Run them with `cargo xtask qemu` / `cargo xtask
//! qemu-bench` from the workspace root.
#![no_std]

pub mod background_bench;
pub mod cases;
pub mod gyro_bench;
pub mod motionplus_bench;
pub mod rt;

/// The real recordings, as the build script read them from `$WIICAL_DATA` (default
/// `<workspace>/../shared/data`) and wrote them to `OUT_DIR` (never into the repository):
/// the same `f32` bits the host's run of the cases used. The build script provides a module
/// with the same functions for its own (host) run.
pub mod real_data {
    include!(concat!(env!("OUT_DIR"), "/real_data.rs"));

    /// `imu_tk_xsens/xsens_acc.mat`: 51,175 samples of raw 16-bit counts as little-endian
    /// `f32` triplets `x, y, z` (the time column is dropped: its rate is 100 Hz).
    pub fn xsens_acc_f32le() -> &'static [u8] {
        XSENS_ACC_F32LE
    }

    /// The 38 static-window means (raw counts) the host's detector found in the Xsens
    /// recording with `wiical fit`'s default settings.
    pub fn xsens_poses() -> &'static [[f32; 3]] {
        &XSENS_POSES
    }

    /// `mag_ellipsoid_fit_python/mag_out.txt`: 347 raw magnetometer points, file order.
    pub fn mag_out_points() -> &'static [[f32; 3]] {
        &MAG_OUT_POINTS
    }
}

include!(concat!(env!("OUT_DIR"), "/expected.rs"));

/// The host's results for the case called `name`, as `f32` bit patterns.
pub fn expected(name: &str) -> Option<&'static [u32]> {
    EXPECTED.iter().find(|(n, _)| *n == name).map(|(_, v)| *v)
}

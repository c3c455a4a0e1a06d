//! The command line's grammar (clap) and its dispatch to `cmd`, in the library so that `main`
//! stays a printer and the fuzz target (fuzz/fuzz_targets/cli.rs) drives exactly the argument
//! and file path a user does.

use crate::cmd;
use anyhow::Result;
use clap::{Parser, Subcommand};

/// `wiical`'s arguments.
#[derive(Parser)]
#[command(name = "wiical", version, about = "Accelerometer / gyro / magnetometer calibration for the Wii Remote, Nunchuk and friends", long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    /// The subcommand.
    pub cmd: Cmd,
}

/// One subcommand with its arguments.
#[derive(Subcommand)]
pub enum Cmd {
    /// Six-position test (seed: T̂ = M·Â⁺) from a CSV with a `pose` column (x+ x- y+ y- z+ z-).
    SixPosition(cmd::six_position::Args),
    /// Static-interval detection + multi-position fit (bias + scale + non-orthogonality).
    Fit(cmd::fit::Args),
    /// Every sensor of a recording (accelerometer, gyroscope, magnetometer) with the method its
    /// recognised protocol calls for (free poses, six faces, one pose, Ferraris turns, rate
    /// table): one table and verdict per sensor.
    Calibrate(cmd::calibrate::Args),
    /// Gyroscope scale, misalignment and bias from the motions between static poses
    /// (Tedaldi et al. 2014): FILE with x,y,z and gx,gy,gz columns, or an accelerometer file and
    /// a gyro file (IMU-TK). The model (uncalibrated, bias, scale, full, each ± bias) is chosen
    /// by leave-one-motion-out error.
    Gyrofit(cmd::gyrofit::Args),
    /// Residual analysis: find what the linear model leaves unexplained, trace it to a missing
    /// effect (quadratic, cubic, bias-drift, temperature, temperature-scale, outliers), add it
    /// and report the error before and after (in-sample and leave-one-window-out CV).
    Analyze(cmd::analyze::Args),
    /// Correct a recording with a calibration file: the core calibration and its host-only
    /// time and temperature terms (`host_terms`, which the adapter does not apply), per
    /// sample; writes t,a_x,a_y,a_z (g) as CSV.
    Correct(cmd::correct::Args),
    /// Many recordings through `analyze` (or `fit`): one JSON line per file in a resumable
    /// results file (files already in it are skipped), `--jobs N` at once.
    Batch(cmd::batch::Args),
    /// Simulate a Wiimote/Nunchuk multi-position recording with known truth and, optionally,
    /// one effect the linear model lacks (truth written to FILE.truth.json).
    Simulate(cmd::simulate::Args),
    /// Record a Wii Remote's (and Nunchuk's) accelerometer over Bluetooth HID to CSV.
    ///
    /// Columns t,x,y,z (+ ext_x,ext_y,ext_z with a Nunchuk), raw counts; the factory
    /// calibrations go to OUT.cal.json. `--guided N` walks through N still poses for `fit`.
    Capture(cmd::capture::CaptureArgs),
    /// Talk to a wiical adapter over its serial port: info, get, put CAL.json, commit, stream.
    Device(cmd::device::DeviceArgs),
    /// Run the adapter's logic with a simulated Nunchuk and flash, serving the wire protocol
    /// on a pseudo-terminal (prints its path).
    #[cfg(unix)]
    DeviceSim(cmd::device_sim::SimArgs),
    /// Magnetometer hard/soft-iron fit: sphere (4 parameters), axis-aligned ellipsoid (6) or
    /// rotated ellipsoid (9), from streaming normal equations solved by Cholesky.
    Magfit(cmd::magfit::Args),
    /// Watch a calibration in the browser: a local page (127.0.0.1, port printed) with the
    /// poses' gravity directions on two hemispheres, still/moving, the coverage gap, the fit
    /// RMS, per-pose residuals and the verdict after each pose (magnetometer: the points and
    /// the ellipsoid fit error), from a recording replayed at its pace (`--replay`).
    Live(cmd::live::Args),
    /// Noise of a still recording: overlapping Allan deviation per axis (accelerometer, gyro,
    /// magnetometer) and the IEEE 952 terms where their slope is seen — white noise N,
    /// bias instability B, rate random walk K, quantisation Q, rate ramp R.
    Noise(cmd::noise::Args),
    /// Bias against temperature of a still warm-up (one or more poses): per axis a polynomial
    /// of order 1–3 in T − T_ref (chosen by leave-one-segment-out error), ArduPilot
    /// (INS_TCAL1_*) and PX4 (TC_A0_*) parameter files, or a calibration file's linear term.
    Tempcal(cmd::tempcal::Args),
    /// Decode a factory calibration block (hex bytes) of a Wii Remote (10 bytes at EEPROM 0x16,
    /// or both copies), a Nunchuk (16 bytes at 0x20, or 0x20–0x3F) or a MotionPlus (the 32
    /// gyro calibration bytes at 0xA60020, CRC-32 checked).
    DecodeCal(cmd::decode_cal::Args),
    /// The Wiimote article's Kalman filter ([position, velocity, bias]) as a Monte Carlo:
    /// a still accelerometer with a 0.25 m/s² bias, positions every 0.01 s with 0.5 cm noise.
    KalmanDemo(cmd::kalman_demo::Args),
}

/// Runs the parsed command; returns what to print on standard output.
pub fn run(cli: Cli) -> Result<String> {
    match cli.cmd {
        Cmd::SixPosition(a) => cmd::six_position::run(&a),
        Cmd::Fit(a) => cmd::fit::run(&a),
        Cmd::Calibrate(a) => cmd::calibrate::run(&a),
        Cmd::Analyze(a) => cmd::analyze::run(&a),
        Cmd::Correct(a) => cmd::correct::run(&a),
        Cmd::Gyrofit(a) => cmd::gyrofit::run(&a),
        Cmd::Batch(a) => cmd::batch::run(&a),
        Cmd::Simulate(a) => cmd::simulate::run(&a),
        Cmd::Capture(a) => cmd::capture::run(&a),
        Cmd::Device(a) => cmd::device::run(&a, &mut std::io::stdout().lock()),
        #[cfg(unix)]
        Cmd::DeviceSim(a) => cmd::device_sim::run(&a),
        Cmd::Magfit(a) => cmd::magfit::run(&a),
        Cmd::Live(a) => cmd::live::run(&a),
        Cmd::DecodeCal(a) => cmd::decode_cal::run(&a),
        Cmd::Noise(a) => cmd::noise::run(&a),
        Cmd::Tempcal(a) => cmd::tempcal::run(&a),
        Cmd::KalmanDemo(a) => cmd::kalman_demo::run(&a),
    }
}

/// Parses `args` (the first is the program name) and runs the command: the whole path of one
/// invocation except printing. A usage error is returned as clap's error (exit status 2 in
/// `main`), any other failure as the command's error.
pub fn run_args<I, T>(args: I) -> std::result::Result<String, RunError>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cli = Cli::try_parse_from(args).map_err(RunError::Usage)?;
    run(cli).map_err(RunError::Failed)
}

/// Why [`run_args`] produced no output.
#[derive(Debug)]
pub enum RunError {
    /// The arguments do not parse (or `--help`/`--version` was asked).
    Usage(clap::Error),
    /// The command ran and failed.
    Failed(anyhow::Error),
}

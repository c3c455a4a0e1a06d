//! `wiical gyrofit`: gyroscope scale, misalignment and bias from a multi-position recording
//! (engine: [`wiical_analysis::gyro`]; method: docs/gyro.md).

use super::{check_outputs, load_held, load_options, to_json, DetectArgs, PLAIN_TEXT_IN_PASSES};
use crate::cli_error::cli_error;
use anyhow::{bail, Context, Result};
use std::path::PathBuf;
use wiical_analysis::calibrate::GyroOutcome;
use wiical_analysis::gyro::open_text;
use wiical_analysis::gyro::request::{gyrofit_of, Gyrofit};
use wiical_analysis::gyro::ImuPair;
use wiical_analysis::{GyrofitRequest, Recording};
use wiical_core::multipos::MultiPosModel;

/// Arguments of `wiical gyrofit`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Recording with accelerometer and gyro columns (x,y,z and gx,gy,gz), or the
    /// accelerometer file of a pair (IMU-TK's `t x y z` text).
    pub file: PathBuf,
    /// The gyro file of a pair (same samples as FILE).
    pub gyro_file: Option<PathBuf>,
    /// Nominal gyro sensitivity in rad/s per count: one value for all axes or three
    /// (signed: an inverted axis is negative), e.g. 1.598e-4 (IMU-TK's Xsens, 1/6258).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub scale: Option<Vec<f64>>,
    /// Nominal gyro sensitivity as counts per °/s (datasheet style, e.g. 16.384 for ±2000 °/s
    /// on 16 bits); one value or three (signed). Alternative to --scale.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub counts_per_dps: Option<Vec<f64>>,
    /// Header names of the gyro columns in a single file (default: the triplet the header
    /// names as the gyroscope: gx,gy,gz, gyro_x_dps, …).
    #[arg(long, value_delimiter = ',')]
    pub gyro_columns: Option<Vec<String>>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Held-out errors by a refit per motion (slow: one fit per motion and model) instead of
    /// one Gauss–Newton step from the all-motion fit (docs/gyro.md: how far apart they are).
    #[arg(long)]
    pub exact_held_out: bool,
    /// Write the chosen gyro calibration (bias, matrix raw → rad/s, model, and the accepted
    /// g-sensitivity in rad/s/g) as JSON here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Known table rates, °/s (0 for a rest part), e.g. 25 for a rate table turned at ±25 °/s
    /// about each axis, or 0,200,270 for a record player at 33⅓ and 45 RPM: the gyro's scale,
    /// misalignment and bias from the steady parts, no clock needed.
    #[arg(long, value_delimiter = ',', value_parser = super::calibrate::rate_dps)]
    pub table_rate: Option<Vec<f64>>,
    /// The angle of each full turn between rests (the Ferraris protocol), degrees.
    #[arg(long, default_value_t = 360.0, value_parser = super::calibrate::angle_deg)]
    pub rotation_deg: f64,
    #[command(flatten)]
    pub detect: DetectArgs,
}

impl Args {
    /// The engine's request from the flags (the one translation of them; `--out` is the
    /// command line's own).
    fn request(&self) -> GyrofitRequest {
        GyrofitRequest {
            file: self.file.clone(),
            gyro_file: self.gyro_file.clone(),
            gyro_columns: self.gyro_columns.clone(),
            scale: self.scale.clone(),
            counts_per_dps: self.counts_per_dps.clone(),
            detect: self.detect.fit_options(MultiPosModel::Full).detect,
            exact_held_out: self.exact_held_out,
            table_rates_dps: self.table_rate.clone(),
            rotation_deg: self.rotation_deg,
        }
    }
}

/// Runs `wiical gyrofit`; returns what to print.
pub fn run(a: &Args) -> Result<String> {
    let req = a.request();
    let gyro_columns = req.gyro_columns().map_err(cli_error)?;
    let mut inputs = vec![a.file.as_path()];
    inputs.extend(a.gyro_file.as_deref());
    check_outputs(&inputs, &[a.out.as_deref()])?;
    let found = read_and_fit(a, &req, gyro_columns)?;
    let file = a.file.display().to_string();
    if let Some(e) = &found.motion_error {
        eprintln!(
            "note: in {file}: the motions between poses gave no calibration ({e}); the recognised protocol's method was used"
        );
    }
    if let Some(path) = &a.out {
        save(path, &found.report)?;
    }
    if a.json {
        return to_json(&found.report);
    }
    Ok(match &found.report {
        GyroOutcome::Motions(rep) => crate::render::gyrofit::text(rep, &file),
        GyroOutcome::Protocol(rep) => crate::render::protocol::gyro_text(rep, &file),
    })
}

/// Reads FILE (and GYRO_FILE) — notes on them go to stderr, each once — and runs `gyrofit`
/// on them ([`gyrofit_of`]: one code for the rows held and read in passes).
fn read_and_fit(
    a: &Args,
    req: &GyrofitRequest,
    gyro_columns: Option<[String; 3]>,
) -> Result<Gyrofit> {
    let (acc_opts, gyro_opts) = (
        a.detect.load_options()?,
        load_options(None, &a.detect.read)?,
    );
    if a.gyro_file.is_none() && gyro_columns.is_none() {
        if let Some(block) = wiical_capture::motionplus::detect(&a.file)? {
            return fit(req, &read_motionplus(a, &acc_opts, &block)?);
        }
    }
    let gyro_file = a.gyro_file.as_deref().map(|g| (g, &gyro_opts));
    let streamed = super::with_spinner(&format!("reading {}", a.file.display()), || {
        open_text(
            (&a.file, &acc_opts),
            gyro_file,
            gyro_columns.clone(),
            acc_opts.read.stream_from_bytes,
        )
    })
    .map_err(cli_error)?;
    if let Some(imu) = streamed {
        super::print_notes(&a.file, imu.accelerometer());
        match &a.gyro_file {
            Some(g) => super::print_notes(g, imu.gyroscope()),
            None => gyro_info(a, imu.accelerometer(), imu.gyroscope()),
        }
        return fit(req, &imu);
    }
    let (acc, gyro) = match &a.gyro_file {
        Some(g) => {
            // Two files: the gyro's is parsed on a second thread while the accelerometer's is
            // read here (parsing is a good part of what is left outside the fit); its notes
            // are printed after the accelerometer's, as when read one after the other.
            let (acc, gyro) = std::thread::scope(|s| {
                let gyro = s.spawn(|| {
                    wiical_analysis::input::front_door::load_held(g, &gyro_opts, held_limit())
                });
                let acc = load_held(&a.file, &acc_opts, "gyrofit", PLAIN_TEXT_IN_PASSES);
                (acc, gyro.join())
            });
            let acc = acc?;
            let gyro = gyro
                .map_err(|_| anyhow::anyhow!("reading {} failed", g.display()))?
                .map_err(cli_error)?;
            super::print_notes(g, &gyro);
            (acc, gyro)
        }
        None => {
            let (acc, gyro) = super::with_spinner(&format!("reading {}", a.file.display()), || {
                wiical_analysis::input::front_door::load_imu_within(
                    &a.file,
                    &acc_opts,
                    gyro_columns,
                    Some(held_limit()),
                )
            })
            .map_err(cli_error)?;
            super::print_notes(&a.file, &acc);
            gyro_info(a, &acc, &gyro);
            (acc, gyro)
        }
    };
    fit(req, &ImuPair::held(acc, gyro))
}

/// `gyrofit` on the rows `imu`, its error as the command line says it.
fn fit<S: wiical_analysis::gyro::ImuSide>(
    req: &GyrofitRequest,
    imu: &ImuPair<S>,
) -> Result<Gyrofit> {
    gyrofit_of(req, imu).map_err(cli_error)
}

/// A `wiical capture` of a MotionPlus: its gyro rows in slow-range counts
/// ([`wiical_capture::motionplus`]), held (a capture is at most a few hours at 100 Hz).
fn read_motionplus(
    a: &Args,
    acc_opts: &wiical_analysis::LoadOptions,
    block: &[u8; 32],
) -> Result<ImuPair<Recording>> {
    use wiical_analysis::input::columns::Sensor;
    use wiical_analysis::input::front_door::open_whole;
    let Err(text) = open_whole(&a.file, &acc_opts.read).map_err(cli_error)? else {
        bail!("{} is not a text capture", a.file.display());
    };
    let slow = wiical_capture::motionplus::to_slow_counts(&text, block)
        .with_context(|| format!("reading the MotionPlus capture {}", a.file.display()))?;
    eprintln!(
        "note: in {}: a MotionPlus capture: {} gyro rows with an axis in the fast range mapped onto the slow scale with {}; {} rows without gyro data (a Nunchuk passed through) left out",
        a.file.display(),
        slow.fast_rows,
        if slow.block_used {
            "its calibration block"
        } else {
            "the nominal ranges (its calibration block fails its CRC or is implausible)"
        },
        slow.without_gyro
    );
    let parse = |opts: &wiical_analysis::LoadOptions| {
        wiical_analysis::input::text::parse(&slow.text, opts)
            .map_err(|e| cli_error(e.in_file(&a.file)))
    };
    let acc = parse(acc_opts)?;
    let gyro = parse(&wiical_analysis::LoadOptions {
        columns: None,
        sensor: Some(Sensor::Gyroscope),
        read: acc_opts.read,
    })?;
    super::print_notes(&a.file, &acc);
    Ok(ImuPair::held(acc, gyro))
}

/// The bound on the samples `gyrofit` holds (a file it cannot read in passes).
fn held_limit() -> wiical_analysis::input::front_door::HoldLimit {
    wiical_analysis::input::front_door::HoldLimit::of("gyrofit", PLAIN_TEXT_IN_PASSES)
}

/// The loader's notes on the gyro's triplet of FILE that it did not make on the
/// accelerometer's.
fn gyro_info(a: &Args, acc: &Recording, gyro: &Recording) {
    for note in gyro.info.iter().filter(|n| !acc.info.contains(n)) {
        eprintln!("note: in {}: {note}", a.file.display());
    }
}

/// Writes `--out` (`wiical_analysis::output::gyrocal`): the chosen calibration (the motion
/// fit's with the accepted g-sensitivity; accepted effects the file cannot hold are named on
/// stderr). Refused when a protocol's method measured only the bias and no nominal scale is
/// known (the file would have no scale).
fn save(path: &std::path::Path, outcome: &GyroOutcome) -> Result<()> {
    let Some(file) = outcome.cal_file() else {
        bail!(
            "--out {}: only the gyro's bias was measured and no nominal scale is known (give --scale or --counts-per-dps, or known rates with --table-rate)",
            path.display()
        );
    };
    wiical_analysis::output::gyrocal::write_gyro_calibration(path, &file).map_err(cli_error)?;
    let GyroOutcome::Motions(rep) = outcome else {
        return Ok(());
    };
    for name in rep
        .effects
        .iter()
        .map(|e| e.name.as_str())
        .filter(|n| *n != wiical_analysis::gyro::device::G_SENSITIVITY)
    {
        eprintln!(
            "note: {} holds no {name} term (accepted above): a gyro calibration file carries only g-sensitivity",
            path.display()
        );
    }
    Ok(())
}

//! `wiical calibrate`: every sensor a recording holds, each with the method its recognised
//! protocol calls for, and one verdict per sensor (`wiical.calibrate` in Python returns the
//! same dictionary).
//!
//! The file is read once per sensor triplet the header names (accelerometer, gyroscope,
//! magnetometer; a header-less `t x y z` file is an accelerometer). Each sensor's result is
//! its own command's report — `fit` ([`crate::pipeline::fit_judged`], with the protocol's
//! method), `gyrofit` (the motions between poses, else [`crate::protocol::gyro`]), `magfit`
//! (the ellipsoid and its loop) — or the one sentence saying why it gave none. A sensor's
//! failure never hides the others'.

pub use crate::gyro::request::GyroOutcome;
use crate::gyro::request::{gyrofit_of, GyrofitRequest};
use crate::gyro::ImuPair;
use crate::input::columns::{all_named, column_sensor, Sensor};
use crate::input::front_door::Input;
use crate::input::read_options::ReadOptions;
use crate::input::recording::Recording;
use crate::magnetometer::{self, MagAnalysis, MagFitReport, MagModel};
use crate::pipeline::{fit_judged, Judged};
use crate::protocol::gyro::GyroProtocolOptions;
use crate::{FitOptions, FitReport, LoadOptions};
use serde::Serialize;
use std::path::Path;

/// Settings of `calibrate` (the per-sensor commands' defaults unless given).
#[derive(Debug, Clone, Default)]
pub struct CalibrateOptions {
    /// The accelerometer's fit (detector and model).
    pub fit: FitOptions,
    /// The gyro's settings (turn angle, table rates, nominal: `gyrofit`'s, as `--scale`); its
    /// detector is `fit`'s.
    pub gyro: GyroProtocolOptions,
    /// How the file is read (the accelerometer's input streamed from its size, as `fit`'s).
    pub read: crate::input::read_options::ReadOptions,
}

/// One sensor's outcome: its report, or why it has none.
#[derive(Debug, Clone, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Outcome<T> {
    /// The sensor's command's report.
    Ok(T),
    /// The one sentence saying why it gave none.
    Error(String),
}

/// The magnetometer's fit and loop.
#[derive(Debug, Clone, Serialize)]
pub struct MagOutcome {
    /// The ellipsoid fit.
    pub fit: MagFitReport,
    /// Its residual loop.
    pub analysis: MagAnalysis,
}

/// Everything `calibrate` found (`--json`).
#[derive(Debug, Clone, Serialize)]
pub struct CalibrateReport {
    /// Columns of each sensor found, e.g. `accelerometer: ax,ay,az`.
    pub sensors: Vec<String>,
    /// The accelerometer (absent when the file holds none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accelerometer: Option<Outcome<Judged<FitReport>>>,
    /// The gyroscope.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyroscope: Option<Outcome<GyroOutcome>>,
    /// The magnetometer.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub magnetometer: Option<Outcome<MagOutcome>>,
}

/// A sensor's triplet from `path`, when the header names one for `sensor`; the accelerometer
/// is also the triplet of a file that names no sensor (`x,y,z`, a header-less `t x y z`),
/// as for `fit`.
fn triplet(path: &Path, sensor: Sensor, read: &ReadOptions) -> Option<Recording> {
    // The accelerometer as `fit` reads it (the loader's default triplet: `x,y,z` beside
    // `gx,gy,gz` is the accelerometer); the others by their names.
    let opts = LoadOptions {
        columns: None,
        sensor: (sensor != Sensor::Accelerometer).then_some(sensor),
        read: *read,
    };
    let rec = crate::load(path, &opts).ok()?;
    let named = all_named(&rec.axis_columns, sensor);
    let other = rec.axis_columns.iter().any(|c| {
        column_sensor(c).is_some_and(|s| matches!(s, Sensor::Gyroscope | Sensor::Magnetometer))
    });
    (named || (sensor == Sensor::Accelerometer && !other)).then_some(rec)
}

/// The accelerometer's input as `fit` reads it (a window-mean table, a raw file's still
/// epochs, or samples), when the file has an accelerometer.
fn accel_input(
    path: &Path,
    acc: &Option<Recording>,
    read: &ReadOptions,
) -> Option<crate::Result<Input>> {
    acc.as_ref()?;
    let opts = crate::input::window_means::WindowInputOptions {
        load: LoadOptions {
            read: *read,
            ..Default::default()
        },
        force: false,
    };
    Some(crate::input::front_door::load_input(path, &opts))
}

/// Calibrates every sensor `path` holds.
pub fn calibrate(path: &Path, opts: &CalibrateOptions) -> crate::Result<CalibrateReport> {
    if path.as_os_str() == "-" {
        // Each sensor's triplet is read from the file in turn: standard input reads once.
        return Err(crate::Error::InvalidSetting(
            "calibrate reads the file once per sensor: give a file, not - (standard input)",
        ));
    }
    if !(opts.gyro.rotation_deg.is_finite() && opts.gyro.rotation_deg > 0.0) {
        return Err(crate::Error::InvalidSetting(
            "rotation_deg: the angle of each full turn must be a finite number of degrees above 0",
        ));
    }
    if let Some(r) = &opts.gyro.table_rates_dps {
        if r.is_empty() || r.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(crate::Error::InvalidSetting(
                "table_rate: the table rates must be finite numbers of °/s, 0 or above",
            ));
        }
    }
    let acc = triplet(path, Sensor::Accelerometer, &opts.read);
    let gyro = triplet(path, Sensor::Gyroscope, &opts.read);
    let mag = triplet(path, Sensor::Magnetometer, &opts.read);
    if acc.is_none() && gyro.is_none() && mag.is_none() {
        // Nothing named: the loader's own error for the accelerometer says why.
        crate::load(path, &LoadOptions::default())?;
    }
    let sensors = [
        ("accelerometer", &acc),
        ("gyroscope", &gyro),
        ("magnetometer", &mag),
    ]
    .iter()
    .filter_map(|(n, r)| {
        r.as_ref()
            .map(|r| format!("{n}: {}", r.axis_columns.join(",")))
    })
    .collect();
    let accelerometer = accel_input(path, &acc, &opts.read)
        .map(|i| outcome(i.and_then(|i| fit_judged(&i, &opts.fit))));
    Ok(CalibrateReport {
        sensors,
        accelerometer,
        gyroscope: gyro.map(|g| outcome(gyro_of(path, acc, g, opts))),
        magnetometer: mag.as_ref().map(|m| outcome(mag_of(m))),
    })
}

/// A sensor's result as its outcome.
fn outcome<T>(r: crate::Result<T>) -> Outcome<T> {
    match r {
        Ok(v) => Outcome::Ok(v),
        Err(e) => Outcome::Error(sentence(&e)),
    }
}

/// The error and its causes in one sentence (as the CLI prints them).
fn sentence(e: &crate::Error) -> String {
    let mut s = e.to_string();
    let mut src = std::error::Error::source(e);
    while let Some(c) = src {
        let t = c.to_string();
        if !s.contains(&t) {
            s = format!("{s}: {t}");
        }
        src = c.source();
    }
    s
}

/// The gyro as `gyrofit` decides ([`gyrofit_of`]): the motions between free poses when they
/// calibrate it, else the protocol's method. A file without an accelerometer gives its gyro's
/// triplet as both, as the loader does for `gyrofit` (a gyro-only file: the protocol's method
/// on the gyro alone). `opts.gyro.nominal_rad_per_raw`, when given, is both methods' nominal
/// (as `gyrofit --scale`); else the gyro columns' unit, if they state one.
fn gyro_of(
    path: &Path,
    acc: Option<Recording>,
    gyro: Recording,
    opts: &CalibrateOptions,
) -> crate::Result<GyroOutcome> {
    let req = GyrofitRequest {
        scale: opts.gyro.nominal_rad_per_raw.map(Vec::from),
        detect: opts.fit.detect.clone(),
        table_rates_dps: opts.gyro.table_rates_dps.clone(),
        rotation_deg: opts.gyro.rotation_deg,
        ..GyrofitRequest::new(path)
    };
    let acc = acc.unwrap_or_else(|| gyro.clone());
    Ok(gyrofit_of(&req, &ImuPair::held(acc, gyro))?.report)
}

/// The magnetometer: `magfit`'s default ellipsoid and its loop.
fn mag_of(m: &Recording) -> crate::Result<MagOutcome> {
    let prep = magnetometer::fit_source(m, MagModel::Ellipsoid)?;
    let alpha = crate::search::select::ALPHA;
    let analysis = magnetometer::analyze_source(m, &prep, &[], MagModel::Ellipsoid, alpha)?;
    let fit = prep.report;
    Ok(MagOutcome { fit, analysis })
}

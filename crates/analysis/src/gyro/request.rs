//! What a caller of `gyrofit` asks for, as one typed value: the files and the settings the
//! command line (`wiical gyrofit`) and the Python package (`wiical.gyrofit`) both take, with
//! their defaults here and the translation into [`GyroOptions`] written once, so that the two
//! doors cannot drift apart (issue 48). Argument errors are [`GyroArgError`]s: they name no
//! flag or keyword; the command line names its flags for them (`cli_error`), Python raises
//! `ValueError`.

use super::nominal::{nominal_from_columns, nominal_given_usable};
use super::options::GyroOptions;
use super::{GyroError, ImuPair, ImuSide};
use crate::detect::windows::DetectOptions;
pub use crate::error::gyro::{GyroArgError, NominalSetting};
use crate::input::columns::{all_named, Sensor};
use crate::input::recording::Recording;
use crate::input::text::LoadOptions;
use crate::protocol::gyro::GyroProtocolReport;
use crate::protocol::gyro::{self as protocol, GyroProtocolError, GyroProtocolOptions};
use serde::Serialize;
use std::path::PathBuf;

/// A `gyrofit` request: the recording (one file with accelerometer and gyro columns, or the
/// two files of a pair) and the settings both doors expose. [`GyrofitRequest::new`] has the
/// defaults: the nominal sensitivity from the gyro columns' unit or estimated from the
/// motions, the detector's defaults, held-out errors by one Gauss–Newton step.
#[derive(Debug, Clone)]
pub struct GyrofitRequest {
    /// Recording with accelerometer and gyro columns, or the accelerometer file of a pair.
    pub file: PathBuf,
    /// The gyro file of a pair (the same samples as `file`).
    pub gyro_file: Option<PathBuf>,
    /// Header names of the gyro columns in a single file (three; `None`: the triplet the
    /// header names as the gyroscope).
    pub gyro_columns: Option<Vec<String>>,
    /// Nominal sensitivity in rad/s per count: one value for every axis or three (signed: an
    /// inverted axis is negative).
    pub scale: Option<Vec<f64>>,
    /// Nominal sensitivity as counts per °/s (datasheet style): one value or three (signed).
    /// The alternative to `scale`; giving both is refused.
    pub counts_per_dps: Option<Vec<f64>>,
    /// Static-window detection on the accelerometer.
    pub detect: DetectOptions,
    /// Held-out errors by a refit per motion instead of one Gauss–Newton step
    /// ([`GyroOptions::exact_held_out`]).
    pub exact_held_out: bool,
    /// Known table rates, °/s (0 for a rest part): the protocol's known-rate method instead
    /// of the motions ([`crate::protocol::rates`]).
    pub table_rates_dps: Option<Vec<f64>>,
    /// The angle of each full turn between rests (Ferraris), degrees.
    pub rotation_deg: f64,
}

impl GyrofitRequest {
    /// The request for `file` with every setting at its default.
    pub fn new(file: impl Into<PathBuf>) -> Self {
        Self {
            file: file.into(),
            gyro_file: None,
            gyro_columns: None,
            scale: None,
            counts_per_dps: None,
            detect: DetectOptions::default(),
            exact_held_out: false,
            table_rates_dps: None,
            rotation_deg: 360.0,
        }
    }

    /// The gyro columns as three names; checked before any file is read.
    pub fn gyro_columns(&self) -> Result<Option<[String; 3]>, GyroArgError> {
        match self.gyro_columns.as_deref() {
            None => Ok(None),
            Some([x, y, z]) => Ok(Some([x.clone(), y.clone(), z.clone()])),
            Some(other) => Err(GyroArgError::ColumnsNotThree(other.to_vec())),
        }
    }

    /// The nominal sensitivity in rad/s per count and where it came from (the report's
    /// `nominal_source`: `--scale`, `--counts-per-dps`), else the gyro columns' unit
    /// (`gyro_x_dps`: 1 count = 1 °/s); `None`: neither, the engine estimates it from the
    /// motions.
    pub fn nominal(&self, gyro: &Recording) -> Result<Option<([f64; 3], String)>, GyroArgError> {
        let (s, source) = match (&self.scale, &self.counts_per_dps) {
            (Some(s), None) => (per_axis(s, NominalSetting::Scale)?, "--scale"),
            (None, Some(c)) => (
                per_axis(c, NominalSetting::CountsPerDps)?.map(|c| 1f64.to_radians() / c),
                "--counts-per-dps",
            ),
            (Some(_), Some(_)) => return Err(GyroArgError::BothNominals),
            (None, None) => return Ok(nominal_from_columns(gyro)),
        };
        if !nominal_given_usable(&s) {
            return Err(GyroArgError::NominalUnusable);
        }
        Ok(Some((s, source.to_string())))
    }

    /// The gyro loop's settings for the gyro recording `gyro` (whose columns may state the
    /// nominal's unit).
    pub fn options(&self, gyro: &Recording) -> Result<GyroOptions, GyroArgError> {
        let mut opts = GyroOptions::of_nominal(self.nominal(gyro)?);
        opts.detect = self.detect.clone();
        opts.exact_held_out = self.exact_held_out;
        Ok(opts)
    }
}

/// Three values from one or three given.
fn per_axis(v: &[f64], setting: NominalSetting) -> Result<[f64; 3], GyroArgError> {
    match v {
        [a] => Ok([*a; 3]),
        [a, b, c] => Ok([*a, *b, *c]),
        _ => Err(GyroArgError::NotPerAxis {
            setting,
            given: v.len(),
        }),
    }
}

impl<S: ImuSide> ImuPair<S> {
    /// The protocol's method on the gyro (with the accelerometer when `with_acc`), held or
    /// in passes ([`crate::protocol::gyro::run`]); a file's failure outside, the method's own
    /// error inside.
    fn protocol(
        &self,
        with_acc: bool,
        opts: &GyroProtocolOptions,
    ) -> crate::Result<Result<GyroProtocolReport, GyroProtocolError>> {
        let rep = protocol::run(with_acc.then_some(&self.acc), &self.gyro, opts);
        self.check()?;
        Ok(rep)
    }
}

/// The gyro's report (`gyrofit`'s, `calibrate`'s gyroscope): the motion fit's or a protocol's.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum GyroOutcome {
    /// The motions between free poses ([`crate::gyro::run`]).
    Motions(Box<crate::gyro::GyroReport>),
    /// A recognised protocol's method ([`crate::protocol::gyro`]).
    Protocol(Box<GyroProtocolReport>),
}

impl GyroOutcome {
    /// The gyro calibration file of the report; `None` when a protocol's method measured only
    /// the bias and no nominal scale is known ([`GyroProtocolReport::cal_file`]).
    pub fn cal_file(&self) -> Option<crate::output::gyrocal::GyroCalFile> {
        match self {
            GyroOutcome::Motions(rep) => Some(rep.cal_file()),
            GyroOutcome::Protocol(rep) => rep.cal_file(),
        }
    }
}

/// What `gyrofit` found: the motion fit's report, or the recognised protocol's method's
/// (its JSON is the report's).
#[derive(Debug)]
pub struct Gyrofit {
    /// The report.
    pub report: GyroOutcome,
    /// Why the motions between poses gave no calibration, when the protocol's method was
    /// used because of it (a note beside the report).
    pub motion_error: Option<GyroError>,
}

impl serde::Serialize for Gyrofit {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.report.serialize(s)
    }
}

/// Runs `gyrofit` as the library call: reads the file (or the pair) whole with the loader's
/// defaults, then [`gyrofit_of`]. The command line reads on its own (large files in passes, a
/// MotionPlus capture) and calls [`gyrofit_of`].
pub fn gyrofit(req: &GyrofitRequest) -> crate::Result<Gyrofit> {
    let gyro_columns = req.gyro_columns()?;
    let load = LoadOptions::default();
    let (acc, gyro) = match &req.gyro_file {
        Some(g) => (crate::load(&req.file, &load)?, crate::load(g, &load)?),
        None => crate::input::front_door::load_imu(&req.file, &load, gyro_columns)?,
    };
    gyrofit_of(req, &ImuPair::held(acc, gyro))
}

/// `gyrofit` on the recording `input`: a gyro-only file (the loader took the gyro's named
/// columns for the accelerometer: the file has none) or known table rates go to the
/// protocol's methods ([`crate::protocol::gyro`]); otherwise the motions between poses, and
/// the protocol's methods when those say the recording is another protocol's. When neither
/// gives a calibration, the motion fit's error is the one returned.
pub fn gyrofit_of<S: ImuSide>(req: &GyrofitRequest, input: &ImuPair<S>) -> crate::Result<Gyrofit> {
    let (acc, gyro) = (input.accelerometer(), input.gyroscope());
    let opts = req.options(gyro)?;
    let popts = GyroProtocolOptions {
        rotation_deg: req.rotation_deg,
        table_rates_dps: req.table_rates_dps.clone(),
        detect: opts.detect.clone(),
        nominal_rad_per_raw: (!opts.estimate_nominal).then_some(opts.nominal_rad_per_count),
    };
    // The same triplet given as both by hand stays the motion fit's to judge.
    let gyro_only = req.gyro_file.is_none()
        && acc.axis_columns == gyro.axis_columns
        && all_named(&gyro.axis_columns, Sensor::Gyroscope);
    let motion_error = if gyro_only || req.table_rates_dps.is_some() {
        None
    } else {
        match input.motions(&opts)? {
            Ok(rep) => {
                return Ok(Gyrofit {
                    report: GyroOutcome::Motions(Box::new(rep)),
                    motion_error: None,
                })
            }
            Err(e) if e.says_another_protocol() => Some(e),
            Err(e) => return Err(e.into()),
        }
    };
    match input.protocol(!gyro_only, &popts)? {
        Ok(rep) => Ok(Gyrofit {
            report: GyroOutcome::Protocol(Box::new(rep)),
            motion_error,
        }),
        Err(e) => Err(motion_error.map_or_else(|| e.into(), Into::into)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gyro(columns: [&str; 3]) -> Recording {
        let mut r = crate::arrays::recording(vec![[1.0, 2.0, 3.0]; 4], None, None).unwrap();
        r.axis_columns = columns.map(str::to_string);
        r
    }

    #[test]
    fn the_nominal_comes_from_one_setting_checked_per_axis() {
        let g = gyro(["gx", "gy", "gz"]);
        let mut req = GyrofitRequest::new("f.csv");
        assert_eq!(req.nominal(&g).unwrap(), None);
        req.scale = Some(vec![2e-3]);
        assert_eq!(
            req.nominal(&g).unwrap(),
            Some(([2e-3; 3], "--scale".to_string()))
        );
        req.scale = Some(vec![1.0, 2.0]);
        assert!(matches!(
            req.nominal(&g),
            Err(GyroArgError::NotPerAxis {
                setting: NominalSetting::Scale,
                given: 2
            })
        ));
        req.scale = None;
        req.counts_per_dps = Some(vec![16.384, -16.384, 16.384]);
        let (s, source) = req.nominal(&g).unwrap().unwrap();
        assert_eq!(source, "--counts-per-dps");
        assert!((s[1] + 1f64.to_radians() / 16.384).abs() < 1e-15, "{s:?}");
        req.counts_per_dps = Some(vec![0.0]);
        assert!(matches!(
            req.nominal(&g),
            Err(GyroArgError::NominalUnusable)
        ));
        req.scale = Some(vec![1.0]);
        assert!(matches!(req.nominal(&g), Err(GyroArgError::BothNominals)));
    }

    #[test]
    fn the_columns_unit_is_the_nominal_when_none_is_given() {
        let req = GyrofitRequest::new("f.csv");
        let opts = req
            .options(&gyro(["gyro_x_dps", "gyro_y_dps", "gyro_z_dps"]))
            .unwrap();
        assert!(!opts.estimate_nominal);
        assert_eq!(opts.nominal_rad_per_count, [1f64.to_radians(); 3]);
        let opts = req.options(&gyro(["gx", "gy", "gz"])).unwrap();
        assert!(opts.estimate_nominal);
    }

    #[test]
    fn gyro_columns_must_be_three() {
        let mut req = GyrofitRequest::new("f.csv");
        req.gyro_columns = Some(vec!["a".into(), "b".into()]);
        let e = req.gyro_columns().unwrap_err();
        assert!(matches!(&e, GyroArgError::ColumnsNotThree(n) if n.len() == 2));
        // Checked before the file is read: the missing file is not the error.
        assert!(matches!(
            gyrofit(&req),
            Err(crate::Error::Gyro(super::super::GyroError::Arg(_)))
        ));
    }
}

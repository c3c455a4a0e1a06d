//! `gyrofit` on large plain text files in bounded memory: the accelerometer's and the gyro's
//! triplets each a [`TextSource`] (the file read in passes, never held; for one file, two
//! sources of it with different columns), the windows found by `fit`'s streamed detection
//! ([`crate::detect::windows::detect_windows_streamed`]), and every other stage reading the rows through the same
//! passes as the held recording (`gyro/samples.rs`): the report is the held one's, bit for
//! bit.
//!
//! Memory is a piece of each file in flight, the windows, and the motions' samples with a
//! second either side (what the fit integrates, dozens of times: a pass over the file per
//! integration would cost hundreds of passes); on a multi-position recording those are a small
//! fraction of the rows (docs/gyro.md, "Large files").
//!
//! Streamed when both triplets give the same number of rows and the paired recording would take
//! its rate and temperature from the accelerometer's file as from the gyro's (always for one
//! file); otherwise (a capture whose gyro rows are a subset, two files of which only one states
//! a rate) [`open`] declines and the files are read whole.

use super::options::{GyroError, GyroOptions};
use super::samples::{ended_early, Imu, Row};
use super::GyroReport;
use crate::detect::windows::detect_windows_streamed;
use crate::detect::windows::sample_clock;
use crate::detect::windows::{DetectOptions, Windows};
use crate::error::{Error, Result};
use crate::input::columns::{all_named, LoadOptions, Sensor};
use crate::input::recording::Recording;
use crate::input::text_source::TextSource;
use crate::input::timecheck::TimeSteps;
use std::cell::RefCell;
use std::path::{Path, PathBuf};

/// The accelerometer's and the gyro's samples of large text files, opened for passes.
#[derive(Debug)]
pub struct StreamedImu {
    acc: TextSource,
    gyro: TextSource,
    acc_path: PathBuf,
    gyro_path: PathBuf,
}

impl StreamedImu {
    /// The accelerometer's recording without its samples (columns, notes, rate).
    pub fn accelerometer(&self) -> &Recording {
        &self.acc.meta
    }

    /// The gyro's recording without its samples.
    pub fn gyroscope(&self) -> &Recording {
        &self.gyro.meta
    }

    /// Rows.
    pub fn len(&self) -> usize {
        self.acc.len()
    }

    /// True without rows (never, once opened).
    pub fn is_empty(&self) -> bool {
        self.acc.is_empty()
    }
}

/// True when `path` is a regular file (not standard input) of at least `min_bytes`.
fn large(path: &Path, min_bytes: u64) -> bool {
    path.as_os_str() != "-"
        && std::fs::metadata(path).is_ok_and(|m| m.is_file() && m.len() >= min_bytes)
}

/// `path` opened as a source of `opts`'s triplet; `None` when it is not plain delimited text.
fn source(path: &Path, opts: &LoadOptions) -> Result<Option<TextSource>> {
    TextSource::open(path, opts, |_| true).map_err(|e| e.in_file(path))
}

/// The accelerometer (`acc`: its file and columns) and the gyro — of the file `gyro_file`
/// (its columns), else of the accelerometer's file (`gyro_columns`, else the triplet the header
/// names as a gyroscope's, as [`crate::input::front_door::load_imu`] takes it) — opened as
/// sources when one of the files is a regular plain text file of at least `stream_from` bytes
/// and both can be streamed (module docs); `None`: read them whole.
pub fn open(
    acc: (&Path, &LoadOptions),
    gyro_file: Option<(&Path, &LoadOptions)>,
    gyro_columns: Option<[String; 3]>,
    stream_from: u64,
) -> Result<Option<StreamedImu>> {
    let named = gyro_file.is_none() && gyro_columns.is_none();
    let same_file = LoadOptions {
        columns: gyro_columns,
        sensor: Some(Sensor::Gyroscope),
        read: acc.1.read,
    };
    let (gyro_path, gyro_opts) = gyro_file.unwrap_or((acc.0, &same_file));
    let paths = [acc.0, gyro_path];
    if !paths.iter().any(|p| large(p, stream_from)) || !paths.iter().all(|p| large(p, 0)) {
        return Ok(None);
    }
    let (a, g) = std::thread::scope(|s| {
        let g = s.spawn(|| source(gyro_path, gyro_opts));
        (source(acc.0, acc.1), g.join())
    });
    let g = g.unwrap_or_else(|p| std::panic::resume_unwind(p));
    let (Some(a), Some(g)) = (a?, g?) else {
        return Ok(None);
    };
    if named && !all_named(&g.meta.axis_columns, Sensor::Gyroscope) {
        let taken = g.meta.axis_columns.join(",");
        return Err(Error::from(GyroError::NoGyroColumns { taken }).in_file(acc.0));
    }
    let pairs = a.len() == g.len()
        && a.meta.sample_rate_hz.is_some() == g.meta.sample_rate_hz.is_some()
        && a.has_temp() == g.has_temp();
    Ok(pairs.then(|| StreamedImu {
        acc: a,
        gyro: g,
        acc_path: acc.0.to_path_buf(),
        gyro_path: gyro_path.to_path_buf(),
    }))
}

/// [`super::run`] on the streamed files: the same report as for their recordings held.
/// A file that changed or could not be read during a pass is that file's error.
pub fn run_streamed(imu: &StreamedImu, opts: &GyroOptions) -> Result<GyroReport> {
    super::check_nominal_scale(opts)?;
    let failed = RefCell::new(None);
    let view = Streamed {
        acc: (&imu.acc, &imu.acc_path),
        gyro: (&imu.gyro, &imu.gyro_path),
        failed: &failed,
        worst_clock_s: 0.0,
    };
    let out = clocks(&view).and_then(|worst_clock_s| {
        let view = Streamed {
            worst_clock_s,
            ..view
        };
        super::run_on(&view, opts)
    });
    if let Some(e) = failed.take() {
        return Err(e);
    }
    imu.acc.check().map_err(|e| e.in_file(&imu.acc_path))?;
    imu.gyro.check().map_err(|e| e.in_file(&imu.gyro_path))?;
    Ok(out?)
}

/// The paired recording of two sources (or of the same file's two triplets).
#[derive(Clone, Copy)]
struct Streamed<'a> {
    acc: (&'a TextSource, &'a Path),
    gyro: (&'a TextSource, &'a Path),
    /// Where a failure of the streamed detection is kept for [`run_streamed`].
    failed: &'a RefCell<Option<Error>>,
    /// The largest difference between the two time columns on one row, s (0 without both).
    worst_clock_s: f64,
}

/// Half the median step of `src`'s time column, s: the most the two clocks may differ
/// (infinite without a step), as `align` allows.
fn clock_tolerance(src: &TextSource) -> f64 {
    0.5 * src.steps.map_or(f64::INFINITY, |s| s.median_s)
}

/// The largest difference of the two time columns on one row, refused as `align` refuses it
/// when it is above [`clock_tolerance`]; a pass only when the rows may differ (two files, or
/// rows skipped in one triplet and not the other).
fn clocks(view: &Streamed<'_>) -> std::result::Result<f64, GyroError> {
    let (a, g) = (view.acc.0, view.gyro.0);
    if !(a.has_time() && g.has_time()) {
        return Ok(0.0);
    }
    let same_rows = view.acc.1 == view.gyro.1
        && a.meta.skipped_empty_rows == 0
        && g.meta.skipped_empty_rows == 0;
    if same_rows {
        return Ok(0.0);
    }
    let mut rows = 0;
    let worst = a
        .rows()
        .zip(g.rows())
        .inspect(|_| rows += 1)
        .map(|(a, g)| (a.t.unwrap_or(f64::NAN) - g.t.unwrap_or(f64::NAN)).abs())
        .fold(0.0, f64::max);
    if rows != a.len() {
        return Err(ended_early());
    }
    if worst > clock_tolerance(a) {
        return Err(GyroError::GyroClocksDiffer { offset_s: worst });
    }
    Ok(worst)
}

impl Streamed<'_> {
    /// Counts a pass's rows: short of the file's, the pass ended early.
    fn whole(&self, rows: usize) -> std::result::Result<(), GyroError> {
        if rows == self.len() {
            Ok(())
        } else {
            Err(ended_early())
        }
    }
}

impl Imu for Streamed<'_> {
    fn len(&self) -> usize {
        self.acc.0.len()
    }

    fn rate_hz(&self) -> Option<f64> {
        self.acc.0.estimated_rate_hz()
    }

    fn gyro_columns(&self) -> &[String; 3] {
        &self.gyro.0.meta.axis_columns
    }

    fn gyro_is_integer(&self) -> bool {
        self.gyro.0.summary.integer
    }

    fn windows(&self, opts: &DetectOptions) -> std::result::Result<Windows, GyroError> {
        detect_windows_streamed(self.acc.0, opts).map_err(|e| match e {
            Error::Detect(d) => GyroError::Detect(d),
            Error::Fit(f) => GyroError::Fit(f),
            other => {
                self.failed
                    .borrow_mut()
                    .get_or_insert(other.in_file(self.acc.1));
                ended_early()
            }
        })
    }

    fn time_steps(&self) -> Option<TimeSteps> {
        self.acc.0.has_time().then_some(self.acc.0.steps).flatten()
    }

    /// From the first pass: an axis is constant when all its values compare equal (`−0` and
    /// `0` do, NaN does not).
    fn constant_axes(&self) -> Option<Vec<usize>> {
        let constant = self.gyro.0.summary.constant;
        Some((0..3).filter(|&a| constant[a]).collect())
    }

    fn pass(
        &self,
        default_rate_hz: f64,
        visit: &mut dyn FnMut(usize, &Row),
    ) -> std::result::Result<(), GyroError> {
        let opts = DetectOptions {
            default_rate_hz,
            ..Default::default()
        };
        let clock = sample_clock(self.acc.0, &opts);
        let mut rows = 0;
        for (i, (a, g)) in self.acc.0.rows().zip(self.gyro.0.rows()).enumerate() {
            let row = Row {
                acc: a.xyz,
                gyro: g.xyz,
                t: clock(a.t, i),
                temp: a.temp,
            };
            visit(i, &row);
            rows += 1;
        }
        self.whole(rows)
    }

    fn gyro_pass(
        &self,
        visit: &mut dyn FnMut(usize, &[f64; 3]),
    ) -> std::result::Result<(), GyroError> {
        let mut rows = 0;
        for (i, g) in self.gyro.0.rows().enumerate() {
            visit(i, &g.xyz);
            rows += 1;
        }
        self.whole(rows)
    }

    fn swapped(&self) -> Option<Self> {
        (self.worst_clock_s <= clock_tolerance(self.gyro.0)).then_some(Self {
            acc: self.gyro,
            gyro: self.acc,
            ..*self
        })
    }
}

//! `wiical._wiical`: the compiled half of the Python package. Every function returns the
//! JSON text that the matching `wiical … --json` command prints, built by the same library
//! calls from the same report types (`wiical_analysis::pipeline`, `magnetometer`,
//! `six_position`, `factory`, `noise`, `tempcal`, `correct`); `wiical/__init__.py` turns it
//! into dictionaries. Samples cross the boundary as numpy arrays (the `numpy` crate: numpy's C
//! API looked up at run time, so no headers at build time and one abi3 wheel serves every
//! CPython from 3.9 on): an array given is read in place and copied once, into the
//! [`Recording`]; an array returned takes over the Rust vector without a copy.
//!
//! Arrays go through the loader's checks ([`wiical_analysis::arrays`]) and settings through
//! the CLI flags' ranges ([`DetectOptions::checked_settings`]), so that no door accepts what
//! another refuses.
//!
//! The analysis runs with the GIL released (`Python::detach`), so other Python threads (a
//! Dask worker's, a GUI's) keep running.

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArrayDyn};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use wiical_analysis::arrays::ArrayError;
use wiical_analysis::input::front_door::{load_input, Input};
use wiical_analysis::input::raw::load::raw_file_format;
use wiical_analysis::input::raw::samples;
use wiical_analysis::input::read_options::ReadOptions;
use wiical_analysis::input::window_means::WindowInputOptions;
use wiical_analysis::{
    input::columns::Sensor, AnalyzeOptions, Candidate, DetectOptions, FitOptions, LoadOptions,
    Recording,
};
use wiical_analysis::{Progress, ProgressHook, SampleInput};
use wiical_core::multipos::MultiPosModel;

create_exception!(
    _wiical,
    WiicalError,
    PyValueError,
    "An input wiical cannot use, with the sentence the command line prints."
);

/// The engine's error, or one of its stages' (joined into it), as a Python exception (its
/// message with its causes).
fn py_err(e: impl Into<wiical_analysis::Error>) -> PyErr {
    WiicalError::new_err(e.into().full_message())
}

/// A Python-side argument error (`ValueError`, not a [`WiicalError`]: the call was wrong,
/// not the data).
fn arg_err(msg: String) -> PyErr {
    PyValueError::new_err(msg)
}

/// Pretty JSON with a final newline, as the CLI prints it.
fn to_json<T: serde::Serialize>(v: &T) -> PyResult<String> {
    serde_json::to_string_pretty(v)
        .map(|s| s + "\n")
        .map_err(|e| arg_err(format!("internal: JSON: {e}")))
}

/// An array refused by the loader's checks, as a [`WiicalError`] (the data is wrong, not
/// the call).
fn array_err(e: ArrayError) -> PyErr {
    WiicalError::new_err(e.to_string())
}

/// Samples given as arrays: `xyz` (n × 3, any strides: read in place), optional times (s) and
/// temperatures (°C) of length n, checked as the loader checks a file's rows.
fn recording_from_arrays(
    xyz: &PyReadonlyArrayDyn<'_, f64>,
    t: Option<&PyReadonlyArray1<'_, f64>>,
    temp: Option<&PyReadonlyArray1<'_, f64>>,
) -> PyResult<Recording> {
    let view = xyz.as_array();
    let shape = view.shape();
    if shape.len() != 2 || shape[1] != 3 {
        let dims: Vec<String> = shape.iter().map(usize::to_string).collect();
        return Err(array_err(ArrayError::Shape {
            arg: "data",
            shape: format!("({})", dims.join(", ")),
        }));
    }
    // The one copy: into the rows the engine works on.
    let rows: Vec<[f64; 3]> = view
        .rows()
        .into_iter()
        .map(|r| [r[0], r[1], r[2]])
        .collect();
    let column = |a: Option<&PyReadonlyArray1<'_, f64>>| a.map(|a| a.as_array().to_vec());
    wiical_analysis::arrays::recording(rows, column(t), column(temp)).map_err(array_err)
}

/// Where the samples come from: a file the CLI reads (path), or arrays.
#[derive(FromPyObject)]
enum Source<'py> {
    /// A path (`str` or `os.PathLike`).
    #[pyo3(transparent)]
    Path(PathBuf),
    /// `(xyz, t or None, temp or None)`: float64 arrays, `xyz` of any shape (checked here so
    /// that a wrong one gets the package's sentence, not a conversion error).
    Arrays(
        PyReadonlyArrayDyn<'py, f64>,
        Option<PyReadonlyArray1<'py, f64>>,
        Option<PyReadonlyArray1<'py, f64>>,
    ),
}

/// The loader's options: `columns` (three header names) and which sensor's triplet.
fn load_options(columns: Option<Vec<String>>, sensor: Option<Sensor>) -> PyResult<LoadOptions> {
    let columns = match columns.as_deref() {
        None => None,
        Some([x, y, z]) => Some([x.clone(), y.clone(), z.clone()]),
        Some(other) => {
            return Err(py_err(wiical_analysis::Error::ColumnsNotThree(
                other.to_vec(),
            )))
        }
    };
    Ok(LoadOptions {
        columns,
        sensor,
        ..Default::default()
    })
}

/// How a file is read: plain text files of at least `stream_from_bytes` are streamed (read in
/// passes), as the CLI's `--stream-from-bytes` says (`None`: 128 MiB, as the CLI).
fn read_options(stream_from_bytes: Option<u64>) -> ReadOptions {
    let d = ReadOptions::default();
    ReadOptions {
        stream_from_bytes: stream_from_bytes.unwrap_or(d.stream_from_bytes),
        ..d
    }
}

/// The input as `fit`/`analyze` read it: a file (samples or a window-mean table), or arrays.
fn input_of(
    py: Python<'_>,
    source: Source<'_>,
    columns: Option<Vec<String>>,
    windows: bool,
    read: ReadOptions,
    progress: &Reporter,
) -> PyResult<Input> {
    match source {
        Source::Path(path) => {
            let opts = WindowInputOptions {
                load: LoadOptions {
                    read,
                    ..load_options(columns, None)?
                },
                force: windows,
            };
            progress.report("reading", 0, 0);
            let input = py.detach(|| load_input(&path, &opts)).map_err(py_err)?;
            let rows = input.len();
            progress.report("reading", rows, rows);
            Ok(input)
        }
        Source::Arrays(xyz, t, temp) => Ok(Input::Samples(recording_from_arrays(
            &xyz,
            t.as_ref(),
            temp.as_ref(),
        )?)),
    }
}

/// A Python progress callback `progress(stage: str, done: int, total: int)` (`total` 0: not
/// known), called from the thread doing the work (the GIL taken for the call). The first
/// exception it raises is kept and raised when the work returns.
#[derive(Clone, Default)]
struct Reporter {
    cb: Option<Arc<Py<PyAny>>>,
    failed: Arc<Mutex<Option<PyErr>>>,
}

impl Reporter {
    fn new(cb: Option<Py<PyAny>>) -> Self {
        Self {
            cb: cb.map(Arc::new),
            failed: Arc::default(),
        }
    }

    /// Reports `stage`, `done` of `total`; callable with or without the GIL.
    fn report(&self, stage: &str, done: usize, total: usize) {
        let Some(cb) = &self.cb else { return };
        Python::attach(|py| {
            if let Err(e) = cb.call1(py, (stage, done, total)) {
                let mut failed = self.failed.lock().unwrap_or_else(|p| p.into_inner());
                failed.get_or_insert(e);
            }
        });
    }

    /// The engine's progress hook that passes reports on (stage in words).
    fn hook(&self) -> ProgressHook {
        let me = self.clone();
        ProgressHook::new(move |p: Progress| me.report(&p.to_string(), p.done, p.total))
    }

    /// `Err` with the callback's first exception, if it raised one.
    fn finish(&self) -> PyResult<()> {
        let mut failed = self.failed.lock().unwrap_or_else(|p| p.into_inner());
        failed.take().map_or(Ok(()), Err)
    }
}

/// Detector settings (as the CLI's flags), a dict with every key (`None`: not given).
#[derive(FromPyObject, Default)]
#[pyo3(from_item_all)]
struct Detect {
    rate_hz: f64,
    window_s: Option<f64>,
    init_s: Option<f64>,
    min_static_s: Option<f64>,
    threshold: Option<f64>,
    adc_range: Option<(f64, f64)>,
}

impl Detect {
    /// The detector's options after the CLI flags' range checks (the error names the
    /// keyword argument and its range).
    fn options(&self) -> PyResult<DetectOptions> {
        DetectOptions::checked_settings(
            self.window_s,
            self.init_s,
            self.min_static_s,
            self.threshold,
            self.rate_hz,
            self.adc_range,
        )
        .map_err(|e| arg_err(e.to_string()))
    }
}

/// A sample rate given as `name` (Hz), through the CLI's `--rate-hz` range.
fn rate(name: &str, v: f64) -> PyResult<f64> {
    wiical_analysis::detect::windows::check_rate_hz(v)
        .map_err(|e| arg_err(format!("{name} = {v:?}: {e}")))
}

fn model_of(name: &str) -> PyResult<MultiPosModel> {
    match name {
        "full" => Ok(MultiPosModel::Full),
        "diagonal" => Ok(MultiPosModel::Diagonal),
        _ => Err(arg_err(format!(
            "model '{name}': expected full or diagonal"
        ))),
    }
}

/// `wiical fit --json`: static windows and the multi-position fit, with the quality verdict.
#[pyfunction]
#[pyo3(signature = (source, detect, columns=None, windows=false, model="full", progress=None, stream_from_bytes=None))]
#[allow(clippy::too_many_arguments)]
fn fit(
    py: Python<'_>,
    source: Source<'_>,
    detect: Detect,
    columns: Option<Vec<String>>,
    windows: bool,
    model: &str,
    progress: Option<Py<PyAny>>,
    stream_from_bytes: Option<u64>,
) -> PyResult<String> {
    let opts = FitOptions {
        detect: detect.options()?,
        model: model_of(model)?,
    };
    let progress = Reporter::new(progress);
    let read = read_options(stream_from_bytes);
    let input = input_of(py, source, columns, windows, read, &progress)?;
    progress.finish()?;
    progress.report("fitting", 0, 0);
    let judged = py
        .detach(|| wiical_analysis::pipeline::fit_judged(&input, &opts))
        .map_err(py_err)?;
    progress.report("fitting", 1, 1);
    progress.finish()?;
    to_json(&judged)
}

/// `wiical analyze --json`: the residual analysis, with the quality verdict.
#[pyfunction]
#[pyo3(signature = (source, detect, columns=None, windows=false, alpha=None, cv_factor=None, candidates=None, progress=None, stream_from_bytes=None))]
#[allow(clippy::too_many_arguments)]
fn analyze(
    py: Python<'_>,
    source: Source<'_>,
    detect: Detect,
    columns: Option<Vec<String>>,
    windows: bool,
    alpha: Option<f64>,
    cv_factor: Option<f64>,
    candidates: Option<Vec<String>>,
    progress: Option<Py<PyAny>>,
    stream_from_bytes: Option<u64>,
) -> PyResult<String> {
    let progress = Reporter::new(progress);
    let d = AnalyzeOptions::default();
    let (alpha, cv_factor) = (alpha.unwrap_or(d.alpha), cv_factor.unwrap_or(d.cv_factor));
    wiical_analysis::search::select::check_rule(alpha, cv_factor).map_err(py_err)?;
    let candidates = candidates
        .map(|names| names.iter().map(|n| n.parse::<Candidate>()).collect())
        .transpose()
        .map_err(py_err)?;
    let opts = AnalyzeOptions {
        fit: FitOptions {
            detect: detect.options()?,
            model: MultiPosModel::Full,
        },
        alpha,
        cv_factor,
        candidates,
        progress: progress.hook(),
        ..d
    };
    let read = read_options(stream_from_bytes);
    let input = input_of(py, source, columns, windows, read, &progress)?;
    progress.finish()?;
    let judged = py
        .detach(|| wiical_analysis::pipeline::analyze_judged(&input, &opts))
        .map_err(py_err)?;
    progress.finish()?;
    to_json(&judged)
}

/// The samples of a request: a file (read by the engine, as the CLI reads it), or arrays
/// (checked here as the loader checks a file's rows).
fn sample_input(source: Source<'_>) -> PyResult<SampleInput> {
    match source {
        Source::Path(path) => Ok(SampleInput::File(path)),
        Source::Arrays(xyz, t, temp) => Ok(SampleInput::from(recording_from_arrays(
            &xyz,
            t.as_ref(),
            temp.as_ref(),
        )?)),
    }
}

/// Samples of a file as `read` returns them.
fn samples_of(
    py: Python<'_>,
    source: Source<'_>,
    columns: Option<Vec<String>>,
) -> PyResult<Recording> {
    match source {
        Source::Path(path) => {
            let opts = load_options(columns, None)?;
            py.detach(|| wiical_analysis::load(&path, &opts))
                .map_err(py_err)
        }
        Source::Arrays(xyz, t, temp) => recording_from_arrays(&xyz, t.as_ref(), temp.as_ref()),
    }
}

/// `wiical magfit --json`: hard/soft-iron fit of magnetometer points and the residual loop,
/// by the engine's one request ([`wiical_analysis::MagfitRequest`]).
#[pyfunction]
#[pyo3(signature = (source, model="ellipsoid", columns=None))]
fn magfit(
    py: Python<'_>,
    source: Source<'_>,
    model: &str,
    columns: Option<Vec<String>>,
) -> PyResult<String> {
    let req = wiical_analysis::MagfitRequest {
        model: model.parse().map_err(arg_err)?,
        columns,
        ..wiical_analysis::MagfitRequest::new(sample_input(source)?)
    };
    let out = py
        .detach(|| wiical_analysis::magfit(&req))
        .map_err(py_err)?;
    to_json(&out)
}

/// `wiical calibrate --json`: every sensor of a recording with its recognised protocol's
/// method (`table_rate`: known gyro rates in °/s; `rotation_deg`: each full turn's angle).
#[pyfunction]
#[pyo3(signature = (path, table_rate=None, rotation_deg=360.0))]
fn calibrate(
    py: Python<'_>,
    path: PathBuf,
    table_rate: Option<Vec<f64>>,
    rotation_deg: f64,
) -> PyResult<String> {
    use wiical_analysis::calibrate::CalibrateOptions;
    if !(rotation_deg.is_finite() && rotation_deg > 0.0) {
        return Err(arg_err(format!(
            "rotation_deg {rotation_deg}: expected a positive angle in degrees"
        )));
    }
    if let Some(r) = &table_rate {
        if r.is_empty() || r.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(arg_err(
                "table_rate: expected one or more rates in °/s, each finite and ≥ 0".into(),
            ));
        }
    }
    let mut opts = CalibrateOptions::default();
    opts.gyro.rotation_deg = rotation_deg;
    opts.gyro.table_rates_dps = table_rate;
    let rep = py
        .detach(|| wiical_analysis::calibrate::calibrate(&path, &opts))
        .map_err(py_err)?;
    to_json(&rep)
}

/// `wiical six-position --json`: the seed's six-position test on a file with a pose column.
#[pyfunction]
#[pyo3(signature = (path, estimator="mean"))]
fn six_position(py: Python<'_>, path: PathBuf, estimator: &str) -> PyResult<String> {
    use wiical_analysis::fit::six_position::PoseEstimator;
    let est = match estimator {
        "mean" => PoseEstimator::Mean,
        "kalman" => PoseEstimator::Kalman,
        _ => {
            return Err(arg_err(format!(
                "estimator '{estimator}': expected mean or kalman"
            )))
        }
    };
    let rep = py
        .detach(|| {
            let rec = wiical_analysis::load(&path, &LoadOptions::default())?;
            Ok::<_, wiical_analysis::Error>(wiical_analysis::fit::six_position::run(&rec, est)?)
        })
        .map_err(py_err)?;
    to_json(&rep)
}

/// `wiical decode-cal --json`: a factory calibration block given as hex text. Returns the
/// JSON and whether the checksum holds (the CLI exits 1 when it does not).
#[pyfunction]
fn decode_cal(device: &str, hex: &str) -> PyResult<(String, bool)> {
    use wiical_factory::{self as factory, Device};
    // The decoder's sentence as the CLI prints it (a FactoryError has no source chain).
    let err = |e: factory::FactoryError| WiicalError::new_err(e.to_string());
    match device.parse::<Device>().map_err(err)? {
        Device::MotionPlus => {
            let bytes = factory::parse_hex(hex).map_err(err)?;
            let rep = factory::motionplus_calibration(&bytes, None).map_err(err)?;
            Ok((to_json(&rep)?, rep.checksum_ok))
        }
        _ => {
            let rep = factory::decode_cal(device, hex).map_err(err)?;
            Ok((to_json(&rep)?, rep.checksum_ok))
        }
    }
}

/// `wiical gyrofit --json`: gyro scale, misalignment and bias from the motions between the
/// static windows `fit` finds. `gyro_path`: the gyro file of a pair (IMU-TK); else the gyro
/// columns of `path` (named in the header, or `gyro_columns`). The nominal: `scale` (rad/s per
/// count, one or three values) or `counts_per_dps`, else the columns' unit, else estimated
/// from the motions — the CLI's order, in the engine's one request
/// ([`wiical_analysis::GyrofitRequest`]); its argument errors are `ValueError`s.
#[pyfunction]
#[pyo3(signature = (path, detect, gyro_path=None, gyro_columns=None, scale=None, counts_per_dps=None))]
fn gyrofit(
    py: Python<'_>,
    path: PathBuf,
    detect: Detect,
    gyro_path: Option<PathBuf>,
    gyro_columns: Option<Vec<String>>,
    scale: Option<Vec<f64>>,
    counts_per_dps: Option<Vec<f64>>,
) -> PyResult<String> {
    use wiical_analysis::{gyro::GyroError, Error, GyrofitRequest};
    let req = GyrofitRequest {
        gyro_file: gyro_path,
        gyro_columns,
        scale,
        counts_per_dps,
        detect: detect.options()?,
        ..GyrofitRequest::new(path)
    };
    let rep = py
        .detach(|| wiical_analysis::gyrofit(&req))
        .map_err(|e| match e {
            Error::Gyro(GyroError::Arg(e)) => arg_err(e.to_string()),
            e => py_err(e),
        })?;
    to_json(&rep)
}

/// What `read` returns: the samples (n × 3), times and temperatures (n, or `None`) as numpy
/// arrays, the times as block spans (`times="spans"`: start, duration and row boundaries, or
/// `None`), and the loader's metadata (JSON).
type ReadResult<'py> = (
    Bound<'py, PyAny>,
    Option<Bound<'py, PyArray1<f64>>>,
    Option<Bound<'py, PyAny>>,
    Option<SpanArrays<'py>>,
    String,
);

/// A raw file's times as block spans: each block's start (s), duration (s) and first row,
/// the row count last ([`samples::Spans`]).
type SpanArrays<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<u64>>,
);

fn sensor_of(sensor: Option<&str>) -> PyResult<Option<Sensor>> {
    match sensor {
        None => Ok(None),
        Some("accelerometer") => Ok(Some(Sensor::Accelerometer)),
        Some("gyroscope") => Ok(Some(Sensor::Gyroscope)),
        Some("magnetometer") => Ok(Some(Sensor::Magnetometer)),
        Some(s) => Err(arg_err(format!(
            "sensor '{s}': expected accelerometer, gyroscope or magnetometer"
        ))),
    }
}

/// Reads any recording the CLI reads: `(xyz, t or None, temp or None, spans or None,
/// metadata JSON)`, the values and temperatures as `dtype` (`"float64"` or `"float32"`), the
/// times (float64) as `times` asks: `"full"`, `"none"` or `"spans"` (a raw file's blocks'
/// spans, [`samples::Spans`]; a text file has no blocks, its times are given in full). A raw
/// file (`.cwa`, `.bin`) is written straight into vectors allocated once, its blocks decoded
/// on all cores ([`samples::read`]), which the arrays then take over. Any other file is the
/// loader's recording, whose vectors the float64 arrays take over without a copy (the rows of
/// `[f64; 3]` reinterpreted as 3n values, `bytemuck`: same alignment, same bytes); as float32
/// they are cast, one copy.
#[pyfunction]
#[pyo3(signature = (path, columns=None, sensor=None, progress=None, dtype="float64", times="full"))]
fn read<'py>(
    py: Python<'py>,
    path: PathBuf,
    columns: Option<Vec<String>>,
    sensor: Option<&str>,
    progress: Option<Py<PyAny>>,
    dtype: &str,
    times: &str,
) -> PyResult<ReadResult<'py>> {
    let opts = load_options(columns, sensor_of(sensor)?)?;
    let single = match dtype {
        "float64" => false,
        "float32" => true,
        other => {
            return Err(arg_err(format!(
                "dtype '{other}': expected \"float64\" or \"float32\""
            )))
        }
    };
    let times = match times {
        "full" => samples::Times::Full,
        "none" => samples::Times::Omit,
        "spans" => samples::Times::Spans,
        other => {
            return Err(arg_err(format!(
                "times '{other}': expected \"full\", \"none\" or \"spans\""
            )))
        }
    };
    let progress = Reporter::new(progress);
    progress.report("reading", 0, 0);
    if let Some(format) = raw_file_format(&path) {
        let out = if single {
            read_raw::<f32>(py, &path, format, &opts, times)?
        } else {
            read_raw::<f64>(py, &path, format, &opts, times)?
        };
        let n = out.0.len()?;
        progress.report("reading", n, n);
        progress.finish()?;
        return Ok(out);
    }
    let rec = py
        .detach(|| wiical_analysis::load(&path, &opts))
        .map_err(py_err)?;
    // A Ctrl-C during the read: KeyboardInterrupt now, before any array is made.
    py.check_signals()?;
    progress.report("reading", rec.len(), rec.len());
    progress.finish()?;
    let meta = serde_json::json!({
        "columns": rec.axis_columns,
        "sample_rate_hz": rec.sample_rate_hz.or_else(|| rec.estimated_rate_hz()),
        "labels": rec.labels,
        "notes": rec.notes,
        "info": rec.info,
        "skipped_empty_rows": rec.skipped_empty_rows,
    });
    let n = rec.xyz.len();
    let flat: Vec<f64> = bytemuck::allocation::cast_vec(rec.xyz);
    let (xyz, temp) = if single {
        let xyz = PyArray1::from_iter(py, flat.iter().map(|&v| v as f32));
        let temp = rec
            .temp
            .map(|t| PyArray1::from_iter(py, t.iter().map(|&v| v as f32)).into_any());
        (xyz.reshape([n, 3])?.into_any(), temp)
    } else {
        let xyz = PyArray1::from_vec(py, flat).reshape([n, 3])?.into_any();
        (xyz, rec.temp.map(|t| PyArray1::from_vec(py, t).into_any()))
    };
    let keep_t = times != samples::Times::Omit;
    let t = rec.t.filter(|_| keep_t).map(|t| PyArray1::from_vec(py, t));
    Ok((xyz, t, temp, None, meta.to_string()))
}

/// A raw file's samples read with the GIL released into vectors of `T` allocated once (zeroed
/// by the allocator: untouched pages cost nothing until written), then taken over by numpy
/// arrays without a copy.
fn read_raw<'py, T: samples::Real + numpy::Element>(
    py: Python<'py>,
    path: &std::path::Path,
    format: wiical_analysis::input::raw::RawFormat,
    opts: &LoadOptions,
    times: samples::Times,
) -> PyResult<ReadResult<'py>> {
    let got = py
        .detach(|| match map_cwa(path, format) {
            Some(bytes) => samples::read_cwa_bytes::<T>(path, bytes, opts, times),
            None => samples::read::<T>(path, format, opts, times),
        })
        .map_err(|e| py_err(e.in_file(path)))?;
    py.check_signals()?;
    let n = got.temp.len();
    let meta = serde_json::json!({
        "columns": got.meta.columns,
        "sample_rate_hz": got.meta.rate_hz,
        "labels": Option::<Vec<String>>::None,
        "notes": got.meta.notes,
        "info": [got.meta.info],
        "skipped_empty_rows": 0,
    });
    let spans = got.spans.map(|s| {
        (
            PyArray1::from_vec(py, s.start_s),
            PyArray1::from_vec(py, s.dur_s),
            PyArray1::from_vec(py, s.rows),
        )
    });
    Ok((
        PyArray1::from_vec(py, got.xyz).reshape([n, 3])?.into_any(),
        got.t.map(|t| PyArray1::from_vec(py, t)),
        Some(PyArray1::from_vec(py, got.temp).into_any()),
        spans,
        meta.to_string(),
    ))
}

/// A `.cwa` file mapped read-only into memory, for [`samples::read_cwa_bytes`] to decode its
/// blocks where the page cache holds them instead of copying them into a buffer first (the
/// copy was a tenth of the read's CPU); `None` (the file then read as usual, with the same
/// result) for another format or a file that cannot be mapped (not a regular file, an error).
///
/// The mapping's one hazard: a file cut shorter by another program *while* it is read makes
/// the pages past its new end unreadable, and touching one kills the process (SIGBUS) rather
/// than raising the one-sentence error. A file that is already short, or cut inside a block,
/// when it is opened reads exactly as when read, since only the length it has is mapped.
fn map_cwa(
    path: &std::path::Path,
    format: wiical_analysis::input::raw::RawFormat,
) -> Option<wiical_analysis::input::raw::cwa::Bytes> {
    if format != wiical_analysis::input::raw::RawFormat::Cwa {
        return None;
    }
    let file = std::fs::File::open(path).ok()?;
    if !file.metadata().ok()?.is_file() {
        return None;
    }
    // SAFETY: the map is read-only and private to this read; its bytes are only read while
    // it lives. The file changing underneath is the hazard stated above (a recording being
    // written is appended to, which leaves the mapped length intact).
    let map = unsafe { memmap2::Mmap::map(&file) }.ok()?;
    Some(Box::new(MappedCwa(map)))
}

/// A mapped `.cwa` whose pages are let go of as the reader passes them, so that the
/// process's resident memory holds the output and a chunk of the file, not the whole file.
struct MappedCwa(memmap2::Mmap);

impl wiical_analysis::input::raw::cwa::Mapped for MappedCwa {
    fn bytes(&self) -> &[u8] {
        &self.0
    }

    fn consumed(&self, upto: usize) {
        // Whole pages before `upto` only: rounded down to 64 KiB, a multiple of every page
        // size in use (the mapping itself starts on a page).
        let upto = upto & !0xffff;
        if upto > 0 {
            // SAFETY: the pages before `upto` are never read again by the reader (it asks
            // only for later chunks) and nothing else borrows this private mapping; for a
            // read-only file mapping, dropping them only unmaps them (the page cache keeps
            // them), and reading them again would fault them back in from the file.
            let _ = unsafe {
                self.0
                    .unchecked_advise_range(memmap2::UncheckedAdvice::DontNeed, 0, upto)
            };
        }
    }
}

/// Every sample's time from a raw file's block spans (what `read(times="spans")` gives): the
/// float64 array `read(times="full")` gives, bit for bit, expanded on all cores.
#[pyfunction]
fn span_times<'py>(
    py: Python<'py>,
    start_s: PyReadonlyArray1<'py, f64>,
    dur_s: PyReadonlyArray1<'py, f64>,
    rows: PyReadonlyArray1<'py, u64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let spans = samples::Spans {
        start_s: start_s.as_slice()?.to_vec(),
        dur_s: dur_s.as_slice()?.to_vec(),
        rows: rows.as_slice()?.to_vec(),
    };
    let n = spans.rows.last().copied().unwrap_or(0);
    let n = usize::try_from(n).map_err(|_| arg_err("spans: too many rows".into()))?;
    let t = py.detach(|| {
        let mut t = vec![0.0; n];
        spans.times_into(&mut t).map(|()| t)
    });
    let t = t.ok_or_else(|| {
        arg_err(
            "spans: inconsistent (one start and duration a block, rows one longer and increasing)"
                .into(),
        )
    })?;
    Ok(PyArray1::from_vec(py, t))
}

/// `wiical noise --json`: the Allan deviation of a still recording and the IEEE 952 terms.
/// A file's every sensor (as the CLI reads it), or arrays as one sensor.
#[pyfunction]
#[pyo3(signature = (source, rate_hz=100.0, columns=None, stream_from_bytes=None))]
fn noise(
    py: Python<'_>,
    source: Source<'_>,
    rate_hz: f64,
    columns: Option<Vec<String>>,
    stream_from_bytes: Option<u64>,
) -> PyResult<String> {
    let req = wiical_analysis::NoiseRequest {
        columns,
        read: read_options(stream_from_bytes),
        rate_hz: rate("rate_hz", rate_hz)?,
        ..wiical_analysis::NoiseRequest::new(sample_input(source)?)
    };
    // A file as `wiical noise` reads it: a large plain text file streamed in passes (memory: a
    // piece of it and the Allan sums), not held — which stops at the size cap of files read
    // whole (256 MiB) where the command line reads on.
    let rep = py.detach(|| wiical_analysis::noise(req)).map_err(py_err)?;
    to_json(&rep)
}

/// `wiical tempcal --json`: the bias of a still warm-up against temperature, per axis. The
/// settings' ranges are the engine's (the CLI's flags name the same ones).
#[pyfunction]
#[pyo3(signature = (source, tref, segments, block_s, pose_deg, rate_hz=100.0, columns=None))]
#[allow(clippy::too_many_arguments)]
fn tempcal(
    py: Python<'_>,
    source: Source<'_>,
    tref: f64,
    segments: usize,
    block_s: f64,
    pose_deg: f64,
    rate_hz: f64,
    columns: Option<Vec<String>>,
) -> PyResult<String> {
    use wiical_analysis::tempcal::{TempcalError, TempcalOptions};
    use wiical_analysis::{TempcalRequest, TempcalRunError};
    let req = TempcalRequest {
        columns,
        options: TempcalOptions {
            t_ref_c: tref,
            segments,
            block_s,
            pose_deg,
            default_rate_hz: rate("rate_hz", rate_hz)?,
        },
        ..TempcalRequest::new(sample_input(source)?)
    };
    let rep = py
        .detach(|| wiical_analysis::tempcal(&req))
        .map_err(|e| match e {
            TempcalRunError::Read(e) => py_err(e),
            TempcalRunError::Tempcal(TempcalError::Setting { what }) => {
                arg_err(format!("{what} (tref, segments, block_s, pose_deg)"))
            }
            TempcalRunError::Tempcal(other) => WiicalError::new_err(other.to_string()),
        })?;
    to_json(&rep)
}

/// What `correct` returns: times (s), corrected acceleration (n × 3, g) and the terms applied.
type Corrected<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyAny>, Vec<String>);

/// `wiical correct`: every sample corrected with a calibration file, host terms included.
#[pyfunction]
#[pyo3(signature = (calibration, source, rate_hz=100.0, columns=None))]
fn correct<'py>(
    py: Python<'py>,
    calibration: PathBuf,
    source: Source<'py>,
    rate_hz: f64,
    columns: Option<Vec<String>>,
) -> PyResult<Corrected<'py>> {
    use wiical_analysis::output::calfile::read_calibration_file;
    let rate_hz = rate("rate_hz", rate_hz)?;
    let file = py
        .detach(|| read_calibration_file(&calibration))
        .map_err(py_err)?;
    let rec = samples_of(py, source, columns)?;
    let c = py
        .detach(|| wiical_analysis::correct::correct_recording(&file, &rec, rate_hz))
        .map_err(py_err)?;
    let n = c.accel.len();
    let flat: Vec<f64> = c.accel.iter().flatten().map(|v| f64::from(*v)).collect();
    let accel = PyArray1::from_vec(py, flat).reshape([n, 3])?.into_any();
    Ok((PyArray1::from_vec(py, c.times), accel, c.applied))
}

/// The compiled module.
#[pymodule]
fn _wiical(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("WiicalError", m.py().get_type::<WiicalError>())?;
    // numpy's C API is looked up now, at import, not at the first array a call returns: that
    // lookup runs Python code, and a Ctrl-C pending after a long read raised its
    // KeyboardInterrupt inside it, which the numpy crate turns into a panic.
    // SAFETY: reads the API table's version entry; no argument, no pointer kept.
    let _ = unsafe { numpy::PY_ARRAY_API.PyArray_GetNDArrayCVersion(m.py()) };
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(analyze, m)?)?;
    m.add_function(wrap_pyfunction!(magfit, m)?)?;
    m.add_function(wrap_pyfunction!(gyrofit, m)?)?;
    m.add_function(wrap_pyfunction!(six_position, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(decode_cal, m)?)?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_function(wrap_pyfunction!(span_times, m)?)?;
    m.add_function(wrap_pyfunction!(noise, m)?)?;
    m.add_function(wrap_pyfunction!(tempcal, m)?)?;
    m.add_function(wrap_pyfunction!(correct, m)?)?;
    Ok(())
}

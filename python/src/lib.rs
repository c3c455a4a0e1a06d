//! `wiical._wiical`: the compiled half of the Python package. Every function returns the
//! JSON text that the matching `wiical … --json` command prints, built by the same library
//! calls from the same report types (`wiical_analysis::pipeline`, `magnetometer`,
//! `six_position`, `factory`); `wiical/__init__.py` turns it into dictionaries and numpy
//! arrays. Samples cross the boundary as little-endian `f64` bytes (numpy's `tobytes()` /
//! `frombuffer`), so the package needs no numpy headers at build time and one abi3 wheel
//! serves every CPython from 3.9 on.
//!
//! The analysis runs with the GIL released (`Python::detach`), so other Python threads (a
//! Dask worker's, a GUI's) keep running.

use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::path::PathBuf;
use wiical_analysis::input::window_table::{load_input, Input, WindowInputOptions};
use wiical_analysis::{
    input::columns::Sensor, AnalyzeOptions, Candidate, DetectOptions, FitOptions, LoadOptions,
    Recording,
};
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

/// `f64` values from little-endian bytes (numpy `float64` `tobytes()`).
fn f64s(bytes: &[u8], what: &str) -> PyResult<Vec<f64>> {
    if !bytes.len().is_multiple_of(8) {
        return Err(arg_err(format!(
            "{what}: {} bytes is not a whole number of float64 values",
            bytes.len()
        )));
    }
    Ok(bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
        .collect())
}

/// Samples given as arrays: `xyz` (n × 3, row-major), optional times (s) and temperatures
/// (°C) of the same length.
fn recording_from_arrays(xyz: &[u8], t: Option<&[u8]>, temp: Option<&[u8]>) -> PyResult<Recording> {
    let flat = f64s(xyz, "samples")?;
    if !flat.len().is_multiple_of(3) {
        return Err(arg_err(format!(
            "samples: {} values is not n rows of 3 (x, y, z)",
            flat.len()
        )));
    }
    let xyz: Vec<[f64; 3]> = flat.chunks_exact(3).map(|r| [r[0], r[1], r[2]]).collect();
    let column = |b: Option<&[u8]>, what: &str| -> PyResult<Option<Vec<f64>>> {
        let Some(b) = b else { return Ok(None) };
        let v = f64s(b, what)?;
        if v.len() != xyz.len() {
            return Err(arg_err(format!(
                "{what} has {} values but there are {} samples",
                v.len(),
                xyz.len()
            )));
        }
        Ok(Some(v))
    };
    Ok(Recording {
        t: column(t, "t")?,
        temp: column(temp, "temp")?,
        xyz,
        axis_columns: ["x".into(), "y".into(), "z".into()],
        ..Default::default()
    })
}

/// [`recording_from_arrays`] on the bytes objects Python passed.
fn arrays(
    xyz: &Bound<'_, PyBytes>,
    t: &Option<Bound<'_, PyBytes>>,
    temp: &Option<Bound<'_, PyBytes>>,
) -> PyResult<Recording> {
    recording_from_arrays(
        xyz.as_bytes(),
        t.as_ref().map(|b| b.as_bytes()),
        temp.as_ref().map(|b| b.as_bytes()),
    )
}

/// Where the samples come from: a file the CLI reads (path), or arrays.
#[derive(FromPyObject)]
enum Source<'py> {
    /// A path (`str` or `os.PathLike`).
    #[pyo3(transparent)]
    Path(PathBuf),
    /// `(xyz bytes, t bytes or None, temp bytes or None)`.
    Arrays(
        Bound<'py, PyBytes>,
        Option<Bound<'py, PyBytes>>,
        Option<Bound<'py, PyBytes>>,
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
    Ok(LoadOptions { columns, sensor })
}

/// The input as `fit`/`analyze` read it: a file (samples or a window-mean table), or arrays.
fn input_of(
    py: Python<'_>,
    source: Source<'_>,
    columns: Option<Vec<String>>,
    windows: bool,
) -> PyResult<Input> {
    match source {
        Source::Path(path) => {
            let opts = WindowInputOptions {
                load: load_options(columns, None)?,
                force: windows,
            };
            py.detach(|| load_input(&path, &opts)).map_err(py_err)
        }
        Source::Arrays(xyz, t, temp) => Ok(Input::Samples(arrays(&xyz, &t, &temp)?)),
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
    fn options(&self) -> DetectOptions {
        DetectOptions::from_settings(
            self.window_s,
            self.init_s,
            self.min_static_s,
            self.threshold,
            self.rate_hz,
            self.adc_range,
        )
    }
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
#[pyo3(signature = (source, detect, columns=None, windows=false, model="full"))]
fn fit(
    py: Python<'_>,
    source: Source<'_>,
    detect: Detect,
    columns: Option<Vec<String>>,
    windows: bool,
    model: &str,
) -> PyResult<String> {
    let opts = FitOptions {
        detect: detect.options(),
        model: model_of(model)?,
    };
    let input = input_of(py, source, columns, windows)?;
    let judged = py
        .detach(|| wiical_analysis::pipeline::fit_judged(&input, &opts))
        .map_err(py_err)?;
    to_json(&judged)
}

/// `wiical analyze --json`: the residual analysis, with the quality verdict.
#[pyfunction]
#[pyo3(signature = (source, detect, columns=None, windows=false, alpha=None, cv_factor=None, candidates=None))]
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
) -> PyResult<String> {
    let d = AnalyzeOptions::default();
    let (alpha, cv_factor) = (alpha.unwrap_or(d.alpha), cv_factor.unwrap_or(d.cv_factor));
    wiical_analysis::search::select::check_rule(alpha, cv_factor).map_err(py_err)?;
    let candidates = candidates
        .map(|names| names.iter().map(|n| n.parse::<Candidate>()).collect())
        .transpose()
        .map_err(py_err)?;
    let opts = AnalyzeOptions {
        fit: FitOptions {
            detect: detect.options(),
            model: MultiPosModel::Full,
        },
        alpha,
        cv_factor,
        candidates,
        ..d
    };
    let input = input_of(py, source, columns, windows)?;
    let judged = py
        .detach(|| wiical_analysis::pipeline::analyze_judged(&input, &opts))
        .map_err(py_err)?;
    to_json(&judged)
}

/// Samples of a file as `read` returns them (the magnetometer's triplet for `magfit`).
fn samples_of(
    py: Python<'_>,
    source: Source<'_>,
    columns: Option<Vec<String>>,
    sensor: Option<Sensor>,
) -> PyResult<Recording> {
    match source {
        Source::Path(path) => {
            let opts = load_options(columns, sensor)?;
            py.detach(|| wiical_analysis::load(&path, &opts))
                .map_err(py_err)
        }
        Source::Arrays(xyz, t, temp) => arrays(&xyz, &t, &temp),
    }
}

/// `wiical magfit --json`: hard/soft-iron fit of magnetometer points.
#[pyfunction]
#[pyo3(signature = (source, model="ellipsoid", columns=None))]
fn magfit(
    py: Python<'_>,
    source: Source<'_>,
    model: &str,
    columns: Option<Vec<String>>,
) -> PyResult<String> {
    let model: wiical_analysis::magnetometer::MagModel = model.parse().map_err(arg_err)?;
    let rec = samples_of(py, source, columns, Some(Sensor::Magnetometer))?;
    let rep = py
        .detach(|| wiical_analysis::magnetometer::fit_points(&rec.xyz, model))
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
    use wiical_analysis::factory::{self, Device};
    let err = |e: factory::FactoryError| py_err(e);
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
/// from the motions — the CLI's order.
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
    use wiical_analysis::gyro::{nominal_from_columns, GyroOptions};
    let three = |v: Vec<f64>, what: &str| -> PyResult<[f64; 3]> {
        match v.as_slice() {
            [a] => Ok([*a; 3]),
            [a, b, c] => Ok([*a, *b, *c]),
            _ => Err(arg_err(format!(
                "{what} takes one value or three, got {}",
                v.len()
            ))),
        }
    };
    let gyro_columns = match gyro_columns.as_deref() {
        None => None,
        Some([x, y, z]) => Some([x.clone(), y.clone(), z.clone()]),
        Some(o) => {
            return Err(arg_err(format!(
                "gyro_columns needs three names, got {}",
                o.len()
            )))
        }
    };
    let (acc, gyro) = py
        .detach(|| match &gyro_path {
            Some(g) => Ok((
                wiical_analysis::load(&path, &LoadOptions::default())?,
                wiical_analysis::load(g, &LoadOptions::default())?,
            )),
            None => {
                wiical_analysis::input::load::load_imu(&path, &LoadOptions::default(), gyro_columns)
            }
        })
        .map_err(py_err)?;
    let given = match (scale, counts_per_dps) {
        (Some(s), None) => Some((three(s, "scale")?, "--scale".to_string())),
        (None, Some(c)) => Some((
            three(c, "counts_per_dps")?.map(|c| 1f64.to_radians() / c),
            "--counts-per-dps".to_string(),
        )),
        (Some(_), Some(_)) => return Err(arg_err("give scale or counts_per_dps, not both".into())),
        (None, None) => nominal_from_columns(&gyro),
    };
    let mut opts = match given {
        Some((s, source)) => GyroOptions {
            nominal_source: source,
            ..GyroOptions::new(s)
        },
        None => GyroOptions::estimated(),
    };
    opts.detect = detect.options();
    let rep = py
        .detach(|| wiical_analysis::gyro::run(&acc, &gyro, &opts))
        .map_err(py_err)?;
    to_json(&rep)
}

/// What `read` returns: samples as bytes plus the loader's metadata (JSON).
type ReadResult<'py> = (
    Bound<'py, PyBytes>,
    Option<Bound<'py, PyBytes>>,
    Option<Bound<'py, PyBytes>>,
    String,
);

/// Reads any recording the CLI reads: `(xyz bytes, t bytes or None, temp bytes or None,
/// metadata JSON)`; `wiical.read` makes numpy arrays of them.
#[pyfunction]
#[pyo3(signature = (path, columns=None, sensor=None))]
fn read<'py>(
    py: Python<'py>,
    path: PathBuf,
    columns: Option<Vec<String>>,
    sensor: Option<&str>,
) -> PyResult<ReadResult<'py>> {
    let sensor = match sensor {
        None => None,
        Some("accelerometer") => Some(Sensor::Accelerometer),
        Some("gyroscope") => Some(Sensor::Gyroscope),
        Some("magnetometer") => Some(Sensor::Magnetometer),
        Some(s) => {
            return Err(arg_err(format!(
                "sensor '{s}': expected accelerometer, gyroscope or magnetometer"
            )))
        }
    };
    let opts = load_options(columns, sensor)?;
    let rec = py
        .detach(|| wiical_analysis::load(&path, &opts))
        .map_err(py_err)?;
    let bytes = |v: &mut dyn Iterator<Item = f64>| -> Vec<u8> {
        v.flat_map(f64::to_le_bytes).collect::<Vec<u8>>()
    };
    let xyz = bytes(&mut rec.xyz.iter().flatten().copied());
    let t = rec.t.as_ref().map(|t| bytes(&mut t.iter().copied()));
    let temp = rec.temp.as_ref().map(|t| bytes(&mut t.iter().copied()));
    let meta = serde_json::json!({
        "columns": rec.axis_columns,
        "sample_rate_hz": rec.sample_rate_hz.or_else(|| rec.estimated_rate_hz()),
        "labels": rec.labels,
        "notes": rec.notes,
        "info": rec.info,
        "skipped_empty_rows": rec.skipped_empty_rows,
    });
    Ok((
        PyBytes::new(py, &xyz),
        t.map(|b| PyBytes::new(py, &b)),
        temp.map(|b| PyBytes::new(py, &b)),
        meta.to_string(),
    ))
}

/// The compiled module.
#[pymodule]
fn _wiical(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("WiicalError", m.py().get_type::<WiicalError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(analyze, m)?)?;
    m.add_function(wrap_pyfunction!(magfit, m)?)?;
    m.add_function(wrap_pyfunction!(gyrofit, m)?)?;
    m.add_function(wrap_pyfunction!(six_position, m)?)?;
    m.add_function(wrap_pyfunction!(decode_cal, m)?)?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    Ok(())
}

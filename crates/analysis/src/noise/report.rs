//! `wiical noise`: which sensors a still recording holds, each axis's Allan deviation and its
//! IEEE 952 terms ([`crate::noise::allan`]), as the report whose JSON is the command's contract:
//! `axes` = one object per column with `column`, `unit`, `n`, `b`, `b_tau_s`, `k`, `q`, `r`
//! (IEEE 952's reading, [`crate::noise::reading`]; null where the term's slope is not seen),
//! `joint_fit` (the same keys from the five-term fit to the whole curve, a cross-check), `tau_s`,
//! `adev`, `adev_rel_err`.

use crate::error::noise::NoiseError;
use crate::error::Result;
use crate::input::columns::{classify, unit_of, Sensor};
use crate::input::front_door::open_whole;
use crate::input::recording::Recording;
use crate::input::text::{parse, LoadOptions};
use crate::noise::allan::{fit_terms, overlapping_adev, AllanCurve, NoiseTerms};
use crate::noise::reading::read_terms;
use serde::Serialize;
use std::path::Path;

/// One axis's noise.
#[derive(Debug, Clone, Serialize)]
pub struct NoiseAxis {
    /// The column.
    pub column: String,
    /// The sensor the header names it as (`accelerometer`, `gyroscope`, `magnetometer`, or
    /// `unnamed`).
    pub sensor: &'static str,
    /// The column's unit when its name states it (`gyro_x_dps` → `deg/s`) or, for an
    /// accelerometer, when its magnitude says g or m/s²; null otherwise (the file's own unit).
    pub unit: Option<String>,
    /// The terms by IEEE 952's reading (each off its own slope).
    #[serde(flatten)]
    pub terms: NoiseTerms,
    /// The five terms fitted jointly to the whole curve: a cross-check of the reading (the
    /// colouring at short τ pulls its N down and its B up on real logs).
    pub joint_fit: NoiseTerms,
    /// The curve.
    #[serde(flatten)]
    pub curve: AllanCurve,
}

/// The result of `wiical noise`.
#[derive(Debug, Clone, Serialize)]
pub struct NoiseReport {
    /// Samples per axis.
    pub samples: usize,
    /// Sample rate used, Hz.
    pub sample_rate_hz: f64,
    /// Length of the recording, s.
    pub duration_s: f64,
    /// Every axis of every sensor found.
    pub axes: Vec<NoiseAxis>,
}

/// The sensors of a still recording, read once: every triplet the header names (accelerometer,
/// gyroscope, magnetometer; plain `x,y,z` when it names none), or `columns` alone.
pub fn load_sensors(path: &Path, columns: Option<[String; 3]>) -> Result<Vec<Recording>> {
    let text = match open_whole(path)? {
        Ok(raw) => return raw_sensors(&raw, columns, path),
        Err(text) => text,
    };
    if columns.is_some() {
        let opts = LoadOptions {
            columns,
            sensor: None,
        };
        return Ok(vec![parse(&text, &opts).map_err(|e| e.in_file(path))?]);
    }
    let mut out: Vec<Recording> = Vec::new();
    // Which triplet each sensor picks is decided by the header: read it from the first lines,
    // then parse the whole text once per wanted triplet, so that memory holds the text and the
    // kept recordings only (not a discarded full parse beside them: 200 MB of x,y,z took
    // 820 MB that way). A head that does not parse on its own is parsed in full instead.
    let head = head_lines(&text, 64);
    let mut taken: Vec<[String; 3]> = Vec::new();
    for sensor in [
        Sensor::Accelerometer,
        Sensor::Gyroscope,
        Sensor::Magnetometer,
    ] {
        let opts = LoadOptions {
            columns: None,
            sensor: Some(sensor),
        };
        let probe = match parse(head, &opts) {
            Ok(rec) => rec.axis_columns,
            Err(_) => {
                parse(&text, &opts)
                    .map_err(|e| e.in_file(path))?
                    .axis_columns
            }
        };
        let named = sensor_of(&probe[0]);
        let wanted = named == sensor || (taken.is_empty() && named == Sensor::Unnamed);
        if wanted && !taken.contains(&probe) {
            out.push(parse(&text, &opts).map_err(|e| e.in_file(path))?);
            taken.push(probe);
        }
    }
    if out.is_empty() {
        // No sensor named at all: the loader's own choice.
        out.push(parse(&text, &LoadOptions::default()).map_err(|e| e.in_file(path))?);
    }
    Ok(out)
}

/// [`load_sensors`] of a raw file: the accelerometer (or `columns`), and an AX6's gyroscope.
fn raw_sensors(
    raw: &crate::input::raw::RawFile,
    columns: Option<[String; 3]>,
    path: &Path,
) -> Result<Vec<Recording>> {
    let mut out = vec![crate::input::raw::to_recording(
        raw,
        &LoadOptions {
            columns,
            sensor: None,
        },
    )
    .map_err(|e| e.in_file(path))?];
    let gyro = LoadOptions {
        columns: Some(["gx".into(), "gy".into(), "gz".into()]),
        sensor: None,
    };
    if let (Ok(g), None) = (crate::input::raw::to_recording(raw, &gyro), &out[0].labels) {
        if g.axis_columns != out[0].axis_columns {
            out.push(g);
        }
    }
    Ok(out)
}

/// The text up to and including its `n`-th line (all of it when shorter).
fn head_lines(text: &str, n: usize) -> &str {
    match text.match_indices('\n').nth(n.saturating_sub(1)) {
        Some((i, _)) => &text[..=i],
        None => text,
    }
}

fn sensor_of(column: &str) -> Sensor {
    classify(&column.to_ascii_lowercase()).map_or(Sensor::Unnamed, |(_, s, _)| s)
}

/// Each axis's Allan deviation and terms. `default_rate_hz` is used when the recording has no
/// time column or `Fs`. Refused when a recording is too short for any τ, or is not still,
/// varying and evenly sampled ([`crate::noise::still`]).
pub fn noise(recs: &[Recording], default_rate_hz: f64) -> Result<NoiseReport, NoiseError> {
    let first = recs.first().ok_or(NoiseError::NoSampleRate)?;
    let rate = first.estimated_rate_hz().unwrap_or(default_rate_hz);
    if !(rate.is_finite() && rate > 0.0) {
        return Err(NoiseError::NoSampleRate);
    }
    let samples = first.len();
    if samples < 2 * crate::noise::allan::MIN_CLUSTERS {
        return Err(NoiseError::NoiseTooShort {
            samples,
            needed: 2 * crate::noise::allan::MIN_CLUSTERS,
        });
    }
    for rec in recs {
        crate::noise::still::check_still(rec, sensor_of(&rec.axis_columns[0]), rate)?;
    }
    let mut axes = Vec::new();
    for rec in recs {
        let sensor = sensor_of(&rec.axis_columns[0]);
        let accel_unit = (sensor == Sensor::Accelerometer || sensor == Sensor::Unnamed)
            .then(|| accel_unit(rec))
            .flatten();
        for a in 0..3 {
            let y: Vec<f64> = rec.xyz.iter().map(|v| v[a]).collect();
            let curve = overlapping_adev(&y, rate);
            let column = rec.axis_columns[a].clone();
            // The column's own unit, else (accelerometer) what its magnitude says.
            let unit = unit_of(&column)
                .map(String::from)
                .or_else(|| accel_unit.clone());
            axes.push(NoiseAxis {
                sensor: sensor_name(sensor),
                unit,
                terms: read_terms(&curve),
                joint_fit: fit_terms(&curve),
                curve,
                column,
            });
        }
    }
    Ok(NoiseReport {
        samples,
        sample_rate_hz: rate,
        duration_s: samples as f64 / rate,
        axes,
    })
}

/// g or m/s² when the mean acceleration's magnitude says so (≈ 1 or ≈ 9.81).
fn accel_unit(rec: &Recording) -> Option<String> {
    let n = rec.len().max(1) as f64;
    let mean: [f64; 3] = std::array::from_fn(|a| rec.xyz.iter().map(|v| v[a]).sum::<f64>() / n);
    let norm = mean.iter().map(|m| m * m).sum::<f64>().sqrt();
    match crate::input::recording::infer_units(rec.is_integer(), norm) {
        "raw" => None,
        u => Some(u.into()),
    }
}

fn sensor_name(s: Sensor) -> &'static str {
    match s {
        Sensor::Accelerometer => "accelerometer",
        Sensor::Gyroscope => "gyroscope",
        Sensor::Magnetometer => "magnetometer",
        Sensor::Unnamed => "unnamed",
    }
}

/// One accelerometer axis's noise from a `wiical noise --json` file, in m/s² units: what the
/// `[p, v, b]` Kalman filter takes (`wiical_core::kalman::PvbConfig::from_allan`).
#[derive(Debug, Clone, PartialEq)]
pub struct AccelNoise {
    /// The column it came from.
    pub column: String,
    /// White noise density N, m/s²/√Hz.
    pub n_ms2_per_sqrt_hz: f64,
    /// Rate random walk K, m/s²/√s (0 when its slope was not seen).
    pub k_ms2_per_sqrt_s: f64,
    /// Whether K was seen.
    pub k_seen: bool,
}

/// Standard gravity, m/s² per g.
const G: f64 = 9.80665;

#[derive(serde::Deserialize)]
struct NoiseFile {
    axes: Vec<AxisIn>,
}

#[derive(serde::Deserialize)]
struct AxisIn {
    column: String,
    sensor: String,
    unit: Option<String>,
    n: Option<f64>,
    k: Option<f64>,
}

/// The accelerometer noise of a `wiical noise --json` file: the axis named `axis`, else the
/// noisiest accelerometer axis (largest N: the filter's σ must cover every axis it is used
/// on). Refused, in one sentence, when the file has no such axis, its unit is not g or m/s², or
/// its N was not seen.
pub fn accel_noise_from_json(text: &str, axis: Option<&str>) -> Result<AccelNoise, NoiseError> {
    let why = |w: String| NoiseError::NoiseFileUnusable { why: w };
    let file: NoiseFile = serde_json::from_str(text)
        .map_err(|e| why(format!("not a `wiical noise --json` file: {e}")))?;
    let accel = |a: &&AxisIn| a.sensor == "accelerometer" || a.sensor == "unnamed";
    let chosen = match axis {
        Some(name) => file.axes.iter().find(|a| a.column == name),
        None => file
            .axes
            .iter()
            .filter(accel)
            .filter(|a| a.n.is_some())
            .max_by(|a, b| a.n.unwrap_or(0.0).total_cmp(&b.n.unwrap_or(0.0))),
    }
    .ok_or_else(|| {
        why(format!(
            "no axis {} in it",
            axis.unwrap_or("of an accelerometer with N seen")
        ))
    })?;
    let to_ms2 = match chosen.unit.as_deref() {
        Some("g") => G,
        Some("m/s^2") => 1.0,
        other => {
            return Err(why(format!(
                "axis {} is in {}, not g or m/s²",
                chosen.column,
                other.unwrap_or("an unknown unit")
            )))
        }
    };
    let n = chosen.n.ok_or_else(|| {
        why(format!(
            "axis {}'s white noise N was not seen (the curve has no −½ slope)",
            chosen.column
        ))
    })?;
    Ok(AccelNoise {
        column: chosen.column.clone(),
        n_ms2_per_sqrt_hz: n * to_ms2,
        k_ms2_per_sqrt_s: chosen.k.unwrap_or(0.0) * to_ms2,
        k_seen: chosen.k.is_some(),
    })
}

//! `wiical noise`: which sensors a still recording holds, each axis's Allan deviation and its
//! IEEE 952 terms ([`crate::noise::allan`]), as the report whose JSON is the command's contract:
//! `axes` = one object per column with `column`, `unit`, `n`, `b`, `b_tau_s`, `k`, `q`, `r`
//! (IEEE 952's reading, `crate::noise::reading`; null where the term's slope is not seen),
//! `joint_fit` (the same keys from the five-term fit to the whole curve, a cross-check), `tau_s`,
//! `adev`, `adev_rel_err`.

use crate::detect::polled::Polling;
use crate::error::noise::NoiseError;
use crate::error::Result;
use crate::input::columns::{column_sensor, unit_of, Sensor};
use crate::input::front_door::open_whole;
use crate::input::read_options::ReadOptions;
use crate::input::recording::Recording;
use crate::input::text::{parse, LoadOptions};
use crate::input::text_source::TextSource;
use crate::noise::allan::{fit_terms, AllanCurve, NoiseTerms};
use crate::noise::pass::{sensor_noise, Overlap, SensorSamples, FULL_OVERLAP_M};
use crate::noise::reading::read_terms;
use crate::source::{RowSource, SampleSource};
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
    /// What the large-file path did differently from holding the samples (absent when they
    /// were held): [`crate::noise::pass`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub streamed: Option<String>,
    /// The sensors whose log was polled faster than they update ([`crate::detect::polled`]):
    /// their Allan deviations are of the distinct samples at the sensor's own rate, not of
    /// the rows (a reading logged four times in a row flattens the curve's first points and
    /// halves the white noise read off them). Absent when none was.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub polled: Vec<PolledSensor>,
}

/// One sensor of a `noise` report found polled faster than it updates.
#[derive(Debug, Clone, Serialize)]
pub struct PolledSensor {
    /// Its columns, comma-separated.
    pub columns: String,
    /// The rates and runs.
    #[serde(flatten)]
    pub polling: Polling,
}

/// The sensors of a still recording, read once: every triplet the header names (accelerometer,
/// gyroscope, magnetometer; plain `x,y,z` when it names none), or `columns` alone. `read`:
/// how standard input is read.
pub fn load_sensors(
    path: &Path,
    columns: Option<[String; 3]>,
    read: &ReadOptions,
) -> Result<Vec<Recording>> {
    let text = match open_whole(path, read)? {
        Ok(raw) => return raw_sensors(&raw, columns, path),
        Err(text) => text,
    };
    // Each wanted triplet parsed from the whole text once: memory holds the text and the
    // kept recordings only (not a discarded full parse beside them: 200 MB of x,y,z took
    // 820 MB that way).
    let open = |opts: &LoadOptions| parse(&text, opts).map(Some).map_err(|e| e.in_file(path));
    let head = head_lines(&text, 64);
    let picked = pick_sensors(head, columns, read, open, |r| r.axis_columns.clone())?;
    Ok(picked.unwrap_or_default())
}

/// The triplets of a still recording [`load_sensors`] and [`open_sensors`] read, each opened
/// by `open` (`None`: the file cannot be read that way, and then none is): `columns` alone,
/// else each sensor's triplet that the header names ([`takes`]; decided from its first lines
/// `head`, from the whole file when they do not parse on their own), else the loader's own
/// choice when it names none.
fn pick_sensors<T>(
    head: &str,
    columns: Option<[String; 3]>,
    read: &ReadOptions,
    open: impl Fn(&LoadOptions) -> Result<Option<T>>,
    axes: impl Fn(&T) -> [String; 3],
) -> Result<Option<Vec<T>>> {
    let opts = |columns, sensor| LoadOptions {
        columns,
        sensor,
        read: *read,
    };
    if columns.is_some() {
        return Ok(open(&opts(columns, None))?.map(|s| vec![s]));
    }
    let (mut out, mut taken) = (Vec::new(), Vec::<[String; 3]>::new());
    for sensor in SENSORS {
        let o = opts(None, Some(sensor));
        let (probe, opened) = match parse(head, &o) {
            Ok(rec) => (rec.axis_columns, None),
            Err(_) => match open(&o)? {
                Some(s) => (axes(&s), Some(s)),
                None => return Ok(None),
            },
        };
        if takes(sensor, &probe, &taken) {
            match opened.map_or_else(|| open(&o), |s| Ok(Some(s)))? {
                Some(s) => out.push(s),
                None => return Ok(None),
            }
            taken.push(probe);
        }
    }
    if out.is_empty() {
        // No sensor named at all: the loader's own choice.
        match open(&opts(None, None))? {
            Some(s) => out.push(s),
            None => return Ok(None),
        }
    }
    Ok(Some(out))
}

/// The sensors asked for in turn, each the triplet the loader picks for it.
const SENSORS: [Sensor; 3] = [
    Sensor::Accelerometer,
    Sensor::Gyroscope,
    Sensor::Magnetometer,
];

/// True when the triplet `probe` the loader picked for `sensor` is to be read, given the
/// triplets `taken` so far: its header names that sensor (or names none and nothing was taken
/// yet), and it is not one already taken. The held and the streamed paths choose alike.
fn takes(sensor: Sensor, probe: &[String; 3], taken: &[[String; 3]]) -> bool {
    let named = sensor_of(&probe[0]);
    let wanted = named == sensor || (taken.is_empty() && named == Sensor::Unnamed);
    wanted && !taken.contains(probe)
}

/// The sensors of a still recording: held as recordings, or (a plain text file of at least
/// [`ReadOptions::stream_from_bytes`] bytes) opened as sources read in passes. One code reads
/// either ([`noise_of`]); the two variants only carry the sources' type.
#[derive(Debug)]
pub enum Sensors {
    /// Every sample held ([`load_sensors`]).
    Held(Vec<Recording>),
    /// Read in passes from the file, never held.
    Streamed(Vec<TextSource>),
}

impl Sensors {
    /// The first sensor's recording (a streamed one's without samples): its notes.
    pub fn first(&self) -> Option<&Recording> {
        match self {
            Sensors::Held(recs) => recs.first(),
            Sensors::Streamed(srcs) => srcs.first().map(|s| &s.meta),
        }
    }
}

/// [`load_sensors`], or the same sensors streamed when `path` is a plain text file of at least
/// [`ReadOptions::stream_from_bytes`] bytes (as for `fit`; gzip, raw or a pose column: held).
pub fn open_sensors(
    path: &Path,
    columns: Option<[String; 3]>,
    read: &ReadOptions,
) -> Result<Sensors> {
    if crate::input::text_source::large(path, read.stream_from_bytes) {
        let open = |opts: &LoadOptions| TextSource::open_from(path, opts, 0);
        let head = first_lines(path, 64);
        let axes = |s: &TextSource| s.meta.axis_columns.clone();
        if let Some(srcs) = pick_sensors(&head, columns.clone(), read, open, axes)? {
            return Ok(Sensors::Streamed(srcs));
        }
    }
    load_sensors(path, columns, read).map(Sensors::Held)
}

/// The first `n` lines of a file (at most its first MiB, cut at a character boundary).
fn first_lines(path: &Path, n: usize) -> String {
    use std::io::Read;
    let mut buf = Vec::new();
    let read = std::fs::File::open(path).and_then(|f| f.take(1 << 20).read_to_end(&mut buf));
    if read.is_err() {
        return String::new();
    }
    let text = match std::str::from_utf8(&buf) {
        Ok(t) => t,
        Err(e) => std::str::from_utf8(&buf[..e.valid_up_to()]).unwrap_or_default(),
    };
    head_lines(text.trim_start_matches('\u{feff}'), n).to_string()
}

/// [`load_sensors`] of a raw file: the accelerometer (or `columns`), and an AX6's gyroscope.
fn raw_sensors(
    raw: &crate::input::raw::Raw,
    columns: Option<[String; 3]>,
    path: &Path,
) -> Result<Vec<Recording>> {
    let load = |opts: &LoadOptions| crate::input::raw::load::load_raw(raw.blocks(), opts);
    let accel = LoadOptions {
        columns,
        ..Default::default()
    };
    let mut out = vec![load(&accel).map_err(|e| e.in_file(path))?];
    let gyro = LoadOptions {
        columns: Some(["gx".into(), "gy".into(), "gz".into()]),
        ..Default::default()
    };
    if let (Ok(g), None) = (load(&gyro), &out[0].labels) {
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
    column_sensor(column).unwrap_or(Sensor::Unnamed)
}

/// One sensor's three axes, each with its reading and joint fit.
fn push_axes(
    axes: &mut Vec<NoiseAxis>,
    sensor: Sensor,
    columns: &[String; 3],
    accel_unit: Option<String>,
    curves: [AllanCurve; 3],
) {
    for (column, curve) in columns.iter().zip(curves) {
        // The column's own unit, else (accelerometer) what its magnitude says.
        let unit = unit_of(column)
            .map(String::from)
            .or_else(|| accel_unit.clone());
        axes.push(NoiseAxis {
            column: column.clone(),
            sensor: sensor_name(sensor),
            unit,
            terms: read_terms(&curve),
            joint_fit: fit_terms(&curve),
            curve,
        });
    }
}

/// Each axis's Allan deviation and terms of the sensors as [`open_sensors`] opened them, held
/// or read in passes: one code ([`sensors_noise`]). `default_rate_hz` is used when the
/// recording has no time column or `Fs`.
pub fn noise_of(sensors: &Sensors, default_rate_hz: f64) -> Result<NoiseReport> {
    match sensors {
        Sensors::Held(recs) => sensors_noise(recs, default_rate_hz),
        Sensors::Streamed(srcs) => sensors_noise(srcs, default_rate_hz),
    }
}

/// [`noise_of`] on the sensors `srcs`, held or read in passes ([`crate::noise::pass`]): a
/// large file keeps fewer overlapping clusters at long τ ([`Overlap::Bounded`], which the
/// report's `streamed` says), held samples every one. Refused when a recording is too short
/// for any τ, or is not still, varying and evenly sampled ([`crate::noise::still`]).
pub fn sensors_noise<S: RowSource + SampleSource>(
    srcs: &[S],
    default_rate_hz: f64,
) -> Result<NoiseReport> {
    let rate = srcs
        .first()
        .ok_or(NoiseError::NoSampleRate)?
        .estimated_rate_hz()
        .unwrap_or(default_rate_hz);
    if !(rate.is_finite() && rate > 0.0) {
        return Err(NoiseError::NoSampleRate.into());
    }
    let samples = srcs.first().map_or(0, RowSource::len);
    let needed = 2 * crate::noise::allan::MIN_CLUSTERS;
    if samples < needed {
        return Err(NoiseError::NoiseTooShort { samples, needed }.into());
    }
    let (mut axes, mut polled) = (Vec::new(), Vec::new());
    for src in srcs {
        let columns = src.axis_columns();
        let input = SensorSamples {
            samples: src,
            len: src.len(),
            columns,
            steps: src.time_steps(),
            overlap: match src.held() {
                Some(_) => Overlap::Full,
                None => Overlap::Bounded,
            },
        };
        let sensor = sensor_of(&columns[0]);
        let got = sensor_noise(&input, sensor, rate)?;
        let accel_unit = (sensor == Sensor::Accelerometer || sensor == Sensor::Unnamed)
            .then(|| unit_of_mean(src.integer(), &got.mean))
            .flatten();
        push_axes(&mut axes, sensor, columns, accel_unit, got.curves);
        if let Some(polling) = got.polling {
            polled.push(PolledSensor {
                columns: columns.join(","),
                polling,
            });
        }
    }
    let streamed = srcs.iter().any(|s| s.held().is_none()).then(|| {
        format!(
            "read in passes from the file, never held: the points beyond τ = {FULL_OVERLAP_M} \
             samples use every (m/{FULL_OVERLAP_M})-th of the overlapping clusters (the fully \
             overlapping value differs by a small fraction of adev_rel_err); the others are \
             the held path's"
        )
    });
    Ok(NoiseReport {
        samples,
        sample_rate_hz: rate,
        duration_s: samples as f64 / rate,
        axes,
        streamed,
        polled,
    })
}

/// g or m/s² when the magnitude of the mean acceleration `mean` says so (≈ 1 or ≈ 9.81), from
/// it and whether every value is an integer.
fn unit_of_mean(integer: bool, mean: &[f64; 3]) -> Option<String> {
    let norm = mean.iter().map(|m| m * m).sum::<f64>().sqrt();
    match crate::input::recording::infer_units(integer, norm) {
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

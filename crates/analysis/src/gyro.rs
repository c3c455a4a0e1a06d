//! Gyroscope calibration from a multi-position recording (the engine of `wiical gyrofit`):
//! static windows from the accelerometer, gravity directions from the accelerometer's own
//! multi-position fit, the motions between windows, and the core's gyro fit
//! ([`wiical_core::gyro_fit`], here in `f64`) for each candidate model, the model chosen by its
//! leave-one-motion-out error (method and sources: `docs/gyro.md`).
//!
//! Candidate models, from nothing fitted to everything:
//!
//! | name | fitted | parameters |
//! |---|---|---|
//! | `uncalibrated` | nothing: the nominal scale, bias from the first static window | 0 |
//! | `bias` | bias | 3 |
//! | `scale` | one scale per axis | 3 |
//! | `scale+bias` | | 6 |
//! | `full` | scale and misalignment (3×3) | 9 |
//! | `full+bias` | | 12 |
//!
//! Each fitted model is refitted without each motion in turn and judged on the motion held out;
//! the one with the smallest held-out RMS angle wins. `uncalibrated` is a candidate too (its
//! held-out error is its in-sample error, nothing being fitted), so the chosen calibration never
//! does worse on held-out motions than none. When the motions do not pin down the full model
//! (e.g. small turns about similar axes) its held-out error exceeds the uncalibrated one and the
//! report says so.

use crate::detect::windows::{detect_windows, DetectOptions};
pub use crate::error::gyro::GyroError;
use crate::fit::base::{run_windows, FitOptions};
use crate::input::recording::Recording;
use crate::input::timecheck::TimeSteps;
use serde::Serialize;
use wiical_core::gyro::{GyroCalibration, MotionResidual};
use wiical_core::gyro_fit::{
    self, fit_keeping_from_nominal, leave_one_out, leave_one_out_one_step, motion_angle,
    nominal_pass, GyroFitConfig, GyroModel, Motion, NominalPass,
};
use wiical_core::multipos::MultiPosModel;
use wiical_core::static_detect::StaticInterval;

type Result<T, E = GyroError> = std::result::Result<T, E>;

/// Settings of [`run`].
#[derive(Debug, Clone)]
pub struct GyroOptions {
    /// Static-window detection on the accelerometer.
    pub detect: DetectOptions,
    /// Nominal gyro sensitivity per axis, rad/s per count (signed: an inverted axis is
    /// negative), from the datasheet.
    pub nominal_rad_per_count: [f64; 3],
    /// Accelerometer model for the gravity directions.
    pub accel_model: MultiPosModel,
    /// Levenberg–Marquardt iteration budget per fit.
    pub max_iterations: u32,
    /// Where the nominal came from, for the report (`--scale`, the columns' unit, …).
    pub nominal_source: String,
    /// Estimate the nominal from the motions instead ([`estimate_nominal`]): no datasheet.
    pub estimate_nominal: bool,
    /// Held-out errors by an exact refit per motion instead of one Gauss–Newton step from the
    /// all-motion fit (`leave_one_out_one_step`; within 0.01° of exact on the real logs,
    /// docs/gyro.md, ~40× faster).
    pub exact_held_out: bool,
}

impl GyroOptions {
    /// Defaults with the nominal estimated from the motions ([`estimate_nominal`]).
    pub fn estimated() -> Self {
        Self {
            estimate_nominal: true,
            nominal_source: "estimated from the motions".into(),
            ..Self::new([1.0; 3])
        }
    }

    /// Defaults for a nominal sensitivity.
    pub fn new(nominal_rad_per_count: [f64; 3]) -> Self {
        Self {
            detect: DetectOptions::default(),
            nominal_rad_per_count,
            accel_model: MultiPosModel::Full,
            max_iterations: 100,
            nominal_source: "given".into(),
            estimate_nominal: false,
            exact_held_out: false,
        }
    }
}

/// One candidate model's numbers.
#[derive(Debug, Clone, Serialize)]
pub struct GyroModelRow {
    /// Model name (see the module docs).
    pub name: &'static str,
    /// Fitted parameters.
    pub parameters: usize,
    /// In-sample RMS angle error over the motions, degrees (null if the fit failed).
    pub rms_deg: Option<f64>,
    /// Leave-one-motion-out RMS angle error, degrees (null if a fit failed).
    pub cv_rms_deg: Option<f64>,
    /// Smallest eigenvalue of the unit-diagonal normal matrix (near 0: badly determined).
    pub identifiability: Option<f64>,
    /// Why the fit failed, if it did.
    pub error: Option<String>,
}

/// One motion between two static windows.
#[derive(Debug, Clone, Serialize)]
pub struct MotionRow {
    /// Time of the motion's first sample, s.
    pub t_start: f64,
    /// Time of its last sample, s.
    pub t_end: f64,
    /// Angle between the gravity directions of the two windows, degrees (how much the motion
    /// tilted the sensor).
    pub tilt_deg: f64,
    /// Angle error with the uncalibrated gyro, degrees.
    pub error_before_deg: f64,
    /// With the chosen calibration (fitted with this motion), degrees.
    pub error_after_deg: f64,
    /// With the chosen model fitted without this motion, degrees.
    pub held_out_deg: f64,
}

/// The result (the JSON contract of `wiical gyrofit --json`: `static_windows`, `motions`,
/// `bias`, `matrix`, `rms_deg_before`, `rms_deg_after`, `cv_rms_deg`).
#[derive(Debug, Clone, Serialize)]
pub struct GyroReport {
    /// Static windows found on the accelerometer.
    pub static_windows: usize,
    /// Motions between consecutive windows.
    pub motions: usize,
    /// Gyro bias of the chosen calibration, raw counts.
    pub bias: [f64; 3],
    /// `K` of the chosen calibration, raw → rad/s (`ω = K·(m − b)`), row-major.
    pub matrix: [[f64; 3]; 3],
    /// RMS angle error of the uncalibrated gyro over the motions, degrees.
    pub rms_deg_before: f64,
    /// In-sample RMS angle error of the chosen model, degrees.
    pub rms_deg_after: f64,
    /// Leave-one-motion-out RMS angle error of the chosen model, degrees.
    pub cv_rms_deg: f64,
    /// How the held-out angles were found: `"one-step"` (one Gauss–Newton step from the
    /// all-motion fit, then the held-out motion integrated exactly) or `"exact"` (a refit per
    /// motion, `--exact-held-out`).
    pub held_out_method: &'static str,
    /// The chosen model.
    pub model: &'static str,
    /// Every candidate.
    pub models: Vec<GyroModelRow>,
    /// Per motion, with the chosen model.
    pub motion_table: Vec<MotionRow>,
    /// Sample rate used, Hz.
    pub sample_rate_hz: f64,
    /// Nominal sensitivity, rad/s per count.
    pub nominal_rad_per_count: [f64; 3],
    /// Where the nominal came from: a flag (`--scale`, `--counts-per-dps`) or the gyro
    /// columns' unit (`deg/s` in `gyro_x_dps`: 1 count = 1 °/s).
    pub nominal_source: String,
    /// Bias from the first static window, raw counts.
    pub bias_from_rest: [f64; 3],
    /// Remarks on the choice (e.g. that the full model generalises worse than none).
    pub notes: Vec<String>,
}

const CANDIDATES: [(&str, GyroModel, bool); 6] = [
    ("uncalibrated", GyroModel::BiasOnly, false),
    ("bias", GyroModel::BiasOnly, true),
    ("scale", GyroModel::Scale, false),
    ("scale+bias", GyroModel::Scale, true),
    ("full", GyroModel::Full, false),
    ("full+bias", GyroModel::Full, true),
];

/// Rows of `acc` and `gyro` that belong together: all of them when the lengths agree (`None`),
/// else (a capture whose rows alternate between gyro and other data, so the loader skipped the
/// rows without gyro values) the accelerometer rows at the gyro rows' times, with those times.
type Aligned = (Vec<[f64; 3]>, Option<Vec<f64>>);

fn align(acc: &Recording, gyro: &Recording) -> Result<Aligned> {
    let mismatch = || GyroError::GyroRowsMismatch {
        accel: acc.len(),
        gyro: gyro.len(),
    };
    if acc.len() == gyro.len() {
        // Rows pair by position, but only when both clocks agree on them (a shifted copy of
        // the gyro log must not be paired silently).
        if let (Some(ta), Some(tg)) = (&acc.t, &gyro.t) {
            let worst = ta
                .iter()
                .zip(tg)
                .map(|(a, g)| (a - g).abs())
                .fold(0.0, f64::max);
            let step = TimeSteps::of(ta).map_or(f64::INFINITY, |s| s.median_s);
            if worst > 0.5 * step {
                return Err(GyroError::GyroClocksDiffer { offset_s: worst });
            }
        }
        return Ok((acc.xyz.clone(), None));
    }
    let (Some(ta), Some(tg)) = (&acc.t, &gyro.t) else {
        return Err(mismatch());
    };
    // A subset of the rows (a capture whose rows alternate): it must span the recording, not
    // stop early (a cut-off gyro file would silently drop the rest of the accelerometer).
    let span = |t: &[f64]| t.last().copied().unwrap_or(0.0) - t.first().copied().unwrap_or(0.0);
    if span(tg) < 0.95 * span(ta) {
        return Err(GyroError::GyroSpanShort {
            gyro: (
                tg.first().copied().unwrap_or(0.0),
                tg.last().copied().unwrap_or(0.0),
            ),
            accel: (
                ta.first().copied().unwrap_or(0.0),
                ta.last().copied().unwrap_or(0.0),
            ),
        });
    }
    let mut out = Vec::with_capacity(tg.len());
    let mut i = 0;
    for t in tg {
        while i < ta.len() && ta[i] < *t {
            i += 1;
        }
        if i >= ta.len() || ta[i] != *t {
            return Err(mismatch());
        }
        out.push(acc.xyz[i]);
    }
    Ok((out, Some(tg.clone())))
}

/// The gyro's sensitivity (rad/s per count, signed per axis) without a datasheet: the scale
/// whose integration best turns each static window's gravity direction into the next's (the
/// RMS of the motions' angle errors, the same error the fit minimises). A coarse search over
/// seven decades (10⁻⁷ to 1 rad/s per count, steps of 10^0.05 ≈ 12 %) with one scale for all
/// axes, then the sign of each axis (a flipped axis), then a golden-section refinement of the
/// scale within the best step. The candidate fits then adjust each axis from there.
pub fn estimate_nominal(motions: &[Motion<'_, f64>], bias: [f64; 3], dt: f64) -> Result<[f64; 3]> {
    let cost = |scale: [f64; 3]| -> f64 {
        let cal = GyroCalibration::nominal(bias, scale);
        let sq: f64 = motions
            .iter()
            .map(|m| motion_angle(m, &cal, dt).map_or(f64::INFINITY, |a| a * a))
            .sum();
        sq / motions.len() as f64
    };
    let at = |log_s: f64, sign: [f64; 3]| sign.map(|g| g * 10f64.powf(log_s));
    let grid = (0..=140).map(|i| -7.0 + 0.05 * i as f64);
    let mut signs = [1.0; 3];
    let (mut best_log, _) = grid
        .clone()
        .map(|l| (l, cost(at(l, signs))))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .ok_or(GyroError::GyroFitFailed(wiical_core::Error::NotConverged))?;
    // The sign of each axis, then the scale again with those signs.
    signs = (0..8)
        .map(|k| std::array::from_fn(|a| if k >> a & 1 == 1 { -1.0 } else { 1.0 }))
        .min_by(|a: &[f64; 3], b: &[f64; 3]| {
            cost(at(best_log, *a)).total_cmp(&cost(at(best_log, *b)))
        })
        .unwrap_or([1.0; 3]);
    best_log = grid
        .map(|l| (l, cost(at(l, signs))))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(best_log, |(l, _)| l);
    // Golden-section search on log₁₀(scale) within one grid step either side.
    let (mut lo, mut hi) = (best_log - 0.05, best_log + 0.05);
    let r = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..30 {
        let (a, b) = (hi - r * (hi - lo), lo + r * (hi - lo));
        if cost(at(a, signs)) < cost(at(b, signs)) {
            hi = b;
        } else {
            lo = a;
        }
    }
    let s = at((lo + hi) / 2.0, signs);
    if !cost(s).is_finite() {
        return Err(GyroError::GyroFitFailed(wiical_core::Error::NotConverged));
    }
    Ok(s)
}

/// Refuses a given nominal whose integrated rotation is absurd next to the tilt the
/// accelerometer sees: over the motions that tilt by more than 20°, the median of
/// ∫|ω|dt / tilt must lie in [0.2, 50]. The path turned is at least the net tilt (ratio ≥ 1 for a
/// right nominal; turns about gravity raise it, rarely past 5), so a factor-of-five unit error is
/// still passed to the fit (which corrects it) while 10^±3 (a rad/deg or counts/LSB mix-up, a
/// typo in the exponent) is named here instead of ending in a singular matrix.
fn check_nominal_plausible(
    motions: &[Motion<'_, f64>],
    bias: [f64; 3],
    scale: [f64; 3],
    dt: f64,
    source: &str,
) -> Result<()> {
    let mut ratios: Vec<f64> = motions
        .iter()
        .filter_map(|m| {
            let tilt = m.g_start.angle(&m.g_end);
            (tilt > 20f64.to_radians()).then(|| {
                let path: f64 = m
                    .samples
                    .iter()
                    .map(|s| {
                        (0..3)
                            .map(|a| ((s[a] - bias[a]) * scale[a]).powi(2))
                            .sum::<f64>()
                            .sqrt()
                    })
                    .sum::<f64>()
                    * dt;
                path / tilt
            })
        })
        .collect();
    if ratios.is_empty() {
        return Ok(());
    }
    ratios.sort_by(f64::total_cmp);
    let median = ratios[ratios.len() / 2];
    if (0.2..=50.0).contains(&median) {
        return Ok(());
    }
    Err(GyroError::GyroNominalImplausible {
        source_name: source.chars().take(60).collect(),
        ratio: median,
        motions: ratios.len(),
    })
}

/// A note per axis whose fitted sensitivity has the opposite sign of the nominal: the gyro
/// axis points the other way from the accelerometer's (a flipped axis, as in sunsided's
/// MPU-6050 logs); the fit has absorbed it, and a datasheet nominal would have missed it.
fn flipped_axes(cal: &GyroCalibration<f64>, nominal: &[f64; 3]) -> Vec<String> {
    (0..3)
        .filter(|&a| cal.matrix[(a, a)] * nominal[a] < 0.0)
        .map(|a| {
            format!(
                "the {} gyro axis turns the other way from the accelerometer's (fitted sensitivity {:.4e} rad/s per count against the nominal {:.4e}): its sign is flipped",
                ["x", "y", "z"][a],
                cal.matrix[(a, a)],
                nominal[a]
            )
        })
        .collect()
}

/// Whether a nominal sensitivity a user gave (rad/s per count, per axis) can start the fit:
/// finite and non-zero on every axis (its sign is the axis's direction). The CLI's
/// `--scale` / `--counts-per-dps` and the Python package's `scale` / `counts_per_dps` both
/// refuse what fails it.
pub fn nominal_given_usable(s: &[f64; 3]) -> bool {
    s.iter().all(|x| x.is_finite() && *x != 0.0)
}

/// The gyro's nominal sensitivity from its columns' unit, when the names state one:
/// `deg/s` (`gyro_x_dps`) is 1 count = 1 °/s, `rad/s` 1 count = 1 rad/s. Returns the nominal
/// (rad/s per count) and a sentence saying where it came from.
pub fn nominal_from_columns(gyro: &Recording) -> Option<([f64; 3], String)> {
    let unit = crate::input::columns::triplet_unit(&gyro.axis_columns)?;
    let per_count = match unit {
        "deg/s" => 1f64.to_radians(),
        "rad/s" => 1.0,
        _ => return None,
    };
    Some((
        [per_count; 3],
        format!(
            "the columns' unit ({unit} in {}): 1 count = 1 {unit}",
            gyro.axis_columns.join(", ")
        ),
    ))
}

fn deg(rad: f64) -> f64 {
    rad.to_degrees()
}

/// The accelerometer rows that belong to the gyro's, as a recording with its clock.
fn paired_accelerometer(acc: &Recording, gyro: &Recording) -> Result<Recording> {
    let (acc_xyz, subset_times) = align(acc, gyro)?;
    Ok(match subset_times {
        // A subset of the rows: the rate comes from their times, not from the file's Fs.
        Some(t) => Recording {
            xyz: acc_xyz,
            t: Some(t),
            ..Default::default()
        },
        None => Recording {
            xyz: acc_xyz,
            t: acc.t.clone(),
            sample_rate_hz: acc.sample_rate_hz.or(gyro.sample_rate_hz),
            ..Default::default()
        },
    })
}

/// What the accelerometer says: the windows `wiical fit` finds on the same file and settings
/// (as the core's intervals), their times, and the motions between them with `fit`'s
/// gravity directions.
struct Segmentation {
    intervals: Vec<StaticInterval>,
    times: Vec<f64>,
    spans: Vec<gyro_fit::MotionSpan>,
}

fn segment(acc_rec: &Recording, opts: &GyroOptions) -> Result<Segmentation> {
    let ws = detect_windows(acc_rec, &opts.detect)?;
    let fit_opts = FitOptions {
        detect: opts.detect.clone(),
        model: opts.accel_model,
    };
    let accel = run_windows(&ws, &fit_opts)?.calibration;
    let intervals: Vec<StaticInterval> = ws
        .stats
        .iter()
        .map(|w| StaticInterval {
            start: w.start as u32,
            end: w.end as u32,
            mean: w.mean.map(|x| x as f32),
            variance: w.var.map(|x| x as f32),
        })
        .collect();
    let spans: Vec<gyro_fit::MotionSpan> = gyro_fit::motion_spans(&intervals, &accel)
        .collect::<std::result::Result<_, _>>()
        .map_err(GyroError::GyroFitFailed)?;
    if spans.len() < 2 {
        return Err(GyroError::TooFewMotions {
            found: spans.len(),
            needed: 2,
        });
    }
    Ok(Segmentation {
        intervals,
        times: ws.times,
        spans,
    })
}

/// Refuses a "gyro" that is an accelerometer (the same file twice, or accelerometer columns
/// given as the gyro's): a gyro's mean over the still windows is its bias, the same
/// in every pose, while gravity's points a different way in each. Refused when the spread of
/// the window means is more than half the RMS of the signal during the motions.
fn check_not_gravity(gyro: &Recording, seg: &Segmentation) -> Result<()> {
    let means: Vec<[f64; 3]> = seg
        .intervals
        .iter()
        .map(|iv| bias_at_rest(gyro, iv))
        .collect();
    let n = means.len() as f64;
    let centre: [f64; 3] = std::array::from_fn(|a| means.iter().map(|m| m[a]).sum::<f64>() / n);
    let sq = |v: [f64; 3]| (0..3).map(|a| (v[a] - centre[a]).powi(2)).sum::<f64>();
    let spread = (means.iter().map(|m| sq(*m)).sum::<f64>() / n).sqrt();
    let (mut acc, mut count) = (0.0, 0usize);
    for s in &seg.spans {
        for v in &gyro.xyz[s.start as usize..s.end as usize] {
            acc += sq(*v);
            count += 1;
        }
    }
    let motion_rms = (acc / count.max(1) as f64).sqrt();
    if spread > 0.5 * motion_rms {
        return Err(GyroError::GyroLooksLikeGravity {
            columns: gyro.axis_columns.join(","),
            spread,
            motion_rms,
        });
    }
    Ok(())
}

/// The gyro's mean over the first window (the uncalibrated bias), raw counts.
fn bias_at_rest(gyro: &Recording, rest: &StaticInterval) -> [f64; 3] {
    let rest_samples = &gyro.xyz[rest.start as usize..rest.end as usize];
    let n = rest_samples.len() as f64;
    std::array::from_fn(|a| rest_samples.iter().map(|s| s[a]).sum::<f64>() / n)
}

/// Runs the gyro calibration on an accelerometer recording and the gyro recording of the same
/// samples.
pub fn run(acc: &Recording, gyro: &Recording, opts: &GyroOptions) -> Result<GyroReport> {
    if !opts.estimate_nominal
        && !opts
            .nominal_rad_per_count
            .iter()
            .all(|s| s.is_finite() && *s != 0.0)
    {
        return Err(GyroError::GyroNominalScale);
    }
    let acc_rec = paired_accelerometer(acc, gyro)?;
    let rate = acc_rec
        .estimated_rate_hz()
        .unwrap_or(opts.detect.default_rate_hz);
    let seg = segment(&acc_rec, opts)?;
    check_not_gravity(gyro, &seg)?;
    let bias_from_rest = bias_at_rest(gyro, &seg.intervals[0]);
    let dt = 1.0 / rate;
    let motions: Vec<Motion<'_, f64>> = seg
        .spans
        .iter()
        .map(|s| Motion {
            samples: &gyro.xyz[s.start as usize..s.end as usize],
            g_start: nalgebra::Vector3::from(s.g_start).cast(),
            g_end: nalgebra::Vector3::from(s.g_end).cast(),
        })
        .collect();
    let (nominal_scale, nominal_source) = if opts.estimate_nominal {
        let s = estimate_nominal(&motions, bias_from_rest, dt)?;
        let source = format!(
            "estimated from the motions ({:.4e}, {:.4e}, {:.4e} rad/s per count: the scale that best turns each window's gravity direction into the next's)",
            s[0], s[1], s[2]
        );
        (s, source)
    } else {
        (opts.nominal_rad_per_count, opts.nominal_source.clone())
    };
    if !opts.estimate_nominal {
        check_nominal_plausible(&motions, bias_from_rest, nominal_scale, dt, &nominal_source)?;
    }
    let nominal = GyroCalibration::nominal(bias_from_rest, nominal_scale);
    let (rows, best, before) = evaluate_candidates(&motions, &nominal, dt, opts)?;
    let (name, fit, cv, held, after) = best;
    let cal = fit.calibration;
    let mut notes = choice_notes(&rows, name);
    notes.extend(flipped_axes(&cal, &nominal_scale));
    let motion_table = motion_table(&seg, &motions, &held, (&before, &after));
    let k = cal.matrix;
    Ok(GyroReport {
        static_windows: seg.intervals.len(),
        motions: motions.len(),
        bias: cal.bias.into(),
        matrix: std::array::from_fn(|r| std::array::from_fn(|c| k[(r, c)])),
        rms_deg_before: rows[0].rms_deg.unwrap_or(f64::NAN),
        rms_deg_after: deg(fit.rms_after),
        cv_rms_deg: cv,
        held_out_method: if opts.exact_held_out {
            "exact"
        } else {
            "one-step"
        },
        model: name,
        models: rows,
        motion_table,
        sample_rate_hz: rate,
        nominal_rad_per_count: nominal_scale,
        nominal_source,
        bias_from_rest,
        notes,
    })
}

/// Remarks on the choice: a full model that generalises worse than none, or no fitted model
/// at all.
fn choice_notes(rows: &[GyroModelRow], name: &str) -> Vec<String> {
    let uncal_cv = rows[0].cv_rms_deg.unwrap_or(f64::NAN);
    let mut notes = Vec::new();
    if let Some(c) = rows
        .iter()
        .find(|r| r.name == "full")
        .and_then(|r| r.cv_rms_deg)
    {
        if c > uncal_cv {
            notes.push(format!(
                "the full 9-parameter fit does worse on held-out motions ({c:.3}°) than the uncalibrated gyro ({uncal_cv:.3}°): these motions do not determine it; {name} was chosen instead"
            ));
        }
    }
    if name == "uncalibrated" {
        notes.push("no fitted model beats the nominal scale on held-out motions: the calibration is the nominal one with the bias from rest".into());
    }
    notes
}

/// Per motion: its times, tilt, angle error before (`angles.0`, the nominal) and after
/// (`angles.1`, the chosen calibration), rad, and held out.
fn motion_table(
    seg: &Segmentation,
    motions: &[Motion<'_, f64>],
    held: &[f64],
    angles: (&[f64], &[f64]),
) -> Vec<MotionRow> {
    seg.spans
        .iter()
        .zip(motions)
        .zip(held)
        .zip(angles.0.iter().zip(angles.1))
        .map(|(((s, m), h), (before, after))| {
            let t = |i: u32| seg.times.get(i as usize).copied().unwrap_or(f64::NAN);
            MotionRow {
                t_start: t(s.start),
                t_end: t(s.end.saturating_sub(1)),
                tilt_deg: deg(m.g_start.angle(&m.g_end)),
                error_before_deg: deg(*before),
                error_after_deg: deg(*after),
                held_out_deg: deg(*h),
            }
        })
        .collect()
}

/// The chosen candidate: name, fit, held-out RMS (degrees), held-out angle per motion (rad),
/// in-sample angle per motion (rad).
type Best = (
    &'static str,
    gyro_fit::GyroFit<f64>,
    f64,
    Vec<f64>,
    Vec<f64>,
);

/// One candidate's outcome: its fit on every motion, its held-out RMS (rad), its held-out and
/// in-sample angles per motion (rad).
type Outcome = (gyro_fit::GyroFit<f64>, f64, Vec<f64>, Vec<f64>);

/// One candidate: its fit on every motion (from the shared nominal pass: `pass` and the
/// motions it kept, `shared`) and its held-out angle per motion (one Gauss–Newton step from the
/// fit, or exact refits with [`GyroOptions::exact_held_out`]).
fn evaluate_one(
    motions: &[Motion<'_, f64>],
    nominal: &GyroCalibration<f64>,
    dt: f64,
    (pass, shared): (&NominalPass<f64>, &[MotionResidual<f64>]),
    opts: &GyroOptions,
    (model, fit_bias): (GyroModel, bool),
) -> core::result::Result<Outcome, wiical_core::Error> {
    let cfg = GyroFitConfig {
        model,
        fit_bias,
        dt,
        max_iterations: opts.max_iterations,
    };
    let mut kept = shared.to_vec();
    let f = fit_keeping_from_nominal(motions, &cfg, pass, &mut kept)?;
    let mut held = vec![0.0; motions.len()];
    let record = |i: usize, a: f64| held[i] = a;
    let cv = if opts.exact_held_out {
        leave_one_out(motions, nominal, &f.adjustment, &cfg, record)?
    } else {
        leave_one_out_one_step(motions, nominal, &f, &cfg, &kept, record)?
    };
    Ok((f, cv, held, kept.iter().map(|k| k.angle).collect()))
}

fn evaluate_candidates(
    motions: &[Motion<'_, f64>],
    nominal: &GyroCalibration<f64>,
    dt: f64,
    opts: &GyroOptions,
) -> Result<(Vec<GyroModelRow>, Best, Vec<f64>)> {
    let mut rows = Vec::new();
    let mut best: Option<Best> = None;
    let mut before = Vec::new();
    // Every candidate starts at the nominal: one pass with all sensitivities serves them all.
    let blank = MotionResidual {
        residual: nalgebra::Vector3::zeros(),
        jacobian: nalgebra::SMatrix::zeros(),
        angle: 0.0,
        rotation: nalgebra::Vector4::zeros(),
    };
    let mut shared = vec![blank; motions.len()];
    let pass = nominal_pass(motions, nominal, dt, &mut shared).map_err(GyroError::GyroFitFailed)?;
    let start = (&pass, shared.as_slice());
    // The candidates are independent: one thread each (the machine's cores share them).
    let outcomes: Vec<_> = std::thread::scope(|scope| {
        let handles: Vec<_> = CANDIDATES
            .iter()
            .map(|&(_, model, fit_bias)| {
                scope.spawn(move || {
                    evaluate_one(motions, nominal, dt, start, opts, (model, fit_bias))
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or(Err(wiical_core::Error::NotConverged)))
            .collect()
    });
    for ((name, model, fit_bias), outcome) in CANDIDATES.into_iter().zip(outcomes) {
        let parameters = model.mask(fit_bias).iter().filter(|f| **f).count();
        match outcome {
            Ok((f, cv, held, angles)) => {
                rows.push(GyroModelRow {
                    name,
                    parameters,
                    rms_deg: Some(deg(f.rms_after)),
                    cv_rms_deg: Some(deg(cv)),
                    identifiability: Some(f.identifiability),
                    error: None,
                });
                if parameters == 0 {
                    before.clone_from(&angles);
                }
                if best.as_ref().is_none_or(|b| deg(cv) < b.2) {
                    best = Some((name, f, deg(cv), held, angles));
                }
            }
            // The uncalibrated candidate fits nothing: its failure is a data error.
            Err(e) if parameters == 0 => return Err(GyroError::GyroFitFailed(e)),
            Err(e) => rows.push(GyroModelRow {
                name,
                parameters,
                rms_deg: None,
                cv_rms_deg: None,
                identifiability: None,
                error: Some(e.to_string()),
            }),
        }
    }
    let best = best.ok_or(GyroError::GyroFitFailed(wiical_core::Error::NotConverged))?;
    Ok((rows, best, before))
}

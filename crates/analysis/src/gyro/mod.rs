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

mod align;
pub(crate) mod basis;
pub mod bias_step;
pub(crate) mod design;
pub mod device;
pub mod effects;
pub(crate) mod floor;
mod lag;
pub mod limits;
mod models;
pub mod motion;
pub(crate) mod motion_basis;
pub(crate) mod motion_search;
mod nominal;
mod options;
pub mod report;
pub mod request;
mod samples;
mod segment;
mod verdict;

pub use crate::error::gyro::GyroError;
use crate::error::Error;
use crate::input::recording::Recording;
use crate::input::text_source::TextSource;
use crate::source::RowSource;
use crate::stats as st;
pub use align::{open_text, ImuPair, TextImu};
use samples::{Collected, Imu};
use std::cell::RefCell;
use wiical_core::gyro::GyroCalibration;

pub use models::{GyroModelRow, MotionRow};
pub use nominal::{estimate_nominal, nominal_from_columns, nominal_given_usable};
pub use options::GyroOptions;
use options::{deg, Result};
pub use report::{GyroQuality, GyroReport};

/// A datasheet scale given by the caller must be finite and non-zero on every axis (without
/// one, the nominal scale is estimated from the motions).
fn check_nominal_scale(opts: &GyroOptions) -> Result<()> {
    let usable = opts
        .nominal_rad_per_count
        .iter()
        .all(|s| s.is_finite() && *s != 0.0);
    if opts.estimate_nominal || usable {
        Ok(())
    } else {
        Err(GyroError::GyroNominalScale)
    }
}

/// Runs the gyro calibration on an accelerometer recording and the gyro recording of the same
/// samples.
pub fn run(acc: &Recording, gyro: &Recording, opts: &GyroOptions) -> Result<GyroReport> {
    check_nominal_scale(opts)?;
    let (acc, gyro, by_time) = align::pair(acc, gyro)?;
    let worst_clock_s = if by_time {
        None
    } else {
        Some(samples::clocks(&*acc, &*gyro)?)
    };
    run_on(
        &Imu::new((&*acc, &*gyro), worst_clock_s, &RefCell::default()),
        opts,
    )
}

/// [`run`] on the paired rows `imu`, held or a large file's ([`ImuPair::motions`]; one code:
/// every stage reads the samples through [`Imu`]'s passes, so both give the same report).
fn run_on(imu: &Imu<'_, impl RowSource>, opts: &GyroOptions) -> Result<GyroReport> {
    let default_rate = opts.detect.default_rate_hz;
    segment::check_gyro_reads(imu, default_rate)?;
    let rate = imu.rate_hz().unwrap_or(default_rate);
    // The two clocks first: a gyro seconds late makes every later stage's numbers wrong.
    let clock = lag::estimate(imu, rate, default_rate)?.and_then(|l| l.problem());
    // A static log is recognised only when no segmentation is found: the test reads the raw
    // vector's direction, which a large offset (raw ADC counts) can hold nearly still even
    // while the sensor turns, so it must not override a segmentation that worked.
    let seg = segment::segment(imu, opts).map_err(|e| {
        segment::static_only(imu, rate, default_rate)
            .or_else(|| segment::swapped(imu, opts))
            .unwrap_or(e)
    })?;
    let dt = 1.0 / rate;
    let margin = (MOTION_MARGIN_S / dt).ceil() as usize;
    let col = samples::collect(imu, (&seg.intervals, &seg.spans), margin, default_rate)?;
    segment::check_not_gravity(imu.gyro_columns(), &seg, &col)
        .map_err(|e| segment::swapped(imu, opts).unwrap_or(e))?;
    let bias_from_rest = col.window_mean[0];
    let motions = seg.motions(&col);
    let (nominal_scale, nominal_source) = nominal::choose(&motions, bias_from_rest, dt, opts)?;
    let nominal = GyroCalibration::nominal(bias_from_rest, nominal_scale);
    let (rows, best, before) = models::evaluate_candidates(&motions, &nominal, dt, opts)?;
    let (name, fit, cv, held, after) = best;
    let cal = fit.calibration;
    let mut notes = models::choice_notes(&rows, name);
    notes.extend(nominal::flipped_axes(&cal, &nominal_scale));
    let motion_table = models::motion_table(&seg, &col, &motions, &held, (&before, &after));
    let k = cal.matrix;
    let fitted = Fitted {
        name,
        bias: cal.bias.into(),
        matrix: std::array::from_fn(|r| std::array::from_fn(|c| k[(r, c)])),
        held: &held,
        identifiability: rows
            .iter()
            .find(|r| r.name == name)
            .and_then(|r| r.identifiability),
    };
    let lp = loop_part(imu, &col, &seg, &fitted, (dt, clock))?;
    let correction = device::correction(fitted.bias, fitted.matrix, &lp.search);
    Ok(GyroReport {
        correction,
        static_windows: seg.intervals.len(),
        motions: motions.len(),
        bias: fitted.bias,
        matrix: fitted.matrix,
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
        noise_floor_deg: lp.floor_deg,
        noise_floor_rate_dps: lp.rate_dps,
        noise_floor_window_dps: lp.window_dps,
        base: lp.search.base,
        effects: lp.search.effects,
        final_model: lp.search.final_model,
        steps: lp.search.steps,
        quality: lp.quality,
        reasons: lp.reasons,
        verdict: lp.verdict,
        diagnostics: lp.diagnostics,
        motion_loop: lp.motion_loop,
        open_basis: lp.open_basis,
    })
}

/// One side of an [`ImuPair`]: a held recording or a large file's source.
pub trait ImuSide: RowSource + Sized {
    /// The side's recording (without its samples when read in passes: columns, notes, rate).
    fn recording(&self) -> &Recording;
    /// The motion fit on the pair ([`run`]); a pass's failure is left in `failed`.
    fn motions(
        imu: &ImuPair<Self>,
        opts: &GyroOptions,
        failed: &RefCell<Option<Error>>,
    ) -> Result<GyroReport>;
}

impl ImuSide for Recording {
    fn recording(&self) -> &Recording {
        self
    }

    /// Paired by position or by time (`align::pair`): held rows may be a subset of the
    /// other's.
    fn motions(
        imu: &ImuPair<Self>,
        opts: &GyroOptions,
        _: &RefCell<Option<Error>>,
    ) -> Result<GyroReport> {
        run(&imu.acc, &imu.gyro, opts)
    }
}

impl ImuSide for TextSource {
    fn recording(&self) -> &Recording {
        &self.meta
    }

    /// By position ([`open_text`] opens only files whose rows pair so); the two clocks'
    /// largest difference on one row (`samples::clocks`) without a pass when the
    /// rows are the same (one file's, none skipped in either triplet).
    fn motions(
        imu: &ImuPair<Self>,
        opts: &GyroOptions,
        failed: &RefCell<Option<Error>>,
    ) -> Result<GyroReport> {
        check_nominal_scale(opts)?;
        let same_rows = imu.acc_path == imu.gyro_path
            && imu.acc.meta.skipped_empty_rows == 0
            && imu.gyro.meta.skipped_empty_rows == 0;
        let worst = if same_rows {
            0.0
        } else {
            samples::clocks(&imu.acc, &imu.gyro)?
        };
        run_on(&Imu::new((&imu.acc, &imu.gyro), Some(worst), failed), opts)
    }
}

impl<S: ImuSide> ImuPair<S> {
    /// The accelerometer's recording (without its samples when read in passes).
    pub fn accelerometer(&self) -> &Recording {
        self.acc.recording()
    }

    /// The gyro's recording (without its samples when read in passes).
    pub fn gyroscope(&self) -> &Recording {
        self.gyro.recording()
    }

    /// The motion fit ([`run`]): the same report held or read in passes; a file's
    /// failure outside, the fit's own error inside (what the fallback to the protocol's
    /// methods reads, [`GyroError::says_another_protocol`]).
    pub fn motions(&self, opts: &GyroOptions) -> crate::Result<Result<GyroReport>> {
        let failed = RefCell::new(None);
        let out = S::motions(self, opts, &failed);
        if let Some(e) = failed.take() {
            return Err(e.in_file(&self.acc_path));
        }
        self.check()?;
        Ok(out)
    }
}

/// The chosen calibration, as the loop needs it.
struct Fitted<'a> {
    name: &'static str,
    bias: [f64; 3],
    matrix: [[f64; 3]; 3],
    /// Held-out angle per motion, rad.
    held: &'a [f64],
    identifiability: Option<f64>,
}

/// What the loop adds to the fit: floors, the window search, the verdict.
struct LoopPart {
    floor_deg: f64,
    rate_dps: f64,
    window_dps: f64,
    search: effects::Search,
    quality: GyroQuality,
    reasons: Vec<String>,
    verdict: String,
    diagnostics: Vec<String>,
    motion_loop: Option<report::MotionLoop>,
    open_basis: Option<report::OpenBasis>,
}

/// The window basis after the named window effects ([`basis`]), with the bias step's column
/// first when one was found.
fn window_basis(
    search: &effects::Search,
    cands: &[effects::Candidate],
    data: &effects::WindowData,
    step: Option<&bias_step::Found>,
) -> Option<report::OpenBasis> {
    let mut chosen: Vec<&effects::Candidate> = step.map(|s| &s.candidate).into_iter().collect();
    chosen.extend(
        search
            .effects
            .iter()
            .filter_map(|e| cands.iter().find(|c| c.name == e.name)),
    );
    basis::search(data, &chosen, &basis::window_terms(cands))
}

/// The window search: a bias step first ([`bias_step`]), then the named candidates
/// ([`effects`]) and the window basis ([`basis`]) on the kept windows.
fn window_search(
    seg: &segment::Segmentation,
    data: &effects::WindowData,
    cands: &[effects::Candidate],
    kept: &[bool],
) -> Result<(
    effects::Search,
    Option<report::OpenBasis>,
    Option<bias_step::Found>,
)> {
    let times = pick(
        seg.windows.iter().map(|w| (w.t_first, w.t_last)).collect(),
        kept,
    );
    let step = bias_step::find(data, cands, &times);
    let mut search = effects::search_from(data, cands, step.as_ref().map(|s| &s.candidate))
        .ok_or(GyroError::GyroFitFailed(wiical_core::Error::NotConverged))?;
    if let Some(s) = &step {
        let chosen: Vec<&effects::Candidate> = search.effects[1..]
            .iter()
            .filter_map(|e| cands.iter().find(|c| c.name == e.name))
            .collect();
        bias_step::finish(&mut search.effects[0], s, data, &chosen);
    }
    let open_basis = window_basis(&search, cands, data, step.as_ref());
    Ok((search, open_basis, step))
}

/// Noise floor, static-window candidates and verdict for the chosen calibration.
fn loop_part(
    imu: &Imu<'_, impl RowSource>,
    col: &Collected,
    seg: &segment::Segmentation,
    fit: &Fitted<'_>,
    (dt, clock): (f64, Option<String>),
) -> Result<LoopPart> {
    let var = samples::window_variances(imu, &seg.intervals, &col.window_mean)?;
    let fl = floor::floors(&var, imu.gyro_is_integer(), seg, &fit.matrix, dt);
    let kept = still_windows(seg, &fl);
    let (data, cands) = keep_windows(window_data(col, fit, &fl), candidates(seg), &kept);
    let (search, open_basis, step) = window_search(seg, &data, &cands, &kept)?;
    let fits_bias = matches!(fit.name, "bias" | "scale+bias" | "full+bias");
    let fits_scale = fit.name.starts_with("scale") || fit.name.starts_with("full");
    let ev = verdict::Evidence {
        held_out: fit.held,
        floor: &fl.motion_rad,
        bias_offset: fits_bias.then(|| segment::bias_against_rest(&col.window_mean, fit.bias)),
        scale_and_bias: (fits_bias && fits_scale)
            .then_some(fit.identifiability)
            .flatten(),
        timestamps: segment::timestamp_problem(imu.time_steps()),
        clock,
        dps_per_count: std::array::from_fn(|a| {
            (0..3)
                .map(|c| fit.matrix[a][c].powi(2))
                .sum::<f64>()
                .sqrt()
                .to_degrees()
        }),
    };
    let (quality, reasons, text) = verdict::judge(&ev);
    let mut diagnostics = limit_sentences(&search);
    let dropped = kept.iter().filter(|k| !**k).count();
    if dropped > 0 {
        diagnostics.push(format!(
            "{dropped} of {} static windows left out of the window candidates: the gyro's noise in them is more than {TURNING_VARIANCE_FACTOR}× the median window's, so it turns while the accelerometer rests (a turn about gravity, which the accelerometer cannot see)",
            kept.len()
        ));
    }
    diagnostics.extend(window_scatter(&search, &data));
    // The motion candidates' fit is linearised about the chosen calibration: it assumes angle
    // errors within the not-usable factor of the floor and samples at one rate.
    let far = st::rms(fit.held) > verdict::NOT_USABLE_FLOOR_FACTOR * st::rms(&fl.motion_rad);
    let motion_loop = if far || ev.timestamps.is_some() {
        diagnostics.push(format!("the motion candidates (scale asymmetry, nonlinearity, time offset) were not tried: their fit is linearised about the chosen calibration and needs {}", if far { "held-out angle errors within 30× the floor" } else { "samples at one rate" }));
        None
    } else {
        let motions = motion_set(
            col,
            seg,
            fit,
            &fl,
            dt,
            (&search, &cands, &data, step.as_ref()),
        );
        motion_search::search(&motions.0, motions.1)
    };
    let mut text = text;
    if let Some(ml) = &motion_loop {
        diagnostics.extend(motion_limit_sentences(ml));
        text.push_str(&with_effects(
            ml,
            st::rms(fit.held),
            st::rms(&fl.motion_rad),
        ));
    }
    let window_dps = (data.mean_var.iter().flatten().sum::<f64>()
        / (3 * data.mean_var.len()).max(1) as f64)
        .sqrt();
    Ok(LoopPart {
        floor_deg: st::rms(&fl.motion_rad).to_degrees(),
        rate_dps: fl.rate_noise.to_degrees(),
        window_dps,
        search,
        quality,
        reasons,
        verdict: text,
        diagnostics,
        motion_loop,
        open_basis,
    })
}

/// The gyro's window means through the chosen calibration and their noise, °/s.
fn window_data(col: &Collected, fit: &Fitted<'_>, fl: &floor::Floors) -> effects::WindowData {
    let rate_dps = col
        .window_mean
        .iter()
        .map(|m| {
            std::array::from_fn(|r| {
                (0..3)
                    .map(|c| fit.matrix[r][c] * (m[c] - fit.bias[c]))
                    .sum::<f64>()
                    .to_degrees()
            })
        })
        .collect();
    let d2 = 1f64.to_degrees().powi(2);
    let mean_var = fl
        .window_mean_var
        .iter()
        .map(|v| v.map(|x| x * d2))
        .collect();
    effects::WindowData { rate_dps, mean_var }
}

/// The static-window candidates this recording can test: g-sensitivity and drift always,
/// temperature when the recording has a temperature that changes.
fn candidates(seg: &segment::Segmentation) -> Vec<effects::Candidate> {
    let gravity = seg.gravity();
    let t0 = seg.windows.iter().map(|w| w.t_centre).sum::<f64>() / seg.windows.len() as f64;
    let mut out = vec![
        effects::Candidate {
            name: "g-sensitivity",
            unit: "°/s/g",
            columns: gravity.iter().map(|g| g.to_vec()).collect(),
            pattern: "the windows' gyro means follow the gravity direction",
        },
        effects::Candidate {
            name: "bias-drift",
            unit: "°/s/h",
            columns: seg
                .windows
                .iter()
                .map(|w| vec![(w.t_centre - t0) / 3600.0])
                .collect(),
            pattern: "the windows' gyro means move with time",
        },
    ];
    let temps: Option<Vec<f64>> = seg.windows.iter().map(|w| w.temp).collect();
    let spread = |t: &Vec<f64>| {
        let lo = t.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = t.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        hi - lo
    };
    if let Some(t) = temps.filter(|t| spread(t) > 0.0 && spread(t).is_finite()) {
        let m = t.iter().sum::<f64>() / t.len() as f64;
        out.push(effects::Candidate {
            name: "temperature",
            unit: "°/s/°C",
            columns: t.iter().map(|x| vec![x - m]).collect(),
            pattern: "the windows' gyro means follow the temperature",
        });
    }
    out
}

/// "no g-sensitivity above 0.02 °/s/g" for every candidate of the last step not accepted.
fn limit_sentences(search: &effects::Search) -> Vec<String> {
    let last = search.steps.last().map_or(&[][..], |s| &s.candidates[..]);
    let rejected = last.iter().filter(|c| !c.passed);
    let said = rejected.map(|c| (&*c.name, &*c.unit, c.detection_limit, &*c.note));
    rejected_sentences(said, "this recording")
}

/// Each candidate not accepted — `(name, unit, detection limit, note)` — in words
/// ([`limit_sentence`]), `source` being what would have shown it.
fn rejected_sentences<'a>(
    rejected: impl Iterator<Item = (&'a str, &'a str, Option<f64>, &'a str)>,
    source: &str,
) -> Vec<String> {
    rejected
        .map(|(name, unit, limit, note)| limit_sentence(name, unit, limit, note, source))
        .collect()
}

/// One candidate not accepted, in words: the smallest value `source` would have shown, or
/// why it was not tested.
fn limit_sentence(name: &str, unit: &str, limit: Option<f64>, note: &str, source: &str) -> String {
    match limit {
        Some(l) => format!(
            "no {name} above {} {unit} (the smallest {source} would show in 80 % of cases)",
            st::sig3(l)
        ),
        None => format!("{name}: not tested ({note})"),
    }
}

/// A sentence when the window means scatter about the final window model more than their noise
/// allows (χ² p below the residual test's level): the bias at rest moves by something no
/// candidate names (hand tremor in windows that are not truly still, a bias that jumps).
fn window_scatter(search: &effects::Search, data: &effects::WindowData) -> Option<String> {
    let f = &search.final_model;
    let p = f.chi2_p?;
    if p >= crate::report::verdict::UNEXPLAINED_P {
        return None;
    }
    let n = data.mean_var.len().max(1) as f64;
    let noise = (data.mean_var.iter().flatten().sum::<f64>() / (3.0 * n)).sqrt();
    Some(format!(
        "the gyro's window means scatter {:.4} °/s RMS about the {} model, {:.1}× their own noise {noise:.4} °/s (χ² p {}): the bias at rest moves by something no candidate names (windows not truly still, a bias that jumps)",
        f.rms_dps,
        if search.effects.is_empty() { "bias-only" } else { "final" },
        f.rms_dps / noise.max(1e-300),
        st::fmt_p(p)
    ))
}

/// Seconds of rate kept either side of a motion: room for the time-offset candidate to shift
/// the gyro's samples against the accelerometer's windows.
const MOTION_MARGIN_S: f64 = 1.0;

/// The motions with the chosen calibration and the accepted window effects applied to every
/// sample (their deviation from their mean over the windows, °/s → rad/s), the chosen
/// model's free parameters and each motion's floor; and the names of the effects applied.
fn motion_set(
    col: &Collected,
    seg: &segment::Segmentation,
    fit: &Fitted<'_>,
    fl: &floor::Floors,
    dt: f64,
    (search, cands, data, step): (
        &effects::Search,
        &[effects::Candidate],
        &effects::WindowData,
        Option<&bias_step::Found>,
    ),
) -> (motion::MotionSet, Vec<String>) {
    let corr = window_correction(col, seg, (search, cands, step), data.rate_dps.len());
    let k = nalgebra::Matrix3::from_fn(|r, c| fit.matrix[r][c]);
    let b = nalgebra::Vector3::from(fit.bias);
    let (mut rates, mut span, mut gravity) = (Vec::new(), Vec::new(), Vec::new());
    for (s, kept) in seg.spans.iter().zip(&col.kept) {
        let (start, end) = (s.start as usize, s.end as usize);
        let lo = kept.lo;
        rates.push(
            kept.gyro
                .iter()
                .enumerate()
                .map(|(i, g)| {
                    let w = k * (nalgebra::Vector3::from(*g) - b);
                    w - nalgebra::Vector3::from(corr(kept, i)).map(f64::to_radians)
                })
                .collect(),
        );
        span.push((start - lo, end - start));
        gravity.push((
            nalgebra::Vector3::from(s.g_start).cast(),
            nalgebra::Vector3::from(s.g_end).cast(),
        ));
    }
    let set = motion::MotionSet {
        rates,
        span,
        gravity,
        // One floor for every motion (their RMS): the fit then minimises what the model choice
        // minimised, so the base is the chosen calibration itself.
        sigma: vec![st::rms(&fl.motion_rad) / 2f64.sqrt(); seg.spans.len()],
        dt,
        mask: models::mask_of(fit.name),
    };
    let applied = search.effects.iter().map(|e| e.name.clone()).collect();
    (set, applied)
}

/// The window search's outcome the motions read: the search, its candidates, and the bias
/// step when one was found.
type WindowEffects<'a> = (
    &'a effects::Search,
    &'a [effects::Candidate],
    Option<&'a bias_step::Found>,
);

/// The accepted window effects at sample `i` of a motion's kept samples, °/s: each
/// regressor's deviation from its mean over the windows times the fitted coefficients (so the
/// constant stays the calibration's bias). The regressors per sample are the windows': the
/// calibrated specific force (g), the time from the windows' mean centre (h), the temperature
/// from the windows' mean (°C), the bias step's `H − 1` split at the middle of its gap
/// ([`bias_step::Found::regressor`]).
fn window_correction<'a>(
    col: &'a Collected,
    seg: &'a segment::Segmentation,
    (search, cands, step): WindowEffects<'a>,
    windows: usize,
) -> impl Fn(&samples::Kept, usize) -> [f64; 3] + 'a {
    let t0 = seg.windows.iter().map(|w| w.t_centre).sum::<f64>() / seg.windows.len() as f64;
    let terms: Vec<(&'a str, Vec<f64>, Vec<f64>)> = search
        .effects
        .iter()
        .filter_map(|e| {
            let step_c = step.filter(|_| e.name.starts_with(bias_step::NAME));
            let c = step_c
                .map(|s| &s.candidate)
                .or_else(|| cands.iter().find(|c| c.name == e.name))?;
            let k = design::width(c);
            let mean = (0..k)
                .map(|j| c.columns.iter().map(|r| r[j]).sum::<f64>() / windows.max(1) as f64)
                .collect();
            Some((c.name, mean, e.values.clone()))
        })
        .collect();
    let temp_mean =
        seg.windows.iter().filter_map(|w| w.temp).sum::<f64>() / seg.windows.len().max(1) as f64;
    move |kept: &samples::Kept, i: usize| {
        let mut out = [0.0; 3];
        for (name, mean, values) in &terms {
            let x: Vec<f64> = match *name {
                "g-sensitivity" => seg
                    .accel
                    .correct_linear(kept.acc[i].map(|x| x as f32))
                    .map(f64::from)
                    .to_vec(),
                "bias-drift" => vec![(kept.t[i] - t0) / 3600.0],
                bias_step::NAME => vec![step.map_or(0.0, |s| s.regressor(kept.t[i]))],
                _ => vec![if col.has_temp {
                    kept.temp[i] - temp_mean
                } else {
                    0.0
                }],
            };
            let k = mean.len();
            for (a, o) in out.iter_mut().enumerate() {
                *o += (0..k)
                    .map(|i| values[a * k + i] * (x[i] - mean[i]))
                    .sum::<f64>();
            }
        }
        out
    }
}

/// "no scale-asymmetry above 0.5 %" for every motion candidate of the last step not accepted.
fn motion_limit_sentences(ml: &report::MotionLoop) -> Vec<String> {
    let last = ml.steps.last().map_or(&[][..], |s| &s.candidates[..]);
    let rejected = last.iter().filter(|c| !c.passed);
    let said = rejected.map(|c| (&*c.name, &*c.unit, c.detection_limit, &*c.note));
    rejected_sentences(said, "these motions")
}

/// A window whose gyro per-sample variance is this many times the median window's is not
/// still for the gyro (the variance of 50 or more samples of noise is within ±40 % of its
/// expectation at 3 standard deviations, so 4× is no noise).
const TURNING_VARIANCE_FACTOR: f64 = 4.0;

/// Which static windows the gyro agrees are still: per-sample variance (the window mean's
/// variance × its samples, mean over the axes) at most [`TURNING_VARIANCE_FACTOR`] × the
/// median window's.
fn still_windows(seg: &segment::Segmentation, fl: &floor::Floors) -> Vec<bool> {
    let var: Vec<f64> = seg
        .windows
        .iter()
        .zip(&fl.window_mean_var)
        .map(|(w, v)| v.iter().sum::<f64>() / 3.0 * (w.end - w.start).max(1) as f64)
        .collect();
    let mut sorted = var.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    var.iter()
        .map(|v| *v <= TURNING_VARIANCE_FACTOR * median)
        .collect()
}

/// The window data and the candidates' regressors on the windows `kept` only.
fn keep_windows(
    data: effects::WindowData,
    cands: Vec<effects::Candidate>,
    kept: &[bool],
) -> (effects::WindowData, Vec<effects::Candidate>) {
    let data = effects::WindowData {
        rate_dps: pick(data.rate_dps, kept),
        mean_var: pick(data.mean_var, kept),
    };
    let cands = cands
        .into_iter()
        .map(|c| effects::Candidate {
            columns: pick(c.columns, kept),
            ..c
        })
        .collect();
    (data, cands)
}

/// The rows of `v` where `kept` is true.
fn pick<T>(v: Vec<T>, kept: &[bool]) -> Vec<T> {
    v.into_iter()
        .zip(kept)
        .filter(|(_, k)| **k)
        .map(|(x, _)| x)
        .collect()
}

/// The verdict's last sentence when the named effects bring the motions' held-out error down
/// by the CV factor: how far, against the floor (`held`, `floor` in rad).
fn with_effects(ml: &report::MotionLoop, held: f64, floor: f64) -> String {
    let names: Vec<&str> = ml
        .window_effects_applied
        .iter()
        .map(String::as_str)
        .chain(ml.effects.iter().map(|e| e.name.as_str()))
        .collect();
    let after = ml.final_model.cv_rms_deg;
    if names.is_empty() || after * crate::search::select::CV_FACTOR > held.to_degrees() {
        return String::new();
    }
    let ratio = after / floor.to_degrees().max(1e-300);
    format!(
        ". With {} applied to the motions the held-out angle error is {after:.3}° ({ratio:.1}× the floor): {}; {}",
        names.join(" and "),
        if ratio <= crate::report::verdict::UNEXPLAINED_CV_FACTOR {
            "they account for the residual"
        } else {
            "they explain part of it"
        },
        written(&names)
    )
}

/// What the calibration `--out` writes carries of the effects `names`: the g-sensitivity
/// (the core's gyro term, [`device::correction`]), none of the others (bias drift,
/// temperature and the motion effects have no term in the gyro calibration file).
fn written(names: &[&str]) -> String {
    const CARRIED: &str = "g-sensitivity";
    let rest: Vec<&str> = names.iter().copied().filter(|n| *n != CARRIED).collect();
    match (names.contains(&CARRIED), rest.is_empty()) {
        (true, true) => "the calibration `--out` writes carries it (its g-sensitivity term, applied with the accelerometer beside the gyro), the verdict judges the calibration without it".into(),
        (true, false) => format!(
            "the calibration `--out` writes carries the g-sensitivity, not {}",
            rest.join(" or ")
        ),
        _ => "the calibration written carries no such terms".into(),
    }
}

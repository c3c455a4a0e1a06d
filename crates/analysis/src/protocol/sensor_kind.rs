//! Which sensor a recording's samples look like, when the file does not say (no header, or
//! `x,y,z`) and its columns were taken for an accelerometer's: said only when the
//! accelerometer's fit has already refused the file, so that its refusal names the likely
//! cause (another sensor) and the command that calibrates it, instead of a pose advice that
//! cannot help (a gyroscope "runs off to an ever larger sphere"; a magnetometer "found 1
//! static windows").
//!
//! Two signatures, each measured, each stated as evidence with its condition ("if this is a
//! gyroscope …"), because an accelerometer can, rarely, show either:
//! - **A gyroscope**: every still window reads the same vector (its zero rate) while the
//!   signal between them moves far from it. An accelerometer turned between rests reads
//!   gravity in a new direction at each: its rests differ by up to 2 g, as far as it moves.
//!   Rule: at least [`MIN_RESTS`] windows, and at least [`MIN_FAR_FRACTION`] of the samples
//!   farther from the rests' median than [`GYRO_REACH_RATIO`] times the farthest rest;
//!   and the rests do not read 1 g (units judged `g` or `m/s^2` mean that they do: an
//!   accelerometer shaken between rests in one pose, as the GRT's Wii Remote shake log).
//! - **A magnetometer**: the samples lie on one ellipsoid, and it rests in fewer than
//!   [`MIN_RESTS`] orientations on it (turned about all the time). An accelerometer recorded
//!   for calibration rests in many; one in motion reads its own acceleration as well, off the
//!   ellipsoid. Rule: at least [`MIN_SAMPLES`] samples, the rotated ellipsoid's fit error
//!   (MATLAB `magcal`'s, as `magfit` prints it) under [`MAX_ELLIPSOID_ERROR_PCT`] % of its
//!   radius, the samples around it in every direction (each axis of `n̂` beyond ±0.5: a blob
//!   in one pose fits an ellipsoid of its noise, not of a field), and fewer than
//!   [`MIN_RESTS`] still windows whose mean lies on it (within that share of the radius; the
//!   detector may call a stretch of sparse points "still", whose mean then lies inside the
//!   ellipsoid, not on it).
//!
//! Both read the samples in passes ([`SampleSource`]: a held recording's slice or a large
//! file's rows), so that a file read in passes is refused with the held path's words.

use crate::detect::windows::Windows;
use crate::error::fit::FitError;
use crate::input::columns::{all_named, Sensor};
use crate::magnetometer::fit::{FitFold, QualityFold};
use crate::magnetometer::model::MagModel;
use crate::protocol::vec3::{mat_vec, norm, sub};
use crate::source::SampleSource;
use wiical_core::magfit::MagFit;

/// Still windows needed to say that the rests read alike.
pub const MIN_RESTS: usize = 3;
/// How much farther than the farthest rest the far samples lie (a factor).
pub const GYRO_REACH_RATIO: f64 = 20.0;
/// Share of the samples that must lie that far.
pub const MIN_FAR_FRACTION: f64 = 0.01;
/// Fewest samples for the magnetometer's signature (an ellipsoid has 9 parameters).
pub const MIN_SAMPLES: usize = 50;
/// Largest ellipsoid fit error (percent of the radius) for the magnetometer's signature.
pub const MAX_ELLIPSOID_ERROR_PCT: f64 = 5.0;

/// The sensor the samples look like, with the measured evidence.
#[derive(Debug, Clone, PartialEq)]
pub enum OtherSensor {
    /// All rests alike, the motion far from them.
    Gyroscope {
        /// The file's units (`counts`, `g`, …) as the detector judged them.
        units: &'static str,
        /// Still windows.
        rests: usize,
        /// Largest distance of a rest from the rests' median, in the file's units.
        rest_spread: f64,
        /// Share of the samples farther than [`GYRO_REACH_RATIO`] × `rest_spread` from it.
        far_fraction: f64,
    },
    /// On one ellipsoid, resting on it in fewer than [`MIN_RESTS`] orientations.
    Magnetometer {
        /// Samples.
        samples: usize,
        /// Still windows whose mean lies on the ellipsoid.
        rests_on: usize,
        /// The rotated ellipsoid's fit error, percent of its radius.
        fit_error_pct: f64,
    },
}

impl OtherSensor {
    /// The evidence and what to do, in one sentence; `columns`: the axis columns taken.
    pub fn sentence(&self, columns: &[String; 3]) -> String {
        let taken = taken(columns);
        match self {
            OtherSensor::Gyroscope {
                units,
                rests,
                rest_spread,
                far_fraction,
            } => format!(
                "{taken}; all {rests} still windows read the same (within {} {units}) while {:.0} % of the samples lie more than {} {units} ({GYRO_REACH_RATIO}×) away: a gyroscope reads its zero rate at every rest, an accelerometer turned between rests reads gravity in a new direction at each; if this is a gyroscope, calibrate it with `wiical gyrofit` (one file with accelerometer and gyroscope columns, or the accelerometer's file and this one)",
                sig3(*rest_spread),
                100.0 * far_fraction,
                sig3(GYRO_REACH_RATIO * rest_spread)
            ),
            OtherSensor::Magnetometer {
                samples,
                rests_on,
                fit_error_pct,
            } => format!(
                "{taken}; its {samples} samples lie on one ellipsoid (fit error {fit_error_pct:.2} % of its radius) and it rests in {rests_on} orientations on it: a magnetometer turned about reads so, an accelerometer in motion reads its own acceleration too; if this is a magnetometer, run `wiical magfit` on it; if it is an accelerometer turned slowly without stopping, hold it still for about a second in at least 9 orientations"
            ),
        }
    }
}

/// The sensor the samples `src` (columns `columns`, still windows `ws`) look like when the
/// columns do not name the accelerometer (`None` when they do, or when neither signature
/// holds, or when the file cannot be read again).
pub fn other_sensor(
    columns: &[String; 3],
    src: &(impl SampleSource + ?Sized),
    ws: &Windows,
) -> Option<OtherSensor> {
    if all_named(columns, Sensor::Accelerometer) {
        return None;
    }
    gyroscope(src, ws).or_else(|| magnetometer(src, ws))
}

/// `err` (the accelerometer's fit refusing the samples `src`) with the other sensor's
/// evidence in front, when there is some ([`other_sensor`]); otherwise `err` unchanged.
pub fn explain(
    err: crate::Error,
    columns: &[String; 3],
    src: &(impl SampleSource + ?Sized),
    ws: &Windows,
) -> crate::Error {
    let crate::Error::Fit(fit) = err else {
        return err;
    };
    match other_sensor(columns, src, ws) {
        Some(other) => FitError::AnotherSensor {
            evidence: other.sentence(columns),
            fit: Box::new(fit),
        }
        .into(),
        None => crate::Error::Fit(fit),
    }
}

/// What the columns taken for an accelerometer's are named: another sensor's (the loader's
/// fallback when no accelerometer is named, or `--columns`), or none.
fn taken(columns: &[String; 3]) -> String {
    let names = columns.join(",");
    let named = [Sensor::Gyroscope, Sensor::Magnetometer]
        .into_iter()
        .find(|s| all_named(columns, *s));
    match named {
        Some(s) => format!("the columns {names} name a {}, not an accelerometer", s.name()),
        None => format!(
            "the file does not name its sensor, so its columns ({names}) were taken for an accelerometer's"
        ),
    }
}

fn gyroscope(src: &(impl SampleSource + ?Sized), ws: &Windows) -> Option<OtherSensor> {
    if ws.stats.len() < MIN_RESTS || crate::protocol::offsets::one_g(ws.units).is_some() {
        return None;
    }
    let centre: [f64; 3] = std::array::from_fn(|k| {
        let v: Vec<f64> = ws.stats.iter().map(|w| w.mean[k]).collect();
        crate::stats::median(&v)
    });
    let rest_spread = ws
        .stats
        .iter()
        .map(|w| norm(sub(w.mean, centre)))
        .fold(0.0, f64::max);
    let far = GYRO_REACH_RATIO * rest_spread;
    let (mut n, mut beyond) = (0usize, 0usize);
    src.each(&mut |m| {
        n += 1;
        beyond += usize::from(norm(sub(*m, centre)) > far);
    })
    .ok()?;
    let far_fraction = beyond as f64 / n.max(1) as f64;
    (rest_spread.is_finite() && n > 0 && far_fraction >= MIN_FAR_FRACTION).then_some(
        OtherSensor::Gyroscope {
            units: ws.units,
            rests: ws.stats.len(),
            rest_spread,
            far_fraction,
        },
    )
}

/// Which directions of `n̂ = W(m − c)/‖W(m − c)‖` the samples reach: per axis, beyond +0.5
/// and beyond −0.5.
#[derive(Default)]
struct Directions([[bool; 2]; 3]);

impl Directions {
    fn push(&mut self, fit: &MagFit, m: &[f64; 3]) {
        let v = fit.apply(m.map(|x| x as f32)).map(f64::from);
        let len = norm(v);
        if len > 0.0 && len.is_finite() {
            for (seen, x) in self.0.iter_mut().zip(v) {
                seen[0] |= x / len > 0.5;
                seen[1] |= x / len < -0.5;
            }
        }
    }

    fn all(&self) -> bool {
        self.0.iter().flatten().all(|x| *x)
    }
}

fn magnetometer(src: &(impl SampleSource + ?Sized), ws: &Windows) -> Option<OtherSensor> {
    let mut fold = FitFold::new(MagModel::Ellipsoid);
    let mut samples = 0usize;
    src.each(&mut |m| {
        samples += 1;
        fold.push(m);
    })
    .ok()?;
    if samples < MIN_SAMPLES {
        return None;
    }
    let solved = fold.solve().ok()?;
    let mut quality = QualityFold::new(solved);
    let mut directions = Directions::default();
    src.each(&mut |m| {
        quality.push(m);
        directions.push(&solved, m);
    })
    .ok()?;
    let fit = quality.report(MagModel::Ellipsoid, samples).ok()?;
    if !(fit.fit_error_pct < MAX_ELLIPSOID_ERROR_PCT && fit.radius > 0.0 && directions.all()) {
        return None;
    }
    let on_surface = |m: &[f64; 3]| {
        let radius = norm(mat_vec(&fit.matrix, sub(*m, fit.center)));
        (radius - fit.radius).abs() <= MAX_ELLIPSOID_ERROR_PCT / 100.0 * fit.radius
    };
    let rests_on = ws.stats.iter().filter(|w| on_surface(&w.mean)).count();
    (rests_on < MIN_RESTS).then_some(OtherSensor::Magnetometer {
        samples,
        rests_on,
        fit_error_pct: fit.fit_error_pct,
    })
}

/// `x` with three significant digits, without an exponent for everyday magnitudes.
fn sig3(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let decimals = (2 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
    format!("{x:.decimals$}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::windows::detect_windows;
    use crate::input::recording::Recording;
    use rand::{Rng, SeedableRng};
    use rand_distr::{Distribution, Normal};

    fn recording(xyz: Vec<[f64; 3]>) -> Recording {
        Recording {
            xyz,
            sample_rate_hz: Some(100.0),
            axis_columns: ["x".into(), "y".into(), "z".into()],
            ..Default::default()
        }
    }

    fn judged(xyz: Vec<[f64; 3]>) -> Option<OtherSensor> {
        let rec = recording(xyz);
        let ws = detect_windows(&rec, &Default::default()).expect("windows");
        other_sensor(&rec.axis_columns, rec.xyz.as_slice(), &ws)
    }

    /// `n` samples of `f(i)` plus white noise of `sd`.
    fn noisy(n: usize, sd: f64, seed: u64, f: impl Fn(usize) -> [f64; 3]) -> Vec<[f64; 3]> {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let noise = Normal::new(0.0, sd).unwrap();
        (0..n)
            .map(|i| f(i).map(|v| v + noise.sample(&mut rng)))
            .collect()
    }

    /// An accelerometer (g) resting 2 s in each of five orientations with 1-s turns between:
    /// too few poses for the fit, and neither signature (its rests differ by up to 2 g).
    #[test]
    fn an_accelerometer_with_too_few_poses_is_not_taken_for_another_sensor() {
        let dirs = [
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, -1.0],
            [-0.6, 0.0, 0.8],
        ];
        let xyz = noisy(5 * 300, 0.002, 1, |i| {
            let (pose, t) = (i / 300, i % 300);
            let a = dirs[pose];
            if t < 200 || pose == 4 {
                return a;
            }
            // The turn to the next pose: along the great circle, with a jolt.
            let b = dirs[pose + 1];
            let s = (t - 200) as f64 / 100.0;
            let v: [f64; 3] = std::array::from_fn(|k| a[k] * (1.0 - s) + b[k] * s);
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            std::array::from_fn(|k| v[k] / n * (1.0 + 0.3 * (s * 6.0).sin()))
        });
        let rec = recording(xyz);
        let ws = detect_windows(&rec, &Default::default()).expect("windows");
        // The rests were found (so the gyroscope's rule was put to the test) ...
        assert!(ws.stats.len() >= MIN_RESTS, "{} windows", ws.stats.len());
        assert_eq!(
            other_sensor(&rec.axis_columns, rec.xyz.as_slice(), &ws),
            None
        );
    }

    /// An accelerometer (g) shaken between rests in one pose (the GRT's Wii Remote shake
    /// log): its rests read alike as a gyroscope's do, but they read 1 g.
    #[test]
    fn an_accelerometer_shaken_in_one_pose_is_not_taken_for_a_gyroscope() {
        let xyz = noisy(8 * 300, 0.002, 5, |i| {
            let t = i % 300;
            let shake = if t < 200 {
                0.0
            } else {
                0.5 * (t as f64 * 0.7).sin()
            };
            [0.05 + shake, -0.02 - 0.5 * shake, 0.99 + 0.3 * shake]
        });
        let rec = recording(xyz);
        let ws = detect_windows(&rec, &Default::default()).expect("windows");
        assert!(
            ws.stats.len() >= MIN_RESTS && ws.units == "g",
            "{} {}",
            ws.stats.len(),
            ws.units
        );
        assert_eq!(
            other_sensor(&rec.axis_columns, rec.xyz.as_slice(), &ws),
            None
        );
    }

    /// A gyroscope (counts about a zero rate of 32768): 3-s rests at the zero rate, 1-s turns
    /// at up to ±3000 counts between them about changing axes.
    #[test]
    fn a_gyroscope_between_rests_is_named() {
        let zero = [32768.0, 32500.0, 32600.0];
        let xyz = noisy(12 * 400, 3.0, 2, |i| {
            let (seg, t) = (i / 400, i % 400);
            if t < 300 {
                return zero;
            }
            let amp = 3000.0 * ((t - 300) as f64 / 100.0 * std::f64::consts::PI).sin();
            std::array::from_fn(|k| zero[k] + if k == seg % 3 { amp } else { 0.1 * amp })
        });
        let xyz = xyz.into_iter().map(|p| p.map(f64::round)).collect();
        match judged(xyz) {
            Some(OtherSensor::Gyroscope {
                rests,
                far_fraction,
                rest_spread,
                ..
            }) => {
                assert!(rests >= 10, "{rests} rests");
                assert!(
                    far_fraction > 0.1 && rest_spread < 20.0,
                    "{far_fraction} {rest_spread}"
                );
            }
            other => panic!("{other:?}"),
        }
    }

    /// A magnetometer turned about without stopping: points on a rotated, off-centre
    /// ellipsoid, a spiral over the whole sphere.
    #[test]
    fn a_magnetometer_turned_about_is_named() {
        let n = 3000;
        let xyz = noisy(n, 1.5, 3, |i| {
            let u = i as f64 / n as f64;
            let (theta, phi) = ((1.0 - 2.0 * u).acos(), 40.0 * std::f64::consts::PI * u);
            let d = [
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ];
            [
                -65.0 + 160.0 * d[0] + 10.0 * d[1],
                80.0 + 170.0 * d[1],
                -130.0 + 195.0 * d[2] + 8.0 * d[0],
            ]
        });
        match judged(xyz) {
            Some(OtherSensor::Magnetometer {
                fit_error_pct,
                rests_on,
                ..
            }) => {
                assert!(
                    fit_error_pct < 2.0 && rests_on < MIN_RESTS,
                    "{fit_error_pct} {rests_on}"
                );
            }
            other => panic!("{other:?}"),
        }
    }

    /// Columns named as an accelerometer's: never taken for another sensor, whatever the data.
    #[test]
    fn named_accelerometer_columns_are_believed() {
        let zero = [32768.0; 3];
        let mut rng = rand::rngs::StdRng::seed_from_u64(4);
        let xyz: Vec<[f64; 3]> = (0..4000)
            .map(|i| {
                if (i / 400) % 2 == 0 {
                    zero
                } else {
                    zero.map(|v| v + rng.random_range(-3000.0..3000.0))
                }
            })
            .collect();
        let mut rec = recording(xyz);
        let ws = detect_windows(&rec, &Default::default()).expect("windows");
        assert!(
            other_sensor(&rec.axis_columns, rec.xyz.as_slice(), &ws).is_some(),
            "the unnamed file shows the signature"
        );
        rec.axis_columns = ["ax".into(), "ay".into(), "az".into()];
        assert_eq!(
            other_sensor(&rec.axis_columns, rec.xyz.as_slice(), &ws),
            None
        );
    }
}

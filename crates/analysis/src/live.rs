//! A calibration watched while it happens (`wiical live`): the state of one session, fed one
//! sample at a time, and the serialisable [`Snapshot`] a view draws.
//!
//! Accelerometer: the core's streaming static detector (the IMU-TK detector with a 2 s initial
//! rest, as `wiical fit --init-s 2`; the adaptive detector needs the whole recording) finds
//! the poses; after each new pose the multi-position fit is run again ([`crate::fit::base::fit_means`])
//! and judged ([`Quality::assess`], which applies the core's coverage rule). Before a fit
//! exists, directions are provisional: the sample minus the mid-range of the pose means, and
//! the coverage rule is applied to those.
//!
//! Magnetometer: a bounded, thinned set of points and the ellipsoid fit of
//! [`crate::magnetometer::fit_points`] (MATLAB `magcal`'s fit error, percent), refitted every
//! [`MAG_REFIT_EVERY`] kept points.

use crate::detect::windows::MAX_WINDOW;
use crate::fit::base::fit_means;
use crate::magnetometer::{fit_points, MagModel};
use crate::report::verdict::{Quality, Verdict};
use serde::Serialize;
use wiical_core::acceptance::CoverageRule;
use wiical_core::multipos::{norm_residual, MultiPosModel};
use wiical_core::static_detect::{StaticDetector, StaticDetectorConfig, StaticInterval};
use wiical_core::Calibration;

/// Poses kept (a session of more is not a calibration; later poses are counted, not kept).
pub const MAX_POSES: usize = 500;
/// Longest source status line kept, bytes.
pub const MAX_SOURCE_STATUS: usize = 500;
/// Magnetometer points kept for the view and the fit.
pub const MAX_MAG_POINTS: usize = 2000;
/// Magnetometer: refit after this many newly kept points.
pub const MAG_REFIT_EVERY: usize = 50;
/// Magnetometer: keep one sample in this many (a 100 Hz stream gives 10 points a second).
pub const MAG_KEEP_EVERY: u64 = 10;

/// Detector settings of a live accelerometer session, seconds: variance window, initial rest
/// (noise reference), shortest hold.
const WINDOW_S: f32 = 1.0;
const INIT_S: f32 = 2.0;
const MIN_STATIC_S: f32 = 2.0;

/// Which sensor the stream is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LiveSensor {
    /// Accelerometer: poses, fit, verdict.
    Accelerometer,
    /// Magnetometer: points and the ellipsoid fit error.
    Magnetometer,
}

/// Why a session cannot start or a sample is refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LiveError {
    /// The sample rate is not a positive finite number or is out of the detector's range.
    #[error("the sample rate {rate_hz} Hz cannot drive the static detector (need 2 to 400 Hz with a 1 s window)")]
    Rate {
        /// The rate given.
        rate_hz: f64,
    },
    /// A sample is not finite or not representable in `f32`.
    #[error("sample {index} is not a finite number in f32 range")]
    NonFinite {
        /// 1-based sample number.
        index: u64,
    },
}

/// One pose found so far.
#[derive(Debug, Clone, Serialize)]
pub struct LivePose {
    /// Start and end of the hold, s (stream clock).
    pub t_start: f64,
    /// End of the hold, s.
    pub t_end: f64,
    /// Samples in the hold.
    pub samples: u32,
    /// Mean raw reading.
    pub mean: [f64; 3],
    /// Unit gravity direction (calibrated when a fit exists, else provisional); `None` when
    /// it cannot be told yet (the first pose before any other).
    pub direction: Option<[f64; 3]>,
    /// ‖a‖ − 1 g of this pose under the latest fit, milli-g.
    pub residual_mg: Option<f64>,
}

/// The latest fit and its verdict.
#[derive(Debug, Clone, Serialize)]
pub struct LiveFit {
    /// RMS of ‖a‖ − 1 g over the poses, milli-g.
    pub rms_mg: f64,
    /// Good or poor (RMS within the limit and the poses cover the sphere).
    pub verdict: Verdict,
    /// The one-line verdict as `wiical fit` prints it.
    pub line: String,
    /// Poses the fit used.
    pub poses: usize,
}

/// Magnetometer state.
#[derive(Debug, Clone, Serialize)]
pub struct MagSnapshot {
    /// Kept points as unit directions from the fitted centre (or the points' mean before a
    /// fit), for drawing on the sphere.
    pub directions: Vec<[f64; 3]>,
    /// Points kept.
    pub points: usize,
    /// Ellipsoid fit error, percent (`magcal`), when a fit succeeded.
    pub fit_error_pct: Option<f64>,
    /// Field strength, raw units.
    pub radius: Option<f64>,
    /// Why there is no fit yet.
    pub fit_note: Option<String>,
}

/// What a view draws: everything about the session, serialisable.
#[derive(Debug, Clone, Serialize)]
pub struct Snapshot {
    /// The stream's sensor.
    pub sensor: LiveSensor,
    /// Samples received.
    pub samples: u64,
    /// Time of the latest sample, s.
    pub t: f64,
    /// True while the latest window is still (accelerometer).
    pub still: bool,
    /// Unit direction of the latest sample (see [`LivePose::direction`]).
    pub current: Option<[f64; 3]>,
    /// Poses found (at most [`MAX_POSES`] kept).
    pub poses: Vec<LivePose>,
    /// Poses found, including any beyond [`MAX_POSES`].
    pub pose_count: usize,
    /// True when directions come from the fit, false when provisional.
    pub calibrated_directions: bool,
    /// The coverage rule's gap (`None`: the poses cover the sphere).
    pub coverage_gap: Option<String>,
    /// The latest fit, once there are enough poses.
    pub fit: Option<LiveFit>,
    /// Why there is no fit (too few poses, degenerate poses).
    pub fit_note: Option<String>,
    /// Magnetometer stream only.
    pub mag: Option<MagSnapshot>,
    /// `None` while the source runs; the reason once it ended.
    pub ended: Option<String>,
    /// What the source says about itself (an adapter's streaming and self-calibration
    /// state, a capture's latest instruction), one line; `None` when it says nothing.
    pub source_status: Option<String>,
}

/// One live calibration session.
pub struct LiveSession {
    sensor: LiveSensor,
    det: StaticDetector<MAX_WINDOW>,
    rate_hz: f64,
    samples: u64,
    t: f64,
    t0: Option<f64>,
    last: Option<[f64; 3]>,
    poses: Vec<LivePose>,
    pose_count: usize,
    cal: Option<Calibration>,
    quality: Option<Quality>,
    fit_note: Option<String>,
    mag_points: Vec<[f64; 3]>,
    mag_since_fit: usize,
    mag_fit: Option<(f64, f64, [f64; 3])>,
    mag_note: Option<String>,
    ended: Option<String>,
    source_status: Option<String>,
}

impl LiveSession {
    /// A session for a stream at `rate_hz`; `integer_counts` says whether the samples are
    /// integer ADC counts (the detector then floors the noise at the quantisation's 1/12).
    pub fn new(sensor: LiveSensor, rate_hz: f64, integer_counts: bool) -> Result<Self, LiveError> {
        if !(rate_hz.is_finite() && (2.0..=400.0).contains(&rate_hz)) {
            return Err(LiveError::Rate { rate_hz });
        }
        let mut cfg =
            StaticDetectorConfig::for_rate(rate_hz as f32, WINDOW_S, INIT_S, MIN_STATIC_S);
        // Floating-point data (g, m/s², µT) have no quantisation floor: a tiny one keeps the
        // threshold positive on a perfectly constant rest.
        if !integer_counts {
            cfg.min_variance = 1e-12;
        }
        let det = StaticDetector::new(cfg).map_err(|_| LiveError::Rate { rate_hz })?;
        Ok(Self {
            sensor,
            det,
            rate_hz,
            samples: 0,
            t: 0.0,
            t0: None,
            last: None,
            poses: Vec::new(),
            pose_count: 0,
            cal: None,
            quality: None,
            fit_note: None,
            mag_points: Vec::new(),
            mag_since_fit: 0,
            mag_fit: None,
            mag_note: None,
            ended: None,
            source_status: None,
        })
    }

    /// Feeds one sample: `t` its time in seconds (any origin), `xyz` the raw reading.
    /// Returns true when the sample completed a new pose (the fit was run again).
    pub fn push(&mut self, t: f64, xyz: [f64; 3]) -> Result<bool, LiveError> {
        let index = self.samples + 1;
        let m = xyz.map(|v| v as f32);
        if !(t.is_finite() && m.iter().all(|v| v.is_finite())) {
            return Err(LiveError::NonFinite { index });
        }
        let t0 = *self.t0.get_or_insert(t);
        self.samples = index;
        self.t = t - t0;
        self.last = Some(xyz);
        match self.sensor {
            LiveSensor::Accelerometer => {
                let iv = self
                    .det
                    .push(m)
                    .map_err(|_| LiveError::NonFinite { index })?;
                Ok(iv.map(|iv| self.add_pose(&iv)).unwrap_or(false))
            }
            LiveSensor::Magnetometer => {
                self.push_mag(xyz);
                Ok(false)
            }
        }
    }

    /// Ends the stream (`why`: e.g. "source ended"): a hold still open becomes the last pose.
    pub fn finish(&mut self, why: &str) {
        if self.ended.is_some() {
            return;
        }
        if self.sensor == LiveSensor::Accelerometer {
            if let Some(iv) = self.det.finish() {
                self.add_pose(&iv);
            }
        } else if self.mag_since_fit > 0 {
            self.refit_mag();
        }
        self.ended = Some(why.to_string());
    }

    /// Sets the source's status line (see [`Snapshot::source_status`]); at most
    /// [`MAX_SOURCE_STATUS`] bytes are kept.
    pub fn set_source_status(&mut self, line: &str) {
        let mut end = line.len().min(MAX_SOURCE_STATUS);
        while !line.is_char_boundary(end) {
            end -= 1;
        }
        self.source_status = Some(line[..end].to_string());
    }

    fn add_pose(&mut self, iv: &StaticInterval) -> bool {
        self.pose_count += 1;
        if self.poses.len() >= MAX_POSES {
            return false;
        }
        let time = |i: u32| f64::from(i) / self.rate_hz;
        self.poses.push(LivePose {
            t_start: time(iv.start),
            t_end: time(iv.end.saturating_sub(1)),
            samples: iv.len(),
            mean: iv.mean.map(f64::from),
            direction: None,
            residual_mg: None,
        });
        self.refit();
        true
    }

    /// The fit of all poses kept, its verdict, and every pose's direction and residual.
    fn refit(&mut self) {
        let means: Vec<[f32; 3]> = self
            .poses
            .iter()
            .map(|p| p.mean.map(|v| v as f32))
            .collect();
        match fit_means(&means, MultiPosModel::Full) {
            Ok(fit) => {
                let cal = fit.calibration;
                let pose_means: Vec<[f64; 3]> = self.poses.iter().map(|p| p.mean).collect();
                self.quality = Some(Quality::assess(
                    &cal,
                    &pose_means,
                    1000.0 * f64::from(fit.rms),
                ));
                for (p, m) in self.poses.iter_mut().zip(&means) {
                    p.residual_mg = Some(1000.0 * f64::from(norm_residual(&cal, *m, 1.0)));
                }
                self.cal = Some(cal);
                self.fit_note = None;
            }
            Err(e) => {
                // Keep the previous fit (if any) on screen; say why this one failed.
                self.fit_note = Some(e.to_string());
            }
        }
        let dirs: Vec<Option<[f64; 3]>> = self
            .poses
            .iter()
            .map(|p| self.direction_of(p.mean))
            .collect();
        for (p, d) in self.poses.iter_mut().zip(dirs) {
            p.direction = d;
        }
    }

    /// Mid-range of the pose means per axis: the provisional centre before a fit.
    fn provisional_centre(&self) -> Option<[f64; 3]> {
        if self.poses.len() < 2 {
            return None;
        }
        Some(std::array::from_fn(|a| {
            let lo = self
                .poses
                .iter()
                .map(|p| p.mean[a])
                .fold(f64::INFINITY, f64::min);
            let hi = self
                .poses
                .iter()
                .map(|p| p.mean[a])
                .fold(f64::NEG_INFINITY, f64::max);
            0.5 * (lo + hi)
        }))
    }

    /// Unit direction of a raw reading: through the fit, else from the provisional centre.
    fn direction_of(&self, m: [f64; 3]) -> Option<[f64; 3]> {
        let v = match &self.cal {
            Some(cal) => cal.correct_linear(m.map(|x| x as f32)).map(f64::from),
            None => {
                let c = self.provisional_centre()?;
                [m[0] - c[0], m[1] - c[1], m[2] - c[2]]
            }
        };
        unit(v)
    }

    fn push_mag(&mut self, xyz: [f64; 3]) {
        if !(self.samples - 1).is_multiple_of(MAG_KEEP_EVERY) {
            return;
        }
        if self.mag_points.len() >= MAX_MAG_POINTS {
            // Thin the oldest half by two so the sphere keeps its history within the bound.
            let half = self.mag_points.len() / 2;
            let mut kept: Vec<[f64; 3]> =
                self.mag_points[..half].iter().step_by(2).copied().collect();
            kept.extend_from_slice(&self.mag_points[half..]);
            self.mag_points = kept;
        }
        self.mag_points.push(xyz);
        self.mag_since_fit += 1;
        if self.mag_since_fit >= MAG_REFIT_EVERY {
            self.refit_mag();
        }
    }

    fn refit_mag(&mut self) {
        self.mag_since_fit = 0;
        match fit_points(&self.mag_points, MagModel::Ellipsoid) {
            Ok(r) => {
                self.mag_fit = Some((r.fit_error_pct, r.radius, r.center));
                self.mag_note = None;
            }
            Err(e) => self.mag_note = Some(e.to_string()),
        }
    }

    /// The coverage rule's gap over the pose directions (`None`: covered).
    fn coverage_gap(&self) -> Option<String> {
        if let (Some(q), Some(_)) = (&self.quality, &self.cal) {
            return q.coverage_gap.clone();
        }
        let dirs: Vec<[f32; 3]> = self
            .poses
            .iter()
            .filter_map(|p| p.direction.map(|d| d.map(|v| v as f32)))
            .collect();
        CoverageRule::default()
            .check(&dirs)
            .err()
            .map(|g| g.to_string())
    }

    /// What a view draws now.
    pub fn snapshot(&self) -> Snapshot {
        let fit = self.quality.as_ref().map(|q| LiveFit {
            rms_mg: q.fit_rms_mg,
            verdict: q.verdict,
            line: q.line(),
            poses: q.poses,
        });
        let is_acc = self.sensor == LiveSensor::Accelerometer;
        Snapshot {
            sensor: self.sensor,
            samples: self.samples,
            t: self.t,
            still: is_acc && self.det.is_still(),
            current: if is_acc {
                self.last.and_then(|m| self.direction_of(m))
            } else {
                self.last.and_then(|m| self.mag_direction(m))
            },
            poses: self.poses.clone(),
            pose_count: self.pose_count,
            calibrated_directions: self.cal.is_some(),
            coverage_gap: if is_acc { self.coverage_gap() } else { None },
            fit,
            fit_note: self.fit_note.clone(),
            mag: (!is_acc).then(|| self.mag_snapshot()),
            ended: self.ended.clone(),
            source_status: self.source_status.clone(),
        }
    }

    fn mag_centre(&self) -> Option<[f64; 3]> {
        if let Some((_, _, c)) = self.mag_fit {
            return Some(c);
        }
        let n = self.mag_points.len();
        (n > 0).then(|| {
            std::array::from_fn(|a| self.mag_points.iter().map(|p| p[a]).sum::<f64>() / n as f64)
        })
    }

    fn mag_direction(&self, m: [f64; 3]) -> Option<[f64; 3]> {
        let c = self.mag_centre()?;
        unit([m[0] - c[0], m[1] - c[1], m[2] - c[2]])
    }

    fn mag_snapshot(&self) -> MagSnapshot {
        MagSnapshot {
            directions: self
                .mag_points
                .iter()
                .filter_map(|m| self.mag_direction(*m))
                .collect(),
            points: self.mag_points.len(),
            fit_error_pct: self.mag_fit.map(|f| f.0),
            radius: self.mag_fit.map(|f| f.1),
            fit_note: self.mag_note.clone(),
        }
    }
}

fn unit(v: [f64; 3]) -> Option<[f64; 3]> {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (n.is_finite() && n > 0.0).then(|| v.map(|x| x / n))
}

#[cfg(test)]
mod tests {
    use super::*;
    use wiical_sim::{simulate, SimConfig};

    fn run(cfg: &SimConfig) -> (LiveSession, Vec<usize>) {
        let out = simulate(cfg).unwrap();
        let rec = &out.recording;
        let rate = rec.estimated_rate_hz().unwrap_or(cfg.rate_hz);
        let mut s = LiveSession::new(LiveSensor::Accelerometer, rate, rec.is_integer()).unwrap();
        let times = rec.times(rate);
        let mut counts = Vec::new();
        for (t, x) in times.iter().zip(&rec.xyz) {
            if s.push(*t, *x).unwrap() {
                counts.push(s.snapshot().pose_count);
            }
        }
        s.finish("source ended");
        (s, counts)
    }

    #[test]
    fn live_poses_appear_one_by_one_and_the_verdict_turns_good() {
        let cfg = SimConfig {
            poses: 20,
            seed: 7,
            ..SimConfig::default()
        };
        let (s, counts) = run(&cfg);
        let snap = s.snapshot();
        // The initial rest plus every simulated hold, each found as it ends.
        assert_eq!(snap.pose_count, cfg.poses + 1, "{:?}", snap.fit_note);
        assert_eq!(counts, (1..=counts.len()).collect::<Vec<_>>());
        let fit = snap.fit.as_ref().expect("a fit");
        assert_eq!(fit.verdict, Verdict::Good, "{}", fit.line);
        assert!(snap.coverage_gap.is_none());
        assert_eq!(snap.ended.as_deref(), Some("source ended"));
        assert!(snap.calibrated_directions);
        // Every pose's direction is a unit vector and its residual small (Wiimote noise).
        for p in &snap.poses {
            let d = p.direction.unwrap();
            assert!(((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - 1.0).abs() < 1e-9);
            assert!(p.residual_mg.unwrap().abs() < 30.0, "{p:?}");
        }
    }

    #[test]
    fn live_still_during_holds_and_moving_between_them() {
        let cfg = SimConfig {
            poses: 12,
            seed: 5,
            ..SimConfig::default()
        };
        let out = simulate(&cfg).unwrap();
        let rec = &out.recording;
        let rate = rec.estimated_rate_hz().unwrap();
        let mut s = LiveSession::new(LiveSensor::Accelerometer, rate, rec.is_integer()).unwrap();
        // The middle of every hold after the rest, and the middle of the motion before it.
        let poses = &out.truth.poses;
        let mut checks: Vec<(f64, bool)> = Vec::new();
        for w in poses.windows(2) {
            checks.push((0.5 * (w[0].t_end + w[1].t_start), false));
            checks.push((0.5 * (w[1].t_start + w[1].t_end), true));
        }
        let mut k = 0;
        for (t, x) in rec.times(rate).iter().zip(&rec.xyz) {
            s.push(*t, *x).unwrap();
            while k < checks.len() && *t >= checks[k].0 {
                assert_eq!(s.snapshot().still, checks[k].1, "at {} s", checks[k].0);
                k += 1;
            }
        }
        assert_eq!(k, checks.len());
    }

    #[test]
    fn live_directions_match_the_simulated_truth() {
        let cfg = SimConfig {
            poses: 16,
            seed: 3,
            ..SimConfig::default()
        };
        let out = simulate(&cfg).unwrap();
        let (s, _) = run(&cfg);
        let snap = s.snapshot();
        // Each simulated hold is the live pose covering its middle: its direction within 3°
        // of the truth (the fit removes bias and scale; small cross-axis terms remain).
        for truth in &out.truth.poses {
            let mid = 0.5 * (truth.t_start + truth.t_end);
            let p = snap
                .poses
                .iter()
                .find(|p| p.t_start <= mid && mid <= p.t_end)
                .unwrap_or_else(|| panic!("no pose at {mid} s"));
            let d = p.direction.unwrap();
            let cos: f64 = (0..3).map(|a| d[a] * truth.direction[a]).sum();
            assert!(
                cos > (3.0f64).to_radians().cos(),
                "{:?} vs {:?}",
                d,
                truth.direction
            );
        }
    }

    #[test]
    fn live_too_few_poses_names_the_gap_and_no_verdict() {
        // The initial rest and the first five holds of a simulation (the truth lists the rest
        // first): six poses.
        let cfg = SimConfig {
            poses: 10,
            seed: 2,
            ..SimConfig::default()
        };
        let out = simulate(&cfg).unwrap();
        let rec = &out.recording;
        let stop = out.truth.poses[5].t_end + 0.5;
        let rate = rec.estimated_rate_hz().unwrap();
        let mut s = LiveSession::new(LiveSensor::Accelerometer, rate, rec.is_integer()).unwrap();
        for (t, x) in rec
            .times(rate)
            .iter()
            .zip(&rec.xyz)
            .take_while(|(t, _)| **t < stop)
        {
            s.push(*t, *x).unwrap();
        }
        s.finish("source ended");
        let snap = s.snapshot();
        assert_eq!(snap.pose_count, 6);
        assert!(snap.fit.is_none(), "{:?}", snap.fit);
        assert!(snap.fit_note.is_some());
        let gap = snap.coverage_gap.expect("a gap");
        assert!(gap.contains('6') && gap.contains("12"), "{gap}");
    }

    #[test]
    fn live_refuses_bad_rate_and_non_finite_samples() {
        assert!(LiveSession::new(LiveSensor::Accelerometer, 0.0, true).is_err());
        assert!(LiveSession::new(LiveSensor::Accelerometer, f64::NAN, true).is_err());
        let mut s = LiveSession::new(LiveSensor::Accelerometer, 100.0, true).unwrap();
        assert_eq!(
            s.push(0.0, [f64::NAN, 0.0, 0.0]),
            Err(LiveError::NonFinite { index: 1 })
        );
        assert_eq!(
            s.push(0.0, [1e300, 0.0, 0.0]),
            Err(LiveError::NonFinite { index: 1 })
        );
        assert_eq!(s.snapshot().samples, 0);
    }

    #[test]
    fn live_magnetometer_fit_error_of_a_sphere_is_small() {
        // Points on an offset ellipsoid (known centre), in steps around two angles.
        let mut s = LiveSession::new(LiveSensor::Magnetometer, 100.0, false).unwrap();
        let c = [120.0, -40.0, 15.0];
        let ax = [300.0, 250.0, 280.0];
        let mut k = 0u32;
        for i in 0..40 {
            for j in 0..30 {
                let th = std::f64::consts::PI * (f64::from(i) + 0.5) / 40.0;
                let ph = 2.0 * std::f64::consts::PI * f64::from(j) / 30.0;
                let u = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
                let m = std::array::from_fn(|a| c[a] + ax[a] * u[a]);
                s.push(f64::from(k) / 100.0, m).unwrap();
                k += 1;
            }
        }
        s.finish("source ended");
        let snap = s.snapshot();
        let mag = snap.mag.unwrap();
        assert_eq!(mag.points, 120);
        assert!(mag.fit_error_pct.unwrap() < 0.1, "{mag:?}");
        let r = mag.radius.unwrap();
        // Geometric mean of the semi-axes.
        assert!((r - (300.0f64 * 250.0 * 280.0).cbrt()).abs() < 1.0, "{r}");
        assert!(snap.poses.is_empty() && snap.fit.is_none());
    }
}

//! The quality verdict of a fitted calibration, printed by `fit` / `analyze` and stored in
//! the calibration file so that `device put` can refuse a poor one.
//!
//! It applies the core's one definition ([`wiical_core::acceptance`]): the fit RMS of `‖a‖ − 1`
//! against [`Acceptance::max_fit_rms`] and the poses' directions against
//! [`CoverageRule::default`]. The sensor-specific plausibility limits (offsets, sensitivity,
//! output bound) need to know the sensor; `device put` applies the Nunchuk's
//! ([`Acceptance::nunchuk`]) because the adapter is a Nunchuk adapter.

use serde::{Deserialize, Serialize};
use wiical_core::acceptance::{Acceptance, CoverageRule};
use wiical_core::Calibration;

/// Good or poor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    /// Fit RMS within the limit, the poses cover the sphere, and (analyze) the residual is
    /// explained.
    Good,
    /// Fit RMS or coverage fails: re-record before uploading.
    Poor,
    /// (analyze) Good by RMS and coverage, but the final model's held-out error is more than
    /// [`UNEXPLAINED_CV_FACTOR`] × the noise floor with χ² p < [`UNEXPLAINED_P`]: something the
    /// model lacks; uploadable with `--force`.
    #[serde(rename = "unexplained-residual")]
    UnexplainedResidual,
}

/// The residual test's factor: held-out RMS over the noise floor.
pub const UNEXPLAINED_CV_FACTOR: f64 = 3.0;

/// The residual test's χ² p-value.
pub const UNEXPLAINED_P: f64 = 1e-3;

/// The residual test: held-out RMS `cv_mg` more than [`UNEXPLAINED_CV_FACTOR`] × the noise
/// floor `floor_mg` with χ² p-value `chi2_p` below [`UNEXPLAINED_P`] (false for NaN).
pub fn residual_unexplained(cv_mg: f64, floor_mg: f64, chi2_p: f64) -> bool {
    cv_mg > UNEXPLAINED_CV_FACTOR * floor_mg && chi2_p < UNEXPLAINED_P
}

/// The residual test of a final model (`analyze`): its held-out error against the noise floor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResidualCheck {
    /// Leave-one-window-out RMS of the final model, milli-g.
    pub cv_rms_mg: f64,
    /// The windows' noise floor, milli-g.
    pub floor_mg: f64,
    /// χ² p-value of the final model against the floor.
    pub chi2_p: f64,
    /// True when `cv_rms_mg > 3 × floor_mg` and `chi2_p < 1e-3`.
    pub unexplained: bool,
}

/// The verdict and the numbers behind it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Quality {
    /// Good or poor.
    pub verdict: Verdict,
    /// RMS of `‖a‖ − 1` over the poses, milli-g (reference units × 1000).
    pub fit_rms_mg: f64,
    /// The limit it is held to, milli-g.
    pub max_fit_rms_mg: f64,
    /// Number of poses (static windows) the fit used.
    pub poses: usize,
    /// Why the poses do not cover the sphere (`None`: they do).
    pub coverage_gap: Option<String>,
    /// (analyze) The final model's held-out error against the noise floor; absent for `fit`
    /// (no floor) and when the floor or the CV is unknown.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual: Option<ResidualCheck>,
}

impl Quality {
    /// Judges a fit: `cal` the fitted calibration, `pose_means` the raw mean of every pose,
    /// `fit_rms_mg` the fit's RMS of `‖a‖ − 1` in milli-g.
    pub fn assess(cal: &Calibration, pose_means: &[[f64; 3]], fit_rms_mg: f64) -> Self {
        Self::assess_with(cal, pose_means, fit_rms_mg, CoverageRule::default())
    }

    /// [`Quality::assess`] with the poses held to `rule` (e.g.
    /// [`CoverageRule::six_position`] for a six-position table).
    pub fn assess_with(
        cal: &Calibration,
        pose_means: &[[f64; 3]],
        fit_rms_mg: f64,
        rule: CoverageRule,
    ) -> Self {
        // The core's f32 limit in mg, rounded to the µg (0.03_f32 is 29.99999933 mg).
        let max_fit_rms_mg = (f64::from(Acceptance::nunchuk().max_fit_rms) * 1e6).round() / 1e3;
        let directions: Vec<[f32; 3]> = pose_means
            .iter()
            .map(|m| cal.correct_linear(m.map(|v| v as f32)))
            .collect();
        let coverage_gap = rule.check(&directions).err().map(|gap| gap.to_string());
        let rms_ok = fit_rms_mg.is_finite() && fit_rms_mg <= max_fit_rms_mg;
        let verdict = if rms_ok && coverage_gap.is_none() {
            Verdict::Good
        } else {
            Verdict::Poor
        };
        Self {
            verdict,
            fit_rms_mg,
            max_fit_rms_mg,
            poses: pose_means.len(),
            coverage_gap,
            residual: None,
        }
    }

    /// Adds the residual test of an analysis (final model's held-out RMS `cv_rms_mg` and χ²
    /// p-value against the floor `floor_mg`): a good verdict whose residual is unexplained
    /// becomes [`Verdict::UnexplainedResidual`]. Unknown numbers leave it as it is.
    pub fn with_residual(
        mut self,
        cv_rms_mg: Option<f64>,
        floor_mg: Option<f64>,
        chi2_p: Option<f64>,
    ) -> Self {
        let (Some(cv), Some(floor), Some(p)) = (cv_rms_mg, floor_mg, chi2_p) else {
            return self;
        };
        if !(cv.is_finite() && floor.is_finite() && floor > 0.0 && p.is_finite()) {
            return self;
        }
        let unexplained = residual_unexplained(cv, floor, p);
        if unexplained && self.verdict == Verdict::Good {
            self.verdict = Verdict::UnexplainedResidual;
        }
        self.residual = Some(ResidualCheck {
            cv_rms_mg: cv,
            floor_mg: floor,
            chi2_p: p,
            unexplained,
        });
        self
    }

    /// One line for the text output, e.g. `quality: good (fit RMS 3.1 mg ≤ 30 mg, 14 poses
    /// cover the sphere)`.
    pub fn line(&self) -> String {
        let rms = if self.fit_rms_mg <= self.max_fit_rms_mg {
            format!(
                "fit RMS {:.2} mg ≤ {:.0} mg",
                self.fit_rms_mg, self.max_fit_rms_mg
            )
        } else {
            format!(
                "fit RMS {:.2} mg exceeds {:.0} mg",
                self.fit_rms_mg, self.max_fit_rms_mg
            )
        };
        let cover = match &self.coverage_gap {
            None => format!("{} poses cover the sphere", self.poses),
            Some(gap) => format!("poses do not cover the sphere: {gap}"),
        };
        match self.verdict {
            Verdict::Good => format!("quality: good ({rms}, {cover})"),
            Verdict::Poor => format!(
                "quality: POOR ({rms}, {cover}); `wiical device put` refuses it without --force"
            ),
            Verdict::UnexplainedResidual => {
                let r = self.residual.as_ref();
                let (cv, floor, p) = r.map_or((f64::NAN, f64::NAN, f64::NAN), |r| {
                    (r.cv_rms_mg, r.floor_mg, r.chi2_p)
                });
                format!(
                    "quality: UNEXPLAINED RESIDUAL ({rms}, {cover}; but the held-out error {cv:.2} mg is {:.0}× the noise floor {floor:.2} mg, χ² p = {p:.1e}: the model misses something); `wiical device put` refuses it without --force",
                    cv / floor
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Unit directions scaled to raw counts around 512 with 200 counts/g.
    fn raw_means(dirs: &[[f64; 3]]) -> Vec<[f64; 3]> {
        dirs.iter()
            .map(|d| {
                let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                d.map(|v| 512.0 + 200.0 * v / n)
            })
            .collect()
    }

    fn nunchuk_cal() -> Calibration {
        let mut cal = Calibration {
            bias: [512.0; 3],
            ..Default::default()
        };
        for (i, row) in cal.matrix.iter_mut().enumerate() {
            row[i] = 1.0 / 200.0;
        }
        cal
    }

    fn sphere_dirs() -> Vec<[f64; 3]> {
        let mut v = Vec::new();
        for a in 0..3 {
            for s in [1.0, -1.0] {
                let mut d = [0.0; 3];
                d[a] = s;
                v.push(d);
            }
        }
        for x in [1.0, -1.0] {
            for y in [1.0, -1.0] {
                for z in [1.0, -1.0] {
                    v.push([x, y, z]);
                }
            }
        }
        v
    }

    #[test]
    fn spread_poses_with_a_small_rms_are_good() {
        let q = Quality::assess(&nunchuk_cal(), &raw_means(&sphere_dirs()), 4.0);
        assert_eq!(q.verdict, Verdict::Good, "{q:?}");
        assert_eq!(q.poses, 14);
        assert!(q
            .line()
            .starts_with("quality: good (fit RMS 4.00 mg ≤ 30 mg, 14 poses"));
    }

    #[test]
    fn a_large_rms_or_a_hemisphere_is_poor() {
        let q = Quality::assess(&nunchuk_cal(), &raw_means(&sphere_dirs()), 45.0);
        assert_eq!(q.verdict, Verdict::Poor);
        assert!(q.line().contains("exceeds 30 mg"), "{}", q.line());
        // Only poses with z up: the −z side is never seen.
        let upper: Vec<[f64; 3]> = sphere_dirs().into_iter().filter(|d| d[2] >= 0.0).collect();
        let mut many = upper.clone();
        many.extend(upper.iter().map(|d| [d[0] * 0.9, d[1] * 1.1, d[2] + 0.3]));
        let q = Quality::assess(&nunchuk_cal(), &raw_means(&many), 4.0);
        assert_eq!(q.verdict, Verdict::Poor);
        assert!(q.coverage_gap.as_deref().unwrap().contains("z"), "{q:?}");
    }

    /// The six canonical poses are the six-position method's whole design: good under its
    /// rule, poor under the multi-position default (12 poses), and five of them miss a side.
    #[test]
    fn six_poses_pass_the_six_position_rule_only() {
        let six = raw_means(&sphere_dirs()[..6]);
        let q = Quality::assess(&nunchuk_cal(), &six, 4.0);
        assert_eq!(q.verdict, Verdict::Poor, "{q:?}");
        let rule = CoverageRule::six_position();
        let q = Quality::assess_with(&nunchuk_cal(), &six, 4.0, rule);
        assert_eq!(q.verdict, Verdict::Good, "{q:?}");
        let q = Quality::assess_with(&nunchuk_cal(), &six[..5], 4.0, rule);
        assert_eq!(q.verdict, Verdict::Poor, "{q:?}");
    }
}

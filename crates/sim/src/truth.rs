//! What the simulation knows: the true poses, outliers, calibration (correction side, with the
//! time and temperature terms the core cannot hold folded in per sample), and its self-check.

use crate::conditions::{SampleConditions, TempModel};
use crate::config::{SimConfig, SimDraw};
use crate::draw::TrueOutlier;
use crate::error::Result;
use crate::error::SimulateError;
use crate::motion::SegKind;
use crate::open_basis_terms::{self, Acts, ExtraTerm, OpenTerm};
use crate::sensor::Scene;
use serde::Serialize;
use wiical_analysis::report::effect_names as names;
use wiical_core::{Calibration, Conditions, Effects};

/// One simulated pose (the true hold, not what a detector finds).
#[derive(Debug, Clone, Serialize)]
pub struct TruePose {
    /// Start of the hold, s.
    pub t_start: f64,
    /// End of the hold, s.
    pub t_end: f64,
    /// Unit specific-force direction in sensor axes (the "up" direction).
    pub direction: [f64; 3],
}

/// Everything the simulation knows (written to `FILE.truth.json`).
#[derive(Debug, Clone, Serialize)]
pub struct Truth {
    /// Device imitated.
    pub device: &'static str,
    /// Effects put in, comma-separated as on the command line (`none` without any).
    pub effect: String,
    /// The first effect's magnitude, milli-g (meaning per effect: see the module docs; 0 for
    /// `none`).
    pub magnitude_mg: f64,
    /// Every effect's magnitude, milli-g, in the order of `effect`.
    pub magnitudes_mg: Vec<f64>,
    /// The effects put on one axis only, as `effect: axis` (`quadratic: z`); absent when
    /// every effect is on every axis.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub single_axis: Vec<String>,
    /// Seed.
    pub seed: u64,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Number of samples.
    pub samples: usize,
    /// Per-sample white-noise std, counts (before rounding).
    pub noise_std_counts: f64,
    /// Forward matrix `D` (file units per g: counts, or m/s² for `mems16`; upper triangular, row-major).
    pub forward_matrix: [[f64; 3]; 3],
    /// The true calibration, correction side (what a perfect `analyze` would return):
    /// `Calibration::correct(m, {time_s: t, temperature_c: θ})` maps the noiseless reading
    /// back to the true specific force.
    pub calibration: Calibration,
    /// Poses in order; the first is the initial rest.
    pub poses: Vec<TruePose>,
    /// Poses that were not still (`outliers` only).
    pub outliers: Vec<TrueOutlier>,
    /// Temperature model: room temperature, warm-up amplitude and time constant.
    pub temperature_model: TempModel,
    /// The open-basis families put in, each with its value and unit;
    /// absent when there are none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub open_basis: Vec<OpenTerm>,
    /// The time and temperature terms, correction side, bias coefficients in the file's unit
    /// (what [`Truth::calibration_at`] folds in).
    #[serde(skip)]
    pub extra_terms: Vec<ExtraTerm>,
}

impl Truth {
    /// The true calibration at one sample: [`Truth::calibration`] with the time and
    /// temperature terms the core cannot hold folded in (bias terms added to `bias`, scale
    /// terms multiplying the rows of `matrix`), so that
    /// `calibration_at(c).correct(m, {time_s, temperature_c})` maps the noiseless reading
    /// back to the true specific force.
    pub fn calibration_at(&self, c: &SampleConditions) -> Calibration {
        let mut cal = self.calibration;
        for t in &self.extra_terms {
            let r = t.regressor.value(c);
            for j in 0..3 {
                let v = t.coefficients[j] * r;
                match t.acts {
                    Acts::Bias => cal.bias[j] += v as f32,
                    Acts::Scale => {
                        for k in &mut cal.matrix[j] {
                            *k *= (1.0 + v) as f32;
                        }
                    }
                }
            }
        }
        cal
    }

    /// The core's [`Conditions`] of a sample (true temperature).
    pub fn conditions(c: &SampleConditions) -> Conditions {
        Conditions {
            time_s: c.time_s as f32,
            temperature_c: Some(c.temperature_c as f32),
        }
    }
}

/// The true calibration of `scene`: the inverse of its forward model with the effect terms.
fn true_calibration(scene: &Scene) -> Result<Calibration> {
    // In the file's unit: every count-valued term scaled by the unit of a count.
    let u = scene.unit;
    let d = &scene.d.map(|r| r.map(|v| v * u));
    let k_true = wiical_core::model::invert3(&wiical_core::Mat3::from_fn(|r, c| d[r][c] as f32))
        .map_err(SimulateError::ForwardNotInvertible)?;
    let mut calibration = Calibration::from_inverse(
        &k_true,
        &wiical_core::Vec3::new(
            (scene.bias[0] * u) as f32,
            (scene.bias[1] * u) as f32,
            (scene.bias[2] * u) as f32,
        ),
    );
    let e = &scene.terms.eff64;
    calibration.effects = Effects {
        temp_ref_c: scene.tm.room_c as f32,
        quadratic: e[0].map(|v| v as f32),
        cubic: e[1].map(|v| v as f32),
        bias_drift: e[2].map(|v| (v * u) as f32),
        bias_temp: e[3].map(|v| (v * u) as f32),
        scale_temp: e[4].map(|v| v as f32),
        cross_quadratic: scene.terms.cross.quadratic.map(|r| r.map(|v| v as f32)),
        cross_cubic: scene.terms.cross.cubic.map(|r| r.map(|v| v as f32)),
    };
    Ok(calibration)
}

/// The poses of `scene` with their hold times.
fn true_poses(scene: &Scene) -> Vec<TruePose> {
    scene
        .dirs
        .iter()
        .enumerate()
        .map(|(k, dir)| {
            let seg = scene
                .segs
                .iter()
                .find(|s| matches!(s.kind, SegKind::Hold(p) if p == k))
                .map_or((0.0, 0.0), |s| (s.t0, s.t1));
            TruePose {
                t_start: seg.0,
                t_end: seg.1,
                direction: *dir,
            }
        })
        .collect()
}

/// Self-check: the truth calibration maps a noiseless hold reading of `scene` back to its
/// direction.
pub(super) fn check_truth(scene: &Scene, truth: &Truth) -> Result<()> {
    let Some(p) = truth.poses.get(1) else {
        return Ok(());
    };
    let n = scene.conds.len();
    let tc = 0.5 * (p.t_start + p.t_end);
    let idx = ((tc * scene.fs) as usize).min(n.saturating_sub(1));
    let Some(c) = scene.conds.get(idx) else {
        return Ok(());
    };
    let m = scene
        .reading(&p.direction, c)
        .map(|v| (v * scene.unit) as f32);
    let a = truth.calibration_at(c).correct(m, &Truth::conditions(c));
    let err = (0..3)
        .map(|j| (a[j] as f64 - p.direction[j]).abs())
        .fold(0.0, f64::max);
    if err > 1e-4 {
        return Err(SimulateError::TruthNotInverse { err_g: err }.into());
    }
    Ok(())
}

/// The truth of `scene` with `effects` drawn into it.
pub(super) fn truth(scene: &Scene, cfg: &SimConfig, effects: &[SimDraw]) -> Result<Truth> {
    let names: Vec<&str> = effects.iter().map(|(e, _, _)| e.name()).collect();
    let unit = scene.unit;
    let mut open = open_basis_terms::cross_truth(&scene.terms.cross);
    open.extend(
        scene
            .terms
            .extras
            .iter()
            .map(|t| open_basis_terms::extra_truth(t, cfg.device.unit_name(), unit)),
    );
    let extra_terms = scene
        .terms
        .extras
        .iter()
        .map(|t| ExtraTerm {
            coefficients: match t.acts {
                Acts::Bias => t.coefficients.map(|c| c * unit),
                Acts::Scale => t.coefficients,
            },
            ..*t
        })
        .collect();
    Ok(Truth {
        device: cfg.device.name(),
        effect: if names.is_empty() {
            "none".into()
        } else {
            names.join(",")
        },
        magnitude_mg: effects.first().map_or(0.0, |e| e.1),
        magnitudes_mg: effects.iter().map(|e| e.1).collect(),
        single_axis: effects
            .iter()
            .filter_map(|(e, _, a)| Some(format!("{}: {}", e.name(), names::AXES[(*a)?])))
            .collect(),
        seed: cfg.seed,
        rate_hz: scene.fs,
        samples: scene.conds.len(),
        noise_std_counts: scene.noise,
        forward_matrix: scene.d.map(|r| r.map(|v| v * unit)),
        calibration: true_calibration(scene)?,
        poses: true_poses(scene),
        outliers: scene.terms.outliers.clone(),
        temperature_model: scene.tm,
        open_basis: open,
        extra_terms,
    })
}

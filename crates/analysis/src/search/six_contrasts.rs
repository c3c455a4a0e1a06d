//! The residual analysis of a six-position file (a `pose` column with `x+ x- y+ y- z+ z-`).
//!
//! Six poses give 18 numbers for the seed's 12 parameters (`D`, 9, and `b`, 3), so the residual
//! `M − T̂·Â` has 6 degrees of freedom, and its structure is fixed by the method: `T̂ = M·Â⁺`
//! takes each column of `D` as half the difference of a `±` pair and `b` as the mean of all six
//! poses, so whatever differs between the `+` and `−` pose is absorbed into `D`, and the `+`
//! and `−` residuals of a pair are *equal*: each is the pair's midpoint minus `b`. In each
//! axis row the three pair midpoints sum to zero, leaving two contrasts per row:
//!
//! * **own pair against the other two** (`z_even = √3·R[a][a]`): what a per-axis even-order
//!   nonlinearity of axis `a` produces. With the core's correction `a = u + k2·u²`, the `±1 g`
//!   poses of that axis read `u ≈ ±1 − k2`, so the row's own-pair residual is `−⅔·k2`, the other
//!   two pairs `+⅓·k2` each, and `k2 ≈ −1.5·R[a][a]` (g units);
//! * **between the two other pairs** (`z_mis = R[a][j] − R[a][k]`): zero for any per-axis
//!   effect of axis `a`. A tilt of pair `j` towards axis `a` common to both of its poses (the
//!   jig was not level the same way for `+` and `−`), or a cross-axis even term (`a` reading
//!   `a_j²`), singles out pair `j` in row `a` instead, and so moves *both* contrasts.
//!
//! Six poses therefore cannot fully separate the two explanations: a quadratic of axis `a` is
//! indistinguishable from equal tilts of the other two pairs towards `a`. The rule used here:
//! if the other-pairs contrasts are significant, the poses are misaligned (`pose-misalignment`,
//! a property of the jig that no calibration term can absorb) and the own-pair part is not
//! attributed; only if they are not, a significant own-pair contrast is reported and stored as
//! a `quadratic` (with that caveat in its evidence).
//!
//! Odd effects (a cubic, scale errors) are absorbed into `D` and invisible; time or temperature
//! effects are confounded with the pose order; a leave-one-out cross-validation is impossible
//! because without a pose its axis's scale is undetermined. With raw sample blocks per pose the
//! contrasts are tested against the noise of the pose means (each contrast has the variance of
//! one pose mean, `v̄ = mean over poses of var/n`); with one averaged row per pose (the seed's
//! worked example) there is no noise estimate and nothing can be tested.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::error::six_position::SixPositionError;
use crate::fit::six_position::{pose_means, solve_poses, PoseEstimator};
use crate::input::recording::Recording;
use crate::report::contract::{AnalyzeReport, EffectReport, ModelSummary, SixPositionDetails};
use crate::search::candidate::Candidate;
use crate::search::options::AnalyzeOptions;
use crate::stats as st;

type Result<T, E = SixPositionError> = std::result::Result<T, E>;
use nalgebra::{Matrix3, SMatrix};
use std::fmt::Write as _;
use wiical_core::six_position::{Pose, SixPositionFit};
use wiical_core::{linalg, lm};
use wiical_core::{Calibration, Conditions, Effects};

/// `[D | b]`, 3×4.
type THat = [[f64; 4]; 3];
/// Residual, rows = axes, columns = poses.
type Residual = [[f64; 6]; 3];
/// 3×3 matrix.
type Mat = [[f64; 3]; 3];

/// Per-axis variance of each pose's samples and the sample counts.
fn pose_variances(rec: &Recording) -> Option<[[f64; 3]; 6]> {
    let labels = rec.labels.as_ref()?;
    let mut out = [[0.0; 3]; 6];
    for pose in Pose::ALL {
        let xs: Vec<[f64; 3]> = labels
            .iter()
            .zip(&rec.xyz)
            .filter(|(l, _)| Pose::from_label(l) == Some(pose))
            .map(|(_, x)| *x)
            .collect();
        if xs.len() < 2 {
            return None;
        }
        let n = xs.len() as f64;
        for a in 0..3 {
            let m = xs.iter().map(|x| x[a]).sum::<f64>() / n;
            let v = xs.iter().map(|x| (x[a] - m).powi(2)).sum::<f64>() / (n - 1.0);
            out[pose as usize][a] = v;
        }
    }
    Some(out)
}

/// `[D | b] = M·Ûᵀ(ÛÛᵀ)⁻¹` for targets `u` (one 3-vector per pose) and the residual `M − T̂Û`
/// (`ÛÛᵀ` is symmetric positive definite for six turned poses: Cholesky).
fn solve_targets(means: &[[f64; 3]; 6], u: &[[f64; 3]; 6]) -> Option<(THat, Residual)> {
    let uh = SMatrix::<f64, 4, 6>::from_fn(|k, p| if k < 3 { u[p][k] } else { 1.0 });
    let m = SMatrix::<f64, 3, 6>::from_fn(|r, p| means[p][r]);
    let chol = linalg::cholesky_checked(&(uh * uh.transpose()), lm::REL_PIVOT_F64)?;
    // T̂ = M Ûᵀ G⁻¹, i.e. G T̂ᵀ = Û Mᵀ.
    let t_hat = chol.solve(&(uh * m.transpose())).transpose();
    let res = m - t_hat * uh;
    Some((
        std::array::from_fn(|r| std::array::from_fn(|c| t_hat[(r, c)])),
        std::array::from_fn(|r| std::array::from_fn(|p| res[(r, p)])),
    ))
}

/// `K = D⁻¹` (the core's checked inverse; `None` when `D` is singular).
fn inv3(d: [[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let k = linalg::invert3_checked(&Matrix3::from_fn(|r, c| d[r][c]), 1e-12).ok()?;
    Some(std::array::from_fn(|r| std::array::from_fn(|c| k[(r, c)])))
}

/// Residual in g: `K·r_p` per pose.
fn residual_g(k: &[[f64; 3]; 3], res: &[[f64; 6]; 3]) -> [[f64; 6]; 3] {
    let mut out = [[0.0; 6]; 3];
    for p in 0..6 {
        for a in 0..3 {
            out[a][p] = (0..3).map(|b| k[a][b] * res[b][p]).sum();
        }
    }
    out
}

/// Pair midpoints (rows = axes, columns = pairs).
fn pairs(r: &[[f64; 6]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|a| std::array::from_fn(|j| 0.5 * (r[a][2 * j] + r[a][2 * j + 1])))
}

/// Fits `D`, `b` and a per-axis quadratic `k2` (correction side) to the six poses: the pose
/// targets become the `u` that the quadratic maps to `±1 g`, and `k2` is updated from the
/// own-pair residual until it vanishes.
fn fit_with_quadratic(means: &[[f64; 3]; 6]) -> Option<(Mat, [f64; 3], [f64; 3], Residual)> {
    let mut q = [0.0f64; 3];
    let mut last = None;
    for _ in 0..50 {
        let u: [[f64; 3]; 6] = std::array::from_fn(|p| {
            let dir = Pose::ALL[p].direction();
            std::array::from_fn(|j| {
                let s = dir[j] as f64;
                if s == 0.0 {
                    0.0
                } else if q[j].abs() < 1e-12 {
                    s
                } else {
                    // Root of q u² + u − s = 0 near s.
                    (-1.0 + (1.0 + 4.0 * q[j] * s).max(0.0).sqrt()) / (2.0 * q[j])
                }
            })
        });
        let (t, res) = solve_targets(means, &u)?;
        let d: [[f64; 3]; 3] = std::array::from_fn(|r| [t[r][0], t[r][1], t[r][2]]);
        let k = inv3(d)?;
        let rg = residual_g(&k, &res);
        let pr = pairs(&rg);
        let mut change = 0.0f64;
        for j in 0..3 {
            let dq = -1.5 * pr[j][j];
            q[j] += dq;
            change = change.max(dq.abs());
        }
        last = Some((k, [t[0][3], t[1][3], t[2][3]], q, rg));
        if change < 1e-12 {
            break;
        }
    }
    last
}

/// The residual structure of the six-position solve (see the module docs).
struct Structure {
    /// Pose means, f32 as the core solved them.
    means32: [[f32; 3]; 6],
    /// The same in f64.
    means: [[f64; 3]; 6],
    /// Samples per pose.
    counts: [u32; 6],
    /// The core's solve.
    fit: SixPositionFit,
    /// `K = D⁻¹`.
    k: Mat,
    /// Residual in g, rows = axes, columns = poses.
    rg: Residual,
    /// Pair midpoints in g.
    pr: [[f64; 3]; 3],
    /// Pair midpoints in raw units.
    pr_raw: [[f64; 3]; 3],
    /// ‖a‖ − 1 g per pose, mg.
    norm_res: [f64; 6],
    /// Own-pair contrasts as the quadratic they imply, mg/g².
    implied_k2: [f64; 3],
    /// Other-pairs contrasts, mg.
    mis: [f64; 3],
}

/// The two other pairs of axis row `a`.
fn others(a: usize) -> (usize, usize) {
    match a {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

fn structure(rec: &Recording) -> Result<Structure> {
    let (means32, counts) = pose_means(rec, PoseEstimator::Mean)?;
    crate::fit::six_position::check_poses(rec, &means32)?;
    let fit = solve_poses(&means32)?;
    // Recompute in f64 from the f32 means (the solve is linear; f64 keeps the residual exact).
    let means: [[f64; 3]; 6] = means32.map(|m| m.map(|x| x as f64));
    let u0: [[f64; 3]; 6] = std::array::from_fn(|p| Pose::ALL[p].direction().map(|x| x as f64));
    let (t, res) = solve_targets(&means, &u0).ok_or(SixPositionError::SixPositionSingular)?;
    let d: [[f64; 3]; 3] = std::array::from_fn(|r| [t[r][0], t[r][1], t[r][2]]);
    let k = inv3(d).ok_or(SixPositionError::SingularD)?;
    let rg = residual_g(&k, &res);
    let pr = pairs(&rg);
    let bias = [t[0][3], t[1][3], t[2][3]];
    let norm_res: [f64; 6] = std::array::from_fn(|p| {
        let a: [f64; 3] =
            std::array::from_fn(|r| (0..3).map(|c| k[r][c] * (means[p][c] - bias[c])).sum());
        ((a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() - 1.0) * 1e3
    });
    let mis: [f64; 3] = std::array::from_fn(|a| {
        let (j, l) = others(a);
        (pr[a][j] - pr[a][l]) * 1e3
    });
    Ok(Structure {
        means32,
        means,
        counts,
        fit,
        k,
        rg,
        implied_k2: std::array::from_fn(|a| -1.5 * pr[a][a] * 1e3),
        pr,
        pr_raw: pairs(&res),
        norm_res,
        mis,
    })
}

/// The contrasts tested against the noise of the pose means.
struct Tests {
    pose_mean_var: Option<[f64; 3]>,
    chi_e: Option<f64>,
    chi_m: Option<f64>,
    p_e: Option<f64>,
    p_m: Option<f64>,
    even_sig: bool,
    mis_sig: bool,
    floor_mg: Option<f64>,
}

fn tests(rec: &Recording, s: &Structure, alpha: f64) -> Tests {
    // Noise of one pose mean (raw), averaged over poses.
    let var = pose_variances(rec);
    // Integer counts: a pose whose samples never change still has the quantisation variance.
    let quant_floor = if rec.is_integer() { 1.0 / 12.0 } else { 0.0 };
    let pose_mean_var: Option<[f64; 3]> = var.map(|v| {
        std::array::from_fn(|a| {
            (0..6)
                .map(|p| v[p][a].max(quant_floor) / s.counts[p].max(1) as f64)
                .sum::<f64>()
                / 6.0
        })
    });
    let (mut chi_e, mut chi_m) = (None, None);
    if let Some(v) = pose_mean_var {
        let mut ce = 0.0;
        let mut cm = 0.0;
        for (a, &va) in v.iter().enumerate() {
            if va <= 0.0 {
                continue;
            }
            let (j, l) = others(a);
            ce += 3.0 * s.pr_raw[a][a].powi(2) / va;
            cm += (s.pr_raw[a][j] - s.pr_raw[a][l]).powi(2) / va;
        }
        chi_e = Some(ce);
        chi_m = Some(cm);
    }
    let p_e = chi_e.map(|c| st::chi2_sf(c, 3.0));
    let p_m = chi_m.map(|c| st::chi2_sf(c, 3.0));
    // Two tests: Bonferroni factor 2.
    let level = alpha / 2.0;
    let mis_sig = p_m.is_some_and(|p| p < level);
    // A misaligned jig moves the own-pair contrasts too: only attribute them to a quadratic
    // when the other-pairs contrasts are clean.
    let even_sig = p_e.is_some_and(|p| p < level) && !mis_sig;
    // Floor of one residual entry: variance v̄·(1 − 2/3) (each pose's diagonal of I − P).
    let floor_mg = pose_mean_var.map(|v| {
        let per: Vec<f64> = (0..3)
            .map(|a| (v[a] / 3.0).sqrt() * s.k[a][a].abs() * 1e3)
            .collect();
        st::rms(&per)
    });
    Tests {
        pose_mean_var,
        chi_e,
        chi_m,
        p_e,
        p_m,
        even_sig,
        mis_sig,
        floor_mg,
    }
}

/// The effects the tests support, the calibration that stores them, the final RMS and
/// parameter count.
fn six_effects(
    s: &Structure,
    t: &Tests,
    base_rms: f64,
) -> (Vec<EffectReport>, Calibration, f64, usize) {
    let mut effects = Vec::new();
    let mut cal = s.fit.calibration();
    let mut final_rms = base_rms;
    let mut final_params = 12;
    if t.even_sig {
        if let Some((kq, bq, q, rgq)) = fit_with_quadratic(&s.means) {
            let rq: Vec<f64> = rgq.iter().flatten().map(|x| x * 1e3).collect();
            final_rms = st::rms(&rq);
            final_params += 3;
            cal = Calibration {
                bias: bq.map(|x| x as f32),
                matrix: kq.map(|r| r.map(|x| x as f32)),
                effects: Effects {
                    quadratic: q.map(|x| x as f32),
                    ..Effects::default()
                },
            };
            effects.push(EffectReport {
                name: Candidate::Quadratic.to_string(),
                params: 3,
                rms_mg: final_rms,
                cv_rms_mg: None,
                cv_rms_before_mg: None,
                evidence: format!(
                    "each axis's own ± pair sits off the other two pairs, which agree with each other (χ² = {:.1} on 3 dof, p {}): an even nonlinearity, k2 = {} mg/g² (six poses cannot tell it from equal tilts of the other two pairs towards the axis)",
                    t.chi_e.unwrap_or(f64::NAN),
                    t.p_e.map_or("n/a".into(), |p| format!("{p:.1e}")),
                    fmt3(&q.map(|x| x * 1e3))
                ),
                f_stat: t.chi_e,
                p_value: t.p_e,
                values: Some(q.map(|x| x * 1e3)),
                std_errors: None,
                unit: Some("mg/g² (k2)".into()),
                rejected_windows: None,
                cv_profile: None,
            });
        }
    }
    if t.mis_sig {
        final_params += 3;
        effects.push(EffectReport {
            name: "pose-misalignment".into(),
            params: 3,
            rms_mg: final_rms,
            cv_rms_mg: None,
            cv_rms_before_mg: None,
            evidence: format!(
                "in the axis rows the two other pairs disagree (χ² = {:.1} on 3 dof, p {}), contrasts {} mg: a ± pair tilted the same way in both of its poses, or a cross-axis even term; a property of the poses that the calibration cannot absorb (re-level the jig); the own-pair contrasts are then not attributed to a quadratic, since the tilt moves them too",
                t.chi_m.unwrap_or(f64::NAN),
                t.p_m.map_or("n/a".into(), |p| format!("{p:.1e}")),
                fmt3(&s.mis)
            ),
            f_stat: t.chi_m,
            p_value: t.p_m,
            values: Some(s.mis),
            std_errors: None,
            unit: Some("mg (other-pairs contrast per axis row)".into()),
            rejected_windows: None,
            cv_profile: None,
        });
    }
    (effects, cal, final_rms, final_params)
}

/// The six-position section of the report.
fn details(s: &Structure, t: &Tests, explanation: String) -> SixPositionDetails {
    SixPositionDetails {
        samples_per_pose: s.counts,
        pose_means_raw: s.means,
        pose_residual_mg: s.rg.map(|r| r.map(|x| x * 1e3)),
        pair_residual_mg: s.pr.map(|r| r.map(|x| x * 1e3)),
        norm_residual_mg: s.norm_res,
        implied_k2_mg: s.implied_k2,
        misalignment_contrast_mg: s.mis,
        pose_mean_std_raw: t.pose_mean_var.map(|v| v.map(f64::sqrt)),
        chi2_even: t.chi_e,
        p_even: t.p_e,
        chi2_misalignment: t.chi_m,
        p_misalignment: t.p_m,
        explanation,
    }
}

/// Sanity: the stored calibration reproduces the fit on the pose means.
fn check_reproduces_poses(cal: &Calibration, means32: &[[f32; 3]]) -> Result<()> {
    for (p, m) in means32.iter().enumerate() {
        let a = cal.correct(*m, &Conditions::default());
        let dir = Pose::ALL[p].direction();
        let err = (0..3).map(|j| (a[j] - dir[j]).abs()).fold(0.0f32, f32::max);
        if !(err < 0.2) {
            return Err(SixPositionError::SixPositionNotReproduced);
        }
    }
    Ok(())
}

/// Runs the six-position analysis.
pub fn analyze_six(rec: &Recording, opts: &AnalyzeOptions) -> Result<AnalyzeReport> {
    let s = structure(rec)?;
    let t = tests(rec, &s, opts.alpha);
    let all_res: Vec<f64> = s.rg.iter().flatten().map(|x| x * 1e3).collect();
    let base_rms = st::rms(&all_res);
    let chi_total = match (t.chi_e, t.chi_m) {
        (Some(a), Some(b)) => Some(a + b),
        _ => None,
    };
    let base = ModelSummary {
        params: 12,
        rms_mg: base_rms,
        cv_rms_mg: None,
        windows_used: 6,
        chi2: chi_total,
        chi2_dof: chi_total.map(|_| 6),
        chi2_p: chi_total.map(|c| st::chi2_sf(c, 6.0)),
    };
    let (effects, cal, final_rms, final_params) = six_effects(&s, &t, base_rms);
    check_reproduces_poses(&cal, &s.means32)?;
    let counts_total: u32 = s.counts.iter().sum();
    let explanation = explanation(
        &s.pr,
        &s.implied_k2,
        &s.mis,
        &s.k,
        t.pose_mean_var.is_some(),
        counts_total,
    );
    let details = details(&s, &t, explanation.clone());
    let final_model = ModelSummary {
        params: final_params,
        rms_mg: final_rms,
        cv_rms_mg: None,
        windows_used: 6,
        chi2: None,
        chi2_dof: None,
        chi2_p: None,
    };
    let verdict = verdict(&t, effects.is_empty(), base_rms, final_rms, &explanation);
    Ok(AnalyzeReport {
        mode: "six-position",
        units: if rec.is_integer() {
            "raw"
        } else {
            "raw (averaged)"
        },
        samples: rec.len(),
        static_windows: 6,
        noise_floor_mg: t.floor_mg,
        noise_floor_batch_mg: None,
        base,
        effects,
        final_model,
        steps: Vec::new(),
        verdict,
        time_origin_s: rec
            .t
            .as_ref()
            .and_then(|t| t.first().copied())
            .unwrap_or(0.0),
        time_temp_correlation: None,
        residual_correlates: None,
        diagnostics: Vec::new(),
        calibration: cal,
        host_terms: Vec::new(),
        windows: Vec::new(),
        six_position: Some(details),
        window_input: None,
        autocalibration: None,
        autocalibration_converged: None,
        polling: None,
    })
}

fn verdict(
    t: &Tests,
    no_effects: bool,
    base_rms: f64,
    final_rms: f64,
    explanation: &str,
) -> String {
    if t.pose_mean_var.is_none() {
        format!(
            "Six-position mode: per-axis residual RMS {base_rms:.2} mg, no noise estimate (one averaged row per pose), so nothing can be tested and no effect is added. {explanation}"
        )
    } else if no_effects {
        format!(
            "Six-position mode: per-axis residual RMS {base_rms:.3} mg against a floor of {:.3} mg; neither contrast is significant: nothing six poses can see is missing. Cross-validation is impossible with six poses. {explanation}",
            t.floor_mg.unwrap_or(f64::NAN)
        )
    } else {
        format!(
            "Six-position mode: per-axis residual RMS {base_rms:.3} → {final_rms:.3} mg (floor {:.3} mg). Cross-validation is impossible with six poses. {explanation}",
            t.floor_mg.unwrap_or(f64::NAN)
        )
    }
}

fn fmt3(v: &[f64; 3]) -> String {
    format!("[{:.2}, {:.2}, {:.2}]", v[0], v[1], v[2])
}

fn explanation(
    pr: &[[f64; 3]; 3],
    k2: &[f64; 3],
    mis: &[f64; 3],
    k: &[[f64; 3]; 3],
    have_noise: bool,
    samples: u32,
) -> String {
    let axes = ["x", "y", "z"];
    let mut s = String::from(
        "The + and − pose of each pair have the same residual by construction (T̂ = M·Â⁺ puts any ± difference into D; only the pair midpoint minus b remains). ",
    );
    let _ = write!(
        s,
        "Own-pair residuals (x in the x pair, y in the y pair, z in the z pair): {} mg, which a per-axis quadratic alone would explain as k2 = {} mg/g²; other-pairs contrasts: {} mg, which no per-axis effect produces (a tilt of a ± pair common to both its poses, or a cross-axis even term, singles out that pair and moves both contrasts, so six poses cannot tell a quadratic from equal tilts of the other two pairs). ",
        fmt3(&[pr[0][0] * 1e3, pr[1][1] * 1e3, pr[2][2] * 1e3]),
        fmt3(k2),
        fmt3(mis)
    );
    // Name the largest entry.
    let mut best = (0, 0, 0.0f64);
    for (a, row) in pr.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            if v.abs() > best.2.abs() {
                best = (a, j, *v);
            }
        }
    }
    let _ = write!(
        s,
        "Largest: the {} reading in the {} pair, {:+.2} mg ({:+.3} raw units). ",
        axes[best.0],
        axes[best.1],
        best.2 * 1e3,
        best.2 / k[best.0][best.0]
    );
    s.push_str("Six poses cannot see odd effects (a cubic or scale error is absorbed into D), cannot separate drift or temperature from the pose order, cannot tell an outlier from a tilt, and cannot be cross-validated (without a pose, its axis's scale is undetermined); a multi-position recording (≥ 15 poses) can.");
    if !have_noise {
        let _ = write!(
            s,
            " This file has one averaged row per pose ({samples} rows), so there is no noise estimate to test the residual against."
        );
    }
    s
}

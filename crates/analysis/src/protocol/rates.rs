//! A gyroscope calibrated from known constant rates (a rate table, a record player): no clock
//! is needed, only the steady parts' mean readings and the rates they were turned at.
//!
//! The steady parts are the gyro's own still windows (a constant rate is a still signal to the
//! detector). Each steady mean `m` satisfies `m = S·ω + b` (`S` raw per rad/s, `b` raw), with
//! `|ω|` one of the known rates. The windows are sorted onto the rates by one common scale (the
//! ratio of the rates is what the data must show: 0, 200 and 270 °/s read as 0, r and 1.35 r);
//! windows between the rates (spin-up) are left out. Then:
//!
//! * **axis-aligned** rotations (every turning window within 20° of a sensor axis, all three
//!   axes turned: a rate table) → the seed's six-position method on rates,
//!   `[S | b] = M·Âᵀ(ÂÂᵀ)⁻¹` with `Â`'s columns `[±R·e_i; 1]` and `[0; 1]` for rests: scale,
//!   misalignment and bias;
//! * rotations in **many orientations** (a turntable) → the rate *shells*: `‖K(m − b)‖ = R`,
//!   `K` upper triangular (the same gauge as the accelerometer's multi-position fit), `b` from
//!   the rests, by the core's Levenberg–Marquardt in `f64`.

use super::vec3::{along_axis, axis_label, mat_vec, norm, sub, AXES};
use nalgebra::{Matrix3, Matrix4, Matrix4x3, SVector, Vector4};
use serde::Serialize;
use wiical_core::lm::{self, LmSettings, Problem};

/// A turning window points along a sensor axis when within this angle of it.
const AXIS_TOLERANCE_DEG: f64 = 20.0;

/// A window's rate is taken as one of the known rates when within this fraction of it.
const RATE_MATCH: f64 = 0.06;

/// One steady part of the gyro: its mean and samples.
#[derive(Debug, Clone, Copy)]
pub struct SteadyMean {
    /// Mean reading, raw units.
    pub mean: [f64; 3],
    /// Samples averaged.
    pub samples: usize,
    /// Standard error of the mean per axis, raw (from the spread of its blocks' means, so
    /// correlated noise and wobble count; NaN when unknown).
    pub std_error: [f64; 3],
}

/// A steady window sorted onto a known rate.
#[derive(Debug, Clone, Serialize)]
pub struct RateWindow {
    /// Index among the steady windows.
    pub window: usize,
    /// The known rate it was turned at, °/s (0 for a rest).
    pub rate_dps: f64,
    /// Its rate after calibration, °/s (magnitude).
    pub calibrated_dps: f64,
    /// The sensor axis it turned about (`+x`…), when within 20° of one.
    pub axis: Option<String>,
}

/// A known-rate gyro calibration.
#[derive(Debug, Clone, Serialize)]
pub struct RateFit {
    /// `rate-table` (axis-aligned, six-position on rates) or `rate-shells` (many orientations).
    pub method: &'static str,
    /// `b`, raw.
    pub bias: [f64; 3],
    /// `K`, rad/s per raw unit (`ω = K·(m − b)`).
    pub matrix: [[f64; 3]; 3],
    /// The windows used, with their rates.
    pub windows: Vec<RateWindow>,
    /// Steady windows at none of the rates (spin-up, a rate not given).
    pub left_out: usize,
    /// RMS of `|ω| − R` over the turning windows after calibration, °/s.
    pub rms_dps: f64,
    /// RMS of the same before (nominal scale from the common scale, bias from the rests), °/s.
    pub rms_dps_before: f64,
    /// What the turning windows' own noise allows: RMS of their means' standard errors through
    /// the calibration, °/s (NaN when unknown).
    pub noise_floor_dps: f64,
}

/// Why the rates give no calibration.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RateFitError {
    /// No rest and no nonzero rate found, or nothing matched the rates.
    #[error(
        "no steady part of the gyro matches the rates given ({rates} °/s): {found} steady \
         part(s) found; check --table-rate"
    )]
    NoMatch {
        /// The rates given.
        rates: String,
        /// Steady windows found.
        found: usize,
    },
    /// Rotations about fewer than three axes on an axis-aligned table.
    #[error(
        "the table turned about {axes} only: the scale of the other axes cannot be had; turn \
         it about every axis"
    )]
    MissingAxes {
        /// Axes turned about.
        axes: String,
    },
    /// Too few turning windows for the shell fit.
    #[error(
        "{n} steady turning part(s) cannot fix 6 scale parameters: hold the sensor in at least \
         6 orientations on the turntable (best 10 or more)"
    )]
    TooFewShells {
        /// Turning windows.
        n: usize,
    },
    /// The solver failed.
    #[error("the rate-shell fit failed: {0}")]
    Solver(String),
}

/// Samples per block of the steady-rate search (no clock is assumed: a count of samples).
pub const STEADY_BLOCK: usize = 32;

/// The steady parts of a gyro recording for the known-rate methods: blocks of
/// [`STEADY_BLOCK`] samples whose spread is within 4× the rest's noise or 6 % of their rate
/// (a turntable's spin shakes the sensor: its noise grows with the rate, which the still-window
/// detector, tuned on the quietest blocks, refuses), joined while their means agree within
/// 1 % of the rate (or the rest's noise); the interior of runs of at least 3 blocks is kept.
/// `xyz`: the gyro's samples in one pass, in order (held or a large file's rows alike).
pub fn steady_runs(
    xyz: impl Iterator<Item = [f64; 3]>,
    bias: [f64; 3],
    rest_sd: [f64; 3],
) -> Vec<SteadyMean> {
    let block = |b: &[[f64; 3]]| {
        let n = b.len() as f64;
        let mean: [f64; 3] = std::array::from_fn(|a| b.iter().map(|s| s[a]).sum::<f64>() / n);
        let rate = norm(sub(mean, bias));
        let steady = (0..3).all(|a| {
            let v = b.iter().map(|s| (s[a] - mean[a]).powi(2)).sum::<f64>() / (n - 1.0);
            v.sqrt() <= (4.0 * rest_sd[a]).max(0.06 * rate)
        });
        steady.then_some(mean)
    };
    let mut blocks: Vec<Option<[f64; 3]>> = Vec::new();
    let mut buf = Vec::with_capacity(STEADY_BLOCK);
    for s in xyz {
        buf.push(s);
        if buf.len() == STEADY_BLOCK {
            blocks.push(block(&buf));
            buf.clear();
        }
    }
    let mut runs: Vec<Vec<[f64; 3]>> = Vec::new();
    let mut open: Vec<[f64; 3]> = Vec::new();
    for b in blocks {
        let joined = match (open.is_empty(), b) {
            (false, Some(m)) => {
                let mean = mean_of(&open);
                let tol = (0.01 * norm(sub(m, bias))).max(4.0 * norm(rest_sd));
                norm(sub(mean, m)) <= tol
            }
            _ => false,
        };
        if !joined && !open.is_empty() {
            runs.push(std::mem::take(&mut open));
        }
        open.extend(b);
    }
    runs.push(open);
    // A run's first and last blocks may straddle a ramp (their means are still within 1 % of
    // the rate): only the interior is kept, of runs of at least 3 blocks.
    runs.into_iter()
        .filter(|r| r.len() >= 3)
        .map(|r| {
            let inner = &r[1..r.len() - 1];
            let mean = mean_of(inner);
            let k = inner.len() as f64;
            let std_error = std::array::from_fn(|a| {
                let v = inner.iter().map(|b| (b[a] - mean[a]).powi(2)).sum::<f64>() / (k - 1.0);
                (v / k).sqrt()
            });
            SteadyMean {
                mean,
                samples: inner.len() * STEADY_BLOCK,
                std_error,
            }
        })
        .collect()
}

fn mean_of(blocks: &[[f64; 3]]) -> [f64; 3] {
    let n = blocks.len().max(1) as f64;
    std::array::from_fn(|a| blocks.iter().map(|b| b[a]).sum::<f64>() / n)
}

/// Rests: the windows whose rate is within a few percent of the slowest's distance to the rest.
fn split_rests(ws: &[SteadyMean]) -> (Vec<usize>, [f64; 3]) {
    let norms: Vec<f64> = ws.iter().map(|w| norm(w.mean)).collect();
    let Some(slowest) = (0..ws.len()).min_by(|a, b| norms[*a].total_cmp(&norms[*b])) else {
        return (Vec::new(), [0.0; 3]);
    };
    let origin = ws[slowest].mean;
    let far = ws
        .iter()
        .map(|w| norm(sub(w.mean, origin)))
        .fold(0.0, f64::max);
    let rests: Vec<usize> = (0..ws.len())
        .filter(|i| norm(sub(ws[*i].mean, origin)) <= 0.02 * far)
        .collect();
    let total: f64 = rests.iter().map(|i| ws[*i].samples as f64).sum();
    let bias = std::array::from_fn(|a| {
        rests
            .iter()
            .map(|i| ws[*i].samples as f64 * ws[*i].mean[a])
            .sum::<f64>()
            / total
    });
    (rests, bias)
}

/// The common scale (raw per °/s) that puts most turning windows on a known rate.
fn common_scale(turning: &[f64], rates: &[f64]) -> Option<f64> {
    let mut best: Option<(usize, f64)> = None;
    for r in turning {
        for rate in rates {
            let s = r / rate;
            let hits = turning
                .iter()
                .filter(|x| {
                    rates
                        .iter()
                        .any(|q| ((*x / s) / q - 1.0).abs() <= RATE_MATCH)
                })
                .count();
            if best.is_none_or(|(h, _)| hits > h) {
                best = Some((hits, s));
            }
        }
    }
    best.map(|(_, s)| s)
}

/// The known-rate calibration of the steady windows `ws` for the rates `rates_dps` (°/s; a 0
/// among them, or not, the rests are found either way).
pub fn fit_rates(ws: &[SteadyMean], rates_dps: &[f64]) -> Result<RateFit, RateFitError> {
    let nonzero: Vec<f64> = rates_dps.iter().copied().filter(|r| *r > 0.0).collect();
    let no_match = || RateFitError::NoMatch {
        rates: rates_dps
            .iter()
            .map(|r| format!("{r}"))
            .collect::<Vec<_>>()
            .join(","),
        found: ws.len(),
    };
    let (rests, bias0) = split_rests(ws);
    let turning_idx: Vec<usize> = (0..ws.len()).filter(|i| !rests.contains(i)).collect();
    let mags: Vec<f64> = turning_idx
        .iter()
        .map(|i| norm(sub(ws[*i].mean, bias0)))
        .collect();
    let scale = common_scale(&mags, &nonzero).ok_or_else(no_match)?;
    let mut matched: Vec<(usize, f64)> = rests.iter().map(|i| (*i, 0.0)).collect();
    for (i, m) in turning_idx.iter().zip(&mags) {
        if let Some(q) = nonzero
            .iter()
            .find(|q| ((m / scale) / *q - 1.0).abs() <= RATE_MATCH)
        {
            matched.push((*i, *q));
        }
    }
    if matched.iter().all(|(_, r)| *r == 0.0) {
        return Err(no_match());
    }
    let left_out = ws.len() - matched.len();
    let axis_of = |i: usize| axis_of(sub(ws[i].mean, bias0));
    let aligned = matched
        .iter()
        .all(|(i, r)| *r == 0.0 || axis_of(*i).is_some());
    let (method, bias, k) = if aligned {
        let (b, k) = table_fit(ws, &matched, &axis_of)?;
        ("rate-table", b, k)
    } else {
        let (b, k) = shell_fit(ws, &matched, bias0, scale, !rests.is_empty())?;
        ("rate-shells", b, k)
    };
    let cal = |m: [f64; 3]| norm(mat_vec(&k, sub(m, bias))).to_degrees();
    let before = |m: [f64; 3]| norm(sub(m, bias0)) / scale;
    let rms = |f: &dyn Fn([f64; 3]) -> f64| {
        let t: Vec<f64> = matched
            .iter()
            .filter(|(_, r)| *r > 0.0)
            .map(|(i, r)| f(ws[*i].mean) - r)
            .collect();
        (t.iter().map(|e| e * e).sum::<f64>() / t.len().max(1) as f64).sqrt()
    };
    let floor: Vec<f64> = matched
        .iter()
        .filter(|(_, r)| *r > 0.0)
        .map(|(i, _)| norm(mat_vec(&k, ws[*i].std_error)).to_degrees())
        .collect();
    let noise_floor_dps =
        (floor.iter().map(|e| e * e).sum::<f64>() / floor.len().max(1) as f64).sqrt();
    Ok(RateFit {
        noise_floor_dps,
        method,
        bias,
        matrix: k,
        windows: matched
            .iter()
            .map(|(i, r)| RateWindow {
                window: *i,
                rate_dps: *r,
                calibrated_dps: cal(ws[*i].mean),
                axis: (*r > 0.0).then(|| axis_of(*i)).flatten().map(axis_label),
            })
            .collect(),
        left_out,
        rms_dps: rms(&cal),
        rms_dps_before: rms(&before),
    })
}

/// `(axis, sign)` of a direction within [`AXIS_TOLERANCE_DEG`] of a sensor axis.
fn axis_of(v: [f64; 3]) -> Option<(usize, f64)> {
    along_axis(v, AXIS_TOLERANCE_DEG)
}

/// The six-position method on rates: `[S | b] = M·Âᵀ(ÂÂᵀ)⁻¹`, `K = S⁻¹` (rad/s).
fn table_fit(
    ws: &[SteadyMean],
    matched: &[(usize, f64)],
    axis_of: &dyn Fn(usize) -> Option<(usize, f64)>,
) -> Result<([f64; 3], [[f64; 3]; 3]), RateFitError> {
    let mut turned = [false; 3];
    let mut gram = Matrix4::<f64>::zeros();
    let mut m_at = Matrix4x3::<f64>::zeros();
    for (i, rate) in matched {
        let mut a = Vector4::new(0.0, 0.0, 0.0, 1.0);
        if *rate > 0.0 {
            let (axis, sign) = axis_of(*i).expect("aligned windows have an axis");
            turned[axis] = true;
            a[axis] = sign * rate.to_radians();
        }
        let w = ws[*i].samples as f64;
        gram += w * a * a.transpose();
        for r in 0..3 {
            for c in 0..4 {
                m_at[(c, r)] += w * ws[*i].mean[r] * a[c];
            }
        }
    }
    if turned.contains(&false) {
        let axes = (0..3).filter(|a| turned[*a]).map(|a| AXES[a]);
        return Err(RateFitError::MissingAxes {
            axes: axes.collect::<Vec<_>>().join(", "),
        });
    }
    let t = gram
        .try_inverse()
        .map(|inv| inv * m_at)
        .ok_or(RateFitError::MissingAxes {
            axes: "none".into(),
        })?;
    let s = Matrix3::from_fn(|r, c| t[(c, r)]);
    let k = s
        .try_inverse()
        .ok_or(RateFitError::Solver("singular scale".into()))?;
    Ok((
        std::array::from_fn(|r| t[(3, r)]),
        std::array::from_fn(|r| std::array::from_fn(|c| k[(r, c)])),
    ))
}

/// `‖K(m − b)‖ = R` over the turning windows; `K` upper triangular (rad/s per raw), `b` held
/// at the rests' mean when there are rests.
struct Shells<'a> {
    points: Vec<([f64; 3], f64)>,
    _ws: std::marker::PhantomData<&'a ()>,
}

impl Problem<f64, 9> for Shells<'_> {
    fn observations(&self) -> usize {
        self.points.len()
    }

    fn residual_and_gradient(&self, p: &SVector<f64, 9>, i: usize) -> (f64, SVector<f64, 9>) {
        let (m, r) = self.points[i];
        let d = [m[0] - p[6], m[1] - p[7], m[2] - p[8]];
        let v = [
            p[0] * d[0] + p[1] * d[1] + p[2] * d[2],
            p[3] * d[1] + p[4] * d[2],
            p[5] * d[2],
        ];
        let n = norm(v).max(f64::MIN_POSITIVE);
        let u = v.map(|x| x / n);
        let mut g = SVector::<f64, 9>::zeros();
        g[0] = u[0] * d[0];
        g[1] = u[0] * d[1];
        g[2] = u[0] * d[2];
        g[3] = u[1] * d[1];
        g[4] = u[1] * d[2];
        g[5] = u[2] * d[2];
        g[6] = -u[0] * p[0];
        g[7] = -(u[0] * p[1] + u[1] * p[3]);
        g[8] = -(u[0] * p[2] + u[1] * p[4] + u[2] * p[5]);
        (n - r, g)
    }
}

fn shell_fit(
    ws: &[SteadyMean],
    matched: &[(usize, f64)],
    bias0: [f64; 3],
    scale_raw_per_dps: f64,
    rests: bool,
) -> Result<([f64; 3], [[f64; 3]; 3]), RateFitError> {
    // Radians in the problem, scaled so that the parameters are near 1.
    let points: Vec<([f64; 3], f64)> = matched
        .iter()
        .filter(|(_, r)| *r > 0.0)
        .map(|(i, r)| (ws[*i].mean, r.to_radians()))
        .collect();
    let free = if rests { 6 } else { 9 };
    if points.len() < free + 1 {
        return Err(RateFitError::TooFewShells { n: points.len() });
    }
    if rests {
        return algebraic_shells(&points, bias0).map(|k| (bias0, k));
    }
    let k0 = 1.0 / scale_raw_per_dps.to_degrees();
    let p0 = SVector::<f64, 9>::from_column_slice(&[
        k0, 0.0, 0.0, k0, 0.0, k0, bias0[0], bias0[1], bias0[2],
    ]);
    let mut mask = [true; 9];
    if rests {
        mask[6..].fill(false);
    }
    let problem = Shells {
        points,
        _ws: std::marker::PhantomData,
    };
    let settings = LmSettings {
        param_bound: None,
        step_test: lm::StepTest::PerParameter { rel: 1e-10 },
        gain_tol: 1e-12,
        ..LmSettings::default()
    };
    let fit = lm::minimize(&problem, p0, &mask, None, &settings)
        .map_err(|e| RateFitError::Solver(format!("{e:?}")))?;
    let p = fit.params;
    Ok((
        [p[6], p[7], p[8]],
        [[p[0], p[1], p[2]], [0.0, p[3], p[4]], [0.0, 0.0, p[5]]],
    ))
}

/// With the bias known from the rests, each shell `‖K(m − b)‖ = R` is linear in the
/// symmetric `A = KᵀK`: `dᵀA d = R²` (freeIMUCal's ellipsoid with a known centre). Solved by
/// least squares in relative terms (each row over `R²`), then `K` is `A`'s upper-triangular
/// Cholesky factor (`A = KᵀK`), the multi-position fit's gauge.
fn algebraic_shells(
    points: &[([f64; 3], f64)],
    bias: [f64; 3],
) -> Result<[[f64; 3]; 3], RateFitError> {
    let mut ata = nalgebra::SMatrix::<f64, 6, 6>::zeros();
    let mut atb = nalgebra::SVector::<f64, 6>::zeros();
    for (m, r) in points {
        let d = sub(*m, bias);
        let row = nalgebra::SVector::<f64, 6>::from_column_slice(&[
            d[0] * d[0],
            2.0 * d[0] * d[1],
            2.0 * d[0] * d[2],
            d[1] * d[1],
            2.0 * d[1] * d[2],
            d[2] * d[2],
        ]) / (r * r);
        ata += row * row.transpose();
        atb += row;
    }
    let x = ata
        .cholesky()
        .map(|c| c.solve(&atb))
        .ok_or_else(|| RateFitError::Solver("the shells do not fix the six terms".into()))?;
    let a = Matrix3::new(x[0], x[1], x[2], x[1], x[3], x[4], x[2], x[4], x[5]);
    let l = a
        .cholesky()
        .ok_or_else(|| RateFitError::Solver("the fitted shell is not an ellipsoid".into()))?
        .l();
    Ok(std::array::from_fn(|r| std::array::from_fn(|c| l[(c, r)])))
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops mirror the matrix notation
mod tests {
    use super::*;

    /// raw = S·ω + b with S in raw per rad/s.
    fn truth_s() -> [[f64; 3]; 3] {
        let k = 1000.0f64.to_degrees() / 1000.0; // ~57.3 raw per rad/s ≈ 1 raw per °/s
        [
            [k * 1.02, k * 0.01, -k * 0.008],
            [-k * 0.006, k * 0.985, k * 0.012],
            [k * 0.004, -k * 0.009, k * 1.015],
        ]
    }
    const B: [f64; 3] = [0.8, -1.3, 2.1];

    fn reading(w: [f64; 3]) -> SteadyMean {
        let s = truth_s();
        SteadyMean {
            mean: std::array::from_fn(|r| (0..3).map(|c| s[r][c] * w[c]).sum::<f64>() + B[r]),
            samples: 500,
            std_error: [f64::NAN; 3],
        }
    }

    fn check_k(fit: &RateFit, tol: f64) {
        let s = Matrix3::from_fn(|r, c| truth_s()[r][c]);
        let k = s.try_inverse().unwrap();
        for r in 0..3 {
            assert!((fit.bias[r] - B[r]).abs() < 1e-6, "{fit:?}");
            for c in 0..3 {
                // Only the gauge-free part for shells: compare K·S ≈ rotation; for the table,
                // K itself.
                if fit.method == "rate-table" {
                    assert!((fit.matrix[r][c] - k[(r, c)]).abs() < tol, "{fit:?}");
                }
            }
        }
        assert!(fit.rms_dps < 1e-6, "{}", fit.rms_dps);
    }

    #[test]
    fn a_rate_table_gives_scale_misalignment_and_bias() {
        let r = 25f64.to_radians();
        let mut ws = vec![reading([0.0; 3])];
        for a in 0..3 {
            for s in [1.0, -1.0] {
                let mut w = [0.0; 3];
                w[a] = s * r;
                ws.push(reading(w));
                ws.push(reading([0.0; 3]));
            }
        }
        // A spin-up part at 60 % of the rate is left out.
        ws.push(reading([0.6 * r, 0.0, 0.0]));
        let fit = fit_rates(&ws, &[0.0, 25.0]).unwrap();
        assert_eq!(fit.method, "rate-table");
        assert_eq!(fit.left_out, 1);
        check_k(&fit, 1e-9);
        assert!(fit.rms_dps_before > 0.1);
    }

    #[test]
    fn a_turntable_in_many_orientations_lands_on_its_shells() {
        let mut ws = vec![reading([0.0; 3])];
        for i in 0..12 {
            let th = 0.7 * i as f64;
            let ph = 1.3 * i as f64 + 0.2;
            let dir = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
            for rate in [200.0f64, 270.0] {
                ws.push(reading(dir.map(|d| d * rate.to_radians())));
            }
        }
        let fit = fit_rates(&ws, &[0.0, 200.0, 270.0]).unwrap();
        assert_eq!(fit.method, "rate-shells");
        check_k(&fit, 0.0);
        for w in &fit.windows {
            assert!((w.calibrated_dps - w.rate_dps).abs() < 1e-3, "{w:?}");
        }
    }

    #[test]
    fn a_table_turned_about_two_axes_names_the_missing_one() {
        let r = 25f64.to_radians();
        let ws = vec![
            reading([0.0; 3]),
            reading([r, 0.0, 0.0]),
            reading([-r, 0.0, 0.0]),
            reading([0.0, r, 0.0]),
        ];
        let e = fit_rates(&ws, &[25.0]).unwrap_err();
        assert_eq!(
            e,
            RateFitError::MissingAxes {
                axes: "x, y".into()
            }
        );
    }
}

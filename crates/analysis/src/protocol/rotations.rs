//! Turns between rests, integrated, and the Ferraris gyro calibration from turns of a known
//! angle (Ferraris et al. 1995; imucal's `FerrarisCalibration` does the same from a hand
//! annotation — here the turns are found in the data).
//!
//! Between two rests the gyro's reading less its bias, integrated over time, is `S·θ·n`
//! (`S` raw per rad, `θ` the angle turned, `n` the axis, for a turn about one fixed axis). A
//! *full turn* is recognised without knowing the gyro's scale: the accelerometer reads the same
//! direction before and after (within [`SAME_POSE_DEG`]) while the gyro's integral is large
//! and along one sensor axis. With full turns of a known angle (360° unless told) about `x`,
//! `y` and `z`, each column of `S` is the integral of the turn about that axis over `±θ` (the
//! sign from the data), and `K = S⁻¹`. The bias comes from the rests.

use super::vec3::{along_axis, angle_deg, axis_label, norm, AXES};
use serde::Serialize;

/// Before and after a full turn the accelerometer reads the same direction within this.
pub const SAME_POSE_DEG: f64 = 8.0;

/// A full turn's integral lies within this angle of a sensor axis.
const TURN_AXIS_DEG: f64 = 25.0;

/// One motion between two rests.
#[derive(Debug, Clone, Serialize)]
pub struct Turn {
    /// Index of the rest before it.
    pub after_rest: usize,
    /// Time of its start and end, s.
    pub t_start: f64,
    /// End time, s.
    pub t_end: f64,
    /// `∫(m − b) dt`, raw units × s.
    pub integral: [f64; 3],
    /// Angle in the nominal units (°), when the nominal scale is known.
    pub angle_deg: Option<f64>,
    /// Angle between the accelerometer's directions before and after, degrees.
    pub pose_change_deg: Option<f64>,
    /// The sensor axis the integral lies along (`+x`…), within 25°.
    pub axis: Option<String>,
    /// True for a full turn: back to the same pose about one axis.
    pub full_turn: bool,
}

/// The rests and what a turn between two of them is judged by.
pub struct TurnInput<'a> {
    /// Rests: sample ranges `[start, end)`, in time order.
    pub rests: &'a [(usize, usize)],
    /// The accelerometer's direction in each rest (unit), when there is one.
    pub rest_directions: Option<&'a [[f64; 3]]>,
    /// Gyro bias, raw.
    pub bias: [f64; 3],
    /// Nominal raw units per °/s, when known.
    pub raw_per_dps: Option<f64>,
}

/// One gyro sample as a turn integrates it: its time (s), its reading (raw), and a further
/// offset (raw) taken off beside the bias — the g-sensitivity's `H·a(t)` once it is known
/// ([`super::g_sensitivity`]), else zero.
pub type TurnSample = (f64, [f64; 3], [f64; 3]);

/// The motions between consecutive rests of the `n` samples `samples` (one pass, in order:
/// held or a large file's rows alike), integrated by the trapezoid rule; full turns marked
/// ([`Turn::full_turn`]).
pub fn turns(samples: impl Iterator<Item = TurnSample>, n: usize, inp: &TurnInput) -> Vec<Turn> {
    // (rest pair, first sample, last sample) of each motion: the last of a rest to the first
    // of the next.
    let spans: Vec<(usize, usize, usize)> = inp
        .rests
        .windows(2)
        .enumerate()
        .map(|(k, p)| (k, p[0].1.saturating_sub(1), p[1].0.min(n.saturating_sub(1))))
        .filter(|(_, s, e)| e > s)
        .collect();
    let mut found: Vec<([f64; 3], f64, f64)> = vec![([0.0; 3], 0.0, 0.0); spans.len()];
    let last = spans.last().map_or(0, |s| s.2);
    let (mut first, mut prev): (usize, Option<(f64, [f64; 3])>) = (0, None);
    for (i, (t, m, o)) in samples.enumerate().take(last + 1) {
        let y: [f64; 3] = std::array::from_fn(|a| m[a] - inp.bias[a] - o[a]);
        while spans.get(first).is_some_and(|s| s.2 < i) {
            first += 1;
        }
        // At most two motions touch a sample: one ends at it, the next starts at it.
        for (j, &(_, s, e)) in spans.iter().enumerate().skip(first) {
            if s > i {
                break;
            }
            let f = &mut found[j];
            if i == s {
                f.1 = t;
            }
            if let (true, Some((t0, y0))) = (i > s, prev) {
                let dt = t - t0;
                for (a, acc) in f.0.iter_mut().enumerate() {
                    *acc += 0.5 * (y0[a] + y[a]) * dt;
                }
            }
            if i == e {
                f.2 = t;
            }
        }
        prev = Some((t, y));
    }
    let mut out: Vec<Turn> = spans
        .iter()
        .zip(found)
        .map(|(&(k, _, _), (integral, t_start, t_end))| turn(inp, k, integral, (t_start, t_end)))
        .collect();
    drop_small_turns(&mut out);
    out
}

/// A wobble that returns to the same pose about one axis is no full turn, nor is a re-grip
/// tumble of half a turn about the vertical: without a known unit their integrals cannot be
/// told from a turn's by size alone, but beside the recording's real turns they are small.
/// Candidates under 70 % of the largest candidate's integral are dropped (imucal's session: a
/// 13° wobble beside turns of 354–370°; simulated sessions: tumbles of 150–180°).
fn drop_small_turns(turns: &mut [Turn]) {
    let largest = turns
        .iter()
        .filter(|t| t.full_turn)
        .map(|t| norm(t.integral))
        .fold(0.0, f64::max);
    for t in turns.iter_mut().filter(|t| t.full_turn) {
        t.full_turn = norm(t.integral) >= 0.7 * largest;
    }
}

/// The motion after rest `k`, from its integral `∫(m − b)dt` (raw × s) and its times.
fn turn(inp: &TurnInput, k: usize, integral: [f64; 3], (t_start, t_end): (f64, f64)) -> Turn {
    let pose_change_deg = inp.rest_directions.map(|d| angle_deg(d[k], d[k + 1]));
    let axis = axis_of(integral);
    let angle_deg = inp.raw_per_dps.map(|s| norm(integral) / s);
    let full_turn = axis.is_some()
        && pose_change_deg.is_some_and(|c| c <= SAME_POSE_DEG)
        && angle_deg.is_none_or(|a| a >= 180.0);
    Turn {
        after_rest: k,
        t_start,
        t_end,
        integral,
        angle_deg,
        pose_change_deg,
        axis: axis.map(axis_label),
        full_turn,
    }
}

/// `(axis, sign)` of an integral within [`TURN_AXIS_DEG`] of a sensor axis.
fn axis_of(v: [f64; 3]) -> Option<(usize, f64)> {
    along_axis(v, TURN_AXIS_DEG)
}

/// The Ferraris gyro calibration: `K` (rad/s per raw) from full turns of `angle_deg`.
#[derive(Debug, Clone, Serialize)]
pub struct TurnFit {
    /// `b`, raw.
    pub bias: [f64; 3],
    /// `K`, rad/s per raw unit.
    pub matrix: [[f64; 3]; 3],
    /// The angle each full turn was taken to be, degrees.
    pub angle_deg: f64,
    /// Each full turn's angle after calibration (norm of `K·∫(m − b)dt`), degrees.
    pub calibrated_deg: Vec<f64>,
    /// Full turns used per axis.
    pub turns_per_axis: [usize; 3],
}

/// Why the turns give no calibration.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TurnFitError {
    /// No full turn about some axis.
    #[error(
        "no full turn about {axes}: the gyro's scale on that axis cannot be had from turns; \
         turn the sensor once about each axis between rests (the Ferraris protocol)"
    )]
    MissingAxes {
        /// Axes without a full turn.
        axes: String,
    },
    /// `S` singular.
    #[error("the turns' integrals do not span three axes")]
    Singular,
}

/// Fits `K` from the full turns in `turns` (each of `angle_deg`, sign from the data).
pub fn fit_turns(turns: &[Turn], bias: [f64; 3], angle_deg: f64) -> Result<TurnFit, TurnFitError> {
    let mut cols = [[0.0f64; 3]; 3];
    let mut count = [0usize; 3];
    for t in turns.iter().filter(|t| t.full_turn) {
        let Some((a, sign)) = axis_of(t.integral) else {
            continue;
        };
        for (c, v) in cols[a].iter_mut().zip(t.integral) {
            *c += sign * v / angle_deg.to_radians();
        }
        count[a] += 1;
    }
    if count.contains(&0) {
        let axes: Vec<&str> = (0..3).filter(|a| count[*a] == 0).map(|a| AXES[a]).collect();
        return Err(TurnFitError::MissingAxes {
            axes: axes.join(", "),
        });
    }
    let s = nalgebra::Matrix3::from_fn(|r, c| cols[c][r] / count[c] as f64);
    let k = s.try_inverse().ok_or(TurnFitError::Singular)?;
    let matrix: [[f64; 3]; 3] = std::array::from_fn(|r| std::array::from_fn(|c| k[(r, c)]));
    let calibrated_deg = turns
        .iter()
        .filter(|t| t.full_turn)
        .map(|t| {
            let v = std::array::from_fn(|r| (0..3).map(|c| matrix[r][c] * t.integral[c]).sum());
            norm(v).to_degrees()
        })
        .collect();
    Ok(TurnFit {
        bias,
        matrix,
        angle_deg,
        calibrated_deg,
        turns_per_axis: count,
    })
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops mirror the matrix notation
mod tests {
    use super::*;

    /// Three rests and full turns of 360° about x, then y, then z (raw = S·ω + b), 100 Hz,
    /// each turn with a non-constant rate (a half sine over 3 s).
    #[test]
    fn full_turns_give_the_gyro_scale_and_misalignment() {
        let s = [
            [1.03, 0.01, -0.02],
            [0.015, 0.97, 0.01],
            [-0.01, 0.02, 1.01],
        ];
        let b = [0.4, -0.7, 1.1];
        let (mut gyro, mut rests) = (Vec::new(), Vec::new());
        let rest = |g: &mut Vec<[f64; 3]>, r: &mut Vec<(usize, usize)>| {
            let st = g.len();
            g.extend(std::iter::repeat_n(b, 200));
            r.push((st, g.len()));
        };
        rest(&mut gyro, &mut rests);
        for axis in 0..3 {
            for i in 0..300 {
                // ∫ sin(π t/3) dt over 3 s = 6/π; scaled to 360°.
                let w = 360.0 * std::f64::consts::PI / 6.0
                    * (std::f64::consts::PI * i as f64 / 300.0).sin();
                let mut om = [0.0; 3];
                om[axis] = w;
                gyro.push(std::array::from_fn(|r| {
                    (0..3).map(|c| s[r][c] * om[c]).sum::<f64>() + b[r]
                }));
            }
            rest(&mut gyro, &mut rests);
        }
        let dirs = vec![[0.0, 0.0, 1.0]; rests.len()];
        let inp = TurnInput {
            rests: &rests,
            rest_directions: Some(&dirs),
            bias: b,
            raw_per_dps: Some(1.0),
        };
        let samples = gyro
            .iter()
            .enumerate()
            .map(|(i, m)| (i as f64 / 100.0, *m, [0.0; 3]));
        let ts = turns(samples, gyro.len(), &inp);
        assert_eq!(ts.len(), 3);
        assert!(ts.iter().all(|t| t.full_turn), "{ts:?}");
        let fit = fit_turns(&ts, b, 360.0).unwrap();
        // K = S⁻¹ in rad/s per (raw °/s): S⁻¹ · (π/180)⁻¹ … compare K·S = I·(π/180).
        for r in 0..3 {
            for c in 0..3 {
                let ks: f64 = (0..3).map(|j| fit.matrix[r][j] * s[j][c]).sum();
                let want = if r == c { 1f64.to_radians() } else { 0.0 };
                assert!(
                    (ks - want).abs() < 2e-4 * 1f64.to_radians(),
                    "({r},{c}) {ks}"
                );
            }
        }
        for a in &fit.calibrated_deg {
            assert!((a - 360.0).abs() < 0.1, "{a}");
        }
        // Without a turn about z the axis is named.
        let e = fit_turns(&ts[..2], b, 360.0).unwrap_err();
        assert_eq!(e, TurnFitError::MissingAxes { axes: "z".into() });
    }
}

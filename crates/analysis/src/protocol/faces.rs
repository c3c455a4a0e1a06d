//! Which face of the sensor each still window rests on: the six-position family of protocols
//! recognised from the data, not from labels.
//!
//! A still window's mean, taken from the sensor's zero reading (the reading at 0 g), points
//! along the measured specific force — "up" in sensor axes. The window rests on a *face* when
//! that direction lies within [`FACE_TOLERANCE_DEG`] of a sensor half-axis (`x+` is `+x`
//! pointing up). Hand-placed faces sit a few degrees off (the mouse recording's `z−` is 7°
//! off); free poses spread everywhere, so a recording whose every window is a face, and
//! whose repeats of a face agree, is a six-position-style recording.

use super::vec3::{angle_deg, nearest_axis, norm, sub};
use serde::Serialize;
use wiical_core::six_position::Pose;

/// A window within this angle of a half-axis rests on that face. Wide enough for a hand-held
/// face (the real recordings' faces are ≤ 8° off), narrow enough that the diagonals between
/// faces (≥ 35° from every axis) never count.
pub const FACE_TOLERANCE_DEG: f64 = 20.0;

/// Two windows on the same face agree when their directions are within this angle: a repeat,
/// not a second, tilted pose (a free-pose recording may hold several poses near one axis).
pub const REPEAT_TOLERANCE_DEG: f64 = 10.0;

/// The face of one still window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowFace {
    /// The face, when the window is within [`FACE_TOLERANCE_DEG`] of a half-axis.
    pub pose: Option<Pose>,
    /// Angle between the window's direction and the nearest half-axis, degrees.
    pub off_deg: f64,
    /// Unit direction of the window's mean from the zero reading.
    pub direction: [f64; 3],
}

/// The faces of a recording's still windows and what they identify.
#[derive(Debug, Clone, Serialize)]
pub struct FaceSet {
    /// Distinct faces seen, in `x+ x- y+ y- z+ z-` order.
    pub distinct: Vec<&'static str>,
    /// Faces held more than once (in separate still windows).
    pub repeated: Vec<&'static str>,
    /// Faces never held.
    pub missing: Vec<&'static str>,
    /// Still windows that rest on no face (free poses).
    pub off_face_windows: usize,
    /// Largest angle of a face window from its axis, degrees.
    pub worst_off_deg: f64,
    /// True when every window is a face and the repeats of each face agree
    /// ([`REPEAT_TOLERANCE_DEG`]): the recording is a six-position-style set.
    pub all_faces: bool,
    /// Number of windows per face, in [`Pose::ALL`] order.
    #[serde(skip)]
    pub counts: [usize; 6],
}

/// The reading at 0 g that directions are taken from. Data already in g or m/s², and signed
/// counts, read 0 at 0 g; unsigned counts (the Wii Remote's 8- or 10-bit ADC) read mid-scale,
/// the middle of the smallest power-of-two range holding the means. Counts are taken as
/// unsigned only when every mean lies in the range's upper three quarters: an axis at 0 g of a
/// signed sensor reads near 0, far below a quarter of its range, even when no mean happens to
/// be negative (one pose, z up, both horizontal offsets positive).
pub fn zero_reading(means: &[[f64; 3]], units: &str) -> [f64; 3] {
    let signed = means.iter().flatten().any(|v| *v < 0.0);
    if units != "raw" || signed {
        return [0.0; 3];
    }
    let hi = means.iter().flatten().fold(0.0f64, |a, v| a.max(*v));
    let range = (hi + 1.0).log2().ceil().exp2();
    let lo = means.iter().flatten().fold(f64::INFINITY, |a, v| a.min(*v));
    if lo < 0.25 * range {
        return [0.0; 3];
    }
    [range / 2.0; 3]
}

/// The face of a window whose mean is `mean`, directions from `zero`.
pub fn window_face(mean: [f64; 3], zero: [f64; 3]) -> WindowFace {
    let u = sub(mean, zero);
    let n = norm(u);
    let direction = if n > 0.0 { u.map(|v| v / n) } else { [0.0; 3] };
    // A zero vector points nowhere: 90° from every axis, no face.
    let (axis, sign, off_deg) = nearest_axis(u).unwrap_or((0, 1.0, 90.0));
    let pose =
        (off_deg <= FACE_TOLERANCE_DEG).then(|| Pose::ALL[2 * axis + usize::from(sign < 0.0)]);
    WindowFace {
        pose,
        off_deg,
        direction,
    }
}

/// The face set of windows already classified.
pub fn face_set(faces: &[WindowFace]) -> FaceSet {
    let mut counts = [0usize; 6];
    let mut first: [Option<[f64; 3]>; 6] = [None; 6];
    let mut repeats_agree = true;
    let mut worst_off_deg: f64 = 0.0;
    for f in faces {
        let Some(pose) = f.pose else { continue };
        let k = pose as usize;
        counts[k] += 1;
        worst_off_deg = worst_off_deg.max(f.off_deg);
        match first[k] {
            None => first[k] = Some(f.direction),
            Some(d) => repeats_agree &= angle_deg(d, f.direction) <= REPEAT_TOLERANCE_DEG,
        }
    }
    let labels = |keep: &dyn Fn(usize) -> bool| -> Vec<&'static str> {
        Pose::ALL
            .iter()
            .filter(|p| keep(**p as usize))
            .map(|p| p.label())
            .collect()
    };
    let off_face_windows = faces.iter().filter(|f| f.pose.is_none()).count();
    FaceSet {
        distinct: labels(&|k| counts[k] > 0),
        repeated: labels(&|k| counts[k] > 1),
        missing: labels(&|k| counts[k] == 0),
        off_face_windows,
        worst_off_deg,
        all_faces: off_face_windows == 0 && !faces.is_empty() && repeats_agree,
        counts,
    }
}

/// True when every window points within [`REPEAT_TOLERANCE_DEG`] of the first: one pose held
/// (perhaps with pauses), the AHRS seed's one-pose offset case.
pub fn one_pose(faces: &[WindowFace]) -> bool {
    let Some(first) = faces.first() else {
        return false;
    };
    faces
        .iter()
        .all(|f| angle_deg(first.direction, f.direction) <= REPEAT_TOLERANCE_DEG)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faces_of_signed_and_unsigned_readings() {
        // Signed counts: a hand-placed z− 7° off (the mouse recording's first pose).
        let f = window_face(
            [1795.0, -435.8, -15664.0],
            zero_reading(&[[1.0, -1.0, 0.0]], "raw"),
        );
        assert_eq!(f.pose, Some(Pose::ZNeg));
        assert!((f.off_deg - 6.7).abs() < 0.3, "{}", f.off_deg);
        // Unsigned 8-bit counts (the seed's x+ pose): zero at 128.
        let zero = zero_reading(&[[153.3, 127.2, 130.0], [103.0, 128.0, 130.0]], "raw");
        assert_eq!(zero, [128.0; 3]);
        assert_eq!(
            window_face([153.3, 127.2, 130.0], zero).pose,
            Some(Pose::XPos)
        );
        assert_eq!(
            window_face([103.0, 128.0, 130.0], zero).pose,
            Some(Pose::XNeg)
        );
        // Signed counts that happen to be positive (one pose, z up): still signed.
        assert_eq!(zero_reading(&[[175.0, 403.0, 16026.0]], "raw"), [0.0; 3]);
        // A diagonal pose (35° from every axis) is no face.
        assert_eq!(window_face([1.0, 1.0, 1.0], [0.0; 3]).pose, None);
        // 21° off is no face, 19° is.
        let tilt = |deg: f64| [deg.to_radians().sin(), 0.0, deg.to_radians().cos()];
        assert_eq!(window_face(tilt(21.0), [0.0; 3]).pose, None);
        assert_eq!(window_face(tilt(19.0), [0.0; 3]).pose, Some(Pose::ZPos));
    }

    #[test]
    fn face_set_names_repeats_and_missing() {
        let zero = [0.0; 3];
        let means = [
            [0.0, 0.0, -1.0],
            [0.05, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
        ];
        let faces: Vec<_> = means.iter().map(|m| window_face(*m, zero)).collect();
        let set = face_set(&faces);
        assert_eq!(set.distinct, ["x+", "x-", "y+", "y-", "z-"]);
        assert_eq!(set.repeated, ["z-"]);
        assert_eq!(set.missing, ["z+"]);
        assert!(set.all_faces);
        assert!(!one_pose(&faces));
        // A second z− pose 15° from the first is a tilted pose, not a repeat.
        let mut tilted = faces.clone();
        tilted.push(window_face([0.26, 0.0, -0.97], zero));
        assert!(!face_set(&tilted).all_faces);
    }
}

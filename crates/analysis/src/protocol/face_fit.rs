//! The seed's six-position method on faces recognised from the data, for any set of faces.
//!
//! With the homogeneous model `M = T̂·Â` (`T̂ = [D | b]`, 3×4; `Â` the faces' ideal directions
//! with a row of ones, 4×k) the least-squares solution is `T̂ = M·Âᵀ(ÂÂᵀ)⁻¹` (the seed's eqs.
//! 6–7). With the six faces once each this is the core's constant pseudo-inverse
//! ([`wiical_core::six_position::solve`], used then, in `f32`, as on the device); with repeats
//! the repeats are averaged first (weighted by their samples); with a face missing the same
//! formula holds as long as the faces are not all in one affine plane (`ÂÂᵀ` of rank 4).
//!
//! What a missing face costs: the bias of an axis held only one way up (say `z−` without `z+`)
//! is no longer the midpoint of its own `±1 g` readings but comes from the other faces' readings
//! of that axis at 0 g, so it moves with how level those faces sat — to first order in their
//! tilt (1° reads as 17 mg), where a `±` pair's midpoint moves only to second order. Such an axis
//! is named, with the face to add.

use super::faces::FaceSet;
use super::vec3::AXES;
use nalgebra::{Matrix3, Matrix4, Matrix4x3};
use serde::Serialize;
use wiical_core::six_position::{self, Pose};
use wiical_core::Calibration;

/// One face's mean: its pose, mean reading (raw units) and the samples behind it.
#[derive(Debug, Clone, Copy)]
pub struct FaceMean {
    /// The face.
    pub pose: Pose,
    /// Mean reading, raw units.
    pub mean: [f64; 3],
    /// Samples averaged (for weighting repeats); `None` when unknown.
    pub samples: Option<usize>,
}

/// A face-set calibration.
#[derive(Debug, Clone)]
pub struct FaceFit {
    /// `K = D⁻¹`, `b`.
    pub calibration: Calibration,
    /// `T̂ = [D | b]`, 3×4, raw units per g.
    pub t_hat: [[f64; 4]; 3],
    /// The averaged face means used (`M`'s columns), with their poses.
    pub faces: Vec<(Pose, [f64; 3])>,
    /// Smallest eigenvalue of `ÂÂᵀ / k` (0: faces in one plane; 1/3 for the six faces).
    pub identifiability: f64,
    /// What the faces could not give, one sentence each (empty for the six faces).
    pub not_identified: Vec<String>,
    /// `"six-position"` (all six faces) or `"faces"` (a face missing: the same formula on
    /// fewer columns).
    pub method: &'static str,
    /// The seed's `b` (the least-squares bias: the mean of the six faces), for comparison with
    /// the own-pair bias used ([`FaceFit::calibration`]).
    pub seed_bias: [f64; 3],
}

/// Why a face set gives no calibration.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FaceFitError {
    /// The faces lie in one affine plane (e.g. only `x± y±`): an axis's scale is unknown.
    #[error(
        "the faces {faces} leave {axis}'s scale unknown: no face with {axis} up or down; \
         add the faces {axis}+ and {axis}-"
    )]
    Plane {
        /// The faces held.
        faces: String,
        /// The axis without a face.
        axis: &'static str,
    },
    /// Fewer than four faces.
    #[error(
        "{n} face(s) ({faces}) cannot give bias and scale on three axes (at least four faces, \
         best all six: each axis up and down)"
    )]
    TooFew {
        /// Faces held.
        n: usize,
        /// Their labels.
        faces: String,
    },
    /// `D` is singular (faces recognised but readings do not differ).
    #[error("the faces' readings do not differ enough to invert the scale matrix")]
    Singular,
}

/// Averages the repeats of each face (weighted by samples when all are known).
pub fn average_faces(means: &[FaceMean]) -> Vec<(Pose, [f64; 3])> {
    let mut out = Vec::new();
    for pose in Pose::ALL {
        let of: Vec<&FaceMean> = means.iter().filter(|f| f.pose == pose).collect();
        if of.is_empty() {
            continue;
        }
        let w = |f: &FaceMean| f.samples.map_or(1.0, |n| n as f64);
        let total: f64 = of.iter().map(|f| w(f)).sum();
        let mean =
            std::array::from_fn(|a| of.iter().map(|f| w(f) * f.mean[a]).sum::<f64>() / total);
        out.push((pose, mean));
    }
    out
}

/// The face-set calibration of `means` (see the module docs); `set` names repeats and gaps.
pub fn fit_faces(means: &[FaceMean], set: &FaceSet) -> Result<FaceFit, FaceFitError> {
    let faces = average_faces(means);
    let labels = faces
        .iter()
        .map(|(p, _)| p.label())
        .collect::<Vec<_>>()
        .join(" ");
    if faces.len() < 4 {
        return Err(FaceFitError::TooFew {
            n: faces.len(),
            faces: labels,
        });
    }
    if let Some(axis) = (0..3).find(|a| !faces.iter().any(|(p, _)| p.direction()[*a] != 0.0)) {
        return Err(FaceFitError::Plane {
            faces: labels,
            axis: AXES[axis],
        });
    }
    let (mut t_hat, identifiability) = if faces.len() == 6 {
        six_of_core(&faces)?
    } else {
        least_squares(&faces)?
    };
    let seed_bias = [t_hat[0][3], t_hat[1][3], t_hat[2][3]];
    own_pair_bias(&mut t_hat, &faces);
    let d = Matrix3::from_fn(|r, c| t_hat[r][c]);
    let k = d.try_inverse().ok_or(FaceFitError::Singular)?;
    let calibration = Calibration {
        bias: std::array::from_fn(|r| t_hat[r][3] as f32),
        matrix: std::array::from_fn(|r| std::array::from_fn(|c| k[(r, c)] as f32)),
        effects: Default::default(),
    };
    Ok(FaceFit {
        calibration,
        t_hat,
        method: if faces.len() == 6 {
            "six-position"
        } else {
            "faces"
        },
        faces,
        identifiability,
        not_identified: single_sided_axes(set),
        seed_bias,
    })
}

/// Each axis held both ways up takes its bias from its own pair: the midpoint of its `±1 g`
/// readings (Ferraris et al.; imucal). The seed's `b`, the mean of all faces, also averages
/// each axis's readings at 0 g from the other faces, which move with how level those faces
/// sat to first order (17 mg per degree); the own pair's midpoint moves only to second order.
/// `D` (the half-differences) is the same either way. Measured on imucal's Ferraris session:
/// the faces' `|a| − 1` is 1.46 mg at worst with the seed's `b`, under 0.1 mg with this one.
fn own_pair_bias(t_hat: &mut [[f64; 4]; 3], faces: &[(Pose, [f64; 3])]) {
    for (a, row) in t_hat.iter_mut().enumerate() {
        let of = |p: Pose| faces.iter().find(|(q, _)| *q == p).map(|(_, m)| m[a]);
        if let (Some(up), Some(down)) = (of(Pose::ALL[2 * a]), of(Pose::ALL[2 * a + 1])) {
            row[3] = 0.5 * (up + down);
        }
    }
}

/// The six faces through the core's `f32` constant pseudo-inverse (the device's code).
fn six_of_core(faces: &[(Pose, [f64; 3])]) -> Result<([[f64; 4]; 3], f64), FaceFitError> {
    let labelled: Vec<(Pose, [f32; 3])> = faces
        .iter()
        .map(|(p, m)| (*p, m.map(|v| v as f32)))
        .collect();
    let fit = six_position::solve_labelled(&labelled).map_err(|_| FaceFitError::Singular)?;
    Ok((fit.t_hat.map(|row| row.map(f64::from)), 1.0 / 3.0))
}

/// `T̂ = M·Âᵀ(ÂÂᵀ)⁻¹` in `f64` for four or five faces.
fn least_squares(faces: &[(Pose, [f64; 3])]) -> Result<([[f64; 4]; 3], f64), FaceFitError> {
    let mut gram = Matrix4::<f64>::zeros();
    let mut m_at = Matrix4x3::<f64>::zeros(); // (M·Âᵀ)ᵀ, 4×3
    for (pose, mean) in faces {
        let d = pose.direction();
        let a = nalgebra::Vector4::new(f64::from(d[0]), f64::from(d[1]), f64::from(d[2]), 1.0);
        gram += a * a.transpose();
        for r in 0..3 {
            for c in 0..4 {
                m_at[(c, r)] += mean[r] * a[c];
            }
        }
    }
    let smallest = gram.symmetric_eigenvalues().min() / faces.len() as f64;
    let inv = gram.try_inverse().ok_or(FaceFitError::Singular)?;
    let t = inv * m_at; // 4×3 = (T̂)ᵀ
    Ok((
        std::array::from_fn(|r| std::array::from_fn(|c| t[(c, r)])),
        smallest,
    ))
}

/// One sentence per axis held only one way up: its bias rests on the other faces being level.
fn single_sided_axes(set: &FaceSet) -> Vec<String> {
    (0..3)
        .filter_map(|a| {
            let (up, down) = (set.counts[2 * a], set.counts[2 * a + 1]);
            let (have, lack) = match (up, down) {
                (0, n) if n > 0 => (format!("{}-", AXES[a]), format!("{}+", AXES[a])),
                (n, 0) if n > 0 => (format!("{}+", AXES[a]), format!("{}-", AXES[a])),
                _ => return None,
            };
            let times = up.max(down);
            let held = if times > 1 {
                format!("; {have} appears {times} times")
            } else {
                String::new()
            };
            Some(format!(
                "{ax}'s bias and scale cannot be separated by its own faces: no face with {lack} \
                 up{held}; its bias is taken from the other faces' {ax} readings at 0 g, which \
                 assumes they sat level (1° of tilt moves it by 17 mg): add the face {lack}",
                ax = AXES[a]
            ))
        })
        .collect()
}

/// A face fit's report (`protocol.face_fit` in the JSON).
#[derive(Debug, Clone, Serialize)]
pub struct FaceFitReport {
    /// `six-position` or `faces`.
    pub method: &'static str,
    /// `T̂ = [D | b]`, 3×4.
    pub t_hat: [[f64; 4]; 3],
    /// The faces' averaged means, by face label.
    pub face_means: Vec<(&'static str, [f64; 3])>,
    /// Residual of each face `M − T̂·Â`, raw units, by face label.
    pub face_residuals: Vec<(&'static str, [f64; 3])>,
    /// What could not be identified.
    pub not_identified: Vec<String>,
    /// Each face's `‖K(m − b)‖ − 1` after calibration, mg, by face label.
    pub face_norm_error_mg: Vec<(&'static str, f64)>,
    /// The seed's least-squares `b` (mean of the faces); the calibration's bias takes each
    /// axis held both ways from its own pair instead (level-insensitive).
    pub seed_bias: [f64; 3],
}

impl FaceFit {
    /// The report of this fit.
    pub fn report(&self) -> FaceFitReport {
        let residual = |p: &Pose, m: &[f64; 3]| -> [f64; 3] {
            let d = p.direction().map(f64::from);
            std::array::from_fn(|r| {
                let t = &self.t_hat[r];
                m[r] - (t[0] * d[0] + t[1] * d[1] + t[2] * d[2] + t[3])
            })
        };
        FaceFitReport {
            method: self.method,
            t_hat: self.t_hat,
            face_means: self.faces.iter().map(|(p, m)| (p.label(), *m)).collect(),
            face_residuals: self
                .faces
                .iter()
                .map(|(p, m)| (p.label(), residual(p, m)))
                .collect(),
            not_identified: self.not_identified.clone(),
            face_norm_error_mg: self
                .faces
                .iter()
                .map(|(p, m)| {
                    let a = self.calibration.correct_linear(m.map(|v| v as f32));
                    let n = f64::from((a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt());
                    (p.label(), 1000.0 * (n - 1.0))
                })
                .collect(),
            seed_bias: self.seed_bias,
        }
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops mirror the matrix notation
mod tests {
    use super::super::faces::{face_set, window_face};
    use super::*;

    /// A sensor with a known `D` and `b`; the faces' means are `D·e + b` exactly.
    fn truth() -> ([[f64; 3]; 3], [f64; 3]) {
        (
            [
                [16100.0, 120.0, -80.0],
                [-60.0, 16550.0, 140.0],
                [90.0, -30.0, 16300.0],
            ],
            [420.0, -310.0, 650.0],
        )
    }

    fn mean_of(pose: Pose) -> FaceMean {
        let (d, b) = truth();
        let e = pose.direction().map(f64::from);
        FaceMean {
            pose,
            mean: std::array::from_fn(|r| (0..3).map(|c| d[r][c] * e[c]).sum::<f64>() + b[r]),
            samples: Some(100),
        }
    }

    fn fit_of(poses: &[Pose]) -> Result<FaceFit, FaceFitError> {
        let means: Vec<FaceMean> = poses.iter().map(|p| mean_of(*p)).collect();
        let faces: Vec<_> = means
            .iter()
            .map(|m| window_face(m.mean, [0.0; 3]))
            .collect();
        fit_faces(&means, &face_set(&faces))
    }

    fn assert_truth(fit: &FaceFit, tol: f64) {
        let (d, b) = truth();
        for r in 0..3 {
            for c in 0..3 {
                assert!(
                    (fit.t_hat[r][c] - d[r][c]).abs() < tol,
                    "D[{r}][{c}] {fit:?}"
                );
            }
            assert!((fit.t_hat[r][3] - b[r]).abs() < tol, "b[{r}]");
        }
    }

    #[test]
    fn six_faces_give_the_truth_through_the_core() {
        let fit = fit_of(&Pose::ALL).unwrap();
        assert_eq!(fit.method, "six-position");
        assert!(fit.not_identified.is_empty());
        assert_truth(&fit, 0.01);
    }

    #[test]
    fn five_faces_give_the_truth_and_name_the_single_sided_axis() {
        use Pose::*;
        let fit = fit_of(&[ZNeg, ZNeg, XPos, XNeg, YPos, YNeg]).unwrap();
        assert_eq!(fit.method, "faces");
        assert_truth(&fit, 1e-6);
        assert_eq!(fit.not_identified.len(), 1);
        let msg = &fit.not_identified[0];
        assert!(msg.starts_with("z's bias and scale"), "{msg}");
        assert!(
            msg.contains("no face with z+ up; z- appears 2 times"),
            "{msg}"
        );
    }

    #[test]
    fn planar_and_too_few_faces_are_refused_with_the_face_to_add() {
        use Pose::*;
        let e = fit_of(&[XPos, XNeg, YPos, YNeg]).unwrap_err();
        assert_eq!(
            e,
            FaceFitError::Plane {
                faces: "x+ x- y+ y-".into(),
                axis: "z"
            }
        );
        assert!(matches!(
            fit_of(&[XPos, YPos, ZPos]),
            Err(FaceFitError::TooFew { n: 3, .. })
        ));
    }
}

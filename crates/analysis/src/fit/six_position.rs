//! The seed's six-position test from a labelled recording.
//!
//! The file has a `pose` column with labels `x+ x- y+ y- z+ z-` and the three axes. Each pose
//! is either one row (an already averaged mean, as in the seed's worked example) or a block of
//! consecutive raw samples, averaged here with the core's Welford mean or its Kalman observer
//! for a constant. A label that appears in two separate blocks is a duplicate pose.

use crate::error::six_position::SixPositionError;
use crate::input::recording::Recording;
use serde::Serialize;
use wiical_core::estimators::{ConstantKalman3, Welford3};
use wiical_core::six_position::{self, Pose, SixPositionFit};

type Result<T, E = SixPositionError> = std::result::Result<T, E>;

/// How a block of samples of one pose is reduced to its mean.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PoseEstimator {
    /// Arithmetic mean (Welford).
    Mean,
    /// The seed's Kalman observer for a constant, 3-vector form with diagonal P₀ and R
    /// (R from the block's own sample variance, P₀ large).
    Kalman,
}

/// JSON report (keys `t_hat`, `d_inv`, `bias`, `residual` are the CLI contract).
#[derive(Debug, Clone, Serialize)]
pub struct SixPositionReport {
    /// T̂ = [D | b], 3×4.
    pub t_hat: [[f32; 4]; 3],
    /// D⁻¹, 3×3 (the seed's printed "D").
    pub d_inv: [[f32; 3]; 3],
    /// Bias b.
    pub bias: [f32; 3],
    /// Residual M − T̂Â, 3 rows × 6 poses (x+, x−, y+, y−, z+, z−).
    pub residual: [[f32; 6]; 3],
    /// D = gLT.
    pub d: [[f32; 3]; 3],
    /// Pose means used (M's columns), by pose in the order above.
    pub pose_means: [[f32; 3]; 6],
    /// Samples per pose.
    pub samples_per_pose: [u32; 6],
}

impl SixPositionReport {
    /// Builds the report from the core's result.
    pub fn new(fit: &SixPositionFit, means: [[f32; 3]; 6], counts: [u32; 6]) -> Self {
        Self {
            t_hat: fit.t_hat,
            d_inv: fit.d_inv,
            bias: fit.bias,
            residual: fit.residual,
            d: fit.d,
            pose_means: means,
            samples_per_pose: counts,
        }
    }
}

/// Groups the labelled rows into pose blocks and returns the six means.
pub fn pose_means(rec: &Recording, est: PoseEstimator) -> Result<([[f32; 3]; 6], [u32; 6])> {
    let labels = rec.labels.as_ref().ok_or(SixPositionError::NoPoseColumn)?;
    let mut blocks: Vec<(Pose, usize, usize)> = Vec::new();
    for (i, l) in labels.iter().enumerate() {
        let pose = Pose::from_label(l).ok_or_else(|| SixPositionError::UnknownPose {
            row: i + 1,
            label: l.clone(),
        })?;
        match blocks.last_mut() {
            Some((p, _, end)) if *p == pose => *end = i + 1,
            _ => {
                if let Some((_, s, _)) = blocks.iter().find(|(p, _, _)| *p == pose) {
                    return Err(SixPositionError::DuplicatePose {
                        pose,
                        row: i + 1,
                        first: s + 1,
                    });
                }
                blocks.push((pose, i, i + 1));
            }
        }
    }
    let mut means = [[0.0f32; 3]; 6];
    let mut counts = [0u32; 6];
    for pose in Pose::ALL {
        let (_, s, e) = blocks
            .iter()
            .find(|(p, _, _)| *p == pose)
            .ok_or(SixPositionError::MissingPose(pose))?;
        let samples: Vec<[f32; 3]> = rec.xyz[*s..*e]
            .iter()
            .map(|v| [v[0] as f32, v[1] as f32, v[2] as f32])
            .collect();
        means[pose as usize] = reduce(&samples, est)?;
        counts[pose as usize] = samples.len() as u32;
    }
    Ok((means, counts))
}

/// Plausibility of the six poses before they are solved: each axis's blocks with it
/// up and down must differ by much more than their noise (else they are not the opposite
/// orientations they are labelled as: 10 standard errors; poses given as one averaged row have
/// no noise to compare with), and it must read higher up than down (else the ± labels are
/// swapped, which would give a negative scale).
pub(crate) fn check_poses(rec: &Recording, means: &[[f32; 3]; 6]) -> Result<()> {
    let labels = rec.labels.as_ref().ok_or(SixPositionError::NoPoseColumn)?;
    // Per pose and axis: n, Σx, Σx².
    let mut acc = [[(0.0f64, 0.0f64, 0.0f64); 3]; 6];
    for (l, v) in labels.iter().zip(&rec.xyz) {
        if let Some(p) = Pose::from_label(l) {
            for (e, &va) in acc[p as usize].iter_mut().zip(v) {
                *e = (e.0 + 1.0, e.1 + va, e.2 + va * va);
            }
        }
    }
    let var_of_mean = |(n, s, q): (f64, f64, f64)| {
        if n < 2.0 {
            f64::NAN
        } else {
            ((q - s * s / n) / (n - 1.0)).max(0.0) / n
        }
    };
    for a in 0..3 {
        let (up, down) = (f64::from(means[2 * a][a]), f64::from(means[2 * a + 1][a]));
        let se = (var_of_mean(acc[2 * a][a]) + var_of_mean(acc[2 * a + 1][a])).sqrt();
        let same = (up - down).abs() <= 16.0 * f64::EPSILON * up.abs().max(1.0);
        if same || (se.is_finite() && (up - down).abs() < 10.0 * se.max(f64::MIN_POSITIVE)) {
            return Err(SixPositionError::SixPoseNotSeparated {
                axis: a,
                difference: up - down,
                standard_error: if se.is_finite() { se } else { 0.0 },
            });
        }
        if up - down <= 0.0 {
            return Err(SixPositionError::SixPoseSwapped { axis: a, up, down });
        }
    }
    Ok(())
}

fn reduce(samples: &[[f32; 3]], est: PoseEstimator) -> Result<[f32; 3]> {
    let mut w = Welford3::new();
    for s in samples {
        w.push(*s).map_err(SixPositionError::PoseBlock)?;
    }
    let mean = w.mean().map_err(SixPositionError::PoseBlock)?;
    if est == PoseEstimator::Mean || samples.len() < 2 {
        return Ok([mean.x, mean.y, mean.z]);
    }
    // Kalman observer: x₀ = first sample, P₀ large, R = sample variance (floored at the
    // quantisation variance 1/12 so that a constant block still has a positive R).
    let var = w.variance().map_err(SixPositionError::PoseBlock)?;
    let r = [var.x, var.y, var.z].map(|v| v.max(1.0 / 12.0));
    let mut k =
        ConstantKalman3::new(samples[0], [1e6; 3], r).map_err(SixPositionError::PoseBlock)?;
    for s in samples {
        k.update(*s).map_err(SixPositionError::PoseBlock)?;
    }
    let x = k.estimate();
    Ok([x.x, x.y, x.z])
}

/// Runs the six-position test on a labelled recording.
pub fn run(rec: &Recording, est: PoseEstimator) -> Result<SixPositionReport> {
    let (means, counts) = pose_means(rec, est)?;
    check_poses(rec, &means)?;
    let fit = solve_poses(&means)?;
    Ok(SixPositionReport::new(&fit, means, counts))
}

/// The core's six-position solve, its errors told in terms of poses.
pub fn solve_poses(means: &[[f32; 3]; 6]) -> Result<SixPositionFit> {
    six_position::solve(means).map_err(|e| match e {
        wiical_core::Error::DegenerateGeometry => SixPositionError::PosesNotTurned,
        other => SixPositionError::SixPositionFailed(other),
    })
}

#[cfg(test)]
mod plausibility {
    use super::*;

    /// The seed's six poses (its own numbers) as a pose table.
    const SEED: &str = "pose,x,y,z\nx+,153.329,127.181,129.991\nx-,102.978,127.989,129.991\ny+,128.072,153.248,129.586\ny-,127.989,101.200,128.992\nz+,127.989,127.989,154.179\nz-,127.989,127.183,105.012\n";

    #[test]
    fn swapped_labels_are_refused_naming_the_axis() {
        assert!(run(
            &crate::parse(SEED, &Default::default()).unwrap(),
            PoseEstimator::Mean
        )
        .is_ok());
        let swapped = SEED
            .replace("x+,", "X,")
            .replace("x-,", "x+,")
            .replace("X,", "x-,");
        let rec = crate::parse(&swapped, &Default::default()).unwrap();
        let e = run(&rec, PoseEstimator::Mean).unwrap_err();
        assert!(
            matches!(e, SixPositionError::SixPoseSwapped { axis: 0, .. }),
            "{e:?}"
        );
        assert!(e.to_string().contains("labels are swapped"), "{e}");
    }

    #[test]
    fn blocks_of_pure_noise_are_refused() {
        // Six blocks of 50 samples of the same still orientation with ±1 count of noise.
        let mut text = String::from("pose,x,y,z\n");
        for pose in ["x+", "x-", "y+", "y-", "z+", "z-"] {
            for i in 0..50 {
                let d = f64::from(i * 37 % 7 - 3) / 3.0;
                text += &format!("{pose},{},{},{}\n", 512.0 + d, 512.0 - d, 700.0 + d);
            }
        }
        let rec = crate::parse(&text, &Default::default()).unwrap();
        let e = run(&rec, PoseEstimator::Mean).unwrap_err();
        assert!(
            matches!(e, SixPositionError::SixPoseNotSeparated { .. }),
            "{e:?}"
        );
        assert!(e.to_string().contains("not opposite orientations"), "{e}");
    }
}

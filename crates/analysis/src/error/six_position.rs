//! The six-position method's error (`wiical six-position`, and `analyze` on a file with a
//! `pose` column): why the labelled pose blocks give no calibration. Shared by the fit
//! (`fit::six_position`) and the search's contrasts (`search::six_contrasts`). Joined into
//! [`super::Error`] as `Error::SixPosition`; re-exported as `fit::SixPositionError`.

use wiical_core::six_position::Pose;

/// Why a six-position table could not be solved: the labels (missing, unknown, a pose twice
/// or not at all), the blocks (swapped ±, not turned, refused by the core) or the solve.
/// Joined into [`super::Error::SixPosition`].
#[derive(Debug, thiserror::Error)]
pub enum SixPositionError {
    /// No `pose` column.
    #[error("the file needs a 'pose' column with labels x+ x- y+ y- z+ z-")]
    NoPoseColumn,
    /// A label that is not a pose.
    #[error("row {row}: unknown pose label '{label}' (expected x+ x- y+ y- z+ z-)")]
    UnknownPose {
        /// 1-based row.
        row: usize,
        /// The label.
        label: String,
    },
    /// A pose in two separate blocks.
    #[error("{}: pose '{}' appears again at row {row} after other poses (first block starts at row {first})", wiical_core::Error::DuplicatePose, pose.label())]
    DuplicatePose {
        /// The pose.
        pose: Pose,
        /// 1-based row of the second block.
        row: usize,
        /// 1-based first row of the first block.
        first: usize,
    },
    /// A pose without rows.
    #[error("{}: no rows for pose '{}'", wiical_core::Error::MissingPose, .0.label())]
    MissingPose(Pose),
    /// The core refused a pose block.
    #[error("{0}")]
    PoseBlock(wiical_core::Error),
    /// The ± poses coincide.
    #[error("the ± poses do not differ enough to determine the scale (was the sensor turned between poses?)")]
    PosesNotTurned,
    /// The core's six-position solve failed otherwise.
    #[error("six-position solve failed: {0}")]
    SixPositionFailed(wiical_core::Error),
    /// The f64 six-position solve is singular.
    #[error("six-position solve is singular")]
    SixPositionSingular,
    /// `D` has no inverse.
    #[error("D is singular")]
    SingularD,
    /// A six-position axis that reads lower with it up than down.
    #[error("axis {} reads {up:.2} with it up and {down:.2} with it down (pose {}+ and {}−): the ± labels are swapped, which would make its scale negative; relabel the poses", ["x","y","z"][*axis], ["x","y","z"][*axis], ["x","y","z"][*axis])]
    SixPoseSwapped {
        /// Axis 0..3.
        axis: usize,
        /// Mean with the axis up.
        up: f64,
        /// Mean with the axis down.
        down: f64,
    },
    /// A six-position axis whose up and down blocks differ by no more than their noise.
    #[error("the {}+ and {}− poses differ by {difference:.3} on that axis, within the noise of their blocks (standard error {standard_error:.3}): they are not opposite orientations; record each pose with the axis straight up and straight down", ["x","y","z"][*axis], ["x","y","z"][*axis])]
    SixPoseNotSeparated {
        /// Axis 0..3.
        axis: usize,
        /// Mean up − mean down.
        difference: f64,
        /// Its standard error.
        standard_error: f64,
    },
    /// The six-position calibration written to the report does not map the pose means back
    /// to ±1 g (a self-check after the fit: a bug, not bad input).
    #[error("internal: six-position calibration does not reproduce the poses")]
    SixPositionNotReproduced,
}

//! The one error type of the core. Every fallible function returns [`Error`]; nothing in the
//! core panics on data (NaN, infinities, degenerate geometry, too few samples).

use core::fmt;

/// Why a core computation could not produce a result.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// An input value was NaN or infinite.
    NonFinite,
    /// Not enough samples were accumulated for the estimate.
    TooFewSamples {
        /// Minimum number needed.
        needed: u32,
        /// Number supplied.
        got: u32,
    },
    /// Not enough distinct static poses for the model.
    TooFewPoses {
        /// Minimum number needed.
        needed: u32,
        /// Number supplied.
        got: u32,
    },
    /// A pose label was given twice (six-position test).
    DuplicatePose,
    /// A required pose label is missing (six-position test).
    MissingPose,
    /// The poses do not span 3-D well enough (e.g. all in one plane) to identify the model.
    DegenerateGeometry,
    /// A matrix that must be invertible / positive definite is not (numerically).
    Singular,
    /// The iterative solver did not converge within its iteration budget.
    NotConverged,
    /// The solver's parameters ran off to infinity: the data are fitted ever better by an
    /// ever larger model (for a multi-position fit, an ever larger sphere: the poses cover too
    /// few orientations, or the windows are not static), so there is no finite solution.
    Diverged,
    /// A sample sits at the ADC rail, so it does not measure the true value.
    Saturated,
    /// No axis is close enough to vertical for an offset-only accelerometer calibration.
    NoVerticalAxis,
    /// A configuration parameter is out of its valid range.
    InvalidParameter,
    /// A fixed-capacity buffer is full.
    CapacityExceeded,
    /// The fitted surface is not an ellipsoid (e.g. a hyperboloid from bad data).
    NotAnEllipsoid,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::NonFinite => f.write_str("input contains NaN or infinite values"),
            Error::TooFewSamples { needed, got } => {
                write!(f, "too few samples: need at least {needed}, got {got}")
            }
            Error::TooFewPoses { needed, got } => {
                write!(f, "too few static poses: need at least {needed}, got {got}")
            }
            Error::DuplicatePose => f.write_str("a pose is given more than once"),
            Error::MissingPose => f.write_str("a required pose is missing"),
            Error::DegenerateGeometry => f.write_str(
                "poses are badly spread (e.g. all in one plane): the model cannot be identified",
            ),
            Error::Singular => f.write_str("matrix is singular or not positive definite"),
            Error::NotConverged => f.write_str("solver did not converge"),
            Error::Diverged => f.write_str(
                "no finite solution: the fit runs off to an ever larger sphere (the poses cover \
                 too few orientations, or the windows are not static)",
            ),
            Error::Saturated => f.write_str("sample is saturated at the sensor's range limit"),
            Error::NoVerticalAxis => {
                f.write_str("no sensor axis is close to vertical (needed for offset calibration)")
            }
            Error::InvalidParameter => f.write_str("invalid parameter"),
            Error::CapacityExceeded => f.write_str("fixed-capacity buffer is full"),
            Error::NotAnEllipsoid => f.write_str("fitted quadric is not an ellipsoid"),
        }
    }
}

impl core::error::Error for Error {}

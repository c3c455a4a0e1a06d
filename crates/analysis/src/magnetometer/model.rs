//! Which surface a magnetometer fit uses: sphere, axis-aligned or rotated ellipsoid.

use std::fmt;
use std::str::FromStr;
use wiical_core::magfit::{AxisEllipsoidFit, EllipsoidFit, SphereFit};

/// Which surface to fit to the raw magnetometer samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MagModel {
    /// Sphere: hard iron only (`W = I`), 4 parameters.
    Sphere,
    /// Axis-aligned ellipsoid: hard iron + per-axis scale (diagonal `W`), 6 parameters.
    Axis,
    /// Rotated ellipsoid: hard iron + full soft iron (symmetric `W`), 9 parameters.
    Ellipsoid,
}

impl MagModel {
    /// All models, simplest first.
    pub const ALL: [MagModel; 3] = [MagModel::Sphere, MagModel::Axis, MagModel::Ellipsoid];

    /// The command-line / JSON name: `"sphere"`, `"axis"` or `"ellipsoid"`.
    pub fn name(self) -> &'static str {
        match self {
            MagModel::Sphere => "sphere",
            MagModel::Axis => "axis",
            MagModel::Ellipsoid => "ellipsoid",
        }
    }

    /// Number of free parameters, which is also the minimum number of samples.
    pub fn params(self) -> u32 {
        match self {
            MagModel::Sphere => SphereFit::PARAMS,
            MagModel::Axis => AxisEllipsoidFit::PARAMS,
            MagModel::Ellipsoid => EllipsoidFit::PARAMS,
        }
    }
}

impl fmt::Display for MagModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for MagModel {
    /// A readable message naming the accepted values (usable by clap's `value_parser`).
    type Err = String;

    /// Parses `sphere`, `axis` or `ellipsoid` (case-insensitive, surrounding blanks ignored).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim();
        MagModel::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(t))
            .ok_or_else(|| format!("unknown model '{s}' (expected sphere, axis or ellipsoid)"))
    }
}

//! The effect names of the JSON contract, in one table: the analysis's candidates
//! ([`crate::search::candidate::Candidate`]), the model's parameter blocks ([`crate::fit::model::Term`]), the
//! simulator's effects (`wiical_sim::SimEffect`), the CLI's flags and messages all take
//! them from here, so that a name cannot differ between the one that puts an effect into a
//! simulation and the one that reports it found.

/// Per-axis quadratic nonlinearity.
pub const QUADRATIC: &str = "quadratic";
/// Per-axis cubic nonlinearity.
pub const CUBIC: &str = "cubic";
/// Bias linear in time.
pub const BIAS_DRIFT: &str = "bias-drift";
/// Bias linear in temperature.
pub const TEMPERATURE: &str = "temperature";
/// Scale linear in temperature.
pub const TEMPERATURE_SCALE: &str = "temperature-scale";
/// Windows that were not still (rejected, not a model term).
pub const OUTLIERS: &str = "outliers";
/// Bias curving in time (a diagnostic the calibration cannot store).
pub const BIAS_DRIFT_CURVED: &str = "bias-drift-curved";
/// The simulator's "no effect".
pub const NONE: &str = "none";
/// The sensor axes a single-axis effect is named by (`quadratic (z)`): x, y, z of the fitted
/// frame (x kept, y in the x–y plane), the frame the simulator's truth uses too.
pub const AXES: [&str; 3] = ["x", "y", "z"];

// The open basis: families selected term by term after the candidates, each
// term named by its family and what it acts on, e.g. `cross-quadratic (z: x·y)` (output axis z,
// monomial u_x·u_y), `scale-drift (x)`, `thermal-lag (y)`. The simulator's effect of the same
// family carries the same name.

/// Orientation-dependent error of degree 2 other than the per-axis square: `a_i += c·u_j·u_k`.
pub const CROSS_QUADRATIC: &str = "cross-quadratic";
/// Orientation-dependent error of degree 3 other than the per-axis cube: `a_i += c·u_j·u_k·u_l`.
pub const CROSS_CUBIC: &str = "cross-cubic";
/// Scale linear in time (a sensitivity that changes during the recording).
pub const SCALE_DRIFT: &str = "scale-drift";
/// Scale quadratic in time.
pub const SCALE_DRIFT_CURVED: &str = "scale-drift-curved";
/// Bias quadratic in temperature (about the reference temperature).
pub const TEMPERATURE_SQUARED: &str = "temperature-squared";
/// Bias cubic in temperature (about the reference temperature).
pub const TEMPERATURE_CUBED: &str = "temperature-cubed";
/// Scale quadratic in temperature.
pub const TEMPERATURE_SCALE_SQUARED: &str = "temperature-scale-squared";
/// Scale cubic in temperature.
pub const TEMPERATURE_SCALE_CUBED: &str = "temperature-scale-cubed";
/// Bias linear in the temperature seen through a first-order lag of fitted time constant.
pub const THERMAL_LAG: &str = "thermal-lag";
/// A step of one axis's bias between two windows (a knock), searched before the candidates
/// (`search::bias_step`).
pub const BIAS_STEP: &str = "bias-step";
/// Bias linear in the rate of change of the temperature, dT/dt.
pub const TEMPERATURE_RATE: &str = "temperature-rate";

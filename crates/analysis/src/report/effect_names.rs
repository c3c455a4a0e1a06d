//! The effect names of the JSON contract, in one table: the analysis's candidates
//! ([`crate::search::candidate::Candidate`]), the model's parameter blocks ([`crate::fit::model::Term`]), the
//! simulator's effects (`crate::simulate::SimEffect`), the CLI's flags and messages all take
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

//! One row of the report's `residual_correlates` (part of the JSON contract of `wiical
//! analyze`): how the final residual correlates with one regressor. Computed by
//! [`crate::search::correlates`]; renaming a field breaks users' scripts.

use serde::Serialize;

/// The residual's correlation with one regressor.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResidualCorrelate {
    /// `time`, `temperature`, `g_x` … `g_z`, `g_x^3` …, `g_x^4` …, `g_x*g_y*g_z`, `time*g_x` …,
    /// `temperature*g_x` …, `temperature*g_x^2` ….
    pub regressor: String,
    /// Pearson correlation of the final per-window residual (‖a‖ − 1) with the regressor.
    pub r: f64,
    /// Two-sided p-value of r (Student's t on `dof`), not corrected.
    pub p_value: f64,
    /// `p_value` × the number of regressors tried (Bonferroni), at most 1.
    pub p_bonferroni: f64,
    /// The analysis' family-wise level α the Bonferroni test is held to.
    pub alpha: f64,
    /// True when `p_bonferroni` < `alpha`.
    pub significant: bool,
    /// Least-squares slope of the residual on the regressor, in `slope_unit`.
    pub slope: f64,
    /// `mg/min`, `mg/°C`, `mg/g`, `mg/g^3`, `mg/g^4`, `mg/(g·min)`, `mg/(g·°C)` or
    /// `mg/(g²·°C)`.
    pub slope_unit: &'static str,
    /// Windows the correlation is over.
    pub windows: usize,
    /// Degrees of freedom of the t-test: windows − rank of the model's span (with a constant) − 1.
    pub dof: usize,
}

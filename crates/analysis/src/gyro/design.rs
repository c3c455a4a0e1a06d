//! The gyro's static-window regression shared by the candidate search (`effects`)
//! and the detection limits (`limits`): the candidates, the window data they are
//! fitted to, and the design matrix (a constant for the bias, then each candidate's
//! regressors).

use nalgebra::DMatrix;

/// One candidate: its name, the unit of its coefficients, and its regressors per window.
#[derive(Debug, Clone)]
pub struct Candidate {
    /// `g-sensitivity`, `bias-drift`, `temperature`.
    pub name: &'static str,
    /// Unit of a coefficient (°/s per regressor unit).
    pub unit: &'static str,
    /// Regressors per window (one row per window, one column per regressor).
    pub columns: Vec<Vec<f64>>,
    /// What pattern it looks for, for the evidence line.
    pub pattern: &'static str,
}

/// What the window regressions are fitted to.
#[derive(Debug, Clone)]
pub struct WindowData {
    /// Gyro mean per window through the calibration, °/s.
    pub rate_dps: Vec<[f64; 3]>,
    /// Variance of each of those means from the gyro's own noise, (°/s)².
    pub mean_var: Vec<[f64; 3]>,
}

/// The design matrix: a constant (the bias), then the regressors of `base` and `extra`.
pub fn design(base: &[&Candidate], extra: Option<&Candidate>, n: usize) -> DMatrix<f64> {
    let k = k_total(base, extra);
    let cols: Vec<Vec<f64>> = (0..k).map(|j| flat_column(base, extra, j)).collect();
    DMatrix::from_fn(n, 1 + k, |r, c| if c == 0 { 1.0 } else { cols[c - 1][r] })
}

/// Regressor columns in total.
fn k_total(base: &[&Candidate], extra: Option<&Candidate>) -> usize {
    base.iter()
        .chain(extra.iter())
        .map(|c| c.columns.first().map_or(0, Vec::len))
        .sum()
}

/// Column `j` of the regressors (windows down), counting across the candidates in order.
fn flat_column(base: &[&Candidate], extra: Option<&Candidate>, mut j: usize) -> Vec<f64> {
    for c in base.iter().chain(extra.iter()) {
        let k = c.columns.first().map_or(0, Vec::len);
        if j < k {
            return c.columns.iter().map(|row| row[j]).collect();
        }
        j -= k;
    }
    Vec::new()
}

/// Regressor columns of one candidate.
pub fn width(c: &Candidate) -> usize {
    c.columns.first().map_or(0, Vec::len)
}

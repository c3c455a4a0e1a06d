//! Samples handed over in memory (the Python package's numpy arrays) made a [`Recording`]
//! through the checks the loader makes on a file's rows: every value finite, readings within
//! ±10¹², not all numerically zero, times in order, columns of one length. A file's error
//! names its line and column; these name the argument, its row (from 0, as the caller indexes
//! it) and column, so that no door accepts what another refuses.

// The loader's own bounds, so that arrays and files share one limit.
use crate::input::bounded::{MAX_READING, MIN_FULL_SCALE};
use crate::input::recording::Recording;

/// Why arrays cannot be a recording.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ArrayError {
    /// Not n rows of three values.
    #[error("{arg} has shape {shape}: give an array of shape (n, 3) (x, y, z per row)")]
    Shape {
        /// The argument.
        arg: &'static str,
        /// Its shape as the caller writes it, e.g. `(100, 4)`.
        shape: String,
    },
    /// No rows.
    #[error("{arg} has no rows: nothing to analyse")]
    Empty {
        /// The argument.
        arg: &'static str,
    },
    /// NaN or ±inf.
    #[error("{arg}, row {row}, column {column}: value {value} is not finite")]
    NotFinite {
        /// The argument.
        arg: &'static str,
        /// Row, from 0.
        row: usize,
        /// Column: x, y, z, or the argument's own name for a 1-D array.
        column: &'static str,
        /// The value.
        value: f64,
    },
    /// Beyond ±10¹².
    #[error("{arg}, row {row}, column {column}: the reading {value:e} is beyond ±1e12, which no sensor reports; the value is corrupt or in the wrong unit")]
    OutOfRange {
        /// The argument.
        arg: &'static str,
        /// Row, from 0.
        row: usize,
        /// Column.
        column: &'static str,
        /// The value.
        value: f64,
    },
    /// Every reading numerically zero.
    #[error("{arg}: every reading is smaller than 1e-9 in magnitude (largest {largest:.2e}): the recording carries no measurable signal; check its unit or scale")]
    TooSmall {
        /// The argument.
        arg: &'static str,
        /// The largest |value|.
        largest: f64,
    },
    /// A time earlier than the one before.
    #[error(
        "{arg}, row {row}: time goes from {previous} back to {value}; rows must be in time order"
    )]
    TimeGoesBack {
        /// The argument.
        arg: &'static str,
        /// Row, from 0.
        row: usize,
        /// The time before.
        previous: f64,
        /// The time at `row`.
        value: f64,
    },
    /// A per-sample column of another length than the samples.
    #[error("{arg} has {len} values but there are {rows} samples")]
    Length {
        /// The argument.
        arg: &'static str,
        /// Its length.
        len: usize,
        /// Rows of the samples.
        rows: usize,
    },
}

const XYZ: [&str; 3] = ["x", "y", "z"];

/// Checks one value of `arg` at `row`, `column`.
fn reading(arg: &'static str, row: usize, column: &'static str, v: f64) -> Result<(), ArrayError> {
    if !v.is_finite() {
        return Err(ArrayError::NotFinite {
            arg,
            row,
            column,
            value: v,
        });
    }
    if v.abs() > MAX_READING {
        return Err(ArrayError::OutOfRange {
            arg,
            row,
            column,
            value: v,
        });
    }
    Ok(())
}

/// Samples `xyz` (argument `arg`) checked as the loader checks a file's axis columns.
pub fn check_samples(arg: &'static str, xyz: &[[f64; 3]]) -> Result<(), ArrayError> {
    if xyz.is_empty() {
        return Err(ArrayError::Empty { arg });
    }
    let mut largest = 0.0f64;
    for (row, r) in xyz.iter().enumerate() {
        for (v, column) in r.iter().zip(XYZ) {
            reading(arg, row, column, *v)?;
            largest = largest.max(v.abs());
        }
    }
    if largest < MIN_FULL_SCALE {
        return Err(ArrayError::TooSmall { arg, largest });
    }
    Ok(())
}

/// Times `t` (s) of `rows` samples: finite, as many, never going back (a repeat is accepted:
/// coarse time stamps, as in a file).
pub fn check_times(arg: &'static str, t: &[f64], rows: usize) -> Result<(), ArrayError> {
    check_length(arg, t.len(), rows)?;
    let mut previous: Option<f64> = None;
    for (row, &v) in t.iter().enumerate() {
        if !v.is_finite() {
            return Err(ArrayError::NotFinite {
                arg,
                row,
                column: arg,
                value: v,
            });
        }
        if let Some(p) = previous.filter(|p| v < *p) {
            return Err(ArrayError::TimeGoesBack {
                arg,
                row,
                previous: p,
                value: v,
            });
        }
        previous = Some(v);
    }
    Ok(())
}

/// A per-sample reading column (temperatures, °C) of `rows` samples.
pub fn check_column(arg: &'static str, v: &[f64], rows: usize) -> Result<(), ArrayError> {
    check_length(arg, v.len(), rows)?;
    v.iter()
        .enumerate()
        .try_for_each(|(row, &x)| reading(arg, row, arg, x))
}

fn check_length(arg: &'static str, len: usize, rows: usize) -> Result<(), ArrayError> {
    if len == rows {
        Ok(())
    } else {
        Err(ArrayError::Length { arg, len, rows })
    }
}

/// A recording of `xyz` (argument `data`), times `t` and temperatures `temp`, after the
/// checks above; its axis columns are named x, y, z.
pub fn recording(
    xyz: Vec<[f64; 3]>,
    t: Option<Vec<f64>>,
    temp: Option<Vec<f64>>,
) -> Result<Recording, ArrayError> {
    check_samples("data", &xyz)?;
    if let Some(t) = &t {
        check_times("t", t, xyz.len())?;
    }
    if let Some(temp) = &temp {
        check_column("temp", temp, xyz.len())?;
    }
    Ok(Recording {
        t,
        temp,
        xyz,
        axis_columns: XYZ.map(String::from),
        ..Default::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(xyz: Vec<[f64; 3]>, t: Option<Vec<f64>>, temp: Option<Vec<f64>>) -> String {
        recording(xyz, t, temp).unwrap_err().to_string()
    }

    #[test]
    fn each_refusal_names_the_argument_row_and_column() {
        let ok = vec![[0.0, 0.0, 1.0]; 3];
        let mut nan = ok.clone();
        nan[1][2] = f64::NAN;
        assert_eq!(
            err(nan, None, None),
            "data, row 1, column z: value NaN is not finite"
        );
        let mut inf = ok.clone();
        inf[2][0] = f64::NEG_INFINITY;
        assert!(err(inf, None, None).starts_with("data, row 2, column x: value -inf"));
        let mut big = ok.clone();
        big[0][1] = 2e12;
        assert!(err(big, None, None).contains("beyond ±1e12"));
        assert!(err(vec![[0.0; 3]; 3], None, None).contains("smaller than 1e-9"));
        assert_eq!(
            err(ok.clone(), Some(vec![0.0, 0.2, 0.1]), None),
            "t, row 2: time goes from 0.2 back to 0.1; rows must be in time order"
        );
        assert_eq!(
            err(ok.clone(), Some(vec![0.0, 0.1]), None),
            "t has 2 values but there are 3 samples"
        );
        assert!(err(ok.clone(), None, Some(vec![20.0, f64::NAN, 20.0]))
            .starts_with("temp, row 1, column temp"));
        assert_eq!(
            err(vec![], None, None),
            "data has no rows: nothing to analyse"
        );
        // Repeated times are read, as in a file.
        let rec = recording(ok, Some(vec![0.0, 0.0, 0.01]), Some(vec![20.0; 3])).unwrap();
        assert_eq!(rec.len(), 3);
        assert_eq!(rec.axis_columns, ["x", "y", "z"]);
    }
}

//! A loaded recording and what can be inferred from it alone: the sample rate (from a time
//! column or metadata) and the input units (raw counts, g or m/s², from the window means).

use crate::input::timecheck::TimeSteps;

/// A loaded 3-axis recording. Values are kept in f64 exactly as read; conversion to the core's
/// f32 happens at the solver boundary.
#[derive(Debug, Clone, Default)]
pub struct Recording {
    /// Sample times in seconds, if the file has a time column.
    pub t: Option<Vec<f64>>,
    /// The three axis values of every sample (raw units).
    pub xyz: Vec<[f64; 3]>,
    /// Sensor temperature per sample (°C), if present.
    pub temp: Option<Vec<f64>>,
    /// Pose labels (six-position files), if present.
    pub labels: Option<Vec<String>>,
    /// Sample rate from metadata (`Fs,…`), if present.
    pub sample_rate_hz: Option<f64>,
    /// Names of the columns used for x, y, z (for messages).
    pub axis_columns: [String; 3],
    /// Rows skipped because all three selected axis fields were empty (e.g. `wiical capture`
    /// leaves the Nunchuk columns empty while the Nunchuk is unplugged).
    pub skipped_empty_rows: usize,
    /// Things about the file worth telling the user that do not stop the analysis (gaps in
    /// the time column, a time step that looks like milliseconds); see
    /// [`crate::input::timecheck::time_notes`].
    pub notes: Vec<String>,
    /// What the loader chose that the user should see but that is no warning (which axis
    /// triplet it took from a header naming several).
    pub info: Vec<String>,
}

impl Recording {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.xyz.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.xyz.is_empty()
    }

    /// Sample times: the time column, else `i / Fs`, else `i / default_rate_hz`.
    pub fn times(&self, default_rate_hz: f64) -> Vec<f64> {
        if let Some(t) = &self.t {
            return t.clone();
        }
        let fs = self.sample_rate_hz.unwrap_or(default_rate_hz);
        (0..self.len()).map(|i| i as f64 / fs).collect()
    }

    /// True when every axis value is an integer (raw ADC counts): the quantisation floor of
    /// 1/12 count² then applies to variances.
    pub fn is_integer(&self) -> bool {
        self.xyz.iter().all(|s| s.iter().all(|v| v.fract() == 0.0))
    }

    /// Estimated sample rate from metadata, else from the time column: one over the median
    /// step, or over the mean step when the timestamps come in bursts
    /// ([`crate::input::timecheck::TimeSteps::rate_hz`]).
    pub fn estimated_rate_hz(&self) -> Option<f64> {
        if let Some(fs) = self.sample_rate_hz {
            return Some(fs);
        }
        TimeSteps::of(self.t.as_ref()?).map(|s| s.rate_hz())
    }
}

/// Input units inferred from the data: integer values are raw counts; otherwise the median
/// norm of the static-window means says g (≈ 1) or m/s² (≈ 9.81); anything else is taken as
/// raw (an uncalibrated but already scaled sensor).
pub fn infer_units(integer: bool, median_window_norm: f64) -> &'static str {
    if integer {
        "raw"
    } else if (0.8..1.25).contains(&median_window_norm) {
        "g"
    } else if (7.8..12.3).contains(&median_window_norm) {
        "m/s^2"
    } else {
        "raw"
    }
}

//! A table whose rows are still windows already (GGIR's sphere data, the still epochs of a raw
//! file): the rows as the analysis's windows. Read from text by [`crate::input::window_table`], built
//! from raw files by [`crate::input::raw::epochs`].

use crate::detect::windows::{WindowStats, Windows};
use crate::input::recording::{infer_units, Recording};
use crate::report::contract::WindowInputInfo;
use crate::stats as st;

/// A window-mean table: the rows as a [`Recording`] (means as its samples, with time and
/// temperature) plus what the extra columns said.
#[derive(Debug, Clone)]
pub struct WindowTable {
    /// The means, times and temperatures as the loader reads any file.
    pub recording: Recording,
    /// Per-row standard deviations (x, y, z), when the file has them.
    pub sd: Option<Vec<[f64; 3]>>,
    /// Per-row sample counts, when the file has them.
    pub count: Option<Vec<usize>>,
    /// How it was read.
    pub info: WindowInputInfo,
}

impl WindowTable {
    /// The rows as the analysis's windows: mean; variance = SD² (NaN without SD columns);
    /// the count when given (else unknown); temperature; time = the file's time column (s),
    /// else the row index (rows taken as equally spaced, 1 s apart). Units are inferred from
    /// the median norm of the means, as for detected windows.
    pub fn to_windows(&self) -> Windows {
        let rec = &self.recording;
        let times: Vec<f64> = rec
            .t
            .clone()
            .unwrap_or_else(|| (0..rec.len()).map(|i| i as f64).collect());
        let t0 = times.first().copied().unwrap_or(0.0);
        let stats: Vec<WindowStats> = (0..rec.len())
            .map(|i| WindowStats {
                start: i,
                end: i + 1,
                mean: rec.xyz[i],
                var: self
                    .sd
                    .as_ref()
                    .map_or([f64::NAN; 3], |sd| sd[i].map(|s| s * s)),
                batch_var_of_mean: None,
                t_centre: times[i] - t0,
                temp: rec.temp.as_ref().map(|t| t[i]),
                count: self.count.as_ref().map(|c| c[i]),
            })
            .collect();
        let norms: Vec<f64> = rec
            .xyz
            .iter()
            .map(|m| (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt())
            .collect();
        // The "reference" noise of a table: the median within-window variance per axis.
        let reference_variance = std::array::from_fn(|a| match &self.sd {
            Some(sd) => st::median(&sd.iter().map(|s| s[a] * s[a]).collect::<Vec<_>>()) as f32,
            None => f32::NAN,
        });
        Windows {
            units: infer_units(rec.is_integer(), st::median(&norms)),
            stats,
            times,
            reference_variance,
        }
    }
}

//! A table whose rows are still windows already (GGIR's sphere data, the still epochs of a raw
//! file). Read from text by [`crate::input::window_means`], built from raw files by
//! [`crate::input::raw::epochs`]; its rows become the analysis's windows in
//! `detect::table`, in place of the detection.

use crate::input::recording::Recording;
use crate::report::contract::WindowInputInfo;

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

//! The simulation's output: the recording, its truth and every sample's true conditions; the
//! recording as CSV text and its truth as JSON, written next to it.

use crate::conditions::SampleConditions;
use crate::error::Result;
use crate::truth::Truth;
use std::path::{Path, PathBuf};
use wiical_analysis::Recording;
use wiical_io::write::write_file;

/// Where the truth of a recording written to `path` goes (`path` + `.truth.json`): the
/// engine's rule, which `wiical batch` reads to leave the truth files out of a folder.
pub use wiical_analysis::batch::truth_path;

/// A simulated recording and its truth.
#[derive(Debug, Clone)]
pub struct SimOutput {
    /// The recording, as `input::front_door::load` would return it.
    pub recording: Recording,
    /// The truth.
    pub truth: Truth,
    /// The true conditions of every sample (the truth's time and temperature terms depend on
    /// them, see [`Truth::calibration_at`]).
    pub conditions: Vec<SampleConditions>,
}

/// The recording as CSV text (`t,x,y,z[,temp]`), readable by
/// [`wiical_analysis::input::front_door::load`].
pub fn to_csv(rec: &Recording) -> String {
    let mut s = String::with_capacity(rec.len() * 24 + 32);
    s.push_str(if rec.temp.is_some() {
        "t,x,y,z,temp\n"
    } else {
        "t,x,y,z\n"
    });
    let times = rec.times(100.0);
    // Centiseconds when every time is one (100 Hz), else 10 µs (200, 400 Hz).
    let decimals = if times
        .iter()
        .all(|t| ((t * 100.0).round() - t * 100.0).abs() < 1e-6)
    {
        2
    } else {
        5
    };
    for (i, m) in rec.xyz.iter().enumerate() {
        use std::fmt::Write as _;
        let _ = write!(s, "{:.*},{},{},{}", decimals, times[i], m[0], m[1], m[2]);
        if let Some(tc) = &rec.temp {
            let _ = write!(s, ",{:.2}", tc[i]);
        }
        s.push('\n');
    }
    s
}

/// Writes the recording (CSV) and its truth (JSON, [`truth_path`]); returns the truth's path.
pub fn write(out: &SimOutput, path: &Path) -> Result<PathBuf> {
    write_file(path, to_csv(&out.recording).as_bytes())?;
    let tp = truth_path(path);
    let json = serde_json::to_string_pretty(&out.truth)? + "\n";
    write_file(&tp, json.as_bytes())?;
    Ok(tp)
}

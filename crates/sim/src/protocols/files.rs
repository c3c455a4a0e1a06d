//! A protocol simulation written: the samples as CSV (the truth's `columns`: `t` in seconds
//! when there is a clock, whole counts) and the truth as JSON next to it, each atomically.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::ProtocolSim;
use crate::error::Result;
use crate::files::truth_path;
use wiical_io::write::write_file;

/// The recording as CSV text: a header of the truth's columns (`t,ax,ay,az,gx,gy,gz`, no `t`
/// without a clock, `gx,gy,gz` for the turntable), then one row per sample, times to the
/// microsecond, counts as whole numbers.
pub fn protocol_csv(sim: &ProtocolSim) -> String {
    let n = sim.len();
    let mut s = String::with_capacity(n * 48 + 32);
    s.push_str(&sim.truth.columns.join(","));
    s.push('\n');
    for i in 0..n {
        let mut sep = "";
        if let Some(t) = &sim.t {
            let _ = write!(s, "{:.6}", t[i]);
            sep = ",";
        }
        let accel = sim.accel.as_ref().map(|a| a[i]);
        for v in accel.iter().chain([&sim.gyro[i]]).flatten() {
            // Whole counts within ±32768: exact as integers.
            let _ = write!(s, "{sep}{}", *v as i32);
            sep = ",";
        }
        s.push('\n');
    }
    s
}

/// Writes the recording to `path` ([`protocol_csv`]) and its truth to `path.truth.json`;
/// returns the truth's path.
pub fn write_protocol(sim: &ProtocolSim, path: &Path) -> Result<PathBuf> {
    write_file(path, protocol_csv(sim).as_bytes())?;
    let tp = truth_path(path);
    let json = serde_json::to_string_pretty(&sim.truth)? + "\n";
    write_file(&tp, json.as_bytes())?;
    Ok(tp)
}

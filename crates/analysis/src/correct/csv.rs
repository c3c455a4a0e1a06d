//! The corrected recording as CSV text, `t,a_x,a_y,a_z`: one writer for the held and the
//! streamed path, so that their files are the same byte for byte. Each value is the shortest
//! text that reads back to it (`Display` of the `f64` time as the recording gives it and of
//! the `f32` acceleration, g).

use super::Corrected;
use crate::error::Result;
use crate::output::write::write_with;
use std::io::Write;
use std::path::Path;

/// The header line.
pub const HEADER: &[u8] = b"t,a_x,a_y,a_z\n";

/// One corrected sample's line: time `t` (s) and acceleration `a` (g).
pub fn write_row(w: &mut (impl Write + ?Sized), t: f64, a: &[f32; 3]) -> std::io::Result<()> {
    writeln!(w, "{t},{},{},{}", a[0], a[1], a[2])
}

/// Writes the corrected samples of `c` to `path` atomically
/// ([`crate::output::write::write_with`]).
pub fn write_corrected(path: &Path, c: &Corrected) -> Result<()> {
    write_with(path, |w| {
        w.write_all(HEADER)?;
        for (t, a) in c.times.iter().zip(&c.accel) {
            write_row(w, *t, a)?;
        }
        Ok(())
    })
    .map_err(Into::into)
}

//! Detection: a [`crate::input::recording::Recording`] in → its static windows
//! ([`windows::Windows`]: the core's detector, the `f32` code the firmware runs, then `f64`
//! statistics per window) out — or, for a large text file streamed in passes, [`streamed`], the
//! same windows without holding the samples; [`table`], the rows of a window-mean table as windows in place of
//! the detection; [`motion`], the check that those windows were still; and [`polled`], a log
//! polled faster than its sensor updates (runs of repeated samples) found in those windows.

mod held;
pub mod motion;
pub mod polled;
mod spans;
pub mod streamed;
pub mod table;
pub mod windows;

pub use crate::error::detect::{DetectError, Setting};

//! Detection: a recording's rows in ([`crate::source::RowSource`]: held, or a large text file
//! read in passes) → its static windows ([`windows::Windows`]: the core's detector, the `f32`
//! code the firmware runs, then `f64` statistics per window) out, by one code (the held recording
//! is the case of one chunk in place; [`detector`], the detector itself); [`table`], the rows of a window-mean table as windows in place of
//! the detection; [`motion`], the check that those windows were still; and [`polled`], a log
//! polled faster than its sensor updates (runs of repeated samples) found in those windows.

pub mod detector;
mod held;
pub mod motion;
pub mod polled;
mod spans;
pub mod table;
pub mod windows;

pub use crate::error::detect::{DetectError, Setting};

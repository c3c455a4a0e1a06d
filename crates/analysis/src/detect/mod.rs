//! Detection: a [`crate::input::recording::Recording`] in → its static windows
//! ([`windows::Windows`]: the core's detector, the `f32` code the firmware runs, then `f64`
//! statistics per window) out; and [`motion`], the check that those windows were still.

pub mod motion;
pub mod windows;

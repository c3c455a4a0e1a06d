//! Library side of the `wiical` CLI: every subcommand's logic lives in a module here so that
//! tests can call it directly; `main.rs` only parses arguments and prints.
pub mod analyze;
pub mod analyze_model;
pub mod analyze_plot;
pub mod analyze_six;
pub mod analyze_stats;
pub mod capture;
pub mod decode_cal;
pub mod device;
#[cfg(unix)]
pub mod device_sim;
pub mod fit_cmd;
pub mod input;
pub mod kalman_demo;
pub mod magfit_cmd;
pub mod simulate;
pub mod six_position_cmd;

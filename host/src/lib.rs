//! Library side of the `wiical` CLI: every subcommand's logic lives in a module here so that
//! tests can call it directly; `main.rs` only parses arguments and prints.
pub mod decode_cal;
pub mod fit_cmd;
pub mod input;
pub mod kalman_demo;
pub mod magfit_cmd;
pub mod six_position_cmd;

//! The `wiical` command line, as a library so that tests can call each command directly:
//! `cmd` (one module per subcommand: arguments → engine → rendering), `render` (tables and
//! plots), `cli_error` (engine errors told with flag names). The analysis itself is the
//! `wiical-analysis` crate; the adapter client is [`client`]. `main.rs` only parses and
//! dispatches.
pub mod capture;
pub mod cli;
pub mod cli_error;
pub mod client;
pub mod cmd;
#[cfg(unix)]
pub mod device_sim;
pub mod live;
pub mod render;

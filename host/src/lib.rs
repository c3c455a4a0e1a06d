//! The `wiical` command line, as a library so that tests can call each command directly:
//! `cmd` (one module per subcommand: arguments → engine → rendering), `render` (tables and
//! plots), `cli_error` (engine errors told with flag names), `live` (the live page's server).
//! The analysis is the `wiical-analysis` crate; the adapter client, the Wii Remote capture and
//! the simulated adapter are the `wiical-client`, `wiical-capture` and `wiical-device-sim`
//! crates, re-exported here under the names the commands use. `main.rs` only parses and
//! dispatches.
pub mod cli;
pub mod cli_error;
pub mod cmd;
pub mod live;
pub mod render;
pub mod signals;

pub use wiical_capture as capture;
pub use wiical_client as client;
#[cfg(unix)]
pub use wiical_device_sim as device_sim;

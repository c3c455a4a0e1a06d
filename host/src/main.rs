//! `wiical`: accelerometer / gyro / magnetometer calibration from the command line.
//!
//! Every subcommand prints a readable table, or with `--json` a JSON object whose keys are a
//! stable contract (see README.md). Errors are printed as one readable chain, exit status 1.
//! This file only parses, runs and prints; the grammar is `wiical::cli`, each command `wiical::cmd`.

use clap::Parser;
use std::io::Write as _;
use wiical::cli::{run, Cli};

fn main() {
    let cli = Cli::parse();
    // Ctrl-C, SIGTERM and SIGHUP delete the run's temporary files before it ends.
    wiical::signals::install();
    match run(cli) {
        Ok(text) => {
            // A closed pipe (`wiical … | head`) is no panic, but the output was not all
            // written: say so and exit non-zero, as a shell expects.
            let mut stdout = std::io::stdout().lock();
            if let Err(e) = stdout
                .write_all(text.as_bytes())
                .and_then(|_| stdout.flush())
            {
                if e.kind() == std::io::ErrorKind::BrokenPipe {
                    eprintln!("error: standard output was closed before the output was written");
                } else {
                    eprintln!("error: writing the output: {e:#}");
                }
                std::process::exit(1);
            }
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::exit(1);
        }
    }
}

//! `wiical batch`: many recordings through `fit` or `analyze`, one JSON line per file in a
//! resumable results file (engine: [`wiical_analysis::batch`]).

use super::DetectArgs;
use crate::cli_error::cli_error;
use anyhow::{bail, Result};
use std::path::PathBuf;
use std::time::Instant;
use wiical_analysis::batch::{self, BatchCommand, BatchOptions};
use wiical_analysis::input::window_means::WindowInputOptions;
use wiical_analysis::AnalyzeOptions;
use wiical_core::multipos::MultiPosModel;

/// Arguments of `wiical batch`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Files, directories (every non-hidden file below, sorted; not the FILE.truth.json
    /// that `wiical simulate` writes beside each recording) or quoted patterns ("data/*.csv").
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Results file, JSON lines: one {"file", "ok", "result" | "error"} per file. Files
    /// already in it are skipped, so an interrupted run is resumed by running it again.
    #[arg(long)]
    pub out: PathBuf,
    /// Files analysed at once (worker threads, 1 to 256).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u16).range(1..=256))]
    pub jobs: u16,
    /// The pipeline: analyze (residual analysis) or fit (the linear fit only).
    #[arg(long, default_value = "analyze", value_parser = parse_command)]
    pub command: BatchCommand,
    #[command(flatten)]
    pub detect: DetectArgs,
}

fn parse_command(s: &str) -> Result<BatchCommand, String> {
    match s {
        "analyze" => Ok(BatchCommand::Analyze),
        "fit" => Ok(BatchCommand::Fit),
        _ => Err(format!("'{s}': expected analyze or fit")),
    }
}

/// Runs `wiical batch`; returns the summary line.
pub fn run(a: &Args) -> Result<String> {
    // Refused before anything is walked or read: `-` (standard output carries the summary)
    // and a results file batch did not create.
    super::check_outputs(&[], &[Some(&a.out)])?;
    batch::check_results_file(&a.out).map_err(cli_error)?;
    let found = batch::expand_inputs(&a.inputs, &a.out).map_err(cli_error)?;
    if found.files.is_empty() && found.problems.is_empty() {
        bail!("no files found in the inputs given");
    }
    let opts = BatchOptions {
        command: a.command,
        jobs: usize::from(a.jobs),
        input: WindowInputOptions {
            load: a.detect.load_options()?,
            force: a.detect.windows,
        },
        analyze: AnalyzeOptions {
            fit: a.detect.fit_options(MultiPosModel::Full),
            ..Default::default()
        },
    };
    let bar = indicatif::ProgressBar::with_draw_target(
        Some((found.files.len() + found.problems.len()) as u64),
        indicatif::ProgressDrawTarget::stderr(),
    );
    let started = Instant::now();
    let s = batch::run(&found, &a.out, &opts, &|line| {
        bar.inc(1);
        bar.set_message(line.file.clone());
    })
    .map_err(cli_error)?;
    bar.finish_and_clear();
    let secs = started.elapsed().as_secs_f64();
    let done = s.ok + s.failed;
    let unlisted = match s.unlisted {
        0 => String::new(),
        n => format!(
            "; {n} place{} below a directory could not be listed (a line each)",
            if n == 1 { "" } else { "s" }
        ),
    };
    Ok(format!(
        "batch: {} files: {} with a result, {} with an error, {} already in {} (skipped); {done} in {secs:.1} s ({:.2} files/s, {} jobs){unlisted}\n",
        s.files,
        s.ok,
        s.failed,
        s.skipped,
        a.out.display(),
        if secs > 0.0 { done as f64 / secs } else { 0.0 },
        a.jobs
    ))
}

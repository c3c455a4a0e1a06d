//! Many recordings at once (`wiical batch`): every file through the same pipeline as
//! `wiical fit` / `wiical analyze`, one JSON line per file in a results file that is
//! resumable.
//!
//! * **One line per file**: `{"file": …, "ok": true, "result": {…}}` with `result` the
//!   command's `--json` object, or `{"file": …, "ok": false, "error": "…"}` with the engine's
//!   sentence. A file that cannot be analysed is a line, never a stop.
//! * **Resumable**: the results file is a journal, appended to one whole line per write. On a
//!   new run, the files it already holds are skipped; a last line cut short by a kill is
//!   removed first (it was never complete), so after any number of interrupted runs every
//!   file appears exactly once.
//! * **Parallel**: `jobs` worker threads take files in order; a single writer appends the
//!   lines as they finish (so the order of lines is the order of completion).
//!
//! Cost: each file costs what its command costs (linear in its samples, see BENCHMARKS.md);
//! memory is that of `jobs` files at a time plus the set of names already done.

use crate::error::output::OutputError;
use crate::error::{Error, Result};
use crate::input::window_table::{load_input, WindowInputOptions};
use crate::pipeline;
use crate::{AnalyzeOptions, FitOptions};
use serde::{Deserialize, Serialize};
use std::collections::HashSet;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;

/// Which pipeline each file goes through.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BatchCommand {
    /// `wiical fit --json`.
    Fit,
    /// `wiical analyze --json`.
    Analyze,
}

/// Settings of a batch run.
#[derive(Debug, Clone)]
pub struct BatchOptions {
    /// The pipeline.
    pub command: BatchCommand,
    /// Worker threads (≥ 1).
    pub jobs: usize,
    /// How each file is read (columns, `--windows`).
    pub input: WindowInputOptions,
    /// The analysis settings (its `fit` is used by [`BatchCommand::Fit`] too).
    pub analyze: AnalyzeOptions,
}

/// One line of the results file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BatchLine {
    /// The file, as found (the key a resumed run skips by).
    pub file: String,
    /// Whether the pipeline produced a result.
    pub ok: bool,
    /// The command's `--json` object.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub result: Option<serde_json::Value>,
    /// Why not, in one sentence.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// What a run did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct BatchSummary {
    /// Files found.
    pub files: usize,
    /// Already in the results file, skipped.
    pub skipped: usize,
    /// Analysed with a result.
    pub ok: usize,
    /// Analysed with an error line.
    pub failed: usize,
}

/// The files of `inputs`: a directory gives every regular, non-hidden file below it
/// (sorted, recursively); a file is taken as is; a pattern with `*`, `?` or `[` is expanded
/// (sorted). `exclude` (the results file) is never taken. Duplicates are dropped.
pub fn expand_inputs(inputs: &[PathBuf], exclude: &Path) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for input in inputs {
        let s = input.to_string_lossy();
        if input.is_dir() {
            walk(input, &mut files)?;
        } else if s.contains(['*', '?', '[']) {
            let paths = glob::glob(&s).map_err(|e| Error::BatchInput {
                input: input.clone(),
                why: e.msg.to_string(),
            })?;
            let mut found: Vec<PathBuf> = paths.filter_map(|p| p.ok()).collect();
            found.retain(|p| p.is_file());
            found.sort();
            files.extend(found);
        } else if input.is_file() {
            files.push(input.clone());
        } else {
            return Err(Error::BatchInput {
                input: input.clone(),
                why: "no such file or directory".into(),
            });
        }
    }
    let exclude = std::fs::canonicalize(exclude).ok();
    let mut seen = HashSet::new();
    files.retain(|f| {
        let c = std::fs::canonicalize(f).unwrap_or_else(|_| f.clone());
        Some(&c) != exclude.as_ref() && seen.insert(c)
    });
    Ok(files)
}

/// Regular non-hidden files below `dir`, sorted by path.
fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    for entry in walkdir::WalkDir::new(dir).sort_by_file_name() {
        let entry = entry.map_err(|e| Error::BatchInput {
            input: dir.to_path_buf(),
            why: e.to_string(),
        })?;
        let hidden = entry.file_name().to_string_lossy().starts_with('.');
        if entry.file_type().is_file() && !hidden {
            out.push(entry.into_path());
        }
    }
    Ok(())
}

/// The files a results file already holds, after removing a last line cut short (a run
/// killed while writing it). A missing file holds none.
pub fn resume(out: &Path) -> Result<HashSet<String>> {
    let io = |source| {
        Error::from(OutputError::Write {
            path: out.into(),
            source,
        })
    };
    let file = match std::fs::OpenOptions::new().read(true).write(true).open(out) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(HashSet::new()),
        Err(e) => return Err(io(e)),
    };
    let mut done = HashSet::new();
    let mut complete_len = 0u64;
    let mut reader = std::io::BufReader::new(&file);
    let mut line = Vec::new();
    loop {
        line.clear();
        let n = reader.read_until(b'\n', &mut line).map_err(io)?;
        if n == 0 || line.last() != Some(&b'\n') {
            break;
        }
        complete_len += n as u64;
        if let Ok(l) = serde_json::from_slice::<BatchLine>(&line) {
            done.insert(l.file);
        }
    }
    file.set_len(complete_len).map_err(io)?;
    Ok(done)
}

/// The line of one file.
fn run_one(path: &Path, opts: &BatchOptions) -> BatchLine {
    let result = load_input(path, &opts.input).and_then(|input| match opts.command {
        BatchCommand::Fit => {
            let fit: &FitOptions = &opts.analyze.fit;
            serde_json::to_value(pipeline::fit_judged(&input, fit)?).map_err(Error::from)
        }
        BatchCommand::Analyze => {
            serde_json::to_value(pipeline::analyze_judged(&input, &opts.analyze)?)
                .map_err(Error::from)
        }
    });
    let file = path.to_string_lossy().into_owned();
    match result {
        Ok(v) => BatchLine {
            file,
            ok: true,
            result: Some(v),
            error: None,
        },
        Err(e) => BatchLine {
            file,
            ok: false,
            result: None,
            error: Some(e.full_message()),
        },
    }
}

/// Runs `files` not yet in `out` through the pipeline with `opts.jobs` workers, appending a
/// line per file to `out` (created if missing). `on_line` sees each line as it is written
/// (a progress display). Fails only when the results file cannot be read or written.
pub fn run(
    files: &[PathBuf],
    out: &Path,
    opts: &BatchOptions,
    on_line: &(dyn Fn(&BatchLine) + Sync),
) -> Result<BatchSummary> {
    let done = resume(out)?;
    let todo: Vec<&PathBuf> = files
        .iter()
        .filter(|f| !done.contains(f.to_string_lossy().as_ref()))
        .collect();
    let mut summary = BatchSummary {
        files: files.len(),
        skipped: files.len() - todo.len(),
        ..Default::default()
    };
    let io = |source| {
        Error::from(OutputError::Write {
            path: out.into(),
            source,
        })
    };
    let mut journal = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(out)
        .map_err(io)?;
    let next = AtomicUsize::new(0);
    let (tx, rx) = mpsc::channel::<BatchLine>();
    std::thread::scope(|s| -> Result<()> {
        for _ in 0..opts.jobs.max(1) {
            let tx = tx.clone();
            let (next, todo) = (&next, &todo);
            s.spawn(move || {
                while let Some(path) = todo.get(next.fetch_add(1, Ordering::Relaxed)) {
                    if tx.send(run_one(path, opts)).is_err() {
                        break;
                    }
                }
            });
        }
        drop(tx);
        for line in rx {
            // One write per line: a kill leaves whole lines and at most one cut-short last
            // line, which `resume` removes.
            let mut text = serde_json::to_string(&line)?;
            text.push('\n');
            if let Err(e) = journal.write_all(text.as_bytes()) {
                next.store(usize::MAX / 2, Ordering::Relaxed); // stop the workers
                return Err(io(e));
            }
            if line.ok {
                summary.ok += 1;
            } else {
                summary.failed += 1;
            }
            on_line(&line);
        }
        Ok(())
    })?;
    journal.sync_all().map_err(io)?;
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulate::{simulate, to_csv, SimConfig};

    /// `n` simulated recordings and one file that is not a recording, in a new directory.
    fn inputs(n: usize) -> (tempfile::TempDir, Vec<PathBuf>) {
        let dir = tempfile::tempdir().unwrap();
        let mut files = Vec::new();
        for seed in 0..n as u64 {
            let sim = simulate(&SimConfig {
                seed,
                poses: 20,
                ..Default::default()
            })
            .unwrap();
            let p = dir.path().join(format!("rec{seed:02}.csv"));
            std::fs::write(&p, to_csv(&sim.recording)).unwrap();
            files.push(p);
        }
        let bad = dir.path().join("notes.csv");
        std::fs::write(&bad, "not a recording\n").unwrap();
        files.push(bad);
        (dir, files)
    }

    fn opts(jobs: usize) -> BatchOptions {
        BatchOptions {
            command: BatchCommand::Analyze,
            jobs,
            input: Default::default(),
            analyze: Default::default(),
        }
    }

    fn lines(out: &Path) -> Vec<BatchLine> {
        std::fs::read_to_string(out)
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect()
    }

    #[test]
    fn every_file_is_one_line_and_a_bad_file_is_an_error_line() {
        let (dir, files) = inputs(4);
        let out = dir.path().join("results.jsonl");
        let s = run(&files, &out, &opts(2), &|_| {}).unwrap();
        assert_eq!((s.files, s.ok, s.failed, s.skipped), (5, 4, 1, 0));
        let got = lines(&out);
        assert_eq!(got.len(), 5);
        let bad = got.iter().find(|l| l.file.ends_with("notes.csv")).unwrap();
        assert!(!bad.ok && bad.error.as_deref().unwrap().contains("notes.csv"));
        // Each result is what `analyze --json` gives for that file on its own (compared as
        // text: parsing JSON floats back is not exact, their shortest printed form is).
        let input = load_input(&files[1], &Default::default()).unwrap();
        let alone = pipeline::analyze_judged(&input, &Default::default()).unwrap();
        let want = serde_json::to_string(&BatchLine {
            file: files[1].to_string_lossy().into_owned(),
            ok: true,
            result: Some(serde_json::to_value(&alone).unwrap()),
            error: None,
        })
        .unwrap();
        let text = std::fs::read_to_string(&out).unwrap();
        assert!(text.lines().any(|l| l == want));
        // A second run finds them all done.
        let again = run(&files, &out, &opts(1), &|_| {}).unwrap();
        assert_eq!((again.skipped, again.ok + again.failed), (5, 0));
        assert_eq!(lines(&out).len(), 5);
    }

    #[test]
    fn a_line_cut_short_by_a_kill_is_dropped_and_its_file_redone() {
        let (dir, files) = inputs(3);
        let out = dir.path().join("results.jsonl");
        run(&files[..2], &out, &opts(1), &|_| {}).unwrap();
        // A kill in the middle of the third line's write.
        let mut f = std::fs::OpenOptions::new().append(true).open(&out).unwrap();
        f.write_all(br#"{"file":"rec02.csv","ok":tr"#).unwrap();
        drop(f);
        assert_eq!(resume(&out).unwrap().len(), 2);
        let s = run(&files, &out, &opts(2), &|_| {}).unwrap();
        assert_eq!((s.skipped, s.ok + s.failed), (2, 2));
        let got = lines(&out);
        let mut names: Vec<&str> = got.iter().map(|l| l.file.as_str()).collect();
        names.sort();
        let mut want: Vec<String> = files
            .iter()
            .map(|f| f.to_string_lossy().into_owned())
            .collect();
        want.sort();
        assert_eq!(names, want);
    }

    #[test]
    fn directories_and_patterns_expand_sorted_without_the_results_file() {
        let (dir, _files) = inputs(2);
        let out = dir.path().join("results.jsonl");
        std::fs::write(&out, "").unwrap();
        std::fs::write(dir.path().join(".hidden.csv"), "x").unwrap();
        let all = expand_inputs(&[dir.path().to_path_buf()], &out).unwrap();
        let names: Vec<String> = all
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["notes.csv", "rec00.csv", "rec01.csv"]);
        let pattern = dir.path().join("rec*.csv");
        assert_eq!(expand_inputs(&[pattern], &out).unwrap().len(), 2);
        let missing = expand_inputs(&[dir.path().join("nope.csv")], &out).unwrap_err();
        assert!(missing.to_string().contains("no such file"), "{missing}");
    }
}

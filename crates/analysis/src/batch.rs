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
//! * **Keyed by the file, not its spelling**: each line carries the file's canonical path
//!   (`canonical`, or `canonical_bytes` when the name is not UTF-8), and a resumed run skips
//!   by it, so `data/a.csv`, `./data/a.csv` and a link to it are one file, and two non-UTF-8
//!   names that print alike stay two.
//! * **Never over someone else's file** ([`check_results_file`]): the results file is
//!   created, or appended to only when it already is a results file (empty, or its first
//!   line is a batch line); an input, any other file, a directory, a pipe or a device is
//!   refused before anything is opened for writing.
//! * **Walking a directory** follows links to files and directories (as a pattern does), a
//!   link loop or an unreadable directory being an error line of its own, not a stop.
//!
//! Cost: each file costs what its command costs (linear in its samples, see BENCHMARKS.md);
//! memory is that of `jobs` files at a time plus the set of names already done.

use crate::error::output::OutputError;
use crate::error::{Error, Result};
use crate::input::front_door::load_input;
use crate::input::window_means::WindowInputOptions;
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
    /// The file, as found.
    pub file: String,
    /// The file's canonical path (the key a resumed run skips by), when it is UTF-8.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub canonical: Option<String>,
    /// The canonical path's bytes, when it is not UTF-8 (Unix).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub canonical_bytes: Option<Vec<u8>>,
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
    /// Places below a directory that could not be walked (an error line each).
    pub unlisted: usize,
}

/// What [`expand_inputs`] found: the files to run, and the places below a directory that
/// could not be walked (an unreadable directory, a link loop), each to become an error line.
#[derive(Debug, Default)]
pub struct Expanded {
    /// The files, in order, without duplicates (by canonical path) or the results file.
    pub files: Vec<PathBuf>,
    /// Places that could not be listed, with the reason.
    pub problems: Vec<(PathBuf, String)>,
}

/// The files of `inputs`: a directory gives every regular, non-hidden file below it
/// (sorted, recursively, links followed) but the simulator's truth files (`FILE.truth.json`
/// beside its recording `FILE`: [`truth_path`]), which are no
/// recordings; a file is taken as is; a pattern with `*`, `?` or `[` is expanded (sorted).
/// `exclude` (the results file) is never taken. Duplicates (by canonical path) are dropped.
pub fn expand_inputs(inputs: &[PathBuf], exclude: &Path) -> Result<Expanded> {
    let mut found = Expanded::default();
    for input in inputs {
        let s = input.to_string_lossy();
        if input.is_dir() {
            walk(input, &mut found);
        } else if s.contains(['*', '?', '[']) {
            let paths = glob::glob(&s).map_err(|e| Error::BatchInput {
                input: input.clone(),
                why: e.msg.to_string(),
            })?;
            let mut matched: Vec<PathBuf> = paths.filter_map(|p| p.ok()).collect();
            matched.sort();
            for p in matched {
                match std::fs::metadata(&p) {
                    Ok(m) if m.is_file() => found.files.push(p),
                    Ok(m) if !m.is_dir() => found.problems.push((p, NOT_REGULAR.into())),
                    _ => {}
                }
            }
        } else if input.is_file() {
            found.files.push(input.clone());
        } else if input.exists() {
            return Err(Error::BatchInput {
                input: input.clone(),
                why: NOT_REGULAR.into(),
            });
        } else {
            return Err(Error::BatchInput {
                input: input.clone(),
                why: "no such file or directory".into(),
            });
        }
    }
    let exclude = std::fs::canonicalize(exclude).ok();
    let mut seen = HashSet::new();
    found.files.retain(|f| {
        let c = std::fs::canonicalize(f).unwrap_or_else(|_| f.clone());
        Some(&c) != exclude.as_ref() && seen.insert(c)
    });
    Ok(found)
}

/// Why a pipe, device or socket among the inputs is a line and not a run (opening a pipe
/// with no writer would block the whole batch).
const NOT_REGULAR: &str =
    "not a regular file (a pipe, device or socket): not read; give recordings as files";

/// Regular non-hidden files below `dir`, sorted by path, links followed (walkdir stops at a
/// link back to an ancestor and reports the loop). An entry that cannot be read is a
/// problem, not a stop.
fn walk(dir: &Path, out: &mut Expanded) {
    let walker = walkdir::WalkDir::new(dir)
        .follow_links(true)
        .sort_by_file_name();
    for entry in walker {
        let entry = match entry {
            Ok(e) => e,
            Err(e) => {
                let place = e.path().unwrap_or(dir).to_path_buf();
                let dangling = std::fs::symlink_metadata(&place).is_ok_and(|m| m.is_symlink())
                    && std::fs::metadata(&place).is_err();
                let why = match (e.loop_ancestor(), e.io_error()) {
                    (Some(a), _) => format!("a link loop back to {}", a.display()),
                    _ if dangling => "a link to nothing (dangling)".to_string(),
                    (None, Some(io)) => format!("cannot be listed: {io}"),
                    _ => e.to_string(),
                };
                out.problems.push((place, why));
                continue;
            }
        };
        let hidden = entry.file_name().to_string_lossy().starts_with('.');
        let kind = entry.file_type();
        if hidden || kind.is_dir() {
            continue;
        }
        if kind.is_file() {
            if !is_truth_beside_its_recording(entry.path()) {
                out.files.push(entry.into_path());
            }
        } else {
            // A pipe would block the batch forever; a device or socket is no recording.
            out.problems.push((entry.into_path(), NOT_REGULAR.into()));
        }
    }
}

/// Where the truth of a recording written to `path` goes: `path` + `.truth.json`. The
/// simulator (`wiical-sim`, `wiical simulate`) writes it there; [`expand_inputs`] leaves such
/// a file out of a folder when its recording is beside it.
pub fn truth_path(path: &Path) -> PathBuf {
    let mut p = path.as_os_str().to_owned();
    p.push(".truth.json");
    PathBuf::from(p)
}

/// True for `FILE.truth.json` when `FILE` is a regular file beside it: what `wiical simulate`
/// writes next to each recording (the known truth, JSON), which would otherwise be one
/// failure line per recording in a batch over a simulated folder.
fn is_truth_beside_its_recording(path: &Path) -> bool {
    let name = path.file_name().map(|n| n.to_string_lossy());
    let Some(stem) = name.as_deref().and_then(|n| n.strip_suffix(".truth.json")) else {
        return false;
    };
    !stem.is_empty()
        && truth_path(&path.with_file_name(stem)) == path
        && path.with_file_name(stem).is_file()
}

/// Refuses a results file batch did not create: anything that is not a regular file (a
/// directory, a FIFO, a device, which could also block forever), and a regular file that is
/// not empty and does not start with a batch line (an input, a recording, any other file:
/// appending to it would spoil it). A missing file is fine (it is created).
pub fn check_results_file(out: &Path) -> Result<()> {
    let meta = match std::fs::metadata(out) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(source) => {
            return Err(OutputError::Write {
                path: out.into(),
                source,
            }
            .into())
        }
    };
    if !meta.is_file() {
        return Err(OutputError::OutputNotRegular { output: out.into() }.into());
    }
    let mut head = Vec::new();
    let file = std::fs::File::open(out).map_err(|source| OutputError::Write {
        path: out.into(),
        source,
    })?;
    // The first line, bounded: a batch line holds one file's result (kilobytes).
    let mut reader = std::io::BufReader::new(std::io::Read::take(file, 1 << 20));
    reader
        .read_until(b'\n', &mut head)
        .map_err(|source| OutputError::Write {
            path: out.into(),
            source,
        })?;
    let ours = head.is_empty()
        || serde_json::from_slice::<BatchLine>(&head).is_ok()
        || (!head.ends_with(b"\n") && head.starts_with(b"{\"file\":"));
    if ours {
        Ok(())
    } else {
        Err(OutputError::NotBatchResults { out: out.into() }.into())
    }
}

/// The canonical path of `path`: the key of a file in the results file. A file that cannot
/// be resolved (deleted or renamed while the batch runs, a dangling link) is keyed by its
/// canonical directory and its name, which is what the file gets once it is back: keyed by
/// the path as typed (`dm/k250.csv`) its error line would not match it, and a resumed run
/// would write a second, contradictory line for it. `path` itself only when even the
/// directory cannot be resolved.
fn key_of(path: &Path) -> PathBuf {
    if let Ok(c) = std::fs::canonicalize(path) {
        return c;
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    match (std::fs::canonicalize(dir), path.file_name()) {
        (Ok(d), Some(name)) => d.join(name),
        _ => path.to_path_buf(),
    }
}

/// The key a line was written for: its canonical path (bytes or text), else its `file`
/// resolved now (lines written before the key was kept).
fn line_key(l: &BatchLine) -> PathBuf {
    if let Some(b) = &l.canonical_bytes {
        #[cfg(unix)]
        {
            use std::os::unix::ffi::OsStrExt;
            return PathBuf::from(std::ffi::OsStr::from_bytes(b));
        }
        #[cfg(not(unix))]
        return PathBuf::from(String::from_utf8_lossy(b).into_owned());
    }
    match &l.canonical {
        // An absolute key as written; a relative one (written for a missing file by earlier
        // versions) resolved now, as the file's own key is.
        Some(c) if Path::new(c).is_absolute() => PathBuf::from(c),
        Some(c) => key_of(Path::new(c)),
        None => key_of(Path::new(&l.file)),
    }
}

/// A line for `path` with its key filled in (see [`BatchLine::canonical`]).
fn keyed(path: &Path, ok: bool) -> BatchLine {
    let key = key_of(path);
    let (canonical, canonical_bytes) = match key.to_str() {
        Some(s) => (Some(s.to_string()), None),
        None => (None, Some(key.as_os_str().as_encoded_bytes().to_vec())),
    };
    BatchLine {
        file: path.to_string_lossy().into_owned(),
        canonical,
        canonical_bytes,
        ok,
        result: None,
        error: None,
    }
}

/// The files (canonical paths, as `line_key` reads them) a results file already holds, after removing a
/// last line cut short (a run killed while writing it). A missing file holds none; a file
/// that is not a results file is refused ([`check_results_file`]) before it is opened for
/// writing.
pub fn resume(out: &Path) -> Result<HashSet<PathBuf>> {
    check_results_file(out)?;
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
            done.insert(line_key(&l));
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
    match result {
        Ok(v) => BatchLine {
            result: Some(v),
            ..keyed(path, true)
        },
        Err(e) => BatchLine {
            error: Some(e.full_message()),
            ..keyed(path, false)
        },
    }
}

/// Holds the results file's lock for as long as `journal` is open (the kernel drops it when
/// the process ends, killed or not, so a resumed run never finds a stale lock). A second run
/// on the same file is refused rather than doing every file again beside the first.
#[cfg(unix)]
fn lock_results(journal: &std::fs::File, out: &Path) -> Result<()> {
    use rustix::fs::{flock, FlockOperation};
    match flock(journal, FlockOperation::NonBlockingLockExclusive) {
        Ok(()) => Ok(()),
        Err(e) if e == rustix::io::Errno::WOULDBLOCK => {
            Err(OutputError::ResultsInUse { out: out.into() }.into())
        }
        Err(e) => Err(OutputError::Write {
            path: out.into(),
            source: e.into(),
        }
        .into()),
    }
}

/// Elsewhere no lock is taken: two runs on one results file each do every file.
#[cfg(not(unix))]
fn lock_results(_journal: &std::fs::File, _out: &Path) -> Result<()> {
    Ok(())
}

/// The error line of a place below a directory that could not be walked.
fn problem_line(place: &Path, why: &str) -> BatchLine {
    BatchLine {
        error: Some(format!("{}: {why}", place.display())),
        ..keyed(place, false)
    }
}

/// Runs the files of `found` not yet in `out` through the pipeline with `opts.jobs`
/// workers, appending a line per file to `out` (created if missing; appended to only when it
/// is a results file), and a line per place that could not be walked. `on_line` sees each
/// line as it is written (a progress display). Fails only when the results file is refused
/// or cannot be read or written.
pub fn run(
    found: &Expanded,
    out: &Path,
    opts: &BatchOptions,
    on_line: &(dyn Fn(&BatchLine) + Sync),
) -> Result<BatchSummary> {
    let files = &found.files;
    let io = |source| {
        Error::from(OutputError::Write {
            path: out.into(),
            source,
        })
    };
    // Refused before it is opened: opening a FIFO for writing would block.
    check_results_file(out)?;
    let mut journal = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(out)
        .map_err(io)?;
    lock_results(&journal, out)?;
    let done = resume(out)?;
    let todo: Vec<&PathBuf> = files
        .iter()
        .filter(|f| !done.contains(&key_of(f)))
        .collect();
    let problems: Vec<BatchLine> = found
        .problems
        .iter()
        .filter(|(p, _)| !done.contains(&key_of(p)))
        .map(|(p, why)| problem_line(p, why))
        .collect();
    let mut summary = BatchSummary {
        files: files.len(),
        skipped: files.len() - todo.len(),
        ..Default::default()
    };
    let next = AtomicUsize::new(0);
    let (tx, rx) = mpsc::channel::<BatchLine>();
    let unlisted = problems.len();
    for p in problems {
        let _ = tx.send(p);
    }
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
    summary.failed -= unlisted;
    summary.unlisted = unlisted;
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use wiical_sim::{simulate, to_csv, SimConfig};

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

    fn all(files: &[PathBuf]) -> Expanded {
        Expanded {
            files: files.to_vec(),
            problems: Vec::new(),
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
        let s = run(&all(&files), &out, &opts(2), &|_| {}).unwrap();
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
            canonical: Some(
                std::fs::canonicalize(&files[1])
                    .unwrap()
                    .to_string_lossy()
                    .into_owned(),
            ),
            canonical_bytes: None,
            ok: true,
            result: Some(serde_json::to_value(&alone).unwrap()),
            error: None,
        })
        .unwrap();
        let text = std::fs::read_to_string(&out).unwrap();
        assert!(text.lines().any(|l| l == want));
        // A second run finds them all done.
        let again = run(&all(&files), &out, &opts(1), &|_| {}).unwrap();
        assert_eq!((again.skipped, again.ok + again.failed), (5, 0));
        assert_eq!(lines(&out).len(), 5);
    }

    /// A file deleted while the batch runs gets its error line under the key it has when it
    /// is back (its canonical directory and name, not the path as typed), so the resumed run
    /// skips it: one line per file, never an `ok: false` and an `ok: true` for one file.
    #[test]
    fn a_file_missing_during_the_run_is_one_line_when_it_is_back() {
        let (dir, files) = inputs(2);
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        // Spelled through another directory, as a relative path is: not its canonical form.
        let spelled = dir.path().join("sub/../rec00.csv");
        let found = all(&[spelled.clone(), files[1].clone()]);
        let out = dir.path().join("results.jsonl");
        let kept = std::fs::read(&files[0]).unwrap();
        std::fs::remove_file(&files[0]).unwrap();
        let first = run(&found, &out, &opts(1), &|_| {}).unwrap();
        assert_eq!((first.ok, first.failed), (1, 1));
        std::fs::write(&files[0], kept).unwrap();
        let again = run(&found, &out, &opts(1), &|_| {}).unwrap();
        assert_eq!((again.skipped, again.ok + again.failed), (2, 0));
        let got = lines(&out);
        assert_eq!(got.len(), 2, "{got:?}");
        let want = std::fs::canonicalize(&files[0]).unwrap();
        let missing = got.iter().find(|l| !l.ok).unwrap();
        assert_eq!(missing.canonical.as_deref(), want.to_str());
    }

    #[test]
    fn a_line_cut_short_by_a_kill_is_dropped_and_its_file_redone() {
        let (dir, files) = inputs(3);
        let out = dir.path().join("results.jsonl");
        run(&all(&files[..2]), &out, &opts(1), &|_| {}).unwrap();
        // A kill in the middle of the third line's write.
        let mut f = std::fs::OpenOptions::new().append(true).open(&out).unwrap();
        f.write_all(br#"{"file":"rec02.csv","ok":tr"#).unwrap();
        drop(f);
        assert_eq!(resume(&out).unwrap().len(), 2);
        let s = run(&all(&files), &out, &opts(2), &|_| {}).unwrap();
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
        let found = expand_inputs(&[dir.path().to_path_buf()], &out).unwrap();
        let names: Vec<String> = found
            .files
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["notes.csv", "rec00.csv", "rec01.csv"]);
        let pattern = dir.path().join("rec*.csv");
        assert_eq!(expand_inputs(&[pattern], &out).unwrap().files.len(), 2);
        let missing = expand_inputs(&[dir.path().join("nope.csv")], &out).unwrap_err();
        assert!(missing.to_string().contains("no such file"), "{missing}");
    }

    /// In a folder `wiical simulate` wrote, each recording's `FILE.truth.json` is not taken
    /// (it is no recording); a truth file without its recording, or named on its own, is.
    #[test]
    fn the_simulators_truth_files_beside_their_recordings_are_not_taken() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("results.jsonl");
        let sim = simulate(&SimConfig {
            poses: 20,
            ..Default::default()
        })
        .unwrap();
        let rec = dir.path().join("rec.csv");
        let truth = wiical_sim::write(&sim, &rec).unwrap();
        let orphan = dir.path().join("gone.csv.truth.json");
        std::fs::copy(&truth, &orphan).unwrap();
        let found = expand_inputs(&[dir.path().to_path_buf()], &out).unwrap();
        assert_eq!(found.files, [orphan, rec]);
        let named = expand_inputs(std::slice::from_ref(&truth), &out).unwrap();
        assert_eq!(named.files, [truth]);
    }

    /// A second run on a results file another run is writing is refused (not a second pass
    /// over every file beside the first); the lock goes with the first run's file.
    #[cfg(unix)]
    #[test]
    fn a_second_run_on_a_results_file_in_use_is_refused() {
        let (dir, files) = inputs(1);
        let out = dir.path().join("results.jsonl");
        let first = std::fs::File::create(&out).unwrap();
        rustix::fs::flock(&first, rustix::fs::FlockOperation::LockExclusive).unwrap();
        let err = run(&all(&files), &out, &opts(1), &|_| {}).unwrap_err();
        assert!(
            err.to_string().contains("another wiical batch run"),
            "{err}"
        );
        assert!(
            lines(&out).is_empty(),
            "nothing written beside the first run"
        );
        drop(first);
        let s = run(&all(&files), &out, &opts(1), &|_| {}).unwrap();
        assert_eq!(s.ok + s.failed, 2);
    }

    /// A pipe among the inputs is a line (not a read that blocks the batch), whether found by
    /// walking, by a pattern, or given by name (then refused, naming what it is).
    #[cfg(unix)]
    #[test]
    fn a_pipe_among_the_inputs_is_a_line_not_a_block() {
        let (dir, _files) = inputs(1);
        let out = dir.path().join("results.jsonl");
        let fifo = dir.path().join("pipe.csv");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        assert!(made.unwrap().success());
        for input in [dir.path().to_path_buf(), dir.path().join("*.csv")] {
            let found = expand_inputs(&[input], &out).unwrap();
            assert_eq!(found.files.len(), 2, "{found:?}");
            assert_eq!(found.problems.len(), 1, "{found:?}");
            assert!(found.problems[0].1.contains("not a regular file"));
        }
        let named = expand_inputs(&[fifo], &out).unwrap_err();
        assert!(
            named.to_string().contains("a pipe, device or socket"),
            "{named}"
        );
    }
}

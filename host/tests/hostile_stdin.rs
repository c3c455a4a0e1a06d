//! Hostile inputs around standard input's copy (docs/bad-inputs.md, issue 49): the copy in
//! `$TMPDIR` is deleted when a signal ends the run (SIGTERM, SIGINT, SIGHUP), a copy left by
//! a killed run (SIGKILL) is deleted by the next one, a signal the run was started with
//! ignored stays ignored, and a `$TMPDIR` that cannot take the copy is named with what is
//! wrong with it and the fact that standard input is being copied there.
#![cfg(unix)]

mod common;
use common::data_dir;
use std::io::Write;
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The names in `dir`.
fn names(dir: &Path) -> Vec<String> {
    let mut n: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    n.sort();
    n
}

/// `wiical analyze -` (through `sh -c` with `prelude` before it, when given) copying standard
/// input to `tmpdir` (anything over 4 kB is copied), given a real recording's first 100 kB and
/// its standard input then held open: the run stays in the copy until the test ends it.
/// Returns once the copy exists.
fn copying(tmpdir: &Path, prelude: Option<&str>) -> Child {
    let bin = env!("CARGO_BIN_EXE_wiical");
    let mut cmd = match prelude {
        Some(p) => {
            let mut c = Command::new("sh");
            c.args([
                "-c",
                &format!("{p}; exec \"$0\" analyze - --stream-from-bytes 4096"),
                bin,
            ]);
            c
        }
        None => {
            let mut c = Command::new(bin);
            c.args(["analyze", "-", "--stream-from-bytes", "4096"]);
            c
        }
    };
    // The signals this file sends start at their default action in the child, whatever the
    // test runner inherited (under `nohup` SIGHUP arrives ignored, and an ignored signal stays
    // ignored: `an_ignored_signal_stays_ignored`). SAFETY: signal(2) is async-signal-safe, so
    // it may run between fork and exec.
    unsafe {
        cmd.pre_exec(|| {
            for s in [libc::SIGHUP, libc::SIGINT, libc::SIGTERM] {
                libc::signal(s, libc::SIG_DFL);
            }
            Ok(())
        });
    }
    let mut child = cmd
        .env("TMPDIR", tmpdir)
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let rec = std::fs::read(data_dir().join("imu_tk_xsens/xsens_acc.mat")).unwrap();
    child
        .stdin
        .as_mut()
        .unwrap()
        .write_all(&rec[..100_000])
        .unwrap();
    let start = Instant::now();
    while !names(tmpdir).iter().any(|n| n.starts_with("wiical-stdin-")) {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "no copy of standard input in {tmpdir:?}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    child
}

fn kill(child: &Child, signal: &str) {
    let ok = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
}

/// SIGTERM, SIGINT and SIGHUP in the middle of the copy: the copy is deleted, and the run
/// ends as killed by that signal (the shell's 143, 130, 129).
#[test]
fn a_signal_deletes_the_copy_of_standard_input() {
    for (signal, number) in [("TERM", 15), ("INT", 2), ("HUP", 1)] {
        let tmp = tempfile::tempdir().unwrap();
        let mut child = copying(tmp.path(), None);
        kill(&child, signal);
        let status = child.wait().unwrap();
        assert_eq!(status.signal(), Some(number), "SIG{signal}: {status:?}");
        assert_eq!(names(tmp.path()), Vec::<String>::new(), "SIG{signal}");
    }
}

/// A copy left by a run killed with SIGKILL (which no process can catch) is there — named
/// with that run's process id — and the next copy of standard input deletes it.
#[test]
fn a_copy_left_by_a_killed_run_is_deleted_by_the_next() {
    let tmp = tempfile::tempdir().unwrap();
    let mut child = copying(tmp.path(), None);
    let pid = child.id();
    kill(&child, "KILL");
    child.wait().unwrap();
    let left = names(tmp.path());
    assert_eq!(left.len(), 1, "{left:?}");
    assert!(
        left[0].starts_with(&format!("wiical-stdin-{pid}-")),
        "{left:?}"
    );
    let out = Command::new(env!("CARGO_BIN_EXE_wiical"))
        .args(["fit", "-", "--json", "--stream-from-bytes", "4096"])
        .env("TMPDIR", tmp.path())
        .stdin(std::fs::File::open(data_dir().join("imu_tk_xsens/xsens_acc.mat")).unwrap())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(names(tmp.path()), Vec::<String>::new());
}

/// A run started with SIGHUP ignored (as `nohup` starts it) is not ended by one: the signal
/// stays ignored, the run goes on to its report once its input ends.
#[test]
fn an_ignored_signal_stays_ignored() {
    let tmp = tempfile::tempdir().unwrap();
    let mut child = copying(tmp.path(), Some("trap '' HUP"));
    kill(&child, "HUP");
    std::thread::sleep(Duration::from_millis(300));
    assert!(child.try_wait().unwrap().is_none(), "SIGHUP ended the run");
    drop(child.stdin.take());
    let out = child.wait_with_output().unwrap();
    // 100 kB of a recording: too short to fit, a sentence; not a signal.
    assert_eq!(out.status.signal(), None, "{:?}", out.status);
    assert_eq!(names(tmp.path()), Vec::<String>::new());
}

/// `$TMPDIR` that does not exist, or is a file: the sentence says standard input is copied
/// there, names TMPDIR and the directory, and what is wrong with it.
#[test]
fn a_tmpdir_that_cannot_take_the_copy_is_named() {
    let scratch = tempfile::tempdir().unwrap();
    let file = scratch.path().join("a-file");
    std::fs::write(&file, "x").unwrap();
    let missing = scratch.path().join("nonexistent");
    let rec = data_dir().join("imu_tk_xsens/xsens_acc.mat");
    for (dir, what) in [
        (&missing, "that directory does not exist"),
        (&file, "it is not a directory"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_wiical"))
            .args(["fit", "-", "--stream-from-bytes", "4096"])
            .env("TMPDIR", dir)
            .stdin(std::fs::File::open(&rec).unwrap())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success());
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        for w in [
            "standard input is too long to hold",
            "copied to a temporary file in",
            &dir.display().to_string(),
            "TMPDIR",
            what,
        ] {
            assert!(err.contains(w), "{w:?} not in {err}");
        }
    }
}

//! The temporary files this process makes under a name (the copy of standard input,
//! `input::front_door`): each is registered while it exists, so that the `wiical` binary's
//! signal handler can delete it before the process ends on SIGINT, SIGTERM or SIGHUP
//! ([`remove_registered`]); and each is named with the process id (`wiical-stdin-<pid>-…`),
//! so that a later copy deletes the ones a process that could not clean up left behind
//! (SIGKILL, a crash, a power cut: [`remove_stale`]).
//!
//! Why: a copy of standard input is as large as the recording piped in (hundreds of MB to
//! GB), and `tempfile`'s delete-on-drop does not run when a signal ends the process. The
//! spill (`input::text_spill`) needs none of this: its file has no name and goes with the
//! process whatever ends it.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

/// The start of the name of a copy of standard input; the process id and `-` follow.
pub const STDIN_PREFIX: &str = "wiical-stdin-";

/// The named temporary files of this process that exist now.
static REGISTERED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn registered() -> MutexGuard<'static, Vec<PathBuf>> {
    // A panic while the list was held leaves a list still true: use it.
    REGISTERED
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A temporary file of this process, deleted when this is dropped, and by
/// [`remove_registered`] until then.
#[derive(Debug)]
pub struct OwnTemp {
    path: tempfile::TempPath,
}

impl OwnTemp {
    /// A new empty file in `dir`, named `wiical-stdin-<pid>-` and random characters, open for
    /// writing; registered.
    pub(crate) fn stdin_copy_in(dir: &Path) -> std::io::Result<(Self, std::fs::File)> {
        let prefix = format!("{STDIN_PREFIX}{}-", std::process::id());
        let named = tempfile::Builder::new().prefix(&prefix).tempfile_in(dir)?;
        let (file, path) = named.into_parts();
        registered().push(path.to_path_buf());
        Ok((Self { path }, file))
    }
}

impl std::ops::Deref for OwnTemp {
    type Target = Path;

    fn deref(&self) -> &Path {
        &self.path
    }
}

impl AsRef<Path> for OwnTemp {
    fn as_ref(&self) -> &Path {
        &self.path
    }
}

impl Drop for OwnTemp {
    /// Unregistered, then deleted (by the `TempPath` dropped after this).
    fn drop(&mut self) {
        let mut list = registered();
        if let Some(i) = list.iter().position(|p| p.as_path() == &*self.path) {
            list.swap_remove(i);
        }
    }
}

/// Deletes every registered temporary file that still exists (for a signal handler, just
/// before the process ends); how many were deleted. The list is left empty.
pub fn remove_registered() -> usize {
    registered()
        .drain(..)
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count()
}

/// Deletes the copies of standard input in `dir` that a process no longer running left
/// (named `wiical-stdin-<pid>-…` with a `pid` that no process has): the files deleted.
/// A file whose process may run (it exists, or cannot be asked about) is left alone, and so
/// is anything named otherwise (copies from versions before the pid was in the name).
/// A process id seen from another PID namespace sharing `dir` (containers sharing `/tmp`)
/// may be taken for gone; such a copy is then deleted while its process reads it, which
/// stops that process with a read error, not a wrong answer.
pub fn remove_stale(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let own = std::process::id();
    let mut removed = Vec::new();
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(stale_pid) else {
            continue;
        };
        let is_file = entry.file_type().is_ok_and(|t| t.is_file());
        if pid != own
            && is_file
            && !process_may_run(pid)
            && std::fs::remove_file(entry.path()).is_ok()
        {
            removed.push(entry.path());
        }
    }
    removed
}

/// The process id in a copy of standard input's name (`wiical-stdin-<pid>-…`).
fn stale_pid(name: &str) -> Option<u32> {
    let rest = name.strip_prefix(STDIN_PREFIX)?;
    let (pid, tail) = rest.split_once('-')?;
    let digits = !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit());
    (digits && !tail.is_empty())
        .then(|| pid.parse().ok())
        .flatten()
}

/// Whether a process `pid` may be running: `false` only when the system says there is none
/// (`kill(pid, 0)` fails with ESRCH).
#[cfg(unix)]
fn process_may_run(pid: u32) -> bool {
    let Some(pid) = i32::try_from(pid)
        .ok()
        .and_then(rustix::process::Pid::from_raw)
    else {
        return true;
    };
    !matches!(
        rustix::process::test_kill_process(pid),
        Err(rustix::io::Errno::SRCH)
    )
}

/// Whether a process `pid` may be running: always, where it cannot be asked.
#[cfg(not(unix))]
fn process_may_run(_pid: u32) -> bool {
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The process id is read from a copy's name only in the name's exact form.
    #[test]
    fn a_copys_process_id_is_read_from_its_name() {
        assert_eq!(stale_pid("wiical-stdin-1234-abXY12"), Some(1234));
        assert_eq!(stale_pid("wiical-stdin-abXY12"), None);
        assert_eq!(stale_pid("wiical-stdin-12a-x"), None);
        assert_eq!(stale_pid("wiical-stdin-12-"), None);
        assert_eq!(stale_pid("other-1234-x"), None);
    }

    /// A copy whose process has ended is deleted; one of a running process (this one, or its
    /// parent) and a file named otherwise are kept. A registered copy is deleted by
    /// [`remove_registered`], and unregistered when dropped.
    #[test]
    #[cfg(unix)]
    fn stale_copies_are_deleted_and_live_ones_kept() {
        let dir = tempfile::tempdir().unwrap();
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        assert!(!process_may_run(dead), "process {dead} still runs");
        let parent = std::os::unix::process::parent_id();
        let names = [
            format!("{STDIN_PREFIX}{dead}-aaaa"),
            format!("{STDIN_PREFIX}{parent}-bbbb"),
            format!("{STDIN_PREFIX}{}-cccc", std::process::id()),
            format!("{STDIN_PREFIX}dddd"),
        ];
        for n in &names {
            std::fs::write(dir.path().join(n), "1,2,3\n").unwrap();
        }
        assert_eq!(remove_stale(dir.path()), vec![dir.path().join(&names[0])]);
        for n in &names[1..] {
            assert!(dir.path().join(n).exists(), "{n} deleted");
        }
        let (copy, _file) = OwnTemp::stdin_copy_in(dir.path()).unwrap();
        let path = copy.to_path_buf();
        assert!(path.exists());
        let (kept, _f) = OwnTemp::stdin_copy_in(dir.path()).unwrap();
        drop(kept);
        assert!(registered().contains(&path));
        assert!(remove_registered() >= 1);
        assert!(!path.exists());
        drop(copy);
        assert!(!registered().contains(&path));
    }
}

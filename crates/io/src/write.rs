//! Writing output files: every file the engine or the CLI writes goes through
//! [`write_with`] (or [`write_file`]), so that no failure can leave a half-written file where
//! a good one was.
//!
//! How: the bytes go to a temporary file in the target's own directory (so the final rename
//! never crosses a file system), which is flushed and `fsync`ed, then renamed over the target
//! in one step; the directory is `fsync`ed too so the rename itself survives a power cut. If
//! anything fails before the rename (a full disk, a file-size limit, an error while the
//! caller produces the bytes) the temporary file is deleted and the target keeps its old
//! bytes. A symbolic link as target is followed (the file it points to is replaced, the link
//! kept); anything that is not a regular file (`/dev/null`, a directory) is refused rather
//! than replaced by a rename.
//!
//! [`check_outputs`] refuses, before anything is opened, outputs that are one of the inputs
//! or each other (same file by device and inode where it exists, by canonical directory and
//! name where it does not yet).

use crate::error::output::OutputError;
use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes `bytes` to `path` atomically (created or replaced; see the module docs).
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    write_with(path, |w| w.write_all(bytes))
}

/// Writes what `fill` produces to `path` atomically: `fill` writes into a buffered temporary
/// file; only when it returns `Ok` and the data are on disk does the file replace `path`.
/// An error from `fill` (or from the disk) leaves `path` untouched.
pub fn write_with<F>(path: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut dyn Write) -> std::io::Result<()>,
{
    let pending = PendingFile::create(path)?;
    let mut out = std::io::BufWriter::new(pending.file());
    fill(&mut out).map_err(|e| pending.error(e))?;
    out.flush().map_err(|e| pending.error(e))?;
    drop(out);
    pending.commit()
}

/// A large output written as it is produced (a corrected recording of hundreds of millions of
/// rows, which [`write_with`] would take as one closure): bytes go through a buffer of
/// [`STREAM_BUFFER_BYTES`] into the temporary file of a [`PendingFile`], and
/// [`AtomicWriter::commit`] flushes, `fsync`s and renames it over the target. Dropped without
/// a commit (a check that fails after half the rows were written) the temporary file is
/// deleted and the target keeps its old bytes: the same rule as [`write_with`].
#[derive(Debug)]
pub struct AtomicWriter {
    out: std::io::BufWriter<std::fs::File>,
    pending: PendingFile,
}

/// Buffer of an [`AtomicWriter`], bytes: large enough that the writes are few system calls.
pub const STREAM_BUFFER_BYTES: usize = 1 << 20;

impl AtomicWriter {
    /// Opens the temporary file next to `path` (nothing at `path` changes yet).
    pub fn create(path: &Path) -> Result<Self> {
        let pending = PendingFile::create(path)?;
        let file = pending.file().try_clone().map_err(|e| pending.error(e))?;
        Ok(Self {
            out: std::io::BufWriter::with_capacity(STREAM_BUFFER_BYTES, file),
            pending,
        })
    }

    /// An I/O error of this writer as a write error naming the target.
    pub fn error(&self, source: std::io::Error) -> Error {
        self.pending.error(source)
    }

    /// Flushes the buffer and replaces the target with the file written ([`PendingFile::commit`]).
    pub fn commit(mut self) -> Result<()> {
        self.out.flush().map_err(|e| self.pending.error(e))?;
        drop(self.out);
        self.pending.commit()
    }
}

impl Write for AtomicWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.out.write(buf)
    }

    fn write_all(&mut self, buf: &[u8]) -> std::io::Result<()> {
        self.out.write_all(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// A file being written for a long time (a capture): the bytes go to a temporary file next
/// to the target, which replaces the target only on [`PendingFile::commit`]. Dropped without
/// a commit, the temporary file is deleted; [`PendingFile::keep_aside`] keeps it under its
/// temporary name instead (a partial recording that must not replace an existing file).
#[derive(Debug)]
pub struct PendingFile {
    tmp: tempfile::NamedTempFile,
    target: PathBuf,
    given: PathBuf,
    existed: bool,
}

impl PendingFile {
    /// Opens the temporary file next to `path` (nothing at `path` changes yet).
    pub fn create(path: &Path) -> Result<Self> {
        let target = resolve_target(path)?;
        let existed = target.exists();
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let prefix = format!(".{name}.");
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).suffix(".tmp");
        set_permissions(&mut builder, &target);
        let tmp = builder
            .tempfile_in(&dir)
            .map_err(|source| OutputError::Write {
                path: path.into(),
                source,
            })?;
        Ok(Self {
            tmp,
            target,
            given: path.to_path_buf(),
            existed,
        })
    }

    /// The temporary file to write into.
    pub fn file(&self) -> &std::fs::File {
        self.tmp.as_file()
    }

    /// True when a file existed at the target when this was created.
    pub fn target_existed(&self) -> bool {
        self.existed
    }

    /// The target path as given.
    pub fn path(&self) -> &Path {
        &self.given
    }

    /// An I/O error as a write error of the target.
    pub fn error(&self, source: std::io::Error) -> Error {
        OutputError::Write {
            path: self.given.clone(),
            source,
        }
        .into()
    }

    /// `fsync`s the data and renames the temporary file over the target (then `fsync`s the
    /// directory).
    pub fn commit(self) -> Result<()> {
        self.tmp.as_file().sync_all().map_err(|e| self.error(e))?;
        let given = self.given.clone();
        let dir = self.target.parent().map(Path::to_path_buf);
        self.tmp
            .persist(&self.target)
            .map_err(|e| OutputError::Write {
                path: given.clone(),
                source: e.error,
            })?;
        match dir {
            Some(d) if !d.as_os_str().is_empty() => sync_dir(&d),
            _ => sync_dir(Path::new(".")),
        }
        .map_err(|source| {
            OutputError::Write {
                path: given,
                source,
            }
            .into()
        })
    }

    /// `fsync`s the data and keeps the temporary file under its own name, leaving the target
    /// untouched; returns where the data are.
    pub fn keep_aside(self) -> Result<PathBuf> {
        self.tmp.as_file().sync_all().map_err(|e| self.error(e))?;
        let given = self.given.clone();
        let (_, path) = self.tmp.keep().map_err(|e| OutputError::Write {
            path: given,
            source: e.error,
        })?;
        Ok(path)
    }
}

/// The file to replace: `path`, or what it links to; refused if it exists and is not a
/// regular file.
fn resolve_target(path: &Path) -> Result<PathBuf> {
    match std::fs::metadata(path) {
        Ok(meta) if meta.is_file() => std::fs::canonicalize(path).map_err(|source| {
            OutputError::Write {
                path: path.into(),
                source,
            }
            .into()
        }),
        Ok(_) => Err(OutputError::OutputNotRegular {
            output: path.into(),
        }
        .into()),
        Err(_) => Ok(path.to_path_buf()),
    }
}

/// New files get `0666` less the umask (as `File::create`); a replaced file keeps its mode.
#[cfg(unix)]
fn set_permissions(builder: &mut tempfile::Builder, target: &Path) {
    use std::os::unix::fs::PermissionsExt;
    let perms = match std::fs::metadata(target) {
        Ok(meta) => meta.permissions(),
        Err(_) => std::fs::Permissions::from_mode(0o666),
    };
    builder.permissions(perms);
}

#[cfg(not(unix))]
fn set_permissions(_: &mut tempfile::Builder, _: &Path) {}

/// `fsync` of the directory, so the rename is durable (a no-op where directories cannot be
/// opened).
fn sync_dir(dir: &Path) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        std::fs::File::open(dir)?.sync_all()?;
    }
    #[cfg(not(unix))]
    let _ = dir;
    Ok(())
}

/// What identifies a file: device and inode for one that exists, canonical directory plus
/// name for one that does not exist yet.
#[derive(Debug, PartialEq, Eq)]
enum FileKey {
    Inode(u64, u64),
    Path(PathBuf),
}

fn file_key(path: &Path) -> Option<FileKey> {
    if let Ok(meta) = std::fs::metadata(path) {
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            return Some(FileKey::Inode(meta.dev(), meta.ino()));
        }
        #[cfg(not(unix))]
        {
            let _ = meta;
            return std::fs::canonicalize(path).ok().map(FileKey::Path);
        }
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let dir = std::fs::canonicalize(dir).ok()?;
    Some(FileKey::Path(dir.join(path.file_name()?)))
}

/// The file standard input reads (`-` as an input), by device and inode: in
/// `wiical correct CAL - --out rec.csv < rec.csv` the recording being read is named only
/// through file descriptor 0, so comparing names alone would let the output replace it.
/// `None` when descriptor 0 is closed or cannot be examined (nothing to compare).
fn stdin_key() -> Option<FileKey> {
    #[cfg(unix)]
    {
        use std::os::fd::AsFd;
        use std::os::unix::fs::MetadataExt;
        let fd = std::io::stdin().as_fd().try_clone_to_owned().ok()?;
        let meta = std::fs::File::from(fd).metadata().ok()?;
        Some(FileKey::Inode(meta.dev(), meta.ino()))
    }
    #[cfg(not(unix))]
    None
}

/// Refuses outputs that are one of the inputs, or each other, before anything is written.
/// `-` (standard input) as an input is compared by what descriptor 0 reads (`stdin_key`).
/// Paths whose directory does not exist are not compared (writing them fails later with a
/// clear error).
pub fn check_outputs(inputs: &[&Path], outputs: &[&Path]) -> Result<()> {
    let input_keys: Vec<(&Path, FileKey)> = inputs
        .iter()
        .filter_map(|p| {
            let key = if p.as_os_str() == "-" {
                stdin_key()
            } else {
                file_key(p)
            };
            key.map(|k| (*p, k))
        })
        .collect();
    let mut seen: Vec<(&Path, FileKey)> = Vec::new();
    for out in outputs {
        // Every output's place is checked before any is written, so that a command with two
        // outputs writes both or neither.
        if out.as_os_str() == "-" {
            return Err(OutputError::OutputIsStdout {
                output: out.to_path_buf(),
            }
            .into());
        }
        let dir = match out.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !dir.is_dir() {
            return Err(OutputError::OutputDirMissing {
                output: out.to_path_buf(),
            }
            .into());
        }
        if std::fs::metadata(out).is_ok_and(|m| !m.is_file()) {
            return Err(OutputError::OutputNotRegular {
                output: out.to_path_buf(),
            }
            .into());
        }
        let Some(key) = file_key(out) else { continue };
        if let Some((input, _)) = input_keys.iter().find(|(_, k)| *k == key) {
            if input.as_os_str() == "-" {
                return Err(OutputError::OutputIsStdin {
                    output: out.to_path_buf(),
                }
                .into());
            }
            return Err(OutputError::OutputIsInput {
                output: out.to_path_buf(),
                input: input.to_path_buf(),
            }
            .into());
        }
        if let Some((first, _)) = seen.iter().find(|(_, k)| *k == key) {
            return Err(OutputError::OutputsCollide {
                first: first.to_path_buf(),
                second: out.to_path_buf(),
            }
            .into());
        }
        seen.push((out, key));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A new scratch directory, removed when the test ends (the guard is kept alive by the
    /// caller's binding).
    fn scratch(tag: &str) -> (tempfile::TempDir, PathBuf) {
        let guard = tempfile::Builder::new()
            .prefix(&format!("wiical-write-{tag}-"))
            .tempdir()
            .unwrap();
        let dir = guard.path().to_path_buf();
        (guard, dir)
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn creates_and_replaces() {
        let (_guard, dir) = scratch("replace");
        let p = dir.join("a.json");
        write_file(&p, b"first").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"first");
        write_file(&p, b"second, longer").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"second, longer");
        assert_eq!(entries(&dir), vec!["a.json"], "no temporary file left");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_failure_while_writing_keeps_the_old_bytes() {
        let (_guard, dir) = scratch("fail");
        let p = dir.join("good_cal.json");
        std::fs::write(&p, b"{\"the\": \"good calibration\"}").unwrap();
        // The failpoint: the producer writes half its output, then fails (as a full disk or
        // a file-size limit would).
        let e = write_with(&p, |w| {
            w.write_all(&[b'x'; 100_000])?;
            Err(std::io::Error::other("simulated: no space left"))
        })
        .unwrap_err();
        assert!(e.to_string().starts_with("cannot write"), "{e}");
        assert_eq!(
            std::fs::read(&p).unwrap(),
            b"{\"the\": \"good calibration\"}"
        );
        assert_eq!(
            entries(&dir),
            vec!["good_cal.json"],
            "temporary file removed"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Written as it is produced: nothing at the target until the commit; dropped uncommitted,
    /// the old bytes stay and no temporary file is left.
    #[test]
    fn a_streamed_file_appears_only_when_committed() {
        let (_guard, dir) = scratch("stream");
        let p = dir.join("out.csv");
        std::fs::write(&p, b"old").unwrap();
        let mut w = AtomicWriter::create(&p).unwrap();
        for i in 0..100_000 {
            writeln!(w, "{i}").unwrap();
        }
        w.flush().unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        drop(w);
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        assert_eq!(entries(&dir), vec!["out.csv"], "temporary file removed");
        let mut w = AtomicWriter::create(&p).unwrap();
        w.write_all(b"new\n").unwrap();
        w.commit().unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new\n");
        assert_eq!(entries(&dir), vec!["out.csv"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_missing_directory_is_an_error_not_a_panic() {
        let (_guard, dir) = scratch("nodir");
        let e = write_file(&dir.join("no/such/dir/x.json"), b"x").unwrap_err();
        assert!(e.to_string().starts_with("cannot write"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn devices_are_refused_and_links_followed() {
        let e = write_file(Path::new("/dev/null"), b"x").unwrap_err();
        assert!(
            matches!(e, Error::Output(OutputError::OutputNotRegular { .. })),
            "{e}"
        );
        assert!(!e.to_string().contains("standard input"), "{e}");
        let (_guard, dir) = scratch("link");
        let real = dir.join("real.json");
        std::fs::write(&real, b"old").unwrap();
        let link = dir.join("link.json");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write_file(&link, b"new").unwrap();
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn a_replaced_file_keeps_its_mode() {
        use std::os::unix::fs::PermissionsExt;
        let (_guard, dir) = scratch("mode");
        let p = dir.join("a.csv");
        std::fs::write(&p, b"old").unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o640)).unwrap();
        write_file(&p, b"new").unwrap();
        let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o640);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn outputs_equal_to_an_input_or_each_other_are_refused() {
        let (_guard, dir) = scratch("distinct");
        let rec = dir.join("victim.csv");
        std::fs::write(&rec, b"t,x,y,z\n").unwrap();
        let other = dir.join("out.json");
        // Same file under another spelling.
        let respelled = dir.join(".").join("victim.csv");
        let e = check_outputs(&[&rec], &[&other, &respelled]).unwrap_err();
        assert!(
            matches!(e, Error::Output(OutputError::OutputIsInput { .. })),
            "{e}"
        );
        // Two outputs, neither existing yet, one file.
        let plot = dir.join("sub/../out.json");
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let e = check_outputs(&[&rec], &[&other, &plot]).unwrap_err();
        assert!(
            matches!(e, Error::Output(OutputError::OutputsCollide { .. })),
            "{e}"
        );
        assert!(check_outputs(&[&rec, Path::new("-")], &[&other, &dir.join("p.svg")]).is_ok());
        #[cfg(unix)]
        {
            // A hard link is the same file under another name.
            let hard = dir.join("hard.csv");
            std::fs::hard_link(&rec, &hard).unwrap();
            assert!(check_outputs(&[&rec], &[&hard]).is_err());
        }
        assert_eq!(std::fs::read(&rec).unwrap(), b"t,x,y,z\n");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

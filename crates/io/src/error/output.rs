//! The output stage's error: why a file was not written, or a calibration file (the format the
//! output stage writes) not read back. Joined into [`super::Error`] as
//! `Error::Output` (and into `wiical_analysis::Error` as its `Error::Output`).

use std::path::PathBuf;

/// Why an output was not written: the write failed (nothing half-written is left), or the
/// output was refused before anything was written (standard output, a missing directory, an
/// input, two outputs naming one file, a calibration that does not validate); or a calibration
/// file read back is not one. Joined into [`super::Error::Output`].
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// A file could not be written.
    #[error("cannot write {}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// An output named `-`.
    #[error("{}: standard output carries the report; give a file name for this output", output.display())]
    OutputIsStdout {
        /// The output as given.
        output: PathBuf,
    },
    /// An output in a directory that does not exist.
    #[error("cannot write {}: its directory does not exist (nothing was written)", output.display())]
    OutputDirMissing {
        /// The output as given.
        output: PathBuf,
    },
    /// An output names something that is not a regular file (a directory, a device, a
    /// pipe): it is never replaced nor written into.
    #[error("refusing to write {}: it is not a regular file (a directory, device or pipe); give the name of a file to create or replace", output.display())]
    OutputNotRegular {
        /// The output as given.
        output: PathBuf,
    },
    /// A batch results file that exists and is not one (its first line is not a batch
    /// line): batch appends only to its own results.
    #[error("refusing to append to {}: it exists and is not a batch results file (its first line is not a batch line); give a new file name, or the results file of an earlier batch run to resume it", out.display())]
    NotBatchResults {
        /// The results file as given.
        out: PathBuf,
    },
    /// A batch results file another batch run is writing (it holds the file's lock): two runs
    /// on one results file would each do every file, and their lines would interleave.
    #[error("refusing to write {}: another wiical batch run is writing it; wait for that run to end (then run again to resume), or give another --out", out.display())]
    ResultsInUse {
        /// The results file as given.
        out: PathBuf,
    },
    /// An output would replace one of the command's inputs.
    #[error("refusing to write {}: it is the input {} (choose another output file)", output.display(), input.display())]
    OutputIsInput {
        /// The output asked for.
        output: PathBuf,
        /// The input it is the same file as.
        input: PathBuf,
    },
    /// An output is the file standard input reads (`-` as the input, the recording
    /// redirected from that file): writing it would replace the recording being read.
    #[error("refusing to write {}: it is the file standard input reads (the recording given as -); choose another output file", output.display())]
    OutputIsStdin {
        /// The output asked for.
        output: PathBuf,
    },
    /// Two outputs of one command are the same file (one would overwrite the other).
    #[error("refusing to write {} twice: it is also given as {} (choose different output files)", first.display(), second.display())]
    OutputsCollide {
        /// One output.
        first: PathBuf,
        /// Another output naming the same file.
        second: PathBuf,
    },
    /// Refusing to write a calibration that does not validate.
    #[error("refusing to write an invalid calibration: {0}")]
    RefuseInvalidCalibration(wiical_core::Error),
    /// Refusing to write host terms that do not validate (the sentence names the entry).
    #[error("refusing to write invalid host terms: {0}")]
    RefuseInvalidHostTerms(String),
    /// Not a calibration JSON.
    #[error("{} is not a calibration JSON", path.display())]
    NotCalibrationJson {
        /// The file.
        path: PathBuf,
        /// The parser's complaint.
        #[source]
        source: serde_json::Error,
    },
    /// A calibration file that does not validate.
    #[error("{}: invalid calibration: {cause}", path.display())]
    InvalidCalibrationFile {
        /// The file.
        path: PathBuf,
        /// Why.
        cause: wiical_core::Error,
    },
    /// A gyro calibration file that cannot be read as one (the sentence names the key).
    #[error("{}: not a usable gyro calibration: {cause}", path.display())]
    InvalidGyroCalibrationFile {
        /// The file.
        path: PathBuf,
        /// Why, in one sentence.
        cause: String,
    },
}

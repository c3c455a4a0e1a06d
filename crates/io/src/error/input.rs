//! The input stage's error: why a file could not be read or parsed into a recording (the file,
//! line and column named in each sentence). Joined into [`super::Error`] as
//! `Error::Input` (and into `wiical_analysis::Error` as its `Error::Input`).

use std::path::PathBuf;

/// Why an input could not be loaded: reading it (size caps, gzip, UTF-8), a raw accelerometer
/// file's blocks, or a field, line or header of a text/CSV/GRT/window-mean file. Joined into
/// [`super::Error::Input`]; the file itself is named by the `Error::InFile` around it (the
/// analysis engine's).
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// The file could not be read.
    #[error("cannot read {}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// An input larger than the cap for its kind.
    #[error("{} is larger than {limit_mib} MiB, the limit for this kind of file", path.display())]
    TooLarge {
        /// The file (`-` for standard input).
        path: PathBuf,
        /// The cap, MiB.
        limit_mib: u64,
    },
    /// A text file too large to read whole holds what its pieces cannot be read with (a quote
    /// in a data row, a lone carriage return, a comment mark inside a row, a line too long).
    #[error("{} is larger than {limit_mib} MiB, so it is read in pieces, which takes plain delimited rows (quotes only in the header, comments only as whole lines starting with # or %), but {why}", path.display())]
    NotPlainInPieces {
        /// The file.
        path: PathBuf,
        /// The size from which a file is read only in pieces, MiB.
        limit_mib: u64,
        /// What is where, and what to do.
        why: String,
    },
    /// A text line too long to be part of a recording.
    #[error("line {line} is {bytes} bytes long (the limit is {max}): not a recording's line (a file without line breaks?)")]
    LineTooLong {
        /// 1-based line.
        line: usize,
        /// Its length.
        bytes: usize,
        /// The limit.
        max: usize,
    },
    /// A gzip file that cannot be decompressed (corrupt or cut short).
    #[error("cannot decompress {} (gzip): {cause}", path.display())]
    Gzip {
        /// The file.
        path: PathBuf,
        /// Why.
        cause: std::io::Error,
    },
    /// A gzip file whose content is larger than the cap.
    #[error("{} decompresses to more than {limit_mib} MiB: split the recording or decompress only the part to analyse", path.display())]
    GzipTooLarge {
        /// The file.
        path: PathBuf,
        /// The cap, MiB.
        limit_mib: u64,
    },
    /// The file is not UTF-8 text.
    #[error("{} is not UTF-8 text: {why}", path.display())]
    NotUtf8 {
        /// The file.
        path: PathBuf,
        /// Where it stops being UTF-8, or which other encoding it is, and what to do.
        why: String,
    },
    /// Text whose first bytes hold no digit: no recording's rows (a stream such as `yes`).
    #[error("the first {bytes} bytes of {} hold no digit: not a recording's rows", path.display())]
    NoDigits {
        /// The file (`-` for standard input).
        path: PathBuf,
        /// Bytes looked at.
        bytes: usize,
    },
    /// Standard input copied to a temporary file (too long to hold) passed a bound: the most
    /// copied, or the free space kept on the temporary directory's disk.
    #[error("{} (standard input) was copied to {} to be read in passes, but {why}: save it to a file on a disk with room and give that file's path", path.display(), dir.display())]
    SpoolBound {
        /// `-`.
        path: PathBuf,
        /// The temporary directory.
        dir: PathBuf,
        /// Which bound, with the numbers and the variable that sets it.
        why: String,
    },
    /// Standard input too long to hold could not be copied to the temporary directory.
    #[error("standard input is too long to hold in memory, so it is copied to a temporary file in {} ({}) to be read in passes, but {why}: set TMPDIR to a writable directory with room for it, or save the input to a file and give that file's path", dir.display(), if *from_tmpdir { "TMPDIR" } else { "the system's temporary directory: TMPDIR is not set" })]
    StdinCopy {
        /// The temporary directory.
        dir: PathBuf,
        /// Whether `TMPDIR` named it.
        from_tmpdir: bool,
        /// What is wrong with it.
        why: String,
    },
    /// The rows a file read in passes keeps for its later passes (in a temporary file once
    /// they pass the memory kept for them) could not be written or read back there.
    #[error("its rows are kept in a temporary file in {} ({}) for the passes that read them, but {why}: set TMPDIR to a writable directory with room for them, or free space there", dir.display(), if *from_tmpdir { "TMPDIR" } else { "the system's temporary directory: TMPDIR is not set" })]
    RowsNotKept {
        /// The temporary directory.
        dir: PathBuf,
        /// Whether `TMPDIR` named it.
        from_tmpdir: bool,
        /// What failed, in words.
        why: String,
    },
    /// A file named or shaped like a raw format that is not one (wrong magic, bad header).
    #[error("not a readable {format} file: {why}")]
    RawHeader {
        /// `Axivity .cwa` or `GENEActiv .bin`.
        format: &'static str,
        /// What is wrong, one clause.
        why: String,
    },
    /// A raw file without one readable data block.
    #[error("none of its {blocks} data blocks is readable ({skipped} skipped: {why})")]
    RawNoData {
        /// Data blocks (pages) in the file.
        blocks: usize,
        /// Blocks skipped.
        skipped: usize,
        /// Why they were skipped.
        why: String,
    },
    /// A channel asked for (`--columns`, the gyroscope) that the raw file does not record.
    #[error("the file records {have}; {wanted} was asked for")]
    RawNoChannel {
        /// The channels of the file.
        have: String,
        /// What was asked for.
        wanted: String,
    },
    /// GGIRread's block selection: every block of the requested range fails its checksum.
    #[error("blocks {start}..{end}: all requested blocks are corrupt")]
    AllBlocksCorrupt {
        /// First block asked for.
        start: usize,
        /// End block (exclusive) asked for.
        end: usize,
    },
    /// GGIRread's block selection: more consecutive corrupt blocks than it accepts.
    #[error("more than {max} consecutive corrupt blocks from block #{block}")]
    TooManyCorruptBlocks {
        /// The first of them.
        block: usize,
        /// The most accepted.
        max: usize,
    },
    /// GGIRread's grid would be far longer than the blocks' samples (timestamps years apart).
    #[error("blocks {start}..{end} span {rows} grid rows at the file's rate, far more than their samples: their timestamps are inconsistent")]
    GridTooLong {
        /// First block asked for.
        start: usize,
        /// End block asked for.
        end: usize,
        /// Rows the grid would have.
        rows: f64,
    },
    /// Too few still 10-s epochs in a raw recording for the autocalibration.
    #[error("found {found} still 10-s epochs (SD < 13 mg on every axis, |mean| < 2 g) among {examined} complete epochs in {span_s:.0} s of data, but the autocalibration needs at least {needed}: {cause}")]
    TooFewStillEpochs {
        /// Epochs found.
        found: usize,
        /// Complete 10-s epochs examined.
        examined: usize,
        /// Epochs needed.
        needed: usize,
        /// Seconds of data searched.
        span_s: f64,
        /// What would give more: a longer recording, or what was wrong with this one (blocks
        /// skipped, a rate not held).
        cause: String,
    },
    /// No data lines at all.
    #[error("file is empty (no data lines)")]
    Empty,
    /// Explicit axis columns were asked for, but the file has no header to name them.
    #[error("choosing the axis columns needs a CSV file with a header; this file has no header")]
    ColumnsNeedHeader,
    /// A field is not a number.
    #[error("line {line}: column '{column}': '{text}' is not a number")]
    NotANumber {
        /// 1-based line.
        line: usize,
        /// Column name.
        column: String,
        /// The field.
        text: String,
    },
    /// A field is a number too large for a double (it would read as infinite).
    #[error("line {line}: column '{column}': value '{text}' is beyond the range of a double (±1.8e308): no reading is that large; check the column or the number's exponent")]
    BeyondDouble {
        /// 1-based line.
        line: usize,
        /// Column name.
        column: String,
        /// The field.
        text: String,
    },
    /// A field is NaN or infinite.
    #[error("line {line}: column '{column}': value '{text}' is not finite")]
    NotFinite {
        /// 1-based line.
        line: usize,
        /// Column name.
        column: String,
        /// The field.
        text: String,
    },
    /// A header-less line has a different number of columns from the first one.
    #[error("line {line}: expected {expected} columns like the first data line, found {found}")]
    RaggedLine {
        /// 1-based line.
        line: usize,
        /// Columns of the first data line.
        expected: usize,
        /// Columns of this one.
        found: usize,
    },
    /// A GRT file whose samples are not 3-dimensional.
    #[error("line {line}: GRT file with NumDimensions {text}; only 3-axis data can be calibrated")]
    GrtDimensions {
        /// 1-based line.
        line: usize,
        /// The value given.
        text: String,
    },
    /// A GRT file without the `NumDimensions:` line before its data.
    #[error("GRT file without a NumDimensions line before LabelledTrainingData")]
    GrtNoDimensions,
    /// A header-less file with a column count that has no meaning.
    #[error("line {line}: {found} columns without a header; expected 3 (x y z), 4 (t x y z) or 5 (t x y z temp)")]
    HeaderlessColumns {
        /// 1-based line.
        line: usize,
        /// Columns found.
        found: usize,
    },
    /// Only comments.
    #[error("file has no data rows")]
    NoDataRows,
    /// The CSV reader failed.
    #[error("malformed CSV")]
    MalformedCsv(#[source] csv::Error),
    /// Numbers before any header in a CSV file.
    #[error("line {line}: data before any header; a CSV file needs a header naming its columns (e.g. t,x,y,z)")]
    DataBeforeHeader {
        /// 1-based line.
        line: usize,
    },
    /// `Fs,0`, negative, not a number, below 1 mHz or above 1 MHz.
    #[error("line {line}: the sample rate '{text}' must be a number from 0.001 Hz to 1 MHz")]
    BadSampleRate {
        /// 1-based line.
        line: usize,
        /// The rate as written.
        text: String,
    },
    /// A sensor value beyond ±10¹²: a corrupt cell (no sensor reports such numbers).
    #[error("line {line}, column {column}: the reading {text} is beyond ±1e12, which no sensor reports; the cell is corrupt or in the wrong column")]
    ReadingOutOfRange {
        /// 1-based line.
        line: usize,
        /// Column name.
        column: String,
        /// The text of the cell.
        text: String,
    },
    /// Every reading is numerically zero.
    #[error("every reading is smaller than 1e-9 in magnitude (largest {largest:.2e}): the recording carries no measurable signal; check its unit or scale")]
    ReadingsTooSmall {
        /// The largest |value| seen.
        largest: f64,
    },
    /// A CSV row with a different number of fields from the header.
    #[error("line {line}: expected {expected} fields like the header, found {found}")]
    RaggedRow {
        /// 1-based line.
        line: usize,
        /// Header fields.
        expected: usize,
        /// Fields of this row.
        found: usize,
    },
    /// Metadata only.
    #[error("no header line found")]
    NoHeader,
    /// A file read in passes (its samples streamed, never held) changed between them.
    #[error("the file changed while it was being read (its size, modification time or content differ from the first pass's); read it again once it is complete")]
    ChangedWhileRead,
    /// A header and nothing else.
    #[error("file has a header but no data rows")]
    HeaderOnly,
    /// A window-mean table's standard deviation is negative, NaN or infinite.
    #[error("line {line}: column '{column}': window standard deviation '{text}' must be a finite number ≥ 0")]
    WindowSdInvalid {
        /// 1-based line.
        line: usize,
        /// Column name.
        column: String,
        /// The field.
        text: String,
    },
    /// A window-mean table's sample count is not an integer ≥ 2.
    #[error("line {line}: column '{column}': sample count '{text}' must be an integer ≥ 2 (a window averages at least two samples)")]
    WindowCountInvalid {
        /// 1-based line.
        line: usize,
        /// Column name.
        column: String,
        /// The field.
        text: String,
    },
    /// A window-mean table names standard-deviation columns for some axes but not all.
    #[error("window-mean table: standard-deviation column(s) {found} found but none for axis {axis} (e.g. sd{axis}); give all three or none")]
    WindowSdColumnMissing {
        /// The SD columns found.
        found: String,
        /// The axis without one.
        axis: &'static str,
    },
    /// The SD/count columns were read for a different number of rows than the means.
    #[error("window-mean table: {values} rows of SD/count values for {rows} rows of means")]
    WindowRowsMismatch {
        /// Rows of means.
        rows: usize,
        /// Rows of SD/count values.
        values: usize,
    },
    /// A window-mean table with more rows than the analysis accepts.
    #[error("window-mean table with {rows} rows: at most {max} windows are analysed")]
    TooManyWindowRows {
        /// Rows in the file.
        rows: usize,
        /// The cap.
        max: usize,
    },
    /// The same column name twice.
    #[error("column '{name}' appears twice in the header")]
    DuplicateColumn {
        /// The name.
        name: String,
    },
    /// A requested column is not in the header.
    #[error("column '{name}' not found; the header has: {header}")]
    ColumnNotFound {
        /// The requested name.
        name: String,
        /// The header, comma-separated.
        header: String,
    },
    /// The time column goes back.
    #[error("line {line}: column '{column}': time goes from {previous} back to {value}; rows must be in time order")]
    TimeNotIncreasing {
        /// 1-based line.
        line: usize,
        /// The time column's name.
        column: String,
        /// Time on the previous row.
        previous: f64,
        /// Time on this row.
        value: f64,
    },
    /// An axis column chosen is the time, temperature or label column.
    #[error("column '{name}' is not a sensor axis (it is the time, temperature or pose column); choose three axis columns")]
    AxisIsNotAnAxis {
        /// The column.
        name: String,
    },
    /// The same column chosen for two axes.
    #[error("the axis columns {columns} name one column twice; choose three different columns")]
    AxisTwice {
        /// The chosen columns, comma-separated.
        columns: String,
    },
    /// No recognisable axis columns.
    #[error("no x/y/z columns recognised in the header ({header}); name them x,y,z (or ax,ay,az / mx,my,mz / gx,gy,gz), or choose the axis columns explicitly")]
    NoAxisColumns {
        /// The header, comma-separated.
        header: String,
    },
    /// More samples than a command that holds its whole recording keeps
    /// (`wiical_analysis::input::front_door::HoldLimit`): refused as they are read, before the memory
    /// they would take is taken.
    #[error("it holds more than {limit} samples, the most `wiical {command}` keeps in memory; {instead}")]
    TooManyToHold {
        /// The bound, samples.
        limit: usize,
        /// The command that holds the recording.
        command: &'static str,
        /// What reads it instead.
        instead: &'static str,
    },
}

impl InputError {
    /// The file this error names, for `wiical_analysis::Error::renaming` (`None` for the errors
    /// about a file's content, which the `Error::InFile` around them names).
    pub fn file_mut(&mut self) -> Option<&mut PathBuf> {
        use InputError as E;
        match self {
            E::Read { path, .. }
            | E::TooLarge { path, .. }
            | E::NotPlainInPieces { path, .. }
            | E::Gzip { path, .. }
            | E::GzipTooLarge { path, .. }
            | E::NotUtf8 { path, .. }
            | E::NoDigits { path, .. } => Some(path),
            _ => None,
        }
    }
}

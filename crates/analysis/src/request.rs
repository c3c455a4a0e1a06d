//! What every pipeline's request shares (issue 48): where its samples come from — a file the
//! loader reads, or a recording the caller holds (the Python package's arrays) — and the
//! checks of the settings both doors take. Each pipeline's request type lives in its room
//! (`gyro/request.rs`, `magnetometer/request.rs`, `noise/request.rs`, `tempcal/request.rs`)
//! and is re-exported at the crate root with the one function that runs it.

use crate::input::read_options::ReadOptions;
use crate::input::recording::Recording;
use crate::input::text::LoadOptions;
use std::borrow::Cow;
use std::path::PathBuf;

/// The samples a request analyses: a file (read as the command line reads it, `-` for
/// standard input) or a recording already held.
#[derive(Debug, Clone)]
pub enum SampleInput {
    /// A recording file.
    File(PathBuf),
    /// Samples the caller holds (checked as the loader checks a file's rows:
    /// [`crate::arrays::recording`]); boxed, the variants' sizes apart.
    Held(Box<Recording>),
}

impl From<PathBuf> for SampleInput {
    fn from(p: PathBuf) -> Self {
        SampleInput::File(p)
    }
}

impl From<&std::path::Path> for SampleInput {
    fn from(p: &std::path::Path) -> Self {
        SampleInput::File(p.to_path_buf())
    }
}

impl From<&str> for SampleInput {
    fn from(p: &str) -> Self {
        SampleInput::File(p.into())
    }
}

impl From<Recording> for SampleInput {
    fn from(r: Recording) -> Self {
        SampleInput::Held(Box::new(r))
    }
}

/// Header names of three axis columns, given as a list (a flag's or a keyword's): refused
/// unless exactly three.
pub fn three_columns(columns: Option<&[String]>) -> crate::Result<Option<[String; 3]>> {
    match columns {
        None => Ok(None),
        Some([x, y, z]) => Ok(Some([x.clone(), y.clone(), z.clone()])),
        Some(other) => Err(crate::Error::ColumnsNotThree(other.to_vec())),
    }
}

/// The loader's options for `columns` (checked: three) read as `read` says.
pub fn load_options(columns: Option<&[String]>, read: ReadOptions) -> crate::Result<LoadOptions> {
    Ok(LoadOptions {
        columns: three_columns(columns)?,
        read,
        ..Default::default()
    })
}

/// The recording of `input` read whole with `opts` (a held one as it is, not copied).
pub(crate) fn held<'a>(
    input: &'a SampleInput,
    opts: &LoadOptions,
) -> crate::Result<Cow<'a, Recording>> {
    match input {
        SampleInput::File(path) => crate::load(path, opts).map(Cow::Owned),
        SampleInput::Held(rec) => Ok(Cow::Borrowed(rec.as_ref())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_are_three_or_none() {
        assert_eq!(three_columns(None).unwrap(), None);
        let three = ["a", "b", "c"].map(String::from);
        assert_eq!(three_columns(Some(&three)).unwrap(), Some(three.clone()));
        let two = ["a".to_string(), "b".to_string()];
        assert!(matches!(
            three_columns(Some(&two)),
            Err(crate::Error::ColumnsNotThree(n)) if n == two
        ));
    }
}

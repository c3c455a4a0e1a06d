//! The Gesture Recognition Toolkit's labelled-data text format (`.grt`), as GRT's Wii Remote
//! recordings are shipped: a `key: value` header block, then after `LabelledTrainingData:`
//! one sample per line, `class x y z` (tab- or space-separated). Only 3-dimensional files
//! are read, as a recording without time (GRT does not store one); the class labels are
//! gesture classes, not calibration poses, so they are counted for the note and dropped.

use crate::error::input::InputError;
use crate::error::Result;
use crate::input::recording::Recording;

/// The first line of a GRT labelled-classification file.
pub const MAGIC: &str = "GRT_LABELLED_CLASSIFICATION_DATA_FILE";

/// True when `first_line` (the file's first non-blank line) starts a GRT file.
pub fn is_grt(first_line: &str) -> bool {
    first_line.trim_start().starts_with(MAGIC)
}

/// Parses a GRT labelled-classification file (see the module docs).
pub fn parse(text: &str) -> Result<Recording> {
    let mut lines = text.lines().enumerate();
    let mut dims = None;
    for (i, line) in lines.by_ref() {
        let line = line.trim();
        if line == "LabelledTrainingData:" {
            break;
        }
        if let Some(v) = line.strip_prefix("NumDimensions:") {
            let d = v.trim().parse::<usize>().ok();
            if d != Some(3) {
                return Err(InputError::GrtDimensions {
                    line: i + 1,
                    text: crate::input::bounded::quote(v.trim()),
                }
                .into());
            }
            dims = d;
        }
    }
    if dims.is_none() {
        return Err(InputError::GrtNoDimensions.into());
    }
    let mut rec = Recording::default();
    let mut classes = std::collections::BTreeSet::new();
    for (i, line) in lines {
        let fields: Vec<&str> = line.split_ascii_whitespace().collect();
        if fields.is_empty() {
            continue;
        }
        if fields.len() != 4 {
            return Err(InputError::RaggedLine {
                line: i + 1,
                expected: 4,
                found: fields.len(),
            }
            .into());
        }
        classes.insert(fields[0].to_string());
        let mut xyz = [0.0; 3];
        for (a, (f, name)) in fields[1..].iter().zip(["x", "y", "z"]).enumerate() {
            xyz[a] = crate::input::bounded::parse_number(f, i + 1, name, false)?;
        }
        rec.xyz.push(xyz);
    }
    if rec.xyz.is_empty() {
        return Err(InputError::NoDataRows.into());
    }
    rec.axis_columns = ["x".into(), "y".into(), "z".into()];
    rec.info.push(format!(
        "GRT file: {} samples in {} gesture class(es), read as one recording without time (class labels dropped)",
        rec.len(),
        classes.len()
    ));
    Ok(rec)
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "GRT_LABELLED_CLASSIFICATION_DATA_FILE_V1.0\nDatasetName: t\nNumDimensions: 3\nLabelledTrainingData:\n";

    #[test]
    fn samples_are_read_and_labels_dropped() {
        let r = parse(&format!("{HEAD}1\t0.5\t0.25\t0.125\n2 1 2 3\n")).unwrap();
        assert_eq!(r.xyz, vec![[0.5, 0.25, 0.125], [1.0, 2.0, 3.0]]);
        assert!(r.t.is_none() && r.labels.is_none());
        assert!(r.info[0].contains("2 gesture class(es)"), "{:?}", r.info);
    }

    #[test]
    fn bad_files_name_the_line() {
        let e = parse(&HEAD.replace("NumDimensions: 3", "NumDimensions: 6")).unwrap_err();
        assert!(
            matches!(
                e,
                crate::Error::Input(InputError::GrtDimensions { line: 3, .. })
            ),
            "{e}"
        );
        let e = parse(&format!("{HEAD}1 0.5 0.25\n")).unwrap_err();
        assert!(
            matches!(
                e,
                crate::Error::Input(InputError::RaggedLine { line: 5, .. })
            ),
            "{e}"
        );
        let e = parse(&format!("{HEAD}1 0.5 nan 1\n")).unwrap_err();
        assert!(e.to_string().contains("line 5"), "{e}");
        assert!(matches!(
            parse(HEAD),
            Err(crate::Error::Input(InputError::NoDataRows))
        ));
        assert!(matches!(
            parse("GRT_LABELLED_CLASSIFICATION_DATA_FILE_V1.0\n1 2 3 4\n"),
            Err(crate::Error::Input(InputError::GrtNoDimensions))
        ));
    }
}

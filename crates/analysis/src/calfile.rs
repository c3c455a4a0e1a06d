//! The calibration file: a [`Calibration`] as pretty-printed JSON (what `wiical fit --out`,
//! `analyze --out`, `six-position --out` and `magfit --out` write and `wiical device put`
//! reads). Its keys are those of the core's serde derive (`bias`, `matrix`, `effects`).

use crate::error::{Error, Result};
use crate::write::write_file;
use std::path::Path;
use wiical_core::Calibration;

/// The JSON text of a calibration (pretty-printed, with a final newline).
pub fn to_json(cal: &Calibration) -> Result<String> {
    Ok(serde_json::to_string_pretty(cal)? + "\n")
}

/// Writes a calibration after checking it is valid (finite, invertible: what the adapter
/// accepts).
pub fn write_calibration(path: &Path, cal: &Calibration) -> Result<()> {
    cal.validate().map_err(Error::RefuseInvalidCalibration)?;
    write_calibration_unchecked(path, cal)
}

/// Writes a calibration as it is (e.g. one read back from a device, to be inspected).
pub fn write_calibration_unchecked(path: &Path, cal: &Calibration) -> Result<()> {
    write_file(path, to_json(cal)?.as_bytes())
}

/// Reads a calibration file and checks it is valid.
pub fn read_calibration(path: &Path) -> Result<Calibration> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Read {
        path: path.into(),
        source,
    })?;
    let cal: Calibration =
        serde_json::from_str(&text).map_err(|source| Error::NotCalibrationJson {
            path: path.into(),
            source,
        })?;
    cal.validate()
        .map_err(|cause| Error::InvalidCalibrationFile {
            path: path.into(),
            cause,
        })?;
    Ok(cal)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_refusals() {
        let dir = std::env::temp_dir().join(format!("wiical-calfile-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("cal.json");
        let mut cal = Calibration {
            bias: [512.0, 511.5, 530.25],
            ..Default::default()
        };
        cal.matrix[0][1] = 1e-4;
        write_calibration(&path, &cal).unwrap();
        assert_eq!(read_calibration(&path).unwrap(), cal);
        let mut bad = cal;
        bad.matrix[1][1] = f32::NAN;
        let e = write_calibration(&path, &bad).unwrap_err().to_string();
        assert!(
            e.starts_with("refusing to write an invalid calibration"),
            "{e}"
        );
        std::fs::write(&path, "{\"bias\": 1}").unwrap();
        let e = read_calibration(&path).unwrap_err().to_string();
        assert!(e.ends_with("is not a calibration JSON"), "{e}");
        let e = read_calibration(&dir.join("missing.json"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("cannot read"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

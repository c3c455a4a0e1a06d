//! The calibration file: what `wiical fit --out`, `analyze --out`, `six-position --out` and
//! `magfit --out` write and `wiical device put` reads. Pretty-printed JSON:
//!
//! ```json
//! { "schema": "wiical-calibration/2",
//!   "bias": [..3], "matrix": [[..3], [..3], [..3]],
//!   "effects": { "quadratic": [..3], "cubic": [..3], "bias_drift": [..3],
//!                "temp_ref_c": 0.0, "bias_temp": [..3], "scale_temp": [..3],
//!                "cross_quadratic": [[..5], [..5], [..5]],
//!                "cross_cubic": [[..9], [..9], [..9]] },
//!   "quality": { "verdict": "good", "fit_rms_mg": .., "max_fit_rms_mg": 30.0,
//!                "poses": 14, "coverage_gap": null } }
//! ```
//!
//! Reading is strict: an unknown key anywhere is an error (a misspelt `bias-drift` or
//! `effect` would otherwise drop the terms silently, and a `fit --json` report would pass for
//! a calibration). `effects` and each of its keys may be left out (zero); `quality` may be
//! left out (a calibration not from a fit: six-position, magfit, hand-written).
//!
//! **Versions.** Version 2 added the orientation-dependent cross terms `cross_quadratic`
//! (1/g, per output axis the monomials of `wiical_core::model::CROSS2`) and `cross_cubic`
//! (1/g², `CROSS3`); each may be left out (zero). A file is written with the lowest version
//! that holds its terms: `wiical-calibration/1` (exactly the version-1 layout) when every
//! cross term is zero, so that an older wiical still reads it, and `wiical-calibration/2`
//! otherwise, which an older wiical refuses by its schema instead of dropping the terms.
//! Reading accepts both; a file labelled version 1 with a non-zero cross term is refused
//! (version 1 has none: the label or the terms are wrong).
//! **Files without `schema`** (written before it existed, or the core's plain serde JSON as
//! `device get --json` prints it) are read with the same strict keys, cross terms included.
//! Any other `schema` value is refused (a file from a newer wiical must not be
//! half-understood).

use crate::error::output::OutputError;
use crate::error::Result;
use crate::input::bounded::{read_text, MAX_CALIBRATION_BYTES};
use crate::output::host_term_checks::{self as host_terms, HostTerm};
use crate::output::write::write_file;
use crate::report::verdict::Quality;
use serde::{Deserialize, Serialize};
use std::path::Path;
use wiical_core::terms::{Shape, TermSpec, NAMES, TERMS};
use wiical_core::{Calibration, Effects};

/// The newest `schema` value, written when the calibration has cross terms.
pub const SCHEMA: &str = "wiical-calibration/2";

/// The version-3 `schema` value: written only when the file carries host-only terms
/// (`host_terms`), so that a version-2 reader refuses the file by its schema instead of
/// failing on (or, were it lenient, dropping) the unknown key.
pub const SCHEMA_V3: &str = "wiical-calibration/3";

/// The version-1 `schema` value: still read, and written when every cross term is zero.
pub const SCHEMA_V1: &str = "wiical-calibration/1";

/// The file's layout (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileV1 {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    schema: Option<String>,
    bias: [f32; 3],
    matrix: [[f32; 3]; 3],
    #[serde(default)]
    effects: EffectsV1,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    quality: Option<Quality>,
    /// Version 3: the host-only time and temperature terms; absent when there are none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    host_terms: Option<Vec<HostTerm>>,
}

/// The effect terms, strict (the core's serde derive is lenient, for its other users): one
/// key per row of the core's table of effect terms (`wiical_core::terms::TERMS`), in its
/// order, each term's coefficients as an array (`[..3]`), an array of rows (`[[..n]; 3]`
/// for a cross term) or a number (the reference temperature). Every key may be left out
/// (zero); terms newer than version 1 are written only when non-zero, and may be `null`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct EffectsV1(Effects);

impl EffectsV1 {
    /// The lowest file version holding every non-zero term (1 or 2; 3 is for host terms).
    fn version(&self) -> u8 {
        TERMS
            .iter()
            .filter(|t| self.0.field(t.id).iter().any(|x| *x != 0.0))
            .map(|t| t.since_file)
            .max()
            .unwrap_or(1)
    }

    /// The keys of the terms version 1 does not have, for messages.
    fn newer_than_v1() -> String {
        let names: Vec<&str> = TERMS
            .iter()
            .filter(|t| t.since_file > 1)
            .map(|t| t.name)
            .collect();
        names.join(" / ")
    }
}

impl Serialize for EffectsV1 {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let e = &self.0;
        let shown = |t: &&TermSpec| t.since_file == 1 || e.field(t.id).iter().any(|x| *x != 0.0);
        let mut m = s.serialize_struct("EffectsV1", TERMS.iter().filter(shown).count())?;
        for t in TERMS.iter().filter(shown) {
            let c = e.field(t.id);
            match t.shape {
                Shape::Reference => m.serialize_field(t.name, &c[0])?,
                Shape::Cross(_) => {
                    let rows: Vec<&[f32]> = c.chunks(t.per_axis()).collect();
                    m.serialize_field(t.name, &rows)?
                }
                _ => m.serialize_field(t.name, c)?,
            }
        }
        m.end()
    }
}

impl<'de> Deserialize<'de> for EffectsV1 {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        d.deserialize_struct("EffectsV1", &NAMES, TermsVisitor)
    }
}

/// Reads the `effects` object strictly (unknown or repeated keys refused).
struct TermsVisitor;

impl<'de> serde::de::Visitor<'de> for TermsVisitor {
    type Value = EffectsV1;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("struct EffectsV1")
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(
        self,
        mut map: A,
    ) -> std::result::Result<EffectsV1, A::Error> {
        use serde::de::Error as _;
        let mut e = Effects::default();
        let mut seen = [false; TERMS.len()];
        while let Some(key) = map.next_key::<std::borrow::Cow<'de, str>>()? {
            let Some(i) = NAMES.iter().position(|n| *n == key) else {
                return Err(A::Error::unknown_field(&key, &NAMES));
            };
            let t = &TERMS[i];
            if std::mem::replace(&mut seen[i], true) {
                return Err(A::Error::duplicate_field(t.name));
            }
            let values: Vec<f32> = match (t.shape, t.per_axis()) {
                (Shape::Reference, _) => vec![map.next_value::<f32>()?],
                (Shape::Cross(_), 5) => rows::<5, A>(&mut map, t)?,
                (Shape::Cross(_), 9) => rows::<9, A>(&mut map, t)?,
                (Shape::Cross(_), n) => {
                    return Err(A::Error::custom(format!("no reader for rows of {n}")))
                }
                _ => map.next_value::<[f32; 3]>()?.to_vec(),
            };
            e.field_mut(t.id).copy_from_slice(&values);
        }
        Ok(EffectsV1(e))
    }
}

/// The value of a cross term: three rows of `N`, `null` or absent (zero) for a term newer
/// than version 1.
fn rows<'de, const N: usize, A: serde::de::MapAccess<'de>>(
    map: &mut A,
    t: &TermSpec,
) -> std::result::Result<Vec<f32>, A::Error>
where
    [[f32; N]; 3]: Deserialize<'de>,
{
    let r: Option<[[f32; N]; 3]> = if t.since_file > 1 {
        map.next_value()?
    } else {
        Some(map.next_value()?)
    };
    Ok(r.unwrap_or([[0.0; N]; 3]).as_flattened().to_vec())
}

/// A calibration file's contents: the calibration and, when it came from a fit, the fit's
/// quality verdict.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationFile {
    /// The calibration.
    pub calibration: Calibration,
    /// The fit's quality (absent for calibrations not from a multi-position fit).
    pub quality: Option<Quality>,
    /// Host-only terms (time, temperature) the adapter does not apply; empty for most files.
    pub host_terms: Vec<HostTerm>,
}

/// The JSON text of a calibration file (pretty-printed, with a final newline), with the
/// lowest schema version that holds its terms.
pub fn to_json_file(f: &CalibrationFile) -> Result<String> {
    let cal = &f.calibration;
    let effects = EffectsV1(cal.effects);
    let hosts = if f.host_terms.is_empty() { 1 } else { 3 };
    let schema = schema_of(effects.version().max(hosts));
    let file = FileV1 {
        schema: Some(schema.into()),
        bias: cal.bias,
        matrix: cal.matrix,
        effects,
        quality: f.quality.clone(),
        host_terms: (!f.host_terms.is_empty()).then(|| f.host_terms.clone()),
    };
    Ok(serde_json::to_string_pretty(&file)? + "\n")
}

/// The JSON text of a calibration file without host terms.
pub fn to_json_with(cal: &Calibration, quality: Option<&Quality>) -> Result<String> {
    to_json_file(&CalibrationFile {
        calibration: *cal,
        quality: quality.cloned(),
        host_terms: Vec::new(),
    })
}

/// The JSON text of a calibration without a quality section.
pub fn to_json(cal: &Calibration) -> Result<String> {
    to_json_with(cal, None)
}

/// Parses calibration-file text strictly (see the module docs); does not validate. The
/// numeric fields' shapes are checked first ([`check_shapes`]) so that a wrong count or type
/// is told as "bias has 4 values, expected 3" rather than in the deserializer's words.
pub fn parse(text: &str) -> std::result::Result<CalibrationFile, serde_json::Error> {
    let value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| non_json_number(text, e))?;
    check_shapes(&value).map_err(serde::de::Error::custom)?;
    let file: FileV1 = serde_json::from_str(text)?;
    let hosts = file.host_terms.unwrap_or_default();
    check_schema(file.schema.as_deref(), &file.effects, &hosts)?;
    host_terms::validate(&hosts).map_err(serde::de::Error::custom)?;
    Ok(CalibrationFile {
        calibration: Calibration {
            bias: file.bias,
            matrix: file.matrix,
            effects: file.effects.0,
        },
        quality: file.quality,
        host_terms: hosts,
    })
}

/// A syntax error at a `NaN` or `Infinity` (which Python's `json.dump` writes and JSON does
/// not have) told as such, with its place, instead of "expected value"; any other error as is.
fn non_json_number(text: &str, e: serde_json::Error) -> serde_json::Error {
    if !e.is_syntax() || e.line() == 0 {
        return e;
    }
    let Some(line) = text.lines().nth(e.line() - 1) else {
        return e;
    };
    let from = line
        .char_indices()
        .nth(e.column().saturating_sub(2))
        .map_or(line.len(), |(i, _)| i);
    let at = line[from..].trim_start_matches([' ', '-', '+', ',', ':', '[']);
    let word = ["NaN", "nan", "Infinity", "infinity", "inf"]
        .into_iter()
        .find(|w| at.starts_with(w));
    match word {
        Some(w) => serde::de::Error::custom(format!(
            "line {} column {}: {w} is not a number JSON has (no NaN or infinity): write the finite value, or re-fit",
            e.line(),
            e.column()
        )),
        None => e,
    }
}

/// The numeric fields of a calibration file and their shapes: `(path, rows, columns)`, one
/// row meaning a flat list and zero columns a single number; the effect sections come from
/// the core's table of effect terms. Read by [`check_shapes`] before the deserializer, which
/// would describe a mismatch in its own terms ("invalid type: map, expected a tuple struct").
fn shapes() -> Vec<(String, usize, usize)> {
    use wiical_core::terms::{Shape, TERMS};
    let mut out = vec![("bias".to_string(), 1, 3), ("matrix".to_string(), 3, 3)];
    out.extend(TERMS.iter().map(|t| {
        let (rows, cols) = match t.shape {
            Shape::Reference => (1, 0),
            Shape::Cross(_) => (3, t.per_axis()),
            _ => (1, 3),
        };
        (format!("effects.{}", t.name), rows, cols)
    }));
    out
}

/// What a JSON value is, in words ("an object", "the text \"abc\"").
fn json_kind(v: &serde_json::Value) -> String {
    use serde_json::Value;
    match v {
        Value::Null => "null".into(),
        Value::Bool(b) => format!("{b}"),
        Value::Number(n) => format!("the number {n}"),
        Value::String(t) => format!("the text \"{}\"", crate::input::bounded::quote(t)),
        Value::Array(a) => format!("a list of {} values", a.len()),
        Value::Object(_) => "an object".into(),
    }
}

/// One number of the file: present, a JSON number, and within the f32 range the calibration
/// is stored in (a larger one would silently become infinite).
fn check_number(name: &str, v: &serde_json::Value) -> std::result::Result<(), String> {
    let Some(x) = v.as_f64() else {
        return Err(format!("{name} is {}, expected a number", json_kind(v)));
    };
    if x.abs() > f64::from(f32::MAX) {
        return Err(format!(
            "{name} is {v}, beyond the largest value a calibration holds (about 3.4e38)"
        ));
    }
    Ok(())
}

/// A flat list of `n` numbers named `name`.
fn check_list(name: &str, v: &serde_json::Value, n: usize) -> std::result::Result<(), String> {
    let Some(items) = v.as_array() else {
        return Err(format!(
            "{name} is {}, expected a list of {n} numbers",
            json_kind(v)
        ));
    };
    if items.len() != n {
        return Err(format!("{name} has {} values, expected {n}", items.len()));
    }
    for (i, x) in items.iter().enumerate() {
        check_number(&format!("{name}[{i}]"), x)?;
    }
    Ok(())
}

/// Checks the numeric fields of a calibration file against `shapes()`, naming the field,
/// the row and what was found. Keys it does not know are left to the strict deserializer
/// (which names them as unknown fields); `bias` and `matrix` must be present.
pub fn check_shapes(value: &serde_json::Value) -> std::result::Result<(), String> {
    let Some(top) = value.as_object() else {
        return Err(format!(
            "the file holds {}, expected an object with \"bias\" and \"matrix\"",
            json_kind(value)
        ));
    };
    for key in ["bias", "matrix"] {
        if !top.contains_key(key) {
            return Err(format!(
                "the file has no \"{key}\" (a calibration has \"bias\": 3 numbers and \"matrix\": 3 rows of 3)"
            ));
        }
    }
    if let Some(e) = top.get("effects").filter(|e| !e.is_object()) {
        return Err(format!("effects is {}, expected an object", json_kind(e)));
    }
    for (path, rows, cols) in shapes() {
        let path = path.as_str();
        let v = match path.split_once('.') {
            Some((section, key)) => top.get(section).and_then(|s| s.get(key)),
            None => top.get(path),
        };
        // The optional cross sections may be written as null (absent).
        let Some(v) = v.filter(|v| !(v.is_null() && rows == 3 && cols > 3)) else {
            continue;
        };
        match (rows, cols) {
            (_, 0) => check_number(path, v)?,
            (1, n) => check_list(path, v, n)?,
            (r, n) => {
                let Some(items) = v.as_array().filter(|a| a.len() == r) else {
                    return Err(format!(
                        "{path} is {}, expected {r} rows of {n} numbers",
                        json_kind(v)
                    ));
                };
                for (i, row) in items.iter().enumerate() {
                    check_list(&format!("{path} row {}", i + 1), row, n)?;
                }
            }
        }
    }
    Ok(())
}

/// The `schema` value of file version `v` (1 to 3).
fn schema_of(v: u8) -> &'static str {
    match v {
        0 | 1 => SCHEMA_V1,
        2 => SCHEMA,
        _ => SCHEMA_V3,
    }
}

/// Refuses a `schema` label that does not hold the file's terms, or is unknown.
fn check_schema(
    schema: Option<&str>,
    effects: &EffectsV1,
    hosts: &[HostTerm],
) -> std::result::Result<(), serde_json::Error> {
    if !hosts.is_empty() && matches!(schema, Some(SCHEMA) | Some(SCHEMA_V1)) {
        return Err(serde::de::Error::custom(format!(
            "the file says schema '{}' but has host_terms, which only version 3 has: set \"schema\": \"{SCHEMA_V3}\"",
            schema.unwrap_or_default()
        )));
    }
    match schema {
        None | Some(SCHEMA) | Some(SCHEMA_V3) => {}
        Some(SCHEMA_V1) => {
            if effects.version() > 1 {
                return Err(serde::de::Error::custom(format!(
                    "the file says schema '{SCHEMA_V1}' but has {} terms, which version 1 does not have: set \"schema\": \"{}\"",
                    EffectsV1::newer_than_v1(),
                    schema_of(effects.version())
                )));
            }
        }
        Some(schema) => {
            return Err(serde::de::Error::custom(format!(
                "schema '{}' is not '{SCHEMA_V3}', '{SCHEMA}' or '{SCHEMA_V1}' (written by another version of wiical?)",
                crate::input::bounded::quote(schema)
            )));
        }
    }
    Ok(())
}

/// Writes a calibration (with the fit's quality, if any) after checking it is valid (finite,
/// invertible), atomically.
pub fn write_calibration_with(
    path: &Path,
    cal: &Calibration,
    quality: Option<&Quality>,
) -> Result<()> {
    cal.validate()
        .map_err(OutputError::RefuseInvalidCalibration)?;
    Ok(write_file(path, to_json_with(cal, quality)?.as_bytes())?)
}

/// Writes a calibration file (core calibration, quality, host terms) after checking the
/// calibration is valid (finite, invertible) and the host terms are, atomically.
pub fn write_calibration_file(path: &Path, f: &CalibrationFile) -> Result<()> {
    f.calibration
        .validate()
        .map_err(OutputError::RefuseInvalidCalibration)?;
    host_terms::validate(&f.host_terms).map_err(OutputError::RefuseInvalidHostTerms)?;
    Ok(write_file(path, to_json_file(f)?.as_bytes())?)
}

/// Writes a calibration after checking it is valid (finite, invertible: what the adapter
/// accepts).
pub fn write_calibration(path: &Path, cal: &Calibration) -> Result<()> {
    write_calibration_with(path, cal, None)
}

/// Writes a calibration as it is (e.g. one read back from a device, to be inspected).
pub fn write_calibration_unchecked(path: &Path, cal: &Calibration) -> Result<()> {
    Ok(write_file(path, to_json(cal)?.as_bytes())?)
}

/// Reads a calibration file (a regular file of at most [`MAX_CALIBRATION_BYTES`], or `-`),
/// strictly, and checks the calibration is valid.
pub fn read_calibration_file(path: &Path) -> Result<CalibrationFile> {
    let text = read_text(path, MAX_CALIBRATION_BYTES)?;
    let file = parse(&text).map_err(|source| OutputError::NotCalibrationJson {
        path: path.into(),
        source,
    })?;
    file.calibration
        .validate()
        .map_err(|cause| OutputError::InvalidCalibrationFile {
            path: path.into(),
            cause,
        })?;
    Ok(file)
}

/// Reads a calibration file and checks it is valid (the quality section, if any, dropped).
pub fn read_calibration(path: &Path) -> Result<Calibration> {
    Ok(read_calibration_file(path)?.calibration)
}

/// Which of a calibration's non-zero terms the adapter applies to every sample, and which
/// stay in the file for hosts: the adapter corrects with what depends on the
/// acceleration alone (bias and `K`, the per-axis and the orientation-dependent cross
/// terms); it has no clock origin and no thermometer, so the time and temperature terms are
/// stored with the calibration but not applied.
#[derive(Debug, Default, PartialEq, Serialize)]
pub struct AdapterTerms {
    /// Applied on the device.
    pub applied: Vec<String>,
    /// Kept in the file (and stored) for hosts with a clock and a thermometer.
    pub host_only: Vec<String>,
}

/// Sorts the calibration's non-zero terms into [`AdapterTerms`], by the core's table of
/// effect terms (`device_applies`), each named by its key and, when it depends on more than
/// its own axis, on what (`cross_cubic (orientation)`, `bias_drift (time)`).
pub fn adapter_terms(cal: &Calibration) -> AdapterTerms {
    let e = &cal.effects;
    let mut t = AdapterTerms {
        applied: vec!["bias and K".into()],
        host_only: Vec::new(),
    };
    for spec in TERMS.iter().filter(|s| s.is_term()) {
        if !e.field(spec.id).iter().any(|x| *x != 0.0) {
            continue;
        }
        let name = match spec.depends_on() {
            Some(on) => format!("{} ({on})", spec.name),
            None => spec.name.to_string(),
        };
        if spec.device_applies {
            t.applied.push(name);
        } else {
            t.host_only.push(name);
        }
    }
    t
}

/// [`adapter_terms`] of a file, its host-only terms (`host_terms`, kept in the file only:
/// the device stores the core calibration) added to the host list.
pub fn adapter_terms_file(f: &CalibrationFile) -> AdapterTerms {
    let mut t = adapter_terms(&f.calibration);
    t.host_only.extend(
        f.host_terms
            .iter()
            .map(|h| format!("{} (host_terms)", h.name)),
    );
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Calibration {
        let mut cal = Calibration {
            bias: [512.0, 511.5, 530.25],
            ..Default::default()
        };
        cal.matrix[0][1] = 1e-4;
        cal.effects.quadratic = [0.01, 0.0, -0.02];
        cal
    }

    /// A NaN or an infinity (Python's `json.dump` writes them) is named with its place, not
    /// told as "expected value".
    #[test]
    fn a_nan_or_infinity_token_is_named() {
        let good = to_json(&sample()).unwrap();
        for (token, word) in [
            ("NaN", "NaN"),
            ("-Infinity", "Infinity"),
            ("Infinity", "Infinity"),
        ] {
            let text = good.replacen("512.0", token, 1);
            let e = parse(&text).unwrap_err().to_string();
            assert!(
                e.contains(&format!("{word} is not a number JSON has")),
                "{e}"
            );
            assert!(e.contains("line 4"), "{e}");
        }
        let e = parse("{\"bias\": [1, 2,").unwrap_err().to_string();
        assert!(!e.contains("is not a number JSON has"), "{e}");
    }

    #[test]
    fn round_trip_and_refusals() {
        let guard = tempfile::tempdir().unwrap();
        let dir = guard.path();
        let path = dir.join("cal.json");
        let cal = sample();
        write_calibration(&path, &cal).unwrap();
        assert_eq!(read_calibration(&path).unwrap(), cal);
        let mut bad = cal;
        bad.matrix[1][1] = f32::NAN;
        let e = write_calibration(&path, &bad).unwrap_err().to_string();
        assert!(
            e.starts_with("refusing to write an invalid calibration"),
            "{e}"
        );
        assert_eq!(read_calibration(&path).unwrap(), cal, "old file intact");
        std::fs::write(&path, "{\"bias\": 1}").unwrap();
        let e = read_calibration(&path).unwrap_err().to_string();
        assert!(e.ends_with("is not a calibration JSON"), "{e}");
        let e = read_calibration(&dir.join("missing.json"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("cannot read"), "{e}");
    }

    #[test]
    fn the_schema_is_written_and_checked() {
        let text = to_json(&sample()).unwrap();
        assert!(
            text.starts_with("{\n  \"schema\": \"wiical-calibration/1\","),
            "{text}"
        );
        assert!(
            !text.contains("cross_"),
            "a version-1 file has no cross keys: {text}"
        );
        assert_eq!(parse(&text).unwrap().calibration, sample());
        let other = text.replace("wiical-calibration/1", "wiical-calibration/9");
        let e = parse(&other).unwrap_err().to_string();
        assert!(e.contains("schema 'wiical-calibration/9'"), "{e}");
    }

    fn with_cross() -> Calibration {
        let mut cal = sample();
        cal.effects.cross_quadratic[1] = [1e-3, 0.0, -2e-3, 0.0, 5e-4];
        cal.effects.cross_cubic[2][8] = -7.5e-4;
        cal
    }

    #[test]
    fn cross_terms_are_written_as_version_2_and_read_back() {
        let cal = with_cross();
        let text = to_json(&cal).unwrap();
        assert!(
            text.starts_with("{\n  \"schema\": \"wiical-calibration/2\","),
            "{text}"
        );
        assert_eq!(parse(&text).unwrap().calibration, cal);
        // Only one family non-zero: the other key is left out and reads as zero.
        let mut only_cubic = sample();
        only_cubic.effects.cross_cubic[0][0] = 1e-3;
        let text = to_json(&only_cubic).unwrap();
        assert!(
            text.contains("cross_cubic") && !text.contains("cross_quadratic"),
            "{text}"
        );
        assert_eq!(parse(&text).unwrap().calibration, only_cubic);
        // A hand-written version-2 file without cross keys is fine too.
        let plain = to_json(&sample())
            .unwrap()
            .replace("calibration/1", "calibration/2");
        assert_eq!(parse(&plain).unwrap().calibration, sample());
    }

    #[test]
    fn version_1_files_with_cross_terms_and_bad_cross_shapes_are_refused() {
        let v2 = to_json(&with_cross()).unwrap();
        let e = parse(&v2.replace("calibration/2", "calibration/1"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("version 1 does not have") && e.contains("wiical-calibration/2"),
            "{e}"
        );
        // Zero cross keys under the version-1 label are harmless.
        let zeros = r#"{"schema":"wiical-calibration/1","bias":[1,2,3],"matrix":[[1,0,0],[0,1,0],[0,0,1]],"effects":{"cross_cubic":[[0,0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0,0]]}}"#;
        assert!(!parse(zeros).unwrap().calibration.effects.has_cross_terms());
        // Unlabelled (the core's plain serde JSON): read with the cross terms.
        let unlabelled = v2.replacen("\"schema\": \"wiical-calibration/2\",", "", 1);
        assert_ne!(unlabelled, v2);
        assert_eq!(parse(&unlabelled).unwrap().calibration, with_cross());
        let plain = serde_json::to_string(&with_cross()).unwrap();
        assert_eq!(parse(&plain).unwrap().calibration, with_cross());
        // Four coefficients where an axis has five monomials.
        let short = r#"{"schema":"wiical-calibration/2","bias":[1,2,3],"matrix":[[1,0,0],[0,1,0],[0,0,1]],"effects":{"cross_quadratic":[[0,0,0,0],[0,0,0,0,0],[0,0,0,0,0]]}}"#;
        assert!(parse(short).is_err());
        let misspelt = v2.replace("cross_cubic", "cross_cubics");
        assert!(parse(&misspelt)
            .unwrap_err()
            .to_string()
            .contains("unknown field"));
    }

    #[test]
    fn old_files_without_schema_are_read_strictly() {
        let old =
            r#"{"bias":[1,2,3],"matrix":[[1,0,0],[0,1,0],[0,0,1]],"effects":{"cubic":[0,0,0.5]}}"#;
        let f = parse(old).unwrap();
        assert_eq!(f.calibration.effects.cubic, [0.0, 0.0, 0.5]);
        assert_eq!(f.quality, None);
        let no_effects = r#"{"bias":[1,2,3],"matrix":[[1,0,0],[0,1,0],[0,0,1]]}"#;
        assert!(parse(no_effects).unwrap().calibration.effects.is_none());
    }

    #[test]
    fn unknown_keys_are_refused() {
        let base = to_json(&sample()).unwrap();
        // A misspelt effect term, a misspelt section, an extra top-level key.
        for (from, to) in [
            ("\"bias_drift\"", "\"bias-drift\""),
            ("\"effects\"", "\"effect\""),
            ("\"bias\": [", "\"static_windows\": 12, \"bias\": ["),
        ] {
            let text = base.replacen(from, to, 1);
            assert_ne!(text, base);
            let e = parse(&text).unwrap_err().to_string();
            assert!(e.contains("unknown field"), "{to}: {e}");
        }
    }

    fn with_hosts() -> CalibrationFile {
        use crate::output::host_term_checks::HostReference;
        let term = |family: &str, axis: u8, value: f64, r: HostReference| HostTerm {
            name: format!("{family} ({})", ["x", "y", "z"][axis as usize]),
            family: family.into(),
            axis,
            value,
            unit: "1/s".into(),
            reference: r,
            time_constant_s: None,
        };
        let t = HostReference {
            time_s: Some(312.5),
            ..Default::default()
        };
        let c = HostReference {
            temperature_c: Some(27.25),
            ..Default::default()
        };
        CalibrationFile {
            calibration: sample(),
            quality: None,
            host_terms: vec![
                term("scale-drift", 2, 3.25e-6, t),
                term("temperature-squared", 0, -0.0125, c),
                HostTerm {
                    time_constant_s: Some(215.5),
                    ..term("thermal-lag", 1, 0.75, c)
                },
                term(
                    "temperature-rate",
                    2,
                    -40.5,
                    HostReference {
                        rate_c_per_s: Some(0.0125),
                        ..Default::default()
                    },
                ),
            ],
        }
    }

    #[test]
    fn host_terms_are_written_as_version_3_and_read_back() {
        let f = with_hosts();
        let text = to_json_file(&f).unwrap();
        assert!(
            text.contains(&format!("\"schema\": \"{SCHEMA_V3}\"")),
            "{text}"
        );
        assert_eq!(parse(&text).unwrap(), f);
        // Without host terms the same calibration is written exactly as before.
        let plain = CalibrationFile {
            host_terms: Vec::new(),
            ..f.clone()
        };
        assert_eq!(to_json_file(&plain).unwrap(), to_json(&sample()).unwrap());
        assert!(!to_json(&sample()).unwrap().contains("host_terms"));
        // Labelled version 1 or 2, the host terms are refused, naming the fix.
        for old in [SCHEMA, SCHEMA_V1] {
            let relabelled = text.replace(SCHEMA_V3, old);
            let e = parse(&relabelled).unwrap_err().to_string();
            assert!(e.contains("host_terms") && e.contains(SCHEMA_V3), "{e}");
        }
        // A version-2 reader (strict keys, schemas 1 and 2 only) refuses the file by its
        // schema; its schema check is the same as ours without version 3.
        let e = check_schema(Some(SCHEMA_V3), &EffectsV1::default(), &[]);
        assert!(e.is_ok());
        let e = check_schema(Some("wiical-calibration/4"), &EffectsV1::default(), &[]);
        assert!(e.unwrap_err().to_string().contains("another version"));
        // Bad terms are refused on read, naming the entry and field.
        let bad = text.replacen("\"axis\": 2", "\"axis\": 7", 1);
        let e = parse(&bad).unwrap_err().to_string();
        assert!(e.contains("host_terms[0]: axis is 7"), "{e}");
        let bad = text.replacen("\"family\": \"scale-drift\"", "\"family\": \"warp\"", 1);
        assert!(parse(&bad)
            .unwrap_err()
            .to_string()
            .contains("family 'warp'"));
    }

    #[test]
    fn quality_round_trips() {
        let q = Quality {
            verdict: crate::report::verdict::Verdict::Poor,
            fit_rms_mg: 41.5,
            max_fit_rms_mg: 30.0,
            poses: 10,
            coverage_gap: Some("too few poses: 10 of 12".into()),
            residual: None,
        };
        let text = to_json_with(&sample(), Some(&q)).unwrap();
        assert_eq!(parse(&text).unwrap().quality, Some(q));
        let e = parse(&text.replace("\"poses\"", "\"pose_count\"")).unwrap_err();
        assert!(e.to_string().contains("unknown field"), "{e}");
    }
}

//! The gyro calibration file: what `wiical gyrofit --out` writes. Pretty-printed JSON:
//!
//! ```json
//! { "format": "wiical-gyro-calibration/2", "model": "full+bias",
//!   "bias": [..3], "matrix": [[..3], [..3], [..3]],
//!   "effects": { "g_sensitivity": [[..3], [..3], [..3]] },
//!   "units": "rad/s", "cv_rms_deg": 0.55 }
//! ```
//!
//! `ω = matrix·(m − bias) − g_sensitivity·a` (`m` raw counts, `ω` rad/s, `a` the
//! accelerometer's calibrated reading in g; `wiical_core::gyro_correct` has the conventions).
//! The `effects` keys, their shapes and the version are derived from the core's table of gyro
//! terms (`wiical_core::terms::GYRO_TERMS`): a file is written with the highest `since_file` of
//! its non-zero terms, `wiical-gyro-calibration/1` (exactly the layout before the terms, no
//! `effects` key) when there are none, so that what an older wiical wrote and reads is
//! unchanged. Reading is strict: unknown keys refused, version 1 with a term refused, every
//! number finite, `matrix` invertible and each term within its plausibility bound.

use crate::error::output::OutputError;
use crate::error::Result;
use crate::input::bounded::{read_text, MAX_CALIBRATION_BYTES};
use crate::output::write::write_file;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;
use wiical_core::gyro_correct::{GyroCorrection, GyroEffects};
use wiical_core::terms::{Shape, GYRO_TERMS};

/// The `format` value of a file without effect terms.
pub const FORMAT_V1: &str = "wiical-gyro-calibration/1";

/// The `format` prefix; the version follows it.
const FORMAT_PREFIX: &str = "wiical-gyro-calibration/";

/// The newest version this build reads and writes: the highest `since_file` of the table.
pub fn newest_version() -> u8 {
    GYRO_TERMS
        .iter()
        .map(|t| t.since_file)
        .max()
        .unwrap_or(1)
        .max(1)
}

/// A gyro calibration file.
#[derive(Debug, Clone, PartialEq)]
pub struct GyroCalFile {
    /// The gyro model `gyrofit` chose (`full+bias`, …).
    pub model: String,
    /// The calibration with its effect terms.
    pub correction: GyroCorrection<f64>,
    /// Leave-one-motion-out RMS angle error of the chosen model, degrees; NaN (no key in the
    /// file) when the method has none.
    pub cv_rms_deg: f64,
}

/// The file's layout (see the module docs).
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Layout {
    format: String,
    model: String,
    bias: [f64; 3],
    matrix: [[f64; 3]; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    effects: Option<BTreeMap<String, serde_json::Value>>,
    units: String,
    /// Absent when the method has no held-out error (a protocol's exactly determined fit).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    cv_rms_deg: Option<f64>,
}

/// The lowest version holding every non-zero term of `e`.
fn version_of(e: &GyroEffects<f64>) -> u8 {
    GYRO_TERMS
        .iter()
        .filter(|t| e.field(t.id).iter().any(|x| *x != 0.0))
        .map(|t| t.since_file)
        .max()
        .unwrap_or(1)
}

/// The effect terms as JSON, one key per non-zero row of the table (a `Matrix` term as rows).
fn effects_json(e: &GyroEffects<f64>) -> Option<BTreeMap<String, serde_json::Value>> {
    let map: BTreeMap<String, serde_json::Value> = GYRO_TERMS
        .iter()
        .filter(|t| e.field(t.id).iter().any(|x| *x != 0.0))
        .map(|t| {
            let c = e.field(t.id);
            let v = match t.shape {
                Shape::Matrix(_) | Shape::Cross(_) => {
                    serde_json::json!(c.chunks(t.per_axis()).collect::<Vec<_>>())
                }
                Shape::Reference => serde_json::json!(c[0]),
                _ => serde_json::json!(c),
            };
            (t.name.to_string(), v)
        })
        .collect();
    (!map.is_empty()).then_some(map)
}

/// The file's text.
pub fn to_text(f: &GyroCalFile) -> Result<String> {
    let c = &f.correction;
    c.validate()
        .map_err(OutputError::RefuseInvalidCalibration)?;
    let layout = Layout {
        format: format!("{FORMAT_PREFIX}{}", version_of(&c.effects)),
        model: f.model.clone(),
        bias: c.bias,
        matrix: c.matrix,
        effects: effects_json(&c.effects),
        units: "rad/s".into(),
        cv_rms_deg: f.cv_rms_deg.is_finite().then_some(f.cv_rms_deg),
    };
    // Serialising plain numbers and strings cannot fail; a failure would be a non-number.
    let text = serde_json::to_string_pretty(&layout)
        .map_err(|_| OutputError::RefuseInvalidCalibration(wiical_core::Error::NonFinite))?;
    Ok(text + "\n")
}

/// Writes the file atomically (refusing a calibration that does not validate).
pub fn write_gyro_calibration(path: &Path, f: &GyroCalFile) -> Result<()> {
    Ok(write_file(path, to_text(f)?.as_bytes())?)
}

/// The effect terms of a file's `effects` object, strictly: a key per row of the table, each
/// with its row's shape; anything else is an error naming the key.
fn parse_effects(
    map: &BTreeMap<String, serde_json::Value>,
) -> std::result::Result<GyroEffects<f64>, String> {
    let mut e = GyroEffects::default();
    for (key, v) in map {
        let Some(t) = wiical_core::terms::by_name_in(&GYRO_TERMS, key) else {
            return Err(format!(
                "unknown effect term \"{}\" (known: {})",
                crate::input::bounded::quote(key),
                wiical_core::terms::GYRO_NAMES.join(", ")
            ));
        };
        let flat: Vec<f64> = match v.as_array() {
            Some(rows) if rows.iter().all(|r| r.is_array()) => rows
                .iter()
                .flat_map(|r| r.as_array().into_iter().flatten())
                .map(|x| x.as_f64().unwrap_or(f64::NAN))
                .collect(),
            _ => Vec::new(),
        };
        if flat.len() != t.len() || flat.iter().any(|x| !x.is_finite()) {
            return Err(format!(
                "effects.{key} must be {} rows of {} finite numbers",
                t.len() / t.per_axis(),
                t.per_axis()
            ));
        }
        e.field_mut(t.id).copy_from_slice(&flat);
    }
    Ok(e)
}

/// Parses a file's text (see the module docs for what is refused).
pub fn parse(text: &str) -> std::result::Result<GyroCalFile, String> {
    let l: Layout = serde_json::from_str(text).map_err(|e| e.to_string())?;
    let version = l
        .format
        .strip_prefix(FORMAT_PREFIX)
        .and_then(|v| v.parse::<u8>().ok())
        .filter(|v| (1..=newest_version()).contains(v))
        .ok_or_else(|| {
            format!(
                "format \"{}\" is not {FORMAT_PREFIX}1 to {}",
                crate::input::bounded::quote(&l.format),
                newest_version()
            )
        })?;
    if l.units != "rad/s" {
        return Err(format!(
            "units \"{}\" is not rad/s",
            crate::input::bounded::quote(&l.units)
        ));
    }
    let effects = parse_effects(&l.effects.unwrap_or_default())?;
    if version_of(&effects) > version {
        return Err(format!(
            "format version {version} holds no such effect terms (the label or the terms are wrong)"
        ));
    }
    let correction = GyroCorrection {
        bias: l.bias,
        matrix: l.matrix,
        effects,
    };
    correction
        .validate()
        .map_err(|e| format!("invalid calibration: {e}"))?;
    Ok(GyroCalFile {
        model: l.model,
        correction,
        cv_rms_deg: l.cv_rms_deg.unwrap_or(f64::NAN),
    })
}

/// Reads a gyro calibration file (bounded in size) and checks it.
pub fn read_gyro_calibration(path: &Path) -> Result<GyroCalFile> {
    let text = read_text(path, MAX_CALIBRATION_BYTES)?;
    parse(&text).map_err(|cause| {
        OutputError::InvalidGyroCalibrationFile {
            path: path.into(),
            cause,
        }
        .into()
    })
}

/// A gyro file's calibration as the adapter holds it for a Wii MotionPlus (issue 50 item 2):
/// the linear part turned from the accelerometer's frame into the MotionPlus's count axes.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionPlusGyro {
    /// What the adapter applies, `ω_c = K_c·(m − b)`: `m` the MotionPlus's slow-range counts
    /// (the file's gyro columns, which must be them, in report order yaw, roll, pitch), `ω_c`
    /// rad/s along the count axes (positive where each count rises), `K_c = R·K`. No effect
    /// terms (see [`Self::host_only`]).
    pub device: GyroCorrection<f32>,
    /// `R` row by row: count axis `i` measures the accelerometer frame's axis `axes[i].0`
    /// with the sign `axes[i].1` (±1): `ω_c[i] = axes[i].1 · ω[axes[i].0]`.
    pub axes: [(usize, f64); 3],
    /// The file's non-zero terms that the adapter does not apply (rows of
    /// [`GYRO_TERMS`] without `device_applies`: the g-sensitivity needs the accelerometer
    /// fixed to the gyro, which is in the Wii Remote); they stay in the file for hosts.
    pub host_only: Vec<&'static str>,
}

/// Turns a gyro file's calibration (`ω = K·(m − b)`, rad/s in the accelerometer's frame, as
/// `gyrofit` fits it) into the MotionPlus's count axes, which the adapter's corrector works
/// in: for each count column `i` the accelerometer axis it turns about most (the largest
/// `|K[a][i]|`) and that entry's sign give row `i` of a signed permutation `R`, and
/// `K_c = R·K`, `b` unchanged. `R` is orthogonal, so `ω_c = R·ω` exactly (no rate changes
/// but its axes), `K_c`'s diagonal is positive (each count rises with its own rate) and the
/// misalignment stays in its off-diagonal terms. Units stay rad/s and counts; the adapter
/// re-encodes the corrected rates as counts at its ideal scale (18.618 counts per °/s slow).
/// `Err` (one sentence) when two count columns turn about the same accelerometer axis: the
/// file is then no MotionPlus's in a Wii Remote.
pub fn for_motionplus(c: &GyroCorrection<f64>) -> std::result::Result<MotionPlusGyro, String> {
    const AXES: [&str; 3] = ["x", "y", "z"];
    const COUNTS: [&str; 3] = ["yaw", "roll", "pitch"];
    let k = &c.matrix;
    let mut axes = [(0usize, 1.0f64); 3];
    for (i, axis) in axes.iter_mut().enumerate() {
        let a = (0..3)
            .max_by(|&p, &q| k[p][i].abs().total_cmp(&k[q][i].abs()))
            .unwrap_or(0);
        *axis = (a, if k[a][i] < 0.0 { -1.0 } else { 1.0 });
    }
    for i in 0..3 {
        for j in i + 1..3 {
            if axes[i].0 == axes[j].0 {
                return Err(format!(
                    "the gyro's count columns {} and {} both turn mostly about the accelerometer's {} axis, so they cannot be the MotionPlus's count axes",
                    COUNTS[i], COUNTS[j], AXES[axes[i].0]
                ));
            }
        }
    }
    let kc: [[f64; 3]; 3] = core::array::from_fn(|i| {
        let (a, sign) = axes[i];
        k[a].map(|x| sign * x)
    });
    let device = GyroCorrection {
        bias: c.bias.map(|x| x as f32),
        matrix: kc.map(|row| row.map(|x| x as f32)),
        effects: GyroEffects::default(),
    };
    let host_only = GYRO_TERMS
        .iter()
        .filter(|t| !t.device_applies && c.effects.field(t.id).iter().any(|x| *x != 0.0))
        .map(|t| t.name)
        .collect();
    Ok(MotionPlusGyro {
        device,
        axes,
        host_only,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values with short decimal forms (serde_json's default reader may be one ulp off on
    /// others).
    fn sample(g: bool) -> GyroCalFile {
        let s = 1.0642e-3;
        let mut correction = GyroCorrection {
            bias: [-31.0, 12.5, 7.25],
            matrix: [[s, 1e-6, 0.0], [0.0, 1.01 * s, 0.0], [0.0, 2e-6, -0.99 * s]],
            effects: GyroEffects::default(),
        };
        if g {
            correction.effects.g_sensitivity[0] = [1.7e-3, -3e-4, 8e-4];
            correction.effects.g_sensitivity[2][2] = -1.4e-3;
        }
        GyroCalFile {
            model: "full+bias".into(),
            correction,
            cv_rms_deg: 0.547,
        }
    }

    /// Without terms the file is version 1 with the keys (and order) it had before them; with
    /// G it is version 2 with `effects.g_sensitivity` as three rows; both read back exactly.
    #[test]
    fn versions_follow_the_terms_and_round_trip() {
        let plain = to_text(&sample(false)).unwrap();
        let keys: Vec<&str> = plain
            .lines()
            .filter_map(|l| l.strip_prefix("  \"")?.split('"').next())
            .collect();
        assert_eq!(
            keys,
            ["format", "model", "bias", "matrix", "units", "cv_rms_deg"]
        );
        assert!(plain.contains(FORMAT_V1));
        assert_eq!(parse(&plain).unwrap(), sample(false));
        let with_g = to_text(&sample(true)).unwrap();
        assert!(with_g.contains("\"format\": \"wiical-gyro-calibration/2\""));
        let v: serde_json::Value = serde_json::from_str(&with_g).unwrap();
        assert_eq!(v["effects"]["g_sensitivity"][0][0], 1.7e-3);
        assert_eq!(v["effects"]["g_sensitivity"][2][2], -1.4e-3);
        assert_eq!(parse(&with_g).unwrap(), sample(true));
    }

    #[test]
    fn wrong_files_are_refused_naming_the_reason() {
        let with_g = to_text(&sample(true)).unwrap();
        let as_v1 = with_g.replace("calibration/2", "calibration/1");
        assert!(parse(&as_v1)
            .unwrap_err()
            .contains("version 1 holds no such"));
        let future = with_g.replace("calibration/2", "calibration/9");
        assert!(parse(&future).unwrap_err().contains("is not"));
        let typo = with_g.replace("g_sensitivity", "g-sensitivity");
        assert!(parse(&typo).unwrap_err().contains("unknown effect term"));
        let short = with_g
            .replacen("-0.0014", "", 1)
            .replace(",\n      \n", "\n");
        assert!(parse(&short).is_err());
        let mut huge = sample(true);
        huge.correction.effects.g_sensitivity[1][1] = 1.0; // 57 °/s/g
        assert!(to_text(&huge).is_err());
        let extra = with_g.replacen("\"units\"", "\"unit\": 1, \"units\"", 1);
        assert!(parse(&extra).is_err());
    }

    /// The count-axes conversion against a mounting written out here: the MotionPlus's yaw
    /// count turns about the accelerometer's −z, roll about +y, pitch about −x (a left-handed
    /// count frame, as Dolphin says the block is). The file's `K` is built as `Rᵀ·K_c` from a
    /// known `K_c` (positive diagonal, 1–2 % misalignment); the conversion gives `R` and
    /// `K_c` back, and rates from random counts agree (`ω_c = R·ω`) within f32 rounding.
    #[test]
    fn a_motionplus_file_is_turned_into_its_count_axes() {
        let s = std::f64::consts::PI / 180.0 / 18.4;
        let kc = [
            [s, 0.012 * s, -0.004 * s],
            [-0.008 * s, 1.02 * s, 0.0],
            [0.02 * s, 0.0, 0.98 * s],
        ];
        // Rows of R: (accelerometer axis, sign) for yaw, roll, pitch.
        let r = [(2usize, -1.0), (1, 1.0), (0, -1.0)];
        let mut k = [[0.0; 3]; 3];
        for (i, (a, sign)) in r.iter().enumerate() {
            k[*a] = kc[i].map(|x| sign * x);
        }
        let mut file = GyroCorrection {
            bias: [8100.5, 8230.0, 8150.25],
            matrix: k,
            effects: GyroEffects::default(),
        };
        file.effects.g_sensitivity[1][2] = 1e-3;
        let m = for_motionplus(&file).unwrap();
        assert_eq!(m.axes, r);
        assert_eq!(m.host_only, vec!["g_sensitivity"]);
        assert!(m.device.effects.is_none());
        assert_eq!(m.device.bias, file.bias.map(|x| x as f32));
        for (row, want) in m.device.matrix.iter().zip(&kc) {
            for (got, want) in row.iter().zip(want) {
                assert!(
                    (f64::from(*got) - want).abs() <= want.abs() * 1e-7,
                    "{got} {want}"
                );
            }
        }
        let mut rng = 0x2545_f491_u64;
        for _ in 0..100 {
            let counts: [f64; 3] = core::array::from_fn(|_| {
                rng = rng.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                (rng >> 33) as f64 % 16384.0
            });
            let w = file.correct_linear(counts);
            let wc = m.device.correct_linear(counts.map(|x| x as f32));
            for i in 0..3 {
                let want = r[i].1 * w[r[i].0];
                let bound = 8.0 * f64::from(f32::EPSILON) * (w[r[i].0].abs() + 16384.0 * 2.0 * s);
                assert!(
                    (f64::from(wc[i]) - want).abs() <= bound,
                    "{i}: {} vs {want}",
                    wc[i]
                );
            }
        }
        // Two count columns about one accelerometer axis: refused, naming them.
        let mut twice = file;
        twice.matrix[0][0] = 2.0 * s;
        let e = for_motionplus(&twice).unwrap_err();
        assert!(
            e.contains("yaw and pitch both turn mostly about the accelerometer's x axis"),
            "{e}"
        );
    }
}

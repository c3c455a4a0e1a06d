//! One still pose: the AHRS seed's accelerometer offsets (average the rest, subtract ±1 g on
//! the vertical axis; the other axes' mean is their offset).
//!
//! One pose measures three numbers, so it gives three offsets and nothing else: the scale and
//! misalignment are kept nominal (1 for data in g, 1/9.80665 for m/s²) and said to be
//! unmeasured. The horizontal offsets hold only if the sensor sat level — a tilt of 1° reads as
//! 17 mg — which one pose cannot tell apart from a bias; the report says so.

use super::faces::WindowFace;
use crate::detect::windows::WindowStats;
use serde::Serialize;
use wiical_core::Calibration;

/// Standard gravity, m/s² (the nominal of data in m/s²).
const G_MS2: f64 = 9.80665;

/// The one-pose offsets.
#[derive(Debug, Clone, Serialize)]
pub struct OffsetReport {
    /// The vertical axis (`z+` = +z up).
    pub vertical: Option<&'static str>,
    /// How far the pose is from that axis, degrees.
    pub off_deg: f64,
    /// Offsets, raw units (what `bias` holds).
    pub offsets: [f64; 3],
    /// The same in mg (`null` for raw counts, whose scale one pose cannot give).
    pub offsets_mg: Option<[f64; 3]>,
    /// Standard error of each offset from the rest's noise, mg (`null` for raw counts).
    pub std_error_mg: Option<[f64; 3]>,
    /// Samples averaged.
    pub samples: usize,
}

/// Why one pose gives no offsets.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OffsetError {
    /// No axis within 20° of vertical.
    #[error(
        "one still pose with no axis near vertical ({off:.0}° from the nearest): offsets need \
         an axis pointing up or down; rest the sensor flat on a face"
    )]
    NotLevel {
        /// Angle from the nearest axis, degrees.
        off: f64,
    },
}

/// The nominal scale of `units`: 1 g in the data's units (`None` for raw counts).
pub fn one_g(units: &str) -> Option<f64> {
    match units {
        "g" => Some(1.0),
        "m/s^2" => Some(G_MS2),
        _ => None,
    }
}

/// Offsets from the windows of one pose (`faces[0]` its face). Raw counts keep the measured
/// magnitude as their 1 g, so their vertical offset is the zero reading (`zero`) by assumption.
pub fn offsets(
    windows: &[WindowStats],
    face: &WindowFace,
    units: &str,
    zero: [f64; 3],
) -> Result<(Calibration, OffsetReport), OffsetError> {
    let pose = face
        .pose
        .ok_or(OffsetError::NotLevel { off: face.off_deg })?;
    let n: usize = windows.iter().map(|w| w.count.unwrap_or(1)).sum();
    let mean: [f64; 3] = std::array::from_fn(|a| {
        windows
            .iter()
            .map(|w| w.count.unwrap_or(1) as f64 * w.mean[a])
            .sum::<f64>()
            / n as f64
    });
    let axis = pose as usize / 2;
    let up = pose.direction()[axis] as f64;
    let g = one_g(units).unwrap_or_else(|| (mean[axis] - zero[axis]).abs());
    let mut offsets = if one_g(units).is_some() { mean } else { zero };
    if one_g(units).is_none() {
        for a in (0..3).filter(|a| *a != axis) {
            offsets[a] = mean[a];
        }
    }
    offsets[axis] = mean[axis] - up * g;
    let var: [f64; 3] = std::array::from_fn(|a| {
        windows
            .iter()
            .map(|w| w.count.unwrap_or(1) as f64 * w.var[a])
            .sum::<f64>()
            / n as f64
    });
    let mg = |v: f64| 1000.0 * v / g;
    let known = one_g(units).is_some();
    let cal = Calibration {
        bias: offsets.map(|v| v as f32),
        matrix: std::array::from_fn(|r| {
            std::array::from_fn(|c| if r == c { (1.0 / g) as f32 } else { 0.0 })
        }),
        effects: Default::default(),
    };
    Ok((
        cal,
        OffsetReport {
            vertical: Some(pose.label()),
            off_deg: face.off_deg,
            offsets,
            offsets_mg: known.then(|| offsets.map(mg)),
            std_error_mg: known.then(|| var.map(|v| mg((v / n as f64).sqrt()))),
            samples: n,
        },
    ))
}

/// What one pose cannot give, one sentence each.
pub fn not_identified(units: &str) -> Vec<String> {
    let mut out = vec![
        "scale and misalignment were not measured (one pose gives three numbers): they are \
         kept nominal; record the six faces (each axis up and down) to measure them"
            .to_string(),
        "the horizontal offsets assume the sensor sat level: 1° of tilt reads as 17 mg".to_string(),
    ];
    if one_g(units).is_none() {
        out.push(
            "the data are raw counts: the vertical axis's offset needs its sensitivity (counts \
             per g), which one pose cannot give, so it is taken as the zero reading"
                .to_string(),
        );
    }
    out
}

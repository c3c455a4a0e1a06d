//! What a protocol simulation knows: both sensors' truth, the faces held (and which are
//! missing or repeated), and every segment of the motion with its samples, axis, angle and
//! rates (written to `FILE.truth.json`).

use serde::Serialize;

use super::imu::AxesTruth;
use super::path::SegmentKind;
use super::plans::Plan;
use super::record::Imu;
use super::{Face, ProtocolSimOptions};
use crate::gyro::GyroTruth;

/// One segment of the motion.
#[derive(Debug, Clone, Serialize)]
pub struct TrueSegment {
    /// What it is.
    pub kind: SegmentKind,
    /// The face held or tumbled to (`x+`), the axis turned about (`x`, rotations and the
    /// rests around them, rate-table spins), the turntable orientation (`o1`); may be empty.
    pub label: String,
    /// First sample (row of the file, from 0).
    pub first: usize,
    /// One past the last sample.
    pub end: usize,
    /// Start, s.
    pub t_start: f64,
    /// End, s.
    pub t_end: f64,
    /// Rotation axis, unit vector in the fixture frame; zero for a rest.
    pub axis: [f64; 3],
    /// Angle turned about `axis` over the segment, degrees (right-handed).
    pub angle_deg: f64,
    /// Rate about `axis` at the start, °/s.
    pub rate_start_dps: f64,
    /// Rate about `axis` at the end, °/s (equal to the start's for a steady rate).
    pub rate_end_dps: f64,
    /// Gravity's direction (up, 1 g at rest) in the fixture frame at the start.
    pub up_start: [f64; 3],
    /// The same at the end.
    pub up_end: [f64; 3],
}

/// Everything a protocol simulation knows (module docs of `protocols` for the conventions).
#[derive(Debug, Clone, Serialize)]
pub struct ProtocolTruth {
    /// [`super::SimProtocol::name`].
    pub protocol: &'static str,
    /// Seed.
    pub seed: u64,
    /// Sample rate, Hz (also when no time column is written).
    pub rate_hz: f64,
    /// Number of samples.
    pub samples: usize,
    /// The file's columns, in order.
    pub columns: Vec<&'static str>,
    /// The accelerometer (`m = D·a + b`, `a` in g); absent when it is not written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accel: Option<AxesTruth>,
    /// The gyro (`m = D·(ω + G·a) + b`, `ω` rad/s, `K = D⁻¹` raw → rad/s as in
    /// [`GyroTruth::matrix`]).
    pub gyro: AxesTruth,
    /// `G`, rad/s per g: row = gyro axis, column = fixture axis of the specific force.
    pub gyro_g_sensitivity: [[f64; 3]; 3],
    /// The faces held, in order (`x+`, …; empty for the rate table and the turntable).
    pub faces: Vec<String>,
    /// Faces of the six never held (six-faces, Ferraris, face-missing).
    pub missing_faces: Vec<String>,
    /// Faces held more than once.
    pub repeated_faces: Vec<String>,
    /// Every segment, in order, covering every sample.
    pub segments: Vec<TrueSegment>,
}

impl ProtocolTruth {
    /// The gyro's truth as [`GyroTruth`] (matrix, bias, g-sensitivity; no other effect).
    pub fn gyro_truth(&self) -> GyroTruth {
        GyroTruth {
            matrix: self.gyro.matrix,
            bias: self.gyro.bias,
            g_sensitivity: self.gyro_g_sensitivity,
            ..Default::default()
        }
    }

    /// The segments of one kind.
    pub fn segments_of(&self, kind: SegmentKind) -> impl Iterator<Item = &TrueSegment> {
        self.segments.iter().filter(move |s| s.kind == kind)
    }
}

/// The truth of a simulation.
pub(super) fn truth(
    o: &ProtocolSimOptions,
    imu: &Imu,
    plan: &Plan,
    ranges: &[(usize, usize)],
    clock: bool,
) -> ProtocolTruth {
    let accel_written = o.protocol != super::SimProtocol::Turntable;
    let mut columns = Vec::new();
    if clock {
        columns.push("t");
    }
    if accel_written {
        columns.extend(["ax", "ay", "az"]);
    }
    columns.extend(["gx", "gy", "gz"]);
    let count = |f: Face| plan.faces.iter().filter(|g| **g == f).count();
    // Only a protocol meant to hold all six faces can miss one (not the one pose either).
    let sided = plan.faces.len() >= 6;
    ProtocolTruth {
        protocol: o.protocol.name(),
        seed: o.seed,
        rate_hz: o.rate_hz,
        samples: ranges.last().map_or(0, |r| r.1),
        columns,
        accel: accel_written.then(|| imu.accel.clone()),
        gyro: imu.gyro.clone(),
        gyro_g_sensitivity: imu.g_sensitivity,
        faces: plan.faces.iter().map(|f| f.name()).collect(),
        missing_faces: names(Face::SIX.into_iter().filter(|f| sided && count(*f) == 0)),
        repeated_faces: names(Face::SIX.into_iter().filter(|f| count(*f) > 1)),
        segments: segments(plan, ranges),
    }
}

/// Face names.
fn names(faces: impl Iterator<Item = Face>) -> Vec<String> {
    faces.map(|f| f.name()).collect()
}

/// The truth of every segment of `plan`.
fn segments(plan: &Plan, ranges: &[(usize, usize)]) -> Vec<TrueSegment> {
    let up = |r: &nalgebra::Rotation3<f64>| (r.inverse() * nalgebra::Vector3::z()).into();
    plan.path
        .segs
        .iter()
        .zip(ranges)
        .map(|(s, &(first, end))| {
            let (angle, w0, w1) = s.totals();
            let still = s.kind == SegmentKind::Rest;
            TrueSegment {
                kind: s.kind,
                label: s.label.clone(),
                first,
                end,
                t_start: s.t0,
                t_end: s.t1(),
                axis: if still {
                    [0.0; 3]
                } else {
                    s.axis.into_inner().into()
                },
                angle_deg: angle.to_degrees(),
                rate_start_dps: w0.to_degrees(),
                rate_end_dps: w1.to_degrees(),
                up_start: up(&s.r0),
                up_end: up(&s.r1()),
            }
        })
        .collect()
}

//! Calibration protocols recognised from the data, and the method each one calls for.
//!
//! A calibration protocol is a first-class object here (as in imucal), not a file layout: what
//! the recording *did* — which faces it rested on, how it turned between rests, at which
//! constant rates — is read from the still windows the detector found, once, for every
//! command, and decides the method:
//!
//! | recognised | method | room |
//! |---|---|---|
//! | free poses (today's protocol: windows off the faces) | the multi-position fit ([`crate::fit::base`]) | — |
//! | six faces (each axis up and down; repeats averaged) | the seed's six-position method `T̂ = M·Â⁺` | [`face_fit`] |
//! | four or five faces | the same formula on fewer columns; single-sided axes named with the face to add | [`face_fit`] |
//! | one pose with an axis near vertical | the AHRS seed's offsets (scale and misalignment not measured) | [`offsets`] |
//! | full turns between rests (Ferraris) | gyro scale and misalignment from a known angle; its g-sensitivity from the rests | [`rotations`], [`g_sensitivity`] |
//! | constant known rates (rate table, turntable) | gyro scale, misalignment, bias from the rates | [`rates`] |
//!
//! When the accelerometer's fit refuses a file that does not name its sensor, [`sensor_kind`]
//! says whether the samples look like a gyroscope's or a magnetometer's, and which command
//! calibrates them.
//!
//! The free-pose protocol keeps today's pipeline unchanged (its outputs carry no `protocol`
//! key); the others add a `protocol` object to the JSON and a `protocol:` line to the text.

pub mod accel;
pub mod face_fit;
pub mod faces;
pub mod g_sensitivity;
pub mod gyro;
pub(crate) mod labelled;
pub mod offsets;
pub mod rates;
pub mod rotations;
pub mod sensor_kind;
pub(crate) mod vec3;

use crate::detect::windows::Windows;
use faces::{face_set, one_pose, window_face, zero_reading, FaceSet, WindowFace};
use serde::Serialize;

/// What the accelerometer's still windows are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum AccelProtocol {
    /// No still window.
    None,
    /// One pose held (perhaps with pauses).
    OnePose,
    /// Every window on a face of the sensor (the six-position family).
    Faces,
    /// Poses in free orientations: today's multi-position protocol.
    FreePoses,
}

/// The recognition of a recording's still windows.
#[derive(Debug, Clone)]
pub struct AccelRecognition {
    /// The protocol.
    pub protocol: AccelProtocol,
    /// Each window's face.
    pub faces: Vec<WindowFace>,
    /// The faces' summary.
    pub set: FaceSet,
    /// The reading at 0 g the directions were taken from.
    pub zero: [f64; 3],
}

/// Recognises the protocol of the still windows `ws` (their means only: costs nothing beside
/// the detection, and the same for held and streamed recordings).
pub fn recognise(ws: &Windows) -> AccelRecognition {
    let means: Vec<[f64; 3]> = ws.stats.iter().map(|w| w.mean).collect();
    let zero = zero_reading(&means, ws.units);
    let faces: Vec<WindowFace> = means.iter().map(|m| window_face(*m, zero)).collect();
    let set = face_set(&faces);
    let protocol = if faces.is_empty() {
        AccelProtocol::None
    } else if one_pose(&faces) && faces[0].pose.is_some() {
        // One pose gives offsets only with an axis near vertical; otherwise the
        // multi-position fit's own refusal says what to record, as before.
        AccelProtocol::OnePose
    } else if set.all_faces {
        AccelProtocol::Faces
    } else {
        AccelProtocol::FreePoses
    };
    AccelRecognition {
        protocol,
        faces,
        set,
        zero,
    }
}

/// Number words for the summary line.
fn count_word(n: usize) -> String {
    ["no", "one", "two", "three", "four", "five", "six"]
        .get(n)
        .map_or_else(|| n.to_string(), |w| (*w).to_string())
}

impl AccelRecognition {
    /// One line: `six faces (x+ x- y+ y- z+ z-); z+ held twice`, `one pose (z+ up, 1.1° off)`,
    /// `free poses (38 still windows, 9 on a face)`.
    pub fn summary(&self) -> String {
        let set = &self.set;
        match self.protocol {
            AccelProtocol::None => "no still pose".into(),
            AccelProtocol::OnePose => {
                let f = &self.faces[0];
                let up = f.pose.map_or("?", |p| p.label());
                format!("one pose ({up} up, {:.1}° off the axis)", f.off_deg)
            }
            AccelProtocol::Faces => {
                let mut s = format!(
                    "{} faces ({})",
                    count_word(set.distinct.len()),
                    set.distinct.join(" ")
                );
                for r in &set.repeated {
                    let n = set.counts
                        [wiical_core::six_position::Pose::from_label(r).map_or(0, |p| p as usize)];
                    s.push_str(&format!(", {r} held {} times", n));
                }
                if !set.missing.is_empty() {
                    s.push_str(&format!(", missing {}", set.missing.join(" ")));
                }
                s
            }
            AccelProtocol::FreePoses => format!(
                "free poses ({} still windows, {} on a face)",
                self.faces.len(),
                self.faces.len() - set.off_face_windows
            ),
        }
    }
}

/// The `protocol` object of an accelerometer report (absent for free poses).
#[derive(Debug, Clone, Serialize)]
pub struct ProtocolReport {
    /// What was recognised, as printed after `protocol:`.
    pub summary: String,
    /// The recognised protocol.
    pub kind: AccelProtocol,
    /// The method used: `six-position`, `faces`, `one-pose-offsets`.
    pub method: &'static str,
    /// The faces: distinct, repeated, missing.
    pub faces: FaceSet,
    /// The six-position family's details.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub face_fit: Option<face_fit::FaceFitReport>,
    /// The one-pose offsets' details.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub offsets: Option<offsets::OffsetReport>,
    /// What the protocol could not identify, one sentence each.
    pub not_identified: Vec<String>,
}

//! Calibration protocols with known truth: an IMU (accelerometer and gyroscope, raw 16-bit
//! counts) on a fixture, moved the way each calibration method asks, for testing the
//! recognition of a protocol and the methods that fit it.
//!
//! | protocol | the motion | written |
//! |---|---|---|
//! | `six-faces` | a fixture resting on each of its faces in turn (x+ x− y+ y− z+ z−, tilted ≤ [`FIXTURE_TILT_DEG`]), `face_s` each, with tumbles of `tumble_s` between them | `t,ax,ay,az,gx,gy,gz` (no `t` with `no_clock`) |
//! | `one-pose` | one still pose, z up within [`ONE_POSE_TILT_DEG`], `one_pose_s` | the same |
//! | `ferraris` | the six faces hand-placed (tilts ≤ [`HAND_TILT_DEG`]), then for x, y, z: a rest, a rotation of `rotation_deg` about an axis within [`ROTATION_AXIS_DEG`] of it (lopsided rate, `rotation_s`), a rest | the same |
//! | `rate-table` | a rest, then for x, y, z and each sign: spin-up (`ramp_s`), `table_rate_dps` for `spin_s` about the table's axis (within [`TABLE_AXIS_DEG`]), spin-down, rest; gravity is world +z throughout, so the accelerometer sees it turn | the same |
//! | `turntable` | `turntable_orientations` random orientations on a record player's platter, each at the speeds `turntable_rates_dps` (`turntable_hold_s` each, ramps between); the re-orientations are not recorded | `gx,gy,gz` only: no clock, no accelerometer |
//! | `face-missing` | `six-faces` with `missing_face` left out and `repeated_face` held in its place (default: z+ missing, z− twice) | as `six-faces` |
//!
//! Conventions (those of [`crate::Truth`] and [`crate::gyro::GyroTruth`]): the fixture's
//! frame is the reference ("the faces", "the axes"); the accelerometer reads
//! `m = D·a + b` (`a` the specific force in g, 1 g up at rest), the gyro `m = K⁻¹·(ω + G·a) + b`
//! (`ω` rad/s, right-handed, `G` rad/s per g), both in counts rounded to whole numbers, see
//! [`AxesTruth`]. Angles and rates in the truth are in degrees and °/s, about the
//! [`TrueSegment::axis`] given in the fixture frame.
//!
//! The IMU is drawn from the seed alone (its own random stream), so one seed gives the same
//! sensors under every protocol; the motion is drawn from a second stream.
//!
//! One concern a file: `path` (the motion in closed form), `imu` (the sensors and their
//! truth), `plans` (each protocol's motion), `record` (the samples), `truth` (what is known),
//! `files` (CSV and JSON out).

mod files;
mod imu;
mod path;
mod plans;
mod record;
mod truth;

pub use files::{protocol_csv, write_protocol};
pub use imu::AxesTruth;
pub use path::SegmentKind;
pub use plans::{
    FIXTURE_TILT_DEG, HAND_TILT_DEG, ONE_POSE_TILT_DEG, ROTATION_AXIS_DEG, TABLE_AXIS_DEG,
};
pub use truth::{ProtocolTruth, TrueSegment};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use wiical_analysis::Recording;

/// The calibration protocols simulated (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimProtocol {
    /// A fixture on each of its six faces.
    SixFaces,
    /// One still pose, z up.
    OnePose,
    /// Six faces, then a rotation of a known angle about each axis.
    Ferraris,
    /// Constant known rates about each axis.
    RateTable,
    /// Known rate magnitudes on a record player, gyro only, no clock.
    Turntable,
    /// Six faces with one missing and another repeated.
    FaceMissing,
}

impl SimProtocol {
    /// Every protocol, in the order of the module docs.
    pub const ALL: [SimProtocol; 6] = [
        SimProtocol::SixFaces,
        SimProtocol::OnePose,
        SimProtocol::Ferraris,
        SimProtocol::RateTable,
        SimProtocol::Turntable,
        SimProtocol::FaceMissing,
    ];

    /// Parses a [`SimProtocol::name`] (`_` taken for `-`).
    pub fn parse(s: &str) -> Option<Self> {
        let s = s.trim().replace('_', "-");
        Self::ALL.into_iter().find(|p| p.name() == s)
    }

    /// The protocol's name on the command line and in the truth.
    pub fn name(self) -> &'static str {
        match self {
            SimProtocol::SixFaces => "six-faces",
            SimProtocol::OnePose => "one-pose",
            SimProtocol::Ferraris => "ferraris",
            SimProtocol::RateTable => "rate-table",
            SimProtocol::Turntable => "turntable",
            SimProtocol::FaceMissing => "face-missing",
        }
    }
}

/// A face of the fixture, named by the fixture axis that points up when it rests on it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Face {
    /// 0, 1, 2 for x, y, z.
    pub axis: usize,
    /// The axis points up (`+`) or down (`−`).
    pub up: bool,
}

impl Face {
    /// The six faces in the order a six-position protocol holds them: x+ x− y+ y− z+ z−.
    pub const SIX: [Face; 6] = [
        Face { axis: 0, up: true },
        Face { axis: 0, up: false },
        Face { axis: 1, up: true },
        Face { axis: 1, up: false },
        Face { axis: 2, up: true },
        Face { axis: 2, up: false },
    ];

    /// `x+`, `x-`, …
    pub fn name(self) -> String {
        let axis = ["x", "y", "z"][self.axis.min(2)];
        format!("{axis}{}", if self.up { '+' } else { '-' })
    }

    /// Parses a [`Face::name`].
    pub fn parse(s: &str) -> Option<Self> {
        Self::SIX.into_iter().find(|f| f.name() == s.trim())
    }

    /// The unit vector pointing up when resting on this face, fixture frame.
    pub fn direction(self) -> [f64; 3] {
        let mut d = [0.0; 3];
        d[self.axis.min(2)] = if self.up { 1.0 } else { -1.0 };
        d
    }
}

/// What is simulated. Durations in seconds; each face, tumble and rest is drawn within ±10 %
/// (tumbles ±20 %) of its nominal length.
#[derive(Debug, Clone)]
pub struct ProtocolSimOptions {
    /// The protocol.
    pub protocol: SimProtocol,
    /// Seed of every random choice.
    pub seed: u64,
    /// Sample rate, Hz (positive).
    pub rate_hz: f64,
    /// Write no time column (the turntable never writes one).
    pub no_clock: bool,
    /// Each face held, s.
    pub face_s: f64,
    /// Each tumble between two faces (and re-grip before a rotation), s.
    pub tumble_s: f64,
    /// The one pose, s.
    pub one_pose_s: f64,
    /// Each rest around a Ferraris rotation and between rate-table spins, s.
    pub rest_s: f64,
    /// Ferraris rotation angle, degrees (positive: right-handed about the axis).
    pub rotation_deg: f64,
    /// Each rotation's true angle is drawn within `rotation_deg ±` this, degrees (0: exact).
    pub rotation_jitter_deg: f64,
    /// Range of a Ferraris rotation's duration, s.
    pub rotation_s: (f64, f64),
    /// The rate table's rate, °/s (each axis turned at `+` and `−` this).
    pub table_rate_dps: f64,
    /// Each constant rate of the rate table held, s.
    pub spin_s: f64,
    /// Each spin-up or spin-down (rate table, turntable), s.
    pub ramp_s: f64,
    /// Orientations on the turntable.
    pub turntable_orientations: usize,
    /// The turntable's speeds in the order played at each orientation, °/s (0: stopped);
    /// the platter turns clockwise seen from above.
    pub turntable_rates_dps: Vec<f64>,
    /// Each speed held per orientation, s.
    pub turntable_hold_s: f64,
    /// `face-missing`: the face never held.
    pub missing_face: Face,
    /// `face-missing`: the face held in its place (so twice).
    pub repeated_face: Face,
    /// Accelerometer sensitivity, counts per g.
    pub accel_counts_per_g: f64,
    /// Accelerometer white noise per sample, milli-g.
    pub accel_noise_mg: f64,
    /// Gyro sensitivity, counts per °/s.
    pub gyro_counts_per_dps: f64,
    /// Gyro white noise per sample, °/s.
    pub gyro_noise_dps: f64,
    /// Largest element of the gyro's g-sensitivity, °/s per g (each drawn in ±this; 0: none).
    pub g_sensitivity_dps_per_g: f64,
}

impl Default for ProtocolSimOptions {
    /// Six faces at 100 Hz, 20 s a face, 2 s tumbles; a BMI160/MPU-like IMU: 16 384 counts/g
    /// with 1.2 mg of noise, 16.4 counts per °/s (±2000 °/s) with 0.07 °/s of noise; Ferraris
    /// rotations of exactly 360° in 2–4 s; the rate table at ±25 °/s for 20 s with 1 s ramps;
    /// the turntable at 0, 200, 270 °/s (33⅓ and 45 RPM), 8 orientations, 10 s each.
    fn default() -> Self {
        Self {
            protocol: SimProtocol::SixFaces,
            seed: 1,
            rate_hz: 100.0,
            no_clock: false,
            face_s: 20.0,
            tumble_s: 2.0,
            one_pose_s: 60.0,
            rest_s: 5.0,
            rotation_deg: 360.0,
            rotation_jitter_deg: 0.0,
            rotation_s: (2.0, 4.0),
            table_rate_dps: 25.0,
            spin_s: 20.0,
            ramp_s: 1.0,
            turntable_orientations: 8,
            turntable_rates_dps: vec![0.0, 200.0, 270.0],
            turntable_hold_s: 10.0,
            missing_face: Face { axis: 2, up: true },
            repeated_face: Face { axis: 2, up: false },
            accel_counts_per_g: 16384.0,
            accel_noise_mg: 1.2,
            gyro_counts_per_dps: 16.4,
            gyro_noise_dps: 0.07,
            g_sensitivity_dps_per_g: 0.0,
        }
    }
}

/// A simulated protocol: what the file holds and the truth.
#[derive(Debug, Clone)]
pub struct ProtocolSim {
    /// Sample times, s (`i / rate_hz`); `None` when no time column is written.
    pub t: Option<Vec<f64>>,
    /// Accelerometer, whole counts; `None` when not written (turntable).
    pub accel: Option<Vec<[f64; 3]>>,
    /// Gyro, whole counts.
    pub gyro: Vec<[f64; 3]>,
    /// The truth.
    pub truth: ProtocolTruth,
}

impl ProtocolSim {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.gyro.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.gyro.is_empty()
    }

    /// The accelerometer as a [`Recording`] (columns `ax,ay,az`), when written.
    pub fn accel_recording(&self) -> Option<Recording> {
        let xyz = self.accel.clone()?;
        Some(self.recording(xyz, ["ax", "ay", "az"]))
    }

    /// The gyro as a [`Recording`] (columns `gx,gy,gz`).
    pub fn gyro_recording(&self) -> Recording {
        self.recording(self.gyro.clone(), ["gx", "gy", "gz"])
    }

    fn recording(&self, xyz: Vec<[f64; 3]>, names: [&str; 3]) -> Recording {
        Recording {
            t: self.t.clone(),
            xyz,
            axis_columns: names.map(String::from),
            ..Default::default()
        }
    }
}

/// Simulates one protocol (module docs). A `rate_hz` that is not positive gives no samples.
pub fn simulate_protocol(o: &ProtocolSimOptions) -> ProtocolSim {
    let mut imu_rng = ChaCha8Rng::seed_from_u64(o.seed);
    let mut motion_rng = ChaCha8Rng::seed_from_u64(o.seed);
    motion_rng.set_stream(1);
    let imu = record::Imu::draw(&mut imu_rng, o);
    let plan = plans::plan(o, &mut motion_rng);
    let fs = if o.rate_hz.is_finite() && o.rate_hz > 0.0 {
        o.rate_hz
    } else {
        0.0
    };
    let rec = record::record(&plan.path.segs, fs, &imu, &mut motion_rng);
    let accel_written = o.protocol != SimProtocol::Turntable;
    let clock = accel_written && !o.no_clock;
    let truth = truth::truth(o, &imu, &plan, &rec.ranges, clock);
    let n = rec.gyro.len();
    ProtocolSim {
        t: clock.then(|| (0..n).map(|i| i as f64 / fs).collect()),
        accel: accel_written.then_some(rec.accel),
        gyro: rec.gyro,
        truth,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_back() {
        for p in SimProtocol::ALL {
            assert_eq!(SimProtocol::parse(p.name()), Some(p));
        }
        assert_eq!(
            SimProtocol::parse("rate_table"),
            Some(SimProtocol::RateTable)
        );
        assert_eq!(SimProtocol::parse("sixfaces"), None);
        for f in Face::SIX {
            assert_eq!(Face::parse(&f.name()), Some(f));
        }
    }
}

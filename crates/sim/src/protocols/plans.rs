//! Each protocol's motion: the poses (a face up with a small tilt and any heading), the
//! tumbles between them, the rotations and the spins, as a [`Path`].

use nalgebra::{Rotation3, Unit, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::{PI, TAU};

use super::imu::uniform;
use super::path::{Path, Profile, SegmentKind};
use super::{Face, ProtocolSimOptions, SimProtocol};
use crate::geometry::{random_unit, tilt};

/// Largest tilt of a fixture's face from level (a table that is not quite level), degrees.
pub const FIXTURE_TILT_DEG: f64 = 0.5;
/// Largest tilt of a hand-placed face (Ferraris), degrees.
pub const HAND_TILT_DEG: f64 = 3.0;
/// Largest tilt of the one pose's z axis from vertical, degrees.
pub const ONE_POSE_TILT_DEG: f64 = 1.0;
/// Largest angle between a Ferraris rotation's axis and the fixture axis it is about, degrees.
pub const ROTATION_AXIS_DEG: f64 = 2.0;
/// Largest angle between a rate table's axis and the fixture axis it turns, degrees.
pub const TABLE_AXIS_DEG: f64 = 0.5;

/// A protocol's motion and the faces it holds, in order.
pub(super) struct Plan {
    pub(super) path: Path,
    pub(super) faces: Vec<Face>,
}

/// The motion of `o.protocol`.
pub(super) fn plan(o: &ProtocolSimOptions, rng: &mut ChaCha8Rng) -> Plan {
    match o.protocol {
        SimProtocol::SixFaces => faces(o, rng, &Face::SIX, FIXTURE_TILT_DEG),
        SimProtocol::FaceMissing => {
            let list = Face::SIX.map(|f| {
                if f == o.missing_face {
                    o.repeated_face
                } else {
                    f
                }
            });
            faces(o, rng, &list, FIXTURE_TILT_DEG)
        }
        SimProtocol::OnePose => {
            let up = Face { axis: 2, up: true };
            let mut path = Path::new(face_pose(rng, up, ONE_POSE_TILT_DEG));
            path.rest(&up.name(), o.one_pose_s.max(0.0));
            Plan {
                path,
                faces: vec![up],
            }
        }
        SimProtocol::Ferraris => {
            let mut p = faces(o, rng, &Face::SIX, HAND_TILT_DEG);
            ferraris_rotations(&mut p.path, o, rng);
            p
        }
        SimProtocol::RateTable => rate_table(o, rng),
        SimProtocol::Turntable => turntable(o, rng),
    }
}

/// `nominal` drawn within `±spread` (a fraction) of itself, never negative.
fn jitter(rng: &mut ChaCha8Rng, nominal: f64, spread: f64) -> f64 {
    (nominal * uniform(rng, (1.0 - spread, 1.0 + spread))).max(0.0)
}

/// The rotation (fixture → world) that puts fixture direction `up` up, at a random heading.
fn up_pose(rng: &mut ChaCha8Rng, up: Vector3<f64>) -> Rotation3<f64> {
    let level = Rotation3::rotation_between(&up, &Vector3::z())
        .unwrap_or_else(|| Rotation3::from_axis_angle(&Vector3::x_axis(), PI));
    let heading = Rotation3::from_axis_angle(&Vector3::z_axis(), rng.random_range(0.0..TAU));
    heading * level
}

/// Resting on `face` at a random heading, tilted from level by up to `max_tilt_deg` about a
/// random horizontal axis.
fn face_pose(rng: &mut ChaCha8Rng, face: Face, max_tilt_deg: f64) -> Rotation3<f64> {
    let pose = up_pose(rng, Vector3::from(face.direction()));
    let phi = rng.random_range(0.0..TAU);
    let horizontal = Unit::new_normalize(Vector3::new(phi.cos(), phi.sin(), 0.0));
    let angle = uniform(rng, (0.0, max_tilt_deg)).to_radians();
    Rotation3::from_axis_angle(&horizontal, angle) * pose
}

/// A lift of 3–8 cm for a tumble, m.
fn lift(rng: &mut ChaCha8Rng) -> f64 {
    rng.random_range(0.03..0.08)
}

/// The faces in `list`, each held `face_s`, with a tumble between two.
fn faces(o: &ProtocolSimOptions, rng: &mut ChaCha8Rng, list: &[Face], max_tilt: f64) -> Plan {
    let mut path = Path::new(Rotation3::identity());
    for (k, f) in list.iter().enumerate() {
        let pose = face_pose(rng, *f, max_tilt);
        if k == 0 {
            path.jump_to(pose);
        } else {
            let dur = jitter(rng, o.tumble_s, 0.2);
            let h = lift(rng);
            path.tumble_to(pose, &f.name(), dur, h);
        }
        let dur = jitter(rng, o.face_s, 0.1);
        path.rest(&f.name(), dur);
    }
    Plan {
        path,
        faces: list.to_vec(),
    }
}

/// For x, y, z: a re-grip to z up, a rest, a rotation of `rotation_deg` (± the jitter) about
/// an axis within [`ROTATION_AXIS_DEG`] of the fixture axis (lopsided rate), a rest.
fn ferraris_rotations(path: &mut Path, o: &ProtocolSimOptions, rng: &mut ChaCha8Rng) {
    for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
        let start = face_pose(rng, Face { axis: 2, up: true }, HAND_TILT_DEG);
        let (dur, h) = (jitter(rng, o.tumble_s, 0.2), lift(rng));
        path.tumble_to(start, name, dur, h);
        let dur = jitter(rng, o.rest_s, 0.1);
        path.rest(name, dur);
        let u = tilt(
            rng,
            Face { axis, up: true }.direction(),
            ROTATION_AXIS_DEG.to_radians(),
        );
        let j = o.rotation_jitter_deg.abs();
        let angle = (o.rotation_deg + uniform(rng, (-j, j))).to_radians();
        let warp = rng.random_range(-0.5..0.5);
        let dur = uniform(rng, o.rotation_s).max(0.0);
        let turn = Profile::Turn { angle, warp };
        let u = Unit::new_normalize(Vector3::from(u));
        path.push(SegmentKind::Rotation, name, dur, u, turn);
        let dur = jitter(rng, o.rest_s, 0.1);
        path.rest(name, dur);
    }
}

/// Spin-up to `rate` (rad/s) about `u`, hold it `hold_s`, spin down; `ramp_s` each ramp.
fn spin(path: &mut Path, label: &str, u: Unit<Vector3<f64>>, rate: f64, hold_s: f64, ramp_s: f64) {
    let ramp = |from, to| Profile::Rate { from, to };
    path.push(SegmentKind::Ramp, label, ramp_s, u, ramp(0.0, rate));
    path.push(SegmentKind::Steady, label, hold_s, u, ramp(rate, rate));
    path.push(SegmentKind::Ramp, label, ramp_s, u, ramp(rate, 0.0));
}

/// A rest with z up; then for x, y, z and each sign, a spin at `table_rate_dps` about the
/// table's axis for that fixture axis, and a rest.
fn rate_table(o: &ProtocolSimOptions, rng: &mut ChaCha8Rng) -> Plan {
    let up = Face { axis: 2, up: true };
    let mut path = Path::new(face_pose(rng, up, FIXTURE_TILT_DEG));
    path.rest("", o.rest_s.max(0.0));
    for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
        let u = tilt(
            rng,
            Face { axis, up: true }.direction(),
            TABLE_AXIS_DEG.to_radians(),
        );
        let u = Unit::new_normalize(Vector3::from(u));
        for sign in [1.0, -1.0] {
            let rate = sign * o.table_rate_dps.to_radians();
            spin(
                &mut path,
                name,
                u,
                rate,
                o.spin_s.max(0.0),
                o.ramp_s.max(0.0),
            );
            path.rest(name, o.rest_s.max(0.0));
        }
    }
    Plan {
        path,
        faces: Vec::new(),
    }
}

/// Random orientations on a platter turning clockwise seen from above (about world −z): at
/// each, the speeds in turn with a ramp between two different ones, then back to 0. The
/// re-orientation between two is not recorded (the recording paused).
fn turntable(o: &ProtocolSimOptions, rng: &mut ChaCha8Rng) -> Plan {
    let mut path = Path::new(Rotation3::identity());
    let (hold, ramp) = (o.turntable_hold_s.max(0.0), o.ramp_s.max(0.0));
    for k in 0..o.turntable_orientations {
        let up = Vector3::from(random_unit(rng));
        let pose = up_pose(rng, up);
        path.jump_to(pose);
        // The platter's rotation vector (world −z) in the fixture frame.
        let down = Unit::new_normalize(pose.inverse() * -Vector3::z());
        let label = format!("o{}", k + 1);
        let mut prev = 0.0;
        for w in o.turntable_rates_dps.iter().map(|r| r.to_radians()) {
            if w != prev {
                let p = Profile::Rate { from: prev, to: w };
                path.push(SegmentKind::Ramp, &label, ramp, down, p);
            }
            if w == 0.0 {
                path.rest(&label, hold);
            } else {
                let p = Profile::Rate { from: w, to: w };
                path.push(SegmentKind::Steady, &label, hold, down, p);
            }
            prev = w;
        }
        if prev != 0.0 {
            let p = Profile::Rate {
                from: prev,
                to: 0.0,
            };
            path.push(SegmentKind::Ramp, &label, ramp, down, p);
        }
    }
    Plan {
        path,
        faces: Vec::new(),
    }
}

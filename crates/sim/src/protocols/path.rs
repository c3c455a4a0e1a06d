//! The fixture's motion: a chain of segments, each a rotation about one axis fixed in the
//! fixture (rest, smooth turn, rate ramp, constant rate), so that orientation, body rate and
//! specific force are known in closed form at every instant and the gyro's rate integrates
//! exactly to the orientation change the accelerometer sees.
//!
//! Frames: the world is z up; `R` maps fixture (body) coordinates to world coordinates. A
//! segment starting at `R₀` with unit axis `u` (fixture frame) and angle `θ(τ)` has
//! `R(τ) = R₀·exp(θ(τ)·[u]×)`, body rate `ω = θ̇(τ)·u` (rad/s) and specific force
//! `a = R(τ)ᵀ·(ẑ + p̈(τ)/g₀)` in g, where `p̈` is the vertical acceleration of a tumble's
//! lift (the fixture raised by `h` and set down: `p(τ) = h·sin⁴(πτ/T)`, no jump in the
//! acceleration at either end). A rotation about a
//! world-fixed axis (a turntable's platter) is one about a fixture-fixed axis, since the
//! axis is the same vector in both frames throughout.

use nalgebra::{Rotation3, Unit, UnitQuaternion, Vector3};
use serde::Serialize;
use std::f64::consts::{PI, TAU};

/// Standard gravity, m/s² (a lift's acceleration in g).
const G0: f64 = 9.80665;

/// What a segment is, for the truth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SegmentKind {
    /// Still: a face held, a pose, a pause at zero rate.
    Rest,
    /// A hand motion between two still poses (lift, turn, set down), or a re-grip.
    Tumble,
    /// A rotation of a known angle between rests (Ferraris).
    Rotation,
    /// A rate changing smoothly from one value to another (spin-up, spin-down).
    Ramp,
    /// A constant non-zero rate (rate table, turntable).
    Steady,
}

/// How the angle about the segment's axis evolves over its duration `T`.
#[derive(Debug, Clone, Copy)]
pub(super) enum Profile {
    /// `θ ≡ 0`.
    Still,
    /// A turn by `angle` (rad): `θ(f) = angle·c(h(f))` with the cycloid
    /// `c(x) = x − sin(2πx)/(2π)` (zero rate and acceleration at both ends) and the warp
    /// `h(f) = f + warp·sin²(πf)/π` (`|warp| < 1`, so `h′ = 1 + warp·sin(2πf) > 0`;
    /// non-zero makes the rate lopsided: its peak comes early for `warp > 0`, late for `< 0`).
    Turn { angle: f64, warp: f64 },
    /// The rate going from `from` to `to` (rad/s) with a raised-cosine blend
    /// (`from == to`: constant).
    Rate { from: f64, to: f64 },
}

impl Profile {
    /// `(θ, θ̇)` at time `tau` into a segment of duration `dur`.
    fn at(self, tau: f64, dur: f64) -> (f64, f64) {
        match self {
            Profile::Still => (0.0, 0.0),
            Profile::Turn { angle, warp } => {
                let f = tau / dur;
                let h = f + warp * (PI * f).sin().powi(2) / PI;
                let dh = 1.0 + warp * (TAU * f).sin();
                let c = h - (TAU * h).sin() / TAU;
                let dc = 1.0 - (TAU * h).cos();
                (angle * c, angle * dc * dh / dur)
            }
            Profile::Rate { from, to } => {
                let x = PI * tau / dur;
                let blend = tau / 2.0 - dur * x.sin() / TAU;
                (
                    from * tau + (to - from) * blend,
                    from + (to - from) * 0.5 * (1.0 - x.cos()),
                )
            }
        }
    }
}

/// One stretch of the motion.
#[derive(Debug, Clone)]
pub(super) struct Seg {
    pub(super) kind: SegmentKind,
    /// Face (`x+`), axis (`x`) or orientation (`o3`) the segment belongs to; may be empty.
    pub(super) label: String,
    /// Start, s.
    pub(super) t0: f64,
    /// Duration, s.
    pub(super) dur: f64,
    /// Orientation at the start (fixture → world).
    pub(super) r0: Rotation3<f64>,
    /// Rotation axis, fixture frame.
    pub(super) axis: Unit<Vector3<f64>>,
    pub(super) profile: Profile,
    /// Height of a tumble's lift, m (0: none).
    pub(super) lift_m: f64,
}

/// The motion at one instant.
pub(super) struct State {
    /// Body rate, rad/s, fixture frame.
    pub(super) omega: Vector3<f64>,
    /// Specific force, g, fixture frame.
    pub(super) accel: Vector3<f64>,
}

impl Seg {
    /// End time, s.
    pub(super) fn t1(&self) -> f64 {
        self.t0 + self.dur
    }

    /// Total angle turned, rad, and the rates at the start and at the end, rad/s.
    pub(super) fn totals(&self) -> (f64, f64, f64) {
        let (angle, _) = self.profile.at(self.dur, self.dur);
        let (_, w0) = self.profile.at(0.0, self.dur);
        let (_, w1) = self.profile.at(self.dur, self.dur);
        (angle, w0, w1)
    }

    /// Orientation at the end.
    pub(super) fn r1(&self) -> Rotation3<f64> {
        self.r0 * Rotation3::from_axis_angle(&self.axis, self.totals().0)
    }

    /// The motion at absolute time `t` (clamped to the segment).
    pub(super) fn state(&self, t: f64) -> State {
        let tau = (t - self.t0).clamp(0.0, self.dur);
        let (theta, rate) = self.profile.at(tau, self.dur);
        let r = self.r0 * Rotation3::from_axis_angle(&self.axis, theta);
        // p = h·sin⁴(πτ/T): p̈ = 4h(π/T)²·sin²·(3cos² − sin²), zero at both ends.
        let (s, c) = (PI * tau / self.dur).sin_cos();
        let k = PI / self.dur;
        let lift = 4.0 * self.lift_m * k * k * s * s * (3.0 * c * c - s * s);
        State {
            omega: self.axis.into_inner() * rate,
            accel: r.inverse() * Vector3::new(0.0, 0.0, 1.0 + lift / G0),
        }
    }
}

/// A motion under construction: the segments so far, and where they leave the fixture.
pub(super) struct Path {
    pub(super) segs: Vec<Seg>,
    /// Orientation now.
    pub(super) r: Rotation3<f64>,
    /// Time now, s.
    pub(super) t: f64,
}

impl Path {
    /// A motion starting at orientation `r` at time 0.
    pub(super) fn new(r: Rotation3<f64>) -> Self {
        Self {
            segs: Vec::new(),
            r,
            t: 0.0,
        }
    }

    /// Appends a segment from the current orientation and time.
    pub(super) fn push(
        &mut self,
        kind: SegmentKind,
        label: &str,
        dur: f64,
        axis: Unit<Vector3<f64>>,
        profile: Profile,
    ) {
        let seg = Seg {
            kind,
            label: label.into(),
            t0: self.t,
            dur,
            r0: self.r,
            axis,
            profile,
            lift_m: 0.0,
        };
        self.r = seg.r1();
        self.t = seg.t1();
        self.segs.push(seg);
    }

    /// A still segment.
    pub(super) fn rest(&mut self, label: &str, dur: f64) {
        self.push(
            SegmentKind::Rest,
            label,
            dur,
            Vector3::z_axis(),
            Profile::Still,
        );
    }

    /// A tumble to orientation `target`: the one rotation that takes the fixture there
    /// (axis and angle of `R_nowᵀ·R_target`), with a lift of `lift_m`.
    pub(super) fn tumble_to(&mut self, target: Rotation3<f64>, label: &str, dur: f64, lift_m: f64) {
        let delta = UnitQuaternion::from_rotation_matrix(&(self.r.inverse() * target));
        let (axis, angle) = delta.axis_angle().unwrap_or((Vector3::z_axis(), 0.0));
        let turn = Profile::Turn { angle, warp: 0.0 };
        self.push(SegmentKind::Tumble, label, dur, axis, turn);
        if let Some(s) = self.segs.last_mut() {
            s.lift_m = lift_m;
        }
        // Land exactly on the target (the axis–angle round trip is exact to rounding only).
        self.r = target;
    }

    /// Jumps to orientation `r` without recording the move (the recording paused).
    pub(super) fn jump_to(&mut self, r: Rotation3<f64>) {
        self.r = r;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rate each profile gives is the derivative of its angle (central differences).
    #[test]
    fn rates_are_the_angles_derivatives() {
        let dur = 3.0;
        for p in [
            Profile::Turn {
                angle: 2.0 * PI,
                warp: 0.4,
            },
            Profile::Rate {
                from: 0.3,
                to: -1.2,
            },
        ] {
            for k in 1..30 {
                let tau = dur * k as f64 / 30.0;
                let h = 1e-6;
                let d = (p.at(tau + h, dur).0 - p.at(tau - h, dur).0) / (2.0 * h);
                assert!((d - p.at(tau, dur).1).abs() < 1e-6, "{p:?} at {tau}");
            }
        }
        let (end, w0, w1) = Seg {
            kind: SegmentKind::Rotation,
            label: String::new(),
            t0: 0.0,
            dur,
            r0: Rotation3::identity(),
            axis: Vector3::x_axis(),
            profile: Profile::Turn {
                angle: 2.0 * PI,
                warp: -0.3,
            },
            lift_m: 0.0,
        }
        .totals();
        assert!((end - 2.0 * PI).abs() < 1e-12 && w0.abs() < 1e-12 && w1.abs() < 1e-12);
    }

    /// A tumble lands on its target and its rate integrates to the turn.
    #[test]
    fn tumble_reaches_its_target() {
        let target = Rotation3::from_euler_angles(PI, 0.2, -1.0);
        let mut p = Path::new(Rotation3::from_euler_angles(0.1, 0.0, 0.5));
        p.tumble_to(target, "", 2.0, 0.05);
        let s = &p.segs[0];
        assert!((s.r1().matrix() - target.matrix()).abs().max() < 1e-9);
        let a = s.state(s.t1()).accel;
        assert!((a - target.inverse() * Vector3::z()).norm() < 1e-9);
    }
}

//! A play-session simulator for the background recalibration: minutes to hours of game-like
//! Nunchuk motion with a known, drifting truth (test support; std, f64, seeded).
//!
//! ## The truth (documented here, not taken from the code under test)
//! * sensor: `m = S(t)·D₀·a + b(θ) + v`, rounded and clamped to 10 bits as the Nunchuk's ADC
//!   does; `D₀ = K₀⁻¹` with `K₀` upper triangular (≈ 200 counts/g, cross terms of a few
//!   counts/g) — the frame convention of the multi-position fit, so that a fitted calibration
//!   and the truth can be compared vector by vector; `v` white Gaussian noise of
//!   [`NOISE_COUNTS`];
//! * drift: `b(θ) = b₀ + s·(θ − θ_ref)` with a per-axis slope `s` (counts/°C), and a slow
//!   per-axis scale change `S(t) = diag(1 + r·t/1 h)`;
//! * temperature: `θ(t) = θ_start + rise·(1 − e^(−t/τ)) + wobble·sin(2πt/15 min)` (a
//!   controller warming in the hand and the room);
//! * motion, 200 reports per second, a random sequence of segments: **rest** (put down in a
//!   uniformly random orientation for 2–25 s, reached by a 0.4 s turn), **swing** (0.4–1.5 s:
//!   the direction turns by up to 180° while up to 3 g of linear acceleration peaks),
//!   **shake** (1–5 s of 0.5–2 g at 4–8 Hz), **hold** (1–6 s in the hand: slow wander and a
//!   20 mg, 9 Hz tremor — never still enough to count).

use nalgebra::{Matrix3, Unit, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, StandardNormal};
use wiical_core::{Calibration, Conditions, PreparedCalibration};

/// Reports per second.
pub const RATE_HZ: f64 = 200.0;
/// White noise per axis, counts.
pub const NOISE_COUNTS: f64 = 0.6;

/// The drifting sensor.
#[derive(Debug, Clone)]
pub struct Truth {
    /// `K₀`, g per count (upper triangular).
    pub k0: Matrix3<f64>,
    /// `b₀` at `θ_ref`, counts.
    pub b0: Vector3<f64>,
    /// `θ_ref`, °C.
    pub theta_ref: f64,
    /// Bias slope, counts/°C.
    pub slope: Vector3<f64>,
    /// Relative scale change per hour.
    pub scale_per_h: Vector3<f64>,
    /// Temperature: start, rise, time constant (s), wobble amplitude.
    pub temp: (f64, f64, f64, f64),
}

impl Truth {
    /// A Nunchuk-like sensor drawn from `rng`; `drift` false gives no slope, no scale change
    /// and a steady temperature.
    pub fn random(rng: &mut ChaCha8Rng, drift: bool) -> Self {
        let mut u = |lo: f64, hi: f64| rng.random_range(lo..hi);
        let sens = [u(190.0, 210.0), u(190.0, 210.0), u(190.0, 210.0)];
        let d0 = Matrix3::new(
            sens[0],
            u(-3.0, 3.0),
            u(-3.0, 3.0),
            0.0,
            sens[1],
            u(-3.0, 3.0),
            0.0,
            0.0,
            sens[2],
        );
        let k0 = d0
            .try_inverse()
            .expect("upper triangular with a positive diagonal");
        let b0 = Vector3::new(u(495.0, 530.0), u(495.0, 530.0), u(495.0, 530.0));
        let sign = |x: f64| if x < 0.5 { -1.0 } else { 1.0 };
        let (slope, scale, temp) = if drift {
            (
                Vector3::new(
                    sign(u(0.0, 1.0)) * u(0.25, 0.45),
                    sign(u(0.0, 1.0)) * u(0.25, 0.45),
                    sign(u(0.0, 1.0)) * u(0.25, 0.45),
                ),
                Vector3::new(
                    sign(u(0.0, 1.0)) * u(0.002, 0.004),
                    sign(u(0.0, 1.0)) * u(0.002, 0.004),
                    sign(u(0.0, 1.0)) * u(0.002, 0.004),
                ),
                (22.0, 12.0, 1200.0, 0.5),
            )
        } else {
            (Vector3::zeros(), Vector3::zeros(), (24.0, 0.0, 1200.0, 0.3))
        };
        Self {
            k0,
            b0,
            theta_ref: 22.0,
            slope,
            scale_per_h: scale,
            temp,
        }
    }

    /// Temperature at `t` s, °C.
    pub fn temperature(&self, t: f64) -> f64 {
        let (start, rise, tau, wobble) = self.temp;
        start
            + rise * (1.0 - (-t / tau).exp())
            + wobble * (2.0 * std::f64::consts::PI * t / 900.0).sin()
    }

    /// Forward matrix `S(t)·D₀`.
    pub fn forward(&self, t: f64) -> Matrix3<f64> {
        let s = Matrix3::from_diagonal(&(Vector3::repeat(1.0) + self.scale_per_h * (t / 3600.0)));
        s * self.k0.try_inverse().expect("invertible")
    }

    /// Noise-free raw reading of specific force `a` (g) at `t`.
    pub fn raw_exact(&self, a: &Vector3<f64>, t: f64) -> Vector3<f64> {
        self.forward(t) * a + self.b0 + self.slope * (self.temperature(t) - self.theta_ref)
    }

    /// The truth as a calibration at `t` (its bias at the temperature then, no slope).
    pub fn calibration_at(&self, t: f64) -> Calibration {
        let k = self.forward(t).try_inverse().expect("invertible");
        let b = self.b0 + self.slope * (self.temperature(t) - self.theta_ref);
        Calibration {
            bias: [b[0] as f32, b[1] as f32, b[2] as f32],
            matrix: std::array::from_fn(|i| std::array::from_fn(|j| k[(i, j)] as f32)),
            effects: Default::default(),
        }
    }
}

/// The fixed directions the error against the truth is averaged over: the 26 directions of
/// a cube's faces, edges and corners.
pub fn test_directions() -> Vec<Vector3<f64>> {
    let mut v = Vec::new();
    for x in -1..=1 {
        for y in -1..=1 {
            for z in -1..=1 {
                if (x, y, z) != (0, 0, 0) {
                    v.push(Vector3::new(x as f64, y as f64, z as f64).normalize());
                }
            }
        }
    }
    v
}

/// The correction the adapter applies (`PreparedCalibration`, the type its corrector holds),
/// with the temperature given as the condition, to a raw reading (not quantised).
pub fn correct(cal: &PreparedCalibration, m: &Vector3<f64>, temperature_c: f64) -> Vector3<f64> {
    let cond = Conditions {
        time_s: 0.0,
        temperature_c: Some(temperature_c as f32),
    };
    let a = cal.correct([m[0] as f32, m[1] as f32, m[2] as f32], &cond);
    Vector3::new(a[0] as f64, a[1] as f64, a[2] as f64)
}

/// RMS over [`test_directions`] of `‖ĉ(m(a)) − a‖` at `t`, g: the calibration's error
/// against the truth, noise-free.
pub fn truth_error(truth: &Truth, cal: &PreparedCalibration, t: f64) -> f64 {
    let dirs = test_directions();
    let theta = truth.temperature(t);
    let ss: f64 = dirs
        .iter()
        .map(|a| (correct(cal, &truth.raw_exact(a, t), theta) - a).norm_squared())
        .sum();
    (ss / dirs.len() as f64).sqrt()
}

/// Which segments a session draws (weights) — e.g. shaking only.
#[derive(Debug, Clone, Copy)]
pub struct Mix {
    /// Weights of rest, swing, shake, hold.
    pub weights: [f64; 4],
    /// Rests keep the session's first orientation (a Nunchuk left in one pose).
    pub one_orientation: bool,
}

impl Mix {
    /// Ordinary play.
    pub const PLAY: Mix = Mix {
        weights: [0.3, 0.3, 0.2, 0.2],
        one_orientation: false,
    };
}

#[derive(Debug, Clone, Copy)]
enum Kind {
    Rest,
    Swing,
    Shake,
    Hold,
}

#[derive(Debug, Clone, Copy)]
struct Segment {
    kind: Kind,
    start: f64,
    len: f64,
    from: Vector3<f64>,
    to: Vector3<f64>,
    amp: f64,
    freq: f64,
    axis: Vector3<f64>,
}

/// One report of the simulation.
#[derive(Debug, Clone, Copy)]
pub struct Sample {
    /// Time, s.
    pub t: f64,
    /// The Nunchuk's 10-bit counts.
    pub raw: [u16; 3],
    /// Temperature, °C.
    pub temperature_c: f64,
    /// True when the Nunchuk is resting (past its 0.4 s turn into the rest).
    pub resting: bool,
}

/// A seeded play session; iterate for its reports.
pub struct Session {
    rng: ChaCha8Rng,
    /// The truth.
    pub truth: Truth,
    mix: Mix,
    n: u64,
    end: u64,
    seg: Segment,
}

fn random_unit(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    loop {
        let v = Vector3::new(
            StandardNormal.sample(rng),
            StandardNormal.sample(rng),
            StandardNormal.sample(rng),
        );
        if v.norm() > 1e-6 {
            return v.normalize();
        }
    }
}

/// Turn from `a` to `b` by the fraction `f` (spherical interpolation).
fn slerp(a: &Vector3<f64>, b: &Vector3<f64>, f: f64) -> Vector3<f64> {
    match UnitQuaternion::rotation_between(a, b) {
        Some(q) => UnitQuaternion::identity().slerp(&q, f.clamp(0.0, 1.0)) * a,
        // Opposite directions: turn about any perpendicular axis.
        None => {
            let axis = Unit::new_normalize(a.cross(&Vector3::x()) + a.cross(&Vector3::y()));
            UnitQuaternion::from_axis_angle(&axis, std::f64::consts::PI * f) * a
        }
    }
}

impl Session {
    /// A session of `duration_s` seconds with seed `seed`; `drift` as [`Truth::random`].
    pub fn new(seed: u64, duration_s: f64, drift: bool, mix: Mix) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let truth = Truth::random(&mut rng, drift);
        let up = random_unit(&mut rng);
        let seg = Segment {
            kind: Kind::Rest,
            start: 0.0,
            len: 5.0,
            from: up,
            to: up,
            amp: 0.0,
            freq: 0.0,
            axis: up,
        };
        let mut s = Self {
            rng,
            truth,
            mix,
            n: 0,
            end: (duration_s * RATE_HZ) as u64,
            seg,
        };
        // The first segment comes from the mix too (a shaking-only session never rests).
        s.next_segment(0.0);
        s
    }

    fn next_segment(&mut self, t: f64) {
        let r = &mut self.rng;
        let total: f64 = self.mix.weights.iter().sum();
        let mut x = r.random_range(0.0..total);
        let mut kind = Kind::Hold;
        for (k, w) in [Kind::Rest, Kind::Swing, Kind::Shake, Kind::Hold]
            .into_iter()
            .zip(self.mix.weights)
        {
            if x < w {
                kind = k;
                break;
            }
            x -= w;
        }
        let from = self.seg.to;
        let (len, to, amp, freq) = match kind {
            Kind::Rest => {
                let to = if self.mix.one_orientation {
                    from
                } else {
                    random_unit(r)
                };
                (r.random_range(2.0..25.0), to, 0.0, 0.0)
            }
            Kind::Swing => {
                let to = slerp(&from, &random_unit(r), r.random_range(0.3..1.0));
                (r.random_range(0.4..1.5), to, r.random_range(1.0..3.0), 0.0)
            }
            Kind::Shake => (
                r.random_range(1.0..5.0),
                from,
                r.random_range(0.5..2.0),
                r.random_range(4.0..8.0),
            ),
            Kind::Hold => {
                let to = slerp(&from, &random_unit(r), 0.2);
                (r.random_range(1.0..6.0), to, 0.02, 9.0)
            }
        };
        let axis = random_unit(r);
        self.seg = Segment {
            kind,
            start: t,
            len,
            from,
            to,
            amp,
            freq,
            axis,
        };
    }

    /// Specific force at `t` within the current segment, and whether it is resting.
    fn force(&self, t: f64) -> (Vector3<f64>, bool) {
        let s = &self.seg;
        let tau = t - s.start;
        let pi = std::f64::consts::PI;
        match s.kind {
            Kind::Rest => {
                let f = (tau / 0.4).min(1.0);
                let dir = slerp(&s.from, &s.to, f);
                let bump = if f < 1.0 { 0.3 * (pi * f).sin() } else { 0.0 };
                (dir + s.axis * bump, f >= 1.0)
            }
            Kind::Swing => {
                let f = tau / s.len;
                let dir = slerp(&s.from, &s.to, f);
                (dir + s.axis * (s.amp * (pi * f).sin()), false)
            }
            Kind::Shake => (
                s.from + s.axis * (s.amp * (2.0 * pi * s.freq * tau).sin()),
                false,
            ),
            Kind::Hold => {
                let dir = slerp(&s.from, &s.to, tau / s.len);
                (
                    dir + s.axis * (s.amp * (2.0 * pi * s.freq * tau).sin()),
                    false,
                )
            }
        }
    }
}

impl Iterator for Session {
    type Item = Sample;

    fn next(&mut self) -> Option<Sample> {
        if self.n >= self.end {
            return None;
        }
        let t = self.n as f64 / RATE_HZ;
        self.n += 1;
        if t >= self.seg.start + self.seg.len {
            self.next_segment(t);
        }
        let (a, resting) = self.force(t);
        let noise = Normal::new(0.0, NOISE_COUNTS).expect("positive sd");
        let m = self.truth.raw_exact(&a, t);
        let raw = std::array::from_fn(|i| {
            (m[i] + noise.sample(&mut self.rng))
                .round()
                .clamp(0.0, 1023.0) as u16
        });
        Some(Sample {
            t,
            raw,
            temperature_c: self.truth.temperature(t),
            resting,
        })
    }
}

//! Gyro recordings with known truth, for `gyrofit`'s loop: an accelerometer and a gyro on one
//! rigid body that rests in a pose, turns about a fixed axis to the next pose, rests, and so on.
//!
//! Each turn is a rotation about one axis (body frame) by angle `θ(t)` with the smooth profile
//! `θ(t) = Θ·(t/T − sin(2πt/T)/(2π))` (zero rate and acceleration at both ends), so the
//! orientation is known in closed form at every sample: `R(t) = R₀·exp(θ(t)·[u]×)`, the body
//! rate `ω = θ̇·u` and the specific force in the body frame `a = R(t)ᵀ·ĝ` (1 g up, the
//! acceleration of the turn itself neglected: hand turns about the sensor's own centre).
//!
//! Sensor models (truth in [`GyroTruth`]): accelerometer `a_raw = a + noise` (g); gyro
//! `m = K⁻¹·ω_meas + b`, with `ω_meas = ω + G·a + d·t + k_T·(T − T₀) + noise` (rad/s; `G` the
//! g-sensitivity in rad/s per g, `d` a bias drift in rad/s per s, `k_T` per °C), `K` the true
//! raw → rad/s matrix.
//!
//! The motion effects act on `ω_meas` per axis of the calibrated frame, as the inverse of the
//! corrections `gyrofit` looks for (`gyro::motion`): scale asymmetry `a` (the sensor reads
//! `ω/(1 + a·sign ω)`), a cubic `c` (it reads the `x` with `x + c·x·(x/ω_ref)² = ω`), and a
//! time offset `τ` (the gyro reads at `t` the rate of `t − τ`, linear between samples).

use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use wiical_analysis::Recording;

/// What is simulated.
#[derive(Debug, Clone)]
pub struct GyroSimOptions {
    /// Seed of every random choice.
    pub seed: u64,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Poses (static windows).
    pub poses: usize,
    /// Seconds of rest per pose.
    pub rest_s: f64,
    /// Seconds per turn.
    pub turn_s: f64,
    /// Turn angle range, degrees (each turn's angle drawn uniformly in it).
    pub turn_deg: (f64, f64),
    /// Accelerometer noise per sample, g.
    pub accel_noise_g: f64,
    /// Gyro noise per sample, rad/s.
    pub gyro_noise: f64,
    /// The truth.
    pub truth: GyroTruth,
}

/// The true gyro.
#[derive(Debug, Clone)]
pub struct GyroTruth {
    /// Raw → rad/s.
    pub matrix: [[f64; 3]; 3],
    /// Bias, raw counts.
    pub bias: [f64; 3],
    /// g-sensitivity, rad/s per g (row = gyro axis, column = specific-force component).
    pub g_sensitivity: [[f64; 3]; 3],
    /// Bias quadratic in the gravity direction, rad/s per g² (row = gyro axis; columns the
    /// monomials `g_x², g_y², g_z², g_x·g_y, g_x·g_z, g_y·g_z` of the true specific force): a
    /// term of the window open basis that no named candidate models.
    pub g_quadratic: [[f64; 6]; 3],
    /// Bias drift, rad/s per second.
    pub drift: [f64; 3],
    /// Temperature sensitivity of the bias, rad/s per °C (with a temperature column that rises
    /// by `temp_ramp` °C and comes back, half a sine over the recording, so that it is not a
    /// linear function of time; no column when the ramp is 0).
    pub temp_coef: [f64; 3],
    /// Peak temperature change over the recording, °C.
    pub temp_ramp: f64,
    /// Scale asymmetry per axis (fraction; `gyro::motion`'s coefficient).
    pub asymmetry: [f64; 3],
    /// Cubic scale nonlinearity per axis (fraction at ±100 °/s).
    pub nonlinearity: [f64; 3],
    /// Gyro lag behind the accelerometer, s.
    pub time_offset: f64,
    /// Products of two rates read on a gyro axis (row = axis; columns the monomials
    /// `ω_x², ω_y², ω_z², ω_x·ω_y, ω_x·ω_z, ω_y·ω_z` over 100 °/s): the gyro reads
    /// `ω_a − Σ c·monomial/(100 °/s)`, which the motions' open basis term (`+ c·ω_i·ω_j /
    /// 100 °/s` on the calibrated rate) undoes to first order.
    pub rate_product: [[f64; 6]; 3],
}

impl Default for GyroTruth {
    /// An MPU-like gyro: 16.4 counts per °/s with a few % of scale error and misalignment,
    /// a bias of tens of counts, no further effects.
    fn default() -> Self {
        let s = 1f64.to_radians() / 16.4;
        Self {
            matrix: [
                [s * 1.02, s * 0.01, -s * 0.005],
                [-s * 0.008, s * 0.98, s * 0.012],
                [s * 0.006, -s * 0.01, s * 1.01],
            ],
            bias: [23.0, -41.0, 12.0],
            g_sensitivity: [[0.0; 3]; 3],
            g_quadratic: [[0.0; 6]; 3],
            drift: [0.0; 3],
            temp_coef: [0.0; 3],
            temp_ramp: 0.0,
            asymmetry: [0.0; 3],
            nonlinearity: [0.0; 3],
            time_offset: 0.0,
            rate_product: [[0.0; 6]; 3],
        }
    }
}

impl Default for GyroSimOptions {
    /// 24 poses, 3 s rest, 1.5 s turns of 60–150°, 100 Hz, MPU-like noise.
    fn default() -> Self {
        Self {
            seed: 1,
            rate_hz: 100.0,
            poses: 24,
            rest_s: 3.0,
            turn_s: 1.5,
            turn_deg: (60.0, 150.0),
            accel_noise_g: 0.004,
            gyro_noise: 0.05f64.to_radians(),
            truth: GyroTruth::default(),
        }
    }
}

/// A simulated pair: the accelerometer's recording (g, with time and, when the truth has a
/// ramp, temperature) and the gyro's (raw counts, same rows).
pub struct GyroSim {
    /// Accelerometer, g.
    pub accel: Recording,
    /// Gyro, raw counts (not rounded).
    pub gyro: Recording,
}

/// A random unit vector.
fn unit(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    loop {
        let v = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let n = v.norm();
        if n > 0.1 && n <= 1.0 {
            return v / n;
        }
    }
}

/// Angle and rate of the turn at fraction `f` of its duration `t_turn`: `(θ, θ̇)`.
fn profile(total: f64, f: f64, t_turn: f64) -> (f64, f64) {
    let tau = std::f64::consts::TAU;
    let theta = total * (f - (tau * f).sin() / tau);
    let rate = total * (1.0 - (tau * f).cos()) / t_turn;
    (theta, rate)
}

/// The body's orientation and rate at every sample: rests and turns in turn.
fn trajectory(o: &GyroSimOptions, rng: &mut ChaCha8Rng) -> Vec<(Rotation3<f64>, Vector3<f64>)> {
    let dt = 1.0 / o.rate_hz;
    let rest = (o.rest_s * o.rate_hz).round() as usize;
    let turn = (o.turn_s * o.rate_hz).round() as usize;
    let mut r = Rotation3::from_scaled_axis(unit(rng) * rng.random_range(0.0..3.0));
    let mut out = Vec::with_capacity(o.poses * (rest + turn));
    for pose in 0..o.poses {
        out.extend(std::iter::repeat_n((r, Vector3::zeros()), rest));
        if pose + 1 == o.poses {
            break;
        }
        let axis = Unit::new_normalize(unit(rng));
        let total = rng.random_range(o.turn_deg.0..o.turn_deg.1).to_radians();
        for i in 0..turn {
            let f = (i as f64 + 0.5) * dt / o.turn_s;
            let (theta, rate) = profile(total, f, o.turn_s);
            out.push((
                r * Rotation3::from_axis_angle(&axis, theta),
                axis.into_inner() * rate,
            ));
        }
        r *= Rotation3::from_axis_angle(&axis, total);
    }
    out
}

/// Simulates one recording pair.
pub fn simulate_gyro(o: &GyroSimOptions) -> GyroSim {
    let mut rng = ChaCha8Rng::seed_from_u64(o.seed);
    let traj = trajectory(o, &mut rng);
    let t = &o.truth;
    let k = Matrix3::from_fn(|r, c| t.matrix[r][c]);
    let k_inv = k.try_inverse().unwrap_or_else(Matrix3::identity);
    let g_sens = Matrix3::from_fn(|r, c| t.g_sensitivity[r][c]);
    let n = traj.len();
    let span = n.max(2) as f64 / o.rate_hz;
    let mut noise = |s: f64| -> f64 {
        let z: f64 = StandardNormal.sample(&mut rng);
        s * z
    };
    let (mut acc, mut gyr, mut times, mut temps) = (vec![], vec![], vec![], vec![]);
    let rates: Vec<Vector3<f64>> = traj.iter().map(|(_, w)| *w).collect();
    for (i, (rot, _)) in traj.iter().enumerate() {
        let time = i as f64 / o.rate_hz;
        let a = rot.inverse() * Vector3::z();
        let temp = t.temp_ramp * (std::f64::consts::PI * time / span).sin();
        let drift = Vector3::from(t.drift) * time + Vector3::from(t.temp_coef) * temp;
        let wn = Vector3::from_fn(|_, _| noise(o.gyro_noise));
        let w = motion_effects(t, &rates, i as f64 - t.time_offset * o.rate_hz);
        let w_meas = w + g_sens * a + quadratic(&t.g_quadratic, &a) + drift + wn;
        let m = k_inv * w_meas + Vector3::from(t.bias);
        let an = Vector3::from_fn(|_, _| noise(o.accel_noise_g));
        acc.push((a + an).into());
        gyr.push(m.into());
        times.push(time);
        temps.push(25.0 + temp);
    }
    let temp = (t.temp_ramp != 0.0).then_some(temps);
    let rec = |xyz: Vec<[f64; 3]>, names: [&str; 3]| Recording {
        t: Some(times.clone()),
        xyz,
        temp: temp.clone(),
        sample_rate_hz: Some(o.rate_hz),
        axis_columns: names.map(String::from),
        ..Default::default()
    };
    GyroSim {
        accel: rec(acc, ["ax", "ay", "az"]),
        gyro: rec(gyr, ["gx", "gy", "gz"]),
    }
}

/// The bias quadratic in the specific force `a` (g): `Σ q[axis][m]·monomial_m(a)`.
fn quadratic(q: &[[f64; 6]; 3], a: &Vector3<f64>) -> Vector3<f64> {
    let m = [
        a.x * a.x,
        a.y * a.y,
        a.z * a.z,
        a.x * a.y,
        a.x * a.z,
        a.y * a.z,
    ];
    Vector3::from_fn(|r, _| (0..6).map(|k| q[r][k] * m[k]).sum())
}

/// The true rate at fractional sample `x` (linear between samples, clamped), as the gyro
/// reads it through the asymmetry and the cubic of `t` (module docs).
fn motion_effects(t: &GyroTruth, rates: &[Vector3<f64>], x: f64) -> Vector3<f64> {
    let last = rates.len().saturating_sub(1);
    let x = x.clamp(0.0, last as f64);
    let i = (x.floor() as usize).min(last);
    let f = x - i as f64;
    let w = rates[i] * (1.0 - f) + rates[(i + 1).min(last)] * f;
    let r = wiical_analysis::gyro::motion::RATE_REF;
    let w = w - quadratic(&t.rate_product, &w) / r;
    Vector3::from_fn(|k, _| {
        let (a, c, target) = (t.asymmetry[k], t.nonlinearity[k], w[k]);
        // Newton on m + a·|m| + c·m³/r² = target (monotone for small a, c).
        let mut m = target / (1.0 + a * target.signum());
        for _ in 0..4 {
            let g = m + a * m.abs() + c * m.powi(3) / (r * r) - target;
            m -= g / (1.0 + a * m.signum() + 3.0 * c * m * m / (r * r));
        }
        m
    })
}

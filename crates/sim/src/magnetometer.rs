//! Magnetometer recordings with known truth: a sensor turned smoothly over the whole sphere
//! several times, seen through hard iron `c`, soft iron `W⁻¹` and white noise, plus one effect
//! the magnetometer loop ([`wiical_analysis::magnetometer`]) looks for.
//!
//! Trajectory: the field's direction in the sensor frame is `(sin θ cos φ, sin θ sin φ, cos θ)`
//! with `cos θ = cos(2π·5s)` and `φ = 2π·41s` (`s` the fraction of the recording): five passes
//! from pole to pole, so every tenth of the recording (one held-out block) holds half a pass.
//! Measurement: `m = W⁻¹·(R·(1 + h)·n̂) + c(t) + ε`, `ε ~ N(0, σ²)` per axis, where the effect
//! sets `c(t)` (drift, step, temperature, interference) or `h` (shape: `h = a·n̂ₓn̂ᵧn̂_z`, odd
//! and cubic, so neither the centre nor the quadratic soft iron absorbs it).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, Uniform};
use wiical_analysis::magnetometer::Follow;
use wiical_analysis::Recording;

/// The one effect a simulated recording carries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MagEffectTruth {
    /// None: a clean recording.
    None,
    /// The centre moves by this much per second, per axis.
    Drift([f64; 3]),
    /// The centre jumps by this much at this fraction of the recording.
    Step([f64; 3], f64),
    /// The centre moves by this much per °C (the temperature swings ±10 °C, 1.5 cycles).
    Temperature([f64; 3]),
    /// The centre moves by this much per unit of a `current` column switching between 0 and
    /// 10 at random times (ArduPilot COMPASS_MOT's model).
    Interference([f64; 3]),
    /// Radial shape distortion `h = a·n̂ₓn̂ᵧn̂_z`: the amplitude `a`.
    Shape(f64),
}

/// What to simulate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MagSimConfig {
    /// Samples.
    pub samples: usize,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Field strength, file units.
    pub radius: f64,
    /// Hard iron.
    pub center: [f64; 3],
    /// Noise per axis (standard deviation), file units.
    pub sigma: f64,
    /// The effect.
    pub effect: MagEffectTruth,
    /// Seed.
    pub seed: u64,
}

impl Default for MagSimConfig {
    /// 100 s at 50 Hz, R = 500 counts, σ = 2 counts, centre (120, −80, 45): a QMC5883L-like
    /// hand rotation.
    fn default() -> Self {
        Self {
            samples: 5000,
            rate_hz: 50.0,
            radius: 500.0,
            center: [120.0, -80.0, 45.0],
            sigma: 2.0,
            effect: MagEffectTruth::None,
            seed: 1,
        }
    }
}

/// A simulated recording.
#[derive(Debug, Clone, PartialEq)]
pub struct MagSim {
    /// Samples.
    pub xyz: Vec<[f64; 3]>,
    /// Times, s.
    pub t: Vec<f64>,
    /// Temperature, °C.
    pub temp: Vec<f64>,
    /// The interference column.
    pub current: Vec<f64>,
    /// The shape effect's RMS contribution to the radius, file units (0 without one).
    pub shape_rms: f64,
}

impl MagSim {
    /// The samples with their time and temperature columns as a recording (unit `raw`), and
    /// the current as a column the centre may follow (its first axis, as `--follow` reads one).
    pub fn recording(&self) -> (Recording, Follow<Recording>) {
        let rec = Recording {
            t: Some(self.t.clone()),
            xyz: self.xyz.clone(),
            temp: Some(self.temp.clone()),
            ..Default::default()
        };
        let current = Recording {
            xyz: self.current.iter().map(|&c| [c, 0.0, 0.0]).collect(),
            ..Default::default()
        };
        (rec, ("current".into(), current))
    }
}

/// Soft iron `W⁻¹`: symmetric, a few per cent from identity.
const SOFT: [[f64; 3]; 3] = [[1.05, 0.03, -0.02], [0.03, 0.96, 0.04], [-0.02, 0.04, 1.0]];

/// Simulates `cfg` (see the module docs).
pub fn simulate_mag(cfg: &MagSimConfig) -> MagSim {
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let noise = Normal::new(0.0, cfg.sigma.max(0.0)).expect("σ ≥ 0");
    let n = cfg.samples.max(1);
    let current = switching(&mut rng, n, cfg.rate_hz);
    let (mut xyz, mut t, mut temp) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    let mut shape2 = 0.0;
    let t_mid = 0.5 * (n - 1) as f64 / cfg.rate_hz;
    for (i, &current_i) in current.iter().enumerate().take(n) {
        let s = i as f64 / n as f64;
        let ti = i as f64 / cfg.rate_hz;
        let tc = 25.0 + 10.0 * (2.0 * std::f64::consts::PI * 1.5 * s).sin();
        let ct = (2.0 * std::f64::consts::PI * 5.0 * s).cos();
        let st = (1.0 - ct * ct).sqrt();
        let phi = 2.0 * std::f64::consts::PI * 41.0 * s;
        let u = [st * phi.cos(), st * phi.sin(), ct];
        let (shift, h) = match cfg.effect {
            MagEffectTruth::None => ([0.0; 3], 0.0),
            MagEffectTruth::Drift(k) => (k.map(|v| v * (ti - t_mid)), 0.0),
            MagEffectTruth::Step(k, at) => (if s >= at { k } else { [0.0; 3] }, 0.0),
            MagEffectTruth::Temperature(k) => (k.map(|v| v * (tc - 25.0)), 0.0),
            MagEffectTruth::Interference(k) => (k.map(|v| v * current_i), 0.0),
            MagEffectTruth::Shape(a) => ([0.0; 3], a * u[0] * u[1] * u[2]),
        };
        shape2 += (cfg.radius * h).powi(2);
        let b = u.map(|x| cfg.radius * (1.0 + h) * x);
        xyz.push(std::array::from_fn(|a| {
            (0..3).map(|k| SOFT[a][k] * b[k]).sum::<f64>()
                + cfg.center[a]
                + shift[a]
                + noise.sample(&mut rng)
        }));
        t.push(ti);
        temp.push(tc);
    }
    MagSim {
        xyz,
        t,
        temp,
        current,
        shape_rms: (shape2 / n as f64).sqrt(),
    }
}

/// A current switching between 0 and 10 at random times (2–10 s apart).
fn switching(rng: &mut ChaCha8Rng, n: usize, rate_hz: f64) -> Vec<f64> {
    let gap = Uniform::new(2.0 * rate_hz, 10.0 * rate_hz).expect("a valid range");
    let mut out = Vec::with_capacity(n);
    let mut level = 0.0;
    while out.len() < n {
        let len = gap.sample(rng) as usize;
        out.extend(std::iter::repeat_n(level, len.max(1)));
        level = 10.0 - level;
    }
    out.truncate(n);
    out
}

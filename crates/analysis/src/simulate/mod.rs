//! The simulator: Wiimote- / Nunchuk-like multi-position recordings with known truth and,
//! optionally, one or several effects the linear model lacks, for testing `wiical analyze` blind.
//!
//! What a recording looks like:
//! * 10-bit counts (bias near 512; ~105 counts/g for the Wiimote's ADXL330, ~200 counts/g for
//!   the Nunchuk's LIS3L02AL read at 10 bits), small non-orthogonality, white noise of about a
//!   count, rounding to integers (the noise dithers the quantiser, so window means are not
//!   biased by it), at 100 Hz.
//! * An initial rest period (lying flat, +z up), then `poses` hand-placed static poses
//!   (4–8 s each: six near the ± axes, the rest uniformly spread) with 1.5–3 s of hand
//!   motion between them (a rotation with a smooth profile plus hand accelerations of a few
//!   tenths of g). The `brisk` [`Profile`]: holds of 2–4 s, moves of 1–2 s with two hand
//!   bumps (lifting, knocking down: 20–40 ms pulses of 0.3–1 g).
//! * [`Device::Mems16`]: a 16-bit MEMS (16 384 counts/g, bias near 0) written in m/s²; the
//!   truth is in the same unit.
//! * A `temp` column (°C, 0.01 °C resolution): room temperature plus a self-heating warm-up
//!   `ΔT·(1 − e^{−t/τ})`, the hand warming the case while it moves the sensor (first-order,
//!   τ = 30 s) and a slow air-conditioning wobble. Temperature therefore rises with time, so
//!   time and temperature are correlated (typically r ≈ 0.9 over the windows) but not
//!   identical.
//!
//! The sensor's frame follows the same convention as the fit (the forward matrix `D` is upper
//! triangular: x axis kept, y in the x–y plane), so the truth's parameters are directly
//! comparable with what `analyze` reports.
//!
//! The effects (`--effect a,b`: several at once, each drawn as if it were alone, in the order
//! given) and their `--magnitude` (always milli-g, one value for all or one per effect):
//! | effect | truth term (correction side, see `wiical_core::model`) | magnitude X means |
//! |---|---|---|
//! | `quadratic` | `k2` per axis | largest `|k2|` is X mg/g² (X mg at 1 g on that axis) |
//! | `cubic` | `k3` per axis | largest `|k3|` is X mg/g³ |
//! | `bias-drift` | bias drift per axis (raw/s) | the bias moves by X mg (vector norm) over the recording |
//! | `temperature` | bias temperature coefficient (raw/°C) | the bias moves by X mg over the recording's temperature range |
//! | `temperature-scale` | relative scale temperature coefficient (1/°C) per axis | the largest axis's scale moves by X mg/g over the recording's temperature range |
//! | `outliers` | 2–3 poses that were not still | each carries an extra specific force along gravity that shifts its mean ‖a‖ by ±X mg |
//!
//! The open basis (issue 19 item 3, [`open_basis`]): families beyond the seven candidates.
//! The cross terms are held by the core's `Effects`; the time and temperature families are
//! the simulator's own terms (correction side: a bias term is added to the bias the correction
//! subtracts, a scale term multiplies `u_i` by `1 + s_i·r`), listed with value and unit in the
//! truth's `open_basis`. Ranges are over the samples of the holds (what the windows see);
//! `θ_ref` is the mean of the holds' mean temperatures (the analysis' `θ̄`; for the thermal
//! lag, of the lagged temperature), `t_ref` the mean of the holds' mid-times.
//! | effect | truth term | magnitude X means |
//! |---|---|---|
//! | `cross-quadratic` | one `cross_quadratic[i][j]` (1/g): output axis `i` (drawn, or `--axis`), one of its five monomials `u_j·u_k` (drawn) | the term reaches ±X mg at its largest over the sphere of directions (coefficient X/peak, peak ½ for `u_x·u_y`, 1 for `u_x²`) |
//! | `cross-cubic` | one `cross_cubic[i][j]` (1/g²), one of nine monomials | the same, peak `1/√27` for `u_x·u_y·u_z` |
//! | `scale-drift` | scale `1 + s_i·t` (1/s) | the largest axis's scale moves by X mg/g over the recording |
//! | `scale-drift-curved` | scale `1 + s_i·(t − t_ref)²` (1/s²) | the same over the range of `(t − t_ref)²` |
//! | `temperature-squared` | bias `c·(θ − θ_ref)²` (file unit/°C²) | the bias moves by X mg (vector norm) over the range of `(θ − θ_ref)²` |
//! | `temperature-cubed` | bias `c·(θ − θ_ref)³` (file unit/°C³) | the same over the range of `(θ − θ_ref)³` |
//! | `temperature-scale-squared`, `-cubed` | scale `1 + s_i·(θ − θ_ref)^2 or 3` | the largest axis's scale moves by X mg/g over that range |
//! | `thermal-lag` | bias `c·(θ_lag − θ_ref)`, `θ_lag` the true temperature through a first-order lag of τ = [`open_basis::THERMAL_LAG_TAU_S`] (300 s) | the bias moves by X mg over the range of `θ_lag` |
//! | `temperature-rate` | bias `c·dθ/dt` (file unit per °C/s, true temperature) | the bias moves by X mg over the range of `dθ/dt` |
//!
//! The temperature families need the `temp` column (it is always written for them). The
//! temperature spans what the warm-up model gives: 3–8 °C of self-heating, 2–5 °C of hand
//! warming and a 0.3–1 °C wobble, so a few °C over the holds even in a brisk recording.
//!
//! The truth is written next to the recording as `FILE.truth.json` ([`Truth`]).

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
pub mod kalman;
pub mod open_basis;

pub use crate::error::simulate::SimulateError;
use crate::error::{Error, Result};
use crate::input::recording::Recording;
use crate::output::write::write_file;
use crate::report::effect_names as names;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Serialize;
use std::path::{Path, PathBuf};
use wiical_core::{Calibration, Conditions, Effects};

/// The effect put into a simulated recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimEffect {
    /// Linear model only.
    None,
    /// Per-axis even nonlinearity.
    Quadratic,
    /// Per-axis odd nonlinearity.
    Cubic,
    /// Bias linear in time.
    BiasDrift,
    /// Bias linear in temperature.
    Temperature,
    /// Scale linear in temperature.
    TemperatureScale,
    /// A few poses that were not still.
    Outliers,
    /// One orientation-dependent degree-2 cross term `a_i += c·u_j·u_k` (open basis).
    CrossQuadratic,
    /// One orientation-dependent degree-3 cross term `a_i += c·u_j·u_k·u_l` (open basis).
    CrossCubic,
    /// Scale linear in time (open basis).
    ScaleDrift,
    /// Scale quadratic in time (open basis).
    ScaleDriftCurved,
    /// Bias quadratic in temperature (open basis).
    TemperatureSquared,
    /// Bias cubic in temperature (open basis).
    TemperatureCubed,
    /// Scale quadratic in temperature (open basis).
    TemperatureScaleSquared,
    /// Scale cubic in temperature (open basis).
    TemperatureScaleCubed,
    /// Bias linear in the temperature seen through a first-order lag (open basis).
    ThermalLag,
    /// Bias linear in the temperature rate dθ/dt (open basis).
    TemperatureRate,
}

impl SimEffect {
    /// The effects of the seven candidates' kinds, `None` first (see [`Self::OPEN_BASIS`]
    /// for the others and [`Self::every`] for both).
    pub const ALL: [SimEffect; 7] = [
        SimEffect::None,
        SimEffect::Quadratic,
        SimEffect::Cubic,
        SimEffect::BiasDrift,
        SimEffect::Temperature,
        SimEffect::TemperatureScale,
        SimEffect::Outliers,
    ];

    /// The open-basis families (issue 19 item 3), see [`open_basis`].
    pub const OPEN_BASIS: [SimEffect; 10] = [
        SimEffect::CrossQuadratic,
        SimEffect::CrossCubic,
        SimEffect::ScaleDrift,
        SimEffect::ScaleDriftCurved,
        SimEffect::TemperatureSquared,
        SimEffect::TemperatureCubed,
        SimEffect::TemperatureScaleSquared,
        SimEffect::TemperatureScaleCubed,
        SimEffect::ThermalLag,
        SimEffect::TemperatureRate,
    ];

    /// Every effect the simulator can put in: [`Self::ALL`], then [`Self::OPEN_BASIS`].
    pub fn every() -> impl Iterator<Item = SimEffect> {
        Self::ALL.into_iter().chain(Self::OPEN_BASIS)
    }

    /// The name used on the command line and by `analyze`.
    pub fn name(self) -> &'static str {
        match self {
            SimEffect::None => names::NONE,
            SimEffect::Quadratic => names::QUADRATIC,
            SimEffect::Cubic => names::CUBIC,
            SimEffect::BiasDrift => names::BIAS_DRIFT,
            SimEffect::Temperature => names::TEMPERATURE,
            SimEffect::TemperatureScale => names::TEMPERATURE_SCALE,
            SimEffect::Outliers => names::OUTLIERS,
            SimEffect::CrossQuadratic => names::CROSS_QUADRATIC,
            SimEffect::CrossCubic => names::CROSS_CUBIC,
            SimEffect::ScaleDrift => names::SCALE_DRIFT,
            SimEffect::ScaleDriftCurved => names::SCALE_DRIFT_CURVED,
            SimEffect::TemperatureSquared => names::TEMPERATURE_SQUARED,
            SimEffect::TemperatureCubed => names::TEMPERATURE_CUBED,
            SimEffect::TemperatureScaleSquared => names::TEMPERATURE_SCALE_SQUARED,
            SimEffect::TemperatureScaleCubed => names::TEMPERATURE_SCALE_CUBED,
            SimEffect::ThermalLag => names::THERMAL_LAG,
            SimEffect::TemperatureRate => names::TEMPERATURE_RATE,
        }
    }

    /// Parses a name (see [`SimEffect::name`]).
    pub fn parse(s: &str) -> Option<Self> {
        Self::every().find(|e| e.name() == s)
    }

    /// Default magnitude (mg): clearly detectable in a default recording.
    pub fn default_magnitude_mg(self) -> f64 {
        match self {
            SimEffect::None => 0.0,
            SimEffect::Quadratic => 20.0,
            SimEffect::Cubic => 30.0,
            SimEffect::BiasDrift => 10.0,
            SimEffect::Temperature => 10.0,
            SimEffect::TemperatureScale => 10.0,
            SimEffect::Outliers => 10.0,
            SimEffect::CrossQuadratic => 20.0,
            SimEffect::CrossCubic => 30.0,
            SimEffect::ScaleDrift
            | SimEffect::ScaleDriftCurved
            | SimEffect::TemperatureSquared
            | SimEffect::TemperatureCubed
            | SimEffect::TemperatureScaleSquared
            | SimEffect::TemperatureScaleCubed
            | SimEffect::ThermalLag
            | SimEffect::TemperatureRate => 10.0,
        }
    }

    /// True when the effect needs the temperature column (it is then always written).
    pub fn needs_temperature(self) -> bool {
        matches!(
            self,
            SimEffect::Temperature
                | SimEffect::TemperatureScale
                | SimEffect::TemperatureSquared
                | SimEffect::TemperatureCubed
                | SimEffect::TemperatureScaleSquared
                | SimEffect::TemperatureScaleCubed
                | SimEffect::ThermalLag
                | SimEffect::TemperatureRate
        )
    }
}

/// One effect put into a simulation and its size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EffectSpec {
    /// Which effect.
    pub effect: SimEffect,
    /// Its size in milli-g (see the module docs); `None`: [`SimEffect::default_magnitude_mg`].
    pub magnitude_mg: Option<f64>,
    /// On one sensor axis only (0, 1, 2 = x, y, z), with the whole magnitude there and the
    /// other axes zero; `None`: on every axis as drawn. Not for `outliers` (no axis).
    pub axis: Option<usize>,
}

impl EffectSpec {
    /// `effect` at `magnitude_mg` (`None`: its default).
    pub fn new(effect: SimEffect, magnitude_mg: Option<f64>) -> Self {
        Self {
            effect,
            magnitude_mg,
            axis: None,
        }
    }

    /// `effect` at `magnitude_mg` on sensor axis `axis` alone (0, 1, 2 = x, y, z).
    pub fn on_axis(effect: SimEffect, magnitude_mg: Option<f64>, axis: usize) -> Self {
        Self {
            axis: Some(axis),
            ..Self::new(effect, magnitude_mg)
        }
    }

    /// The magnitude in use, mg.
    pub fn magnitude(&self) -> f64 {
        self.magnitude_mg
            .unwrap_or_else(|| self.effect.default_magnitude_mg())
    }
}

/// Which sensor to imitate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Device {
    /// Wii Remote (ADXL330, ~105 counts/g at 10 bits).
    Wiimote,
    /// Nunchuk (LIS3L02AL, ~200 counts/g at 10 bits).
    Nunchuk,
    /// A 16-bit MEMS accelerometer at ±2 g (16 384 counts/g, MPU-6050-like noise of ~1.2 mg
    /// per sample), logged in m/s² (each count × 9.80665/16384), typically at 400 Hz.
    Mems16,
}

impl Device {
    /// Parses `wiimote` / `nunchuk`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "wiimote" => Some(Device::Wiimote),
            "nunchuk" => Some(Device::Nunchuk),
            "mems16" => Some(Device::Mems16),
            _ => None,
        }
    }

    /// Name.
    pub fn name(self) -> &'static str {
        match self {
            Device::Wiimote => "wiimote",
            Device::Nunchuk => "nunchuk",
            Device::Mems16 => "mems16",
        }
    }

    /// Nominal sensitivity, counts per g.
    pub fn counts_per_g(self) -> f64 {
        match self {
            Device::Wiimote => 105.0,
            Device::Nunchuk => 200.0,
            Device::Mems16 => 16384.0,
        }
    }

    /// White-noise standard deviation per sample, counts.
    pub fn noise_counts(self) -> f64 {
        match self {
            Device::Wiimote => 1.0,
            Device::Nunchuk => 1.2,
            Device::Mems16 => 20.0,
        }
    }

    /// The ADC's output range, counts: 10-bit unsigned for the Wii devices, signed 16-bit.
    pub fn adc_range(self) -> (f64, f64) {
        match self {
            Device::Wiimote | Device::Nunchuk => (0.0, 1023.0),
            Device::Mems16 => (-32768.0, 32767.0),
        }
    }

    /// Zero-g output, counts (the bias is drawn around it).
    fn zero_g(self) -> f64 {
        match self {
            Device::Wiimote | Device::Nunchuk => 512.0,
            Device::Mems16 => 0.0,
        }
    }

    /// The name of the unit a count is written in: `counts`, or `m/s²` for the MEMS.
    pub fn unit_name(self) -> &'static str {
        match self {
            Device::Wiimote | Device::Nunchuk => "counts",
            Device::Mems16 => "m/s²",
        }
    }

    /// What one count is written as: 1 (counts) for the Wii devices, m/s² for the MEMS.
    pub fn unit_per_count(self) -> f64 {
        match self {
            Device::Wiimote | Device::Nunchuk => 1.0,
            Device::Mems16 => 9.80665 / 16384.0,
        }
    }

    /// The usual sample rate, Hz (the Wii Remote's reports come at 100–200 Hz).
    pub fn typical_rate_hz(self) -> f64 {
        match self {
            Device::Wiimote | Device::Nunchuk => 100.0,
            Device::Mems16 => 400.0,
        }
    }
}

/// How the poses are held and changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Profile {
    /// Holds of 4–8 s, moves of 1.5–3 s (a careful calibration session).
    #[default]
    Calm,
    /// Hand-placed holds of 2–4 s, moves of 1–2 s with two hand bumps each (lifting the
    /// sensor and knocking it down on the table): a quick session.
    Brisk,
}

impl Profile {
    /// Parses `calm` / `brisk`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "calm" => Some(Profile::Calm),
            "brisk" => Some(Profile::Brisk),
            _ => None,
        }
    }

    /// Hold and move durations, s (uniform in each range).
    fn durations(self) -> ((f64, f64), (f64, f64)) {
        match self {
            Profile::Calm => ((4.0, 8.0), (1.5, 3.0)),
            Profile::Brisk => ((2.0, 4.0), (1.0, 2.0)),
        }
    }
}

/// Simulation settings.
#[derive(Debug, Clone)]
pub struct SimConfig {
    /// The effects to put in (empty or `none` only: the linear model alone). Each appears at
    /// most once.
    pub effects: Vec<EffectSpec>,
    /// Seed of every random choice.
    pub seed: u64,
    /// Device.
    pub device: Device,
    /// Number of poses after the initial rest.
    pub poses: usize,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Initial rest, s.
    pub init_s: f64,
    /// Write a `temp` column (forced on for the `temperature` and `temperature-scale` effects).
    pub temp_column: bool,
    /// Per-sample noise std (counts); `None`: the device's.
    pub noise_counts: Option<f64>,
    /// Hold and move lengths.
    pub profile: Profile,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            effects: Vec::new(),
            seed: 1,
            device: Device::Wiimote,
            poses: 30,
            rate_hz: 100.0,
            init_s: 5.0,
            temp_column: true,
            noise_counts: None,
            profile: Profile::Calm,
        }
    }
}

/// One simulated pose (the true hold, not what a detector finds).
#[derive(Debug, Clone, Serialize)]
pub struct TruePose {
    /// Start of the hold, s.
    pub t_start: f64,
    /// End of the hold, s.
    pub t_end: f64,
    /// Unit specific-force direction in sensor axes (the "up" direction).
    pub direction: [f64; 3],
}

/// A pose that was not still (`outliers` effect).
#[derive(Debug, Clone, Serialize)]
pub struct TrueOutlier {
    /// Index into `poses`.
    pub pose: usize,
    /// Start of the hold, s.
    pub t_start: f64,
    /// End of the hold, s.
    pub t_end: f64,
    /// Shift of the hold's mean ‖a‖, milli-g.
    pub shift_mg: f64,
}

/// Everything the simulation knows (written to `FILE.truth.json`).
#[derive(Debug, Clone, Serialize)]
pub struct Truth {
    /// Device imitated.
    pub device: &'static str,
    /// Effects put in, comma-separated as on the command line (`none` without any).
    pub effect: String,
    /// The first effect's magnitude, milli-g (meaning per effect: see the module docs; 0 for
    /// `none`).
    pub magnitude_mg: f64,
    /// Every effect's magnitude, milli-g, in the order of `effect`.
    pub magnitudes_mg: Vec<f64>,
    /// The effects put on one axis only, as `effect: axis` (`quadratic: z`); absent when
    /// every effect is on every axis.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub single_axis: Vec<String>,
    /// Seed.
    pub seed: u64,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Number of samples.
    pub samples: usize,
    /// Per-sample white-noise std, counts (before rounding).
    pub noise_std_counts: f64,
    /// Forward matrix `D` (file units per g: counts, or m/s² for `mems16`; upper triangular, row-major).
    pub forward_matrix: [[f64; 3]; 3],
    /// The true calibration, correction side (what a perfect `analyze` would return):
    /// `Calibration::correct(m, {time_s: t, temperature_c: θ})` maps the noiseless reading
    /// back to the true specific force.
    pub calibration: Calibration,
    /// Poses in order; the first is the initial rest.
    pub poses: Vec<TruePose>,
    /// Poses that were not still (`outliers` only).
    pub outliers: Vec<TrueOutlier>,
    /// Temperature model: room temperature, warm-up amplitude and time constant.
    pub temperature_model: TempModel,
    /// The open-basis families put in (issue 19 item 3), each with its value and unit;
    /// absent when there are none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub open_basis: Vec<open_basis::OpenTerm>,
    /// The time and temperature terms, correction side, bias coefficients in the file's unit
    /// (what [`Truth::calibration_at`] folds in).
    #[serde(skip)]
    pub extra_terms: Vec<open_basis::ExtraTerm>,
}

impl Truth {
    /// The true calibration at one sample: [`Truth::calibration`] with the time and
    /// temperature terms the core cannot hold folded in (bias terms added to `bias`, scale
    /// terms multiplying the rows of `matrix`), so that
    /// `calibration_at(c).correct(m, {time_s, temperature_c})` maps the noiseless reading
    /// back to the true specific force.
    pub fn calibration_at(&self, c: &SampleConditions) -> Calibration {
        let mut cal = self.calibration;
        for t in &self.extra_terms {
            let r = t.regressor.value(c);
            for j in 0..3 {
                let v = t.coefficients[j] * r;
                match t.acts {
                    open_basis::Acts::Bias => cal.bias[j] += v as f32,
                    open_basis::Acts::Scale => {
                        for k in &mut cal.matrix[j] {
                            *k *= (1.0 + v) as f32;
                        }
                    }
                }
            }
        }
        cal
    }

    /// The core's [`Conditions`] of a sample (true temperature).
    pub fn conditions(c: &SampleConditions) -> Conditions {
        Conditions {
            time_s: c.time_s as f32,
            temperature_c: Some(c.temperature_c as f32),
        }
    }
}

/// The true conditions of one sample: what the time and temperature terms depend on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleConditions {
    /// Time since the first sample, s.
    pub time_s: f64,
    /// True temperature (before the thermometer's noise and rounding), °C.
    pub temperature_c: f64,
    /// The true temperature through the first-order lag of
    /// [`open_basis::THERMAL_LAG_TAU_S`], °C.
    pub lagged_c: f64,
    /// `dθ/dt` of the true temperature (central difference), °C/s.
    pub rate_c_per_s: f64,
}

/// Parameters of the simulated temperature.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TempModel {
    /// Room temperature, °C.
    pub room_c: f64,
    /// Self-heating warm-up amplitude, °C.
    pub warmup_c: f64,
    /// Warm-up time constant, s.
    pub warmup_tau_s: f64,
    /// Hand-warming steady-state rise while held, °C.
    pub hand_c: f64,
    /// Air-conditioning wobble amplitude, °C, and period, s.
    pub wobble_c: f64,
    /// Wobble period, s.
    pub wobble_period_s: f64,
}

/// A simulated recording and its truth.
#[derive(Debug, Clone)]
pub struct SimOutput {
    /// The recording, as `input::load` would return it.
    pub recording: Recording,
    /// The truth.
    pub truth: Truth,
    /// The true conditions of every sample (the truth's time and temperature terms depend on
    /// them, see [`Truth::calibration_at`]).
    pub conditions: Vec<SampleConditions>,
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

fn random_unit(rng: &mut ChaCha8Rng) -> [f64; 3] {
    loop {
        let v: [f64; 3] = [
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
        ];
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if n > 1e-6 {
            return [v[0] / n, v[1] / n, v[2] / n];
        }
    }
}

/// `d` tilted by a random angle up to `max_rad`.
fn tilt(rng: &mut ChaCha8Rng, d: [f64; 3], max_rad: f64) -> [f64; 3] {
    let r = random_unit(rng);
    let ang = rng.random_range(0.0..max_rad);
    unit([d[0] + ang * r[0], d[1] + ang * r[1], d[2] + ang * r[2]])
}

/// Spherical interpolation between unit vectors.
fn slerp(a: [f64; 3], b: [f64; 3], s: f64) -> [f64; 3] {
    let dot = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).clamp(-1.0, 1.0);
    let om = dot.acos();
    if om < 1e-6 {
        return a;
    }
    if (std::f64::consts::PI - om).abs() < 1e-3 {
        // Antipodal: go through any perpendicular direction.
        let p = if a[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let d = a[0] * p[0] + a[1] * p[1] + a[2] * p[2];
        let q = unit([p[0] - d * a[0], p[1] - d * a[1], p[2] - d * a[2]]);
        let th = s * std::f64::consts::PI;
        return unit([
            a[0] * th.cos() + q[0] * th.sin(),
            a[1] * th.cos() + q[1] * th.sin(),
            a[2] * th.cos() + q[2] * th.sin(),
        ]);
    }
    let (wa, wb) = (((1.0 - s) * om).sin() / om.sin(), (s * om).sin() / om.sin());
    unit([
        wa * a[0] + wb * b[0],
        wa * a[1] + wb * b[1],
        wa * a[2] + wb * b[2],
    ])
}

/// Solves `a = u + q·u² + c·u³` for `u` near `a` (Newton).
fn invert_nonlinearity(a: f64, q: f64, c: f64) -> f64 {
    let mut u = a;
    for _ in 0..30 {
        let f = u + q * u * u + c * u * u * u - a;
        let df = 1.0 + 2.0 * q * u + 3.0 * c * u * u;
        if df.abs() < 1e-9 {
            break;
        }
        let step = f / df;
        u -= step;
        if step.abs() < 1e-15 {
            break;
        }
    }
    u
}

/// Per-axis coefficients for a nonlinearity of size `x` (largest axis exactly `x`).
fn axis_coefficients(rng: &mut ChaCha8Rng, x: f64) -> [f64; 3] {
    let mut k = [0.0; 3];
    let big = rng.random_range(0..3usize);
    for (j, kj) in k.iter_mut().enumerate() {
        let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
        let size = if j == big {
            1.0
        } else {
            rng.random_range(0.4..1.0)
        };
        *kj = sign * size * x;
    }
    k
}

/// Checks the settings; returns the effects in use (without `none`) with their magnitudes (mg)
/// and the noise (counts).
fn check_config(cfg: &SimConfig) -> Result<(Vec<SimDraw>, f64)> {
    if !(cfg.rate_hz.is_finite() && cfg.rate_hz >= 20.0 && cfg.rate_hz <= 2000.0) {
        return Err(Error::InvalidSetting("rate must be between 20 and 2000 Hz"));
    }
    if cfg.poses < 9 || cfg.poses > 20_000 {
        return Err(Error::InvalidSetting(
            "poses must be between 9 and 20000 (the full model needs at least 9)",
        ));
    }
    let mut effects: Vec<SimDraw> = Vec::new();
    for spec in &cfg.effects {
        let magnitude = spec.magnitude();
        if !(magnitude.is_finite() && (0.0..=200.0).contains(&magnitude)) {
            return Err(Error::InvalidSetting(
                "magnitude must be between 0 and 200 mg",
            ));
        }
        if spec.effect == SimEffect::None {
            continue;
        }
        if effects.iter().any(|(e, _, _)| *e == spec.effect) {
            return Err(Error::InvalidSetting("effect: each effect may appear once"));
        }
        if spec
            .axis
            .is_some_and(|a| a > 2 || spec.effect == SimEffect::Outliers)
        {
            return Err(Error::InvalidSetting(
                "axis: x, y or z, and not for outliers (they have no axis)",
            ));
        }
        effects.push((spec.effect, magnitude, spec.axis));
    }
    if !(cfg.init_s.is_finite() && cfg.init_s >= 3.0) {
        return Err(Error::InvalidSetting(
            "the initial rest must be at least 3 s (the detector's noise reference)",
        ));
    }
    let noise = cfg
        .noise_counts
        .unwrap_or_else(|| cfg.device.noise_counts());
    // 20 counts for the 10-bit devices, 0.01 g for finer ones.
    let max_noise = 20.0f64.max(0.01 * cfg.device.counts_per_g());
    if !(noise.is_finite() && (0.0..=max_noise).contains(&noise)) {
        return Err(Error::InvalidSetting(
            "noise must be between 0 and 20 counts (0.01 g for a 16-bit device)",
        ));
    }
    Ok((effects, noise))
}

/// One stretch of the timeline.
struct Seg {
    t0: f64,
    t1: f64,
    kind: SegKind,
}

enum SegKind {
    /// Still at pose `k`.
    Hold(usize),
    /// Turning from one pose to the next with a hand wobble.
    Move {
        from: usize,
        to: usize,
        amp: [f64; 3],
        freq: f64,
        /// Hand bumps (brisk profile): centre time (s), width (s, Gaussian σ) and
        /// peak specific force (g, vector).
        bumps: [(f64, f64, [f64; 3]); 2],
    },
}

/// The rest direction (near +z) and `poses` directions: the six near-axis ones shuffled,
/// then uniform.
fn pose_directions(rng: &mut ChaCha8Rng, poses: usize) -> Vec<[f64; 3]> {
    let mut dirs = vec![tilt(rng, [0.0, 0.0, 1.0], 0.03)];
    let mut axes: Vec<[f64; 3]> = (0..6)
        .map(|k| {
            let mut v = [0.0; 3];
            v[k / 2] = if k % 2 == 0 { 1.0 } else { -1.0 };
            v
        })
        .collect();
    // Shuffle the six near-axis poses (Fisher–Yates).
    for i in (1..axes.len()).rev() {
        let j = rng.random_range(0..=i);
        axes.swap(i, j);
    }
    for k in 0..poses {
        let d = match axes.get(k) {
            Some(a) => tilt(rng, *a, 0.17),
            None => random_unit(rng),
        };
        dirs.push(d);
    }
    dirs
}

/// Rest, then motion + hold for each pose; returns the segments and the duration, s.
fn timeline(rng: &mut ChaCha8Rng, init_s: f64, n_dirs: usize, profile: Profile) -> (Vec<Seg>, f64) {
    let ((hold_lo, hold_hi), (move_lo, move_hi)) = profile.durations();
    let mut segs = vec![Seg {
        t0: 0.0,
        t1: init_s,
        kind: SegKind::Hold(0),
    }];
    let mut t = init_s;
    for k in 1..n_dirs {
        let mv = rng.random_range(move_lo..move_hi);
        let amp = random_unit(rng).map(|x| x * rng.random_range(0.15..0.4));
        let freq = rng.random_range(0.8..2.0);
        let bumps = if profile == Profile::Brisk {
            // Lifting (early in the move) and knocking the sensor down (late): 20–40 ms
            // pulses of 0.3–1 g.
            [(0.1, 0.25), (0.75, 0.9)].map(|(a, b)| {
                let at = t + mv * rng.random_range(a..b);
                let width = rng.random_range(0.02..0.04);
                let peak = rng.random_range(0.3..1.0);
                (at, width, random_unit(rng).map(|x| x * peak))
            })
        } else {
            [(0.0, 1.0, [0.0; 3]); 2]
        };
        segs.push(Seg {
            t0: t,
            t1: t + mv,
            kind: SegKind::Move {
                from: k - 1,
                to: k,
                amp,
                freq,
                bumps,
            },
        });
        t += mv;
        let hold = rng.random_range(hold_lo..hold_hi);
        segs.push(Seg {
            t0: t,
            t1: t + hold,
            kind: SegKind::Hold(k),
        });
        t += hold;
    }
    (segs, t)
}

/// The temperature model and the true temperature of every sample, °C.
fn temperatures(rng: &mut ChaCha8Rng, segs: &[Seg], n: usize, fs: f64) -> (TempModel, Vec<f64>) {
    let tm = TempModel {
        room_c: rng.random_range(20.0..26.0),
        warmup_c: rng.random_range(3.0..8.0),
        warmup_tau_s: rng.random_range(50.0..150.0),
        hand_c: rng.random_range(2.0..5.0),
        wobble_c: rng.random_range(0.3..1.0),
        wobble_period_s: rng.random_range(80.0..200.0),
    };
    let wobble_phase = rng.random_range(0.0..std::f64::consts::TAU);
    let mut temps = Vec::with_capacity(n);
    let mut hand = 0.0;
    let mut seg_i = 0;
    for i in 0..n {
        let ti = i as f64 / fs;
        while seg_i + 1 < segs.len() && ti >= segs[seg_i].t1 {
            seg_i += 1;
        }
        let held = matches!(segs[seg_i].kind, SegKind::Move { .. });
        let target = if held { tm.hand_c } else { 0.0 };
        hand += (target - hand) / (30.0 * fs);
        let th = tm.room_c
            + tm.warmup_c * (1.0 - (-ti / tm.warmup_tau_s).exp())
            + hand
            + tm.wobble_c
                * ((std::f64::consts::TAU * ti / tm.wobble_period_s) + wobble_phase).sin()
            - tm.wobble_c * wobble_phase.sin();
        temps.push(th);
    }
    (tm, temps)
}

/// Everything a sample depends on.
struct Scene {
    fs: f64,
    noise: f64,
    /// Forward matrix, counts per g.
    d: [[f64; 3]; 3],
    /// Bias, counts.
    bias: [f64; 3],
    dirs: Vec<[f64; 3]>,
    segs: Vec<Seg>,
    tm: TempModel,
    temps: Vec<f64>,
    /// Quadratic, cubic, drift (counts/s), bias temperature coefficient (counts/°C), scale
    /// temperature coefficient (1/°C).
    eff64: [[f64; 3]; 5],
    outliers: Vec<TrueOutlier>,
    /// Open-basis cross terms (1/g, 1/g²), as the core holds them.
    cross: open_basis::Cross,
    /// Open-basis time and temperature terms (bias coefficients in counts).
    extras: Vec<open_basis::ExtraTerm>,
    /// The true conditions of every sample.
    conds: Vec<SampleConditions>,
    /// ADC range, counts.
    adc: (f64, f64),
    /// Written value of one count ([`Device::unit_per_count`]).
    unit: f64,
}

/// One effect to draw: which, its size (mg), and the one axis it is on (`None`: every axis).
type SimDraw = (SimEffect, f64, Option<usize>);

/// The effect's draw moved onto axis `axis` alone: the whole magnitude `x` there, with the
/// sign it was drawn with, the other axes zero (the random draw is made as usual, so the rest
/// of the scene is the one the same seed gives without an axis).
fn onto_axis(v: [f64; 3], axis: Option<usize>, x: f64) -> [f64; 3] {
    match axis {
        None => v,
        Some(a) => std::array::from_fn(|j| if j == a { x.copysign(v[a]) } else { 0.0 }),
    }
}

/// The effect terms drawn for a scene.
struct Drawn {
    /// See [`Scene::eff64`].
    eff64: [[f64; 3]; 5],
    outliers: Vec<TrueOutlier>,
    cross: open_basis::Cross,
    extras: Vec<open_basis::ExtraTerm>,
}

/// The effect terms (and the outlier poses) for `effects` (each with its size in mg), drawn
/// in the order given, each as if it were alone (so a single effect draws exactly what it
/// always did; an open-basis family draws only when it is asked for).
fn effect_terms(
    rng: &mut ChaCha8Rng,
    effects: &[SimDraw],
    s: &[f64; 3],
    scene: &Scene,
    duration: f64,
    holds: &open_basis::HoldStats,
) -> Result<Drawn> {
    let (tmin, tmax) = scene
        .temps
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        });
    let t_range = (tmax - tmin).max(0.5);
    let mut eff64 = [[0.0f64; 3]; 5];
    let mut outliers = Vec::new();
    let mut cross = open_basis::Cross::default();
    let mut extras = Vec::new();
    for &(effect, magnitude, axis) in effects {
        let x = magnitude / 1000.0;
        match effect {
            SimEffect::None => {}
            SimEffect::Quadratic => eff64[0] = onto_axis(axis_coefficients(rng, x), axis, x),
            SimEffect::Cubic => eff64[1] = onto_axis(axis_coefficients(rng, x), axis, x),
            SimEffect::BiasDrift => {
                let v = onto_axis(random_unit(rng), axis, 1.0);
                eff64[2] = std::array::from_fn(|j| v[j] * x * s[j] / duration);
            }
            SimEffect::Temperature => {
                let v = onto_axis(random_unit(rng), axis, 1.0);
                eff64[3] = std::array::from_fn(|j| v[j] * x * s[j] / t_range);
            }
            SimEffect::TemperatureScale => {
                eff64[4] = onto_axis(axis_coefficients(rng, x), axis, x).map(|k| k / t_range);
            }
            SimEffect::Outliers => outliers = outlier_poses(rng, magnitude, scene)?,
            SimEffect::CrossQuadratic | SimEffect::CrossCubic => {
                open_basis::draw_cross(rng, effect, x, axis, &mut cross);
            }
            _ => extras.extend(open_basis::draw_extra(rng, effect, x, axis, s, holds)),
        }
    }
    Ok(Drawn {
        eff64,
        outliers,
        cross,
        extras,
    })
}

/// The true conditions of every sample: its time, the true temperature, that temperature
/// through the first-order lag of [`open_basis::THERMAL_LAG_TAU_S`] (starting in equilibrium
/// with it, exact discretisation of `dθ_lag/dt = (θ − θ_lag)/τ`) and its rate (central
/// difference, one-sided at the ends).
fn sample_conditions(temps: &[f64], fs: f64) -> Vec<SampleConditions> {
    let alpha = 1.0 - (-1.0 / (fs * open_basis::THERMAL_LAG_TAU_S)).exp();
    let mut lag = temps.first().copied().unwrap_or(0.0);
    let last = temps.len().saturating_sub(1);
    temps
        .iter()
        .enumerate()
        .map(|(i, &th)| {
            lag += alpha * (th - lag);
            let (a, b) = (i.saturating_sub(1), (i + 1).min(last));
            let rate = if b > a {
                (temps[b] - temps[a]) * fs / (b - a) as f64
            } else {
                0.0
            };
            SampleConditions {
                time_s: i as f64 / fs,
                temperature_c: th,
                lagged_c: lag,
                rate_c_per_s: rate,
            }
        })
        .collect()
}

/// The holds' samples, mean mid-time and mean temperature (each hold weighted equally, as
/// the analysis weighs its windows): what the open-basis magnitudes and references use.
fn hold_stats<'a>(
    segs: &[Seg],
    conds: &'a [SampleConditions],
    fs: f64,
) -> open_basis::HoldStats<'a> {
    let mut samples = Vec::new();
    let (mut mids, mut temps, mut lagged) = (Vec::new(), Vec::new(), Vec::new());
    for seg in segs.iter().filter(|s| matches!(s.kind, SegKind::Hold(_))) {
        let lo = ((seg.t0 * fs).ceil() as usize).min(conds.len());
        let hi = ((seg.t1 * fs).ceil() as usize).min(conds.len());
        let Some(hold) = conds.get(lo..hi).filter(|h| !h.is_empty()) else {
            continue;
        };
        samples.extend(hold);
        mids.push(0.5 * (seg.t0 + seg.t1));
        let n = hold.len() as f64;
        temps.push(hold.iter().map(|c| c.temperature_c).sum::<f64>() / n);
        lagged.push(hold.iter().map(|c| c.lagged_c).sum::<f64>() / n);
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / (v.len().max(1) as f64);
    open_basis::HoldStats {
        samples,
        t_ref: mean(&mids),
        theta_ref: mean(&temps),
        lagged_ref: mean(&lagged),
    }
}

/// 2–3 distinct poses (not the rest) whose mean ‖a‖ is pushed by ±`magnitude` mg.
fn outlier_poses(rng: &mut ChaCha8Rng, magnitude: f64, scene: &Scene) -> Result<Vec<TrueOutlier>> {
    let count = rng.random_range(2..=3usize);
    let mut chosen: Vec<usize> = Vec::new();
    while chosen.len() < count {
        let k = rng.random_range(1..scene.dirs.len());
        if !chosen.contains(&k) {
            chosen.push(k);
        }
    }
    chosen.sort_unstable();
    let mut outliers = Vec::new();
    for k in chosen {
        let seg = scene
            .segs
            .iter()
            .find(|s| matches!(s.kind, SegKind::Hold(p) if p == k))
            .ok_or(SimulateError::NoHoldSegment)?;
        let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
        outliers.push(TrueOutlier {
            pose: k,
            t_start: seg.t0,
            t_end: seg.t1,
            shift_mg: sign * magnitude,
        });
    }
    Ok(outliers)
}

impl Scene {
    /// Specific force in sensor axes at time `ti` in segment `seg`, g.
    fn specific_force(&self, seg: &Seg, ti: f64) -> [f64; 3] {
        match seg.kind {
            SegKind::Hold(k) => {
                let mut f = self.dirs[k];
                if let Some(o) = self.outliers.iter().find(|o| o.pose == k) {
                    // A 2 s half-sine push along gravity in the middle of the hold whose
                    // average over the hold is the outlier's shift.
                    let len = seg.t1 - seg.t0;
                    let tb = 2.0f64.min(len * 0.5);
                    let start = seg.t0 + 0.5 * (len - tb);
                    if ti >= start && ti < start + tb {
                        let amp = o.shift_mg / 1000.0 * std::f64::consts::PI * len / (2.0 * tb);
                        let bump = amp * (std::f64::consts::PI * (ti - start) / tb).sin();
                        for (fj, dj) in f.iter_mut().zip(self.dirs[k]) {
                            *fj += bump * dj;
                        }
                    }
                }
                f
            }
            SegKind::Move {
                from,
                to,
                amp,
                freq,
                bumps,
            } => {
                let tau = (ti - seg.t0) / (seg.t1 - seg.t0);
                let prof = 0.5 * (1.0 - (std::f64::consts::PI * tau).cos());
                let g = slerp(self.dirs[from], self.dirs[to], prof);
                let env = (std::f64::consts::PI * tau).sin();
                let w = (std::f64::consts::TAU * freq * (ti - seg.t0)).sin() * env;
                let bump = |j: usize| {
                    bumps
                        .iter()
                        .map(|(at, width, peak)| {
                            peak[j] * (-0.5 * ((ti - at) / width).powi(2)).exp()
                        })
                        .sum::<f64>()
                };
                std::array::from_fn(|j| g[j] + amp[j] * w + bump(j))
            }
        }
    }

    /// The noiseless reading (counts) of specific force `f` at the sample conditions `c`:
    /// the correction-side model inverted, `a = u + q u² + c u³ + cross(u)`,
    /// `u = (1 + σ·Δθ)·(1 + S)·D⁻¹(m − b_eff − B)` per axis, with `S` and `B` the open-basis
    /// scale and bias terms (without open-basis terms, exactly the computation it always was).
    fn reading(&self, f: &[f64; 3], c: &SampleConditions) -> [f64; 3] {
        let e = &self.eff64;
        let (ti, theta) = (c.time_s, c.temperature_c);
        let dth = theta - self.tm.room_c;
        let mut w: [f64; 3] = std::array::from_fn(|j| invert_nonlinearity(f[j], e[0][j], e[1][j]));
        if self.cross.any() {
            w = open_basis::invert_with_cross(f, &e[0], &e[1], &self.cross, w);
        }
        let mut v: [f64; 3] = std::array::from_fn(|j| w[j] / (1.0 + e[4][j] * dth));
        let mut extra_bias = [0.0; 3];
        for t in &self.extras {
            let r = t.regressor.value(c);
            for j in 0..3 {
                match t.acts {
                    open_basis::Acts::Bias => extra_bias[j] += t.coefficients[j] * r,
                    open_basis::Acts::Scale => v[j] /= 1.0 + t.coefficients[j] * r,
                }
            }
        }
        std::array::from_fn(|j| {
            let lin: f64 = (0..3).map(|k| self.d[j][k] * v[k]).sum();
            let b_eff = self.bias[j] + e[2][j] * ti + e[3][j] * dth;
            if self.extras.is_empty() {
                lin + b_eff
            } else {
                lin + (b_eff + extra_bias[j])
            }
        })
    }

    /// The recording: 10-bit counts with noise, times at 0.01 s and the measured temperature.
    fn record(&self, rng: &mut ChaCha8Rng, temp_column: bool) -> Recording {
        let normal = StandardNormal;
        let n = self.temps.len();
        let mut rec = Recording {
            axis_columns: ["x".into(), "y".into(), "z".into()],
            ..Default::default()
        };
        let mut tcol = Vec::with_capacity(n);
        let mut temp_col = Vec::with_capacity(n);
        let mut seg_i = 0;
        for (i, &theta) in self.temps.iter().enumerate() {
            let ti = i as f64 / self.fs;
            while seg_i + 1 < self.segs.len() && ti >= self.segs[seg_i].t1 {
                seg_i += 1;
            }
            let f = self.specific_force(&self.segs[seg_i], ti);
            let clean = self.reading(&f, &self.conds[i]);
            let mut m = [0.0; 3];
            for j in 0..3 {
                let v: f64 = normal.sample(rng);
                let (lo, hi) = self.adc;
                m[j] = (clean[j] + self.noise * v).round().clamp(lo, hi) * self.unit;
            }
            rec.xyz.push(m);
            // Printed to 10 µs (to_csv), so 200 and 400 Hz times stay distinct.
            tcol.push((ti * 1e5).round() / 1e5);
            let tn: f64 = normal.sample(rng);
            let meas = theta + 0.02 * tn;
            temp_col.push((meas * 100.0).round() / 100.0);
        }
        rec.t = Some(tcol);
        if temp_column {
            rec.temp = Some(temp_col);
        }
        rec
    }

    /// The true calibration: the inverse of the forward model with the effect terms.
    fn calibration(&self) -> Result<Calibration> {
        // In the file's unit: every count-valued term scaled by the unit of a count.
        let u = self.unit;
        let d = &self.d.map(|r| r.map(|v| v * u));
        let k_true =
            wiical_core::model::invert3(&wiical_core::Mat3::from_fn(|r, c| d[r][c] as f32))
                .map_err(SimulateError::ForwardNotInvertible)?;
        let mut calibration = Calibration::from_inverse(
            &k_true,
            &wiical_core::Vec3::new(
                (self.bias[0] * u) as f32,
                (self.bias[1] * u) as f32,
                (self.bias[2] * u) as f32,
            ),
        );
        let e = &self.eff64;
        calibration.effects = Effects {
            temp_ref_c: self.tm.room_c as f32,
            quadratic: e[0].map(|v| v as f32),
            cubic: e[1].map(|v| v as f32),
            bias_drift: e[2].map(|v| (v * u) as f32),
            bias_temp: e[3].map(|v| (v * u) as f32),
            scale_temp: e[4].map(|v| v as f32),
            cross_quadratic: self.cross.quadratic.map(|r| r.map(|v| v as f32)),
            cross_cubic: self.cross.cubic.map(|r| r.map(|v| v as f32)),
        };
        Ok(calibration)
    }

    /// The poses with their hold times.
    fn true_poses(&self) -> Vec<TruePose> {
        self.dirs
            .iter()
            .enumerate()
            .map(|(k, dir)| {
                let seg = self
                    .segs
                    .iter()
                    .find(|s| matches!(s.kind, SegKind::Hold(p) if p == k))
                    .map_or((0.0, 0.0), |s| (s.t0, s.t1));
                TruePose {
                    t_start: seg.0,
                    t_end: seg.1,
                    direction: *dir,
                }
            })
            .collect()
    }

    /// Self-check: the truth calibration maps a noiseless hold reading back to its direction.
    fn check_truth(&self, truth: &Truth) -> Result<()> {
        let Some(p) = truth.poses.get(1) else {
            return Ok(());
        };
        let n = self.conds.len();
        let tc = 0.5 * (p.t_start + p.t_end);
        let idx = ((tc * self.fs) as usize).min(n.saturating_sub(1));
        let Some(c) = self.conds.get(idx) else {
            return Ok(());
        };
        let m = self
            .reading(&p.direction, c)
            .map(|v| (v * self.unit) as f32);
        let a = truth.calibration_at(c).correct(m, &Truth::conditions(c));
        let err = (0..3)
            .map(|j| (a[j] as f64 - p.direction[j]).abs())
            .fold(0.0, f64::max);
        if err > 1e-4 {
            return Err(SimulateError::TruthNotInverse { err_g: err }.into());
        }
        Ok(())
    }
}

/// A hold with at least this many seconds of still samples must be found ([`score_holds`]).
pub const HOLD_MIN_STILL_S: f64 = 1.5;

/// Shortest detected window (s, first to last sample) that counts as finding a hold: what a
/// centred 0.5 s variance window leaves of [`HOLD_MIN_STILL_S`] still samples.
pub const FOUND_MIN_S: f64 = 1.0;

/// How far (s) a window may reach past its hold's true edges and still lie inside it: the
/// sensor is nearly still in the first and last quarter second of a move (its rotation starts
/// and ends smoothly), and the IMU-TK setting's 1 s window reached 0.12 s into a calm move
/// before this change (seed 4, pose 25); a bump or the turn itself is far outside it.
pub const FOUND_EDGE_S: f64 = 0.25;

/// Holds found by a detection, against the simulation's truth.
#[derive(Debug, Clone, PartialEq)]
pub struct HoldScore {
    /// Holds with at least [`HOLD_MIN_STILL_S`] still seconds.
    pub present: usize,
    /// Of those, the holds that a detected window of at least [`FOUND_MIN_S`] lies inside
    /// (within [`FOUND_EDGE_S`] of each edge).
    pub found: usize,
    /// Windows that lie inside no hold (they average motion).
    pub stray: usize,
    /// Indices (in the truth's poses) of the present holds not found.
    pub missed: Vec<usize>,
}

/// Scores detected `windows` (`(t_start, t_end)`: times of the first and last sample, s)
/// against the true holds: the measure of issue 19 item 1 ("every hold a window").
pub fn score_holds(poses: &[TruePose], windows: &[(f64, f64)]) -> HoldScore {
    let inside = |p: &TruePose, w: &(f64, f64)| {
        w.0 >= p.t_start - FOUND_EDGE_S && w.1 <= p.t_end + FOUND_EDGE_S
    };
    let mut score = HoldScore {
        present: 0,
        found: 0,
        stray: windows
            .iter()
            .filter(|w| !poses.iter().any(|p| inside(p, w)))
            .count(),
        missed: Vec::new(),
    };
    for (k, p) in poses.iter().enumerate() {
        if p.t_end - p.t_start < HOLD_MIN_STILL_S {
            continue;
        }
        score.present += 1;
        if windows
            .iter()
            .any(|w| w.1 - w.0 >= FOUND_MIN_S && inside(p, w))
        {
            score.found += 1;
        } else {
            score.missed.push(k);
        }
    }
    score
}

/// Simulates a recording (see the module docs).
pub fn simulate(cfg: &SimConfig) -> Result<SimOutput> {
    let (effects, noise) = check_config(cfg)?;
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let cpg = cfg.device.counts_per_g();
    let fs = cfg.rate_hz;
    // Sensor: upper-triangular forward matrix, bias near mid-scale.
    let s: [f64; 3] = std::array::from_fn(|_| cpg * (1.0 + rng.random_range(-0.04..0.04)));
    let mut off = || cpg * rng.random_range(-0.015..0.015);
    let d = [[s[0], off(), off()], [0.0, s[1], off()], [0.0, 0.0, s[2]]];
    // 10-bit: within ±20 counts of mid-scale; 16-bit: within ±0.05 g of zero.
    let bias_spread = 20.0f64.max(0.05 * cpg);
    let zero = cfg.device.zero_g();
    let bias: [f64; 3] =
        std::array::from_fn(|_| zero + rng.random_range(-bias_spread..bias_spread));
    let dirs = pose_directions(&mut rng, cfg.poses);
    let (segs, duration) = timeline(&mut rng, cfg.init_s, dirs.len(), cfg.profile);
    let n = (duration * fs).floor() as usize;
    let (tm, temps) = temperatures(&mut rng, &segs, n, fs);
    let conds = sample_conditions(&temps, fs);
    let mut scene = Scene {
        fs,
        noise,
        d,
        bias,
        dirs,
        segs,
        tm,
        temps,
        eff64: [[0.0; 3]; 5],
        outliers: Vec::new(),
        cross: open_basis::Cross::default(),
        extras: Vec::new(),
        conds,
        adc: cfg.device.adc_range(),
        unit: cfg.device.unit_per_count(),
    };
    let drawn = {
        let holds = hold_stats(&scene.segs, &scene.conds, fs);
        effect_terms(&mut rng, &effects, &s, &scene, duration, &holds)?
    };
    (scene.eff64, scene.outliers) = (drawn.eff64, drawn.outliers);
    (scene.cross, scene.extras) = (drawn.cross, drawn.extras);
    let rec = scene.record(
        &mut rng,
        cfg.temp_column || effects.iter().any(|(e, _, _)| e.needs_temperature()),
    );
    let truth = scene.truth(cfg, &effects)?;
    scene.check_truth(&truth)?;
    Ok(SimOutput {
        recording: rec,
        truth,
        conditions: scene.conds,
    })
}

impl Scene {
    /// The truth of this scene with `effects` drawn into it.
    fn truth(&self, cfg: &SimConfig, effects: &[SimDraw]) -> Result<Truth> {
        let names: Vec<&str> = effects.iter().map(|(e, _, _)| e.name()).collect();
        let unit = self.unit;
        let mut open = open_basis::cross_truth(&self.cross);
        open.extend(
            self.extras
                .iter()
                .map(|t| open_basis::extra_truth(t, cfg.device.unit_name(), unit)),
        );
        let extra_terms = self
            .extras
            .iter()
            .map(|t| open_basis::ExtraTerm {
                coefficients: match t.acts {
                    open_basis::Acts::Bias => t.coefficients.map(|c| c * unit),
                    open_basis::Acts::Scale => t.coefficients,
                },
                ..*t
            })
            .collect();
        Ok(Truth {
            device: cfg.device.name(),
            effect: if names.is_empty() {
                "none".into()
            } else {
                names.join(",")
            },
            magnitude_mg: effects.first().map_or(0.0, |e| e.1),
            magnitudes_mg: effects.iter().map(|e| e.1).collect(),
            single_axis: effects
                .iter()
                .filter_map(|(e, _, a)| Some(format!("{}: {}", e.name(), names::AXES[(*a)?])))
                .collect(),
            seed: cfg.seed,
            rate_hz: self.fs,
            samples: self.conds.len(),
            noise_std_counts: self.noise,
            forward_matrix: self.d.map(|r| r.map(|v| v * unit)),
            calibration: self.calibration()?,
            poses: self.true_poses(),
            outliers: self.outliers.clone(),
            temperature_model: self.tm,
            open_basis: open,
            extra_terms,
        })
    }
}

/// The recording as CSV text (`t,x,y,z[,temp]`), readable by [`crate::input::load::load`].
pub fn to_csv(rec: &Recording) -> String {
    let mut s = String::with_capacity(rec.len() * 24 + 32);
    s.push_str(if rec.temp.is_some() {
        "t,x,y,z,temp\n"
    } else {
        "t,x,y,z\n"
    });
    let times = rec.times(100.0);
    // Centiseconds when every time is one (100 Hz), else 10 µs (200, 400 Hz).
    let decimals = if times
        .iter()
        .all(|t| ((t * 100.0).round() - t * 100.0).abs() < 1e-6)
    {
        2
    } else {
        5
    };
    for (i, m) in rec.xyz.iter().enumerate() {
        use std::fmt::Write as _;
        let _ = write!(s, "{:.*},{},{},{}", decimals, times[i], m[0], m[1], m[2]);
        if let Some(tc) = &rec.temp {
            let _ = write!(s, ",{:.2}", tc[i]);
        }
        s.push('\n');
    }
    s
}

/// Where the truth of a recording written to `path` goes: `path` + `.truth.json`.
pub fn truth_path(path: &Path) -> PathBuf {
    let mut p = path.as_os_str().to_owned();
    p.push(".truth.json");
    PathBuf::from(p)
}

/// Writes the recording (CSV) and its truth (JSON, [`truth_path`]); returns the truth's path.
pub fn write(out: &SimOutput, path: &Path) -> Result<PathBuf> {
    write_file(path, to_csv(&out.recording).as_bytes())?;
    let tp = truth_path(path);
    let json = serde_json::to_string_pretty(&out.truth)? + "\n";
    write_file(&tp, json.as_bytes())?;
    Ok(tp)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nonlinearity_inverse() {
        for &(a, q, c) in &[(0.7, 0.02, -0.01), (-1.0, -0.03, 0.02), (0.0, 0.05, 0.05)] {
            let u = invert_nonlinearity(a, q, c);
            assert!((u + q * u * u + c * u * u * u - a).abs() < 1e-12);
        }
    }

    #[test]
    fn same_seed_same_recording_and_parses_back() {
        let cfg = SimConfig {
            poses: 10,
            effects: vec![EffectSpec::new(SimEffect::Temperature, None)],
            ..Default::default()
        };
        let a = simulate(&cfg).unwrap();
        let b = simulate(&cfg).unwrap();
        assert_eq!(a.recording.xyz, b.recording.xyz);
        let text = to_csv(&a.recording);
        let back = crate::input::load::parse(&text, &Default::default()).unwrap();
        assert_eq!(back.xyz, a.recording.xyz);
        assert_eq!(back.temp.as_ref().unwrap().len(), a.recording.len());
        assert!(a.recording.xyz.iter().flatten().all(|v| v.fract() == 0.0));
    }

    /// The 16-bit MEMS is written in m/s² (a hold's mean norm is ~9.8, on the lattice of
    /// 9.80665/16384), its truth in the same unit (`check_truth` inverts it inside
    /// `simulate`), and its 400 Hz times survive the CSV distinct and in order.
    #[test]
    fn mems16_brisk_at_400_hz_is_in_m_s2_and_parses_back() {
        let cfg = SimConfig {
            poses: 10,
            device: Device::Mems16,
            rate_hz: 400.0,
            profile: Profile::Brisk,
            ..Default::default()
        };
        let a = simulate(&cfg).unwrap();
        let rest = &a.recording.xyz[..400];
        let norm = rest
            .iter()
            .map(|m| m.iter().map(|v| v * v).sum::<f64>().sqrt())
            .sum::<f64>()
            / 400.0;
        assert!((norm - 9.80665).abs() < 0.6, "{norm}");
        let q = 9.80665 / 16384.0;
        assert!(rest
            .iter()
            .flatten()
            .all(|v| ((v / q) - (v / q).round()).abs() < 1e-6));
        let text = to_csv(&a.recording);
        let back = crate::input::load::parse(&text, &Default::default()).unwrap();
        assert!((back.estimated_rate_hz().unwrap() - 400.0).abs() < 1e-6);
        // Brisk: holds of 2–4 s after the rest.
        for p in &a.truth.poses[1..] {
            assert!((2.0..4.0).contains(&(p.t_end - p.t_start)), "{p:?}");
        }
    }
}

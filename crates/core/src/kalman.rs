//! The 3-state Kalman filter of *Where's the Wiimote? Using Kalman Filtering To Extract
//! Accelerometer Data* (seed `kalman_wiimote_article.txt`): one axis of motion, state
//! `x = [p, v, b]` — position (m), velocity (m/s) and accelerometer bias (m/s²) — with the
//! measured acceleration as the control input and position measurements (e.g. from the
//! Wiimote's IR camera) as the observations.
//!
//! ## What was reconstructed, and why
//! The article's equations were images and are lost; its text fixes enough to rebuild them:
//!
//! * the kinematics of eq. (8)–(9) are `ṗ = v`, `v̇ = a`;
//! * eq. (10) "models the true acceleration" from the accelerometer with a bias and a white
//!   noise; with the accelerometer reading `a_m = a + b + w` this is `a = a_m − b − w`, and
//!   the text says the filter "will estimate the bias then remove it from any measured
//!   acceleration";
//! * eq. (13): the bias is constant (`ḃ = 0`, "noticeable in the F matrix"), the measured
//!   acceleration is the control `u` ("Accelerometer input is a good example of an element of
//!   the control vector"), and the accelerometer noise enters as process noise `w`;
//! * eq. (11)/(14): a position measurement `z_i = p(t_i) + v_i`, i.e. `H = [1 0 0]`, with
//!   `R = σ_p²` (the article assumes σ_p = 0.5 cm);
//! * the article precomputes the time-invariant matrices; the position row of eq. (3)
//!   "multiplies out" to `p + v·dt + ½(a_m − b)·dt²`.
//!
//! Continuous model: `ẋ = F_c x + B_c u + G w` with
//! `F_c = [[0,1,0],[0,0,−1],[0,0,0]]`, `B_c = [0,1,0]ᵀ`, `G = −B_c`. `F_c` is nilpotent
//! (`F_c³ = 0`), so the transition matrix `Φ = exp(F_c·dt)` is exact:
//!
//! ```text
//!     ⎡1  dt  −dt²/2⎤        ⎡dt²/2⎤
//! F = ⎢0   1  −dt   ⎥,   B = ⎢ dt  ⎥,   H = [1 0 0],   R = σ_p²
//!     ⎣0   0   1    ⎦        ⎣  0  ⎦
//!
//! Q = B·Bᵀ·σ_a² + diag(0, 0, σ_bw²·dt)
//! ```
//!
//! `B = ∫₀^dt Φ(s)·B_c ds` is the zero-order-hold input matrix: the accelerometer sample
//! `a_m,k` is held over the step. Its white noise is held the same way, so the noise enters
//! through the same `B` and `Q = B Bᵀ σ_a²` (σ_a is the standard deviation of one
//! accelerometer sample, m/s²). The optional bias random walk `b_{k+1} = b_k + w_b`,
//! `var(w_b) = σ_bw²·dt` (σ_bw in m/s²/√s), lets the filter follow a slowly drifting bias;
//! with `σ_bw = 0` the bias is the constant of the article.
//!
//! Time update (eq. 3–4): `x⁻ = F x + B a_m`, `P⁻ = F P Fᵀ + Q`.
//! Measurement update (eq. 5–7): `S = H P⁻ Hᵀ + R` (a scalar, so the "matrix inverse" of
//! eq. 5 is a division), `K = P⁻ Hᵀ / S`, `x = x⁻ + K (z − H x⁻)`, and the covariance in
//! Joseph form `P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ`, which (unlike the short form
//! `(I − K H) P⁻` of eq. 7) stays symmetric positive semi-definite in `f32` even though the
//! variances span several decades (the article's "possible numerical issues"). `P` is also
//! re-symmetrised after every step.
//!
//! ## `f32` and large positions
//! The position is an absolute number: near 10 m the `f32` spacing is 1e-6 m, 1/5000 of the
//! article's 5 mm measurement noise, and it doubles with every doubling of `|p|`. Keep the
//! position origin near the working volume (positions of a hand-held remote are within a
//! metre or two of the camera's reference); the velocity and bias are unaffected.

use crate::Error;
use nalgebra::{SMatrix, SVector};

/// 3×3 `f32` matrix (covariances, transition matrix).
pub type Mat3x3 = SMatrix<f32, 3, 3>;
/// 3-vector `f32` (state `[p, v, b]`, gains).
pub type State = SVector<f32, 3>;

/// Parameters of a [`PvbFilter`]. Units: seconds, metres, m/s, m/s².
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct PvbConfig {
    /// Time step between accelerometer samples (and position measurements), s. > 0.
    pub dt: f32,
    /// σ_a: standard deviation of the white noise of one accelerometer sample, m/s². ≥ 0.
    pub accel_noise: f32,
    /// σ_bw: bias random-walk density, m/s² per √s (`var` grows by `σ_bw²·dt` per step).
    /// 0 for a constant bias. ≥ 0.
    pub bias_walk: f32,
    /// σ_p: standard deviation of a position measurement, m. > 0.
    pub pos_noise: f32,
    /// Initial state estimate `[p, v, b]` (m, m/s, m/s²).
    pub initial_state: [f32; 3],
    /// Initial standard deviations of `[p, v, b]` (diagonal `P0`, off-diagonals zero as the
    /// article advises). Each ≥ 0.
    pub initial_std: [f32; 3],
}

impl PvbConfig {
    /// The noise terms from an Allan deviation of the still accelerometer (`wiical noise`,
    /// IEEE 952): `velocity_random_walk` N in m/s²/√Hz (the white noise density) gives the
    /// per-sample σ_a = N/√dt; `rate_random_walk` K in m/s²/√s (the +½ slope; 0 when not
    /// seen) is the bias random-walk density σ_bw directly. The bias instability B is not a
    /// term of this filter (a flicker process has no finite-state model); a filter tuned to
    /// hold B can raise `bias_walk` so that σ_bw·√τ ≈ B at the τ of interest.
    pub fn from_allan(
        dt: f32,
        velocity_random_walk: f32,
        rate_random_walk: f32,
        pos_noise: f32,
        initial_std: [f32; 3],
    ) -> Result<Self, Error> {
        let cfg = Self {
            dt,
            accel_noise: velocity_random_walk / libm::sqrtf(dt),
            bias_walk: rate_random_walk,
            pos_noise,
            initial_state: [0.0; 3],
            initial_std,
        };
        cfg.validate()?;
        Ok(cfg)
    }

    fn validate(&self) -> Result<(), Error> {
        let scalars = [self.dt, self.accel_noise, self.bias_walk, self.pos_noise];
        if !crate::all_finite(&scalars)
            || !crate::all_finite(&self.initial_state)
            || !crate::all_finite(&self.initial_std)
        {
            return Err(Error::NonFinite);
        }
        if self.dt <= 0.0
            || self.accel_noise < 0.0
            || self.bias_walk < 0.0
            || self.pos_noise <= 0.0
            || self.initial_std.iter().any(|s| *s < 0.0)
        {
            return Err(Error::InvalidParameter);
        }
        Ok(())
    }
}

/// What a measurement update saw: the innovation and its predicted variance. Their ratio
/// `residual²/variance` (the NIS) is χ²(1)-distributed for a consistent filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Innovation {
    /// `z − H x⁻`, m.
    pub residual: f32,
    /// `S = H P⁻ Hᵀ + R`, m².
    pub variance: f32,
}

/// The position/velocity/bias Kalman filter (see the [module docs](self) for the model).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PvbFilter {
    x: State,
    p: Mat3x3,
    f: Mat3x3,
    b: State,
    q: Mat3x3,
    r: f32,
}

impl PvbFilter {
    /// Builds the filter and precomputes `F`, `B`, `Q`, `R` for the fixed step `cfg.dt`.
    /// Invalid parameters give [`Error::NonFinite`] / [`Error::InvalidParameter`].
    pub fn new(cfg: &PvbConfig) -> Result<Self, Error> {
        cfg.validate()?;
        let dt = cfg.dt;
        let h = 0.5 * dt * dt;
        let f = Mat3x3::new(1.0, dt, -h, 0.0, 1.0, -dt, 0.0, 0.0, 1.0);
        let b = State::new(h, dt, 0.0);
        let mut q = b * b.transpose() * (cfg.accel_noise * cfg.accel_noise);
        q[(2, 2)] += cfg.bias_walk * cfg.bias_walk * dt;
        let s = State::from(cfg.initial_std);
        let p = Mat3x3::from_diagonal(&s.component_mul(&s));
        let r = cfg.pos_noise * cfg.pos_noise;
        let all = [f.as_slice(), b.as_slice(), q.as_slice(), p.as_slice(), &[r]];
        if !all.iter().all(|v| crate::all_finite(v)) || r <= 0.0 {
            // Overflow/underflow of squares of extreme (but finite) parameters.
            return Err(Error::InvalidParameter);
        }
        Ok(Self {
            x: State::from(cfg.initial_state),
            p,
            f,
            b,
            q,
            r,
        })
    }

    /// Time update over one step with the measured acceleration `a_m` (m/s², the raw
    /// accelerometer reading along the axis of motion, bias included, gravity removed):
    /// `x⁻ = F x + B a_m`, `P⁻ = F P Fᵀ + Q`. A non-finite `a_m` (or a result that
    /// overflows) gives [`Error::NonFinite`] and leaves the filter unchanged.
    pub fn predict(&mut self, a_m: f32) -> Result<(), Error> {
        if !a_m.is_finite() {
            return Err(Error::NonFinite);
        }
        let x = self.f * self.x + self.b * a_m;
        let p = symmetrize(&(self.f * self.p * self.f.transpose() + self.q));
        if !crate::all_finite(x.as_slice()) || !crate::all_finite(p.as_slice()) {
            return Err(Error::NonFinite);
        }
        self.x = x;
        self.p = p;
        Ok(())
    }

    /// Measurement update with a position measurement `z` (m). Returns the innovation.
    /// A non-finite `z` gives [`Error::NonFinite`]; a non-positive innovation variance gives
    /// [`Error::Singular`]; in both cases the filter is unchanged.
    pub fn update(&mut self, z: f32) -> Result<Innovation, Error> {
        if !z.is_finite() {
            return Err(Error::NonFinite);
        }
        let s = self.p[(0, 0)] + self.r;
        if !(s.is_finite() && s > 0.0) {
            return Err(Error::Singular);
        }
        let residual = z - self.x[0];
        let k: State = self.p.column(0) / s;
        let x = self.x + k * residual;
        // I − K H: H = [1 0 0] selects the first column.
        let mut i_kh = Mat3x3::identity();
        for i in 0..3 {
            i_kh[(i, 0)] -= k[i];
        }
        let p = i_kh * self.p * i_kh.transpose() + k * k.transpose() * self.r;
        let p = symmetrize(&p);
        if !crate::all_finite(x.as_slice()) || !crate::all_finite(p.as_slice()) {
            return Err(Error::NonFinite);
        }
        self.x = x;
        self.p = p;
        Ok(Innovation {
            residual,
            variance: s,
        })
    }

    /// State estimate `[p, v, b]` (m, m/s, m/s²).
    pub fn state(&self) -> State {
        self.x
    }

    /// Estimate covariance `P` (units of the state, squared).
    pub fn covariance(&self) -> Mat3x3 {
        self.p
    }

    /// Estimated accelerometer bias, m/s².
    pub fn bias(&self) -> f32 {
        self.x[2]
    }

    /// The transition matrix `F` for the configured step.
    pub fn transition(&self) -> Mat3x3 {
        self.f
    }

    /// The control input matrix `B` for the configured step.
    pub fn input(&self) -> State {
        self.b
    }

    /// The process noise covariance `Q` for the configured step.
    pub fn process_noise(&self) -> Mat3x3 {
        self.q
    }

    /// The measurement noise variance `R = σ_p²`, m².
    pub fn measurement_noise(&self) -> f32 {
        self.r
    }
}

fn symmetrize(p: &Mat3x3) -> Mat3x3 {
    (p + p.transpose()) * 0.5
}

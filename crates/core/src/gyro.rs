//! Gyroscope calibration from a multi-position recording: scale, misalignment and bias
//! (Tedaldi, Pretto, Menegatti, *A robust and easy to implement method for IMU calibration
//! without external equipments*, ICRA 2014 — the method of IMU-TK).
//!
//! ## Idea
//! The sensor rests in a static pose, is turned by hand, rests in the next pose, and so on.
//! In every static window the (already calibrated) accelerometer gives the direction of
//! gravity in the sensor frame. Between two windows the true rotation is unknown, but a
//! correctly calibrated gyroscope, integrated over the motion, must rotate the first window's
//! gravity direction onto the second's. The mismatch of the two unit vectors is the residual;
//! its size is (to first order) the angle error of the integrated rotation.
//!
//! ## Model and conventions
//! * Raw gyro samples `m` (counts); angular rate in rad/s, sensor frame:
//!   `ω = K·(m − b)` ([`GyroCalibration`]). `K` is a full 3×3 matrix (scale and
//!   misalignment, 9 parameters): the accelerometer fixes the frame, so unlike the
//!   accelerometer's `K` no rotation gauge is left over.
//! * Orientation: unit quaternion `q = (w, x, y, z)` of the *current* sensor frame relative to
//!   the sensor frame at the start of the motion (`v_start = q ⊗ v_now ⊗ q*`), obeying
//!   `q̇ = ½ q ⊗ (0, ω)`.
//! * Integration: classical Runge–Kutta (RK4) between consecutive samples, with `ω` linear
//!   in time between them (the stage at mid-step uses the mean of the two samples), as
//!   IMU-TK does. The quaternion is normalised once at the end of the motion.
//! * Gravity: the two directions `g₀` (window before) and `g₁` (window after) are unit
//!   vectors in the sensor frame. Predicted `ĝ₁ = q* ⊗ g₀ ⊗ q`; residual `r = ĝ₁ − g₁`
//!   (3 components, rad to first order); angle `∠(ĝ₁, g₁)` for reporting.
//!
//! ## Parameterisation of the fit
//! The fit starts from a nominal calibration `K₀, b₀` (the sensor's datasheet scale with its
//! axis signs, bias from the initial rest) and estimates
//! `ω = P·(K₀(m − b₀) − δ)`: `P` (3×3, dimensionless, starts at the identity) and `δ`
//! (rad/s, the bias correction expressed in the nominal frame, starts at 0). All parameters
//! are then of order one whatever the sensor's units, which keeps the `f32` normal equations
//! well scaled. The result maps back to `K = P·K₀`, `b = b₀ + K₀⁻¹δ`.
//! Parameter order in vectors and Jacobians: `P` row-major (0–8), then `δ` (9–11).
//!
//! ## Exact derivatives
//! The Jacobian is the derivative of the *discrete* RK4 solution. One RK4 step is a right
//! multiplication `q_{n+1} = q_n ⊗ m_n` (`m_n` a polynomial in the step's rates), so
//! `∂q_N/∂p = G ⊗ q_N` with `G` a sum over the steps of each step's derivative rotated into the
//! start frame ([`MotionIntegrator`] has the formulas). This equals integrating the forward
//! sensitivities `Ṡ = ½ S ⊗ ω + ½ q ⊗ ∂ω/∂p` with the same RK4 stages as `q` (explicit
//! Runge–Kutta methods commute with differentiation), at less than half the work. Tests
//! compare it with central differences.
//!
//! ## Memory
//! [`MotionIntegrator`] takes one sample at a time and keeps only the quaternion and the
//! sensitivity sums (4 + 27 + 9 numbers), so a motion of any length costs constant memory; the
//! fit (`gyro_fit`) accumulates the normal equations motion by motion.
//!
//! Generic over the float type (`f32` on the adapter, `f64` on a desktop) through
//! [`nalgebra::RealField`].

use crate::Error;
use nalgebra::{Matrix3, RealField, SMatrix, Vector3, Vector4};

/// Number of fit parameters: `P` (9, row-major) then `δ` (3).
pub const NPARAM: usize = 12;

/// `∂q/∂p`: one quaternion column per parameter.
pub type Sensitivity<T> = SMatrix<T, 4, NPARAM>;
/// `∂r/∂p` of one motion.
pub type MotionJacobian<T> = SMatrix<T, 3, NPARAM>;

/// Gyroscope calibration `ω = K·(m − b)`: `m` raw counts, `ω` rad/s in the sensor
/// (accelerometer) frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GyroCalibration<T: RealField + Copy> {
    /// `b`, raw counts: the reading at zero rate.
    pub bias: Vector3<T>,
    /// `K`, rad/s per count (row-major when printed).
    pub matrix: Matrix3<T>,
}

impl<T: RealField + Copy> GyroCalibration<T> {
    /// Nominal calibration: a per-axis sensitivity `rad_per_count` (signed, so an inverted
    /// axis has a negative entry) and a bias, usually the mean of the initial rest.
    pub fn nominal(bias: [T; 3], rad_per_count: [T; 3]) -> Self {
        Self {
            bias: Vector3::from(bias),
            matrix: Matrix3::from_diagonal(&Vector3::from(rad_per_count)),
        }
    }

    /// Angular rate in rad/s of a raw sample.
    #[inline]
    pub fn rate(&self, m: &[T; 3]) -> Vector3<T> {
        self.matrix * (Vector3::from(*m) - self.bias)
    }

    /// Checks that every entry is finite and `K` invertible.
    pub fn validate(&self) -> Result<(), Error> {
        if !self
            .bias
            .iter()
            .chain(self.matrix.iter())
            .all(|x| x.is_finite())
        {
            return Err(Error::NonFinite);
        }
        let det = self.matrix.determinant();
        let size = self.matrix.norm();
        if det.abs() <= size * size * size * nalgebra::convert(1e-9) || !det.is_finite() {
            return Err(Error::Singular);
        }
        Ok(())
    }
}

/// The adjustable part of the fit: `ω = P·(u − δ)` with `u = K₀(m − b₀)` (see the
/// [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Adjustment<T: RealField + Copy> {
    /// `P`, dimensionless (identity: no change).
    pub p: Matrix3<T>,
    /// `δ`, rad/s in the nominal frame.
    pub delta: Vector3<T>,
}

impl<T: RealField + Copy> Adjustment<T> {
    /// No change from the nominal calibration.
    pub fn identity() -> Self {
        Self {
            p: Matrix3::identity(),
            delta: Vector3::zeros(),
        }
    }

    /// From the parameter vector (order: `P` row-major, then `δ`).
    pub fn from_params(x: &SMatrix<T, NPARAM, 1>) -> Self {
        Self {
            p: Matrix3::new(x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8]),
            delta: Vector3::new(x[9], x[10], x[11]),
        }
    }

    /// To the parameter vector (order: `P` row-major, then `δ`).
    pub fn to_params(&self) -> SMatrix<T, NPARAM, 1> {
        let p = &self.p;
        SMatrix::<T, NPARAM, 1>::from_column_slice(&[
            p[(0, 0)],
            p[(0, 1)],
            p[(0, 2)],
            p[(1, 0)],
            p[(1, 1)],
            p[(1, 2)],
            p[(2, 0)],
            p[(2, 1)],
            p[(2, 2)],
            self.delta.x,
            self.delta.y,
            self.delta.z,
        ])
    }

    /// The calibration this adjustment makes of `nominal`: `K = P·K₀`, `b = b₀ + K₀⁻¹δ`.
    pub fn apply(&self, nominal: &GyroCalibration<T>) -> Result<GyroCalibration<T>, Error> {
        let k0_inv = nominal.matrix.try_inverse().ok_or(Error::Singular)?;
        let cal = GyroCalibration {
            bias: nominal.bias + k0_inv * self.delta,
            matrix: self.p * nominal.matrix,
        };
        cal.validate()?;
        Ok(cal)
    }
}

/// Quaternion product `a ⊗ b`, `(w, x, y, z)` order.
#[inline]
pub fn qmul<T: RealField + Copy>(a: &Vector4<T>, b: &Vector4<T>) -> Vector4<T> {
    Vector4::new(
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    )
}

/// `½ q ⊗ (0, v)`: the quaternion rate for body rate `v`, or its derivative part.
#[inline]
fn half_q_pure<T: RealField + Copy>(q: &Vector4<T>, v: &Vector3<T>, half: T) -> Vector4<T> {
    Vector4::new(
        -(q[1] * v.x + q[2] * v.y + q[3] * v.z) * half,
        (q[0] * v.x + q[2] * v.z - q[3] * v.y) * half,
        (q[0] * v.y - q[1] * v.z + q[3] * v.x) * half,
        (q[0] * v.z + q[1] * v.y - q[2] * v.x) * half,
    )
}

/// `2` in any float type.
#[inline]
fn two_of<T: RealField + Copy>() -> T {
    nalgebra::convert(2.0)
}

/// Vector part of `(xs, xv) ⊗ (ys, yv)`.
#[inline]
fn vec_mul<T: RealField + Copy>(xs: T, xv: &Vector3<T>, ys: T, yv: &Vector3<T>) -> Vector3<T> {
    yv * xs + xv * ys + xv.cross(yv)
}

/// The rotation `v ↦ q ⊗ (0, v) ⊗ q⁻¹` as a matrix, for any non-zero `q`.
#[inline]
fn rotation_matrix<T: RealField + Copy>(q: &Vector4<T>) -> Matrix3<T> {
    let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
    let two = two_of::<T>();
    let n = w * w + x * x + y * y + z * z;
    Matrix3::new(
        w * w + x * x - y * y - z * z,
        two * (x * y - w * z),
        two * (x * z + w * y),
        two * (x * y + w * z),
        w * w - x * x + y * y - z * z,
        two * (y * z - w * x),
        two * (x * z - w * y),
        two * (y * z + w * x),
        w * w - x * x - y * y + z * z,
    ) / n
}

#[inline]
fn conj<T: RealField + Copy>(q: &Vector4<T>) -> Vector4<T> {
    Vector4::new(q[0], -q[1], -q[2], -q[3])
}

#[inline]
fn pure<T: RealField + Copy>(v: &Vector3<T>) -> Vector4<T> {
    Vector4::new(T::zero(), v.x, v.y, v.z)
}

/// What a motion gives: the gravity residual, its Jacobian and the angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionResidual<T: RealField + Copy> {
    /// `ĝ₁ − g₁` (unit vectors; rad to first order).
    pub residual: Vector3<T>,
    /// `∂r/∂p`; zero columns for parameters whose sensitivity was not tracked.
    pub jacobian: MotionJacobian<T>,
    /// Angle between `ĝ₁` and `g₁`, rad.
    pub angle: T,
    /// The integrated orientation of the end frame in the start frame (unit quaternion).
    pub rotation: Vector4<T>,
}

/// Streaming RK4 integration of one motion, with the sensitivities of the orientation to the
/// parameters that are marked as tracked.
///
/// Push the raw samples of the motion in order (the last sample of the static window before
/// through the first sample of the window after); then [`MotionIntegrator::finish`].
///
/// ## How the sensitivities are kept (exact, but cheap)
/// One RK4 step with `ω` linear between samples is a right multiplication: every stage is `q`
/// times a polynomial in the stage rates, so `q_{n+1} = q_n ⊗ m_n` with
/// `m_n = (1 − c₂ρ) + a(W₀ + W₁) + 4c₁W_m + c₂(W₀W_m + W_mW₁) − c₄ρ W₀W₁`
/// (`W = ω/2` as pure quaternions at the step's start, middle and end, `ρ = |W_m|²`,
/// `c₁ = h/6`, `c₂ = h²/6`, `c₃ = h³/12`, `c₄ = h⁴/24`, `a = c₁ − c₃ρ`). Differentiating the
/// product `q_N = m₀ ⊗ … ⊗ m_{N−1}` gives `∂q_N/∂p = G ⊗ q_N` with
/// `G = Σ_n q_n ⊗ (∂m_n/∂p ⊗ m_n⁻¹) ⊗ q_n⁻¹`: each step's derivative is carried to the start
/// frame by a rotation. Only `G`'s vector part matters (its scalar part moves `q_N` along
/// itself, which the normalisation in [`MotionIntegrator::finish`] removes). Since
/// `∂ω/∂P_ij = e_i u_j` and `∂ω/∂δ_j = −P e_j`, `G` is a sum of outer products of rotated
/// per-axis vectors with the nominal rates: 3×3×3 numbers for `P` and 3×3 for `δ` (then
/// multiplied by `P` at the end), less than half the work of integrating the 12 columns of
/// `∂q/∂p` through the RK4 stages (1,298 against 2,846 instructions per sample on a Cortex-M33), and the same derivative of the discrete solution (the tests
/// compare it with central differences).
#[derive(Debug, Clone)]
pub struct MotionIntegrator<T: RealField + Copy> {
    nominal: GyroCalibration<T>,
    adj: Adjustment<T>,
    tracked: [bool; NPARAM],
    /// Rows `i` of `P` with a tracked entry, or all rows when a `δ` is tracked.
    rows: [bool; 3],
    dt: T,
    /// `h/6, h²/6, h³/12, h⁴/24`.
    c: [T; 4],
    q: Vector4<T>,
    /// `x[i]` column `j`: vector part of `G` for `P_ij`.
    x: [Matrix3<T>; 3],
    /// `z[i]`: `Σ` over steps of the rotated derivative along axis `i` of `ω` (for `δ`).
    z: [Vector3<T>; 3],
    /// Previous sample's nominal rate `u` (already minus `δ`).
    prev_u: Option<Vector3<T>>,
    steps: u32,
}

impl<T: RealField + Copy> MotionIntegrator<T> {
    /// A new motion at the identity orientation. `dt` is the sample period in seconds;
    /// `tracked[k]` says whether `∂q/∂p_k` is integrated (all false: orientation only, the
    /// cheap path for evaluating a calibration).
    pub fn new(
        nominal: GyroCalibration<T>,
        adj: Adjustment<T>,
        dt: T,
        tracked: [bool; NPARAM],
    ) -> Result<Self, Error> {
        nominal.validate()?;
        if !(dt.is_finite() && dt > T::zero()) {
            return Err(Error::InvalidParameter);
        }
        if !adj.p.iter().chain(adj.delta.iter()).all(|x| x.is_finite()) {
            return Err(Error::NonFinite);
        }
        let any_delta = tracked[9..].contains(&true);
        let c = [
            dt / nalgebra::convert::<f64, T>(6.0),
            dt * dt / nalgebra::convert::<f64, T>(6.0),
            dt * dt * dt / nalgebra::convert::<f64, T>(12.0),
            dt * dt * dt * dt / nalgebra::convert::<f64, T>(24.0),
        ];
        Ok(Self {
            nominal,
            adj,
            tracked,
            rows: core::array::from_fn(|i| any_delta || tracked[3 * i..3 * i + 3].contains(&true)),
            dt,
            c,
            q: Vector4::new(T::one(), T::zero(), T::zero(), T::zero()),
            x: [Matrix3::zeros(); 3],
            z: [Vector3::zeros(); 3],
            prev_u: None,
            steps: 0,
        })
    }

    /// For evaluating a final calibration: no adjustment, no sensitivities.
    pub fn for_calibration(cal: GyroCalibration<T>, dt: T) -> Result<Self, Error> {
        Self::new(cal, Adjustment::identity(), dt, [false; NPARAM])
    }

    /// Number of RK4 steps taken (samples pushed minus one).
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// Adds the next raw sample; from the second one on, advances one RK4 step.
    pub fn push(&mut self, m: &[T; 3]) -> Result<(), Error> {
        if !m.iter().all(|x| x.is_finite()) {
            return Err(Error::NonFinite);
        }
        let u = self.nominal.matrix * (Vector3::from(*m) - self.nominal.bias) - self.adj.delta;
        if let Some(u0) = self.prev_u {
            self.step(&u0, &u);
            self.steps = self.steps.saturating_add(1);
        }
        self.prev_u = Some(u);
        Ok(())
    }

    /// One RK4 step from nominal rate `u0` to `u1` (linear in between), for the orientation
    /// and, when any parameter is tracked, the sensitivity sums.
    fn step(&mut self, u0: &Vector3<T>, u1: &Vector3<T>) {
        let two: T = nalgebra::convert(2.0);
        let half: T = nalgebra::convert(0.5);
        let h = self.dt;
        let h2 = h * half;
        let h6 = h / nalgebra::convert::<f64, T>(6.0);
        let um = (u0 + u1) * half;
        let p = self.adj.p;
        let (w0, wm, w1) = (p * u0, p * um, p * u1);
        let q = self.q;
        let k1 = half_q_pure(&q, &w0, half);
        let q2 = q + k1 * h2;
        let k2 = half_q_pure(&q2, &wm, half);
        let q3 = q + k2 * h2;
        let k3 = half_q_pure(&q3, &wm, half);
        let q4 = q + k3 * h;
        let k4 = half_q_pure(&q4, &w1, half);
        self.q = q + (k1 + k2 * two + k3 * two + k4) * h6;
        if self.rows.contains(&true) {
            self.accumulate(&q, [w0 * half, wm * half, w1 * half], u0, u1);
        }
    }

    /// Adds one step's term of `G` (see the type's docs): `q` the orientation at the step's
    /// start, `w` the half rates `W₀, W_m, W₁`, `u0, u1` the nominal rates at both ends.
    fn accumulate(&mut self, q: &Vector4<T>, w: [Vector3<T>; 3], u0: &Vector3<T>, u1: &Vector3<T>) {
        let [c1, c2, c3, c4] = self.c;
        let (w0, wm, w1) = (w[0], w[1], w[2]);
        let half: T = nalgebra::convert(0.5);
        let quarter: T = nalgebra::convert(0.25);
        let four: T = nalgebra::convert(4.0);
        let rho = wm.norm_squared();
        let a = c1 - c3 * rho;
        let (d01, x01) = (w0.dot(&w1), w0.cross(&w1));
        // m = q_n⁻¹ ⊗ q_{n+1} and its inverse.
        let m_s = T::one() - c2 * rho - c2 * (w0.dot(&wm) + wm.dot(&w1)) + c4 * rho * d01;
        let m_v = (w0 + w1) * a + wm * (four * c1) + (w0.cross(&wm) + wm.cross(&w1)) * c2
            - x01 * (c4 * rho);
        let m2 = m_s * m_s + m_v.norm_squared();
        let (inv_s, inv_v) = (m_s / m2, -m_v / m2);
        // ∂m/∂W₀ along v = v ⊗ α, ∂m/∂W₁ along v = β ⊗ v, ∂m/∂W_m along e_i uses γ.
        let alpha_v = wm * c2 - w1 * (c4 * rho);
        let beta_v = wm * c2 - w0 * (c4 * rho);
        let (gamma_s, gamma_v) = (c2 - c4 * d01, (w0 + w1) * c3 + x01 * c4);
        let (sum01, diff01) = (w0 + w1, w0 - w1);
        // Rotation by q (q ⊗ v ⊗ q⁻¹, q not quite unit after RK4).
        let rot = rotation_matrix(q);
        let units: [Vector3<T>; 3] = [Vector3::x(), Vector3::y(), Vector3::z()];
        let mut ab = [(Vector3::zeros(), Vector3::zeros()); 3];
        for i in (0..3).filter(|i| self.rows[*i]) {
            let e = &units[i];
            let d0 = (-e.dot(&alpha_v), e * a + e.cross(&alpha_v));
            let d1 = (-beta_v.dot(e), e * a + beta_v.cross(e));
            let dr = two_of::<T>() * wm[i];
            let dm = (
                -c2 * sum01[i] - dr * gamma_s,
                e * (four * c1) + diff01.cross(e) * c2 - gamma_v * dr,
            );
            // ∂m/∂ω = ½ ∂m/∂W; the middle rate is half of each end's.
            let va = vec_mul(
                d0.0 * half + dm.0 * quarter,
                &(d0.1 * half + dm.1 * quarter),
                inv_s,
                &inv_v,
            );
            let vb = vec_mul(
                d1.0 * half + dm.0 * quarter,
                &(d1.1 * half + dm.1 * quarter),
                inv_s,
                &inv_v,
            );
            ab[i] = (rot * va, rot * vb);
        }
        for i in (0..3).filter(|i| self.rows[*i]) {
            let (a_i, b_i) = ab[i];
            for j in (0..3).filter(|j| self.tracked[3 * i + j]) {
                let mut col = self.x[i].column_mut(j);
                col += a_i * u0[j] + b_i * u1[j];
            }
            self.z[i] += a_i + b_i;
        }
    }

    /// `∂q/∂p_k` at the current state: `G_k ⊗ q` (see the type's docs).
    fn sensitivity(&self, k: usize) -> Vector4<T> {
        let g = if k < 9 {
            self.x[k / 3].column(k % 3).into_owned()
        } else {
            let j = k - 9;
            let p = &self.adj.p;
            -(self.z[0] * p[(0, j)] + self.z[1] * p[(1, j)] + self.z[2] * p[(2, j)])
        };
        qmul(&pure(&g), &self.q)
    }

    /// Ends the motion: gravity residual between `g_start` (window before) and `g_end`
    /// (window after), both in the sensor frame, any non-zero length.
    pub fn finish(
        &self,
        g_start: &Vector3<T>,
        g_end: &Vector3<T>,
    ) -> Result<MotionResidual<T>, Error> {
        let gs = g_start
            .try_normalize(T::zero())
            .ok_or(Error::InvalidParameter)?;
        let ge = g_end
            .try_normalize(T::zero())
            .ok_or(Error::InvalidParameter)?;
        let qn = self.q.norm();
        if !(qn.is_finite() && qn > T::zero()) {
            return Err(Error::NonFinite);
        }
        let n = self.q / qn;
        let (nc, gq) = (conj(&n), pure(&gs));
        let rotated = qmul(&qmul(&nc, &gq), &n);
        let predicted = Vector3::new(rotated[1], rotated[2], rotated[3]);
        let residual = predicted - ge;
        let mut jacobian = MotionJacobian::zeros();
        for k in 0..NPARAM {
            if !self.tracked[k] {
                continue;
            }
            let s = self.sensitivity(k);
            // Derivative of the normalisation n = q/|q|, then of n* ⊗ g ⊗ n.
            let dn = (s - n * n.dot(&s)) / qn;
            let dv = qmul(&qmul(&conj(&dn), &gq), &n) + qmul(&qmul(&nc, &gq), &dn);
            jacobian.set_column(k, &Vector3::new(dv[1], dv[2], dv[3]));
        }
        let angle = predicted.cross(&ge).norm().atan2(predicted.dot(&ge));
        if !residual
            .iter()
            .chain(jacobian.iter())
            .all(|x| x.is_finite())
        {
            return Err(Error::NonFinite);
        }
        Ok(MotionResidual {
            residual,
            jacobian,
            angle,
            rotation: n,
        })
    }
}

//! The sensor: the scene a sample depends on, the specific force it feels (the motion and
//! the push of a pose that was not still), its noiseless reading (the correction-side model
//! inverted) and the recorded counts (noise, rounding, ADC range).

use crate::conditions::{SampleConditions, TempModel};
use crate::draw::EffectTerms;
use crate::motion::{self, Seg, SegKind};
use crate::open_basis_terms::{self, Acts};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use wiical_analysis::Recording;

/// Everything a sample depends on.
pub(super) struct Scene {
    pub(super) fs: f64,
    pub(super) noise: f64,
    /// Forward matrix, counts per g.
    pub(super) d: [[f64; 3]; 3],
    /// Bias, counts.
    pub(super) bias: [f64; 3],
    pub(super) dirs: Vec<[f64; 3]>,
    pub(super) segs: Vec<Seg>,
    pub(super) tm: TempModel,
    pub(super) temps: Vec<f64>,
    /// The effect terms drawn.
    pub(super) terms: EffectTerms,
    /// The true conditions of every sample.
    pub(super) conds: Vec<SampleConditions>,
    /// ADC range, counts.
    pub(super) adc: (f64, f64),
    /// Written value of one count ([`Device::unit_per_count`]).
    pub(super) unit: f64,
}

/// Solves `a = u + q·u² + c·u³` for `u` near `a` (Newton).
pub(super) fn invert_nonlinearity(a: f64, q: f64, c: f64) -> f64 {
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

impl Scene {
    /// Specific force in sensor axes at time `ti` in segment `seg`, g: the motion's, and
    /// within the hold of a pose that was not still, its push along gravity.
    fn specific_force(&self, seg: &Seg, ti: f64) -> [f64; 3] {
        let mut f = motion::specific_force(&self.dirs, seg, ti);
        if let SegKind::Hold(k) = seg.kind {
            let outlier = self.terms.outliers.iter().find(|o| o.pose == k);
            if let Some(push) = outlier.and_then(|o| o.push(ti)) {
                for (fj, dj) in f.iter_mut().zip(self.dirs[k]) {
                    *fj += push * dj;
                }
            }
        }
        f
    }

    /// The noiseless reading (counts) of specific force `f` at the sample conditions `c`:
    /// the correction-side model inverted, `a = u + q u² + c u³ + cross(u)`,
    /// `u = (1 + σ·Δθ)·(1 + S)·D⁻¹(m − b_eff − B)` per axis, with `S` and `B` the open-basis
    /// scale and bias terms (without open-basis terms, exactly the computation it always was).
    pub(super) fn reading(&self, f: &[f64; 3], c: &SampleConditions) -> [f64; 3] {
        let e = &self.terms.eff64;
        let (ti, theta) = (c.time_s, c.temperature_c);
        let dth = theta - self.tm.room_c;
        let mut w: [f64; 3] = std::array::from_fn(|j| invert_nonlinearity(f[j], e[0][j], e[1][j]));
        if self.terms.cross.any() {
            w = open_basis_terms::invert_with_cross(f, &e[0], &e[1], &self.terms.cross, w);
        }
        let mut v: [f64; 3] = std::array::from_fn(|j| w[j] / (1.0 + e[4][j] * dth));
        let mut extra_bias = [0.0; 3];
        for t in &self.terms.extras {
            let r = t.regressor.value(c);
            for j in 0..3 {
                match t.acts {
                    Acts::Bias => extra_bias[j] += t.coefficients[j] * r,
                    Acts::Scale => v[j] /= 1.0 + t.coefficients[j] * r,
                }
            }
        }
        std::array::from_fn(|j| {
            let lin: f64 = (0..3).map(|k| self.d[j][k] * v[k]).sum();
            let b_eff = self.bias[j] + e[2][j] * ti + e[3][j] * dth;
            if self.terms.extras.is_empty() {
                lin + b_eff
            } else {
                lin + (b_eff + extra_bias[j])
            }
        })
    }

    /// The recording: 10-bit counts with noise, times at 0.01 s and the measured temperature.
    pub(super) fn record(&self, rng: &mut ChaCha8Rng, temp_column: bool) -> Recording {
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
}

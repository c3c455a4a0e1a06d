//! The hard/soft-iron fit: the points fed, in file order, to one of the core's streaming `f32`
//! accumulators ([`wiical_core::magfit`], exactly what the firmware does on the device), solved,
//! and a second pass over the same points computes the fit quality. Everything the core
//! returns is `f32`; the report widens it to `f64` only for printing / JSON.

use super::model::MagModel;
pub use crate::error::magnetometer::MagnetometerError;
use wiical_core::magfit::{AxisEllipsoidFit, EllipsoidFit, MagFit, ResidualAccumulator, SphereFit};

type Result<T, E = MagnetometerError> = std::result::Result<T, E>;

/// Result of [`fit_points`], in raw sensor units (ready for `--json`).
///
/// Convention (as in MATLAB `magcal`): `‖matrix·(m − center)‖ ≈ radius` for every sample,
/// `matrix` symmetric with determinant 1, so `radius` is the field strength in raw units.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MagFitReport {
    /// Model name: `sphere`, `axis` or `ellipsoid`.
    pub model: String,
    /// Number of points fitted.
    pub samples: usize,
    /// Hard-iron offset (ellipsoid centre), raw units.
    pub center: [f64; 3],
    /// Soft-iron matrix `W`, row-major, symmetric, `det W = 1`.
    pub matrix: [[f64; 3]; 3],
    /// Field strength `R`, raw units (geometric mean of the semi-axes).
    pub radius: f64,
    /// MATLAB `magcal` fit error, percent: `100·√(mean((‖W(m−c)‖² − R²)²)) / (2R²)`.
    pub fit_error_pct: f64,
    /// RMS of `‖W(m−c)‖ − R`, raw units.
    pub rms_radius_error: f64,
}

impl MagFitReport {
    fn new(model: MagModel, samples: usize, fit: &MagFit, pct: f32, rms: f32) -> Self {
        let w = fit.matrix.map(|r| r.map(f64::from));
        Self {
            model: model.name().to_string(),
            samples,
            center: fit.center.map(f64::from),
            matrix: w,
            radius: f64::from(fit.radius),
            fit_error_pct: f64::from(pct),
            rms_radius_error: f64::from(rms),
        }
    }
}

/// Fits `points` (raw magnetometer samples, any consistent unit) with `model` using the
/// core's streaming `f32` accumulator, then computes the fit quality over the same points.
///
/// Errors (readable messages wrapping [`wiical_core::Error`]): no points, a point that is
/// not finite or not representable in `f32`, fewer points than the model's parameters,
/// degenerate coverage (points on a plane, line or single spot), or a fitted surface that
/// is not an ellipsoid.
pub fn fit_points(points: &[[f64; 3]], model: MagModel) -> Result<MagFitReport> {
    let mut fold = FitFold::new(model);
    points.iter().for_each(|p| fold.push(p));
    let fit = fold.solve()?;
    let mut quality = QualityFold::new(fit);
    points.iter().for_each(|p| quality.push(p));
    quality.report(model, points.len())
}

/// The core's accumulator of one model.
#[derive(Debug, Clone)]
enum Acc {
    Sphere(SphereFit),
    Axis(AxisEllipsoidFit),
    Ellipsoid(EllipsoidFit),
}

impl Acc {
    fn push(&mut self, p: [f32; 3]) -> Result<(), wiical_core::Error> {
        match self {
            Acc::Sphere(f) => f.push(p),
            Acc::Axis(f) => f.push(p),
            Acc::Ellipsoid(f) => f.push(p),
        }
    }

    fn solve(&self) -> Result<MagFit, wiical_core::Error> {
        match self {
            Acc::Sphere(f) => f.solve(),
            Acc::Axis(f) => f.solve(),
            Acc::Ellipsoid(f) => f.solve(),
        }
    }
}

/// The fit's accumulator fed one point at a time in file order (what [`fit_points`] does
/// with a slice, and [`super::pass`] with a recording's rows): each point converted to the
/// core's `f32`; the first one that is not finite there, or the first the core refuses,
/// ends the accumulation and is the error [`FitFold::solve`] gives.
#[derive(Debug)]
pub struct FitFold {
    model: MagModel,
    acc: Acc,
    n: usize,
    not_f32: Option<MagnetometerError>,
    refused: Option<wiical_core::Error>,
}

impl FitFold {
    /// An empty accumulator of `model`.
    pub fn new(model: MagModel) -> Self {
        let acc = match model {
            MagModel::Sphere => Acc::Sphere(SphereFit::default()),
            MagModel::Axis => Acc::Axis(AxisEllipsoidFit::default()),
            MagModel::Ellipsoid => Acc::Ellipsoid(EllipsoidFit::default()),
        };
        Self {
            model,
            acc,
            n: 0,
            not_f32: None,
            refused: None,
        }
    }

    /// The next point.
    pub fn push(&mut self, p: &[f64; 3]) {
        self.n += 1;
        if self.not_f32.is_some() {
            return;
        }
        let q = p.map(|v| v as f32);
        if !q.iter().all(|v| v.is_finite()) {
            self.not_f32 = Some(MagnetometerError::MagSampleNotF32 {
                index: self.n,
                x: p[0],
                y: p[1],
                z: p[2],
            });
            return;
        }
        if self.refused.is_none() {
            if let Err(e) = self.acc.push(q) {
                self.refused = Some(e);
            }
        }
    }

    /// The fit, or why not: no points, the first point not finite in `f32` (1-based), the
    /// core's refusal.
    pub fn solve(self) -> Result<MagFit> {
        if self.n == 0 {
            return Err(MagnetometerError::NoMagSamples);
        }
        if let Some(e) = self.not_f32 {
            return Err(e);
        }
        let (model, n) = (self.model, self.n);
        self.refused
            .map_or_else(|| self.acc.solve(), Err)
            .map_err(|source| MagnetometerError::MagFit {
                context: format!("{model} fit of {n} samples failed{}", hint(source)),
                source,
            })
    }
}

/// The fit's quality ([`ResidualAccumulator`]) fed one point at a time; the first point it
/// refuses is the error [`QualityFold::report`] gives.
#[derive(Debug)]
pub struct QualityFold {
    fit: MagFit,
    acc: ResidualAccumulator,
    n: usize,
    refused: Option<MagnetometerError>,
}

impl QualityFold {
    /// An empty accumulator for `fit`.
    pub fn new(fit: MagFit) -> Self {
        Self {
            acc: ResidualAccumulator::new(fit),
            fit,
            n: 0,
            refused: None,
        }
    }

    /// The next point (as the fit took it: converted to `f32`).
    pub fn push(&mut self, p: &[f64; 3]) {
        self.n += 1;
        if self.refused.is_some() {
            return;
        }
        if let Err(source) = self.acc.push(p.map(|v| v as f32)) {
            self.refused = Some(MagnetometerError::MagFit {
                context: format!("fit quality: sample {}", self.n),
                source,
            });
        }
    }

    /// The report of `samples` points fitted with `model`.
    pub fn report(self, model: MagModel, samples: usize) -> Result<MagFitReport> {
        if let Some(e) = self.refused {
            return Err(e);
        }
        let q = self
            .acc
            .finish()
            .map_err(|source| MagnetometerError::MagFit {
                context: "fit quality".into(),
                source,
            })?;
        Ok(MagFitReport::new(
            model,
            samples,
            &self.fit,
            q.fit_error_pct,
            q.rms_radius_error,
        ))
    }
}

/// What the user can do about a core error.
fn hint(e: wiical_core::Error) -> &'static str {
    use wiical_core::Error as E;
    match e {
        E::DegenerateGeometry => {
            " (the samples lie on a plane, a line or one spot: rotate the sensor through all \
             orientations)"
        }
        E::NotAnEllipsoid => {
            " (the samples do not look like an ellipsoid: check for outliers, a changing \
             field, or too little rotation; a simpler model may help)"
        }
        _ => "",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Simulated points and the truth they were made from.
    struct Sim {
        pts: Vec<[f64; 3]>,
        c: [f64; 3],
        w: [[f64; 3]; 3],
        r: f64,
    }

    /// Noise-free points on a rotated ellipsoid with a large hard-iron offset, by a
    /// deterministic spiral (Fibonacci) covering of the sphere: `m = c + W⁻¹·(R·n̂)`.
    fn ellipsoid_points(n: usize) -> Sim {
        let c = [6135.0, -249.0, 3443.0];
        let r = 1100.0;
        // W = Rz(0.5)·diag(0.7, 1.0, 1/0.7)·Rz(0.5)ᵀ (det 1); its inverse uses 1/diag.
        let (s, co) = (0.5f64.sin(), 0.5f64.cos());
        let rot = [[co, -s, 0.0], [s, co, 0.0], [0.0, 0.0, 1.0]];
        let d = [0.7, 1.0, 1.0 / 0.7];
        let sym = |diag: [f64; 3]| {
            let mut m = [[0.0; 3]; 3];
            for (i, row) in m.iter_mut().enumerate() {
                for (j, v) in row.iter_mut().enumerate() {
                    *v = (0..3).map(|k| rot[i][k] * diag[k] * rot[j][k]).sum();
                }
            }
            m
        };
        let w = sym(d);
        let winv = sym(d.map(|x| 1.0 / x));
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let pts = (0..n)
            .map(|k| {
                let z = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
                let rho = (1.0 - z * z).sqrt();
                let t = golden * k as f64;
                let v = [r * rho * t.cos(), r * rho * t.sin(), r * z];
                let mut m = c;
                for (i, mi) in m.iter_mut().enumerate() {
                    *mi += (0..3).map(|k| winv[i][k] * v[k]).sum::<f64>();
                }
                m
            })
            .collect();
        Sim { pts, c, w, r }
    }

    #[test]
    fn model_names_parse() {
        for m in MagModel::ALL {
            assert_eq!(m.name().parse::<MagModel>(), Ok(m));
            assert_eq!(m.to_string(), m.name());
        }
        assert_eq!(" Ellipsoid ".parse::<MagModel>(), Ok(MagModel::Ellipsoid));
        let err = "cube".parse::<MagModel>().unwrap_err();
        assert!(err.contains("cube") && err.contains("ellipsoid"), "{err}");
    }

    #[test]
    fn ellipsoid_fit_recovers_simulated_truth() {
        let Sim { pts, c, w, r } = ellipsoid_points(500);
        let rep = fit_points(&pts, MagModel::Ellipsoid).unwrap();
        assert_eq!(rep.model, "ellipsoid");
        assert_eq!(rep.samples, 500);
        for (got, want) in rep.center.iter().zip(c) {
            assert!((got - want).abs() < 1e-4 * r, "{rep:?}");
        }
        for (got, want) in rep.matrix.iter().flatten().zip(w.iter().flatten()) {
            assert!((got - want).abs() < 1e-4, "{rep:?}");
        }
        assert!((rep.radius - r).abs() < 1e-4 * r, "{rep:?}");
        // Noise-free: only f32 rounding remains.
        assert!(
            rep.fit_error_pct < 1e-3 && rep.rms_radius_error < 0.05,
            "{rep:?}"
        );
        let json = serde_json::to_value(&rep).unwrap();
        assert_eq!(json["model"], "ellipsoid");
        assert_eq!(json["matrix"].as_array().unwrap().len(), 3);
    }

    #[test]
    fn simpler_models_fit_worse_on_a_rotated_ellipsoid() {
        let Sim { pts, r, .. } = ellipsoid_points(500);
        let reps: Vec<MagFitReport> = MagModel::ALL
            .iter()
            .map(|m| fit_points(&pts, *m).unwrap())
            .collect();
        // Semi-axes 0.7R..1.43R: a sphere leaves residuals of tens of % of R.
        assert!(reps[0].fit_error_pct > 10.0, "{:?}", reps[0]);
        assert!(reps[0].fit_error_pct > reps[1].fit_error_pct);
        assert!(reps[1].fit_error_pct > 100.0 * reps[2].fit_error_pct);
        assert_eq!(
            reps[0].matrix,
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        );
        assert!(reps[2].rms_radius_error < 1e-4 * r);
    }

    #[test]
    fn errors_are_readable() {
        let msg = |pts: &[[f64; 3]], m| {
            crate::Error::from(fit_points(pts, m).unwrap_err()).full_message()
        };
        assert!(msg(&[], MagModel::Sphere).contains("no samples"));

        let mut pts = ellipsoid_points(50).pts;
        pts[7][1] = f64::NAN;
        let e = msg(&pts, MagModel::Ellipsoid);
        assert!(e.contains("sample 8"), "{e}");
        pts[7][1] = 1e300; // finite in f64, infinite in f32
        assert!(msg(&pts, MagModel::Ellipsoid).contains("sample 8"));

        let e = msg(&pts[..5], MagModel::Axis);
        assert!(e.contains("too few samples") && e.contains("6"), "{e}");

        let planar: Vec<[f64; 3]> = (0..100)
            .map(|k| {
                let t = k as f64 * 0.1;
                [100.0 + 50.0 * t.cos(), 50.0 * t.sin(), 7.0]
            })
            .collect();
        for m in MagModel::ALL {
            let e = msg(&planar, m);
            assert!(e.contains("plane") && e.contains(m.name()), "{e}");
        }
    }
}

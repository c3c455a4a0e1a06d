//! Magnetometers: the hard/soft-iron fit of `wiical magfit` (`fit`, on the core's streaming
//! `f32` fits) and the residual loop around it, as `analyze` has for the accelerometer: a
//! noise floor measured from the data (`floor`), the fit's residual linearised with every
//! candidate's columns (`design`, `candidates`), candidates accepted by F and held-out
//! error (`search`) with a detection limit for each one not accepted, and a verdict
//! (`verdict`) in `analyze`'s contract shape (`contract`). One code reads a held
//! recording and a large file alike, in passes over its rows ([`pass`]).
//!
//! **Detection limits.** For a candidate not accepted at the last step, the magnitude it
//! would need to pass both rules there: the extra residual sum of squares it must explain is
//! the larger of `q·F_crit·s²` (its F-test at the step's level, `s²` the reference variance)
//! and `(CV_FACTOR² − 1)·cv²·n` (the held-out RMS divided by the factor); a centre effect `k`
//! explains `kᵀ·S·k` (`S` the Schur complement of its columns against the model), so the
//! limit is `√(need/λ_min(S))`, the worst direction; for a scanned step the worst position.
//! Shape is measured as the RMS it adds, `√(need/n)`.

pub(crate) mod candidates;
pub(crate) mod contract;
pub(crate) mod design;
pub(crate) mod fit;
pub(crate) mod floor;
pub(crate) mod model;
pub mod pass;
pub(crate) mod request;
pub(crate) mod search;
pub(crate) mod verdict;

pub use crate::error::magnetometer::MagnetometerError;
pub use contract::{MagAnalysis, MagCandidate, MagEffect, MagModelSummary, MagStep};
pub use fit::{fit_points, MagFitReport};
pub use model::MagModel;
pub use pass::{analyze_source, fit_source, Follow, Prepared};

use design::{Fit, Shape};

/// An `interference:<column>` effect a first pass accepted: the centre moves by
/// `k·(g − mean)` with the followed column `g`.
///
/// Why a second pass: the loop's columns are a linearisation about the base fit, which the
/// core made without the column, and the directions `n̂` are taken at samples that still hold
/// the moved centre; when the centre moves far (10 % of the field) that cost the coefficient
/// a bias of 10 standard errors (docs/magnetometer.md). The second pass is one Gauss–Newton
/// step about the first pass's estimate: the base refitted on the samples with the shift
/// taken out, each sample's geometry at its shifted place, and the shift's own linear term
/// added back to the residual, so the loop fits the whole `k` again with the right `n̂`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct KnownShift {
    /// The column's index among the followed columns.
    pub column: usize,
    /// The column's mean (the loop's column is `g − mean`).
    pub mean: f64,
    /// The first pass's coefficient per axis, field unit per column unit.
    pub k: [f64; 3],
}

impl KnownShift {
    /// The column's centred value in `follow` (0 where it is missing or not finite: no
    /// shift, as the loop's own row has no value there either).
    fn x(&self, follow: &[f64]) -> f64 {
        let x = follow.get(self.column).map_or(0.0, |v| v - self.mean);
        if x.is_finite() {
            x
        } else {
            0.0
        }
    }
}

/// The accepted `interference:<column>` effects of `first` as shifts (`scalars`: the
/// candidates the pass was given, which hold each column's index and mean).
pub(crate) fn known_shifts(scalars: &[candidates::Scalar], first: &MagAnalysis) -> Vec<KnownShift> {
    first
        .effects
        .iter()
        .filter(|e| e.name.starts_with("interference:") && e.values.len() == 3)
        .filter_map(|e| {
            let s = scalars.iter().find(|s| s.name() == e.name)?;
            let (column, mean) = s.follow_column()?;
            Some(KnownShift {
                column,
                mean,
                k: [e.values[0], e.values[1], e.values[2]],
            })
        })
        .collect()
}

/// `m` with the `known` shifts taken out.
pub(crate) fn shifted(m: &[f64; 3], follow: &[f64], known: &[KnownShift]) -> [f64; 3] {
    let mut out = *m;
    for s in known {
        let x = s.x(follow);
        (0..3).for_each(|a| out[a] -= s.k[a] * x);
    }
    out
}

/// The loop's pass over the samples once the fit and the axes' noise are known: each
/// sample's geometry ([`design::geo`]) folded into the residual's floor, the coverage and the
/// blocks' normal equations, and dropped.
pub(crate) struct LoopPass<'r> {
    rep: &'r MagFitReport,
    sigma: [f64; 3],
    unit: String,
    n: usize,
    geo: floor::GeoFold,
    lay: candidates::LayoutFold,
    known: Vec<KnownShift>,
}

impl<'r> LoopPass<'r> {
    /// A pass over `n` samples around the fit `rep` (made with `model`), the axes' noise
    /// `sigma`, the candidates' `scalars`, the field's `unit`.
    pub fn new(
        rep: &'r MagFitReport,
        sigma: [f64; 3],
        scalars: Vec<candidates::Scalar>,
        model: MagModel,
        unit: &str,
        n: usize,
    ) -> Self {
        let shape = match model {
            MagModel::Sphere => Shape::Sphere,
            MagModel::Axis => Shape::Axis,
            MagModel::Ellipsoid => Shape::Ellipsoid,
        };
        Self {
            rep,
            sigma,
            unit: unit.to_string(),
            n,
            geo: floor::GeoFold::new(sigma),
            lay: candidates::LayoutFold::new(scalars, shape, unit, n),
            known: Vec::new(),
        }
    }

    /// The same pass about a first pass's estimate of the column-following effects
    /// ([`KnownShift`]: each sample's geometry at its shifted place, the shift's linear term
    /// added back to its residual).
    pub fn with_known(mut self, known: &[KnownShift]) -> Self {
        self.known = known.to_vec();
        self
    }

    /// The next sample `m`, its time (s, or the sample index), temperature (°C, `NaN`
    /// without a column) and the followed columns' values.
    pub fn push(&mut self, m: &[f64; 3], t: f64, temp: f64, follow: &[f64]) {
        let at = shifted(m, follow, &self.known);
        let mut g = design::geo(&at, &self.rep.center, &self.rep.matrix, self.rep.radius);
        for s in &self.known {
            // The loop's own column for this effect is `x·Wᵀn̂` ([`design::follow_row`]).
            let x = s.x(follow);
            g.res += x * (0..3).map(|a| g.grad[a] * s.k[a]).sum::<f64>();
        }
        self.geo.push(&g);
        self.lay.push(&g, t, temp, follow);
    }

    /// The search, the summaries and the verdict at family level `alpha`; `has_temp` and
    /// `has_follow` say whether a temperature column and `--follow` columns were there.
    pub fn finish(self, alpha: f64, has_temp: bool, has_follow: bool) -> MagAnalysis {
        let noise = self.geo.floor();
        let coverage = self.geo.coverage();
        let lay = self.lay.finish();
        let found = search::search(&lay, noise, alpha);
        let n = self.n;
        let base = summary(&found.base, n, noise);
        let final_model = summary(&found.last, n, noise);
        let (verdict, reasons) = verdict::verdict(&final_model, noise, coverage, &self.unit);
        let mut diagnostics = Vec::new();
        if !has_temp {
            diagnostics.push(
                "temperature not tested: the file has no temperature column (log one beside the \
                 field)"
                    .into(),
            );
        }
        if !has_follow {
            diagnostics.push(
                "interference not tested: no column named for it (give --follow current, \
                 throttle or pwm when the file logs one)"
                    .into(),
            );
        }
        MagAnalysis {
            noise_floor: noise,
            noise_floor_axes: self.sigma,
            coverage,
            base,
            effects: found.effects,
            final_model,
            steps: found.steps,
            verdict,
            reasons,
            diagnostics,
        }
    }
}

fn summary(f: &Fit, n: usize, floor: f64) -> MagModelSummary {
    let dof = n.saturating_sub(f.rank);
    let chi2 = if floor > 0.0 {
        f.rss / (floor * floor)
    } else {
        f64::INFINITY
    };
    MagModelSummary {
        params: f.rank,
        rms: (f.rss / n.max(1) as f64).sqrt(),
        cv_rms: f.cv,
        chi2,
        chi2_dof: dof,
        chi2_p: if dof > 0 {
            crate::stats::chi2_sf(chi2, dof as f64)
        } else {
            f64::NAN
        },
    }
}

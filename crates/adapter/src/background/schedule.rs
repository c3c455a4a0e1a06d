//! The fit cut into slices: each call of [`Job::slice`] does a bounded piece of work, so that
//! the caller can run one slice per Nunchuk report and never hold a report back.
//!
//! A job runs through these phases, one slice each unless said otherwise:
//! 1. **prepare**: the fresh bins are split into training bins and held-out bins (every
//!    `heldout_every`-th fresh bin, the choice rotating from one job to the next); the
//!    training bins' directions must satisfy the coverage rule;
//! 2. **model** (its own slice: a coverage check on the RP2040's soft float costs as much as
//!    a few bins of a pass): the model is the full one when the training directions also
//!    satisfy the stricter full-coverage rule, else bias + scale; the temperature slope is
//!    freed when every training bin has a temperature and they span enough degrees;
//! 3. **pass** (several slices of at most `bins_per_slice` bins): the normal equations at the
//!    current parameters;
//! 4. **solve**: a damped Gauss–Newton step (12×12 Cholesky), then back to 3, for
//!    `fit_iterations` steps or until a step raises the cost (it is then undone);
//! 5. **held out** (slices of at most `bins_per_slice` bins): the RMS residual of the
//!    candidate and of the live calibration on the held-out bins;
//! 6. **check**: the candidate calibration and the acceptance predicate.
//!
//! The grid must not change while a job runs (the caller defers moments that end meanwhile),
//! nor the live calibration (the caller drops the job).

use heapless::Vec;
use wiical_core::acceptance::{Acceptance, CoverageRule};
use wiical_core::{Calibration, Error};

use super::adopt::Refusal;
use super::fit::{self, BinData, FitModel, LiveModel, Normal, NP};
use super::grid::{Grid, BINS};

/// What the schedule reads from the settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JobSettings {
    /// Bins older than this (s of play) are left out.
    pub max_bin_age_s: u32,
    /// Rule the training bins must satisfy for a bias + scale fit.
    pub coverage: CoverageRule,
    /// Rule for the full 9-parameter fit.
    pub full_coverage: CoverageRule,
    /// Learn a bias temperature slope when the bins allow.
    pub learn_temperature: bool,
    /// Smallest spread of training-bin temperatures (max − min, °C) to free the slope.
    pub min_temp_span_c: f32,
    /// Every this-many-th fresh bin is held out (≥ 2).
    pub heldout_every: u8,
    /// Fewest held-out bins to judge a candidate.
    pub min_heldout: u8,
    /// Gauss–Newton steps.
    pub fit_iterations: u8,
    /// Levenberg damping added to the normal matrix's diagonal (relative).
    pub damping: f32,
    /// Most bins one slice processes.
    pub bins_per_slice: u8,
    /// The acceptance predicate.
    pub acceptance: Acceptance,
}

/// A candidate that passed the fit and the acceptance predicate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// The calibration.
    pub calibration: Calibration,
    /// Held-out RMS of ‖a‖ − 1 g under the candidate, g.
    pub candidate_g: f32,
    /// Held-out RMS under the live calibration, g.
    pub live_g: f32,
    /// Training RMS under the candidate, g.
    pub fit_rms_g: f32,
    /// The model fitted.
    pub model: FitModel,
    /// Whether a temperature slope was fitted.
    pub temperature: bool,
    /// Training and held-out bins.
    pub bins: (u8, u8),
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Prepare,
    Model,
    Pass { next: u8 },
    Solve,
    HeldOut { next: u8 },
    Check,
}

/// One fit in progress; see the module docs.
#[derive(Debug, Clone)]
pub struct Job {
    phase: Phase,
    rotation: u8,
    live: Option<LiveModel>,
    train: u64,
    held: u64,
    mask: [bool; NP],
    model: FitModel,
    theta_c: f32,
    params: [f32; NP],
    prev: Option<([f32; NP], f32)>,
    iteration: u8,
    normal: Normal,
    fit_rms: f32,
    held_sums: (f32, f32, u32),
    /// Bins processed by the latest slice (for tests and budgets).
    pub last_slice_bins: u8,
}

/// What a slice ended with. The candidate variant is large (a calibration), but the outcome
/// is returned by value once per slice and there is no heap to box it on.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Outcome {
    /// More slices to go.
    Continue,
    /// The job finished with a candidate.
    Candidate(Candidate),
    /// The job finished without one.
    Refused(Refusal),
}

impl Job {
    /// A job about to prepare; `rotation` picks which fresh bins are held out.
    pub fn new(rotation: u8) -> Self {
        Self {
            phase: Phase::Prepare,
            rotation,
            live: None,
            train: 0,
            held: 0,
            mask: [false; NP],
            model: FitModel::BiasScale,
            theta_c: 0.0,
            params: [0.0; NP],
            prev: None,
            iteration: 0,
            normal: Normal::default(),
            fit_rms: 0.0,
            held_sums: (0.0, 0.0, 0),
            last_slice_bins: 0,
        }
    }

    /// Runs one slice over the frozen `grid` with the unchanged `live` calibration.
    pub fn slice(
        &mut self,
        grid: &Grid,
        live: &Calibration,
        s: &JobSettings,
        now_s: u32,
    ) -> Outcome {
        self.last_slice_bins = 0;
        let r = match self.phase {
            Phase::Prepare => self.prepare(grid, live, s, now_s),
            Phase::Model => self.choose_model(grid, live, s),
            Phase::Pass { next } => self.pass(grid, s, next),
            Phase::Solve => self.solve(s),
            Phase::HeldOut { next } => self.held_out(grid, s, next),
            Phase::Check => return self.check(s),
        };
        match r {
            Ok(()) => Outcome::Continue,
            Err(why) => Outcome::Refused(why),
        }
    }

    fn prepare(
        &mut self,
        grid: &Grid,
        live: &Calibration,
        s: &JobSettings,
        now_s: u32,
    ) -> Result<(), Refusal> {
        let model = LiveModel::of(live).ok_or(Refusal::UnsupportedLive)?;
        let every = s.heldout_every.max(2);
        let mut rank = self.rotation;
        for (i, bin) in grid.bins().iter().enumerate() {
            if !bin.fresh(now_s, s.max_bin_age_s) {
                continue;
            }
            rank = rank.wrapping_add(1);
            if rank.is_multiple_of(every) {
                self.held |= 1 << i;
            } else {
                self.train |= 1 << i;
            }
        }
        s.coverage
            .check(&self.train_dirs(grid, live))
            .map_err(Refusal::Coverage)?;
        let held = self.held.count_ones() as u8;
        if held < s.min_heldout {
            return Err(Refusal::TooFewHeldOut {
                needed: s.min_heldout,
                got: held,
            });
        }
        self.live = Some(model);
        self.phase = Phase::Model;
        Ok(())
    }

    /// The training bins' directions under the live calibration.
    fn train_dirs(&self, grid: &Grid, live: &Calibration) -> Vec<[f32; 3], BINS> {
        let mut dirs = Vec::new();
        for (i, bin) in grid.bins().iter().enumerate() {
            if self.train & (1 << i) != 0 {
                // Capacity is BINS: cannot fail.
                let _ = dirs.push(live.correct_linear(bin.mean));
            }
        }
        dirs
    }

    fn choose_model(
        &mut self,
        grid: &Grid,
        live: &Calibration,
        s: &JobSettings,
    ) -> Result<(), Refusal> {
        let dirs = self.train_dirs(grid, live);
        let (mut tmin, mut tmax, mut tsum) = (f32::INFINITY, f32::NEG_INFINITY, 0.0f32);
        let mut all_temps = true;
        for (i, bin) in grid.bins().iter().enumerate() {
            if self.train & (1 << i) != 0 {
                let t = bin.temperature_c;
                all_temps &= t.is_finite();
                tmin = tmin.min(t);
                tmax = tmax.max(t);
                tsum += t;
            }
        }
        self.model = match s.full_coverage.check(&dirs) {
            Ok(()) => FitModel::Full,
            Err(_) => FitModel::BiasScale,
        };
        let temperature = s.learn_temperature && all_temps && tmax - tmin >= s.min_temp_span_c;
        self.theta_c = if all_temps {
            tsum / dirs.len() as f32
        } else {
            0.0
        };
        self.mask = fit::mask(self.model, temperature);
        self.phase = Phase::Pass { next: 0 };
        Ok(())
    }

    /// The bins of `set` from index `next` on, at most `bins_per_slice`, as the fit sees
    /// them; returns the index after the last one visited.
    fn each_bin(
        &mut self,
        grid: &Grid,
        set: u64,
        next: u8,
        s: &JobSettings,
        mut f: impl FnMut(&mut Self, &BinData),
    ) -> u8 {
        let Some(live) = self.live else {
            return BINS as u8;
        };
        let mut i = usize::from(next);
        let mut done = 0u8;
        while i < BINS && done < s.bins_per_slice.max(1) {
            if set & (1 << i) != 0 {
                let d = fit::bin_data(&grid.bins()[i], &live, self.theta_c);
                f(self, &d);
                done += 1;
            }
            i += 1;
        }
        self.last_slice_bins = done;
        i as u8
    }

    fn pass(&mut self, grid: &Grid, s: &JobSettings, next: u8) -> Result<(), Refusal> {
        let p = self.params;
        let end = self.each_bin(grid, self.train, next, s, |job, d| job.normal.add(&p, d));
        if usize::from(end) < BINS {
            self.phase = Phase::Pass { next: end };
            return Ok(());
        }
        let cost = self.normal.cost;
        if !cost.is_finite() {
            return Err(Refusal::Fit(Error::NonFinite));
        }
        match self.prev {
            // The last step raised the cost: undo it and stop.
            Some((prev, prev_cost)) if cost > prev_cost => {
                self.params = prev;
                self.fit_rms = libm::sqrtf(prev_cost / self.normal.n.max(1) as f32);
                self.phase = Phase::HeldOut { next: 0 };
            }
            _ if self.iteration >= s.fit_iterations => {
                self.fit_rms = self.normal.rms();
                self.phase = Phase::HeldOut { next: 0 };
            }
            _ => self.phase = Phase::Solve,
        }
        Ok(())
    }

    fn solve(&mut self, s: &JobSettings) -> Result<(), Refusal> {
        let step = self
            .normal
            .step(&self.mask, s.damping)
            .map_err(Refusal::Fit)?;
        self.prev = Some((self.params, self.normal.cost));
        for (p, d) in self.params.iter_mut().zip(step) {
            *p += d;
        }
        self.iteration += 1;
        self.normal = Normal::default();
        self.phase = Phase::Pass { next: 0 };
        Ok(())
    }

    fn held_out(&mut self, grid: &Grid, s: &JobSettings, next: u8) -> Result<(), Refusal> {
        let p = self.params;
        let end = self.each_bin(grid, self.held, next, s, |job, d| {
            let c = fit::residual(&p, d, None);
            let l = fit::residual(&[0.0; NP], d, None);
            job.held_sums.0 += c * c;
            job.held_sums.1 += l * l;
            job.held_sums.2 += 1;
        });
        self.phase = if usize::from(end) < BINS {
            Phase::HeldOut { next: end }
        } else {
            Phase::Check
        };
        Ok(())
    }

    fn check(&mut self, s: &JobSettings) -> Outcome {
        let Some(live) = self.live else {
            return Outcome::Refused(Refusal::Interrupted);
        };
        let Some(cal) = fit::compose(&live, &self.params, self.theta_c) else {
            return Outcome::Refused(Refusal::Fit(Error::Singular));
        };
        if let Err(r) = s.acceptance.check(&cal, Some(self.fit_rms)) {
            return Outcome::Refused(Refusal::Implausible(r));
        }
        let (c2, l2, n) = self.held_sums;
        let n = n.max(1) as f32;
        Outcome::Candidate(Candidate {
            calibration: cal,
            candidate_g: libm::sqrtf(c2 / n),
            live_g: libm::sqrtf(l2 / n),
            fit_rms_g: self.fit_rms,
            model: self.model,
            temperature: self.mask[9],
            bins: (self.train.count_ones() as u8, self.held.count_ones() as u8),
        })
    }
}

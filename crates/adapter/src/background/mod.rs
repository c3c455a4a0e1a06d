//! Background recalibration: the adapter keeps its accelerometer calibrated from the still
//! moments of ordinary play, without a C + Z session.
//!
//! The method is free-living autocalibration (van Hees et al. 2014, as in GGIR): whatever
//! orientations a player happens to leave the Nunchuk in, a still Nunchuk reads ‖a‖ = 1 g,
//! so still moments in enough orientations re-determine bias and scale. Here it runs on the
//! adapter itself, in real time, in fixed memory:
//!
//! 1. [`crate::still`]: every report goes through the core's static detector with the
//!    self-calibration's absolute stillness limit; each still moment that ends is one sample.
//! 2. [`grid`]: the moment is binned by orientation into a fixed grid over the sphere; a bin
//!    keeps exponentially weighted statistics (newest moments weigh more, so the grid
//!    follows drift) and the moment's temperature when the caller has one.
//! 3. [`schedule`] and [`fit`]: every [`BackgroundSettings::fit_interval_ms`] of play, when the
//!    fresh bins satisfy the coverage rule, a correction of the live calibration is fitted
//!    (bias + scale, the full 9 parameters when coverage allows, plus a bias-against-
//!    temperature slope when the temperatures span enough), one bounded slice per report.
//! 4. [`adopt`]: the candidate replaces the live calibration only if it passes the acceptance
//!    predicate and beats the live one on held-out bins by a margin, adoption is on, the live
//!    calibration is not a protected host upload, and the flash-write budget allows.
//!
//! The caller (the protocol's report loop) hands over each report with
//! [`Background::on_report`], stores what [`Background::pending_calibration`] returns through the
//! power-loss-safe store and answers with [`Background::committed`], and tells the machine
//! when the live calibration changed for another reason ([`Background::calibration_changed`])
//! or the Nunchuk went away ([`Background::on_unplug`]). Nothing changes the live calibration
//! except that commit, so a fit that is interrupted (unplug, power cut, a new calibration)
//! leaves the calibration as it was.
//!
//! Time is play time, counted in reports at the fixed poll rate; the clock and the
//! flash-write budget resume after a power cycle from the stored settings record
//! ([`Background::resume`]). The bins are the Nunchuk's: a different Nunchuk plugged in
//! ([`Background::on_plug_in`]) clears them.

pub mod adopt;
pub mod fit;
pub mod grid;
pub mod schedule;

pub use adopt::{BudgetRecord, LiveOrigin, Refusal};
pub use fit::FitModel;
pub use grid::{Grid, BINS};
pub use schedule::Candidate;

use wiical_core::acceptance::{Acceptance, CoverageGap, CoverageRule};
use wiical_core::static_detect::StaticDetectorConfig;
use wiical_core::Calibration;

use crate::still::StillFeed;
use adopt::{Budget, Policy};
use schedule::{Job, JobSettings, Outcome};

use crate::selfcal::SelfCalConfig;

/// Every setting of the background recalibration, as named fields (ArduPilot's
/// `CompassCalibrator` style). Seconds are of play; variances raw counts²; g for errors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BackgroundSettings {
    /// Reports per second (the clock).
    pub rate_hz: u32,
    /// Static detector settings (window ≤ [`crate::still::DETECTOR_CAPACITY`]).
    pub detector: StaticDetectorConfig,
    /// Largest per-axis variance of a still moment (the absolute stillness limit).
    pub max_still_variance: f32,
    /// Floor of a moment's weight in its bin (0 < w ≤ 1): how fast bins forget.
    pub newest_weight: f32,
    /// Bins not visited for this long are left out of fits.
    pub max_bin_age_s: u32,
    /// Coverage the training bins need for a bias + scale fit.
    pub coverage: CoverageRule,
    /// Coverage the training bins need for the full 9-parameter fit.
    pub full_coverage: CoverageRule,
    /// Learn a bias-against-temperature slope when the bins' temperatures allow.
    pub learn_temperature: bool,
    /// Smallest temperature span (°C) over the training bins to learn the slope.
    pub min_temp_span_c: f32,
    /// Every this-many-th fresh bin is held out of the fit to judge it.
    pub heldout_every: u8,
    /// Fewest held-out bins to judge a candidate.
    pub min_heldout: u8,
    /// Gauss–Newton steps per fit.
    pub fit_iterations: u8,
    /// Relative Levenberg damping of each step.
    pub damping: f32,
    /// Most bins processed per slice (per report).
    pub bins_per_slice: u8,
    /// Play milliseconds between fit attempts (counted in reports at `rate_hz`; at least one
    /// report).
    pub fit_interval_ms: u32,
    /// Held-out improvement a candidate needs, g.
    pub margin_g: f32,
    /// A candidate's held-out error must be at most this × the live one's.
    pub improvement_ratio: f32,
    /// What a candidate must pass.
    pub acceptance: Acceptance,
    /// Play seconds between commits (the flash-write budget).
    pub min_commit_interval_s: u32,
    /// Commits per 24 h of play (at most [`adopt::MAX_DAILY`]).
    pub max_commits_per_day: u8,
    /// Adopt better candidates (false: monitor only).
    pub adopt: bool,
    /// A calibration uploaded by the host may be replaced.
    pub replace_host: bool,
}

impl BackgroundSettings {
    /// Settings for a Nunchuk polled at `rate_hz`: the self-calibration's detector and
    /// stillness limit; bins forget with weight ½ and age out after 4 h; the default
    /// coverage rule for bias + scale, 18 bins spread ≥ 0.2 for the full model; the slope from
    /// a 4 °C span; every 4th bin held out, at least 4; 4 Gauss–Newton steps, 3 bins per slice
    /// (on the RP2040's soft float the worst poll period of a fit took 113 % of the 5 ms
    /// period with 6, 74 % with 3 and the model choice in its own slice);
    /// a fit every minute; adopt when 3 mg and 30 % better; the Nunchuk acceptance limits; at
    /// most one commit per 30 min and 8 per day; adoption on, host uploads kept.
    pub fn nunchuk(rate_hz: u32) -> Self {
        let sc = SelfCalConfig::nunchuk(rate_hz);
        Self {
            rate_hz: rate_hz.max(1),
            detector: sc.detector,
            max_still_variance: sc.max_pose_variance,
            newest_weight: 0.5,
            max_bin_age_s: 14_400,
            coverage: CoverageRule::default(),
            full_coverage: CoverageRule {
                min_poses: 18,
                min_axis_component: 0.5,
                min_spread: 0.2,
            },
            learn_temperature: true,
            min_temp_span_c: 4.0,
            heldout_every: 4,
            min_heldout: 4,
            fit_iterations: 4,
            damping: 1e-3,
            bins_per_slice: 3,
            fit_interval_ms: 60_000,
            margin_g: 0.0015,
            improvement_ratio: 0.7,
            acceptance: Acceptance::nunchuk(),
            min_commit_interval_s: 1800,
            max_commits_per_day: 8,
            adopt: true,
            replace_host: false,
        }
    }

    /// Reports between two fit attempts: [`BackgroundSettings::fit_interval_ms`] at
    /// [`BackgroundSettings::rate_hz`], at least one.
    fn fit_interval_reports(&self) -> u32 {
        let r = u64::from(self.fit_interval_ms) * u64::from(self.rate_hz.max(1)) / 1000;
        r.clamp(1, u64::from(u32::MAX)) as u32
    }

    fn job(&self) -> JobSettings {
        JobSettings {
            max_bin_age_s: self.max_bin_age_s,
            coverage: self.coverage,
            full_coverage: self.full_coverage,
            learn_temperature: self.learn_temperature,
            min_temp_span_c: self.min_temp_span_c,
            heldout_every: self.heldout_every,
            min_heldout: self.min_heldout,
            fit_iterations: self.fit_iterations,
            damping: self.damping,
            bins_per_slice: self.bins_per_slice,
            acceptance: self.acceptance,
        }
    }

    fn policy(&self) -> Policy {
        Policy {
            margin_g: self.margin_g,
            improvement_ratio: self.improvement_ratio,
            adopt: self.adopt,
            replace_host: self.replace_host,
            min_commit_interval_s: self.min_commit_interval_s,
            max_commits_per_day: self.max_commits_per_day,
        }
    }
}

/// What the machine is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BackgroundPhase {
    /// Binning still moments; a fit starts when one is due.
    Collecting,
    /// A fit is running, one slice per report.
    Fitting,
    /// A candidate was adopted and waits to be stored.
    Committing,
    /// The detector refused its settings: nothing is binned.
    Invalid,
}

/// The latest adoption.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Adoption {
    /// Play time of the commit, s.
    pub at_s: u32,
    /// Held-out RMS of ‖a‖ − 1 g before (the live calibration), g.
    pub before_g: f32,
    /// Held-out RMS under the adopted calibration, g.
    pub after_g: f32,
}

/// Everything a status report needs (the wire protocol will carry it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BackgroundStatus {
    /// The phase.
    pub phase: BackgroundPhase,
    /// Fresh bins (of [`BINS`]).
    pub bins_filled: u8,
    /// Still moments binned since power-up.
    pub moments: u32,
    /// The coverage gap at the last attempt (`None`: covered, or no attempt yet).
    pub coverage_gap: Option<CoverageGap>,
    /// The last candidate that passed the fit and acceptance.
    pub last_candidate: Option<Candidate>,
    /// The last adoption.
    pub last_adoption: Option<Adoption>,
    /// Why the last attempt did not adopt (`None` after an adoption).
    pub last_refusal: Option<Refusal>,
    /// Play time, s, on the clock that resumes across power cycles.
    pub play_s: u32,
    /// The play clock at this power-up, s (`play_s − power_up_s`: play since power-up).
    pub power_up_s: u32,
}

/// The background recalibration; see the module docs.
#[derive(Debug, Clone)]
pub struct Background {
    s: BackgroundSettings,
    feed: StillFeed,
    grid: Grid,
    job: Option<Job>,
    rotation: u8,
    budget: Budget,
    origin: LiveOrigin,
    ticks: u32,
    play_s: u32,
    /// Reports until the next fit attempt may start.
    attempt_wait: u32,
    moments_at_attempt: u32,
    deferred: Option<([f32; 3], Option<f32>)>,
    pending: Option<Candidate>,
    status: BackgroundStatus,
    max_slice_bins: u8,
    nunchuk: Option<[u8; 16]>,
}

impl Background {
    /// A machine with empty bins, the live calibration made by `origin`.
    pub fn new(settings: BackgroundSettings, origin: LiveOrigin) -> Self {
        let feed = StillFeed::new(settings.detector, settings.max_still_variance);
        let phase = if feed.valid() {
            BackgroundPhase::Collecting
        } else {
            BackgroundPhase::Invalid
        };
        Self {
            s: settings,
            feed,
            grid: Grid::default(),
            job: None,
            rotation: 0,
            budget: Budget::default(),
            origin,
            ticks: 0,
            play_s: 0,
            attempt_wait: settings.fit_interval_reports(),
            moments_at_attempt: 0,
            deferred: None,
            pending: None,
            status: BackgroundStatus {
                phase,
                bins_filled: 0,
                moments: 0,
                coverage_gap: None,
                last_candidate: None,
                last_adoption: None,
                last_refusal: None,
                play_s: 0,
                power_up_s: 0,
            },
            max_slice_bins: 0,
            nunchuk: None,
        }
    }

    /// Resumes the play clock and the flash-write budget from the stored record (at
    /// power-up, before any report): the clock goes on from the record's, and the commits it
    /// lists count against the budget as if no time had passed since it was written.
    pub fn resume(&mut self, record: &BudgetRecord) {
        self.budget = Budget::from_record(record);
        self.play_s = record.clock_s;
        self.status.power_up_s = record.clock_s;
        self.attempt_wait = self.s.fit_interval_reports();
    }

    /// The budget and the clock as a record to store now.
    pub fn budget_record(&self) -> BudgetRecord {
        self.budget.to_record(self.play_s)
    }

    /// As [`Background::budget_record`], with a commit now counted: stored *before* the
    /// adopted calibration, so that a power cut between the two writes leaves a budget that is
    /// stricter (a commit counted that did not happen), never looser.
    pub fn budget_record_committing(&self) -> BudgetRecord {
        let mut b = self.budget.clone();
        b.record(self.play_s);
        b.to_record(self.play_s)
    }

    /// A Nunchuk was initialised; `identity` is its factory calibration block (the extension
    /// bus's identifier is the same for every Nunchuk, the block differs from one to the
    /// next). A different Nunchuk than the last one clears the bins, whose moments were
    /// another sensor's; the same one plugged back keeps them.
    pub fn on_plug_in(&mut self, identity: [u8; 16]) {
        if self.nunchuk.is_some_and(|n| n != identity) {
            self.interrupt();
            self.grid = Grid::default();
            self.moments_at_attempt = 0;
        }
        self.nunchuk = Some(identity);
    }

    /// The settings.
    pub fn settings(&self) -> &BackgroundSettings {
        &self.s
    }

    /// Changes the settings (e.g. adoption on or off, the budget or the fit interval from the
    /// host); a running fit is dropped, the bins are kept, and a shorter fit interval takes
    /// effect from now (the next attempt comes no later than the new interval).
    pub fn set_settings(&mut self, settings: BackgroundSettings) {
        if self.job.take().is_some() {
            self.refuse(Refusal::Interrupted);
        }
        self.s = settings;
        self.attempt_wait = self.attempt_wait.min(settings.fit_interval_reports());
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The most bins any slice has processed so far (the per-report work bound).
    pub fn max_slice_bins(&self) -> u8 {
        self.max_slice_bins
    }

    /// The status.
    pub fn status(&self) -> BackgroundStatus {
        let mut st = self.status;
        st.phase = if !self.feed.valid() {
            BackgroundPhase::Invalid
        } else if self.pending.is_some() {
            BackgroundPhase::Committing
        } else if self.job.is_some() {
            BackgroundPhase::Fitting
        } else {
            BackgroundPhase::Collecting
        };
        st.bins_filled = self.grid.filled(self.play_s, self.s.max_bin_age_s);
        st.moments = self.grid.moments();
        st.play_s = self.play_s;
        st
    }

    /// Feeds one report: raw counts, the temperature at this time if the caller has one (°C),
    /// and the live calibration (unchanged while a fit runs, else tell
    /// [`Background::calibration_changed`]). Does at most one slice of fit work.
    pub fn on_report(&mut self, raw: [u16; 3], temperature_c: Option<f32>, live: &Calibration) {
        let moment = self.feed.push(raw).map(|m| m.mean);
        self.on_tick(moment, temperature_c, live);
    }

    /// One report whose stillness another feed judged (the adapter's report loop, where the
    /// self-calibration's [`StillFeed`] runs the one detector): the mean raw counts of the
    /// still moment this report ended, if any. Otherwise as [`Background::on_report`]: the
    /// clock moves one report and at most one slice of fit work is done.
    pub fn on_tick(
        &mut self,
        moment: Option<[f32; 3]>,
        temperature_c: Option<f32>,
        live: &Calibration,
    ) {
        self.tick();
        if let Some(mean) = moment {
            self.on_still_moment(mean, temperature_c, live);
        }
        if self.job.is_none() && self.pending.is_none() && self.due() {
            self.start_job();
            return;
        }
        self.run_slice(live);
    }

    /// A still moment found by another detector (mean raw counts, its temperature): binned
    /// like the ones [`Background::on_report`] finds (the caller's detector must apply the
    /// same absolute stillness limit). While a fit runs the grid is frozen, so the latest such
    /// moment waits until the fit ends.
    pub fn on_still_moment(
        &mut self,
        mean: [f32; 3],
        temperature_c: Option<f32>,
        live: &Calibration,
    ) {
        if self.job.is_some() {
            self.deferred = Some((mean, temperature_c));
        } else {
            self.bin(mean, temperature_c, live);
        }
    }

    /// Play time passed without reports (a replay of still windows recorded elsewhere, e.g.
    /// on the host): the clock moves on by `seconds`, and a fit that falls due runs to its end
    /// at once, all its slices in this call (no poll deadline to keep here).
    pub fn advance(&mut self, seconds: u32, live: &Calibration) {
        self.play_s = self.play_s.saturating_add(seconds);
        let reports = u64::from(seconds) * u64::from(self.s.rate_hz);
        self.attempt_wait = (u64::from(self.attempt_wait).saturating_sub(reports)) as u32;
        if self.job.is_none() && self.pending.is_none() && self.due() {
            self.start_job();
        }
        while self.job.is_some() {
            self.run_slice(live);
        }
    }

    fn start_job(&mut self) {
        self.rotation = self.rotation.wrapping_add(1);
        self.moments_at_attempt = self.grid.moments();
        self.attempt_wait = self.s.fit_interval_reports();
        self.job = Some(Job::new(self.rotation));
    }

    fn tick(&mut self) {
        self.attempt_wait = self.attempt_wait.saturating_sub(1);
        self.ticks += 1;
        if self.ticks >= self.s.rate_hz {
            self.ticks = 0;
            self.play_s = self.play_s.saturating_add(1);
        }
    }

    fn bin(&mut self, mean: [f32; 3], temperature_c: Option<f32>, live: &Calibration) {
        let (w, now) = (self.s.newest_weight, self.play_s);
        self.grid.add(mean, temperature_c, live, w, now);
    }

    fn due(&self) -> bool {
        self.feed.valid()
            && self.attempt_wait == 0
            && self.grid.moments() != self.moments_at_attempt
    }

    fn run_slice(&mut self, live: &Calibration) {
        let Some(job) = self.job.as_mut() else {
            return;
        };
        let outcome = job.slice(&self.grid, live, &self.s.job(), self.play_s);
        self.max_slice_bins = self.max_slice_bins.max(job.last_slice_bins);
        match outcome {
            Outcome::Continue => return,
            Outcome::Refused(why) => self.refuse(why),
            Outcome::Candidate(c) => self.consider(c),
        }
        self.job = None;
        if let Some((mean, t)) = self.deferred.take() {
            self.bin(mean, t, live);
        }
    }

    fn consider(&mut self, c: Candidate) {
        self.status.coverage_gap = None;
        self.status.last_candidate = Some(c);
        let policy = self.s.policy();
        match adopt::decide(
            &policy,
            &self.budget,
            self.origin,
            c.candidate_g,
            c.live_g,
            self.play_s,
        ) {
            Ok(()) => self.pending = Some(c),
            Err(why) => self.refuse(why),
        }
    }

    fn refuse(&mut self, why: Refusal) {
        if let Refusal::Coverage(gap) = why {
            self.status.coverage_gap = Some(gap);
        }
        self.status.last_refusal = Some(why);
    }

    /// The adopted calibration to store, if one waits (it keeps waiting, and this keeps
    /// returning it, until [`Background::committed`] answers or an interruption drops it).
    /// Until the caller has stored it the live calibration is the old one.
    pub fn pending_calibration(&self) -> Option<Calibration> {
        self.pending.map(|c| c.calibration)
    }

    /// The pending calibration was stored and is now live (`Ok`), or storing failed (`Err`:
    /// the old one stays live).
    pub fn committed(&mut self, stored: Result<(), ()>) {
        let Some(c) = self.pending.take() else {
            return;
        };
        match stored {
            Ok(()) => {
                self.budget.record(self.play_s);
                self.origin = LiveOrigin::Background;
                self.status.last_adoption = Some(Adoption {
                    at_s: self.play_s,
                    before_g: c.live_g,
                    after_g: c.candidate_g,
                });
                self.status.last_refusal = None;
            }
            Err(()) => self.refuse(Refusal::Storage),
        }
    }

    /// The live calibration changed for another reason (host upload, self-calibration,
    /// reset): a running fit or a waiting adoption is dropped; the bins, in raw counts, stay.
    pub fn calibration_changed(&mut self, origin: LiveOrigin) {
        self.origin = origin;
        self.interrupt();
    }

    /// Who made the live calibration, as the machine knows it.
    pub fn origin(&self) -> LiveOrigin {
        self.origin
    }

    /// A self-calibration session runs (call on every report it has): a running fit or a
    /// waiting adoption is dropped, the bins stay, and nothing is binned meanwhile.
    pub fn suspend(&mut self) {
        self.interrupt();
    }

    /// The Nunchuk went away (or a self-calibration session takes over): the fit and any
    /// waiting adoption are dropped and the detector starts over.
    pub fn on_unplug(&mut self) {
        self.interrupt();
        self.feed.restart();
    }

    fn interrupt(&mut self) {
        let running = self.job.take().is_some() || self.pending.take().is_some();
        self.deferred = None;
        if running {
            self.refuse(Refusal::Interrupted);
        }
    }
}

//! Self-calibration on the adapter (no PC), and the stale-calibration monitor.
//!
//! ## The user's side
//! 1. Plug the Nunchuk in with **C and Z held**, and keep holding them for
//!    [`SelfCalConfig::hold_samples`] reports (3 s at 200 Hz): the mode starts.
//! 2. Release the buttons, then hold the Nunchuk still in one orientation after another
//!    (resting it against a table edge, a book, a wall…). The status LED guides:
//!    [`SelfCalStatus::WaitingForStillness`] → [`SelfCalStatus::PoseTaken`] when a still
//!    moment of at least the detector's minimum length ended in a *new* orientation (more than
//!    [`SelfCalConfig::min_separation_rad`] from every pose taken), or
//!    [`SelfCalStatus::MoveToNewOrientation`] when it repeated one already taken.
//! 3. As soon as the poses satisfy the [`CoverageRule`] (enough of them, both signs on every
//!    axis, not all in one plane), the adapter fits the 9-parameter model
//!    ([`wiical_core::multipos`]) and checks it with the core's [`Acceptance`] predicate (the
//!    same one the host uses). Only a calibration that passes is committed, through the
//!    power-loss-safe store; the LED then shows [`SelfCalStatus::Done`]. Any failure (fit,
//!    plausibility, storage, timeout, unplug) shows [`SelfCalStatus::Failed`] and the old
//!    calibration stays live.
//! 4. Holding C and Z again for the hold time leaves the mode early (cancel): the session
//!    fails with the coverage gap that was still open, and nothing changes.
//!
//! Throughout, the Wii Remote keeps receiving reports corrected with the live calibration
//! (the session only observes the raw samples).
//!
//! ## Stillness
//! The core's [`StaticDetector`](wiical_core::static_detect::StaticDetector), through the
//! stillness rule shared with the background recalibration ([`StillFeed`]), finds still
//! moments. Its noise reference is the variance of
//! its first window; a hand that shakes while the detector starts would inflate it, so the
//! detector is restarted until that first window is itself still (every axis variance ≤
//! [`SelfCalConfig::max_pose_variance`]), and every still moment must meet the same
//! absolute limit to count. A shaking hand therefore yields no poses, not bad ones.
//!
//! ## Stale-calibration monitor
//! Outside a session the same detector watches the game: every still moment's mean,
//! corrected with the live calibration, should have ‖a‖ = 1 g. [`SelfCal::stale`] keeps an
//! exponentially weighted RMS of ‖a‖ − 1 g over those moments; past
//! [`SelfCalConfig::stale_threshold_g`] (after a few moments) it suggests recalibration.
//!
//! Time is counted in reports (the poll rate is fixed), so the logic needs no clock.

use heapless::Vec;
use wiical_core::acceptance::{angle_between, Acceptance, CoverageGap, CoverageRule, Rejection};
use wiical_core::multipos::{self, MultiPosConfig};
use wiical_core::static_detect::{StaticDetectorConfig, StaticInterval};
use wiical_core::Calibration;

use crate::still::StillFeed;

/// Most poses a session keeps (the coverage rule stops well before; a session that fills
/// this without meeting it fails).
pub const MAX_POSES: usize = 32;
/// Capacity of the static detector's sample ring (the window must fit); defined by the
/// stillness feed both sessions share.
pub use crate::still::DETECTOR_CAPACITY;

/// Settings of the self-calibration and the stale monitor. Counts of reports, raw counts²
/// for variances, radians for angles, g for accelerations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SelfCalConfig {
    /// C + Z held this many consecutive reports enters (right after plug-in) or leaves.
    pub hold_samples: u32,
    /// The hold that enters must start within this many reports after plug-in.
    pub entry_grace_samples: u32,
    /// Static detector settings (window ≤ [`DETECTOR_CAPACITY`]).
    pub detector: StaticDetectorConfig,
    /// Largest per-axis variance (raw counts²) of a still moment that counts as a pose.
    pub max_pose_variance: f32,
    /// A pose must be at least this far (radians) from every pose already taken.
    pub min_separation_rad: f32,
    /// When to stop collecting.
    pub coverage: CoverageRule,
    /// What a fitted calibration must pass to be committed.
    pub acceptance: Acceptance,
    /// A session that has not finished after this many reports fails.
    pub timeout_samples: u32,
    /// How long (reports) [`SelfCalStatus::PoseTaken`] / `MoveToNewOrientation` and the final
    /// `Done` / `Failed` are shown before the status moves on.
    pub show_samples: u32,
    /// Stale monitor: RMS of ‖a‖ − 1 g (g) beyond which recalibration is suggested.
    pub stale_threshold_g: f32,
    /// Stale monitor: still moments needed before the estimate is trusted.
    pub stale_min_moments: u32,
    /// Stale monitor: weight of the newest moment in the running mean square (0 < w ≤ 1).
    pub stale_weight: f32,
}

impl SelfCalConfig {
    /// Settings for a Nunchuk polled at `rate_hz` reports per second: 3 s hold within 1 s
    /// of plug-in; 0.2 s detector window, 1 s minimum still moment, variance ≤ 2 counts²
    /// (≈ 7 mg standard deviation at 200 counts/g); poses 20° apart; the default coverage
    /// rule; the Nunchuk acceptance limits; 5 min timeout; stale threshold 50 mg after 3
    /// moments.
    pub fn nunchuk(rate_hz: u32) -> Self {
        let r = rate_hz.max(10);
        let mut detector = StaticDetectorConfig::for_rate(r as f32, 0.2, 0.2, 1.0);
        detector.window = detector.window.min(DETECTOR_CAPACITY as u16 - 1) | 1;
        detector.init_samples = u32::from(detector.window);
        detector.min_variance = 0.25;
        Self {
            hold_samples: 3 * r,
            entry_grace_samples: r,
            detector,
            max_pose_variance: 2.0,
            min_separation_rad: 20f32.to_radians(),
            coverage: CoverageRule::default(),
            acceptance: Acceptance::nunchuk(),
            timeout_samples: 300 * r,
            show_samples: r,
            stale_threshold_g: 0.05,
            stale_min_moments: 3,
            stale_weight: 0.25,
        }
    }
}

/// Why a session ended without a new calibration (the old one stays live).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SelfCalFailure {
    /// Left by the user (C + Z held) before the poses covered the sphere: the gap left.
    Cancelled(CoverageGap),
    /// [`MAX_POSES`] poses taken and the coverage rule is still not met.
    Coverage(CoverageGap),
    /// The multi-position fit failed (e.g. degenerate geometry).
    Fit(wiical_core::Error),
    /// The fitted calibration is implausible.
    Implausible(Rejection),
    /// The session did not finish within [`SelfCalConfig::timeout_samples`].
    Timeout,
    /// The Nunchuk was unplugged during the session.
    Unplugged,
    /// Storing the calibration failed (the old one is still stored and live).
    Storage,
    /// The detector refused its settings (a configuration error).
    Config,
}

impl SelfCalFailure {
    /// A fixed English sentence per reason (no numbers): what the adapter sends to the host.
    /// Formatting the `f32`s of [`core::fmt::Display`] would cost the firmware ~10 KiB of
    /// float-printing code.
    pub const fn summary(&self) -> &'static str {
        use CoverageGap as G;
        match self {
            SelfCalFailure::Cancelled(G::TooFewPoses { .. }) => {
                "cancelled: fewer poses than the coverage rule needs"
            }
            SelfCalFailure::Cancelled(G::MissingDirection { .. }) => {
                "cancelled: some axis was never pointed up or down"
            }
            SelfCalFailure::Cancelled(_) => "cancelled: poses nearly in one plane",
            SelfCalFailure::Coverage(_) => "too many poses without covering the sphere",
            SelfCalFailure::Fit(_) => "the fit failed (degenerate poses)",
            SelfCalFailure::Implausible(Rejection::Offset { .. }) => {
                "fit refused: offset beyond the limit"
            }
            SelfCalFailure::Implausible(Rejection::Sensitivity { .. }) => {
                "fit refused: sensitivity outside 0.8-1.2 of nominal"
            }
            SelfCalFailure::Implausible(Rejection::FitRms { .. }) => {
                "fit refused: residual too large (moved during poses?)"
            }
            SelfCalFailure::Implausible(_) => "fit refused as implausible",
            SelfCalFailure::Timeout => "session timed out",
            SelfCalFailure::Unplugged => "Nunchuk unplugged during the session",
            SelfCalFailure::Storage => "storing the calibration failed",
            SelfCalFailure::Config => "invalid self-calibration settings",
        }
    }
}

impl core::fmt::Display for SelfCalFailure {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SelfCalFailure::Cancelled(gap) => write!(f, "cancelled before enough poses: {gap}"),
            SelfCalFailure::Coverage(gap) => write!(f, "poses do not cover the sphere: {gap}"),
            SelfCalFailure::Fit(e) => write!(f, "fit failed: {e}"),
            SelfCalFailure::Implausible(r) => write!(f, "fit refused: {r}"),
            SelfCalFailure::Timeout => f.write_str("session timed out"),
            SelfCalFailure::Unplugged => f.write_str("Nunchuk unplugged during the session"),
            SelfCalFailure::Storage => f.write_str("storing the calibration failed"),
            SelfCalFailure::Config => f.write_str("invalid self-calibration settings"),
        }
    }
}

/// The outcome of the last session.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SelfCalResult {
    /// Committed: the fitted calibration is stored and live.
    Done {
        /// Fit RMS of ‖a‖ − 1 g over the poses, g.
        rms_g: f32,
        /// Poses used.
        poses: u8,
    },
    /// Failed; the old calibration is unchanged.
    Failed(SelfCalFailure),
}

/// What the status LED shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SelfCalStatus {
    /// Not in the mode, no result to show.
    Off,
    /// C + Z held after plug-in: entering when the hold completes.
    Arming,
    /// In the mode: hold still in a new orientation.
    WaitingForStillness {
        /// Poses taken so far.
        poses: u8,
    },
    /// A pose was just taken.
    PoseTaken {
        /// Poses taken so far.
        poses: u8,
    },
    /// The still moment repeated an orientation already taken (or was not still enough).
    MoveToNewOrientation {
        /// Poses taken so far.
        poses: u8,
    },
    /// Fitted and accepted; being stored.
    Committing,
    /// The session succeeded (shown for a while after).
    Done,
    /// The session failed (shown for a while after).
    Failed(SelfCalFailure),
}

/// Running estimate of how far the live calibration is off, from still moments during play.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StaleEstimate {
    /// Still moments seen since the calibration changed.
    pub moments: u32,
    /// Exponentially weighted RMS of ‖a‖ − 1 g over them, g (0 before the first).
    pub rms_g: f32,
    /// ‖a‖ − 1 g of the latest moment, g.
    pub last_g: f32,
    /// True when enough moments were seen and the RMS is past the threshold.
    pub recalibration_suggested: bool,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    /// Normal play; `since_plug` counts reports since plug-in up to the grace limit.
    Normal,
    /// C + Z held since plug-in for `held` reports.
    Arming { held: u32 },
    /// In a session.
    Collecting,
    /// Fitted, waiting for [`SelfCal::take_pending`] and [`SelfCal::committed`].
    Committing,
}

/// The self-calibration state machine and the stale monitor; see the module docs.
#[derive(Debug, Clone)]
pub struct SelfCal {
    cfg: SelfCalConfig,
    mode: Mode,
    feed: StillFeed,
    since_plug: u32,
    session_samples: u32,
    /// The buttons were released since the session began (so a hold can end it).
    released: bool,
    exit_held: u32,
    poses: Vec<[f32; 3], MAX_POSES>,
    directions: Vec<[f32; 3], MAX_POSES>,
    status: SelfCalStatus,
    status_age: u32,
    pending: Option<(Calibration, f32)>,
    result: Option<SelfCalResult>,
    stale: StaleEstimate,
    /// The mean raw counts of the latest still moment of normal play, until taken.
    moment: Option<[f32; 3]>,
}

impl SelfCal {
    /// A state machine in normal mode.
    pub fn new(cfg: SelfCalConfig) -> Self {
        Self {
            cfg,
            mode: Mode::Normal,
            feed: StillFeed::new(cfg.detector, cfg.max_pose_variance),
            since_plug: u32::MAX,
            session_samples: 0,
            released: false,
            exit_held: 0,
            poses: Vec::new(),
            directions: Vec::new(),
            status: SelfCalStatus::Off,
            status_age: 0,
            pending: None,
            result: None,
            stale: StaleEstimate::default(),
            moment: None,
        }
    }

    /// The settings.
    pub fn config(&self) -> &SelfCalConfig {
        &self.cfg
    }

    /// A Nunchuk was (re)connected: the entry window opens.
    pub fn on_plug_in(&mut self) {
        self.since_plug = 0;
    }

    /// The Nunchuk went away: a running session fails.
    pub fn on_unplug(&mut self) {
        match self.mode {
            Mode::Collecting => self.fail(SelfCalFailure::Unplugged),
            Mode::Arming { .. } => {
                self.mode = Mode::Normal;
                self.set_status(SelfCalStatus::Off);
            }
            Mode::Normal | Mode::Committing => {}
        }
        self.since_plug = u32::MAX;
    }

    /// True while a session runs (collecting or committing).
    pub fn active(&self) -> bool {
        matches!(self.mode, Mode::Collecting | Mode::Committing)
    }

    /// What the LED should show.
    pub fn status(&self) -> SelfCalStatus {
        self.status
    }

    /// Poses taken in the current (or last) session.
    pub fn poses(&self) -> &[[f32; 3]] {
        &self.poses
    }

    /// The outcome of the last finished session.
    pub fn last_result(&self) -> Option<SelfCalResult> {
        self.result
    }

    /// The stale-calibration estimate.
    pub fn stale(&self) -> StaleEstimate {
        self.stale
    }

    /// The live calibration changed (upload or session): restart the stale estimate.
    pub fn calibration_changed(&mut self) {
        self.stale = StaleEstimate::default();
    }

    /// The calibration a finished session wants committed, with its fit RMS (g). The caller
    /// stores it and reports back with [`SelfCal::committed`].
    pub fn take_pending(&mut self) -> Option<(Calibration, f32)> {
        self.pending.take()
    }

    /// The caller stored (`Ok`) or failed to store (`Err`) the pending calibration.
    pub fn committed(&mut self, stored: Result<f32, ()>) {
        if self.mode != Mode::Committing {
            return;
        }
        match stored {
            Ok(rms_g) => {
                self.mode = Mode::Normal;
                self.result = Some(SelfCalResult::Done {
                    rms_g,
                    poses: self.poses.len() as u8,
                });
                self.set_status(SelfCalStatus::Done);
                self.calibration_changed();
                self.restart_detector();
            }
            Err(()) => self.fail(SelfCalFailure::Storage),
        }
    }

    /// Feed one Nunchuk report: raw counts, buttons, and the live calibration (used for pose
    /// directions and the stale monitor).
    pub fn on_report(&mut self, raw: [u16; 3], c: bool, z: bool, live: &Calibration) {
        let both = c && z;
        self.since_plug = self.since_plug.saturating_add(1);
        self.age_status();
        match self.mode {
            Mode::Normal => {
                if both && self.since_plug <= self.cfg.entry_grace_samples {
                    self.mode = Mode::Arming { held: 1 };
                    self.set_status(SelfCalStatus::Arming);
                } else {
                    self.watch(raw, live);
                }
            }
            Mode::Arming { held } => {
                if !both {
                    self.mode = Mode::Normal;
                    self.set_status(SelfCalStatus::Off);
                } else if held + 1 >= self.cfg.hold_samples {
                    self.start_session();
                } else {
                    self.mode = Mode::Arming { held: held + 1 };
                }
            }
            Mode::Collecting => self.collect(raw, both, live),
            Mode::Committing => {}
        }
    }

    fn start_session(&mut self) {
        self.mode = Mode::Collecting;
        self.poses.clear();
        self.directions.clear();
        self.session_samples = 0;
        self.released = false;
        self.exit_held = 0;
        self.pending = None;
        self.restart_detector();
        self.set_status(SelfCalStatus::WaitingForStillness { poses: 0 });
    }

    fn restart_detector(&mut self) {
        self.feed.restart();
    }

    /// The mean raw counts of the still moment of normal play (outside a session) that the
    /// latest report ended, if any: the stale monitor's moments, handed on to the background
    /// recalibration so that one detector serves both.
    pub fn take_still_moment(&mut self) -> Option<[f32; 3]> {
        self.moment.take()
    }

    fn collect(&mut self, raw: [u16; 3], both: bool, live: &Calibration) {
        self.session_samples = self.session_samples.saturating_add(1);
        if !both {
            self.released = true;
            self.exit_held = 0;
        } else if self.released {
            self.exit_held += 1;
            if self.exit_held >= self.cfg.hold_samples {
                let gap = match self.cfg.coverage.check(&self.directions) {
                    Err(gap) => gap,
                    // Covered but not yet fitted cannot happen (the fit runs at once).
                    Ok(()) => CoverageGap::BadDirection,
                };
                self.fail(SelfCalFailure::Cancelled(gap));
                return;
            }
        }
        if self.session_samples >= self.cfg.timeout_samples {
            self.fail(SelfCalFailure::Timeout);
            return;
        }
        let Some(interval) = self.detect(raw) else {
            return;
        };
        self.consider_pose(&interval, live);
    }

    /// Push a sample through the detector (the shared stillness rule, [`StillFeed`]); a
    /// still moment that just ended, if any.
    fn detect(&mut self, raw: [u16; 3]) -> Option<StaticInterval> {
        if !self.feed.valid() {
            if self.mode == Mode::Collecting {
                self.fail(SelfCalFailure::Config);
            }
            return None;
        }
        self.feed.push(raw)
    }

    fn consider_pose(&mut self, interval: &StaticInterval, live: &Calibration) {
        let n = self.poses.len() as u8;
        let direction = live.correct_linear(interval.mean);
        let new = self
            .directions
            .iter()
            .all(|d| angle_between(d, &direction) > self.cfg.min_separation_rad);
        if !new {
            self.set_status(SelfCalStatus::MoveToNewOrientation { poses: n });
            return;
        }
        if self.poses.push(interval.mean).is_err() || self.directions.push(direction).is_err() {
            // Unreachable in practice: the coverage check below runs after every pose.
            let gap = self.cfg.coverage.check(&self.directions).err();
            self.fail(SelfCalFailure::Coverage(
                gap.unwrap_or(CoverageGap::BadDirection),
            ));
            return;
        }
        let n = self.poses.len() as u8;
        self.set_status(SelfCalStatus::PoseTaken { poses: n });
        match self.cfg.coverage.check(&self.directions) {
            Ok(()) => self.fit_and_check(),
            Err(gap) if self.poses.is_full() => self.fail(SelfCalFailure::Coverage(gap)),
            Err(_) => {}
        }
    }

    fn fit_and_check(&mut self) {
        let fit = match multipos::fit(&self.poses, &MultiPosConfig::default()) {
            Ok(f) => f,
            Err(e) => return self.fail(SelfCalFailure::Fit(e)),
        };
        if let Err(r) = self.cfg.acceptance.check(&fit.calibration, Some(fit.rms)) {
            return self.fail(SelfCalFailure::Implausible(r));
        }
        self.pending = Some((fit.calibration, fit.rms));
        self.mode = Mode::Committing;
        self.set_status(SelfCalStatus::Committing);
    }

    fn fail(&mut self, why: SelfCalFailure) {
        self.mode = Mode::Normal;
        self.pending = None;
        self.result = Some(SelfCalResult::Failed(why));
        self.set_status(SelfCalStatus::Failed(why));
        self.restart_detector();
    }

    fn set_status(&mut self, s: SelfCalStatus) {
        self.status = s;
        self.status_age = 0;
    }

    /// Transient statuses fall back after [`SelfCalConfig::show_samples`] reports.
    fn age_status(&mut self) {
        self.status_age = self.status_age.saturating_add(1);
        if self.status_age < self.cfg.show_samples {
            return;
        }
        let next = match self.status {
            SelfCalStatus::PoseTaken { poses } | SelfCalStatus::MoveToNewOrientation { poses } => {
                SelfCalStatus::WaitingForStillness { poses }
            }
            SelfCalStatus::Done | SelfCalStatus::Failed(_) if self.mode == Mode::Normal => {
                SelfCalStatus::Off
            }
            other => other,
        };
        if next != self.status {
            self.set_status(next);
        }
    }

    /// Stale monitor (normal mode): every still moment updates the estimate.
    fn watch(&mut self, raw: [u16; 3], live: &Calibration) {
        self.moment = None;
        let Some(interval) = self.detect(raw) else {
            return;
        };
        self.moment = Some(interval.mean);
        let a = live.correct_linear(interval.mean);
        let err = libm::sqrtf(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) - 1.0;
        if !err.is_finite() {
            return;
        }
        let s = &mut self.stale;
        let w = if s.moments == 0 {
            1.0
        } else {
            self.cfg.stale_weight.clamp(f32::MIN_POSITIVE, 1.0)
        };
        let ms = s.rms_g * s.rms_g;
        s.rms_g = libm::sqrtf(ms + w * (err * err - ms));
        s.last_g = err;
        s.moments = s.moments.saturating_add(1);
        s.recalibration_suggested =
            s.moments >= self.cfg.stale_min_moments && s.rms_g > self.cfg.stale_threshold_g;
    }
}

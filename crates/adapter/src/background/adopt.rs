//! Whether a fitted candidate replaces the live calibration: the held-out comparison with its
//! hysteresis, who made the live calibration, and the flash-write budget.
//!
//! The rules, in the order they are applied (the first that fails is the reason reported):
//! 1. the candidate must beat the live calibration on the held-out bins by
//!    [`super::BackgroundSettings::margin_g`] *and* by the factor
//!    [`super::BackgroundSettings::improvement_ratio`] — a margin, not just "lower", so that
//!    two calibrations within the noise of each other never replace one another (no
//!    ping-pong: after an adoption the live calibration is the one at the floor, and a
//!    candidate from the same bins cannot beat it by the margin);
//! 2. adoption must be on ([`super::BackgroundSettings::adopt`]; off leaves the monitor);
//! 3. a calibration uploaded by the host is replaced only when
//!    [`super::BackgroundSettings::replace_host`] allows it;
//! 4. the flash-write budget: at most one commit per
//!    [`super::BackgroundSettings::min_commit_interval_s`] of play and at most
//!    [`super::BackgroundSettings::max_commits_per_day`] per 24 h of play.
//!
//! Time is play time (seconds of reports): the adapter has no clock. The budget's commit
//! times and the play clock are stored with the settings record ([`BudgetRecord`]), and the
//! clock resumes at power-up from the value stored last: play between that write and the
//! power-off is not counted, so a power cycle can only make the budget stricter, never reset
//! it.

use wiical_core::acceptance::{CoverageGap, Rejection};

/// Most commit times the budget remembers (caps `max_commits_per_day`).
pub const MAX_DAILY: usize = 16;

/// Seconds in the budget's day.
pub const DAY_S: u32 = 86_400;

/// Who made the live calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LiveOrigin {
    /// No user calibration: the Nunchuk's factory block (or the nominal one).
    Factory,
    /// The C + Z self-calibration session.
    SelfCal,
    /// An earlier background adoption.
    Background,
    /// Uploaded by the host.
    Host,
}

/// Why the last candidate (or attempt) did not become the live calibration. Numbers in g.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Refusal {
    /// The fresh training bins do not satisfy the coverage rule: the gap.
    Coverage(CoverageGap),
    /// Fewer held-out bins than needed to judge a candidate.
    TooFewHeldOut {
        /// Needed.
        needed: u8,
        /// Present.
        got: u8,
    },
    /// The fit failed (e.g. a parameter the bins do not determine).
    Fit(wiical_core::Error),
    /// The candidate failed the acceptance predicate.
    Implausible(Rejection),
    /// The candidate is not better than the live calibration on the held-out bins by the
    /// margin and ratio.
    NotBetter {
        /// Candidate's held-out RMS of ‖a‖ − 1 g.
        candidate_g: f32,
        /// Live calibration's held-out RMS.
        live_g: f32,
    },
    /// Better, but adoption is off (monitor only).
    MonitorOnly {
        /// Candidate's held-out RMS.
        candidate_g: f32,
        /// Live calibration's held-out RMS.
        live_g: f32,
    },
    /// Better, but the live calibration was uploaded by the host and may not be replaced.
    HostCalibration,
    /// Better, but the flash-write budget is spent: play seconds until the next commit.
    Budget {
        /// Seconds of play until a commit is allowed again.
        wait_s: u32,
    },
    /// The live calibration has effect terms beyond a bias temperature slope, which the
    /// background fit cannot carry over.
    UnsupportedLive,
    /// The fit was abandoned: the live calibration changed, the Nunchuk was unplugged, or a
    /// self-calibration session began.
    Interrupted,
    /// Storing the adopted calibration failed (the old one is still live).
    Storage,
}

impl Refusal {
    /// A fixed English sentence per reason (no numbers, as the self-calibration's failures:
    /// no float formatting in the firmware).
    pub const fn summary(&self) -> &'static str {
        match self {
            Refusal::Coverage(_) => "the still moments do not cover the sphere yet",
            Refusal::TooFewHeldOut { .. } => "too few held-out bins to judge a candidate",
            Refusal::Fit(_) => "the background fit failed",
            Refusal::Implausible(_) => "the candidate failed the acceptance limits",
            Refusal::NotBetter { .. } => "the candidate is not better than the live one",
            Refusal::MonitorOnly { .. } => "better candidate found; adoption is off",
            Refusal::HostCalibration => "better candidate found; host calibration kept",
            Refusal::Budget { .. } => "better candidate found; flash-write budget spent",
            Refusal::UnsupportedLive => "the live calibration has terms the fit cannot keep",
            Refusal::Interrupted => "the fit was interrupted",
            Refusal::Storage => "storing the adopted calibration failed",
        }
    }
}

/// The settings the policy reads (a view of the background settings).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Policy {
    /// Held-out improvement needed, g.
    pub margin_g: f32,
    /// Candidate held-out error must be at most this × the live one.
    pub improvement_ratio: f32,
    /// Adoption on.
    pub adopt: bool,
    /// A host calibration may be replaced.
    pub replace_host: bool,
    /// Play seconds between commits.
    pub min_commit_interval_s: u32,
    /// Commits per 24 h of play.
    pub max_commits_per_day: u8,
}

/// Commit times (play seconds) for the budget.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Budget {
    times: heapless::HistoryBuf<u32, MAX_DAILY>,
}

/// The budget as stored with the settings record: the play clock when the record was written
/// and the commit times on that clock (the last [`MAX_DAILY`], oldest first).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BudgetRecord {
    /// Play seconds when the record was written; the clock resumes here at power-up.
    pub clock_s: u32,
    /// Commit times, play seconds; the first `count` are valid, oldest first.
    pub commits: [u32; MAX_DAILY],
    /// Valid entries of `commits`.
    pub count: u8,
}

impl BudgetRecord {
    /// The valid commit times, oldest first.
    pub fn commits(&self) -> &[u32] {
        &self.commits[..usize::from(self.count).min(MAX_DAILY)]
    }
}

impl Budget {
    /// The budget a [`BudgetRecord`] describes.
    pub fn from_record(record: &BudgetRecord) -> Self {
        let mut b = Self::default();
        for &t in record.commits() {
            b.record(t);
        }
        b
    }

    /// This budget as a record written at play time `clock_s`.
    pub fn to_record(&self, clock_s: u32) -> BudgetRecord {
        let mut r = BudgetRecord {
            clock_s,
            ..BudgetRecord::default()
        };
        for (slot, &t) in r.commits.iter_mut().zip(self.times.oldest_ordered()) {
            *slot = t;
            r.count += 1;
        }
        r
    }

    /// Records a commit at `now_s`.
    pub fn record(&mut self, now_s: u32) {
        self.times.write(now_s);
    }

    /// The latest commit, if any.
    pub fn last(&self) -> Option<u32> {
        self.times.recent().copied()
    }

    /// Seconds until a commit is allowed at `now_s` (0: allowed now).
    pub fn wait_s(&self, policy: &Policy, now_s: u32) -> u32 {
        let interval = self.last().map_or(0, |t| {
            (t.saturating_add(policy.min_commit_interval_s)).saturating_sub(now_s)
        });
        let cap = usize::from(policy.max_commits_per_day).min(MAX_DAILY);
        if cap == 0 {
            return u32::MAX;
        }
        // Commits within the last day, oldest first: the day allows another once fewer than
        // `cap` remain, i.e. once the (within − cap)-th oldest has left it.
        let in_day = || {
            self.times
                .oldest_ordered()
                .filter(move |t| now_s.saturating_sub(**t) < DAY_S)
        };
        let within = in_day().count();
        let day = if within < cap {
            0
        } else {
            in_day()
                .nth(within - cap)
                .map_or(0, |t| t.saturating_add(DAY_S).saturating_sub(now_s))
        };
        interval.max(day)
    }
}

/// Applies the rules of the module docs to a candidate with held-out errors
/// `candidate_g` and `live_g`.
pub fn decide(
    policy: &Policy,
    budget: &Budget,
    origin: LiveOrigin,
    candidate_g: f32,
    live_g: f32,
    now_s: u32,
) -> Result<(), Refusal> {
    let better = candidate_g.is_finite()
        && live_g.is_finite()
        && candidate_g + policy.margin_g <= live_g
        && candidate_g <= policy.improvement_ratio * live_g;
    if !better {
        return Err(Refusal::NotBetter {
            candidate_g,
            live_g,
        });
    }
    if !policy.adopt {
        return Err(Refusal::MonitorOnly {
            candidate_g,
            live_g,
        });
    }
    if origin == LiveOrigin::Host && !policy.replace_host {
        return Err(Refusal::HostCalibration);
    }
    match budget.wait_s(policy, now_s) {
        0 => Ok(()),
        wait_s => Err(Refusal::Budget { wait_s }),
    }
}

//! The background recalibration's state in its wire form ([`BackgroundReport`]).

use embedded_storage_async::nor_flash::NorFlash;
use wiical_core::acceptance::CoverageGap;
use wiical_wire::{
    AdoptionReport, BackgroundPhase as WirePhase, BackgroundReport, BackgroundSettings,
    CalibrationOrigin, CandidateReport, CoverageGapReport, RefusalReport, BACKGROUND_BINS,
};

use super::Protocol;
use crate::background::{BackgroundPhase, FitModel, LiveOrigin, Refusal, BINS};

// The wire's bin list has one entry per grid bin.
const _: () = assert!(BINS == BACKGROUND_BINS && BINS <= 64);

/// g → mg, the unit of every error on the wire.
fn mg(g: f32) -> f32 {
    g * 1000.0
}

fn gap(g: CoverageGap) -> CoverageGapReport {
    let sat = |n: u32| n.min(255) as u8;
    match g {
        CoverageGap::TooFewPoses { needed, got } => CoverageGapReport::TooFewBins {
            needed: sat(needed),
            got: sat(got),
        },
        CoverageGap::MissingDirection { axis, positive } => CoverageGapReport::MissingDirection {
            axis: axis.min(2) as u8,
            positive,
        },
        CoverageGap::Flat { .. } => CoverageGapReport::Flat,
        CoverageGap::BadDirection => CoverageGapReport::BadDirection,
    }
}

/// The wire form of a refusal.
pub fn refusal(r: Refusal) -> RefusalReport {
    match r {
        Refusal::Coverage(g) => RefusalReport::Coverage(gap(g)),
        Refusal::TooFewHeldOut { needed, got } => RefusalReport::TooFewHeldOut { needed, got },
        Refusal::Fit(_) => RefusalReport::Fit,
        Refusal::Implausible(_) => RefusalReport::Implausible,
        Refusal::NotBetter {
            candidate_g,
            live_g,
        } => RefusalReport::NotBetter {
            candidate_mg: mg(candidate_g),
            live_mg: mg(live_g),
        },
        Refusal::MonitorOnly {
            candidate_g,
            live_g,
        } => RefusalReport::MonitorOnly {
            candidate_mg: mg(candidate_g),
            live_mg: mg(live_g),
        },
        Refusal::HostCalibration => RefusalReport::HostCalibration,
        Refusal::Budget { wait_s } => RefusalReport::Budget { wait_s },
        Refusal::UnsupportedLive => RefusalReport::UnsupportedLive,
        Refusal::Interrupted => RefusalReport::Interrupted,
        Refusal::Storage => RefusalReport::Storage,
    }
}

/// The wire form of an origin.
pub fn origin(o: LiveOrigin) -> CalibrationOrigin {
    match o {
        LiveOrigin::Factory => CalibrationOrigin::Factory,
        LiveOrigin::SelfCal => CalibrationOrigin::SelfCal,
        LiveOrigin::Background => CalibrationOrigin::Background,
        LiveOrigin::Host => CalibrationOrigin::Host,
    }
}

impl<F: NorFlash> Protocol<F> {
    /// The background recalibration's state, as `GetBackgroundStatus` answers it.
    pub fn background_report(&self) -> BackgroundReport {
        let bg = &self.background;
        let st = bg.status();
        let s = bg.settings();
        let (mut fresh_bins, mut bin_moments) = (0u64, heapless::Vec::new());
        for (i, b) in bg.grid().bins().iter().enumerate() {
            if b.fresh(st.play_s, s.max_bin_age_s) {
                fresh_bins |= 1 << i;
            }
            // Cannot overflow: BINS == BACKGROUND_BINS (checked above).
            let _ = bin_moments.push(b.count.min(255) as u8);
        }
        BackgroundReport {
            phase: match st.phase {
                BackgroundPhase::Collecting => WirePhase::Collecting,
                BackgroundPhase::Fitting => WirePhase::Fitting,
                BackgroundPhase::Committing => WirePhase::Committing,
                BackgroundPhase::Invalid => WirePhase::Invalid,
            },
            settings: BackgroundSettings {
                adopt: s.adopt,
                replace_uploaded: s.replace_host,
                commit_interval_s: s.min_commit_interval_s,
                commits_per_day: s.max_commits_per_day,
                fit_interval_ms: s.fit_interval_ms,
            },
            origin: origin(bg.origin()),
            // Since power-up (the clock itself resumes across power cycles).
            play_s: st.play_s.saturating_sub(st.power_up_s),
            moments: st.moments,
            bins_filled: st.bins_filled,
            fresh_bins,
            bin_moments,
            temperature_c: self.corrector.temperature(),
            coverage_gap: st.coverage_gap.map(gap),
            candidate: st.last_candidate.map(|c| CandidateReport {
                candidate_mg: mg(c.candidate_g),
                live_mg: mg(c.live_g),
                fit_rms_mg: mg(c.fit_rms_g),
                full_model: c.model == FitModel::Full,
                temperature: c.temperature,
                training_bins: c.bins.0,
                heldout_bins: c.bins.1,
            }),
            last_adoption: st.last_adoption.map(|a| AdoptionReport {
                at_s: a.at_s.saturating_sub(st.power_up_s),
                before_mg: mg(a.before_g),
                after_mg: mg(a.after_g),
            }),
            last_refusal: st.last_refusal.map(refusal),
        }
    }
}

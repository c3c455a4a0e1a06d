//! The background recalibration in the report loop: every report outside a C + Z session
//! ticks it (with the still moment the self-calibration's feed found, if any, and the board's
//! temperature), a fit does one bounded slice per report, and an adoption is committed by
//! [`Protocol::service`] through the power-loss-safe store — outside the report path, so
//! the poll deadline holds.

use embedded_storage_async::nor_flash::NorFlash;
use wiical_core::Calibration;

use super::Protocol;
use crate::background::{Background, BackgroundSettings, LiveOrigin};
use crate::settings::{Intervals, StoredSettings};
use crate::store::Loaded;

/// Why a stored calibration and its origin did not both reach flash.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum CommitError {
    /// Writing or reading back failed; the old calibration is live.
    Storage,
    /// A setting was outside its bounds; nothing was stored.
    OutOfBounds,
    /// The calibration was stored but the corrector refused it (cannot happen for a
    /// calibration that passed validation).
    Internal,
}

/// The background machine for settings `stored`, with the live calibration made by `origin`.
pub(super) fn background_for(
    rate_hz: u32,
    stored: &StoredSettings,
    origin: LiveOrigin,
) -> Background {
    let mut s = BackgroundSettings::nunchuk(rate_hz);
    s.adopt = stored.background_adopt;
    s.replace_host = stored.replace_uploaded;
    apply_intervals(&mut s, &stored.intervals);
    let mut bg = Background::new(s, origin);
    bg.resume(&stored.budget);
    bg
}

/// The budget's limits and the fit interval into the machine's settings.
fn apply_intervals(s: &mut BackgroundSettings, i: &Intervals) {
    s.min_commit_interval_s = i.commit_interval_s;
    s.max_commits_per_day = i.commits_per_day;
    s.fit_interval_ms = i.fit_interval_ms;
}

impl<F: NorFlash> Protocol<F> {
    /// One report's share of the background recalibration (see the module docs).
    pub(super) fn tick_background(&mut self, live: &Calibration) {
        if self.selfcal.active() {
            self.background.suspend();
            let _ = self.selfcal.take_still_moment();
            return;
        }
        let moment = self.selfcal.take_still_moment();
        let t = self.corrector.temperature();
        self.background.on_tick(moment, t, live);
    }

    /// Store `cal` made by `origin` with its origin record (the order that can only protect
    /// more, [`crate::settings`]), read it back, and only then make it live.
    pub(super) async fn store_with_origin(
        &mut self,
        cal: Calibration,
        origin: LiveOrigin,
    ) -> Result<(), CommitError> {
        let mut settings = self.settings;
        settings.origin = origin;
        if origin == LiveOrigin::Host {
            self.save_settings(settings).await?;
        }
        if self.store.save(&cal).await.is_err() {
            return Err(CommitError::Storage);
        }
        // Read back: only a calibration that the next boot will load goes live.
        match self.store.load().await {
            Ok(Loaded::Calibration(back)) if back.bits_equal(&cal) => {}
            _ => return Err(CommitError::Storage),
        }
        if self.corrector.set_user_calibration(Some(cal)).is_err() {
            return Err(CommitError::Internal);
        }
        self.refresh_block();
        self.selfcal.calibration_changed();
        if origin != LiveOrigin::Host {
            // The calibration is live whatever this write does: a failure leaves the older
            // origin, which protects at least as much (see the settings module).
            let _ = self.save_settings(settings).await;
        }
        Ok(())
    }

    async fn save_settings(&mut self, settings: StoredSettings) -> Result<(), CommitError> {
        if settings == self.settings {
            return Ok(());
        }
        self.store
            .save_settings(&settings)
            .await
            .map_err(|_| CommitError::Storage)?;
        self.settings = settings;
        Ok(())
    }

    /// Commits the background recalibration's adopted calibration, if one waits. The commit
    /// is counted in the stored budget first, then the calibration and its origin follow: a
    /// power cut at any point leaves a budget that counts at least the commits that happened.
    pub(super) async fn service_background(&mut self) {
        let Some(cal) = self.background.pending_calibration() else {
            return;
        };
        let counted = StoredSettings {
            budget: self.background.budget_record_committing(),
            ..self.settings
        };
        if self.save_settings(counted).await.is_err() {
            self.background.committed(Err(()));
            return;
        }
        let stored = self.store_with_origin(cal, LiveOrigin::Background).await;
        self.background.committed(stored.map_err(|_| ()));
    }

    /// Background adoption on or off, whether it may replace a host upload, the flash-write
    /// budget and the fit interval: checked against the wire protocol's bounds (nothing is
    /// stored otherwise: the budget bounds flash wear), stored (power-loss safe), then in
    /// force.
    pub(super) async fn set_background(
        &mut self,
        w: &wiical_wire::BackgroundSettings,
    ) -> Result<(), CommitError> {
        let intervals = Intervals {
            commit_interval_s: w.commit_interval_s,
            commits_per_day: w.commits_per_day,
            fit_interval_ms: w.fit_interval_ms,
        };
        if w.out_of_bounds().is_some() || !intervals.in_bounds() {
            return Err(CommitError::OutOfBounds);
        }
        let settings = StoredSettings {
            background_adopt: w.adopt,
            replace_uploaded: w.replace_uploaded,
            intervals,
            ..self.settings
        };
        self.save_settings(settings).await?;
        let mut s = *self.background.settings();
        s.adopt = w.adopt;
        s.replace_host = w.replace_uploaded;
        apply_intervals(&mut s, &intervals);
        self.background.set_settings(s);
        Ok(())
    }

    /// The background recalibration (status, grid, settings).
    pub fn background(&self) -> &Background {
        &self.background
    }

    /// The stored settings in force.
    pub fn stored_settings(&self) -> StoredSettings {
        self.settings
    }

    /// The board's temperature reading (°C; `None`: no reading). The firmware calls this at a
    /// low rate (a few times a minute is plenty: a sensor's temperature moves in minutes): it
    /// is the covariate of the background recalibration and feeds the live calibration's
    /// temperature terms.
    pub fn set_temperature(&mut self, temperature_c: Option<f32>) {
        self.corrector.set_temperature(temperature_c);
    }
}

//! Sources of `wiical live`: a recording replayed at its own pace (its time column, else its
//! rate), `speed` times faster, or an adapter's sample stream (a real adapter or `wiical
//! device-sim --pty`). The samples go through a [`LiveSession`]; a snapshot is
//! published at most every [`PUBLISH_EVERY`] of wall time, on every new pose and at the end.
//! An adapter's stream state and self-calibration status (the C + Z mode, protocol 2's
//! `GetStatus`) become the page's source status line; its background recalibration's grid
//! (protocol 5's `GetBackgroundStatus`) is drawn on the page's hemispheres. A MotionPlus's
//! gyro samples (protocol 8) feed the gyro view ([`super::gyro`]), published as `gyro`.

use super::gyro::GyroView;
use super::Shared;
use crate::client::{ClientOptions, Device, Streamed};
use std::sync::Arc;
use std::time::{Duration, Instant};
use wiical_analysis::live::{LiveSensor, LiveSession, Snapshot};
use wiical_analysis::Recording;
use wiical_wire::{AdapterStatus, SelfCalOutcome, SelfCalPhase};

/// Snapshots a second at most (besides one per pose and the last).
pub const PUBLISH_EVERY: Duration = Duration::from_millis(100);

/// Sleep only when ahead of the clock by more than this (a 100 Hz file replayed 50× fast is
/// 5000 samples a second: one sleep per sample would be mostly scheduler overhead).
const MIN_SLEEP: Duration = Duration::from_millis(5);

/// Replays `rec` (times `times`, seconds) into `session`, publishing to `shared`; ends the
/// session with "source ended" (or the reason a sample was refused) and returns the last
/// snapshot.
pub fn replay(
    rec: &Recording,
    times: &[f64],
    speed: f64,
    mut session: LiveSession,
    shared: &Arc<Shared>,
) -> Snapshot {
    let start = Instant::now();
    let t0 = times.first().copied().unwrap_or(0.0);
    // As if published a period ago: the first sample is shown at once (a viewer that comes
    // within the first period sees the replay running, not the empty session).
    let mut last_publish = start.checked_sub(PUBLISH_EVERY).unwrap_or(start);
    shared.publish(&session.snapshot());
    for (t, xyz) in times.iter().zip(&rec.xyz) {
        // Saturates: a time so far ahead (a tiny speed, a huge time stamp) waits "forever"
        // rather than panicking in the conversion.
        let due = Duration::try_from_secs_f64(((t - t0) / speed).max(0.0)).unwrap_or(Duration::MAX);
        let now = start.elapsed();
        if due > now + MIN_SLEEP {
            std::thread::sleep(due - now);
        }
        match session.push(*t, *xyz) {
            Ok(new_pose) => {
                if new_pose || last_publish.elapsed() >= PUBLISH_EVERY {
                    shared.publish(&session.snapshot());
                    last_publish = Instant::now();
                }
            }
            Err(e) => {
                session.finish(&format!("source ended: {e}"));
                let snap = session.snapshot();
                shared.publish(&snap);
                return snap;
            }
        }
    }
    session.finish("source ended");
    let snap = session.snapshot();
    shared.publish(&snap);
    snap
}

/// How often an adapter's self-calibration status is asked for while streaming.
pub const STATUS_EVERY: Duration = Duration::from_millis(500);

/// Streams an adapter (or `wiical device-sim`) at `path` into `session`: the raw 10-bit
/// counts, timed by the sample sequence number at the rate the adapter announces. Every
/// [`STATUS_EVERY`] the adapter's self-calibration status is asked for (keeping the samples
/// that arrive meanwhile) and shown with the stream's state as the source status line.
/// Ends when the device stops answering (unplugged, simulator stopped): `source ended: <why>`.
pub fn device(path: &str, shared: &Arc<Shared>) -> Option<Snapshot> {
    let fail = |why: String| -> Option<Snapshot> {
        let mut s = LiveSession::new(LiveSensor::Accelerometer, 100.0, true).ok()?;
        s.finish(&format!("source ended: {why}"));
        let snap = s.snapshot();
        shared.publish(&snap);
        Some(snap)
    };
    let mut dev = match Device::connect(path, ClientOptions::default()) {
        Ok((dev, _)) => dev,
        Err(e) => return fail(e.to_string()),
    };
    let rate_hz = match dev.start_stream(1) {
        Ok(mhz) => f64::from(mhz) / 1000.0,
        Err(e) => return fail(e.to_string()),
    };
    let mut feed = match LiveSession::new(LiveSensor::Accelerometer, rate_hz, true) {
        Ok(session) => Feed {
            session,
            shared: shared.clone(),
            rate_hz,
            last_publish: Instant::now(),
            first_seq: None,
            last_seq: 0,
            received: 0,
            gyro: GyroView::new(rate_hz),
            gyro_seen: false,
        },
        Err(e) => return fail(e.to_string()),
    };
    feed.status(None);
    let mut last_status = Instant::now();
    let why = loop {
        if last_status.elapsed() >= STATUS_EVERY {
            last_status = Instant::now();
            match dev.status_while_streaming_all() {
                Ok((status, samples)) => {
                    if let Some(e) = samples.iter().find_map(|s| feed.push(s).err()) {
                        break e;
                    }
                    feed.status(status.as_ref());
                }
                Err(e) => break e.to_string(),
            }
            match dev.background_while_streaming_all() {
                Ok((grid, samples)) => {
                    if let Some(g) = &grid {
                        shared.set_adapter_grid(grid_json(g));
                    }
                    if let Some(e) = samples.iter().find_map(|s| feed.push(s).err()) {
                        break e;
                    }
                }
                Err(e) => break e.to_string(),
            }
        }
        let pushed = match dev.next_streamed() {
            Ok(s) => feed.push(&s),
            Err(e) => break e.to_string(),
        };
        if let Err(e) = pushed {
            break e;
        }
    };
    feed.session.finish(&format!("source ended: {why}"));
    let snap = feed.session.snapshot();
    shared.publish(&snap);
    Some(snap)
}

/// An adapter's samples on their way into a session.
struct Feed {
    session: LiveSession,
    shared: Arc<Shared>,
    rate_hz: f64,
    last_publish: Instant,
    first_seq: Option<u32>,
    last_seq: u32,
    received: u64,
    /// The MotionPlus's rates (fed while the adapter serves one).
    gyro: GyroView,
    gyro_seen: bool,
}

impl Feed {
    /// One streamed sample (an accelerometer's into the session, a gyro's into the gyro
    /// view); the session's refusal as a sentence.
    fn push(&mut self, s: &Streamed) -> Result<(), String> {
        // Sequence numbers wrap at 2³²; the wrapping difference keeps time monotonic.
        let seq0 = *self.first_seq.get_or_insert(s.seq());
        self.last_seq = s.seq();
        self.received += 1;
        let s = match s {
            Streamed::Accelerometer(s) => s,
            Streamed::Gyro(g) => {
                self.gyro.push(g);
                self.gyro_seen = true;
                if self.last_publish.elapsed() >= PUBLISH_EVERY {
                    self.publish();
                }
                return Ok(());
            }
        };
        let t = f64::from(s.seq.wrapping_sub(seq0)) / self.rate_hz;
        let new_pose = self
            .session
            .push(t, s.raw.map(f64::from))
            .map_err(|e| e.to_string())?;
        if new_pose || self.last_publish.elapsed() >= PUBLISH_EVERY {
            self.publish();
        }
        Ok(())
    }

    fn publish(&mut self) {
        if self.gyro_seen {
            match serde_json::to_value(self.gyro.snapshot()) {
                Ok(v) => self.shared.set_gyro(v),
                Err(e) => self
                    .shared
                    .set_gyro(serde_json::json!({ "error": e.to_string() })),
            }
        }
        self.shared.publish(&self.session.snapshot());
        self.last_publish = Instant::now();
    }

    /// Sets the status line from the stream's counters and the adapter's `status`.
    fn status(&mut self, status: Option<&AdapterStatus>) {
        let sent = self
            .first_seq
            .map_or(0, |s0| u64::from(self.last_seq.wrapping_sub(s0)) + 1);
        let mut line = format!(
            "adapter streaming at {} Hz: {} samples, {} lost",
            self.rate_hz,
            self.received,
            sent.saturating_sub(self.received)
        );
        match status {
            Some(st) => line.push_str(&format!("; {}", selfcal_text(st))),
            None => line.push_str("; self-calibration status not known"),
        }
        self.session.set_source_status(&line);
        self.publish();
    }
}

/// The adapter's background-recalibration grid for the page: each bin's centre direction,
/// its still moments and whether it is fresh, and one line of words.
pub fn grid_json(b: &wiical_wire::BackgroundReport) -> serde_json::Value {
    let bins: Vec<_> = b
        .bin_moments
        .iter()
        .enumerate()
        .filter_map(|(i, m)| {
            let c = crate::client::background_bin_centre(i)?;
            Some(serde_json::json!({
                "direction": c, "moments": m, "fresh": b.fresh_bins >> i & 1 == 1,
            }))
        })
        .collect();
    let mut line = format!(
        "{} of {} bins fresh, {} still moments",
        b.bins_filled,
        b.bin_moments.len(),
        b.moments
    );
    if let Some(c) = b.candidate {
        line.push_str(&format!(
            "; held out: candidate {:.2} mg vs live {:.2} mg",
            c.candidate_mg, c.live_mg
        ));
    }
    if let Some(a) = b.last_adoption {
        line.push_str(&format!(
            "; adopted at {} s ({:.2} → {:.2} mg)",
            a.at_s, a.before_mg, a.after_mg
        ));
    }
    if let Some(r) = &b.last_refusal {
        line.push_str(&format!("; {}", crate::render::device::refusal_text(r)));
    }
    serde_json::json!({ "bins": bins, "line": line, "adopt": b.settings.adopt })
}

/// The adapter's self-calibration state in words: the phase (what its LED shows), the last
/// session's result, and the stale-calibration suggestion.
pub fn selfcal_text(st: &AdapterStatus) -> String {
    let phase = match st.phase {
        SelfCalPhase::Off => "off (hold C + Z while plugging the Nunchuk in to start it)",
        SelfCalPhase::Arming => "arming (keep C + Z held)",
        SelfCalPhase::WaitingForStillness => "hold still in a new orientation",
        SelfCalPhase::PoseTaken => "pose taken",
        SelfCalPhase::MoveToNewOrientation => "that orientation was taken: turn further",
        SelfCalPhase::Committing => "storing the calibration",
        SelfCalPhase::Done => "done",
        SelfCalPhase::Failed => "failed",
    };
    let mut text = format!("self-calibration: {phase}");
    let in_session = !matches!(st.phase, SelfCalPhase::Off | SelfCalPhase::Arming);
    if in_session && st.poses > 0 {
        text.push_str(&format!(", {} poses", st.poses));
    }
    match &st.last_result {
        Some(SelfCalOutcome::Done { rms_mg, poses }) => text.push_str(&format!(
            "; last self-calibration stored: {rms_mg:.2} mg RMS over {poses} poses"
        )),
        Some(SelfCalOutcome::Failed { message }) => {
            text.push_str(&format!("; last self-calibration failed: {message}"))
        }
        None => {}
    }
    if st.recalibration_suggested {
        text.push_str(&format!(
            "; recalibration suggested ({:.0} mg RMS over {} still moments)",
            st.stale_rms_mg, st.stale_moments
        ));
    }
    text
}

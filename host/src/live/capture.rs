//! `wiical capture --live`: the capture's samples feed a [`LiveSession`] while it records, so
//! the same page as `wiical live` shows the poses and the fit of the capture in progress.
//!
//! The session is fed the Wii Remote's accelerometer (raw 10-bit counts, the capture's host
//! clock), at the nominal rate of report mode `0x35` ([`CAPTURE_RATE_HZ`]); the capture's
//! instructions ("pose 3 done: turn the remote…") become the page's source status line.

use super::source::PUBLISH_EVERY;
use super::Shared;
use crate::capture::CaptureUi;
use std::sync::Arc;
use std::time::Instant;
use wiical_analysis::live::{LiveError, LiveSensor, LiveSession};

/// Reports a second of a Wii Remote in mode `0x35` (WiiBrew: about 100), what the live
/// detector's window and rest lengths are counted in.
pub const CAPTURE_RATE_HZ: f64 = 100.0;

/// A [`CaptureUi`] that passes everything on to `inner` and feeds the live view.
pub struct LiveCaptureUi<'a> {
    inner: &'a mut dyn CaptureUi,
    session: LiveSession,
    shared: Arc<Shared>,
    last_publish: Instant,
}

impl<'a> LiveCaptureUi<'a> {
    /// Wraps `inner`; publishes the empty session at once (the page has a first picture).
    pub fn new(inner: &'a mut dyn CaptureUi, shared: Arc<Shared>) -> Result<Self, LiveError> {
        let session = LiveSession::new(LiveSensor::Accelerometer, CAPTURE_RATE_HZ, true)?;
        shared.publish(&session.snapshot());
        Ok(Self {
            inner,
            session,
            shared,
            last_publish: Instant::now(),
        })
    }

    /// The capture is over (`why`: "capture finished", or the error): a hold still open
    /// becomes the last pose, and the page says how it ended.
    pub fn end(&mut self, why: &str) {
        self.session.finish(why);
        self.shared.publish(&self.session.snapshot());
    }
}

impl CaptureUi for LiveCaptureUi<'_> {
    fn message(&mut self, text: &str) {
        self.inner.message(text);
        self.session.set_source_status(text);
        self.shared.publish(&self.session.snapshot());
        self.last_publish = Instant::now();
    }

    fn progress(&mut self, samples: u64, t: f64, prompt: &str) {
        self.inner.progress(samples, t, prompt);
    }

    fn sample(&mut self, t: f64, remote: [u16; 3], nunchuk: Option<[u16; 3]>) {
        self.inner.sample(t, remote, nunchuk);
        // Counts are finite: a refusal cannot happen; the sample is then simply not shown.
        let new_pose = self.session.push(t, remote.map(f64::from)).unwrap_or(false);
        if new_pose || self.last_publish.elapsed() >= PUBLISH_EVERY {
            self.shared.publish(&self.session.snapshot());
            self.last_publish = Instant::now();
        }
    }

    fn finish(&mut self) {
        self.inner.finish();
    }
}

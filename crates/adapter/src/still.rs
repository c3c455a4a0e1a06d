//! Still moments: the core's static detector with an absolute stillness limit — the one rule
//! that the self-calibration session, the stale monitor and the background recalibration all
//! apply (the adapter's report loop runs a single feed, inside [`crate::SelfCal`], and hands
//! its moments of normal play on to the background recalibration).
//!
//! The detector's noise reference is the variance of its first window; a Nunchuk that is
//! moving when the detector starts would inflate it, so the detector is restarted until that
//! first window is itself still (every axis variance ≤ the limit), and every still moment must
//! meet the same absolute limit to count, so that shaking or a trembling hand yields no
//! moments rather than bad ones.

use wiical_core::static_detect::{StaticDetector, StaticDetectorConfig, StaticInterval};

/// Capacity of the static detector's sample ring (the window must fit).
pub const DETECTOR_CAPACITY: usize = 64;

/// The detector and its absolute limit; see the module docs.
#[derive(Debug, Clone)]
pub struct StillFeed {
    cfg: StaticDetectorConfig,
    max_variance: f32,
    detector: Option<StaticDetector<DETECTOR_CAPACITY>>,
}

impl StillFeed {
    /// A feed with detector settings `cfg` (window ≤ [`DETECTOR_CAPACITY`]) and the largest
    /// per-axis variance (raw counts²) of a still moment. Settings the detector refuses give a
    /// feed that never reports a moment.
    pub fn new(cfg: StaticDetectorConfig, max_variance: f32) -> Self {
        Self {
            cfg,
            max_variance,
            detector: StaticDetector::new(cfg).ok(),
        }
    }

    /// True when the detector accepted its settings.
    pub fn valid(&self) -> bool {
        self.detector.is_some()
    }

    /// Starts over (after an unplug: the next samples are a new stream).
    pub fn restart(&mut self) {
        self.detector = StaticDetector::new(self.cfg).ok();
    }

    /// Pushes one report's raw counts; the still moment that just ended, if any.
    pub fn push(&mut self, raw: [u16; 3]) -> Option<StaticInterval> {
        let det = self.detector.as_mut()?;
        let out = match det.push(raw.map(f32::from)) {
            Ok(out) => out,
            // 2³² samples (248 days at 200 Hz): start counting again.
            Err(_) => {
                self.restart();
                return None;
            }
        };
        if det.samples_seen() == self.cfg.init_samples {
            let shaky = det
                .reference_variance()
                .is_some_and(|v| v.iter().any(|x| *x > self.max_variance));
            if shaky {
                self.restart();
                return None;
            }
        }
        out.filter(|i| i.variance.iter().all(|v| *v <= self.max_variance))
    }
}

//! Sources of `wiical live`: a recording replayed at its own pace (its time column, else its
//! rate), `speed` times faster, or an adapter's sample stream (a real adapter or `wiical
//! device-sim --pty`). The samples go through a [`LiveSession`]; a snapshot is
//! published at most every [`PUBLISH_EVERY`] of wall time, on every new pose and at the end.

use super::Shared;
use crate::client::{ClientOptions, Device};
use std::sync::Arc;
use std::time::{Duration, Instant};
use wiical_analysis::live::{LiveSensor, LiveSession, Snapshot};
use wiical_analysis::Recording;

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
    let mut last_publish = Instant::now();
    shared.publish(&session.snapshot());
    for (t, xyz) in times.iter().zip(&rec.xyz) {
        let due = Duration::from_secs_f64(((t - t0) / speed).max(0.0));
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

/// Streams an adapter (or `wiical device-sim`) at `path` into `session`: the raw 10-bit
/// counts, timed by the sample sequence number at the rate the adapter announces. Ends when
/// the device stops answering (unplugged, simulator stopped): `source ended: <why>`.
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
    let mut session = match LiveSession::new(LiveSensor::Accelerometer, rate_hz, true) {
        Ok(s) => s,
        Err(e) => return fail(e.to_string()),
    };
    shared.publish(&session.snapshot());
    let mut last_publish = Instant::now();
    let mut first_seq = None;
    let why = loop {
        let s = match dev.next_sample() {
            Ok(s) => s,
            Err(e) => break e.to_string(),
        };
        // Sequence numbers wrap at 2³²; the wrapping difference keeps time monotonic.
        let seq0 = *first_seq.get_or_insert(s.seq);
        let t = f64::from(s.seq.wrapping_sub(seq0)) / rate_hz;
        match session.push(t, s.raw.map(f64::from)) {
            Ok(new_pose) if new_pose || last_publish.elapsed() >= PUBLISH_EVERY => {
                shared.publish(&session.snapshot());
                last_publish = Instant::now();
            }
            Ok(_) => {}
            Err(e) => break e.to_string(),
        }
    };
    session.finish(&format!("source ended: {why}"));
    let snap = session.snapshot();
    shared.publish(&snap);
    Some(snap)
}

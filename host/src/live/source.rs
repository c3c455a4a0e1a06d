//! Sources of `wiical live`: a recording replayed at its own pace (its time column, else its
//! rate), `speed` times faster. The samples go through a [`LiveSession`]; a snapshot is
//! published at most every [`PUBLISH_EVERY`] of wall time, on every new pose and at the end.

use super::Shared;
use std::sync::Arc;
use std::time::{Duration, Instant};
use wiical_analysis::live::{LiveSession, Snapshot};
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

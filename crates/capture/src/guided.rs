//! Live stillness detection and the guided multi-pose state machine.
//!
//! The stillness test is the one the core's offline `StaticDetector` uses (IMU-TK, Tedaldi et
//! al. 2014): a sample is still when the variance of a window of recent samples is at most
//! `threshold` times the noise variance measured during an initial rest. It runs live here,
//! on a trailing window measured in seconds (the report rate of a remote over Bluetooth is
//! not exact), and each device (remote, Nunchuk) must be still on its own.
//!
//! Sequence: the first `init_s` seconds are the rest (the remote lies still; its noise is the
//! reference, and it is pose 1's start). A pose is done once the samples have been still for
//! `hold_s` seconds; then the user turns the remote: the machine waits for motion, then for
//! stillness again, until `poses` poses are done. A pose whose mean is closer than
//! `min_separation` counts to an earlier one (on every device) is not counted. A pose that
//! does not get still within `still_timeout_s` (or no motion within that time) is an error.

use anyhow::{bail, Result};
use serde::Serialize;
use std::collections::VecDeque;

/// Settings of the guided mode. Times in seconds on the capture's clock.
#[derive(Debug, Clone, PartialEq)]
pub struct GuidedConfig {
    /// Number of poses to record.
    pub poses: usize,
    /// Initial rest (noise reference), s.
    pub init_s: f64,
    /// Trailing variance window, s.
    pub window_s: f64,
    /// Still when window variance ≤ this × rest variance (per device, summed over axes).
    pub threshold: f64,
    /// How long each pose must be held still, s.
    pub hold_s: f64,
    /// Longest wait for stillness (or for motion between poses), s.
    pub still_timeout_s: f64,
    /// A pose must differ from every earlier one by at least this many raw counts (Euclidean
    /// norm of the mean difference) on at least one device. 20 counts ≈ 0.2 g on a Wii Remote.
    pub min_separation: f64,
    /// The rest is refused if a device's noise there exceeds this standard deviation (raw
    /// counts, RMS over the axes): the remote was moving, so the reference would be wrong.
    pub max_rest_std: f64,
}

impl Default for GuidedConfig {
    fn default() -> Self {
        Self {
            poses: 12,
            init_s: 2.0,
            window_s: 0.5,
            threshold: 6.0,
            hold_s: 4.0,
            still_timeout_s: 60.0,
            min_separation: 20.0,
            max_rest_std: 6.0,
        }
    }
}

/// A finished pose.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PoseRecord {
    /// 1-based pose number.
    pub pose: usize,
    /// Time of the first still sample, s.
    pub t_start: f64,
    /// Time of the last sample of the hold, s.
    pub t_end: f64,
    /// Number of samples in the hold.
    pub samples: usize,
    /// Mean raw reading of each device (remote first, then the Nunchuk if recorded).
    pub mean: Vec<[f64; 3]>,
}

/// What the machine has to say after a sample.
#[derive(Debug, Clone, PartialEq)]
pub enum GuidedEvent {
    /// The rest is over; per-device noise standard deviation (RMS over axes, counts).
    RestDone {
        /// Noise std per device.
        noise_std: Vec<f64>,
    },
    /// Pose `pose` is still; hold it.
    Holding {
        /// 1-based pose number.
        pose: usize,
    },
    /// Pose done.
    PoseDone(PoseRecord),
    /// The held pose was the same as an earlier one and is not counted.
    TooClose {
        /// 1-based number it would have had.
        pose: usize,
        /// The earlier pose it matches.
        same_as: usize,
    },
    /// Motion seen: now waiting for pose `pose` to get still.
    Moving {
        /// 1-based pose number awaited.
        pose: usize,
    },
    /// All poses done.
    Finished,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Rest,
    WaitStill { pose: usize, deadline: f64 },
    WaitMotion { pose: usize, deadline: f64 },
    Done,
}

/// Per-device sum of per-axis population variances of a set of samples (two-pass, shifted
/// by the first sample, so raw offsets of hundreds of counts cost no precision).
fn variance_sums<'a>(
    samples: impl Iterator<Item = &'a [[f64; 3]]> + Clone,
    devices: usize,
) -> Vec<[f64; 3]> {
    let mut out = vec![[0.0; 3]; devices];
    let n = samples.clone().count();
    if n == 0 {
        return out;
    }
    let Some(first) = samples.clone().next() else {
        return out;
    };
    let first: Vec<[f64; 3]> = first.to_vec();
    let mut mean = vec![[0.0; 3]; devices];
    for s in samples.clone() {
        for d in 0..devices.min(s.len()) {
            for a in 0..3 {
                mean[d][a] += s[d][a] - first[d][a];
            }
        }
    }
    for m in mean.iter_mut() {
        for v in m.iter_mut() {
            *v /= n as f64;
        }
    }
    for s in samples {
        for d in 0..devices.min(s.len()) {
            for a in 0..3 {
                let e = s[d][a] - first[d][a] - mean[d][a];
                out[d][a] += e * e;
            }
        }
    }
    for o in out.iter_mut() {
        for v in o.iter_mut() {
            *v /= n as f64;
        }
    }
    out
}

/// The guided-mode state machine. Feed it every sample with [`Guided::push`].
#[derive(Debug, Clone)]
pub struct Guided {
    cfg: GuidedConfig,
    devices: usize,
    /// Per-axis variance floor per device (quantisation: a step `q` gives `q²/12`).
    floor: Vec<[f64; 3]>,
    phase: Phase,
    t0: Option<f64>,
    window: VecDeque<(f64, Vec<[f64; 3]>)>,
    rest: Vec<Vec<[f64; 3]>>,
    /// Per device: threshold on the window variance sum.
    limit: Vec<f64>,
    /// The still run being held: start time and samples.
    run: Option<(f64, Vec<Vec<[f64; 3]>>)>,
    poses: Vec<PoseRecord>,
}

impl Guided {
    /// A machine for `devices` 3-axis devices; `quantum[d]` is the per-axis ADC step of each
    /// (the Wii Remote's Y and Z move in steps of 2 on the 10-bit scale).
    pub fn new(cfg: GuidedConfig, quantum: Vec<[f64; 3]>) -> Result<Self> {
        let ok = cfg.poses >= 1
            && [cfg.init_s, cfg.window_s, cfg.hold_s, cfg.still_timeout_s]
                .iter()
                .all(|v| v.is_finite() && *v > 0.0)
            && cfg.threshold.is_finite()
            && cfg.threshold > 0.0
            && cfg.min_separation.is_finite()
            && cfg.min_separation >= 0.0
            && cfg.max_rest_std.is_finite()
            && cfg.max_rest_std > 0.0
            && !quantum.is_empty();
        if !ok {
            bail!("guided mode settings: need at least 1 pose and positive, finite times and thresholds");
        }
        if cfg.window_s >= cfg.hold_s {
            bail!(
                "guided mode: the variance window ({} s) must be shorter than the hold time ({} s)",
                cfg.window_s,
                cfg.hold_s
            );
        }
        let floor = quantum.iter().map(|q| q.map(|s| s * s / 12.0)).collect();
        Ok(Self {
            devices: quantum.len(),
            cfg,
            floor,
            phase: Phase::Rest,
            t0: None,
            window: VecDeque::new(),
            rest: Vec::new(),
            limit: Vec::new(),
            run: None,
            poses: Vec::new(),
        })
    }

    /// The poses done so far.
    pub fn poses(&self) -> &[PoseRecord] {
        &self.poses
    }

    /// True once all poses are done.
    pub fn finished(&self) -> bool {
        self.phase == Phase::Done
    }

    /// A short description of what the user should do now.
    pub fn prompt(&self) -> String {
        match self.phase {
            Phase::Rest => "keep the remote still (measuring its noise)".into(),
            Phase::WaitStill { pose, .. } => format!("pose {pose}/{}: hold still", self.cfg.poses),
            Phase::WaitMotion { pose, .. } => {
                format!(
                    "pose {pose}/{}: turn the remote to a new orientation",
                    self.cfg.poses
                )
            }
            Phase::Done => "done".into(),
        }
    }

    fn window_is_still(&self) -> bool {
        let Some(&(t_first, _)) = self.window.front() else {
            return false;
        };
        let Some(&(t_last, _)) = self.window.back() else {
            return false;
        };
        // A window shorter than 80 % of its length (start-up, gaps) decides nothing.
        if t_last - t_first < 0.8 * self.cfg.window_s || self.window.len() < 3 {
            return false;
        }
        let v = variance_sums(self.window.iter().map(|(_, s)| s.as_slice()), self.devices);
        v.iter()
            .zip(&self.limit)
            .all(|(var, lim)| var.iter().sum::<f64>() <= *lim)
    }

    fn mean_of(samples: &[Vec<[f64; 3]>], devices: usize) -> Vec<[f64; 3]> {
        let mut m = vec![[0.0; 3]; devices];
        for s in samples {
            for d in 0..devices.min(s.len()) {
                for a in 0..3 {
                    m[d][a] += s[d][a];
                }
            }
        }
        let n = samples.len().max(1) as f64;
        m.iter().map(|v| v.map(|x| x / n)).collect()
    }

    /// Feeds one sample (`sample[d]` = raw xyz of device `d`) taken at time `t` (s).
    /// Returns what happened; an error when a pose timed out or the rest was not still.
    pub fn push(&mut self, t: f64, sample: &[[f64; 3]]) -> Result<Vec<GuidedEvent>> {
        if sample.len() != self.devices || !t.is_finite() {
            bail!(
                "guided mode: expected {} devices and a finite time, got {} at t = {t}",
                self.devices,
                sample.len()
            );
        }
        let mut events = Vec::new();
        let t0 = *self.t0.get_or_insert(t);
        self.slide_window(t, sample);
        match self.phase {
            Phase::Rest => self.push_rest(t, t0, sample, &mut events)?,
            Phase::WaitStill { pose, deadline } => {
                self.push_wait_still(t, (pose, deadline), sample, &mut events)?;
            }
            Phase::WaitMotion { pose, deadline } => {
                self.push_wait_motion(t, (pose, deadline), &mut events)?;
            }
            Phase::Done => {}
        }
        Ok(events)
    }

    /// Adds the sample to the stillness window and drops what is older than `window_s`
    /// before `t`: every phase after the rest decides on this window.
    fn slide_window(&mut self, t: f64, sample: &[[f64; 3]]) {
        self.window.push_back((t, sample.to_vec()));
        while let Some(&(tf, _)) = self.window.front() {
            if tf < t - self.cfg.window_s {
                self.window.pop_front();
            } else {
                break;
            }
        }
    }

    /// [`Self::push`] in the initial rest: collects samples until `init_s` after `t0`, then
    /// ends the rest ([`Self::end_rest`]). Each phase has its own method so that `push` reads
    /// as the phases' dispatch.
    fn push_rest(
        &mut self,
        t: f64,
        t0: f64,
        sample: &[[f64; 3]],
        events: &mut Vec<GuidedEvent>,
    ) -> Result<()> {
        self.rest.push(sample.to_vec());
        if t - t0 >= self.cfg.init_s {
            self.end_rest(t, t0, events)?;
        }
        Ok(())
    }

    /// The end of the initial rest at `t` (it began at `t0`): its noise (an error when it
    /// moved), the stillness limits, and pose 1 started with the rest as its hold.
    fn end_rest(&mut self, t: f64, t0: f64, events: &mut Vec<GuidedEvent>) -> Result<()> {
        let v = variance_sums(self.rest.iter().map(|s| s.as_slice()), self.devices);
        let noise_std: Vec<f64> = v
            .iter()
            .map(|d| (d.iter().sum::<f64>() / 3.0).sqrt())
            .collect();
        if let Some((d, s)) = noise_std
            .iter()
            .enumerate()
            .find(|(_, s)| **s > self.cfg.max_rest_std)
        {
            bail!(
                "the {} moved during the initial rest (noise {s:.1} counts RMS, at most {} expected): lay it still at the start and try again",
                if d == 0 { "remote" } else { "Nunchuk" },
                self.cfg.max_rest_std
            );
        }
        self.limit = v
            .iter()
            .zip(&self.floor)
            .map(|(var, fl)| self.cfg.threshold * (0..3).map(|a| var[a].max(fl[a])).sum::<f64>())
            .collect();
        events.push(GuidedEvent::RestDone { noise_std });
        events.push(GuidedEvent::Holding { pose: 1 });
        // The rest is still by construction: it starts pose 1's hold.
        self.run = Some((t0, std::mem::take(&mut self.rest)));
        self.phase = Phase::WaitStill {
            pose: 1,
            deadline: t + self.cfg.still_timeout_s,
        };
        self.check_hold(t, events);
        Ok(())
    }

    /// [`Self::push`] while waiting for `pose` to be held: a still window starts or extends
    /// the hold (recorded once it lasts `hold_s`), a moving one restarts it; an error when
    /// no hold has lasted by `deadline`.
    fn push_wait_still(
        &mut self,
        t: f64,
        (pose, deadline): (usize, f64),
        sample: &[[f64; 3]],
        events: &mut Vec<GuidedEvent>,
    ) -> Result<()> {
        if self.window_is_still() {
            match self.run.as_mut() {
                Some((_, samples)) => samples.push(sample.to_vec()),
                None => {
                    let start = self.window.front().map(|w| w.0).unwrap_or(t);
                    let samples = self.window.iter().map(|(_, s)| s.clone()).collect();
                    self.run = Some((start, samples));
                    events.push(GuidedEvent::Holding { pose });
                }
            }
            self.check_hold(t, events);
        } else {
            self.run = None;
            if t > deadline {
                bail!(
                    "pose {pose}: the remote did not keep still for {} s within {} s; hold it still against something (or raise --still-timeout-s / --threshold)",
                    self.cfg.hold_s,
                    self.cfg.still_timeout_s
                );
            }
        }
        Ok(())
    }

    /// [`Self::push`] after a pose was recorded: the first moving window starts the wait for
    /// `pose` to be held; an error when the remote has not moved by `deadline`.
    fn push_wait_motion(
        &mut self,
        t: f64,
        (pose, deadline): (usize, f64),
        events: &mut Vec<GuidedEvent>,
    ) -> Result<()> {
        if !self.window_is_still() {
            events.push(GuidedEvent::Moving { pose });
            self.phase = Phase::WaitStill {
                pose,
                deadline: t + self.cfg.still_timeout_s,
            };
        } else if t > deadline {
            bail!(
                "pose {pose}: no motion within {} s; turn the remote to a new orientation after each pose",
                self.cfg.still_timeout_s
            );
        }
        Ok(())
    }

    fn check_hold(&mut self, t: f64, events: &mut Vec<GuidedEvent>) {
        let Phase::WaitStill { pose, .. } = self.phase else {
            return;
        };
        let Some((start, samples)) = &self.run else {
            return;
        };
        if t - start < self.cfg.hold_s {
            return;
        }
        let mean = Self::mean_of(samples, self.devices);
        let record = PoseRecord {
            pose,
            t_start: *start,
            t_end: t,
            samples: samples.len(),
            mean,
        };
        self.run = None;
        let deadline = t + self.cfg.still_timeout_s;
        let same = self.poses.iter().find(|p| {
            p.mean.iter().zip(&record.mean).all(|(a, b)| {
                let d2: f64 = (0..3).map(|k| (a[k] - b[k]).powi(2)).sum();
                d2.sqrt() < self.cfg.min_separation
            })
        });
        if let Some(p) = same {
            events.push(GuidedEvent::TooClose {
                pose,
                same_as: p.pose,
            });
            self.phase = Phase::WaitMotion { pose, deadline };
            return;
        }
        self.poses.push(record.clone());
        events.push(GuidedEvent::PoseDone(record));
        if pose >= self.cfg.poses {
            self.phase = Phase::Done;
            events.push(GuidedEvent::Finished);
        } else {
            self.phase = Phase::WaitMotion {
                pose: pose + 1,
                deadline,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(poses: usize) -> GuidedConfig {
        GuidedConfig {
            poses,
            still_timeout_s: 10.0,
            ..Default::default()
        }
    }

    /// Feeds `secs` seconds at 100 Hz of `f(t)`; returns the events.
    fn feed(
        g: &mut Guided,
        t: &mut f64,
        secs: f64,
        f: impl Fn(f64) -> [f64; 3],
    ) -> Result<Vec<GuidedEvent>> {
        let mut ev = Vec::new();
        let end = *t + secs;
        while *t < end {
            ev.extend(g.push(*t, &[f(*t)])?);
            *t += 0.01;
        }
        Ok(ev)
    }

    /// ±1 count alternating noise around `p`.
    fn still(p: [f64; 3]) -> impl Fn(f64) -> [f64; 3] {
        move |t| {
            let k = ((t * 100.0).round() as i64 % 2) as f64;
            [p[0] + k, p[1] - k, p[2] + k]
        }
    }

    #[test]
    fn counts_poses_separated_by_motion() {
        let mut g = Guided::new(cfg(3), vec![[1.0; 3]]).unwrap();
        let mut t = 0.0;
        let mut ev = feed(&mut g, &mut t, 5.0, still([512.0, 512.0, 620.0])).unwrap();
        let swing = |t: f64| [512.0 + 80.0 * (t * 7.0).sin(), 512.0, 560.0];
        ev.extend(feed(&mut g, &mut t, 1.0, swing).unwrap());
        ev.extend(feed(&mut g, &mut t, 5.0, still([620.0, 512.0, 512.0])).unwrap());
        ev.extend(feed(&mut g, &mut t, 1.0, swing).unwrap());
        ev.extend(feed(&mut g, &mut t, 5.0, still([512.0, 620.0, 512.0])).unwrap());
        let done: Vec<&PoseRecord> = ev
            .iter()
            .filter_map(|e| match e {
                GuidedEvent::PoseDone(p) => Some(p),
                _ => None,
            })
            .collect();
        assert_eq!(done.len(), 3, "{ev:?}");
        assert!(g.finished());
        assert!((done[1].mean[0][0] - 620.5).abs() < 0.6, "{:?}", done[1]);
        assert!(done.iter().all(|p| p.t_end - p.t_start >= 4.0));
    }

    #[test]
    fn same_orientation_twice_is_not_a_new_pose() {
        let mut g = Guided::new(cfg(2), vec![[1.0; 3]]).unwrap();
        let mut t = 0.0;
        let p = [512.0, 512.0, 620.0];
        let mut ev = feed(&mut g, &mut t, 5.0, still(p)).unwrap();
        ev.extend(
            feed(&mut g, &mut t, 1.0, |t| {
                [512.0 + 50.0 * (t * 9.0).sin(), 512.0, 600.0]
            })
            .unwrap(),
        );
        ev.extend(feed(&mut g, &mut t, 5.0, still(p)).unwrap());
        assert!(
            ev.contains(&GuidedEvent::TooClose {
                pose: 2,
                same_as: 1
            }),
            "{ev:?}"
        );
        assert_eq!(g.poses().len(), 1);
        assert!(!g.finished());
    }

    #[test]
    fn a_pose_that_never_gets_still_times_out() {
        let mut g = Guided::new(cfg(2), vec![[1.0; 3]]).unwrap();
        let mut t = 0.0;
        feed(&mut g, &mut t, 5.0, still([512.0, 512.0, 620.0])).unwrap();
        let e = feed(&mut g, &mut t, 30.0, |t| {
            [512.0 + 50.0 * (t * 9.0).sin(), 512.0, 600.0]
        })
        .unwrap_err();
        assert!(
            format!("{e}").contains("pose 2: the remote did not keep still"),
            "{e}"
        );
    }

    #[test]
    fn motion_during_the_rest_is_refused() {
        let mut g = Guided::new(cfg(2), vec![[1.0; 3]]).unwrap();
        let mut t = 0.0;
        let e = feed(&mut g, &mut t, 3.0, |t| {
            [512.0 + 50.0 * (t * 9.0).sin(), 512.0, 600.0]
        })
        .unwrap_err();
        assert!(
            format!("{e}").contains("moved during the initial rest"),
            "{e}"
        );
    }

    #[test]
    fn bad_settings_are_refused() {
        assert!(Guided::new(GuidedConfig { poses: 0, ..cfg(1) }, vec![[1.0; 3]]).is_err());
        assert!(Guided::new(
            GuidedConfig {
                hold_s: f64::NAN,
                ..cfg(1)
            },
            vec![[1.0; 3]]
        )
        .is_err());
        assert!(Guided::new(
            GuidedConfig {
                window_s: 5.0,
                ..cfg(1)
            },
            vec![[1.0; 3]]
        )
        .is_err());
        let mut g = Guided::new(cfg(1), vec![[1.0; 3]]).unwrap();
        assert!(g.push(f64::NAN, &[[0.0; 3]]).is_err());
        assert!(g.push(0.0, &[[0.0; 3], [0.0; 3]]).is_err());
    }
}

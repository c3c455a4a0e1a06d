//! A log polled faster than its sensor updates: the same reading written several times in a
//! row, until the sensor's next sample arrives.
//!
//! A firmware loop that reads the sensor's registers at 400 Hz while the sensor updates them
//! at 100 Hz logs every sample four times (the FastAHRS FXOS8700 log: runs of 4, now and then
//! 5 or 1). The repeats carry no new information: a window's 4,000 rows are 1,000 samples, so
//! its noise floor `var/n` taken over the rows is half what it is, and a residual judged
//! against it looks twice as significant as it is. Here each still window's runs of identical
//! consecutive samples (all three axes repeating together) are counted as the samples pass;
//! [`judge`] decides from all windows whether the log was polled, finds the sensor's real rate
//! from the runs and the clock, and then the noise is taken from the distinct samples only.
//!
//! Told from chance repeats: a quiet, coarsely quantised sensor also repeats its reading now
//! and then, but chance repeats follow a geometric law, whose most common run is always a
//! single sample, and each longer run is rarer than the one before. A polled log's most common
//! run is the poll-to-update ratio (≥ 2), at least [`MODE_OVER_SINGLES`] times as common as a
//! single sample, and a good share of its samples repeat the one before
//! ([`MIN_REPEATED_SHARE`]). All three are required.

use serde::Serialize;

/// Run lengths counted one by one up to this; longer runs share the last bin.
pub const RUN_BINS: usize = 16;

/// Least share of the windows' samples that repeat the sample before them for a polled log
/// (a poll-to-update ratio of 1.5 repeats a third of them; chance repeats of a quantised
/// sensor on all three axes at once are a few percent on the project's real recordings).
pub const MIN_REPEATED_SHARE: f64 = 1.0 / 3.0;

/// The most common run must be at least this many times as common as a run of one sample:
/// under chance repeats (a geometric law) a run of `k` samples is always rarer than one of a
/// single sample, so even a histogram flattened by a very quiet sensor stays far below it.
pub const MODE_OVER_SINGLES: f64 = 2.0;

/// Fewest runs over all windows for a judgement: below it the histogram says little.
pub const MIN_RUNS: usize = 100;

/// The runs of identical consecutive samples in one window, folded sample by sample in order
/// with the window's mean known (the second pass over a window's samples, held or streamed).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Runs {
    /// Runs, i.e. distinct sensor samples.
    pub distinct: usize,
    /// Over the distinct samples (each run's first), `Σ (x − m)` per axis (`m` the window's
    /// mean of all samples).
    pub sum: [f64; 3],
    /// Over the distinct samples, `Σ (x − m)²` per axis.
    pub sq: [f64; 3],
    /// `hist[k]`: runs of `k + 1` samples (the last bin: of [`RUN_BINS`] or more).
    pub hist: [u32; RUN_BINS],
    prev: Option<[f64; 3]>,
    len: usize,
}

impl Runs {
    /// The next sample `x` of a window whose mean is `m`.
    pub fn push(&mut self, x: &[f64; 3], m: &[f64; 3]) {
        // Bit-for-bit equality of all three axes: a repeat is the same register value read
        // again, not a value that happens to be close.
        if self.prev.as_ref() == Some(x) {
            self.len += 1;
            return;
        }
        self.close();
        self.prev = Some(*x);
        self.len = 1;
        self.distinct += 1;
        for a in 0..3 {
            let d = x[a] - m[a];
            self.sum[a] += d;
            self.sq[a] += d * d;
        }
    }

    /// Ends the run in progress (call once after the last sample; idempotent).
    pub fn close(&mut self) {
        if self.len > 0 {
            self.hist[(self.len - 1).min(RUN_BINS - 1)] += 1;
            self.len = 0;
        }
    }

    /// Per axis, the distinct samples' summed squared deviations from their own mean (the
    /// variance's numerator: `detect::windows` divides it by `distinct − 1` and floors it as
    /// it does a window's own).
    pub fn sq_about_own_mean(&self) -> [f64; 3] {
        let k = self.distinct.max(1) as f64;
        std::array::from_fn(|a| (self.sq[a] - self.sum[a] * self.sum[a] / k).max(0.0))
    }
}

/// The runs of the samples `xs` about their mean `m`.
pub fn runs_of(xs: &[[f64; 3]], m: &[f64; 3]) -> Runs {
    let mut r = Runs::default();
    xs.iter().for_each(|x| r.push(x, m));
    r.close();
    r
}

/// A log found to be polled faster than its sensor updates (`polling` in the JSON of `fit`,
/// `analyze`, `noise`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Polling {
    /// The rate the log was written at, Hz (its clock over the still windows).
    pub poll_hz: f64,
    /// The sensor's own update rate, Hz: distinct samples per second of the same clock.
    pub sensor_hz: f64,
    /// The most common run of identical samples (the poll-to-update ratio, rounded).
    pub typical_run: usize,
    /// Share of the samples that repeat the one before.
    pub repeated_share: f64,
    /// Samples in the still windows (or the recording, for `noise`).
    pub samples: usize,
    /// Distinct samples among them: the noise is taken from these.
    pub distinct: usize,
}

impl Polling {
    /// One sentence: `polled at 400 Hz, the sensor updates at ~102 Hz (runs of 4 identical
    /// samples; 74 % of the samples repeat the one before): noise from the 20,444 distinct
    /// samples of 80,000`.
    pub fn sentence(&self) -> String {
        format!(
            "polled at {} Hz, the sensor updates at ~{} Hz (runs of {} identical samples; {:.0} % \
             of the samples repeat the one before): noise from the {} distinct samples of {}",
            round_hz(self.poll_hz),
            round_hz(self.sensor_hz),
            self.typical_run,
            100.0 * self.repeated_share,
            self.distinct,
            self.samples
        )
    }
}

/// A rate for the sentence: three significant figures, no trailing zeros.
fn round_hz(hz: f64) -> String {
    if !(hz.is_finite() && hz > 0.0) {
        return format!("{hz}");
    }
    let digits = (2 - hz.log10().floor() as i32).max(0) as usize;
    let s = format!("{hz:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Whether the runs `runs` (one per window, or one for a whole still recording) spanning
/// `seconds` of clock over `samples` samples are a polled log's, and if so its rates.
pub fn judge(runs: &[&Runs], samples: usize, seconds: f64) -> Option<Polling> {
    let mut hist = [0u64; RUN_BINS];
    let mut distinct = 0usize;
    for r in runs {
        distinct += r.distinct;
        for (h, k) in hist.iter_mut().zip(r.hist) {
            *h += u64::from(k);
        }
    }
    let total: u64 = hist.iter().sum();
    // A NaN or non-positive span of clock judges nothing.
    if (total as usize) < MIN_RUNS || samples == 0 || seconds.is_nan() || seconds <= 0.0 {
        return None;
    }
    // The most common run; ties go to the shorter (a geometric law's tie is never above 1).
    let typical = (0..RUN_BINS).max_by_key(|k| (hist[*k], std::cmp::Reverse(*k)))? + 1;
    let repeated_share = 1.0 - distinct as f64 / samples as f64;
    let dominant = hist[typical - 1] as f64 >= MODE_OVER_SINGLES * hist[0] as f64;
    if typical < 2 || !dominant || repeated_share < MIN_REPEATED_SHARE {
        return None;
    }
    let poll_hz = samples as f64 / seconds;
    Some(Polling {
        poll_hz,
        sensor_hz: poll_hz * distinct as f64 / samples as f64,
        typical_run: typical,
        repeated_share,
        samples,
        distinct,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// A sensor updating at `sensor_hz` with white noise `sigma` (quantised to `q`), read by a
    /// loop at `poll_hz`: each poll reads the sensor's latest sample.
    fn polled(sensor_hz: f64, poll_hz: f64, seconds: f64, sigma: f64, q: f64) -> Vec<[f64; 3]> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let updates = (sensor_hz * seconds) as usize + 1;
        let sensor: Vec<[f64; 3]> = (0..updates)
            .map(|_| {
                std::array::from_fn(|a| {
                    let g: f64 = StandardNormal.sample(&mut rng);
                    ((a as f64 + sigma * g) / q).round() * q
                })
            })
            .collect();
        (0..(poll_hz * seconds) as usize)
            .map(|i| sensor[((i as f64 / poll_hz) * sensor_hz).floor() as usize])
            .collect()
    }

    fn mean(xs: &[[f64; 3]]) -> [f64; 3] {
        std::array::from_fn(|a| xs.iter().map(|x| x[a]).sum::<f64>() / xs.len() as f64)
    }

    /// 100 Hz polled at 400 Hz: found, the sensor's rate within 1 %, the distinct samples'
    /// variance that of the sensor's noise (σ² = 1: within 3 standard errors of 1000 samples).
    #[test]
    fn a_log_polled_four_times_per_update_is_found_with_its_rate() {
        let xs = polled(100.0, 400.0, 10.0, 1.0, 1e-3);
        let r = runs_of(&xs, &mean(&xs));
        let p = judge(&[&r], xs.len(), xs.len() as f64 / 400.0).expect("polled");
        assert_eq!(p.typical_run, 4);
        assert!((p.sensor_hz / 100.0 - 1.0).abs() < 0.01, "{p:?}");
        assert!((p.repeated_share - 0.75).abs() < 0.01, "{p:?}");
        let v = r.sq_about_own_mean().map(|q| q / (r.distinct - 1) as f64);
        // The distinct samples: each run's first, in order.
        let mut want = xs.clone();
        want.dedup();
        assert_eq!(r.distinct, want.len());
        let m = mean(&want);
        for a in 0..3 {
            let direct =
                want.iter().map(|x| (x[a] - m[a]).powi(2)).sum::<f64>() / (want.len() - 1) as f64;
            assert!(
                (v[a] - direct).abs() < 1e-9 * direct,
                "{a}: {} {direct}",
                v[a]
            );
            // var of a sample variance of n normals: 2σ⁴/(n−1).
            assert!(
                (v[a] - 1.0).abs() < 3.0 * (2.0 / 999.0f64).sqrt(),
                "{a}: {}",
                v[a]
            );
        }
        assert!(
            p.sentence()
                .starts_with("polled at 400 Hz, the sensor updates at ~"),
            "{}",
            p.sentence()
        );
    }

    /// A sensor read once per update, even coarsely quantised so that all three axes often
    /// repeat by chance (σ of 0.4 steps), is not polled: its most common run is one sample.
    #[test]
    fn chance_repeats_of_a_quantised_sensor_are_not_polling() {
        for (sigma, q) in [(1.0, 1e-3), (0.4, 1.0), (0.25, 1.0)] {
            let xs = polled(100.0, 100.0, 20.0, sigma, q);
            let r = runs_of(&xs, &mean(&xs));
            assert_eq!(
                r.hist[0] as usize,
                r.hist.iter().map(|k| *k as usize).max().unwrap()
            );
            assert!(
                judge(&[&r], xs.len(), 20.0).is_none(),
                "σ {sigma} q {q}: {:?}",
                r.hist
            );
        }
        // A twice-polled one is (σ 1 step, 2 polls per update).
        let xs = polled(100.0, 200.0, 20.0, 1.0, 1.0);
        let r = runs_of(&xs, &mean(&xs));
        assert_eq!(judge(&[&r], xs.len(), 20.0).map(|p| p.typical_run), Some(2));
    }

    #[test]
    fn rates_are_rounded_to_three_figures() {
        assert_eq!(round_hz(400.0), "400");
        assert_eq!(round_hz(102.2222), "102");
        assert_eq!(round_hz(12.345), "12.3");
        assert_eq!(round_hz(0.5), "0.5");
    }
}

//! The gyro's clock against the accelerometer's: how far the gyro's turns come after (or
//! before) the accelerometer's at the same timestamps.
//!
//! Why: the fit takes the accelerometer's rests as the gyro's and integrates the gyro between
//! them. A gyro file whose rows lag their timestamps by seconds (a logger that stamped the two
//! streams with different clocks, a pair exported with a gap) integrates the wrong samples:
//! the held-out error was 87° on the Xsens pair with the gyro 10 s late, and the verdict called
//! that "usable". The fit cannot see the cause; the two sensors' activity can: the gyro's rate
//! magnitude is high exactly while the accelerometer's direction changes.
//!
//! How: both sensors are averaged over blocks of [`BLOCK_S`] (longer for very long recordings,
//! so that at most [`MAX_BLOCKS`] blocks are kept: bounded memory and time). The gyro's
//! activity is its block mean's distance from the median block mean (the rate at rest: a
//! multi-position recording rests most of the time), the accelerometer's the distance between
//! consecutive block means (its direction changing during the block). Their Pearson
//! correlation at block lags up to [`SEARCH_S`] either way gives the lag: the one with the
//! highest correlation.

use super::options::Result;
use super::samples::Imu;
use crate::source::RowSource;

/// Length of a block both sensors are averaged over, s (the lag's resolution).
pub const BLOCK_S: f64 = 0.1;

/// At most this many blocks are kept (beyond, blocks grow: 20 000 blocks of 0.1 s are 33 min).
pub const MAX_BLOCKS: usize = 20_000;

/// Lags tried either way, s: a clock offset of more than a minute is no offset but another
/// recording.
pub const SEARCH_S: f64 = 60.0;

/// A lag beyond this is reported as a reason the calibration cannot hold, s: the fit's motions
/// carry [`super::MOTION_MARGIN_S`] of margin and the time-offset candidate of the motion loop
/// models offsets within a motion (docs/gyro.md: 0.74 s already spoils the calibration).
pub const MAX_LAG_S: f64 = 0.5;

/// The correlation at the best lag must reach this (the activities agree there) and exceed
/// the one at no lag by [`MIN_GAIN`] for a lag to be named.
pub const MIN_CORRELATION: f64 = 0.5;

/// See [`MIN_CORRELATION`].
pub const MIN_GAIN: f64 = 0.2;

/// The lag the two sensors' activities agree best at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lag {
    /// Gyro after the accelerometer, s (negative: before).
    pub seconds: f64,
    /// Correlation of the activities at that lag.
    pub correlation: f64,
    /// Correlation at no lag.
    pub at_zero: f64,
}

impl Lag {
    /// The reason the calibration cannot hold, when the lag is one of seconds.
    pub fn problem(&self) -> Option<String> {
        let named = self.seconds.abs() > MAX_LAG_S
            && self.correlation >= MIN_CORRELATION
            && self.correlation - self.at_zero >= MIN_GAIN;
        named.then(|| {
            let way = if self.seconds > 0.0 { "lags" } else { "leads" };
            format!(
                "the gyro {way} the accelerometer by {:.1} s (its turns come {:.1} s {} the accelerometer's at the same timestamps: activity correlation {:.2} there, {:.2} at no lag): the two clocks are not aligned, so the fit integrates the wrong samples; shift the gyro's timestamps by {:.1} s",
                self.seconds.abs(),
                self.seconds.abs(),
                if self.seconds > 0.0 { "after" } else { "before" },
                self.correlation,
                self.at_zero,
                -self.seconds,
            )
        })
    }
}

/// The lag of `imu`'s gyro behind its accelerometer at `rate` Hz (one pass); `None` when the
/// recording is too short for a block series or either sensor never moves.
pub(super) fn estimate(
    imu: &Imu<'_, impl RowSource>,
    rate: f64,
    default_rate: f64,
) -> Result<Option<Lag>> {
    let n = imu.len();
    let per_block = ((rate * BLOCK_S).round() as usize)
        .max(1)
        .max(n.div_ceil(MAX_BLOCKS));
    let mut gyro: Vec<[f64; 3]> = Vec::with_capacity(n / per_block + 1);
    let mut acc: Vec<[f64; 3]> = Vec::with_capacity(n / per_block + 1);
    let (mut gs, mut as_, mut k) = ([0.0; 3], [0.0; 3], 0usize);
    imu.pass(default_rate, &mut |_, row| {
        for a in 0..3 {
            gs[a] += row.gyro[a];
            as_[a] += row.acc[a];
        }
        k += 1;
        if k == per_block {
            gyro.push(gs.map(|s| s / k as f64));
            acc.push(as_.map(|s| s / k as f64));
            (gs, as_, k) = ([0.0; 3], [0.0; 3], 0);
        }
    })?;
    let block_s = per_block as f64 / rate;
    Ok(lag_of(&gyro, &acc, block_s))
}

/// [`estimate`] on the block means.
fn lag_of(gyro: &[[f64; 3]], acc: &[[f64; 3]], block_s: f64) -> Option<Lag> {
    if gyro.len() < 8 {
        return None;
    }
    let median: [f64; 3] = std::array::from_fn(|a| {
        let v: Vec<f64> = gyro.iter().map(|g| g[a]).collect();
        crate::stats::median(&v)
    });
    let dist =
        |u: &[f64; 3], v: &[f64; 3]| (0..3).map(|a| (u[a] - v[a]).powi(2)).sum::<f64>().sqrt();
    // The accelerometer's change from block i - 1 to block i is what it turned during block i:
    // both series start at block 1.
    let g: Vec<f64> = gyro[1..].iter().map(|m| dist(m, &median)).collect();
    let a: Vec<f64> = acc.windows(2).map(|w| dist(&w[1], &w[0])).collect();
    let most = ((SEARCH_S / block_s).round() as usize).min(g.len() / 2);
    let r = |lag: isize| correlation_at(&g, &a, lag);
    let at_zero = r(0)?;
    let (mut best, mut best_r) = (0isize, at_zero);
    for lag in 1..=most as isize {
        for l in [lag, -lag] {
            if let Some(c) = r(l).filter(|c| *c > best_r) {
                (best, best_r) = (l, c);
            }
        }
    }
    Some(Lag {
        seconds: best as f64 * block_s,
        correlation: best_r,
        at_zero,
    })
}

/// Pearson correlation of `g[i + lag]` with `a[i]` over the indices both have; `None` when
/// either is constant there.
fn correlation_at(g: &[f64], a: &[f64], lag: isize) -> Option<f64> {
    let n = g.len().min(a.len()) as isize;
    let (lo, hi) = (0.max(-lag), n.min(n - lag));
    if hi - lo < 4 {
        return None;
    }
    let pairs = (lo..hi).map(|i| (g[(i + lag) as usize], a[i as usize]));
    let m = (hi - lo) as f64;
    let (sg, sa) = pairs
        .clone()
        .fold((0.0, 0.0), |(x, y), (p, q)| (x + p, y + q));
    let (mg, ma) = (sg / m, sa / m);
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (p, q) in pairs {
        sxy += (p - mg) * (q - ma);
        sxx += (p - mg).powi(2);
        syy += (q - ma).powi(2);
    }
    (sxx > 0.0 && syy > 0.0).then(|| sxy / (sxx * syy).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A turn of 1 s in some 5-s slots (chosen by a fixed pseudo-random sequence, so that no
    /// shift repeats the pattern): the gyro's block means rise while the accelerometer's
    /// direction changes, the gyro's series shifted by `shift` blocks.
    fn series(shift: usize) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let n = 3000;
        let mut state = 0x2545_f491_u64;
        let slots: Vec<bool> = (0..n / 50 + 1)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                !state.is_multiple_of(3)
            })
            .collect();
        let turning = |i: usize| (i % 50) >= 20 && (i % 50) < 30 && slots[i / 50];
        let mut angle = 0.0f64;
        let acc: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                if turning(i) {
                    angle += 0.15;
                }
                [angle.cos(), angle.sin(), 0.1]
            })
            .collect();
        let gyro = (0..n)
            .map(|i| {
                let j = i.checked_sub(shift);
                let on = j.is_some_and(turning);
                [100.0 + if on { 50.0 } else { 0.0 }, -3.0, 7.0]
            })
            .collect();
        (gyro, acc)
    }

    #[test]
    fn a_shifted_gyro_is_found_at_its_shift_and_an_aligned_one_at_zero() {
        let (g, a) = series(0);
        let lag = lag_of(&g, &a, 0.1).unwrap();
        assert_eq!(lag.seconds, 0.0);
        assert!(lag.problem().is_none());
        let (g, a) = series(100);
        let lag = lag_of(&g, &a, 0.1).unwrap();
        assert!((lag.seconds - 10.0).abs() < 1e-9, "{lag:?}");
        let text = lag.problem().unwrap();
        assert!(
            text.starts_with("the gyro lags the accelerometer by 10.0 s"),
            "{text}"
        );
        // The accelerometer late instead: the gyro leads.
        let (g, a) = series(0);
        let a_late: Vec<[f64; 3]> = (0..a.len()).map(|i| a[i.saturating_sub(30)]).collect();
        let lag = lag_of(&g, &a_late, 0.1).unwrap();
        assert!((lag.seconds + 3.0).abs() < 1e-9, "{lag:?}");
        assert!(lag
            .problem()
            .unwrap()
            .starts_with("the gyro leads the accelerometer by 3.0 s"));
    }

    #[test]
    fn still_sensors_give_no_lag() {
        let g = vec![[1.0, 2.0, 3.0]; 100];
        let a = vec![[0.0, 0.0, 1.0]; 100];
        assert_eq!(lag_of(&g, &a, 0.1), None);
    }
}

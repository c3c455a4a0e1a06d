//! What `wiical correct` refuses ([`super`] module docs: units, a non-finite output, an
//! implausible calibration, an output beyond ±16 g), each written once as a fold over the
//! samples in their order ([`RangeFold`], [`UnitsCount`]) and a verdict on what it folded, by
//! the one pass every recording is corrected by ([`super::pass`]: held or read from a file).

use super::{CorrectError, PLAUSIBLE_MEDIAN_G};
use crate::input::recording::Recording;
use wiical_core::acceptance::{Acceptance, ConditionRange};
use wiical_core::Calibration;

/// The recording's extremes the acceptance conditions are taken from, folded sample by
/// sample.
#[derive(Debug, Clone, Copy)]
pub struct RangeFold {
    /// Smallest and largest finite reading (`f64::min`/`max` from ±∞).
    lo: f64,
    hi: f64,
    /// Smallest and largest finite temperature, `None` before the first.
    temp: Option<(f64, f64)>,
}

impl Default for RangeFold {
    fn default() -> Self {
        Self::new()
    }
}

impl RangeFold {
    /// No samples yet.
    pub fn new() -> Self {
        Self {
            lo: f64::INFINITY,
            hi: f64::NEG_INFINITY,
            temp: None,
        }
    }

    /// One sample's readings.
    pub fn push_reading(&mut self, m: &[f64; 3]) {
        for &v in m.iter().filter(|v| v.is_finite()) {
            (self.lo, self.hi) = (self.lo.min(v), self.hi.max(v));
        }
    }

    /// One sample's temperature, °C.
    pub fn push_temperature(&mut self, x: f64) {
        if x.is_finite() {
            self.temp = Some(self.temp.map_or((x, x), |(a, b)| (a.min(x), b.max(x))));
        }
    }

    /// The acceptance limits for a recording of these extremes lasting
    /// `max_time_s` (s since its first sample, the last sample's); `None` without a finite
    /// reading.
    pub fn limits(&self, max_time_s: Option<f64>) -> Option<Acceptance> {
        if self.lo > self.hi {
            return None;
        }
        let max_time_s = max_time_s.filter(|t| t.is_finite() && *t >= 0.0);
        let nunchuk = Acceptance::nunchuk();
        Some(Acceptance {
            input_range: (self.lo as f32, self.hi as f32),
            conditions: ConditionRange {
                max_time_s: max_time_s.unwrap_or(0.0) as f32,
                temperature_c: self.temp.map(|(a, b)| (a as f32, b as f32)),
            },
            nominal_zero: 0.0,
            max_offset: f32::MAX,
            nominal_sensitivity: 1.0,
            sensitivity_ratio: (f32::MIN, f32::MAX),
            max_cross_axis: f32::MAX,
            ..nunchuk
        })
    }
}

/// Refuses a calibration that fails the acceptance predicate over the recording's limits
/// (`None`: nothing to check): the ones `device put` uses ([`Acceptance::nunchuk`]: the ±16 g
/// output bound and the `θ₀` range) with the sensor-specific ones (offset from 512 counts,
/// sensitivity near 200 counts/g, cross-axis share) opened up and the input box and
/// conditions taken from the recording ([`RangeFold::limits`]): corrected output beyond ±16 g
/// somewhere in its input range and conditions, or an implausible `θ₀`.
pub fn check_plausible_within(
    cal: &Calibration,
    limits: Option<Acceptance>,
) -> Result<(), CorrectError> {
    let Some(limits) = limits else {
        return Ok(());
    };
    limits
        .check(cal, None)
        .map_err(|why| CorrectError::Implausible {
            why,
            lo: limits.input_range.0,
            hi: limits.input_range.1,
        })
}

/// `‖a‖` of one reading `m` corrected by the calibration's linear part alone (`K·(m − b)`,
/// in `f32` as the core computes it), g: what the units check takes the median of.
pub fn linear_norm(cal: &Calibration, m: &[f64; 3]) -> f64 {
    norm(cal.correct_linear(m.map(|v| v as f32)).map(f64::from))
}

/// Euclidean norm.
pub fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Refuses a recording whose readings, corrected by the calibration's linear part alone
/// (`K·(m − b)`: units are a linear matter, whatever the effect terms), have a median `‖a‖`
/// outside [`PLAUSIBLE_MEDIAN_G`]: the calibration was made from readings in other units
/// (described from its zero point and sensitivity and the raw readings' median magnitude).
pub fn check_units(cal: &Calibration, rec: &Recording) -> Result<(), CorrectError> {
    let median_g = median(rec.xyz.iter().map(|m| linear_norm(cal, m)).collect());
    units_verdict(cal, median_g, || {
        median(rec.xyz.iter().map(|m| norm(*m)).collect())
    })
}

/// The units check on the median `median_g` (`None`: no finite value, nothing to check);
/// `median_raw` gives the raw readings' median magnitude for the sentence.
pub fn units_verdict(
    cal: &Calibration,
    median_g: Option<f64>,
    median_raw: impl FnOnce() -> Option<f64>,
) -> Result<(), CorrectError> {
    let Some(median_g) = median_g else {
        return Ok(());
    };
    let (lo, hi) = PLAUSIBLE_MEDIAN_G;
    if (lo..=hi).contains(&median_g) {
        return Ok(());
    }
    let per_g = wiical_core::model::invert3(&cal.k()).map_or(f64::NAN, |d| {
        (0..3).map(|i| f64::from(d[(i, i)])).sum::<f64>() / 3.0
    });
    Err(CorrectError::UnitsMismatch {
        median_g: round3(median_g),
        zero: round3(cal.bias.iter().map(|b| f64::from(*b)).sum::<f64>() / 3.0),
        per_g: round3(per_g),
        median_raw: round3(median_raw().unwrap_or(f64::NAN)),
    })
}

/// Where the finite values of [`linear_norm`] lie against [`PLAUSIBLE_MEDIAN_G`], counted in
/// one pass: enough to pass the units check without the median itself whenever fewer than
/// half lie on either side (every recording in the right units), which a streamed recording
/// then needs no pass of its own for.
#[derive(Debug, Clone, Copy, Default)]
pub struct UnitsCount {
    /// Finite values.
    pub finite: usize,
    /// Finite values below the range.
    below: usize,
    /// Finite values above the range.
    above: usize,
}

impl UnitsCount {
    /// One value.
    pub fn push(&mut self, v: f64) {
        if v.is_finite() {
            self.finite += 1;
            self.below += usize::from(v < PLAUSIBLE_MEDIAN_G.0);
            self.above += usize::from(v > PLAUSIBLE_MEDIAN_G.1);
        }
    }

    /// True when the median ([`median`]: the mean of the values of rank `(n − 1)/2` and
    /// `n/2`) lies in the range for certain: both ranks' values do (a mean of two values in
    /// the range is in it), or there is no value (nothing to check).
    pub fn surely_passes(&self) -> bool {
        let n = self.finite;
        n == 0 || (self.below <= (n - 1) / 2 && self.above < n - n / 2)
    }
}

/// The refusal of the corrected sample `a` (0-based `i`, time `t`; the sentence says 1-based)
/// when a value is not finite, or, with `bounded`, beyond the ±16 g output bound of the
/// acceptance limits (host terms can push a sample there, which the acceptance predicate
/// does not see).
pub fn bad_output(i: usize, t: f64, a: &[f32; 3], bounded: bool) -> Option<CorrectError> {
    let bound = Acceptance::nunchuk().output_bound;
    for (j, v) in a.iter().enumerate() {
        let why = if !v.is_finite() {
            "not a finite number".to_string()
        } else if bounded && v.abs() > bound {
            format!("beyond ±{bound} g")
        } else {
            continue;
        };
        return Some(CorrectError::BadOutput {
            sample: i + 1,
            time_s: t,
            axis: ["x", "y", "z"][j],
            value: *v,
            why,
        });
    }
    None
}

/// The median of `v` (the mean of the middle two for an even count) of its finite values;
/// `None` without one.
pub fn median(mut v: Vec<f64>) -> Option<f64> {
    v.retain(|x| x.is_finite());
    (!v.is_empty()).then(|| crate::stats::median(&v))
}

/// Three significant figures, for a sentence.
fn round3(x: f64) -> f64 {
    format!("{x:.2e}").parse().unwrap_or(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The counts decide exactly when the sorted median is in range for certain: on every
    /// small set of values around the range's ends, `surely_passes` implies the median passes,
    /// and it fails to be sure only when one of the two middle values is out of range.
    #[test]
    fn the_counts_are_sure_only_when_the_median_is_in_range() {
        let pool = [0.1, 0.4999, 0.5, 0.7, 1.0, 1.9, 2.0, 2.0001, 3.0, f64::NAN];
        // Every list of up to four values from the pool (digits of a base-10 count).
        let sets = (0..4u32).flat_map(|len| {
            (0..10usize.pow(len)).map(move |code| {
                (0..len)
                    .map(|d| pool[code / 10usize.pow(d) % 10])
                    .collect::<Vec<f64>>()
            })
        });
        let (lo, hi) = PLAUSIBLE_MEDIAN_G;
        for s in sets {
            let mut c = UnitsCount::default();
            s.iter().for_each(|&v| c.push(v));
            let m = median(s.clone());
            let passes = m.is_none_or(|m| (lo..=hi).contains(&m));
            if c.surely_passes() {
                assert!(passes, "{s:?}: {m:?}");
            }
            let mut f: Vec<f64> = s.iter().copied().filter(|x| x.is_finite()).collect();
            f.sort_by(f64::total_cmp);
            let n = f.len();
            if n > 0 {
                let (a, b) = (f[(n - 1) / 2], f[n / 2]);
                let both_in = (lo..=hi).contains(&a) && (lo..=hi).contains(&b);
                assert_eq!(c.surely_passes(), both_in, "{s:?}");
            }
        }
    }
}

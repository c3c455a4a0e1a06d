//! The host terms' regressors sample by sample, for a recording read once in order
//! ([`super::pass`]): the same values, bit for bit, as the analysis's columns
//! ([`thermal::lagged`], [`thermal::sample_rates`]) — the same operations in the same order —
//! with memory bounded by ±15 s of samples.
//!
//! * Time and temperature are the sample's own.
//! * The lagged temperature ([`thermal::lagged`]) is a recursion: one state per term.
//! * dT/dt ([`thermal::sample_rates`]) is the least-squares slope over the samples within
//!   ±[`thermal::RATE_SPAN_S`]/2, from differences of running sums taken from the first
//!   sample. [`RateRing`] holds each sample's running sums (before it) from the oldest
//!   sample still inside the span to the first one past it, so a sample is given out once a
//!   later one lies beyond its span (or the file ended): the sums at both ends of its span
//!   are then the ones the held prefix array has at those indices.

use super::CorrectError;
use crate::output::host_term_checks::{HostTerm, Regressor};
use crate::search::thermal;
use std::collections::VecDeque;

/// Most samples [`RateRing`] holds: the samples within 30 s (35 kHz of samples, or a time
/// column in other units than seconds); past it the rate is refused rather than memory
/// growing with the file ([`CorrectError::RateSpanTooDense`]).
pub const MAX_RATE_SPAN_SAMPLES: usize = 1 << 20;

/// What one host term's regressor is per sample.
#[derive(Debug, Clone, Copy)]
enum Kind {
    /// An unknown family (refused when a file is read): zero.
    Zero,
    /// Seconds since the first sample.
    Time,
    /// The sample's temperature, °C.
    Temperature,
    /// The temperature through a first-order lag: (time constant s, state).
    Lagged(f64, Lag),
    /// dT/dt over ±15 s, °C/s.
    Rate,
}

/// [`thermal::lagged`]'s recursion, one sample at a time.
#[derive(Debug, Clone, Copy, Default)]
struct Lag {
    /// The lagged temperature and the previous sample's time (`None` before the first).
    state: Option<(f64, f64)>,
}

impl Lag {
    fn next(&mut self, t: f64, x: f64, tau_s: f64) -> f64 {
        // Started at the first sample's temperature and time, as the held recursion.
        let (mut y, prev_t) = self.state.unwrap_or((x, t));
        let dt = (t - prev_t).max(0.0);
        y += (1.0 - (-dt / tau_s).exp()) * (x - y);
        self.state = Some((y, t));
        y
    }
}

/// The host terms' regressors for a recording read sample by sample.
#[derive(Debug, Clone)]
pub struct Regressors {
    kinds: Vec<Kind>,
    /// The first temperature-rate term's name (the one a refusal names).
    rate_term: Option<String>,
}

impl Regressors {
    /// The regressors of `terms` for a recording with a temperature column or not
    /// (`has_temp`); a term needing the temperature without one is refused (the first such
    /// term, named).
    pub fn new(terms: &[HostTerm], has_temp: bool) -> Result<Self, CorrectError> {
        let mut kinds = Vec::with_capacity(terms.len());
        let mut rate_term = None;
        for t in terms {
            let Some((regressor, _, _)) = t.shape() else {
                kinds.push(Kind::Zero);
                continue;
            };
            if !has_temp && regressor != Regressor::Time {
                return Err(CorrectError::NeedsTemperature {
                    term: t.name.clone(),
                });
            }
            kinds.push(match regressor {
                Regressor::Time => Kind::Time,
                Regressor::Temperature => Kind::Temperature,
                Regressor::LaggedTemperature(tau) => Kind::Lagged(tau, Lag::default()),
                Regressor::TemperatureRate => {
                    rate_term.get_or_insert_with(|| t.name.clone());
                    Kind::Rate
                }
            });
        }
        Ok(Self { kinds, rate_term })
    }

    /// The first temperature-rate term's name, if any.
    pub fn rate_term(&self) -> Option<&str> {
        self.rate_term.as_deref()
    }

    /// True when a term needs dT/dt (samples are then given out ±15 s late: [`RateRing`]).
    pub fn needs_rate(&self) -> bool {
        self.rate_term.is_some()
    }

    /// The next sample's regressor values into `xs` (one per term): `since` s after the first
    /// sample, temperature `temp` (0 without one: no term reads it then), dT/dt `rate`
    /// ([`RateRing`]) of 0-based sample `i`. An undefined rate a term needs is refused, naming
    /// the first rate term and the sample.
    pub fn next(
        &mut self,
        i: usize,
        since: f64,
        temp: Option<f64>,
        rate: Option<f64>,
        xs: &mut [f64],
    ) -> Result<(), CorrectError> {
        if let (Some(term), None) = (&self.rate_term, rate) {
            return Err(CorrectError::RateUndefined {
                term: term.clone(),
                sample: i,
            });
        }
        let theta = temp.unwrap_or(0.0);
        for (x, k) in xs.iter_mut().zip(self.kinds.iter_mut()) {
            *x = match k {
                Kind::Zero => 0.0,
                Kind::Time => since,
                Kind::Temperature => theta,
                Kind::Lagged(tau, lag) => lag.next(since, theta, *tau),
                Kind::Rate => rate.unwrap_or(0.0),
            };
        }
        Ok(())
    }

    /// Terms.
    pub fn len(&self) -> usize {
        self.kinds.len()
    }
}

/// One sample in the ring: its time since the first sample, the running sums before it
/// (`[1, t, y, t², t·y]` about the first sample, [`thermal::sample_rates`]) and what the
/// caller keeps with it.
#[derive(Debug, Clone, Copy)]
struct Entry<P> {
    since: f64,
    before: [f64; 5],
    payload: P,
}

/// A sample given out by [`RateRing::pop`]: its 0-based index, what was pushed with it and
/// its dT/dt (`None` where its span has no time spread; always `None` when rates are not
/// asked for).
#[derive(Debug, Clone, Copy)]
pub struct Ready<P> {
    /// 0-based sample index.
    pub index: usize,
    /// What was pushed with it.
    pub payload: P,
    /// dT/dt over its ±15 s, °C/s.
    pub rate: Option<f64>,
}

/// The samples of the last ±15 s, their running sums, and the samples waiting for the end of
/// their span (module docs). Without rates asked for, a sample is given out as soon as it is
/// pushed and nothing is held.
#[derive(Debug)]
pub struct RateRing<P> {
    rates: bool,
    /// Most samples held ([`MAX_RATE_SPAN_SAMPLES`], or none for samples held already).
    max: usize,
    entries: VecDeque<Entry<P>>,
    /// Global index of `entries[0]`.
    base: usize,
    /// Samples pushed.
    pushed: usize,
    /// Next sample to give out.
    next: usize,
    /// First sample past the span of the last one given out.
    hi: usize,
    /// Running sums of every sample pushed.
    total: [f64; 5],
    /// The first sample's time and temperature (the sums' origin).
    origin: Option<(f64, f64)>,
}

impl<P: Copy> RateRing<P> {
    /// An empty ring; `rates`: whether dT/dt is asked for.
    pub fn new(rates: bool) -> Self {
        Self {
            rates,
            max: MAX_RATE_SPAN_SAMPLES,
            entries: VecDeque::new(),
            base: 0,
            pushed: 0,
            next: 0,
            hi: 0,
            total: [0.0; 5],
            origin: None,
        }
    }

    /// [`RateRing::new`] without a bound on the samples held: for a recording held in memory
    /// already, which the ring's copies of ±15 s cannot outgrow.
    pub fn unbounded(rates: bool) -> Self {
        Self {
            max: usize::MAX,
            ..Self::new(rates)
        }
    }

    /// The next sample: `since` s after the first, temperature `temp` °C (used only with
    /// rates). Refused when the ring would hold more than its bound
    /// ([`MAX_RATE_SPAN_SAMPLES`]): the sentence names `term`.
    pub fn push(
        &mut self,
        since: f64,
        temp: f64,
        payload: P,
        term: &dyn Fn() -> String,
    ) -> Result<(), CorrectError> {
        let before = self.total;
        if self.rates {
            let (t0, y0) = *self.origin.get_or_insert((since, temp));
            let (t, y) = (since - t0, temp - y0);
            let add = [1.0, t, y, t * t, t * y];
            self.total = std::array::from_fn(|k| before[k] + add[k]);
            if self.entries.len() >= self.max {
                return Err(CorrectError::RateSpanTooDense {
                    term: term(),
                    sample: self.next,
                    max: MAX_RATE_SPAN_SAMPLES,
                });
            }
        }
        self.entries.push_back(Entry {
            since,
            before,
            payload,
        });
        self.pushed += 1;
        Ok(())
    }

    /// The next sample whose span is complete (`ended`: no sample follows), if any.
    pub fn pop(&mut self, ended: bool) -> Option<Ready<P>> {
        if self.next >= self.pushed {
            return None;
        }
        let at = |ring: &Self, i: usize| ring.entries[i - ring.base];
        let c = at(self, self.next).since;
        let half = 0.5 * thermal::RATE_SPAN_S;
        if !self.rates {
            let e = self.entries.pop_front()?;
            self.base += 1;
            self.next += 1;
            return Some(Ready {
                index: self.next - 1,
                payload: e.payload,
                rate: None,
            });
        }
        let newest = self.entries.back()?.since;
        if !ended && newest <= c + half {
            return None; // its span may hold samples not read yet
        }
        // The first sample at or after c − half: the held `partition_point(t < c − half)`.
        while self.base < self.next && self.entries.front()?.since < c - half {
            self.entries.pop_front();
            self.base += 1;
        }
        let lo = self.entries.front()?.before;
        self.hi = self.hi.max(self.base);
        while self.hi < self.pushed && at(self, self.hi).since <= c + half {
            self.hi += 1;
        }
        let hi = if self.hi < self.pushed {
            at(self, self.hi).before
        } else {
            self.total
        };
        let payload = at(self, self.next).payload;
        self.next += 1;
        Some(Ready {
            index: self.next - 1,
            payload,
            rate: slope_of(&lo, &hi),
        })
    }
}

/// The least-squares slope from the running sums at a span's two ends, as
/// [`thermal::sample_rates`] computes it.
fn slope_of(lo: &[f64; 5], hi: &[f64; 5]) -> Option<f64> {
    let [n, st, sy, stt, sty]: [f64; 5] = std::array::from_fn(|k| hi[k] - lo[k]);
    let sxx = stt - st * st / n;
    let sxy = sty - st * sy / n;
    (n > 0.0 && sxx > 1e-12 * stt.max(1e-300)).then(|| sxy / sxx)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every sample's rate and lagged temperature, given out by the ring, are the held
    /// functions' bit for bit: uneven times with gaps longer than the span (undefined rates),
    /// repeated times, a warm-up curve; with rates asked for or not.
    #[test]
    fn streamed_regressors_are_the_held_ones_bit_for_bit() {
        let mut times = Vec::new();
        let mut t = 1000.0;
        for i in 0..6000 {
            t += match i % 7 {
                0 => 0.0,
                1 => 0.013,
                _ => 0.021,
            };
            if i == 2500 {
                t += 40.0; // a gap longer than the span
            }
            if i == 2501 {
                t += 50.0; // a sample alone: no spread about it
            }
            times.push(t);
        }
        let t0 = times[0];
        let since: Vec<f64> = times.iter().map(|t| t - t0).collect();
        let temp: Vec<f64> = since
            .iter()
            .map(|s| 25.0 + 8.0 * (1.0 - (-s / 90.0).exp()) + 0.01 * (s * 7.0).sin())
            .collect();
        let rates = thermal::sample_rates(&since, &temp);
        assert!(rates.iter().any(Option::is_none) && rates.iter().any(Option::is_some));
        let lagged = thermal::lagged(&since, &temp, 37.0);
        for want_rates in [true, false] {
            let mut ring = RateRing::new(want_rates);
            let mut lag = Lag::default();
            let mut got = Vec::new();
            let mut take = |r: Ready<usize>| {
                let i = r.payload;
                assert_eq!(r.index, i);
                got.push((r.rate, lag.next(since[i], temp[i], 37.0)));
            };
            for (i, (&s, &x)) in since.iter().zip(&temp).enumerate() {
                ring.push(s, x, i, &String::new).unwrap();
                while let Some(r) = ring.pop(false) {
                    take(r);
                }
                // Held: at most the samples of the span and one past it.
                assert!(ring.entries.len() <= 30 * 60 + 2, "{}", ring.entries.len());
            }
            while let Some(r) = ring.pop(true) {
                take(r);
            }
            assert_eq!(got.len(), since.len());
            for (i, (rate, lag)) in got.iter().enumerate() {
                let want = if want_rates { rates[i] } else { None };
                assert_eq!(rate.map(f64::to_bits), want.map(f64::to_bits), "{i}");
                assert_eq!(lag.to_bits(), lagged[i].to_bits(), "{i}");
            }
        }
    }

    /// More samples within the span than the ring holds: refused, naming the term.
    #[test]
    fn a_span_too_dense_is_refused() {
        let mut ring = RateRing::new(true);
        let term = || "temperature-rate (z)".to_string();
        let e = (0..=MAX_RATE_SPAN_SAMPLES)
            .try_for_each(|_| ring.push(0.0, 20.0, (), &term))
            .unwrap_err();
        assert!(e.to_string().contains("temperature-rate (z)"), "{e}");
    }
}

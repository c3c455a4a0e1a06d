//! GGIR's still epochs of a raw recording, the input of its free-living autocalibration (van
//! Hees et al. 2014; GGIR `g.calibrate`): the recording is cut into consecutive 10-s epochs;
//! an epoch is **still** when the standard deviation of every axis is below 13 mg and the
//! absolute mean of every axis below 2 g (a mean beyond the range is a clipped or broken
//! sample stream, not gravity). The still epochs' means, SDs, sample counts, mean temperatures
//! and centre times become a window-mean table ([`WindowTable`]), analysed exactly as a GGIR
//! sphere-data file ([`crate::input::window_means`]: the autocalibration report and the residual
//! analysis with temperature).
//!
//! GGIR cuts epochs on its resampled grid by sample count; here the samples keep their own
//! times, so an epoch is `[t₀ + 10k, t₀ + 10(k+1))` and counts only when it holds at least 90 %
//! of the samples the rate promises (an epoch across a gap of skipped blocks is left out
//! rather than judged on a fraction of its samples).

use crate::autocal::MIN_EPOCHS;
use crate::error::input::InputError;
use crate::error::Result;
use crate::input::recording::Recording;
use crate::input::table::WindowTable;
use crate::report::contract::WindowInputInfo;

/// What too few still epochs call for when nothing was wrong with the recording.
pub(crate) const LONGER: &str = "a longer recording (days of wear) is needed";

/// The still-epoch rule (defaults: GGIR's).
#[derive(Debug, Clone)]
pub struct EpochOptions {
    /// Epoch length, s (10).
    pub epoch_s: f64,
    /// Largest per-axis SD of a still epoch, g (0.013).
    pub sd_max_g: f64,
    /// Largest per-axis |mean|, g (2).
    pub mean_max_g: f64,
    /// Smallest fraction of the expected samples an epoch must hold (0.9).
    pub min_fill: f64,
}

impl Default for EpochOptions {
    fn default() -> Self {
        Self {
            epoch_s: 10.0,
            sd_max_g: 0.013,
            mean_max_g: 2.0,
            min_fill: 0.9,
        }
    }
}

/// One epoch's statistics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Epoch {
    /// Centre time, s (the recording's clock).
    pub t_centre: f64,
    /// Per-axis mean, g.
    pub mean: [f64; 3],
    /// Per-axis sample SD (n − 1), g.
    pub sd: [f64; 3],
    /// Samples.
    pub count: usize,
    /// Mean temperature, °C (NaN without temperature).
    pub temp: f64,
}

/// What the search found.
#[derive(Debug, Clone, Default)]
pub struct StillEpochs {
    /// The still epochs, in time order.
    pub still: Vec<Epoch>,
    /// Complete epochs examined (still or not).
    pub examined: usize,
    /// Seconds from the first to the last sample.
    pub span_s: f64,
}

/// Running sums of one epoch (Welford's update: no cancellation over 1000 samples near 1 g).
#[derive(Default)]
struct Acc {
    n: usize,
    mean: [f64; 3],
    m2: [f64; 3],
    temp: f64,
}

impl Acc {
    fn push(&mut self, x: [f64; 3], temp: f64) {
        self.n += 1;
        let n = self.n as f64;
        for (a, &xa) in x.iter().enumerate() {
            let d = xa - self.mean[a];
            self.mean[a] += d / n;
            self.m2[a] += d * (xa - self.mean[a]);
        }
        self.temp += temp;
    }

    fn epoch(&self, t_centre: f64) -> Epoch {
        let n = self.n as f64;
        Epoch {
            t_centre,
            mean: self.mean,
            sd: self.m2.map(|m| (m / (n - 1.0).max(1.0)).sqrt()),
            count: self.n,
            temp: self.temp / n,
        }
    }
}

/// The still-epoch search fed one sample at a time, in time order: memory is the still
/// epochs found (a few per minute of wear), never the samples, so a week-long raw file is
/// searched while it is read ([`crate::input::raw::load`]).
pub struct EpochScan {
    t0: f64,
    needed: usize,
    acc: Acc,
    k_cur: u64,
    out: StillEpochs,
    opts: EpochOptions,
}

impl EpochScan {
    /// A search whose epochs start at `t0` (the first sample's time, s) for samples at
    /// `rate_hz`: an epoch counts when it holds at least `min_fill` of the samples promised.
    pub fn new(t0: f64, rate_hz: f64, opts: &EpochOptions) -> Self {
        Self {
            t0,
            needed: (opts.min_fill * opts.epoch_s * rate_hz).ceil().max(2.0) as usize,
            acc: Acc::default(),
            k_cur: 0,
            out: StillEpochs::default(),
            opts: opts.clone(),
        }
    }

    /// The next sample (time `t` s, not before the previous one's; `x` in g; `temp` °C or NaN).
    pub fn push(&mut self, t: f64, x: [f64; 3], temp: f64) {
        let k = ((t - self.t0) / self.opts.epoch_s).floor().max(0.0) as u64;
        if k != self.k_cur {
            self.close();
            self.acc = Acc::default();
            self.k_cur = k;
        }
        self.acc.push(x, temp);
    }

    /// Judges the epoch in progress (when it holds enough samples).
    fn close(&mut self) {
        if self.acc.n < self.needed {
            return;
        }
        self.out.examined += 1;
        let e = self
            .acc
            .epoch(self.t0 + (self.k_cur as f64 + 0.5) * self.opts.epoch_s);
        let still = e.sd.iter().all(|&s| s < self.opts.sd_max_g)
            && e.mean.iter().all(|&m| m.abs() < self.opts.mean_max_g);
        if still {
            self.out.still.push(e);
        }
    }

    /// The search's result once the last sample (at `t_end`, s) was pushed; the last epoch
    /// counts only when it ends inside the data.
    pub fn finish(mut self, t_end: f64, rate_hz: f64) -> StillEpochs {
        self.out.span_s = t_end - self.t0;
        if t_end - self.t0 >= (self.k_cur as f64 + 1.0) * self.opts.epoch_s - 1.0 / rate_hz {
            self.close();
        }
        self.out
    }
}

/// The still epochs of samples `xyz` (g) at times `t` (s, rising) sampled at `rate_hz`, with
/// their temperatures when given: [`EpochScan`] over samples held in memory.
pub fn still_epochs(
    t: &[f64],
    xyz: &[[f64; 3]],
    temp: Option<&[f64]>,
    rate_hz: f64,
    opts: &EpochOptions,
) -> StillEpochs {
    let (Some(&t0), Some(&t_end)) = (t.first(), t.last()) else {
        return StillEpochs::default();
    };
    let mut scan = EpochScan::new(t0, rate_hz, opts);
    for (i, (&ti, &x)) in t.iter().zip(xyz).enumerate() {
        scan.push(ti, x, temp.map_or(f64::NAN, |tp| tp[i]));
    }
    scan.finish(t_end, rate_hz)
}

/// The window-mean table of the still epochs `found`; `like` carries what the table keeps of
/// the recording (axis names, the reader's notes and info; `temp: Some` when it had
/// temperatures). Too few epochs is [`InputError::TooFewStillEpochs`].
pub(crate) fn table_of(
    found: StillEpochs,
    like: Recording,
    source: &str,
    opts: &EpochOptions,
) -> Result<WindowTable> {
    if found.still.len() < MIN_EPOCHS {
        return Err(InputError::TooFewStillEpochs {
            found: found.still.len(),
            examined: found.examined,
            needed: MIN_EPOCHS,
            span_s: found.span_s,
            cause: LONGER.into(),
        }
        .into());
    }
    let means = Recording {
        t: Some(found.still.iter().map(|e| e.t_centre).collect()),
        xyz: found.still.iter().map(|e| e.mean).collect(),
        temp: like
            .temp
            .as_ref()
            .map(|_| found.still.iter().map(|e| e.temp).collect()),
        axis_columns: like.axis_columns,
        // The reader's warnings (skipped blocks, gaps) stay with the table: the CLI shows them.
        notes: like.notes,
        info: like.info,
        sample_rate_hz: None,
        ..Recording::default()
    };
    let description = format!(
        "{} still {}-s epochs (SD < {} mg on every axis, |mean| < {} g) of {} complete epochs in {:.1} h of {source}: analysed as window means, no static detection",
        found.still.len(),
        opts.epoch_s,
        opts.sd_max_g * 1000.0,
        opts.mean_max_g,
        found.examined,
        found.span_s / 3600.0
    );
    Ok(WindowTable {
        info: WindowInputInfo {
            rows: found.still.len(),
            sd_columns: None,
            count_column: None,
            forced: false,
            description,
        },
        sd: Some(found.still.iter().map(|e| e.sd).collect()),
        count: Some(found.still.iter().map(|e| e.count).collect()),
        recording: means,
    })
}

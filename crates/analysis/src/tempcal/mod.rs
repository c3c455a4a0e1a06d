//! `wiical tempcal`: the bias of a still sensor against its temperature during a warm-up, as
//! ArduPilot's TCAL and PX4's thermal calibration learn it, with the polynomial's order chosen
//! by held-out error instead of fixed at 3.
//!
//! Model, per axis `j` and block `i` (a block = the mean of about a second of samples):
//!
//! ```text
//! m_ij = o_{p(i),j} + Σ_{k=1..K_j} c_jk · ΔT_i^k + e_ij,      ΔT = T − T_ref
//! ```
//!
//! `o_p` is the constant of pose `p` (gravity's component on that axis plus the bias at
//! `T_ref`): one per static pose, so several poses of one warm-up share the polynomial. The
//! polynomial has no constant term (it is confounded with the pose constants; both autopilots
//! leave the constant to their ordinary accelerometer calibration). The correction is
//! `m − Σ c_k ΔT^k`, ArduPilot's and PX4's sign ([`params`]).
//!
//! Order `K_j` ∈ 1..=3: the record is cut into [`TempcalOptions::segments`] contiguous
//! segments of blocks (by time); each is left out in turn, the model fitted to the rest
//! predicts it (pose constants from the pose's other blocks), and the order with the lowest
//! held-out RMS wins; one within [`TIE_REL`] of a lower order's counts as a tie and the lower
//! order is taken. Leaving out the first or last segment asks the polynomial to extrapolate
//! to the coldest or warmest part of the warm-up, which is where a needless cubic fails.
//!
//! Range check as TCAL (`TEMP_RANGE_MIN` = 10 °C): a record spanning less is refused, saying
//! how much was seen.

pub(crate) mod fit;
pub mod params;
pub(crate) mod request;

use crate::input::recording::{infer_units, Recording};
use fit::{fit_axis, heldout_rms, segment_of};
use serde::Serialize;

/// ArduPilot's fixed TCAL reference temperature (`TEMP_REFERENCE`), °C: the default `T_ref`.
pub const TEMP_REF_C: f64 = 35.0;
/// The smallest temperature range accepted, °C (ArduPilot TCAL's `TEMP_RANGE_MIN`).
pub const MIN_RANGE_C: f64 = 10.0;
/// Highest polynomial order tried (both autopilots store up to the cube).
pub const MAX_ORDER: usize = 3;
/// Held-out RMS within this fraction of a lower order's is a tie (the lower order is taken):
/// a difference of under 1 % is within the scatter of the cross-validation itself.
pub const TIE_REL: f64 = 0.01;
/// A block whose within-block SD exceeds this many times the median block SD is taken as
/// moving (a hand, a turn between poses) and left out.
pub const MOVING_FACTOR: f64 = 5.0;
/// [`TempcalAxis::noise_ratio`] above this: the record is not a still warm-up (the CLI warns).
/// Between what still sensors give and what a worn one gives: white noise 1.0 (simulation);
/// the static ADIS16405 log with a temperature ramp put on it 1.08–1.22 over 30 min and
/// 1.29–1.70 over 2.8 h (its slow drift is not all a cubic); the GGIR wrist epochs 2.4–2.6
/// (docs/tempcal.md). A heuristic: no real still warm-up with temperatures was at hand.
pub const STILL_RATIO: f64 = 2.0;
/// Most blocks used (a day at 1 block/s); more would only cost time.
pub const MAX_BLOCKS: usize = 200_000;

/// Settings of [`fit_warmup`].
#[derive(Debug, Clone)]
pub struct TempcalOptions {
    /// Reference temperature `T_ref`, °C.
    pub t_ref_c: f64,
    /// Contiguous segments for the leave-one-segment-out choice of order.
    pub segments: usize,
    /// Block length, s: samples are averaged over blocks this long before the fit.
    pub block_s: f64,
    /// A block whose direction differs from its pose's first block by more than this starts a
    /// new pose, degrees.
    pub pose_deg: f64,
    /// Sample rate when the recording has no time column or `Fs`, Hz.
    pub default_rate_hz: f64,
}

impl Default for TempcalOptions {
    fn default() -> Self {
        Self {
            t_ref_c: TEMP_REF_C,
            segments: 8,
            block_s: 1.0,
            pose_deg: 10.0,
            default_rate_hz: 100.0,
        }
    }
}

/// Why a temperature calibration cannot be made. Not a variant of [`crate::Error`]: this
/// module imports only [`crate::input::recording`], and the crate error importing it back would be an
/// import circle (`scripts/module-graph`).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TempcalError {
    /// No temperature column.
    #[error("the recording has no temperature column (temp, temperature, temp_c): a temperature calibration needs the sensor's temperature on every row")]
    NoTemperature,
    /// A temperature that is not a number.
    #[error("row {row}'s temperature is not a finite number")]
    NonFiniteTemperature {
        /// 1-based data row.
        row: usize,
    },
    /// Every temperature lies where kelvin put a sensor's working range (200–400): as °C it
    /// would be hotter than any accelerometer runs, and the coefficients, reference
    /// temperature and range written as °C would be ~273 °C off.
    #[error("the temperature column runs from {min:.1} to {max:.1}, which as °C is hotter than any accelerometer works: it looks like kelvin; give the temperature in °C (subtract 273.15)")]
    Kelvin {
        /// Lowest temperature in the file.
        min: f64,
        /// Highest temperature in the file.
        max: f64,
    },
    /// Too little temperature range (TCAL's check).
    #[error("the temperature spans only {seen_c:.1} °C ({min_c:.1} to {max_c:.1} °C) in the still blocks; a temperature calibration needs at least {needed_c:.0} °C (as ArduPilot's TCAL): record a warm-up from a cold start")]
    RangeTooSmall {
        /// Range seen, °C.
        seen_c: f64,
        /// Lowest temperature, °C.
        min_c: f64,
        /// Highest temperature, °C.
        max_c: f64,
        /// Needed, °C.
        needed_c: f64,
    },
    /// Too few still blocks for the fit and its cross-validation.
    #[error("only {blocks} still blocks in poses held for at least two blocks (of {total} blocks, {moving} moving); the order choice needs at least {needed}: record a longer still warm-up")]
    TooFewBlocks {
        /// Usable blocks.
        blocks: usize,
        /// All blocks.
        total: usize,
        /// Blocks left out as moving.
        moving: usize,
        /// Fewest accepted.
        needed: usize,
    },
    /// No order could predict any held-out segment.
    #[error("no left-out segment could be predicted (every pose lies inside one segment): hold each pose through a good part of the warm-up")]
    NothingHeldOut,
    /// A setting out of range.
    #[error("{what}")]
    Setting {
        /// What is wrong, in a sentence.
        what: String,
    },
}

/// One axis's result.
#[derive(Debug, Clone, Serialize)]
pub struct TempcalAxis {
    /// The column.
    pub column: String,
    /// The chosen order (1..=3).
    pub order: usize,
    /// `c_1..c_order`: bias change per °C^k about `t_ref_c`, in the file's units.
    pub coefficients: Vec<f64>,
    /// Their standard errors (white-noise least squares on the block means).
    pub std_errors: Vec<f64>,
    /// Held-out RMS of orders 1, 2, 3 (null where no segment could be predicted), file units.
    pub heldout_rms: Vec<Option<f64>>,
    /// In-sample RMS of the chosen fit, file units.
    pub residual_rms: f64,
    /// In-sample RMS over the block-to-block noise (RMS of successive differences within a
    /// pose, /√2): ≈ 1 for a still sensor whose bias follows the temperature; well above 1
    /// (see [`STILL_RATIO`]) when the poses were not still or the bias depends on more than
    /// the temperature. Null when no pose has two successive blocks.
    pub noise_ratio: Option<f64>,
    /// The order-1 fit's slope and its standard error (what a calibration file's `bias_temp`
    /// holds), file units per °C.
    pub linear: [f64; 2],
    /// Block temperatures and values minus their pose constants (for the plot).
    #[serde(skip)]
    pub points: Vec<(f64, f64)>,
}

impl TempcalAxis {
    /// The fitted bias change at `temp_c` relative to `t_ref`, file units.
    pub fn bias_at(&self, temp_c: f64, t_ref_c: f64) -> f64 {
        let dt = temp_c - t_ref_c;
        self.coefficients
            .iter()
            .enumerate()
            .map(|(k, c)| c * dt.powi(k as i32 + 1))
            .sum()
    }
}

/// The result of `wiical tempcal`.
#[derive(Debug, Clone, Serialize)]
pub struct TempcalReport {
    /// Units of the values: `g`, `m/s^2` or `raw` (inferred from the mean magnitude).
    pub units: String,
    /// Samples read.
    pub samples: usize,
    /// Sample rate used, Hz.
    pub sample_rate_hz: f64,
    /// Samples per block.
    pub block_samples: usize,
    /// Blocks used in the fit.
    pub blocks: usize,
    /// Blocks left out as moving (or straddling two pose labels).
    pub blocks_moving: usize,
    /// Blocks left out because their pose was held for one block only.
    pub blocks_single: usize,
    /// Static poses found (each with its own constant).
    pub poses: usize,
    /// Reference temperature, °C.
    pub t_ref_c: f64,
    /// Lowest block temperature, °C.
    pub t_min_c: f64,
    /// Highest block temperature, °C.
    pub t_max_c: f64,
    /// Segments of the leave-one-segment-out order choice.
    pub segments: usize,
    /// Relative held-out RMS difference counted as a tie.
    pub tie_tolerance: f64,
    /// One per axis.
    pub axes: Vec<TempcalAxis>,
}

/// A block: about `block_s` of samples averaged.
#[derive(Debug, Clone, Copy)]
struct Block {
    temp_c: f64,
    xyz: [f64; 3],
    sd: Option<f64>,
    label: Option<usize>,
}

/// The still blocks with their poses, and what was left out.
struct Blocks {
    kept: Vec<Block>,
    pose: Vec<usize>,
    poses: usize,
    total: usize,
    moving: usize,
    single: usize,
    per_block: usize,
    rate_hz: f64,
}

/// Fits the bias against temperature of a still (one or more poses) warm-up recording.
pub fn fit_warmup(
    rec: &Recording,
    opts: &TempcalOptions,
) -> std::result::Result<TempcalReport, TempcalError> {
    check_options(opts)?;
    let b = blocks(rec, opts)?;
    let needed = 2 * opts.segments;
    if b.kept.len() < needed.max(MAX_ORDER + 2) {
        return Err(TempcalError::TooFewBlocks {
            blocks: b.kept.len(),
            total: b.total,
            moving: b.moving,
            needed: needed.max(MAX_ORDER + 2),
        });
    }
    let temps: Vec<f64> = b.kept.iter().map(|k| k.temp_c).collect();
    let (t_min, t_max) = temps
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, z), t| {
            (a.min(*t), z.max(*t))
        });
    if t_max - t_min < MIN_RANGE_C {
        return Err(TempcalError::RangeTooSmall {
            seen_c: t_max - t_min,
            min_c: t_min,
            max_c: t_max,
            needed_c: MIN_RANGE_C,
        });
    }
    let seg = segment_of(b.kept.len(), opts.segments);
    let axes = (0..3)
        .map(|j| axis_report(rec, &b, &temps, &seg, j, opts))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(TempcalReport {
        units: units_of(rec, &b.kept).into(),
        samples: rec.len(),
        sample_rate_hz: b.rate_hz,
        block_samples: b.per_block,
        blocks: b.kept.len(),
        blocks_moving: b.moving,
        blocks_single: b.single,
        poses: b.poses,
        t_ref_c: opts.t_ref_c,
        t_min_c: t_min,
        t_max_c: t_max,
        segments: opts.segments,
        tie_tolerance: TIE_REL,
        axes,
    })
}

/// Every setting through the range checks the CLI's flags and the Python keywords share.
fn check_options(o: &TempcalOptions) -> std::result::Result<(), TempcalError> {
    check_tref_c(o.t_ref_c)?;
    if !(2..=50).contains(&o.segments) {
        return Err(setting("the number of segments must be from 2 to 50"));
    }
    crate::detect::windows::check_duration_s(o.block_s)
        .map_err(|e| setting(&format!("the block length: {e}")))?;
    check_pose_deg(o.pose_deg)?;
    crate::detect::windows::check_rate_hz(o.default_rate_hz)
        .map_err(|e| setting(&format!("the sample rate: {e}")))?;
    Ok(())
}

fn setting(what: &str) -> TempcalError {
    TempcalError::Setting {
        what: what.to_string(),
    }
}

/// The reference temperature `T_ref`, °C: from −100 to 200 (beyond any sensor's rated range,
/// so a value outside is a typo, not a setting).
pub fn check_tref_c(v: f64) -> std::result::Result<f64, TempcalError> {
    if v.is_finite() && (-100.0..=200.0).contains(&v) {
        Ok(v)
    } else {
        Err(setting(
            "the reference temperature must be a number from −100 to 200 °C",
        ))
    }
}

/// The pose-change angle, degrees: above 0 (every block a pose) and below 180 (one pose).
pub fn check_pose_deg(v: f64) -> std::result::Result<f64, TempcalError> {
    if v.is_finite() && v > 0.0 && v < 180.0 {
        Ok(v)
    } else {
        Err(setting("the pose angle must be above 0 and below 180°"))
    }
}

/// One axis: the held-out RMS of every order, the chosen order's fit and the linear fit.
fn axis_report(
    rec: &Recording,
    b: &Blocks,
    temps: &[f64],
    seg: &[usize],
    j: usize,
    opts: &TempcalOptions,
) -> std::result::Result<TempcalAxis, TempcalError> {
    let y: Vec<f64> = b.kept.iter().map(|k| k.xyz[j]).collect();
    let data = fit::AxisData {
        temp_c: temps,
        y: &y,
        pose: &b.pose,
        poses: b.poses,
        t_ref_c: opts.t_ref_c,
    };
    let rms: Vec<Option<f64>> = (1..=MAX_ORDER)
        .map(|k| heldout_rms(&data, seg, opts.segments, k))
        .collect();
    let best = rms.iter().flatten().fold(f64::INFINITY, |m, r| m.min(*r));
    if !best.is_finite() {
        return Err(TempcalError::NothingHeldOut);
    }
    let order = (1..=MAX_ORDER)
        .find(|k| rms[k - 1].is_some_and(|r| r <= best * (1.0 + TIE_REL)))
        .unwrap_or(1);
    let all = vec![true; y.len()];
    let chosen = fit_axis(&data, &all, order).ok_or(TempcalError::NothingHeldOut)?;
    let linear = fit_axis(&data, &all, 1).ok_or(TempcalError::NothingHeldOut)?;
    let residual_rms = (chosen.rss / y.len() as f64).sqrt();
    let points = (0..y.len())
        .map(|i| {
            (
                temps[i],
                y[i] - chosen.offsets[b.pose[i]].unwrap_or(f64::NAN),
            )
        })
        .collect();
    Ok(TempcalAxis {
        column: rec.axis_columns[j].clone(),
        order,
        coefficients: chosen.coef.clone(),
        std_errors: chosen.se.clone(),
        heldout_rms: rms,
        residual_rms,
        noise_ratio: step_noise(&y, &b.pose).map(|s| residual_rms / s),
        linear: [linear.coef[0], linear.se[0]],
        points,
    })
}

/// The noise of one block from successive differences within a pose (a slow drift, such as
/// the bias following the temperature, hardly enters them): `√(mean (Δy)² / 2)`.
fn step_noise(y: &[f64], pose: &[usize]) -> Option<f64> {
    let (ss, n) = (1..y.len())
        .filter(|i| pose[*i] == pose[i - 1])
        .fold((0.0, 0usize), |(s, n), i| {
            (s + (y[i] - y[i - 1]).powi(2), n + 1)
        });
    (n > 0 && ss > 0.0).then(|| (ss / (2.0 * n as f64)).sqrt())
}

/// `g`, `m/s^2` or `raw`, from whether the values are integers and the median block magnitude.
fn units_of(rec: &Recording, kept: &[Block]) -> &'static str {
    let mut norms: Vec<f64> = kept
        .iter()
        .map(|b| b.xyz.iter().map(|v| v * v).sum::<f64>().sqrt())
        .collect();
    norms.sort_by(f64::total_cmp);
    let median = norms.get(norms.len() / 2).copied().unwrap_or(0.0);
    infer_units(rec.is_integer(), median)
}

/// Temperatures that all lie in this range, °C, are taken for kelvin: 200 K is −73 °C and
/// 400 K is 127 °C (a sensor's working range), while 200–400 °C is beyond any accelerometer's.
pub const KELVIN_LIKE: (f64, f64) = (200.0, 400.0);

/// Refuses a temperature column in kelvin ([`KELVIN_LIKE`]): read as °C its fit would be
/// written as °C with `T_ref` ~273 °C below every sample, extrapolated across that gap.
fn check_celsius(temp: &[f64]) -> std::result::Result<(), TempcalError> {
    let (min, max) = temp
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, z), t| {
            (a.min(*t), z.max(*t))
        });
    let (lo, hi) = KELVIN_LIKE;
    if !temp.is_empty() && min >= lo && max <= hi {
        return Err(TempcalError::Kelvin { min, max });
    }
    Ok(())
}

/// Averages the samples into blocks, drops moving blocks, assigns poses (by the pose label
/// when the file has one, else by direction) and drops poses held for one block only.
fn blocks(rec: &Recording, opts: &TempcalOptions) -> std::result::Result<Blocks, TempcalError> {
    let temp = rec
        .temp
        .as_ref()
        .filter(|t| t.len() == rec.len())
        .ok_or(TempcalError::NoTemperature)?;
    if let Some(i) = temp.iter().position(|t| !t.is_finite()) {
        return Err(TempcalError::NonFiniteTemperature { row: i + 1 });
    }
    check_celsius(temp)?;
    let rate_hz = rec
        .estimated_rate_hz()
        .filter(|r| r.is_finite() && *r > 0.0)
        .unwrap_or(opts.default_rate_hz);
    let n = rec.len();
    let per_block = ((rate_hz * opts.block_s).round() as usize)
        .max(1)
        .max(n.div_ceil(MAX_BLOCKS))
        .min(n.max(1));
    let labels = label_ids(rec);
    // A block straddling two pose labels is a change of pose: counted as moving.
    let total = n / per_block;
    let mut all: Vec<Block> = (0..total)
        .filter_map(|k| block_of(rec, temp, labels.as_deref(), k * per_block, per_block))
        .collect();
    let mut sds: Vec<f64> = all.iter().filter_map(|b| b.sd).collect();
    sds.sort_by(f64::total_cmp);
    let median_sd = sds.get(sds.len() / 2).copied().unwrap_or(0.0);
    if median_sd > 0.0 {
        all.retain(|b| b.sd.is_none_or(|s| s <= MOVING_FACTOR * median_sd));
    }
    let moving = total - all.len();
    let pose = assign_poses(&all, opts.pose_deg);
    let (kept, pose, poses, single) = drop_single(all, pose);
    Ok(Blocks {
        kept,
        pose,
        poses,
        total,
        moving,
        single,
        per_block,
        rate_hz,
    })
}

/// Each sample's pose label as a small integer (the file's `pose`/`label` column), if any.
fn label_ids(rec: &Recording) -> Option<Vec<usize>> {
    let labels = rec.labels.as_ref()?;
    let mut ids: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
    Some(
        labels
            .iter()
            .map(|l| {
                let next = ids.len();
                *ids.entry(l.as_str()).or_insert(next)
            })
            .collect(),
    )
}

/// The block of `len` samples from `start`; `None` when it straddles two pose labels.
fn block_of(
    rec: &Recording,
    temp: &[f64],
    labels: Option<&[usize]>,
    start: usize,
    len: usize,
) -> Option<Block> {
    let rows = start..start + len;
    let label = match labels {
        Some(l) => {
            let first = l[start];
            if l[rows.clone()].iter().any(|x| *x != first) {
                return None;
            }
            Some(first)
        }
        None => None,
    };
    let nf = len as f64;
    let xyz: [f64; 3] =
        std::array::from_fn(|a| rec.xyz[rows.clone()].iter().map(|v| v[a]).sum::<f64>() / nf);
    let sd = (len >= 2).then(|| {
        let ss: f64 = rec.xyz[rows.clone()]
            .iter()
            .map(|v| (0..3).map(|a| (v[a] - xyz[a]).powi(2)).sum::<f64>())
            .sum();
        (ss / (nf - 1.0)).sqrt()
    });
    let temp_c = temp[rows].iter().sum::<f64>() / nf;
    Some(Block {
        temp_c,
        xyz,
        sd,
        label,
    })
}

/// Pose index of every block: by label when labelled; else a new pose whenever a block's
/// direction is more than `pose_deg` from the current pose's first block.
fn assign_poses(blocks: &[Block], pose_deg: f64) -> Vec<usize> {
    let cos_max = pose_deg.to_radians().cos();
    let mut out = Vec::with_capacity(blocks.len());
    let mut reference: Option<[f64; 3]> = None;
    let mut current = 0usize;
    for b in blocks {
        if let Some(l) = b.label {
            out.push(l);
            continue;
        }
        let norm = b.xyz.iter().map(|v| v * v).sum::<f64>().sqrt();
        let dir = b.xyz.map(|v| v / norm.max(f64::MIN_POSITIVE));
        match reference {
            Some(r) if r.iter().zip(&dir).map(|(a, b)| a * b).sum::<f64>() >= cos_max => {}
            Some(_) => {
                current += 1;
                reference = Some(dir);
            }
            None => reference = Some(dir),
        }
        out.push(current);
    }
    out
}

/// Drops the blocks of poses held for a single block (their constant would take the block)
/// and renumbers the poses 0..P.
fn drop_single(blocks: Vec<Block>, pose: Vec<usize>) -> (Vec<Block>, Vec<usize>, usize, usize) {
    let top = pose.iter().max().map_or(0, |m| m + 1);
    let mut count = vec![0usize; top];
    for p in &pose {
        count[*p] += 1;
    }
    let mut renum = vec![usize::MAX; top];
    let mut poses = 0;
    for (p, c) in count.iter().enumerate() {
        if *c >= 2 {
            renum[p] = poses;
            poses += 1;
        }
    }
    let (mut kept, mut new_pose, mut single) = (Vec::new(), Vec::new(), 0);
    for (b, p) in blocks.into_iter().zip(pose) {
        if renum[p] == usize::MAX {
            single += 1;
        } else {
            kept.push(b);
            new_pose.push(renum[p]);
        }
    }
    (kept, new_pose, poses, single)
}

#[cfg(test)]
mod tests;

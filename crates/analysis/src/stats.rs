//! Distribution functions for the residual analysis: upper-tail probabilities of the
//! chi-square, F and Student-t distributions, from the regularised incomplete gamma and beta
//! functions (Lentz continued fractions, Lanczos log-gamma; accurate to ~1e-12 relative, far
//! beyond what a decision rule at α = 10⁻³ needs).
//!
//! Why here and not a crate (e.g. `statrs`): these are forty lines of textbook numerics that
//! the unit tests check against printed table values, and the golden outputs of
//! `host/tests/golden` depend on their last digits; replacing them is a deliberate change of
//! those outputs, not part of a restructuring.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
/// `ln Γ(x)` for `x > 0` (Lanczos, g = 7, 9 terms).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection formula.
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Continued fraction of the incomplete beta function (modified Lentz).
fn beta_cf(a: f64, b: f64, x: f64) -> f64 {
    const FPMIN: f64 = 1e-300;
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    if d.abs() < FPMIN {
        d = FPMIN;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..=500 {
        let m = m as f64;
        let m2 = 2.0 * m;
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 + aa * d;
        if d.abs() < FPMIN {
            d = FPMIN;
        }
        c = 1.0 + aa / c;
        if c.abs() < FPMIN {
            c = FPMIN;
        }
        d = 1.0 / d;
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 + aa * d;
        if d.abs() < FPMIN {
            d = FPMIN;
        }
        c = 1.0 + aa / c;
        if c.abs() < FPMIN {
            c = FPMIN;
        }
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// Regularised incomplete beta function `I_x(a, b)`, `a, b > 0`, `0 ≤ x ≤ 1`.
pub fn beta_inc(a: f64, b: f64, x: f64) -> f64 {
    if !(a > 0.0 && b > 0.0) || x.is_nan() {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let ln_bt = ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln();
    let bt = ln_bt.exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        bt * beta_cf(a, b, x) / a
    } else {
        1.0 - bt * beta_cf(b, a, 1.0 - x) / b
    }
}

/// Regularised upper incomplete gamma function `Q(a, x) = Γ(a, x)/Γ(a)`.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if !(a > 0.0) || x.is_nan() {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    let gln = ln_gamma(a);
    if x < a + 1.0 {
        // Series for P(a, x).
        let mut ap = a;
        let mut sum = 1.0 / a;
        let mut del = sum;
        for _ in 0..1000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - gln).exp()
    } else {
        // Continued fraction for Q(a, x) (modified Lentz).
        const FPMIN: f64 = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / FPMIN;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < FPMIN {
                d = FPMIN;
            }
            c = b + an / c;
            if c.abs() < FPMIN {
                c = FPMIN;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (-x + a * x.ln() - gln).exp() * h
    }
}

/// Upper tail `P(χ²_k > x)`.
pub fn chi2_sf(x: f64, k: f64) -> f64 {
    gamma_q(k / 2.0, x / 2.0)
}

/// Upper tail `P(F_{d1,d2} > f)`.
pub fn f_sf(f: f64, d1: f64, d2: f64) -> f64 {
    if f <= 0.0 {
        return 1.0;
    }
    beta_inc(d2 / 2.0, d1 / 2.0, d2 / (d2 + d1 * f))
}

/// Two-sided `P(|T_ν| > t)` of Student's t.
pub fn t_two_sided(t: f64, nu: f64) -> f64 {
    beta_inc(nu / 2.0, 0.5, nu / (nu + t * t))
}

/// Upper critical value of the F distribution on (`d1`, `d2`) at `level`: the smallest `f`
/// with `P(F > f) ≤ level`. The bracket grows until it holds the value (a critical value at a
/// Bonferroni level on few degrees of freedom can exceed 10⁶), then 100 halvings of the
/// monotone survival function reach full `f64` precision.
pub fn f_critical(level: f64, d1: f64, d2: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 1.0);
    while f_sf(hi, d1, d2) > level && hi < 1e18 {
        hi *= 2.0;
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if f_sf(mid, d1, d2) > level {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The keys of the ranks `wants` asks for — `(stream, k)`: the `k`-th smallest (from 0, below
/// the stream's count) of stream `stream`'s keys — among keys given by their order keys
/// (`u64`s whose integer order is the values' order: an `f64`'s bits for non-negative values,
/// or [`order_key`] for any), selected together 16 bits at a time so that no key is stored:
/// `tops[s]` counts stream `s`'s keys by their top 16 bits (the caller's first pass), and
/// each call of `pass` gives every key again with its stream; three passes in all, whatever
/// the number of ranks. The exact order statistic, as a sort gives it. Errors are `pass`'s
/// (a re-read file that changed).
pub fn select_keys<E>(
    tops: &[&[usize]],
    wants: &[(usize, usize)],
    mut pass: impl FnMut(&mut dyn FnMut(usize, u64)) -> Result<(), E>,
) -> Result<Vec<u64>, E> {
    if wants.is_empty() {
        return Ok(Vec::new());
    }
    let mut state: Vec<(u64, usize)> = wants.iter().map(|&(s, k)| digit_of(tops[s], k)).collect();
    let mut hists = vec![vec![0usize; 1 << 16]; wants.len()];
    for shift in [32u32, 16, 0] {
        hists.iter_mut().for_each(|h| h.fill(0));
        pass(&mut |stream, key| {
            for ((&(s, _), &(prefix, _)), h) in wants.iter().zip(&state).zip(&mut hists) {
                if s == stream && key >> (shift + 16) == prefix {
                    h[((key >> shift) & 0xffff) as usize] += 1;
                }
            }
        })?;
        for ((prefix, k), h) in state.iter_mut().zip(&hists) {
            let (digit, rest) = digit_of(h, *k);
            (*prefix, *k) = ((*prefix << 16) | digit, rest);
        }
    }
    Ok(state.into_iter().map(|(key, _)| key).collect())
}

/// An `f64` as a key whose unsigned order is `f64::total_cmp`'s (−NaN < −∞ < … < −0 < +0 <
/// … < +∞ < NaN): the keys [`select_keys`] selects among, for values of any sign. For
/// non-negative values, whose bits already order as they do, the bits serve as well.
pub fn order_key(x: f64) -> u64 {
    let b = x.to_bits() as i64;
    ((b ^ (((b >> 63) as u64) >> 1) as i64) as u64) ^ (1 << 63)
}

/// The value of an [`order_key`].
pub fn from_order_key(k: u64) -> f64 {
    let b = k ^ (1 << 63);
    f64::from_bits(b ^ ((((b as i64) >> 63) as u64) >> 1))
}

/// Keys counted in a first pass for their order statistics ([`OrderCounts::keys`],
/// [`medians`]): by value while at most `max_distinct` distinct ones are seen (the exact order
/// statistic then comes from the counts, with no further pass), else by their top 16 bits,
/// the first digit of [`select_keys`] (memory bounded whatever the number of keys).
#[derive(Debug, Clone)]
pub struct OrderCounts {
    by_value: Option<rustc_hash::FxHashMap<u64, usize>>,
    max_distinct: usize,
    /// Counts by the top 16 bits, once the counts by value are dropped (empty before).
    top: Vec<usize>,
    /// Keys pushed.
    pub len: usize,
}

impl OrderCounts {
    /// Counts by value of at most `max_distinct` keys.
    pub fn new(max_distinct: usize) -> Self {
        let mut counts = Self {
            by_value: Some(rustc_hash::FxHashMap::default()),
            max_distinct,
            top: Vec::new(),
            len: 0,
        };
        if max_distinct == 0 {
            counts.drop_values();
        }
        counts
    }

    /// One more key.
    pub fn push(&mut self, key: u64) {
        self.push_n(key, 1);
    }

    /// `n` more of one key (as `n` pushes of it).
    #[inline]
    pub fn push_n(&mut self, key: u64, n: usize) {
        self.len += n;
        match &mut self.by_value {
            Some(map) => {
                *map.entry(key).or_insert(0) += n;
                if map.len() > self.max_distinct {
                    self.drop_values();
                }
            }
            None => self.top[(key >> 48) as usize] += n,
        }
    }

    /// Past `max_distinct` keys: the counts by value become counts by the top 16 bits.
    fn drop_values(&mut self) {
        self.top = vec![0; 1 << 16];
        for (key, c) in self.by_value.take().into_iter().flatten() {
            self.top[(key >> 48) as usize] += c;
        }
    }

    /// The distinct keys and their counts in rising order, while counted by value.
    pub fn sorted(&self) -> Option<Vec<(u64, usize)>> {
        let mut counts: Vec<(u64, usize)> = self
            .by_value
            .as_ref()?
            .iter()
            .map(|(k, c)| (*k, *c))
            .collect();
        counts.sort_unstable();
        Some(counts)
    }

    /// The keys of `ranks` (each below [`OrderCounts::len`]): from the counts by value when
    /// they were kept, else selected in passes ([`select_keys`], `pass` giving every key
    /// again).
    pub fn keys<E>(
        &self,
        ranks: &[usize],
        mut pass: impl FnMut(&mut dyn FnMut(u64)) -> Result<(), E>,
    ) -> Result<Vec<u64>, E> {
        if let Some(sorted) = self.sorted() {
            return Ok(ranks.iter().map(|&k| kth_counted(&sorted, k)).collect());
        }
        let wants: Vec<(usize, usize)> = ranks.iter().map(|&k| (0, k)).collect();
        select_keys(&[&self.top], &wants, |key| pass(&mut |k| key(0, k)))
    }

    /// The median of the counted keys' values (`value` of a key; the mean of the middle two
    /// for an even count, `NaN` for none): [`medians`] of this one stream.
    pub fn median<E>(
        &self,
        value: impl Fn(u64) -> f64,
        mut pass: impl FnMut(&mut dyn FnMut(u64)) -> Result<(), E>,
    ) -> Result<f64, E> {
        let m = medians(&[self], value, |key| pass(&mut |k| key(0, k)))?;
        Ok(m[0])
    }
}

/// The `k`-th smallest key of keys counted by value (`sorted`: distinct keys in rising order
/// with their counts); `u64::MAX` past the last (a rank below the count always has one).
pub fn kth_counted(sorted: &[(u64, usize)], mut k: usize) -> u64 {
    for &(key, c) in sorted {
        if k < c {
            return key;
        }
        k -= c;
    }
    u64::MAX
}

/// The median of each stream of keys counted in `counts` (`value` of a key; the mean of the
/// middle two for an even count, `NaN` for none): the middle keys from the counts by value
/// where they were kept, the others selected together in the same passes ([`select_keys`],
/// each call of `pass` giving every key again with its stream's index in `counts`).
pub fn medians<E>(
    counts: &[&OrderCounts],
    value: impl Fn(u64) -> f64,
    pass: impl FnMut(&mut dyn FnMut(usize, u64)) -> Result<(), E>,
) -> Result<Vec<f64>, E> {
    let middle = |n: usize| match n {
        0 => vec![],
        _ if n % 2 == 1 => vec![n / 2],
        _ => vec![n / 2 - 1, n / 2],
    };
    let sorted: Vec<_> = counts.iter().map(|c| c.sorted()).collect();
    let wants: Vec<(usize, usize)> = (0..counts.len())
        .filter(|&s| sorted[s].is_none())
        .flat_map(|s| middle(counts[s].len).into_iter().map(move |k| (s, k)))
        .collect();
    let tops: Vec<&[usize]> = counts.iter().map(|c| c.top.as_slice()).collect();
    let mut selected = select_keys(&tops, &wants, pass)?.into_iter();
    Ok((0..counts.len())
        .map(|s| {
            let keys: Vec<u64> = match &sorted[s] {
                Some(by_value) => middle(counts[s].len)
                    .into_iter()
                    .map(|k| kth_counted(by_value, k))
                    .collect(),
                None => selected
                    .by_ref()
                    .take(middle(counts[s].len).len())
                    .collect(),
            };
            match keys.as_slice() {
                [m] => value(*m),
                [lo, hi] => 0.5 * (value(*lo) + value(*hi)),
                _ => f64::NAN,
            }
        })
        .collect())
}

/// The bucket of a histogram holding the `k`-th value, and `k` within it.
fn digit_of(hist: &[usize], mut k: usize) -> (u64, usize) {
    for (d, &c) in hist.iter().enumerate() {
        if k < c {
            return (d as u64, k);
        }
        k -= c;
    }
    (hist.len() as u64 - 1, 0)
}

/// The power detection limits are stated at: an effect at its limit passes the test in 80 %
/// of recordings like the one measured.
pub const POWER: f64 = 0.8;

/// `P(χ²_q(λ) > c)`: the non-central χ² as a Poisson(λ/2) mixture of central χ²'s.
pub fn noncentral_chi2_sf(c: f64, q: f64, lambda: f64) -> f64 {
    let half = 0.5 * lambda;
    let mut sum = 0.0;
    let mut log_w = -half;
    // The Poisson weights are negligible beyond λ/2 + 40·√(λ/2): sum at least that far.
    let terms = (half + 40.0 * half.sqrt() + 100.0).min(1e7) as usize;
    for k in 0..terms {
        let kf = k as f64;
        if k > 0 {
            log_w += half.ln() - kf.ln();
        }
        let w = log_w.exp();
        sum += w * chi2_sf(c, q + 2.0 * kf);
        if kf > half && w < 1e-14 {
            break;
        }
    }
    sum.min(1.0)
}

/// The non-centrality at which the χ² test with critical value `c` on `q` dof has [`POWER`].
///
/// Remembered per `(c, q)` for the process: the searches ask the same question for every
/// candidate of a step (the same `q`, residual dof and level give the same `c`), and each
/// answer costs 80 bisection steps of a Poisson-weighted series (it was a quarter of a
/// `batch` run's CPU). The value is the bisection's, bit for bit, whoever asked first.
pub fn lambda_for_power(c: f64, q: f64) -> f64 {
    use std::collections::HashMap;
    use std::sync::{Mutex, OnceLock};
    /// Answers kept at most; beyond, the memory starts again (a bound, never reached in
    /// practice: a recording asks a few dozen distinct questions).
    const KEPT: usize = 4096;
    static KNOWN: OnceLock<Mutex<HashMap<(u64, u64), f64>>> = OnceLock::new();
    let known = KNOWN.get_or_init(Default::default);
    let key = (c.to_bits(), q.to_bits());
    if let Some(v) = known.lock().ok().and_then(|m| m.get(&key).copied()) {
        return v;
    }
    let v = bisect_lambda_for_power(c, q);
    if let Ok(mut m) = known.lock() {
        if m.len() >= KEPT {
            m.clear();
        }
        m.insert(key, v);
    }
    v
}

/// [`lambda_for_power`] computed: the power rises with λ, so a bracket and its halving.
fn bisect_lambda_for_power(c: f64, q: f64) -> f64 {
    let mut hi = 1.0;
    while noncentral_chi2_sf(c, q, hi) < POWER && hi < 1e6 {
        hi *= 2.0;
    }
    let mut lo = 0.0;
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if noncentral_chi2_sf(c, q, mid) < POWER {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The detection limit of an effect whose acceptance needs an F-test at `level` **and** a
/// held-out RMS lowered by the CV factor: the larger of the two sizes, in the unit of
/// `se_max` (the gyro's, the accelerometer's and any other least-squares search's rule).
///
/// * **F-test, [`POWER`].** A coefficient `β` of standard error `SE` (from the step's design
///   and reference variance σ²) adds the non-centrality `λ = (β/SE)²` to the block's F-test
///   on `q` coefficients and `d2` residual dof. The limit is `√λ₈₀·se_max`, with `λ₈₀` the
///   non-centrality at which `P(χ²_q(λ) > q·F_crit) = 0.8` (the denominator taken as known:
///   a slight underestimate of the limit on few dof) and `se_max` the largest standard error
///   among the effect's coefficients, so the limit holds for every one of them.
/// * **Held-out RMS.** Leave-one-out residuals of a least-squares fit with `p` parameters on
///   `m` rows have mean square ≈ `σ²(1 + p/m)`; a coefficient `β` left out adds
///   `σ²β²/(m·SE²)` to it per row. `cv_need` is the squared size, in units of `se_max²`, at
///   which the held-out RMS falls by the factor `c`: `rows·(c²(1 + p₁/m) − (1 + p₀/m))`.
///
/// `None` when the limit is not finite (no residual dof, a zero level).
pub fn limit_from(se_max: f64, q: f64, d2: f64, level: f64, cv_need: f64) -> Option<f64> {
    let crit = q * f_critical(level, q, d2);
    let beta_f = lambda_for_power(crit, q).sqrt() * se_max;
    let beta_cv = se_max * cv_need.max(0.0).sqrt();
    let limit = beta_f.max(beta_cv);
    limit.is_finite().then_some(limit)
}

/// The held-out requirement of [`limit_from`] for `rows` rows with `p1` parameters with the
/// effect and `p0` without it, at CV factor `cv_factor`.
pub fn cv_need(rows: f64, p1: f64, p0: f64, cv_factor: f64) -> f64 {
    rows * (cv_factor.powi(2) * (1.0 + p1 / rows) - (1.0 + p0 / rows))
}

/// Pearson correlation of two equally long series (0 when either is constant).
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    if n < 2 {
        return 0.0;
    }
    let ma = a[..n].iter().sum::<f64>() / n as f64;
    let mb = b[..n].iter().sum::<f64>() / n as f64;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a[..n].iter().zip(&b[..n]) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    if saa <= 0.0 || sbb <= 0.0 {
        0.0
    } else {
        sab / (saa * sbb).sqrt()
    }
}

/// Median of a slice (the mean of the middle two for an even count; empty gives NaN; NaN
/// ordered as `f64::total_cmp` orders it): the values held are the one-chunk case of
/// [`OrderCounts::median`], counted by value while few are distinct, else selected in passes
/// over the slice (memory bounded, no copy of the values).
pub fn median(v: &[f64]) -> f64 {
    let pass = |key: &mut dyn FnMut(u64)| {
        v.iter().for_each(|&x| key(order_key(x)));
        Ok::<(), std::convert::Infallible>(())
    };
    let mut counts = OrderCounts::new(v.len().min(HELD_DISTINCT));
    let Ok(()) = pass(&mut |k| counts.push(k));
    let Ok(m) = counts.median(from_order_key, pass);
    m
}

/// Most distinct values [`median`] counts by value before it selects in passes (a map of
/// this many keys is smaller than the passes' histograms).
const HELD_DISTINCT: usize = 1 << 12;

/// Root mean square (0 for an empty slice).
pub fn rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// A p-value for text: `= 1.2e-5`, or `< 1e-15` below what the tail functions resolve.
pub fn fmt_p(p: f64) -> String {
    if p < 1e-15 {
        "< 1e-15".into()
    } else {
        format!("= {p:.1e}")
    }
}

/// `x` to three significant digits (at least; whole digits are kept), as the reports print a
/// detection limit or a coefficient: `0.0123`, `1.23`, `123`, `12345`.
pub fn sig3(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let d = (2 - x.abs().log10().floor() as i32).max(0) as usize;
    format!("{x:.d$}")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `k`-th smallest of `v` in `total_cmp` order by its definition, with no sort: the
    /// value with at most `k` values below it and more than `k` at or below it.
    fn kth_by_definition(v: &[f64], k: usize) -> f64 {
        let below = |x: f64| v.iter().filter(|y| y.total_cmp(&x).is_lt()).count();
        let at_most = |x: f64| v.iter().filter(|y| y.total_cmp(&x).is_le()).count();
        *v.iter()
            .find(|&&x| below(x) <= k && k < at_most(x))
            .expect("k below the length")
    }

    /// The definition's checker on a hand example with ties: 1, 2, 2, 3.
    #[test]
    fn the_reference_kth_is_the_sorted_one_by_hand() {
        let v = [3.0, 2.0, 1.0, 2.0];
        let got: Vec<f64> = (0..4).map(|k| kth_by_definition(&v, k)).collect();
        assert_eq!(got, [1.0, 2.0, 2.0, 3.0]);
    }

    /// Values with ties (a few small integers), both zeros, infinities, NaN and any bits.
    fn values() -> impl proptest::strategy::Strategy<Value = Vec<f64>> {
        use proptest::prelude::*;
        let one = prop_oneof![
            4 => (-3i32..4).prop_map(f64::from),
            1 => Just(-0.0),
            1 => Just(f64::INFINITY),
            1 => Just(f64::NEG_INFINITY),
            1 => Just(f64::NAN),
            2 => any::<f64>(),
        ];
        proptest::collection::vec(one, 0..40)
    }

    /// The definition's median: the middle value, or the mean of the middle two.
    fn median_by_definition(v: &[f64]) -> f64 {
        match v.len() {
            0 => f64::NAN,
            n if n % 2 == 1 => kth_by_definition(v, n / 2),
            n => 0.5 * (kth_by_definition(v, n / 2 - 1) + kth_by_definition(v, n / 2)),
        }
    }

    fn same(a: f64, b: f64) -> bool {
        a.to_bits() == b.to_bits() || a.is_nan() && b.is_nan()
    }

    proptest::proptest! {
        /// The one selection gives the definition's order statistic, bit for bit, for odd and
        /// even counts, ties, both zeros, negatives, infinities and NaN: held (`median`), from
        /// the counts by value (`cap` at least the distinct values) or in passes (below), at
        /// every rank (`OrderCounts::keys`), and for several streams at once (`medians`: the
        /// values and their negations, whatever each one's cap).
        #[test]
        fn the_selection_is_the_definitions(v in values(), cap in 0usize..50, cap2 in 0usize..50) {
            let pass = |key: &mut dyn FnMut(u64)| {
                v.iter().for_each(|&x| key(order_key(x)));
                Ok::<(), ()>(())
            };
            let mut counts = OrderCounts::new(cap);
            pass(&mut |k| counts.push(k)).unwrap();
            let want = median_by_definition(&v);
            let got = counts.median(from_order_key, pass).unwrap();
            proptest::prop_assert!(same(got, want), "{got} {want}");
            proptest::prop_assert!(same(median(&v), want), "{} {want}", median(&v));
            let ranks: Vec<usize> = (0..v.len()).collect();
            for (k, key) in counts.keys(&ranks, pass).unwrap().into_iter().enumerate() {
                proptest::prop_assert_eq!(from_order_key(key).to_bits(), kth_by_definition(&v, k).to_bits());
            }
            let neg: Vec<f64> = v.iter().map(|x| -x).collect();
            let mut counts2 = OrderCounts::new(cap2);
            neg.iter().for_each(|&x| counts2.push(order_key(x)));
            let both = medians(&[&counts, &counts2], from_order_key, |key| {
                v.iter().for_each(|&x| key(0, order_key(x)));
                neg.iter().for_each(|&x| key(1, order_key(x)));
                Ok::<(), ()>(())
            })
            .unwrap();
            proptest::prop_assert!(same(both[0], want));
            proptest::prop_assert!(same(both[1], median_by_definition(&neg)));
        }

        /// The keys order as `total_cmp` does, and give their value back bit for bit.
        #[test]
        fn order_keys_keep_the_total_order(a in proptest::num::f64::ANY, b in proptest::num::f64::ANY) {
            proptest::prop_assert_eq!(order_key(a).cmp(&order_key(b)), a.total_cmp(&b));
            proptest::prop_assert_eq!(from_order_key(order_key(a)).to_bits(), a.to_bits());
        }
    }

    /// Many values (more distinct than the held median counts by value): selected in passes
    /// over the slice, the sorted middle.
    #[test]
    fn a_long_held_median_is_the_sorted_middle() {
        for n in [HELD_DISTINCT * 3, HELD_DISTINCT * 3 + 1] {
            let v: Vec<f64> = (0..n)
                .map(|i| ((i * 7919) % 10007) as f64 * 0.37 - 900.0)
                .collect();
            let mut sorted = v.clone();
            sorted.sort_by(f64::total_cmp);
            let want = if n % 2 == 1 {
                sorted[n / 2]
            } else {
                0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
            };
            assert_eq!(median(&v).to_bits(), want.to_bits(), "n = {n}");
        }
    }

    /// The counts by value give the sorted list's `k`-th key for every `k`; once more
    /// distinct keys than the cap were pushed they are dropped (the selection then runs in
    /// passes).
    #[test]
    fn counts_by_value_give_the_sorted_kth_within_their_cap() {
        let values = [3.5f64, 0.0, 1.25, 3.5, 7.0, 1.25, 1.25, 0.5];
        let mut counted = OrderCounts::new(8);
        for v in values {
            counted.push(v.to_bits());
        }
        let mut sorted = values;
        sorted.sort_by(f64::total_cmp);
        let by_value = counted.sorted().unwrap();
        for (k, v) in sorted.iter().enumerate() {
            assert_eq!(kth_counted(&by_value, k), v.to_bits(), "k = {k}");
        }
        assert_eq!(kth_counted(&by_value, values.len()), u64::MAX);
        let mut capped = OrderCounts::new(2);
        for v in [1.0f64, 2.0, 3.0] {
            capped.push(v.to_bits());
        }
        assert!(capped.sorted().is_none());
        assert_eq!(capped.top.iter().sum::<usize>(), 3);
    }

    #[test]
    fn gamma_function_values() {
        // Γ(5) = 24, Γ(1/2) = √π.
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-12);
        assert!((ln_gamma(0.1) - 9.513_507_698_668_732f64.ln()).abs() < 1e-10);
    }

    /// Critical values from printed statistical tables.
    #[test]
    fn table_critical_values() {
        // χ²: df 10 at 0.05 → 18.307; df 1 at 0.001 → 10.828; df 30 at 0.01 → 50.892.
        assert!((chi2_sf(18.307, 10.0) - 0.05).abs() < 1e-4);
        assert!((chi2_sf(10.828, 1.0) - 0.001).abs() < 1e-5);
        assert!((chi2_sf(50.892, 30.0) - 0.01).abs() < 1e-4);
        // F: (3, 20) at 0.05 → 3.10; (1, 10) at 0.01 → 10.04; (5, 30) at 0.001 → 5.53.
        assert!((f_sf(3.098, 3.0, 20.0) - 0.05).abs() < 2e-4);
        assert!((f_sf(10.04, 1.0, 10.0) - 0.01).abs() < 1e-4);
        assert!((f_sf(5.53, 5.0, 30.0) - 0.001).abs() < 5e-5);
        // t: df 10 two-sided 0.05 → 2.228; df 30 two-sided 0.01 → 2.750.
        assert!((t_two_sided(2.228, 10.0) - 0.05).abs() < 2e-4);
        assert!((t_two_sided(2.750, 30.0) - 0.01).abs() < 1e-4);
        // F(1, ν) = t²_ν.
        assert!((f_sf(2.5f64.powi(2), 1.0, 12.0) - t_two_sided(2.5, 12.0)).abs() < 1e-12);
    }

    /// The value selected by digits is the sorted one's, for non-negative values by their bits
    /// and for signed ones by their `total_cmp` order.
    #[test]
    fn digits_select_the_kth_value() {
        let bits = |x: f64| x.to_bits();
        let positive: Vec<f64> = (0..1000).map(|i| (i * 31 % 997) as f64 * 0.37).collect();
        let signed: Vec<f64> = positive.iter().map(|v| v - 150.0).collect();
        for (vals, key) in [(&positive, bits as fn(f64) -> u64), (&signed, order_key)] {
            let mut top = vec![0usize; 1 << 16];
            vals.iter().for_each(|&v| top[(key(v) >> 48) as usize] += 1);
            let mut sorted = vals.clone();
            sorted.sort_by(f64::total_cmp);
            let ranks = [0, 1, 499, 500, 999];
            let wants: Vec<(usize, usize)> = ranks.iter().map(|&k| (0, k)).collect();
            let Ok(got) = select_keys(&[&top], &wants, |f| {
                vals.iter().for_each(|&v| f(0, key(v)));
                Ok::<(), std::convert::Infallible>(())
            });
            for (k, g) in ranks.iter().zip(got) {
                assert_eq!(g, key(sorted[*k]), "k = {k}");
            }
        }
    }

    /// The remembered answer is the computed one for each question, whatever the order of
    /// asking (questions differing only in `q`, or only in `c`, are not confused), and
    /// the same from several threads at once.
    #[test]
    fn remembered_powers_are_the_computed_ones() {
        let questions = [
            (3.841_458_8, 1.0),
            (3.841_458_8, 2.0),
            (9.2, 2.0),
            (9.2, 3.0),
        ];
        let threads: Vec<_> = (0..3)
            .map(|k| {
                std::thread::spawn(move || {
                    (0..8)
                        .map(|i| questions[(i + k) % questions.len()])
                        .map(|(c, q)| (lambda_for_power(c, q), bisect_lambda_for_power(c, q)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        for t in threads {
            for (remembered, computed) in t.join().unwrap() {
                assert_eq!(remembered.to_bits(), computed.to_bits());
            }
        }
        // The same critical value is passed more easily with more dof: less non-centrality.
        assert!(lambda_for_power(9.2, 3.0) < lambda_for_power(9.2, 2.0));
    }

    /// The central case (λ = 0) is the test's level; a known value of the non-central χ²
    /// (R: `pchisq(3.84, 1, ncp = 7.85, lower = FALSE)` = 0.800); F critical values from
    /// printed tables (the digits from SciPy's `f.isf`), and one beyond 10⁶ (F(1, 1) at 10⁻⁷:
    /// `tan²(π/2·(1 − 10⁻⁷))`).
    #[test]
    fn power_and_critical_values_against_known_values() {
        assert!((noncentral_chi2_sf(3.841_458_8, 1.0, 0.0) - 0.05).abs() < 1e-6);
        assert!((noncentral_chi2_sf(3.841_458_8, 1.0, 7.848_861) - 0.8).abs() < 1e-4);
        assert!((lambda_for_power(3.841_458_8, 1.0) - 7.848_861).abs() < 1e-3);
        assert!((f_critical(0.05, 3.0, 20.0) - 3.098_391).abs() < 1e-5);
        assert!((f_critical(0.001, 5.0, 30.0) - 5.533_913).abs() < 1e-4);
        let big = (std::f64::consts::FRAC_PI_2 * (1.0 - 1e-7)).tan().powi(2);
        assert!((f_critical(1e-7, 1.0, 1.0) / big - 1.0).abs() < 1e-6);
        // The held-out need: c = 1 and p₁ = p₀ need nothing; the F part then decides.
        assert_eq!(cv_need(30.0, 9.0, 9.0, 1.0), 0.0);
        let l = limit_from(2.0, 1.0, 1e6, 0.05, 0.0).unwrap();
        assert!((l - 2.0 * 7.848_861f64.sqrt()).abs() < 1e-2, "{l}");
    }

    #[test]
    fn beta_symmetry_and_edges() {
        for &(a, b, x) in &[(2.0, 3.0, 0.3), (0.5, 7.0, 0.9), (10.0, 1.5, 0.95)] {
            let s = beta_inc(a, b, x) + beta_inc(b, a, 1.0 - x);
            assert!((s - 1.0).abs() < 1e-12);
        }
        // I_x(1, 1) = x.
        assert!((beta_inc(1.0, 1.0, 0.37) - 0.37).abs() < 1e-14);
        assert_eq!(beta_inc(2.0, 2.0, 0.0), 0.0);
        assert_eq!(beta_inc(2.0, 2.0, 1.0), 1.0);
        assert!(beta_inc(-1.0, 2.0, 0.5).is_nan());
        assert_eq!(chi2_sf(0.0, 3.0), 1.0);
    }

    #[test]
    fn correlation_and_median() {
        let a = [1.0, 2.0, 3.0, 4.0];
        assert!((correlation(&a, &[2.0, 4.0, 6.0, 8.0]) - 1.0).abs() < 1e-12);
        assert!((correlation(&a, &[8.0, 6.0, 4.0, 2.0]) + 1.0).abs() < 1e-12);
        assert_eq!(correlation(&a, &[1.0; 4]), 0.0);
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!((rms(&[3.0, 4.0]) - (12.5f64).sqrt()).abs() < 1e-12);
    }
}

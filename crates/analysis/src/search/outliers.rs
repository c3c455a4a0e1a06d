//! The outlier screen: windows that were not still (a bump, a hand that moved) sit far from
//! the others' fit and are rejected rather than modelled.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::fit::model::{self as am, Fit, Mask, Params, Win};
use crate::search::floor::reference_variance;
use crate::search::select::{MIN_DOF_OUTLIER, MIN_SPARE_OUTLIER};
use crate::stats as st;

/// The outlier candidate: the windows it rejects and the model refitted without them.
pub struct OutlierTrial {
    /// Rejected windows (0-based), most extreme first.
    pub rejected: Vec<usize>,
    /// Their Bonferroni-corrected p-values.
    pub p_values: Vec<f64>,
    /// Their squared t statistics.
    pub f_stats: Vec<f64>,
    /// The fit without them.
    pub fit: Fit,
    /// Its held-out residuals (g; `None` for rejected windows).
    pub loo: Vec<Option<f64>>,
    /// Windows in use after the rejection.
    pub used: Vec<bool>,
    /// The effect added to the current model for the screen, when the current model alone
    /// could not single the windows out (`None`: screened under the current model).
    pub screened_with: Option<String>,
    /// With `screened_with`: the leave-one-window-out RMS of the kept windows under that
    /// model, fitted without the rejected windows and with them (g). The rejection is judged
    /// by these (an effect the current model lacks would otherwise hide its benefit).
    pub judged_cv: Option<(f64, Option<f64>)>,
}

/// Outlier screening and test under the current model.
///
/// 1. A robust refit (Tukey biweight, c = 4.685, scale = 1.4826·median |r|, iteratively
///    reweighted) finds the windows the bulk of the data disagrees with; those beyond 3 robust
///    scales are the suspects. (A plain least-squares screen fails here: a few windows that
///    were not still pull the fit towards themselves and inflate the scale, masking each other.)
/// 2. Each suspect is tested against the fit on the other windows: its prediction error
///    `e` has variance `σ²(1 + h)` (`h` the leverage), `σ²` that fit's reference variance
///    ([`crate::search::floor::reference_variance`]: `RSS/dof`, but never less than the mean squared
///    noise floor of the windows it uses — a chance-low `RSS/dof` on ~20 dof otherwise turns
///    an ordinary 3–4 σ window into t ≈ 6.6, the clean-recording false positive of
///    docs/residuals.md). The others' floor, not the suspect's own: a window that was not
///    still has a large sample variance of its own, which would hide it. `t = e/(σ√(1 + h))`
///    is referred to Student-t on the fit's dof (exact when `RSS/dof` is taken, conservative
///    when the floor is); the two-sided p-value is multiplied by the number of windows
///    searched (Bonferroni: the family-wise level over all windows) and compared with
///    `level`. Suspects that fail are put back and the test repeated until the rejected set
///    is stable.
///
/// `floor` is per window (g); an empty slice (or zeros) tests against `RSS/dof` alone.
pub fn find_outliers(
    current: &Fit,
    used0: &[bool],
    mask: &Mask,
    wins: &[Win],
    floor: &[f64],
    level: f64,
    max_reject: usize,
) -> Option<OutlierTrial> {
    let n = used0.iter().filter(|u| **u).count();
    if n < current.k + MIN_SPARE_OUTLIER {
        return None;
    }
    let (p, scale) = robust_fit(current, used0, mask, wins)?;
    let mut suspects: Vec<(usize, f64)> = (0..wins.len())
        .filter(|i| used0[*i])
        .map(|i| (i, am::residual(&p, &wins[i])))
        .filter(|(_, r)| r.abs() > SUSPECT_SCALES * scale)
        .collect();
    suspects.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
    suspects.truncate(max_reject);
    if suspects.is_empty() {
        return None;
    }
    test_suspects(&p, &suspects, used0, mask, wins, floor, level)
}

/// Tukey biweight tuning constant (95 % efficiency at Gaussian residuals).
const BIWEIGHT_C: f64 = 4.685;
/// Median absolute residual to a Gaussian σ.
const MAD_TO_SIGMA: f64 = 1.4826;
/// Windows beyond this many robust scales are suspects.
const SUSPECT_SCALES: f64 = 3.0;

/// Iteratively reweighted biweight fit from `current`: the parameters and the robust scale
/// (`None` when the scale is zero or undefined).
fn robust_fit(current: &Fit, used0: &[bool], mask: &Mask, wins: &[Win]) -> Option<(Params, f64)> {
    let n_all = wins.len();
    let k = current.k;
    let mut p = current.p;
    let mut w: Vec<f64> = used0.iter().map(|u| if *u { 1.0 } else { 0.0 }).collect();
    let mut scale = 0.0;
    for _ in 0..50 {
        let r: Vec<f64> = (0..n_all)
            .filter(|i| used0[*i])
            .map(|i| am::residual(&p, &wins[i]).abs())
            .collect();
        scale = MAD_TO_SIGMA * st::median(&r);
        if !(scale > 0.0) {
            return None;
        }
        let c = BIWEIGHT_C * scale;
        let new_w: Vec<f64> = (0..n_all)
            .map(|i| {
                if !used0[i] {
                    return 0.0;
                }
                let u = am::residual(&p, &wins[i]) / c;
                if u.abs() >= 1.0 {
                    0.0
                } else {
                    (1.0 - u * u).powi(2)
                }
            })
            .collect();
        if new_w.iter().filter(|x| **x > 0.0).count() < k + 2 {
            break;
        }
        let change = new_w
            .iter()
            .zip(&w)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        w = new_w;
        match am::fit_weighted(&p, mask, wins, &w) {
            Some(f) => p = f.p,
            None => break,
        }
        if change < 1e-6 {
            break;
        }
    }
    Some((p, scale))
}

/// Tests each suspect against the fit on the other windows (see [`find_outliers`]) and
/// iterates until the rejected set is stable.
/// The prediction-error t statistic of window `i` and its degrees of freedom. A suspect
/// currently rejected is outside the fit `clean` (whose variance and dof are `clean_s2`); one
/// still in it is tested by its deletion residual (a refit without it).
fn deletion_t(
    clean: &am::Fit,
    clean_s2: (f64, usize),
    i: usize,
    used: &[bool],
    mask: &Mask,
    wins: &[Win],
    floor: &[f64],
) -> Option<(f64, usize)> {
    let (e, h, s2, d) = if used[i] {
        let mut u2 = used.to_vec();
        u2[i] = false;
        let f2 = am::fit(&clean.p, mask, wins, &u2)?;
        let d2 = f2.n.saturating_sub(f2.k).max(1);
        (
            am::residual(&f2.p, &wins[i]),
            am::leverage(&f2.p, mask, wins, &u2, i)?,
            reference_variance(f2.rss, d2 as f64, floor, &u2),
            d2,
        )
    } else {
        (
            am::residual(&clean.p, &wins[i]),
            am::leverage(&clean.p, mask, wins, used, i)?,
            clean_s2.0,
            clean_s2.1,
        )
    };
    Some((e / (s2 * (1.0 + h)).max(1e-300).sqrt(), d))
}

#[allow(clippy::too_many_arguments)]
fn test_suspects(
    p: &Params,
    suspects: &[(usize, f64)],
    used0: &[bool],
    mask: &Mask,
    wins: &[Win],
    floor: &[f64],
    level: f64,
) -> Option<OutlierTrial> {
    let n = used0.iter().filter(|u| **u).count();
    // 2. Test each suspect against the fit on the others; iterate to a stable set.
    let mut rejected: Vec<usize> = suspects.iter().map(|s| s.0).collect();
    let mut result = None;
    for _ in 0..10 {
        let mut used = used0.to_vec();
        for &i in &rejected {
            used[i] = false;
        }
        let clean = am::fit(p, mask, wins, &used)?;
        let dof = clean.n.saturating_sub(clean.k);
        if dof < MIN_DOF_OUTLIER {
            return None;
        }
        let sigma2 = reference_variance(clean.rss, dof as f64, floor, &used);
        let mut keep = Vec::new();
        let mut pv = Vec::new();
        let mut ts = Vec::new();
        for &(i, _) in suspects {
            let t_d = deletion_t(&clean, (sigma2, dof), i, &used, mask, wins, floor)?;
            let (t, d) = t_d;
            let pval = (st::t_two_sided(t, d as f64) * n as f64).min(1.0);
            if pval < level {
                keep.push(i);
                pv.push(pval);
                ts.push(t * t);
            }
        }
        let stable = {
            let mut a = keep.clone();
            let mut b = rejected.clone();
            a.sort_unstable();
            b.sort_unstable();
            a == b
        };
        if stable {
            result = Some((keep, pv, ts, clean, used));
            break;
        }
        if keep.is_empty() {
            return None;
        }
        rejected = keep;
    }
    let (rejected, p_values, f_stats, fit, used) = result?;
    if rejected.is_empty() {
        return None;
    }
    let loo = crate::fit::press::loo(&fit, mask, wins, &used)?;
    Some(OutlierTrial {
        rejected,
        p_values,
        f_stats,
        fit,
        loo,
        used,
        screened_with: None,
        judged_cv: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` directions spread over the sphere (Fibonacci lattice).
    fn directions(n: usize) -> Vec<[f64; 3]> {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let a = golden * i as f64;
                [r * a.cos(), r * a.sin(), z]
            })
            .collect()
    }

    /// Windows whose norm is 1 g + a deterministic ±0.1 mg scatter, plus `shift` (g) on the
    /// windows listed; the identity model fitted to them.
    fn scene(n: usize, shifted: &[(usize, f64)]) -> (Vec<Win>, Fit, Mask) {
        let wins: Vec<Win> = directions(n)
            .into_iter()
            .enumerate()
            .map(|(i, d)| {
                let noise = 1e-4 * ((i as f64 * 12.9898).sin() * 43_758.545).fract();
                let extra = shifted.iter().find(|s| s.0 == i).map_or(0.0, |s| s.1);
                let k = 1.0 + noise + extra;
                Win {
                    y: d.map(|x| x * k),
                    tau: 0.0,
                    theta: 0.0,
                    slots: Default::default(),
                }
            })
            .collect();
        let mut p0 = [0.0; am::NP];
        for i in [am::KMAT, am::KMAT + 3, am::KMAT + 5] {
            p0[i] = 1.0;
        }
        let mask = am::mask_of(&[]);
        let fit = am::fit(&p0, &mask, &wins, &vec![true; n]).unwrap();
        (wins, fit, mask)
    }

    #[test]
    fn one_window_far_off_is_rejected_and_only_it() {
        let (wins, fit, mask) = scene(30, &[(11, 0.01)]);
        let t = find_outliers(&fit, &[true; 30], &mask, &wins, &[], 1e-3, 6).unwrap();
        assert_eq!(t.rejected, vec![11]);
        assert!(!t.used[11] && t.used.iter().filter(|u| **u).count() == 29);
        assert!(t.p_values[0] < 1e-3);
        // Without it the rest fits to the scatter (≈ 0.1 mg), far below the 10 mg shift.
        assert!(t.fit.rms() < 2e-4, "{}", t.fit.rms());
        assert!(t.loo[11].is_none() && t.loo.iter().flatten().count() == 29);
    }

    #[test]
    fn two_outliers_do_not_mask_each_other() {
        let (wins, fit, mask) = scene(30, &[(4, 0.008), (20, -0.006)]);
        let t = find_outliers(&fit, &[true; 30], &mask, &wins, &[], 1e-3, 6).unwrap();
        let mut r = t.rejected.clone();
        r.sort_unstable();
        assert_eq!(r, vec![4, 20]);
    }

    #[test]
    fn clean_windows_and_too_few_windows_give_nothing() {
        let (wins, fit, mask) = scene(30, &[]);
        assert!(find_outliers(&fit, &[true; 30], &mask, &wins, &[], 1e-3, 6).is_none());
        // A shift at the level of the scatter is not an outlier.
        let (wins, fit, mask) = scene(30, &[(7, 1e-4)]);
        assert!(find_outliers(&fit, &[true; 30], &mask, &wins, &[], 1e-3, 6).is_none());
        // 9 parameters need at least 13 windows before anything is screened.
        let (wins, fit, mask) = scene(12, &[(3, 0.01)]);
        assert!(find_outliers(&fit, &[true; 12], &mask, &wins, &[], 1e-3, 6).is_none());
    }

    #[test]
    fn the_noise_floor_bounds_the_reference_scale_from_below() {
        // The others scatter by ≈ 0.1 mg, so a 1.5 mg shift is ~15 of their σ: rejected when
        // the test trusts their RSS alone.
        let (wins, fit, mask) = scene(30, &[(7, 1.5e-3)]);
        let t = find_outliers(&fit, &[true; 30], &mask, &wins, &[], 1e-3, 6).unwrap();
        assert_eq!(t.rejected, vec![7]);
        // Each window's mean is known to scatter by 0.5 mg (its samples' floor): the same shift
        // is then 3 floors, ordinary among 30 windows, and nothing is rejected.
        let floor = vec![5e-4; 30];
        assert!(find_outliers(&fit, &[true; 30], &mask, &wins, &floor, 1e-3, 6).is_none());
        // A window 10 mg off is still far beyond the floor.
        let (wins, fit, mask) = scene(30, &[(7, 1e-2)]);
        let t = find_outliers(&fit, &[true; 30], &mask, &wins, &floor, 1e-3, 6).unwrap();
        assert_eq!(t.rejected, vec![7]);
        // The suspect's own floor does not count (a window that moved has a large one).
        let mut own = vec![0.0; 30];
        own[7] = 1e-2;
        let (wins, fit, mask) = scene(30, &[(7, 1.5e-3)]);
        assert!(find_outliers(&fit, &[true; 30], &mask, &wins, &own, 1e-3, 6).is_some());
        // NaN floors (too short for a batch estimate) fall back to the RSS.
        let nan = vec![f64::NAN; 30];
        let (wins, fit, mask) = scene(30, &[(7, 1.5e-3)]);
        assert!(find_outliers(&fit, &[true; 30], &mask, &wins, &nan, 1e-3, 6).is_some());
    }

    #[test]
    fn at_most_max_reject_windows_are_suspected() {
        let (wins, fit, mask) = scene(30, &[(9, 0.02), (17, -0.004)]);
        let t = find_outliers(&fit, &[true; 30], &mask, &wins, &[], 1e-3, 1).unwrap();
        assert_eq!(t.rejected, vec![9], "only the most extreme one");
        let t = find_outliers(&fit, &[true; 30], &mask, &wins, &[], 1e-3, 2).unwrap();
        assert_eq!(t.rejected.len(), 2);
    }
}

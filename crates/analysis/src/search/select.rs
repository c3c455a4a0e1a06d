//! The selection rule: which candidate, if any, is added at one greedy step.
//!
//! Everything that decides is here, in [`select`], with its constants; the rest of the
//! analysis only measures (fits, F-tests, held-out errors) and reports.
//!
//! Every p-value the rule compares with its level refers residuals to one variance,
//! [`crate::search::floor::reference_variance`]: the fit's `rss/dof`, bounded below by the mean
//! squared noise floor of the windows in use. The levels below assume that bound: with
//! `rss/dof` alone a chance-low residual variance (one recording in ~100 on ~20 dof) inflates
//! every statistic, and clean recordings gained an effect or lost a window about once in 150
//! at these same levels (docs/residuals.md).

use crate::detect::windows::{RangeError, SettingError};
use crate::error::search::SearchError;
use crate::stats as st;

/// Default family-wise significance level per greedy step, split over the hypotheses tested
/// at the step (Bonferroni: each effect as a block, each single axis of a nonlinearity, the
/// curved-drift diagnostic and the outliers — up to 13 with a temperature column — counting
/// only those the windows are enough to test). 10⁻³ rather than the usual 0.05 because a
/// recording has tens of windows and the analysis tests about a dozen hypotheses per step for
/// up to [`MAX_EFFECTS`] steps: at 0.05 a clean recording would gain a spurious effect in
/// roughly one run of five, at 10⁻³ in about one of a thousand (the false-positive rates
/// measured in docs/residuals.md: 0 of 800 clean recordings, with the single axes too).
pub const ALPHA: f64 = 1e-3;

/// Default factor by which a candidate must divide the leave-one-window-out RMS. The F-test
/// alone accepts effects that are real but too small to matter or that fit a few windows'
/// noise; requiring the held-out error to fall by 10 % keeps only effects that make the
/// calibration better on poses it has not seen.
pub const CV_FACTOR: f64 = 1.1;

/// At most this many effects are added: each step costs degrees of freedom and a 30-pose
/// recording cannot support more than a few 3-parameter blocks beyond the base 9.
pub const MAX_EFFECTS: usize = 3;

/// At most this fraction of the windows may be rejected as outliers: beyond it the "outliers"
/// are the data, and the model (not the windows) is what is wrong.
pub const MAX_OUTLIER_FRACTION: f64 = 0.2;

/// Windows beyond the parameters a parametric candidate needs before it is tried: with fewer
/// than 3 residual degrees of freedom the F-test has no power and the leave-one-out refits are
/// barely determined.
pub const MIN_DOF_TERM: usize = 3;

/// Windows beyond the parameters the outlier screen needs: the robust scale is a median of
/// residuals and the prediction-error test needs at least 3 degrees of freedom after a suspect
/// is removed, so 4 spare windows are the least that can single one out.
pub const MIN_SPARE_OUTLIER: usize = 4;

/// Residual degrees of freedom the outlier test needs in the fit on the other windows.
pub const MIN_DOF_OUTLIER: usize = 3;

/// The family-wise levels `--alpha` may take. Below 10⁻⁶ the detection limits' critical
/// values grow without bound and each costs minutes of series terms (`--alpha 1e-300` ran for
/// over a minute to add nothing); above 0.5 a clean recording gains a spurious effect at
/// almost every step.
pub const ALPHA_RANGE: (f64, f64) = (1e-6, 0.5);

/// The factors `--cv-factor` may take: below 1 a candidate that makes the held-out error
/// worse would pass; above 100 no real effect ever does (it would have to remove 99 % of the
/// held-out error).
pub const CV_FACTOR_RANGE: (f64, f64) = (1.0, 100.0);

/// A family-wise level within [`ALPHA_RANGE`].
pub fn check_alpha(v: f64) -> Result<f64, RangeError> {
    let (lo, hi) = ALPHA_RANGE;
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(RangeError::Alpha)
    }
}

/// A CV factor within [`CV_FACTOR_RANGE`].
pub fn check_cv_factor(v: f64) -> Result<f64, RangeError> {
    let (lo, hi) = CV_FACTOR_RANGE;
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(RangeError::CvFactor)
    }
}

/// Checks the two settings of the rule ([`check_alpha`], [`check_cv_factor`]); the error names
/// the setting by its keyword (`alpha`, `cv_factor`).
pub fn check_rule(alpha: f64, cv_factor: f64) -> Result<(), SearchError> {
    let named = |name, value: f64, why| {
        let e = SettingError {
            name,
            value: format!("{value:?}"),
            why,
        };
        SearchError::InvalidSetting(e.to_string())
    };
    check_alpha(alpha).map_err(|why| named("alpha", alpha, why))?;
    check_cv_factor(cv_factor).map_err(|why| named("cv_factor", cv_factor, why))?;
    Ok(())
}

/// The numbers a parametric candidate (an effect block fitted jointly with the model) was
/// measured by at this step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TermScore {
    /// p-value of its F-test (before the Bonferroni factor over candidates).
    pub p_value: f64,
    /// Its share of the step's level (weighted Bonferroni: 1, or less for a nonlinearity
    /// whose block and single axes share one family's level): significant when
    /// `p_value < level × weight`.
    pub weight: f64,
    /// Its leave-one-window-out RMS over the windows in use, g.
    pub cv: f64,
    /// The same over the windows the outlier candidate keeps (when there is one), g.
    pub cv_on_kept: Option<f64>,
    /// The core can store it (false: diagnostic only, never added).
    pub storable: bool,
    /// For several effects added at once: every member passes its drop test (the combination
    /// without it is significantly worse, F-test at the same level, and its CV at least the
    /// factor higher). True for a single effect.
    pub members_pass: bool,
}

/// The numbers the outlier candidate was measured by: its suspects already passed their own
/// Bonferroni prediction-error test ([`crate::search::outliers`]); what remains is whether rejecting them
/// helps the others.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutlierScore {
    /// Leave-one-window-out RMS of the kept windows with the suspects rejected, g.
    pub cv_kept: f64,
    /// The current model's leave-one-window-out RMS over the same kept windows, g.
    pub cv_current_kept: Option<f64>,
}

/// Outcome of one step.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// Per term candidate: its F-test passes at the step's level.
    pub significant: Vec<bool>,
    /// Per term candidate: its CV improves by the factor.
    pub cv_improved: Vec<bool>,
    /// The outlier candidate improves the CV of the kept windows by the factor.
    pub outliers_pass: bool,
    /// What is added.
    pub choice: Choice,
    /// The best diagnostic-only candidate that passes and beats every storable one (worth a
    /// sentence in the report, never added).
    pub diagnostic: Option<usize>,
}

/// What one step adds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Choice {
    /// Nothing: the step ends the search.
    Nothing,
    /// The term candidate at this index.
    Term(usize),
    /// Reject the outlier candidate's windows.
    Outliers,
}

/// The rule. A term candidate passes when its F-test p-value is below `level × weight`
/// (`level` = α divided by the hypothesis families tested at this step, `weight` its share of
/// its family: weighted Bonferroni) **and** its CV times `cv_factor` is at most the current
/// CV **and**, for several effects at once, every member passes its drop test; the passing
/// storable candidate with the lowest CV wins (so a combination wins over its parts only when
/// each part is needed). The outlier candidate passes when
/// rejecting its windows improves the CV of the kept windows by the same factor; it wins over
/// the best term candidate when its CV on the kept windows is lower than that candidate's on
/// the same windows (so that both are judged on the same poses).
pub fn select(
    terms: &[TermScore],
    outliers: Option<&OutlierScore>,
    current_cv: Option<f64>,
    level: f64,
    cv_factor: f64,
) -> Selection {
    let significant: Vec<bool> = terms.iter().map(|t| t.p_value < level * t.weight).collect();
    let cv_improved: Vec<bool> = terms
        .iter()
        .map(|t| current_cv.is_some_and(|c0| t.cv * cv_factor <= c0))
        .collect();
    let passes = |i: usize| significant[i] && cv_improved[i] && terms[i].members_pass;
    let best_among = |storable: bool| {
        (0..terms.len())
            .filter(|&i| passes(i) && terms[i].storable == storable)
            .min_by(|&a, &b| terms[a].cv.total_cmp(&terms[b].cv))
    };
    let best_term = best_among(true);
    let outliers_pass = outliers.is_some_and(|o| {
        o.cv_current_kept
            .is_some_and(|c0| o.cv_kept * cv_factor <= c0)
    });
    let choose_outliers = match (outliers, best_term) {
        (Some(o), Some(b)) if outliers_pass => {
            o.cv_kept < terms[b].cv_on_kept.unwrap_or(f64::INFINITY)
        }
        (Some(_), None) => outliers_pass,
        _ => false,
    };
    let diagnostic = best_among(false)
        .filter(|&d| !choose_outliers && best_term.is_none_or(|b| terms[d].cv < terms[b].cv));
    let choice = if choose_outliers {
        Choice::Outliers
    } else {
        best_term.map_or(Choice::Nothing, Choice::Term)
    };
    Selection {
        significant,
        cv_improved,
        outliers_pass,
        choice,
        diagnostic,
    }
}

/// RMS of the held-out residuals over the windows selected by `sel` (`None` when one of them
/// has no held-out residual or none is selected), g.
pub fn cv_over(loo: &[Option<f64>], sel: &[bool]) -> Option<f64> {
    let v: Vec<f64> = loo
        .iter()
        .zip(sel)
        .filter(|(_, s)| **s)
        .map(|(e, _)| *e)
        .collect::<Option<Vec<f64>>>()?;
    (!v.is_empty()).then(|| st::rms(&v))
}

/// Paired comparison of two sets of held-out residuals on the common windows: the two-sided
/// p-value of a paired t-test on the squared errors (`None` with fewer than 3 pairs).
pub fn paired_p(a: &[Option<f64>], b: &[Option<f64>], sel: &[bool]) -> Option<f64> {
    let d: Vec<f64> = a
        .iter()
        .zip(b)
        .zip(sel)
        .filter(|(_, s)| **s)
        .filter_map(|((x, y), _)| Some(x.as_ref()?.powi(2) - y.as_ref()?.powi(2)))
        .collect();
    if d.len() < 3 {
        return None;
    }
    let n = d.len() as f64;
    let m = d.iter().sum::<f64>() / n;
    let v = d.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    if v <= 0.0 {
        return Some(if m == 0.0 { 1.0 } else { 0.0 });
    }
    Some(st::t_two_sided(m / (v / n).sqrt(), n - 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn term(p_value: f64, cv: f64) -> TermScore {
        TermScore {
            p_value,
            weight: 1.0,
            cv,
            cv_on_kept: None,
            storable: true,
            members_pass: true,
        }
    }

    #[test]
    fn a_combination_wins_only_when_every_member_is_needed() {
        let single = term(1e-9, 0.6);
        let mut pair = term(1e-12, 0.3);
        let s = select(&[single, pair], None, Some(1.0), 1e-4, CV_FACTOR);
        assert_eq!(s.choice, Choice::Term(1));
        // One member fails its drop test: the pair is refused, the single wins.
        pair.members_pass = false;
        let s = select(&[single, pair], None, Some(1.0), 1e-4, CV_FACTOR);
        assert_eq!(s.choice, Choice::Term(0));
    }

    #[test]
    fn a_candidate_needs_both_significance_and_a_cv_gain() {
        let cur = Some(1.0);
        // Significant and 1/0.8 = 1.25 > 1.1 better: accepted.
        let s = select(&[term(1e-6, 0.8)], None, cur, 1e-4, CV_FACTOR);
        assert_eq!(s.choice, Choice::Term(0));
        // Significant but only 1/0.95 ≈ 1.05 better: refused.
        let s = select(&[term(1e-6, 0.95)], None, cur, 1e-4, CV_FACTOR);
        assert_eq!((s.significant[0], s.cv_improved[0]), (true, false));
        assert_eq!(s.choice, Choice::Nothing);
        // Much better under CV but p above the level: refused.
        let s = select(&[term(2e-4, 0.5)], None, cur, 1e-4, CV_FACTOR);
        assert_eq!((s.significant[0], s.cv_improved[0]), (false, true));
        assert_eq!(s.choice, Choice::Nothing);
        // Exactly at the factor passes (≤), just above does not.
        let s = select(&[term(0.0, 1.0 / 1.1)], None, cur, 1e-4, 1.1);
        assert!(s.cv_improved[0]);
        // Without a current CV nothing can pass.
        let s = select(&[term(0.0, 0.1)], None, None, 1e-4, CV_FACTOR);
        assert_eq!(s.choice, Choice::Nothing);
    }

    #[test]
    fn the_lowest_cv_among_passing_storable_candidates_wins() {
        let mut diag = term(1e-9, 0.3);
        diag.storable = false;
        let terms = [term(1e-9, 0.7), term(1e-9, 0.5), term(0.5, 0.1), diag];
        let s = select(&terms, None, Some(1.0), 1e-4, CV_FACTOR);
        // 2 has the lowest CV but is not significant; 3 is lower but diagnostic only.
        assert_eq!(s.choice, Choice::Term(1));
        assert_eq!(s.diagnostic, Some(3));
        // A diagnostic that does not beat the winner is not mentioned.
        let mut terms = terms;
        terms[3].cv = 0.6;
        let s = select(&terms, None, Some(1.0), 1e-4, CV_FACTOR);
        assert_eq!(s.diagnostic, None);
    }

    #[test]
    fn outliers_win_only_when_better_on_the_windows_they_keep() {
        let out = OutlierScore {
            cv_kept: 0.4,
            cv_current_kept: Some(0.9),
        };
        // No passing term: the outliers are taken.
        let s = select(&[term(0.5, 0.5)], Some(&out), Some(1.0), 1e-4, CV_FACTOR);
        assert_eq!(s.choice, Choice::Outliers);
        // A passing term that does worse on the kept windows: still the outliers.
        let mut t = term(1e-9, 0.6);
        t.cv_on_kept = Some(0.5);
        let s = select(&[t], Some(&out), Some(1.0), 1e-4, CV_FACTOR);
        assert_eq!(s.choice, Choice::Outliers);
        // A term that explains the kept windows better wins.
        t.cv_on_kept = Some(0.3);
        let s = select(&[t], Some(&out), Some(1.0), 1e-4, CV_FACTOR);
        assert_eq!(s.choice, Choice::Term(0));
        // Rejection that does not help the others by the factor is refused.
        let weak = OutlierScore {
            cv_kept: 0.85,
            cv_current_kept: Some(0.9),
        };
        let s = select(&[], Some(&weak), Some(1.0), 1e-4, CV_FACTOR);
        assert!(!s.outliers_pass);
        assert_eq!(s.choice, Choice::Nothing);
    }

    #[test]
    fn rule_settings_are_checked() {
        assert!(check_rule(ALPHA, CV_FACTOR).is_ok());
        assert!(check_rule(0.0, 1.1).is_err());
        assert!(check_rule(1.0, 1.1).is_err());
        assert!(check_rule(f64::NAN, 1.1).is_err());
        assert!(check_rule(0.01, 0.99).is_err());
        // The ranges' ends are in, a step beyond them out, and the error names the setting.
        assert!(check_rule(1e-6, 1.0).is_ok() && check_rule(0.5, 100.0).is_ok());
        let tiny = check_rule(1e-300, 1.1).unwrap_err().to_string();
        assert_eq!(
            tiny,
            "alpha = 1e-300: give a significance level from 0.000001 to 0.5"
        );
        assert!(check_rule(0.51, 1.1).is_err());
        let big = check_rule(0.01, 1e300).unwrap_err().to_string();
        assert_eq!(big, "cv_factor = 1e300: give a factor from 1 to 100");
    }

    #[test]
    fn paired_test_and_cv_over_selected_windows() {
        let a = [Some(1.0), Some(2.0), Some(3.0), None];
        assert_eq!(cv_over(&a, &[true, false, false, false]), Some(1.0));
        assert_eq!(cv_over(&a, &[true, false, false, true]), None);
        assert_eq!(cv_over(&a, &[false; 4]), None);
        let b = [Some(1.0), Some(2.0), Some(3.0), Some(0.0)];
        // Identical errors: no difference at all.
        assert_eq!(paired_p(&a, &b, &[true; 4]), Some(1.0));
        // Held-out errors consistently ten times smaller: a clear difference.
        let x = [1.0, 1.1, 0.9, 1.05, 0.95].map(Some);
        let y = [0.1, 0.12, 0.08, 0.11, 0.09].map(Some);
        assert!(paired_p(&x, &y, &[true; 5]).unwrap() < 1e-3);
        // Fewer than three pairs: no test.
        assert_eq!(paired_p(&x, &y, &[true, true, false, false, false]), None);
    }
}

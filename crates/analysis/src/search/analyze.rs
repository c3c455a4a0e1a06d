//! The residual analysis of a multi-position recording: finds what the linear model leaves
//! unexplained, traces it to an effect the model lacks, adds that effect and reports the error
//! before and after, in-sample and under cross-validation. A file with a `pose` column goes to
//! [`crate::search::six_contrasts`] instead.
//!
//! 1. Static windows are detected and the base 9-parameter model fitted exactly as the base
//!    fit does ([`crate::detect::windows`], [`crate::fit::base`]: the core's detector and `f32`
//!    Levenberg–Marquardt).
//! 2. The base model is refined in `f64` ([`crate::fit::model`]); each window's residual is
//!    `‖a‖ − 1 g`, compared with the noise floor ([`crate::search::floor`]).
//! 3. A step of one axis's bias at a gap between windows (a knock, [`crate::search::bias_step`])
//!    is searched first, so that a smooth candidate cannot stand in for it; then candidate
//!    effects ([`crate::search::candidate`]) are tried greedily ([`crate::search::trial`],
//!    [`crate::search::outliers`]) and one per step is added by the rule of [`crate::search::select`]; the
//!    evidence is written by [`crate::search::evidence`].
//! 4. The final model is stored in the core's `f32` [`Calibration`] (`effects`), so that
//!    `Calibration::correct(m, &Conditions { time_s: t − t₀, temperature_c })` reproduces it,
//!    with `t₀` the time of the first sample ([`AnalyzeReport::time_origin_s`]).

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use crate::detect::windows::{detect_windows, Windows};
use crate::error::search::SearchError;
use crate::error::Result;
use crate::fit::base::fit_means_named;
use crate::fit::model::{self as am, Fit, Normalisation, Part, Term, Win};
use crate::input::recording::Recording;
use crate::report::contract::{
    AnalyzeReport, CandidateReport, EffectReport, ModelSummary, StepReport, WindowInfo,
};
use crate::report::progress::{Progress, Stage};
use crate::search::bias_step;
use crate::search::candidate::Candidate;
use crate::search::correlates::{residual_correlates, span_of, WindowPoint};
use crate::search::evidence::{self as ev, TermContext};
use crate::search::floor::{chi2_summary, floors, reference_variance};
use crate::search::limits;
use crate::search::open_basis_screening::{self, LAG_MAX_FRACTION};
use crate::search::options::AnalyzeOptions;
use crate::search::outliers::{find_outliers, OutlierTrial};
use crate::search::select::{check_rule, cv_over, select, Choice, OutlierScore, TermScore};
use crate::search::thermal::{self, SampleTemps};
use crate::search::trial::{
    base_mask, block_weight, bonferroni_weights, drop_tests, mask_for, term_note, try_term,
    CandSpec, State, TermTrial,
};
use crate::source::RowSource;
use crate::stats as st;
use wiical_core::multipos::MultiPosModel;
use wiical_core::Calibration;

/// Runs the analysis on a recording you hold: a `pose` column's six faces by
/// [`crate::search::six_contrasts`], everything else by the analysis of its rows that a large
/// file read in passes gets too (one code).
pub fn analyze(rec: &Recording, opts: &AnalyzeOptions) -> Result<AnalyzeReport> {
    if rec.labels.is_some() {
        check_rule(opts.alpha, opts.cv_factor)?;
        return Ok(crate::search::six_contrasts::analyze_six(rec, opts)?);
    }
    analyze_rows(rec, opts)
}

/// The analysis of the rows of `src`, held or a large file read in passes (one code, so the
/// same report): the windows detected and their protocol recognised; six faces by
/// [`crate::search::six_contrasts`] on each face's rows (read where they are kept), free
/// poses by the multi-position pipeline of this module ([`analyze_windows`]).
pub(crate) fn analyze_rows<R: RowSource + ?Sized>(
    src: &R,
    opts: &AnalyzeOptions,
) -> Result<AnalyzeReport> {
    check_rule(opts.alpha, opts.cv_factor)?;
    opts.progress.report(Progress {
        stage: Stage::Windows,
        done: 0,
        total: 0,
    });
    let ws = detect_windows(src, &opts.fit.detect);
    src.check()?;
    let ws = ws?;
    if let Some(labelled) = crate::protocol::labelled::faces_recording(src, &ws)? {
        src.check()?;
        return Ok(crate::search::six_contrasts::analyze_six(&labelled, opts)?);
    }
    analyze_windows(src, ws, opts)
}

/// The multi-position analysis of windows already found in the rows of `src`: detected by
/// [`analyze_rows`], or read from a window-mean table ([`crate::input::window_means`]);
/// everything after the detection is the same pipeline.
pub(crate) fn analyze_windows<R: RowSource + ?Sized>(
    src: &R,
    ws: Windows,
    opts: &AnalyzeOptions,
) -> Result<AnalyzeReport> {
    check_rule(opts.alpha, opts.cv_factor)?;
    let report = |stage, done, total| opts.progress.report(Progress { stage, done, total });
    let mut ctx = Context::new(ws, opts)?;
    report(Stage::BaseFit, 0, 1);
    let base = ctx.base_fit()?;
    report(Stage::BaseFit, 1, 1);
    let mut search = Search::new(&ctx, &base);
    if base.loo.is_some() {
        // A restricted candidate list is the user's choice of effects: the bias step and the
        // open basis, which could stand in for a withheld candidate, run only when every
        // candidate is allowed.
        let steps = match opts.candidates {
            None => {
                let sc = step_context(&ctx.nrm, &ctx.ws, ctx.temp_range, opts);
                let (steps, rows) = bias_step::search(&sc, &mut search.state, &mut ctx.wins);
                search.effects.extend(rows);
                steps
            }
            Some(_) => Vec::new(),
        };
        while search.effects.len() < opts.max_effects + steps.len() && search.step(&ctx) {}
        if opts.candidates.is_none() {
            let has_temp = ctx.temp_range > 0.05;
            // The rows' temperature history, read only when the open basis will use it (it
            // needs a temperature spread).
            let taus = thermal::lag_grid(LAG_MAX_FRACTION * ctx.duration);
            let temps = match has_temp && src.has_temp() {
                true => Some(SampleTemps::of(src, &ctx.ws, &opts.fit.detect, &taus)?),
                false => None,
            };
            let hc = open_basis_screening::HostContext {
                nrm: &ctx.nrm,
                has_time: ctx.duration > 0.0,
                has_temp,
                units: ctx.ws.units,
                samples: temps.as_ref(),
            };
            let open = open_basis_screening::extend(
                &mut search.state,
                &mut ctx.wins,
                ctx.model,
                opts,
                &hc,
            );
            search.effects.extend(open.effects);
            search.host_terms = open.host_terms;
        }
        if !steps.is_empty() {
            let sc = step_context(&ctx.nrm, &ctx.ws, ctx.temp_range, opts);
            let rows = &mut search.effects[..steps.len()];
            bias_step::refit_jointly(&sc, &mut search.state, &ctx.wins, &steps, rows);
        }
    }
    ctx.report(src.len(), &base, search)
}

/// What the bias-step search reads ([`bias_step::StepContext`]).
fn step_context<'a>(
    nrm: &'a Normalisation,
    ws: &'a Windows,
    temp_range: f64,
    opts: &'a AnalyzeOptions,
) -> bias_step::StepContext<'a> {
    bias_step::StepContext {
        nrm,
        stats: &ws.stats,
        units: ws.units,
        has_temp: temp_range > 0.05,
        opts,
        model: opts.fit.model,
    }
}

/// What the analysis knows about the recording once the windows are found.
struct Context<'a> {
    opts: &'a AnalyzeOptions,
    model: MultiPosModel,
    ws: Windows,
    nrm: Normalisation,
    wins: Vec<Win>,
    /// The core's f32 base fit, the f64 refinement's starting point.
    core_cal: Calibration,
    /// Recording duration, s.
    duration: f64,
    /// Range of the window temperatures, °C (0 without a temperature column).
    temp_range: f64,
    /// Correlation of window time and temperature.
    time_temp_r: Option<f64>,
}

/// The base model and its noise floor.
struct Base {
    fit: Fit,
    loo: Option<Vec<Option<f64>>>,
    floor: Vec<f64>,
    noise_floor: f64,
    noise_floor_batch: Option<f64>,
}

impl<'a> Context<'a> {
    fn new(ws: Windows, opts: &'a AnalyzeOptions) -> Result<Self> {
        let model = opts.fit.model;
        let means32: Vec<[f32; 3]> = ws.stats.iter().map(|w| w.mean.map(|x| x as f32)).collect();
        let core_cal = fit_means_named(&means32, model, "model")
            .map_err(|e| e.found_by(opts.fit.detect.adaptive))?
            .calibration;
        let means: Vec<[f64; 3]> = ws.stats.iter().map(|w| w.mean).collect();
        let times: Vec<f64> = ws.stats.iter().map(|w| w.t_centre).collect();
        let temps: Option<Vec<f64>> = ws.stats.iter().map(|w| w.temp).collect();
        let nrm = Normalisation::of(&means, &times, temps.as_deref());
        let wins: Vec<Win> = ws
            .stats
            .iter()
            .map(|w| nrm.window(&w.mean, w.t_centre, w.temp))
            .collect();
        let duration = ws.clock.map_or(0.0, |(first, last)| last - first);
        let temp_info = temps.as_ref().map(|t| {
            let lo = t.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = t.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            (hi - lo, st::correlation(&times, t))
        });
        Ok(Context {
            opts,
            model,
            ws,
            nrm,
            wins,
            core_cal,
            duration,
            temp_range: temp_info.map_or(0.0, |x| x.0),
            time_temp_r: temp_info.map(|x| x.1),
        })
    }

    fn n(&self) -> usize {
        self.wins.len()
    }

    /// The f64 refinement of the base fit, its held-out residuals and the noise floor.
    fn base_fit(&self) -> Result<Base> {
        let p0 = self.nrm.params_from(&self.core_cal);
        let bmask = base_mask(self.model);
        let all = vec![true; self.n()];
        let fit = am::fit(&p0, &bmask, &self.wins, &all).ok_or(SearchError::RefinementFailed)?;
        let loo = crate::fit::press::loo(&fit, &bmask, &self.wins, &all);
        let floor = floors(&fit.p, &self.wins, &self.ws.stats, self.nrm.scale, false);
        let floor_batch = floors(&fit.p, &self.wins, &self.ws.stats, self.nrm.scale, true);
        let fb: Vec<f64> = floor_batch
            .iter()
            .copied()
            .filter(|x| x.is_finite())
            .collect();
        Ok(Base {
            noise_floor: st::rms(&floor),
            noise_floor_batch: (!fb.is_empty()).then(|| st::rms(&fb)),
            fit,
            loo,
            floor,
        })
    }

    /// The parametric candidates to try on top of `state`: each effect alone (the axes of its
    /// block the model lacks), for the nonlinearities each of those axes alone when there are
    /// several ([`Term::splits_by_axis`]: a one-axis nonlinearity costs one parameter, not
    /// three, so a recording too short for the block can still test it), every combination of up to `room` whole effects (several effects at
    /// once: with one of two effects unmodelled, the other's F-test divides by a residual
    /// variance the first inflates, so neither passes alone), and the curved-drift
    /// diagnostic. Single axes enter no combination, so the candidates grow linearly with the
    /// axes, not with their subsets.
    fn candidate_specs(&self, state: &State, room: usize) -> Vec<CandSpec> {
        let mut blocks = Vec::new();
        for t in Term::ALL {
            let candidate = t.effect();
            let have = state.axes_of(t);
            if have == [true; 3] || !self.opts.allows(candidate) {
                continue;
            }
            if t.needs_temperature() && !(self.temp_range > 0.05) {
                continue;
            }
            if t == Term::Drift && !(self.duration > 0.0) {
                continue;
            }
            blocks.push(Part {
                term: t,
                axes: have.map(|h| !h),
            });
        }
        let mut specs: Vec<CandSpec> = blocks
            .iter()
            .map(|&p| CandSpec::single(p.term.effect(), vec![p]))
            .collect();
        for p in blocks
            .iter()
            .filter(|p| p.count() > 1 && p.term.splits_by_axis())
        {
            for a in (0..3).filter(|a| p.axes[*a]) {
                let one = Part::axis(p.term, a);
                specs.push(CandSpec::single(p.term.effect(), vec![one]));
            }
        }
        for size in 2..=room.min(blocks.len()) {
            for combo in subsets(&blocks, size) {
                specs.push(CandSpec::combination(combo));
            }
        }
        if self.duration > 0.0
            && self.opts.allows(Candidate::BiasDriftCurved)
            && state.axes_of(Term::Drift2) != [true; 3]
        {
            let mut parts = Vec::new();
            let drift = state.axes_of(Term::Drift);
            if drift != [true; 3] {
                parts.push(Part {
                    term: Term::Drift,
                    axes: drift.map(|h| !h),
                });
            }
            parts.push(Part::block(Term::Drift2));
            specs.push(CandSpec::single(Candidate::BiasDriftCurved, parts));
        }
        specs
    }

    /// What the detection limits need ([`crate::search::limits`]).
    fn limit_context(&self) -> limits::LimitContext<'_> {
        limits::LimitContext {
            model: self.model,
            wins: &self.wins,
            nrm: &self.nrm,
            duration: self.duration,
            cv_factor: self.opts.cv_factor,
        }
    }

    /// Times of the windows' first and last samples, s.
    fn window_times(&self) -> Vec<(f64, f64)> {
        self.ws
            .stats
            .iter()
            .map(|w| (w.t_first, w.t_last))
            .collect()
    }
}

/// The last step's whole effects that did not pass (each candidate by itself: no single
/// axis, no combination), as "no X above L unit" ([`limits::phrase`]).
fn whole_effect_limits(steps: &[StepReport]) -> Vec<String> {
    let Some(last) = steps.last() else {
        return Vec::new();
    };
    last.candidates
        .iter()
        .filter(|c| Candidate::CANDIDATES.iter().any(|k| k.name() == c.name))
        .filter_map(|c| {
            Some(limits::phrase(
                &c.name,
                c.detection_limit?,
                c.detection_unit.as_deref()?,
            ))
        })
        .collect()
}

/// Every `size`-element subset of `items`, in lexicographic order of positions.
fn subsets<T: Copy>(items: &[T], size: usize) -> Vec<Vec<T>> {
    let mut out = Vec::new();
    let mut idx: Vec<usize> = (0..size).collect();
    if size == 0 || size > items.len() {
        return out;
    }
    loop {
        out.push(idx.iter().map(|&i| items[i]).collect());
        // Advance the rightmost position that can still move.
        let Some(k) = (0..size).rev().find(|&k| idx[k] < items.len() - size + k) else {
            return out;
        };
        idx[k] += 1;
        for j in k + 1..size {
            idx[j] = idx[j - 1] + 1;
        }
    }
}

/// The greedy search: the current model and what has been added so far.
struct Search {
    state: State,
    effects: Vec<EffectReport>,
    steps: Vec<StepReport>,
    first_signature: Option<Vec<f64>>,
    outliers_done: bool,
    diagnostics: Vec<String>,
    /// The open basis's accepted time and temperature terms ([`open_basis_screening::Extension`]).
    host_terms: Vec<crate::report::host_term::HostTerm>,
}

/// The candidates tried at one step.
struct StepTrials {
    level: f64,
    cur_cv: Option<f64>,
    reports: Vec<CandidateReport>,
    terms: Vec<TermTrial>,
    outliers: Option<(usize, OutlierTrial)>,
}

impl Search {
    fn new(ctx: &Context<'_>, base: &Base) -> Self {
        let n = ctx.n();
        Search {
            state: State {
                parts: Vec::new(),
                used: vec![true; n],
                fit: base.fit.clone(),
                loo: base.loo.clone().unwrap_or_else(|| vec![None; n]),
                floor: base.floor.clone(),
            },
            effects: Vec::new(),
            steps: Vec::new(),
            first_signature: None,
            outliers_done: false,
            diagnostics: Vec::new(),
            host_terms: Vec::new(),
        }
    }

    /// Tries every candidate once; returns false when the search ends.
    fn step(&mut self, ctx: &Context<'_>) -> bool {
        let Some(mut tr) = self.trials(ctx) else {
            return false;
        };
        let (scores, out_score) = self.scores(&tr);
        let sel = select(
            &scores,
            out_score.as_ref(),
            tr.cur_cv,
            tr.level,
            ctx.opts.cv_factor,
        );
        for (i, t) in tr.terms.iter_mut().enumerate() {
            let (sig, ok, storable) = (sel.significant[i], sel.cv_improved[i], scores[i].storable);
            t.passes_rules = sig && ok && t.members_pass();
            let rep = &mut tr.reports[t.report];
            rep.passed = t.passes_rules && storable;
            rep.note = term_note(t, (sig, ok, storable), tr.level, ctx.opts.cv_factor);
        }
        if let Some((idx, o)) = &tr.outliers {
            tr.reports[*idx].passed = sel.outliers_pass;
            tr.reports[*idx].note =
                ev::outlier_note(&o.rejected, sel.outliers_pass, ctx.opts.cv_factor);
        }
        self.fill_limits(ctx, &mut tr, sel.outliers_pass);
        if let Some(d) = sel.diagnostic {
            self.diagnostics
                .push(ev::diagnostic_text(&tr.terms[d], tr.cur_cv));
        }
        let mut step = StepReport {
            candidates: std::mem::take(&mut tr.reports),
            level: tr.level,
            accepted: None,
        };
        match sel.choice {
            Choice::Nothing => {
                self.steps.push(step);
                false
            }
            Choice::Outliers => {
                let (_, ot) = tr.outliers.take().expect("outliers chosen");
                let best_smooth = scores
                    .iter()
                    .enumerate()
                    .filter(|(i, s)| s.storable && tr.terms[*i].passes_rules)
                    .min_by(|a, b| a.1.cv.total_cmp(&b.1.cv))
                    .map(|(i, _)| &tr.terms[i]);
                step.accepted = Some(Candidate::Outliers.to_string());
                self.steps.push(step);
                self.accept_outliers(ctx, ot, best_smooth);
                true
            }
            Choice::Term(b) => {
                step.accepted = Some(tr.terms[b].name());
                self.steps.push(step);
                self.accept_term(ctx, b, &tr);
                true
            }
        }
    }

    /// The detection limit of every candidate of the step that did not pass
    /// ([`crate::search::limits`]): a term that passed the rule (accepted, or beaten by a
    /// better one) has none, nor the outlier candidate once some window stood out.
    fn fill_limits(&self, ctx: &Context<'_>, tr: &mut StepTrials, outliers_pass: bool) {
        let lc = ctx.limit_context();
        for t in tr.terms.iter().filter(|t| !t.passes_rules) {
            if let Some((l, unit)) = limits::term_limit(&lc, &self.state, t, tr.level * t.weight) {
                tr.reports[t.report].detection_limit = Some(l);
                tr.reports[t.report].detection_unit = Some(unit);
            }
        }
        let idx = tr
            .reports
            .iter()
            .position(|r| r.name == Candidate::Outliers.to_string());
        if let (Some(i), None, false) = (idx, &tr.outliers, outliers_pass) {
            if let Some(l) = limits::outlier_limit(&lc, &self.state, tr.level) {
                tr.reports[i].detection_limit = Some(l);
                tr.reports[i].detection_unit = Some(limits::OUTLIER_UNIT.to_string());
            }
        }
    }

    /// What the selection rule sees of each candidate of the step.
    fn scores(&self, tr: &StepTrials) -> (Vec<TermScore>, Option<OutlierScore>) {
        let scores: Vec<TermScore> = tr
            .terms
            .iter()
            .map(|t| TermScore {
                p_value: t.p,
                weight: t.weight,
                cv: t.cv,
                cv_on_kept: tr
                    .outliers
                    .as_ref()
                    .map(|(_, o)| cv_over(&t.loo, &o.used).unwrap_or(f64::INFINITY)),
                storable: t.candidate.storable(),
                members_pass: t.members_pass(),
            })
            .collect();
        let out_score = tr.outliers.as_ref().map(|(_, o)| match o.judged_cv {
            Some((cv_kept, cv_current_kept)) => OutlierScore {
                cv_kept,
                cv_current_kept,
            },
            None => OutlierScore {
                cv_kept: cv_over(&o.loo, &o.used).unwrap_or(f64::INFINITY),
                cv_current_kept: cv_over(&self.state.loo, &o.used),
            },
        });
        (scores, out_score)
    }

    /// Fits every candidate of this step (`None`: nothing left to try).
    fn trials(&self, ctx: &Context<'_>) -> Option<StepTrials> {
        let room = ctx.opts.max_effects.saturating_sub(self.effects.len());
        let specs = ctx.candidate_specs(&self.state, room);
        let try_outliers = !self.outliers_done && ctx.opts.allows(Candidate::Outliers);
        // Bonferroni over the hypotheses tested at this step, weighted
        // (`bonferroni_weights`): α/m per family (an effect with its single axes, the
        // diagnostic, the outliers) that the windows are enough to test, shared within a
        // nonlinearity's family by the block and its axes. A combination is no new
        // hypothesis: every member must pass its own drop test at its block's level.
        let (families, weights) = bonferroni_weights(&specs, &self.state, ctx.model);
        let m = families + usize::from(try_outliers);
        if m == 0 {
            return None;
        }
        let level = ctx.opts.alpha / m as f64;
        let cur_cv = cv_over(&self.state.loo, &self.state.used);
        let mut reports = Vec::new();
        let mut terms = Vec::new();
        let stage = Stage::Candidates {
            step: self.steps.len() + 1,
        };
        let total = specs.len() + usize::from(try_outliers);
        let progress = |done| ctx.opts.progress.report(Progress { stage, done, total });
        for (done, spec) in specs.iter().enumerate() {
            progress(done);
            let (rep, trial) = try_term(spec, &self.state, ctx.model, &ctx.wins, cur_cv);
            if let Some(mut t) = trial {
                t.report = reports.len();
                t.weight = weights[done];
                terms.push(t);
            }
            reports.push(rep);
        }
        for i in 0..terms.len() {
            if terms[i].is_combination() {
                let level_of = |t| level * block_weight(t, &specs, &weights, &self.state);
                let drops =
                    drop_tests(&terms[i], &terms, &self.state, level_of, ctx.opts.cv_factor);
                terms[i].drops = drops;
            }
        }
        let mut outliers = None;
        progress(specs.len());
        if try_outliers {
            let (rep, trial) = self.outlier_trial(ctx, level, &terms);
            if let Some(t) = trial {
                outliers = Some((reports.len(), t));
            }
            reports.push(rep);
            progress(total);
        }
        Some(StepTrials {
            level,
            cur_cv,
            reports,
            terms,
            outliers,
        })
    }

    /// The outlier candidate's report row (verdict filled in later) and trial. The screen runs
    /// under the current model and under the current model plus each single effect tried at
    /// this step: an effect the model still lacks inflates the robust scale and can hide the
    /// windows that were not still (and they, in turn, hide the effect from its F-test). The
    /// screen whose kept windows that model explains best (lowest CV) is taken; its windows
    /// are then judged under the current model, refitted without them.
    fn outlier_trial(
        &self,
        ctx: &Context<'_>,
        level: f64,
        terms: &[TermTrial],
    ) -> (CandidateReport, Option<OutlierTrial>) {
        let n_used = self.state.n_used();
        let max_reject = ((ctx.opts.max_outlier_fraction * n_used as f64).floor() as usize).max(1);
        let cur_mask = mask_for(ctx.model, &self.state.parts);
        let screen = |fit: &am::Fit, mask: &am::Mask, level: f64| {
            find_outliers(
                fit,
                &self.state.used,
                mask,
                &ctx.wins,
                &self.state.floor,
                level,
                max_reject,
            )
        };
        let mut tr = screen(&self.state.fit, &cur_mask, level);
        if tr.is_none() {
            // Every extra model screened is one more chance of a false rejection: Bonferroni
            // over the models.
            // Whole blocks only: screening under every single axis too would multiply the
            // models (and divide the level) without a new kind of effect.
            let screened =
                |t: &&TermTrial| !t.is_combination() && !t.axis_member && t.candidate.storable();
            let models = 1 + terms.iter().filter(screened).count();
            let level = level / models as f64;
            let mut best: Option<(f64, OutlierTrial, String)> = None;
            for t in terms.iter().filter(screened) {
                let mut with = self.state.parts.clone();
                with.extend(t.parts.iter().copied());
                let Some(o) = screen(&t.fit, &mask_for(ctx.model, &with), level) else {
                    continue;
                };
                // The screen is justified only if the effect it assumed is then significant on
                // the kept windows (the F-test it failed because of them).
                let Some(cur_kept) = am::fit(&self.state.fit.p, &cur_mask, &ctx.wins, &o.used)
                else {
                    continue;
                };
                let dof = o.fit.n.saturating_sub(o.fit.k).max(1) as f64;
                let s2 = reference_variance(o.fit.rss, dof, &self.state.floor, &o.used);
                let f = ((cur_kept.rss - o.fit.rss).max(0.0) / t.dp as f64) / s2;
                if !(crate::stats::f_sf(f, t.dp as f64, dof) < level) {
                    continue;
                }
                let cv = cv_over(&o.loo, &o.used).unwrap_or(f64::INFINITY);
                if best.as_ref().is_none_or(|b| cv < b.0) {
                    best = Some((cv, o, t.name()));
                }
            }
            tr = best.and_then(|(cv_kept, o, name)| {
                let with = terms.iter().find(|t| t.name() == name)?;
                let cv_before = cv_over(&with.loo, &o.used);
                let fit = am::fit(&self.state.fit.p, &cur_mask, &ctx.wins, &o.used)?;
                let loo = crate::fit::press::loo(&fit, &cur_mask, &ctx.wins, &o.used)?;
                Some(OutlierTrial {
                    fit,
                    loo,
                    screened_with: Some(name),
                    judged_cv: Some((cv_kept, cv_before)),
                    ..o
                })
            });
        }
        (self.outlier_report(&tr), tr)
    }

    /// The outlier candidate's line in the step's report.
    fn outlier_report(&self, tr: &Option<OutlierTrial>) -> CandidateReport {
        let mut rep = CandidateReport {
            name: Candidate::Outliers.to_string(),
            params: 0,
            rms_mg: None,
            cv_rms_mg: None,
            cv_rms_current_mg: None,
            f_stat: None,
            p_value: None,
            passed: false,
            note: "no window stands out (robust screen + Bonferroni prediction-error test)".into(),
            windows_short: None,
            detection_limit: None,
            detection_unit: None,
        };
        if let Some(tr) = &tr {
            let cv_kept = cv_over(&tr.loo, &tr.used).unwrap_or(f64::INFINITY);
            rep.params = tr.rejected.len();
            rep.rms_mg = Some(tr.fit.rms() * 1e3);
            let (cv_kept, cv_cur) = tr
                .judged_cv
                .unwrap_or((cv_kept, cv_over(&self.state.loo, &tr.used)));
            rep.cv_rms_mg = Some(cv_kept * 1e3);
            rep.cv_rms_current_mg = cv_cur.map(|x| x * 1e3);
            rep.f_stat = tr.f_stats.iter().copied().reduce(f64::min);
            rep.p_value = tr.p_values.iter().copied().reduce(f64::max);
        }
        rep
    }

    fn accept_outliers(
        &mut self,
        ctx: &Context<'_>,
        ot: OutlierTrial,
        best_smooth: Option<&TermTrial>,
    ) {
        let evidence = ev::outlier_evidence(&ot, &self.state.loo, &ctx.window_times(), best_smooth);
        if self.first_signature.is_none() {
            let sig = (0..ctx.n())
                .map(|i| {
                    if ot.rejected.contains(&i) {
                        am::residual(&self.state.fit.p, &ctx.wins[i]) * 1e3
                    } else {
                        0.0
                    }
                })
                .collect();
            self.first_signature = Some(sig);
        }
        self.effects.push(EffectReport {
            name: Candidate::Outliers.to_string(),
            params: ot.rejected.len(),
            rms_mg: ot.fit.rms() * 1e3,
            cv_rms_mg: cv_over(&ot.loo, &ot.used).map(|x| x * 1e3),
            cv_rms_before_mg: cv_over(&self.state.loo, &ot.used).map(|x| x * 1e3),
            evidence,
            f_stat: ot.f_stats.iter().copied().reduce(f64::min),
            p_value: ot.p_values.iter().copied().reduce(f64::max),
            values: None,
            std_errors: None,
            unit: None,
            rejected_windows: Some(ot.rejected.iter().map(|i| i + 1).collect()),
            cv_profile: None,
        });
        self.state.used = ot.used;
        self.state.fit = ot.fit;
        self.state.loo = ot.loo;
        self.outliers_done = true;
    }

    fn accept_term(&mut self, ctx: &Context<'_>, b: usize, tr: &StepTrials) {
        let bt = &tr.terms[b];
        let mut new_parts = self.state.parts.clone();
        new_parts.extend(bt.parts.iter().copied());
        let mask = mask_for(ctx.model, &new_parts);
        let se = am::standard_errors(&bt.fit, &mask, &ctx.wins, &self.state.used);
        if self.first_signature.is_none() {
            let sig = (0..ctx.n())
                .map(|i| {
                    (am::residual(&self.state.fit.p, &ctx.wins[i])
                        - am::residual(&bt.fit.p, &ctx.wins[i]))
                        * 1e3
                })
                .collect();
            self.first_signature = Some(sig);
        }
        if bt.is_combination() {
            self.accept_combination(ctx, bt, tr, &se);
        } else {
            let (vals, ses, unit) =
                ev::term_values(bt.parts[0], &ctx.nrm, &bt.fit.p, &se, ctx.duration);
            let tctx = TermContext {
                current: &self.state.fit,
                used: &self.state.used,
                wins: &ctx.wins,
                cur_cv: tr.cur_cv,
                time_temp_r: ctx.time_temp_r,
            };
            let evidence = ev::term_evidence(&tctx, bt, &tr.terms, (&vals, &ses, &unit));
            self.effects.push(EffectReport {
                name: bt.name(),
                params: bt.dp,
                rms_mg: bt.fit.rms() * 1e3,
                cv_rms_mg: Some(bt.cv * 1e3),
                cv_rms_before_mg: tr.cur_cv.map(|x| x * 1e3),
                evidence,
                f_stat: Some(bt.f),
                p_value: Some(bt.p),
                values: Some(vals),
                std_errors: Some(ses),
                unit: Some(unit),
                rejected_windows: None,
                cv_profile: None,
            });
        }
        self.state.parts = new_parts;
        self.state.fit = bt.fit.clone();
        self.state.loo = bt.loo.clone();
    }

    /// One effect report per member of an accepted combination, the most needed first
    /// (highest CV without it): each member's numbers are its drop test, so its evidence says
    /// what the other members leave and how much of that it explains.
    fn accept_combination(
        &mut self,
        ctx: &Context<'_>,
        bt: &TermTrial,
        tr: &StepTrials,
        se: &am::Params,
    ) {
        let mut drops = bt.drops.clone();
        drops.sort_by(|a, b| b.cv_without.total_cmp(&a.cv_without));
        for d in &drops {
            let rest: Vec<Part> = bt.parts.iter().copied().filter(|t| *t != d.part).collect();
            let without = tr
                .terms
                .iter()
                .find(|t| t.adds(&rest) && t.candidate != Candidate::BiasDriftCurved)
                .map(|t| &t.fit);
            let (vals, ses, unit) = ev::term_values(d.part, &ctx.nrm, &bt.fit.p, se, ctx.duration);
            let mctx = ev::MemberContext {
                without: without.unwrap_or(&self.state.fit),
                used: &self.state.used,
                wins: &ctx.wins,
                time_temp_r: ctx.time_temp_r,
            };
            let evidence = ev::member_evidence(&mctx, bt, d, &tr.terms, (&vals, &ses, &unit));
            self.effects.push(EffectReport {
                name: d.part.name(),
                params: d.part.count(),
                rms_mg: bt.fit.rms() * 1e3,
                cv_rms_mg: Some(bt.cv * 1e3),
                cv_rms_before_mg: Some(d.cv_without * 1e3),
                evidence,
                f_stat: Some(d.f),
                p_value: Some(d.p),
                values: Some(vals),
                std_errors: Some(ses),
                unit: Some(unit),
                rejected_windows: None,
                cv_profile: None,
            });
        }
    }
}

impl Context<'_> {
    /// The base and final model summaries.
    fn summaries(&self, base: &Base, state: &State) -> (ModelSummary, ModelSummary) {
        let n = self.n();
        let all = vec![true; n];
        let k_base = base_mask(self.model).iter().filter(|x| **x).count();
        let k_terms = am::with_open(mask_for(self.model, &state.parts), &self.wins)
            .iter()
            .filter(|x| **x)
            .count();
        let (c2b, dofb, pb) = chi2_summary(&base.fit.p, &self.wins, &all, &base.floor, k_base);
        let (c2f, doff, pf) =
            chi2_summary(&state.fit.p, &self.wins, &state.used, &base.floor, k_terms);
        let base_summary = ModelSummary {
            params: k_base,
            rms_mg: base.fit.rms() * 1e3,
            cv_rms_mg: base
                .loo
                .as_ref()
                .and_then(|l| cv_over(l, &all))
                .map(|x| x * 1e3),
            windows_used: n,
            chi2: c2b,
            chi2_dof: dofb,
            chi2_p: pb,
        };
        let final_summary = ModelSummary {
            params: k_terms + state.used.iter().filter(|u| !**u).count(),
            rms_mg: state.fit.rms() * 1e3,
            cv_rms_mg: if base.loo.is_some() {
                cv_over(&state.loo, &state.used).map(|x| x * 1e3)
            } else {
                None
            },
            windows_used: state.n_used(),
            chi2: c2f,
            chi2_dof: doff,
            chi2_p: pf,
        };
        (base_summary, final_summary)
    }

    /// The window table.
    fn window_infos(&self, base: &Base, search: &Search) -> Vec<WindowInfo> {
        let state = &search.state;
        self.ws
            .stats
            .iter()
            .enumerate()
            .map(|(i, w)| WindowInfo {
                index: i + 1,
                t_start: w.t_first,
                t_end: w.t_last,
                t_centre: w.t_centre,
                samples: w.count,
                temp: w.temp,
                mean: w.mean,
                residual_base_mg: am::residual(&base.fit.p, &self.wins[i]) * 1e3,
                residual_final_mg: am::residual(&state.fit.p, &self.wins[i]) * 1e3,
                cv_base_mg: base.loo.as_ref().and_then(|l| l[i]).map(|x| x * 1e3),
                cv_final_mg: state.loo.get(i).copied().flatten().map(|x| x * 1e3),
                floor_mg: base.floor[i] * 1e3,
                rejected: !state.used[i],
                signature_mg: search.first_signature.as_ref().map(|s| s[i]),
            })
            .collect()
    }

    /// What the final residual correlates with ([`crate::search::correlates`]), over the
    /// windows in use, when the final model fails the verdict's residual test (held-out RMS
    /// over the floor and χ²); `None` when it passes or a number is unknown.
    fn correlates(
        &self,
        base: &Base,
        state: &State,
        final_model: &ModelSummary,
    ) -> Option<Vec<crate::report::correlate::ResidualCorrelate>> {
        let floor_mg = Some(base.noise_floor * 1e3).filter(|x| x.is_finite() && *x > 0.0)?;
        let (cv, p) = (final_model.cv_rms_mg?, final_model.chi2_p?);
        if !crate::report::verdict::residual_unexplained(cv, floor_mg, p) {
            return None;
        }
        let cal = self.nrm.to_calibration(&state.fit.p);
        let mask = am::with_open(mask_for(self.model, &state.parts), &self.wins);
        let points: Vec<WindowPoint> = self
            .ws
            .stats
            .iter()
            .zip(&self.wins)
            .zip(&state.used)
            .filter(|(_, u)| **u)
            .map(|((w, win), _)| {
                let a = cal.correct_linear(w.mean.map(|x| x as f32)).map(f64::from);
                let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt().max(1e-300);
                let g = a.map(|x| x / n);
                WindowPoint {
                    residual_mg: am::residual(&state.fit.p, win) * 1e3,
                    span: span_of(&mask, g, win),
                    t_s: w.t_centre,
                    temp_c: w.temp,
                    g,
                }
            })
            .collect();
        Some(residual_correlates(&points, self.opts.alpha))
    }

    /// The [`crate::detect::motion`] check on the base fit: are the windows really still?
    fn motion_diagnostic(&self, base: &Base) -> Option<String> {
        let k = self
            .nrm
            .to_calibration(&base.fit.p)
            .matrix
            .map(|row| row.map(f64::from));
        let residuals: Vec<f64> = self
            .wins
            .iter()
            .map(|w| am::residual(&base.fit.p, w))
            .collect();
        let reference = crate::detect::motion::reference_variance(&self.ws.stats);
        let m = crate::detect::motion::check(&k, &self.ws.stats, reference, &residuals)?;
        crate::detect::motion::diagnostic(&m, self.opts.alpha, base.noise_floor * 1e3)
    }

    fn report(&self, samples: usize, base: &Base, search: Search) -> Result<AnalyzeReport> {
        let (base_summary, final_model) = self.summaries(base, &search.state);
        let calibration = match self.wins.first() {
            Some(w) => self.nrm.to_calibration_open(&search.state.fit.p, &w.slots),
            None => self.nrm.to_calibration(&search.state.fit.p),
        };
        calibration
            .validate()
            .map_err(SearchError::InvalidCalibration)?;
        let windows = self.window_infos(base, &search);
        let residual_correlates = self.correlates(base, &search.state, &final_model);
        // Candidates the last step could not test at all (too few windows for them).
        let untested: Vec<(String, usize)> = search
            .steps
            .last()
            .map(|st| {
                st.candidates
                    .iter()
                    .filter_map(|c| c.windows_short.map(|k| (c.name.clone(), k)))
                    .collect()
            })
            .unwrap_or_default();
        let mut verdict = ev::verdict_text(
            &base_summary,
            &final_model,
            &search.effects,
            &ev::Floor {
                mg: base.noise_floor * 1e3,
                batch_mg: base.noise_floor_batch.map(|x| x * 1e3),
            },
            self.opts.alpha,
            base.loo.is_some(),
            &ev::NotFound {
                untested: &untested,
                limits: &whole_effect_limits(&search.steps),
            },
        );
        let mut diagnostics = search.diagnostics;
        diagnostics.extend(self.motion_diagnostic(base));
        for d in &diagnostics {
            verdict.push_str(&format!(" Diagnostic: {d}."));
        }
        Ok(AnalyzeReport {
            mode: "multi-position",
            units: self.ws.units,
            samples,
            static_windows: self.n(),
            // Unknown (NaN) when the windows' sample counts are not known.
            noise_floor_mg: Some(base.noise_floor * 1e3).filter(|x| x.is_finite()),
            noise_floor_batch_mg: base.noise_floor_batch.map(|x| x * 1e3),
            base: base_summary,
            effects: search.effects,
            final_model,
            steps: search.steps,
            verdict,
            time_origin_s: self.ws.clock.map_or(0.0, |(first, _)| first),
            time_temp_correlation: self.time_temp_r,
            diagnostics,
            calibration,
            host_terms: search.host_terms,
            windows,
            six_position: None,
            residual_correlates,
            window_input: None,
            autocalibration: None,
            autocalibration_converged: None,
            polling: self.ws.polling.clone(),
        })
    }
}

//! Host terms end to end: a simulated recording with a time or temperature effect
//! the core calibration has no field for is analysed; the accepted host terms travel in the
//! calibration file (schema `wiical-calibration/3`, written and read back), and the host
//! correction (`wiical_analysis::correct`: the core's `f32` `Calibration::correct` with the
//! host terms folded in) reproduces the analysis's own `f64` final model window by window,
//! while the core calibration alone does measurably worse. Per sample, `correct_recording`
//! gives hold means as good as the final model's.

use wiical_analysis::correct::{correct_at, correct_recording};
use wiical_analysis::detect::windows::detect_windows;
use wiical_analysis::output::calfile::{parse, to_json_file, CalibrationFile, SCHEMA_V3};
use wiical_analysis::output::host_term_checks::{HostTerm, Regressor};
use wiical_analysis::search::thermal::SampleTemps;
use wiical_analysis::{analyze, AnalyzeOptions, AnalyzeReport};
use wiical_sim::{Device, EffectSpec, SimConfig, SimEffect, SimOutput};

/// A 16-bit MEMS recording at its usual rate with `effect` at `mg`.
fn sim(effect: SimEffect, mg: f64, seed: u64) -> SimOutput {
    let device = Device::Mems16;
    wiical_sim::simulate(&SimConfig {
        effects: vec![EffectSpec::new(effect, Some(mg))],
        seed,
        device,
        rate_hz: device.typical_rate_hz(),
        ..Default::default()
    })
    .unwrap()
}

/// The first seed of 1..=6 whose analysis accepts a host term of `family`.
fn accepted(effect: SimEffect, mg: f64) -> (SimOutput, AnalyzeReport) {
    for seed in 1..=6 {
        let s = sim(effect, mg, seed);
        let r = analyze(&s.recording, &AnalyzeOptions::default()).unwrap();
        if r.host_terms.iter().any(|t| t.family == effect.name()) {
            return (s, r);
        }
    }
    panic!("{} never accepted as a host term", effect.name());
}

fn norm(a: [f32; 3]) -> f64 {
    a.iter().map(|x| f64::from(*x).powi(2)).sum::<f64>().sqrt()
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// Each host term's regressor per window, as the analysis took it: the mean window time and
/// temperature, the window mean of the lagged temperature, the window's rate.
fn window_regressors(terms: &[HostTerm], r: &AnalyzeReport, st: &SampleTemps) -> Vec<Vec<f64>> {
    terms
        .iter()
        .map(|t| match t.shape().unwrap().0 {
            Regressor::Time => r.windows.iter().map(|w| w.t_centre).collect(),
            Regressor::Temperature => r.windows.iter().map(|w| w.temp.unwrap()).collect(),
            Regressor::LaggedTemperature(tau) => {
                let lagged = st.lagged.iter().find(|l| l.0.to_bits() == tau.to_bits());
                lagged.unwrap().1.clone()
            }
            Regressor::TemperatureRate => st.rates.clone().unwrap(),
        })
        .collect()
}

/// One family: returns (max |Δ‖a‖| host vs f64, RMS final, RMS core alone, RMS of the
/// per-sample corrected hold means), g.
fn check(effect: SimEffect, mg: f64) -> [f64; 4] {
    let (s, r) = accepted(effect, mg);
    // The calibration file, written and read back.
    let file = CalibrationFile {
        calibration: r.calibration,
        quality: None,
        host_terms: r.host_terms.clone(),
    };
    let text = to_json_file(&file).unwrap();
    assert!(text.contains(SCHEMA_V3), "{text}");
    let file = parse(&text).unwrap();
    // serde_json reads a number back to within an ulp or two, not always bit for bit.
    assert_eq!(file.host_terms.len(), r.host_terms.len());
    for (a, b) in file.host_terms.iter().zip(&r.host_terms) {
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-14 * x.abs().max(y.abs());
        let rf = |t: &HostTerm| {
            let r = t.reference;
            [r.time_s, r.temperature_c, r.rate_c_per_s].map(|x| x.unwrap_or(0.0))
        };
        assert!(
            a.name == b.name && a.axis == b.axis && close(a.value, b.value),
            "{a:?} {b:?}"
        );
        assert!(
            rf(a).iter().zip(rf(b)).all(|(x, y)| close(*x, y)),
            "{a:?} {b:?}"
        );
    }
    let opts = AnalyzeOptions::default();
    let ws = detect_windows(&s.recording, &opts.fit.detect).unwrap();
    assert_eq!(ws.stats.len(), r.windows.len());
    // The lagged temperature at each term's time constant as the file gives it.
    let taus: Vec<f64> = (file.host_terms.iter())
        .filter_map(|t| match t.shape().unwrap().0 {
            Regressor::LaggedTemperature(tau) => Some(tau),
            _ => None,
        })
        .collect();
    let st = SampleTemps::of(&s.recording, &ws, &opts.fit.detect, &taus).unwrap();
    let xs = window_regressors(&file.host_terms, &r, &st);
    let core_only = CalibrationFile {
        host_terms: Vec::new(),
        ..file.clone()
    };
    let (mut worst, mut fin, mut core) = (0.0f64, Vec::new(), Vec::new());
    for (i, w) in r.windows.iter().enumerate() {
        let m = w.mean.map(|v| v as f32);
        let x: Vec<f64> = xs.iter().map(|c| c[i]).collect();
        let host = norm(correct_at(&file, m, w.t_centre, w.temp, &x)) - 1.0;
        let want = w.residual_final_mg * 1e-3;
        worst = worst.max((host - want).abs());
        if !w.rejected {
            fin.push(want);
            core.push(norm(correct_at(&core_only, m, w.t_centre, w.temp, &[])) - 1.0);
        }
    }
    // Per sample: the corrected samples' hold means.
    let c = correct_recording(&file, &s.recording, 100.0).unwrap();
    let held: Vec<f64> = (ws.stats.iter())
        .zip(&r.windows)
        .filter(|(_, w)| !w.rejected)
        .map(|(s, _)| {
            let (a, b) = (s.start, s.end);
            let mut mean = [0.0f64; 3];
            for v in &c.accel[a..b] {
                for j in 0..3 {
                    mean[j] += f64::from(v[j]) / (b - a) as f64;
                }
            }
            mean.iter().map(|x| x * x).sum::<f64>().sqrt() - 1.0
        })
        .collect();
    let out = [worst, rms(&fin), rms(&core), rms(&held)];
    eprintln!(
        "{}: host terms {:?}; max |Δ‖a‖| {:.2e} g; RMS final {:.3} mg, core alone {:.3} mg, \
         per-sample hold means {:.3} mg; applied {:?}",
        effect.name(),
        r.host_terms.iter().map(|t| &t.name).collect::<Vec<_>>(),
        out[0],
        out[1] * 1e3,
        out[2] * 1e3,
        out[3] * 1e3,
        c.applied
    );
    out
}

/// Window by window the host correction is the f64 final model to f32 precision; without
/// the host terms the RMS is at least twice the final model's; the per-sample correction's
/// hold means are within 20 % (+0.05 mg) of the final model's RMS.
fn assert_family(effect: SimEffect, mg: f64) {
    let [worst, fin, core, held] = check(effect, mg);
    let name = effect.name();
    assert!(worst < 2e-5, "{name}: |Δ‖a‖| {worst:e} g");
    assert!(
        core >= 2.0 * fin,
        "{name}: core alone {core} vs final {fin}"
    );
    assert!(
        (held - fin).abs() <= 0.2 * fin + 5e-5,
        "{name}: per-sample hold means {held} vs final {fin}"
    );
}

#[test]
fn a_scale_drift_travels_and_is_applied() {
    assert_family(SimEffect::ScaleDrift, 20.0);
}

#[test]
fn a_temperature_squared_bias_travels_and_is_applied() {
    assert_family(SimEffect::TemperatureSquared, 20.0);
}

#[test]
fn a_temperature_scale_cubed_travels_and_is_applied() {
    assert_family(SimEffect::TemperatureScaleCubed, 20.0);
}

#[test]
fn a_thermal_lag_travels_and_is_applied() {
    assert_family(SimEffect::ThermalLag, 20.0);
}

#[test]
fn a_temperature_rate_travels_and_is_applied() {
    assert_family(SimEffect::TemperatureRate, 20.0);
}

/// A recording without a temperature column cannot take a temperature term: refused,
/// naming the term (the core's temperature terms first, then the host terms).
#[test]
fn a_temperature_term_without_temperature_is_refused() {
    let (mut s, r) = accepted(SimEffect::TemperatureSquared, 20.0);
    let mut file = CalibrationFile {
        calibration: r.calibration,
        quality: None,
        host_terms: r.host_terms.clone(),
    };
    s.recording.temp = None;
    let e = r.calibration.effects;
    let core = if e.bias_temp != [0.0; 3] {
        Some("bias_temp (temperature)")
    } else if e.scale_temp != [0.0; 3] {
        Some("scale_temp (temperature)")
    } else {
        None
    };
    let host = r
        .host_terms
        .iter()
        .find(|t| t.shape().unwrap().0 != Regressor::Time)
        .unwrap()
        .name
        .clone();
    let msg = |f: &CalibrationFile| {
        correct_recording(f, &s.recording, 100.0)
            .unwrap_err()
            .to_string()
    };
    let m = msg(&file);
    assert!(m.contains("needs the temperature"), "{m}");
    assert!(m.contains(core.unwrap_or(&host)), "{m}");
    // Without the core's temperature terms, the host term is named.
    file.calibration.effects.bias_temp = [0.0; 3];
    file.calibration.effects.scale_temp = [0.0; 3];
    let m = msg(&file);
    assert!(
        m.contains(&format!("term {host} needs the temperature")),
        "{m}"
    );
}

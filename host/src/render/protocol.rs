//! Text of the recognised protocols: the `protocol:` line and what the method could not
//! identify (accelerometer), and the gyro's protocol report.

use std::fmt::Write as _;
use wiical_analysis::calibrate::{CalibrateReport, GyroOutcome, Outcome};
use wiical_analysis::protocol::gyro::GyroProtocolReport;
use wiical_analysis::protocol::ProtocolReport;

/// The accelerometer's protocol lines: what was recognised, the method, its faces' errors
/// and what it could not identify.
pub fn accel_lines(p: &ProtocolReport) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "protocol: {} → method: {}", p.summary, p.method);
    if let Some(f) = &p.face_fit {
        let errs: Vec<String> = f
            .face_norm_error_mg
            .iter()
            .map(|(l, e)| format!("{l} {e:+.3}"))
            .collect();
        let _ = writeln!(
            o,
            "  faces' ‖a‖ − 1 g after calibration (mg): {}",
            errs.join(", ")
        );
    }
    if let Some(off) = &p.offsets {
        match (off.offsets_mg, off.std_error_mg) {
            (Some(mg), Some(se)) => {
                let _ = writeln!(
                    o,
                    "  offsets ({} up, {:.1}° off): x {:+.2} ± {:.2}, y {:+.2} ± {:.2}, z {:+.2} ± {:.2} mg",
                    off.vertical.unwrap_or("?"),
                    off.off_deg,
                    mg[0],
                    se[0],
                    mg[1],
                    se[1],
                    mg[2],
                    se[2]
                );
            }
            _ => {
                let _ = writeln!(o, "  offsets (raw): {:?}", off.offsets);
            }
        }
    }
    for n in &p.not_identified {
        let _ = writeln!(o, "  not identified: {n}");
    }
    o
}

/// The gyro's protocol report as text.
pub fn gyro_text(rep: &GyroProtocolReport, file: &str) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "Gyroscope of {file}");
    let _ = writeln!(o, "protocol: {} → method: {}", rep.protocol, rep.method);
    let _ = writeln!(
        o,
        "bias b (raw): {:.6} {:.6} {:.6}  (± {:.2e} {:.2e} {:.2e}, {} rest(s), {} samples)",
        rep.bias[0],
        rep.bias[1],
        rep.bias[2],
        rep.bias_std_error[0],
        rep.bias_std_error[1],
        rep.bias_std_error[2],
        rep.rests,
        rep.rest_samples
    );
    match &rep.matrix {
        Some(k) => {
            let _ = writeln!(o, "K (rad/s per raw unit):");
            for r in k {
                let _ = writeln!(o, "  {:>14.8} {:>14.8} {:>14.8}", r[0], r[1], r[2]);
            }
        }
        None => {
            let _ = writeln!(o, "K: not measured (no nominal scale known)");
        }
    }
    if let Some(f) = &rep.turn_fit {
        let a: Vec<String> = f.calibrated_deg.iter().map(|d| format!("{d:.2}")).collect();
        let _ = writeln!(o, "full turns after calibration (°): {}", a.join(", "));
    }
    if let Some(g) = &rep.g_sensitivity {
        o.push_str(&g_sensitivity_lines(g));
    }
    if let Some(f) = &rep.rate_fit {
        let _ = writeln!(o, "  window  rate (°/s)  calibrated (°/s)  axis");
        for w in &f.windows {
            let _ = writeln!(
                o,
                "  {:>6} {:>11.2} {:>17.3}  {}",
                w.window,
                w.rate_dps,
                w.calibrated_dps,
                w.axis.as_deref().unwrap_or("-")
            );
        }
    }
    for n in &rep.notes {
        let _ = writeln!(o, "  {n}");
    }
    let _ = writeln!(o, "verdict: {}", rep.verdict);
    o
}

/// The g-sensitivity `G` (°/s per g) with its standard errors, one row per gyro axis.
fn g_sensitivity_lines(g: &wiical_analysis::protocol::g_sensitivity::GSensitivityFit) -> String {
    let mut o = String::new();
    let (Some(m), Some(se)) = (g.dps_per_g, g.dps_per_g_std_error) else {
        return o;
    };
    let _ = writeln!(
        o,
        "g-sensitivity G (°/s per g; row = gyro axis, column = gravity's x y z), ± standard error, from {} rests:",
        g.rests
    );
    for (row, err) in m.iter().zip(&se) {
        let _ = writeln!(
            o,
            "  {:>9.4} ±{:.4} {:>9.4} ±{:.4} {:>9.4} ±{:.4}",
            row[0], err[0], row[1], err[1], row[2], err[2]
        );
    }
    o
}

/// `wiical calibrate`'s text: one block per sensor with its verdict.
pub fn calibrate_text(rep: &CalibrateReport, file: &str) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "Calibration of {file}: {}", rep.sensors.join("; "));
    if let Some(acc) = &rep.accelerometer {
        let _ = writeln!(o, "\n== accelerometer");
        match acc {
            Outcome::Ok(j) => {
                let r = &j.report;
                match &r.protocol {
                    Some(p) => o.push_str(&accel_lines(p)),
                    None => {
                        let _ = writeln!(
                            o,
                            "protocol: free poses ({} still windows) → method: multi-position fit",
                            r.static_windows
                        );
                    }
                }
                let _ = writeln!(
                    o,
                    "bias b (raw): {:.6} {:.6} {:.6}",
                    r.bias[0], r.bias[1], r.bias[2]
                );
                let _ = writeln!(o, "K = D⁻¹ (g per raw unit):");
                for row in &r.matrix {
                    let _ = writeln!(o, "  {:>14.8} {:>14.8} {:>14.8}", row[0], row[1], row[2]);
                }
                let _ = writeln!(o, "{}", j.quality.line());
            }
            Outcome::Error(e) => {
                let _ = writeln!(o, "not calibrated: {e}");
            }
        }
    }
    if let Some(g) = &rep.gyroscope {
        let _ = writeln!(o, "\n== gyroscope");
        match g {
            Outcome::Ok(GyroOutcome::Protocol(r)) => o.push_str(&gyro_text(r, file)),
            Outcome::Ok(GyroOutcome::Motions(r)) => {
                let _ = writeln!(
                    o,
                    "protocol: motions between free poses ({} windows, {} motions) → method: {} (held-out error {:.3}°)",
                    r.static_windows, r.motions, r.model, r.cv_rms_deg
                );
                let _ = writeln!(o, "verdict: {}", r.verdict);
            }
            Outcome::Error(e) => {
                let _ = writeln!(o, "not calibrated: {e}");
            }
        }
    }
    if let Some(m) = &rep.magnetometer {
        let _ = writeln!(o, "\n== magnetometer");
        match m {
            Outcome::Ok(m) => {
                let f = &m.fit;
                let _ = writeln!(
                    o,
                    "ellipsoid: centre {:.4} {:.4} {:.4}, radius {:.4}, fit error {:.3} %",
                    f.center[0], f.center[1], f.center[2], f.radius, f.fit_error_pct
                );
                let _ = writeln!(o, "verdict: {}", m.analysis.verdict);
            }
            Outcome::Error(e) => {
                let _ = writeln!(o, "not calibrated: {e}");
            }
        }
    }
    o
}

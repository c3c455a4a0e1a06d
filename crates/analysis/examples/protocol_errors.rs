//! Parameter error of the protocol methods against the simulated truth (issue 47's acceptance
//! row "Simulated protocols: parameter error against the truth for each, 50 seeds each").
//!
//! Each protocol of [`SimProtocol::ALL`] is simulated for seeds `1..=SEEDS` and given to the
//! methods blind, as `fit`/`gyrofit` would run them (no truth, no labels): the accelerometer
//! through `detect_windows` and `protocol::accel::fit_by_protocol`, the gyro through
//! `protocol::gyro::run` (table rates given for the rate table and the turntable, nothing else).
//! The calibrations are then compared with the truth and summarised as a markdown table
//! (median and 95th percentile of |error|, refusals, coverage of the stated standard errors),
//! the table of `docs/protocols-sim.md`.
//!
//! `cargo run --release -p wiical-analysis --example protocol_errors [-- SEEDS]` (the simulator,
//! `wiical-sim`, is a dev-dependency)

use nalgebra::{Matrix3, Vector3};
use wiical_analysis::detect::windows::{detect_windows, DetectOptions};
use wiical_analysis::protocol::accel::fit_by_protocol;
use wiical_analysis::protocol::gyro::{run, GyroProtocolOptions, GyroProtocolReport};
use wiical_analysis::FitOptions;
use wiical_sim::protocols::{
    simulate_protocol, AxesTruth, ProtocolSim, ProtocolSimOptions, SimProtocol,
};

/// Seeds per protocol unless given on the command line.
const SEEDS: u64 = 50;

/// One sensor's comparison on one seed: `(parameter, |error|)` pairs, and whether every
/// parameter with a stated standard error lies within 3 of them (`None`: none stated).
struct Outcome {
    errors: Vec<(&'static str, f64)>,
    within_3se: Option<bool>,
    /// The method the library reported (`six-position`, `rate-shells`, …).
    method: String,
}

/// One table row group: a protocol's sensor over all seeds.
#[derive(Default)]
struct Group {
    params: Vec<(&'static str, Vec<f64>)>,
    refused: usize,
    first_refusal: Option<String>,
    within: (usize, usize),
    methods: Vec<String>,
}

impl Group {
    /// Adds one seed's result.
    fn add(&mut self, r: Result<Outcome, String>) {
        match r {
            Ok(o) => {
                for (name, e) in o.errors {
                    match self.params.iter_mut().find(|(n, _)| *n == name) {
                        Some((_, v)) => v.push(e),
                        None => self.params.push((name, vec![e])),
                    }
                }
                if let Some(w) = o.within_3se {
                    self.within.0 += usize::from(w);
                    self.within.1 += 1;
                }
                if !self.methods.contains(&o.method) {
                    self.methods.push(o.method);
                }
            }
            Err(e) => {
                self.refused += 1;
                self.first_refusal.get_or_insert(e);
            }
        }
    }
}

fn mat(m: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|r, c| m[r][c])
}

fn mat32(m: &[[f32; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|r, c| f64::from(m[r][c]))
}

/// The matrix errors of a fitted `K` against the truth: `P = K·D` is the identity for a
/// perfect fit, so its diagonal less one is each axis's scale error and its off-diagonal the
/// misalignment left. `triangular` compares in the free-pose gauge (`K` upper triangular,
/// `D = U` of the truth), where the fixture's frame is not seen.
fn matrix_errors(k: &Matrix3<f64>, truth: &AxesTruth, triangular: bool) -> (f64, f64) {
    let d = if triangular {
        mat(&truth.forward_matrix_triangular)
    } else {
        mat(&truth.forward_matrix)
    };
    let p = k * d;
    let scale = (0..3).map(|i| (p[(i, i)] - 1.0).abs()).fold(0.0, f64::max);
    let mis = (0..3)
        .flat_map(|r| (0..3).filter(move |c| *c != r).map(move |c| (r, c)))
        .map(|(r, c)| p[(r, c)].abs())
        .fold(0.0, f64::max);
    (100.0 * scale, 1000.0 * mis)
}

/// The accelerometer's method on the simulation, compared with the truth: bias as
/// `|K_true·Δb|` in mg; for one pose the horizontal offsets and the vertical one apart (the
/// latter is not measured from raw counts, the scale is nominal).
fn accel(sim: &ProtocolSim) -> Option<Result<Outcome, String>> {
    let rec = sim.accel_recording()?;
    let truth = sim.truth.accel.as_ref()?;
    let ws = match detect_windows(&rec, &DetectOptions::default()) {
        Ok(ws) => ws,
        Err(e) => return Some(Err(format!("detect: {e}"))),
    };
    let res = match fit_by_protocol(&ws, &FitOptions::default()) {
        Ok(r) => r,
        Err(e) => return Some(Err(e.full_message())),
    };
    let cal = &res.report.calibration;
    let method = res
        .report
        .protocol
        .as_ref()
        .map_or("free-pose fit", |p| p.method);
    let db = Vector3::from_fn(|i, _| f64::from(cal.bias[i]) - truth.bias[i]);
    let e_mg = mat(&truth.matrix) * db * 1000.0;
    let mut errors = Vec::new();
    if method == "one-pose-offsets" {
        errors.push(("offset x, y (mg)", e_mg.xy().norm()));
        errors.push(("offset z (mg), not measured", e_mg.z.abs()));
    } else {
        let (scale, mis) = matrix_errors(&mat32(&cal.matrix), truth, method == "free-pose fit");
        errors.push(("bias (mg)", e_mg.norm()));
        errors.push(("scale (%)", scale));
        errors.push(("misalignment (mrad)", mis));
    }
    Some(Ok(Outcome {
        errors,
        within_3se: None,
        method: method.to_string(),
    }))
}

/// The gyro's options for a protocol: the known rates of the rate table and the turntable.
fn gyro_options(p: SimProtocol, o: &ProtocolSimOptions) -> GyroProtocolOptions {
    let table_rates_dps = match p {
        SimProtocol::RateTable => Some(vec![o.table_rate_dps]),
        SimProtocol::Turntable => Some(o.turntable_rates_dps.clone()),
        _ => None,
    };
    GyroProtocolOptions {
        table_rates_dps,
        nominal_rad_per_raw: None,
        ..Default::default()
    }
}

/// The gyro's method compared with the truth: bias in °/s (`|K_true·Δb|`), and when a matrix
/// was measured its scale (%) and misalignment (mrad); `rate-shells` in the triangular gauge.
fn gyro(sim: &ProtocolSim, opts: &GyroProtocolOptions) -> Result<Outcome, String> {
    let acc = sim.accel_recording();
    let rep: GyroProtocolReport =
        run(acc.as_ref(), &sim.gyro_recording(), opts).map_err(|e| e.to_string())?;
    let truth = &sim.truth.gyro;
    let db = Vector3::from_fn(|i, _| rep.bias[i] - truth.bias[i]);
    let e_dps = (mat(&truth.matrix) * db).map(f64::to_degrees);
    let within = (0..3).all(|i| db[i].abs() <= 3.0 * rep.bias_std_error[i]);
    let mut errors = vec![("bias (°/s)", e_dps.norm())];
    let measured = matches!(rep.method, "ferraris" | "rate-table" | "rate-shells");
    match (&rep.matrix, measured) {
        (Some(k), true) => {
            let (scale, mis) = matrix_errors(&mat(k), truth, rep.method == "rate-shells");
            errors.push(("scale (%)", scale));
            errors.push(("misalignment (mrad)", mis));
        }
        _ if opts.table_rates_dps.is_some() || sim.truth.protocol == "ferraris" => {
            let why = rep.notes.first().cloned().unwrap_or_default();
            return Err(format!("{}: {} ({why})", rep.method, rep.protocol));
        }
        _ => {}
    }
    Ok(Outcome {
        errors,
        within_3se: Some(within),
        method: rep.method.to_string(),
    })
}

/// The median, 95th percentile (nearest rank) and largest of `v`.
fn median_p95(v: &[f64]) -> (f64, f64, f64) {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    let median = if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    };
    let rank = ((0.95 * n as f64).ceil() as usize).clamp(1, n);
    (median, s[rank - 1], s[n - 1])
}

/// Prints a group's rows of the markdown table.
fn print_group(protocol: &str, sensor: &str, g: &Group, seeds: u64) {
    let refused = match &g.first_refusal {
        Some(m) => format!("{}/{seeds}: “{}”", g.refused, m.replace('|', "\\|")),
        None => format!("0/{seeds}"),
    };
    let within = if g.within.1 == 0 {
        "— (no standard error stated)".to_string()
    } else {
        format!("{}/{}", g.within.0, g.within.1)
    };
    let method = g.methods.join(", ");
    if g.params.is_empty() {
        println!("| {protocol} | {sensor} | — | — | — | — | — | {refused} | — |");
    }
    for (k, (name, v)) in g.params.iter().enumerate() {
        let (m, p, x) = median_p95(v);
        let (r, w, meth) = if k == 0 {
            (refused.as_str(), within.as_str(), method.as_str())
        } else {
            ("", "", "")
        };
        println!(
            "| {protocol} | {sensor} | {meth} | {name} | {m:.4} | {p:.4} | {x:.4} | {r} | {w} |"
        );
    }
}

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(SEEDS);
    println!(
        "| protocol | sensor | method | parameter | median \\|error\\| | 95th pct \\|error\\| \
         | max \\|error\\| | refused | within 3 SE |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for p in SimProtocol::ALL {
        let (mut ga, mut gg) = (Group::default(), Group::default());
        for seed in 1..=seeds {
            let o = ProtocolSimOptions {
                protocol: p,
                seed,
                ..Default::default()
            };
            let sim = simulate_protocol(&o);
            if let Some(r) = accel(&sim) {
                ga.add(r);
            }
            gg.add(gyro(&sim, &gyro_options(p, &o)));
        }
        if p != SimProtocol::Turntable {
            print_group(p.name(), "accel", &ga, seeds);
        }
        print_group(p.name(), "gyro", &gg, seeds);
    }
}

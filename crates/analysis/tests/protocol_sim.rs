//! The protocol methods, blind, on simulated protocols against the truth: a few seeds each,
//! with bounds derived from what the simulation puts in (noise, a fixture's or a hand's tilt,
//! a rotation or table axis off the fixture's), so that a broken method fails while the
//! protocol's own limits pass. The 50-seed table is `docs/protocols-sim.md`
//! (`examples/protocol_errors.rs`).
//!
//! The bounds, from the simulator's defaults (`ProtocolSimOptions::default`, `plans.rs`):
//! accelerometer noise 1.2 mg per sample over faces of ≥ 1000 samples (a `±` pair's midpoint:
//! SE 0.027 mg); fixture faces tilted ≤ 0.5° (8.7 mrad), hand-placed ≤ 3°; the sensor's axes
//! 0.5–1° (≤ 17.5 mrad) off the fixture's; Ferraris rotation axes ≤ 2° (35 mrad) off, rate
//! table axes ≤ 0.5°. A tilt moves a midpoint only to second order (tilt × misalignment), a
//! scale to second order (`K·D = U⁻¹` with `U` the faces' or axes' true directions: its
//! diagonal moves by up to tilt²/2 + 2·tilt² = 2.5·tilt²), a misalignment to first order (the
//! tilt itself).

use nalgebra::{Matrix3, Vector3};
use wiical_analysis::detect::windows::{detect_windows, DetectOptions};
use wiical_analysis::protocol::accel::fit_by_protocol;
use wiical_analysis::protocol::gyro::{run, GyroProtocolOptions, GyroProtocolReport};
use wiical_analysis::{Calibration, FitOptions};
use wiical_sim::protocols::{
    simulate_protocol, AxesTruth, ProtocolSim, ProtocolSimOptions, SimProtocol,
};

fn sim(protocol: SimProtocol, seed: u64) -> ProtocolSim {
    simulate_protocol(&ProtocolSimOptions {
        protocol,
        seed,
        ..Default::default()
    })
}

fn mat(m: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|r, c| m[r][c])
}

/// Errors of a calibration `(K, b)` against a sensor's truth: `K_true·Δb` (sensor units),
/// each axis's scale error (diagonal of `K·D − I`) and the largest off-diagonal of `K·D`
/// (misalignment, rad). `triangular`: the free-pose gauge (`D = U`, upper triangular).
struct Errors {
    bias: Vector3<f64>,
    scale: [f64; 3],
    misalignment: f64,
}

fn errors(k: &Matrix3<f64>, b: [f64; 3], t: &AxesTruth, triangular: bool) -> Errors {
    let d = mat(if triangular {
        &t.forward_matrix_triangular
    } else {
        &t.forward_matrix
    });
    let p = k * d;
    let db = Vector3::from_fn(|i, _| b[i] - t.bias[i]);
    let off = (0..9)
        .filter(|i| i % 4 != 0)
        .map(|i| p[(i / 3, i % 3)].abs());
    Errors {
        bias: mat(&t.matrix) * db,
        scale: std::array::from_fn(|i| p[(i, i)] - 1.0),
        misalignment: off.fold(0.0, f64::max),
    }
}

/// The accelerometer's calibration by the method its protocol calls for, with the method.
fn accel_fit(s: &ProtocolSim) -> (Calibration, &'static str) {
    let rec = s.accel_recording().expect("an accelerometer");
    let ws = detect_windows(&rec, &DetectOptions::default()).expect("windows");
    let r = fit_by_protocol(&ws, &FitOptions::default()).expect("a calibration");
    let method = r.report.protocol.as_ref().map_or("free", |p| p.method);
    (r.report.calibration, method)
}

fn accel_errors(s: &ProtocolSim) -> (Errors, &'static str) {
    let (cal, method) = accel_fit(s);
    let k = Matrix3::from_fn(|r, c| f64::from(cal.matrix[r][c]));
    let b = cal.bias.map(f64::from);
    let t = s.truth.accel.as_ref().expect("accelerometer truth");
    (errors(&k, b, t, false), method)
}

fn gyro_run(s: &ProtocolSim, opts: &GyroProtocolOptions) -> GyroProtocolReport {
    run(s.accel_recording().as_ref(), &s.gyro_recording(), opts).expect("a gyro report")
}

/// The gyro's bias lies within 5 of its stated standard errors of the truth, per axis.
fn assert_gyro_bias(s: &ProtocolSim, rep: &GyroProtocolReport) {
    let truth = &s.truth.gyro.bias;
    for (i, ((b, t), se)) in rep
        .bias
        .iter()
        .zip(truth)
        .zip(&rep.bias_std_error)
        .enumerate()
    {
        let d = b - t;
        assert!(
            d.abs() <= 5.0 * se,
            "{} seed {}: gyro bias {i} off by {d} counts (SE {se})",
            s.truth.protocol,
            s.truth.seed,
        );
    }
}

#[test]
fn six_faces_give_the_accelerometer_within_noise_and_tilt() {
    for seed in 1..=4 {
        let s = sim(SimProtocol::SixFaces, seed);
        let (e, method) = accel_errors(&s);
        assert_eq!(method, "six-position");
        // 5 SE of a midpoint (0.13 mg) + tilt × misalignment (0.15 mg) + tilt²/2 (0.04 mg).
        assert!(
            e.bias.norm() < 0.32e-3,
            "seed {seed}: bias {} mg",
            e.bias.norm() * 1e3
        );
        // 2.5·tilt² (1.9e-4) + 5 SE (1.4e-4).
        assert!(
            e.scale.iter().all(|x| x.abs() < 3.3e-4),
            "seed {seed}: {:?}",
            e.scale
        );
        // The faces' tilt (8.7 mrad) + noise.
        assert!(e.misalignment < 9.0e-3, "seed {seed}: {}", e.misalignment);
        let rep = gyro_run(&s, &GyroProtocolOptions::default());
        assert_eq!(rep.method, "rest-bias");
        assert_gyro_bias(&s, &rep);
    }
}

#[test]
fn a_missing_face_costs_its_axis_first_order_tilt_only() {
    for seed in 1..=4 {
        let s = sim(SimProtocol::FaceMissing, seed);
        let (e, method) = accel_errors(&s);
        assert_eq!(method, "faces");
        // x and y keep their own pairs (as for six faces); z's bias comes from the other
        // faces' z readings at 0 g: first order in their tilt (≤ 8.7 mg), and so z's scale.
        assert!(e.bias.xy().norm() < 0.32e-3, "seed {seed}: {}", e.bias);
        assert!(e.bias.z.abs() < 8.8e-3, "seed {seed}: {}", e.bias);
        assert!(
            e.scale[..2].iter().all(|x| x.abs() < 3.3e-4),
            "{:?}",
            e.scale
        );
        assert!(e.scale[2].abs() < 8.8e-3, "seed {seed}: {:?}", e.scale);
        assert!(e.misalignment < 9.0e-3, "seed {seed}: {}", e.misalignment);
    }
}

#[test]
fn one_pose_gives_the_horizontal_offsets_within_tilt_and_misalignment() {
    // Seeds whose horizontal readings include a negative one (see the ignored test below).
    for seed in [2, 3, 7, 8] {
        let s = sim(SimProtocol::OnePose, seed);
        let (e, method) = accel_errors(&s);
        assert_eq!(method, "one-pose-offsets");
        // The pose's tilt (≤ 1°) and the sensor's misalignment (≤ 1°) read as an offset.
        assert!(e.bias.xy().norm() < 35e-3, "seed {seed}: {}", e.bias);
        let rep = gyro_run(&s, &GyroProtocolOptions::default());
        assert_gyro_bias(&s, &rep);
    }
}

/// One pose of signed 16-bit counts whose three means are all positive is taken for unsigned
/// counts (`faces::zero_reading` puts 0 g at mid-scale, 8192 or 16384), so no axis is near
/// vertical and the offsets are refused. 16 of 50 seeds do this; seed 1 is one of them.
#[test]
fn one_pose_with_positive_horizontal_readings_is_not_refused() {
    let s = sim(SimProtocol::OnePose, 1);
    let (e, _) = accel_errors(&s);
    assert!(e.bias.xy().norm() < 35e-3, "{}", e.bias);
}

/// The Ferraris gyro fit: bias within its standard errors, and x's and y's columns within the
/// rotation axes' tilt (2°, 35 mrad: scale to second order, 2.5·tilt² = 0.3 %; misalignment
/// to first, 35 mrad, and a little more through the z column's lost part, below).
fn assert_ferraris_xy(s: &ProtocolSim, opts: &GyroProtocolOptions) {
    let rep = gyro_run(s, opts);
    assert_eq!(rep.method, "ferraris", "{:?}", rep.notes);
    assert_gyro_bias(s, &rep);
    let k = mat(&rep.matrix.expect("a matrix"));
    let e = errors(&k, rep.bias, &s.truth.gyro, false);
    let seed = s.truth.seed;
    assert!(
        e.scale[..2].iter().all(|x| x.abs() < 3e-3),
        "seed {seed}: {:?}",
        e.scale
    );
    assert!(e.misalignment < 40e-3, "seed {seed}: {}", e.misalignment);
}

#[test]
fn ferraris_gives_the_accelerometer_and_the_gyro_s_x_and_y() {
    for seed in 1..=3 {
        let s = sim(SimProtocol::Ferraris, seed);
        let (e, method) = accel_errors(&s);
        assert_eq!(method, "six-position");
        // Hand-placed faces (3°, 52 mrad): second order for bias (52 × 17.5 mrad + 52²/2
        // mrad of 1 g: 2.3 mg) and scale (2.5·tilt²: 0.7 %), first order for misalignment.
        assert!(e.bias.norm() < 2.3e-3, "seed {seed}: {}", e.bias);
        assert!(e.scale.iter().all(|x| x.abs() < 7e-3), "{:?}", e.scale);
        assert!(e.misalignment < 53e-3, "seed {seed}: {}", e.misalignment);
        assert_ferraris_xy(&s, &GyroProtocolOptions::default());
    }
}

#[test]
fn ferraris_takes_the_rotation_angle_given() {
    // Two full turns (720°) each: the same poses before and after, twice the integral.
    let s = simulate_protocol(&ProtocolSimOptions {
        protocol: SimProtocol::Ferraris,
        seed: 2,
        rotation_deg: 720.0,
        rotation_s: (4.0, 6.0),
        ..Default::default()
    });
    let opts = GyroProtocolOptions {
        rotation_deg: 720.0,
        ..Default::default()
    };
    assert_ferraris_xy(&s, &opts);
}

/// The z turn of a Ferraris session is about the vertical: the accelerometer barely sees it,
/// its still windows run into the turn, and `rotations::turns` integrates only between them,
/// so part of the turn is lost (seed 4: 17 %; seeds 21, 50: all of it, no z turn found).
#[test]
fn ferraris_integrates_the_whole_z_turn() {
    for seed in [1, 4, 21] {
        let s = sim(SimProtocol::Ferraris, seed);
        let rep = gyro_run(&s, &GyroProtocolOptions::default());
        assert_eq!(rep.method, "ferraris", "seed {seed}: {:?}", rep.notes);
        let e = errors(
            &mat(&rep.matrix.expect("a matrix")),
            rep.bias,
            &s.truth.gyro,
            false,
        );
        assert!(e.scale[2].abs() < 3e-3, "seed {seed}: {:?}", e.scale);
    }
}

#[test]
fn known_rates_give_the_gyro() {
    for seed in 1..=3 {
        let s = sim(SimProtocol::RateTable, seed);
        let rep = gyro_run(
            &s,
            &GyroProtocolOptions {
                table_rates_dps: Some(vec![25.0]),
                ..Default::default()
            },
        );
        assert_eq!(rep.method, "rate-table");
        assert_gyro_bias(&s, &rep);
        let e = errors(&mat(&rep.matrix.unwrap()), rep.bias, &s.truth.gyro, false);
        assert!(e.scale.iter().all(|x| x.abs() < 2e-3), "{:?}", e.scale);
        // The table's axis (≤ 0.5°: 8.7 mrad).
        assert!(e.misalignment < 9e-3, "seed {seed}: {}", e.misalignment);

        let s = sim(SimProtocol::Turntable, seed);
        let rep = gyro_run(
            &s,
            &GyroProtocolOptions {
                table_rates_dps: Some(vec![0.0, 200.0, 270.0]),
                ..Default::default()
            },
        );
        assert_eq!(rep.method, "rate-shells");
        assert_gyro_bias(&s, &rep);
        // Shells see `KᵀK` only: the triangular gauge.
        let e = errors(&mat(&rep.matrix.unwrap()), rep.bias, &s.truth.gyro, true);
        assert!(e.scale.iter().all(|x| x.abs() < 2e-3), "{:?}", e.scale);
        assert!(e.misalignment < 5e-3, "seed {seed}: {}", e.misalignment);
    }
}

/// The g-sensitivity a Ferraris session's rests give (imucal's `K_ga`): with a known `G`
/// injected (each element within ±0.1 °/s/g — a consumer MEMS gyro's datasheet value, 1.6
/// counts per g; rests on different faces then still read alike within the rest detector's
/// five noise widths), the fitted `H` (raw per g, the
/// gyro's rest reading against the calibrated accelerometer) within 3 of its standard errors
/// of the truth in that frame, `D_g·G·P⁻¹` (`P = K_a·D_a`: the accelerometer's calibration
/// of this recording on its true forward model; hand-placed faces make `P` a few degrees off
/// the identity, which moves `G` by as much, so the truth is taken where the fit can see it).
/// Without an injected `G`, the same test holds with the truth zero.
#[test]
fn ferraris_recovers_an_injected_g_sensitivity() {
    let mut worst: f64 = 0.0;
    for (seed, dps) in [(1, 0.1), (2, 0.1), (3, 0.05), (4, 0.0)] {
        let s = simulate_protocol(&ProtocolSimOptions {
            protocol: SimProtocol::Ferraris,
            seed,
            g_sensitivity_dps_per_g: dps,
            ..Default::default()
        });
        let rep = gyro_run(&s, &GyroProtocolOptions::default());
        assert_eq!(rep.method, "ferraris", "{:?}", rep.notes);
        assert_gyro_bias(&s, &rep);
        let g = rep.g_sensitivity.as_ref().expect("a g-sensitivity");
        let (cal, _) = accel_fit(&s);
        let ka = Matrix3::from_fn(|r, c| f64::from(cal.matrix[r][c]));
        let p = ka * mat(&s.truth.accel.as_ref().unwrap().forward_matrix);
        let truth = mat(&s.truth.gyro.forward_matrix)
            * mat(&s.truth.gyro_g_sensitivity)
            * p.try_inverse().unwrap();
        for r in 0..3 {
            for c in 0..3 {
                let (got, se) = (g.raw_per_g[r][c], g.raw_per_g_std_error[r][c]);
                let z = (got - truth[(r, c)]) / se;
                worst = worst.max(z.abs());
                assert!(
                    z.abs() <= 3.0,
                    "seed {seed}: H[{r}][{c}] {got} vs {} (SE {se}, {z:.2} SE)",
                    truth[(r, c)]
                );
            }
        }
        // The check can fail: an injected G stands far out of the errors (a fit that ignored
        // it, H = 0, would be off by many standard errors).
        if dps > 0.0 {
            let loudest = (0..9)
                .map(|i| (truth[(i / 3, i % 3)] / g.raw_per_g_std_error[i / 3][i % 3]).abs())
                .fold(0.0, f64::max);
            assert!(loudest > 10.0, "seed {seed}: {loudest}");
        }
        // The calibration file carries G = K·H (rad/s per g).
        let file = rep.cal_file().expect("a calibration file");
        let k = mat(&rep.matrix.unwrap());
        let want = k * Matrix3::from_fn(|r, c| g.raw_per_g[r][c]);
        let got = mat(&file.correction.effects.g_sensitivity);
        assert!((got - want).abs().max() < 1e-12, "{got} vs {want}");
    }
    println!("largest |error| / SE over the seeds: {worst:.2}");
}

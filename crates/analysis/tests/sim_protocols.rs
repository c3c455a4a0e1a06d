//! The simulated calibration protocols against what physics and the truth's conventions say
//! independently of the simulator's code: a still face reads `D·up + b`, a constant rate
//! `D_g·(ω + G·a) + b_g`, the gyro corrected with the truth integrates to the angle of a
//! rotation and turns one face's gravity into the next face's, the turntable's corrected
//! rates have the speeds' magnitudes; and the files carry what the brief says they carry.

use nalgebra::{Matrix3, Rotation3, Vector3};
use wiical_sim::protocols::{
    simulate_protocol, write_protocol, AxesTruth, Face, ProtocolSim, ProtocolSimOptions,
    SegmentKind, SimProtocol, TrueSegment,
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

fn mean(rows: &[[f64; 3]]) -> Vector3<f64> {
    rows.iter().map(|r| Vector3::from(*r)).sum::<Vector3<f64>>() / rows.len() as f64
}

fn angle_deg(a: Vector3<f64>, b: Vector3<f64>) -> f64 {
    a.angle(&b).to_degrees()
}

/// Five standard errors of a mean of `n` samples of noise `sigma` (counts), plus a little
/// for the rounding to whole counts.
fn tol(sigma: f64, n: usize) -> f64 {
    5.0 * sigma / (n as f64).sqrt() + 0.05
}

/// The calibrated specific force (g) and body rate (rad/s) of every sample, with the truth:
/// `a = K_a·(m − b_a)`, `ω = K_g·(m − b_g) − G·a`.
fn calibrated(s: &ProtocolSim) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
    let t = &s.truth;
    let acc = t.accel.as_ref().unwrap();
    let a: Vec<Vector3<f64>> = s
        .accel
        .as_ref()
        .unwrap()
        .iter()
        .map(|m| acc.correct(*m).into())
        .collect();
    let g = mat(&t.gyro_g_sensitivity);
    let w = s
        .gyro
        .iter()
        .zip(&a)
        .map(|(m, a)| Vector3::from(t.gyro.correct(*m)) - g * a)
        .collect();
    (a, w)
}

/// The mean of a still segment matches `D·x + b` within its standard error.
fn assert_mean(samples: &[[f64; 3]], truth: &AxesTruth, x: Vector3<f64>, what: &str) {
    let n = samples.len();
    let want = mat(&truth.forward_matrix) * x + Vector3::from(truth.bias);
    let got = mean(samples);
    let err = (got - want).abs().max();
    assert!(
        err < tol(truth.noise_std_counts, n),
        "{what}: {got} vs {want} ({n} samples)"
    );
}

#[test]
fn six_faces_window_means_are_the_forward_model_of_each_face() {
    let s = simulate_protocol(&ProtocolSimOptions {
        g_sensitivity_dps_per_g: 0.3,
        ..Default::default()
    });
    let t = &s.truth;
    let (acc, g) = (t.accel.as_ref().unwrap(), mat(&t.gyro_g_sensitivity));
    assert_eq!(t.faces, ["x+", "x-", "y+", "y-", "z+", "z-"]);
    assert!(t.missing_faces.is_empty() && t.repeated_faces.is_empty());
    let rests: Vec<&TrueSegment> = t.segments_of(SegmentKind::Rest).collect();
    assert_eq!(rests.len(), 6);
    for (r, face) in rests.iter().zip(&t.faces) {
        let up = Vector3::from(r.up_start);
        let dir = Vector3::from(Face::parse(face).unwrap().direction());
        assert!(angle_deg(up, dir) <= 0.5 + 1e-9, "{face}: {up}");
        assert!((18.0..=22.0).contains(&(r.t_end - r.t_start)), "{r:?}");
        let rows = r.first..r.end;
        assert_mean(&s.accel.as_ref().unwrap()[rows.clone()], acc, up, face);
        // At rest the gyro reads its bias and its g-sensitivity.
        assert_mean(&s.gyro[rows], &t.gyro, g * up, face);
    }
    for tb in t.segments_of(SegmentKind::Tumble) {
        assert!((1.6..=2.4).contains(&(tb.t_end - tb.t_start)), "{tb:?}");
    }
}

/// The gyro, calibrated with the truth, integrated over all the motion between two rests
/// (tumbles, rotations, spins), turns the gravity the accelerometer saw at one rest into the
/// gravity it sees at the next, under every protocol with an accelerometer.
#[test]
fn the_gyro_turns_each_rests_gravity_into_the_next() {
    let cases = [
        (SimProtocol::SixFaces, 5),
        (SimProtocol::FaceMissing, 5),
        (SimProtocol::Ferraris, 5 + 1 + 3 + 2),
        (SimProtocol::RateTable, 6),
    ];
    for (protocol, moves) in cases {
        let s = simulate_protocol(&ProtocolSimOptions {
            protocol,
            g_sensitivity_dps_per_g: 0.3,
            ..Default::default()
        });
        let (a, w) = calibrated(&s);
        let dt = 1.0 / s.truth.rate_hz;
        let gravity = |seg: &TrueSegment| {
            a[seg.first..seg.end]
                .iter()
                .sum::<Vector3<f64>>()
                .normalize()
        };
        let rests: Vec<&TrueSegment> = s.truth.segments_of(SegmentKind::Rest).collect();
        let mut checked = 0;
        for pair in rests.windows(2) {
            if pair[0].end == pair[1].first {
                continue;
            }
            // Gravity in the body frame: ġ = −ω × g.
            let mut up = gravity(pair[0]);
            for wi in &w[pair[0].end..pair[1].first] {
                up = Rotation3::from_scaled_axis(-wi * dt) * up;
            }
            let next = gravity(pair[1]);
            let err = angle_deg(up, next);
            assert!(err < 0.2, "{protocol:?} before {:?}: {err}°", pair[1]);
            checked += 1;
        }
        assert_eq!(checked, moves, "{protocol:?}");
    }
}

/// Each Ferraris rotation's corrected gyro integral is the truth's angle about the truth's
/// axis; the axes are within 2° of x, y, z; the rates are lopsided; the angle is 360° unless
/// jittered.
#[test]
fn ferraris_rotations_integrate_to_the_truths_angle() {
    for jitter in [0.0, 5.0] {
        let s = simulate_protocol(&ProtocolSimOptions {
            protocol: SimProtocol::Ferraris,
            rotation_jitter_deg: jitter,
            seed: 7,
            ..Default::default()
        });
        let (_, w) = calibrated(&s);
        let dt = 1.0 / s.truth.rate_hz;
        let rots: Vec<&TrueSegment> = s.truth.segments_of(SegmentKind::Rotation).collect();
        assert_eq!(rots.len(), 3);
        assert_eq!(s.truth.segments_of(SegmentKind::Rest).count(), 6 + 6);
        for (i, r) in rots.iter().enumerate() {
            let axis = Vector3::from(r.axis);
            assert_eq!(r.label, ["x", "y", "z"][i]);
            assert!(angle_deg(axis, Vector3::ith(i, 1.0)) <= 2.001, "{r:?}");
            assert!((2.0..=4.0).contains(&(r.t_end - r.t_start)));
            if jitter == 0.0 {
                assert!((r.angle_deg - 360.0).abs() < 1e-9);
            } else {
                assert!((r.angle_deg - 360.0).abs() <= 5.0 && r.angle_deg != 360.0);
            }
            let rates = &w[r.first..r.end];
            let integral: Vector3<f64> = rates.iter().sum::<Vector3<f64>>() * dt;
            let want = axis * r.angle_deg.to_radians();
            assert!(
                (integral - want).norm().to_degrees() < 0.2,
                "{integral} vs {want}"
            );
            let peak = rates.iter().map(|v| v.norm()).fold(0.0, f64::max);
            let avg = integral.norm() / (r.t_end - r.t_start);
            assert!(peak > 1.9 * avg, "not a rate profile: {peak} vs {avg}");
        }
    }
}

/// The rate table's steady parts read `D_g·(±R·u) + b_g` (no g-sensitivity by default), in
/// the order x+ x− y+ y− z+ z−, about axes within 0.5° of the fixture's; the accelerometer
/// keeps reading 1 g while gravity turns about the spin axis.
#[test]
fn rate_table_steady_means_are_the_rate_through_the_forward_model() {
    let s = sim(SimProtocol::RateTable, 3);
    let t = &s.truth;
    let steady: Vec<&TrueSegment> = t.segments_of(SegmentKind::Steady).collect();
    assert_eq!(steady.len(), 6);
    let (a, _) = calibrated(&s);
    for (k, seg) in steady.iter().enumerate() {
        let axis = Vector3::from(seg.axis);
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        assert!(angle_deg(axis, Vector3::ith(k / 2, 1.0)) <= 0.501);
        assert_eq!(seg.rate_start_dps, sign * 25.0);
        assert_eq!(seg.rate_end_dps, seg.rate_start_dps);
        assert!((seg.t_end - seg.t_start - 20.0).abs() < 1e-9);
        let omega = axis * (sign * 25f64).to_radians();
        assert_mean(&s.gyro[seg.first..seg.end], &t.gyro, omega, &seg.label);
        for v in &a[seg.first..seg.end] {
            assert!((v.norm() - 1.0).abs() < 0.01, "{v}");
        }
        // Gravity turns about the axis: its component along the axis stays put.
        let along: Vec<f64> = a[seg.first..seg.end].iter().map(|v| v.dot(&axis)).collect();
        let spread = along.iter().fold(f64::MIN, |m, v| m.max(*v))
            - along.iter().fold(f64::MAX, |m, v| m.min(*v));
        assert!(spread < 0.03, "{}: {spread}", seg.label);
    }
    let ramps = t.segments_of(SegmentKind::Ramp).count();
    assert_eq!(ramps, 12);
}

/// The turntable: gyro columns only, no clock; each steady part's corrected rate has the
/// speed's magnitude about the platter's axis (vertical in the world, so along each rest's
/// gravity), the stopped parts read the bias.
#[test]
fn turntable_is_gyro_only_at_known_rate_magnitudes() {
    let s = sim(SimProtocol::Turntable, 5);
    let t = &s.truth;
    assert!(s.t.is_none() && s.accel.is_none() && t.accel.is_none());
    assert_eq!(t.columns, ["gx", "gy", "gz"]);
    let csv = wiical_sim::protocols::protocol_csv(&s);
    assert!(csv.starts_with("gx,gy,gz\n"));
    let steady: Vec<&TrueSegment> = t.segments_of(SegmentKind::Steady).collect();
    assert_eq!(steady.len(), 16);
    let k = mat(&t.gyro.matrix);
    let b = Vector3::from(t.gyro.bias);
    for (i, seg) in steady.iter().enumerate() {
        let speed = [200.0, 270.0][i % 2];
        let w = k * (mean(&s.gyro[seg.first..seg.end]) - b);
        assert!((w.norm().to_degrees() - speed).abs() < 0.05, "{seg:?}: {w}");
        // Clockwise seen from above: the rate vector points down.
        assert!(angle_deg(w, -Vector3::from(seg.up_start)) < 0.05);
    }
    let rests: Vec<&TrueSegment> = t.segments_of(SegmentKind::Rest).collect();
    assert_eq!(rests.len(), 8);
    for r in rests {
        assert_mean(&s.gyro[r.first..r.end], &t.gyro, Vector3::zeros(), &r.label);
    }
}

#[test]
fn one_pose_is_a_still_minute_with_z_up() {
    let s = sim(SimProtocol::OnePose, 2);
    let t = &s.truth;
    assert_eq!(t.segments.len(), 1);
    let r = &t.segments[0];
    assert_eq!(
        (r.kind, r.first, r.end, s.len()),
        (SegmentKind::Rest, 0, 6000, 6000)
    );
    assert!(angle_deg(Vector3::from(r.up_start), Vector3::z()) <= 1.0);
    assert_eq!(t.faces, ["z+"]);
    assert!(t.missing_faces.is_empty() && t.repeated_faces.is_empty());
    assert_mean(
        s.accel.as_ref().unwrap(),
        t.accel.as_ref().unwrap(),
        r.up_start.into(),
        "pose",
    );
}

/// A face missing: z+ never held, z− twice (the gravity of every rest says so, not only the
/// labels).
#[test]
fn face_missing_holds_z_minus_twice_and_never_z_plus() {
    let s = sim(SimProtocol::FaceMissing, 4);
    let t = &s.truth;
    assert_eq!(t.faces, ["x+", "x-", "y+", "y-", "z-", "z-"]);
    assert_eq!(
        (t.missing_faces.as_slice(), t.repeated_faces.as_slice()),
        (&["z+".to_string()][..], &["z-".to_string()][..])
    );
    let (a, _) = calibrated(&s);
    let mut down = 0;
    for r in t.segments_of(SegmentKind::Rest) {
        let g = a[r.first..r.end].iter().sum::<Vector3<f64>>().normalize();
        assert!(g.z < 0.99, "a rest with z up: {g}");
        down += usize::from(g.z < -0.99);
    }
    assert_eq!(down, 2);
}

/// The files: header, rows, whole counts, the truth next to them; without a clock no `t`.
#[test]
fn written_files_carry_the_samples_and_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    for no_clock in [false, true] {
        let s = simulate_protocol(&ProtocolSimOptions {
            protocol: SimProtocol::SixFaces,
            no_clock,
            face_s: 2.0,
            ..Default::default()
        });
        let path = dir.path().join(format!("six{no_clock}.csv"));
        let truth_path = write_protocol(&s, &path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let mut lines = text.lines();
        let header = lines.next().unwrap();
        assert_eq!(
            header,
            if no_clock {
                "ax,ay,az,gx,gy,gz"
            } else {
                "t,ax,ay,az,gx,gy,gz"
            }
        );
        let rows: Vec<Vec<f64>> = lines
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows.len(), s.len());
        let off = usize::from(!no_clock);
        for (i, row) in rows.iter().enumerate() {
            assert_eq!(&row[off..off + 3], &s.accel.as_ref().unwrap()[i][..]);
            assert_eq!(&row[off + 3..], &s.gyro[i][..]);
            if !no_clock {
                assert!((row[0] - i as f64 / 100.0).abs() < 1e-9);
            }
        }
        // The loader reads the accelerometer's columns back.
        let rec = wiical_analysis::input::text::parse(&text, &Default::default()).unwrap();
        assert_eq!(rec.xyz, *s.accel.as_ref().unwrap());
        assert_eq!(rec.t.is_some(), !no_clock);
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(truth_path).unwrap()).unwrap();
        assert_eq!(json["protocol"], "six-faces");
        assert_eq!(json["segments"].as_array().unwrap().len(), 11);
        assert_eq!(json["accel"]["unit"], "g");
        assert_eq!(json["gyro"]["unit"], "rad/s");
    }
}

/// One seed, one IMU under every protocol; another seed, another IMU and another motion.
#[test]
fn the_seed_draws_the_imu_once_for_every_protocol() {
    let a = sim(SimProtocol::SixFaces, 9);
    let b = sim(SimProtocol::Ferraris, 9);
    assert_eq!(a.truth.gyro.forward_matrix, b.truth.gyro.forward_matrix);
    assert_eq!(
        a.truth.accel.as_ref().unwrap().bias,
        b.truth.accel.as_ref().unwrap().bias
    );
    let again = sim(SimProtocol::SixFaces, 9);
    assert_eq!(a.accel, again.accel);
    assert_eq!(a.gyro, again.gyro);
    let other = sim(SimProtocol::SixFaces, 10);
    assert_ne!(a.truth.gyro.bias, other.truth.gyro.bias);
    assert_ne!(a.accel, other.accel);
}

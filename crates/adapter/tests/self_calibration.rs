//! Self-calibration on the adapter, driven by simulated Nunchuk pose sessions with a known
//! truth.
//!
//! ## The simulation (its truth is documented here, not taken from the code under test)
//! The host's simulator (`wiical simulate`) is not available to this crate (it is being moved
//! into `crates/analysis`), so the sessions are generated here:
//! * sensor: `m = D·a + b + v`, with `D` = [`truth`]'s forward matrix (≈ 200 counts/g, cross
//!   terms up to 3 counts/g, like the protocol tests' truth) and `b` its bias; `v` white
//!   Gaussian noise of [`NOISE_COUNTS`] counts; then rounded and clamped to 10 bits, as the
//!   Nunchuk's ADC does;
//! * `a` is the specific force in the sensor frame: the unit "up" direction of the pose when
//!   still; between poses the direction turns (linear interpolation, renormalised) for
//!   [`MOVE_S`] seconds while a hand's acceleration of 0.3 g (a 2 Hz sinusoid) is added;
//! * the user holds C and Z for [`HOLD_S`] s right after plug-in (resting in the first
//!   pose), releases them, and then holds each pose still for [`STILL_S`] s;
//! * 200 reports per second.
//!
//! "Within the host fit's error": the reference is the 9-parameter multi-position fit of the
//! same core on the exact still segments of the same recording (what `wiical fit` computes
//! with perfect segmentation). The self-calibration must get the bias and the gravity
//! magnitude over all directions as close to the truth as that reference, up to twice its
//! error plus the quantisation floor of 0.1 count / 0.5 mg.

mod common;

use common::{block_on, factory_block, CutFlash};
use nalgebra::{Matrix3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use wiical_adapter::poller::NunchukInfo;
use wiical_adapter::protocol::bits_equal;
use wiical_adapter::{
    BootLoad, CalibrationStore, DeviceInfo, IdealScale, Protocol, SelfCalConfig, SelfCalFailure,
    SelfCalResult, SelfCalStatus,
};
use wiical_core::acceptance::{CoverageGap, Rejection};
use wiical_core::multipos::{self, MultiPosConfig};
use wiical_core::Calibration;
use wiical_extbus::{CalibrationCopy, Encryption, NunchukReport};
use wiical_wire::{Hello, Request, Response, SelfCalOutcome, SelfCalPhase};

type Flash = CutFlash<4, 512, 4>;

const RATE_HZ: f64 = 200.0;
const NOISE_COUNTS: f64 = 0.5;
const HOLD_S: f64 = 3.3;
const STILL_S: f64 = 1.6;
const MOVE_S: f64 = 0.7;

/// The simulated sensor's truth: forward matrix (counts/g) and bias (counts).
fn truth() -> (Matrix3<f64>, Vector3<f64>) {
    (
        Matrix3::new(203.0, 2.5, -1.0, -3.0, 196.0, 1.5, 0.8, -2.2, 207.0),
        Vector3::new(505.3, 497.8, 518.6),
    )
}

/// A plausible calibration that is clearly not the truth's (bias 8 counts off, scale 3 %):
/// what the adapter had before the session.
fn old_calibration() -> Calibration {
    let k = 1.0 / 195.0;
    Calibration {
        bias: [513.0, 490.0, 511.0],
        matrix: [[k, 0.0, 0.0], [0.0, k, 0.0], [0.0, 0.0, k]],
        effects: Default::default(),
    }
}

/// Pose directions ("up" in the sensor frame): the six half-axes and the eight cube
/// diagonals, ordered so that both signs of every axis appear early.
fn sphere_poses() -> Vec<[f64; 3]> {
    let s = 1.0 / 3f64.sqrt();
    let mut v = vec![
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, 0.0, -1.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
    ];
    for (x, y, z) in [
        (1., 1., 1.),
        (-1., -1., -1.),
        (1., -1., 1.),
        (-1., 1., -1.),
        (1., 1., -1.),
        (-1., -1., 1.),
        (1., -1., -1.),
        (-1., 1., 1.),
    ] {
        v.push([x * s, y * s, z * s]);
    }
    v
}

/// One simulated report stream: the reports and, for the reference fit, the raw samples of
/// each still segment.
struct Session {
    reports: Vec<NunchukReport>,
    segments: Vec<Vec<[f32; 3]>>,
}

struct SimOptions {
    /// Poses to visit, in order.
    poses: Vec<[f64; 3]>,
    /// Standard deviation of a hand's tremor added while "still", g (0: resting).
    tremor_g: f64,
    /// Hold C + Z this long at the end (leaving the mode), s.
    exit_hold_s: f64,
    seed: u64,
    truth: (Matrix3<f64>, Vector3<f64>),
}

impl SimOptions {
    fn new(poses: Vec<[f64; 3]>, seed: u64) -> Self {
        Self {
            poses,
            tremor_g: 0.0,
            exit_hold_s: 0.0,
            seed,
            truth: truth(),
        }
    }
}

fn simulate(o: &SimOptions) -> Session {
    let (d, b) = o.truth;
    let mut rng = ChaCha8Rng::seed_from_u64(o.seed);
    let noise = Normal::new(0.0, NOISE_COUNTS).unwrap();
    let tremor = Normal::new(0.0, o.tremor_g.max(1e-12)).unwrap();
    let mut reports = Vec::new();
    let mut segments = Vec::new();
    let mut emit = |a: Vector3<f64>, c: bool, z: bool, rng: &mut ChaCha8Rng| -> [f32; 3] {
        let m = d * a + b + Vector3::from_fn(|_, _| noise.sample(rng));
        let accel = [m.x, m.y, m.z].map(|v| v.round().clamp(0.0, 1023.0) as u16);
        reports.push(NunchukReport {
            stick: [128, 128],
            accel,
            c,
            z,
        });
        accel.map(f32::from)
    };
    let n = |s: f64| (s * RATE_HZ).round() as usize;
    let up = |p: &[f64; 3]| Vector3::new(p[0], p[1], p[2]);
    // Plug-in hold in the first pose (not a segment: the session has not started).
    for _ in 0..n(HOLD_S) {
        emit(up(&o.poses[0]), true, true, &mut rng);
    }
    for (i, p) in o.poses.iter().enumerate() {
        let mut seg = Vec::new();
        for _ in 0..n(STILL_S) {
            let shake = if o.tremor_g > 0.0 {
                Vector3::from_fn(|_, _| tremor.sample(&mut rng))
            } else {
                Vector3::zeros()
            };
            seg.push(emit(up(p) + shake, false, false, &mut rng));
        }
        segments.push(seg);
        let next = o.poses.get(i + 1).unwrap_or(p);
        let steps = n(MOVE_S);
        for k in 0..steps {
            let f = (k as f64 + 0.5) / steps as f64;
            let mut dir = up(p) * (1.0 - f) + up(next) * f;
            if dir.norm() < 1e-3 {
                dir = Vector3::new(1.0, 0.0, 0.0); // opposite poses: turn through +x
            }
            let hand = 0.3 * (2.0 * std::f64::consts::PI * 2.0 * k as f64 / RATE_HZ).sin();
            emit(
                dir.normalize() + Vector3::new(hand, -hand, 0.5 * hand),
                false,
                false,
                &mut rng,
            );
        }
    }
    let last = up(o.poses.last().unwrap());
    for _ in 0..n(o.exit_hold_s) {
        emit(last, true, true, &mut rng);
    }
    // Some still time after, so that the result's status can be seen.
    for _ in 0..n(0.5) {
        emit(last, false, false, &mut rng);
    }
    Session { reports, segments }
}

fn device_info() -> DeviceInfo {
    DeviceInfo::new("selfcal-test", [9; 8], 200_000)
}

fn nunchuk_info() -> NunchukInfo {
    let block = factory_block();
    NunchukInfo {
        encryption: Encryption::None,
        calibration_bytes: block.encode().unwrap(),
        calibration: Some((block, CalibrationCopy::First)),
    }
}

fn boot(flash: &mut Flash) -> Protocol<&mut Flash> {
    let store = CalibrationStore::new(flash, 0..Flash::SIZE).unwrap();
    block_on(Protocol::boot(store, device_info(), IdealScale::default()))
}

/// Commit `cal` over the wire, as a host would.
fn commit_over_wire(p: &mut Protocol<&mut Flash>, cal: &Calibration) {
    let r = block_on(p.handle(Request::Hello(Hello::CURRENT)));
    assert!(matches!(r, Response::Hello(_)));
    assert_eq!(
        block_on(p.handle(Request::PutCalibration((*cal).into()))),
        Response::Ack
    );
    assert_eq!(
        block_on(p.handle(Request::CommitCalibration)),
        Response::Ack
    );
}

/// Plug in, play the session, servicing the commit after every report as the firmware's
/// Nunchuk task does. Returns the statuses seen (deduplicated, in order).
fn play(p: &mut Protocol<&mut Flash>, s: &Session) -> Vec<SelfCalStatus> {
    p.on_connected(&nunchuk_info());
    let mut seen: Vec<SelfCalStatus> = Vec::new();
    for r in &s.reports {
        p.on_report(r);
        block_on(p.service());
        let st = p.selfcal().status();
        if seen.last() != Some(&st) {
            seen.push(st);
        }
    }
    seen
}

/// (bias error in counts, max |‖a‖ − 1| in g over 400 directions) of `cal` against the truth.
fn error_vs_truth(cal: &Calibration, truth: &(Matrix3<f64>, Vector3<f64>)) -> (f64, f64) {
    let (d, b) = truth;
    let bias = Vector3::new(cal.bias[0] as f64, cal.bias[1] as f64, cal.bias[2] as f64);
    let k = Matrix3::from_fn(|i, j| cal.matrix[i][j] as f64);
    let mut worst = 0.0f64;
    let n = 400;
    for i in 0..n {
        // Fibonacci sphere.
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let phi = i as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let u = Vector3::new(r * phi.cos(), r * phi.sin(), z);
        let m = d * u + b;
        worst = worst.max(((k * (m - bias)).norm() - 1.0).abs());
    }
    ((bias - b).norm(), worst)
}

/// The reference: the core's fit on the exact still segments.
fn reference_fit(s: &Session) -> Calibration {
    let means: Vec<[f32; 3]> = s
        .segments
        .iter()
        .map(|seg| {
            let n = seg.len() as f64;
            let mut m = [0.0f64; 3];
            for x in seg {
                for a in 0..3 {
                    m[a] += x[a] as f64 / n;
                }
            }
            m.map(|v| v as f32)
        })
        .collect();
    multipos::fit(&means, &MultiPosConfig::default())
        .unwrap()
        .calibration
}

fn assert_old_kept(p: &Protocol<&mut Flash>) {
    let live = p.corrector().user_calibration().copied().unwrap();
    assert!(
        bits_equal(&live, &old_calibration()),
        "live changed: {live:?}"
    );
}

fn assert_boots_with(flash: &mut Flash, want: &Calibration) {
    flash.reboot();
    let p = boot(flash);
    assert_eq!(p.status().boot, BootLoad::Loaded);
    let got = p.corrector().user_calibration().copied().unwrap();
    assert!(bits_equal(&got, want), "{got:?} vs {want:?}");
}

#[test]
fn a_full_session_recovers_the_truth_within_the_reference_fit_error() {
    let session = simulate(&SimOptions::new(sphere_poses(), 1));
    let mut flash = Flash::new(1);
    let mut p = boot(&mut flash);
    commit_over_wire(&mut p, &old_calibration());
    let seen = play(&mut p, &session);

    // The LED went through the guided states, in order, and ended with Done.
    assert_eq!(seen.first(), Some(&SelfCalStatus::Arming));
    assert!(seen.contains(&SelfCalStatus::WaitingForStillness { poses: 0 }));
    assert!(seen.contains(&SelfCalStatus::PoseTaken { poses: 1 }));
    // (`Committing` lasts from the fit to the `service()` call right after: not observed.)
    assert!(seen.contains(&SelfCalStatus::Done));
    let Some(SelfCalResult::Done { rms_g, poses }) = p.selfcal().last_result() else {
        panic!("{:?} after {seen:?}", p.selfcal().last_result())
    };
    // The coverage rule stopped the session at its minimum (12 of the 14 poses offered).
    assert_eq!(poses, 12);

    let cal = *p.corrector().user_calibration().unwrap();
    let (bias_err, norm_err) = error_vs_truth(&cal, &session_truth());
    let (ref_bias_err, ref_norm_err) = error_vs_truth(&reference_fit(&session), &session_truth());
    eprintln!(
        "self-cal: bias error {bias_err:.4} counts, max |‖a‖−1| {:.3} mg, fit RMS {:.3} mg; \
         reference fit: {ref_bias_err:.4} counts, {:.3} mg",
        norm_err * 1e3,
        rms_g * 1e3,
        ref_norm_err * 1e3
    );
    assert!(
        bias_err <= 2.0 * ref_bias_err + 0.1,
        "{bias_err} vs {ref_bias_err}"
    );
    assert!(
        norm_err <= 2.0 * ref_norm_err + 5e-4,
        "{norm_err} vs {ref_norm_err}"
    );
    // And in absolute terms: well below one count (5 mg).
    assert!(norm_err < 2e-3 && bias_err < 0.5);

    // Stored: the next boot loads exactly this calibration.
    drop(p);
    assert_boots_with(&mut flash, &cal);
}

fn session_truth() -> (Matrix3<f64>, Vector3<f64>) {
    truth()
}

#[test]
fn the_session_is_reported_over_the_wire() {
    let session = simulate(&SimOptions::new(sphere_poses(), 2));
    let mut flash = Flash::new(2);
    let mut p = boot(&mut flash);
    p.on_connected(&nunchuk_info());
    let hello = block_on(p.handle(Request::Hello(Hello::CURRENT)));
    assert!(matches!(hello, Response::Hello(_)));
    let mut phases = Vec::new();
    for (i, r) in session.reports.iter().enumerate() {
        p.on_report(r);
        block_on(p.service());
        if i % 50 == 0 {
            let Response::Status(st) = block_on(p.handle(Request::GetStatus)) else {
                panic!()
            };
            if phases.last() != Some(&st.phase) {
                phases.push(st.phase);
            }
            // Uploads are refused while the session runs.
            if matches!(st.phase, SelfCalPhase::WaitingForStillness) {
                assert_eq!(
                    block_on(p.handle(Request::PutCalibration(old_calibration().into()))),
                    Response::Error(wiical_wire::ErrorCode::Busy)
                );
            }
        }
    }
    assert!(phases.contains(&SelfCalPhase::Arming), "{phases:?}");
    assert!(phases.contains(&SelfCalPhase::WaitingForStillness));
    let Response::Status(st) = block_on(p.handle(Request::GetStatus)) else {
        panic!()
    };
    assert!(
        matches!(st.last_result, Some(SelfCalOutcome::Done { poses: 12, rms_mg }) if rms_mg < 5.0),
        "{st:?}"
    );
}

/// Runs a session that must fail; checks the failure and that the old calibration stays
/// live and stored.
fn failing_session(o: &SimOptions) -> SelfCalFailure {
    let session = simulate(o);
    let mut flash = Flash::new(o.seed);
    let mut p = boot(&mut flash);
    commit_over_wire(&mut p, &old_calibration());
    let seen = play(&mut p, &session);
    let Some(SelfCalResult::Failed(why)) = p.selfcal().last_result() else {
        panic!("{:?} after {seen:?}", p.selfcal().last_result())
    };
    assert!(seen.contains(&SelfCalStatus::Failed(why)), "{seen:?}");
    assert!(!p.selfcal().active());
    assert_old_kept(&p);
    drop(p);
    assert_boots_with(&mut flash, &old_calibration());
    why
}

#[test]
fn too_few_poses_then_leaving_fails_cleanly() {
    let mut o = SimOptions::new(sphere_poses()[..5].to_vec(), 3);
    o.exit_hold_s = 3.2;
    let why = failing_session(&o);
    assert_eq!(
        why,
        SelfCalFailure::Cancelled(CoverageGap::TooFewPoses { needed: 12, got: 5 })
    );
}

#[test]
fn poses_all_in_one_plane_fail_cleanly() {
    // 16 distinct directions in the x–y plane (22.5° apart): the coverage rule is never
    // met (no pose with ±z up), the user gives up.
    let poses: Vec<[f64; 3]> = (0..16)
        .map(|i| {
            let t = i as f64 * std::f64::consts::PI / 8.0;
            [t.cos(), t.sin(), 0.0]
        })
        .collect();
    let mut o = SimOptions::new(poses, 4);
    o.exit_hold_s = 3.2;
    let why = failing_session(&o);
    assert_eq!(
        why,
        SelfCalFailure::Cancelled(CoverageGap::MissingDirection {
            axis: 2,
            positive: true
        })
    );
}

#[test]
fn a_shaking_hand_gives_no_poses_and_fails_cleanly() {
    // 0.05 g of tremor: 10 counts standard deviation, a variance 50× the limit.
    let mut o = SimOptions::new(sphere_poses(), 5);
    o.tremor_g = 0.05;
    o.exit_hold_s = 3.2;
    let why = failing_session(&o);
    assert_eq!(
        why,
        SelfCalFailure::Cancelled(CoverageGap::TooFewPoses { needed: 12, got: 0 })
    );
}

#[test]
fn an_implausible_fit_is_not_committed() {
    // A sensor with 1.5× the nominal sensitivity: the fit is excellent, the acceptance
    // predicate refuses it.
    let mut o = SimOptions::new(sphere_poses(), 6);
    let (d, _) = truth();
    o.truth = (d * 1.5, Vector3::new(512.0, 510.0, 505.0));
    let why = failing_session(&o);
    assert!(
        matches!(
            why,
            SelfCalFailure::Implausible(Rejection::Sensitivity { .. })
        ),
        "{why:?}"
    );
}

#[test]
fn a_session_that_does_not_finish_times_out() {
    let session = simulate(&SimOptions::new(sphere_poses()[..4].to_vec(), 7));
    let mut flash = Flash::new(7);
    let mut cfg = SelfCalConfig::nunchuk(200);
    cfg.timeout_samples = 2000; // 10 s; the session offers 4 poses in 12 s
    let mut p = boot(&mut flash).with_selfcal_config(cfg);
    commit_over_wire(&mut p, &old_calibration());
    play(&mut p, &session);
    assert_eq!(
        p.selfcal().last_result(),
        Some(SelfCalResult::Failed(SelfCalFailure::Timeout))
    );
    assert_old_kept(&p);
}

#[test]
fn buttons_held_later_than_plug_in_do_not_enter_the_mode() {
    let mut session = simulate(&SimOptions::new(sphere_poses(), 8));
    // Two seconds of play before the buttons go down.
    let first = session.reports[0];
    let idle = NunchukReport {
        c: false,
        z: false,
        ..first
    };
    session.reports.splice(0..0, std::iter::repeat_n(idle, 400));
    let mut flash = Flash::new(8);
    let mut p = boot(&mut flash);
    commit_over_wire(&mut p, &old_calibration());
    let seen = play(&mut p, &session);
    assert_eq!(seen, vec![SelfCalStatus::Off]);
    assert_eq!(p.selfcal().last_result(), None);
    assert_old_kept(&p);
}

/// Power cut at every flash word operation of the self-calibration's commit: the next boot
/// has the old calibration or the new one, bit for bit, never anything else.
#[test]
fn power_cut_during_the_commit_leaves_old_or_new() {
    let session = simulate(&SimOptions::new(sphere_poses(), 9));
    // Word operations before the session's commit (boot + the old calibration's commit),
    // and after it: the same sequence without cuts.
    let ops_before = {
        let mut flash = Flash::new(9);
        let mut p = boot(&mut flash);
        commit_over_wire(&mut p, &old_calibration());
        drop(p);
        flash.ops
    };
    let (ops_total, new_cal) = {
        let mut flash = Flash::new(9);
        let mut p = boot(&mut flash);
        commit_over_wire(&mut p, &old_calibration());
        play(&mut p, &session);
        let cal = *p.corrector().user_calibration().unwrap();
        assert!(matches!(
            p.selfcal().last_result(),
            Some(SelfCalResult::Done { .. })
        ));
        drop(p);
        (flash.ops, cal)
    };
    assert!(ops_total > ops_before);
    let (mut old_seen, mut new_seen) = (0, 0);
    for cut in ops_before..=ops_total {
        let mut flash = Flash::new(cut);
        flash.cut_after = Some(cut);
        let mut p = boot(&mut flash);
        commit_over_wire(&mut p, &old_calibration());
        play(&mut p, &session);
        let result = p.selfcal().last_result();
        let live = *p.corrector().user_calibration().unwrap();
        drop(p);
        match result {
            Some(SelfCalResult::Failed(SelfCalFailure::Storage)) => {
                assert!(
                    bits_equal(&live, &old_calibration()),
                    "cut {cut}: live changed"
                );
            }
            Some(SelfCalResult::Done { .. }) => assert!(bits_equal(&live, &new_cal)),
            other => panic!("cut {cut}: {other:?}"),
        }
        flash.reboot();
        let p = boot(&mut flash);
        let loaded = p.corrector().user_calibration().copied();
        match loaded {
            Some(c) if bits_equal(&c, &old_calibration()) => old_seen += 1,
            Some(c) if bits_equal(&c, &new_cal) => new_seen += 1,
            other => panic!("cut {cut}: booted with {other:?}"),
        }
    }
    eprintln!(
        "{} cut points: {old_seen} booted old, {new_seen} booted new",
        ops_total - ops_before + 1
    );
    assert!(old_seen > 0 && new_seen > 0);
}

/// The stale monitor: with the truth's calibration live, still moments read 1 g; with a
/// calibration 10 % off in scale it suggests recalibration.
#[test]
fn the_stale_monitor_flags_a_calibration_that_is_off() {
    let mut o = SimOptions::new(sphere_poses()[..8].to_vec(), 10);
    o.exit_hold_s = 0.0;
    let mut session = simulate(&o);
    // No button hold at plug-in: plain play.
    let n_hold = (HOLD_S * RATE_HZ).round() as usize;
    session.reports.drain(..n_hold);
    let (d, b) = truth();
    let k = d.try_inverse().unwrap();
    let good = Calibration {
        bias: [b.x, b.y, b.z].map(|v| v as f32),
        matrix: std::array::from_fn(|i| std::array::from_fn(|j| k[(i, j)] as f32)),
        effects: Default::default(),
    };
    let mut bad = good;
    for r in &mut bad.matrix {
        for x in r {
            *x *= 1.1;
        }
    }
    for (cal, expect_flag) in [(good, false), (bad, true)] {
        let mut flash = Flash::new(10);
        let mut p = boot(&mut flash);
        commit_over_wire(&mut p, &cal);
        let seen = play(&mut p, &session);
        assert_eq!(seen, vec![SelfCalStatus::Off]);
        let st = p.selfcal().stale();
        eprintln!("stale estimate: {st:?}");
        assert!(st.moments >= 7, "{st:?}");
        assert_eq!(st.recalibration_suggested, expect_flag, "{st:?}");
        if expect_flag {
            assert!((st.rms_g - 0.1).abs() < 0.01, "{st:?}");
        } else {
            assert!(st.rms_g < 0.005, "{st:?}");
        }
        let Response::Status(w) = block_on(p.handle(Request::GetStatus)) else {
            panic!()
        };
        assert_eq!(w.recalibration_suggested, expect_flag);
        assert_eq!(w.stale_moments, st.moments);
    }
}

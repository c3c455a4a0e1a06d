//! Deterministic instruction counts and peak stack of the core's on-device operations on
//! the emulated Cortex-M33 (QEMU `mps2-an505`, run with `-icount shift=0`; see [`rt`] for
//! how instructions are counted). Prints a table; `cargo xtask qemu-bench` runs it.
//!
//! Each operation runs `reps` times in a loop whose inputs go through `black_box` (so the
//! calibration, filter state etc. are loaded from memory every time, as in the firmware);
//! the same loop with the operation left out is subtracted, and the difference divided by
//! `reps`. Peak stack is measured on one call by stack painting.
#![no_std]
#![no_main]

use core::fmt::Write as _;
use core::hint::black_box;
use cortex_m_rt::{entry, exception};
use cortex_m_semihosting::hprintln;
use wiical_adapter::{Corrector, EmulatedNunchuk, IdealScale, SelfCal, SelfCalConfig};
use wiical_core::acceptance::{Acceptance, CoverageRule};
use wiical_core::gyro::{Adjustment, GyroCalibration, MotionIntegrator, NPARAM};
use wiical_core::gyro_zero::{ZeroRateConfig, ZeroRateTracker};
use wiical_core::kalman::PvbFilter;
use wiical_core::magfit::{AxisEllipsoidFit, EllipsoidFit, SphereFit};
use wiical_core::multipos::{self, MultiPosConfig};
use wiical_core::six_position;
use wiical_core::static_detect::{NoiseSurvey, StaticDetector, StaticDetectorConfig};
use wiical_core::{Calibration, Conditions, PreparedCalibration};
use wiical_qemu_tests::cases::{
    adapter_report_update, adapter_wiimote_read, factory_info, mag_point, poses30,
    wiimote_calibration, XorShift, NUNCHUK_CAL, NUNCHUK_RAWS, PVB_CONFIG, SAMPLES, SEED_M,
};
use wiical_qemu_tests::rt;

#[exception]
fn SysTick() {
    rt::on_systick_wrap();
}

/// Instructions per tick (measured, see [`rt::instructions_per_tick`]).
#[derive(Clone, Copy)]
struct Scale(f64);

impl Scale {
    fn per_op(self, op_ticks: u64, base_ticks: u64, reps: u32) -> f64 {
        op_ticks.saturating_sub(base_ticks) as f64 * self.0 / f64::from(reps)
    }
}

/// A target from the project brief: `instructions ≤ max_instr`, `stack ≤ max_stack`.
struct Target {
    max_instr: Option<f64>,
    max_stack: Option<usize>,
}

const NONE: Target = Target {
    max_instr: None,
    max_stack: None,
};

fn row(name: &str, unit: &str, instr: f64, stack: Option<usize>, target: Target) -> bool {
    let stack_txt = match stack {
        Some(s) => s,
        None => usize::MAX,
    };
    let mut verdict_ok = true;
    let mut verdict: heapless::String<96> = heapless::String::new();
    if let Some(m) = target.max_instr {
        let ok = instr <= m;
        verdict_ok &= ok;
        let _ = write!(
            verdict,
            "<= {m} instr: {}",
            if ok { "met" } else { "MISSED" }
        );
    }
    if let Some(m) = target.max_stack {
        let ok = stack.is_some_and(|s| s <= m);
        verdict_ok &= ok;
        if !verdict.is_empty() {
            let _ = verdict.write_str("; ");
        }
        let _ = write!(
            verdict,
            "<= {m} B stack: {}",
            if ok { "met" } else { "MISSED" }
        );
    }
    let precision = if instr < 1000.0 { 1 } else { 0 };
    if stack_txt == usize::MAX {
        hprintln!(
            "| {:<58} | {:<10} | {:>12.*} | {:>10} | {} |",
            name,
            unit,
            precision,
            instr,
            "> 64 KiB",
            verdict.as_str()
        );
    } else {
        hprintln!(
            "| {:<58} | {:<10} | {:>12.*} | {:>10} | {} |",
            name,
            unit,
            precision,
            instr,
            stack_txt,
            verdict.as_str()
        );
    }
    verdict_ok
}

/// Peak stack with SysTick stopped (so no exception frame lands in the measurement).
fn stack_of<R>(f: impl FnOnce() -> R) -> Option<usize> {
    rt::systick_enabled(false);
    let s = rt::peak_stack(f);
    rt::systick_enabled(true);
    s
}

#[entry]
fn main() -> ! {
    let Some(p) = cortex_m::Peripherals::take() else {
        rt::exit(false)
    };
    rt::start_systick(p.SYST);

    let (instr, ticks, ratio) = rt::instructions_per_tick();
    let sc = Scale(ratio);
    hprintln!(
        "timer: SysTick on the core clock (QEMU emulates no DWT cycle counter); \
         {} instructions of a subs/bne loop = {} ticks: {} instructions per tick",
        instr,
        ticks,
        ratio
    );
    hprintln!();
    hprintln!(
        "| {:<58} | {:<10} | {:>12} | {:>10} | target |",
        "operation",
        "per",
        "instructions",
        "stack (B)"
    );
    hprintln!("|{:-<60}|{:-<12}|{:->14}|{:->12}|---|", "", "", "", "");

    let Ok(cal) = wiimote_calibration() else {
        rt::exit(false)
    };

    let mut all_ok = correction_rows(sc, cal);
    all_ok &= six_position_rows(sc);
    let (ok, iters) = multipos_rows(sc);
    all_ok &= ok;
    all_ok &= magnetometer_rows(sc);
    all_ok &= kalman_rows(sc);
    all_ok &= static_detection_rows(sc);
    all_ok &= gyro_rows(sc);
    all_ok &= noise_survey_rows(sc);
    all_ok &= adapter_rows(sc);
    all_ok &= selfcal_rows(sc);
    all_ok &= wiical_qemu_tests::background_bench::rows(sc.0);
    all_ok &= wiical_qemu_tests::background_bench::report_path_rows(sc.0);
    all_ok &= wiical_qemu_tests::gyro_bench::rows(sc.0);
    all_ok &= wiical_qemu_tests::motionplus_bench::rows(sc.0);

    hprintln!();
    hprintln!(
        "multipos::fit used {} Levenberg-Marquardt iterations on the 30 poses",
        iters
    );
    hprintln!(
        "targets: {}",
        if all_ok { "all met" } else { "some MISSED" }
    );
    rt::exit(true)
}

/// Repetitions of the per-sample correction loops.
const R_CORR: u32 = 10_000;

/// `Calibration::correct_linear`, and `correct` with every effect term.
fn correction_rows(sc: Scale, cal: Calibration) -> bool {
    let mut all_ok = true;
    // --- correction
    let base = rt::time_reps(R_CORR, |i| {
        let c = black_box(&cal);
        (c as *const Calibration, SAMPLES[i as usize & 7])
    });
    let op = rt::time_reps(R_CORR, |i| {
        black_box(&cal).correct_linear(SAMPLES[i as usize & 7])
    });
    let st = stack_of(|| black_box(&cal).correct_linear(black_box(SAMPLES[0])));
    all_ok &= row(
        "Calibration::correct_linear",
        "sample",
        sc.per_op(op, base, R_CORR),
        st,
        Target {
            max_instr: Some(60.0),
            max_stack: None,
        },
    );
    let mut cal_fx = cal;
    cal_fx.effects.quadratic = [0.01, -0.02, 0.005];
    cal_fx.effects.cubic = [-0.003, 0.002, 0.001];
    cal_fx.effects.bias_drift = [0.01, -0.02, 0.0];
    cal_fx.effects.temp_ref_c = 25.0;
    cal_fx.effects.bias_temp = [0.1, 0.0, -0.05];
    cal_fx.effects.scale_temp = [1e-4, -2e-4, 0.0];
    let cond = Conditions {
        time_s: 12.0,
        temperature_c: Some(31.0),
    };
    let base = rt::time_reps(R_CORR, |i| {
        let c = black_box(&cal_fx);
        let k = black_box(&cond);
        (
            c as *const Calibration,
            k as *const Conditions,
            SAMPLES[i as usize & 7],
        )
    });
    let op = rt::time_reps(R_CORR, |i| {
        black_box(&cal_fx).correct(SAMPLES[i as usize & 7], black_box(&cond))
    });
    let st = stack_of(|| black_box(&cal_fx).correct(black_box(SAMPLES[0]), black_box(&cond)));
    all_ok &= row(
        "Calibration::correct (all effect terms)",
        "sample",
        sc.per_op(op, base, R_CORR),
        st,
        NONE,
    );
    all_ok &= cross_and_prepared_rows(sc, cal_fx, cond, base);
    all_ok
}

/// `correct` with the cross terms on top (against the same baseline `base` as the effect
/// terms), and both calibrations prepared once.
fn cross_and_prepared_rows(sc: Scale, cal_fx: Calibration, cond: Conditions, base: u64) -> bool {
    let mut all_ok = true;
    // The orientation-dependent cross terms on top (what the adapter applies).
    let mut cal_x = cal_fx;
    cal_x.effects.cross_quadratic = wiical_qemu_tests::cases::CROSS_QUADRATIC;
    cal_x.effects.cross_cubic = wiical_qemu_tests::cases::CROSS_CUBIC;
    let op = rt::time_reps(R_CORR, |i| {
        black_box(&cal_x).correct(SAMPLES[i as usize & 7], black_box(&cond))
    });
    let st = stack_of(|| black_box(&cal_x).correct(black_box(SAMPLES[0]), black_box(&cond)));
    all_ok &= row(
        "Calibration::correct (all terms + cross terms)",
        "sample",
        sc.per_op(op, base, R_CORR),
        st,
        NONE,
    );
    // The per-sample path: the same two calibrations prepared once (the cross-term test done
    // at construction, not per call).
    for (label, prepared) in [
        (
            "PreparedCalibration::correct (all effect terms)",
            cal_fx.prepare(),
        ),
        (
            "PreparedCalibration::correct (all + cross terms)",
            cal_x.prepare(),
        ),
    ] {
        let base = rt::time_reps(R_CORR, |i| {
            let p = black_box(&prepared);
            let k = black_box(&cond);
            (
                p as *const PreparedCalibration,
                k as *const Conditions,
                SAMPLES[i as usize & 7],
            )
        });
        let op = rt::time_reps(R_CORR, |i| {
            black_box(&prepared).correct(SAMPLES[i as usize & 7], black_box(&cond))
        });
        let st = stack_of(|| black_box(&prepared).correct(black_box(SAMPLES[0]), black_box(&cond)));
        all_ok &= row(label, "sample", sc.per_op(op, base, R_CORR), st, NONE);
    }
    all_ok
}

/// The seed's six-position solve.
fn six_position_rows(sc: Scale) -> bool {
    let mut all_ok = true;
    // --- six-position solve
    const R_SIX: u32 = 200;
    let base = rt::time_reps(R_SIX, |_| black_box(&SEED_M) as *const _);
    let op = rt::time_reps(R_SIX, |_| six_position::solve(black_box(&SEED_M)));
    let st = stack_of(|| six_position::solve(black_box(&SEED_M)));
    all_ok &= row(
        "six_position::solve (seed M)",
        "solve",
        sc.per_op(op, base, R_SIX),
        st,
        NONE,
    );
    all_ok
}

/// The multi-position fit of 30 poses; also its iteration count.
fn multipos_rows(sc: Scale) -> (bool, u32) {
    let mut all_ok = true;
    // --- multi-position fit, 30 poses
    let poses = poses30();
    let cfg = MultiPosConfig::default();
    const R_MP: u32 = 4;
    let base = rt::time_reps(R_MP, |_| black_box(&poses) as *const _);
    let op = rt::time_reps(R_MP, |_| multipos::fit(black_box(&poses), &cfg));
    let st = stack_of(|| multipos::fit(black_box(&poses), &cfg));
    let iters = multipos::fit(&poses, &cfg)
        .map(|f| f.iterations)
        .unwrap_or(0);
    all_ok &= row(
        "multipos::fit, 30 poses (9-param LM)",
        "fit",
        sc.per_op(op, base, R_MP),
        st,
        Target {
            max_instr: Some(3_000_000.0),
            max_stack: Some(8 * 1024),
        },
    );
    (all_ok, iters)
}

/// The magnetometer fits: per-sample sums, then the solves.
fn magnetometer_rows(sc: Scale) -> bool {
    let mut all_ok = true;
    // --- magnetometer: accumulate per sample, then solve
    const NPTS: usize = 300;
    let pts: [[f32; 3]; NPTS] = core::array::from_fn(|k| mag_point(k, NPTS));
    const R_PUSH: u32 = 3 * NPTS as u32;
    let mut acc = EllipsoidFit::new();
    let base = rt::time_reps(R_PUSH, |i| {
        let a = black_box(&mut acc);
        (a as *mut EllipsoidFit, pts[i as usize % NPTS])
    });
    let mut acc = EllipsoidFit::new();
    let op = rt::time_reps(R_PUSH, |i| black_box(&mut acc).push(pts[i as usize % NPTS]));
    let mut acc2 = EllipsoidFit::new();
    let st = stack_of(|| black_box(&mut acc2).push(black_box(pts[1])));
    all_ok &= row(
        "magfit::EllipsoidFit::push (9-param sums)",
        "sample",
        sc.per_op(op, base, R_PUSH),
        st,
        NONE,
    );
    let mut sph = SphereFit::new();
    let base = rt::time_reps(R_PUSH, |i| {
        let a = black_box(&mut sph);
        (a as *mut SphereFit, pts[i as usize % NPTS])
    });
    let mut sph = SphereFit::new();
    let op = rt::time_reps(R_PUSH, |i| black_box(&mut sph).push(pts[i as usize % NPTS]));
    let mut sph2 = SphereFit::new();
    let st = stack_of(|| black_box(&mut sph2).push(black_box(pts[1])));
    all_ok &= row(
        "magfit::SphereFit::push",
        "sample",
        sc.per_op(op, base, R_PUSH),
        st,
        NONE,
    );
    let mut axis = AxisEllipsoidFit::new();
    for p in &pts {
        let _ = axis.push(*p);
    }
    const R_SOLVE: u32 = 20;
    let base = rt::time_reps(R_SOLVE, |_| black_box(&acc) as *const _);
    let op = rt::time_reps(R_SOLVE, |_| black_box(&acc).solve());
    let st = stack_of(|| black_box(&acc).solve());
    all_ok &= row(
        "magfit::EllipsoidFit::solve (rotated ellipsoid)",
        "solve",
        sc.per_op(op, base, R_SOLVE),
        st,
        NONE,
    );
    let base = rt::time_reps(R_SOLVE, |_| black_box(&axis) as *const _);
    let op = rt::time_reps(R_SOLVE, |_| black_box(&axis).solve());
    let st = stack_of(|| black_box(&axis).solve());
    all_ok &= row(
        "magfit::AxisEllipsoidFit::solve",
        "solve",
        sc.per_op(op, base, R_SOLVE),
        st,
        NONE,
    );
    let base = rt::time_reps(R_SOLVE, |_| black_box(&sph) as *const _);
    let op = rt::time_reps(R_SOLVE, |_| black_box(&sph).solve());
    let st = stack_of(|| black_box(&sph).solve());
    all_ok &= row(
        "magfit::SphereFit::solve",
        "solve",
        sc.per_op(op, base, R_SOLVE),
        st,
        NONE,
    );
    all_ok
}

/// One `[p, v, b]` Kalman step.
fn kalman_rows(sc: Scale) -> bool {
    let mut all_ok = true;
    // --- Kalman [p, v, b] step
    let mut rng = XorShift::new(2008);
    let inputs: [(f32, f32); 64] =
        core::array::from_fn(|_| (0.25 + 0.05 * rng.next_f32(), 0.005 * rng.next_f32()));
    let Ok(filter0) = PvbFilter::new(&PVB_CONFIG) else {
        rt::exit(false)
    };
    const R_KF: u32 = 2_000;
    let mut f = filter0;
    let base = rt::time_reps(R_KF, |i| {
        let f = black_box(&mut f);
        (f as *mut PvbFilter, inputs[i as usize & 63])
    });
    let mut f = filter0;
    let op = rt::time_reps(R_KF, |i| {
        let (a, z) = inputs[i as usize & 63];
        let f = black_box(&mut f);
        f.predict(a).and_then(|_| f.update(z))
    });
    let mut f2 = filter0;
    let st = stack_of(|| {
        let f = black_box(&mut f2);
        f.predict(black_box(0.25))
            .and_then(|_| f.update(black_box(0.001)))
    });
    all_ok &= row(
        "kalman::PvbFilter predict + update",
        "step",
        sc.per_op(op, base, R_KF),
        st,
        NONE,
    );
    all_ok
}

/// The static detector's per-sample push.
fn static_detection_rows(sc: Scale) -> bool {
    let mut all_ok = true;
    // --- static detection, 101-sample window (as the host benchmark)
    let dcfg = StaticDetectorConfig::for_rate(100.0, 1.0, 2.0, 2.0);
    const R_SD: u32 = 1_000;
    let stream = |i: u32| [33000.0 + (i % 7) as f32, 33300.0 - (i % 5) as f32, 36400.0];
    if let Ok(mut det) = StaticDetector::<101>::new(dcfg) {
        let base = rt::time_reps(R_SD, |i| {
            let d = black_box(&mut det);
            (d as *mut StaticDetector<101>, stream(i))
        });
        let Ok(mut det) = StaticDetector::<101>::new(dcfg) else {
            rt::exit(false)
        };
        let op = rt::time_reps(R_SD, |i| black_box(&mut det).push(stream(i)));
        let st = stack_of(|| black_box(&mut det).push(black_box(stream(3))));
        all_ok &= row(
            "static_detect::StaticDetector<101>::push",
            "sample",
            sc.per_op(op, base, R_SD),
            st,
            NONE,
        );
    }
    all_ok
}

/// The gyro's per-sample steps.
fn gyro_rows(sc: Scale) -> bool {
    let mut all_ok = true;
    // --- gyro: the per-sample step of a motion's integration (RK4 on the quaternion), alone
    // (evaluating a calibration) and with the 9 scale/misalignment sensitivities the fit tracks
    let gcal = GyroCalibration::<f32>::nominal([8192.0, 8190.0, 8195.0], [1.2e-3, -1.2e-3, 1.2e-3]);
    let gstream = |i: u32| {
        [
            8192.0 + (i % 97) as f32,
            8190.0 - (i % 89) as f32,
            8195.0 + (i % 53) as f32,
        ]
    };
    const R_GYRO: u32 = 1_000;
    let with_scale: [bool; NPARAM] = core::array::from_fn(|k| k < 9);
    for (label, tracked) in [
        ("gyro::MotionIntegrator::push (RK4 step)", [false; NPARAM]),
        (
            "gyro::MotionIntegrator::push (RK4 + 9 sensitivities)",
            with_scale,
        ),
    ] {
        let Ok(integ0) = MotionIntegrator::new(gcal, Adjustment::identity(), 0.01, tracked) else {
            rt::exit(false)
        };
        let mut integ = integ0.clone();
        let base = rt::time_reps(R_GYRO, |i| {
            let g = black_box(&mut integ);
            (g as *mut MotionIntegrator<f32>, gstream(i))
        });
        let mut integ = integ0.clone();
        let op = rt::time_reps(R_GYRO, |i| black_box(&mut integ).push(&gstream(i)));
        let mut integ = integ0;
        let _ = integ.push(&gstream(0));
        let st = stack_of(|| black_box(&mut integ).push(&black_box(gstream(3))));
        all_ok &= row(label, "sample", sc.per_op(op, base, R_GYRO), st, NONE);
    }
    let zcfg = ZeroRateConfig {
        block: 50,
        max_spread: 200.0f32,
        blend: 0.5,
    };
    if let Ok(tracker0) = ZeroRateTracker::new(zcfg, [8192.0, 8190.0, 8195.0]) {
        let mut tr = tracker0;
        let base = rt::time_reps(R_GYRO, |i| {
            let t = black_box(&mut tr);
            (t as *mut ZeroRateTracker<f32>, gstream(i))
        });
        let mut tr = tracker0;
        let op = rt::time_reps(R_GYRO, |i| black_box(&mut tr).push(gstream(i), true));
        let st = stack_of(|| black_box(&mut tr).push(black_box(gstream(3)), true));
        all_ok &= row(
            "gyro_zero::ZeroRateTracker::push",
            "sample",
            sc.per_op(op, base, R_GYRO),
            st,
            NONE,
        );
    }
    all_ok
}

/// The adaptive detector's noise survey.
fn noise_survey_rows(sc: Scale) -> bool {
    let mut all_ok = true;
    const R_SD: u32 = 1_000;
    let stream = |i: u32| [33000.0 + (i % 7) as f32, 33300.0 - (i % 5) as f32, 36400.0];
    // --- the adaptive detector's noise survey (pass 1 of static_detect::adaptive), 100 Hz:
    // 25-sample blocks, so the per-block histogram update is amortised over 25 pushes.
    if let Ok(mut survey) = NoiseSurvey::for_rate(100.0) {
        let base = rt::time_reps(R_SD, |i| {
            let s = black_box(&mut survey);
            (s as *mut NoiseSurvey, stream(i))
        });
        let Ok(mut survey) = NoiseSurvey::for_rate(100.0) else {
            rt::exit(false)
        };
        let op = rt::time_reps(R_SD, |i| black_box(&mut survey).push(stream(i)));
        let st = stack_of(|| black_box(&mut survey).push(black_box(stream(3))));
        all_ok &= row(
            "static_detect::NoiseSurvey::push (adaptive, 25/block)",
            "sample",
            sc.per_op(op, base, R_SD),
            st,
            NONE,
        );
    }
    all_ok
}

/// The adapter's per-report update and the Wii Remote's read path.
fn adapter_rows(sc: Scale) -> bool {
    let mut all_ok = true;
    // --- the adapter (wiical-adapter): per-report update and the Wii Remote's read
    let Ok(info) = factory_info() else {
        rt::exit(false)
    };
    let mut corrector = Corrector::new(IdealScale::default());
    corrector.set_factory(&info);
    if corrector.set_user_calibration(Some(NUNCHUK_CAL)).is_err() {
        rt::exit(false)
    }
    let mut emu = EmulatedNunchuk::new(&corrector.calibration_block_bytes());
    emu.on_write(&[0xF0, 0x55]);
    emu.on_write(&[0xFB, 0x00]);
    const R_AD: u32 = 2_000;
    let base = rt::time_reps(R_AD, |i| {
        let c = black_box(&corrector);
        let e = black_box(&mut emu);
        (
            c as *const Corrector,
            e as *mut EmulatedNunchuk,
            NUNCHUK_RAWS[i as usize % 6],
        )
    });
    let op = rt::time_reps(R_AD, |i| {
        adapter_report_update(
            black_box(&corrector),
            black_box(&mut emu),
            NUNCHUK_RAWS[i as usize % 6],
            i & 1 == 0,
        )
    });
    let st = stack_of(|| {
        adapter_report_update(
            black_box(&corrector),
            black_box(&mut emu),
            black_box(NUNCHUK_RAWS[1]),
            true,
        )
    });
    all_ok &= row(
        "adapter: report update (Corrector::correct + set_report)",
        "report",
        sc.per_op(op, base, R_AD),
        st,
        NONE,
    );
    for (label, init) in [
        (
            "adapter: Wii Remote read path, plain (ptr + 6 B)",
            &[0xFBu8, 0x00][..],
        ),
        (
            "adapter: Wii Remote read path, encrypted (ptr + 6 B)",
            &[0x40u8, 0x00][..],
        ),
    ] {
        emu.on_write(init);
        let mut buf = [0u8; 6];
        let base = rt::time_reps(R_AD, |_| {
            let e = black_box(&mut emu);
            (e as *mut EmulatedNunchuk, black_box(&mut buf) as *mut _)
        });
        let op = rt::time_reps(R_AD, |_| {
            adapter_wiimote_read(black_box(&mut emu), black_box(&mut buf))
        });
        let st = stack_of(|| adapter_wiimote_read(black_box(&mut emu), black_box(&mut buf)));
        all_ok &= row(
            label,
            "read",
            sc.per_op(op, base, R_AD),
            st,
            Target {
                max_instr: Some(5_000.0),
                max_stack: None,
            },
        );
    }
    all_ok
}

/// Report `k` of a synthetic self-calibration session at 200 Hz (the one of
/// `crates/adapter/tests/self_calibration.rs`, simplified): C + Z held 3.3 s at plug-in, then
/// 14 poses (six half-axes, eight diagonals) held 1.6 s each with 0.7 s moves between them;
/// `m = D·u + b` with a Nunchuk-like `D`, ±0.5 count of deterministic noise, rounded.
/// Returns `None` after the end.
fn session_report(k: usize, rng: &mut XorShift) -> Option<([u16; 3], bool)> {
    const HOLD: usize = 660;
    const STILL: usize = 320;
    const MOVE: usize = 140;
    let s = 0.577_350_26f32;
    let poses: [[f32; 3]; 14] = [
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, 0.0, -1.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [s, s, s],
        [-s, -s, -s],
        [s, -s, s],
        [-s, s, -s],
        [s, s, -s],
        [-s, -s, s],
        [s, -s, -s],
        [-s, s, s],
    ];
    let (up, buttons) = if k < HOLD {
        (poses[0], true)
    } else {
        let j = k - HOLD;
        let (i, t) = (j / (STILL + MOVE), j % (STILL + MOVE));
        let p = *poses.get(i)?;
        if t < STILL {
            (p, false)
        } else {
            let next = poses.get(i + 1).copied().unwrap_or(p);
            let f = (t - STILL) as f32 / MOVE as f32;
            let h = 0.3 * libm::sinf(0.0628 * t as f32);
            let mut d = [0.0f32; 3];
            for a in 0..3 {
                d[a] = p[a] * (1.0 - f) + next[a] * f;
            }
            ([d[0] + 0.2 + h, d[1] - h, d[2] + 0.5 * h], false)
        }
    };
    let dm = [
        [203.0f32, 2.5, -1.0],
        [-3.0, 196.0, 1.5],
        [0.8, -2.2, 207.0],
    ];
    let b = [505.3f32, 497.8, 518.6];
    let raw = core::array::from_fn(|r| {
        let m = dm[r][0] * up[0] + dm[r][1] * up[1] + dm[r][2] * up[2] + b[r];
        libm::roundf(m + 0.5 * rng.next_f32()).clamp(0.0, 1023.0) as u16
    });
    Some((raw, buttons))
}

/// Runs the synthetic session through a fresh [`SelfCal`]; the number of reports it took to
/// produce a calibration to commit (`None` if it never did).
fn run_session(live: &Calibration) -> Option<usize> {
    let mut sc = SelfCal::new(SelfCalConfig::nunchuk(200));
    sc.on_plug_in();
    let mut rng = XorShift::new(14);
    let mut k = 0;
    while let Some((raw, b)) = session_report(k, &mut rng) {
        sc.on_report(raw, b, b, black_box(live));
        k += 1;
        if sc.take_pending().is_some() {
            return Some(k);
        }
    }
    None
}

/// The adapter's self-calibration: per report while collecting, the checks, and the whole
/// session (detector on every report, pose bookkeeping, coverage, fit, acceptance).
fn selfcal_rows(sc_scale: Scale) -> bool {
    let live = wiical_adapter::corrector::nominal_calibration();
    let Some(collecting) = selfcal_collecting_row(sc_scale, live) else {
        return false;
    };
    let Some(checks) = selfcal_check_rows(sc_scale, live) else {
        return false;
    };
    collecting & checks & selfcal_session_row(sc_scale, live)
}

/// `SelfCal::on_report` while collecting; `None` when the session did not start.
fn selfcal_collecting_row(sc_scale: Scale, live: Calibration) -> Option<bool> {
    let mut ok = true;
    // Per report, collecting, on a still stream with small noise (the common case).
    let mut sc = SelfCal::new(SelfCalConfig::nunchuk(200));
    sc.on_plug_in();
    for _ in 0..700 {
        sc.on_report([512, 512, 712], true, true, &live);
    }
    if !sc.active() {
        hprintln!("self-calibration did not start");
        return None;
    }
    let still = |i: u32| [512 + (i % 3) as u16, 511 + (i % 2) as u16, 712];
    const R: u32 = 4_000;
    let base = rt::time_reps(R, |i| {
        let s = black_box(&mut sc);
        (s as *mut SelfCal, still(i))
    });
    let op = rt::time_reps(R, |i| {
        black_box(&mut sc).on_report(still(i), false, false, black_box(&live))
    });
    let st = stack_of(|| black_box(&mut sc).on_report(still(1), false, false, black_box(&live)));
    ok &= row(
        "adapter: SelfCal::on_report, collecting (detector<64>)",
        "report",
        sc_scale.per_op(op, base, R),
        st,
        NONE,
    );
    Some(ok)
}

/// The checks at the end of a session: the 12-pose fit, acceptance, coverage; `None` when
/// the fit fails.
fn selfcal_check_rows(sc_scale: Scale, live: Calibration) -> Option<bool> {
    let mut ok = true;
    // The checks at the end of a session, on a 12-pose set.
    let poses: [[f32; 3]; 12] = core::array::from_fn(|i| {
        let mut rng = XorShift::new(14);
        let mut r = None;
        // Middle of pose i's still segment.
        for k in 0..=(660 + i * 460 + 160) {
            r = session_report(k, &mut rng);
        }
        r.map_or([0.0; 3], |(m, _)| m.map(f32::from))
    });
    let cfg = MultiPosConfig::default();
    const R_FIT: u32 = 4;
    let base = rt::time_reps(R_FIT, |_| black_box(&poses) as *const _);
    let op = rt::time_reps(R_FIT, |_| multipos::fit(black_box(&poses), &cfg));
    let st = stack_of(|| multipos::fit(black_box(&poses), &cfg));
    ok &= row(
        "multipos::fit, 12 poses (self-calibration)",
        "fit",
        sc_scale.per_op(op, base, R_FIT),
        st,
        NONE,
    );
    let Ok(fit) = multipos::fit(&poses, &cfg) else {
        hprintln!("12-pose fit failed");
        return None;
    };
    let acc = Acceptance::nunchuk();
    const R_CHK: u32 = 50;
    let base = rt::time_reps(R_CHK, |_| black_box(&fit.calibration) as *const _);
    let op = rt::time_reps(R_CHK, |_| {
        acc.check(black_box(&fit.calibration), Some(fit.rms))
    });
    let st = stack_of(|| acc.check(black_box(&fit.calibration), Some(fit.rms)));
    ok &= row(
        "quality::Acceptance::check (Nunchuk limits, exact bound)",
        "check",
        sc_scale.per_op(op, base, R_CHK),
        st,
        NONE,
    );
    let dirs: [[f32; 3]; 12] = poses.map(|m| live.correct_linear(m));
    let rule = CoverageRule::default();
    let base = rt::time_reps(R_CHK, |_| black_box(&dirs) as *const _);
    let op = rt::time_reps(R_CHK, |_| rule.check(black_box(&dirs)));
    let st = stack_of(|| rule.check(black_box(&dirs)));
    ok &= row(
        "quality::CoverageRule::check, 12 directions",
        "check",
        sc_scale.per_op(op, base, R_CHK),
        st,
        NONE,
    );
    Some(ok)
}

/// The whole session, once.
fn selfcal_session_row(sc_scale: Scale, live: Calibration) -> bool {
    let mut ok = true;
    let mut done = None;
    let op = rt::time_reps(1, |_| done = run_session(&live));
    let base = rt::time_reps(1, |_| black_box(&live) as *const _);
    let st = stack_of(|| run_session(black_box(&live)));
    ok &= done.is_some();
    ok &= row(
        "adapter: whole self-cal session (reports, fit, checks)",
        "session",
        sc_scale.per_op(op, base, 1),
        st,
        Target {
            max_instr: None,
            max_stack: Some(8 * 1024),
        },
    );
    match done {
        Some(n) => hprintln!("the whole self-calibration session took {} reports", n),
        None => hprintln!("the synthetic self-calibration session did not finish: MISSED"),
    }
    ok
}

//! Instruction counts of the adapter's background recalibration (`wiical_adapter::background`)
//! on the emulated Cortex-M33: a report while collecting, and every report of a whole fit, one
//! slice each, whose worst case must stay far under the 5 ms poll period.
//!
//! The grid is filled with 48 still moments of a Nunchuk-like sensor (bias and scale a few
//! percent off the nominal calibration used as the live one, temperatures 22–31.4 °C so that
//! the temperature slope is fitted too: the largest model), then still reports are fed until
//! the first fit runs to its end. Each report of the fit is timed on its own (SysTick ticks,
//! [`crate::rt`]), so the row is the worst single report, not an average.

use core::hint::black_box;
use cortex_m_semihosting::hprintln;
use wiical_adapter::background::{Background, BackgroundPhase, BackgroundSettings, LiveOrigin};
use wiical_adapter::corrector::nominal_calibration;
use wiical_adapter::{Corrector, IdealScale, SelfCal, SelfCalConfig};

use crate::rt;

/// Instructions per report a 5 ms poll period allows at the RP2350's 150 MHz, taking one
/// instruction per cycle (a floor for the M33: many take more, so the margin is wider).
const POLL_BUDGET: f64 = 750_000.0;

/// A unit direction spread over the sphere (Fibonacci lattice, `n` points).
fn direction(i: u32, n: u32) -> [f32; 3] {
    let z = 1.0 - (2.0 * i as f32 + 1.0) / n as f32;
    let r = libm::sqrtf((1.0 - z * z).max(0.0));
    let phi = i as f32 * 2.399_963;
    [r * libm::cosf(phi), r * libm::sinf(phi), z]
}

/// One row of the QEMU benchmark table (the per-5-ms-poll budget verdict); the MotionPlus bench
/// prints its rows with it too.
pub(crate) fn print_row(name: &str, unit: &str, instr: f64, stack: Option<usize>, ok: bool) {
    let verdict = if ok {
        "<= 750000 instr (5 ms at 150 MHz): met"
    } else {
        "<= 750000 instr (5 ms at 150 MHz): MISSED"
    };
    match stack {
        Some(s) => hprintln!(
            "| {:<58} | {:<10} | {:>12.0} | {:>10} | {} |",
            name,
            unit,
            instr,
            s,
            verdict
        ),
        None => hprintln!(
            "| {:<58} | {:<10} | {:>12.0} | {:>10} | {} |",
            name,
            unit,
            instr,
            "> 64 KiB",
            verdict
        ),
    }
}

/// A machine with 48 moments binned, just before its first fit is due.
fn filled() -> (Background, wiical_core::Calibration) {
    let live = nominal_calibration();
    let mut bg = Background::new(BackgroundSettings::nunchuk(200), LiveOrigin::SelfCal);
    let bias = [508.0, 517.0, 505.0];
    let sens = [204.0, 197.0, 201.0];
    for i in 0..48 {
        let d = direction(i, 48);
        let t = 22.0 + 0.2 * i as f32;
        let m = core::array::from_fn(|a| bias[a] + 0.3 * (t - 22.0) + sens[a] * d[a]);
        bg.on_still_moment(m, Some(t), &live);
    }
    (bg, live)
}

/// Still input around the sensor's "z up" reading.
fn still(i: u32) -> [u16; 3] {
    [508 + (i % 3) as u16, 517 + (i % 2) as u16, 706]
}

/// The rows; returns whether every target was met. `per_tick`: instructions per SysTick tick.
pub fn rows(per_tick: f64) -> bool {
    let (mut bg, live) = filled();
    // A report while collecting (detector, no fit due).
    const R: u32 = 2_000;
    let base = rt::time_reps(R, |i| (black_box(&mut bg) as *mut Background, still(i)));
    let op = rt::time_reps(R, |i| {
        black_box(&mut bg).on_report(still(i), Some(25.0), black_box(&live))
    });
    let per = op.saturating_sub(base) as f64 * per_tick / f64::from(R);
    rt::systick_enabled(false);
    let st = rt::peak_stack(|| black_box(&mut bg).on_report(still(1), Some(25.0), &live));
    rt::systick_enabled(true);
    let mut ok = per <= POLL_BUDGET;
    print_row("background: on_report, collecting", "report", per, st, ok);
    // Until the first fit starts (60 s of play).
    let mut i = 0u32;
    while bg.status().phase != BackgroundPhase::Fitting && i < 20_000 {
        bg.on_report(still(i), Some(25.0), &live);
        i += 1;
    }
    if bg.status().phase != BackgroundPhase::Fitting {
        hprintln!("background: no fit started: MISSED");
        return false;
    }
    let mut stack_probe = bg.clone();
    let (mut worst, mut worst_at, mut slices) = (0u64, 0u32, 0u32);
    while bg.status().phase == BackgroundPhase::Fitting && slices < 1_000 {
        let t0 = rt::ticks();
        black_box(&mut bg).on_report(still(i), Some(25.0), black_box(&live));
        let dt = rt::ticks() - t0;
        if dt > worst {
            (worst, worst_at) = (dt, slices);
        }
        slices += 1;
        i += 1;
    }
    let worst_instr = worst as f64 * per_tick;
    rt::systick_enabled(false);
    let st = rt::peak_stack(|| {
        while stack_probe.status().phase == BackgroundPhase::Fitting {
            stack_probe.on_report(still(0), Some(25.0), &live);
        }
    });
    rt::systick_enabled(true);
    let fit_ok = worst_instr <= POLL_BUDGET;
    ok &= fit_ok;
    print_row(
        "background: worst report of a fit (one slice, 12 params)",
        "report",
        worst_instr,
        st,
        fit_ok,
    );
    let st = bg.status();
    hprintln!(
        "background: the fit took {} reports (slices), the worst was slice {}; model {:?}, \
         temperature slope {:?}, bins (training, held out) {:?}; ended {:?}, refusal {:?}",
        slices,
        worst_at,
        st.last_candidate.map(|c| c.model),
        st.last_candidate.map(|c| c.temperature),
        st.last_candidate.map(|c| c.bins),
        st.phase,
        st.last_refusal.map(|r| r.summary())
    );
    ok
}

/// The adapter's whole per-report path as `Protocol::on_report` runs it, without the emulated
/// register map and the stream: the self-calibration's report (its stillness feed, the one
/// detector), the background machine's tick with the moment that feed found, and the
/// correction. The grid is the one of [`filled`]; still reports are fed until the first fit
/// has run to its end, and the worst single report is the row (the Nunchuk task's work per
/// poll besides the I²C transfer and the emulated map's update).
pub fn report_path_rows(per_tick: f64) -> bool {
    let (mut bg, live) = filled();
    let mut selfcal = SelfCal::new(SelfCalConfig::nunchuk(200));
    let mut corrector = Corrector::new(IdealScale::default());
    if corrector.set_user_calibration(Some(live)).is_err() {
        return false;
    }
    let (mut worst, mut reports, mut fitting) = (0u64, 0u32, 0u32);
    let mut probe = None;
    let mut i = 0u32;
    // Until the first fit has started and ended (60 s of play, then its slices).
    while i < 20_000 {
        if probe.is_none() && bg.status().phase == BackgroundPhase::Fitting {
            probe = Some((bg.clone(), selfcal.clone(), i));
        }
        let t0 = rt::ticks();
        report_path(
            &mut selfcal,
            black_box(&mut bg),
            &corrector,
            &live,
            still(i),
        );
        let dt = rt::ticks() - t0;
        worst = worst.max(dt);
        reports += 1;
        i += 1;
        if bg.status().phase == BackgroundPhase::Fitting {
            fitting += 1;
        } else if fitting > 0 {
            break;
        }
    }
    // Peak stack over the same fit's reports, replayed from where it started.
    rt::systick_enabled(false);
    let st = probe.and_then(|(mut bg, mut sc, mut j)| {
        rt::peak_stack(|| {
            while bg.status().phase == BackgroundPhase::Fitting {
                report_path(&mut sc, &mut bg, &corrector, &live, still(j));
                j += 1;
            }
        })
    });
    rt::systick_enabled(true);
    let worst_instr = worst as f64 * per_tick;
    let ok = fitting > 0 && worst_instr <= POLL_BUDGET;
    print_row(
        "adapter report path (self-cal feed + background + correct), worst",
        "report",
        worst_instr,
        st,
        ok,
    );
    hprintln!(
        "adapter report path: {} reports timed, {} of them fitting; moments binned {}",
        reports,
        fitting,
        bg.status().moments
    );
    ok
}

/// One report as `Protocol::on_report` handles it (see [`report_path_rows`]).
#[inline(never)]
fn report_path(
    selfcal: &mut SelfCal,
    bg: &mut Background,
    corrector: &Corrector,
    live: &wiical_core::Calibration,
    raw: [u16; 3],
) -> [u16; 3] {
    selfcal.on_report(raw, false, false, live);
    let moment = selfcal.take_still_moment();
    bg.on_tick(moment, Some(25.0), live);
    black_box(corrector.correct(raw)).counts
}

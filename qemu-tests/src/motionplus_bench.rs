//! Instruction counts of the adapter's work per MotionPlus report on the emulated Cortex-M33:
//! the 6 bytes polled from the real MotionPlus decoded (`Frame::decode`), then
//! `EmulatedMotionPlus::on_frame` (the fast range mapped onto the slow scale, the gyro
//! calibration applied, the zero-rate tracker fed, the corrected rates re-encoded with their
//! range bits and written into the register map the Wii Remote reads).
//!
//! The reports are a still stretch (the tracker's blocks of 100 end in bias updates, which
//! correct the sample a second time: the most expensive report), slow turns, and fast turns
//! beyond the slow range; each report is timed on its own (SysTick ticks, [`crate::rt`]), so the
//! worst row is the worst single report, not an average. The budget is the Wii Remote's poll
//! period (5 ms) at the RP2350's 150 MHz, one instruction per cycle as a floor (the RP2040's
//! cycles are measured in rp2040js by the emulator's `motionplus-turns` scenario).

use core::hint::black_box;
use cortex_m_semihosting::hprintln;
use wiical_adapter::motionplus::{EmulatedMotionPlus, GyroCorrector, IdealGyroScale, Tracking};
use wiical_adapter::{Corrector, IdealScale};
use wiical_core::gyro_correct::GyroCorrection;
use wiical_extbus::{Frame, MotionPlusReport, PassthroughMode};

use crate::background_bench::print_row;
use crate::rt;

/// Instructions per report a 5 ms poll period allows at 150 MHz (see the module docs).
const POLL_BUDGET: f64 = 750_000.0;
/// Reports timed: 20 tracker blocks of still input, then turns.
const REPORTS: u32 = 4_000;
/// The nominal slow scale, counts per °/s (hid-wiimote's 8192/440, docs/gyro.md).
const SLOW_CPD: f32 = 8192.0 / 440.0;

/// A calibration a few percent off nominal with some misalignment and a bias, in slow counts
/// along the count axes (the units `GyroCorrector` takes).
fn calibration() -> GyroCorrection<f32> {
    let k = core::f32::consts::PI / 180.0 / SLOW_CPD;
    GyroCorrection {
        bias: [8201.5, 8180.25, 8195.0],
        matrix: [
            [1.03 * k, 2e-3 * k, -1e-3 * k],
            [-1.5e-3 * k, 0.97 * k, 3e-3 * k],
            [0.5e-3 * k, -2e-3 * k, 1.05 * k],
        ],
        effects: Default::default(),
    }
}

/// Report `i`: still (with one count of dither) for the first half, then slow turns, then
/// every fourth report a fast turn with its range bits cleared.
fn report_bytes(i: u32) -> [u8; 6] {
    let d = (i % 3) as u16;
    let r = if i < REPORTS / 2 {
        MotionPlusReport {
            rate: [8201 + d, 8180 + d, 8195 - d],
            slow: [true; 3],
            extension_connected: false,
        }
    } else if i.is_multiple_of(4) {
        MotionPlusReport {
            rate: [14_000 - 7 * d, 2_500 + 11 * d, 9_000],
            slow: [false; 3],
            extension_connected: false,
        }
    } else {
        MotionPlusReport {
            rate: [9_500 + 5 * d, 7_000 - 3 * d, 8_400],
            slow: [true; 3],
            extension_connected: false,
        }
    };
    r.to_bytes().unwrap_or([0; 6])
}

/// The firmware's work for one polled report.
#[inline(never)]
fn on_report(emu: &mut EmulatedMotionPlus, nunchuk: &Corrector, bytes: &[u8; 6]) -> bool {
    match Frame::decode(bytes, PassthroughMode::None) {
        Ok(frame) => emu.on_frame(&frame, nunchuk, true).is_some(),
        Err(_) => false,
    }
}

/// The rows; returns whether the budget was met and the tracker moved the bias (the worst
/// case was exercised). `per_tick`: instructions per SysTick tick.
pub fn rows(per_tick: f64) -> bool {
    let mut gyro = GyroCorrector::new(IdealGyroScale::default(), Some(Tracking::default()));
    if gyro.set_calibration(Some(calibration())).is_err() {
        hprintln!("motionplus: calibration refused: MISSED");
        return false;
    }
    let mut emu = EmulatedMotionPlus::new(gyro);
    let nunchuk = Corrector::new(IdealScale::default());
    let bytes: [[u8; 6]; 8] = core::array::from_fn(|i| report_bytes(i as u32));
    let (mut worst, mut total, mut served) = (0u64, 0u64, 0u32);
    for i in 0..REPORTS {
        let b = report_bytes(i);
        let t0 = rt::ticks();
        served += u32::from(on_report(black_box(&mut emu), &nunchuk, black_box(&b)));
        let dt = rt::ticks() - t0;
        worst = worst.max(dt);
        total += dt;
    }
    let updates = emu.gyro().bias_updates();
    // Each timing includes one `rt::ticks` read (a few instructions): an upper bound.
    let mean = total as f64 * per_tick / f64::from(REPORTS);
    let worst_instr = worst as f64 * per_tick;
    rt::systick_enabled(false);
    let st = rt::peak_stack(|| on_report(&mut emu, &nunchuk, &bytes[0]));
    rt::systick_enabled(true);
    let ok = worst_instr <= POLL_BUDGET && updates > 0 && served == REPORTS;
    print_row(
        "MotionPlus report: decode, correct, track, encode (mean)",
        "report",
        mean,
        st,
        ok,
    );
    print_row(
        "MotionPlus report: worst single report",
        "report",
        worst_instr,
        st,
        ok,
    );
    hprintln!(
        "motionplus: {} reports served, {} tracker bias updates",
        served,
        updates
    );
    ok
}

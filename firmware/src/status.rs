//! Adapter status shared without locks (written by the extension task after every poll), and
//! the status-LED task.

use core::sync::atomic::{AtomicBool, AtomicU32, AtomicU8, Ordering};

use embassy_rp::gpio::Output;
use embassy_time::Timer;
use wiical_adapter::{CorrectionMode, SelfCalStatus, Status};

const CONNECTED: u8 = 1 << 0;
const CALIBRATED: u8 = 1 << 1;
const STREAMING: u8 = 1 << 2;

static FLAGS: AtomicU8 = AtomicU8::new(0);
static BLOCK_GENERATION: AtomicU32 = AtomicU32::new(0);
/// Self-calibration phase, see [`phase_code`]; 0 = not in the mode.
static SELFCAL: AtomicU8 = AtomicU8::new(0);
/// The stale monitor suggests recalibrating. (Separate flags rather than read-modify-write
/// bits: the RP2040's Cortex-M0+ has no atomic RMW instructions.)
static RECALIBRATE: AtomicBool = AtomicBool::new(false);

/// Small code per self-calibration status, for the LED (0 = off).
fn phase_code(s: &SelfCalStatus) -> u8 {
    match s {
        SelfCalStatus::Off => 0,
        SelfCalStatus::Arming => 1,
        SelfCalStatus::WaitingForStillness { .. } => 2,
        SelfCalStatus::PoseTaken { .. } => 3,
        SelfCalStatus::MoveToNewOrientation { .. } => 4,
        SelfCalStatus::Committing | SelfCalStatus::Done => 5,
        SelfCalStatus::Failed(_) => 6,
    }
}

/// Publishes the self-calibration status and the stale monitor's suggestion (called by the
/// extension task after every poll).
pub fn publish_selfcal(s: &SelfCalStatus, recalibration_suggested: bool) {
    SELFCAL.store(phase_code(s), Ordering::Relaxed);
    RECALIBRATE.store(recalibration_suggested, Ordering::Relaxed);
}

/// Publishes the adapter's state (called by the extension task); `detect` is the
/// extension-detect line's level (`Protocol::extension_detect`).
pub fn publish(st: &Status, block_generation: u32, detect: bool) {
    let mut f = 0;
    if detect {
        f |= CONNECTED;
    }
    if st.mode == CorrectionMode::Calibrated {
        f |= CALIBRATED;
    }
    if st.streaming {
        f |= STREAMING;
    }
    FLAGS.store(f, Ordering::Relaxed);
    BLOCK_GENERATION.store(block_generation, Ordering::Relaxed);
}

/// The extension-detect line should be high: a Nunchuk connected and answering, or a
/// MotionPlus connected and activated by the Wii Remote.
pub fn connected() -> bool {
    FLAGS.load(Ordering::Relaxed) & CONNECTED != 0
}

/// Generation of the emulated calibration block (changes when the Wii Remote must re-read it).
pub fn block_generation() -> u32 {
    BLOCK_GENERATION.load(Ordering::Relaxed)
}

/// Which of 10 slots of 100 ms (one second) the LED is lit in. The self-calibration's
/// guidance wins over everything else (see `firmware/README.md`).
fn pattern(flags: u8, selfcal: u8, recalibrate: bool) -> u16 {
    match selfcal {
        1 => return 0b11_0011_0011, // arming: C + Z held after plug-in
        2 => return 0b00_0000_0101, // double flash: hold still in a new orientation
        3 => return 0b11_1111_1111, // steady: pose taken
        4 => return 0b01_0101_0101, // 5 Hz: orientation already taken, move on
        5 => return 0b11_1111_1110, // long on: done, calibration stored
        6 => return 0b00_0111_0111, // two long flashes: failed, old calibration kept
        _ => {}
    }
    if flags & STREAMING != 0 {
        0b01_0101_0101 // 5 Hz blink: streaming to the host
    } else if flags & CONNECTED == 0 {
        0b00_0000_0001 // short flash each second: no Nunchuk
    } else if flags & CALIBRATED == 0 {
        0b00_0001_1111 // 1 Hz, 50 %: Nunchuk, uncalibrated (pass-through)
    } else if recalibrate {
        0b11_1101_1011 // steady with two gaps: calibrated, but still moments read ≠ 1 g
    } else {
        0b11_1111_1111 // steady: Nunchuk, calibrated
    }
}

/// Drives the status LED: see [`pattern`].
#[embassy_executor::task]
pub async fn led_task(mut led: Output<'static>) -> ! {
    let mut slot = 0u16;
    loop {
        let lit = pattern(
            FLAGS.load(Ordering::Relaxed),
            SELFCAL.load(Ordering::Relaxed),
            RECALIBRATE.load(Ordering::Relaxed),
        );
        let on = lit & (1 << slot) != 0;
        led.set_level(on.into());
        slot = (slot + 1) % 10;
        Timer::after_millis(100).await;
    }
}

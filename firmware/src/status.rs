//! Adapter status shared without locks (written by the Nunchuk task after every poll), and
//! the status-LED task.

use core::sync::atomic::{AtomicU32, AtomicU8, Ordering};

use embassy_rp::gpio::Output;
use embassy_time::Timer;
use wiical_adapter::{CorrectionMode, Status};

const CONNECTED: u8 = 1 << 0;
const CALIBRATED: u8 = 1 << 1;
const STREAMING: u8 = 1 << 2;

static FLAGS: AtomicU8 = AtomicU8::new(0);
static BLOCK_GENERATION: AtomicU32 = AtomicU32::new(0);

/// Publishes the adapter's state (called by the Nunchuk task).
pub fn publish(st: &Status, block_generation: u32) {
    let mut f = 0;
    if st.connected {
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

/// A Nunchuk is connected and answering.
pub fn connected() -> bool {
    FLAGS.load(Ordering::Relaxed) & CONNECTED != 0
}

/// Generation of the emulated calibration block (changes when the Wii Remote must re-read it).
pub fn block_generation() -> u32 {
    BLOCK_GENERATION.load(Ordering::Relaxed)
}

/// Which of 10 slots of 100 ms (one second) the LED is lit in.
fn pattern(flags: u8) -> u16 {
    if flags & STREAMING != 0 {
        0b01_0101_0101 // 5 Hz blink: streaming to the host
    } else if flags & CONNECTED == 0 {
        0b00_0000_0001 // short flash each second: no Nunchuk
    } else if flags & CALIBRATED == 0 {
        0b00_0001_1111 // 1 Hz, 50 %: Nunchuk, uncalibrated (pass-through)
    } else {
        0b11_1111_1111 // steady: Nunchuk, calibrated
    }
}

/// Drives the status LED: see [`pattern`].
#[embassy_executor::task]
pub async fn led_task(mut led: Output<'static>) -> ! {
    let mut slot = 0u16;
    loop {
        let on = pattern(FLAGS.load(Ordering::Relaxed)) & (1 << slot) != 0;
        led.set_level(on.into());
        slot = (slot + 1) % 10;
        Timer::after_millis(100).await;
    }
}

//! The Wii Remote side: I²C1 target at `0x52` serving the emulated Nunchuk register map,
//! and the extension-detect line.

use defmt::warn;
use embassy_rp::gpio::Output;
use embassy_rp::i2c_slave::{Command, I2cSlave, ReadStatus};
use embassy_rp::peripherals::I2C1;
use embassy_time::Timer;

use crate::{status, Adapter};

/// Bytes handed to the I²C FIFO per lock of the adapter: one whole report, so that the Wii
/// Remote never reads half of an old and half of a new report.
const READ_CHUNK: usize = 6;

/// Answers the Wii Remote: writes go to the register map (pointer, init, key), reads are
/// served from it in [`READ_CHUNK`]-byte pieces for as long as the Wii Remote clocks.
#[embassy_executor::task]
pub async fn wiimote_task(mut dev: I2cSlave<'static, I2C1>, adapter: &'static Adapter) -> ! {
    let mut rx = [0u8; 64];
    loop {
        match dev.listen(&mut rx).await {
            Ok(Command::Write(n)) => adapter.lock().await.emulated().on_write(&rx[..n]),
            Ok(Command::WriteRead(n)) => {
                // A repeated start (a real Nunchuk needs a stop, but tolerate it).
                adapter.lock().await.emulated().on_write(&rx[..n]);
                respond(&mut dev, adapter).await;
            }
            Ok(Command::Read) => respond(&mut dev, adapter).await,
            Ok(Command::GeneralCall(_)) => {}
            Err(e) => warn!("Wii Remote bus: {}", e),
        }
    }
}

/// Serves one read of the Wii Remote in [`READ_CHUNK`]-byte pieces.
///
/// A read that ends inside a piece (the 16-byte calibration block is 6 + 6 + 4 of 6) leaves
/// bytes in the TX FIFO; the I²C block flushes them when the next read is addressed and
/// reports it as an abort (`LeftoverBytes`) before anything of the new read was sent. The
/// piece taken for the new read is then sent again rather than dropped: dropping it would
/// advance the register pointer by a report the Wii Remote never got and serve it bytes
/// 6..12 (zeros) as the report (found by the emulator, `cargo xtask emulate`).
async fn respond(dev: &mut I2cSlave<'static, I2C1>, adapter: &'static Adapter) {
    let mut chunk = [0u8; READ_CHUNK];
    adapter.lock().await.emulated().on_read(&mut chunk);
    let mut sent_any = false;
    loop {
        match dev.respond_to_read(&chunk).await {
            Ok(ReadStatus::NeedMoreBytes) => {
                sent_any = true;
                adapter.lock().await.emulated().on_read(&mut chunk);
            }
            Ok(ReadStatus::LeftoverBytes(_)) if !sent_any => {
                // Stale bytes of the previous read were flushed; send this piece again.
                sent_any = true;
            }
            Ok(ReadStatus::Done | ReadStatus::LeftoverBytes(_)) => break,
            Err(e) => {
                warn!("Wii Remote read: {}", e);
                break;
            }
        }
    }
}

/// Drives the extension-detect line: high while a Nunchuk is connected. When the emulated
/// calibration block changes (a commit, or a different Nunchuk), the line drops for 100 ms
/// so that the Wii Remote re-initialises the extension and re-reads the block.
#[embassy_executor::task]
pub async fn ext_detect_task(mut detect: Output<'static>) -> ! {
    let mut generation = status::block_generation();
    loop {
        let connected = status::connected();
        let g = status::block_generation();
        if connected && g != generation && detect.is_set_high() {
            detect.set_low();
            Timer::after_millis(100).await;
        }
        generation = g;
        detect.set_level(connected.into());
        Timer::after_millis(20).await;
    }
}

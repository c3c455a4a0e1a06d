//! The Wii Remote side: I²C1 target serving the emulated extension's register map (a Nunchuk
//! at `0x52`; a MotionPlus at `0x53` while inactive and `0x52` once activated), and the
//! extension-detect line.

use defmt::warn;
#[cfg(feature = "motionplus")]
use embassy_futures::select::{select, Either};
use embassy_rp::gpio::Output;
use embassy_rp::i2c_slave::{Command, I2cSlave, ReadStatus};
use embassy_rp::peripherals::I2C1;
use embassy_time::Timer;

use wiical_adapter::Protocol;

use crate::board::StoreFlash;
use crate::shared::Adapter;
#[cfg(feature = "motionplus")]
use crate::shared::ADDRESS_CHANGED;
use crate::status;

/// Bytes handed to the I²C FIFO per lock of the adapter: one whole report, so that the Wii
/// Remote never reads half of an old and half of a new report.
const READ_CHUNK: usize = 6;

/// Answers the Wii Remote: writes go to the register map (pointer, init, key, the
/// MotionPlus's activation), reads are served from it in [`READ_CHUNK`]-byte pieces for as
/// long as the Wii Remote clocks. Before each transaction is awaited, the target address is
/// set to the one the adapter logic answers at now ([`set_address`]).
#[embassy_executor::task]
pub async fn wiimote_task(mut dev: I2cSlave<'static, I2C1>, adapter: &'static Adapter) -> ! {
    let mut rx = [0u8; 64];
    #[cfg(feature = "motionplus")]
    let mut address = wiical_extbus::nunchuk::I2C_ADDRESS;
    loop {
        #[cfg(feature = "motionplus")]
        let command = {
            let wanted = adapter.lock().await.target_address();
            if wanted != address {
                set_address(wanted);
                address = wanted;
            }
            // Woken also when the extension changes (another address, while the Wii Remote
            // is silent): dropping `listen` between transactions loses nothing.
            match select(dev.listen(&mut rx), ADDRESS_CHANGED.wait()).await {
                Either::First(c) => c,
                Either::Second(()) => continue,
            }
        };
        #[cfg(not(feature = "motionplus"))]
        let command = dev.listen(&mut rx).await;
        match command {
            Ok(Command::Write(n)) => write(&mut *adapter.lock().await, &rx[..n]),
            Ok(Command::WriteRead(n)) => {
                // A repeated start (a real Nunchuk needs a stop, but tolerate it).
                write(&mut *adapter.lock().await, &rx[..n]);
                serve_reads(&mut dev, adapter).await;
            }
            Ok(Command::Read) => serve_reads(&mut dev, adapter).await,
            Ok(Command::GeneralCall(_)) => {}
            Err(e) => warn!("Wii Remote bus: {}", e),
        }
    }
}

/// The Wii Remote's write to the extension presented (a MotionPlus or a Nunchuk).
#[cfg(feature = "motionplus")]
fn write(a: &mut Protocol<StoreFlash>, bytes: &[u8]) {
    a.target_write(bytes);
}

/// The Wii Remote's write to the emulated Nunchuk.
#[cfg(not(feature = "motionplus"))]
fn write(a: &mut Protocol<StoreFlash>, bytes: &[u8]) {
    a.emulated().on_write(bytes);
}

/// The Wii Remote's read of the extension presented (a MotionPlus or a Nunchuk).
#[cfg(feature = "motionplus")]
fn read(a: &mut Protocol<StoreFlash>, buf: &mut [u8]) {
    a.target_read(buf);
}

/// The Wii Remote's read of the emulated Nunchuk.
#[cfg(not(feature = "motionplus"))]
fn read(a: &mut Protocol<StoreFlash>, buf: &mut [u8]) {
    a.emulated().on_read(buf);
}

/// Moves the I²C1 target to another 7-bit address. The DW_apb_i2c block takes a new
/// `IC_SAR` only while disabled (RP2040 datasheet 4.3.10.3, RP2350 12.2): disable, wait for
/// `IC_ENABLE_STATUS.IC_EN` to clear, write, enable. embassy-rp's `I2cSlave` keeps its address
/// in a private config written only by `new`/`reset` (embassy-rp 0.10), so the register is
/// written here, between transactions (the interrupt mask and FIFO thresholds the driver set
/// are kept by the block across a disable).
#[cfg(feature = "motionplus")]
fn set_address(address: u8) {
    let i2c = embassy_rp::pac::I2C1;
    i2c.ic_enable().write(|w| w.set_enable(false));
    while i2c.ic_enable_status().read().ic_en() {}
    i2c.ic_sar().write(|w| w.set_ic_sar(u16::from(address)));
    i2c.ic_enable().write(|w| w.set_enable(true));
}

/// How a read of the Wii Remote ended.
#[derive(PartialEq, Eq)]
enum ReadEnd {
    /// The Wii Remote stopped clocking; the next transaction is for `listen`.
    Finished,
    /// The read ended inside a piece and this task saw its end only once the Wii Remote had
    /// addressed the next read (the I²C block flushed the piece's rest then, `LeftoverBytes`
    /// after bytes were sent). That read waits now, the clock held; a write between the two
    /// (the register pointer) is still in the RX FIFO, its STOP_DET and the new read's RD_REQ
    /// cleared by the driver (`IC_CLR_INTR`).
    Overtaken,
}

/// Serves one read of the Wii Remote, and the next ones as long as each was overtaken by
/// the next (see [`ReadEnd::Overtaken`]).
///
/// An overtaken read happens when this task runs late (the poll task's correction, the
/// adapter's mutex): the Wii Remote reads the 16-byte calibration block (6 + 6 + 4 of 6),
/// writes the pointer 0x00 and addresses the first report read before this task sees the
/// block read's end. `listen` would then see the new read's RD_REQ without the write's
/// STOP_DET and drop the pointer byte, and the report would be served from 0x32 (bytes 2..7
/// of the block; found by the emulator, `cargo xtask emulate commit-analyzed-cal`). So the
/// pending write is applied from the RX FIFO first, then the waiting read is served.
async fn serve_reads(dev: &mut I2cSlave<'static, I2C1>, adapter: &'static Adapter) {
    while respond(dev, adapter).await == ReadEnd::Overtaken {
        let i2c = embassy_rp::pac::I2C1;
        let mut guard = adapter.lock().await;
        // The bus is held for the waiting read: nothing more arrives while this drains.
        let received = core::iter::from_fn(|| {
            i2c.ic_status().read().rfne().then(|| {
                let entry = i2c.ic_data_cmd().read();
                (entry.dat(), entry.first_data_byte())
            })
        });
        #[cfg(feature = "motionplus")]
        guard.target_received(received);
        #[cfg(not(feature = "motionplus"))]
        guard.emulated().on_received(received);
    }
}

/// Serves one read of the Wii Remote in [`READ_CHUNK`]-byte pieces.
///
/// A read that ends inside a piece (the 16-byte calibration block is 6 + 6 + 4 of 6) leaves
/// bytes in the TX FIFO; the I²C block flushes them when the next read is addressed and
/// reports it as an abort (`LeftoverBytes`). Before anything of this read was sent, that is
/// the previous read's rest: the piece taken for this read is then sent again rather than
/// dropped: dropping it would advance the register pointer by a report the Wii Remote never
/// got and serve it bytes 6..12 (zeros) as the report (found by the emulator, `cargo xtask
/// emulate`). After bytes were sent, it is this read's rest: [`ReadEnd::Overtaken`].
async fn respond(dev: &mut I2cSlave<'static, I2C1>, adapter: &'static Adapter) -> ReadEnd {
    let mut chunk = [0u8; READ_CHUNK];
    read(&mut *adapter.lock().await, &mut chunk);
    let mut sent_any = false;
    loop {
        match dev.respond_to_read(&chunk).await {
            Ok(ReadStatus::NeedMoreBytes) => {
                sent_any = true;
                read(&mut *adapter.lock().await, &mut chunk);
            }
            Ok(ReadStatus::LeftoverBytes(_)) if !sent_any => {
                // Stale bytes of the previous read were flushed; send this piece again.
                sent_any = true;
            }
            Ok(ReadStatus::LeftoverBytes(_)) => return ReadEnd::Overtaken,
            Ok(ReadStatus::Done) => return ReadEnd::Finished,
            Err(e) => {
                warn!("Wii Remote read: {}", e);
                return ReadEnd::Finished;
            }
        }
    }
}

/// Drives the extension-detect line: high while a Nunchuk is connected, or a MotionPlus is
/// connected and activated. When the emulated
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

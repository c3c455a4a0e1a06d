//! The extension side: I²C0 controller polling a Nunchuk or a MotionPlus at [`POLL_HZ`].

use defmt::{info, warn};
use embassy_rp::i2c::{Async, I2c};
use embassy_rp::peripherals::I2C0;
use embassy_time::{Delay, Duration, Instant, Ticker};
use wiical_adapter::{CorrectionMode, ExtensionEvent, MotionPlusEvent, PollEvent, Protocol};

use crate::board::{StoreFlash, POLL_HZ};
use crate::shared::{Adapter, Streamed, SAMPLES};
use crate::status;

/// The controller side's poller: a MotionPlus (then a Nunchuk) with the `motionplus` feature
/// (both chips'), else a Nunchuk.
#[cfg(feature = "motionplus")]
type Poller = wiical_adapter::ExtensionPoller;
/// The controller side's poller: a Nunchuk (without the `motionplus` feature).
#[cfg(not(feature = "motionplus"))]
type Poller = wiical_adapter::NunchukPoller;

/// One poll of whichever extension is connected, or a search for one.
#[cfg(feature = "motionplus")]
async fn poll(p: &mut Poller, bus: &mut Bus) -> ExtensionEvent<embassy_rp::i2c::Error> {
    p.poll(bus, &mut Delay, Instant::now().as_millis()).await
}

/// One poll of the Nunchuk.
#[cfg(not(feature = "motionplus"))]
async fn poll(p: &mut Poller, bus: &mut Bus) -> ExtensionEvent<embassy_rp::i2c::Error> {
    ExtensionEvent::Nunchuk(p.poll(bus, &mut Delay, Instant::now().as_millis()).await)
}

type Bus = I2c<'static, I2C0, Async>;

/// Feeds one poll to the adapter logic; with the MotionPlus path, wakes the Wii Remote task
/// when the address it must answer at changed (another extension connected), and hands the
/// poller the mode the Wii Remote activated the emulated MotionPlus in (the real one follows
/// it on the next poll: Nunchuk pass-through or alone). The stream's sample is a Nunchuk
/// report's or a MotionPlus gyro frame's (protocol 8's `GyroSample`), never both in one poll.
#[cfg(feature = "motionplus")]
fn feed<E>(
    a: &mut Protocol<StoreFlash>,
    event: &ExtensionEvent<E>,
    poller: &mut Poller,
) -> Option<Streamed> {
    let address = a.target_address();
    let sample = a.on_extension_poll(event, poller);
    if a.target_address() != address {
        crate::shared::ADDRESS_CHANGED.signal(());
    }
    if let Some(mode) = a.motionplus_mode() {
        poller.motionplus.set_mode(mode);
    }
    match sample {
        Some(s) => Some(Streamed::Sample(s)),
        None => a.take_gyro_sample().map(Streamed::Gyro),
    }
}

/// The extension-detect line's level: a Nunchuk connected, or a MotionPlus connected and
/// activated.
#[cfg(feature = "motionplus")]
fn detect(a: &Protocol<StoreFlash>) -> bool {
    a.extension_detect()
}

/// The extension-detect line's level: a Nunchuk connected.
#[cfg(not(feature = "motionplus"))]
fn detect(a: &Protocol<StoreFlash>) -> bool {
    a.status().connected
}

/// Feeds one poll to the adapter logic (a Nunchuk's: no MotionPlus is looked for).
#[cfg(not(feature = "motionplus"))]
fn feed<E>(
    a: &mut Protocol<StoreFlash>,
    event: &ExtensionEvent<E>,
    poller: &mut Poller,
) -> Option<Streamed> {
    match event {
        ExtensionEvent::Nunchuk(r) => a.on_poll(r, poller.is_connected()).map(Streamed::Sample),
        ExtensionEvent::MotionPlus(_) => None,
    }
}

/// Polls the extension (the poller looks for a MotionPlus, then a Nunchuk, and re-initialises
/// after an unplug, with back-off), feeds every result to the adapter logic (correction →
/// emulated register map, stream sample, self-calibration from the Nunchuk's buttons, stale
/// monitor, one slice of the background recalibration), lets it commit a finished
/// self-calibration or a background adoption (`service`: a flash write, during which this
/// task holds the adapter, as a host commit does), and publishes the status.
#[embassy_executor::task]
pub async fn extension_task(mut bus: Bus, adapter: &'static Adapter) -> ! {
    let mut poller = Poller::default();
    let mut ticker = Ticker::every(Duration::from_hz(u64::from(POLL_HZ)));
    let mut was_connected = false;
    let mut dropped: u32 = 0;
    loop {
        ticker.next().await;
        let event = poll(&mut poller, &mut bus).await;
        let (sample, st, generation, detect, selfcal, stale) = {
            let mut a = adapter.lock().await;
            let sample = feed(&mut a, &event, &mut poller);
            a.service().await;
            let sc = a.selfcal();
            (
                sample,
                a.status(),
                a.block_generation(),
                detect(&a),
                sc.status(),
                sc.stale(),
            )
        };
        status::publish(&st, generation, detect);
        status::publish_selfcal(&selfcal, stale.recalibration_suggested);
        if let Some(s) = sample {
            if SAMPLES.try_send(s).is_err() {
                dropped = dropped.wrapping_add(1);
                if dropped.is_power_of_two() {
                    warn!("host too slow: {} samples dropped", dropped);
                }
            }
        }
        log_connection(&event, st.mode);
        let connected = poller.is_connected();
        if was_connected && !connected {
            warn!("extension unplugged");
        }
        was_connected = connected;
    }
}

/// Says what was found on a (re)connection.
fn log_connection<E>(event: &ExtensionEvent<E>, mode: CorrectionMode) {
    match event {
        ExtensionEvent::Nunchuk(Ok(PollEvent::Connected(info))) => {
            info!(
                "Nunchuk connected ({}), factory calibration {}",
                if info.encryption == wiical_extbus::Encryption::None {
                    "plain"
                } else {
                    "legacy encrypted"
                },
                if info.calibration.is_some() {
                    "valid"
                } else {
                    "missing"
                }
            );
            if mode == CorrectionMode::PassThrough {
                warn!("uncalibrated: pass-through");
            }
        }
        ExtensionEvent::MotionPlus(Ok(MotionPlusEvent::Connected(_))) => {
            info!("MotionPlus connected and activated");
        }
        ExtensionEvent::MotionPlus(Ok(MotionPlusEvent::Switched(mode))) => {
            info!("MotionPlus activated again in mode {=u8}", *mode as u8);
        }
        _ => {}
    }
}

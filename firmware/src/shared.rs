//! What the tasks share with each other: the adapter state behind one mutex, and the channel
//! that carries stream samples from the extension task to the serial task. Each task imports
//! these from here rather than from another task.

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::mutex::Mutex;
#[cfg(feature = "motionplus")]
use embassy_sync::signal::Signal;
use wiical_adapter::Protocol;
#[cfg(feature = "motionplus")]
use wiical_wire::GyroSample;
use wiical_wire::{Response, Sample};

use crate::board::StoreFlash;

/// The adapter state shared by the tasks: protocol handler, corrector, emulated register
/// map and calibration store. Held only for short, non-blocking sections except during a
/// calibration commit (flash write).
pub type Adapter = Mutex<CriticalSectionRawMutex, Protocol<StoreFlash>>;

/// One streamed sample: a Nunchuk's accelerometer, or (protocol 8) a MotionPlus's gyro. Both
/// count in one `seq` (the adapter's stream), so they share one channel and its order.
pub enum Streamed {
    /// A Nunchuk's sample, sent as [`Response::Sample`].
    Sample(Sample),
    /// A MotionPlus's sample, sent as [`Response::GyroSample`].
    #[cfg(feature = "motionplus")]
    Gyro(GyroSample),
}

impl Streamed {
    /// The response that carries it to the host.
    pub fn response(self) -> Response {
        match self {
            Self::Sample(s) => Response::Sample(s),
            #[cfg(feature = "motionplus")]
            Self::Gyro(g) => Response::GyroSample(g),
        }
    }
}

/// Samples on their way from the extension task to the host (dropped when full: the host sees
/// a gap in `seq`).
pub static SAMPLES: Channel<CriticalSectionRawMutex, Streamed, 16> = Channel::new();

/// Signalled by the extension task when the address the Wii Remote side must answer at
/// changed without a transaction of the Wii Remote (another extension connected), so that
/// the Wii Remote task moves there without waiting for a transaction at the old address.
#[cfg(feature = "motionplus")]
pub static ADDRESS_CHANGED: Signal<CriticalSectionRawMutex, ()> = Signal::new();

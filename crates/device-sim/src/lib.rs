//! `wiical device-sim --pty`: the adapter firmware's logic ([`wiical_adapter`]) running on
//! the desktop, serving the wire protocol on a pseudo-terminal.
//!
//! The same code as the firmware runs here: a [`NunchukPoller`] polls a simulated Nunchuk
//! (the [`NunchukRegisters`] state machine behind a simulated I²C bus) at 200 Hz, a
//! [`Protocol`] corrects the reports, fills the emulated register map and answers requests,
//! and a [`CalibrationStore`] keeps the committed calibration (and the MotionPlus's gyro
//! calibration, protocol 7) in a simulated NOR flash
//! (in memory, or mirrored to a file with `--flash` so that it survives a restart).
//!
//! The simulated sensor has a known forward model ([`TRUE_D`], [`TRUE_BIAS`]) with 0.6-count
//! noise; its factory block is the diagonal, rounded part of that model. Its motion
//! ([`SimMotion`]): by default the gravity vector turns slowly (periods of 13 s and 20 s), the
//! stick circles and the buttons blink; `poses` is a calibration by hand (held orientations,
//! smooth turns, the C + Z self-calibration gesture at plug-in). The simulated clock can run
//! faster than the wall clock ([`SimOptions::time_scale`]) so that a test need not wait.
//!
//! A host opening the pty is like plugging the USB cable in; closing it (the simulator sees
//! a hang-up) closes the session and stops the stream, as a real adapter does when the port
//! is closed.
//!
//! With [`SimExtension::MotionPlus`] the bus holds a simulated MotionPlus instead ([`motionplus`]:
//! a known truth turned by a known program), found, activated and polled by the adapter's
//! `ExtensionPoller` as on the board; its corrected rates stream as `GyroSample`s (protocol 8).
//!
//! For tests, [`spawn`] returns the pty path and a [`SimHandle`] that can unplug the
//! Nunchuk, inject raw bytes towards the host, and stop the simulator (giving back the flash
//! so that a new simulator can boot from it).
#![cfg(unix)] // pseudo-terminals

pub mod motionplus;

use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use embedded_hal_async::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};
use embedded_storage_async::nor_flash::{
    ErrorType as FlashErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use motionplus::SimMotionPlus;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serialport::{SerialPort, TTYPort};
use wiical_adapter::{
    CalibrationStore, DeviceInfo, ExtensionPoller, IdealScale, NunchukPoller, PollerConfig,
    Protocol,
};
use wiical_extbus::nunchuk::StickAxisCalibration;
use wiical_extbus::{CalibrationBlock, NunchukRegisters, NunchukReport};
use wiical_wire::{encode_frame, DefaultFrameDecoder, Request, Response, MAX_FRAME_LEN};

/// Erase page of the simulated flash, bytes (the 4 KiB sector of a QSPI NOR flash).
pub const FLASH_PAGE: usize = 4096;
/// Number of pages given to the calibration store.
pub const FLASH_PAGES: usize = 2;
/// Program granularity of the simulated flash, bytes.
pub const FLASH_WORD: usize = 4;
/// Size of the simulated flash image, bytes.
pub const FLASH_SIZE: usize = FLASH_PAGE * FLASH_PAGES;

/// True forward model of the simulated Nunchuk accelerometer, `m = D·a + b`: counts per g
/// with small cross-axis terms (row = output axis).
pub const TRUE_D: [[f64; 3]; 3] = [[203.0, 2.5, -1.0], [-3.0, 196.0, 1.5], [0.8, -2.2, 207.0]];
/// True bias (zero-g counts) of the simulated accelerometer.
pub const TRUE_BIAS: [f64; 3] = [505.3, 497.8, 518.6];

// ------------------------------------------------------------------------------------------
// Flash

/// Error of the simulated flash.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimFlashError {
    /// Offset or length not aligned to the word / page size.
    NotAligned,
    /// Outside the image.
    OutOfBounds,
    /// The backing file could not be written.
    Io,
}

impl NorFlashError for SimFlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            SimFlashError::NotAligned => NorFlashErrorKind::NotAligned,
            SimFlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            SimFlashError::Io => NorFlashErrorKind::Other,
        }
    }
}

/// A NOR flash image shared between simulator runs (clone it to keep it across a restart),
/// optionally mirrored to a file after every program / erase.
///
/// The mirror file is replaced atomically at every step (temporary file, fsync, rename), so
/// that a crash or a full disk leaves the image of the previous step, never a torn file the
/// next start refuses: the store's power-loss safety then carries over to the mirror.
#[derive(Debug, Clone)]
pub struct SimFlash {
    image: Arc<Mutex<Vec<u8>>>,
    file: Option<PathBuf>,
    /// Fault injection (power-cut tests): mirror writes left before the power is cut.
    power: Option<Arc<AtomicU32>>,
}

impl SimFlash {
    /// A blank (erased) in-memory flash.
    pub fn in_memory() -> Self {
        Self {
            image: Arc::new(Mutex::new(vec![0xFF; FLASH_SIZE])),
            file: None,
            power: None,
        }
    }

    /// A flash mirrored to `path`: loaded from it if it exists (it must then be a
    /// [`FLASH_SIZE`]-byte image), created blank otherwise.
    pub fn file(path: &Path) -> Result<Self> {
        let image = if path.exists() {
            // Bounded: `/dev/zero` or a huge file is refused, not read whole.
            let data = match wiical_io::bounded::read_bounded(path, FLASH_SIZE as u64) {
                Ok(d) => d,
                Err(wiical_io::Error::Input(wiical_io::InputError::TooLarge { .. })) => bail!(
                    "{} is not a device-sim flash image (larger than {FLASH_SIZE} bytes)",
                    path.display()
                ),
                Err(e) => return Err(e.into()),
            };
            if data.len() != FLASH_SIZE {
                bail!(
                    "{} is not a device-sim flash image ({} bytes, expected {FLASH_SIZE})",
                    path.display(),
                    data.len()
                );
            }
            data
        } else {
            let data = vec![0xFF; FLASH_SIZE];
            wiical_io::write::write_file(path, &data)
                .map_err(anyhow::Error::new)
                .with_context(|| format!("cannot create {}", path.display()))?;
            data
        };
        Ok(Self {
            image: Arc::new(Mutex::new(image)),
            file: Some(path.to_path_buf()),
            power: None,
        })
    }

    /// Fault injection for power-cut tests: the next `writes` mirror updates succeed, the
    /// one after is interrupted half-way (as a process killed while writing), and every
    /// later one fails. The in-memory image is what the flash chip would hold; the file
    /// keeps the last complete update.
    pub fn cut_power_after(&mut self, writes: u32) {
        self.power = Some(Arc::new(AtomicU32::new(writes)));
    }

    /// A copy of the image.
    pub fn snapshot(&self) -> Vec<u8> {
        self.lock().clone()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<u8>> {
        // A panicking holder cannot leave the image half-written in a way the store cannot
        // cope with (that is the point of the store), so a poisoned lock is still usable.
        self.image.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn persist(&self, image: &[u8]) -> Result<(), SimFlashError> {
        let Some(path) = &self.file else {
            return Ok(());
        };
        let powered = match &self.power {
            None => true,
            Some(left) => left
                .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| n.checked_sub(1))
                .is_ok(),
        };
        wiical_io::write::write_with(path, |w| {
            if powered {
                w.write_all(image)
            } else {
                w.write_all(&image[..image.len() / 2])?;
                Err(io::Error::other("simulated power cut"))
            }
        })
        .map_err(|_| SimFlashError::Io)
    }

    fn range(
        offset: u32,
        len: usize,
        align: usize,
    ) -> Result<std::ops::Range<usize>, SimFlashError> {
        let start = offset as usize;
        if !start.is_multiple_of(align) || !len.is_multiple_of(align) {
            return Err(SimFlashError::NotAligned);
        }
        let end = start.checked_add(len).ok_or(SimFlashError::OutOfBounds)?;
        if end > FLASH_SIZE {
            return Err(SimFlashError::OutOfBounds);
        }
        Ok(start..end)
    }
}

impl FlashErrorType for SimFlash {
    type Error = SimFlashError;
}

impl ReadNorFlash for SimFlash {
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), SimFlashError> {
        let r = Self::range(offset, bytes.len(), 1)?;
        bytes.copy_from_slice(&self.lock()[r]);
        Ok(())
    }

    fn capacity(&self) -> usize {
        FLASH_SIZE
    }
}

impl NorFlash for SimFlash {
    const WRITE_SIZE: usize = FLASH_WORD;
    const ERASE_SIZE: usize = FLASH_PAGE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), SimFlashError> {
        let len = to.checked_sub(from).ok_or(SimFlashError::OutOfBounds)? as usize;
        let r = Self::range(from, len, FLASH_PAGE)?;
        let mut img = self.lock();
        img[r].fill(0xFF);
        self.persist(&img)
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), SimFlashError> {
        let r = Self::range(offset, bytes.len(), FLASH_WORD)?;
        let mut img = self.lock();
        // NOR programming only clears bits.
        for (b, d) in img[r].iter_mut().zip(bytes) {
            *b &= d;
        }
        self.persist(&img)
    }
}

// ------------------------------------------------------------------------------------------
// Simulated Nunchuk on a simulated bus

/// Bus error of the simulated extension port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SimNak;

impl embedded_hal_async::i2c::Error for SimNak {
    fn kind(&self) -> ErrorKind {
        ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address)
    }
}

/// The simulated Nunchuk's factory calibration block: the diagonal of [`TRUE_D`] and
/// [`TRUE_BIAS`], rounded (what a factory two-point calibration would store).
pub fn sim_factory_block() -> CalibrationBlock {
    let zero = TRUE_BIAS.map(|b| b.round() as u16);
    let one_g: [u16; 3] = std::array::from_fn(|i| (TRUE_BIAS[i] + TRUE_D[i][i]).round() as u16);
    CalibrationBlock {
        zero,
        one_g,
        stick_x: StickAxisCalibration {
            max: 0xE2,
            min: 0x1D,
            centre: 0x80,
        },
        stick_y: StickAxisCalibration {
            max: 0xDF,
            min: 0x1F,
            centre: 0x7F,
        },
    }
}

fn fresh_nunchuk() -> NunchukRegisters {
    let mut n = NunchukRegisters::new();
    // The block is in range by construction; a failure would leave zeros, caught by tests.
    let _ = n.set_calibration(&sim_factory_block());
    n
}

/// The simulated extension port: a Nunchuk (or, when `motionplus` is set, a MotionPlus
/// alone) when plugged, NAKs otherwise. A replug powers up a fresh, uninitialised device.
struct SimBus {
    nunchuk: NunchukRegisters,
    motionplus: Option<SimMotionPlus>,
    plugged: Arc<AtomicBool>,
    was_plugged: bool,
}

impl ErrorType for SimBus {
    type Error = SimNak;
}

impl I2c for SimBus {
    async fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), SimNak> {
        let plugged = self.plugged.load(Ordering::Relaxed);
        if let Some(mp) = self.motionplus.as_mut() {
            if plugged && !self.was_plugged {
                mp.power_up();
            }
            self.was_plugged = plugged;
            return if plugged && mp.transaction(address, operations) {
                Ok(())
            } else {
                Err(SimNak)
            };
        }
        if plugged && !self.was_plugged {
            let mut fresh = fresh_nunchuk();
            let mut report = [0u8; 6];
            for (i, b) in report.iter_mut().enumerate() {
                *b = self.nunchuk.register(i as u8);
            }
            fresh.set_report(&NunchukReport::from_bytes(&report));
            self.nunchuk = fresh;
        }
        self.was_plugged = plugged;
        if !plugged || address != wiical_extbus::nunchuk::I2C_ADDRESS {
            return Err(SimNak);
        }
        for op in operations {
            match op {
                Operation::Write(b) => self.nunchuk.write(b),
                Operation::Read(b) => self.nunchuk.read(b),
            }
        }
        Ok(())
    }
}

struct NoDelay;

impl embedded_hal_async::delay::DelayNs for NoDelay {
    async fn delay_ns(&mut self, _ns: u32) {}
}

/// Which motion the simulated Nunchuk makes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum SimMotion {
    /// Gravity turns continuously (periods of 13 s and 20 s), never still; the stick circles
    /// and the buttons blink. Plugged in from the start.
    #[default]
    Sweep,
    /// A calibration by hand ([`POSE_DIRECTIONS`]): plugged in when a host first opens the
    /// port, with C + Z held for the first [`POSE_CZ_HOLD_S`] (the adapter's self-calibration
    /// gesture), then each orientation held [`POSE_HOLD_S`] with smooth
    /// [`POSE_MOVE_S`] turns between, then back to the first and still from then on.
    Poses,
}

/// Gravity directions (sensor frame, unit after normalising) the `poses` motion holds, in
/// order: the six half-axes, the eight cube corners and four edge midpoints, ordered so that
/// no turn is a half turn. Every direction is at least 35° from every other.
pub const POSE_DIRECTIONS: [[f64; 3]; 18] = [
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 1.0],
    [0.0, 1.0, 0.0],
    [-1.0, 1.0, 1.0],
    [-1.0, 0.0, 0.0],
    [-1.0, -1.0, 1.0],
    [0.0, -1.0, 0.0],
    [1.0, -1.0, 1.0],
    [1.0, -1.0, -1.0],
    [0.0, 0.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, -1.0],
    [0.0, -1.0, -1.0],
    [1.0, 0.0, -1.0],
    [0.0, 1.0, -1.0],
    [-1.0, 0.0, -1.0],
];
/// `poses` motion: the first orientation (the rest the detectors take their noise from), s.
pub const POSE_REST_S: f64 = 6.0;
/// `poses` motion: C and Z held from plug-in for this long (the adapter enters its
/// self-calibration after a 3 s hold starting within 1 s of plug-in), s.
pub const POSE_CZ_HOLD_S: f64 = 4.5;
/// `poses` motion: each later orientation is held this long, s.
pub const POSE_HOLD_S: f64 = 4.0;
/// `poses` motion: each turn between two orientations takes this long, s.
pub const POSE_MOVE_S: f64 = 2.0;

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    v.map(|x| x / n)
}

/// Gravity direction of the `poses` motion at `t` s after plug-in: holds, and great-circle
/// turns between them with a smooth (zero velocity at both ends) angle profile.
pub fn pose_direction(t: f64) -> [f64; 3] {
    let n = POSE_DIRECTIONS.len();
    let step = POSE_MOVE_S + POSE_HOLD_S;
    let after_rest = t - POSE_REST_S;
    if after_rest < 0.0 {
        return unit(POSE_DIRECTIONS[0]);
    }
    // Turn k (0-based) goes from pose k to pose k+1; turn n-1 goes back to the first.
    let k = (after_rest / step).floor() as usize;
    if k >= n {
        return unit(POSE_DIRECTIONS[0]);
    }
    let a = unit(POSE_DIRECTIONS[k]);
    let b = unit(POSE_DIRECTIONS[(k + 1) % n]);
    let u = ((after_rest - k as f64 * step) / POSE_MOVE_S).min(1.0);
    let f = u * u * (3.0 - 2.0 * u);
    let cos = a
        .iter()
        .zip(&b)
        .map(|(x, y)| x * y)
        .sum::<f64>()
        .clamp(-1.0, 1.0);
    let theta = cos.acos();
    if theta < 1e-9 {
        return b;
    }
    let (wa, wb) = (
        ((1.0 - f) * theta).sin() / theta.sin(),
        (f * theta).sin() / theta.sin(),
    );
    std::array::from_fn(|i| wa * a[i] + wb * b[i])
}

/// Synthetic motion of the simulated Nunchuk.
struct Motion {
    kind: SimMotion,
    rng: ChaCha8Rng,
    noise: Normal<f64>,
}

impl Motion {
    fn new(kind: SimMotion, seed: u64) -> Self {
        Self {
            kind,
            rng: ChaCha8Rng::seed_from_u64(seed),
            noise: Normal::new(0.0, 0.6).unwrap_or_else(|_| unreachable!()),
        }
    }

    /// The report at time `t` (s of the simulated clock since the motion started).
    fn report(&mut self, t: f64) -> NunchukReport {
        match self.kind {
            SimMotion::Sweep => self.sweep(t),
            SimMotion::Poses => {
                let hold = t < POSE_CZ_HOLD_S;
                NunchukReport {
                    stick: [128, 128],
                    accel: self.counts(pose_direction(t)),
                    c: hold,
                    z: hold,
                }
            }
        }
    }

    /// Raw 10-bit counts for gravity along `a` (g): the true forward model plus noise.
    fn counts(&mut self, a: [f64; 3]) -> [u16; 3] {
        std::array::from_fn(|i| {
            let m = TRUE_BIAS[i]
                + (0..3).map(|j| TRUE_D[i][j] * a[j]).sum::<f64>()
                + self.noise.sample(&mut self.rng);
            m.round().clamp(0.0, 1023.0) as u16
        })
    }

    fn sweep(&mut self, t: f64) -> NunchukReport {
        use std::f64::consts::TAU;
        let theta = 1.2 * (TAU * t / 20.0).sin();
        let phi = TAU * t / 13.0;
        let a = [
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        ];
        let accel = self.counts(a);
        let stick = [
            (128.0 + 60.0 * (TAU * t / 7.0).cos()).round() as u8,
            (128.0 + 60.0 * (TAU * t / 7.0).sin()).round() as u8,
        ];
        NunchukReport {
            stick,
            accel,
            c: t % 6.0 < 0.5,
            z: t % 9.0 < 0.5,
        }
    }
}

// ------------------------------------------------------------------------------------------
// The simulator

/// Which extension is on the simulated adapter's bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum SimExtension {
    /// A Nunchuk making the [`SimMotion`].
    #[default]
    Nunchuk,
    /// A MotionPlus alone ([`motionplus`]): its known truth and motion program, from boot.
    #[cfg_attr(feature = "clap", value(name = "motionplus"))]
    MotionPlus,
}

/// Simulator settings.
#[derive(Debug, Clone)]
pub struct SimOptions {
    /// The flash (clone a [`SimFlash`] to boot a later simulator from the same one).
    pub flash: SimFlash,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Present this schema key instead of the real one (to exercise the mismatch path).
    pub schema_key: Option<u32>,
    /// Report poll rate, Hz (of the simulated clock).
    pub poll_hz: u32,
    /// What the simulated Nunchuk does.
    pub motion: SimMotion,
    /// The extension on the bus.
    pub extension: SimExtension,
    /// The simulated clock runs this many times faster than the wall clock (polls, and so
    /// samples, come this many times more often; the adapter still announces `poll_hz`, so
    /// a host timing samples by their sequence number sees simulated time). At least 1.
    pub time_scale: f64,
}

impl Default for SimOptions {
    fn default() -> Self {
        Self {
            flash: SimFlash::in_memory(),
            seed: 1,
            schema_key: None,
            poll_hz: wiical_adapter::DEFAULT_POLL_HZ,
            motion: SimMotion::Sweep,
            extension: SimExtension::Nunchuk,
            time_scale: 1.0,
        }
    }
}

/// Counters of a running simulator.
#[derive(Debug, Default)]
pub struct SimCounters {
    /// Requests answered.
    pub requests: AtomicU64,
    /// Corrupt frames received (answered with `BadFrame`).
    pub bad_frames: AtomicU64,
    /// Samples sent.
    pub samples: AtomicU64,
    /// Times a host closed the port.
    pub hangups: AtomicU64,
}

/// Control of a running simulator; dropping it stops the simulator.
pub struct SimHandle {
    path: PathBuf,
    stop: Arc<AtomicBool>,
    plugged: Arc<AtomicBool>,
    inject: mpsc::Sender<Vec<u8>>,
    corrupt: Arc<AtomicU32>,
    corrupt_acks: Arc<AtomicU32>,
    counters: Arc<SimCounters>,
    thread: Option<JoinHandle<Result<()>>>,
}

impl SimHandle {
    /// The pty the host opens.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Plug or unplug the simulated Nunchuk.
    pub fn set_nunchuk_plugged(&self, plugged: bool) {
        self.plugged.store(plugged, Ordering::Relaxed);
    }

    /// Write raw bytes towards the host, between two frames (line noise, corruption).
    pub fn inject_to_host(&self, bytes: &[u8]) {
        let _ = self.inject.send(bytes.to_vec());
    }

    /// Damage the next `n` answers (not samples) on their way to the host: one byte in the
    /// middle of the frame is changed, so the host sees a CRC/COBS failure.
    pub fn corrupt_next_answers(&self, n: u32) {
        self.corrupt.store(n, Ordering::Relaxed);
    }

    /// Like [`Self::corrupt_next_answers`] but only for `Ack` answers (e.g. to lose the
    /// acknowledgement of a commit while the requests around it get through).
    pub fn corrupt_next_acks(&self, n: u32) {
        self.corrupt_acks.store(n, Ordering::Relaxed);
    }

    /// Counters so far.
    pub fn counters(&self) -> &SimCounters {
        &self.counters
    }

    /// Stop the simulator and wait for it. Its flash keeps the committed calibration. A
    /// simulator thread that panicked is an error carrying the panic's message.
    pub fn stop(mut self) -> Result<()> {
        self.shutdown().unwrap_or_else(|panic| {
            Err(anyhow!(
                "the device-sim thread panicked: {}",
                panic_message(panic.as_ref())
            ))
        })
    }

    /// Stops the simulator thread and waits for it: what it returned, or its panic (`Err`).
    fn shutdown(&mut self) -> std::thread::Result<Result<()>> {
        self.stop.store(true, Ordering::Relaxed);
        self.thread.take().map_or(Ok(Ok(())), JoinHandle::join)
    }

    /// True while the simulator thread runs.
    pub fn is_running(&self) -> bool {
        self.thread.as_ref().is_some_and(|t| !t.is_finished())
    }
}

impl Drop for SimHandle {
    /// Stops the simulator. What it returned is dropped with it (call [`SimHandle::stop`] to
    /// see it), but a panic of its thread is raised here (unless this thread is already
    /// unwinding): a test whose simulator panicked must not pass.
    fn drop(&mut self) {
        if let Err(panic) = self.shutdown() {
            if !std::thread::panicking() {
                std::panic::resume_unwind(panic);
            }
        }
    }
}

/// The message a panic was raised with (its `&str` or `String` payload), or a note that it
/// has none that can be shown.
fn panic_message(payload: &(dyn std::any::Any + Send)) -> &str {
    payload
        .downcast_ref::<&str>()
        .copied()
        .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
        .unwrap_or("(a panic without a text message)")
}

/// Start a simulator on a new pty; returns the pty path (what `--port` takes) and its
/// handle.
pub fn spawn(opts: SimOptions) -> Result<(PathBuf, SimHandle)> {
    let (master, slave) =
        TTYPort::pair().map_err(|e| anyhow!("cannot create a pseudo-terminal: {e}"))?;
    let path = PathBuf::from(
        slave
            .name()
            .ok_or_else(|| anyhow!("the pseudo-terminal has no name"))?,
    );
    // The slave is opened by the host; keeping it open here would make us compete for its
    // input. With no slave open the master reports a hang-up, which is how a closed port
    // is detected.
    drop(slave);

    let store = CalibrationStore::new(opts.flash.clone(), 0..FLASH_SIZE as u32)
        .map_err(|e| anyhow!("{e}"))?;
    let info = DeviceInfo::new(
        concat!("device-sim ", env!("CARGO_PKG_VERSION")),
        *b"wiicalSM",
        opts.poll_hz.max(1) * 1000,
    );
    let mut proto = embassy_futures::block_on(Protocol::boot(store, info, IdealScale::default()));
    if let Some(k) = opts.schema_key {
        proto = proto.with_schema_key(k);
    }

    let stop = Arc::new(AtomicBool::new(false));
    // The `poses` motion plugs the Nunchuk in when a host first opens the port; a MotionPlus
    // is plugged in from the start.
    let mp = opts.extension == SimExtension::MotionPlus;
    let from_boot = opts.motion == SimMotion::Sweep || mp;
    let plugged = Arc::new(AtomicBool::new(from_boot));
    let counters = Arc::new(SimCounters::default());
    let corrupt = Arc::new(AtomicU32::new(0));
    let corrupt_acks = Arc::new(AtomicU32::new(0));
    let (tx, rx) = mpsc::channel();
    let worker = Worker {
        master,
        proto,
        poller: if mp {
            Poller::Extension(ExtensionPoller::default())
        } else {
            Poller::Nunchuk(NunchukPoller::new(PollerConfig::default()))
        },
        bus: SimBus {
            nunchuk: fresh_nunchuk(),
            motionplus: mp.then(|| SimMotionPlus::new(opts.seed)),
            plugged: plugged.clone(),
            was_plugged: true,
        },
        motion: Motion::new(opts.motion, opts.seed),
        poll_hz: f64::from(opts.poll_hz.max(1)),
        period: Duration::from_secs_f64(
            1.0 / f64::from(opts.poll_hz.max(1)) / opts.time_scale.max(1.0),
        ),
        plugged: plugged.clone(),
        ticks: 0,
        motion_start: from_boot.then_some(0),
        stop: stop.clone(),
        inject: rx,
        corrupt: corrupt.clone(),
        corrupt_acks: corrupt_acks.clone(),
        counters: counters.clone(),
        attached: false,
    };
    let thread = std::thread::Builder::new()
        .name("device-sim".into())
        .spawn(move || worker.run())
        .context("cannot start the simulator thread")?;
    Ok((
        path.clone(),
        SimHandle {
            path,
            stop,
            plugged,
            inject: tx,
            corrupt,
            corrupt_acks,
            counters,
            thread: Some(thread),
        },
    ))
}

/// Most polls made in a row before the port is read again.
const MAX_BURST: u32 = 64;

/// The firmware's poller: the Nunchuk's alone (the adapter's original path, as before the
/// MotionPlus), or both extensions' (`ExtensionPoller`, MotionPlus first) for a MotionPlus.
enum Poller {
    Nunchuk(NunchukPoller),
    Extension(ExtensionPoller),
}

struct Worker {
    master: TTYPort,
    proto: Protocol<SimFlash>,
    poller: Poller,
    bus: SimBus,
    motion: Motion,
    /// Simulated poll rate, Hz.
    poll_hz: f64,
    /// Wall time between polls (the simulated period over the time scale).
    period: Duration,
    plugged: Arc<AtomicBool>,
    /// Polls so far: the simulated clock is `ticks / poll_hz` (it runs on even when the
    /// machine is too busy to keep the wall-clock pace, so the stream stays consistent).
    ticks: u64,
    /// Tick at which the motion started (`poses`: the first host's arrival).
    motion_start: Option<u64>,
    stop: Arc<AtomicBool>,
    inject: mpsc::Receiver<Vec<u8>>,
    corrupt: Arc<AtomicU32>,
    corrupt_acks: Arc<AtomicU32>,
    counters: Arc<SimCounters>,
    /// A host has the port open (we received from it and saw no hang-up since).
    attached: bool,
}

impl Worker {
    fn run(mut self) -> Result<()> {
        let mut next_poll = Instant::now();
        let mut rx = DefaultFrameDecoder::new();
        let mut buf = [0u8; 512];
        while !self.stop.load(Ordering::Relaxed) {
            while let Ok(bytes) = self.inject.try_recv() {
                self.send_bytes(&bytes);
            }
            // Every poll due (a sped-up clock has several per millisecond), within bounds.
            let mut burst = 0;
            while Instant::now() >= next_poll && burst < MAX_BURST {
                self.poll_once();
                next_poll += self.period;
                burst += 1;
            }
            let now = Instant::now();
            if next_poll + (20 * self.period).max(Duration::from_millis(20)) < now {
                // Fell far behind (machine busy): the simulated clock slows down instead of
                // bursting.
                next_poll = now + self.period;
            }
            let wait = next_poll
                .saturating_duration_since(Instant::now())
                .clamp(Duration::from_millis(1), Duration::from_millis(5));
            let _ = self.master.set_timeout(wait);
            match self.master.read(&mut buf) {
                Ok(n) if n > 0 => {
                    self.attached = true;
                    if self.motion_start.is_none() {
                        // `poses`: the user plugs the Nunchuk in (C + Z held) and starts.
                        self.motion_start = Some(self.ticks);
                        self.plugged.store(true, Ordering::Relaxed);
                    }
                    let items: Vec<_> = rx.feed::<Request>(&buf[..n]).collect();
                    for item in items {
                        let resp = match item {
                            Ok(req) => {
                                self.counters.requests.fetch_add(1, Ordering::Relaxed);
                                embassy_futures::block_on(self.proto.handle(req))
                            }
                            Err(e) => {
                                self.counters.bad_frames.fetch_add(1, Ordering::Relaxed);
                                self.proto.bad_frame(e)
                            }
                        };
                        self.send(&resp);
                    }
                }
                Ok(_) => {}
                Err(e) if e.kind() == io::ErrorKind::TimedOut => {}
                Err(_) => {
                    // Hang-up: no host has the port open.
                    if self.attached {
                        self.attached = false;
                        self.counters.hangups.fetch_add(1, Ordering::Relaxed);
                    }
                    self.proto.reset_session();
                    rx.reset();
                    std::thread::sleep(wait);
                }
            }
        }
        Ok(())
    }

    /// One poll of the simulated Nunchuk at the simulated time, as the firmware's Nunchuk
    /// task does it: read, correct, stream, commit a finished self-calibration.
    fn poll_once(&mut self) {
        let t = self.ticks as f64 / self.poll_hz;
        let motion_t = self
            .motion_start
            .map_or(0.0, |s| self.ticks.saturating_sub(s) as f64 / self.poll_hz);
        self.ticks += 1;
        let now_ms = (t * 1000.0) as u64;
        let streamed = match &mut self.poller {
            Poller::Nunchuk(poller) => {
                self.bus.nunchuk.set_report(&self.motion.report(motion_t));
                let r = embassy_futures::block_on(poller.poll(&mut self.bus, &mut NoDelay, now_ms));
                self.proto
                    .on_poll(&r, poller.is_connected())
                    .map(Response::Sample)
            }
            Poller::Extension(poller) => {
                if let Some(mp) = self.bus.motionplus.as_mut() {
                    let report = mp.report(motion_t);
                    mp.set_report(&report);
                }
                let e = embassy_futures::block_on(poller.poll(&mut self.bus, &mut NoDelay, now_ms));
                let sample = self.proto.on_extension_poll(&e, poller);
                sample
                    .map(Response::Sample)
                    .or_else(|| self.proto.take_gyro_sample().map(Response::GyroSample))
            }
        };
        if let Some(resp) = streamed {
            if self.send(&resp) {
                self.counters.samples.fetch_add(1, Ordering::Relaxed);
            }
        }
        embassy_futures::block_on(self.proto.service());
    }

    fn send(&mut self, resp: &Response) -> bool {
        let mut out = [0u8; MAX_FRAME_LEN];
        match encode_frame(resp, &mut out) {
            Ok(frame) => {
                let mut frame = frame.to_vec();
                let take = |c: &AtomicU32| {
                    c.fetch_update(Ordering::Relaxed, Ordering::Relaxed, |n| n.checked_sub(1))
                        .is_ok()
                };
                let damage = match resp {
                    Response::Sample(_) | Response::GyroSample(_) => false,
                    Response::Ack => take(&self.corrupt_acks) || take(&self.corrupt),
                    _ => take(&self.corrupt),
                };
                if damage {
                    let mid = frame.len() / 2;
                    if let Some(b) = frame.get_mut(mid) {
                        // Stay non-zero: the frame must not be split, only damaged.
                        *b = if *b == 0x55 { 0xAA } else { 0x55 };
                    }
                }
                self.send_bytes(&frame)
            }
            Err(_) => false,
        }
    }

    /// Write to the host; a full buffer (host not reading) or a hang-up drops the bytes,
    /// like a USB CDC device whose host is not listening.
    fn send_bytes(&mut self, bytes: &[u8]) -> bool {
        let _ = self.master.set_timeout(Duration::from_millis(50));
        self.master
            .write_all(bytes)
            .and_then(|_| self.master.flush())
            .is_ok()
    }
}

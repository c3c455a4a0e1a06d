//! The transport: a [`WiimoteIo`] writes output reports and reads input reports with a
//! timeout, and tells the time. [`HidWiimote`] is a real remote through hidapi;
//! [`super::replay::ReplayWiimote`] is a scripted fake for tests; [`LogReplay`] plays back
//! a raw report log written by [`RawLogger`] (`wiical capture --raw-log`), so a session with a
//! real remote can be reproduced without it.

use super::hid::{self, PRODUCT_IDS, VENDOR_ID};
use anyhow::{anyhow, bail, Context, Result};
use std::collections::VecDeque;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// A duplex link to one Wii Remote.
pub trait WiimoteIo {
    /// Sends one output report (report ID first).
    fn write(&mut self, report: &[u8]) -> Result<()>;
    /// Waits at most `ms` milliseconds for one input report and copies it into `buf` (report
    /// ID first). Returns its length, or 0 when the time ran out. An error means the link is
    /// gone (device switched off, out of range, unplugged).
    fn read_timeout(&mut self, buf: &mut [u8], ms: i32) -> Result<usize>;
    /// The clock used for timestamps and timeouts, seconds from an arbitrary origin:
    /// the host's monotonic clock for a device, the script's time in a replay.
    fn now_s(&self) -> f64;
    /// A one-line description of the device, for the files written.
    fn describe(&self) -> String;
}

impl<T: WiimoteIo + ?Sized> WiimoteIo for &mut T {
    fn write(&mut self, report: &[u8]) -> Result<()> {
        (**self).write(report)
    }
    fn read_timeout(&mut self, buf: &mut [u8], ms: i32) -> Result<usize> {
        (**self).read_timeout(buf, ms)
    }
    fn now_s(&self) -> f64 {
        (**self).now_s()
    }
    fn describe(&self) -> String {
        (**self).describe()
    }
}

/// A Wii Remote connected over Bluetooth, through hidapi (on Linux the `hidraw` device the
/// kernel creates for a paired remote).
///
/// Not tested here: this project's machines have no Bluetooth and no Wii Remote, so only the
/// "no device" path of [`open_wiimote`] runs in the tests. The protocol logic above this
/// transport is exercised with [`super::replay::ReplayWiimote`].
pub struct HidWiimote {
    dev: hidapi::HidDevice,
    start: Instant,
    description: String,
}

impl WiimoteIo for HidWiimote {
    fn write(&mut self, report: &[u8]) -> Result<()> {
        // Windows' HID stack only accepts writes of the device's full output report length
        // (22 bytes for the Wii Remote), so shorter reports are padded with zeros there, as
        // wiiuse does. Elsewhere the report goes out as is. (Untested: no Windows machine.)
        #[cfg(windows)]
        let padded = {
            let mut p = report.to_vec();
            if p.len() < 22 {
                p.resize(22, 0);
            }
            p
        };
        #[cfg(windows)]
        let report = padded.as_slice();
        let n = self.dev.write(report).map_err(|e| {
            anyhow!(
                "cannot send report 0x{:02X}: {e}",
                report.first().unwrap_or(&0)
            )
        })?;
        if n < report.len() {
            bail!(
                "report 0x{:02X} only partly sent ({n} of {} bytes)",
                report.first().unwrap_or(&0),
                report.len()
            );
        }
        Ok(())
    }

    fn read_timeout(&mut self, buf: &mut [u8], ms: i32) -> Result<usize> {
        self.dev
            .read_timeout(buf, ms)
            .map_err(|e| anyhow!("lost the Wii Remote: {e}"))
    }

    fn now_s(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    fn describe(&self) -> String {
        self.description.clone()
    }
}

/// The message when no remote is present. Pairing advice: WiiBrew ("Bluetooth
/// Communication"): pressing 1+2 (or the red sync button) makes the remote discoverable for
/// about 20 s; holding 1+2 keeps it so.
pub const NO_DEVICE_HELP: &str = "no Wii Remote found: pair it over Bluetooth (press 1+2, or the red sync button under the battery cover, and connect it with your Bluetooth settings, e.g. `bluetoothctl`: scan on, pair, connect) and run the command again while its LEDs are lit";

/// Opens the first Wii Remote (vendor `0x057E`, product `0x0306` or `0x0330`) that hidapi
/// lists. Errors are written for the user: hidapi unavailable, no remote paired, or no
/// permission to open it.
pub fn open_wiimote() -> Result<HidWiimote> {
    let api = hidapi::HidApi::new().map_err(|e| {
        anyhow!(
            "cannot initialise HID access (hidapi: {e}); on Linux this needs /sys and /dev/hidraw* (it does not work in most containers)"
        )
    })?;
    let Some(info) = api
        .device_list()
        .find(|d| d.vendor_id() == VENDOR_ID && PRODUCT_IDS.contains(&d.product_id()))
    else {
        bail!("{NO_DEVICE_HELP}");
    };
    let path = info.path().to_string_lossy().into_owned();
    let dev = info.open_device(&api).map_err(|e| {
        anyhow!(
            "found a Wii Remote at {path} but cannot open it ({e}); on Linux give your user read/write access to /dev/hidraw* (a udev rule for vendor 057e), or run as root"
        )
    })?;
    let description = format!(
        "{} ({:04x}:{:04x}) at {path}",
        info.product_string().unwrap_or("Nintendo Wii Remote"),
        info.vendor_id(),
        info.product_id()
    );
    Ok(HidWiimote {
        dev,
        start: Instant::now(),
        description,
    })
}

/// Wraps a transport and logs every report, in and out, as text lines
/// `<t> <in|out> <hex bytes>` (`t` in seconds on the transport's clock, written with all the
/// digits an `f64` needs to round-trip, so that a replay reproduces the timestamps exactly).
/// [`LogReplay`] reads such a log back.
pub struct RawLogger<D, W: Write> {
    inner: D,
    log: W,
}

impl<D: WiimoteIo, W: Write> RawLogger<D, W> {
    /// Logs the traffic of `inner` to `log`; the first line is a `#` comment naming the device.
    pub fn new(inner: D, mut log: W) -> Result<Self> {
        writeln!(
            log,
            "# wiical raw Wii Remote report log: <t s> <in|out> <hex>; device: {}",
            inner.describe()
        )?;
        Ok(Self { inner, log })
    }

    /// Flushes the log.
    pub fn flush(&mut self) -> Result<()> {
        self.log.flush().context("cannot write the raw report log")
    }
}

impl<D: WiimoteIo, W: Write> WiimoteIo for RawLogger<D, W> {
    fn write(&mut self, report: &[u8]) -> Result<()> {
        let t = self.inner.now_s();
        writeln!(self.log, "{t} out {}", hid::hex(report))
            .context("cannot write the raw report log")?;
        self.inner.write(report)
    }

    fn read_timeout(&mut self, buf: &mut [u8], ms: i32) -> Result<usize> {
        let n = self.inner.read_timeout(buf, ms)?;
        if n > 0 {
            let t = self.inner.now_s();
            let bytes = buf.get(..n).unwrap_or(buf);
            writeln!(self.log, "{t} in {}", hid::hex(bytes))
                .context("cannot write the raw report log")?;
        }
        Ok(n)
    }

    fn now_s(&self) -> f64 {
        self.inner.now_s()
    }

    fn describe(&self) -> String {
        self.inner.describe()
    }
}

/// Plays back the input reports of a raw log ([`RawLogger`]) at their logged times. Output
/// reports are accepted and not checked: the capture logic sends the same requests as when
/// the log was made, and the logged replies follow in the logged order.
///
/// The clock is simulated: a read that finds the next logged report later than the timeout
/// advances the clock by the timeout and returns 0, as a real read would after waiting.
/// After the last report the link reports itself lost, like a remote switched off.
pub struct LogReplay {
    reports: VecDeque<(f64, Vec<u8>)>,
    clock: f64,
    /// Time of the first logged report (the pace's origin).
    first: f64,
    description: String,
    /// `Some((speed, start))`: reports are handed out no earlier than their logged time
    /// divided by `speed` after `start` (see [`LogReplay::paced`]).
    pace: Option<(f64, std::time::Instant)>,
}

impl LogReplay {
    /// Parses a log (see [`RawLogger`]). Lines that are empty or start with `#` are skipped.
    pub fn parse(text: &str) -> Result<Self> {
        let mut reports = VecDeque::new();
        let mut description = "raw report log".to_string();
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if let Some(c) = line.strip_prefix('#') {
                if let Some((_, d)) = c.split_once("device: ") {
                    description = format!("replay of {}", d.trim());
                }
                continue;
            }
            if line.is_empty() {
                continue;
            }
            let mut f = line.split_whitespace();
            let (Some(t), Some(dir)) = (f.next(), f.next()) else {
                bail!(
                    "raw log line {}: expected `<t> <in|out> <hex bytes>`",
                    i + 1
                );
            };
            let t: f64 = t
                .parse()
                .ok()
                .filter(|t: &f64| t.is_finite())
                .ok_or_else(|| anyhow!("raw log line {}: bad time {t:?}", i + 1))?;
            let bytes = f
                .map(|h| u8::from_str_radix(h, 16))
                .collect::<Result<Vec<u8>, _>>()
                .map_err(|_| anyhow!("raw log line {}: bad hex byte", i + 1))?;
            match dir {
                "in" => reports.push_back((t, bytes)),
                "out" => {}
                other => bail!(
                    "raw log line {}: expected in or out, found {other:?}",
                    i + 1
                ),
            }
        }
        if reports.is_empty() {
            bail!("the raw log has no input reports");
        }
        let clock = reports.front().map(|r| r.0).unwrap_or(0.0);
        Ok(Self {
            reports,
            clock,
            first: clock,
            description,
            pace: None,
        })
    }

    /// Replays at `speed` times the logged pace (wall clock) instead of as fast as possible,
    /// as the session happened (`wiical capture --replay LOG --replay-speed X`, e.g. to
    /// watch it with `--live`). The simulated clock is unchanged, so the recording is the same.
    pub fn paced(mut self, speed: f64) -> Self {
        self.pace = Some((speed, std::time::Instant::now()));
        self
    }

    /// Reads and parses a log file (a regular file of at most the recording size cap).
    pub fn load(path: &Path) -> Result<Self> {
        let text = wiical_io::bounded::read_text(path, wiical_io::bounded::MAX_RECORDING_BYTES)?;
        Self::parse(&text).with_context(|| format!("in {}", path.display()))
    }
}

impl WiimoteIo for LogReplay {
    fn write(&mut self, _report: &[u8]) -> Result<()> {
        Ok(())
    }

    fn read_timeout(&mut self, buf: &mut [u8], ms: i32) -> Result<usize> {
        let Some((t, _)) = self.reports.front() else {
            bail!("lost the Wii Remote: end of the replayed log");
        };
        let wait = f64::from(ms.max(0)) / 1000.0;
        if *t > self.clock + wait {
            self.clock += wait;
            return Ok(0);
        }
        if let Some((speed, start)) = self.pace {
            let t0 = self.first;
            let due = std::time::Duration::from_secs_f64(((*t - t0) / speed).max(0.0));
            let now = start.elapsed();
            // Sleeps of under 2 ms are left for the next report (scheduler overhead).
            if due > now + std::time::Duration::from_millis(2) {
                std::thread::sleep(due - now);
            }
        }
        let (t, bytes) = self
            .reports
            .pop_front()
            .ok_or_else(|| anyhow!("end of the replayed log"))?;
        self.clock = self.clock.max(t);
        let n = bytes.len().min(buf.len());
        buf[..n].copy_from_slice(&bytes[..n]);
        Ok(n)
    }

    fn now_s(&self) -> f64 {
        self.clock
    }

    fn describe(&self) -> String {
        self.description.clone()
    }
}

//! The sensors the simulator imitates: sensitivity, noise, ADC range and unit.

/// Which sensor to imitate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Device {
    /// Wii Remote (ADXL330, ~105 counts/g at 10 bits).
    Wiimote,
    /// Nunchuk (LIS3L02AL, ~200 counts/g at 10 bits).
    Nunchuk,
    /// A 16-bit MEMS accelerometer at ±2 g (16 384 counts/g, MPU-6050-like noise of ~1.2 mg
    /// per sample), logged in m/s² (each count × 9.80665/16384), typically at 400 Hz.
    Mems16,
}

impl Device {
    /// Parses `wiimote` / `nunchuk`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "wiimote" => Some(Device::Wiimote),
            "nunchuk" => Some(Device::Nunchuk),
            "mems16" => Some(Device::Mems16),
            _ => None,
        }
    }

    /// Name.
    pub fn name(self) -> &'static str {
        match self {
            Device::Wiimote => "wiimote",
            Device::Nunchuk => "nunchuk",
            Device::Mems16 => "mems16",
        }
    }

    /// Nominal sensitivity, counts per g.
    pub fn counts_per_g(self) -> f64 {
        match self {
            Device::Wiimote => 105.0,
            Device::Nunchuk => 200.0,
            Device::Mems16 => 16384.0,
        }
    }

    /// White-noise standard deviation per sample, counts.
    pub fn noise_counts(self) -> f64 {
        match self {
            Device::Wiimote => 1.0,
            Device::Nunchuk => 1.2,
            Device::Mems16 => 20.0,
        }
    }

    /// The ADC's output range, counts: 10-bit unsigned for the Wii devices, signed 16-bit.
    pub fn adc_range(self) -> (f64, f64) {
        match self {
            Device::Wiimote | Device::Nunchuk => (0.0, 1023.0),
            Device::Mems16 => (-32768.0, 32767.0),
        }
    }

    /// Zero-g output, counts (the bias is drawn around it).
    pub(super) fn zero_g(self) -> f64 {
        match self {
            Device::Wiimote | Device::Nunchuk => 512.0,
            Device::Mems16 => 0.0,
        }
    }

    /// The name of the unit a count is written in: `counts`, or `m/s²` for the MEMS.
    pub fn unit_name(self) -> &'static str {
        match self {
            Device::Wiimote | Device::Nunchuk => "counts",
            Device::Mems16 => "m/s²",
        }
    }

    /// What one count is written as: 1 (counts) for the Wii devices, m/s² for the MEMS.
    pub fn unit_per_count(self) -> f64 {
        match self {
            Device::Wiimote | Device::Nunchuk => 1.0,
            Device::Mems16 => 9.80665 / 16384.0,
        }
    }

    /// The usual sample rate, Hz (the Wii Remote's reports come at 100–200 Hz).
    pub fn typical_rate_hz(self) -> f64 {
        match self {
            Device::Wiimote | Device::Nunchuk => 100.0,
            Device::Mems16 => 400.0,
        }
    }
}

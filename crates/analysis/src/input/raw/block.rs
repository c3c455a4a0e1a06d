//! What a raw file is made of, at the bottom of `raw/`: its format, its blocks (pages) decoded
//! or skipped, and the civil-date arithmetic both formats' timestamps need.
//! The readers (`cwa`, `geneactiv`) build these; `mod.rs` and `load` use them.

/// Which raw format a file is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RawFormat {
    /// Axivity `.cwa` (`MD` header block, `AX` data blocks).
    Cwa,
    /// GENEActiv `.bin` (text header starting `Device Identity`, hex-encoded pages).
    GeneActiv,
}

impl RawFormat {
    /// What the format's notes call one of its blocks ("data block", "page").
    pub(crate) fn unit(self) -> &'static str {
        match self {
            Self::Cwa => "data block",
            Self::GeneActiv => "page",
        }
    }
}

/// One decoded data block (Axivity) or page (GENEActiv).
#[derive(Debug, Clone)]
pub struct GoodBlock {
    /// Position in the file (0: the first data block).
    pub index: usize,
    /// The block's sequence number as stored (Axivity `sequenceId`, GENEActiv `Sequence Number`).
    pub sequence: u32,
    /// Time of the block's first sample, device-clock seconds (see the module docs).
    pub start_s: f64,
    /// The block's sample rate, Hz.
    pub rate_hz: f64,
    /// Sensor temperature, °C.
    pub temp_c: f64,
    /// Battery voltage, V (Axivity: `3·(b/256 + 1)`; GENEActiv: the page's value).
    pub battery_v: f64,
    /// Light: Axivity's raw 10-bit light value per block; GENEActiv's lux of the first sample.
    pub light: f64,
    /// Samples, row-major, one value a channel of the file ([`Reader::channels`](super::Reader::channels))
    /// each (g for the accelerometer, °/s for the gyroscope, raw counts for a magnetometer).
    pub data: Vec<f64>,
    /// GENEActiv: light per sample (lux); `None` for Axivity.
    pub light_per_sample: Option<Vec<f64>>,
}

impl GoodBlock {
    /// Samples in the block.
    pub fn len(&self, channels: usize) -> usize {
        self.data.len() / channels.max(1)
    }
}

/// A data block of the file: decoded, or skipped and why.
#[derive(Debug, Clone)]
pub enum Block {
    /// Decoded.
    Good(GoodBlock),
    /// Its checksum fails (bits were corrupted; nothing in it can be trusted).
    Corrupt,
    /// Checksum fine but a field is impossible (header, length, date, layout); the reason.
    Invalid(String),
}

/// Seconds since 1970-01-01 of a civil date and time (proleptic Gregorian, no time zone):
/// the days-from-civil count of H. Hinnant's date algorithms.
pub fn civil_seconds(y: i64, mo: u32, d: u32, h: u32, mi: u32, s: f64) -> f64 {
    let y = if mo <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (mo as i64 + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d as i64 - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    let days = era * 146_097 + doe - 719_468;
    days as f64 * 86_400.0 + (h * 3600 + mi * 60) as f64 + s
}

/// `s` seconds since 1970-01-01 as the civil date and time `YYYY-MM-DD hh:mm:ss` (the inverse
/// of [`civil_seconds`], whole seconds): how a block's device-clock time is named in a note.
pub fn civil_text(s: f64) -> String {
    if !s.is_finite() {
        return format!("{s} s");
    }
    let days = (s / 86_400.0).floor() as i64;
    let sod = (s - days as f64 * 86_400.0).floor() as i64;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02}",
        sod / 3600,
        sod / 60 % 60,
        sod % 60
    )
}

/// True when a civil date and time is possible (day checked against the month's length).
pub fn valid_civil(y: i64, mo: u32, d: u32, h: u32, mi: u32, s: u32) -> bool {
    let leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
    let month_days = [
        31,
        if leap { 29 } else { 28 },
        31,
        30,
        31,
        30,
        31,
        31,
        30,
        31,
        30,
        31,
    ];
    (1..=12).contains(&mo)
        && d >= 1
        && d <= month_days[(mo - 1) as usize]
        && h < 24
        && mi < 60
        && s < 60
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_seconds_match_known_instants() {
        // 2019-02-26 09:55:06 UTC is 1551174906 (date -u -d @1551174906).
        assert_eq!(civil_seconds(2019, 2, 26, 9, 55, 6.0), 1_551_174_906.0);
        assert_eq!(civil_seconds(1970, 1, 1, 0, 0, 0.0), 0.0);
        assert_eq!(civil_seconds(2000, 3, 1, 0, 0, 0.0), 951_868_800.0);
        assert_eq!(civil_text(1_551_174_906.5), "2019-02-26 09:55:06");
        assert_eq!(civil_text(951_868_800.0 - 1.0), "2000-02-29 23:59:59");
        assert_eq!(civil_text(0.0), "1970-01-01 00:00:00");
        assert!(valid_civil(2024, 2, 29, 23, 59, 59));
        assert!(!valid_civil(2023, 2, 29, 0, 0, 0));
        assert!(!valid_civil(2023, 13, 1, 0, 0, 0));
    }
}

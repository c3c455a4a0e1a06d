//! GENEActiv `.bin` files, from Activinsights' published description ("Decoding .bin files"
//! in the GENEActiv instructions): a text file of `Key:Value` lines (CR LF).
//!
//! * The file header (about 59 lines, starting `Device Identity`) gives, among others,
//!   `Device Model`, `Measurement Frequency` (`85.7 Hz`), the per-axis calibration
//!   `x gain`, `x offset`, … (g = (raw·100 − offset) / gain), `Volts` and `Lux` (lux =
//!   light·Lux/Volts) and `Number of Pages`.
//! * Each page: a `Recorded Data` line, `Key:Value` lines (`Sequence Number`,
//!   `Page Time:YYYY-MM-DD hh:mm:ss:mmm`, `Temperature` °C, `Battery voltage`,
//!   `Measurement Frequency`), then one line of hex digits, 12 per sample (300 samples): x, y, z
//!   as 12-bit two's complement (3 digits each), then 10 bits of light and a button bit and a
//!   reserved bit (3 digits).
//!
//! A page whose fields or hex digits are impossible is skipped with its reason
//! ([`Block::Invalid`]; the format has no checksum); a last page cut off by the end of the file
//! is a note (GENEActiv files copied in part end mid-page). Header lines may hold NUL padding:
//! everything is read as bytes.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` is deliberately true for NaN.
use super::{civil_seconds, valid_civil, Block, GoodBlock, RawFile, RawFormat};
use crate::error::input::InputError;

/// This module's errors are all the input stage's.
type Result<T, E = InputError> = std::result::Result<T, E>;

/// Samples in a page.
pub const PAGE_SAMPLES: usize = 300;
/// Longest line accepted, bytes (a data line is 3600 hex digits).
const MAX_LINE: usize = 8192;

/// Gains a header may declare (counts·100 per g): GENEActiv's ±8 g over 12 bits is about
/// 25 600; a gain outside this range would put the 12-bit full scale below 0.5 g or above
/// 1000 g.
const GAIN_RANGE: std::ops::RangeInclusive<f64> = 204.8..=409_600.0;
/// Largest |offset| a header may declare (counts·100: the whole 12-bit range).
const MAX_OFFSET: f64 = 204_800.0;
/// Highest rate a header or page may declare, Hz (the devices stop at 100 Hz).
const MAX_RATE_HZ: f64 = 10_000.0;
/// Temperatures a page may report, °C (the sensor's operating range with margin).
const TEMP_RANGE: std::ops::RangeInclusive<f64> = -60.0..=100.0;

/// A header's number as an error quotes it: exponent notation when huge or tiny (1e300, not
/// 301 digits).
fn shown(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e7).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// The header's calibration and declarations.
#[derive(Debug, Clone)]
struct Header {
    gain: [f64; 3],
    offset: [f64; 3],
    lux_per_volt: f64,
    rate_hz: f64,
    pages: Option<usize>,
    model: String,
}

fn field<'a>(line: &'a [u8], key: &str) -> Option<&'a str> {
    let line = std::str::from_utf8(line).ok()?;
    let (k, v) = line.split_once(':')?;
    (k.trim() == key).then(|| v.trim_matches(|c: char| c.is_whitespace() || c == '\0'))
}

/// First number in `v` (`85.7 Hz` → 85.7).
fn number(v: &str) -> Option<f64> {
    v.split_whitespace()
        .next()?
        .parse::<f64>()
        .ok()
        .filter(|x| x.is_finite())
}

fn read_header(lines: &[&[u8]]) -> Result<Header> {
    let err = |why: String| InputError::RawHeader {
        format: "GENEActiv .bin",
        why,
    };
    let find = |key: &str| lines.iter().find_map(|l| field(l, key));
    let num = |key: &str| {
        find(key)
            .and_then(number)
            .ok_or_else(|| err(format!("no number in its header line '{key}'")))
    };
    let mut gain = [0.0; 3];
    let mut offset = [0.0; 3];
    for (k, a) in ["x", "y", "z"].iter().enumerate() {
        gain[k] = num(&format!("{a} gain"))?;
        offset[k] = num(&format!("{a} offset"))?;
        if !(GAIN_RANGE.contains(&gain[k]) && offset[k].abs() <= MAX_OFFSET) {
            return Err(err(format!(
                "{a} gain {} or offset {} is impossible (a gain of {}…{} and an offset within ±{MAX_OFFSET} are)",
                shown(gain[k]),
                shown(offset[k]),
                GAIN_RANGE.start(),
                GAIN_RANGE.end()
            )));
        }
    }
    let volts = num("Volts")?;
    let rate_hz = num("Measurement Frequency")?;
    if !(rate_hz > 0.0 && rate_hz <= MAX_RATE_HZ && volts > 0.0) {
        return Err(err(format!(
            "the measurement frequency ({} Hz) must be in (0, {MAX_RATE_HZ}] Hz and Volts ({}) positive",
            shown(rate_hz),
            shown(volts)
        )));
    }
    Ok(Header {
        gain,
        offset,
        lux_per_volt: num("Lux")? / volts,
        rate_hz,
        pages: find("Number of Pages")
            .and_then(number)
            .map(|p| p.max(0.0) as usize),
        model: find("Device Model").unwrap_or("").to_string(),
    })
}

/// Reads a whole GENEActiv `.bin` file.
pub fn parse(bytes: &[u8]) -> Result<RawFile> {
    let lines: Vec<&[u8]> = bytes
        .split(|&c| c == b'\n')
        .map(|l| l.strip_suffix(b"\r").unwrap_or(l))
        .collect();
    let first_page = lines
        .iter()
        .position(|l| *l == b"Recorded Data")
        .unwrap_or(lines.len());
    let header = read_header(&lines[..first_page])?;
    let ends_cut = !bytes.ends_with(b"\n");
    let mut blocks = Vec::new();
    let mut notes = Vec::new();
    let mut i = first_page;
    while i < lines.len() {
        if lines[i] != b"Recorded Data" {
            i += 1;
            continue;
        }
        let next = (i + 1..lines.len())
            .find(|&j| lines[j] == b"Recorded Data")
            .unwrap_or(lines.len());
        let index = blocks.len();
        let last_and_cut = next == lines.len() && ends_cut;
        match decode_page(&lines[i + 1..next], index, &header) {
            Ok(p) if p.len(3) == PAGE_SAMPLES || !last_and_cut => blocks.push(Block::Good(p)),
            Ok(p) => notes.push(cut_note(index, p.len(3))),
            Err(_) if last_and_cut => notes.push(cut_note(index, 0)),
            Err(why) => blocks.push(Block::Invalid(why)),
        }
        i = next;
    }
    Ok(RawFile {
        format: RawFormat::GeneActiv,
        device: format!("GENEActiv {}", header.model).trim().to_string(),
        channels: ["ax", "ay", "az"].iter().map(|s| s.to_string()).collect(),
        header_rate_hz: header.rate_hz,
        blocks,
        declared_blocks: header.pages,
        notes,
    })
}

fn cut_note(index: usize, samples: usize) -> String {
    format!(
        "the file is cut short in page #{index} ({samples} of {PAGE_SAMPLES} samples complete): that page is not read"
    )
}

/// `Page Time:2013-05-30 10:12:54:500` → device-clock seconds.
fn page_time(v: &str) -> Option<f64> {
    let (date, time) = v.trim().split_once(' ')?;
    let d: Vec<u32> = date
        .split('-')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    let t: Vec<u32> = time
        .split(':')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    let (&[y, mo, d], &[h, mi, s, ms]) = (d.as_slice(), t.as_slice()) else {
        return None;
    };
    (valid_civil(y.into(), mo, d, h, mi, s) && ms < 1000).then(|| {
        civil_seconds(
            y.into(),
            mo,
            d,
            h,
            mi,
            f64::from(s) + f64::from(ms) / 1000.0,
        )
    })
}

/// 12-bit two's complement of three hex digits.
fn hex3(d: &[u8]) -> Option<i32> {
    let s = std::str::from_utf8(d).ok()?;
    u16::from_str_radix(s, 16).ok().map(i32::from)
}

fn decode_page(
    lines: &[&[u8]],
    index: usize,
    h: &Header,
) -> std::result::Result<GoodBlock, String> {
    let get = |key: &str| lines.iter().find_map(|l| field(l, key));
    let start_s = get("Page Time")
        .and_then(page_time)
        .ok_or("no valid 'Page Time'")?;
    let temp_c = get("Temperature")
        .and_then(number)
        .ok_or("no 'Temperature'")?;
    if !TEMP_RANGE.contains(&temp_c) {
        return Err(format!(
            "temperature {} °C is impossible ({}…{} °C)",
            shown(temp_c),
            TEMP_RANGE.start(),
            TEMP_RANGE.end()
        ));
    }
    let rate_hz = get("Measurement Frequency")
        .and_then(number)
        .filter(|r| *r > 0.0)
        .unwrap_or(h.rate_hz);
    if rate_hz > MAX_RATE_HZ {
        return Err(format!(
            "measurement frequency {} Hz is impossible",
            shown(rate_hz)
        ));
    }
    let sequence = get("Sequence Number")
        .and_then(number)
        .map_or(0, |v| v.clamp(0.0, u32::MAX as f64) as u32);
    let hex = lines
        .iter()
        .find(|l| !l.is_empty() && !l.contains(&b':'))
        .ok_or("no data line")?;
    if hex.len() > MAX_LINE {
        return Err(format!("a data line of {} bytes", hex.len()));
    }
    let mut data = Vec::with_capacity(3 * PAGE_SAMPLES);
    let mut lux = Vec::with_capacity(PAGE_SAMPLES);
    for s in hex.chunks_exact(12) {
        for k in 0..3 {
            let raw = hex3(&s[3 * k..3 * k + 3]).ok_or("a sample that is not hex digits")?;
            let raw = if raw >= 2048 { raw - 4096 } else { raw };
            data.push((f64::from(raw) * 100.0 - h.offset[k]) / h.gain[k]);
        }
        let light = hex3(&s[9..12]).ok_or("a sample that is not hex digits")? >> 2;
        lux.push(f64::from(light) * h.lux_per_volt);
    }
    Ok(GoodBlock {
        index,
        sequence,
        start_s,
        rate_hz,
        temp_c,
        battery_v: get("Battery voltage").and_then(number).unwrap_or(f64::NAN),
        light: lux.first().copied().unwrap_or(f64::NAN),
        data,
        light_per_sample: Some(lux),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "Device Identity\r\nDevice Model:1.1  \r\nMeasurement Frequency:50 Hz\r\nx gain:25600\r\nx offset:0\r\ny gain:25600\r\ny offset:-256\r\nz gain:25600\r\nz offset:0\r\nVolts:300\r\nLux:800\r\nNumber of Pages:9\r\n";

    fn page(time: &str, hex: &str) -> String {
        format!("Recorded Data\r\nSequence Number:0\r\nPage Time:{time}\r\nTemperature:21.5\r\nMeasurement Frequency:50\r\n{hex}\r\n")
    }

    #[test]
    fn a_page_decodes_calibration_time_and_light() {
        // x = 0x100 = 256 → 256·100/25600 = 1 g; y = 0xfff = −1 → (−100 + 256)/25600;
        // z = 0x800 = −2048 → −8 g; light 0x00c >> 2 = 3 → 3·800/300 lux.
        let hex = "100fff80000c".repeat(PAGE_SAMPLES);
        let text = format!("{HEADER}{}", page("2013-05-30 10:12:54:500", &hex));
        let raw = parse(text.as_bytes()).unwrap();
        let b = raw.good().next().unwrap();
        assert_eq!(&b.data[..3], &[1.0, 156.0 / 25600.0, -8.0]);
        assert_eq!(b.light_per_sample.as_ref().unwrap()[0], 8.0);
        assert_eq!(b.start_s, civil_seconds(2013, 5, 30, 10, 12, 54.5));
        assert_eq!(raw.declared_blocks, Some(9));
        assert_eq!(raw.device, "GENEActiv 1.1");
    }

    #[test]
    fn bad_and_cut_pages_are_skipped() {
        let hex = "100fff80000c".repeat(PAGE_SAMPLES);
        let mut text = format!(
            "{HEADER}{}{}",
            page("2013-05-30 10:12:54:500", &"zz".repeat(6)),
            page("2013-05-30 10:12:58:000", &hex)
        );
        text.push_str("Recorded Data\r\nPage Time:2013-05-30 10:13:02:000\r\n100f");
        let raw = parse(text.as_bytes()).unwrap();
        assert_eq!(raw.invalid_blocks().len(), 1);
        assert_eq!(raw.good().count(), 1);
        assert!(raw.notes[0].contains("page #2"), "{:?}", raw.notes);
        let e = parse(b"Device Identity\r\nx gain:0\r\nx offset:1\r\n").unwrap_err();
        assert!(e.to_string().contains("x gain"), "{e}");
    }
}

#[cfg(test)]
mod plausibility {
    use super::tests_support::*;
    use super::*;

    /// Header gains, offsets, rates and page temperatures beyond any device are refused by
    /// name (a header of 1e300 must not turn into samples of 1e-296 g).
    #[test]
    fn impossible_header_and_page_values_are_refused() {
        let hex = "100fff80000c".repeat(PAGE_SAMPLES);
        let page = page_at("2013-05-30 10:12:54:500", "21.5", &hex);
        for (from, to, want) in [
            ("x gain:25600", "x gain:1e300", "x gain 1e300"),
            (
                "y offset:-256",
                "y offset:1e300",
                "y gain 25600 or offset 1e300",
            ),
            (
                "Frequency:50 Hz",
                "Frequency:1e300 Hz",
                "measurement frequency",
            ),
            ("Volts:300", "Volts:-3", "Volts (-3)"),
        ] {
            let text = format!("{}{page}", HEADER.replace(from, to));
            let e = parse(text.as_bytes()).unwrap_err().to_string();
            assert!(e.contains(want), "{to}: {e}");
        }
        let text = format!(
            "{HEADER}{}",
            page_at("2013-05-30 10:12:54:500", "1e300", &hex)
        );
        let raw = parse(text.as_bytes()).unwrap();
        let (_, why) = raw.invalid_blocks()[0];
        assert!(why.contains("temperature 1e300 °C is impossible"), "{why}");
        // The real device's values pass.
        let text = format!("{HEADER}{page}");
        assert_eq!(parse(text.as_bytes()).unwrap().good().count(), 1);
    }
}

#[cfg(test)]
mod tests_support {
    pub(super) const HEADER: &str = "Device Identity\r\nDevice Model:1.1  \r\nMeasurement Frequency:50 Hz\r\nx gain:25600\r\nx offset:0\r\ny gain:25600\r\ny offset:-256\r\nz gain:25600\r\nz offset:0\r\nVolts:300\r\nLux:800\r\nNumber of Pages:9\r\n";

    pub(super) fn page_at(time: &str, temp: &str, hex: &str) -> String {
        format!("Recorded Data\r\nSequence Number:0\r\nPage Time:{time}\r\nTemperature:{temp}\r\nMeasurement Frequency:50\r\n{hex}\r\n")
    }
}

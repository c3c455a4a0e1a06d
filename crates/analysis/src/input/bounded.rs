//! Reading one numeric field with bounds, its errors naming the line and column (shared by
//! every file format's reader), and the most samples a command holds. The file reads with
//! bounds (size caps, gzip, UTF-8, line lengths) are `wiical-io`'s, re-exported here.

pub use wiical_io::bounded::*;

use crate::error::input::InputError;
use crate::error::Result;

/// Longest piece of a field quoted back in an error message, characters.
pub const MAX_QUOTED_CHARS: usize = 40;

/// `text` as quoted in an error message: at most [`MAX_QUOTED_CHARS`] characters, control
/// characters escaped, with the full length said when it was cut (a 10 MB bad field must not
/// be echoed whole).
pub fn quote(text: &str) -> String {
    quote_at_most(text, MAX_QUOTED_CHARS)
}

/// A header line as quoted in an error message (longer than a field, still bounded).
pub fn quote_header(text: &str) -> String {
    quote_at_most(text, 5 * MAX_QUOTED_CHARS)
}

fn quote_at_most(text: &str, max: usize) -> String {
    let count = text.chars().count();
    let shown: String = text
        .chars()
        .take(max)
        .flat_map(char::escape_debug)
        .collect();
    if count > max {
        format!("{shown}… ({count} characters)")
    } else {
        shown
    }
}

/// A decimal number as Rust's `str::parse::<f64>` reads it (correctly rounded; `inf`, `nan`
/// accepted here and refused as not finite by the caller), by `fast-float2`. Whitespace or
/// anything after the number is refused.
pub(crate) fn parse_f64(s: &[u8]) -> Option<f64> {
    fast_float2::parse::<f64, _>(s).ok()
}

/// Parses one field. Callers hand over fields already free of surrounding blanks (split on
/// ASCII whitespace, or trimmed by the CSV reader). With `decimal_comma` one `,` is the
/// decimal separator. Quoted text in errors is cut to a readable length.
pub(crate) fn parse_number(s: &str, line_no: usize, col: &str, decimal_comma: bool) -> Result<f64> {
    let parsed = if decimal_comma && s.contains(',') {
        if s.matches(',').count() == 1 && !s.contains('.') {
            parse_f64(s.replacen(',', ".", 1).as_bytes()).ok_or(())
        } else {
            Err(())
        }
    } else {
        parse_f64(s.as_bytes()).ok_or(())
    };
    let v = parsed.map_err(|_| InputError::NotANumber {
        line: line_no,
        column: quote(col),
        text: quote(s),
    })?;
    if v.is_infinite() && written_as_digits(s) {
        return Err(InputError::BeyondDouble {
            line: line_no,
            column: quote(col),
            text: quote(s),
        }
        .into());
    }
    if !v.is_finite() {
        return Err(InputError::NotFinite {
            line: line_no,
            column: quote(col),
            text: quote(s),
        }
        .into());
    }
    Ok(v)
}

/// True when `s` spells a number with digits (as `1e309` does), not `inf`/`Infinity`/`NaN`:
/// such a field that reads as infinite overflowed a double.
fn written_as_digits(s: &str) -> bool {
    s.bytes().any(|b| b.is_ascii_digit())
        && !s
            .bytes()
            .any(|b| b.is_ascii_alphabetic() && !matches!(b, b'e' | b'E'))
}

/// Largest magnitude a sensor reading may have. No sensor in any unit reports 10¹² (a 32-bit
/// counter is 4·10⁹); values beyond are a corrupt cell, and squares of them (10²⁴, summed over
/// windows) would lose every digit of the noise the detector measures.
pub(crate) const MAX_READING: f64 = 1e12;

/// The largest reading of a recording must reach this (any unit: 1 nano-g, 1 count): below it
/// every reading is numerically zero next to rounding and no pose can be told from another.
pub(crate) const MIN_FULL_SCALE: f64 = 1e-9;

/// Highest sample rate a recording or `--rate-hz` may state (1 MHz; inertial sensors stop at
/// a few kHz).
pub const MAX_RATE_HZ: f64 = 1e6;

/// Lowest sample rate a recording or `--rate-hz` may state (one sample per 1000 s: below it
/// no inertial recording exists, and the averaging times and windows it implies are absurd).
pub const MIN_RATE_HZ: f64 = 1e-3;

/// A sensor reading (axis or temperature): a finite number of magnitude at most
/// [`MAX_READING`], else an error naming the line and column.
pub(crate) fn parse_reading(
    s: &str,
    line_no: usize,
    col: &str,
    decimal_comma: bool,
) -> Result<f64> {
    let v = parse_number(s, line_no, col, decimal_comma)?;
    if v.abs() > MAX_READING {
        return Err(InputError::ReadingOutOfRange {
            line: line_no,
            column: quote(col),
            text: quote(s),
        }
        .into());
    }
    Ok(v)
}

/// Refuses a recording whose readings are all numerically zero (largest |value| below
/// [`MIN_FULL_SCALE`]): a unit error (e.g. a scale applied twice), not a sensor.
pub(crate) fn check_reading_scale(xyz: &[[f64; 3]]) -> Result<()> {
    // The first reading of full scale ends the scan (in a recording, the first row); the
    // largest is looked for only to be named.
    if xyz.is_empty() || xyz.iter().flatten().any(|v| v.abs() >= MIN_FULL_SCALE) {
        return Ok(());
    }
    let largest = xyz.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    check_largest_reading(true, largest)
}

/// [`check_reading_scale`] given its fold: `any` sample, the `largest` |value|.
pub(crate) fn check_largest_reading(any: bool, largest: f64) -> Result<()> {
    if any && largest < MIN_FULL_SCALE {
        return Err(InputError::ReadingsTooSmall { largest }.into());
    }
    Ok(())
}

/// The most samples a command that holds its whole recording (`magfit`, `tempcal`, `gyrofit`,
/// `six-position`, `correct` of a raw file) loads: 2²² (11.6 h at 100 Hz), about 170 MB as
/// held (40 B a sample: time, x, y, z, temperature) and at most twice that while read.
/// Why: a 2.5 MB `.gz` holding 1 GB of rows, or a 300 MB `.cwa`, took 1–3.8 GB in those
/// commands; the commands that read in passes (`fit`, `analyze`, `correct` of text, `noise`)
/// have no such bound.
pub const MAX_HELD_SAMPLES: usize = 1 << 22;

/// The bound `front_door::load_held` reads within, and the sentence's parts.
#[derive(Debug, Clone, Copy)]
pub struct HoldLimit {
    /// At most this many samples.
    pub samples: usize,
    /// The command holding them (`magfit`).
    pub command: &'static str,
    /// What reads such a file instead (the end of the sentence).
    pub instead: &'static str,
}

impl HoldLimit {
    /// [`MAX_HELD_SAMPLES`] for `command`.
    pub fn of(command: &'static str, instead: &'static str) -> Self {
        Self {
            samples: MAX_HELD_SAMPLES,
            command,
            instead,
        }
    }

    /// The refusal when `n` samples are more than the bound.
    pub(crate) fn check(&self, n: usize) -> std::result::Result<(), InputError> {
        if n > self.samples {
            Err(InputError::TooManyToHold {
                limit: self.samples,
                command: self.command,
                instead: self.instead,
            })
        } else {
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_f64_reads_as_str_parse_does() {
        let cases = [
            "0",
            "-0",
            "509",
            "24.68",
            "-0.80836403369903564",
            "0.1",
            "1.",
            ".5",
            "-.5",
            "+3.25",
            "123456789012345",
            "1234567890123456",
            "9007199254740993",
            "0.000000000000001",
            "99999.9999999999",
            "1e3",
            "inf",
            "NaN",
            "-",
            ".",
            "1.2.3",
            "",
            "1,5",
            " 1",
        ];
        for c in cases {
            let want = c.parse::<f64>().ok();
            let got = parse_f64(c.as_bytes());
            assert_eq!(
                got.map(f64::to_bits),
                want.map(f64::to_bits),
                "{c:?}: {got:?} vs {want:?}"
            );
        }
        // A sweep of short decimals, bit for bit.
        for i in (-200_000i64..200_000).step_by(7) {
            for d in 0..6 {
                let c = format!("{}.{:0d$}", i / 1000, (i % 1000).unsigned_abs(), d = d);
                let want = c.parse::<f64>().ok().map(f64::to_bits);
                assert_eq!(parse_f64(c.as_bytes()).map(f64::to_bits), want, "{c}");
            }
        }
    }

    /// The windowed scan names the line a line-by-line count names: the first line over the
    /// limit, its length, at every position and length around the limit.
    #[test]
    fn quote_cuts_long_fields_and_escapes_controls() {
        assert_eq!(quote("abc"), "abc");
        assert_eq!(quote("a\tb"), "a\\tb");
        let long = "9".repeat(10_000_000);
        let q = quote(&long);
        assert!(q.len() < 80, "{q}");
        assert!(q.ends_with("… (10000000 characters)"), "{q}");
    }
}

//! The text `wiical decode-cal` prints: a factory calibration block's values and whether its
//! checksum holds.

use anyhow::Result;
use std::fmt::Write as _;
use wiical_factory::{DecodeCalReport, MotionPlusFactory};

/// A Wii Remote / Nunchuk accelerometer block: zero-g, one-g, counts per g, checksum.
pub fn block_text(rep: &DecodeCalReport) -> Result<String> {
    let mut o = String::new();
    writeln!(o, "{} calibration block", rep.device)?;
    writeln!(o, "  zero-g (10-bit):  {:?}", rep.zero)?;
    writeln!(o, "  one-g  (10-bit):  {:?}", rep.one_g)?;
    writeln!(o, "  counts per g:     {:?}", rep.counts_per_g)?;
    writeln!(o, "  checksum:         {}", ok_or_bad(rep.checksum_ok))?;
    Ok(o)
}

/// The MotionPlus gyro block: both ranges (zero, reference reading, counts per °/s), the
/// UID and the CRC-32 check.
pub fn motionplus_text(rep: &MotionPlusFactory) -> Result<String> {
    let mut o = String::new();
    writeln!(o, "motionplus calibration block (yaw, roll, pitch)")?;
    for (name, r) in [("fast", &rep.fast), ("slow", &rep.slow)] {
        writeln!(
            o,
            "  {name}: zero {:?}, reading at {} °/s {:?}",
            r.zero, r.degrees, r.scale
        )?;
        match r.counts_per_dps {
            Some(c) => writeln!(
                o,
                "        14-bit counts per °/s: {:.3} {:.3} {:.3}",
                c[0], c[1], c[2]
            )?,
            None => writeln!(o, "        reference rate 0: no sensitivity")?,
        }
    }
    writeln!(o, "  uid: {:02X} {:02X}", rep.uid[0], rep.uid[1])?;
    writeln!(o, "  CRC-32:   {}", ok_or_bad(rep.checksum_ok))?;
    Ok(o)
}

fn ok_or_bad(ok: bool) -> &'static str {
    if ok {
        "ok"
    } else {
        "BAD"
    }
}

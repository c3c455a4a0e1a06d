//! `wiical decode-cal`: a factory calibration block.

use super::to_json;
use crate::render;
use anyhow::{bail, Result};
use std::io::Write as _;
use wiical_factory as factory;

/// Arguments of `wiical decode-cal`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// wiimote | nunchuk | motionplus.
    #[arg(long)]
    pub device: String,
    /// The bytes, e.g. "82 82 82 15 9C 9C 9E 38 40 3E" (spaces, commas, 0x prefixes allowed).
    #[arg(num_args = 1.., required = true)]
    pub hex: Vec<String>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs `wiical decode-cal`; returns what to print. A block whose checksum fails (in every
/// copy given) is still decoded and printed, but the command then fails (exit status 1), so
/// that a script does not take a corrupt block for a good one.
pub fn run(a: &Args) -> Result<String> {
    let device: factory::Device = a.device.parse().map_err(anyhow::Error::new)?;
    let (text, checksum_ok, name) = match device {
        factory::Device::MotionPlus => {
            let (text, ok) = motionplus(a)?;
            (text, ok, "motionplus".to_string())
        }
        _ => {
            let rep = factory::decode_cal(&a.device, &a.hex.join(" "))?;
            (render(a, &rep)?, rep.checksum_ok, rep.device.clone())
        }
    };
    if checksum_ok {
        return Ok(text);
    }
    let mut stdout = std::io::stdout().lock();
    stdout.write_all(text.as_bytes())?;
    stdout.flush()?;
    bail!(
        "the {name} calibration block's checksum is wrong (in every copy given): the values above are not trustworthy"
    )
}

fn render(a: &Args, rep: &factory::DecodeCalReport) -> Result<String> {
    if a.json {
        return to_json(rep);
    }
    render::decode_cal::block_text(rep)
}

/// The MotionPlus's 32-byte gyro calibration block (`0xA60020`–`0xA6003F`, read while the
/// MotionPlus is inactive): both ranges, their sensitivities and the CRC-32 check.
fn motionplus(a: &Args) -> Result<(String, bool)> {
    let bytes = factory::parse_hex(&a.hex.join(" "))?;
    let rep = factory::motionplus_calibration(&bytes, None)?;
    if a.json {
        return Ok((to_json(&rep)?, rep.checksum_ok));
    }
    Ok((render::decode_cal::motionplus_text(&rep)?, rep.checksum_ok))
}

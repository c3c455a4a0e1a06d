//! `cargo xtask firmware`: the chip, the release build, its flash and RAM use against the
//! budgets, and the drag-and-drop UF2 image (the emulator boots the RP2040's).

use std::path::PathBuf;
use std::process::Command;

use crate::tools::{cargo, ensure_target, root, run, Result};
use crate::{elfsize, uf2};

/// The embedded target of the RP2350 (Cortex-M33 with FPU), also QEMU's `mps2-an505` core.
pub(crate) const TARGET: &str = "thumbv8m.main-none-eabihf";
/// The embedded target of the RP2040 (Cortex-M0+), for `firmware --chip rp2040`.
pub(crate) const TARGET_RP2040: &str = "thumbv6m-none-eabi";
/// Firmware budgets from the project brief (the same for both chips).
const FLASH_BUDGET: u64 = 128 * 1024;
const RAM_BUDGET: u64 = 32 * 1024;

/// The chip the firmware is built for: a cargo feature of `firmware/` and its target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Chip {
    /// Raspberry Pi Pico 2: feature `rp2350` (the firmware's default), [`TARGET`].
    Rp2350,
    /// Raspberry Pi Pico: feature `rp2040`, [`TARGET_RP2040`].
    Rp2040,
}

impl Chip {
    fn name(self) -> &'static str {
        match self {
            Chip::Rp2350 => "rp2350",
            Chip::Rp2040 => "rp2040",
        }
    }

    pub(crate) fn target(self) -> &'static str {
        match self {
            Chip::Rp2350 => TARGET,
            Chip::Rp2040 => TARGET_RP2040,
        }
    }

    /// What this chip's boot ROM expects of a UF2 file.
    fn uf2_target(self) -> uf2::Target {
        match self {
            Chip::Rp2350 => uf2::Target::RP2350,
            Chip::Rp2040 => uf2::Target::RP2040,
        }
    }

    /// The drag-and-drop image `cargo xtask firmware` writes (the emulator boots the RP2040's).
    pub(crate) fn uf2_path(self) -> PathBuf {
        root()
            .join("target/uf2")
            .join(format!("wiical-adapter-{}.uf2", self.name()))
    }
}

/// Parses the options of `firmware`: nothing, or `--chip rp2350|rp2040` (also `--chip=…`).
pub(crate) fn parse_chip(args: &[String]) -> Result<Chip> {
    let value = match args {
        [] => return Ok(Chip::Rp2350),
        [flag, value] if flag == "--chip" => value.as_str(),
        [flag] if flag.starts_with("--chip=") => &flag["--chip=".len()..],
        _ => return Err(format!("firmware: unexpected arguments {args:?}")),
    };
    match value {
        "rp2350" => Ok(Chip::Rp2350),
        "rp2040" => Ok(Chip::Rp2040),
        other => Err(format!(
            "firmware: unknown chip `{other}` (expected rp2350 or rp2040)"
        )),
    }
}

pub(crate) fn firmware(chip: Chip) -> Result<bool> {
    let target = chip.target();
    ensure_target(target)?;
    let dir = root().join("firmware");
    // The chip feature and the target are given explicitly, so the result does not depend on
    // `.cargo/config.toml`'s build target. The RP2350 keeps the default features (it is the
    // default chip), so this build shares its artifacts with a plain `cargo build --release`.
    let mut build = Command::new(cargo());
    build.current_dir(&dir).args(["build", "--release"]);
    if chip != Chip::Rp2350 {
        build.arg("--no-default-features");
    }
    build.args(["--features", chip.name(), "--target", target]);
    run(&mut build)?;
    let elf = dir
        .join("target")
        .join(target)
        .join("release")
        .join("wiical-firmware");
    let data = std::fs::read(&elf).map_err(|e| format!("cannot read {}: {e}", elf.display()))?;
    let sizes = elfsize::measure(&data)?;
    println!("{} ({})", elf.display(), chip.name());
    println!("{sizes}");
    let flash_ok = sizes.flash() <= FLASH_BUDGET;
    let ram_ok = sizes.ram() <= RAM_BUDGET;
    let verdict = |ok: bool| if ok { "met" } else { "MISSED" };
    println!(
        "flash {} B = {:.1} KiB (budget 128 KiB: {}), static RAM {} B = {:.1} KiB (budget 32 KiB: {})",
        sizes.flash(),
        sizes.flash() as f64 / 1024.0,
        verdict(flash_ok),
        sizes.ram(),
        sizes.ram() as f64 / 1024.0,
        verdict(ram_ok)
    );
    write_uf2(chip, &data)?;
    Ok(flash_ok && ram_ok)
}

/// Writes the chip's UF2 image of the firmware ELF `elf` (atomically: a temporary file renamed
/// over the old image), reads it back to check the round trip, and prints what it holds.
fn write_uf2(chip: Chip, elf: &[u8]) -> Result<()> {
    let target = chip.uf2_target();
    let pages = uf2::pages_from_elf(elf, target).map_err(|e| format!("UF2: {e}"))?;
    let bytes = uf2::encode(&pages, target);
    let back = uf2::decode(&bytes, target.family_id).map_err(|e| format!("UF2 read-back: {e}"))?;
    if back.pages != pages {
        return Err("UF2 read-back: the pages differ from the ELF's".into());
    }
    let path = chip.uf2_path();
    let dir = path.parent().ok_or("UF2 path has no directory")?;
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let tmp = path.with_extension("uf2.tmp");
    std::fs::write(&tmp, &bytes).map_err(|e| format!("cannot write {}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, &path)
        .map_err(|e| format!("cannot rename {} to {}: {e}", tmp.display(), path.display()))?;
    let (first, last) = match (pages.keys().next(), pages.keys().next_back()) {
        (Some(&f), Some(&l)) => (f, l + uf2::PAGE),
        _ => return Err("UF2: no pages".into()),
    };
    let e10 = match back.e10_block {
        Some(addr) => format!(
            " + 1 RP2350-E10 block (family {:#010x} absolute, at {addr:#010x})",
            uf2::ABSOLUTE_FAMILY_ID
        ),
        None => String::new(),
    };
    println!(
        "{}: {} B = {:.1} KiB, {} blocks of 256 B at {first:#010x}..{last:#010x}{e10}, family {:#010x}",
        path.display(),
        bytes.len(),
        bytes.len() as f64 / 1024.0,
        pages.len(),
        target.family_id
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(a: &[&str]) -> Vec<String> {
        a.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn chip_option_is_parsed_exactly() {
        assert_eq!(parse_chip(&args(&[])), Ok(Chip::Rp2350));
        assert_eq!(parse_chip(&args(&["--chip", "rp2040"])), Ok(Chip::Rp2040));
        assert_eq!(parse_chip(&args(&["--chip", "rp2350"])), Ok(Chip::Rp2350));
        assert_eq!(parse_chip(&args(&["--chip=rp2040"])), Ok(Chip::Rp2040));
        assert!(parse_chip(&args(&["--chip"])).is_err());
        assert!(parse_chip(&args(&["--chip", "rp2040x"])).is_err());
        assert!(parse_chip(&args(&["--chip", "RP2040"])).is_err());
        assert!(parse_chip(&args(&["rp2040"])).is_err());
        assert!(parse_chip(&args(&["--chip", "rp2040", "--chip", "rp2350"])).is_err());
        assert_eq!(Chip::Rp2040.target(), "thumbv6m-none-eabi");
        assert_eq!(Chip::Rp2350.target(), "thumbv8m.main-none-eabihf");
    }
}

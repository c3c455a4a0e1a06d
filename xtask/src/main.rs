//! `cargo xtask`: project tasks that need more than cargo.
//!
//! | command | what |
//! |---|---|
//! | `cargo xtask qemu` | runs the core's test vectors on an emulated Cortex-M33 (QEMU `mps2-an505`) and compares them with the host's; ends with `N passed, M failed` |
//! | `cargo xtask qemu-bench` | deterministic instruction counts (`-icount shift=0`) and peak stack of the on-device operations |
//! | `cargo xtask firmware [--chip rp2350\|rp2040]` | builds the release firmware for that chip (default RP2350), prints its flash and static RAM use (fails over 128 KiB / 32 KiB) and writes the drag-and-drop image `target/uf2/wiical-adapter-<chip>.uf2` |
//! | `cargo xtask emulate [SCENARIO…]` | boots the RP2040 firmware's UF2 image in rp2040js with a simulated Nunchuk, Wii Remote and USB host (`emulator/`); one line per scenario, then `N passed, M failed` |
//!
//! Each installs what it is missing first: the rustup target (`thumbv8m.main-none-eabihf`, or
//! `thumbv6m-none-eabi` for the RP2040 firmware) and,
//! for the QEMU commands, Debian's `qemu-system-arm` (through `apt-get`, with `sudo` when not
//! root). `qemu-tests/` and `firmware/` are separate cargo workspaces (their own target and
//! `.cargo/config.toml`); this program builds them with their own configuration.

mod elfsize;
mod emulate;
mod uf2;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// The embedded target of the RP2350 (Cortex-M33 with FPU), also QEMU's `mps2-an505` core.
const TARGET: &str = "thumbv8m.main-none-eabihf";
/// How long one QEMU run may take before it is killed.
const QEMU_TIMEOUT: Duration = Duration::from_secs(300);
/// The embedded target of the RP2040 (Cortex-M0+), for `firmware --chip rp2040`.
const TARGET_RP2040: &str = "thumbv6m-none-eabi";
/// Firmware budgets from the project brief (the same for both chips).
const FLASH_BUDGET: u64 = 128 * 1024;
const RAM_BUDGET: u64 = 32 * 1024;

const USAGE: &str = "\
usage: cargo xtask <command>

commands:
  qemu        run the core's test vectors on QEMU (Cortex-M33, mps2-an505)
  qemu-bench  instruction counts and peak stack on QEMU (-icount shift=0)
  firmware [--chip rp2350|rp2040]
              build the release firmware for that chip (default rp2350), print its
              flash and static RAM use, write target/uf2/wiical-adapter-<chip>.uf2
  emulate [SCENARIO...]
              boot the RP2040 firmware's UF2 in rp2040js (emulator/) against a simulated
              Nunchuk, Wii Remote and the wiical CLI; all scenarios by default
";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("qemu") => qemu_tests(),
        Some("qemu-bench") => qemu_bench(),
        Some("firmware") => match parse_chip(&args[1..]) {
            Ok(chip) => firmware(chip),
            Err(e) => {
                eprintln!("xtask: {e}");
                eprint!("{USAGE}");
                return ExitCode::from(2);
            }
        },
        Some("emulate") => emulate::emulate(&args[1..]),
        Some("emulate-correct") => emulate::correct(&args[1..]),
        Some("help" | "-h" | "--help") => {
            print!("{USAGE}");
            Ok(true)
        }
        _ => {
            eprint!("{USAGE}");
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}

pub(crate) type Result<T> = std::result::Result<T, String>;

/// The workspace root (this crate lives in `<root>/xtask`).
pub(crate) fn root() -> PathBuf {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest.parent().unwrap_or(manifest).to_path_buf()
}

/// Runs a command to completion, inheriting stdio; error if it cannot start or fails.
pub(crate) fn run(cmd: &mut Command) -> Result<()> {
    let shown = format!("{cmd:?}");
    let status = cmd
        .status()
        .map_err(|e| format!("cannot run {shown}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("{shown} failed ({status})"))
    }
}

/// Adds the rustup target if it is not installed.
fn ensure_target(target: &str) -> Result<()> {
    let out = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .map_err(|e| format!("cannot run rustup: {e}"))?;
    let installed = String::from_utf8_lossy(&out.stdout);
    if installed.lines().any(|l| l.trim() == target) {
        return Ok(());
    }
    eprintln!("xtask: installing the rustup target {target}");
    run(Command::new("rustup").args(["target", "add", target]))
}

fn have(program: &str, arg: &str) -> bool {
    Command::new(program)
        .arg(arg)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Installs Debian's `qemu-system-arm` if the program is missing.
fn ensure_qemu() -> Result<()> {
    if have("qemu-system-arm", "--version") {
        return Ok(());
    }
    eprintln!("xtask: qemu-system-arm is missing; installing it with apt-get");
    let is_root = Command::new("id")
        .arg("-u")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
        .unwrap_or(false);
    let apt = |args: &[&str]| -> Result<()> {
        let mut cmd = if is_root {
            Command::new("apt-get")
        } else {
            let mut c = Command::new("sudo");
            c.arg("apt-get");
            c
        };
        cmd.args(args).env("DEBIAN_FRONTEND", "noninteractive");
        run(&mut cmd)
    };
    apt(&["update", "-qq"])?;
    apt(&["install", "-y", "-qq", "qemu-system-arm"])?;
    if have("qemu-system-arm", "--version") {
        Ok(())
    } else {
        Err("qemu-system-arm is still missing after apt-get install".into())
    }
}

/// Builds one binary of `qemu-tests/` (release) and returns the ELF's path.
fn build_qemu_bin(bin: &str) -> Result<PathBuf> {
    let dir = root().join("qemu-tests");
    run(Command::new(cargo())
        .current_dir(&dir)
        .args(["build", "--release", "--bin", bin]))?;
    Ok(dir.join("target").join(TARGET).join("release").join(bin))
}

/// The cargo that runs us (so that the same toolchain builds the embedded crates).
pub(crate) fn cargo() -> String {
    std::env::var("CARGO").unwrap_or_else(|_| "cargo".into())
}

/// Result of one QEMU run.
struct QemuRun {
    lines: Vec<String>,
    success: bool,
    timed_out: bool,
}

/// Runs an ELF on QEMU's MPS2+ AN505 (Cortex-M33 with FPU) with semihosting, relaying its
/// output line by line; kills it after [`QEMU_TIMEOUT`].
fn run_qemu(elf: &Path, icount: bool) -> Result<QemuRun> {
    let mut cmd = Command::new("qemu-system-arm");
    cmd.args([
        "-machine",
        "mps2-an505",
        "-cpu",
        "cortex-m33",
        "-nographic",
        "-monitor",
        "none",
        "-serial",
        "none",
        "-semihosting-config",
        "enable=on,target=native",
    ]);
    if icount {
        // One instruction = 1 ns of virtual time: SysTick readings count instructions.
        cmd.args(["-icount", "shift=0"]);
    }
    cmd.arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped());
    let mut child = cmd
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
    let stdout = child.stdout.take().ok_or("no stdout from qemu")?;
    let (tx, rx) = mpsc::channel::<String>();
    let reader = std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let start = Instant::now();
    let mut lines = Vec::new();
    let mut timed_out = false;
    let status = loop {
        while let Ok(line) = rx.try_recv() {
            println!("{line}");
            lines.push(line);
        }
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            break Some(status);
        }
        if start.elapsed() > QEMU_TIMEOUT {
            timed_out = true;
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let _ = reader.join();
    while let Ok(line) = rx.try_recv() {
        println!("{line}");
        lines.push(line);
    }
    Ok(QemuRun {
        lines,
        success: status.is_some_and(|s| s.success()),
        timed_out,
    })
}

/// Parses a closing line `N passed, M failed`.
fn parse_summary(line: &str) -> Option<(u32, u32)> {
    let (p, f) = line.trim().split_once(", ")?;
    let passed = p.strip_suffix(" passed")?.parse().ok()?;
    let failed = f.strip_suffix(" failed")?.parse().ok()?;
    Some((passed, failed))
}

fn qemu_tests() -> Result<bool> {
    ensure_target(TARGET)?;
    ensure_qemu()?;
    let elf = build_qemu_bin("qemu-tests")?;
    eprintln!(
        "xtask: running {} on qemu-system-arm -machine mps2-an505",
        elf.display()
    );
    let run = run_qemu(&elf, false)?;
    let last = run.lines.iter().rev().find(|l| !l.trim().is_empty());
    let summary = last.and_then(|l| parse_summary(l));
    if run.timed_out {
        eprintln!("xtask: QEMU timed out after {} s", QEMU_TIMEOUT.as_secs());
    }
    match summary {
        Some((_, 0)) if run.success => Ok(true),
        Some((_, failed)) if failed > 0 && !run.success => Ok(false),
        Some((passed, _)) => {
            // The program's verdict and QEMU's exit status disagree: count it as a failure.
            eprintln!("xtask: QEMU exited unsuccessfully after the summary");
            println!("{passed} passed, 1 failed");
            Ok(false)
        }
        None => {
            if !run.timed_out {
                eprintln!("xtask: the target program did not end with a summary line");
            }
            println!("0 passed, 1 failed");
            Ok(false)
        }
    }
}

fn qemu_bench() -> Result<bool> {
    ensure_target(TARGET)?;
    ensure_qemu()?;
    let elf = build_qemu_bin("qemu-bench")?;
    eprintln!(
        "xtask: running {} on qemu-system-arm -machine mps2-an505 -icount shift=0",
        elf.display()
    );
    let run = run_qemu(&elf, true)?;
    if run.timed_out {
        return Err(format!("QEMU timed out after {} s", QEMU_TIMEOUT.as_secs()));
    }
    Ok(run.success)
}

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
fn parse_chip(args: &[String]) -> Result<Chip> {
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

    #[test]
    fn summary_line_is_parsed_exactly() {
        assert_eq!(parse_summary("13 passed, 0 failed"), Some((13, 0)));
        assert_eq!(parse_summary("  2 passed, 11 failed\r"), Some((2, 11)));
        assert_eq!(parse_summary("13 passed"), None);
        assert_eq!(parse_summary("x passed, 0 failed"), None);
        assert_eq!(parse_summary("test a ... ok (3 passed, 0 failed)"), None);
    }

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

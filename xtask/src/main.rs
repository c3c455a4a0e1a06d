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
mod firmware;
mod tools;
mod uf2;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use firmware::{parse_chip, TARGET};
use tools::{cargo, ensure_target, have, root, run, Result};

/// How long one QEMU run may take before it is killed.
const QEMU_TIMEOUT: Duration = Duration::from_secs(300);

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
            Ok(chip) => firmware::firmware(chip),
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
    // The reader ends with QEMU's output; a panic of it is raised here, not taken for the end
    // of the output.
    if let Err(panic) = reader.join() {
        std::panic::resume_unwind(panic);
    }
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
}

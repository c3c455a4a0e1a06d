//! `cargo xtask emulate`: runs the real RP2040 firmware in rp2040js (`emulator/`, a Node.js
//! harness) with a simulated Nunchuk, Wii Remote and USB host, and the real `wiical` CLI on a
//! pseudo-terminal. The boards boot from the drag-and-drop file `cargo xtask firmware` writes
//! (`target/uf2/wiical-adapter-rp2040.uf2`), so the file a user drops is the file tested; the
//! ELF is compared with it. The UF2 loader's own tests (`node --test src/uf2.test.js`) run
//! first. And `emulate-correct`, the independent expectation the harness
//! compares the Wii Remote's reports with.

use std::io::{BufRead, Write};
use std::path::Path;
use std::process::Command;

use wiical_core::Calibration;

use crate::firmware::{self, Chip};
use crate::tools::{cargo, root, run, Result};

/// Ideal scale the adapter re-encodes corrected samples on (firmware/README.md, crates/adapter
/// `IdealScale::default`): 0 g = 512 counts, 200 counts per g, saturated to 10 bits.
const IDEAL_ZERO: f64 = 512.0;
const IDEAL_COUNTS_PER_G: f64 = 200.0;

/// Reads a calibration (the JSON `wiical fit --out` writes) and, for each stdin line of three
/// raw counts, prints the counts a Wii Remote must read from a calibrated adapter: the core's
/// correction `K·(m − b)` plus its per-axis and orientation-dependent cross terms (g),
/// re-encoded on the ideal scale in f64 (round half away from zero,
/// clamp to 0..=1023). Uses the core only, not the adapter crate the firmware runs.
pub fn correct(args: &[String]) -> Result<bool> {
    let [path] = args else {
        return Err("usage: cargo xtask emulate-correct CAL.json < raw-counts".into());
    };
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read {path}: {e}"))?;
    let cal: Calibration =
        serde_json::from_str(&text).map_err(|e| format!("{path}: not a calibration: {e}"))?;
    cal.validate()
        .map_err(|e| format!("{path}: invalid calibration: {e:?}"))?;
    let stdin = std::io::stdin();
    let mut out = std::io::stdout().lock();
    for line in stdin.lock().lines() {
        let line = line.map_err(|e| e.to_string())?;
        let raw: Vec<f32> = line
            .split_whitespace()
            .map(|t| t.parse::<u16>().map(f32::from))
            .collect::<std::result::Result<_, _>>()
            .map_err(|e| format!("bad raw counts `{line}`: {e}"))?;
        let [x, y, z] = raw[..] else {
            return Err(format!("expected three raw counts, got `{line}`"));
        };
        // As the adapter does: the terms that depend on the acceleration alone (time and
        // temperature terms are not applied: no clock origin, no thermometer).
        let g = if cal.effects.is_none() {
            cal.correct_linear([x, y, z])
        } else {
            cal.correct([x, y, z], &wiical_core::Conditions::default())
        };
        let counts = g.map(|a| {
            let c = (IDEAL_ZERO + f64::from(a) * IDEAL_COUNTS_PER_G).round();
            c.clamp(0.0, 1023.0) as u16
        });
        writeln!(out, "{} {} {}", counts[0], counts[1], counts[2]).map_err(|e| e.to_string())?;
    }
    Ok(true)
}

fn have(program: &str, arg: &str) -> bool {
    Command::new(program)
        .arg(arg)
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Builds the firmware (RP2040, with its UF2 image) and the host CLI, installs the harness's
/// npm packages from the lockfile if missing, runs the UF2 loader's tests, then the scenarios.
/// The harness prints one line per scenario and a closing `N passed, M failed`.
pub fn emulate(args: &[String]) -> Result<bool> {
    for (program, package) in [("node", "nodejs"), ("npm", "npm"), ("socat", "socat")] {
        if !have(program, "--version") && !have(program, "-V") {
            return Err(format!(
                "{program} is missing: run scripts/setup (apt-get install {package})"
            ));
        }
    }
    let root = root();
    let emulator = root.join("emulator");
    if !emulator.join("node_modules").join("rp2040js").exists() {
        run(Command::new("npm")
            .current_dir(&emulator)
            .args(["ci", "--no-audit", "--no-fund"]))?;
    }
    if !firmware::firmware(Chip::Rp2040)? {
        return Err("the RP2040 firmware is over its budget".into());
    }
    let wiical = host_binary(&root)?;
    let elf = root
        .join("firmware/target")
        .join(Chip::Rp2040.target())
        .join("release/wiical-firmware");
    let me = std::env::current_exe().map_err(|e| e.to_string())?;
    run(Command::new("node").current_dir(&emulator).args([
        "--test",
        "--test-reporter=spec",
        "src/uf2.test.js",
    ]))?;
    let status = Command::new("node")
        .current_dir(&emulator)
        .arg(Path::new("run.js"))
        .arg("--elf")
        .arg(&elf)
        .arg("--uf2")
        .arg(Chip::Rp2040.uf2_path())
        .arg("--wiical")
        .arg(&wiical)
        .arg("--expect")
        .arg(&me)
        .args(args)
        .status()
        .map_err(|e| format!("cannot run node: {e}"))?;
    Ok(status.success())
}

/// The host CLI the emulated board talks to: `$WIICAL_BIN` when set (scripts/test passes the
/// binary `cargo test` built, so that it is not built a second time with the other feature
/// set of a plain `cargo build`), else `target/debug/wiical`, built here.
fn host_binary(root: &Path) -> Result<std::path::PathBuf> {
    if let Some(bin) = std::env::var_os("WIICAL_BIN") {
        return Ok(bin.into());
    }
    run(Command::new(cargo())
        .current_dir(root)
        .args(["build", "--locked", "-p", "wiical"]))?;
    Ok(root.join("target/debug/wiical"))
}

//! The command line's argument-and-file path (`wiical <command> FILE [FLAGS…]`), as a user
//! drives it: the first byte picks a subcommand that reads a file (or decode-cal's hex), the
//! bytes up to the first NUL are its extra arguments (one per line, at most eight), the rest
//! is the file's content. It must never panic; errors are expected. Only commands that read
//! local files are driven (no device, no HID, no simulation), and arguments that could name an
//! output (`--out`, `--plot`, any path) are dropped: the outputs' own hostile cases are tested in
//! host/tests/hostile.rs and safety.rs. The input is written to one scratch file under TMPDIR.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::PathBuf;
use std::sync::OnceLock;

/// Subcommands and fixed leading arguments (gyrofit with and without a nominal).
const COMMANDS: [&[&str]; 10] = [
    &["fit"],
    &["analyze"],
    &["magfit"],
    &["six-position"],
    &["gyrofit"],
    &["gyrofit", "--counts-per-dps", "16.4"],
    &["noise"],
    &["tempcal"],
    &["fit", "--windows"],
    &["decode-cal", "--device"],
];

/// A scratch directory for the whole run.
fn scratch() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("wiical-fuzz-cli-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch directory");
        dir
    })
}

/// Could this argument make the command write a file?
fn may_name_an_output(arg: &str) -> bool {
    let lower = arg.to_ascii_lowercase();
    ["out", "plot", "log", "flash", "result", "/", "\\"]
        .iter()
        .any(|w| lower.contains(w))
}

fuzz_target!(|data: &[u8]| {
    let dir = scratch();
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let split = rest.iter().position(|&b| b == 0).unwrap_or(rest.len());
    let (arg_bytes, file) = (&rest[..split], rest.get(split + 1..).unwrap_or(&[]));
    let command = COMMANDS[pick as usize % COMMANDS.len()];
    let extra: Vec<String> = String::from_utf8_lossy(arg_bytes)
        .lines()
        .filter(|a| !may_name_an_output(a))
        .take(8)
        .map(str::to_owned)
        .collect();
    let input = dir.join("input.csv");
    if std::fs::write(&input, file).is_err() {
        return;
    }
    let mut args: Vec<String> = vec!["wiical".into()];
    args.extend(command.iter().map(|s| s.to_string()));
    if command[0] != "decode-cal" {
        args.push(input.to_string_lossy().into_owned());
    }
    args.extend(extra);
    // Any result but a panic is fine: usage errors, refusals and reports alike.
    let _ = wiical::cli::run_args(args);
});

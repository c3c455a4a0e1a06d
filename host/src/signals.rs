//! The signals that end a run (SIGINT from Ctrl-C, SIGTERM, SIGHUP from a closed terminal)
//! first delete the temporary files the run made under a name — the copy of standard input,
//! as large as the recording piped in (`wiical_analysis::input::temp_files`) — and then end
//! the process as the signal would have (the shell sees 130, 143 or 129).
//!
//! A thread of its own waits for them (`signal-hook`): the deletion runs outside the signal
//! handler, where taking a lock and calling `unlink` are safe. A signal the process was
//! started with ignored (`nohup` ignores SIGHUP; a shell's background job, SIGINT) is left
//! ignored: taking it over would let it end a run that was meant to outlive it.

/// Starts the thread (see the module docs); a system that cannot start it leaves the default
/// actions (the run ends without deleting, and the next copy of standard input deletes what
/// it left: `temp_files::remove_stale`).
#[cfg(unix)]
pub fn install() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let ignored = ignored_at_start();
    let wanted: Vec<i32> = [SIGINT, SIGTERM, SIGHUP]
        .into_iter()
        .filter(|s| !ignored.contains(s))
        .collect();
    let Ok(mut signals) = signal_hook::iterator::Signals::new(&wanted) else {
        return;
    };
    let _ = std::thread::Builder::new()
        .name("wiical-signals".into())
        .spawn(move || {
            if let Some(signal) = signals.forever().next() {
                wiical_analysis::input::temp_files::remove_registered();
                // Default action restored and the signal raised again: the process ends as
                // killed by it. Should that fail, the conventional status.
                let _ = signal_hook::low_level::emulate_default_handler(signal);
                std::process::exit(128 + signal);
            }
        });
}

/// No signals to catch where there are none.
#[cfg(not(unix))]
pub fn install() {}

/// The signals this process was started with ignored, from `SigIgn` in `/proc/self/status`
/// (Linux; elsewhere none are known to be, and all three are taken over).
#[cfg(unix)]
fn ignored_at_start() -> Vec<i32> {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("SigIgn:"))
        .and_then(|mask| u64::from_str_radix(mask.trim(), 16).ok())
        .map(ignored_in)
        .unwrap_or_default()
}

/// The signal numbers set in a `SigIgn` mask (bit `n - 1` for signal `n`).
#[cfg(unix)]
fn ignored_in(mask: u64) -> Vec<i32> {
    (1..=64).filter(|n| mask >> (n - 1) & 1 == 1).collect()
}

#[cfg(all(test, unix))]
mod tests {
    /// Bit `n - 1` of the mask is signal `n`: SIGHUP (1) and SIGINT (2) from `0x3`, SIGTERM (15)
    /// from `0x4000`.
    #[test]
    fn the_ignored_mask_names_signals_by_number() {
        assert_eq!(super::ignored_in(0x3), vec![1, 2]);
        assert_eq!(super::ignored_in(0x4000), vec![15]);
        assert!(super::ignored_in(0).is_empty());
    }
}

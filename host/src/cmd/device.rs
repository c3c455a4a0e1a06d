//! `wiical device …`: the command line of the adapter client ([`crate::client`]).

use std::io::{self, Write};
use std::path::PathBuf;
use std::time::Duration;

use crate::cli_error::cli_error;
use crate::client::{same_bits, ClientOptions, Device};
use crate::cmd::{device_gyro, to_json};
use crate::render::device as render;
use anyhow::{anyhow, bail, Result};
use serde::Serialize;
use wiical_analysis::output::calfile::{self, adapter_terms, adapter_terms_file, CalibrationFile};
use wiical_analysis::report::verdict::Verdict;
use wiical_core::acceptance::Acceptance;
use wiical_core::terms::TERMS;
use wiical_core::Calibration;
use wiical_wire::{
    AdapterStatus, BackgroundSettings, BackgroundSettingsField, BootRecord, CalibrationState,
    HelloResponse, RecordProblem, Sample, SelfCalOutcome, PROTOCOL_VERSION, SCHEMA_KEY,
};

/// Arguments of `wiical device`.
#[derive(clap::Args, Debug, Clone)]
pub struct DeviceArgs {
    #[command(subcommand)]
    pub action: DeviceAction,
    /// Serial port of the adapter (e.g. /dev/ttyACM0, or the pty printed by `device-sim`).
    #[arg(long, global = true)]
    pub port: Option<String>,
    /// Print JSON (stream: one JSON object per line).
    #[arg(long, global = true)]
    pub json: bool,
    /// Answer timeout per request (and per sample), ms (1 to 600000).
    #[arg(long, global = true, default_value_t = 1000,
          value_parser = clap::value_parser!(u64).range(1..=600_000))]
    pub timeout_ms: u64,
    /// Re-sends of a request whose answer was lost or corrupted (0 to 20).
    #[arg(long, global = true, default_value_t = 3,
          value_parser = clap::value_parser!(u32).range(0..=20))]
    pub retries: u32,
}

/// `wiical device` subcommands.
#[derive(clap::Subcommand, Debug, Clone)]
pub enum DeviceAction {
    /// Handshake and show firmware version, device ID and protocol versions.
    Info,
    /// Show the live (and staged) calibration.
    Get {
        /// Also write the live calibration here (JSON, the format `put` reads).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Upload a calibration (JSON from `wiical fit --out`, or a gyro calibration from
    /// `wiical gyrofit --out`, told apart by its content) and verify it; with `--commit`
    /// also make it live and store it. Without `--commit` the adapter discards the upload
    /// when this command closes the port (a staged calibration belongs to its session).
    Put {
        /// Calibration JSON (accelerometer or gyro).
        file: PathBuf,
        /// Commit in the same session.
        #[arg(long)]
        commit: bool,
        /// Upload even when the fit's quality verdict is poor or the calibration is not
        /// plausible for a Nunchuk (a gyro one: a MotionPlus); the adapter still refuses an
        /// implausible one.
        #[arg(long)]
        force: bool,
    },
    /// Upload FILE (an accelerometer or a gyro calibration), verify it and make it live and
    /// stored, in one session.
    Commit {
        /// Calibration JSON (accelerometer or gyro).
        file: PathBuf,
        /// As for `put`: upload even when the quality verdict is poor.
        #[arg(long)]
        force: bool,
    },
    /// The adapter's self-calibration (C + Z held at plug-in): progress, last result, the
    /// stale-calibration estimate from still moments during play, and the background
    /// recalibration (bins, coverage, candidate vs live error, last adoption and refusal).
    SelfcalStatus,
    /// Store the background recalibration's settings in the adapter: adoption on or off,
    /// whether it may replace a calibration uploaded by the host, the flash-write budget and
    /// the fit interval. A setting not given keeps the adapter's current value.
    #[command(group(clap::ArgGroup::new("setting").required(true).multiple(true)
        .args(["background", "replace_uploaded", "commit_every", "commits_per_day", "fit_every"])))]
    SelfcalSet {
        /// Adopt better calibrations found during play (off: monitor only).
        #[arg(long, value_parser = ["on", "off"])]
        background: Option<String>,
        /// Allow replacing a calibration the host uploaded.
        #[arg(long, value_parser = ["yes", "no"])]
        replace_uploaded: Option<String>,
        /// At most one commit of an adopted calibration per SECONDS of play (10 to 604800;
        /// the adapter's default 1800).
        #[arg(long, value_name = "SECONDS")]
        commit_every: Option<u32>,
        /// At most N commits per 24 h of play (1 to 16; default 8).
        #[arg(long, value_name = "N")]
        commits_per_day: Option<u8>,
        /// A fit attempt every SECONDS of play, decimals allowed (0.5 to 3600; default 60).
        #[arg(long, value_name = "SECONDS")]
        fit_every: Option<f64>,
    },
    /// Stream corrected samples (CSV: seq,raw_x,raw_y,raw_z,ax,ay,az,c,z,stick_x,stick_y).
    Stream {
        /// Stop after this many samples (default: until interrupted).
        #[arg(long)]
        count: Option<u64>,
        /// Keep one report in DIVIDER (the adapter polls at 200 Hz).
        #[arg(long, default_value_t = 1)]
        divider: u16,
    },
}

#[derive(Serialize)]
struct InfoJson {
    port: String,
    firmware_version: String,
    device_id: String,
    protocol_version: u16,
    schema_key: String,
    host_protocol_version: u16,
    host_schema_key: String,
}

#[derive(Serialize)]
struct StateJson {
    port: String,
    live: Calibration,
    staged: Option<Calibration>,
    /// True when `live` is a committed (stored) calibration; false: pass-through with the
    /// Nunchuk's factory calibration.
    stored: bool,
    /// What the adapter found in storage at boot (`loaded`, `empty`, `rejected: …`,
    /// `storage error`).
    boot: String,
    /// Damaged or interrupted records the adapter skipped at boot.
    damaged_records: u16,
}

/// The sentence to add when the adapter refused its stored record at boot, skipped damaged
/// records, or could not read its storage (alone, "committed, stored" or "none committed"
/// would hide it).
fn boot_note(s: &CalibrationState) -> Option<String> {
    if s.damaged_records > 0 && !matches!(s.boot, BootRecord::Rejected(_)) {
        let n = s.damaged_records;
        let (what, shown) = match s.boot {
            BootRecord::Loaded => (
                "the live calibration shown is the newest intact record",
                "it may be older than your last commit",
            ),
            _ => ("no intact record is left", "the adapter runs uncalibrated"),
        };
        return Some(format!(
            "warning: the adapter rejected {n} damaged or interrupted calibration record{} in its storage at boot (CRC mismatch); {what}, and {shown}: commit the calibration again (`wiical device commit FILE`)\n",
            if n == 1 { "" } else { "s" }
        ));
    }
    match &s.boot {
        BootRecord::Rejected(p) => {
            let version = match p {
                RecordProblem::UnsupportedVersion(v) => format!(" (version {v})"),
                _ => String::new(),
            };
            Some(format!(
                "warning: the adapter rejected its stored calibration record at boot ({}{version}) and runs uncalibrated: commit a calibration again (`wiical device commit FILE`)\n",
                p.description()
            ))
        }
        BootRecord::StorageError => Some(
            "warning: the adapter could not read its calibration storage at boot and runs uncalibrated: commit a calibration again, or check the flash\n"
                .into(),
        ),
        BootRecord::Empty | BootRecord::Loaded => None,
    }
}

#[derive(Serialize)]
struct SampleJson {
    seq: u32,
    raw: [u16; 3],
    corrected: [f32; 3],
    c: bool,
    z: bool,
    stick: [u8; 2],
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect()
}

/// Upload `cal` (read and judged by [`checked_for_put`], so the acceptance predicate is not
/// run again) and read it back: the staged copy must be bit-identical.
fn put_verified(dev: &mut Device, cal: Option<Calibration>) -> Result<Calibration> {
    let cal = cal.ok_or_else(|| anyhow!("internal: calibration not read"))?;
    dev.put_judged(&cal)?;
    let s = dev.get_calibration()?;
    let ok = s
        .staged
        .map(|w| same_bits(&w, &cal.into()))
        .unwrap_or(false);
    if !ok {
        bail!("the calibration read back from the adapter differs from the one sent");
    }
    Ok(cal)
}

fn selfcal_json(port: &str, st: &AdapterStatus) -> serde_json::Value {
    let last = match &st.last_result {
        None => serde_json::Value::Null,
        Some(SelfCalOutcome::Done { rms_mg, poses }) => {
            serde_json::json!({"ok": true, "rms_mg": rms_mg, "poses": poses})
        }
        Some(SelfCalOutcome::Failed { message }) => {
            serde_json::json!({"ok": false, "message": message.as_str()})
        }
    };
    serde_json::json!({
        "port": port,
        "phase": format!("{:?}", st.phase),
        "poses": st.poses,
        "last_result": last,
        "stale_moments": st.stale_moments,
        "stale_rms_mg": st.stale_rms_mg,
        "recalibration_suggested": st.recalibration_suggested,
    })
}

/// What `device put` thinks of a calibration file before sending it.
#[derive(Debug, Default, PartialEq)]
pub struct PutCheck {
    /// Reasons to refuse without `--force`.
    pub refusals: Vec<String>,
    /// Things to warn about in any case.
    pub warnings: Vec<String>,
}

/// Judges a calibration file for the adapter: the core's plausibility limits for the
/// Nunchuk ([`Acceptance::nunchuk`], the same the adapter applies), the fit's stored
/// quality verdict, and terms the adapter does not apply (it corrects without a clock origin
/// or a temperature: drift and temperature terms are ignored).
pub fn judge_for_put(file: &CalibrationFile) -> PutCheck {
    let mut check = PutCheck::default();
    if let Err(why) = Acceptance::nunchuk().check(&file.calibration, None) {
        check
            .refusals
            .push(format!("not plausible for a Nunchuk: {why}"));
    }
    match &file.quality {
        Some(q) if q.verdict != Verdict::Good => {
            check.refusals.push(format!("the fit's {}", q.line()))
        }
        Some(_) => {}
        None => check.warnings.push(
            "the file has no quality verdict (not from `wiical fit` / `analyze`): only plausibility was checked"
                .into(),
        ),
    }
    let e = &file.calibration.effects;
    // The terms the core's table says the adapter does not apply (the reference θ₀ is no term).
    for t in TERMS.iter().filter(|t| t.is_term() && !t.device_applies) {
        let name = t.name;
        if e.field(t.id).iter().any(|x| *x != 0.0) {
            check.warnings.push(format!(
                "the adapter does not apply the {name} terms (it has no clock origin or temperature sensor); they are stored but ignored"
            ));
        }
    }
    if !file.host_terms.is_empty() {
        let names: Vec<&str> = file.host_terms.iter().map(|t| t.name.as_str()).collect();
        check.warnings.push(format!(
            "the adapter does not apply the host terms {} (time and temperature); they stay in the file for `wiical correct` and are not uploaded",
            names.join(", ")
        ));
    }
    check
}

/// Reads a calibration file for `device put`, prints the warnings, and refuses (without
/// `force`) a poor or implausible one.
fn checked_for_put(path: &std::path::Path, force: bool) -> Result<CalibrationFile> {
    let file = calfile::read_calibration_file(path).map_err(cli_error)?;
    let check = judge_for_put(&file);
    for w in &check.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    if !check.refusals.is_empty() {
        if !force {
            bail!(
                "refusing to upload {}: {} (re-record, or pass --force to upload anyway)",
                path.display(),
                check.refusals.join("; ")
            );
        }
        for r in &check.refusals {
            eprintln!(
                "warning: {}: uploading with --force although {r}",
                path.display()
            );
        }
    }
    Ok(file)
}

/// The file `put` / `commit` uploads, read and judged: an accelerometer calibration, or a
/// gyro calibration (told by its content, [`device_gyro::is_gyro_file`]); neither for the
/// other actions.
fn read_upload(
    action: &DeviceAction,
) -> Result<(Option<CalibrationFile>, Option<device_gyro::GyroPut>)> {
    let (DeviceAction::Put { file, force, .. } | DeviceAction::Commit { file, force }) = action
    else {
        return Ok((None, None));
    };
    Ok(if device_gyro::is_gyro_file(file) {
        (None, Some(device_gyro::checked_for_put(file, *force)?))
    } else {
        (Some(checked_for_put(file, *force)?), None)
    })
}

/// Run `wiical device …`. Streamed samples are written to `out` as they arrive; the
/// returned text is printed afterwards.
pub fn run(args: &DeviceArgs, out: &mut dyn Write) -> Result<String> {
    let port = args
        .port
        .as_deref()
        .ok_or_else(|| anyhow!("--port is required (e.g. --port /dev/ttyACM0)"))?;
    let opts = ClientOptions {
        timeout: Duration::from_millis(args.timeout_ms.max(1)),
        retries: args.retries,
    };
    // A calibration file is read and judged before the adapter is even opened; a gyro file
    // (told by its content) goes its own way.
    let (to_put, gyro) = read_upload(&args.action)?;
    let (mut dev, hello) = Device::connect(port, opts)?;
    let json = args.json;
    if let Some(g) = &gyro {
        let commit = matches!(
            args.action,
            DeviceAction::Put { commit: true, .. } | DeviceAction::Commit { .. }
        );
        return device_gyro::put(&mut dev, port, g, commit, json);
    }
    match &args.action {
        DeviceAction::Info => info(&mut dev, &hello, port, json),
        DeviceAction::Get { out: file } => get(&mut dev, port, file.as_deref(), json),
        DeviceAction::Put {
            file,
            commit: false,
            ..
        } => {
            let terms = to_put.as_ref().map(adapter_terms_file);
            let cal = put_verified(&mut dev, to_put.map(|f| f.calibration))?;
            let terms = terms.unwrap_or_else(|| adapter_terms(&cal));
            if json {
                return to_json(&serde_json::json!({
                    "port": port, "staged": true, "verified": true, "calibration": cal,
                    "terms": terms
                }));
            }
            let mut o = render::staged_text(file, port);
            render::fmt_terms(&mut o, &terms)?;
            Ok(o)
        }
        DeviceAction::Put { commit: true, .. } | DeviceAction::Commit { .. } => {
            let terms = to_put.as_ref().map(adapter_terms_file);
            let cal = put_verified(&mut dev, to_put.map(|f| f.calibration))?;
            let terms = terms.unwrap_or_else(|| adapter_terms(&cal));
            dev.commit()?;
            let s = dev.get_calibration()?;
            if json {
                return to_json(&serde_json::json!({
                    "port": port, "committed": true, "stored": s.stored,
                    "live": Calibration::from(s.live), "terms": terms
                }));
            }
            let mut o = render::committed_text(port);
            render::fmt_terms(&mut o, &terms)?;
            Ok(o)
        }
        DeviceAction::SelfcalStatus => selfcal_status(&mut dev, port, json),
        DeviceAction::SelfcalSet {
            background,
            replace_uploaded,
            commit_every,
            commits_per_day,
            fit_every,
        } => {
            let change = SettingsChange {
                adopt: background.as_deref().map(|b| b == "on"),
                replace_uploaded: replace_uploaded.as_deref().map(|r| r == "yes"),
                commit_interval_s: *commit_every,
                commits_per_day: *commits_per_day,
                fit_every_s: *fit_every,
            };
            selfcal_set(&mut dev, port, &change, json)
        }
        DeviceAction::Stream { count, divider } => {
            stream(&mut dev, *count, *divider, json, out)?;
            Ok(String::new())
        }
    }
}

/// `device selfcal-status`: the self-calibration and the background recalibration.
fn selfcal_status(dev: &mut Device, port: &str, json: bool) -> Result<String> {
    let st = dev.status()?;
    let bg = dev.background_status()?;
    if json {
        let mut v = selfcal_json(port, &st);
        v["background"] = background_json(&bg);
        return to_json(&v);
    }
    let mut o = String::new();
    render::fmt_status(&mut o, &st)?;
    render::fmt_background(&mut o, &bg)?;
    Ok(o)
}

/// The settings `selfcal-set` was given (`None`: keep the adapter's current value).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SettingsChange {
    /// `--background on|off`.
    pub adopt: Option<bool>,
    /// `--replace-uploaded yes|no`.
    pub replace_uploaded: Option<bool>,
    /// `--commit-every`, s of play.
    pub commit_interval_s: Option<u32>,
    /// `--commits-per-day`.
    pub commits_per_day: Option<u8>,
    /// `--fit-every`, s of play.
    pub fit_every_s: Option<f64>,
}

impl SettingsChange {
    /// The adapter's settings `now` with this change applied, or one sentence naming the flag
    /// outside its bounds (the adapter refuses such values too: the budget bounds flash wear).
    pub fn apply(&self, now: BackgroundSettings) -> Result<BackgroundSettings> {
        let fit_interval_ms = match self.fit_every_s {
            None => now.fit_interval_ms,
            Some(s) if s.is_finite() && (0.0..=4.0e6).contains(&s) => (s * 1000.0).round() as u32,
            Some(s) => bail!("--fit-every {s}: must be between 0.5 and 3600 seconds of play"),
        };
        let want = BackgroundSettings {
            adopt: self.adopt.unwrap_or(now.adopt),
            replace_uploaded: self.replace_uploaded.unwrap_or(now.replace_uploaded),
            commit_interval_s: self.commit_interval_s.unwrap_or(now.commit_interval_s),
            commits_per_day: self.commits_per_day.unwrap_or(now.commits_per_day),
            fit_interval_ms,
        };
        match want.out_of_bounds() {
            None => Ok(want),
            Some(BackgroundSettingsField::CommitInterval) => {
                let r = BackgroundSettings::COMMIT_INTERVAL_S;
                bail!(
                    "--commit-every {}: must be between {} and {} seconds of play (the interval bounds how often the adapter writes its flash)",
                    want.commit_interval_s, r.start(), r.end()
                )
            }
            Some(BackgroundSettingsField::CommitsPerDay) => {
                let r = BackgroundSettings::COMMITS_PER_DAY;
                bail!(
                    "--commits-per-day {}: must be between {} and {} (the adapter remembers {} commit times; --background off stops adoptions)",
                    want.commits_per_day, r.start(), r.end(), r.end()
                )
            }
            Some(BackgroundSettingsField::FitInterval) => {
                bail!(
                    "--fit-every {}: must be between 0.5 and 3600 seconds of play",
                    f64::from(want.fit_interval_ms) / 1000.0
                )
            }
        }
    }
}

/// `device selfcal-set`: stores the background settings (the ones not given kept) and reads
/// them back.
fn selfcal_set(
    dev: &mut Device,
    port: &str,
    change: &SettingsChange,
    json: bool,
) -> Result<String> {
    let now = dev.background_status()?.settings;
    let want = change.apply(now)?;
    dev.set_background(want)?;
    let back = dev.background_status()?.settings;
    if back != want {
        bail!("the adapter on {port} acknowledged the background settings but reports {back:?}, not {want:?}");
    }
    if json {
        return to_json(&serde_json::json!({
            "port": port, "stored": true,
            "adopt": back.adopt, "replace_uploaded": back.replace_uploaded,
            "commit_interval_s": back.commit_interval_s,
            "commits_per_day": back.commits_per_day,
            "fit_interval_s": f64::from(back.fit_interval_ms) / 1000.0,
        }));
    }
    let mut o = format!(
        "background recalibration on {port}: adoption {}, a host upload {} (stored in the adapter)\n",
        if back.adopt { "on" } else { "off (monitor only)" },
        if back.replace_uploaded { "may be replaced" } else { "is kept" }
    );
    o.push_str(&render::budget_text(&back));
    o.push('\n');
    Ok(o)
}

fn background_json(b: &wiical_wire::BackgroundReport) -> serde_json::Value {
    serde_json::json!({
        "phase": format!("{:?}", b.phase),
        "adopt": b.settings.adopt,
        "replace_uploaded": b.settings.replace_uploaded,
        "commit_interval_s": b.settings.commit_interval_s,
        "commits_per_day": b.settings.commits_per_day,
        "fit_interval_s": f64::from(b.settings.fit_interval_ms) / 1000.0,
        "origin": format!("{:?}", b.origin),
        "play_s": b.play_s,
        "moments": b.moments,
        "bins_filled": b.bins_filled,
        "bins": b.bin_moments.len(),
        "fresh_bins": (0..b.bin_moments.len()).filter(|i| b.fresh_bins >> i & 1 == 1).collect::<Vec<_>>(),
        "bin_moments": b.bin_moments.as_slice(),
        "temperature_c": b.temperature_c,
        "coverage_gap": b.coverage_gap.as_ref().map(|g| format!("{g:?}")),
        "candidate": b.candidate.map(|c| serde_json::json!({
            "candidate_mg": c.candidate_mg, "live_mg": c.live_mg, "fit_rms_mg": c.fit_rms_mg,
            "full_model": c.full_model, "temperature": c.temperature,
            "training_bins": c.training_bins, "heldout_bins": c.heldout_bins,
        })),
        "last_adoption": b.last_adoption.map(|a| serde_json::json!({
            "at_s": a.at_s, "before_mg": a.before_mg, "after_mg": a.after_mg,
        })),
        "last_refusal": b.last_refusal.as_ref().map(render::refusal_text),
    })
}

/// `device info`: the handshake's answer and the stale-calibration monitor.
fn info(dev: &mut Device, hello: &HelloResponse, port: &str, json: bool) -> Result<String> {
    let j = InfoJson {
        port: port.to_string(),
        firmware_version: hello.firmware_version.to_string(),
        device_id: hex(&hello.device_id),
        protocol_version: hello.protocol_version,
        schema_key: format!("0x{:08X}", hello.schema_key),
        host_protocol_version: PROTOCOL_VERSION,
        host_schema_key: format!("0x{SCHEMA_KEY:08X}"),
    };
    if json {
        return to_json(&j);
    }
    let mut o = String::new();
    render::fmt_info(
        &mut o,
        &render::InfoText {
            port: &j.port,
            firmware_version: &j.firmware_version,
            device_id: &j.device_id,
            protocol_version: j.protocol_version,
            schema_key: &j.schema_key,
            host_protocol_version: j.host_protocol_version,
            host_schema_key: &j.host_schema_key,
        },
    )?;
    render::fmt_stale(&mut o, &dev.status()?)?;
    o.extend(boot_note(&dev.get_calibration()?));
    Ok(o)
}

/// `device get [--out FILE]`: the live and staged calibrations.
fn get(dev: &mut Device, port: &str, file: Option<&std::path::Path>, json: bool) -> Result<String> {
    // `-` and a directory are refused as every command's output is.
    super::check_outputs(&[], &[file])?;
    let s = dev.get_calibration()?;
    let live = Calibration::from(s.live);
    if let Some(path) = file {
        calfile::write_calibration_unchecked(path, &live).map_err(cli_error)?;
    }
    let j = StateJson {
        port: port.to_string(),
        live,
        staged: s.staged.map(Calibration::from),
        stored: s.stored,
        boot: render::boot_word(&s.boot),
        damaged_records: s.damaged_records,
    };
    // The MotionPlus's gyro calibration (protocol 7), shown only when the adapter holds one
    // (or refused its record): otherwise the output is what it was before it existed.
    let gyro = device_gyro::state(dev)?.filter(device_gyro::has_news);
    if json {
        // Without a gyro calibration the JSON is byte for byte what it was.
        let Some(g) = &gyro else {
            return to_json(&j);
        };
        let mut v = serde_json::to_value(&j)?;
        v["gyro"] = device_gyro::state_json(g);
        return to_json(&v);
    }
    let mut o = render::state_text(&j.live, j.staged.as_ref(), j.stored)?;
    o.extend(boot_note(&s));
    if let Some(g) = &gyro {
        o.push_str(&device_gyro::state_text(g)?);
    }
    Ok(o)
}

/// Stream samples to `out` (CSV with header, or JSON lines). Ends after `count` samples, or
/// when `out` is closed (`| head`).
pub fn stream(
    dev: &mut Device,
    count: Option<u64>,
    divider: u16,
    as_json: bool,
    out: &mut dyn Write,
) -> Result<u64> {
    if divider == 0 {
        bail!("--divider must be at least 1");
    }
    dev.start_stream(divider)?;
    let mut n = 0u64;
    let mut write = |line: String| -> Result<bool> {
        match out.write_all(line.as_bytes()) {
            Ok(()) => Ok(true),
            Err(e) if e.kind() == io::ErrorKind::BrokenPipe => Ok(false),
            Err(e) => Err(e.into()),
        }
    };
    let mut open =
        as_json || write("seq,raw_x,raw_y,raw_z,ax,ay,az,c,z,stick_x,stick_y\n".to_string())?;
    while open && count.is_none_or(|c| n < c) {
        let s = dev.next_sample()?;
        let c = s.buttons & Sample::BUTTON_C != 0;
        let z = s.buttons & Sample::BUTTON_Z != 0;
        let line = if as_json {
            serde_json::to_string(&SampleJson {
                seq: s.seq,
                raw: s.raw,
                corrected: s.corrected,
                c,
                z,
                stick: s.stick,
            })? + "\n"
        } else {
            format!(
                "{},{},{},{},{},{},{},{},{},{},{}\n",
                s.seq,
                s.raw[0],
                s.raw[1],
                s.raw[2],
                s.corrected[0],
                s.corrected[1],
                s.corrected[2],
                u8::from(c),
                u8::from(z),
                s.stick[0],
                s.stick[1]
            )
        };
        open = write(line)?;
        n += 1;
    }
    let _ = out.flush();
    dev.stop_stream()?;
    Ok(n)
}

//! `wiical simulate`: a recording with known truth.

use anyhow::Result;
use std::fmt::Write as _;
use std::path::PathBuf;
use wiical_sim::protocols::{simulate_protocol, write_protocol, ProtocolSimOptions, SimProtocol};
use wiical_sim::{Device, EffectSpec, Profile, SimConfig, SimEffect};

/// Arguments of `wiical simulate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output CSV (t,x,y,z,temp).
    #[arg(long)]
    pub out: PathBuf,
    /// The effect(s) to put in, comma-separated (`quadratic,temperature`); `none`: the
    /// linear model alone; the open-basis families too (`cross-quadratic`, `scale-drift`,
    /// `thermal-lag`, …). An unknown name is answered with the list of names.
    #[arg(long, default_value = "none", value_parser = parse_effect, value_delimiter = ',')]
    pub effect: Vec<SimEffect>,
    /// Size of the effect in milli-g (meaning per effect: see `wiical_sim`):
    /// one value for every effect, or one per effect (comma-separated, same order).
    #[arg(long, value_delimiter = ',')]
    pub magnitude: Vec<f64>,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// wiimote (~105 counts/g) | nunchuk (~200 counts/g) | mems16 (16-bit, 16 384 counts/g,
    /// written in m/s²).
    #[arg(long, default_value = "wiimote", value_parser = parse_device)]
    pub device: Device,
    /// Sample rate, Hz (20 to 2000); default: the device's usual (100, or 400 for mems16;
    /// 100 with --protocol).
    #[arg(long, value_parser = parse_rate)]
    pub rate: Option<f64>,
    /// calm (holds of 4–8 s, moves of 1.5–3 s) | brisk (holds of 2–4 s, moves of 1–2 s with
    /// hand bumps).
    #[arg(long, default_value = "calm", value_parser = parse_profile)]
    pub profile: Profile,
    /// Number of poses after the initial rest (1 to 5000: about 22 kB of CSV per pose, so the
    /// file stays well inside the 256 MiB that `fit` and `analyze` read).
    #[arg(long, default_value_t = 30, value_parser = parse_poses)]
    pub poses: usize,
    /// Leave out the temperature column.
    #[arg(long)]
    pub no_temp: bool,
    /// Put the effect(s) on one sensor axis only (x, y or z): the whole magnitude there, the
    /// other axes zero (`analyze` names it e.g. `quadratic (z)`); for a cross term, its output
    /// axis (the monomial is drawn); not for `outliers`.
    #[arg(long, value_parser = parse_axis)]
    pub axis: Option<usize>,
    /// Instead, a calibration protocol with an IMU (accelerometer and gyro in raw 16-bit
    /// counts): six-faces | one-pose | ferraris | rate-table | turntable | face-missing,
    /// written as t,ax,ay,az,gx,gy,gz (the turntable: gx,gy,gz, no clock), the truth in
    /// FILE.truth.json (see `wiical_sim::protocols`).
    #[arg(
        long,
        value_parser = parse_protocol,
        conflicts_with_all = ["effect", "magnitude", "device", "profile", "poses", "no_temp", "axis"]
    )]
    pub protocol: Option<SimProtocol>,
    /// With --protocol: write no time column.
    #[arg(long, requires = "protocol")]
    pub no_clock: bool,
}

/// `--protocol`: one of the protocols' names.
fn parse_protocol(s: &str) -> Result<SimProtocol, String> {
    SimProtocol::parse(s).ok_or_else(|| {
        let names: Vec<&str> = SimProtocol::ALL.iter().map(|p| p.name()).collect();
        format!("'{s}': expected one of {}", names.join(", "))
    })
}

/// `--axis`: x, y or z.
fn parse_axis(s: &str) -> Result<usize, String> {
    wiical_analysis::report::effect_names::AXES
        .iter()
        .position(|a| *a == s)
        .ok_or_else(|| format!("'{s}': expected x, y or z"))
}

fn parse_effect(s: &str) -> Result<SimEffect, String> {
    SimEffect::parse_simulated(s).ok_or_else(|| {
        let names: Vec<&str> = SimEffect::simulated().map(|e| e.name()).collect();
        format!("'{s}': expected one of {}", names.join(", "))
    })
}

fn parse_device(s: &str) -> Result<Device, String> {
    Device::parse(s).ok_or_else(|| format!("'{s}': expected wiimote, nunchuk or mems16"))
}

/// `--rate`: 20 to 2000 Hz (the simulator's bounds).
fn parse_rate(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(r) if (20.0..=2000.0).contains(&r) => Ok(r),
        Ok(r) => Err(format!("{r} Hz: give 20 to 2000")),
        Err(_) => Err(format!("'{s}' is not a number")),
    }
}

fn parse_profile(s: &str) -> Result<Profile, String> {
    Profile::parse(s).ok_or_else(|| format!("'{s}': expected calm or brisk"))
}

/// Pairs `--effect` with `--magnitude` (none, one for all, or one per effect).
fn effect_specs(
    effects: &[SimEffect],
    mags: &[f64],
    axis: Option<usize>,
) -> Result<Vec<EffectSpec>> {
    if mags.len() > 1 && mags.len() != effects.len() {
        anyhow::bail!(
            "--magnitude: {} values for {} effects (give one for all or one per effect)",
            mags.len(),
            effects.len()
        );
    }
    Ok(effects
        .iter()
        .enumerate()
        .map(|(i, e)| EffectSpec {
            axis,
            ..EffectSpec::new(*e, mags.get(i).or(mags.first()).copied())
        })
        .collect())
}

/// `--poses`: 1 to [`MAX_POSES`].
fn parse_poses(s: &str) -> Result<usize, String> {
    let n: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a whole number"))?;
    if (1..=MAX_POSES).contains(&n) {
        Ok(n)
    } else {
        Err(format!("{n} poses: give 1 to {MAX_POSES} (a larger simulation would write a file the readers refuse)"))
    }
}

/// Most poses a simulation writes (≈ 110 MB of CSV).
pub const MAX_POSES: usize = 5000;

/// Runs `wiical simulate`; returns what to print.
pub fn run(a: &Args) -> Result<String> {
    // `-` is refused as every command's --out is (it would be a file named "-").
    super::check_outputs(&[], &[Some(&a.out)])?;
    if let Some(protocol) = a.protocol {
        return run_protocol(a, protocol);
    }
    let effects = effect_specs(&a.effect, &a.magnitude, a.axis)?;
    let cfg = SimConfig {
        effects,
        seed: a.seed,
        device: a.device,
        poses: a.poses,
        rate_hz: a.rate.unwrap_or_else(|| a.device.typical_rate_hz()),
        profile: a.profile,
        temp_column: !a.no_temp,
        ..Default::default()
    };
    // The simulator's errors are its own (a setting, a write, a self-check) and read as they
    // are: no engine setting behind them that `cli_error` would name a flag for.
    let sim = wiical_sim::simulate(&cfg)?;
    let truth = wiical_sim::write(&sim, &a.out)?;
    let mut o = String::new();
    writeln!(
        o,
        "wrote {} ({} samples, {} poses, {} {}, effect {} at {} mg) and the truth {}",
        a.out.display(),
        sim.recording.len(),
        sim.truth.poses.len() - 1,
        sim.truth.device,
        if sim.recording.temp.is_some() {
            "with temp"
        } else {
            "without temp"
        },
        sim.truth.effect,
        if sim.truth.magnitudes_mg.len() > 1 {
            sim.truth
                .magnitudes_mg
                .iter()
                .map(|m| m.to_string())
                .collect::<Vec<_>>()
                .join(",")
        } else {
            sim.truth.magnitude_mg.to_string()
        },
        truth.display()
    )?;
    Ok(o)
}

/// `wiical simulate --protocol`: the protocol at `--seed`, `--rate` (default 100 Hz) and
/// `--no-clock`, everything else at the simulator's defaults.
fn run_protocol(a: &Args, protocol: SimProtocol) -> Result<String> {
    let defaults = ProtocolSimOptions::default();
    let o = ProtocolSimOptions {
        protocol,
        seed: a.seed,
        rate_hz: a.rate.unwrap_or(defaults.rate_hz),
        no_clock: a.no_clock,
        ..defaults
    };
    let sim = simulate_protocol(&o);
    let truth = write_protocol(&sim, &a.out)?;
    Ok(format!(
        "wrote {} ({} samples at {} Hz, protocol {}, columns {}) and the truth {}\n",
        a.out.display(),
        sim.len(),
        sim.truth.rate_hz,
        sim.truth.protocol,
        sim.truth.columns.join(","),
        truth.display()
    ))
}

//! Errors of the analysis engine as the command line tells them: where a message concerns a
//! setting, it names the flag that changes it (the engine's own messages name no flags).

use anyhow::anyhow;
use wiical_analysis::detect::{DetectError, Setting};
use wiical_analysis::fit::FitError;
use wiical_analysis::gyro::request::{GyroArgError, NominalSetting};
use wiical_analysis::gyro::GyroError;
use wiical_analysis::input::InputError;
use wiical_analysis::Error;

/// Converts an engine error into the CLI's error, naming flags where a setting is concerned.
/// Causes are kept as a chain, printed `outer: inner` by `main`. Takes a stage's own error
/// (`DetectError`, `FitError`, …) as well as the engine's [`Error`] that joins them.
pub fn cli_error(e: impl Into<Error>) -> anyhow::Error {
    match e.into() {
        Error::InFile { path, source } => {
            cli_error(*source).context(format!("in {}", path.display()))
        }
        Error::Input(InputError::ColumnsNeedHeader) => {
            anyhow!("--columns needs a CSV file with a header; this file has no header")
        }
        Error::Input(InputError::NoAxisColumns { header }) => anyhow!(
            "no x/y/z columns recognised in the header ({header}); name them x,y,z (or ax,ay,az / mx,my,mz / gx,gy,gz), or choose them with --columns"
        ),
        Error::ColumnsNotThree(names) => anyhow!(
            "--columns needs exactly three names (x,y,z), got {}: {}",
            names.len(),
            names.join(",")
        ),
        Error::Detect(DetectError::WindowTooLong { samples, max }) => anyhow!(
            "window of {samples} samples exceeds the maximum {max}; use a shorter --window-s"
        ),
        Error::Detect(DetectError::Saturated {
            window,
            start,
            end,
            axis,
            value,
            sample,
        }) => anyhow!(
            "{}: static window {window} (samples {start}..{end}) has axis {axis} at the ADC limit ({value}) in sample {sample}: that pose is saturated and cannot be used; re-record it or pass --adc-range",
            wiical_core::Error::Saturated
        ),
        Error::Fit(FitError::TooFewWindows {
            found,
            needed,
            model,
            adaptive: false,
        }) => anyhow!(
            "found {found} static windows but the {model} needs at least {needed}: hold the sensor still in more orientations (or lower --min-static-s / raise --threshold)"
        ),
        Error::Detect(DetectError::DetectorSetting { setting, why }) => {
            let flag = match setting {
                Setting::InitialRest => "--init-s",
                Setting::MinStatic => "--min-static-s",
                Setting::Threshold => "--threshold",
            };
            anyhow!("{flag} ({setting}) is too short or invalid: {why}")
        }
        Error::Input(InputError::AxisIsNotAnAxis { name }) => anyhow!(
            "--columns: column '{name}' is not a sensor axis (it is the time, temperature or pose column); give three axis columns"
        ),
        e @ Error::Detect(DetectError::RateTooLow { .. }) => {
            anyhow!("{e} (a table of window means is read with --windows)")
        }
        Error::Fit(FitError::AnotherSensor { evidence, fit }) => {
            anyhow!("{evidence}; the accelerometer's fit: {:#}", cli_error(*fit))
        }
        e @ Error::Fit(FitError::PoseTable { .. }) => {
            anyhow!("{e}: use `wiical six-position FILE` or `wiical analyze FILE`")
        }
        Error::Gyro(GyroError::Arg(e)) => gyro_arg_error(e),
        other => anyhow::Error::new(other),
    }
}

/// A `gyrofit` request's argument error, naming the flags.
fn gyro_arg_error(e: GyroArgError) -> anyhow::Error {
    match e {
        GyroArgError::ColumnsNotThree(names) => anyhow!(
            "--gyro-columns needs exactly three names (e.g. gx,gy,gz), got {}: {}",
            names.len(),
            names.join(",")
        ),
        GyroArgError::NotPerAxis { setting, given } => {
            let flag = match setting {
                NominalSetting::Scale => "--scale",
                NominalSetting::CountsPerDps => "--counts-per-dps",
            };
            anyhow!("{flag} takes one value or three (x,y,z), got {given}")
        }
        GyroArgError::BothNominals => anyhow!("give either --scale or --counts-per-dps, not both"),
        e @ GyroArgError::NominalUnusable => anyhow::Error::new(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_are_named_and_the_file_is_kept() {
        let e = Error::from(InputError::ColumnsNeedHeader).in_file("rec.txt");
        assert_eq!(
            format!("{:#}", cli_error(e)),
            "in rec.txt: --columns needs a CSV file with a header; this file has no header"
        );
        let e = FitError::TooFewWindows {
            found: 4,
            needed: 9,
            model: "9-parameter model",
            adaptive: false,
        };
        assert!(format!("{:#}", cli_error(e)).contains("--min-static-s"));
        // The adaptive detector already tried its shortest holds: no flag to suggest.
        let e = FitError::TooFewWindows {
            found: 4,
            needed: 9,
            model: "9-parameter model",
            adaptive: true,
        };
        let text = format!("{:#}", cli_error(e));
        assert!(!text.contains("--"), "{text}");
        assert!(text.contains("record again"), "{text}");
        // Millisecond times: the engine's question, plus the flag for window-mean tables.
        let text = format!("{:#}", cli_error(DetectError::RateTooLow { rate_hz: 0.1 }));
        assert!(text.contains("milliseconds"), "{text}");
        assert!(
            text.ends_with("(a table of window means is read with --windows)"),
            "{text}"
        );
        // A pose table given to `fit`: the commands that take it.
        let text = format!("{:#}", cli_error(FitError::PoseTable { rows: 6 }));
        assert!(text.contains("wiical six-position FILE"), "{text}");
        // Others keep the engine's message and its causes.
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "gone");
        let e = Error::from(InputError::Read {
            path: "x.csv".into(),
            source: io,
        });
        assert_eq!(format!("{:#}", cli_error(e)), "cannot read x.csv: gone");
    }
}

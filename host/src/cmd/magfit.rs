//! `wiical magfit`: magnetometer hard/soft-iron fit, and the residual loop around it (noise
//! floor, candidate effects, detection limits, verdict).

use super::{check_outputs, print_notes, to_json, with_spinner, write_calibration};
use crate::cli_error::cli_error;
use crate::render;
use anyhow::{anyhow, Result};
use std::path::{Path, PathBuf};
use wiical_analysis::input::text_source::{large, TextSource};
use wiical_analysis::magnetometer::MagModel;
use wiical_analysis::source::RowSource;
use wiical_analysis::{LoadOptions, MagfitOutput, MagfitRequest, Recording};
use wiical_core::Calibration;

/// Arguments of `wiical magfit`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Recording: CSV with header (mx,my,mz or x,y,z) or whitespace `x y z` text.
    pub file: PathBuf,
    /// sphere | axis | ellipsoid.
    #[arg(long, default_value = "ellipsoid", value_parser = clap::value_parser!(MagModel))]
    pub model: MagModel,
    /// Header names of the x,y,z columns to use.
    #[arg(long, value_delimiter = ',')]
    pub columns: Option<Vec<String>>,
    /// How the file is read (hidden flags).
    #[command(flatten)]
    pub read: super::ReadArgs,
    /// Header names of columns the hard iron may follow (current, throttle, PWM): each is
    /// tested as an interference `offset = k × column` (ArduPilot COMPASS_MOT's model).
    #[arg(long, value_delimiter = ',')]
    pub follow: Option<Vec<String>>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Write the calibration (centre as bias, W/radius as matrix: unit field) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

impl Args {
    /// The engine's request from the flags (`--out`, `--json` and the reading in passes are
    /// the command line's own).
    fn request(&self) -> MagfitRequest {
        MagfitRequest {
            model: self.model,
            columns: self.columns.clone(),
            follow: self.follow.clone().unwrap_or_default(),
            read: self.read.options(),
            ..MagfitRequest::new(self.file.as_path())
        }
    }
}

/// Runs `wiical magfit`; returns what to print.
pub fn run(a: &Args) -> Result<String> {
    check_outputs(&[&a.file], &[a.out.as_deref()])?;
    let req = a.request();
    let opts = req.load_options().map_err(cli_error)?;
    let file = a.file.as_path();
    let out = match open_in_passes(a, &opts)? {
        Some(src) => fit_and_loop(a, &req, &src, |name, o| column_in_passes(file, name, o))?,
        None => {
            let rec = super::load_held(file, &opts, "magfit", super::PLAIN_TEXT_IN_PASSES)?;
            fit_and_loop(a, &req, &rec, |_, o| column_held(file, o))?
        }
    };
    if let Some(path) = &a.out {
        let rep = &out.fit;
        let k = rep.matrix.map(|r| r.map(|x| (x / rep.radius) as f32));
        let cal = Calibration {
            bias: rep.center.map(|x| x as f32),
            matrix: k,
            effects: Default::default(),
        };
        write_calibration(path, &cal)?;
    }
    if a.json {
        return to_json(&out);
    }
    let mut text = render::magfit_text(&out.fit, &a.file.display().to_string());
    text.push_str(&render::magfit::analysis_text(&out.analysis, out.unit));
    Ok(text)
}

/// The request run on `src` (the field's rows, held or read in passes: the same code), its
/// `--follow` columns read as it is (`open_column` with a column's name and load options).
fn fit_and_loop<R: RowSource>(
    a: &Args,
    req: &MagfitRequest,
    src: &R,
    open_column: impl Fn(&str, &LoadOptions) -> Result<R>,
) -> Result<MagfitOutput> {
    req.run(src, |name, o| open_column(name, o).map_err(Followed::Door))
        .map_err(|e| follow_error(e, &a.file))
}

/// Why the request gave nothing: the command line's reading of a followed column, or the
/// engine's refusal (of the fit, the loop, or a followed column with empty rows).
enum Followed {
    /// The command line's reading of the column failed (its message already told).
    Door(anyhow::Error),
    /// The engine refused.
    Engine(wiical_analysis::Error),
}

impl From<wiical_analysis::Error> for Followed {
    fn from(e: wiical_analysis::Error) -> Self {
        Followed::Engine(e)
    }
}

/// The request's error, told the command line's way (`--follow` and the file named for a
/// followed column with empty rows).
fn follow_error(e: Followed, file: &Path) -> anyhow::Error {
    use wiical_analysis::magnetometer::MagnetometerError;
    match e {
        Followed::Door(e) => e,
        Followed::Engine(wiical_analysis::Error::Magnetometer(MagnetometerError::FollowRows {
            column,
            got,
            rows,
        })) => anyhow!(
            "--follow {column}: {got} rows in {} against {rows} of the field (a row where one \
             is empty): give a column filled on every row",
            file.display()
        ),
        Followed::Engine(e) => cli_error(e),
    }
}

/// The field's rows read in passes from the file (memory bounded) when it is a regular plain
/// text file of at least `--stream-from-bytes`; `None`: it is held whole.
fn open_in_passes(a: &Args, opts: &LoadOptions) -> Result<Option<TextSource>> {
    if !large(&a.file, opts.read.stream_from_bytes) {
        return Ok(None);
    }
    let src = with_spinner(&format!("reading {}", a.file.display()), || {
        TextSource::open_from(&a.file, opts, 0)
    })
    .map_err(cli_error)?;
    if let Some(src) = &src {
        print_notes(&a.file, &src.meta);
    }
    Ok(src)
}

/// The followed column `name` of `file` read in passes (the field was: the file must still be
/// plain text).
fn column_in_passes(file: &Path, name: &str, opts: &LoadOptions) -> Result<TextSource> {
    let col = TextSource::open(file, opts, |_| true).map_err(|e| e.in_file(file));
    col.map_err(cli_error)?.ok_or_else(|| {
        anyhow!(
            "--follow {name}: {} is no longer plain text (was it replaced while read?)",
            file.display()
        )
    })
}

/// A followed column of `file` held whole (the field was).
fn column_held(file: &Path, opts: &LoadOptions) -> Result<Recording> {
    use wiical_analysis::input::front_door::{load_held, HoldLimit};
    let limit = HoldLimit::of("magfit", super::PLAIN_TEXT_IN_PASSES);
    load_held(file, opts, limit).map_err(cli_error)
}

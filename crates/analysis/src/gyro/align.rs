//! Pairing the accelerometer's rows with the gyro's: held recordings by position when both
//! have the same samples, by time when the gyro's rows are a subset (a capture whose rows
//! alternate); large plain text files ([`TextImu`], read in passes, never held) by position
//! only. Both are an [`ImuPair`].

use super::options::{GyroError, Result};
use crate::error::Error;
use crate::input::columns::{all_named, LoadOptions, Sensor};
use crate::input::recording::Recording;
use crate::input::text_source::{large, TextSource};
use crate::source::RowSource;
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// Two held recordings of the same samples, row by row: the accelerometer's and the gyro's,
/// and whether they were paired by time (a subset of the accelerometer's rows).
pub(super) type Paired<'a> = (Cow<'a, Recording>, Cow<'a, Recording>, bool);

/// `acc` and `gyro` paired: by position when the lengths agree (each with the other's
/// temperature and sample rate where it states none, so the pair read the other way round is
/// the same rows), else (a capture whose rows alternate between gyro and other data, so the
/// loader skipped the rows without gyro values) the accelerometer rows at the gyro rows'
/// times, with those times (their rate from them, not from the file's Fs).
pub(super) fn pair<'a>(acc: &'a Recording, gyro: &'a Recording) -> Result<Paired<'a>> {
    if acc.len() == gyro.len() {
        return Ok((filled(acc, gyro), filled(gyro, acc), false));
    }
    let mismatch = || GyroError::GyroRowsMismatch {
        accel: acc.len(),
        gyro: gyro.len(),
    };
    let (Some(ta), Some(tg)) = (&acc.t, &gyro.t) else {
        return Err(mismatch());
    };
    // A subset of the rows (a capture whose rows alternate): it must span the recording, not
    // stop early (a cut-off gyro file would silently drop the rest of the accelerometer).
    let span = |t: &[f64]| t.last().copied().unwrap_or(0.0) - t.first().copied().unwrap_or(0.0);
    if span(tg) < 0.95 * span(ta) {
        return Err(GyroError::GyroSpanShort {
            gyro: (
                tg.first().copied().unwrap_or(0.0),
                tg.last().copied().unwrap_or(0.0),
            ),
            accel: (
                ta.first().copied().unwrap_or(0.0),
                ta.last().copied().unwrap_or(0.0),
            ),
        });
    }
    let mut out = Vec::with_capacity(tg.len());
    let mut i = 0;
    for t in tg {
        while i < ta.len() && ta[i] < *t {
            i += 1;
        }
        if i >= ta.len() || ta[i] != *t {
            return Err(mismatch());
        }
        out.push(acc.xyz[i]);
    }
    let acc = Recording {
        xyz: out,
        t: Some(tg.clone()),
        ..Default::default()
    };
    Ok((Cow::Owned(acc), Cow::Borrowed(gyro), true))
}

/// `rec` with `other`'s temperature and sample rate where it states none (either file of a
/// pair may state them).
fn filled<'a>(rec: &'a Recording, other: &Recording) -> Cow<'a, Recording> {
    let temp = rec.temp.is_none() && other.temp.is_some();
    let rate = rec.sample_rate_hz.is_none() && other.sample_rate_hz.is_some();
    if !(temp || rate) {
        return Cow::Borrowed(rec);
    }
    Cow::Owned(Recording {
        temp: rec.temp.clone().or_else(|| other.temp.clone()),
        sample_rate_hz: rec.sample_rate_hz.or(other.sample_rate_hz),
        ..rec.clone()
    })
}

/// The accelerometer's and the gyro's rows of one recording, as `gyrofit` reads them: held
/// recordings ([`ImuPair::held`]) or large plain text files read in passes ([`open_text`]:
/// for one file, two sources of it with different columns). Everything `gyrofit` does with
/// them is written once, for both ([`crate::gyro::request::gyrofit_of`]).
///
/// Memory, read in passes, is a piece of each file in flight, the windows, and the motions'
/// samples with a second either side (what the fit integrates, dozens of times: a pass over
/// the file per integration would cost hundreds of passes); on a multi-position recording
/// those are a small fraction of the rows (docs/gyro.md, "Large files").
#[derive(Debug)]
pub struct ImuPair<S> {
    pub(super) acc: S,
    pub(super) gyro: S,
    /// The files a failed pass is reported in (held rows never fail).
    pub(super) acc_path: PathBuf,
    pub(super) gyro_path: PathBuf,
}

/// Large plain text files read in passes ([`open_text`]).
pub type TextImu = ImuPair<TextSource>;

impl<S: RowSource> ImuPair<S> {
    /// Whether the passes read both files whole (a file changed or unreadable during one is
    /// that file's error).
    pub(super) fn check(&self) -> crate::Result<()> {
        self.acc.check().map_err(|e| e.in_file(&self.acc_path))?;
        self.gyro.check().map_err(|e| e.in_file(&self.gyro_path))
    }
}

impl ImuPair<Recording> {
    /// The accelerometer's recording and the gyro's, held.
    pub fn held(acc: Recording, gyro: Recording) -> Self {
        Self {
            acc,
            gyro,
            acc_path: PathBuf::new(),
            gyro_path: PathBuf::new(),
        }
    }
}

/// The accelerometer (`acc`: its file and columns) and the gyro — of the file `gyro_file`
/// (its columns), else of the accelerometer's file (`gyro_columns`, else the triplet the
/// header names as a gyroscope's, as [`crate::input::front_door::load_imu`] takes it) —
/// opened as sources when one of the files is a regular plain text file of at least
/// `stream_from` bytes and the paired rows would be the held pair's: the same number of rows
/// in both, and the rate and temperature from the accelerometer's file as from the gyro's
/// (always for one file). `None` (a capture whose gyro rows are a subset, two files of which
/// only one states a rate): read them whole.
pub fn open_text(
    acc: (&Path, &LoadOptions),
    gyro_file: Option<(&Path, &LoadOptions)>,
    gyro_columns: Option<[String; 3]>,
    stream_from: u64,
) -> crate::Result<Option<TextImu>> {
    let named = gyro_file.is_none() && gyro_columns.is_none();
    let same_file = LoadOptions {
        columns: gyro_columns,
        sensor: Some(Sensor::Gyroscope),
        read: acc.1.read,
    };
    let (gyro_path, gyro_opts) = gyro_file.unwrap_or((acc.0, &same_file));
    let paths = [acc.0, gyro_path];
    if !paths.iter().any(|p| large(p, stream_from)) || !paths.iter().all(|p| large(p, 0)) {
        return Ok(None);
    }
    let (a, g) = std::thread::scope(|s| {
        let g = s.spawn(|| TextSource::open_from(gyro_path, gyro_opts, 0));
        (TextSource::open_from(acc.0, acc.1, 0), g.join())
    });
    let g = g.unwrap_or_else(|p| std::panic::resume_unwind(p));
    let (Some(a), Some(g)) = (a?, g?) else {
        return Ok(None);
    };
    if named && !all_named(&g.meta.axis_columns, Sensor::Gyroscope) {
        let taken = g.meta.axis_columns.join(",");
        return Err(Error::from(GyroError::NoGyroColumns { taken }).in_file(acc.0));
    }
    let pairs = a.len() == g.len()
        && a.meta.sample_rate_hz.is_some() == g.meta.sample_rate_hz.is_some()
        && a.has_temp() == g.has_temp();
    Ok(pairs.then(|| TextImu {
        acc: a,
        gyro: g,
        acc_path: acc.0.to_path_buf(),
        gyro_path: gyro_path.to_path_buf(),
    }))
}

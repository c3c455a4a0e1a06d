//! The one way a pipeline reads a recording's samples: [`SampleSource`] (the triplets) or
//! [`RowSource`] (the rows with their time and temperature), in order and as often as it needs,
//! whether they are held in memory (a slice, a [`Recording`]) or read again from a large file
//! in passes ([`TextSource`]). A fold written against it is the held and the large-file path at
//! once, so the two cannot drift apart.

use crate::input::recording::Recording;
use crate::input::text_source::{Row, TextSource};

/// Samples read in passes: a held recording's, or a large file's rows.
pub trait SampleSource {
    /// Calls `f` with every sample in order; a file's error (changed, unreadable) ends it.
    fn each(&self, f: &mut dyn FnMut(&[f64; 3])) -> crate::Result<()>;
}

impl SampleSource for [[f64; 3]] {
    fn each(&self, f: &mut dyn FnMut(&[f64; 3])) -> crate::Result<()> {
        self.iter().for_each(f);
        Ok(())
    }
}

impl SampleSource for Vec<[f64; 3]> {
    fn each(&self, f: &mut dyn FnMut(&[f64; 3])) -> crate::Result<()> {
        self.as_slice().each(f)
    }
}

impl SampleSource for TextSource {
    fn each(&self, f: &mut dyn FnMut(&[f64; 3])) -> crate::Result<()> {
        self.rows().for_each(|r| f(&r.xyz));
        self.check()
    }
}

/// A recording's rows read in passes, with what a pipeline reads besides the triplet (the
/// time and temperature columns): a held [`Recording`]'s, or a large file's ([`TextSource`]).
/// An iterator rather than [`SampleSource::each`]'s callback, so that columns read from
/// other sources (`magfit --follow`) are read in step with it.
pub trait RowSource {
    /// Rows in every pass.
    fn len(&self) -> usize;
    /// A pass over every row in order; a file's failure ends it early ([`RowSource::check`]).
    fn rows(&self) -> Box<dyn Iterator<Item = Row> + '_>;
    /// The first failure of a pass (a file changed or unreadable), after it.
    fn check(&self) -> crate::Result<()>;
    /// The names of the axes' columns (the field's unit is read off them).
    fn axis_columns(&self) -> &[String; 3];
    /// `Fs` from the file's metadata, Hz.
    fn sample_rate_hz(&self) -> Option<f64>;
    /// Whether the rows carry a time.
    fn has_time(&self) -> bool;
    /// Whether the rows carry a temperature.
    fn has_temp(&self) -> bool;
}

impl RowSource for Recording {
    fn len(&self) -> usize {
        self.xyz.len()
    }
    fn rows(&self) -> Box<dyn Iterator<Item = Row> + '_> {
        Box::new(self.xyz.iter().enumerate().map(|(i, xyz)| Row {
            t: self.t.as_ref().map(|t| t[i]),
            xyz: *xyz,
            temp: self.temp.as_ref().map(|v| v[i]),
        }))
    }
    fn check(&self) -> crate::Result<()> {
        Ok(())
    }
    fn axis_columns(&self) -> &[String; 3] {
        &self.axis_columns
    }
    fn sample_rate_hz(&self) -> Option<f64> {
        self.sample_rate_hz
    }
    fn has_time(&self) -> bool {
        self.t.is_some()
    }
    fn has_temp(&self) -> bool {
        self.temp.is_some()
    }
}

impl RowSource for TextSource {
    fn len(&self) -> usize {
        TextSource::len(self)
    }
    fn rows(&self) -> Box<dyn Iterator<Item = Row> + '_> {
        Box::new(TextSource::rows(self))
    }
    fn check(&self) -> crate::Result<()> {
        TextSource::check(self)
    }
    fn axis_columns(&self) -> &[String; 3] {
        &self.meta.axis_columns
    }
    fn sample_rate_hz(&self) -> Option<f64> {
        self.meta.sample_rate_hz
    }
    fn has_time(&self) -> bool {
        TextSource::has_time(self)
    }
    fn has_temp(&self) -> bool {
        TextSource::has_temp(self)
    }
}

//! The one way a pipeline reads a recording's samples: [`SampleSource`], in order and as often
//! as it needs, whether they are held in memory (a slice) or read again from a large file in
//! passes ([`TextSource`]). A fold written against it is the held and the large-file path at
//! once, so the two cannot drift apart.

use crate::input::text_source::TextSource;

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

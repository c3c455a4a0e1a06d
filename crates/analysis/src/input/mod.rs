//! Input: a file (or text) in → a [`recording::Recording`] (samples, time, temperature,
//! labels, rate) or, for files whose rows are still windows already, a
//! [`table::WindowTable`]. Every file comes in through [`front_door`]: sniffed once (gzip, raw
//! `.cwa` / `.bin` magic, else text), then one reader per kind.
//!
//! Every reader goes through [`bounded`] (caps on size and line length, one sentence per bad
//! field); the time column is checked by [`timecheck`], axis triplets are found by
//! [`columns`], and the formats are text/CSV ([`text`], its data rows parsed in parallel
//! chunks by `text_rows`), GRT (`grt`), raw Axivity /
//! GENEActiv files ([`raw`]) and window-mean text tables ([`window_means`]). Standard input too
//! long to hold is copied to a named temporary file that [`temp_files`] deletes on every exit
//! it can see (and on the next run, after one it could not).

pub mod bounded;
pub mod columns;
pub mod front_door;
pub(crate) mod grt;
pub mod raw;
pub mod read_options;
pub mod recording;
pub mod sample_summary;
pub mod table;
pub mod temp_files;
pub mod text;
pub(crate) mod text_csv;
pub mod text_file;
pub(crate) mod text_rows;
pub mod text_source;
pub(crate) mod text_spill;
pub mod timecheck;
pub mod window_means;

pub use crate::error::input::InputError;

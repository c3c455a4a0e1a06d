//! Input: a file (or text) in → a [`recording::Recording`] (samples, time, temperature,
//! labels, rate) or, for files whose rows are still windows already, a
//! [`table::WindowTable`]; [`window_table::load_input`] decides which.
//!
//! Every reader goes through [`bounded`] (caps on size and line length, one sentence per bad
//! field); the time column is checked by [`timecheck`], axis triplets are found by
//! [`columns`], and the formats are text/CSV ([`mod@load`], its data rows parsed in parallel
//! chunks by `text_rows`), GRT ([`grt`]), raw Axivity /
//! GENEActiv files ([`raw`]) and window-mean tables ([`window_table`]).

pub mod bounded;
pub mod columns;
pub mod grt;
pub mod load;
pub mod raw;
pub mod recording;
pub mod table;
pub(crate) mod text_rows;
pub mod timecheck;
pub mod window_table;

pub use crate::error::input::InputError;

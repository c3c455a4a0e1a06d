//! Where a raw file's blocks come from ([`Blocks`]: the file on disk or a file held whole) and
//! the reader that gives them a chunk at a time whatever the format ([`Reader`]). Both passes
//! read through it: the plan ([`super::samples::plan`]) and the sinks of the second pass
//! ([`super::load`]); its own module so that those two import it, not each other.

use super::cwa::BlockReader;
use super::geneactiv::{self, PageReader};
use super::{Block, RawFile, RawFormat};
use crate::error::Result;
use std::path::Path;

/// Where a raw file's blocks come from.
#[derive(Debug, Clone, Copy)]
pub enum Blocks<'a> {
    /// The regular file at this path, in this format
    /// ([`raw_file_format`](super::load::raw_file_format)): read a chunk of blocks at a time,
    /// never whole.
    File(&'a Path, RawFormat),
    /// A file read whole (standard input, a gzip file): its blocks are the one chunk.
    Held(&'a RawFile),
}

impl<'a> Blocks<'a> {
    /// A reader at the first block (each pass opens its own).
    pub(super) fn open(self) -> Result<Reader<'a>> {
        match self {
            Self::File(path, format) => Reader::open(path, format),
            Self::Held(raw) => Ok(Reader::Held(raw)),
        }
    }

    pub(super) fn format(self) -> RawFormat {
        match self {
            Self::File(_, format) => format,
            Self::Held(raw) => raw.format,
        }
    }
}

/// A raw file's blocks a chunk at a time, whatever its format (a held file: one chunk).
pub(super) enum Reader<'a> {
    Cwa(BlockReader),
    Bin(Box<PageReader<std::io::BufReader<std::fs::File>>>),
    Held(&'a RawFile),
}

impl Reader<'_> {
    pub(super) fn open(path: &Path, format: RawFormat) -> Result<Self> {
        Ok(match format {
            RawFormat::Cwa => Self::Cwa(BlockReader::open(path)?),
            RawFormat::GeneActiv => Self::Bin(Box::new(PageReader::open(path)?)),
        })
    }

    /// The channel names (a `.cwa` file's are known once its first block is decoded).
    pub(super) fn channels(&self) -> Vec<String> {
        match self {
            Self::Cwa(r) => r.channels(),
            Self::Bin(_) => geneactiv::CHANNELS.iter().map(|s| s.to_string()).collect(),
            Self::Held(raw) => raw.channels.clone(),
        }
    }

    pub(super) fn notes(&self) -> Vec<String> {
        match self {
            Self::Cwa(r) => r.notes(),
            Self::Bin(r) => r.notes(),
            Self::Held(raw) => raw.notes.clone(),
        }
    }

    pub(super) fn device(&self) -> String {
        match self {
            Self::Cwa(r) => r.header.device.to_string(),
            Self::Bin(r) => r.device(),
            Self::Held(raw) => raw.device.clone(),
        }
    }

    pub(super) fn header_rate_hz(&self) -> f64 {
        match self {
            Self::Cwa(r) => r.header.rate_hz,
            Self::Bin(r) => r.header_rate_hz(),
            Self::Held(raw) => raw.header_rate_hz,
        }
    }

    /// Every chunk of blocks in file order through `each`.
    pub(super) fn for_each_chunk(&mut self, mut each: impl FnMut(&Self, &[Block])) -> Result<()> {
        if let Self::Held(raw) = *self {
            each(self, &raw.blocks);
            return Ok(());
        }
        let mut chunk = Vec::new();
        loop {
            let more = match self {
                Self::Cwa(r) => r.next_chunk(&mut chunk)?,
                Self::Bin(r) => r.next_chunk(&mut chunk)?,
                Self::Held(_) => false,
            };
            each(self, &chunk);
            if !more {
                return Ok(());
            }
        }
    }
}

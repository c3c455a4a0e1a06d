//! Where a raw file's blocks come from ([`Blocks`]: the file on disk, or its bytes held in
//! memory) and the one reader that gives them a chunk at a time whatever the format and the
//! source ([`Reader`]): bytes in memory are read by the same block and page readers as a file,
//! a chunk at a time, so that a held file and one read from disk give the same blocks by
//! construction. Both passes read through it: the plan ([`super::samples::plan`]) and the sinks
//! of the second pass ([`super::load`]); its own module so that those two import it, not each
//! other.

use super::block::{Block, RawFormat};
use super::cwa::BlockReader;
use super::geneactiv::{self, PageReader};
use crate::error::Result;
use std::path::{Path, PathBuf};

/// Where a raw file's blocks come from.
#[derive(Debug, Clone, Copy)]
pub enum Blocks<'a> {
    /// The regular file at this path, in this format
    /// ([`raw_file_format`](super::load::raw_file_format)): read a chunk of blocks at a time,
    /// never whole.
    File(&'a Path, RawFormat),
    /// A file's bytes held in memory (standard input, a gzip file's content), in this format
    /// ([`detect`](super::detect)): read a chunk at a time as the file would be.
    Bytes(&'a [u8], RawFormat),
}

impl<'a> Blocks<'a> {
    /// A reader at the first block (each pass opens its own); the header's errors.
    pub fn open(self) -> Result<Reader<'a>> {
        Ok(match self {
            Self::File(path, RawFormat::Cwa) => Reader::Cwa(BlockReader::open(path)?),
            Self::File(path, RawFormat::GeneActiv) => {
                Reader::Bin(Box::new(PageReader::open(path)?))
            }
            Self::Bytes(bytes, RawFormat::Cwa) => {
                Reader::Cwa(BlockReader::of_bytes(Path::new(""), Box::new(bytes))?)
            }
            Self::Bytes(bytes, RawFormat::GeneActiv) => {
                Reader::Bin(Box::new(PageReader::of_bytes(bytes)?))
            }
        })
    }

    /// The format of the blocks.
    pub fn format(self) -> RawFormat {
        match self {
            Self::File(_, format) | Self::Bytes(_, format) => format,
        }
    }
}

/// A raw file a reader can be opened on as often as it is read: a regular file's path, or a
/// file's bytes held in memory ([`Blocks`] of it).
#[derive(Debug, Clone)]
pub enum Raw {
    /// The regular file at this path, in this format.
    File(PathBuf, RawFormat),
    /// A file's bytes (standard input, a gzip file's content), in this format.
    Held(Vec<u8>, RawFormat),
}

impl Raw {
    /// Where its blocks come from.
    pub fn blocks(&self) -> Blocks<'_> {
        match self {
            Self::File(path, format) => Blocks::File(path, *format),
            Self::Held(bytes, format) => Blocks::Bytes(bytes, *format),
        }
    }
}

/// A raw file's blocks a chunk at a time, whatever its format and source.
pub enum Reader<'a> {
    /// An Axivity `.cwa` file's data blocks.
    Cwa(BlockReader<'a>),
    /// A GENEActiv `.bin` file's pages.
    Bin(Box<PageReader<Box<dyn std::io::BufRead + 'a>>>),
}

impl Reader<'_> {
    /// The channel names (a `.cwa` file's are known once its first block is decoded).
    pub fn channels(&self) -> Vec<String> {
        match self {
            Self::Cwa(r) => r.channels(),
            Self::Bin(_) => geneactiv::CHANNELS.iter().map(|s| s.to_string()).collect(),
        }
    }

    /// What the reader noticed that does not stop it (a cut-off last block), once read.
    pub fn notes(&self) -> Vec<String> {
        match self {
            Self::Cwa(r) => r.notes(),
            Self::Bin(r) => r.notes(),
        }
    }

    /// The device as the header names it (`AX3`, `AX6`, `GENEActiv 1.1`).
    pub fn device(&self) -> String {
        match self {
            Self::Cwa(r) => r.header.device.to_string(),
            Self::Bin(r) => r.device(),
        }
    }

    /// The sample rate the header declares, Hz.
    pub fn header_rate_hz(&self) -> f64 {
        match self {
            Self::Cwa(r) => r.header.rate_hz,
            Self::Bin(r) => r.header_rate_hz(),
        }
    }

    /// Every chunk of blocks in file order through `each`.
    pub fn for_each_chunk(&mut self, mut each: impl FnMut(&Self, &[Block])) -> Result<()> {
        let mut chunk = Vec::new();
        loop {
            let more = match self {
                Self::Cwa(r) => r.next_chunk(&mut chunk)?,
                Self::Bin(r) => r.next_chunk(&mut chunk)?,
            };
            each(self, &chunk);
            if !more {
                return Ok(());
            }
        }
    }

    /// Every block of the file in order, gathered (for a reader that looks at blocks out of
    /// order: GGIRread's grid, [`super::ggir`]; memory in proportion to the file).
    pub fn all_blocks(&mut self) -> Result<Vec<Block>> {
        let mut all = Vec::new();
        self.for_each_chunk(|_, chunk| all.extend_from_slice(chunk))?;
        Ok(all)
    }
}

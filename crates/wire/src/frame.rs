//! Framing: `COBS( postcard(msg) ‖ CRC-16 ) ‖ 0x00`.
//!
//! * The message is serialized with postcard; a CRC-16/IBM-3740 (a.k.a. CCITT-FALSE:
//!   poly `0x1021`, init `0xFFFF`) of those bytes is appended little-endian, so that a
//!   corrupted frame that still COBS-decodes and even still deserializes is rejected.
//! * The whole is COBS-encoded (no `0x00` inside) and terminated by one `0x00`, so a
//!   receiver can always resynchronise at the next `0x00`. A sender may also emit a lone
//!   `0x00` at any time (e.g. on connect) to flush a half-received frame: empty frames are
//!   ignored.
//!
//! Encoding uses postcard's own flavors (`CrcModifier` over `Cobs` over `Slice`). Decoding
//! uses the `cobs` crate postcard itself uses for `from_bytes_cobs`, then checks the CRC
//! before deserializing so that corruption is reported as such; postcard's
//! `CobsAccumulator` is not used because it has no CRC and, on overflow, restarts in the
//! middle of the oversize frame instead of discarding it up to the next delimiter.

use core::marker::PhantomData;

use crc::{Crc, CRC_16_IBM_3740};
use postcard::ser_flavors::{crc::CrcModifier, Cobs, Slice};
use serde::{de::DeserializeOwned, Serialize};

/// The CRC used inside every frame.
pub static CRC16: Crc<u16> = Crc::<u16>::new(&CRC_16_IBM_3740);

/// Size of the encode buffer and of [`DefaultFrameDecoder`]'s buffer. Every message of this
/// crate fits in a frame of this length (checked by the test `largest_messages_fit`).
pub const MAX_FRAME_LEN: usize = 640;

/// A [`FrameDecoder`] sized for every message of this crate.
pub type DefaultFrameDecoder = FrameDecoder<MAX_FRAME_LEN>;

/// What went wrong while encoding or decoding a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameError {
    /// Encoding: the output buffer is too small for the frame.
    BufferTooSmall,
    /// Encoding: postcard could not serialize the message.
    Serialize,
    /// Decoding: more bytes than the decoder's buffer arrived before a `0x00`; the rest of
    /// that frame is discarded up to the next `0x00`.
    Oversize,
    /// Decoding: the bytes between two `0x00` are not valid COBS.
    Cobs,
    /// Decoding: the frame is shorter than its CRC or the CRC does not match.
    Crc,
    /// Decoding: the CRC matched but the bytes are not a valid message of the expected type
    /// (e.g. an unknown enum variant from a newer schema).
    Deserialize,
    /// Decoding: the message decoded but did not use every byte before the CRC.
    TrailingBytes,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            FrameError::BufferTooSmall => "output buffer too small for the frame",
            FrameError::Serialize => "message could not be serialized",
            FrameError::Oversize => "frame longer than the receive buffer (discarded)",
            FrameError::Cobs => "invalid COBS encoding",
            FrameError::Crc => "CRC mismatch",
            FrameError::Deserialize => "frame is not a valid message",
            FrameError::TrailingBytes => "unexpected bytes after the message",
        })
    }
}

impl core::error::Error for FrameError {}

/// Encode `msg` as one complete frame (including the terminating `0x00`) into `buf`;
/// returns the frame, a prefix of `buf`.
pub fn encode_frame<'a, T: Serialize + ?Sized>(
    msg: &T,
    buf: &'a mut [u8],
) -> Result<&'a [u8], FrameError> {
    let map = |e: postcard::Error| match e {
        postcard::Error::SerializeBufferFull => FrameError::BufferTooSmall,
        _ => FrameError::Serialize,
    };
    let cobs = Cobs::try_new(Slice::new(buf)).map_err(map)?;
    let out = postcard::serialize_with_flavor(msg, CrcModifier::new(cobs, CRC16.digest()))
        .map_err(map)?;
    Ok(out)
}

/// Incremental frame decoder with a fixed buffer of `N` bytes (the largest accepted
/// COBS-encoded frame, delimiter excluded).
///
/// Feed it whatever chunks the serial port returns; it yields one item per frame: the
/// decoded message, or a [`FrameError`] for a corrupt or oversize frame, after which it
/// continues with the next frame. It never panics and never allocates.
#[derive(Debug, Clone)]
pub struct FrameDecoder<const N: usize> {
    buf: [u8; N],
    len: usize,
    discarding: bool,
}

impl<const N: usize> Default for FrameDecoder<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> FrameDecoder<N> {
    /// An empty decoder.
    pub const fn new() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            discarding: false,
        }
    }

    /// Drop any partially received frame (e.g. after reopening the port).
    pub fn reset(&mut self) {
        self.len = 0;
        self.discarding = false;
    }

    /// Number of bytes of the current, incomplete frame held in the buffer.
    pub fn buffered(&self) -> usize {
        self.len
    }

    /// Push one byte. Returns `Some` when the byte completes a frame (or overflows the
    /// buffer): the decoded message or the reason it was rejected.
    pub fn push_byte<T: DeserializeOwned>(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        if byte == 0 {
            let len = core::mem::replace(&mut self.len, 0);
            if core::mem::replace(&mut self.discarding, false) || len == 0 {
                // End of an oversize frame (already reported) or an empty frame.
                return None;
            }
            return Some(self.decode_buffer(len));
        }
        if self.discarding {
            return None;
        }
        match self.buf.get_mut(self.len) {
            Some(slot) => {
                *slot = byte;
                self.len += 1;
                None
            }
            None => {
                self.len = 0;
                self.discarding = true;
                Some(Err(FrameError::Oversize))
            }
        }
    }

    /// Feed a chunk of received bytes; iterate over the result to get every frame the
    /// chunk completes. Bytes of an incomplete trailing frame are kept for the next call.
    ///
    /// The iterator consumes the chunk lazily: drain it (e.g. with a `for` loop), or the
    /// bytes it has not reached yet are never fed.
    #[must_use = "the chunk is only consumed while the iterator is drained"]
    pub fn feed<'d, 'c, T: DeserializeOwned>(
        &'d mut self,
        chunk: &'c [u8],
    ) -> Frames<'d, 'c, T, N> {
        Frames {
            decoder: self,
            rest: chunk,
            _msg: PhantomData,
        }
    }

    fn decode_buffer<T: DeserializeOwned>(&mut self, len: usize) -> Result<T, FrameError> {
        let frame = self.buf.get_mut(..len).ok_or(FrameError::Oversize)?;
        let n = cobs::decode_in_place(frame).map_err(|_| FrameError::Cobs)?;
        let raw = frame.get(..n).ok_or(FrameError::Cobs)?;
        let split = n.checked_sub(2).ok_or(FrameError::Crc)?;
        let (body, crc) = raw.split_at(split);
        if CRC16.checksum(body).to_le_bytes() != [crc[0], crc[1]] {
            return Err(FrameError::Crc);
        }
        let (msg, rest) =
            postcard::take_from_bytes::<T>(body).map_err(|_| FrameError::Deserialize)?;
        if rest.is_empty() {
            Ok(msg)
        } else {
            Err(FrameError::TrailingBytes)
        }
    }
}

/// Iterator over the frames completed by one chunk; see [`FrameDecoder::feed`].
pub struct Frames<'d, 'c, T, const N: usize> {
    decoder: &'d mut FrameDecoder<N>,
    rest: &'c [u8],
    _msg: PhantomData<fn() -> T>,
}

impl<T, const N: usize> Frames<'_, '_, T, N> {
    /// Bytes of the chunk not consumed yet.
    pub fn remaining(&self) -> usize {
        self.rest.len()
    }
}

impl<T: DeserializeOwned, const N: usize> Iterator for Frames<'_, '_, T, N> {
    type Item = Result<T, FrameError>;

    fn next(&mut self) -> Option<Self::Item> {
        while let Some((&b, rest)) = self.rest.split_first() {
            self.rest = rest;
            if let Some(item) = self.decoder.push_byte(b) {
                return Some(item);
            }
        }
        None
    }
}

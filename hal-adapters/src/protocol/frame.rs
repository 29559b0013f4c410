//! Framing: header, payload and CRC, COBS-encoded and ended by a zero byte.
//!
//! ```text
//! raw frame:  version u8 | id u8 | seq u16 | len u16 | payload (len bytes) | crc u32
//! on the wire: COBS(raw frame) | 0x00
//! ```
//! The CRC is CRC-32/ISO-HDLC (the Ethernet/zlib CRC, `crc::CRC_32_ISO_HDLC`) of every byte
//! from the version to the payload's end, little-endian. COBS (the `cobs` crate) removes every
//! zero byte from the frame, so a zero only ever ends a frame: a receiver that starts in the
//! middle of a stream, or after garbage, resynchronises at the next zero.

use super::messages::{EncodeError, Message};
#[cfg(any(test, feature = "std"))]
extern crate std;

/// The protocol's version: the first byte of every frame. 2: the configuration frame carries
/// the GNSS correlated error (`docs/protocol.md`, changelog); a version-1 frame is refused by
/// version, not misread.
pub const VERSION: u8 = 5;

/// Header bytes before the payload: version, id, sequence number, payload length.
pub const HEADER_LEN: usize = 6;

/// CRC bytes after the payload.
pub const CRC_LEN: usize = 4;

/// Longest payload of any message [bytes].
pub const MAX_PAYLOAD: usize = 256;

/// Longest raw (unstuffed) frame [bytes].
pub const MAX_RAW: usize = HEADER_LEN + MAX_PAYLOAD + CRC_LEN;

/// Longest frame on the wire, its zero delimiter included [bytes]: a buffer of this size
/// holds any frame.
pub const MAX_FRAME: usize = cobs::max_encoding_length(MAX_RAW) + 1;

/// The frame check: CRC-32/ISO-HDLC.
pub const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Encodes messages into frames, numbering them (the decoder counts gaps in the numbers).
#[derive(Clone, Copy, Debug, Default)]
pub struct Encoder {
    seq: u16,
}

/// A frame could not be written to an `embedded_io::Write`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WriteError<E> {
    /// The message could not be encoded.
    Encode(EncodeError),
    /// The writer failed.
    Io(E),
}

impl Encoder {
    /// An encoder whose next frame has sequence number 0.
    pub const fn new() -> Self {
        Self { seq: 0 }
    }

    /// The sequence number of the next frame.
    pub fn next_seq(&self) -> u16 {
        self.seq
    }

    /// Encodes `message` as one frame into `out` (with its zero delimiter); returns the
    /// frame's length. `out` of [`MAX_FRAME`] bytes always suffices.
    pub fn encode(&mut self, message: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
        let mut raw = [0u8; MAX_RAW];
        let len = message.write_payload(&mut raw[HEADER_LEN..HEADER_LEN + MAX_PAYLOAD])?;
        raw[0] = VERSION;
        raw[1] = message.id() as u8;
        raw[2..4].copy_from_slice(&self.seq.to_le_bytes());
        raw[4..6].copy_from_slice(&(len as u16).to_le_bytes());
        let end = HEADER_LEN + len;
        let crc = CRC.checksum(&raw[..end]);
        raw[end..end + CRC_LEN].copy_from_slice(&crc.to_le_bytes());
        let raw = &raw[..end + CRC_LEN];
        let n = cobs::try_encode(raw, out).map_err(|_| EncodeError::BufferTooSmall)?;
        *out.get_mut(n).ok_or(EncodeError::BufferTooSmall)? = 0;
        self.seq = self.seq.wrapping_add(1);
        Ok(n + 1)
    }

    /// Appends the frame of `message` to `out` (host side); returns its length.
    #[cfg(any(test, feature = "std"))]
    pub fn append(
        &mut self,
        message: &Message,
        out: &mut std::vec::Vec<u8>,
    ) -> Result<usize, EncodeError> {
        let mut buf = [0u8; MAX_FRAME];
        let n = self.encode(message, &mut buf)?;
        out.extend_from_slice(&buf[..n]);
        Ok(n)
    }

    /// Encodes `message` and writes the frame to `w` (a UART, a file).
    pub fn write<W: embedded_io::Write>(
        &mut self,
        message: &Message,
        w: &mut W,
    ) -> Result<(), WriteError<W::Error>> {
        let mut buf = [0u8; MAX_FRAME];
        let n = self.encode(message, &mut buf).map_err(WriteError::Encode)?;
        w.write_all(&buf[..n]).map_err(WriteError::Io)
    }
}

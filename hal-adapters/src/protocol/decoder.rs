//! The streaming decoder: bytes in, messages out, with what it refused counted.
//!
//! Bytes are gathered up to a zero (the frame delimiter), then COBS-decoded, and the raw frame
//! checked in this order: length (at least a header and a CRC), CRC, version, message id, the
//! payload length of that id, the payload's fields. Anything refused is reported with its
//! [`Refusal`] and its bytes counted as skipped; the decoder is then ready for the next frame,
//! so it resynchronises after garbage at the next zero. Zero bytes between frames are idle
//! fill, not counted. A frame longer than [`MAX_FRAME`] is dropped as it arrives (bounded
//! memory, `no_std`).

use super::frame::{CRC, CRC_LEN, HEADER_LEN, MAX_FRAME, VERSION};
use super::messages::{Message, MessageId, PayloadError};
use core::fmt;

/// Why a frame was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Refusal {
    /// Longer than any frame ([`MAX_FRAME`]).
    TooLong,
    /// The COBS stuffing is broken.
    Cobs,
    /// Shorter than a header and a CRC.
    TooShort,
    /// The CRC does not match.
    Crc,
    /// A protocol version this decoder does not know.
    Version(u8),
    /// A message id this version does not define.
    UnknownId(u8),
    /// The payload length is not the message's.
    Length {
        /// The message.
        id: MessageId,
        /// The length in the header [bytes].
        len: u16,
    },
    /// A field of the payload is out of range.
    Payload(PayloadError),
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooLong => write!(f, "frame longer than {MAX_FRAME} bytes"),
            Self::Cobs => f.write_str("broken COBS stuffing"),
            Self::TooShort => f.write_str("frame shorter than its header and CRC"),
            Self::Crc => f.write_str("CRC mismatch"),
            Self::Version(v) => write!(f, "unknown protocol version {v} (this is {VERSION})"),
            Self::UnknownId(id) => write!(f, "unknown message id 0x{id:02x}"),
            Self::Length { id, len } => write!(
                f,
                "{} payload of {len} bytes (expected {})",
                id.name(),
                id.payload_len()
            ),
            Self::Payload(e) => write!(f, "payload: {e}"),
        }
    }
}

/// A sequence step of half the 16-bit range or more is read as going back, not as a gap.
const SEQ_HALF_RANGE: u16 = 1 << 15;

/// Reads a message's payload (its id and length checked).
type PayloadReader = fn(MessageId, &[u8]) -> Result<Message, PayloadError>;

/// A frame accepted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Received {
    /// Its sequence number.
    pub seq: u16,
    /// Its message.
    pub message: Message,
}

/// What the decoder has seen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DecodeStats {
    /// Bytes fed.
    pub bytes: u64,
    /// Bytes of refused frames and of a cut-off last frame (delimiters included).
    pub skipped_bytes: u64,
    /// Frames refused for their CRC.
    pub crc_failures: u32,
    /// Frames refused for any other reason.
    pub other_refusals: u32,
    /// Frames accepted, by message ([`MessageId::index`]).
    pub frames: [u32; MessageId::ALL.len()],
    /// Frames missing between accepted ones (gaps in the sequence numbers).
    pub frames_lost: u32,
    /// Frames whose sequence number repeats the previous frame's or goes back (by less than
    /// half the 16-bit range): counted here, not as a loss of nearly 65536 frames.
    pub frames_out_of_order: u32,
}

impl DecodeStats {
    /// Frames accepted, of every message.
    pub fn frames_total(&self) -> u32 {
        self.frames.iter().sum()
    }
}

/// The streaming decoder (module docs).
#[derive(Clone, Debug)]
pub struct Decoder {
    buf: [u8; MAX_FRAME],
    len: usize,
    /// The frame being gathered is longer than the buffer: dropped up to the next zero.
    overflowed: bool,
    last_seq: Option<u16>,
    stats: DecodeStats,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// A decoder waiting for its first frame.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME],
            len: 0,
            overflowed: false,
            last_seq: None,
            stats: DecodeStats {
                bytes: 0,
                skipped_bytes: 0,
                crc_failures: 0,
                other_refusals: 0,
                frames: [0; MessageId::ALL.len()],
                frames_lost: 0,
                frames_out_of_order: 0,
            },
        }
    }

    /// What it has seen so far.
    pub fn stats(&self) -> &DecodeStats {
        &self.stats
    }

    /// Feeds one byte: a message or a refusal when it ended a frame.
    pub fn feed(&mut self, byte: u8) -> Option<Result<Received, Refusal>> {
        self.feed_with(byte, Message::read_payload)
    }

    /// [`Self::feed`] with the payload read by `read`.
    fn feed_with(&mut self, byte: u8, read: PayloadReader) -> Option<Result<Received, Refusal>> {
        self.stats.bytes += 1;
        if byte != 0 {
            if self.len < MAX_FRAME {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflowed = true;
                self.stats.skipped_bytes += 1;
            }
            return None;
        }
        if self.len == 0 && !self.overflowed {
            return None; // idle fill
        }
        let result = if self.overflowed {
            Err(Refusal::TooLong)
        } else {
            self.frame(read)
        };
        match &result {
            Ok(r) => {
                let m = r.message.id().index();
                self.stats.frames[m] = self.stats.frames[m].saturating_add(1);
                if let Some(last) = self.last_seq {
                    let step = r.seq.wrapping_sub(last);
                    if step == 0 || step >= SEQ_HALF_RANGE {
                        self.stats.frames_out_of_order =
                            self.stats.frames_out_of_order.saturating_add(1);
                    } else {
                        let gap = u32::from(step - 1);
                        self.stats.frames_lost = self.stats.frames_lost.saturating_add(gap);
                    }
                }
                self.last_seq = Some(r.seq);
            }
            Err(e) => {
                // The frame's bytes and its delimiter (an overflow's bytes were counted as
                // they came).
                self.stats.skipped_bytes += self.len as u64 + 1;
                if *e == Refusal::Crc {
                    self.stats.crc_failures += 1;
                } else {
                    self.stats.other_refusals += 1;
                }
            }
        }
        self.len = 0;
        self.overflowed = false;
        Some(result)
    }

    /// Feeds `bytes`, handing every message or refusal to `on`.
    pub fn push(&mut self, bytes: &[u8], mut on: impl FnMut(Result<Received, Refusal>)) {
        for b in bytes {
            if let Some(r) = self.feed(*b) {
                on(r);
            }
        }
    }

    /// [`Self::push`] for a board's configuration input: the payloads of configuration
    /// frames only are read; a valid frame of another message is refused
    /// ([`PayloadError::NotTaken`]), and no other message's reader is linked in.
    pub fn push_config(&mut self, bytes: &[u8], mut on: impl FnMut(Result<Received, Refusal>)) {
        for b in bytes {
            if let Some(r) = self.feed_with(*b, Message::read_config_only) {
                on(r);
            }
        }
    }

    /// The end of the stream: bytes of a frame without its delimiter (cut off) are counted as
    /// skipped. Returns how many there were.
    pub fn finish(&mut self) -> usize {
        let n = self.len;
        self.stats.skipped_bytes += n as u64;
        self.len = 0;
        self.overflowed = false;
        n
    }

    /// Checks and decodes the gathered frame (module docs' order), its payload by `read`.
    fn frame(&mut self, read: PayloadReader) -> Result<Received, Refusal> {
        let n = cobs::decode_in_place(&mut self.buf[..self.len]).map_err(|_| Refusal::Cobs)?;
        let raw = &self.buf[..n];
        if n < HEADER_LEN + CRC_LEN {
            return Err(Refusal::TooShort);
        }
        let (body, crc) = raw.split_at(n - CRC_LEN);
        let crc = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
        if CRC.checksum(body) != crc {
            return Err(Refusal::Crc);
        }
        if body[0] != VERSION {
            return Err(Refusal::Version(body[0]));
        }
        let id = MessageId::from_id(body[1]).ok_or(Refusal::UnknownId(body[1]))?;
        let seq = u16::from_le_bytes([body[2], body[3]]);
        let len = u16::from_le_bytes([body[4], body[5]]);
        let payload = &body[HEADER_LEN..];
        if usize::from(len) != id.payload_len() || payload.len() != usize::from(len) {
            return Err(Refusal::Length { id, len });
        }
        let message = read(id, payload).map_err(Refusal::Payload)?;
        Ok(Received { seq, message })
    }
}

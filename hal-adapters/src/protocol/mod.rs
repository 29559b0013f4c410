//! The board's output protocol (version [`VERSION`]): binary frames, little-endian, COBS
//! framing with a zero delimiter, CRC-32/ISO-HDLC ([`frame`]); the messages ([`messages`]);
//! the streaming decoder that resynchronises after garbage ([`decoder`]); the status model
//! ([`status`]) and the vibration metric ([`vibration`]) of the health frame; the device
//! configuration, its validation and text form ([`config`], [`config_text`]); output rate
//! dividers ([`rate`]). The byte layouts are in `docs/protocol.md`.
//!
//! The firmware only calls it: the [`Encoder`] writes a frame into the caller's buffer or an
//! `embedded_io::Write`; nothing here allocates.

pub mod config;
pub mod config_text;
pub mod decoder;
pub mod frame;
pub mod messages;
mod payload;
pub mod rate;
#[cfg(any(test, feature = "selftest"))]
pub mod selftest;
pub mod status;
pub mod vibration;
mod wire;

#[cfg(test)]
pub(crate) mod tests;

pub use decoder::{DecodeStats, Decoder, Received, Refusal};
pub use frame::{Encoder, MAX_FRAME, VERSION};
pub use messages::{Message, MessageId};

//! Consistent Overhead Byte Stuffing (Cheshire & Baker, IEEE/ACM ToN 7(2), 1999) through the
//! `cobs` crate: removes every `0x00` from a packet at a cost of at most one byte per 254, so
//! `0x00` can delimit packets on a byte stream.
//!
//! The encoded packet is a sequence of blocks, each a code byte `c` (1 ..= 255) followed by
//! `c − 1` non-zero data bytes; a block with `c < 255` stands for its data followed by a zero,
//! except the last block, whose zero is implied by the end of the packet (a packet ending in
//! a full 254-byte block has no extra block). This module fixes the framing the serial link
//! relies on around the crate: the empty packet is one code byte, and a zero inside a packet
//! is an error rather than the end of it.

/// Largest encoded size of an `n`-byte packet (without the delimiter).
pub const fn max_encoded_len(n: usize) -> usize {
    cobs::max_encoding_length(n)
}

/// Why bytes are not a COBS packet.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CobsError {
    /// A `0x00` inside the packet (the delimiter belongs between packets).
    #[error("zero byte at offset {0} inside a COBS packet")]
    Zero(usize),
    /// The blocks do not add up: a code byte announces more bytes than follow.
    #[error("COBS packet truncated: its blocks run past its end")]
    Truncated,
}

/// Encodes `data` (without the trailing `0x00` delimiter).
pub fn encode(data: &[u8]) -> Vec<u8> {
    cobs::encode_vec(data)
}

/// Decodes one packet (without its delimiter). The empty packet decodes to nothing.
pub fn decode(packet: &[u8]) -> Result<Vec<u8>, CobsError> {
    if packet.is_empty() {
        return Ok(Vec::new());
    }
    // The crate would take a zero as the end of the packet and ignore the rest.
    if let Some(at) = packet.iter().position(|&b| b == 0) {
        return Err(CobsError::Zero(at));
    }
    cobs::decode_vec(packet).map_err(|_| CobsError::Truncated)
}

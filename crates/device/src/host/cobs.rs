//! Consistent Overhead Byte Stuffing (Cheshire & Baker, IEEE/ACM ToN 7(2), 1999): removes
//! every `0x00` from a packet at a cost of at most one byte per 254, so `0x00` can delimit
//! packets on a byte stream.
//!
//! The encoded packet is a sequence of blocks, each a code byte `c` (1 ..= 255) followed by
//! `c − 1` non-zero data bytes; a block with `c < 255` stands for its data followed by a zero,
//! except the last block, whose zero is implied by the end of the packet.

/// Largest encoded size of an `n`-byte packet (without the delimiter).
pub const fn max_encoded_len(n: usize) -> usize {
    n + n / 254 + 1
}

/// Why bytes are not a COBS packet.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CobsError {
    /// A `0x00` inside the packet (the delimiter belongs between packets).
    #[error("zero byte at offset {0} inside a COBS packet")]
    Zero(usize),
    /// A block's code byte announces more bytes than follow.
    #[error("COBS block at offset {0} runs past the end of the packet")]
    Truncated(usize),
}

/// Encodes `data` (without the trailing `0x00` delimiter).
pub fn encode(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(max_encoded_len(data.len()));
    let mut code_at = 0;
    let mut code: u8 = 1;
    out.push(0);
    for (i, &b) in data.iter().enumerate() {
        if b == 0 {
            out[code_at] = code;
            code_at = out.len();
            out.push(0);
            code = 1;
        } else {
            out.push(b);
            code += 1;
            // A full block (254 data bytes) has no implied zero; start another only if more
            // data follows.
            if code == 0xFF && i + 1 < data.len() {
                out[code_at] = code;
                code_at = out.len();
                out.push(0);
                code = 1;
            }
        }
    }
    out[code_at] = code;
    out
}

/// Decodes one packet (without its delimiter). The empty packet decodes to nothing.
pub fn decode(packet: &[u8]) -> Result<Vec<u8>, CobsError> {
    let mut out = Vec::with_capacity(packet.len());
    let mut i = 0;
    while i < packet.len() {
        let code = packet[i];
        if code == 0 {
            return Err(CobsError::Zero(i));
        }
        let start = i + 1;
        let end = start + usize::from(code) - 1;
        let Some(block) = packet.get(start..end) else {
            return Err(CobsError::Truncated(i));
        };
        if let Some(z) = block.iter().position(|&b| b == 0) {
            return Err(CobsError::Zero(start + z));
        }
        out.extend_from_slice(block);
        i = end;
        if code != 0xFF && i < packet.len() {
            out.push(0);
        }
    }
    Ok(out)
}

//! The two checksums of the protocol, from the `crc` crate's catalogue (its tables are built
//! at compile time, 256 entries each, as the hand-written ones were):
//!
//! - CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, not reflected, no final xor; the
//!   catalogue's CRC-16/IBM-3740) guards each frame.
//! - CRC-32/ISO-HDLC (the zlib / Ethernet CRC: reflected poly 0xEDB88320, init and final xor
//!   0xFFFFFFFF) guards a whole uploaded scene.

use crc::{CRC_16_IBM_3740, CRC_32_ISO_HDLC, Crc};

const CRC16: Crc<u16> = Crc::<u16>::new(&CRC_16_IBM_3740);
const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// CRC-16/CCITT-FALSE of `data` (check value of `b"123456789"`: 0x29B1).
pub fn crc16_ccitt_false(data: &[u8]) -> u16 {
    CRC16.checksum(data)
}

/// Incremental CRC-32/ISO-HDLC, for data that arrives in pieces. A plain value (`Copy`,
/// comparable), so a receiver holding one can be compared and restored whole; the crate's
/// `Digest` borrows its table and is neither.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crc32 {
    /// The CRC of the data so far (what [`Crc32::finish`] returns).
    crc: u32,
}

impl Default for Crc32 {
    fn default() -> Self {
        Self::new()
    }
}

impl Crc32 {
    /// A CRC over no data yet.
    pub const fn new() -> Self {
        Crc32 { crc: 0 }
    }

    /// Adds `data`.
    pub fn update(&mut self, data: &[u8]) {
        // Resume from the register the finished CRC came from: undo the final xor, and give
        // it as an initial value in the catalogue's convention, which for a reflected
        // algorithm is bit-reversed (`crc` reflects the initial value of refin algorithms).
        let register = self.crc ^ CRC_32_ISO_HDLC.xorout;
        let mut digest = CRC32.digest_with_initial(register.reverse_bits());
        digest.update(data);
        self.crc = digest.finalize();
    }

    /// The CRC of everything added so far.
    pub fn finish(&self) -> u32 {
        self.crc
    }
}

/// CRC-32/ISO-HDLC of `data` (check value of `b"123456789"`: 0xCBF43926).
pub fn crc32(data: &[u8]) -> u32 {
    CRC32.checksum(data)
}

//! Little-endian byte readers and writers, and the material encoding shared by
//! [`Message::SetMaterial`](super::Message::SetMaterial) and the scene format.

use friction::{FrictionMaterial, ModelKind, Stribeck};

use super::ErrorCode;

/// Reads little-endian values from a byte slice; every read is checked.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
}

impl<'a> Reader<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Self {
        Reader { bytes }
    }

    pub(crate) fn remaining(&self) -> usize {
        self.bytes.len()
    }

    pub(crate) fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        if n > self.bytes.len() {
            return None;
        }
        let (head, tail) = self.bytes.split_at(n);
        self.bytes = tail;
        Some(head)
    }

    fn array<const N: usize>(&mut self) -> Option<[u8; N]> {
        self.take(N)?.try_into().ok()
    }

    pub(crate) fn u8(&mut self) -> Option<u8> {
        self.array::<1>().map(|[b]| b)
    }

    pub(crate) fn u16(&mut self) -> Option<u16> {
        self.array().map(u16::from_le_bytes)
    }

    pub(crate) fn u32(&mut self) -> Option<u32> {
        self.array().map(u32::from_le_bytes)
    }

    pub(crate) fn f32(&mut self) -> Option<f32> {
        self.array().map(f32::from_le_bytes)
    }
}

/// A destination for little-endian values: a fixed buffer on the device, a `Vec` on the host.
pub(crate) trait Sink {
    fn put(&mut self, bytes: &[u8]);

    fn u8(&mut self, v: u8) {
        self.put(&[v]);
    }

    fn u16(&mut self, v: u16) {
        self.put(&v.to_le_bytes());
    }

    fn u32(&mut self, v: u32) {
        self.put(&v.to_le_bytes());
    }

    fn f32(&mut self, v: f32) {
        self.put(&v.to_le_bytes());
    }
}

/// Writes into a fixed buffer; bytes past its end are dropped and flagged.
#[derive(Debug)]
pub(crate) struct Writer<'a> {
    buf: &'a mut [u8],
    len: usize,
    overflow: bool,
}

impl<'a> Writer<'a> {
    pub(crate) fn new(buf: &'a mut [u8]) -> Self {
        Writer {
            buf,
            len: 0,
            overflow: false,
        }
    }

    /// Bytes written, or `None` when the buffer overflowed.
    pub(crate) fn finish(self) -> Option<usize> {
        (!self.overflow).then_some(self.len)
    }
}

impl Sink for Writer<'_> {
    fn put(&mut self, bytes: &[u8]) {
        let end = self.len + bytes.len();
        match self.buf.get_mut(self.len..end) {
            Some(dst) => {
                dst.copy_from_slice(bytes);
                self.len = end;
            }
            None => self.overflow = true,
        }
    }
}

#[cfg(feature = "std")]
impl Sink for Vec<u8> {
    fn put(&mut self, bytes: &[u8]) {
        self.extend_from_slice(bytes);
    }
}

/// Bytes of an encoded material.
pub const MATERIAL_LEN: usize = 51;

pub(crate) fn put_material(w: &mut impl Sink, m: &FrictionMaterial) {
    for v in [
        m.stiffness_n_per_m,
        m.damping_ns_per_m,
        m.mu_static,
        m.mu_dynamic,
        m.transition_time_s,
        m.converge_tol_m,
        m.stop_speed_m_per_s,
        m.viscous_ns_per_m,
        m.karnopp_band_m_per_s,
        m.bristle_stiffness_n_per_m,
        m.bristle_damping_ns_per_m,
        m.stribeck_speed_m_per_s,
    ] {
        w.f32(v);
    }
    let (tag, exponent) = match m.stribeck {
        Stribeck::Linear => (0, 0),
        Stribeck::Power { exponent } => (1, exponent),
        Stribeck::Smoothstep => (2, 0),
    };
    w.u8(tag);
    w.u8(exponent);
    w.u8(match m.model {
        ModelKind::StickSlip => 0,
        ModelKind::CoulombViscous => 1,
        ModelKind::Karnopp => 2,
        ModelKind::Dahl => 3,
        ModelKind::LuGre => 4,
    });
}

/// Reads and validates a material. `BadPayloadLength` when the bytes run out, `BadField` for
/// an unknown tag, `BadMaterial` for a value out of range.
pub(crate) fn get_material(r: &mut Reader<'_>) -> Result<FrictionMaterial, ErrorCode> {
    let mut f = [0.0f32; 12];
    for v in &mut f {
        *v = r.f32().ok_or(ErrorCode::BadPayloadLength)?;
    }
    let short = ErrorCode::BadPayloadLength;
    let (tag, exponent, model) = (
        r.u8().ok_or(short)?,
        r.u8().ok_or(short)?,
        r.u8().ok_or(short)?,
    );
    let stribeck = match (tag, exponent) {
        (0, 0) => Stribeck::Linear,
        (1, 1..) => Stribeck::Power { exponent },
        (1, 0) => return Err(ErrorCode::BadMaterial),
        (2, 0) => Stribeck::Smoothstep,
        _ => return Err(ErrorCode::BadField),
    };
    let model = match model {
        0 => ModelKind::StickSlip,
        1 => ModelKind::CoulombViscous,
        2 => ModelKind::Karnopp,
        3 => ModelKind::Dahl,
        4 => ModelKind::LuGre,
        _ => return Err(ErrorCode::BadField),
    };
    let m = FrictionMaterial {
        stiffness_n_per_m: f[0],
        damping_ns_per_m: f[1],
        mu_static: f[2],
        mu_dynamic: f[3],
        transition_time_s: f[4],
        converge_tol_m: f[5],
        stop_speed_m_per_s: f[6],
        viscous_ns_per_m: f[7],
        karnopp_band_m_per_s: f[8],
        bristle_stiffness_n_per_m: f[9],
        bristle_damping_ns_per_m: f[10],
        stribeck_speed_m_per_s: f[11],
        stribeck,
        model,
    };
    m.validate().map_err(|_| ErrorCode::BadMaterial)?;
    Ok(m)
}

//! Frames over a byte link (UART).
//!
//! A frame on the wire is `COBS(payload || crc16) || 0x00`: COBS removes every
//! zero byte so 0x00 delimits frames and a receiver resynchronises at the
//! next one; the CRC (CRC-16/CCITT-FALSE, poly 0x1021, init 0xFFFF) catches
//! corruption; every payload starts with its type and a 16-bit sequence
//! number, so a receiver counts lost frames from the gaps. Little-endian
//! fields; f32 in IEEE 754.
//!
//! No heap: encoding writes into the caller's buffer, decoding keeps one
//! frame in a fixed buffer and counts what it had to drop.

/// Largest payload, bytes.
pub const MAX_PAYLOAD: usize = 64;
/// Largest encoded frame: COBS adds one byte per 254 plus one, the CRC two,
/// the delimiter one.
pub const MAX_FRAME: usize = MAX_PAYLOAD + 2 + 2 + 1;

/// CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF; the catalogue's
/// CRC-16/IBM-3740, check value 0x29B1 for "123456789"), from the `crc`
/// crate, bitwise (no table).
const CRC16: crc::Crc<u16, crc::NoTable> =
    crc::Crc::<u16, crc::NoTable>::new(&crc::CRC_16_IBM_3740);

/// CRC-16/CCITT-FALSE of `data`.
pub fn crc16(data: &[u8]) -> u16 {
    CRC16.checksum(data)
}

use crate::codes::Status;

/// Why a frame or command was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// The output buffer is too small.
    BufferTooSmall,
    /// The CRC does not match.
    BadCrc,
    /// The COBS encoding is broken.
    BadCobs,
    /// Unknown type byte.
    UnknownType(u8),
    /// The payload length does not fit the type.
    BadLength,
    /// A code field holds a value its enum does not have.
    UnknownCode(u8),
    /// A command field is out of its bounds (the Ack's status).
    OutOfBounds(Status),
}

/// COBS-encodes `data` into `out` (no delimiter); returns the length.
///
/// Written here rather than taken from the `cobs` crate: on the board the
/// crate costs 144 bytes more flash (measured, fw profile); the tests check
/// this encoder and decoder against the crate.
///
/// # Errors
/// [`FrameError::BufferTooSmall`].
pub fn cobs_encode(data: &[u8], out: &mut [u8]) -> Result<usize, FrameError> {
    let mut code_at = 0usize;
    let mut n = 1usize;
    let mut code: u8 = 1;
    for (i, &b) in data.iter().enumerate() {
        if b == 0 {
            *out.get_mut(code_at).ok_or(FrameError::BufferTooSmall)? = code;
            code_at = n;
            n += 1;
            code = 1;
        } else {
            *out.get_mut(n).ok_or(FrameError::BufferTooSmall)? = b;
            n += 1;
            code += 1;
            if code == 0xFF {
                *out.get_mut(code_at).ok_or(FrameError::BufferTooSmall)? = code;
                code = 1;
                if i + 1 == data.len() {
                    // A full block ends the data: no empty block after it
                    // (the encoding stays within n + ceil(n / 254) bytes).
                    return Ok(n);
                }
                code_at = n;
                n += 1;
            }
        }
    }
    *out.get_mut(code_at).ok_or(FrameError::BufferTooSmall)? = code;
    Ok(n)
}

/// COBS-decodes `data` (no delimiter) into `out`; returns the length.
///
/// # Errors
/// [`FrameError::BadCobs`] (a zero inside, a code past the end) or
/// [`FrameError::BufferTooSmall`].
pub fn cobs_decode(data: &[u8], out: &mut [u8]) -> Result<usize, FrameError> {
    let (mut i, mut n) = (0usize, 0usize);
    while i < data.len() {
        let code = *data.get(i).ok_or(FrameError::BadCobs)?;
        if code == 0 {
            return Err(FrameError::BadCobs);
        }
        i += 1;
        for _ in 1..code {
            let b = *data.get(i).ok_or(FrameError::BadCobs)?;
            if b == 0 {
                return Err(FrameError::BadCobs);
            }
            *out.get_mut(n).ok_or(FrameError::BufferTooSmall)? = b;
            n += 1;
            i += 1;
        }
        if code < 0xFF && i < data.len() {
            *out.get_mut(n).ok_or(FrameError::BufferTooSmall)? = 0;
            n += 1;
        }
    }
    Ok(n)
}

/// A whole frame for `payload`: COBS(payload || crc16) || 0x00.
///
/// # Errors
/// [`FrameError::BufferTooSmall`].
pub fn frame(payload: &[u8], out: &mut [u8]) -> Result<usize, FrameError> {
    let mut tmp = [0u8; MAX_PAYLOAD + 2];
    let n = payload.len();
    tmp.get_mut(..n)
        .ok_or(FrameError::BufferTooSmall)?
        .copy_from_slice(payload);
    tmp.get_mut(n..n + 2)
        .ok_or(FrameError::BufferTooSmall)?
        .copy_from_slice(&crc16(payload).to_le_bytes());
    let m = cobs_encode(tmp.get(..n + 2).unwrap_or(&[]), out)?;
    *out.get_mut(m).ok_or(FrameError::BufferTooSmall)? = 0;
    Ok(m + 1)
}

/// Counters of a [`Decoder`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Frames decoded.
    pub frames: u64,
    /// Frames with a bad CRC, broken COBS, an unknown type or a bad length.
    pub corrupt: u64,
    /// Frames longer than the buffer (dropped whole).
    pub overflow: u64,
    /// Frames missing according to the sequence numbers.
    pub lost: u64,
}

/// A streaming frame decoder: feed bytes, get payloads.
#[derive(Clone, Debug)]
pub struct Decoder {
    buf: [u8; MAX_FRAME],
    n: usize,
    overflowed: bool,
    last_seq: Option<u16>,
    /// What has been seen.
    pub stats: LinkStats,
}

impl Default for Decoder {
    fn default() -> Self {
        Self {
            buf: [0; MAX_FRAME],
            n: 0,
            overflowed: false,
            last_seq: None,
            stats: LinkStats::default(),
        }
    }
}

impl Decoder {
    /// Takes one byte; at a frame's end returns its checked payload (copied
    /// into `out`, length returned). Corrupt frames are counted and skipped.
    pub fn push(&mut self, b: u8, out: &mut [u8; MAX_PAYLOAD + 2]) -> Option<usize> {
        if b != 0 {
            match self.buf.get_mut(self.n) {
                Some(slot) => {
                    *slot = b;
                    self.n += 1;
                }
                None => self.overflowed = true,
            }
            return None;
        }
        let (n, over) = (self.n, self.overflowed);
        self.n = 0;
        self.overflowed = false;
        if over {
            self.stats.overflow += 1;
            return None;
        }
        if n == 0 {
            return None;
        }
        let m = match cobs_decode(self.buf.get(..n).unwrap_or(&[]), out) {
            Ok(m) if m >= 3 => m,
            _ => {
                self.stats.corrupt += 1;
                return None;
            }
        };
        let Some((p, c)) = out.split_at_checked(m - 2) else {
            self.stats.corrupt += 1;
            return None;
        };
        let crc = u16::from_le_bytes([
            c.first().copied().unwrap_or(0),
            c.get(1).copied().unwrap_or(0),
        ]);
        if crc16(p) != crc {
            self.stats.corrupt += 1;
            return None;
        }
        // Sequence gaps (the seq field follows the type byte).
        if let (Some(lo), Some(hi)) = (p.get(1), p.get(2)) {
            let seq = u16::from_le_bytes([*lo, *hi]);
            if let Some(last) = self.last_seq {
                self.stats.lost += u64::from(seq.wrapping_sub(last).wrapping_sub(1));
            }
            self.last_seq = Some(seq);
        }
        self.stats.frames += 1;
        Some(m - 2)
    }

    /// Counts a payload that framed correctly but did not parse.
    pub fn count_corrupt(&mut self) {
        self.stats.corrupt += 1;
        self.stats.frames = self.stats.frames.saturating_sub(1);
    }
}

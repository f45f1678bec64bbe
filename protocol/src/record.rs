//! The record the board keeps in flash: its configuration (site, base,
//! scheme, aided mode: set by commands) and its last accepted calibration.
//!
//! ```text
//! u32 magic "RINS" | u16 version | u16 flags (bit 0 calibration, bit 1 aided)
//! | u32 sequence (the journal's: the highest valid one is the record)
//! | i32 lat (1e-7 deg) | i32 height (mm) | 3 x f32 base roll, pitch, heading (deg)
//! | u8 scheme | u8 count | u16 reserved (0) | f32 rate (deg/s) | i32 lon (1e-7 deg)
//! | 3 x f32 gyro bias (rad/s) | 3 x f32 M k | u16 reserved (0) | u16 CRC-16
//! ```
//!
//! 72 bytes, a whole number of 32-bit words (the flash programs words);
//! the CRC covers everything before it, so a write cut anywhere leaves a
//! record that does not check.

use crate::codes::SchemeKind;
use crate::frame::{crc16, FrameError};
use crate::wire::{Reader, Writer};

/// Bytes of a record.
pub const RECORD_LEN: usize = 72;
/// "RINS".
pub const MAGIC: u32 = 0x5249_4E53;
/// The layout's version.
pub const VERSION: u16 = 1;

/// What the board is told by commands.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardConfig {
    /// Site latitude, 1e-7 deg.
    pub lat_e7: i32,
    /// Site height above the ellipsoid, mm.
    pub height_mm: i32,
    /// Base roll, pitch, heading, deg.
    pub base_deg: [f32; 3],
    /// The rotation scheme.
    pub scheme: SchemeKind,
    /// Its rate, deg/s.
    pub rate_dps: f32,
    /// Its turns or positions.
    pub count: u8,
    /// Aided navigation (a moving vehicle with GNSS).
    pub aided: bool,
    /// The aided origin's longitude, 1e-7 deg.
    pub lon_e7: i32,
}

/// A calibration as stored: gyro bias (rad/s, sensor frame) and `M k`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct StoredCalibration {
    /// rad/s.
    pub bias_radps: [f32; 3],
    /// Installation errors and the table axis' scale error.
    pub m_k: [f32; 3],
}

/// The record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    /// The journal's sequence number.
    pub seq: u32,
    /// The configuration.
    pub config: BoardConfig,
    /// The last accepted calibration.
    pub calibration: Option<StoredCalibration>,
}

impl Record {
    /// Its bytes.
    pub fn encode(&self) -> [u8; RECORD_LEN] {
        let mut out = [0u8; RECORD_LEN];
        let mut w = Writer::new(&mut out);
        let c = &self.config;
        let flags = u16::from(self.calibration.is_some()) | (u16::from(c.aided) << 1);
        w.put(&MAGIC);
        w.put(&VERSION);
        w.put(&flags);
        w.put(&self.seq);
        w.put(&c.lat_e7);
        w.put(&c.height_mm);
        w.put(&c.base_deg);
        w.put(&c.scheme);
        w.put(&c.count);
        w.put(&0u16);
        w.put(&c.rate_dps);
        w.put(&c.lon_e7);
        let cal = self.calibration.unwrap_or_default();
        w.put(&cal.bias_radps);
        w.put(&cal.m_k);
        w.put(&0u16);
        // 70 bytes so far: the CRC fills the last two.
        let _ = w.finish();
        let crc = crc16(out.get(..RECORD_LEN - 2).unwrap_or(&[]));
        if let Some(d) = out.get_mut(RECORD_LEN - 2..) {
            d.copy_from_slice(&crc.to_le_bytes());
        }
        out
    }

    /// A record from its bytes.
    ///
    /// # Errors
    /// [`FrameError::BadCrc`] (blank flash, a cut write, corruption), a
    /// wrong magic or version ([`FrameError::UnknownType`]), an unknown
    /// scheme.
    pub fn decode(b: &[u8]) -> Result<Self, FrameError> {
        let body = b.get(..RECORD_LEN - 2).ok_or(FrameError::BadLength)?;
        let crc = b
            .get(RECORD_LEN - 2..RECORD_LEN)
            .ok_or(FrameError::BadLength)?;
        if crc16(body).to_le_bytes()
            != [
                crc.first().copied().unwrap_or(0),
                crc.get(1).copied().unwrap_or(0),
            ]
        {
            return Err(FrameError::BadCrc);
        }
        let mut r = Reader::new(body);
        let magic: u32 = r.get()?;
        let version: u16 = r.get()?;
        if magic != MAGIC || version != VERSION {
            return Err(FrameError::UnknownType(0));
        }
        let flags: u16 = r.get()?;
        let seq = r.get()?;
        let lat_e7 = r.get()?;
        let height_mm = r.get()?;
        let base_deg = r.get()?;
        let scheme = r.get()?;
        let count = r.get()?;
        let _: u16 = r.get()?;
        let rate_dps = r.get()?;
        let lon_e7 = r.get()?;
        let cal = StoredCalibration {
            bias_radps: r.get()?,
            m_k: r.get()?,
        };
        Ok(Self {
            seq,
            config: BoardConfig {
                lat_e7,
                height_mm,
                base_deg,
                scheme,
                rate_dps,
                count,
                aided: flags & 2 != 0,
                lon_e7,
            },
            calibration: (flags & 1 != 0).then_some(cal),
        })
    }
}

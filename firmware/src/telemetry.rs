//! Telemetry and commands over a byte link (UART).
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

/// What a device sends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Telemetry {
    /// A raw IMU sample: time (µs), rate (rad/s), specific force (m/s^2),
    /// temperature (deg C), sensor frame `s`.
    Imu {
        /// Time since boot, µs.
        t_us: u64,
        /// rad/s.
        gyro_radps: [f32; 3],
        /// m/s^2.
        accel_mps2: [f32; 3],
        /// deg C.
        temp_c: f32,
    },
    /// An encoder read: time (µs) and the unwrapped count.
    Encoder {
        /// Time since boot, µs.
        t_us: u64,
        /// Unwrapped count.
        counts: i64,
        /// Counts per revolution.
        counts_per_rev: u32,
    },
    /// Navigation state: base attitude `q_b_n` (w, x, y, z), velocity
    /// (NED, m/s) and position offset (NED, m).
    Nav {
        /// Time since boot, µs.
        t_us: u64,
        /// `q_b_n`.
        q_b_n: [f32; 4],
        /// m/s.
        v_n: [f32; 3],
        /// m.
        p_n: [f32; 3],
    },
    /// A calibration result: gyro bias (rad/s) and column `M k`.
    Calibration {
        /// rad/s.
        bias_radps: [f32; 3],
        /// Installation errors and the k-axis scale error.
        m_k: [f32; 3],
        /// 0 accepted; otherwise the refusal reason code.
        status: u8,
    },
    /// How the calibration just accepted differs from the record stored
    /// in flash at power-up (new minus stored): the health figure of a
    /// sensor whose errors drift between power-ups.
    CalibrationChange {
        /// Bias change, rad/s.
        d_bias_radps: [f32; 3],
        /// `M k` change.
        d_m_k: [f32; 3],
    },
    /// A fault: its code and how many so far.
    Fault {
        /// Time since boot, µs.
        t_us: u64,
        /// Fault code (see the firmware's fault list).
        code: u8,
        /// Occurrences so far.
        count: u32,
    },
    /// The answer to a command: its sequence number and 0 or a reason code.
    Ack {
        /// The command's sequence number.
        seq: u16,
        /// 0 accepted, else why not.
        status: u8,
    },
}

/// What a host sends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// Rotation scheme: 0 still, 1 continuous, 2 reciprocating, 3 indexed;
    /// rate (deg/s, 0 < r <= 200), turns / positions.
    SetScheme {
        /// Scheme code.
        kind: u8,
        /// deg/s.
        rate_dps: f32,
        /// Turns (reciprocating) or positions (indexed: 2 or 4).
        count: u8,
    },
    /// Start the table.
    Start,
    /// Stop the table (motor off).
    Stop,
    /// Run the power-up calibration again.
    Recalibrate,
    /// A GNSS fix for the aided filter (the receiver's integer units:
    /// 1e-7 deg, mm, mm/s; the fix is used at the next navigation sample).
    GnssFix(core_nav::aided::GnssFix),
}

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
    /// A command field is out of its bounds (reason code for the Ack).
    OutOfBounds(u8),
}

const T_IMU: u8 = 1;
const T_ENC: u8 = 2;
const T_NAV: u8 = 3;
const T_CAL: u8 = 4;
const T_FAULT: u8 = 5;
const T_ACK: u8 = 6;
const T_CAL_CHANGE: u8 = 7;
const C_SCHEME: u8 = 0x81;
const C_START: u8 = 0x82;
const C_STOP: u8 = 0x83;
const C_RECAL: u8 = 0x84;
const C_GNSS: u8 = 0x85;

/// A little-endian writer into a fixed buffer.
struct LeWriter<'a> {
    buf: &'a mut [u8],
    n: usize,
    ok: bool,
}

impl LeWriter<'_> {
    fn bytes(&mut self, b: &[u8]) {
        match self.buf.get_mut(self.n..self.n + b.len()) {
            Some(dst) => {
                dst.copy_from_slice(b);
                self.n += b.len();
            }
            None => self.ok = false,
        }
    }
    fn f32s(&mut self, v: &[f32]) {
        for x in v {
            self.bytes(&x.to_le_bytes());
        }
    }
}

/// A little-endian reader.
struct LeReader<'a> {
    buf: &'a [u8],
    n: usize,
}

impl LeReader<'_> {
    fn take<const N: usize>(&mut self) -> Result<[u8; N], FrameError> {
        let s = self
            .buf
            .get(self.n..self.n + N)
            .ok_or(FrameError::BadLength)?;
        self.n += N;
        let mut a = [0u8; N];
        a.copy_from_slice(s);
        Ok(a)
    }
    fn u8(&mut self) -> Result<u8, FrameError> {
        Ok(self.take::<1>()?[0])
    }
    fn u16(&mut self) -> Result<u16, FrameError> {
        Ok(u16::from_le_bytes(self.take()?))
    }
    fn u32(&mut self) -> Result<u32, FrameError> {
        Ok(u32::from_le_bytes(self.take()?))
    }
    fn u64(&mut self) -> Result<u64, FrameError> {
        Ok(u64::from_le_bytes(self.take()?))
    }
    fn i64(&mut self) -> Result<i64, FrameError> {
        Ok(i64::from_le_bytes(self.take()?))
    }
    fn f32(&mut self) -> Result<f32, FrameError> {
        Ok(f32::from_le_bytes(self.take()?))
    }
    fn f32n<const N: usize>(&mut self) -> Result<[f32; N], FrameError> {
        let mut a = [0f32; N];
        for x in a.iter_mut() {
            *x = self.f32()?;
        }
        Ok(a)
    }
    fn end(&self) -> Result<(), FrameError> {
        if self.n == self.buf.len() {
            Ok(())
        } else {
            Err(FrameError::BadLength)
        }
    }
}

impl Telemetry {
    /// The payload (type, sequence, fields) into `out`; returns its length.
    ///
    /// # Errors
    /// [`FrameError::BufferTooSmall`].
    pub fn payload(&self, seq: u16, out: &mut [u8]) -> Result<usize, FrameError> {
        let mut w = LeWriter {
            buf: out,
            n: 0,
            ok: true,
        };
        match *self {
            Telemetry::Imu {
                t_us,
                gyro_radps,
                accel_mps2,
                temp_c,
            } => {
                w.bytes(&[T_IMU]);
                w.bytes(&seq.to_le_bytes());
                w.bytes(&t_us.to_le_bytes());
                w.f32s(&gyro_radps);
                w.f32s(&accel_mps2);
                w.f32s(&[temp_c]);
            }
            Telemetry::Encoder {
                t_us,
                counts,
                counts_per_rev,
            } => {
                w.bytes(&[T_ENC]);
                w.bytes(&seq.to_le_bytes());
                w.bytes(&t_us.to_le_bytes());
                w.bytes(&counts.to_le_bytes());
                w.bytes(&counts_per_rev.to_le_bytes());
            }
            Telemetry::Nav {
                t_us,
                q_b_n,
                v_n,
                p_n,
            } => {
                w.bytes(&[T_NAV]);
                w.bytes(&seq.to_le_bytes());
                w.bytes(&t_us.to_le_bytes());
                w.f32s(&q_b_n);
                w.f32s(&v_n);
                w.f32s(&p_n);
            }
            Telemetry::Calibration {
                bias_radps,
                m_k,
                status,
            } => {
                w.bytes(&[T_CAL]);
                w.bytes(&seq.to_le_bytes());
                w.f32s(&bias_radps);
                w.f32s(&m_k);
                w.bytes(&[status]);
            }
            Telemetry::CalibrationChange {
                d_bias_radps,
                d_m_k,
            } => {
                w.bytes(&[T_CAL_CHANGE]);
                w.bytes(&seq.to_le_bytes());
                w.f32s(&d_bias_radps);
                w.f32s(&d_m_k);
            }
            Telemetry::Fault { t_us, code, count } => {
                w.bytes(&[T_FAULT]);
                w.bytes(&seq.to_le_bytes());
                w.bytes(&t_us.to_le_bytes());
                w.bytes(&[code]);
                w.bytes(&count.to_le_bytes());
            }
            Telemetry::Ack { seq: s, status } => {
                w.bytes(&[T_ACK]);
                w.bytes(&seq.to_le_bytes());
                w.bytes(&s.to_le_bytes());
                w.bytes(&[status]);
            }
        }
        if w.ok {
            Ok(w.n)
        } else {
            Err(FrameError::BufferTooSmall)
        }
    }

    /// Parses a payload into (sequence, telemetry).
    ///
    /// # Errors
    /// Unknown type or wrong length.
    pub fn parse(p: &[u8]) -> Result<(u16, Self), FrameError> {
        let mut r = LeReader { buf: p, n: 0 };
        let ty = r.u8()?;
        let seq = r.u16()?;
        let t = match ty {
            T_IMU => Telemetry::Imu {
                t_us: r.u64()?,
                gyro_radps: r.f32n()?,
                accel_mps2: r.f32n()?,
                temp_c: r.f32()?,
            },
            T_ENC => Telemetry::Encoder {
                t_us: r.u64()?,
                counts: r.i64()?,
                counts_per_rev: r.u32()?,
            },
            T_NAV => Telemetry::Nav {
                t_us: r.u64()?,
                q_b_n: r.f32n()?,
                v_n: r.f32n()?,
                p_n: r.f32n()?,
            },
            T_CAL => Telemetry::Calibration {
                bias_radps: r.f32n()?,
                m_k: r.f32n()?,
                status: r.u8()?,
            },
            T_CAL_CHANGE => Telemetry::CalibrationChange {
                d_bias_radps: r.f32n()?,
                d_m_k: r.f32n()?,
            },
            T_FAULT => Telemetry::Fault {
                t_us: r.u64()?,
                code: r.u8()?,
                count: r.u32()?,
            },
            T_ACK => Telemetry::Ack {
                seq: r.u16()?,
                status: r.u8()?,
            },
            other => return Err(FrameError::UnknownType(other)),
        };
        r.end()?;
        Ok((seq, t))
    }
}

/// Reason codes of refused commands (also sent in [`Telemetry::Ack`]).
pub mod reason {
    /// Unknown scheme kind.
    pub const BAD_SCHEME: u8 = 1;
    /// Rate out of (0, 200] deg/s or not finite.
    pub const BAD_RATE: u8 = 2;
    /// Turns 0, or positions other than 2 / 4.
    pub const BAD_COUNT: u8 = 3;
    /// Unknown command or malformed frame.
    pub const MALFORMED: u8 = 4;
    /// A GNSS fix out of range: latitude beyond +-90 deg, longitude beyond
    /// +-180 deg, a sigma zero.
    pub const BAD_FIX: u8 = 5;
    /// A GNSS fix while the board is not navigating with the aided filter
    /// (not configured for it, or still starting).
    pub const NOT_AIDED: u8 = 6;
    /// Not available while the aided filter navigates (`Recalibrate`: the
    /// filter estimates the gyro errors itself, and a restart would lose
    /// the vehicle's position).
    pub const AIDED: u8 = 7;
}

impl Command {
    /// The payload into `out`; returns its length.
    ///
    /// # Errors
    /// [`FrameError::BufferTooSmall`].
    pub fn payload(&self, seq: u16, out: &mut [u8]) -> Result<usize, FrameError> {
        let mut w = LeWriter {
            buf: out,
            n: 0,
            ok: true,
        };
        let code = match self {
            Command::SetScheme { .. } => C_SCHEME,
            Command::Start => C_START,
            Command::Stop => C_STOP,
            Command::Recalibrate => C_RECAL,
            Command::GnssFix(_) => C_GNSS,
        };
        w.bytes(&[code]);
        w.bytes(&seq.to_le_bytes());
        if let Command::GnssFix(f) = self {
            for v in [f.lat_e7, f.lon_e7, f.height_mm]
                .iter()
                .chain(f.v_n_mmps.iter())
            {
                w.bytes(&v.to_le_bytes());
            }
            for v in [f.sigma_h_mm, f.sigma_v_mm, f.sigma_vel_mmps] {
                w.bytes(&v.to_le_bytes());
            }
        }
        if let Command::SetScheme {
            kind,
            rate_dps,
            count,
        } = *self
        {
            w.bytes(&[kind]);
            w.f32s(&[rate_dps]);
            w.bytes(&[count]);
        }
        if w.ok {
            Ok(w.n)
        } else {
            Err(FrameError::BufferTooSmall)
        }
    }

    /// Parses and bounds-checks a command payload into (sequence, command).
    ///
    /// # Errors
    /// [`FrameError::OutOfBounds`] with the reason code, or a malformed payload.
    pub fn parse(p: &[u8]) -> Result<(u16, Self), FrameError> {
        let mut r = LeReader { buf: p, n: 0 };
        let code = r.u8()?;
        let seq = r.u16()?;
        let c = match code {
            C_SCHEME => {
                let (kind, rate_dps, count) = (r.u8()?, r.f32()?, r.u8()?);
                if kind > 3 {
                    return Err(FrameError::OutOfBounds(reason::BAD_SCHEME));
                }
                if kind != 0 && !(rate_dps.is_finite() && rate_dps > 0.0 && rate_dps <= 200.0) {
                    return Err(FrameError::OutOfBounds(reason::BAD_RATE));
                }
                if (kind == 2 && count == 0) || (kind == 3 && count != 2 && count != 4) {
                    return Err(FrameError::OutOfBounds(reason::BAD_COUNT));
                }
                Command::SetScheme {
                    kind,
                    rate_dps,
                    count,
                }
            }
            C_START => Command::Start,
            C_STOP => Command::Stop,
            C_RECAL => Command::Recalibrate,
            C_GNSS => {
                let mut i = [0i32; 6];
                for x in i.iter_mut() {
                    *x = r.u32()? as i32;
                }
                let [lat_e7, lon_e7, height_mm, vn, ve, vd] = i;
                let f = core_nav::aided::GnssFix {
                    lat_e7,
                    lon_e7,
                    height_mm,
                    v_n_mmps: [vn, ve, vd],
                    sigma_h_mm: r.u32()?,
                    sigma_v_mm: r.u32()?,
                    sigma_vel_mmps: r.u32()?,
                };
                if lat_e7.unsigned_abs() > 900_000_000
                    || lon_e7.unsigned_abs() > 1_800_000_000
                    || f.sigma_h_mm == 0
                    || f.sigma_v_mm == 0
                    || f.sigma_vel_mmps == 0
                {
                    return Err(FrameError::OutOfBounds(reason::BAD_FIX));
                }
                Command::GnssFix(f)
            }
            other => return Err(FrameError::UnknownType(other)),
        };
        r.end()?;
        Ok((seq, c))
    }
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

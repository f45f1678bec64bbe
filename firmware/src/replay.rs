//! A recording replayed through the board's logic (the QEMU test): a
//! fixed-size binary stream of IMU samples and encoder reads, little-endian,
//! and a trailer with the host's result of the same replay.
//!
//! ```text
//! header:  "RPLY" | u32 version (1) | u32 records | f64 lat_deg | f64 height_m
//!          | 3 x f64 base roll, pitch, heading (deg) | f64 rate (rad/s) | u32 counts/rev
//! record:  u8 kind (1 IMU, 2 encoder) | u64 t_us | 7 x u32 words
//!          IMU: gyro xyz, accel xyz (f32 bits), temp (f32 bits)
//!          encoder: the 16-bit hardware count in word 0
//! trailer: u8 mode (3 = navigating) | 3 x f32 p_n | 3 x f32 v_n (bits)
//! ```

/// Bytes in the header.
pub const HEADER: usize = 12 + 6 * 8 + 4;

/// The board's configuration for the replay (the header's fields).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Header {
    /// Records that follow.
    pub records: u32,
    /// Site latitude, deg.
    pub lat_deg: f64,
    /// Site height, m.
    pub height_m: f64,
    /// Base roll, pitch, heading, deg.
    pub base_deg: [f64; 3],
    /// Table rate, rad/s.
    pub rate_radps: f64,
    /// Encoder counts per revolution.
    pub counts_per_rev: u32,
}

impl Header {
    /// The board's configuration.
    pub fn config(&self) -> crate::app::AppConfig {
        crate::app::AppConfig {
            lat_deg: self.lat_deg,
            height_m: self.height_m,
            base_deg: self.base_deg,
            counts_per_rev: self.counts_per_rev,
            scheme: core_nav::scheme::Scheme::Continuous {
                rate: self.rate_radps,
            },
            ..crate::app::AppConfig::default()
        }
    }

    /// Encodes the header.
    pub fn encode(&self) -> [u8; HEADER] {
        let mut r = [0u8; HEADER];
        let mut n = 0;
        let mut put = |b: &[u8]| {
            if let Some(d) = r.get_mut(n..n + b.len()) {
                d.copy_from_slice(b);
            }
            n += b.len();
        };
        put(&MAGIC);
        put(&1u32.to_le_bytes());
        put(&self.records.to_le_bytes());
        for v in [
            self.lat_deg,
            self.height_m,
            self.base_deg[0],
            self.base_deg[1],
            self.base_deg[2],
            self.rate_radps,
        ] {
            put(&v.to_le_bytes());
        }
        put(&self.counts_per_rev.to_le_bytes());
        r
    }

    /// Decodes a header; `None` on a wrong magic or version.
    pub fn decode(r: &[u8]) -> Option<Self> {
        if r.get(..4)? != MAGIC || word(r, 4) != 1 {
            return None;
        }
        let f = |i: usize| -> Option<f64> {
            let mut a = [0u8; 8];
            a.copy_from_slice(r.get(12 + 8 * i..20 + 8 * i)?);
            Some(f64::from_le_bytes(a))
        };
        Some(Self {
            records: word(r, 8),
            lat_deg: f(0)?,
            height_m: f(1)?,
            base_deg: [f(2)?, f(3)?, f(4)?],
            rate_radps: f(5)?,
            counts_per_rev: word(r, 60),
        })
    }
}
/// Bytes per record.
pub const RECORD: usize = 1 + 8 + 28;
/// Bytes in the trailer.
pub const TRAILER: usize = 1 + 24;
/// The magic.
pub const MAGIC: [u8; 4] = *b"RPLY";

/// One replayed event.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// An IMU sample (rad/s, m/s^2, deg C).
    Imu {
        /// µs.
        t_us: u64,
        /// rad/s.
        gyro: [f32; 3],
        /// m/s^2.
        accel: [f32; 3],
        /// deg C.
        temp: f32,
    },
    /// An encoder read.
    Encoder {
        /// µs.
        t_us: u64,
        /// 16-bit counter.
        hw: u16,
    },
}

/// The result a replay ends with.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Outcome {
    /// 3 when navigating at the end.
    pub mode: u8,
    /// Position offset, m.
    pub p_n: [f32; 3],
    /// Velocity, m/s.
    pub v_n: [f32; 3],
}

fn word(b: &[u8], i: usize) -> u32 {
    let mut a = [0u8; 4];
    if let Some(s) = b.get(i..i + 4) {
        a.copy_from_slice(s);
    }
    u32::from_le_bytes(a)
}

/// Encodes one event.
pub fn encode(e: &Event) -> [u8; RECORD] {
    let mut r = [0u8; RECORD];
    let (kind, t_us, words) = match *e {
        Event::Imu {
            t_us,
            gyro,
            accel,
            temp,
        } => (
            1u8,
            t_us,
            [
                gyro[0].to_bits(),
                gyro[1].to_bits(),
                gyro[2].to_bits(),
                accel[0].to_bits(),
                accel[1].to_bits(),
                accel[2].to_bits(),
                temp.to_bits(),
            ],
        ),
        Event::Encoder { t_us, hw } => (2u8, t_us, [u32::from(hw), 0, 0, 0, 0, 0, 0]),
    };
    r[0] = kind;
    r[1..9].copy_from_slice(&t_us.to_le_bytes());
    for (k, w) in words.iter().enumerate() {
        if let Some(dst) = r.get_mut(9 + 4 * k..13 + 4 * k) {
            dst.copy_from_slice(&w.to_le_bytes());
        }
    }
    r
}

/// Decodes one event; `None` for an unknown kind.
pub fn decode(r: &[u8]) -> Option<Event> {
    let mut t = [0u8; 8];
    t.copy_from_slice(r.get(1..9)?);
    let t_us = u64::from_le_bytes(t);
    let f = |k: usize| f32::from_bits(word(r, 9 + 4 * k));
    match r.first()? {
        1 => Some(Event::Imu {
            t_us,
            gyro: [f(0), f(1), f(2)],
            accel: [f(3), f(4), f(5)],
            temp: f(6),
        }),
        2 => Some(Event::Encoder {
            t_us,
            hw: word(r, 9) as u16,
        }),
        _ => None,
    }
}

/// Encodes the trailer.
pub fn encode_outcome(o: &Outcome) -> [u8; TRAILER] {
    let mut r = [0u8; TRAILER];
    r[0] = o.mode;
    for (k, v) in o.p_n.iter().chain(o.v_n.iter()).enumerate() {
        if let Some(dst) = r.get_mut(1 + 4 * k..5 + 4 * k) {
            dst.copy_from_slice(&v.to_bits().to_le_bytes());
        }
    }
    r
}

/// Decodes the trailer.
pub fn decode_outcome(r: &[u8]) -> Outcome {
    let f = |k: usize| f32::from_bits(word(r, 1 + 4 * k));
    Outcome {
        mode: r.first().copied().unwrap_or(0),
        p_n: [f(0), f(1), f(2)],
        v_n: [f(3), f(4), f(5)],
    }
}

/// Runs the events through `app` (what both the host and the QEMU build do).
pub fn step(app: &mut crate::app::App, e: &Event) {
    match *e {
        Event::Imu {
            t_us,
            gyro,
            accel,
            temp,
        } => {
            let s = crate::icm42688::Sample {
                gyro_radps: gyro,
                accel_mps2: accel,
                temp_c: temp,
            };
            // Raw words for the data monitor: a distinct pattern per sample.
            let raw = crate::icm42688::RawSample {
                temp_lsb: 0,
                accel_lsb: [
                    (accel[0] * 1e3) as i16,
                    (accel[1] * 1e3) as i16,
                    (t_us / 10_000) as i16,
                ],
                gyro_lsb: [
                    (gyro[0] * 1e4) as i16,
                    (gyro[1] * 1e4) as i16,
                    (gyro[2] * 1e4) as i16,
                ],
            };
            app.on_imu(t_us, &raw, &s);
        }
        Event::Encoder { t_us, hw } => app.on_encoder(t_us, hw),
    }
}

/// The outcome of `app` now.
pub fn outcome(app: &crate::app::App) -> Outcome {
    match app.nav() {
        Some(n) if app.mode == crate::app::Mode::Navigating => {
            let s = n.state();
            Outcome {
                mode: 3,
                p_n: [s.p_n.x, s.p_n.y, s.p_n.z],
                v_n: [s.v_n.x, s.v_n.y, s.v_n.z],
            }
        }
        _ => Outcome::default(),
    }
}

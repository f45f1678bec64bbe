//! A recording replayed through the board's program (the QEMU test and its
//! host twin): a binary stream of IMU samples, encoder reads, GNSS fixes
//! and the host's configuration commands, little-endian, and a trailer
//! with the host's result of the same replay.
//!
//! The IMU samples and encoder reads stand in for the sensors (QEMU has
//! none); the commands and fixes are what a host sends over the link:
//! under QEMU they arrive through the emulated USART from `rins record`,
//! and the records here are for the host's run of the same program.
//!
//! ```text
//! header:  "RPLY" | u32 version (5) | u32 records | f64 lat_deg | f64 height_m
//!          | 3 x f64 base roll, pitch, heading (deg) | f64 rate (rad/s) | u32 counts/rev
//!          | u32 aided (0 / 1) | f64 lon_deg | 3 x f64 antenna in b (m)
//!          | 20 x f64 filter: gyro ARW, accel VRW, gyro bias initial sigma,
//!            sigma, tau, accel bias initial sigma, sigma, tau, gate, gyro
//!            scale sigma, misalignment sigma, warm-up tau, gyro bias,
//!            accel bias and gyro scale drift over the warm-up, accel
//!            scale sigma, misalignment sigma
//!            sigma, GNSS correlated sigma h, v, tau (the units of
//!            core_nav::eskf::EskfConfig)
//!          | 4 x f64 initial sigma: position, velocity, level, heading
//!          | 3 x f64 zero-velocity detector's noise: specific force
//!            (m/s^2), rate (rad/s) per sample, table rate over a window
//!            (rad/s)
//!          | u32 zero-velocity updates (0 / 1)
//!          | u32 configuration commands (first in the stream)
//!          | u32 fix latency (µs: a fix is sent this long after its time of validity)
//! record:  u8 kind | u64 t_us | words (u32), as many as the kind has:
//!          1 IMU (7): gyro xyz, accel xyz (f32 bits), temp (f32 bits)
//!          2 encoder (7): the 16-bit hardware count in word 0
//!          3 GNSS fix (9): lat, lon (1e-7 deg), height (mm), v_n xyz (mm/s)
//!            as i32; sigma h, v (mm), sigma velocity (mm/s) as u32; t_us
//!            is its time of validity. It goes to the board as a command
//!            frame over the link, `latency` later.
//!          4 command (9): a configuration command's payload, its length
//!            in the first byte (t_us 0: the host's configuration, sent first).
//! trailer: u8 mode (3 = navigating) | 3 x f32 p_n | 3 x f32 v_n (bits)
//! ```

use core_nav::aided::{AidedConfig, GnssFix};
use core_nav::eskf::{EskfConfig, InitialSigma};
use core_nav::table::Axis;

/// Bytes in the header.
pub const HEADER: usize = 12 + 6 * 8 + 4 + 4 + (1 + 3 + 20 + 4 + 3) * 8 + 4 + 8;
/// The header's f64 fields after the fixed ones.
const AIDED_F64: usize = 31;
/// The format's version.
pub const VERSION: u32 = 5;

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
    /// Aided navigation (a moving vehicle with GNSS): the site's longitude
    /// (deg) and the navigator's settings.
    pub aided: Option<(f64, AidedConfig)>,
    /// Configuration commands the host sends (first in the stream; the
    /// board boots with them stored, `firmware::replay::stored_journal`).
    pub commands: u32,
    /// How long after its time of validity each fix is sent, µs.
    pub fix_latency_us: u32,
}

impl Header {
    /// The header's f64 fields after the fixed ones, in order.
    fn aided_f64(&self) -> [f64; AIDED_F64] {
        let mut v = [0.0; AIDED_F64];
        if let Some((lon, c)) = self.aided {
            let e = &c.eskf;
            let i = &c.initial;
            let [ax, ay, az] = c.antenna_b_m;
            let head = [lon, ax, ay, az];
            let tail = [
                i.position_m,
                i.velocity_mps,
                i.level_rad,
                i.heading_rad,
                c.zupt_noise.sigma_f_mps2,
                c.zupt_noise.sigma_w_radps,
                c.zupt_noise.sigma_table_rate_radps,
            ];
            let all = head.into_iter().chain(e.to_array()).chain(tail);
            for (slot, x) in v.iter_mut().zip(all) {
                *slot = x;
            }
        }
        v
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
        put(&VERSION.to_le_bytes());
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
        put(&u32::from(self.aided.is_some()).to_le_bytes());
        for v in self.aided_f64() {
            put(&v.to_le_bytes());
        }
        let zupt = self.aided.is_some_and(|(_, c)| c.zupt);
        put(&u32::from(zupt).to_le_bytes());
        put(&self.commands.to_le_bytes());
        put(&self.fix_latency_us.to_le_bytes());
        r
    }

    /// Decodes a header; `None` on a wrong magic or version.
    pub fn decode(r: &[u8]) -> Option<Self> {
        if r.get(..4)? != MAGIC || word(r, 4) != VERSION {
            return None;
        }
        let f = |i: usize| -> Option<f64> {
            let mut a = [0u8; 8];
            a.copy_from_slice(r.get(12 + 8 * i..20 + 8 * i)?);
            Some(f64::from_le_bytes(a))
        };
        // The aided block's f64s start after the u32 flag at byte 64.
        let g = |i: usize| -> Option<f64> {
            let mut a = [0u8; 8];
            a.copy_from_slice(r.get(68 + 8 * i..76 + 8 * i)?);
            Some(f64::from_le_bytes(a))
        };
        let aided = if word(r, 64) == 1 {
            let mut eskf = [0.0; core_nav::eskf::ESKF_CONFIG_LEN];
            for (k, x) in eskf.iter_mut().enumerate() {
                *x = g(4 + k)?;
            }
            let cfg = AidedConfig {
                eskf: EskfConfig::from_array(eskf),
                initial: InitialSigma {
                    position_m: g(24)?,
                    velocity_mps: g(25)?,
                    level_rad: g(26)?,
                    heading_rad: g(27)?,
                },
                axis: Axis::Z,
                antenna_b_m: [g(1)?, g(2)?, g(3)?],
                zupt: word(r, 68 + 8 * AIDED_F64) == 1,
                zupt_noise: core_nav::aided::ZuptNoise {
                    sigma_f_mps2: g(28)?,
                    sigma_w_radps: g(29)?,
                    sigma_table_rate_radps: g(30)?,
                },
                // The board takes no velocity lag (tuning.rs).
                velocity_lag_s: [0.0; 2],
                // The board sizes its receiver from its fixes (tuning.rs).
                receiver_from_fixes: true,
            };
            Some((g(0)?, cfg))
        } else {
            None
        };
        Some(Self {
            records: word(r, 8),
            lat_deg: f(0)?,
            height_m: f(1)?,
            base_deg: [f(2)?, f(3)?, f(4)?],
            rate_radps: f(5)?,
            counts_per_rev: word(r, 60),
            aided,
            commands: word(r, HEADER - 8),
            fix_latency_us: word(r, HEADER - 4),
        })
    }
}

/// Bytes of a record's kind and time stamp.
pub const RECORD_HEAD: usize = 1 + 8;
/// Bytes of the longest record.
pub const RECORD_MAX: usize = RECORD_HEAD + 4 * 9;
/// Bytes in the trailer.
pub const TRAILER: usize = 1 + 24;
/// Bytes of a command record's payload at most.
pub const COMMAND_MAX: usize = 35;
/// The magic.
pub const MAGIC: [u8; 4] = *b"RPLY";

/// Bytes of a record of `kind` after its head (`None`: an unknown kind).
pub fn record_body(kind: u8) -> Option<usize> {
    match kind {
        1 | 2 => Some(4 * 7),
        3 | 4 => Some(4 * 9),
        _ => None,
    }
}

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
    /// A GNSS fix, sent over the command link `fix_latency_us` after
    /// its time of validity.
    Gnss {
        /// Its time of validity, µs.
        t_us: u64,
        /// The fix.
        fix: GnssFix,
    },
    /// A configuration command's payload (the host's, sent first).
    Command {
        /// Bytes used.
        len: u8,
        /// The payload.
        payload: [u8; COMMAND_MAX],
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

/// Encodes one event into `out`; returns its length.
pub fn encode(e: &Event, out: &mut [u8; RECORD_MAX]) -> usize {
    let mut words = [0u32; 9];
    let (kind, t_us) = match *e {
        Event::Imu {
            t_us,
            gyro,
            accel,
            temp,
        } => {
            for (w, v) in words.iter_mut().zip(gyro.iter().chain(accel.iter())) {
                *w = v.to_bits();
            }
            if let Some(w) = words.get_mut(6) {
                *w = temp.to_bits();
            }
            (1u8, t_us)
        }
        Event::Encoder { t_us, hw } => {
            words[0] = u32::from(hw);
            (2u8, t_us)
        }
        Event::Gnss { t_us, fix: f } => {
            let v = f.v_n_mmps;
            words = [
                f.lat_e7 as u32,
                f.lon_e7 as u32,
                f.height_mm as u32,
                v[0] as u32,
                v[1] as u32,
                v[2] as u32,
                f.sigma_h_mm,
                f.sigma_v_mm,
                f.sigma_vel_mmps,
            ];
            (3u8, t_us)
        }
        Event::Command { len, payload } => {
            let mut b = [0u8; 36];
            b[0] = len;
            b[1..].copy_from_slice(&payload);
            for (w, c) in words.iter_mut().zip(b.chunks_exact(4)) {
                *w = u32::from_le_bytes(c.try_into().unwrap_or([0; 4]));
            }
            (4u8, 0)
        }
    };
    *out = [0u8; RECORD_MAX];
    out[0] = kind;
    out[1..9].copy_from_slice(&t_us.to_le_bytes());
    for (k, w) in words.iter().enumerate() {
        if let Some(dst) = out.get_mut(9 + 4 * k..13 + 4 * k) {
            dst.copy_from_slice(&w.to_le_bytes());
        }
    }
    RECORD_HEAD + record_body(kind).unwrap_or(0)
}

/// Decodes one event (head and body); `None` for an unknown kind or a
/// short record.
pub fn decode(r: &[u8]) -> Option<Event> {
    let mut t = [0u8; 8];
    t.copy_from_slice(r.get(1..9)?);
    let t_us = u64::from_le_bytes(t);
    let kind = *r.first()?;
    if r.len() < RECORD_HEAD + record_body(kind)? {
        return None;
    }
    let w = |k: usize| word(r, 9 + 4 * k);
    let f = |k: usize| f32::from_bits(w(k));
    match kind {
        1 => Some(Event::Imu {
            t_us,
            gyro: [f(0), f(1), f(2)],
            accel: [f(3), f(4), f(5)],
            temp: f(6),
        }),
        2 => Some(Event::Encoder {
            t_us,
            hw: w(0) as u16,
        }),
        4 => {
            let body = r.get(RECORD_HEAD..RECORD_HEAD + 36)?;
            let mut payload = [0u8; COMMAND_MAX];
            payload.copy_from_slice(body.get(1..)?);
            let len = *body.first()?;
            (usize::from(len) <= COMMAND_MAX).then_some(Event::Command { len, payload })
        }
        _ => Some(Event::Gnss {
            t_us,
            fix: GnssFix {
                lat_e7: w(0) as i32,
                lon_e7: w(1) as i32,
                height_mm: w(2) as i32,
                v_n_mmps: [w(3) as i32, w(4) as i32, w(5) as i32],
                sigma_h_mm: w(6),
                sigma_v_mm: w(7),
                sigma_vel_mmps: w(8),
            },
        }),
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

impl Event {
    /// A configuration command as a replay record.
    pub fn command(c: &crate::Command) -> Option<Self> {
        let mut payload = [0u8; COMMAND_MAX];
        let n = c.encode(0, &mut payload).ok()?;
        Some(Event::Command {
            len: u8::try_from(n).ok()?,
            payload,
        })
    }
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

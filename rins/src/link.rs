//! The host's end of the board's link: a port (a serial device, or
//! `unix:PATH` for the QEMU build's emulated USART), commands sent and
//! acknowledged, telemetry decoded, and GNSS fixes relayed with their time
//! of validity on the board's clock. Every byte is the `protocol` crate's.

use anyhow::{anyhow, bail, Context, Result};
use protocol::{Command, Decoder, SchemeKind, Status, Telemetry, MAX_FRAME, MAX_PAYLOAD};
use recording::moving::GnssRow;
use recording::Recording;
use std::io::{Read, Write};
use std::time::{Duration, Instant};

/// The commands that configure a board for `rec`: its site, its base, its
/// table's scheme at `rate_radps`, and aided navigation when the recording
/// has GNSS (the origin at the site, its longitude).
pub fn config_commands(rec: &Recording, rate_radps: f64) -> Vec<Command> {
    let m = &rec.meta;
    let e7 = |deg: f64| (deg * 1e7).round() as i32;
    let aided = rec.moving.as_ref().filter(|mv| mv.gnss.is_some());
    vec![
        Command::SetSite {
            lat_e7: e7(m.latitude_deg),
            height_mm: (m.height_m * 1e3).round() as i32,
        },
        Command::SetBase {
            roll_deg: m.roll_deg as f32,
            pitch_deg: m.pitch_deg as f32,
            heading_deg: m.heading_deg as f32,
        },
        Command::SetScheme {
            kind: SchemeKind::Continuous,
            rate_dps: rate_radps.to_degrees() as f32,
            count: 0,
        },
        Command::SetAided {
            on: u8::from(aided.is_some()),
            lon_e7: aided.map_or(0, |mv| e7(mv.longitude_deg)),
        },
    ]
}

/// A byte link to a board.
pub trait Port: Read + Write + Send {}
impl<T: Read + Write + Send> Port for T {}

/// Opens `spec`: `unix:PATH` (a socket: the QEMU build's USART3), or a
/// serial device at `baud`.
///
/// # Errors
/// The port cannot be opened.
pub fn open(spec: &str, baud: u32) -> Result<Box<dyn Port>> {
    if let Some(path) = spec.strip_prefix("unix:") {
        #[cfg(unix)]
        {
            // QEMU creates the socket as it starts: wait for it.
            let start = Instant::now();
            loop {
                match std::os::unix::net::UnixStream::connect(path) {
                    Ok(s) => {
                        s.set_read_timeout(Some(Duration::from_millis(200)))?;
                        return Ok(Box::new(s));
                    }
                    Err(e) if start.elapsed() < Duration::from_secs(30) => {
                        let _ = e;
                        std::thread::sleep(Duration::from_millis(50));
                    }
                    Err(e) => return Err(e).with_context(|| format!("connecting to {path}")),
                }
            }
        }
        #[cfg(not(unix))]
        bail!("unix sockets need a unix host: {path}");
    }
    let p = serialport::new(spec, baud)
        .timeout(Duration::from_millis(200))
        .open()
        .with_context(|| format!("opening {spec}"))?;
    Ok(Box::new(p))
}

/// A session with a board: what was received (raw and decoded) and the
/// commands' sequence numbers.
pub struct Session {
    port: Box<dyn Port>,
    decoder: Decoder,
    seq: u16,
    /// Every byte received.
    pub bytes: Vec<u8>,
    /// The port closed (the QEMU build exited).
    pub closed: bool,
}

impl Session {
    /// A session on `port`.
    pub fn new(port: Box<dyn Port>) -> Self {
        Self {
            port,
            decoder: Decoder::default(),
            seq: 0,
            bytes: vec![],
            closed: false,
        }
    }

    /// Sends `c`; returns its sequence number.
    ///
    /// # Errors
    /// The port's.
    pub fn send(&mut self, c: &Command) -> Result<u16> {
        let mut f = [0u8; MAX_FRAME];
        let seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        let n = c.to_frame(seq, &mut f).map_err(|e| anyhow!("{e:?}"))?;
        self.port.write_all(&f[..n])?;
        self.port.flush()?;
        Ok(seq)
    }

    /// Reads what is there (up to the port's timeout); returns the frames.
    ///
    /// # Errors
    /// The port's.
    pub fn pump(&mut self) -> Result<Vec<Telemetry>> {
        let mut buf = [0u8; 4096];
        let n = match self.port.read(&mut buf) {
            Ok(0) => {
                self.closed = true;
                0
            }
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
                ) =>
            {
                0
            }
            Err(e) => return Err(e.into()),
        };
        self.bytes.extend_from_slice(&buf[..n]);
        let mut out = [0u8; MAX_PAYLOAD + 2];
        let mut frames = vec![];
        for b in &buf[..n] {
            if let Some(m) = self.decoder.push(*b, &mut out) {
                match Telemetry::decode(&out[..m]) {
                    Ok((_, t)) => frames.push(t),
                    Err(_) => self.decoder.count_corrupt(),
                }
            }
        }
        Ok(frames)
    }

    /// Sends `c` and waits for its `Ack` (resending twice); the frames
    /// that came meanwhile go to `seen`.
    ///
    /// # Errors
    /// No answer, or the port's.
    pub fn command(&mut self, c: &Command, seen: &mut impl FnMut(&Telemetry)) -> Result<Status> {
        for _ in 0..3 {
            let seq = self.send(c)?;
            let start = Instant::now();
            while start.elapsed() < Duration::from_secs(2) && !self.closed {
                for t in self.pump()? {
                    seen(&t);
                    if let Telemetry::Ack { seq: s, status } = t {
                        if s == seq {
                            return Ok(status);
                        }
                    }
                }
            }
        }
        bail!("the board did not acknowledge {c:?}")
    }
}

/// GNSS fixes relayed to a board at their time of validity, sent
/// `latency_us` after it (by the board's clock, read from its IMU frames).
pub struct Relay {
    fixes: Vec<GnssRow>,
    next: usize,
    /// The recording's time of its first IMU sample, µs (`None`: the
    /// fixes' times are already the board's).
    rec_t0_us: Option<i64>,
    offset_us: Option<i64>,
    latency_us: u64,
    /// Fixes sent.
    pub sent: usize,
}

impl Relay {
    /// A relay of `fixes`; `rec_t0_us` maps their clock to the board's
    /// (the board's first IMU frame is the recording's first sample).
    pub fn new(fixes: Vec<GnssRow>, rec_t0_us: Option<i64>, latency_us: u64) -> Self {
        Self {
            fixes,
            next: 0,
            rec_t0_us,
            offset_us: rec_t0_us.is_none().then_some(0),
            latency_us,
            sent: 0,
        }
    }

    /// The fixes due now that frame `t` shows the board's time.
    pub fn due(&mut self, t: &Telemetry) -> Vec<Command> {
        let Telemetry::Imu { t_us, .. } = *t else {
            return vec![];
        };
        let offset = *self
            .offset_us
            .get_or_insert_with(|| t_us as i64 - self.rec_t0_us.unwrap_or(0));
        let mut out = vec![];
        while let Some(f) = self.fixes.get(self.next) {
            let t_valid = ((f.t_s * 1e6).round() as i64 + offset).max(0) as u64;
            if t_valid + self.latency_us > t_us {
                break;
            }
            out.push(Command::GnssFix {
                t_valid_us: t_valid,
                fix: f.to_fix(),
            });
            self.next += 1;
            self.sent += 1;
        }
        out
    }

    /// Fixes not yet sent.
    pub fn left(&self) -> usize {
        self.fixes.len() - self.next
    }
}

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
            heading_deg: heading_for_board(m.heading_deg),
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

/// A heading (deg, any turn) as the board takes it: within +-180 deg
/// (`protocol`'s `SetBase`), in f32. A recording's 0-360 deg heading
/// above 180 (or a hair under 360, which rounds to 360 in f32) was sent
/// as it was and refused with `BadBase`.
fn heading_for_board(deg: f64) -> f32 {
    let h = ((deg + 180.0).rem_euclid(360.0) - 180.0) as f32;
    // -180 + a hair rounds to -180.0 in f32: inside.
    h.clamp(-180.0, 180.0)
}

/// A byte link to a board.
pub trait Port: Read + Write + Send {}
impl<T: Read + Write + Send> Port for T {}

/// The board's baud rate when none is given, bit/s.
pub const BOARD_BAUD: u32 = 921_600;

/// Opens `spec`: `unix:PATH` (a socket: the QEMU build's USART3), or a
/// serial device at `baud` (default `default_baud`). `--flag` names the
/// option that gave `baud`.
///
/// # Errors
/// The port cannot be opened; a baud rate given for a socket (it has
/// none: refused, not ignored).
pub fn open(spec: &str, baud: Option<u32>, default_baud: u32, flag: &str) -> Result<Box<dyn Port>> {
    if let Some(path) = spec.strip_prefix("unix:") {
        if let Some(b) = baud {
            bail!("{flag} {b} with {spec}: a socket has no baud rate");
        }
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
    let p = serialport::new(spec, baud.unwrap_or(default_baud))
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

    /// Waits up to `timeout` for the board's first frame (a board just
    /// powered answers only when its `init` ends: up to about 5 s when the
    /// boot moves its flash journal, two 128 KiB erases at the datasheet's
    /// worst); the frames go to `seen`. Bytes sent before would arrive
    /// while `init` runs.
    ///
    /// # Errors
    /// Nothing came within `timeout`, or the port's.
    pub fn wait_for_board(
        &mut self,
        timeout: Duration,
        seen: &mut impl FnMut(&Telemetry),
    ) -> Result<()> {
        let start = Instant::now();
        while start.elapsed() < timeout && !self.closed {
            let frames = self.pump()?;
            frames.iter().for_each(&mut *seen);
            if !frames.is_empty() {
                return Ok(());
            }
        }
        bail!(
            "the board sent nothing in {:.0} s: is it powered, on this port, at this baud?",
            timeout.as_secs_f64()
        )
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

/// The longest a receiver's solution may take to reach the host (its
/// computation and output at the port's baud): u-blox receivers report
/// within ~100 ms of the epoch; a figure outside [0, 2 s] means the host's
/// UTC clock is not synchronised (NTP) and the fix's epoch cannot be put
/// on the board's clock.
pub const MAX_RECEIVER_LATENCY_US: i64 = 2_000_000;

/// A solution from a live receiver, with when the host read it: its UTC
/// clock (µs since 1970) and its monotonic clock.
#[derive(Clone, Copy, Debug)]
pub struct Arrival {
    /// The receiver's solution.
    pub pvt: crate::ubx::NavPvt,
    /// The host's UTC clock at arrival, µs since 1970.
    pub host_utc_us: i64,
    /// The host's monotonic clock at arrival.
    pub at: Instant,
}

/// Why a live fix was not relayed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Skip {
    /// No valid 3-D solution, or no valid UTC time.
    NoFix,
    /// It came before the board's first IMU frame (no clock to map to).
    NoBoardClock,
    /// The receiver's epoch against the host's UTC clock is outside
    /// [0, [`MAX_RECEIVER_LATENCY_US`]]: the host's clock is off.
    ClockMismatch,
}

/// A fix's time of validity on the board's clock, µs: the board's time
/// when the host read it (the last IMU frame's board time `board_us`, read
/// at `board_at`, plus the host's monotonic time since) less the
/// receiver's latency (the host's UTC at arrival less the fix's UTC
/// epoch). The link's own latency (a telemetry frame's bytes at 921,600
/// baud, well under a millisecond) is neglected.
///
/// # Errors
/// [`Skip::ClockMismatch`].
pub fn board_time_of_validity(
    board_us: u64,
    board_at: Instant,
    a: &Arrival,
    fix_utc_us: i64,
) -> Result<u64, Skip> {
    let latency = a.host_utc_us - fix_utc_us;
    if !(0..=MAX_RECEIVER_LATENCY_US).contains(&latency) {
        return Err(Skip::ClockMismatch);
    }
    let since = match a.at.checked_duration_since(board_at) {
        Some(d) => d.as_micros() as i64,
        None => -(board_at.duration_since(a.at).as_micros() as i64),
    };
    Ok((board_us as i64 + since - latency).max(0) as u64)
}

/// A live receiver's fixes (UBX-NAV-PVT on a port) relayed to a board,
/// each at its time of validity on the board's clock.
pub struct LiveRelay {
    rx: std::sync::mpsc::Receiver<Arrival>,
    board: Option<(u64, Instant)>,
    /// Fixes sent.
    pub sent: usize,
    /// Solutions not relayed, by reason.
    pub skipped: Vec<(Skip, usize)>,
    /// The receiver's frames with a bad checksum, shared with its reader.
    pub bad_frames: std::sync::Arc<std::sync::atomic::AtomicU32>,
}

impl LiveRelay {
    /// Reads `port` on a thread of its own until it closes.
    pub fn spawn(mut port: Box<dyn Port>) -> Self {
        let (tx, rx) = std::sync::mpsc::channel();
        let bad = std::sync::Arc::new(std::sync::atomic::AtomicU32::new(0));
        let bad_frames = bad.clone();
        std::thread::spawn(move || {
            let mut d = crate::ubx::Decoder::default();
            let mut buf = [0u8; 1024];
            loop {
                let n = match port.read(&mut buf) {
                    Ok(0) => return,
                    Ok(n) => n,
                    Err(e) if matches!(e.kind(), std::io::ErrorKind::TimedOut) => continue,
                    Err(_) => return,
                };
                let host_utc_us = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_micros() as i64);
                let at = Instant::now();
                for (c, i, p) in d.push(&buf[..n]) {
                    if let Some(pvt) = crate::ubx::NavPvt::parse(c, i, &p) {
                        let arrival = Arrival {
                            pvt,
                            host_utc_us,
                            at,
                        };
                        if tx.send(arrival).is_err() {
                            return;
                        }
                    }
                }
                bad.store(d.bad_checksum, std::sync::atomic::Ordering::Relaxed);
            }
        });
        Self {
            rx,
            board: None,
            sent: 0,
            skipped: vec![],
            bad_frames,
        }
    }

    fn skip(&mut self, why: Skip) {
        match self.skipped.iter_mut().find(|(w, _)| *w == why) {
            Some((_, n)) => *n += 1,
            None => self.skipped.push((why, 1)),
        }
    }

    /// The fixes that arrived, now that frame `t` (when it is an IMU
    /// frame) shows the board's time.
    pub fn due(&mut self, t: &Telemetry) -> Vec<Command> {
        if let Telemetry::Imu { t_us, .. } = *t {
            self.board = Some((t_us, Instant::now()));
        }
        let mut out = vec![];
        while let Ok(a) = self.rx.try_recv() {
            let (Some(fix), Some(utc)) = (a.pvt.fix(), a.pvt.utc_unix_us()) else {
                self.skip(Skip::NoFix);
                continue;
            };
            let Some((b_us, b_at)) = self.board else {
                self.skip(Skip::NoBoardClock);
                continue;
            };
            match board_time_of_validity(b_us, b_at, &a, utc) {
                Ok(t_valid_us) => {
                    out.push(Command::GnssFix { t_valid_us, fix });
                    self.sent += 1;
                }
                Err(why) => self.skip(why),
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arrival(host_utc_us: i64, at: Instant) -> Arrival {
        let mut d = crate::ubx::Decoder::default();
        let bytes = crate::ubx::tests_support::real_nav_pvt();
        let (c, i, p) = d.push(&bytes).remove(0);
        Arrival {
            pvt: crate::ubx::NavPvt::parse(c, i, &p).unwrap(),
            host_utc_us,
            at,
        }
    }

    #[test]
    fn a_base_heading_of_any_turn_is_one_the_board_takes() {
        // The held-back drive's 185 deg, a hair under a whole turn (a
        // simulated body's roll wraps its heading to 359.99999999 deg),
        // and the plain ones: each a SetBase the protocol accepts, the
        // same direction to f32's precision.
        for deg in [
            0.0,
            90.0,
            180.0,
            185.0,
            359.999_999_99,
            360.0,
            -190.0,
            725.0,
        ] {
            let mut rec = Recording::default();
            rec.meta.heading_deg = deg;
            let cmds = config_commands(&rec, 0.5);
            let Some(Command::SetBase { heading_deg, .. }) = cmds.get(1).copied() else {
                panic!("{cmds:?}");
            };
            assert_eq!(cmds[1].check(), Ok(()), "{deg}: {heading_deg}");
            let turn = (f64::from(heading_deg) - deg).rem_euclid(360.0);
            assert!(turn.min(360.0 - turn) < 1e-4, "{deg}: {heading_deg}");
        }
    }

    #[test]
    fn a_fix_is_put_on_the_boards_clock_at_its_epoch() {
        // The board said 10 s at `t0`; the fix's bytes came 250 ms later
        // (host monotonic), 120 ms after its UTC epoch (host UTC): its
        // time of validity is 10.25 - 0.12 = 10.13 s on the board's clock.
        let t0 = Instant::now();
        let a = arrival(1_000_120_000, t0 + Duration::from_millis(250));
        let t = board_time_of_validity(10_000_000, t0, &a, 1_000_000_000).unwrap();
        assert_eq!(t, 10_130_000);
        // A fix read before the board's last IMU frame (the frames were
        // drained later) maps backwards in time just as well.
        let b = arrival(1_000_120_000, t0);
        let t = board_time_of_validity(
            10_250_000,
            t0 + Duration::from_millis(250),
            &b,
            1_000_000_000,
        );
        assert_eq!(t, Ok(10_000_000 - 120_000));
    }

    #[cfg(unix)]
    #[test]
    fn a_live_receivers_fixes_reach_the_board_at_their_epoch() {
        // A receiver on a port (one end of a socket pair) sends a solution
        // whose epoch is 100 ms before now; the board's last IMU frame
        // said 50 s just now. The fix's time of validity is 49.9 s on the
        // board's clock, within the few ms the threads take.
        let (host, mut receiver) = std::os::unix::net::UnixStream::pair().unwrap();
        host.set_read_timeout(Some(Duration::from_millis(50)))
            .unwrap();
        let mut relay = LiveRelay::spawn(Box::new(host));
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_micros() as i64;
        let imu = Telemetry::Imu {
            t_us: 50_000_000,
            gyro_radps: [0.0; 3],
            accel_mps2: [0.0; 3],
            temp_c: 25.0,
        };
        assert!(relay.due(&imu).is_empty());
        receiver
            .write_all(&crate::ubx::tests_support::real_nav_pvt_at(now - 100_000))
            .unwrap();
        let start = Instant::now();
        let mut got = vec![];
        while got.is_empty() && start.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(5));
            got = relay.due(&Telemetry::Ack {
                seq: 0,
                status: Status::Accepted,
            });
        }
        let Some(Command::GnssFix { t_valid_us, fix }) = got.first().copied() else {
            panic!("no fix relayed: {:?}", relay.skipped);
        };
        assert_eq!(fix.lat_e7, 534_507_692);
        // 50 ms: the test's sleeps and the scheduler, not the mapping.
        assert!(t_valid_us.abs_diff(49_900_000) < 50_000, "{t_valid_us}");
    }

    #[test]
    fn a_host_clock_off_by_seconds_is_refused_not_relayed() {
        let t0 = Instant::now();
        // The host's UTC is 3 s behind the receiver's epoch, or 5 s ahead.
        for host in [997_000_000, 1_005_000_000] {
            let a = arrival(host, t0);
            assert_eq!(
                board_time_of_validity(10_000_000, t0, &a, 1_000_000_000),
                Err(Skip::ClockMismatch)
            );
        }
    }
}

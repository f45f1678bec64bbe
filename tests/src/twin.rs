//! The QEMU test's host twin: a replay ([`protocol::replay`]) run through
//! the board's program on the host ([`crate::board::HostBoard`]) as the
//! QEMU build runs it: booted from the journal the replay's configuration
//! left nearly full (`firmware::replay::stored_journal`: the boot erases
//! both sectors, 4 s on the twin's clock), the sensors on from reset (one
//! data-ready edge a millisecond from the end of `init`), the host's
//! configuration commands sent again through the UART (they change
//! nothing), each GNSS fix sent `fix_latency_us` after its time of
//! validity (on the board's clock: the relay's mapping, the board's first
//! IMU frame being the recording's first sample).

use crate::board::{HostBoard, NorFlash};
use firmware::replay::{
    decode, outcome, record_body, Event, Header, Outcome, Sensors, HEADER, RECORD_HEAD,
};
use protocol::Command;

/// The QEMU build's clock at boot (1.5 s below the u32 wrap after the
/// boot's two erases).
pub const CLOCK_START: u32 = u32::MAX - 1_500_000 - 2 * firmware::record::ERASE_WORST_US;

/// What the twin's run came to.
pub struct TwinRun {
    /// The outcome (the trailer).
    pub outcome: Outcome,
    /// The board at the end.
    pub board: HostBoard,
    /// Fixes sent.
    pub fixes: usize,
}

/// How the twin runs a replay.
#[derive(Clone, Copy, Debug, Default)]
pub struct TwinOptions {
    /// Send each fix this long after its time of validity, µs (`None`: the
    /// header's).
    pub latency_us: Option<u64>,
    /// The board's fix horizon, µs (`None`: its tuning's).
    pub horizon_us: Option<u64>,
    /// Stamp each fix with its arrival, not its time of validity (what a
    /// board without times of validity does).
    pub stamp_at_arrival: bool,
}

/// A replay's header and its records.
///
/// # Panics
/// A malformed replay (the twin is a test tool).
fn events(bytes: &[u8]) -> (Header, Vec<Event>) {
    let h = Header::decode(&bytes[..HEADER]).expect("a replay header");
    let mut events = vec![];
    let mut at = HEADER;
    for _ in 0..h.records {
        let n = RECORD_HEAD + record_body(bytes[at]).expect("a known record");
        events.push(decode(&bytes[at..at + n]).expect("a record"));
        at += n;
    }
    (h, events)
}

/// The board's program on the host behind a unix socket at `path`, as the
/// QEMU build's USART3 is to `rins command` and `rins record` (`--port
/// unix:PATH`): booted blank (the factory configuration: the client
/// configures it), its sensors a replay's (from `rins qemu-replay`; its
/// commands and fixes left to the client), one data-ready edge a
/// millisecond of wall time, then idle when the replay ends. Serves one
/// connection until the peer closes it; the thread returns the board.
///
/// # Panics
/// The socket cannot be bound; a malformed replay (a test's fixture).
#[cfg(unix)]
pub fn serve_unix(path: &std::path::Path, replay: Vec<u8>) -> std::thread::JoinHandle<HostBoard> {
    use std::io::{Read, Write};
    use std::time::{Duration, Instant};
    let _ = std::fs::remove_file(path);
    let listener = std::os::unix::net::UnixListener::bind(path).expect("binding the socket");
    std::thread::spawn(move || {
        let (h, events) = events(&replay);
        let tuning = firmware::replay::tuning(&h, firmware::tuning::board());
        let mut b = HostBoard::new(tuning, NorFlash::new(4096), u64::from(CLOCK_START), Ok(()));
        let Ok((mut sock, _)) = listener.accept() else {
            return b;
        };
        let _ = sock.set_read_timeout(Some(Duration::from_millis(2)));
        let mut it = events
            .into_iter()
            .filter(|e| matches!(e, Event::Imu { .. } | Event::Encoder { .. }));
        let (mut s, mut i, mut more) = (Sensors::default(), 0u64, true);
        let (start, mut buf) = (Instant::now(), [0u8; 512]);
        loop {
            match sock.read(&mut buf) {
                Ok(0) => return b,
                Ok(n) => b.receive(buf.get(..n).unwrap_or(&[])),
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) => {}
                Err(_) => return b,
            }
            // Catch up with the wall clock, an edge a millisecond.
            while (i as u128) < start.elapsed().as_millis() {
                if more {
                    more = s.advance(i, &mut || it.next(), &mut |_| {});
                    let (mut enc, mut motor) = (s, s);
                    let mcu = b.mcu_us + 1_000;
                    b.edge(mcu, &mut s, &mut enc, &mut motor);
                } else {
                    b.idle(1_000);
                }
                i += 1;
            }
            let out = std::mem::take(&mut b.sent);
            if sock.write_all(&out).is_err() {
                return b;
            }
        }
    })
}

/// Runs `bytes` (a replay; its trailer ignored).
///
/// # Panics
/// A malformed replay (the twin is a test tool).
pub fn run(bytes: &[u8], opt: TwinOptions) -> TwinRun {
    let (h, events) = events(bytes);
    let mut tuning = firmware::replay::tuning(&h, firmware::tuning::board());
    if let Some(hz) = opt.horizon_us {
        tuning.nav.fix_horizon_us = hz;
    }
    let commands: Vec<Command> = events
        .iter()
        .filter_map(|e| match e {
            Event::Command { len, payload } => Some(
                Command::decode(&payload[..usize::from(*len)])
                    .expect("a command")
                    .1,
            ),
            _ => None,
        })
        .collect();
    let mut flash = NorFlash::new(4096);
    firmware::replay::stored_journal(
        &mut flash,
        crate::board::JOURNAL,
        commands.iter().copied(),
        tuning.control.limits,
    )
    .expect("the stored journal");
    let mut b = HostBoard::new(tuning, flash, u64::from(CLOCK_START), Ok(()));
    // As `rins record` configures a board, at once: the configuration
    // and the scheme are the ones stored, so nothing changes whenever
    // they are taken (under QEMU they arrive at no fixed sample).
    for c in &commands {
        b.command(c);
    }
    let latency = opt.latency_us.unwrap_or(u64::from(h.fix_latency_us));
    let first_rec = events.iter().find_map(|e| match e {
        Event::Imu { t_us, .. } => Some(*t_us),
        _ => None,
    });
    let mut it = events
        .into_iter()
        .filter(|e| !matches!(e, Event::Command { .. }));
    let mut s = Sensors::default();
    let mut fixes: Vec<(u64, core_nav::aided::GnssFix)> = vec![];
    let mut sent = 0;
    let mut offset: Option<i64> = None;
    let mut mcu = b.mcu_us;
    let mut i = 0u64;
    loop {
        let more = s.advance(i, &mut || it.next(), &mut |e| {
            if let Event::Gnss { t_us, fix } = e {
                fixes.push((t_us, fix));
            }
        });
        mcu += 1_000;
        // The encoder and the motor: copies of the sensors after the
        // advance (the same count; the duty is not used).
        let (mut enc, mut motor) = (s, s);
        b.edge(mcu, &mut s, &mut enc, &mut motor);
        i += 1;
        if offset.is_none() {
            if let (Some(x), Some(r0)) = (b.program.nav.nav.last_input(), first_rec) {
                offset = Some(x.t_us as i64 - r0 as i64);
            }
        }
        if let (Some(o), Some(x)) = (offset, b.program.nav.nav.last_input().copied()) {
            while let Some(&(t, fix)) = fixes.first() {
                let tv = (t as i64 + o) as u64;
                if tv + latency > x.t_us {
                    break;
                }
                fixes.remove(0);
                let t_valid_us = if opt.stamp_at_arrival { x.t_us } else { tv };
                b.command(&Command::GnssFix { t_valid_us, fix });
                sent += 1;
            }
        }
        if !more {
            break;
        }
    }
    b.program.nav.run(b.stats);
    TwinRun {
        outcome: outcome(&b.program.nav.nav),
        board: b,
        fixes: sent,
    }
}

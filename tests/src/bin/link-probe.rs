//! The link test's host end (`scripts/qemu-link-test`): through QEMU's
//! USART3 (a Unix socket), byte by byte, valid commands, random bytes,
//! a truncated frame, a bad CRC, an oversize frame, an unknown message
//! id and an out-of-bounds command; then it reads back the board's acks,
//! the `BadCommand` fault's count and the health frame's link counters,
//! and checks them against what it sent.
//!
//! Its frames are written from the book's formats chapter ("Telemetry and
//! commands": `COBS(payload || crc16) || 0x00`, CRC-16/CCITT-FALSE
//! little-endian, the byte layouts there), not with the `protocol`
//! crate's encoder, so that the two check each other.
//!
//! `link-probe SOCKET [--timeout-s S]`; exits 0 when every check holds.

use std::io::{Read, Write};
use std::os::unix::net::UnixStream;
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// CRC-16/CCITT-FALSE: polynomial 0x1021, initial 0xFFFF, no reflection,
/// no final xor (check value 0x29B1 for "123456789").
fn crc16(data: &[u8]) -> u16 {
    let mut crc = 0xFFFFu16;
    for &b in data {
        crc ^= u16::from(b) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x1021
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// Consistent Overhead Byte Stuffing: no zero byte in the output.
fn cobs(data: &[u8]) -> Vec<u8> {
    let mut out = vec![0];
    let mut code_at = 0;
    for &b in data {
        if b == 0 {
            out[code_at] = (out.len() - code_at) as u8;
            code_at = out.len();
            out.push(0);
        } else {
            out.push(b);
            if out.len() - code_at == 0xFF {
                out[code_at] = 0xFF;
                code_at = out.len();
                out.push(0);
            }
        }
    }
    out[code_at] = (out.len() - code_at) as u8;
    out
}

fn uncobs(data: &[u8]) -> Option<Vec<u8>> {
    let mut out = vec![];
    let mut i = 0;
    while i < data.len() {
        let code = data[i] as usize;
        if code == 0 || i + code > data.len() + 1 {
            return None;
        }
        out.extend_from_slice(data.get(i + 1..i + code)?);
        i += code;
        if code < 0xFF && i < data.len() {
            out.push(0);
        }
    }
    Some(out)
}

/// A payload framed: its CRC appended (little-endian), COBS, the
/// delimiter.
fn frame(payload: &[u8]) -> Vec<u8> {
    let mut p = payload.to_vec();
    p.extend_from_slice(&crc16(payload).to_le_bytes());
    let mut f = cobs(&p);
    f.push(0);
    f
}

/// A command's payload: its id, its sequence number (u16 LE), its fields.
fn command(id: u8, seq: u16, fields: &[u8]) -> Vec<u8> {
    let mut p = vec![id];
    p.extend_from_slice(&seq.to_le_bytes());
    p.extend_from_slice(fields);
    p
}

/// `Stop` (0x83, no fields).
fn stop(seq: u16) -> Vec<u8> {
    command(0x83, seq, &[])
}

/// `SetSite` (0x86): latitude 1e-7 deg (i32), height mm (i32).
fn set_site(seq: u16, lat_e7: i32, height_mm: i32) -> Vec<u8> {
    let mut f = lat_e7.to_le_bytes().to_vec();
    f.extend_from_slice(&height_mm.to_le_bytes());
    command(0x86, seq, &f)
}

/// `SetScheme` (0x81): kind (u8: 1 continuous), rate deg/s (f32), count (u8).
fn set_scheme(seq: u16, kind: u8, rate_dps: f32, count: u8) -> Vec<u8> {
    let mut f = vec![kind];
    f.extend_from_slice(&rate_dps.to_le_bytes());
    f.push(count);
    command(0x81, seq, &f)
}

/// A deterministic generator (the same bytes every run).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> u8 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 33) as u8
    }
    fn nonzero(&mut self) -> u8 {
        loop {
            let b = self.next();
            if b != 0 {
                return b;
            }
        }
    }
}

/// What the host sends and what the board must answer.
struct Plan {
    bytes: Vec<u8>,
    /// (seq, status) each command must be answered with.
    acks: Vec<(u16, u8)>,
    /// Frames the board must count as bad commands.
    bad: u32,
}

fn plan() -> Plan {
    let mut p = Plan {
        bytes: vec![],
        acks: vec![],
        bad: 0,
    };
    let mut rng = Lcg(42);
    // A valid command first.
    p.bytes.extend(frame(&stop(1)));
    p.acks.push((1, 0));
    // Random bytes: 300 without a zero (one oversize frame), then 20
    // random runs of 1-40 bytes each ended by a delimiter (a corrupt frame
    // each: checked below not to be a valid frame by chance).
    p.bytes.extend((0..300).map(|_| rng.nonzero()));
    p.bytes.push(0);
    p.bad += 1;
    for _ in 0..20 {
        let n = 1 + usize::from(rng.next() % 40);
        let run: Vec<u8> = (0..n).map(|_| rng.nonzero()).collect();
        let valid = uncobs(&run).is_some_and(|d| {
            d.len() >= 3 && crc16(&d[..d.len() - 2]).to_le_bytes() == d[d.len() - 2..]
        });
        assert!(!valid, "a random run is a valid frame");
        p.bytes.extend(run);
        p.bytes.push(0);
        p.bad += 1;
    }
    // Truncated: a SetSite whose last three encoded bytes never came.
    let f = frame(&set_site(2, -339_000_000, 20_000));
    p.bytes.extend(&f[..f.len() - 4]);
    p.bytes.push(0);
    p.bad += 1;
    // A bad CRC: the right frame with its CRC's low byte changed.
    let mut q = set_site(2, -339_000_000, 20_000);
    let crc = crc16(&q) ^ 0x0055;
    q.extend_from_slice(&crc.to_le_bytes());
    p.bytes.extend(cobs(&q));
    p.bytes.push(0);
    p.bad += 1;
    // Oversize: a valid frame's bytes repeated past the largest frame.
    let big = frame(&set_site(2, 1, 1));
    for _ in 0..8 {
        p.bytes.extend(&big[..big.len() - 1]);
    }
    p.bytes.push(0);
    p.bad += 1;
    // An unknown message id: answered Malformed (4).
    p.bytes.extend(frame(&command(0x7F, 3, &[1, 2, 3])));
    p.acks.push((3, 4));
    p.bad += 1;
    // A valid SetSite: Accepted once stored.
    p.bytes.extend(frame(&set_site(4, -339_123_456, 21_000)));
    p.acks.push((4, 0));
    // An out-of-bounds rate: BadRate (2).
    p.bytes.extend(frame(&set_scheme(5, 1, 500.0, 0)));
    p.acks.push((5, 2));
    p.bad += 1;
    // And the link still takes a command after all that.
    p.bytes.extend(frame(&stop(6)));
    p.acks.push((6, 0));
    p
}

/// What came back.
#[derive(Default, Debug)]
struct Seen {
    acks: Vec<(u16, u8)>,
    bad_command: Option<u32>,
    /// The latest health frame's (rx_bytes, rx_lost).
    health: Option<(u32, u32)>,
    frames: u32,
    corrupt: u32,
}

fn u32_at(p: &[u8], i: usize) -> Option<u32> {
    Some(u32::from_le_bytes(p.get(i..i + 4)?.try_into().ok()?))
}

/// One telemetry payload (id, the link's seq u16, fields) into `seen`.
fn take(p: &[u8], seen: &mut Seen) {
    seen.frames += 1;
    match p.first() {
        // Ack: the command's seq (u16), status (u8).
        Some(6) if p.len() == 6 => seen.acks.push((u16::from_le_bytes([p[3], p[4]]), p[5])),
        // Fault: t_us (u64), fault (u8: 10 BadCommand), count (u32).
        Some(5) if p.len() == 16 && p[11] == 10 => seen.bad_command = u32_at(p, 12),
        // Health: t_us (u64), reset (u8), six u32, rx_bytes, rx_lost.
        Some(8) if p.len() >= 44 => {
            seen.health = u32_at(p, 36).zip(u32_at(p, 40));
        }
        _ => {}
    }
}

/// One received byte: a frame at its delimiter, checked and taken.
fn byte(b: u8, buf: &mut Vec<u8>, seen: &mut Seen) {
    if b != 0 {
        buf.push(b);
        return;
    }
    match uncobs(buf) {
        Some(d) if d.len() >= 3 && crc16(&d[..d.len() - 2]).to_le_bytes() == d[d.len() - 2..] => {
            take(&d[..d.len() - 2], seen)
        }
        _ => seen.corrupt += 1,
    }
    buf.clear();
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: link-probe SOCKET [--timeout-s S]");
        std::process::exit(2);
    };
    let timeout = args
        .iter()
        .position(|a| a == "--timeout-s")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse::<f64>().ok())
        .unwrap_or(60.0);
    let start = Instant::now();
    let mut sock = loop {
        match UnixStream::connect(path) {
            Ok(s) => break s,
            Err(e) if start.elapsed().as_secs_f64() < 10.0 => {
                let _ = e;
                std::thread::sleep(Duration::from_millis(50));
            }
            Err(e) => {
                eprintln!("link-probe: cannot connect to {path}: {e}");
                std::process::exit(1);
            }
        }
    };
    let (tx, rx) = mpsc::channel::<u8>();
    let mut reader = sock.try_clone().expect("a second handle on the socket");
    std::thread::spawn(move || {
        let mut b = [0u8; 4096];
        while let Ok(n) = reader.read(&mut b) {
            if n == 0 {
                break;
            }
            for x in &b[..n] {
                if tx.send(*x).is_err() {
                    return;
                }
            }
        }
    });
    let p = plan();
    let mut seen = Seen::default();
    let mut buf = vec![];
    // The board's first frame (its boot report) says its USART is up:
    // bytes sent before it would meet a receiver not yet started.
    while seen.frames == 0 && start.elapsed().as_secs_f64() < timeout {
        if let Ok(b) = rx.recv_timeout(Duration::from_millis(200)) {
            byte(b, &mut buf, &mut seen);
        }
    }
    // Byte by byte, as a UART delivers them.
    for b in &p.bytes {
        sock.write_all(&[*b]).expect("the socket takes the byte");
    }
    sock.flush().ok();
    println!(
        "link-probe: sent {} bytes: {} commands to answer, {} bad frames and refusals",
        p.bytes.len(),
        p.acks.len(),
        p.bad
    );
    let done = |s: &Seen| {
        p.acks.iter().all(|a| s.acks.contains(a))
            && s.bad_command == Some(p.bad)
            && s.health.is_some_and(|h| h.0 as usize >= p.bytes.len())
    };
    while !done(&seen) && start.elapsed().as_secs_f64() < timeout {
        if let Ok(b) = rx.recv_timeout(Duration::from_millis(200)) {
            byte(b, &mut buf, &mut seen);
        }
    }
    let mut failed = 0;
    let mut check = |what: &str, ok: bool| {
        println!("link: {what} ... {}", if ok { "ok" } else { "FAILED" });
        if !ok {
            failed += 1;
        }
    };
    for a in &p.acks {
        check(
            &format!("command {} answered with status {}", a.0, a.1),
            seen.acks.contains(a),
        );
    }
    check(
        &format!(
            "bad commands counted: {} sent, the board says {:?}",
            p.bad, seen.bad_command
        ),
        seen.bad_command == Some(p.bad),
    );
    check(
        &format!(
            "every byte received, none lost: {} sent, the board says (received, lost) {:?}",
            p.bytes.len(),
            seen.health
        ),
        seen.health == Some((p.bytes.len() as u32, 0)),
    );
    check(
        &format!(
            "the board's frames intact: {} read, {} corrupt",
            seen.frames, seen.corrupt
        ),
        seen.frames > 0 && seen.corrupt == 0,
    );
    println!("{} passed, {failed} failed", 3 + p.acks.len() - failed);
    std::process::exit(i32::from(failed > 0));
}

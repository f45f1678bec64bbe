//! The link's logic (the lowest-priority task): bytes from the UART's
//! receive queue decoded into commands, checked, acknowledged or routed to
//! the task that answers them; the configuration commands applied to the
//! stored configuration; telemetry framed (one sequence number for the
//! whole link, so the host counts every frame lost) into the transmit
//! queue, whole frames only.

use crate::control::ControlCmd;
use crate::navigation::NavCmd;
use core_nav::scheme::{Limits, Profile, Scheme};
use protocol::frame::Decoder;
use protocol::record::BoardConfig;
use protocol::{Command, FrameError, SchemeKind, Status, Telemetry, MAX_FRAME, MAX_PAYLOAD};

/// Where a command goes.
// A configuration is the large variant; no heap on the board.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Route {
    /// To the control tick (acknowledged here).
    Control(ControlCmd),
    /// To navigation (which acknowledges it).
    Nav(NavCmd),
    /// The configuration changed: store it, tell navigation and the tick,
    /// and acknowledge command `seq` once it is stored (or say it was
    /// not).
    Config {
        /// The new configuration.
        cfg: BoardConfig,
        /// The command's sequence number.
        seq: u16,
    },
}

/// The scheme a configuration names.
pub fn scheme(c: &BoardConfig) -> Scheme {
    let rate = f64::from(c.rate_dps).to_radians();
    match c.scheme {
        SchemeKind::Still => Scheme::Still,
        SchemeKind::Continuous => Scheme::Continuous { rate },
        SchemeKind::Reciprocating => Scheme::Reciprocating {
            rate,
            turns: u32::from(c.count),
        },
        SchemeKind::Indexed => Scheme::Indexed {
            rate,
            positions: c.count,
            dwell_s: 10.0,
        },
    }
}

/// The link's state.
pub struct Link {
    decoder: Decoder,
    seq: u16,
    limits: Limits,
    /// The configuration in use (commands change it).
    pub config: BoardConfig,
    /// Commands taken (acknowledged or routed).
    pub commands: u32,
    /// Frames dropped because the transmit queue had no room.
    pub tx_dropped: u32,
}

impl Link {
    /// The link with the stored configuration.
    pub fn new(config: BoardConfig, limits: Limits) -> Self {
        Self {
            decoder: Decoder::default(),
            seq: 0,
            limits,
            config,
            commands: 0,
            tx_dropped: 0,
        }
    }

    /// The decoder's counters (frames, corrupt, overflow, lost).
    pub fn rx_stats(&self) -> protocol::LinkStats {
        self.decoder.stats
    }

    /// One received byte; a complete command is checked and routed, and
    /// answered (`ack`) unless navigation answers it.
    pub fn rx(&mut self, b: u8, route: &mut impl FnMut(Route), ack: &mut impl FnMut(Telemetry)) {
        let mut p = [0u8; MAX_PAYLOAD + 2];
        let Some(n) = self.decoder.push(b, &mut p) else {
            return;
        };
        let payload = p.get(..n).unwrap_or(&[]);
        let seq = u16::from_le_bytes([
            payload.get(1).copied().unwrap_or(0),
            payload.get(2).copied().unwrap_or(0),
        ]);
        self.commands = self.commands.wrapping_add(1);
        let status = match Command::parse(payload) {
            Ok((_, c)) => self.take(seq, c, route),
            Err(FrameError::OutOfBounds(s)) => Some(s),
            Err(_) => Some(Status::Malformed),
        };
        if let Some(status) = status {
            ack(Telemetry::Ack { seq, status });
        }
    }

    /// A command taken as [`Self::rx`] takes it, its routes dropped: the
    /// configuration it leaves in [`Self::config`] (a replay's stored
    /// configuration, `crate::replay::stored_journal`).
    pub fn apply(&mut self, c: Command) {
        let _ = self.take(0, c, &mut |_| {});
    }

    /// Routes a checked command; `None` when navigation acknowledges it,
    /// or the link task once the configuration is stored.
    fn take(&mut self, seq: u16, c: Command, route: &mut impl FnMut(Route)) -> Option<Status> {
        let mut cfg = self.config;
        match c {
            Command::Stop {} => {
                route(Route::Control(ControlCmd::Stop));
                return Some(Status::Accepted);
            }
            Command::Start {} => {
                route(Route::Nav(NavCmd::Start { seq }));
                return None;
            }
            Command::Recalibrate {} => {
                route(Route::Nav(NavCmd::Recalibrate { seq }));
                return None;
            }
            Command::GnssFix { t_valid_us, fix } => {
                route(Route::Nav(NavCmd::Fix {
                    seq,
                    t_valid_us,
                    fix,
                }));
                return None;
            }
            Command::SetScheme {
                kind,
                rate_dps,
                count,
            } => {
                cfg.scheme = kind;
                cfg.rate_dps = rate_dps;
                cfg.count = count;
                if Profile::new(scheme(&cfg), self.limits).is_err() {
                    return Some(Status::BadRate);
                }
            }
            Command::SetSite { lat_e7, height_mm } => {
                cfg.lat_e7 = lat_e7;
                cfg.height_mm = height_mm;
            }
            Command::SetBase {
                roll_deg,
                pitch_deg,
                heading_deg,
            } => cfg.base_deg = [roll_deg, pitch_deg, heading_deg],
            Command::SetAided { on, lon_e7 } => {
                cfg.aided = on == 1;
                cfg.lon_e7 = lon_e7;
            }
        }
        self.config = cfg;
        route(Route::Config { cfg, seq });
        None
    }

    /// The configuration as telemetry.
    pub fn config_report(&self) -> Telemetry {
        let c = &self.config;
        Telemetry::Config {
            lat_e7: c.lat_e7,
            height_mm: c.height_mm,
            base_deg: c.base_deg,
            scheme: c.scheme,
            rate_dps: c.rate_dps,
            count: c.count,
            aided: u8::from(c.aided),
            lon_e7: c.lon_e7,
        }
    }

    /// Frames `t` with the link's next sequence number and hands it to
    /// `send` whole (`send` returns false when it has no room: the frame
    /// is dropped and counted, and its sequence number stays used, so the
    /// host counts it lost).
    pub fn send(&mut self, t: &Telemetry, send: &mut impl FnMut(&[u8]) -> bool) {
        let mut f = [0u8; MAX_FRAME];
        let seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        let Ok(n) = t.to_frame(seq, &mut f) else {
            return;
        };
        if !send(f.get(..n).unwrap_or(&[])) {
            self.tx_dropped = self.tx_dropped.saturating_add(1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tasks::FACTORY;

    fn frame(c: &Command, seq: u16) -> Vec<u8> {
        let mut f = [0u8; MAX_FRAME];
        let n = c.to_frame(seq, &mut f).unwrap();
        f[..n].to_vec()
    }

    /// Feeds `bytes` one at a time; returns the routes and the acks.
    fn feed(l: &mut Link, bytes: &[u8]) -> (Vec<Route>, Vec<Telemetry>) {
        let (mut routes, mut acks) = (vec![], vec![]);
        for b in bytes {
            l.rx(*b, &mut |r| routes.push(r), &mut |t| acks.push(t));
        }
        (routes, acks)
    }

    #[test]
    fn a_site_sent_byte_by_byte_changes_the_configuration_and_is_routed_to_be_stored() {
        let mut l = Link::new(FACTORY, Limits::default());
        let c = Command::SetSite {
            lat_e7: -339_000_000,
            height_mm: 40_000,
        };
        let (routes, acks) = feed(&mut l, &frame(&c, 7));
        assert_eq!(l.config.lat_e7, -339_000_000);
        assert!(
            matches!(routes.as_slice(), [Route::Config { cfg, seq: 7 }] if cfg.height_mm == 40_000)
        );
        // Acknowledged by the link task once stored, not here.
        assert!(acks.is_empty());
    }

    #[test]
    fn out_of_range_and_malformed_commands_are_answered_with_the_reason() {
        let mut l = Link::new(FACTORY, Limits::default());
        // 500 deg/s is beyond the table's 200 deg/s.
        let fast = Command::SetScheme {
            kind: SchemeKind::Continuous,
            rate_dps: 500.0,
            count: 0,
        };
        let (routes, acks) = feed(&mut l, &frame(&fast, 1));
        assert!(routes.is_empty());
        assert_eq!(
            acks,
            [Telemetry::Ack {
                seq: 1,
                status: Status::BadRate
            }]
        );
        assert_eq!(l.config, FACTORY);
        // A frame whose CRC is fine but whose type is not a command.
        let mut p = [0u8; MAX_PAYLOAD];
        let n = Telemetry::Ack {
            seq: 0,
            status: Status::Accepted,
        }
        .encode(9, &mut p)
        .unwrap();
        let mut f = [0u8; MAX_FRAME];
        let m = protocol::frame(&p[..n], &mut f).unwrap();
        let (_, acks) = feed(&mut l, &f[..m]);
        assert!(matches!(
            acks.as_slice(),
            [Telemetry::Ack {
                status: Status::Malformed,
                ..
            }]
        ));
    }

    #[test]
    fn fixes_and_starts_go_to_navigation_which_answers_them() {
        let mut l = Link::new(FACTORY, Limits::default());
        let (routes, acks) = feed(&mut l, &frame(&Command::Start {}, 3));
        assert_eq!(routes, [Route::Nav(NavCmd::Start { seq: 3 })]);
        assert!(acks.is_empty());
    }

    #[test]
    fn a_frame_without_room_is_dropped_whole_and_its_number_stays_used() {
        let mut l = Link::new(FACTORY, Limits::default());
        let t = l.config_report();
        let mut sent = vec![];
        l.send(&t, &mut |b| {
            sent.push(b.to_vec());
            true
        });
        l.send(&t, &mut |_| false);
        l.send(&t, &mut |b| {
            sent.push(b.to_vec());
            true
        });
        assert_eq!(l.tx_dropped, 1);
        // The host's decoder sees sequence numbers 0 and 2: one frame lost.
        let mut d = protocol::Decoder::default();
        let mut out = [0u8; MAX_PAYLOAD + 2];
        let mut seqs = vec![];
        for b in sent.concat() {
            if let Some(n) = d.push(b, &mut out) {
                seqs.push(Telemetry::decode(&out[..n]).unwrap().0);
            }
        }
        assert_eq!(seqs, [0, 2]);
    }
}

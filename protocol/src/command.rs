//! What a host sends; every command is answered with an `Ack`.

use crate::codes::{SchemeKind, Status};
use crate::frame::{frame, FrameError, MAX_FRAME, MAX_PAYLOAD};
use crate::wire::messages;
use core_nav::aided::GnssFix;

messages! {
    /// A host's command.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub enum Command {
        /// The rotation scheme: kind, rate (deg/s, 0 < r <= 200), turns
        /// (reciprocating, >= 1) or positions (indexed: 2 or 4). Stored.
        SetScheme = 0x81 {
            /// Kind.
            kind: SchemeKind,
            /// deg/s.
            rate_dps: f32,
            /// Turns or positions.
            count: u8,
        },
        /// Start the table (after a stop or a fault).
        Start = 0x82 {},
        /// Stop the table (motor off).
        Stop = 0x83 {},
        /// Run the power-up calibration again.
        Recalibrate = 0x84 {},
        /// A GNSS fix for the aided filter, in the receiver's integer
        /// units, with its time of validity on the board's clock (µs).
        GnssFix = 0x85 {
            /// When the fix was valid, board µs.
            t_valid_us: u64,
            /// The fix.
            fix: GnssFix,
        },
        /// The site: latitude (1e-7 deg), height above the ellipsoid (mm).
        /// Stored; used from the next calibration (or power-up) on.
        SetSite = 0x86 {
            /// 1e-7 deg.
            lat_e7: i32,
            /// mm.
            height_mm: i32,
        },
        /// The base's attitude: roll, pitch, heading (deg). Stored.
        SetBase = 0x87 {
            /// deg.
            roll_deg: f32,
            /// deg.
            pitch_deg: f32,
            /// deg.
            heading_deg: f32,
        },
        /// Aided navigation on (1) or off (0), the origin at the site's
        /// latitude and height and this longitude (1e-7 deg). Stored; the
        /// board restarts its navigation with it.
        SetAided = 0x88 {
            /// 0 off, 1 on.
            on: u8,
            /// 1e-7 deg.
            lon_e7: i32,
        },
    }
}

impl Command {
    /// The whole frame into `out`.
    ///
    /// # Errors
    /// [`FrameError::BufferTooSmall`] (never with a `MAX_FRAME` buffer).
    pub fn to_frame(&self, seq: u16, out: &mut [u8; MAX_FRAME]) -> Result<usize, FrameError> {
        let mut p = [0u8; MAX_PAYLOAD];
        let n = self.encode(seq, &mut p)?;
        frame(p.get(..n).unwrap_or(&[]), out)
    }

    /// Its fields' bounds.
    ///
    /// # Errors
    /// The status the `Ack` carries.
    pub fn check(&self) -> Result<(), Status> {
        match *self {
            Command::SetScheme {
                kind,
                rate_dps,
                count,
            } => {
                if kind != SchemeKind::Still
                    && !(rate_dps.is_finite() && rate_dps > 0.0 && rate_dps <= 200.0)
                {
                    return Err(Status::BadRate);
                }
                let bad = match kind {
                    SchemeKind::Reciprocating => count == 0,
                    SchemeKind::Indexed => count != 2 && count != 4,
                    _ => false,
                };
                if bad {
                    return Err(Status::BadCount);
                }
                Ok(())
            }
            Command::GnssFix { fix: f, .. } => {
                if f.lat_e7.unsigned_abs() > 900_000_000
                    || f.lon_e7.unsigned_abs() > 1_800_000_000
                    || f.sigma_h_mm == 0
                    || f.sigma_v_mm == 0
                {
                    return Err(Status::BadFix);
                }
                Ok(())
            }
            Command::SetSite { lat_e7, height_mm } => {
                if lat_e7.unsigned_abs() > 900_000_000
                    || !(-1_000_000..=20_000_000).contains(&height_mm)
                {
                    return Err(Status::BadSite);
                }
                Ok(())
            }
            Command::SetBase {
                roll_deg,
                pitch_deg,
                heading_deg,
            } => {
                let within = |x: f32, m: f32| x.is_finite() && x.abs() <= m;
                if within(roll_deg, 180.0) && within(pitch_deg, 90.0) && within(heading_deg, 180.0)
                {
                    Ok(())
                } else {
                    Err(Status::BadBase)
                }
            }
            Command::SetAided { on, lon_e7 } => {
                if on > 1 || lon_e7.unsigned_abs() > 1_800_000_000 {
                    return Err(Status::BadSite);
                }
                Ok(())
            }
            Command::Start {} | Command::Stop {} | Command::Recalibrate {} => Ok(()),
        }
    }

    /// Parses and bounds-checks a payload into (sequence, command).
    ///
    /// # Errors
    /// [`FrameError::OutOfBounds`] with the status for the `Ack`, or a
    /// malformed payload.
    pub fn parse(p: &[u8]) -> Result<(u16, Self), FrameError> {
        let (seq, c) = Self::decode(p)?;
        c.check().map_err(FrameError::OutOfBounds)?;
        Ok((seq, c))
    }
}

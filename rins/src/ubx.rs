//! A u-blox receiver's UBX stream: the frames (`0xB5 0x62`, class, id,
//! length, payload, Fletcher-8 checksum) and the navigation solution
//! `UBX-NAV-PVT` (class 0x01, id 0x07, 92 bytes), which carries everything
//! a fix needs in the board's own units: latitude and longitude in 1e-7
//! deg, height above the ellipsoid in mm, NED velocity in mm/s, and the
//! receiver's accuracy estimates (horizontal, vertical, speed) in mm and
//! mm/s, with the fix's UTC epoch.
//!
//! Field offsets from u-blox's interface description (u-blox 8 / M8
//! protocol 15 onwards, unchanged in the F9 generation).

use core_nav::aided::GnssFix;

/// UBX-NAV-PVT's class and id.
const NAV_PVT: (u8, u8) = (0x01, 0x07);
/// UBX-NAV-PVT's payload length, bytes.
const NAV_PVT_LEN: usize = 92;
/// The longest payload kept (longer frames are counted and skipped).
const MAX_LEN: usize = 1024;

/// A streaming UBX frame decoder that counts what it drops.
#[derive(Debug, Default)]
pub struct Decoder {
    buf: Vec<u8>,
    /// Frames whose checksum failed.
    pub bad_checksum: u32,
    /// Frames longer than this decoder keeps.
    pub too_long: u32,
}

impl Decoder {
    /// Feeds `bytes`; returns the complete frames as (class, id, payload).
    pub fn push(&mut self, bytes: &[u8]) -> Vec<(u8, u8, Vec<u8>)> {
        self.buf.extend_from_slice(bytes);
        let mut out = vec![];
        loop {
            // Resynchronise on the two sync characters.
            match self.buf.windows(2).position(|w| w == [0xB5, 0x62]) {
                Some(0) => {}
                Some(i) => {
                    self.buf.drain(..i);
                }
                None => {
                    // Keep a trailing 0xB5: it may start the next frame.
                    let keep = usize::from(self.buf.last() == Some(&0xB5));
                    let n = self.buf.len() - keep;
                    self.buf.drain(..n);
                    return out;
                }
            }
            if self.buf.len() < 6 {
                return out;
            }
            let len = usize::from(u16::from_le_bytes([self.buf[4], self.buf[5]]));
            if len > MAX_LEN {
                self.too_long += 1;
                self.buf.drain(..2);
                continue;
            }
            if self.buf.len() < 8 + len {
                return out;
            }
            let body = &self.buf[2..6 + len];
            let (a, b) = checksum(body);
            if [a, b] == self.buf[6 + len..8 + len] {
                out.push((self.buf[2], self.buf[3], self.buf[6..6 + len].to_vec()));
                self.buf.drain(..8 + len);
            } else {
                self.bad_checksum += 1;
                self.buf.drain(..2);
            }
        }
    }
}

/// UBX's 8-bit Fletcher checksum over class, id, length and payload.
pub fn checksum(body: &[u8]) -> (u8, u8) {
    body.iter().fold((0u8, 0u8), |(a, b), x| {
        let a = a.wrapping_add(*x);
        (a, b.wrapping_add(a))
    })
}

/// A UBX-NAV-PVT solution, in the receiver's units.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NavPvt {
    /// UTC date and time of the epoch: year, month, day, hour, minute,
    /// second.
    pub utc: (u16, u8, u8, u8, u8, u8),
    /// Fraction of the second, ns (may be negative).
    pub nano: i32,
    /// `valid`: bit 0 date, bit 1 time, bit 2 fully resolved.
    pub valid: u8,
    /// 0 none, 2 2-D, 3 3-D, 4 GNSS + dead reckoning, 5 time only.
    pub fix_type: u8,
    /// `flags` bit 0: the fix is within its accuracy limits (gnssFixOK).
    pub fix_ok: bool,
    /// Satellites used.
    pub num_sv: u8,
    /// Longitude and latitude, 1e-7 deg.
    pub lon_e7: i32,
    /// Latitude, 1e-7 deg.
    pub lat_e7: i32,
    /// Height above the ellipsoid, mm.
    pub height_mm: i32,
    /// Horizontal and vertical accuracy estimates, mm.
    pub h_acc_mm: u32,
    /// Vertical accuracy estimate, mm.
    pub v_acc_mm: u32,
    /// Velocity north, east, down, mm/s.
    pub vel_ned_mmps: [i32; 3],
    /// Speed accuracy estimate, mm/s.
    pub s_acc_mmps: u32,
}

fn u32_at(p: &[u8], i: usize) -> u32 {
    u32::from_le_bytes([p[i], p[i + 1], p[i + 2], p[i + 3]])
}

fn i32_at(p: &[u8], i: usize) -> i32 {
    u32_at(p, i) as i32
}

impl NavPvt {
    /// Parses a frame: `None` unless it is a NAV-PVT of the right length.
    pub fn parse(class: u8, id: u8, p: &[u8]) -> Option<Self> {
        if (class, id) != NAV_PVT || p.len() != NAV_PVT_LEN {
            return None;
        }
        Some(Self {
            utc: (
                u16::from_le_bytes([p[4], p[5]]),
                p[6],
                p[7],
                p[8],
                p[9],
                p[10],
            ),
            valid: p[11],
            nano: i32_at(p, 16),
            fix_type: p[20],
            fix_ok: p[21] & 1 == 1,
            num_sv: p[23],
            lon_e7: i32_at(p, 24),
            lat_e7: i32_at(p, 28),
            height_mm: i32_at(p, 32),
            h_acc_mm: u32_at(p, 40),
            v_acc_mm: u32_at(p, 44),
            vel_ned_mmps: [i32_at(p, 48), i32_at(p, 52), i32_at(p, 56)],
            s_acc_mmps: u32_at(p, 68),
        })
    }

    /// The epoch as microseconds since 1970-01-01 UTC, when the receiver
    /// says its date and time are valid.
    pub fn utc_unix_us(&self) -> Option<i64> {
        if self.valid & 0b11 != 0b11 {
            return None;
        }
        let (y, mo, d, h, mi, s) = self.utc;
        let days = days_from_civil(i64::from(y), i64::from(mo), i64::from(d));
        let secs = days * 86_400 + i64::from(h) * 3_600 + i64::from(mi) * 60 + i64::from(s);
        Some(secs * 1_000_000 + i64::from(self.nano) / 1_000)
    }

    /// The fix the board takes: a 3-D solution (or GNSS with dead
    /// reckoning) within the receiver's accuracy limits, with non-zero
    /// accuracy estimates; `None` otherwise.
    pub fn fix(&self) -> Option<GnssFix> {
        let three_d = matches!(self.fix_type, 3 | 4);
        let sigmas = self.h_acc_mm > 0 && self.v_acc_mm > 0 && self.s_acc_mmps > 0;
        (three_d && self.fix_ok && sigmas).then_some(GnssFix {
            lat_e7: self.lat_e7,
            lon_e7: self.lon_e7,
            height_mm: self.height_mm,
            v_n_mmps: self.vel_ned_mmps,
            sigma_h_mm: self.h_acc_mm,
            sigma_v_mm: self.v_acc_mm,
            sigma_vel_mmps: self.s_acc_mmps,
        })
    }
}

/// Days from 1970-01-01 to a proleptic Gregorian date (Howard Hinnant's
/// `days_from_civil`).
pub fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// Test data shared by the modules' tests.
#[cfg(test)]
pub(crate) mod tests_support {
    /// A real receiver's NAV-PVT (a u-blox receiver near Manchester,
    /// 2020-10-20, as pyubx2's stream test decodes its capture), framed
    /// and checksummed by pyubx2 1.4 (`UBXMessage(...).serialize()`), an
    /// independent implementation.
    pub(crate) const REAL: &str = "b56201075c0038ba0503e4070a140e0431072600000032d2feff0301000a2826aafeacf0db1f7e4b01001a8e00004f4100006a4f000044000000e6ffffff8300000049000000d851f600730400006fa72d00c2000000000000000000000000000000bbea";

    pub(crate) fn hex(s: &str) -> Vec<u8> {
        (0..s.len())
            .step_by(2)
            .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
            .collect()
    }

    /// [`REAL`]'s bytes.
    pub(crate) fn real_nav_pvt() -> Vec<u8> {
        hex(REAL)
    }

    /// [`REAL`] with its UTC epoch moved to `unix_us` (µs since 1970),
    /// checksummed again.
    pub(crate) fn real_nav_pvt_at(unix_us: i64) -> Vec<u8> {
        let mut b = hex(REAL);
        let (secs, us) = (unix_us.div_euclid(1_000_000), unix_us.rem_euclid(1_000_000));
        let (days, sod) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
        // Howard Hinnant's civil_from_days.
        let z = days + 719_468;
        let era = z.div_euclid(146_097);
        let doe = z - era * 146_097;
        let yoe = (doe - doe / 1_460 + doe / 36_524 - doe / 146_096) / 365;
        let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
        let mp = (5 * doy + 2) / 153;
        let d = doy - (153 * mp + 2) / 5 + 1;
        let m = if mp < 10 { mp + 3 } else { mp - 9 };
        let y = yoe + era * 400 + i64::from(m <= 2);
        let p = 6;
        b[p + 4..p + 6].copy_from_slice(&(y as u16).to_le_bytes());
        b[p + 6] = m as u8;
        b[p + 7] = d as u8;
        b[p + 8] = (sod / 3_600) as u8;
        b[p + 9] = (sod / 60 % 60) as u8;
        b[p + 10] = (sod % 60) as u8;
        b[p + 16..p + 20].copy_from_slice(&((us * 1_000) as i32).to_le_bytes());
        let n = b.len();
        let (c0, c1) = super::checksum(&b[2..n - 2]);
        b[n - 2] = c0;
        b[n - 1] = c1;
        b
    }
}

#[cfg(test)]
mod tests {
    use super::tests_support::{hex, REAL};
    use super::*;

    #[test]
    fn a_real_nav_pvt_decodes_to_the_independent_decoders_values() {
        let mut d = Decoder::default();
        let frames = d.push(&hex(REAL));
        assert_eq!(frames.len(), 1);
        let (c, i, p) = &frames[0];
        let pvt = NavPvt::parse(*c, *i, p).unwrap();
        assert_eq!(pvt.lat_e7, 534_507_692);
        assert_eq!(pvt.lon_e7, -22_403_544);
        assert_eq!(pvt.height_mm, 84_862);
        assert_eq!(
            (pvt.h_acc_mm, pvt.v_acc_mm, pvt.s_acc_mmps),
            (16_719, 20_330, 1_139)
        );
        assert_eq!(pvt.vel_ned_mmps, [68, -26, 131]);
        assert_eq!((pvt.fix_type, pvt.num_sv), (3, 10));
        // 2020-10-20 14:04:49 UTC less 77,262 ns: 1603202689 s since 1970
        // (date -u -d '2020-10-20 14:04:49' +%s).
        assert_eq!(pvt.utc_unix_us(), Some(1_603_202_689_000_000 - 77));
        let fix = pvt.fix().unwrap();
        assert_eq!(fix.sigma_h_mm, 16_719);
    }

    #[test]
    fn garbage_and_a_damaged_frame_are_skipped_and_counted() {
        let good = hex(REAL);
        let mut bad = good.clone();
        bad[40] ^= 0x01;
        let mut stream = vec![0x00, 0xB5, 0x13, 0x62];
        stream.extend_from_slice(&bad);
        stream.extend_from_slice(b"$GPGGA,noise*00\r\n");
        stream.extend_from_slice(&good);
        let mut d = Decoder::default();
        // Byte by byte, as a port delivers them.
        let frames: Vec<_> = stream.iter().flat_map(|b| d.push(&[*b])).collect();
        assert_eq!(frames.len(), 1);
        assert_eq!(d.bad_checksum, 1);
    }

    #[test]
    fn an_epoch_moved_in_time_reads_back() {
        for t in [
            0i64,
            1_603_202_689_123_456,
            1_798_761_599_999_999,
            951_782_400_500_000,
        ] {
            let b = super::tests_support::real_nav_pvt_at(t);
            let (c, i, p) = Decoder::default().push(&b).remove(0);
            assert_eq!(NavPvt::parse(c, i, &p).unwrap().utc_unix_us(), Some(t));
        }
    }

    #[test]
    fn no_fix_without_a_valid_3d_solution() {
        let mut d = Decoder::default();
        let (c, i, p) = d.push(&hex(REAL)).remove(0);
        let pvt = NavPvt::parse(c, i, &p).unwrap();
        assert!(NavPvt { fix_type: 2, ..pvt }.fix().is_none());
        assert!(NavPvt {
            fix_ok: false,
            ..pvt
        }
        .fix()
        .is_none());
        assert!(NavPvt { h_acc_mm: 0, ..pvt }.fix().is_none());
        assert!(NavPvt { valid: 0b01, ..pvt }.utc_unix_us().is_none());
    }
}

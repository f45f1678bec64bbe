//! RTKLIB time-tag files (`*.tag`, "TIMETAG RTKLIB"): when the logging
//! host received each chunk of a stream. Layout (little-endian): a 60-byte
//! text header, the host tick at open (u32, ms), the open time (u32
//! seconds + f64 fraction, GPST on the Unix-epoch scale), then one
//! `(u32 ms since open, u32 bytes written through this chunk)` pair per
//! chunk.
//!
//! A logger's own clock (a sensor board's ms counter) is put on GPST
//! through these tags: each row is received at its chunk's time; the
//! delivery delay (receive time minus the row's stamp) has a floor, the
//! fastest delivery, and a line through that floor (offset and drift) maps
//! the logger's clock to the host's ([`ClockMap::fit`]).

use anyhow::{bail, Result};
use std::path::Path;

/// A parsed tag file.
#[derive(Clone, Debug, PartialEq)]
pub struct TagFile {
    /// The stream's open time, GPST seconds on the Unix-epoch scale.
    pub open_s: f64,
    /// Per chunk: (ms since open, bytes written through the chunk).
    pub chunks: Vec<(u32, u32)>,
}

const HEADER: usize = 60;
const MAGIC: &[u8] = b"TIMETAG RTKLIB";

impl TagFile {
    /// Reads `path`.
    ///
    /// # Errors
    /// Unreadable, not a tag file, a truncated pair, times or positions
    /// going backwards.
    pub fn read(path: &Path) -> Result<Self> {
        let b = std::fs::read(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        Self::parse(&b, &path.display().to_string())
    }

    /// Parses a tag file's bytes (`what` names it in errors).
    ///
    /// # Errors
    /// As [`Self::read`].
    pub fn parse(b: &[u8], what: &str) -> Result<Self> {
        if !b.starts_with(MAGIC) || b.len() < HEADER + 16 {
            bail!("{what}: not an RTKLIB time-tag file (no \"TIMETAG RTKLIB\" header)");
        }
        let u32_at = |i: usize| {
            b.get(i..i + 4)
                .and_then(|s| s.try_into().ok())
                .map(u32::from_le_bytes)
        };
        let sec = u32_at(HEADER + 4).unwrap_or(0);
        let frac = b
            .get(HEADER + 8..HEADER + 16)
            .and_then(|s| s.try_into().ok())
            .map(f64::from_le_bytes)
            .unwrap_or(f64::NAN);
        if !(0.0..1.0).contains(&frac) {
            bail!("{what}: the open time's fraction {frac} is not in [0, 1)");
        }
        let body = b.get(HEADER + 16..).unwrap_or(&[]);
        if body.len() % 8 != 0 {
            bail!(
                "{what}: {} bytes after the header: not whole (ms, position) pairs",
                body.len()
            );
        }
        let mut chunks = Vec::with_capacity(body.len() / 8);
        for (k, p) in body.chunks_exact(8).enumerate() {
            let at = HEADER + 16 + 8 * k;
            let (ms, pos) = (u32_at(at).unwrap_or(0), u32_at(at + 4).unwrap_or(0));
            if let Some(&(m0, p0)) = chunks.last() {
                if ms < m0 || pos < p0 {
                    bail!("{what}: pair {} (byte {at}) goes backwards: ({ms} ms, byte {pos}) after ({m0} ms, byte {p0})", k + 1);
                }
            }
            let _ = p;
            chunks.push((ms, pos));
        }
        Ok(Self {
            open_s: f64::from(sec) + frac,
            chunks,
        })
    }

    /// The host's receive time (GPST s) of each of the rows ending at
    /// byte `ends[i]` of the stream (the first chunk whose position
    /// reaches it).
    pub fn receive_times(&self, ends: &[u64]) -> Vec<Option<f64>> {
        let mut k = 0usize;
        ends.iter()
            .map(|&e| {
                while self.chunks.get(k).is_some_and(|c| u64::from(c.1) < e) {
                    k += 1;
                }
                self.chunks
                    .get(k)
                    .map(|c| self.open_s + f64::from(c.0) * 1e-3)
            })
            .collect()
    }

    /// The stream's length the tags account for, bytes.
    pub fn stream_len(&self) -> u64 {
        self.chunks.last().map_or(0, |c| u64::from(c.1))
    }
}

/// A logger clock put on GPST: `t = stamp + offset + drift (stamp - stamp0)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClockMap {
    /// The first stamp, logger seconds.
    pub stamp0_s: f64,
    /// GPST minus the logger's clock at `stamp0_s`, s (the delivery floor).
    pub offset_s: f64,
    /// The logger clock's rate error against the host's, dimensionless
    /// (positive: the host's clock runs fast of it).
    pub drift: f64,
    /// RMS of the floor's points about the line, s.
    pub floor_rms_s: f64,
}

/// Width of the windows whose fastest delivery makes one floor point, s.
const FLOOR_WINDOW_S: f64 = 5.0;

impl ClockMap {
    /// The line through the delivery floor: the fastest delivery of each
    /// [`FLOOR_WINDOW_S`] window of stamps, fitted by least squares, then
    /// lowered to the fastest delivery overall (no row arrives before it
    /// was stamped).
    ///
    /// # Errors
    /// Fewer than two windows with rows.
    pub fn fit(stamps_s: &[f64], received_s: &[Option<f64>]) -> Result<Self> {
        let stamp0_s = stamps_s.first().copied().unwrap_or(0.0);
        let mut floor: Vec<(f64, f64)> = vec![];
        for (s, r) in stamps_s.iter().zip(received_s) {
            let Some(r) = r else { continue };
            let (x, d) = (s - stamp0_s, r - s);
            let w = (x / FLOOR_WINDOW_S).floor();
            match floor.last_mut() {
                Some(p) if (p.0 / FLOOR_WINDOW_S).floor() == w => {
                    if d < p.1 {
                        *p = (x, d);
                    }
                }
                _ => floor.push((x, d)),
            }
        }
        if floor.len() < 2 {
            bail!("the time tags cover fewer than two {FLOOR_WINDOW_S} s windows: cannot fit the logger's clock");
        }
        let n = floor.len() as f64;
        let (mx, my) = floor
            .iter()
            .fold((0.0, 0.0), |a, p| (a.0 + p.0 / n, a.1 + p.1 / n));
        let sxx: f64 = floor.iter().map(|p| (p.0 - mx).powi(2)).sum();
        let sxy: f64 = floor.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        let drift = if sxx > 0.0 { sxy / sxx } else { 0.0 };
        let line = |x: f64| my + drift * (x - mx);
        let floor_rms_s = (floor.iter().map(|p| (p.1 - line(p.0)).powi(2)).sum::<f64>() / n).sqrt();
        let lowest = stamps_s
            .iter()
            .zip(received_s)
            .filter_map(|(s, r)| r.map(|r| (r - s) - line(s - stamp0_s)))
            .fold(f64::INFINITY, f64::min);
        Ok(Self {
            stamp0_s,
            offset_s: line(0.0) + lowest.min(0.0),
            drift,
            floor_rms_s,
        })
    }

    /// GPST (s) of a logger stamp (s).
    pub fn gpst(&self, stamp_s: f64) -> f64 {
        let x = stamp_s - self.stamp0_s;
        stamp_s + self.offset_s + self.drift * x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tag_bytes(open: (u32, f64), pairs: &[(u32, u32)]) -> Vec<u8> {
        let mut b = b"TIMETAG RTKLIB EX".to_vec();
        b.resize(HEADER, 0);
        b.extend(7u32.to_le_bytes());
        b.extend(open.0.to_le_bytes());
        b.extend(open.1.to_le_bytes());
        for (m, p) in pairs {
            b.extend(m.to_le_bytes());
            b.extend(p.to_le_bytes());
        }
        b
    }

    #[test]
    fn reads_pairs_and_finds_each_rows_chunk() {
        let t = TagFile::parse(&tag_bytes((100, 0.5), &[(10, 40), (20, 80)]), "t").unwrap();
        assert_eq!(t.open_s, 100.5);
        let r = t.receive_times(&[10, 40, 41, 80, 81]);
        assert_eq!(
            r,
            vec![Some(100.51), Some(100.51), Some(100.52), Some(100.52), None]
        );
    }

    #[test]
    fn bad_tags_are_refused() {
        assert!(TagFile::parse(b"nope", "t").is_err());
        let mut b = tag_bytes((1, 0.0), &[(10, 40)]);
        b.push(0);
        assert!(TagFile::parse(&b, "t")
            .unwrap_err()
            .to_string()
            .contains("pairs"));
        let back = tag_bytes((1, 0.0), &[(10, 40), (5, 50)]);
        assert!(TagFile::parse(&back, "t")
            .unwrap_err()
            .to_string()
            .contains("backwards"));
    }

    #[test]
    fn the_floor_recovers_a_known_offset_and_drift() {
        // A logger 3.2 s behind the host, its clock 20 ppm slow; deliveries
        // 12 ms to 60 ms late (a deterministic spread), the fastest in each
        // window 12 ms.
        let stamps: Vec<f64> = (0..6000).map(|k| 1000.0 + k as f64 * 0.01).collect();
        let recv: Vec<Option<f64>> = stamps
            .iter()
            .enumerate()
            .map(|(k, s)| {
                Some(
                    s + 3.2
                        + 20e-6 * (s - 1000.0)
                        + 0.012
                        + 0.048 * ((k * 37 % 100) as f64 / 100.0),
                )
            })
            .collect();
        let m = ClockMap::fit(&stamps, &recv).unwrap();
        // The floor points are exact: only rounding separates the fit.
        assert!((m.drift - 20e-6).abs() < 1e-9, "{}", m.drift);
        assert!((m.gpst(1030.0) - (1030.0 + 3.2 + 20e-6 * 30.0 + 0.012)).abs() < 1e-6);
    }
}

//! Real sensor noise as a background: a static recording of a real IMU
//! whose deviations from their mean are added, sample for sample, to a
//! simulated run's samples. The simulator then supplies the table motion
//! and the deterministic errors, the real sensor everything it does when
//! nobody models it (white and coloured noise, drift, quantisation, thermal
//! wander). What diagnose sees on such a run is noise it did not assume.
//!
//! The one recording long enough for 600 s runs is the ADIS16405 bench
//! recording (10,000 s at 100 Hz; CC BY-NC-SA, read from where it lies,
//! never copied). The Xsens and Ferraris sessions' still stretches (52 s
//! and a few seconds) are too short for a whole run and are not used.

use recording::Recording;
use std::fmt;
use std::path::Path;

/// Standard gravity, m/s^2 (the ADIS16405 recording is in g).
const G0: f64 = 9.806_65;

/// A real static recording: per-sample gyro (rad/s) and accel (m/s^2) in
/// the sensor's axes, at `rate_hz`.
#[derive(Clone, Debug)]
pub struct RealNoise {
    /// Where it came from.
    pub name: String,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Samples: gyro x-z (rad/s), accel x-z (m/s^2).
    pub samples: Vec<[f64; 6]>,
}

/// Which window of the recording, with which axes, a run gets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Draw {
    /// First sample.
    pub start: usize,
    /// Axis permutation (0-5; the same for gyro and accel).
    pub perm: usize,
    /// Sign flips per axis (bit i flips axis i).
    pub signs: u8,
}

/// A real recording that cannot serve as a background, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct RealNoiseError(pub String);

impl fmt::Display for RealNoiseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for RealNoiseError {}

type Result<T> = std::result::Result<T, RealNoiseError>;

/// `Err(RealNoiseError(format!(...)))`.
macro_rules! bail {
    ($($arg:tt)*) => { return Err(RealNoiseError(format!($($arg)*))) };
}

const PERMS: [[usize; 3]; 6] = [
    [0, 1, 2],
    [1, 2, 0],
    [2, 0, 1],
    [0, 2, 1],
    [2, 1, 0],
    [1, 0, 2],
];

impl RealNoise {
    /// The ADIS16405 bench recording (`adis_16405_imu1_f32le_1000000x6.bin`:
    /// little-endian f32, rows of gx gy gz (deg/s) ax ay az (g), 100 Hz).
    ///
    /// # Errors
    /// The file cannot be read or is not whole rows of six f32.
    pub fn adis16405(path: &Path) -> Result<Self> {
        let raw = std::fs::read(path)
            .map_err(|e| RealNoiseError(format!("reading {}: {e}", path.display())))?;
        if raw.len() % 24 != 0 || raw.is_empty() {
            bail!(
                "{}: {} bytes is not whole rows of six little-endian f32",
                path.display(),
                raw.len()
            );
        }
        let d2r = core::f64::consts::PI / 180.0;
        let samples = raw
            .chunks_exact(24)
            .map(|row| {
                let mut v = [0.0; 6];
                for (c, (x, b)) in v.iter_mut().zip(row.chunks_exact(4)).enumerate() {
                    let f = f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]]));
                    *x = if c < 3 { f * d2r } else { f * G0 };
                }
                v
            })
            .collect::<Vec<_>>();
        if let Some(i) = samples
            .iter()
            .position(|s| s.iter().any(|x| !x.is_finite()))
        {
            bail!("{}: row {i} is not finite", path.display());
        }
        Ok(Self {
            name: "ADIS16405 bench (real)".into(),
            rate_hz: 100.0,
            samples,
        })
    }

    /// The draw for `seed` of a run `n` samples long: a window start spread
    /// over the recording (golden-ratio steps), an axis permutation and sign
    /// flips. Windows overlap once there are more draws than the recording
    /// holds whole windows (16 of 600 s in the ADIS hour x 2.8): the nulls
    /// are then not independent in their drift, only in its axes and signs.
    pub fn draw(&self, seed: u64, n: usize) -> Draw {
        let span = self.samples.len().saturating_sub(n).max(1) as f64;
        let phi = 0.618_033_988_749_894_9;
        let start = ((seed as f64 * phi).fract() * span) as usize;
        Draw {
            start,
            perm: (seed % 6) as usize,
            signs: ((seed / 6) % 8) as u8,
        }
    }

    /// Adds the draw's window, its mean removed per channel, to `rec`'s
    /// IMU samples (one recording sample to one IMU row: the rates must
    /// match) and drops the temperature column (the real sensor's is not
    /// known, and its thermal drift is in the samples).
    ///
    /// # Errors
    /// Different sample rates or a window past the recording's end.
    pub fn add_to(&self, rec: &mut Recording, d: Draw) -> Result<()> {
        if (rec.meta.imu_rate_hz - self.rate_hz).abs() > 1e-9 {
            bail!(
                "the run samples at {} Hz, the real noise at {} Hz",
                rec.meta.imu_rate_hz,
                self.rate_hz
            );
        }
        let n = rec.imu.len();
        let Some(win) = self.samples.get(d.start..d.start + n) else {
            bail!(
                "a {n}-sample run from sample {} passes the end of {} ({} samples)",
                d.start,
                self.name,
                self.samples.len()
            );
        };
        let mut mean = [0.0; 6];
        for s in win {
            for (m, x) in mean.iter_mut().zip(s) {
                *m += x / n as f64;
            }
        }
        let p = PERMS[d.perm % 6];
        for (row, s) in rec.imu.iter_mut().zip(win) {
            for (i, &src) in p.iter().enumerate() {
                let sign = if d.signs >> i & 1 == 1 { -1.0 } else { 1.0 };
                row.gyro_radps[i] += sign * (s[src] - mean[src]);
                row.accel_mps2[i] += sign * (s[3 + src] - mean[3 + src]);
            }
            row.temp_c = None;
        }
        rec.meta.description = Some(format!(
            "{} + real noise: {} from sample {}, axes {:?}, signs {:03b}",
            rec.meta.description.as_deref().unwrap_or("simulated run"),
            self.name,
            d.start,
            p,
            d.signs
        ));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use recording::{ImuRow, Meta};

    fn run(n: usize) -> Recording {
        Recording {
            gyro_only: false,
            moving: None,
            meta: Meta::default(),
            imu: (0..n)
                .map(|k| ImuRow {
                    t_s: k as f64 / 100.0,
                    gyro_radps: [1.0, 2.0, 3.0],
                    accel_mps2: [0.0, 0.0, -9.8],
                    temp_c: Some(25.0),
                })
                .collect(),
            table: vec![],
        }
    }

    fn noise(n: usize) -> RealNoise {
        // Channel c of sample k: c + 10 k (a ramp, distinct per channel).
        RealNoise {
            name: "ramp".into(),
            rate_hz: 100.0,
            samples: (0..n)
                .map(|k| std::array::from_fn(|c| c as f64 + 10.0 * k as f64))
                .collect(),
        }
    }

    #[test]
    fn the_window_is_added_mean_free_with_its_axes_permuted_and_signed() {
        let mut rec = run(5);
        let nz = noise(20);
        let d = Draw {
            start: 3,
            perm: 1, // axes (y, z, x) of the recording
            signs: 0b001,
        };
        nz.add_to(&mut rec, d).unwrap();
        // Window samples 3..8; its mean removed leaves 10 (k - 5) on every
        // channel, x flipped.
        for (k, row) in rec.imu.iter().enumerate() {
            let dev = 10.0 * (k as f64 - 2.0);
            assert!((row.gyro_radps[0] - (1.0 - dev)).abs() < 1e-12);
            assert!((row.gyro_radps[1] - (2.0 + dev)).abs() < 1e-12);
            assert!((row.accel_mps2[2] - (-9.8 + dev)).abs() < 1e-12);
            assert_eq!(row.temp_c, None);
        }
    }

    #[test]
    fn a_short_recording_or_another_rate_is_an_error() {
        let nz = noise(10);
        let mut rec = run(8);
        let d = Draw {
            start: 5,
            perm: 0,
            signs: 0,
        };
        assert!(nz.add_to(&mut rec, d).is_err());
        rec.meta.imu_rate_hz = 200.0;
        assert!(nz.add_to(&mut run(2).clone(), d).is_ok());
        assert!(nz.add_to(&mut rec, Draw { start: 0, ..d }).is_err());
    }

    #[test]
    fn draws_spread_over_the_recording_and_stay_inside() {
        let nz = noise(1_000);
        let starts: Vec<usize> = (0..100).map(|s| nz.draw(s, 600).start).collect();
        assert!(starts.iter().all(|s| s + 600 <= 1_000));
        let (lo, hi) = (
            starts.iter().min().copied().unwrap_or(0),
            starts.iter().max().copied().unwrap_or(0),
        );
        assert!(lo < 40 && hi > 360, "{lo}..{hi}");
        let perms: std::collections::BTreeSet<_> = (0..100)
            .map(|s| (nz.draw(s, 600).perm, nz.draw(s, 600).signs))
            .collect();
        assert_eq!(perms.len(), 48);
    }
}

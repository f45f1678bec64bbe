//! The turntable: its axis, the table angle carried without losing precision
//! over many turns, interpolation of the 50 Hz encoder to the IMU time
//! stamps, and the base attitude `c_b_n = c_s_n c_b_s(theta)`.
//!
//! Frames (recording-v1): the table turns `s` relative to `b` about `k`
//! (the same unit vector in `b` and `s`), `c_s_b = exp(theta [k x])`.

use crate::error::NavError;
use crate::real::{sin_cos, wrap_pi, Real};
use nalgebra::{Quaternion, Vector3};

/// The table axis: the sensor axis it nominally coincides with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Axis {
    /// Sensor x.
    X,
    /// Sensor y.
    Y,
    /// Sensor z (the paper's scheme).
    #[default]
    Z,
}

impl Axis {
    /// The unit vector `k` (same in `b` and `s`).
    pub fn unit<T: Real>(self) -> Vector3<T> {
        match self {
            Axis::X => Vector3::x(),
            Axis::Y => Vector3::y(),
            Axis::Z => Vector3::z(),
        }
    }
}

/// Below this table rate (rad/s) the table counts as still: 0.05 deg/s, a
/// tenth of an encoder count per second at 16,384 counts per turn over a
/// 10 s stretch, and 50x below the slowest rotation scheme (2.5 deg/s). The
/// one "is the table still" threshold: calibration's phase finder,
/// diagnose's motion classes and the firmware's static phase use it.
pub const STILL_RATE_RADPS: f64 = 0.05 * core::f64::consts::PI / 180.0;

/// Is a table rate (rad/s) still?
pub fn is_still(rate_radps: f64) -> bool {
    rate_radps.abs() < STILL_RATE_RADPS
}

/// An incremental encoder's scale: counts per revolution (lines x 4). The
/// one home of counts <-> radians.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EncoderScale {
    /// Counts per revolution.
    pub counts_per_rev: u32,
}

impl EncoderScale {
    /// A scale of `counts_per_rev` counts per turn (0 is taken as 1).
    pub fn new(counts_per_rev: u32) -> Self {
        Self {
            counts_per_rev: counts_per_rev.max(1),
        }
    }

    /// Radians per count.
    pub fn rad_per_count(&self) -> f64 {
        core::f64::consts::TAU / f64::from(self.counts_per_rev)
    }

    /// One read's 1-sigma quantisation error, rad (`q / sqrt(12)`).
    pub fn read_sigma_rad(&self) -> f64 {
        self.rad_per_count() / libm::sqrt(12.0)
    }

    /// An unwrapped count as an angle, rad (f64: exact to 2^53 counts).
    pub fn to_rad(&self, counts: i64) -> f64 {
        counts as f64 * core::f64::consts::TAU / f64::from(self.counts_per_rev)
    }

    /// A count difference over `dt_s` seconds as a rate, rad/s.
    pub fn rate(&self, d_counts: f64, dt_s: f64) -> f64 {
        d_counts / f64::from(self.counts_per_rev) * core::f64::consts::TAU / dt_s
    }

    /// The count an encoder shows for an angle `rad` (floor: the
    /// quantisation error is in `[0, 1)` count).
    pub fn count_floor(&self, rad: f64) -> i64 {
        libm::floor(rad * f64::from(self.counts_per_rev) / core::f64::consts::TAU) as i64
    }

    /// The nearest count to an angle `rad` (an angle that came from a count).
    pub fn count_nearest(&self, rad: f64) -> i64 {
        libm::round(rad / core::f64::consts::TAU * f64::from(self.counts_per_rev)) as i64
    }

    /// The 16-bit hardware counter (a wrapping quadrature count) for an
    /// unwrapped count.
    pub fn hw_count(counts: i64) -> u16 {
        counts.rem_euclid(65_536) as u16
    }
}

/// `q_s_b = exp(theta k / 2)` for a table angle `theta` (rad, any size: it
/// is wrapped first).
pub fn q_s_b<T: Real>(axis: Axis, theta: T) -> Quaternion<T> {
    let (s, c) = sin_cos(wrap_pi(theta) * T::lit(0.5));
    let k = axis.unit::<T>() * s;
    Quaternion::new(c, k.x, k.y, k.z)
}

/// Base attitude `q_b_n = q_s_n ⊗ q_b_s(theta)` from the sensor attitude and
/// the table angle (rad).
pub fn q_b_n<T: Real>(q_s_n: &Quaternion<T>, axis: Axis, theta: T) -> Quaternion<T> {
    q_s_n * q_s_b(axis, theta).conjugate()
}

/// A table angle as whole turns plus the angle within the turn, so an f32
/// keeps sub-arcsecond resolution after thousands of revolutions (an f32
/// holding 500 rad is 6e-5 rad = 12 arcsec coarse).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct TableAngle<T: Real> {
    /// Whole turns.
    pub turns: i64,
    /// Angle within the turn, rad, in `[0, 2 pi)`.
    pub rad: T,
}

impl<T: Real> TableAngle<T> {
    /// From an unwrapped angle in rad (recording files, host side, f64).
    pub fn from_rad_f64(angle_rad: f64) -> Self {
        let tau = core::f64::consts::TAU;
        let turns = libm::floor(angle_rad / tau);
        let mut rad = angle_rad - turns * tau;
        let mut turns = turns as i64;
        if rad >= tau {
            rad -= tau;
            turns += 1;
        }
        Self {
            turns,
            rad: T::lit(rad),
        }
    }

    /// From an unwrapped encoder count and the counts per revolution (exact
    /// integer reduction: the firmware path).
    pub fn from_counts(counts: i64, counts_per_rev: u32) -> Self {
        let cpr = i64::from(counts_per_rev.max(1));
        let turns = counts.div_euclid(cpr);
        let rem = counts.rem_euclid(cpr);
        // rem < 2^31, exact in f64; the product rounds once into T.
        let rad = T::lit(rem as f64 * (core::f64::consts::TAU / cpr as f64));
        Self { turns, rad }
    }

    /// `self - earlier`, rad (small differences are exact to T's precision).
    pub fn minus(&self, earlier: &Self) -> T {
        let dturns = self.turns.saturating_sub(earlier.turns);
        T::lit(dturns as f64) * T::two_pi() + (self.rad - earlier.rad)
    }

    /// `self + d` for an angle `d` (rad) of at most a few turns.
    pub fn plus(&self, d: T) -> Self {
        let two_pi = T::two_pi();
        let rad = self.rad + d;
        if !rad.is_finite() {
            return *self;
        }
        let k = (rad / two_pi).floor();
        let mut rad = rad - k * two_pi;
        let mut turns = self.turns.saturating_add(k.to_f64() as i64);
        // Rounding can leave rad at exactly 2 pi or a hair below 0.
        if rad >= two_pi {
            rad -= two_pi;
            turns = turns.saturating_add(1);
        } else if rad < T::zero() {
            rad += two_pi;
            turns = turns.saturating_sub(1);
        }
        Self { turns, rad }
    }

    /// The whole angle in `T`, rad (coarse after many turns in f32: for
    /// scheme references and rate checks, never for navigation).
    pub fn to_rad(&self) -> T {
        self.rad + T::two_pi() * T::lit(self.turns as f64)
    }

    /// The whole angle as f64 rad (host output).
    pub fn to_rad_f64(&self) -> f64 {
        self.turns as f64 * core::f64::consts::TAU + self.rad.to_f64()
    }
}

/// Interpolates the encoder (e.g. 50 Hz) to IMU time stamps (e.g. 100 Hz):
/// linear between the two latest encoder samples, linear extrapolation up to
/// `max_extrapolation_us` past the latest one (the MCU cannot wait for the
/// next encoder read; a constant-rate table is then still exact).
#[derive(Clone, Copy, Debug)]
pub struct EncoderInterpolator<T: Real> {
    prev: Option<(u64, TableAngle<T>)>,
    last: Option<(u64, TableAngle<T>)>,
    /// How far past the latest encoder sample the angle may be extrapolated, µs.
    pub max_extrapolation_us: u64,
}

impl<T: Real> EncoderInterpolator<T> {
    /// An empty interpolator.
    pub fn new(max_extrapolation_us: u64) -> Self {
        Self {
            prev: None,
            last: None,
            max_extrapolation_us,
        }
    }

    /// Adds an encoder sample at `t_us`. A sample that is not after the
    /// latest one is refused.
    ///
    /// # Errors
    /// [`NavError::TimeNotIncreasing`].
    pub fn push(&mut self, t_us: u64, angle: TableAngle<T>) -> Result<(), NavError> {
        if let Some((t_last, _)) = self.last {
            if t_us <= t_last {
                return Err(NavError::TimeNotIncreasing {
                    prev_us: t_last,
                    t_us,
                });
            }
        }
        self.prev = self.last;
        self.last = Some((t_us, angle));
        Ok(())
    }

    /// The latest encoder sample.
    pub fn latest(&self) -> Option<(u64, TableAngle<T>)> {
        self.last
    }

    /// The table rate between the two latest encoder samples, rad/s
    /// (`None` before two samples).
    pub fn rate(&self) -> Option<T> {
        let ((t0, a0), (t1, a1)) = (self.prev?, self.last?);
        let dt = T::lit(t1.saturating_sub(t0) as f64 * 1e-6);
        Some(a1.minus(&a0) / dt)
    }

    /// The table angle at `t_us`.
    ///
    /// # Errors
    /// [`NavError::NoEncoderData`] with no sample yet, or when `t_us` is more
    /// than `max_extrapolation_us` outside the samples.
    pub fn angle_at(&self, t_us: u64) -> Result<TableAngle<T>, NavError> {
        let (t1, a1) = self.last.ok_or(NavError::NoEncoderData)?;
        let Some((t0, a0)) = self.prev else {
            return if t_us.abs_diff(t1) <= self.max_extrapolation_us {
                Ok(a1)
            } else {
                Err(NavError::NoEncoderData)
            };
        };
        if t_us.saturating_add(self.max_extrapolation_us) < t0
            || t_us > t1.saturating_add(self.max_extrapolation_us)
        {
            return Err(NavError::NoEncoderData);
        }
        // Signed offset from t0 in µs, as T (differences are small).
        let num = T::lit(t_us as f64 - t0 as f64);
        let den = T::lit((t1 - t0) as f64);
        Ok(a0.plus(a1.minus(&a0) * (num / den)))
    }
}

/// The table encoder's hardware counter (embedded-hal 1.0 has no encoder
/// trait): a 16-bit quadrature count that wraps.
pub trait QuadratureCounter {
    /// What a read can fail with.
    type Error: core::fmt::Debug;
    /// The raw counter value.
    ///
    /// # Errors
    /// The implementation's read error.
    fn read_count(&mut self) -> Result<u16, Self::Error>;
}

/// Turns a wrapping 16-bit hardware encoder counter into an unwrapped
/// count. Correct while the table moves less than half the counter range
/// (32,768 counts: two turns at 16,384 counts/rev) between reads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CounterUnwrapper {
    last: Option<u16>,
    total: i64,
}

impl CounterUnwrapper {
    /// A fresh unwrapper: the first read defines count 0 + that read.
    pub fn new() -> Self {
        Self::default()
    }

    /// The signed count change from hardware read `prev` to `raw` (the
    /// shorter way round the 16-bit counter).
    pub fn delta(prev: u16, raw: u16) -> i64 {
        i64::from(raw.wrapping_sub(prev) as i16)
    }

    /// Takes a hardware read and returns the unwrapped count.
    pub fn update(&mut self, raw: u16) -> i64 {
        match self.last {
            None => self.total = i64::from(raw),
            Some(prev) => self.total += Self::delta(prev, raw),
        }
        self.last = Some(raw);
        self.total
    }

    /// The change the last read made, counts (for glitch checks).
    pub fn total(&self) -> i64 {
        self.total
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unwrapper_follows_many_turns_both_ways() {
        let mut u = CounterUnwrapper::new();
        let mut truth: i64 = 0;
        // 100 turns forward, 100 back, in steps of 1,000 counts.
        for k in 0..3_300_i64 {
            truth += if k < 1_650 { 1_000 } else { -1_000 };
            assert_eq!(u.update(truth.rem_euclid(65_536) as u16), truth);
        }
    }

    #[test]
    fn counts_and_rad_agree() {
        let cpr = 16_384;
        for counts in [-100_000_i64, -1, 0, 1, 16_383, 16_384, 1_000_003] {
            let a = TableAngle::<f64>::from_counts(counts, cpr);
            let want = counts as f64 * core::f64::consts::TAU / f64::from(cpr);
            assert!((a.to_rad_f64() - want).abs() < 1e-9);
            let b = TableAngle::<f64>::from_rad_f64(want);
            assert!((b.minus(&a)).abs() < 1e-9);
        }
    }

    #[test]
    fn interpolation_is_exact_at_constant_rate_across_wraps() {
        let rate = 1.745_329_251_994_329_5_f64; // 100 deg/s
        let mut it = EncoderInterpolator::<f32>::new(20_000);
        for j in 0..2_000_u64 {
            let t = j * 20_000;
            it.push(t, TableAngle::from_rad_f64(rate * t as f64 * 1e-6))
                .unwrap();
            if j == 0 {
                // One sample: no rate yet, the angle is held.
                assert_eq!(it.angle_at(t + 5_000).unwrap().rad, 0.0);
                continue;
            }
            for dt in [0_u64, 10_000, 20_000] {
                let a = it.angle_at(t + dt).unwrap();
                let want = rate * (t + dt) as f64 * 1e-6;
                let err = wrap_pi(a.to_rad_f64() - want);
                // f32 angle within the turn: ulp(2 pi) / 2 = 2.4e-7 rad, plus
                // the rounding of the interpolation product.
                assert!(err.abs() < 1e-6, "t={t} dt={dt} err={err}");
            }
        }
        assert!(it.angle_at(100 * 20_000_000).is_err());
    }
}

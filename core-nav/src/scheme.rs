//! Rotation schemes: table reference generators (angle, rate, acceleration;
//! rate- and acceleration-limited) for continuous rotation, reciprocating
//! rotation (forward / back a whole number of turns) and 2- / 4-position
//! indexing with dwell.
//!
//! The reference is a pure function of time (µs since the scheme started), so
//! the MCU, the simulator and offline processing agree. It is computed in
//! `f64`: a continuous scheme passes thousands of radians and an f32 angle
//! would be coarse (6e-5 rad at 500 rad); at 100 Hz the ~40 soft-float
//! operations per call cost the M4F about 10 µs.

use crate::error::NavError;

/// Rate and acceleration limits of the table, rad/s and rad/s^2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Largest |rate|, rad/s.
    pub max_rate: f64,
    /// Largest |acceleration|, rad/s^2.
    pub max_accel: f64,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_rate: 200f64.to_radians(),
            max_accel: 100f64.to_radians(),
        }
    }
}

/// A rotation scheme.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scheme {
    /// Hold still.
    Still,
    /// Turn one way at `rate` rad/s (signed), after a ramp at the limit.
    Continuous {
        /// Rate, rad/s.
        rate: f64,
    },
    /// `turns` whole turns forward at `rate`, then back, repeated: the
    /// symmetric scale-factor error cancels over a cycle.
    Reciprocating {
        /// Cruise rate, rad/s (> 0).
        rate: f64,
        /// Whole turns each way (>= 1).
        turns: u32,
    },
    /// Indexing between 2 (0, 180 deg) or 4 (0, 180, 90, 270 deg)
    /// positions, dwelling `dwell_s` at each, moving at `rate`.
    Indexed {
        /// Move rate, rad/s (> 0).
        rate: f64,
        /// 2 or 4.
        positions: u8,
        /// Dwell at each position, s.
        dwell_s: f64,
    },
    /// Multi-rate: `turns` whole turns at each of the first `count`
    /// signed `rates` (rad/s) in turn, from rest to rest, dwelling
    /// `dwell_s` after each: the phases a multi-rate calibration solves
    /// the rate-squared term and (both signs) the asymmetry from.
    Rates {
        /// Signed rates, rad/s (the first `count` used).
        rates: [f64; MAX_RATES],
        /// How many rates (1 ..= [`MAX_RATES`]).
        count: u8,
        /// Whole turns at each rate (>= 1).
        turns: u32,
        /// Dwell after each, s.
        dwell_s: f64,
    },
}

/// Most rates in a [`Scheme::Rates`].
pub const MAX_RATES: usize = 4;

impl Scheme {
    /// The largest rate the scheme commands, rad/s (unsigned; 0 still).
    pub fn peak_rate(&self) -> f64 {
        match *self {
            Scheme::Still => 0.0,
            Scheme::Continuous { rate }
            | Scheme::Reciprocating { rate, .. }
            | Scheme::Indexed { rate, .. } => libm::fabs(rate),
            Scheme::Rates { rates, count, .. } => rates
                .iter()
                .take(usize::from(count))
                .fold(0.0, |m, r| m.max(libm::fabs(*r))),
        }
    }
}

/// The table reference at one time.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Reference {
    /// Angle from the scheme's start, rad, unwrapped.
    pub angle: f64,
    /// Rate, rad/s.
    pub rate: f64,
    /// Acceleration, rad/s^2.
    pub accel: f64,
}

/// One piece of the profile: a dwell or a trapezoidal move.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
struct Segment {
    /// Duration, s.
    duration: f64,
    /// Signed distance, rad (0 for a dwell).
    dist: f64,
    /// Ramp time and cruise time of the move, s.
    t_ramp: f64,
    t_cruise: f64,
    /// Peak rate (unsigned) and acceleration (unsigned).
    v: f64,
    a: f64,
}

impl Segment {
    fn dwell(duration: f64) -> Self {
        Self {
            duration,
            ..Self::default()
        }
    }

    /// A rest-to-rest trapezoidal (or triangular) move of `dist` rad.
    fn mv(dist: f64, vmax: f64, amax: f64) -> Self {
        let d = dist.abs();
        let (t_ramp, t_cruise, v) = if d >= vmax * vmax / amax {
            (vmax / amax, (d - vmax * vmax / amax) / vmax, vmax)
        } else {
            let t = libm::sqrt(d / amax);
            (t, 0.0, amax * t)
        };
        Self {
            duration: 2.0 * t_ramp + t_cruise,
            dist,
            t_ramp,
            t_cruise,
            v,
            a: amax,
        }
    }

    /// Reference `tau` s into the segment, angle relative to its start.
    fn at(&self, tau: f64) -> Reference {
        if self.dist == 0.0 {
            return Reference::default();
        }
        let sgn = self.dist.signum();
        let (a, v, tr, tc) = (self.a, self.v, self.t_ramp, self.t_cruise);
        // Not `clamp`: it panics when its bounds are out of order or NaN,
        // and that panic's message (formatting two f64) costs the firmware
        // ~12 KiB of float formatting. `max` then `min` never panics.
        let tau = tau.max(0.0).min(self.duration);
        let (angle, rate, accel) = if tau < tr {
            (0.5 * a * tau * tau, a * tau, a)
        } else if tau < tr + tc {
            (0.5 * a * tr * tr + v * (tau - tr), v, 0.0)
        } else {
            let td = self.duration - tau; // time left
            (self.dist.abs() - 0.5 * a * td * td, a * td, -a)
        };
        Reference {
            angle: sgn * angle,
            rate: sgn * rate,
            accel: sgn * accel,
        }
    }
}

/// Most segments in one period of a scheme.
const MAX_SEGMENTS: usize = 8;

/// A scheme made ready to evaluate: its segments over one period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile {
    scheme: Scheme,
    limits: Limits,
    segments: [Segment; MAX_SEGMENTS],
    count: usize,
    period_s: f64,
    /// Net angle of one period, rad (a whole number of turns).
    net_rad: f64,
}

impl Profile {
    /// Prepares `scheme` under `limits`.
    ///
    /// # Errors
    /// [`NavError::BadScheme`] for a rate of zero or above the limit, zero
    /// turns, a position count other than 2 or 4, a rate count other than
    /// 1 ..= [`MAX_RATES`], or a negative dwell.
    pub fn new(scheme: Scheme, limits: Limits) -> Result<Self, NavError> {
        let ok_rate = |r: f64| r.is_finite() && r.abs() > 0.0 && r.abs() <= limits.max_rate;
        if !(limits.max_rate > 0.0 && limits.max_accel > 0.0) {
            return Err(NavError::BadScheme);
        }
        let mut p = Self {
            scheme,
            limits,
            segments: [Segment::default(); MAX_SEGMENTS],
            count: 0,
            period_s: 0.0,
            net_rad: 0.0,
        };
        let tau = core::f64::consts::TAU;
        match scheme {
            Scheme::Still => {}
            Scheme::Continuous { rate } => {
                if !ok_rate(rate) {
                    return Err(NavError::BadScheme);
                }
            }
            Scheme::Reciprocating { rate, turns } => {
                if !ok_rate(rate) || turns == 0 {
                    return Err(NavError::BadScheme);
                }
                let d = f64::from(turns) * tau;
                p.push(Segment::mv(d, rate.abs(), limits.max_accel));
                p.push(Segment::mv(-d, rate.abs(), limits.max_accel));
            }
            Scheme::Indexed {
                rate,
                positions,
                dwell_s,
            } => {
                if !(ok_rate(rate) && dwell_s >= 0.0 && dwell_s.is_finite()) {
                    return Err(NavError::BadScheme);
                }
                let stops: &[f64] = match positions {
                    2 => &[0.0, 180.0],
                    4 => &[0.0, 180.0, 90.0, 270.0],
                    _ => return Err(NavError::BadScheme),
                };
                for (i, a) in stops.iter().enumerate() {
                    let next = stops.get(i + 1).copied().unwrap_or(0.0);
                    p.push(Segment::dwell(dwell_s));
                    p.push(Segment::mv(
                        (next - a).to_radians(),
                        rate.abs(),
                        limits.max_accel,
                    ));
                }
            }
            Scheme::Rates {
                rates,
                count,
                turns,
                dwell_s,
            } => {
                let n = usize::from(count);
                let used = rates.get(..n).unwrap_or(&[]);
                let ok = (1..=MAX_RATES).contains(&n)
                    && turns > 0
                    && dwell_s >= 0.0
                    && dwell_s.is_finite()
                    && used.iter().all(|r| ok_rate(*r));
                if !ok {
                    return Err(NavError::BadScheme);
                }
                for r in used {
                    let d = f64::from(turns) * tau * r.signum();
                    p.push(Segment::mv(d, libm::fabs(*r), limits.max_accel));
                    p.push(Segment::dwell(dwell_s));
                }
            }
        }
        p.period_s = p.segments.iter().take(p.count).map(|s| s.duration).sum();
        p.net_rad = p.segments.iter().take(p.count).map(|s| s.dist).sum();
        Ok(p)
    }

    fn push(&mut self, s: Segment) {
        if let Some(slot) = self.segments.get_mut(self.count) {
            *slot = s;
            self.count += 1;
        }
    }

    /// The scheme.
    pub fn scheme(&self) -> Scheme {
        self.scheme
    }

    /// Length of one period, s (0 for still and continuous).
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// The reference `t_s` seconds after the scheme started (before: still).
    pub fn at(&self, t_s: f64) -> Reference {
        // Before the start (or NaN): still.
        if t_s.partial_cmp(&0.0) != Some(core::cmp::Ordering::Greater) {
            return Reference::default();
        }
        match self.scheme {
            Scheme::Still => Reference::default(),
            Scheme::Continuous { rate } => {
                let a = self.limits.max_accel * rate.signum();
                let t_r = rate / a;
                if t_s < t_r {
                    Reference {
                        angle: 0.5 * a * t_s * t_s,
                        rate: a * t_s,
                        accel: a,
                    }
                } else {
                    Reference {
                        angle: 0.5 * rate * t_r + rate * (t_s - t_r),
                        rate,
                        accel: 0.0,
                    }
                }
            }
            _ => {
                // Each period adds its net angle (0 but for multi-rate's
                // whole turns).
                let periods = libm::floor(t_s / self.period_s);
                let mut tau = t_s - periods * self.period_s;
                let mut angle0 = periods * self.net_rad;
                for s in self.segments.iter().take(self.count) {
                    if tau < s.duration {
                        let r = s.at(tau);
                        return Reference {
                            angle: angle0 + r.angle,
                            ..r
                        };
                    }
                    tau -= s.duration;
                    angle0 += s.dist;
                }
                Reference {
                    angle: angle0,
                    ..Reference::default()
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference is consistent: angle is the integral of rate, rate of
    /// accel (checked by finite differences), and limits hold.
    fn check(p: &Profile, t_end: f64) {
        let dt = 1e-4;
        let lim = Limits::default();
        let mut t = dt;
        while t < t_end {
            let (a, b) = (p.at(t - dt), p.at(t + dt));
            let r = p.at(t);
            assert!(r.rate.abs() <= lim.max_rate + 1e-12);
            assert!(r.accel.abs() <= lim.max_accel + 1e-12);
            // Central differences: O(dt^2 * jerk) away from the kinks,
            // O(dt * accel) at a kink.
            assert!(((b.angle - a.angle) / (2.0 * dt) - r.rate).abs() < 2.0 * dt * lim.max_accel);
            t += 0.0137;
        }
    }

    #[test]
    fn multi_rate_turns_whole_turns_at_each_rate_and_its_angle_is_continuous() {
        let lim = Limits::default();
        let d = 1f64.to_radians();
        let scheme = Scheme::Rates {
            rates: [30.0 * d, 60.0 * d, -90.0 * d, 0.0],
            count: 3,
            turns: 2,
            dwell_s: 5.0,
        };
        let p = Profile::new(scheme, lim).unwrap();
        assert!((scheme.peak_rate() - 90.0 * d).abs() < 1e-15);
        // Over two periods: the angle is the rate's integral across the
        // period's end too (the net turn carried on).
        check(&p, 2.0 * p.period_s() + 1.0);
        // Each move's cruise at its rate, and the angle after the moves:
        // 2 + 2 - 2 turns a period.
        let mut seen = [false; 3];
        let mut t = 0.0;
        while t < p.period_s() {
            let r = p.at(t).rate;
            for (s, want) in seen.iter_mut().zip([30.0, 60.0, -90.0]) {
                *s |= (r - want * d).abs() < 1e-12;
            }
            t += 0.01;
        }
        assert_eq!(seen, [true; 3]);
        let turn = core::f64::consts::TAU;
        assert!((p.at(p.period_s() - 1.0).angle - 2.0 * turn).abs() < 1e-9);
        assert!((p.at(2.0 * p.period_s() - 1.0).angle - 4.0 * turn).abs() < 1e-9);
        for bad in [0u8, 5] {
            let s = Scheme::Rates {
                rates: [d; MAX_RATES],
                count: bad,
                turns: 1,
                dwell_s: 1.0,
            };
            assert!(Profile::new(s, lim).is_err());
        }
    }

    #[test]
    fn schemes_are_consistent_and_periodic() {
        let rate = 30f64.to_radians();
        let lim = Limits::default();
        let c = Profile::new(Scheme::Continuous { rate }, lim).unwrap();
        check(&c, 20.0);
        assert!((c.at(100.0).rate - rate).abs() < 1e-15);
        let r = Profile::new(Scheme::Reciprocating { rate, turns: 2 }, lim).unwrap();
        check(&r, 3.0 * r.period_s());
        // Back at the start after each period, 2 turns out at half.
        assert!(r.at(r.period_s()).angle.abs() < 1e-9);
        let half = r.at(0.5 * r.period_s() - 1e-9).angle;
        assert!((half - 2.0 * core::f64::consts::TAU).abs() < 1e-6, "{half}");
        for n in [2, 4] {
            let i = Profile::new(
                Scheme::Indexed {
                    rate,
                    positions: n,
                    dwell_s: 5.0,
                },
                lim,
            )
            .unwrap();
            check(&i, 2.0 * i.period_s());
            assert!(i.at(2.5).rate == 0.0 && i.at(2.5).angle == 0.0);
        }
        assert!(Profile::new(Scheme::Continuous { rate: 0.0 }, lim).is_err());
        // Dual-axis: both gimbals back at 0 after a period, each moving
        // 180 deg at a time, never both at once.
        for n in [8, 16] {
            let d = DualAxisProfile::new(n, rate, 2.0, lim).unwrap();
            let end = d.at(d.period_s() - 1e-9);
            assert!(
                end.inner.angle.abs() < 1e-6 && end.outer.angle.abs() < 1e-6,
                "{end:?}"
            );
            let mut t = 0.0;
            while t < d.period_s() {
                let r = d.at(t);
                assert!(r.inner.rate == 0.0 || r.outer.rate == 0.0);
                t += 0.05;
            }
        }
        assert!(DualAxisProfile::new(6, rate, 2.0, lim).is_err());
        assert!(Profile::new(Scheme::Reciprocating { rate, turns: 0 }, lim).is_err());
    }
}

/// The two gimbals of a tri-axial table used for dual-axis schemes: the
/// outer turns about the base's x axis, the inner (carried by the outer)
/// about the sensor's z axis: `c_s_b = Rx(outer) Rz(inner)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Gimbal {
    /// About the sensor z (the inner gimbal).
    Inner,
    /// About the base x (the outer gimbal).
    Outer,
}

/// Most moves in one period of a dual-axis sequence.
const MAX_DUAL_MOVES: usize = 16;

/// A dual-axis indexing sequence (simulation only: a tri-axial table):
/// 180 deg moves alternating between the inner and outer gimbals, each
/// after a dwell. 8 positions: `I+ O+ I+ O+ I- O- I- O-`: each gimbal turns
/// a whole turn forward in two half turns, interleaved with the other, then
/// back, so every error fixed in the sensor spends equal time pointing each
/// way about both axes (the z gyro included) and each direction of turning
/// is used as much as the other; 16 positions: those 8 and their mirror
/// with the gimbals swapped, so both axes lead equally often.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DualAxisProfile {
    moves: [(Gimbal, f64); MAX_DUAL_MOVES],
    count: usize,
    dwell_s: f64,
    segment: Segment,
    period_s: f64,
}

/// Both gimbals' references at one time.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct DualReference {
    /// Inner gimbal (about sensor z).
    pub inner: Reference,
    /// Outer gimbal (about base x).
    pub outer: Reference,
}

impl DualAxisProfile {
    /// An 8- or 16-position sequence moving at `rate` (rad/s) under
    /// `limits`, dwelling `dwell_s` before each move.
    ///
    /// # Errors
    /// [`NavError::BadScheme`] for other position counts, a bad rate or dwell.
    pub fn new(positions: u8, rate: f64, dwell_s: f64, limits: Limits) -> Result<Self, NavError> {
        use Gimbal::{Inner as I, Outer as O};
        const H: f64 = core::f64::consts::PI;
        let first: [(Gimbal, f64); 8] = [
            (I, H),
            (O, H),
            (I, H),
            (O, H),
            (I, -H),
            (O, -H),
            (I, -H),
            (O, -H),
        ];
        let mirror: [(Gimbal, f64); 8] = [
            (O, H),
            (I, H),
            (O, H),
            (I, H),
            (O, -H),
            (I, -H),
            (O, -H),
            (I, -H),
        ];
        if !(rate.is_finite()
            && rate > 0.0
            && rate <= limits.max_rate
            && dwell_s >= 0.0
            && dwell_s.is_finite())
        {
            return Err(NavError::BadScheme);
        }
        let mut moves = [(I, 0.0); MAX_DUAL_MOVES];
        let count = match positions {
            8 => 8,
            16 => 16,
            _ => return Err(NavError::BadScheme),
        };
        for (slot, m) in moves
            .iter_mut()
            .zip(first.iter().chain(mirror.iter()))
            .take(count)
        {
            *slot = *m;
        }
        let segment = Segment::mv(H, rate, limits.max_accel);
        Ok(Self {
            moves,
            count,
            dwell_s,
            segment,
            period_s: count as f64 * (dwell_s + segment.duration),
        })
    }

    /// Length of one period, s.
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// Both gimbals `t_s` seconds after the sequence started (before: still).
    pub fn at(&self, t_s: f64) -> DualReference {
        let mut out = DualReference::default();
        if t_s.partial_cmp(&0.0) != Some(core::cmp::Ordering::Greater) || self.period_s <= 0.0 {
            return out;
        }
        let mut tau = t_s - libm::floor(t_s / self.period_s) * self.period_s;
        let step = self.dwell_s + self.segment.duration;
        for (g, a) in self.moves.iter().take(self.count) {
            if tau < step {
                let mut r = Reference::default();
                if tau >= self.dwell_s {
                    r = self.segment.at(tau - self.dwell_s);
                    let sg = a.signum();
                    r = Reference {
                        angle: r.angle * sg,
                        rate: r.rate * sg,
                        accel: r.accel * sg,
                    };
                }
                match g {
                    Gimbal::Inner => {
                        out.inner = Reference {
                            angle: out.inner.angle + r.angle,
                            ..r
                        }
                    }
                    Gimbal::Outer => {
                        out.outer = Reference {
                            angle: out.outer.angle + r.angle,
                            ..r
                        }
                    }
                }
                return out;
            }
            match g {
                Gimbal::Inner => out.inner.angle += a,
                Gimbal::Outer => out.outer.angle += a,
            }
            tau -= step;
        }
        out
    }
}

//! The table's motion at the physics rate: the lab console's servo
//! ([`Servo`]) driving the motor ([`Table`]) after the scheme's reference,
//! tick by tick. Nothing in it is random, so every run of one motor,
//! scheme and length shares it: [`motion`] makes it once and keeps the
//! last few (a Monte Carlo of a thousand seeds steps the table once), in
//! a [`Kept`], the home of what runs share.

use crate::world::{Kinematics, MotorParams, Servo, Table};
use core_nav::scheme::{Limits, Profile, Scheme};
use std::sync::{Arc, Mutex, OnceLock};

/// The table's state at every physics tick from t = 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Motion {
    /// Tick, s.
    dt_s: f64,
    /// The state at tick i (t = i dt_s).
    kin: Vec<Kinematics>,
}

impl Motion {
    /// Steps the servo and the motor from rest for `n_ticks` ticks of
    /// `dt_s` s after `profile`, which starts `static_s` s in.
    pub fn run(
        motor: &MotorParams,
        profile: &Profile,
        static_s: f64,
        dt_s: f64,
        n_ticks: u64,
    ) -> Self {
        let mut table = Table::new(motor.clone());
        let mut servo = Servo::for_motor(motor);
        let mut kin = Vec::with_capacity(usize::try_from(n_ticks).unwrap_or(0) + 1);
        for tick in 0..=n_ticks {
            let t = tick as f64 * dt_s;
            kin.push(table.kin);
            let v = servo.update(&profile.at(t - static_s), &table.kin, dt_s);
            table.step(dt_s, v, 0.0);
        }
        Self { dt_s, kin }
    }

    /// The ticks held.
    pub fn len(&self) -> usize {
        self.kin.len()
    }

    /// No tick held.
    pub fn is_empty(&self) -> bool {
        self.kin.is_empty()
    }

    /// Kinematics at `t` s by cubic Hermite interpolation of the angle
    /// (with the rates as slopes), linear in rate and acceleration;
    /// before the first tick the first, past the last the last.
    pub fn at(&self, t: f64) -> Kinematics {
        let x = (t / self.dt_s).max(0.0);
        let i = (x.floor() as usize).min(self.kin.len().saturating_sub(2));
        let (Some(a), Some(b)) = (self.kin.get(i), self.kin.get(i + 1)) else {
            return self.kin.last().copied().unwrap_or_default();
        };
        let u = (x - i as f64).clamp(0.0, 1.0);
        let h = self.dt_s;
        let (u2, u3) = (u * u, u * u * u);
        let theta = (2.0 * u3 - 3.0 * u2 + 1.0) * a.theta
            + (u3 - 2.0 * u2 + u) * h * a.rate
            + (-2.0 * u3 + 3.0 * u2) * b.theta
            + (u3 - u2) * h * b.rate;
        Kinematics {
            theta,
            rate: a.rate + u * (b.rate - a.rate),
            accel: a.accel + u * (b.accel - a.accel),
        }
    }
}

/// What a motion is made from.
#[derive(Clone, Debug, PartialEq)]
struct Key {
    motor: MotorParams,
    scheme: Scheme,
    limits: Limits,
    static_s: f64,
    dt_s: f64,
    n_ticks: u64,
}

/// Motions kept: the last four made or asked for, up to 192 MB in all
/// (24 bytes a tick); a longer motion is made and not kept.
static KEPT_MOTIONS: Kept<Key, Motion> = Kept::new(4, 192 << 20);

/// The motion of `motor` after `scheme` (within `limits`, starting
/// `static_s` s in) for `n_ticks` ticks of `dt_s` s: from the last few
/// made when one matches, else made now.
pub fn motion(
    motor: &MotorParams,
    scheme: Scheme,
    limits: Limits,
    static_s: f64,
    dt_s: f64,
    n_ticks: u64,
) -> Result<Arc<Motion>, core_nav::NavError> {
    let profile = Profile::new(scheme, limits)?;
    let key = Key {
        motor: motor.clone(),
        scheme,
        limits,
        static_s,
        dt_s,
        n_ticks,
    };
    let bytes = usize::try_from(n_ticks)
        .unwrap_or(usize::MAX)
        .saturating_mul(std::mem::size_of::<Kinematics>());
    Ok(KEPT_MOTIONS.get_or_make(key, bytes, || {
        Motion::run(motor, &profile, static_s, dt_s, n_ticks)
    }))
}

/// The last few values made from their keys, for what every run of one
/// configuration shares (nothing random in it). A value is made once, by
/// the first thread to ask; others asking for it meanwhile wait for it.
pub struct Kept<K, V> {
    entries: usize,
    bytes: usize,
    list: Mutex<Vec<Entry<K, V>>>,
}

/// A key, its value's size in bytes, the value once made.
type Entry<K, V> = (K, usize, Arc<OnceLock<Arc<V>>>);

impl<K: PartialEq, V> Kept<K, V> {
    /// Keeps the last `entries` values, at most `bytes` in all.
    pub const fn new(entries: usize, bytes: usize) -> Self {
        Self {
            entries,
            bytes,
            list: Mutex::new(Vec::new()),
        }
    }

    /// The value for `key` (`bytes` its size): the kept one, else
    /// `make`'s, kept unless larger than all may be.
    pub fn get_or_make(&self, key: K, bytes: usize, make: impl FnOnce() -> V) -> Arc<V> {
        if bytes > self.bytes {
            return Arc::new(make());
        }
        let slot = self.slot(key, bytes);
        Arc::clone(slot.get_or_init(|| Arc::new(make())))
    }

    /// The slot for `key`, moved to the back (the most recent); a new one
    /// pushes out the oldest beyond the limits.
    fn slot(&self, key: K, bytes: usize) -> Arc<OnceLock<Arc<V>>> {
        // A poisoned lock only means a thread panicked while holding it;
        // the list itself is always whole.
        let mut list = self
            .list
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let slot = match list.iter().position(|(k, ..)| *k == key) {
            Some(i) => list.remove(i).2,
            None => Arc::new(OnceLock::new()),
        };
        list.push((key, bytes, Arc::clone(&slot)));
        let total = |l: &Vec<Entry<K, V>>| l.iter().map(|e| e.1).sum::<usize>();
        while list.len() > self.entries || (list.len() > 1 && total(&list) > self.bytes) {
            list.remove(0);
        }
        slot
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn continuous() -> (Scheme, Limits) {
        (
            Scheme::Continuous {
                rate: 30f64.to_radians(),
            },
            Limits::default(),
        )
    }

    #[test]
    fn kept_motion_is_the_motion_made_again() {
        let (scheme, limits) = continuous();
        let m = MotorParams::default();
        let a = motion(&m, scheme, limits, 1.0, 1e-3, 3_000).expect("scheme");
        let b = motion(&m, scheme, limits, 1.0, 1e-3, 3_000).expect("scheme");
        assert!(
            Arc::ptr_eq(&a, &b),
            "the second ask is served from the kept"
        );
        let profile = Profile::new(scheme, limits).expect("scheme");
        assert_eq!(*a, Motion::run(&m, &profile, 1.0, 1e-3, 3_000));
        // Another motor is another motion.
        let mut stiff = m.clone();
        stiff.coulomb *= 2.0;
        let c = motion(&stiff, scheme, limits, 1.0, 1e-3, 3_000).expect("scheme");
        assert_ne!(*a, *c);
    }

    #[test]
    fn the_table_follows_the_reference_and_interpolation_hits_the_ticks() {
        let (scheme, limits) = continuous();
        let profile = Profile::new(scheme, limits).expect("scheme");
        let m = Motion::run(&MotorParams::default(), &profile, 0.5, 1e-3, 4_000);
        assert_eq!(m.len(), 4_001);
        // Still before the scheme starts, at the rate after (a 25 Hz loop
        // settles in well under a second; 1 % of the rate covers the
        // cogging's ripple).
        assert_eq!(m.at(0.25).rate, 0.0);
        let want = 30f64.to_radians();
        assert!(
            (m.at(3.5).rate - want).abs() < 0.01 * want,
            "{:?}",
            m.at(3.5)
        );
        // On a tick the interpolation is the tick.
        // (2.0 / 1e-3 may round to just below tick 2000: 1e-12 rad.)
        let k = m.kin[2_000];
        assert!((m.at(2.0).theta - k.theta).abs() < 1e-12);
        // Past the end: the last tick.
        assert_eq!(m.at(100.0).theta, m.kin[4_000].theta);
    }
}

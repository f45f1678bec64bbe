//! Table rate control, the one controller of the board (f32, rate from the
//! gyro's table-axis channel: the 50 Hz encoder's 16,384 counts per turn
//! would quantise a rate to 1.1 deg/s) and of the simulated lab table's
//! console (hal-sim, f64, rate from its tachometer): PI on the rate with
//! feed-forward from the motor model, an angle loop on the encoder, and
//! anti-windup. It runs at 1 kHz on the board.
//!
//! ```text
//! w_cmd = w_ref + k_angle (theta_ref - theta_enc)
//! u = Ke w_ref + (R / Kt)(J a_ref + b w_ref + Tc sign w_ref) + kp (w_cmd - w_gyro) + ki int(w_cmd - w_gyro)
//! ```
//! `u` is the motor voltage; the integrator stops while `u` saturates.

use crate::real::Real;
use crate::scheme::Reference;

/// The motor as the controller knows it; `hal-sim`'s motor is built from
/// the same numbers ([`MotorModel::default`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorModel<T: Real> {
    /// Inertia, kg m^2.
    pub inertia: T,
    /// Torque / back-EMF constant, N m/A = V s/rad.
    pub kt: T,
    /// Winding resistance, ohm.
    pub resistance: T,
    /// Supply, V.
    pub supply_v: T,
    /// Viscous friction, N m s/rad.
    pub viscous: T,
    /// Coulomb friction, N m.
    pub coulomb: T,
}

impl<T: Real> Default for MotorModel<T> {
    /// The board's direct-drive gimbal torque motor (representative values:
    /// 0.4 N m stall at 12 V, 240 rad/s no-load).
    fn default() -> Self {
        Self {
            inertia: T::lit(2e-3),
            kt: T::lit(0.05),
            resistance: T::lit(1.5),
            supply_v: T::lit(12.0),
            viscous: T::lit(2e-4),
            coulomb: T::lit(5e-3),
        }
    }
}

/// The rate controller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateController<T: Real> {
    /// Motor model for the feed-forward.
    pub motor: MotorModel<T>,
    /// Rate gain, V per rad/s.
    pub kp: T,
    /// Integral gain, V per rad.
    pub ki: T,
    /// Angle gain, 1/s.
    pub k_angle: T,
    integ: T,
}

impl<T: Real> RateController<T> {
    /// Gains for a `bandwidth_hz` rate loop on `motor` (proportional gain at
    /// the crossover, integral corner a fifth below, angle loop an eighth).
    /// The board's loop and the simulated console both run at 1 kHz with
    /// 25 Hz (1 ms of delay costs 9 deg of phase there).
    pub fn new(motor: MotorModel<T>, bandwidth_hz: T) -> Self {
        let wc = T::two_pi() * bandwidth_hz;
        let kp = wc * motor.inertia * motor.resistance / motor.kt;
        Self {
            motor,
            kp,
            ki: kp * wc / T::lit(5.0),
            k_angle: wc / T::lit(8.0),
            integ: T::zero(),
        }
    }

    /// Clears the integrator (motor stopped, new scheme).
    pub fn reset(&mut self) {
        self.integ = T::zero();
    }

    /// The integrator's state, V.
    pub fn integrator(&self) -> T {
        self.integ
    }

    /// The duty cycle in [-1, 1] (sign = direction) for reference `r`
    /// (angle, rate, acceleration; rad, rad/s, rad/s^2), the encoder's
    /// angle error `angle_err` = reference - measured (rad) and the gyro's
    /// table-axis rate `rate_meas` (rad/s), after `dt` s.
    pub fn update(&mut self, r: &Reference, angle_err: T, rate_meas: T, dt: T) -> T {
        let m = &self.motor;
        let (w_ref, a_ref) = (T::lit(r.rate), T::lit(r.accel));
        let zero = T::zero();
        let sgn = if w_ref > zero {
            T::one()
        } else if w_ref < zero {
            -T::one()
        } else {
            zero
        };
        let ff = m.kt * w_ref
            + m.resistance / m.kt * (m.inertia * a_ref + m.viscous * w_ref + m.coulomb * sgn);
        let e = w_ref + self.k_angle * angle_err - rate_meas;
        let u = ff + self.kp * e + self.integ;
        if u.abs() < m.supply_v && u.is_finite() {
            self.integ += self.ki * e * dt;
        }
        let d = u / m.supply_v;
        if d.is_finite() {
            d.max(-T::one()).min(T::one())
        } else {
            zero
        }
    }
}

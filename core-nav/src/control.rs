//! Table rate control: PI on the rate with feed-forward, an angle loop on
//! the encoder, and anti-windup; the rate measured by the gyro's table-axis
//! channel (100 Hz, low noise; the 50 Hz encoder's 16,384 counts per turn
//! would quantise a rate to 1.1 deg/s).
//!
//! ```text
//! w_cmd = w_ref + k_angle (theta_ref - theta_enc)
//! u = Ke w_ref + (R / Kt)(J a_ref + b w_ref + Tc sign w_ref) + kp (w_cmd - w_gyro) + ki int(w_cmd - w_gyro)
//! ```
//! `u` is the motor voltage; the integrator stops while `u` saturates.

use core_nav::scheme::Reference;

/// The motor as the controller knows it (the board's table).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorModel {
    /// Inertia, kg m^2.
    pub inertia: f32,
    /// Torque / back-EMF constant, N m/A = V s/rad.
    pub kt: f32,
    /// Winding resistance, ohm.
    pub resistance: f32,
    /// Supply, V.
    pub supply_v: f32,
    /// Viscous friction, N m s/rad.
    pub viscous: f32,
    /// Coulomb friction, N m.
    pub coulomb: f32,
}

impl Default for MotorModel {
    /// The board's direct-drive gimbal motor (hal-sim's default motor).
    fn default() -> Self {
        Self {
            inertia: 2e-3,
            kt: 0.05,
            resistance: 1.5,
            supply_v: 12.0,
            viscous: 2e-4,
            coulomb: 5e-3,
        }
    }
}

/// The rate controller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateController {
    /// Motor model for the feed-forward.
    pub motor: MotorModel,
    /// Rate gain, V per rad/s.
    pub kp: f32,
    /// Integral gain, V per rad.
    pub ki: f32,
    /// Angle gain, 1/s.
    pub k_angle: f32,
    integ: f32,
}

impl RateController {
    /// Gains for a `bandwidth_hz` rate loop on `motor` (proportional gain at
    /// the crossover, integral corner a fifth below, angle loop an eighth).
    /// The loop runs at the IMU rate (100 Hz): keep the bandwidth <= 15 Hz
    /// (10 ms of delay is 54 deg of phase there).
    pub fn new(motor: MotorModel, bandwidth_hz: f32) -> Self {
        let wc = 2.0 * core::f32::consts::PI * bandwidth_hz;
        let kp = wc * motor.inertia * motor.resistance / motor.kt;
        Self {
            motor,
            kp,
            ki: kp * wc / 5.0,
            k_angle: wc / 8.0,
            integ: 0.0,
        }
    }

    /// Clears the integrator (motor stopped, new scheme).
    pub fn reset(&mut self) {
        self.integ = 0.0;
    }

    /// The duty cycle in [-1, 1] (sign = direction) for reference `r`
    /// (angle, rate, acceleration; rad, rad/s, rad/s^2), the encoder's
    /// angle error `angle_err` = reference - measured (rad) and the gyro's
    /// table-axis rate `rate_meas` (rad/s), after `dt` s.
    pub fn update(&mut self, r: &Reference, angle_err: f32, rate_meas: f32, dt: f32) -> f32 {
        let m = &self.motor;
        let (w_ref, a_ref) = (r.rate as f32, r.accel as f32);
        let sgn = if w_ref > 0.0 {
            1.0
        } else if w_ref < 0.0 {
            -1.0
        } else {
            0.0
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
            d.clamp(-1.0, 1.0)
        } else {
            0.0
        }
    }
}

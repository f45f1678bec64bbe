//! The car's body on its suspension: what a real car does that its road
//! alone does not. The body `v` rolls and pitches about a pivot at the
//! rear axle's centre and heaves along the road's down axis:
//!
//! - **in turns and on the pedals**: roll `-k_roll a_lat` (the body leans
//!   out of the turn; `a_lat = speed yaw_rate`), pitch `k_pitch a_long`
//!   (squat when accelerating, dive when braking), each acceleration the
//!   mean over the last [`LAG_S`] (the suspension's lag; it also makes the
//!   pose twice differentiable where the plan's edges are only once);
//! - **in turns, on its tyres**: the rear axle slides out of the turn by
//!   its tyres' slip angle `k_slip a_lat` (the rear axle's cornering
//!   compliance), so the body yaws that much into the turn from the road's
//!   heading, which its rear axle's centre still follows: the point that
//!   does not slide sideways is ahead of the axle by `k_slip speed^2`;
//! - **on the road's roughness**: its bounce, heave, pitch and roll modes
//!   near 1-1.8 Hz, each two sines of seeded frequency and phase, scaled by
//!   `speed / (speed + 5 m/s)`;
//! - **parked with its engine running**: the same modes at
//!   [`PARKED_SCALE`] of their driving size: a parked car is never still.
//!
//! The sizes (the book's Simulated drives) are drawn per drive from
//! passenger cars' ranges; the IMU sits [`Body::imu_above_m`] above the
//! pivot, so the body's roll moves it sideways. `crate::drive` composes
//! this pose with the road's.

use crate::rng::Rng;

/// Seconds either side of the pose's central differences (their error at
/// the modes' 1.8 Hz is under 3e-5 of the term).
const FD_S: f64 = 1e-3;
/// The suspension's lag: the body follows the mean acceleration over this
/// many seconds.
pub const LAG_S: f64 = 0.4;
/// The road modes' size parked (engine idling, occupants), of driving's.
pub const PARKED_SCALE: f64 = 0.03;
/// The speed at which the road's input is half its full size, m/s.
const ROAD_HALF_MPS: f64 = 5.0;

/// One drive's body: its gradients, the IMU's height and its modes.
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    /// Roll per lateral acceleration, rad per m/s^2 (the roll gradient).
    pub roll_rad_per_mps2: f64,
    /// Pitch per longitudinal acceleration, rad per m/s^2.
    pub pitch_rad_per_mps2: f64,
    /// The IMU's height above the pivot, m.
    pub imu_above_m: f64,
    /// The rear axle's slip angle per lateral acceleration, rad per m/s^2
    /// (its cornering compliance).
    pub slip_rad_per_mps2: f64,
    /// Roll, pitch (rad) and heave (m) modes: (amplitude, Hz, phase rad).
    modes: [[(f64, f64, f64); 2]; 3],
}

/// The body's pose relative to the road and its first two derivatives:
/// `[roll rad, pitch rad, heave m (down), yaw rad]` each as `[x, x',
/// x'']` (per s, per s^2); the yaw is the slip angle's, positive to the
/// right (into a right turn).
pub type Pose = [[f64; 3]; 4];

impl Body {
    /// A car drawn from `seed` (its own stream).
    pub fn draw(seed: u64) -> Self {
        let mut rng = Rng::new(seed, 22);
        let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rng.uniform();
        let g = core_nav::units::G0_MPS2;
        let roll = u(3.0, 6.0).to_radians() / g;
        let pitch = u(1.0, 2.0).to_radians() / g;
        let above = u(0.3, 0.9);
        let mut mode = |amp: f64, lo: f64, hi: f64| {
            [0, 1].map(|_| (amp, u(lo, hi), u(0.0, std::f64::consts::TAU)))
        };
        // Heave: about 0.4 m/s^2 rms of vertical acceleration at full size.
        let heave = mode(0.0065, 1.0, 1.5);
        let pitch_modes = mode(0.08f64.to_radians(), 1.2, 1.8);
        let roll_modes = mode(0.05f64.to_radians(), 1.0, 1.6);
        // A passenger car's rear axle: 2-4 deg of slip per g (drawn last,
        // so the draws above are the cars they were).
        let slip = u(2.0, 4.0).to_radians() / g;
        Self {
            roll_rad_per_mps2: roll,
            pitch_rad_per_mps2: pitch,
            imu_above_m: above,
            slip_rad_per_mps2: slip,
            modes: [roll_modes, pitch_modes, heave],
        }
    }

    /// The pose at `t` (s) from the drive's `(speed m/s, heading rad)` at
    /// any time.
    pub fn pose(&self, t: f64, drive: impl Fn(f64) -> (f64, f64)) -> Pose {
        let at = |tt: f64| {
            let ((s, psi), (s0, psi0)) = (drive(tt), drive(tt - LAG_S));
            self.at(tt, (s, (s - s0) / LAG_S, (psi - psi0) / LAG_S))
        };
        let (a, b, c) = (at(t - FD_S), at(t), at(t + FD_S));
        [0, 1, 2, 3].map(|k| {
            [
                b[k],
                (c[k] - a[k]) / (2.0 * FD_S),
                (c[k] - 2.0 * b[k] + a[k]) / (FD_S * FD_S),
            ]
        })
    }

    /// Roll, pitch (rad), heave (m) and slip yaw (rad) at `t` for `(speed,
    /// accel, rate)` (m/s, m/s^2, rad/s).
    fn at(&self, t: f64, (speed, accel, rate): (f64, f64, f64)) -> [f64; 4] {
        let road = speed / (speed + ROAD_HALF_MPS);
        let size = PARKED_SCALE + (1.0 - PARKED_SCALE) * road;
        let tau = std::f64::consts::TAU;
        let m = self.modes.map(|two| {
            size * two
                .iter()
                .map(|(a, f, p)| a * (tau * f * t + p).sin())
                .sum::<f64>()
        });
        [
            m[0] - self.roll_rad_per_mps2 * speed * rate,
            m[1] + self.pitch_rad_per_mps2 * accel,
            m[2],
            self.slip_rad_per_mps2 * speed * rate,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_body_leans_out_of_a_turn_and_squats_when_accelerating() {
        let b = Body::draw(1);
        // A right turn (positive rate, z down) at 10 m/s: the body rolls
        // left (negative), by the gradient times 10 * 0.2 = 2 m/s^2, to
        // within the road modes' size.
        let p = b.pose(0.0, |t| (10.0 + 1.5 * t, 0.2 * t));
        let quasi = -b.roll_rad_per_mps2 * 2.0;
        assert!(quasi < -0.005 && (p[0][0] - quasi).abs() < 0.002, "{p:?}");
        let squat = b.pitch_rad_per_mps2 * 1.5;
        assert!(squat > 0.002 && (p[1][0] - squat).abs() < 0.003, "{p:?}");
        // ... and yaws into it by its slip angle: 2 m/s^2 at 2-4 deg/g.
        let slip = b.slip_rad_per_mps2 * 2.0;
        assert!(
            slip > 0.006 && (p[3][0] - slip).abs() < 1e-3 * slip,
            "{p:?}"
        );
        // Parked: the modes at their parked size, never exactly still.
        let parked = b.pose(0.3, |_| (0.0, 0.0));
        assert!(
            parked[2][0].abs() < 0.0005 && parked[2][1] != 0.0,
            "{parked:?}"
        );
    }

    #[test]
    fn the_poses_derivatives_are_its_own() {
        // The central differences against the modes' closed forms: a
        // parked car's heave is `size sum a sin(w t + p)`.
        let b = Body::draw(4);
        let tau = std::f64::consts::TAU;
        let t = 2.7;
        let p = b.pose(t, |_| (0.0, 0.0));
        let (mut v, mut a) = (0.0, 0.0);
        for (amp, f, ph) in b.modes[2] {
            let w = tau * f;
            v += PARKED_SCALE * amp * w * (w * t + ph).cos();
            a -= PARKED_SCALE * amp * w * w * (w * t + ph).sin();
        }
        // Tolerance: the differences' truncation, (w h)^2 / 6 of the term
        // at 1.5 Hz (1.5e-5), and the sum's other mode.
        assert!(
            (p[2][1] - v).abs() < 3e-5 * v.abs().max(1e-6),
            "{} {v}",
            p[2][1]
        );
        assert!(
            (p[2][2] - a).abs() < 3e-5 * a.abs().max(1e-5),
            "{} {a}",
            p[2][2]
        );
    }
}

//! Initialisation: from a known attitude (the paper's lab tests: the table
//! is set up aligned to north and level), by coarse levelling from the
//! accelerometers, and by gyrocompassing from the gyros where they
//! resolve the earth's rate.
//!
//! Source: Groves 2nd ed. Sec. 5.6.2 (Eq. 5.101, levelling) and 5.6.3
//! (gyrocompassing).

use crate::attitude::{euler_to_quat, Euler};
use crate::error::NavError;
use crate::real::Real;
use crate::table::{q_s_b, Axis};
use nalgebra::{Quaternion, Vector3};

/// Sensor attitude `q_s_n` from the base attitude (ZYX Euler, rad) and the
/// table angle `theta` (rad): `q_s_n = q_b_n ⊗ q_s_b(theta)`.
pub fn q_s_n_from_base<T: Real>(base: &Euler<T>, axis: Axis, theta: T) -> Quaternion<T> {
    euler_to_quat(base) * q_s_b(axis, theta)
}

/// Running mean of static accelerometer samples (m/s^2, in the frame they
/// are given in), for levelling. No heap: a sum and a count.
#[derive(Clone, Copy, Debug, Default)]
pub struct MeanAccumulator<T: Real> {
    sum: Vector3<T>,
    count: u32,
}

impl<T: Real> MeanAccumulator<T> {
    /// Adds one sample; non-finite samples are refused.
    ///
    /// # Errors
    /// [`NavError::NonFiniteSample`].
    pub fn push(&mut self, v: &Vector3<T>) -> Result<(), NavError> {
        if !v.iter().all(|x| x.is_finite()) {
            return Err(NavError::NonFiniteSample);
        }
        self.sum += v;
        self.count = self.count.saturating_add(1);
        Ok(())
    }

    /// Number of samples.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The mean.
    ///
    /// # Errors
    /// [`NavError::NotEnoughSamples`] with no sample.
    pub fn mean(&self) -> Result<Vector3<T>, NavError> {
        if self.count == 0 {
            return Err(NavError::NotEnoughSamples);
        }
        Ok(self.sum / T::lit(f64::from(self.count)))
    }
}

/// Roll and pitch (rad) of the frame the mean specific force `f` (m/s^2) is
/// expressed in, from a static base: `f = c_n_b [0, 0, -g]`. Heading is
/// unobservable from accelerometers and taken from `heading` (rad).
///
/// # Errors
/// [`NavError::NotStatic`] when `|f|` is not within 10 % of `g`.
pub fn coarse_level<T: Real>(f: &Vector3<T>, g: T, heading: T) -> Result<Euler<T>, NavError> {
    let n = f.norm();
    if !n.is_finite() || n < T::lit(0.9) * g || n > T::lit(1.1) * g {
        return Err(NavError::NotStatic);
    }
    let roll = (-f.y).atan2(-f.z);
    let pitch = f.x.atan2((f.y * f.y + f.z * f.z).sqrt_cr());
    Ok(Euler {
        roll,
        pitch,
        heading,
    })
}

/// Heading (rad, in (-pi, pi]) by gyrocompassing: the mean angular rate
/// `w_b` (rad/s) of a still base, in `b`, is the earth's rate; taken into
/// the level frame with `level`'s roll and pitch (`w_l = Ry(pitch)
/// Rx(roll) w_b`), its horizontal part points north: `w_l = [W cos(lat)
/// cos(psi), -W cos(lat) sin(psi), -W sin(lat)]`, so `psi = atan2(-w_l.y,
/// w_l.x)` (Groves 2nd ed. Sec. 5.6.3). Its error is the horizontal rate
/// error over `W cos(lat)`: the caller says whether the gyros resolve it.
pub fn gyrocompass<T: Real>(w_b: &Vector3<T>, level: &Euler<T>) -> T {
    let (sr, cr) = (level.roll.sin(), level.roll.cos());
    let (sp, cp) = (level.pitch.sin(), level.pitch.cos());
    // Rx(roll) w, then Ry(pitch) of that (b to the level frame).
    let y1 = cr * w_b.y - sr * w_b.z;
    let z1 = sr * w_b.y + cr * w_b.z;
    let x2 = cp * w_b.x + sp * z1;
    (-y1).atan2(x2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::{quat_to_dcm, quat_to_euler};

    #[test]
    fn levelling_recovers_roll_and_pitch() {
        let truth = Euler::<f64>::from_deg(3.0, -7.0, 40.0);
        let c_b_n = quat_to_dcm(&euler_to_quat(&truth));
        let f_b = c_b_n.transpose() * Vector3::new(0.0, 0.0, -9.8);
        let e = coarse_level(&f_b, 9.8, truth.heading).unwrap();
        let back = quat_to_euler(&euler_to_quat(&e));
        assert!((back.roll - truth.roll).abs() < 1e-12);
        assert!((back.pitch - truth.pitch).abs() < 1e-12);
        assert!(coarse_level(&(f_b * 0.5), 9.8, 0.0).is_err());
    }

    #[test]
    fn gyrocompassing_recovers_the_heading_of_a_tilted_base() {
        // The earth's rate at 30 deg south seen by a base at roll 3, pitch
        // -7 and each heading: levelled with the true roll and pitch, the
        // heading comes back to rounding.
        let lat = (-30.0f64).to_radians();
        let w_n = Vector3::new(lat.cos(), 0.0, -lat.sin()) * 7.292115e-5;
        for h in [-170.0, -90.0, 0.0, 45.0, 135.0, 180.0] {
            let truth = Euler::<f64>::from_deg(3.0, -7.0, h);
            let w_b = quat_to_dcm(&euler_to_quat(&truth)).transpose() * w_n;
            let psi = gyrocompass(&w_b, &truth);
            let d = (psi - truth.heading).sin().abs();
            assert!(d < 1e-9, "{h}: {}", psi.to_degrees());
        }
    }
}

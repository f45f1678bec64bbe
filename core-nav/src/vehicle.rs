//! What a land vehicle knows about its own motion, as measurements for the
//! aided navigator ([`crate::aided::AidedNav::update_base_velocity`]):
//!
//! - **It does not slide sideways or leave the road** (non-holonomic
//!   constraints, Sukkarieh 2000; Groves 2nd ed. Sec. 15.4.1): the
//!   velocity of the point that does not slip lies along the vehicle's
//!   forward axis, so its two components across that axis are zero, to
//!   within [`nhc_sigma_mps`].
//! - **What it reads on its odometer**: its forward speed times one plus
//!   the tyres' scale error ([`BaseVelocity::gain`]).
//! - **Where its forward axis is in the base's frame**: the recording's
//!   `b` is the vehicle's body only when the IMU was mounted square or the
//!   import turned it; a host carries the axis's error as its own filter
//!   states ([`BaseVelocity::aux`]; `rins::aided::vehicle`).
//!
//! Frames: `b` the base (the table's, or the IMU's when no table), `n`
//! local NED. The constraint is on the forward axis only: the mounting's
//! roll about it does not enter (both cross components are zero with one
//! sigma), so an IMU upside down needs no more than its forward axis.
//!
//! The measurement of the base's velocity along a unit vector `e_b` is
//! `z = m - e_b . (c_n_b v_n) = a . dv + (a x v_n) . phi + noise`, `a =
//! c_b_n e_b` (the error state's conventions: [`crate::eskf`]).

use crate::eskf::{State, AUX_MAX, I_PHI, I_V, N};
use crate::real::Real;
use nalgebra::{Matrix3, Vector3};

/// The cross velocities' 1-sigma on a straight road, m/s: a car body's
/// bounce on its suspension (1-1.5 Hz at a centimetre: 0.06-0.09 m/s) and
/// its tyres' slip in gentle driving.
pub const NHC_SIGMA_MPS: f64 = 0.1;
/// The rear axle's slip angle per lateral acceleration, rad per m/s^2 (a
/// passenger car's rear cornering compliance, about 0.3 deg per m/s^2 or
/// 2.8 deg per g): in a turn the axle slides out by this times the speed
/// times the lateral acceleration.
pub const NHC_SLIP_RAD_PER_MPS2: f64 = 0.005;
/// That compliance's prior 1-sigma, rad per m/s^2 (1.4 deg per g: rear
/// axles from about 1.5 to 4.5 deg per g within it; Gillespie ch. 6).
pub const NHC_SLIP_PRIOR_SIGMA_RAD_PER_MPS2: f64 = 0.0025;
/// The slip a constant compliance does not describe, rad per m/s^2: a
/// tyre's cornering stiffness falls by about a fifth between a gentle turn
/// and 0.4 g, and its force lags the steering by its relaxation length.
pub const NHC_SLIP_UNMODELLED_RAD_PER_MPS2: f64 = 0.001;
/// The IMU's distance ahead of the point that does not slide sideways
/// (the rear axle's centre), m: unknown on a log, its prior taken as a
/// car's half wheelbase; a turn's rate times it is a lateral velocity.
pub const NHC_LEVER_M: f64 = 1.5;
/// That distance's prior 1-sigma, m: from the rear axle itself to a
/// windscreen near the front one.
pub const NHC_LEVER_PRIOR_SIGMA_M: f64 = 1.5;
/// The constraints are off above this lateral acceleration (a hard turn,
/// where tyres slide), m/s^2.
pub const NHC_MAX_LATERAL_MPS2: f64 = 4.0;
/// ... and below this speed (standing or creeping: the zero-velocity
/// detector's case), m/s.
pub const NHC_MIN_SPEED_MPS: f64 = 1.0;
/// Seconds between two constraint updates: the body's bounce and a
/// turn's slip decorrelate in about half a second, so updates closer
/// together would count one error many times.
pub const NHC_EVERY_S: f64 = 0.5;

/// A cross velocity's 1-sigma (m/s) at `speed_mps` while the base turns
/// at `rate_radps` (rad/s, its rotation relative to the ground): the
/// road's [`NHC_SIGMA_MPS`], the slip of a turn's lateral acceleration
/// `speed rate` at `slip_rad_per_mps2` (what is not known of the rear
/// axle's slip per lateral acceleration: a host that carries the
/// compliance as a state passes [`NHC_SLIP_UNMODELLED_RAD_PER_MPS2`], one
/// that does not [`NHC_SLIP_RAD_PER_MPS2`]) and the rate times
/// `lever_sigma_m` (m: what is not known of the IMU's distance from the
/// rear axle; a host that carries that distance as a state passes 0, one
/// that does not [`NHC_LEVER_M`]), in quadrature.
/// The forward axis's own error is not in it: it is one constant, which
/// updates repeated every [`NHC_EVERY_S`] as if white would average away
/// (on a real car with the axis's yaw known to 10 deg, constraints so made
/// turned a 0.9 m outage into 5.4 m); a host carries it as filter states
/// ([`BaseVelocity::aux`]). `None` where the constraint does not hold:
/// below [`NHC_MIN_SPEED_MPS`], above [`NHC_MAX_LATERAL_MPS2`], or a
/// non-finite input.
pub fn nhc_sigma_mps(
    speed_mps: f64,
    rate_radps: f64,
    lever_sigma_m: f64,
    slip_rad_per_mps2: f64,
) -> Option<f64> {
    let lateral = speed_mps * rate_radps.abs();
    let ok = speed_mps.is_finite() && lateral.is_finite();
    if !ok || speed_mps < NHC_MIN_SPEED_MPS || lateral > NHC_MAX_LATERAL_MPS2 {
        return None;
    }
    let slip = speed_mps * slip_rad_per_mps2 * lateral;
    let lever = lever_sigma_m * rate_radps.abs();
    Some(libm::sqrt(
        NHC_SIGMA_MPS * NHC_SIGMA_MPS + slip * slip + lever * lever,
    ))
}

/// Two unit vectors across `x_b` (unit), completing it to an orthonormal
/// triad: the first across `b`'s z (the lateral one when `b` is upright
/// or upside down: the axis's yaw error moves the velocity into it), the
/// second in the plane of `x_b` and `b`'s z (the vertical one: its
/// pitch error's).
pub fn across<T: Real>(x_b: &Vector3<T>) -> [Vector3<T>; 2] {
    let hint = if x_b.z.abs() < T::lit(0.9) {
        Vector3::z()
    } else {
        Vector3::y()
    };
    let e1 = x_b.cross(&hint);
    let n1 = e1.norm();
    let e1 = if n1 > T::zero() {
        e1 / n1
    } else {
        Vector3::x()
    };
    [e1, x_b.cross(&e1)]
}

/// The measurement row and innovation of the base's velocity along `e_b`
/// (unit, in `b`) measured as `m_mps`, with the base at `c_b_n` moving at
/// `v_n` (NED, m/s): `(h, z)` (module docs).
pub fn velocity_b_row<T: Real, const M: usize>(
    e_b: &Vector3<T>,
    m_mps: T,
    c_b_n: &Matrix3<T>,
    v_n: &Vector3<T>,
) -> (State<T, M>, T) {
    let a = c_b_n * e_b;
    let a_x_v = a.cross(v_n);
    let mut h = State::<T, M>::zeros();
    for (k, (ak, axk)) in a.iter().zip(a_x_v.iter()).enumerate() {
        for (i, v) in [(I_V + k, *ak), (I_PHI + k, *axk)] {
            if let Some(x) = h.get_mut(i) {
                *x = v;
            }
        }
    }
    (h, m_mps - a.dot(v_n))
}

/// A measurement of the base's velocity along `e_b`: `value = gain (e_b .
/// v_b) + sum_k aux[k] dx[N + k] + noise`, `v_b` the base's velocity in
/// `b` (m/s), `dx[N + k]` a host's own error states ([`crate::eskf::AUX_MAX`]:
/// a mounting's angle moving `e_b`, an odometer's scale in `gain`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaseVelocity<T: Real> {
    /// The unit axis in `b`.
    pub e_b: Vector3<T>,
    /// The measured value, m/s (0 for a constraint).
    pub value_mps: T,
    /// Its 1-sigma, m/s.
    pub sigma_mps: T,
    /// The measurement's gain on `e_b . v_b` (1: a constraint; `1 + k` an
    /// odometer of scale error `k`).
    pub gain: T,
    /// The measurement's derivative by each host state, m/s per unit.
    pub aux: [T; AUX_MAX],
}

impl<T: Real> BaseVelocity<T> {
    /// A velocity along `e_b` measured as `value_mps` to `sigma_mps`, with
    /// no gain and no host states.
    pub fn plain(e_b: Vector3<T>, value_mps: T, sigma_mps: T) -> Self {
        Self {
            e_b,
            value_mps,
            sigma_mps,
            gain: T::one(),
            aux: [T::zero(); AUX_MAX],
        }
    }

    /// `(h, z)` with the base at `c_b_n` moving at `v_n` (NED, m/s).
    pub fn row<const M: usize>(&self, c_b_n: &Matrix3<T>, v_n: &Vector3<T>) -> (State<T, M>, T) {
        let (h, z) = velocity_b_row::<T, M>(&self.e_b, T::zero(), c_b_n, v_n);
        let mut h = h * self.gain;
        for (k, a) in self.aux.iter().enumerate() {
            if let Some(x) = h.get_mut(N + k) {
                *x = *a;
            }
        }
        (h, self.value_mps + z * self.gain)
    }
}

/// The forward axis is read off the filter's velocity in `b` only at this
/// speed or more, m/s: the velocity's direction is then known to its
/// 1-sigma over it (0.05 m/s / 5 m/s: 0.6 deg).
pub const FORWARD_MIN_SPEED_MPS: f64 = 5.0;
/// ... and while the base turns slower than this, rad/s (1 deg/s: a
/// straight road; the slip of a turn and the lever arm stay below 0.2
/// deg).
pub const FORWARD_MAX_RATE_RADPS: f64 = 0.017_453;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::quat_to_dcm;
    use nalgebra::{Quaternion, UnitQuaternion};

    #[test]
    fn the_row_is_the_measurement_s_derivative() {
        // A closed-form check by finite differences: perturb the velocity
        // and the attitude (c_b_n true = (I + [phi x]) c_b_n est) and the
        // predicted measurement changes by h . dx to second order.
        let q = UnitQuaternion::from_euler_angles(0.1, -0.2, 2.0);
        let c = quat_to_dcm(&Quaternion::from(q.coords));
        let v = Vector3::new(12.0, -5.0, 0.4);
        let e = Vector3::new(0.3, -0.8, 0.5).normalize();
        let (h, z0) = velocity_b_row::<f64, { crate::eskf::N }>(&e, 0.0, &c, &v);
        let dv = Vector3::new(1e-4, -2e-4, 3e-5);
        let phi = Vector3::new(2e-5, 1e-5, -3e-5);
        let skew = Matrix3::new(0.0, -phi.z, phi.y, phi.z, 0.0, -phi.x, -phi.y, phi.x, 0.0);
        let c_true = (Matrix3::identity() + skew) * c;
        let m_true = e.dot(&(c_true.transpose() * (v + dv)));
        let mut dx = State::<f64>::zeros();
        dx.fixed_rows_mut::<3>(I_V).copy_from(&dv);
        dx.fixed_rows_mut::<3>(I_PHI).copy_from(&phi);
        // z = m - e.(c^T v): with m the true value, z = h dx + O(|dx|^2)
        // (|dx|^2 x |v|: 1e-8 x 13 = 1.3e-7 m/s at most).
        let z = m_true + z0;
        assert!((z - h.dot(&dx)).abs() < 2e-7, "{} {}", z, h.dot(&dx));
    }

    #[test]
    fn the_sigma_grows_in_turns_and_is_off_where_the_car_slides_or_stands() {
        let straight = nhc_sigma_mps(20.0, 0.0, NHC_LEVER_M, NHC_SLIP_RAD_PER_MPS2).unwrap();
        assert!((straight - NHC_SIGMA_MPS).abs() < 1e-12);
        // 20 m/s at 5 deg/s: 1.75 m/s^2 lateral.
        let turn = nhc_sigma_mps(20.0, 5f64.to_radians(), 0.0, NHC_SLIP_RAD_PER_MPS2).unwrap();
        assert!(turn > 2.0 * straight, "{turn}");
        // The lever's part: 1.5 m at 5 deg/s is 0.13 m/s, in quadrature.
        let with_lever =
            nhc_sigma_mps(20.0, 5f64.to_radians(), NHC_LEVER_M, NHC_SLIP_RAD_PER_MPS2).unwrap();
        let lever = NHC_LEVER_M * 5f64.to_radians();
        assert!((with_lever.powi(2) - turn.powi(2) - lever.powi(2)).abs() < 1e-12);
        assert_eq!(nhc_sigma_mps(20.0, 15f64.to_radians(), 0.0, 0.0), None);
        assert_eq!(nhc_sigma_mps(0.5, 0.0, 0.0, 0.0), None);
        assert_eq!(nhc_sigma_mps(f64::NAN, 0.0, 0.0, 0.0), None);
    }

    #[test]
    fn across_completes_an_orthonormal_triad() {
        for x in [
            Vector3::<f64>::x(),
            -Vector3::z(),
            Vector3::new(-1.0, 0.1, 0.2).normalize(),
        ] {
            let [a, b] = across(&x);
            for (p, q) in [(a, b), (a, x), (b, x)] {
                assert!(p.dot(&q).abs() < 1e-12);
            }
            assert!((a.norm() - 1.0).abs() < 1e-12 && (b.norm() - 1.0).abs() < 1e-12);
        }
    }
}

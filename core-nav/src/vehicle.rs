//! What a land vehicle knows about its own motion, as measurements for the
//! aided navigator ([`crate::aided::AidedNav::update_base_velocity`]):
//!
//! - **It does not slide sideways or leave the road** (non-holonomic
//!   constraints, Sukkarieh 2000; Groves 2nd ed. Sec. 15.4.1): the
//!   velocity of the point that does not slip lies along the vehicle's
//!   forward axis, so its two components across that axis are zero, to
//!   within [`nhc_sigma_mps`].
//! - **Where its forward axis is in the base's frame**: the recording's
//!   `b` is the vehicle's body only when the IMU was mounted square or the
//!   import turned it; otherwise [`ForwardFinder`] finds the axis from the
//!   aided solution's velocity in `b` on straight stretches.
//!
//! Frames: `b` the base (the table's, or the IMU's when no table), `n`
//! local NED. The constraint is on the forward axis only: the mounting's
//! roll about it does not enter (both cross components are zero with one
//! sigma), so an IMU upside down needs no more than its forward axis.
//!
//! The measurement of the base's velocity along a unit vector `e_b` is
//! `z = m - e_b . (c_n_b v_n) = a . dv + (a x v_n) . phi + noise`, `a =
//! c_b_n e_b` (the error state's conventions: [`crate::eskf`]).

use crate::eskf::{State, I_PHI, I_V};
use crate::real::Real;
use nalgebra::{Matrix3, Vector3};

/// The cross velocities' 1-sigma on a straight road, m/s: a car body's
/// bounce on its suspension (1-1.5 Hz at a centimetre: 0.06-0.09 m/s) and
/// its tyres' slip in gentle driving.
pub const NHC_SIGMA_MPS: f64 = 0.1;
/// The tyres' slip angle per lateral acceleration, rad per m/s^2 (a
/// passenger car's cornering compliance, about 0.3 deg per m/s^2).
pub const NHC_SLIP_RAD_PER_MPS2: f64 = 0.005;
/// The IMU's distance from the point that does not slide sideways (the
/// rear axle's centre), m: unknown on a log, taken as a car's half
/// wheelbase; a turn's rate times it is a lateral velocity.
pub const NHC_LEVER_M: f64 = 1.5;
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
/// at `rate_radps` (rad/s, its rotation relative to the ground), with the
/// forward axis known to `sigma_axis_rad` across that component (1-sigma,
/// rad: its yaw for the lateral one, its pitch for the vertical): the
/// road's [`NHC_SIGMA_MPS`], the slip of a turn's lateral acceleration
/// `speed rate`, the lever arm's `rate` [`NHC_LEVER_M`] and the axis's own
/// error times the speed, in quadrature. `None` where the constraint does
/// not hold: below [`NHC_MIN_SPEED_MPS`], above [`NHC_MAX_LATERAL_MPS2`],
/// a non-finite input, or the axis's term above the road's: that error is
/// one constant, and updates repeated every [`NHC_EVERY_S`] as if it were
/// white would average it away (on a real car with the axis's yaw known
/// to 10 deg, the constraints turned a 0.9 m outage into 5.4 m, the
/// heading's drift put into the velocity).
pub fn nhc_sigma_mps(speed_mps: f64, rate_radps: f64, sigma_axis_rad: f64) -> Option<f64> {
    let lateral = speed_mps * rate_radps.abs();
    let ok = speed_mps.is_finite() && lateral.is_finite() && sigma_axis_rad.is_finite();
    let axis = speed_mps * sigma_axis_rad;
    if !ok
        || speed_mps < NHC_MIN_SPEED_MPS
        || lateral > NHC_MAX_LATERAL_MPS2
        || axis > NHC_SIGMA_MPS
    {
        return None;
    }
    let slip = speed_mps * NHC_SLIP_RAD_PER_MPS2 * lateral;
    let lever = NHC_LEVER_M * rate_radps.abs();
    Some(libm::sqrt(
        NHC_SIGMA_MPS * NHC_SIGMA_MPS + slip * slip + lever * lever + axis * axis,
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
pub fn velocity_b_row<T: Real>(
    e_b: &Vector3<T>,
    m_mps: T,
    c_b_n: &Matrix3<T>,
    v_n: &Vector3<T>,
) -> (State<T>, T) {
    let a = c_b_n * e_b;
    let a_x_v = a.cross(v_n);
    let mut h = State::<T>::zeros();
    for (k, (ak, axk)) in a.iter().zip(a_x_v.iter()).enumerate() {
        for (i, v) in [(I_V + k, *ak), (I_PHI + k, *axk)] {
            if let Some(x) = h.get_mut(i) {
                *x = v;
            }
        }
    }
    (h, m_mps - a.dot(v_n))
}

/// The vehicle's forward axis in `b`, found from the data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Forward {
    /// The unit forward axis in `b`.
    pub x_b: [f64; 3],
    /// Its yaw in `b` (about `b`'s z, from `b`'s x), rad.
    pub yaw_rad: f64,
    /// Its pitch in `b` (up from `b`'s x-y plane), rad.
    pub pitch_rad: f64,
    /// 1-sigma of the yaw, rad.
    pub sigma_yaw_rad: f64,
    /// 1-sigma of the pitch, rad.
    pub sigma_pitch_rad: f64,
    /// Straight-driving samples it was found from (one a second).
    pub samples: u32,
}

impl Forward {
    /// The axis's larger 1-sigma, rad.
    pub fn sigma_rad(&self) -> f64 {
        self.sigma_yaw_rad.max(self.sigma_pitch_rad)
    }
}

/// Finds the vehicle's forward axis in `b` from the aided solution's
/// velocity in `b` while the vehicle drives straight: its direction, one
/// sample a second (a car's slip and bounce decorrelate within it),
/// averaged. The 1-sigma is the samples' scatter over the square root of
/// their number and, in quadrature, what does not average down: the
/// filter's own heading (for the yaw) and pitch (for the pitch) 1-sigma,
/// which turn every sample alike, and its velocity's 1-sigma over the
/// speed (its errors are correlated over many seconds).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ForwardFinder {
    n: u32,
    last_t_s: Option<f64>,
    yaw0: f64,
    mean: [f64; 2],
    m2: [f64; 2],
    filter_var: [f64; 2],
}

/// A sample counts only at this speed or more, m/s: the velocity's
/// direction is then known to its 1-sigma over it (0.05 m/s / 5 m/s: 0.6
/// deg).
pub const FORWARD_MIN_SPEED_MPS: f64 = 5.0;
/// ... and while the base turns slower than this, rad/s (1 deg/s: a
/// straight road; the slip of a turn and the lever arm stay below 0.2
/// deg).
pub const FORWARD_MAX_RATE_RADPS: f64 = 0.017_453;
/// Samples before the axis is used (20 s of straight driving).
pub const FORWARD_MIN_SAMPLES: u32 = 20;

impl ForwardFinder {
    /// An empty finder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Offers the solution at `t_s`: the base's velocity `v_b` (m/s, in
    /// `b`), its rotation rate relative to the ground (rad/s), its
    /// velocity's 1-sigma (m/s, the largest axis) and the filter's heading
    /// and pitch 1-sigma (rad). Whether it was taken.
    pub fn offer(
        &mut self,
        t_s: f64,
        v_b: &Vector3<f64>,
        rate_radps: f64,
        sigma_v_mps: f64,
        sigma_heading_pitch_rad: [f64; 2],
    ) -> bool {
        let speed = v_b.norm();
        let spaced = self.last_t_s.is_none_or(|l| t_s - l >= 1.0);
        let finite = sigma_heading_pitch_rad.iter().all(|s| s.is_finite());
        if !(spaced && finite && speed.is_finite() && sigma_v_mps.is_finite())
            || speed < FORWARD_MIN_SPEED_MPS
            || rate_radps.abs() > FORWARD_MAX_RATE_RADPS
            || sigma_v_mps > 0.05 * speed
        {
            return false;
        }
        self.last_t_s = Some(t_s);
        let u = v_b / speed;
        let yaw = libm::atan2(u.y, u.x);
        if self.n == 0 {
            self.yaw0 = yaw;
        }
        let dyaw = wrap(yaw - self.yaw0);
        let pitch = libm::asin((-u.z).clamp(-1.0, 1.0));
        self.n = self.n.saturating_add(1);
        let n = f64::from(self.n);
        for (k, x) in [dyaw, pitch].into_iter().enumerate() {
            if let (Some(m), Some(m2), Some(fv), Some(s)) = (
                self.mean.get_mut(k),
                self.m2.get_mut(k),
                self.filter_var.get_mut(k),
                sigma_heading_pitch_rad.get(k),
            ) {
                let d = x - *m;
                *m += d / n;
                *m2 += d * (x - *m);
                let dir = sigma_v_mps / speed;
                *fv += (s * s + dir * dir - *fv) / n;
            }
        }
        true
    }

    /// The axis, once [`FORWARD_MIN_SAMPLES`] samples are in.
    pub fn forward(&self) -> Option<Forward> {
        if self.n < FORWARD_MIN_SAMPLES {
            return None;
        }
        let n = f64::from(self.n);
        let [my, mp] = self.mean;
        let sigma = |k: usize| {
            let m2 = self.m2.get(k).copied().unwrap_or(0.0);
            let fv = self.filter_var.get(k).copied().unwrap_or(0.0);
            libm::sqrt(m2 / (n - 1.0) / n + fv)
        };
        let yaw = wrap(self.yaw0 + my);
        let (sy, cy, sp, cp) = (libm::sin(yaw), libm::cos(yaw), libm::sin(mp), libm::cos(mp));
        Some(Forward {
            x_b: [cp * cy, cp * sy, -sp],
            yaw_rad: yaw,
            pitch_rad: mp,
            sigma_yaw_rad: sigma(0),
            sigma_pitch_rad: sigma(1),
            samples: self.n,
        })
    }
}

/// `x` into `(-pi, pi]`.
fn wrap(x: f64) -> f64 {
    let tau = core::f64::consts::TAU;
    let y = x - tau * libm::floor(x / tau + 0.5);
    if y <= -core::f64::consts::PI {
        y + tau
    } else {
        y
    }
}

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
        let (h, z0) = velocity_b_row(&e, 0.0, &c, &v);
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
        let straight = nhc_sigma_mps(20.0, 0.0, 0.0).unwrap();
        assert!((straight - NHC_SIGMA_MPS).abs() < 1e-12);
        // 20 m/s at 5 deg/s: 1.75 m/s^2 lateral.
        let turn = nhc_sigma_mps(20.0, 5f64.to_radians(), 0.0).unwrap();
        assert!(turn > 2.0 * straight, "{turn}");
        assert_eq!(nhc_sigma_mps(20.0, 15f64.to_radians(), 0.0), None);
        assert_eq!(nhc_sigma_mps(0.5, 0.0, 0.0), None);
        assert_eq!(nhc_sigma_mps(f64::NAN, 0.0, 0.0), None);
        // The axis known to 0.2 deg at 20 m/s: 0.07 m/s, used; to 1 deg:
        // 0.35 m/s, above the road's, not.
        assert!(nhc_sigma_mps(20.0, 0.0, 0.2f64.to_radians()).is_some());
        assert_eq!(nhc_sigma_mps(20.0, 0.0, 1f64.to_radians()), None);
    }

    #[test]
    fn the_finder_recovers_an_upside_down_yawed_axis_within_its_sigma() {
        // Forward axis yawed 185 deg and pitched -2 deg in b, samples with
        // 0.5 deg of scatter (a deterministic spread), the filter's heading
        // known to 0.2 deg.
        let (yaw, pitch) = (185f64.to_radians(), (-2f64).to_radians());
        let mut f = ForwardFinder::new();
        for i in 0..60 {
            let d = 0.5f64.to_radians() * libm::sin(f64::from(i) * 1.7);
            let (y, p) = (yaw + d, pitch - 0.5 * d);
            let u = Vector3::new(p.cos() * y.cos(), p.cos() * y.sin(), -p.sin());
            let sig = [0.2f64.to_radians(); 2];
            assert!(f.offer(f64::from(i), &(u * 15.0), 0.0, 0.1, sig));
            // A second offer within the second is not taken.
            assert!(!f.offer(f64::from(i) + 0.5, &(u * 15.0), 0.0, 0.1, sig));
        }
        let fw = f.forward().unwrap();
        assert!(
            wrap(fw.yaw_rad - yaw).abs() < 3.0 * fw.sigma_yaw_rad,
            "{fw:?}"
        );
        assert!(
            (fw.pitch_rad - pitch).abs() < 3.0 * fw.sigma_pitch_rad,
            "{fw:?}"
        );
        // The filter's 0.2 deg and its velocity's 0.1 / 15 m/s (0.38 deg)
        // dominate the 60 samples' 0.05 deg: 0.43 deg.
        let expect = 0.2f64.to_radians().hypot(0.1 / 15.0);
        assert!(
            fw.sigma_yaw_rad > expect && fw.sigma_yaw_rad < 1.05 * expect,
            "{fw:?}"
        );
        // Too slow, turning, or an unaided velocity: not taken.
        let mut g = ForwardFinder::new();
        let v = Vector3::new(10.0, 0.0, 0.0);
        assert!(!g.offer(0.0, &(v * 0.3), 0.0, 0.1, [0.0; 2]));
        assert!(!g.offer(1.0, &v, 0.1, 0.1, [0.0; 2]));
        assert!(!g.offer(2.0, &v, 0.0, 2.0, [0.0; 2]));
        assert_eq!(g.forward(), None);
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

//! Attitude toolkit: quaternions, direction cosine matrices, ZYX Euler angles
//! and rotation vectors.
//!
//! Conventions (see the crate docs): `q_a_b` / `c_a_b` map a vector expressed
//! in frame `a` into frame `b`: `v_b = c_a_b * v_a = q_a_b ⊗ v_a ⊗ q_a_b*`.
//! Quaternions are Hamilton (`ijk = -1`), scalar first in
//! `Quaternion::new(w, x, y, z)`. Euler angles are ZYX: `c_b_n = Rz(heading)
//! Ry(pitch) Rx(roll)`, rad.
//!
//! Sources: Groves 2nd ed. Sec. 2.2 (Eq. 2.15, 2.22, 2.34-2.35);
//! Savage, *Strapdown Analytics* 2nd ed., Sec. 3.2.2 (rotation vector).

use crate::real::{sin_cos, sinc_omc_sq, Real};
use nalgebra::{Matrix3, Quaternion, Vector3};

/// A unit quaternion written as `1 + d`: `w_m1 = w - 1` and the vector part.
/// Small rotations keep their full precision this way (`w - 1 ~ -|phi|^2/8`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeltaQuat<T: Real> {
    /// `w - 1`.
    pub w_m1: T,
    /// Vector part `(x, y, z)`.
    pub v: Vector3<T>,
}

impl<T: Real> DeltaQuat<T> {
    /// The quaternion `1 + d`.
    pub fn to_quat(&self) -> Quaternion<T> {
        Quaternion::new(T::one() + self.w_m1, self.v.x, self.v.y, self.v.z)
    }

    /// The quaternion `d` (so the rotation is `1 + d`).
    pub fn d(&self) -> Quaternion<T> {
        Quaternion::new(self.w_m1, self.v.x, self.v.y, self.v.z)
    }
}

/// Rotation vector `phi` (rad, axis times angle) to the quaternion
/// `exp(phi/2)`, as `1 + d`. Series (no libm trigonometry) for
/// `|phi| <= pi/2`, which covers every per-step rotation; a square root and a
/// reduced series above that.
pub fn rotvec_to_delta<T: Real>(phi: &Vector3<T>) -> DeltaQuat<T> {
    let a2 = phi.norm_squared();
    let half_a2 = a2 * T::lit(0.25); // (|phi|/2)^2
    if half_a2 <= T::lit(core::f64::consts::FRAC_PI_4 * core::f64::consts::FRAC_PI_4) {
        let (sinc, omc) = sinc_omc_sq(half_a2);
        DeltaQuat {
            w_m1: -omc,
            v: phi * (sinc * T::lit(0.5)),
        }
    } else {
        let a = a2.sqrt_cr();
        let (s, c) = sin_cos(a * T::lit(0.5));
        DeltaQuat {
            w_m1: c - T::one(),
            v: phi * (s / a),
        }
    }
}

/// Rotation vector to unit quaternion, `exp(phi/2)`.
pub fn rotvec_to_quat<T: Real>(phi: &Vector3<T>) -> Quaternion<T> {
    rotvec_to_delta(phi).to_quat()
}

/// Unit quaternion to rotation vector (rad), angle in `[0, pi]`. The
/// quaternion need not be normalised; `q` and `-q` give the same result.
pub fn quat_to_rotvec<T: Real>(q: &Quaternion<T>) -> Vector3<T> {
    let (mut w, mut v) = (q.w, q.imag());
    if w < T::zero() {
        w = -w;
        v = -v;
    }
    let s = v.norm();
    if s <= T::default_epsilon() * w {
        // 2 atan(s/w)/s -> 2/w as s -> 0 (error s^2/(3w^2) below eps).
        return v * (T::lit(2.0) / w);
    }
    v * (T::lit(2.0) * s.atan2(w) / s)
}

/// Quaternion to DCM: `c_a_b` from `q_a_b` (Groves Eq. 2.34). The quaternion
/// must be normalised.
pub fn quat_to_dcm<T: Real>(q: &Quaternion<T>) -> Matrix3<T> {
    let (w, x, y, z) = (q.w, q.i, q.j, q.k);
    let two = T::lit(2.0);
    let (ww, xx, yy, zz) = (w * w, x * x, y * y, z * z);
    let (xy, xz, yz) = (x * y, x * z, y * z);
    let (wx, wy, wz) = (w * x, w * y, w * z);
    Matrix3::new(
        ww + xx - yy - zz,
        two * (xy - wz),
        two * (xz + wy),
        two * (xy + wz),
        ww - xx + yy - zz,
        two * (yz - wx),
        two * (xz - wy),
        two * (yz + wx),
        ww - xx - yy + zz,
    )
}

/// DCM to quaternion (Shepperd's method: the largest of the four diagonal
/// combinations is taken, so no precision is lost near 180 deg). `w >= 0`.
pub fn dcm_to_quat<T: Real>(c: &Matrix3<T>) -> Quaternion<T> {
    let m = |r: usize, k: usize| c.get((r, k)).copied().unwrap_or_else(T::zero);
    let (c00, c11, c22) = (m(0, 0), m(1, 1), m(2, 2));
    let tr = c00 + c11 + c22;
    let quarter = T::lit(0.25);
    let one = T::one();
    let q = if tr >= c00 && tr >= c11 && tr >= c22 {
        let w2 = (one + tr).sqrt_cr() * T::lit(2.0); // 4w
        Quaternion::new(
            quarter * w2,
            (m(2, 1) - m(1, 2)) / w2,
            (m(0, 2) - m(2, 0)) / w2,
            (m(1, 0) - m(0, 1)) / w2,
        )
    } else if c00 >= c11 && c00 >= c22 {
        let x4 = (one + c00 - c11 - c22).sqrt_cr() * T::lit(2.0);
        Quaternion::new(
            (m(2, 1) - m(1, 2)) / x4,
            quarter * x4,
            (m(0, 1) + m(1, 0)) / x4,
            (m(0, 2) + m(2, 0)) / x4,
        )
    } else if c11 >= c22 {
        let y4 = (one - c00 + c11 - c22).sqrt_cr() * T::lit(2.0);
        Quaternion::new(
            (m(0, 2) - m(2, 0)) / y4,
            (m(0, 1) + m(1, 0)) / y4,
            quarter * y4,
            (m(1, 2) + m(2, 1)) / y4,
        )
    } else {
        let z4 = (one - c00 - c11 + c22).sqrt_cr() * T::lit(2.0);
        Quaternion::new(
            (m(1, 0) - m(0, 1)) / z4,
            (m(0, 2) + m(2, 0)) / z4,
            (m(1, 2) + m(2, 1)) / z4,
            quarter * z4,
        )
    };
    if q.w < T::zero() {
        -q
    } else {
        q
    }
}

/// ZYX Euler angles of `b` in `n`, rad.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Euler<T: Real> {
    /// Rotation about x (third), rad.
    pub roll: T,
    /// Rotation about y (second), rad, in `[-pi/2, pi/2]`.
    pub pitch: T,
    /// Rotation about z (first), rad.
    pub heading: T,
}

impl<T: Real> Euler<T> {
    /// Euler angles from degrees (configuration boundary).
    pub fn from_deg(roll_deg: f64, pitch_deg: f64, heading_deg: f64) -> Self {
        Self {
            roll: T::lit(roll_deg.to_radians()),
            pitch: T::lit(pitch_deg.to_radians()),
            heading: T::lit(heading_deg.to_radians()),
        }
    }
}

/// ZYX Euler angles to `q_b_n` (Groves Eq. 2.22 as quaternions).
pub fn euler_to_quat<T: Real>(e: &Euler<T>) -> Quaternion<T> {
    let half = T::lit(0.5);
    let (sr, cr) = sin_cos(e.roll * half);
    let (sp, cp) = sin_cos(e.pitch * half);
    let (sh, ch) = sin_cos(e.heading * half);
    Quaternion::new(
        ch * cp * cr + sh * sp * sr,
        ch * cp * sr - sh * sp * cr,
        ch * sp * cr + sh * cp * sr,
        sh * cp * cr - ch * sp * sr,
    )
}

/// `c_b_n` to ZYX Euler angles (Groves Eq. 2.23), rad; heading in `(-pi, pi]`.
pub fn dcm_to_euler<T: Real>(c: &Matrix3<T>) -> Euler<T> {
    let m = |r: usize, k: usize| c.get((r, k)).copied().unwrap_or_else(T::zero);
    let s = (-m(2, 0)).max(-T::one()).min(T::one());
    Euler {
        roll: m(2, 1).atan2(m(2, 2)),
        pitch: s.asin(),
        heading: m(1, 0).atan2(m(0, 0)),
    }
}

/// `q_b_n` to ZYX Euler angles, rad.
pub fn quat_to_euler<T: Real>(q: &Quaternion<T>) -> Euler<T> {
    dcm_to_euler(&quat_to_dcm(q))
}

/// Rotates `v_a` into `b` with `q_a_b` (normalised): `v_b = q v q*`.
pub fn rotate<T: Real>(q: &Quaternion<T>, v: &Vector3<T>) -> Vector3<T> {
    // v + 2 u x (u x v + w v), u = vector part (Rodrigues form, 30 flops).
    let u = q.imag();
    let t = u.cross(v) * T::lit(2.0);
    v + t * q.w + u.cross(&t)
}

/// The skew-symmetric (cross-product) matrix `[v x]`.
pub fn skew<T: Real>(v: &Vector3<T>) -> Matrix3<T> {
    Matrix3::new(
        T::zero(),
        -v.z,
        v.y,
        v.z,
        T::zero(),
        -v.x,
        -v.y,
        v.x,
        T::zero(),
    )
}

/// The 1-sigma of roll, pitch and heading (rad) at `e` from the covariance
/// `p_phi` (rad^2) of the small rotation `phi` about north, east and down
/// that the aided filter carries (`c_b_n,true = (I + [phi x])
/// c_b_n,est`). For ZYX angles a rotation in `n` is `phi = A d(roll,
/// pitch, heading)` with `A`'s columns the roll axis `Rz(heading) Ry(pitch)
/// x`, the pitch axis `Rz(heading) y` and down; so the angles' covariance
/// is `A^-1 P A^-T` (singular only at pitch +-90 deg, where heading and
/// roll are one angle: NaN there).
pub fn euler_sigma<T: Real>(e: &Euler<T>, p_phi: &Matrix3<T>) -> [T; 3] {
    let (st, ct) = sin_cos(e.pitch);
    let (sp, cp) = sin_cos(e.heading);
    let z = T::zero();
    let a = Matrix3::new(cp * ct, -sp, z, sp * ct, cp, z, -st, z, T::one());
    match a.try_inverse() {
        Some(ai) => {
            let c = ai * p_phi * ai.transpose();
            [0, 1, 2].map(|i| c.get((i, i)).copied().unwrap_or(z).max(z).sqrt_cr())
        }
        None => [T::lit(f64::NAN); 3],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn euler_sigmas_follow_the_rotation_axes_closed_form() {
        let s = 0.01f64; // rad
        let close = |a: [f64; 3], b: [f64; 3]| (0..3).all(|i| (a[i] - b[i]).abs() < 1e-12);
        let e = |r: f64, p: f64, h: f64| Euler {
            roll: r,
            pitch: p,
            heading: h,
        };
        // Level, heading north: roll about north, pitch about east.
        let p = Matrix3::from_diagonal(&Vector3::new(s * s, 4.0 * s * s, 9.0 * s * s));
        assert!(close(
            euler_sigma(&e(0.0, 0.0, 0.0), &p),
            [s, 2.0 * s, 3.0 * s]
        ));
        // Heading east: roll about east, pitch about south.
        let east = euler_sigma(&e(0.0, 0.0, 90f64.to_radians()), &p);
        assert!(close(east, [2.0 * s, s, 3.0 * s]), "{east:?}");
        // Pitched 30 deg up, heading north: a rotation about north is
        // roll / cos(30) and heading tan(30) (roll's axis leans out of the
        // level plane); one about down is heading alone.
        let th = 30f64.to_radians();
        let pn = Matrix3::from_diagonal(&Vector3::new(s * s, 0.0, 0.0));
        let got = euler_sigma(&e(0.0, th, 0.0), &pn);
        assert!(close(got, [s / th.cos(), 0.0, s * th.tan()]), "{got:?}");
        let pd = Matrix3::from_diagonal(&Vector3::new(0.0, 0.0, s * s));
        assert!(close(euler_sigma(&e(0.0, th, 0.0), &pd), [0.0, 0.0, s]));
    }

    #[test]
    fn heading_90_maps_north_to_east() {
        let q = euler_to_quat(&Euler::<f64>::from_deg(0.0, 0.0, 90.0));
        let v = rotate(&q, &Vector3::new(1.0, 0.0, 0.0));
        assert!((v - Vector3::new(0.0, 1.0, 0.0)).norm() < 1e-15);
    }

    #[test]
    fn rotvec_exp_matches_closed_form_across_the_series_switch() {
        for k in 0..400 {
            let a = f64::from(k) * 0.01;
            let axis = Vector3::new(0.3, -0.5, 0.8).normalize();
            let q = rotvec_to_quat(&(axis * a));
            let (s, c) = crate::real::sin_cos(a / 2.0);
            let r = Quaternion::new(c, s * axis.x, s * axis.y, s * axis.z);
            assert!((q - r).norm() < 1e-15, "angle {a}: {}", (q - r).norm());
        }
    }
}

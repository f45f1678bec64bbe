//! The same physical run described in other axes: the sensor frame `s` and
//! the base frame `b` relabelled together by a signed permutation `P` (a
//! proper rotation taking each axis to plus or minus an axis), so that `s`
//! still coincides with `b` at table angle 0, as recording-v1 requires.
//!
//! - samples: `w_s' = P w_s`, `f_s' = P f_s`;
//! - the table axis: `k' = P k = sign e_j`: axis `j`, and the angle's sign
//!   flips with `sign` (`exp(theta [k' x]) = exp(sign theta [e_j x])`);
//! - the base attitude: `c_b'_n = c_b_n P^T`, written back as ZYX Euler.
//!
//! A diagnosis must not depend on the labelling: the relabelling test runs
//! every effect through these maps and asks for the same answer.

use crate::{err, Recording, RecordingError, TableRow};
use core_nav::attitude::{dcm_to_euler, euler_to_quat, quat_to_dcm, Euler};
use core_nav::table::Axis;
use nalgebra::{Matrix3, Vector3};
use std::path::Path;

/// A signed permutation of the three axes with determinant +1: row `i`
/// holds the old axis that becomes new axis `i`, with its sign.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisMap {
    /// `P`, entries in {-1, 0, 1}: `v' = P v`.
    pub p: Matrix3<f64>,
    /// A name for reports ("base rolled 180 deg").
    pub name: &'static str,
}

impl AxisMap {
    /// The base (and the sensor on it) rolled 180 deg about x.
    pub const ROLL_180: AxisMap = AxisMap::new(
        [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]],
        "rolled 180 deg",
    );
    /// The base pitched 90 deg about y: new x = old -z, new z = old x.
    pub const PITCH_90: AxisMap = AxisMap::new(
        [[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]],
        "pitched 90 deg",
    );
    /// The base turned 90 deg in heading about z: new x = old y, new y =
    /// old -x.
    pub const HEADING_90: AxisMap = AxisMap::new(
        [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
        "turned 90 deg in heading",
    );
    /// A cyclic permutation of the sensor axes (x <- y <- z).
    pub const CYCLE: AxisMap = AxisMap::new(
        [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
        "axes cycled (x, y, z) <- (y, z, x)",
    );
    /// A permutation with sign flips: new (x, y, z) = old (-z, -y, -x).
    pub const SWAP_FLIP: AxisMap = AxisMap::new(
        [[0.0, 0.0, -1.0], [0.0, -1.0, 0.0], [-1.0, 0.0, 0.0]],
        "axes swapped with sign flips (x, y, z) <- (-z, -y, -x)",
    );
    /// The fixed set the relabelling test runs.
    pub const SET: [AxisMap; 5] = [
        AxisMap::ROLL_180,
        AxisMap::PITCH_90,
        AxisMap::HEADING_90,
        AxisMap::CYCLE,
        AxisMap::SWAP_FLIP,
    ];

    const fn new(rows: [[f64; 3]; 3], name: &'static str) -> Self {
        let [[a, b, c], [d, e, f], [g, h, i]] = rows;
        Self {
            p: Matrix3::new(a, b, c, d, e, f, g, h, i),
            name,
        }
    }

    /// Whether `p` is a signed permutation with determinant +1.
    pub fn is_proper(&self) -> bool {
        let entries_ok = self.p.iter().all(|x| [-1.0, 0.0, 1.0].contains(x));
        let rows_ok = self
            .p
            .row_iter()
            .all(|r| r.iter().filter(|x| **x != 0.0).count() == 1);
        entries_ok && rows_ok && (self.p.determinant() - 1.0).abs() < 1e-12
    }

    /// The new axis and sign of old basis axis `a`: `P e_a = sign e_j`.
    pub fn axis(&self, a: Axis) -> (Axis, f64) {
        let v = self.p * a.unit::<f64>();
        let j = v.iamax();
        let axis = [Axis::X, Axis::Y, Axis::Z]
            .get(j)
            .copied()
            .unwrap_or(Axis::Z);
        (axis, v[j].signum())
    }

    /// Vector `v` (old axes) in the new axes.
    pub fn vector(&self, v: &Vector3<f64>) -> Vector3<f64> {
        self.p * v
    }
}

/// ZYX Euler angles of `c_b_n` that compose back to it, also at pitch
/// +-90 deg (where core-nav's formula leaves roll and heading to residue:
/// there the heading is set to 0 and the roll carries the rotation).
fn euler_of(c: &Matrix3<f64>) -> Euler<f64> {
    let e = dcm_to_euler(c);
    if (quat_to_dcm(&euler_to_quat(&e)) - c).amax() < 1e-9 {
        return e;
    }
    let s = -c[(2, 0)];
    Euler {
        roll: (s.signum() * c[(0, 1)]).atan2(c[(1, 1)]),
        pitch: s.signum() * core::f64::consts::FRAC_PI_2,
        heading: 0.0,
    }
}

/// `rec` relabelled by `map`.
///
/// # Errors
/// A map that is not a proper signed permutation; a moving-base recording
/// (its truth and lever arms are not relabelled here).
pub fn relabel(rec: &Recording, map: &AxisMap) -> Result<Recording, RecordingError> {
    let here = Path::new("relabel");
    if !map.is_proper() {
        return Err(err(
            here,
            None,
            format!("{}: not a signed permutation with determinant +1", map.name),
        ));
    }
    if rec.moving.is_some() {
        return Err(err(
            here,
            None,
            "a moving-base recording is not relabelled (its truth and lever arms would need it)",
        ));
    }
    let mut out = rec.clone();
    let turn = |v: [f64; 3]| -> [f64; 3] { map.vector(&Vector3::from(v)).into() };
    for r in &mut out.imu {
        r.gyro_radps = turn(r.gyro_radps);
        r.accel_mps2 = turn(r.accel_mps2); // NaN stays NaN (gyro-only)
    }
    let (axis, sign) = map.axis(rec.meta.axis);
    out.meta.axis = axis;
    out.table = rec
        .table
        .iter()
        .map(|t| TableRow {
            t_s: t.t_s,
            angle_rad: sign * t.angle_rad,
        })
        .collect();
    let c_b_n = core_nav::site::c_b_n(&rec.meta.base());
    let e = euler_of(&(c_b_n * map.p.transpose()));
    out.meta.roll_deg = e.roll.to_degrees();
    out.meta.pitch_deg = e.pitch.to_degrees();
    out.meta.heading_deg = e.heading.to_degrees();
    out.meta.description = Some(format!(
        "{} [relabelled: {}]",
        rec.meta.description.as_deref().unwrap_or(""),
        map.name
    ));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_map_is_proper_and_keeps_the_physics() {
        // The gravity and earth rate a level sensor feels, relabelled, equal
        // what the relabelled base attitude predicts: P C_n_b v_n.
        let base = Euler::from_deg(-90.0, 3.5, 30.0);
        let c_b_n = core_nav::site::c_b_n(&base);
        let g_n = Vector3::new(0.1, -0.2, 9.8);
        for m in AxisMap::SET {
            assert!(m.is_proper(), "{}", m.name);
            let c2 = c_b_n * m.p.transpose();
            let e = euler_of(&c2);
            let back = quat_to_dcm(&euler_to_quat(&e));
            // 1e-12: a few ulps of the Euler round trip.
            assert!((back - c2).amax() < 1e-12, "{}", m.name);
            let old_s = c_b_n.transpose() * g_n;
            assert!((m.p * old_s - back.transpose() * g_n).amax() < 1e-12);
        }
        let not = AxisMap::new(
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]],
            "mirror",
        );
        assert!(!not.is_proper());
    }

    #[test]
    fn the_table_axis_and_angle_follow_the_map() {
        assert_eq!(AxisMap::ROLL_180.axis(Axis::Z), (Axis::Z, -1.0));
        assert_eq!(AxisMap::CYCLE.axis(Axis::Z), (Axis::Y, 1.0));
        assert_eq!(AxisMap::PITCH_90.axis(Axis::Z), (Axis::X, -1.0));
    }
}

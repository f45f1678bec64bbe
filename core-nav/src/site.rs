//! The site and the static base: the one home of "where the run happens"
//! (gravity, earth rate), "how the base sits" (`c_b_n`) and "what a perfect
//! IMU on the table reads" (the ideal sensor). The simulator
//! (`hal-sim`), calibration, diagnose and the firmware all call these.
//!
//! recording-v1, static base, table turning `s` relative to `b`:
//!
//! ```text
//! w_is_s = c_n_s w_ie_n + w_bs_s          (w_bs_s = theta_dot k for a perfect table)
//! f_s    = c_n_s [0, 0, -g]
//! ```

use crate::attitude::{euler_to_quat, quat_to_dcm, Euler};
use crate::calib::EarthModel;
use crate::earth::{earth_rate_n, normal_gravity, GeoPoint};
use crate::table::Axis;
use nalgebra::{Matrix3, Vector3};

/// Where a run happens (host and configuration side, f64).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Site {
    /// Latitude as given, deg (kept as given for the recording's meta).
    pub lat_deg: f64,
    /// Position (longitude 0 unless set).
    pub origin: GeoPoint,
    /// Gravity magnitude, m/s^2 (WGS-84 normal gravity unless given).
    pub gravity_mps2: f64,
    /// Multiplies the earth rate the sensor feels (1: the real earth; 0: a
    /// model without it).
    pub earth_rate_scale: f64,
}

impl Site {
    /// A site at `lat_deg` (deg) and `height_m` (m above the ellipsoid) with
    /// WGS-84 normal gravity and the real earth rate.
    pub fn new(lat_deg: f64, height_m: f64) -> Self {
        let origin = GeoPoint::from_deg(lat_deg, 0.0, height_m);
        let s = crate::real::sin_cos(origin.lat_rad).0;
        Self {
            lat_deg,
            origin,
            gravity_mps2: normal_gravity(s * s, height_m),
            earth_rate_scale: 1.0,
        }
    }

    /// The same site with a measured gravity magnitude (m/s^2) when one is
    /// given.
    pub fn with_gravity(mut self, gravity_mps2: Option<f64>) -> Self {
        if let Some(g) = gravity_mps2 {
            self.gravity_mps2 = g;
        }
        self
    }

    /// Earth rate in `n`, `w_ie_n`, rad/s (scaled by `earth_rate_scale`).
    pub fn w_ie_n(&self) -> Vector3<f64> {
        let l = self.origin.lat_rad;
        let (s, c) = crate::real::sin_cos(l);
        earth_rate_n(s, c) * self.earth_rate_scale
    }

    /// Specific force of a body at rest, in `n`: `[0, 0, -g]`, m/s^2.
    pub fn f_rest_n(&self) -> Vector3<f64> {
        Vector3::new(0.0, 0.0, -self.gravity_mps2)
    }

    /// What a perfect IMU whose axes are at `c_n_s` (the transpose of
    /// `c_s_n`) reads on a static base while its frame turns at `w_bs_s`
    /// (rad/s, in `s`) relative to the base: `(w_is_s rad/s, f_s m/s^2)`.
    pub fn ideal_imu(
        &self,
        c_n_s: &Matrix3<f64>,
        w_bs_s: &Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        self.at_rest().ideal_imu(c_n_s, w_bs_s)
    }

    /// What a body at rest here feels, in `n`: made once for many samples.
    pub fn at_rest(&self) -> AtRest {
        AtRest {
            w_ie_n: self.w_ie_n(),
            f_n: self.f_rest_n(),
        }
    }

    /// The earth model a calibration on this site uses (the full earth
    /// rate, whatever `earth_rate_scale` says: calibration corrects for the
    /// real earth).
    pub fn earth_model(&self, base: &Euler<f64>, axis: Axis) -> EarthModel {
        let (s, c) = crate::real::sin_cos(self.origin.lat_rad);
        EarthModel::Known {
            w_ie_n: earth_rate_n(s, c),
            c_b_n: c_b_n(base),
            axis,
        }
    }
}

/// What a body at rest on a [`Site`] feels, in `n` ([`Site::at_rest`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AtRest {
    /// Earth rate, rad/s ([`Site::w_ie_n`]).
    pub w_ie_n: Vector3<f64>,
    /// Specific force, m/s^2 ([`Site::f_rest_n`]).
    pub f_n: Vector3<f64>,
}

impl AtRest {
    /// [`Site::ideal_imu`]: `(w_is_s rad/s, f_s m/s^2)` for axes at
    /// `c_n_s` turning at `w_bs_s` (rad/s, in `s`) on the base.
    pub fn ideal_imu(
        &self,
        c_n_s: &Matrix3<f64>,
        w_bs_s: &Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        (c_n_s * self.w_ie_n + w_bs_s, c_n_s * self.f_n)
    }
}

/// The base attitude as a DCM `c_b_n` (maps `b` into `n`) from roll, pitch,
/// heading (rad, `Euler`).
pub fn c_b_n(base: &Euler<f64>) -> Matrix3<f64> {
    quat_to_dcm(&euler_to_quat(base))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_level_north_facing_imu_reads_gravity_up_and_the_earth_rate() {
        // Closed form at 45 deg N: w = Omega (cos lat, 0, -sin lat),
        // f = (0, 0, -g) in NED; the sensor axes are n.
        let site = Site::new(45.0, 0.0);
        let (w, f) = site.ideal_imu(&Matrix3::identity(), &Vector3::zeros());
        let om = crate::earth::EARTH_RATE_RADPS;
        let h = core::f64::consts::FRAC_1_SQRT_2;
        assert!((w - Vector3::new(om * h, 0.0, -om * h)).norm() < 1e-18);
        // Normal gravity at 45 deg (TR8350.2): 9.806199 m/s^2.
        assert!((f.z + 9.806_199).abs() < 2e-6, "{f}");
        let with = site.with_gravity(Some(9.8));
        assert_eq!(with.f_rest_n().z, -9.8);
    }

    #[test]
    fn heading_turns_the_earth_rate_into_the_body() {
        // Heading 90 deg (facing east): north is the body's -y.
        let base = Euler::<f64>::from_deg(0.0, 0.0, 90.0);
        let site = Site::new(0.0, 0.0);
        let (w, _) = site.ideal_imu(&c_b_n(&base).transpose(), &Vector3::zeros());
        let om = crate::earth::EARTH_RATE_RADPS;
        assert!((w - Vector3::new(0.0, -om, 0.0)).norm() < 1e-18, "{w}");
    }
}

//! The ideal world: exact earth rate and gravity at the site, a static base,
//! a table turning at a constant rate, an error-free IMU.
//!
//! `w_is_s = c_b_s(theta) c_n_b w_ie_n + theta_dot k`,
//! `f_s = c_b_s(theta) c_n_b [0, 0, -g]` (recording-v1).

use core_nav::attitude::{euler_to_quat, quat_to_dcm, Euler};
use core_nav::earth::{earth_rate_n, normal_gravity, GeoPoint};
use core_nav::strapdown::ImuSample;
use core_nav::table::Axis;
use nalgebra::{Matrix3, Rotation3, Unit, Vector3};

/// A static base with a constant-rate table and an ideal IMU.
#[derive(Clone, Debug)]
pub struct IdealWorld {
    /// Site.
    pub site: GeoPoint,
    /// Gravity magnitude at the site, m/s^2.
    pub gravity_mps2: f64,
    /// Base attitude in `n`.
    pub base: Euler<f64>,
    /// Table axis.
    pub axis: Axis,
    /// Table rate, rad/s (constant).
    pub rate_radps: f64,
    /// Table angle at t = 0, rad.
    pub theta0_rad: f64,
}

impl IdealWorld {
    /// A world at `site` with normal gravity, level north-facing base and a
    /// still table about z.
    pub fn new(site: GeoPoint) -> Self {
        let s = libm::sin(site.lat_rad);
        Self {
            site,
            gravity_mps2: normal_gravity(s * s, site.height_m),
            base: Euler::default(),
            axis: Axis::Z,
            rate_radps: 0.0,
            theta0_rad: 0.0,
        }
    }

    /// Table angle at `t_s` seconds, rad (unwrapped).
    pub fn theta(&self, t_s: f64) -> f64 {
        self.theta0_rad + self.rate_radps * t_s
    }

    /// `c_s_b(theta)`.
    pub fn c_s_b(&self, theta: f64) -> Matrix3<f64> {
        let k = Unit::new_normalize(self.axis.unit::<f64>());
        *Rotation3::from_axis_angle(&k, theta).matrix()
    }

    /// `c_b_n` from the base attitude.
    pub fn c_b_n(&self) -> Matrix3<f64> {
        quat_to_dcm(&euler_to_quat(&self.base))
    }

    /// The ideal IMU sample at `t_us`.
    pub fn sample(&self, t_us: u64) -> ImuSample<f64> {
        let t = t_us as f64 * 1e-6;
        let c_n_s = (self.c_b_n() * self.c_s_b(self.theta(t))).transpose();
        let (s, c) = (libm::sin(self.site.lat_rad), libm::cos(self.site.lat_rad));
        let w_ie_n = earth_rate_n(s, c);
        ImuSample {
            t_us,
            w_is_s: c_n_s * w_ie_n + self.axis.unit::<f64>() * self.rate_radps,
            f_s: c_n_s * Vector3::new(0.0, 0.0, -self.gravity_mps2),
        }
    }
}

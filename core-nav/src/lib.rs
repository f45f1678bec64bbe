//! # core-nav: the navigation core of rins
//!
//! `no_std`, no heap, no panics outside tests. Generic over the float type
//! ([`Real`]): `f32` on the Cortex-M4F, `f64` as the host twin, the same code.
//!
//! ## Frames (the one place they are defined; `shared/spec/recording-v1.md`)
//!
//! | frame | axes |
//! | --- | --- |
//! | `n` | local level **NED**: x north, y east, z down |
//! | `b` | the base the table stands on: x forward, y right, z down |
//! | `s` | the IMU's own axes (what the sensor measures in) |
//! | `e` | ECEF (WGS-84) |
//! | `i` | inertial |
//!
//! The table turns `s` relative to `b` about the unit vector `k` (same in
//! `b` and `s`): `c_s_b = exp(theta [k x])`, a positive `theta` is a
//! right-handed rotation of the sensor about `+k`; at `theta = 0`, `s = b`.
//!
//! Naming: `c_a_b` / `q_a_b` map a vector expressed in `a` into `b`
//! (`v_b = c_a_b v_a`); a vector's last suffix is the frame it is expressed
//! in; `w_ab_c` is the rate of `b` relative to `a` expressed in `c`.
//!
//! ## Modules
//!
//! [`earth`] (WGS-84, gravity, radii), [`site`] (the site and the ideal
//! sensor: the one home of that physics for every crate), [`attitude`],
//! [`strapdown`] (the mechanization), [`table`] (axis, table angle, encoder
//! scale and interpolation, the "still" threshold), [`scheme`] (rotation
//! schemes), [`control`] (the table's rate controller, board and simulator),
//! [`calib`] (power-up calibration), [`multipos`] (multi-position
//! calibration), [`align`] (levelling), [`allan`] (Allan deviation),
//! [`real`] (the float type), [`error`].
//!
//! Ideal sensor on a static base (recording-v1; [`site::Site::ideal_imu`]):
//! `w_is_s = c_b_s c_n_b w_ie_n + theta_dot k`,
//! `w_ie_n = Omega_e [cos lat, 0, -sin lat]`,
//! `f_s = c_b_s c_n_b (a_n - g_n)`, `g_n = [0, 0, g]` (level and at rest an
//! ideal accelerometer reads `[0, 0, -g]`).
//!
//! ## Units
//!
//! SI and unsuffixed inside: m, s, rad, m/s, m/s^2, rad/s. Anything else
//! carries its unit in the name (`_us`, `_deg`, `_dps`, ...). Time is integer
//! µs (`u64`); step lengths are derived from differences.

#![no_std]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

pub mod aided;
pub mod align;
pub mod allan;
pub mod attitude;
pub mod calib;
pub mod control;
pub mod earth;
pub mod error;
pub mod eskf;
pub mod multipos;
pub mod real;
pub mod scheme;
pub mod site;
pub mod stats;
pub mod strapdown;
pub mod table;
pub mod units;
pub mod vehicle;

pub use error::NavError;
pub use real::Real;

//! # hal-sim: the simulated world of rins
//!
//! Host-only, `f64` physics. Frames and units as in `core-nav` (its crate
//! docs) and `shared/spec/recording-v1.md`.
//!
//! This first part is the ideal world: a static base with a turntable turning
//! at a constant rate and an error-free IMU on its axis, whose outputs are the
//! recording spec's formulas evaluated exactly.

pub mod bench;
pub mod drivers;
pub mod dual;
pub mod icm42688;
pub mod ideal;
pub mod imu;
pub mod recording;
pub mod rng;
pub mod sim;
pub mod world;

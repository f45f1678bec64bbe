//! # hal-sim: the simulated world of rins
//!
//! Host-only, `f64` physics. Frames and units as in `core-nav` (its crate
//! docs) and `shared/spec/recording-v1.md`.
//!
//! - [`world`]: site (core-nav's), base, table geometry, motor, the lab
//!   console's servo (core-nav's controller), encoder.
//! - [`imu`]: the sensor error model; [`sensor`]: sensor files
//!   (`rins-sensor/2`), the shipped datasheet profiles among them.
//! - [`catalogue`]: the diagnose-v1 effect ids and their physical bounds
//!   (the `sensor` crate's, re-exported), the one list the simulator's
//!   knobs, diagnose and the study are keyed by.
//! - [`sim`]: `simulate` and its `--effect` knobs ([`sim::EFFECTS`]);
//!   [`motion`]: the table's motion under its servo, made once and shared
//!   by every run of one table and scheme.
//! - [`dual`]: dual-axis sequences on a tri-axial table.
//! - [`drive`]: a vehicle under the table (city / highway drives, the ideal
//!   sensor on a moving base, the GNSS receiver); [`body`]: its body on
//!   its suspension (roll, pitch and heave on the road and parked).
//! - [`twin`]: a fitted sensor model and a recording's own run re-simulated
//!   with it (the table's motion from the `recording` crate's encoder track).
//! - [`icm42688`], [`mod@bench`], [`drivers`]: the ICM-42688-P register model,
//!   the shared bench, embedded-hal 1.0 mock drivers with fault injection.
//! - [`rng`]: the seeded generator. The `rins-recording/1` format itself
//!   (reader, writer, encoder track) is the `recording` crate.

pub mod bench;
pub mod body;
pub use ::sensor::catalogue;
pub mod drive;
pub mod drivers;
pub mod dual;
pub mod icm42688;
pub mod imu;
pub mod motion;
pub mod rng;
pub mod sensor;
pub mod sim;
pub mod twin;
pub mod world;

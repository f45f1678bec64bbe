//! Sensor files and the sensor model: the `sensor` crate's, re-exported
//! where hal-sim's users have always found them (`hal_sim::sensor`).

pub use ::sensor::file::*;
pub use ::sensor::spec::{Mounting, ALLAN_PEAK_PER_GM_SIGMA, G0};

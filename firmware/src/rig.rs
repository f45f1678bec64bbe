//! The table this board drives, from the rig file `sensors/rig.toml`
//! (read and checked by `build.rs`: a builder edits the TOML, not Rust):
//! the encoder's counts a turn, the motor's constants, the PWM's
//! frequency and the IMU's SPI clock. The bounds are [`crate::rig_bounds`].

pub use crate::rig_bounds::{spi_clock, Rig, RigError, APB2_HZ};

include!(concat!(env!("OUT_DIR"), "/rig.rs"));

/// The IMU's SPI clock on the board, Hz ([`spi_clock`] of the rig's).
pub const IMU_SPI_HZ: u32 = match spi_clock(APB2_HZ, RIG.spi_max_hz) {
    Some((_, hz)) => hz,
    // Refused by the build (`Rig::check`): the slowest.
    None => APB2_HZ / 256,
};

/// The rig's motor, for the rate loop's feed-forward.
pub fn motor() -> core_nav::control::MotorModel<f32> {
    core_nav::control::MotorModel {
        inertia: RIG.inertia_kg_m2 as f32,
        kt: RIG.kt_nm_per_a as f32,
        resistance: RIG.resistance_ohm as f32,
        supply_v: RIG.supply_v as f32,
        viscous: RIG.viscous_nm_s_per_rad as f32,
        coulomb: RIG.coulomb_nm as f32,
    }
}

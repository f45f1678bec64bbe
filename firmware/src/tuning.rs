//! What the board's build fixes: the tuning of its own IMU (the
//! ICM-42688-P) and table, not the site (that is set by commands and
//! stored: `protocol::record::BoardConfig`).
//!
//! The filter's noise model is made at build time from the board's sensor
//! file, `sensors/icm42688.toml`, by the sensor crate's one derivation
//! (`sensor::filter`, which `rins navigate --gnss` uses too): build.rs
//! writes it into `$OUT_DIR/sensor_tuning.rs`. The start's sigmas and the
//! encoder's are the board's own (a test, `tests/tests/board.rs`, checks
//! the whole against `rins::aided::aided_config`).

use crate::control::ControlConfig;
use crate::navigation::NavConfig;
use crate::tasks::Tuning;
use core_nav::aided::{AidedConfig, ZuptNoise};
use core_nav::eskf::{EskfConfig, InitialSigma};
use core_nav::table::Axis;

include!(concat!(env!("OUT_DIR"), "/sensor_tuning.rs"));

/// The ICM-42688-P's filter (see the module).
pub const ICM42688_FILTER: AidedConfig = AidedConfig {
    eskf: SENSOR_ESKF,
    initial: InitialSigma {
        position_m: 1.0,
        velocity_mps: 0.05,
        level_rad: 0.008_726_646_259_971_648,
        heading_rad: 0.034_906_585_039_886_59,
    },
    axis: Axis::Z,
    antenna_b_m: [0.0; 3],
    zupt: true,
    zupt_noise: ZuptNoise {
        sigma_f_mps2: SIGMA_F,
        sigma_w_radps: SIGMA_W,
        sigma_table_rate_radps: crate::rig::SIGMA_TABLE_RATE_RADPS,
    },
    // No lag: each fix's velocity is taken at its time of validity. A
    // receiver whose velocity lags its positions (RTKLIB's) is corrected
    // by the host's `navigate` only; the link carries one time per fix.
    velocity_lag_s: [0.0; 2],
    // The receiver sized from its first fixes (the board is not told
    // which one it has): `gnss_corr_sigma_m` below is a 1.5 m receiver's
    // until then.
    receiver_from_fixes: true,
};

/// The board's tuning: the tick's and navigation's defaults (1 kHz rate
/// loop at 25 Hz bandwidth, the rig's encoder and motor, 60 s + 60 s calibration,
/// a 400 ms fix horizon) and the ICM-42688-P's filter.
pub fn board() -> Tuning {
    Tuning {
        control: ControlConfig::default(),
        nav: NavConfig::default(),
        filter: ICM42688_FILTER,
    }
}

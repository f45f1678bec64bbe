//! What the board's build fixes: the tuning of its own IMU (the
//! ICM-42688-P) and table, not the site (that is set by commands and
//! stored: `protocol::record::BoardConfig`).
//!
//! The filter's noise model is `rins`'s for hal-sim's `icm42688` profile
//! (`rins::aided::aided_config`, zero-velocity updates on, a 6-sigma
//! gate); the board cannot depend on the host's crates, so the values are
//! written here and a test (`tests/tests/board.rs`) checks they are still
//! the profile's.

use crate::control::ControlConfig;
use crate::navigation::NavConfig;
use crate::tasks::Tuning;
use core_nav::aided::{AidedConfig, ZuptNoise};
use core_nav::eskf::{EskfConfig, InitialSigma, WarmupDrift};
use core_nav::table::Axis;

/// The ICM-42688-P's filter (see the module).
pub const ICM42688_FILTER: AidedConfig = AidedConfig {
    eskf: EskfConfig {
        gyro_arw: 4.886_921_905_584_122_5e-5,
        accel_vrw: 0.000_686_465_499_999_999_9,
        gyro_bias_init_sigma: 0.008_726_733_844_383_18,
        gyro_bias_sigma: 0.012_363_834_460_618_403,
        gyro_bias_tau_s: 1e7,
        accel_bias_init_sigma: 0.196_134_020_460_404_65,
        accel_bias_sigma: 0.200_073_227_200_582_15,
        accel_bias_tau_s: 1e7,
        gate_sigma: 6.0,
        gyro_scale_sigma: 0.005,
        gyro_misalignment_sigma: 0.008_838_834_764_831_844,
        warmup: WarmupDrift {
            tau_s: 600.0,
            gyro_bias: 0.000_523_598_775_598_298_9,
            accel_bias: 0.008_825_985,
            gyro_scale: 0.000_300_000_000_000_000_03,
        },
        accel_scale_sigma: 0.005,
        accel_misalignment_sigma: 0.007_071_067_811_865_474_5,
        gnss_corr_sigma_m: [1.060_660_171_779_821_4, 2.121_320_343_559_643],
        gnss_corr_tau_s: 60.0,
    },
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
        sigma_table_rate_radps: SIGMA_TABLE_RATE,
    },
};

/// The zero-velocity detector's per-sample noise at 100 Hz
/// (`rins::aided::zupt_noise`): m/s^2 and rad/s.
const SIGMA_F: f64 = 0.007_002_444_011_357_032_5;
/// See [`SIGMA_F`].
const SIGMA_W: f64 = 0.000_577_235_932_629_626_1;
/// The table rate's error over the detector's window, rad/s
/// (`core_nav::aided::table_rate_sigma_radps` of the 16,384-count
/// encoder's read at 100 Hz).
const SIGMA_TABLE_RATE: f64 = 0.000_313_122_517_129_361_35;

/// The board's tuning: the tick's and navigation's defaults (1 kHz rate
/// loop at 25 Hz bandwidth, 16,384-count encoder, 60 s + 60 s calibration,
/// a 400 ms fix horizon) and the ICM-42688-P's filter.
pub fn board() -> Tuning {
    Tuning {
        control: ControlConfig::default(),
        nav: NavConfig::default(),
        filter: ICM42688_FILTER,
    }
}

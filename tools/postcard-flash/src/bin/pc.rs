#![no_std]
#![no_main]
use core::hint::black_box;
use panic_halt as _;
use serde::{Deserialize, Serialize};

#[derive(Serialize, Deserialize, Clone, Copy, Debug)]
pub struct GnssFix { lat_e7: i32, lon_e7: i32, height_mm: i32, v_n_mmps: [i32; 3], sigma_h_mm: u32, sigma_v_mm: u32, sigma_vel_mmps: u32 }

#[derive(Serialize, Deserialize, Clone, Copy, Debug)]
pub enum Telemetry {
    Imu { t_us: u64, gyro_radps: [f32; 3], accel_mps2: [f32; 3], temp_c: f32 },
    Encoder { t_us: u64, counts: i64, counts_per_rev: u32 },
    Nav { t_us: u64, q_b_n: [f32; 4], v_n: [f32; 3], p_n: [f32; 3] },
    Calibration { bias_radps: [f32; 3], m_k: [f32; 3], status: u8 },
    Fault { t_us: u64, fault: u8, count: u32 },
    Ack { seq: u16, status: u8 },
    CalibrationChange { d_bias_radps: [f32; 3], d_m_k: [f32; 3] },
    Health { t_us: u64, reset: u8, tick_worst: u32, tick_overruns: u32, nav_worst: u32, nav_overruns: u32, samples_dropped: u32, samples_duplicated: u32, rx_bytes: u32, rx_lost: u32, rx_line_errors: [u32; 3], init_stack_bytes: u32, stack_bytes: u32 },
    Config { lat_e7: i32, height_mm: i32, base_deg: [f32; 3], scheme: u8, rate_dps: f32, count: u8, aided: u8, lon_e7: i32 },
}

#[derive(Serialize, Deserialize, Clone, Copy, Debug)]
pub enum Command {
    SetScheme { kind: u8, rate_dps: f32, count: u8 },
    Start,
    Stop,
    Recalibrate,
    GnssFix { t_valid_us: u64, fix: GnssFix },
    SetSite { lat_e7: i32, height_mm: i32 },
    SetBase { roll_deg: f32, pitch_deg: f32, heading_deg: f32 },
    SetAided { on: u8, lon_e7: i32 },
}

const CALSTATUS: u8 = 0x80; const FAULT: u8 = 1; const STATUS: u8 = 0; const RESET: u8 = 1; const SCHEME: u8 = 1;

include!("../all_messages.rs");

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut out = [0u8; 128];
    loop {
        let t = ALL[black_box(0usize) % ALL.len()];
        let seq: u16 = black_box(1);
        let n = postcard::to_slice(&(seq, t), &mut out).map(|s| s.len()).unwrap_or(0);
        black_box(n);
        let c: Result<(u16, Command), _> = postcard::from_bytes(black_box(&out[..black_box(40)]));
        black_box(&c);
    }
}

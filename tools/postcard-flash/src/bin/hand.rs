#![no_std]
#![no_main]
use core::hint::black_box;
use panic_halt as _;
use protocol::{CalStatus, Command, Fault, ResetCause, SchemeKind, Status, Telemetry};
const CALSTATUS: CalStatus = CalStatus::Stored;
const FAULT: Fault = Fault::ImuTimeout;
const STATUS: Status = Status::Accepted;
const RESET: ResetCause = ResetCause::PowerOn;
const SCHEME: SchemeKind = SchemeKind::Continuous;

const ALL: [Telemetry; 9] = [
    Telemetry::Imu { t_us: 1, gyro_radps: [0.1; 3], accel_mps2: [9.8; 3], temp_c: 25.0 },
    Telemetry::Encoder { t_us: 2, counts: 3, counts_per_rev: 16384 },
    Telemetry::Nav { t_us: 3, q_b_n: [1.0, 0.0, 0.0, 0.0], v_n: [0.0; 3], p_n: [0.0; 3] },
    Telemetry::Calibration { bias_radps: [0.0; 3], m_k: [0.0; 3], status: CALSTATUS },
    Telemetry::Fault { t_us: 4, fault: FAULT, count: 1 },
    Telemetry::Ack { seq: 5, status: STATUS },
    Telemetry::CalibrationChange { d_bias_radps: [0.0; 3], d_m_k: [0.0; 3] },
    Telemetry::Health { t_us: 6, reset: RESET, tick_worst: 1, tick_overruns: 0, nav_worst: 1, nav_overruns: 0, samples_dropped: 0, samples_duplicated: 0, rx_bytes: 1, rx_lost: 0 },
    Telemetry::Config { lat_e7: 1, height_mm: 2, base_deg: [0.0; 3], scheme: SCHEME, rate_dps: 30.0, count: 0, aided: 0, lon_e7: 3 },
];


#[cortex_m_rt::entry]
fn main() -> ! {
    let mut out = [0u8; 128];
    loop {
        // Every telemetry message encoded, every command decoded.
        let t = ALL[black_box(0usize) % ALL.len()];
        let n = t.encode(1, &mut out).unwrap_or(0);
        black_box(n);
        let c = Command::decode(black_box(&out[..black_box(40)]));
        black_box(&c);
    }
}

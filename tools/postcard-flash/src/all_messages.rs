// Every telemetry message once, the same in both measurements (`hand`
// and `pc`), each with its own `Telemetry` type and code constants in
// scope: included, not a module, so the two binaries measure one list.
const ALL: [Telemetry; 9] = [
    Telemetry::Imu { t_us: 1, gyro_radps: [0.1; 3], accel_mps2: [9.8; 3], temp_c: 25.0 },
    Telemetry::Encoder { t_us: 2, counts: 3, counts_per_rev: 16384 },
    Telemetry::Nav { t_us: 3, q_b_n: [1.0, 0.0, 0.0, 0.0], v_n: [0.0; 3], p_n: [0.0; 3] },
    Telemetry::Calibration { bias_radps: [0.0; 3], m_k: [0.0; 3], status: CALSTATUS },
    Telemetry::Fault { t_us: 4, fault: FAULT, count: 1 },
    Telemetry::Ack { seq: 5, status: STATUS },
    Telemetry::CalibrationChange { d_bias_radps: [0.0; 3], d_m_k: [0.0; 3] },
    Telemetry::Health { t_us: 6, reset: RESET, tick_worst: 1, tick_overruns: 0, nav_worst: 1, nav_overruns: 0, samples_dropped: 0, samples_duplicated: 0, rx_bytes: 1, rx_lost: 0, rx_line_errors: [0, 0, 0], init_stack_bytes: 1, stack_bytes: 1 },
    Telemetry::Config { lat_e7: 1, height_mm: 2, base_deg: [0.0; 3], scheme: SCHEME, rate_dps: 30.0, count: 0, aided: 0, lon_e7: 3 },
];

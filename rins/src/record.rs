//! `rins record`: the board's telemetry (framed: COBS, CRC-16, sequence
//! numbers; the `protocol` crate) decoded into a recording
//! (`rins-recording/1`), with the link's losses counted.
//!
//! IMU frames carry the board's 10 ms means (its rate loop reads the IMU at
//! 1 kHz): the recording says so (`[imu] sample = "average"`) and its
//! times are the ends of the intervals. Encoder frames carry the unwrapped
//! count; the angle is `count x 2 pi / counts_per_rev`.

use core_nav::table::EncoderScale;
use protocol::{CalStatus, Decoder, Fault, LinkStats, ResetCause, Telemetry, MAX_PAYLOAD};
use recording::{ImuRow, Meta, Recording, SampleKind, TableRow};

/// What came over the link besides the samples.
#[derive(Clone, Debug, Default)]
pub struct Decoded {
    /// The samples as a recording.
    pub recording: Recording,
    /// Frames decoded, corrupt, overflowing, lost.
    pub stats: LinkStats,
    /// Rows dropped because their time did not increase (a board reset).
    pub out_of_order: u64,
    /// Navigation states: (t_us, p_n).
    pub nav: Vec<(u64, [f32; 3])>,
    /// Calibration frames in the order sent: the record stored at power-up
    /// (status `CAL_STATUS_STORED`), refusals (their reason codes) and
    /// accepted results (status 0).
    pub calibrations: Vec<CalibrationFrame>,
    /// Changes of an accepted calibration from the stored record:
    /// (bias rad/s, `M k`).
    pub calibration_changes: Vec<([f32; 3], [f32; 3])>,
    /// Faults: (t_us, fault, count).
    pub faults: Vec<(u64, Fault, u32)>,
    /// The board's health frames, in order.
    pub health: Vec<Health>,
    /// The configuration frames the board sent.
    pub configs: Vec<Telemetry>,
    /// The boot reports, one per boot: why the board reset, the resets in
    /// a row and in all, safe mode, a HardFault's registers.
    pub boots: Vec<BootReport>,
}

/// One `Boot` frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BootReport {
    /// Why the board reset.
    pub reset: protocol::ResetCause,
    /// Watchdog and fault resets in a row.
    pub in_row: u32,
    /// Resets since power-on.
    pub total: u32,
    /// It booted into safe mode.
    pub safe_mode: bool,
    /// A HardFault's CFSR, HFSR, MMFAR, BFAR, PC and LR (all 0: none).
    pub fault_regs: [u32; 6],
}

/// One `Health` frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Health {
    /// Board time, µs.
    pub t_us: u64,
    /// Why the board last reset.
    pub reset: ResetCause,
    /// The control tick's worst case, cycles, and its overruns.
    pub tick: (u32, u32),
    /// Navigation's worst case, cycles, and its overruns.
    pub nav: (u32, u32),
    /// IMU samples dropped and duplicated.
    pub samples: (u32, u32),
    /// Bytes received by the board and lost.
    pub rx: (u32, u32),
    /// The board's USART line errors: overruns, noise, framing (at least).
    pub rx_line_errors: [u32; 3],
    /// The stack's peak during init and the tasks' at the last scan,
    /// bytes (0: not measured).
    pub stack: (u32, u32),
}

/// One `Calibration` frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibrationFrame {
    /// Gyro bias, rad/s.
    pub bias_radps: [f32; 3],
    /// Column `M k` (installation errors and the table axis' scale error).
    pub m_k: [f32; 3],
    /// Accepted, the record found at power-up, or why refused.
    pub status: CalStatus,
}

/// Decodes a byte stream; `meta` is what the recording is told about the
/// site, the base and the table (the board does not send it).
pub fn decode(bytes: impl IntoIterator<Item = u8>, meta: Meta) -> Decoded {
    let mut d = Decoder::default();
    let mut out = [0u8; MAX_PAYLOAD + 2];
    let mut r = Decoded {
        recording: Recording {
            gyro_only: false,
            moving: None,
            meta: Meta {
                imu_sample: SampleKind::Average,
                ..meta
            },
            imu: vec![],
            table: vec![],
        },
        ..Decoded::default()
    };
    for b in bytes {
        let Some(n) = d.push(b, &mut out) else {
            continue;
        };
        let Ok((_, t)) = Telemetry::decode(&out[..n]) else {
            d.count_corrupt();
            continue;
        };
        match t {
            Telemetry::Imu {
                t_us,
                gyro_radps,
                accel_mps2,
                temp_c,
            } => {
                let t_s = t_us as f64 * 1e-6;
                if r.recording.imu.last().is_some_and(|x| x.t_s >= t_s) {
                    r.out_of_order += 1;
                    continue;
                }
                r.recording.imu.push(ImuRow {
                    t_s,
                    gyro_radps: gyro_radps.map(f64::from),
                    accel_mps2: accel_mps2.map(f64::from),
                    temp_c: Some(f64::from(temp_c)),
                });
            }
            Telemetry::Encoder {
                t_us,
                counts,
                counts_per_rev,
            } => {
                let t_s = t_us as f64 * 1e-6;
                if r.recording.table.last().is_some_and(|x| x.t_s >= t_s) || counts_per_rev == 0 {
                    r.out_of_order += 1;
                    continue;
                }
                let angle_rad = EncoderScale::new(counts_per_rev).to_rad(counts);
                r.recording.table.push(TableRow { t_s, angle_rad });
            }
            Telemetry::Nav { t_us, p_n, .. } => r.nav.push((t_us, p_n)),
            Telemetry::Calibration {
                bias_radps,
                m_k,
                status,
            } => r.calibrations.push(CalibrationFrame {
                bias_radps,
                m_k,
                status,
            }),
            Telemetry::CalibrationChange {
                d_bias_radps,
                d_m_k,
            } => r.calibration_changes.push((d_bias_radps, d_m_k)),
            Telemetry::Fault { t_us, fault, count } => r.faults.push((t_us, fault, count)),
            Telemetry::Ack { .. } => {}
            Telemetry::Health {
                t_us,
                reset,
                tick_worst,
                tick_overruns,
                nav_worst,
                nav_overruns,
                samples_dropped,
                samples_duplicated,
                rx_bytes,
                rx_lost,
                rx_line_errors,
                init_stack_bytes,
                stack_bytes,
            } => r.health.push(Health {
                t_us,
                reset,
                tick: (tick_worst, tick_overruns),
                nav: (nav_worst, nav_overruns),
                samples: (samples_dropped, samples_duplicated),
                rx: (rx_bytes, rx_lost),
                rx_line_errors,
                stack: (init_stack_bytes, stack_bytes),
            }),
            c @ Telemetry::Config { .. } => r.configs.push(c),
            Telemetry::Boot {
                reset,
                resets_in_row,
                resets_total,
                safe_mode,
                fault_regs,
            } => r.boots.push(BootReport {
                reset,
                in_row: resets_in_row,
                total: resets_total,
                safe_mode: safe_mode != 0,
                fault_regs,
            }),
        }
    }
    r.stats = d.stats;
    r
}

/// The link statistics as JSON (`rins record --json`).
pub fn link_json(d: &Decoded) -> serde_json::Value {
    let s = &d.stats;
    serde_json::json!({
        "frames": s.frames, "lost": s.lost, "corrupt": s.corrupt, "overflow": s.overflow,
        "out_of_order": d.out_of_order, "imu_samples": d.recording.imu.len(),
        "encoder_reads": d.recording.table.len(),
        "faults": d.faults.iter().map(|(t, f, c)| serde_json::json!({"t_us": t, "fault": format!("{f:?}"), "code": f.code(), "count": c})).collect::<Vec<_>>(),
        "health": d.health.last().map(|h| serde_json::json!({
            "reset": format!("{:?}", h.reset), "tick_worst_cycles": h.tick.0, "tick_overruns": h.tick.1,
            "nav_worst_cycles": h.nav.0, "nav_overruns": h.nav.1, "samples_dropped": h.samples.0,
            "samples_duplicated": h.samples.1, "rx_bytes": h.rx.0, "rx_lost": h.rx.1,
            "rx_line_errors": h.rx_line_errors,
            "init_stack_bytes": (h.stack.0 > 0).then_some(h.stack.0),
            "stack_bytes": (h.stack.1 > 0).then_some(h.stack.1)})),
        "boots": d.boots.iter().map(|b| serde_json::json!({
            "reset": format!("{:?}", b.reset), "resets_in_row": b.in_row,
            "resets_total": b.total, "safe_mode": b.safe_mode,
            "hard_fault": (b.fault_regs != [0; 6]).then(|| serde_json::json!({
                "cfsr": b.fault_regs[0], "hfsr": b.fault_regs[1], "mmfar": b.fault_regs[2],
                "bfar": b.fault_regs[3], "pc": b.fault_regs[4], "lr": b.fault_regs[5]}))})).collect::<Vec<_>>(),
    })
}

/// The board's calibration frames as `rins-calibration/1` (the format
/// `rins calibrate` writes and `rins navigate --calibration` reads): the
/// last accepted result as the calibration, every frame in order, the
/// stored record and the change from it. `None` when no frame came.
pub fn calibration_json(d: &Decoded, axis: core_nav::table::Axis) -> Option<serde_json::Value> {
    let v = |a: &[f32; 3]| a.map(f64::from).to_vec();
    let accepted = d
        .calibrations
        .iter()
        .rev()
        .find(|c| c.status == CalStatus::Accepted);
    let stored = d
        .calibrations
        .iter()
        .find(|c| c.status == CalStatus::Stored);
    if d.calibrations.is_empty() {
        return None;
    }
    let frame = |c: &CalibrationFrame| {
        let what = match c.status {
            CalStatus::Accepted => "accepted".to_string(),
            CalStatus::Stored => "stored at power-up".to_string(),
            why => format!("refused ({why:?})"),
        };
        serde_json::json!({"bias_radps": v(&c.bias_radps), "m_k": v(&c.m_k), "status": c.status.code(), "what": what})
    };
    let zero = [0.0f64; 3].to_vec();
    let mut out = serde_json::json!({
        "format": "rins-calibration/1",
        "method": "board",
        "axis": recording::axis_name(axis),
        "board": {
            "frames": d.calibrations.iter().map(frame).collect::<Vec<_>>(),
            "stored_at_power_up": stored.map(frame),
            "change_from_stored": d.calibration_changes.last().map(|(b, m)| serde_json::json!({"bias_radps": v(b), "m_k": v(m)})),
        },
    });
    if let (Some(a), Some(o)) = (accepted, out.as_object_mut()) {
        o.insert(
            "gyro".into(),
            serde_json::json!({"bias_radps": v(&a.bias_radps), "m_k": v(&a.m_k), "q_per_radps": zero, "asymmetry": zero}),
        );
    }
    Some(out)
}

/// A one-line account of the link.
pub fn link_report(d: &Decoded) -> String {
    let s = &d.stats;
    let mut out = format!(
        "{} frames: {} IMU samples, {} encoder reads, {} nav states, {} faults; lost {}, corrupt {}, overflowing {}, out of order {}",
        s.frames,
        d.recording.imu.len(),
        d.recording.table.len(),
        d.nav.len(),
        d.faults.len(),
        s.lost,
        s.corrupt,
        s.overflow,
        d.out_of_order
    );
    for b in &d.boots {
        out.push_str(&boot_line(b));
    }
    if let Some(h) = d.health.last() {
        let b = |x: u32| {
            if x > 0 {
                format!("{x} B")
            } else {
                "not measured".into()
            }
        };
        out.push_str(&format!(
            "\nhealth: init stack {}, tasks' stack {}, worst tick {} and nav {} (DWT cycles; instructions under QEMU)",
            b(h.stack.0),
            b(h.stack.1),
            h.tick.0,
            h.nav.0
        ));
        let [o, n, f] = h.rx_line_errors;
        if o + n + f > 0 {
            out.push_str(&format!(
                "\nthe board's USART saw {o} overruns, {n} noise and {f} framing errors: check the line's wiring, ground and baud rate"
            ));
        }
    }
    out
}

/// A boot report as a line of its own: the cause, the resets in a row,
/// safe mode and a HardFault's registers.
fn boot_line(b: &BootReport) -> String {
    let mut l = format!(
        "\nboot: reset {:?}, {} in a row, {} since power-on",
        b.reset, b.in_row, b.total
    );
    if b.safe_mode {
        l.push_str(": SAFE MODE (motor off, no tick: the board reset itself too often in a row; power-cycle or press reset once the cause is fixed)");
    }
    if b.fault_regs != [0; 6] {
        let [cfsr, hfsr, mmfar, bfar, pc, lr] = b.fault_regs;
        l.push_str(&format!(
            "\n  after a HardFault: CFSR {cfsr:#010x} HFSR {hfsr:#010x} MMFAR {mmfar:#010x} BFAR {bfar:#010x} PC {pc:#010x} LR {lr:#010x}"
        ));
    }
    l
}

//! `rins record`: the board's telemetry (framed: COBS, CRC-16, sequence
//! numbers; `firmware::telemetry`) decoded into a recording
//! (`rins-recording/1`), with the link's losses counted.
//!
//! IMU frames carry the board's 10 ms means (its rate loop reads the IMU at
//! 1 kHz): the recording says so (`[imu] sample = "average"`) and its
//! times are the ends of the intervals. Encoder frames carry the unwrapped
//! count; the angle is `count x 2 pi / counts_per_rev`.

use core_nav::table::EncoderScale;
use firmware::telemetry::{Decoder, LinkStats, Telemetry, MAX_PAYLOAD};
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
    /// Faults: (t_us, code, count).
    pub faults: Vec<(u64, u8, u32)>,
}

/// One `Calibration` frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibrationFrame {
    /// Gyro bias, rad/s.
    pub bias_radps: [f32; 3],
    /// Column `M k` (installation errors and the table axis' scale error).
    pub m_k: [f32; 3],
    /// 0 accepted, `CAL_STATUS_STORED` the record found at power-up, else
    /// the refusal code.
    pub status: u8,
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
        let Ok((_, t)) = Telemetry::parse(&out[..n]) else {
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
            Telemetry::Fault { t_us, code, count } => r.faults.push((t_us, code, count)),
            Telemetry::Ack { .. } => {}
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
        "encoder_reads": d.recording.table.len(), "faults": d.faults,
    })
}

/// The board's calibration frames as `rins-calibration/1` (the format
/// `rins calibrate` writes and `rins navigate --calibration` reads): the
/// last accepted result as the calibration, every frame in order, the
/// stored record and the change from it. `None` when no frame came.
pub fn calibration_json(d: &Decoded, axis: core_nav::table::Axis) -> Option<serde_json::Value> {
    use firmware::app::CAL_STATUS_STORED;
    let v = |a: &[f32; 3]| a.map(f64::from).to_vec();
    let accepted = d.calibrations.iter().rev().find(|c| c.status == 0);
    let stored = d
        .calibrations
        .iter()
        .find(|c| c.status == CAL_STATUS_STORED);
    if d.calibrations.is_empty() {
        return None;
    }
    let frame = |c: &CalibrationFrame| {
        let what = match c.status {
            0 => "accepted".to_string(),
            CAL_STATUS_STORED => "stored at power-up".to_string(),
            code => format!("refused (reason {code})"),
        };
        serde_json::json!({"bias_radps": v(&c.bias_radps), "m_k": v(&c.m_k), "status": c.status, "what": what})
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
    format!(
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
    )
}

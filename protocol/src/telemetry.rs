//! What a board sends. Times are the board's clock (µs since its IMU's
//! first sample: the sensor's sample clock); the sensor frame is `s`, the
//! navigation frame NED.

use crate::codes::{CalStatus, Fault, ResetCause, SchemeKind, Status};
use crate::frame::{frame, FrameError, MAX_FRAME, MAX_PAYLOAD};
use crate::wire::messages;

messages! {
    /// A board's message.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub enum Telemetry {
        /// An IMU sample: the mean over a navigation period ending at
        /// `t_us` (recording-v1 `sample = "average"`), sensor frame `s`.
        Imu = 1 {
            /// µs.
            t_us: u64,
            /// rad/s.
            gyro_radps: [f32; 3],
            /// m/s^2.
            accel_mps2: [f32; 3],
            /// deg C.
            temp_c: f32,
        },
        /// An encoder read: the unwrapped count.
        Encoder = 2 {
            /// µs.
            t_us: u64,
            /// Unwrapped count.
            counts: i64,
            /// Counts per revolution.
            counts_per_rev: u32,
        },
        /// Navigation state: base attitude `q_b_n` (w, x, y, z), velocity
        /// (NED, m/s) and position offset from the start (NED, m).
        Nav = 3 {
            /// µs.
            t_us: u64,
            /// `q_b_n`.
            q_b_n: [f32; 4],
            /// m/s.
            v_n: [f32; 3],
            /// m.
            p_n: [f32; 3],
        },
        /// A calibration: gyro bias (rad/s, `s`) and column `M k`.
        Calibration = 4 {
            /// rad/s.
            bias_radps: [f32; 3],
            /// Installation errors and the table axis' scale error.
            m_k: [f32; 3],
            /// Accepted, stored at power-up, or why refused.
            status: CalStatus,
        },
        /// A fault and how many so far (sent when it first happens, then
        /// at most once a second while it repeats).
        Fault = 5 {
            /// µs.
            t_us: u64,
            /// Which.
            fault: Fault,
            /// Occurrences so far.
            count: u32,
        },
        /// The answer to a command: its sequence number and status.
        Ack = 6 {
            /// The command's sequence number.
            seq: u16,
            /// Accepted or why not.
            status: Status,
        },
        /// The accepted calibration minus the record stored at power-up.
        CalibrationChange = 7 {
            /// rad/s.
            d_bias_radps: [f32; 3],
            /// `M k` change.
            d_m_k: [f32; 3],
        },
        /// The board's health, once a second: why it last reset, each
        /// task's worst case (CPU cycles on the board, instructions under
        /// QEMU) and overruns, the samples dropped or duplicated, the
        /// link's bytes.
        Health = 8 {
            /// µs.
            t_us: u64,
            /// Why the board last reset.
            reset: ResetCause,
            /// The control tick's worst case, cycles.
            tick_worst: u32,
            /// Control ticks still running at the next period.
            tick_overruns: u32,
            /// Navigation's worst case, cycles.
            nav_worst: u32,
            /// Navigation inputs dropped (its queue full).
            nav_overruns: u32,
            /// IMU samples dropped (data-ready late).
            samples_dropped: u32,
            /// Data-ready without new data.
            samples_duplicated: u32,
            /// Bytes received.
            rx_bytes: u32,
            /// Bytes lost on receive.
            rx_lost: u32,
            /// The USART's line errors (RM0090 30.6.1): overruns, noise,
            /// framing errors; at least these many (a burst within one
            /// link period counts once).
            rx_line_errors: [u32; 3],
            /// The stack's peak during `init`, bytes (0: not measured).
            init_stack_bytes: u32,
            /// The tasks' stack peak at the last scan (once a minute),
            /// bytes (0: not measured yet).
            stack_bytes: u32,
        },
        /// The configuration in use (at boot and after each change).
        Config = 9 {
            /// Site latitude, 1e-7 deg.
            lat_e7: i32,
            /// Site height, mm.
            height_mm: i32,
            /// Base roll, pitch, heading, deg.
            base_deg: [f32; 3],
            /// The rotation scheme.
            scheme: SchemeKind,
            /// Its rate, deg/s.
            rate_dps: f32,
            /// Its turns (reciprocating) or positions (indexed).
            count: u8,
            /// 1: aided navigation (a moving vehicle with GNSS).
            aided: u8,
            /// The aided origin's longitude, 1e-7 deg.
            lon_e7: i32,
        },
        /// Once, at boot: why the board reset, how many resets came in a
        /// row without a healthy run between and in all since power-on,
        /// whether it booted into safe mode, and the registers a HardFault
        /// left (all 0 when the last reset was not one).
        Boot = 10 {
            /// Why the board reset.
            reset: ResetCause,
            /// Watchdog and fault resets in a row (0 after a healthy run,
            /// a power-on or the reset pin).
            resets_in_row: u32,
            /// Resets since power-on.
            resets_total: u32,
            /// 1: safe mode (motor off, no tick, the link up).
            safe_mode: u8,
            /// A HardFault's CFSR, HFSR, MMFAR, BFAR, stacked PC and LR.
            fault_regs: [u32; 6],
        },
    }
}

impl Telemetry {
    /// The whole frame (payload, CRC, COBS, delimiter) into `out`.
    ///
    /// # Errors
    /// [`FrameError::BufferTooSmall`] (never with a `MAX_FRAME` buffer).
    pub fn to_frame(&self, seq: u16, out: &mut [u8; MAX_FRAME]) -> Result<usize, FrameError> {
        let mut p = [0u8; MAX_PAYLOAD];
        let n = self.encode(seq, &mut p)?;
        frame(p.get(..n).unwrap_or(&[]), out)
    }
}

//! The board's logic as one state machine, driven by the RTIC tasks (or a
//! host test through hal-sim): IMU samples at 1 kHz (the rate loop; every
//! tenth, as the mean of ten, feeds calibration and 100 Hz navigation),
//! encoder reads at 50 Hz, commands; out come the motor duty, telemetry
//! frames and faults.
//!
//! Power-up: still for `static_s` (gyro biases), spin up to the scheme's
//! rate (refused after `spinup_timeout_s`), rotate for `rotate_s` (whole
//! turns), solve the earth-aware calibration (`core_nav::calib`), check it
//! is plausible, store it (a CRC-protected record for flash; the record of
//! the previous power-up, read back at boot, is reported with the change),
//! then navigate in f32 while the table keeps turning. A bump, a table that will not
//! reach its rate or an implausible result restarts the calibration with a
//! reported reason.

use crate::faults::{Fault, FaultCounts};
use crate::icm42688::{DataFault, DataMonitor, RawSample, Sample};
use crate::telemetry::{
    frame, reason, Command, Decoder, FrameError, Telemetry, MAX_FRAME, MAX_PAYLOAD,
};
use core_nav::aided::{AidedConfig, AidedNav, OriginE7};
use core_nav::attitude::{euler_to_quat, Euler};
use core_nav::calib::{solve, Checks, GyroCalibration, Phase, PhaseAccumulator, Unknowns};
use core_nav::control::{MotorModel, RateController};
use core_nav::earth::GeoPoint;
use core_nav::scheme::{Limits, Profile, Reference, Scheme};
use core_nav::site::Site;
use core_nav::strapdown::{ImuSample, Strapdown, StrapdownConfig};
use core_nav::table::{
    q_b_n, q_s_b, Axis, CounterUnwrapper, EncoderInterpolator, EncoderScale, TableAngle,
};
use nalgebra::{Quaternion, Vector3};

/// Everything the board is told at build time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AppConfig {
    /// Site latitude, deg.
    pub lat_deg: f64,
    /// Site height, m.
    pub height_m: f64,
    /// Base attitude: roll, pitch, heading, deg.
    pub base_deg: [f64; 3],
    /// Encoder counts per revolution.
    pub counts_per_rev: u32,
    /// The rotation scheme (calibration uses its rate).
    pub scheme: Scheme,
    /// Table limits.
    pub limits: Limits,
    /// Static calibration phase, s (the paper's 60 s, or from the Allan curve).
    pub static_s: f64,
    /// Rotating calibration phase, s.
    pub rotate_s: f64,
    /// The rate must be reached within this, s.
    pub spinup_timeout_s: f64,
    /// Motor model and rate-loop bandwidth, Hz.
    pub motor: MotorModel<f32>,
    /// Rate-loop bandwidth, Hz.
    pub bandwidth_hz: f32,
    /// Navigation telemetry every this many navigation steps.
    pub nav_every: u32,
    /// The IMU is read at this period for the rate loop, µs (1 kHz: the
    /// loop's 25 Hz bandwidth keeps the motor's cogging ripple under
    /// 0.5 deg/s up to 100 deg/s); every sample on the navigation grid
    /// (`nav_period_us`) also feeds calibration, navigation and telemetry.
    pub control_period_us: u64,
    /// The navigation period, µs (100 Hz).
    pub nav_period_us: u64,
    /// Aided navigation on a moving vehicle (`None`: a static base, as
    /// above). With it the board skips the power-up calibration (the
    /// vehicle need not stand still: the filter estimates the gyro and
    /// accelerometer errors), starts the table at once and navigates from
    /// the first sample with an encoder angle, taking GNSS fixes over the
    /// command link ([`Command::GnssFix`]).
    pub aided: Option<BoardAided>,
}

/// The board's aided-navigation settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardAided {
    /// Where the vehicle powers up (the navigation origin).
    pub origin: OriginE7,
    /// The filter, the antenna lever arm, zero-velocity updates.
    pub cfg: AidedConfig,
}

impl Default for AppConfig {
    fn default() -> Self {
        Self {
            lat_deg: 30.53,
            height_m: 20.0,
            base_deg: [0.0; 3],
            counts_per_rev: 16_384,
            scheme: Scheme::Continuous {
                rate: 30f64.to_radians(),
            },
            limits: Limits::default(),
            static_s: 60.0,
            rotate_s: 60.0,
            spinup_timeout_s: 10.0,
            motor: MotorModel::default(),
            // The rate loop runs at 1 kHz with 25 Hz bandwidth. (An earlier
            // 100 Hz loop left the cogging ripple, 24 per turn, at 0.68 /
            // 0.45 / 0.35 deg/s RMS with 8 / 10 / 12 Hz bandwidth at 30
            // deg/s and 0.68 at 70 deg/s: too much.)
            bandwidth_hz: 25.0,
            nav_every: 10,
            control_period_us: 1_000,
            nav_period_us: 10_000,
            aided: None,
        }
    }
}

/// Where the board is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mode {
    /// Still, measuring the biases (since µs).
    CalStatic(u64),
    /// Spinning up (since µs).
    CalSpinUp(u64),
    /// Rotating for the calibration (since µs).
    CalRotate(u64),
    /// Navigating.
    Navigating,
    /// Motor off after a fault, waiting for a command.
    Stopped(Fault),
}

/// `Calibration.status` of the record found in flash at power-up (not a
/// refusal code: those are 1-8, an accepted calibration 0).
pub const CAL_STATUS_STORED: u8 = 0x80;

/// Length of a stored calibration record, bytes.
pub const CAL_RECORD: usize = 4 + 12 + 12 + 2;
const CAL_MAGIC: u32 = 0x5249_4E53; // "RINS"

/// A vector as the f32 triple telemetry carries.
fn f32x3(v: &Vector3<f64>) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// The calibration as a flash record: magic, bias, M k, CRC-16.
pub fn encode_record(c: &GyroCalibration) -> [u8; CAL_RECORD] {
    let mut r = [0u8; CAL_RECORD];
    let mut w = 0usize;
    let mut put = |b: &[u8]| {
        if let Some(dst) = r.get_mut(w..w + b.len()) {
            dst.copy_from_slice(b);
        }
        w += b.len();
    };
    put(&CAL_MAGIC.to_le_bytes());
    for v in c.bias.iter().chain(c.m_k.iter()) {
        put(&(*v as f32).to_le_bytes());
    }
    let crc = crate::telemetry::crc16(r.get(..CAL_RECORD - 2).unwrap_or(&[]));
    if let Some(dst) = r.get_mut(CAL_RECORD - 2..) {
        dst.copy_from_slice(&crc.to_le_bytes());
    }
    r
}

/// Reads a flash record back; `None` when the magic or CRC is wrong.
pub fn decode_record(r: &[u8; CAL_RECORD], axis: Axis) -> Option<GyroCalibration> {
    let body = r.get(..CAL_RECORD - 2)?;
    let crc = u16::from_le_bytes([*r.get(CAL_RECORD - 2)?, *r.get(CAL_RECORD - 1)?]);
    if crate::telemetry::crc16(body) != crc || body.get(..4)? != CAL_MAGIC.to_le_bytes() {
        return None;
    }
    let f = |i: usize| -> Option<f64> {
        let b = body.get(4 + 4 * i..8 + 4 * i)?;
        Some(f64::from(f32::from_le_bytes([
            *b.first()?,
            *b.get(1)?,
            *b.get(2)?,
            *b.get(3)?,
        ])))
    };
    Some(GyroCalibration {
        bias: Vector3::new(f(0)?, f(1)?, f(2)?),
        m_k: Vector3::new(f(3)?, f(4)?, f(5)?),
        axis,
        ..GyroCalibration::default()
    })
}

/// Telemetry frames waiting for the UART.
pub const TX_QUEUE: usize = 32;

/// Encoder reads kept for the table rate (0.5 s at 50 Hz, plus one).
pub const ENC_HIST: usize = 26;

/// What the board's memory holds besides the mechanization: one
/// calibration phase's sums at a time (the still phase's, then the
/// rotating phase's), or the aided navigator. Never both: an aided board
/// does not calibrate on the table. One enum, so the larger of the two
/// (the navigator, 7 KiB) is the static RAM they cost, not their sum.
// No heap on the board: the variants share memory, which is the point.
#[allow(clippy::large_enum_variant)]
enum Work {
    Phase(PhaseAccumulator),
    Aided(AidedNav<f32>),
}

/// The board's logic.
pub struct App {
    cfg: AppConfig,
    /// Where the board is.
    pub mode: Mode,
    ctrl: RateController<f32>,
    profile: Profile,
    scheme_t0: Option<(u64, f32)>,
    unwrap: CounterUnwrapper,
    last_hw: Option<(u64, u16)>,
    glitch_run: u8,
    enc: EncoderInterpolator<f32>,
    /// The last encoder reads (0.5 s at 50 Hz), for the table rate the
    /// zero-velocity detector removes: over two reads a count (0.38 mrad
    /// at 16,384 counts) is 1.1 deg/s of rate, over 0.5 s 0.04 deg/s.
    enc_hist: heapless::Deque<(u64, TableAngle<f32>), ENC_HIST>,
    last_count: Option<(u64, i64)>,
    rate_window: Option<(u64, i64)>,
    stall_since: Option<u64>,
    rate_ok_since: Option<u64>,
    /// The calibration phase's sums or the aided navigator.
    work: Work,
    static_phase: Option<Phase>,
    /// The calibration in use.
    pub calibration: Option<GyroCalibration>,
    /// The record to store in flash.
    pub stored: Option<[u8; CAL_RECORD]>,
    /// The record read from flash at power-up ([`App::restore`]).
    pub previous: Option<GyroCalibration>,
    /// The accepted calibration minus `previous`: (bias rad/s, `M k`).
    pub change: Option<(Vector3<f64>, Vector3<f64>)>,
    nav: Option<Strapdown<f32>>,
    nav_count: u32,
    last_imu_us: Option<u64>,
    rate_meas: f32,
    duty: f32,
    avg: [f32; 7],
    avg_n: u32,
    last_nav: Option<(u64, Sample)>,
    monitor: DataMonitor,
    /// Fault counters.
    pub faults: FaultCounts,
    /// Why the last calibration was refused (for the log).
    pub last_refusal: Option<core_nav::calib::CalibError>,
    tx: heapless::Deque<([u8; MAX_FRAME], usize), TX_QUEUE>,
    seq: u16,
    rx: Decoder,
}

impl App {
    /// The board at power-up.
    ///
    /// # Errors
    /// [`FrameError::OutOfBounds`] when the configured scheme is out of range.
    pub fn new(cfg: AppConfig) -> Result<Self, FrameError> {
        let profile = Profile::new(cfg.scheme, cfg.limits)
            .map_err(|_| FrameError::OutOfBounds(reason::BAD_SCHEME))?;
        Ok(Self {
            cfg,
            mode: Mode::CalStatic(0),
            ctrl: RateController::new(cfg.motor, cfg.bandwidth_hz),
            profile,
            scheme_t0: None,
            unwrap: CounterUnwrapper::new(),
            last_hw: None,
            glitch_run: 0,
            enc: EncoderInterpolator::new(40_000),
            enc_hist: heapless::Deque::new(),
            last_count: None,
            rate_window: None,
            stall_since: None,
            rate_ok_since: None,
            work: Work::Phase(PhaseAccumulator::new(0.0, Axis::Z)),
            static_phase: None,
            calibration: None,
            stored: None,
            previous: None,
            change: None,
            nav: None,
            nav_count: 0,
            last_imu_us: None,
            rate_meas: 0.0,
            duty: 0.0,
            avg: [0.0; 7],
            avg_n: 0,
            last_nav: None,
            monitor: DataMonitor::default(),
            faults: FaultCounts::default(),
            last_refusal: None,
            tx: heapless::Deque::new(),
            seq: 0,
            rx: Decoder::default(),
        })
    }

    /// Takes the calibration record found in flash at power-up. A valid
    /// record is reported (`Calibration` with status
    /// [`CAL_STATUS_STORED`]) and kept: the power-up calibration still runs
    /// and, when accepted, its change from this record is reported
    /// (`CalibrationChange`). Returns whether the record was valid (blank or
    /// corrupt flash: `false`, nothing kept).
    pub fn restore(&mut self, record: &[u8; CAL_RECORD]) -> bool {
        let Some(c) = decode_record(record, Axis::Z) else {
            return false;
        };
        self.previous = Some(c);
        self.emit(Telemetry::Calibration {
            bias_radps: f32x3(&c.bias),
            m_k: f32x3(&c.m_k),
            status: CAL_STATUS_STORED,
        });
        true
    }

    /// The motor duty in [-1, 1] (sign = direction) to apply now.
    pub fn duty(&self) -> f32 {
        self.duty
    }

    /// The navigation state (while navigating).
    pub fn nav(&self) -> Option<&Strapdown<f32>> {
        self.aided().map(AidedNav::nav).or(self.nav.as_ref())
    }

    /// The aided navigator (while navigating with it).
    pub fn aided(&self) -> Option<&AidedNav<f32>> {
        match &self.work {
            Work::Aided(a) => Some(a),
            Work::Phase(_) => None,
        }
    }

    /// Adds a sample to the calibration phase's sums; a refused sample is
    /// a counted fault.
    fn accumulate(
        &mut self,
        t_us: u64,
        w: &Vector3<f32>,
        f: &Vector3<f32>,
        angle: TableAngle<f32>,
    ) {
        let refused = match &mut self.work {
            Work::Phase(acc) => acc.push(t_us, w, f, angle).is_err(),
            Work::Aided(_) => true,
        };
        if refused {
            self.fault(t_us, Fault::NavRefused);
        }
    }

    /// The calibration phase's result.
    fn finish_phase(&self) -> Result<Phase, core_nav::calib::CalibError> {
        match &self.work {
            Work::Phase(acc) => acc.finish(&self.checks(), self.cfg.nav_period_us as f64 * 1e-6),
            Work::Aided(_) => Err(core_nav::calib::CalibError::NotEnoughData),
        }
    }

    fn emit(&mut self, t: Telemetry) {
        let mut p = [0u8; MAX_PAYLOAD];
        let mut f = [0u8; MAX_FRAME];
        let Ok(n) = t.payload(self.seq, &mut p) else {
            return;
        };
        let Ok(m) = frame(p.get(..n).unwrap_or(&[]), &mut f) else {
            return;
        };
        self.seq = self.seq.wrapping_add(1);
        if self.tx.push_back((f, m)).is_err() {
            // Counted, never silent: the host also sees the sequence gap.
            self.faults.count(Fault::TelemetryOverflow);
        }
    }

    fn fault(&mut self, t_us: u64, f: Fault) {
        let count = self.faults.count(f);
        self.emit(Telemetry::Fault {
            t_us,
            code: f as u8,
            count,
        });
    }

    /// The IMU did not come up at power-up: `wrong_device` when WHO_AM_I
    /// was not the ICM-42688-P's, else a bus failure. Counted and reported
    /// (`Fault`); safe state: stopped (no calibration, no navigation, the
    /// motor off).
    pub fn on_imu_init_failed(&mut self, t_us: u64, wrong_device: bool) {
        let f = if wrong_device {
            Fault::WrongDevice
        } else {
            Fault::SpiError
        };
        self.stop(t_us, f);
    }

    fn stop(&mut self, t_us: u64, f: Fault) {
        self.duty = 0.0;
        self.ctrl.reset();
        self.scheme_t0 = None;
        self.mode = Mode::Stopped(f);
        self.fault(t_us, f);
    }

    /// Hands the queued telemetry frames to `send` (the UART).
    pub fn drain(&mut self, mut send: impl FnMut(&[u8])) {
        while let Some((f, n)) = self.tx.pop_front() {
            send(f.get(..n).unwrap_or(&[]));
        }
    }

    fn table_angle(&self, t_us: u64) -> TableAngle<f32> {
        self.enc
            .angle_at(t_us)
            .or_else(|_| {
                self.enc
                    .latest()
                    .map(|(_, a)| a)
                    .ok_or(core_nav::NavError::NoEncoderData)
            })
            .unwrap_or_default()
    }

    /// An SPI failure while reading the IMU: counted, the sample skipped.
    pub fn on_imu_error(&mut self, t_us: u64) {
        self.fault(t_us, Fault::SpiError);
    }

    /// A new IMU sample at `t_us` (raw words and SI values, sensor frame):
    /// the rate loop every sample; calibration, navigation and telemetry on
    /// the navigation grid (`t_us` a multiple of `nav_period_us`).
    pub fn on_imu(&mut self, t_us: u64, raw: &RawSample, s: &Sample) {
        match self.monitor.check(raw) {
            Some(DataFault::Stuck) => return self.stop(t_us, Fault::ImuStuck),
            Some(DataFault::Saturated) => return self.fault(t_us, Fault::ImuSaturated),
            None => {}
        }
        let dt = self
            .last_imu_us
            .map_or(1e-3, |t| (t_us.saturating_sub(t)) as f32 * 1e-6);
        self.last_imu_us = Some(t_us);
        self.rate_meas = s.gyro_radps[2];
        let angle = self.table_angle(t_us);
        // Navigation takes the mean of the samples in each nav period: a
        // 1 kHz sample carries sqrt(10) the white noise of a 100 Hz one, and
        // keeping only every tenth would alias it all in.
        for (a, v) in self.avg.iter_mut().zip(
            s.gyro_radps
                .iter()
                .chain(s.accel_mps2.iter())
                .chain([s.temp_c].iter()),
        ) {
            *a += v;
        }
        self.avg_n += 1;
        if t_us.is_multiple_of(self.cfg.nav_period_us.max(1)) {
            let n = self.avg_n.max(1) as f32;
            let m = self.avg.map(|a| a / n);
            let mean = Sample {
                gyro_radps: [m[0], m[1], m[2]],
                accel_mps2: [m[3], m[4], m[5]],
                temp_c: m[6],
            };
            self.avg = [0.0; 7];
            self.avg_n = 0;
            self.on_nav_tick(t_us, raw, &mean, angle);
        }
        self.control(t_us, angle, dt);
    }

    /// The last navigation-rate sample (the period's mean) and its time.
    pub fn last_nav_sample(&self) -> Option<(u64, Sample)> {
        self.last_nav
    }

    fn on_nav_tick(&mut self, t_us: u64, raw: &RawSample, s: &Sample, angle: TableAngle<f32>) {
        self.last_nav = Some((t_us, *s));
        self.emit(Telemetry::Imu {
            t_us,
            gyro_radps: s.gyro_radps,
            accel_mps2: s.accel_mps2,
            temp_c: s.temp_c,
        });
        let w = Vector3::from(s.gyro_radps);
        let f = Vector3::from(s.accel_mps2);
        match self.mode {
            Mode::CalStatic(_) if self.cfg.aided.is_some() => self.start_aided(t_us, s, angle),
            Mode::CalStatic(t0) => {
                self.accumulate(t_us, &w, &f, angle);
                if t_us.saturating_sub(t0) as f64 * 1e-6 >= self.cfg.static_s {
                    match self.finish_phase() {
                        Ok(p) => {
                            self.static_phase = Some(p);
                            self.start_scheme(t_us, angle);
                            self.mode = Mode::CalSpinUp(t_us);
                        }
                        Err(e) => self.refuse(t_us, e),
                    }
                }
            }
            Mode::CalSpinUp(t0) => {
                if t_us.saturating_sub(t0) as f64 * 1e-6 > self.cfg.spinup_timeout_s {
                    self.refuse(
                        t_us,
                        core_nav::calib::CalibError::RateNotReached {
                            measured_radps: f64::from(self.rate_meas),
                            commanded_radps: self.cfg.scheme_rate(),
                        },
                    );
                } else if self
                    .rate_ok_since
                    .is_some_and(|s| t_us.saturating_sub(s) >= 2_000_000)
                {
                    self.work = Work::Phase(PhaseAccumulator::new(self.cfg.scheme_rate(), Axis::Z));
                    self.mode = Mode::CalRotate(t_us);
                }
            }
            Mode::CalRotate(t0) => {
                self.accumulate(t_us, &w, &f, angle);
                if t_us.saturating_sub(t0) as f64 * 1e-6 >= self.cfg.rotate_s {
                    self.finish_calibration(t_us, raw, s, angle);
                }
            }
            Mode::Navigating => self.navigate(t_us, s, angle),
            Mode::Stopped(_) => {}
        }
    }

    /// The board's site (core-nav's one model of gravity and earth rate).
    fn site(&self) -> Site {
        Site::new(self.cfg.lat_deg, self.cfg.height_m)
    }

    fn checks(&self) -> Checks {
        Checks {
            gravity_mps2: self.site().gravity_mps2,
            ..Checks::default()
        }
    }

    fn refuse(&mut self, t_us: u64, e: core_nav::calib::CalibError) {
        self.last_refusal = Some(e);
        self.emit(Telemetry::Calibration {
            bias_radps: [0.0; 3],
            m_k: [0.0; 3],
            status: refusal_code(&e),
        });
        self.fault(t_us, Fault::CalibrationRefused);
        self.restart_calibration(t_us);
    }

    fn restart_calibration(&mut self, t_us: u64) {
        self.duty = 0.0;
        self.ctrl.reset();
        self.scheme_t0 = None;
        self.rate_ok_since = None;
        self.work = Work::Phase(PhaseAccumulator::new(0.0, Axis::Z));
        self.nav = None;
        self.mode = Mode::CalStatic(t_us);
    }

    fn start_scheme(&mut self, t_us: u64, angle: TableAngle<f32>) {
        let a = angle.to_rad();
        self.scheme_t0 = Some((t_us, a));
        self.rate_ok_since = None;
        self.stall_since = None;
        self.ctrl.reset();
    }

    fn finish_calibration(
        &mut self,
        t_us: u64,
        _raw: &RawSample,
        s: &Sample,
        angle: TableAngle<f32>,
    ) {
        let rot = match self.finish_phase() {
            Ok(p) => p,
            Err(e) => return self.refuse(t_us, e),
        };
        let Some(st) = self.static_phase else {
            return self.restart_calibration(t_us);
        };
        let [r, p, h] = self.cfg.base_deg;
        let base = Euler::<f64>::from_deg(r, p, h);
        let earth = self.site().earth_model(&base, Axis::Z);
        let cal = match solve(
            &[st, rot],
            &earth,
            Unknowns {
                quadratic: false,
                asymmetry: false,
            },
            Axis::Z,
        ) {
            Ok(c) => c,
            Err(e) => return self.refuse(t_us, e),
        };
        // Plausible for a MEMS gyro: bias under 5 deg/s, M k under 5 %.
        if cal.bias.amax() > 5f64.to_radians() || cal.m_k.amax() > 0.05 {
            return self.refuse(t_us, core_nav::calib::CalibError::Degenerate);
        }
        self.calibration = Some(cal);
        self.stored = Some(encode_record(&cal));
        self.emit(Telemetry::Calibration {
            bias_radps: f32x3(&cal.bias),
            m_k: f32x3(&cal.m_k),
            status: 0,
        });
        if let Some(p) = self.previous {
            let change = (cal.bias - p.bias, cal.m_k - p.m_k);
            self.change = Some(change);
            self.emit(Telemetry::CalibrationChange {
                d_bias_radps: f32x3(&change.0),
                d_m_k: f32x3(&change.1),
            });
        }
        // Navigation starts here, from the known base attitude and the table angle.
        let theta = angle.rad;
        let q0 = euler_to_quat(&base) * q_s_b(Axis::Z, f64::from(theta));
        let q0 = Quaternion::from(q0.coords.map(|x| x as f32));
        let first = self.imu_sample(t_us, s);
        let cfg = StrapdownConfig {
            gravity_mps2: None,
            ..StrapdownConfig::default()
        };
        let origin = GeoPoint::from_deg(self.cfg.lat_deg, 0.0, self.cfg.height_m);
        match Strapdown::new(cfg, origin, Vector3::zeros(), q0, &first) {
            Ok(n) => {
                self.nav = Some(n);
                self.mode = Mode::Navigating;
            }
            Err(_) => self.restart_calibration(t_us),
        }
    }

    /// The calibrated sample the navigation uses: the period's mean `s`,
    /// which stands for the middle of the period ending at `t_us`
    /// (recording-v1 `sample = "average"`; the host shifts the same way).
    pub fn imu_sample(&self, t_us: u64, s: &Sample) -> ImuSample<f32> {
        let w = Vector3::from(s.gyro_radps);
        ImuSample {
            t_us: t_us.saturating_sub(self.cfg.nav_period_us / 2),
            w_is_s: self.calibration.map_or(w, |c| c.apply(&w)),
            f_s: Vector3::from(s.accel_mps2),
        }
    }

    /// Aided: navigation starts at the first sample with an encoder
    /// angle, from the configured origin and vehicle attitude; the table
    /// starts turning.
    fn start_aided(&mut self, t_us: u64, s: &Sample, angle: TableAngle<f32>) {
        let Some(a) = self.cfg.aided else { return };
        if self.enc.latest().is_none() {
            return;
        }
        let [r, p, h] = self.cfg.base_deg;
        let q = euler_to_quat(&Euler::<f64>::from_deg(r, p, h));
        let q_b_n = Quaternion::from(q.coords.map(|x| x as f32));
        let cfg = StrapdownConfig {
            gravity_mps2: None,
            ..StrapdownConfig::default()
        };
        let first = self.imu_sample(t_us, s);
        match AidedNav::new(cfg, a.origin, &q_b_n, &angle, &first, a.cfg) {
            Ok(n) => {
                self.work = Work::Aided(n);
                self.start_scheme(t_us, angle);
                self.mode = Mode::Navigating;
            }
            Err(_) => self.fault(t_us, Fault::NavRefused),
        }
    }

    fn navigate(&mut self, t_us: u64, s: &Sample, angle: TableAngle<f32>) {
        let sample = self.imu_sample(t_us, s);
        let step = if let Work::Aided(a) = &mut self.work {
            let rate = match (self.enc_hist.front(), self.enc_hist.back()) {
                (Some((t0, a0)), Some((t1, a1))) if t1 > t0 => {
                    a1.minus(a0) / ((t1 - t0) as f32 * 1e-6)
                }
                _ => 0.0,
            };
            a.step(&sample, &angle, rate).map(|_| *a.nav().state())
        } else if let Some(nav) = self.nav.as_mut() {
            nav.step(&sample).copied()
        } else {
            return;
        };
        match step {
            Ok(st) => {
                self.nav_count = self.nav_count.wrapping_add(1);
                if self.nav_count.is_multiple_of(self.cfg.nav_every.max(1)) {
                    let q = q_b_n(&st.q_s_n, Axis::Z, angle.rad);
                    self.emit(Telemetry::Nav {
                        t_us,
                        q_b_n: [q.w, q.i, q.j, q.k],
                        v_n: [st.v_n.x, st.v_n.y, st.v_n.z],
                        p_n: [st.p_n.x, st.p_n.y, st.p_n.z],
                    });
                }
            }
            Err(_) => self.fault(t_us, Fault::NavRefused),
        }
    }

    fn control(&mut self, t_us: u64, angle: TableAngle<f32>, dt: f32) {
        let Some((t0, a0)) = self.scheme_t0 else {
            self.duty = 0.0;
            return;
        };
        let r: Reference = self.profile.at(t_us.saturating_sub(t0) as f64 * 1e-6);
        let a = angle.to_rad();
        let err = r.angle as f32 - (a - a0);
        self.duty = self.ctrl.update(&r, err, self.rate_meas, dt);
    }

    /// An encoder read at `t_us`: the 16-bit hardware counter. A read that
    /// implies a rate above twice the table's limit is a glitch: counted and
    /// dropped (the last accepted read stays the reference); after three in
    /// a row the new count is accepted (a lasting offset: resync).
    pub fn on_encoder(&mut self, t_us: u64, hw: u16) {
        if let Some((tl, hl)) = self.last_hw {
            let d = CounterUnwrapper::delta(hl, hw) as f64;
            let dt = (t_us.saturating_sub(tl)) as f64 * 1e-6;
            let rate = EncoderScale::new(self.cfg.counts_per_rev).rate(d, dt.max(1e-6));
            if libm::fabs(rate) > 2.0 * self.cfg.limits.max_rate && self.glitch_run < 3 {
                self.glitch_run += 1;
                return self.fault(t_us, Fault::EncoderGlitch);
            }
        }
        self.glitch_run = 0;
        let moved = self.last_hw.is_some_and(|(_, hl)| hl != hw);
        self.last_hw = Some((t_us, hw));
        let counts = self.unwrap.update(hw);
        // The static phase counts only while the table is at rest (after a
        // refusal the table may still be coasting down).
        if moved && matches!(self.mode, Mode::CalStatic(_)) {
            self.work = Work::Phase(PhaseAccumulator::new(0.0, Axis::Z));
            self.mode = Mode::CalStatic(t_us);
        }
        self.last_count = Some((t_us, counts));
        let angle = TableAngle::from_counts(counts, self.cfg.counts_per_rev);
        if self.enc.push(t_us, angle).is_err() {
            self.fault(t_us, Fault::EncoderGlitch);
        } else {
            if self.enc_hist.is_full() {
                self.enc_hist.pop_front();
            }
            // Cannot fail: a slot was just made.
            let _ = self.enc_hist.push_back((t_us, angle));
        }
        self.emit(Telemetry::Encoder {
            t_us,
            counts,
            counts_per_rev: self.cfg.counts_per_rev,
        });
        self.check_rate(t_us, counts);
    }

    /// Encoder rate over ~1 s against the command: spin-up done, or a stall.
    fn check_rate(&mut self, t_us: u64, counts: i64) {
        let (tw, cw) = *self.rate_window.get_or_insert((t_us, counts));
        if t_us.saturating_sub(tw) < 500_000 {
            return;
        }
        self.rate_window = Some((t_us, counts));
        let rate = EncoderScale::new(self.cfg.counts_per_rev)
            .rate((counts - cw) as f64, t_us.saturating_sub(tw) as f64 * 1e-6);
        let Some((t0, _)) = self.scheme_t0 else {
            return;
        };
        let want = self.profile.at(t_us.saturating_sub(t0) as f64 * 1e-6).rate;
        if libm::fabs(want) < 2f64.to_radians() {
            return;
        }
        if libm::fabs(rate / want - 1.0) < 0.02 {
            self.rate_ok_since.get_or_insert(t_us);
        } else {
            self.rate_ok_since = None;
        }
        if libm::fabs(rate) < 0.2 * libm::fabs(want) {
            let since = *self.stall_since.get_or_insert(t_us);
            if t_us.saturating_sub(since) >= 1_000_000 {
                self.stop(t_us, Fault::MotorStall);
            }
        } else {
            self.stall_since = None;
        }
    }

    /// The watchdog: called by the scheduler (e.g. at 10 Hz); no IMU sample
    /// for 100 ms stops the motor.
    pub fn check_watchdog(&mut self, t_us: u64) {
        if let Some(t) = self.last_imu_us {
            if t_us.saturating_sub(t) > 100_000 && !matches!(self.mode, Mode::Stopped(_)) {
                self.stop(t_us, Fault::ImuTimeout);
            }
        }
    }

    /// Bytes from the host: decoded, bounds-checked, answered with an Ack.
    pub fn on_rx(&mut self, t_us: u64, bytes: &[u8]) {
        let mut out = [0u8; MAX_PAYLOAD + 2];
        for b in bytes {
            let Some(n) = self.rx.push(*b, &mut out) else {
                continue;
            };
            let seq = u16::from_le_bytes([
                out.get(1).copied().unwrap_or(0),
                out.get(2).copied().unwrap_or(0),
            ]);
            let status = match Command::parse(out.get(..n).unwrap_or(&[])) {
                Ok((_, c)) => self.apply(t_us, c),
                Err(FrameError::OutOfBounds(r)) => r,
                Err(_) => reason::MALFORMED,
            };
            if status != 0 {
                self.fault(t_us, Fault::BadCommand);
            }
            self.emit(Telemetry::Ack { seq, status });
        }
    }

    fn apply(&mut self, t_us: u64, c: Command) -> u8 {
        match c {
            Command::Start => {
                let a = self.table_angle(t_us);
                self.start_scheme(t_us, a);
                if matches!(self.mode, Mode::Stopped(_)) {
                    self.mode = if self.nav().is_some() {
                        Mode::Navigating
                    } else {
                        Mode::CalStatic(t_us)
                    };
                }
                0
            }
            Command::Stop => {
                self.duty = 0.0;
                self.scheme_t0 = None;
                0
            }
            // The aided filter estimates the gyro errors itself, and a
            // restart would lose the vehicle's position: refused.
            Command::Recalibrate if self.aided().is_some() => reason::AIDED,
            Command::Recalibrate => {
                self.restart_calibration(t_us);
                0
            }
            Command::GnssFix(f) => match &mut self.work {
                Work::Aided(a) => {
                    a.gnss(&f);
                    0
                }
                Work::Phase(_) => reason::NOT_AIDED,
            },
            Command::SetScheme {
                kind,
                rate_dps,
                count,
            } => {
                let rate = f64::from(rate_dps).to_radians();
                let scheme = match kind {
                    0 => Scheme::Still,
                    1 => Scheme::Continuous { rate },
                    2 => Scheme::Reciprocating {
                        rate,
                        turns: u32::from(count),
                    },
                    _ => Scheme::Indexed {
                        rate,
                        positions: count,
                        dwell_s: 10.0,
                    },
                };
                match Profile::new(scheme, self.cfg.limits) {
                    Ok(p) => {
                        self.profile = p;
                        self.cfg.scheme = scheme;
                        0
                    }
                    Err(_) => reason::BAD_RATE,
                }
            }
        }
    }
}

impl AppConfig {
    /// The scheme's rate (the calibration's), rad/s.
    pub fn scheme_rate(&self) -> f64 {
        match self.scheme {
            Scheme::Still => 0.0,
            Scheme::Continuous { rate }
            | Scheme::Reciprocating { rate, .. }
            | Scheme::Indexed { rate, .. } => rate,
        }
    }
}

/// The calibration refusal code sent in telemetry (`Calibration.status`).
pub fn refusal_code(e: &core_nav::calib::CalibError) -> u8 {
    use core_nav::calib::CalibError as E;
    match e {
        E::TableMoved { .. } => 1,
        E::NotStatic { .. } => 2,
        E::NotLevelOrMoving { .. } => 3,
        E::RateNotReached { .. } => 4,
        E::NotAWholeTurn => 5,
        E::NotEnoughData => 6,
        E::Degenerate => 7,
        E::NonFinite => 8,
    }
}

//! The navigation task's logic (below the control tick, above the link):
//! the power-up calibration ([`crate::calibration`]), then the strapdown
//! mechanization in f32 on a static base, or the aided navigator on a
//! moving vehicle with GNSS fixes applied at their time of validity.
//!
//! It takes one [`NavInput`] per navigation period from the tick's queue
//! and the link's commands from its own; it asks the tick to start or stop
//! the table, and sends its telemetry (and the calibration to store) to the
//! link. A propagation of the filter (hundreds of thousands of
//! instructions) runs here, preempted by every control tick.

use crate::calibration::{refusal_status, CalConfig, CalPhase, CalStep, PowerUp};
use crate::control::{ControlCmd, NavInput};
use crate::faults::{Fault, FaultCounts};
use crate::icm42688::Sample;
use core_nav::aided::{AidedConfig, AidedNav, GnssFix, OriginE7};
use core_nav::attitude::{euler_to_quat, Euler};
use core_nav::calib::GyroCalibration;
use core_nav::earth::GeoPoint;
use core_nav::eskf::Workspace;
use core_nav::site::Site;
use core_nav::strapdown::{ImuSample, Strapdown, StrapdownConfig};
use core_nav::table::{q_b_n, q_s_b, Axis, TableAngle};
use nalgebra::{Quaternion, Vector3};
use protocol::record::StoredCalibration;
use protocol::{CalStatus, Status, Telemetry};

/// Fixes waiting for their application time.
pub const FIX_QUEUE: usize = 8;

/// Navigation's settings (from the stored configuration).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavConfig {
    /// Site latitude, deg.
    pub lat_deg: f64,
    /// Site height, m.
    pub height_m: f64,
    /// Base attitude: roll, pitch, heading, deg.
    pub base_deg: [f64; 3],
    /// The scheme's rate (the calibration's), rad/s.
    pub scheme_rate_radps: f64,
    /// The calibration's durations.
    pub cal: CalConfig,
    /// The navigation period, µs.
    pub period_us: u64,
    /// A navigation frame every this many steps.
    pub telemetry_every: u32,
    /// Aided navigation (`None`: a static base).
    pub aided: Option<BoardAided>,
    /// A fix is applied this long after its time of validity (µs): the
    /// longest receiver-plus-link latency expected. A fix arriving earlier
    /// waits; one arriving later is applied at arrival (counted late).
    /// Either way its innovation comes from the state stored for its time
    /// of validity, and the outcome does not depend on when within the
    /// horizon it arrived.
    pub fix_horizon_us: u64,
}

impl Default for NavConfig {
    fn default() -> Self {
        Self {
            lat_deg: 0.0,
            height_m: 0.0,
            base_deg: [0.0; 3],
            scheme_rate_radps: 30f64.to_radians(),
            cal: CalConfig::default(),
            period_us: 10_000,
            telemetry_every: 10,
            aided: None,
            fix_horizon_us: 400_000,
        }
    }
}

/// The board's aided-navigation settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardAided {
    /// Where the vehicle powers up (the navigation origin).
    pub origin: OriginE7,
    /// The filter, the antenna lever arm, zero-velocity updates.
    pub cfg: AidedConfig,
}

/// Where navigation is.
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
    /// Motor off after a fault, waiting for a start command.
    Stopped(Fault),
}

impl Mode {
    /// Its code in the QEMU outcome (3 navigating).
    pub fn code(&self) -> u8 {
        match self {
            Mode::CalStatic(_) => 0,
            Mode::CalSpinUp(_) => 1,
            Mode::CalRotate(_) => 2,
            Mode::Navigating => 3,
            Mode::Stopped(_) => 4,
        }
    }
}

/// A command for navigation (each with the sequence number it is acked with).
// A configuration is the large variant: the queue's slots are sized for
// it (8 of them); no heap on the board.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NavCmd {
    /// A GNSS fix valid at `t_valid_us`.
    Fix {
        /// The command's sequence number.
        seq: u16,
        /// µs, the board's clock.
        t_valid_us: u64,
        /// The fix.
        fix: GnssFix,
    },
    /// The power-up calibration again.
    Recalibrate {
        /// The command's sequence number.
        seq: u16,
    },
    /// Start after a stop or a fault.
    Start {
        /// The command's sequence number.
        seq: u16,
    },
    /// A new configuration (already acknowledged and stored by the link).
    Config(NavConfig),
}

/// What navigation sends to the link.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outbound {
    /// A message for the host.
    Telemetry(Telemetry),
    /// An accepted calibration for the flash record.
    Store(StoredCalibration),
}

/// What navigation is running. The calibration's sums (4 KiB) and the
/// aided navigator (12 KiB) are fields of their own, restarted in place:
/// neither is ever built as a value on the navigation task's stack.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    Cal,
    Aided,
    Idle,
}

/// The navigation task's large state, statics on the board (36 KiB in
/// all): built in place at boot, never as a value on a stack.
pub struct NavMemory<'a> {
    /// The filter's workspace.
    pub ws: &'a mut Workspace<f32>,
    /// The aided navigator (12 KiB, [`AidedNav::BLANK`] until aided
    /// navigation starts it in place).
    pub aided: &'a mut AidedNav<f32>,
    /// Where the calibration's sums are built (4 KiB).
    pub cal: &'a mut core::mem::MaybeUninit<PowerUp>,
}

/// Builds the calibration's sums in their static, in a frame of their own.
#[inline(never)]
fn place_cal(
    slot: &mut core::mem::MaybeUninit<PowerUp>,
    cfg: CalConfig,
    t_us: u64,
) -> &mut PowerUp {
    slot.write(PowerUp::new(cfg, t_us))
}

/// The navigation task's state (`'a`: its [`NavMemory`]).
pub struct Navigator<'a> {
    cfg: NavConfig,
    mode: Mode,
    stage: Stage,
    cal: &'a mut PowerUp,
    aided: &'a mut AidedNav<f32>,
    ws: &'a mut Workspace<f32>,
    /// The calibration in use.
    pub calibration: Option<GyroCalibration>,
    /// The calibration stored at power-up.
    pub previous: Option<GyroCalibration>,
    nav: Option<Strapdown<f32>>,
    steps: u32,
    last: Option<NavInput>,
    fixes: heapless::Deque<(u64, GnssFix), FIX_QUEUE>,
    /// Fixes applied after the horizon.
    pub fixes_late: u32,
    saw_stop: bool,
    /// Fault counters.
    pub faults: FaultCounts,
}

fn f32x3(v: &Vector3<f64>) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

impl<'a> Navigator<'a> {
    /// Navigation at power-up (`t_us`), with the calibration found in flash
    /// and its large state in `mem` (the aided navigator is restarted in
    /// place, with the configuration's filter, when aided navigation
    /// starts).
    pub fn new(
        cfg: NavConfig,
        t_us: u64,
        stored: Option<StoredCalibration>,
        mem: NavMemory<'a>,
    ) -> Self {
        let previous = stored.map(|s| GyroCalibration {
            bias: Vector3::from(s.bias_radps).map(f64::from),
            m_k: Vector3::from(s.m_k).map(f64::from),
            axis: Axis::Z,
            ..GyroCalibration::default()
        });
        Self {
            cfg,
            mode: Mode::CalStatic(t_us),
            stage: Stage::Cal,
            cal: place_cal(mem.cal, cfg.cal, t_us),
            aided: mem.aided,
            ws: mem.ws,
            calibration: None,
            previous,
            nav: None,
            steps: 0,
            last: None,
            fixes: heapless::Deque::new(),
            fixes_late: 0,
            saw_stop: false,
            faults: FaultCounts::default(),
        }
    }

    /// The record found at power-up, as telemetry (sent once at boot).
    pub fn stored_report(&self) -> Option<Telemetry> {
        self.previous.map(|c| Telemetry::Calibration {
            bias_radps: f32x3(&c.bias),
            m_k: f32x3(&c.m_k),
            status: CalStatus::Stored,
        })
    }

    /// Where it is.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The settings.
    pub fn config(&self) -> &NavConfig {
        &self.cfg
    }

    /// The mechanization (while navigating).
    pub fn nav(&self) -> Option<&Strapdown<f32>> {
        self.aided().map(AidedNav::nav).or(self.nav.as_ref())
    }

    /// The aided navigator (while navigating with it).
    pub fn aided(&self) -> Option<&AidedNav<f32>> {
        (self.stage == Stage::Aided).then_some(&*self.aided)
    }

    /// The last input (its time and mean sample).
    pub fn last_input(&self) -> Option<&NavInput> {
        self.last.as_ref()
    }

    fn site(&self) -> Site {
        Site::new(self.cfg.lat_deg, self.cfg.height_m)
    }

    fn base(&self) -> Euler<f64> {
        let [r, p, h] = self.cfg.base_deg;
        Euler::<f64>::from_deg(r, p, h)
    }

    fn fault(&mut self, t_us: u64, f: Fault, out: &mut impl FnMut(Outbound)) {
        if let Some(t) = self.faults.count(t_us, f) {
            out(Outbound::Telemetry(t));
        }
    }

    fn restart(&mut self, t_us: u64, ctl: &mut impl FnMut(ControlCmd)) {
        ctl(ControlCmd::Stop);
        self.cal.restart(t_us);
        self.stage = Stage::Cal;
        self.nav = None;
        self.fixes.clear();
        self.mode = Mode::CalStatic(t_us);
    }

    /// One navigation period's input from the tick.
    pub fn input(
        &mut self,
        x: &NavInput,
        out: &mut impl FnMut(Outbound),
        ctl: &mut impl FnMut(ControlCmd),
    ) {
        self.last = Some(*x);
        out(Outbound::Telemetry(Telemetry::Imu {
            t_us: x.t_us,
            gyro_radps: x.mean.gyro_radps,
            accel_mps2: x.mean.accel_mps2,
            temp_c: x.mean.temp_c,
        }));
        // A stop the tick reports is taken once, when it begins (a start
        // command may come before the tick has heard of it).
        let new_stop = x.stopped.is_some() && !self.saw_stop;
        self.saw_stop = x.stopped.is_some();
        if let (Some(f), true) = (x.stopped, new_stop) {
            self.mode = Mode::Stopped(f);
            return;
        }
        match self.mode {
            Mode::Stopped(_) => {}
            Mode::Navigating => self.navigate(x, out),
            _ if self.cfg.aided.is_some() => self.start_aided(x, out, ctl),
            _ => self.calibrate(x, out, ctl),
        }
    }

    #[inline(never)]
    fn calibrate(
        &mut self,
        x: &NavInput,
        out: &mut impl FnMut(Outbound),
        ctl: &mut impl FnMut(ControlCmd),
    ) {
        let (site, base, rate) = (self.site(), self.base(), self.cfg.scheme_rate_radps);
        if self.stage != Stage::Cal {
            return self.restart(x.t_us, ctl);
        }
        let step = self.cal.input(x, &site, &base, rate);
        self.mode = match self.cal.phase() {
            CalPhase::Static(t) => Mode::CalStatic(t),
            CalPhase::SpinUp(t) => Mode::CalSpinUp(t),
            CalPhase::Rotate(t) => Mode::CalRotate(t),
        };
        match step {
            CalStep::Continue => {}
            CalStep::StartTable => ctl(ControlCmd::StartScheme),
            CalStep::Refused(e) => {
                out(Outbound::Telemetry(Telemetry::Calibration {
                    bias_radps: [0.0; 3],
                    m_k: [0.0; 3],
                    status: refusal_status(&e),
                }));
                self.fault(x.t_us, Fault::CalibrationRefused, out);
                self.restart(x.t_us, ctl);
            }
            CalStep::Accepted(c) => self.accept(x, c, out, ctl),
        }
    }

    #[inline(never)]
    fn accept(
        &mut self,
        x: &NavInput,
        c: GyroCalibration,
        out: &mut impl FnMut(Outbound),
        ctl: &mut impl FnMut(ControlCmd),
    ) {
        self.calibration = Some(c);
        let stored = StoredCalibration {
            bias_radps: f32x3(&c.bias),
            m_k: f32x3(&c.m_k),
        };
        out(Outbound::Store(stored));
        out(Outbound::Telemetry(Telemetry::Calibration {
            bias_radps: stored.bias_radps,
            m_k: stored.m_k,
            status: CalStatus::Accepted,
        }));
        if let Some(p) = self.previous {
            out(Outbound::Telemetry(Telemetry::CalibrationChange {
                d_bias_radps: f32x3(&(c.bias - p.bias)),
                d_m_k: f32x3(&(c.m_k - p.m_k)),
            }));
        }
        // Navigation starts here, from the known base attitude and the table angle.
        let q0 = euler_to_quat(&self.base()) * q_s_b(Axis::Z, f64::from(x.angle.rad));
        let q0 = Quaternion::from(q0.coords.map(|v| v as f32));
        let first = self.imu_sample(x.t_us, &x.mean);
        let cfg = StrapdownConfig {
            gravity_mps2: None,
            ..StrapdownConfig::default()
        };
        let origin = GeoPoint::from_deg(self.cfg.lat_deg, 0.0, self.cfg.height_m);
        match Strapdown::new(cfg, origin, Vector3::zeros(), q0, &first) {
            Ok(n) => {
                self.nav = Some(n);
                self.stage = Stage::Idle;
                self.mode = Mode::Navigating;
            }
            Err(_) => self.restart(x.t_us, ctl),
        }
    }

    /// The calibrated sample navigation uses: the period's mean, which
    /// stands for the middle of the period ending at `t_us` (recording-v1
    /// `sample = "average"`; the host shifts the same way).
    pub fn imu_sample(&self, t_us: u64, s: &Sample) -> ImuSample<f32> {
        let w = Vector3::from(s.gyro_radps);
        ImuSample {
            t_us: t_us.saturating_sub(self.cfg.period_us / 2),
            w_is_s: self.calibration.map_or(w, |c| c.apply(&w)),
            f_s: Vector3::from(s.accel_mps2),
        }
    }

    /// Aided: navigation starts at the first input with an encoder angle,
    /// from the configured origin and vehicle attitude; the table starts.
    #[inline(never)]
    fn start_aided(
        &mut self,
        x: &NavInput,
        out: &mut impl FnMut(Outbound),
        ctl: &mut impl FnMut(ControlCmd),
    ) {
        let Some(a) = self.cfg.aided else { return };
        if !x.encoder_seen {
            return;
        }
        let q = euler_to_quat(&self.base());
        let q_b_n = Quaternion::from(q.coords.map(|v| v as f32));
        let cfg = StrapdownConfig {
            gravity_mps2: None,
            ..StrapdownConfig::default()
        };
        let first = self.imu_sample(x.t_us, &x.mean);
        match self
            .aided
            .restart(cfg, a.origin, &q_b_n, &x.angle, &first, a.cfg)
        {
            Ok(()) => {
                self.stage = Stage::Aided;
                ctl(ControlCmd::StartScheme);
                self.mode = Mode::Navigating;
            }
            Err(_) => self.fault(x.t_us, Fault::NavRefused, out),
        }
    }

    /// Hands the aided navigator the first fix whose horizon has passed.
    #[inline(never)]
    fn due_fix(&mut self, t_us: u64, out: &mut impl FnMut(Outbound)) {
        let horizon = self.cfg.fix_horizon_us;
        let due = self
            .fixes
            .front()
            .is_some_and(|(tv, _)| tv.saturating_add(horizon) <= t_us);
        if !due {
            return;
        }
        let Some((tv, fix)) = self.fixes.pop_front() else {
            return;
        };
        if self.stage != Stage::Aided {
            return;
        }
        let r = self.aided.gnss_at(&fix, tv);
        if r.is_err() {
            self.fault(t_us, Fault::FixRefused, out);
        }
    }

    #[inline(never)]
    fn navigate(&mut self, x: &NavInput, out: &mut impl FnMut(Outbound)) {
        self.due_fix(x.t_us, out);
        let sample = self.imu_sample(x.t_us, &x.mean);
        let step = if self.stage == Stage::Aided {
            let a = &mut *self.aided;
            a.step_in(&sample, &x.angle, x.table_rate_radps, self.ws)
                .map(|_| *a.nav().state())
        } else {
            match self.nav.as_mut() {
                Some(n) => n.step(&sample).copied(),
                None => return,
            }
        };
        match step {
            Ok(st) => {
                self.steps = self.steps.wrapping_add(1);
                if self.steps.is_multiple_of(self.cfg.telemetry_every.max(1)) {
                    // Aided: the filter's own solution, the one the host's
                    // `navigate --gnss` writes (core-nav's one function).
                    let (q, v, p) = if self.stage == Stage::Aided {
                        let s = self.aided.solution(&x.angle);
                        (s.q_b_n, s.v_n, s.p_n)
                    } else {
                        (q_b_n(&st.q_s_n, Axis::Z, x.angle.rad), st.v_n, st.p_n)
                    };
                    out(Outbound::Telemetry(Telemetry::Nav {
                        t_us: x.t_us,
                        q_b_n: [q.w, q.i, q.j, q.k],
                        v_n: [v.x, v.y, v.z],
                        p_n: [p.x, p.y, p.z],
                    }));
                }
            }
            Err(_) => self.fault(x.t_us, Fault::NavRefused, out),
        }
    }

    /// A command from the link; acknowledged here.
    #[inline(never)]
    pub fn command(
        &mut self,
        c: NavCmd,
        out: &mut impl FnMut(Outbound),
        ctl: &mut impl FnMut(ControlCmd),
    ) {
        let now = self.last.map_or(0, |x| x.t_us);
        let (seq, status) = match c {
            NavCmd::Fix {
                seq,
                t_valid_us,
                fix,
            } => (seq, self.fix(now, t_valid_us, fix, out)),
            NavCmd::Recalibrate { seq } if self.aided().is_some() => (seq, Status::Aided),
            NavCmd::Recalibrate { seq } => {
                self.restart(now, ctl);
                (seq, Status::Accepted)
            }
            NavCmd::Start { seq } => {
                if matches!(self.mode, Mode::Stopped(_)) {
                    if self.nav().is_some() {
                        self.mode = Mode::Navigating;
                        ctl(ControlCmd::StartScheme);
                    } else {
                        self.restart(now, ctl);
                    }
                } else if self.mode == Mode::Navigating {
                    ctl(ControlCmd::StartScheme);
                }
                (seq, Status::Accepted)
            }
            NavCmd::Config(cfg) => {
                let restart = cfg.aided.is_some() != self.cfg.aided.is_some();
                self.cfg = cfg;
                if restart {
                    self.restart(now, ctl);
                }
                return;
            }
        };
        out(Outbound::Telemetry(Telemetry::Ack { seq, status }));
    }

    fn fix(
        &mut self,
        now: u64,
        t_valid_us: u64,
        fix: GnssFix,
        out: &mut impl FnMut(Outbound),
    ) -> Status {
        if self.aided().is_none() {
            return Status::NotAided;
        }
        if t_valid_us > now.saturating_add(self.cfg.period_us) {
            self.fault(now, Fault::FixRefused, out);
            return Status::BadFix;
        }
        if t_valid_us.saturating_add(self.cfg.fix_horizon_us) < now {
            self.fixes_late = self.fixes_late.saturating_add(1);
            self.fault(now, Fault::FixLate, out);
        }
        if self.fixes.push_back((t_valid_us, fix)).is_err() {
            self.fault(now, Fault::FixRefused, out);
            return Status::BadFix;
        }
        Status::Accepted
    }

    /// The table angle last seen.
    pub fn angle(&self) -> TableAngle<f32> {
        self.last.map(|x| x.angle).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tuning::ICM42688_FILTER;

    /// A navigator whose large state is leaked (a static on the board).
    fn navigator(aided: bool) -> Navigator<'static> {
        let cfg = NavConfig {
            lat_deg: 45.0,
            aided: aided.then_some(BoardAided {
                origin: OriginE7 {
                    lat_e7: 450_000_000,
                    lon_e7: 0,
                    height_mm: 0,
                },
                cfg: ICM42688_FILTER,
            }),
            ..NavConfig::default()
        };
        let mem = NavMemory {
            ws: Box::leak(Box::new(Workspace::ZERO)),
            aided: Box::leak(Box::new(AidedNav::BLANK)),
            cal: Box::leak(Box::new(core::mem::MaybeUninit::uninit())),
        };
        Navigator::new(cfg, 0, None, mem)
    }

    /// A still, level sensor's mean sample at `t_us`.
    fn still(t_us: u64) -> NavInput {
        NavInput {
            t_us,
            mean: Sample {
                gyro_radps: [0.0; 3],
                accel_mps2: [0.0, 0.0, -9.806],
                temp_c: 25.0,
            },
            angle: TableAngle::default(),
            table_rate_radps: 0.0,
            encoder_seen: true,
            table_moved: false,
            rate_ok_since: None,
            stopped: None,
        }
    }

    fn fix() -> GnssFix {
        GnssFix {
            lat_e7: 450_000_000,
            lon_e7: 0,
            height_mm: 0,
            v_n_mmps: [0; 3],
            sigma_h_mm: 1_000,
            sigma_v_mm: 2_000,
            sigma_vel_mmps: 100,
        }
    }

    /// Sends a fix command; returns its Ack's status.
    fn send_fix(n: &mut Navigator<'_>, t_valid_us: u64) -> Status {
        let mut acks = vec![];
        let c = NavCmd::Fix {
            seq: 1,
            t_valid_us,
            fix: fix(),
        };
        n.command(
            c,
            &mut |o| {
                if let Outbound::Telemetry(Telemetry::Ack { status, .. }) = o {
                    acks.push(status);
                }
            },
            &mut |_| {},
        );
        acks[0]
    }

    fn run(n: &mut Navigator<'_>, from_us: u64, to_us: u64) {
        let mut t = from_us;
        while t <= to_us {
            n.input(&still(t), &mut |_| {}, &mut |_| {});
            t += 10_000;
        }
    }

    #[test]
    fn the_blank_static_restarted_in_place_navigates_as_a_new_navigator() {
        // The board's aided navigator is `AidedNav::BLANK` (zeros, in
        // .bss) restarted in place; the host's is `AidedNav::new`. Over
        // 5 s of a turning table with a fix every second, bit for bit.
        let origin = OriginE7 {
            lat_e7: -339_000_000,
            lon_e7: 1_512_000_000,
            height_mm: 40_000,
        };
        let q = Quaternion::new(1.0f32, 0.0, 0.0, 0.0);
        let sample = |k: u64| ImuSample {
            t_us: k * 10_000,
            w_is_s: Vector3::new(1e-4, -2e-4, 0.5f32),
            f_s: Vector3::new(0.01, -0.02, -9.79f32),
        };
        let angle = |k: u64| TableAngle::from_rad_f64(0.5 * k as f64 * 0.01);
        let cfg = StrapdownConfig::default();
        let mut a = AidedNav::BLANK;
        a.restart(cfg, origin, &q, &angle(0), &sample(0), ICM42688_FILTER)
            .unwrap();
        let mut b = AidedNav::new(cfg, origin, &q, &angle(0), &sample(0), ICM42688_FILTER).unwrap();
        let mut ws = Workspace::ZERO;
        for k in 1..=500u64 {
            if k % 100 == 0 {
                a.gnss_at(&fix_at(origin), k * 10_000 - 5_000).unwrap();
                b.gnss_at(&fix_at(origin), k * 10_000 - 5_000).unwrap();
            }
            let ra = a.step_in(&sample(k), &angle(k), 0.5, &mut ws).unwrap();
            let rb = b.step_in(&sample(k), &angle(k), 0.5, &mut ws).unwrap();
            assert_eq!(format!("{ra:?}"), format!("{rb:?}"));
        }
        let (sa, sb) = (a.nav().state(), b.nav().state());
        assert_eq!(format!("{sa:?}"), format!("{sb:?}"));
        assert_eq!(a.counts.fixes_used, 5);
        assert_eq!(a.kf.p, b.kf.p);
    }

    fn fix_at(o: OriginE7) -> GnssFix {
        GnssFix {
            lat_e7: o.lat_e7,
            lon_e7: o.lon_e7,
            height_mm: o.height_mm,
            ..fix()
        }
    }

    #[test]
    fn a_fix_before_aided_navigation_is_refused_with_the_reason() {
        let mut n = navigator(false);
        run(&mut n, 10_000, 100_000);
        assert_eq!(send_fix(&mut n, 90_000), Status::NotAided);
    }

    #[test]
    fn a_fix_waits_for_its_horizon_and_is_applied_at_its_epoch() {
        let mut n = navigator(true);
        run(&mut n, 10_000, 1_000_000);
        assert_eq!(n.mode(), Mode::Navigating);
        // Valid at 0.95 s, sent at 1.0 s: held until 0.95 + 0.4 s.
        assert_eq!(send_fix(&mut n, 950_000), Status::Accepted);
        run(&mut n, 1_010_000, 1_340_000);
        assert_eq!(n.aided().unwrap().counts.fixes_used, 0);
        run(&mut n, 1_350_000, 1_400_000);
        assert_eq!(n.aided().unwrap().counts.fixes_used, 1);
        assert_eq!(n.fixes_late, 0);
    }

    #[test]
    fn a_fix_from_the_future_is_refused_and_a_stale_one_counted_late() {
        let mut n = navigator(true);
        run(&mut n, 10_000, 1_000_000);
        // Valid beyond the next navigation period: a wrong clock.
        assert_eq!(send_fix(&mut n, 1_100_000), Status::BadFix);
        // Valid 0.5 s ago, past the 0.4 s horizon: applied, counted late.
        assert_eq!(send_fix(&mut n, 500_000), Status::Accepted);
        assert_eq!(n.fixes_late, 1);
        run(&mut n, 1_010_000, 1_020_000);
        assert_eq!(n.aided().unwrap().counts.fixes_used, 1);
    }
}

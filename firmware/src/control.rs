//! The control tick's logic (the highest-priority task, paced by the IMU's
//! data-ready): the sample monitor, the table's rate loop
//! (`core_nav::control`, the controller the simulator's console shares),
//! the encoder with its glitch and stall filters, and the navigation
//! period's mean sample handed to the navigation task.
//!
//! Nothing here takes long: a few thousand instructions a sample, so the
//! rate loop keeps its period whatever navigation does.

use crate::faults::{Fault, FaultCounts};
use crate::icm42688::{DataFault, DataMonitor, RawSample, Sample};
use core_nav::control::{MotorModel, RateController};
use core_nav::scheme::{Limits, Profile, Reference, Scheme};
use core_nav::table::{CounterUnwrapper, EncoderInterpolator, EncoderScale, TableAngle};
use protocol::Telemetry;

/// The tick's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlConfig {
    /// Encoder counts per revolution.
    pub counts_per_rev: u32,
    /// Table limits.
    pub limits: Limits,
    /// Motor model.
    pub motor: MotorModel<f32>,
    /// Rate-loop bandwidth, Hz.
    pub bandwidth_hz: f32,
    /// The IMU's sample period, µs (the rate loop's period).
    pub sample_period_us: u64,
    /// Samples per navigation period (their mean goes to navigation).
    pub nav_every: u32,
    /// Samples per encoder read.
    pub encoder_every: u32,
}

impl Default for ControlConfig {
    fn default() -> Self {
        Self {
            counts_per_rev: crate::rig::RIG.counts_per_rev,
            limits: Limits::default(),
            motor: crate::rig::motor(),
            // The rate loop runs at 1 kHz with 25 Hz bandwidth (a 100 Hz
            // loop left the motor's cogging ripple at 0.35-0.68 deg/s RMS).
            bandwidth_hz: 25.0,
            sample_period_us: 1_000,
            nav_every: 10,
            encoder_every: 20,
        }
    }
}

/// What the tick hands to navigation once per navigation period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavInput {
    /// The end of the period, µs (the sample clock).
    pub t_us: u64,
    /// The period's mean sample (sensor frame).
    pub mean: Sample,
    /// The table's angle at `t_us` (interpolated between encoder reads).
    pub angle: TableAngle<f32>,
    /// The table's rate over the last 0.5 s of encoder reads, rad/s.
    pub table_rate_radps: f32,
    /// Whether at least one encoder read has been taken.
    pub encoder_seen: bool,
    /// The table moved since the last input.
    pub table_moved: bool,
    /// Since when the table's rate has matched the command (2 %).
    pub rate_ok_since: Option<u64>,
    /// The table has been stopped by this fault (stall, stuck IMU, timeout).
    pub stopped: Option<Fault>,
}

/// What navigation or the link asks of the tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ControlCmd {
    /// Run the scheme from the table's present angle.
    StartScheme,
    /// Motor off, the scheme stopped.
    Stop,
    /// Motor off after a fault seen elsewhere (the IMU silent).
    Halt(Fault),
    /// A new scheme (already checked against the limits).
    Scheme(Scheme),
}

/// Encoder reads kept for the table rate (0.5 s at 50 Hz, plus one).
pub const ENC_HIST: usize = 26;

/// The tick's state.
pub struct Control {
    cfg: ControlConfig,
    ctrl: RateController<f32>,
    profile: Profile,
    scheme_t0: Option<(u64, f32)>,
    unwrap: CounterUnwrapper,
    last_hw: Option<(u64, u16)>,
    glitch_run: u8,
    enc: EncoderInterpolator<f32>,
    enc_hist: heapless::Deque<(u64, TableAngle<f32>), ENC_HIST>,
    rate_window: Option<(u64, i64)>,
    stall_since: Option<u64>,
    rate_ok_since: Option<u64>,
    moved: bool,
    stopped: Option<Fault>,
    rate_meas: f32,
    duty: f32,
    avg: [f32; 7],
    avg_n: u32,
    samples: u64,
    last_t: Option<u64>,
    monitor: DataMonitor,
    /// Fault counters (and their reporting).
    pub faults: FaultCounts,
}

impl Control {
    /// The tick at power-up with `scheme`.
    ///
    /// # Errors
    /// The scheme is out of the limits.
    pub fn new(cfg: ControlConfig, scheme: Scheme) -> Result<Self, core_nav::NavError> {
        Ok(Self {
            cfg,
            ctrl: RateController::new(cfg.motor, cfg.bandwidth_hz),
            profile: Profile::new(scheme, cfg.limits)?,
            scheme_t0: None,
            unwrap: CounterUnwrapper::new(),
            last_hw: None,
            glitch_run: 0,
            enc: EncoderInterpolator::new(40_000),
            enc_hist: heapless::Deque::new(),
            rate_window: None,
            stall_since: None,
            rate_ok_since: None,
            moved: false,
            stopped: None,
            rate_meas: 0.0,
            duty: 0.0,
            avg: [0.0; 7],
            avg_n: 0,
            samples: 0,
            last_t: None,
            monitor: DataMonitor::default(),
            faults: FaultCounts::default(),
        })
    }

    /// The settings.
    pub fn config(&self) -> &ControlConfig {
        &self.cfg
    }

    /// The motor duty in [-1, 1] (sign = direction) to apply now.
    pub fn duty(&self) -> f32 {
        self.duty
    }

    /// Whether the scheme is running.
    pub fn running(&self) -> bool {
        self.scheme_t0.is_some()
    }

    fn fault(&mut self, t_us: u64, f: Fault, out: &mut impl FnMut(Telemetry)) {
        if let Some(t) = self.faults.count(t_us, f) {
            out(t);
        }
    }

    fn stop(&mut self, t_us: u64, f: Option<Fault>, out: &mut impl FnMut(Telemetry)) {
        self.duty = 0.0;
        self.ctrl.reset();
        self.scheme_t0 = None;
        self.rate_ok_since = None;
        if let Some(f) = f {
            self.stopped = Some(f);
            self.fault(t_us, f, out);
        }
    }

    /// A command from navigation or the link.
    pub fn command(&mut self, t_us: u64, c: ControlCmd, out: &mut impl FnMut(Telemetry)) {
        match c {
            ControlCmd::StartScheme => {
                let a = self.table_angle(t_us).to_rad();
                self.scheme_t0 = Some((t_us, a));
                self.rate_ok_since = None;
                self.stall_since = None;
                self.stopped = None;
                self.ctrl.reset();
            }
            ControlCmd::Stop => self.stop(t_us, None, out),
            ControlCmd::Halt(f) => self.stop(t_us, Some(f), out),
            // The scheme in use, sent again (a host configuring a board
            // that has it stored): the motion goes on as it was.
            ControlCmd::Scheme(s) if s == self.profile.scheme() => {}
            ControlCmd::Scheme(s) => {
                if let Ok(p) = Profile::new(s, self.cfg.limits) {
                    self.profile = p;
                }
            }
        }
    }

    /// The table's angle at `t_us` (the last read if it cannot be
    /// interpolated).
    pub fn table_angle(&self, t_us: u64) -> TableAngle<f32> {
        self.enc
            .angle_at(t_us)
            .ok()
            .or_else(|| self.enc.latest().map(|(_, a)| a))
            .unwrap_or_default()
    }

    /// Whether this sample index is an encoder read.
    pub fn encoder_due(&self) -> bool {
        self.samples
            .is_multiple_of(u64::from(self.cfg.encoder_every.max(1)))
    }

    /// One IMU sample at `t_us` (the sample clock): `None` when the read
    /// failed. Runs the rate loop; at the end of each navigation period
    /// returns the period's input for navigation.
    pub fn sample(
        &mut self,
        t_us: u64,
        s: Option<(RawSample, Sample)>,
        out: &mut impl FnMut(Telemetry),
    ) -> Option<NavInput> {
        self.samples = self.samples.wrapping_add(1);
        let Some((raw, s)) = s else {
            self.fault(t_us, Fault::SpiError, out);
            return None;
        };
        match self.monitor.check(&raw) {
            Some(DataFault::Stuck) => {
                if self.stopped.is_none() {
                    self.stop(t_us, Some(Fault::ImuStuck), out);
                } else {
                    self.fault(t_us, Fault::ImuStuck, out);
                }
                return self.period_end(t_us, None);
            }
            Some(DataFault::Saturated) => {
                // No valid rate to close the loop on: the motor to a safe
                // (zero) duty for this sample; the loop resumes on the next.
                self.duty = 0.0;
                self.fault(t_us, Fault::ImuSaturated, out);
                return self.period_end(t_us, None);
            }
            None => {}
        }
        let dt = self
            .last_t
            .map_or(1e-3, |t| t_us.saturating_sub(t) as f32 * 1e-6);
        self.last_t = Some(t_us);
        self.rate_meas = s.gyro_radps[2];
        let temp = [s.temp_c];
        let chans = s
            .gyro_radps
            .iter()
            .chain(s.accel_mps2.iter())
            .chain(temp.iter());
        for (a, v) in self.avg.iter_mut().zip(chans) {
            *a += v;
        }
        self.avg_n += 1;
        let angle = self.table_angle(t_us);
        self.control(t_us, angle, dt);
        self.period_end(t_us, Some(angle))
    }

    /// At the end of a navigation period: the mean of its valid samples.
    fn period_end(&mut self, t_us: u64, angle: Option<TableAngle<f32>>) -> Option<NavInput> {
        if !self
            .samples
            .is_multiple_of(u64::from(self.cfg.nav_every.max(1)))
        {
            return None;
        }
        let n = self.avg_n;
        let m = self.avg.map(|a| a / n.max(1) as f32);
        self.avg = [0.0; 7];
        self.avg_n = 0;
        if n == 0 {
            return None;
        }
        let rate = match (self.enc_hist.front(), self.enc_hist.back()) {
            (Some((t0, a0)), Some((t1, a1))) if t1 > t0 => a1.minus(a0) / ((t1 - t0) as f32 * 1e-6),
            _ => 0.0,
        };
        let moved = core::mem::take(&mut self.moved);
        Some(NavInput {
            t_us,
            mean: Sample {
                gyro_radps: [m[0], m[1], m[2]],
                accel_mps2: [m[3], m[4], m[5]],
                temp_c: m[6],
            },
            angle: angle.unwrap_or_else(|| self.table_angle(t_us)),
            table_rate_radps: rate,
            encoder_seen: self.enc.latest().is_some(),
            table_moved: moved,
            rate_ok_since: self.rate_ok_since,
            stopped: self.stopped,
        })
    }

    fn control(&mut self, t_us: u64, angle: TableAngle<f32>, dt: f32) {
        let Some((t0, a0)) = self.scheme_t0 else {
            self.duty = 0.0;
            return;
        };
        let r: Reference = self.profile.at(t_us.saturating_sub(t0) as f64 * 1e-6);
        let err = r.angle as f32 - (angle.to_rad() - a0);
        self.duty = self.ctrl.update(&r, err, self.rate_meas, dt);
    }

    /// An encoder read at `t_us`: the 16-bit hardware counter. A read that
    /// implies a rate above twice the table's limit is a glitch: counted and
    /// dropped (the last accepted read stays the reference); after three in
    /// a row the new count is accepted (a lasting offset: resync).
    pub fn encoder(&mut self, t_us: u64, hw: u16, out: &mut impl FnMut(Telemetry)) {
        let scale = EncoderScale::new(self.cfg.counts_per_rev);
        if let Some((tl, hl)) = self.last_hw {
            let d = CounterUnwrapper::delta(hl, hw) as f64;
            let dt = (t_us.saturating_sub(tl)) as f64 * 1e-6;
            let rate = scale.rate(d, dt.max(1e-6));
            if libm::fabs(rate) > 2.0 * self.cfg.limits.max_rate && self.glitch_run < 3 {
                self.glitch_run += 1;
                return self.fault(t_us, Fault::EncoderGlitch, out);
            }
        }
        self.glitch_run = 0;
        self.moved |= self.last_hw.is_some_and(|(_, hl)| hl != hw);
        self.last_hw = Some((t_us, hw));
        let counts = self.unwrap.update(hw);
        let angle = TableAngle::from_counts(counts, self.cfg.counts_per_rev);
        if self.enc.push(t_us, angle).is_err() {
            self.fault(t_us, Fault::EncoderGlitch, out);
        } else {
            if self.enc_hist.is_full() {
                self.enc_hist.pop_front();
            }
            // Cannot fail: a slot was just made.
            let _ = self.enc_hist.push_back((t_us, angle));
        }
        out(Telemetry::Encoder {
            t_us,
            counts,
            counts_per_rev: self.cfg.counts_per_rev,
        });
        self.check_rate(t_us, counts, out);
    }

    /// Encoder rate over 0.5 s against the command: the rate reached, or a
    /// stall (under 20 % of the command for 1 s: motor off).
    fn check_rate(&mut self, t_us: u64, counts: i64, out: &mut impl FnMut(Telemetry)) {
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
                self.stop(t_us, Some(Fault::MotorStall), out);
            }
        } else {
            self.stall_since = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CPR: u32 = 16_384;

    fn control() -> Control {
        let scheme = Scheme::Continuous {
            rate: 30f64.to_radians(),
        };
        Control::new(ControlConfig::default(), scheme).unwrap()
    }

    /// A sample whose raw words change every call (never "stuck").
    fn sample(k: u32, gyro_z: f32) -> Option<(RawSample, Sample)> {
        let w = (k % 1000) as i16;
        let raw = RawSample {
            temp_lsb: w,
            accel_lsb: [w, 1, 2],
            gyro_lsb: [3, w, 4],
        };
        let s = Sample {
            gyro_radps: [0.0, 0.0, gyro_z],
            accel_mps2: [0.0, 0.0, -9.8],
            temp_c: 25.0,
        };
        Some((raw, s))
    }

    fn faults(out: &[Telemetry], which: Fault) -> usize {
        out.iter()
            .filter(|t| matches!(t, Telemetry::Fault { fault, .. } if *fault == which))
            .count()
    }

    #[test]
    fn the_navigation_input_is_the_mean_of_its_period() {
        let mut c = control();
        let mut out = vec![];
        let mut inputs = vec![];
        for k in 1..=20u32 {
            let t = u64::from(k) * 1_000;
            if let Some(x) = c.sample(t, sample(k, k as f32 * 0.01), &mut |m| out.push(m)) {
                inputs.push(x);
            }
        }
        // Every tenth sample: the mean of gyro z over samples 1..10 and
        // 11..20 (0.055 and 0.155 rad/s).
        assert_eq!(inputs.len(), 2);
        assert!((inputs[0].mean.gyro_radps[2] - 0.055).abs() < 1e-6);
        assert!((inputs[1].mean.gyro_radps[2] - 0.155).abs() < 1e-6);
        assert_eq!(inputs[1].t_us, 20_000);
    }

    #[test]
    fn an_encoder_glitch_is_dropped_and_a_lasting_offset_resynced() {
        let mut c = control();
        let mut out = vec![];
        c.encoder(0, 0, &mut |m| out.push(m));
        c.encoder(20_000, 10, &mut |m| out.push(m));
        // 8,000 counts in 20 ms is 8,800 deg/s: beyond twice the 200 deg/s
        // limit. Dropped three times, then accepted as an offset.
        for k in 2..=5u64 {
            c.encoder(k * 20_000, 8_000, &mut |m| out.push(m));
        }
        assert_eq!(faults(&out, Fault::EncoderGlitch), 1, "reported once");
        let encoder_frames = out
            .iter()
            .filter(|t| matches!(t, Telemetry::Encoder { .. }))
            .count();
        assert_eq!(encoder_frames, 3, "two reads, then the resync");
        let angle = c.table_angle(100_000).to_rad();
        assert!((angle - 8_000.0 / CPR as f32 * core::f32::consts::TAU).abs() < 1e-3);
    }

    #[test]
    fn a_table_that_does_not_turn_is_a_stall_and_the_motor_stops() {
        let mut c = control();
        let mut out = vec![];
        c.encoder(0, 0, &mut |m| out.push(m));
        c.command(0, ControlCmd::StartScheme, &mut |m| out.push(m));
        assert!(c.running());
        // The encoder never moves while 30 deg/s is commanded: after 1 s
        // of under 20 % of the command (checked every 0.5 s), a stall.
        for k in 1..=110u64 {
            c.encoder(k * 20_000, 0, &mut |m| out.push(m));
        }
        assert_eq!(faults(&out, Fault::MotorStall), 1);
        assert!(!c.running());
        assert_eq!(c.duty(), 0.0);
    }

    #[test]
    fn a_saturated_sample_sets_a_safe_duty_and_the_loop_resumes() {
        let mut c = control();
        let mut out = vec![];
        c.encoder(0, 0, &mut |m| out.push(m));
        c.command(0, ControlCmd::StartScheme, &mut |m| out.push(m));
        for k in 1..=50u32 {
            c.sample(u64::from(k) * 1_000, sample(k, 0.0), &mut |m| out.push(m));
        }
        assert!(c.duty() > 0.0, "the loop drives the table up to its rate");
        let mut sat = sample(51, 0.0);
        if let Some((raw, _)) = sat.as_mut() {
            raw.gyro_lsb[2] = i16::MAX;
        }
        c.sample(51_000, sat, &mut |m| out.push(m));
        assert_eq!(c.duty(), 0.0);
        assert_eq!(faults(&out, Fault::ImuSaturated), 1);
        c.sample(52_000, sample(52, 0.0), &mut |m| out.push(m));
        assert!(c.duty() > 0.0);
    }

    #[test]
    fn a_failed_read_is_counted_and_skipped() {
        let mut c = control();
        let mut out = vec![];
        assert!(c.sample(1_000, None, &mut |m| out.push(m)).is_none());
        assert_eq!(faults(&out, Fault::SpiError), 1);
    }
}

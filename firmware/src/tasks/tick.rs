//! The control tick (priority 3): the IMU read behind each data-ready
//! edge, the rate loop, the encoder, the motor.

use super::*;

/// The control tick (priority 3).
pub struct TickTask<'a> {
    /// Its logic.
    pub control: Control,
    /// The sensor's sample clock.
    pub clock: SampleClock,
    pub(super) nav_in: Producer<'a, NavInput, NAV_Q>,
    pub(super) from_nav: Consumer<'a, ControlCmd, CMD_Q>,
    pub(super) from_link: Consumer<'a, ControlCmd, CMD_Q>,
    pub(super) out: Producer<'a, Telemetry, OUT_Q>,
}

impl TickTask<'_> {
    /// One data-ready edge at MCU time `mcu_us`; returns whether
    /// navigation has an input to take (pend it).
    pub fn run(
        &mut self,
        mcu_us: u64,
        imu: &mut impl Imu,
        enc: &mut impl Encoder,
        motor: &mut impl Motor,
        stats: &Stats,
    ) -> bool {
        stats.progress.tick.fetch_add(1, Ordering::Relaxed);
        let out = &mut self.out;
        let mut emit = |t: Telemetry| {
            if out.enqueue(t).is_err() {
                stats.out_lost.fetch_add(1, Ordering::Relaxed);
            }
        };
        let read = imu.read();
        let t_us = match self.clock.edge(mcu_us, !matches!(read, Ok(None))) {
            Edge::Duplicate => {
                stats.duplicated.fetch_add(1, Ordering::Relaxed);
                if let Some(t) = self.control.faults.count(mcu_us, Fault::SampleDuplicated) {
                    emit(t);
                }
                return false;
            }
            Edge::Sample { t_us, dropped } => {
                if dropped > 0 {
                    stats.dropped.fetch_add(dropped, Ordering::Relaxed);
                    if let Some(t) = self.control.faults.count(t_us, Fault::SampleDropped) {
                        emit(t);
                    }
                }
                t_us
            }
        };
        stats.last_sample_us.store(mcu_us as u32, Ordering::Relaxed);
        stats.samples.fetch_add(1, Ordering::Relaxed);
        while let Some(c) = self.from_link.dequeue().or_else(|| self.from_nav.dequeue()) {
            self.control.command(t_us, c, &mut emit);
        }
        if self.control.encoder_due() {
            let hw = enc.count();
            self.control.encoder(t_us, hw, &mut emit);
        }
        let input = self.control.sample(t_us, read.ok().flatten(), &mut emit);
        motor.set(self.control.duty());
        let Some(x) = input else { return false };
        if self.nav_in.enqueue(x).is_err() {
            stats.nav_overruns.fetch_add(1, Ordering::Relaxed);
            if let Some(t) = self.control.faults.count(t_us, Fault::NavOverrun) {
                emit(t);
            }
        }
        true
    }
}

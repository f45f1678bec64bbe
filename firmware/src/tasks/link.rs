//! The link task (priority 1): commands in, telemetry out, the flash
//! journal, supervision of the IMU, and the watchdog.

use super::*;

/// What the link task asks of its interrupt-level wiring.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkOut {
    /// Bytes are queued: enable the UART's transmit interrupt.
    pub tx_pending: bool,
    /// The IMU is silent: the motor off now.
    pub motor_off: bool,
    /// The board has run healthily for [`HEALTHY_AFTER_US`] (once): the
    /// reset log's row of resets is over (`crate::resets`).
    pub healthy: bool,
}

/// The link, the flash journal, supervision and the watchdog (priority 1).
pub struct LinkTask<'a> {
    /// Its logic.
    pub link: Link,
    /// The flash record.
    pub journal: Journal,
    /// What is to be stored, and the commands waiting on it.
    pub(super) store: Store,
    pub(super) rx: RxRing,
    pub(super) tx: Producer<'a, u8, TX_Q>,
    pub(super) from_tick: Consumer<'a, Telemetry, OUT_Q>,
    pub(super) from_nav: Consumer<'a, Outbound, OUT_Q>,
    pub(super) to_tick: Producer<'a, ControlCmd, CMD_Q>,
    pub(super) to_nav: Producer<'a, NavCmd, CMD_Q>,
    pub(super) feeder: Feeder,
    pub(super) sensors: bool,
    /// Since when the IMU's data-ready edges are expected.
    pub(super) window: Window,
    pub(super) last_run_us: u64,
    pub(super) healthy_told: bool,
    pub(super) clock_start: u64,
    pub(super) last_health: Option<u64>,
    pub(super) timed_out: bool,
    pub(super) reset: ResetCause,
    pub(super) tuning: Tuning,
    pub(super) boot_reports: [Option<Telemetry>; 6],
    /// Commands refused as malformed or out of bounds.
    pub(super) refused: u32,
    /// What the counters below were when each was last reported.
    pub(super) counted: [(u32, Option<u64>); COUNTED.len()],
}

impl LinkTask<'_> {
    /// Commands received so far (the QEMU harness waits for the host's
    /// configuration before it powers the sensors).
    pub fn commands(&self) -> u32 {
        self.link.commands
    }

    /// Whether the board runs its sensors (an IMU that answered, not safe
    /// mode): only then is the data-ready interrupt unmasked.
    pub fn sensors(&self) -> bool {
        self.sensors
    }

    /// The IMU's edges are not expected (a host test's board that idles
    /// with no sensors, to count what else it reports).
    pub fn sensors_later(&mut self) {
        self.window = Window::Later;
    }

    /// One run (every 10 ms).
    pub fn run(
        &mut self,
        mcu_us: u64,
        rx: &impl RxDma,
        flash: &mut impl Flash,
        wdg: &mut impl Watchdog,
        stats: &Stats,
    ) -> LinkOut {
        stats.progress.link.fetch_add(1, Ordering::Relaxed);
        self.last_run_us = mcu_us;
        if self.window == Window::FirstRun {
            self.window = Window::From(mcu_us);
        }
        let mut o = LinkOut::default();
        for t in self.boot_reports.iter_mut().filter_map(Option::take) {
            send(&mut self.link, &mut self.tx, &t);
        }
        self.receive(rx, stats);
        while let Some(t) = self.from_tick.dequeue() {
            send(&mut self.link, &mut self.tx, &t);
        }
        while let Some(x) = self.from_nav.dequeue() {
            match x {
                Outbound::Telemetry(t) => send(&mut self.link, &mut self.tx, &t),
                Outbound::Store(c) => self.store.calibration(c),
            }
        }
        let (link, tx) = (&mut self.link, &mut self.tx);
        let stored = self
            .store
            .run(&mut self.journal, flash, link.config, &mut |seq, status| {
                send(link, tx, &Telemetry::Ack { seq, status })
            });
        if stored.is_err() {
            self.fault(mcu_us, Fault::FlashError);
        }
        o.motor_off = self.supervise(mcu_us, stats);
        self.report_counted(mcu_us, stats);
        if self
            .last_health
            .is_none_or(|t| mcu_us.saturating_sub(t) >= HEALTH_EVERY_US)
        {
            self.last_health = Some(mcu_us);
            let h = self.health(mcu_us, stats);
            send(&mut self.link, &mut self.tx, &h);
        }
        if self.feeder.check(&stats.progress, self.sensors) {
            wdg.feed();
            let up = mcu_us.saturating_sub(self.clock_start) >= HEALTHY_AFTER_US;
            if up && self.sensors && !self.timed_out && !self.healthy_told {
                self.healthy_told = true;
                o.healthy = true;
            }
        }
        o.tx_pending = !self.tx.is_empty();
        o
    }

    /// The bytes received since the last run: the ring's overwritten
    /// ones counted lost, the rest decoded in order.
    fn receive(&mut self, dma: &impl RxDma, stats: &Stats) {
        let lost = self.rx.sync(dma);
        if lost > 0 {
            stats.rx_lost.fetch_add(lost, Ordering::Relaxed);
        }
        let mut routes: heapless::Vec<Route, 4> = heapless::Vec::new();
        let mut overtaken = 0;
        while let Some(b) = self.rx.next(dma, &mut overtaken) {
            stats.rx_bytes.fetch_add(1, Ordering::Relaxed);
            let (link, tx) = (&mut self.link, &mut self.tx);
            let mut acks: heapless::Vec<Telemetry, 1> = heapless::Vec::new();
            link.rx(
                b,
                &mut |r| {
                    let _ = routes.push(r);
                },
                &mut |t| {
                    let _ = acks.push(t);
                },
            );
            for a in &acks {
                if matches!(a, Telemetry::Ack { status, .. } if is_bad(*status)) {
                    self.refused = self.refused.saturating_add(1);
                }
                send(link, tx, a);
            }
            for r in routes.iter().copied() {
                self.route(r, stats);
            }
            routes.clear();
        }
        if overtaken > 0 {
            stats.rx_lost.fetch_add(overtaken, Ordering::Relaxed);
        }
    }

    fn route(&mut self, r: Route, stats: &Stats) {
        match r {
            Route::Control(c) => {
                if self.to_tick.enqueue(c).is_err() {
                    stats.out_lost.fetch_add(1, Ordering::Relaxed);
                }
            }
            Route::Nav(c) => {
                if self.to_nav.enqueue(c).is_err() {
                    stats.out_lost.fetch_add(1, Ordering::Relaxed);
                }
            }
            Route::Config { cfg, seq } => {
                // Acknowledged when stored (`crate::store`); an ack that
                // cannot wait is lost telemetry, counted.
                let lost = u32::from(self.store.config(seq).is_err())
                    + u32::from(
                        self.to_tick
                            .enqueue(ControlCmd::Scheme(scheme(&cfg)))
                            .is_err(),
                    )
                    + u32::from(
                        self.to_nav
                            .enqueue(NavCmd::Config(nav_config(&cfg, &self.tuning)))
                            .is_err(),
                    );
                stats.out_lost.fetch_add(lost, Ordering::Relaxed);
                let t = self.link.config_report();
                send(&mut self.link, &mut self.tx, &t);
            }
        }
    }

    pub(super) fn fault(&mut self, t_us: u64, f: Fault) {
        let t = Telemetry::Fault {
            t_us,
            fault: f,
            count: 1,
        };
        send(&mut self.link, &mut self.tx, &t);
    }

    /// The IMU silent for [`IMU_TIMEOUT_US`] while the board runs, or
    /// since its edges were expected when none has come (a data-ready
    /// line dead from power-up): the motor off (the caller), the tick told
    /// (it stops the scheme when samples come back) and the fault
    /// reported, once.
    fn supervise(&mut self, mcu_us: u64, stats: &Stats) -> bool {
        let Window::From(from) = self.window else {
            return false;
        };
        if !self.sensors {
            return false;
        }
        let last = if stats.samples.load(Ordering::Relaxed) == 0 {
            from as u32
        } else {
            stats.last_sample_us.load(Ordering::Relaxed)
        };
        // Signed: a tick that preempted this task since it read the clock
        // stored a later time than `mcu_us`.
        let silent = (mcu_us as u32).wrapping_sub(last) as i32 > IMU_TIMEOUT_US as i32;
        if silent && !self.timed_out {
            self.timed_out = true;
            let _ = self.to_tick.enqueue(ControlCmd::Halt(Fault::ImuTimeout));
            self.fault(mcu_us, Fault::ImuTimeout);
        }
        if !silent {
            self.timed_out = false;
        }
        silent
    }

    /// When the board started, µs.
    pub fn started_us(&self) -> u64 {
        self.clock_start
    }
}

/// Since when the IMU's silence is a fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Window {
    /// From the link task's first run: the end of `init`, whatever it
    /// took (a boot that erases the journal takes up to 4 s, the
    /// datasheet's worst for two 128 KiB sectors,
    /// [`crate::record::ERASE_WORST_US`]); the data-ready interrupt is
    /// unmasked only then, so no edge can come before.
    FirstRun,
    /// Not expected (a host test's board with no sensors).
    Later,
    /// From this MCU time, µs.
    From(u64),
}

/// A refusal of the command itself (malformed, out of bounds), not of
/// what the board could do with a good one (not aided, not stored).
pub(super) fn is_bad(s: protocol::Status) -> bool {
    use protocol::Status as S;
    !matches!(s, S::Accepted | S::NotAided | S::Aided | S::NotStored)
}

pub(super) fn send(link: &mut Link, tx: &mut Producer<'_, u8, TX_Q>, t: &Telemetry) {
    link.send(t, &mut |bytes| {
        if tx.capacity() - tx.len() < bytes.len() {
            return false;
        }
        for b in bytes {
            let _ = tx.enqueue(*b);
        }
        true
    });
}

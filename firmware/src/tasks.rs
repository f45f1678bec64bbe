//! The board's program: what runs at which priority, in which order, and
//! what passes between the tasks. Written once, generic over the
//! peripherals; the board's RTIC app (`main.rs`), its QEMU build (the same
//! app with the sensors replayed) and the host tests all run it.
//!
//! | task | priority | paced by | does |
//! | --- | --- | --- | --- |
//! | UART | 4 (top) | TXE (RXNE: QEMU) | the next byte out (in: the receive ring) |
//! | receive DMA | 4 | half a ring | counts the ring's halves ([`crate::uart_rx`]) |
//! | [`TickTask`] | 3 | the IMU's data-ready (1 kHz) | IMU read, rate loop, encoder at 50 Hz, motor |
//! | [`NavTask`] | 2 | pended by the tick every 10th sample | calibration, strapdown, aided filter |
//! | [`LinkTask`] | 1 | a 100 Hz timer | commands, telemetry, the flash journal, supervision, the watchdog |
//!
//! The tick is driven by the IMU's data-ready interrupt, so the sensor's
//! oscillator is the time base (as flight controllers do): the rate loop
//! runs once per sample, never on a sample twice or between samples, and
//! [`crate::clock::SampleClock`] counts samples dropped or duplicated.
//! Received bytes need no task: the DMA writes them into a ring the link
//! task reads ([`crate::uart_rx`]), so they survive the CPU's stalls on
//! flash (a word programmed stalls every fetch). The UART's interrupt is
//! above the tick all the same: the QEMU build (no DMA model) receives a
//! byte every 11 µs at 921,600 baud through it, and the tick may take
//! 200 µs.
//!
//! Between tasks only lock-free single-producer single-consumer queues
//! ([`crate::queue`]) and atomic counters: no task ever waits for a lower
//! one, and a full queue is a counted fault, never a wait.

use crate::clock::{Edge, SampleClock};
use crate::control::{Control, ControlCmd, ControlConfig, NavInput};
use crate::faults::Fault;
use crate::link::{scheme, Link, Route};
use crate::navigation::{BoardAided, NavCmd, NavConfig, NavMemory, Navigator, Outbound};
pub use crate::ports::{BusError, Encoder, Imu, Motor, Reading, Watchdog};
use crate::ports::{Flash, RxDma, Sample};
use crate::queue::{Consumer, Producer, Queue};
use crate::record::Journal;
use crate::resets::{BootVerdict, HEALTHY_AFTER_US};
use crate::store::Store;
use crate::uart_rx::RxRing;
use crate::watchdog::{Feeder, Progress};
use core::sync::atomic::{AtomicU32, Ordering};
use core_nav::aided::{AidedConfig, OriginE7};
use protocol::record::BoardConfig;
use protocol::{ResetCause, SchemeKind, Telemetry};

/// Navigation inputs queued (80 ms of them).
pub const NAV_Q: usize = 8;
/// Commands queued for a task.
pub const CMD_Q: usize = 8;
/// Telemetry queued by a task for the link.
pub const OUT_Q: usize = 32;
/// Bytes queued to transmit.
pub const TX_Q: usize = 2048;
/// No IMU sample for this long stops the motor and reports
/// [`Fault::ImuTimeout`], µs: well inside the watchdog's shortest period
/// (the IWDG's 100 ms at the LSI's typical 32 kHz is 68 ms at its 47 kHz
/// worst, RM0090 and the STM32F405 datasheet), so the fault is told and
/// the motor off before the watchdog resets a board whose tick stopped;
/// the link task sees it within one of its 10 ms periods.
pub const IMU_TIMEOUT_US: u32 = 20_000;
/// Health telemetry every this long, µs.
pub const HEALTH_EVERY_US: u64 = 1_000_000;

/// Counters every task writes and the link reports.
#[derive(Debug, Default)]
pub struct Stats {
    /// The tasks' progress (the watchdog's rule).
    pub progress: Progress,
    /// The tick's worst case, cycles (instructions under QEMU).
    pub tick_worst: AtomicU32,
    /// Ticks still running when the next data-ready came.
    pub tick_overruns: AtomicU32,
    /// Navigation's worst case, cycles.
    pub nav_worst: AtomicU32,
    /// Navigation inputs dropped (its queue full).
    pub nav_overruns: AtomicU32,
    /// The link task's worst case, cycles.
    pub link_worst: AtomicU32,
    /// The UART interrupt's worst case, cycles (what it holds the tasks
    /// off; what holds it off is in the book's Firmware chapter, the link's margin).
    pub uart_worst: AtomicU32,
    /// Samples dropped (data-ready late).
    pub dropped: AtomicU32,
    /// Data-ready edges without new data.
    pub duplicated: AtomicU32,
    /// Bytes received by the UART.
    pub rx_bytes: AtomicU32,
    /// Bytes lost on receive (overrun flag, queue full).
    pub rx_lost: AtomicU32,
    /// Telemetry lost in the tasks' queues.
    pub out_lost: AtomicU32,
    /// The MCU clock's low 32 bits at the last IMU sample, µs.
    pub last_sample_us: AtomicU32,
    /// Samples taken.
    pub samples: AtomicU32,
    /// The stack's peak during `init`, bytes (0: not measured).
    pub init_stack_bytes: AtomicU32,
    /// The tasks' stack peak at its last scan, bytes (0: not yet).
    pub stack_bytes: AtomicU32,
}

impl Stats {
    /// Keeps the worst of `cycles` in `slot`.
    pub fn worst(slot: &AtomicU32, cycles: u32) {
        slot.fetch_max(cycles, Ordering::Relaxed);
    }
}

/// Everything compiled in: the chip's and the table's tuning, not the
/// site's (that is [`BoardConfig`], set by commands and stored).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tuning {
    /// The tick's settings.
    pub control: ControlConfig,
    /// Navigation's settings apart from the configuration's.
    pub nav: NavConfig,
    /// The aided filter's noise model for this IMU.
    pub filter: AidedConfig,
}

/// The configuration a blank board starts with: the equator at sea level,
/// a level base heading north, 30 deg/s continuous, not aided. A user sets
/// their own with `rins command` (it is stored).
pub const FACTORY: BoardConfig = BoardConfig {
    lat_e7: 0,
    height_mm: 0,
    base_deg: [0.0; 3],
    scheme: SchemeKind::Continuous,
    rate_dps: 30.0,
    count: 0,
    aided: false,
    lon_e7: 0,
};

/// Navigation's settings for a configuration.
pub fn nav_config(c: &BoardConfig, t: &Tuning) -> NavConfig {
    let lat = f64::from(c.lat_e7) * 1e-7;
    let h = f64::from(c.height_mm) * 1e-3;
    let rate = match scheme(c) {
        core_nav::scheme::Scheme::Still => 0.0,
        core_nav::scheme::Scheme::Continuous { rate }
        | core_nav::scheme::Scheme::Reciprocating { rate, .. }
        | core_nav::scheme::Scheme::Indexed { rate, .. } => rate,
    };
    NavConfig {
        lat_deg: lat,
        height_m: h,
        base_deg: c.base_deg.map(f64::from),
        scheme_rate_radps: rate,
        aided: c.aided.then_some(BoardAided {
            origin: OriginE7 {
                lat_e7: c.lat_e7,
                lon_e7: c.lon_e7,
                height_mm: c.height_mm,
            },
            cfg: t.filter,
        }),
        ..t.nav
    }
}

/// The program's static memory: the queues between the tasks, the
/// filter's workspace, the aided navigator and the calibration's sums
/// (a static on the board, never on a stack).
pub struct Queues {
    ws: core_nav::eskf::Workspace<f32>,
    aided: core_nav::aided::AidedNav<f32>,
    cal: core::mem::MaybeUninit<crate::calibration::PowerUp>,
    nav_in: Queue<NavInput, NAV_Q>,
    nav_ctl: Queue<ControlCmd, CMD_Q>,
    link_ctl: Queue<ControlCmd, CMD_Q>,
    nav_cmd: Queue<NavCmd, CMD_Q>,
    tick_out: Queue<Telemetry, OUT_Q>,
    nav_out: Queue<Outbound, OUT_Q>,
    tx: Queue<u8, TX_Q>,
}

impl Default for Queues {
    fn default() -> Self {
        Self::new()
    }
}

impl Queues {
    /// Empty queues.
    pub const fn new() -> Self {
        Self {
            ws: core_nav::eskf::Workspace::ZERO,
            aided: core_nav::aided::AidedNav::BLANK,
            cal: core::mem::MaybeUninit::uninit(),
            nav_in: Queue::new(),
            nav_ctl: Queue::new(),
            link_ctl: Queue::new(),
            nav_cmd: Queue::new(),
            tick_out: Queue::new(),
            nav_out: Queue::new(),
            tx: Queue::new(),
        }
    }
}

/// The UART interrupt's end of the transmit queue (received bytes go
/// into the receive ring, [`crate::uart_rx`], which the link task reads).
pub struct UartEnds<'a> {
    /// Bytes to send out.
    pub tx: Consumer<'a, u8, TX_Q>,
}

impl UartEnds<'_> {
    /// The next byte to send, if any.
    pub fn next_tx(&mut self) -> Option<u8> {
        self.tx.dequeue()
    }
}

/// The board as it boots: the tasks and the UART's queue ends.
pub struct Program<'a> {
    /// The control tick.
    pub tick: TickTask<'a>,
    /// Navigation.
    pub nav: NavTask<'a>,
    /// The link.
    pub link: LinkTask<'a>,
    /// The UART interrupt's ends.
    pub uart: UartEnds<'a>,
}

/// What the boot knows.
#[derive(Clone, Copy, Debug)]
pub struct Boot {
    /// The MCU clock now, µs.
    pub now_us: u64,
    /// Why the board reset.
    pub reset: ResetCause,
    /// The IMU answered at init (`Err(fault)`: it did not: a stopped
    /// board that reports, with no tick).
    pub imu: Result<(), Fault>,
    /// The compiled-in tuning.
    pub tuning: Tuning,
    /// How the clock tree started (`crate::clocks`): `Err` why the board
    /// runs at 16 MHz from HSI (a stopped board that reports).
    pub clock: Result<(), Fault>,
    /// The reset log's word on this boot (`crate::resets`): resets in a
    /// row, a HardFault's registers, safe mode.
    pub resets: BootVerdict,
}

impl<'a> Program<'a> {
    /// The program over `queues`, with the journal opened at boot.
    ///
    /// # Errors
    /// The tuning's scheme or the stored one is out of the table's limits
    /// (the factory configuration is then used; if that fails too, a build
    /// error the host tests catch).
    ///
    /// Built straight into `slot` (a static on the board): the program is
    /// 21 KiB, and a value of it built on `init`'s stack and then moved
    /// took 72 KiB of stack at boot.
    pub fn new(
        slot: &'a mut core::mem::MaybeUninit<Self>,
        queues: &'a mut Queues,
        journal: Journal,
        boot: Boot,
    ) -> Result<&'a mut Self, core_nav::NavError> {
        let stored = journal.current;
        let mut config = stored.map_or(FACTORY, |r| r.config);
        let t = boot.tuning;
        let control = match Control::new(t.control, scheme(&config)) {
            Ok(c) => c,
            Err(_) => {
                config = FACTORY;
                Control::new(t.control, scheme(&config))?
            }
        };
        let (nav_in_p, nav_in_c) = queues.nav_in.split();
        let (nav_ctl_p, nav_ctl_c) = queues.nav_ctl.split();
        let (link_ctl_p, link_ctl_c) = queues.link_ctl.split();
        let (nav_cmd_p, nav_cmd_c) = queues.nav_cmd.split();
        let (tick_out_p, tick_out_c) = queues.tick_out.split();
        let (nav_out_p, nav_out_c) = queues.nav_out.split();
        // Safe mode: a board that reset itself too often in a row boots
        // as one whose IMU did not answer: stopped, no tick, the link up.
        // A clock tree left at 16 MHz: navigation does not fit, so the
        // same stopped board.
        let imu = if boot.resets.safe_mode {
            Err(Fault::ResetLoop)
        } else {
            boot.clock.and(boot.imu)
        };
        let mem = NavMemory {
            ws: &mut queues.ws,
            aided: &mut queues.aided,
            cal: &mut queues.cal,
        };
        let (tx_p, tx_c) = queues.tx.split();
        let mut navigator = Navigator::new(
            nav_config(&config, &t),
            boot.now_us,
            stored.and_then(|r| r.calibration),
            mem,
        );
        let mut link = LinkTask {
            link: Link::new(config, t.control.limits),
            store: Store::new(stored.and_then(|r| r.calibration)),
            journal,
            rx: RxRing::default(),
            tx: tx_p,
            from_tick: tick_out_c,
            from_nav: nav_out_c,
            to_tick: link_ctl_p,
            to_nav: nav_cmd_p,
            feeder: Feeder::default(),
            sensors: imu.is_ok(),
            sensors_from: imu.is_ok().then_some(boot.now_us),
            last_run_us: boot.now_us,
            healthy_told: false,
            clock_start: boot.now_us,
            last_health: None,
            timed_out: false,
            reset: boot.reset,
            tuning: t,
            boot_reports: [None; 6],
            counted: [(0, None); COUNTED.len()],
            refused: 0,
        };
        let r = boot.resets;
        link.boot_reports = [
            Some(Telemetry::Boot {
                reset: boot.reset,
                resets_in_row: r.in_row,
                resets_total: r.total,
                safe_mode: u8::from(r.safe_mode),
                fault_regs: r.fault.unwrap_or_default().words(),
            }),
            Some(link.link.config_report()),
            navigator.stored_report(),
            None,
            r.fault.map(|_| Telemetry::Fault {
                t_us: boot.now_us,
                fault: Fault::HardFault,
                count: 1,
            }),
            // (A clock that failed is told below, as the stopped board's,
            // unless safe mode's reset loop is.)
            boot.clock
                .err()
                .filter(|f| imu != Err(*f))
                .map(|fault| Telemetry::Fault {
                    t_us: boot.now_us,
                    fault,
                    count: 1,
                }),
        ];
        if let Err(f) = imu {
            // No IMU: the board stays stopped, reports, and runs no tick.
            let mut sink = |_o: Outbound| {};
            navigator.input(
                &NavInput {
                    t_us: boot.now_us,
                    mean: Sample::default(),
                    angle: Default::default(),
                    table_rate_radps: 0.0,
                    encoder_seen: false,
                    table_moved: false,
                    rate_ok_since: None,
                    stopped: Some(f),
                },
                &mut sink,
                &mut |_c| {},
            );
            if let Some(slot) = link.boot_reports.get_mut(3) {
                *slot = Some(Telemetry::Fault {
                    t_us: boot.now_us,
                    fault: f,
                    count: if f == Fault::ResetLoop { r.in_row } else { 1 },
                });
            }
        }
        Ok(slot.write(Self {
            tick: TickTask {
                control,
                clock: SampleClock::new(t.control.sample_period_us),
                nav_in: nav_in_p,
                from_nav: nav_ctl_c,
                from_link: link_ctl_c,
                out: tick_out_p,
            },
            nav: NavTask {
                nav: navigator,
                input: nav_in_c,
                cmds: nav_cmd_c,
                ctl: nav_ctl_p,
                out: nav_out_p,
            },
            link,
            uart: UartEnds { tx: tx_c },
        }))
    }
}

/// The control tick (priority 3).
pub struct TickTask<'a> {
    /// Its logic.
    pub control: Control,
    /// The sensor's sample clock.
    pub clock: SampleClock,
    nav_in: Producer<'a, NavInput, NAV_Q>,
    from_nav: Consumer<'a, ControlCmd, CMD_Q>,
    from_link: Consumer<'a, ControlCmd, CMD_Q>,
    out: Producer<'a, Telemetry, OUT_Q>,
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

/// Navigation (priority 2).
pub struct NavTask<'a> {
    /// Its logic.
    pub nav: Navigator<'a>,
    input: Consumer<'a, NavInput, NAV_Q>,
    cmds: Consumer<'a, NavCmd, CMD_Q>,
    ctl: Producer<'a, ControlCmd, CMD_Q>,
    out: Producer<'a, Outbound, OUT_Q>,
}

impl NavTask<'_> {
    /// Takes the commands and the inputs queued.
    pub fn run(&mut self, stats: &Stats) {
        stats.progress.nav.fetch_add(1, Ordering::Relaxed);
        let (out, ctl) = (&mut self.out, &mut self.ctl);
        let mut emit = |o: Outbound| {
            if out.enqueue(o).is_err() {
                stats.out_lost.fetch_add(1, Ordering::Relaxed);
            }
        };
        // A full command queue to the tick loses the command: counted as
        // lost telemetry would be (the tick drains it every sample).
        let mut control = |c: ControlCmd| {
            if ctl.enqueue(c).is_err() {
                stats.out_lost.fetch_add(1, Ordering::Relaxed);
            }
        };
        while let Some(c) = self.cmds.dequeue() {
            self.nav.command(c, &mut emit, &mut control);
        }
        while let Some(x) = self.input.dequeue() {
            self.nav.input(&x, &mut emit, &mut control);
        }
    }
}

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
    store: Store,
    rx: RxRing,
    tx: Producer<'a, u8, TX_Q>,
    from_tick: Consumer<'a, Telemetry, OUT_Q>,
    from_nav: Consumer<'a, Outbound, OUT_Q>,
    to_tick: Producer<'a, ControlCmd, CMD_Q>,
    to_nav: Producer<'a, NavCmd, CMD_Q>,
    feeder: Feeder,
    sensors: bool,
    /// Since when the IMU's data-ready edges are expected, µs (`None`
    /// while the QEMU harness has not powered its sensors).
    sensors_from: Option<u64>,
    last_run_us: u64,
    healthy_told: bool,
    clock_start: u64,
    last_health: Option<u64>,
    timed_out: bool,
    reset: ResetCause,
    tuning: Tuning,
    boot_reports: [Option<Telemetry>; 6],
    /// Commands refused as malformed or out of bounds.
    refused: u32,
    /// What the counters below were when each was last reported.
    counted: [(u32, Option<u64>); COUNTED.len()],
}

/// The counters the tasks keep (no task may wait to send a report) and
/// the faults the link reports them as.
const COUNTED: [Fault; 4] = [
    Fault::TickOverrun,
    Fault::RxLost,
    Fault::TelemetryOverflow,
    Fault::BadCommand,
];

/// Counter `f`'s total: the tasks' (`stats`), or for
/// [`Fault::BadCommand`] the commands refused (`refused`, each also
/// answered with its reason) and the frames that arrived corrupt or
/// oversize (`link`'s decoder: no command to answer).
fn counter(stats: &Stats, link: &Link, refused: u32, f: Fault) -> u32 {
    let a = match f {
        Fault::TickOverrun => &stats.tick_overruns,
        Fault::RxLost => &stats.rx_lost,
        Fault::BadCommand => {
            let s = link.rx_stats();
            let frames = u32::try_from(s.corrupt.saturating_add(s.overflow)).unwrap_or(u32::MAX);
            return frames.saturating_add(refused);
        }
        _ => &stats.out_lost,
    };
    a.load(Ordering::Relaxed)
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

    /// The IMU's edges are not expected yet (the QEMU harness powers its
    /// sensors when the host's configuration has come).
    pub fn sensors_later(&mut self) {
        self.sensors_from = None;
    }

    /// The IMU's edges are expected from now on.
    pub fn sensors_started(&mut self) {
        if self.sensors && self.sensors_from.is_none() {
            self.sensors_from = Some(self.last_run_us);
        }
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
        while let Some(b) = self.rx.next(dma) {
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

    /// The tasks' overruns and losses as faults: when a counter has grown,
    /// at most once per [`crate::faults::REPORT_EVERY_US`] each, with the
    /// total so far.
    fn report_counted(&mut self, mcu_us: u64, stats: &Stats) {
        for (f, (seen, last)) in COUNTED.iter().zip(self.counted.iter_mut()) {
            let now = counter(stats, &self.link, self.refused, *f);
            let due =
                last.is_none_or(|t| mcu_us.saturating_sub(t) >= crate::faults::REPORT_EVERY_US);
            if now > *seen && due {
                *seen = now;
                *last = Some(mcu_us);
                let t = Telemetry::Fault {
                    t_us: mcu_us,
                    fault: *f,
                    count: now,
                };
                send(&mut self.link, &mut self.tx, &t);
            }
        }
    }

    fn fault(&mut self, t_us: u64, f: Fault) {
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
        let Some(from) = self.sensors_from.filter(|_| self.sensors) else {
            return false;
        };
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

    fn health(&self, mcu_us: u64, stats: &Stats) -> Telemetry {
        let l = |a: &AtomicU32| a.load(Ordering::Relaxed);
        Telemetry::Health {
            t_us: mcu_us,
            reset: self.reset,
            tick_worst: l(&stats.tick_worst),
            tick_overruns: l(&stats.tick_overruns),
            nav_worst: l(&stats.nav_worst),
            nav_overruns: l(&stats.nav_overruns),
            samples_dropped: l(&stats.dropped),
            samples_duplicated: l(&stats.duplicated),
            rx_bytes: l(&stats.rx_bytes),
            rx_lost: l(&stats.rx_lost),
            init_stack_bytes: l(&stats.init_stack_bytes),
            stack_bytes: l(&stats.stack_bytes),
        }
    }

    /// When the board started, µs.
    pub fn started_us(&self) -> u64 {
        self.clock_start
    }
}

/// A refusal of the command itself (malformed, out of bounds), not of
/// what the board could do with a good one (not aided, not stored).
fn is_bad(s: protocol::Status) -> bool {
    use protocol::Status as S;
    !matches!(s, S::Accepted | S::NotAided | S::Aided | S::NotStored)
}

fn send(link: &mut Link, tx: &mut Producer<'_, u8, TX_Q>, t: &Telemetry) {
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

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
/// ([`crate::watchdog::RUN`], a host test checks it), so the fault is told and
/// the motor off before the watchdog resets a board whose tick stopped;
/// the link task sees it within one of its 10 ms periods.
pub const IMU_TIMEOUT_US: u32 = 20_000;
/// Health telemetry every this long, µs.
pub const HEALTH_EVERY_US: u64 = 1_000_000;

mod config;
mod health;
mod link;
mod nav;
mod stats;
mod tick;

pub use config::{nav_config, Tuning, FACTORY};
use health::COUNTED;
pub use link::{LinkOut, LinkTask, Window};
pub use nav::NavTask;
pub use stats::Stats;
pub use tick::TickTask;

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
            window: link::Window::FirstRun,
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

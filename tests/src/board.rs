//! The board's program on the host: the same tasks (`firmware::tasks`) in
//! the order the board's priorities give them (the UART's bytes, then the
//! tick at each data-ready edge, navigation when the tick pends it, the
//! link task every 10 ms), over any sensors (hal-sim's, or a replay's).
//! The closed-loop tests and the QEMU test's host twin run it.

use firmware::protocol::Command;
use firmware::record::{Flash, FlashError, Journal, Sector};
use firmware::tasks::{Boot, Encoder, Imu, Motor, Program, Queues, Stats, Tuning, Watchdog};
use firmware::uart_rx::SoftDma;
use protocol::MAX_FRAME;

/// NOR flash in memory (programs only clear bits; erases set them), with
/// an optional cut: after `cut_after` operations every write is lost, as
/// when power fails (the word being written when it does holds garbage).
#[derive(Clone, Debug)]
pub struct NorFlash {
    /// The bytes (address 0 first).
    pub mem: Vec<u8>,
    /// Operations left before the power fails (`None`: it never does).
    pub cut_after: Option<usize>,
    /// Operations done.
    pub ops: usize,
    /// How long an erase takes, µs: the board's sector at the datasheet's
    /// worst ([`firmware::record::ERASE_WORST_US`]) unless a test says.
    pub erase_us: u64,
    /// The time the flash has kept the CPU waiting, µs (its erases).
    pub busy_us: u64,
}

impl NorFlash {
    /// `len` bytes, erased.
    pub fn new(len: usize) -> Self {
        Self {
            mem: vec![0xFF; len],
            cut_after: None,
            ops: 0,
            erase_us: u64::from(firmware::record::ERASE_WORST_US),
            busy_us: 0,
        }
    }

    /// Whether this operation completes (`Full`), is the one the power
    /// fails in (`Cut`), or comes after (`Off`).
    fn power(&mut self) -> Power {
        let n = self.ops;
        self.ops += 1;
        match self.cut_after {
            Some(c) if n > c => Power::Off,
            Some(c) if n == c => Power::Cut,
            _ => Power::Full,
        }
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Power {
    Full,
    Cut,
    Off,
}

impl Flash for NorFlash {
    fn read(&mut self, addr: u32, buf: &mut [u8]) -> Result<(), FlashError> {
        let a = addr as usize;
        buf.copy_from_slice(
            self.mem
                .get(a..a + buf.len())
                .ok_or(FlashError::OutOfRange)?,
        );
        Ok(())
    }
    fn program_word(&mut self, addr: u32, word: u32) -> Result<(), FlashError> {
        let a = addr as usize;
        let p = self.power();
        let d = self.mem.get_mut(a..a + 4).ok_or(FlashError::OutOfRange)?;
        // Cut mid-word: the first byte made it, the rest did not.
        let bytes = match p {
            Power::Full => 4,
            Power::Cut => 1,
            Power::Off => 0,
        };
        for (x, w) in d.iter_mut().zip(word.to_le_bytes()).take(bytes) {
            *x &= w;
        }
        Ok(())
    }
    fn erase(&mut self, s: Sector) -> Result<(), FlashError> {
        let p = self.power();
        self.busy_us += self.erase_us;
        let a = s.base as usize;
        let d = self
            .mem
            .get_mut(a..a + s.len as usize)
            .ok_or(FlashError::OutOfRange)?;
        match p {
            Power::Full => d.fill(0xFF),
            // Half erased: the rest keeps its old bits.
            Power::Cut => {
                let half = d.len() / 2;
                d[..half].fill(0xFF);
            }
            Power::Off => {}
        }
        Ok(())
    }
}

/// The journal's sectors on the host and under QEMU: two of 2 KiB.
pub const JOURNAL: [Sector; 2] = firmware::record::MODEL_SECTORS;

/// A watchdog that counts its feeds.
#[derive(Clone, Copy, Debug, Default)]
pub struct CountingWatchdog {
    /// Feeds.
    pub feeds: u32,
}
impl Watchdog for CountingWatchdog {
    fn feed(&mut self) {
        self.feeds += 1;
    }
}

/// The board's program on the host.
pub struct HostBoard {
    /// The tasks.
    pub program: &'static mut Program<'static>,
    /// Their counters.
    pub stats: &'static Stats,
    /// The receive ring the UART's bytes go into (as under QEMU: the
    /// board's DMA writes the same ring).
    pub rx: &'static SoftDma,
    /// The flash.
    pub flash: NorFlash,
    /// The watchdog.
    pub wdg: CountingWatchdog,
    /// The MCU clock, µs.
    pub mcu_us: u64,
    next_link_us: u64,
    /// Every byte the board sent.
    pub sent: Vec<u8>,
    /// The link task's last word on the motor: off (the IMU silent).
    pub motor_off: bool,
    /// The link task said the board ran healthily (the reset log's row
    /// is over).
    pub healthy: bool,
    seq: u16,
    /// When `init` started (the watchdog with it), µs.
    booted_us: u64,
    first_feed_us: Option<u64>,
    last_feed_us: Option<u64>,
    longest_unfed_us: u64,
}

impl HostBoard {
    /// The board booting at MCU time `now_us` on `flash` after a
    /// power-on.
    pub fn new(
        tuning: Tuning,
        flash: NorFlash,
        now_us: u64,
        imu_ok: Result<(), firmware::faults::Fault>,
    ) -> Self {
        let resets = firmware::resets::BootVerdict {
            cause: protocol::ResetCause::PowerOn,
            ..Default::default()
        };
        Self::boot(tuning, flash, now_us, imu_ok, resets)
    }

    /// The board booting at MCU time `now_us` on `flash` with the reset
    /// log's verdict `resets` (its cause the reset's).
    pub fn boot(
        tuning: Tuning,
        flash: NorFlash,
        now_us: u64,
        imu_ok: Result<(), firmware::faults::Fault>,
        resets: firmware::resets::BootVerdict,
    ) -> Self {
        Self::boot_clocked(tuning, flash, now_us, imu_ok, resets, Ok(()))
    }

    /// [`Self::boot`] with the clock tree's start (`firmware::clocks`).
    pub fn boot_clocked(
        tuning: Tuning,
        mut flash: NorFlash,
        now_us: u64,
        imu_ok: Result<(), firmware::faults::Fault>,
        resets: firmware::resets::BootVerdict,
        clock: Result<(), firmware::faults::Fault>,
    ) -> Self {
        let queues: &'static mut Queues = Box::leak(Box::new(Queues::new()));
        let stats: &'static Stats = Box::leak(Box::default());
        // As `init` runs on the board: the link task's timer starts before
        // the journal opens (so its first run is due when `init` ends,
        // before any data-ready edge), and the clock is read after the
        // erases, which take the flash's time.
        let timer_from = now_us;
        let busy = flash.busy_us;
        let journal =
            Journal::open(&mut flash, JOURNAL).unwrap_or_else(|_| Journal::blank(JOURNAL));
        let now_us = now_us + (flash.busy_us - busy);
        let slot = Box::leak(Box::new(core::mem::MaybeUninit::uninit()));
        let program = Program::new(
            slot,
            queues,
            journal,
            Boot {
                now_us,
                reset: resets.cause,
                imu: imu_ok,
                tuning,
                clock,
                resets,
            },
        )
        .expect("the tuning's scheme is within the limits");
        let mut b = Self {
            program,
            stats,
            rx: Box::leak(Box::default()),
            flash,
            wdg: CountingWatchdog::default(),
            mcu_us: now_us,
            next_link_us: now_us,
            sent: vec![],
            motor_off: false,
            healthy: false,
            seq: 0,
            booted_us: timer_from,
            first_feed_us: None,
            last_feed_us: None,
            longest_unfed_us: 0,
        };
        // The link task's update, pending since before the erases, runs
        // first when `init` returns (once: its timer's flag is one bit).
        b.link_due();
        b
    }

    /// The longest the watchdog went unfed after the tasks started, µs
    /// (the run period's to beat), and how long after the watchdog's start
    /// at the top of `init` its first feed came (the boot period's).
    pub fn unfed_us(&self) -> (u64, Option<u64>) {
        (
            self.longest_unfed_us,
            self.first_feed_us.map(|t| t - self.booted_us),
        )
    }

    /// Bytes arriving at the board's UART.
    pub fn receive(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.rx.write(*b);
        }
    }

    /// The acknowledgements the board has sent so far.
    pub fn acks(&self) -> usize {
        let mut d = protocol::Decoder::default();
        let mut out = [0u8; protocol::MAX_PAYLOAD + 2];
        let mut n = 0;
        for b in &self.sent {
            if let Some(m) = d.push(*b, &mut out) {
                if matches!(
                    protocol::Telemetry::decode(&out[..m]),
                    Ok((_, protocol::Telemetry::Ack { .. }))
                ) {
                    n += 1;
                }
            }
        }
        n
    }

    /// A command arriving whole (byte by byte through the UART's queue).
    pub fn command(&mut self, c: &Command) {
        let mut f = [0u8; MAX_FRAME];
        let n = c.to_frame(self.seq, &mut f).expect("a frame fits");
        self.seq = self.seq.wrapping_add(1);
        self.receive(&f[..n]);
    }

    /// The link task if it is due (every 10 ms), and the UART's output.
    pub fn link_due(&mut self) {
        while self.mcu_us >= self.next_link_us {
            self.next_link_us += 10_000;
            let feeds = self.wdg.feeds;
            let out = self.program.link.run(
                self.mcu_us,
                self.rx,
                &mut self.flash,
                &mut self.wdg,
                self.stats,
            );
            self.motor_off = out.motor_off;
            self.healthy |= out.healthy;
            self.watch_feeds(feeds);
            while let Some(b) = self.program.uart.next_tx() {
                self.sent.push(b);
            }
        }
    }

    fn watch_feeds(&mut self, before: u32) {
        let (now, last) = (self.mcu_us, self.last_feed_us);
        if let Some(l) = last {
            self.longest_unfed_us = self.longest_unfed_us.max(now - l);
        }
        if self.wdg.feeds != before {
            self.first_feed_us.get_or_insert(now);
            self.last_feed_us = Some(now);
        }
    }

    /// Time passes without a data-ready edge (the IMU silent).
    pub fn idle(&mut self, dt_us: u64) {
        let end = self.mcu_us + dt_us;
        while self.mcu_us < end {
            self.mcu_us = (self.mcu_us + 1_000).min(end);
            self.link_due();
        }
    }

    /// One data-ready edge at the MCU time `mcu_us`: the tick, navigation
    /// if pended, the link task if due.
    pub fn edge(
        &mut self,
        mcu_us: u64,
        imu: &mut impl Imu,
        enc: &mut impl Encoder,
        motor: &mut impl Motor,
    ) {
        self.mcu_us = mcu_us;
        if self.program.tick.run(mcu_us, imu, enc, motor, self.stats) {
            self.program.nav.run(self.stats);
        }
        self.link_due();
    }
}

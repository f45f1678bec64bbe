//! The watchdog's rule: the hardware watchdog (IWDG, [`RUN`]) is fed only
//! when every task that should be running has made progress since the last
//! feed. Each task bumps its own counter; the background task checks them
//! and feeds. A control tick that stopped (a hung IMU), a navigation task
//! starved or stuck, or a link task that no longer runs all reset the chip.
//!
//! A board stopped at power-up (its IMU did not answer) runs no tick and no
//! navigation: it expects only the link's progress, so it stays up and
//! reports instead of resetting every 100 ms.

use core::sync::atomic::{AtomicU32, Ordering};

/// The IWDG's clock, the LSI: 17 kHz at least, 32 kHz typically, 47 kHz at
/// most over voltage and temperature (the STM32F405 datasheet, DS8626,
/// LSI oscillator characteristics), Hz. The IWDG's period is known only
/// within this range.
pub const LSI_HZ: [u32; 3] = [17_000, 32_000, 47_000];

/// An IWDG setting (RM0090 21.4): the prescaler register PR (the LSI
/// divided by `4 << pr`, `pr` 0-6) and the reload RLR (0-4095); the
/// counter reaches 0, and resets the chip, `(rlr + 1) * (4 << pr)` LSI
/// periods after a feed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Iwdg {
    /// PR, 0-6.
    pub pr: u8,
    /// RLR, 0-4095.
    pub rlr: u16,
}

impl Iwdg {
    /// The period with the LSI at `lsi_hz`, µs.
    pub const fn period_us(self, lsi_hz: u32) -> u64 {
        (self.rlr as u64 + 1) * (4u64 << self.pr) * 1_000_000 / lsi_hz as u64
    }
    /// The shortest period (the LSI at its fastest), µs.
    pub const fn shortest_us(self) -> u64 {
        self.period_us(LSI_HZ[2])
    }
    /// The longest period (the LSI at its slowest), µs.
    pub const fn longest_us(self) -> u64 {
        self.period_us(LSI_HZ[0])
    }
    /// Within the registers' ranges.
    pub const fn valid(self) -> bool {
        self.pr <= 6 && self.rlr <= 0x0FFF
    }
}

/// From the top of `init` to its end: /64, reload 4095 (8.2 s at the
/// typical LSI; 5.6-15.4 s): longer than the worst boot, two journal
/// erases at the datasheet's worst ([`crate::record::ERASE_WORST_US`]
/// each) with the clock tree's bounded start, so a boot that erases is
/// never reset half-way, and a boot that hangs (a stack overflow that
/// locks the core) is reset.
pub const BOOT: Iwdg = Iwdg { pr: 4, rlr: 4095 };

/// Once the tasks run: /32, reload 99 (100 ms at the typical LSI; 68-188
/// ms): longer than the IMU's silence the link task reports first
/// (`tasks::IMU_TIMEOUT_US` and one link period).
pub const RUN: Iwdg = Iwdg { pr: 3, rlr: 99 };

/// Each task's progress counter.
#[derive(Debug, Default)]
pub struct Progress {
    /// Control ticks run.
    pub tick: AtomicU32,
    /// Navigation runs.
    pub nav: AtomicU32,
    /// Background runs.
    pub link: AtomicU32,
}

/// The feeding rule.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Feeder {
    seen: [u32; 3],
    /// Feeds refused (a task made no progress).
    pub refused: u32,
}

impl Feeder {
    /// Whether to feed now: every expected task advanced since the last
    /// feed. `sensors` is false on a board whose IMU never came up.
    pub fn check(&mut self, p: &Progress, sensors: bool) -> bool {
        let now = [
            p.tick.load(Ordering::Relaxed),
            p.nav.load(Ordering::Relaxed),
            p.link.load(Ordering::Relaxed),
        ];
        let moved = |i: usize| now.get(i) != self.seen.get(i);
        let ok = moved(2) && (!sensors || (moved(0) && moved(1)));
        if ok {
            self.seen = now;
        } else {
            self.refused = self.refused.saturating_add(1);
        }
        ok
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_periods_cover_the_boot_and_the_link_over_the_lsis_range() {
        assert!(BOOT.valid() && RUN.valid());
        // RM0090 table 107's corners at 32 kHz: /4 reload 0 is 0.125 ms,
        // /256 reload 4095 is 32.768 s.
        assert_eq!(Iwdg { pr: 0, rlr: 0 }.period_us(32_000), 125);
        assert_eq!(Iwdg { pr: 6, rlr: 4095 }.period_us(32_000), 32_768_000);
        assert_eq!(RUN.period_us(32_000), 100_000);
        assert_eq!((RUN.shortest_us(), RUN.longest_us()), (68_085, 188_235));
        // Two worst erases and the clock tree's two bounded waits (each at
        // least 100 ms, at most 400,000 polls of a few cycles at 16 MHz:
        // 0.2 s together, taken as 1 s) inside the boot's shortest period.
        let boot_us = 2 * u64::from(crate::record::ERASE_WORST_US) + 1_000_000;
        assert!(BOOT.shortest_us() > boot_us, "{}", BOOT.shortest_us());
        // The IMU's silence is told (one link run after the timeout) before
        // the run period's shortest reset.
        let told_us = u64::from(crate::tasks::IMU_TIMEOUT_US) + 10_000;
        assert!(RUN.shortest_us() > 2 * told_us);
    }

    #[test]
    fn a_stalled_task_starves_the_watchdog() {
        let p = Progress::default();
        let mut f = Feeder::default();
        let bump = |a: &AtomicU32| a.fetch_add(1, Ordering::Relaxed);
        for _ in 0..3 {
            bump(&p.tick);
            bump(&p.nav);
            bump(&p.link);
            assert!(f.check(&p, true));
        }
        // Navigation stops: no feed, however often the others run.
        bump(&p.tick);
        bump(&p.link);
        assert!(!f.check(&p, true));
        // A board without sensors needs only the link.
        bump(&p.link);
        assert!(f.check(&p, false));
    }
}

//! The watchdog's rule: the hardware watchdog (IWDG, 100 ms) is fed only
//! when every task that should be running has made progress since the last
//! feed. Each task bumps its own counter; the background task checks them
//! and feeds. A control tick that stopped (a hung IMU), a navigation task
//! starved or stuck, or a link task that no longer runs all reset the chip.
//!
//! A board stopped at power-up (its IMU did not answer) runs no tick and no
//! navigation: it expects only the link's progress, so it stays up and
//! reports instead of resetting every 100 ms.

use core::sync::atomic::{AtomicU32, Ordering};

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

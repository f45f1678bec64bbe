//! The clock tree's start, with every wait bounded: the crystal (HSE) and
//! the PLL each get a timeout, and a part that does not start is a fault
//! reported at boot, not a silent hang before the watchdog runs.
//!
//! | HSE | PLL | the board runs on | reported |
//! | --- | --- | --- | --- |
//! | starts | locks | HSE through the PLL, 168 MHz | nothing |
//! | silent | locks | HSI through the PLL, 168 MHz | [`Fault::ClockFallback`] |
//! | any | does not lock | HSI alone, 16 MHz, safe mode | [`Fault::ClockFailed`] |
//!
//! HSI is 16 MHz within 1 % at 25 °C (the STM32F405 datasheet), so the
//! fallback's time stamps and baud rate carry that error; at 16 MHz the
//! navigation does not fit its period, so the board stays stopped with
//! the link up (the same safe state as a reset loop's).

use crate::faults::Fault;
use crate::ports::{ClockControl, ClockSource};

/// Polls of a ready flag before the part is given up: a poll is a
/// volatile read and a branch, at least 4 cycles at HSI's 16 MHz before
/// the PLL runs, so at least 100 ms (ST's `HSE_STARTUP_TIMEOUT`; the
/// datasheet's crystal start-up is 2 ms, the PLL's lock 0.2 ms).
pub const START_POLLS: u32 = 400_000;

/// What the clock tree runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plan {
    /// The crystal through the PLL: 168 MHz.
    Hse168,
    /// The internal oscillator through the PLL: 168 MHz.
    Hsi168,
    /// The internal oscillator alone: 16 MHz.
    Hsi16,
}

impl Plan {
    /// The fault this plan is reported as (`Ok`: the crystal's).
    ///
    /// # Errors
    /// The fallback's fault.
    pub fn status(self) -> Result<(), Fault> {
        match self {
            Self::Hse168 => Ok(()),
            Self::Hsi168 => Err(Fault::ClockFallback),
            Self::Hsi16 => Err(Fault::ClockFailed),
        }
    }
}

/// Whether `ready` holds within `polls` polls.
fn within(polls: u32, mut ready: impl FnMut() -> bool) -> bool {
    (0..polls).any(|_| ready())
}

/// Tries the crystal, then the PLL from whichever oscillator runs, each
/// within `polls` polls; leaves the PLL off (the HAL's set-up turns it on
/// again with the source found here) and the crystal on only if it
/// started.
pub fn plan(c: &mut impl ClockControl, polls: u32) -> Plan {
    c.hse_on(true);
    let hse = within(polls, || c.hse_ready());
    if !hse {
        c.hse_on(false);
    }
    let src = if hse {
        ClockSource::Hse
    } else {
        ClockSource::Hsi
    };
    c.pll_configure(src);
    c.pll_on(true);
    let locked = within(polls, || c.pll_ready());
    c.pll_on(false);
    let _ = within(polls, || !c.pll_ready());
    match (hse, locked) {
        (true, true) => Plan::Hse168,
        (false, true) => Plan::Hsi168,
        (_, false) => Plan::Hsi16,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A clock tree whose parts start after so many polls (`None`: never).
    struct Tree {
        hse_after: Option<u32>,
        pll_after: Option<u32>,
        hse: (bool, u32),
        pll: (bool, u32),
        src: Option<ClockSource>,
    }
    impl Tree {
        fn new(hse_after: Option<u32>, pll_after: Option<u32>) -> Self {
            Self {
                hse_after,
                pll_after,
                hse: (false, 0),
                pll: (false, 0),
                src: None,
            }
        }
    }
    fn ready(part: &mut (bool, u32), after: Option<u32>) -> bool {
        part.1 += 1;
        part.0 && after.is_some_and(|n| part.1 > n)
    }
    impl ClockControl for Tree {
        fn hse_on(&mut self, on: bool) {
            self.hse = (on, 0);
        }
        fn hse_ready(&mut self) -> bool {
            ready(&mut self.hse, self.hse_after)
        }
        fn pll_configure(&mut self, src: ClockSource) {
            self.src = Some(src);
        }
        fn pll_on(&mut self, on: bool) {
            self.pll = (on, 0);
        }
        fn pll_ready(&mut self) -> bool {
            ready(&mut self.pll, self.pll_after)
        }
    }

    #[test]
    fn each_dead_part_ends_in_its_plan_within_the_polls() {
        let cases = [
            (Some(10), Some(5), Plan::Hse168, Some(ClockSource::Hse)),
            (None, Some(5), Plan::Hsi168, Some(ClockSource::Hsi)),
            (Some(10), None, Plan::Hsi16, Some(ClockSource::Hse)),
            (None, None, Plan::Hsi16, Some(ClockSource::Hsi)),
            // Started one poll too late: given up.
            (Some(100), Some(5), Plan::Hsi168, Some(ClockSource::Hsi)),
        ];
        for (hse, pll, want, src) in cases {
            let mut t = Tree::new(hse, pll);
            assert_eq!(plan(&mut t, 100), want, "{hse:?} {pll:?}");
            assert_eq!(t.src, src);
            // The crystal left on only when it runs; the PLL left off.
            assert_eq!(
                t.hse.0,
                want == Plan::Hse168 || (hse.is_some_and(|n| n < 100))
            );
            assert!(!t.pll.0);
        }
        assert_eq!(Plan::Hsi16.status(), Err(Fault::ClockFailed));
    }
}

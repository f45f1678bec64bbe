//! The clock tree's start, with every wait bounded: the crystal (HSE) and
//! the PLL each get a timeout, and a part that does not start is a fault
//! reported at boot, not a silent hang before the watchdog runs.
//!
//! | HSE | PLL | the board runs on | reported |
//! | --- | --- | --- | --- |
//! | starts | locks | HSE through the PLL, 168 MHz | nothing |
//! | silent | (not tried) | HSI alone, 16 MHz, safe mode | [`Fault::HseFailed`] |
//! | starts | does not lock | HSI alone, 16 MHz, safe mode | [`Fault::PllFailed`] |
//!
//! At 16 MHz navigation does not fit its period, so the board stays
//! stopped with the link up (the same safe state as a reset loop's). HSI is
//! 16 MHz within 1 % at 25 degC (the STM32F405 datasheet), and 921,600 baud
//! from it is 941,176 (2.1 % fast, inside the receiver's 3.75 %, RM0090
//! 30.3.5): the link still reports why.
//!
//! Only the crystal's configuration goes through the HAL's clock set-up,
//! with constants: its checks fold away and no panic path is linked.

use crate::faults::Fault;
use crate::ports::{ClockControl, ClockSource};

/// Polls of a ready flag before the part is given up: a poll is a
/// volatile read and a branch, at least 4 cycles at HSI's 16 MHz before
/// the PLL runs, so at least 100 ms (ST's `HSE_STARTUP_TIMEOUT`; the
/// datasheet's crystal starts in 2 ms, the PLL locks in 0.2 ms).
pub const START_POLLS: u32 = 400_000;

/// What the clock tree runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plan {
    /// The crystal through the PLL: 168 MHz.
    Hse168,
    /// The internal oscillator alone (16 MHz), with why.
    Hsi16(Fault),
}

impl Plan {
    /// The fault this plan is reported as (`Ok`: the crystal's).
    ///
    /// # Errors
    /// Why the board runs from HSI.
    pub fn status(self) -> Result<(), Fault> {
        match self {
            Self::Hse168 => Ok(()),
            Self::Hsi16(f) => Err(f),
        }
    }
}

/// Whether `ready` holds within `polls` polls.
fn within(polls: u32, mut ready: impl FnMut() -> bool) -> bool {
    (0..polls).any(|_| ready())
}

/// Tries the crystal, then the PLL from it, each within `polls` polls;
/// leaves the PLL off (the HAL's set-up turns it on again) and the crystal
/// on only if both started.
pub fn plan(c: &mut impl ClockControl, polls: u32) -> Plan {
    c.hse_on(true);
    if !within(polls, || c.hse_ready()) {
        c.hse_on(false);
        return Plan::Hsi16(Fault::HseFailed);
    }
    c.pll_configure(ClockSource::Hse);
    c.pll_on(true);
    let locked = within(polls, || c.pll_ready());
    c.pll_on(false);
    let _ = within(polls, || !c.pll_ready());
    if locked {
        Plan::Hse168
    } else {
        c.hse_on(false);
        Plan::Hsi16(Fault::PllFailed)
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
        use Fault::{HseFailed, PllFailed};
        let cases = [
            (Some(10), Some(5), Plan::Hse168, Some(ClockSource::Hse)),
            (None, Some(5), Plan::Hsi16(HseFailed), None),
            (
                Some(10),
                None,
                Plan::Hsi16(PllFailed),
                Some(ClockSource::Hse),
            ),
            (None, None, Plan::Hsi16(HseFailed), None),
            // Started one poll too late: given up.
            (Some(100), Some(5), Plan::Hsi16(HseFailed), None),
            (
                Some(10),
                Some(100),
                Plan::Hsi16(PllFailed),
                Some(ClockSource::Hse),
            ),
        ];
        for (hse, pll, want, src) in cases {
            let mut t = Tree::new(hse, pll);
            assert_eq!(plan(&mut t, 100), want, "{hse:?} {pll:?}");
            assert_eq!(t.src, src);
            // The crystal left on only when the plan uses it; the PLL off.
            assert_eq!(t.hse.0, want == Plan::Hse168);
            assert!(!t.pll.0);
        }
        assert_eq!(Plan::Hsi16(PllFailed).status(), Err(PllFailed));
    }
}

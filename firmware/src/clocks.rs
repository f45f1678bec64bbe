//! The clock tree's start, with every wait bounded: the crystal (HSE) and
//! the PLL each get a timeout, and a part that does not start is a fault
//! reported at boot, not a silent hang before the watchdog runs.
//!
//! | HSE | PLL | the board runs on | reported |
//! | --- | --- | --- | --- |
//! | starts | locks | HSE through the PLL, 168 MHz | nothing |
//! | silent | locks from HSI | HSI through the PLL, 168 MHz, stopped | [`Fault::HseFailed`] |
//! | silent | does not lock | HSI alone, 16 MHz, stopped | [`Fault::HseFailed`] |
//! | starts | does not lock | HSI alone, 16 MHz, stopped | [`Fault::PllFailed`] |
//!
//! A board without its crystal stays stopped with the link up (the same
//! safe state as a reset loop's): HSI is 16 MHz within 1 % at 25 degC
//! only (the STM32F405 datasheet; about 4 % over -10..85 degC), too loose
//! for the IMU's time mapping to be trusted. Through the PLL the link keeps
//! the crystal's divisor (APB1 at 42 MHz, BRR 46: 0.9 % slow, [`baud`])
//! where 16 MHz alone needs BRR 17 (2.1 % fast): with HSI's 1 % both are
//! inside the receiver's 3.41 % (RM0090 30.3.5, a fractional divisor), but
//! only the PLL's leaves room for HSI's drift.
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
    /// The internal oscillator through the PLL (168 MHz), with why.
    Hsi168(Fault),
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
            Self::Hsi168(f) | Self::Hsi16(f) => Err(f),
        }
    }

    /// APB1's clock (USART3's), Hz.
    pub fn apb1_hz(self) -> u32 {
        match self {
            Self::Hse168 | Self::Hsi168(_) => 42_000_000,
            Self::Hsi16(_) => 16_000_000,
        }
    }
}

/// The PLL's input clocks, Hz: the Feather's crystal and HSI.
pub const HSE_HZ: u32 = 12_000_000;
/// See [`HSE_HZ`].
pub const HSI_HZ: u32 = 16_000_000;

/// PLLCFGR's fields (RM0090 7.3.2): PLLM (5:0), PLLN (14:6), PLLP
/// (17:16), PLLSRC (22), PLLQ (27:24). The other bits are reserved and
/// must keep their reset value (bit 29 is 1 at reset).
pub const PLLCFGR_FIELDS: u32 = 0x3F | (0x1FF << 6) | (0b11 << 16) | (1 << 22) | (0xF << 24);

/// PLLCFGR for 168 MHz from `src` with the reserved bits of `old` kept:
/// 2 MHz into the VCO (M = 6 from the crystal, 8 from HSI), 336 MHz out of
/// it (N = 168), the system at 168 MHz (P = 2, written 0), USB at 48 MHz
/// (Q = 7).
pub const fn pllcfgr(old: u32, src: ClockSource) -> u32 {
    let (m, hse) = match src {
        ClockSource::Hse => (HSE_HZ / 2_000_000, 1),
        ClockSource::Hsi => (HSI_HZ / 2_000_000, 0),
    };
    (old & !PLLCFGR_FIELDS) | m | (168 << 6) | (hse << 22) | (7 << 24)
}

/// The baud rate USART3 runs at from `apb1_hz` for `want` (BRR in 16ths,
/// oversampling by 16, rounded), baud.
pub const fn baud(apb1_hz: u32, want: u32) -> u32 {
    let brr = (apb1_hz + want / 2) / want;
    apb1_hz / brr
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
        return if locks(c, ClockSource::Hsi, polls) {
            Plan::Hsi168(Fault::HseFailed)
        } else {
            Plan::Hsi16(Fault::HseFailed)
        };
    }
    if locks(c, ClockSource::Hse, polls) {
        Plan::Hse168
    } else {
        c.hse_on(false);
        Plan::Hsi16(Fault::PllFailed)
    }
}

/// Whether the PLL locks from `src` within `polls` polls (left off).
fn locks(c: &mut impl ClockControl, src: ClockSource, polls: u32) -> bool {
    c.pll_configure(src);
    c.pll_on(true);
    let locked = within(polls, || c.pll_ready());
    c.pll_on(false);
    let _ = within(polls, || !c.pll_ready());
    locked
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
    fn the_pll_keeps_pllcfgrs_reserved_bits_and_the_links_divisor() {
        // PLLCFGR's reset value (RM0090 7.3.2): bit 29 reserved, set.
        const RESET: u32 = 0x2400_3010;
        for src in [ClockSource::Hse, ClockSource::Hsi] {
            let v = pllcfgr(RESET, src);
            assert_eq!(v & (1 << 29), 1 << 29, "{src:?}");
            assert_eq!(v & !PLLCFGR_FIELDS, RESET & !PLLCFGR_FIELDS);
            let m = v & 0x3F;
            let input = if src == ClockSource::Hse {
                HSE_HZ
            } else {
                HSI_HZ
            };
            // 2 MHz into the VCO, N 168, P 2: 168 MHz.
            assert_eq!(input / m, 2_000_000);
            assert_eq!((v >> 6) & 0x1FF, 168);
            assert_eq!((v >> 16) & 0b11, 0);
            assert_eq!((v >> 24) & 0xF, 7);
        }
        // The raw write this replaces cleared bit 29.
        assert_eq!((6 | (168 << 6) | (1 << 22) | (7 << 24)) & (1 << 29), 0);
        // The link from each plan: through the PLL (crystal or HSI) BRR 46,
        // 913,043 baud (0.93 % slow); HSI alone BRR 17, 941,176 (2.12 %
        // fast). With HSI's 1 % at 25 degC the PLL's stays inside RM0090's
        // 3.41 % with 1.5 points to spare, HSI alone with 0.3.
        let off = |hz: u32| (f64::from(baud(hz, 921_600)) / 921_600.0 - 1.0) * 100.0;
        let pll = off(Plan::Hsi168(Fault::HseFailed).apb1_hz());
        let alone = off(Plan::Hsi16(Fault::HseFailed).apb1_hz());
        assert!(
            (pll + 0.93).abs() < 0.01 && (alone - 2.12).abs() < 0.01,
            "{pll} {alone}"
        );
        assert!(pll.abs() + 1.0 < 3.41 - 1.4 && alone.abs() + 1.0 < 3.41);
    }

    #[test]
    fn each_dead_part_ends_in_its_plan_within_the_polls() {
        use Fault::{HseFailed, PllFailed};
        let cases = [
            (Some(10), Some(5), Plan::Hse168, Some(ClockSource::Hse)),
            // A dead crystal: the PLL from HSI.
            (
                None,
                Some(5),
                Plan::Hsi168(HseFailed),
                Some(ClockSource::Hsi),
            ),
            (
                Some(10),
                None,
                Plan::Hsi16(PllFailed),
                Some(ClockSource::Hse),
            ),
            (None, None, Plan::Hsi16(HseFailed), Some(ClockSource::Hsi)),
            // Started one poll too late: given up.
            (
                Some(100),
                Some(5),
                Plan::Hsi168(HseFailed),
                Some(ClockSource::Hsi),
            ),
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

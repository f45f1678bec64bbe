//! What survives a reset: how many resets came in a row, and what a
//! HardFault left. Kept in RAM the startup code does not zero (the board's
//! `.uninit` section), guarded by a check word: after a power-on the RAM
//! holds noise, the check fails and the log starts afresh.
//!
//! The rule against a reset loop: a watchdog reset, a window-watchdog or
//! low-power reset, and a software reset that a HardFault asked for each
//! count one more in a row; a power-on, a brown-out or the reset pin (a
//! person) start the count again, and so does a healthy run
//! ([`HEALTHY_AFTER_US`] with every task making progress). After
//! [`SAFE_AFTER`] in a row the board boots into safe mode: motor off, no
//! tick, the link up, telemetry saying why; it stays so until a power-on,
//! or the reset pin.

use protocol::ResetCause;

/// Resets in a row that send the board into safe mode.
pub const SAFE_AFTER: u32 = 3;
/// A run this long with every task making progress ends a row of resets,
/// µs.
pub const HEALTHY_AFTER_US: u64 = 10_000_000;

/// The registers a HardFault leaves (ARMv7-M: SCB's fault status and
/// address registers, and the exception frame's PC and LR).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct FaultRegs {
    /// Configurable Fault Status Register.
    pub cfsr: u32,
    /// HardFault Status Register.
    pub hfsr: u32,
    /// MemManage Fault Address Register.
    pub mmfar: u32,
    /// BusFault Address Register.
    pub bfar: u32,
    /// The stacked PC: the instruction that faulted.
    pub pc: u32,
    /// The stacked LR.
    pub lr: u32,
}

impl FaultRegs {
    /// In the order `Telemetry::Boot` sends them.
    pub fn words(&self) -> [u32; 6] {
        [
            self.cfsr, self.hfsr, self.mmfar, self.bfar, self.pc, self.lr,
        ]
    }
}

/// The log as it lies in no-init RAM.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct ResetLog {
    in_row: u32,
    total: u32,
    fault: FaultRegs,
    has_fault: u32,
    check: u32,
}

/// What the boot learns from the log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BootVerdict {
    /// Why the board reset.
    pub cause: ResetCause,
    /// Watchdog and fault resets in a row, this one included.
    pub in_row: u32,
    /// Resets since power-on (this boot is not counted at a power-on).
    pub total: u32,
    /// Boot into safe mode.
    pub safe_mode: bool,
    /// The registers of the HardFault that caused this reset, if one did.
    pub fault: Option<FaultRegs>,
}

impl Default for BootVerdict {
    /// A first boot: no reset counted, no fault, not safe mode.
    fn default() -> Self {
        Self {
            cause: ResetCause::Unknown,
            in_row: 0,
            total: 0,
            safe_mode: false,
            fault: None,
        }
    }
}

const MAGIC: u32 = 0x5249_4e53; // "RINS"

impl ResetLog {
    fn sum(&self) -> u32 {
        let f = self.fault.words();
        [self.in_row, self.total, self.has_fault]
            .iter()
            .chain(f.iter())
            .fold(MAGIC, |a, w| a.rotate_left(5) ^ w)
    }

    fn seal(&mut self) {
        self.check = self.sum();
    }

    fn valid(&self) -> bool {
        self.check == self.sum()
    }

    /// At boot, with the chip's reset flags: counts this reset and says
    /// whether to boot into safe mode.
    pub fn boot(&mut self, cause: ResetCause) -> BootVerdict {
        let fresh = !self.valid() || matches!(cause, ResetCause::PowerOn | ResetCause::BrownOut);
        if fresh {
            *self = Self::default();
        }
        let fault = (self.has_fault == MAGIC).then_some(self.fault);
        let counts = matches!(
            cause,
            ResetCause::IndependentWatchdog | ResetCause::WindowWatchdog | ResetCause::LowPower
        ) || (cause == ResetCause::Software && fault.is_some());
        if !fresh {
            self.total = self.total.saturating_add(1);
        }
        self.in_row = if counts {
            self.in_row.saturating_add(1)
        } else {
            0
        };
        self.fault = FaultRegs::default();
        self.has_fault = 0;
        self.seal();
        BootVerdict {
            cause,
            in_row: self.in_row,
            total: self.total,
            safe_mode: self.in_row >= SAFE_AFTER,
            fault,
        }
    }

    /// The board has run healthily: the row of resets is over.
    pub fn healthy(&mut self) {
        if self.valid() && self.in_row != 0 {
            self.in_row = 0;
            self.seal();
        }
    }

    /// A HardFault's registers, kept for the next boot's report.
    pub fn hard_fault(&mut self, regs: FaultRegs) {
        if !self.valid() {
            *self = Self::default();
        }
        self.fault = regs;
        self.has_fault = MAGIC;
        self.seal();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_in_ram_starts_a_fresh_log() {
        let mut l = ResetLog {
            in_row: 7,
            total: 99,
            check: 1234,
            ..ResetLog::default()
        };
        let v = l.boot(ResetCause::IndependentWatchdog);
        assert_eq!((v.in_row, v.total, v.safe_mode), (1, 0, false));
    }

    #[test]
    fn watchdog_resets_in_a_row_end_in_safe_mode_and_a_person_ends_it() {
        let mut l = ResetLog::default();
        l.boot(ResetCause::PowerOn);
        let mut last = BootVerdict::default();
        for _ in 0..SAFE_AFTER {
            last = l.boot(ResetCause::IndependentWatchdog);
        }
        assert!(last.safe_mode);
        assert_eq!((last.in_row, last.total), (SAFE_AFTER, SAFE_AFTER));
        let v = l.boot(ResetCause::Pin);
        assert!(!v.safe_mode);
        assert_eq!(v.in_row, 0);
    }

    #[test]
    fn a_healthy_run_ends_the_row() {
        let mut l = ResetLog::default();
        l.boot(ResetCause::PowerOn);
        l.boot(ResetCause::IndependentWatchdog);
        l.boot(ResetCause::IndependentWatchdog);
        l.healthy();
        let v = l.boot(ResetCause::IndependentWatchdog);
        assert_eq!(v.in_row, 1);
        assert!(!v.safe_mode);
    }

    #[test]
    fn a_hard_faults_registers_reach_the_next_boot_once() {
        let mut l = ResetLog::default();
        l.boot(ResetCause::PowerOn);
        let regs = FaultRegs {
            cfsr: 0x0000_8200,
            hfsr: 0x4000_0000,
            mmfar: 0,
            bfar: 0x2002_0000,
            pc: 0x0800_1234,
            lr: 0xFFFF_FFF9,
        };
        l.hard_fault(regs);
        let v = l.boot(ResetCause::Software);
        assert_eq!(v.fault, Some(regs));
        assert_eq!(v.in_row, 1);
        // A debugger's reset (software, no fault) is no fault reset.
        let v = l.boot(ResetCause::Software);
        assert_eq!((v.fault, v.in_row), (None, 0));
    }
}

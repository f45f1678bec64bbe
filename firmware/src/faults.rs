//! Faults: each detected, counted and reported (telemetry `Fault`), ending
//! in a safe state (motor stopped) or a recovery. The codes are the
//! protocol's ([`protocol::Fault`]).
//!
//! A fault that persists (a stuck sensor, a flood of bad commands) is
//! reported when it first happens and then at most once per
//! [`REPORT_EVERY_US`], with its count: the link is never flooded, and the
//! count loses nothing.

pub use protocol::codes::FAULT_KINDS;
pub use protocol::Fault;
use protocol::Telemetry;

/// The shortest time between two reports of one fault, µs.
pub const REPORT_EVERY_US: u64 = 1_000_000;

/// Counts per fault, and when each was last reported.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FaultCounts {
    counts: [u32; FAULT_KINDS],
    reported: [Option<u64>; FAULT_KINDS],
}

impl FaultCounts {
    /// Counts one `f` at `t_us`; returns the report to send, if one is due.
    pub fn count(&mut self, t_us: u64, f: Fault) -> Option<Telemetry> {
        let i = usize::from(f.code()).checked_sub(1)?;
        let c = self.counts.get_mut(i)?;
        *c = c.saturating_add(1);
        let count = *c;
        let last = self.reported.get_mut(i)?;
        let due = last.is_none_or(|t| t_us.saturating_sub(t) >= REPORT_EVERY_US);
        if !due {
            return None;
        }
        *last = Some(t_us);
        Some(Telemetry::Fault {
            t_us,
            fault: f,
            count,
        })
    }

    /// How many `f` so far.
    pub fn get(&self, f: Fault) -> u32 {
        usize::from(f.code())
            .checked_sub(1)
            .and_then(|i| self.counts.get(i).copied())
            .unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_persistent_fault_is_reported_once_a_second_with_its_count() {
        let mut f = FaultCounts::default();
        let sent: u32 = (0..3000u64)
            .filter_map(|ms| f.count(ms * 1000, Fault::ImuStuck))
            .map(|_| 1)
            .sum();
        assert_eq!(sent, 3);
        assert_eq!(f.get(Fault::ImuStuck), 3000);
        assert!(f.count(3_000_000, Fault::SpiError).is_some());
    }
}

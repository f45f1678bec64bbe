//! Time on the board.
//!
//! - [`Clock64`]: a 64-bit microsecond clock from a free-running 32-bit
//!   hardware counter at 1 MHz (TIM5 on the STM32F405): it wraps every
//!   71.6 min; each reader extends it by counting wraps, and must read it
//!   at least once a wrap (every task does, at 1 kHz to 100 Hz).
//! - [`SampleClock`]: the sensor's sample clock as the navigation's time
//!   base. The IMU's data-ready edge paces the control tick; a sample's time
//!   is the first sample's time plus whole sample periods (the sensor's
//!   oscillator, as flight controllers take it), so jitter in the
//!   interrupt's latency never reaches the navigation. The MCU clock at each
//!   data-ready counts samples the sensor made but nobody read (dropped) and
//!   data-ready edges without new data (duplicated).

/// A 32-bit counter extended to 64 bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Clock64 {
    last: u32,
    wraps: u32,
}

impl Clock64 {
    /// A clock whose reading `start` (the counter's value at boot) is
    /// `start` µs: every task's clock made from the same `start` agrees.
    pub const fn new(start: u32) -> Self {
        Self {
            last: start,
            wraps: 0,
        }
    }

    /// The 64-bit time for the counter's value `now` (µs).
    pub fn extend(&mut self, now: u32) -> u64 {
        if now < self.last {
            self.wraps = self.wraps.wrapping_add(1);
        }
        self.last = now;
        (u64::from(self.wraps) << 32) | u64::from(now)
    }
}

/// What a data-ready edge meant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Edge {
    /// A new sample at this time (µs, the sample clock), after `dropped`
    /// samples that were never read.
    Sample {
        /// The sample's time, µs.
        t_us: u64,
        /// Samples lost before it.
        dropped: u32,
    },
    /// No new data behind the edge.
    Duplicate,
}

/// The sensor's sample clock (see the module).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleClock {
    period_us: u64,
    first: Option<u64>,
    last_mcu: u64,
    n: u64,
    /// Samples dropped so far.
    pub dropped: u32,
    /// Duplicated data-ready edges so far.
    pub duplicated: u32,
}

impl SampleClock {
    /// A clock for a sensor sampling every `period_us`.
    pub const fn new(period_us: u64) -> Self {
        Self {
            period_us,
            first: None,
            last_mcu: 0,
            n: 0,
            dropped: 0,
            duplicated: 0,
        }
    }

    /// The sample's index since the first (0 for the first).
    pub fn index(&self) -> u64 {
        self.n
    }

    /// A data-ready edge at MCU time `mcu_us`; `fresh` is the sensor's
    /// word that the data is new.
    pub fn edge(&mut self, mcu_us: u64, fresh: bool) -> Edge {
        if !fresh {
            self.duplicated = self.duplicated.saturating_add(1);
            return Edge::Duplicate;
        }
        let Some(t0) = self.first else {
            self.first = Some(mcu_us);
            self.last_mcu = mcu_us;
            return Edge::Sample {
                t_us: mcu_us,
                dropped: 0,
            };
        };
        let p = self.period_us.max(1);
        // Whole periods since the last edge, rounded (a late interrupt is
        // not a lost sample until it is half a period late).
        let periods = (mcu_us.saturating_sub(self.last_mcu) + p / 2) / p;
        let dropped = u32::try_from(periods.saturating_sub(1)).unwrap_or(u32::MAX);
        self.dropped = self.dropped.saturating_add(dropped);
        self.n = self.n.saturating_add(periods.max(1));
        self.last_mcu = mcu_us;
        Edge::Sample {
            t_us: t0.saturating_add(self.n.saturating_mul(p)),
            dropped,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clock_carries_across_the_u32_wrap() {
        let mut c = Clock64::new(u32::MAX - 5);
        assert_eq!(c.extend(u32::MAX - 1), u64::from(u32::MAX - 1));
        assert_eq!(c.extend(3), (1u64 << 32) + 3);
        assert_eq!(c.extend(u32::MAX), (1u64 << 32) + u64::from(u32::MAX));
        assert_eq!(c.extend(0), 2u64 << 32);
    }

    #[test]
    fn late_edges_drop_whole_samples_and_keep_the_grid() {
        let mut s = SampleClock::new(1_000);
        assert_eq!(
            s.edge(5_000, true),
            Edge::Sample {
                t_us: 5_000,
                dropped: 0
            }
        );
        // 300 µs of interrupt latency: the same grid.
        assert_eq!(
            s.edge(6_300, true),
            Edge::Sample {
                t_us: 6_000,
                dropped: 0
            }
        );
        // Two periods later (one sample never read).
        assert_eq!(
            s.edge(8_100, true),
            Edge::Sample {
                t_us: 8_000,
                dropped: 1
            }
        );
        assert_eq!(s.edge(8_200, false), Edge::Duplicate);
        assert_eq!((s.dropped, s.duplicated), (1, 1));
    }
}

//! Faults: each one detected, counted, reported (telemetry) and ending in a
//! safe state (motor stopped) or a recovery.

/// Fault codes (telemetry `Fault.code`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Fault {
    /// An SPI transfer failed (the sample is skipped; recovery: next sample).
    SpiError = 1,
    /// WHO_AM_I is not the ICM-42688-P's (safe state: no navigation).
    WrongDevice = 2,
    /// Identical IMU samples: a hung sensor (safe state: motor off, IMU reset).
    ImuStuck = 3,
    /// IMU at full scale or "no data" (the sample is skipped).
    ImuSaturated = 4,
    /// The encoder jumped faster than the table can turn (the read is
    /// dropped; recovery: resync on the next plausible read).
    EncoderGlitch = 5,
    /// The table does not follow the command (safe state: motor off until
    /// a new start command).
    MotorStall = 6,
    /// No IMU sample for 100 ms: the watchdog (safe state: motor off).
    ImuTimeout = 7,
    /// The power-up calibration refused its data (it restarts).
    CalibrationRefused = 8,
    /// The navigation refused a sample (non-finite, time gap).
    NavRefused = 9,
    /// A command was malformed or out of bounds (answered with the reason).
    BadCommand = 10,
    /// Telemetry frames dropped because the output queue was full.
    TelemetryOverflow = 11,
}

/// How many kinds of fault there are.
pub const FAULT_KINDS: usize = 11;

/// Counts per fault.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FaultCounts {
    counts: [u32; FAULT_KINDS],
}

impl FaultCounts {
    /// Counts one `f`; returns its new count.
    pub fn count(&mut self, f: Fault) -> u32 {
        match self.counts.get_mut(f as usize - 1) {
            Some(c) => {
                *c = c.saturating_add(1);
                *c
            }
            None => 0,
        }
    }

    /// How many `f` so far.
    pub fn get(&self, f: Fault) -> u32 {
        self.counts.get(f as usize - 1).copied().unwrap_or(0)
    }
}

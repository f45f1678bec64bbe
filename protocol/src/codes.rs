//! The codes the board and the host agree on, one enum each: faults,
//! command results, calibration results, rotation schemes, reset causes.
//! `TryFrom<u8>` refuses a value the enum does not have.

use crate::frame::FrameError;
use crate::wire::{Reader, Wire, Writer};

macro_rules! codes {
    (
        $(#[$m:meta])*
        pub enum $name:ident {
            $( $(#[$vm:meta])* $v:ident = $n:literal ),* $(,)?
        }
        unknown => $err:expr
    ) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        #[repr(u8)]
        pub enum $name {
            $( $(#[$vm])* $v = $n ),*
        }

        impl $name {
            /// Every value, in code order.
            pub const ALL: &'static [$name] = &[$( $name::$v ),*];

            /// The code on the wire.
            pub const fn code(self) -> u8 {
                self as u8
            }
        }

        impl TryFrom<u8> for $name {
            type Error = u8;
            fn try_from(c: u8) -> Result<Self, u8> {
                match c {
                    $( $n => Ok($name::$v), )*
                    other => Err(other),
                }
            }
        }

        impl Wire for $name {
            fn put(&self, w: &mut Writer<'_>) {
                w.put(&self.code());
            }
            fn get(r: &mut Reader<'_>) -> Result<Self, FrameError> {
                let c: u8 = r.get()?;
                $name::try_from(c).map_err($err)
            }
        }
    };
}

codes! {
    /// A fault: detected, counted, reported (telemetry `Fault`), ending in
    /// a safe state (motor stopped) or a recovery.
    pub enum Fault {
        /// An SPI transfer failed (the sample is skipped; recovery: next sample).
        SpiError = 1,
        /// WHO_AM_I is not the ICM-42688-P's (safe state: stopped, no navigation).
        WrongDevice = 2,
        /// Identical IMU samples: a hung sensor (safe state: motor off).
        ImuStuck = 3,
        /// IMU at full scale or "no data" (the sample is skipped, the motor
        /// to a safe duty).
        ImuSaturated = 4,
        /// The encoder jumped faster than the table can turn (the read is
        /// dropped; recovery: resync on the next plausible read).
        EncoderGlitch = 5,
        /// The table does not follow the command (safe state: motor off
        /// until a new start command).
        MotorStall = 6,
        /// No IMU sample for 20 ms (safe state: motor off).
        ImuTimeout = 7,
        /// The power-up calibration refused its data (it restarts).
        CalibrationRefused = 8,
        /// The navigation refused a sample (non-finite, time gap).
        NavRefused = 9,
        /// Commands refused as malformed or out of bounds (each also
        /// answered with its reason) and frames that arrived corrupt or
        /// oversize (no command to answer): the count is their total.
        BadCommand = 10,
        /// Telemetry frames dropped because an output queue was full.
        TelemetryOverflow = 11,
        /// The IMU's data-ready came more than 1.5 periods after the last:
        /// samples the sensor made were never read.
        SampleDropped = 12,
        /// Data-ready without new data (the sensor's status said so).
        SampleDuplicated = 13,
        /// The control tick was still running when its next period began.
        TickOverrun = 14,
        /// Navigation had not taken the last input when the next came (its
        /// queue full: the input is dropped).
        NavOverrun = 15,
        /// Received bytes lost: the UART's overrun flag, or bytes the
        /// receive ring overwrote before they were read.
        RxLost = 16,
        /// The flash record could not be written (the journal full, or the
        /// controller's error flags).
        FlashError = 17,
        /// A GNSS fix arrived after the navigation's horizon (applied at
        /// arrival, from the stored state at its time of validity).
        FixLate = 18,
        /// A GNSS fix older than the stored states, or from the future:
        /// refused.
        FixRefused = 19,
        /// The IMU did not answer at power-up (bus failure; safe state:
        /// stopped, reported).
        ImuInitFailed = 20,
        /// The board reset itself (watchdog, fault) this many times in a
        /// row without a healthy run between: it booted into safe mode
        /// (motor off, no tick, the link up) instead of trying again.
        ResetLoop = 21,
        /// The last reset came from a HardFault: its registers are in the
        /// boot report (`Telemetry::Boot`).
        HardFault = 22,
        /// The crystal (HSE) did not start within 100 ms: the board runs
        /// at 16 MHz from HSI, in safe mode (stopped, no tick, the link
        /// up; 921,600 baud 2.1 % fast).
        HseFailed = 23,
        /// The PLL did not lock within 100 ms: as [`Fault::HseFailed`].
        PllFailed = 24,
    }
    unknown => FrameError::UnknownCode
}

/// How many kinds of fault there are.
pub const FAULT_KINDS: usize = 24;

codes! {
    /// The answer to a command (telemetry `Ack`): accepted, or why not.
    pub enum Status {
        /// Accepted.
        Accepted = 0,
        /// Unknown scheme kind.
        BadScheme = 1,
        /// Rate out of (0, 200] deg/s or not finite.
        BadRate = 2,
        /// Turns 0, or positions other than 2 / 4.
        BadCount = 3,
        /// Unknown command or malformed frame.
        Malformed = 4,
        /// A GNSS fix out of range: latitude beyond +-90 deg, longitude
        /// beyond +-180 deg, a position sigma zero (a velocity sigma of
        /// zero is a position-only fix).
        BadFix = 5,
        /// A GNSS fix while the board is not navigating with the aided
        /// filter (not configured for it, or still starting).
        NotAided = 6,
        /// Not available while the aided filter navigates (`Recalibrate`:
        /// the filter estimates the gyro errors itself, and a restart would
        /// lose the vehicle's position).
        Aided = 7,
        /// A site out of range: latitude beyond +-90 deg, height beyond
        /// -1 km .. 20 km.
        BadSite = 8,
        /// A base attitude out of range: roll or heading beyond +-180 deg,
        /// pitch beyond +-90 deg, or not finite.
        BadBase = 9,
        /// Taken, but the flash record could not be written (the change
        /// holds until power-off).
        NotStored = 10,
    }
    unknown => FrameError::UnknownCode
}

codes! {
    /// A calibration frame's status: accepted, the record found in flash
    /// at power-up, or why the power-up calibration was refused.
    pub enum CalStatus {
        /// Accepted.
        Accepted = 0,
        /// The table moved during the still phase.
        TableMoved = 1,
        /// The still phase was not still.
        NotStatic = 2,
        /// The base is not level, or it moves.
        NotLevelOrMoving = 3,
        /// The table did not reach its rate.
        RateNotReached = 4,
        /// The rotating phase was not a whole number of turns.
        NotAWholeTurn = 5,
        /// Too few samples.
        NotEnoughData = 6,
        /// The solution is degenerate or implausible.
        Degenerate = 7,
        /// Non-finite data.
        NonFinite = 8,
        /// The record found in flash at power-up.
        Stored = 0x80,
    }
    unknown => FrameError::UnknownCode
}

codes! {
    /// A rotation scheme's kind.
    pub enum SchemeKind {
        /// The table still.
        Still = 0,
        /// Continuous rotation at a rate.
        Continuous = 1,
        /// Back and forth, whole turns each way.
        Reciprocating = 2,
        /// Stepping between 2 or 4 positions.
        Indexed = 3,
    }
    unknown => |_| FrameError::OutOfBounds(Status::BadScheme)
}

codes! {
    /// Why the board last reset (RCC_CSR on the STM32F4, read at boot).
    pub enum ResetCause {
        /// The flags said nothing (or the chip does not report them).
        Unknown = 0,
        /// Power-on or power-down reset.
        PowerOn = 1,
        /// The reset pin.
        Pin = 2,
        /// A software reset (`SYSRESETREQ`, e.g. a debugger).
        Software = 3,
        /// The independent watchdog.
        IndependentWatchdog = 4,
        /// The window watchdog.
        WindowWatchdog = 5,
        /// Low-power management.
        LowPower = 6,
        /// Brown-out.
        BrownOut = 7,
    }
    unknown => FrameError::UnknownCode
}

impl ResetCause {
    /// From RCC_CSR's flags (RM0090 6.3.21: bit 31 LPWRRSTF, 30 WWDGRSTF,
    /// 29 IWDGRSTF, 28 SFTRSTF, 27 PORRSTF, 26 PINRSTF, 25 BORRSTF). A
    /// power-on sets PIN and BOR too, a watchdog PIN: the most specific
    /// flag wins.
    pub fn from_rcc_csr(csr: u32) -> Self {
        let bit = |n: u32| csr & (1 << n) != 0;
        if bit(29) {
            Self::IndependentWatchdog
        } else if bit(30) {
            Self::WindowWatchdog
        } else if bit(31) {
            Self::LowPower
        } else if bit(28) {
            Self::Software
        } else if bit(27) {
            Self::PowerOn
        } else if bit(25) {
            Self::BrownOut
        } else if bit(26) {
            Self::Pin
        } else {
            Self::Unknown
        }
    }
}

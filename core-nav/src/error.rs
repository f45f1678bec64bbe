//! Errors of the navigation core: values, never panics.

/// What can go wrong in a navigation step or an initialisation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NavError {
    /// A sample holds NaN or infinity; the step was not taken.
    NonFiniteSample,
    /// The sample's time stamp is not after the previous one (µs).
    TimeNotIncreasing {
        /// Previous time stamp, µs.
        prev_us: u64,
        /// Offending time stamp, µs.
        t_us: u64,
    },
    /// The gap between two samples exceeds the configured maximum (µs).
    GapTooLong {
        /// The gap, µs.
        dt_us: u64,
        /// The configured maximum, µs.
        max_us: u64,
    },
    /// Latitude within 0.1 deg of a pole: the NED mechanization is singular.
    PolarRegion,
    /// Too few samples for the requested operation.
    NotEnoughSamples,
    /// Accelerometer mean too far from 1 g to level from (the base moves or
    /// the sensor is broken): `|f| / g` is outside `[0.9, 1.1]`.
    NotStatic,
    /// No encoder sample yet, or the requested time is too far outside the
    /// encoder samples to interpolate.
    NoEncoderData,
    /// A rotation scheme with a zero or too-high rate, zero turns, an
    /// unsupported position count or a negative dwell.
    BadScheme,
}

impl core::fmt::Display for NavError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NonFiniteSample => write!(f, "IMU sample is not finite (NaN or infinity)"),
            Self::TimeNotIncreasing { prev_us, t_us } => {
                write!(f, "time stamp {t_us} us is not after {prev_us} us")
            }
            Self::GapTooLong { dt_us, max_us } => {
                write!(f, "gap of {dt_us} us between samples exceeds {max_us} us")
            }
            Self::PolarRegion => write!(f, "latitude too close to a pole for NED navigation"),
            Self::NotEnoughSamples => write!(f, "not enough samples"),
            Self::NotStatic => write!(f, "accelerometers do not read 1 g: not static"),
            Self::NoEncoderData => write!(f, "no encoder angle available for this time"),
            Self::BadScheme => write!(
                f,
                "rotation scheme out of range (rate, turns, positions or dwell)"
            ),
        }
    }
}

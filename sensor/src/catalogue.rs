//! The effect catalogue: the diagnose-v1 effect ids (`shared/spec/
//! diagnose-v1.md`) and each one's physically possible size, the one list
//! the simulator's `--effect` knobs, diagnose's candidates and the blind
//! study are all keyed by. It lives with the sensor model because its
//! bounds are the sensor's and the rig's physics (datasheet figures), not
//! the simulator's. A new id added here is a compile error in every
//! `match` that must handle it.

use core::fmt;

/// An effect id of diagnose-v1: physics a nominal model leaves out.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum EffectId {
    /// The earth's rotation (rad/s) the nominal model may leave out.
    EarthRate,
    /// Gyro bias proportional to specific force (rad/s per m/s^2).
    GyroGSensitivity,
    /// Gyro rate-squared scale term (1/(rad/s)).
    GyroScaleNonlinearity,
    /// Gyro scale for positive minus negative rates (1).
    GyroScaleAsymmetry,
    /// IMU origin off the table axis (m).
    LeverArm,
    /// Table axis tilted from its nominal direction (rad).
    AxisTilt,
    /// IMU samples late relative to their stamps (s).
    TimeOffset,
    /// Bias with temperature, or a warm-up (rad/s per degC).
    TemperatureBias,
    /// A wandering (Gauss-Markov) bias (rad/s).
    BiasInstability,
    /// Once-per-revolution encoder error (rad).
    EncoderError,
    /// Accelerometer rate-squared scale term (1/(m/s^2)).
    AccelScaleNonlinearity,
    /// The sensor's mount wobbling with the table angle (a bent shaft, a
    /// bearing): a small rotation of the sensor on the platform that
    /// repeats each revolution (rad): cross-axis gyro signals in proportion
    /// to the table rate and accelerometer ones locked to the angle.
    TableAngleHarmonic,
    /// Table motion between encoder reads that the encoder track cannot
    /// follow and the IMU's samples alias (a stepper's steps, cogging): rate
    /// noise on the table-axis gyro while the table turns, not the
    /// sensor's, with an angle too small for the encoder to show
    /// (rad/sqrt(s), the density of that rate noise).
    UntrackedTableMotion,
}

impl EffectId {
    /// Every id, in the spec's order.
    pub const ALL: [EffectId; 13] = [
        EffectId::EarthRate,
        EffectId::GyroGSensitivity,
        EffectId::GyroScaleNonlinearity,
        EffectId::GyroScaleAsymmetry,
        EffectId::LeverArm,
        EffectId::AxisTilt,
        EffectId::TimeOffset,
        EffectId::TemperatureBias,
        EffectId::BiasInstability,
        EffectId::EncoderError,
        EffectId::AccelScaleNonlinearity,
        EffectId::TableAngleHarmonic,
        EffectId::UntrackedTableMotion,
    ];

    /// The id as the spec and the JSON write it.
    pub const fn as_str(self) -> &'static str {
        match self {
            EffectId::EarthRate => "earth_rate",
            EffectId::GyroGSensitivity => "gyro_g_sensitivity",
            EffectId::GyroScaleNonlinearity => "gyro_scale_nonlinearity",
            EffectId::GyroScaleAsymmetry => "gyro_scale_asymmetry",
            EffectId::LeverArm => "lever_arm",
            EffectId::AxisTilt => "axis_tilt",
            EffectId::TimeOffset => "time_offset",
            EffectId::TemperatureBias => "temperature_bias",
            EffectId::BiasInstability => "bias_instability",
            EffectId::EncoderError => "encoder_error",
            EffectId::AccelScaleNonlinearity => "accel_scale_nonlinearity",
            EffectId::TableAngleHarmonic => "table_angle_harmonic",
            EffectId::UntrackedTableMotion => "untracked_table_motion",
        }
    }

    /// The id named `s`, if any.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|e| e.as_str() == s)
    }

    /// The physically possible size of the effect as its simulator knob
    /// and the study state it (the knob's unit; the earth rate as the rate
    /// more than the earth's); `None` for a noise term.
    pub const fn bound(self) -> Option<Bound> {
        Some(match self {
            EffectId::EarthRate => bound::EARTH_RATE,
            EffectId::GyroGSensitivity => bound::GYRO_G_SENSITIVITY,
            EffectId::GyroScaleNonlinearity => bound::GYRO_K2,
            EffectId::GyroScaleAsymmetry => bound::GYRO_ASYMMETRY,
            EffectId::LeverArm => bound::LEVER_ARM,
            EffectId::AxisTilt => bound::AXIS_TILT,
            EffectId::TimeOffset => bound::TIME_OFFSET,
            EffectId::TemperatureBias => bound::TEMP_GYRO,
            EffectId::EncoderError => bound::ENCODER,
            EffectId::AccelScaleNonlinearity => bound::ACCEL_K2,
            EffectId::TableAngleHarmonic => bound::TABLE_HARMONIC,
            EffectId::BiasInstability | EffectId::UntrackedTableMotion => return None,
        })
    }

    /// A deterministic effect with parameters a model can state
    /// (`bias_instability` and `untracked_table_motion` are noise: they
    /// have none).
    pub const fn is_deterministic(self) -> bool {
        !matches!(
            self,
            EffectId::BiasInstability | EffectId::UntrackedTableMotion
        )
    }

    /// A noise term: found from the residual's statistics, not fitted as
    /// a regressor (the complement of [`Self::is_deterministic`]).
    pub const fn is_noise(self) -> bool {
        !self.is_deterministic()
    }
}

/// The physically possible size of one parameter of an effect: a fitted
/// value beyond it is not that physics (a mislabelled frame, a signal of
/// another kind, a regressor that is numerically zero), whatever the fit
/// says. Figures from physics and datasheets, each with its source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bound {
    /// Largest possible magnitude, in `unit`.
    pub max_abs: f64,
    /// The parameter's SI unit.
    pub unit: &'static str,
    /// Where the figure comes from.
    pub source: &'static str,
}

/// The bounds, one per kind of parameter diagnose fits.
pub mod bound {
    use super::Bound;
    use core_nav::earth::EARTH_RATE_RADPS;

    const DEG: f64 = core::f64::consts::PI / 180.0;
    use crate::spec::G0;

    /// Earth rate more (or less) than the model has: at most the whole
    /// earth rate either way (the model left it out, or has it with the
    /// wrong sign through a base labelled 180 deg off).
    pub const EARTH_RATE: Bound = Bound {
        max_abs: 2.0 * EARTH_RATE_RADPS,
        unit: "rad/s",
        source: "twice WGS-84 Omega_e: the model's own earth rate counted wrong at most once over",
    };
    /// Gyro g-sensitivity, each of the nine entries.
    pub const GYRO_G_SENSITIVITY: Bound = Bound {
        max_abs: 1.0 * DEG / G0,
        unit: "rad/s per m/s^2",
        source: "1 deg/s per g: 10x the largest MEMS datasheet figure (MPU-6050 0.1 deg/s/g, ADIS16405 0.05 deg/s/g)",
    };
    /// Gyro rate-squared scale term.
    pub const GYRO_K2: Bound = Bound {
        max_abs: 0.01 / (125.0 * DEG),
        unit: "1/(rad/s)",
        source: "a bow of 1 % of full scale at the smallest MEMS full scale (125 deg/s): 5x the datasheets' nonlinearity (MPU-6050 0.2 % FS, ADIS16405 0.1 % FS)",
    };
    /// Gyro scale asymmetry (positive minus negative).
    pub const GYRO_ASYMMETRY: Bound = Bound {
        max_abs: 0.03,
        unit: "1",
        source: "the whole scale-factor tolerance of a consumer MEMS gyro (MPU-6050 +-3 %)",
    };
    /// Lever arm, each component.
    pub const LEVER_ARM: Bound = Bound {
        max_abs: 1.0,
        unit: "m",
        source: "an IMU on a bench turntable sits within 1 m of its axis",
    };
    /// Axis tilt about each normal.
    pub const AXIS_TILT: Bound = Bound {
        max_abs: 10.0 * DEG,
        unit: "rad",
        source: "a base or table axis 10 deg from its label is a mislabelled frame, not a tilt",
    };
    /// Time offset between the IMU and the encoder, per triad.
    pub const TIME_OFFSET: Bound = Bound {
        max_abs: 1.0,
        unit: "s",
        source: "an offset over 1 s is a wrong time base: 100 samples at 100 Hz",
    };
    /// Gyro bias temperature coefficient.
    pub const TEMP_GYRO: Bound = Bound {
        max_abs: 0.5 * DEG,
        unit: "rad/s per degC",
        source:
            "3x the MPU-6050's zero-rate change (+-20 deg/s over -40..85 degC, 0.16 deg/s/degC)",
    };
    /// Accelerometer bias temperature coefficient.
    pub const TEMP_ACCEL: Bound = Bound {
        max_abs: 5e-3 * G0,
        unit: "m/s^2 per degC",
        source: "5 mg/degC: 10x the MPU-6050's zero-g change (+-60 mg over -40..85 degC)",
    };
    /// A gyro warm-up's total change.
    pub const WARMUP_GYRO: Bound = Bound {
        max_abs: 20.0 * DEG,
        unit: "rad/s",
        source:
            "the whole turn-on zero-rate tolerance of a consumer MEMS gyro (MPU-6050 +-20 deg/s)",
    };
    /// Once-per-revolution encoder error amplitude (each quadrature part).
    pub const ENCODER: Bound = Bound {
        max_abs: 0.05,
        unit: "rad",
        source: "3 deg: an optical disc 0.5 mm off centre at a 10 mm code radius",
    };
    /// Accelerometer specific-force-squared term.
    pub const ACCEL_K2: Bound = Bound {
        max_abs: 0.01 / (2.0 * G0),
        unit: "1/(m/s^2)",
        source: "a bow of 1 % of full scale at the smallest MEMS full scale (2 g): 2x the MPU-6050's 0.5 % FS",
    };
    /// The sensor's mount wobbling with the table angle, each harmonic
    /// part of the small rotation.
    pub const TABLE_HARMONIC: Bound = Bound {
        max_abs: 0.05,
        unit: "rad",
        source: "3 deg: a mount that rocks further on its shaft is loose, not misaligned",
    };
}

impl fmt::Display for EffectId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl PartialEq<&str> for EffectId {
    fn eq(&self, other: &&str) -> bool {
        self.as_str() == *other
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_id_round_trips() {
        for e in EffectId::ALL {
            assert_eq!(EffectId::parse(e.as_str()), Some(e));
        }
        assert_eq!(EffectId::parse("nope"), None);
    }
}

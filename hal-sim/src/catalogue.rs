//! The effect catalogue: the diagnose-v1 effect ids (`shared/spec/
//! diagnose-v1.md`), the one list the simulator's `--effect` knobs, diagnose's
//! candidates and the blind study are all keyed by. A new id added here is a
//! compile error in every `match` that must handle it.

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
}

impl EffectId {
    /// Every id, in the spec's order.
    pub const ALL: [EffectId; 11] = [
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
        }
    }

    /// The id named `s`, if any.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|e| e.as_str() == s)
    }

    /// A deterministic effect with parameters a model can state
    /// (`bias_instability` is noise: it has none).
    pub const fn is_deterministic(self) -> bool {
        !matches!(self, EffectId::BiasInstability)
    }
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
    fn every_id_round_trips_and_has_a_simulator_knob() {
        for e in EffectId::ALL {
            assert_eq!(EffectId::parse(e.as_str()), Some(e));
            assert!(
                crate::sim::EFFECTS.iter().any(|k| k.name == e.as_str()),
                "{e}: no --effect knob"
            );
        }
        assert_eq!(EffectId::parse("nope"), None);
    }
}

//! The units a person reads: the book's units table (`docs/src/formats.md`,
//! "Units") as factors from SI. Files and computations stay SI; every tool
//! that prints or plots a rate, a force or a noise density converts with
//! these, so that one quantity has one unit everywhere.

/// Degrees per radian.
pub const DEG_PER_RAD: f64 = 180.0 / core::f64::consts::PI;
/// deg/h per rad/s (gyro bias, instability, rate error, Allan deviation).
pub const DPH_PER_RADPS: f64 = DEG_PER_RAD * 3600.0;
/// deg/sqrt(h) per rad/sqrt(s), i.e. per rad/s/sqrt(Hz) (angle random
/// walk): sqrt(3600 s/h) = 60.
pub const DEG_SQRTH_PER_RAD_SQRTS: f64 = DEG_PER_RAD * 60.0;
/// Standard gravity, m/s^2: the g of ug and of "per g".
pub const G0_MPS2: f64 = 9.806_65;
/// ug per m/s^2 (accelerometer bias, instability, Allan deviation; and,
/// per sqrt(Hz), velocity random walk).
pub const UG_PER_MPS2: f64 = 1e6 / G0_MPS2;

/// A gyro's (`gyro`) or an accelerometer's level (bias, instability,
/// Allan deviation) in the printed unit: (factor from SI, unit).
pub const fn level(gyro: bool) -> (f64, &'static str) {
    if gyro {
        (DPH_PER_RADPS, "deg/h")
    } else {
        (UG_PER_MPS2, "ug")
    }
}

/// A gyro's or an accelerometer's white-noise density in the printed unit:
/// (factor from SI, unit): deg/sqrt(h) and ug/sqrt(Hz).
pub const fn density(gyro: bool) -> (f64, &'static str) {
    if gyro {
        (DEG_SQRTH_PER_RAD_SQRTS, "deg/sqrt(h)")
    } else {
        (UG_PER_MPS2, "ug/sqrt(Hz)")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_against_hand_values() {
        // 1 deg/h = 4.848e-6 rad/s; 1 g = 1e6 ug; 1 deg/sqrt(h) = 2.909e-4
        // rad/sqrt(s) (Groves, Table 4.x units); tolerances: the printed digits.
        assert!((1.0 / DPH_PER_RADPS - 4.848_137e-6).abs() < 1e-12);
        assert!((G0_MPS2 * UG_PER_MPS2 - 1e6).abs() < 1e-6);
        assert!((1.0 / DEG_SQRTH_PER_RAD_SQRTS - 2.908_882e-4).abs() < 1e-10);
    }
}

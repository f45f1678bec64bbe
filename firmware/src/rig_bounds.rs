//! The rig file's model (`sensors/rig.toml`: the table's encoder, motor,
//! PWM and the IMU's SPI clock) and its bounds. Plain Rust with no
//! dependency: `build.rs` includes this file to check the rig before it
//! writes the board's constants (`crate::rig`), and the host tests call
//! the same checks.

/// APB2's clock on the board (SPI1), Hz: SYSCLK 168 MHz / 2.
pub const APB2_HZ: u32 = 84_000_000;
/// TIM10's clock on the board (APB2's timers run at twice APB2), Hz.
pub const TIM10_HZ: u32 = 168_000_000;
/// The ICM-42688-P's fastest SPI clock, Hz (its datasheet: 24 MHz).
pub const IMU_SPI_MAX_HZ: u32 = 24_000_000;
/// The encoder's counter is read every this long, µs (the tick's
/// `encoder_every` samples at 1 kHz).
pub const ENCODER_READ_US: u32 = 20_000;
/// The table's fastest rate and acceleration the firmware allows, rad/s
/// and rad/s^2 (`core_nav::scheme::Limits::default`: 200 deg/s, 100
/// deg/s^2).
pub const TABLE_LIMITS: (f64, f64) = (3.490_658_503_988_659, 1.745_329_251_994_329_5);

/// The table, as its builder describes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rig {
    /// Quadrature counts per turn of the table.
    pub counts_per_rev: u32,
    /// Inertia about the table's axis, kg m^2.
    pub inertia_kg_m2: f64,
    /// Torque constant, N m/A.
    pub kt_nm_per_a: f64,
    /// Winding resistance, ohm.
    pub resistance_ohm: f64,
    /// The driver's supply, V.
    pub supply_v: f64,
    /// Viscous friction, N m s/rad.
    pub viscous_nm_s_per_rad: f64,
    /// Coulomb friction, N m.
    pub coulomb_nm: f64,
    /// The motor's PWM frequency, Hz.
    pub pwm_hz: u32,
    /// The IMU's SPI clock at most, Hz.
    pub spi_max_hz: u32,
}

/// The SPI clock the board runs for `max_hz`: the fastest `pclk_hz / 2^k`
/// (k 1-8, SPI_CR1's BR) at or below it, with its divisor; `None` when
/// even /256 is above it. (stm32f4xx-hal 0.23 rounds the other way: asked
/// 8 MHz it runs 84 / 8 = 10.5 MHz; given exactly a divided clock, it
/// picks that divisor.)
pub const fn spi_clock(pclk_hz: u32, max_hz: u32) -> Option<(u32, u32)> {
    let mut div = 2;
    while div <= 256 {
        if pclk_hz / div <= max_hz {
            return Some((div, pclk_hz / div));
        }
        div *= 2;
    }
    None
}

/// A rig value out of its bounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RigError(pub &'static str);

fn positive(x: f64) -> bool {
    x.is_finite() && x > 0.0
}

impl Rig {
    /// The motor's torque at `rate` rad/s with the full supply, N m.
    pub fn torque_at(&self, rate: f64) -> f64 {
        (self.supply_v - self.kt_nm_per_a * rate) * self.kt_nm_per_a / self.resistance_ohm
    }

    /// Checks every value against what the board and its firmware can do.
    ///
    /// # Errors
    /// The first value out of its bounds, and why.
    pub fn check(&self) -> Result<(), RigError> {
        let (rate, accel) = TABLE_LIMITS;
        let cpr = f64::from(self.counts_per_rev);
        if self.counts_per_rev < 1_000 {
            return Err(RigError("encoder.counts_per_rev under 1,000: the rate loop's 1 kHz rate would be quantised to more than 0.36 deg/s a count in 20 ms"));
        }
        if cpr * rate / core::f64::consts::TAU * f64::from(ENCODER_READ_US) * 1e-6 >= 32_768.0 {
            return Err(RigError("encoder.counts_per_rev too large: at 200 deg/s the 16-bit counter moves half a turn of itself between 20 ms reads"));
        }
        let motor = [
            self.inertia_kg_m2,
            self.kt_nm_per_a,
            self.resistance_ohm,
            self.supply_v,
        ];
        if !motor.iter().all(|x| positive(*x)) {
            return Err(RigError(
                "motor: inertia, kt, resistance and supply must be positive and finite",
            ));
        }
        let friction = [self.viscous_nm_s_per_rad, self.coulomb_nm];
        if !friction.iter().all(|x| x.is_finite() && *x >= 0.0) {
            return Err(RigError("motor: friction must be finite and not negative"));
        }
        let need = self.inertia_kg_m2 * accel + self.coulomb_nm + self.viscous_nm_s_per_rad * rate;
        if self.torque_at(rate) < 2.0 * need {
            return Err(RigError("motor: at 200 deg/s it gives less than twice the torque the table needs at 100 deg/s^2 with its friction"));
        }
        if self.pwm_hz < 1_000 || self.pwm_hz > 100_000 {
            return Err(RigError("pwm.hz outside 1-100 kHz"));
        }
        if TIM10_HZ / self.pwm_hz < 256 {
            return Err(RigError(
                "pwm.hz too high: fewer than 256 duty steps from TIM10's 168 MHz",
            ));
        }
        if self.spi_max_hz > IMU_SPI_MAX_HZ {
            return Err(RigError("imu_spi.max_hz above the ICM-42688-P's 24 MHz"));
        }
        if spi_clock(APB2_HZ, self.spi_max_hz).is_none() {
            return Err(RigError("imu_spi.max_hz under 84 MHz / 256"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spi_clock_is_never_above_what_is_asked() {
        // The HAL asked 8 MHz ran 84 / 8 = 10.5 MHz; here 5.25 MHz.
        assert_eq!(spi_clock(APB2_HZ, 8_000_000), Some((16, 5_250_000)));
        assert_eq!(spi_clock(APB2_HZ, 5_250_000), Some((16, 5_250_000)));
        assert_eq!(spi_clock(APB2_HZ, 5_000_000), Some((32, 2_625_000)));
        assert_eq!(spi_clock(APB2_HZ, 42_000_000), Some((2, 42_000_000)));
        assert_eq!(spi_clock(APB2_HZ, 300_000), None);
        // Each divided clock, asked again, is itself (the HAL's rounding
        // takes a power of two exactly: 84 MHz / f = the divisor).
        for k in 1..=8 {
            let f = APB2_HZ >> k;
            assert_eq!(spi_clock(APB2_HZ, f), Some((1 << k, f)));
        }
    }

    #[test]
    fn the_shipped_rig_passes_and_bad_values_are_refused() {
        assert_eq!(crate::rig::RIG.check(), Ok(()));
        let good = crate::rig::RIG;
        let bad = [
            Rig {
                counts_per_rev: 500,
                ..good
            },
            Rig {
                counts_per_rev: 6_000_000,
                ..good
            },
            Rig {
                kt_nm_per_a: f64::NAN,
                ..good
            },
            // 0.3 V: 6 mN m at 200 deg/s against the 9 mN m the table needs.
            Rig {
                supply_v: 0.3,
                ..good
            },
            Rig {
                coulomb_nm: -1.0,
                ..good
            },
            Rig {
                pwm_hz: 700_000,
                ..good
            },
            Rig {
                spi_max_hz: 30_000_000,
                ..good
            },
        ];
        for r in bad {
            assert!(r.check().is_err(), "{r:?}");
        }
    }
}

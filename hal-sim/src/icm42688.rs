//! Register-level model of the TDK InvenSense ICM-42688-P, written from its
//! datasheet (DS-000347 rev. 1.8): Sec. 14 (register map, user bank 0),
//! Sec. 8.1 (SPI: R/W bit 7, auto-increment), Sec. 12.8 (soft reset),
//! Sec. 14.x register descriptions cited by name below.
//!
//! Modelled: WHO_AM_I (0x47), DEVICE_CONFIG soft reset (1 ms), PWR_MGMT0
//! sensor modes, GYRO_CONFIG0 / ACCEL_CONFIG0 full scale and ODR, data
//! registers (16-bit two's complement, big-endian unless INTF_CONFIG0 says
//! little; 0x8000 while a sensor is off or starting), TEMP_DATA
//! (`T = raw / 132.48 + 25`), INT_STATUS DATA_RDY (cleared on read),
//! the INT1 pin (polarity, pulsed 100 us or latched, routed by INT_SOURCE0),
//! REG_BANK_SEL (other banks store bytes only).

/// Register addresses (bank 0).
pub mod reg {
    /// DEVICE_CONFIG: bit 0 SOFT_RESET_CONFIG.
    pub const DEVICE_CONFIG: u8 = 0x11;
    /// DRIVE_CONFIG.
    pub const DRIVE_CONFIG: u8 = 0x13;
    /// INT_CONFIG: bit 2 INT1_MODE (1 latched), bit 1 drive, bit 0 INT1_POLARITY (1 high).
    pub const INT_CONFIG: u8 = 0x14;
    /// TEMP_DATA1 (high byte), then TEMP_DATA0.
    pub const TEMP_DATA1: u8 = 0x1D;
    /// ACCEL_DATA_X1: accel x, y, z then gyro x, y, z follow, 2 bytes each.
    pub const ACCEL_DATA_X1: u8 = 0x1F;
    /// GYRO_DATA_X1.
    pub const GYRO_DATA_X1: u8 = 0x25;
    /// INT_STATUS: bit 4 RESET_DONE_INT, bit 3 DATA_RDY_INT; clear on read.
    pub const INT_STATUS: u8 = 0x2D;
    /// INTF_CONFIG0: bit 4 SENSOR_DATA_ENDIAN (1 big).
    pub const INTF_CONFIG0: u8 = 0x4C;
    /// PWR_MGMT0: bits 3:2 GYRO_MODE (11 low noise), bits 1:0 ACCEL_MODE (10 LP, 11 LN).
    pub const PWR_MGMT0: u8 = 0x4E;
    /// GYRO_CONFIG0: bits 7:5 GYRO_FS_SEL, bits 3:0 GYRO_ODR.
    pub const GYRO_CONFIG0: u8 = 0x4F;
    /// ACCEL_CONFIG0: bits 7:5 ACCEL_FS_SEL, bits 3:0 ACCEL_ODR.
    pub const ACCEL_CONFIG0: u8 = 0x50;
    /// INT_SOURCE0: bit 3 UI_DRDY_INT1_EN, bit 4 RESET_DONE_INT1_EN.
    pub const INT_SOURCE0: u8 = 0x65;
    /// WHO_AM_I.
    pub const WHO_AM_I: u8 = 0x75;
    /// REG_BANK_SEL: bits 2:0.
    pub const REG_BANK_SEL: u8 = 0x76;
}

/// WHO_AM_I value.
pub const WHO_AM_I_VALUE: u8 = 0x47;
/// Temperature sensitivity, LSB/degC (room-temperature offset 25 degC).
pub const TEMP_LSB_PER_C: f64 = 132.48;
/// Gyro sensitivity at FS_SEL = 0 (+-2000 deg/s), LSB/(deg/s); each FS_SEL
/// step halves the range and doubles it. The datasheet's table (16.4, 32.8,
/// 65.5, 131, 262, 524.3, 1048.6, 2097.2) is `32768 / full scale` rounded:
/// 524.3 and 2097.2 only fit 16.384.
pub const GYRO_LSB_PER_DPS_FS0: f64 = 32768.0 / 2000.0;
/// Accel sensitivity at FS_SEL = 0 (+-16 g), LSB/g.
pub const ACCEL_LSB_PER_G_FS0: f64 = 2048.0;
/// Soft-reset time, ns (datasheet: wait 1 ms after SOFT_RESET_CONFIG).
pub const RESET_NS: u64 = 1_000_000;
/// Gyro start-up from off, ns (datasheet Table 1: 30 ms typ).
pub const GYRO_STARTUP_NS: u64 = 30_000_000;
/// Accel start-up from off, ns (datasheet Table 2: 10 ms typ).
pub const ACCEL_STARTUP_NS: u64 = 10_000_000;
/// INT1 pulse length in pulsed mode, ns.
pub const INT_PULSE_NS: u64 = 100_000;

use crate::sensor::G0;

/// Output data rate for an ODR code, Hz (GYRO_ODR / ACCEL_ODR field).
pub fn odr_hz(code: u8) -> Option<f64> {
    Some(match code & 0x0F {
        0x01 => 32_000.0,
        0x02 => 16_000.0,
        0x03 => 8_000.0,
        0x04 => 4_000.0,
        0x05 => 2_000.0,
        0x06 => 1_000.0,
        0x07 => 200.0,
        0x08 => 100.0,
        0x09 => 50.0,
        0x0A => 25.0,
        0x0B => 12.5,
        0x0F => 500.0,
        _ => return None,
    })
}

/// Reset values of bank 0 (datasheet Sec. 14, "Reset value" column).
fn reset_bank0() -> [u8; 128] {
    let mut r = [0u8; 128];
    r[reg::DRIVE_CONFIG as usize] = 0x05;
    for a in reg::TEMP_DATA1..=0x2A {
        // Data registers: 0x80 high, 0x00 low (-32768: no data).
        r[a as usize] = if (a - reg::TEMP_DATA1).is_multiple_of(2) {
            0x80
        } else {
            0x00
        };
    }
    r[reg::INT_STATUS as usize] = 0x10;
    r[reg::INTF_CONFIG0 as usize] = 0x30;
    r[reg::GYRO_CONFIG0 as usize] = 0x06;
    r[reg::ACCEL_CONFIG0 as usize] = 0x06;
    r[0x51] = 0x16; // GYRO_CONFIG1
    r[0x52] = 0x11; // GYRO_ACCEL_CONFIG0
    r[0x53] = 0x0D; // ACCEL_CONFIG1
    r[0x64] = 0x10; // INT_CONFIG1
    r[reg::INT_SOURCE0 as usize] = 0x10;
    r[reg::WHO_AM_I as usize] = WHO_AM_I_VALUE;
    r
}

/// Faults the chip can be made to show.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ChipFaults {
    /// Every SPI transaction fails while set.
    pub spi_error: bool,
    /// Data registers stop updating (a hung sensor).
    pub stuck: bool,
    /// Data registers read full scale.
    pub saturated: bool,
    /// WHO_AM_I reads this instead (a wrong or dead chip).
    pub who_am_i: Option<u8>,
}

/// The chip's state.
#[derive(Clone, Debug)]
pub struct Icm42688 {
    bank0: [u8; 128],
    other_banks: [[u8; 128]; 4],
    /// Time of the last soft reset or power-on, ns.
    reset_at_ns: u64,
    gyro_on_at_ns: Option<u64>,
    accel_on_at_ns: Option<u64>,
    /// Time of the last data-ready event, ns.
    last_drdy_ns: Option<u64>,
    /// Latched INT1 state (latched mode).
    int_latched: bool,
    /// Faults.
    pub faults: ChipFaults,
}

impl Default for Icm42688 {
    fn default() -> Self {
        Self::new()
    }
}

impl Icm42688 {
    /// A chip just powered on (as after a reset at t = 0).
    pub fn new() -> Self {
        Self {
            bank0: reset_bank0(),
            other_banks: [[0; 128]; 4],
            reset_at_ns: 0,
            gyro_on_at_ns: None,
            accel_on_at_ns: None,
            last_drdy_ns: None,
            int_latched: false,
            faults: ChipFaults::default(),
        }
    }

    fn bank(&self) -> u8 {
        self.bank0[reg::REG_BANK_SEL as usize] & 0x07
    }

    /// The gyro output data rate, Hz, when the gyro is on and its ODR valid.
    pub fn gyro_odr_hz(&self) -> Option<f64> {
        if (self.bank0[reg::PWR_MGMT0 as usize] >> 2) & 0x03 == 0x03 {
            odr_hz(self.bank0[reg::GYRO_CONFIG0 as usize])
        } else {
            None
        }
    }

    /// The accel output data rate, Hz, when the accelerometer is on.
    pub fn accel_odr_hz(&self) -> Option<f64> {
        if self.bank0[reg::PWR_MGMT0 as usize] & 0x03 >= 0x02 {
            odr_hz(self.bank0[reg::ACCEL_CONFIG0 as usize])
        } else {
            None
        }
    }

    /// The sample rate at which new data arrives (the faster sensor's ODR), Hz.
    pub fn data_rate_hz(&self) -> Option<f64> {
        match (self.gyro_odr_hz(), self.accel_odr_hz()) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        }
    }

    /// Gyro full scale, deg/s.
    pub fn gyro_full_scale_dps(&self) -> f64 {
        2000.0 / f64::from(1u32 << (self.bank0[reg::GYRO_CONFIG0 as usize] >> 5))
    }

    /// Accel full scale, g.
    pub fn accel_full_scale_g(&self) -> f64 {
        16.0 / f64::from(1u32 << ((self.bank0[reg::ACCEL_CONFIG0 as usize] >> 5) & 0x03))
    }

    fn in_reset(&self, now_ns: u64) -> bool {
        now_ns < self.reset_at_ns + RESET_NS
    }

    fn put16(&mut self, addr: u8, v: i16) {
        let big = self.bank0[reg::INTF_CONFIG0 as usize] & 0x10 != 0;
        let [hi, lo] = v.to_be_bytes();
        let (a, b) = if big { (hi, lo) } else { (lo, hi) };
        self.bank0[addr as usize] = a;
        self.bank0[addr as usize + 1] = b;
    }

    /// A new sample from the sensing element at `now_ns`: rate `w_dps`
    /// (deg/s), specific force `f_g` (g), temperature (degC), all in the
    /// chip's axes. Quantises, saturates and stores it per the current
    /// configuration; raises DATA_RDY.
    pub fn new_sample(&mut self, now_ns: u64, w_dps: [f64; 3], f_g: [f64; 3], temp_c: f64) {
        if self.in_reset(now_ns) || self.faults.stuck {
            return;
        }
        let gyro_ready = self.gyro_odr_hz().is_some()
            && self
                .gyro_on_at_ns
                .is_some_and(|t| now_ns >= t + GYRO_STARTUP_NS);
        let accel_ready = self.accel_odr_hz().is_some()
            && self
                .accel_on_at_ns
                .is_some_and(|t| now_ns >= t + ACCEL_STARTUP_NS);
        let sat = self.faults.saturated;
        let to_lsb = |x: f64, lsb_per_unit: f64| -> i16 {
            if sat {
                return i16::MAX;
            }
            (x * lsb_per_unit).round().clamp(-32768.0, 32767.0) as i16
        };
        let g_lsb = GYRO_LSB_PER_DPS_FS0 * 2000.0 / self.gyro_full_scale_dps();
        let a_lsb = ACCEL_LSB_PER_G_FS0 * 16.0 / self.accel_full_scale_g();
        for i in 0..3 {
            let ga = reg::GYRO_DATA_X1 + 2 * i as u8;
            let aa = reg::ACCEL_DATA_X1 + 2 * i as u8;
            self.put16(
                ga,
                if gyro_ready {
                    to_lsb(w_dps[i], g_lsb)
                } else {
                    i16::MIN
                },
            );
            self.put16(
                aa,
                if accel_ready {
                    to_lsb(f_g[i], a_lsb)
                } else {
                    i16::MIN
                },
            );
        }
        let t = ((temp_c - 25.0) * TEMP_LSB_PER_C)
            .round()
            .clamp(-32768.0, 32767.0) as i16;
        self.put16(reg::TEMP_DATA1, t);
        if gyro_ready || accel_ready {
            self.bank0[reg::INT_STATUS as usize] |= 0x08;
            self.last_drdy_ns = Some(now_ns);
            if self.bank0[reg::INT_CONFIG as usize] & 0x04 != 0 {
                self.int_latched = true;
            }
        }
    }

    /// Level of the INT1 pin at `now_ns` (true = high).
    pub fn int1_high(&self, now_ns: u64) -> bool {
        let routed = self.bank0[reg::INT_SOURCE0 as usize] & 0x08 != 0;
        let active = routed
            && if self.bank0[reg::INT_CONFIG as usize] & 0x04 != 0 {
                self.int_latched
            } else {
                self.last_drdy_ns
                    .is_some_and(|t| now_ns >= t && now_ns < t + INT_PULSE_NS)
            };
        let active_high = self.bank0[reg::INT_CONFIG as usize] & 0x01 != 0;
        active == active_high
    }

    /// Reads register `addr` (current bank) at `now_ns`, with side effects
    /// (INT_STATUS clears).
    pub fn read(&mut self, addr: u8, now_ns: u64) -> u8 {
        let addr = addr & 0x7F;
        if self.in_reset(now_ns) {
            return 0x00;
        }
        if self.bank() != 0 {
            let b = self.bank() as usize - 1;
            return self.other_banks.get(b).map_or(0, |r| r[addr as usize]);
        }
        match addr {
            reg::WHO_AM_I => self.faults.who_am_i.unwrap_or(WHO_AM_I_VALUE),
            reg::INT_STATUS => {
                let v = self.bank0[addr as usize];
                self.bank0[addr as usize] = 0;
                self.int_latched = false;
                v
            }
            _ => self.bank0[addr as usize],
        }
    }

    /// Writes register `addr` (current bank) at `now_ns`. Read-only
    /// registers ignore writes.
    pub fn write(&mut self, addr: u8, value: u8, now_ns: u64) {
        let addr = addr & 0x7F;
        if self.in_reset(now_ns) {
            return;
        }
        if addr == reg::REG_BANK_SEL {
            self.bank0[addr as usize] = value & 0x07;
            return;
        }
        if self.bank() != 0 {
            let b = self.bank() as usize - 1;
            if let Some(r) = self.other_banks.get_mut(b) {
                r[addr as usize] = value;
            }
            return;
        }
        match addr {
            reg::DEVICE_CONFIG => {
                if value & 0x01 != 0 {
                    let faults = self.faults;
                    *self = Self::new();
                    self.faults = faults;
                    self.reset_at_ns = now_ns;
                } else {
                    self.bank0[addr as usize] = value;
                }
            }
            reg::TEMP_DATA1..=0x2A | reg::INT_STATUS | reg::WHO_AM_I => {}
            reg::PWR_MGMT0 => {
                let old = self.bank0[addr as usize];
                let gyro_on = |v: u8| (v >> 2) & 0x03 == 0x03;
                let accel_on = |v: u8| v & 0x03 >= 0x02;
                if gyro_on(value) && !gyro_on(old) {
                    self.gyro_on_at_ns = Some(now_ns);
                } else if !gyro_on(value) {
                    self.gyro_on_at_ns = None;
                }
                if accel_on(value) && !accel_on(old) {
                    self.accel_on_at_ns = Some(now_ns);
                } else if !accel_on(value) {
                    self.accel_on_at_ns = None;
                }
                self.bank0[addr as usize] = value;
            }
            _ => self.bank0[addr as usize] = value,
        }
    }

    /// Converts a chip-axes sample in SI (rad/s, m/s^2) for [`Self::new_sample`].
    pub fn si_to_chip(w: [f64; 3], f: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        (w.map(f64::to_degrees), f.map(|x| x / G0))
    }
}

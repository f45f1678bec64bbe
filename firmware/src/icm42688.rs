//! Driver for the TDK InvenSense ICM-42688-P over SPI (datasheet DS-000347:
//! Sec. 8.1 SPI, Sec. 14 register map). Generic over
//! `embedded_hal::spi::SpiDevice`; one typed register per datasheet register
//! used; errors as values (`Error<CommE>`).

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{Operation, SpiDevice};

/// Register addresses (user bank 0).
pub mod reg {
    /// DEVICE_CONFIG (bit 0: soft reset).
    pub const DEVICE_CONFIG: u8 = 0x11;
    /// INT_CONFIG (bit 2: latched, bit 1: push-pull, bit 0: active high).
    pub const INT_CONFIG: u8 = 0x14;
    /// INT_CONFIG1 (bit 6: 8 us pulses, bit 5: no de-assert minimum, bit
    /// 4: INT_ASYNC_RESET, which the datasheet asks to clear).
    pub const INT_CONFIG1: u8 = 0x64;
    /// TEMP_DATA1: start of the 14-byte burst (temp, accel xyz, gyro xyz).
    pub const TEMP_DATA1: u8 = 0x1D;
    /// INT_STATUS (bit 3: DATA_RDY; clears on read).
    pub const INT_STATUS: u8 = 0x2D;
    /// INTF_CONFIG0 (bit 4: big-endian sensor data).
    pub const INTF_CONFIG0: u8 = 0x4C;
    /// PWR_MGMT0 (bits 3:2 gyro mode, 1:0 accel mode).
    pub const PWR_MGMT0: u8 = 0x4E;
    /// GYRO_CONFIG0 (bits 7:5 full scale, 3:0 ODR).
    pub const GYRO_CONFIG0: u8 = 0x4F;
    /// ACCEL_CONFIG0 (bits 7:5 full scale, 3:0 ODR).
    pub const ACCEL_CONFIG0: u8 = 0x50;
    /// INT_SOURCE0 (bit 3: data ready to INT1).
    pub const INT_SOURCE0: u8 = 0x65;
    /// WHO_AM_I.
    pub const WHO_AM_I: u8 = 0x75;
    /// REG_BANK_SEL.
    pub const REG_BANK_SEL: u8 = 0x76;
}

/// The identity the chip reports.
pub const WHO_AM_I: u8 = 0x47;
const READ: u8 = 0x80;

/// What can go wrong.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error<CommE> {
    /// The bus failed.
    Comm(CommE),
    /// WHO_AM_I was not 0x47 (the value read).
    WrongDevice(u8),
}

/// Gyro full scale.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GyroFs {
    /// +-2000 deg/s.
    Dps2000 = 0,
    /// +-1000 deg/s.
    Dps1000 = 1,
    /// +-500 deg/s.
    Dps500 = 2,
    /// +-250 deg/s.
    Dps250 = 3,
}

impl GyroFs {
    /// Full scale, deg/s.
    pub fn full_scale_dps(self) -> f32 {
        2000.0 / (1u32 << self as u32) as f32
    }
}

/// Accelerometer full scale.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AccelFs {
    /// +-16 g.
    G16 = 0,
    /// +-8 g.
    G8 = 1,
    /// +-4 g.
    G4 = 2,
    /// +-2 g.
    G2 = 3,
}

impl AccelFs {
    /// Full scale, g.
    pub fn full_scale_g(self) -> f32 {
        16.0 / (1u32 << self as u32) as f32
    }
}

/// Output data rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Odr {
    /// 1 kHz.
    Hz1000 = 0x06,
    /// 200 Hz.
    Hz200 = 0x07,
    /// 100 Hz (the navigation rate).
    Hz100 = 0x08,
    /// 50 Hz.
    Hz50 = 0x09,
}

/// Configuration applied by [`Icm42688::init`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// Gyro range.
    pub gyro_fs: GyroFs,
    /// Accelerometer range.
    pub accel_fs: AccelFs,
    /// Both sensors' ODR.
    pub odr: Odr,
}

impl Default for Config {
    /// +-500 deg/s (the table turns at most 200 deg/s), +-4 g, 1 kHz (the
    /// rate loop's rate; navigation takes every tenth sample).
    fn default() -> Self {
        Self {
            gyro_fs: GyroFs::Dps500,
            accel_fs: AccelFs::G4,
            odr: Odr::Hz1000,
        }
    }
}

pub use crate::ports::{RawSample, Sample};

/// Standard gravity for the g -> m/s^2 conversion (the chip's unit), m/s^2.
const G0: f32 = 9.806_65;

/// The driver.
#[derive(Debug)]
pub struct Icm42688<SPI> {
    spi: SPI,
    config: Config,
}

impl<SPI: SpiDevice> Icm42688<SPI> {
    /// A driver on `spi` (nothing is sent until [`Self::init`]).
    pub fn new(spi: SPI) -> Self {
        Self {
            spi,
            config: Config::default(),
        }
    }

    /// Gives the bus back.
    pub fn release(self) -> SPI {
        self.spi
    }

    fn write_reg(&mut self, r: u8, v: u8) -> Result<(), Error<SPI::Error>> {
        self.spi.write(&[r & 0x7F, v]).map_err(Error::Comm)
    }

    fn read_regs(&mut self, r: u8, out: &mut [u8]) -> Result<(), Error<SPI::Error>> {
        self.spi
            .transaction(&mut [Operation::Write(&[READ | r]), Operation::Read(out)])
            .map_err(Error::Comm)
    }

    /// WHO_AM_I.
    ///
    /// # Errors
    /// The bus error.
    pub fn who_am_i(&mut self) -> Result<u8, Error<SPI::Error>> {
        let mut b = [0u8];
        self.read_regs(reg::WHO_AM_I, &mut b)?;
        Ok(b[0])
    }

    /// Resets the chip, checks its identity, configures ranges, ODR and the
    /// data-ready interrupt (INT1, push-pull, active high, a 100 us pulse a
    /// sample: an edge every sample whether or not the last INT_STATUS was
    /// read, so one missed read cannot stop the tick as a latched line
    /// would; INT_ASYNC_RESET cleared as the datasheet's INT_CONFIG1 asks
    /// for proper INT1 operation), turns both sensors on in low-noise mode and
    /// waits for the gyro to start (datasheet: 1 ms after reset, 30 ms gyro
    /// start-up; 45 ms are waited).
    ///
    /// # Errors
    /// The bus error, or [`Error::WrongDevice`].
    pub fn init(
        &mut self,
        config: Config,
        delay: &mut impl DelayNs,
    ) -> Result<(), Error<SPI::Error>> {
        self.write_reg(reg::DEVICE_CONFIG, 0x01)?;
        delay.delay_ms(2);
        let id = self.who_am_i()?;
        if id != WHO_AM_I {
            return Err(Error::WrongDevice(id));
        }
        self.write_reg(reg::REG_BANK_SEL, 0x00)?;
        self.write_reg(reg::INTF_CONFIG0, 0x30)?; // big-endian data (reset value)
        self.write_reg(reg::INT_CONFIG, 0x03)?;
        self.write_reg(reg::INT_CONFIG1, 0x00)?;
        self.write_reg(reg::INT_SOURCE0, 0x08)?;
        self.write_reg(
            reg::GYRO_CONFIG0,
            ((config.gyro_fs as u8) << 5) | config.odr as u8,
        )?;
        self.write_reg(
            reg::ACCEL_CONFIG0,
            ((config.accel_fs as u8) << 5) | config.odr as u8,
        )?;
        self.write_reg(reg::PWR_MGMT0, 0x0F)?;
        delay.delay_ms(45);
        self.config = config;
        Ok(())
    }

    /// True when a new sample is ready (reads and so clears INT_STATUS).
    ///
    /// # Errors
    /// The bus error.
    pub fn data_ready(&mut self) -> Result<bool, Error<SPI::Error>> {
        let mut b = [0u8];
        self.read_regs(reg::INT_STATUS, &mut b)?;
        Ok(b[0] & 0x08 != 0)
    }

    /// One burst read of temperature, accelerometer and gyro (14 bytes).
    ///
    /// # Errors
    /// The bus error.
    pub fn read_raw_lsb(&mut self) -> Result<RawSample, Error<SPI::Error>> {
        let mut b = [0u8; 14];
        self.read_regs(reg::TEMP_DATA1, &mut b)?;
        let w = |i: usize| {
            i16::from_be_bytes([
                b.get(2 * i).copied().unwrap_or(0),
                b.get(2 * i + 1).copied().unwrap_or(0),
            ])
        };
        Ok(RawSample {
            temp_lsb: w(0),
            accel_lsb: [w(1), w(2), w(3)],
            gyro_lsb: [w(4), w(5), w(6)],
        })
    }

    /// Converts a raw sample with the configured ranges: gyro
    /// `32768 / FS` LSB per deg/s, accel `32768 / FS` LSB per g,
    /// temperature `raw / 132.48 + 25` deg C.
    pub fn to_si(&self, r: &RawSample) -> Sample {
        let g_scale =
            self.config.gyro_fs.full_scale_dps() / 32768.0 * core::f32::consts::PI / 180.0;
        let a_scale = self.config.accel_fs.full_scale_g() / 32768.0 * G0;
        Sample {
            gyro_radps: r.gyro_lsb.map(|x| f32::from(x) * g_scale),
            accel_mps2: r.accel_lsb.map(|x| f32::from(x) * a_scale),
            temp_c: f32::from(r.temp_lsb) / 132.48 + 25.0,
        }
    }

    /// Reads one sample in SI units.
    ///
    /// # Errors
    /// The bus error.
    pub fn read_si(&mut self) -> Result<(RawSample, Sample), Error<SPI::Error>> {
        let r = self.read_raw_lsb()?;
        Ok((r, self.to_si(&r)))
    }
}

/// A sensor fault seen in the data stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DataFault {
    /// The same raw sample `n` times in a row: a hung sensor (noise makes
    /// exact repeats of all seven words vanishingly rare).
    Stuck,
    /// A word at full scale (or the chip's "no data" value, -32768).
    Saturated,
}

/// Watches the raw stream for stuck or saturated data.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DataMonitor {
    last: Option<RawSample>,
    repeats: u16,
    /// Stuck samples seen.
    pub stuck_count: u32,
    /// Saturated samples seen.
    pub saturated_count: u32,
}

/// Identical samples in a row that mean "stuck".
pub const STUCK_REPEATS: u16 = 5;

impl DataMonitor {
    /// Checks one raw sample.
    pub fn check(&mut self, r: &RawSample) -> Option<DataFault> {
        self.repeats = if self.last == Some(*r) {
            self.repeats.saturating_add(1)
        } else {
            0
        };
        self.last = Some(*r);
        let words = r.accel_lsb.iter().chain(r.gyro_lsb.iter());
        if words
            .clone()
            .any(|w| *w == i16::MAX || *w == i16::MIN || *w == i16::MIN + 1)
        {
            self.saturated_count = self.saturated_count.saturating_add(1);
            return Some(DataFault::Saturated);
        }
        if self.repeats + 1 >= STUCK_REPEATS {
            self.stuck_count = self.stuck_count.saturating_add(1);
            return Some(DataFault::Stuck);
        }
        None
    }
}

/// The driver behind the data-ready line: INT_STATUS says whether the
/// data is new (a read clears it), then one burst read.
impl<SPI: SpiDevice> crate::ports::Imu for Icm42688<SPI> {
    fn read(&mut self) -> crate::ports::Reading {
        match self.data_ready() {
            Ok(false) => Ok(None),
            Ok(true) => self.read_si().map(Some).map_err(|_| crate::ports::BusError),
            Err(_) => Err(crate::ports::BusError),
        }
    }
}

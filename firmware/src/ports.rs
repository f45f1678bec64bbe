//! The ports: the traits the board's parts implement and the program
//! calls, with the values that cross them. Drivers (`icm42688`, the
//! board's and QEMU's `hw` modules, the host's models in `tests`) import
//! this module and nothing of the task layer; the tasks import it too.
//! (stabilizer's `src/hardware/` and eldruin's driver crates keep the same
//! split.)

/// The IMU's bus failed (the sample is skipped and counted).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BusError;

/// What a read behind a data-ready edge gives: the raw and the SI
/// sample, `None` when the sensor says there is no new data, or the bus's
/// failure.
pub type Reading = Result<Option<(RawSample, Sample)>, BusError>;

/// The IMU behind its data-ready line.
pub trait Imu {
    /// Reads the sample behind a data-ready edge: `Ok(None)` when the
    /// sensor says there is no new data.
    ///
    /// # Errors
    /// The bus failed.
    fn read(&mut self) -> Reading;
}

/// The table's encoder.
pub trait Encoder {
    /// The 16-bit hardware count.
    fn count(&mut self) -> u16;
}

/// The table's motor.
pub trait Motor {
    /// Duty in [-1, 1], the sign the direction.
    fn set(&mut self, duty: f32);
}

/// The hardware watchdog.
pub trait Watchdog {
    /// Feeds it.
    fn feed(&mut self);
}

/// A raw sample in LSB, as read (chip axes = the sensor frame `s`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct RawSample {
    /// TEMP_DATA.
    pub temp_lsb: i16,
    /// ACCEL_DATA x, y, z.
    pub accel_lsb: [i16; 3],
    /// GYRO_DATA x, y, z.
    pub gyro_lsb: [i16; 3],
}

/// A sample in SI units, in the sensor frame `s`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Sample {
    /// Angular rate, rad/s.
    pub gyro_radps: [f32; 3],
    /// Specific force, m/s^2.
    pub accel_mps2: [f32; 3],
    /// Die temperature, deg C.
    pub temp_c: f32,
}

/// What the flash controller refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlashError {
    /// The controller's error flags after an operation (SR bits), or the
    /// unlock did not take.
    Controller(u32),
    /// An address outside the journal's sectors.
    OutOfRange,
    /// The journal has no blank slot left until the next boot.
    Full,
}

/// NOR flash as the journal uses it: reads, word programs (bits go from 1
/// to 0 only), sector erases (all bits to 1).
pub trait Flash {
    /// Reads `buf.len()` bytes at `addr` (an absolute address).
    ///
    /// # Errors
    /// An address outside the device.
    fn read(&mut self, addr: u32, buf: &mut [u8]) -> Result<(), FlashError>;
    /// Programs one word at `addr` (word aligned, already erased).
    ///
    /// # Errors
    /// The controller's flags.
    fn program_word(&mut self, addr: u32, word: u32) -> Result<(), FlashError>;
    /// Erases a whole sector (only at boot).
    ///
    /// # Errors
    /// The controller's flags.
    fn erase(&mut self, sector: Sector) -> Result<(), FlashError>;
}

/// A flash sector of the journal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sector {
    /// The controller's sector number (SNB).
    pub number: u8,
    /// Its first address.
    pub base: u32,
    /// Its length, bytes.
    pub len: u32,
}

/// The receive side of the telemetry UART: a ring the hardware writes on
/// its own (the STM32F405's DMA1 stream 1, channel 4, USART3_RX, RM0090
/// table 42, circular), so that no byte waits for the CPU, which stalls on
/// every flash fetch while a word is programmed. The `uart_rx` module's `RxRing`
/// reads it.
pub trait RxDma {
    /// The ring's length, bytes (even).
    const LEN: u32;
    /// Half rings the writer has completed (its half-transfer and
    /// transfer-complete events, counted by their interrupt, wrapping).
    /// Read before [`Self::remaining`]: a half counted late is allowed, one
    /// counted before the writer's position shows it is not.
    fn halves(&self) -> u32;
    /// Bytes the writer has left before it wraps (the stream's NDTR),
    /// 1..=`LEN` (`LEN`: at the ring's start).
    fn remaining(&self) -> u32;
    /// The ring's byte `i` (`i < LEN`).
    fn byte(&self, i: u32) -> u8;
    /// Restarts after a transfer error (which turns the stream off): how
    /// many so far (wrapping), the writer's position when the last one
    /// stopped it and the position it started again from (a whole ring's
    /// start: NDTR and M0AR written anew, the half rings counted to it).
    /// A writer that never stops: none.
    fn restarted(&self) -> Restart {
        Restart::default()
    }
}

/// A receive stream's restarts ([`RxDma::restarted`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Restart {
    /// Restarts so far, wrapping.
    pub count: u32,
    /// The writer's position (bytes written, wrapping) when it stopped.
    pub stopped_at: u32,
    /// The position it went on from.
    pub from: u32,
}

/// An oscillator the PLL can take.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockSource {
    /// The crystal (12 MHz on the board).
    Hse,
    /// The internal RC oscillator (16 MHz).
    Hsi,
}

/// The reset and clock controller's start-up flags (RCC_CR, RCC_PLLCFGR),
/// for the `clocks` module's start.
pub trait ClockControl {
    /// The crystal's oscillator on or off (HSEON).
    fn hse_on(&mut self, on: bool);
    /// Whether it runs (HSERDY).
    fn hse_ready(&mut self) -> bool;
    /// The PLL set for 168 MHz (and 48 MHz) from `src` (PLL off).
    fn pll_configure(&mut self, src: ClockSource);
    /// The PLL on or off (PLLON).
    fn pll_on(&mut self, on: bool);
    /// Whether it is locked (PLLRDY).
    fn pll_ready(&mut self) -> bool;
}

//! Mock drivers: embedded-hal 1.0 traits on top of the shared [`Bench`], so
//! the firmware's own drivers and logic run unchanged on the host.
//!
//! - [`SimSpi`]: `SpiDevice` to the ICM-42688-P register model. Each
//!   transaction is one chip-select frame: its first byte is the command
//!   (bit 7 = read, bits 6:0 = address), the following bytes read or write
//!   consecutive registers (auto-increment). `DelayNs` operations advance
//!   simulated time.
//! - [`SimDrdy`]: `InputPin`, the chip's INT1 line.
//! - [`SimPwm`] (`SetDutyCycle`) and [`SimDir`] (`OutputPin`): the H-bridge.
//! - [`SimEncoder`]: [`QuadratureCounter`], the wrapping 16-bit timer count.
//! - [`SimDelay`]: `DelayNs`, advances the world; [`SimClock`]: the time.

use crate::bench::SharedBench;
use core_nav::table::QuadratureCounter;
use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{ErrorType as PinErrorType, InputPin, OutputPin};
use embedded_hal::pwm::{ErrorType as PwmErrorType, SetDutyCycle};
use embedded_hal::spi::{self, ErrorKind, Operation, SpiDevice};
use std::convert::Infallible;

pub use crate::bench::Bench;

/// An SPI failure (injected with `ChipFaults::spi_error`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SimSpiError;

impl spi::Error for SimSpiError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Other
    }
}

impl core::fmt::Display for SimSpiError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "simulated SPI failure")
    }
}

/// `SpiDevice` to the simulated ICM-42688-P.
#[derive(Clone, Debug)]
pub struct SimSpi {
    bench: SharedBench,
    /// Transactions served.
    pub transactions: u64,
}

impl SimSpi {
    /// A device on `bench`.
    pub fn new(bench: SharedBench) -> Self {
        Self {
            bench,
            transactions: 0,
        }
    }
}

impl spi::ErrorType for SimSpi {
    type Error = SimSpiError;
}

/// The frame being clocked: command seen or not, read or write, next address.
struct Frame {
    cmd: Option<(bool, u8)>,
}

impl Frame {
    /// One byte out (MOSI) and its answer (MISO).
    fn byte(&mut self, b: &mut Bench, mosi: u8) -> u8 {
        let now = b.now_ns;
        match self.cmd {
            None => {
                self.cmd = Some((mosi & 0x80 != 0, mosi & 0x7F));
                0x00
            }
            Some((read, addr)) => {
                self.cmd = Some((read, (addr + 1) & 0x7F));
                if read {
                    b.chip.read(addr, now)
                } else {
                    b.chip.write(addr, mosi, now);
                    0x00
                }
            }
        }
    }
}

impl SpiDevice for SimSpi {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Self::Error> {
        let mut b = self.bench.borrow_mut();
        if b.chip.faults.spi_error {
            return Err(SimSpiError);
        }
        self.transactions += 1;
        let mut frame = Frame { cmd: None };
        for op in operations {
            match op {
                Operation::Write(w) => {
                    for &x in w.iter() {
                        frame.byte(&mut b, x);
                    }
                }
                Operation::Read(r) => {
                    for x in r.iter_mut() {
                        *x = frame.byte(&mut b, 0x00);
                    }
                }
                Operation::Transfer(r, w) => {
                    let n = r.len().max(w.len());
                    for i in 0..n {
                        let out = frame.byte(&mut b, w.get(i).copied().unwrap_or(0x00));
                        if let Some(slot) = r.get_mut(i) {
                            *slot = out;
                        }
                    }
                }
                Operation::TransferInPlace(buf) => {
                    for x in buf.iter_mut() {
                        *x = frame.byte(&mut b, *x);
                    }
                }
                Operation::DelayNs(ns) => {
                    let t = b.now_ns + u64::from(*ns);
                    b.advance_to(t);
                }
            }
        }
        Ok(())
    }
}

/// The chip's INT1 line as an input pin.
#[derive(Clone, Debug)]
pub struct SimDrdy(pub SharedBench);

impl PinErrorType for SimDrdy {
    type Error = Infallible;
}

impl InputPin for SimDrdy {
    fn is_high(&mut self) -> Result<bool, Self::Error> {
        let b = self.0.borrow();
        Ok(b.chip.int1_high(b.now_ns))
    }
    fn is_low(&mut self) -> Result<bool, Self::Error> {
        self.is_high().map(|h| !h)
    }
}

/// The H-bridge PWM input.
#[derive(Clone, Debug)]
pub struct SimPwm(pub SharedBench);

impl PwmErrorType for SimPwm {
    type Error = Infallible;
}

impl SetDutyCycle for SimPwm {
    fn max_duty_cycle(&self) -> u16 {
        self.0.borrow().pwm_max
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Self::Error> {
        let mut b = self.0.borrow_mut();
        b.pwm_duty = duty.min(b.pwm_max);
        Ok(())
    }
}

/// The H-bridge direction input (high = positive rotation).
#[derive(Clone, Debug)]
pub struct SimDir(pub SharedBench);

impl PinErrorType for SimDir {
    type Error = Infallible;
}

impl OutputPin for SimDir {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        self.0.borrow_mut().dir_forward = false;
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Self::Error> {
        self.0.borrow_mut().dir_forward = true;
        Ok(())
    }
}

/// The encoder timer.
#[derive(Clone, Debug)]
pub struct SimEncoder(pub SharedBench);

impl QuadratureCounter for SimEncoder {
    type Error = Infallible;
    fn read_count(&mut self) -> Result<u16, Self::Error> {
        Ok(self.0.borrow_mut().encoder_hw_count())
    }
}

/// A delay that advances simulated time.
#[derive(Clone, Debug)]
pub struct SimDelay(pub SharedBench);

impl DelayNs for SimDelay {
    fn delay_ns(&mut self, ns: u32) {
        let mut b = self.0.borrow_mut();
        let t = b.now_ns + u64::from(ns);
        b.advance_to(t);
    }
}

/// The simulated clock.
#[derive(Clone, Debug)]
pub struct SimClock(pub SharedBench);

impl SimClock {
    /// Now, µs.
    pub fn now_us(&self) -> u64 {
        self.0.borrow().now_ns / 1_000
    }
    /// Advances to `t_us` (the scheduler's next tick).
    pub fn advance_to_us(&self, t_us: u64) {
        self.0.borrow_mut().advance_to(t_us * 1_000);
    }
}

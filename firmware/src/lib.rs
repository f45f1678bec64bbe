//! # rins firmware logic
//!
//! `no_std`, no heap, no panics: everything the board does that can be
//! logic lives here and is tested on the host through `hal-sim`; the
//! binary (`main.rs`, RTIC 2) only wires the STM32F405's peripherals to it.
//!
//! - [`icm42688`]: the IMU driver, generic over `embedded_hal::spi::SpiDevice`.
//! - [`app`]: the board's logic: rate control (`core_nav::control`, the
//!   controller the simulator's console shares), faults, the power-up
//!   calibration state machine and its flash record, navigation.
//! - [`replay`]: the QEMU build's input stream.
//! - [`telemetry`]: framed telemetry and commands (COBS, CRC-16, sequence
//!   numbers): loss and corruption are counted, never silent.
//!
//! Frames and units as in `core-nav` (its crate docs).

#![no_std]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

pub mod app;
pub mod faults;
pub mod icm42688;
pub mod replay;
pub mod telemetry;

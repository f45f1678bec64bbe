//! # rins firmware
//!
//! `no_std`, no heap, no panics: the board's program, tested on the host
//! through `hal-sim` and under QEMU. On the target the library also holds
//! [`app`] (the RTIC 2 app: the tasks bound to their interrupts) and
//! [`bsp`] (the board's peripherals, or QEMU's with the `qemu` feature);
//! the binaries (`src/bin/`) hold only their panic handlers.
//!
//! - [`tasks`]: the scheduling (what runs at which priority, the queues
//!   between the tasks), generic over the peripherals.
//! - [`control`]: the control tick's logic (rate loop, encoder glitch and
//!   stall filters).
//! - [`calibration`]: the power-up calibration.
//! - [`navigation`]: strapdown and aided navigation, fixes at their epoch.
//! - [`ports`]: the traits the board's parts implement (IMU, encoder,
//!   motor, watchdog, flash, the receive ring's DMA).
//! - [`uart_rx`]: the receive ring the link task reads.
//! - [`link`]: commands in, telemetry out ([`protocol`] on the wire).
//! - [`record`]: the flash journal (erases only at boot).
//! - [`store`]: what is stored and when a command is told so.
//! - [`faults`]: counted, rate-limited fault reports.
//! - [`watchdog`]: the watchdog's progress rule.
//! - [`resets`]: what survives a reset (resets in a row, a HardFault's
//!   registers) and the rule against a reset loop.
//! - [`clocks`]: the clock tree's start, every wait bounded.
//! - [`clock`]: the 64-bit microsecond clock and the sensor's sample clock.
//! - [`icm42688`]: the IMU driver, generic over `embedded_hal::spi::SpiDevice`.
//! - [`replay`]: the sensors' stand-in for the QEMU build.
//!
//! Frames and units as in `core-nav` (its crate docs).

#![cfg_attr(not(test), no_std)]
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

#[cfg(target_os = "none")]
#[allow(missing_docs)] // RTIC's generated items
pub mod app;
#[cfg(target_os = "none")]
pub mod bsp;
pub mod calibration;
pub mod clock;
pub mod clocks;
pub mod control;
pub mod faults;
pub mod icm42688;
pub mod link;
pub mod navigation;
pub mod pins;
pub mod ports;
pub mod queue;
pub mod record;
pub mod replay;
pub mod resets;
pub mod rig;
pub mod rig_bounds;
pub mod store;
pub mod tasks;
pub mod tuning;
pub mod uart_rx;
pub mod watchdog;

pub use protocol;

//! Board support (the target only): the peripherals wired to the
//! program's ports, for the board (`board`) or, with the `qemu` feature,
//! for QEMU's netduinoplus2 with the sensors it lacks replayed (`qemu`:
//! the QEMU test's harness, its report and its instruction profile, none
//! of it in the board's build). `hw` is the one the build is for; `app`
//! (the RTIC app) runs on it.

pub mod common;
pub mod logger;

#[cfg(not(feature = "qemu"))]
pub mod board;
#[cfg(not(feature = "qemu"))]
pub use board as hw;

#[cfg(feature = "qemu")]
pub mod qemu;
#[cfg(feature = "qemu")]
pub use qemu as hw;

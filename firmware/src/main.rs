//! rins firmware for the STM32F405 (RTIC 2): the board's app
//! (`rtic_app.rs`) on the board's peripherals (`hw_board.rs`). Wiring only:
//! the program is the `firmware` library's `tasks`, which the host tests
//! and the QEMU build run too.

#![cfg_attr(target_os = "none", no_std, no_main)]

/// On the host there is nothing to run: the program is the `firmware`
/// library, tested through `hal-sim` in `tests/`.
#[cfg(not(target_os = "none"))]
fn main() {
    println!("the rins firmware runs on the STM32F405: build it with `cargo fw`");
}

#[cfg(target_os = "none")]
use panic_probe as _;

#[cfg(target_os = "none")]
#[path = "logger.rs"]
mod logger;

#[cfg(target_os = "none")]
#[path = "hw_board.rs"]
mod hw;

#[cfg(target_os = "none")]
#[path = "rtic_app.rs"]
mod rtic_app;

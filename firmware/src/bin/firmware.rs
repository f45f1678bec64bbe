//! rins firmware for the STM32F405 (RTIC 2): the `firmware` library's app
//! (`firmware::app`) on the board's peripherals (`firmware::bsp::board`).
//! This file holds only what a binary must: the panic handler. Built with
//! the `qemu` feature the library's app is the QEMU build's: use
//! `cargo qemu` (the `firmware-qemu` binary) for that.

#![cfg_attr(target_os = "none", no_std, no_main)]

/// On the host there is nothing to run: the program is the `firmware`
/// library, tested through `hal-sim` in `tests/`.
#[cfg(not(target_os = "none"))]
fn main() {
    println!("the rins firmware runs on the STM32F405: build it with `cargo fw`");
}

// The panic handler prints through defmt (the library's RTT logger); the
// board's code has no panic path (scripts/check-no-panic checks the ELF).
#[cfg(target_os = "none")]
use panic_probe as _;

// The app, its interrupt handlers and `main` are the library's.
#[cfg(target_os = "none")]
use firmware as _;

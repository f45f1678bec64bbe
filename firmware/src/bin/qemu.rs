//! The firmware's QEMU build (`cargo qemu`; `qemu-system-arm -M
//! netduinoplus2 -icount shift=0`): the board's RTIC app (`rtic_app.rs`)
//! with the sensors QEMU lacks replayed (`hw_qemu.rs`); commands and GNSS
//! fixes come through the emulated USART3 from `rins record`. It prints
//! the budgets, the stack's peak and the outcome against the host twin's,
//! `N passed, M failed`, and exits with the result.

#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    println!("the QEMU build runs under qemu-system-arm: `cargo qemu`");
}

#[cfg(target_os = "none")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    cortex_m_semihosting::hprintln!("panic");
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

#[cfg(target_os = "none")]
#[path = "../logger.rs"]
mod logger;

#[cfg(target_os = "none")]
#[path = "../hw_qemu.rs"]
mod hw;

#[cfg(target_os = "none")]
#[path = "../report.rs"]
mod report;

#[cfg(target_os = "none")]
#[path = "../profile.rs"]
mod profile;

#[cfg(target_os = "none")]
#[path = "../rtic_app.rs"]
mod rtic_app;

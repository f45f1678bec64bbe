//! The firmware's QEMU build (`cargo qemu`; `qemu-system-arm -M
//! netduinoplus2 -icount shift=0`): the board's RTIC app (`firmware::app`)
//! with the sensors QEMU lacks replayed (`firmware::bsp::qemu`); commands and GNSS
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

// The app (with the QEMU harness: the `qemu` feature), its interrupt
// handlers and `main` are the library's.
#[cfg(target_os = "none")]
use firmware as _;

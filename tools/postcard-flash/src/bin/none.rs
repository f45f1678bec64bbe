#![no_std]
#![no_main]
use core::hint::black_box;
use panic_halt as _;
#[cortex_m_rt::entry]
fn main() -> ! {
    let mut out = [0u8; 128];
    loop { black_box(&mut out); }
}

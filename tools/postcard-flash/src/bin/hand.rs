#![no_std]
#![no_main]
use core::hint::black_box;
use panic_halt as _;
use protocol::{CalStatus, Command, Fault, ResetCause, SchemeKind, Status, Telemetry};
const CALSTATUS: CalStatus = CalStatus::Stored;
const FAULT: Fault = Fault::ImuTimeout;
const STATUS: Status = Status::Accepted;
const RESET: ResetCause = ResetCause::PowerOn;
const SCHEME: SchemeKind = SchemeKind::Continuous;

include!("../all_messages.rs");


#[cortex_m_rt::entry]
fn main() -> ! {
    let mut out = [0u8; 128];
    loop {
        // Every telemetry message encoded, every command decoded.
        let t = ALL[black_box(0usize) % ALL.len()];
        let n = t.encode(1, &mut out).unwrap_or(0);
        black_box(n);
        let c = Command::decode(black_box(&out[..black_box(40)]));
        black_box(&c);
    }
}

//! # rins protocol
//!
//! Every byte the board and the host exchange, defined once (`no_std`, no
//! heap), and used by the firmware, the `rins` CLI and the tests:
//!
//! - [`frame`]: a frame on the wire is `COBS(payload || crc16) || 0x00`;
//!   a streaming [`frame::Decoder`] counts corrupt, overflowing and lost
//!   frames.
//! - [`wire`]: the little-endian field codec and the `messages!` macro
//!   that writes each message's encoder and decoder from one list of
//!   fields.
//! - [`codes`]: typed fault, reason, scheme and status codes
//!   (`TryFrom<u8>` refuses unknown values).
//! - [`telemetry`]: what a board sends; [`command`]: what a host sends.
//! - [`record`]: the calibration and configuration record the board keeps
//!   in flash.
//! - [`replay`]: the QEMU test's input stream.
//!
//! Units: SI unless a field's name says otherwise (`_us` microseconds,
//! `_e7` 1e-7 deg, `_mm` millimetres, `_dps` deg/s); frames as in
//! `core-nav` (NED navigation frame `n`, sensor frame `s`, base frame `b`).

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

pub mod codes;
pub mod command;
pub mod frame;
pub mod record;
pub mod replay;
pub mod telemetry;
pub mod wire;

pub use codes::{CalStatus, Fault, ResetCause, SchemeKind, Status};
pub use command::Command;
pub use frame::{frame, Decoder, FrameError, LinkStats, MAX_FRAME, MAX_PAYLOAD};
pub use telemetry::Telemetry;

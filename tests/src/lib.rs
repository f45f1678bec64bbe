//! Scenario tests across the rins crates live in `tests/tests/`; this library
//! holds what they share: where their reference data is ([`data`]) and the
//! simulated runs several of them diagnose ([`runs`]).

pub mod board;
pub mod data;
pub mod hardware;
pub mod runs;
pub mod twin;

//! Scenario tests across the rins crates live in `tests/tests/`; this library
//! holds what they share: where their reference data is ([`data`]).

pub mod data;

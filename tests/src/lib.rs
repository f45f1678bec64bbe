//! Scenario tests across the rins crates live in `tests/`.

//! The sensor model, one home (`no_std`; files with the `std` feature):
//!
//! - [`spec`]: a unit's error budget in SI (per triad, temperature,
//!   mounting), what hal-sim simulates and the tools measure;
//! - [`filter`]: the aided filter's noise model derived from it, for the
//!   host's navigation and the board's build (firmware's build.rs makes
//!   its tuning from its sensor file through it);
//! - [`file`] (`std`): the sensor file format (`rins-sensor/2`: a term
//!   measured, from its base, or unknown), the shipped profiles
//!   (`sensors/*.toml`), [`file::ImuSpec`];
//! - [`catalogue`]: the diagnose-v1 effect ids and each one's physical
//!   bound, which the simulator's knobs and diagnose share.
#![cfg_attr(not(feature = "std"), no_std)]

pub mod catalogue;
pub mod filter;
pub mod spec;

#[cfg(feature = "std")]
pub mod file;

//! `rins diagnose` in the CLI: the `diagnose` crate (the pipeline, the
//! study, the one noise estimator) with its presentation here, the text
//! report and the plots ([`show`], [`twin`]'s `text` and `plots`).

pub use ::diagnose::*;
pub mod sensor_out;
pub mod show;
pub mod twin;

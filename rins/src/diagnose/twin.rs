//! The twin of a diagnosis (the `diagnose` crate's) with its text and
//! plots.

pub use ::diagnose::twin::*;
#[path = "twin_show.rs"]
mod show;
pub use show::{plots, text};

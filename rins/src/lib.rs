//! The host side of rins: [`calibrate`], [`nav`] (navigation of
//! recordings, trajectory-v1), [`allan`], [`reproduce`] (the paper's
//! experiment), [`demo`] (the main job), [`diagnose`] and its blind
//! [`study`] (with [`realnoise`] backgrounds), [`record`] (board telemetry into recordings),
//! [`qemu_replay`] (the QEMU test's input), [`report`] and [`plot`] (charts
//! in SVG and PNG). The `rins` binary (`src/cmd/`, one file per command)
//! wires these to the command line.

pub mod aided;
pub mod align;
pub mod allan;
pub mod calibrate;
pub mod demo;
pub mod diagnose;
pub mod import;
pub mod link;
pub mod nav;
pub mod outages;
pub mod plot;
pub mod qemu_replay;
pub mod record;
pub mod report;
pub mod reproduce;
pub mod ubx;

/// A progress bar for a job measured in fractions (hidden when not a terminal).
pub fn progress_bar(what: &str) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(1000);
    pb.set_style(
        indicatif::ProgressStyle::with_template("{msg:>12} [{bar:40}] {percent:>3}% {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    pb
}

pub use ::diagnose::{realnoise, study};

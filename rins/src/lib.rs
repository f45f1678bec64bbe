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
pub mod coverage;
pub mod demo;
pub mod diagnose;
pub mod import;
pub mod link;
pub mod memory;
pub mod multipos;
pub mod nav;
pub mod outages;
pub mod plot;
pub mod qemu_replay;
pub mod record;
pub mod report;
pub mod reproduce;
pub mod results;
pub mod sensor_file;
pub mod shard;
pub mod ubx;
pub mod vehicle_study;

/// A job's progress, measured in thousandths: on a terminal a bar with
/// the time spent and an estimate of the time left; elsewhere (a log, CI)
/// a plain line at most every [`PROGRESS_LINE_S`] with the same figures,
/// and one when it ends, if it took that long.
pub struct Progress {
    bar: Option<indicatif::ProgressBar>,
    what: String,
    start: std::time::Instant,
    last_line: std::sync::Mutex<std::time::Instant>,
}

/// Seconds between progress lines when stderr is not a terminal.
pub const PROGRESS_LINE_S: f64 = 10.0;

impl Progress {
    /// Progress at `pos` thousandths.
    pub fn set_position(&self, pos: u64) {
        match &self.bar {
            Some(b) => b.set_position(pos),
            None => {
                let now = std::time::Instant::now();
                let Ok(mut last) = self.last_line.lock() else {
                    return;
                };
                if now.duration_since(*last).as_secs_f64() < PROGRESS_LINE_S {
                    return;
                }
                *last = now;
                let spent = now.duration_since(self.start).as_secs_f64();
                let f = (pos as f64 / 1000.0).clamp(0.0, 1.0);
                // Under 1 % done, the time left is a guess of a guess.
                let left = if f >= 0.01 {
                    format!("about {:.0} s left", spent * (1.0 - f) / f)
                } else {
                    "no estimate yet".to_string()
                };
                eprintln!(
                    "{}: {:.0} % after {spent:.0} s, {left}",
                    self.what,
                    100.0 * f
                );
            }
        }
    }

    /// The job is done: the bar goes; a log gets its time if it took long.
    pub fn finish_and_clear(&self) {
        match &self.bar {
            Some(b) => b.finish_and_clear(),
            None => {
                let spent = self.start.elapsed().as_secs_f64();
                if spent >= PROGRESS_LINE_S {
                    eprintln!("{}: done in {spent:.0} s", self.what);
                }
            }
        }
    }
}

/// A [`Progress`] for the job `what`.
pub fn progress_bar(what: &str) -> Progress {
    use std::io::IsTerminal;
    let bar = std::io::stderr().is_terminal().then(|| {
        let pb = indicatif::ProgressBar::new(1000);
        pb.set_style(
            indicatif::ProgressStyle::with_template(
                "{msg:>12} [{bar:40}] {percent:>3}% {elapsed}, about {eta} left",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        pb.set_message(what.to_string());
        pb
    });
    let start = std::time::Instant::now();
    Progress {
        bar,
        what: what.to_string(),
        start,
        last_line: std::sync::Mutex::new(start),
    }
}

pub use ::diagnose::{realnoise, study};

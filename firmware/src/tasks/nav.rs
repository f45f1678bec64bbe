//! Navigation (priority 2): calibration, strapdown and the aided filter
//! on the tick's inputs.

use super::*;

/// Navigation (priority 2).
pub struct NavTask<'a> {
    /// Its logic.
    pub nav: Navigator<'a>,
    pub(super) input: Consumer<'a, NavInput, NAV_Q>,
    pub(super) cmds: Consumer<'a, NavCmd, CMD_Q>,
    pub(super) ctl: Producer<'a, ControlCmd, CMD_Q>,
    pub(super) out: Producer<'a, Outbound, OUT_Q>,
}

impl NavTask<'_> {
    /// Takes the commands and the inputs queued.
    pub fn run(&mut self, stats: &Stats) {
        stats.progress.nav.fetch_add(1, Ordering::Relaxed);
        let (out, ctl) = (&mut self.out, &mut self.ctl);
        let mut emit = |o: Outbound| {
            if out.enqueue(o).is_err() {
                stats.out_lost.fetch_add(1, Ordering::Relaxed);
            }
        };
        // A full command queue to the tick loses the command: counted as
        // lost telemetry would be (the tick drains it every sample).
        let mut control = |c: ControlCmd| {
            if ctl.enqueue(c).is_err() {
                stats.out_lost.fetch_add(1, Ordering::Relaxed);
            }
        };
        while let Some(c) = self.cmds.dequeue() {
            self.nav.command(c, &mut emit, &mut control);
        }
        while let Some(x) = self.input.dequeue() {
            self.nav.input(&x, &mut emit, &mut control);
        }
    }
}

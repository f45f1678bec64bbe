//! What the link task tells of the board's health: the tasks' counters
//! as faults (at a bounded rate, with their totals) and the health frame.

use super::link::send;
use super::*;

/// The counters the tasks keep (no task may wait to send a report) and
/// the faults the link reports them as.
pub(super) const COUNTED: [Fault; 4] = [
    Fault::TickOverrun,
    Fault::RxLost,
    Fault::TelemetryOverflow,
    Fault::BadCommand,
];

/// Counter `f`'s total: the tasks' (`stats`), or for
/// [`Fault::BadCommand`] the commands refused (`refused`, each also
/// answered with its reason) and the frames that arrived corrupt or
/// oversize (`link`'s decoder: no command to answer).
fn counter(stats: &Stats, link: &Link, refused: u32, f: Fault) -> u32 {
    let a = match f {
        Fault::TickOverrun => &stats.tick_overruns,
        Fault::RxLost => &stats.rx_lost,
        Fault::BadCommand => {
            let s = link.rx_stats();
            let frames = u32::try_from(s.corrupt.saturating_add(s.overflow)).unwrap_or(u32::MAX);
            return frames.saturating_add(refused);
        }
        _ => &stats.out_lost,
    };
    a.load(Ordering::Relaxed)
}

impl LinkTask<'_> {
    /// The tasks' overruns and losses as faults: when a counter has grown,
    /// at most once per [`crate::faults::REPORT_EVERY_US`] each, with the
    /// total so far.
    pub(super) fn report_counted(&mut self, mcu_us: u64, stats: &Stats) {
        for (f, (seen, last)) in COUNTED.iter().zip(self.counted.iter_mut()) {
            let now = counter(stats, &self.link, self.refused, *f);
            let due =
                last.is_none_or(|t| mcu_us.saturating_sub(t) >= crate::faults::REPORT_EVERY_US);
            if now > *seen && due {
                *seen = now;
                *last = Some(mcu_us);
                let t = Telemetry::Fault {
                    t_us: mcu_us,
                    fault: *f,
                    count: now,
                };
                send(&mut self.link, &mut self.tx, &t);
            }
        }
    }

    pub(super) fn health(&self, mcu_us: u64, stats: &Stats) -> Telemetry {
        let l = |a: &AtomicU32| a.load(Ordering::Relaxed);
        Telemetry::Health {
            t_us: mcu_us,
            reset: self.reset,
            tick_worst: l(&stats.tick_worst),
            tick_overruns: l(&stats.tick_overruns),
            nav_worst: l(&stats.nav_worst),
            nav_overruns: l(&stats.nav_overruns),
            samples_dropped: l(&stats.dropped),
            samples_duplicated: l(&stats.duplicated),
            rx_bytes: l(&stats.rx_bytes),
            rx_lost: l(&stats.rx_lost),
            rx_line_errors: stats.rx_line.each_ref().map(l),
            init_stack_bytes: l(&stats.init_stack_bytes),
            stack_bytes: l(&stats.stack_bytes),
        }
    }
}

//! The counters every task writes and the link reports (atomics: no
//! task waits to count).

use super::*;

/// Counters every task writes and the link reports.
#[derive(Debug, Default)]
pub struct Stats {
    /// The tasks' progress (the watchdog's rule).
    pub progress: Progress,
    /// The tick's worst case, cycles (instructions under QEMU).
    pub tick_worst: AtomicU32,
    /// Ticks still running when the next data-ready came.
    pub tick_overruns: AtomicU32,
    /// Navigation's worst case, cycles.
    pub nav_worst: AtomicU32,
    /// Navigation inputs dropped (its queue full).
    pub nav_overruns: AtomicU32,
    /// The link task's worst case, cycles.
    pub link_worst: AtomicU32,
    /// The UART interrupt's worst case, cycles (what it holds the tasks
    /// off; what holds it off is in the book's Firmware chapter, the link's margin).
    pub uart_worst: AtomicU32,
    /// Samples dropped (data-ready late).
    pub dropped: AtomicU32,
    /// Data-ready edges without new data.
    pub duplicated: AtomicU32,
    /// Bytes received by the UART.
    pub rx_bytes: AtomicU32,
    /// Bytes lost on receive (overrun flag, queue full).
    pub rx_lost: AtomicU32,
    /// The USART's line errors: overruns, noise, framing
    /// ([`crate::uart_rx::LineErrors`]).
    pub rx_line: [AtomicU32; 3],
    /// Telemetry lost in the tasks' queues.
    pub out_lost: AtomicU32,
    /// The MCU clock's low 32 bits at the last IMU sample, µs.
    pub last_sample_us: AtomicU32,
    /// Samples taken.
    pub samples: AtomicU32,
    /// The stack's peak during `init`, bytes (0: not measured).
    pub init_stack_bytes: AtomicU32,
    /// The tasks' stack peak at its last scan, bytes (0: not yet).
    pub stack_bytes: AtomicU32,
}

impl Stats {
    /// Keeps the worst of `cycles` in `slot`.
    pub fn worst(slot: &AtomicU32, cycles: u32) {
        slot.fetch_max(cycles, Ordering::Relaxed);
    }
}

//! The telemetry UART's receive ring, read by the link task: bytes the
//! hardware wrote on its own since the last run (the board's DMA; the
//! QEMU build's and the host's [`SoftDma`] where there is none), and the
//! bytes it overwrote before they were read, counted.
//!
//! Why a ring and not a byte per interrupt: while the flash programs a
//! word, every instruction fetch from flash stalls, the USART's interrupt
//! and the vector table's included; the DMA writes SRAM through the bus
//! matrix meanwhile. The figures are in the book's firmware chapter.

use crate::ports::RxDma;
use core::sync::atomic::{AtomicU32, AtomicU8, Ordering};

/// Bytes kept clear of the writer: a byte this close behind it may be
/// overwritten while the drain runs, so it is counted lost instead.
pub const GUARD: u32 = 64;

/// The reader's side of a receive ring.
#[derive(Clone, Copy, Debug, Default)]
pub struct RxRing {
    /// Bytes taken (or skipped as lost) since the start, wrapping.
    taken: u32,
    /// Bytes written by the writer at the last [`Self::sync`], wrapping.
    end: u32,
}

impl RxRing {
    /// Bytes the writer has written since the start (wrapping): its
    /// position placed after the half rings counted, which may lag the
    /// position by less than half a ring (their interrupt is late by at
    /// most a flash stall). The halves are read first ([`RxDma::halves`]).
    fn written<D: RxDma>(dma: &D) -> u32 {
        let base = dma.halves().wrapping_mul(D::LEN / 2);
        let pos = D::LEN.saturating_sub(dma.remaining()) % D::LEN.max(1);
        let ahead = pos.wrapping_add(D::LEN).wrapping_sub(base % D::LEN.max(1)) % D::LEN.max(1);
        base.wrapping_add(ahead)
    }

    /// Takes the writer's position: the bytes up to it are what
    /// [`Self::next`] gives; returns the bytes it overwrote before they
    /// were read (skipped, to be counted lost).
    pub fn sync<D: RxDma>(&mut self, dma: &D) -> u32 {
        self.end = Self::written(dma);
        let waiting = self.end.wrapping_sub(self.taken);
        let keep = D::LEN.saturating_sub(GUARD);
        let lost = waiting.saturating_sub(keep);
        self.taken = self.taken.wrapping_add(lost);
        lost
    }

    /// The next byte up to the position [`Self::sync`] took.
    pub fn next<D: RxDma>(&mut self, dma: &D) -> Option<u8> {
        if self.taken == self.end {
            return None;
        }
        let b = dma.byte(self.taken % D::LEN.max(1));
        self.taken = self.taken.wrapping_add(1);
        Some(b)
    }
}

/// The ring's length where software writes it, bytes: 22 ms at 921,600
/// baud, twice the link task's period.
pub const SOFT_LEN: u32 = 2048;

/// A receive ring written by software, with the DMA's counters: the QEMU
/// build's USART interrupt (QEMU 7.2 models no DMA on the STM32F405) and
/// the host's tests write it a byte at a time, so the link task reads the
/// same ring the same way on every build.
pub struct SoftDma {
    buf: [AtomicU8; SOFT_LEN as usize],
    written: AtomicU32,
}

impl SoftDma {
    /// An empty ring.
    pub const fn new() -> Self {
        Self {
            buf: [const { AtomicU8::new(0) }; SOFT_LEN as usize],
            written: AtomicU32::new(0),
        }
    }

    /// A received byte (the single writer: one interrupt, or the host).
    pub fn write(&self, b: u8) {
        let n = self.written.load(Ordering::Relaxed);
        if let Some(slot) = self.buf.get((n % SOFT_LEN) as usize) {
            slot.store(b, Ordering::Relaxed);
        }
        self.written.store(n.wrapping_add(1), Ordering::Release);
    }
}

impl Default for SoftDma {
    fn default() -> Self {
        Self::new()
    }
}

impl RxDma for SoftDma {
    const LEN: u32 = SOFT_LEN;
    fn halves(&self) -> u32 {
        self.written.load(Ordering::Acquire) / (SOFT_LEN / 2)
    }
    fn remaining(&self) -> u32 {
        SOFT_LEN - self.written.load(Ordering::Acquire) % SOFT_LEN
    }
    fn byte(&self, i: u32) -> u8 {
        self.buf
            .get(i as usize)
            .map_or(0, |b| b.load(Ordering::Relaxed))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A writer whose counters can be set: `written` bytes so far, its
    /// half-ring interrupt `late` halves behind.
    struct At {
        written: u32,
        late: u32,
    }
    impl RxDma for At {
        const LEN: u32 = 16;
        fn halves(&self) -> u32 {
            (self.written / 8).wrapping_sub(self.late)
        }
        fn remaining(&self) -> u32 {
            16 - self.written % 16
        }
        fn byte(&self, i: u32) -> u8 {
            i as u8
        }
    }

    #[test]
    fn the_position_holds_with_a_half_counted_late_and_across_the_wrap() {
        for written in [0, 5, 8, 15, 16, 17, 1_000, u32::MAX - 3, u32::MAX] {
            let on_time = At { written, late: 0 };
            assert_eq!(RxRing::written(&on_time), written);
            // The interrupt one half late (a flash stall held it off).
            let late = At { written, late: 1 };
            if written >= 8 || written > u32::MAX - 8 {
                assert_eq!(RxRing::written(&late), written, "{written}");
            }
        }
    }

    #[test]
    fn bytes_overwritten_before_they_are_read_are_counted() {
        let mut r = RxRing::default();
        // 12 waiting of a 16-byte ring: within it, but 64 of guard take
        // the whole of a ring this small: all counted lost.
        assert_eq!(
            r.sync(&At {
                written: 12,
                late: 0
            }),
            12
        );
        assert_eq!(
            r.next(&At {
                written: 12,
                late: 0
            }),
            None
        );
        let soft = SoftDma::new();
        let mut r = RxRing::default();
        for b in 0..3000u32 {
            soft.write(b as u8);
        }
        // 3000 written into 2048: the oldest 1016 (and the guard's 64)
        // were overwritten or may be while the drain runs.
        assert_eq!(r.sync(&soft), 3000 - (SOFT_LEN - GUARD));
        let first = r.next(&soft);
        assert_eq!(first, Some((3000 - (SOFT_LEN - GUARD)) as u8));
        let mut n = 1;
        while r.next(&soft).is_some() {
            n += 1;
        }
        assert_eq!(n, SOFT_LEN - GUARD);
    }
}

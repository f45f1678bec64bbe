//! The telemetry UART's receive ring, read by the link task: bytes the
//! hardware wrote on its own since the last run (the board's DMA; the
//! QEMU build's and the host's [`SoftDma`] where there is none), and the
//! bytes it overwrote before they were read, counted.
//!
//! Why a ring and not a byte per interrupt: while the flash programs a
//! word, every instruction fetch from flash stalls, the USART's interrupt
//! and the vector table's included; the DMA writes SRAM through the bus
//! matrix meanwhile. The figures are in the book's firmware chapter.

use crate::ports::{Restart, RxDma};
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
    /// The writer's restarts seen.
    restarts: u32,
}

impl RxRing {
    /// Bytes the writer has written since the start (wrapping): its
    /// position placed after the half rings counted, which may lag the
    /// position by less than half a ring (their interrupt is late by at
    /// most a flash stall). The halves are read first ([`RxDma::halves`]).
    pub fn written<D: RxDma>(dma: &D) -> u32 {
        let base = dma.halves().wrapping_mul(D::LEN / 2);
        let pos = D::LEN.saturating_sub(dma.remaining()) % D::LEN.max(1);
        let ahead = pos.wrapping_add(D::LEN).wrapping_sub(base % D::LEN.max(1)) % D::LEN.max(1);
        base.wrapping_add(ahead)
    }

    /// Takes the writer's position: the bytes up to it are what
    /// [`Self::next`] gives; returns the bytes it overwrote before they
    /// were read, and after a restart the bytes left unread when the
    /// stream stopped (skipped, to be counted lost).
    pub fn sync<D: RxDma>(&mut self, dma: &D) -> u32 {
        let mut lost = 0;
        let r = dma.restarted();
        if r.count != self.restarts {
            self.restarts = r.count;
            lost = ahead_of(r.stopped_at, self.taken);
            self.taken = r.from;
        }
        self.end = Self::written(dma);
        // The restart's count again: one between the two reads makes the
        // position a mix of the old stream and the new; the next run takes it.
        if dma.restarted().count != self.restarts {
            self.end = self.taken;
            return lost;
        }
        let waiting = self.end.wrapping_sub(self.taken);
        let keep = D::LEN.saturating_sub(GUARD);
        let over = waiting.saturating_sub(keep);
        self.taken = self.taken.wrapping_add(over);
        lost + over
    }

    /// The next byte up to the position [`Self::sync`] took. A byte the
    /// writer overtook while the drain ran (its slot written again before
    /// the read was done) is not given: it and the bytes to within
    /// [`GUARD`] of the writer are skipped and added to `lost`, and the
    /// drain goes on from there. A restart during the drain ends it.
    pub fn next<D: RxDma>(&mut self, dma: &D, lost: &mut u32) -> Option<u8> {
        loop {
            if self.taken == self.end || dma.restarted().count != self.restarts {
                return None;
            }
            let b = dma.byte(self.taken % D::LEN.max(1));
            // The slot of byte p holds byte p + LEN from the writer's
            // (p + LEN + 1)th byte on: one byte's margin.
            let w = Self::written(dma);
            if w.wrapping_sub(self.taken) < D::LEN {
                self.taken = self.taken.wrapping_add(1);
                return Some(b);
            }
            let resume = w.wrapping_sub(D::LEN.saturating_sub(GUARD));
            *lost = lost.saturating_add(resume.wrapping_sub(self.taken));
            self.taken = resume;
            // The drain still ends where the sync put it (or here, if the
            // writer took all of it): a writer faster than the drain
            // cannot keep it running.
            if ahead_of(self.taken, self.end) > 0 {
                self.end = self.taken;
            }
        }
    }
}

/// Bytes from `from` up to `to` (wrapping), 0 when `to` is not ahead.
fn ahead_of(to: u32, from: u32) -> u32 {
    let d = to.wrapping_sub(from);
    if d > u32::MAX / 2 {
        0
    } else {
        d
    }
}

/// Where a stream that stopped at `stopped_at` (bytes written, wrapping)
/// starts again: the next whole ring's start of a ring of `len` bytes (a
/// power of two), with the half rings counted to it.
pub fn restart_from(stopped_at: u32, len: u32) -> Restart {
    let from = stopped_at.wrapping_add(len - 1) & !(len - 1);
    Restart {
        count: 0,
        stopped_at,
        from,
    }
}

/// USART_SR's line-error flags (RM0090 30.6.1) in the order of
/// `Stats::rx_line`: ORE (bit 3), NF (2), FE (1).
pub const LINE_FLAGS: [u32; 3] = [1 << 3, 1 << 2, 1 << 1];

/// Counts the line errors SR shows into `counts` (overrun, noise,
/// framing); whether there was any.
///
/// With the receive DMA the USART's error interrupt (CR3's EIE) tells of
/// them, but SR's flags clear only when DR is read after SR, which the
/// DMA does at the next byte: until then the interrupt would run again
/// and again. So it is turned off when this counts, and on again by the
/// link task once SR is clear ([`line_clear`]): a burst of errors before
/// the next byte counts once (the health frame says "at least").
pub fn count_line_errors(sr: u32, counts: &[AtomicU32; 3]) -> bool {
    let mut any = false;
    for (flag, n) in LINE_FLAGS.iter().zip(counts) {
        if sr & flag != 0 {
            n.fetch_add(1, Ordering::Relaxed);
            any = true;
        }
    }
    any
}

/// Whether SR shows no line error (the error interrupt may go on again).
pub fn line_clear(sr: u32) -> bool {
    LINE_FLAGS.iter().all(|f| sr & f == 0)
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

    /// A DMA that writes `per_read` bytes each time a byte is read (a
    /// writer faster than the drain: navigation pre-empting the link
    /// task), byte `p` being `p % 251`; with a transfer error at
    /// `stop_at` bytes after which it restarts as the board's does.
    struct Racing {
        soft: core::cell::RefCell<Vec<u8>>,
        written: core::cell::Cell<u32>,
        halves: core::cell::Cell<u32>,
        per_read: u32,
        restart: core::cell::Cell<Restart>,
        stop_at: Option<u32>,
    }
    const RLEN: u32 = 2048;
    impl Racing {
        fn new(per_read: u32, stop_at: Option<u32>) -> Self {
            Self {
                soft: core::cell::RefCell::new(vec![0; RLEN as usize]),
                written: core::cell::Cell::new(0),
                halves: core::cell::Cell::new(0),
                per_read,
                restart: core::cell::Cell::new(Restart::default()),
                stop_at,
            }
        }
        fn write(&self, n: u32) {
            for _ in 0..n {
                let p = self.written.get();
                if Some(p) == self.stop_at && self.restart.get().count == 0 {
                    // The stream stops; the board's interrupt restarts it.
                    let mut r = restart_from(p, RLEN);
                    r.count = 1;
                    self.restart.set(r);
                    self.written.set(r.from);
                    self.halves.set(r.from / (RLEN / 2));
                    continue;
                }
                self.soft.borrow_mut()[(p % RLEN) as usize] = (p % 251) as u8;
                self.written.set(p + 1);
                self.halves.set((p + 1) / (RLEN / 2));
            }
        }
    }
    impl RxDma for Racing {
        const LEN: u32 = RLEN;
        fn halves(&self) -> u32 {
            self.halves.get()
        }
        fn remaining(&self) -> u32 {
            RLEN - self.written.get() % RLEN
        }
        fn byte(&self, i: u32) -> u8 {
            let b = self.soft.borrow()[i as usize];
            self.write(self.per_read);
            b
        }
        fn restarted(&self) -> Restart {
            self.restart.get()
        }
    }

    /// Drains `dma` as the link task does; every byte given must be the
    /// one written at its position. Returns (bytes given, lost).
    fn drain(r: &mut RxRing, dma: &Racing) -> (u32, u32) {
        let mut lost = r.sync(dma);
        let mut n = 0;
        let mut last: Option<u8> = None;
        while let Some(b) = r.next(dma, &mut lost) {
            // Consecutive bytes follow each other unless bytes were skipped
            // (counted) in between.
            if let Some(l) = last {
                assert!(b == (l + 1) % 251 || lost > 0, "byte {b} after {l}");
            }
            last = Some(b);
            n += 1;
        }
        (n, lost)
    }

    #[test]
    fn a_byte_the_writer_overtakes_during_the_drain_is_counted_not_given() {
        // 1,000 bytes waiting, then three written for every one read: the
        // writer laps the reader after about 500 reads. Before the check,
        // all 1,000 were given and none counted; ~500 of them were bytes
        // of the next lap.
        let dma = Racing::new(3, None);
        dma.write(1_000);
        let mut r = RxRing::default();
        let (given, lost) = drain(&mut r, &dma);
        assert!(lost > 0, "nothing counted");
        // Every byte accounted: given, lost, or still waiting.
        let waiting = RxRing::written(&dma) - r.taken;
        assert_eq!(given + lost + waiting, RxRing::written(&dma));
        assert!(given < 1_000, "{given}");
        // Each byte given was its position's (checked in `drain` for runs;
        // here the last one against the reader's position).
        assert_eq!(
            dma.soft.borrow()[((r.taken - 1) % RLEN) as usize],
            ((r.taken - 1) % 251) as u8
        );
    }

    #[test]
    fn a_transfer_errors_restart_is_followed_and_its_unread_bytes_counted() {
        // 300 bytes read, then the stream stops at byte 700 with 400
        // unread; it restarts from the next ring's start (2048) and writes
        // 100 more.
        let dma = Racing::new(0, Some(700));
        dma.write(300);
        let mut r = RxRing::default();
        assert_eq!(drain(&mut r, &dma), (300, 0));
        dma.write(400);
        dma.write(101);
        assert_eq!(dma.restarted().from, RLEN);
        assert_eq!(RxRing::written(&dma), RLEN + 100);
        let (given, lost) = drain(&mut r, &dma);
        // The 400 unread when it stopped, counted; the 100 after it given
        // (as the bytes at positions 2048.., not the old ring's).
        assert_eq!((given, lost), (100, 400));
        assert_eq!(r.taken, RLEN + 100);
    }

    #[test]
    fn each_line_error_is_counted_once_under_its_name() {
        let n = [const { AtomicU32::new(0) }; 3];
        // SR with RXNE (5) and TXE (7) only: nothing.
        assert!(!count_line_errors((1 << 5) | (1 << 7), &n));
        // An overrun and a framing error together, then noise.
        assert!(count_line_errors((1 << 3) | (1 << 1) | (1 << 5), &n));
        assert!(count_line_errors(1 << 2, &n));
        assert_eq!(n.each_ref().map(|a| a.load(Ordering::Relaxed)), [1, 1, 1]);
        assert!(!line_clear(1 << 1) && line_clear(1 << 5));
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
            r.next(
                &At {
                    written: 12,
                    late: 0
                },
                &mut 0
            ),
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
        let first = r.next(&soft, &mut 0);
        assert_eq!(first, Some((3000 - (SOFT_LEN - GUARD)) as u8));
        let mut n = 1;
        while r.next(&soft, &mut 0).is_some() {
            n += 1;
        }
        assert_eq!(n, SOFT_LEN - GUARD);
    }
}

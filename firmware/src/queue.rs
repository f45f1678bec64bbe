//! A lock-free single-producer single-consumer queue of `Copy` values,
//! fixed capacity, no heap, no panic path: the tasks' one way to pass data
//! (one task enqueues, one other task dequeues, each from any priority).
//!
//! Written here rather than taken from `heapless::spsc`: heapless 0.9's
//! producer and consumer index by a run-time length (`% n`), which links
//! a division-by-zero panic into the board's ELF.

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicUsize, Ordering};

/// A queue of `N - 1` values at most (one slot tells full from empty).
pub struct Queue<T: Copy, const N: usize> {
    buf: [UnsafeCell<MaybeUninit<T>>; N],
    /// The next slot to read (written by the consumer only).
    head: AtomicUsize,
    /// The next slot to write (written by the producer only).
    tail: AtomicUsize,
}

// SAFETY: a slot is written only by the producer while it is outside
// [head, tail) and read only by the consumer while inside it; head and
// tail are published with release and read with acquire.
unsafe impl<T: Copy + Send, const N: usize> Sync for Queue<T, N> {}

const fn next<const N: usize>(i: usize) -> usize {
    if i + 1 >= N {
        0
    } else {
        i + 1
    }
}

impl<T: Copy, const N: usize> Queue<T, N> {
    /// An empty queue (a `const`, for a static).
    pub const fn new() -> Self {
        Self {
            buf: [const { UnsafeCell::new(MaybeUninit::uninit()) }; N],
            head: AtomicUsize::new(0),
            tail: AtomicUsize::new(0),
        }
    }

    /// Its two ends.
    pub fn split(&mut self) -> (Producer<'_, T, N>, Consumer<'_, T, N>) {
        let q: &Self = self;
        (Producer { q }, Consumer { q })
    }

    fn len(&self) -> usize {
        let (h, t) = (
            self.head.load(Ordering::Acquire),
            self.tail.load(Ordering::Acquire),
        );
        if t >= h {
            t - h
        } else {
            N - h + t
        }
    }
}

impl<T: Copy, const N: usize> Default for Queue<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

/// The writing end.
pub struct Producer<'a, T: Copy, const N: usize> {
    q: &'a Queue<T, N>,
}

/// The reading end.
pub struct Consumer<'a, T: Copy, const N: usize> {
    q: &'a Queue<T, N>,
}

impl<T: Copy, const N: usize> Producer<'_, T, N> {
    /// Adds `v`; gives it back when the queue is full.
    ///
    /// # Errors
    /// The queue is full.
    pub fn enqueue(&mut self, v: T) -> Result<(), T> {
        let t = self.q.tail.load(Ordering::Relaxed);
        let n = next::<N>(t);
        if n == self.q.head.load(Ordering::Acquire) {
            return Err(v);
        }
        let Some(slot) = self.q.buf.get(t) else {
            return Err(v);
        };
        // SAFETY: slot `t` is outside [head, tail): only this producer
        // touches it until `tail` moves past it below.
        unsafe { (*slot.get()).write(v) };
        self.q.tail.store(n, Ordering::Release);
        Ok(())
    }

    /// Values queued.
    pub fn len(&self) -> usize {
        self.q.len()
    }

    /// Whether nothing is queued.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The most it holds.
    pub fn capacity(&self) -> usize {
        N.saturating_sub(1)
    }
}

impl<T: Copy, const N: usize> Consumer<'_, T, N> {
    /// Takes the oldest value.
    pub fn dequeue(&mut self) -> Option<T> {
        let h = self.q.head.load(Ordering::Relaxed);
        if h == self.q.tail.load(Ordering::Acquire) {
            return None;
        }
        let slot = self.q.buf.get(h)?;
        // SAFETY: slot `h` is inside [head, tail): written by the producer
        // (published by its release store of `tail`), not touched by it
        // until `head` moves past it below.
        let v = unsafe { (*slot.get()).assume_init() };
        self.q.head.store(next::<N>(h), Ordering::Release);
        Some(v)
    }

    /// Values queued.
    pub fn len(&self) -> usize {
        self.q.len()
    }

    /// Whether nothing is queued.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holds_n_minus_one_in_order_and_wraps() {
        let mut q: Queue<u32, 4> = Queue::new();
        let (mut p, mut c) = q.split();
        for round in 0..5 {
            for i in 0..3 {
                assert_eq!(p.enqueue(round * 10 + i), Ok(()));
            }
            assert_eq!(p.enqueue(99), Err(99));
            assert_eq!(c.len(), 3);
            for i in 0..3 {
                assert_eq!(c.dequeue(), Some(round * 10 + i));
            }
            assert_eq!(c.dequeue(), None);
        }
    }

    #[test]
    fn one_thread_each_end_loses_nothing() {
        let q: &'static mut Queue<u64, 64> = Box::leak(Box::new(Queue::new()));
        let (mut p, mut c) = q.split();
        std::thread::scope(|s| {
            s.spawn(move || {
                let mut i = 0u64;
                while i < 100_000 {
                    if p.enqueue(i).is_ok() {
                        i += 1;
                    }
                }
            });
            let mut want = 0u64;
            while want < 100_000 {
                if let Some(v) = c.dequeue() {
                    assert_eq!(v, want);
                    want += 1;
                }
            }
        });
    }
}

//! The defmt logger over RTT (SEGGER's protocol: a control block probe-rs
//! finds by its id, one up channel, non-blocking: bytes that do not fit
//! are dropped), written here instead of taken from `defmt-rtt`, which
//! panics when the logger is taken reentrantly: a panic path on the
//! board. Here a frame started inside another is dropped and counted
//! (`NESTED`). Interrupts are masked from a frame's start to its end, so
//! the only nesting is a `Format` implementation that logs.

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicU32, Ordering};

/// The up channel's buffer, bytes.
const SIZE: usize = 1024;

#[repr(C)]
struct Channel {
    name: *const u8,
    buffer: *mut u8,
    size: u32,
    write: AtomicU32,
    read: AtomicU32,
    flags: AtomicU32,
}

/// SEGGER's RTT control block (layout fixed by the protocol).
#[repr(C)]
pub struct Header {
    id: [u8; 16],
    max_up_channels: u32,
    max_down_channels: u32,
    up: Channel,
}

// SAFETY: the pointers are to statics; the host reads the block, the
// target writes `write` (atomic) and the buffer below it.
unsafe impl Sync for Header {}

struct Buffer(UnsafeCell<[u8; SIZE]>);
// SAFETY: written only inside a frame, with interrupts masked.
unsafe impl Sync for Buffer {}
static BUFFER: Buffer = Buffer(UnsafeCell::new([0; SIZE]));
static NAME: [u8; 6] = *b"defmt\0";

/// Non-blocking, trim: write what fits.
const MODE_TRIM: u32 = 1;

#[no_mangle]
static _SEGGER_RTT: Header = Header {
    id: *b"SEGGER RTT\0\0\0\0\0\0",
    max_up_channels: 1,
    max_down_channels: 0,
    up: Channel {
        name: NAME.as_ptr(),
        buffer: BUFFER.0.get().cast::<u8>(),
        size: SIZE as u32,
        write: AtomicU32::new(0),
        read: AtomicU32::new(0),
        flags: AtomicU32::new(MODE_TRIM),
    },
};

/// Frames dropped because they started inside another.
pub static NESTED: AtomicU32 = AtomicU32::new(0);
/// Bytes dropped because the host had not read the buffer.
pub static OVERFLOW: AtomicU32 = AtomicU32::new(0);

struct State {
    depth: u32,
    /// Interrupts were enabled when the frame started.
    enable: bool,
    encoder: defmt::Encoder,
}
struct Shared(UnsafeCell<State>);
// SAFETY: touched only with interrupts masked (acquire to release).
unsafe impl Sync for Shared {}
static STATE: Shared = Shared(UnsafeCell::new(State {
    depth: 0,
    enable: false,
    encoder: defmt::Encoder::new(),
}));

fn write_all(bytes: &[u8]) {
    let ch = &_SEGGER_RTT.up;
    let mut w = ch.write.load(Ordering::Relaxed) as usize % SIZE;
    let r = ch.read.load(Ordering::Relaxed) as usize;
    for (i, b) in bytes.iter().enumerate() {
        let next = (w + 1) % SIZE;
        if next == r {
            let left = u32::try_from(bytes.len() - i).unwrap_or(u32::MAX);
            OVERFLOW.fetch_add(left, Ordering::Relaxed);
            break;
        }
        // SAFETY: w < SIZE (reduced above); interrupts are masked.
        unsafe { BUFFER.0.get().cast::<u8>().add(w).write_volatile(*b) };
        w = next;
    }
    ch.write.store(w as u32, Ordering::Release);
}

#[defmt::global_logger]
struct Logger;

// SAFETY: defmt's contract: acquire, writes, release, in that order;
// the state is only touched with interrupts masked.
unsafe impl defmt::Logger for Logger {
    fn acquire() {
        let enable = cortex_m::register::primask::read().is_active();
        cortex_m::interrupt::disable();
        // SAFETY: interrupts are masked.
        let st = unsafe { &mut *STATE.0.get() };
        st.depth += 1;
        if st.depth > 1 {
            NESTED.fetch_add(1, Ordering::Relaxed);
            return;
        }
        st.enable = enable;
        st.encoder.start_frame(write_all);
    }

    unsafe fn flush() {}

    unsafe fn release() {
        // SAFETY: interrupts are masked since `acquire`.
        let st = unsafe { &mut *STATE.0.get() };
        if st.depth > 1 {
            st.depth -= 1;
            return;
        }
        st.encoder.end_frame(write_all);
        st.depth = 0;
        if st.enable {
            // SAFETY: they were enabled when the frame started.
            unsafe { cortex_m::interrupt::enable() };
        }
    }

    unsafe fn write(bytes: &[u8]) {
        // SAFETY: interrupts are masked since `acquire`.
        let st = unsafe { &mut *STATE.0.get() };
        if st.depth == 1 {
            st.encoder.write(bytes, write_all);
        }
    }
}

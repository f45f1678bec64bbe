//! The link while the flash programs (issue 34): every fetch from flash
//! stalls while a word is programmed (RM0090 3.5.4; a word takes 16 µs,
//! at most 100 µs, STM32F405 datasheet table "Flash memory programming"),
//! the USART's interrupt and the vector table's included, and a byte
//! lasts 10.85 µs at 921,600 baud. The host sends configuration commands
//! back to back while the board stores them; the board's link task runs
//! as it does on the chip, its flash a model whose every programmed word
//! stalls the CPU for the datasheet's worst time, and the bytes arrive on
//! the line's clock meanwhile.
//!
//! Two receivers on the same line: the board's (DMA1 stream 1 writes a
//! ring during the stall, its half-ring interrupt counted only when the
//! CPU runs again) receives every byte; a byte per interrupt (the old
//! design) loses the bytes of every stall but the first, the USART's
//! overrun (RM0090 30.3.3: the data register keeps its byte, the shift
//! register's are lost). The second case is what makes the first mean
//! something: the same model, the same traffic, bytes lost.

use firmware::ports::RxDma;
use firmware::record::{Flash, FlashError, Sector};
use firmware::uart_rx::SoftDma;
use protocol::{Command, MAX_FRAME};
use rins_tests::board::{HostBoard, NorFlash};
use std::cell::{Cell, RefCell};

/// A byte on the line: 10 bits at 921,600 baud, ns.
const BYTE_NS: u64 = 10_851;
/// A word programmed, the datasheet's worst (x32 parallelism), ns.
const WORD_NS: u64 = 100_000;
/// The link task's period, ns.
const LINK_NS: u64 = 10_000_000;
/// The board's receive ring (`firmware/src/bsp/board.rs`), bytes.
const RING: u32 = 2048;

/// The host's bytes, byte `k` complete at `(k + 1) * BYTE_NS`.
fn stream(n_commands: u16) -> Vec<u8> {
    let mut out = vec![];
    for i in 0..n_commands {
        let c = Command::SetSite {
            lat_e7: -339_000_000 + i32::from(i),
            height_mm: 20_000 + i32::from(i),
        };
        let mut f = [0u8; MAX_FRAME];
        let n = c.to_frame(i, &mut f).expect("a frame fits");
        out.extend_from_slice(&f[..n]);
    }
    out
}

/// What receives the line's bytes while time passes.
trait Receiver: RxDma {
    /// The line's bytes up to `t_ns`; `cpu_free`: the CPU fetches from
    /// flash (no word being programmed), so interrupts run.
    fn advance(&self, t_ns: u64, cpu_free: bool);
    /// Bytes the receiver itself lost (the model's count).
    fn lost(&self) -> u32;
}

/// The board's receiver: DMA1 stream 1 writes the ring whatever the CPU
/// does; its half-ring interrupt (fetched from flash) runs only when the
/// CPU does.
struct Dma<'a> {
    line: &'a [u8],
    ring: RefCell<Vec<u8>>,
    written: Cell<u32>,
    halves: Cell<u32>,
}

impl<'a> Dma<'a> {
    fn new(line: &'a [u8]) -> Self {
        Self {
            line,
            ring: RefCell::new(vec![0; RING as usize]),
            written: Cell::new(0),
            halves: Cell::new(0),
        }
    }
}

impl RxDma for Dma<'_> {
    const LEN: u32 = RING;
    fn halves(&self) -> u32 {
        self.halves.get()
    }
    fn remaining(&self) -> u32 {
        RING - self.written.get() % RING
    }
    fn byte(&self, i: u32) -> u8 {
        self.ring.borrow()[i as usize]
    }
}

impl Receiver for Dma<'_> {
    fn advance(&self, t_ns: u64, cpu_free: bool) {
        let arrived = ((t_ns / BYTE_NS) as usize).min(self.line.len()) as u32;
        while self.written.get() < arrived {
            let k = self.written.get();
            self.ring.borrow_mut()[(k % RING) as usize] = self.line[k as usize];
            self.written.set(k + 1);
        }
        if cpu_free {
            self.halves.set(self.written.get() / (RING / 2));
        }
    }
    fn lost(&self) -> u32 {
        0
    }
}

/// A byte per interrupt: the USART holds one byte (DR); a byte completing
/// while DR is full and the interrupt cannot run is an overrun, lost.
struct Irq<'a> {
    line: &'a [u8],
    soft: SoftDma,
    next: Cell<u32>,
    lost: Cell<u32>,
}

impl RxDma for Irq<'_> {
    const LEN: u32 = firmware::uart_rx::SOFT_LEN;
    fn halves(&self) -> u32 {
        self.soft.halves()
    }
    fn remaining(&self) -> u32 {
        self.soft.remaining()
    }
    fn byte(&self, i: u32) -> u8 {
        self.soft.byte(i)
    }
}

impl Receiver for Irq<'_> {
    fn advance(&self, t_ns: u64, cpu_free: bool) {
        let arrived = ((t_ns / BYTE_NS) as usize).min(self.line.len()) as u32;
        let k = self.next.get();
        if arrived <= k {
            return;
        }
        if cpu_free {
            // The interrupt takes each byte as it completes.
            for j in k..arrived {
                self.soft.write(self.line[j as usize]);
            }
        } else {
            // Stalled: the first byte waits in DR (read after the stall),
            // the rest overrun.
            self.soft.write(self.line[k as usize]);
            self.lost.set(self.lost.get() + (arrived - k - 1));
        }
        self.next.set(arrived);
    }
    fn lost(&self) -> u32 {
        self.lost.get()
    }
}

/// The journal's flash with the CPU stalled for [`WORD_NS`] a word: the
/// line's bytes arrive meanwhile.
struct StallingFlash<'a, R: Receiver> {
    nor: NorFlash,
    now_ns: &'a Cell<u64>,
    rx: &'a R,
    words: u32,
}

impl<R: Receiver> Flash for StallingFlash<'_, R> {
    fn read(&mut self, addr: u32, buf: &mut [u8]) -> Result<(), FlashError> {
        self.nor.read(addr, buf)
    }
    fn program_word(&mut self, addr: u32, word: u32) -> Result<(), FlashError> {
        let t = self.now_ns.get() + WORD_NS;
        self.rx.advance(t, false);
        self.now_ns.set(t);
        self.words += 1;
        self.nor.program_word(addr, word)
    }
    fn erase(&mut self, s: Sector) -> Result<(), FlashError> {
        panic!("no erase at run time ({s:?})");
    }
}

struct Outcome {
    words: u32,
    model_lost: u32,
    rx_lost: u32,
    rx_bytes: u32,
    frames: u64,
    corrupt: u64,
    stored_lat_e7: Option<i32>,
}

/// The board's link task over `rx` for as long as the line takes and a
/// second more (the last record stored).
fn run<R: Receiver>(line: &[u8], rx: &R) -> Outcome {
    let t = firmware::tuning::board();
    let mut b = HostBoard::new(t, NorFlash::new(4096), 0, Ok(()));
    let now = Cell::new(0u64);
    let mut flash = StallingFlash {
        nor: b.flash.clone(),
        now_ns: &now,
        rx,
        words: 0,
    };
    let end = line.len() as u64 * BYTE_NS + 1_000_000_000;
    let mut next = 0;
    while next < end {
        // The link task's next run: the CPU runs until then.
        let start = next.max(now.get());
        rx.advance(start, true);
        now.set(start);
        b.program
            .link
            .run(start / 1_000, rx, &mut flash, &mut b.wdg, b.stats);
        while b.program.uart.next_tx().is_some() {}
        rx.advance(now.get(), true);
        next += LINK_NS;
    }
    let s = b.program.link.link.rx_stats();
    let l = |a: &std::sync::atomic::AtomicU32| a.load(std::sync::atomic::Ordering::Relaxed);
    Outcome {
        words: flash.words,
        model_lost: rx.lost(),
        rx_lost: l(&b.stats.rx_lost),
        rx_bytes: l(&b.stats.rx_bytes),
        frames: s.frames,
        corrupt: s.corrupt,
        stored_lat_e7: b.program.link.journal.current.map(|r| r.config.lat_e7),
    }
}

#[test]
fn every_byte_arrives_while_records_are_programmed() {
    // 2,000 commands back to back: about 0.4 s of line, several records
    // (each coalescing the commands before it), a stall every link run.
    const N: u16 = 2_000;
    let line = stream(N);
    let dma = Dma::new(&line);
    let o = run(&line, &dma);
    println!(
        "DMA ring: {} words programmed during {} bytes; {} received, {} lost, {} frames, {} corrupt",
        o.words,
        line.len(),
        o.rx_bytes,
        o.rx_lost,
        o.frames,
        o.corrupt
    );
    // The stalls overlapped the traffic (else the test shows nothing).
    assert!(o.words as usize >= 2 * firmware::record::SLOT_WORDS);
    assert_eq!(o.rx_bytes as usize, line.len());
    assert_eq!((o.rx_lost, o.model_lost, o.corrupt), (0, 0, 0));
    assert_eq!(o.frames, u64::from(N));
    // The last command's configuration is the one stored.
    assert_eq!(o.stored_lat_e7, Some(-339_000_000 + i32::from(N) - 1));
}

#[test]
fn a_byte_per_interrupt_loses_bytes_in_every_stall() {
    const N: u16 = 2_000;
    let line = stream(N);
    let irq = Irq {
        line: &line,
        soft: SoftDma::new(),
        next: Cell::new(0),
        lost: Cell::new(0),
    };
    let o = run(&line, &irq);
    println!(
        "byte per interrupt: {} words programmed, {} bytes lost to overrun, {} corrupt frames",
        o.words, o.model_lost, o.corrupt
    );
    // A 100 µs stall is 9.2 bytes: 8 or 9 lost in each stall that falls
    // in the traffic.
    assert!(o.words > 0);
    assert!(o.model_lost >= 8 * o.words.min(30), "{}", o.model_lost);
    assert!(o.corrupt > 0);
    assert!(o.frames < u64::from(N));
}

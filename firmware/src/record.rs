//! The record that survives: the board's configuration and calibration
//! ([`protocol::record::Record`]) in a journal of fixed slots across two
//! flash sectors reserved in `memory.x`.
//!
//! The STM32F405 has one flash bank: while a sector is erased (about a
//! second for 128 KiB, two at most) every instruction fetch from flash stalls, the
//! control tick's included, and the watchdog would reset the chip half-way.
//! So:
//!
//! - **Erases happen only at boot** ([`Journal::open`]), before the
//!   watchdog and the tick start: a blank journal sector is made ready
//!   when the active one is nearly full, and the current record copied
//!   into it.
//! - **At run time words are only programmed** into slots that are already
//!   erased, one word per call of [`Journal::step`] (a word takes 16 µs,
//!   at most 100 µs, by the datasheet): the tick is delayed by at most one
//!   word's programming.
//! - **A write cut anywhere** leaves a slot that is neither blank nor
//!   valid (its CRC, in the last word, is written last): [`Journal::open`]
//!   skips it and the record before it stands. The highest valid sequence
//!   number across both sectors is the record.

use protocol::record::{Record, RECORD_LEN};

/// The longest a journal sector's erase takes on the board, µs: a
/// 128 KiB sector at x32 parallelism (2.7-3.6 V) takes 1 s typically and
/// 2 s at most by the STM32F405 datasheet (DS8626, flash memory
/// programming, t_ERASE128KB). A boot that moves the journal erases two.
pub const ERASE_WORST_US: u32 = 2_000_000;

/// Bytes in a flash word (the F405 programs 32 bits at 2.7-3.6 V).
pub const WORD: usize = 4;
/// Words in a record slot.
pub const SLOT_WORDS: usize = RECORD_LEN / WORD;
/// Free slots below which the boot moves the journal to the other sector.
pub const LOW_WATER: u32 = 16;

pub use crate::ports::{Flash, FlashError, Sector};

impl Sector {
    fn slots(&self) -> u32 {
        self.len / RECORD_LEN as u32
    }
    fn slot_addr(&self, i: u32) -> u32 {
        self.base + i * RECORD_LEN as u32
    }
}

/// The STM32F405's sectors 10 and 11 (128 KiB each at 0x080C_0000 and
/// 0x080E_0000), kept out of the program by `memory.x`.
pub const F405_SECTORS: [Sector; 2] = [
    Sector {
        number: 10,
        base: 0x080C_0000,
        len: 128 * 1024,
    },
    Sector {
        number: 11,
        base: 0x080E_0000,
        len: 128 * 1024,
    },
];

/// The journal's model in RAM (the QEMU build and the host twin: QEMU has
/// no flash controller): two 2 KiB sectors from address 0.
pub const MODEL_SECTORS: [Sector; 2] = [
    Sector {
        number: 10,
        base: 0,
        len: 2048,
    },
    Sector {
        number: 11,
        base: 2048,
        len: 2048,
    },
];

/// What a slot holds.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Slot {
    Blank,
    Valid(Record),
    Garbage,
}

fn read_slot<F: Flash>(f: &mut F, addr: u32) -> Slot {
    let mut b = [0u8; RECORD_LEN];
    if f.read(addr, &mut b).is_err() {
        return Slot::Garbage;
    }
    if b.iter().all(|x| *x == 0xFF) {
        return Slot::Blank;
    }
    match Record::decode(&b) {
        Ok(r) => Slot::Valid(r),
        Err(_) => Slot::Garbage,
    }
}

/// A write in progress: the record's words, the next one to program.
#[derive(Clone, Copy, Debug)]
struct Pending {
    words: [u32; SLOT_WORDS],
    addr: u32,
    next: usize,
}

/// The journal.
#[derive(Clone, Copy, Debug)]
pub struct Journal {
    sectors: [Sector; 2],
    active: usize,
    /// The next blank slot of the active sector.
    next_slot: u32,
    /// The record now (the last valid one, or the last queued).
    pub current: Option<Record>,
    pending: Option<Pending>,
    /// Slots found cut (neither blank nor valid) at boot.
    pub garbage: u32,
    /// Erases done at this boot.
    pub erases: u32,
}

/// What a boot scan of one sector found: (best record, last used slot + 1, garbage).
fn scan<F: Flash>(f: &mut F, s: &Sector) -> (Option<Record>, u32, u32) {
    let (mut best, mut end, mut garbage) = (None::<Record>, 0, 0);
    for i in 0..s.slots() {
        match read_slot(f, s.slot_addr(i)) {
            Slot::Blank => {}
            Slot::Valid(r) => {
                end = i + 1;
                if best.is_none_or(|b| r.seq > b.seq) {
                    best = Some(r);
                }
            }
            Slot::Garbage => {
                end = i + 1;
                garbage += 1;
            }
        }
    }
    (best, end, garbage)
}

impl Journal {
    /// At boot, before the watchdog and the tick start: finds the record
    /// (the highest valid sequence in either sector) and makes sure the
    /// active sector has room, erasing and moving to the other one if not
    /// (the only erases the board ever does).
    ///
    /// # Errors
    /// The flash refused an erase or a program.
    pub fn open<F: Flash>(f: &mut F, sectors: [Sector; 2]) -> Result<Self, FlashError> {
        let [a, b] = sectors;
        let sa = scan(f, &a);
        let sb = scan(f, &b);
        let seq = |r: &Option<Record>| r.map(|r| r.seq);
        let active = usize::from(seq(&sb.0) > seq(&sa.0));
        let (cur, end, _) = if active == 0 { sa } else { sb };
        let mut j = Self {
            sectors,
            active,
            next_slot: end,
            current: cur,
            pending: None,
            garbage: sa.2 + sb.2,
            erases: 0,
        };
        let s = j.sector();
        if s.slots().saturating_sub(end) < LOW_WATER || (cur.is_none() && end > 0) {
            j.move_on(f)?;
        }
        Ok(j)
    }

    /// A journal with no record whose flash could not be read at boot:
    /// writes are tried (and fail, counted) until the next boot.
    pub fn blank(sectors: [Sector; 2]) -> Self {
        Self {
            sectors,
            active: 0,
            next_slot: 0,
            current: None,
            pending: None,
            garbage: 0,
            erases: 0,
        }
    }

    fn sector(&self) -> Sector {
        self.sectors
            .get(self.active)
            .copied()
            .unwrap_or(F405_SECTORS[0])
    }

    /// Boot only: erase the other sector, copy the record into it, erase
    /// the full one.
    fn move_on<F: Flash>(&mut self, f: &mut F) -> Result<(), FlashError> {
        let other = 1 - self.active;
        let to = self
            .sectors
            .get(other)
            .copied()
            .ok_or(FlashError::OutOfRange)?;
        f.erase(to)?;
        self.erases += 1;
        let old = self.sector();
        self.active = other;
        self.next_slot = 0;
        if let Some(r) = self.current {
            self.write(r.config, r.calibration)?;
            while self.step(f)? {}
        }
        f.erase(old)?;
        self.erases += 1;
        Ok(())
    }

    /// Queues a new record (the sequence number is the journal's); the
    /// words are programmed by [`Self::step`]. A write still in progress is
    /// replaced (its slot is left cut: skipped at boot).
    ///
    /// # Errors
    /// [`FlashError::Full`]: no blank slot until the next boot.
    pub fn write(
        &mut self,
        config: protocol::record::BoardConfig,
        calibration: Option<protocol::record::StoredCalibration>,
    ) -> Result<(), FlashError> {
        let s = self.sector();
        if self.next_slot >= s.slots() {
            return Err(FlashError::Full);
        }
        let r = Record {
            seq: self.current.map_or(1, |c| c.seq.wrapping_add(1)),
            config,
            calibration,
        };
        let bytes = r.encode();
        let mut words = [0u32; SLOT_WORDS];
        for (w, c) in words.iter_mut().zip(bytes.chunks_exact(WORD)) {
            *w = u32::from_le_bytes(c.try_into().unwrap_or([0xFF; 4]));
        }
        self.pending = Some(Pending {
            words,
            addr: s.slot_addr(self.next_slot),
            next: 0,
        });
        self.next_slot += 1;
        self.current = Some(r);
        Ok(())
    }

    /// Programs the next word of the pending write; `Ok(true)` while words
    /// remain.
    ///
    /// # Errors
    /// The controller's flags (the write is abandoned: its slot is cut).
    pub fn step<F: Flash>(&mut self, f: &mut F) -> Result<bool, FlashError> {
        let Some(p) = self.pending.as_mut() else {
            return Ok(false);
        };
        let Some(w) = p.words.get(p.next).copied() else {
            self.pending = None;
            return Ok(false);
        };
        let addr = p.addr + (p.next * WORD) as u32;
        p.next += 1;
        if let Err(e) = f.program_word(addr, w) {
            self.pending = None;
            return Err(e);
        }
        let more = p.next < SLOT_WORDS;
        if !more {
            self.pending = None;
        }
        Ok(more)
    }

    /// Whether a write is in progress.
    pub fn busy(&self) -> bool {
        self.pending.is_some()
    }

    /// Blank slots left in the active sector.
    pub fn free_slots(&self) -> u32 {
        self.sector().slots().saturating_sub(self.next_slot)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tasks::FACTORY;

    /// Two small sectors (2 KiB each) of NOR flash: programs only clear
    /// bits of erased words, erases set them, every erase counted.
    struct Nor {
        mem: Vec<u8>,
        erases: u32,
    }

    const SECTORS: [Sector; 2] = MODEL_SECTORS;

    impl Nor {
        fn new() -> Self {
            Self {
                mem: vec![0xFF; 4096],
                erases: 0,
            }
        }
        fn at(addr: u32) -> usize {
            addr as usize
        }
    }

    impl Flash for Nor {
        fn read(&mut self, addr: u32, buf: &mut [u8]) -> Result<(), FlashError> {
            let i = Self::at(addr);
            buf.copy_from_slice(&self.mem[i..i + buf.len()]);
            Ok(())
        }
        fn program_word(&mut self, addr: u32, word: u32) -> Result<(), FlashError> {
            let i = Self::at(addr);
            if self.mem[i..i + 4] != [0xFF; 4] {
                return Err(FlashError::Controller(0x80)); // PGSERR
            }
            self.mem[i..i + 4].copy_from_slice(&word.to_le_bytes());
            Ok(())
        }
        fn erase(&mut self, s: Sector) -> Result<(), FlashError> {
            let i = Self::at(s.base);
            self.mem[i..i + s.len as usize].fill(0xFF);
            self.erases += 1;
            Ok(())
        }
    }

    fn site(lat_e7: i32) -> protocol::record::BoardConfig {
        protocol::record::BoardConfig { lat_e7, ..FACTORY }
    }

    fn save(j: &mut Journal, f: &mut Nor, lat_e7: i32) {
        j.write(site(lat_e7), None).unwrap();
        while j.step(f).unwrap() {}
    }

    #[test]
    fn a_blank_journal_has_no_record_and_erases_nothing() {
        let mut f = Nor::new();
        let j = Journal::open(&mut f, SECTORS).unwrap();
        assert!(j.current.is_none());
        assert_eq!(f.erases, 0);
    }

    #[test]
    fn a_record_written_word_by_word_is_found_at_the_next_boot() {
        let mut f = Nor::new();
        let mut j = Journal::open(&mut f, SECTORS).unwrap();
        save(&mut j, &mut f, 1);
        save(&mut j, &mut f, -339_000_000);
        let again = Journal::open(&mut f, SECTORS).unwrap();
        let r = again.current.unwrap();
        assert_eq!((r.seq, r.config.lat_e7), (2, -339_000_000));
        assert_eq!(f.erases, 0, "run-time writes never erase");
    }

    #[test]
    fn a_nearly_full_sector_moves_on_at_boot_with_its_record() {
        let mut f = Nor::new();
        let mut j = Journal::open(&mut f, SECTORS).unwrap();
        let slots = SECTORS[0].len / RECORD_LEN as u32;
        let mut n = 0;
        while j.free_slots() >= LOW_WATER {
            n += 1;
            save(&mut j, &mut f, n);
        }
        assert_eq!(f.erases, 0);
        let j = Journal::open(&mut f, SECTORS).unwrap();
        // The other sector erased, the record copied, the full one erased.
        assert_eq!((j.erases, f.erases), (2, 2));
        assert_eq!(j.current.unwrap().config.lat_e7, n);
        assert_eq!(j.free_slots(), slots - 1);
    }

    #[test]
    fn a_full_sector_refuses_until_the_next_boot() {
        let mut f = Nor::new();
        let mut j = Journal::open(&mut f, SECTORS).unwrap();
        let slots = SECTORS[0].len / RECORD_LEN as u32;
        for i in 0..slots {
            save(&mut j, &mut f, i as i32);
        }
        assert_eq!(j.write(site(0), None), Err(FlashError::Full));
        assert_eq!(f.erases, 0);
    }
}

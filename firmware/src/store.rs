//! What the board stores, and when it says so: a configuration command is
//! acknowledged once the record holding it is in flash (`Accepted`), or
//! told it could not be (`NotStored`: the change holds until power-off);
//! a burst of changes is coalesced into one record (each change is
//! cumulative: the latest configuration holds every earlier one), not a
//! journal slot each; the calibration the navigation hands over rides in
//! the same record.

use crate::record::{Flash, FlashError, Journal};
use protocol::record::{BoardConfig, StoredCalibration};
use protocol::Status;

/// Configuration commands that can wait for their record at once: more
/// arriving before it is stored lose their oldest ack (counted by the
/// caller as lost telemetry; the host resends).
pub const ACKS_WAITING: usize = 32;

/// The pending store and the commands waiting on it.
#[derive(Debug, Default)]
pub struct Store {
    want: bool,
    cal: Option<StoredCalibration>,
    waiting: heapless::Vec<u16, ACKS_WAITING>,
    in_flight: heapless::Vec<u16, ACKS_WAITING>,
}

/// An ack that could not wait (the oldest of more than [`ACKS_WAITING`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AckDropped(pub u16);

impl Store {
    /// The store with the calibration found at boot.
    pub fn new(cal: Option<StoredCalibration>) -> Self {
        Self {
            cal,
            ..Self::default()
        }
    }

    /// Configuration command `seq` changed the configuration: store it.
    ///
    /// # Errors
    /// The oldest waiting ack was dropped to make room.
    pub fn config(&mut self, seq: u16) -> Result<(), AckDropped> {
        self.want = true;
        let mut dropped = Ok(());
        if self.waiting.is_full() {
            dropped = Err(AckDropped(self.waiting.remove(0)));
        }
        let _ = self.waiting.push(seq);
        dropped
    }

    /// A calibration to store with the configuration.
    pub fn calibration(&mut self, cal: StoredCalibration) {
        self.cal = Some(cal);
        self.want = true;
    }

    /// One link run: programs a word of the record in progress; when it is
    /// done its commands are acknowledged, and a wanted record is started
    /// (`config` the configuration now). `ack(seq, status)` for each
    /// command answered.
    ///
    /// # Errors
    /// The journal full or the flash controller's error (each command
    /// waiting on it told `NotStored`).
    pub fn run<F: Flash>(
        &mut self,
        journal: &mut Journal,
        flash: &mut F,
        config: BoardConfig,
        ack: &mut impl FnMut(u16, Status),
    ) -> Result<(), FlashError> {
        if let Err(e) = journal.step(flash) {
            self.answer(true, Status::NotStored, ack);
            return Err(e);
        }
        if journal.busy() {
            return Ok(());
        }
        self.answer(true, Status::Accepted, ack);
        if !self.want {
            return Ok(());
        }
        self.want = false;
        match journal.write(config, self.cal) {
            Ok(()) => {
                core::mem::swap(&mut self.in_flight, &mut self.waiting);
                Ok(())
            }
            Err(e) => {
                self.answer(false, Status::NotStored, ack);
                Err(e)
            }
        }
    }

    /// Answers the commands in flight (`in_flight`) or waiting.
    fn answer(&mut self, in_flight: bool, status: Status, ack: &mut impl FnMut(u16, Status)) {
        let list = if in_flight {
            &mut self.in_flight
        } else {
            &mut self.waiting
        };
        for seq in list.iter() {
            ack(*seq, status);
        }
        list.clear();
    }

    /// Whether a record is wanted or being written.
    pub fn pending(&self) -> bool {
        self.want || !self.in_flight.is_empty()
    }
}

//! The sensors' stand-in for a replay ([`protocol::replay`]): the QEMU
//! build (which has no IMU, encoder or motor) and its host twin feed the
//! board's program the recording's samples through these, at the same
//! sample indices, so both run the same instructions on the same data.
//!
//! Tick `i` (0-based: the sample clock's index) stands for the
//! recording's time `(i + 1)` ms: it reads the recording's 100 Hz sample
//! that covers it (held for ten 1 kHz ticks) and the encoder's last count.

use crate::icm42688::{RawSample, Sample};
use crate::navigation::Navigator;
use crate::tasks::{Encoder, Imu, Motor, Tuning};
pub use protocol::replay::*;

/// The replay's sensors.
#[derive(Clone, Copy, Debug, Default)]
pub struct Sensors {
    sample: Option<(RawSample, Sample)>,
    hw: u16,
    reads: u32,
    pending: Option<Event>,
    /// The last duty the program set.
    pub duty: f32,
}

impl Sensors {
    /// Takes the events up to the sample tick `i` reads (from `next`),
    /// handing the others (fixes, commands) to `other`; `false` when the
    /// replay has ended.
    pub fn advance(
        &mut self,
        i: u64,
        next: &mut impl FnMut() -> Option<Event>,
        other: &mut impl FnMut(Event),
    ) -> bool {
        let until = (i / 10 + 1) * 10_000;
        loop {
            let Some(e) = self.pending.take().or_else(&mut *next) else {
                return self.sample.is_some() && !i.is_multiple_of(10);
            };
            let t = match e {
                Event::Imu { t_us, .. } | Event::Encoder { t_us, .. } => t_us,
                Event::Gnss { .. } | Event::Command { .. } => {
                    other(e);
                    continue;
                }
            };
            if t > until {
                self.pending = Some(e);
                return true;
            }
            self.take(&e);
        }
    }

    fn take(&mut self, e: &Event) {
        match *e {
            Event::Imu {
                gyro, accel, temp, ..
            } => {
                let s = Sample {
                    gyro_radps: gyro,
                    accel_mps2: accel,
                    temp_c: temp,
                };
                let raw = RawSample {
                    temp_lsb: 0,
                    accel_lsb: [(accel[0] * 1e3) as i16, (accel[1] * 1e3) as i16, 0],
                    gyro_lsb: [
                        (gyro[0] * 1e4) as i16,
                        (gyro[1] * 1e4) as i16,
                        (gyro[2] * 1e4) as i16,
                    ],
                };
                self.sample = Some((raw, s));
            }
            Event::Encoder { hw, .. } => self.hw = hw,
            _ => {}
        }
    }
}

impl Imu for Sensors {
    fn read(&mut self) -> crate::tasks::Reading {
        self.reads = self.reads.wrapping_add(1);
        // A distinct raw word per read (the held sample would otherwise
        // look stuck to the data monitor); never a full-scale value.
        let n = (self.reads % 30_000) as i16;
        Ok(self.sample.map(|(mut raw, s)| {
            raw.accel_lsb[2] = n;
            (raw, s)
        }))
    }
}

impl Encoder for Sensors {
    fn count(&mut self) -> u16 {
        self.hw
    }
}

impl Motor for Sensors {
    fn set(&mut self, duty: f32) {
        self.duty = duty;
    }
}

/// The outcome of navigation now.
pub fn outcome(nav: &Navigator<'_>) -> Outcome {
    match nav.nav() {
        Some(n) if nav.mode() == crate::navigation::Mode::Navigating => {
            let s = n.state();
            Outcome {
                mode: 3,
                p_n: [s.p_n.x, s.p_n.y, s.p_n.z],
                v_n: [s.v_n.x, s.v_n.y, s.v_n.z],
            }
        }
        _ => Outcome {
            mode: nav.mode().code(),
            ..Outcome::default()
        },
    }
}

/// Records the boot's journal holds beyond what it can take before it
/// moves on: [`crate::record::LOW_WATER`] slots or fewer left.
fn records_to_fill(sector: crate::record::Sector) -> u32 {
    let slots = sector.len / protocol::record::RECORD_LEN as u32;
    slots.saturating_sub(crate::record::LOW_WATER) + 1
}

/// Writes into `f` the journal a board configured by `commands` (applied
/// to the factory configuration, as the link takes them) has left after
/// many configurations: the resulting configuration stored, its active
/// sector nearly full, so the boot that opens it moves the journal to the
/// other sector and erases both (the boot the datasheet's erase times
/// make longest). The QEMU build and its host twin boot from it, with the
/// sensors running from reset; the host's commands, sent again, change
/// nothing (the configuration and the scheme are the ones in use).
///
/// # Errors
/// The flash refused a write.
pub fn stored_journal<F: crate::record::Flash>(
    f: &mut F,
    sectors: [crate::record::Sector; 2],
    commands: impl IntoIterator<Item = protocol::Command>,
    limits: core_nav::scheme::Limits,
) -> Result<protocol::record::BoardConfig, crate::record::FlashError> {
    let mut link = crate::link::Link::new(crate::tasks::FACTORY, limits);
    for c in commands {
        link.apply(c);
    }
    let cfg = link.config;
    let mut j = crate::record::Journal::open(f, sectors)?;
    let [first, _] = sectors;
    for _ in 0..records_to_fill(first) {
        j.write(cfg, None)?;
        while j.step(f)? {}
    }
    Ok(cfg)
}

/// The board's tuning for a replay: the compiled one, with the replay's
/// encoder and, when it is aided, its filter (the recording's sensor
/// profile, as `rins navigate --gnss` takes it).
pub fn tuning(h: &Header, mut t: Tuning) -> Tuning {
    t.control.counts_per_rev = h.counts_per_rev;
    if let Some((_, cfg)) = h.aided {
        t.filter = cfg;
    }
    t
}

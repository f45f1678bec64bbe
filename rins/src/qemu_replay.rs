//! The QEMU test's input (`rins qemu-replay`): a recording turned into the
//! board's input stream, in time order: the host's configuration commands
//! (site, base, scheme, aided mode: the ones `rins record --like` sends),
//! IMU samples, 16-bit encoder reads and, on a moving-base recording, GNSS
//! fixes at their time of validity. The trailer is left for the board's
//! host twin (`cargo run -p rins-tests --bin board-twin`), which runs the
//! board's program on the stream: `rins` does not contain the board.
//!
//! A moving-base recording with `gnss.csv` configures the board for aided
//! navigation (the filter's noise model from the recording's sensor
//! profile, as `rins navigate --gnss` takes it); each fix carries its own
//! time of validity and is sent [`FIX_LATENCY_US`] later.

use anyhow::{anyhow, bail, Result};
use core_nav::table::EncoderScale;
use protocol::replay::{encode, encode_outcome, Event, Header, Outcome, HEADER, RECORD_MAX};
use recording::Recording;

/// How long after its time of validity a fix reaches the board in the
/// replay, µs (a receiver's 50-100 ms and a relay's, well inside the
/// board's horizon of 400 ms).
pub const FIX_LATENCY_US: u32 = 150_000;

/// The stream.
pub struct Replay {
    /// The bytes the QEMU build reads (header, records, an empty trailer
    /// for the host twin to fill).
    pub bytes: Vec<u8>,
    /// Events in the stream.
    pub events: usize,
    /// Configuration commands in it.
    pub commands: usize,
}

/// Builds the replay of `rec` for a board whose encoder has
/// `counts_per_rev` counts per turn. The board's scheme rate is the table's
/// last steady rate, rounded to 0.1 deg/s.
///
/// # Errors
/// A table that never turns (the board's calibration needs rotation), a
/// sensor profile the recording does not name.
pub fn build(rec: &Recording, counts_per_rev: u32) -> Result<Replay> {
    let m = &rec.meta;
    let rate = match rec
        .table
        .windows(2)
        .rev()
        .find(|w| w[1].angle_rad != w[0].angle_rad)
    {
        Some(w) => w[0].rate_to(&w[1]),
        None => bail!("the table never turns: the board's calibration needs rotation"),
    };
    let mut header = Header {
        records: 0,
        lat_deg: m.latitude_deg,
        height_m: m.height_m,
        base_deg: [m.roll_deg, m.pitch_deg, m.heading_deg],
        rate_radps: (rate.to_degrees() * 10.0).round().to_radians() / 10.0,
        counts_per_rev,
        aided: None,
        commands: 0,
        fix_latency_us: FIX_LATENCY_US,
    };
    let mut fixes = Vec::new();
    if let Some(g) = rec
        .moving
        .as_ref()
        .and_then(|mv| mv.gnss.as_ref().map(|g| (mv, g)))
    {
        let (mv, gnss) = g;
        let opt = crate::aided::AidedOptions {
            f32: true,
            ..crate::aided::AidedOptions::new(crate::aided::profile(rec, None)?)
        };
        let lever = mv.gnss_meta.map_or([0.0; 3], |g| g.antenna_b_m);
        header.aided = Some((
            mv.longitude_deg,
            crate::aided::aided_config(
                m.axis,
                lever,
                &opt,
                m.imu_rate_hz,
                EncoderScale::new(counts_per_rev).read_sigma_rad(),
            ),
        ));
        // Each fix at its own time of validity (the relay, `rins record
        // --gnss`, sends the same times): the board applies it from the
        // state stored nearest that time.
        for f in gnss {
            if f.t_s >= 0.0 {
                fixes.push(Event::Gnss {
                    t_us: (f.t_s * 1e6).round() as u64,
                    fix: f.to_fix(),
                });
            }
        }
    }
    let scale = EncoderScale::new(counts_per_rev);
    let commands = crate::link::config_commands(rec, header.rate_radps);
    let mut events: Vec<Event> = commands
        .iter()
        .filter_map(Event::command)
        .chain(rec.imu.iter().map(|r| Event::Imu {
            t_us: (r.t_s * 1e6).round() as u64,
            gyro: r.gyro_radps.map(|x| x as f32),
            accel: r.accel_mps2.map(|x| x as f32),
            temp: r.temp_c.unwrap_or(25.0) as f32,
        }))
        .chain(rec.table.iter().map(|r| Event::Encoder {
            t_us: (r.t_s * 1e6).round() as u64,
            hw: EncoderScale::hw_count(scale.count_nearest(r.angle_rad)),
        }))
        .chain(fixes)
        .collect();
    // The commands first; then by time: encoder, fix, IMU sample.
    events.sort_by_key(|e| match e {
        Event::Command { .. } => (0, 0),
        Event::Imu { t_us, .. } => (*t_us, 3),
        Event::Gnss { t_us, .. } => (*t_us, 2),
        Event::Encoder { t_us, .. } => (*t_us, 1),
    });
    header.commands = u32::try_from(commands.len()).map_err(|_| anyhow!("too many commands"))?;
    header.records = u32::try_from(events.len()).map_err(|_| anyhow!("too many events"))?;
    let mut bytes = Vec::with_capacity(HEADER + events.len() * RECORD_MAX + 32);
    bytes.extend_from_slice(&header.encode());
    for e in &events {
        let mut r = [0u8; RECORD_MAX];
        let n = encode(e, &mut r);
        bytes.extend_from_slice(&r[..n]);
    }
    bytes.extend_from_slice(&encode_outcome(&Outcome {
        mode: NOT_RUN,
        ..Outcome::default()
    }));
    Ok(Replay {
        bytes,
        events: events.len(),
        commands: commands.len(),
    })
}

/// The trailer's mode before the host twin has run the stream.
pub const NOT_RUN: u8 = 0xFF;

//! The QEMU test's input (`rins qemu-replay`): a recording turned into the
//! board's input stream (IMU samples, 16-bit encoder reads and, on a
//! moving-base recording, GNSS fixes as command frames, in time order),
//! run through the board's logic on the host; the host's outcome goes in
//! the trailer for the QEMU build to compare with, bit for bit.
//!
//! A moving-base recording with `gnss.csv` configures the board for aided
//! navigation (the filter's noise model from the recording's sensor
//! profile, as `rins navigate --gnss` takes it); each fix arrives just
//! before the IMU sample nearest its time, the sample `rins navigate
//! --gnss` uses it at.

use anyhow::{anyhow, bail, Result};
use core_nav::table::EncoderScale;
use firmware::app::{App, Mode};
use firmware::replay::{
    encode, encode_outcome, outcome, step, Event, Header, Outcome, HEADER, RECORD_MAX,
};
use recording::Recording;

/// The stream and what the host's run of it came to.
pub struct Replay {
    /// The bytes the QEMU build reads (header, records, outcome trailer).
    pub bytes: Vec<u8>,
    /// Events in the stream.
    pub events: usize,
    /// The host's final state (the trailer).
    pub outcome: Outcome,
    /// The board logic's mode at the end.
    pub mode: Mode,
    /// What the board's aided navigator counted (aided replays).
    pub aided: Option<core_nav::aided::AidedCounts>,
}

/// Builds the replay of `rec` for a board whose encoder has
/// `counts_per_rev` counts per turn. The board's scheme rate is the table's
/// last steady rate, rounded to 0.1 deg/s.
///
/// # Errors
/// A table that never turns (the board's calibration needs rotation), a
/// configuration the board refuses, or a run that does not reach
/// navigation.
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
    };
    let mut fixes = Vec::new();
    if let Some(g) = rec
        .moving
        .as_ref()
        .and_then(|mv| mv.gnss.as_ref().map(|g| (mv, g)))
    {
        let (mv, gnss) = g;
        let opt = crate::aided::AidedOptions {
            profile: crate::aided::profile(rec, None)?,
            zupt: true,
            gate_sigma: 6.0,
            f32: true,
        };
        let lever = mv.gnss_meta.map_or([0.0; 3], |g| g.antenna_b_m);
        header.aided = Some((
            mv.longitude_deg,
            crate::aided::aided_config(m.axis, lever, &opt),
        ));
        // Each fix just before the first IMU sample at or after its time
        // less half a sample period (the nearest), as `navigate --gnss`.
        let half = 0.5 / m.imu_rate_hz;
        let mut k = 0usize;
        for f in gnss {
            while rec.imu.get(k).is_some_and(|r| r.t_s < f.t_s - half) {
                k += 1;
            }
            let Some(r) = rec.imu.get(k).filter(|r| r.t_s <= f.t_s + half) else {
                continue;
            };
            fixes.push(Event::Gnss {
                t_us: (r.t_s * 1e6).round() as u64,
                fix: f.to_fix(),
            });
        }
    }
    let scale = EncoderScale::new(counts_per_rev);
    let cfg = header.config();
    let mut events: Vec<Event> = rec
        .imu
        .iter()
        .map(|r| Event::Imu {
            t_us: (r.t_s * 1e6).round() as u64,
            gyro: r.gyro_radps.map(|x| x as f32),
            accel: r.accel_mps2.map(|x| x as f32),
            temp: r.temp_c.unwrap_or(25.0) as f32,
        })
        .chain(rec.table.iter().map(|r| Event::Encoder {
            t_us: (r.t_s * 1e6).round() as u64,
            hw: EncoderScale::hw_count(scale.count_nearest(r.angle_rad)),
        }))
        .chain(fixes)
        .collect();
    // Encoder, then a fix, then the IMU sample at the same time (the board
    // reads the encoder first; a fix waits for the next sample).
    events.sort_by_key(|e| match e {
        Event::Imu { t_us, .. } => (*t_us, 2),
        Event::Gnss { t_us, .. } => (*t_us, 1),
        Event::Encoder { t_us, .. } => (*t_us, 0),
    });
    let mut app =
        App::new(cfg).map_err(|e| anyhow!("the board refuses the configuration: {e:?}"))?;
    let mut bytes = Vec::with_capacity(HEADER + events.len() * RECORD_MAX + 32);
    header.records = u32::try_from(events.len()).map_err(|_| anyhow!("too many events"))?;
    bytes.extend_from_slice(&header.encode());
    for e in &events {
        step(&mut app, e);
        let mut r = [0u8; RECORD_MAX];
        let n = encode(e, &mut r);
        bytes.extend_from_slice(&r[..n]);
    }
    let o = outcome(&app);
    bytes.extend_from_slice(&encode_outcome(&o));
    if o.mode != 3 {
        bail!(
            "the board's logic did not reach navigation on this recording (mode {:?}, last refusal {:?})",
            app.mode,
            app.last_refusal
        );
    }
    Ok(Replay {
        bytes,
        events: events.len(),
        outcome: o,
        mode: app.mode,
        aided: app.aided().map(|a| a.counts),
    })
}

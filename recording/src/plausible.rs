//! Samples a sensor cannot have given: beyond its full scale, a spike no
//! neighbour shares, a channel stuck on one value. Found here, once, for
//! every tool that reads samples (`navigate`, `calibrate`, `diagnose`),
//! each named by its time and data row; the tools exclude them (counted
//! and said) or take them when told to.
//!
//! - **Full scale**: `|x|` above the sensor's range (a datasheet figure
//!   the caller gives; a reading at the rail is the rail, a reading beyond
//!   it is not a reading).
//! - **Spike**: the sample's distance from the mean of its two neighbours
//!   over [`SPIKE_SIGMAS`] robust sigmas of that same second difference,
//!   both over the whole channel and over the [`SPIKE_LOCAL`] samples
//!   each side (its median absolute deviation / 0.6745: a hand's jolt
//!   while walking is large against a still channel's noise, not against
//!   its own stride's), and its neighbours within that of each other (a
//!   step, a turn starting, is not a spike).
//! - **Stuck**: a run of equal readings at least [`STUCK_SAMPLES`] long
//!   and [`STUCK_OVER_P99`] times the channel's own 99th-percentile run,
//!   on a channel whose readings otherwise change nearly every sample
//!   (its median run under 3): a noisy sensor does not repeat itself for a
//!   second. A coarse quantiser's channel sitting inside one step repeats
//!   for long runs all along (the real MPU-6050 recording's 10 mg steps:
//!   103 equal readings in a row), and a noise-free simulated one repeats
//!   throughout; neither is flagged.

use crate::{ImuRow, Recording};

/// Robust sigmas of the second difference beyond which a lone sample is a
/// spike.
pub const SPIKE_SIGMAS: f64 = 30.0;
/// Samples each side whose scatter a spike must also stand out of.
pub const SPIKE_LOCAL: usize = 50;
/// Equal readings in a row that make a stuck channel, at least.
pub const STUCK_SAMPLES: usize = 100;
/// A stuck run is this many times the channel's 99th-percentile run.
pub const STUCK_OVER_P99: f64 = 10.0;

/// The channels' names as in `imu.csv` (its columns after `t_s`).
pub fn channel_name(ch: usize) -> &'static str {
    crate::IMU_COLS.get(ch + 1).copied().unwrap_or("?")
}

/// What is wrong with a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// Beyond the sensor's full scale (the scale, in the channel's unit).
    BeyondFullScale(f64),
    /// A lone spike (its robust sigmas).
    Spike(f64),
    /// One of a run of equal readings (the run's length).
    Stuck(usize),
}

/// One implausible reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Implausible {
    /// Index into `imu.csv`'s data rows (0-based).
    pub row: usize,
    /// Its time, s.
    pub t_s: f64,
    /// The channel (0-2 gyro x-z, 3-5 accelerometer x-z: [`channel_name`]).
    pub channel: usize,
    /// The reading.
    pub value: f64,
    /// Why.
    pub kind: Kind,
}

impl std::fmt::Display for Implausible {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = channel_name(self.channel);
        let with_unit = |v: f64| {
            if self.channel < 3 {
                format!(
                    "{v} rad/s ({} deg/s)",
                    crate::figures::sig(v.to_degrees(), 3)
                )
            } else {
                // Standard gravity, the g of the book's units table.
                format!("{v} m/s^2 ({} g)", crate::figures::sig(v / 9.806_65, 3))
            }
        };
        write!(
            f,
            "imu.csv data row {} (t = {} s): {name} = {}, ",
            self.row + 1,
            self.t_s,
            with_unit(self.value)
        )?;
        match self.kind {
            Kind::BeyondFullScale(fs) => {
                write!(f, "beyond the sensor's full scale {}", with_unit(fs))
            }
            Kind::Spike(s) => write!(f, "a spike {s:.0} robust sigmas off its neighbours"),
            Kind::Stuck(n) => write!(f, "stuck: one of {n} equal readings in a row"),
        }
    }
}

fn value(r: &ImuRow, ch: usize) -> f64 {
    match ch {
        0..=2 => r.gyro_radps[ch],
        _ => r.accel_mps2[ch - 3],
    }
}

/// The implausible readings of `rec`, in row order; `full_scale` is the
/// gyros' (rad/s) and the accelerometers' (m/s^2) range when known. A
/// gyro-only recording's missing accelerometer channels are skipped.
pub fn check(rec: &Recording, full_scale: Option<(f64, f64)>) -> Vec<Implausible> {
    let mut out = vec![];
    for ch in 0..6 {
        let x: Vec<f64> = rec.imu.iter().map(|r| value(r, ch)).collect();
        if x.iter().all(|v| v.is_nan()) {
            continue;
        }
        let fs = full_scale.map(|(g, a)| if ch < 3 { g } else { a });
        let mut add = |row: usize, kind: Kind| {
            out.push(Implausible {
                row,
                t_s: rec.imu[row].t_s,
                channel: ch,
                value: x[row],
                kind,
            })
        };
        if let Some(fs) = fs.filter(|f| *f > 0.0) {
            for (k, v) in x.iter().enumerate() {
                if v.abs() > fs * (1.0 + 1e-6) {
                    add(k, Kind::BeyondFullScale(fs));
                }
            }
        }
        for (k, s) in spikes(&x) {
            add(k, Kind::Spike(s));
        }
        for (k, n) in stuck(&x) {
            add(k, Kind::Stuck(n));
        }
    }
    out.sort_by(|a, b| a.row.cmp(&b.row).then(a.channel.cmp(&b.channel)));
    out.dedup_by(|a, b| a.row == b.row && a.channel == b.channel);
    out
}

/// Lone spikes: (row, robust sigmas).
fn spikes(x: &[f64]) -> Vec<(usize, f64)> {
    if x.len() < 5 {
        return vec![];
    }
    let d2: Vec<f64> = x.windows(3).map(|w| w[1] - 0.5 * (w[0] + w[2])).collect();
    let robust = |d: &[f64]| {
        let mut abs: Vec<f64> = d
            .iter()
            .map(|d| d.abs())
            .filter(|d| d.is_finite())
            .collect();
        core_nav::stats::median(&mut abs) / 0.6745
    };
    let sigma = robust(&d2);
    if sigma.is_nan() || sigma <= 0.0 {
        return vec![];
    }
    d2.iter()
        .enumerate()
        .filter_map(|(i, d)| {
            let s = d.abs() / sigma;
            let (a, b) = (x[i], x[i + 2]);
            if !(s > SPIKE_SIGMAS && (a - b).abs() < SPIKE_SIGMAS * sigma) {
                return None;
            }
            let near = |lo: usize, hi: usize| d2.get(lo..hi).unwrap_or(&[]);
            let local: Vec<f64> = near(i.saturating_sub(SPIKE_LOCAL), i)
                .iter()
                .chain(near(i + 1, (i + 1 + SPIKE_LOCAL).min(d2.len())))
                .copied()
                .collect();
            let ls = robust(&local);
            (ls.is_nan() || ls <= 0.0 || d.abs() > SPIKE_SIGMAS * ls).then_some((i + 1, s))
        })
        .collect()
}

/// Rows in runs of [`STUCK_SAMPLES`] or more equal readings, on a channel
/// whose median run is under 3: (row, run length).
fn stuck(x: &[f64]) -> Vec<(usize, usize)> {
    let mut runs: Vec<(usize, usize)> = vec![];
    let mut start = 0;
    for k in 1..=x.len() {
        if k == x.len() || x[k] != x[start] {
            runs.push((start, k - start));
            start = k;
        }
    }
    let mut lens: Vec<f64> = runs.iter().map(|r| r.1 as f64).collect();
    if core_nav::stats::median(&mut lens) >= 3.0 {
        return vec![];
    }
    let p99 = core_nav::stats::percentile(&mut lens, 99.0);
    let least = (STUCK_SAMPLES as f64).max(STUCK_OVER_P99 * p99);
    // A run is stuck only among noise: next to a smooth, noise-free
    // stretch (a simulation without noise, still then turning) it is the
    // signal, not a hold.
    let around = |s: usize, n: usize| {
        let before = x.get(s.saturating_sub(STUCK_SAMPLES)..s).unwrap_or(&[]);
        let after = x
            .get(s + n..(s + n + STUCK_SAMPLES).min(x.len()))
            .unwrap_or(&[]);
        noisy(before) || noisy(after)
    };
    runs.iter()
        .filter(|(s, n)| *n as f64 >= least && around(*s, *n))
        .flat_map(|&(s, n)| (s..s + n).map(move |k| (k, n)))
        .collect()
}

/// Whether `x` scatters as noise does: its second differences as large as
/// its first on average (white noise: sqrt(3) times; a smooth signal
/// sampled fast: far smaller), with at least one change.
fn noisy(x: &[f64]) -> bool {
    let mean_abs = |d: &mut dyn Iterator<Item = f64>| {
        let (s, n) = d.fold((0.0, 0usize), |(s, n), v| (s + v.abs(), n + 1));
        s / n.max(1) as f64
    };
    let d1 = mean_abs(&mut x.windows(2).map(|w| w[1] - w[0]));
    let d2 = mean_abs(&mut x.windows(3).map(|w| w[2] - 2.0 * w[1] + w[0]));
    d1 > 0.0 && d2 > NOISE_D2_OVER_D1 * d1
}

/// The least ratio of mean absolute second to first difference a noisy
/// stretch shows (white noise's is sqrt(3); a table turning at 30 deg/s
/// sampled at 100 Hz: 0.005).
const NOISE_D2_OVER_D1: f64 = 0.3;

/// `rec` with each implausible reading replaced by the channel's last
/// plausible one before it (the first after it when none precedes; kept
/// when the channel has none) (the sample kept, so time stays even), and
/// how many readings were replaced.
pub fn excluded(rec: &Recording, bad: &[Implausible]) -> (Recording, usize) {
    let mut out = rec.clone();
    for b in bad {
        let prev = (0..b.row)
            .rev()
            .find(|k| !bad.iter().any(|o| o.row == *k && o.channel == b.channel));
        // None before it (the run starts the recording): the first one
        // after; none at all: the reading as it is (never a NaN).
        let next = || {
            (b.row + 1..rec.imu.len())
                .find(|k| !bad.iter().any(|o| o.row == *k && o.channel == b.channel))
        };
        let v = prev
            .or_else(next)
            .map_or(b.value, |k| value(&rec.imu[k], b.channel));
        if let Some(r) = out.imu.get_mut(b.row) {
            match b.channel {
                0..=2 => r.gyro_radps[b.channel] = v,
                c => r.accel_mps2[c - 3] = v,
            }
        }
    }
    (out, bad.len())
}

/// Values a lattice is looked for in (the first ones of a channel).
const LATTICE_VALUES: usize = 50_000;
/// The fewest distinct values a lattice is read from (a still sensor
/// whose noise is under its LSB sits on a handful of levels).
const LATTICE_LEVELS: usize = 4;

/// The step of the lattice a channel's values `x` lie on (an ADC's LSB
/// in the channel's unit, as printed): the mean of the single-step gaps
/// between distinct values (those under 1.5 times the smallest; a
/// printout rounded to fewer digits than the LSB makes them uneven, their
/// mean is the step), refined by least squares on the levels' indices;
/// `Some` if at least 99 % of the distinct values (at least
/// [`LATTICE_LEVELS`] of them) sit within 15 % of a step of the lattice (a print rounding of up to a
/// tenth of a step passes, values off any lattice do not: a simulated
/// float, a filtered or rescaled output).
pub fn lattice(x: &[f64]) -> Option<f64> {
    let mut v: Vec<f64> = x
        .iter()
        .take(LATTICE_VALUES)
        .copied()
        .filter(|x| x.is_finite())
        .collect();
    v.sort_by(f64::total_cmp);
    let scale = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let eps = 1e-9 * scale.max(f64::MIN_POSITIVE);
    v.dedup_by(|a, b| (*a - *b).abs() <= eps);
    if v.len() < LATTICE_LEVELS {
        return None;
    }
    let gaps: Vec<f64> = v
        .windows(2)
        .filter_map(|w| Some(w.get(1)? - w.first()?))
        .collect();
    let smallest = gaps.iter().copied().fold(f64::INFINITY, f64::min);
    let single: Vec<f64> = gaps
        .iter()
        .copied()
        .filter(|g| *g < 1.5 * smallest)
        .collect();
    let mut step = single.iter().sum::<f64>() / single.len().max(1) as f64;
    let v0 = *v.first()?;
    let index = |x: f64, step: f64| ((x - v0) / step).round();
    for _ in 0..3 {
        // Least squares of v = v0 + a + step k over the levels.
        let n = v.len() as f64;
        let ks: Vec<f64> = v.iter().map(|x| index(*x, step)).collect();
        let (mk, mv) = (ks.iter().sum::<f64>() / n, v.iter().sum::<f64>() / n);
        let (mut skv, mut skk) = (0.0, 0.0);
        for (k, x) in ks.iter().zip(&v) {
            skv += (k - mk) * (x - mv);
            skk += (k - mk) * (k - mk);
        }
        if skk > 0.0 {
            step = skv / skk;
        }
    }
    let on = v
        .iter()
        .filter(|x| {
            let r = (*x - v0) / step;
            (r - r.round()).abs() < 0.15
        })
        .count();
    (step.is_finite() && step > eps && on as f64 >= 0.99 * v.len() as f64).then_some(step)
}

/// The rail a channel's values `x` clip at: the largest `|x|` when the
/// readings pile up there (at least 5 of them, and twice as many as at
/// the next value in), a sensor held at its full scale; `None` otherwise
/// (no reading reached the rail: the largest is only a lower bound).
pub fn clipped_at(x: &[f64]) -> Option<f64> {
    let top = x
        .iter()
        .filter(|x| x.is_finite())
        .fold(0.0f64, |m, x| m.max(x.abs()));
    if top <= 0.0 {
        return None;
    }
    let eps = 1e-9 * top;
    for sign in [1.0, -1.0] {
        let rail = sign * top;
        let at = x.iter().filter(|x| (**x - rail).abs() <= eps).count();
        let next = x
            .iter()
            .filter(|x| sign * **x < top - eps)
            .fold(f64::NEG_INFINITY, |m, x| m.max(sign * x));
        let before = x
            .iter()
            .filter(|x| (sign * **x - next).abs() <= eps)
            .count();
        if at >= 5 && at >= 2 * before {
            return Some(top);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec_with(gz: impl Fn(usize) -> f64, n: usize) -> Recording {
        let mut r = Recording::default();
        for k in 0..n {
            // A noisy channel: a fixed pseudo-random walk of small steps.
            let noise = ((k * 7919) % 101) as f64 * 1e-4;
            r.imu.push(ImuRow {
                t_s: k as f64 * 0.01,
                gyro_radps: [noise, -noise, gz(k)],
                accel_mps2: [noise, noise, -9.8 + noise],
                temp_c: None,
            });
        }
        r
    }

    #[test]
    fn a_reading_beyond_full_scale_and_a_lone_spike_are_named() {
        let noise = |k: usize| ((k * 7919) % 101) as f64 * 1e-4;
        let r = rec_with(|k| if k == 500 { 50.0 } else { 0.5 + noise(k) }, 1000);
        let bad = check(&r, Some((34.9, 156.9)));
        assert!(bad
            .iter()
            .any(|b| b.row == 500 && b.channel == 2 && matches!(b.kind, Kind::BeyondFullScale(_))));
        let bad = check(&r, None);
        assert_eq!(bad.len(), 1, "{bad:?}");
        assert!(matches!(bad[0].kind, Kind::Spike(_)));
        assert!(bad[0].to_string().contains("data row 501"), "{}", bad[0]);
        // A step (a turn starting) is not a spike.
        let step = rec_with(|k| if k < 500 { noise(k) } else { 0.5 + noise(k) }, 1000);
        assert!(check(&step, None).is_empty());
        let (fixed, n) = excluded(&r, &check(&r, None));
        assert_eq!(n, 1);
        assert_eq!(fixed.imu[500].gyro_radps[2], r.imu[499].gyro_radps[2]);
    }

    #[test]
    fn a_stuck_channel_is_found_and_a_noise_free_one_is_not() {
        let noise = |k: usize| ((k * 7919) % 101) as f64 * 1e-4;
        let r = rec_with(
            |k| {
                if (300..450).contains(&k) {
                    0.25
                } else {
                    noise(k)
                }
            },
            1000,
        );
        let bad = check(&r, None);
        assert_eq!(bad.len(), 150, "{bad:?}");
        assert!(bad.iter().all(|b| b.kind == Kind::Stuck(150)));
        let ideal = rec_with(|_| 0.5, 1000);
        assert!(check(&ideal, None).is_empty());
    }

    #[test]
    fn a_noise_free_still_start_then_turning_is_not_stuck() {
        // `simulate --ideal`: 1200 equal readings still, then the table
        // turning (a smooth sinusoid): the signal, not a hold.
        let ideal = |k: usize| match k < 1200 {
            true => 7.29e-5,
            false => 7.29e-5 + 0.5 * ((k - 1200) as f64 * 0.005).sin(),
        };
        let r = rec_with(ideal, 5000);
        let bad: Vec<_> = check(&r, None)
            .into_iter()
            .filter(|b| b.channel == 2)
            .collect();
        assert!(bad.is_empty(), "{:?}", bad.first());
        // A hold at the very start of a noisy channel is stuck, and its
        // replacement (no reading before it) is the first after, never NaN.
        let noise = |k: usize| ((k * 7919) % 101) as f64 * 1e-4;
        let r = rec_with(|k| if k < 150 { 0.25 } else { noise(k) }, 1000);
        let bad = check(&r, None);
        assert_eq!(bad.len(), 150, "{:?}", bad.first());
        let (fixed, _) = excluded(&r, &bad);
        assert!(fixed.imu.iter().all(|x| x.gyro_radps[2].is_finite()));
        assert_eq!(fixed.imu[0].gyro_radps[2], noise(150));
    }

    #[test]
    fn a_lattice_is_found_on_quantised_values_and_not_on_floats() {
        // An MPU-6050's accelerometer at +-2 g: 1/16384 g steps.
        let lsb = 9.80665 / 16384.0;
        let q: Vec<f64> = (0..5000)
            .map(|k| ((k as f64 * 0.37).sin() * 40.0).round() * lsb + 3.0 * lsb)
            .collect();
        let found = lattice(&q).unwrap();
        assert!((found / lsb - 1.0).abs() < 1e-9, "{found}");
        let floats: Vec<f64> = (0..5000).map(|k| (k as f64 * 0.37).sin() * 0.01).collect();
        assert_eq!(lattice(&floats), None);
        // The real MPU-6050 log's gyro: 1/16.4 deg/s counts printed to
        // 0.01 deg/s (gaps of 0.06 and 0.07): the count's step, to 1 %.
        let printed: Vec<f64> = (0..5000)
            .map(|k| ((((k as f64 * 0.37).sin() * 300.0).round() / 16.4) * 100.0).round() / 100.0)
            .collect();
        let found = lattice(&printed).unwrap();
        assert!((found * 16.4 - 1.0).abs() < 0.01, "{found}");
        // Clipping: readings piled up at the rail; none for a quiet channel
        // whose extreme level is simply rare.
        let clipped: Vec<f64> = (0..1000)
            .map(|k| ((k as f64 * 0.05).sin() * 300.0).clamp(-250.0, 250.0))
            .collect();
        assert_eq!(clipped_at(&clipped), Some(250.0));
        assert_eq!(clipped_at(&q), None);
    }
}

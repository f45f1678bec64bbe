//! Sample times that are arrival times: the one home of putting a
//! sensor's samples back on its own regular clock.
//!
//! A sensor samples on its own regular clock; a logger that stamps each
//! sample when it arrives sees it some time later, never earlier. Polled
//! faster than the sensor, the lag is under a poll interval; delivered in
//! bursts (a USB or Bluetooth link, a FIFO read every 50 ms) it is up to a
//! burst's length, and the stamps then break into pieces a few samples
//! long that no Allan difference or regression block may straddle.
//!
//! When no sample was lost, the `k`-th sample was made at `a + p k`: the
//! least-squares line through the stamps gives the period `p`; the
//! stamps' lags about the line have a floor (the last sample of each
//! burst, delivered at once) that stays flat along the run. A lost sample
//! shifts every later index by one and so steps that floor by one period:
//! a floor that moves by half a period or more is refused, with the
//! longest gap-free span. The samples' instants are the line lowered to
//! the floor (a sample is never seen before it is made).

use crate::segments;
#[cfg(doc)]
use crate::GAP_PERIODS;

/// The floor of the lags is taken over windows of this many periods
/// (each holds several bursts of a logger that delivers in bursts).
pub const FLOOR_WINDOW_PERIODS: usize = 100;

/// The samples on the sensor's regular clock.
#[derive(Clone, Debug, PartialEq)]
pub struct Regular {
    /// The samples' instants, s (the stamps' clock).
    pub t_s: Vec<f64>,
    /// The sensor's period on the stamps' clock, s.
    pub period_s: f64,
    /// The stamps' mean lag behind the instants and their largest, s.
    pub mean_lag_s: f64,
    /// See `mean_lag_s`.
    pub max_lag_s: f64,
}

/// Why the stamps cannot be put on a regular clock, with the figures a
/// person needs.
#[derive(Clone, Debug, PartialEq)]
pub struct Irregular {
    /// How far the lags' floor moves along the run, s.
    pub floor_moves_s: f64,
    /// Where it has moved furthest from its start, s.
    pub at_s: f64,
    /// The sensor's period, s.
    pub period_s: f64,
    /// The longest gap-free span (no interval over [`GAP_PERIODS`]
    /// periods): first and last stamp, s.
    pub longest_span_s: [f64; 2],
    /// The first and last stamp, s.
    pub stamps_s: [f64; 2],
}

impl core::fmt::Display for Irregular {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        // Times from the first stamp (a log stamped in epoch seconds reads
        // as its own minutes).
        let [t0, t1] = self.stamps_s;
        let [a, b] = self.longest_span_s.map(|t| t - t0);
        write!(
            f,
            "the stamps are not a regular clock seen late: their earliest lag moves by {:.1} ms (near {:.1} s from the first stamp), more than half the sensor's period ({:.2} ms): ",
            self.floor_moves_s * 1e3,
            self.at_s - t0,
            self.period_s * 1e3,
        )?;
        match (b - a) >= 0.99 * (t1 - t0) {
            true => write!(
                f,
                "no sample is missing by the stamps (no gap in the whole {:.2} s), so the sensor's clock wanders against the logger's: these stamps are not arrival times on one regular clock; take them as they are (drop [time] regular)",
                t1 - t0
            ),
            false => write!(
                f,
                "samples were lost or the sensor's clock is not regular; the longest gap-free span is {:.2} s ({a:.2}-{b:.2} s from the first stamp)",
                b - a
            ),
        }
    }
}

impl std::error::Error for Irregular {}

/// The longest run of `t_s` without a gap of [`GAP_PERIODS`] nominal
/// periods `dt_s`: its first and last time, s.
pub fn longest_gap_free(t_s: &[f64], dt_s: f64) -> [f64; 2] {
    segments(t_s, dt_s)
        .iter()
        .max_by_key(|s| s.len())
        .and_then(|s| Some([*t_s.get(s.start)?, *t_s.get(s.end.checked_sub(1)?)?]))
        .unwrap_or([0.0, 0.0])
}

/// Whether `t_s` (s) already is a regular clock at the nominal period
/// `dt_s`: one gap-free run.
pub fn is_gap_free(t_s: &[f64], dt_s: f64) -> bool {
    segments(t_s, dt_s).len() <= 1
}

/// The samples stamped at `t_s` (s, increasing; arrival times) put on
/// their sensor's regular clock (the module's rules).
///
/// # Errors
/// Fewer than two stamps, or a floor of the lags that moves by half a
/// period or more (samples lost, or not one regular clock).
pub fn regular(t_s: &[f64]) -> Result<Regular, Irregular> {
    let n = t_s.len();
    let (first, last) = match (t_s.first(), t_s.last()) {
        (Some(a), Some(b)) if n >= 2 && b > a => (*a, *b),
        _ => {
            return Err(Irregular {
                floor_moves_s: 0.0,
                at_s: 0.0,
                period_s: 0.0,
                longest_span_s: [0.0, 0.0],
                stamps_s: [0.0, 0.0],
            })
        }
    };
    let mk = (n as f64 - 1.0) / 2.0;
    let mt = t_s.iter().sum::<f64>() / n as f64;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (k, t) in t_s.iter().enumerate() {
        sxy += (k as f64 - mk) * (t - mt);
        sxx += (k as f64 - mk) * (k as f64 - mk);
    }
    let p = match sxy / sxx {
        p if p > 0.0 && p.is_finite() => p,
        _ => (last - first) / (n as f64 - 1.0),
    };
    let line = |k: usize| mt + p * (k as f64 - mk);
    let lag: Vec<f64> = t_s.iter().enumerate().map(|(k, t)| t - line(k)).collect();
    // The floor over each window, and how far it moves from the first.
    let floors: Vec<(f64, f64)> = lag
        .chunks(FLOOR_WINDOW_PERIODS)
        .enumerate()
        .map(|(j, w)| {
            let at = line(j * FLOOR_WINDOW_PERIODS);
            (w.iter().copied().fold(f64::INFINITY, f64::min), at)
        })
        .collect();
    let lo = floors.iter().map(|f| f.0).fold(f64::INFINITY, f64::min);
    let hi = floors.iter().map(|f| f.0).fold(f64::NEG_INFINITY, f64::max);
    let start = floors.first().map_or(0.0, |f| f.0);
    if hi - lo >= 0.5 * p {
        let at_s = floors
            .iter()
            .max_by(|a, b| (a.0 - start).abs().total_cmp(&(b.0 - start).abs()))
            .map_or(first, |f| f.1);
        return Err(Irregular {
            floor_moves_s: hi - lo,
            at_s,
            period_s: p,
            longest_span_s: longest_gap_free(t_s, p),
            stamps_s: [first, last],
        });
    }
    let lags: Vec<f64> = lag.iter().map(|l| l - lo).collect();
    Ok(Regular {
        t_s: (0..n).map(|k| line(k) + lo).collect(),
        period_s: p,
        mean_lag_s: lags.iter().sum::<f64>() / n as f64,
        max_lag_s: lags.iter().copied().fold(0.0, f64::max),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 10 ms samples made at `k * 0.01 + 0.003`, delivered in bursts:
    /// every `burst` samples arrive one after another 0.1 ms apart, the
    /// first 1 ms after the burst's last is made, stamped to 1 us.
    fn bursty(n: usize, burst: usize, lost_at: Option<usize>) -> Vec<f64> {
        let made: Vec<f64> = (0..n)
            .filter(|k| Some(*k) != lost_at)
            .map(|k| k as f64 * 0.01 + 0.003)
            .collect();
        (0..made.len())
            .map(|i| {
                let last = (i / burst + 1) * burst - 1;
                let t = made.get(last).copied().unwrap_or(made[made.len() - 1])
                    + 0.001
                    + 1e-4 * (i % burst) as f64;
                (t * 1e6).round() / 1e6
            })
            .collect()
    }

    #[test]
    fn bursts_go_back_on_the_sensors_clock() {
        let t = bursty(60_000, 5, None);
        assert!(!is_gap_free(&t, 0.01));
        let r = regular(&t).unwrap();
        // The period: the bursts' sawtooth leaves a least-squares slope
        // error of a burst over the run (50 ms / 600 s / 60,000 samples).
        assert!((r.period_s - 0.01).abs() < 1e-8, "{}", r.period_s);
        // Every instant within the floor's 1 ms delivery of the true one
        // (and the sawtooth's slope error, 50 ms / 60,000 at most).
        for (k, x) in r.t_s.iter().enumerate().step_by(997) {
            let truth = k as f64 * 0.01 + 0.003;
            assert!((x - truth).abs() < 2e-3, "{k}: {x} vs {truth}");
        }
        assert!(is_gap_free(&r.t_s, 0.01));
        // Lags up to the burst's four periods.
        assert!((0.035..0.046).contains(&r.max_lag_s), "{}", r.max_lag_s);
    }

    #[test]
    fn a_lost_sample_is_refused_with_the_longest_span() {
        let t = bursty(60_000, 5, Some(30_000));
        let e = regular(&t).unwrap_err();
        assert!(e.floor_moves_s >= 0.005, "{e:?}");
        assert!((e.at_s - 300.0).abs() < 300.0, "{e:?}");
        // Bursts of five 10 ms samples: the longest gap-free piece is one
        // burst (0.4 ms long) or two.
        assert!(e.longest_span_s[1] - e.longest_span_s[0] < 0.1, "{e:?}");
        assert!(e.to_string().contains("samples were lost"), "{e}");
    }

    #[test]
    fn bursts_that_share_one_stamp_go_back_on_the_sensors_clock() {
        // A logger that stamps each burst of five once, when it arrives.
        let t: Vec<f64> = (0..6000)
            .map(|k| ((k / 5 + 1) * 5) as f64 * 0.01 + 0.002)
            .collect();
        let r = regular(&t).unwrap();
        for (k, x) in r.t_s.iter().enumerate() {
            assert!((x - (k as f64 * 0.01 + 0.012)).abs() < 2e-3, "{k}: {x}");
        }
        assert!(is_gap_free(&r.t_s, 0.01));
    }

    #[test]
    fn a_wandering_clock_without_gaps_is_said_to_be_one_in_its_own_time() {
        // Epoch-second stamps of a sensor whose clock wanders 20 ms
        // against the logger's over ten minutes, no sample lost: nothing
        // is missing, the refusal says so and what to do, in seconds from
        // the first stamp.
        let t: Vec<f64> = (0..60_000)
            .map(|k| {
                let u = k as f64 * 0.01;
                1.6e9 + u + 0.02 * (u / 600.0 * core::f64::consts::PI).sin()
            })
            .collect();
        let e = regular(&t).unwrap_err().to_string();
        assert!(e.contains("no sample is missing"), "{e}");
        assert!(e.contains("drop [time] regular"), "{e}");
        assert!(!e.contains("1600000"), "{e}");
    }

    #[test]
    fn a_regular_clock_stays_as_it_is() {
        let t: Vec<f64> = (0..1000).map(|k| k as f64 * 0.01).collect();
        let r = regular(&t).unwrap();
        for (a, b) in r.t_s.iter().zip(&t) {
            assert!((a - b).abs() < 1e-9);
        }
        assert!(r.max_lag_s < 1e-9);
    }
}

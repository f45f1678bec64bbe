//! The one noise estimator: a channel's Allan curve and its noise fit
//! (core-nav's `allan`), as `rins allan` and diagnose's report both print
//! it.

use core::ops::Range;
use core_nav::allan::{fit_noise, oadev_segments, octave_factors, AdevPoint, NoiseFit};
use core_nav::units;

/// The channel names, in the recording's column order (recording-v1).
pub const CHANNELS: [&str; 6] = {
    let c = recording::IMU_COLS;
    [c[1], c[2], c[3], c[4], c[5], c[6]]
};

/// Octaves need at least this many second differences to be shown.
pub const MIN_TERMS: usize = 10;
/// The fit starts at this many sample periods: the first octaves are shaped
/// by the sensor's own anti-alias / decimation filter (seen on the ADIS16405).
pub const FIT_MIN_M: usize = 10;

/// The Allan curve of one channel's samples `y` (period `tau0_s`; no
/// difference straddles a gap between the `segments`, the rows sampled
/// without one: `recording::segment_ranges`) and its noise fit: the one
/// noise estimator `rins allan` and diagnose both print.
pub fn fit_channel(
    y: &[f64],
    tau0_s: f64,
    segments: &[Range<usize>],
) -> (Vec<AdevPoint>, NoiseFit) {
    let longest = segments
        .iter()
        .map(ExactSizeIterator::len)
        .max()
        .unwrap_or(0);
    let points: Vec<AdevPoint> = octave_factors(longest, MIN_TERMS)
        .filter_map(|m| oadev_segments(y, tau0_s, m, segments))
        .collect();
    let fitted: Vec<AdevPoint> = points
        .iter()
        .copied()
        .filter(|p| p.m >= FIT_MIN_M)
        .collect();
    let fit = fit_noise(if fitted.len() >= 3 { &fitted } else { &points }).unwrap_or_default();
    (points, fit)
}

/// One channel's noise terms as a person reads them, in the book's units
/// (gyro: deg/sqrt(h), deg/h; accelerometer: ug/sqrt(Hz), ug). A term the
/// curve cannot support is said to be not measured, never printed as a
/// number: white noise the fit did not hold, a floor the averaging times
/// do not reach (its bound given as such).
pub fn describe(channel: usize, f: &NoiseFit) -> String {
    let gyro = channel < 3;
    let ((dens, du), (level, lu)) = (units::density(gyro), units::level(gyro));
    let mut s = match f.white > 0.0 {
        true => format!(
            "white {:.3} +- {:.3} {du}",
            f.white * dens,
            f.white_sigma * dens
        ),
        false => "white noise not measured (not in the fit)".into(),
    };
    s += &match f.floor_seen {
        true => format!(", bias instability {:.2} {lu}", f.bias_instability * level),
        false => format!(
            ", bias instability not measured (the curve still falls at {:.3} s, its longest averaging time: below {:.2} {lu})",
            f.tau_max_s,
            f.bias_instability * level
        ),
    };
    if f.gm_sigma > 0.0 {
        s += &format!(
            ", Gauss-Markov {:.2} {lu} over {}",
            f.gm_sigma * level,
            recording::figures::duration(f.gm_tau_s, 2)
        );
    }
    if f.rrw > 0.0 {
        let rrw = f.rrw * level;
        let rrw = if rrw >= 0.01 {
            format!("{rrw:.3}")
        } else {
            format!("{rrw:.3e}")
        };
        s += &format!(", rate random walk {rrw} {lu}/sqrt(s)");
    }
    s
}

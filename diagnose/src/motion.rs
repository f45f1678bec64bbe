//! The table's motion as the regressors of its own effects (the lever
//! arm's `theta_ddot k x r + theta_dot^2 k x (k x r)`): which signal
//! carries it where the encoder's track cannot follow the table.
//!
//! Where the track follows (a motor that turns smoothly between reads), its
//! rate and acceleration are the motion. Where it does not (a stepper's
//! steps and reversals between reads), two defensible measures remain:
//!
//! - **the table-axis gyro** ([`MotionSource::Gyro`], the default): the rate
//!   the sensor itself turns at, the stepper's ripple included, which is
//!   what the accelerometer's lever arm feels. Its bias and scale are taken
//!   against the encoder (the better measure of the angle: the gyro's
//!   integral is set to the encoder's), its white noise out of the square;
//! - **the encoder's differences** ([`MotionSource::Encoder`]): the rate
//!   between reads, linear between their midpoints; the motion as the
//!   encoder saw it, steps below its read interval left out.
//!
//! Both give the acceleration as a difference of rates, so that a block's
//! mean acceleration is its rate change over the block: a regressor smoothed
//! wider than the block (a reversal spread over 0.4 s) would have less
//! energy than the motion it stands for and inflate the fit (errors in
//! variables) with a sigma that cannot know it. The gyro's samples are
//! differentiated band-limited (what the accelerometer feels at its own
//! instants, a ripple near the Nyquist rate included) or, the other
//! defensible reading, by centred differences. diagnose fits with the
//! first and refits with the other two; their spread is the motion
//! model's error and goes into every sigma (`lib::motion_spread`).

use super::Prediction;

/// The signal that carries the table's motion where the track cannot
/// follow it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MotionSource {
    /// The table-axis gyro, its bias and scale against the encoder, its
    /// acceleration the band-limited derivative ([`differentiate`]).
    #[default]
    Gyro,
    /// The same gyro, its acceleration the centred difference (which keeps
    /// a third of a ripple near the Nyquist rate): the other defensible
    /// reading of the same samples.
    GyroCentred,
    /// The encoder reads' differences.
    Encoder,
}

/// Sets `p.motion` (rate squared rad^2/s^2, acceleration rad/s^2 per
/// sample): the track's when it follows the table throughout, else from
/// `source`.
pub fn fill(p: &mut Prediction, source: MotionSource) {
    let follows: Vec<bool> = p
        .t_s
        .iter()
        .map(|t| p.track.follows(t - p.time_offset_s))
        .collect();
    let tracked = p.theta.iter().map(|m| (m.1 * m.1, m.2));
    if follows.iter().all(|f| *f) {
        p.motion = tracked.collect();
        return;
    }
    // The gyro everywhere: where the track cannot follow, the table moves
    // in ways the encoder cannot see, and the same ripple runs on through
    // the intervals whose reads a smooth track happens to fit. The
    // encoder's differences only where the track does not follow.
    p.motion = match source {
        MotionSource::Gyro => gyro(p, differentiate),
        MotionSource::GyroCentred => gyro(p, centred),
        MotionSource::Encoder => tracked
            .zip(encoder(p))
            .zip(follows)
            .map(|((t, o), f)| if f { t } else { o })
            .collect(),
    };
    p.motion_source = source;
}

/// The encoder's rate at each sample where the track cannot follow the
/// table: centred differences over [`super::predict::MOTION_WINDOW_S`]
/// (rad/s); the track's rate where it follows.
fn smooth_rates(p: &Prediction) -> Vec<f64> {
    p.t_s
        .iter()
        .zip(&p.theta)
        .map(|(t, m)| {
            let t = t - p.time_offset_s;
            if p.track.follows(t) {
                m.1
            } else {
                p.smoothed_rate(t)
            }
        })
        .collect()
}

/// The table-axis gyro as the motion: (rate^2, acceleration) per sample,
/// both at the instants the accelerometer is sampled.
fn gyro(p: &Prediction, derivative: Derivative) -> Vec<(f64, f64)> {
    let g: Vec<f64> = p
        .y_w
        .iter()
        .zip(&p.w_earth)
        .map(|(y, e)| (y - e).dot(&p.k))
        .collect();
    let e = smooth_rates(p);
    let len = ((super::predict::MOTION_WINDOW_S / p.dt_s.max(1e-6)).round() as usize).max(2);
    let (bias, scale) = against_encoder(&g, &e, len);
    let white = still_variance(p, &g, len);
    let w: Vec<f64> = g.iter().map(|x| (x - bias) / scale).collect();
    let var = white / (scale * scale);
    let accel = derivative(&p.t_s, p.dt_s, &w);
    w.iter().zip(accel).map(|(w, a)| (w * w - var, a)).collect()
}

/// The gyro's bias (rad/s) and scale against the encoder's rate: a line
/// through the windows' means of `len` samples (both averaged alike); a
/// run that never turns keeps the scale 1.
fn against_encoder(g: &[f64], e: &[f64], len: usize) -> (f64, f64) {
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let (gm, em): (Vec<f64>, Vec<f64>) = g
        .chunks_exact(len)
        .zip(e.chunks_exact(len))
        .map(|(a, b)| (mean(a), mean(b)))
        .unzip();
    let (gbar, ebar) = (mean(&gm), mean(&em));
    let sxx: f64 = em.iter().map(|x| (x - ebar).powi(2)).sum();
    let sxy: f64 = em
        .iter()
        .zip(&gm)
        .map(|(x, y)| (x - ebar) * (y - gbar))
        .sum();
    // A scale from windows that turn at least a turn's worth in all
    // (1 rad/s over a window each, summed in quadrature), else none.
    let scale = if sxx > 1.0 && sxy > 0.0 {
        sxy / sxx
    } else {
        1.0
    };
    (gbar - scale * ebar, scale)
}

/// The gyro's white noise variance on the table axis, (rad/s)^2: the
/// median scatter within windows of `len` samples where the table is
/// still (0 when it never is: the square then keeps the noise, an upper
/// bound).
fn still_variance(p: &Prediction, g: &[f64], len: usize) -> f64 {
    let mut v: Vec<f64> = g
        .chunks_exact(len)
        .enumerate()
        .filter(|(i, _)| {
            (i * len..(i + 1) * len)
                .all(|r| p.theta.get(r).is_some_and(|m| m.1 == 0.0) && p.track.follows(p.t_s[r]))
        })
        .map(|(_, c)| {
            let m = c.iter().sum::<f64>() / len as f64;
            c.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (len - 1) as f64
        })
        .collect();
    v.sort_unstable_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// A derivative per sample of samples at times `t` (s, nominal interval
/// `dt`): `(t, dt, w) -> dw/dt`.
type Derivative = fn(&[f64], f64, &[f64]) -> Vec<f64>;

/// The centred difference of `w` inside each segment without a gap
/// (one-sided at its ends).
fn centred(t: &[f64], dt: f64, w: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; w.len()];
    for seg in recording::segments(t, dt) {
        if seg.end - seg.start < 2 {
            continue;
        }
        for (r, o) in out.iter_mut().enumerate().take(seg.end).skip(seg.start) {
            let (a, b) = (r.max(seg.start + 1) - 1, (r + 1).min(seg.end - 1));
            *o = (w[b] - w[a]) / (t[b] - t[a]).max(1e-9);
        }
    }
    out
}

/// Taps each side of [`differentiate`]'s filter: with a Hann taper its
/// gain is the derivative's within 0.2 % up to 0.45 of the sample rate
/// (a stepper's ripple sampled near its Nyquist rate, where a centred
/// difference keeps a third of it; the sum `2 (-1)^(n+1) sin(n x) / n`
/// is `x` below pi).
const DIFF_TAPS: usize = 16;

/// The derivative of `w` (per second) at each sample: the band-limited
/// ideal differentiator `(-1)^(n+1) / (n dt)`, Hann-tapered over
/// [`DIFF_TAPS`] each side, inside each segment without a gap (fewer taps
/// near its ends, one-sided at them). A sharp reversal keeps its rate
/// change in its block, the ripple its own instantaneous acceleration.
fn differentiate(t: &[f64], dt: f64, w: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; w.len()];
    for seg in recording::segments(t, dt) {
        if seg.end - seg.start < 2 {
            continue;
        }
        for (r, o) in out.iter_mut().enumerate().take(seg.end).skip(seg.start) {
            let taps = (r - seg.start).min(seg.end - 1 - r).min(DIFF_TAPS);
            *o = if taps == 0 {
                let (a, b) = if r == seg.start {
                    (r, r + 1)
                } else {
                    (r - 1, r)
                };
                (w[b] - w[a]) / (t[b] - t[a]).max(1e-9)
            } else {
                let hann = |n: usize| {
                    0.5 * (1.0 + (std::f64::consts::PI * n as f64 / (taps + 1) as f64).cos())
                };
                (1..=taps)
                    .map(|n| {
                        let sign = if n % 2 == 1 { 1.0 } else { -1.0 };
                        sign / n as f64 * hann(n) * (w[r + n] - w[r - n])
                    })
                    .sum::<f64>()
                    / dt
            };
        }
    }
    out
}

/// The encoder's differences as the motion: the rate between reads at
/// their midpoints, linear between them (its square less the reads'
/// rounding variance); the acceleration the slope between midpoints.
fn encoder(p: &Prediction) -> Vec<(f64, f64)> {
    let (t, a) = (p.track.times(), p.track.angles());
    let mid: Vec<(f64, f64)> = t
        .windows(2)
        .zip(a.windows(2))
        .filter(|(t, _)| t[1] > t[0])
        .map(|(t, a)| (0.5 * (t[0] + t[1]), (a[1] - a[0]) / (t[1] - t[0])))
        .collect();
    if mid.len() < 2 {
        return vec![(0.0, 0.0); p.t_s.len()];
    }
    let q = super::encoder_quantum(a);
    let q = if q.is_finite() { q } else { 0.0 };
    p.t_s
        .iter()
        .map(|t| {
            let t = t - p.time_offset_s;
            let i = mid.partition_point(|m| m.0 <= t).clamp(1, mid.len() - 1);
            let ((t0, w0), (t1, w1)) = (mid[i - 1], mid[i]);
            let acc = (w1 - w0) / (t1 - t0).max(1e-9);
            // Two roundings over one read interval.
            let var = 2.0 * q * q / 12.0 / (t1 - t0).max(1e-9).powi(2);
            let w = w0 + acc * (t - t0);
            (w * w - var, acc)
        })
        .collect()
}

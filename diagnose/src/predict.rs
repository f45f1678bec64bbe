//! Predict: the ideal sensor (core-nav's site model) for the recorded table
//! motion, sample by sample, the block means the regression runs on, and
//! the input checks.

use super::DiagnoseError;
use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use rayon::prelude::*;
pub use recording::track::encoder_quantum;
use recording::track::EncoderTrack;
use recording::Recording;

/// The window over which the encoder's rate is taken where the track
/// cannot follow the table (the gyro's bias and scale against it), s: the
/// default regression
/// block (the fit sees block means; motion faster than a block is
/// averaged there anyway), long against a stepper's step and resonance
/// periods (milliseconds to tens of them) and against the encoder's read
/// interval.
pub const MOTION_WINDOW_S: f64 = 0.2;

/// The ideal sensor and the table motion at each IMU sample.
#[derive(Clone, Debug, Default)]
pub struct Prediction {
    /// Time, s.
    pub t_s: Vec<f64>,
    /// Ideal rate in s (earth rate as the model has it + table rate), rad/s.
    pub w: Vec<Vector3<f64>>,
    /// Ideal specific force in s, m/s^2.
    pub f: Vec<Vector3<f64>>,
    /// Table angle, rate, acceleration (rad, rad/s, rad/s^2).
    pub theta: Vec<(f64, f64, f64)>,
    /// The table's rate squared and its acceleration as regressors of the
    /// motion's own effects (rad^2/s^2, rad/s^2): the track's where it
    /// follows the table, else from [`Prediction::motion_source`]
    /// ([`crate::motion`]).
    pub motion: Vec<(f64, f64)>,
    /// The signal `motion` takes where the track cannot follow the table.
    pub motion_source: crate::motion::MotionSource,
    /// Temperature change from the first sample, deg C (0 if not recorded).
    pub dtemp: Vec<f64>,
    /// The recording has temperatures.
    pub temp_recorded: bool,
    /// The table axis `k` (same in `b` and `s`).
    pub k: Vector3<f64>,
    /// Specific force of gravity in the base frame `b`, m/s^2.
    pub f_b: Vector3<f64>,
    /// The site's full earth rate in `b`, rad/s.
    pub w_e_b: Vector3<f64>,
    /// Earth rate the prediction includes, rad/s (0 if the model has none).
    pub earth_in_model_radps: f64,
    /// Earth-rate part of `w` (as the model has it), rad/s in s.
    pub w_earth: Vec<Vector3<f64>>,
    /// The table's motion from the encoder reads (hal-sim's table model).
    pub track: EncoderTrack,
    /// IMU samples are this late relative to their stamps, s.
    pub time_offset_s: f64,
    /// Nominal sample interval, s (`1 / [imu] rate_hz`).
    pub dt_s: f64,
    /// The recording has accelerometer columns (else gyro-only: the
    /// accelerometer channels hold the ideal values, are left out of every
    /// fit and reported as not recorded).
    pub accel_recorded: bool,
    /// The table angle is an encoder's measurement (else commanded, or no
    /// table: effects that need a measured angle are not offered).
    pub angle_measured: bool,
    /// Measured samples minus the model's known effects: gyro (rad/s).
    pub y_w: Vec<Vector3<f64>>,
    /// See `y_w`: accel (m/s^2).
    pub y_f: Vec<Vector3<f64>>,
    /// The model's known effects per channel and sample (channel unit; empty
    /// when the model has none): subtracted from the measurements in `y_w`,
    /// `y_f`, added back in the model's re-simulated samples.
    pub known: [Vec<f64>; 6],
}

impl Prediction {
    /// Blocks of `len` sample intervals over the prediction's samples,
    /// never across a gap.
    pub fn blocks(&self, len: usize) -> Blocks {
        Blocks::new(&self.t_s, self.dt_s, len)
    }

    /// Encoder angle at stamp `t` (rad): the read itself when one is stamped
    /// there (to 1 us), else the table's fitted shape through the reads
    /// (hal-sim's [`EncoderTrack`]).
    pub fn angle_at(&self, t: f64) -> f64 {
        self.track.angle(t)
    }

    /// The table's rate at `t` (s) from the encoder angles' centred
    /// difference over [`MOTION_WINDOW_S`], rad/s.
    pub fn smoothed_rate(&self, t: f64) -> f64 {
        let w = MOTION_WINDOW_S;
        (self.track.angle(t + 0.5 * w) - self.track.angle(t - 0.5 * w)) / w
    }

    /// Whether channel `ch` (0-2 gyro, 3-5 accel) was recorded.
    pub fn recorded(&self, ch: usize) -> bool {
        ch < 3 || self.accel_recorded
    }

    /// Ideal value of channel `ch` at sample `r`.
    pub fn truth(&self, ch: usize, r: usize) -> f64 {
        if ch < 3 {
            self.w[r][ch]
        } else {
            self.f[r][ch - 3]
        }
    }

    /// Measured value of channel `ch` at sample `r`.
    pub fn meas(&self, ch: usize, r: usize) -> f64 {
        if ch < 3 {
            self.y_w[r][ch]
        } else {
            self.y_f[r][ch - 3]
        }
    }

    /// The model's known effects on channel `ch` at sample `r`.
    pub fn known(&self, ch: usize, r: usize) -> f64 {
        self.known[ch].get(r).copied().unwrap_or(0.0)
    }

    /// The nominal regressor `j` (0 intercept, 1-3 the triad's truth) of
    /// channel `ch` at sample `r`.
    pub fn nominal(&self, ch: usize, j: usize, r: usize) -> f64 {
        if j == 0 {
            1.0
        } else if ch < 3 {
            self.w[r][j - 1]
        } else {
            self.f[r][j - 1]
        }
    }
}

/// One sample's prediction: ideal rate and specific force in `s` (rad/s,
/// m/s^2), the table's (angle, rate, acceleration) (rad, rad/s, rad/s^2),
/// the accelerometer measurement (the ideal one when gyro-only).
type Row = (Vector3<f64>, Vector3<f64>, (f64, f64, f64), Vector3<f64>);

/// Predicts the ideal sensor for `rec` (the nominal world: earth rate scaled
/// by `earth_scale`, gravity, the table's motion about its nominal axis),
/// with the IMU samples `time_offset_s` late relative to their stamps.
pub fn predict(rec: &Recording, earth_scale: f64, time_offset_s: f64) -> Prediction {
    predict_on(rec, EncoderTrack::of(rec), earth_scale, time_offset_s)
}

/// [`predict`] through `track`, the table's motion already made from
/// `rec`'s encoder reads (`EncoderTrack::of(rec)`; a re-prediction with
/// another time offset reads the same encoder).
pub fn predict_on(
    rec: &Recording,
    track: EncoderTrack,
    earth_scale: f64,
    time_offset_s: f64,
) -> Prediction {
    let m = &rec.meta;
    let site = m.site();
    let c_b_n = core_nav::site::c_b_n(&m.base());
    let k = Unit::new_normalize(m.axis.unit::<f64>());
    let temp_recorded = rec.imu.iter().all(|r| r.temp_c.is_some()) && !rec.imu.is_empty();
    let temp0 = rec.imu.first().and_then(|r| r.temp_c).unwrap_or(25.0);
    // The ideal sensor in the base frame (the table at angle 0): the site's
    // one model (core-nav), here with the full earth rate.
    let (w_e_b, f_b) = site.ideal_imu(&c_b_n.transpose(), &Vector3::zeros());
    // The site as the model has it (its earth rate scaled).
    let model_site = core_nav::site::Site {
        earth_rate_scale: earth_scale,
        ..site
    };
    let mut p = Prediction {
        k: k.into_inner(),
        f_b,
        w_e_b,
        earth_in_model_radps: earth_scale * w_e_b.norm(),
        temp_recorded,
        track,
        time_offset_s,
        dt_s: rec.dt_s(),
        accel_recorded: !rec.gyro_only,
        angle_measured: rec.meta.table_source.is_measured(),
        ..Prediction::default()
    };
    // Each row on its own (the track is only read): in parallel, then
    // pushed in order.
    let rows: Vec<Row> = rec
        .imu
        .par_iter()
        .map(|r| {
            let m = p.track.at(r.t_s - time_offset_s);
            let (th, rate, acc) = (m.theta, m.rate, m.accel);
            let c_s_b: Matrix3<f64> = *Rotation3::from_axis_angle(&k, th).matrix();
            let c_n_s = (c_b_n * c_s_b).transpose();
            let (w, f) = model_site.ideal_imu(&c_n_s, &(k.into_inner() * rate));
            let y_f = if rec.gyro_only {
                f
            } else {
                Vector3::from(r.accel_mps2)
            };
            (w, f, (th, rate, acc), y_f)
        })
        .collect();
    for (r, (w, f, theta, y_f)) in rec.imu.iter().zip(rows) {
        p.t_s.push(r.t_s);
        p.w_earth.push(w - k.into_inner() * theta.1);
        p.w.push(w);
        p.f.push(f);
        p.theta.push(theta);
        p.dtemp.push(r.temp_c.map_or(0.0, |t| t - temp0));
        p.y_w.push(Vector3::from(r.gyro_radps));
        p.y_f.push(y_f);
    }
    crate::motion::fill(&mut p, crate::motion::MotionSource::Gyro);
    p
}

/// `rec` with its encoder angles re-rounded to `factor` times their own
/// quantum, the grid shifted by `offset` of the new quantum: the same run as
/// a coarser encoder would have read it. `None` when the angles are on no
/// grid (nothing to re-round).
pub fn requantised(rec: &Recording, factor: f64, offset: f64) -> Option<Recording> {
    let a: Vec<f64> = rec.table.iter().map(|r| r.angle_rad).collect();
    let q = encoder_quantum(&a) * factor;
    if q.is_nan() || q <= 0.0 || !rec.meta.table_source.is_measured() {
        return None;
    }
    let mut out = rec.clone();
    for r in &mut out.table {
        r.angle_rad = q * (r.angle_rad / q + offset).round();
    }
    Some(out)
}

/// Residual rms.
pub fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// Blocks of `len` sample intervals that never straddle a gap
/// (recording-v1): each starts on a sample and ends `len` samples later,
/// inside one segment; a segment's partial last block is dropped.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Blocks {
    /// First sample of each block.
    pub starts: Vec<usize>,
    /// Sample intervals per block.
    pub len: usize,
}

impl Blocks {
    /// Blocks of `len` intervals over samples at `t_s` (s) with the nominal
    /// interval `dt_s` (s).
    pub fn new(t_s: &[f64], dt_s: f64, len: usize) -> Self {
        let len = len.max(1);
        let mut starts = vec![];
        for seg in recording::segments(t_s, dt_s) {
            let mut a = seg.start;
            while a + len < seg.end {
                starts.push(a);
                a += len;
            }
        }
        Self { starts, len }
    }

    /// Blocks of `block_s` seconds over the recording's samples.
    pub fn of(rec: &Recording, block_s: f64) -> Self {
        let t: Vec<f64> = rec.imu.iter().map(|r| r.t_s).collect();
        let dt = rec.dt_s();
        Self::new(&t, dt, ((block_s / dt).round() as usize).max(1))
    }

    /// Number of blocks.
    pub fn count(&self) -> usize {
        self.starts.len()
    }

    /// The middle sample of block `b`.
    pub fn middle(&self, b: usize) -> usize {
        self.starts.get(b).map_or(0, |s| s + self.len / 2)
    }

    /// Block means of `v` (one value per sample): block `b` is the
    /// trapezoid integral over samples `start ..= start + len` (neighbours
    /// share their edge sample) over its length, so a block is the mean
    /// over an interval that starts and ends on a sample (where the encoder
    /// angle is known), not over the samples' centres.
    pub fn mean(&self, v: &[f64]) -> Vec<f64> {
        let len = self.len;
        self.starts
            .iter()
            .filter_map(|a| v.get(*a..=a + len))
            .map(|s| {
                let inner: f64 = s.iter().skip(1).take(len - 1).sum();
                let ends = s.first().copied().unwrap_or(0.0) + s.last().copied().unwrap_or(0.0);
                (inner + 0.5 * ends) / len as f64
            })
            .collect()
    }
}

pub(super) fn check(rec: &Recording) -> Result<(), DiagnoseError> {
    if rec.imu.len() < 200 {
        return Err(DiagnoseError::TooShort {
            samples: rec.imu.len(),
        });
    }
    if rec.table.len() < 5 {
        return Err(DiagnoseError::TooFewEncoderReads {
            reads: rec.table.len(),
        });
    }
    for (i, r) in rec.imu.iter().enumerate() {
        if !(r.t_s.is_finite()
            && r.gyro_radps.iter().all(|v| v.is_finite())
            && (rec.gyro_only || r.accel_mps2.iter().all(|v| v.is_finite())))
        {
            return Err(DiagnoseError::NonFiniteImu {
                index: i,
                t_s: r.t_s,
            });
        }
    }
    if let Some(i) = rec
        .table
        .iter()
        .position(|r| !(r.t_s.is_finite() && r.angle_rad.is_finite()))
    {
        return Err(DiagnoseError::NonFiniteEncoder { index: i });
    }
    Ok(())
}

/// The nominal sample interval, s (`1 / [imu] rate_hz`).
pub(super) fn dt_of(p: &Prediction) -> f64 {
    p.dt_s
}

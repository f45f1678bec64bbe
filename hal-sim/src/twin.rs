//! The twin: a recording's own run re-simulated with a fitted sensor model
//! ([`SimModel`], `rins-sim-model/1` TOML, written by `rins diagnose
//! --sim-model`), by the simulator's own physics: the table's motion from
//! the recording's encoder reads ([`crate::track`]), the site and base of
//! its header ([`crate::world::Scene`]), and the sensor's error model
//! ([`crate::imu::ImuModel`]). Only the IMU samples are new; sample times,
//! encoder reads and temperatures are the recording's.
//!
//! The sensor model is `y = x + b + M x + K2 x.^2 + (a / 2) |x| + G f + T
//! dtemp + n` per triad (rad/s for the gyros, m/s^2 for the
//! accelerometers), with `x` the truth the scene gives for the table's
//! motion, `n` white noise plus a Gauss-Markov bias or a random walk per
//! channel.

use crate::imu::{ImuModel, ImuSpec};
use crate::world::{Geometry, Kinematics, Scene, UntrackedMotion};
use nalgebra::{Matrix3, Vector3};
use recording::track::EncoderTrack;
use recording::{ImuRow, Recording};
use serde::{Deserialize, Serialize};

/// The format tag of a sim model file.
pub const FORMAT: &str = "rins-sim-model/1";

fn one() -> f64 {
    1.0
}

fn is_zero_wobble(v: &[[f64; 4]; 2]) -> bool {
    v.iter().flatten().all(|x| *x == 0.0)
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

fn is_zero3(v: &[f64; 3]) -> bool {
    v.iter().all(|x| *x == 0.0)
}

fn is_zero33(v: &[[f64; 3]; 3]) -> bool {
    v.iter().all(is_zero3)
}

/// One channel's noise: white plus a Gauss-Markov bias or a random walk.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelNoise {
    /// White noise density, channel unit x sqrt(s) (rad/sqrt(s) for a gyro,
    /// m/s/sqrt(s) for an accelerometer).
    #[serde(default)]
    pub white: f64,
    /// Gauss-Markov bias, stationary 1-sigma, channel unit.
    #[serde(default)]
    pub gm_sigma: f64,
    /// Its correlation time, s (0: none).
    #[serde(default)]
    pub gm_tau_s: f64,
    /// Random walk of the bias, channel unit / sqrt(s).
    #[serde(default)]
    pub random_walk: f64,
}

/// One triad's terms; channel unit rad/s (gyros) or m/s^2 (accelerometers),
/// axes of the sensor frame `s`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TriadTerms {
    /// Bias, channel unit.
    #[serde(default)]
    pub bias: [f64; 3],
    /// Scale-factor errors (diagonal) and misalignment (off-diagonal):
    /// output `x + M x`; row: the output axis, column: the input axis.
    #[serde(default)]
    pub scale_misalignment: [[f64; 3]; 3],
    /// Second-order scale term per axis, 1 / channel unit.
    #[serde(default, skip_serializing_if = "is_zero3")]
    pub k2: [f64; 3],
    /// Scale asymmetry per axis (positive minus negative input), 1.
    #[serde(default, skip_serializing_if = "is_zero3")]
    pub asymmetry: [f64; 3],
    /// Bias temperature coefficient per axis, channel unit per degC (of the
    /// recording's temperature, from its first sample).
    #[serde(default, skip_serializing_if = "is_zero3")]
    pub temp_bias_per_degc: [f64; 3],
    /// Noise per axis.
    #[serde(default)]
    pub noise: [ChannelNoise; 3],
}

/// A gyro bias settling after turn-on when no temperature was recorded:
/// `b (1 - exp(-t / tau))`, `t` from the first sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Warmup {
    /// Time constant, s.
    pub tau_s: f64,
    /// Settled change of the gyro bias per axis, rad/s.
    pub gyro_bias_radps: [f64; 3],
}

/// A fitted sensor and table model the simulator runs (`rins-sim-model/1`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimModel {
    /// `rins-sim-model/1`.
    pub format: String,
    /// Where it came from (free text).
    #[serde(default)]
    pub source: String,
    /// The earth rate the gyros feel, x the site's.
    #[serde(default = "one")]
    pub earth_rate_scale: f64,
    /// Gyro triad, rad/s.
    pub gyro: TriadTerms,
    /// Accelerometer triad, m/s^2.
    pub accel: TriadTerms,
    /// Gyro g-sensitivity `G`, rad/s per m/s^2 (row: gyro axis, column:
    /// specific-force axis, both in `s`).
    #[serde(default, skip_serializing_if = "is_zero33")]
    pub g_sens_radps_per_mps2: [[f64; 3]; 3],
    /// IMU origin from the table axis, m, in `s`.
    #[serde(default, skip_serializing_if = "is_zero3")]
    pub lever_arm_m: [f64; 3],
    /// The table base rotated by this small rotation vector, rad, in `b`
    /// (a tilted axis or a base off level).
    #[serde(default, skip_serializing_if = "is_zero3")]
    pub tilt_rad: [f64; 3],
    /// The sensor's mount wobbling with the table angle, rad:
    /// `world::Geometry::wobble_harmonics` (per harmonic 1x, 2x: `[a, b, c,
    /// d]`, cos and sin on the axis's first normal, then its second).
    #[serde(default, skip_serializing_if = "is_zero_wobble")]
    pub wobble_harmonics_rad: [[f64; 4]; 2],
    /// IMU samples this late relative to their stamps (and the encoder), s:
    /// the gyros', and the accelerometers' unless `accel_time_offset_s`
    /// says otherwise.
    #[serde(default)]
    pub time_offset_s: f64,
    /// The accelerometers' own offset, s, when it differs from the gyros'
    /// (a chip filters and reads its two triads with different delays).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accel_time_offset_s: Option<f64>,
    /// Encoder angle error `e(theta) = c cos(theta) + s sin(theta)`: `[c,
    /// s]`, rad (the encoder shows the true angle plus `e`).
    #[serde(default)]
    pub encoder_error_rad: [f64; 2],
    /// A gyro warm-up (no temperature recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warmup: Option<Warmup>,
    /// Table motion between encoder reads that the track cannot follow
    /// (`untracked_table_motion`): the density of its rate noise about the
    /// table axis while the table turns, rad/sqrt(s)
    /// ([`crate::world::UntrackedMotion`]). The table-axis gyro's `white`
    /// is then the sensor's own.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub untracked_motion_rad_per_sqrt_s: f64,
}

impl Default for SimModel {
    /// The nominal, error-free, noise-free sensor.
    fn default() -> Self {
        Self {
            format: FORMAT.into(),
            source: String::new(),
            earth_rate_scale: 1.0,
            gyro: TriadTerms::default(),
            accel: TriadTerms::default(),
            g_sens_radps_per_mps2: [[0.0; 3]; 3],
            lever_arm_m: [0.0; 3],
            tilt_rad: [0.0; 3],
            wobble_harmonics_rad: [[0.0; 4]; 2],
            time_offset_s: 0.0,
            accel_time_offset_s: None,
            encoder_error_rad: [0.0; 2],
            warmup: None,
            untracked_motion_rad_per_sqrt_s: 0.0,
        }
    }
}

/// Why a twin cannot be made.
#[derive(Clone, Debug, PartialEq)]
pub enum TwinError {
    /// The model file is not a `rins-sim-model/1` TOML.
    Parse(String),
    /// A value is NaN or infinite, or out of its range.
    Value(String),
    /// The recording cannot carry the model (no encoder reads, a
    /// temperature term without temperatures).
    Recording(String),
}

impl std::fmt::Display for TwinError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TwinError::Parse(e) => write!(f, "not a {FORMAT} model: {e}"),
            TwinError::Value(e) => write!(f, "model value: {e}"),
            TwinError::Recording(e) => write!(f, "recording: {e}"),
        }
    }
}

impl std::error::Error for TwinError {}

impl SimModel {
    /// Parses a model file.
    ///
    /// # Errors
    /// Bad TOML, an unknown key, a wrong format tag, a non-finite or
    /// negative noise value.
    pub fn from_toml(text: &str) -> Result<Self, TwinError> {
        let m: Self = toml::from_str(text).map_err(|e| TwinError::Parse(e.to_string()))?;
        if m.format != FORMAT {
            return Err(TwinError::Parse(format!(
                "format {:?}, expected {FORMAT:?}",
                m.format
            )));
        }
        m.check()?;
        Ok(m)
    }

    /// The model as TOML (with a header saying what it is).
    ///
    /// # Errors
    /// A value TOML cannot hold.
    pub fn to_toml(&self) -> Result<String, TwinError> {
        let body = toml::to_string(self).map_err(|e| TwinError::Parse(e.to_string()))?;
        Ok(format!(
            "# {FORMAT}: a sensor and table model for `rins simulate --like REC --sim-model THIS`.\n\
             # Units: gyro rad/s, accel m/s^2, angles rad, times s; axes of the sensor frame s.\n{body}"
        ))
    }

    fn check(&self) -> Result<(), TwinError> {
        let accel_dt = self.accel_time_offset_s.unwrap_or(self.time_offset_s);
        let mut all: Vec<f64> = vec![self.earth_rate_scale, self.time_offset_s, accel_dt];
        if self.untracked_motion_rad_per_sqrt_s < 0.0 {
            return Err(TwinError::Value(
                "untracked_motion_rad_per_sqrt_s must not be negative".into(),
            ));
        }
        all.push(self.untracked_motion_rad_per_sqrt_s);
        all.extend(self.lever_arm_m);
        all.extend(self.tilt_rad);
        all.extend(self.wobble_harmonics_rad.iter().flatten());
        all.extend(self.encoder_error_rad);
        all.extend(self.g_sens_radps_per_mps2.iter().flatten());
        for t in [&self.gyro, &self.accel] {
            all.extend(t.bias);
            all.extend(t.scale_misalignment.iter().flatten());
            all.extend(t.k2);
            all.extend(t.asymmetry);
            all.extend(t.temp_bias_per_degc);
            for n in &t.noise {
                let v = [n.white, n.gm_sigma, n.gm_tau_s, n.random_walk];
                if v.iter().any(|x| !x.is_finite() || *x < 0.0) {
                    return Err(TwinError::Value(format!(
                        "noise terms must be finite and not negative: {n:?}"
                    )));
                }
            }
        }
        if let Some(w) = &self.warmup {
            if !(w.tau_s.is_finite() && w.tau_s > 0.0) {
                return Err(TwinError::Value("warmup.tau_s must be positive".into()));
            }
            all.extend(w.gyro_bias_radps);
        }
        if all.iter().any(|x| !x.is_finite()) {
            return Err(TwinError::Value("a value is NaN or infinite".into()));
        }
        if !(0.0..=1.0).contains(&self.time_offset_s.abs()) || accel_dt.abs() > 1.0 {
            return Err(TwinError::Value("time_offset_s beyond 1 s".into()));
        }
        Ok(())
    }

    /// The same model without noise.
    pub fn noise_free(&self) -> Self {
        let mut m = self.clone();
        m.gyro.noise = Default::default();
        m.accel.noise = Default::default();
        m.untracked_motion_rad_per_sqrt_s = 0.0;
        m
    }
}

/// Sets one triad's realised values from the model's terms.
fn set_triad(t: &mut crate::imu::TriadModel, terms: &TriadTerms, temp_bias: [f64; 3]) {
    let m = Matrix3::from_fn(|r, c| terms.scale_misalignment[r][c]);
    t.bias = Vector3::from(terms.bias);
    t.scale = m.diagonal();
    t.misalignment = m - Matrix3::from_diagonal(&m.diagonal());
    t.k2 = Vector3::from(terms.k2);
    t.k3 = Vector3::zeros();
    t.asymmetry = Vector3::from(terms.asymmetry);
    t.temp_bias = Vector3::from(temp_bias);
    t.temp_scale = Vector3::zeros();
    let n = &terms.noise;
    t.white = Vector3::from_fn(|i, _| n[i].white);
    t.bias_instability = Vector3::from_fn(|i, _| n[i].gm_sigma);
    t.bi_tau_s = Vector3::from_fn(|i, _| n[i].gm_tau_s);
    t.rrw = Vector3::from_fn(|i, _| n[i].random_walk);
}

/// The table's true motion at `t` (s) from the encoder track: the encoder
/// shows `theta + e(theta)` with `e = c cos(theta) + s sin(theta)` (rad).
fn true_motion(track: &EncoderTrack, t: f64, c: f64, s: f64) -> Kinematics {
    let shown = track.at(t);
    let e = c * shown.theta.cos() + s * shown.theta.sin();
    let de = -c * shown.theta.sin() + s * shown.theta.cos();
    Kinematics {
        theta: shown.theta - e,
        rate: shown.rate / (1.0 + de),
        accel: shown.accel,
    }
}

/// Re-simulates `rec`'s run with `model`: the same sample times, encoder
/// reads, temperatures, site and base; IMU samples from the simulator's
/// physics with the model's sensor, noise drawn from `seed`.
///
/// # Errors
/// A recording without IMU samples or with fewer than 3 encoder reads; a
/// temperature term on a recording without temperatures; a model with a
/// warm-up on a recording with temperatures.
pub fn simulate_like(rec: &Recording, model: &SimModel, seed: u64) -> Result<Recording, TwinError> {
    model.check()?;
    if rec.imu.is_empty() || rec.table.len() < 3 {
        return Err(TwinError::Recording(format!(
            "{} IMU samples and {} encoder reads: a twin needs samples and at least 3 reads",
            rec.imu.len(),
            rec.table.len()
        )));
    }
    let temps: Option<Vec<f64>> = rec.imu.iter().map(|r| r.temp_c).collect();
    let has_temp_terms = [&model.gyro, &model.accel]
        .iter()
        .any(|t| !is_zero3(&t.temp_bias_per_degc));
    if temps.is_none() && has_temp_terms {
        return Err(TwinError::Recording(
            "the model has temperature coefficients and the recording no temperatures".into(),
        ));
    }
    if temps.is_some() && model.warmup.is_some() {
        return Err(TwinError::Recording(
            "the model has a warm-up (for runs without temperatures) and the recording temperatures"
                .into(),
        ));
    }
    let m = &rec.meta;
    let mut site = m.site();
    site.earth_rate_scale = model.earth_rate_scale;
    // A base rotated by `tilt` (in b): the table axis tilted by it and the
    // sensor on the platform by the same, so that `c_s_b(theta) = R(tilt)
    // R(k theta)` (world::Geometry::c_s_b).
    let tilt = Vector3::from(model.tilt_rad);
    let scene = Scene {
        site,
        base: m.base(),
        geometry: Geometry {
            axis: m.axis,
            axis_tilt: tilt,
            wobble: tilt,
            wobble_harmonics: model.wobble_harmonics_rad,
            lever_arm_s: Vector3::from(model.lever_arm_m),
        },
        bump: None,
    };
    let t0 = rec.imu.first().map_or(0.0, |r| r.t_s);
    let mut spec = ImuSpec::ideal();
    spec.temp.ambient_c = 0.0;
    spec.temp.lsb_c = 0.0;
    let (gyro_temp, temp0) = match (&temps, &model.warmup) {
        (Some(t), _) => (
            model.gyro.temp_bias_per_degc,
            t.first().copied().unwrap_or(0.0),
        ),
        (None, Some(w)) => {
            // The warm-up as the simulator's temperature curve: 1 "degC"
            // of rise, the bias change per degC.
            spec.temp.warmup_c = 1.0;
            spec.temp.warmup_tau_s = w.tau_s;
            (w.gyro_bias_radps, 0.0)
        }
        (None, None) => ([0.0; 3], 0.0),
    };
    if temps.is_none() && model.warmup.is_none() {
        spec.temp.warmup_c = 0.0;
    }
    spec.temp.ambient_c = temp0;
    let mut imu = ImuModel::new(spec, seed);
    set_triad(&mut imu.gyro, &model.gyro, gyro_temp);
    set_triad(&mut imu.accel, &model.accel, model.accel.temp_bias_per_degc);
    imu.g_sens = Matrix3::from_fn(|r, c| model.g_sens_radps_per_mps2[r][c]);
    imu.start_drift();
    let track = EncoderTrack::of(rec);
    let [ec, es] = model.encoder_error_rad;
    let dt_nominal = 1.0 / m.imu_rate_hz.max(1e-9);
    let untracked = UntrackedMotion {
        density_rad_per_sqrt_s: model.untracked_motion_rad_per_sqrt_s,
    };
    let mut untracked_rng = crate::rng::Rng::new(seed, 41);
    let mut out = rec.clone();
    let fixed = scene.fixed();
    let mut t_prev = t0 - dt_nominal;
    for (r, (row, src)) in out.imu.iter_mut().zip(&rec.imu).enumerate() {
        let t_true = src.t_s - model.time_offset_s;
        let kin = true_motion(&track, t_true, ec, es);
        let (mut w, mut f) = scene.truth_in(&fixed, &kin, t_true);
        if let Some(dt_a) = model.accel_time_offset_s {
            f = scene
                .truth_in(
                    &fixed,
                    &true_motion(&track, t0.max(src.t_s - dt_a), ec, es),
                    src.t_s - dt_a,
                )
                .1;
        }
        let temp = match &temps {
            Some(t) => t.get(r).copied().unwrap_or(temp0),
            None => imu.temperature_c(src.t_s - t0),
        };
        let dt = (src.t_s - t_prev).max(1e-6);
        t_prev = src.t_s;
        w +=
            m.axis.unit::<f64>() * untracked.rate(&mut untracked_rng, kin.rate, dt.min(dt_nominal));
        let (g, a) = imu.measure(&w, &f, temp, dt);
        *row = ImuRow {
            t_s: src.t_s,
            gyro_radps: [g.x, g.y, g.z],
            accel_mps2: if rec.gyro_only {
                [f64::NAN; 3]
            } else {
                [a.x, a.y, a.z]
            },
            temp_c: src.temp_c,
        };
    }
    out.meta.description = Some(format!(
        "rins simulate --like: twin of the recording{} (seed {seed}); {}",
        m.description
            .as_deref()
            .map(|d| format!(" \"{d}\""))
            .unwrap_or_default(),
        if model.source.is_empty() {
            "model given"
        } else {
            &model.source
        }
    ));
    Ok(out)
}

//! `simulate`: a whole run (table + IMU + encoder) written as a recording.
//!
//! Physics runs at 1 kHz: the table follows the scheme's reference, either
//! exactly (`ideal`: a perfect table) or through its motor and servo. IMU
//! samples are taken at `imu_rate_hz` from the truth at `t - latency +
//! jitter`, encoder reads at `encoder_rate_hz` from the angle at
//! `t - encoder latency`, quantised to whole counts (not in `ideal`).

use crate::catalogue::EffectId;
use crate::drive::{Drive, DriveKind, GnssSpec, Receiver, Vehicle, VehicleState};
use crate::imu::{ImuModel, ImuSpec};
use crate::motion::{motion, Kept};
use crate::rng::Rng;
use crate::world::{
    Bump, EncoderSpec, Geometry, Kinematics, MotorParams, Scene, Site, UntrackedMotion,
};
use core_nav::attitude::Euler;
use core_nav::scheme::{Limits, Profile, Scheme};
use core_nav::table::Axis;
use nalgebra::Vector3;
use recording::moving::{GnssMeta, GnssRow, MovingBase, TruthRow};
use recording::{ImuRow, Meta, Recording, TableRow};
use std::collections::VecDeque;

/// Everything a run is made of.
#[derive(Clone, Debug)]
pub struct SimConfig {
    /// A perfect table and encoder (exact profile, no quantisation or
    /// latency); the IMU is whatever `imu` says (`ImuSpec::ideal()` for
    /// `--ideal`).
    pub ideal: bool,
    /// The sensor.
    pub imu: ImuSpec,
    /// Rotation scheme after the static phase.
    pub scheme: Scheme,
    /// Table limits.
    pub limits: Limits,
    /// The table stays still for this long first (calibration's static phase), s.
    pub static_s: f64,
    /// Run length, s.
    pub duration_s: f64,
    /// Site.
    pub site: Site,
    /// Base attitude as given: roll, pitch, heading, deg.
    pub base_deg: [f64; 3],
    /// Table geometry.
    pub geometry: Geometry,
    /// Encoder.
    pub encoder: EncoderSpec,
    /// Motor and mechanics.
    pub motor: MotorParams,
    /// Base bump.
    pub bump: Option<Bump>,
    /// IMU rate, Hz.
    pub imu_rate_hz: f64,
    /// Encoder read rate, Hz.
    pub encoder_rate_hz: f64,
    /// Seed for every random draw.
    pub seed: u64,
    /// Deterministic gyro g-sensitivity: VALUE x a fixed sign pattern on all
    /// nine entries, rad/s per m/s^2 (replaces the profile's random draw).
    pub g_sens_override: Option<f64>,
    /// A deterministic gyro g-sensitivity matrix, rad/s per m/s^2 (row: the
    /// gyro axis, column: the specific force axis; replaces both the above
    /// and the profile's random draw).
    pub g_sens_matrix: Option<nalgebra::Matrix3<f64>>,
    /// Deterministic gyro bias temperature coefficient, rad/s per degC, all
    /// axes (replaces the profile's random draw).
    pub temp_bias_override: Option<f64>,
    /// A vehicle under the table (moving base; `None`: a static base).
    pub drive: Option<DriveSpec>,
    /// Table motion between encoder reads the track cannot follow.
    pub untracked: UntrackedMotion,
}

/// The vehicle the table rides on and its GNSS receiver.
#[derive(Clone, Debug, PartialEq)]
pub struct DriveSpec {
    /// City or highway.
    pub kind: DriveKind,
    /// The receiver (its rate, antenna, noise, outages).
    pub gnss: GnssSpec,
    /// Longitude of the start, deg.
    pub longitude_deg: f64,
    /// The base's mounting in the vehicle: roll, pitch, yaw of `b` in
    /// the vehicle's frame (ZYX), deg; zeros: the base is the vehicle.
    pub mounting_deg: [f64; 3],
    /// The table's centre ahead of the rear axle's, m
    /// ([`Vehicle::with_imu_ahead_m`]).
    pub imu_ahead_m: f64,
}

impl SimConfig {
    /// A run of `duration_s` with `imu` about `axis`, table still.
    pub fn new(imu: ImuSpec, axis: Axis, duration_s: f64) -> Self {
        Self {
            ideal: false,
            imu,
            scheme: Scheme::Still,
            limits: Limits::default(),
            static_s: 0.0,
            duration_s,
            site: Site::new(30.53, 20.0),
            base_deg: [0.0; 3],
            geometry: Geometry::perfect(axis),
            encoder: EncoderSpec::default(),
            motor: MotorParams::default(),
            bump: None,
            imu_rate_hz: 100.0,
            encoder_rate_hz: 50.0,
            seed: 1,
            g_sens_override: None,
            g_sens_matrix: None,
            temp_bias_override: None,
            drive: None,
            untracked: UntrackedMotion::default(),
        }
    }

    /// Sets one named effect (see [`EFFECTS`]) to `value`.
    ///
    /// # Errors
    /// An unknown name, with the list of known ones.
    pub fn set_effect(&mut self, name: &str, value: f64) -> Result<(), SimError> {
        let e = EFFECTS
            .iter()
            .find(|e| e.name == name)
            .ok_or_else(|| SimError::UnknownEffect(name.to_string()))?;
        if !value.is_finite() {
            return Err(SimError::NonFiniteEffect {
                name: name.to_string(),
                value,
            });
        }
        (e.apply)(self, value);
        Ok(())
    }
}

/// Why a simulation cannot run.
#[derive(Clone, Debug, PartialEq)]
pub enum SimError {
    /// `--effect` names no knob of [`EFFECTS`].
    UnknownEffect(String),
    /// An effect's value is NaN or infinite.
    NonFiniteEffect {
        /// The knob.
        name: String,
        /// Its value.
        value: f64,
    },
    /// Duration or a sample rate is not positive.
    NotPositive {
        /// What, as a user names it (the flag or the file's key).
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// An IMU or encoder latency outside [0, 1] s.
    Latency,
    /// The rotation scheme is out of the table's limits.
    Scheme(core_nav::NavError),
}

impl std::fmt::Display for SimError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SimError::UnknownEffect(name) => {
                let names: Vec<&str> = EFFECTS.iter().map(|e| e.name).collect();
                write!(f, "unknown effect {name:?}; known: {}", names.join(", "))
            }
            SimError::NonFiniteEffect { name, value } => {
                write!(f, "effect {name}: value {value} is not finite")
            }
            SimError::NotPositive { what, value } => {
                write!(f, "{what} must be positive (given {value})")
            }
            SimError::Latency => f.write_str("latencies must be within [0, 1] s"),
            SimError::Scheme(e) => write!(f, "rotation scheme: {e}"),
        }
    }
}

impl std::error::Error for SimError {}

/// A named knob of the world: every effect id of
/// `shared/spec/diagnose-v1.md` and the other error-model terms.
pub struct Effect {
    /// Name for `--effect NAME=VALUE`.
    pub name: &'static str,
    /// Unit of VALUE.
    pub unit: &'static str,
    /// What it does.
    pub help: &'static str,
    apply: fn(&mut SimConfig, f64),
}

/// Perpendicular to the table axis: where the lever arm points and which
/// way the axis tilts.
fn radial(axis: Axis) -> Vector3<f64> {
    match axis {
        Axis::X => Vector3::y(),
        Axis::Y => Vector3::z(),
        Axis::Z => Vector3::x(),
    }
}

/// Fixed sign pattern for a full g-sensitivity matrix (documented, not random).
const G_SENS_PATTERN: [[f64; 3]; 3] = [[1.0, -1.0, 1.0], [1.0, 1.0, -1.0], [-1.0, 1.0, 1.0]];

/// The knobs: every diagnose-v1 id ([`EffectId`]) first, then the other
/// terms of the error model.
pub const EFFECTS: &[Effect] = &[
    Effect {
        name: EffectId::EarthRate.as_str(),
        unit: "x Omega_e",
        help: "scale of the earth rate the sensor feels (1 = real earth, 0 = none)",
        apply: |c, v| c.site.earth_rate_scale = v,
    },
    Effect {
        name: EffectId::GyroGSensitivity.as_str(),
        unit: "rad/s per m/s^2",
        help: "gyro bias G f, G = VALUE x fixed sign pattern on all nine entries",
        apply: |c, v| {
            c.imu.g_sensitivity = 0.0;
            c.g_sens_override = Some(v)
        },
    },
    Effect {
        name: EffectId::GyroScaleNonlinearity.as_str(),
        unit: "1/(rad/s)",
        help: "gyro K2 (rate-squared term), all axes",
        apply: |c, v| c.imu.gyro.k2 = v,
    },
    Effect {
        name: EffectId::GyroScaleAsymmetry.as_str(),
        unit: "1",
        help: "gyro scale for positive minus negative rates, all axes",
        apply: |c, v| c.imu.gyro.asymmetry = v,
    },
    Effect {
        name: EffectId::LeverArm.as_str(),
        unit: "m",
        help: "IMU origin this far from the table axis (radially)",
        apply: |c, v| c.geometry.lever_arm_s = radial(c.geometry.axis) * v,
    },
    Effect {
        name: EffectId::AxisTilt.as_str(),
        unit: "rad",
        help: "table axis tilted by this angle (about a perpendicular axis of b)",
        apply: |c, v| {
            let k = c.geometry.axis.unit::<f64>();
            c.geometry.axis_tilt = k.cross(&radial(c.geometry.axis)) * v
        },
    },
    Effect {
        name: EffectId::TimeOffset.as_str(),
        unit: "s",
        help: "IMU samples this late relative to their stamps (and the encoder)",
        apply: |c, v| c.imu.latency_s = v,
    },
    Effect {
        name: EffectId::TemperatureBias.as_str(),
        unit: "rad/s per degC",
        help: "gyro bias temperature coefficient (all axes), with the warm-up curve",
        apply: |c, v| {
            c.imu.gyro.temp_bias = 0.0;
            c.temp_bias_override = Some(v)
        },
    },
    Effect {
        name: EffectId::BiasInstability.as_str(),
        unit: "rad/s",
        help: "gyro Gauss-Markov bias sigma (tau 100 s unless bias_tau_s is set)",
        apply: |c, v| {
            c.imu.gyro.bias_instability = v;
            if c.imu.gyro.bi_tau_s <= 0.0 {
                c.imu.gyro.bi_tau_s = 100.0
            }
        },
    },
    Effect {
        name: EffectId::EncoderError.as_str(),
        unit: "rad",
        help: "once-per-revolution encoder error (eccentricity) amplitude",
        apply: |c, v| c.encoder.eccentricity_rad = v,
    },
    Effect {
        name: EffectId::AccelScaleNonlinearity.as_str(),
        unit: "1/(m/s^2)",
        help: "accelerometer K2, all axes",
        apply: |c, v| c.imu.accel.k2 = v,
    },
    Effect {
        name: EffectId::TableAngleHarmonic.as_str(),
        unit: "rad",
        help: "the sensor's mount rocking with the table angle once per revolution (a bent shaft): amplitude of the small rotation",
        apply: |c, v| c.geometry.wobble_harmonics[0] = [v, 0.0, 0.0, v],
    },
    Effect {
        name: EffectId::UntrackedTableMotion.as_str(),
        unit: "rad/sqrt(s)",
        help: "table motion between encoder reads that the track cannot follow (a stepper's steps): rate noise of this density about the table axis while it turns, seen by the gyros, not the encoder",
        apply: |c, v| c.untracked.density_rad_per_sqrt_s = v,
    },
    // Other terms of the error model.
    Effect {
        name: "accel_time_offset",
        unit: "s",
        help: "accelerometer samples this late relative to their stamps, when it differs from time_offset (the gyros')",
        apply: |c, v| c.imu.accel_latency_s = Some(v),
    },
    Effect {
        name: "gyro_bias",
        unit: "rad/s",
        help: "turn-on gyro bias 1 sigma",
        apply: |c, v| c.imu.gyro.bias = v,
    },
    Effect {
        name: "accel_bias",
        unit: "m/s^2",
        help: "turn-on accelerometer bias 1 sigma",
        apply: |c, v| c.imu.accel.bias = v,
    },
    Effect {
        name: "gyro_scale",
        unit: "1",
        help: "gyro scale-factor error 1 sigma",
        apply: |c, v| c.imu.gyro.scale = v,
    },
    Effect {
        name: "accel_scale",
        unit: "1",
        help: "accelerometer scale-factor error 1 sigma",
        apply: |c, v| c.imu.accel.scale = v,
    },
    Effect {
        name: "gyro_misalignment",
        unit: "rad",
        help: "gyro misalignment, each off-diagonal 1 sigma",
        apply: |c, v| c.imu.gyro.misalignment = v,
    },
    Effect {
        name: "accel_misalignment",
        unit: "rad",
        help: "accelerometer misalignment, each off-diagonal 1 sigma",
        apply: |c, v| c.imu.accel.misalignment = v,
    },
    Effect {
        name: "gyro_k3",
        unit: "1/(rad/s)^2",
        help: "gyro third-order scale nonlinearity",
        apply: |c, v| c.imu.gyro.k3 = v,
    },
    Effect {
        name: "accel_scale_asymmetry",
        unit: "1",
        help: "accelerometer scale asymmetry",
        apply: |c, v| c.imu.accel.asymmetry = v,
    },
    Effect {
        name: "gyro_arw",
        unit: "rad/sqrt(s)",
        help: "gyro white noise (angle random walk)",
        apply: |c, v| c.imu.gyro.white = v,
    },
    Effect {
        name: "accel_vrw",
        unit: "m/s/sqrt(s)",
        help: "accelerometer white noise (velocity random walk)",
        apply: |c, v| c.imu.accel.white = v,
    },
    Effect {
        name: "bias_tau_s",
        unit: "s",
        help: "gyro Gauss-Markov correlation time",
        apply: |c, v| c.imu.gyro.bi_tau_s = v,
    },
    Effect {
        name: "accel_bias_instability",
        unit: "m/s^2",
        help: "accelerometer Gauss-Markov bias sigma",
        apply: |c, v| c.imu.accel.bias_instability = v,
    },
    Effect {
        name: "gyro_rrw",
        unit: "rad/s/sqrt(s)",
        help: "gyro rate random walk",
        apply: |c, v| c.imu.gyro.rrw = v,
    },
    Effect {
        name: "accel_temperature_bias",
        unit: "m/s^2 per degC",
        help: "accelerometer bias temperature coefficient 1 sigma",
        apply: |c, v| c.imu.accel.temp_bias = v,
    },
    Effect {
        name: "gyro_temperature_scale",
        unit: "1/degC",
        help: "gyro scale temperature coefficient 1 sigma",
        apply: |c, v| c.imu.gyro.temp_scale = v,
    },
    Effect {
        name: "warmup_c",
        unit: "degC",
        help: "self-heating rise after turn-on",
        apply: |c, v| c.imu.temp.warmup_c = v,
    },
    Effect {
        name: "warmup_tau_s",
        unit: "s",
        help: "warm-up time constant",
        apply: |c, v| c.imu.temp.warmup_tau_s = v,
    },
    Effect {
        name: "gyro_lsb",
        unit: "rad/s",
        help: "gyro output quantisation",
        apply: |c, v| c.imu.gyro.lsb = v,
    },
    Effect {
        name: "accel_lsb",
        unit: "m/s^2",
        help: "accelerometer output quantisation",
        apply: |c, v| c.imu.accel.lsb = v,
    },
    Effect {
        name: "gyro_full_scale",
        unit: "rad/s",
        help: "gyro saturation",
        apply: |c, v| c.imu.gyro.full_scale = v,
    },
    Effect {
        name: "accel_full_scale",
        unit: "m/s^2",
        help: "accelerometer saturation",
        apply: |c, v| c.imu.accel.full_scale = v,
    },
    Effect {
        name: "jitter",
        unit: "s",
        help: "IMU sample-time jitter 1 sigma (clamped to 4 ms)",
        apply: |c, v| c.imu.jitter_s = v,
    },
    Effect {
        name: "wobble",
        unit: "rad",
        help: "sensor tilted on the platform: its axes cone once per revolution",
        apply: |c, v| c.geometry.wobble = radial(c.geometry.axis) * v,
    },
    Effect {
        name: "encoder_latency",
        unit: "s",
        help: "encoder reads this late",
        apply: |c, v| c.encoder.latency_s = v,
    },
    Effect {
        name: "encoder_counts",
        unit: "counts/rev",
        help: "encoder resolution",
        apply: |c, v| c.encoder.counts_per_rev = v.round().clamp(4.0, 1e9) as u32,
    },
];

/// The largest jitter used, s (samples are taken this long after their
/// stamp so the truth is known on both sides).
const MAX_JITTER_S: f64 = 0.004;
/// Physics step, s.
const PHYS_DT: f64 = 1e-3;

/// The level a simulated recording's `meta.toml` states it knows, 1-sigma,
/// deg: a machinist's level (0.05 mm/m a division), what a user levelling
/// a real base could state.
pub const STATED_LEVEL_SIGMA_DEG: f64 = 0.003;

/// The heading a simulated recording's `meta.toml` states it knows,
/// 1-sigma, deg: a base set against a surveyed line.
pub const STATED_HEADING_SIGMA_DEG: f64 = 0.1;

/// Runs `cfg` and returns the recording. `progress` is told the fraction
/// done now and then.
///
/// # Errors
/// A scheme out of range, non-positive rates or duration, a latency above
/// 1 s.
pub fn simulate(cfg: &SimConfig, progress: &mut dyn FnMut(f64)) -> Result<Recording, SimError> {
    simulate_observed(cfg, progress, &mut |_| {})
}

/// The sensor's hidden state at one IMU sample: the oracle a study checks
/// estimates against (never in the recording).
#[derive(Clone, Copy, Debug)]
pub struct Hidden {
    /// The sample's stamp, s.
    pub t_s: f64,
    /// The gyro's bias at the sample, rad/s in `s`
    /// ([`crate::imu::ImuModel::gyro_bias_now`]).
    pub gyro_bias_radps: Vector3<f64>,
    /// The sensor's true temperature minus its ambient, degC.
    pub temp_rise_c: f64,
}

/// [`simulate`], telling `hidden` each IMU sample's [`Hidden`] state.
///
/// # Errors
/// As [`simulate`].
pub fn simulate_observed(
    cfg: &SimConfig,
    progress: &mut dyn FnMut(f64),
    hidden: &mut dyn FnMut(&Hidden),
) -> Result<Recording, SimError> {
    for (what, value) in [
        ("the duration (--duration-s), s", cfg.duration_s),
        (
            "the IMU's rate (the sensor file's rate_hz), Hz",
            cfg.imu_rate_hz,
        ),
        ("the encoder's rate, Hz", cfg.encoder_rate_hz),
    ] {
        if value.is_nan() || value <= 0.0 {
            return Err(SimError::NotPositive { what, value });
        }
    }
    if !(0.0..=1.0).contains(&cfg.imu.latency_s)
        || !(0.0..=1.0).contains(&cfg.imu.accel_latency_s.unwrap_or(0.0))
        || !(0.0..=1.0).contains(&cfg.encoder.latency_s)
    {
        return Err(SimError::Latency);
    }
    let profile = Profile::new(cfg.scheme, cfg.limits).map_err(SimError::Scheme)?;
    let mut imu = ImuModel::new(cfg.imu.clone(), cfg.seed);
    if let Some(v) = cfg.g_sens_override {
        imu.g_sens = nalgebra::Matrix3::from_fn(|r, c| v * G_SENS_PATTERN[r][c]);
    }
    if let Some(m) = cfg.g_sens_matrix {
        imu.g_sens = m;
    }
    if let Some(v) = cfg.temp_bias_override {
        imu.gyro.temp_bias = Vector3::repeat(v);
    }
    let [roll_deg, pitch_deg, heading_deg] = cfg.base_deg;
    let scene = Scene {
        site: cfg.site,
        base: Euler::from_deg(roll_deg, pitch_deg, heading_deg),
        geometry: cfg.geometry,
        bump: cfg.bump,
    };
    let fixed = scene.fixed();
    // A moving base: the vehicle (its attitude at t = 0 is the base's),
    // its receiver, its true motion per IMU sample.
    let origin = core_nav::earth::GeoPoint::from_deg(
        cfg.site.lat_deg,
        cfg.drive.as_ref().map_or(0.0, |d| d.longitude_deg),
        cfg.site.origin.height_m,
    );
    let tangent = origin.tangent();
    let mut vehicle = cfg.drive.as_ref().map(|d| {
        Vehicle::new(
            Drive::plan(d.kind, cfg.duration_s, cfg.seed),
            origin,
            heading_deg,
            crate::drive::mounting(d.mounting_deg),
        )
        .with_imu_ahead_m(d.imu_ahead_m)
    });
    let mut receiver = cfg
        .drive
        .as_ref()
        .map(|d| Receiver::new(d.gnss.clone(), cfg.seed));
    let mut veh_hist: VecDeque<VehicleState> = VecDeque::with_capacity(2_000);
    let (mut gnss_rows, mut truth_rows) = (vec![], vec![]);
    let mut k_gnss = 1u64;
    let mut jitter = Rng::new(cfg.seed, 3);
    let mut untracked = Rng::new(cfg.seed, 41);
    let reference = |t: f64| profile.at(t - cfg.static_s);
    let n_ticks = (cfg.duration_s / PHYS_DT).round() as u64 + 10;
    // The table under its servo (none for a perfect table): shared by
    // every run of this motor, scheme and length.
    let table = if cfg.ideal {
        None
    } else {
        Some(
            motion(
                &cfg.motor,
                cfg.scheme,
                cfg.limits,
                cfg.static_s,
                PHYS_DT,
                n_ticks,
            )
            .map_err(SimError::Scheme)?,
        )
    };
    let imu_dt = 1.0 / cfg.imu_rate_hz;
    let n_imu = (cfg.duration_s * cfg.imu_rate_hz).floor() as u64 + 1;
    let n_enc = (cfg.duration_s * cfg.encoder_rate_hz).floor() as u64 + 1;
    let mut rec = Recording {
        gyro_only: false,
        moving: None,
        meta: Meta {
            table_source: recording::TableSource::Encoder,
            description: Some(format!(
                "rins simulate: imu {}, scheme {:?}, static {} s, seed {}{}",
                cfg.imu.name,
                cfg.scheme,
                cfg.static_s,
                cfg.seed,
                if cfg.ideal { ", ideal table" } else { "" }
            )),
            latitude_deg: cfg.site.lat_deg,
            height_m: cfg.site.origin.height_m,
            gravity_mps2: Some(cfg.site.gravity_mps2),
            heading_deg,
            pitch_deg,
            roll_deg,
            // The simulated base is the truth, but meta.toml states what
            // a user could know of a real one, never an exact 0.
            heading_sigma_deg: Some(STATED_HEADING_SIGMA_DEG),
            level_sigma_deg: Some(STATED_LEVEL_SIGMA_DEG),
            imu_model: Some(cfg.imu.model.to_string()),
            imu_rate_hz: cfg.imu_rate_hz,
            imu_sample: recording::SampleKind::Instantaneous,
            axis: cfg.geometry.axis,
            encoder_rate_hz: cfg.encoder_rate_hz,
        },
        imu: Vec::with_capacity(n_imu as usize),
        table: Vec::with_capacity(n_enc as usize),
    };
    let kin_exact = |t: f64| {
        let r = reference(t);
        Kinematics {
            theta: r.angle,
            rate: r.rate,
            accel: r.accel,
        }
    };
    let kin_at = |tt: f64| match &table {
        Some(m) => m.at(tt),
        None => kin_exact(tt),
    };
    // On a static base: the truth sample k sees, `j` s of jitter late.
    let static_truth = |k: u64, j: f64| {
        let t_true = (k as f64 / cfg.imu_rate_hz - cfg.imu.latency_s + j).max(0.0);
        let kin = kin_at(t_true);
        let (w, mut f) = scene.truth_in(&fixed, &kin, t_true);
        if let Some(l) = cfg.imu.accel_latency_s {
            let t_a = (k as f64 / cfg.imu_rate_hz - l + j).max(0.0);
            f = scene.truth_in(&fixed, &kin_at(t_a), t_a).1;
        }
        SampleTruth {
            w,
            f,
            rate: kin.rate,
        }
    };
    // Without jitter, every seed's run sees the same truths: made once.
    // Encoder reading k (the encoder has no random part).
    let enc_row = |k: u64| {
        let t_k = k as f64 / cfg.encoder_rate_hz;
        let angle_rad = if cfg.ideal {
            cfg.encoder.shown(kin_at(t_k).theta)
        } else {
            let th = kin_at((t_k - cfg.encoder.latency_s).max(0.0)).theta;
            cfg.encoder.angle(th)
        };
        TableRow {
            t_s: t_k,
            angle_rad,
        }
    };
    let t_last = n_ticks as f64 * PHYS_DT;
    let kept = (vehicle.is_none() && cfg.imu.jitter_s == 0.0).then(|| {
        let bytes = (n_imu as usize).saturating_mul(std::mem::size_of::<SampleTruth>())
            + (n_enc as usize).saturating_mul(std::mem::size_of::<TableRow>());
        KEPT_TRUTHS.get_or_make(TruthKey::of(cfg, &scene), bytes, || StaticTruths {
            samples: (0..n_imu).map(|k| static_truth(k, 0.0)).collect(),
            table: (0..n_enc)
                .map(enc_row)
                .take_while(|r| r.t_s <= t_last)
                .collect(),
        })
    });
    let (mut k_imu, mut k_enc) = (0u64, 0u64);
    if let Some(kept) = &kept {
        rec.table.extend_from_slice(&kept.table);
        k_enc = n_enc;
    }
    let mut last_report = 0u64;
    let mut next_tick = 0u64;
    while next_tick <= n_ticks {
        let tick = next_tick;
        let t = tick as f64 * PHYS_DT;
        if let Some(v) = vehicle.as_mut() {
            if tick > 0 {
                v.step(PHYS_DT);
            }
            if veh_hist.len() == 2_000 {
                veh_hist.pop_front();
            }
            veh_hist.push_back(*v.state());
            if let (Some(r), Some(d)) = (receiver.as_mut(), cfg.drive.as_ref()) {
                let t_fix = k_gnss as f64 / d.gnss.rate_hz;
                if t + 0.5 * PHYS_DT >= t_fix && t_fix <= cfg.duration_s {
                    k_gnss += 1;
                    let stamp = t_fix - d.gnss.stamp_early_s;
                    if let Some(f) = r.fix(v.state(), t_fix).filter(|_| stamp >= 0.0) {
                        gnss_rows.push(GnssRow {
                            t_s: stamp,
                            lat_deg: f.pos.lat_rad.to_degrees(),
                            lon_deg: f.pos.lon_rad.to_degrees(),
                            height_m: f.pos.height_m,
                            v_n_mps: [f.v_n.x, f.v_n.y, f.v_n.z],
                            sigma_h_m: f.sigma[0],
                            sigma_v_m: f.sigma[1],
                            sigma_vel_mps: f.sigma[2],
                            quality: None,
                        });
                    }
                }
            }
        }
        // IMU samples whose truth (with jitter) is now known.
        while k_imu < n_imu {
            let t_k = k_imu as f64 / cfg.imu_rate_hz;
            if t_k + MAX_JITTER_S > t && tick != n_ticks {
                break;
            }
            let j = if kept.is_some() {
                0.0
            } else {
                (jitter.normal() * cfg.imu.jitter_s).clamp(-MAX_JITTER_S, MAX_JITTER_S)
            };
            let t_true = (t_k - cfg.imu.latency_s + j).max(0.0);
            let on_vehicle = |tt: f64| {
                let v = veh_at(&veh_hist, tt)?;
                let (w_b, f_b) = v.ideal_b();
                let f_b = f_b + v.c_b_v.transpose() * crate::drive::vibration_v(tt, v.speed_mps);
                Some(scene.truth_on_vehicle(&fixed, &kin_at(tt), tt, &w_b, &f_b))
            };
            let truth = match (&kept, on_vehicle(t_true)) {
                (Some(kept), _) => kept.samples.get(k_imu as usize).copied(),
                (None, Some((w, f))) => Some(SampleTruth {
                    w,
                    f: match cfg.imu.accel_latency_s {
                        Some(l) => on_vehicle((t_k - l + j).max(0.0)).map_or(f, |t| t.1),
                        None => f,
                    },
                    rate: kin_at(t_true).rate,
                }),
                (None, None) => None,
            };
            let SampleTruth { mut w, f, rate } = truth.unwrap_or_else(|| static_truth(k_imu, j));
            w += cfg.geometry.axis.unit::<f64>() * cfg.untracked.rate(&mut untracked, rate, imu_dt);
            if let Some(v) = veh_at(&veh_hist, t_k) {
                let d = tangent.ned_to(&v.pos);
                let [r, p, h] = v.base_euler_rad();
                truth_rows.push(TruthRow {
                    t_s: t_k,
                    p_n_m: [d.x, d.y, d.z],
                    v_n_mps: [v.v_n.x, v.v_n.y, v.v_n.z],
                    euler_deg: [
                        r.to_degrees(),
                        p.to_degrees(),
                        h.to_degrees().rem_euclid(360.0),
                    ],
                });
            }
            let temp = imu.temperature_c(t_true);
            let (g, a) = imu.measure(&w, &f, temp, imu_dt);
            hidden(&Hidden {
                t_s: t_k,
                gyro_bias_radps: imu.gyro_bias_now(&f, temp),
                temp_rise_c: temp - cfg.imu.temp.ambient_c,
            });
            rec.imu.push(ImuRow {
                t_s: t_k,
                gyro_radps: [g.x, g.y, g.z],
                accel_mps2: [a.x, a.y, a.z],
                temp_c: Some(imu.temp_output_c(temp)),
            });
            k_imu += 1;
        }
        while k_enc < n_enc {
            let row = enc_row(k_enc);
            if row.t_s > t {
                break;
            }
            rec.table.push(row);
            k_enc += 1;
        }
        if tick - last_report >= 10_000 {
            last_report = tick;
            progress(tick as f64 / n_ticks as f64);
        }
        // A vehicle moves every tick; on a static base nothing happens
        // until the next sample's truth is known or the next encoder read.
        next_tick = if vehicle.is_some() {
            tick + 1
        } else {
            // The first tick at or after `t_s` (ceil without the library
            // call x86-64's baseline needs for it).
            let due = |t_s: f64| {
                let x = t_s / PHYS_DT;
                let c = x as u64;
                c + u64::from((c as f64) < x)
            };
            let imu_due = due(k_imu as f64 / cfg.imu_rate_hz + MAX_JITTER_S);
            let enc_due = due(k_enc as f64 / cfg.encoder_rate_hz);
            imu_due.min(enc_due).clamp(tick + 1, n_ticks.max(tick + 1))
        };
    }
    progress(1.0);
    if let Some(d) = &cfg.drive {
        // The base's attitude at t = 0 is the vehicle's (its pitch on the
        // road's grade there).
        if let Some(first) = truth_rows.first() {
            let [r, p, h] = first.euler_deg;
            rec.meta.roll_deg = r;
            rec.meta.pitch_deg = p;
            rec.meta.heading_deg = h;
        }
        if let Some(desc) = rec.meta.description.as_mut() {
            desc.push_str(&format!(", {} drive", d.kind.name()));
        }
        rec.moving = Some(MovingBase {
            odometer: None,
            longitude_deg: d.longitude_deg,
            gnss_meta: Some(GnssMeta {
                antenna_b_m: [
                    d.gnss.antenna_b_m.x,
                    d.gnss.antenna_b_m.y,
                    d.gnss.antenna_b_m.z,
                ],
                rate_hz: d.gnss.rate_hz,
            }),
            gnss: Some(gnss_rows),
            truth: Some(truth_rows),
            heading_unknown: false,
        });
    }
    Ok(rec)
}

/// The truth an IMU sample sees (before the sensor's errors).
#[derive(Clone, Copy, Debug)]
struct SampleTruth {
    /// `w_is_s`, rad/s.
    w: Vector3<f64>,
    /// `f_s`, m/s^2.
    f: Vector3<f64>,
    /// The table's rate then, rad/s.
    rate: f64,
}

/// A static base's truths without jitter: each IMU sample's, and the
/// encoder's readings (deterministic: the table's motion, quantised).
struct StaticTruths {
    /// Per IMU sample.
    samples: Vec<SampleTruth>,
    /// The encoder's rows, as the recording stores them.
    table: Vec<TableRow>,
}

/// What a static base's truths are made from: the table's motion, the
/// scene, the sample times, the encoder.
#[derive(Clone, Debug, PartialEq)]
struct TruthKey {
    ideal: bool,
    motor: MotorParams,
    scheme: Scheme,
    limits: Limits,
    static_s: f64,
    duration_s: f64,
    scene: Scene,
    latency_s: f64,
    accel_latency_s: Option<f64>,
    imu_rate_hz: f64,
    encoder: EncoderSpec,
    encoder_rate_hz: f64,
}

impl TruthKey {
    fn of(cfg: &SimConfig, scene: &Scene) -> Self {
        Self {
            ideal: cfg.ideal,
            motor: cfg.motor.clone(),
            scheme: cfg.scheme,
            limits: cfg.limits,
            static_s: cfg.static_s,
            duration_s: cfg.duration_s,
            scene: *scene,
            latency_s: cfg.imu.latency_s,
            accel_latency_s: cfg.imu.accel_latency_s,
            imu_rate_hz: cfg.imu_rate_hz,
            encoder: cfg.encoder,
            encoder_rate_hz: cfg.encoder_rate_hz,
        }
    }
}

/// Static-base runs' truths without jitter: the last four, up to 64 MB
/// (56 bytes an IMU sample, 16 an encoder reading).
static KEPT_TRUTHS: Kept<TruthKey, StaticTruths> = Kept::new(4, 64 << 20);

/// The vehicle at `t` (s) from the tick history, its rates and forces
/// linear between ticks; `None` on a static base.
fn veh_at(h: &VecDeque<VehicleState>, t: f64) -> Option<VehicleState> {
    let first = h.front()?;
    let x = ((t - first.t_s) / PHYS_DT).max(0.0);
    let i = (x.floor() as usize).min(h.len().saturating_sub(2));
    let (Some(a), Some(b)) = (h.get(i), h.get(i + 1)) else {
        return h.back().copied();
    };
    let u = (x - i as f64).clamp(0.0, 1.0);
    let mut v = *a;
    v.t_s = a.t_s + u * (b.t_s - a.t_s);
    v.v_n = a.v_n + (b.v_n - a.v_n) * u;
    v.a_n = a.a_n + (b.a_n - a.a_n) * u;
    v.w_nv_v = a.w_nv_v + (b.w_nv_v - a.w_nv_v) * u;
    v.pos.lat_rad = a.pos.lat_rad + u * (b.pos.lat_rad - a.pos.lat_rad);
    v.pos.lon_rad = a.pos.lon_rad + u * (b.pos.lon_rad - a.pos.lon_rad);
    v.pos.height_m = a.pos.height_m + u * (b.pos.height_m - a.pos.height_m);
    for k in 0..3 {
        v.euler_rad[k] = a.euler_rad[k] + u * wrap(b.euler_rad[k] - a.euler_rad[k]);
    }
    Some(v)
}

fn wrap(x: f64) -> f64 {
    (x + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

#[cfg(test)]
mod knob_tests {
    use super::EFFECTS;
    use crate::catalogue::EffectId;

    #[test]
    fn every_catalogue_id_has_a_simulator_knob() {
        for e in EffectId::ALL {
            assert!(
                EFFECTS.iter().any(|k| k.name == e.as_str()),
                "{e}: no --effect knob"
            );
        }
    }
}

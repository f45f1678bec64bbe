//! `rins study`: the blind study of `rins diagnose`.
//!
//! For each sensor grade (`nav440` to `mtig`) and each effect id, recordings
//! with the effect hidden at multiples of its minimum detectable effect
//! (MDE: the magnitude the detection rule catches half the time, from the
//! Fisher information of the run, [`crate::fisher()`]), many seeds
//! per cell, plus null recordings. Detection runs and nulls start from the
//! whole sensor ([`background_full`]): the grade's full error model (bias,
//! scale, misalignment, rate-squared terms, asymmetry, g-sensitivity, white
//! noise, bias instability, output quantisation, temperature and warm-up
//! with its temperature recorded) and the default table (motor, servo,
//! cogging, 14-bit encoder). The tool is not told what is inside.
//!
//! Scored: detection (the effect named) against magnitude, false alarms on
//! the nulls (a finding beyond the profile's own terms at up to
//! [`PROFILE_FACTOR`] times their size, [`beyond_profile`]; its bias
//! instability is the background's), and the confusion matrix (injected at
//! 2x MDE -> first named).
//!
//! Runs: 600 s, reciprocating at 60 deg/s (two turns each way) after 30 s
//! still. About a vertical axis, except g-sensitivity and accelerometer
//! nonlinearity, which a vertical axis cannot excite (gravity stays on z):
//! those turn about the horizontal y axis. The noise terms have no Fisher
//! MDE (their test is a likelihood ratio, not a regression): they are
//! hidden at multiples of the profile's figure ([`noise_scales`]:
//! `bias_instability` x the datasheet's, `untracked_table_motion` x the
//! gyro white noise density).

use crate::realnoise::RealNoise;
use crate::DiagnoseError;
use crate::{fisher, lambda_50, run as diagnose_run, Options};
use core_nav::earth::EARTH_RATE_RADPS;
use core_nav::scheme::Scheme;
use core_nav::table::Axis;
use hal_sim::catalogue::EffectId;
use hal_sim::imu::ImuSpec;
use hal_sim::sim::SimError;
use hal_sim::sim::{simulate, SimConfig};
use rayon::prelude::*;
use recording::Recording;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// The table axis an effect's run turns about and a reference magnitude
/// (SI, the `--effect` unit; earth_rate in rad/s of extra rate) from which
/// the MDE is scaled. Every catalogue id is studied (the match is
/// exhaustive: a new id must say how it is studied).
pub fn scenario(id: EffectId) -> (Axis, f64) {
    match id {
        EffectId::EarthRate => (Axis::Z, 2e-5),
        EffectId::LeverArm => (Axis::Z, 0.02),
        EffectId::TimeOffset => (Axis::Z, 0.002),
        EffectId::GyroScaleNonlinearity => (Axis::Z, 0.003),
        EffectId::GyroScaleAsymmetry => (Axis::Z, 1e-3),
        EffectId::AxisTilt => (Axis::Z, 2e-3),
        EffectId::EncoderError => (Axis::Z, 2e-4),
        EffectId::TemperatureBias => (Axis::Z, 2e-5),
        // Excited only with gravity across the table axis: a horizontal axis.
        EffectId::GyroGSensitivity => (Axis::Y, 2e-4),
        EffectId::AccelScaleNonlinearity => (Axis::Y, 2e-4),
        EffectId::BiasInstability => (Axis::Z, 1.0),
        EffectId::TableAngleHarmonic => (Axis::Z, 2e-3),
        EffectId::UntrackedTableMotion => (Axis::Z, 1.0),
    }
}

/// Multiples of the profile's gyro white noise density at which
/// `untracked_table_motion` is hidden (its size is a density too).
pub const UNTRACKED_SCALES: [f64; 4] = [1.0, 3.0, 10.0, 30.0];

/// A noise effect's magnitudes: the multiples and the profile's figure they
/// multiply (bias instability: the datasheet's; untracked table motion: the
/// gyro white noise density); `None` for an effect with an MDE.
pub fn noise_scales(g: &ImuSpec, id: EffectId) -> Option<(&'static [f64], f64)> {
    match id {
        EffectId::BiasInstability => Some((&BI_SCALES, g.gyro.bias_instability)),
        EffectId::UntrackedTableMotion => Some((&UNTRACKED_SCALES, g.gyro.white)),
        _ => None,
    }
}

/// The scale at which a cell enters the confusion matrix: 2x the MDE, the
/// datasheet's bias instability, ten times the gyro's white noise.
fn confusion_scale(id: &str) -> f64 {
    match EffectId::parse(id) {
        Some(EffectId::BiasInstability) => 1.0,
        Some(EffectId::UntrackedTableMotion) => 10.0,
        _ => 2.0,
    }
}

/// Every effect studied with its scenario.
pub fn effects() -> Vec<(EffectId, Axis, f64)> {
    EffectId::ALL
        .into_iter()
        .map(|e| {
            let (axis, reference) = scenario(e);
            (e, axis, reference)
        })
        .collect()
}

/// Levels at which the confidences are checked on the nulls.
pub const CALIBRATION_ALPHAS: [f64; 3] = [0.1, 0.01, 0.001];

/// Multiples of the MDE.
pub const SCALES: [f64; 4] = [0.5, 1.0, 2.0, 4.0];
/// Multiples of the datasheet bias instability.
pub const BI_SCALES: [f64; 4] = [0.1, 0.3, 1.0, 3.0];

/// Why a study cannot run.
#[derive(Debug)]
pub enum StudyError {
    /// No sensor profile of that name.
    UnknownGrade(String),
    /// A simulation failed.
    Sim(SimError),
    /// A diagnosis failed.
    Diagnose(DiagnoseError),
    /// The thread pool failed.
    Worker(String),
    /// A `+real` grade without a real recording.
    NoRealNoise,
    /// The real recording cannot serve the run.
    RealNoise(String),
}

impl std::fmt::Display for StudyError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StudyError::UnknownGrade(g) => {
                write!(f, "unknown grade {g:?} ({})", ImuSpec::NAMES.join(", "))
            }
            StudyError::Sim(e) => write!(f, "simulation: {e}"),
            StudyError::Diagnose(e) => write!(f, "diagnose: {e}"),
            StudyError::Worker(e) => f.write_str(e),
            StudyError::NoRealNoise => {
                f.write_str("a +real grade needs a real static recording (--real-noise PATH)")
            }
            StudyError::RealNoise(e) => write!(f, "real noise: {e}"),
        }
    }
}

impl std::error::Error for StudyError {}

impl From<SimError> for StudyError {
    fn from(e: SimError) -> Self {
        StudyError::Sim(e)
    }
}

impl From<DiagnoseError> for StudyError {
    fn from(e: DiagnoseError) -> Self {
        StudyError::Diagnose(e)
    }
}

/// A grade of the study: a sensor profile's deterministic errors (bias,
/// scale, misalignment) and its noise, simulated from the profile or taken
/// from a real static recording ([`RealNoise`]).
#[derive(Clone, Debug)]
pub struct Grade {
    /// Name in the tables (`nav440`, `adis16405+real`, ...).
    pub name: String,
    /// The profile.
    pub spec: ImuSpec,
    /// Real noise, when the background is real.
    pub real: Option<Arc<RealNoise>>,
}

/// A grade by name (the `rins simulate --imu` profiles); `<profile>+real`
/// takes its noise from `real`.
///
/// # Errors
/// An unknown name, or `+real` without a real recording.
pub fn grade(name: &str, real: Option<&Arc<RealNoise>>) -> Result<Grade, StudyError> {
    let (profile, is_real) = match name.strip_suffix("+real") {
        Some(p) => (p, true),
        None => (name, false),
    };
    let spec = hal_sim::sensor::resolve(profile)
        .map_err(|e| StudyError::UnknownGrade(format!("{name}: {e}")))?;
    let real = if is_real {
        Some(real.cloned().ok_or(StudyError::NoRealNoise)?)
    } else {
        None
    };
    Ok(Grade {
        name: name.to_string(),
        spec,
        real,
    })
}

/// One run's background for grade `g` about `axis` (`wander`: with the
/// profile's bias instability, simulated grades only).
pub fn background(g: &Grade, axis: Axis, wander: bool, seed: u64) -> SimConfig {
    let mut s = ImuSpec::ideal();
    let real = g.real.is_some();
    for (t, f) in [(&mut s.gyro, &g.spec.gyro), (&mut s.accel, &g.spec.accel)] {
        t.bias = f.bias;
        t.scale = f.scale;
        t.misalignment = f.misalignment;
        // A real background brings its own noise and quantisation.
        if !real {
            t.white = f.white;
            t.lsb = f.lsb;
        }
    }
    if wander && !real {
        s.gyro.bias_instability = g.spec.gyro.bias_instability;
        s.gyro.bi_tau_s = g.spec.gyro.bi_tau_s;
    }
    s.temp = g.spec.temp;
    if real {
        // Its thermal drift is in the real samples, its temperature unknown.
        s.temp.warmup_c = 0.0;
    }
    let mut c = SimConfig::new(s, axis, 600.0);
    c.scheme = Scheme::Reciprocating {
        rate: 60f64.to_radians(),
        turns: 2,
    };
    c.static_s = 30.0;
    c.seed = seed;
    c
}

/// A null with the whole sensor: grade `g`'s full error model (its
/// rate-squared terms, asymmetry, g-sensitivity, temperature and warm-up,
/// wandering bias), the simulator's default table (14-bit encoder, motor
/// ripple, cogging, servo), on the study's run about `axis`. With a real
/// background its noise and thermal drift are the real recording's.
pub fn background_full(g: &Grade, axis: Axis, seed: u64) -> SimConfig {
    let mut s = g.spec.clone();
    if g.real.is_some() {
        for t in [&mut s.gyro, &mut s.accel] {
            t.white = 0.0;
            t.lsb = 0.0;
            t.bias_instability = 0.0;
            t.rrw = 0.0;
        }
        s.temp.warmup_c = 0.0;
    }
    let mut c = background(g, axis, true, seed);
    c.imu = s;
    c
}

/// The runs the nulls with the whole sensor take in turn.
pub const FULL_NULL_RUNS: usize = 3;

/// Null run `k` (mod [`FULL_NULL_RUNS`]) on the background `c`: the
/// study's own run; the book's diagnose example (`--scheme reciprocating
/// --rate-dps 60`: one turn each way, no still start); the board's run
/// (continuous at 30 deg/s). The last two are where the 14-bit encoder's
/// quantisation was once fitted as physics.
pub fn full_null_run(mut c: SimConfig, k: usize) -> SimConfig {
    match k % FULL_NULL_RUNS {
        1 => {
            c.scheme = Scheme::Reciprocating {
                rate: 60f64.to_radians(),
                turns: 1,
            };
            c.static_s = 0.0;
        }
        2 => {
            c.scheme = Scheme::Continuous {
                rate: 30f64.to_radians(),
            };
            c.static_s = 0.0;
        }
        _ => {}
    }
    c
}

/// The profile's own figure for effect `id` (what a null with the whole
/// sensor may name, at up to [`PROFILE_FACTOR`] times this size), in the
/// effect's parameter unit; `None` for an effect the profile does not have.
/// `accel` picks the accelerometer triad's figure where both have one.
pub fn profile_figure(spec: &ImuSpec, id: EffectId, accel: bool) -> Option<f64> {
    let t = if accel { &spec.accel } else { &spec.gyro };
    let v = match id {
        EffectId::GyroScaleNonlinearity => spec.gyro.k2,
        EffectId::GyroScaleAsymmetry => spec.gyro.asymmetry,
        EffectId::AccelScaleNonlinearity => spec.accel.k2,
        EffectId::GyroGSensitivity => spec.g_sensitivity,
        EffectId::TemperatureBias => t.temp_bias,
        EffectId::TimeOffset => spec.latency_s,
        _ => 0.0,
    };
    (v > 0.0).then_some(v)
}

/// How far beyond the profile's own figure a null's finding may be before it
/// is a false alarm: the 4x (a 1-sigma figure drawn at 3 sigma
/// is inside).
pub const PROFILE_FACTOR: f64 = 4.0;

/// The findings of a null with the whole sensor that the profile does not
/// explain: an effect it does not have, or one beyond [`PROFILE_FACTOR`]
/// times its figure (bias instability, the profile's noise, aside).
pub fn beyond_profile(d: &crate::Diagnosis, spec: &ImuSpec) -> Vec<String> {
    d.findings
        .iter()
        .filter(|f| f.effect != EffectId::BiasInstability)
        .filter(|f| {
            // A noise term the profile does not have (the table's untracked
            // motion) is beyond it whatever its size.
            f.effect.is_noise()
                || f.parameters.iter().filter(|p| p.sigma.is_some()).any(|p| {
                    let accel = p.name.contains("mps2");
                    profile_figure(spec, f.effect, accel)
                        .is_none_or(|fig| p.value.abs() > PROFILE_FACTOR * fig)
                })
        })
        .map(|f| f.effect.as_str().to_string())
        .collect()
}

/// Simulates `c` for grade `g`: with a real background, the draw of `seed`
/// from the real recording is added (and the temperature column dropped).
///
/// # Errors
/// A simulation failure; a real recording too short for the run.
pub fn record(g: &Grade, c: &SimConfig, seed: u64) -> Result<Recording, StudyError> {
    let mut rec = simulate(c, &mut |_| {})?;
    if let Some(r) = &g.real {
        let d = r.draw(seed, rec.imu.len());
        r.add_to(&mut rec, d)
            .map_err(|e| StudyError::RealNoise(e.to_string()))?;
    }
    Ok(rec)
}

/// Puts `effect` at `mag` into `c` (earth_rate: `mag` rad/s more than the
/// earth's; bias_instability: `mag` x the grade's value; the rest in their
/// knob's unit).
pub fn inject(
    c: &mut SimConfig,
    g: &ImuSpec,
    effect: EffectId,
    mag: f64,
) -> Result<(), StudyError> {
    match effect {
        EffectId::EarthRate => Ok(c.set_effect(effect.as_str(), 1.0 + mag / EARTH_RATE_RADPS)?),
        EffectId::BiasInstability => {
            c.imu.gyro.bias_instability = g.gyro.bias_instability * mag;
            c.imu.gyro.bi_tau_s = g.gyro.bi_tau_s;
            // The wander hidden is the gyros' alone: the whole sensor's
            // accelerometer wander would be named for it.
            c.imu.accel.bias_instability = 0.0;
            c.imu.accel.rrw = 0.0;
            c.imu.gyro.rrw = 0.0;
            Ok(())
        }
        EffectId::TemperatureBias => {
            // A real background has no warm-up of its own (its temperature
            // is unknown): the effect brings the profile's, and on a real
            // background its temperature column is dropped, so diagnose
            // sees a warm-up on real drift (the hard case).
            c.imu.temp.warmup_c = g.temp.warmup_c;
            Ok(c.set_effect(effect.as_str(), mag)?)
        }
        _ => Ok(c.set_effect(effect.as_str(), mag)?),
    }
}

/// One cell of the table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cell {
    /// Grade.
    pub grade: String,
    /// Effect id.
    pub effect: String,
    /// Multiple of the MDE (or of the datasheet value for bias instability).
    pub scale: f64,
    /// Injected magnitude (the effect's unit).
    pub magnitude: f64,
    /// Runs.
    pub runs: usize,
    /// Runs where the effect was named.
    pub detected: usize,
    /// Runs where it was named first.
    pub first: usize,
    /// Runs where it was named, or a finding said it cannot be told apart
    /// from it in this run (a look-alike).
    pub named_or_lookalike: usize,
    /// The magnitude is beyond what any sensor, table or site can have
    /// (the catalogue's bound): not simulated, no runs.
    pub beyond_bound: bool,
}

/// Minimum detectable effect of one effect in one grade's run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Mde {
    /// Grade.
    pub grade: String,
    /// Effect id.
    pub effect: String,
    /// Parameters the run excites.
    pub k: usize,
    /// Noncentrality at the reference magnitude.
    pub lambda_ref: f64,
    /// Noncentrality the rule detects half the time.
    pub lambda_50: f64,
    /// The MDE (the effect's unit).
    pub mde: f64,
}

/// The study's result.
#[derive(Clone, Debug, Serialize)]
pub struct Study {
    /// Seeds per cell.
    pub runs: usize,
    /// MDE per grade and effect.
    pub mde: Vec<Mde>,
    /// Detection per grade, effect and magnitude.
    pub cells: Vec<Cell>,
    /// Null runs per grade.
    pub null_runs: BTreeMap<String, usize>,
    /// Null runs with a finding other than bias instability, per grade.
    pub false_alarms: BTreeMap<String, usize>,
    /// Per grade, each null run's strongest evidence for any effect (the
    /// smallest adjusted tail probability, `Details::strongest_p_adjusted`):
    /// the confidences are honest when at most a fraction `alpha` of them
    /// fall below `alpha`.
    pub null_strongest_p: BTreeMap<String, Vec<f64>>,
    /// Injected effect (at 2x MDE) -> first effect named ("none") -> count.
    pub confusion: BTreeMap<String, BTreeMap<String, usize>>,
    /// Nulls with the whole sensor ([`background_full`]) per grade.
    pub full_null_runs: BTreeMap<String, usize>,
    /// Per grade, what those nulls named beyond the profile's own terms
    /// ([`beyond_profile`]; "none" for a run that named nothing beyond
    /// them) -> runs.
    pub full_named: BTreeMap<String, BTreeMap<String, usize>>,
}

/// What a run named: effects (most significant first), look-alikes, the
/// run's strongest evidence (adjusted tail probability).
pub type Named = (Vec<String>, Vec<String>, f64);

/// A null with the whole sensor: what it names beyond the profile's own
/// terms ([`beyond_profile`]) and the smallest adjusted noise-alone
/// probability among those findings (1 if none).
fn beyond_profile_named(rec: &Recording, spec: &ImuSpec) -> Result<Named, StudyError> {
    let d = diagnose_run(rec, "study", &Options::default())?;
    let beyond = beyond_profile(&d, spec);
    let p = d
        .findings
        .iter()
        .filter(|f| beyond.iter().any(|b| f.effect == b.as_str()))
        .map(|f| 1.0 - f.confidence)
        .fold(1.0f64, f64::min);
    Ok((beyond, vec![], p))
}

/// Effects named in a run, most significant first (bias instability
/// dropped unless `keep_bi`), and the look-alikes the findings name.
fn named(rec: &Recording, keep_bi: bool) -> Result<Named, StudyError> {
    let d = diagnose_run(rec, "study", &Options::default())?;
    let found = d
        .findings
        .iter()
        .map(|f| f.effect)
        .filter(|e| keep_bi || *e != EffectId::BiasInstability)
        .map(|e| e.as_str().to_string())
        .collect();
    let alike = d
        .findings
        .iter()
        .filter_map(|f| f.lookalike)
        .chain(d.unexplained.iter().filter_map(|u| u.may_be))
        .map(|e| e.as_str().to_string())
        .collect();
    Ok((found, alike, d.details.strongest_p_adjusted))
}

/// The MDE of `effect` in grade `g`'s run.
///
/// # Errors
/// A simulation or diagnosis failure.
pub fn mde(g: &Grade, effect: EffectId, axis: Axis, reference: f64) -> Result<Mde, StudyError> {
    // The noise model from the run as recorded; the signature from twins
    // without quantisation (encoder and output), whose rounding changes with
    // any change of the signal and would pass for part of it.
    let c0 = background_full(g, axis, 99);
    let mut s0 = c0.clone();
    s0.encoder.counts_per_rev = 1 << 30;
    s0.imu.gyro.lsb = 0.0;
    s0.imu.accel.lsb = 0.0;
    let mut s1 = s0.clone();
    inject(&mut s1, &g.spec, effect, reference)?;
    let r0 = record(g, &c0, 99)?;
    let (mut q0, mut q1) = (simulate(&s0, &mut |_| {})?, simulate(&s1, &mut |_| {})?);
    if g.real.is_some() {
        // As the real runs: no temperature column (the same candidates).
        for row in q0.imu.iter_mut().chain(q1.imu.iter_mut()) {
            row.temp_c = None;
        }
    }
    let (lam, k, n) = fisher(&r0, &q0, &q1, effect, &Options::default())?;
    let l50 = lambda_50(k, n);
    let mde = if lam > 0.0 && k > 0 {
        reference * (l50 / lam).sqrt()
    } else {
        f64::INFINITY
    };
    Ok(Mde {
        grade: g.name.clone(),
        effect: effect.as_str().into(),
        k,
        lambda_ref: lam,
        lambda_50: l50,
        mde,
    })
}

/// A unit of work: one run of a cell, a null, or a null with the whole
/// sensor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Job {
    /// Cell `cell`'s run with `seed`.
    Cell {
        /// Index into [`Plan::cells`].
        cell: usize,
        /// The run's seed.
        seed: u64,
    },
    /// A null of grade `grade` (index into the plan's grades).
    Null {
        /// Grade index.
        grade: usize,
        /// The run's seed.
        seed: u64,
    },
    /// A null with the whole sensor, as run `run` of [`full_null_run`].
    FullNull {
        /// Grade index.
        grade: usize,
        /// The run's seed.
        seed: u64,
        /// Which run.
        run: usize,
    },
}

/// What a study will run: its MDEs, cells and jobs (every shard of a
/// study computes the same plan; the jobs are what the shards split).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// The grades' names, in order.
    pub grades: Vec<String>,
    /// Seeds per cell.
    pub runs: usize,
    /// MDE per grade and effect.
    pub mde: Vec<Mde>,
    /// The cells, nothing counted yet.
    pub cells: Vec<Cell>,
    /// Each cell's (grade index, effect, axis, magnitude in inject's unit).
    #[serde(skip)]
    meta: Vec<(usize, EffectId, Axis, f64)>,
    /// Every run of the study, in order: job `i` is the study's run `i`.
    pub jobs: Vec<Job>,
}

/// Plans the study: `runs` seeds per cell, `nulls` null runs per grade
/// (half about z, half about y), seeds from `seed`.
///
/// # Errors
/// A simulation failure (the MDEs' runs).
pub fn plan(
    grades: &[Grade],
    effects: &[(EffectId, Axis, f64)],
    runs: usize,
    nulls: usize,
    seed: u64,
) -> Result<Plan, StudyError> {
    // MDEs first (two noise-free-difference runs each).
    let mut mdes = vec![];
    for g in grades {
        for (e, axis, reference) in effects {
            if e.is_noise() {
                continue;
            }
            mdes.push(mde(g, *e, *axis, *reference)?);
        }
    }
    let mut cells = vec![];
    let mut meta = vec![]; // (grade index, effect, axis, scale)
    for (gi, g) in grades.iter().enumerate() {
        for (e, axis, _) in effects {
            // A real background has its own wandering bias: hiding more on
            // top of it tells nothing about the tool.
            if *e == EffectId::BiasInstability && g.real.is_some() {
                continue;
            }
            let (scales, base): (&[f64], f64) = match noise_scales(&g.spec, *e) {
                Some(n) => n,
                None => {
                    let m = mdes
                        .iter()
                        .find(|m| m.grade == g.name && m.effect == e.as_str())
                        .map_or(f64::INFINITY, |m| m.mde);
                    (&SCALES, m)
                }
            };
            if !base.is_finite() {
                continue;
            }
            for s in scales {
                let magnitude = base * s;
                let beyond_bound = e.bound().is_some_and(|b| magnitude > b.max_abs);
                cells.push(Cell {
                    grade: g.name.clone(),
                    effect: e.as_str().into(),
                    scale: *s,
                    magnitude,
                    runs: if beyond_bound { 0 } else { runs },
                    detected: 0,
                    first: 0,
                    named_or_lookalike: 0,
                    beyond_bound,
                });
                meta.push((
                    gi,
                    *e,
                    *axis,
                    // inject's unit: bias instability as the multiple.
                    if *e == EffectId::BiasInstability {
                        *s
                    } else {
                        magnitude
                    },
                ));
            }
        }
    }
    let mut jobs = vec![];
    for (ci, cell) in cells.iter().enumerate() {
        for k in 0..cell.runs {
            jobs.push(Job::Cell {
                cell: ci,
                seed: seed + 1000 * k as u64 + 17,
            });
        }
    }
    for gi in 0..grades.len() {
        for k in 0..nulls {
            jobs.push(Job::Null {
                grade: gi,
                seed: seed + 7919 * k as u64 + 3,
            });
            jobs.push(Job::FullNull {
                grade: gi,
                seed: seed + 7919 * k as u64 + 5,
                run: 1 + k % (FULL_NULL_RUNS - 1),
            });
        }
    }
    Ok(Plan {
        grades: grades.iter().map(|g| g.name.clone()).collect(),
        runs,
        mde: mdes,
        cells,
        meta,
        jobs,
    })
}

/// Runs the plan's jobs whose index `keep` accepts (all of them: the
/// whole study; `i % N == K`: shard K of N), in parallel on rayon's pool;
/// returns (job index, what it named) in job order.
///
/// # Errors
/// A simulation or diagnosis failure.
pub fn run_jobs(
    grades: &[Grade],
    plan: &Plan,
    keep: &(dyn Fn(usize) -> bool + Sync),
    progress: &(dyn Fn(f64) + Sync),
) -> Result<Vec<(usize, Named)>, StudyError> {
    let mine: Vec<usize> = (0..plan.jobs.len()).filter(|i| keep(*i)).collect();
    let done = AtomicUsize::new(0);
    let total = mine.len().max(1);
    mine.par_iter()
        .map(|&i| {
            let out = run_job(grades, plan, &plan.jobs[i]).map(|v| (i, v));
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(d as f64 / total as f64);
            out
        })
        .collect()
}

fn run_job(grades: &[Grade], plan: &Plan, job: &Job) -> Result<Named, StudyError> {
    match job {
        Job::Cell { cell, seed } => {
            let (gi, e, axis, mag) = *plan
                .meta
                .get(*cell)
                .ok_or_else(|| StudyError::Worker(format!("no cell {cell}")))?;
            let bi = e == EffectId::BiasInstability;
            let g = &grades[gi];
            let mut c = background_full(g, axis, *seed);
            inject(&mut c, &g.spec, e, mag)
                .and_then(|()| record(g, &c, *seed))
                .and_then(|r| named(&r, bi))
        }
        Job::Null { grade, seed } => {
            let axis = if seed % 2 == 0 { Axis::Z } else { Axis::Y };
            let g = &grades[*grade];
            record(g, &background_full(g, axis, *seed), *seed)
                .and_then(|r| beyond_profile_named(&r, &g.spec))
        }
        Job::FullNull { grade, seed, run } => {
            let g = &grades[*grade];
            let c = full_null_run(background_full(g, Axis::Z, *seed), *run);
            record(g, &c, *seed).and_then(|r| {
                let d = diagnose_run(&r, "study", &Options::default())?;
                Ok((beyond_profile(&d, &g.spec), vec![], 1.0))
            })
        }
    }
}

/// The study from its plan and every job's result (from one run or from
/// all the shards, in any order): the same counts either way.
///
/// # Errors
/// A job missing or given twice.
pub fn aggregate(plan: &Plan, mut results: Vec<(usize, Named)>) -> Result<Study, StudyError> {
    results.sort_by_key(|r| r.0);
    let idx: Vec<usize> = results.iter().map(|r| r.0).collect();
    if idx != (0..plan.jobs.len()).collect::<Vec<_>>() {
        return Err(StudyError::Worker(format!(
            "{} results for {} jobs: a shard is missing or given twice",
            idx.len(),
            plan.jobs.len()
        )));
    }
    let jobs = &plan.jobs;
    let mut cells = plan.cells.clone();
    let runs = plan.runs;
    let mdes = plan.mde.clone();
    let mut confusion: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    let mut null_runs = BTreeMap::new();
    let mut false_alarms = BTreeMap::new();
    let mut full_null_runs: BTreeMap<String, usize> = BTreeMap::new();
    let mut full_named: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    let mut null_p: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for (i, (found, alike, p_adj)) in results {
        match &jobs[i] {
            Job::Cell { cell, .. } => {
                let c = &mut cells[*cell];
                let hit = found.contains(&c.effect);
                c.detected += usize::from(hit);
                c.named_or_lookalike += usize::from(hit || alike.contains(&c.effect));
                c.first += usize::from(found.first() == Some(&c.effect));
                if c.scale == confusion_scale(&c.effect) {
                    let top = found.first().cloned().unwrap_or_else(|| "none".into());
                    *confusion
                        .entry(c.effect.clone())
                        .or_default()
                        .entry(top)
                        .or_default() += 1;
                }
            }
            Job::FullNull { grade, .. } => {
                let g = plan.grades[*grade].clone();
                *full_null_runs.entry(g.clone()).or_insert(0) += 1;
                let named = full_named.entry(g).or_default();
                if found.is_empty() {
                    *named.entry("none".into()).or_insert(0) += 1;
                }
                for e in found {
                    *named.entry(e).or_insert(0) += 1;
                }
            }
            Job::Null { grade, .. } => {
                let g = plan.grades[*grade].clone();
                null_p.entry(g.clone()).or_default().push(p_adj);
                *null_runs.entry(g.clone()).or_insert(0) += 1;
                let fa = !found.is_empty();
                *false_alarms.entry(g).or_insert(0) += usize::from(fa);
                let top = found.first().cloned().unwrap_or_else(|| "none".into());
                *confusion
                    .entry("none".into())
                    .or_default()
                    .entry(top)
                    .or_default() += 1;
            }
        }
    }
    Ok(Study {
        runs,
        mde: mdes,
        cells,
        null_runs,
        false_alarms,
        null_strongest_p: null_p,
        confusion,
        full_null_runs,
        full_named,
    })
}

/// The format of a study shard's JSON.
pub const SHARD_FORMAT: &str = "rins-study-shard/1";

/// One shard of a study: its plan (the same in every shard), which shard
/// it is (k of n, as `--shard K/N`), and the results of its jobs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StudyShard {
    /// [`SHARD_FORMAT`].
    pub format: String,
    /// The study's plan.
    pub plan: Plan,
    /// This shard, from 0.
    pub k: usize,
    /// Shards in all.
    pub n: usize,
    /// (job index, what the run named), in job order.
    pub results: Vec<(usize, Named)>,
}

/// Runs the whole study: `runs` seeds per cell, `nulls` null runs per
/// grade (half about z, half about y), in parallel on rayon's pool.
///
/// # Errors
/// A simulation failure or an unknown grade.
pub fn run(
    grades: &[Grade],
    effects: &[(EffectId, Axis, f64)],
    runs: usize,
    nulls: usize,
    seed: u64,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<Study, StudyError> {
    let p = plan(grades, effects, runs, nulls, seed)?;
    let results = run_jobs(grades, &p, &|_| true, progress)?;
    aggregate(&p, results)
}

/// The study as Markdown: detection per magnitude, MDEs, false alarms, the
/// confusion matrix.
pub fn markdown(s: &Study) -> String {
    let mut out = String::new();
    let mut grades: Vec<&str> = s.cells.iter().map(|c| c.grade.as_str()).collect();
    grades.dedup();
    for g in grades {
        out += &format!(
            "#### {g}: detection (named anywhere) against magnitude, {} seeds a cell\n\n",
            s.runs
        );
        out += "| effect | MDE | 0.5x | 1x | 2x | 4x |\n| --- | --- | --- | --- | --- | --- |\n";
        let mut effects: Vec<&str> = s
            .cells
            .iter()
            .filter(|c| c.grade == g)
            .map(|c| c.effect.as_str())
            .collect();
        effects.dedup();
        for e in effects {
            let m = s.mde.iter().find(|m| m.grade == g && m.effect == e);
            let mde = m.map_or_else(
                || match EffectId::parse(e) {
                    Some(EffectId::UntrackedTableMotion) => "gyro white x 1 / 3 / 10 / 30".into(),
                    _ => "datasheet BI x 0.1 / 0.3 / 1 / 3".into(),
                },
                |m| format!("{:.2e}", m.mde),
            );
            out += &format!("| {e} | {mde} |");
            for c in s.cells.iter().filter(|c| c.grade == g && c.effect == e) {
                let pct = |n: usize| 100.0 * n as f64 / c.runs.max(1) as f64;
                if c.beyond_bound {
                    out += " beyond bound |";
                } else if c.named_or_lookalike > c.detected {
                    out += &format!(
                        " {:.0} % ({:.0} %) |",
                        pct(c.detected),
                        pct(c.named_or_lookalike)
                    );
                } else {
                    out += &format!(" {:.0} % |", pct(c.detected));
                }
            }
            out += "\n";
        }
        let nr = s.null_runs.get(g).copied().unwrap_or(0);
        let fa = s.false_alarms.get(g).copied().unwrap_or(0);
        out += "\n(in brackets: named, or named by a finding as the look-alike it cannot be told apart from in this run)\n";
        out += &format!(
            "\nfalse alarms on {nr} null runs with the whole sensor (named beyond the profile's own terms at up to {PROFILE_FACTOR}x): {fa} ({:.1} %)\n",
            100.0 * fa as f64 / nr.max(1) as f64
        );
        if let (Some(n), Some(named)) = (s.full_null_runs.get(g), s.full_named.get(g)) {
            let clean = named.get("none").copied().unwrap_or(0);
            let beyond: Vec<String> = named
                .iter()
                .filter(|(k, _)| k.as_str() != "none")
                .map(|(k, v)| format!("{k} {v}"))
                .collect();
            out += &format!(
                "the diagnose chapter's example and the board's run (the whole sensor, no still start): {} of {n} name something beyond the profile's own terms at up to {PROFILE_FACTOR}x their size{}\n",
                n - clean,
                if beyond.is_empty() {
                    String::new()
                } else {
                    format!(" ({})", beyond.join(", "))
                }
            );
        }
        if let Some(ps) = s.null_strongest_p.get(g) {
            out += "confidence on the nulls (a finding at confidence 1 - alpha should turn up in at most alpha of them):";
            for a in CALIBRATION_ALPHAS {
                let k = ps.iter().filter(|p| **p < a).count();
                out += &format!(
                    " alpha {a}: {k} of {} ({:.1} %);",
                    ps.len(),
                    100.0 * k as f64 / ps.len().max(1) as f64
                );
            }
            out += "\n\n";
        }
    }
    out += "confusion (injected at 2x MDE, bias instability at 1x datasheet, untracked table motion at 10x the gyro white; nulls as `none`) -> first named, all grades:\n\n";
    for (inj, row) in &s.confusion {
        out += &format!(
            "- {inj}: {}\n",
            row.iter()
                .map(|(k, v)| format!("{k} {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    out
}

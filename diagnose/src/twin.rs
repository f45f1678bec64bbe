//! The simulator is the model: a diagnosis written as a hal-sim sensor model
//! ([`SimModel`], `rins diagnose --sim-model`), the recording's own run
//! re-simulated with it ([`hal_sim::twin::simulate_like`], `rins simulate
//! --like`), and the recording judged against that twin.
//!
//! **Closeness.** The twin is good when the recording sits as close to it as
//! two seeds of the twin sit to each other: per channel, the rms difference
//! of 1 s block means between the recording and each of [`TWIN_SEEDS`]
//! twins, over the same between every pair of twins. A ratio near 1: the
//! recording is one more draw of the twin; well above 1: the twin misses
//! something the recording has (a finding left out, a noise model too
//! quiet). Judged good at [`GOOD_RATIO`] or below on every channel.
//!
//! **With and without each finding.** The recording against the noise-free
//! twin with every finding, with none (the nominal model) and without each
//! finding in turn: the residual by motion, at the table-angle harmonics,
//! its Allan deviation, and the closeness ratio. The fit improves with the
//! simulator itself, not with the regression's own columns.

use super::locate::{harmonics, parts, PART_LABELS};
use rayon::prelude::*;

use super::{predict, Blocks, Diagnosis, Model};
use hal_sim::catalogue::EffectId;
use hal_sim::twin::{simulate_like, ChannelNoise, SimModel, TwinError, Warmup, FORMAT};
use recording::Recording;

/// Block length of the closeness measure, s.
pub const CLOSENESS_BLOCK_S: f64 = 1.0;
/// Twins drawn per closeness (seeds `seed .. seed + TWIN_SEEDS`): four give
/// six twin pairs, so the reference spread is itself known to ~10 % on a
/// 10-minute run (600 blocks, fewer independent ones where drift rules).
pub const TWIN_SEEDS: u64 = 4;
/// The closeness ratio at or below which a twin is judged good (the
/// issue's goal: a recording 30 % farther from its twin than two twins are
/// from each other is not one more draw of it).
pub const GOOD_RATIO: f64 = 1.3;
/// Harmonics of the table angle reported.
pub const TWIN_HARMONICS: usize = 4;

/// How close a recording sits to its twin (channel unit, 1 s block means).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Closeness {
    /// Rms difference, recording vs twin, per channel.
    pub rec_to_twin: [f64; 6],
    /// Rms difference, twin vs twin (other seeds), per channel.
    pub twin_to_twin: [f64; 6],
}

impl Closeness {
    /// Ratio per channel.
    pub fn ratio(&self) -> [f64; 6] {
        std::array::from_fn(|c| self.rec_to_twin[c] / self.twin_to_twin[c].max(1e-300))
    }

    /// The channel farthest from its twin and its ratio.
    pub fn worst(&self) -> (usize, f64) {
        self.ratio()
            .into_iter()
            .enumerate()
            .fold((0, 0.0), |a, (c, r)| if r > a.1 { (c, r) } else { a })
    }

    /// Every channel at or below [`GOOD_RATIO`].
    pub fn good(&self) -> bool {
        self.worst().1 <= GOOD_RATIO
    }
}

fn rms_diff(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()).max(1);
    (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / n as f64).sqrt()
}

/// The closeness of `rec` to the twin of `model`, from twins with seeds
/// `seed .. seed + TWIN_SEEDS`.
///
/// # Errors
/// The twin cannot be simulated ([`simulate_like`]).
pub fn closeness(rec: &Recording, model: &SimModel, seed: u64) -> Result<Closeness, TwinError> {
    let twins: Vec<Recording> = (0..TWIN_SEEDS)
        .into_par_iter()
        .map(|k| simulate_like(rec, model, seed.wrapping_add(k)))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(closeness_to(rec, &twins))
}

/// The closeness of `rec` to already simulated `twins` (at least two).
pub fn closeness_to(rec: &Recording, twins: &[Recording]) -> Closeness {
    let bl = Blocks::of(rec, CLOSENESS_BLOCK_S);
    let mut c = Closeness::default();
    for ch in 0..6 {
        let r = bl.mean(&rec.channel(ch));
        let tw: Vec<Vec<f64>> = twins.iter().map(|t| bl.mean(&t.channel(ch))).collect();
        let ms = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64;
        let rt: Vec<f64> = tw.iter().map(|t| rms_diff(&r, t)).collect();
        let mut tt = vec![];
        for i in 0..tw.len() {
            for j in i + 1..tw.len() {
                tt.push(rms_diff(&tw[i], &tw[j]));
            }
        }
        c.rec_to_twin[ch] = ms(&rt).sqrt();
        c.twin_to_twin[ch] = ms(&tt).sqrt();
    }
    c
}

impl Diagnosis {
    /// The diagnosis as a simulator model: the nominal terms, every finding
    /// (and the effects `model` already had), the noise model per channel.
    pub fn sim_model(&self, model: &Model, source: &str) -> SimModel {
        self.sim_model_without(model, source, None)
    }

    /// [`Self::sim_model`] without finding `skip` (an index into
    /// `findings`).
    pub fn sim_model_without(&self, model: &Model, source: &str, skip: Option<usize>) -> SimModel {
        let det = &self.details;
        let mut m = SimModel {
            format: FORMAT.into(),
            source: source.into(),
            earth_rate_scale: det.earth_scale,
            ..SimModel::default()
        };
        for ch in 0..6 {
            let t = if ch < 3 { &mut m.gyro } else { &mut m.accel };
            let i = ch % 3;
            let nom = det.nominal.get(ch).copied().unwrap_or([None; 4]);
            t.bias[i] = nom[0].unwrap_or(0.0);
            for j in 0..3 {
                t.scale_misalignment[i][j] = nom[j + 1].unwrap_or(0.0);
            }
            if let Some(n) = det.noise.get(ch) {
                let q = n.lambda * n.r;
                t.noise[i] = ChannelNoise {
                    white: n.white_density(),
                    ..ChannelNoise::default()
                };
                if n.lambda > 0.0 && n.phi < 1.0 {
                    t.noise[i].gm_sigma = n.gm_sigma();
                    t.noise[i].gm_tau_s = n.tau_s();
                } else if n.lambda > 0.0 {
                    t.noise[i].random_walk = (q / n.block_s.max(1e-9)).sqrt();
                }
            }
        }
        for (id, params) in &model.known {
            if id == "earth_rate" {
                continue; // in the prediction, so in det.earth_scale
            }
            for (name, v) in params {
                put(&mut m, name, *v, self.details.axis_index);
            }
        }
        for (fi, f) in self.findings.iter().enumerate() {
            if f.effect == EffectId::UntrackedTableMotion {
                // The table-axis gyro's white is the sensor's own; the
                // motion is the table's (left out: the sensor's alone).
                let ka = f.channels.first().copied().unwrap_or(0) % 3;
                if let (Some(n), Some(w)) = (
                    m.gyro.noise.get_mut(ka),
                    f.value("sensor_white_rad_per_sqrt_s"),
                ) {
                    n.white = w;
                }
                if Some(fi) != skip {
                    m.untracked_motion_rad_per_sqrt_s =
                        f.value("untracked_density_rad_per_sqrt_s").unwrap_or(0.0);
                }
                continue;
            }
            if Some(fi) == skip {
                if f.effect == EffectId::BiasInstability {
                    // Without it: white noise only on its channels.
                    for ch in &f.channels {
                        let t = if *ch < 3 { &mut m.gyro } else { &mut m.accel };
                        if let Some(n) = t.noise.get_mut(ch % 3) {
                            *n = ChannelNoise {
                                white: n.white,
                                ..ChannelNoise::default()
                            };
                        }
                    }
                }
                continue;
            }
            if f.effect == EffectId::EarthRate {
                if let Some(v) = f.value("earth_rate_radps") {
                    m.earth_rate_scale = v / core_nav::earth::EARTH_RATE_RADPS;
                }
                continue;
            }
            for p in &f.parameters {
                put(&mut m, &p.name, p.value, self.details.axis_index);
            }
        }
        m
    }
}

/// Puts one diagnose parameter (its report name) into the sim model; names
/// that are not sensor terms (the noise's, reported with a bias
/// instability) are left to the noise model.
fn put(m: &mut SimModel, name: &str, v: f64, axis_index: usize) {
    let axis = |c: Option<char>| match c {
        Some('x') => Some(0usize),
        Some('y') => Some(1),
        Some('z') => Some(2),
        _ => None,
    };
    let nth = |s: &str, n: usize| s.chars().nth(n);
    let add = |x: &mut f64| *x += v;
    if let Some(rest) = name.strip_prefix("g_sens_") {
        if let (Some(i), Some(j)) = (axis(nth(rest, 0)), axis(nth(rest, 1))) {
            add(&mut m.g_sens_radps_per_mps2[i][j]);
        }
    } else if let Some(rest) = name.strip_prefix("k2_") {
        if let Some(i) = axis(nth(rest, 0)) {
            if rest.ends_with("per_radps") {
                add(&mut m.gyro.k2[i]);
            } else {
                add(&mut m.accel.k2[i]);
            }
        }
    } else if let Some(rest) = name.strip_prefix("asymmetry_") {
        if let Some(i) = axis(nth(rest, 0)) {
            add(&mut m.gyro.asymmetry[i]);
        }
    } else if let Some(rest) = name.strip_prefix("lever_") {
        if let Some(i) = axis(nth(rest, 0)) {
            add(&mut m.lever_arm_m[i]);
        }
    } else if let Some(rest) = name.strip_prefix("tilt_about_") {
        if let Some(i) = axis(nth(rest, 0)) {
            add(&mut m.tilt_rad[i]);
        }
    } else if name == "time_offset_s" {
        add(&mut m.time_offset_s);
    } else if name == "accel_time_offset_s" {
        m.accel_time_offset_s = Some(m.accel_time_offset_s.unwrap_or(0.0) + v);
    } else if let Some(rest) = name.strip_prefix("temp_bias_") {
        if let Some(i) = axis(nth(rest, 0)) {
            if rest.contains("radps") {
                add(&mut m.gyro.temp_bias_per_degc[i]);
            } else {
                add(&mut m.accel.temp_bias_per_degc[i]);
            }
        }
    } else if let Some(rest) = name.strip_prefix("warmup_bias_") {
        if let Some(i) = axis(nth(rest, 0)) {
            add(&mut m.warmup.get_or_insert_with(Warmup::default).gyro_bias_radps[i]);
        }
    } else if name == "warmup_tau_s" {
        m.warmup.get_or_insert_with(Warmup::default).tau_s = v;
    } else if name == "wobble_1x_cos_rad" {
        // The once-a-turn rocking that turns with the table (effects.rs,
        // `wobble_parts`): cos on the first normal and sin on the second.
        m.wobble_harmonics_rad[0][0] += v;
        m.wobble_harmonics_rad[0][3] += v;
    } else if name == "wobble_1x_sin_rad" {
        m.wobble_harmonics_rad[0][1] += v;
        m.wobble_harmonics_rad[0][2] -= v;
    } else if let Some(rest) = name.strip_prefix("wobble_") {
        // wobble_2x_{axis}_{cos|sin}_rad: the second harmonic on the normal
        // named by its axis (the first normal follows the table axis
        // cyclically, as hal-sim's Geometry::normals).
        let n = nth(rest, 0).and_then(|c| c.to_digit(10)).unwrap_or(0) as usize;
        let normal = axis(nth(rest, 3)).map(|a| (a + 3 - axis_index) % 3);
        let sine = usize::from(rest.contains("_sin_"));
        if let (Some(h), Some(nrm @ 1..=2)) = (n.checked_sub(1).filter(|h| *h < 2), normal) {
            m.wobble_harmonics_rad[h][2 * (nrm - 1) + sine] += v;
        }
    } else if name == "encoder_cos_rad" {
        add(&mut m.encoder_error_rad[0]);
    } else if name == "encoder_sin_rad" {
        add(&mut m.encoder_error_rad[1]);
    }
}

/// The recording minus a noise-free twin, located.
#[derive(Clone, Debug, Default)]
pub struct Residuals {
    /// (part of the run, rms of the 0.2 s means per channel, blocks).
    pub by_part: Vec<(String, [f64; 6], usize)>,
    /// Amplitudes at table-angle harmonics 1..=TWIN_HARMONICS per channel
    /// (empty when the table did not turn a whole revolution).
    pub harmonics: Vec<[f64; 6]>,
    /// Allan deviation per channel: (tau s, adev channel unit).
    pub allan: Vec<Vec<(f64, f64)>>,
    /// Rms per channel over the run.
    pub rms: [f64; 6],
}

/// One twin compared with the recording.
#[derive(Clone, Debug)]
pub struct TwinRun {
    /// "every finding", "nominal only", "without <id>".
    pub label: String,
    /// The finding left out, if any.
    pub without: Option<EffectId>,
    /// Closeness of the recording to this twin.
    pub closeness: Closeness,
    /// The recording minus this twin without noise.
    pub residuals: Residuals,
}

/// The recording against its twin with and without each finding.
#[derive(Clone, Debug)]
pub struct TwinReport {
    /// The model with every finding (what `--sim-model` writes).
    pub model: SimModel,
    /// Every finding first, then the nominal model, then one run without
    /// each finding.
    pub runs: Vec<TwinRun>,
}

impl TwinReport {
    /// The twin with every finding.
    pub fn full(&self) -> Option<&TwinRun> {
        self.runs.first()
    }
}

fn residuals(rec: &Recording, twin: &Recording, part: &[usize], theta: &[f64]) -> Residuals {
    let dt = rec.dt_s();
    let res: Vec<Vec<f64>> = (0..6)
        .map(|ch| {
            rec.channel(ch)
                .iter()
                .zip(twin.channel(ch))
                .map(|(a, b)| a - b)
                .collect()
        })
        .collect();
    let rms_of = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
    let mut out = Residuals {
        rms: std::array::from_fn(|ch| rms_of(&res[ch])),
        ..Residuals::default()
    };
    // By motion on 0.2 s means (a block's part is its middle sample's): the
    // white noise averaged down, a misfit that follows the motion left.
    let bl = Blocks::of(rec, 0.2);
    let bres: Vec<Vec<f64>> = res.iter().map(|r| bl.mean(r)).collect();
    let bpart: Vec<usize> = (0..bl.count())
        .map(|b| part.get(bl.middle(b)).copied().unwrap_or(0))
        .collect();
    for (li, label) in PART_LABELS.iter().enumerate() {
        let idx: Vec<usize> = (0..bpart.len()).filter(|b| bpart[*b] == li).collect();
        if idx.is_empty() {
            continue;
        }
        let v: [f64; 6] = std::array::from_fn(|ch| {
            rms_of(
                &idx.iter()
                    .filter_map(|b| bres[ch].get(*b).copied())
                    .collect::<Vec<_>>(),
            )
        });
        out.by_part.push(((*label).to_string(), v, idx.len()));
    }
    let turned = theta
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
            (lo.min(*t), hi.max(*t))
        });
    if turned.1 - turned.0 >= std::f64::consts::TAU {
        let h: Vec<Vec<f64>> = (0..6)
            .map(|ch| harmonics(&res[ch], theta, TWIN_HARMONICS))
            .collect();
        out.harmonics = (0..TWIN_HARMONICS)
            .map(|k| std::array::from_fn(|ch| h[ch].get(k).copied().unwrap_or(0.0)))
            .collect();
    }
    out.allan = res
        .iter()
        .map(|r| {
            core_nav::allan::octave_factors(r.len(), 20)
                .filter_map(|m| core_nav::allan::oadev(r, dt, m))
                .filter(|p| p.adev > 0.0)
                .map(|p| (p.tau_s, p.adev))
                .collect()
        })
        .collect();
    out
}

/// The recording against the twin of diagnosis `d` (made with `model`):
/// with every finding, with none, without each in turn. Twins are drawn
/// from seeds `seed ..`.
///
/// # Errors
/// A twin cannot be simulated.
pub fn report(
    d: &Diagnosis,
    rec: &Recording,
    model: &Model,
    source: &str,
    seed: u64,
) -> Result<TwinReport, TwinError> {
    let full = d.sim_model(model, source);
    let mut variants: Vec<(String, Option<EffectId>, SimModel)> =
        vec![("every finding".into(), None, full.clone())];
    if !d.findings.is_empty() {
        let mut nominal = full.clone();
        for fi in 0..d.findings.len() {
            // Strip every finding: rebuild without each, keeping the nominal.
            nominal = strip(
                &nominal,
                &d.sim_model_without(model, source, Some(fi)),
                &full,
            );
        }
        variants.push(("nominal only".into(), None, nominal));
    }
    for (fi, f) in d.findings.iter().enumerate() {
        let triad = if f.effect == EffectId::BiasInstability {
            if f.channels.iter().all(|c| *c < 3) {
                " (gyros)"
            } else {
                " (accels)"
            }
        } else {
            ""
        };
        variants.push((
            format!("without {}{triad}", f.effect.as_str()),
            Some(f.effect),
            d.sim_model_without(model, source, Some(fi)),
        ));
    }
    let p = predict(rec, full.earth_rate_scale, full.time_offset_s);
    let part = parts(&p);
    let theta: Vec<f64> = p.theta.iter().map(|t| t.0).collect();
    let mut runs = vec![];
    for (label, without, m) in variants {
        let clean = simulate_like(rec, &m.noise_free(), seed)?;
        runs.push(TwinRun {
            label,
            without,
            closeness: closeness(rec, &m, seed)?,
            residuals: residuals(rec, &clean, &part, &theta),
        });
    }
    Ok(TwinReport { model: full, runs })
}

/// `acc` with every term where `without` differs from `full` taken from
/// `without` (so stripping findings one by one leaves the nominal model).
fn strip(acc: &SimModel, without: &SimModel, full: &SimModel) -> SimModel {
    let pick = |a: f64, w: f64, f: f64| if w != f { w } else { a };
    let pick3 = |a: [f64; 3], w: [f64; 3], f: [f64; 3]| -> [f64; 3] {
        std::array::from_fn(|i| pick(a[i], w[i], f[i]))
    };
    let mut m = acc.clone();
    m.earth_rate_scale = pick(
        acc.earth_rate_scale,
        without.earth_rate_scale,
        full.earth_rate_scale,
    );
    m.time_offset_s = pick(acc.time_offset_s, without.time_offset_s, full.time_offset_s);
    m.untracked_motion_rad_per_sqrt_s = pick(
        acc.untracked_motion_rad_per_sqrt_s,
        without.untracked_motion_rad_per_sqrt_s,
        full.untracked_motion_rad_per_sqrt_s,
    );
    if without.accel_time_offset_s != full.accel_time_offset_s {
        m.accel_time_offset_s = without.accel_time_offset_s;
    }
    m.lever_arm_m = pick3(acc.lever_arm_m, without.lever_arm_m, full.lever_arm_m);
    m.tilt_rad = pick3(acc.tilt_rad, without.tilt_rad, full.tilt_rad);
    for h in 0..2 {
        for i in 0..4 {
            m.wobble_harmonics_rad[h][i] = pick(
                acc.wobble_harmonics_rad[h][i],
                without.wobble_harmonics_rad[h][i],
                full.wobble_harmonics_rad[h][i],
            );
        }
    }
    m.encoder_error_rad = std::array::from_fn(|i| {
        pick(
            acc.encoder_error_rad[i],
            without.encoder_error_rad[i],
            full.encoder_error_rad[i],
        )
    });
    m.g_sens_radps_per_mps2 = std::array::from_fn(|i| {
        pick3(
            acc.g_sens_radps_per_mps2[i],
            without.g_sens_radps_per_mps2[i],
            full.g_sens_radps_per_mps2[i],
        )
    });
    if without.warmup != full.warmup {
        m.warmup = without.warmup;
    }
    for (t, (w, f)) in [
        (&mut m.gyro, (&without.gyro, &full.gyro)),
        (&mut m.accel, (&without.accel, &full.accel)),
    ] {
        t.k2 = pick3(t.k2, w.k2, f.k2);
        t.asymmetry = pick3(t.asymmetry, w.asymmetry, f.asymmetry);
        t.temp_bias_per_degc = pick3(
            t.temp_bias_per_degc,
            w.temp_bias_per_degc,
            f.temp_bias_per_degc,
        );
        for i in 0..3 {
            if w.noise[i] != f.noise[i] {
                t.noise[i] = w.noise[i];
            }
        }
    }
    m
}

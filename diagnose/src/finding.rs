//! What a diagnosis says, typed: findings, unexplained mismatches, the
//! details a person and the plots read. The `rins-diagnose/1` JSON
//! (`shared/spec/diagnose-v1.md`) and the text report are both written from
//! these types ([`Diagnosis::to_json`], `show::text`).

use super::locate;
use super::noise::Noise;
use super::CHANNELS;
use hal_sim::catalogue::EffectId;
use recording::Recording;
use serde_json::{json, Map, Value};

/// A fitted parameter: SI name (its unit in the suffix), value, 1-sigma
/// when fitted (a fixed parameter, e.g. a warm-up constant chosen on a
/// grid, has none).
#[derive(Clone, Debug, PartialEq)]
pub struct Parameter {
    /// Name with its unit (`lever_x_m`, `time_offset_s`, ...).
    pub name: String,
    /// Value, in the unit its name says.
    pub value: f64,
    /// 1-sigma, same unit.
    pub sigma: Option<f64>,
    /// The largest physically possible magnitude, same unit (the
    /// catalogue's bound: a finding never exceeds it); `None` for noise
    /// terms and parameters fixed on a grid.
    pub max_abs: Option<f64>,
}

/// How much a finding improves the fit: per-channel residual rms (channel
/// index, channel unit) and the held-out rms over its channels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FitFigures {
    /// Residual rms per channel without the finding.
    pub residual_rms_before: Vec<(usize, f64)>,
    /// Residual rms per channel with it.
    pub residual_rms_after: Vec<(usize, f64)>,
    /// Held-out residual rms without it.
    pub heldout_rms_before: f64,
    /// Held-out residual rms with it.
    pub heldout_rms_after: f64,
    /// Per channel the finding's regressors touch (claimed or not): the
    /// whitened held-out residual rms (each block against the noise
    /// model's prediction of it; 1 is the noise), without and with it:
    /// `(channel, before, after)`. A signal finding claims exactly the
    /// channels where after < before. Empty for the noise findings
    /// (untracked motion, bias instability), which take power out of the
    /// white noise instead.
    pub heldout_whitened: Vec<(usize, f64, f64)>,
}

/// One finding of the report (diagnose-v1).
#[derive(Clone, Debug, PartialEq)]
pub struct Finding {
    /// Effect id.
    pub effect: EffectId,
    /// Channels (0-2 gyro x-z, 3-5 accel x-z; [`CHANNELS`] names them).
    pub channels: Vec<usize>,
    /// Where the mismatch shows.
    pub where_: String,
    /// For a person.
    pub explanation: String,
    /// Fitted parameters.
    pub parameters: Vec<Parameter>,
    /// Parameters of this finding the run cannot measure (a white noise
    /// the fit does not hold, a floor the run does not reach): named
    /// here, absent from `parameters`, never written as 0.
    pub not_measured: Vec<String>,
    /// BIC of the model with the finding minus without (negative: better).
    pub delta_bic: f64,
    /// The finding's amplitude over its standard error.
    pub snr: f64,
    /// Its degrees of freedom (fitted and searched parameters).
    pub dof: usize,
    /// Chance that the fitted noise model alone gives this much evidence
    /// for this one effect: chi-square tail with `dof` degrees of freedom
    /// of `snr^2` over the largest dispersion of its channels.
    pub p_noise: f64,
    /// Confidence that the effect is there: `1 - m p_noise` (at least 0),
    /// `m` the effect ids the library tried (Bonferroni): on runs without
    /// any effect, a finding at confidence `c` or more turns up in at most
    /// `1 - c` of them. Checked on real-noise nulls by `rins study`.
    pub confidence: f64,
    /// Before / after figures.
    pub fit: FitFigures,
    /// The effect this one cannot be told apart from in this run, if any
    /// (also said in `explanation`; not part of the spec's JSON).
    pub lookalike: Option<EffectId>,
}

impl Finding {
    /// The parameter named `name`.
    pub fn parameter(&self, name: &str) -> Option<&Parameter> {
        self.parameters.iter().find(|p| p.name == name)
    }

    /// The value of parameter `name`.
    pub fn value(&self, name: &str) -> Option<f64> {
        self.parameter(name).map(|p| p.value)
    }

    /// The channels' recording-v1 names.
    pub fn channel_names(&self) -> Vec<&'static str> {
        self.channels
            .iter()
            .filter_map(|c| CHANNELS.get(*c).copied())
            .collect()
    }

    /// The finding as the spec writes it (each parameter's 1-sigma as
    /// `sigma_<name>`).
    pub fn to_json(&self) -> Value {
        let mut params = Map::new();
        for p in &self.parameters {
            params.insert(p.name.clone(), p.value.into());
            if let Some(s) = p.sigma {
                params.insert(format!("sigma_{}", p.name), s.into());
            }
        }
        let per_channel = |v: &[(usize, f64)]| -> Map<String, Value> {
            v.iter()
                .filter_map(|(c, x)| Some(((*CHANNELS.get(*c)?).to_string(), (*x).into())))
                .collect()
        };
        json!({
            "effect": self.effect.as_str(),
            "channels": self.channel_names(),
            "where": self.where_,
            "explanation": self.explanation,
            "parameters": params,
            "not_measured": self.not_measured,
            "significance": {"delta_bic": self.delta_bic, "snr": self.snr},
            "fit": {
                "residual_rms_before": per_channel(&self.fit.residual_rms_before),
                "residual_rms_after": per_channel(&self.fit.residual_rms_after),
                "heldout_rms_before": self.fit.heldout_rms_before,
                "heldout_rms_after": self.fit.heldout_rms_after,
                "heldout_whitened": self.fit.heldout_whitened.iter().filter_map(|(c, b, a)| {
                    Some(((*CHANNELS.get(*c)?).to_string(), json!({"before": b, "after": a})))
                }).collect::<Map<String, Value>>(),
            },
        })
    }
}

/// A mismatch no effect explains.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Unexplained {
    /// Channels (recording-v1 names).
    pub channels: Vec<String>,
    /// Where.
    #[serde(rename = "where")]
    pub where_: String,
    /// Amplitude over its standard error.
    pub snr: f64,
    /// The effect it may be, when the run cannot tell it from the noise
    /// (a slow finding the long blocks did not confirm; not in the spec's
    /// JSON).
    #[serde(skip)]
    pub may_be: Option<EffectId>,
}

/// One parameter's power in a run ([`Details::observability`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Observability {
    /// The effect.
    pub effect: EffectId,
    /// The parameter (its name carries its unit).
    pub parameter: String,
    /// The smallest size the run shows half the time; `None`: the run
    /// cannot separate it from the model at all.
    pub min_detectable: Option<f64>,
    /// Its physical bound.
    pub bound: f64,
}

impl Observability {
    /// Can this run show a physically possible size of it?
    pub fn observable(&self) -> bool {
        self.min_detectable.is_some_and(|m| m <= self.bound)
    }
}

/// What a person reads beyond the JSON, and what the plots draw.
#[derive(Clone, Debug, Default)]
pub struct Details {
    /// Noise model per channel (fitted to the final residual).
    pub noise: Vec<Noise>,
    /// Effects not excited by this run, with the experiment that would.
    pub not_observable: Vec<(EffectId, String)>,
    /// Each candidate parameter's power in this run: the smallest size
    /// the run would show (detected half the time, alone beyond the final
    /// model: its sigma there times sqrt of the one-degree noncentrality)
    /// against its physical bound, in the parameter's unit. "Not named"
    /// means "not there" where this is below the bound, "cannot be seen
    /// here" where it is above.
    pub observability: Vec<Observability>,
    /// The noise terms of the final residual per channel, from the one
    /// noise estimator (`rins allan`'s Allan fit): what the report prints.
    pub allan: Vec<core_nav::allan::NoiseFit>,
    /// Effects the recording's columns or table source rule out, and why.
    pub ruled_out: Vec<(EffectId, String)>,
    /// The recording's segments between gaps: first and last sample time
    /// (s) and samples.
    pub segments: Vec<(f64, f64, usize)>,
    /// The table axis as a sensor axis index (0 x, 1 y, 2 z).
    pub axis_index: usize,
    /// The nominal IMU rate, Hz (`[imu] rate_hz`).
    pub rate_hz: f64,
    /// The accelerometers were recorded (else gyro-only).
    pub accel_recorded: bool,
    /// Locate: the nominal residual split by motion and time.
    pub locate: locate::Locate,
    /// Block length, s.
    pub block_s: f64,
    /// Sample time, s.
    pub dt_s: f64,
    /// Per-sample residual before (nominal) and after (every finding), per
    /// channel (channel unit).
    pub res_before: [Vec<f64>; 6],
    /// See `res_before`.
    pub res_after: [Vec<f64>; 6],
    /// The fitted model's samples (the re-simulation: ideal sensor, nominal
    /// terms, every finding, the model's known effects; no noise), per
    /// channel (channel unit).
    pub model: [Vec<f64>; 6],
    /// Table angle per sample, rad.
    pub theta: Vec<f64>,
    /// Time per sample, s.
    pub t_s: Vec<f64>,
    /// Ljung-Box whiteness of the whitened final residual per channel:
    /// (statistic, lags).
    pub whiteness: Vec<(f64, usize)>,
    /// The nominal terms of the final fit per channel: intercept (channel
    /// unit) and the coefficients on the triad's truth x, y, z (1); `None`
    /// where the run did not excite the term.
    pub nominal: [[Option<f64>; 4]; 6],
    /// The earth rate the prediction includes, x the site's.
    pub earth_scale: f64,
    /// The run's strongest evidence for any effect, named or not: the
    /// smallest chi-square tail probability of a candidate against the
    /// final model, times the effect ids tried (Bonferroni; at most 1). On
    /// runs without an effect it is below `alpha` in at most `alpha` of
    /// them if the confidences mean what they say.
    pub strongest_p_adjusted: f64,
    /// The effect that evidence is for.
    pub strongest_effect: Option<EffectId>,
    /// Dispersion of the whitened final residual per channel (its long-run
    /// variance over its variance, at least 1: `locate::dispersion`): the
    /// confidences divide the evidence by it.
    pub dispersion: Vec<f64>,
    /// Intervals between encoder reads (start, end, s) the prediction cannot
    /// follow the table through (hal-sim's `EncoderTrack::unfollowed`).
    pub unfollowed: Vec<(f64, f64)>,
}

/// The report.
#[derive(Clone, Debug)]
pub struct Diagnosis {
    /// The recording as named by the caller.
    pub recording: String,
    /// Findings, most significant first.
    pub findings: Vec<Finding>,
    /// Unexplained mismatches.
    pub unexplained: Vec<Unexplained>,
    /// For the text report and the plots.
    pub details: Details,
}

impl Diagnosis {
    /// The parameter `name` of the finding of `effect`, if one is named
    /// and has it.
    pub fn parameter(&self, effect: EffectId, name: &str) -> Option<&Parameter> {
        self.findings
            .iter()
            .filter(|f| f.effect == effect)
            .find_map(|f| f.parameter(name))
    }

    /// The recording `rec` (the one diagnosed) with its IMU samples replaced
    /// by the fitted model's: the same run re-simulated, to compare or to
    /// diagnose again.
    pub fn resimulated(&self, rec: &Recording) -> Recording {
        let mut sim = rec.clone();
        let m = &self.details.model;
        for (r, row) in sim.imu.iter_mut().enumerate() {
            for i in 0..3 {
                if let (Some(w), Some(f)) = (m[i].get(r), m[3 + i].get(r)) {
                    row.gyro_radps[i] = *w;
                    if !rec.gyro_only {
                        row.accel_mps2[i] = *f;
                    }
                }
            }
        }
        sim.meta.description = Some(format!(
            "rins diagnose: the fitted model of {}",
            self.recording
        ));
        sim
    }

    /// The `rins-diagnose/1` JSON.
    pub fn to_json(&self) -> Value {
        let det = &self.details;
        let resid: Map<String, Value> = CHANNELS
            .iter()
            .zip(&det.res_before)
            .enumerate()
            .filter(|(ch, _)| *ch < 3 || det.accel_recorded)
            .map(|(_, (n, r))| ((*n).to_string(), super::rms(r).into()))
            .collect();
        let ruled_out: Vec<Value> = det
            .ruled_out
            .iter()
            .map(|(id, why)| json!({"effect": id.as_str(), "why": why}))
            .collect();
        let segments: Vec<Value> = det
            .segments
            .iter()
            .map(|(a, b, n)| json!({"start_s": a, "end_s": b, "samples": n}))
            .collect();
        let unfollowed: Vec<Value> = det
            .unfollowed
            .iter()
            .map(|(a, b)| json!({"start_s": a, "end_s": b}))
            .collect();
        json!({
            "format": "rins-diagnose/1",
            "recording": self.recording,
            "nominal": {"residual_rms": resid},
            "findings": self.findings.iter().map(Finding::to_json).collect::<Vec<_>>(),
            "unexplained": self.unexplained,
            "ruled_out": ruled_out,
            "segments": segments,
            "rate_hz": det.rate_hz,
            "track_unfollowed": unfollowed,
            "observability": det.observability.iter().map(|o| json!({
                "effect": o.effect.as_str(),
                "parameter": o.parameter,
                "min_detectable": o.min_detectable,
                "bound": o.bound,
                "observable": o.observable(),
            })).collect::<Vec<_>>(),
        })
    }
}

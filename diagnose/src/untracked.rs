//! Table motion between encoder reads that the prediction does not follow
//! (`untracked_table_motion`: a stepper's steps, cogging, a servo's buzz):
//! found on the table-axis gyro's final residual against the cross axes',
//! and taken out of that channel's white noise. The table-axis gyro's own
//! white noise cannot be seen under the motion; the quieter cross axis of
//! the same triad gives it (MEMS datasheets give one density for all three
//! axes).
//! The motion's density is what the channel's block-mean noise holds above
//! that; the twin simulates it as [`hal_sim::world::UntrackedMotion`].

use super::{rms, Finding, FitFigures, Parameter, Prediction};
use core_nav::allan::NoiseFit;
use hal_sim::catalogue::EffectId;

/// How far the table-axis gyro may sit above the cross-axis gyros (rms of
/// the final per-sample residual) before the table is said to move between
/// encoder reads in ways the track cannot follow: the three gyros of a MEMS
/// triad share their noise density to within a factor of ~1.5 (datasheets
/// give one figure for all axes); 3 leaves room for that.
pub const UNTRACKED_RATIO: f64 = 3.0;

/// The motion as measured (channel units rad/s; densities rad/sqrt(s)).
#[derive(Clone, Debug, PartialEq)]
pub struct Untracked {
    /// The table-axis gyro channel.
    pub ch: usize,
    /// Its final residual, rms per sample, rad/s.
    pub along_radps: f64,
    /// The cross-axis gyros' mean rms per sample, rad/s.
    pub cross_radps: f64,
    /// The frequency where its power peaks (periodogram of the longest
    /// segment), Hz.
    pub peak_hz: f64,
    /// What would resolve it.
    pub needs: String,
    /// The encoder track's own intervals it cannot follow: total s, count.
    pub unfollowed: (f64, usize),
    /// Run span, s.
    pub span_s: f64,
    /// Half the IMU's sample rate, Hz.
    pub nyquist_hz: f64,
}

/// The untracked motion on the table-axis gyro of `res` (per-sample final
/// residuals), if it stands [`UNTRACKED_RATIO`] above the cross axes.
pub fn detect(p: &Prediction, res: &[Vec<f64>; 6]) -> Option<Untracked> {
    let ka = p.k.iamax();
    let moved = p
        .theta
        .iter()
        .any(|t| t.1.abs() > hal_sim::world::TURNING_RADPS);
    let others: Vec<f64> = (0..3).filter(|c| *c != ka).map(|c| rms(&res[c])).collect();
    let cross = others.iter().sum::<f64>() / others.len().max(1) as f64;
    let along = rms(res.get(ka)?);
    if !moved || along <= UNTRACKED_RATIO * cross {
        return None;
    }
    let peak = peak_hz(p, res.get(ka)?)?;
    let unfollowed: f64 = p.track.unfollowed().iter().map(|(a, b)| b - a).sum();
    let span = p.t_s.last().copied().unwrap_or(0.0) - p.t_s.first().copied().unwrap_or(0.0);
    Some(Untracked {
        ch: ka,
        along_radps: along,
        cross_radps: cross,
        peak_hz: peak,
        needs: what_resolves(p, peak),
        unfollowed: (unfollowed, p.track.unfollowed().len()),
        span_s: span,
        nyquist_hz: 0.5 / p.dt_s,
    })
}

/// The periodogram's peak of `z` on the longest segment (its first 60 s
/// at most), on a log grid from 0.2 Hz to Nyquist, Hz.
fn peak_hz(p: &Prediction, z: &[f64]) -> Option<f64> {
    let seg = recording::segments(&p.t_s, p.dt_s)
        .into_iter()
        .max_by_key(|s| s.len())?;
    let z: Vec<f64> = z
        .get(seg.start..seg.end)?
        .iter()
        .take(6000)
        .copied()
        .collect();
    let nyq = 0.5 / p.dt_s;
    (0..400)
        .map(|i| 0.2 * (nyq / 0.2).powf(f64::from(i) / 399.0))
        .map(|f| {
            let (mut c, mut s) = (0.0, 0.0);
            for (r, v) in z.iter().enumerate() {
                let ph = std::f64::consts::TAU * f * r as f64 * p.dt_s;
                c += v * ph.cos();
                s += v * ph.sin();
            }
            (f, c * c + s * s)
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|x| x.0)
}

/// What would resolve motion peaking at `peak` Hz: reads that sample its
/// cycle (2.5 per cycle), or, where the encoder already reads that fast,
/// angles fine enough that the track's fits over a few reads follow it.
fn what_resolves(p: &Prediction, peak: f64) -> String {
    let dps = 180.0 / std::f64::consts::PI;
    let reads = p.track.times();
    let enc_hz = (reads.len().saturating_sub(1)) as f64
        / (reads.last().copied().unwrap_or(0.0) - reads.first().copied().unwrap_or(0.0)).max(1e-9);
    let quantum_deg = recording::track::encoder_quantum(p.track.angles()) * dps;
    if enc_hz >= 2.5 * peak {
        format!(
            "the encoder already reads at {enc_hz:.0} Hz, so the angles as recorded (a step of {quantum_deg:.3} deg at the finest) and the track's fits over eight reads are what cannot follow it: a finer encoder, or the motor's own step count, would resolve it"
        )
    } else {
        format!(
            "the encoder reads at {enc_hz:.0} Hz: reads at {:.0} Hz or more would resolve it",
            2.5 * peak
        )
    }
}

/// The sensor's own white noise density on the table axis (the quieter
/// cross axis's: motion leaking into a cross axis through misalignment or a
/// rocking mount can only raise its figure) and the motion's (what the
/// table axis holds above it), from the one noise estimator's fits
/// (`allan`, per channel), rad/sqrt(s); and the sensor figure's 1-sigma.
pub fn densities(u: &Untracked, allan: &[NoiseFit]) -> (f64, f64, f64) {
    let quiet = (0..3)
        .filter(|c| *c != u.ch)
        .filter_map(|c| allan.get(c))
        .min_by(|a, b| a.white.total_cmp(&b.white))
        .copied()
        .unwrap_or_default();
    let total = allan.get(u.ch).map_or(0.0, |a| a.white);
    let motion = (total * total - quiet.white * quiet.white).max(0.0).sqrt();
    (quiet.white, motion, quiet.white_sigma)
}

/// Takes the motion out of the table axis's white noise in `allan`: its
/// white is the sensor's own ([`densities`]).
pub fn take_out(u: &Untracked, allan: &mut [NoiseFit]) {
    let (sensor, _, sigma) = densities(u, allan);
    if let Some(a) = allan.get_mut(u.ch) {
        a.white = sensor;
        a.white_sigma = sigma;
    }
}

/// The motion as a finding: its size (rms per sample and density), where
/// its power sits, what would resolve it, the table axis's own white noise
/// it was taken out of (`allan` before [`take_out`]); the evidence is the
/// likelihood ratio of the table-axis block means with and without the
/// motion's variance (`blocks` of them).
pub fn finding(u: &Untracked, allan: &[NoiseFit], blocks: usize) -> Finding {
    let (sensor, motion, _) = densities(u, allan);
    let v = ((sensor * sensor + motion * motion) / (sensor * sensor).max(1e-300)).max(1.0);
    let nb = blocks.max(2) as f64;
    let chi2 = nb * (v - 1.0 - v.ln());
    let dps = 180.0 / std::f64::consts::PI;
    let motion_rms = (u.along_radps.powi(2) - u.cross_radps.powi(2))
        .max(0.0)
        .sqrt();
    let par = |name: &str, value: f64| Parameter {
        name: name.into(),
        value,
        sigma: None,
        max_abs: None,
    };
    Finding {
        effect: EffectId::UntrackedTableMotion,
        channels: vec![u.ch],
        where_: format!(
            "the table-axis gyro differs from the encoder's rate by {:.2} deg/s rms where the cross axes read {:.3} deg/s; its power peaks near {:.1} Hz (of the {:.0} Hz the samples show; faster steps alias); the encoder track itself cannot follow {:.0} s of the {:.0} s run ({} intervals)",
            u.along_radps * dps,
            u.cross_radps * dps,
            u.peak_hz,
            u.nyquist_hz,
            u.unfollowed.0,
            u.span_s,
            u.unfollowed.1
        ),
        explanation: format!(
            "the table moves between encoder reads in ways the track cannot follow (a stepper's steps, cogging): rate noise on the table-axis gyro, not the sensor's; {}. Taken out of that channel's white noise: the sensor's own there is {}, the motion's {:.3} deg/sqrt(h)",
            u.needs,
            if sensor > 0.0 {
                format!("the quieter cross axis's {:.3} deg/sqrt(h)", sensor * dps * 60.0)
            } else {
                "not measured here (no cross axis's white noise in its fit)".into()
            },
            motion * dps * 60.0
        ),
        parameters: [
            Some(par("untracked_rate_rms_radps", motion_rms)),
            Some(par("untracked_density_rad_per_sqrt_s", motion)),
            (sensor > 0.0).then(|| par("sensor_white_rad_per_sqrt_s", sensor)),
            Some(par("untracked_peak_hz", u.peak_hz)),
        ]
        .into_iter()
        .flatten()
        .collect(),
        not_measured: if sensor > 0.0 {
            vec![]
        } else {
            vec!["sensor_white_rad_per_sqrt_s".into()]
        },
        delta_bic: -chi2 + nb.ln(),
        snr: chi2.sqrt(),
        dof: 1,
        p_noise: 1.0,
        confidence: 0.0,
        fit: FitFigures {
            residual_rms_before: vec![(u.ch, u.along_radps)],
            residual_rms_after: vec![(u.ch, u.along_radps)],
            heldout_rms_before: u.along_radps,
            heldout_rms_after: u.along_radps,
            heldout_whitened: vec![],
        },
        lookalike: None,
    }
}

//! Sensor files a tool writes from what it measured (`rins allan
//! --sensor-out`, `rins diagnose --sensor-out`): the one home of what
//! such a file holds.
//!
//! A written file (`rins-sensor/2`) starts from its base: a shipped
//! sensor (named in `base`), a user's file (its values, said in the
//! comments), or nothing, where every term is `"unknown"`. The terms the
//! tool measured replace the base's and are listed in `measured`; a term
//! the data cannot support (white noise the fit did not hold, an Allan
//! floor the averaging times do not reach) is not measured: the base's
//! stays, or it stays unknown. Never a zero for a term not measured.

use core_nav::allan::NoiseFit;
use hal_sim::imu::{ImuSpec, TriadSpec};
use hal_sim::sensor::{self, terms, Provenance, ALLAN_PEAK_PER_GM_SIGMA};
use recording::Recording;

/// A sensor file being written: the spec, where its terms come from, and
/// the comment lines.
#[derive(Clone, Debug)]
pub struct Written {
    /// The terms.
    pub spec: ImuSpec,
    /// `base` and `measured`.
    pub from: Provenance,
    /// Comment lines (where the figures come from).
    pub notes: Vec<String>,
}

/// A triad of a spec, to set.
type TriadOf = fn(&mut ImuSpec) -> &mut TriadSpec;

/// How a triad's three axes make its one figure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Combine {
    /// The RMS over the axes (a still sensor's Allan curves).
    Rms,
    /// The quietest axis's (a fit's residual: what the model leaves out of
    /// the motion can only add to a channel's noise, never take from it).
    Quietest,
}

/// The sensor a file starts from: its spec, and its shipped name when it
/// is a shipped one (written as `base`).
pub type Base = (ImuSpec, Option<String>);

/// A sensor that knows nothing: every term unknown.
fn nothing_known(name: &str) -> ImuSpec {
    let text = format!("format = {:?}\nname = {name:?}\n", sensor::FORMAT);
    match sensor::parse(&text, name) {
        Ok(s) => s,
        // The text is the format's smallest valid file: cannot fail.
        Err(_) => ImuSpec::ideal(),
    }
}

impl Written {
    /// Starts from `base` (or nothing known), the file named after it and
    /// `tool` ("allan", "diagnose"), written from `what` (the recording).
    pub fn start(base: Option<Base>, tool: &str, what: &str) -> Self {
        let (mut spec, shipped, note) = match base {
            Some((s, Some(n))) => (
                s,
                Some(n.clone()),
                format!("the rest is the shipped {n:?}'s (base)"),
            ),
            Some((s, None)) => {
                let n = s.name.clone();
                (s, None, format!("the rest is the sensor file {n:?}'s"))
            }
            None => (
                nothing_known("measured"),
                None,
                "no base sensor (--sensor): every term not measured is unknown".into(),
            ),
        };
        spec.name = match spec.name.as_str() {
            "measured" => format!("{tool}-measured"),
            n => format!("{n}-{tool}"),
        };
        Self {
            spec,
            from: Provenance {
                base: shipped,
                measured: vec![],
            },
            notes: vec![
                format!("Written by rins {tool} from {what}: the terms marked measured are its;"),
                note,
            ],
        }
    }

    /// Sets the term `key` (`table.key`, [`terms`]) through `set`: measured.
    pub fn measured(&mut self, key: &str, set: impl FnOnce(&mut ImuSpec)) {
        set(&mut self.spec);
        self.spec.unknown.retain(|u| u != key);
        if !self.from.measured.iter().any(|m| m == key) {
            self.from.measured.push(key.to_string());
        }
    }

    /// The file's text.
    pub fn text(&self) -> String {
        sensor::write_with(&self.spec, &self.from, &self.notes)
    }

    /// Per triad, the noise its three axes' Allan fits measured (`fits`:
    /// the channels in recording order, 3 or 6): combined over the axes
    /// (`how`) from
    /// the white noise where every axis's fit holds it, of the Allan floor
    /// (as the format's bias instability) where every axis's curve reaches
    /// its floor, with the correlation time of a fitted Gauss-Markov bias
    /// (else the floor's tau over 1.89, where such a process's Allan
    /// deviation peaks), and of the rate random walk where every axis
    /// shows one. What is not measured is said in the notes. The gyro
    /// `table_axis` (a table run's), when given, is left out: its rate
    /// carries what the encoder track does not follow, not the sensor's.
    pub fn noise(&mut self, fits: &[NoiseFit], table_axis: Option<usize>, how: Combine) {
        let rms = |v: &[f64]| match how {
            Combine::Rms => (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt(),
            Combine::Quietest => v.iter().copied().fold(f64::INFINITY, f64::min),
        };
        let triads: [(usize, &str, [&str; 4], TriadOf); 2] = [
            (
                0,
                "gyro",
                [
                    terms::GYRO_NOISE,
                    terms::GYRO_FLOOR,
                    terms::GYRO_TAU,
                    terms::GYRO_RRW,
                ],
                |s| &mut s.gyro,
            ),
            (
                3,
                "accel",
                [
                    terms::ACCEL_NOISE,
                    terms::ACCEL_FLOOR,
                    terms::ACCEL_TAU,
                    terms::ACCEL_RRW,
                ],
                |s| &mut s.accel,
            ),
        ];
        for (k, name, [noise, floor, tau, rrw], triad) in triads {
            let Some(all) = fits.get(k..k + 3) else {
                continue;
            };
            let f: Vec<NoiseFit> = all
                .iter()
                .enumerate()
                .filter(|(i, _)| k > 0 || Some(*i) != table_axis)
                .map(|(_, x)| *x)
                .collect();
            if f.iter().all(|x| x.white > 0.0) {
                let w = rms(&f.iter().map(|x| x.white).collect::<Vec<_>>());
                self.measured(noise, |s| triad(s).white = w);
            } else {
                self.notes.push(format!(
                    "{name}: white noise not measured (not in every axis's fit)"
                ));
            }
            if f.iter().all(|x| x.floor_seen) {
                let b = core_nav::allan::FLOOR_OVER_B
                    * rms(&f.iter().map(|x| x.bias_instability).collect::<Vec<_>>());
                // The floor is a flat stretch of the curve (IEEE 952's
                // flicker floor): simulated as the flicker bank, whose floor
                // is the stated one over three decades of tau, not as one
                // Gauss-Markov bump (whose valley before the bump lies
                // below its peak).
                self.measured(floor, |s| {
                    triad(s).bias_instability = b / ALLAN_PEAK_PER_GM_SIGMA;
                    triad(s).flicker = true;
                });
                let taus: Vec<f64> = f
                    .iter()
                    .map(|x| match x.gm_tau_s > 0.0 {
                        true => x.gm_tau_s,
                        false => x.floor_tau_s / 1.89,
                    })
                    .collect();
                let t = taus.iter().sum::<f64>() / taus.len().max(1) as f64;
                self.measured(tau, |s| triad(s).bi_tau_s = t);
            } else {
                let longest = f.iter().map(|x| x.tau_max_s).fold(0.0, f64::max);
                self.notes.push(format!(
                    "{name}: bias instability not measured (the Allan curve still falls at {longest:.3} s, its longest averaging time)"
                ));
            }
            if f.iter().all(|x| x.rrw > 0.0) {
                let r = rms(&f.iter().map(|x| x.rrw).collect::<Vec<_>>());
                self.measured(rrw, |s| triad(s).rrw = r);
            }
            if k == 0 {
                if let Some(a) = table_axis {
                    self.notes.push(format!(
                        "gyro noise from the axes across the table's (its axis {} carries the table's motion)",
                        ["x", "y", "z"].get(a).copied().unwrap_or("?")
                    ));
                }
            }
            for (ch, x) in all.iter().enumerate() {
                self.notes.push(format!(
                    "{}: {} (SI)",
                    crate::allan::CHANNELS.get(k + ch).copied().unwrap_or("?"),
                    fit_note(x)
                ));
            }
        }
    }

    /// A measured white noise holds the resolution's rounding (`lsb^2 /
    /// 12` per sample, a density of `lsb / sqrt(12 rate)`), which the
    /// file's resolution term gives again: the file's noise is the
    /// sensor's own, the rounding taken out (a noise at or under the
    /// rounding is unknown: the resolution hides it).
    fn quantisation_out(&mut self, name: &str, triad: TriadOf, lsb: f64, rate_hz: f64) {
        let key = if name == "gyro" {
            terms::GYRO_NOISE
        } else {
            terms::ACCEL_NOISE
        };
        if !self.from.measured.iter().any(|m| m == key) {
            return;
        }
        let q2 = lsb * lsb / (12.0 * rate_hz);
        let w = triad(&mut self.spec).white;
        if w * w > q2 {
            triad(&mut self.spec).white = (w * w - q2).sqrt();
            self.notes.push(format!(
                "{name}: white noise {w:.4e} measured, the resolution's rounding {:.4e} taken out (SI)",
                q2.sqrt()
            ));
        } else {
            self.spec.unknown.push(key.into());
            self.from.measured.retain(|m| m != key);
            self.notes.push(format!(
                "{name}: white noise unknown: {w:.4e} measured is within the resolution's rounding {:.4e} (SI)",
                q2.sqrt()
            ));
        }
    }

    /// The turn-on bias from one run's biases (`intercepts`: per channel,
    /// in recording order, the bias the run shows, `None` where it did
    /// not excite it): per triad the RMS over the axes that show one, a
    /// one-run figure for the population's 1-sigma, said so.
    pub fn bias_from_run(&mut self, intercepts: &[Option<f64>]) {
        let triads: [(usize, &str, TriadOf); 2] = [
            (0, terms::GYRO_BIAS, |s| &mut s.gyro),
            (3, terms::ACCEL_BIAS, |s| &mut s.accel),
        ];
        for (k, key, triad) in triads {
            let b: Vec<f64> = intercepts
                .iter()
                .skip(k)
                .take(3)
                .flatten()
                .copied()
                .filter(|x| x.is_finite())
                .collect();
            if b.is_empty() {
                continue;
            }
            let rms = (b.iter().map(|x| x * x).sum::<f64>() / b.len() as f64).sqrt();
            self.measured(key, |s| triad(s).bias = rms);
            self.notes.push(format!(
                "{key}: this run's biases, the RMS over {} axes (one run: a rough figure for the 1-sigma of a turn-on bias)",
                b.len()
            ));
        }
    }

    /// The resolution and full scale the samples show, per triad: the
    /// lattice their values lie on ([`recording::plausible::lattice`]:
    /// an ADC's step, or a printout's when it is coarser), and the full
    /// scale where they clip.
    pub fn seen_in_data(&mut self, rec: &Recording) {
        let triads: [(usize, &str, [&str; 2], TriadOf); 2] = [
            (0, "gyro", [terms::GYRO_LSB, terms::GYRO_FULL_SCALE], |s| {
                &mut s.gyro
            }),
            (
                3,
                "accel",
                [terms::ACCEL_LSB, terms::ACCEL_FULL_SCALE],
                |s| &mut s.accel,
            ),
        ];
        for (k, name, [lsb, fs], triad) in triads {
            if k == 3 && rec.gyro_only {
                continue;
            }
            // The axes that show a lattice (a quiet axis may sit on too
            // few levels to show one) must agree on it.
            let steps: Vec<f64> = (k..k + 3)
                .filter_map(|c| recording::plausible::lattice(&rec.channel(c)))
                .collect();
            let mean = steps.iter().sum::<f64>() / steps.len().max(1) as f64;
            if !steps.is_empty() && steps.iter().all(|x| (x / mean - 1.0).abs() < 0.01) {
                self.measured(lsb, |s| triad(s).lsb = mean);
                self.quantisation_out(name, triad, mean, rec.meta.imu_rate_hz);
            } else {
                self.notes
                    .push(format!("{name}: no common resolution seen in the samples"));
            }
            let clips: Vec<Option<f64>> = (k..k + 3)
                .map(|c| recording::plausible::clipped_at(&rec.channel(c)))
                .collect();
            match clips.iter().flatten().copied().reduce(f64::max) {
                Some(f) => self.measured(fs, |s| triad(s).full_scale = f),
                None => {
                    let seen = (k..k + 3)
                        .flat_map(|c| rec.channel(c))
                        .filter(|x| x.is_finite())
                        .fold(0.0, |m: f64, x| m.max(x.abs()));
                    self.notes.push(format!(
                        "{name}: full scale not measured (no sample clips; the largest reading is {seen:.4e} SI)"
                    ));
                }
            }
        }
    }
}

/// One channel's fit in a comment's words: each term its value or "not
/// measured" (never a zero for a term the fit left out), the bias
/// instability's bound said as one.
fn fit_note(x: &NoiseFit) -> String {
    let value = |v: f64| match v > 0.0 && v.is_finite() {
        true => format!("{v:.4e}"),
        false => "not measured".into(),
    };
    let b = match x.floor_seen {
        true => value(x.bias_instability),
        false if x.bias_instability > 0.0 => {
            format!("not measured (below {:.4e})", x.bias_instability)
        }
        false => "not measured".into(),
    };
    format!(
        "white {}, bias instability B {b}, rrw {}",
        value(x.white),
        value(x.rrw)
    )
}

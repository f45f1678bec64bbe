//! The library of candidate physics: every effect id of
//! `shared/spec/diagnose-v1.md` as regressors on the prediction (what the
//! effect adds to the sensor's output, linear in its parameters), with the
//! words a person reads and the experiment that excites it.
//!
//! Frames: `s` the sensor (= platform) frame, `b` the table base; `k` the
//! table axis (the same in both); `R(theta)` takes `s` to `b`.

use super::Prediction;
use hal_sim::catalogue::{bound, Bound, EffectId};
use nalgebra::{Rotation3, Unit, Vector3};

/// Which physics a candidate is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// Earth rate (more or less of it than the model has), rad/s.
    EarthRate,
    /// Gyro bias `G f` (nine entries), rad/s per m/s^2.
    GSens,
    /// Gyro rate-squared term per axis, 1/(rad/s).
    GyroK2,
    /// Gyro scale asymmetry per axis (`a/2 |w|`), 1.
    GyroAsym,
    /// IMU origin off the table axis, m in `s`.
    Lever,
    /// Table axis / base tilted about the two axes normal to `k`, rad.
    Tilt,
    /// IMU stamps late relative to the encoder, s.
    TimeOffset,
    /// Gyro bias following the recorded temperature, rad/s per degC.
    TempGyro,
    /// Accelerometer bias following the recorded temperature, m/s^2 per degC.
    TempAccel,
    /// No temperature recorded: a gyro warm-up `1 - exp(-t / tau)` with this
    /// `tau`, s (a nonlinear parameter, fitted on a grid).
    Warmup(f64),
    /// Once-per-revolution encoder angle error, rad.
    Encoder,
    /// Accelerometer specific-force-squared term per axis, 1/(m/s^2).
    AccelK2,
    /// The sensor's mount wobbling with the table angle: a small rotation
    /// `delta(theta)` of the sensor on the platform, 1x and 2x harmonics on
    /// the axis's two normals, rad (hal-sim's `Geometry::wobble_harmonics`).
    Wobble,
}

/// One candidate.
#[derive(Clone, Debug)]
pub struct Candidate {
    /// Effect id (diagnose-v1).
    pub id: EffectId,
    /// Its physics.
    pub kind: Kind,
}

/// One regressor: parameter `param` of the candidate acts on channel `ch`
/// (0-2 gyro x-z, 3-5 accel x-z) through `col` (per IMU sample).
pub struct Term {
    /// Channel.
    pub ch: usize,
    /// Parameter index.
    pub param: usize,
    /// Regressor per sample (channel unit per parameter unit).
    pub col: Vec<f64>,
}

const AX: [&str; 3] = ["x", "y", "z"];

/// A gyro axis whose rate never exceeds this (the simulator's turning
/// threshold, 5 deg/s) gets no rate-shaped terms: nothing in the run drives
/// them.
pub const MIN_RATE_RADPS: f64 = hal_sim::world::TURNING_RADPS;

/// Vector of `b` expressed in `s` at table angle `th` (rad) about `k`: the
/// inverse of the rotation `predict` uses (`R(k, th)` takes `s` to `b`).
fn to_s(k: &Vector3<f64>, th: f64, v: &Vector3<f64>) -> Vector3<f64> {
    Rotation3::from_axis_angle(&Unit::new_unchecked(*k), th).inverse_transform_vector(v)
}

/// The two unit vectors normal to `k` (basis axes of `b`), and their names.
fn normals(k: &Vector3<f64>) -> [(Vector3<f64>, &'static str); 2] {
    let i = k.iamax();
    let a = (i + 1) % 3;
    let b = (i + 2) % 3;
    [(Vector3::ith(a, 1.0), AX[a]), (Vector3::ith(b, 1.0), AX[b])]
}

/// One part of a wobble parameter: (harmonic n, on the axis's second
/// normal, its sine, weight): the parameter adds `weight * value *
/// {cos|sin}(n theta)` to the rocking about that normal.
type WobblePart = (usize, bool, bool, f64);

/// The wobble's parameters, each as its parts, in [`Kind::Wobble`]'s name
/// order. At once per revolution, a rocking that stays fixed in the table's
/// base (`u1 cos - u2 sin`, `u1 sin + u2 cos`, for `theta` positive about
/// `k = u1 x u2`) is no wobble at all: the sensor turned by one fixed
/// rotation of the base, a tilt of the base, which gravity and the earth
/// rate alone show and the tilt terms carry. So the 1x parameters are the
/// two parts that turn with the table: `wobble_1x_cos_rad` the rocking
/// `c (u1 cos + u2 sin)`, `wobble_1x_sin_rad` `s (u1 sin - u2 cos)`; a
/// rocking about one normal alone is half this and half a tilt. The 2x
/// harmonic has no such part: each normal, cos and sin.
fn wobble_parts() -> [Vec<WobblePart>; 6] {
    let one = |second, sine| vec![(2, second, sine, 1.0)];
    [
        vec![(1, false, false, 1.0), (1, true, true, 1.0)],
        vec![(1, false, true, 1.0), (1, true, false, -1.0)],
        one(false, false),
        one(false, true),
        one(true, false),
        one(true, true),
    ]
}

impl Candidate {
    /// A slow effect (temperature, warm-up): its signal lives at periods of
    /// minutes, where a noise model fitted to short blocks is least sure.
    pub fn is_slow(&self) -> bool {
        matches!(
            self.kind,
            Kind::TempGyro | Kind::TempAccel | Kind::Warmup(_)
        )
    }

    /// Its physics rides on the table's measured rate (rate-squared,
    /// asymmetry, time offset, the mount's wobble): what the encoder's
    /// rounding can imitate (`select::quantisation_moved`). Not the encoder
    /// error, which lives in the angles themselves and which coarser
    /// rounding changes for real.
    pub fn rides_on_rate(&self) -> bool {
        matches!(
            self.kind,
            Kind::GyroK2 | Kind::GyroAsym | Kind::TimeOffset | Kind::Wobble
        )
    }

    /// Parameters chosen by searching a grid rather than fitted linearly
    /// (a warm-up's time constant): free parameters all the same, each
    /// counted in the BIC penalty like a fitted one.
    pub fn searched_params(&self) -> usize {
        match self.kind {
            Kind::Warmup(_) => 1,
            _ => 0,
        }
    }

    /// Parameter names, SI units in the names.
    pub fn params(&self, p: &Prediction) -> Vec<String> {
        let per_axis = |f: &dyn Fn(&str) -> String| AX.iter().map(|a| f(a)).collect();
        match self.kind {
            Kind::EarthRate => vec!["earth_rate_radps".into()],
            Kind::GSens => AX
                .iter()
                .flat_map(|i| {
                    AX.iter()
                        .map(move |j| format!("g_sens_{i}{j}_radps_per_mps2"))
                })
                .collect(),
            Kind::GyroK2 => per_axis(&|a| format!("k2_{a}_per_radps")),
            Kind::GyroAsym => per_axis(&|a| format!("asymmetry_{a}")),
            Kind::Lever => per_axis(&|a| format!("lever_{a}_m")),
            Kind::Tilt => normals(&p.k)
                .iter()
                .map(|(_, a)| format!("tilt_about_{a}_rad"))
                .collect(),
            // Per triad: the gyros' offset (the IMU-wide one when the two
            // agree) and the accelerometers'.
            Kind::TimeOffset => vec!["time_offset_s".into(), "accel_time_offset_s".into()],
            Kind::TempGyro => per_axis(&|a| format!("temp_bias_{a}_radps_per_degc")),
            Kind::TempAccel => per_axis(&|a| format!("temp_bias_{a}_mps2_per_degc")),
            Kind::Warmup(_) => per_axis(&|a| format!("warmup_bias_{a}_radps")),
            Kind::Encoder => vec!["encoder_cos_rad".into(), "encoder_sin_rad".into()],
            Kind::AccelK2 => per_axis(&|a| format!("k2_{a}_per_mps2")),
            Kind::Wobble => {
                let [(_, a1), (_, a2)] = normals(&p.k);
                let mut v = vec!["wobble_1x_cos_rad".to_string(), "wobble_1x_sin_rad".into()];
                v.extend(
                    [a1, a2].into_iter().flat_map(|a| {
                        ["cos", "sin"].map(move |f| format!("wobble_2x_{a}_{f}_rad"))
                    }),
                );
                v
            }
        }
    }

    /// The physically possible size of each of its parameters (the
    /// catalogue's [`bound`]): a fit beyond it is not this physics.
    pub fn bound(&self) -> Bound {
        match self.kind {
            Kind::EarthRate => bound::EARTH_RATE,
            Kind::GSens => bound::GYRO_G_SENSITIVITY,
            Kind::GyroK2 => bound::GYRO_K2,
            Kind::GyroAsym => bound::GYRO_ASYMMETRY,
            Kind::Lever => bound::LEVER_ARM,
            Kind::Tilt => bound::AXIS_TILT,
            Kind::TimeOffset => bound::TIME_OFFSET,
            Kind::TempGyro => bound::TEMP_GYRO,
            Kind::TempAccel => bound::TEMP_ACCEL,
            Kind::Warmup(_) => bound::WARMUP_GYRO,
            Kind::Encoder => bound::ENCODER,
            Kind::AccelK2 => bound::ACCEL_K2,
            Kind::Wobble => bound::TABLE_HARMONIC,
        }
    }

    /// Extra parameters fixed by the candidate itself (nonlinear ones found
    /// on a grid), reported with the fitted ones.
    pub fn fixed(&self) -> Vec<(String, f64)> {
        match self.kind {
            Kind::Warmup(tau) => vec![("warmup_tau_s".into(), tau)],
            _ => vec![],
        }
    }

    /// The regressors on the prediction `p`.
    pub fn terms(&self, p: &Prediction) -> Vec<Term> {
        let n = p.t_s.len();
        let col = |f: &dyn Fn(usize) -> f64| (0..n).map(f).collect::<Vec<f64>>();
        let mut out = vec![];
        let k = p.k;
        match self.kind {
            Kind::EarthRate => {
                let unit = p.w_e_b / p.w_e_b.norm().max(1e-300);
                let v: Vec<Vector3<f64>> = (0..n).map(|r| to_s(&k, p.theta[r].0, &unit)).collect();
                for ch in 0..3 {
                    out.push(Term {
                        ch,
                        param: 0,
                        col: v.iter().map(|x| x[ch]).collect(),
                    });
                }
            }
            Kind::GSens => {
                for i in 0..3 {
                    for j in 0..3 {
                        out.push(Term {
                            ch: i,
                            param: 3 * i + j,
                            col: col(&|r| p.f[r][j]),
                        });
                    }
                }
            }
            Kind::GyroK2 | Kind::GyroAsym | Kind::AccelK2 => {
                for i in 0..3 {
                    // Only axes the run drives (a gyro that sees nothing but
                    // the earth rate says nothing about its nonlinearity).
                    if self.kind != Kind::AccelK2
                        && !p.w.iter().any(|w| w[i].abs() > MIN_RATE_RADPS)
                    {
                        continue;
                    }
                    // An asymmetry is the scale difference between positive
                    // and negative rates: a run that turns one way only has
                    // no negative rate to compare (what is left of |w| is
                    // the scale, and the earth rate's sign in the still
                    // phase, which a bias step mimics).
                    if self.kind == Kind::GyroAsym
                        && !(p.w.iter().any(|w| w[i] > MIN_RATE_RADPS)
                            && p.w.iter().any(|w| w[i] < -MIN_RATE_RADPS))
                    {
                        continue;
                    }
                    let c = match self.kind {
                        Kind::GyroK2 => col(&|r| p.w[r][i] * p.w[r][i]),
                        Kind::GyroAsym => col(&|r| 0.5 * p.w[r][i].abs()),
                        _ => col(&|r| p.f[r][i] * p.f[r][i]),
                    };
                    let ch = if self.kind == Kind::AccelK2 { i + 3 } else { i };
                    out.push(Term {
                        ch,
                        param: i,
                        col: c,
                    });
                }
            }
            Kind::Lever => {
                // a = theta_ddot k x r + theta_dot^2 k x (k x r), linear in r.
                for j in 0..3 {
                    let e = Vector3::ith(j, 1.0);
                    let (t1, t2) = (k.cross(&e), k.cross(&k.cross(&e)));
                    for i in 0..3 {
                        out.push(Term {
                            ch: 3 + i,
                            param: j,
                            col: col(&|r| {
                                let (w2, a) = p.motion[r];
                                t1[i] * a + t2[i] * w2
                            }),
                        });
                    }
                }
            }
            Kind::Tilt => {
                // Base rotated by delta: gravity and earth rate seen in s
                // change by R^T (v_b x delta).
                for (j, (u, _)) in normals(&k).iter().enumerate() {
                    let (df, dw) = (p.f_b.cross(u), p.w_e_b.cross(u));
                    let vf: Vec<Vector3<f64>> =
                        (0..n).map(|r| to_s(&k, p.theta[r].0, &df)).collect();
                    let vw: Vec<Vector3<f64>> =
                        (0..n).map(|r| to_s(&k, p.theta[r].0, &dw)).collect();
                    for i in 0..3 {
                        out.push(Term {
                            ch: 3 + i,
                            param: j,
                            col: vf.iter().map(|x| x[i]).collect(),
                        });
                        out.push(Term {
                            ch: i,
                            param: j,
                            col: vw.iter().map(|x| x[i]).collect(),
                        });
                    }
                }
            }
            Kind::TimeOffset => {
                // y(t) = x(t - dt): the residual is -dt dx/dt (first order;
                // the gyros' refined by re-predicting with the fitted
                // offset). The accelerometers have their own: a chip's two
                // triads are filtered and read with different delays.
                for i in 0..3 {
                    out.push(Term {
                        ch: i,
                        param: 0,
                        col: col(&|r| -deriv(&p.w, &p.t_s, r, i)),
                    });
                    out.push(Term {
                        ch: 3 + i,
                        param: 1,
                        col: col(&|r| -deriv(&p.f, &p.t_s, r, i)),
                    });
                }
            }
            Kind::TempGyro | Kind::TempAccel => {
                let base = if self.kind == Kind::TempGyro { 0 } else { 3 };
                for i in 0..3 {
                    out.push(Term {
                        ch: base + i,
                        param: i,
                        col: p.dtemp.clone(),
                    });
                }
            }
            Kind::Warmup(tau) => {
                let t0 = p.t_s.first().copied().unwrap_or(0.0);
                for i in 0..3 {
                    out.push(Term {
                        ch: i,
                        param: i,
                        col: col(&|r| 1.0 - (-(p.t_s[r] - t0) / tau).exp()),
                    });
                }
            }
            Kind::Wobble => {
                // Offered over a quarter revolution or more: its gyro part
                // is on the axes normal to the table's, where the encoder's
                // quantisation does not reach, and it flips with the
                // direction of turning (a g-sensitivity or the earth rate
                // does not). Not at half a turn: a reciprocating table turns
                // exactly that between its stops, and a cliff there (a
                // real stepper's 179.7 deg, or its track shifted by a few
                // ms) offered the term to one pass and not the next.
                if turned(p) < std::f64::consts::FRAC_PI_2 {
                    return out;
                }
                // delta = u h(theta): the sensor turns on its platform by
                // delta, so w_s = (I - [delta x]) theta_dot k + d delta / dt
                // = theta_dot (k x u h + u h') and f_s = f x u h.
                let [(u1, _), (u2, _)] = normals(&k);
                // cos and sin of theta and 2 theta, once per sample (the
                // parameters' parts x 6 channels would otherwise take them
                // 48 times a sample: a third of a diagnosis).
                let trig: Vec<[f64; 4]> = p
                    .theta
                    .iter()
                    .map(|t| {
                        let (s1, c1) = t.0.sin_cos();
                        let (s2, c2) = (2.0 * t.0).sin_cos();
                        [c1, s1, c2, s2]
                    })
                    .collect();
                let ku = [k.cross(&u1), k.cross(&u2)];
                for (param, parts) in wobble_parts().iter().enumerate() {
                    // h(theta) and dh/dtheta of one part at sample r.
                    let h = |r: usize, &(n, _, sine, _): &WobblePart| {
                        let t = trig.get(r).copied().unwrap_or_default();
                        let at = |j: usize| t.get(j).copied().unwrap_or(0.0);
                        let (c, s) = (at(2 * n - 2), at(2 * n - 1));
                        let nf = n as f64;
                        if sine {
                            (s, nf * c)
                        } else {
                            (c, -nf * s)
                        }
                    };
                    let uv = |&(_, second, _, _): &WobblePart| {
                        if second {
                            (u2, ku[1])
                        } else {
                            (u1, ku[0])
                        }
                    };
                    // delta(theta) = sum of w u h(theta): the gyros see
                    // theta_dot (k x delta + d delta / d theta), the
                    // accelerometers f x delta.
                    let sum = |r: usize, ch: usize| {
                        parts.iter().fold(0.0, |acc, part| {
                            let ((hv, dh), (u, kxu), w) = (h(r, part), uv(part), part.3);
                            let i = ch % 3;
                            acc + w * if ch < 3 {
                                p.theta[r].1 * (kxu[i] * hv + u[i] * dh)
                            } else {
                                p.f[r].cross(&u)[i] * hv
                            }
                        })
                    };
                    for ch in 0..6 {
                        out.push(Term {
                            ch,
                            param,
                            col: col(&|r| sum(r, ch)),
                        });
                    }
                }
            }
            Kind::Encoder => {
                // A once-per-revolution error is a 1x harmonic only over a
                // whole revolution: on a run that never turns through one,
                // it is one smooth function of angle among all (graduation
                // errors, the reads' own quantisation, which repeats when a
                // reciprocating table revisits the same angles) and the
                // run cannot tell them apart: not excited.
                if !whole_turns(p) {
                    return out;
                }
                // Encoder angle error e(theta) = c cos + s sin: the rate
                // taken from it is off by de/dt = theta_dot de/dtheta, on the
                // table axis (the gyro is right, the prediction wrong).
                for i in 0..3 {
                    if k[i].abs() < 1e-12 {
                        continue;
                    }
                    out.push(Term {
                        ch: i,
                        param: 0,
                        col: col(&|r| {
                            let (th, w, _) = p.theta[r];
                            k[i] * w * th.sin()
                        }),
                    });
                    out.push(Term {
                        ch: i,
                        param: 1,
                        col: col(&|r| {
                            let (th, w, _) = p.theta[r];
                            -k[i] * w * th.cos()
                        }),
                    });
                }
            }
        }
        out
    }

    /// Where the mismatch shows.
    pub fn where_(&self) -> &'static str {
        match self.kind {
            Kind::EarthRate => "1x table revolution harmonic on the gyros normal to the table axis (the horizontal earth rate)",
            Kind::GSens => "gyro bias phase-locked to the accelerometer channels",
            Kind::GyroK2 => "table-axis gyro: grows with the square of the rate, same sign both ways",
            Kind::GyroAsym => "table-axis gyro: flips with the direction of rotation, in proportion to the rate",
            Kind::Lever => "accelerometers: with the square of the table rate (centripetal) and its acceleration (tangential)",
            Kind::Tilt => "1x table revolution harmonic on the accelerometers normal to the table axis",
            Kind::TimeOffset => "gyros where the table rate changes (ramps, reversals); accelerometers where gravity turns through them",
            Kind::TempGyro | Kind::TempAccel => "slow, following the recorded temperature",
            Kind::Warmup(_) => "slow, an exponential settling after turn-on (no temperature recorded)",
            Kind::Encoder => "1x table revolution harmonic on the table-axis gyro, in proportion to the rate",
            Kind::AccelK2 => "accelerometers, with the square of the specific force along each axis",
            Kind::Wobble => "1x and 2x table-angle harmonics on the gyros normal to the table axis, in proportion to the rate, and on the accelerometers",
        }
    }

    /// For a person.
    pub fn explain(&self) -> &'static str {
        match self.kind {
            Kind::EarthRate => "the earth's rotation is felt by the gyros but is not (or not rightly) in the model",
            Kind::GSens => "the gyro bias depends on the specific force (g-sensitivity): it changes as gravity and the table's accelerations turn through the sensor axes",
            Kind::GyroK2 => "the gyro output is not linear in rate: a rate-squared term grows with the table rate",
            Kind::GyroAsym => "the gyro scale differs between positive and negative rates",
            Kind::Lever => "the IMU sits off the table axis: centripetal and tangential accelerations add to the specific force",
            Kind::Tilt => "the table axis is not where the model puts it (tilted axis or base not level): gravity turns through the sensor once per revolution",
            Kind::TimeOffset => "the IMU samples and the encoder reads are stamped on clocks offset from each other: the error follows the rate's changes",
            Kind::TempGyro => "the gyro bias follows the recorded temperature",
            Kind::TempAccel => "the accelerometer bias follows the recorded temperature",
            Kind::Warmup(_) => "the gyro bias settles after turn-on as the sensor warms up (temperature not recorded: modelled as a warm-up exponential)",
            Kind::Encoder => "the encoder angle carries an error that repeats each revolution (eccentricity, graduation): the rate taken from it is wrong once per turn",
            Kind::AccelK2 => "the accelerometer output is not linear in specific force",
            Kind::Wobble => "the sensor's mount rocks with the table angle (a bent shaft, a bearing, a loose mount): the gyros normal to the table axis see the rocking's rate, the accelerometers gravity tilted by it, both locked to the angle",
        }
    }

    /// The experiment that would excite it when this run does not.
    pub fn excite(&self) -> &'static str {
        match self.kind {
            Kind::EarthRate => "turn the table about a vertical axis so the horizontal earth rate turns through the gyros",
            Kind::GSens | Kind::AccelK2 => "turn the table about a horizontal axis so gravity sweeps +-1 g through the sensor axes",
            Kind::GyroK2 | Kind::GyroAsym => "turn the table at several rates in both directions",
            Kind::Lever => "turn the table at a high rate with ramps (centripetal and tangential accelerations)",
            Kind::Tilt => "turn the table through whole revolutions",
            Kind::TimeOffset => "change the table rate (ramps, reversals)",
            Kind::TempGyro | Kind::TempAccel | Kind::Warmup(_) => "record from a cold start, with the temperature",
            Kind::Encoder => "turn the table through whole revolutions at a steady rate",
            Kind::Wobble => "turn the table through whole revolutions at two rates, both ways",
        }
    }
}

/// The span of table angles the run covers, rad.
fn turned(p: &Prediction) -> f64 {
    let (lo, hi) = p
        .theta
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), t| {
            (l.min(t.0), h.max(t.0))
        });
    if p.theta.is_empty() {
        0.0
    } else {
        hi - lo
    }
}

/// Whether the table turns through at least one whole revolution.
fn whole_turns(p: &Prediction) -> bool {
    turned(p) >= std::f64::consts::TAU
}

/// Central difference of component `i` of `v` over time `t`.
pub fn deriv(v: &[Vector3<f64>], t: &[f64], r: usize, i: usize) -> f64 {
    let a = r.saturating_sub(1);
    let b = (r + 1).min(v.len().saturating_sub(1));
    if b <= a {
        return 0.0;
    }
    (v[b][i] - v[a][i]) / (t[b] - t[a])
}

/// The experiment that tells two effects apart when a run cannot.
pub fn separate(a: EffectId, b: EffectId) -> String {
    use EffectId::*;
    let pair = |x: EffectId, y: EffectId| (a == x && b == y) || (a == y && b == x);
    if pair(GyroScaleNonlinearity, GyroScaleAsymmetry) {
        "run at two or more rates: a rate-squared term grows with the rate squared, an asymmetry in proportion to it".into()
    } else if pair(GyroGSensitivity, EncoderError) {
        "turn both ways or at two rates: an encoder error's rate error scales with the rate and flips with it, a g-sensitivity follows gravity's angle alone".into()
    } else if pair(GyroGSensitivity, GyroScaleNonlinearity) {
        "put the IMU on the table axis (no centripetal acceleration) or turn the axis horizontal so gravity alone excites the g-sensitivity".into()
    } else if pair(AxisTilt, EarthRate) {
        "repeat at another heading or reverse the rotation: the earth rate's 1x harmonic stays fixed in the earth frame, a tilt's on the accelerometers follows the base".into()
    } else if pair(TimeOffset, EncoderError) {
        "turn at a steady rate for whole revolutions (encoder error) and reverse often (time offset)".into()
    } else if pair(TimeOffset, LeverArm) {
        "ramp the rate at two accelerations: a time offset follows the rate change, a lever arm its square".into()
    } else if a == TemperatureBias || b == TemperatureBias {
        "record from a cold start with the temperature, or heat the sensor while the table turns"
            .into()
    } else {
        "reverse the rotation, change the rate or tilt the axis: a run where the two signatures differ".into()
    }
}

/// The library for a prediction: every id's candidates (a warm-up grid
/// stands for `temperature_bias` when no temperature was recorded).
pub fn library(p: &Prediction) -> Vec<Candidate> {
    let out = ruled_out(p);
    library_all(p)
        .into_iter()
        .filter(|c| !out.iter().any(|(id, _)| *id == c.id) || c.kind == Kind::Tilt)
        .filter(|c| p.accel_recorded || c.kind != Kind::TempAccel)
        .collect()
}

/// The effect ids the recording itself rules out, with the reason: a
/// gyro-only recording has no accelerometer terms (the axis tilt keeps its
/// gyro part, the earth rate tilted), a commanded table angle (or no table)
/// measures nothing the encoder errors or the IMU-to-encoder offsets could
/// show in.
pub fn ruled_out(p: &Prediction) -> Vec<(EffectId, String)> {
    let mut v = vec![];
    if !p.accel_recorded {
        let why = "the recording has no accelerometer columns (gyro-only)";
        for id in [EffectId::LeverArm, EffectId::AccelScaleNonlinearity] {
            v.push((id, why.to_string()));
        }
        v.push((
            EffectId::AxisTilt,
            format!("{why}: only its gyro part (the earth rate tilted) is fitted"),
        ));
    }
    if !p.angle_measured {
        let why = "the table angle is not measured (a commanded angle, or no table): nothing shows an encoder error or an offset between the IMU and the encoder";
        for id in [EffectId::EncoderError, EffectId::TimeOffset] {
            v.push((id, why.to_string()));
        }
    }
    v
}

fn library_all(p: &Prediction) -> Vec<Candidate> {
    let c = |id, kind| Candidate { id, kind };
    let mut v = vec![
        c(EffectId::EarthRate, Kind::EarthRate),
        c(EffectId::GyroGSensitivity, Kind::GSens),
        c(EffectId::GyroScaleNonlinearity, Kind::GyroK2),
        c(EffectId::GyroScaleAsymmetry, Kind::GyroAsym),
        c(EffectId::LeverArm, Kind::Lever),
        c(EffectId::AxisTilt, Kind::Tilt),
        c(EffectId::TimeOffset, Kind::TimeOffset),
        c(EffectId::EncoderError, Kind::Encoder),
        c(EffectId::AccelScaleNonlinearity, Kind::AccelK2),
        c(EffectId::TableAngleHarmonic, Kind::Wobble),
    ];
    if p.temp_recorded {
        v.push(c(EffectId::TemperatureBias, Kind::TempGyro));
        v.push(c(EffectId::TemperatureBias, Kind::TempAccel));
    } else {
        let span = p.t_s.last().copied().unwrap_or(0.0) - p.t_s.first().copied().unwrap_or(0.0);
        for tau in [60.0, 120.0, 300.0, 600.0, 1200.0, 2400.0] {
            if tau < span / 2.0 {
                v.push(c(EffectId::TemperatureBias, Kind::Warmup(tau)));
            }
        }
    }
    v
}

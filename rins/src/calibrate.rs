//! Calibration of a recording (`rins calibrate`): find the phases the table
//! went through (static, or steady at one rate) from the encoder, then run
//! core-nav's calibration on them.

use anyhow::{anyhow, bail, Result};
use core_nav::calib::{
    solve, CalibError, Checks, EarthModel, GyroCalibration, Phase, PhaseAccumulator, Unknowns,
};
use core_nav::table::{is_still, EncoderInterpolator, TableAngle};
use nalgebra::Vector3;
use recording::{axis_name, parse_axis, Recording};
use serde_json::{json, Value};

/// A stretch of the run at one table rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Start, s.
    pub t0_s: f64,
    /// End, s.
    pub t1_s: f64,
    /// Mean encoder rate, rad/s (0: static).
    pub rate_radps: f64,
}

/// Finds the static and steady-rate stretches of `rec` from its encoder:
/// a 1 s centred rate, static below 0.05 deg/s, steady while within 1 %
/// (or 0.1 deg/s) of the stretch's first rate; ramps are left out and
/// `trim_s` is cut from each end. Stretches shorter than `min_s` are dropped.
pub fn segments(rec: &Recording, min_s: f64, trim_s: f64) -> Vec<Segment> {
    let t = &rec.table;
    let half = (0.5 * rec.meta.encoder_rate_hz).round().max(1.0) as usize;
    let rate = |i: usize| -> Option<f64> {
        let a = t.get(i.checked_sub(half)?)?;
        let b = t.get(i + half)?;
        Some(a.rate_to(b))
    };
    let mut out = vec![];
    let mut cur: Option<(f64, f64, f64)> = None; // (t0, t_last, rate0)
    let close = |r: f64, r0: f64| {
        if is_still(r0) {
            is_still(r)
        } else {
            (r - r0).abs() < (0.01 * r0.abs()).max(0.1f64.to_radians())
        }
    };
    let flush = |c: Option<(f64, f64, f64)>, out: &mut Vec<Segment>| {
        if let Some((t0, t1, _)) = c {
            let (a, b) = (t0 + trim_s, t1 - trim_s);
            if b - a >= min_s {
                out.push(Segment {
                    t0_s: a,
                    t1_s: b,
                    rate_radps: 0.0,
                });
            }
        }
    };
    for (i, row) in t.iter().enumerate() {
        let Some(r) = rate(i) else { continue };
        let ti = row.t_s;
        match cur {
            Some((t0, _, r0)) if close(r, r0) => cur = Some((t0, ti, r0)),
            _ => {
                flush(cur, &mut out);
                cur = Some((ti, ti, r));
            }
        }
    }
    flush(cur, &mut out);
    // Measured mean rates over the trimmed stretches.
    for s in &mut out {
        let a = t.iter().find(|r| r.t_s >= s.t0_s);
        let b = t.iter().rev().find(|r| r.t_s <= s.t1_s);
        if let (Some(a), Some(b)) = (a, b) {
            let r = a.rate_to(b);
            s.rate_radps = if is_still(r) { 0.0 } else { r };
        }
    }
    out
}

/// The moves of the table within `[t0_s, t1_s]`: maximal stretches turning
/// one way (ramps included), between stops or reversals, as read from the
/// encoder. A reciprocating scheme's moves are whole turns.
pub fn moves(rec: &Recording, t0_s: f64, t1_s: f64) -> Vec<Segment> {
    let t: Vec<_> = rec
        .table
        .iter()
        .filter(|r| r.t_s >= t0_s && r.t_s <= t1_s)
        .collect();
    let mut out = vec![];
    let mut start: Option<(usize, f64)> = None; // (index, sign)
    for j in 0..t.len().saturating_sub(1) {
        let d = t[j + 1].angle_rad - t[j].angle_rad;
        let sg = if d.abs() < 1e-9 { 0.0 } else { d.signum() };
        match start {
            Some((_, s0)) if sg == s0 => {}
            Some((i0, _)) => {
                out.push((i0, j));
                start = if sg != 0.0 { Some((j, sg)) } else { None };
            }
            None if sg != 0.0 => start = Some((j, sg)),
            None => {}
        }
    }
    if let Some((i0, _)) = start {
        out.push((i0, t.len() - 1));
    }
    out.into_iter()
        .filter_map(|(a, b)| {
            let (ra, rb) = (t.get(a)?, t.get(b)?);
            let dt = rb.t_s - ra.t_s;
            (dt > 1.0).then(|| Segment {
                t0_s: ra.t_s,
                t1_s: rb.t_s,
                rate_radps: ra.rate_to(rb),
            })
        })
        .collect()
}

/// Calibration methods.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// The paper: first static + first rotating phase, earth rate ignored.
    Paper,
    /// The paper's phases with the earth rate taken into account.
    Earth,
    /// +rate and -rate phases (no static phase needed), earth-aware.
    Reciprocating,
    /// Every phase: bias, scale, rate-squared (and asymmetry), earth-aware.
    Multirate,
    /// Pick from the phases found: multirate with 3+ rates, reciprocating
    /// with both directions, else earth.
    Auto,
    /// Rests in many attitudes (hand-turned or a tri-axial table):
    /// accelerometer and gyro scale, misalignment and bias
    /// ([`crate::multipos`]).
    Multiposition,
}

/// Accumulates the IMU samples of `seg` into a phase.
pub fn accumulate(
    rec: &Recording,
    seg: &Segment,
    commanded_radps: Option<f64>,
) -> Result<PhaseAccumulator> {
    let mut acc = PhaseAccumulator::new(
        if seg.rate_radps == 0.0 {
            0.0
        } else {
            commanded_radps.unwrap_or(seg.rate_radps)
        },
        rec.meta.axis,
    );
    let mut enc = EncoderInterpolator::<f64>::new(1_000_000);
    let mut rows = rec.table.iter().peekable();
    for r in rec
        .imu
        .iter()
        .filter(|r| r.t_s >= seg.t0_s && r.t_s <= seg.t1_s)
    {
        let t_us = (r.t_s * 1e6).round() as u64;
        while let Some(e) = rows.peek() {
            if enc.latest().is_some_and(|(tl, _)| tl >= t_us) {
                break;
            }
            enc.push(
                (e.t_s * 1e6).round() as u64,
                TableAngle::from_rad_f64(e.angle_rad),
            )
            .map_err(|e| anyhow!("table.csv: {e}"))?;
            rows.next();
        }
        let a = enc.angle_at(t_us).map_err(|e| anyhow!("{e}"))?;
        acc.push(
            t_us,
            &Vector3::from(r.gyro_radps),
            &Vector3::from(r.accel_mps2),
            a,
        )
        .map_err(|e| anyhow!("imu.csv at {} s: {e}", r.t_s))?;
    }
    Ok(acc)
}

/// A finished calibration with what it was made from.
#[derive(Clone, Debug)]
pub struct Calibration {
    /// Method used.
    pub method: Method,
    /// The corrections.
    pub gyro: GyroCalibration,
    /// The phases used.
    pub phases: Vec<(Segment, Phase)>,
    /// The unknowns solved for.
    pub unknowns: Unknowns,
    /// Whether the phases' temperatures were recorded (the drift's
    /// temperature part counted).
    pub drift_temperature: bool,
    /// The sensor whose drift between phases (bias instability, rate
    /// random walk, temperature) the sigmas of `M k`, `q` and `a` count
    /// besides white noise; `None`: white noise only (the drift unknown).
    pub drift_of: Option<String>,
}

/// The earth model for a recording (latitude, base attitude).
pub fn earth_of(rec: &Recording) -> EarthModel {
    let m = &rec.meta;
    m.site().earth_model(&m.base(), m.axis)
}

/// The checks for a recording (gravity from meta or normal gravity).
pub fn checks_of(rec: &Recording) -> Checks {
    Checks {
        gravity_mps2: rec.meta.site().gravity_mps2,
        ..Checks::default()
    }
}

/// Calibrates `rec` with `method` from the phases found in `[t0_s, t1_s]`:
/// static and steady-rate stretches ([`segments`]), or whole moves
/// ([`moves`]) for the reciprocating method. `commanded_radps`, when given,
/// is checked against the measured rate of steady phases.
///
/// # Errors
/// No suitable phases, or a refused phase (with its reason).
pub fn calibrate(
    rec: &Recording,
    window: (f64, f64),
    method: Method,
    commanded_radps: Option<f64>,
) -> Result<Calibration> {
    calibrate_with(rec, window, method, commanded_radps, None)
}

/// [`calibrate`] with the sensor whose drift the sigmas count (`None`:
/// the recording's `[imu] model` when it names a known profile, else
/// white noise only, said in the report).
///
/// # Errors
/// As [`calibrate`].
pub fn calibrate_with(
    rec: &Recording,
    window: (f64, f64),
    method: Method,
    commanded_radps: Option<f64>,
    sensor: Option<&hal_sim::imu::ImuSpec>,
) -> Result<Calibration> {
    let dt = 1.0 / rec.meta.imu_rate_hz;
    let mut cut = rec.clone();
    cut.table.retain(|r| r.t_s >= window.0 && r.t_s <= window.1);
    let segs = &segments(&cut, 5.0, 0.3)[..];
    let mv = moves(rec, window.0, window.1);
    let checks = checks_of(rec);
    let first_static = segs.iter().find(|s| s.rate_radps == 0.0);
    let rotating: Vec<&Segment> = segs.iter().filter(|s| s.rate_radps != 0.0).collect();
    let both_signs =
        rotating.iter().any(|s| s.rate_radps > 0.0) && rotating.iter().any(|s| s.rate_radps < 0.0);
    let mut mags: Vec<f64> = rotating.iter().map(|s| s.rate_radps.abs()).collect();
    mags.sort_by(|a, b| a.total_cmp(b));
    mags.dedup_by(|a, b| (*a - *b).abs() < 0.02 * b.abs());
    let method = match method {
        Method::Auto if mags.len() + usize::from(first_static.is_some()) >= 3 => Method::Multirate,
        Method::Auto if both_signs => Method::Reciprocating,
        Method::Auto => Method::Earth,
        m => m,
    };
    let chosen: Vec<Segment> = match method {
        Method::Paper | Method::Earth => {
            let (Some(s), Some(r)) = (first_static, rotating.first()) else {
                bail!(
                    "{method:?} calibration needs a still phase and a rotating one (5 s or more each) between --from-s and --to-s; found {}. A simulated run has a still phase only when asked: rins simulate --static-s 60; or give --method reciprocating or multirate for a run that turns both ways or at several rates",
                    describe(segs)
                );
            };
            vec![*s, **r]
        }
        Method::Reciprocating => {
            // Whole-turn moves each way (a move cut by the window's end is
            // not one), as many as fit, an equal number each way.
            let whole = |s: &&Segment| {
                let turns = (s.rate_radps * (s.t1_s - s.t0_s)).abs() / core::f64::consts::TAU;
                turns >= 0.99 && (turns - turns.round()).abs() * 360.0 < 0.5
            };
            let pos: Vec<&Segment> = mv
                .iter()
                .filter(|s| s.rate_radps > 0.0)
                .filter(whole)
                .collect();
            let neg: Vec<&Segment> = mv
                .iter()
                .filter(|s| s.rate_radps < 0.0)
                .filter(whole)
                .collect();
            let n = pos
                .len()
                .min(neg.len())
                .min(core_nav::calib::MAX_PHASES / 2);
            if n == 0 {
                bail!(
                    "reciprocating calibration needs moves both ways; found {}",
                    describe(&mv)
                );
            }
            pos.iter()
                .take(n)
                .chain(neg.iter().take(n))
                .map(|s| **s)
                .collect()
        }
        Method::Multiposition => bail!(
            "a multi-position session is calibrated by rins::multipos::calibrate (rins calibrate --method multiposition)"
        ),
        Method::Multirate | Method::Auto => {
            // The first still phase (the bias) and every turning one: a
            // multi-rate run's later dwells add nothing the first does not.
            let chosen: Vec<Segment> = first_static
                .into_iter()
                .chain(rotating.iter().copied())
                .copied()
                .collect();
            if chosen.len() > core_nav::calib::MAX_PHASES {
                bail!(
                    "{} phases (a still one and {} turning) between --from-s and --to-s; a calibration takes at most {}: narrow the window ({})",
                    chosen.len(),
                    rotating.len(),
                    core_nav::calib::MAX_PHASES,
                    describe(&chosen)
                );
            }
            chosen
        }
    };
    let mut phases = vec![];
    for s in &chosen {
        // Moves include their ramps: their mean rate is not the command's.
        let cmd = if method == Method::Reciprocating {
            None
        } else {
            commanded_radps.map(|c| c.abs() * s.rate_radps.signum())
        };
        let acc = accumulate(rec, s, cmd)?;
        let p = acc
            .finish(&checks, dt)
            .map_err(|e| anyhow!("phase {:.1}-{:.1} s: {e}", s.t0_s, s.t1_s))?;
        phases.push((*s, p));
    }
    let earth = if method == Method::Paper {
        EarthModel::Ignore
    } else {
        earth_of(rec)
    };
    let unknowns = Unknowns {
        quadratic: method == Method::Multirate
            && mags.len() + usize::from(first_static.is_some()) >= 3,
        asymmetry: method == Method::Multirate && both_signs && mags.len() >= 2,
    };
    let ps: Vec<Phase> = phases.iter().map(|(_, p)| *p).collect();
    let mut gyro =
        solve(&ps, &earth, unknowns, rec.meta.axis).map_err(|e: CalibError| anyhow!("{e}"))?;
    let spec = sensor.cloned().or_else(|| {
        rec.meta
            .imu_model
            .as_deref()
            .and_then(hal_sim::imu::ImuSpec::by_model)
    });
    let spans = spans(rec, &phases);
    if let Some(spec) = &spec {
        let g = core_nav::calib::gains(&ps, unknowns).map_err(|e| anyhow!("{e}"))?;
        let d = spec.gyro.bias_drift().sigma(&g, &spans);
        let add = |v: &mut Vector3<f64>, d: f64| *v = v.map(|x| x.hypot(d));
        add(&mut gyro.sigma_m_k, d.y);
        if unknowns.quadratic {
            add(&mut gyro.sigma_q, d.z);
        }
        if unknowns.asymmetry {
            add(&mut gyro.sigma_a, d.w);
        }
    }
    Ok(Calibration {
        method,
        gyro,
        phases,
        unknowns,
        drift_of: spec.map(|s| s.name),
        drift_temperature: spans.iter().all(|s| s.temp_c.is_some()),
    })
}

/// Each phase's start, used length and mean recorded temperature (the
/// drift's covariance between phases, [`core_nav::calib::BiasDrift`]).
pub fn spans(rec: &Recording, phases: &[(Segment, Phase)]) -> Vec<core_nav::calib::PhaseSpan> {
    phases
        .iter()
        .map(|(s, p)| {
            let end = s.t0_s + p.duration_s;
            let temps: Vec<Option<f64>> = rec
                .imu
                .iter()
                .filter(|r| r.t_s >= s.t0_s && r.t_s < end)
                .map(|r| r.temp_c)
                .collect();
            let all: Option<Vec<f64>> = temps.iter().copied().collect();
            core_nav::calib::PhaseSpan {
                t0_s: s.t0_s,
                duration_s: p.duration_s,
                temp_c: all
                    .filter(|t| !t.is_empty())
                    .map(|t| t.iter().sum::<f64>() / t.len() as f64),
            }
        })
        .collect()
}

fn describe(segs: &[Segment]) -> String {
    if segs.is_empty() {
        return "no phase of 5 s or more".into();
    }
    segs.iter()
        .map(|s| {
            format!(
                "{:.1}-{:.1} s at {:.2} deg/s",
                s.t0_s,
                s.t1_s,
                s.rate_radps.to_degrees()
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

fn vec3_json(v: &Vector3<f64>) -> Value {
    json!([v.x, v.y, v.z])
}

/// Whether the method solved for the rate-squared term and the
/// asymmetry: an unsolved term is held at exactly 0 with a predicted
/// sigma of exactly 0, which a least-squares solution from noisy data
/// never gives (`core_nav::calib::solve`).
fn solved(g: &GyroCalibration) -> (bool, bool) {
    let any = |v: &Vector3<f64>, s: &Vector3<f64>| v.iter().chain(s.iter()).any(|x| *x != 0.0);
    (any(&g.q, &g.sigma_q), any(&g.a, &g.sigma_a))
}

/// A predicted sigma as JSON: `null` for a term not solved for.
fn sigma_json(v: &Vector3<f64>, solved: bool) -> Value {
    if solved {
        vec3_json(v)
    } else {
        Value::Null
    }
}

/// The calibration file (`rins-calibration/1`): a term the method did
/// not solve for is applied as 0 (no correction), its predicted sigma
/// `null`, and it is listed in `not_estimated`.
pub fn to_json(r: &Calibration) -> Value {
    let g = &r.gyro;
    let (q_solved, a_solved) = solved(g);
    let not_estimated: Vec<&str> = [(q_solved, "q_per_radps"), (a_solved, "asymmetry")]
        .into_iter()
        .filter(|(s, _)| !s)
        .map(|(_, n)| n)
        .collect();
    json!({
        "format": "rins-calibration/1",
        "method": r.method,
        "axis": axis_name(g.axis),
        "gyro": {
            "bias_radps": vec3_json(&g.bias),
            "m_k": vec3_json(&g.m_k),
            "q_per_radps": vec3_json(&g.q),
            "asymmetry": vec3_json(&g.a),
        },
        "predicted_sigma": {
            "bias_radps": vec3_json(&g.sigma_bias),
            "m_k": vec3_json(&g.sigma_m_k),
            "q_per_radps": sigma_json(&g.sigma_q, q_solved),
            "asymmetry": sigma_json(&g.sigma_a, a_solved),
        },
        "not_estimated": not_estimated,
        "sigma_drift_of": r.drift_of,
        "phases": r.phases.iter().map(|(s, p)| json!({
            "t_start_s": s.t0_s, "t_end_s": s.t1_s, "rate_dps": p.rate_radps.to_degrees(),
            "duration_s": p.duration_s, "mean_gyro_radps": vec3_json(&p.mean_w), "arw_rad_per_sqrt_s": vec3_json(&p.arw),
        })).collect::<Vec<_>>(),
    })
}

/// Reads a calibration file written by [`to_json`] (or by `rins record`
/// from the board's frames: no predicted errors).
///
/// # Errors
/// Wrong format or missing fields, named.
pub fn from_json(v: &Value) -> Result<GyroCalibration> {
    if v.get("format").and_then(Value::as_str) != Some("rins-calibration/1") {
        bail!("not a rins-calibration/1 file");
    }
    let vec = |path: &[&str]| -> Result<Vector3<f64>> {
        let mut x = v;
        for p in path {
            x = x
                .get(p)
                .ok_or_else(|| anyhow!("missing {}", path.join(".")))?;
        }
        let a = x
            .as_array()
            .filter(|a| a.len() == 3)
            .ok_or_else(|| anyhow!("{} must be 3 numbers", path.join(".")))?;
        let n: Vec<f64> = a.iter().filter_map(Value::as_f64).collect();
        if n.len() != 3 || n.iter().any(|x| !x.is_finite()) {
            bail!("{} must be 3 finite numbers", path.join("."));
        }
        Ok(Vector3::new(n[0], n[1], n[2]))
    };
    let axis = v
        .get("axis")
        .and_then(Value::as_str)
        .and_then(parse_axis)
        .ok_or_else(|| anyhow!("missing axis"))?;
    // Predicted errors are optional (the board's calibration frames carry
    // none; a term not solved for has null): absent, held as 0, which the
    // report prints as unknown.
    let sigma = |path: &[&str]| -> Result<Vector3<f64>> {
        let missing = path
            .iter()
            .try_fold(v, |x, p| x.get(p))
            .is_none_or(Value::is_null);
        if missing {
            Ok(Vector3::zeros())
        } else {
            vec(path)
        }
    };
    Ok(GyroCalibration {
        bias: vec(&["gyro", "bias_radps"])?,
        m_k: vec(&["gyro", "m_k"])?,
        q: vec(&["gyro", "q_per_radps"])?,
        a: vec(&["gyro", "asymmetry"])?,
        sigma_bias: sigma(&["predicted_sigma", "bias_radps"])?,
        sigma_m_k: sigma(&["predicted_sigma", "m_k"])?,
        sigma_q: sigma(&["predicted_sigma", "q_per_radps"])?,
        sigma_a: sigma(&["predicted_sigma", "asymmetry"])?,
        axis,
        second: None,
    })
}

/// A phase's white gyro noise in words (`core_nav::calib::sensor_noise`:
/// still, all three axes; turning, the two across the table's).
fn phase_arw(p: &core_nav::calib::Phase, axis: core_nav::table::Axis) -> String {
    let a = core_nav::calib::sensor_noise(p, axis);
    let arw = (a.norm() / 3f64.sqrt()).to_degrees() * 60.0;
    match core_nav::table::is_still(p.rate_radps) {
        true => format!("ARW {arw:.3} deg/sqrt(h)"),
        false => format!("ARW {arw:.3} deg/sqrt(h) (the axes across the table's)"),
    }
}

/// Text report.
pub fn report(r: &Calibration) -> String {
    let g = &r.gyro;
    let dph = |x: f64| x.to_degrees() * 3600.0;
    let mut s = format!(
        "calibration ({:?}, table axis {}):\n",
        r.method,
        axis_name(g.axis)
    );
    for (seg, p) in &r.phases {
        s += &format!(
            "  phase {:7.1}-{:7.1} s  rate {:8.3} deg/s  {}\n",
            seg.t0_s,
            seg.t1_s,
            p.rate_radps.to_degrees(),
            phase_arw(p, g.axis)
        );
    }
    let (q_solved, a_solved) = solved(g);
    s += "  axis        bias [deg/h]        M k [ppm]          q [ppm/(deg/s)]\n";
    for (i, n) in ["x", "y", "z"].iter().enumerate() {
        let q = if q_solved {
            format!(
                "{:9.3} +- {:7.3}",
                g.q[i] * 1e6 * 1f64.to_radians(),
                g.sigma_q[i] * 1e6 * 1f64.to_radians()
            )
        } else {
            "not estimated".into()
        };
        s += &format!(
            "  {n}    {:9.2} +- {:6.2}   {:9.1} +- {:7.1}   {q}\n",
            dph(g.bias[i]),
            dph(g.sigma_bias[i]),
            g.m_k[i] * 1e6,
            g.sigma_m_k[i] * 1e6,
        );
    }
    s += &match &r.drift_of {
        Some(n) => format!(
            "  bias: over the phases, at their temperature; the other sigmas count white noise and {n}'s drift between phases (bias instability, rate random walk, {})\n",
            if r.drift_temperature { "temperature" } else { "not the temperature's: none recorded" }
        ),
        None => "  bias: over the phases, at their temperature; the other sigmas count white noise only: the sensor's drift between phases is not known (--sensor)\n".into(),
    };
    if !q_solved || !a_solved {
        s += &format!(
            "  not estimated by this method (one rate, or one direction): {}; applied as 0 (no correction); --method multirate on a run at 3+ rates both ways solves them\n",
            [(q_solved, "q"), (a_solved, "the asymmetry")]
                .iter()
                .filter(|(s, _)| !s)
                .map(|(_, n)| *n)
                .collect::<Vec<_>>()
                .join(" and ")
        );
    }
    s
}

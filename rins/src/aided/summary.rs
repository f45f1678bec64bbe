//! What an aided run shows: its errors against the truth (with GNSS and at
//! the end of each outage), NIS and NEES against their 95 % bounds.

use super::AidedRun;
use recording::Recording;

/// What a run shows against the truth and its own statistics.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct AidedSummary {
    /// What the errors are measured against: "truth" (truth.csv),
    /// "receiver" (a real log's own fixes), "none".
    pub reference: &'static str,
    /// The part of the run the reference covers (first and last row with
    /// a reference), s: a truth that ends before the log measures the
    /// errors over the overlap only.
    pub reference_span_s: Option<[f64; 2]>,
    /// The run's first and last navigated times, s.
    pub run_span_s: Option<[f64; 2]>,
    /// Horizontal error rms while fixes arrive, m (with truth).
    pub h_rms_with_gnss_m: Option<f64>,
    /// The same without the stretches from an outage's end to the
    /// re-initialisation that ended it (the gate refusing the returning
    /// fixes: the outage's error, not the receiver's), m; `None` when no
    /// re-initialisation followed an outage.
    pub h_rms_with_gnss_settled_m: Option<f64>,
    /// Each re-initialisation: when, the jump it made, and the outage
    /// whose error it took out (the last one that ended before it).
    pub reinit_at: Vec<ReinitError>,
    /// Per GNSS gap longer than 2 fix intervals: start s, length s,
    /// horizontal error at its end and its largest, m (with truth), and the
    /// filter's horizontal 1-sigma at its end, m.
    pub outages: Vec<OutageError>,
    /// Mean NIS per fix component and the fraction of fixes inside the
    /// two-sided 95 % chi-square bounds of their components.
    /// `None` when no fix was used (never a 0 for a figure not measured).
    pub nis_mean_per_dof: Option<f64>,
    /// See `nis_mean_per_dof`.
    pub nis_in_95: Option<f64>,
    /// Mean NEES per degree of freedom and the fraction inside its 95 %
    /// bounds (5 dof), with truth.
    pub nees_mean_per_dof: Option<f64>,
    /// See `nees_mean_per_dof`.
    pub nees_in_95: Option<f64>,
    /// The attitude's own mean NEES per degree of freedom (with truth).
    pub nees_attitude_per_dof: Option<f64>,
    /// The fraction of seconds inside the 95 % bounds of the 9-dof NEES a
    /// user computes from trajectory.csv's sigma columns alone (a
    /// diagonal covariance), with truth.
    pub nees_diag_in_95: Option<f64>,
    /// Zero-velocity updates, gate rejections, refusals, mechanization faults.
    pub zupts: u32,
    /// Zero-rotation updates (one per still window).
    pub zarus: u32,
    /// Windows the detector called still that the filter's own velocity
    /// refuted (`core_nav::aided::STILL_VELOCITY_NIS`): no update made.
    pub still_refuted: u32,
    /// See `zupts`.
    pub rejected: u32,
    /// See `zupts`.
    pub refused: u32,
    /// See `zupts`.
    pub faults: u32,
    /// Re-initialisations from fixes the gate kept refusing while they
    /// agreed among themselves (a filter lost after an outage).
    pub reinits: u32,
    /// Re-initialisations of the height alone: the gate refused the
    /// fixes' heights while it took their horizontal positions.
    pub height_reinits: u32,
    /// Where zero-velocity updates fired: (first s, last s, updates) per
    /// stretch (updates at most 0.5 s apart).
    pub zupt_spans: Vec<(f64, f64, u32)>,
    /// What the vehicle's constraints did (`--vehicle`), `None` without.
    pub vehicle: Option<super::vehicle::VehicleReport>,
    /// The run started moving: the velocity the fixes gave it.
    pub moving_start: Option<super::align::MovingStart>,
    /// The ride's noise learnt from the fixes (`None`: not asked,
    /// `--learn-noise`).
    pub learnt_noise: Option<super::learn::LearnReport>,
    /// The process noise the filter started from (the sensor file's):
    /// what a peer is given to compare equals.
    pub process_noise: super::learn::ProcessNoise,
}

/// The stretches of zero-velocity updates in `run`.
fn zupt_spans(run: &AidedRun) -> Vec<(f64, f64, u32)> {
    let mut spans: Vec<(f64, f64, u32)> = vec![];
    for r in run.rows.iter().filter(|r| r.zupt) {
        let t = r.traj.t_s;
        match spans.last_mut() {
            Some(s) if t - s.1 <= 0.5 => {
                s.1 = t;
                s.2 += 1;
            }
            _ => spans.push((t, t, 1)),
        }
    }
    spans
}

/// A re-initialisation and what it took out.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct ReinitError {
    /// When, s.
    pub t_s: f64,
    /// The horizontal jump it made, m.
    pub jump_m: f64,
    /// The outage that ended last before it, when no fix's horizontal
    /// position was taken in between: start s, length s (`None`: the
    /// filter was lost with fixes arriving).
    pub after_outage: Option<[f64; 2]>,
}

/// One outage's errors.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct OutageError {
    /// Last fix before it, s.
    pub start_s: f64,
    /// Time to the next fix, s.
    pub len_s: f64,
    /// Horizontal error at its end (before the next fix), m.
    pub end_error_m: Option<f64>,
    /// Largest horizontal error inside it, m.
    pub max_error_m: Option<f64>,
    /// The filter's horizontal 1-sigma (rss of north and east) at its end, m.
    pub end_sigma_m: f64,
    /// The share of its samples whose horizontal error is inside 3 times
    /// the filter's horizontal 1-sigma (outages cut in, with a reference).
    pub within_3_sigma: Option<f64>,
    /// The height's error at its end (its magnitude), m, and the filter's
    /// height 1-sigma there, m (outages cut in, with a reference): the
    /// vertical channel a user reads in `sigma_down_m`.
    pub end_height_error_m: Option<f64>,
    /// See `end_height_error_m`.
    pub end_height_sigma_m: Option<f64>,
    /// The share of its samples whose height error is inside 3 times the
    /// filter's height 1-sigma.
    pub height_within_3_sigma: Option<f64>,
}

/// The receiver's solution as a reference: each fix's position as offsets
/// from the site (NED, m) and its velocity (the antenna's, a lever arm
/// from the base's point; attitude unknown), at its time on the IMU's
/// clock: its stamp plus `time_offset_s` (the receiver's clock less the
/// IMU's, as the filter was given it).
pub(crate) fn receiver_reference(
    rec: &Recording,
    time_offset_s: f64,
) -> Vec<recording::moving::TruthRow> {
    let Some(mv) = rec.moving.as_ref() else {
        return vec![];
    };
    let origin = core_nav::earth::GeoPoint::from_deg(
        rec.meta.latitude_deg,
        mv.longitude_deg,
        rec.meta.height_m,
    );
    mv.gnss
        .iter()
        .flatten()
        .map(|f| {
            let d = origin.ned_to(&core_nav::earth::GeoPoint::from_deg(
                f.lat_deg, f.lon_deg, f.height_m,
            ));
            recording::moving::TruthRow {
                t_s: f.t_s + time_offset_s,
                p_n_m: [d.x, d.y, d.z],
                v_n_mps: f.v_n_mps,
                euler_deg: [f64::NAN; 3],
            }
        })
        .collect()
}

/// The outage whose error a re-initialisation at `t_s` took out: the last
/// one that ended before it, when no fix was taken between its end and
/// `t_s` (a fix the gate passed means the filter had come back: a later
/// re-initialisation is the filter lost again, with fixes arriving).
fn outage_before(outages: &[OutageError], run: &AidedRun, t_s: f64) -> Option<[f64; 2]> {
    let o = outages
        .iter()
        .filter(|o| o.start_s + o.len_s <= t_s)
        .max_by(|a, b| a.start_s.total_cmp(&b.start_s))?;
    let end = o.start_s + o.len_s;
    let taken = run
        .rows
        .iter()
        .any(|r| r.fix_taken && r.traj.t_s >= end && r.traj.t_s < t_s);
    (!taken).then_some([o.start_s, o.len_s])
}

/// Two-sided 95 % bounds of a chi-square with `k` degrees of freedom
/// (Wilson-Hilferty), per degree of freedom.
pub fn chi2_95_bounds(k: usize) -> (f64, f64) {
    let k = k.max(1) as f64;
    let a = 2.0 / (9.0 * k);
    let q = |z: f64| (1.0 - a + z * a.sqrt()).powi(3);
    (q(-1.959_964), q(1.959_964))
}

/// The summary of `run` on `rec` (errors only where `truth.csv` exists).
pub fn summary(rec: &Recording, run: &AidedRun) -> AidedSummary {
    let given = rec
        .moving
        .as_ref()
        .and_then(|m| m.truth.as_deref())
        .unwrap_or(&[]);
    // No truth (a real log): the receiver's own solution, every fix (those
    // withheld in the outages cut in among them), is the reference.
    let from_fixes = match given.is_empty() {
        true => receiver_reference(rec, run.time_offset_s),
        false => vec![],
    };
    let truth = if given.is_empty() {
        &from_fixes[..]
    } else {
        given
    };
    // The truth at each row's time (interpolated: a truth file need not
    // share the trajectory's rows).
    let h_err = |i: usize| -> Option<f64> {
        let r = run.rows.get(i)?;
        let tr = recording::moving::truth_at(truth, r.traj.t_s)?;
        Some(
            ((tr.p_n_m[0] - r.traj.ned_m[0]).powi(2) + (tr.p_n_m[1] - r.traj.ned_m[1]).powi(2))
                .sqrt(),
        )
    };
    // The height's error and its 1-sigma at each row.
    let v_err = |i: usize| -> Option<(f64, f64)> {
        let r = run.rows.get(i)?;
        let tr = recording::moving::truth_at(truth, r.traj.t_s)?;
        Some(((tr.p_n_m[2] - r.traj.ned_m[2]).abs(), r.sigma_p_m[2]))
    };
    let mut s = AidedSummary {
        zupts: run.zupts,
        zarus: run.zarus,
        still_refuted: run.still_refuted,
        reinits: run.reinits,
        height_reinits: run.height_reinits,
        rejected: run.rejected,
        refused: run.refused,
        faults: run.faults,
        zupt_spans: zupt_spans(run),
        ..AidedSummary::default()
    };
    let fix_rows: Vec<usize> = (0..run.rows.len()).filter(|i| run.rows[*i].fix).collect();
    let rate = rec
        .moving
        .as_ref()
        .and_then(|m| m.gnss_meta)
        .map_or(1.0, |g| g.rate_hz);
    // With GNSS: rows within one fix interval after a fix.
    let mut sq = vec![];
    s.reference = match (given.is_empty(), truth.is_empty()) {
        (false, _) => "truth",
        (true, false) => "receiver",
        (true, true) => "none",
    };
    let covered = |r: &&super::AidedRow| recording::moving::truth_at(truth, r.traj.t_s).is_some();
    s.reference_span_s = run
        .rows
        .iter()
        .find(covered)
        .zip(run.rows.iter().rev().find(covered))
        .map(|(a, b)| [a.traj.t_s, b.traj.t_s]);
    s.run_span_s = run
        .rows
        .first()
        .zip(run.rows.last())
        .map(|(a, b)| [a.traj.t_s, b.traj.t_s]);
    for &(a, l) in &run.outages_cut {
        let inside: Vec<usize> = (0..run.rows.len())
            .filter(|i| run.rows[*i].traj.t_s >= a && run.rows[*i].traj.t_s < a + l)
            .collect();
        let errs: Vec<(usize, f64)> = inside
            .iter()
            .filter_map(|i| h_err(*i).map(|e| (*i, e)))
            .collect();
        let sigma = |i: usize| {
            run.rows
                .get(i)
                .map_or(0.0, |r| r.sigma_p_m[0].hypot(r.sigma_p_m[1]))
        };
        let end = errs.last().copied();
        let v_errs: Vec<(f64, f64)> = inside.iter().filter_map(|i| v_err(*i)).collect();
        s.outages.push(OutageError {
            start_s: a,
            len_s: l,
            end_error_m: end.map(|e| e.1),
            max_error_m: errs.iter().map(|e| e.1).reduce(f64::max),
            end_sigma_m: end
                .map(|e| e.0)
                .or(inside.last().copied())
                .map_or(f64::NAN, sigma),
            within_3_sigma: (!errs.is_empty()).then(|| {
                errs.iter().filter(|(i, e)| *e <= 3.0 * sigma(*i)).count() as f64
                    / errs.len() as f64
            }),
            end_height_error_m: v_errs.last().map(|e| e.0),
            end_height_sigma_m: v_errs.last().map(|e| e.1),
            height_within_3_sigma: (!v_errs.is_empty()).then(|| {
                v_errs.iter().filter(|(e, sd)| *e <= 3.0 * sd).count() as f64 / v_errs.len() as f64
            }),
        });
    }
    for w in fix_rows.windows(2) {
        let (a, b) = (w[0], w[1]);
        let gap = run.rows[b].traj.t_s - run.rows[a].traj.t_s;
        if gap > 2.0 / rate && run.outages_cut.is_empty() {
            let errs: Vec<f64> = (a + 1..b).filter_map(h_err).collect();
            let last = run.rows.get(b - 1);
            s.outages.push(OutageError {
                start_s: run.rows[a].traj.t_s,
                len_s: gap,
                end_error_m: h_err(b - 1),
                max_error_m: errs.iter().copied().reduce(f64::max),
                end_sigma_m: last.map_or(f64::NAN, |r| r.sigma_p_m[0].hypot(r.sigma_p_m[1])),
                within_3_sigma: None,
                end_height_error_m: None,
                end_height_sigma_m: None,
                height_within_3_sigma: None,
            });
        } else if gap <= 2.0 / rate {
            sq.extend((a..b).filter_map(h_err).map(|e| e * e));
        }
    }
    if !sq.is_empty() {
        s.h_rms_with_gnss_m = Some((sq.iter().sum::<f64>() / sq.len() as f64).sqrt());
    }
    s.vehicle = run.vehicle;
    s.learnt_noise = run.learnt.clone();
    s.process_noise = run.process_noise;
    s.moving_start = run.moving_start;
    s.reinit_at = run
        .reinit_at
        .iter()
        .map(|&(t_s, jump_m)| ReinitError {
            t_s,
            jump_m,
            after_outage: outage_before(&s.outages, run, t_s),
        })
        .collect();
    // The recovery stretches: an outage's end to its re-initialisation.
    let recovering: Vec<[f64; 2]> = s
        .reinit_at
        .iter()
        .filter_map(|r| r.after_outage.map(|[a, l]| [a + l, r.t_s]))
        .collect();
    if !recovering.is_empty() {
        let mut sq = vec![];
        for w in fix_rows.windows(2) {
            let (a, b) = (w[0], w[1]);
            if run.rows[b].traj.t_s - run.rows[a].traj.t_s <= 2.0 / rate {
                sq.extend(
                    (a..b)
                        .filter(|i| {
                            let t = run.rows[*i].traj.t_s;
                            !recovering.iter().any(|[x, y]| t >= *x && t <= *y)
                        })
                        .filter_map(h_err)
                        .map(|e| e * e),
                );
            }
        }
        if !sq.is_empty() {
            s.h_rms_with_gnss_settled_m = Some((sq.iter().sum::<f64>() / sq.len() as f64).sqrt());
        }
    }
    let used: Vec<&(f64, f64, u8)> = run.nis.iter().filter(|x| x.2 > 0).collect();
    if !used.is_empty() {
        let dof: f64 = used.iter().map(|x| f64::from(x.2)).sum();
        s.nis_mean_per_dof = Some(used.iter().map(|x| x.1).sum::<f64>() / dof);
        s.nis_in_95 = Some(
            used.iter()
                .filter(|x| {
                    let (lo, hi) = chi2_95_bounds(x.2 as usize);
                    let v = x.1 / f64::from(x.2);
                    v >= lo && v <= hi
                })
                .count() as f64
                / used.len() as f64,
        );
    }
    if !run.nees_attitude.is_empty() {
        let n = run.nees_attitude.len() as f64;
        s.nees_attitude_per_dof =
            Some(run.nees_attitude.iter().map(|x| x.1 / 3.0).sum::<f64>() / n);
    }
    if !run.nees_diag.is_empty() {
        let (lo, hi) = chi2_95_bounds(9);
        let inside = run
            .nees_diag
            .iter()
            .filter(|x| (lo..=hi).contains(&(x.1 / 9.0)))
            .count();
        s.nees_diag_in_95 = Some(inside as f64 / run.nees_diag.len() as f64);
    }
    if !run.nees.is_empty() {
        let n = run.nees.len() as f64;
        s.nees_mean_per_dof = Some(run.nees.iter().map(|x| x.1 / x.2 as f64).sum::<f64>() / n);
        s.nees_in_95 = Some(
            run.nees
                .iter()
                .filter(|x| {
                    let (lo, hi) = chi2_95_bounds(x.2);
                    let v = x.1 / x.2 as f64;
                    v >= lo && v <= hi
                })
                .count() as f64
                / n,
        );
    }
    s
}

impl AidedSummary {
    /// For a person.
    pub fn text(&self) -> String {
        let over = match (self.reference_span_s, self.run_span_s) {
            (Some([a, b]), Some([r0, r1])) if a > r0 + 0.5 || b < r1 - 0.5 => format!(
                " over {a:.1}-{b:.1} s (of the run's {r0:.1}-{r1:.1} s: the rest has no reference)"
            ),
            _ => String::new(),
        };
        let mut o = self.moving_start.map_or(String::new(), |m| {
            let [n, e, _] = m.v_n_mps;
            format!(
                "moving at the start ({:.1} m/s over the ground, +- {:.2} m/s, from the first fixes): no still start, so no zero-velocity updates\n",
                n.hypot(e),
                m.sigma_mps
            )
        });
        o += &format!(
            "errors against: {}{over}\n",
            match self.reference {
                "truth" => "truth.csv",
                "receiver" =>
                    "the receiver's own solution (no truth.csv; withheld fixes inside the outages)",
                _ => "nothing (no truth.csv, no fixes)",
            }
        );
        if let Some(h) = self.h_rms_with_gnss_m {
            o += &format!("horizontal error with GNSS: {h:.2} m rms");
            if let Some(s) = self.h_rms_with_gnss_settled_m {
                o += &format!(
                    " ({s:.2} m without the stretches from an outage's end to its re-initialisation: the outage's error, below)"
                );
            }
            o += "\n";
        }
        for g in &self.outages {
            o += &format!(
                "GNSS outage at {:.0} s for {:.0} s: horizontal error at its end {} (largest {}), filter 1-sigma {:.1} m{}\n",
                g.start_s,
                g.len_s,
                g.end_error_m.map_or("(no reference)".into(), |e| format!("{e:.2} m")),
                g.max_error_m.map_or("-".into(), |e| format!("{e:.2} m")),
                g.end_sigma_m,
                g.within_3_sigma.map_or(String::new(), |w| format!(", {:.0} % of it inside 3 sigma", 100.0 * w))
            );
            // Not "at its end" nor "1-sigma N m, N %": scripts read those
            // as the horizontal's.
            if let (Some(e), Some(sd), Some(w)) = (
                g.end_height_error_m,
                g.end_height_sigma_m,
                g.height_within_3_sigma,
            ) {
                o += &format!(
                    "  its height: {e:.2} m off when it ended (sigma {sd:.2} m), {:.0} % of it inside 3 sigma\n",
                    100.0 * w
                );
            }
        }
        o += &match (self.nis_mean_per_dof, self.nis_in_95) {
            (Some(m), Some(f)) => format!(
                "NIS per component {} ({:.0} % of fixes inside their 95 % bounds)\n",
                recording::figures::sig(m, 2),
                100.0 * f
            ),
            _ => "NIS not measured: no fix was used\n".into(),
        };
        if let (Some(m), Some(f)) = (self.nees_mean_per_dof, self.nees_in_95) {
            o += &format!(
                "NEES per degree of freedom {} ({:.0} % of seconds inside the 95 % bounds; position, velocity, attitude){}\n",
                recording::figures::sig(m, 2),
                100.0 * f,
                self.nees_attitude_per_dof.map_or(String::new(), |a| format!("; attitude alone {}", recording::figures::sig(a, 2)))
            );
        }
        if let Some(d) = self.nees_diag_in_95 {
            o += &format!(
                "the sigma columns alone (9 dof, diagonal): {:.0} % of seconds inside the 95 % bounds\n",
                100.0 * d
            );
        }
        o += &format!(
            "zero-velocity updates {}, zero-rotation updates {}, gate rejections {}, refused {}, mechanization faults {}, re-initialised from the fixes {} (the height alone {})\n",
            self.zupts, self.zarus, self.rejected, self.refused, self.faults, self.reinits, self.height_reinits
        );
        if self.still_refuted > 0 {
            o += &format!(
                "  still windows the filter's own velocity refuted (moving, no update): {}\n",
                self.still_refuted
            );
        }
        for r in &self.reinit_at {
            o += &match r.after_outage {
                Some([a, l]) => format!(
                    "  re-initialised from the fixes at {:.1} s: a {:.2} m jump, the error the outage at {a:.0} s for {l:.0} s left (the gate refused the returning fixes until then)\n",
                    r.t_s, r.jump_m
                ),
                None => format!(
                    "  re-initialised from the fixes at {:.1} s: a {:.2} m jump, with fixes arriving\n",
                    r.t_s, r.jump_m
                ),
            };
        }
        if let Some(v) = &self.vehicle {
            o += &vehicle_text(v);
        }
        if let Some(l) = &self.learnt_noise {
            o += &learnt_text(l);
        }
        if !self.zupt_spans.is_empty() {
            let shown: Vec<String> = self
                .zupt_spans
                .iter()
                .take(6)
                .map(|(a, b, n)| format!("{a:.1}-{b:.1} s ({n})"))
                .collect();
            o += &format!(
                "  the updates fired in {} stillness stretches: {}{}\n",
                self.zupt_spans.len(),
                shown.join(", "),
                if self.zupt_spans.len() > 6 {
                    ", ... (all in --json)"
                } else {
                    ""
                }
            );
        }
        o
    }

    /// As JSON.
    pub fn json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or(serde_json::Value::Null)
    }
}

/// The learnt noise's line of the summary.
fn learnt_text(l: &super::learn::LearnReport) -> String {
    let (g, a) = (l.gyro_arw_file_deg_rth, l.accel_vrw_file_mps_rth);
    if l.factor_max <= 1.0 {
        return format!(
            "ride noise: the sensor file's (gyro {g:.3} deg/sqrt(h), accel {a:.3} m/s/sqrt(h)): {} returns of a shadow run {}-s without fixes never asked for more\n",
            l.returns,
            super::learn::HORIZON_S
        );
    }
    let r = |f: f64| f.sqrt();
    format!(
        "ride noise learnt from the fixes over {}-s horizons: every process noise term {:.1}x the sensor file's density at the end, {:.1}x at most (gyro white {g:.3} -> {:.3} deg/sqrt(h), accel white {a:.3} -> {:.3} m/s/sqrt(h), the bias instabilities alike; kept through outages; fixes whose sigmas are too small would read the same)\n",
        super::learn::HORIZON_S,
        r(l.factor_end),
        r(l.factor_max),
        g * r(l.factor_end),
        a * r(l.factor_end)
    )
}

/// The vehicle's lines of the summary.
fn vehicle_text(v: &super::vehicle::VehicleReport) -> String {
    match (&v.forward, v.found_at_s) {
        (Some(f), Some(t)) => format!(
            "vehicle: forward axis in b at yaw {:.2} +- {:.2} deg, pitch {:.2} +- {:.2} deg (from {} s of straight driving, found at {t:.0} s); {} constraint updates, {} components gated, {} due but off (standing, turning hard, or the axis too loose for its speed){}\n",
            f.yaw_deg, f.sigma_yaw_deg, f.pitch_deg, f.sigma_pitch_deg, f.samples, v.updates, v.rejected, v.off,
            if v.odometer_unused { "; odometer.csv not used (its scale error needs a filter state rins does not have)" } else { "" }
        ),
        _ => "vehicle: no constraint made: the forward axis needs 20 s of straight driving above 5 m/s with fixes, and the run had less\n".into(),
    }
}

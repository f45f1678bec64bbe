//! What an aided run shows: its errors against the truth (with GNSS and at
//! the end of each outage), NIS and NEES against their 95 % bounds.

use super::AidedRun;
use recording::moving::{truth_at, TruthRow};
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
    /// The share of those seconds above the upper bound (the sigmas too
    /// small); the rest outside are below it (too large: cautious).
    pub nees_diag_above_95: Option<f64>,
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
    /// Where the start attitude and its 1-sigmas came from.
    pub start: super::pipeline::StartAttitude,
    /// The run started moving: the velocity the fixes gave it.
    pub moving_start: Option<super::align::MovingStart>,
    /// The ride's noise learnt from the fixes (`None`: not asked,
    /// `--learn-noise`).
    pub learnt_noise: Option<super::learn::LearnReport>,
    /// The ride's vertical noise from the first pass (`None`:
    /// `--vertical-noise file`).
    pub vertical_noise: Option<super::vertical::VerticalReport>,
    /// The process noise the filter started from (the sensor file's):
    /// what a peer is given to compare equals.
    pub process_noise: super::learn::ProcessNoise,
    /// When the fixes' velocity was valid, from their own positions
    /// (`None`: too few fixes with a velocity to tell).
    pub fix_velocity_lag: Option<super::fixvel::VelocityLag>,
    /// The largest 1-sigma the estimated clock and antenna arm added to
    /// the position sigmas, north, east, down, m (`None`: both given).
    pub considered_m: Option<[f64; 3]>,
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
    /// The share of its seconds whose 9-dof diagonal NEES (the sigma
    /// columns alone, against a truth with attitude) is inside its 95 %
    /// bounds.
    pub nees_diag_in_95: Option<f64>,
    /// The share of its seconds above the upper bound (the sigmas too
    /// small; the rest outside are cautious).
    pub nees_diag_above_95: Option<f64>,
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
    let (kind, truth) = reference(rec, run);
    let errs = Errors { run, truth: &truth };
    let rate = rec
        .moving
        .as_ref()
        .and_then(|m| m.gnss_meta)
        .map_or(1.0, |g| g.rate_hz);
    let mut s = AidedSummary {
        reference: kind,
        reference_span_s: span(run, |r| truth_at(&truth, r.traj.t_s).is_some()),
        run_span_s: span(run, |_| true),
        zupts: run.zupts,
        zarus: run.zarus,
        still_refuted: run.still_refuted,
        reinits: run.reinits,
        height_reinits: run.height_reinits,
        rejected: run.rejected,
        refused: run.refused,
        faults: run.faults,
        zupt_spans: zupt_spans(run),
        vehicle: run.vehicle,
        learnt_noise: run.learnt.clone(),
        vertical_noise: run.vertical.clone(),
        process_noise: run.process_noise,
        moving_start: run.moving_start,
        start: run.start,
        fix_velocity_lag: run.velocity_lag,
        considered_m: run.considered_m,
        ..AidedSummary::default()
    };
    s.outages = run
        .outages_cut
        .iter()
        .map(|&(a, l)| errs.outage(a, l))
        .collect();
    if run.outages_cut.is_empty() {
        s.outages.extend(errs.gaps(rate));
    }
    s.h_rms_with_gnss_m = errs.rms_with_gnss(rate, &[]);
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
        s.h_rms_with_gnss_settled_m = errs.rms_with_gnss(rate, &recovering);
    }
    (s.nis_mean_per_dof, s.nis_in_95) = nis_stats(&run.nis);
    (s.nees_mean_per_dof, s.nees_in_95) = nees_stats(&run.nees);
    s.nees_attitude_per_dof = (!run.nees_attitude.is_empty()).then(|| {
        run.nees_attitude.iter().map(|x| x.1 / 3.0).sum::<f64>() / run.nees_attitude.len() as f64
    });
    s.nees_diag_in_95 = diag_in_95(run.nees_diag.iter());
    s.nees_diag_above_95 = diag_above_95(run.nees_diag.iter());
    s
}

/// What the errors are measured against: `truth.csv`, else (a real log)
/// the receiver's own solution, every fix (those withheld in the outages
/// cut in among them): its kind and rows.
pub fn reference(rec: &Recording, run: &AidedRun) -> (&'static str, Vec<TruthRow>) {
    let given = rec
        .moving
        .as_ref()
        .and_then(|m| m.truth.as_deref())
        .unwrap_or(&[]);
    if !given.is_empty() {
        return ("truth", given.to_vec());
    }
    let fixes = receiver_reference(rec, run.time_offset_s);
    let kind = if fixes.is_empty() { "none" } else { "receiver" };
    (kind, fixes)
}

/// The first and last rows' times where `keep` holds.
fn span(run: &AidedRun, keep: impl Fn(&super::AidedRow) -> bool) -> Option<[f64; 2]> {
    let first = run.rows.iter().find(|r| keep(r))?;
    let last = run.rows.iter().rev().find(|r| keep(r))?;
    Some([first.traj.t_s, last.traj.t_s])
}

/// A run's rows against a reference (interpolated to each row's time: a
/// reference need not share the trajectory's rows).
pub struct Errors<'a> {
    /// The run.
    pub run: &'a AidedRun,
    /// The reference's rows.
    pub truth: &'a [TruthRow],
}

impl Errors<'_> {
    /// Row `i`'s horizontal error, m.
    pub fn horizontal(&self, i: usize) -> Option<f64> {
        let r = self.run.rows.get(i)?;
        let tr = truth_at(self.truth, r.traj.t_s)?;
        let (dn, de) = (tr.p_n_m[0] - r.traj.ned_m[0], tr.p_n_m[1] - r.traj.ned_m[1]);
        Some((dn * dn + de * de).sqrt())
    }

    /// Row `i`'s height error (its magnitude) and height 1-sigma, m.
    pub fn height(&self, i: usize) -> Option<(f64, f64)> {
        let r = self.run.rows.get(i)?;
        let tr = truth_at(self.truth, r.traj.t_s)?;
        Some(((tr.p_n_m[2] - r.traj.ned_m[2]).abs(), r.sigma_p_m[2]))
    }

    /// Row `i`'s horizontal 1-sigma (rss of north and east), m.
    fn sigma(&self, i: usize) -> f64 {
        self.run
            .rows
            .get(i)
            .map_or(0.0, |r| r.sigma_p_m[0].hypot(r.sigma_p_m[1]))
    }

    /// The errors of the outage cut in at `a` s for `l` s.
    pub fn outage(&self, a: f64, l: f64) -> OutageError {
        let rows = &self.run.rows;
        let inside: Vec<usize> = (0..rows.len())
            .filter(|i| rows[*i].traj.t_s >= a && rows[*i].traj.t_s < a + l)
            .collect();
        let errs: Vec<(usize, f64)> = inside
            .iter()
            .filter_map(|i| self.horizontal(*i).map(|e| (*i, e)))
            .collect();
        let end = errs.last().copied();
        let v_errs: Vec<(f64, f64)> = inside.iter().filter_map(|i| self.height(*i)).collect();
        let share = |n: usize, of: usize| (of > 0).then(|| n as f64 / of as f64);
        let diag = self
            .run
            .nees_diag
            .iter()
            .filter(|(t, _)| *t >= a && *t < a + l);
        OutageError {
            start_s: a,
            len_s: l,
            end_error_m: end.map(|e| e.1),
            max_error_m: errs.iter().map(|e| e.1).reduce(f64::max),
            end_sigma_m: end
                .map(|e| e.0)
                .or(inside.last().copied())
                .map_or(f64::NAN, |i| self.sigma(i)),
            within_3_sigma: share(
                errs.iter()
                    .filter(|(i, e)| *e <= 3.0 * self.sigma(*i))
                    .count(),
                errs.len(),
            ),
            end_height_error_m: v_errs.last().map(|e| e.0),
            end_height_sigma_m: v_errs.last().map(|e| e.1),
            height_within_3_sigma: share(
                v_errs.iter().filter(|(e, sd)| *e <= 3.0 * sd).count(),
                v_errs.len(),
            ),
            nees_diag_in_95: diag_in_95(diag.clone()),
            nees_diag_above_95: diag_above_95(diag),
        }
    }

    /// The gaps between fixes longer than two fix intervals at `rate_hz`
    /// (a run without outages cut in: the receiver's own).
    pub fn gaps(&self, rate_hz: f64) -> Vec<OutageError> {
        let rows = &self.run.rows;
        let fix_rows: Vec<usize> = (0..rows.len()).filter(|i| rows[*i].fix).collect();
        fix_rows
            .windows(2)
            .filter_map(|w| {
                let (a, b) = (*w.first()?, *w.get(1)?);
                let gap = rows[b].traj.t_s - rows[a].traj.t_s;
                (gap > 2.0 / rate_hz).then(|| {
                    let errs: Vec<f64> = (a + 1..b).filter_map(|i| self.horizontal(i)).collect();
                    OutageError {
                        start_s: rows[a].traj.t_s,
                        len_s: gap,
                        end_error_m: self.horizontal(b - 1),
                        max_error_m: errs.iter().copied().reduce(f64::max),
                        end_sigma_m: self.sigma(b - 1),
                        ..OutageError::default()
                    }
                })
            })
            .collect()
    }

    /// The horizontal error's rms over the rows within a fix interval
    /// (`rate_hz`) after a fix, but those inside `skip` ([from s, to s]
    /// each), m.
    pub fn rms_with_gnss(&self, rate_hz: f64, skip: &[[f64; 2]]) -> Option<f64> {
        let rows = &self.run.rows;
        let fix_rows: Vec<usize> = (0..rows.len()).filter(|i| rows[*i].fix).collect();
        let skipped = |i: &usize| {
            let t = rows[*i].traj.t_s;
            skip.iter().any(|[x, y]| t >= *x && t <= *y)
        };
        let sq: Vec<f64> = fix_rows
            .windows(2)
            .filter_map(|w| Some((*w.first()?, *w.get(1)?)))
            .filter(|(a, b)| rows[*b].traj.t_s - rows[*a].traj.t_s <= 2.0 / rate_hz)
            .flat_map(|(a, b)| a..b)
            .filter(|i| !skipped(i))
            .filter_map(|i| self.horizontal(i))
            .map(|e| e * e)
            .collect();
        (!sq.is_empty()).then(|| (sq.iter().sum::<f64>() / sq.len() as f64).sqrt())
    }
}

/// The fixes' mean NIS per component and the share of fixes inside the
/// two-sided 95 % bounds of their components, over `(t, NIS, components)`
/// (`None` when no fix was used).
pub fn nis_stats(nis: &[(f64, f64, u8)]) -> (Option<f64>, Option<f64>) {
    let used: Vec<&(f64, f64, u8)> = nis.iter().filter(|x| x.2 > 0).collect();
    if used.is_empty() {
        return (None, None);
    }
    let dof: f64 = used.iter().map(|x| f64::from(x.2)).sum();
    let inside = used
        .iter()
        .filter(|x| {
            let (lo, hi) = chi2_95_bounds(x.2 as usize);
            (lo..=hi).contains(&(x.1 / f64::from(x.2)))
        })
        .count();
    (
        Some(used.iter().map(|x| x.1).sum::<f64>() / dof),
        Some(inside as f64 / used.len() as f64),
    )
}

/// The NEES's mean per degree of freedom and the share of its seconds
/// inside their 95 % bounds, over `(t, NEES, dof)`.
pub fn nees_stats(nees: &[(f64, f64, usize)]) -> (Option<f64>, Option<f64>) {
    if nees.is_empty() {
        return (None, None);
    }
    let n = nees.len() as f64;
    let inside = nees
        .iter()
        .filter(|x| {
            let (lo, hi) = chi2_95_bounds(x.2);
            (lo..=hi).contains(&(x.1 / x.2 as f64))
        })
        .count();
    (
        Some(nees.iter().map(|x| x.1 / x.2 as f64).sum::<f64>() / n),
        Some(inside as f64 / n),
    )
}

/// The share of `(t, NEES)` seconds of the 9-dof diagonal NEES (the sigma
/// columns alone) inside its 95 % bounds (`None` for none).
pub fn diag_in_95<'a>(nees: impl Iterator<Item = &'a (f64, f64)>) -> Option<f64> {
    let (lo, hi) = chi2_95_bounds(9);
    diag_share(nees, |per_dof| (lo..=hi).contains(&per_dof))
}

/// The share of those seconds above the upper 95 % bound (`None` for none).
pub fn diag_above_95<'a>(nees: impl Iterator<Item = &'a (f64, f64)>) -> Option<f64> {
    let (_, hi) = chi2_95_bounds(9);
    diag_share(nees, |per_dof| per_dof > hi)
}

fn diag_share<'a>(
    nees: impl Iterator<Item = &'a (f64, f64)>,
    counts: impl Fn(f64) -> bool,
) -> Option<f64> {
    let (mut n, mut hit) = (0usize, 0usize);
    for x in nees {
        n += 1;
        hit += usize::from(counts(x.1 / 9.0));
    }
    (n > 0).then(|| hit as f64 / n as f64)
}

/// ", N % below (cautious), M % above" of a share inside and above.
fn diag_sides(inside: f64, above: Option<f64>) -> String {
    above.map_or(String::new(), |a| {
        format!(
            " ({:.0} % below them, cautious; {:.0} % above)",
            100.0 * (1.0 - inside - a).max(0.0),
            100.0 * a
        )
    })
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
        let mut o = self.start.text();
        o += &self.fix_velocity_lag.map_or(String::new(), |l| l.text());
        o += &self.moving_start.map_or(String::new(), |m| {
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
            if let Some(d) = g.nees_diag_in_95 {
                o += &format!(
                    "  its sigma columns (9 dof, diagonal NEES): {:.0} % of its seconds inside the 95 % bounds{}\n",
                    100.0 * d,
                    diag_sides(d, g.nees_diag_above_95)
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
                "the sigma columns alone (9 dof, diagonal): {:.0} % of seconds inside the 95 % bounds{}\n",
                100.0 * d,
                diag_sides(d, self.nees_diag_above_95)
            );
        }
        if let Some([n, e, d]) = self.considered_m {
            o += &format!(
                "the position sigmas carry the estimated clock's and antenna arm's errors: up to {n:.3}, {e:.3}, {d:.3} m (1-sigma north, east, down)\n"
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
        if let Some(v) = &self.vertical_noise {
            o += &v.text();
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
    let odo = match &v.odometer {
        Some(o) => format!(
            "; odometer: {} updates ({} gated) of {} samples, its scale error {:+.2} +- {:.2} %",
            o.updates,
            o.rejected,
            o.samples,
            100.0 * o.scale,
            100.0 * o.sigma_scale
        ),
        None => String::new(),
    };
    match (&v.forward, v.found_at_s) {
        (Some(f), Some(t)) => format!(
            "vehicle: forward axis in b at yaw {:.2} +- {:.2} deg, pitch {:.2} +- {:.2} deg (read off the filter's velocity at {t:.1} s, then estimated); the IMU {:.2} +- {:.2} m ahead of the rear axle, which slides out of turns at {:.1} +- {:.1} deg per g; {} constraint updates, {} components gated, {} due but off (standing, turning hard){odo}\n",
            f.yaw_deg, f.sigma_yaw_deg, f.pitch_deg, f.sigma_pitch_deg, f.imu_ahead_m, f.sigma_imu_ahead_m, f.rear_slip_deg_per_g, f.sigma_rear_slip_deg_per_g, v.updates, v.rejected, v.off,
        ),
        _ => "vehicle: no constraint made: the forward axis is read off the filter's velocity on a straight stretch above 5 m/s with fixes, and the run had none\n".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aided::AidedRow;

    /// A run of 11 rows, 1 s apart, 3 m north of the truth (at rest at the
    /// origin), each with a horizontal 1-sigma `sigma` north and a fix.
    fn run_off_by_3(sigma: f64) -> (AidedRun, Vec<TruthRow>) {
        let rows = (0..11)
            .map(|i| {
                let mut r = AidedRow::default();
                r.traj.t_s = f64::from(i);
                r.traj.ned_m = [3.0, 0.0, 0.5];
                r.sigma_p_m = [sigma, 0.0, 1.0];
                r.fix = true;
                r
            })
            .collect();
        let truth = (0..11)
            .map(|i| TruthRow {
                t_s: f64::from(i),
                p_n_m: [0.0; 3],
                v_n_mps: [0.0; 3],
                euler_deg: [0.0; 3],
            })
            .collect();
        let run = AidedRun {
            rows,
            nees_diag: vec![(2.0, 9.0), (3.0, 0.0), (4.0, 900.0), (20.0, 9.0)],
            ..AidedRun::default()
        };
        (run, truth)
    }

    #[test]
    fn an_outage_s_errors_are_the_rows_against_the_reference() {
        for (sigma, inside) in [(1.0, 1.0), (0.9, 0.0)] {
            let (run, truth) = run_off_by_3(sigma);
            let g = Errors {
                run: &run,
                truth: &truth,
            }
            .outage(2.0, 5.0);
            // Rows 2-6: 3 m off each, inside 3 sigma exactly at sigma 1.
            assert_eq!(g.end_error_m, Some(3.0));
            assert_eq!(g.within_3_sigma, Some(inside));
            assert_eq!(g.end_height_error_m, Some(0.5));
            assert_eq!(g.height_within_3_sigma, Some(1.0));
            // Its seconds of the diagonal NEES: 9 (per dof 1, inside), 0
            // (below the lower bound) and 900 (above the upper); the one at
            // 20 s is not its.
            assert_eq!(g.nees_diag_in_95, Some(1.0 / 3.0));
            assert_eq!(g.nees_diag_above_95, Some(1.0 / 3.0));
        }
    }

    #[test]
    fn nis_and_nees_shares_count_their_bounds() {
        // Per component 1 (inside) and 30 (outside); a fix with no
        // component used does not count.
        let (m, f) = nis_stats(&[(0.0, 2.0, 2), (1.0, 60.0, 2), (2.0, 0.0, 0)]);
        assert_eq!((m, f), (Some(15.5), Some(0.5)));
        assert_eq!(nis_stats(&[]), (None, None));
        let (m, f) = nees_stats(&[(0.0, 8.0, 8), (1.0, 0.0, 8)]);
        assert_eq!((m, f), (Some(0.5), Some(0.5)));
        assert_eq!(diag_in_95([].iter()), None);
    }
}

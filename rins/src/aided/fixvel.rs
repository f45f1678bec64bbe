//! When a fix's velocity was valid: the receiver's velocity lag, found
//! from the fixes alone.
//!
//! A receiver that forms its velocity from its own positions, or smooths
//! it in its filter (RTKLIB's with dynamics on), reports at each epoch a
//! mean over the time before it, not the velocity at its time tag. Taken
//! as the velocity at the tag, it is wrong by the acceleration times the
//! lag: on the bundled walk's tight turns (1-2 m/s^2) with RTKLIB's
//! fixes, half an epoch (0.125 s) is 0.1-0.25 m/s against a stated
//! 0.05 m/s.
//!
//! **Estimate**: the velocity between consecutive positions,
//! `(p_{i+1} - p_i) / (t_{i+1} - t_i)`, is the mean over that interval,
//! the velocity at its midpoint to second order (no lag of its own). The
//! reported velocity of fix `k` is compared with those midpoint
//! velocities interpolated at `t_k - lag`; the lag is the one that fits
//! best in weighted least squares (each fix weighted once, by the
//! reported velocity's variance plus the positions' over the intervals
//! at its tag: a weight that moved with the lag would pull the fit to
//! half an epoch),
//! found on a 1 ms grid over `[-T, 2 T]` (`T` the median fix interval),
//! horizontal (north, east) and vertical apart. Its 1-sigma is the
//! least-squares one, `s / sqrt(sum w J^2)` with `J` the interpolated
//! velocity's time derivative and `s^2` the fit's reduced chi-square (the
//! stated sigmas' scale measured, not assumed). **Resolved** only where
//! the best fit is inside the search and clear of the lags an epoch
//! either side (below): otherwise several lags fit alike and the
//! curvature's sigma says nothing of which, so no figure is printed.
//!
//! **Taken** where the lag is positive, at least [`SIGNIFICANT`] of its
//! sigmas from 0, its fit better than lag 0's and than the lags an epoch
//! either side (aliases, where the positions' noise hides the motion) by
//! at least `SIGNIFICANT^2` of the fit's scaled chi-square, and within
//! what the navigator stores
//! ([`core_nav::aided::HISTORY`] samples): a velocity from before its tag
//! is compared with the state then. A lag within its noise of 0 (the
//! simulated receivers, a Doppler velocity) changes nothing.

use core_nav::earth::GeoPoint;
use nalgebra::Vector3;
use recording::moving::GnssRow;

/// How many sigmas from 0 a lag must be to be taken.
pub const SIGNIFICANT: f64 = 3.0;
/// The grid step of the search, s.
const STEP_S: f64 = 1e-3;
/// The fewest fixes with a velocity and positions around it.
const MIN_FIXES: usize = 20;

/// One component group's lag (horizontal or vertical).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Lag {
    /// How long before its time tag the velocity was valid, s.
    pub lag_s: f64,
    /// Its 1-sigma, s.
    pub sigma_s: f64,
    /// The velocities' weighted rms against the positions' differences
    /// at the tag, m/s.
    pub rms_at_tag_mps: f64,
    /// The same at the lag, m/s.
    pub rms_at_lag_mps: f64,
    /// The best fit is clear of the lags an epoch either side (by
    /// `SIGNIFICANT^2` of the fit's scaled chi-square) and inside the
    /// search: false where the positions' noise hides the motion, and
    /// then `lag_s` is one of several equally good lags and `sigma_s` (the
    /// curvature's) says nothing of which.
    pub resolved: bool,
    /// Navigated with it ([`SIGNIFICANT`], positive, stored, resolved).
    pub taken: bool,
}

/// The receiver's velocity lag, horizontal and vertical.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct VelocityLag {
    /// North and east together.
    pub horizontal: Lag,
    /// Down.
    pub vertical: Lag,
    /// Fixes compared.
    pub fixes: usize,
}

impl VelocityLag {
    /// The lags the navigator takes, s (0 where not taken):
    /// [`core_nav::aided::AidedConfig::velocity_lag_s`].
    pub fn taken_s(&self) -> [f64; 2] {
        [self.horizontal, self.vertical].map(|l| if l.taken { l.lag_s } else { 0.0 })
    }
}

/// The velocity between two consecutive fixes, at its midpoint: time (s),
/// velocity (m/s, NED), its variance from the positions' (m^2/s^2,
/// horizontal and vertical).
#[derive(Clone, Copy, Debug)]
struct Mid {
    t_s: f64,
    v: Vector3<f64>,
    var: [f64; 2],
}

/// A fix with a velocity: time, velocity, its variance.
#[derive(Clone, Copy, Debug)]
struct Reported {
    t_s: f64,
    v: Vector3<f64>,
    var: f64,
}

/// The lag of `fixes`' velocities behind their positions; `None` with
/// fewer than [`MIN_FIXES`] fixes to compare. `max_lag_s`: the most the
/// navigator can look back (its stored states' span).
pub fn velocity_lag(fixes: &[GnssRow], max_lag_s: f64) -> Option<VelocityLag> {
    let (mids, reported, period) = pairs(fixes)?;
    let fit = |vertical: bool| fit_lag(&mids, &reported, period, vertical, max_lag_s);
    let (horizontal, n) = fit(false)?;
    let (vertical, _) = fit(true)?;
    Some(VelocityLag {
        horizontal,
        vertical,
        fixes: n,
    })
}

impl VelocityLag {
    /// One line for the summary.
    pub fn text(&self) -> String {
        let part = |name: &str, l: &Lag| {
            if !l.resolved {
                return format!(
                    "{name} not resolved (the fit as good an epoch either side or at the \
                     search's edge: the positions' noise hides the motion; {:.3} m/s rms \
                     at the tag; not taken)",
                    l.rms_at_tag_mps,
                );
            }
            format!(
                "{name} {:+.3} +- {:.3} s ({:.3} -> {:.3} m/s rms against the positions; {})",
                l.lag_s,
                l.sigma_s,
                l.rms_at_tag_mps,
                l.rms_at_lag_mps,
                if l.taken {
                    "taken: compared with the state that long before"
                } else {
                    "not taken: not 3 sigma above 0 within the stored states"
                }
            )
        };
        format!(
            "the fixes' velocity is valid before its time tag by (from {} fixes' own positions): {}; {}\n",
            self.fixes,
            part("horizontal", &self.horizontal),
            part("vertical", &self.vertical),
        )
    }
}

/// The midpoint velocities of consecutive fixes no more than 1.5 median
/// intervals apart, the fixes with a velocity, the median interval (s).
fn pairs(fixes: &[GnssRow]) -> Option<(Vec<Mid>, Vec<Reported>, f64)> {
    let first = fixes.first()?;
    let tangent = GeoPoint::from_deg(first.lat_deg, first.lon_deg, first.height_m).tangent();
    let ned = |f: &GnssRow| tangent.ned_to(&GeoPoint::from_deg(f.lat_deg, f.lon_deg, f.height_m));
    let mut gaps: Vec<f64> = fixes.windows(2).map(|w| w[1].t_s - w[0].t_s).collect();
    let period = core_nav::stats::median(&mut gaps);
    if !(period.is_finite() && period > 0.0) {
        return None;
    }
    let mids = fixes
        .windows(2)
        .filter_map(|w| {
            let (a, b) = (&w[0], &w[1]);
            let dt = b.t_s - a.t_s;
            let var = |s: fn(&GnssRow) -> f64| (s(a).powi(2) + s(b).powi(2)) / (dt * dt);
            (dt > 0.0 && dt <= 1.5 * period).then(|| Mid {
                t_s: 0.5 * (a.t_s + b.t_s),
                v: (ned(b) - ned(a)) / dt,
                var: [var(|f| f.sigma_h_m), var(|f| f.sigma_v_m)],
            })
        })
        .filter(|m| m.v.iter().chain(&m.var).all(|x| x.is_finite()))
        .collect();
    let reported = fixes
        .iter()
        .map(|f| Reported {
            t_s: f.t_s,
            v: Vector3::from(f.v_n_mps),
            var: f.sigma_vel_mps.powi(2),
        })
        .filter(|r| r.v.iter().all(|x| x.is_finite()) && r.var.is_finite())
        .collect();
    Some((mids, reported, period))
}

/// The midpoint velocity at `t_s` (linear between the two midpoints
/// around it, when they are one interval apart), its variance and time
/// derivative (per s).
fn interp(
    mids: &[Mid],
    t_s: f64,
    period: f64,
    k: usize,
) -> Option<(Vector3<f64>, f64, Vector3<f64>)> {
    let i = mids.partition_point(|m| m.t_s <= t_s);
    let (a, b) = (mids.get(i.checked_sub(1)?)?, mids.get(i)?);
    let dt = b.t_s - a.t_s;
    if !(dt > 0.0 && dt <= 1.5 * period) {
        return None;
    }
    let u = (t_s - a.t_s) / dt;
    let var = (1.0 - u).powi(2) * a.var[k] + u * u * b.var[k];
    Some((a.v + (b.v - a.v) * u, var, (b.v - a.v) / dt))
}

/// The least-squares lag of one component group and how many fixes it
/// used (the fixes the whole grid could compare, so every lag sees the
/// same ones).
fn fit_lag(
    mids: &[Mid],
    reported: &[Reported],
    period: f64,
    vertical: bool,
    max_lag_s: f64,
) -> Option<(Lag, usize)> {
    let k = usize::from(vertical);
    let comps: &[usize] = if vertical { &[2] } else { &[0, 1] };
    let steps = (3.0 * period / STEP_S).round() as i64;
    let lag_at = |j: i64| -period + j as f64 * STEP_S;
    // Each fix weighted once, by its variances at its tag: weights that
    // moved with the lag (the interpolated variance is least halfway
    // between two midpoints) would pull the fit towards half an epoch.
    let usable: Vec<(&Reported, f64)> = reported
        .iter()
        .filter(|r| (0..=steps).all(|j| interp(mids, r.t_s - lag_at(j), period, k).is_some()))
        .filter_map(|r| interp(mids, r.t_s, period, k).map(|(_, var, _)| (r, 1.0 / (r.var + var))))
        .collect();
    if usable.len() < MIN_FIXES {
        return None;
    }
    // Weighted sum of squares, its weight and `sum w J^2` at a lag.
    let cost = |lag: f64| -> Option<[f64; 3]> {
        let mut acc = [0.0; 3];
        for (r, w) in &usable {
            let (v, _, dv) = interp(mids, r.t_s - lag, period, k)?;
            for &c in comps {
                acc[0] += w * (r.v[c] - v[c]).powi(2);
                acc[1] += w;
                acc[2] += w * dv[c].powi(2);
            }
        }
        Some(acc)
    };
    let grid: Vec<[f64; 3]> = (0..=steps)
        .map(|j| cost(lag_at(j)))
        .collect::<Option<_>>()?;
    let at = |j: i64| grid.get(usize::try_from(j).ok()?).copied();
    let jb = (0..=steps)
        .zip(&grid)
        .min_by(|a, b| a.1[0].total_cmp(&b.1[0]))?
        .0;
    let [chi2, wsum, jj] = at(jb)?;
    let epoch = (period / STEP_S).round() as i64;
    let [chi2_0, wsum_0, _] = at(epoch)?;
    let dof = (usable.len() * comps.len()).saturating_sub(1).max(1) as f64;
    let s2 = chi2 / dof;
    let sigma_s = (s2 / jj).sqrt();
    let best = lag_at(jb);
    // Clear of 0 and of the lags an epoch either side (an alias when the
    // positions' noise hides the motion): each at least SIGNIFICANT^2
    // of the fit's scaled chi-square worse.
    let clear = |j: i64| at(j).is_none_or(|c| c[0] - chi2 >= SIGNIFICANT * SIGNIFICANT * s2);
    // At the search's edge the minimum may lie beyond it, and an alias
    // beyond it is not seen.
    let resolved = jb > 0 && jb < steps && [jb - epoch, jb + epoch].into_iter().all(clear);
    let taken = resolved
        && best > 0.0
        && best >= SIGNIFICANT * sigma_s
        && best <= max_lag_s
        && clear(epoch);
    let rms = |c: f64, w: f64| (c / w).sqrt();
    Some((
        Lag {
            lag_s: best,
            sigma_s,
            rms_at_tag_mps: rms(chi2_0, wsum_0),
            rms_at_lag_mps: rms(chi2, wsum),
            resolved,
            taken,
        },
        usable.len(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fixes every 0.25 s of a walker on a 2 m circle at 1.5 m/s
    /// (1.1 m/s^2 inward) over a 0.5 m hill every 10 s, positions exact, each
    /// velocity the true one `lag` before its tag plus a deterministic
    /// 2 cm/s wobble.
    fn circle(lag_h: f64, lag_v: f64) -> Vec<GnssRow> {
        let (r, w) = (2.0, 0.75);
        let m_per_deg = 111_320.0;
        let (wb, ab) = (2.0 * std::f64::consts::PI * 0.1, 0.5);
        (0..480)
            .map(|i| {
                let t = i as f64 * 0.25;
                let (n, e, d) = (
                    r * (w * t).sin(),
                    r * (1.0 - (w * t).cos()),
                    ab * (wb * t).sin(),
                );
                let vel = |t: f64| {
                    [
                        r * w * (w * t).cos(),
                        r * w * (w * t).sin(),
                        ab * wb * (wb * t).cos(),
                    ]
                };
                let (vh, vv) = (vel(t - lag_h), vel(t - lag_v));
                let wob = 0.02 * (1.7 * t).sin();
                GnssRow {
                    t_s: t,
                    lat_deg: 40.0 + n / m_per_deg,
                    lon_deg: -105.0 + e / (m_per_deg * 40f64.to_radians().cos()),
                    height_m: 1580.0 - d,
                    v_n_mps: [vh[0] + wob, vh[1] - wob, vv[2] + wob],
                    sigma_h_m: 0.01,
                    sigma_v_m: 0.02,
                    sigma_vel_mps: 0.05,
                    quality: None,
                }
            })
            .collect()
    }

    #[test]
    fn a_velocity_half_an_epoch_late_is_found_and_taken() {
        let l = velocity_lag(&circle(0.125, 0.25), 0.6).expect("enough fixes");
        for (got, want) in [(l.horizontal, 0.125), (l.vertical, 0.25)] {
            // Within 3 of its sigmas, or the search's 1 ms grid.
            assert!(
                (got.lag_s - want).abs() <= (3.0 * got.sigma_s).max(STEP_S),
                "{got:?} vs {want}"
            );
            assert!(
                got.taken && got.resolved && got.rms_at_lag_mps < got.rms_at_tag_mps,
                "{got:?}"
            );
        }
        assert_eq!(l.taken_s(), [l.horizontal.lag_s, l.vertical.lag_s]);
    }

    #[test]
    fn a_velocity_at_its_tag_is_left_alone() {
        let l = velocity_lag(&circle(0.0, 0.0), 0.6).expect("enough fixes");
        for got in [l.horizontal, l.vertical] {
            assert!(
                got.lag_s.abs() <= (3.0 * got.sigma_s).max(STEP_S),
                "{got:?}"
            );
        }
        assert_eq!(l.taken_s(), [0.0; 2]);
    }

    #[test]
    fn a_lag_beyond_the_stored_states_is_not_taken() {
        let l = velocity_lag(&circle(0.125, 0.25), 0.2).expect("enough fixes");
        assert!(l.horizontal.taken && !l.vertical.taken, "{l:?}");
    }

    #[test]
    fn fixes_without_velocity_give_none() {
        let mut f = circle(0.0, 0.0);
        for r in &mut f {
            r.v_n_mps = [f64::NAN; 3];
        }
        assert!(velocity_lag(&f, 0.6).is_none());
        assert!(velocity_lag(&[], 0.6).is_none());
    }

    /// A car at 10 m/s easing its speed by at most 0.1 m/s^2, fixes at 2
    /// Hz with 1 m of white position noise (Gaussian from a seeded
    /// generator), the velocity at its tag with 5 cm/s: the noise hides
    /// the motion and the epochs alias one another.
    fn noisy_car(seed: u64) -> Vec<GnssRow> {
        let mut x = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
        let mut gauss = move || {
            // Sum of 12 uniforms less 6: unit variance.
            (0..12)
                .map(|_| {
                    x = x
                        .wrapping_mul(6_364_136_223_846_793_005)
                        .wrapping_add(1_442_695_040_888_963_407);
                    (x >> 11) as f64 / (1u64 << 53) as f64
                })
                .sum::<f64>()
                - 6.0
        };
        let m_per_deg = 111_320.0;
        (0..600)
            .map(|i| {
                let t = i as f64 * 0.5;
                let n = 10.0 * t + 0.1 * 30f64.powi(2) * (1.0 - (t / 30.0).cos());
                let vn = 10.0 + 0.1 * 30.0 * (t / 30.0).sin();
                GnssRow {
                    t_s: t,
                    lat_deg: 40.0 + (n + gauss()) / m_per_deg,
                    lon_deg: -105.0 + gauss() / (m_per_deg * 40f64.to_radians().cos()),
                    height_m: 1580.0 + 2.0 * gauss(),
                    v_n_mps: [vn + 0.05 * gauss(), 0.05 * gauss(), 0.05 * gauss()],
                    sigma_h_m: 1.0,
                    sigma_v_m: 2.0,
                    sigma_vel_mps: 0.05,
                    quality: None,
                }
            })
            .collect()
    }

    /// Where the noise hides the motion the fit is as good an epoch
    /// either side: such a lag is printed as not resolved, and a lag
    /// called resolved must cover the truth (0) within 3 of its sigmas.
    #[test]
    fn a_lag_the_noise_aliases_is_not_called_resolved() {
        let mut unresolved = 0;
        for seed in 0..8 {
            let l = velocity_lag(&noisy_car(seed), 0.62).expect("enough fixes");
            for got in [l.horizontal, l.vertical] {
                assert!(
                    !got.resolved || got.lag_s.abs() <= 3.0 * got.sigma_s,
                    "seed {seed}: {got:?}"
                );
                unresolved += usize::from(!got.resolved);
                if !got.resolved {
                    assert!(!got.taken, "seed {seed}: {got:?}");
                }
            }
        }
        // The gentle drive's vertical (no motion at all) is never resolved.
        assert!(unresolved >= 8, "{unresolved}");
    }

    #[test]
    fn metre_fixes_of_a_gentle_drive_take_no_lag() {
        for seed in 0..8 {
            let l = velocity_lag(&noisy_car(seed), 0.62).expect("enough fixes");
            assert_eq!(l.taken_s(), [0.0; 2], "seed {seed}: {l:?}");
        }
    }
}

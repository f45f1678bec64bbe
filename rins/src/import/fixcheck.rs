//! A receiver's fixes against a reference solution of the same ride: how
//! far off they are once their clock is lined up, so that a log whose
//! receiver states no accuracy gets a measured one instead of a guess.
//!
//! Why not from the filter's innovations: a receiver that filters its own
//! fixes (the comma2k19 u-blox) gives fixes that agree with each other to
//! a decimetre while the whole track sits 0.4 m west of the pose and 1.1 m
//! above it; the innovations see the scatter, not the offset, and scaling
//! the stated sigma until they look right makes the filter overconfident
//! (the book's aided chapter, the car's fix sigma).

use core_nav::earth::{GeoPoint, Tangent};
use recording::moving::{truth_at, GnssRow, TruthRow};

/// The clock shifts searched, s: the fixes' epoch against the
/// reference's time, within +-0.5 s (a logger's delay is a few tenths).
const SHIFT_SPAN_S: f64 = 0.5;
/// The search's step, s: 2 ms moves a car at 30 m/s by 6 cm, below the
/// decimetre scatter it resolves.
const SHIFT_STEP_S: f64 = 0.002;
/// The least 1-sigma taken from the measurement, m: fixes that sit on the
/// reference would otherwise be taken as exact.
const SIGMA_FLOOR_M: f64 = 0.01;

/// The fixes against the reference, at the clock shift that fits them
/// best.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct FixesAgainstReference {
    /// The shift, s: a fix at its epoch `t` fits the reference at `t +
    /// shift_s` (`navigate --time-offset-s` takes the same sign).
    pub shift_s: f64,
    /// The fixes minus the reference at that shift: mean, NED, m.
    pub mean_ned_m: [f64; 3],
    /// Their root mean square (the mean included: an offset the whole
    /// ride long is error the filter has to cover), NED, m.
    pub rms_ned_m: [f64; 3],
    /// Fixes compared (those inside the reference at every shift).
    pub fixes: usize,
    /// The horizontal 1-sigma the fixes were written with, m.
    pub sigma_h_m: f64,
    /// The vertical one, m.
    pub sigma_v_m: f64,
    /// Whether those are this measurement's ([`Self::sigma_m`]), not the
    /// user's.
    pub sigma_measured: bool,
}

impl FixesAgainstReference {
    /// The 1-sigma the measurement gives, m: horizontal the larger of
    /// north's and east's root mean square (one figure for both axes must
    /// cover the worse), vertical down's, each at least 1 cm.
    pub fn sigma_m(&self) -> [f64; 2] {
        let [n, e, d] = self.rms_ned_m;
        [n.max(e).max(SIGMA_FLOOR_M), d.max(SIGMA_FLOOR_M)]
    }

    /// One line for the import's summary.
    pub fn text(&self, reference: &str) -> String {
        let [mn, me, md] = self.mean_ned_m;
        let [rn, re, rd] = self.rms_ned_m;
        let from = if self.sigma_measured {
            "measured here: the log states none; --fix-sigma-m states yours"
        } else {
            "as given"
        };
        format!(
            "the fixes against {reference}: they fit it best {:+.3} s after their epochs, and are written there (on its clock, the IMU's); then off by mean N {mn:+.2}, E {me:+.2}, D {md:+.2} m, rms {rn:.2}, {re:.2}, {rd:.2} m ({} fixes)\ntheir 1-sigma {:.2} m horizontal, {:.2} m vertical ({from})",
            self.shift_s, self.fixes, self.sigma_h_m, self.sigma_v_m
        )
    }
}

/// The fixes against the reference rows (their positions on `tangent`'s
/// plane, as truth.csv holds them), at the clock shift within +-0.5 s
/// whose horizontal root mean square is least. `None` when no fix lies
/// inside the reference at every shift. The sigmas are left for the
/// caller (0 here).
pub fn against_reference(
    fixes: &[GnssRow],
    truth: &[TruthRow],
    tangent: &Tangent,
) -> Option<FixesAgainstReference> {
    let (t0, t1) = (truth.first()?.t_s, truth.last()?.t_s);
    let pts: Vec<(f64, [f64; 3])> = fixes
        .iter()
        .filter(|f| f.t_s - SHIFT_SPAN_S >= t0 && f.t_s + SHIFT_SPAN_S <= t1)
        .map(|f| {
            let d = tangent.ned_to(&GeoPoint::from_deg(f.lat_deg, f.lon_deg, f.height_m));
            (f.t_s, d.into())
        })
        .collect();
    if pts.is_empty() {
        return None;
    }
    let off = |shift: f64| -> Vec<[f64; 3]> {
        pts.iter()
            .filter_map(|(t, p)| {
                let r = truth_at(truth, t + shift)?;
                Some(core::array::from_fn(|i| p[i] - r.p_n_m[i]))
            })
            .collect()
    };
    let steps = (SHIFT_SPAN_S / SHIFT_STEP_S).round() as i64;
    let horizontal = |d: &[[f64; 3]]| d.iter().map(|x| x[0] * x[0] + x[1] * x[1]).sum::<f64>();
    let shift_s = (-steps..=steps)
        .map(|k| k as f64 * SHIFT_STEP_S)
        .min_by(|a, b| horizontal(&off(*a)).total_cmp(&horizontal(&off(*b))))?;
    let d = off(shift_s);
    let n = d.len() as f64;
    let mean = |i: usize| d.iter().map(|x| x[i]).sum::<f64>() / n;
    let rms = |i: usize| (d.iter().map(|x| x[i] * x[i]).sum::<f64>() / n).sqrt();
    Some(FixesAgainstReference {
        shift_s,
        mean_ned_m: core::array::from_fn(mean),
        rms_ned_m: core::array::from_fn(rms),
        fixes: d.len(),
        ..FixesAgainstReference::default()
    })
}

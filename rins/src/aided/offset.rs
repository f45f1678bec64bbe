//! The IMU-to-GNSS time offset, estimated by a pre-pass on the data: the
//! run is navigated with the fixes' positions (ungated) shifted by each
//! offset of a grid, and the fixes' NIS (their innovations' chi-square, which is `-2 log` of
//! their likelihood up to a term that barely moves with the offset)
//! traces a parabola whose minimum is the offset and whose curvature its
//! 1-sigma (a change of 1 in the chi-square), scaled by the NIS's own
//! mean per degree of freedom when the filter is overconfident (a
//! likelihood that is too sharp gives too small a sigma).

use super::{navigate, AidedOptions};
use anyhow::{bail, Result};
use recording::Recording;

/// The gate of the pre-pass's runs, sigmas: none in effect.
const UNGATED: f64 = 1e6;

/// An offset estimate.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct OffsetEstimate {
    /// The IMU's lateness behind the receiver, s.
    pub offset_s: f64,
    /// Its 1-sigma, s.
    pub sigma_s: f64,
    /// The grid: (offset s, total NIS over the fixes, per degree of freedom).
    pub grid: Vec<(f64, f64, f64)>,
}

/// Finds the offset within `+-span_s` of `opt.time_offset_s` in steps of
/// `step_s`.
///
/// # Errors
/// A run that fails, no fixes used, or a minimum at the grid's edge (the
/// offset lies beyond the span).
pub fn estimate(
    rec: &Recording,
    opt: &AidedOptions,
    span_s: f64,
    step_s: f64,
    progress: &mut dyn FnMut(f64),
) -> Result<OffsetEstimate> {
    let n = (span_s / step_s).round() as i64;
    let mut grid = vec![];
    for k in -n..=n {
        let o = AidedOptions {
            time_offset_s: opt.time_offset_s + k as f64 * step_s,
            outages: vec![],
            // Every fix's NIS counts: a gate would drop the worst ones and
            // lower the sum where the offset is wrong.
            gate_sigma: UNGATED,
            // Positions only: a receiver's velocity may lag its own
            // positions (a filter inside it), which is not the clocks'.
            gnss_velocity: false,
            // The fixes alone: zero-velocity updates do not depend on the
            // offset and only blur the fixes' residuals.
            zupt: false,
            ..opt.clone()
        };
        let run = navigate(rec, &o, &mut |_| {})?;
        let used: Vec<&(f64, f64, u8)> = run.nis.iter().filter(|x| x.2 > 0).collect();
        let dof: f64 = used.iter().map(|x| f64::from(x.2)).sum();
        if dof == 0.0 {
            bail!("no fix was used: no offset can be estimated");
        }
        let per = used.iter().map(|x| x.1).sum::<f64>() / dof;
        grid.push((o.time_offset_s, per * dof, per));
        progress((k + n + 1) as f64 / (2 * n + 1) as f64);
    }
    let best = (0..grid.len())
        .min_by(|a, b| grid[*a].1.total_cmp(&grid[*b].1))
        .unwrap_or(0);
    if best == 0 || best + 1 == grid.len() {
        bail!(
            "the fixes' NIS is least at the grid's edge ({:+.3} s): the offset is beyond +-{span_s} s",
            grid[best].0
        );
    }
    // The parabola through the least point and its neighbours.
    let (x0, y0) = (grid[best].0, grid[best].1);
    let (ym, yp) = (grid[best - 1].1, grid[best + 1].1);
    let c = (ym + yp - 2.0 * y0) / (2.0 * step_s * step_s);
    let shift = if c > 0.0 {
        (ym - yp) / (4.0 * c * step_s)
    } else {
        0.0
    };
    let scale = grid[best].2.max(1.0);
    Ok(OffsetEstimate {
        offset_s: x0 + shift.clamp(-step_s, step_s),
        sigma_s: if c > 0.0 {
            (scale / c).sqrt()
        } else {
            f64::INFINITY
        },
        grid,
    })
}

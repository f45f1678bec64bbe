//! `rins calibrate --method multiposition`: a hand-turned or tri-axial
//! session of rests in many attitudes (Tedaldi 2014,
//! `core_nav::multipos`): the accelerometer from the rests' norms, the
//! gyro from the gravity direction carried across each move. Each figure
//! is measured on the session itself, before and after: the rests' norm
//! against the site's gravity, the gravity direction the gyro predicts
//! across each move against the next rest's.

use anyhow::{anyhow, bail, Result};
use core_nav::multipos::{
    fit_accelerometer, fit_gyroscope, integrate, static_intervals, TriadCorrection,
};
use nalgebra::{Matrix3, Vector3};
use recording::Recording;
use serde_json::{json, Value};

/// Most rests a session may hold (the fit's own limit is lower).
const MAX_RESTS: usize = 200;

/// A multi-position calibration and its checks on the session.
#[derive(Clone, Debug)]
pub struct MultiPosition {
    /// The rests found: `[start, end)` sample indices in the window.
    pub rests: Vec<(usize, usize)>,
    /// Gravity the norms are fitted to, m/s^2 (the site's).
    pub g_mps2: f64,
    /// Accelerometer correction: `a = matrix (raw - bias)`, m/s^2.
    pub accel: TriadCorrection,
    /// Worst rest's norm error over `g`, before and after.
    pub norm_error: [f64; 2],
    /// Gyro correction: `w = matrix (raw - bias)`, rad/s.
    pub gyro: TriadCorrection,
    /// Gravity direction predicted across each move, rms, rad: before
    /// (the fit's start: the first rest's bias and one scale) and after.
    pub transition_rms_rad: [f64; 2],
    /// Moves left out of the gyro fit as outliers.
    pub outliers: usize,
}

fn mean(v: &[Vector3<f64>]) -> Vector3<f64> {
    v.iter().sum::<Vector3<f64>>() / v.len().max(1) as f64
}

/// The session between `window` s, starting with `rest_s` s at rest.
///
/// # Errors
/// Too short an initial rest, fewer than 9 rests, or a fit that does not
/// converge.
pub fn calibrate(rec: &Recording, window: (f64, f64), rest_s: f64) -> Result<MultiPosition> {
    rec.require_accel("rins calibrate --method multiposition")
        .map_err(|e| anyhow!("{e}"))?;
    let rows: Vec<_> = rec
        .imu
        .iter()
        .filter(|r| r.t_s >= window.0 && r.t_s <= window.1)
        .collect();
    let acc: Vec<Vector3<f64>> = rows.iter().map(|r| r.accel_mps2.into()).collect();
    let gyr: Vec<Vector3<f64>> = rows.iter().map(|r| r.gyro_radps.into()).collect();
    let dt = rec.dt_s();
    let n_rest = (rest_s / dt) as usize;
    if n_rest < 10 || n_rest > acc.len() {
        bail!("the session must start with --rest-s {rest_s} s at rest inside the window ({} samples)", acc.len());
    }
    let var = |v: &[Vector3<f64>]| {
        let m = mean(v);
        v.iter().map(|x| (x - m).norm_squared()).sum::<f64>() / v.len().max(1) as f64
    };
    // imu_tk's detector: +-0.5 s windows, 10x the rest's variance, 1 s least.
    let mut iv = [(0usize, 0usize); MAX_RESTS];
    let half = ((0.5 / dt) as usize).max(1);
    let found = static_intervals(
        &acc,
        half,
        var(&acc[..n_rest]),
        10.0,
        (1.0 / dt) as usize,
        &mut iv,
    );
    let rests = iv.get(..found.min(MAX_RESTS)).unwrap_or(&[]).to_vec();
    if rests.len() < 9 {
        bail!("{} rests found; a multi-position calibration needs 9 or more, in attitudes that point gravity along every axis", rests.len());
    }
    let means: Vec<Vector3<f64>> = rests.iter().map(|&(a, b)| mean(&acc[a..b])).collect();
    let g = rec.meta.site().gravity_mps2;
    let centre = mean(&means);
    let spread = means.iter().map(|m| (m - centre).norm()).sum::<f64>() / means.len() as f64;
    let (accel, _) = fit_accelerometer(&means, g, centre, Vector3::repeat(g / spread))
        .map_err(|e| anyhow!("the accelerometer fit: {e}"))?;
    let worst = |c: &TriadCorrection| {
        means
            .iter()
            .map(|m| (c.apply(m).norm() / g - 1.0).abs())
            .fold(0.0, f64::max)
    };
    let raw = TriadCorrection {
        matrix: Matrix3::identity(),
        bias: Vector3::zeros(),
    };
    let up: Vec<Vector3<f64>> = means.iter().map(|m| accel.apply(m).normalize()).collect();
    let bias = mean(&gyr[..n_rest]);
    let init = Matrix3::identity() * raw_scale(&gyr, dt, &rests, &up, bias);
    let (gyro, _, outliers) = fit_gyroscope(&gyr, dt, &rests, &up, bias, init)
        .map_err(|e| anyhow!("the gyro fit: {e}"))?;
    let moves = |c: &TriadCorrection| {
        let e: Vec<f64> = rests
            .windows(2)
            .zip(up.windows(2))
            .map(|(r, u)| {
                let span = r[0].1.saturating_sub(1)..(r[1].0 + 1).min(gyr.len());
                let q = integrate(gyr.get(span).unwrap_or(&[]), dt, c);
                (core_nav::attitude::quat_to_dcm(&q).transpose() * u[0] - u[1]).norm()
            })
            .collect();
        (e.iter().map(|x| x * x).sum::<f64>() / e.len().max(1) as f64).sqrt()
    };
    let before = TriadCorrection { matrix: init, bias };
    Ok(MultiPosition {
        g_mps2: g,
        norm_error: [worst(&raw), worst(&accel)],
        transition_rms_rad: [moves(&before), moves(&gyro)],
        rests,
        accel,
        gyro,
        outliers,
    })
}

/// The gyro's scale to start the fit from, output per raw unit: the
/// angles between consecutive rests' gravity directions over the raw
/// rotation each move integrates (least squares through 0). A turn about
/// gravity is invisible to the first, so it starts low, never off by the
/// raw unit's factor (a log in counts: 1/6258 rad/s per count for
/// imu_tk's Xsens).
fn raw_scale(
    gyr: &[Vector3<f64>],
    dt: f64,
    rests: &[(usize, usize)],
    up: &[Vector3<f64>],
    bias: Vector3<f64>,
) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (r, u) in rests.windows(2).zip(up.windows(2)) {
        let raw: Vector3<f64> = gyr
            .get(r[0].1..r[1].0)
            .unwrap_or(&[])
            .iter()
            .map(|w| (w - bias) * dt)
            .sum();
        let phi = raw.norm();
        let theta = u[0].dot(&u[1]).clamp(-1.0, 1.0).acos();
        num += theta * phi;
        den += phi * phi;
    }
    if den > 0.0 && num > 0.0 {
        num / den
    } else {
        1.0
    }
}

/// A matrix's rows in text.
fn rows(m: &Matrix3<f64>) -> String {
    (0..3)
        .map(|i| format!("[{:+.5e} {:+.5e} {:+.5e}]", m[(i, 0)], m[(i, 1)], m[(i, 2)]))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Text report.
pub fn report(m: &MultiPosition) -> String {
    let b = |v: &Vector3<f64>, k: f64| format!("[{:+.5} {:+.5} {:+.5}]", v.x * k, v.y * k, v.z * k);
    let pct = |x: f64| recording::figures::sig(100.0 * x, 2);
    let deg = |x: f64| recording::figures::sig(x.to_degrees(), 2);
    format!(
        "multi-position calibration: {} rests\n  accelerometer: a = T K (raw - b)\n    T K {}\n    b {} (as recorded)\n    the rests' norms against g = {:.5} m/s^2: worst {} % before, {} % after\n  gyro: w = M (raw - b)\n    M {}\n    b {} (as recorded)\n    gravity carried across each of {} moves: {} deg rms from the fit's start (the first rest's bias, one scale), {} deg after ({} left out as outliers)\n",
        m.rests.len(),
        rows(&m.accel.matrix),
        b(&m.accel.bias, 1.0),
        m.g_mps2,
        pct(m.norm_error[0]),
        pct(m.norm_error[1]),
        rows(&m.gyro.matrix),
        b(&m.gyro.bias, 1.0),
        m.rests.len() - 1,
        deg(m.transition_rms_rad[0]),
        deg(m.transition_rms_rad[1]),
        m.outliers
    )
}

/// The calibration as JSON (`rins-multiposition/1`).
pub fn to_json(m: &MultiPosition) -> Value {
    let mat = |x: &Matrix3<f64>| {
        (0..3)
            .map(|i| [x[(i, 0)], x[(i, 1)], x[(i, 2)]])
            .collect::<Vec<_>>()
    };
    json!({
        "format": "rins-multiposition/1",
        "rests": m.rests.len(),
        "g_mps2": m.g_mps2,
        "accel": { "matrix": mat(&m.accel.matrix), "bias_mps2": [m.accel.bias.x, m.accel.bias.y, m.accel.bias.z] },
        "gyro": { "matrix": mat(&m.gyro.matrix), "bias_radps": [m.gyro.bias.x, m.gyro.bias.y, m.gyro.bias.z] },
        "norm_error": { "before": m.norm_error[0], "after": m.norm_error[1] },
        "transition_rms_rad": { "before": m.transition_rms_rad[0], "after": m.transition_rms_rad[1] },
        "outliers": m.outliers,
    })
}

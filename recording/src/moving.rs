//! The moving-base part of a recording (recording-v1, "Moving base and
//! GNSS"): `[base] moving = true`, the site's longitude, `[gnss]`
//! (antenna lever arm in `b`, rate), `gnss.csv` (receiver fixes) and, for
//! simulated runs, `truth.csv` (the base's true motion, trajectory-v1
//! columns).

use crate::{err, parse_columns, RecordingError};
use std::fmt::Write as _;
use std::path::Path;

/// `[gnss]` of `meta.toml`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssMeta {
    /// Antenna position from the table's centre, in `b`, m.
    pub antenna_b_m: [f64; 3],
    /// Fix rate, Hz.
    pub rate_hz: f64,
}

/// One `gnss.csv` row: the antenna's fix, WGS-84, velocity in `n`, the
/// receiver's 1-sigma accuracies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssRow {
    /// Time, s (the IMU's clock).
    pub t_s: f64,
    /// Latitude, deg.
    pub lat_deg: f64,
    /// Longitude, deg.
    pub lon_deg: f64,
    /// Height above the ellipsoid, m.
    pub height_m: f64,
    /// Velocity north, east, down, m/s (NaN when the file has no velocity
    /// columns: a row cannot state NaN, recording-v1).
    pub v_n_mps: [f64; 3],
    /// Horizontal 1-sigma, m.
    pub sigma_h_m: f64,
    /// Vertical 1-sigma, m.
    pub sigma_v_m: f64,
    /// Velocity 1-sigma, m/s (NaN when the file has no velocity columns).
    pub sigma_vel_mps: f64,
    /// The receiver's solution type (the optional `quality` column,
    /// RTKLIB's Q codes), `None` when not given.
    pub quality: Option<Solution>,
}

/// A fix's solution type: RTKLIB's `Q` codes, the optional `quality`
/// column of `gnss.csv` (an extra column recording-v1 readers ignore).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Solution {
    /// Carrier phase, ambiguities fixed (Q = 1).
    RtkFixed,
    /// Carrier phase, ambiguities float (Q = 2).
    RtkFloat,
    /// SBAS-corrected (Q = 3).
    Sbas,
    /// Code differential (Q = 4).
    Dgnss,
    /// Single point (Q = 5).
    Single,
    /// Precise point positioning (Q = 6).
    Ppp,
}

impl Solution {
    /// RTKLIB's Q code.
    pub fn q(self) -> u8 {
        match self {
            Solution::RtkFixed => 1,
            Solution::RtkFloat => 2,
            Solution::Sbas => 3,
            Solution::Dgnss => 4,
            Solution::Single => 5,
            Solution::Ppp => 6,
        }
    }

    /// From RTKLIB's Q code (1-6).
    pub fn from_q(q: u8) -> Option<Self> {
        Some(match q {
            1 => Solution::RtkFixed,
            2 => Solution::RtkFloat,
            3 => Solution::Sbas,
            4 => Solution::Dgnss,
            5 => Solution::Single,
            6 => Solution::Ppp,
            _ => return None,
        })
    }
}

impl GnssRow {
    /// Whether the receiver gave a velocity (a position-only fix has its
    /// velocity and its sigma NaN).
    pub fn has_velocity(&self) -> bool {
        self.sigma_vel_mps.is_finite()
    }

    /// The fix in the receiver's integer units, as the board gets it over
    /// the command link and core-nav's aided navigator takes it.
    /// Sigmas below the units' 1 mm (or 1 mm/s) are kept at 1, so that a
    /// fix never reads as position-only (velocity sigma 0) or as refused.
    pub fn to_fix(&self) -> core_nav::aided::GnssFix {
        let mut f = core_nav::aided::GnssFix::from_si(
            self.lat_deg,
            self.lon_deg,
            self.height_m,
            if self.has_velocity() {
                self.v_n_mps
            } else {
                [0.0; 3]
            },
            self.sigma_h_m,
            self.sigma_v_m,
            if self.has_velocity() {
                self.sigma_vel_mps
            } else {
                0.0
            },
        );
        f.sigma_h_mm = f.sigma_h_mm.max(1);
        f.sigma_v_mm = f.sigma_v_mm.max(1);
        if self.has_velocity() {
            f.sigma_vel_mmps = f.sigma_vel_mmps.max(1);
        }
        f
    }
}

/// One `truth.csv` row (trajectory-v1 columns: the base `b`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruthRow {
    /// Time, s.
    pub t_s: f64,
    /// North, east, down offset from the site point in its local NED, m.
    pub p_n_m: [f64; 3],
    /// Velocity, NED, m/s.
    pub v_n_mps: [f64; 3],
    /// Roll, pitch, heading of `b`, deg (heading in [0, 360)).
    pub euler_deg: [f64; 3],
}

/// The truth at `t_s` (s), from the rows around it: position and velocity
/// linearly interpolated, roll, pitch and heading along the shorter way
/// round (heading across 0/360, roll across +-180); a row's own time gives
/// that row exactly. `None` outside the rows' span (never extrapolated).
pub fn truth_at(rows: &[TruthRow], t_s: f64) -> Option<TruthRow> {
    let k = rows.partition_point(|r| r.t_s < t_s);
    let b = rows.get(k)?;
    if b.t_s == t_s {
        return Some(*b);
    }
    let a = rows.get(k.checked_sub(1)?)?;
    let u = (t_s - a.t_s) / (b.t_s - a.t_s);
    let lerp = |x: [f64; 3], y: [f64; 3]| core::array::from_fn(|i| x[i] + u * (y[i] - x[i]));
    let angle = |x: f64, y: f64| x + u * (y - x + 180.0).rem_euclid(360.0) - u * 180.0;
    let mut euler: [f64; 3] = core::array::from_fn(|i| angle(a.euler_deg[i], b.euler_deg[i]));
    euler[2] = euler[2].rem_euclid(360.0);
    Some(TruthRow {
        t_s,
        p_n_m: lerp(a.p_n_m, b.p_n_m),
        v_n_mps: lerp(a.v_n_mps, b.v_n_mps),
        euler_deg: euler,
    })
}

/// Checks that `truth.csv`'s rows overlap `[t0_s, t1_s]` (a run's first
/// and last navigated times): errors are measured over the overlap only
/// (a reference solution usually ends before the logger), never against a
/// missing or extrapolated truth. Returns the overlap, s.
///
/// # Errors
/// No rows, or rows that share no time with the run: the span the file
/// covers and the run's, naming the file.
pub fn truth_overlap(
    rows: &[TruthRow],
    t0_s: f64,
    t1_s: f64,
    path: &Path,
) -> Result<[f64; 2], RecordingError> {
    let (first, last) = match (rows.first(), rows.last()) {
        (Some(f), Some(l)) => (f.t_s, l.t_s),
        _ => return Err(crate::err(path, None, "no truth rows")),
    };
    let (a, b) = (first.max(t0_s), last.min(t1_s));
    if a < b {
        return Ok([a, b]);
    }
    Err(crate::err(
        path,
        None,
        format!(
            "the truth covers {first:.3} s to {last:.3} s, the run {t0_s:.3} s to {t1_s:.3} s: no time in common to measure errors over"
        ),
    ))
}

/// The moving-base files and keys of a recording.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct MovingBase {
    /// `[site] longitude_deg` (0 when absent).
    pub longitude_deg: f64,
    /// `[gnss]`, when present.
    pub gnss_meta: Option<GnssMeta>,
    /// `gnss.csv`, when present.
    pub gnss: Option<Vec<GnssRow>>,
    /// `truth.csv`, when present (simulated runs).
    pub truth: Option<Vec<TruthRow>>,
    /// `odometer.csv`, when present.
    pub odometer: Option<Vec<OdometerRow>>,
    /// `[base] heading_known = false` (an extra key): the base's heading
    /// at `t_s = 0` is not known (an imported log whose `[base]` heading
    /// is a placeholder); navigation finds it from the fixes' velocity.
    pub heading_unknown: bool,
}

/// `gnss.csv` columns.
pub const GNSS_COLS: [&str; 10] = [
    "t_s",
    "lat_deg",
    "lon_deg",
    "height_m",
    "vn_mps",
    "ve_mps",
    "vd_mps",
    "sigma_h_m",
    "sigma_v_m",
    "sigma_vel_mps",
];

/// `gnss.csv` of position-only fixes: the four velocity columns absent
/// together.
pub const GNSS_POS_COLS: [&str; 6] = [
    "t_s",
    "lat_deg",
    "lon_deg",
    "height_m",
    "sigma_h_m",
    "sigma_v_m",
];

/// The optional solution-type column (RTKLIB's Q: 1 fixed, 2 float, 3
/// SBAS, 4 DGNSS, 5 single, 6 PPP).
pub const GNSS_QUALITY_COL: &str = "quality";

/// The velocity columns, present or absent together.
const GNSS_VEL_COLS: [&str; 4] = ["vn_mps", "ve_mps", "vd_mps", "sigma_vel_mps"];

/// `truth.csv` (and trajectory-v1) columns.
pub const TRUTH_COLS: [&str; 10] = [
    "t_s",
    "north_m",
    "east_m",
    "down_m",
    "vn_mps",
    "ve_mps",
    "vd_mps",
    "roll_deg",
    "pitch_deg",
    "heading_deg",
];

/// The moving-base keys of `meta.toml` (`None` unless `[base] moving =
/// true`).
///
/// # Errors
/// `moving` not a boolean; `[gnss]` with a missing or malformed key.
pub fn parse_meta(text: &str, path: &Path) -> Result<Option<MovingBase>, RecordingError> {
    let t: toml::Table = text
        .parse()
        .map_err(|e| err(path, None, format!("not TOML: {e}")))?;
    let moving = match t.get("base").and_then(|b| b.get("moving")) {
        None => false,
        Some(v) => v
            .as_bool()
            .ok_or_else(|| err(path, None, "[base] moving: expected true or false"))?,
    };
    if !moving {
        return Ok(None);
    }
    let num = |v: &toml::Value| v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
    let longitude_deg = match t.get("site").and_then(|s| s.get("longitude_deg")) {
        None => 0.0,
        Some(v) => num(v)
            .filter(|x| x.is_finite())
            .ok_or_else(|| err(path, None, "[site] longitude_deg: expected a number"))?,
    };
    let gnss_meta = match t.get("gnss") {
        None => None,
        Some(g) => {
            let a = g
                .get("antenna_b_m")
                .and_then(|v| v.as_array())
                .ok_or_else(|| err(path, None, "[gnss] antenna_b_m: expected [x, y, z]"))?;
            let v: Vec<f64> = a.iter().filter_map(num).filter(|x| x.is_finite()).collect();
            let [x, y, z] = v[..] else {
                return Err(err(
                    path,
                    None,
                    "[gnss] antenna_b_m: expected three numbers",
                ));
            };
            let rate_hz = g
                .get("rate_hz")
                .and_then(num)
                .filter(|r| r.is_finite() && *r > 0.0)
                .ok_or_else(|| err(path, None, "[gnss] rate_hz: expected a positive number"))?;
            Some(GnssMeta {
                antenna_b_m: [x, y, z],
                rate_hz,
            })
        }
    };
    let heading_unknown = match t.get("base").and_then(|b| b.get("heading_known")) {
        None => false,
        Some(v) => !v
            .as_bool()
            .ok_or_else(|| err(path, None, "[base] heading_known: expected true or false"))?,
    };
    Ok(Some(MovingBase {
        odometer: None,
        longitude_deg,
        gnss_meta,
        gnss: None,
        truth: None,
        heading_unknown,
    }))
}

/// Parses `gnss.csv`.
///
/// # Errors
/// As the other recording files (missing columns, bad rows, time not
/// increasing), and a sigma that is not positive.
pub fn parse_gnss(text: &str, path: &Path) -> Result<Vec<GnssRow>, RecordingError> {
    let header: Vec<&str> = text
        .lines()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("")
        .split(',')
        .map(str::trim)
        .collect();
    let has = GNSS_VEL_COLS.map(|c| header.contains(&c));
    let velocity = has.iter().all(|h| *h);
    if !velocity && has.iter().any(|h| *h) {
        return Err(err(
            path,
            Some(1),
            "the velocity columns vn_mps, ve_mps, vd_mps, sigma_vel_mps are present or absent together",
        ));
    }
    let mut cols: Vec<&str> = if velocity {
        GNSS_COLS.to_vec()
    } else {
        GNSS_POS_COLS.to_vec()
    };
    let quality = header.contains(&GNSS_QUALITY_COL);
    if quality {
        cols.push(GNSS_QUALITY_COL);
    }
    parse_columns(text, path, &cols)?
        .into_iter()
        .map(|(line, v)| {
            let at = |name: &str| {
                cols.iter()
                    .position(|c| *c == name)
                    .and_then(|i| v.get(i).copied())
                    .unwrap_or(f64::NAN)
            };
            let q = match quality {
                false => None,
                true => {
                    let q = at(GNSS_QUALITY_COL);
                    let s = (q.fract() == 0.0 && (1.0..=6.0).contains(&q))
                        .then(|| Solution::from_q(q as u8))
                        .flatten();
                    Some(s.ok_or_else(|| {
                        err(path, Some(line), format!("quality {q}: RTKLIB's Q, 1 to 6"))
                    })?)
                }
            };
            let mut row = gnss_row(
                path,
                line,
                ["t_s", "lat_deg", "lon_deg", "height_m"].map(at),
                ["vn_mps", "ve_mps", "vd_mps"].map(at),
                ["sigma_h_m", "sigma_v_m", "sigma_vel_mps"].map(at),
            )?;
            row.quality = q;
            Ok(row)
        })
        .collect()
}

/// One fix, checked: a position in range, positive sigmas, and a velocity
/// with its positive sigma, or all four NaN (the parser's fill for a file
/// without the velocity columns).
fn gnss_row(
    path: &Path,
    line: usize,
    [t_s, lat_deg, lon_deg, height_m]: [f64; 4],
    v_n_mps: [f64; 3],
    [sh, sv, sw]: [f64; 3],
) -> Result<GnssRow, RecordingError> {
    if !(lat_deg.abs() <= 90.0 && lon_deg.abs() <= 180.0 && height_m.is_finite()) {
        return Err(err(
            path,
            Some(line),
            "latitude, longitude or height out of range",
        ));
    }
    if !(sh > 0.0 && sv > 0.0) {
        return Err(err(path, Some(line), "sigmas must be positive"));
    }
    let no_velocity = sw.is_nan() && v_n_mps.iter().all(|v| v.is_nan());
    let velocity = sw > 0.0 && v_n_mps.iter().all(|v| v.is_finite());
    if !(no_velocity || velocity) {
        return Err(err(
            path,
            Some(line),
            "the velocity must be finite with a positive sigma (fixes without one: a file without the four velocity columns, recording-v1)",
        ));
    }
    Ok(GnssRow {
        t_s,
        lat_deg,
        lon_deg,
        height_m,
        v_n_mps,
        sigma_h_m: sh,
        sigma_v_m: sv,
        sigma_vel_mps: sw,
        quality: None,
    })
}

/// Parses `truth.csv` (or a trajectory-v1 `trajectory.csv`).
///
/// # Errors
/// As the other recording files.
pub fn parse_truth(text: &str, path: &Path) -> Result<Vec<TruthRow>, RecordingError> {
    let rows = parse_columns(text, path, &TRUTH_COLS)?;
    rows.into_iter()
        .map(|(line, v)| {
            let [t_s, n, e, d, vn, ve, vd, r, p, h] = v[..] else {
                return Err(err(path, Some(line), "wrong number of columns"));
            };
            Ok(TruthRow {
                t_s,
                p_n_m: [n, e, d],
                v_n_mps: [vn, ve, vd],
                euler_deg: [r, p, h],
            })
        })
        .collect()
}

/// `gnss.csv` as text.
///
/// Position-only when no row has a velocity; otherwise every column, and
/// a position-only row among rows with velocity is written with NaNs that
/// the reader refuses (recording-v1: the columns go together per file).
pub fn gnss_text(rows: &[GnssRow]) -> String {
    let position_only = !rows.is_empty() && rows.iter().all(|r| !r.has_velocity());
    let quality = !rows.is_empty() && rows.iter().all(|r| r.quality.is_some());
    let mut s = if position_only {
        GNSS_POS_COLS.join(",")
    } else {
        GNSS_COLS.join(",")
    };
    if quality {
        s.push(',');
        s.push_str(GNSS_QUALITY_COL);
    }
    s.push('\n');
    for r in rows {
        let [vn, ve, vd] = r.v_n_mps;
        let _ = if position_only {
            writeln!(
                s,
                "{:.3},{:.9},{:.9},{:.3},{},{}",
                r.t_s, r.lat_deg, r.lon_deg, r.height_m, r.sigma_h_m, r.sigma_v_m
            )
        } else {
            writeln!(
                s,
                "{:.3},{:.9},{:.9},{:.3},{vn:.4},{ve:.4},{vd:.4},{},{},{}",
                r.t_s, r.lat_deg, r.lon_deg, r.height_m, r.sigma_h_m, r.sigma_v_m, r.sigma_vel_mps
            )
        };
        if let (true, Some(q)) = (quality, r.quality) {
            s.pop();
            let _ = writeln!(s, ",{}", q.q());
        }
    }
    s
}

/// One `odometer.csv` row: the vehicle's speed along `b`'s x axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometerRow {
    /// Time, s (the IMU's clock).
    pub t_s: f64,
    /// Speed, m/s (wheel speeds averaged, or the car's own).
    pub speed_mps: f64,
    /// Its 1-sigma, m/s, when the file gives one.
    pub sigma_mps: Option<f64>,
}

/// `odometer.csv`'s columns; `sigma_mps` is optional.
pub const ODOMETER_COLS: [&str; 3] = ["t_s", "speed_mps", "sigma_mps"];

/// Parses `odometer.csv`.
///
/// # Errors
/// As the other recording files, and a sigma that is not positive.
pub fn parse_odometer(text: &str, path: &Path) -> Result<Vec<OdometerRow>, RecordingError> {
    let header = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
    let sigma = header.split(',').any(|c| c.trim() == ODOMETER_COLS[2]);
    let cols = if sigma {
        &ODOMETER_COLS[..]
    } else {
        &ODOMETER_COLS[..2]
    };
    crate::parse_columns(text, path, cols)?
        .into_iter()
        .map(|(line, v)| match v[..] {
            [t_s, speed_mps] => Ok(OdometerRow {
                t_s,
                speed_mps,
                sigma_mps: None,
            }),
            [t_s, speed_mps, s] if s > 0.0 => Ok(OdometerRow {
                t_s,
                speed_mps,
                sigma_mps: Some(s),
            }),
            _ => Err(err(path, Some(line), "sigma_mps must be positive")),
        })
        .collect()
}

/// `odometer.csv` as text (`sigma_mps` when every row has one; times to
/// the microsecond: a CAN bus delivers two frames within a millisecond).
pub fn odometer_text(rows: &[OdometerRow]) -> String {
    let sigma = !rows.is_empty() && rows.iter().all(|r| r.sigma_mps.is_some());
    let mut s = ODOMETER_COLS[..if sigma { 3 } else { 2 }].join(",");
    s.push('\n');
    for r in rows {
        let _ = match r.sigma_mps.filter(|_| sigma) {
            Some(sg) => writeln!(s, "{:.6},{:.4},{sg}", r.t_s, r.speed_mps),
            None => writeln!(s, "{:.6},{:.4}", r.t_s, r.speed_mps),
        };
    }
    s
}

/// `truth.csv` as text.
pub fn truth_text(rows: &[TruthRow]) -> String {
    let mut s = TRUTH_COLS.join(",");
    s.push('\n');
    for r in rows {
        let [n, e, d] = r.p_n_m;
        let [vn, ve, vd] = r.v_n_mps;
        let [ro, pi, he] = r.euler_deg;
        let _ = writeln!(
            s,
            "{:.3},{n:.4},{e:.4},{d:.4},{vn:.5},{ve:.5},{vd:.5},{ro:.6},{pi:.6},{he:.6}",
            r.t_s
        );
    }
    s
}

/// The moving-base lines of `meta.toml`: (`[site]` keys, `[base]` keys,
/// the `[gnss]` table).
pub fn meta_lines(m: &MovingBase) -> (String, String, String) {
    let site = format!("longitude_deg = {:?}\n", m.longitude_deg);
    let base = match m.heading_unknown {
        true => "moving = true\nheading_known = false\n".to_string(),
        false => "moving = true\n".to_string(),
    };
    let gnss = m.gnss_meta.map_or(String::new(), |g| {
        let [x, y, z] = g.antenna_b_m;
        format!(
            "\n[gnss]\nantenna_b_m = [{x:?}, {y:?}, {z:?}]\nrate_hz = {:?}\n",
            g.rate_hz
        )
    });
    (site, base, gnss)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn position_only_fixes_read_write_and_reach_the_filter_without_velocity() {
        let p = Path::new("walk/gnss.csv");
        let text = "t_s,lat_deg,lon_deg,height_m,sigma_h_m,sigma_v_m\n1.0,-33.9,151.2,40.0,2.5,4.0\n2.0,-33.9,151.2,40.5,0.01,0.02\n";
        let rows = parse_gnss(text, p).unwrap();
        assert!(rows.iter().all(|r| !r.has_velocity()));
        assert_eq!(parse_gnss(&gnss_text(&rows), p).unwrap().len(), 2);
        assert!(gnss_text(&rows).starts_with("t_s,lat_deg,lon_deg,height_m,sigma_h_m,sigma_v_m\n"));
        let f = rows[1].to_fix();
        assert!(!f.has_velocity());
        assert_eq!((f.sigma_h_mm, f.sigma_v_mm), (10, 20));
        // A velocity sigma below a mm/s still says "velocity".
        let with = GnssRow {
            v_n_mps: [1.0, 0.0, 0.0],
            sigma_vel_mps: 1e-4,
            ..rows[0]
        };
        assert!(with.to_fix().has_velocity());
    }

    #[test]
    fn the_solution_type_column_reads_and_writes_back() {
        let p = Path::new("walk/gnss.csv");
        let text = "t_s,lat_deg,lon_deg,height_m,sigma_h_m,sigma_v_m,quality\n1.0,40.1,-105.1,1580.0,0.014,0.01,1\n1.25,40.1,-105.1,1580.0,0.014,0.01,2\n";
        let rows = parse_gnss(text, p).unwrap();
        assert_eq!(rows[0].quality, Some(Solution::RtkFixed));
        assert_eq!(rows[1].quality, Some(Solution::RtkFloat));
        let back = parse_gnss(&gnss_text(&rows), p).unwrap();
        assert_eq!(
            back.iter().map(|r| r.quality).collect::<Vec<_>>(),
            rows.iter().map(|r| r.quality).collect::<Vec<_>>()
        );
        let bad = text.replace(",2\n", ",7\n");
        let e = parse_gnss(&bad, p).unwrap_err().to_string();
        assert!(e.contains("gnss.csv:3") && e.contains("quality"), "{e}");
    }

    #[test]
    fn bad_fixes_are_refused_naming_the_file_and_line() {
        let p = Path::new("walk/gnss.csv");
        let head =
            "t_s,lat_deg,lon_deg,height_m,vn_mps,ve_mps,vd_mps,sigma_h_m,sigma_v_m,sigma_vel_mps\n";
        let ok = "1.0,30.5,114.3,20,0,0,0,1.5,3,0.05\n";
        for (bad, why) in [
            (
                "2.0,30.5,114.3,20,0,0,0,0,3,0.05\n",
                "sigmas must be positive",
            ),
            (
                "2.0,30.5,114.3,20,0,0,0,-1,3,0.05\n",
                "sigmas must be positive",
            ),
            ("2.0,30.5,114.3,20,0,0,0,NaN,3,0.05\n", "not finite"),
            ("2.0,30.5,114.3,20,0,0,0,1.5,3,0\n", "velocity"),
            ("2.0,95.0,114.3,20,0,0,0,1.5,3,0.05\n", "out of range"),
            ("0.5,30.5,114.3,20,0,0,0,1.5,3,0.05\n", ""),
        ] {
            let e = parse_gnss(&format!("{head}{ok}{bad}"), p).unwrap_err();
            assert_eq!(e.line, Some(3), "{bad}: {e}");
            assert!(
                e.to_string().contains("walk/gnss.csv") && e.to_string().contains(why),
                "{e}"
            );
        }
        let partial = "t_s,lat_deg,lon_deg,height_m,vn_mps,ve_mps,vd_mps,sigma_h_m,sigma_v_m\n";
        let e = parse_gnss(&format!("{partial}1.0,30.5,114.3,20,0,0,0,1.5,3\n"), p).unwrap_err();
        assert!(e.to_string().contains("together"), "{e}");
    }

    fn row(t_s: f64, x: f64, heading: f64) -> TruthRow {
        TruthRow {
            t_s,
            p_n_m: [x, -x, 0.5 * x],
            v_n_mps: [1.0, 2.0, 3.0 * x],
            euler_deg: [-179.0 + x, 0.0, heading],
        }
    }

    #[test]
    fn the_truth_between_rows_is_interpolated_and_a_rows_time_gives_the_row() {
        let rows = [row(10.0, 0.0, 359.0), row(10.1, 2.0, 3.0)];
        assert_eq!(truth_at(&rows, 10.1), Some(rows[1]));
        let m = truth_at(&rows, 10.075).unwrap();
        // Three quarters of the way: x = 1.5; heading 359 -> 3 the short
        // way (4 deg): 2 deg; roll -179 -> -177: -177.5.
        assert!((m.p_n_m[0] - 1.5).abs() < 1e-12 && (m.p_n_m[1] + 1.5).abs() < 1e-12);
        assert!((m.v_n_mps[2] - 4.5).abs() < 1e-12);
        assert!((m.euler_deg[2] - 2.0).abs() < 1e-9, "{:?}", m.euler_deg);
        assert!((m.euler_deg[0] + 177.5).abs() < 1e-9, "{:?}", m.euler_deg);
    }

    #[test]
    fn no_truth_outside_the_rows_and_a_file_with_no_time_in_common_is_named() {
        let rows = [row(10.0, 0.0, 0.0), row(11.0, 1.0, 0.0)];
        assert!(truth_at(&rows, 9.99).is_none());
        assert!(truth_at(&rows, 11.01).is_none());
        let p = Path::new("run/truth.csv");
        assert_eq!(truth_overlap(&rows, 10.0, 11.0, p), Ok([10.0, 11.0]));
        // A truth that ends before the log: the overlap.
        assert_eq!(truth_overlap(&rows, 9.0, 14.0, p), Ok([10.0, 11.0]));
        let e = truth_overlap(&rows, 11.5, 14.0, p).unwrap_err().to_string();
        assert!(e.contains("run/truth.csv") && e.contains("10.000 s"), "{e}");
    }
}

#[cfg(test)]
mod odometer_tests {
    use super::*;

    #[test]
    fn odometer_rows_round_trip_with_and_without_sigma() {
        let p = Path::new("drive/odometer.csv");
        let rows = parse_odometer("t_s,speed_mps\n0.010,12.5\n0.020,12.6\n", p).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1].sigma_mps, None);
        assert_eq!(parse_odometer(&odometer_text(&rows), p).unwrap(), rows);
        let with = parse_odometer("t_s,speed_mps,sigma_mps\n0.010,12.5,0.1\n", p).unwrap();
        assert_eq!(with[0].sigma_mps, Some(0.1));
        assert_eq!(parse_odometer(&odometer_text(&with), p).unwrap(), with);
        let e = parse_odometer("t_s,speed_mps,sigma_mps\n0.010,12.5,0\n", p).unwrap_err();
        assert!(e.to_string().contains("odometer.csv:2"), "{e}");
        let e = parse_odometer("t_s,speed_mps\n0.020,1\n0.010,1\n", p).unwrap_err();
        assert!(e.to_string().contains("odometer.csv:3"), "{e}");
    }
}

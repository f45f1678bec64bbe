//! RTKLIB solution files (`.pos`): `%` header lines, the last of which
//! names the columns; one line per epoch, whitespace-separated; time as
//! `YYYY/MM/DD hh:mm:ss.sss` in GPST (RTKLIB's default); position as
//! latitude, longitude (deg) and height (m); `Q` the solution type; `sdn,
//! sde, sdu` the 1-sigma per axis; optional velocity `vn, ve, vu` with
//! `sdvn, sdve, sdvu`.

use anyhow::{anyhow, bail, Result};
use recording::moving::{GnssRow, Solution};
use std::path::Path;

/// One epoch, GPST seconds on the Unix-epoch scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PosEpoch {
    /// GPST, s (Unix-epoch scale).
    pub t_gpst: f64,
    /// The fix (its `t_s` set by the caller).
    pub row: GnssRow,
}

/// Seconds from 1970-01-01 of a calendar date and time (the proleptic
/// Gregorian calendar; no leap seconds: GPST is continuous).
pub fn calendar_s(y: i64, mo: i64, d: i64, h: i64, mi: i64, s: f64) -> f64 {
    let days = crate::ubx::days_from_civil(y, mo, d);
    (days * 86_400 + h * 3600 + mi * 60) as f64 + s
}

fn time_of(date: &str, clock: &str) -> Option<f64> {
    let d: Vec<i64> = date
        .split('/')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    let c: Vec<&str> = clock.split(':').collect();
    let (&[y, mo, dd], &[h, mi, s]) = (d.as_slice(), c.as_slice()) else {
        return None;
    };
    let (h, mi, s) = (h.parse().ok()?, mi.parse().ok()?, s.parse::<f64>().ok()?);
    ((1..=12).contains(&mo) && (1..=31).contains(&dd) && s.is_finite())
        .then(|| calendar_s(y, mo, dd, h, mi, s))
}

/// Reads a `.pos` file; `geoid_m` is added to every height (0 for
/// ellipsoidal heights; the geoid's height above the ellipsoid when the
/// file holds heights above mean sea level).
///
/// # Errors
/// Unreadable; no column header; times not GPST; a line with missing or
/// non-numeric fields, a Q outside 1-6, non-positive sigmas, time not
/// increasing: each naming file and line.
pub fn read_pos(path: &Path, geoid_m: f64) -> Result<Vec<PosEpoch>> {
    let text = std::fs::read_to_string(path).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    parse_pos(&text, &path.display().to_string(), geoid_m)
}

/// [`read_pos`] on text (`what` names it in errors).
///
/// # Errors
/// As [`read_pos`].
pub fn parse_pos(text: &str, what: &str, geoid_m: f64) -> Result<Vec<PosEpoch>> {
    let mut names: Vec<String> = vec![];
    let mut out: Vec<PosEpoch> = vec![];
    for (k, line) in text.lines().enumerate() {
        let n = k + 1;
        if let Some(h) = line.strip_prefix('%') {
            if h.contains("latitude(deg)") {
                names = h.split_whitespace().map(str::to_string).collect();
                if names.first().map(String::as_str) != Some("GPST") {
                    bail!("{what}:{n}: times are {:?}: only GPST (RTKLIB's default time system) is read", names.first());
                }
                // The time takes two fields (date, clock) but one name.
                names.insert(1, "clock".into());
            }
            continue;
        }
        if line.trim().is_empty() {
            continue;
        }
        if names.is_empty() {
            bail!(
                "{what}:{n}: a solution line before the column header (% GPST latitude(deg) ...)"
            );
        }
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() < names.len() {
            bail!(
                "{what}:{n}: {} fields, the header names {}",
                f.len(),
                names.len()
            );
        }
        let num = |name: &str| -> Result<Option<f64>> {
            let Some(i) = names.iter().position(|c| c == name) else {
                return Ok(None);
            };
            let s = f.get(i).copied().unwrap_or("");
            s.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .map(Some)
                .ok_or_else(|| anyhow!("{what}:{n}: {name} is {s:?}, not a finite number"))
        };
        let need = |name: &str| {
            num(name)?.ok_or_else(|| anyhow!("{what}: no column {name} in the header"))
        };
        let t = time_of(
            f.first().copied().unwrap_or(""),
            f.get(1).copied().unwrap_or(""),
        )
        .ok_or_else(|| anyhow!("{what}:{n}: the time is not YYYY/MM/DD hh:mm:ss.sss"))?;
        if let Some(p) = out.last() {
            if t <= p.t_gpst {
                bail!("{what}:{n}: time does not increase");
            }
        }
        let q = need("Q")?;
        let quality = Solution::from_q(q as u8)
            .filter(|_| q.fract() == 0.0)
            .ok_or_else(|| anyhow!("{what}:{n}: Q = {q}: RTKLIB's 1 to 6"))?;
        let (sdn, sde, sdu) = (need("sdn(m)")?, need("sde(m)")?, need("sdu(m)")?);
        if !(sdn > 0.0 && sde > 0.0 && sdu > 0.0) {
            bail!("{what}:{n}: sigmas must be positive (sdn {sdn}, sde {sde}, sdu {sdu})");
        }
        let vel = match (num("vn(m/s)")?, num("ve(m/s)")?, num("vu(m/s)")?) {
            (Some(vn), Some(ve), Some(vu)) => {
                let s = [need("sdvn")?, need("sdve")?, need("sdvu")?];
                if s.iter().any(|x| *x <= 0.0) {
                    bail!("{what}:{n}: velocity sigmas must be positive");
                }
                Some((
                    [vn, ve, -vu],
                    (s.iter().map(|x| x * x).sum::<f64>() / 3.0).sqrt(),
                ))
            }
            _ => None,
        };
        out.push(PosEpoch {
            t_gpst: t,
            row: GnssRow {
                t_s: 0.0,
                lat_deg: need("latitude(deg)")?,
                lon_deg: need("longitude(deg)")?,
                height_m: need("height(m)")? + geoid_m,
                v_n_mps: vel.map_or([f64::NAN; 3], |v| v.0),
                sigma_h_m: ((sdn * sdn + sde * sde) / 2.0).sqrt(),
                sigma_v_m: sdu,
                sigma_vel_mps: vel.map_or(f64::NAN, |v| v.1),
                quality: Some(quality),
            },
        });
    }
    if out.is_empty() {
        bail!("{what}: no solution lines");
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn calendar_seconds_match_the_unix_epoch() {
        // 2025-08-28 17:30:39 is 1756402239 s after 1970-01-01 (date -d).
        assert_eq!(calendar_s(2025, 8, 28, 17, 30, 39.0), 1_756_402_239.0);
        assert_eq!(calendar_s(2000, 3, 1, 0, 0, 0.0), 951_868_800.0);
    }

    #[test]
    fn reads_the_walks_layout_and_refuses_bad_lines() {
        let head = "% GPST latitude(deg) longitude(deg) height(m) Q ns sdn(m) sde(m) sdu(m) sdne(m) sdeu(m) sdun(m) age(s) ratio vn(m/s) ve(m/s) vu(m/s) sdvn sdve sdvu sdvne sdveu sdvun\n";
        let l1 = "2025/08/28 17:30:39.749 40.0966916 -105.1471665 1601.4350000 1 25 0.0098995 0.0098995 0.0100000 0 0 0 0 0 0.001 -0.002 0.027 0.0494975 0.0494975 0.0494975 0 0 0\n";
        let l2 = l1.replace("39.749", "39.999").replace(" 1 25 ", " 2 25 ");
        let e = parse_pos(&format!("{head}{l1}{l2}"), "s.pos", -21.39).unwrap();
        assert_eq!(e.len(), 2);
        assert!((e[0].row.height_m - (1601.435 - 21.39)).abs() < 1e-9);
        assert_eq!(e[0].row.v_n_mps[2], -0.027);
        assert_eq!(e[1].row.quality, Some(Solution::RtkFloat));
        assert!((e[1].t_gpst - e[0].t_gpst - 0.25).abs() < 1e-9);
        let bad = format!("{head}{l1}{}", l2.replace(" 2 25 ", " 9 25 "));
        assert!(parse_pos(&bad, "s.pos", 0.0)
            .unwrap_err()
            .to_string()
            .contains("s.pos:3"));
        let bad = format!(
            "{head}{l1}{}",
            l2.replace("0.0098995 0.0098995", "0 0.0098995")
        );
        assert!(parse_pos(&bad, "s.pos", 0.0)
            .unwrap_err()
            .to_string()
            .contains("sigmas"));
        let bad = format!("{head}{l1}{l1}");
        assert!(parse_pos(&bad, "s.pos", 0.0)
            .unwrap_err()
            .to_string()
            .contains("increase"));
        assert!(parse_pos(&head.replace("GPST", "UTC"), "s.pos", 0.0).is_err());
    }
}

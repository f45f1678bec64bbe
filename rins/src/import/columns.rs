//! An IMU CSV described by a column map (`rins-columns/1`, TOML): which
//! column holds what, in which unit, on which clock. Reads the file,
//! drops a log's cut first and last lines and, when the logger polls
//! faster than the sensor (its rows come faster than the sensor's rate),
//! the rows it repeats (both counted); each distinct sample keeps its
//! first sighting's time.
//!
//! ```toml
//! format = "rins-columns/1"
//! header = false        # true: the first line names the columns
//! delimiter = ","
//! rate_hz = 100.0       # the sensor's nominal output rate
//! [columns]             # 0-based indices (header = false) or names
//! time = 6
//! gyro = [3, 4, 5]
//! accel = [0, 1, 2]
//! [units]
//! time = "ms"           # "s", "ms" or "us"
//! gyro = "dps"          # "dps" or "radps"
//! accel = "g"           # "g" or "mps2"
//! [time]
//! source = "tag"        # "tag": the logger's clock through an RTKLIB .tag file
//!                       # "gpst": the time column is GPST s (Unix-epoch scale)
//!                       # "log": the time column on the logger's own clock
//!                       # "rate": no time column: sample k at k / rate_hz
//! regular = true        # the sensor samples on its own regular clock
//! ```
//!
//! `rins import rtklib` takes "tag" and "gpst"; `rins import csv` (an
//! IMU-only log) takes "log" and "rate".

use anyhow::{anyhow, bail, Result};
use std::path::Path;

/// Where a row's time comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeSource {
    /// The logger's own clock, put on GPST through an RTKLIB tag file.
    Tag,
    /// The time column is already GPST seconds (Unix-epoch scale).
    Gpst,
    /// The time column on the logger's own clock (its first row is 0).
    Log,
    /// No time column: sample `k` at `k / rate_hz` (every row a sample).
    Rate,
}

/// A parsed column map.
#[derive(Clone, Debug, PartialEq)]
pub struct ColumnMap {
    /// The first line names the columns.
    pub header: bool,
    /// The field separator.
    pub delimiter: char,
    /// The sensor's nominal output rate, Hz.
    pub rate_hz: f64,
    /// Column of the time, of the gyros (x, y, z), of the accelerometers.
    time: Option<Col>,
    gyro: [Col; 3],
    accel: [Col; 3],
    /// Factors to s, rad/s, m/s^2.
    time_s: f64,
    gyro_si: f64,
    accel_si: f64,
    /// Where times come from.
    pub source: TimeSource,
    /// The sensor samples on its own regular clock (`[time] regular =
    /// true`): the distinct samples' first sightings are fitted to it.
    pub regular: bool,
}

#[derive(Clone, Debug, PartialEq)]
enum Col {
    Index(usize),
    Name(String),
}

/// One distinct IMU sample as read: the time column (in s, on its own
/// clock), the end of its first sighting in the file (bytes, `\n` line
/// ends counted as `line_end_bytes`), gyro (rad/s) and accelerometer
/// (m/s^2) in the sensor's axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawSample {
    /// Time column, s.
    pub stamp_s: f64,
    /// The file line of its first sighting (1-based).
    pub line: usize,
    /// Gyro, rad/s, sensor axes.
    pub gyro_radps: [f64; 3],
    /// Accelerometer, m/s^2, sensor axes.
    pub accel_mps2: [f64; 3],
}

/// How many times the sensor's nominal rate a log's rows must come at
/// for a repeated row to be a stale read (a logger polling faster than
/// its sensor), not a sample: clocks differ by far less than this.
pub const OVERSAMPLED: f64 = 1.1;

/// What reading the file counted.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImuCsv {
    /// The distinct samples.
    pub samples: Vec<RawSample>,
    /// Every row's time column (s) and the byte where it ends, counting
    /// line ends as stored and as CRLF (for the tag file's receive
    /// times), repeats included.
    pub rows: Vec<(f64, u64, u64)>,
    /// Rows that repeated the previous row's six values in a log that
    /// polls faster than its sensor (dropped: stale reads).
    pub repeats: usize,
    /// A cut first line (logging began mid-line): dropped.
    pub cut_first: bool,
    /// A cut last line (no line end): dropped.
    pub cut_last: bool,
    /// The file's length counting each line end as one byte, and as two.
    pub len_lf: u64,
    /// See `len_lf`.
    pub len_crlf: u64,
}

fn col(v: &toml::Value, what: &str, header: bool) -> Result<Col> {
    match (v.as_integer(), v.as_str()) {
        (Some(i), _) if i >= 0 && !header => Ok(Col::Index(i as usize)),
        (_, Some(s)) if header => Ok(Col::Name(s.to_string())),
        _ if header => bail!("{what} must be a column name (header = true)"),
        _ => bail!("{what} must be a 0-based column index (header = false)"),
    }
}

fn triple(t: &toml::Table, key: &str, header: bool) -> Result<[Col; 3]> {
    let a = t
        .get(key)
        .and_then(|v| v.as_array())
        .filter(|a| a.len() == 3)
        .ok_or_else(|| anyhow!("columns.{key} must be three columns (x, y, z)"))?;
    let c = |i: usize| {
        a.get(i)
            .ok_or_else(|| anyhow!("columns.{key}"))
            .and_then(|v| col(v, &format!("columns.{key}[{i}]"), header))
    };
    Ok([c(0)?, c(1)?, c(2)?])
}

impl ColumnMap {
    /// Reads a column map file.
    ///
    /// # Errors
    /// Unreadable, or what [`Self::parse`] refuses.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| anyhow!("{}: {e}", path.display()))?;
        Self::parse(&text).map_err(|e| anyhow!("{}: {e}", path.display()))
    }

    /// Parses a column map's text.
    ///
    /// # Errors
    /// Another format, a missing or mistyped key, an unknown unit.
    pub fn parse(text: &str) -> Result<Self> {
        let t: toml::Table = text.parse().map_err(|e| anyhow!("{e}"))?;
        if t.get("format").and_then(|v| v.as_str()) != Some("rins-columns/1") {
            bail!("format must be \"rins-columns/1\"");
        }
        let header = t.get("header").and_then(|v| v.as_bool()).unwrap_or(false);
        let delimiter = match t.get("delimiter").map(|v| v.as_str()) {
            None => ',',
            Some(Some(d)) if d.chars().count() == 1 => d.chars().next().unwrap_or(','),
            Some(_) => bail!("delimiter must be one character"),
        };
        let rate_hz = t
            .get("rate_hz")
            .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
            .filter(|r| *r > 0.0 && r.is_finite())
            .ok_or_else(|| {
                anyhow!("rate_hz (the sensor's nominal rate, Hz) is required and > 0")
            })?;
        let sub = |name: &str| -> Result<&toml::Table> {
            t.get(name)
                .and_then(|v| v.as_table())
                .ok_or_else(|| anyhow!("missing table [{name}]"))
        };
        let cols = sub("columns")?;
        let units = sub("units")?;
        let unit = |key: &str, opts: &[(&str, f64)]| -> Result<f64> {
            let u = units
                .get(key)
                .and_then(|v| v.as_str())
                .ok_or_else(|| anyhow!("units.{key} is required"))?;
            opts.iter()
                .find(|(n, _)| *n == u)
                .map(|(_, f)| *f)
                .ok_or_else(|| {
                    let names: Vec<&str> = opts.iter().map(|(n, _)| *n).collect();
                    anyhow!("units.{key} = {u:?}: one of {}", names.join(", "))
                })
        };
        let regular = match sub("time")?.get("regular") {
            None => false,
            Some(v) => v
                .as_bool()
                .ok_or_else(|| anyhow!("time.regular must be true or false"))?,
        };
        let source = match sub("time")?.get("source").and_then(|v| v.as_str()) {
            Some("tag") => TimeSource::Tag,
            Some("gpst") => TimeSource::Gpst,
            Some("log") => TimeSource::Log,
            Some("rate") => TimeSource::Rate,
            other => bail!("time.source = {other:?}: \"tag\", \"gpst\", \"log\" or \"rate\""),
        };
        let time = match (cols.get("time"), source) {
            (Some(_), TimeSource::Rate) => {
                bail!(
                    "columns.time with time.source = \"rate\": drop one (\"log\" reads the column)"
                )
            }
            (None, TimeSource::Rate) => None,
            (Some(v), _) => Some(col(v, "columns.time", header)?),
            (None, _) => bail!("columns.time is required (or time.source = \"rate\")"),
        };
        Ok(Self {
            header,
            delimiter,
            rate_hz,
            time,
            gyro: triple(cols, "gyro", header)?,
            accel: triple(cols, "accel", header)?,
            time_s: match source {
                TimeSource::Rate => 1.0,
                _ => unit("time", &[("s", 1.0), ("ms", 1e-3), ("us", 1e-6)])?,
            },
            gyro_si: unit(
                "gyro",
                &[("dps", core::f64::consts::PI / 180.0), ("radps", 1.0)],
            )?,
            accel_si: unit("accel", &[("g", hal_sim::sensor::G0), ("mps2", 1.0)])?,
            source,
            regular,
        })
    }

    /// Reads the IMU CSV `path` with this map.
    ///
    /// # Errors
    /// Unreadable; a column the map names that the file lacks; a row with
    /// the wrong number of fields or a non-number (other than a cut first
    /// or last line); time going backwards: each naming file and line.
    pub fn read_csv(&self, path: &Path) -> Result<ImuCsv> {
        let text = std::fs::read_to_string(path).map_err(|e| anyhow!("{}: {e}", path.display()))?;
        self.parse_csv(&text, &path.display().to_string())
    }

    /// [`Self::read_csv`] on text (`what` names it in errors).
    ///
    /// # Errors
    /// As [`Self::read_csv`].
    pub fn parse_csv(&self, text: &str, what: &str) -> Result<ImuCsv> {
        let mut out = ImuCsv::default();
        let lines: Vec<&str> = text.split_inclusive('\n').collect();
        let mut names: Vec<String> = vec![];
        let mut width = None;
        let (mut lf, mut crlf) = (0u64, 0u64);
        let mut last: Option<[f64; 6]> = None;
        let mut repeated = vec![];
        let n_lines = lines.len();
        for (k, raw) in lines.iter().enumerate() {
            let ends = raw.ends_with('\n');
            let body = raw.trim_end_matches(['\n', '\r']);
            let had_cr = raw.ends_with("\r\n");
            let line = k + 1;
            lf += raw.len() as u64;
            crlf += raw.len() as u64 + u64::from(ends && !had_cr);
            if k == 0 && self.header {
                names = body
                    .split(self.delimiter)
                    .map(|s| s.trim().to_string())
                    .collect();
                continue;
            }
            if body.trim().is_empty() {
                continue;
            }
            let fields: Vec<&str> = body.split(self.delimiter).map(str::trim).collect();
            if !ends && k + 1 == n_lines {
                out.cut_last = true;
                continue;
            }
            let w = *width.get_or_insert_with(|| self.width(&names).max(fields.len()));
            if fields.len() != w {
                if out.rows.is_empty() && out.samples.is_empty() && !out.cut_first {
                    out.cut_first = true;
                    width = None;
                    continue;
                }
                bail!("{what}:{line}: {} fields, expected {w}", fields.len());
            }
            // `role`: the column map's key for it (e.g. "accel z").
            let get = |c: &Col, role: &str| -> Result<f64> {
                let (i, named) = match c {
                    Col::Index(i) => (*i, String::new()),
                    Col::Name(n) => (
                        names.iter().position(|x| x == n).ok_or_else(|| {
                            anyhow!("{what}: no column named {n:?} in the header ({role})")
                        })?,
                        format!(" {n:?}"),
                    ),
                };
                let s = fields.get(i).ok_or_else(|| {
                    anyhow!(
                        "{what}:{line}: no column {i}{named} ({role} in the column map; the row has {} fields)",
                        fields.len()
                    )
                })?;
                s.parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| {
                        anyhow!("{what}:{line}: column {i}{named} ({role} in the column map) is {s:?}, not a finite number")
                    })
            };
            let stamp = match &self.time {
                Some(c) => get(c, "time")? * self.time_s,
                None => (out.rows.len()) as f64 / self.rate_hz,
            };
            let mut v = [0.0; 6];
            let roles = [
                "gyro x", "gyro y", "gyro z", "accel x", "accel y", "accel z",
            ];
            for ((slot, c), role) in v
                .iter_mut()
                .zip(self.gyro.iter().chain(&self.accel))
                .zip(roles)
            {
                *slot = get(c, role)?;
            }
            // A stamp shared with the row before is a burst delivered at
            // once (put back on the sensor's clock by the import); one
            // that goes back is refused.
            if let Some(&(prev, _, _)) = out.rows.last() {
                if stamp < prev {
                    bail!("{what}:{line}: time {stamp} s goes back (previous {prev} s)");
                }
            }
            out.rows.push((stamp, lf, crlf));
            repeated.push(last == Some(v));
            last = Some(v);
            let [gx, gy, gz, ax, ay, az] = v;
            out.samples.push(RawSample {
                stamp_s: stamp,
                line,
                gyro_radps: [gx, gy, gz].map(|x| x * self.gyro_si),
                accel_mps2: [ax, ay, az].map(|x| x * self.accel_si),
            });
        }
        out.len_lf = lf;
        out.len_crlf = crlf;
        self.drop_stale(&mut out, &repeated);
        if out.samples.len() < 2 {
            bail!("{what}: fewer than two IMU rows");
        }
        Ok(out)
    }

    /// Drops the rows that repeat the one before (`repeated`, a flag a
    /// sample) when the log has more rows than the sensor makes samples
    /// (more than [`OVERSAMPLED`] times `rate_hz` over its stamps): a
    /// logger polling faster than its sensor reads a sample again. A log
    /// at the sensor's rate keeps every row (a quantised still sensor
    /// repeats itself), as one without a time column does.
    fn drop_stale(&self, out: &mut ImuCsv, repeated: &[bool]) {
        let span = match (out.rows.first(), out.rows.last()) {
            (Some(a), Some(b)) => b.0 - a.0,
            _ => 0.0,
        };
        let rows = out.rows.len().saturating_sub(1) as f64;
        if self.time.is_none() || rows <= OVERSAMPLED * self.rate_hz * span {
            return;
        }
        let mut flags = repeated.iter();
        out.samples
            .retain(|_| !flags.next().copied().unwrap_or(false));
        out.repeats = repeated.iter().filter(|r| **r).count();
    }

    /// The fields a row must have: past the highest index the map names
    /// (the header's count when it names columns).
    fn width(&self, names: &[String]) -> usize {
        if self.header {
            return names.len();
        }
        self.time
            .iter()
            .chain(&self.gyro)
            .chain(&self.accel)
            .filter_map(|c| match c {
                Col::Index(i) => Some(i + 1),
                Col::Name(_) => None,
            })
            .max()
            .unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAP: &str = "format = \"rins-columns/1\"\nrate_hz = 100\n[columns]\ntime = 6\ngyro = [3, 4, 5]\naccel = [0, 1, 2]\n[units]\ntime = \"ms\"\ngyro = \"dps\"\naccel = \"g\"\n[time]\nsource = \"tag\"\n";

    #[test]
    fn cut_edges_and_repeats_are_dropped_and_counted() {
        let m = ColumnMap::parse(MAP).unwrap();
        let text =
            "1.0,0.5,3\n0,0,1,0.1,0,0,100\n0,0,1,0.1,0,0,106\n0,0,1,0.2,0,0,112\n0,0,1,0.2,0,";
        let r = m.parse_csv(text, "imu.csv").unwrap();
        assert!(r.cut_first && r.cut_last);
        assert_eq!((r.samples.len(), r.repeats, r.rows.len()), (2, 1, 3));
        assert_eq!(r.samples[1].stamp_s, 0.112);
        assert!((r.samples[1].gyro_radps[0] - 0.2f64.to_radians()).abs() < 1e-15);
        assert_eq!(r.samples[0].accel_mps2[2], hal_sim::sensor::G0);
        // Byte ends with CRLF line ends: the cut first line is 10 + 1.
        assert_eq!((r.rows[0].1, r.rows[0].2), (10 + 18, 11 + 19));
    }

    #[test]
    fn a_log_at_the_sensors_rate_keeps_a_repeated_row_as_a_sample() {
        // 10 ms rows of a 100 Hz sensor: the repeat at 110 ms is a
        // quantised sample, not a stale read (the real ADIS16405 log has
        // one); the same rows 6 ms apart are a logger polling too fast.
        let m = ColumnMap::parse(MAP).unwrap();
        let at = |dt: u32| {
            (0..4)
                .map(|k| format!("0,0,1,{},0,0,{}\n", [1, 2, 2, 3][k], 100 + dt * k as u32))
                .collect::<String>()
        };
        let r = m.parse_csv(&at(10), "imu.csv").unwrap();
        assert_eq!((r.samples.len(), r.repeats), (4, 0));
        let r = m.parse_csv(&at(6), "imu.csv").unwrap();
        assert_eq!((r.samples.len(), r.repeats), (3, 1));
        assert!((r.samples[2].stamp_s - 0.118).abs() < 1e-12);
    }

    #[test]
    fn a_map_that_does_not_fit_the_file_names_file_and_line() {
        let m = ColumnMap::parse(MAP).unwrap();
        let e = m
            .parse_csv("0,0,1,0,0,0,1\n0,0,1,0,0\n0,0,1,0,0,0,3\n", "imu.csv")
            .unwrap_err();
        assert!(e.to_string().contains("imu.csv:2"), "{e}");
        let e = m
            .parse_csv("0,0,1,0,0,0,5\n0,0,x,0,0,0,6\n", "imu.csv")
            .unwrap_err();
        assert!(
            e.to_string().contains("imu.csv:2") && e.to_string().contains("\"x\""),
            "{e}"
        );
        // The column's role in the map is named, not only its index.
        let role = ["gyro", "accel"].iter().any(|t| {
            e.to_string().contains(&format!("{t} ")) && e.to_string().contains("in the column map")
        });
        assert!(role, "{e}");
        let e = m
            .parse_csv("0,0,1,0,0,0,5\n0,0,1,0,0,1,4\n", "imu.csv")
            .unwrap_err();
        assert!(e.to_string().contains("goes back"), "{e}");
        let named = MAP
            .replace("time = 6", "time = \"t\"")
            .replace("header", "h");
        let e = ColumnMap::parse(&named).unwrap_err();
        assert!(e.to_string().contains("columns.time"), "{e}");
        let e = ColumnMap::parse(&MAP.replace("\"dps\"", "\"rpm\"")).unwrap_err();
        assert!(e.to_string().contains("units.gyro"), "{e}");
    }
}

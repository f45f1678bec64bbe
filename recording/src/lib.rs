//! Reader and writer for the recording format `rins-recording/1`
//! (`shared/spec/recording-v1.md`): a directory with `meta.toml`, `imu.csv`
//! and `table.csv`.
//!
//! Readers find columns by header name (any order, extra columns ignored),
//! ignore unknown TOML keys, and refuse non-finite numbers, rows with the
//! wrong number of fields, time going backwards and missing files or keys
//! with an error that names the file and line (or key). Nothing here panics
//! on bad input.
//!
//! The writer prints every number with Rust's shortest round-trip
//! representation, so write -> read -> write gives identical files.
//!
//! A crate of its own: boards, the simulator, the host tools and the tests
//! all read and write this format. [`moving`]: the moving-base keys and
//! files (`gnss.csv`, `truth.csv`); [`track`]: the table's motion from the
//! recorded encoder reads.

pub mod clock;
pub mod figures;
pub mod moving;
pub mod plausible;
pub mod relabel;
pub mod track;

use core_nav::table::Axis;
use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};

/// Appends formatted text to a `String` (which cannot fail, unlike `write!`).
macro_rules! out {
    ($s:expr, $($arg:tt)*) => { $s.push_str(&format!($($arg)*)) };
}

/// The format tag in `meta.toml`.
pub const FORMAT: &str = "rins-recording/1";

/// Whether IMU values are instantaneous or averages over the interval.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SampleKind {
    /// The value at `t_s` (the default).
    #[default]
    Instantaneous,
    /// The mean over the interval ending at `t_s` (`[imu] sample = "average"`).
    Average,
}

/// `meta.toml`: where, what, how the table is mounted.
#[derive(Clone, Debug, PartialEq)]
pub struct Meta {
    /// Free text.
    pub description: Option<String>,
    /// Geodetic latitude, deg.
    pub latitude_deg: f64,
    /// Height above the WGS-84 ellipsoid, m.
    pub height_m: f64,
    /// Gravity at the site, m/s^2 (else WGS-84 normal gravity).
    pub gravity_mps2: Option<f64>,
    /// Base attitude in n (ZYX Euler), deg.
    pub heading_deg: f64,
    /// See `heading_deg`.
    pub pitch_deg: f64,
    /// See `heading_deg`.
    pub roll_deg: f64,
    /// `[base] heading_sigma_deg`: the stated heading's 1-sigma, deg
    /// (`None`: unknown, not zero).
    pub heading_sigma_deg: Option<f64>,
    /// `[base] level_sigma_deg`: the stated roll's and pitch's 1-sigma,
    /// deg (`None`: unknown).
    pub level_sigma_deg: Option<f64>,
    /// IMU model, free text.
    pub imu_model: Option<String>,
    /// IMU sample rate, Hz.
    pub imu_rate_hz: f64,
    /// Instantaneous or averaged samples.
    pub imu_sample: SampleKind,
    /// Table axis.
    pub axis: Axis,
    /// Encoder read rate, Hz.
    pub encoder_rate_hz: f64,
    /// What `table.csv`'s angle is: measured, commanded, or no table.
    pub table_source: TableSource,
}

/// What the table angle of a recording is (`[table] source`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TableSource {
    /// Read from an encoder (the default): a measurement.
    #[default]
    Encoder,
    /// The angle the table was told to be at (`source = "commanded"`): not a
    /// measurement; effects that need a measured angle (encoder errors,
    /// offsets between the IMU and the encoder) cannot be fitted.
    Commanded,
    /// No table (no `table.csv` and no `[table]`): an IMU fixed to its base,
    /// read as a table that never turns, at angle 0.
    None,
}

impl TableSource {
    /// The name `[table] source` gives it.
    pub fn as_str(self) -> &'static str {
        match self {
            TableSource::Encoder => "encoder",
            TableSource::Commanded => "commanded",
            TableSource::None => "none",
        }
    }

    /// Whether the angle is a measurement of the table (an encoder).
    pub fn is_measured(self) -> bool {
        self == TableSource::Encoder
    }
}

impl Meta {
    /// The recording's site: latitude, height, and its measured gravity
    /// when `meta.toml` has one (else WGS-84 normal gravity).
    pub fn site(&self) -> core_nav::site::Site {
        core_nav::site::Site::new(self.latitude_deg, self.height_m).with_gravity(self.gravity_mps2)
    }

    /// The base attitude (roll, pitch, heading).
    pub fn base(&self) -> core_nav::attitude::Euler<f64> {
        core_nav::attitude::Euler::from_deg(self.roll_deg, self.pitch_deg, self.heading_deg)
    }
}

impl Default for Meta {
    fn default() -> Self {
        Self {
            description: None,
            latitude_deg: 30.53,
            height_m: 20.0,
            gravity_mps2: None,
            heading_deg: 0.0,
            pitch_deg: 0.0,
            roll_deg: 0.0,
            heading_sigma_deg: None,
            level_sigma_deg: None,
            imu_model: None,
            imu_rate_hz: 100.0,
            imu_sample: SampleKind::Instantaneous,
            axis: Axis::Z,
            encoder_rate_hz: 50.0,
            table_source: TableSource::Encoder,
        }
    }
}

/// One row of `imu.csv`: instantaneous rate (rad/s) and specific force
/// (m/s^2) in the sensor frame `s` at `t_s`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ImuRow {
    /// Seconds since the start of the run.
    pub t_s: f64,
    /// Angular rate `w_is_s`, rad/s.
    pub gyro_radps: [f64; 3],
    /// Specific force `f_s`, m/s^2 (NaN in a gyro-only recording:
    /// [`Recording::gyro_only`]).
    pub accel_mps2: [f64; 3],
    /// IMU temperature, deg C (optional column).
    pub temp_c: Option<f64>,
}

impl ImuRow {
    /// Channel `ch` in the order of `imu.csv` (0-2 gyro x-z, rad/s; 3-5
    /// accelerometer x-z, m/s^2); NaN for any other index.
    pub fn channel(&self, ch: usize) -> f64 {
        let v = if ch < 3 {
            self.gyro_radps.get(ch)
        } else {
            self.accel_mps2.get(ch.wrapping_sub(3))
        };
        v.copied().unwrap_or(f64::NAN)
    }
}

/// One row of `table.csv`: the unwrapped encoder angle (rad) at `t_s`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct TableRow {
    /// Seconds since the start of the run.
    pub t_s: f64,
    /// Table angle `theta`, rad, unwrapped.
    pub angle_rad: f64,
}

impl TableRow {
    /// The mean table rate from `self` to a `later` read, rad/s (the one
    /// encoder-rate formula; an interval under 1 ns counts as 1 ns).
    pub fn rate_to(&self, later: &TableRow) -> f64 {
        (later.angle_rad - self.angle_rad) / (later.t_s - self.t_s).max(1e-9)
    }
}

/// A whole recording in memory.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Recording {
    /// `meta.toml`.
    pub meta: Meta,
    /// `imu.csv` rows, time increasing.
    pub imu: Vec<ImuRow>,
    /// `table.csv` rows, time increasing.
    pub table: Vec<TableRow>,
    /// The moving-base keys and files (`[base] moving = true`), if any.
    pub moving: Option<crate::moving::MovingBase>,
    /// `imu.csv` has no accelerometer columns: every row's `accel_mps2` is
    /// NaN, and tools that need accelerometers refuse it
    /// ([`Recording::require_accel`]).
    pub gyro_only: bool,
}

/// A run of IMU rows with no gap inside (recording-v1: an interval over
/// [`GAP_PERIODS`] sample periods is a gap).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Segment {
    /// First row.
    pub start: usize,
    /// One past the last row.
    pub end: usize,
}

impl Segment {
    /// Rows in the segment.
    pub fn len(&self) -> usize {
        self.end.saturating_sub(self.start)
    }

    /// Whether the segment has no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Its rows as a range.
    pub fn range(&self) -> core::ops::Range<usize> {
        self.start..self.end
    }
}

/// The rows of [`segments`] as ranges.
pub fn segment_ranges(t_s: &[f64], dt_s: f64) -> Vec<core::ops::Range<usize>> {
    segments(t_s, dt_s).iter().map(Segment::range).collect()
}

/// An interval longer than this many nominal sample periods is a gap
/// (recording-v1).
pub const GAP_PERIODS: f64 = 2.5;

/// The stamps' rounding a gap's length is read through, s: an interval of
/// exactly [`GAP_PERIODS`] periods (a logger's stamps in whole
/// milliseconds make many) is no gap on any clock origin, while a
/// difference of two stamps near 1e9 s (epoch seconds) is rounded by
/// 2.4e-7 s.
pub const GAP_STAMP_TOLERANCE_S: f64 = 1e-6;

/// Sample times `t_s` (s, increasing) split at the gaps: intervals over
/// [`GAP_PERIODS`] times the nominal interval `dt_s` (beyond
/// [`GAP_STAMP_TOLERANCE_S`]).
pub fn segments(t_s: &[f64], dt_s: f64) -> Vec<Segment> {
    let limit = GAP_PERIODS * dt_s + GAP_STAMP_TOLERANCE_S;
    let mut out = vec![];
    let mut start = 0;
    for (i, w) in t_s.windows(2).enumerate() {
        if let [a, b] = w {
            if b - a > limit {
                out.push(Segment { start, end: i + 1 });
                start = i + 1;
            }
        }
    }
    if start < t_s.len() {
        out.push(Segment {
            start,
            end: t_s.len(),
        });
    }
    out
}

/// What went wrong reading or writing a recording: the file, the line (1-based)
/// where known, and what.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordingError {
    /// The file.
    pub path: PathBuf,
    /// 1-based line, when the problem is on one.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for RecordingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "{}:{}: {}", self.path.display(), l, self.message),
            None => write!(f, "{}: {}", self.path.display(), self.message),
        }
    }
}

impl std::error::Error for RecordingError {}

/// A recording error in `path` (at 1-based `line` when on one): the one
/// constructor every reader uses.
pub(crate) fn err(path: &Path, line: Option<usize>, message: impl Into<String>) -> RecordingError {
    RecordingError {
        path: path.to_path_buf(),
        line,
        message: message.into(),
    }
}

impl Recording {
    /// The nominal sample interval, s: `1 / [imu] rate_hz` (never the span
    /// over the count, which a gap would stretch).
    pub fn dt_s(&self) -> f64 {
        1.0 / self.meta.imu_rate_hz
    }

    /// The IMU rows split at the gaps: intervals over [`GAP_PERIODS`]
    /// nominal periods. A recording without gaps is one segment.
    pub fn segments(&self) -> Vec<Segment> {
        let t: Vec<f64> = self.imu.iter().map(|r| r.t_s).collect();
        segments(&t, self.dt_s())
    }

    /// Refuses a gyro-only recording, naming the missing columns, for a
    /// tool that needs accelerometers (`what` names the tool).
    ///
    /// # Errors
    /// The recording has no accelerometer columns.
    pub fn require_accel(&self, what: &str) -> Result<(), RecordingError> {
        if self.gyro_only {
            return Err(err(
                Path::new("imu.csv"),
                Some(1),
                format!("{what} needs accelerometers: this recording is gyro-only (no accel_x_mps2, accel_y_mps2, accel_z_mps2 columns)"),
            ));
        }
        Ok(())
    }

    /// Channel `ch` of every IMU row ([`ImuRow::channel`]).
    pub fn channel(&self, ch: usize) -> Vec<f64> {
        self.imu.iter().map(|r| r.channel(ch)).collect()
    }

    /// Reads a recording directory.
    ///
    /// # Errors
    /// A [`RecordingError`] naming the file and line of the first problem.
    pub fn read(dir: &Path) -> Result<Self, RecordingError> {
        let meta_path = dir.join("meta.toml");
        let meta = parse_meta(&read_text(&meta_path)?, &meta_path)?;
        let imu_path = dir.join("imu.csv");
        let (imu, gyro_only) = parse_imu_columns(&read_text(&imu_path)?, &imu_path)?;
        let table_path = dir.join("table.csv");
        let table = if meta.table_source == TableSource::None {
            if table_path.exists() {
                return Err(err(
                    &meta_path,
                    None,
                    "table.csv is present but meta.toml has no [table]: add [table] axis and encoder_rate_hz",
                ));
            }
            still_table(&imu)
        } else {
            parse_table(&read_text(&table_path)?, &table_path)?
        };
        let mut moving = crate::moving::parse_meta(&read_text(&meta_path)?, &meta_path)?;
        if let Some(m) = moving.as_mut() {
            let g = dir.join("gnss.csv");
            if g.exists() {
                m.gnss = Some(crate::moving::parse_gnss(&read_text(&g)?, &g)?);
            }
            let t = dir.join("truth.csv");
            if t.exists() {
                m.truth = Some(crate::moving::parse_truth(&read_text(&t)?, &t)?);
            }
            let o = dir.join("odometer.csv");
            if o.exists() {
                m.odometer = Some(crate::moving::parse_odometer(&read_text(&o)?, &o)?);
            }
        }
        Ok(Self {
            meta,
            imu,
            table,
            moving,
            gyro_only,
        })
    }

    /// Writes the recording into `dir` (created if missing). Refuses to
    /// overwrite an existing recording: tools never rewrite one in place.
    ///
    /// # Errors
    /// A [`RecordingError`] when a file exists already or cannot be written.
    pub fn write(&self, dir: &Path) -> Result<(), RecordingError> {
        fs::create_dir_all(dir).map_err(|e| err(dir, None, format!("cannot create: {e}")))?;
        let mut files = vec![
            ("meta.toml", self.meta_text()),
            ("imu.csv", self.imu_text()),
        ];
        if self.meta.table_source != TableSource::None {
            files.push(("table.csv", self.table_text()));
        }
        if let Some(m) = &self.moving {
            if let Some(g) = &m.gnss {
                files.push(("gnss.csv", crate::moving::gnss_text(g)));
            }
            if let Some(t) = &m.truth {
                files.push(("truth.csv", crate::moving::truth_text(t)));
            }
            if let Some(o) = &m.odometer {
                files.push(("odometer.csv", crate::moving::odometer_text(o)));
            }
        }
        for (name, text) in files {
            let p = dir.join(name);
            if p.exists() {
                return Err(err(
                    &p,
                    None,
                    "exists already; a recording is never rewritten in place",
                ));
            }
            fs::write(&p, text).map_err(|e| err(&p, None, format!("cannot write: {e}")))?;
        }
        Ok(())
    }

    /// `meta.toml` as text.
    pub fn meta_text(&self) -> String {
        let m = &self.meta;
        let mut s = String::new();
        let q = |x: &str| format!("{x:?}"); // TOML basic string (Rust escapes are a subset)
        out!(s, "format = {}\n", q(FORMAT));
        if let Some(d) = &m.description {
            out!(s, "description = {}\n", q(d));
        }
        out!(s, "\n[site]\n");
        out!(s, "latitude_deg = {}\n", toml_f64(m.latitude_deg));
        out!(s, "height_m = {}\n", toml_f64(m.height_m));
        if let Some(g) = m.gravity_mps2 {
            out!(s, "gravity_mps2 = {}\n", toml_f64(g));
        }
        let (mv_site, mv_base, mv_gnss) = self
            .moving
            .as_ref()
            .map(crate::moving::meta_lines)
            .unwrap_or_default();
        s.push_str(&mv_site);
        out!(s, "\n[base]\n");
        s.push_str(&mv_base);
        out!(s, "heading_deg = {}\n", toml_f64(m.heading_deg));
        out!(s, "pitch_deg = {}\n", toml_f64(m.pitch_deg));
        out!(s, "roll_deg = {}\n", toml_f64(m.roll_deg));
        if let Some(x) = m.heading_sigma_deg {
            out!(s, "heading_sigma_deg = {}\n", toml_f64(x));
        }
        if let Some(x) = m.level_sigma_deg {
            out!(s, "level_sigma_deg = {}\n", toml_f64(x));
        }
        out!(s, "\n[imu]\n");
        if let Some(model) = &m.imu_model {
            out!(s, "model = {}\n", q(model));
        }
        out!(s, "rate_hz = {}\n", toml_f64(m.imu_rate_hz));
        if m.imu_sample == SampleKind::Average {
            out!(s, "sample = \"average\"\n");
        }
        if m.table_source != TableSource::None {
            out!(s, "\n[table]\n");
            out!(s, "axis = {}\n", q(axis_name(m.axis)));
            out!(s, "encoder_rate_hz = {}\n", toml_f64(m.encoder_rate_hz));
            if m.table_source == TableSource::Commanded {
                out!(s, "source = \"commanded\"\n");
            }
        }
        s.push_str(&mv_gnss);
        s
    }

    /// `imu.csv` as text (with `temp_c` when every row has a temperature).
    pub fn imu_text(&self) -> String {
        let with_temp = !self.imu.is_empty() && self.imu.iter().all(|r| r.temp_c.is_some());
        let mut s = String::with_capacity(self.imu.len() * 120 + 100);
        s.push_str("t_s,gyro_x_radps,gyro_y_radps,gyro_z_radps");
        if !self.gyro_only {
            s.push_str(",accel_x_mps2,accel_y_mps2,accel_z_mps2");
        }
        s.push_str(if with_temp { ",temp_c\n" } else { "\n" });
        for r in &self.imu {
            let [gx, gy, gz] = r.gyro_radps;
            out!(s, "{},{gx},{gy},{gz}", r.t_s);
            if !self.gyro_only {
                let [ax, ay, az] = r.accel_mps2;
                out!(s, ",{ax},{ay},{az}");
            }
            match (with_temp, r.temp_c) {
                (true, Some(t)) => {
                    out!(s, ",{t}\n");
                }
                _ => s.push('\n'),
            }
        }
        s
    }

    /// `table.csv` as text.
    pub fn table_text(&self) -> String {
        let mut s = String::with_capacity(self.table.len() * 40 + 20);
        s.push_str("t_s,angle_rad\n");
        for r in &self.table {
            out!(s, "{},{}\n", r.t_s, r.angle_rad);
        }
        s
    }
}

/// The spec's name of an axis.
pub fn axis_name(a: Axis) -> &'static str {
    match a {
        Axis::X => "x",
        Axis::Y => "y",
        Axis::Z => "z",
    }
}

/// Parses an axis name (`x`, `y`, `z`).
pub fn parse_axis(s: &str) -> Option<Axis> {
    match s {
        "x" => Some(Axis::X),
        "y" => Some(Axis::Y),
        "z" => Some(Axis::Z),
        _ => None,
    }
}

/// A float as TOML (always with a decimal point or exponent).
fn toml_f64(x: f64) -> String {
    let s = format!("{x:?}");
    if s.contains(['.', 'e', 'E', 'i', 'N']) {
        s
    } else {
        format!("{s}.0")
    }
}

fn read_text(path: &Path) -> Result<String, RecordingError> {
    fs::read_to_string(path).map_err(|e| err(path, None, format!("cannot read: {e}")))
}

fn key<'a>(
    t: &'a toml::Table,
    table: &str,
    name: &str,
    path: &Path,
) -> Result<&'a toml::Value, RecordingError> {
    let sub = t
        .get(table)
        .and_then(|v| v.as_table())
        .ok_or_else(|| err(path, None, format!("missing table [{table}]")))?;
    sub.get(name)
        .ok_or_else(|| err(path, None, format!("missing key {table}.{name}")))
}

fn num(v: &toml::Value, what: &str, path: &Path) -> Result<f64, RecordingError> {
    let x = match v {
        toml::Value::Float(f) => *f,
        toml::Value::Integer(i) => *i as f64,
        _ => return Err(err(path, None, format!("{what} must be a number"))),
    };
    if !x.is_finite() {
        return Err(err(path, None, format!("{what} is not finite")));
    }
    Ok(x)
}

fn req_num(t: &toml::Table, table: &str, name: &str, path: &Path) -> Result<f64, RecordingError> {
    num(key(t, table, name, path)?, &format!("{table}.{name}"), path)
}

fn opt_str(t: &toml::Table, table: &str, name: &str) -> Option<String> {
    t.get(table)?
        .as_table()?
        .get(name)?
        .as_str()
        .map(str::to_owned)
}

/// Parses `meta.toml` text; `path` names the file in errors.
///
/// # Errors
/// TOML syntax (with its line), a wrong `format`, a missing key (named), a
/// An optional `[base]` sigma, deg: positive and finite when present.
fn opt_sigma(t: &toml::Table, key: &str, path: &Path) -> Result<Option<f64>, RecordingError> {
    match t.get("base").and_then(|b| b.get(key)) {
        None => Ok(None),
        Some(v) => match num(v, &format!("base.{key}"), path)? {
            x if x >= 0.0 && x.is_finite() => Ok(Some(x)),
            x => Err(err(
                path,
                None,
                format!("base.{key} = {x}: a 1-sigma must be >= 0 (0: exact)"),
            )),
        },
    }
}

/// non-finite or non-positive rate, an unknown axis.
pub fn parse_meta(text: &str, path: &Path) -> Result<Meta, RecordingError> {
    let t: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        let line = e
            .span()
            .map(|sp| text.get(..sp.start).map_or(0, |p| p.matches('\n').count()) + 1);
        err(path, line, format!("TOML: {}", e.message()))
    })?;
    match t.get("format").and_then(|v| v.as_str()) {
        Some(FORMAT) => {}
        Some(other) => {
            return Err(err(
                path,
                None,
                format!("format is {other:?}, expected {FORMAT:?}"),
            ))
        }
        None => return Err(err(path, None, "missing key format")),
    }
    let has_table = t.get("table").is_some();
    let axis = if has_table {
        let axis_s = key(&t, "table", "axis", path)?
            .as_str()
            .ok_or_else(|| err(path, None, "table.axis must be a string"))?;
        parse_axis(axis_s).ok_or_else(|| {
            err(
                path,
                None,
                format!("table.axis is {axis_s:?}, expected \"x\", \"y\" or \"z\""),
            )
        })?
    } else {
        Axis::Z
    };
    let table_source = match (has_table, opt_str(&t, "table", "source").as_deref()) {
        (false, _) => TableSource::None,
        (true, None | Some("encoder")) => TableSource::Encoder,
        (true, Some("commanded")) => TableSource::Commanded,
        (true, Some(o)) => {
            return Err(err(
                path,
                None,
                format!("table.source is {o:?}, expected \"encoder\" or \"commanded\""),
            ))
        }
    };
    let imu_sample = match opt_str(&t, "imu", "sample").as_deref() {
        None | Some("instantaneous") => SampleKind::Instantaneous,
        Some("average") => SampleKind::Average,
        Some(o) => {
            return Err(err(
                path,
                None,
                format!("imu.sample is {o:?}, expected \"average\" or \"instantaneous\""),
            ))
        }
    };
    let gravity_mps2 = match t
        .get("site")
        .and_then(|s| s.as_table())
        .and_then(|s| s.get("gravity_mps2"))
    {
        Some(v) => Some(num(v, "site.gravity_mps2", path)?),
        None => None,
    };
    let meta = Meta {
        description: t
            .get("description")
            .and_then(|v| v.as_str())
            .map(str::to_owned),
        latitude_deg: req_num(&t, "site", "latitude_deg", path)?,
        height_m: req_num(&t, "site", "height_m", path)?,
        gravity_mps2,
        heading_deg: req_num(&t, "base", "heading_deg", path)?,
        pitch_deg: req_num(&t, "base", "pitch_deg", path)?,
        roll_deg: req_num(&t, "base", "roll_deg", path)?,
        heading_sigma_deg: opt_sigma(&t, "heading_sigma_deg", path)?,
        level_sigma_deg: opt_sigma(&t, "level_sigma_deg", path)?,
        imu_model: opt_str(&t, "imu", "model"),
        imu_rate_hz: req_num(&t, "imu", "rate_hz", path)?,
        imu_sample,
        axis,
        encoder_rate_hz: if has_table {
            req_num(&t, "table", "encoder_rate_hz", path)?
        } else {
            req_num(&t, "imu", "rate_hz", path)?
        },
        table_source,
    };
    if meta.imu_rate_hz <= 0.0 || meta.encoder_rate_hz <= 0.0 {
        return Err(err(path, None, "rates must be positive"));
    }
    if meta.latitude_deg.abs() > 90.0 {
        return Err(err(path, None, "site.latitude_deg outside [-90, 90]"));
    }
    Ok(meta)
}

/// A CSV body: the header's column indices for the wanted names, then rows.
struct Csv<'a> {
    path: &'a Path,
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    n_fields: usize,
    fields: Vec<&'a str>,
}

impl<'a> Csv<'a> {
    /// Opens a CSV text; returns the reader and the column index of each of
    /// `names` (`None` when absent).
    fn open(
        text: &'a str,
        path: &'a Path,
        names: &[&str],
    ) -> Result<(Self, Vec<Option<usize>>), RecordingError> {
        let mut lines = text.lines().enumerate();
        let (_, header) = lines
            .next()
            .ok_or_else(|| err(path, Some(1), "empty file: no header"))?;
        let cols: Vec<&str> = header
            .trim_end_matches('\r')
            .split(',')
            .map(str::trim)
            .collect();
        let idx = names
            .iter()
            .map(|n| cols.iter().position(|c| c == n))
            .collect();
        Ok((
            Self {
                path,
                lines,
                n_fields: cols.len(),
                fields: Vec::with_capacity(cols.len()),
            },
            idx,
        ))
    }

    /// The next non-empty row's fields and its 1-based line number.
    fn next_row(&mut self) -> Result<Option<usize>, RecordingError> {
        for (i, line) in self.lines.by_ref() {
            let line = line.trim_end_matches('\r');
            if line.trim().is_empty() {
                continue;
            }
            self.fields.clear();
            self.fields.extend(line.split(','));
            if self.fields.len() != self.n_fields {
                return Err(err(
                    self.path,
                    Some(i + 1),
                    format!(
                        "{} fields, the header has {}",
                        self.fields.len(),
                        self.n_fields
                    ),
                ));
            }
            return Ok(Some(i + 1));
        }
        Ok(None)
    }

    fn num(&self, col: usize, name: &str, line: usize) -> Result<f64, RecordingError> {
        let s = self.fields.get(col).copied().unwrap_or("").trim();
        let x: f64 = s.parse().map_err(|_| {
            err(
                self.path,
                Some(line),
                format!("{name}: {s:?} is not a number"),
            )
        })?;
        if !x.is_finite() {
            return Err(err(
                self.path,
                Some(line),
                format!("{name}: {s} is not finite"),
            ));
        }
        Ok(x)
    }
}

fn check_time(path: &Path, line: usize, prev: Option<f64>, t: f64) -> Result<(), RecordingError> {
    if let Some(p) = prev {
        if t <= p {
            return Err(err(
                path,
                Some(line),
                format!("time {t} s does not increase (previous {p} s)"),
            ));
        }
    }
    Ok(())
}

/// Parses a CSV of numbers with every one of `cols` required (any order,
/// extra columns ignored), the first being time, increasing: each row's
/// line and its values in the order of `cols`.
///
/// # Errors
/// A missing column, a bad row, a non-number, time not increasing.
pub(crate) fn parse_columns(
    text: &str,
    path: &Path,
    cols: &[&str],
) -> Result<Vec<(usize, Vec<f64>)>, RecordingError> {
    let (mut csv, idx) = Csv::open(text, path, cols)?;
    let mut at = Vec::with_capacity(cols.len());
    for (k, name) in cols.iter().enumerate() {
        at.push(
            idx.get(k)
                .copied()
                .flatten()
                .ok_or_else(|| err(path, Some(1), format!("missing column {name}")))?,
        );
    }
    let mut rows = vec![];
    let mut prev = None;
    while let Some(line) = csv.next_row()? {
        let mut v = Vec::with_capacity(cols.len());
        for (c, name) in at.iter().zip(cols) {
            v.push(csv.num(*c, name, line)?);
        }
        let t = v.first().copied().unwrap_or(0.0);
        check_time(path, line, prev, t)?;
        prev = Some(t);
        rows.push((line, v));
    }
    Ok(rows)
}

/// The `imu.csv` columns: time, the six channels (rad/s, m/s^2), temperature.
pub const IMU_COLS: [&str; 8] = [
    "t_s",
    "gyro_x_radps",
    "gyro_y_radps",
    "gyro_z_radps",
    "accel_x_mps2",
    "accel_y_mps2",
    "accel_z_mps2",
    "temp_c",
];

/// Parses `imu.csv` text; `path` names the file in errors. A gyro-only file
/// is an error here ([`parse_imu_columns`] reads one).
///
/// # Errors
/// Missing header columns, wrong field counts, non-numbers, non-finite
/// values, time not increasing: each with the line.
pub fn parse_imu(text: &str, path: &Path) -> Result<Vec<ImuRow>, RecordingError> {
    let (rows, gyro_only) = parse_imu_columns(text, path)?;
    if gyro_only {
        return Err(err(path, Some(1), "missing column accel_x_mps2"));
    }
    Ok(rows)
}

/// Parses `imu.csv` text, the accelerometer columns optional (all three or
/// none): the rows, and whether the file is gyro-only (then every row's
/// accelerometer is NaN).
///
/// # Errors
/// As [`parse_imu`]; one or two accelerometer columns without the others.
pub fn parse_imu_columns(text: &str, path: &Path) -> Result<(Vec<ImuRow>, bool), RecordingError> {
    let (mut csv, idx) = Csv::open(text, path, &IMU_COLS)?;
    let accel_present = (4..7)
        .filter(|k| idx.get(*k).copied().flatten().is_some())
        .count();
    let gyro_only = match accel_present {
        0 => true,
        3 => false,
        _ => {
            let missing: Vec<&str> = (4..7)
                .filter(|k| idx.get(*k).copied().flatten().is_none())
                .filter_map(|k| IMU_COLS.get(k).copied())
                .collect();
            return Err(err(
                path,
                Some(1),
                format!(
                    "missing column {}: the accelerometer columns come all three or none",
                    missing.join(", ")
                ),
            ));
        }
    };
    let wanted = if gyro_only { 4 } else { 7 };
    let mut req = [0usize; 7];
    for (k, slot) in req.iter_mut().enumerate().take(wanted) {
        let name = IMU_COLS.get(k).copied().unwrap_or("");
        *slot = idx
            .get(k)
            .copied()
            .flatten()
            .ok_or_else(|| err(path, Some(1), format!("missing column {name}")))?;
    }
    let temp_col = idx.get(7).copied().flatten();
    let mut rows = Vec::with_capacity(text.len() / 100);
    let mut prev = None;
    while let Some(line) = csv.next_row()? {
        let mut v = [f64::NAN; 7];
        for (k, (slot, col)) in v.iter_mut().zip(req).enumerate().take(wanted) {
            *slot = csv.num(col, IMU_COLS.get(k).copied().unwrap_or(""), line)?;
        }
        let temp_c = match temp_col {
            Some(c) => Some(csv.num(c, "temp_c", line)?),
            None => None,
        };
        let [t_s, gx, gy, gz, ax, ay, az] = v;
        check_time(path, line, prev, t_s)?;
        prev = Some(t_s);
        rows.push(ImuRow {
            t_s,
            gyro_radps: [gx, gy, gz],
            accel_mps2: [ax, ay, az],
            temp_c,
        });
    }
    Ok((rows, gyro_only))
}

impl Recording {
    /// A recording of an IMU fixed to its base (no table: the encoder's
    /// angle 0 at every sample), moving when `moving` is given.
    pub fn fixed_imu(
        meta: Meta,
        imu: Vec<ImuRow>,
        moving: Option<crate::moving::MovingBase>,
    ) -> Self {
        Self {
            table: still_table(&imu),
            meta,
            imu,
            moving,
            gyro_only: false,
        }
    }
}

/// The table of a recording without one: at angle 0 at every IMU sample
/// (recording-v1: a table that never turns).
pub fn still_table(imu: &[ImuRow]) -> Vec<TableRow> {
    imu.iter()
        .map(|r| TableRow {
            t_s: r.t_s,
            angle_rad: 0.0,
        })
        .collect()
}

/// Parses `table.csv` text; `path` names the file in errors.
///
/// # Errors
/// As [`parse_imu`].
pub fn parse_table(text: &str, path: &Path) -> Result<Vec<TableRow>, RecordingError> {
    let (mut csv, idx) = Csv::open(text, path, &["t_s", "angle_rad"])?;
    let t_col = idx
        .first()
        .copied()
        .flatten()
        .ok_or_else(|| err(path, Some(1), "missing column t_s"))?;
    let a_col = idx
        .get(1)
        .copied()
        .flatten()
        .ok_or_else(|| err(path, Some(1), "missing column angle_rad"))?;
    let mut rows = Vec::with_capacity(text.len() / 30);
    let mut prev = None;
    while let Some(line) = csv.next_row()? {
        let t_s = csv.num(t_col, "t_s", line)?;
        let angle_rad = csv.num(a_col, "angle_rad", line)?;
        check_time(path, line, prev, t_s)?;
        prev = Some(t_s);
        rows.push(TableRow { t_s, angle_rad });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> PathBuf {
        PathBuf::from("run/imu.csv")
    }

    #[test]
    fn columns_in_any_order_and_extra_ignored() {
        let text = "accel_z_mps2,extra,t_s,gyro_x_radps,gyro_y_radps,gyro_z_radps,accel_x_mps2,accel_y_mps2\n-9.8,7,0.0,1,2,3,4,5\n";
        let rows = parse_imu(text, &p()).unwrap();
        assert_eq!(rows[0].gyro_radps, [1.0, 2.0, 3.0]);
        assert_eq!(rows[0].accel_mps2, [4.0, 5.0, -9.8]);
        assert_eq!(rows[0].temp_c, None);
    }

    #[test]
    fn bad_rows_name_file_and_line() {
        let h =
            "t_s,gyro_x_radps,gyro_y_radps,gyro_z_radps,accel_x_mps2,accel_y_mps2,accel_z_mps2\n";
        let cases = [
            (
                format!("{h}0,0,0,0,0,0,0\n0.01,0,0,NaN,0,0,0\n"),
                3,
                "not finite",
            ),
            (format!("{h}0,0,0,0,0,0,0\n0.01,0,0,0,0,0\n"), 3, "fields"),
            (
                format!("{h}0.02,0,0,0,0,0,0\n0.01,0,0,0,0,0,0\n"),
                3,
                "does not increase",
            ),
            (format!("{h}0,0,0,x,0,0,0\n"), 2, "not a number"),
            (
                "t_s,gyro_x_radps\n".to_string(),
                1,
                "missing column gyro_y_radps",
            ),
        ];
        for (text, line, what) in cases {
            let e = parse_imu(&text, &p()).unwrap_err();
            assert_eq!(e.line, Some(line), "{e}");
            assert!(e.to_string().contains(what), "{e}");
            assert!(e.to_string().starts_with("run/imu.csv:"), "{e}");
        }
    }

    #[test]
    fn gyro_only_files_read_and_partial_accelerometers_are_refused() {
        let text = "t_s,gyro_x_radps,gyro_y_radps,gyro_z_radps\n0,1,2,3\n0.01,1,2,3\n";
        let (rows, gyro_only) = parse_imu_columns(text, &p()).unwrap();
        assert!(gyro_only);
        assert!(rows[1].accel_mps2.iter().all(|a| a.is_nan()));
        assert!(parse_imu(text, &p()).is_err());
        let partial = "t_s,gyro_x_radps,gyro_y_radps,gyro_z_radps,accel_x_mps2\n0,1,2,3,4\n";
        let e = parse_imu_columns(partial, &p()).unwrap_err();
        assert!(e.to_string().contains("accel_y_mps2, accel_z_mps2"), "{e}");
        let rec = Recording {
            imu: rows,
            gyro_only: true,
            ..Recording::default()
        };
        let e = rec.require_accel("rins navigate").unwrap_err();
        assert!(e.to_string().contains("gyro-only"), "{e}");
        // Written back without accelerometer columns.
        assert!(!rec.imu_text().contains("accel"));
    }

    #[test]
    fn table_source_and_no_table_are_read() {
        let base = "format = \"rins-recording/1\"\n[site]\nlatitude_deg = -33.9\nheight_m = 20\n[base]\nheading_deg = 0\npitch_deg = 0\nroll_deg = 0\n[imu]\nrate_hz = 100\n";
        let with = |t: &str| format!("{base}[table]\naxis = \"z\"\nencoder_rate_hz = 50\n{t}");
        let m = parse_meta(&with(""), Path::new("meta.toml")).unwrap();
        assert_eq!(m.table_source, TableSource::Encoder);
        let m = parse_meta(&with("source = \"commanded\"\n"), Path::new("meta.toml")).unwrap();
        assert_eq!(m.table_source, TableSource::Commanded);
        assert!(parse_meta(&with("source = \"guessed\"\n"), Path::new("meta.toml")).is_err());
        let m = parse_meta(base, Path::new("meta.toml")).unwrap();
        assert_eq!(m.table_source, TableSource::None);
        assert_eq!(m.latitude_deg, -33.9);
    }

    #[test]
    fn gaps_split_segments_and_the_rate_is_the_nominal_one() {
        // 100 Hz with a 0.5 s gap: two segments, the rate from rate_hz.
        let mut t: Vec<f64> = (0..100).map(|i| f64::from(i) * 0.01).collect();
        t.extend((0..50).map(|i| 1.5 + f64::from(i) * 0.01));
        let segs = segments(&t, 0.01);
        assert_eq!(segs.len(), 2);
        assert_eq!((segs[0].start, segs[0].end, segs[1].end), (0, 100, 150));
        // An interval of 2 periods is not a gap, 3 is (2.5 the threshold).
        assert_eq!(segments(&[0.0, 0.02, 0.04], 0.01).len(), 1);
        assert_eq!(segments(&[0.0, 0.03], 0.01).len(), 2);
    }

    #[test]
    fn meta_missing_key_is_named_and_unknown_keys_pass() {
        let good = "format = \"rins-recording/1\"\nfuture = 1\n[site]\nlatitude_deg = 30.5\nheight_m = 20\n[base]\nheading_deg = 0\npitch_deg = 0\nroll_deg = 0\n[imu]\nrate_hz = 100\nnew_key = \"x\"\n[table]\naxis = \"z\"\nencoder_rate_hz = 50\n[later]\nx = 1\n";
        let m = parse_meta(good, Path::new("meta.toml")).unwrap();
        assert_eq!(m.axis, Axis::Z);
        assert_eq!(m.height_m, 20.0);
        let bad = good.replace("height_m = 20\n", "");
        let e = parse_meta(&bad, Path::new("meta.toml")).unwrap_err();
        assert!(e.to_string().contains("site.height_m"), "{e}");
        let e = parse_meta("format = [", Path::new("meta.toml")).unwrap_err();
        assert_eq!(e.line, Some(1));
    }
}

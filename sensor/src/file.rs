//! Sensor files (`rins-sensor/2`, and `/1` read as before; TOML; the
//! `std` feature): a unit's error budget in the
//! units datasheets and Allan plots give, its mounting on the base and the
//! antenna's lever arm. The shipped profiles are such files
//! (`sensors/*.toml`, compiled in); a user's own file is read by path.
//! The format is documented in the book's Formats chapter
//! (`docs/src/formats.md`); this module is its one reader and writer.
//!
//! Conversions to the SI [`ImuSpec`]: deg -> rad, g -> m/s^2 with
//! [`G0`], an Allan floor -> the Gauss-Markov sigma whose Allan peak it
//! is ([`ALLAN_PEAK_PER_GM_SIGMA`]), `%` -> fraction, cross-axis
//! sensitivity -> a misalignment per off-diagonal entry (`/ sqrt 2`: the
//! datasheet's figure is the pair's).

use crate::spec::{Mounting, TempSpec, TriadSpec, ALLAN_PEAK_PER_GM_SIGMA, DEG, G0};

const DPH: f64 = DEG / 3600.0;

/// The format's name (`format = ...`): version 2, which can say a term
/// is unknown.
pub const FORMAT: &str = "rins-sensor/2";
/// Version 1: every term a number, a missing one zero (read as before).
pub const FORMAT_V1: &str = "rins-sensor/1";
/// A term's value when it is not known.
pub const UNKNOWN: &str = "unknown";

/// The shipped sensor files, by name.
pub const SHIPPED: [(&str, &str); 6] = [
    ("ideal", include_str!("../../sensors/ideal.toml")),
    ("mtig", include_str!("../../sensors/mtig.toml")),
    ("nav440", include_str!("../../sensors/nav440.toml")),
    ("adis16405", include_str!("../../sensors/adis16405.toml")),
    ("icm42688", include_str!("../../sensors/icm42688.toml")),
    ("icm42605", include_str!("../../sensors/icm42605.toml")),
];

use std::path::Path;
use std::string::{String, ToString};
use std::vec::Vec;
use std::{format, vec};

/// A sensor's whole error budget.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuSpec {
    /// Profile name (a shipped one's: [`ImuSpec::NAMES`]).
    pub name: String,
    /// Model name for the recording's meta.
    pub model: String,
    /// Gyro triad.
    pub gyro: TriadSpec,
    /// Accelerometer triad.
    pub accel: TriadSpec,
    /// Gyro g-sensitivity, each entry 1 sigma, rad/s per m/s^2.
    pub g_sensitivity: f64,
    /// Latency of the IMU samples behind their time stamps, s (the gyros',
    /// and the accelerometers' unless `accel_latency_s` is set).
    pub latency_s: f64,
    /// The accelerometers' own latency, s, when it differs from the gyros'.
    pub accel_latency_s: Option<f64>,
    /// Sample-time jitter, 1 sigma, s.
    pub jitter_s: f64,
    /// Temperature behaviour.
    pub temp: TempSpec,
    /// How the IMU sits on its base (identity for the simulator's).
    pub mounting: Mounting,
    /// The terms the sensor file says are unknown (`table.key`, sorted:
    /// [`crate::file::terms`]); they hold zero here, and a command that
    /// needs one refuses ([`ImuSpec::require`]).
    pub unknown: Vec<String>,
}

impl ImuSpec {
    /// The shipped profile named `name` (`sensors/<name>.toml`).
    pub fn by_name(name: &str) -> Option<Self> {
        crate::file::SHIPPED
            .iter()
            .any(|(n, _)| *n == name)
            .then(|| crate::file::resolve(name).ok())
            .flatten()
    }

    /// The terms of `terms` this sensor does not know.
    pub fn unknown_of<'a>(&self, terms: &[&'a str]) -> Vec<&'a str> {
        terms
            .iter()
            .copied()
            .filter(|t| self.unknown.iter().any(|u| u == t))
            .collect()
    }

    /// Refuses a sensor that does not know a term `what` needs.
    ///
    /// # Errors
    /// The unknown terms, named, with what gives them.
    pub fn require(&self, terms: &[&str], what: &str) -> Result<(), crate::file::SensorError> {
        let missing = self.unknown_of(terms);
        if missing.is_empty() {
            return Ok(());
        }
        Err(crate::file::SensorError(format!(
            "sensor {:?}: {what} needs {}, which its file says are unknown: measure them (rins allan, rins diagnose --sensor-out) or give them (a base = shipped sensor, or the numbers)",
            self.name,
            missing.join(", ")
        )))
    }

    /// The profile whose `model` text is `model` (a simulated recording's
    /// `[imu] model`), or whose name it is, either in any case
    /// (`ADIS16405` is `adis16405`).
    pub fn by_model(model: &str) -> Option<Self> {
        Self::NAMES
            .iter()
            .filter_map(|n| Self::by_name(n))
            .find(|p| p.model.eq_ignore_ascii_case(model) || p.name.eq_ignore_ascii_case(model))
    }

    /// The shipped profiles' names.
    pub const NAMES: [&'static str; 6] = [
        "ideal",
        "mtig",
        "nav440",
        "adis16405",
        "icm42688",
        "icm42605",
    ];

    /// The shipped profile `name`; a shipped file that does not read is a
    /// build defect (every one is read in the sensor module's tests).
    fn shipped(name: &str) -> Self {
        match crate::file::resolve(name) {
            Ok(s) => s,
            Err(e) => panic!("shipped sensor file: {e}"),
        }
    }

    /// No error at all (`sensors/ideal.toml`).
    pub fn ideal() -> Self {
        Self::shipped("ideal")
    }

    /// Xsens MTi-G (`sensors/mtig.toml`).
    pub fn mtig() -> Self {
        Self::shipped("mtig")
    }

    /// MEMSIC NAV440 (`sensors/nav440.toml`).
    pub fn nav440() -> Self {
        Self::shipped("nav440")
    }

    /// Analog Devices ADIS16405 (`sensors/adis16405.toml`).
    pub fn adis16405() -> Self {
        Self::shipped("adis16405")
    }

    /// TDK ICM-42688-P, the board's chip (`sensors/icm42688.toml`).
    pub fn icm42688() -> Self {
        Self::shipped("icm42688")
    }
}

/// A sensor file that cannot be read, naming the file and the key.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SensorError(pub String);

impl std::fmt::Display for SensorError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for SensorError {}

/// The sensor `name_or_path` names: a shipped profile's name, else a
/// sensor file's path.
///
/// # Errors
/// Neither a shipped name nor a readable, valid file.
pub fn resolve(name_or_path: &str) -> Result<ImuSpec, SensorError> {
    if let Some((_, text)) = SHIPPED.iter().find(|(n, _)| *n == name_or_path) {
        return parse(text, &format!("sensors/{name_or_path}.toml"));
    }
    let path = Path::new(name_or_path);
    if !path.exists() {
        return Err(SensorError(format!(
            "--sensor {name_or_path:?}: neither a shipped sensor ({}) nor a file",
            names().join(", ")
        )));
    }
    let text = std::fs::read_to_string(path)
        .map_err(|e| SensorError(format!("{}: {e}", path.display())))?;
    parse(&text, &path.display().to_string())
}

/// The shipped sensors' names.
pub fn names() -> Vec<&'static str> {
    SHIPPED.iter().map(|(n, _)| *n).collect()
}

/// Reads a sensor file's text (`what` names it in errors).
///
/// `rins-sensor/1`: a missing key is zero. `rins-sensor/2`: a term may be
/// `"unknown"`, and a missing error term is unknown (the terms a
/// `/1` file would read as zero: every triad key but `latency_s` and
/// `flicker`, and the gyros' g-sensitivity); latency, jitter, the
/// temperature and the mounting keep their defaults, which are genuine
/// (zero latency and jitter, the identity mounting). Unknown terms read as
/// zero in the spec and are listed in [`ImuSpec::unknown`], so that a
/// command needing one refuses ([`ImuSpec::require`]).
///
/// # Errors
/// Not TOML, another format, a missing or unknown key, a value of the
/// wrong type, a negative magnitude.
pub fn parse(text: &str, what: &str) -> Result<ImuSpec, SensorError> {
    let err = |m: String| SensorError(format!("{what}: {m}"));
    let mut t: toml::Table = text.parse().map_err(|e| err(format!("{e}")))?;
    if let Some(b) = t.remove("base") {
        t = inherit(&b, t).map_err(err)?;
    }
    let v2 = match t.get("format").map(toml::Value::as_str) {
        Some(Some(f)) if f == FORMAT => true,
        Some(Some(f)) if f == FORMAT_V1 => false,
        Some(Some(f)) => {
            return Err(err(format!(
                "format is {f:?}, expected {FORMAT:?} (or {FORMAT_V1:?})"
            )))
        }
        Some(None) => return Err(err("format must be a string".into())),
        None => return Err(err(format!("missing key format (= {FORMAT:?})"))),
    };
    let r = Reader {
        t: &t,
        what,
        v2,
        unknown: core::cell::RefCell::new(vec![]),
    };
    r.known(
        None,
        &[
            "format",
            "name",
            "model",
            "measured",
            "gyro",
            "accel",
            "timing",
            "temperature",
            "mounting",
        ],
    )?;
    r.measured()?;
    let name = r.str_at(None, "name")?.unwrap_or_else(|| what.to_string());
    let model = r.str_at(None, "model")?.unwrap_or_else(|| name.clone());
    let gyro = r.triad("gyro", &GYRO)?;
    let accel = r.triad("accel", &ACCEL)?;
    let g_sensitivity = r.term("gyro", "g_sensitivity_dps_per_g")? * DEG / G0;
    // Latencies are signed (a stamp taken late makes a sample early).
    let latency_s = r.signed("gyro", "latency_s")?.unwrap_or(0.0);
    let accel_latency_s = r.signed("accel", "latency_s")?;
    r.known(Some("timing"), &["jitter_s"])?;
    let jitter_s = r.term("timing", "jitter_s")?;
    r.known(
        Some("temperature"),
        &["ambient_c", "warmup_c", "warmup_tau_s", "lsb_c"],
    )?;
    let temp = r.temperature()?;
    r.known(Some("mounting"), &["imu_to_base_deg", "antenna_b_m"])?;
    let mounting = Mounting {
        imu_to_base_deg: r.vec3("mounting", "imu_to_base_deg")?.unwrap_or([0.0; 3]),
        antenna_b_m: r.vec3("mounting", "antenna_b_m")?,
    };
    let mut unknown = r.unknown.into_inner();
    unknown.sort();
    unknown.dedup();
    Ok(ImuSpec {
        name,
        model,
        gyro,
        accel,
        g_sensitivity,
        latency_s,
        accel_latency_s,
        jitter_s,
        temp,
        mounting,
        unknown,
    })
}

/// A file that starts from a shipped sensor (`base = "icm42605"`): the
/// shipped file's every term, written out as `rins-sensor/2` (so a term
/// the shipped file leaves at zero is a zero, not unknown), with this
/// file's keys over them (a user's unit of a known chip: its own
/// mounting, lever arm or measured noise).
fn inherit(base: &toml::Value, over: toml::Table) -> Result<toml::Table, String> {
    let name = base
        .as_str()
        .ok_or("base must be a shipped sensor's name")?;
    let text = SHIPPED
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, t)| *t)
        .ok_or_else(|| {
            format!(
                "base = {name:?}: not a shipped sensor ({})",
                names().join(", ")
            )
        })?;
    let spec = parse(text, &format!("sensors/{name}.toml")).map_err(|e| e.0)?;
    let mut t: toml::Table = write(&spec, &[])
        .parse()
        .map_err(|e| format!("sensors/{name}.toml: {e}"))?;
    for (k, v) in over {
        match (t.get_mut(&k), v) {
            (Some(toml::Value::Table(bt)), toml::Value::Table(ot)) => bt.extend(ot),
            (_, v) => {
                t.insert(k, v);
            }
        }
    }
    Ok(t)
}

/// One quantity of a triad: the keys that may give it (exactly one of
/// them) and each key's factor to SI; the first is its name when unknown.
struct Quantity {
    keys: &'static [(&'static str, f64)],
}

impl Quantity {
    fn first(&self) -> (&'static str, f64) {
        self.keys.first().copied().unwrap_or(("", 1.0))
    }
}

/// The keys of a triad's table, in the order of [`TriadSpec`]'s fields
/// read by [`Reader::triad`].
struct TriadKeys {
    noise: Quantity,
    floor: Quantity,
    bias: Quantity,
    temp_bias: Quantity,
    rrw: Quantity,
    lsb: Quantity,
    sensitivity: &'static str,
    /// The unit `sensitivity` counts LSBs per (deg/s or g), in SI.
    unit: f64,
    full_scale: Quantity,
    extra: &'static [&'static str],
}

const GYRO: TriadKeys = TriadKeys {
    noise: Quantity {
        keys: &[("noise_density_dps_rthz", DEG), ("arw_deg_rth", DEG / 60.0)],
    },
    floor: Quantity {
        keys: &[
            ("bias_instability_deg_h", DPH),
            ("bias_instability_dps", DEG),
        ],
    },
    bias: Quantity {
        keys: &[("turn_on_bias_dps", DEG)],
    },
    temp_bias: Quantity {
        keys: &[("temp_bias_dps_per_c", DEG)],
    },
    rrw: Quantity {
        keys: &[("rate_random_walk_dps_rts", DEG)],
    },
    lsb: Quantity {
        keys: &[("lsb_dps", DEG)],
    },
    sensitivity: "sensitivity_lsb_per_dps",
    unit: DEG,
    full_scale: Quantity {
        keys: &[("full_scale_dps", DEG)],
    },
    extra: &["g_sensitivity_dps_per_g", "latency_s"],
};

const ACCEL: TriadKeys = TriadKeys {
    noise: Quantity {
        keys: &[
            ("noise_density_ug_rthz", G0 * 1e-6),
            ("noise_density_mps2_rthz", 1.0),
            ("vrw_mps_rth", 1.0 / 60.0),
        ],
    },
    floor: Quantity {
        keys: &[
            ("bias_instability_mg", G0 * 1e-3),
            ("bias_instability_ug", G0 * 1e-6),
        ],
    },
    bias: Quantity {
        keys: &[("turn_on_bias_mg", G0 * 1e-3)],
    },
    temp_bias: Quantity {
        keys: &[("temp_bias_mg_per_c", G0 * 1e-3)],
    },
    rrw: Quantity {
        keys: &[("random_walk_mps2_rts", 1.0)],
    },
    lsb: Quantity {
        keys: &[("lsb_mg", G0 * 1e-3)],
    },
    sensitivity: "sensitivity_lsb_per_g",
    unit: G0,
    full_scale: Quantity {
        keys: &[("full_scale_g", G0)],
    },
    extra: &["latency_s"],
};

/// Keys every triad table shares (dimensionless or in its own unit).
const SHARED: [&str; 8] = [
    "bias_tau_s",
    "scale_pct",
    "cross_axis_pct",
    "misalignment_deg",
    "nonlinearity_pct_fs",
    "asymmetry_pct",
    "temp_scale_ppm_per_c",
    "flicker",
];

/// A value as the file gives it.
enum Val {
    Absent,
    Unknown,
    Num(f64),
}

struct Reader<'a> {
    t: &'a toml::Table,
    what: &'a str,
    /// `rins-sensor/2`: `"unknown"` allowed, a missing term unknown.
    v2: bool,
    /// The terms found unknown (`table.key`).
    unknown: core::cell::RefCell<Vec<String>>,
}

impl Reader<'_> {
    fn err(&self, m: String) -> SensorError {
        SensorError(format!("{}: {m}", self.what))
    }

    fn table(&self, name: Option<&str>) -> Result<Option<&toml::Table>, SensorError> {
        match name {
            None => Ok(Some(self.t)),
            Some(n) => match self.t.get(n) {
                None => Ok(None),
                Some(v) => v
                    .as_table()
                    .map(Some)
                    .ok_or_else(|| self.err(format!("{n} must be a table ([{n}])"))),
            },
        }
    }

    fn key_name(table: Option<&str>, key: &str) -> String {
        table.map_or(key.to_string(), |t| format!("{t}.{key}"))
    }

    /// Records `table.key` as unknown.
    fn mark(&self, table: &str, key: &str) {
        self.unknown.borrow_mut().push(format!("{table}.{key}"));
    }

    /// Refuses keys the format does not have (a misspelt key would
    /// otherwise be a silent zero).
    fn known(&self, table: Option<&str>, keys: &[&str]) -> Result<(), SensorError> {
        let Some(t) = self.table(table)? else {
            return Ok(());
        };
        match t.keys().find(|k| !keys.contains(&k.as_str())) {
            Some(k) => Err(self.err(format!(
                "unknown key {} (the format has: {})",
                Self::key_name(table, k),
                keys.join(", ")
            ))),
            None => Ok(()),
        }
    }

    /// The top-level `measured` list: strings, if present.
    fn measured(&self) -> Result<(), SensorError> {
        match self.t.get("measured") {
            None => Ok(()),
            Some(v) => match v.as_array() {
                Some(a) if a.iter().all(toml::Value::is_str) => Ok(()),
                _ => Err(self.err("measured must be an array of key names".into())),
            },
        }
    }

    fn str_at(&self, table: Option<&str>, key: &str) -> Result<Option<String>, SensorError> {
        let Some(t) = self.table(table)? else {
            return Ok(None);
        };
        match t.get(key) {
            None => Ok(None),
            Some(v) => v.as_str().map(|s| Some(s.to_string())).ok_or_else(|| {
                self.err(format!("{} must be a string", Self::key_name(table, key)))
            }),
        }
    }

    /// A finite number of either sign, `"unknown"` (`/2` only), or absent.
    fn val(&self, table: &str, key: &str) -> Result<Val, SensorError> {
        let Some(t) = self.table(Some(table))? else {
            return Ok(Val::Absent);
        };
        let name = Self::key_name(Some(table), key);
        match t.get(key) {
            None => Ok(Val::Absent),
            Some(v) if v.as_str() == Some(UNKNOWN) => match self.v2 {
                true => Ok(Val::Unknown),
                false => Err(self.err(format!("{name} = \"unknown\" needs format = {FORMAT:?}"))),
            },
            Some(v) => v
                .as_float()
                .or_else(|| v.as_integer().map(|i| i as f64))
                .filter(|x| x.is_finite())
                .map(Val::Num)
                .ok_or_else(|| self.err(format!("{name} must be a finite number or \"unknown\""))),
        }
    }

    /// A finite number of either sign; `"unknown"` is recorded and reads
    /// as absent.
    fn signed(&self, table: &str, key: &str) -> Result<Option<f64>, SensorError> {
        match self.val(table, key)? {
            Val::Absent => Ok(None),
            Val::Unknown => {
                self.mark(table, key);
                Ok(None)
            }
            Val::Num(x) => Ok(Some(x)),
        }
    }

    /// A finite, non-negative number (integers accepted).
    fn num(&self, table: &str, key: &str) -> Result<Option<f64>, SensorError> {
        match self.signed(table, key)? {
            Some(x) if x < 0.0 => Err(self.err(format!(
                "{} = {x}: must be finite and >= 0",
                Self::key_name(Some(table), key)
            ))),
            x => Ok(x),
        }
    }

    /// An error term: its value, or zero when unknown (recorded) or, in
    /// a `/1` file, absent; absent in a `/2` file it is unknown.
    fn term(&self, table: &str, key: &str) -> Result<f64, SensorError> {
        let x = self.num(table, key)?;
        if x.is_none() && self.v2 {
            self.mark(table, key);
        }
        Ok(x.unwrap_or(0.0))
    }

    /// The `[temperature]` table. A `/1` file's absent key is the
    /// simulator's default board ([`TempSpec::default`]); a `/2` file's
    /// is unknown: no warm-up, no reading's rounding, and the default
    /// room (a warm-up's time constant and ambient have no "none").
    fn temperature(&self) -> Result<TempSpec, SensorError> {
        let d = TempSpec::default();
        let get = |key: &str, default: f64, none: f64| -> Result<f64, SensorError> {
            Ok(match self.num("temperature", key)? {
                Some(x) => x,
                None if self.v2 => {
                    self.mark("temperature", key);
                    none
                }
                None => default,
            })
        };
        Ok(TempSpec {
            ambient_c: get("ambient_c", d.ambient_c, d.ambient_c)?,
            warmup_c: get("warmup_c", d.warmup_c, 0.0)?,
            warmup_tau_s: get("warmup_tau_s", d.warmup_tau_s, d.warmup_tau_s)?,
            lsb_c: get("lsb_c", d.lsb_c, 0.0)?,
        })
    }

    fn vec3(&self, table: &str, key: &str) -> Result<Option<[f64; 3]>, SensorError> {
        let Some(t) = self.table(Some(table))? else {
            return Ok(None);
        };
        let name = Self::key_name(Some(table), key);
        let Some(v) = t.get(key) else {
            return Ok(None);
        };
        let bad = || self.err(format!("{name} must be an array of three finite numbers"));
        let a = v.as_array().filter(|a| a.len() == 3).ok_or_else(bad)?;
        let mut out = [0.0; 3];
        for (o, x) in out.iter_mut().zip(a) {
            *o = x
                .as_float()
                .or_else(|| x.as_integer().map(|i| i as f64))
                .filter(|x| x.is_finite())
                .ok_or_else(bad)?;
        }
        Ok(Some(out))
    }

    /// The one key of `q` present (in SI); an error when two are. Unknown
    /// (or absent from a `/2` file): zero, recorded under `q`'s first key.
    fn quantity(&self, table: &str, q: &Quantity) -> Result<f64, SensorError> {
        let mut found: Option<(&str, Option<f64>)> = None;
        for (key, factor) in q.keys {
            let v = match self.val(table, key)? {
                Val::Absent => continue,
                Val::Unknown => None,
                Val::Num(x) if x < 0.0 => {
                    return Err(self.err(format!("{table}.{key} = {x}: must be finite and >= 0")))
                }
                Val::Num(x) => Some(x * factor),
            };
            if let Some((other, _)) = found {
                return Err(self.err(format!(
                    "{table}.{other} and {table}.{key} give the same quantity: keep one"
                )));
            }
            found = Some((key, v));
        }
        match found {
            Some((_, Some(x))) => Ok(x),
            Some((_, None)) => {
                self.mark(table, q.first().0);
                Ok(0.0)
            }
            None => {
                if self.v2 {
                    self.mark(table, q.first().0);
                }
                Ok(0.0)
            }
        }
    }

    /// The resolution: `lsb` or `sensitivity`, once.
    fn lsb(&self, table: &str, k: &TriadKeys) -> Result<f64, SensorError> {
        let canonical = k.lsb.first().0;
        let (lsb, sens) = (self.val(table, canonical)?, self.val(table, k.sensitivity)?);
        let factor = k.lsb.first().1;
        match (lsb, sens) {
            (Val::Num(l), Val::Absent) if l >= 0.0 => Ok(l * factor),
            (Val::Absent, Val::Num(s)) if s > 0.0 => Ok(k.unit / s),
            (Val::Unknown, Val::Absent) | (Val::Absent, Val::Unknown) => {
                self.mark(table, canonical);
                Ok(0.0)
            }
            (Val::Absent, Val::Absent) => {
                if self.v2 {
                    self.mark(table, canonical);
                }
                Ok(0.0)
            }
            _ => Err(self.err(format!(
                "{table}: give the resolution once (lsb or {}, > 0)",
                k.sensitivity
            ))),
        }
    }

    /// The misalignment: `cross_axis_pct` (the pair's, per entry / sqrt 2)
    /// or `misalignment_deg`, once.
    fn misalignment(&self, table: &str) -> Result<f64, SensorError> {
        let cross = self.num(table, "cross_axis_pct");
        let mis = self.num(table, "misalignment_deg");
        let unknown_before = self.unknown.borrow().len();
        let (cross, mis) = (cross?, mis?);
        let said_unknown = self.unknown.borrow().len() > unknown_before;
        Ok(match (cross, mis) {
            (Some(_), Some(_)) => {
                return Err(self.err(format!(
                    "{table}.cross_axis_pct and {table}.misalignment_deg give the same quantity: keep one"
                )))
            }
            (Some(c), None) => c / 100.0 / core::f64::consts::SQRT_2,
            (None, Some(m)) => m * DEG,
            (None, None) => {
                if self.v2 || said_unknown {
                    self.unknown.borrow_mut().retain(|u| {
                        u != &format!("{table}.cross_axis_pct")
                    });
                    self.mark(table, "misalignment_deg");
                }
                0.0
            }
        })
    }

    fn triad(&self, table: &str, k: &TriadKeys) -> Result<TriadSpec, SensorError> {
        let mut keys: Vec<&str> = SHARED.to_vec();
        for q in [
            &k.noise,
            &k.floor,
            &k.bias,
            &k.temp_bias,
            &k.rrw,
            &k.lsb,
            &k.full_scale,
        ] {
            keys.extend(q.keys.iter().map(|(n, _)| *n));
        }
        keys.push(k.sensitivity);
        keys.extend(k.extra);
        self.known(Some(table), &keys)?;
        let full_scale = self.quantity(table, &k.full_scale)?;
        let fs_key = k.full_scale.first().0;
        let fs_unknown = self.is_unknown(table, fs_key);
        let lsb = self.lsb(table, k)?;
        let nonlin = self.term(table, "nonlinearity_pct_fs")? / 100.0;
        if nonlin > 0.0 && (full_scale <= 0.0 || fs_unknown) {
            return Err(self.err(format!(
                "{table}.nonlinearity_pct_fs needs the full scale ({table}.{fs_key})"
            )));
        }
        let misalignment = self.misalignment(table)?;
        let flicker = match self.table(Some(table))?.and_then(|t| t.get("flicker")) {
            None => false,
            Some(v) => v
                .as_bool()
                .ok_or_else(|| self.err(format!("{table}.flicker must be true or false")))?,
        };
        Ok(TriadSpec {
            bias: self.quantity(table, &k.bias)?,
            scale: self.term(table, "scale_pct")? / 100.0,
            misalignment,
            k2: if nonlin > 0.0 {
                nonlin / full_scale
            } else {
                0.0
            },
            k3: 0.0,
            asymmetry: self.term(table, "asymmetry_pct")? / 100.0,
            white: self.quantity(table, &k.noise)?,
            bias_instability: self.quantity(table, &k.floor)? / ALLAN_PEAK_PER_GM_SIGMA,
            bi_tau_s: self.term(table, "bias_tau_s")?,
            flicker,
            rrw: self.quantity(table, &k.rrw)?,
            temp_bias: self.quantity(table, &k.temp_bias)?,
            temp_scale: self.term(table, "temp_scale_ppm_per_c")? / 1e6,
            lsb,
            full_scale,
        })
    }

    fn is_unknown(&self, table: &str, key: &str) -> bool {
        let k = format!("{table}.{key}");
        self.unknown.borrow().contains(&k)
    }
}

/// Where a written file's terms come from: the shipped sensor it starts
/// from (its name, for `base`), and the keys the writing tool measured
/// (`table.key`, the format's first key of each term).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Provenance {
    /// The shipped sensor the unmeasured terms come from.
    pub base: Option<String>,
    /// The keys measured.
    pub measured: Vec<String>,
}

/// A sensor file for `spec`: every term in the format's first unit (or
/// `"unknown"` where [`ImuSpec::unknown`] lists it), with `comment` lines
/// (where the figures come from) on top.
pub fn write(spec: &ImuSpec, comment: &[String]) -> String {
    write_with(spec, &Provenance::default(), comment)
}

/// [`write`] saying where each term comes from: `base` and `measured` at
/// the top, and each measured term marked `# measured` on its line.
pub fn write_with(spec: &ImuSpec, from: &Provenance, comment: &[String]) -> String {
    let mut s = String::new();
    for c in comment {
        s.push_str(&format!("# {c}\n"));
    }
    s.push_str(&format!("format = {FORMAT:?}\n"));
    if let Some(b) = &from.base {
        s.push_str(&format!("base = {b:?}\n"));
    }
    s.push_str(&format!(
        "name = {:?}\nmodel = {:?}\n",
        spec.name, spec.model
    ));
    if !from.measured.is_empty() {
        s.push_str(&format!("measured = {:?}\n", from.measured));
    }
    let line = |s: &mut String, table: &str, key: &str, v: f64| {
        let k = format!("{table}.{key}");
        if spec.unknown.contains(&k) {
            s.push_str(&format!("{key} = {UNKNOWN:?}\n"));
        } else if from.measured.contains(&k) {
            s.push_str(&format!("{key} = {v:?}  # measured\n"));
        } else {
            s.push_str(&format!("{key} = {v:?}\n"));
        }
    };
    let triad = |s: &mut String, table: &str, t: &TriadSpec, k: &TriadKeys| {
        for (q, v) in [
            (&k.noise, t.white),
            (&k.floor, t.bias_instability * ALLAN_PEAK_PER_GM_SIGMA),
            (&k.bias, t.bias),
            (&k.temp_bias, t.temp_bias),
            (&k.rrw, t.rrw),
            (&k.lsb, t.lsb),
            (&k.full_scale, t.full_scale),
        ] {
            let (key, f) = q.first();
            line(s, table, key, v / f);
        }
        line(s, table, "bias_tau_s", t.bi_tau_s);
        line(s, table, "scale_pct", t.scale * 100.0);
        line(s, table, "misalignment_deg", t.misalignment / DEG);
        if t.k2 == 0.0 {
            line(s, table, "nonlinearity_pct_fs", 0.0);
        } else if t.full_scale > 0.0 {
            line(s, table, "nonlinearity_pct_fs", t.k2 * t.full_scale * 100.0);
        } else {
            s.push_str(&format!("nonlinearity_pct_fs = {UNKNOWN:?}\n"));
        }
        line(s, table, "asymmetry_pct", t.asymmetry * 100.0);
        line(s, table, "temp_scale_ppm_per_c", t.temp_scale * 1e6);
        if t.flicker {
            s.push_str("flicker = true\n");
        }
    };
    s.push_str("\n[gyro]\n");
    triad(&mut s, "gyro", &spec.gyro, &GYRO);
    line(
        &mut s,
        "gyro",
        "g_sensitivity_dps_per_g",
        spec.g_sensitivity * G0 / DEG,
    );
    line(&mut s, "gyro", "latency_s", spec.latency_s);
    s.push_str("\n[accel]\n");
    triad(&mut s, "accel", &spec.accel, &ACCEL);
    if let Some(l) = spec.accel_latency_s {
        line(&mut s, "accel", "latency_s", l);
    }
    let t = &spec.temp;
    s.push_str("\n[timing]\n");
    line(&mut s, "timing", "jitter_s", spec.jitter_s);
    s.push_str("\n[temperature]\n");
    for (key, v) in [
        ("ambient_c", t.ambient_c),
        ("warmup_c", t.warmup_c),
        ("warmup_tau_s", t.warmup_tau_s),
        ("lsb_c", t.lsb_c),
    ] {
        line(&mut s, "temperature", key, v);
    }
    let m = &spec.mounting;
    s.push_str(&format!(
        "\n[mounting]\nimu_to_base_deg = {:?}\n",
        m.imu_to_base_deg
    ));
    if let Some(a) = m.antenna_b_m {
        s.push_str(&format!("antenna_b_m = {a:?}\n"));
    }
    s
}

/// Every term's key name as [`ImuSpec::unknown`] and
/// [`Provenance::measured`] spell it (`table.key`), per triad.
pub mod terms {
    /// White noise density.
    pub const GYRO_NOISE: &str = "gyro.noise_density_dps_rthz";
    /// See [`GYRO_NOISE`].
    pub const ACCEL_NOISE: &str = "accel.noise_density_ug_rthz";
    /// Bias instability (the Allan floor).
    pub const GYRO_FLOOR: &str = "gyro.bias_instability_deg_h";
    /// See [`GYRO_FLOOR`].
    pub const ACCEL_FLOOR: &str = "accel.bias_instability_mg";
    /// The floor's correlation time.
    pub const GYRO_TAU: &str = "gyro.bias_tau_s";
    /// See [`GYRO_TAU`].
    pub const ACCEL_TAU: &str = "accel.bias_tau_s";
    /// Rate random walk.
    pub const GYRO_RRW: &str = "gyro.rate_random_walk_dps_rts";
    /// See [`GYRO_RRW`].
    pub const ACCEL_RRW: &str = "accel.random_walk_mps2_rts";
    /// Turn-on bias.
    pub const GYRO_BIAS: &str = "gyro.turn_on_bias_dps";
    /// See [`GYRO_BIAS`].
    pub const ACCEL_BIAS: &str = "accel.turn_on_bias_mg";
    /// Scale factor error.
    pub const GYRO_SCALE: &str = "gyro.scale_pct";
    /// See [`GYRO_SCALE`].
    pub const ACCEL_SCALE: &str = "accel.scale_pct";
    /// Misalignment.
    pub const GYRO_MISALIGNMENT: &str = "gyro.misalignment_deg";
    /// See [`GYRO_MISALIGNMENT`].
    pub const ACCEL_MISALIGNMENT: &str = "accel.misalignment_deg";
    /// Resolution.
    pub const GYRO_LSB: &str = "gyro.lsb_dps";
    /// See [`GYRO_LSB`].
    pub const ACCEL_LSB: &str = "accel.lsb_mg";
    /// Full scale.
    pub const GYRO_FULL_SCALE: &str = "gyro.full_scale_dps";
    /// See [`GYRO_FULL_SCALE`].
    pub const ACCEL_FULL_SCALE: &str = "accel.full_scale_g";
    /// What a sensor must give to make noise (`rins simulate`).
    pub const NOISE: [&str; 2] = [GYRO_NOISE, ACCEL_NOISE];
    /// What the aided filter's noise model is made of.
    pub const FILTER: [&str; 10] = [
        GYRO_NOISE,
        ACCEL_NOISE,
        GYRO_FLOOR,
        ACCEL_FLOOR,
        GYRO_BIAS,
        ACCEL_BIAS,
        GYRO_SCALE,
        ACCEL_SCALE,
        GYRO_MISALIGNMENT,
        ACCEL_MISALIGNMENT,
    ];
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_shipped_file_reads_and_names_itself() {
        for (name, text) in SHIPPED {
            let s = parse(text, name).unwrap();
            assert_eq!(s.name, name);
        }
    }

    #[test]
    fn datasheet_units_become_si_exactly() {
        let s = resolve("icm42688").unwrap();
        assert_eq!(s.gyro.white, 0.0028 * DEG);
        assert_eq!(s.gyro.bias_instability, 5.0 * DPH / 0.62);
        assert_eq!(s.gyro.misalignment, 1.25e-2 / core::f64::consts::SQRT_2);
        assert_eq!(s.accel.bias, 20e-3 * G0);
        assert_eq!(s.accel.white, 70e-6 * G0);
        assert_eq!(s.gyro.lsb, DEG / 16.4);
        assert_eq!(s.accel.lsb, G0 / 2048.0);
        let n = resolve("nav440").unwrap();
        assert_eq!(n.gyro.white, 0.4 * DEG / 60.0);
    }

    #[test]
    fn a_written_file_reads_back() {
        for name in names() {
            let s = resolve(name).unwrap();
            let back = parse(&write(&s, &["test".into()]), "back").unwrap();
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(b.abs());
            for (x, y) in [(&s.gyro, &back.gyro), (&s.accel, &back.accel)] {
                for (a, b) in [
                    (x.white, y.white),
                    (x.bias_instability, y.bias_instability),
                    (x.bias, y.bias),
                    (x.scale, y.scale),
                    (x.misalignment, y.misalignment),
                    (x.k2, y.k2),
                    (x.lsb, y.lsb),
                    (x.full_scale, y.full_scale),
                    (x.temp_bias, y.temp_bias),
                ] {
                    assert!(close(a, b), "{name}: {a} != {b}");
                }
            }
            assert!(close(s.g_sensitivity, back.g_sensitivity));
            assert_eq!(s.mounting, back.mounting);
        }
    }

    #[test]
    fn a_file_can_start_from_a_shipped_sensor() {
        let text = "format = \"rins-sensor/1\"\nbase = \"icm42605\"\nname = \"walk\"\n[gyro]\nnoise_density_dps_rthz = 0.005\n[mounting]\nimu_to_base_deg = [180, 0, -90]\n";
        let s = parse(text, "walk.toml").unwrap();
        let b = resolve("icm42605").unwrap();
        assert_eq!(s.name, "walk");
        assert_eq!(s.model, b.model);
        assert_eq!(s.gyro.white, 0.005 * DEG);
        assert_eq!(s.gyro.bias, b.gyro.bias);
        assert_eq!(s.accel, b.accel);
        assert_eq!(s.mounting.imu_to_base_deg, [180.0, 0.0, -90.0]);
        let e = parse("format = \"rins-sensor/1\"\nbase = \"nope\"\n", "f").unwrap_err();
        assert!(e.0.contains("not a shipped sensor"), "{e}");
    }

    #[test]
    fn bad_files_name_the_key() {
        let base = "format = \"rins-sensor/1\"\n[gyro]\n";
        let e = parse(&format!("{base}noise_density_dps = 1\n"), "f.toml").unwrap_err();
        assert!(
            e.0.contains("f.toml") && e.0.contains("gyro.noise_density_dps"),
            "{e}"
        );
        let e = parse(&format!("{base}scale_pct = -1\n"), "f.toml").unwrap_err();
        assert!(e.0.contains("gyro.scale_pct"), "{e}");
        let e = parse(
            &format!("{base}arw_deg_rth = 1\nnoise_density_dps_rthz = 1\n"),
            "f",
        )
        .unwrap_err();
        assert!(e.0.contains("keep one"), "{e}");
        let e = parse("format = \"x\"\n", "f").unwrap_err();
        assert!(e.0.contains("rins-sensor/1"), "{e}");
        let e = parse(&format!("{base}nonlinearity_pct_fs = 0.1\n"), "f").unwrap_err();
        assert!(e.0.contains("full scale"), "{e}");
        let e = parse(
            "format = \"rins-sensor/1\"\n[mounting]\nimu_to_base_deg = [1, 2]\n",
            "f",
        )
        .unwrap_err();
        assert!(e.0.contains("mounting.imu_to_base_deg"), "{e}");
    }

    #[test]
    fn version_2_says_unknown_and_a_missing_term_is_unknown() {
        let text = "format = \"rins-sensor/2\"\nname = \"m\"\n[gyro]\nnoise_density_dps_rthz = 0.01\nfull_scale_dps = \"unknown\"\n[accel]\nnoise_density_ug_rthz = 80\n";
        let s = parse(text, "m.toml").unwrap();
        assert_eq!(s.gyro.white, 0.01 * DEG);
        assert!(s.unknown.contains(&terms::GYRO_FULL_SCALE.to_string()));
        // Missing error terms are unknown, not zero...
        for t in [
            terms::GYRO_FLOOR,
            terms::ACCEL_BIAS,
            terms::GYRO_SCALE,
            terms::ACCEL_LSB,
        ] {
            assert!(s.unknown.contains(&t.to_string()), "{t}: {:?}", s.unknown);
        }
        assert!(!s.unknown.contains(&terms::GYRO_NOISE.to_string()));
        // ...as are the stamps' jitter and the board's warm-up (simulated
        // as none, and written back as unknown)...
        for t in [
            "timing.jitter_s",
            "temperature.warmup_c",
            "temperature.lsb_c",
        ] {
            assert!(s.unknown.contains(&t.to_string()), "{t}: {:?}", s.unknown);
        }
        assert_eq!((s.jitter_s, s.temp.warmup_c), (0.0, 0.0));
        let back = write(&s, &[]);
        assert!(back.contains("jitter_s = \"unknown\""), "{back}");
        assert!(back.contains("warmup_c = \"unknown\""), "{back}");
        // ...while the latency (the stamps are the samples' instants
        // unless said) and the mounting are zeros by convention.
        assert!(!s.unknown.iter().any(|u| u.ends_with("latency_s")));
        assert_eq!(s.latency_s, 0.0);
        let e = s.require(&terms::FILTER, "the aided filter").unwrap_err();
        assert!(
            e.0.contains(terms::GYRO_FLOOR) && !e.0.contains(terms::GYRO_NOISE),
            "{e}"
        );
        assert!(s.require(&terms::NOISE, "simulate").is_ok());
        // "unknown" in a version 1 file is refused, naming the key.
        let e = parse(&text.replace("/2", "/1"), "m.toml").unwrap_err();
        assert!(
            e.0.contains("gyro.full_scale_dps") && e.0.contains("rins-sensor/2"),
            "{e}"
        );
    }

    #[test]
    fn a_base_gives_every_term_and_unknown_survives_a_round_trip() {
        // A /2 file on a shipped base: the base's zeros are zeros.
        let text = "format = \"rins-sensor/2\"\nbase = \"icm42605\"\nname = \"u\"\n[gyro]\nnoise_density_dps_rthz = 0.005\nscale_pct = \"unknown\"\n";
        let s = parse(text, "u.toml").unwrap();
        assert_eq!(s.unknown, vec![terms::GYRO_SCALE.to_string()]);
        assert_eq!(s.gyro.rrw, 0.0);
        let prov = Provenance {
            base: Some("icm42605".into()),
            measured: vec![terms::GYRO_NOISE.into()],
        };
        let w = write_with(&s, &prov, &["t".into()]);
        assert!(w.contains("scale_pct = \"unknown\""), "{w}");
        assert!(
            w.contains("noise_density_dps_rthz = 0.005  # measured"),
            "{w}"
        );
        assert!(
            w.contains("measured = [\"gyro.noise_density_dps_rthz\"]"),
            "{w}"
        );
        let back = parse(&w, "back").unwrap();
        assert_eq!(back.unknown, s.unknown);
        assert_eq!(back.gyro.white, s.gyro.white);
    }

    #[test]
    fn the_walks_mounting_turns_z_up_into_minus_g_down() {
        // The walk's IMU: +z up reads +1 g at rest; mounted [180, 0, -90]
        // its specific force in b (FRD) must be [0, 0, -g].
        let m = Mounting {
            imu_to_base_deg: [180.0, 0.0, -90.0],
            antenna_b_m: None,
        };
        let f_b = m.c_s_b() * nalgebra::Vector3::new(0.0, 0.0, G0);
        assert!((f_b - nalgebra::Vector3::new(0.0, 0.0, -G0)).norm() < 1e-12);
        // x of s is -y of b, y of s is -x of b (the author's C).
        let x_b = m.c_s_b() * nalgebra::Vector3::x();
        assert!((x_b + nalgebra::Vector3::y()).norm() < 1e-12, "{x_b}");
    }
}

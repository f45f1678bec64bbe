//! Sensor files (`rins-sensor/1`, TOML): a unit's error budget in the
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

use crate::imu::{ImuSpec, TempSpec, TriadSpec};
use std::path::Path;

const DEG: f64 = core::f64::consts::PI / 180.0;
const DPH: f64 = DEG / 3600.0;
/// Standard gravity, m/s^2 (the `g` of datasheets' mg and ug).
pub const G0: f64 = 9.806_65;
/// A first-order Gauss-Markov process's Allan deviation peaks at 0.62 of
/// its sigma (at 1.89 tau): a datasheet's or `rins allan`'s bias
/// instability (the Allan floor) is this fraction of the process's sigma.
pub const ALLAN_PEAK_PER_GM_SIGMA: f64 = 0.62;

/// The format's name (`format = ...`).
pub const FORMAT: &str = "rins-sensor/1";

/// The shipped sensor files, by name.
pub const SHIPPED: [(&str, &str); 6] = [
    ("ideal", include_str!("../../sensors/ideal.toml")),
    ("mtig", include_str!("../../sensors/mtig.toml")),
    ("nav440", include_str!("../../sensors/nav440.toml")),
    ("adis16405", include_str!("../../sensors/adis16405.toml")),
    ("icm42688", include_str!("../../sensors/icm42688.toml")),
    ("icm42605", include_str!("../../sensors/icm42605.toml")),
];

/// How the IMU sits on its base: `C_s^b` and the antenna.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Mounting {
    /// ZYX Euler angles of the IMU's axes `s` in the base `b`, deg (roll,
    /// pitch, yaw: `C_s^b = Rz(yaw) Ry(pitch) Rx(roll)`, as `[base]` gives
    /// `b` in `n`). Zero: `s` = `b`.
    pub imu_to_base_deg: [f64; 3],
    /// The GNSS antenna's position from the IMU, in `b`, m (`None`: the
    /// recording's `[gnss] antenna_b_m`).
    pub antenna_b_m: Option<[f64; 3]>,
}

impl Mounting {
    /// Whether `s` = `b`.
    pub fn is_identity(&self) -> bool {
        self.imu_to_base_deg == [0.0; 3]
    }

    /// `C_s^b`.
    pub fn c_s_b(&self) -> nalgebra::Matrix3<f64> {
        let [r, p, y] = self.imu_to_base_deg;
        let e = core_nav::attitude::Euler::<f64>::from_deg(r, p, y);
        core_nav::attitude::quat_to_dcm(&core_nav::attitude::euler_to_quat(&e))
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
/// # Errors
/// Not TOML, another format, a missing or unknown key, a value of the
/// wrong type, a negative magnitude.
pub fn parse(text: &str, what: &str) -> Result<ImuSpec, SensorError> {
    let err = |m: String| SensorError(format!("{what}: {m}"));
    let mut t: toml::Table = text.parse().map_err(|e| err(format!("{e}")))?;
    if let Some(b) = t.remove("base") {
        t = inherit(&b, t).map_err(err)?;
    }
    let mut r = Reader { t: &t, what };
    match r.str_at(None, "format")? {
        Some(f) if f == FORMAT => {}
        Some(f) => return Err(err(format!("format is {f:?}, expected {FORMAT:?}"))),
        None => return Err(err(format!("missing key format (= {FORMAT:?})"))),
    }
    r.known(
        None,
        &[
            "format",
            "name",
            "model",
            "gyro",
            "accel",
            "timing",
            "temperature",
            "mounting",
        ],
    )?;
    let name = r.str_at(None, "name")?.unwrap_or_else(|| what.to_string());
    let model = r.str_at(None, "model")?.unwrap_or_else(|| name.clone());
    let gyro = r.triad("gyro", &GYRO)?;
    let accel = r.triad("accel", &ACCEL)?;
    let g_sensitivity = r.num("gyro", "g_sensitivity_dps_per_g")?.unwrap_or(0.0) * DEG / G0;
    // Latencies are signed (a stamp taken late makes a sample early).
    let latency_s = r.signed("gyro", "latency_s")?.unwrap_or(0.0);
    let accel_latency_s = r.signed("accel", "latency_s")?;
    r.known(Some("timing"), &["jitter_s"])?;
    let jitter_s = r.num("timing", "jitter_s")?.unwrap_or(0.0);
    let d = TempSpec::default();
    r.known(
        Some("temperature"),
        &["ambient_c", "warmup_c", "warmup_tau_s", "lsb_c"],
    )?;
    let temp = TempSpec {
        ambient_c: r.num("temperature", "ambient_c")?.unwrap_or(d.ambient_c),
        warmup_c: r.num("temperature", "warmup_c")?.unwrap_or(d.warmup_c),
        warmup_tau_s: r
            .num("temperature", "warmup_tau_s")?
            .unwrap_or(d.warmup_tau_s),
        lsb_c: r.num("temperature", "lsb_c")?.unwrap_or(d.lsb_c),
    };
    r.known(Some("mounting"), &["imu_to_base_deg", "antenna_b_m"])?;
    let mounting = Mounting {
        imu_to_base_deg: r.vec3("mounting", "imu_to_base_deg")?.unwrap_or([0.0; 3]),
        antenna_b_m: r.vec3("mounting", "antenna_b_m")?,
    };
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
    })
}

/// A file that starts from a shipped sensor (`base = "icm42605"`): the
/// shipped file's tables with this file's keys over them (a user's unit of
/// a known chip: its own mounting, lever arm or measured noise).
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
    let mut t: toml::Table = text
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
/// them, or none for zero) and each key's factor to SI.
struct Quantity {
    keys: &'static [(&'static str, f64)],
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

struct Reader<'a> {
    t: &'a toml::Table,
    what: &'a str,
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

    /// A finite number of either sign.
    fn signed(&self, table: &str, key: &str) -> Result<Option<f64>, SensorError> {
        let Some(t) = self.table(Some(table))? else {
            return Ok(None);
        };
        let name = Self::key_name(Some(table), key);
        match t.get(key) {
            None => Ok(None),
            Some(v) => v
                .as_float()
                .or_else(|| v.as_integer().map(|i| i as f64))
                .filter(|x| x.is_finite())
                .map(Some)
                .ok_or_else(|| self.err(format!("{name} must be a finite number"))),
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

    /// The one key of `q` present (in SI), zero when none is; an error
    /// when two are.
    fn quantity(&self, table: &str, q: &Quantity) -> Result<f64, SensorError> {
        let mut found: Option<(&str, f64)> = None;
        for (key, factor) in q.keys {
            if let Some(x) = self.num(table, key)? {
                if let Some((other, _)) = found {
                    return Err(self.err(format!(
                        "{table}.{other} and {table}.{key} give the same quantity: keep one"
                    )));
                }
                found = Some((key, x * factor));
            }
        }
        Ok(found.map_or(0.0, |(_, x)| x))
    }

    fn triad(&mut self, table: &str, k: &TriadKeys) -> Result<TriadSpec, SensorError> {
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
        let n = |key: &str| self.num(table, key).map(|x| x.unwrap_or(0.0));
        let full_scale = self.quantity(table, &k.full_scale)?;
        let lsb = match (
            self.quantity(table, &k.lsb)?,
            self.num(table, k.sensitivity)?,
        ) {
            (l, None) => l,
            (0.0, Some(s)) if s > 0.0 => k.unit / s,
            _ => {
                return Err(self.err(format!(
                    "{table}: give the resolution once (lsb or {})",
                    k.sensitivity
                )))
            }
        };
        let nonlin = n("nonlinearity_pct_fs")? / 100.0;
        if nonlin > 0.0 && full_scale <= 0.0 {
            return Err(self.err(format!(
                "{table}.nonlinearity_pct_fs needs the full scale ({table}.{})",
                k.full_scale.keys.first().map_or("", |(n, _)| *n)
            )));
        }
        let misalignment = match (self.num(table, "cross_axis_pct")?, self.num(table, "misalignment_deg")?) {
            (Some(_), Some(_)) => {
                return Err(self.err(format!(
                    "{table}.cross_axis_pct and {table}.misalignment_deg give the same quantity: keep one"
                )))
            }
            (Some(c), None) => c / 100.0 / core::f64::consts::SQRT_2,
            (None, Some(m)) => m * DEG,
            (None, None) => 0.0,
        };
        let flicker = match self.table(Some(table))?.and_then(|t| t.get("flicker")) {
            None => false,
            Some(v) => v
                .as_bool()
                .ok_or_else(|| self.err(format!("{table}.flicker must be true or false")))?,
        };
        Ok(TriadSpec {
            bias: self.quantity(table, &k.bias)?,
            scale: n("scale_pct")? / 100.0,
            misalignment,
            k2: if nonlin > 0.0 {
                nonlin / full_scale
            } else {
                0.0
            },
            k3: 0.0,
            asymmetry: n("asymmetry_pct")? / 100.0,
            white: self.quantity(table, &k.noise)?,
            bias_instability: self.quantity(table, &k.floor)? / ALLAN_PEAK_PER_GM_SIGMA,
            bi_tau_s: n("bias_tau_s")?,
            flicker,
            rrw: self.quantity(table, &k.rrw)?,
            temp_bias: self.quantity(table, &k.temp_bias)?,
            temp_scale: n("temp_scale_ppm_per_c")? / 1e6,
            lsb,
            full_scale,
        })
    }
}

/// A sensor file for `spec` (`rins allan --sensor-out`, `rins diagnose
/// --sensor-out`): every quantity in the format's first unit, with
/// `comment` lines (where the figures come from) on top.
pub fn write(spec: &ImuSpec, comment: &[String]) -> String {
    let mut s = String::new();
    for c in comment {
        s.push_str(&format!("# {c}\n"));
    }
    s.push_str(&format!(
        "format = {FORMAT:?}\nname = {:?}\nmodel = {:?}\n",
        spec.name, spec.model
    ));
    let triad = |s: &mut String, t: &TriadSpec, k: &TriadKeys| {
        let first = |q: &Quantity| q.keys.first().copied().unwrap_or(("", 1.0));
        let mut line = |key: &str, v: f64| s.push_str(&format!("{key} = {v:?}\n"));
        for (q, v) in [
            (&k.noise, t.white),
            (&k.floor, t.bias_instability * ALLAN_PEAK_PER_GM_SIGMA),
            (&k.bias, t.bias),
            (&k.temp_bias, t.temp_bias),
            (&k.rrw, t.rrw),
            (&k.lsb, t.lsb),
            (&k.full_scale, t.full_scale),
        ] {
            let (key, f) = first(q);
            line(key, v / f);
        }
        line("bias_tau_s", t.bi_tau_s);
        line("scale_pct", t.scale * 100.0);
        line("misalignment_deg", t.misalignment / DEG);
        if t.full_scale > 0.0 {
            line("nonlinearity_pct_fs", t.k2 * t.full_scale * 100.0);
        }
        line("asymmetry_pct", t.asymmetry * 100.0);
        line("temp_scale_ppm_per_c", t.temp_scale * 1e6);
        if t.flicker {
            s.push_str("flicker = true\n");
        }
    };
    s.push_str("\n[gyro]\n");
    triad(&mut s, &spec.gyro, &GYRO);
    s.push_str(&format!(
        "g_sensitivity_dps_per_g = {:?}\nlatency_s = {:?}\n",
        spec.g_sensitivity * G0 / DEG,
        spec.latency_s
    ));
    s.push_str("\n[accel]\n");
    triad(&mut s, &spec.accel, &ACCEL);
    if let Some(l) = spec.accel_latency_s {
        s.push_str(&format!("latency_s = {l:?}\n"));
    }
    let t = &spec.temp;
    s.push_str(&format!(
        "\n[timing]\njitter_s = {:?}\n\n[temperature]\nambient_c = {:?}\nwarmup_c = {:?}\nwarmup_tau_s = {:?}\nlsb_c = {:?}\n",
        spec.jitter_s, t.ambient_c, t.warmup_c, t.warmup_tau_s, t.lsb_c
    ));
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

//! The nominal model a recording is compared with ([`Model`], from TOML),
//! the options of a diagnosis, and the known effects subtracted from the
//! measurements.

use super::effects::{self, Candidate};
use super::{DiagnoseError, Prediction};
use hal_sim::catalogue::EffectId;
use std::collections::BTreeMap;

/// The nominal model: the spec's (gravity, earth rate, table motion, bias,
/// scale, misalignment, white noise) plus effects it already contains.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// The site's earth rate is in the model.
    pub earth_rate: bool,
    /// Effects the model contains, with their parameters (names as in the
    /// report; parameters not given are 0).
    pub known: BTreeMap<String, BTreeMap<String, f64>>,
}

impl Default for Model {
    fn default() -> Self {
        Self {
            earth_rate: true,
            known: BTreeMap::new(),
        }
    }
}

impl Model {
    /// Parses a model file:
    ///
    /// ```toml
    /// earth_rate = true                # default
    /// [known.lever_arm]                # effects the model already has
    /// lever_x_m = 0.02
    /// [known.time_offset]
    /// time_offset_s = 0.002
    /// ```
    ///
    /// # Errors
    /// Bad TOML, an unknown key, effect id or parameter, a non-number.
    pub fn from_toml(text: &str) -> Result<Self, DiagnoseError> {
        Self::parse(text).map_err(DiagnoseError::Model)
    }

    fn parse(text: &str) -> Result<Self, String> {
        let t: toml::Table = text.parse().map_err(|e| format!("{e}"))?;
        let mut m = Self::default();
        for (k, v) in &t {
            match k.as_str() {
                "earth_rate" => {
                    m.earth_rate = v.as_bool().ok_or("earth_rate: expected true or false")?;
                }
                "known" => {
                    let tab = v.as_table().ok_or("known: expected a table of effects")?;
                    for (id, params) in tab {
                        if !EffectId::parse(id).is_some_and(EffectId::is_deterministic) {
                            return Err(format!(
                                "known.{id}: not an effect id with parameters; known: {}",
                                EffectId::ALL
                                    .iter()
                                    .filter(|e| e.is_deterministic())
                                    .map(|e| e.as_str())
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            ));
                        }
                        let pt = params
                            .as_table()
                            .ok_or_else(|| format!("known.{id}: expected parameters"))?;
                        let mut ps = BTreeMap::new();
                        for (pn, pv) in pt {
                            let x = pv
                                .as_float()
                                .or_else(|| pv.as_integer().map(|i| i as f64))
                                .filter(|x| x.is_finite())
                                .ok_or_else(|| format!("known.{id}.{pn}: expected a number"))?;
                            ps.insert(pn.clone(), x);
                        }
                        m.known.insert(id.clone(), ps);
                    }
                }
                other => {
                    return Err(format!(
                        "unknown key {other:?} (expected earth_rate, known)"
                    ))
                }
            }
        }
        Ok(m)
    }
}

/// How to diagnose.
#[derive(Clone, Debug)]
pub struct Options {
    /// The nominal model.
    pub model: Model,
    /// Block length for the regression, s (the residual is averaged over
    /// blocks; the noise model is fitted to the block means).
    pub block_s: f64,
    /// Contiguous held-out segments.
    pub folds: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            model: Model::default(),
            block_s: 0.2,
            folds: 5,
        }
    }
}

/// The known effects' contribution, subtracted from the measurements.
pub(super) fn apply_known(p: &mut Prediction, model: &Model) -> Result<(), DiagnoseError> {
    for (id, params) in &model.known {
        if id == "time_offset" || id == "earth_rate" {
            continue; // in the prediction itself
        }
        let cands: Vec<Candidate> = effects::library(p)
            .into_iter()
            .filter(|c| c.id == id.as_str())
            .collect();
        for c in &cands {
            let names = c.params(p);
            let terms = c.terms(p);
            for (pi, pname) in names.iter().enumerate() {
                let Some(v) = params.get(pname) else { continue };
                for t in terms.iter().filter(|t| t.param == pi) {
                    let n = t.col.len();
                    let known = &mut p.known[t.ch];
                    known.resize(n, 0.0);
                    for (r, x) in t.col.iter().enumerate() {
                        known[r] += v * x;
                        if t.ch < 3 {
                            p.y_w[r][t.ch] -= v * x;
                        } else {
                            p.y_f[r][t.ch - 3] -= v * x;
                        }
                    }
                }
            }
        }
        let all: Vec<String> = cands.iter().flat_map(|c| c.params(p)).collect();
        if let Some(bad) = params.keys().find(|k| !all.contains(k)) {
            return Err(DiagnoseError::Model(format!(
                "known.{id}.{bad} is not a parameter of {id} in this run; its parameters: {}",
                all.join(", ")
            )));
        }
    }
    Ok(())
}

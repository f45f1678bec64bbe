//! `rins diagnose`: every effect id hidden in a simulated run is named
//! first with its parameters inside their confidence intervals; nulls give
//! no finding; the JSON has the spec's shape exactly; the ADIS16405 bench
//! hour shows bias instability.

use core_nav::table::Axis;
use hal_sim::catalogue::EffectId;
use hal_sim::imu::ImuSpec;
use hal_sim::sim::{simulate, SimConfig};
use rins::diagnose::{run, Diagnosis, Model, Options};

/// The nominal model's terms (NAV440 bias, scale, misalignment), white
/// noise, and (if `wander`) its gyro bias instability; a reciprocating run
/// (60 deg/s, two turns each way) after a 30 s still phase, about `axis`;
/// the default table (motor, servo, 14-bit encoder).
fn config(axis: Axis, wander: bool, seed: u64, duration_s: f64) -> SimConfig {
    rins_tests::runs::reduced_nav440(axis, wander, seed, duration_s)
}

fn diagnose(c: &SimConfig, model: Model) -> Diagnosis {
    let rec = simulate(c, &mut |_| {}).unwrap();
    run(
        &rec,
        "test",
        &Options {
            model,
            ..Options::default()
        },
    )
    .unwrap()
}

fn named(d: &Diagnosis) -> Vec<&str> {
    d.findings
        .iter()
        .map(|f| f.effect.as_str())
        .filter(|e| *e != "bias_instability")
        .collect()
}

/// A parameter and its 1-sigma.
fn param(d: &Diagnosis, effect: &str, name: &str) -> (f64, f64) {
    let p = d.parameter(EffectId::parse(effect).unwrap(), name).unwrap();
    (p.value, p.sigma.unwrap())
}

/// Inside the confidence interval: 3 sigma (99.7 %) of the fit's own
/// covariance, plus 2 % of the truth for what the covariance does not hold
/// (regressors built from encoder rates, first-order terms).
fn inside(est: (f64, f64), truth: f64, what: &str) {
    let (v, s) = est;
    assert!(
        (v - truth).abs() <= 3.0 * s + 0.02 * truth.abs(),
        "{what}: {v:.4e} +- {s:.1e} against {truth:.4e}"
    );
}

#[test]
fn each_effect_is_named_first_with_its_parameters() {
    let deg = 1f64.to_radians();
    let pattern = [[1.0, -1.0, 1.0], [1.0, 1.0, -1.0], [-1.0, 1.0, 1.0]];
    for (effect, v, axis) in [
        ("lever_arm", 0.02, Axis::Z),
        ("time_offset", 0.002, Axis::Z),
        ("gyro_scale_nonlinearity", 0.003, Axis::Z),
        ("gyro_scale_asymmetry", 0.003, Axis::Z),
        ("axis_tilt", 0.002, Axis::Z),
        ("encoder_error", 2e-4, Axis::Z),
        ("temperature_bias", 5e-4, Axis::Z),
        ("gyro_g_sensitivity", 2e-4, Axis::Y),
        ("accel_scale_nonlinearity", 2e-4, Axis::Y),
    ] {
        let mut c = config(axis, true, 11, 600.0);
        c.set_effect(effect, v).unwrap();
        let d = diagnose(&c, Model::default());
        let found = named(&d);
        println!("{effect}: {found:?}");
        assert_eq!(found.first().copied(), Some(effect), "{effect}: {found:?}");
        let hyp = |a: &str, b: &str| {
            let (x, sx) = param(&d, effect, a);
            let (y, sy) = param(&d, effect, b);
            (x.hypot(y), sx.max(sy))
        };
        match effect {
            "lever_arm" => inside(param(&d, effect, "lever_x_m"), v, effect),
            "time_offset" => inside(param(&d, effect, "time_offset_s"), v, effect),
            "gyro_scale_nonlinearity" => inside(param(&d, effect, "k2_z_per_radps"), v, effect),
            "gyro_scale_asymmetry" => inside(param(&d, effect, "asymmetry_z"), v, effect),
            "axis_tilt" => inside(hyp("tilt_about_x_rad", "tilt_about_y_rad"), v, effect),
            "encoder_error" => inside(hyp("encoder_cos_rad", "encoder_sin_rad"), v, effect),
            "temperature_bias" => {
                // The warm-up's one exponential looks like slow drift over
                // 10 minutes, which the fit's covariance does not hold:
                // over nine seeds the coefficient was off by up to 11 %
                // (5 % RMS, 0.97 on average) against sigmas of 2-7 %.
                for a in ["x", "y", "z"] {
                    let (x, sx) = param(&d, effect, &format!("temp_bias_{a}_radps_per_degc"));
                    assert!(
                        (x - v).abs() <= 3.0 * sx + 0.1 * v,
                        "{effect} {a}: {x:.4e} +- {sx:.1e} against {v:.4e}"
                    );
                }
            }
            "gyro_g_sensitivity" => {
                // About y, gravity sweeps x and z: those columns are excited.
                for (i, a) in ["x", "y", "z"].iter().enumerate() {
                    for (j, b) in [(0, "x"), (2, "z")] {
                        let name = format!("g_sens_{a}{b}_radps_per_mps2");
                        inside(param(&d, effect, &name), v * pattern[i][j], &name);
                    }
                }
            }
            "accel_scale_nonlinearity" => {
                for a in ["x", "z"] {
                    inside(param(&d, effect, &format!("k2_{a}_per_mps2")), v, effect);
                }
            }
            _ => unreachable!(),
        }
        let _ = deg;
    }
}

#[test]
fn earth_rate_left_out_of_the_model_is_named() {
    // The model says the earth does not turn; the recording says it does.
    let c = config(Axis::Z, false, 12, 600.0);
    let d = diagnose(
        &c,
        Model {
            earth_rate: false,
            ..Model::default()
        },
    );
    assert_eq!(
        named(&d).first().copied(),
        Some("earth_rate"),
        "{:?}",
        named(&d)
    );
    // Only the horizontal part turns through the gyros on a vertical axis;
    // the fitted magnitude is the earth's rate.
    inside(
        param(&d, "earth_rate", "earth_rate_radps"),
        core_nav::earth::EARTH_RATE_RADPS,
        "earth rate",
    );
}

#[test]
fn bias_instability_is_named_with_its_parameters() {
    let c = config(Axis::Z, true, 13, 1200.0);
    let d = diagnose(&c, Model::default());
    let f = d
        .findings
        .iter()
        .find(|f| f.effect == "bias_instability")
        .expect("bias instability");
    let truth = ImuSpec::nav440().gyro.bias_instability;
    for a in ["x", "y"] {
        let s = f.value(&format!("gm_sigma_{a}_radps")).unwrap();
        // One 20-minute run holds ~20 correlation times of 60 s, but the
        // flicker bank's slowest member (30 x 60 s) is longer than the run:
        // over nine seeds the fitted sigma was 0.61 to 1.81 of the truth.
        assert!(
            (0.5..2.0).contains(&(s / truth)),
            "{a}: {s:.3e} vs {truth:.3e}"
        );
    }
    assert!(f.fit.heldout_rms_after < f.fit.heldout_rms_before);
    assert!(named(&d).is_empty(), "{:?}", named(&d));
}

#[test]
fn nulls_give_no_finding() {
    for seed in [21, 22, 23] {
        // White noise only: nothing at all.
        let d = diagnose(&config(Axis::Z, false, seed, 600.0), Model::default());
        assert!(d.findings.is_empty(), "white null {seed}: {:?}", d.findings);
        // With the wandering bias: only bias_instability.
        let d = diagnose(&config(Axis::Z, true, seed, 600.0), Model::default());
        assert!(named(&d).is_empty(), "wander null {seed}: {:?}", named(&d));
    }
}

#[test]
fn a_still_perfect_table_names_nothing() {
    // The issue's null: a table that never turns and hides nothing (the
    // nominal model's terms, white noise, and with `wander` its bias
    // instability), 600 s: no effect named (bias instability only when
    // the bias wanders), whatever the seed.
    for seed in [31, 32, 33] {
        for wander in [false, true] {
            let mut c = config(Axis::Z, wander, seed, 600.0);
            c.scheme = core_nav::scheme::Scheme::Still;
            let d = diagnose(&c, Model::default());
            assert!(d.unexplained.is_empty(), "{:?}", d.unexplained);
            match wander {
                false => assert!(d.findings.is_empty(), "still {seed}: {:?}", d.findings),
                true => assert!(
                    named(&d).is_empty(),
                    "still, wander {seed}: {:?}",
                    named(&d)
                ),
            }
        }
    }
}

#[test]
fn known_effects_in_the_model_are_not_reported_again() {
    let mut c = config(Axis::Z, false, 14, 600.0);
    c.set_effect("lever_arm", 0.02).unwrap();
    let m = Model::from_toml("earth_rate = true\n[known.lever_arm]\nlever_x_m = 0.02\n").unwrap();
    let d = diagnose(&c, m);
    assert!(d.findings.is_empty(), "{:?}", d.findings);
    // A bad model is an error, not a silent default.
    assert!(Model::from_toml("[known.lever]\nx = 1\n").is_err());
    assert!(Model::from_toml("earth_rate = 3\n").is_err());
}

/// The key structure of a JSON value: objects by their keys (recursively),
/// arrays by their first element.
fn shape(v: &serde_json::Value, path: &str, out: &mut Vec<String>) {
    match v {
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                // Maps keyed by channel or parameter name are open.
                let open = [
                    "residual_rms",
                    "parameters",
                    "residual_rms_before",
                    "residual_rms_after",
                ]
                .contains(&k.as_str());
                out.push(format!("{path}.{k}"));
                if !open {
                    shape(x, &format!("{path}.{k}"), out);
                }
            }
        }
        serde_json::Value::Array(a) => {
            if let Some(x) = a.first() {
                shape(x, &format!("{path}[]"), out);
            }
        }
        _ => {}
    }
}

#[test]
fn json_example_copy_equals_the_spec() {
    let Some(spec) = rins_tests::data::external(
        "diagnose::json_example_copy_equals_the_spec",
        "../spec",
        "diagnose-v1.md",
    ) else {
        return;
    };
    let spec = std::fs::read_to_string(spec).unwrap();
    let a = spec.find("```json").unwrap() + 7;
    let b = a + spec[a..].find("```").unwrap();
    let from_spec: serde_json::Value = serde_json::from_str(&spec[a..b]).unwrap();
    let copy: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(rins_tests::data::bundled("diagnose-v1-example.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(
        copy, from_spec,
        "tests/data/diagnose-v1-example.json is stale: copy it from shared/spec/diagnose-v1.md"
    );
}

#[test]
fn json_has_every_key_of_the_spec_and_only_documented_additions() {
    // The spec's example, as copied into tests/data (the copy is checked
    // against shared/spec by `json_example_copy_equals_the_spec`).
    let example: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(rins_tests::data::bundled("diagnose-v1-example.json")).unwrap(),
    )
    .unwrap();
    let mut want = vec![];
    shape(&example, "", &mut want);
    want.sort();
    // A report with a finding and an unexplained entry.
    let mut c = config(Axis::Z, true, 15, 600.0);
    c.set_effect("lever_arm", 0.02).unwrap();
    // Physics outside the library: a three-lobed bearing tilting the
    // platform three times a revolution (3 mg on accel x at 3x/rev).
    let mut rec = simulate(&c, &mut |_| {}).unwrap();
    let p = rins::diagnose::predict(&rec, 1.0, 0.0);
    for (r, th) in rec.imu.iter_mut().zip(&p.theta) {
        r.accel_mps2[0] += 0.03 * (3.0 * th.0).cos();
    }
    let d = run(&rec, "test", &Options::default()).unwrap();
    println!("{:?}", d.unexplained);
    assert!(!d.unexplained.is_empty() && !d.findings.is_empty());
    assert!(d
        .unexplained
        .iter()
        .any(|u| u.where_.starts_with("3x") && u.channels == ["accel_x_mps2"]));
    // Judged greedily: the harmonic does not leak into offsets as well.
    assert!(
        !d.unexplained
            .iter()
            .any(|u| u.where_.contains("offset") && u.channels == ["accel_x_mps2"]),
        "{:?}",
        d.unexplained
    );
    let mut got = vec![];
    let json = d.to_json();
    shape(&json, "", &mut got);
    got.sort();
    got.dedup();
    want.dedup();
    // Every key of the spec, and beyond them only the keys this version
    // adds (the spec lets a later version add keys, never rename one):
    // what the recording rules out, its segments between gaps, its rate.
    let added = [
        ".rate_hz",
        ".ruled_out",
        ".segments",
        ".segments[].end_s",
        ".segments[].samples",
        ".segments[].start_s",
        ".track_unfollowed",
        ".track_unfollowed[].end_s",
        ".track_unfollowed[].start_s",
        ".findings[].not_measured",
        ".observability",
        ".observability[].bound",
        ".observability[].effect",
        ".observability[].min_detectable",
        ".observability[].observable",
        ".observability[].parameter",
    ];
    let missing: Vec<&String> = want.iter().filter(|k| !got.contains(k)).collect();
    assert!(missing.is_empty(), "spec keys missing: {missing:?}");
    let extra: Vec<&String> = got
        .iter()
        .filter(|k| !want.contains(k) && !added.contains(&k.as_str()))
        // Per channel a finding's regressors touch (recording-v1 channel
        // names), each `{before, after}`: the book's diagnose chapter.
        .filter(|k| {
            let Some(rest) = k.strip_prefix(".findings[].fit.heldout_whitened") else {
                return true;
            };
            let parts: Vec<&str> = rest.split('.').skip(1).collect();
            let channel = |c: &str| c.ends_with("_radps") || c.ends_with("_mps2");
            !(parts.is_empty()
                || (parts.len() == 1 && channel(parts[0]))
                || (parts.len() == 2
                    && channel(parts[0])
                    && ["before", "after"].contains(&parts[1])))
        })
        .collect();
    assert!(
        extra.is_empty(),
        "keys neither in the spec nor documented: {extra:?}"
    );
    // Ids, channels and units as the spec says.
    for f in json["findings"].as_array().unwrap() {
        assert!(hal_sim::catalogue::EffectId::parse(f["effect"].as_str().unwrap()).is_some());
        for ch in f["channels"].as_array().unwrap() {
            assert!(rins::diagnose::CHANNELS.contains(&ch.as_str().unwrap()));
        }
        for k in f["parameters"].as_object().unwrap().keys() {
            assert!(
                [
                    "_m",
                    "_s",
                    "_rad",
                    "_radps",
                    "_mps2",
                    "_per_radps",
                    "_per_mps2",
                    "_per_degc",
                    "_per_sqrt_s",
                    "asymmetry_"
                ]
                .iter()
                .any(|u| k.ends_with(u) || k.contains(u)),
                "{k}: no unit in the name"
            );
        }
    }
    // Most significant first.
    let dbic: Vec<f64> = d.to_json()["findings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["significance"]["delta_bic"].as_f64().unwrap())
        .collect();
    assert!(dbic.windows(2).all(|w| w[0] <= w[1]), "{dbic:?}");
}

#[test]
fn bad_recordings_are_errors() {
    let mut rec = simulate(&config(Axis::Z, false, 16, 60.0), &mut |_| {}).unwrap();
    rec.imu[100].gyro_radps[0] = f64::NAN;
    let e = run(&rec, "bad", &Options::default()).unwrap_err();
    assert!(
        matches!(
            e,
            rins::diagnose::DiagnoseError::NonFiniteImu { index: 100, .. }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("imu sample 100"), "{e}");
    rec.imu.truncate(10);
    let e = run(&rec, "short", &Options::default()).unwrap_err();
    assert_eq!(e, rins::diagnose::DiagnoseError::TooShort { samples: 10 });
    assert!(e.to_string().contains("too short"));
}

#[test]
fn adis16405_bench_hour_shows_bias_instability() {
    // The real ADIS16405 recording (external data), written out as a
    // rins-recording/1 (static, table still; gyro deg/s, accel g; site and
    // heading not recorded: the nominal bias absorbs the earth rate).
    use recording::{ImuRow, Meta, Recording, TableRow};
    let Some(path) = rins_tests::data::external(
        "diagnose::adis16405_bench_hour_shows_bias_instability",
        "adis16405_static",
        "adis_16405_imu1_f32le_1000000x6.bin",
    ) else {
        return;
    };
    let raw = std::fs::read(path).unwrap();
    let f = |row: &[u8], c: usize| {
        f64::from(f32::from_le_bytes(
            row[4 * c..4 * c + 4].try_into().unwrap(),
        ))
    };
    // The first hour (360,000 samples).
    let imu: Vec<ImuRow> = raw
        .chunks_exact(24)
        .take(360_000)
        .enumerate()
        .map(|(k, r)| ImuRow {
            t_s: k as f64 / 100.0,
            gyro_radps: [
                f(r, 0).to_radians(),
                f(r, 1).to_radians(),
                f(r, 2).to_radians(),
            ],
            accel_mps2: [f(r, 3) * 9.80665, f(r, 4) * 9.80665, f(r, 5) * 9.80665],
            temp_c: None,
        })
        .collect();
    let table: Vec<TableRow> = (0..180_000)
        .map(|k| TableRow {
            t_s: k as f64 / 50.0,
            angle_rad: 0.0,
        })
        .collect();
    let rec = Recording {
        gyro_only: false,
        moving: None,
        meta: Meta {
            latitude_deg: 51.08,
            height_m: 1100.0,
            ..Meta::default()
        },
        imu,
        table,
    };
    let dir = std::env::temp_dir().join(format!("rins-adis-{}", std::process::id()));
    rec.write(&dir).unwrap();
    let rec = Recording::read(&dir).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    let t = std::time::Instant::now();
    let report = run(&rec, "adis16405", &Options::default())
        .unwrap()
        .to_json();
    println!("diagnosed 1 h in {:.2} s", t.elapsed().as_secs_f64());
    let findings = report["findings"].as_array().unwrap();
    let bi: Vec<&serde_json::Value> = findings
        .iter()
        .filter(|f| f["effect"] == "bias_instability")
        .collect();
    for f in &bi {
        println!("{} {} {}", f["channels"], f["parameters"], f["fit"]);
    }
    // A constant bias + white noise does not explain the sensor: bias
    // instability is named on the gyros, with its parameters, and modelling
    // it lowers the held-out residual.
    assert!(!bi.is_empty(), "{findings:?}");
    assert!(bi.iter().any(|f| f["channels"]
        .as_array()
        .unwrap()
        .iter()
        .any(|c| c == "gyro_x_radps")));
    for f in bi {
        for (k, v) in f["parameters"].as_object().unwrap() {
            if !(k.starts_with("bias_instability_") && k.ends_with("_radps")) {
                continue;
            }
            let b = v.as_f64().unwrap();
            // The Allan floors of this unit: 19-30 deg/h (allan_reference.rs).
            assert!((5.0..80.0).contains(&(b.to_degrees() * 3600.0)), "{k} {b}");
        }
        assert!(
            f["fit"]["heldout_rms_after"].as_f64().unwrap()
                < f["fit"]["heldout_rms_before"].as_f64().unwrap()
        );
    }
}

#[test]
fn blind_study_runs_and_its_mde_is_calibrated() {
    // One effect, one seed a cell, two nulls: the Fisher MDE is right if
    // half of it goes unseen (noncentrality a quarter of the 50 % point: a
    // detection chance well under 1 %) and four times it is always seen.
    let s = rins::study::run(
        &[rins::study::grade("nav440", None).unwrap()],
        &[(hal_sim::catalogue::EffectId::LeverArm, Axis::Z, 0.02)],
        1,
        2,
        5,
        &|_| {},
    )
    .unwrap();
    let m = &s.mde[0];
    println!("{m:?}");
    assert!(m.mde.is_finite() && m.mde > 0.0 && m.k == 2, "{m:?}");
    let at = |x: f64| s.cells.iter().find(|c| c.scale == x).unwrap();
    assert_eq!(at(0.5).detected, 0);
    assert_eq!((at(4.0).detected, at(4.0).first), (1, 1));
    assert_eq!(s.null_runs["nav440"], 2);
    assert_eq!(s.false_alarms["nav440"], 0);
    assert_eq!(s.confusion["lever_arm"]["lever_arm"], 1);
    let md = rins::study::markdown(&s);
    assert!(
        md.contains("| lever_arm |") && md.contains("false alarms on 2 null runs with the whole sensor (named beyond the profile's own terms at up to 4x): 0"),
        "{md}"
    );
    assert!(serde_json::to_string(&s).unwrap().contains("false_alarms"));
}

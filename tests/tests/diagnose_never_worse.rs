//! A fit that never gets worse (issue 33): every finding that models a
//! signal claims exactly the channels whose held-out residual it lowers,
//! read from the report's JSON (`fit.heldout_whitened`: per channel its
//! regressors touch, the whitened held-out rms without and with it), on
//! real runs (the bundled 300 s stepper cut, the whole 1500 s run in
//! ../shared/data) and on simulated runs of several effect ids. The noise
//! findings (untracked motion, bias instability) take power out of the
//! white noise instead and carry no such figures.

use core_nav::table::Axis;
use hal_sim::catalogue::EffectId;
use hal_sim::sim::simulate;
use recording::Recording;
use rins::diagnose::{run, Options};

/// The breaches of the rule in `rec`'s report, one line each.
fn breaches(rec: &Recording, label: &str) -> Vec<String> {
    let d = run(rec, label, &Options::default()).unwrap();
    let mut bad = vec![];
    let mut signal = 0;
    for f in &d.findings {
        let j = f.to_json();
        let claimed: Vec<&str> = j["channels"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_str().unwrap())
            .collect();
        let held = j["fit"]["heldout_whitened"].as_object().unwrap();
        let noise = matches!(
            f.effect,
            EffectId::UntrackedTableMotion | EffectId::BiasInstability
        );
        if noise {
            assert!(
                held.is_empty(),
                "{label}: {} has held-out figures",
                f.effect
            );
            continue;
        }
        signal += 1;
        for c in &claimed {
            let Some(h) = held.get(*c) else {
                bad.push(format!(
                    "{label}: {} claims {c} with no held-out figure",
                    f.effect
                ));
                continue;
            };
            let (b, a) = (h["before"].as_f64().unwrap(), h["after"].as_f64().unwrap());
            if a >= b {
                bad.push(format!(
                    "{label}: {} claims {c}: held-out {b:.6} -> {a:.6}",
                    f.effect
                ));
            }
        }
        for (c, h) in held {
            let (b, a) = (h["before"].as_f64().unwrap(), h["after"].as_f64().unwrap());
            if a < b && !claimed.contains(&c.as_str()) {
                bad.push(format!(
                    "{label}: {} lowers {c} ({b:.6} -> {a:.6}) and does not claim it",
                    f.effect
                ));
            }
        }
    }
    println!("{label}: {signal} signal findings checked");
    bad
}

#[test]
fn real_runs_claim_only_the_channels_they_improve() {
    let cut = rins_tests::data::bundled("mpu6050_stepper_roll_slow_300s");
    let mut bad = breaches(&Recording::read(&cut).unwrap(), "real 300 s cut");
    if let Some(p) = rins_tests::data::external(
        "diagnose_never_worse::real_runs_claim_only_the_channels_they_improve",
        "mpu6050_stepper_roll_slow",
        "recording",
    ) {
        bad.extend(breaches(&Recording::read(&p).unwrap(), "real 1500 s run"));
    }
    assert!(bad.is_empty(), "{bad:#?}");
}

#[test]
fn simulated_runs_claim_only_the_channels_they_improve() {
    let mut bad = vec![];
    for (k, (effect, v, axis)) in [
        ("lever_arm", 0.04, Axis::Z),
        ("time_offset", 0.004, Axis::Z),
        ("gyro_g_sensitivity", 4e-4, Axis::Y),
        ("table_angle_harmonic", 2e-3, Axis::Z),
        ("accel_scale_nonlinearity", 4e-4, Axis::Y),
    ]
    .into_iter()
    .enumerate()
    {
        let mut c = rins_tests::runs::reduced_nav440(axis, false, 41 + k as u64, 300.0);
        c.set_effect(effect, v).unwrap();
        let rec = simulate(&c, &mut |_| {}).unwrap();
        bad.extend(breaches(&rec, effect));
    }
    assert!(bad.is_empty(), "{bad:#?}");
}

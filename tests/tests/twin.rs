//! The simulator is the model: every effect id hidden in a recording,
//! diagnosed, written as a hal-sim model (`Diagnosis::sim_model`, what
//! `rins diagnose --sim-model` writes), re-simulated with the recording's
//! own run (`hal_sim::twin::simulate_like`, `rins simulate --like`), and
//! the recording judged against its twin: as close to it as two seeds of
//! the twin are to each other (closeness ratio <= 1.3 on every channel).
//!
//! Each case also checks that the ratio can fail: the twin of the nominal
//! model (every finding stripped) must sit farther than 1.3 from the
//! recording, so the hidden effect is visible to the measure.

use hal_sim::catalogue::EffectId;
use rins::diagnose::twin::{closeness, report, GOOD_RATIO};
use rins::diagnose::{run, Options};
use rins::realnoise::RealNoise;
use rins::study::{background, grade, inject, mde, record, scenario, Grade};
use std::sync::Arc;

/// Magnitude per id, x its MDE in the grade's run (the bias instability:
/// x the datasheet's). The study detects every id at 2x; here each must
/// also stand out of the 1 s block means the closeness ratio looks at
/// (ratio of the nominal twin above ~1.6: the effect's power in 1 s means
/// at least 1.5x the twins' own spread), measured at 4x MDE on the
/// simulated ADIS16405 and scaled by the square root of the power needed.
fn factor(id: EffectId) -> f64 {
    match id {
        EffectId::EarthRate => 14.0,
        EffectId::AxisTilt => 12.0,
        EffectId::TimeOffset | EffectId::UntrackedTableMotion => 10.0,
        EffectId::GyroGSensitivity
        | EffectId::EncoderError
        | EffectId::AccelScaleNonlinearity
        | EffectId::TableAngleHarmonic => 8.0,
        EffectId::LeverArm | EffectId::BiasInstability => 6.0,
        // Re-measured with the whole-sensor MDE (the study's since its
        // detection runs carry the full profile): 4x gave a nominal twin of
        // 1.27; the ratio's excess power scales as the square, so 6x. With
        // the simulator's new random streams 6x gave 1.28: to reach ~1.6,
        // 6 x sqrt((1.6^2 - 1) / (1.28^2 - 1)), about 9x.
        EffectId::TemperatureBias => 9.0,
        EffectId::GyroScaleNonlinearity | EffectId::GyroScaleAsymmetry => 4.0,
    }
}

fn magnitude(g: &Grade, id: EffectId) -> f64 {
    let (axis, reference) = scenario(id);
    if id == EffectId::BiasInstability {
        return factor(id);
    }
    if let Some((_, base)) = rins::study::noise_scales(&g.spec, id) {
        // A noise term: multiples of the profile's figure (the study's).
        return factor(id) * base;
    }
    factor(id) * mde(g, id, axis, reference).unwrap().mde
}

struct Case {
    id: EffectId,
    full: f64,
    nominal: f64,
    named: bool,
}

fn hide(g: &Grade, id: EffectId, mag: f64, seed: u64) -> Case {
    let (axis, _) = scenario(id);
    let mut c = background(g, axis, id == EffectId::BiasInstability, seed);
    inject(&mut c, &g.spec, id, mag).unwrap();
    let rec = record(g, &c, seed).unwrap();
    let opts = Options::default();
    let d = run(&rec, "hidden", &opts).unwrap();
    let r = report(&d, &rec, &opts.model, "test", 1000 + seed).unwrap();
    let full = r.runs[0].closeness.worst().1;
    let nominal = r
        .runs
        .iter()
        .find(|x| x.label == "nominal only")
        .map_or(f64::NAN, |x| x.closeness.worst().1);
    // The model file round-trips and the twin from the file is the same.
    let text = r.model.to_toml().unwrap();
    let back = hal_sim::twin::SimModel::from_toml(&text).unwrap();
    assert_eq!(back, r.model);
    let again = closeness(&rec, &back, 1000 + seed).unwrap();
    assert!((again.worst().1 - full).abs() < 1e-9);
    if !d.findings.iter().any(|f| f.effect == id) {
        eprintln!(
            "  {}: findings {:?}, unexplained {:?}",
            id.as_str(),
            d.findings
                .iter()
                .map(|f| (f.effect.as_str(), f.lookalike.map(|e| e.as_str())))
                .collect::<Vec<_>>(),
            d.unexplained
                .iter()
                .map(|u| (&u.where_, u.may_be))
                .collect::<Vec<_>>()
        );
    }
    Case {
        id,
        full,
        nominal,
        // Named, or named as what a finding cannot be told apart from in
        // this run (a look-alike; a slow mismatch not told from drift).
        named: d
            .findings
            .iter()
            .any(|f| f.effect == id || f.lookalike == Some(id))
            || d.unexplained.iter().any(|u| u.may_be == Some(id)),
    }
}

fn check_all(g: &Grade) {
    let mut bad = vec![];
    for (k, id) in EffectId::ALL.into_iter().enumerate() {
        // An effect this run can only show beyond its physical bound (the
        // earth rate on a gyro whose noise hides the real one) is not hidden.
        let mag = magnitude(g, id);
        if let Some(b) = id.bound().filter(|b| mag > b.max_abs) {
            eprintln!(
                "{} {:<28} skipped: {mag:.2e} is beyond its bound {:.2e} {}",
                g.name,
                id.as_str(),
                b.max_abs,
                b.unit
            );
            continue;
        }
        let c = hide(g, id, mag, 11 + 7 * k as u64);
        eprintln!(
            "{} {:<28} named {:<5} twin ratio {:.2} (nominal twin {:.2})",
            g.name,
            c.id.as_str(),
            c.named,
            c.full,
            c.nominal
        );
        // A warm-up without a temperature column on real drift is the
        // drift's look-alike (the book's Diagnose chapter, "what diagnose cannot separate"): the
        // twin must still hold, naming it is not asked for.
        let must_name = !(g.real.is_some() && id == EffectId::TemperatureBias);
        if !((c.named || !must_name) && c.full <= GOOD_RATIO && c.nominal > GOOD_RATIO) {
            bad.push(format!(
                "{}: named {}, ratio {:.2}, nominal {:.2}",
                c.id.as_str(),
                c.named,
                c.full,
                c.nominal
            ));
        }
    }
    assert!(bad.is_empty(), "{}: {bad:?}", g.name);
}

#[test]
fn every_hidden_effect_gives_a_twin_as_close_as_its_own_seeds() {
    let g = grade("adis16405", None).unwrap();
    check_all(&g);
}

#[test]
fn on_real_noise_every_hidden_effect_gives_a_close_twin() {
    let Some(p) = rins_tests::data::external(
        "twin::on_real_noise_every_hidden_effect_gives_a_close_twin",
        "adis16405_static",
        "adis_16405_imu1_f32le_1000000x6.bin",
    ) else {
        return;
    };
    let r = Arc::new(RealNoise::adis16405(&p).unwrap());
    let g = grade("adis16405+real", Some(&r)).unwrap();
    check_all(&g);
}

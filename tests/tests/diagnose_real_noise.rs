//! diagnose on real sensor noise it did not make: the ADIS16405 bench
//! recording's deviations (external data, `rins_tests::data`) added to
//! simulated table motion (`rins::realnoise`, the study's `+real`
//! backgrounds). The simulator's own noise model is not in these runs.

use core_nav::scheme::Scheme;
use core_nav::table::Axis;
use hal_sim::catalogue::EffectId;
use rins::diagnose::{run, Options};
use rins::realnoise::RealNoise;
use rins::study::{background, grade, record};
use std::sync::Arc;

fn real(test: &str) -> Option<Arc<RealNoise>> {
    let p = rins_tests::data::external(
        &format!("diagnose_real_noise::{test}"),
        "adis16405_static",
        "adis_16405_imu1_f32le_1000000x6.bin",
    )?;
    Some(Arc::new(RealNoise::adis16405(&p).unwrap()))
}

fn named(d: &rins::diagnose::Diagnosis) -> Vec<EffectId> {
    d.findings
        .iter()
        .map(|f| f.effect)
        .filter(|e| *e != EffectId::BiasInstability)
        .collect()
}

#[test]
fn real_noise_nulls_name_nothing() {
    // The study's null backgrounds (600 s reciprocating at 60 deg/s, about
    // z and about y) on twelve draws of the real recording. Before slow
    // findings were confirmed on long blocks, 2.5 % of such nulls were
    // given a warm-up (temperature_bias) on the real drift.
    let Some(r) = real("real_noise_nulls_name_nothing") else {
        return;
    };
    let g = grade("adis16405+real", Some(&r)).unwrap();
    let mut strongest = vec![];
    for k in 0..12u64 {
        let seed = 1 + 7919 * k + 3;
        let axis = if k % 2 == 0 { Axis::Z } else { Axis::Y };
        let rec = record(&g, &background(&g, axis, true, seed), seed).unwrap();
        let d = run(&rec, "null", &Options::default()).unwrap();
        assert!(
            named(&d).is_empty(),
            "seed {seed} {axis:?}: {:?}",
            named(&d)
        );
        strongest.push(d.details.strongest_p_adjusted);
    }
    // Confidence that means what it says: a null's strongest evidence for
    // any effect falls below 0.1 in at most 10 % of nulls. Of 12, five or
    // more below it has a chance of 0.4 % (binomial) if the confidences
    // are honest; the study checks it on hundreds (the book, Diagnose).
    let below = strongest.iter().filter(|p| **p < 0.1).count();
    println!("nulls' strongest adjusted p: {strongest:.3?}");
    assert!(below <= 4, "{below} of 12 nulls below 0.1: {strongest:?}");
}

#[test]
fn a_long_step_profile_on_real_drift_is_not_a_warm_up() {
    // 300 s still, then 900 s at one rate: the real sensor's drift, no
    // temperature column. Warm-up, lever arm and asymmetry look alike on
    // such a run; none is there, none may be named.
    let Some(r) = real("a_long_step_profile_on_real_drift_is_not_a_warm_up") else {
        return;
    };
    let g = grade("adis16405+real", Some(&r)).unwrap();
    for seed in [5u64, 11] {
        let mut c = background(&g, Axis::Z, true, seed);
        c.duration_s = 1200.0;
        c.static_s = 300.0;
        c.scheme = Scheme::Continuous {
            rate: 60f64.to_radians(),
        };
        let rec = record(&g, &c, seed).unwrap();
        assert!(rec.imu.iter().all(|s| s.temp_c.is_none()));
        let d = run(&rec, "step", &Options::default()).unwrap();
        assert!(named(&d).is_empty(), "seed {seed}: {:?}", named(&d));
    }
}

#[test]
fn a_warm_up_on_real_drift_is_still_found() {
    // The confirmation on long blocks must not hide a real warm-up: a
    // 150 s turn-on transient of 3e-4 rad/s per degC over 6 degC (1.8
    // mrad/s, 370 deg/h, ten times the recording's own bias instability),
    // temperature not recorded, on three draws of the real drift. A warm-up
    // as slow as the run itself (600 s) is the drift's look-alike: then the
    // report says so (an unexplained slow mismatch) or the drift takes it.
    let Some(r) = real("a_warm_up_on_real_drift_is_still_found") else {
        return;
    };
    let g = grade("adis16405+real", Some(&r)).unwrap();
    let mut found = 0;
    for seed in [21u64, 22, 23] {
        let mut c = background(&g, Axis::Z, true, seed);
        c.imu.temp.warmup_c = 6.0;
        c.imu.temp.warmup_tau_s = 150.0;
        c.set_effect("temperature_bias", 3e-4).unwrap();
        let rec = record(&g, &c, seed).unwrap();
        let d = run(&rec, "warm-up", &Options::default()).unwrap();
        println!("seed {seed}: {:?}", named(&d));
        found += usize::from(named(&d).contains(&EffectId::TemperatureBias));
        assert!(named(&d).iter().all(|e| *e == EffectId::TemperatureBias));
    }
    assert!(found >= 2, "named in {found} of 3");
}

#[test]
fn cross_axis_g_sensitivity_on_a_horizontal_axis_is_g_sensitivity() {
    // The independent generator's case: gyro y driven by accel z and gyro
    // z by accel y, on a table turning about the horizontal y axis, real
    // noise. It was named axis_tilt; it is g-sensitivity (the full 3x3
    // candidate), and gyro z's term (accel y stays ~0 here) is not claimed.
    let Some(r) = real("cross_axis_g_sensitivity_on_a_horizontal_axis_is_g_sensitivity") else {
        return;
    };
    let g = grade("adis16405+real", Some(&r)).unwrap();
    let v = 2e-4; // rad/s per m/s^2: 0.11 deg/s per g, the ADIS datasheet's order
    for seed in [31u64, 32] {
        let mut c = background(&g, Axis::Y, true, seed);
        let mut m = nalgebra::Matrix3::zeros();
        m[(1, 2)] = v;
        m[(2, 1)] = v;
        c.g_sens_matrix = Some(m);
        let rec = record(&g, &c, seed).unwrap();
        let d = run(&rec, "g-sens", &Options::default()).unwrap();
        println!("seed {seed}: {:?}", named(&d));
        assert_eq!(
            named(&d).first(),
            Some(&EffectId::GyroGSensitivity),
            "{:?}",
            named(&d)
        );
        let f = d
            .findings
            .iter()
            .find(|f| f.effect == EffectId::GyroGSensitivity)
            .unwrap();
        let (x, s) = (
            f.value("g_sens_yz_radps_per_mps2").unwrap(),
            f.parameter("g_sens_yz_radps_per_mps2")
                .and_then(|p| p.sigma)
                .unwrap(),
        );
        println!("g_sens_yz {x:.3e} +- {s:.1e}");
        assert!((x - v).abs() < 3.0 * s + 0.02 * v, "{x} vs {v} +- {s}");
    }
}

/// The independent generator's sharp reversals, in closed form (not
/// hal-sim's physics): the table about z (down) of a level base at heading
/// 0, +-90 deg/s every 2 s through 400 deg/s^2 ramps whose knots fall
/// between the 50 Hz encoder reads, the reads stamped 3 ms off the 100 Hz
/// IMU samples and floored to 16,384 counts. Earth rate and gravity in NED
/// written out here: `w_s = Rz(theta)^T Omega (cos lat, 0, -sin lat) +
/// theta_dot z`, `f_s = Rz(theta)^T (0, 0, -g)`.
fn reversals(duration_s: f64) -> recording::Recording {
    use recording::{ImuRow, Meta, Recording, TableRow};
    let (w, a) = (90f64.to_radians(), 400f64.to_radians());
    let ramp = 2.0 * w / a; // 0.45 s
    let half = 2.0; // s per direction, ramp included
                    // Angle, rate at t: a periodic trapezoid started still for 20 s.
    let kin = |t: f64| -> (f64, f64) {
        let t0 = 20.0;
        if t < t0 {
            return (0.0, 0.0);
        }
        // From still: ramp up to +w over ramp / 2, then the cycle.
        let up = w / a;
        let tt = t - t0;
        if tt < up {
            return (0.5 * a * tt * tt, a * tt);
        }
        let th_up = 0.5 * a * up * up;
        let tc = tt - up;
        let cycle = 2.0 * half;
        let k = (tc / cycle).floor();
        let u = tc - k * cycle;
        // One cycle: +w for (half - ramp), ramp down, -w for (half -
        // ramp), ramp up; net angle per cycle zero.
        let hold = half - ramp;
        let (th, rate) = if u < hold {
            (w * u, w)
        } else if u < hold + ramp {
            let d = u - hold;
            (w * hold + w * d - 0.5 * a * d * d, w - a * d)
        } else if u < 2.0 * hold + ramp {
            let d = u - hold - ramp;
            (w * hold - w * d, -w)
        } else {
            let d = u - 2.0 * hold - ramp;
            (-w * d + 0.5 * a * d * d, -w + a * d)
        };
        (th_up + th, rate)
    };
    let lat: f64 = 30.53f64.to_radians();
    let omega = 7.292_115e-5;
    let g = 9.7936;
    let mut rec = Recording {
        gyro_only: false,
        moving: None,
        meta: Meta {
            description: Some("independent closed-form reversals".into()),
            latitude_deg: lat.to_degrees(),
            height_m: 20.0,
            gravity_mps2: Some(g),
            heading_deg: 0.0,
            pitch_deg: 0.0,
            roll_deg: 0.0,
            heading_sigma_deg: None,
            level_sigma_deg: None,
            imu_rate_hz: 100.0,
            encoder_rate_hz: 50.0,
            ..Meta::default()
        },
        imu: vec![],
        table: vec![],
    };
    let n = (duration_s * 100.0) as usize;
    for k in 0..=n {
        let t = k as f64 / 100.0;
        let (th, rate) = kin(t);
        let (c, s) = (th.cos(), th.sin());
        let (wn, we, wd) = (omega * lat.cos(), 0.0, -omega * lat.sin());
        // Rz(theta)^T v = (c vx + s vy, -s vx + c vy, vz).
        rec.imu.push(ImuRow {
            t_s: t,
            gyro_radps: [c * wn + s * we, -s * wn + c * we, wd + rate],
            accel_mps2: [0.0, 0.0, -g],
            temp_c: None,
        });
    }
    let q = std::f64::consts::TAU / 16_384.0;
    let m = (duration_s * 50.0) as usize;
    for k in 0..m {
        let t = k as f64 / 50.0 + 0.003;
        rec.table.push(TableRow {
            t_s: t,
            angle_rad: (kin(t).0 / q).floor() * q,
        });
    }
    rec
}

#[test]
fn sharp_reversals_from_an_independent_generator_name_nothing() {
    // The independent generator's null: a time offset (0.036 ms) was named
    // and the table-axis residual was far from white; the prediction, not
    // the sensor, failed at the knots. The table's shape is now fitted with
    // its knots between reads (hal-sim's EncoderTrack).
    let Some(r) = real("sharp_reversals_from_an_independent_generator_name_nothing") else {
        return;
    };
    for seed in [41u64, 42, 43] {
        let mut rec = reversals(600.0);
        let d0 = r.draw(seed, rec.imu.len());
        r.add_to(&mut rec, d0).unwrap();
        let d = run(&rec, "reversals", &Options::default()).unwrap();
        println!("seed {seed}: {:?}", named(&d));
        let u = &d.details.unfollowed;
        assert!(
            u.is_empty(),
            "{} intervals not followed: {:?}",
            u.len(),
            &u[..u.len().min(4)]
        );
        // The table-axis residual's whiteness (Ljung-Box, 20 lags; the
        // generator's null gave 3042). Printed, not asserted: the real
        // sensor's own filter colours its noise at 0.2 s whatever the
        // prediction does; the prediction is checked directly below.
        println!(
            "seed {seed}: Ljung-Box gyro z {:.0}",
            d.details.whiteness[2].0
        );
    }
    // The table model against the closed form, at every IMU sample after
    // the still start: the angle within one count (the reads are floored:
    // their error is within one count), the rate within 20 mrad/s (one
    // count over a 20 ms read spacing, ~q / (h sqrt(8)) ~ 7 mrad/s, with
    // the knots' margin).
    let clean = reversals(600.0);
    let tr = recording::track::EncoderTrack::of(&clean);
    let w_up = 7.292_115e-5 * 30.53f64.to_radians().sin();
    let rate = |k: usize| clean.imu[k].gyro_radps[2] + w_up;
    let (mut angle, mut worst_angle, mut worst_rate) = (0.0f64, 0.0f64, 0.0f64);
    for k in 1..clean.imu.len() {
        // Trapezoid: exact on the linear pieces of the rate, off by at most
        // a dt^2 / 8 ~ 1e-4 rad within a 10 ms step holding a knot, and
        // the ramp's two knots cancel.
        angle += 0.5 * (rate(k - 1) + rate(k)) * 0.01;
        if k > 2100 {
            let t = k as f64 / 100.0;
            worst_angle = worst_angle.max((tr.angle(t) - angle).abs());
            worst_rate = worst_rate.max((tr.at(t).rate - rate(k)).abs());
        }
    }
    let q = std::f64::consts::TAU / 16_384.0;
    println!("worst angle error {worst_angle:.2e} rad, rate {worst_rate:.2e} rad/s");
    assert!(worst_angle < 1.05 * q && worst_rate < 0.02);
}

#[test]
fn a_true_time_offset_on_reversals_is_named_alone() {
    // The generator's other case: a true time offset on a reciprocating run
    // with real noise came with a spurious encoder_error. Here 2 ms on the
    // sharp reversals above (the IMU stamps late: its samples are the
    // truth 2 ms earlier).
    let Some(r) = real("a_true_time_offset_on_reversals_is_named_alone") else {
        return;
    };
    let dt = 0.002;
    for seed in [51u64, 52] {
        let clean = reversals(600.0);
        let late = {
            // The same run with every IMU sample taken dt earlier: shift the
            // gyro by interpolating the closed form's samples (10 ms apart,
            // the rate is piecewise linear so linear interpolation is exact
            // away from the knots, 0.2 % of the samples).
            let mut rec = clean.clone();
            let s = dt / 0.01;
            for k in 1..rec.imu.len() {
                for i in 0..3 {
                    let (a, b) = (clean.imu[k - 1].gyro_radps[i], clean.imu[k].gyro_radps[i]);
                    rec.imu[k].gyro_radps[i] = b + s * (a - b);
                }
            }
            rec
        };
        let mut rec = late;
        let d0 = r.draw(seed, rec.imu.len());
        r.add_to(&mut rec, d0).unwrap();
        let d = run(&rec, "time offset", &Options::default()).unwrap();
        println!("seed {seed}: {:?}", named(&d));
        assert_eq!(named(&d), vec![EffectId::TimeOffset], "seed {seed}");
        let f = &d
            .findings
            .iter()
            .find(|f| f.effect == EffectId::TimeOffset)
            .unwrap();
        let (x, s) = (
            f.value("time_offset_s").unwrap(),
            f.parameter("time_offset_s").and_then(|p| p.sigma).unwrap(),
        );
        println!("time offset {x:.5} +- {s:.1e}");
        assert!((x - dt).abs() < 3.0 * s + 0.02 * dt, "{x} vs {dt}");
    }
}

#[test]
fn g_sensitivity_and_encoder_error_on_a_one_way_run_are_look_alikes() {
    // One way, one rate, about the horizontal y axis: a g-sensitivity's
    // gyro-y term (G_yz f_z) and an encoder error are both a 1x harmonic on
    // the table-axis gyro (gyro z's term sees f_y, ~0 on a horizontal
    // axis). The g-sensitivity must be named or given as the look-alike of
    // what is named; when both are named, the report must say that the run
    // cannot split the signal between them.
    let Some(r) = real("g_sensitivity_and_encoder_error_on_a_one_way_run_are_look_alikes") else {
        return;
    };
    let g = grade("adis16405+real", Some(&r)).unwrap();
    let v = 2e-4;
    for seed in [61u64, 62, 63] {
        let mut c = background(&g, Axis::Y, true, seed);
        c.scheme = Scheme::Continuous {
            rate: 60f64.to_radians(),
        };
        let mut m = nalgebra::Matrix3::zeros();
        m[(1, 2)] = v;
        m[(2, 1)] = v;
        c.g_sens_matrix = Some(m);
        let rec = record(&g, &c, seed).unwrap();
        let d = run(&rec, "one way", &Options::default()).unwrap();
        let n = named(&d);
        println!(
            "seed {seed}: {:?}",
            d.findings
                .iter()
                .map(|f| (f.effect, f.lookalike))
                .collect::<Vec<_>>()
        );
        assert!(
            n.contains(&EffectId::GyroGSensitivity)
                || d.findings
                    .iter()
                    .any(|f| f.lookalike == Some(EffectId::GyroGSensitivity)),
            "{n:?}"
        );
        if n.contains(&EffectId::EncoderError) && n.contains(&EffectId::GyroGSensitivity) {
            assert!(
                d.findings
                    .iter()
                    .any(|f| (f.effect == EffectId::EncoderError
                        && f.lookalike == Some(EffectId::GyroGSensitivity))
                        || (f.effect == EffectId::GyroGSensitivity
                            && f.lookalike == Some(EffectId::EncoderError))),
                "named together without the look-alike"
            );
        }
    }
}

//! An effect hidden in a real run (issue 33's injection harness): the
//! bundled real stepper-table run (MPU-6050 on a stepper shaft, MIT; its
//! first 300 s) with one effect of datasheet size added, computed from
//! the run's own encoder reads (their finite differences: the motion as
//! the encoder saw it, steps and all, not diagnose's own track) and
//! re-quantised to the sensor's own print lattice with dither, so the copy
//! looks like the original and still holds an effect smaller than a print
//! step. diagnose's change between the copy and the untouched run must be
//! the injected size within 35 % + 3 sigma, or, where the run cannot show
//! any possible size of it, the report must say so with its power.

use hal_sim::catalogue::EffectId;
use nalgebra::Vector3;
use recording::Recording;
use rins::diagnose::{run, Diagnosis, Options};

fn real() -> Recording {
    Recording::read(&rins_tests::data::bundled("mpu6050_stepper_roll_slow_300s")).unwrap()
}

/// The encoder's rate and acceleration at `t` (rad/s, rad/s^2): the
/// reads' differences, linear between the intervals' midpoints.
fn encoder_motion(rec: &Recording, t: f64) -> (f64, f64) {
    let mid: Vec<(f64, f64)> = rec
        .table
        .windows(2)
        .map(|w| (0.5 * (w[0].t_s + w[1].t_s), w[0].rate_to(&w[1])))
        .collect();
    let i = mid.partition_point(|m| m.0 <= t).clamp(1, mid.len() - 1);
    let ((t0, w0), (t1, w1)) = (mid[i - 1], mid[i]);
    let a = (w1 - w0) / (t1 - t0);
    (w0 + a * (t - t0), a)
}

/// What an injection adds to row `r`: (gyro, accel) in the sensor frame,
/// rad/s and m/s^2.
type Add = dyn Fn(&Recording, usize) -> (Vector3<f64>, Vector3<f64>);

/// `rec` with `add` added to every row, each channel put back on its own
/// print lattice (so the copy looks like the original). The rounding is
/// dithered: a printed sample stands for any value within half a step of
/// it, so a uniform draw over that step is added before the effect and
/// the rounding. Without it an effect smaller than half a step (0.3 % at
/// 1 g is 0.3 of the MPU-6050's 0.01 g print step) rounds back to the
/// very sample it was added to, and the copy holds none of it.
fn injected(rec: &Recording, add: &Add) -> Recording {
    let lattice: Vec<f64> = (0..6)
        .map(|ch| {
            let x: Vec<f64> = rec.imu.iter().map(|s| s.channel(ch)).collect();
            recording::plausible::lattice(&x).expect("the MPU-6050's print lattice")
        })
        .collect();
    let mut rng = hal_sim::rng::Rng::new(11, 3);
    let mut put = |v: f64, q: f64| (((v / q) + rng.uniform() - 0.5).round()) * q;
    let mut out = rec.clone();
    for (r, s) in out.imu.iter_mut().enumerate() {
        let (g, a) = add(rec, r);
        for i in 0..3 {
            s.gyro_radps[i] = put(s.gyro_radps[i] + g[i], lattice[i]);
            s.accel_mps2[i] = put(s.accel_mps2[i] + a[i], lattice[i + 3]);
        }
    }
    out
}

type Base = std::sync::OnceLock<(Recording, Diagnosis)>;

/// The bundled 300 s cut and its diagnosis, made once.
fn cut() -> &'static (Recording, Diagnosis) {
    static B: Base = Base::new();
    B.get_or_init(|| untouched(real()))
}

fn untouched(rec: Recording) -> (Recording, Diagnosis) {
    let d = run(&rec, "untouched", &Options::default()).unwrap();
    (rec, d)
}

fn param(d: &Diagnosis, effect: EffectId, name: &str) -> (f64, f64) {
    d.parameter(effect, name)
        .map_or((0.0, 0.0), |p| (p.value, p.sigma.unwrap_or(0.0)))
}

/// Hides `size` of `effect`'s parameter `name` in the real run through
/// `add` and checks diagnose's change against the untouched run: the
/// size within 35 % + 3 sigma; or, where the run's power for that
/// parameter (the smallest size it shows, in the report) is above the
/// size hidden, the report says so: declared not observable when even
/// the physical bound is beyond it.
fn hidden(effect: EffectId, name: &str, size: f64, add: &Add) {
    hidden_in(cut(), effect, name, size, add);
}

/// [`hidden`] in the run `base` (the run and its own diagnosis).
fn hidden_in(base: &(Recording, Diagnosis), effect: EffectId, name: &str, size: f64, add: &Add) {
    let (rec, d0) = base;
    let d = run(&injected(rec, add), "injected", &Options::default()).unwrap();
    let power = d
        .details
        .observability
        .iter()
        .find(|o| o.effect == effect && o.parameter == name)
        .unwrap_or_else(|| panic!("{name}: no power reported"));
    let ((v1, s1), (v0, s0)) = (param(&d, effect, name), param(d0, effect, name));
    let (change, sigma) = (v1 - v0, s1.hypot(s0));
    println!(
        "{name}: untouched {v0:.4e} +- {s0:.1e}, with {size:.3e} hidden {v1:.4e} +- {s1:.1e}: change {change:.4e}; the run shows it from {:?} (bound {:.3e})",
        power.min_detectable, power.bound
    );
    let named = d.findings.iter().any(|f| f.effect == effect);
    println!(
        "  named: {:?}",
        d.findings.iter().map(|f| f.effect).collect::<Vec<_>>()
    );
    if !power.observable() {
        assert!(
            !named && d.details.not_observable.iter().any(|(e, _)| *e == effect),
            "{effect}: beyond this run's power at any possible size, and not said so"
        );
        return;
    }
    if power.min_detectable.is_some_and(|m| m > size) && !named {
        // Below what this run shows: not named, and the report's power
        // says why.
        return;
    }
    assert!(
        (change - size).abs() <= 0.35 * size.abs() + 3.0 * sigma,
        "{name}: change {change:.4e} against {size:.4e} (+- {sigma:.1e})"
    );
}

const G0: f64 = 9.80665;

#[test]
fn a_lever_arm_hidden_in_the_real_stepper_run_is_found_at_its_size() {
    // 2 cm off the roll axis (x), along y and along z: radial both; the
    // motion as the encoder's reads give it (their differences).
    for (name, r) in [
        ("lever_y_m", Vector3::new(0.0, 0.02, 0.0)),
        ("lever_z_m", Vector3::new(0.0, 0.0, 0.02)),
    ] {
        hidden(EffectId::LeverArm, name, 0.02, &move |rec, i| {
            let k = rec.meta.axis.unit::<f64>();
            let (w, a) = encoder_motion(rec, rec.imu[i].t_s);
            (
                Vector3::zeros(),
                k.cross(&r) * a + k.cross(&k.cross(&r)) * w * w,
            )
        });
    }
}

#[test]
fn a_g_sensitivity_hidden_in_the_real_stepper_run_is_found_at_its_size() {
    // The MPU-6050's datasheet figure, 0.1 deg/s per g, on gyro y from
    // the measured specific force along z.
    let g = 0.1f64.to_radians() / G0;
    hidden(
        EffectId::GyroGSensitivity,
        "g_sens_yz_radps_per_mps2",
        g,
        &move |rec, i| {
            (
                Vector3::new(0.0, g * rec.imu[i].accel_mps2[2], 0.0),
                Vector3::zeros(),
            )
        },
    );
}

#[test]
fn an_accelerometer_nonlinearity_hidden_in_the_whole_real_run_is_found_at_its_size() {
    // 0.5 % at 1 g (the MPU-6050's +-0.5 % of its 2 g full scale) on y,
    // from the measured specific force. The bundled 300 s cut shows a k2
    // only from 3.6e-4 per m/s^2, the physical bound 5.1e-4: the whole
    // 1500 s run (its power about sqrt(5) better) is where it can be seen.
    let Some(p) = rins_tests::data::external(
        "diagnose_inject_real::an_accelerometer_nonlinearity_hidden_in_the_whole_real_run_is_found_at_its_size",
        "mpu6050_stepper_roll_slow",
        "recording",
    ) else {
        return;
    };
    let base = untouched(Recording::read(&p).unwrap());
    let k2 = 0.005 / G0;
    hidden_in(
        &base,
        EffectId::AccelScaleNonlinearity,
        "k2_y_per_mps2",
        k2,
        &move |rec, i| {
            let f = rec.imu[i].accel_mps2[1];
            (Vector3::zeros(), Vector3::new(0.0, k2 * f * f, 0.0))
        },
    );
}

#[test]
fn a_further_accelerometer_latency_hidden_in_the_real_stepper_run_is_found_at_its_size() {
    // 5 ms more on the accelerometers: each sample the one 5 ms before
    // (linear between the measured samples).
    let dt = 0.005;
    hidden(
        EffectId::TimeOffset,
        "accel_time_offset_s",
        dt,
        &move |rec, i| {
            let j = i.max(1);
            let (a, b) = (&rec.imu[j - 1], &rec.imu[j]);
            let slope =
                (Vector3::from(b.accel_mps2) - Vector3::from(a.accel_mps2)) / (b.t_s - a.t_s);
            (Vector3::zeros(), -slope * dt)
        },
    );
}

#[test]
fn a_warm_up_hidden_in_the_real_stepper_run_is_found_at_its_size() {
    // A gyro settling after turn-on (no temperature recorded: a warm-up
    // exponential), 0.3 deg/s on y over a 60 s time constant: a tenth of
    // the MPU-6050's +-20 deg/s turn-on tolerance, settling as a small
    // board warms.
    let (a, tau) = (0.3f64.to_radians(), 60.0);
    hidden(
        EffectId::TemperatureBias,
        "warmup_bias_y_radps",
        a,
        &move |rec, i| {
            let t = rec.imu[i].t_s - rec.imu[0].t_s;
            (
                Vector3::new(0.0, a * (1.0 - (-t / tau).exp()), 0.0),
                Vector3::zeros(),
            )
        },
    );
}

#[test]
fn a_further_gyro_latency_hidden_in_the_real_stepper_run_is_found_at_its_size() {
    // 5 ms more on the gyros: each sample the one 5 ms before.
    let dt = 0.005;
    hidden(EffectId::TimeOffset, "time_offset_s", dt, &move |rec, i| {
        let j = i.max(1);
        let (a, b) = (&rec.imu[j - 1], &rec.imu[j]);
        let slope = (Vector3::from(b.gyro_radps) - Vector3::from(a.gyro_radps)) / (b.t_s - a.t_s);
        (-slope * dt, Vector3::zeros())
    });
}

/// The encoder's angle at `t`, rad: linear between reads.
fn encoder_angle(rec: &Recording, t: f64) -> f64 {
    let i = rec
        .table
        .partition_point(|r| r.t_s <= t)
        .clamp(1, rec.table.len() - 1);
    let (a, b) = (&rec.table[i - 1], &rec.table[i]);
    a.angle_rad + (b.angle_rad - a.angle_rad) * (t - a.t_s) / (b.t_s - a.t_s)
}

#[test]
fn a_mount_wobble_hidden_in_the_real_stepper_run_is_found_at_its_size() {
    // The sensor rocking 0.3 deg on its shaft about y once a turn (a bent
    // shaft): a small rotation delta = y a cos(theta), so the gyros see
    // theta_dot (k x y a cos + y d(a cos)/d theta) and the accelerometers
    // f x y a cos, from the encoder's angle and rate and the measured
    // specific force. Half of that rocking, y cos - z sin (a/2), stays
    // fixed in the table's base: a tilt of the base, no wobble, which no
    // run can tell from one; the other half, y cos + z sin, is what the
    // report's `wobble_1x_cos_rad` measures: a/2.
    let a = 0.3f64.to_radians();
    hidden(
        EffectId::TableAngleHarmonic,
        "wobble_1x_cos_rad",
        a / 2.0,
        &move |rec, i| {
            let k = rec.meta.axis.unit::<f64>();
            let u = Vector3::y();
            let t = rec.imu[i].t_s;
            let (theta, (w, _)) = (encoder_angle(rec, t), encoder_motion(rec, t));
            let (h, dh) = (a * theta.cos(), -a * theta.sin());
            let f = Vector3::from(rec.imu[i].accel_mps2);
            (w * (k.cross(&u) * h + u * dh), f.cross(&u) * h)
        },
    );
}

#[test]
fn what_the_real_run_cannot_show_at_all_is_declared_so() {
    // The earth rate, a tilt of the table axis and an encoder's
    // once-a-turn error: what this run's motion does not excite (the
    // report's reasons: a vertical table axis, whole revolutions, a steady
    // rate); no injection can show them here, and the report says so,
    // each with the run that would.
    let (_, d) = cut();
    for e in [
        EffectId::EarthRate,
        EffectId::AxisTilt,
        EffectId::EncoderError,
    ] {
        let why = d.details.not_observable.iter().find(|(x, _)| *x == e);
        assert!(
            why.is_some_and(|(_, w)| w.contains("turn the table")),
            "{e}: {why:?}"
        );
        assert!(!d.findings.iter().any(|f| f.effect == e), "{e} named");
    }
}

#[test]
fn rate_terms_the_one_speed_run_cannot_show_are_declared_not_observable() {
    // The stepper turns at one speed one way: a rate-squared term and an
    // asymmetry are a scale change there (0.2 % of 2000 deg/s full scale,
    // the MPU-6050's nonlinearity; 1 % asymmetry).
    let k2 = 0.002 / 2000f64.to_radians();
    hidden(
        EffectId::GyroScaleNonlinearity,
        "k2_x_per_radps",
        k2,
        &move |rec, i| {
            let w = rec.imu[i].gyro_radps[0];
            (Vector3::new(k2 * w * w, 0.0, 0.0), Vector3::zeros())
        },
    );
    hidden(
        EffectId::GyroScaleAsymmetry,
        "asymmetry_x",
        0.01,
        &move |rec, i| {
            let w = rec.imu[i].gyro_radps[0];
            (
                Vector3::new(0.5 * 0.01 * w.abs(), 0.0, 0.0),
                Vector3::zeros(),
            )
        },
    );
}

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

/// The table's motion a copy takes as true: the encoder's reads or the
/// table-axis gyro (the rate the sensor turns at, the stepper's ripple
/// included).
#[derive(Clone, Copy, Debug)]
enum Truth {
    Encoder,
    Gyro,
}

/// The table-axis gyro's rate and acceleration at every sample (rad/s,
/// rad/s^2): the gyro less its mean against the encoder's rate (its bias),
/// the acceleration its centred difference.
fn gyro_motion(rec: &Recording) -> Vec<(f64, f64)> {
    let k = rec.meta.axis.unit::<f64>();
    let g: Vec<f64> = rec
        .imu
        .iter()
        .map(|s| Vector3::from(s.gyro_radps).dot(&k))
        .collect();
    let e: Vec<f64> = rec
        .imu
        .iter()
        .map(|s| encoder_motion(rec, s.t_s).0)
        .collect();
    let bias = g.iter().zip(&e).map(|(g, e)| g - e).sum::<f64>() / g.len() as f64;
    let n = g.len();
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let dt = rec.imu[b].t_s - rec.imu[a].t_s;
            (g[i] - bias, (g[b] - g[a]) / dt)
        })
        .collect()
}

/// The lever arm's specific force (m/s^2 in the sensor frame) at every
/// sample for an arm `r` (m) under the motion `truth` takes.
fn lever_force(rec: &Recording, r: Vector3<f64>, truth: Truth) -> Vec<Vector3<f64>> {
    let k = rec.meta.axis.unit::<f64>();
    let motion = match truth {
        Truth::Encoder => rec.imu.iter().map(|s| encoder_motion(rec, s.t_s)).collect(),
        Truth::Gyro => gyro_motion(rec),
    };
    motion
        .iter()
        .map(|&(w, a)| k.cross(&r) * a + k.cross(&k.cross(&r)) * w * w)
        .collect()
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
    // The upstream firmware's print steps (both runs' ORIGIN.md): gyro
    // 0.01 deg/s, accel 0.01 g (what `plausible::lattice` finds on the
    // slow run; on the fast run's turning rates too few levels repeat in
    // its sample for it to say).
    let (gq, aq) = (0.01f64.to_radians(), 0.01 * G0);
    let lattice = [gq, gq, gq, aq, aq, aq];
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

/// One parameter hidden: (effect, parameter name, size in its unit).
type Case = (EffectId, &'static str, f64);

/// Hides the `cases` in the run `base` (the run and its own diagnosis)
/// through `add`, all at once, and checks each against diagnose's change
/// from the untouched run ([`sized`]).
fn hidden_in(base: &(Recording, Diagnosis), cases: &[Case], add: &Add) {
    let (rec, d0) = base;
    let d = run(&injected(rec, add), "injected", &Options::default()).unwrap();
    println!(
        "  named: {:?}",
        d.findings.iter().map(|f| f.effect).collect::<Vec<_>>()
    );
    for &(effect, name, size) in cases {
        sized(d0, &d, effect, name, size);
    }
}

/// The change of `effect`'s parameter `name` between the untouched run's
/// diagnosis `d0` and the copy's `d`: the size hidden within 35 % + 3
/// sigma; or, where the run's power for that parameter (the smallest size
/// it shows, in the report) is above the size hidden, the report says so:
/// declared not observable when even the physical bound is beyond it.
fn sized(d0: &Diagnosis, d: &Diagnosis, effect: EffectId, name: &str, size: f64) {
    let power = d
        .details
        .observability
        .iter()
        .find(|o| o.effect == effect && o.parameter == name)
        .unwrap_or_else(|| panic!("{name}: no power reported"));
    let ((v1, s1), (v0, s0)) = (param(d, effect, name), param(d0, effect, name));
    let (change, sigma) = (v1 - v0, s1.hypot(s0));
    let off = (change - size).abs();
    println!(
        "{name}: untouched {v0:.4e} +- {s0:.1e}, with {size:.3e} hidden {v1:.4e} +- {s1:.1e}: change {change:.4e} ({:+.0} %, {:.1} sigma); the run shows it from {:?} (bound {:.3e})",
        100.0 * (change / size - 1.0),
        off / sigma,
        power.min_detectable,
        power.bound
    );
    let named = d.findings.iter().any(|f| f.effect == effect);
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
        off <= 0.35 * size.abs() + 3.0 * sigma,
        "{name}: change {change:.4e} against {size:.4e} (+- {sigma:.1e})"
    );
}

const G0: f64 = 9.80665;

/// The fast run (half turns about x at 325 deg/s mean while turning, its
/// whole 23.5 min) and its diagnosis, made once; `None` when the shared
/// data is absent (said on stderr).
fn fast(test: &str) -> Option<&'static (Recording, Diagnosis)> {
    static B: Base = Base::new();
    let test = format!("diagnose_inject_real::{test}");
    let p = rins_tests::data::external(&test, "mpu6050_stepper_roll_fast", "recording")?;
    Some(B.get_or_init(|| untouched(Recording::read(&p).unwrap())))
}

/// The runs a test hides its effects in: the bundled slow cut, and the
/// fast run (read from the shared data; its absence said on stderr).
fn runs(test: &str) -> Vec<&'static (Recording, Diagnosis)> {
    let mut v = vec![cut()];
    v.extend(fast(test));
    v
}

/// A 2 cm lever arm off the roll axis (x) along `r` (m), the motion as
/// `truth` takes it.
fn lever(rec: &Recording, r: Vector3<f64>, truth: Truth) -> Box<Add> {
    let f = lever_force(rec, r, truth);
    Box::new(move |_, i| (Vector3::zeros(), f[i]))
}

/// The MPU-6050's datasheet g-sensitivity, 0.1 deg/s per g, on gyro y
/// from the measured specific force along z (rad/s per m/s^2).
const G_SENS: f64 = 0.1 * std::f64::consts::PI / 180.0 / G0;

fn g_sensitivity() -> Box<Add> {
    Box::new(|rec, i| {
        (
            Vector3::new(0.0, G_SENS * rec.imu[i].accel_mps2[2], 0.0),
            Vector3::zeros(),
        )
    })
}

/// A further latency of `dt` (s) on the gyros (`gyro`) or the
/// accelerometers: each sample the one `dt` before (linear between the
/// measured samples).
fn latency(dt: f64, gyro: bool) -> Box<Add> {
    Box::new(move |rec, i| {
        let j = i.max(1);
        let (a, b) = (&rec.imu[j - 1], &rec.imu[j]);
        let d = |x: [f64; 3], y: [f64; 3]| (Vector3::from(y) - Vector3::from(x)) / (b.t_s - a.t_s);
        if gyro {
            (-d(a.gyro_radps, b.gyro_radps) * dt, Vector3::zeros())
        } else {
            (Vector3::zeros(), -d(a.accel_mps2, b.accel_mps2) * dt)
        }
    })
}

/// A gyro settling after turn-on (no temperature recorded: a warm-up
/// exponential), 0.3 deg/s on y over a 60 s time constant: a tenth of the
/// MPU-6050's +-20 deg/s turn-on tolerance, settling as a small board
/// warms.
const WARM_UP: (f64, f64) = (0.3 * std::f64::consts::PI / 180.0, 60.0);

fn warm_up() -> Box<Add> {
    let (a, tau) = WARM_UP;
    Box::new(move |rec, i| {
        let t = rec.imu[i].t_s - rec.imu[0].t_s;
        (
            Vector3::new(0.0, a * (1.0 - (-t / tau).exp()), 0.0),
            Vector3::zeros(),
        )
    })
}

/// The table's base tilted `delta` (rad) about y (normal to the roll
/// axis): gravity in the sensor frame moves by `f_s x delta_s`, with
/// `delta_s` the tilt turned into the sensor frame by the encoder's angle.
fn tilt(delta: f64) -> Box<Add> {
    Box::new(move |rec, i| {
        let th = encoder_angle(rec, rec.imu[i].t_s);
        let d_s = Vector3::new(0.0, th.cos(), -th.sin()) * delta;
        let f = Vector3::from(rec.imu[i].accel_mps2);
        (Vector3::zeros(), f.cross(&d_s))
    })
}

/// Two injections at once.
fn both(a: Box<Add>, b: Box<Add>) -> Box<Add> {
    Box::new(move |rec, i| {
        let ((g1, a1), (g2, a2)) = (a(rec, i), b(rec, i));
        (g1 + g2, a1 + a2)
    })
}

const LEVER_Y: Vector3<f64> = Vector3::new(0.0, 0.02, 0.0);

#[test]
fn a_lever_arm_hidden_in_the_real_stepper_runs_is_found_at_its_size() {
    // Along y and along z (radial both), each under both motion truths.
    for base in runs("a_lever_arm_hidden_in_the_real_stepper_runs_is_found_at_its_size") {
        for truth in [Truth::Encoder, Truth::Gyro] {
            for (name, r) in [
                ("lever_y_m", LEVER_Y),
                ("lever_z_m", Vector3::new(0.0, 0.0, 0.02)),
            ] {
                println!("{truth:?} motion as truth:");
                let add = lever(&base.0, r, truth);
                hidden_in(base, &[(EffectId::LeverArm, name, 0.02)], &*add);
            }
        }
    }
}

#[test]
fn a_g_sensitivity_hidden_in_the_real_stepper_runs_is_found_at_its_size() {
    for base in runs("a_g_sensitivity_hidden_in_the_real_stepper_runs_is_found_at_its_size") {
        let case = (
            EffectId::GyroGSensitivity,
            "g_sens_yz_radps_per_mps2",
            G_SENS,
        );
        hidden_in(base, &[case], &*g_sensitivity());
    }
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
    let mut bases = vec![untouched(Recording::read(&p).unwrap())];
    bases.extend(
        fast("an_accelerometer_nonlinearity_hidden_in_the_whole_real_run_is_found_at_its_size")
            .cloned(),
    );
    let k2 = 0.005 / G0;
    for base in &bases {
        hidden_in(
            base,
            &[(EffectId::AccelScaleNonlinearity, "k2_y_per_mps2", k2)],
            &move |rec, i| {
                let f = rec.imu[i].accel_mps2[1];
                (Vector3::zeros(), Vector3::new(0.0, k2 * f * f, 0.0))
            },
        );
    }
}

#[test]
fn a_further_accelerometer_latency_hidden_in_the_real_stepper_runs_is_found_at_its_size() {
    for base in
        runs("a_further_accelerometer_latency_hidden_in_the_real_stepper_runs_is_found_at_its_size")
    {
        let case = (EffectId::TimeOffset, "accel_time_offset_s", 0.005);
        hidden_in(base, &[case], &*latency(0.005, false));
    }
}

#[test]
fn a_warm_up_hidden_in_the_real_stepper_runs_is_found_at_its_size() {
    for base in runs("a_warm_up_hidden_in_the_real_stepper_runs_is_found_at_its_size") {
        let case = (EffectId::TemperatureBias, "warmup_bias_y_radps", WARM_UP.0);
        hidden_in(base, &[case], &*warm_up());
    }
}

#[test]
fn a_further_gyro_latency_hidden_in_the_real_stepper_runs_is_found_at_its_size() {
    for base in runs("a_further_gyro_latency_hidden_in_the_real_stepper_runs_is_found_at_its_size")
    {
        let case = (EffectId::TimeOffset, "time_offset_s", 0.005);
        hidden_in(base, &[case], &*latency(0.005, true));
    }
}

#[test]
fn two_effects_hidden_at_once_in_the_real_stepper_runs_are_both_sized() {
    // A lever arm with an accelerometer latency (both ride on the rate's
    // changes), g-sensitivity with an axis tilt (both follow gravity's
    // turn), a gyro latency with a warm-up.
    for base in runs("two_effects_hidden_at_once_in_the_real_stepper_runs_are_both_sized") {
        for truth in [Truth::Encoder, Truth::Gyro] {
            println!("lever arm ({truth:?} motion) and accelerometer latency:");
            hidden_in(
                base,
                &[
                    (EffectId::LeverArm, "lever_y_m", 0.02),
                    (EffectId::TimeOffset, "accel_time_offset_s", 0.005),
                ],
                &*both(lever(&base.0, LEVER_Y, truth), latency(0.005, false)),
            );
        }
        // A tenth of a degree: a base levelled by eye.
        let delta = 0.1f64.to_radians();
        println!("g-sensitivity and an axis tilt:");
        hidden_in(
            base,
            &[
                (
                    EffectId::GyroGSensitivity,
                    "g_sens_yz_radps_per_mps2",
                    G_SENS,
                ),
                (EffectId::AxisTilt, "tilt_about_y_rad", delta),
            ],
            &*both(g_sensitivity(), tilt(delta)),
        );
        println!("gyro latency and a warm-up:");
        hidden_in(
            base,
            &[
                (EffectId::TimeOffset, "time_offset_s", 0.005),
                (EffectId::TemperatureBias, "warmup_bias_y_radps", WARM_UP.0),
            ],
            &*both(latency(0.005, true), warm_up()),
        );
    }
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
fn a_mount_wobble_hidden_in_the_real_stepper_runs_is_found_at_its_size() {
    // The sensor rocking 0.3 deg on its shaft about y once a turn (a bent
    // shaft): a small rotation delta = y a cos(theta), so the gyros see
    // theta_dot (k x y a cos + y d(a cos)/d theta) and the accelerometers
    // f x y a cos, from the encoder's angle, the rate as each truth takes
    // it and the measured specific force. Half of that rocking, y cos - z
    // sin (a/2), stays fixed in the table's base: a tilt of the base, no
    // wobble, which no run can tell from one; the other half, y cos + z
    // sin, is what the report's `wobble_1x_cos_rad` measures: a/2.
    let a = 0.3f64.to_radians();
    for base in runs("a_mount_wobble_hidden_in_the_real_stepper_runs_is_found_at_its_size") {
        for truth in [Truth::Encoder, Truth::Gyro] {
            println!("{truth:?} motion as truth:");
            let rec = &base.0;
            let rate: Vec<f64> = match truth {
                Truth::Encoder => rec
                    .imu
                    .iter()
                    .map(|s| encoder_motion(rec, s.t_s).0)
                    .collect(),
                Truth::Gyro => gyro_motion(rec).iter().map(|m| m.0).collect(),
            };
            let add = move |rec: &Recording, i: usize| {
                let k = rec.meta.axis.unit::<f64>();
                let u = Vector3::y();
                let theta = encoder_angle(rec, rec.imu[i].t_s);
                let (h, dh) = (a * theta.cos(), -a * theta.sin());
                let f = Vector3::from(rec.imu[i].accel_mps2);
                (rate[i] * (k.cross(&u) * h + u * dh), f.cross(&u) * h)
            };
            let case = (EffectId::TableAngleHarmonic, "wobble_1x_cos_rad", a / 2.0);
            hidden_in(base, &[case], &add);
        }
    }
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
    hidden_in(
        cut(),
        &[(EffectId::GyroScaleNonlinearity, "k2_x_per_radps", k2)],
        &move |rec, i| {
            let w = rec.imu[i].gyro_radps[0];
            (Vector3::new(k2 * w * w, 0.0, 0.0), Vector3::zeros())
        },
    );
    hidden_in(
        cut(),
        &[(EffectId::GyroScaleAsymmetry, "asymmetry_x", 0.01)],
        &move |rec, i| {
            let w = rec.imu[i].gyro_radps[0];
            (
                Vector3::new(0.5 * 0.01 * w.abs(), 0.0, 0.0),
                Vector3::zeros(),
            )
        },
    );
}

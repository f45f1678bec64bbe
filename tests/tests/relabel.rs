//! The same answer in any frame: a recording relabelled by a fixed set of
//! signed axis permutations (`recording::relabel::AxisMap::SET`: the base
//! rolled 180 deg, pitched 90 deg, turned 90 deg in heading, the sensor
//! axes cycled, swapped with sign flips; the table axis carried along) is
//! the same physical run, so diagnose must name the same effects with the
//! same sizes, rotated into the new axes, within their sigmas.
//!
//! Run on the real stepper-table recording (bundled, 300 s) and on
//! simulated runs of every effect id.

use core_nav::table::Axis;
use hal_sim::sim::simulate;
use recording::relabel::{relabel, AxisMap};
use recording::Recording;
use rins::diagnose::{run, Diagnosis, Options};

/// The table axis's two normals `u1`, `u2` (cyclic after it: `u1 x u2 =
/// k`), as diagnose and hal-sim take them.
fn normals(a: Axis) -> [nalgebra::Vector3<f64>; 2] {
    let i = a.unit::<f64>().iamax();
    [(i + 1) % 3, (i + 2) % 3].map(|j| nalgebra::Vector3::ith(j, 1.0))
}

/// The once-a-turn wobble's two parts in the relabelled axes. The rocking
/// `c (u1 cos + u2 sin) + s (u1 sin - u2 cos)` is, at `theta = 0` (the
/// same encoder zero in both labellings), the small rotation `c u1 - s
/// u2`: carried into the new axes by `P` and read back on the new
/// normals.
fn wobble_1x(name: &str, value: f64, m: &AxisMap, old: Axis, new: Axis) -> Option<(String, f64)> {
    let ([u1, u2], [n1, n2]) = (normals(old), normals(new));
    let d0 = match name {
        "wobble_1x_cos_rad" => u1 * value,
        "wobble_1x_sin_rad" => -u2 * value,
        _ => return None,
    };
    let d = m.p * d0;
    let (c, s) = (n1.dot(&d), -n2.dot(&d));
    Some(if c.abs() >= s.abs() {
        ("wobble_1x_cos_rad".into(), c)
    } else {
        ("wobble_1x_sin_rad".into(), s)
    })
}

/// A parameter's name and value in the relabelled axes: a `_x_`-style
/// token is a vector component (`P v`), an `_xy_` token a tensor entry
/// (`P G P^T`), the encoder's cosine part flips with the table angle, the
/// once-a-turn wobble's parts turn with the normals ([`wobble_1x`]); every
/// other parameter (offsets, the earth rate, noise) is a scalar.
fn mapped(name: &str, value: f64, m: &AxisMap, axis: Axis) -> (String, f64) {
    let (new_axis, angle_sign) = m.axis(axis);
    if let Some(x) = wobble_1x(name, value, m, axis, new_axis) {
        return x;
    }
    let ax = |c: char| "xyz".find(c);
    let to = |i: usize| -> (usize, f64) {
        let col = m.p.column(i);
        let j = col.iamax();
        (j, col[j])
    };
    let letters = ['x', 'y', 'z'];
    let mut tokens: Vec<String> = name.split('_').map(str::to_string).collect();
    let mut sign = 1.0;
    for t in tokens.iter_mut() {
        let idx: Vec<usize> = t.chars().filter_map(ax).collect();
        if idx.is_empty() || idx.len() != t.len() || idx.len() > 2 {
            continue;
        }
        let mut out = String::new();
        for i in idx {
            let (j, s) = to(i);
            sign *= s;
            out.push(letters[j]);
        }
        *t = out;
        break;
    }
    if name == "encoder_cos_rad" {
        sign = angle_sign;
    }
    // A wobble's sine parts flip with the angle: sin(n theta) = s sin(n theta').
    if name.starts_with("wobble_") && name.contains("_sin_") {
        sign *= angle_sign;
    }
    (tokens.join("_"), sign * value)
}

fn ids(d: &Diagnosis) -> Vec<&'static str> {
    let mut v: Vec<&str> = d.findings.iter().map(|f| f.effect.as_str()).collect();
    v.sort();
    v
}

/// Every finding of `a` is in `b` with its parameters mapped, within the
/// larger of the two sigmas.
fn same(a: &Diagnosis, b: &Diagnosis, m: &AxisMap, axis: Axis) -> Result<(), String> {
    if ids(a) != ids(b) {
        return Err(format!("ids {:?} vs {:?}", ids(a), ids(b)));
    }
    for fa in &a.findings {
        if fa.effect.as_str() == "bias_instability" {
            continue; // noise, not a parameter of the physics
        }
        let fb = b
            .findings
            .iter()
            .find(|f| f.effect == fa.effect)
            .ok_or("missing")?;
        for pa in fa.parameters.iter().filter(|p| p.sigma.is_some()) {
            let (name, want) = mapped(&pa.name, pa.value, m, axis);
            let pb = fb
                .parameters
                .iter()
                .find(|p| p.name == name)
                .ok_or_else(|| format!("{}: {} -> {name} not fitted", fa.effect, pa.name))?;
            let tol = pa.sigma.unwrap_or(0.0).max(pb.sigma.unwrap_or(0.0));
            if (pb.value - want).abs() > tol {
                return Err(format!(
                    "{} {} = {:.4e} +- {:.1e} -> {name} expected {want:.4e}, got {:.4e} +- {:.1e}",
                    fa.effect,
                    pa.name,
                    pa.value,
                    pa.sigma.unwrap_or(0.0),
                    pb.value,
                    pb.sigma.unwrap_or(0.0)
                ));
            }
        }
    }
    Ok(())
}

fn check(rec: &Recording, label: &str, maps: &[AxisMap]) -> Vec<String> {
    let opts = Options::default();
    let a = run(rec, label, &opts).unwrap();
    println!("{label}: {:?}", ids(&a));
    let mut bad = vec![];
    for m in maps {
        let r = relabel(rec, m).unwrap();
        let b = run(&r, m.name, &opts).unwrap();
        if let Err(e) = same(&a, &b, m, rec.meta.axis) {
            bad.push(format!("{label}, {}: {e}", m.name));
        }
    }
    bad
}

#[test]
fn the_parameter_map_rotates_vectors_and_tensors() {
    let m = AxisMap::CYCLE; // new (x, y, z) = old (y, z, x)
    let z = Axis::Z;
    assert_eq!(mapped("lever_y_m", 2.0, &m, z), ("lever_x_m".into(), 2.0));
    assert_eq!(
        mapped("g_sens_zx_radps_per_mps2", 3.0, &m, z),
        ("g_sens_yz_radps_per_mps2".into(), 3.0)
    );
    let f = AxisMap::ROLL_180; // y and z flip: the table angle about z too
    assert_eq!(
        mapped("k2_z_per_radps", 1.0, &f, z),
        ("k2_z_per_radps".into(), -1.0)
    );
    assert_eq!(
        mapped("g_sens_yz_radps_per_mps2", 1.0, &f, z),
        ("g_sens_yz_radps_per_mps2".into(), 1.0)
    );
    assert_eq!(mapped("encoder_cos_rad", 1.0, &f, z).1, -1.0);
    assert_eq!(mapped("time_offset_s", 0.01, &f, z).1, 0.01);
    // c (x cos + y sin) + s (x sin - y cos) with y' = -y, theta' = -theta:
    // c (x' cos' + y' sin') - s (x' sin' - y' cos').
    assert_eq!(
        mapped("wobble_1x_cos_rad", 2.0, &f, z),
        ("wobble_1x_cos_rad".into(), 2.0)
    );
    assert_eq!(
        mapped("wobble_1x_sin_rad", 2.0, &f, z),
        ("wobble_1x_sin_rad".into(), -2.0)
    );
}

#[test]
fn the_real_stepper_table_gives_the_same_answer_in_every_labelling() {
    let p = rins_tests::data::bundled("mpu6050_stepper_roll_slow_300s");
    let rec = Recording::read(&p).unwrap();
    let bad = check(&rec, "mpu6050 stepper (real)", &AxisMap::SET);
    assert!(bad.is_empty(), "{bad:#?}");
}

/// A run with one effect hidden on the reduced NAV440 (300 s).
fn hidden(effect: &str, v: f64, axis: Axis, seed: u64) -> Recording {
    let mut c = rins_tests::runs::reduced_nav440(axis, false, seed, 300.0);
    c.set_effect(effect, v).unwrap();
    simulate(&c, &mut |_| {}).unwrap()
}

#[test]
fn every_effect_id_gives_the_same_answer_in_other_labellings() {
    // Sizes twice those `diagnose::each_effect_is_named_first` finds in
    // 600 s: this run is half as long. Each effect is relabelled by two of
    // the maps, in turn, so every map meets several effects.
    let cases = [
        ("lever_arm", 0.04, Axis::Z),
        ("time_offset", 0.004, Axis::Z),
        ("accel_time_offset", 0.004, Axis::Y),
        ("gyro_scale_nonlinearity", 0.006, Axis::Z),
        ("gyro_scale_asymmetry", 0.006, Axis::Z),
        ("axis_tilt", 0.004, Axis::Z),
        ("encoder_error", 4e-4, Axis::Z),
        ("temperature_bias", 1e-3, Axis::Z),
        ("gyro_g_sensitivity", 4e-4, Axis::Y),
        ("accel_scale_nonlinearity", 4e-4, Axis::Y),
        ("earth_rate", 0.0, Axis::Z),
        ("bias_instability", 2e-5, Axis::Z),
        ("table_angle_harmonic", 2e-3, Axis::Z),
        // Ten times the NAV440's gyro white noise density, rad/sqrt(s).
        ("untracked_table_motion", 1.2e-3, Axis::Z),
    ];
    let set = AxisMap::SET;
    let mut bad = vec![];
    for (k, (effect, v, axis)) in cases.into_iter().enumerate() {
        let rec = hidden(effect, v, axis, 21 + k as u64);
        let maps = [set[k % set.len()], set[(k + 2) % set.len()]];
        bad.extend(check(&rec, effect, &maps));
    }
    assert!(bad.is_empty(), "{bad:#?}");
}

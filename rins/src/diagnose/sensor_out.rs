//! `rins diagnose --sensor-out`: a sensor file (`rins-sensor/2`) from a
//! diagnosis: what the findings measured of the sensor itself (per triad
//! the RMS over the axes it was found on: g-sensitivity, scale
//! nonlinearity and asymmetry, temperature coefficients, latency), on top
//! of a base sensor for the rest. Findings about the table (lever arm,
//! axis tilt, encoder, wobble, untracked motion) and the site (earth
//! rate) are not a sensor's: they are listed in the file's comments.

use hal_sim::catalogue::EffectId;
use hal_sim::imu::ImuSpec;

use super::Diagnosis;

/// The RMS of the values of the parameters whose name starts with
/// `prefix` and ends with `suffix`, over the findings of `effect`.
fn rms_of(d: &Diagnosis, effect: EffectId, prefix: &str, suffix: &str) -> Option<f64> {
    let v: Vec<f64> = d
        .findings
        .iter()
        .filter(|f| f.effect == effect)
        .flat_map(|f| &f.parameters)
        .filter(|p| p.name.starts_with(prefix) && p.name.ends_with(suffix) && p.value.is_finite())
        .map(|p| p.value)
        .collect();
    (!v.is_empty()).then(|| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt())
}

/// The mean of the values of the parameter `name` (signed: a time
/// offset's sign is its direction) over the findings of `effect`.
fn mean_of(d: &Diagnosis, effect: EffectId, name: &str) -> Option<f64> {
    let v: Vec<f64> = d
        .findings
        .iter()
        .filter(|f| f.effect == effect)
        .flat_map(|f| &f.parameters)
        .filter(|p| p.name == name && p.value.is_finite())
        .map(|p| p.value)
        .collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// The sensor file of `d` (recording `rec`) on top of `base`
/// ([`crate::sensor_file::Written`]): the noise of the final residual
/// (white noise and bias instability per triad where the run supports
/// them, the quietest axis's: motion the model leaves out only adds; the
/// table axis left out), the resolution and full scale the samples show,
/// and what the findings measured of the sensor itself.
pub fn sensor_file(
    d: &Diagnosis,
    rec: &recording::Recording,
    base: Option<crate::sensor_file::Base>,
    what: &str,
) -> String {
    let mut w = crate::sensor_file::Written::start(base, "diagnose", what);
    let turned = d.details.theta.windows(2).any(|w| w[0] != w[1]);
    w.noise(
        &d.details.allan,
        turned.then_some(d.details.axis_index),
        crate::sensor_file::Combine::Quietest,
    );
    w.seen_in_data(rec);
    let intercepts: Vec<Option<f64>> = d.details.nominal.iter().map(|n| n[0]).collect();
    w.bias_from_run(&intercepts);
    // (the term's key, the finding, its parameters' prefix and suffix, the field).
    type Field = fn(&mut ImuSpec) -> &mut f64;
    let measured: [(&str, EffectId, &str, &str, Field); 6] = [
        (
            "gyro.g_sensitivity_dps_per_g",
            EffectId::GyroGSensitivity,
            "g_sens_",
            "_radps_per_mps2",
            |s| &mut s.g_sensitivity,
        ),
        (
            "gyro.nonlinearity_pct_fs",
            EffectId::GyroScaleNonlinearity,
            "k2_",
            "_per_radps",
            |s| &mut s.gyro.k2,
        ),
        (
            "gyro.asymmetry_pct",
            EffectId::GyroScaleAsymmetry,
            "asymmetry_",
            "",
            |s| &mut s.gyro.asymmetry,
        ),
        (
            "accel.nonlinearity_pct_fs",
            EffectId::AccelScaleNonlinearity,
            "k2_",
            "_per_mps2",
            |s| &mut s.accel.k2,
        ),
        (
            "gyro.temp_bias_dps_per_c",
            EffectId::TemperatureBias,
            "temp_bias_",
            "_radps_per_degc",
            |s| &mut s.gyro.temp_bias,
        ),
        (
            "accel.temp_bias_mg_per_c",
            EffectId::TemperatureBias,
            "temp_bias_",
            "_mps2_per_degc",
            |s| &mut s.accel.temp_bias,
        ),
    ];
    for (key, effect, prefix, suffix, field) in measured {
        if let Some(v) = rms_of(d, effect, prefix, suffix) {
            w.measured(key, |s| *field(s) = v);
        }
    }
    if let Some(l) = mean_of(d, EffectId::TimeOffset, "time_offset_s") {
        w.measured("gyro.latency_s", |s| s.latency_s = l);
    }
    if let Some(a) = mean_of(d, EffectId::TimeOffset, "accel_time_offset_s") {
        w.measured("accel.latency_s", |s| s.accel_latency_s = Some(a));
    }
    // A nonlinearity is written against the full scale: without one it
    // is unknown, not zero.
    for (t, key) in [
        (&mut w.spec.gyro, "gyro.nonlinearity_pct_fs"),
        (&mut w.spec.accel, "accel.nonlinearity_pct_fs"),
    ] {
        if t.k2 > 0.0 && t.full_scale <= 0.0 {
            w.notes.push(format!(
                "{key}: measured k2 {:.3e} (SI), but there is no full scale to write it against",
                t.k2
            ));
            t.k2 = 0.0;
            w.spec.unknown.push(key.into());
            w.from.measured.retain(|m| m != key);
        }
    }
    for f in &d.findings {
        if matches!(
            f.effect,
            EffectId::LeverArm
                | EffectId::AxisTilt
                | EffectId::EncoderError
                | EffectId::TableAngleHarmonic
                | EffectId::UntrackedTableMotion
                | EffectId::EarthRate
        ) {
            let p: Vec<String> = f
                .parameters
                .iter()
                .map(|p| format!("{} = {:.4e}", p.name, p.value))
                .collect();
            w.notes
                .push(format!("not the sensor's ({}): {}", f.effect, p.join(", ")));
        }
    }
    w.text()
}

//! `rins diagnose --sensor-out`: a sensor file (`rins-sensor/1`) from a
//! diagnosis: what the findings measured of the sensor itself (per triad
//! the RMS over the axes it was found on: g-sensitivity, scale
//! nonlinearity and asymmetry, temperature coefficients, latency), on top
//! of a base sensor for the rest. Findings about the table (lever arm,
//! axis tilt, encoder, wobble, untracked motion) and the site (earth
//! rate) are not a sensor's: they are listed in the file's comments.

use hal_sim::catalogue::EffectId;
use hal_sim::imu::ImuSpec;
use hal_sim::sensor::G0;

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

/// The sensor file of `d` on top of `base`.
pub fn sensor_file(d: &Diagnosis, base: Option<ImuSpec>, what: &str) -> String {
    let mut s = base.unwrap_or_else(|| ImuSpec {
        name: "measured".into(),
        model: "measured".into(),
        ..ImuSpec::ideal()
    });
    let from = s.name.clone();
    s.name = format!("{from}-diagnosed");
    let mut notes = vec![
        format!("Written by rins diagnose from {what}: the terms its findings measured"),
        format!("(the RMS over the axes they were found on); the rest is {from:?}'s."),
    ];
    // (what, the finding, its parameters' prefix and suffix, the field).
    type Field = fn(&mut ImuSpec) -> &mut f64;
    let measured: [(&str, EffectId, &str, &str, Field); 6] = [
        (
            "gyro g-sensitivity",
            EffectId::GyroGSensitivity,
            "g_sens_",
            "_radps_per_mps2",
            |s| &mut s.g_sensitivity,
        ),
        (
            "gyro scale nonlinearity",
            EffectId::GyroScaleNonlinearity,
            "k2_",
            "_per_radps",
            |s| &mut s.gyro.k2,
        ),
        (
            "gyro scale asymmetry",
            EffectId::GyroScaleAsymmetry,
            "asymmetry_",
            "",
            |s| &mut s.gyro.asymmetry,
        ),
        (
            "accel scale nonlinearity",
            EffectId::AccelScaleNonlinearity,
            "k2_",
            "_per_mps2",
            |s| &mut s.accel.k2,
        ),
        (
            "gyro bias temperature coefficient",
            EffectId::TemperatureBias,
            "temp_bias_",
            "_radps_per_degc",
            |s| &mut s.gyro.temp_bias,
        ),
        (
            "accel bias temperature coefficient",
            EffectId::TemperatureBias,
            "temp_bias_",
            "_mps2_per_degc",
            |s| &mut s.accel.temp_bias,
        ),
    ];
    for (name, effect, prefix, suffix, field) in measured {
        if let Some(v) = rms_of(d, effect, prefix, suffix) {
            *field(&mut s) = v;
            notes.push(format!("measured: {name}"));
        }
    }
    if let Some(l) = mean_of(d, EffectId::TimeOffset, "time_offset_s") {
        s.latency_s = l;
        notes.push("measured: latency".into());
    }
    if let Some(a) = mean_of(d, EffectId::TimeOffset, "accel_time_offset_s") {
        s.accel_latency_s = Some(a);
        notes.push("measured: accelerometer latency".into());
    }
    // A nonlinearity is written against the full scale: keep it when the
    // base has none.
    for (t, unit) in [(&mut s.gyro, 1.0), (&mut s.accel, 1.0 / G0)] {
        if t.k2 > 0.0 && t.full_scale <= 0.0 {
            notes.push(format!(
                "no full scale to write a nonlinearity of {:.3e} against ({unit})",
                t.k2
            ));
            t.k2 = 0.0;
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
            notes.push(format!("not the sensor's ({}): {}", f.effect, p.join(", ")));
        }
    }
    hal_sim::sensor::write(&s, &notes)
}

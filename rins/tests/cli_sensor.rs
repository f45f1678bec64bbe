//! A user characterises their unit and navigates with it: `rins allan
//! --sensor-out` writes a sensor file from a static recording, `rins
//! simulate --sensor FILE` and `rins navigate --gnss --sensor FILE` take
//! it. Our simulator only: the recording is hal-sim's ICM-42688-P.

use std::process::Command;

fn rins() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rins"))
}

fn ok(args: &[&str]) -> String {
    let o = rins().args(args).output().unwrap();
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn allan_writes_a_sensor_file_that_simulate_and_navigate_take() {
    let dir = std::env::temp_dir().join(format!("rins-cli-sensor-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let s = |p: &str| dir.join(p).display().to_string();
    ok(&[
        "simulate",
        "--sensor",
        "icm42688",
        "--scheme",
        "still",
        "--static-s",
        "300",
        "--duration-s",
        "300",
        "--seed",
        "9",
        "--out",
        &s("static"),
    ]);
    ok(&["allan", &s("static"), "--sensor-out", &s("unit.toml")]);
    let unit = hal_sim::sensor::resolve(&s("unit.toml")).unwrap();
    // The gyro's white noise is the datasheet's density: the file holds
    // the sensor's own, the 16-bit output's rounding (LSB / sqrt(12) over
    // the 100 Hz band, which the file's resolution gives) taken out;
    // 300 s of samples give it to a few per cent (the fit's sigma), 10 %
    // is its bound here.
    let want = 0.0028f64;
    let got = unit.gyro.white.to_degrees();
    assert!((got / want - 1.0).abs() < 0.1, "{got} vs {want}");
    // The resolution it saw: the datasheet's 16.4 LSB per deg/s.
    assert!((unit.gyro.lsb.to_degrees() * 16.4 - 1.0).abs() < 0.01);
    // What Allan cannot see comes from the recording's own model.
    let icm = hal_sim::sensor::resolve("icm42688").unwrap();
    assert_eq!(
        (unit.gyro.scale, unit.accel.full_scale),
        (icm.gyro.scale, icm.accel.full_scale)
    );
    // The file drives a simulation and a navigation.
    ok(&[
        "simulate",
        "--drive",
        "city",
        "--sensor",
        &s("unit.toml"),
        "--scheme",
        "continuous",
        "--duration-s",
        "60",
        "--seed",
        "2",
        "--out",
        &s("drive"),
    ]);
    let nav = ok(&[
        "navigate",
        &s("drive"),
        "--gnss",
        "--sensor",
        &s("unit.toml"),
        "--out",
        &s("nav"),
    ]);
    assert!(nav.contains("NEES"), "{nav}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_bad_sensor_file_is_refused_naming_file_and_key() {
    let dir = std::env::temp_dir().join(format!("rins-cli-badsensor-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("bad.toml");
    std::fs::write(&f, "format = \"rins-sensor/1\"\n[gyro]\nnoise_dps = 1\n").unwrap();
    let o = rins()
        .args([
            "simulate",
            "--sensor",
            f.to_str().unwrap(),
            "--out",
            dir.join("x").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && e.contains("bad.toml") && e.contains("gyro.noise_dps"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn diagnose_writes_the_latency_it_found_into_a_sensor_file() {
    // Our simulator only: a NAV440 run with 5 ms of latency injected.
    let dir = std::env::temp_dir().join(format!("rins-cli-diag-sensor-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let s = |p: &str| dir.join(p).display().to_string();
    ok(&[
        "simulate",
        "--sensor",
        "nav440",
        "--scheme",
        "reciprocating",
        "--rate-dps",
        "60",
        "--static-s",
        "30",
        "--duration-s",
        "300",
        "--seed",
        "4",
        "--effect",
        "time_offset=0.005",
        "--out",
        &s("rec"),
    ]);
    ok(&["diagnose", &s("rec"), "--sensor-out", &s("unit.toml")]);
    let unit = hal_sim::sensor::resolve(&s("unit.toml")).unwrap();
    // diagnose's latency on such runs is good to well under 0.1 ms (its own
    // sigma); 0.5 ms is this test's bound.
    assert!((unit.latency_s - 0.005).abs() < 5e-4, "{}", unit.latency_s);
    // The noise it measured (the axes across the table's, the output's
    // rounding taken out): the NAV440's ARW within 10 % (300 s of
    // samples).
    let nav = hal_sim::sensor::resolve("nav440").unwrap();
    let want = nav.gyro.white;
    assert!(
        (unit.gyro.white / want - 1.0).abs() < 0.1,
        "{} vs {want}",
        unit.gyro.white
    );
    let text = std::fs::read_to_string(s("unit.toml")).unwrap();
    assert!(text.contains("format = \"rins-sensor/2\"") && text.contains("base = \"nav440\""));
    assert!(text.contains("# measured"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

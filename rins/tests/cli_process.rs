//! `rins calibrate | navigate | allan | demo` end to end on a simulated
//! recording: outputs exist, JSON shapes are the issue's, errors are clear.

use std::path::Path;
use std::process::Command;

fn rins(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_rins"))
        .args(args)
        .output()
        .unwrap()
}

fn ok(o: &std::process::Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn calibrate_navigate_allan_on_a_simulated_run() {
    let dir = std::env::temp_dir().join(format!("rins-cli-proc-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let rec = dir.join("rec");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    ok(&rins(&[
        "simulate",
        "--sensor",
        "nav440",
        "--rate-dps",
        "30",
        "--static-s",
        "60",
        "--duration-s",
        "180",
        "--out",
        &s(&rec),
    ]));
    // calibrate: the report and rins-calibration/1.
    let cal = dir.join("cal.json");
    let out = ok(&rins(&[
        "calibrate",
        &s(&rec),
        "--json",
        &s(&cal),
        "--rate-dps",
        "30",
    ]));
    assert!(out.contains("bias [deg/h]"), "{out}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&cal).unwrap()).unwrap();
    assert_eq!(v["format"], "rins-calibration/1");
    assert_eq!(v["gyro"]["bias_radps"].as_array().unwrap().len(), 3);
    // navigate: trajectory-v1 header, one row per sample from the start, plots.
    let nav = dir.join("nav");
    let out = ok(&rins(&[
        "navigate",
        &s(&rec),
        "--calibration",
        &s(&cal),
        "--out",
        &s(&nav),
        "--start-s",
        "120",
    ]));
    assert!(out.contains("RMS"), "{out}");
    let traj = std::fs::read_to_string(nav.join("trajectory.csv")).unwrap();
    let mut lines = traj.lines();
    assert!(lines.next().unwrap().starts_with(
        "t_s,north_m,east_m,down_m,vn_mps,ve_mps,vd_mps,roll_deg,pitch_deg,heading_deg"
    ));
    assert_eq!(lines.count(), 6001);
    for f in [
        "position_error.svg",
        "velocity_error.svg",
        "roll_pitch_error.svg",
        "heading_error.svg",
    ] {
        assert!(std::fs::read_to_string(nav.join(f))
            .unwrap()
            .starts_with("<svg"));
    }
    // allan: rins-allan/1 with all six channels and their keys.
    let aj = dir.join("allan.json");
    let ap = dir.join("allan-plots");
    ok(&rins(&[
        "allan",
        &s(&rec),
        "--json",
        &s(&aj),
        "--plots",
        &s(&ap),
    ]));
    assert!(ap.join("allan.png").is_file() && ap.join("allan.svg").is_file());
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&aj).unwrap()).unwrap();
    assert_eq!(v["format"], "rins-allan/1");
    for ch in diagnose::noise_terms::CHANNELS {
        let c = &v["channels"][ch];
        let n = c["tau_s"].as_array().unwrap().len();
        assert!(n > 5, "{ch}");
        for k in ["adev", "adev_lo", "adev_hi"] {
            assert_eq!(c[k].as_array().unwrap().len(), n, "{ch}.{k}");
        }
        // A term the curve supports is a number; one it cannot (a floor
        // the 180 s run's averaging times do not reach) is null and named
        // in not_measured, never a zero.
        let not: Vec<&str> = c["not_measured"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_str().unwrap())
            .collect();
        for k in [
            "white_noise_density",
            "bias_instability",
            "rate_random_walk",
        ] {
            assert!(
                c[k].as_f64().is_some_and(|x| x > 0.0) || (c[k].is_null() && not.contains(&k)),
                "{ch}.{k}: {}",
                c[k]
            );
        }
        assert!(c["white_noise_density"].as_f64().unwrap() > 0.0, "{ch}");
    }
    // A calibration for another axis is refused with the reason.
    let mut bad = v.clone();
    bad["format"] = "x".into();
    let badp = dir.join("bad.json");
    std::fs::write(&badp, bad.to_string()).unwrap();
    let o = rins(&[
        "navigate",
        &s(&rec),
        "--calibration",
        &s(&badp),
        "--out",
        &s(&dir.join("n2")),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("rins-calibration/1"));
    // A malformed recording names the file and line.
    std::fs::write(rec.join("imu.csv"), "t_s,gyro_x_radps\n0,1\n").unwrap();
    let o = rins(&["allan", &s(&rec)]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("imu.csv:1: missing column gyro_y_radps"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn demo_runs_and_writes_its_plots() {
    let dir = std::env::temp_dir().join(format!("rins-cli-demo-{}", std::process::id()));
    let out = ok(&rins(&["demo", "--out", dir.to_str().unwrap()]));
    assert!(
        out.contains("conventional") && out.contains("rotary"),
        "{out}"
    );
    for f in [
        "position_error.svg",
        "roll_pitch_error.svg",
        "calibration.json",
        "trajectory_rotary.csv",
    ] {
        assert!(dir.join(f).exists(), "{f}");
    }
    assert!(dir.join("recording_rotary").join("imu.csv").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn navigate_gnss_draws_its_plots_and_refuses_a_truth_that_shares_no_time_with_the_run() {
    // A 30 s drive: navigated with its plots; then its truth.csv moved
    // past the run: an error naming the file and both spans, not errors
    // measured against nothing (a truth that ends early: cli_options.rs).
    let dir = std::env::temp_dir().join(format!("rins-cli-truth-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let rec = dir.join("rec");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    ok(&rins(&[
        "simulate",
        "--drive",
        "city",
        "--sensor",
        "icm42688",
        "--duration-s",
        "30",
        "--out",
        &s(&rec),
    ]));
    // Whole, it navigates and draws its plots.
    let nav = dir.join("nav");
    let out = ok(&rins(&["navigate", &s(&rec), "--gnss", "--out", &s(&nav)]));
    assert!(out.contains("wrote 6 plots"), "{out}");
    for f in ["map.png", "position_error.svg", "consistency.png"] {
        let len = std::fs::metadata(nav.join(f)).unwrap().len();
        assert!(len > 10_000, "{f}: {len} bytes");
    }
    let truth = rec.join("truth.csv");
    let text = std::fs::read_to_string(&truth).unwrap();
    // A truth that shares no time with the run (every row 100 s later).
    let late: Vec<String> = text
        .lines()
        .map(|l| match l.split_once(',') {
            Some((t, rest)) => match t.parse::<f64>() {
                Ok(t) => format!("{:.3},{rest}", t + 100.0),
                Err(_) => l.to_string(),
            },
            None => l.to_string(),
        })
        .collect();
    std::fs::write(&truth, late.join("\n") + "\n").unwrap();
    let o = rins(&[
        "navigate",
        &s(&rec),
        "--gnss",
        "--out",
        &s(&dir.join("nav")),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("truth.csv") && err.contains("covers") && err.contains("no time in common"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

//! No silently ignored option: each option of `navigate --gnss` and
//! `simulate --like` changes the result or is refused with the reason,
//! on the bundled real walk and on a simulated drive.

mod common;

use common::{ok, refused, rins, s};
use std::path::{Path, PathBuf};

fn tmp(name: &str) -> PathBuf {
    common::tmp(&format!("options-{name}"))
}

/// The bundled real walk imported into `dir/rec`.
fn walk(dir: &Path) -> PathBuf {
    let rec = dir.join("rec");
    let args = rins_tests::data::walk_import_args(&rec);
    ok(&rins(&args.iter().map(String::as_str).collect::<Vec<_>>()));
    rec
}

/// trajectory.csv's first and last times, s.
fn span(dir: &Path) -> (f64, f64) {
    let t = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let time = |l: &str| l.split(',').next().unwrap().parse::<f64>().unwrap();
    let mut rows = t.lines().skip(1);
    let first = time(rows.next().unwrap());
    (first, time(rows.last().unwrap()))
}

#[test]
fn navigate_gnss_honours_its_span_and_refuses_what_it_cannot_use() {
    let dir = tmp("walk");
    let rec = s(&walk(&dir));
    let nav = |name: &str, extra: &[&str]| {
        let out = s(&dir.join(name));
        let mut a = vec!["navigate", &rec, "--gnss", "--sensor", "icm42605"];
        a.extend_from_slice(extra);
        a.extend_from_slice(&["--out", &out]);
        rins(&a)
    };
    // --end-s: the trajectory stops there (the walk's log runs to 134 s).
    ok(&nav("end", &["--end-s", "60", "--gnss-outage", "20:10"]));
    let (a, b) = span(&dir.join("end"));
    assert!(a < 0.1 && (59.9..=60.0).contains(&b), "{a}..{b}");
    // An outage past --end-s is refused, not cut silently.
    refused(
        &nav("past", &["--end-s", "60", "--gnss-outage", "50:20"]),
        &["--gnss-outage 50:20", "--end-s"],
    );
    // --start-s where the walker moves: the filter starts at rest, so it
    // is refused with the still stretches the fixes show.
    refused(
        &nav("moving", &["--start-s", "30"]),
        &["--start-s 30", "starts at rest", "still: 0-11 s"],
    );
    // Options the aided run cannot use are refused, by clap.
    refused(
        &nav("cal", &["--calibration", "nope.json"]),
        &["--calibration", "--gnss"],
    );
    refused(&nav("hold", &["--hold-height"]), &["--hold-height"]);
    // --gnss-floor-m: the comma form its value name shows, and it changes
    // the run (a metre-level floor on the walk's RTK fixes).
    let floor = ok(&nav(
        "floor",
        &["--end-s", "60", "--gnss-floor-m", "1,1,1,1.5"],
    ));
    let plain = ok(&nav("plain", &["--end-s", "60"]));
    let rms = |t: &str| {
        t.lines()
            .find_map(|l| l.strip_prefix("horizontal error with GNSS: "))
            .map(str::to_string)
            .unwrap()
    };
    assert_ne!(rms(&floor), rms(&plain));
    refused(
        &nav("floor3", &["--gnss-floor-m", "1,1,1"]),
        &["--gnss-floor-m takes four values"],
    );
    // --sensor's antenna lever arm is used (over meta.toml's 5 cm).
    let sensor = dir.join("arm.toml");
    std::fs::write(
        &sensor,
        "format = \"rins-sensor/1\"\nbase = \"icm42605\"\n[mounting]\nantenna_b_m = [0.0, -0.5, 0.0]\n",
    )
    .unwrap();
    let arm = ok(&rins(&[
        "navigate",
        &rec,
        "--gnss",
        "--sensor",
        &s(&sensor),
        "--end-s",
        "60",
        "--keep-given-arm",
        "--out",
        &s(&dir.join("arm")),
    ]));
    assert!(
        arm.contains("antenna lever arm [0.0, -0.5, 0.0] m from the sensor file"),
        "{arm}"
    );
    // Kept, not replaced by the arm the fixes give (which a default run
    // navigates with: then a 0.5 m arm and meta.toml's 5 cm both end at
    // the fixes' and their rms agreed to the printed digit).
    let given = ok(&nav("given", &["--end-s", "60", "--keep-given-arm"]));
    assert_ne!(rms(&arm), rms(&given));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_truth_that_ends_early_measures_over_the_overlap_and_says_so() {
    let dir = tmp("truth");
    let rec = dir.join("rec");
    ok(&rins(&[
        "simulate",
        "--drive",
        "city",
        "--sensor",
        "nav440",
        "--duration-s",
        "60",
        "--out",
        &s(&rec),
    ]));
    // A reference that ends 3 s before the IMU log.
    let p = rec.join("truth.csv");
    let text = std::fs::read_to_string(&p).unwrap();
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| {
            l.split(',')
                .next()
                .and_then(|t| t.parse::<f64>().ok())
                .is_none_or(|t| t <= 57.0)
        })
        .collect();
    std::fs::write(&p, kept.join("\n") + "\n").unwrap();
    let out = ok(&rins(&[
        "navigate",
        &s(&rec),
        "--gnss",
        "--out",
        &s(&dir.join("nav")),
    ]));
    assert!(
        out.contains("errors against: truth.csv over 0.0-57.0 s (of the run's 0.0-60.0 s"),
        "{out}"
    );
    // --end-s inside the truth: the whole run has a reference again.
    let out = ok(&rins(&[
        "navigate",
        &s(&rec),
        "--gnss",
        "--end-s",
        "50",
        "--out",
        &s(&dir.join("nav50")),
    ]));
    assert!(out.contains("errors against: truth.csv\n"), "{out}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn simulate_like_refuses_the_flags_the_recording_gives() {
    for flag in [
        ["--rate-dps", "20"],
        ["--sensor", "nav440"],
        ["--scheme", "indexed"],
        ["--lat-deg", "10"],
        ["--duration-s", "10"],
    ] {
        let o = rins(&[
            "simulate",
            "--like",
            "rec",
            "--sim-model",
            "m.toml",
            flag[0],
            flag[1],
            "--out",
            "x",
        ]);
        refused(&o, &["--like", flag[0]]);
    }
}

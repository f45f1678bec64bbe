//! `rins calibrate --method multiposition` on a real session nobody here
//! made (imu_tk's Xsens: 38 rests turned by hand, raw counts; BSD, bundled
//! with its ORIGIN.txt): a user's chain, the two files side by side in
//! one CSV, `rins import csv`, `rins calibrate`. The oracle is the session
//! itself: after calibration every rest's accelerometer norm is the
//! site's gravity, and the gyro carries each rest's gravity direction
//! (measured by the accelerometer alone) onto the next rest's.

mod common;

use common::{ok, s};
use std::fmt::Write as _;

#[test]
fn a_real_hand_turned_session_calibrates_from_the_cli() {
    let dir = common::tmp("cli-multipos");
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/data/imu_tk_xsens_multipos");
    let read = |f: &str| std::fs::read_to_string(data.join(f)).unwrap();
    let (acc, gyr) = (read("xsens_acc.mat"), read("xsens_gyro.mat"));
    let mut csv = String::new();
    for (a, g) in acc.lines().zip(gyr.lines()) {
        let a: Vec<&str> = a.split_whitespace().collect();
        let g: Vec<&str> = g.split_whitespace().collect();
        assert_eq!(a[0], g[0], "the two files share their stamps");
        writeln!(
            csv,
            "{},{},{},{},{},{},{}",
            a[0], a[1], a[2], a[3], g[1], g[2], g[3]
        )
        .unwrap();
    }
    std::fs::create_dir_all(&dir).unwrap();
    let (file, map, rec) = (dir.join("xsens.csv"), dir.join("map.toml"), dir.join("rec"));
    std::fs::write(&file, csv).unwrap();
    // Raw counts as recorded: the calibration finds their scale.
    std::fs::write(
        &map,
        "format = \"rins-columns/1\"\nheader = false\nrate_hz = 100\n[columns]\ntime = 0\naccel = [1, 2, 3]\ngyro = [4, 5, 6]\n[units]\ntime = \"s\"\ngyro = \"radps\"\naccel = \"mps2\"\n[time]\nsource = \"log\"\n",
    )
    .unwrap();
    ok(&common::rins(&[
        "import",
        "csv",
        "--imu-file",
        &s(&file),
        "--columns",
        &s(&map),
        "--sensor",
        "ideal",
        "--lat-deg",
        "45.4",
        "--height-m",
        "20",
        "--out",
        &s(&rec),
    ]));
    let json = dir.join("mp.json");
    let text = ok(&common::rins(&[
        "calibrate",
        &s(&rec),
        "--method",
        "multiposition",
        "--rest-s",
        "50",
        "--json",
        &s(&json),
    ]));
    print!("{text}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["format"], "rins-multiposition/1");
    // imu_tk's own count: 38 rests after its 50 s initial one.
    assert!(v["rests"].as_u64().unwrap() >= 30, "{text}");
    // Norms within 0.1 % of g (0.021 % measured; a rest's mean of 1 s
    // of counts is good to 0.01 %), gravity across the moves under 1 deg
    // (0.51 measured) and a third of the fit's start.
    let after = |k: &str| v[k]["after"].as_f64().unwrap();
    assert!(after("norm_error") < 1e-3, "{text}");
    let moves = after("transition_rms_rad").to_degrees();
    let start = v["transition_rms_rad"]["before"]
        .as_f64()
        .unwrap()
        .to_degrees();
    assert!(moves < 1.0 && moves < start / 3.0, "{text}");
    // Refused where it does not apply.
    common::refused(
        &common::rins(&["calibrate", &s(&rec), "--rest-s", "50"]),
        &["--rest-s", "multiposition"],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

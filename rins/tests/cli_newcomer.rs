//! What a newcomer types: negative numbers as values, and contradictory or
//! non-chaining flags refused with the reason and the flag that fixes it.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn rins(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rins"))
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .output()
        .unwrap()
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rins-newcomer-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Fails with a message holding every one of `words`.
fn refused(o: &Output, words: &[&str]) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "exit 0; stderr {err}");
    for w in words {
        assert!(err.contains(w), "{w:?} not in: {err}");
    }
}

#[test]
fn a_southern_site_a_negative_pitch_and_rate_are_values() {
    let out = tmp("south");
    let o = rins(&[
        "simulate",
        "--lat-deg",
        "-33.9",
        "--pitch-deg",
        "-0.2",
        "--rate-dps",
        "-30",
        "--duration-s",
        "5",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let meta = std::fs::read_to_string(out.join("meta.toml")).unwrap();
    assert!(meta.contains("latitude_deg = -33.9"), "{meta}");
    assert!(meta.contains("pitch_deg = -0.2"), "{meta}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn contradictory_flags_are_refused_with_the_reason() {
    let out = tmp("contra");
    let rec = out.join("rec");
    let r = rec.to_str().unwrap();
    let o = rins(&["simulate", "--duration-s", "5", "--out", r]);
    assert!(o.status.success());
    let nav = out.join("nav");
    let n = nav.to_str().unwrap();
    refused(
        &rins(&["navigate", r, "--out", n, "--start-s", "4", "--end-s", "2"]),
        &["--end-s 2", "not after"],
    );
    refused(
        &rins(&["navigate", r, "--out", n, "--start-s", "9"]),
        &["--start-s 9", "last sample"],
    );
    refused(
        &rins(&["simulate", "--ideal", "--sensor", "nav440", "--out", n]),
        &["--ideal", "--sensor"],
    );
    refused(
        &rins(&[
            "simulate",
            "--drive",
            "city",
            "--duration-s",
            "60",
            "--gnss-outage",
            "10:100",
            "--out",
            n,
        ]),
        &["--gnss-outage 10:100", "--duration-s"],
    );
    // simulate's default has no still phase: calibrate says which flag
    // gives one.
    refused(&rins(&["calibrate", r]), &["--static-s"]);
    // The same --out twice (following the book in order twice): refused
    // before simulating, with the flag that fixes it.
    refused(
        &rins(&["simulate", "--duration-s", "5", "--out", r]),
        &["holds a recording already", "another --out"],
    );
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_moving_base_without_gnss_and_a_foreign_demo_directory_are_refused() {
    let out = tmp("moving");
    let rec = out.join("drive");
    let r = rec.to_str().unwrap();
    let o = rins(&[
        "simulate",
        "--drive",
        "city",
        "--duration-s",
        "20",
        "--out",
        r,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let n = out.join("nav");
    refused(
        &rins(&["navigate", r, "--out", n.to_str().unwrap()]),
        &["moving-base", "--gnss"],
    );
    // The drive's directory is not a demo's output: demo will not write
    // into it.
    refused(&rins(&["demo", "--out", r]), &["--out"]);
    assert!(rec.join("imu.csv").exists());
    let _ = std::fs::remove_dir_all(&out);
}

/// The book's real-walk commands (`docs/src/aided.md`), as written: the
/// import of the RTKLIB solution and the IMU CSV, then the aided
/// navigation with two outages.
#[test]
fn the_books_real_walk_commands_run_as_written() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = tmp("walk");
    let (rec, nav) = (dir.join("walk"), dir.join("walk-nav"));
    let args = rins_tests::data::walk_import_args(&rec);
    let o = rins(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = rins(&[
        "navigate",
        &rec.to_string_lossy(),
        "--gnss",
        "--sensor",
        "icm42605",
        "--gnss-outage",
        "20:10",
        "--gnss-outage",
        "45:10",
        "--out",
        &nav.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "trajectory.csv",
        "map.png",
        "position_error.png",
        "consistency.png",
    ] {
        assert!(nav.join(f).is_file(), "{f} missing");
    }
    // The book's command in the chapter is the one run here.
    let book = std::fs::read_to_string(root.join("docs/src/aided.md")).unwrap();
    assert!(book.contains("--imu-file tests/data/gnss_imu_walk_0827/imu_1730.csv"));
    let _ = std::fs::remove_dir_all(&dir);
}

//! Implausible samples (`recording::plausible`): a bad reading put into a
//! real recording is found by its time and row, and the real recordings
//! nobody here made, as they are, give (almost) nothing: the MPU-6050 on a
//! stepper table (its steps and the stepper's jerks included), the real
//! walk (a hand's motion), the ADIS16405's static hours.

mod common;

use recording::plausible::{check, excluded, Kind};
use recording::Recording;

fn stepper() -> Recording {
    Recording::read(&rins_tests::data::bundled("mpu6050_stepper_roll_slow_300s")).unwrap()
}

fn walk() -> Recording {
    rins::import::rtklib(&common::walk_input()).unwrap().0
}

#[test]
fn real_recordings_as_they_are_are_plausible() {
    for (name, rec) in [("mpu6050 stepper", stepper()), ("walk", walk())] {
        let bad = check(&rec, None);
        let readings = rec.imu.len() * 6;
        println!("{name}: {} of {readings} readings flagged", bad.len());
        for b in bad.iter().take(5) {
            println!("  {b}");
        }
        // At most one reading in 10,000 (a real sensor's rare glitch).
        assert!(bad.len() * 10_000 <= readings, "{name}: {}", bad.len());
    }
}

#[test]
fn a_gyro_at_fourteen_times_full_scale_is_found_and_excluded() {
    // The newcomer's case: one gyro sample at 50 rad/s in a real
    // recording.
    let mut rec = stepper();
    let k = rec.imu.len() / 2;
    rec.imu[k].gyro_radps[1] = 50.0;
    let fs = Some((250f64.to_radians(), 2.0 * 9.80665));
    let bad = check(&rec, fs);
    let hit: Vec<_> = bad
        .iter()
        .filter(|b| b.row == k && b.channel == 1)
        .collect();
    assert_eq!(hit.len(), 1, "{bad:?}");
    assert!(matches!(hit[0].kind, Kind::BeyondFullScale(_)));
    let text = hit[0].to_string();
    assert!(text.contains(&format!("data row {}", k + 1)), "{text}");
    // Both values with their unit (50 rad/s = 2865 deg/s; the range 250
    // deg/s).
    assert!(
        text.contains("50 rad/s (2865 deg/s)") && text.contains("(250 deg/s)"),
        "{text}"
    );
    // Without the full scale, it is a spike all the same.
    assert!(check(&rec, None)
        .iter()
        .any(|b| b.row == k && matches!(b.kind, Kind::Spike(_))));
    let (fixed, n) = excluded(&rec, &check(&rec, fs));
    assert!(n >= 1);
    assert_eq!(fixed.imu[k].gyro_radps[1], rec.imu[k - 1].gyro_radps[1]);
}

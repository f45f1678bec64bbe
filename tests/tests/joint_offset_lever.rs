//! The IMU-to-GNSS time offset and the antenna's lever arm estimated
//! together (`navigate --estimate-time-offset --estimate-lever-arm`,
//! `rins::aided::joint`): each pre-pass alone states a sigma with the
//! other held; together, each sigma includes what the other absorbs. Our
//! simulator only: city drives with an RTK-grade receiver (2 cm) whose
//! antenna sits 1 m ahead of and 0.8 m above the base, the recording told
//! 0.4 m ahead, 0.3 m left and level, its fixes stamped 0.1 s early (the
//! IMU 0.1 s late).

use hal_sim::drive::DriveKind;
use hal_sim::imu::ImuSpec;
use hal_sim::sim::simulate;
use rins::aided::{joint, lever, offset, AidedOptions};
use rins::outages;

/// The delay put into the fixes, s.
const LATE_S: f64 = 0.1;
/// The antenna in `b`, m (hal-sim's receiver default).
const ARM_B_M: [f64; 3] = [1.0, 0.0, -0.8];

fn found(
    seed: u64,
) -> (
    offset::OffsetEstimate,
    lever::LeverEstimate,
    joint::JointEstimate,
) {
    let p = ImuSpec::nav440();
    let mut c = outages::config(DriveKind::City, &p, true, seed);
    c.duration_s = 120.0;
    let d = c.drive.as_mut().unwrap();
    (d.gnss.sigma_h_m, d.gnss.sigma_v_m) = (0.02, 0.04);
    assert_eq!(d.gnss.antenna_b_m, nalgebra::Vector3::from(ARM_B_M));
    let mut rec = simulate(&c, &mut |_| {}).unwrap();
    let mv = rec.moving.as_mut().unwrap();
    mv.gnss_meta.as_mut().unwrap().antenna_b_m = [0.4, -0.3, 0.0];
    let fixes = mv.gnss.as_mut().unwrap();
    for f in fixes.iter_mut() {
        f.t_s -= LATE_S;
    }
    fixes.retain(|f| f.t_s >= 0.0);
    // As `navigate` runs them: the arm, then the offset with it, then both.
    let mut opt = AidedOptions::new(p);
    let l = lever::estimate(&rec, &opt, &mut |_| {}).unwrap();
    opt.lever_b_m = Some(l.b_m);
    let o = offset::estimate(&rec, &opt, 0.5, 0.02, &mut |_| {}).unwrap();
    opt.time_offset_s = o.offset_s;
    let j = joint::estimate(&rec, &opt, &o, &l, &mut |_| {}).unwrap();
    (o, l, j)
}

#[test]
fn the_offset_and_the_arm_found_together_cover_the_truth_with_their_marginal_sigmas() {
    let runs: Vec<_> = std::thread::scope(|s| {
        let h: Vec<_> = (3..=4).map(|seed| s.spawn(move || found(seed))).collect();
        h.into_iter().map(|r| r.join().unwrap()).collect()
    });
    for (o, l, j) in &runs {
        println!(
            "separate: offset {:.4} +- {:.4} s, arm {:?} +- {:?}",
            o.offset_s, o.sigma_s, l.b_m, l.sigma_m
        );
        print!("{}", j.text());
        // Within 3.5 of its sigmas: over 12 such drives (seeds 1-12) the
        // errors over their sigmas have an rms of 1.28, 1.24 and 1.30
        // (offset, x, y; the book's Aided navigation), and seed 3's offset
        // is the largest, 3.3 sigma.
        assert!((j.offset_s - LATE_S).abs() < 3.5 * j.sigma_s, "{j:?}");
        for (i, want) in ARM_B_M.iter().enumerate() {
            if let Some(s) = j.sigma_lever_m[i] {
                assert!((j.lever_b_m[i] - want).abs() < 3.5 * s, "axis {i}: {j:?}");
            }
        }
        // Horizontal components resolved: a city drive turns.
        assert!(j.sigma_lever_m[0].is_some() && j.sigma_lever_m[1].is_some());
        // The marginal sigma is never below the conditional one (the
        // inverse's diagonal against the diagonal's inverse), and the
        // forward arm trades against the clock (the antenna moved along
        // the track either way): a correlation the separate sigmas hide.
        assert!(j.sigma_s >= j.sigma_s_arm_held, "{j:?}");
        assert!(j.correlation[0].unwrap().abs() > 0.1, "{j:?}");
        // One after the other, the arm (found first, at the recording's
        // clock) took the clock's `v dt` along x and the offset found at
        // that arm kept the rest: measured 20 of their own sigmas off.
        assert!(
            (j.offset_s - LATE_S).abs() < (o.offset_s - LATE_S).abs(),
            "{o:?} {j:?}"
        );
        assert!((j.lever_b_m[0] - ARM_B_M[0]).abs() < (l.b_m[0] - ARM_B_M[0]).abs());
    }
}

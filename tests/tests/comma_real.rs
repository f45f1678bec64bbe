//! A real car's minute nobody here made: comma2k19's RAV4 on a highway
//! (a dashcam's phone-class IMU, u-blox fixes at 10 Hz, CAN speed, comma's
//! own pose; MIT, `tests/data/comma2k19_rav4_highway_60s`, its ORIGIN.md).
//! The import's clock is checked against the pose (which the receiver's
//! fixes do not enter at their arrival times), the navigation's errors
//! are measured against the pose: comma's INS/GNSS/vision solution, not
//! independent of this IMU, and 2 m from the live fixes while they
//! arrive. Nothing here comes from our simulator.

use core_nav::earth::GeoPoint;
use recording::moving::GnssRow;
use rins::aided::vehicle::Vehicle;
use rins::aided::{navigate, summary, AidedOptions};
use rins::import::comma::{import, CommaInput};
use rins::import::fixcheck::against_reference;

/// The u-blox M8's datasheet horizontal accuracy, 2.5 m CEP, as a
/// 1-sigma per axis (CEP = 1.18 sigma): the log has no sigmas of its own.
const FIX_SIGMA_M: f64 = 2.0;

fn input() -> CommaInput {
    CommaInput {
        fix_sigma_h_m: Some(FIX_SIGMA_M),
        ..measured_input()
    }
}

/// The import as a user runs it by default: the fixes' sigma measured
/// against the pose.
fn measured_input() -> CommaInput {
    CommaInput {
        dir: rins_tests::data::bundled("comma2k19_rav4_highway_60s"),
        fix_sigma_h_m: None,
        sensor: hal_sim::sensor::resolve("icm42605").unwrap(),
    }
}

#[test]
fn the_fixes_are_put_0_12_s_later_by_the_pose_and_the_imu_agrees() {
    let (rec, rep) = import(&input()).unwrap();
    // ORIGIN.md: 6,256 IMU samples over 60 s (about 104 Hz); 579 fixes,
    // of which 2 fall outside the IMU's span on the epoch clock.
    assert_eq!(rep.imu_samples, 6256);
    assert!((rep.imu_rate_found_hz - 104.3).abs() < 0.1);
    assert_eq!((rep.fixes, rep.fixes_outside), (577, 2));
    let mv = rec.moving.as_ref().unwrap();
    let (fixes, truth) = (mv.gnss.as_ref().unwrap(), mv.truth.as_ref().unwrap());
    assert_eq!(mv.odometer.as_ref().unwrap().len(), 4972);
    // Their UTC epochs through the pose's GPS/boot pairs fit the pose
    // best 0.12 s later (the arrival stamps lag the epochs by 0.20 s); the
    // import writes them there.
    let c = rep.fixes_against_reference.as_ref().unwrap();
    assert!((c.shift_s - FIX_LATE_S).abs() < 0.03, "{c:?}");
    // Each written fix against the pose at its time, along the track, as
    // a time: the distance over the speed.
    let o = GeoPoint::from_deg(rec.meta.latitude_deg, mv.longitude_deg, rec.meta.height_m);
    let ahead_s: Vec<f64> = fixes
        .iter()
        .filter_map(|f| {
            let t = recording::moving::truth_at(truth, f.t_s)?;
            let d = o.ned_to(&GeoPoint::from_deg(f.lat_deg, f.lon_deg, f.height_m));
            let (vn, ve) = (t.v_n_mps[0], t.v_n_mps[1]);
            let s2 = vn * vn + ve * ve;
            Some(((d.x - t.p_n_m[0]) * vn + (d.y - t.p_n_m[1]) * ve) / s2)
        })
        .collect();
    let pose_s = ahead_s.iter().sum::<f64>() / ahead_s.len() as f64;
    // The same from the IMU alone: the time offset whose fixes' NIS the
    // filter finds smallest (`navigate --estimate-time-offset`): the pose
    // does not enter it, and must find the written fixes on time.
    let opt = AidedOptions::new(hal_sim::sensor::resolve("icm42605").unwrap());
    let e = rins::aided::offset::estimate(&rec, &opt, 0.5, 0.02, &mut |_| {}).unwrap();
    println!(
        "written fixes {pose_s:.3} s off the pose along the track; the IMU's NIS puts them {:.3} +- {:.3} s late",
        e.offset_s, e.sigma_s
    );
    // Measured before the shift was written: 0.12 s and 0.126 +- 0.073 s.
    assert!(pose_s.abs() < 0.03, "{pose_s}");
    assert!(e.offset_s.abs() < 2.0 * e.sigma_s, "{e:?}");
}

/// The shift the import finds for the fixes' epochs (the test above), s.
const FIX_LATE_S: f64 = 0.12;

fn outage_end(vehicle: Option<Vehicle>, start_s: f64) -> (f64, rins::aided::AidedSummary) {
    let (rec, _) = import(&input()).unwrap();
    let opt = AidedOptions {
        outages: vec![(start_s, 15.0)],
        vehicle,
        ..AidedOptions::new(hal_sim::sensor::resolve("icm42605").unwrap())
    };
    let run = navigate(&rec, &opt, &mut |_| {}).unwrap();
    let ms = run
        .moving_start
        .expect("the car moves from its first sample");
    // The pose's 8.0 m/s at the start, within the fixes' 3 sigma.
    assert!((ms.v_n_mps[0].hypot(ms.v_n_mps[1]) - 8.0).abs() < 3.0 * ms.sigma_mps);
    let s = summary(&rec, &run);
    let g = s
        .outages
        .iter()
        .find(|g| (g.start_s - start_s).abs() < 0.5)
        .unwrap();
    assert!(
        g.within_3_sigma.unwrap_or(0.0) >= 0.7,
        "{:?}",
        g.within_3_sigma
    );
    (g.end_error_m.unwrap(), s)
}

/// The vehicle's forward axis in the pose's body frame over its first
/// `span_s`: the mean direction of `c_n_b v_n`, as yaw and pitch (deg).
fn pose_forward_deg(span_s: f64) -> (f64, f64) {
    let (rec, _) = import(&input()).unwrap();
    let truth = rec.moving.unwrap().truth.unwrap();
    let mut sum = nalgebra::Vector3::zeros();
    for r in truth.iter().filter(|r| r.t_s <= span_s) {
        let [ro, pi, he] = r.euler_deg;
        let e = core_nav::attitude::Euler::<f64>::from_deg(ro, pi, he);
        let c_b_n = core_nav::site::c_b_n(&e);
        let v = nalgebra::Vector3::from(r.v_n_mps);
        sum += c_b_n.transpose() * v / v.norm();
    }
    let u = sum.normalize();
    (u.y.atan2(u.x).to_degrees(), (-u.z).asin().to_degrees())
}

#[test]
fn a_car_s_constraints_and_odometer_bridge_15_s_from_a_moving_start() {
    // The car moves from its first sample: the forward axis is read off
    // the filter's velocity in b at the first straight stretch with
    // fixes, its error carried as filter states tied to the heading's;
    // the CAN speed (odometer.csv) with its scale estimated. The issue's
    // done-when: a 15-20 s outage at least 2x closer than without.
    for start in [25.0, 35.0] {
        let (none, _) = outage_end(None, start);
        let (car, s) = outage_end(Some(Vehicle::Car), start);
        println!("outage at {start} s: {none:.2} m without, {car:.2} m with --vehicle car");
        assert!(car <= 0.5 * none, "{start}: {car} vs {none}");
        let v = s.vehicle.unwrap();
        let f = v.forward.expect("the forward axis found");
        assert!(v.found_at_s.unwrap() < 10.0, "{v:?}");
        // The pose's own: its velocity in its body frame over the run
        // (the dashcam pitched down about 3.7 deg in the car). The pose
        // is comma's solution from this IMU, not independent of it.
        let (yaw, pitch) = pose_forward_deg(60.0);
        println!("{f:?}; the pose's: yaw {yaw:.2}, pitch {pitch:.2}");
        assert!(
            (f.yaw_deg - yaw).abs() < 3.0 * f.sigma_yaw_deg,
            "{f:?} {yaw}"
        );
        assert!(
            (f.pitch_deg - pitch).abs() < 3.0 * f.sigma_pitch_deg,
            "{f:?} {pitch}"
        );
        assert!(v.updates > 50 && v.off == 0, "{v:?}");
        let o = v.odometer.expect("the import writes the CAN speed");
        assert!(o.updates > 50 && o.rejected == 0, "{o:?}");
        // Its scale error within a few per cent, and known.
        assert!(o.scale.abs() < 0.05 && o.sigma_scale < 0.01, "{o:?}");
    }
}

/// Each outage's share of seconds with the sigma columns' NEES inside its
/// 95 % bounds, the run started from `rec`'s meta.toml.
fn outage_nees_shares(rec: &recording::Recording) -> Vec<f64> {
    nees_shares_at(rec, &[25.0, 35.0])
}

/// The same for 15 s outages at `starts` (s), one run each.
fn nees_shares_at(rec: &recording::Recording, starts: &[f64]) -> Vec<f64> {
    starts
        .iter()
        .map(|&start| {
            let opt = AidedOptions {
                outages: vec![(start, 15.0)],
                vehicle: Some(Vehicle::Car),
                ..AidedOptions::new(hal_sim::sensor::resolve("icm42605").unwrap())
            };
            let run = navigate(rec, &opt, &mut |_| {}).unwrap();
            let s = summary(rec, &run);
            s.outages[0].nees_diag_in_95.unwrap()
        })
        .collect()
}

/// The mean of [`nees_shares_at`] over `draws` runs started at the pose's
/// attitude less a draw from the filter's prior (seed `seed`): a
/// relabelled copy of the real minute whose start error is known.
fn drawn_start_shares(
    rec: &recording::Recording,
    starts: &[f64],
    draws: usize,
    seed: u64,
) -> Vec<f64> {
    let prior = rins::aided::INITIAL_SIGMA;
    let mut rng = hal_sim::rng::Rng::new(seed, 1);
    let mut sums = vec![0.0; starts.len()];
    for _ in 0..draws {
        let mut r = rec.clone();
        let d = rng.normal3();
        r.meta.roll_deg += d.x * prior.level_rad.to_degrees();
        r.meta.pitch_deg += d.y * prior.level_rad.to_degrees();
        r.meta.heading_deg += d.z * prior.heading_rad.to_degrees();
        for (s, x) in sums.iter_mut().zip(nees_shares_at(&r, starts)) {
            *s += x / draws as f64;
        }
    }
    sums
}

#[test]
fn the_car_s_sigmas_hold_when_its_start_is_not_the_reference_s_own() {
    // The import starts the filter at the pose's attitude, the reference
    // its errors are measured against: its start error is 0 while the
    // filter, told no sigma, assumes 0.5 deg level and 2 deg heading, and
    // a highway's straight minute never shrinks them (tilt against the
    // accelerometers' bias, heading against the mounting's yaw). Its NEES
    // reads low. Started instead where a user with that prior would be
    // (the pose's attitude less a draw from the prior: a relabelled copy
    // of the real minute whose start error is known), the sigma columns
    // hold. Measured (48 draws, four seeds): 66-72 % of the 25 s outage's
    // seconds in bounds (the issue asks 70 %: met on average, not at every
    // seed; its misses are on the low side, the horizontal position's
    // sigma carrying the fixes' assumed 2 m that the pose shares) and
    // 97-99 % of the 35 s one's; started at the pose, 33 % and 93 %.
    let (rec, _) = import(&input()).unwrap();
    let as_is = outage_nees_shares(&rec);
    let sums = drawn_start_shares(&rec, &[25.0, 35.0], 48, 48);
    println!("in bounds, started at the pose: {as_is:?}; from the prior's draws: {sums:?}");
    // The draws' mean moves +-0.03 between seeds (four measured): twice
    // that under the lowest seed's, and the 35 s outage's the same way.
    assert!(sums[0] >= 0.6 && sums[1] >= 0.9, "{sums:?}");
    assert!(as_is[0] < sums[0], "{as_is:?} {sums:?}");
}

#[test]
fn a_stated_start_sigma_is_the_filter_s_and_the_summary_says_so() {
    let (mut rec, _) = import(&input()).unwrap();
    let opt = AidedOptions::new(hal_sim::sensor::resolve("icm42605").unwrap());
    let run = navigate(&rec, &opt, &mut |_| {}).unwrap();
    let p = rins::aided::INITIAL_SIGMA;
    // The first row's sigma columns are the start's 1-sigmas: roll,
    // pitch and heading are Euler angles of an attitude pitched 4.3 deg,
    // each within sec(4.3 deg) - 1 = 0.3 % of its rotation angle's (1 %).
    let near = |a: f64, b: f64| (a - b).abs() < 0.01 * b;
    let r0 = run.rows[0].sigma_att_deg;
    // Unstated: the assumed prior, said as assumed.
    assert!(near(r0[0], p.level_rad.to_degrees()), "{r0:?}");
    assert!(near(r0[1], p.level_rad.to_degrees()), "{r0:?}");
    assert!(near(r0[2], p.heading_rad.to_degrees()), "{r0:?}");
    assert!(summary(&rec, &run)
        .text()
        .contains("assumed: meta.toml states none"));
    rec.meta.level_sigma_deg = Some(0.05);
    rec.meta.heading_sigma_deg = Some(0.3);
    let run = navigate(&rec, &opt, &mut |_| {}).unwrap();
    let r0 = run.rows[0].sigma_att_deg;
    assert!(
        near(r0[0], 0.05) && near(r0[1], 0.05) && near(r0[2], 0.3),
        "{r0:?}"
    );
    let s = summary(&rec, &run);
    assert!(
        s.start.level_stated && s.start.heading_stated,
        "{:?}",
        s.start
    );
    assert!(s.text().contains("(stated)"));
}

/// The fixes moved by `d_ned_m` (NED at each fix, m) and their epochs by
/// `dt_s`: a relabelled copy whose answer is known.
fn moved(fixes: &[GnssRow], d_ned_m: [f64; 3], dt_s: f64) -> Vec<GnssRow> {
    fixes
        .iter()
        .map(|f| {
            let p = GeoPoint::from_deg(f.lat_deg, f.lon_deg, f.height_m);
            let e = p.to_ecef() + p.c_e_n().transpose() * nalgebra::Vector3::from(d_ned_m);
            let q = GeoPoint::from_ecef(&e).unwrap();
            GnssRow {
                t_s: f.t_s + dt_s,
                lat_deg: q.lat_rad.to_degrees(),
                lon_deg: q.lon_rad.to_degrees(),
                height_m: q.height_m,
                ..*f
            }
        })
        .collect()
}

#[test]
fn the_fixes_sigma_measured_against_the_pose_moves_as_a_relabelled_copy_is_moved() {
    let (rec, rep) = import(&measured_input()).unwrap();
    let r = rep.fixes_against_reference.clone().unwrap();
    println!("{}", r.text("global_pose"));
    // The clock the test above finds along the track, to the search's
    // 2 ms step.
    assert!((r.shift_s - FIX_LATE_S).abs() <= 0.004, "{r:?}");
    assert!(r.sigma_measured);
    let [h, v] = r.sigma_m();
    let mv = rec.moving.as_ref().unwrap();
    let (fixes, truth) = (mv.gnss.as_ref().unwrap(), mv.truth.as_ref().unwrap());
    assert!(fixes.iter().all(|f| f.sigma_h_m == h && f.sigma_v_m == v));
    // One figure for both horizontal axes covers the worse (east).
    assert_eq!(h, r.rms_ned_m[0].max(r.rms_ned_m[1]));
    let o = GeoPoint::from_deg(rec.meta.latitude_deg, mv.longitude_deg, rec.meta.height_m);
    let check = |f: &[GnssRow]| against_reference(f, truth, &o.tangent()).unwrap();
    // The written fixes sit on the pose's clock: measured again, no shift
    // (to a step) and the same offsets.
    let c = check(fixes);
    assert!(c.shift_s.abs() <= 0.002 + 1e-9, "{c:?}");
    // The same fixes 0.5 m east and 2 m up and stamped 50 ms earlier: the
    // shift grows by the 50 ms (to the search's 2 ms step), the mean by the
    // move (within 5 mm east and down; north, along the track, within the
    // step times the speed: 2 ms x 20 m/s = 4 cm, 5 cm taken). Across the track only: the car heads north
    // (1.4 deg) on a straight road, where a fix moved along the track is a
    // fix stamped at another time, and the search takes it as the clock.
    let m = check(&moved(fixes, [0.0, 0.5, -2.0], -0.05));
    println!("moved: {m:?}");
    assert!(
        (m.shift_s - c.shift_s - 0.05).abs() <= 0.002 + 1e-9,
        "{m:?}"
    );
    for (i, (d, tol)) in [(0.0, 0.05), (0.5, 5e-3), (-2.0, 5e-3)].iter().enumerate() {
        assert!(
            (m.mean_ned_m[i] - c.mean_ned_m[i] - d).abs() < *tol,
            "{i}: {m:?}"
        );
    }
    // Closed form: fixes made from the pose itself 80 ms ahead of their
    // stamps and 0.3 m below it (a horizontal move would be taken partly
    // as the clock, as above): that shift, that mean, an rms of the
    // offset itself; the horizontal sigma on its 1 cm floor.
    let made: Vec<GnssRow> = truth
        .iter()
        .step_by(2)
        .map(|r| {
            let d = nalgebra::Vector3::from(r.p_n_m) + nalgebra::Vector3::new(0.0, 0.0, 0.3);
            let e = o.to_ecef() + o.c_e_n().transpose() * d;
            let q = GeoPoint::from_ecef(&e).unwrap();
            GnssRow {
                t_s: r.t_s - 0.08,
                lat_deg: q.lat_rad.to_degrees(),
                lon_deg: q.lon_rad.to_degrees(),
                height_m: q.height_m,
                ..fixes[0]
            }
        })
        .collect();
    let k = check(&made);
    println!("made from the pose: {k:?}");
    assert!((k.shift_s - 0.08).abs() < 1e-9, "{k:?}");
    for (i, d) in [0.0, 0.0, 0.3].iter().enumerate() {
        assert!((k.mean_ned_m[i] - d).abs() < 1e-6, "{i}: {k:?}");
        assert!((k.rms_ned_m[i] - d.abs()).abs() < 1e-6, "{i}: {k:?}");
    }
    let [kh, kv] = k.sigma_m();
    assert!(kh == 0.01 && (kv - 0.3).abs() < 1e-6, "{kh} {kv}");
}

#[test]
fn the_car_minute_as_imported_holds_its_sigmas_in_every_outage() {
    // The done-when on the car minute, as a user runs it: the
    // default import (the fixes on the pose's clock, their sigma measured
    // against it), `--vehicle car`: at least 70 % of each 15 s outage's
    // seconds with the 9-dof diagonal NEES in its 95 % bounds. Measured:
    // 100 % at 10, 25, 35 and 40 s (at the datasheet's 2 m: 33 % at 25 s,
    // all on the low side). The sigma is fitted against the reference the
    // errors are scored against, and covers a bias (the track 0.4 m west
    // of the pose, 1.1 m above it), so two stricter runs: each outage's
    // sigma measured on the fixes outside it only, and starts drawn off
    // the pose at the filter's prior (the start is otherwise the
    // reference's own attitude; 16 draws).
    let (rec, _) = import(&measured_input()).unwrap();
    let starts = [10.0, 25.0, 35.0, 40.0];
    let as_is = nees_shares_at(&rec, &starts);
    let outside: Vec<f64> = starts
        .iter()
        .map(|&a| nees_shares_at(&measured_outside(&rec, a, 15.0), &[a])[0])
        .collect();
    let drawn = drawn_start_shares(&rec, &starts, 16, 70);
    println!("in bounds as imported: {as_is:?}; sigma from outside each outage: {outside:?}; from the prior's draws: {drawn:?}");
    for shares in [&as_is, &outside, &drawn] {
        assert!(shares.iter().all(|&x| x >= 0.7), "{shares:?}");
    }
}

/// `rec` with every fix's sigma measured on the fixes outside
/// `[start_s, start_s + len_s)` only (as the import measures it).
fn measured_outside(rec: &recording::Recording, start_s: f64, len_s: f64) -> recording::Recording {
    let mut r = rec.clone();
    let mv = r.moving.as_mut().unwrap();
    let o = GeoPoint::from_deg(r.meta.latitude_deg, mv.longitude_deg, r.meta.height_m);
    let fixes = mv.gnss.as_mut().unwrap();
    let kept: Vec<GnssRow> = fixes
        .iter()
        .filter(|f| f.t_s < start_s || f.t_s >= start_s + len_s)
        .copied()
        .collect();
    let c = against_reference(&kept, mv.truth.as_ref().unwrap(), &o.tangent()).unwrap();
    let [h, v] = c.sigma_m();
    for f in fixes.iter_mut() {
        (f.sigma_h_m, f.sigma_v_m) = (h, v);
    }
    r
}

/// Over the seconds of a 20 s outage at 5 s (`--vehicle car`, the
/// default import, the filter's prior from `profile`): the share of them
/// whose 9-dof diagonal NEES lies inside its 95 % bounds, the number
/// below the lower bound (sigmas too wide) and above the upper (too
/// narrow), and the horizontal error at its end, m.
fn early_outage(profile: hal_sim::imu::ImuSpec) -> (f64, usize, usize, f64) {
    let (rec, _) = import(&measured_input()).unwrap();
    let (start, len) = (5.0, 20.0);
    let opt = AidedOptions {
        outages: vec![(start, len)],
        vehicle: Some(Vehicle::Car),
        ..AidedOptions::new(profile)
    };
    let run = navigate(&rec, &opt, &mut |_| {}).unwrap();
    let (lo, hi) = rins::aided::chi2_95_bounds(9);
    let inside: Vec<f64> = run
        .nees_diag
        .iter()
        .filter(|(t, _)| (start..start + len).contains(t))
        .map(|(_, n)| n / 9.0)
        .collect();
    let s = summary(&rec, &run);
    let end = s.outages[0].end_error_m.unwrap();
    (
        s.outages[0].nees_diag_in_95.unwrap(),
        inside.iter().filter(|&&x| x < lo).count(),
        inside.iter().filter(|&&x| x > hi).count(),
        end,
    )
}

#[test]
fn an_outage_5_s_after_a_moving_start_is_cautious_by_the_chip_s_gyro_prior() {
    // Five seconds after a moving start, on a straight highway, the filter
    // has not yet seen the gyros' bias: its sigmas carry the chip's
    // turn-on bias, 1 deg/s per axis (the sensor file's), and the heading
    // sigma grows 2.4 -> 4.2 deg in the outage's first 10 s. But comma's
    // `IMU/gyro` is the device's calibrated stream (Android's estimate,
    // -0.56, -2.01, +3.92 deg/s on this minute, taken out): what is left
    // is that estimate's error, 0.03-0.04 deg/s by the whole minute's
    // filter. So the outage's sigma columns are too wide, never too
    // narrow. Measured: 65 % of its seconds inside the bounds (60 % as
    // `navigate` runs it), every miss below, 6.1 m at its end. Given a profile whose turn-on bias is 0.1
    // deg/s (a calibration's residual: the sensor file's 0.005 deg/s/C
    // over its assumed 6 C warm-up is 0.03), 90 % and 1.8 m. The chip in
    // the dashcam is not known, so `navigate` keeps the chip's prior: a
    // sigma too wide is a figure a user can still trust.
    let (_, rep) = import(&measured_input()).unwrap();
    // The import reports the estimate the stream had taken out: the
    // array's mean as numpy reads it, 4.44 deg/s in norm.
    let taken_out = nalgebra::Vector3::from(rep.device_gyro_bias_dps.unwrap());
    assert!((taken_out.norm() - 4.44).abs() < 0.01, "{taken_out}");
    let chip = hal_sim::sensor::resolve("icm42605").unwrap();
    let (share, below, above, end) = early_outage(chip.clone());
    println!("the chip's prior: {share:.2} in bounds, {below} s below, {above} above, {end:.2} m");
    assert_eq!(above, 0, "too narrow with the chip's prior");
    assert!(below > 0, "the chip's prior should read cautious here");
    let mut calibrated = chip;
    calibrated.gyro.bias = 0.1_f64.to_radians();
    let (share_c, below_c, above_c, end_c) = early_outage(calibrated);
    println!("a calibrated stream's prior: {share_c:.2} in bounds, {below_c} s below, {above_c} above, {end_c:.2} m");
    // The 70 %, and closer: the bias was what the outage drifted on.
    assert!(share_c >= 0.7 && end_c < end, "{share_c} {end_c} {end}");
}

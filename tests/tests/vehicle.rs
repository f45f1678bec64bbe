//! A car's constraints (`navigate --gnss --vehicle car`, `rins outages
//! --vehicle car`) on simulated city drives whose base is mounted in the
//! car at a rotation the filter is not told: the forward axis is found
//! within its 3 sigma, its sigma agrees with the spread over the drives,
//! and the constraints at least halve the mean error
//! at a 60 s outage's end on both spinning sensors. Figures from our own
//! simulator only (its car neither slides nor bounces: the constraints
//! hold exactly there, and are taken with a road's sigma).

use hal_sim::drive::DriveKind;
use hal_sim::imu::ImuSpec;
use rins::vehicle_study;

#[test]
fn the_constraints_find_the_mounting_and_halve_the_minute_outage() {
    let imus = [ImuSpec::icm42688(), ImuSpec::nav440()];
    // 12 drives a sensor: the count; fewer do not separate a
    // 60 s outage's errors (their ends range 0.2-14 m from drive to drive).
    let s = vehicle_study::run(DriveKind::City, &imus, 1, 12, &|_| {}).unwrap();
    print!("{}", s.markdown());
    // Every drive's axis within 4 of its sigmas, and at most one drive
    // beyond 3: for a right sigma, of the 48 components (yaw and pitch on
    // 24 drives) one lies beyond 3 with 12 % (48 x 0.27 %), two with
    // 0.8 %, one beyond 4 with 0.3 %. (Measured: one, icm42688 seed 8,
    // its yaw at 3.04 sigma.)
    let mut beyond_3 = 0;
    for r in &s.runs {
        let [y, p] = r
            .forward_sigmas
            .expect("the forward axis found on every drive");
        println!("{} seed {}: {y:.2} / {p:.2} sigma", r.imu, r.seed);
        assert!(
            y <= 4.0 && p <= 4.0,
            "{} seed {}: {y:.2} / {p:.2} sigma",
            r.imu,
            r.seed
        );
        beyond_3 += usize::from(y > 3.0 || p > 3.0);
    }
    assert!(beyond_3 <= 1, "{beyond_3} drives beyond 3 sigma");
    // The axis's sigma against the spread over the 24 drives: the rms of
    // error over sigma is 1 for a right sigma; 24 unit normals' rms lies
    // in [0.64, 1.38] with 99 % (chi-square, 24 dof). Measured: yaw 1.01,
    // pitch 0.49 (conservative: allowed, as the one-sided goal on
    // the simulated drives).
    let rms = |k: usize| {
        let v: Vec<f64> = s
            .runs
            .iter()
            .filter_map(|r| r.forward_sigmas.map(|f| f[k]))
            .collect();
        (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
    };
    println!(
        "axis error over its sigma, rms: yaw {:.2}, pitch {:.2}",
        rms(0),
        rms(1)
    );
    assert!((0.64..=1.38).contains(&rms(0)), "yaw {}", rms(0));
    assert!(rms(1) <= 1.38, "pitch {}", rms(1));
    for imu in &imus {
        let runs: Vec<_> = s.runs.iter().filter(|r| r.imu == imu.name).collect();
        let mean = |k: usize, on: bool| {
            let v: Vec<f64> = runs
                .iter()
                .map(|r| {
                    if on {
                        r.end_error_on_m[k]
                    } else {
                        r.end_error_off_m[k]
                    }
                })
                .collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        // The done-when: the 60 s outage at least halved.
        assert!(mean(0, true) <= 0.5 * mean(0, false), "{}: 60 s", imu.name);
        assert!(mean(1, true) < mean(1, false), "{}: 120 s", imu.name);
    }
}

#[test]
fn an_imu_ahead_of_the_rear_axle_is_found_and_its_turns_do_not_mislead_the_constraints() {
    // Our simulator's car with the IMU 1.5 m ahead of the rear axle, and
    // at the axle, the axle sliding out of turns by its tyres' slip: in a city
    // turn (up to 0.3 rad/s) the IMU then moves sideways at 0.45 m/s,
    // which the constraints must not read as the mounting's or the
    // heading's error. The oracles are the simulator's own distance and slip.
    use rins::aided::vehicle::Vehicle;
    use rins::aided::{navigate, summary, AidedOptions};
    let p = ImuSpec::icm42688();
    for (seed, ahead) in [(1, 1.5), (2, 1.5), (3, 0.0)] {
        let mut c = rins::outages::config_mounted(
            DriveKind::City,
            &p,
            false,
            seed,
            &[(200.0, 60.0)],
            [0.0, 0.0, 3.0],
        );
        c.duration_s = 300.0;
        c.drive.as_mut().unwrap().imu_ahead_m = ahead;
        let rec = hal_sim::sim::simulate(&c, &mut |_| {}).unwrap();
        let opt = AidedOptions {
            outages: vec![(200.0, 60.0)],
            vehicle: Some(Vehicle::Car),
            ..AidedOptions::new(p.clone())
        };
        let run = navigate(&rec, &opt, &mut |_| {}).unwrap();
        let s = summary(&rec, &run);
        let f = s.vehicle.unwrap().forward.unwrap();
        let o = s.outages[0];
        let slip = hal_sim::body::Body::draw(seed).slip_rad_per_mps2;
        let slip = (slip * core_nav::units::G0_MPS2).to_degrees();
        println!(
            "seed {seed}: ahead {ahead} m, found {:.3} +- {:.3} m; slip {slip:.2}, found {:.2} +- {:.2} deg/g; outage end {:.2} m (largest {:.2}), {:.0} % inside 3 sigma",
            f.imu_ahead_m,
            f.sigma_imu_ahead_m,
            f.rear_slip_deg_per_g,
            f.sigma_rear_slip_deg_per_g,
            o.end_error_m.unwrap(),
            o.max_error_m.unwrap(),
            100.0 * o.within_3_sigma.unwrap()
        );
        // Within 3 of its sigmas, and seen (its prior is 1.5 m): measured
        // 0.05-0.06 m on 600 s drives.
        assert!(
            (f.imu_ahead_m - ahead).abs() < 3.0 * f.sigma_imu_ahead_m,
            "seed {seed}: {f:?}"
        );
        assert!(f.sigma_imu_ahead_m < 0.3, "seed {seed}: {f:?}");
        // The rear axle's slip (the body's, drawn per drive), within 3 of
        // its sigmas and seen (its prior is 1.4 deg/g): measured 0.5-0.8.
        assert!(
            (f.rear_slip_deg_per_g - slip).abs() < 3.0 * f.sigma_rear_slip_deg_per_g,
            "seed {seed}: {f:?}"
        );
        assert!(f.sigma_rear_slip_deg_per_g < 1.2, "seed {seed}: {f:?}");
        assert!(o.within_3_sigma.unwrap() >= 0.95, "seed {seed}: {o:?}");
    }
}

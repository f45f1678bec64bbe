//! The aided rotary INS on a moving vehicle (hal-sim's drives, core-nav's
//! filter, `rins::aided`): a drive's recording round-trips, the filter's
//! covariance is honest against the simulated truth (NIS, NEES), the error
//! at an outage's end stays inside what the filter says, and the rotary
//! table beats the still one through long outages (NAV440, mean over
//! drives). Figures from our own simulator only: no real drive with truth
//! is in `../shared/data`.

use hal_sim::drive::DriveKind;
use hal_sim::imu::ImuSpec;
use hal_sim::sim::simulate;
use nalgebra::{Rotation3, Vector3};
use recording::Recording;
use rins::aided::{self, AidedOptions};
use rins::outages;
use rins_tests::board::{HostBoard, NorFlash};
use rins_tests::twin::{self, TwinOptions, TwinRun};

fn opts(p: &ImuSpec) -> AidedOptions {
    AidedOptions::new(p.clone())
}

/// A simulated city drive of `p` (rotary or still table, `seed`, the
/// receiver's outages `gaps`: start s, length s) cut to `seconds`.
fn city_drive(
    p: &ImuSpec,
    rotary: bool,
    seed: u64,
    gaps: &[(f64, f64)],
    seconds: f64,
) -> Recording {
    let mut c = outages::config_with(DriveKind::City, p, rotary, seed, gaps);
    c.duration_s = seconds;
    simulate(&c, &mut |_| {}).unwrap()
}

/// `rins navigate --gnss --f32`: the board's arithmetic.
fn navigate_f32(rec: &Recording, p: &ImuSpec) -> aided::AidedRun {
    let o = AidedOptions {
        f32: true,
        ..opts(p)
    };
    aided::navigate(rec, &o, &mut |_| {}).unwrap()
}

#[test]
fn a_drive_recording_round_trips_with_its_gnss_and_truth() {
    let p = ImuSpec::nav440();
    let rec = city_drive(&p, true, 4, &outages::OUTAGES, 120.0);
    let dir = std::env::temp_dir().join(format!("rins-drive-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    rec.write(&dir).unwrap();
    let back = Recording::read(&dir).unwrap();
    let (a, b) = (rec.moving.as_ref().unwrap(), back.moving.as_ref().unwrap());
    assert_eq!(a.gnss_meta, b.gnss_meta);
    assert_eq!(a.longitude_deg, b.longitude_deg);
    let (ga, gb) = (a.gnss.as_ref().unwrap(), b.gnss.as_ref().unwrap());
    assert_eq!(ga.len(), gb.len());
    // Written to 1e-9 deg (0.1 mm) and 1 mm: the file's precision.
    for (x, y) in ga.iter().zip(gb) {
        assert!((x.lat_deg - y.lat_deg).abs() < 1e-9 && (x.height_m - y.height_m).abs() < 1e-3);
    }
    assert_eq!(a.truth.as_ref().unwrap().len(), rec.imu.len());
    // Without gnss.csv, --gnss says which file is missing.
    std::fs::remove_file(dir.join("gnss.csv")).unwrap();
    let no_gnss = Recording::read(&dir).unwrap();
    let e = aided::navigate(&no_gnss, &opts(&p), &mut |_| {}).unwrap_err();
    assert!(e.to_string().contains("gnss.csv"), "{e}");
    // A malformed fix is an error naming the file and line.
    std::fs::write(
        dir.join("gnss.csv"),
        "t_s,lat_deg,lon_deg,height_m,vn_mps,ve_mps,vd_mps,sigma_h_m,sigma_v_m,sigma_vel_mps\n1.0,30.5,114.3,20,0,0,0,1.5,3,0.05\n2.0,30.5,x,20,0,0,0,1.5,3,0.05\n",
    )
    .unwrap();
    let e = Recording::read(&dir).unwrap_err();
    assert_eq!(e.line, Some(3));
    assert!(e.path.ends_with("gnss.csv"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_filter_is_honest_on_a_city_drive_with_outages() {
    // NAV440, rotary at 30 deg/s, outages of 10-120 s. NIS per component
    // within 0.7-1.3 (its mean over ~2,500 components has a 95 % band of
    // about +-0.06 if the filter is right; the rest is the receiver model's
    // and the unmodelled sensor terms' share), NEES inside its 95 % bounds
    // at least 80 % of the seconds (a consistent filter: 95 %; measured
    // 91-92 % over 20 NAV440 drives: the seconds are correlated over the
    // receiver's minute-long errors, and the filter does not carry the
    // accelerometers' scale and misalignment or the g-sensitivity),
    // every outage's end error within 3 sigma + 2 m of what the filter said.
    let p = ImuSpec::nav440();
    let rec = simulate(&outages::config(DriveKind::City, &p, true, 1), &mut |_| {}).unwrap();
    let run = aided::navigate(&rec, &opts(&p), &mut |_| {}).unwrap();
    let s = aided::summary(&rec, &run);
    print!("{}", s.text());
    assert!(
        (0.7..=1.3).contains(&s.nis_mean_per_dof.unwrap()),
        "NIS {:?}",
        s.nis_mean_per_dof
    );
    assert!(s.nees_in_95.unwrap() >= 0.8);
    assert_eq!(s.outages.len(), outages::OUTAGES.len());
    for g in &s.outages {
        let e = g.end_error_m.unwrap();
        assert!(e < 3.0 * g.end_sigma_m + 2.0, "{g:?}");
    }
    assert_eq!((s.faults, s.refused), (0, 0));
    assert!(
        s.zupts > 0,
        "the drive has stops: zero-velocity updates expected"
    );
    // One zero-rotation update per still window of 50 samples, the
    // zero-velocity updates one per 10.
    assert!(
        s.zarus > 0 && s.zarus * 4 <= s.zupts,
        "{} {}",
        s.zarus,
        s.zupts
    );
}

#[test]
fn the_rotary_table_beats_the_still_one_in_the_issues_drive() {
    // The issue's run: a 900 s city drive, outages 300:60 and 600:120, the
    // table at 30 deg/s or still, NAV440 and ICM-42688-P, six seeds each:
    // the mean horizontal error at each outage's end (`rins outages` runs
    // 20 drives with four outage lengths for the book). The rotation
    // turns the gyro biases across the table axis into sinusoids in n; the
    // still table's biases tilt and turn the solution for the whole
    // outage.
    let outages = [(300.0, 60.0), (600.0, 120.0)];
    let mut jobs = vec![];
    for imu in [ImuSpec::nav440(), ImuSpec::icm42688()] {
        for rotary in [true, false] {
            for seed in 1..=6u64 {
                jobs.push((imu.clone(), rotary, seed));
            }
        }
    }
    let results: Vec<(String, bool, Vec<f64>)> = std::thread::scope(|sc| {
        let hs: Vec<_> = jobs
            .chunks(jobs.len().div_ceil(2))
            .map(|chunk| {
                sc.spawn(move || {
                    chunk
                        .iter()
                        .map(|(imu, rotary, seed)| {
                            let c = outages::config_with(
                                DriveKind::City,
                                imu,
                                *rotary,
                                *seed,
                                &outages,
                            );
                            let rec = simulate(&c, &mut |_| {}).unwrap();
                            let run = aided::navigate(&rec, &opts(imu), &mut |_| {}).unwrap();
                            let s = aided::summary(&rec, &run);
                            let ends = outages
                                .iter()
                                .map(|(t0, l)| {
                                    s.outages
                                        .iter()
                                        .find(|g| {
                                            g.start_s <= t0 + 1e-6
                                                && g.start_s + g.len_s >= t0 + l - 1e-6
                                        })
                                        .and_then(|g| g.end_error_m)
                                        .unwrap()
                                })
                                .collect();
                            (imu.name.to_string(), *rotary, ends)
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        hs.into_iter().flat_map(|h| h.join().unwrap()).collect()
    });
    for imu in ["nav440", "icm42688"] {
        for k in 0..2 {
            let mean = |rotary: bool| {
                let v: Vec<f64> = results
                    .iter()
                    .filter(|r| r.0 == imu && r.1 == rotary)
                    .map(|r| r.2[k])
                    .collect();
                v.iter().sum::<f64>() / v.len() as f64
            };
            let (rot, conv) = (mean(true), mean(false));
            println!("{imu}, outage {k}: rotary {rot:.1} m, conventional {conv:.1} m");
            assert!(
                rot < conv,
                "{imu} outage {k}: rotary {rot:.1} m, conventional {conv:.1} m"
            );
        }
    }
}

#[test]
fn the_f32_board_navigation_follows_its_f64_twin_through_a_drive() {
    // The board's arithmetic (mechanization and filter in f32) against the
    // f64 twin on the same 900 s city drive with two outages: horizontal
    // position within 0.1 m, velocity within 5 mm/s, heading within 0.01
    // deg at every sample (measured 0.037 m, 0.13 mm/s, 0.0014 deg: f32
    // keeps ~7 digits of km-scale offsets, 0.25 mm, and the filter's
    // covariance to ~1e-3 relative).
    let p = ImuSpec::nav440();
    let c = outages::config_with(
        DriveKind::City,
        &p,
        true,
        1,
        &[(300.0, 60.0), (600.0, 120.0)],
    );
    let rec = simulate(&c, &mut |_| {}).unwrap();
    let a = aided::navigate(&rec, &opts(&p), &mut |_| {}).unwrap();
    let b = navigate_f32(&rec, &p);
    assert_eq!(a.rows.len(), b.rows.len());
    let (mut dp, mut dv, mut dh) = (0.0f64, 0.0f64, 0.0f64);
    for (x, y) in a.rows.iter().zip(&b.rows) {
        let (x, y) = (&x.traj, &y.traj);
        dp = dp.max((x.ned_m[0] - y.ned_m[0]).hypot(x.ned_m[1] - y.ned_m[1]));
        dv = dv.max((x.v_mps[0] - y.v_mps[0]).hypot(x.v_mps[1] - y.v_mps[1]));
        dh = dh.max(((x.rph_deg[2] - y.rph_deg[2] + 180.0).rem_euclid(360.0) - 180.0).abs());
    }
    println!("f32 vs f64: {dp:.3} m, {dv:.5} m/s, {dh:.4} deg");
    assert!(dp < 0.1 && dv < 5e-3 && dh < 0.01);
}

/// The board's program on the host (the QEMU test's twin) through a drive.
fn board_drive(seconds: f64, outages: &[(f64, f64)], opt: TwinOptions) -> (TwinRun, Recording) {
    let p = ImuSpec::icm42688();
    let rec = city_drive(&p, true, 5, outages, seconds);
    let bytes = rins::qemu_replay::build(&rec, 16_384).unwrap().bytes;
    (twin::run(&bytes, opt), rec)
}

/// The RMS horizontal distance (m) of the board's navigation frames (its
/// telemetry, decoded as `rins record` does) from the truth, outside the
/// outage (while fixes come).
fn track_rms(run: &TwinRun, rec: &Recording, outage: (f64, f64)) -> f64 {
    let truth = rec.moving.as_ref().unwrap().truth.as_ref().unwrap();
    let d = rins::record::decode(run.board.sent.iter().copied(), recording::Meta::default());
    // The board's clock against the recording's: its first IMU frame is
    // the recording's first sample (the relay's mapping).
    let offset = d.recording.imu[0].t_s - rec.imu[0].t_s;
    let mut sum = 0.0;
    let mut n = 0usize;
    for (t_us, p) in &d.nav {
        let t = *t_us as f64 * 1e-6 - offset;
        if t > outage.0 && t < outage.0 + outage.1 + 30.0 {
            continue;
        }
        let k = truth.partition_point(|r| r.t_s < t).min(truth.len() - 1);
        let tr = &truth[k];
        if (tr.t_s - t).abs() > 0.006 {
            continue;
        }
        sum += (f64::from(p[0]) - tr.p_n_m[0]).powi(2) + (f64::from(p[1]) - tr.p_n_m[1]).powi(2);
        n += 1;
    }
    assert!(n > 500, "{n} navigation frames matched the truth");
    (sum / n as f64).sqrt()
}

#[test]
fn the_board_navigates_a_drive_as_the_host_does() {
    // The board's program (firmware::tasks on the host, fixes arriving on
    // time as command frames byte by byte through the UART's queue, a zero
    // horizon) against `rins navigate --gnss --f32` on the same 300 s city
    // drive with a 60 s outage, on the board's ICM-42688-P. Both run
    // core-nav's AidedNav in f32; they differ in the table angle (the
    // board interpolates its 50 Hz encoder reads, the host fits the track)
    // and the sample the board starts on, and in the state a fix is
    // compared with: the board's stored state nearest the fix's time of
    // validity (a sample's mid-point), the host's the sample whose end is
    // nearest, up to 10 ms apart (20 cm at 20 m/s). Ending position within
    // 1 m and velocity within 5 cm/s (measured: 0.03 m, 0.1 mm/s; on the
    // rigid car before its body moved, 0.09 m, 2.3 cm/s).
    let on_time = TwinOptions {
        latency_us: Some(0),
        horizon_us: Some(0),
        ..TwinOptions::default()
    };
    let (board, rec) = board_drive(300.0, &[(120.0, 60.0)], on_time);
    let host = navigate_f32(&rec, &ImuSpec::icm42688());
    let last = host.rows.last().unwrap().traj;
    let o = board.outcome;
    let dp = (f64::from(o.p_n[0]) - last.ned_m[0]).hypot(f64::from(o.p_n[1]) - last.ned_m[1]);
    let dv = (f64::from(o.v_n[0]) - last.v_mps[0]).hypot(f64::from(o.v_n[1]) - last.v_mps[1]);
    println!("board vs host at the end: {dp:.3} m, {dv:.4} m/s");
    assert!(dp < 1.0 && dv < 0.05, "{dp} m, {dv} m/s");
    assert!(last.ned_m[0].hypot(last.ned_m[1]) > 500.0);
    let counts = board.board.program.nav.nav.aided().unwrap().counts;
    println!(
        "zero-velocity updates: board {}, host {}",
        counts.zupts, host.zupts
    );
    assert!(host.zupts > 100);
    // Within 10 %: the detector learns its threshold from the still start,
    // where the board's table rate (0.5 s of encoder reads) and the host's
    // (the knot fit) differ most while the table spins up.
    assert!(counts.zupts.abs_diff(host.zupts) * 10 <= host.zupts);
    assert!(counts.fixes_used > 200);
}

#[test]
fn fixes_applied_at_their_epoch_lose_nothing_to_the_latency() {
    // The same drive, the fixes sent 150 ms and 300 ms after their time of
    // validity (a receiver and a relay), applied at the board's 400 ms
    // horizon from the state stored for their time of validity: the
    // track's RMS error against the truth (10 Hz navigation frames, away
    // from the outage) within 10 % or 5 cm of on-time fixes' (the error
    // state moves by the velocity error times the horizon: mm). A board
    // that stamps each fix with its arrival instead compares the antenna's
    // position 150 ms later, 1.5-3 m along the track at 10-20 m/s: its
    // track must be worse by far (the check that this test can fail).
    let outage = (120.0, 60.0);
    let on_time = TwinOptions {
        latency_us: Some(0),
        horizon_us: Some(0),
        ..TwinOptions::default()
    };
    let (r0, rec) = board_drive(300.0, &[outage], on_time);
    let e0 = track_rms(&r0, &rec, outage);
    for latency in [150_000, 300_000] {
        let (r, _) = board_drive(
            300.0,
            &[outage],
            TwinOptions {
                latency_us: Some(latency),
                ..TwinOptions::default()
            },
        );
        let e = track_rms(&r, &rec, outage);
        let nav = &r.board.program.nav.nav;
        println!(
            "latency {} ms: track RMS {e:.3} m (on time {e0:.3} m), fixes used {}, late {}",
            latency / 1000,
            nav.aided().map_or(0, |a| a.counts.fixes_used),
            nav.fixes_late
        );
        assert_eq!(nav.fixes_late, 0);
        assert_eq!(r.fixes, r0.fixes);
        assert!(e < e0 * 1.1 + 0.05, "{e} vs {e0}");
    }
    let (naive, _) = board_drive(
        300.0,
        &[outage],
        TwinOptions {
            latency_us: Some(150_000),
            stamp_at_arrival: true,
            ..TwinOptions::default()
        },
    );
    let en = track_rms(&naive, &rec, outage);
    println!("stamped at arrival: track RMS {en:.3} m");
    // 150 ms at 10-14 m/s is 1.5-2 m along the track at every fix, of
    // which the filter takes a share: worse than the band the compensated
    // fixes must stay in (1.1 e0 + 5 cm) by a clear step (measured: 1.37
    // e0 on this drive, 2 e0 on the drive the simulator's earlier random
    // streams made).
    assert!(en > 1.2 * e0 + 0.05, "{en} vs {e0}");
}

#[test]
fn an_aided_board_stopped_by_a_fault_navigates_on_after_start() {
    // The board's program in aided mode through half a drive, then the IMU
    // silent for 200 ms (the link task's supervision stops the motor and
    // the tick halts), then `Start` over the link: it must carry on from
    // where it was, not start again at the origin with the attitude it
    // powered up with.
    use firmware::navigation::Mode;
    use firmware::replay::{decode, record_body, Event, Header, Sensors, HEADER, RECORD_HEAD};
    use protocol::Command;
    let p = ImuSpec::icm42688();
    let rec = city_drive(&p, true, 5, &[], 120.0);
    let bytes = rins::qemu_replay::build(&rec, 16_384).unwrap().bytes;
    let h = Header::decode(&bytes[..HEADER]).unwrap();
    let tuning = firmware::replay::tuning(&h, firmware::tuning::board());
    let mut b = HostBoard::new(tuning, NorFlash::new(4096), 1_000, Ok(()));
    let mut events = vec![];
    let mut at = HEADER;
    for _ in 0..h.records {
        let n = RECORD_HEAD + record_body(bytes[at]).unwrap();
        events.push(decode(&bytes[at..at + n]).unwrap());
        at += n;
    }
    for e in &events {
        if let Event::Command { len, payload } = e {
            b.command(&Command::decode(&payload[..usize::from(*len)]).unwrap().1);
        }
    }
    b.link_due();
    let mut it = events
        .into_iter()
        .filter(|e| matches!(e, Event::Imu { .. } | Event::Encoder { .. }));
    let mut s = Sensors::default();
    let mut mcu = b.mcu_us;
    let mut i = 0u64;
    let edge = |b: &mut HostBoard,
                s: &mut Sensors,
                i: &mut u64,
                mcu: &mut u64,
                it: &mut dyn Iterator<Item = Event>| {
        s.advance(*i, &mut || it.next(), &mut |_| {});
        *mcu += 1_000;
        let (mut e, mut m) = (*s, *s);
        b.edge(*mcu, s, &mut e, &mut m);
        *i += 1;
    };
    for _ in 0..60_000 {
        edge(&mut b, &mut s, &mut i, &mut mcu, &mut it);
    }
    assert_eq!(b.program.nav.nav.mode(), Mode::Navigating);
    let p_before = b.program.nav.nav.aided().unwrap().nav().state().p_n;
    assert!(p_before.norm() > 50.0, "the car has moved: {p_before}");
    // The IMU silent for 200 ms.
    b.idle(200_000);
    mcu = b.mcu_us;
    edge(&mut b, &mut s, &mut i, &mut mcu, &mut it);
    for _ in 0..10 {
        edge(&mut b, &mut s, &mut i, &mut mcu, &mut it);
    }
    assert!(
        matches!(b.program.nav.nav.mode(), Mode::Stopped(_)),
        "{:?}",
        b.program.nav.nav.mode()
    );
    b.command(&Command::Start {});
    b.link_due();
    for _ in 0..20 {
        edge(&mut b, &mut s, &mut i, &mut mcu, &mut it);
    }
    assert_eq!(b.program.nav.nav.mode(), Mode::Navigating);
    let p_after = b.program.nav.nav.aided().unwrap().nav().state().p_n;
    assert!(
        (p_after - p_before).norm() < 50.0,
        "{p_before} -> {p_after}"
    );
}

/// The horizontal error (m) of `run` against the truth at `t_s`.
fn h_error_at(run: &aided::AidedRun, rec: &Recording, t_s: f64) -> f64 {
    let truth = rec.moving.as_ref().unwrap().truth.as_ref().unwrap();
    let k = run.rows.partition_point(|r| r.traj.t_s < t_s);
    let r = &run.rows[k];
    let tr = recording::moving::truth_at(truth, r.traj.t_s).unwrap();
    (tr.p_n_m[0] - r.traj.ned_m[0]).hypot(tr.p_n_m[1] - r.traj.ned_m[1])
}

/// The ICM-42688-P on the still table, a 240 s city drive with a 60 s
/// outage from 120 s, navigated untouched; then its accelerometer `axis`
/// made to read 1 m/s^2 more during the outage: (the sensor, the outage,
/// the tampered recording, the untouched run).
fn tampered_outage(axis: usize) -> (ImuSpec, (f64, f64), Recording, aided::AidedRun) {
    let p = ImuSpec::icm42688();
    let outage = (120.0, 60.0);
    let mut rec = city_drive(&p, false, 5, &[outage], 240.0);
    let clean = aided::navigate(&rec, &opts(&p), &mut |_| {}).unwrap();
    for r in rec.imu.iter_mut() {
        if r.t_s >= outage.0 && r.t_s < outage.0 + outage.1 {
            r.accel_mps2[axis] += 1.0;
        }
    }
    (p, outage, rec, clean)
}

#[test]
fn a_filter_kilometres_off_after_an_outage_is_back_within_10_s_of_fixes() {
    // The ICM-42688-P on the still table, a 60 s outage from 120 s; during
    // it the accelerometers read 1 m/s^2 more along x than the simulation
    // says (a bias the filter's model does not allow: 0.2 m/s^2 1-sigma),
    // so the filter ends the outage 1.4 km off with a sigma of tens of
    // metres, and the 6-sigma gate refuses every returning fix. Three
    // refused fixes that agree among themselves re-initialise position and
    // velocity: within 10 s of the fixes' return the error is inside the
    // receiver's 3 sigma (1.5 m per axis), and the filter is used again
    // (measured: 1.7 m at 10 s, 1.1 m at 50 s; without the re-initialisation
    // 1.9 km and 3.8 km, 648 components refused; since the height alone
    // restarts where only it was refused: 1.3 m and 0.9 m).
    let (p, outage, mut rec, clean) = tampered_outage(0);
    assert_eq!(clean.reinits, 0, "no re-initialisation on a clean drive");
    let run = aided::navigate(&rec, &opts(&p), &mut |_| {}).unwrap();
    let end = outage.0 + outage.1;
    let off = h_error_at(&run, &rec, end - 0.5);
    let back = h_error_at(&run, &rec, end + 10.0);
    let later = h_error_at(&run, &rec, end + 50.0);
    println!(
        "off {off:.0} m at the outage's end, {back:.2} m 10 s after, {later:.2} m 50 s after; re-initialised {} times, gate rejections {}",
        run.reinits, run.rejected
    );
    assert!(off > 1_000.0, "the tampering must lose the filter: {off} m");
    assert!(run.reinits >= 1);
    assert!(back < 3.0 * 1.5 * 2f64.sqrt(), "{back} m");
    assert!(later < 3.0 * 1.5 * 2f64.sqrt(), "{later} m");
    // The same with position-only fixes (recording-v1 allows them): the
    // velocity then comes from the refused fixes' own positions.
    strip_velocity(&mut rec);
    let run = aided::navigate(&rec, &opts(&p), &mut |_| {}).unwrap();
    let back = h_error_at(&run, &rec, end + 10.0);
    let later = h_error_at(&run, &rec, end + 50.0);
    println!(
        "position-only: {back:.2} m 10 s after, {later:.2} m 50 s after; re-initialised {} times",
        run.reinits
    );
    assert!(run.reinits >= 1);
    assert!(back < 3.0 * 1.5 * 2f64.sqrt(), "{back} m");
    assert!(later < 3.0 * 1.5 * 2f64.sqrt(), "{later} m");
}

#[test]
fn a_height_lost_in_an_outage_restarts_the_vertical_channel_alone() {
    // The drive above, the accelerometers' z (down: the still table keeps
    // the sensor level in the car) reading 1 m/s^2 more during the
    // outage: the height ends it kilometres off, the horizontal as it
    // would. The gate refuses the returning fixes' heights and takes
    // their horizontal positions: the vertical channel alone restarts
    // (a full re-initialisation would throw the horizontal state's
    // correlations away while its fixes are accepted; the real walk's
    // three re-initialisations were all of this kind). Measured: no full
    // re-initialisation, 1 of the height (1,768 m off, 1.4 m 10 s after);
    // the horizontal error 10 s after the outage 1.71 m, the clean run's
    // 1.74 m.
    // With the sensor file's vertical noise: the passes before the run
    // would take the tampering's kilometre for a ride's vertical noise
    // and the heights back without a restart (measured: 990 m off at the
    // end, 1.39 m 10 s after, no restart), and the restart is what is
    // tested here.
    let (p, outage, rec, clean) = tampered_outage(2);
    assert_eq!((clean.reinits, clean.height_reinits), (0, 0));
    let o = AidedOptions {
        vertical_learn: false,
        ..opts(&p)
    };
    let run = aided::navigate(&rec, &o, &mut |_| {}).unwrap();
    let end = outage.0 + outage.1;
    let height_off = |run: &aided::AidedRun, t_s: f64| {
        let truth = rec.moving.as_ref().unwrap().truth.as_ref().unwrap();
        let k = run.rows.partition_point(|r| r.traj.t_s < t_s);
        let r = &run.rows[k];
        let tr = recording::moving::truth_at(truth, r.traj.t_s).unwrap();
        (tr.p_n_m[2] - r.traj.ned_m[2]).abs()
    };
    let (h_clean, h) = (
        h_error_at(&clean, &rec, end + 10.0),
        h_error_at(&run, &rec, end + 10.0),
    );
    println!(
        "height {:.0} m off at the outage's end, {:.2} m 10 s after; re-initialised {} times, the height alone {}; horizontal 10 s after {h:.3} m (clean {h_clean:.3} m)",
        height_off(&run, end - 0.5),
        height_off(&run, end + 10.0),
        run.reinits,
        run.height_reinits
    );
    assert!(
        height_off(&run, end - 0.5) > 100.0,
        "the tampering must lose the height"
    );
    assert_eq!(run.reinits, 0, "the horizontal fixes were taken");
    assert!(run.height_reinits >= 1);
    // The receiver's vertical 1-sigma is 3 m: back inside its 3 sigma.
    assert!(height_off(&run, end + 10.0) < 9.0);
    // The horizontal as the clean run's, within the receiver's 1-sigma.
    assert!((h - h_clean).abs() < 1.5, "{h} {h_clean}");
}

/// The recording's fixes made position-only (no velocity columns).
fn strip_velocity(rec: &mut Recording) {
    for f in rec.moving.as_mut().unwrap().gnss.as_mut().unwrap() {
        f.v_n_mps = [f64::NAN; 3];
        f.sigma_vel_mps = f64::NAN;
    }
}

#[test]
fn position_only_fixes_aid_the_filter() {
    // The NAV440 city drive with a 30 s outage, its fixes stripped of
    // velocity: the file is written and read position-only, the filter
    // uses the fixes, and its horizontal error while fixes come is below
    // the fixes' own (1.5 m per axis: 2.1 m horizontal rms). Measured:
    // 1.57 m position-only, 0.65 m with velocity.
    let p = ImuSpec::nav440();
    let mut rec = city_drive(&p, true, 3, &[(120.0, 30.0)], 300.0);
    let with = aided::summary(
        &rec,
        &aided::navigate(&rec, &opts(&p), &mut |_| {}).unwrap(),
    );
    strip_velocity(&mut rec);
    let dir = std::env::temp_dir().join(format!("rins-posonly-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    rec.write(&dir).unwrap();
    let text = std::fs::read_to_string(dir.join("gnss.csv")).unwrap();
    assert!(text.starts_with("t_s,lat_deg,lon_deg,height_m,sigma_h_m,sigma_v_m\n"));
    let back = Recording::read(&dir).unwrap();
    let run = aided::navigate(&back, &opts(&p), &mut |_| {}).unwrap();
    let without = aided::summary(&back, &run);
    println!(
        "rms while fixes come: with velocity {:?} m, position-only {:?} m; outage end {:?} / {:?}",
        with.h_rms_with_gnss_m,
        without.h_rms_with_gnss_m,
        with.outages.first().and_then(|o| o.end_error_m),
        without.outages.first().and_then(|o| o.end_error_m)
    );
    assert_eq!(run.reinits, 0);
    let rms = without.h_rms_with_gnss_m.unwrap();
    assert!(rms < 1.5 * 2f64.sqrt(), "{rms} m");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_known_clock_offset_is_recovered_from_the_fixes() {
    // Our simulator only: a city drive whose fixes are stamped 0.1 s
    // early on the IMU's clock (the IMU 0.1 s late); the pre-pass must
    // find +0.1 s within its own 3 sigma and a sample period.
    let p = ImuSpec::nav440();
    let mut rec = city_drive(&p, true, 6, &outages::OUTAGES, 120.0);
    for f in rec.moving.as_mut().unwrap().gnss.as_mut().unwrap() {
        f.t_s -= 0.1;
    }
    let e = aided::offset::estimate(&rec, &opts(&p), 0.2, 0.02, &mut |_| {}).unwrap();
    println!("offset {:+.4} s +- {:.4} s", e.offset_s, e.sigma_s);
    assert!(
        (e.offset_s - 0.1).abs() < (3.0 * e.sigma_s).max(0.01),
        "{e:?}"
    );
}

#[test]
fn nees_over_position_velocity_and_attitude_is_honest_on_both_sensors_and_schemes() {
    // Our simulator only. NEES over north, east, the three velocities and
    // the attitude's three angles, once a second, mean over 4 city drives
    // per sensor and scheme: within [0.5, 2] per degree of freedom and at
    // least 82 % of the seconds inside their 95 % bounds. The issue's
    // bound is 90 % over many drives: over 12 drives (the simulator's
    // present random streams) nav440 95 % still and 94 % spinning, the
    // ICM-42688-P 89 % still and 91 % spinning. One drive's share spreads
    // by 9 % (0.70 to 0.99), so a 4-drive mean by 4.5 %: 82 % is 2 of
    // those under the worst 12-drive mean. (The still ICM-42688-P's 89 %
    // is under the issue's 90 %: its NEES is low, 0.66, yet some drives
    // spend long stretches outside, a filter finding left open.)
    let study = outages::run(
        DriveKind::City,
        &[ImuSpec::nav440(), ImuSpec::icm42688()],
        1,
        4,
        rins::shard::Shard::ALL,
        &|_| {},
    )
    .unwrap();
    for imu in ["nav440", "icm42688"] {
        for rotary in [false, true] {
            let rs: Vec<_> = study
                .runs
                .iter()
                .filter(|r| r.imu == imu && r.rotary == rotary)
                .collect();
            let n = rs.len() as f64;
            let nees = rs.iter().map(|r| r.nees_per_dof).sum::<f64>() / n;
            let inb = rs.iter().map(|r| r.nees_in_95).sum::<f64>() / n;
            println!(
                "{imu} rotary {rotary}: NEES {nees:.2} per dof, {:.0} % inside",
                100.0 * inb
            );
            assert!((0.5..=2.0).contains(&nees), "{imu} {rotary}: {nees}");
            assert!(inb >= 0.82, "{imu} {rotary}: {inb}");
        }
    }
}

#[test]
fn a_lever_arm_the_filter_is_not_told_is_found_from_the_fixes() {
    // Our simulator only: city drives with an RTK-grade receiver (2 cm)
    // whose antenna sits 1 m ahead of and 0.8 m above the base; each
    // recording says 0.4 m ahead, 0.3 m to the left and level. Over six
    // drives the pre-pass must find each horizontal component within 3.5
    // of its own sigmas, with the errors' rms within 2 sigmas (measured:
    // x 1.2, y 1.7: the sigma of y is optimistic by about half, y's
    // errors lean left by 2.8 cm on average), and the vertical one
    // resolved or said to be unresolved (a car barely rolls).
    let p = ImuSpec::nav440();
    let truth = [1.0, 0.0, -0.8];
    let found: Vec<aided::lever::LeverEstimate> = std::thread::scope(|s| {
        let runs: Vec<_> = (3..=8)
            .map(|seed| {
                let p = &p;
                s.spawn(move || {
                    let mut c = outages::config(DriveKind::City, p, true, seed);
                    c.duration_s = 120.0;
                    let d = c.drive.as_mut().unwrap();
                    (d.gnss.sigma_h_m, d.gnss.sigma_v_m) = (0.02, 0.04);
                    assert_eq!(d.gnss.antenna_b_m, nalgebra::Vector3::from(truth));
                    let mut rec = simulate(&c, &mut |_| {}).unwrap();
                    let m = rec.moving.as_mut().unwrap().gnss_meta.as_mut().unwrap();
                    m.antenna_b_m = [0.4, -0.3, 0.0];
                    aided::lever::estimate(&rec, &opts(p), &mut |_| {}).unwrap()
                })
            })
            .collect();
        runs.into_iter().map(|r| r.join().unwrap()).collect()
    });
    for (i, want) in truth.iter().enumerate() {
        let z: Vec<f64> = found
            .iter()
            .filter_map(|e| e.sigma_m[i].map(|s| (e.b_m[i] - want) / s))
            .collect();
        println!("axis {i}: normalised errors {z:.2?}");
        if i == 2 && z.is_empty() {
            assert!(found.iter().all(|e| e.b_m[2] == 0.0));
            continue;
        }
        assert_eq!(
            z.len(),
            found.len(),
            "axis {i} unresolved somewhere: {found:?}"
        );
        let rms = (z.iter().map(|x| x * x).sum::<f64>() / z.len() as f64).sqrt();
        assert!(
            z.iter().all(|x| x.abs() < 3.5) && rms < 2.0,
            "axis {i}: {z:?}"
        );
    }
    assert!(found.iter().all(|e| e.nis_per_dof[1] < e.nis_per_dof[0]));
}

#[test]
fn a_lever_arm_beyond_the_first_search_is_followed_out_and_one_too_far_refused() {
    // Our simulator only, one city drive as above (antenna 1 m ahead,
    // 0.8 m up, 2 cm fixes). Told 1.6 m behind it (x = -0.6 m), the first
    // search (+-1 m) finds its least at an edge and follows the NIS out:
    // x within 3.5 of its sigmas, as above. Told 4.5 m behind (x = -3.5
    // m), it still falls 3 m out: refused, saying so.
    let p = ImuSpec::nav440();
    let mut c = outages::config(DriveKind::City, &p, true, 3);
    c.duration_s = 120.0;
    let d = c.drive.as_mut().unwrap();
    (d.gnss.sigma_h_m, d.gnss.sigma_v_m) = (0.02, 0.04);
    let rec = simulate(&c, &mut |_| {}).unwrap();
    let told = |x: f64| {
        let mut r = rec.clone();
        let m = r.moving.as_mut().unwrap().gnss_meta.as_mut().unwrap();
        m.antenna_b_m = [x, 0.0, -0.8];
        r
    };
    let (near, far) = (told(-0.6), told(-3.5));
    let (found, refused) = std::thread::scope(|s| {
        let a = s.spawn(|| aided::lever::estimate(&near, &opts(&p), &mut |_| {}));
        let b = s.spawn(|| aided::lever::estimate(&far, &opts(&p), &mut |_| {}));
        (a.join().unwrap(), b.join().unwrap())
    });
    let found = found.unwrap();
    let sigma = found.sigma_m[0].unwrap();
    assert!((found.b_m[0] - 1.0).abs() < 3.5 * sigma, "{found:?}");
    let e = refused.unwrap_err().to_string();
    assert!(e.contains("along x") && e.contains("+-3 m"), "{e}");
}

#[test]
fn the_sigma_columns_nees_is_what_a_user_recomputes_from_trajectory_csv() {
    // The summary's 9-dof diagonal NEES, recomputed as a user would: the
    // trajectory.csv text, the truth rows once a second, the nine errors
    // over their sigma columns, and the chi-square(9) 95 % bounds from a
    // table (2.700, 19.023), not the summary's Wilson-Hilferty ones. Their
    // shares agree to two seconds in the run's (the bounds differ in the
    // third digit).
    let p = ImuSpec::nav440();
    let rec = city_drive(&p, true, 2, &outages::OUTAGES, 200.0);
    let run = aided::navigate(&rec, &opts(&p), &mut |_| {}).unwrap();
    let s = aided::summary(&rec, &run);
    let text = aided::trajectory_csv(&run.rows);
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let truth = rec.moving.as_ref().unwrap().truth.as_deref().unwrap();
    let (mut n, mut inside) = (0usize, 0usize);
    for line in lines {
        let v: Vec<f64> = line
            .split(',')
            .map(|x| x.parse().unwrap_or(f64::NAN))
            .collect();
        let t = v[col("t_s")];
        if (t - t.round()).abs() > 1e-6 {
            continue;
        }
        let Some(tr) = truth.iter().find(|r| (r.t_s - t).abs() < 1e-6) else {
            continue;
        };
        let mut q = 0.0;
        for (i, axis) in ["north_m", "east_m", "down_m"].iter().enumerate() {
            q += ((tr.p_n_m[i] - v[col(axis)]) / v[col(&format!("sigma_{axis}"))]).powi(2);
        }
        for (i, axis) in ["vn_mps", "ve_mps", "vd_mps"].iter().enumerate() {
            q += ((tr.v_n_mps[i] - v[col(axis)]) / v[col(&format!("sigma_{axis}"))]).powi(2);
        }
        for (i, axis) in ["roll_deg", "pitch_deg", "heading_deg"].iter().enumerate() {
            let d = (tr.euler_deg[i] - v[col(axis)] + 540.0) % 360.0 - 180.0;
            q += (d / v[col(&format!("sigma_{axis}"))]).powi(2);
        }
        n += 1;
        inside += usize::from((2.700..=19.023).contains(&q));
    }
    let mine = inside as f64 / n as f64;
    let theirs = s.nees_diag_in_95.unwrap();
    println!("{n} seconds: recomputed {mine:.3}, summary {theirs:.3}");
    assert!(
        n > 150 && (mine - theirs).abs() <= 2.0 / n as f64,
        "{mine} {theirs}"
    );
}

#[test]
fn a_metre_receiver_leaves_an_axis_unresolved_not_an_error() {
    // Our simulator only: hal-sim's automotive receiver (1.5 m, half of it
    // a minute-long drift) on a 300 s city drive told the right arm. The
    // car barely rolls or pitches: the vertical arm's NIS is flat, its
    // least at an edge of the search by chance; that is not an arm beyond
    // the span (an error), but an axis the motion does not resolve, kept
    // as given and said so. The horizontal ones within 3 sigma of the truth
    // (measured on three drives: within 2.2 sigma, y 0.3-0.45 m right).
    let p = ImuSpec::nav440();
    let rec = city_drive(&p, true, 1, &outages::OUTAGES, 300.0);
    let e = aided::lever::estimate(&rec, &opts(&p), &mut |_| {}).unwrap();
    println!("{e:?}");
    assert_eq!((e.sigma_m[2], e.b_m[2]), (None, -0.8), "{e:?}");
    for (i, want) in [1.0, 0.0].iter().enumerate() {
        let s = e.sigma_m[i].unwrap();
        assert!((e.b_m[i] - want).abs() < 3.0 * s, "{i}: {e:?}");
    }
}

#[test]
fn a_smooth_pull_away_from_a_stop_is_not_called_still() {
    // Seed 5's city drive pulls away from its first stop at 15 s with a
    // steady 1.7 m/s^2 and little vibration: the detector's spread test
    // called 15.1-15.25 s still at 1.2-1.5 m/s, and the zero-rotation and
    // zero-velocity updates then made put a 3 cm/s vertical velocity error
    // under a 2 mm/s sigma. The filter's own velocity refutes such a
    // window. Every row the navigator calls still is one whose true speed
    // is under 5 cm/s (a parked car's: zero in hal-sim; the bound is the
    // speed a 0.5 s window can reach from rest at 0.1 m/s^2).
    let p = ImuSpec::icm42688();
    let rec = city_drive(&p, true, 5, &[], 40.0);
    let run = aided::navigate(&rec, &opts(&p), &mut |_| {}).unwrap();
    let truth = rec.moving.as_ref().unwrap().truth.as_deref().unwrap();
    let mut still = 0;
    for r in run.rows.iter().filter(|r| r.still) {
        let Some(tr) = recording::moving::truth_at(truth, r.traj.t_s) else {
            continue;
        };
        let speed = tr.v_n_mps.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!(
            speed < 0.05,
            "still at {:.2} s at {speed:.2} m/s",
            r.traj.t_s
        );
        still += 1;
    }
    // Since the zero-rotation window keeps the gyros as read, the
    // detector's threshold, learnt from the start's spreads, is no longer
    // raised by the bias estimate moving inside its windows, and it calls
    // this pull-away moving itself: no window is left for the velocity to
    // refute (the refutation's own test: core-nav's
    // `a_still_window_the_filter_s_velocity_refutes_is_not_still`).
    println!("{still} still rows, {} refuted", run.still_refuted);
    assert!(still > 500);
}

#[test]
fn an_outage_free_drive_re_initialises_nowhere_and_blames_no_outage() {
    // The issue's null for re-initialisation: city drives with every fix
    // delivered, both sensors (our simulator only). Nothing re-initialises,
    // the summary names no outage and no re-initialisation, and the NIS
    // is measured (fixes were used).
    for (p, seed) in [(ImuSpec::nav440(), 11), (ImuSpec::icm42688(), 12)] {
        let rec = city_drive(&p, true, seed, &[], 150.0);
        let run = aided::navigate(&rec, &opts(&p), &mut |_| {}).unwrap();
        let s = aided::summary(&rec, &run);
        let text = s.text();
        print!("{text}");
        assert_eq!(run.reinits, 0, "{}: {text}", p.name);
        assert!(s.reinit_at.is_empty() && s.outages.is_empty(), "{text}");
        assert!(!text.contains("re-initialised at"), "{text}");
        assert!(s.nis_mean_per_dof.is_some(), "{text}");
    }
}

#[test]
fn fast_fixes_waiting_out_the_horizon_are_not_counted_twice() {
    // The board applies a fix 400 ms after its time of validity; a 10 Hz
    // receiver has four more fixes used in that time. Each fix is compared
    // with the state stored for its time of validity, which must carry the
    // corrections fed back since, or those are taken again (a filter that
    // follows RTK-grade fixes takes nearly all of each). The same 300 s
    // city drive with 10 Hz fixes of 2 cm: the track's RMS error within
    // 10 % or 5 cm of the on-time fixes', at most the one
    // re-initialisation of the outage's end. Measured: 0.061 m against
    // 0.040 m on time (the host: 0.015 m); without the corrections since,
    // 61.8 m and 400 re-initialisations (the check that this test can
    // fail). Before the board sized its receiver from its fixes
    // (`AidedConfig::receiver_from_fixes`) both were 0.28-0.37 m: a
    // correlated error sized for its 1.5 m receiver kept 0.4-0.5 m of the
    // outage's error for the rest of the drive. Not understood: the late
    // fixes' run refutes 1,900 still windows by its velocity, on time 40.
    let p = ImuSpec::icm42688();
    let outage = (120.0, 60.0);
    let mut c = outages::config_with(DriveKind::City, &p, true, 5, &[outage]);
    c.duration_s = 300.0;
    let gnss = &mut c.drive.as_mut().unwrap().gnss;
    (gnss.rate_hz, gnss.sigma_h_m, gnss.sigma_v_m) = (10.0, 0.02, 0.04);
    let rec = simulate(&c, &mut |_| {}).unwrap();
    let bytes = rins::qemu_replay::build(&rec, 16_384).unwrap().bytes;
    let on_time = TwinOptions {
        latency_us: Some(0),
        horizon_us: Some(0),
        ..TwinOptions::default()
    };
    let e0 = track_rms(&twin::run(&bytes, on_time), &rec, outage);
    // The receiver sized from its fixes: 0.37 m with its 1.5 m sizing.
    assert!(e0 < 0.1, "{e0}");
    for latency in [150_000, 300_000] {
        let late = TwinOptions {
            latency_us: Some(latency),
            ..TwinOptions::default()
        };
        let r = twin::run(&bytes, late);
        let e = track_rms(&r, &rec, outage);
        let counts = r.board.program.nav.nav.aided().unwrap().counts;
        println!(
            "latency {} ms: track RMS {e:.3} m (on time {e0:.3} m), fixes used {}, re-initialisations {}",
            latency / 1000,
            counts.fixes_used,
            counts.reinits
        );
        // The outage's end: 2.6 m off against 2 cm fixes, one
        // re-initialisation (on time the gate took them).
        assert!(counts.reinits <= 1, "{counts:?}");
        assert!(counts.fixes_used > 2000);
        assert!(e < e0 * 1.1 + 0.05, "{e} vs {e0}");
    }
}

#[test]
fn a_car_s_still_start_finds_its_gyro_bias_and_keeps_its_heading() {
    // Our simulator: the held-back drive's setting (the ICM-42688-P upside
    // down and yawed 185 deg in a car, RTK-grade fixes at 5 Hz) at the
    // start of a city drive, parked for its first 12 s. The fixes move the
    // gyro bias estimate while the detector's window fills; a window's
    // mean corrected sample by sample mixed those estimates, and the
    // first zero-rotation update took the vertical bias 2.7e-3 rad/s off
    // (10 of its sigmas), its heading 0.6 deg off under a 0.1 deg sigma,
    // and the gate refused every later one: the heading drifted 0.13
    // deg/s while parked. The oracle is closed form: a parked gyro reads
    // its bias and the earth's rate, so the bias is the still span's mean
    // reading less the earth's rate through the true attitude.
    let p = ImuSpec::icm42688();
    let mut c = outages::config_mounted(DriveKind::City, &p, false, 7, &[], [180.0, 0.0, 185.0]);
    c.duration_s = 30.0;
    let d = c.drive.as_mut().unwrap();
    (d.gnss.sigma_h_m, d.gnss.sigma_v_m, d.gnss.rate_hz) = (0.02, 0.04, 5.0);
    let rec = simulate(&c, &mut |_| {}).unwrap();
    let truth = rec.moving.as_ref().unwrap().truth.as_deref().unwrap();
    let parked = truth
        .iter()
        .find(|r| r.v_n_mps.iter().map(|v| v * v).sum::<f64>() > 1e-6)
        .unwrap()
        .t_s;
    assert!(parked > 8.0, "parked {parked} s");
    let run = aided::navigate(&rec, &opts(&p), &mut |_| {}).unwrap();
    // The detector learns its threshold over its first 3.5 s: from 4 s on
    // every second's heading within 3 of its sigmas.
    for r in run
        .rows
        .iter()
        .filter(|r| r.traj.t_s >= 4.0 && r.traj.t_s < parked)
    {
        let tr = recording::moving::truth_at(truth, r.traj.t_s).unwrap();
        let e = (r.traj.rph_deg[2] - tr.euler_deg[2] + 540.0) % 360.0 - 180.0;
        assert!(
            e.abs() < 3.0 * r.sigma_att_deg[2],
            "heading at {:.2} s: {e:.3} deg, sigma {:.3}",
            r.traj.t_s,
            r.sigma_att_deg[2]
        );
    }
    // The closed form: the mean reading over 4 s to the end of the stop
    // less the earth's rate in b (here s).
    let span = rec.imu.iter().filter(|r| r.t_s >= 4.0 && r.t_s < parked);
    let (sum, n) = span.fold((Vector3::zeros(), 0.0), |(s, n), r| {
        (s + Vector3::from(r.gyro_radps), n + 1.0)
    });
    let e = truth[0].euler_deg.map(f64::to_radians);
    let c_b_n = Rotation3::from_euler_angles(e[0], e[1], e[2]);
    let lat = rec.meta.latitude_deg.to_radians();
    let w_ie_n = Vector3::new(lat.cos(), 0.0, -lat.sin()) * 7.292_115e-5;
    let want = sum / n - c_b_n.inverse() * w_ie_n;
    let end = run.rows.iter().rfind(|r| r.traj.t_s < parked).unwrap();
    let got = Vector3::from(end.gyro_bias_radps);
    println!("bias at {parked:.1} s: {got:?}, closed form {want:?}");
    // 3e-4 rad/s: twice the zero-rotation update's 1-sigma (its 1e-4
    // floor with the window mean's white noise, 9e-5); the closed form's
    // own noise over 8 s is 2e-5.
    assert!((got - want).norm() < 3e-4, "{got:?} against {want:?}");
}

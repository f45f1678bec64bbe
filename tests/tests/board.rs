//! The board's parts that QEMU 7.2 does not model, behind their traits on
//! the host: the flash journal under power cuts at every step, the
//! watchdog's progress rule over the whole program, and the compiled-in
//! filter tuning against the sensor profile it comes from.

use firmware::record::{Flash, Journal};
use protocol::record::{BoardConfig, StoredCalibration};
use protocol::SchemeKind;
use rins_tests::board::{HostBoard, NorFlash, JOURNAL};

fn cfg(i: u32) -> BoardConfig {
    BoardConfig {
        lat_e7: -339_000_000 + i as i32,
        height_mm: 20_000,
        base_deg: [0.0, 0.0, i as f32],
        scheme: SchemeKind::Continuous,
        rate_dps: 30.0,
        count: 0,
        aided: i % 2 == 1,
        lon_e7: 184_000_000,
    }
}

fn cal(i: u32) -> Option<StoredCalibration> {
    Some(StoredCalibration {
        bias_radps: [1e-3 * i as f32, 0.0, -1e-4],
        m_k: [1e-3, 2e-3, i as f32 * 1e-4],
    })
}

/// Writes records 0..n through the journal, each programmed word by word
/// as the link task does, booting (`open`) between them; returns the
/// flash operation at which each record's last word went in.
fn write_all(f: &mut NorFlash, n: u32) -> Result<Vec<usize>, firmware::record::FlashError> {
    let mut commits = vec![];
    for i in 0..n {
        let mut j = Journal::open(f, JOURNAL)?;
        j.write(cfg(i), cal(i))?;
        while j.step(f)? {}
        commits.push(f.ops - 1);
    }
    Ok(commits)
}

#[test]
fn a_power_cut_at_any_step_leaves_the_old_record_or_the_new_one() {
    // Enough records to fill a 2 KiB sector (28 slots) twice: the boot's
    // moves to the other sector, with their erases, are cut too.
    const N: u32 = 70;
    let mut whole = NorFlash::new(4096);
    let commits = write_all(&mut whole, N).unwrap();
    let total_ops = whole.ops;
    println!("{N} records: {total_ops} flash operations (words and erases)");
    let mut seen_erase_cuts = 0;
    for cut in 0..total_ops {
        let mut f = NorFlash::new(4096);
        f.cut_after = Some(cut);
        let _ = write_all(&mut f, N);
        // Power back: every operation completes again.
        f.cut_after = None;
        let j = Journal::open(&mut f, JOURNAL).expect("the journal opens after a cut");
        // Before the first record's last word there is no record yet.
        let Some(got) = j.current else {
            assert!(
                cut < firmware::record::SLOT_WORDS,
                "no record after a cut at {cut}"
            );
            continue;
        };
        // The last record whose last word went in before the cut: the old
        // one, or the new one if the cut came after its commit.
        let k = commits.iter().filter(|c| **c < cut).count() as u32 - 1;
        assert_eq!(got.config, cfg(k), "cut at {cut}");
        assert_eq!(got.calibration, cal(k));
        if j.erases > 0 {
            seen_erase_cuts += 1;
        }
        // And the journal writes on from there.
        let mut j = j;
        j.write(cfg(N), cal(N)).unwrap();
        while j.step(&mut f).unwrap() {}
        assert_eq!(
            Journal::open(&mut f, JOURNAL)
                .unwrap()
                .current
                .unwrap()
                .config,
            cfg(N)
        );
    }
    assert!(seen_erase_cuts > 0, "some cuts fell in a boot's move");
}

#[test]
fn erases_happen_only_at_boot() {
    // The program erases nothing while it runs: a flash that refuses
    // erases after boot sees none while 200 records are written.
    struct NoErase(NorFlash, bool);
    impl Flash for NoErase {
        fn read(&mut self, a: u32, b: &mut [u8]) -> Result<(), firmware::record::FlashError> {
            self.0.read(a, b)
        }
        fn program_word(&mut self, a: u32, w: u32) -> Result<(), firmware::record::FlashError> {
            self.0.program_word(a, w)
        }
        fn erase(
            &mut self,
            s: firmware::record::Sector,
        ) -> Result<(), firmware::record::FlashError> {
            assert!(!self.1, "an erase at run time");
            self.0.erase(s)
        }
    }
    let mut f = NoErase(NorFlash::new(4096), false);
    let mut j = Journal::open(&mut f, JOURNAL).unwrap();
    f.1 = true;
    let mut full = 0;
    for i in 0..200 {
        match j.write(cfg(i), cal(i)) {
            Ok(()) => while j.step(&mut f).unwrap() {},
            Err(firmware::record::FlashError::Full) => full += 1,
            Err(e) => panic!("{e:?}"),
        }
    }
    // A 2 KiB sector holds 28 records: the rest wait for the next boot
    // (refused and reported, never an erase under the watchdog).
    assert_eq!(full, 200 - 28);
    f.1 = false;
    let j = Journal::open(&mut f, JOURNAL).unwrap();
    assert_eq!(j.current.unwrap().config, cfg(27));
    assert!(j.erases > 0);
}

#[test]
fn the_watchdog_is_fed_only_while_every_task_makes_progress() {
    let t = firmware::tuning::board();
    let mut b = HostBoard::new(t, NorFlash::new(4096), 0, Ok(()));
    // No IMU sample yet: no tick, no navigation: not fed (the board resets
    // if its IMU never starts after a good init).
    b.idle(300_000);
    assert_eq!(b.wdg.feeds, 0);
    // A board whose IMU failed at init: the link alone keeps it fed.
    let mut s = HostBoard::new(
        t,
        NorFlash::new(4096),
        0,
        Err(firmware::faults::Fault::ImuInitFailed),
    );
    s.idle(300_000);
    assert!(s.wdg.feeds >= 25, "{}", s.wdg.feeds);
}

#[test]
fn the_boards_filter_is_the_icm42688_profiles() {
    // firmware::tuning writes the numbers rins derives from hal-sim's
    // icm42688 profile (the board cannot depend on the host's crates).
    let o = rins::aided::AidedOptions {
        profile: hal_sim::imu::ImuSpec::icm42688(),
        zupt: true,
        gate_sigma: 6.0,
        f32: true,
        outages: vec![],
        floor: Default::default(),
        gnss_velocity: true,
        time_offset_s: 0.0,
    };
    let enc = core_nav::table::EncoderScale::new(
        firmware::control::ControlConfig::default().counts_per_rev,
    );
    let want = rins::aided::aided_config(
        core_nav::table::Axis::Z,
        [0.0; 3],
        &o,
        100.0,
        enc.read_sigma_rad(),
    );
    assert_eq!(firmware::tuning::ICM42688_FILTER, want);
}

/// The faults the board sent (decoded from its bytes).
fn faults_sent(bytes: &[u8]) -> Vec<(protocol::Fault, u32)> {
    let mut d = protocol::Decoder::default();
    let mut out = [0u8; protocol::MAX_PAYLOAD + 2];
    let mut got = vec![];
    for b in bytes {
        if let Some(n) = d.push(*b, &mut out) {
            if let Ok((_, protocol::Telemetry::Fault { fault, count, .. })) =
                protocol::Telemetry::decode(&out[..n])
            {
                got.push((fault, count));
            }
        }
    }
    got
}

#[test]
fn overruns_and_losses_are_reported_as_faults_at_a_bounded_rate() {
    use std::sync::atomic::Ordering::Relaxed;
    let t = firmware::tuning::board();
    let mut b = HostBoard::new(t, NorFlash::new(4096), 0, Ok(()));
    b.idle(20_000);
    assert!(faults_sent(&b.sent).is_empty());
    // Three tick overruns and a lost byte: reported at the next link run,
    // with their totals.
    b.stats.tick_overruns.fetch_add(3, Relaxed);
    b.stats.rx_lost.fetch_add(1, Relaxed);
    b.idle(20_000);
    let f = faults_sent(&b.sent);
    assert!(f.contains(&(protocol::Fault::TickOverrun, 3)), "{f:?}");
    assert!(f.contains(&(protocol::Fault::RxLost, 1)), "{f:?}");
    // More overruns every 10 ms for half a second: no new report within a
    // second of the last; then one, with the total.
    for _ in 0..50 {
        b.stats.tick_overruns.fetch_add(1, Relaxed);
        b.idle(10_000);
    }
    assert_eq!(faults_sent(&b.sent).len(), 2);
    b.idle(600_000);
    let f = faults_sent(&b.sent);
    assert_eq!(f.len(), 3);
    assert_eq!(f[2], (protocol::Fault::TickOverrun, 53));
}

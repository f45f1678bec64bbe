//! The board's parts that QEMU 7.2 does not model, behind their traits on
//! the host: the flash journal under power cuts at every step, the
//! watchdog's progress rule over the whole program, resets in a row and
//! the safe mode they end in, a HardFault's registers after the reset, and
//! the compiled-in filter tuning against the sensor profile it comes from.

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
        f32: true,
        ..rins::aided::AidedOptions::new(hal_sim::imu::ImuSpec::icm42688())
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
    // Its sensors not powered yet (as the QEMU harness does): no IMU
    // timeout among the faults counted here.
    b.program.link.sensors_later();
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

/// A board on blank flash with its IMU answering but its sensors not yet
/// powered (as the QEMU harness boots): no IMU timeout among what a test
/// counts.
fn unpowered() -> HostBoard {
    let b = HostBoard::new(firmware::tuning::board(), NorFlash::new(4096), 0, Ok(()));
    b.program.link.sensors_later();
    b
}

/// Every frame the board sent, decoded.
fn telemetry_sent(bytes: &[u8]) -> Vec<protocol::Telemetry> {
    let mut d = protocol::Decoder::default();
    let mut out = [0u8; protocol::MAX_PAYLOAD + 2];
    let mut got = vec![];
    for b in bytes {
        if let Some(n) = d.push(*b, &mut out) {
            if let Ok((_, t)) = protocol::Telemetry::decode(&out[..n]) {
                got.push(t);
            }
        }
    }
    got
}

/// The IWDG's shortest period: 100 ms at the LSI's typical 32 kHz is
/// 100 * 32 / 47 ms at its 47 kHz worst (STM32F405 datasheet, LSI
/// 17-47 kHz), µs.
const IWDG_SHORTEST_US: u64 = 100_000 * 32 / 47;

/// Runs a booted board with its IMU silent for up to `span_us`, the
/// watchdog at its shortest period: `Some(t)` when it would reset at `t`.
fn until_watchdog(b: &mut HostBoard, span_us: u64) -> Option<u64> {
    let mut fed_at = b.mcu_us;
    let mut feeds = b.wdg.feeds;
    while b.mcu_us < span_us {
        b.idle(1_000);
        if b.wdg.feeds != feeds {
            (feeds, fed_at) = (b.wdg.feeds, b.mcu_us);
        }
        if b.mcu_us - fed_at > IWDG_SHORTEST_US {
            return Some(b.mcu_us);
        }
    }
    None
}

#[test]
fn a_dead_data_ready_line_ends_in_safe_mode_not_a_reset_loop() {
    use firmware::resets::{ResetLog, SAFE_AFTER};
    use protocol::{Fault, ResetCause, Telemetry};
    let t = firmware::tuning::board();
    // The IMU answers at init (WHO_AM_I) but its data-ready line is dead.
    let mut log = ResetLog::default();
    let mut verdict = log.boot(ResetCause::PowerOn);
    let mut resets = 0;
    let board = loop {
        let mut b = HostBoard::boot(t, NorFlash::new(4096), 0, Ok(()), verdict);
        match until_watchdog(&mut b, 2_000_000) {
            Some(at) => {
                // The fault is told and the motor off before the reset.
                let f = faults_sent(&b.sent);
                assert!(
                    f.iter().any(|x| x.0 == Fault::ImuTimeout),
                    "{f:?} before the reset at {at} us"
                );
                assert!(b.motor_off);
                resets += 1;
                assert!(resets <= SAFE_AFTER, "a reset loop");
                verdict = log.boot(ResetCause::IndependentWatchdog);
            }
            None => break b,
        }
    };
    assert_eq!(resets, SAFE_AFTER);
    let sent = telemetry_sent(&board.sent);
    assert!(
        sent.iter().any(|x| matches!(x, Telemetry::Boot { reset: ResetCause::IndependentWatchdog, resets_in_row, safe_mode: 1, .. } if *resets_in_row == SAFE_AFTER)),
        "{sent:?}"
    );
    assert!(faults_sent(&board.sent).contains(&(Fault::ResetLoop, SAFE_AFTER)));
    assert!(!board.program.link.sensors());
    // Safe mode holds: the link alone keeps it fed for a minute.
    let mut b = board;
    assert_eq!(until_watchdog(&mut b, 60_000_000), None);
}

/// A still IMU with a little noise (so no "stuck" sensor), a still table.
struct StillSensors(u32);
impl firmware::tasks::Imu for StillSensors {
    fn read(&mut self) -> firmware::tasks::Reading {
        self.0 = self.0.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        let n = ((self.0 >> 16) as f32 / 65_536.0 - 0.5) * 1e-3;
        let s = firmware::icm42688::Sample {
            gyro_radps: [n, -n, 0.5 * n],
            accel_mps2: [n, 0.5 * n, -9.806_65 + n],
            temp_c: 25.0,
        };
        let lsb = (self.0 >> 28) as i16;
        let raw = firmware::icm42688::RawSample {
            temp_lsb: 0,
            accel_lsb: [lsb, -lsb, -2048 + lsb],
            gyro_lsb: [lsb, lsb, -lsb],
        };
        Ok(Some((raw, s)))
    }
}
impl firmware::tasks::Encoder for StillSensors {
    fn count(&mut self) -> u16 {
        0
    }
}
impl firmware::tasks::Motor for StillSensors {
    fn set(&mut self, _: f32) {}
}

#[test]
fn a_healthy_run_after_resets_ends_the_row() {
    use firmware::resets::{ResetLog, HEALTHY_AFTER_US};
    use protocol::ResetCause;
    let t = firmware::tuning::board();
    let mut log = ResetLog::default();
    log.boot(ResetCause::PowerOn);
    log.boot(ResetCause::IndependentWatchdog);
    let verdict = log.boot(ResetCause::IndependentWatchdog);
    assert_eq!(verdict.in_row, 2);
    // Every task making progress: healthy once the span has passed, and
    // not before.
    let mut b = HostBoard::boot(t, NorFlash::new(4096), 0, Ok(()), verdict);
    let (mut imu, mut enc, mut motor) = (StillSensors(1), StillSensors(0), StillSensors(0));
    let mut healthy_at = None;
    for k in 1..=(HEALTHY_AFTER_US / 1_000 + 100) {
        b.edge(k * 1_000, &mut imu, &mut enc, &mut motor);
        if b.healthy && healthy_at.is_none() {
            healthy_at = Some(k * 1_000);
        }
    }
    let at = healthy_at.unwrap_or_else(|| {
        panic!(
            "not healthy: {} feeds, {:?}",
            b.wdg.feeds,
            faults_sent(&b.sent)
        )
    });
    assert!(
        (HEALTHY_AFTER_US..HEALTHY_AFTER_US + 20_000).contains(&at),
        "{at}"
    );
    log.healthy();
    assert_eq!(log.boot(ResetCause::IndependentWatchdog).in_row, 1);
    // A board without its IMU is never healthy: its row stands.
    let mut s = HostBoard::boot(
        t,
        NorFlash::new(4096),
        0,
        Err(protocol::Fault::ImuInitFailed),
        verdict,
    );
    s.idle(HEALTHY_AFTER_US + 20_000);
    assert!(!s.healthy);
}

#[test]
fn a_hard_faults_registers_are_reported_after_the_reset() {
    use firmware::resets::{FaultRegs, ResetLog};
    use protocol::{Fault, ResetCause, Telemetry};
    let t = firmware::tuning::board();
    let mut log = ResetLog::default();
    log.boot(ResetCause::PowerOn);
    // What the handler stores (a precise bus fault at BFAR, its PC).
    let regs = FaultRegs {
        cfsr: 0x0000_8200,
        hfsr: 0x4000_0000,
        mmfar: 0xE000_EDF4,
        bfar: 0x4001_3C00,
        pc: 0x0800_2F1A,
        lr: 0x0800_2E07,
    };
    log.hard_fault(regs);
    let verdict = log.boot(ResetCause::Software);
    let mut b = HostBoard::boot(t, NorFlash::new(4096), 0, Ok(()), verdict);
    b.program.link.sensors_later();
    b.idle(20_000);
    let sent = telemetry_sent(&b.sent);
    assert!(
        sent.iter().any(|x| matches!(x, Telemetry::Boot { reset: ResetCause::Software, fault_regs, resets_in_row: 1, safe_mode: 0, .. } if *fault_regs == regs.words())),
        "{sent:?}"
    );
    assert!(faults_sent(&b.sent).contains(&(Fault::HardFault, 1)));
    // Told once: the next boot (a person's reset) has no fault.
    let v = log.boot(ResetCause::Pin);
    assert_eq!((v.fault, v.in_row), (None, 0));
}

#[test]
fn a_dead_crystal_or_pll_is_reported_and_stops_the_board() {
    use protocol::Fault;
    let t = firmware::tuning::board();
    let power_on = firmware::resets::BootVerdict {
        cause: protocol::ResetCause::PowerOn,
        ..Default::default()
    };
    // A dead crystal or an unlocked PLL: 16 MHz from HSI, stopped with the
    // link up, told once, fed.
    for why in [Fault::HseFailed, Fault::PllFailed] {
        let mut b = HostBoard::boot_clocked(t, NorFlash::new(4096), 0, Ok(()), power_on, Err(why));
        assert!(!b.program.link.sensors());
        assert_eq!(until_watchdog(&mut b, 5_000_000), None);
        let f = faults_sent(&b.sent);
        assert_eq!(f.iter().filter(|x| x.0 == why).count(), 1, "{f:?}");
        assert!(!f.iter().any(|x| x.0 == Fault::ImuTimeout), "{f:?}");
    }
    // In safe mode after a reset loop both are told.
    let looped = firmware::resets::BootVerdict {
        safe_mode: true,
        in_row: 3,
        ..power_on
    };
    let mut b = HostBoard::boot_clocked(
        t,
        NorFlash::new(4096),
        0,
        Ok(()),
        looped,
        Err(Fault::PllFailed),
    );
    b.idle(20_000);
    let f = faults_sent(&b.sent);
    assert!(
        f.contains(&(Fault::ResetLoop, 3)) && f.contains(&(Fault::PllFailed, 1)),
        "{f:?}"
    );
}

/// The acks the board sent: (seq, status).
fn acks_sent(bytes: &[u8]) -> Vec<(u16, protocol::Status)> {
    telemetry_sent(bytes)
        .into_iter()
        .filter_map(|t| match t {
            protocol::Telemetry::Ack { seq, status } => Some((seq, status)),
            _ => None,
        })
        .collect()
}

fn site(i: u32) -> protocol::Command {
    protocol::Command::SetSite {
        lat_e7: 100_000 * i as i32,
        height_mm: 1_000,
    }
}

#[test]
fn a_configuration_is_acknowledged_once_stored_and_a_full_journal_says_not_stored() {
    use protocol::Status;
    let mut b = unpowered();
    let slots = b.program.link.journal.free_slots();
    // One at a time, as `rins command` sends them: no ack until the record
    // is programmed (18 words, one a link run), then Accepted.
    for i in 0..slots {
        b.command(&site(i));
        b.idle(20_000);
        let n = acks_sent(&b.sent).len();
        assert_eq!(n as u32, i, "acknowledged before it was stored");
        b.idle(300_000);
        assert_eq!(
            acks_sent(&b.sent).last(),
            Some(&(i as u16, Status::Accepted))
        );
    }
    assert_eq!(b.program.link.journal.free_slots(), 0);
    // The journal full: the change holds, and the command is told so,
    // with a flash fault.
    b.command(&site(99));
    b.idle(300_000);
    assert_eq!(
        acks_sent(&b.sent).last(),
        Some(&(slots as u16, Status::NotStored))
    );
    assert!(faults_sent(&b.sent)
        .iter()
        .any(|f| f.0 == protocol::Fault::FlashError));
    assert_eq!(b.program.link.link.config.lat_e7, 9_900_000);
}

#[test]
fn a_burst_of_configurations_is_one_record_and_every_command_is_answered() {
    use protocol::Status;
    let mut b = unpowered();
    let free = b.program.link.journal.free_slots();
    // 30 commands in one burst (well within the 1 KiB receive queue).
    for i in 0..30 {
        b.command(&site(i));
    }
    b.idle(1_000_000);
    let acks = acks_sent(&b.sent);
    assert_eq!(acks.len(), 30, "{acks:?}");
    assert!(acks.iter().all(|a| a.1 == Status::Accepted), "{acks:?}");
    let used = free - b.program.link.journal.free_slots();
    assert!(used <= 2, "{used} journal slots for one burst");
    // What is stored is the last.
    assert_eq!(
        b.program.link.journal.current.map(|r| r.config.lat_e7),
        Some(2_900_000)
    );
}

#[test]
fn corrupt_frames_and_refused_commands_are_told_as_bad_commands_with_their_count() {
    let mut b = unpowered();
    // A frame with its CRC broken, 300 bytes of no zero (oversize), and a
    // scheme faster than the table: three bad commands.
    let mut f = [0u8; protocol::MAX_FRAME];
    let n = site(1).to_frame(0, &mut f).unwrap();
    f[2] ^= 0x5A;
    b.receive(&f[..n]);
    b.receive(&[0x11; 300]);
    b.receive(&[0]);
    b.command(&protocol::Command::SetScheme {
        kind: protocol::SchemeKind::Continuous,
        rate_dps: 500.0,
        count: 0,
    });
    b.idle(30_000);
    let bad: Vec<u32> = faults_sent(&b.sent)
        .into_iter()
        .filter(|f| f.0 == protocol::Fault::BadCommand)
        .map(|f| f.1)
        .collect();
    assert_eq!(bad.last(), Some(&3), "{bad:?}");
}

#[test]
fn the_usarts_line_errors_reach_the_health_frame() {
    use std::sync::atomic::Ordering::Relaxed;
    let mut b = unpowered();
    // What the USART's error interrupt counted (`uart_rx::count_line_errors`):
    // two overruns, a framing error. Before, the health frame had no place
    // for them: they showed only as corrupt frames (BadCommand).
    b.stats.rx_line[0].fetch_add(2, Relaxed);
    b.stats.rx_line[2].fetch_add(1, Relaxed);
    b.idle(1_100_000);
    let last = telemetry_sent(&b.sent)
        .into_iter()
        .filter_map(|t| match t {
            protocol::Telemetry::Health { rx_line_errors, .. } => Some(rx_line_errors),
            _ => None,
        })
        .next_back();
    assert_eq!(last, Some([2, 0, 1]));
}

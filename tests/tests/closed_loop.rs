//! The board's program (`firmware::tasks`, the tasks the RTIC app runs)
//! in closed loop with hal-sim on the host: the real ICM-42688-P driver on
//! the chip model behind its data-ready line, the encoder counter, the
//! motor through PWM and direction pins, commands and telemetry byte by
//! byte through the UART's queues, the configuration in the flash journal.

use core_nav::strapdown::Strapdown;
use core_nav::table::QuadratureCounter;
use embedded_hal::digital::OutputPin;
use embedded_hal::pwm::SetDutyCycle;
use firmware::faults::Fault;
use firmware::icm42688::{Config, Icm42688, Sample};
use firmware::navigation::Mode;
use firmware::record::Journal;
use firmware::tasks::{Encoder, Imu, Motor, Tuning};
use hal_sim::bench::{Bench, BenchConfig, SharedBench};
use hal_sim::drivers::{SimDelay, SimDir, SimEncoder, SimPwm, SimSpi};
use hal_sim::imu::ImuSpec;
use protocol::record::BoardConfig;
use protocol::{CalStatus, Command, SchemeKind, Status, Telemetry};
use rins_tests::board::{HostBoard, NorFlash, JOURNAL};

/// The motor's pins.
struct Pins {
    pwm: SimPwm,
    dir: SimDir,
}
impl Motor for Pins {
    fn set(&mut self, duty: f32) {
        let max = self.pwm.max_duty_cycle();
        self.pwm
            .set_duty_cycle((duty.abs().min(1.0) * f32::from(max)) as u16)
            .unwrap();
        if duty >= 0.0 {
            self.dir.set_high().unwrap()
        } else {
            self.dir.set_low().unwrap()
        }
    }
}

struct Counter(SimEncoder);
impl Encoder for Counter {
    fn count(&mut self) -> u16 {
        self.0.read_count().unwrap()
    }
}

/// The IMU read on every edge whatever its data-ready says (a board that
/// polls on a timer).
struct Polled<'a>(&'a mut Icm42688<SimSpi>);
impl Imu for Polled<'_> {
    fn read(&mut self) -> firmware::tasks::Reading {
        self.0
            .read_si()
            .map(Some)
            .map_err(|_| firmware::tasks::BusError)
    }
}

/// The board's configuration as the tests set it (the bench's site).
fn config(rate_dps: f32) -> BoardConfig {
    BoardConfig {
        lat_e7: 305_300_000,
        height_mm: 20_000,
        base_deg: [0.0; 3],
        scheme: SchemeKind::Continuous,
        rate_dps,
        count: 0,
        aided: false,
        lon_e7: 0,
    }
}

/// A flash holding `cfg` (and `cal`), as a previous power-up left it.
fn flash_with(cfg: BoardConfig, cal: Option<protocol::record::StoredCalibration>) -> NorFlash {
    let mut f = NorFlash::new(4096);
    let mut j = Journal::open(&mut f, JOURNAL).unwrap();
    j.write(cfg, cal).unwrap();
    while j.step(&mut f).unwrap() {}
    f
}

/// The tuning with the calibration's durations.
fn tuning(static_s: f64, rotate_s: f64) -> Tuning {
    let mut t = firmware::tuning::board();
    t.nav.cal.static_s = static_s;
    t.nav.cal.rotate_s = rotate_s;
    t
}

struct Board {
    bench: SharedBench,
    imu: Icm42688<SimSpi>,
    pins: Pins,
    enc: Counter,
    b: HostBoard,
    t_us: u64,
    /// (t, true rate) every 10 ms, rad/s.
    rates: Vec<(u64, f64)>,
    /// The navigation inputs (t, mean) while navigating.
    consumed: Vec<(u64, Sample)>,
    nav_start: Option<(usize, Strapdown<f32>)>,
    read_imu: bool,
    ignore_drdy: bool,
    /// Every navigation input: (t, mean).
    nav_samples: Vec<(u64, Sample)>,
}

impl Board {
    fn new(spec: ImuSpec, t: Tuning, flash: NorFlash, seed: u64) -> Self {
        let mut bc = BenchConfig::new(spec);
        bc.seed = seed;
        let bench = Bench::new(bc).shared();
        let mut imu = Icm42688::new(SimSpi::new(bench.clone()));
        imu.init(Config::default(), &mut SimDelay(bench.clone()))
            .expect("IMU init");
        let t_us = bench.borrow().now_ns / 1000;
        // `init` takes its time (the journal's erases): the sensors run on
        // meanwhile, powered from reset, and the edges come from its end.
        let b = HostBoard::new(t, flash, t_us, Ok(()));
        let t_us = b.mcu_us;
        bench.borrow_mut().advance_to(t_us * 1000);
        Self {
            pins: Pins {
                pwm: SimPwm(bench.clone()),
                dir: SimDir(bench.clone()),
            },
            enc: Counter(SimEncoder(bench.clone())),
            bench,
            imu,
            b,
            t_us,
            rates: vec![],
            consumed: vec![],
            nav_start: None,
            read_imu: true,
            ignore_drdy: false,
            nav_samples: vec![],
        }
    }

    fn mode(&self) -> Mode {
        self.b.program.nav.nav.mode()
    }

    fn duty(&self) -> f32 {
        self.b.program.tick.control.duty()
    }

    fn fault_count(&self, f: Fault) -> u32 {
        self.b.program.tick.control.faults.get(f) + self.b.program.nav.nav.faults.get(f)
    }

    fn run(&mut self, seconds: f64) {
        let end = self.t_us + (seconds * 1e6) as u64;
        while self.t_us < end {
            // The IMU's ODR: a data-ready edge every 1 ms.
            self.t_us += 1_000;
            let t = self.t_us;
            self.bench.borrow_mut().advance_to(t * 1000);
            let before = self.b.program.nav.nav.last_input().map(|x| x.t_us);
            let was_nav = self.mode() == Mode::Navigating;
            if self.read_imu {
                if self.ignore_drdy {
                    let mut imu = Polled(&mut self.imu);
                    self.b.edge(t, &mut imu, &mut self.enc, &mut self.pins);
                } else {
                    self.b.edge(t, &mut self.imu, &mut self.enc, &mut self.pins);
                }
            } else {
                self.b.mcu_us = t;
                self.b.link_due();
            }
            // The link task turns the motor off when the IMU is silent (the
            // board's wiring does it under the motor's lock).
            if self.b.motor_off {
                self.pins.set(0.0);
            }
            let nav = &self.b.program.nav.nav;
            if let Some(x) = nav.last_input().filter(|x| Some(x.t_us) != before) {
                self.nav_samples.push((x.t_us, x.mean));
                if nav.mode() == Mode::Navigating {
                    if !was_nav {
                        self.nav_start = Some((self.consumed.len(), nav.nav().unwrap().clone()));
                    }
                    self.consumed.push((x.t_us, x.mean));
                }
            }
            if t.is_multiple_of(10_000) {
                let r = self.bench.borrow().table.kin.rate;
                self.rates.push((t, r));
            }
        }
    }

    /// A command, byte by byte through the UART's receive queue.
    fn command(&mut self, c: &Command) {
        self.b.command(c);
    }

    /// The telemetry the board sent, decoded.
    fn telemetry(&self) -> Vec<Telemetry> {
        let mut d = protocol::Decoder::default();
        let mut out = [0u8; protocol::MAX_PAYLOAD + 2];
        let mut v = vec![];
        for x in &self.b.sent {
            if let Some(n) = d.push(*x, &mut out) {
                if let Ok((_, t)) = Telemetry::decode(&out[..n]) {
                    v.push(t);
                }
            }
        }
        v
    }
}

fn rms_rate_error(b: &Board, from_s: f64, to_s: f64, want: f64) -> f64 {
    let v: Vec<f64> = b
        .rates
        .iter()
        .filter(|(t, _)| *t as f64 * 1e-6 >= from_s && (*t as f64 * 1e-6) < to_s)
        .map(|(_, r)| r - want)
        .collect();
    (v.iter().map(|e| e * e).sum::<f64>() / v.len() as f64).sqrt()
}

#[test]
fn ten_minutes_from_power_up_calibrate_then_navigate() {
    let rate = 30f64.to_radians();
    let mut b = Board::new(
        ImuSpec::icm42688(),
        tuning(60.0, 60.0),
        flash_with(config(30.0), None),
        3,
    );
    b.run(600.0);
    assert_eq!(
        b.mode(),
        Mode::Navigating,
        "faults {:?}",
        b.b.program.nav.nav.faults
    );
    let cal = b.b.program.nav.nav.calibration.expect("calibrated");
    // Stored in the journal (the link task programs it a word at a time).
    let stored =
        b.b.program
            .link
            .journal
            .current
            .and_then(|r| r.calibration)
            .expect("stored");
    let b32 = cal.bias.map(|x| x as f32);
    assert_eq!(stored.bias_radps, [b32.x, b32.y, b32.z]);
    // The rate loop holds the rate during navigation (after settling).
    let ns = b.nav_start.as_ref().map(|(i, _)| *i).unwrap();
    let t_nav = b.consumed[ns].0 as f64 * 1e-6;
    let rms = rms_rate_error(&b, t_nav, b.t_us as f64 * 1e-6, rate);
    println!(
        "calibrated and navigating from {t_nav:.1} s; rate error RMS {:.3} deg/s",
        rms.to_degrees()
    );
    assert!(rms.to_degrees() < 0.5);
    // Results equal core-nav's offline processing of the same samples (f32,
    // bit for bit): replay from the state the board started navigating with.
    let (i0, mut offline) = b.nav_start.take().unwrap();
    let nav = &b.b.program.nav.nav;
    for (t, s) in &b.consumed[i0 + 1..] {
        offline.step(&nav.imu_sample(*t, s)).unwrap();
    }
    let board = nav.nav().unwrap().state();
    assert_eq!(
        offline.state(),
        board,
        "offline replay differs from the board"
    );
    let h = (board.p_n.x.powi(2) + board.p_n.y.powi(2)).sqrt();
    println!("board after navigating: horizontal {h:.1} m");
    assert_eq!(
        b.b.stats
            .out_lost
            .load(std::sync::atomic::Ordering::Relaxed),
        0
    );
    assert_eq!(b.b.program.link.link.tx_dropped, 0);
    // Every data-ready edge ticked; none dropped.
    assert_eq!(
        b.b.stats.dropped.load(std::sync::atomic::Ordering::Relaxed),
        0
    );
}

/// A board whose journal's active sector holds only a cut slot: the boot
/// moves the journal, erasing both sectors (`Journal::open`).
fn flash_that_erases_at_boot() -> NorFlash {
    let mut f = NorFlash::new(4096);
    f.mem[..4].fill(0);
    f
}

#[test]
fn a_boot_that_erases_two_sectors_calibrates_and_navigates_without_a_timeout() {
    // Both erases at the datasheet's worst (2 s each: the host's flash
    // keeps the CPU waiting that long, as the board's does), the sensors
    // on from reset, the link task first when `init` ends. Before the
    // silence window started at the link's first run, the boot's clock
    // reading (before the erases) made that run an `ImuTimeout` and a
    // halted table.
    let mut b = Board::new(
        ImuSpec::icm42688(),
        tuning(60.0, 60.0),
        flash_that_erases_at_boot(),
        21,
    );
    assert_eq!(b.b.program.link.journal.erases, 2);
    assert_eq!(b.b.flash.busy_us, 4_000_000);
    b.run(180.0);
    let timeouts = b
        .telemetry()
        .into_iter()
        .filter(|t| {
            matches!(
                t,
                Telemetry::Fault {
                    fault: Fault::ImuTimeout,
                    ..
                }
            )
        })
        .count();
    assert_eq!(timeouts, 0);
    assert_eq!(b.fault_count(Fault::ImuTimeout), 0);
    assert_eq!(
        b.mode(),
        Mode::Navigating,
        "{:?}",
        b.b.program.nav.nav.faults
    );
    // The watchdog: its first feed within the boot period's shortest
    // (from the top of `init`, erases included), then never unfed for
    // longer than the run period's shortest.
    let (unfed, first) = b.b.unfed_us();
    let first = first.expect("fed");
    assert!(
        first >= 4_000_000 && first < firmware::watchdog::BOOT.shortest_us(),
        "{first}"
    );
    assert!(unfed < firmware::watchdog::RUN.shortest_us(), "{unfed}");
}

#[test]
fn rate_loop_holds_10_to_100_dps() {
    for dps in [10.0f32, 40.0, 70.0, 100.0] {
        let rate = f64::from(dps).to_radians();
        // The rotating phase must hold a whole turn (36 s at 10 deg/s).
        let mut b = Board::new(
            ImuSpec::icm42688(),
            tuning(5.0, 40.0),
            flash_with(config(dps), None),
            5,
        );
        b.run(40.0);
        let t0 = b.rates.first().unwrap().0 as f64 * 1e-6;
        let rms = rms_rate_error(&b, t0 + 15.0, t0 + 40.0, rate);
        println!(
            "{dps} deg/s: mode {:?}, rate error RMS {:.3} deg/s",
            b.mode(),
            rms.to_degrees()
        );
        assert!(rms.to_degrees() < 0.5, "{dps}: {}", rms.to_degrees());
    }
}

/// A board through calibration and into navigation quickly (5 s still, 15 s
/// rotating at 90 deg/s).
fn navigating_board(seed: u64) -> Board {
    let mut b = Board::new(
        ImuSpec::icm42688(),
        tuning(5.0, 15.0),
        flash_with(config(90.0), None),
        seed,
    );
    b.run(25.0);
    assert_eq!(
        b.mode(),
        Mode::Navigating,
        "faults {:?}",
        b.b.program.nav.nav.faults
    );
    b
}

#[test]
fn spi_errors_are_counted_and_navigation_continues() {
    let mut b = navigating_board(11);
    b.bench.borrow_mut().chip.faults.spi_error = true;
    b.run(0.05);
    b.bench.borrow_mut().chip.faults.spi_error = false;
    b.run(1.0);
    assert!(
        b.fault_count(Fault::SpiError) >= 40,
        "{}",
        b.fault_count(Fault::SpiError)
    );
    assert_eq!(b.mode(), Mode::Navigating);
}

#[test]
fn stuck_imu_stops_the_motor() {
    // A hung chip stops raising data-ready: the link task's supervision
    // catches the silence.
    let mut b = navigating_board(12);
    b.bench.borrow_mut().chip.faults.stuck = true;
    b.run(0.5);
    // Each edge had no new data behind it (counted), the samples stopped,
    // and the link task stopped the motor (the bench's motor sees 0).
    let dup =
        b.b.stats
            .duplicated
            .load(std::sync::atomic::Ordering::Relaxed);
    assert!(dup >= 450, "{dup}");
    assert!(b.b.motor_off);
    assert_eq!(b.bench.borrow().pwm_duty, 0);
    assert!(b.telemetry().iter().any(|t| matches!(
        t,
        Telemetry::Fault {
            fault: Fault::ImuTimeout,
            ..
        }
    )));
    // A board reading on its timer sees the frozen values themselves.
    let mut b = navigating_board(12);
    b.ignore_drdy = true;
    b.bench.borrow_mut().chip.faults.stuck = true;
    b.run(0.5);
    assert_eq!(b.mode(), Mode::Stopped(Fault::ImuStuck));
    assert_eq!(b.duty(), 0.0);
}

#[test]
fn saturated_samples_are_skipped_counted_and_the_motor_held_safe() {
    let mut b = navigating_board(13);
    b.bench.borrow_mut().chip.faults.saturated = true;
    b.run(0.1);
    assert_eq!(
        b.duty(),
        0.0,
        "a saturated sample: the motor to a safe duty"
    );
    b.bench.borrow_mut().chip.faults.saturated = false;
    b.run(0.5);
    assert!(b.fault_count(Fault::ImuSaturated) >= 90);
    assert_eq!(b.mode(), Mode::Navigating);
    // Reported when it began and then at most once a second, with its count.
    let reports = b
        .telemetry()
        .iter()
        .filter(|t| {
            matches!(
                t,
                Telemetry::Fault {
                    fault: Fault::ImuSaturated,
                    ..
                }
            )
        })
        .count();
    assert_eq!(reports, 1);
}

#[test]
fn encoder_glitch_is_dropped_and_counted() {
    let mut b = navigating_board(14);
    let p0 = b.b.program.nav.nav.nav().unwrap().state().p_n;
    b.bench.borrow_mut().faults.encoder_offset_counts = 3_000;
    b.run(0.03);
    b.bench.borrow_mut().faults.encoder_offset_counts = 0;
    b.run(2.0);
    // One or two reads fall in the 30 ms (50 Hz reads).
    assert!((1..=2).contains(&b.fault_count(Fault::EncoderGlitch)));
    assert_eq!(b.mode(), Mode::Navigating);
    // The navigation (sensor frame) does not see the encoder at all.
    assert!((b.b.program.nav.nav.nav().unwrap().state().p_n - p0).norm() < 5.0);
}

#[test]
fn motor_stall_stops_the_motor() {
    let mut b = navigating_board(15);
    b.bench.borrow_mut().faults.motor_stall = true;
    b.run(3.0);
    assert_eq!(b.mode(), Mode::Stopped(Fault::MotorStall));
    assert_eq!(b.duty(), 0.0);
}

#[test]
fn imu_silence_stops_the_motor_and_the_watchdog_starves() {
    let mut b = navigating_board(16);
    let feeds = b.b.wdg.feeds;
    b.read_imu = false;
    b.run(0.3);
    // The link task saw the silence: the motor off, the fault reported.
    assert!(b.telemetry().iter().any(|t| matches!(
        t,
        Telemetry::Fault {
            fault: Fault::ImuTimeout,
            ..
        }
    )));
    assert!(b.b.motor_off);
    assert_eq!(b.bench.borrow().pwm_duty, 0);
    let fed = b.b.wdg.feeds - feeds;
    // Fed while the tick ran (the first 10 ms at most), then never: on the
    // board the IWDG resets the chip 100 ms into the silence.
    assert!(fed <= 2, "fed {fed} times");
    // When samples come back the tick halts the scheme and navigation stops.
    b.read_imu = true;
    b.run(0.05);
    assert_eq!(b.mode(), Mode::Stopped(Fault::ImuTimeout));
    assert_eq!(b.duty(), 0.0);
}

#[test]
fn a_bump_restarts_the_calibration_which_then_succeeds() {
    let mut b = Board::new(
        ImuSpec::icm42688(),
        tuning(10.0, 15.0),
        flash_with(config(90.0), None),
        17,
    );
    let t0 = b.t_us as f64 * 1e-6;
    b.bench.borrow_mut().bump(hal_sim::world::Bump {
        t_s: t0 + 4.0,
        duration_s: 0.3,
        rate_b: nalgebra::Vector3::new(0.2, 0.0, 0.0),
        accel_b: nalgebra::Vector3::zeros(),
    });
    b.run(50.0);
    assert_eq!(b.fault_count(Fault::CalibrationRefused), 1);
    let refusals: Vec<CalStatus> = b
        .telemetry()
        .iter()
        .filter_map(|t| match t {
            Telemetry::Calibration { status, .. } if *status != CalStatus::Accepted => {
                Some(*status)
            }
            _ => None,
        })
        .collect();
    assert_eq!(refusals, vec![CalStatus::NotStatic]);
    assert_eq!(b.mode(), Mode::Navigating);
}

#[test]
fn a_table_that_cannot_reach_its_rate_is_refused() {
    let mut b = Board::new(
        ImuSpec::icm42688(),
        tuning(5.0, 15.0),
        flash_with(config(90.0), None),
        18,
    );
    // A dragging bearing: 0.5 N m s/rad of viscous friction against the
    // motor's 0.4 N m stall torque: 46 deg/s at most.
    b.bench.borrow_mut().table.motor.viscous = 0.5;
    b.run(20.0);
    assert!(b.telemetry().iter().any(|t| matches!(
        t,
        Telemetry::Calibration {
            status: CalStatus::RateNotReached,
            ..
        }
    )));
    assert!(matches!(b.mode(), Mode::CalStatic(_) | Mode::CalSpinUp(_)));
}

#[test]
fn commands_arrive_byte_by_byte_and_are_answered_with_a_reason() {
    let mut b = navigating_board(19);
    b.b.sent.clear();
    let frame = |c: Command, seq: u16| {
        let mut f = [0u8; protocol::MAX_FRAME];
        let n = c.to_frame(seq, &mut f).unwrap();
        f[..n].to_vec()
    };
    // Two commands and a garbage frame, delivered one byte per 11 µs as
    // the UART would (the receive interrupt's queue; the link task every
    // 10 ms).
    let mut bytes = frame(
        Command::SetScheme {
            kind: SchemeKind::Continuous,
            rate_dps: 900.0,
            count: 0,
        },
        7,
    );
    bytes.extend(frame(Command::Stop {}, 8));
    bytes.extend([0x11, 0x22, 0x00]);
    for chunk in bytes.chunks(3) {
        b.b.receive(chunk);
        b.run(0.001);
    }
    b.run(0.05);
    let acks: Vec<(u16, Status)> = b
        .telemetry()
        .iter()
        .filter_map(|t| match t {
            Telemetry::Ack { seq, status } => Some((*seq, *status)),
            _ => None,
        })
        .collect();
    assert_eq!(acks, vec![(7, Status::BadRate), (8, Status::Accepted)]);
    assert_eq!(b.duty(), 0.0, "stopped on command");
    assert_eq!(b.b.program.link.link.rx_stats().corrupt, 1);
}

#[test]
fn the_configuration_is_set_by_commands_and_survives_a_power_cycle() {
    // A board at a southern site: site, base and scheme by command, stored.
    let mut b = Board::new(
        ImuSpec::icm42688(),
        tuning(5.0, 15.0),
        NorFlash::new(4096),
        20,
    );
    for c in [
        Command::SetSite {
            lat_e7: -339_250_000,
            height_mm: 31_000,
        },
        Command::SetBase {
            roll_deg: 0.0,
            pitch_deg: 0.0,
            heading_deg: -120.0,
        },
        Command::SetScheme {
            kind: SchemeKind::Continuous,
            rate_dps: 60.0,
            count: 0,
        },
    ] {
        b.command(&c);
    }
    b.run(1.0);
    let cfg = b.b.program.link.link.config;
    assert_eq!(
        (cfg.lat_e7, cfg.base_deg[2], cfg.rate_dps),
        (-339_250_000, -120.0, 60.0)
    );
    assert_eq!(b.b.program.nav.nav.config().lat_deg, -33.925);
    assert!(b.telemetry().iter().any(|t| matches!(
        t,
        Telemetry::Config {
            lat_e7: -339_250_000,
            ..
        }
    )));
    // Power off, on again with the same flash: the record is the config.
    let flash = b.b.flash.clone();
    let b2 = Board::new(ImuSpec::icm42688(), tuning(5.0, 15.0), flash, 21);
    assert_eq!(b2.b.program.link.link.config, cfg);
}

#[test]
fn telemetry_decodes_back_to_the_samples_exactly_and_counts_losses() {
    let mut b = navigating_board(21);
    b.run(5.0);
    let meta = recording::Meta::default();
    let d = rins::record::decode(b.b.sent.iter().copied(), meta.clone());
    println!("{}", rins::record::link_report(&d));
    assert_eq!(
        (
            d.stats.lost,
            d.stats.corrupt,
            d.stats.overflow,
            d.out_of_order
        ),
        (0, 0, 0, 0)
    );
    // Every IMU row is a sample the board used, bit for bit.
    assert_eq!(d.recording.imu.len(), b.nav_samples.len());
    for (row, (t, s)) in d.recording.imu.iter().zip(&b.nav_samples) {
        assert_eq!(row.t_s, *t as f64 * 1e-6);
        assert_eq!(row.gyro_radps, s.gyro_radps.map(f64::from));
        assert_eq!(row.accel_mps2, s.accel_mps2.map(f64::from));
    }
    assert_eq!(d.recording.meta.imu_sample, recording::SampleKind::Average);
    assert_eq!(d.calibrations.len(), 1);
    assert!(!d.health.is_empty(), "health frames once a second");
    // Through the file format and back.
    let dir = std::env::temp_dir().join(format!("rins-record-{}", std::process::id()));
    d.recording.write(&dir).unwrap();
    assert_eq!(recording::Recording::read(&dir).unwrap(), d.recording);
    std::fs::remove_dir_all(&dir).unwrap();
    // A damaged link: 5 bytes flipped, 2,000 bytes gone (about 50 frames).
    let mut bytes = b.b.sent.clone();
    for k in 0..5 {
        let i = 1_000 + k * 7_919;
        bytes[i] ^= 0x10;
    }
    bytes.drain(30_000..32_000);
    let d2 = rins::record::decode(bytes, meta);
    println!("damaged: {}", rins::record::link_report(&d2));
    assert!(d2.stats.corrupt >= 1);
    assert!(d2.stats.lost >= 40, "{:?}", d2.stats);
    assert!(d2.recording.imu.len() < d.recording.imu.len());
}

#[test]
fn the_stored_record_is_read_at_power_up_and_the_change_reported() {
    use core_nav::table::Axis;
    // First power-up: calibrate and store (the journal, a word a run).
    let mut first = navigating_board(31);
    first.run(1.0);
    let flash = first.b.flash.clone();
    let cal1 = first
        .b
        .program
        .link
        .journal
        .current
        .and_then(|r| r.calibration)
        .unwrap();
    // Second power-up of the same sensor (a new bench seed: the turn-on
    // bias has changed, as between real power-ups), the record read back
    // from flash at boot.
    let mut b = Board::new(ImuSpec::icm42688(), tuning(5.0, 15.0), flash, 32);
    let prev = b.b.program.nav.nav.previous.unwrap();
    let p32 = prev.bias.map(|x| x as f32);
    assert_eq!([p32.x, p32.y, p32.z], cal1.bias_radps);
    b.run(25.0);
    assert_eq!(b.mode(), Mode::Navigating);
    let cal2 = b.b.program.nav.nav.calibration.expect("calibrated again");
    let d = rins::record::decode(b.b.sent.iter().copied(), recording::Meta::default());
    assert_eq!(
        d.calibrations.first().map(|c| c.status),
        Some(CalStatus::Stored)
    );
    assert_eq!(
        d.calibrations.last().map(|c| c.status),
        Some(CalStatus::Accepted)
    );
    assert_eq!(d.calibration_changes.len(), 1);
    let want = cal2.bias - prev.bias;
    assert_eq!(
        d.calibration_changes[0].0,
        [want.x as f32, want.y as f32, want.z as f32]
    );
    let j = rins::record::calibration_json(&d, Axis::Z).unwrap();
    let back = rins::calibrate::from_json(&j).unwrap();
    assert_eq!(back.bias.map(|x| x as f32), cal2.bias.map(|x| x as f32));
    assert!(j["board"]["change_from_stored"]["bias_radps"].is_array());
    // Blank flash: nothing kept, the factory configuration.
    let fresh = Board::new(
        ImuSpec::icm42688(),
        tuning(5.0, 15.0),
        NorFlash::new(4096),
        33,
    );
    assert!(fresh.b.program.nav.nav.previous.is_none());
    assert_eq!(fresh.b.program.link.link.config, firmware::tasks::FACTORY);
}

#[test]
fn a_wrong_imu_at_power_up_is_reported_and_the_motor_never_runs() {
    // The board's init: WHO_AM_I is not the ICM-42688-P's (the chip model
    // answers 0x12), so the driver refuses it and the board boots stopped.
    let mut bc = BenchConfig::new(ImuSpec::icm42688());
    bc.seed = 5;
    let bench = Bench::new(bc).shared();
    bench.borrow_mut().chip.faults.who_am_i = Some(0x12);
    let mut imu = Icm42688::new(SimSpi::new(bench.clone()));
    let err = imu.init(Config::default(), &mut SimDelay(bench.clone()));
    assert!(matches!(
        err,
        Err(firmware::icm42688::Error::WrongDevice(0x12))
    ));
    let mut b = HostBoard::new(
        tuning(5.0, 15.0),
        NorFlash::new(4096),
        0,
        Err(Fault::WrongDevice),
    );
    assert_eq!(b.program.nav.nav.mode(), Mode::Stopped(Fault::WrongDevice));
    // A stopped board that reports and stays up: the link runs, the
    // watchdog is fed on the link's progress alone (no reboot loop).
    b.idle(500_000);
    assert!(b.wdg.feeds >= 40, "{}", b.wdg.feeds);
    let d = rins::record::decode(b.sent.clone(), recording::Meta::default());
    assert_eq!(d.faults.first().map(|f| f.1), Some(Fault::WrongDevice));
    assert_eq!(b.program.tick.control.duty(), 0.0);
}

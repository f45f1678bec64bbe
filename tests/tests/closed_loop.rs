//! The firmware logic in closed loop with hal-sim on the host: the real
//! ICM-42688-P driver on the chip model, the encoder counter, the motor
//! through PWM and direction pins, 100 Hz IMU / 50 Hz encoder scheduling.

use core_nav::scheme::Scheme;
use core_nav::strapdown::Strapdown;
use core_nav::table::QuadratureCounter;
use embedded_hal::digital::OutputPin;
use embedded_hal::pwm::SetDutyCycle;
use firmware::app::{App, AppConfig, Mode};
use firmware::faults::Fault;
use firmware::icm42688::{Config, Icm42688, Sample};
use hal_sim::bench::{Bench, BenchConfig, SharedBench};
use hal_sim::drivers::{SimDelay, SimDir, SimEncoder, SimPwm, SimSpi};
use hal_sim::imu::ImuSpec;

struct Board {
    bench: SharedBench,
    imu: Icm42688<SimSpi>,
    pwm: SimPwm,
    dir: SimDir,
    enc: SimEncoder,
    app: App,
    t_us: u64,
    frames: Vec<u8>,
    /// (t, true rate, reference rate) while the scheme runs, rad/s.
    rates: Vec<(u64, f64)>,
    /// What the app consumed: (t, sample).
    consumed: Vec<(u64, Sample)>,
    nav_start: Option<(usize, Strapdown<f32>)>,
    read_imu: bool,
    /// Read the IMU on the 1 kHz timer whether or not data-ready is set.
    ignore_drdy: bool,
    /// Every navigation-rate sample the board formed: (t, mean).
    nav_samples: Vec<(u64, Sample)>,
    /// Every encoder read: (t, hardware count).
    encoder_reads: Vec<(u64, u16)>,
}

impl Board {
    fn new(spec: ImuSpec, cfg: AppConfig, seed: u64) -> Self {
        let mut bc = BenchConfig::new(spec);
        bc.seed = seed;
        let bench = Bench::new(bc).shared();
        let mut imu = Icm42688::new(SimSpi::new(bench.clone()));
        imu.init(Config::default(), &mut SimDelay(bench.clone()))
            .expect("IMU init");
        let t_us = bench.borrow().now_ns / 1000;
        Self {
            pwm: SimPwm(bench.clone()),
            dir: SimDir(bench.clone()),
            enc: SimEncoder(bench.clone()),
            bench,
            imu,
            app: App::new(cfg).expect("config"),
            t_us: t_us.div_ceil(10_000) * 10_000,
            frames: vec![],
            rates: vec![],
            consumed: vec![],
            nav_start: None,
            read_imu: true,
            ignore_drdy: false,
            nav_samples: vec![],
            encoder_reads: vec![],
        }
    }

    fn run(&mut self, seconds: f64) {
        let end = self.t_us + (seconds * 1e6) as u64;
        while self.t_us < end {
            // The scheduler's 1 kHz tick (the IMU's ODR).
            self.t_us += 1_000;
            let t = self.t_us;
            self.bench.borrow_mut().advance_to(t * 1000);
            if t.is_multiple_of(20_000) {
                let hw = self.enc.read_count().unwrap();
                self.app.on_encoder(t, hw);
                self.encoder_reads.push((t, hw));
            }
            if self.read_imu {
                let ready = if self.ignore_drdy {
                    self.imu.data_ready().map(|_| true)
                } else {
                    self.imu.data_ready()
                };
                match ready {
                    Ok(true) => match self.imu.read_si() {
                        Ok((raw, s)) => {
                            let was_nav = self.app.mode == Mode::Navigating;
                            self.app.on_imu(t, &raw, &s);
                            if t.is_multiple_of(10_000) {
                                self.nav_samples.push(self.app.last_nav_sample().unwrap());
                            }
                            if self.app.mode == Mode::Navigating && t.is_multiple_of(10_000) {
                                if !was_nav {
                                    self.nav_start = Some((
                                        self.consumed.len(),
                                        self.app.nav().unwrap().clone(),
                                    ));
                                }
                                self.consumed.push(self.app.last_nav_sample().unwrap());
                            }
                        }
                        Err(_) => self.app.on_imu_error(t),
                    },
                    Ok(false) => {}
                    Err(_) => self.app.on_imu_error(t),
                }
            }
            if t.is_multiple_of(100_000) {
                self.app.check_watchdog(t);
            }
            let d = self.app.duty();
            let max = self.pwm.max_duty_cycle();
            self.pwm
                .set_duty_cycle((d.abs() * f32::from(max)) as u16)
                .unwrap();
            if d >= 0.0 {
                self.dir.set_high().unwrap()
            } else {
                self.dir.set_low().unwrap()
            }
            if t.is_multiple_of(10_000) {
                let r = self.bench.borrow().table.kin.rate;
                self.rates.push((t, r));
            }
            let frames = &mut self.frames;
            self.app.drain(|f| frames.extend_from_slice(f));
        }
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
    let cfg = AppConfig {
        scheme: Scheme::Continuous { rate },
        ..AppConfig::default()
    };
    let mut b = Board::new(ImuSpec::icm42688(), cfg, 3);
    b.run(600.0);
    assert_eq!(b.app.mode, Mode::Navigating, "faults {:?}", b.app.faults);
    let cal = b.app.calibration.expect("calibrated");
    let stored = b.app.stored.expect("stored");
    assert_eq!(
        firmware::app::decode_record(&stored, core_nav::table::Axis::Z)
            .map(|c| c.bias.map(|x| x as f32)),
        Some(cal.bias.map(|x| x as f32))
    );
    // The rate loop holds the rate during navigation (after settling).
    let (ns, _) = b.nav_start.as_ref().map(|(i, _)| (*i, 0)).unwrap();
    let t_nav = b.consumed[ns].0 as f64 * 1e-6;
    let rms = rms_rate_error(&b, t_nav, 600.0, rate);
    println!(
        "calibrated and navigating from {t_nav:.1} s; rate error RMS {:.3} deg/s",
        rms.to_degrees()
    );
    assert!(rms.to_degrees() < 0.5);
    // Results equal core-nav's offline processing of the same samples (f32,
    // bit for bit): replay from the state the board started navigating with.
    let (i0, mut offline) = b.nav_start.take().unwrap();
    for (t, s) in &b.consumed[i0 + 1..] {
        offline.step(&b.app.imu_sample(*t, s)).unwrap();
    }
    let board = b.app.nav().unwrap().state();
    assert_eq!(
        offline.state(),
        board,
        "offline replay differs from the board"
    );
    let h = (board.p_n.x.powi(2) + board.p_n.y.powi(2)).sqrt();
    println!(
        "board after {:.0} s of navigation: horizontal {:.1} m",
        600.0 - t_nav,
        h
    );
    assert_eq!(b.app.faults.get(Fault::TelemetryOverflow), 0);
}

#[test]
fn rate_loop_holds_10_to_100_dps() {
    for dps in [10.0, 40.0, 70.0, 100.0] {
        let rate = f64::to_radians(dps);
        // The rotating phase must hold a whole turn (36 s at 10 deg/s).
        let cfg = AppConfig {
            scheme: Scheme::Continuous { rate },
            static_s: 5.0,
            rotate_s: 40.0,
            ..AppConfig::default()
        };
        let mut b = Board::new(ImuSpec::icm42688(), cfg, 5);
        b.run(40.0);
        let t0 = b.rates.first().unwrap().0 as f64 * 1e-6;
        let rms = rms_rate_error(&b, t0 + 15.0, t0 + 40.0, rate);
        println!(
            "{dps} deg/s: mode {:?}, rate error RMS {:.3} deg/s",
            b.app.mode,
            rms.to_degrees()
        );
        assert!(rms.to_degrees() < 0.5, "{dps}: {}", rms.to_degrees());
    }
}

/// A board through calibration and into navigation quickly (5 s still, 15 s
/// rotating at 90 deg/s).
/// A short power-up: 5 s still, 15 s at 90 deg/s.
fn quick_calibration() -> AppConfig {
    AppConfig {
        scheme: Scheme::Continuous {
            rate: 90f64.to_radians(),
        },
        static_s: 5.0,
        rotate_s: 15.0,
        ..AppConfig::default()
    }
}

fn navigating_board(seed: u64) -> Board {
    let mut b = Board::new(ImuSpec::icm42688(), quick_calibration(), seed);
    b.run(25.0);
    assert_eq!(
        b.app.mode,
        Mode::Navigating,
        "refused: {:?}",
        b.app.last_refusal
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
        b.app.faults.get(Fault::SpiError) >= 40,
        "{}",
        b.app.faults.get(Fault::SpiError)
    );
    assert_eq!(b.app.mode, Mode::Navigating);
}

#[test]
fn stuck_imu_stops_the_motor() {
    // A hung chip stops raising data-ready: the watchdog catches it.
    let mut b = navigating_board(12);
    b.bench.borrow_mut().chip.faults.stuck = true;
    b.run(0.5);
    assert_eq!(b.app.mode, Mode::Stopped(Fault::ImuTimeout));
    assert_eq!(b.app.duty(), 0.0);
    // A board reading on its timer sees the frozen values themselves.
    let mut b = navigating_board(12);
    b.ignore_drdy = true;
    b.bench.borrow_mut().chip.faults.stuck = true;
    b.run(0.5);
    assert_eq!(b.app.mode, Mode::Stopped(Fault::ImuStuck));
    assert_eq!(b.app.duty(), 0.0);
}

#[test]
fn saturated_samples_are_skipped_and_counted() {
    let mut b = navigating_board(13);
    b.bench.borrow_mut().chip.faults.saturated = true;
    b.run(0.1);
    b.bench.borrow_mut().chip.faults.saturated = false;
    b.run(0.5);
    assert!(b.app.faults.get(Fault::ImuSaturated) >= 90);
    assert_eq!(b.app.mode, Mode::Navigating);
}

#[test]
fn encoder_glitch_is_dropped_and_counted() {
    let mut b = navigating_board(14);
    let p0 = b.app.nav().unwrap().state().p_n;
    b.bench.borrow_mut().faults.encoder_offset_counts = 3_000;
    b.run(0.03);
    b.bench.borrow_mut().faults.encoder_offset_counts = 0;
    b.run(2.0);
    // One or two reads fall in the 30 ms (50 Hz reads).
    assert!((1..=2).contains(&b.app.faults.get(Fault::EncoderGlitch)));
    assert_eq!(b.app.mode, Mode::Navigating);
    // The navigation (sensor frame) does not see the encoder at all.
    assert!((b.app.nav().unwrap().state().p_n - p0).norm() < 5.0);
}

#[test]
fn motor_stall_stops_the_motor() {
    let mut b = navigating_board(15);
    b.bench.borrow_mut().faults.motor_stall = true;
    b.run(3.0);
    assert_eq!(b.app.mode, Mode::Stopped(Fault::MotorStall));
    assert_eq!(b.app.duty(), 0.0);
}

#[test]
fn imu_silence_trips_the_watchdog() {
    let mut b = navigating_board(16);
    b.read_imu = false;
    b.run(0.3);
    assert_eq!(b.app.mode, Mode::Stopped(Fault::ImuTimeout));
    assert_eq!(b.app.duty(), 0.0);
}

#[test]
fn a_bump_restarts_the_calibration_which_then_succeeds() {
    let cfg = AppConfig {
        scheme: Scheme::Continuous {
            rate: 90f64.to_radians(),
        },
        static_s: 10.0,
        rotate_s: 15.0,
        ..AppConfig::default()
    };
    let mut b = Board::new(ImuSpec::icm42688(), cfg, 17);
    let t0 = b.t_us as f64 * 1e-6;
    b.bench.borrow_mut().bump(hal_sim::world::Bump {
        t_s: t0 + 4.0,
        duration_s: 0.3,
        rate_b: nalgebra::Vector3::new(0.2, 0.0, 0.0),
        accel_b: nalgebra::Vector3::zeros(),
    });
    b.run(50.0);
    assert_eq!(b.app.faults.get(Fault::CalibrationRefused), 1);
    assert!(
        matches!(
            b.app.last_refusal,
            Some(core_nav::calib::CalibError::NotStatic { .. })
        ),
        "{:?}",
        b.app.last_refusal
    );
    assert_eq!(b.app.mode, Mode::Navigating);
}

#[test]
fn a_table_that_cannot_reach_its_rate_is_refused() {
    let cfg = AppConfig {
        scheme: Scheme::Continuous {
            rate: 90f64.to_radians(),
        },
        static_s: 5.0,
        rotate_s: 15.0,
        ..AppConfig::default()
    };
    let mut b = Board::new(ImuSpec::icm42688(), cfg, 18);
    // A dragging bearing: 0.5 N m s/rad of viscous friction against the
    // motor's 0.4 N m stall torque: 46 deg/s at most.
    b.bench.borrow_mut().table.motor.viscous = 0.5;
    b.run(20.0);
    assert!(
        matches!(
            b.app.last_refusal,
            Some(core_nav::calib::CalibError::RateNotReached { .. })
        ),
        "{:?}",
        b.app.last_refusal
    );
    assert!(matches!(
        b.app.mode,
        Mode::CalStatic(_) | Mode::CalSpinUp(_)
    ));
}

#[test]
fn malformed_commands_are_answered_with_a_reason() {
    use firmware::telemetry::{frame, reason, Command, Decoder, Telemetry, MAX_FRAME, MAX_PAYLOAD};
    let mut b = navigating_board(19);
    let send = |b: &mut Board, c: Command, seq: u16| {
        let mut p = [0u8; MAX_PAYLOAD];
        let n = c.payload(seq, &mut p).unwrap();
        let mut f = [0u8; MAX_FRAME];
        let m = frame(&p[..n], &mut f).unwrap();
        let t = b.t_us;
        b.app.on_rx(t, &f[..m]);
    };
    b.frames.clear();
    send(
        &mut b,
        Command::SetScheme {
            kind: 1,
            rate_dps: 900.0,
            count: 0,
        },
        7,
    );
    send(&mut b, Command::Stop, 8);
    b.app.on_rx(b.t_us, &[0x11, 0x22, 0x00]); // garbage frame
    b.run(0.05);
    let mut d = Decoder::default();
    let mut out = [0u8; MAX_PAYLOAD + 2];
    let mut acks: Vec<(u16, u8)> = vec![];
    for x in &b.frames {
        if let Some(n) = d.push(*x, &mut out) {
            if let Ok((_, Telemetry::Ack { seq, status })) = Telemetry::parse(&out[..n]) {
                acks.push((seq, status));
            }
        }
    }
    assert_eq!(acks, vec![(7, reason::BAD_RATE), (8, 0)]);
    assert_eq!(b.app.duty(), 0.0, "stopped on command");
    assert_eq!(b.app.faults.get(Fault::BadCommand), 1);
}

#[test]
fn telemetry_decodes_back_to_the_samples_exactly_and_counts_losses() {
    let mut b = navigating_board(21);
    b.run(5.0);
    let meta = recording::Meta::default();
    let d = rins::record::decode(b.frames.iter().copied(), meta.clone());
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
    assert_eq!(d.recording.table.len(), b.encoder_reads.len());
    assert_eq!(d.recording.meta.imu_sample, recording::SampleKind::Average);
    assert_eq!(d.calibrations.len(), 1);
    // Through the file format and back.
    let dir = std::env::temp_dir().join(format!("rins-record-{}", std::process::id()));
    d.recording.write(&dir).unwrap();
    assert_eq!(recording::Recording::read(&dir).unwrap(), d.recording);
    std::fs::remove_dir_all(&dir).unwrap();
    // A damaged link: 5 bytes flipped, 2,000 bytes gone (about 50 frames).
    let mut bytes = b.frames.clone();
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
    use firmware::app::{decode_record, CAL_RECORD, CAL_STATUS_STORED};
    // First power-up: calibrate and store.
    let first = navigating_board(31);
    let record = first.app.stored.expect("stored");
    let cal1 = decode_record(&record, Axis::Z).unwrap();
    // Second power-up of the same sensor (a new bench seed: the turn-on
    // bias has changed, as between real power-ups), the record read back
    // from flash before the calibration starts.
    let mut b = Board::new(ImuSpec::icm42688(), quick_calibration(), 32);
    assert!(b.app.restore(&record));
    assert_eq!(b.app.previous.map(|c| c.bias), Some(cal1.bias));
    b.run(25.0);
    assert_eq!(b.app.mode, Mode::Navigating);
    let cal2 = b.app.calibration.expect("calibrated again");
    let (d_bias, d_mk) = b.app.change.expect("change reported");
    // The change is the new calibration minus the stored record, exactly
    // (both in f64; the record holds f32).
    assert_eq!(d_bias, cal2.bias - cal1.bias);
    assert_eq!(d_mk, cal2.m_k - cal1.m_k);
    // What the host decodes from the link: the stored record first, then
    // the accepted result and its change; calibration.json carries all three
    // and reads back as a calibration.
    let d = rins::record::decode(b.frames.iter().copied(), recording::Meta::default());
    assert_eq!(
        d.calibrations.first().map(|c| c.status),
        Some(CAL_STATUS_STORED)
    );
    assert_eq!(d.calibrations.last().map(|c| c.status), Some(0));
    assert_eq!(d.calibration_changes.len(), 1);
    assert_eq!(
        d.calibration_changes[0].0,
        [d_bias.x as f32, d_bias.y as f32, d_bias.z as f32]
    );
    let j = rins::record::calibration_json(&d, Axis::Z).unwrap();
    let back = rins::calibrate::from_json(&j).unwrap();
    assert_eq!(back.bias.map(|x| x as f32), cal2.bias.map(|x| x as f32));
    assert!(j["board"]["change_from_stored"]["bias_radps"].is_array());
    // Blank flash (erased: 0xFF) or a damaged record: nothing is kept.
    let mut fresh = Board::new(ImuSpec::icm42688(), AppConfig::default(), 33);
    assert!(!fresh.app.restore(&[0xFF; CAL_RECORD]));
    let mut bad = record;
    bad[5] ^= 1;
    assert!(!fresh.app.restore(&bad));
    assert!(fresh.app.previous.is_none());
}

#[test]
fn a_wrong_imu_at_power_up_is_reported_and_the_motor_never_runs() {
    // The board's init: WHO_AM_I is not the ICM-42688-P's (the chip model
    // answers 0x12), so the driver refuses it and the app is told.
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
    let mut app = App::new(AppConfig::default()).unwrap();
    app.on_imu_init_failed(0, true);
    assert_eq!(app.mode, Mode::Stopped(Fault::WrongDevice));
    assert_eq!(app.faults.get(Fault::WrongDevice), 1);
    assert_eq!(app.duty(), 0.0);
    // Sent over the link.
    let mut frames = vec![];
    app.drain(|f| frames.extend_from_slice(f));
    let d = rins::record::decode(frames, recording::Meta::default());
    assert_eq!(d.faults, vec![(0, Fault::WrongDevice as u8, 1)]);
    // Encoder reads and commands to start do not run the motor: no IMU.
    app.on_encoder(20_000, 0);
    assert_eq!(app.duty(), 0.0);
}

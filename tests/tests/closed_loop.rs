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
            }
            if self.read_imu {
                match self.imu.data_ready() {
                    Ok(true) => match self.imu.read_si() {
                        Ok((raw, s)) => {
                            let was_nav = self.app.mode == Mode::Navigating;
                            self.app.on_imu(t, &raw, &s);
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

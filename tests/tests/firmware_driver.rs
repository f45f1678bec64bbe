//! The firmware's ICM-42688-P driver against the hal-sim chip model (written
//! from the datasheet, not from this driver) and against exact bus
//! transactions (embedded-hal-mock).

use core_nav::table::Axis;
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as T};
use firmware::icm42688::{
    reg, AccelFs, Config, DataFault, DataMonitor, Error, GyroFs, Icm42688, Odr,
};
use hal_sim::bench::{Bench, BenchConfig};
use hal_sim::drivers::{SimDelay, SimSpi};
use hal_sim::imu::ImuSpec;

fn bench(rate_dps: f64) -> hal_sim::bench::SharedBench {
    // The chip's own white noise (a live sensor never repeats a sample).
    let mut spec = ImuSpec::ideal();
    spec.gyro.white = ImuSpec::icm42688().gyro.white;
    spec.accel.white = ImuSpec::icm42688().accel.white;
    let mut cfg = BenchConfig::new(spec);
    cfg.geometry = hal_sim::world::Geometry::perfect(Axis::Z);
    let b = Bench::new(cfg).shared();
    b.borrow_mut().table.kin.rate = rate_dps.to_radians();
    b.borrow_mut().table.motor.inertia = 1e12; // a flywheel: holds its rate
    b
}

/// The driver on the chip model, initialised at +-500 deg/s, +-4 g and
/// `odr`.
fn initialised(b: &hal_sim::bench::SharedBench, odr: Odr) -> Icm42688<SimSpi> {
    let mut imu = Icm42688::new(SimSpi::new(b.clone()));
    let cfg = Config {
        gyro_fs: GyroFs::Dps500,
        accel_fs: AccelFs::G4,
        odr,
    };
    imu.init(cfg, &mut SimDelay(b.clone())).unwrap();
    imu
}

#[test]
fn driver_reads_the_chip_model_in_si_units() {
    let b = bench(120.0);
    let mut imu = initialised(&b, Odr::Hz100);
    let mut mon = DataMonitor::default();
    let g = b.borrow().scene.site.gravity_mps2 as f32;
    let mut n_ready = 0;
    let (mut gz, mut az, mut gx, mut ax) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for _ in 0..100 {
        // 100 Hz: a new sample every 10 ms; poll every 5 ms.
        for _ in 0..2 {
            let t = b.borrow().now_ns + 5_000_000;
            b.borrow_mut().advance_to(t);
            if imu.data_ready().unwrap() {
                n_ready += 1;
                let (raw, s) = imu.read_si().unwrap();
                assert_eq!(mon.check(&raw), None);
                gz += s.gyro_radps[2];
                gx += s.gyro_radps[0];
                az += s.accel_mps2[2];
                ax += s.accel_mps2[0];
                assert!((s.temp_c - 25.0).abs() < 0.02);
            }
        }
    }
    // One sample per 10 ms (plus the one pending when init returned).
    assert!((100..=101).contains(&n_ready), "{n_ready}");
    let k = n_ready as f32;
    let (gz, gx, az, ax) = (gz / k, gx / k, az / k, ax / k);
    // Means of 100 samples: noise sd 3.5e-4 rad/s and 5e-3 m/s^2 per sample
    // (datasheet densities over 50 Hz), /10 for the mean, x4; plus half an
    // LSB (+-500 deg/s: 1.3e-4 rad/s; +-4 g: 6e-4 m/s^2) and the earth rate
    // (6e-5 rad/s).
    assert!((gz - 120f32.to_radians()).abs() < 3.4e-4, "{gz}");
    assert!(gx.abs() < 3.4e-4, "{gx}");
    assert!((az + g).abs() < 2.6e-3, "{az}");
    assert!(ax.abs() < 2.6e-3, "{ax}");
}

#[test]
fn wrong_identity_bus_errors_and_bad_data_are_reported() {
    let b = bench(0.0);
    b.borrow_mut().chip.faults.who_am_i = Some(0x12);
    let mut imu = Icm42688::new(SimSpi::new(b.clone()));
    let mut delay = SimDelay(b.clone());
    assert_eq!(
        imu.init(Config::default(), &mut delay),
        Err(Error::WrongDevice(0x12))
    );
    b.borrow_mut().chip.faults.who_am_i = None;
    imu.init(Config::default(), &mut delay).unwrap();
    b.borrow_mut().chip.faults.spi_error = true;
    assert!(matches!(imu.read_raw_lsb(), Err(Error::Comm(_))));
    b.borrow_mut().chip.faults.spi_error = false;
    // Stuck: the same sample five times in a row.
    b.borrow_mut().chip.faults.stuck = true;
    let mut mon = DataMonitor::default();
    let faults: Vec<_> = (0..6)
        .map(|_| {
            let t = b.borrow().now_ns + 10_000_000;
            b.borrow_mut().advance_to(t);
            mon.check(&imu.read_raw_lsb().unwrap())
        })
        .collect();
    assert_eq!(
        faults
            .iter()
            .filter(|f| **f == Some(DataFault::Stuck))
            .count(),
        2,
        "{faults:?}"
    );
    b.borrow_mut().chip.faults.stuck = false;
    b.borrow_mut().chip.faults.saturated = true;
    let t = b.borrow().now_ns + 10_000_000;
    b.borrow_mut().advance_to(t);
    assert_eq!(
        mon.check(&imu.read_raw_lsb().unwrap()),
        Some(DataFault::Saturated)
    );
    assert_eq!((mon.stuck_count, mon.saturated_count), (2, 1));
}

#[test]
fn driver_bus_transactions_are_the_datasheets() {
    const READ: u8 = 0x80;
    let expected = [
        // Soft reset, identity.
        T::transaction_start(),
        T::write_vec(vec![reg::DEVICE_CONFIG, 0x01]),
        T::transaction_end(),
        T::transaction_start(),
        T::write_vec(vec![READ | reg::WHO_AM_I]),
        T::read_vec(vec![0x47]),
        T::transaction_end(),
        // Bank 0, big-endian data, INT1 push-pull active-high pulsed (100
        // us, INT_ASYNC_RESET cleared),
        // data ready to INT1, +-500 deg/s @ 1 kHz, +-4 g @ 1 kHz, both on.
        T::transaction_start(),
        T::write_vec(vec![reg::REG_BANK_SEL, 0x00]),
        T::transaction_end(),
        T::transaction_start(),
        T::write_vec(vec![reg::INTF_CONFIG0, 0x30]),
        T::transaction_end(),
        T::transaction_start(),
        T::write_vec(vec![reg::INT_CONFIG, 0x03]),
        T::transaction_end(),
        T::transaction_start(),
        T::write_vec(vec![reg::INT_CONFIG1, 0x00]),
        T::transaction_end(),
        T::transaction_start(),
        T::write_vec(vec![reg::INT_SOURCE0, 0x08]),
        T::transaction_end(),
        T::transaction_start(),
        T::write_vec(vec![reg::GYRO_CONFIG0, 0x46]),
        T::transaction_end(),
        T::transaction_start(),
        T::write_vec(vec![reg::ACCEL_CONFIG0, 0x46]),
        T::transaction_end(),
        T::transaction_start(),
        T::write_vec(vec![reg::PWR_MGMT0, 0x0F]),
        T::transaction_end(),
        // One burst: temp 0x0100, accel x..z, gyro x..z (big-endian).
        T::transaction_start(),
        T::write_vec(vec![READ | reg::TEMP_DATA1]),
        T::read_vec(vec![
            0x01, 0x00, 0x00, 0x01, 0xFF, 0xFF, 0xE0, 0x00, 0x00, 0x02, 0xFF, 0xFE, 0x00, 0x00,
        ]),
        T::transaction_end(),
    ];
    let mut spi = SpiMock::new(&expected);
    let mut imu = Icm42688::new(spi.clone());
    imu.init(Config::default(), &mut NoopDelay::new()).unwrap();
    let r = imu.read_raw_lsb().unwrap();
    assert_eq!(r.temp_lsb, 256);
    assert_eq!(r.accel_lsb, [1, -1, -8192]);
    assert_eq!(r.gyro_lsb, [2, -2, 0]);
    let s = imu.to_si(&r);
    assert!(
        (s.accel_mps2[2] + 9.806_65).abs() < 1e-5,
        "-8192 LSB at +-4 g is -1 g"
    );
    spi.done();
}

#[test]
fn a_missed_status_read_does_not_stop_the_data_ready_edges() {
    // The chip model's INT1 (hal-sim, from the datasheet: pulsed or
    // latched) after the driver's init: an edge every sample although no
    // sample is ever read, as the tick's EXTI needs (a latched line stays
    // high after one missed INT_STATUS read: no edge again, the tick stops).
    use embedded_hal::digital::InputPin;
    let b = bench(0.0);
    let _imu = initialised(&b, Odr::Hz1000);
    let mut pin = hal_sim::drivers::SimDrdy(b.clone());
    let (mut was, mut edges) = (pin.is_high().unwrap(), 0);
    // 100 ms in 20 us steps, INT_STATUS never read.
    for _ in 0..5_000 {
        let t = b.borrow().now_ns + 20_000;
        b.borrow_mut().advance_to(t);
        let high = pin.is_high().unwrap();
        edges += usize::from(high && !was);
        was = high;
    }
    // One a sample at 1 kHz (a sample at either end may fall outside).
    assert!(
        (99..=101).contains(&edges),
        "{edges} rising edges in 100 ms"
    );
}

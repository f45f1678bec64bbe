//! The ICM-42688-P model answers register-level transactions written from
//! the datasheet (DS-000347): each transaction is one chip-select frame,
//! MOSI bytes out and the MISO bytes expected back, embedded-hal-mock style.

use embedded_hal::digital::InputPin;
use embedded_hal::spi::{Operation, SpiDevice};
use hal_sim::bench::{Bench, BenchConfig, SharedBench};
use hal_sim::drivers::{SimDrdy, SimSpi};
use hal_sim::imu::ImuSpec;

const READ: u8 = 0x80;
const DEVICE_CONFIG: u8 = 0x11;
const INT_CONFIG: u8 = 0x14;
const TEMP_DATA1: u8 = 0x1D;
const ACCEL_DATA_Z1: u8 = 0x23;
const GYRO_DATA_X1: u8 = 0x25;
const INT_STATUS: u8 = 0x2D;
const INTF_CONFIG0: u8 = 0x4C;
const PWR_MGMT0: u8 = 0x4E;
const GYRO_CONFIG0: u8 = 0x4F;
const INT_SOURCE0: u8 = 0x65;
const WHO_AM_I: u8 = 0x75;
const REG_BANK_SEL: u8 = 0x76;

/// One expected frame: what the master clocks out, what it must read.
struct Tx(&'static [u8], &'static [u8]);

fn run(spi: &mut SimSpi, frames: &[Tx]) {
    for (i, Tx(mosi, miso)) in frames.iter().enumerate() {
        let mut got = vec![0u8; mosi.len()];
        spi.transaction(&mut [Operation::Transfer(&mut got, mosi)])
            .unwrap();
        assert_eq!(&got[..], *miso, "frame {i}: out {mosi:02x?}");
    }
}

fn bench(rate_dps: f64) -> SharedBench {
    let b = Bench::new(BenchConfig::new(ImuSpec::ideal())).shared();
    // Turn the table at a known rate without the motor: set its state and
    // give it a flywheel's inertia so back-EMF braking cannot slow it.
    b.borrow_mut().table.kin.rate = rate_dps.to_radians();
    b.borrow_mut().table.motor.inertia = 1e12;
    b.borrow_mut().table.stalled = false;
    // Power-on: the interface answers after 1 ms (datasheet start-up time).
    b.borrow_mut().advance_to(2_000_000);
    b
}

fn wait_ms(b: &SharedBench, ms: u64) {
    let t = b.borrow().now_ns + ms * 1_000_000;
    b.borrow_mut().advance_to(t);
}

#[test]
fn reset_values_identity_and_read_only_registers() {
    let b = bench(0.0);
    let mut spi = SimSpi::new(b.clone());
    run(
        &mut spi,
        &[
            // WHO_AM_I = 0x47 (Sec. 14.54).
            Tx(&[READ | WHO_AM_I, 0x00], &[0x00, 0x47]),
            // Reset values: PWR_MGMT0 0x00, GYRO_CONFIG0 0x06, ACCEL_CONFIG0 0x06.
            Tx(&[READ | PWR_MGMT0, 0, 0, 0], &[0x00, 0x00, 0x06, 0x06]),
            // INT_STATUS resets to 0x10 (RESET_DONE) and clears on read.
            Tx(&[READ | INT_STATUS, 0], &[0x00, 0x10]),
            Tx(&[READ | INT_STATUS, 0], &[0x00, 0x00]),
            // INTF_CONFIG0 0x30: big-endian sensor data.
            Tx(&[READ | INTF_CONFIG0, 0], &[0x00, 0x30]),
            // Sensors off: data registers read 0x8000 (-32768).
            Tx(
                &[READ | TEMP_DATA1, 0, 0, 0, 0],
                &[0x00, 0x80, 0x00, 0x80, 0x00],
            ),
            // WHO_AM_I is read-only.
            Tx(&[WHO_AM_I, 0x12], &[0x00, 0x00]),
            Tx(&[READ | WHO_AM_I, 0x00], &[0x00, 0x47]),
            // Bank 1 holds its own bytes; bank 0 is untouched.
            Tx(&[REG_BANK_SEL, 0x01], &[0, 0]),
            Tx(&[PWR_MGMT0, 0x5A], &[0, 0]),
            Tx(&[READ | PWR_MGMT0, 0], &[0, 0x5A]),
            Tx(&[REG_BANK_SEL, 0x00], &[0, 0]),
            Tx(&[READ | PWR_MGMT0, 0], &[0, 0x00]),
        ],
    );
}

#[test]
fn configured_sensors_deliver_big_endian_data_at_the_odr() {
    // Level, static base at the default site, table turning 100 deg/s about z:
    // gyro z = 100 + earth rate (~0.002 deg/s); accel z = -g (~ -0.9987 g).
    let b = bench(100.0);
    let mut spi = SimSpi::new(b.clone());
    let mut drdy = SimDrdy(b.clone());
    run(
        &mut spi,
        &[
            // INT1: push-pull, active high, latched; data ready routed to INT1.
            Tx(&[INT_CONFIG, 0x07], &[0, 0]),
            Tx(&[INT_SOURCE0, 0x08], &[0, 0]),
            // GYRO_CONFIG0 then ACCEL_CONFIG0 (auto-increment): +-250 deg/s
            // (FS_SEL 3), 100 Hz (ODR 0x08); +-4 g (FS_SEL 2), 100 Hz.
            Tx(&[GYRO_CONFIG0, 0x68, 0x48], &[0, 0, 0]),
            // Gyro and accel low-noise mode.
            Tx(&[PWR_MGMT0, 0x0F], &[0, 0]),
        ],
    );
    wait_ms(&b, 5);
    // Still starting (gyro 30 ms, accel 10 ms): no data yet.
    let mut buf = [0u8; 3];
    spi.transaction(&mut [Operation::Transfer(&mut buf, &[READ | GYRO_DATA_X1, 0, 0])])
        .unwrap();
    assert_eq!(&buf[1..], &[0x80, 0x00]);
    wait_ms(&b, 40);
    assert!(drdy.is_high().unwrap(), "latched data-ready");
    // Burst read: temperature, accel x y z, gyro x y z (14 bytes).
    let mut rx = [0u8; 15];
    let mut tx = [0u8; 15];
    tx[0] = READ | TEMP_DATA1;
    spi.transaction(&mut [Operation::Transfer(&mut rx, &tx)])
        .unwrap();
    let word = |i: usize| i16::from_be_bytes([rx[1 + 2 * i], rx[2 + 2 * i]]);
    let temp_c = f64::from(word(0)) / 132.48 + 25.0;
    let az_g = f64::from(word(3)) / 8192.0; // +-4 g: 8192 LSB/g
    let gz_dps = f64::from(word(6)) / 131.072; // +-250 deg/s: 32768/250 LSB/(deg/s) ("131")
    assert!((temp_c - 25.0).abs() < 0.01, "{temp_c}");
    assert!((az_g + 0.9987).abs() < 1.5e-4, "{az_g}");
    assert!((gz_dps - 100.0).abs() < 0.01, "{gz_dps}");
    // Reading INT_STATUS shows DATA_RDY (and RESET_DONE, pending since
    // power-on: nobody read it yet) and releases the latched line.
    run(&mut spi, &[Tx(&[READ | INT_STATUS, 0], &[0, 0x18])]);
    assert!(drdy.is_low().unwrap());
    // 10 ms later (100 Hz) a new sample raises it again.
    wait_ms(&b, 10);
    assert!(drdy.is_high().unwrap());
    // Little-endian data on request (INTF_CONFIG0 bit 4 cleared).
    run(&mut spi, &[Tx(&[INTF_CONFIG0, 0x20], &[0, 0])]);
    wait_ms(&b, 10);
    let mut rx2 = [0u8; 3];
    spi.transaction(&mut [Operation::Transfer(&mut rx2, &[READ | ACCEL_DATA_Z1, 0, 0])])
        .unwrap();
    let az_le = i16::from_le_bytes([rx2[1], rx2[2]]);
    assert!((f64::from(az_le) / 8192.0 + 0.9987).abs() < 1.5e-4);
}

#[test]
fn soft_reset_restores_defaults_after_one_ms() {
    let b = bench(0.0);
    let mut spi = SimSpi::new(b.clone());
    run(
        &mut spi,
        &[
            Tx(&[PWR_MGMT0, 0x0F], &[0, 0]),
            Tx(&[DEVICE_CONFIG, 0x01], &[0, 0]),
        ],
    );
    // During the reset the interface answers nothing.
    run(&mut spi, &[Tx(&[READ | WHO_AM_I, 0], &[0, 0x00])]);
    wait_ms(&b, 2);
    run(
        &mut spi,
        &[
            Tx(&[READ | WHO_AM_I, 0], &[0, 0x47]),
            Tx(&[READ | PWR_MGMT0, 0], &[0, 0x00]),
            Tx(&[READ | INT_STATUS, 0], &[0, 0x10]),
        ],
    );
}

#[test]
fn pulsed_interrupt_lasts_100_us() {
    let b = bench(0.0);
    let mut spi = SimSpi::new(b.clone());
    let mut drdy = SimDrdy(b.clone());
    run(
        &mut spi,
        &[
            Tx(&[INT_CONFIG, 0x03], &[0, 0]), // pulsed, push-pull, active high
            Tx(&[INT_SOURCE0, 0x08], &[0, 0]),
            Tx(&[GYRO_CONFIG0, 0x08, 0x08], &[0, 0, 0]),
            Tx(&[PWR_MGMT0, 0x0F], &[0, 0]),
        ],
    );
    // After start-up, step 10 us at a time over 100 ms and count rising
    // edges and the high time: 10 pulses (100 Hz) of 100 us.
    wait_ms(&b, 50);
    let (mut edges, mut high_us, mut last) = (0, 0, drdy.is_high().unwrap());
    for _ in 0..10_000 {
        let t = b.borrow().now_ns + 10_000;
        b.borrow_mut().advance_to(t);
        let h = drdy.is_high().unwrap();
        if h && !last {
            edges += 1;
        }
        if h {
            high_us += 10;
        }
        last = h;
    }
    assert_eq!(edges, 10);
    assert_eq!(high_us, 1_000);
}

#[test]
fn injected_faults_show_at_the_interface() {
    let b = bench(0.0);
    let mut spi = SimSpi::new(b.clone());
    run(
        &mut spi,
        &[
            Tx(&[GYRO_CONFIG0, 0x08, 0x08], &[0, 0, 0]),
            Tx(&[PWR_MGMT0, 0x0F], &[0, 0]),
        ],
    );
    wait_ms(&b, 50);
    b.borrow_mut().chip.faults.who_am_i = Some(0x00);
    run(&mut spi, &[Tx(&[READ | WHO_AM_I, 0], &[0, 0x00])]);
    b.borrow_mut().chip.faults.who_am_i = None;
    b.borrow_mut().chip.faults.saturated = true;
    wait_ms(&b, 10);
    run(
        &mut spi,
        &[Tx(&[READ | GYRO_DATA_X1, 0, 0], &[0, 0x7F, 0xFF])],
    );
    b.borrow_mut().chip.faults.saturated = false;
    b.borrow_mut().chip.faults.stuck = true;
    let mut a = [0u8; 13];
    let mut c = [0u8; 13];
    let tx = {
        let mut t = [0u8; 13];
        t[0] = READ | 0x1F;
        t
    };
    spi.transaction(&mut [Operation::Transfer(&mut a, &tx)])
        .unwrap();
    wait_ms(&b, 100);
    spi.transaction(&mut [Operation::Transfer(&mut c, &tx)])
        .unwrap();
    assert_eq!(a, c, "stuck data does not change");
    b.borrow_mut().chip.faults.spi_error = true;
    let mut x = [0u8; 2];
    assert!(spi
        .transaction(&mut [Operation::Transfer(&mut x, &[READ | WHO_AM_I, 0])])
        .is_err());
}

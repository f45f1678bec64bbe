//! The bench: one simulated world (site, base, table with its motor,
//! encoder, the IMU chip) that advances in simulated time, shared by the
//! mock drivers in [`crate::drivers`]. Faults are injected here.

use crate::icm42688::Icm42688;
use crate::imu::{ImuModel, ImuSpec};
use crate::world::{Bump, EncoderSpec, Geometry, MotorParams, Scene, Site, Table};
use core_nav::attitude::Euler;
use core_nav::table::Axis;
use std::cell::RefCell;
use std::rc::Rc;

/// What the bench is made of.
#[derive(Clone, Debug)]
pub struct BenchConfig {
    /// Sensor error budget (its quantisation and saturation are replaced
    /// by the chip's own, per its configured full scale).
    pub imu: ImuSpec,
    /// Site.
    pub site: Site,
    /// Base attitude.
    pub base: Euler<f64>,
    /// Table geometry.
    pub geometry: Geometry,
    /// Encoder.
    pub encoder: EncoderSpec,
    /// Motor.
    pub motor: MotorParams,
    /// Seed.
    pub seed: u64,
}

impl BenchConfig {
    /// The board's chip on a z table at the default site.
    pub fn new(imu: ImuSpec) -> Self {
        Self {
            imu,
            site: Site::new(30.53, 20.0),
            base: Euler::default(),
            geometry: Geometry::perfect(Axis::Z),
            encoder: EncoderSpec::default(),
            motor: MotorParams::default(),
            seed: 1,
        }
    }
}

/// Faults outside the chip (see [`crate::icm42688::ChipFaults`] for the chip's).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BenchFaults {
    /// Counts added to the encoder counter (a glitch: noise on the lines).
    pub encoder_offset_counts: i64,
    /// The counter stops counting (missed counts: a loose connector).
    pub encoder_frozen: bool,
    /// The table is jammed.
    pub motor_stall: bool,
}

/// The simulated world behind the drivers.
#[derive(Debug)]
pub struct Bench {
    /// Simulated time, ns.
    pub now_ns: u64,
    /// Site, base and geometry.
    pub scene: Scene,
    /// Table mechanics and motor.
    pub table: Table,
    /// Sensing element.
    pub imu: ImuModel,
    /// The chip's registers.
    pub chip: Icm42688,
    /// Encoder.
    pub encoder: EncoderSpec,
    /// PWM compare value and its maximum.
    pub pwm_duty: u16,
    /// Maximum PWM compare value.
    pub pwm_max: u16,
    /// Direction pin (high = positive rotation).
    pub dir_forward: bool,
    /// Injected faults.
    pub faults: BenchFaults,
    frozen_count: Option<i64>,
    next_phys_ns: u64,
    next_sample_ns: u64,
}

/// The bench shared by all drivers.
pub type SharedBench = Rc<RefCell<Bench>>;

/// Physics step, ns (1 kHz).
const PHYS_NS: u64 = 1_000_000;

impl Bench {
    /// A bench at t = 0, table at rest, chip just powered.
    pub fn new(cfg: BenchConfig) -> Self {
        let mut spec = cfg.imu.clone();
        for t in [&mut spec.gyro, &mut spec.accel] {
            t.lsb = 0.0;
            t.full_scale = 0.0;
        }
        Self {
            now_ns: 0,
            scene: Scene {
                site: cfg.site,
                base: cfg.base,
                geometry: cfg.geometry,
                bump: None,
            },
            table: Table::new(cfg.motor),
            imu: ImuModel::new(spec, cfg.seed),
            chip: Icm42688::new(),
            encoder: cfg.encoder,
            pwm_duty: 0,
            pwm_max: 1000,
            dir_forward: true,
            faults: BenchFaults::default(),
            frozen_count: None,
            next_phys_ns: 0,
            next_sample_ns: 0,
        }
    }

    /// Wraps the bench for the drivers.
    pub fn shared(self) -> SharedBench {
        Rc::new(RefCell::new(self))
    }

    /// Sets a bump of the base.
    pub fn bump(&mut self, b: Bump) {
        self.scene.bump = Some(b);
    }

    /// Motor terminal voltage from PWM and direction, V.
    pub fn motor_voltage(&self) -> f64 {
        let d = f64::from(self.pwm_duty.min(self.pwm_max)) / f64::from(self.pwm_max.max(1));
        let v = d * self.table.motor.supply_v;
        if self.dir_forward {
            v
        } else {
            -v
        }
    }

    /// Advances the world to `t_ns`: physics at 1 kHz, chip samples at its
    /// data rate.
    pub fn advance_to(&mut self, t_ns: u64) {
        while self.next_phys_ns <= t_ns || self.next_sample_ns <= t_ns {
            if self.next_sample_ns < self.next_phys_ns {
                let t = self.next_sample_ns;
                self.sample_chip(t);
            } else {
                let t = self.next_phys_ns;
                self.table.stalled = self.faults.motor_stall;
                let v = self.motor_voltage();
                self.table.step(PHYS_NS as f64 * 1e-9, v, 0.0);
                self.next_phys_ns = t + PHYS_NS;
            }
        }
        self.now_ns = self.now_ns.max(t_ns);
    }

    fn sample_chip(&mut self, t_ns: u64) {
        let period_ns = match self.chip.data_rate_hz() {
            Some(hz) => (1e9 / hz).round() as u64,
            None => {
                // Sensors off: look again in 1 ms.
                self.next_sample_ns = t_ns + PHYS_NS;
                return;
            }
        };
        let t_s = t_ns as f64 * 1e-9;
        let (w, f) = self.scene.truth(&self.table.kin, t_s);
        let temp = self.imu.temperature_c(t_s);
        let (g, a) = self.imu.measure(&w, &f, temp, period_ns as f64 * 1e-9);
        let (w_dps, f_g) = Icm42688::si_to_chip([g.x, g.y, g.z], [a.x, a.y, a.z]);
        self.chip.new_sample(t_ns, w_dps, f_g, temp);
        self.next_sample_ns = t_ns + period_ns;
    }

    /// The encoder's hardware counter now (the bench reads the disc as it is
    /// now; encoder latency is modelled by [`crate::sim`]).
    pub fn encoder_hw_count(&mut self) -> u16 {
        let live = self.encoder.count(self.table.kin.theta) + self.faults.encoder_offset_counts;
        let c = if self.faults.encoder_frozen {
            *self.frozen_count.get_or_insert(live)
        } else {
            self.frozen_count = None;
            live
        };
        EncoderSpec::hw_count(c)
    }
}

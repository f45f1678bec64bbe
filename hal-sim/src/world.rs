//! The world the IMU lives in: site, base, turntable geometry, the table's
//! motor and encoder, and the true kinematics of the sensor.
//!
//! Frames as in `core-nav`. The platform frame `p` turns relative to `b`
//! about the *true* axis `k_t` (the nominal axis `k` tilted by
//! `axis_tilt`); the sensor is mounted on the platform with a small fixed
//! rotation `wobble` (`c_s_p = exp(wobble x)`), so its axes cone around the
//! axis once per revolution; its origin sits `lever_arm_s` (m, in `s`) from
//! the axis. With the platform angle `theta`:
//!
//! ```text
//! c_p_b = exp(theta [k_t x]),  c_s_b = c_p_b c_s_p,  c_s_n = c_b_n c_s_b
//! w_is_s = c_n_s w_ie_n + c_p_s k_t theta_dot + c_b_s w_bump_b
//! f_s    = c_n_s [0, 0, -g] + c_p_s (theta_ddot k_t x r_p + theta_dot^2 k_t x (k_t x r_p)) + c_b_s a_bump_b
//! ```
//! with `r_p = c_s_p lever_arm_s`.

use core_nav::attitude::Euler;
use core_nav::control::{MotorModel, RateController};
use core_nav::table::{Axis, EncoderScale};
use nalgebra::{Matrix3, Rotation3, Vector3};

/// Where the run happens: core-nav's site (gravity, earth rate, the ideal
/// sensor), the one home of that physics.
pub use core_nav::site::Site;

/// A short shake of the base that comes back to where it was: rate and
/// acceleration are one full sine period each, so attitude and velocity
/// return (a knock on the bench, a person leaning on it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bump {
    /// Start, s.
    pub t_s: f64,
    /// Duration, s.
    pub duration_s: f64,
    /// Peak angular rate of the base, rad/s, in `b`.
    pub rate_b: Vector3<f64>,
    /// Peak acceleration of the base, m/s^2, in `b`.
    pub accel_b: Vector3<f64>,
}

impl Bump {
    /// `(w_bump_b, a_bump_b)` at `t` s.
    pub fn at(&self, t: f64) -> (Vector3<f64>, Vector3<f64>) {
        let tau = (t - self.t_s) / self.duration_s;
        if !(0.0..1.0).contains(&tau) {
            return (Vector3::zeros(), Vector3::zeros());
        }
        let s = (core::f64::consts::TAU * tau).sin();
        (self.rate_b * s, self.accel_b * s)
    }
}

/// Table geometry, including what a model may leave out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// Nominal axis.
    pub axis: Axis,
    /// Small rotation (rad, in `b`) taking the nominal axis to the true one.
    pub axis_tilt: Vector3<f64>,
    /// Fixed small rotation of the sensor on the platform, rad.
    pub wobble: Vector3<f64>,
    /// The mount wobbling with the table angle (`table_angle_harmonic`): a
    /// small rotation added to `wobble`, `delta(theta) = sum over n = 1, 2
    /// of (a cos(n theta) + b sin(n theta)) u1 + (c cos(n theta) + d
    /// sin(n theta)) u2`, `u1`, `u2` the normals of the axis
    /// ([`Geometry::normals`]); `[a, b, c, d]` per harmonic, rad.
    pub wobble_harmonics: [[f64; 4]; 2],
    /// Sensor origin from the axis, m, in `s`.
    pub lever_arm_s: Vector3<f64>,
}

impl Geometry {
    /// A perfect table about `axis`.
    pub fn perfect(axis: Axis) -> Self {
        Self {
            axis,
            axis_tilt: Vector3::zeros(),
            wobble: Vector3::zeros(),
            wobble_harmonics: [[0.0; 4]; 2],
            lever_arm_s: Vector3::zeros(),
        }
    }

    /// The axis's two normals `u1`, `u2` (`u1 x u2 = k`), in the order of
    /// the basis axes after `k`.
    pub fn normals(&self) -> [Vector3<f64>; 2] {
        let k = self.axis.unit::<f64>();
        let i = k.iamax();
        [
            Vector3::ith((i + 1) % 3, 1.0),
            Vector3::ith((i + 2) % 3, 1.0),
        ]
    }

    /// The angle-locked part of the mount's rotation at `theta`, rad, and
    /// its derivative in `theta` (rad per rad).
    pub fn wobble_at(&self, theta: f64) -> (Vector3<f64>, Vector3<f64>) {
        let [u1, u2] = self.normals();
        let mut d = Vector3::zeros();
        let mut dd = Vector3::zeros();
        for (n, [a, b, c, e]) in self.wobble_harmonics.iter().enumerate() {
            if [a, b, c, e].iter().all(|x| **x == 0.0) {
                continue; // adds zeros: skip its sine
            }
            let nf = (n + 1) as f64;
            let (sn, cs) = (nf * theta).sin_cos();
            d += u1 * (a * cs + b * sn) + u2 * (c * cs + e * sn);
            dd += (u1 * (-a * sn + b * cs) + u2 * (-c * sn + e * cs)) * nf;
        }
        (d, dd)
    }

    /// The true axis `k_t` (same in `b` and `p`).
    pub fn k_true(&self) -> Vector3<f64> {
        Rotation3::from_scaled_axis(self.axis_tilt) * self.axis.unit::<f64>()
    }

    /// `c_s_p` at platform angle `theta` (rad): the fixed wobble and the
    /// angle-locked one.
    pub fn c_s_p(&self, theta: f64) -> Matrix3<f64> {
        self.mount(self.k_true(), theta, None).c_s_p
    }

    /// `c_s_b` at platform angle `theta` (rad).
    pub fn c_s_b(&self, theta: f64) -> Matrix3<f64> {
        self.mount(self.k_true(), theta, None).c_s_b
    }

    /// The sensor's mount at platform angle `theta` (rad) about the true
    /// axis `k_t` ([`Geometry::k_true`]), each part computed once.
    /// `still_c_s_p`: `c_s_p` when the mount does not rock with the angle
    /// ([`Geometry::still_c_s_p`]), made once.
    fn mount(&self, k_t: Vector3<f64>, theta: f64, still_c_s_p: Option<&Matrix3<f64>>) -> Mount {
        let (c_s_p, dw) = match still_c_s_p {
            Some(c) => (*c, Vector3::zeros()),
            None => {
                let (w, dw) = self.wobble_at(theta);
                (*Rotation3::from_scaled_axis(self.wobble + w).matrix(), dw)
            }
        };
        Mount {
            k_t,
            c_s_p,
            c_s_b: Rotation3::from_scaled_axis(k_t * theta).matrix() * c_s_p,
            dwobble: dw,
        }
    }

    /// `c_s_p` when the mount does not rock with the table angle (no
    /// wobble harmonics): the same at every angle.
    pub fn still_c_s_p(&self) -> Option<Matrix3<f64>> {
        self.wobble_harmonics
            .iter()
            .flatten()
            .all(|x| *x == 0.0)
            .then(|| *Rotation3::from_scaled_axis(self.wobble).matrix())
    }

    /// The rate of the sensor on its platform, rad/s in `s` (small
    /// angles): the angle-locked wobble turning with the table.
    pub fn wobble_rate(&self, k: &Kinematics) -> Vector3<f64> {
        self.wobble_at(k.theta).1 * k.rate
    }
}

/// [`Geometry`] at one platform angle: what the truth needs of it.
struct Mount {
    /// The true axis (in `b` and `p`).
    k_t: Vector3<f64>,
    /// `c_s_p`.
    c_s_p: Matrix3<f64>,
    /// `c_s_b`.
    c_s_b: Matrix3<f64>,
    /// The angle-locked wobble's derivative in the angle, rad per rad.
    dwobble: Vector3<f64>,
}

/// The table turns (a stepper steps, so the motion the track cannot follow
/// is there) above this rate, rad/s: 5 deg/s, well above any drift of a
/// table held still and below the slowest scheme a table runs.
pub const TURNING_RADPS: f64 = 0.0873;

/// Table motion between encoder reads that the encoder track cannot follow
/// and the IMU's samples alias (`untracked_table_motion`: a stepper's
/// steps, cogging, a servo's buzz). Modelled as white rate noise about the
/// table axis while the table turns: the gyros see it, the encoder does
/// not (its angle stays within the encoder's quantum between reads).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UntrackedMotion {
    /// Density of the rate noise, rad/sqrt(s) (0: none).
    pub density_rad_per_sqrt_s: f64,
}

impl UntrackedMotion {
    /// The rate one sample sees on top of the table's, rad/s about the
    /// table axis: white over the sample period `dt_s`, while the table
    /// turns faster than [`TURNING_RADPS`]. Draws from `rng` only when the
    /// motion is there (runs without it keep their bits).
    pub fn rate(&self, rng: &mut crate::rng::Rng, table_rate_radps: f64, dt_s: f64) -> f64 {
        if self.density_rad_per_sqrt_s <= 0.0 || table_rate_radps.abs() <= TURNING_RADPS {
            return 0.0;
        }
        self.density_rad_per_sqrt_s / dt_s.max(1e-9).sqrt() * rng.normal()
    }
}

/// Angle, rate and acceleration of the platform about the true axis.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Kinematics {
    /// rad (unwrapped).
    pub theta: f64,
    /// rad/s.
    pub rate: f64,
    /// rad/s^2.
    pub accel: f64,
}

/// A static base with its table: computes what an ideal sensor would feel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scene {
    /// Site.
    pub site: Site,
    /// Base attitude in `n`.
    pub base: Euler<f64>,
    /// Table geometry.
    pub geometry: Geometry,
    /// Optional bump of the base.
    pub bump: Option<Bump>,
}

/// The parts of a [`Scene`] that no sample changes, made once per run
/// ([`Scene::fixed`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneFixed {
    /// The true table axis ([`Geometry::k_true`]).
    k_t: Vector3<f64>,
    /// `c_n_b`, the base's attitude (transposed).
    c_n_b: Matrix3<f64>,
    /// What a body at rest on the site feels.
    at_rest: core_nav::site::AtRest,
    /// [`Geometry::still_c_s_p`].
    still_c_s_p: Option<Matrix3<f64>>,
}

impl Scene {
    /// `c_b_n`.
    pub fn c_b_n(&self) -> Matrix3<f64> {
        core_nav::site::c_b_n(&self.base)
    }

    /// What [`Scene::truth_in`] needs that no sample changes.
    pub fn fixed(&self) -> SceneFixed {
        SceneFixed {
            k_t: self.geometry.k_true(),
            c_n_b: self.c_b_n().transpose(),
            at_rest: self.site.at_rest(),
            still_c_s_p: self.geometry.still_c_s_p(),
        }
    }

    /// True `(w_is_s rad/s, f_s m/s^2)` on a moving base: the vehicle's
    /// `(w_ib_b, f_b)` at `t_s` (`drive::VehicleState::ideal_b`) turned into
    /// the sensor on the table at kinematics `k`, the table's own rate and
    /// lever-arm terms added as on a static base (`site` and `base` unused;
    /// `fx` is [`Scene::fixed`]).
    pub fn truth_on_vehicle(
        &self,
        fx: &SceneFixed,
        k: &Kinematics,
        t_s: f64,
        w_ib_b: &Vector3<f64>,
        f_b: &Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let t = self.table_terms(fx, k, t_s);
        (
            t.c_b_s * (w_ib_b + t.w_bump_b) + t.w_table_s + t.w_wobble_s,
            t.c_b_s * (f_b + t.a_bump_b) + t.a_lever_s,
        )
    }

    /// True `(w_is_s rad/s, f_s m/s^2)` for platform kinematics `k` at `t_s`.
    pub fn truth(&self, k: &Kinematics, t_s: f64) -> (Vector3<f64>, Vector3<f64>) {
        self.truth_in(&self.fixed(), k, t_s)
    }

    /// [`Scene::truth`] given [`Scene::fixed`] (a run's samples share it).
    pub fn truth_in(
        &self,
        fx: &SceneFixed,
        k: &Kinematics,
        t_s: f64,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let t = self.table_terms(fx, k, t_s);
        let c_n_s = t.c_b_s * fx.c_n_b;
        let (w_ideal, f_ideal) = fx.at_rest.ideal_imu(&c_n_s, &t.w_table_s);
        (
            w_ideal + t.c_b_s * t.w_bump_b + t.w_wobble_s,
            f_ideal + t.a_lever_s + t.c_b_s * t.a_bump_b,
        )
    }

    /// What the table and the bump add at kinematics `k` and `t_s`, on a
    /// static base and a vehicle alike.
    fn table_terms(&self, fx: &SceneFixed, k: &Kinematics, t_s: f64) -> TableTerms {
        let g = &self.geometry;
        let Mount {
            k_t: kt,
            c_s_p,
            c_s_b,
            dwobble,
        } = g.mount(fx.k_t, k.theta, fx.still_c_s_p.as_ref());
        let c_p_s = c_s_p.transpose();
        let (w_bump_b, a_bump_b) = self
            .bump
            .map_or((Vector3::zeros(), Vector3::zeros()), |b| b.at(t_s));
        let r_p = c_s_p * g.lever_arm_s;
        let a_lever_p = kt.cross(&r_p) * k.accel + kt.cross(&kt.cross(&r_p)) * (k.rate * k.rate);
        TableTerms {
            c_b_s: c_s_b.transpose(),
            w_table_s: c_p_s * (kt * k.rate),
            w_wobble_s: dwobble * k.rate,
            a_lever_s: c_p_s * a_lever_p,
            w_bump_b,
            a_bump_b,
        }
    }
}

/// [`Scene::table_terms`]: the sensor's attitude on the base and what the
/// table's turning and the base's bump add.
struct TableTerms {
    /// `c_b_s`.
    c_b_s: Matrix3<f64>,
    /// The table's rate in `s`, rad/s.
    w_table_s: Vector3<f64>,
    /// The angle-locked wobble's rate in `s`, rad/s.
    w_wobble_s: Vector3<f64>,
    /// The lever arm's centripetal and tangential acceleration in `s`, m/s^2.
    a_lever_s: Vector3<f64>,
    /// The bump's rate in `b`, rad/s.
    w_bump_b: Vector3<f64>,
    /// The bump's acceleration in `b`, m/s^2.
    a_bump_b: Vector3<f64>,
}

/// DC motor driving the table directly through an H-bridge, and the
/// table's mechanics. The electrical time constant (L/R, ~0.1 ms) is far
/// below the 1 ms physics step and is neglected: `i = (V - Ke w) / R`.
///
/// `J w' = Kt i (1 + ripple(theta)) - b w - Tc sign(w) - cogging(theta) + T_ext`
#[derive(Clone, Debug, PartialEq)]
pub struct MotorParams {
    /// Inertia of table + IMU, kg m^2.
    pub inertia: f64,
    /// Torque constant, N m/A (= back-EMF constant, V s/rad).
    pub kt: f64,
    /// Winding resistance, ohm.
    pub resistance: f64,
    /// Supply voltage, V.
    pub supply_v: f64,
    /// Viscous friction, N m s/rad.
    pub viscous: f64,
    /// Coulomb friction, N m (also the breakaway torque).
    pub coulomb: f64,
    /// Cogging torque harmonics: (cycles per revolution, amplitude N m, phase rad).
    pub cogging: Vec<(f64, f64, f64)>,
    /// Torque ripple: (cycles per revolution, relative amplitude).
    pub ripple: Vec<(f64, f64)>,
}

impl Default for MotorParams {
    /// The board's motor ([`MotorModel::default`], the numbers the
    /// controller's feed-forward uses) with 24-slot cogging and 6-cycle
    /// torque ripple, which the controller does not know.
    fn default() -> Self {
        let m = MotorModel::<f64>::default();
        Self {
            inertia: m.inertia,
            kt: m.kt,
            resistance: m.resistance,
            supply_v: m.supply_v,
            viscous: m.viscous,
            coulomb: m.coulomb,
            cogging: vec![(24.0, 2e-3, 0.3)],
            ripple: vec![(6.0, 0.01)],
        }
    }
}

impl MotorParams {
    /// The motor as a controller's feed-forward knows it.
    pub fn model(&self) -> MotorModel<f64> {
        MotorModel {
            inertia: self.inertia,
            kt: self.kt,
            resistance: self.resistance,
            supply_v: self.supply_v,
            viscous: self.viscous,
            coulomb: self.coulomb,
        }
    }

    /// Net torque (N m) at angle `theta`, rate `w`, terminal voltage `v`,
    /// excluding Coulomb friction: each harmonic by its own sine (the
    /// reference form; [`Table::step`] gets the same sums from one phasor).
    pub fn torque(&self, theta: f64, w: f64, v: f64) -> f64 {
        let ripple: f64 = self.ripple.iter().map(|(n, a)| a * (n * theta).sin()).sum();
        let cog: f64 = self
            .cogging
            .iter()
            .map(|(n, a, ph)| a * (n * theta + ph).sin())
            .sum();
        self.torque_of(ripple, cog, w, v)
    }

    /// The torque given the ripple's and the cogging's sums at the angle.
    fn torque_of(&self, ripple: f64, cog: f64, w: f64, v: f64) -> f64 {
        let i = (v - self.kt * w) / self.resistance;
        self.kt * i * (1.0 + ripple) - self.viscous * w - cog
    }
}

/// A unit complex number e^(i x): the motor's harmonics as powers of one.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Phasor {
    re: f64,
    im: f64,
}

impl Phasor {
    const ONE: Phasor = Phasor { re: 1.0, im: 0.0 };

    /// e^(i x), by the sine and cosine.
    fn of(x: f64) -> Self {
        let (im, re) = x.sin_cos();
        Self { re, im }
    }

    /// e^(i x); below 0.1 rad by its Taylor series to the 9th power
    /// (remainder below 0.1^10 / 10! = 3e-17), else [`Phasor::of`].
    fn of_small(x: f64) -> Self {
        if x.abs() >= 0.1 {
            return Self::of(x);
        }
        let x2 = x * x;
        let re = 1.0 - x2 / 2.0 * (1.0 - x2 / 12.0 * (1.0 - x2 / 30.0 * (1.0 - x2 / 56.0)));
        let im = x * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0))));
        Self { re, im }
    }

    fn mul(self, o: Self) -> Self {
        Self {
            re: self.re * o.re - self.im * o.im,
            im: self.re * o.im + self.im * o.re,
        }
    }

    /// The `k`-th power, by squaring.
    fn pow(self, mut k: u32) -> Self {
        let (mut acc, mut b) = (Self::ONE, self);
        while k > 0 {
            if k & 1 == 1 {
                acc = acc.mul(b);
            }
            b = b.mul(b);
            k >>= 1;
        }
        acc
    }
}

fn gcd(a: u32, b: u32) -> u32 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// A ripple harmonic: (cycles per revolution, relative amplitude).
type Ripple = (f64, f64);
/// A cogging harmonic: (cycles per revolution, amplitude N m, phase rad).
type Cogging = (f64, f64, f64);
/// A harmonic as a power of the fundamental's phasor: (power, amplitude,
/// e^(i phase)).
type PowerTerm = (u32, f64, Phasor);
/// The fundamental g, the ripple's (power, amplitude), the cogging's terms.
type Plan = (u32, Vec<(u32, f64)>, Vec<PowerTerm>);

/// Steps between exact phasors: the step-to-step product's rounding (1e-16
/// a step) stays below 1e-13.
const RESYNC_STEPS: u32 = 1024;

/// The motor's torque harmonics as whole powers of one phasor e^(i g
/// theta), g their common fundamental (cycles per revolution): one sine
/// and cosine every [`RESYNC_STEPS`] steps instead of a sine per harmonic
/// and torque evaluation (five a step). Orders that are not whole numbers
/// fall back to their sines.
#[derive(Clone, Debug, PartialEq)]
struct Harmonics {
    /// The motor's ripple and cogging this was made from.
    source: (Vec<Ripple>, Vec<Cogging>),
    /// g, the ripple's (power, amplitude), the cogging's (power,
    /// amplitude, e^(i phase)); `None`: an order is not whole.
    plan: Option<Plan>,
    /// The angle of the last step's end and e^(i g theta) there, with
    /// the steps since it was exact.
    at: Option<(f64, Phasor, u32)>,
}

impl Harmonics {
    fn new(m: &MotorParams) -> Self {
        let orders = m
            .ripple
            .iter()
            .map(|r| r.0)
            .chain(m.cogging.iter().map(|c| c.0));
        let whole = orders
            .clone()
            .all(|n| n.fract() == 0.0 && (1.0..=1e6).contains(&n));
        let g = orders.fold(0u32, |g, n| gcd(g, n as u32));
        let plan = (whole && g > 0).then(|| {
            (
                g,
                m.ripple.iter().map(|(n, a)| (*n as u32 / g, *a)).collect(),
                m.cogging
                    .iter()
                    .map(|(n, a, ph)| (*n as u32 / g, *a, Phasor::of(*ph)))
                    .collect(),
            )
        });
        Self {
            source: (m.ripple.clone(), m.cogging.clone()),
            plan,
            at: None,
        }
    }

    fn made_from(&self, m: &MotorParams) -> bool {
        self.source.0 == m.ripple && self.source.1 == m.cogging
    }

    /// e^(i g theta), from the last step's end when `theta` is it.
    fn phasor(&self, theta: f64) -> Option<(u32, Phasor)> {
        let (g, ..) = self.plan.as_ref()?;
        Some(match self.at {
            Some((t, z, _)) if t == theta => (*g, z),
            _ => (*g, Phasor::of(f64::from(*g) * theta)),
        })
    }

    /// The harmonics at a step's start `theta0`, given `z0` = e^(i g
    /// theta0): each term's sine and cosine there, from powers of `z0`.
    fn at_step(&self, z0: Option<(u32, Phasor)>, theta0: f64) -> StepHarmonics {
        let mut h = StepHarmonics {
            terms: [(0.0, 0.0, 0.0, 0.0); MAX_TERMS],
            ripple: 0,
            len: 0,
            theta0,
        };
        let (Some((g, ripple, cogging)), Some((_, z0))) = (&self.plan, z0) else {
            return h;
        };
        if ripple.len() + cogging.len() > MAX_TERMS {
            return h;
        }
        let terms = ripple
            .iter()
            .map(|(k, a)| (*k, *a, Phasor::ONE))
            .chain(cogging.iter().copied());
        for (slot, (k, a, ph)) in h.terms.iter_mut().zip(terms) {
            let z = z0.pow(k).mul(ph);
            *slot = (f64::from(k * g), a, z.im, z.re);
        }
        h.ripple = ripple.len();
        h.len = ripple.len() + cogging.len();
        h
    }

    /// Carries the phasor to the step's end `theta0 + dtheta`.
    fn advance(&mut self, z0: Option<(u32, Phasor)>, theta0: f64, dtheta: f64) {
        let Some((g, z0)) = z0 else { return };
        let n = match self.at {
            Some((t, _, n)) if t == theta0 => n + 1,
            _ => 0,
        };
        let theta = theta0 + dtheta;
        let z = if n >= RESYNC_STEPS {
            Phasor::of(f64::from(g) * theta)
        } else {
            z0.mul(Phasor::of_small(f64::from(g) * dtheta))
        };
        self.at = Some((theta, z, if n >= RESYNC_STEPS { 0 } else { n }));
    }
}

/// Harmonic terms a step keeps (more: each harmonic's own sine).
const MAX_TERMS: usize = 8;

/// The motor's harmonics at a step's start: per term (order n, amplitude,
/// sin and cos of n theta0 + phase), ripple first. Within the step,
/// sin(n (theta0 + d) + phase) = S cos(n d) + C sin(n d), with n d a few
/// hundredths of a radian: a short series, no sine.
struct StepHarmonics {
    terms: [(f64, f64, f64, f64); MAX_TERMS],
    ripple: usize,
    len: usize,
    theta0: f64,
}

impl StepHarmonics {
    /// (ripple, cogging) sums at the step's start + `d` (rad); `m`'s own
    /// sines when the terms were not kept.
    fn sums(&self, m: &MotorParams, d: f64) -> (f64, f64) {
        if self.len == 0 {
            let th = self.theta0 + d;
            let r = m.ripple.iter().map(|(n, a)| a * (n * th).sin()).sum();
            let c = m
                .cogging
                .iter()
                .map(|(n, a, ph)| a * (n * th + ph).sin())
                .sum();
            return (r, c);
        }
        let (mut r, mut c) = (0.0, 0.0);
        for (i, (n, a, s0, c0)) in self.terms.iter().take(self.len).enumerate() {
            let v = if d == 0.0 {
                *s0
            } else {
                let e = Phasor::of_small(n * d);
                s0 * e.re + c0 * e.im
            };
            if i < self.ripple {
                r += a * v;
            } else {
                c += a * v;
            }
        }
        (r, c)
    }
}

/// The table's mechanical state under a motor, stepped by RK4 with
/// Coulomb friction and stiction handled at rest.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// Motor and mechanics.
    pub motor: MotorParams,
    /// Platform state.
    pub kin: Kinematics,
    /// A stalled table does not turn (jammed by a cable, a hand).
    pub stalled: bool,
    /// The motor's harmonics, ready for a step (remade if `motor`'s
    /// change).
    harmonics: Harmonics,
}

impl Table {
    /// A table at rest at angle 0.
    pub fn new(motor: MotorParams) -> Self {
        Self {
            harmonics: Harmonics::new(&motor),
            motor,
            kin: Kinematics::default(),
            stalled: false,
        }
    }

    /// Advances `dt` s with terminal voltage `v` (duty x supply, signed) and
    /// external torque `t_ext` (N m).
    pub fn step(&mut self, dt: f64, v: f64, t_ext: f64) {
        let v = v.clamp(-self.motor.supply_v, self.motor.supply_v);
        if self.stalled {
            self.kin.rate = 0.0;
            self.kin.accel = 0.0;
            return;
        }
        if !self.harmonics.made_from(&self.motor) {
            self.harmonics = Harmonics::new(&self.motor);
        }
        let (th, w) = (self.kin.theta, self.kin.rate);
        let z0 = self.harmonics.phasor(th);
        let h = self.harmonics.at_step(z0, th);
        // Stiction, only at rest: the drive below breakaway, stay.
        let mut drive_sign = 1.0;
        if w == 0.0 {
            let (r, c) = h.sums(&self.motor, 0.0);
            let drive = self.motor.torque_of(r, c, 0.0, v) + t_ext;
            if drive.abs() <= self.motor.coulomb {
                self.kin.accel = 0.0;
                return;
            }
            drive_sign = drive.signum();
        }
        // The acceleration at the step's start + `dth` (rad), rate `w`:
        // `MotorParams::torque` with the divisions taken out of the stages.
        let m = &self.motor;
        let (k_amp, inv_j) = (m.kt / m.resistance, 1.0 / m.inertia);
        let f = |dth: f64, w: f64| {
            // At rest the Coulomb torque opposes the drive, not the (zero) rate.
            let w = if w == 0.0 {
                drive_sign * f64::MIN_POSITIVE
            } else {
                w
            };
            let (r, c) = h.sums(m, dth);
            let t = k_amp * (v - m.kt * w) * (1.0 + r) - m.viscous * w - c + t_ext;
            (t - m.coulomb * w.signum()) * inv_j
        };
        let k1 = (w, f(0.0, w));
        let k2 = (w + 0.5 * dt * k1.1, f(0.5 * dt * k1.0, w + 0.5 * dt * k1.1));
        let k3 = (w + 0.5 * dt * k2.1, f(0.5 * dt * k2.0, w + 0.5 * dt * k2.1));
        let k4 = (w + dt * k3.1, f(dt * k3.0, w + dt * k3.1));
        let dth = dt / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
        let th_n = th + dth;
        let mut w_n = w + dt / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
        // Friction cannot reverse the motion within a step: stop at zero.
        if w != 0.0 && w_n.signum() != w.signum() {
            w_n = 0.0;
        }
        self.harmonics.advance(z0, th, dth);
        self.kin = Kinematics {
            theta: th_n,
            rate: w_n,
            accel: (w_n - w) / dt,
        };
    }
}

/// The lab table's own servo (the console of a rate table): the board's
/// controller ([`RateController`], one controller for both) closed on the
/// table's true state (its own tachometer). The firmware replaces it in
/// closed-loop runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Servo {
    /// The controller (gains public: kp V per rad/s, ki V per rad, k_angle 1/s).
    pub ctrl: RateController<f64>,
}

impl Servo {
    /// Gains for a 25 Hz rate loop on `motor` (a lab rate table's console).
    pub fn for_motor(m: &MotorParams) -> Self {
        Self::with_bandwidth(m, 25.0)
    }

    /// Gains for a rate loop of `bandwidth_hz` on `motor`.
    pub fn with_bandwidth(m: &MotorParams, bandwidth_hz: f64) -> Self {
        Self {
            ctrl: RateController::new(m.model(), bandwidth_hz),
        }
    }

    /// Terminal voltage (V) for reference `r` given the table state `k`,
    /// after `dt` s.
    pub fn update(&mut self, r: &core_nav::scheme::Reference, k: &Kinematics, dt: f64) -> f64 {
        let duty = self.ctrl.update(r, r.angle - k.theta, k.rate, dt);
        duty * self.ctrl.motor.supply_v
    }
}

/// Encoder: a quadrature disc read into a wrapping 16-bit hardware counter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EncoderSpec {
    /// Counts per revolution (lines x 4).
    pub counts_per_rev: u32,
    /// Once-per-revolution error (eccentricity), amplitude rad.
    pub eccentricity_rad: f64,
    /// Phase of the eccentricity, rad.
    pub eccentricity_phase: f64,
    /// Latency of the reading behind its time stamp, s.
    pub latency_s: f64,
}

impl Default for EncoderSpec {
    /// 4096 lines x 4, no error.
    fn default() -> Self {
        Self {
            counts_per_rev: 16_384,
            eccentricity_rad: 0.0,
            eccentricity_phase: 0.0,
            latency_s: 0.0,
        }
    }
}

impl EncoderSpec {
    /// The angle the disc shows for platform angle `theta` (rad), before
    /// quantisation.
    pub fn shown(&self, theta: f64) -> f64 {
        theta + self.eccentricity_rad * (theta + self.eccentricity_phase).sin()
    }

    /// Unwrapped count for platform angle `theta` (floor: the quantisation
    /// error is in `[0, 1)` count).
    pub fn count(&self, theta: f64) -> i64 {
        self.scale().count_floor(self.shown(theta))
    }

    /// The counts <-> radians scale (core-nav's, the one home).
    pub fn scale(&self) -> EncoderScale {
        EncoderScale::new(self.counts_per_rev)
    }

    /// The angle a recording stores for platform angle `theta` (rad): the
    /// quantised count in radians.
    pub fn angle(&self, theta: f64) -> f64 {
        self.scale().to_rad(self.count(theta))
    }

    /// The 16-bit hardware counter for an unwrapped count.
    pub fn hw_count(count: i64) -> u16 {
        EncoderScale::hw_count(count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coulomb_friction_holds_and_releases() {
        let mut t = Table::new(MotorParams {
            cogging: vec![],
            ripple: vec![],
            ..MotorParams::default()
        });
        // 0.05 V -> 1.7 mN m < 5 mN m breakaway: stays.
        for _ in 0..100 {
            t.step(1e-3, 0.05, 0.0);
        }
        assert_eq!(t.kin.theta, 0.0);
        // 1 V -> 33 mN m: turns, settles at (Kt V/R - Tc) / (b + Kt^2/R).
        for _ in 0..20_000 {
            t.step(1e-3, 1.0, 0.0);
        }
        let m = &t.motor;
        let w_ss = (m.kt / m.resistance - m.coulomb) / (m.viscous + m.kt * m.kt / m.resistance);
        assert!(
            (t.kin.rate / w_ss - 1.0).abs() < 1e-6,
            "{} vs {w_ss}",
            t.kin.rate
        );
    }

    #[test]
    fn lever_arm_gives_centripetal_force() {
        let mut scene = Scene {
            site: Site::new(0.0, 0.0),
            base: Euler::default(),
            geometry: Geometry::perfect(Axis::Z),
            bump: None,
        };
        scene.geometry.lever_arm_s = Vector3::new(0.1, 0.0, 0.0);
        let k = Kinematics {
            theta: 0.0,
            rate: 2.0,
            accel: 0.0,
        };
        let (_, f) = scene.truth(&k, 0.0);
        // Centripetal acceleration -w^2 r along x: specific force -0.4 m/s^2.
        assert!((f.x + 0.4).abs() < 1e-12, "{f}");
    }

    /// The harmonics as one phasor's powers (carried from step to step)
    /// against each harmonic's own sine (`MotorParams::torque`, the
    /// textbook form), on whole and on fractional orders, over a run of
    /// steps longer than [`RESYNC_STEPS`].
    #[test]
    fn harmonics_by_phasor_powers_equal_the_sines() {
        let mut m = MotorParams::default();
        m.cogging.push((18.0, 1e-3, -1.1));
        let mut frac = m.clone();
        frac.ripple.push((2.5, 0.003));
        for mm in [&m, &frac] {
            let mut t = Table::new(mm.clone());
            let mut worst: f64 = 0.0;
            for k in 0..3000 {
                let v = 6.0 * (f64::from(k) * 0.002).sin();
                let th = t.kin.theta;
                let h = t.harmonics.at_step(t.harmonics.phasor(th), th);
                for d in [0.0, 1e-3, -2e-3] {
                    let (r, c) = h.sums(mm, d);
                    let w = t.kin.rate;
                    let a = mm.torque_of(r, c, w, v);
                    worst = worst.max((a - mm.torque(th + d, w, v)).abs());
                }
                t.step(1e-3, v, 0.0);
            }
            // Rounding of up to 24th powers, 1e-3 N m amplitudes and 3000
            // steps' products: far below the 1e-3 N m cogging.
            assert!(worst < 1e-13, "{worst}");
            assert!(t.kin.theta.abs() > 1.0, "the table did not turn");
            if mm.ripple.len() == 1 {
                // Carried from step to step: exact again every RESYNC_STEPS.
                let n = t.harmonics.at.map_or(0, |a| a.2);
                assert!((1..=RESYNC_STEPS).contains(&n), "{:?}", t.harmonics.at);
            }
        }
        assert!(Harmonics::new(&m).plan.is_some());
        assert!(Harmonics::new(&frac).plan.is_none());
    }
}

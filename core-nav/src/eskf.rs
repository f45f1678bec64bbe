//! Error-state Kalman filter for the aided INS (loosely coupled GNSS,
//! zero-velocity updates), `no_std`, fixed-size, generic over the float.
//!
//! # Error state (36)
//!
//! `dx = [dp (3), dv (3), phi (3), dbg (3), dba (3), dgp (3), dM (9), dMa
//! (9)]`,
//! each **truth minus estimate**: `dp` the position error in `n` (north, east, down, m; the
//! curvilinear offsets of [`crate::strapdown::NavState::p_n`]), `dv` the
//! velocity error (NED, m/s), `phi` the attitude error as a small rotation in
//! `n` (`c_s_n,true = (I + [phi x]) c_s_n,est`, rad), `dbg`, `dba` the gyro
//! and accelerometer bias errors in `s` (rad/s, m/s^2), `dM` the gyro
//! triad's scale and misalignment errors (row-major, 1: the gyros read
//! `(I + M) w`), `dMa` the accelerometer triad's (`(I + Ma) f`). On a
//! spinning table the vehicle's acceleration turns through the
//! accelerometer triad at the table rate, and the triad's anisotropy
//! (unequal scales, symmetric misalignment) becomes a ripple at twice the
//! table rate that no other state can take up. The rotation makes the biases across the table axis
//! sinusoids in `n` that average out; what it cannot modulate is the gyro
//! along its own axis, where the table's rate times a scale error is a
//! heading drift (30 deg/s x 3e-3 = 5 deg/min), and the misalignments,
//! which the vehicle's turns put into the level axes (a 90 deg turn with
//! 0.9 % misalignment tilts the solution by 0.8 deg). The table's known
//! rate makes them observable while fixes arrive.
//! `dgp` is the receiver's slowly varying position error (NED, m): GNSS
//! errors (multipath, atmosphere) are correlated over a minute, and a
//! filter that takes every fix as independent averages them down to a
//! confidence it does not have.
//!
//! # Dynamics (Groves 2nd ed. Sec. 14.2.4, local-navigation frame, the
//! small terms of gravity and transport-rate errors left out)
//!
//! ```text
//! dp'  = dv
//! dv'  = -[f_n x] phi - (2 w_ie_n + w_en_n) x dv - c_s_n dba
//!        - c_s_n dMa f_s - c_s_n n_a
//! phi' = -w_in_n x phi - c_s_n dbg - c_s_n dM w_is_s - c_s_n n_g
//! dbg' = -dbg / tau_g + w_g,   dba' = -dba / tau_a + w_a   (Gauss-Markov)
//! dgp' = -dgp / tau_gnss + w_gp,   dM' = w_M (diagonal: scale drift),
//! dMa' = 0
//! ```
//!
//! discretised as `Phi = I + F T + (F T)^2 / 2`, `Q_d` from the white noise
//! densities (the sensor's ARW / VRW are isotropic, so `c_s_n Q c_s_n^T =
//! Q`). For a spinning sensor `c_s_n` turns with the table: a bias in `s`
//! becomes a sinusoid in `n` (the rotation's point), and the filter sees it
//! as such through `c_s_n`.
//!
//! # Updates
//!
//! Measurements are processed one component at a time (the receiver's
//! sigmas are per axis: `R` is diagonal), each with the Joseph form
//! `P = (I - K h) P (I - K h)^T + K r K^T` and `P` symmetrised: no matrix
//! inverse, positive semi-definite in f32. The normalised innovation
//! squared (NIS) of a vector measurement is the sum of its components'
//! (the same as the block form's for a diagonal `R`). A component whose
//! innovation exceeds the gate is rejected and counted, never used
//! silently.
//!
//! - GNSS position of the antenna at `l_n = c_b_n l_b` from the table's
//!   centre, the receiver's error estimate `b` taken out: `z = p_gnss - (p
//!   + l_n) - b = dp - [l_n x] phi + dgp + v`, `v` the white part.
//! - GNSS velocity: `z = v_gnss - v = dv` (the lever arm's rotation term
//!   `c_b_n (w_nb_b x l_b)`, at most 3 cm/s at 30 deg/s of yaw on a 1 m arm,
//!   is added to the measurement by the caller).
//! - Zero velocity: `z = 0 - v = dv`.
//! - Zero rotation of a still base: `z = w_meas - w_true = dbg + dM w_s`
//!   in `s` (the gyros' error on the window's mean rate `w_s`).
//!
//! After an update the estimate `dx` is handed to the mechanization and the
//! biases ([`Eskf::take_correction`]): closed loop, `dx` restarts at zero.

use crate::real::Real;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Size of the error state.
pub const N: usize = 36;
/// Index of `dp` in the error state.
pub const I_P: usize = 0;
/// Index of `dv`.
pub const I_V: usize = 3;
/// Index of `phi`.
pub const I_PHI: usize = 6;
/// Index of `dbg`.
pub const I_BG: usize = 9;
/// Index of `dba`.
pub const I_BA: usize = 12;
/// Index of `dgp`, the receiver's correlated position error (NED).
pub const I_GP: usize = 15;
/// Index of `dM`, the gyro scale and misalignment errors (row-major).
pub const I_M: usize = 18;
/// Index of `dMa`, the accelerometer scale and misalignment errors
/// (row-major).
pub const I_MA: usize = 27;

/// The most states a host may add after the board's `N` (an `Eskf<T, M>`
/// with `N < M <= N + AUX_MAX`): random constants or random walks with no
/// other dynamics (a vehicle's mounting, an odometer's scale, its tyres'
/// slip), whose
/// measurement rows the host makes ([`Eskf::update_scalar`]) and whose
/// corrections it takes ([`Eskf::take_aux`]).
pub const AUX_MAX: usize = 5;

/// Covariance of the error state.
pub type Cov<T, const M: usize = N> = SMatrix<T, M, M>;
/// An error-state vector (or a measurement row).
pub type State<T, const M: usize = N> = SVector<T, M>;

/// Scratch for a propagation: two `N x N` matrices (10 KiB in f32). A
/// board keeps one in a static and passes it in (`*_in` methods), so the
/// propagation takes none of the stack; the other methods make one on the
/// stack when they propagate.
#[derive(Clone, Debug)]
pub struct Workspace<T: Real, const M: usize = N> {
    b: Cov<T, M>,
    w: Cov<T, M>,
}

impl<T: Real, const M: usize> Workspace<T, M> {
    /// Zeros.
    pub fn new() -> Self {
        Self {
            b: Cov::zeros(),
            w: Cov::zeros(),
        }
    }
}

impl<T: Real, const M: usize> Default for Workspace<T, M> {
    fn default() -> Self {
        Self::new()
    }
}

impl Eskf<f32> {
    /// A filter of zeros with `cfg` and `batch`, in a `const` (a board's
    /// static, reset in place with [`Self::reset`] before use).
    pub const fn blank(cfg: EskfConfig, batch: u32) -> Self {
        // (The caller's zeros keep the static in `.bss`.)
        Self {
            p: crate::real::zeros_f32(),
            dx: crate::real::zeros_f32(),
            bias_g: crate::real::zeros_f32(),
            bias_a: crate::real::zeros_f32(),
            gyro_m: crate::real::zeros_f32(),
            accel_m: crate::real::zeros_f32(),
            gnss_bias: crate::real::zeros_f32(),
            cfg,
            pending: Pending::BLANK,
            batch,
            rejected: 0,
            refused: 0,
            elapsed_s: 0.0,
            aux: [(0.0, 0.0); AUX_MAX],
            seen: Innovations {
                n: 0,
                v2: 0.0,
                hph: 0.0,
                r: 0.0,
            },
        }
    }
}

impl Workspace<f32> {
    /// Zeros, for a static.
    pub const ZERO: Self = Self {
        b: Cov::from_array_storage(nalgebra::ArrayStorage([[0.0; N]; N])),
        w: Cov::from_array_storage(nalgebra::ArrayStorage([[0.0; N]; N])),
    };
}

/// The drift a sensor's warm-up adds (temperature coefficients times the
/// warm-up's rise): a random walk whose density falls off with the
/// warm-up, `q(t) = sigma^2 / tau e^(-t / tau)` at `t` s from the filter's
/// start (taken as the power-up: a later start only overstates it), so
/// that it adds `sigma^2` in all, as the warm-up does, and nothing once
/// the sensor is warm. (A constant random walk of the same size kept
/// growing after the warm-up and, early on, ran ahead of the exponential
/// rise: NEES 0.69 per degree of freedom on the spinning ICM-42688-P's
/// drives.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WarmupDrift {
    /// The warm-up's time constant, s (0: no warm-up drift).
    pub tau_s: f64,
    /// The gyro biases' drift over the warm-up, 1-sigma per axis, rad/s.
    pub gyro_bias: f64,
    /// The accelerometer biases', m/s^2.
    pub accel_bias: f64,
    /// The gyro scales' (1): on a spinning table the rate times a drifting
    /// scale is a drifting heading rate.
    pub gyro_scale: f64,
}

impl WarmupDrift {
    /// No warm-up drift.
    pub const NONE: Self = Self {
        tau_s: 0.0,
        gyro_bias: 0.0,
        accel_bias: 0.0,
        gyro_scale: 0.0,
    };

    /// The density's share left at `t_s` s from the start,
    /// `e^(-t / tau) / tau` (1/s; 0 without a warm-up).
    fn density(&self, t_s: f64) -> f64 {
        if self.tau_s > 0.0 {
            libm::exp(-t_s / self.tau_s) / self.tau_s
        } else {
            0.0
        }
    }
}

/// The sensor's noise and bias model the filter assumes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EskfConfig {
    /// Gyro white noise (angle random walk), rad/sqrt(s).
    pub gyro_arw: f64,
    /// Accelerometer white noise (velocity random walk), m/s/sqrt(s).
    pub accel_vrw: f64,
    /// Gyro bias at the start, 1-sigma, rad/s (turn-on bias and
    /// instability: what the filter does not know at power-up).
    pub gyro_bias_init_sigma: f64,
    /// Gyro bias in run: a Gauss-Markov process's stationary 1-sigma,
    /// rad/s, and correlation time, s (its process noise `2 sigma^2 /
    /// tau`: the instability, not the turn-on bias, which is constant in a
    /// run, nor the warm-up's drift: [`EskfConfig::warmup`]).
    pub gyro_bias_sigma: f64,
    /// See `gyro_bias_sigma`, s.
    pub gyro_bias_tau_s: f64,
    /// Accelerometer bias at the start, 1-sigma, m/s^2.
    pub accel_bias_init_sigma: f64,
    /// Accelerometer bias in run: stationary 1-sigma, m/s^2.
    pub accel_bias_sigma: f64,
    /// See `accel_bias_sigma`, s.
    pub accel_bias_tau_s: f64,
    /// Innovation gate per component, in sigmas of its predicted spread.
    pub gate_sigma: f64,
    /// Initial 1-sigma of the gyro scale errors (1).
    pub gyro_scale_sigma: f64,
    /// Initial 1-sigma of the gyro misalignments (rad).
    pub gyro_misalignment_sigma: f64,
    /// The drift the sensor's warm-up adds to its biases and gyro scales.
    pub warmup: WarmupDrift,
    /// Accelerometer scale error, 1-sigma (constant in run).
    pub accel_scale_sigma: f64,
    /// Accelerometer axis misalignment, 1-sigma, rad.
    pub accel_misalignment_sigma: f64,
    /// The receiver's correlated position error: stationary 1-sigma,
    /// horizontal and vertical (m), and its correlation time (s).
    pub gnss_corr_sigma_m: [f64; 2],
    /// See `gnss_corr_sigma_m`, s.
    pub gnss_corr_tau_s: f64,
}

/// The values of an [`EskfConfig`], in [`EskfConfig::to_array`]'s order.
pub const ESKF_CONFIG_LEN: usize = 20;

impl EskfConfig {
    /// Every value in field order (`warmup`'s four and
    /// `gnss_corr_sigma_m`'s two in place): the one order the replay
    /// header and the board's generated tuning write it in.
    pub const fn to_array(&self) -> [f64; ESKF_CONFIG_LEN] {
        let w = &self.warmup;
        let [gh, gv] = self.gnss_corr_sigma_m;
        [
            self.gyro_arw,
            self.accel_vrw,
            self.gyro_bias_init_sigma,
            self.gyro_bias_sigma,
            self.gyro_bias_tau_s,
            self.accel_bias_init_sigma,
            self.accel_bias_sigma,
            self.accel_bias_tau_s,
            self.gate_sigma,
            self.gyro_scale_sigma,
            self.gyro_misalignment_sigma,
            w.tau_s,
            w.gyro_bias,
            w.accel_bias,
            w.gyro_scale,
            self.accel_scale_sigma,
            self.accel_misalignment_sigma,
            gh,
            gv,
            self.gnss_corr_tau_s,
        ]
    }

    /// [`Self::to_array`]'s inverse.
    pub const fn from_array(v: [f64; ESKF_CONFIG_LEN]) -> Self {
        let [gyro_arw, accel_vrw, gyro_bias_init_sigma, gyro_bias_sigma, gyro_bias_tau_s, accel_bias_init_sigma, accel_bias_sigma, accel_bias_tau_s, gate_sigma, gyro_scale_sigma, gyro_misalignment_sigma, tau_s, gyro_bias, accel_bias, gyro_scale, accel_scale_sigma, accel_misalignment_sigma, gh, gv, gnss_corr_tau_s] =
            v;
        Self {
            gyro_arw,
            accel_vrw,
            gyro_bias_init_sigma,
            gyro_bias_sigma,
            gyro_bias_tau_s,
            accel_bias_init_sigma,
            accel_bias_sigma,
            accel_bias_tau_s,
            gate_sigma,
            gyro_scale_sigma,
            gyro_misalignment_sigma,
            warmup: WarmupDrift {
                tau_s,
                gyro_bias,
                accel_bias,
                gyro_scale,
            },
            accel_scale_sigma,
            accel_misalignment_sigma,
            gnss_corr_sigma_m: [gh, gv],
            gnss_corr_tau_s,
        }
    }
}

/// The initial uncertainty, 1-sigma per block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InitialSigma {
    /// Position, m.
    pub position_m: f64,
    /// Velocity, m/s.
    pub velocity_mps: f64,
    /// Roll and pitch, rad.
    pub level_rad: f64,
    /// Heading, rad.
    pub heading_rad: f64,
}

/// Why an update was not made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FilterError {
    /// A measurement, its sigma or the state is NaN or infinite.
    NonFinite,
    /// A sigma is not positive.
    BadSigma,
}

/// What one vector update did.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct UpdateReport<T: Real> {
    /// Normalised innovation squared over the components used.
    pub nis: T,
    /// Components used.
    pub used: u8,
    /// Components rejected by the gate.
    pub rejected: u8,
    /// Which: bit `i` set when component `i` (north, east, down; or x, y,
    /// z) was rejected.
    pub rejected_mask: u8,
}

/// The innovations of scalar updates since a host last took them
/// ([`Eskf::take_seen`]): what an adaptive host compares with what the
/// filter predicted (the learnt ride noise, `rins::aided::learn`). Each
/// component that reached the gate counts, a rejected one at the gate
/// (its square capped at `gate^2 s`: one wild fix must not decide).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Innovations<T: Real> {
    /// Components.
    pub n: u32,
    /// Sum of the innovations squared (units of each measurement^2).
    pub v2: T,
    /// Sum of their predicted variances from the state, `h P h^T`.
    pub hph: T,
    /// Sum of the measurements' own variances `r`.
    pub r: T,
}

/// The filter: covariance, the error estimate since the last correction,
/// the bias estimates, counters.
#[derive(Clone, Debug)]
pub struct Eskf<T: Real, const M: usize = N> {
    /// Covariance of `dx`.
    pub p: Cov<T, M>,
    /// Error estimate not yet handed to the mechanization.
    pub dx: State<T, M>,
    /// Gyro bias estimate in `s`, rad/s (subtract from the gyro samples).
    pub bias_g: Vector3<T>,
    /// Accelerometer bias estimate in `s`, m/s^2.
    pub bias_a: Vector3<T>,
    /// Gyro scale and misalignment estimate `M` (the gyros read `(I + M)
    /// w`): a sample is corrected by `(w - bias_g) - M (w - bias_g)` to
    /// first order ([`Self::correct_gyro`]).
    pub gyro_m: Matrix3<T>,
    /// Accelerometer scale and misalignment estimate `Ma` (the
    /// accelerometers read `(I + Ma) f`).
    pub accel_m: Matrix3<T>,
    /// Estimate of the receiver's correlated position error, NED, m
    /// (decays with its correlation time between fixes).
    pub gnss_bias: Vector3<T>,
    cfg: EskfConfig,
    /// The interval's integrals not yet propagated into `P`.
    pending: Pending<T>,
    /// Predictions gathered into one covariance propagation (1: every
    /// prediction propagates).
    pub batch: u32,
    /// Measurement components rejected by the gate so far.
    pub rejected: u32,
    /// Updates refused (non-finite input) so far.
    pub refused: u32,
    /// Time propagated since the start, s (the warm-up's clock).
    elapsed_s: f64,
    /// The innovations since the host last took them.
    seen: Innovations<T>,
    /// The host's own states `N..M` ([`Self::set_aux`]): prior variance
    /// and random-walk density (their unit^2 and unit^2/s).
    aux: [(f64, f64); AUX_MAX],
}

impl<T: Real, const M: usize> Eskf<T, M> {
    /// A filter with diagonal initial covariance (biases at their initial
    /// sigma).
    pub fn new(cfg: EskfConfig, init: &InitialSigma) -> Self {
        let mut e = Self {
            p: Cov::zeros(),
            dx: State::zeros(),
            bias_g: Vector3::zeros(),
            bias_a: Vector3::zeros(),
            gyro_m: Matrix3::zeros(),
            accel_m: Matrix3::zeros(),
            gnss_bias: Vector3::zeros(),
            cfg,
            pending: Pending::default(),
            batch: 1,
            rejected: 0,
            refused: 0,
            elapsed_s: 0.0,
            aux: [(0.0, 0.0); AUX_MAX],
            seen: Innovations {
                n: 0,
                v2: T::zero(),
                hph: T::zero(),
                r: T::zero(),
            },
        };
        e.reset(cfg, init);
        e
    }

    /// The noise model in use.
    pub fn config(&self) -> &EskfConfig {
        &self.cfg
    }

    /// The noise model from now on (a host that learns the ride's noise;
    /// the board keeps its tuning). Refused unless its process noise
    /// terms are finite and not negative.
    pub fn set_config(&mut self, cfg: EskfConfig) -> Result<(), FilterError> {
        let terms = [
            cfg.gyro_arw,
            cfg.accel_vrw,
            cfg.gyro_bias_sigma,
            cfg.accel_bias_sigma,
        ];
        if !terms.iter().all(|x| x.is_finite() && *x >= 0.0) {
            return Err(FilterError::BadSigma);
        }
        self.cfg = cfg;
        Ok(())
    }

    /// The innovations since the last call, and counting starts again.
    pub fn take_seen(&mut self) -> Innovations<T> {
        core::mem::take(&mut self.seen)
    }

    /// Starts again in place (no 5 KiB covariance built on the stack): as
    /// [`Self::new`] would, keeping [`Self::batch`].
    pub fn reset(&mut self, cfg: EskfConfig, init: &InitialSigma) {
        let mut d = State::<T, M>::zeros();
        let block = |d: &mut State<T, M>, i: usize, v: Vector3<f64>| {
            d.fixed_rows_mut::<3>(i)
                .copy_from(&v.map(|s| T::lit(s * s)));
        };
        block(&mut d, I_P, Vector3::repeat(init.position_m));
        block(&mut d, I_V, Vector3::repeat(init.velocity_mps));
        block(
            &mut d,
            I_PHI,
            Vector3::new(init.level_rad, init.level_rad, init.heading_rad),
        );
        block(&mut d, I_BG, Vector3::repeat(cfg.gyro_bias_init_sigma));
        block(&mut d, I_BA, Vector3::repeat(cfg.accel_bias_init_sigma));
        for (i0, scale, mis) in [
            (I_M, cfg.gyro_scale_sigma, cfg.gyro_misalignment_sigma),
            (I_MA, cfg.accel_scale_sigma, cfg.accel_misalignment_sigma),
        ] {
            for r in 0..3 {
                for c in 0..3 {
                    let sg = if r == c { scale } else { mis };
                    if let Some(x) = d.get_mut(i0 + 3 * r + c) {
                        *x = T::lit(sg * sg);
                    }
                }
            }
        }
        let [gh, gv] = cfg.gnss_corr_sigma_m;
        block(&mut d, I_GP, Vector3::new(gh, gh, gv));
        for (k, (var, _)) in self.aux.iter().enumerate() {
            if let Some(x) = d.get_mut(N + k) {
                *x = T::lit(*var);
            }
        }
        self.p.fill(T::zero());
        for (i, v) in d.iter().enumerate() {
            if let Some(x) = self.p.get_mut((i, i)) {
                *x = *v;
            }
        }
        self.dx = State::zeros();
        self.bias_g = Vector3::zeros();
        self.bias_a = Vector3::zeros();
        self.gyro_m = Matrix3::zeros();
        self.accel_m = Matrix3::zeros();
        self.gnss_bias = Vector3::zeros();
        self.cfg = cfg;
        self.pending = Pending::default();
        self.rejected = 0;
        self.refused = 0;
        self.elapsed_s = 0.0;
    }

    /// The continuous-time system matrix at the current state: `c_s_n`,
    /// the specific force in `n` (m/s^2), the earth and transport rates in
    /// `n` (rad/s), the (corrected) gyro sample in `s` (rad/s).
    pub fn system(
        &self,
        c_s_n: &Matrix3<T>,
        f_n: &Vector3<T>,
        w_ie_n: &Vector3<T>,
        w_en_n: &Vector3<T>,
        w_is_s: &Vector3<T>,
    ) -> Cov<T, M> {
        let mut p = Pending::default();
        p.add(c_s_n, f_n, w_ie_n, w_en_n, w_is_s, T::one());
        self.system_integral(&p)
    }

    /// `F` integrated over the pending interval: `F` is linear in `c_s_n`,
    /// `f_n`, the rates and `c_s_n e_r w_c`, so its integral is `F` of
    /// their integrals.
    fn system_integral(&self, q: &Pending<T>) -> Cov<T, M> {
        let mut f = Cov::<T, M>::zeros();
        system_integral_into(&self.cfg, q, &mut f);
        f
    }
}

/// `F` integrated over the pending interval, into `f`.
fn system_integral_into<T: Real, const M: usize>(
    cfg: &EskfConfig,
    q: &Pending<T>,
    f: &mut Cov<T, M>,
) {
    {
        f.fill(T::zero());
        // Element by element through `get_mut` (a view's bounds assert
        // would link a panic path on the board).
        let put = |f: &mut Cov<T, M>, r: usize, c: usize, m: &Matrix3<T>| {
            for (j, col) in m.column_iter().enumerate() {
                for (i, v) in col.iter().enumerate() {
                    if let Some(x) = f.get_mut((r + i, c + j)) {
                        *x = *v;
                    }
                }
            }
        };
        put(f, I_P, I_V, &(Matrix3::identity() * q.dt));
        put(f, I_V, I_PHI, &(-skew(&q.f_n)));
        put(f, I_V, I_V, &(-skew(&(q.w_ie * T::lit(2.0) + q.w_en))));
        put(f, I_V, I_BA, &(-q.c_s_n));
        put(f, I_PHI, I_PHI, &(-skew(&(q.w_ie + q.w_en))));
        put(f, I_PHI, I_BG, &(-q.c_s_n));
        // d(phi')/d(M_rc) = -c_s_n e_r w_c: a 3x3 block per row of M.
        // d(dv')/d(Ma_rc) = -c_s_n e_r f_c likewise.
        for (i0, m) in [(I_PHI, &q.cw), (I_V, &q.cf)] {
            let j0 = if i0 == I_PHI { I_M } else { I_MA };
            for (j, col) in m.column_iter().enumerate() {
                for (i, v) in col.iter().enumerate() {
                    if let Some(x) = f.get_mut((i0 + i, j0 + j)) {
                        *x = -*v;
                    }
                }
            }
        }
        let gm = |tau: f64| {
            if tau > 0.0 {
                Matrix3::identity() * (q.dt * T::lit(-1.0 / tau))
            } else {
                Matrix3::zeros()
            }
        };
        put(f, I_BG, I_BG, &gm(cfg.gyro_bias_tau_s));
        put(f, I_BA, I_BA, &gm(cfg.accel_bias_tau_s));
        put(f, I_GP, I_GP, &gm(cfg.gnss_corr_tau_s));
    }
}

impl<T: Real, const M: usize> Eskf<T, M> {
    /// Predicts over `dt_s` (see [`Self::system`] for the arguments). The
    /// system's integrals are gathered over [`Self::batch`] predictions
    /// and then propagated at once ([`Self::propagate`]; an update
    /// propagates what is pending first): `P = Phi P Phi^T + Q_d`,
    /// symmetrised, with `Phi = I + A + A^2 / 2`, `A` the integral of `F`
    /// over the interval. (With `F` varying in the interval the dropped
    /// commutator terms are of order `|F|^2 T^2` times its relative change:
    /// at 0.1 s and a table turning 3 deg, below f32's resolution of `P`.)
    pub fn predict(
        &mut self,
        c_s_n: &Matrix3<T>,
        f_n: &Vector3<T>,
        w_ie_n: &Vector3<T>,
        w_en_n: &Vector3<T>,
        w_is_s: &Vector3<T>,
        dt_s: T,
    ) {
        self.predict_opt(c_s_n, f_n, w_ie_n, w_en_n, w_is_s, dt_s, None);
    }

    /// [`Self::predict`] with the board's workspace.
    #[allow(clippy::too_many_arguments)]
    pub fn predict_in(
        &mut self,
        c_s_n: &Matrix3<T>,
        f_n: &Vector3<T>,
        w_ie_n: &Vector3<T>,
        w_en_n: &Vector3<T>,
        w_is_s: &Vector3<T>,
        dt_s: T,
        ws: &mut Workspace<T, M>,
    ) {
        self.predict_opt(c_s_n, f_n, w_ie_n, w_en_n, w_is_s, dt_s, Some(ws));
    }

    #[allow(clippy::too_many_arguments)]
    pub(crate) fn predict_opt(
        &mut self,
        c_s_n: &Matrix3<T>,
        f_n: &Vector3<T>,
        w_ie_n: &Vector3<T>,
        w_en_n: &Vector3<T>,
        w_is_s: &Vector3<T>,
        dt_s: T,
        ws: Option<&mut Workspace<T, M>>,
    ) {
        self.pending.add(c_s_n, f_n, w_ie_n, w_en_n, w_is_s, dt_s);
        if self.pending.n >= self.batch.max(1) {
            self.prop(ws);
        }
    }

    /// Propagates what is pending, in `ws` or a workspace of its own.
    fn prop(&mut self, ws: Option<&mut Workspace<T, M>>) {
        match ws {
            Some(w) => self.propagate_in(w),
            None => self.propagate(),
        }
    }

    /// Propagates the covariance over the pending interval (nothing when
    /// none is pending), its scratch on the stack.
    pub fn propagate(&mut self) {
        if self.pending.n == 0 {
            return;
        }
        let mut ws = Workspace::new();
        self.propagate_in(&mut ws);
    }

    /// [`Self::propagate`] in the board's workspace.
    #[inline(never)]
    pub fn propagate_in(&mut self, ws: &mut Workspace<T, M>) {
        if self.pending.n == 0 {
            return;
        }
        let q = self.pending;
        self.pending = Pending::default();
        let dt_s = q.dt;
        // The workspace: `B`, and `w`, which holds `F` and then `P B^T`.
        let Workspace { b, w } = ws;
        system_integral_into(&self.cfg, &q, w);
        // Phi = I + B, B = A + A^2 / 2 (A sparse: ~80 of 729 entries).
        mul_into(b, w, w);
        for (bij, fij) in b.iter_mut().zip(w.iter()) {
            *bij = *fij + *bij * T::lit(0.5);
        }
        let bias_q = |sigma: f64, tau: f64| {
            if tau > 0.0 {
                2.0 * sigma * sigma / tau
            } else {
                0.0
            }
        };
        let c = &self.cfg;
        let mut qd = State::<T, M>::zeros();
        let [gh, gv] = c.gnss_corr_sigma_m;
        let gq = |s: f64| bias_q(s, c.gnss_corr_tau_s);
        // The warm-up's density at the interval's middle.
        let dt64 = dt_s.to_f64();
        let warm = c.warmup.density(self.elapsed_s + 0.5 * dt64);
        self.elapsed_s += dt64;
        let wq = |sigma: f64| sigma * sigma * warm;
        let sq = wq(c.warmup.gyro_scale);
        let (gq_b, aq_b) = (wq(c.warmup.gyro_bias), wq(c.warmup.accel_bias));
        for (i, q) in [
            (I_M, [sq, 0.0, 0.0]),
            (I_M + 4, [sq, 0.0, 0.0]),
            (I_M + 8, [sq, 0.0, 0.0]),
            (I_V, [c.accel_vrw * c.accel_vrw; 3]),
            (I_PHI, [c.gyro_arw * c.gyro_arw; 3]),
            (
                I_BG,
                [bias_q(c.gyro_bias_sigma, c.gyro_bias_tau_s) + gq_b; 3],
            ),
            (
                I_BA,
                [bias_q(c.accel_bias_sigma, c.accel_bias_tau_s) + aq_b; 3],
            ),
            (I_GP, [gq(gh), gq(gh), gq(gv)]),
        ] {
            for (k, qk) in q.iter().enumerate() {
                if let Some(x) = qd.get_mut(i + k) {
                    *x = T::lit(*qk) * dt_s;
                }
            }
        }
        // Phi P Phi^T = P + B P + (B P)^T + B P B^T, with B's zeros
        // skipped: P B^T = (B P)^T (P symmetric), then B P B^T = (B P) B^T,
        // into the workspace (F's slot takes B P B^T).
        // The error estimate propagates too (it is zero in closed loop), and
        // the receiver error's estimate decays.
        // By reference: `b * dx` would copy B (5 KiB) into the call.
        #[allow(clippy::op_ref)]
        let b_dx = &*b * self.dx;
        self.dx += b_dx;
        // B transposed in place: its rows become contiguous columns.
        b.transpose_mut();
        // P B^T (= (B P)^T, P symmetric), B's zeros skipped, into `w`.
        let mt = w;
        mul_into(mt, &self.p, b);
        // P + M + M^T + X + Q_d, element by element, with X = B P B^T
        // summed on the fly over B's nonzeros (X[r, c] = sum_k B[c, k]
        // mt[k, r]), once per pair (i <= j: X is symmetric) and the same
        // sum added to (i, j) and (j, i), so P stays symmetric to the bit.
        let mut nz = [[0u8; M]; M];
        let mut nz_len = [0usize; M];
        for ((col, list), len) in b
            .as_slice()
            .as_chunks::<M>()
            .0
            .iter()
            .zip(nz.iter_mut())
            .zip(nz_len.iter_mut())
        {
            for (k, v) in col.iter().enumerate() {
                if *v != T::zero() {
                    if let Some(slot) = list.get_mut(*len) {
                        *slot = k as u8;
                        *len += 1;
                    }
                }
            }
        }
        let (ms, bcols, mcols) = (
            mt.as_slice(),
            b.as_slice().as_chunks::<M>().0,
            mt.as_slice().as_chunks::<M>().0,
        );
        let at = |s: &[T], i: usize| s.get(i).copied().unwrap_or_else(T::zero);
        let ps = self.p.as_mut_slice();
        for j in 0..M {
            let (Some(bj), Some(list)) = (
                bcols.get(j),
                nz.get(j)
                    .and_then(|l| l.get(..nz_len.get(j).copied().unwrap_or(0))),
            ) else {
                continue;
            };
            for (i, mi) in mcols.iter().enumerate().take(j + 1) {
                let mut x = T::zero();
                for &k in list {
                    let k = usize::from(k);
                    if let (Some(bv), Some(mv)) = (bj.get(k), mi.get(k)) {
                        x += *bv * *mv;
                    }
                }
                let (ij, ji) = (j * M + i, i * M + j);
                let v = (at(ms, ij) + at(ms, ji)) + x;
                if let Some(p) = ps.get_mut(ij) {
                    *p += v;
                }
                if i != j {
                    if let Some(p) = ps.get_mut(ji) {
                        *p += v;
                    }
                }
            }
        }
        for (k, (_, q)) in self.aux.iter().enumerate() {
            if let Some(x) = qd.get_mut(N + k) {
                *x = T::lit(*q) * dt_s;
            }
        }
        for (i, q) in qd.iter().enumerate() {
            if let Some(pii) = self.p.get_mut((i, i)) {
                *pii += *q;
            }
        }
        if self.cfg.gnss_corr_tau_s > 0.0 {
            let decay = T::one() - dt_s * T::lit(1.0 / self.cfg.gnss_corr_tau_s);
            self.gnss_bias *= decay.max(T::zero());
        }
    }

    /// One scalar measurement `z = h dx + v`, `Var v = r`: the Joseph-form
    /// update. Returns `z^2 / s` (its NIS), or `None` when the gate
    /// rejected it (counted).
    ///
    /// # Errors
    /// Non-finite `z`, `r` or row; `r` not positive.
    pub fn update_scalar(&mut self, h: &State<T, M>, z: T, r: T) -> Result<Option<T>, FilterError> {
        self.update_scalar_opt(h, z, r, None)
    }

    #[inline(never)]
    fn update_scalar_opt(
        &mut self,
        h: &State<T, M>,
        z: T,
        r: T,
        ws: Option<&mut Workspace<T, M>>,
    ) -> Result<Option<T>, FilterError> {
        if !(z.is_finite() && r.is_finite() && h.iter().all(|x| x.is_finite())) {
            self.refused += 1;
            return Err(FilterError::NonFinite);
        }
        if r <= T::zero() {
            self.refused += 1;
            return Err(FilterError::BadSigma);
        }
        self.prop(ws);
        // By reference: `self.p * h` would copy P (5 KiB) onto the stack.
        #[allow(clippy::op_ref)]
        let ph = &self.p * h;
        let s = h.dot(&ph) + r;
        let innov = z - h.dot(&self.dx);
        let gate = T::lit(self.cfg.gate_sigma);
        let hph = h.dot(&ph);
        let seen = &mut self.seen;
        seen.n = seen.n.saturating_add(1);
        seen.v2 += (innov * innov).min(gate * gate * s);
        seen.hph += hph;
        seen.r += r;
        if innov * innov > gate * gate * s {
            self.rejected += 1;
            return Ok(None);
        }
        let k = ph / s;
        self.dx += k * innov;
        // Joseph: (I - k h) P (I - k h)^T + k r k^T, each product by
        // `I - k h` taken as the rank-one change it is (O(n^2), not two
        // dense O(n^3) products): A = (I - k h) P = P - k ph^T (P
        // symmetric), A h = ph - k (h ph), and the result A - (A h) k^T +
        // r k k^T, element by element and symmetrised.
        let ah = ph - k * hph;
        // P is kept symmetric to the bit (each pair below is summed so (i,
        // j) and (j, i) get the same result), so A[i, j] reads P[i, j].
        let half = T::lit(0.5);
        for ((col, (&kj, &phj)), &ahj) in self
            .p
            .as_mut_slice()
            .as_chunks_mut::<M>()
            .0
            .iter_mut()
            .zip(k.as_slice().iter().zip(ph.as_slice()))
            .zip(ah.as_slice())
        {
            let rows = k.as_slice().iter().zip(ph.as_slice()).zip(ah.as_slice());
            for (x, ((&ki, &phi), &ahi)) in col.iter_mut().zip(rows) {
                let sym = ((ki * phj + kj * phi) + (ahi * kj + ahj * ki)) * half;
                *x = *x - sym + r * (ki * kj);
            }
        }
        Ok(Some(innov * innov / s))
    }

    fn update_rows(
        &mut self,
        rows: [State<T, M>; 3],
        z: &Vector3<T>,
        sigma: &Vector3<T>,
        mut ws: Option<&mut Workspace<T, M>>,
    ) -> Result<UpdateReport<T>, FilterError> {
        if !(z.iter().all(|x| x.is_finite()) && sigma.iter().all(|x| x.is_finite())) {
            self.refused += 1;
            return Err(FilterError::NonFinite);
        }
        if sigma.iter().any(|s| *s <= T::zero()) {
            self.refused += 1;
            return Err(FilterError::BadSigma);
        }
        let mut rep = UpdateReport::default();
        for (i, ((h, zi), si)) in rows.iter().zip(z.iter()).zip(sigma.iter()).enumerate() {
            match self.update_scalar_opt(h, *zi, *si * *si, ws.as_deref_mut())? {
                Some(nis) => {
                    rep.nis += nis;
                    rep.used += 1;
                }
                None => {
                    rep.rejected += 1;
                    rep.rejected_mask |= 1 << i;
                }
            }
        }
        Ok(rep)
    }

    /// GNSS position of the antenna: `z = p_gnss - (p + l_n)` (NED
    /// offsets, m), the antenna at `l_n` from the table's centre (m, in
    /// `n`), the 1-sigma per axis of the fix's white error (m; the
    /// correlated part is the `dgp` state).
    ///
    /// # Errors
    /// Non-finite input, a sigma not positive.
    pub fn update_position(
        &mut self,
        z: &Vector3<T>,
        l_n: &Vector3<T>,
        sigma: &Vector3<T>,
    ) -> Result<UpdateReport<T>, FilterError> {
        self.update_position_opt(z, l_n, sigma, None)
    }

    pub(crate) fn update_position_opt(
        &mut self,
        z: &Vector3<T>,
        l_n: &Vector3<T>,
        sigma: &Vector3<T>,
        ws: Option<&mut Workspace<T, M>>,
    ) -> Result<UpdateReport<T>, FilterError> {
        let lx = -skew(l_n);
        let z = z - self.gnss_bias;
        let z = &z;
        let mut rows = [State::<T, M>::zeros(); 3];
        for (i, (h, lrow)) in rows.iter_mut().zip(lx.row_iter()).enumerate() {
            h.fixed_rows_mut::<3>(I_P).copy_from(&unit(i));
            h.fixed_rows_mut::<3>(I_PHI).copy_from(&lrow.transpose());
            h.fixed_rows_mut::<3>(I_GP).copy_from(&unit::<T>(i));
        }
        self.update_rows(rows, z, sigma, ws)
    }

    /// GNSS velocity (or zero velocity): `z = v_meas - v` (NED, m/s), 1-sigma
    /// per axis (m/s).
    ///
    /// # Errors
    /// Non-finite input, a sigma not positive.
    pub fn update_velocity(
        &mut self,
        z: &Vector3<T>,
        sigma: &Vector3<T>,
    ) -> Result<UpdateReport<T>, FilterError> {
        self.update_velocity_opt(z, sigma, None)
    }

    pub(crate) fn update_velocity_opt(
        &mut self,
        z: &Vector3<T>,
        sigma: &Vector3<T>,
        ws: Option<&mut Workspace<T, M>>,
    ) -> Result<UpdateReport<T>, FilterError> {
        let mut rows = [State::<T, M>::zeros(); 3];
        for (i, h) in rows.iter_mut().enumerate() {
            h.fixed_rows_mut::<3>(I_V).copy_from(&unit(i));
        }
        self.update_rows(rows, z, sigma, ws)
    }

    /// Zero rotation of a still base (a zero angular rate update): `z =
    /// w_meas - w_true` (rad/s, in `s`), the corrected gyros' mean over a
    /// window less the rotation the base cannot have made (the table's and
    /// the earth's), against `dbg + dM w_s` with `w_s` the window's mean
    /// rate (rad/s, `s`, the table's included); 1-sigma per axis (rad/s).
    ///
    /// # Errors
    /// Non-finite input, a sigma not positive.
    pub fn update_rate(
        &mut self,
        z: &Vector3<T>,
        w_s: &Vector3<T>,
        sigma: &Vector3<T>,
    ) -> Result<UpdateReport<T>, FilterError> {
        self.update_rate_opt(z, w_s, sigma, None)
    }

    pub(crate) fn update_rate_opt(
        &mut self,
        z: &Vector3<T>,
        w_s: &Vector3<T>,
        sigma: &Vector3<T>,
        ws: Option<&mut Workspace<T, M>>,
    ) -> Result<UpdateReport<T>, FilterError> {
        let mut rows = [State::<T, M>::zeros(); 3];
        for (i, h) in rows.iter_mut().enumerate() {
            h.fixed_rows_mut::<3>(I_BG).copy_from(&unit(i));
            h.fixed_rows_mut::<3>(I_M + 3 * i).copy_from(w_s);
        }
        self.update_rows(rows, z, sigma, ws)
    }

    /// Sizes the receiver's correlated position error afresh (`sigma_m`:
    /// horizontal, vertical 1-sigma, m; a receiver known only once its
    /// fixes arrive): the configuration's, whence its process noise and
    /// a fix's white share, and its states' rows and columns scaled, with
    /// their estimate, so that no variance is above the new prior (a
    /// diagonal scaling keeps the covariance positive semi-definite and
    /// the correlations as they were). A variance already below it stays.
    pub fn size_gnss_corr(&mut self, sigma_m: [f64; 2]) {
        self.cfg.gnss_corr_sigma_m = sigma_m;
        let [gh, gv] = sigma_m;
        for (k, sigma) in [gh, gh, gv].into_iter().enumerate() {
            let i = I_GP + k;
            let var = self.p.get((i, i)).copied().unwrap_or(T::zero());
            let target = T::lit(sigma * sigma);
            // Not above it (or NaN): kept.
            if var.partial_cmp(&target) != Some(core::cmp::Ordering::Greater) {
                continue;
            }
            let f = (target / var).sqrt_cr();
            for j in 0..M {
                let g = if j == i { f * f } else { f };
                if let Some(x) = self.p.get_mut((i, j)) {
                    *x *= g;
                }
                if j != i {
                    if let Some(x) = self.p.get_mut((j, i)) {
                        *x *= f;
                    }
                }
            }
            if let Some(b) = self.gnss_bias.get_mut(k) {
                *b *= f;
            }
        }
    }

    /// Re-initialises position and velocity on the NED axes `axes` says
    /// from a measurement the gate keeps refusing while it agrees with
    /// itself (a filter lost after an outage; `[false, false, true]`: the
    /// vertical channel alone, a height lost while the horizontal fixes
    /// are taken): on those axes the error estimate of position and
    /// velocity set to the whole innovations `zp` (the antenna's, m, NED)
    /// and `zv` (m/s), their covariance to the measurement's own
    /// (`sigma_p` per axis, m; `sigma_v`, m/s) with no correlation to the
    /// other states, and the receiver's correlated error restarted at its
    /// prior; the other axes keep their estimate and covariance.
    pub fn reinit_axes(
        &mut self,
        zp: &Vector3<T>,
        zv: &Vector3<T>,
        sigma_p: &Vector3<T>,
        sigma_v: T,
        axes: [bool; 3],
    ) {
        let blocks = [I_P, I_V, I_GP];
        let on = |k: usize| axes.get(k).copied().unwrap_or(false);
        let rows = blocks
            .iter()
            .flat_map(|b| (0..3).filter(|k| on(*k)).map(move |k| *b + k));
        for i in rows {
            for j in 0..M {
                for idx in [(i, j), (j, i)] {
                    if let Some(x) = self.p.get_mut(idx) {
                        *x = T::zero();
                    }
                }
            }
        }
        let [gh, gv] = self.cfg.gnss_corr_sigma_m;
        let gp = Vector3::new(gh, gh, gv).map(T::lit);
        let axes_it = sigma_p.iter().zip(gp.iter()).zip(zp.iter().zip(zv.iter()));
        for (k, ((sp, g), (p, v))) in axes_it.enumerate().filter(|(k, _)| on(*k)) {
            let diag = [
                (I_P + k, *sp * *sp),
                (I_V + k, sigma_v * sigma_v),
                (I_GP + k, *g * *g),
            ];
            for (i, var) in diag {
                if let Some(x) = self.p.get_mut((i, i)) {
                    *x = var;
                }
            }
            for (i, e) in [(I_P + k, *p), (I_V + k, *v), (I_GP + k, T::zero())] {
                if let Some(x) = self.dx.get_mut(i) {
                    *x = e;
                }
            }
            if let Some(b) = self.gnss_bias.get_mut(k) {
                *b = T::zero();
            }
        }
    }

    /// Hands the error estimate over: `(dp, dv, phi)` to add to the
    /// mechanization's position (m), velocity (m/s) and attitude (a
    /// rotation in `n`, rad); the bias errors go into [`Self::bias_g`],
    /// [`Self::bias_a`]. `dx` restarts at zero.
    pub fn take_correction(&mut self) -> (Vector3<T>, Vector3<T>, Vector3<T>) {
        let v = |i: usize| -> Vector3<T> { self.dx.fixed_rows::<3>(i).into_owned() };
        let out = (v(I_P), v(I_V), v(I_PHI));
        self.bias_g += v(I_BG);
        self.bias_a += v(I_BA);
        for r in 0..3 {
            for c in 0..3 {
                if let (Some(m), Some(x)) =
                    (self.gyro_m.get_mut((r, c)), self.dx.get(I_M + 3 * r + c))
                {
                    *m += *x;
                }
                if let (Some(m), Some(x)) =
                    (self.accel_m.get_mut((r, c)), self.dx.get(I_MA + 3 * r + c))
                {
                    *m += *x;
                }
            }
        }
        self.gnss_bias += v(I_GP);
        for x in self.dx.iter_mut().take(N) {
            *x = T::zero();
        }
        out
    }

    /// The host state `k`'s prior 1-sigma `sigma` (its unit) and
    /// random-walk density `q_per_s` (unit^2/s), kept through
    /// [`Self::reset`]; its covariance row set to the prior, uncorrelated.
    ///
    /// # Errors
    /// `k` not a host state of this filter (`N + k >= M`), a non-finite or
    /// negative term.
    pub fn set_aux(&mut self, k: usize, sigma: f64, q_per_s: f64) -> Result<(), FilterError> {
        let ok = sigma.is_finite() && q_per_s.is_finite() && sigma >= 0.0 && q_per_s >= 0.0;
        let (Some(slot), true, true) = (self.aux.get_mut(k), N + k < M, ok) else {
            return Err(FilterError::BadSigma);
        };
        *slot = (sigma * sigma, q_per_s);
        self.set_aux_row(N + k, sigma * sigma);
        Ok(())
    }

    /// The host state `k` started as `row . dx + w`, a linear function of
    /// the other states plus a white error of 1-sigma `sigma_white`: its
    /// covariance with every state `P row`, its variance `row P row^T +
    /// sigma_white^2` (kept as its prior through [`Self::reset`]); its
    /// random-walk density `q_per_s`. (A vehicle's mounting read off the
    /// filter's own velocity in `b` carries the filter's heading error:
    /// this says so, where an uncorrelated prior would not.)
    ///
    /// # Errors
    /// As [`Self::set_aux`]; a non-finite row.
    pub fn set_aux_as(
        &mut self,
        k: usize,
        row: &State<T, M>,
        sigma_white: f64,
        q_per_s: f64,
    ) -> Result<(), FilterError> {
        if !row.iter().all(|x| x.is_finite()) {
            return Err(FilterError::NonFinite);
        }
        self.set_aux(k, sigma_white, q_per_s)?;
        let i = N + k;
        let mut row = *row;
        if let Some(x) = row.get_mut(i) {
            *x = T::zero();
        }
        #[allow(clippy::op_ref)]
        let pr = &self.p * &row;
        let var = row.dot(&pr) + T::lit(sigma_white * sigma_white);
        for (j, v) in pr.iter().enumerate() {
            for idx in [(i, j), (j, i)] {
                if let Some(x) = self.p.get_mut(idx) {
                    *x = *v;
                }
            }
        }
        if let Some(x) = self.p.get_mut((i, i)) {
            *x = var;
        }
        let dxi = row.dot(&self.dx);
        if let Some(x) = self.dx.get_mut(i) {
            *x = dxi;
        }
        if let Some(a) = self.aux.get_mut(k) {
            a.0 = var.to_f64();
        }
        Ok(())
    }

    fn set_aux_row(&mut self, i: usize, var: f64) {
        for j in 0..M {
            for idx in [(i, j), (j, i)] {
                if let Some(x) = self.p.get_mut(idx) {
                    *x = T::zero();
                }
            }
        }
        if let Some(x) = self.p.get_mut((i, i)) {
            *x = T::lit(var);
        }
        if let Some(x) = self.dx.get_mut(i) {
            *x = T::zero();
        }
    }

    /// Hands the host states' error estimates over (index `k` for state
    /// `N + k`; zero beyond `M`) and restarts them at zero: the host adds
    /// them to its own estimates.
    pub fn take_aux(&mut self) -> [T; AUX_MAX] {
        core::array::from_fn(|k| {
            self.dx
                .get_mut(N + k)
                .map(|x| core::mem::replace(x, T::zero()))
                .unwrap_or_else(T::zero)
        })
    }

    /// A raw gyro sample corrected by the estimates: `(w - bias_g) - M (w -
    /// bias_g)`, rad/s in `s`.
    pub fn correct_gyro(&self, w_is_s: &Vector3<T>) -> Vector3<T> {
        let w = w_is_s - self.bias_g;
        w - self.gyro_m * w
    }

    /// A raw accelerometer sample corrected by the estimates: `(f -
    /// bias_a) - Ma (f - bias_a)`, m/s^2 in `s`.
    pub fn correct_accel(&self, f_s: &Vector3<T>) -> Vector3<T> {
        let f = f_s - self.bias_a;
        f - self.accel_m * f
    }

    /// 1-sigma of error-state component `i` (its unit).
    pub fn sigma(&self, i: usize) -> T {
        self.p
            .get((i, i))
            .copied()
            .unwrap_or_else(T::zero)
            .max(T::zero())
            .sqrt_cr()
    }
}

/// The integrals over a prediction interval of what the system matrix
/// depends on (each `x dt`, so `F` of them is `F`'s integral).
#[derive(Clone, Copy, Debug)]
struct Pending<T: Real> {
    c_s_n: Matrix3<T>,
    f_n: Vector3<T>,
    w_ie: Vector3<T>,
    w_en: Vector3<T>,
    /// Column `3 r + c`: `c_s_n e_r w_c`.
    cw: SMatrix<T, 3, 9>,
    /// Column `3 r + c`: `c_s_n e_r f_c` (`f` in `s`).
    cf: SMatrix<T, 3, 9>,
    dt: T,
    n: u32,
}

impl Pending<f32> {
    const BLANK: Self = Self {
        c_s_n: crate::real::zeros_f32(),
        f_n: crate::real::zeros_f32(),
        w_ie: crate::real::zeros_f32(),
        w_en: crate::real::zeros_f32(),
        cw: crate::real::zeros_f32(),
        cf: crate::real::zeros_f32(),
        dt: 0.0,
        n: 0,
    };
}

impl<T: Real> Default for Pending<T> {
    fn default() -> Self {
        Self {
            c_s_n: Matrix3::zeros(),
            f_n: Vector3::zeros(),
            w_ie: Vector3::zeros(),
            w_en: Vector3::zeros(),
            cw: SMatrix::zeros(),
            cf: SMatrix::zeros(),
            dt: T::zero(),
            n: 0,
        }
    }
}

impl<T: Real> Pending<T> {
    fn add(
        &mut self,
        c_s_n: &Matrix3<T>,
        f_n: &Vector3<T>,
        w_ie: &Vector3<T>,
        w_en: &Vector3<T>,
        w_is_s: &Vector3<T>,
        dt: T,
    ) {
        self.c_s_n += c_s_n * dt;
        self.f_n += f_n * dt;
        self.w_ie += w_ie * dt;
        self.w_en += w_en * dt;
        let f_s = c_s_n.transpose() * f_n;
        for (r, col_r) in c_s_n.column_iter().enumerate() {
            for (c, (wc, fc)) in w_is_s.iter().zip(f_s.iter()).enumerate() {
                for (i, cri) in col_r.iter().enumerate() {
                    if let Some(x) = self.cw.get_mut((i, 3 * r + c)) {
                        *x += *cri * (*wc * dt);
                    }
                    if let Some(x) = self.cf.get_mut((i, 3 * r + c)) {
                        *x += *cri * (*fc * dt);
                    }
                }
            }
        }
        self.dt += dt;
        self.n += 1;
    }
}

/// `out = a c`, column by column (`out[:, i] = sum_k c[k, i] a[:, k]`, k
/// ascending), zeros of `c` skipped: with `c = b^T` the sums of `a b^T`
/// in the order the filter has always summed them.
fn mul_into<T: Real, const M: usize>(out: &mut Cov<T, M>, a: &Cov<T, M>, c: &Cov<T, M>) {
    out.fill(T::zero());
    let cols = c.as_slice().as_chunks::<M>().0;
    for (out_col, c_col) in out
        .as_mut_slice()
        .as_chunks_mut::<M>()
        .0
        .iter_mut()
        .zip(cols)
    {
        for (&v, a_col) in c_col.iter().zip(a.as_slice().as_chunks::<M>().0.iter()) {
            if v != T::zero() {
                for (o, x) in out_col.iter_mut().zip(a_col) {
                    *o += v * *x;
                }
            }
        }
    }
}

/// The unit vector along axis `i` (0, 1, 2; zero for any other).
fn unit<T: Real>(i: usize) -> Vector3<T> {
    Vector3::from_fn(|r, _| if r == i { T::one() } else { T::zero() })
}

fn skew<T: Real>(v: &Vector3<T>) -> Matrix3<T> {
    crate::attitude::skew(v)
}

#[cfg(test)]
mod config_order {
    use super::*;

    #[test]
    fn an_eskf_config_round_trips_through_its_array_in_field_order() {
        let v: [f64; ESKF_CONFIG_LEN] = core::array::from_fn(|i| 1.0 + i as f64);
        let c = EskfConfig::from_array(v);
        assert_eq!(c.to_array(), v);
        // Field order: the warm-up's four after the misalignment sigma,
        // the GNSS error's two before its correlation time.
        assert_eq!(
            (
                c.gyro_arw,
                c.warmup.tau_s,
                c.gnss_corr_sigma_m,
                c.gnss_corr_tau_s
            ),
            (1.0, 12.0, [18.0, 19.0], 20.0)
        );
    }
}

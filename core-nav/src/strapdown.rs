//! Strapdown mechanization in local-level NED for the spinning sensor frame
//! `s` (the table turns `s`; the gyros see the table rate).
//!
//! # Integration rule
//!
//! The samples are instantaneous rates / specific forces at their time
//! stamps (recording-v1), not increments. One step goes from `t_{k-1}` to
//! `t_k` (`T = t_k - t_{k-1}`, from integer µs). The update order is
//! **attitude, velocity, position**:
//!
//! 1. *Attitude.* The body rate is modelled over the interval as the
//!    quadratic through `w_{k-2}, w_{k-1}, w_k` (linear through the last two
//!    on the first step or after a change of step length). With
//!    `A = w_{k-1} T`, `B = (w_k - w_{k-2}) T / 2`,
//!    `C = (w_k - 2 w_{k-1} + w_{k-2}) T / 2` the rotation vector is the Bortz
//!    series to second order, integrated exactly for that model:
//!    `phi = A + B/2 + C/3 + (A x B)/12 + (A x C)/12 + (B x C)/60`
//!    (for the linear model: `phi = T (w_{k-1} + w_k)/2 + T^2/12 w_{k-1} x w_k`,
//!    the classic two-sample coning term for rate samples). The increment
//!    quadrature is third order (error `T^4 w'''/24`); the neglected
//!    `1/12 alpha x (alpha x w)` term is `O(T^4 |w|^2 |w'|)`. The n frame turns
//!    by `zeta = (w_ie_n + w_en_n) T` at mid-interval:
//!    `q_s_n(k) = exp(-zeta/2) ⊗ q_s_n(k-1) ⊗ exp(phi/2)`, the exponentials
//!    by series (no libm trigonometry). The update is applied as an
//!    increment `q += dq` with Kahan compensation and a first-order
//!    renormalisation folded into `dq`, so f32 rounding of a quaternion that
//!    turns 1.7 deg every step does not random-walk the attitude.
//! 2. *Velocity.* `v_n(k) = v_n(k-1) + T/2 (c_s_n(k-1) f_{k-1} + c_s_n(k) f_k)
//!    + T (g_n - (2 w_ie_n + w_en_n) x v_n)` at mid-interval: trapezoidal
//!    (second order) in the specific force resolved in `n`, which is exact
//!    whenever `f_n` is linear in time (a static base under a spinning
//!    sensor has constant `f_n`), so no separate sculling term is needed.
//! 3. *Position.* Trapezoidal in velocity (second order), as curvilinear
//!    north / east / down offsets from a reference point (see
//!    [`NavState::p_n`]).
//!
//! Sources: Savage, *Strapdown Analytics* 2nd ed., Ch. 7 (attitude), 8
//! (velocity); Groves 2nd ed. Sec. 5.4 (local-navigation-frame
//! mechanization, Eq. 5.46, 5.54, 5.56); Bortz (1971) for the rotation
//! vector.

use crate::attitude::{rotate, rotvec_to_delta};
use crate::earth::{earth_rate_n, transport_rate_n, EarthAt, GeoPoint, LocalEarth};
use crate::error::NavError;
use crate::real::Real;
use nalgebra::{Quaternion, Vector3};

/// One IMU sample: instantaneous body rate and specific force of `s`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ImuSample<T: Real> {
    /// Time stamp, µs, on the run's clock.
    pub t_us: u64,
    /// Angular rate of `s` relative to inertial space, in `s`, rad/s.
    pub w_is_s: Vector3<T>,
    /// Specific force, in `s`, m/s^2.
    pub f_s: Vector3<T>,
}

impl<T: Real> ImuSample<T> {
    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        // Six plain tests (an iterator chain costs ~100 instructions per
        // step on the Cortex-M4F at opt-level s).
        let (w, f) = (&self.w_is_s, &self.f_s);
        w.x.is_finite()
            & w.y.is_finite()
            & w.z.is_finite()
            & f.x.is_finite()
            & f.y.is_finite()
            & f.z.is_finite()
    }
}

/// The navigation state at one time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavState<T: Real> {
    /// Time stamp, µs.
    pub t_us: u64,
    /// Attitude of the sensor frame: maps `s` into `n` (NED).
    pub q_s_n: Quaternion<T>,
    /// Velocity relative to the earth, NED, m/s.
    pub v_n: Vector3<T>,
    /// Position as curvilinear offsets from the reference point, m:
    /// `north = (lat - lat0)(R_M(lat0) + h0)`,
    /// `east = (lon - lon0)(R_N(lat0) + h0) cos(lat0)`, `down = h0 - h`.
    /// Carried as offsets so f32 never adds metres to radians (0.4 m per
    /// ulp of latitude); [`LocalEarth::point_at`] gives the geodetic point,
    /// [`GeoPoint::ned_to`] the tangent-plane NED offset.
    pub p_n: Vector3<T>,
}

/// What to do with the (unstable) vertical channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum VerticalChannel {
    /// Integrate it (diverges with time constant `sqrt(R / 2g)` ~ 9.5 min).
    #[default]
    Free,
    /// Hold height and vertical velocity at their initial values (height
    /// known from outside, e.g. a lab bench): for runs of hours.
    HoldHeight,
}

/// Mechanization settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrapdownConfig {
    /// Largest accepted gap between two samples, µs (a longer one is refused:
    /// the integration rule assumes smooth motion between samples).
    pub max_dt_us: u64,
    /// Vertical channel handling.
    pub vertical: VerticalChannel,
    /// Gravity at the reference point, m/s^2; `None`: WGS-84 normal gravity.
    pub gravity_mps2: Option<f64>,
}

impl Default for StrapdownConfig {
    fn default() -> Self {
        Self {
            // 100 Hz nominal: accept up to 5 missed samples.
            max_dt_us: 60_000,
            vertical: VerticalChannel::Free,
            gravity_mps2: None,
        }
    }
}

/// The strapdown integrator: state plus what the integration rule remembers
/// of the previous samples.
#[derive(Clone, Debug)]
pub struct Strapdown<T: Real> {
    earth: LocalEarth<T>,
    cfg: StrapdownConfig,
    state: NavState<T>,
    /// Kahan compensation of `q_s_n` (the low-order bits lost so far).
    q_comp: Quaternion<T>,
    /// Rate and specific force (resolved in n) at `t_{k-1}`.
    w_prev: Vector3<T>,
    f_n_prev: Vector3<T>,
    /// Rate at `t_{k-2}` and the step length before the last, µs.
    w_prev2: Option<(Vector3<T>, u64)>,
    /// Velocity change of the last step (to extrapolate to mid-interval).
    dv_prev: Vector3<T>,
    /// The step length in s as `hi + lo` for the last `dt_us` seen: f32(0.01)
    /// is 2.2e-8 short, which over 523 rad of table rotation (5 min at
    /// 100 deg/s) is a systematic 2.4 arcsec; `lo` carries the rest.
    dt_cache: (u64, T, T),
    steps: u64,
}

impl Strapdown<f32> {
    /// A mechanization not yet started: all zeros in a `const` (a board's
    /// static in `.bss`, replaced before use: not a mechanization until
    /// then).
    pub const BLANK: Self = Self {
        earth: LocalEarth::<f32>::BLANK,
        cfg: StrapdownConfig {
            max_dt_us: 0,
            vertical: VerticalChannel::Free,
            gravity_mps2: None,
        },
        state: NavState {
            t_us: 0,
            q_s_n: Quaternion::from_vector(crate::real::zeros_f32::<4, 1>()),
            v_n: crate::real::zeros_f32(),
            p_n: crate::real::zeros_f32(),
        },
        q_comp: Quaternion::from_vector(crate::real::zeros_f32::<4, 1>()),
        w_prev: crate::real::zeros_f32(),
        f_n_prev: crate::real::zeros_f32(),
        w_prev2: None,
        dv_prev: crate::real::zeros_f32(),
        dt_cache: (0, 0.0, 0.0),
        steps: 0,
    };
}

impl<T: Real> Strapdown<T> {
    /// Starts navigation at the first sample `first` from a known state:
    /// position `origin` (also the reference point of `p_n`), velocity `v_n`
    /// (NED, m/s) and sensor attitude `q_s_n` (normalised here).
    ///
    /// # Errors
    /// [`NavError::NonFiniteSample`] when the sample or the initial state is
    /// not finite; [`NavError::PolarRegion`] within 0.1 deg of a pole.
    pub fn new(
        cfg: StrapdownConfig,
        origin: GeoPoint,
        v_n: Vector3<T>,
        q_s_n: Quaternion<T>,
        first: &ImuSample<T>,
    ) -> Result<Self, NavError> {
        if !first.is_finite() || !v_n.iter().all(|x| x.is_finite()) {
            return Err(NavError::NonFiniteSample);
        }
        if origin.lat_rad.abs() > (90.0_f64 - 0.1).to_radians() {
            return Err(NavError::PolarRegion);
        }
        let n = q_s_n.norm();
        if !(n.is_finite() && n > T::zero()) {
            return Err(NavError::NonFiniteSample);
        }
        let q_s_n = q_s_n / n;
        let earth = LocalEarth::new(origin, cfg.gravity_mps2);
        Ok(Self {
            earth,
            cfg,
            state: NavState {
                t_us: first.t_us,
                q_s_n,
                v_n,
                p_n: Vector3::zeros(),
            },
            q_comp: Quaternion::new(T::zero(), T::zero(), T::zero(), T::zero()),
            w_prev: first.w_is_s,
            f_n_prev: rotate(&q_s_n, &first.f_s),
            w_prev2: None,
            dv_prev: Vector3::zeros(),
            dt_cache: (0, T::zero(), T::zero()),
            steps: 0,
        })
    }

    /// The current state.
    pub fn state(&self) -> &NavState<T> {
        &self.state
    }

    /// The earth model at the reference point.
    pub fn earth(&self) -> &LocalEarth<T> {
        &self.earth
    }

    /// Steps taken so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The earth quantities at the current position.
    pub fn earth_here(&self) -> EarthAt<T> {
        self.earth.at(&self.state.p_n)
    }

    /// Applies an aiding filter's correction (closed loop): `dp` added to
    /// the position offsets (m), `dv` to the velocity (m/s), and the
    /// attitude turned by the small rotation `phi` in `n` (rad):
    /// `c_s_n <- (I + [phi x]) c_s_n` (`eskf`'s error convention). The
    /// specific force the velocity rule remembers turns with it.
    ///
    /// # Errors
    /// [`NavError::NonFiniteSample`] when a correction is not finite (the
    /// state is then unchanged).
    pub fn correct(
        &mut self,
        dp: &Vector3<T>,
        dv: &Vector3<T>,
        phi: &Vector3<T>,
    ) -> Result<(), NavError> {
        if !(dp
            .iter()
            .chain(dv.iter())
            .chain(phi.iter())
            .all(|x| x.is_finite()))
        {
            return Err(NavError::NonFiniteSample);
        }
        let dq = crate::attitude::rotvec_to_quat(phi);
        let q = dq * self.state.q_s_n;
        self.state.q_s_n = q / q.norm();
        self.q_comp = Quaternion::new(T::zero(), T::zero(), T::zero(), T::zero());
        self.f_n_prev = rotate(&dq, &self.f_n_prev);
        self.state.v_n += dv;
        self.state.p_n += dp;
        Ok(())
    }

    /// One strapdown step `k-1 -> k` with the sample at `t_k`. Attitude,
    /// then velocity, then position (see the module docs). On error the state
    /// is unchanged and the sample is not used.
    ///
    /// # Errors
    /// [`NavError::NonFiniteSample`], [`NavError::TimeNotIncreasing`],
    /// [`NavError::GapTooLong`], [`NavError::PolarRegion`].
    pub fn step(&mut self, sample: &ImuSample<T>) -> Result<&NavState<T>, NavError> {
        if !sample.is_finite() {
            return Err(NavError::NonFiniteSample);
        }
        let prev_us = self.state.t_us;
        let dt_us = match sample.t_us.checked_sub(prev_us) {
            Some(d) if d > 0 => d,
            _ => {
                return Err(NavError::TimeNotIncreasing {
                    prev_us,
                    t_us: sample.t_us,
                })
            }
        };
        if dt_us > self.cfg.max_dt_us {
            return Err(NavError::GapTooLong {
                dt_us,
                max_us: self.cfg.max_dt_us,
            });
        }
        if self.dt_cache.0 != dt_us {
            let dt_f64 = dt_us as f64 * 1e-6;
            let hi = T::lit(dt_f64);
            self.dt_cache = (dt_us, hi, T::lit(dt_f64 - hi.to_f64()));
        }
        let (_, dt, dt_lo) = self.dt_cache;
        let half = T::lit(0.5);
        let s = &self.state;

        // Earth and transport rates at mid-interval (extrapolated).
        let v_mid0 = s.v_n + self.dv_prev * half;
        let p_mid = s.p_n + v_mid0 * (dt * half);
        let e_mid = self.earth.at(&p_mid);
        if e_mid.cos_lat <= T::lit(1.745e-3) {
            return Err(NavError::PolarRegion);
        }
        let tan_lat = e_mid.sin_lat / e_mid.cos_lat;
        let w_ie_n = earth_rate_n(e_mid.sin_lat, e_mid.cos_lat);
        let w_en_n = transport_rate_n(&v_mid0, e_mid.r_m, e_mid.r_n, e_mid.height_m, tan_lat);

        // 1. Attitude.
        let w_k = sample.w_is_s;
        // The large term (the table rate) with the step length to f64 precision.
        let a = self.w_prev * dt + self.w_prev * dt_lo;
        let phi = match self.w_prev2 {
            Some((w2, dt2_us)) if dt2_us == dt_us => {
                let b = (w_k - w2) * (dt * half);
                let c = (w_k - self.w_prev * T::lit(2.0) + w2) * (dt * half);
                let third = T::lit(1.0 / 3.0);
                let twelfth = T::lit(1.0 / 12.0);
                a + b * half
                    + c * third
                    + (a.cross(&b) + a.cross(&c)) * twelfth
                    + b.cross(&c) * T::lit(1.0 / 60.0)
            }
            _ => {
                let b = (w_k - self.w_prev) * dt;
                a + b * half + a.cross(&b) * T::lit(1.0 / 12.0)
            }
        };
        let zeta = (w_ie_n + w_en_n) * dt;
        let ds = rotvec_to_delta(&phi).d();
        let dn = rotvec_to_delta(&(-zeta)).d();
        let q = s.q_s_n;
        // (1 + dn) q (1 + ds) - q = q ds + dn q + dn q ds
        let q_ds = q * ds;
        let mut dq = q_ds + dn * q + dn * q_ds;
        // First-order renormalisation: q / |q| ~ q (1 - (|q|^2 - 1)/2).
        let q_try = q + dq;
        let eps = (q_try.norm_squared() - T::one()) * half;
        dq -= q_try * eps;
        // Kahan-compensated q += dq.
        let y = dq - self.q_comp;
        let q_new = q + y;
        self.q_comp = (q_new - q) - y;

        // 2. Velocity.
        let f_n = rotate(&q_new, &sample.f_s);
        let f_avg = (self.f_n_prev + f_n) * half;
        let g_n = Vector3::new(T::zero(), T::zero(), e_mid.gravity);
        let v_mid = s.v_n + (f_avg + g_n) * (dt * half);
        let coriolis = (w_ie_n * T::lit(2.0) + w_en_n).cross(&v_mid);
        let mut dv = (f_avg + g_n - coriolis) * dt;
        if self.cfg.vertical == VerticalChannel::HoldHeight {
            dv.z = T::zero();
        }
        let v_new = s.v_n + dv;

        // 3. Position (curvilinear offsets; rates scaled to the reference radii).
        let rn_h = e_mid.r_n + e_mid.height_m;
        let k_north = self.earth.rm_h0 / (e_mid.r_m + e_mid.height_m);
        let k_east = self.earth.rn_h0_cos / (rn_h * e_mid.cos_lat);
        let v_avg = (s.v_n + v_new) * half;
        let dp = Vector3::new(v_avg.x * k_north, v_avg.y * k_east, v_avg.z) * dt;
        let p_new = s.p_n + dp;

        self.w_prev2 = Some((self.w_prev, dt_us));
        self.w_prev = w_k;
        self.f_n_prev = f_n;
        self.dv_prev = dv;
        self.steps += 1;
        self.state = NavState {
            t_us: sample.t_us,
            q_s_n: q_new,
            v_n: v_new,
            p_n: p_new,
        };
        Ok(&self.state)
    }
}

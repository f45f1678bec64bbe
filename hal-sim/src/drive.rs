//! A vehicle carrying the table: seeded drives (`city`, `highway`: starts,
//! stops, turns, hills), the vehicle's true motion integrated on the WGS-84
//! earth, what an ideal sensor on the spinning table reads on it, and a
//! GNSS receiver (fixes of the antenna at its rate, noise, reported sigmas,
//! outages).
//!
//! The road frame `r` (x forward, y right, z down) has no roll; the plan's
//! speed `s`, heading `psi` and pitch `theta` (from the road's grade) move
//! the rear axle's centre at `s (cos theta cos psi, cos theta sin psi, -sin
//! theta)`: it does not slide sideways or leave the road (what
//! `core_nav::vehicle`'s constraints assume; a real car's sideslip is not
//! simulated). The body `v` rolls, pitches and heaves on its suspension
//! relative to `r` ([`crate::body`]), about a pivot at the axle; the IMU
//! moves with it as a rigid body. The base `b` is mounted in the body by
//! `c_b_v` ([`mounting`]; the identity unless the drive says). Its
//! controls (longitudinal acceleration, yaw rate) are piecewise constant
//! with raised-cosine edges (continuous, so the specific force has no
//! steps between samples); the grade is a sum of sines along the distance.
//!
//! The ideal sensor (recording-v1, "Moving base and GNSS"; Groves Eq. 5.54
//! rearranged), with the earth quantities of `core_nav::earth` (one
//! physics):
//!
//! ```text
//! w_iv_v = c_n_v (w_ie_n + w_en_n) + w_nv_v,  w_nv_v = (-psi' sin theta, theta', psi' cos theta)
//! f_v    = c_n_v (v_n' + (2 w_ie_n + w_en_n) x v_n - g_n)
//! w_ib_b = c_v_b w_iv_v,  f_b = c_v_b f_v
//! w_is_s = c_b_s w_ib_b + theta_table' k,     f_s = c_b_s f_b
//! ```
//!
//! (the IMU at the table's centre; the table's own lever-arm terms are the
//! static world's, `world::Scene`).

use crate::body::{Body, Pose};
use crate::rng::Rng;
use core_nav::attitude::Euler;
use core_nav::earth::{earth_rate_n, normal_gravity, radii, transport_rate_n, GeoPoint};
use nalgebra::{Matrix3, Vector3};

/// Which kind of drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DriveKind {
    /// Stops every minute or two, 8-14 m/s, right-angle turns, 3 % hills.
    City,
    /// 25-33 m/s, gentle curves and lane changes, 4 % grades over 2 km.
    Highway,
}

impl DriveKind {
    /// `city` or `highway`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "city" => Some(Self::City),
            "highway" => Some(Self::Highway),
            _ => None,
        }
    }

    /// The name.
    pub fn name(self) -> &'static str {
        match self {
            Self::City => "city",
            Self::Highway => "highway",
        }
    }
}

/// Half the length of a control's raised-cosine edge, s.
const EDGE_S: f64 = 0.4;

/// One control held over `[t0, t1]`, with raised-cosine edges centred on
/// `t0` and `t1` (its integral is exactly `value (t1 - t0)`).
#[derive(Clone, Copy, Debug)]
struct Hold {
    t0: f64,
    t1: f64,
    value: f64,
}

impl Hold {
    /// Its integral from the start of time to `t` (exact: the plan's speed
    /// and heading carry no integration error, and a stop is a stop).
    fn integral(&self, t: f64) -> f64 {
        let e = |c: f64| -> f64 {
            let u = (t - (c - EDGE_S)) / (2.0 * EDGE_S);
            if u <= 0.0 {
                0.0
            } else if u >= 1.0 {
                t - c
            } else {
                let w = std::f64::consts::PI * u;
                2.0 * EDGE_S * (0.5 * u - w.sin() / (2.0 * std::f64::consts::PI))
            }
        };
        self.value * (e(self.t0) - e(self.t1))
    }

    fn at(&self, t: f64) -> (f64, f64) {
        // (value, derivative)
        let edge = |c: f64| -> (f64, f64) {
            // 0 before c - e, 1 after c + e, raised cosine between.
            let u = (t - (c - EDGE_S)) / (2.0 * EDGE_S);
            if u <= 0.0 {
                (0.0, 0.0)
            } else if u >= 1.0 {
                (1.0, 0.0)
            } else {
                let w = std::f64::consts::PI * u;
                (
                    0.5 * (1.0 - w.cos()),
                    0.5 * w.sin() * std::f64::consts::PI / (2.0 * EDGE_S),
                )
            }
        };
        let (a, da) = edge(self.t0);
        let (b, db) = edge(self.t1);
        (self.value * (a - b), self.value * (da - db))
    }
}

/// A drive's plan: accelerations and yaw rates over time, the road's grade.
#[derive(Clone, Debug)]
pub struct Drive {
    /// Kind.
    pub kind: DriveKind,
    accel: Vec<Hold>,
    yaw: Vec<Hold>,
    /// Grade as (amplitude, wavelength m, phase rad) sines of the distance.
    grade: Vec<(f64, f64, f64)>,
    /// Length of the plan, s.
    pub duration_s: f64,
    /// The car's body on its suspension (drawn from the plan's seed).
    pub body: Body,
}

/// Seconds a plan adds after the requested end (the vehicle keeps going).
const TAIL_S: f64 = 5.0;

impl Drive {
    /// A seeded plan of at least `duration_s`.
    pub fn plan(kind: DriveKind, duration_s: f64, seed: u64) -> Self {
        let mut rng = Rng::new(seed, 21);
        let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rng.uniform();
        let (mut accel, mut yaw) = (vec![], vec![]);
        let mut t;
        let mut v = 0.0;
        let end = duration_s + TAIL_S;
        let go = |accel: &mut Vec<Hold>, t: &mut f64, v: &mut f64, target: f64, a: f64| {
            let dur = (target - *v).abs() / a;
            if dur > 0.0 {
                accel.push(Hold {
                    t0: *t,
                    t1: *t + dur,
                    value: (target - *v).signum() * a,
                });
                *t += dur;
                *v = target;
            }
        };
        match kind {
            DriveKind::City => {
                t = u(8.0, 15.0); // parked at the start
                while t < end {
                    let cruise = u(8.0, 14.0);
                    go(&mut accel, &mut t, &mut v, cruise, u(1.2, 2.2));
                    let mut left = u(20.0, 60.0);
                    while left > 0.0 && t < end {
                        let straight = u(5.0, 20.0).min(left);
                        t += straight;
                        left -= straight;
                        if u(0.0, 1.0) < 0.6 {
                            // A right-angle turn at the cruise speed.
                            let dur = u(6.0, 9.0);
                            let sign = if u(0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
                            yaw.push(Hold {
                                t0: t,
                                t1: t + dur,
                                value: sign * std::f64::consts::FRAC_PI_2 / dur,
                            });
                            t += dur;
                        }
                    }
                    go(&mut accel, &mut t, &mut v, 0.0, u(1.5, 2.5));
                    t += u(10.0, 25.0); // the light
                }
            }
            DriveKind::Highway => {
                t = u(5.0, 10.0);
                go(&mut accel, &mut t, &mut v, u(25.0, 33.0), u(1.2, 1.8));
                while t < end {
                    let straight = u(20.0, 60.0);
                    t += straight;
                    let r = u(0.5, 2.0).to_radians() * if u(0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
                    let dur = u(15.0, 40.0);
                    yaw.push(Hold {
                        t0: t,
                        t1: t + dur,
                        value: r,
                    });
                    t += dur;
                    if u(0.0, 1.0) < 0.3 {
                        // Traffic: slow down and speed up again.
                        let target = u(18.0, 24.0);
                        let back = v;
                        go(&mut accel, &mut t, &mut v, target, u(0.8, 1.5));
                        t += u(10.0, 30.0);
                        go(&mut accel, &mut t, &mut v, back, u(0.8, 1.5));
                    }
                }
            }
        }
        let grade = match kind {
            DriveKind::City => vec![
                (0.03, u(300.0, 500.0), u(0.0, std::f64::consts::TAU)),
                (0.01, 90.0, u(0.0, std::f64::consts::TAU)),
            ],
            DriveKind::Highway => vec![(0.04, u(1500.0, 2500.0), u(0.0, std::f64::consts::TAU))],
        };
        Self {
            kind,
            accel,
            yaw,
            grade,
            duration_s: t.max(end),
            body: Body::draw(seed),
        }
    }

    /// Speed along the road at `t`, m/s (the acceleration's exact
    /// integral; exactly 0 when stopped).
    pub fn speed_at(&self, t: f64) -> f64 {
        let v = integral_at(&self.accel, t);
        if v.abs() < 1e-9 {
            0.0
        } else {
            v.max(0.0)
        }
    }

    /// Longitudinal acceleration (m/s^2) and its rate at `t` (s).
    fn accel_at(&self, t: f64) -> (f64, f64) {
        sum_at(&self.accel, t)
    }

    /// Yaw rate (rad/s) and its rate at `t`.
    fn yaw_at(&self, t: f64) -> (f64, f64) {
        sum_at(&self.yaw, t)
    }

    /// Pitch (rad) and its derivative along the distance (rad/m) at
    /// distance `d` (m).
    fn pitch_at(&self, d: f64) -> (f64, f64) {
        let (th, dth, _) = self.pitch_curve(d);
        (th, dth)
    }

    /// Pitch (rad) and its first and second derivatives along the
    /// distance (rad/m, rad/m^2) at distance `d` (m).
    fn pitch_curve(&self, d: f64) -> (f64, f64, f64) {
        let tau = std::f64::consts::TAU;
        let (mut g, mut dg, mut ddg) = (0.0, 0.0, 0.0);
        for (a, l, ph) in &self.grade {
            let k = tau / l;
            g += a * (k * d + ph).sin();
            dg += a * k * (k * d + ph).cos();
            ddg -= a * k * k * (k * d + ph).sin();
        }
        // theta = atan(g): theta' = g' / (1 + g^2), theta'' = g'' / (1 +
        // g^2) - 2 g g'^2 / (1 + g^2)^2.
        let q = 1.0 + g * g;
        (g.atan(), dg / q, ddg / q - 2.0 * g * dg * dg / (q * q))
    }
}

fn integral_at(h: &[Hold], t: f64) -> f64 {
    h.iter().map(|x| x.integral(t)).sum()
}

fn sum_at(h: &[Hold], t: f64) -> (f64, f64) {
    h.iter()
        .filter(|x| t > x.t0 - EDGE_S && t < x.t1 + EDGE_S)
        .fold((0.0, 0.0), |(a, b), x| {
            let (v, d) = x.at(t);
            (a + v, b + d)
        })
}

/// The vehicle's true state at one time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VehicleState {
    /// Time, s.
    pub t_s: f64,
    /// Position of the table's centre.
    pub pos: GeoPoint,
    /// Velocity relative to the earth, NED, m/s.
    pub v_n: Vector3<f64>,
    /// Its time derivative, NED, m/s^2.
    pub a_n: Vector3<f64>,
    /// Attitude of the vehicle's body `v` in `n`: roll, pitch, heading,
    /// rad (ZYX).
    pub euler_rad: [f64; 3],
    /// Rate of `v` relative to `n`, in `v`, rad/s.
    pub w_nv_v: Vector3<f64>,
    /// The base's mounting in the vehicle, `c_b_v` (the identity unless
    /// the drive says).
    pub c_b_v: Matrix3<f64>,
    /// Speed along the road, m/s.
    pub speed_mps: f64,
    /// Distance driven, m.
    pub distance_m: f64,
}

impl VehicleState {
    /// The vehicle's attitude, `c_v_n`.
    pub fn c_v_n(&self) -> Matrix3<f64> {
        let [r, p, h] = self.euler_rad;
        core_nav::site::c_b_n(&Euler {
            roll: r,
            pitch: p,
            heading: h,
        })
    }

    /// The base's attitude, `c_b_n = c_v_n c_b_v`.
    pub fn c_b_n(&self) -> Matrix3<f64> {
        self.c_v_n() * self.c_b_v
    }

    /// The base's roll, pitch and heading (ZYX), rad.
    pub fn base_euler_rad(&self) -> [f64; 3] {
        let e = core_nav::attitude::dcm_to_euler(&self.c_b_n());
        [e.roll, e.pitch, e.heading]
    }

    /// Rate of `b` relative to `n`, in `b`, rad/s.
    pub fn w_nb_b(&self) -> Vector3<f64> {
        self.c_b_v.transpose() * self.w_nv_v
    }

    /// What an ideal IMU with axes `b` at the table's centre reads:
    /// `(w_ib_b rad/s, f_b m/s^2)` (module docs).
    pub fn ideal_b(&self) -> (Vector3<f64>, Vector3<f64>) {
        let (s, c) = (self.pos.lat_rad.sin(), self.pos.lat_rad.cos());
        let (r_m, r_n) = radii(s * s);
        let w_ie = earth_rate_n(s, c);
        let w_en = transport_rate_n(&self.v_n, r_m, r_n, self.pos.height_m, s / c);
        let g_n = Vector3::new(0.0, 0.0, normal_gravity(s * s, self.pos.height_m));
        let c_n_v = self.c_v_n().transpose();
        let w = c_n_v * (w_ie + w_en) + self.w_nv_v;
        let f = c_n_v * (self.a_n + (w_ie * 2.0 + w_en).cross(&self.v_n) - g_n);
        let c_v_b = self.c_b_v.transpose();
        (c_v_b * w, c_v_b * f)
    }
}

/// The body's vibration, added to the specific force in `v` at `t_s`
/// (m/s^2): road and engine modes at 13 and 27 Hz, 0.25 and 0.1 m/s^2
/// vertically, 0.08 and 0.03 along and across, scaled up with the speed to
/// 3 m/s; parked, the engine's idle at [`IDLE_SCALE`] of the 27 Hz mode's.
/// Oscillatory, so the velocity it implies stays within 4 mm/s (not part
/// of the truth).
pub fn vibration_v(t_s: f64, speed_mps: f64) -> Vector3<f64> {
    let k = (speed_mps / 3.0).clamp(0.0, 1.0);
    let tau = std::f64::consts::TAU;
    let (a, b) = ((tau * 13.0 * t_s).sin(), (tau * 27.0 * t_s + 1.0).sin());
    let b = b * k.max(IDLE_SCALE);
    Vector3::new(
        0.08 * a * k + 0.03 * b,
        0.03 * a * k - 0.08 * b,
        0.25 * a * k + 0.1 * b,
    )
}

/// The engine's vibration idling, of its 27 Hz mode's size driving.
pub const IDLE_SCALE: f64 = 0.3;

/// The base's mounting in the vehicle, `c_b_v`, from its roll, pitch and
/// yaw in the vehicle (ZYX, deg: as `[mounting] imu_to_base_deg`).
pub fn mounting(roll_pitch_yaw_deg: [f64; 3]) -> Matrix3<f64> {
    let [r, p, y] = roll_pitch_yaw_deg.map(f64::to_radians);
    core_nav::site::c_b_n(&Euler {
        roll: r,
        pitch: p,
        heading: y,
    })
}

/// The vehicle integrated over a drive at a fixed step.
#[derive(Clone, Debug)]
pub struct Vehicle {
    drive: Drive,
    state: VehicleState,
    heading0: f64,
    c_b_v: Matrix3<f64>,
    /// The point that does not slide sideways (the rear axle's centre).
    axle: GeoPoint,
    /// The table's centre ahead of it along the vehicle's x, m.
    imu_ahead_m: f64,
}

impl Vehicle {
    /// Parked at `origin`, heading `heading_deg`, at `t = 0`, the base
    /// mounted in it by `c_b_v` ([`mounting`]).
    pub fn new(drive: Drive, origin: GeoPoint, heading_deg: f64, c_b_v: Matrix3<f64>) -> Self {
        let mut v = Self {
            drive,
            state: VehicleState {
                pos: origin,
                ..VehicleState::default()
            },
            heading0: heading_deg.to_radians(),
            c_b_v,
            axle: origin,
            imu_ahead_m: 0.0,
        };
        v.state = v.derived(0.0, origin, 0.0);
        v
    }

    /// The same vehicle with the table's centre `m` metres ahead of the
    /// rear axle's centre (the point the plan drives, which does not
    /// slide sideways): in a turn the table then moves sideways at the
    /// yaw rate times `m`, as an IMU ahead of a real car's rear axle does.
    /// The axle starts at the origin.
    pub fn with_imu_ahead_m(mut self, m: f64) -> Self {
        self.imu_ahead_m = m;
        self.state = self.derived(self.state.t_s, self.axle, self.state.distance_m);
        self
    }

    /// The state now.
    pub fn state(&self) -> &VehicleState {
        &self.state
    }

    /// The drive.
    pub fn drive(&self) -> &Drive {
        &self.drive
    }

    /// The road frame `r` at `t` (heading and the grade's pitch, no roll)
    /// and the rear axle's velocity and acceleration along it, the axle
    /// `distance` m along the road.
    fn road(&self, t: f64, distance: f64) -> Road {
        let speed = self.drive.speed_at(t);
        let (a, _) = self.drive.accel_at(t);
        let (r, r_dot) = self.drive.yaw_at(t);
        let psi = self.heading0 + integral_at(&self.drive.yaw, t);
        let (th, dth_dd, ddth_dd) = self.drive.pitch_curve(distance);
        let th_dot = dth_dd * speed;
        let th_ddot = ddth_dd * speed * speed + dth_dd * a;
        let (sp, cp, st, ct) = (psi.sin(), psi.cos(), th.sin(), th.cos());
        let u = Vector3::new(ct * cp, ct * sp, -st);
        let du_dpsi = Vector3::new(-ct * sp, ct * cp, 0.0);
        let du_dth = Vector3::new(-st * cp, -st * sp, -ct);
        Road {
            euler: [0.0, th, psi],
            w: Vector3::new(-r * st, th_dot, r * ct),
            w_dot: Vector3::new(
                -r_dot * st - r * ct * th_dot,
                th_ddot,
                r_dot * ct - r * st * th_dot,
            ),
            v_n: u * speed,
            a_n: u * a + (du_dpsi * r + du_dth * th_dot) * speed,
            speed,
        }
    }

    /// The body's pose on its suspension at `t` ([`Body::pose`]).
    fn pose(&self, t: f64) -> Pose {
        let d = &self.drive;
        let psi = |tt: f64| integral_at(&d.yaw, tt);
        d.body.pose(t, |tt| (d.speed_at(tt), psi(tt)))
    }

    /// Velocity, acceleration, attitude and rates from the integrated
    /// speed, distance and heading, the rear axle at `axle`: the road's
    /// frame, the body's pose on it about a pivot at the axle, the table's
    /// centre [`Vehicle::with_imu_ahead_m`] ahead of the pivot and the
    /// body's [`Body::imu_above_m`] above it, moving as a rigid body.
    fn derived(&self, t: f64, axle: GeoPoint, distance: f64) -> VehicleState {
        let road = self.road(t, distance);
        let [[ph, ph_d, ph_dd], [th, th_d, th_dd], [z, z_d, z_dd], [ps, ps_d, ps_dd]] =
            self.pose(t);
        let euler = |[r, p, h]: [f64; 3]| Euler {
            roll: r,
            pitch: p,
            heading: h,
        };
        let c_r_n = core_nav::site::c_b_n(&euler(road.euler));
        // The body on the road: ZYX, the slip's yaw, the pitch, the roll.
        let r_v_r = core_nav::site::c_b_n(&euler([ph, th, ps]));
        let c = c_r_n * r_v_r;
        let e = core_nav::attitude::dcm_to_euler(&c);
        let body_euler = [e.roll, e.pitch, e.heading.rem_euclid(std::f64::consts::TAU)];
        let (w_rel, w_rel_dot) = zyx_rate([ph, ph_d, ph_dd], [th, th_d, th_dd], [ps, ps_d, ps_dd]);
        let w_road_v = r_v_r.transpose() * road.w;
        let w = w_road_v + w_rel;
        let w_dot = r_v_r.transpose() * road.w_dot - w_rel.cross(&w_road_v) + w_rel_dot;
        // The pivot heaves along the road's down axis: its offset, velocity
        // and acceleration relative to the axle, in `r`.
        let zr = Vector3::z();
        let q = road.w.cross(&zr) * z + zr * z_d;
        let q_dot = road.w.cross(&zr) * z_d + road.w_dot.cross(&zr) * z + zr * z_dd;
        let l_v = Vector3::new(self.imu_ahead_m, 0.0, -self.drive.body.imu_above_m);
        // Rigid-body motion in the local level frame (its transport rate,
        // under 1e-5 m/s at the arm, left out).
        let l_n = c_r_n * (zr * z) + c * l_v;
        VehicleState {
            t_s: t,
            pos: GeoPoint {
                lat_rad: axle.lat_rad + l_n.x / meridian(&axle),
                lon_rad: axle.lon_rad + l_n.y / (transverse(&axle) * axle.lat_rad.cos()),
                height_m: axle.height_m - l_n.z,
            },
            v_n: road.v_n + c_r_n * q + c * w.cross(&l_v),
            a_n: road.a_n
                + c_r_n * (road.w.cross(&q) + q_dot)
                + c * (w_dot.cross(&l_v) + w.cross(&w.cross(&l_v))),
            euler_rad: body_euler,
            w_nv_v: w,
            c_b_v: self.c_b_v,
            speed_mps: road.speed,
            distance_m: distance,
        }
    }

    /// Advances by `dt` s: speed and heading from the plan's exact
    /// integrals, distance and position by the midpoint rule.
    pub fn step(&mut self, dt: f64) {
        let t0 = self.state.t_s;
        let d0 = self.state.distance_m;
        let p0 = self.axle;
        let v0 = self.road(t0, d0).v_n;
        let tm = t0 + 0.5 * dt;
        let speed_m = self.drive.speed_at(tm);
        let heading_m = self.heading0 + integral_at(&self.drive.yaw, tm);
        let d_m = d0 + 0.5 * dt * speed_m;
        let (th, _) = self.drive.pitch_at(d_m);
        let v_m = Vector3::new(
            th.cos() * heading_m.cos(),
            th.cos() * heading_m.sin(),
            -th.sin(),
        ) * speed_m;
        let lat_m = p0.lat_rad + 0.5 * dt * v0.x / meridian(&p0);
        let pm = GeoPoint {
            lat_rad: lat_m,
            ..p0
        };
        let pos = GeoPoint {
            lat_rad: p0.lat_rad + dt * v_m.x / meridian(&pm),
            lon_rad: p0.lon_rad + dt * v_m.y / (transverse(&pm) * lat_m.cos()),
            height_m: p0.height_m - dt * v_m.z,
        };
        let distance = d0 + dt * speed_m;
        self.axle = pos;
        self.state = self.derived(t0 + dt, pos, distance);
    }
}

/// The road frame `r` and the rear axle's motion along it.
struct Road {
    /// `r`'s roll (0), pitch and heading, rad.
    euler: [f64; 3],
    /// `r`'s rate relative to `n`, in `r`, rad/s, and its derivative.
    w: Vector3<f64>,
    w_dot: Vector3<f64>,
    /// The axle's velocity (m/s) and acceleration (m/s^2), NED.
    v_n: Vector3<f64>,
    a_n: Vector3<f64>,
    /// Speed along the road, m/s.
    speed: f64,
}

fn meridian(p: &GeoPoint) -> f64 {
    let s = p.lat_rad.sin();
    radii(s * s).0 + p.height_m
}

fn transverse(p: &GeoPoint) -> f64 {
    let s = p.lat_rad.sin();
    radii(s * s).1 + p.height_m
}

/// The GNSS receiver.
#[derive(Clone, Debug, PartialEq)]
pub struct GnssSpec {
    /// Fix rate, Hz.
    pub rate_hz: f64,
    /// Antenna from the table's centre, in `b`, m.
    pub antenna_b_m: Vector3<f64>,
    /// Horizontal position error, 1-sigma per axis, m (half white, half a
    /// 60 s Gauss-Markov: multipath and atmosphere drift).
    pub sigma_h_m: f64,
    /// Vertical, m.
    pub sigma_v_m: f64,
    /// Velocity error, 1-sigma per axis, m/s (white).
    pub sigma_vel_mps: f64,
    /// Outages: (start s, length s); no fix inside.
    pub outages: Vec<(f64, f64)>,
    /// The fixes' stamps on the IMU's clock are this early, s: a logger
    /// that stamps the IMU's samples late (`navigate
    /// --estimate-time-offset` finds `+stamp_early_s`). Fixes whose stamp
    /// would fall before 0 are not written.
    pub stamp_early_s: f64,
}

impl Default for GnssSpec {
    /// A 1 Hz automotive receiver, antenna 1 m ahead of and 0.8 m above the
    /// table.
    fn default() -> Self {
        Self {
            rate_hz: 1.0,
            antenna_b_m: Vector3::new(1.0, 0.0, -0.8),
            sigma_h_m: 1.5,
            sigma_v_m: 3.0,
            sigma_vel_mps: 0.05,
            outages: vec![],
            stamp_early_s: 0.0,
        }
    }
}

/// One receiver fix (recording-v1 `gnss.csv`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssFix {
    /// Time, s (the IMU's clock).
    pub t_s: f64,
    /// Antenna position.
    pub pos: GeoPoint,
    /// Antenna velocity, NED, m/s.
    pub v_n: Vector3<f64>,
    /// Reported 1-sigma: horizontal, vertical (m), velocity (m/s).
    pub sigma: [f64; 3],
}

/// Correlation time of the receiver's position error, s.
const GNSS_TAU_S: f64 = 60.0;

/// The receiver: its correlated position error and random streams.
#[derive(Clone, Debug)]
pub struct Receiver {
    spec: GnssSpec,
    rng: Rng,
    drift: Vector3<f64>,
    last_t: Option<f64>,
}

impl Receiver {
    /// A receiver drawing its errors from `seed`.
    pub fn new(spec: GnssSpec, seed: u64) -> Self {
        let mut rng = Rng::new(seed, 31);
        let sig = Vector3::new(spec.sigma_h_m, spec.sigma_h_m, spec.sigma_v_m) * 0.5f64.sqrt();
        let drift = rng.normal3().component_mul(&sig);
        Self {
            spec,
            rng,
            drift,
            last_t: None,
        }
    }

    /// In an outage at `t`?
    pub fn in_outage(&self, t: f64) -> bool {
        self.spec.outages.iter().any(|(s, l)| t >= *s && t < s + l)
    }

    /// The fix at the nominal epoch `t_epoch_s` (k / rate, s) for the
    /// vehicle in `v` (its time, the physics step nearest the epoch),
    /// `None` in an outage (the error processes still advance). Outages
    /// are windows on the nominal epochs: the vehicle's accumulated float
    /// time (299.99999999982 s for 300 s) would put every outage one fix
    /// late and one fix long.
    pub fn fix(&mut self, v: &VehicleState, t_epoch_s: f64) -> Option<GnssFix> {
        let sp = &self.spec;
        let sig = Vector3::new(sp.sigma_h_m, sp.sigma_h_m, sp.sigma_v_m) * 0.5f64.sqrt();
        let dt = self.last_t.map_or(1.0 / sp.rate_hz, |l| v.t_s - l);
        self.last_t = Some(v.t_s);
        let phi = (-dt / GNSS_TAU_S).exp();
        self.drift = self.drift * phi
            + self
                .rng
                .normal3()
                .component_mul(&(sig * (1.0 - phi * phi).sqrt()));
        let white = self.rng.normal3().component_mul(&sig);
        let vel_noise = self.rng.normal3() * sp.sigma_vel_mps;
        if self.in_outage(t_epoch_s) {
            return None;
        }
        let c_b_n = v.c_b_n();
        let l_n = c_b_n * sp.antenna_b_m;
        let err = self.drift + white;
        let d_n = l_n + err;
        let p = v.pos;
        let pos = GeoPoint {
            lat_rad: p.lat_rad + d_n.x / meridian(&p),
            lon_rad: p.lon_rad + d_n.y / (transverse(&p) * p.lat_rad.cos()),
            height_m: p.height_m - d_n.z,
        };
        let v_ant = v.v_n + c_b_n * v.w_nb_b().cross(&sp.antenna_b_m);
        Some(GnssFix {
            t_s: v.t_s,
            pos,
            v_n: v_ant + vel_noise,
            sigma: [sp.sigma_h_m, sp.sigma_v_m, sp.sigma_vel_mps],
        })
    }
}

/// Parses `START:LEN` (s) of `--gnss-outage`.
///
/// # Errors
/// Not two non-negative numbers, a zero length.
pub fn parse_outage(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s
        .split_once(':')
        .ok_or_else(|| format!("--gnss-outage {s:?}: expected START:LEN in seconds"))?;
    let start: f64 = a
        .trim()
        .parse()
        .map_err(|_| format!("--gnss-outage {s:?}: START is not a number"))?;
    let len: f64 = b
        .trim()
        .parse()
        .map_err(|_| format!("--gnss-outage {s:?}: LEN is not a number"))?;
    if !(start.is_finite() && len.is_finite() && start >= 0.0 && len > 0.0) {
        return Err(format!(
            "--gnss-outage {s:?}: START must be >= 0 and LEN > 0"
        ));
    }
    Ok((start, len))
}

/// The body rate (rad/s, in the rotated frame) of ZYX angles `roll`,
/// `pitch`, `yaw` (each `[x, x', x'']`, rad, per s, per s^2) and its
/// derivative (Groves Eq. 2.56's inverse, differentiated).
fn zyx_rate(roll: [f64; 3], pitch: [f64; 3], yaw: [f64; 3]) -> (Vector3<f64>, Vector3<f64>) {
    let ([ph, ph_d, ph_dd], [th, th_d, th_dd], [_, ps_d, ps_dd]) = (roll, pitch, yaw);
    let (sr, cr, st, ct) = (ph.sin(), ph.cos(), th.sin(), th.cos());
    let w = Vector3::new(
        ph_d - ps_d * st,
        th_d * cr + ps_d * sr * ct,
        -th_d * sr + ps_d * cr * ct,
    );
    let w_dot = Vector3::new(
        ph_dd - ps_dd * st - ps_d * th_d * ct,
        th_dd * cr - th_d * ph_d * sr + ps_dd * sr * ct + ps_d * (ph_d * cr * ct - th_d * sr * st),
        -th_dd * sr - th_d * ph_d * cr + ps_dd * cr * ct - ps_d * (ph_d * sr * ct + th_d * cr * st),
    );
    (w, w_dot)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plan_integrates_to_its_speeds_and_stops() {
        for kind in [DriveKind::City, DriveKind::Highway] {
            let d = Drive::plan(kind, 600.0, 3);
            let mut v = Vehicle::new(
                d,
                GeoPoint::from_deg(30.5, 114.3, 20.0),
                45.0,
                Matrix3::identity(),
            );
            let mut vmax: f64 = 0.0;
            let mut stops = 0;
            let mut prev = 0.0;
            for _ in 0..600_000 {
                v.step(1e-3);
                let s = v.state().speed_mps;
                vmax = vmax.max(s);
                if prev > 0.0 && s == 0.0 {
                    stops += 1;
                }
                prev = s;
            }
            match kind {
                DriveKind::City => {
                    assert!(vmax > 7.0 && vmax < 14.5, "{vmax}");
                    assert!(stops >= 3, "{stops} stops");
                }
                DriveKind::Highway => assert!(vmax > 24.0 && vmax < 33.5, "{vmax}"),
            }
        }
    }

    #[test]
    fn an_outage_is_a_window_on_the_fixes_nominal_epochs() {
        // --gnss-outage 300:60 at 1 Hz: the fixes of 300 s to 359 s are
        // dropped, those of 299 s and 360 s kept, whatever the vehicle's
        // accumulated time at the physics step nearest each epoch.
        let spec = GnssSpec {
            outages: vec![(300.0, 60.0)],
            ..GnssSpec::default()
        };
        let mut r = Receiver::new(spec, 1);
        let d = Drive::plan(DriveKind::City, 600.0, 3);
        let mut state = *Vehicle::new(
            d,
            GeoPoint::from_deg(30.5, 114.3, 20.0),
            0.0,
            Matrix3::identity(),
        )
        .state();
        let mut kept = vec![];
        for k in 295..=365u32 {
            let epoch = f64::from(k);
            state.t_s = epoch - 1.8e-10;
            if r.fix(&state, epoch).is_some() {
                kept.push(k);
            }
        }
        let want: Vec<u32> = (295..300).chain(360..=365).collect();
        assert_eq!(kept, want);
    }

    #[test]
    fn velocity_and_acceleration_agree() {
        // a_n is v_n's derivative and v_n the position's: central
        // differences over 1 ms, to 1e-3 m/s^2 and 1e-4 m/s (the midpoint
        // rule's error at the raised-cosine edges), at the rear axle and
        // 1.5 m ahead of it.
        for ahead in [0.0, 1.5] {
            let d = Drive::plan(DriveKind::City, 300.0, 5);
            let mut v = Vehicle::new(
                d,
                GeoPoint::from_deg(30.5, 114.3, 20.0),
                10.0,
                Matrix3::identity(),
            )
            .with_imu_ahead_m(ahead);
            let mut prev = *v.state();
            v.step(1e-3);
            let mut cur = *v.state();
            let (mut sideways, mut slid, mut rv, mut rr) = (0.0f64, 0.0f64, 0.0, 0.0);
            for _ in 0..300_000 {
                v.step(1e-3);
                let next = *v.state();
                let fd = (next.v_n - prev.v_n) / 2e-3;
                assert!(
                    (fd - cur.a_n).norm() < 1e-3,
                    "ahead {ahead}, t {}: {fd:?} vs {:?}",
                    cur.t_s,
                    cur.a_n
                );
                let (p, q) = (&prev.pos, &next.pos);
                let dp = Vector3::new(
                    (q.lat_rad - p.lat_rad) * meridian(&cur.pos),
                    (q.lon_rad - p.lon_rad) * transverse(&cur.pos) * cur.pos.lat_rad.cos(),
                    p.height_m - q.height_m,
                ) / 2e-3;
                assert!(
                    (dp - cur.v_n).norm() < 1e-4,
                    "ahead {ahead}, t {}: {dp:?} vs {:?}",
                    cur.t_s,
                    cur.v_n
                );
                // Sideways in `v`: the rear axle's slide out of the turn
                // (the road's speed across the body yawed by the slip),
                // the yaw rate times the arm, plus the body's roll rate
                // times the IMU's height (zero-mean).
                let v_v = cur.c_v_n().transpose() * cur.v_n;
                let rate = cur.w_nv_v.z;
                let slide = -cur.speed_mps * v.pose(cur.t_s)[3][0].sin();
                rv += rate * (v_v.y - slide);
                rr += rate * rate;
                sideways = sideways.max(v_v.y.abs());
                slid = slid.max(slide.abs());
                prev = cur;
                cur = next;
            }
            // Regressed on the yaw rate, the sideways velocity's slope is the
            // arm: to 0.02 m (the roll's rate at a turn's ends is odd about
            // it; measured -0.012 at both arms).
            assert!((rv / rr - ahead).abs() < 0.02, "{} vs {ahead}", rv / rr);
            assert!(sideways > 0.02, "{sideways}");
            // A city corner's slide: 0.05-0.3 m/s (2-4 deg/g at 2-4 m/s^2
            // and 6-14 m/s).
            assert!(slid > 0.05 && slid < 0.3, "{slid}");
        }
    }
}

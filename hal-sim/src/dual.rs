//! A tri-axial table for dual-axis schemes (simulation only: the recording
//! format carries one table angle). The run starts like the paper's: still,
//! then turning about z for the calibration; at `switch_s` the dual-axis
//! sequence takes over. Kinematics are exact (a perfect table); the sensor
//! is any [`ImuSpec`].
//!
//! `c_s_b = Rx(outer) Rz(inner)`; `w_bs_s = Rz(inner)^T x outer_dot +
//! z inner_dot`.

use crate::imu::{ImuModel, ImuSpec};
use crate::world::Site;
use core_nav::attitude::{euler_to_quat, quat_to_dcm, Euler};
use core_nav::scheme::{DualAxisProfile, Profile};
use core_nav::table::Axis;
use nalgebra::{Matrix3, Rotation3, Vector3};
use recording::{ImuRow, Meta, Recording, SampleKind, TableRow};

/// A dual-axis run: the recording (its table angle is the inner gimbal)
/// and both gimbal angles at each IMU sample.
#[derive(Clone, Debug)]
pub struct DualRun {
    /// The samples (table.csv holds the inner angle).
    pub recording: Recording,
    /// (inner, outer) gimbal angles at each IMU sample, rad.
    pub angles: Vec<(f64, f64)>,
}

/// `c_s_b` for gimbal angles (rad).
pub fn c_s_b(inner: f64, outer: f64) -> Matrix3<f64> {
    (Rotation3::from_axis_angle(&Vector3::x_axis(), outer)
        * Rotation3::from_axis_angle(&Vector3::z_axis(), inner))
    .into_inner()
}

/// Gimbal kinematics at a time: ((inner angle, rate), (outer angle, rate)), rad and rad/s.
pub type Gimbals = ((f64, f64), (f64, f64));

/// The calibration window for a dual-axis run: still until `static_s`,
/// then one reciprocating cycle (a whole turn each way) of the inner
/// gimbal, then one of the outer, each taking `cycle_s`; then `dual`. Both
/// gimbals are back at 0 when `dual` starts, so its outer flips turn the
/// sensor about its own x axis. Returns the kinematics and when `dual`
/// starts.
pub fn calibrate_then_dual(
    recip: Profile,
    static_s: f64,
    dual: DualAxisProfile,
) -> (impl Fn(f64) -> Gimbals, f64) {
    let cycle = recip.period_s();
    let start = static_s + 2.0 * cycle;
    let f = move |t: f64| -> Gimbals {
        let r = |tau: f64| {
            if (0.0..cycle).contains(&tau) {
                recip.at(tau)
            } else {
                Default::default()
            }
        };
        if t < static_s + cycle {
            let a = r(t - static_s);
            ((a.angle, a.rate), (0.0, 0.0))
        } else if t < start {
            let a = r(t - static_s - cycle);
            ((0.0, 0.0), (a.angle, a.rate))
        } else {
            let d = dual.at(t - start);
            ((d.inner.angle, d.inner.rate), (d.outer.angle, d.outer.rate))
        }
    };
    (f, start)
}

/// Simulates `duration_s` of any gimbal motion `kin`.
pub fn simulate_gimbals(
    spec: ImuSpec,
    site: Site,
    kin: &dyn Fn(f64) -> Gimbals,
    duration_s: f64,
    seed: u64,
) -> DualRun {
    let rate_hz = 100.0;
    let mut imu = ImuModel::new(spec.clone(), seed);
    let c_b_n = quat_to_dcm(&euler_to_quat(&Euler::<f64>::default()));
    let n = (duration_s * rate_hz).floor() as usize + 1;
    let mut rec = Recording {
        gyro_only: false,
        moving: None,
        meta: Meta {
            description: Some(format!(
                "dual-axis simulation, imu {}, seed {seed}",
                spec.name
            )),
            latitude_deg: site.lat_deg,
            height_m: site.origin.height_m,
            gravity_mps2: Some(site.gravity_mps2),
            imu_model: Some(spec.model.to_string()),
            imu_rate_hz: rate_hz,
            imu_sample: SampleKind::Instantaneous,
            axis: Axis::Z,
            encoder_rate_hz: rate_hz,
            ..Meta::default()
        },
        imu: Vec::with_capacity(n),
        table: Vec::with_capacity(n),
    };
    let mut angles = Vec::with_capacity(n);
    for k in 0..n {
        let t = k as f64 / rate_hz;
        let ((bi, bi_dot), (ao, ao_dot)) = kin(t);
        let c_s_b = c_s_b(bi, ao);
        let c_n_s = (c_b_n * c_s_b).transpose();
        let w_bs_s = Rotation3::from_axis_angle(&Vector3::z_axis(), -bi) * (Vector3::x() * ao_dot)
            + Vector3::z() * bi_dot;
        let w = c_n_s * site.w_ie_n() + w_bs_s;
        let f = c_n_s * Vector3::new(0.0, 0.0, -site.gravity_mps2);
        let temp = imu.temperature_c(t);
        let (g, a) = imu.measure(&w, &f, temp, 1.0 / rate_hz);
        rec.imu.push(ImuRow {
            t_s: t,
            gyro_radps: g.into(),
            accel_mps2: a.into(),
            temp_c: Some(imu.temp_output_c(temp)),
        });
        rec.table.push(TableRow {
            t_s: t,
            angle_rad: bi,
        });
        angles.push((bi, ao));
    }
    DualRun {
        recording: rec,
        angles,
    }
}

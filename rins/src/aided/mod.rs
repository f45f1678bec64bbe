//! Aided navigation of a moving-base recording (`rins navigate REC
//! --gnss`): core-nav's strapdown mechanization of the spinning sensor,
//! core-nav's error-state Kalman filter ([`core_nav::eskf`]) with the GNSS
//! fixes of `gnss.csv` (antenna lever arm through the table angle) and
//! zero-velocity updates when the vehicle stands still, closed loop. Output:
//! trajectory-v1 rows plus the filter's 1-sigma, and the fixes' NIS.
//!
//! The base attitude `c_b_n = c_s_n c_b_s(theta)` and the table rate come
//! from the encoder (hal-sim's [`hal_sim::track::EncoderTrack`]).
//!
//! **Zero velocity** is detected from the IMU with the table's own rotation
//! removed: over the last [`ZUPT_WINDOW`] samples the base's rotation
//! `|c_s_b (w_is_s - theta_dot k)|` stays under [`ZUPT_GYRO_RADPS`] and the
//! specific force's spread under [`ZUPT_ACCEL_MPS2`]: a moving car shakes
//! (road and engine vibration) and turns; a parked one does neither.

use anyhow::{bail, Result};
use core_nav::attitude::{dcm_to_quat, quat_to_dcm, quat_to_euler};
use core_nav::earth::{earth_rate_n, transport_rate_n, GeoPoint};
use core_nav::eskf::{Eskf, EskfConfig, InitialSigma, I_P, I_PHI, I_V};
use core_nav::real::Real;
use core_nav::strapdown::{ImuSample, Strapdown};
use core_nav::table::q_s_b;
use hal_sim::imu::ImuSpec;
use hal_sim::recording::Recording;
use hal_sim::track::EncoderTrack;
use nalgebra::{Quaternion, Vector3};

use crate::nav::TrajRow;

mod summary;
pub use summary::{chi2_95_bounds, summary, AidedSummary, OutageError};

/// Samples the zero-velocity detector looks back over (0.5 s at 100 Hz).
pub const ZUPT_WINDOW: usize = 50;
/// The base's rotation under which it may be still, rad/s (0.5 deg/s:
/// above a MEMS gyro's 0.5 s noise, below a car's yaw in traffic).
pub const ZUPT_GYRO_RADPS: f64 = 0.0087;
/// The specific force's standard deviation under which it may be still,
/// m/s^2 (a moving car's vibration is several times more).
pub const ZUPT_ACCEL_MPS2: f64 = 0.05;
/// Zero-velocity measurement 1-sigma, m/s.
pub const ZUPT_SIGMA_MPS: f64 = 0.02;

/// The share of a fix's reported variance the filter takes as correlated
/// over a minute (the rest white): automotive receivers' errors are half
/// multipath and atmosphere. The simulator's receiver is built the same
/// way (`hal_sim::drive::Receiver`), so on simulated runs the NEES tests the
/// filter's algebra and tuning, not this assumption.
pub const GNSS_CORR_SHARE: f64 = 0.5;

/// How to aid.
#[derive(Clone, Debug)]
pub struct AidedOptions {
    /// The sensor profile the filter's noise model comes from.
    pub profile: ImuSpec,
    /// Use zero-velocity updates.
    pub zupt: bool,
    /// Innovation gate, sigmas.
    pub gate_sigma: f64,
    /// Mechanization and filter in f32, as on the board (else f64).
    pub f32: bool,
}

/// One output row: trajectory-v1 and the filter's 1-sigma.
#[derive(Clone, Copy, Debug, Default)]
pub struct AidedRow {
    /// The trajectory-v1 columns.
    pub traj: TrajRow,
    /// Position 1-sigma, north, east, down, m.
    pub sigma_p_m: [f64; 3],
    /// Velocity 1-sigma, m/s.
    pub sigma_v_mps: [f64; 3],
    /// Attitude 1-sigma (rotation about north, east, down), deg.
    pub sigma_att_deg: [f64; 3],
    /// A GNSS fix was used at this sample.
    pub fix: bool,
    /// The detector said still.
    pub still: bool,
}

/// A navigation run.
#[derive(Clone, Debug, Default)]
pub struct AidedRun {
    /// One row per IMU sample.
    pub rows: Vec<AidedRow>,
    /// Per GNSS fix used: (time s, NIS, components used).
    pub nis: Vec<(f64, f64, u8)>,
    /// Components the gate rejected, updates refused, fixes not used.
    pub rejected: u32,
    /// See `rejected`.
    pub refused: u32,
    /// Zero-velocity updates made.
    pub zupts: u32,
    /// Steps the mechanization refused (non-finite samples, gaps).
    pub faults: u32,
    /// Normalised estimation error squared against `truth.csv` (simulated
    /// runs), once a second: (time s, NEES, degrees of freedom: north,
    /// east, and the three velocities).
    pub nees: Vec<(f64, f64, usize)>,
}

/// The filter's noise model from a sensor profile: white noise as the
/// datasheet's, the bias as one Gauss-Markov process holding the turn-on
/// bias and the instability (1 h correlation).
pub fn filter_config(p: &ImuSpec, gate_sigma: f64) -> EskfConfig {
    let g = &p.gyro;
    let a = &p.accel;
    EskfConfig {
        gyro_arw: g.white.max(1e-6),
        accel_vrw: a.white.max(1e-5),
        gyro_bias_sigma: (g.bias * g.bias + g.bias_instability * g.bias_instability).sqrt(),
        gyro_bias_tau_s: 3600.0,
        accel_bias_sigma: (a.bias * a.bias + a.bias_instability * a.bias_instability).sqrt(),
        accel_bias_tau_s: 3600.0,
        gate_sigma,
        gyro_scale_sigma: g.scale.max(1e-5),
        gyro_misalignment_sigma: g.misalignment.max(1e-5),
        gnss_corr_sigma_m: [GNSS_CORR_SHARE.sqrt() * 1.5, GNSS_CORR_SHARE.sqrt() * 3.0],
        gnss_corr_tau_s: 60.0,
    }
}

/// Navigates `rec` with its GNSS fixes.
///
/// # Errors
/// Not a moving-base recording, no `gnss.csv`, no encoder reads, a start
/// the mechanization refuses.
pub fn navigate(
    rec: &Recording,
    opt: &AidedOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<AidedRun> {
    if opt.f32 {
        navigate_t::<f32>(rec, opt, progress)
    } else {
        navigate_t::<f64>(rec, opt, progress)
    }
}

/// [`navigate`] with the mechanization and the filter in `T` (f32 as on
/// the board); the bookkeeping (fixes, truth, output) in f64.
fn navigate_t<T: Real>(
    rec: &Recording,
    opt: &AidedOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<AidedRun> {
    let m = &rec.meta;
    let Some(mv) = &rec.moving else {
        bail!("not a moving-base recording ([base] moving = true in meta.toml): --gnss needs one")
    };
    let Some(fixes) = &mv.gnss else {
        bail!("gnss.csv is missing: --gnss needs the receiver's fixes")
    };
    let lever_b = Vector3::from(mv.gnss_meta.map_or([0.0; 3], |g| g.antenna_b_m));
    if rec.table.len() < 3 || rec.imu.len() < 2 {
        bail!("the recording has too few IMU samples or encoder reads");
    }
    let track = EncoderTrack::of(rec);
    let k_axis = m.axis.unit::<f64>();
    let origin = GeoPoint::from_deg(m.latitude_deg, mv.longitude_deg, m.height_m);
    let c_s_b = |t: f64| quat_to_dcm(&q_s_b(m.axis, track.angle(t)));
    let to_us = crate::nav::clock_us(m);
    let sample = |k: usize, kf: Option<&Eskf<T>>| {
        let r = &rec.imu[k];
        let (w, f) = (
            Vector3::from(r.gyro_radps).map(T::lit),
            Vector3::from(r.accel_mps2).map(T::lit),
        );
        ImuSample::<T> {
            t_us: to_us(r.t_s),
            w_is_s: kf.map_or(w, |kf| kf.correct_gyro(&w)),
            f_s: kf.map_or(f, |kf| kf.correct_accel(&f)),
        }
    };
    let c_b_n0 = core_nav::site::c_b_n(&m.base());
    let t0 = rec.imu[0].t_s;
    let q0 = dcm_to_quat(&(c_b_n0 * c_s_b(t0)));
    let cfg = crate::nav::strapdown_config(m, false);
    let q0 = Quaternion::from(q0.coords.map(T::lit));
    let mut nav = Strapdown::<T>::new(cfg, origin, Vector3::zeros(), q0, &sample(0, None))
        .map_err(|e| anyhow::anyhow!("cannot start navigation: {e}"))?;
    let earth = *nav.earth();
    let (rm_h0, rn_h0_cos) = (earth.rm_h0.to_f64(), earth.rn_h0_cos.to_f64());
    let f64v = |v: &Vector3<T>| v.map(|x| x.to_f64());
    let tv = |v: &Vector3<f64>| v.map(T::lit);
    let mut kf = Eskf::<T>::new(
        filter_config(&opt.profile, opt.gate_sigma),
        &InitialSigma {
            position_m: 1.0,
            velocity_mps: 0.05,
            level_rad: 0.5f64.to_radians(),
            heading_rad: 2f64.to_radians(),
        },
    );
    let mut run = AidedRun::default();
    let truth = mv.truth.as_deref().unwrap_or(&[]);
    let mut next_truth = 0usize;
    let mut next_fix = 0usize;
    let mut window: std::collections::VecDeque<(f64, Vector3<f64>)> =
        std::collections::VecDeque::with_capacity(ZUPT_WINDOW + 1);
    let n = rec.imu.len();
    for k in 0..n {
        let t = rec.imu[k].t_s;
        let s = sample(k, Some(&kf));
        if k > 0 {
            let prev_t = rec.imu[k - 1].t_s;
            if nav.step(&s).is_err() {
                run.faults += 1;
                continue;
            }
            let st = *nav.state();
            let e = nav.earth_here();
            let c_s_n = quat_to_dcm(&st.q_s_n);
            let w_ie = earth_rate_n(e.sin_lat, e.cos_lat);
            let w_en = transport_rate_n(&st.v_n, e.r_m, e.r_n, e.height_m, e.sin_lat / e.cos_lat);
            kf.predict(
                &c_s_n,
                &(c_s_n * s.f_s),
                &w_ie,
                &w_en,
                &s.w_is_s,
                T::lit(t - prev_t),
            );
        }
        let st = *nav.state();
        let (p_n, v_n) = (f64v(&st.p_n), f64v(&st.v_n));
        let c_s_n = quat_to_dcm(&st.q_s_n).map(|x| x.to_f64());
        let csb = c_s_b(t);
        let c_b_n = c_s_n * csb.transpose();
        // The base's rotation and the specific force, table removed.
        let rate = track.at(t).rate;
        let w_ib_b = csb * (f64v(&s.w_is_s) - k_axis * rate);
        let f_b = csb * f64v(&s.f_s);
        if window.len() == ZUPT_WINDOW {
            window.pop_front();
        }
        window.push_back((w_ib_b.norm(), f_b));
        let still = opt.zupt && window.len() == ZUPT_WINDOW && is_still(&window);
        let mut row_fix = false;
        // GNSS: the fix nearest this sample.
        while let Some(f) = fixes.get(next_fix) {
            if f.t_s > t + 0.5 / m.imu_rate_hz {
                break;
            }
            next_fix += 1;
            if f.t_s < t - 0.5 / m.imu_rate_hz {
                run.refused += 1; // before the run or skipped by a fault
                continue;
            }
            let p_fix = Vector3::new(
                (f.lat_deg.to_radians() - origin.lat_rad) * rm_h0,
                (f.lon_deg.to_radians() - origin.lon_rad) * rn_h0_cos,
                origin.height_m - f.height_m,
            );
            let l_n = c_b_n * lever_b;
            let zp = p_fix - (p_n + l_n);
            let v_ant = v_n + c_b_n * w_ib_b.cross(&lever_b);
            let zv = Vector3::from(f.v_n_mps) - v_ant;
            let sp = Vector3::new(f.sigma_h_m, f.sigma_h_m, f.sigma_v_m)
                * (1.0 - GNSS_CORR_SHARE).sqrt();
            let sv = Vector3::repeat(f.sigma_vel_mps);
            let (mut nis, mut used) = (0.0, 0u8);
            match kf.update_position(&tv(&zp), &tv(&l_n), &tv(&sp)) {
                Ok(r) => {
                    nis += r.nis.to_f64();
                    used += r.used;
                }
                Err(_) => run.refused += 1,
            }
            match kf.update_velocity(&tv(&zv), &tv(&sv)) {
                Ok(r) => {
                    nis += r.nis.to_f64();
                    used += r.used;
                }
                Err(_) => run.refused += 1,
            }
            run.nis.push((f.t_s, nis, used));
            row_fix = true;
        }
        if still
            && k % 10 == 0
            && kf
                .update_velocity(&(-st.v_n), &Vector3::repeat(T::lit(ZUPT_SIGMA_MPS)))
                .is_ok()
        {
            run.zupts += 1;
        }
        if row_fix || (still && k % 10 == 0) {
            let (dp, dv, phi) = kf.take_correction();
            if nav.correct(&dp, &dv, &phi).is_err() {
                run.faults += 1;
            }
        }
        let st = *nav.state();
        let c_b_n = quat_to_dcm(&st.q_s_n).map(|x| x.to_f64()) * c_s_b(t).transpose();
        let e = quat_to_euler(&dcm_to_quat(&c_b_n));
        let ned = origin.ned_to(&earth.point_at(&st.p_n));
        let v_n = f64v(&st.v_n);
        let sig = |i: usize| {
            [
                kf.sigma(i).to_f64(),
                kf.sigma(i + 1).to_f64(),
                kf.sigma(i + 2).to_f64(),
            ]
        };
        run.rows.push(AidedRow {
            traj: TrajRow {
                t_s: t,
                ned_m: [ned.x, ned.y, ned.z],
                v_mps: [v_n.x, v_n.y, v_n.z],
                rph_deg: [
                    e.roll.to_degrees(),
                    e.pitch.to_degrees(),
                    e.heading.to_degrees().rem_euclid(360.0),
                ],
                faults: run.faults,
            },
            sigma_p_m: sig(I_P),
            sigma_v_mps: sig(I_V),
            sigma_att_deg: sig(I_PHI).map(f64::to_degrees),
            fix: row_fix,
            still,
        });
        // NEES once a second against the truth (north, east, velocity):
        // the error in the tangent plane at the start, the filter's
        // covariance of (dp_n, dp_e, dv).
        if k % (m.imu_rate_hz.round().max(1.0) as usize) == 0 {
            while truth.get(next_truth).is_some_and(|r| r.t_s < t - 1e-6) {
                next_truth += 1;
            }
            if let Some(tr) = truth.get(next_truth).filter(|r| (r.t_s - t).abs() < 1e-6) {
                let e = nalgebra::SVector::<f64, 5>::from_column_slice(&[
                    tr.p_n_m[0] - ned.x,
                    tr.p_n_m[1] - ned.y,
                    tr.v_n_mps[0] - v_n.x,
                    tr.v_n_mps[1] - v_n.y,
                    tr.v_n_mps[2] - v_n.z,
                ]);
                let idx = [I_P, I_P + 1, I_V, I_V + 1, I_V + 2];
                let p5 =
                    nalgebra::SMatrix::<f64, 5, 5>::from_fn(|r, c| kf.p[(idx[r], idx[c])].to_f64());
                if let Some(ch) = p5.cholesky() {
                    let x = ch.solve(&e);
                    run.nees.push((t, e.dot(&x), 5));
                }
            }
        }
        if k % 20_000 == 0 {
            progress(k as f64 / n as f64);
        }
    }
    run.rejected = kf.rejected;
    run.refused += kf.refused;
    progress(1.0);
    Ok(run)
}

fn is_still(w: &std::collections::VecDeque<(f64, Vector3<f64>)>) -> bool {
    let n = w.len().max(1) as f64;
    if w.iter().any(|(g, _)| *g > ZUPT_GYRO_RADPS) {
        return false;
    }
    let mean: Vector3<f64> = w.iter().map(|(_, f)| *f).sum::<Vector3<f64>>() / n;
    let var = w
        .iter()
        .map(|(_, f)| (f - mean).norm_squared())
        .sum::<f64>()
        / n;
    var.sqrt() < ZUPT_ACCEL_MPS2
}

/// trajectory.csv with the filter's sigmas as extra columns
/// (trajectory-v1 allows extra columns named with their units).
pub fn trajectory_csv(rows: &[AidedRow]) -> String {
    let mut s = String::with_capacity(rows.len() * 200);
    s.push_str("t_s,north_m,east_m,down_m,vn_mps,ve_mps,vd_mps,roll_deg,pitch_deg,heading_deg,sigma_north_m,sigma_east_m,sigma_down_m,sigma_vn_mps,sigma_ve_mps,sigma_vd_mps,sigma_roll_deg,sigma_pitch_deg,sigma_heading_deg,gnss_fix,zupt\n");
    for r in rows {
        let t = &r.traj;
        let [n, e, d] = t.ned_m;
        let [vn, ve, vd] = t.v_mps;
        let [ro, pi, he] = t.rph_deg;
        let [sn, se, sd] = r.sigma_p_m;
        let [svn, sve, svd] = r.sigma_v_mps;
        let [sr, sp, sh] = r.sigma_att_deg;
        s.push_str(&format!(
            "{:.3},{n:.4},{e:.4},{d:.4},{vn:.5},{ve:.5},{vd:.5},{ro:.6},{pi:.6},{he:.6},{sn:.4},{se:.4},{sd:.4},{svn:.5},{sve:.5},{svd:.5},{sr:.6},{sp:.6},{sh:.6},{},{}\n",
            t.t_s,
            u8::from(r.fix),
            u8::from(r.still)
        ));
    }
    s
}

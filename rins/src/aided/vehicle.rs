//! `navigate --gnss --vehicle car`: the land vehicle's constraints and its
//! odometer ([`core_nav::vehicle`]) made between the navigator's steps,
//! with the car's mounting and the odometer's scale as filter states.
//!
//! **The mounting, from a moving start.** The first time the car drives
//! straight (under 1 deg/s) above 5 m/s with fixes, its forward axis in
//! `b` is read off the filter's own velocity in `b`, and two host states
//! ([`crate::aided::HOST_M`]) carry its error: the axis's yaw `a` (about
//! the second cross axis) and pitch `c` (about the first). Read off the
//! filter's velocity, the axis's error is the filter's heading and level
//! error seen through that velocity: the states start as exactly that
//! linear function of the filter's states (`Eskf::set_aux_as`), not as
//! an uncorrelated guess. So the constraints tie the axis and the heading
//! together (their sum is what the fixes' track knows) and neither is
//! told more than the data says. (A fixed axis with a 10 deg sigma either
//! had to stay off, or told the filter a heading it did not know.)
//!
//! **The constraints**: every [`NHC_EVERY_S`] while the car moves and does
//! not turn hard, its two cross velocities are measured as zero, through
//! outages too. With the true axis `x + a e1 + c e2` (`e1`, `e2` across
//! `x`, [`across`]) a cross velocity `e1 . v_b` reads `-a` times the
//! forward speed more than the estimated axis's: that is the states' row.
//!
//! **The odometer** (`odometer.csv`): the forward speed times `1 + k`, `k`
//! the tyres' scale error (a third host state, prior
//! [`ODOMETER_SCALE_SIGMA`]), every [`NHC_EVERY_S`] from the same start:
//! a scale error is one constant that updates repeated as if white would
//! average away, so it is estimated, not left in the noise.
//!
//! **The IMU ahead of the rear axle**: the point that does not slide
//! sideways is the rear axle's centre; an IMU `L` ahead of it along the
//! axis moves at `v_b = v_axle + L (w_b x x)` (`w_b` the base's rate), so
//! a cross velocity reads `L e . (w_b x x)` in a turn. `L` is one constant
//! through a turn's many updates, not white: a fourth host state (prior
//! [`NHC_LEVER_M`] +- [`NHC_LEVER_PRIOR_SIGMA_M`]), seen in the turns
//! while fixes arrive.
//!
//! **The rear axle's slip**: in a turn the tyres hold the car only at a
//! slip angle, so the rear axle itself slides out of the turn, by its
//! cornering compliance `k` times the lateral acceleration `s r` (`s` the
//! speed, `r` the rate about the vertical): `-k s^2 r` along the level
//! axis across `x`. It too is one constant through a turn, and at one
//! speed it reads as the IMU's distance (`r (L - k s^2)`): a fifth host
//! state (prior [`NHC_SLIP_RAD_PER_MPS2`] +-
//! [`NHC_SLIP_PRIOR_SIGMA_RAD_PER_MPS2`]), told apart from `L` by turns
//! taken at different speeds, and correlated with it where they are not.
//! Left in the noise, it took half a metre from a simulated IMU's 1.5 m
//! at a city's turning speeds, its sigma a tenth of that.

use crate::aided::HostNav;
use core_nav::attitude::quat_to_dcm;
use core_nav::eskf::AUX_MAX;
use core_nav::real::Real;
use core_nav::table::TableAngle;
use core_nav::units::G0_MPS2;
use core_nav::vehicle::{
    across, nhc_sigma_mps, velocity_b_row, BaseVelocity, FORWARD_MAX_RATE_RADPS,
    FORWARD_MIN_SPEED_MPS, NHC_EVERY_S, NHC_LEVER_M, NHC_LEVER_PRIOR_SIGMA_M, NHC_SIGMA_MPS,
    NHC_SLIP_PRIOR_SIGMA_RAD_PER_MPS2, NHC_SLIP_RAD_PER_MPS2, NHC_SLIP_UNMODELLED_RAD_PER_MPS2,
};
use nalgebra::Vector3;
use recording::moving::OdometerRow;
use serde::Serialize;

/// Host state of the forward axis's yaw error, rad.
pub const AUX_YAW: usize = 0;
/// Host state of its pitch error, rad.
pub const AUX_PITCH: usize = 1;
/// Host state of the odometer's scale error (1).
pub const AUX_SCALE: usize = 2;
/// Host state of the error of the IMU's distance ahead of the rear axle, m.
pub const AUX_AHEAD: usize = 3;
/// Host state of the error of the rear axle's slip per lateral
/// acceleration, rad per m/s^2 (module docs).
pub const AUX_SLIP: usize = 4;
/// The odometer's scale error's prior 1-sigma: a car's speed as its CAN
/// bus reports it, from wheel speeds on tyres whose radius varies a few
/// per cent with wear, pressure and load (speedometers read 0-10 % high by
/// regulation; the wheel-speed signal itself within a few per cent).
pub const ODOMETER_SCALE_SIGMA: f64 = 0.05;
/// An odometer sample's 1-sigma when the file gives none, m/s: the CAN
/// speed's resolution (0.01 km/h) is far below what decides it, the
/// sample's age against the step it is used at (up to half a 50 Hz period
/// at 2 m/s^2: 0.02 m/s) and the IMU's lever arm to the rear axle in a
/// turn (1.5 m at 3 deg/s: 0.08 m/s), in quadrature.
pub const ODOMETER_SIGMA_MPS: f64 = 0.1;
/// An odometer sample is used only within this of the step, s.
pub const ODOMETER_MAX_AGE_S: f64 = 0.1;

/// What a vehicle is, as navigation uses it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Vehicle {
    /// A car: no sliding sideways, no leaving the road.
    Car,
}

impl Vehicle {
    /// `car`.
    pub fn parse(s: &str) -> Option<Self> {
        (s == "car").then_some(Self::Car)
    }
}

/// What the constraints and the odometer did over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct VehicleReport {
    /// The forward axis at the run's end (`None`: the car never drove
    /// straight above 5 m/s with fixes, so no constraint was made).
    pub forward: Option<ForwardReport>,
    /// When the axis was first read off the filter, s.
    pub found_at_s: Option<f64>,
    /// Constraint updates made (two components each).
    pub updates: u32,
    /// Components the gate refused.
    pub rejected: u32,
    /// Updates due but not made: standing, creeping or turning hard.
    pub off: u32,
    /// The odometer, when the recording has one.
    pub odometer: Option<OdometerReport>,
}

/// The forward axis in `b`, in degrees, with the filter's 1-sigma.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ForwardReport {
    /// Yaw of the vehicle's forward axis in `b`, deg (0: along `b`'s x).
    pub yaw_deg: f64,
    /// Its pitch, deg (up from `b`'s x-y plane).
    pub pitch_deg: f64,
    /// 1-sigma of the yaw, deg.
    pub sigma_yaw_deg: f64,
    /// 1-sigma of the pitch, deg.
    pub sigma_pitch_deg: f64,
    /// The IMU's distance ahead of the rear axle's centre along the axis,
    /// m (module docs).
    pub imu_ahead_m: f64,
    /// Its 1-sigma, m.
    pub sigma_imu_ahead_m: f64,
    /// The rear axle's slip angle per lateral acceleration, deg per g
    /// (module docs).
    pub rear_slip_deg_per_g: f64,
    /// Its 1-sigma, deg per g.
    pub sigma_rear_slip_deg_per_g: f64,
}

/// The odometer's use over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct OdometerReport {
    /// Its samples in the recording.
    pub samples: usize,
    /// Updates made with it.
    pub updates: u32,
    /// Updates the gate refused.
    pub rejected: u32,
    /// Its scale error at the run's end (reads `1 + scale` times the
    /// speed), and its 1-sigma.
    pub scale: f64,
    /// 1-sigma of `scale`.
    pub sigma_scale: f64,
}

/// The constraints' and the odometer's state through a run.
#[derive(Clone, Debug, Default)]
pub struct VehicleAid {
    /// The forward axis in `b` (unit) once read off the filter.
    x_b: Option<Vector3<f64>>,
    /// The odometer's scale error estimate.
    scale: f64,
    /// The IMU's distance ahead of the rear axle, m (module docs).
    ahead_m: f64,
    /// The rear axle's slip per lateral acceleration, rad per m/s^2.
    slip: f64,
    odometer: Vec<OdometerRow>,
    next_odo: usize,
    next_s: f64,
    /// What was done.
    pub report: VehicleReport,
}

impl VehicleAid {
    /// Constraints, with the recording's odometer samples (time-ordered;
    /// empty: none).
    pub fn new(odometer: Vec<OdometerRow>) -> Self {
        let report = VehicleReport {
            odometer: (!odometer.is_empty()).then(|| OdometerReport {
                samples: odometer.len(),
                ..Default::default()
            }),
            ..Default::default()
        };
        Self {
            odometer,
            report,
            ahead_m: NHC_LEVER_M,
            slip: NHC_SLIP_RAD_PER_MPS2,
            ..Default::default()
        }
    }

    /// After the navigator's step at `t_s` (the table at `table`):
    /// `aided` when a fix was used within the last two seconds (the axis
    /// is read off only then).
    pub fn after_step<T: Real>(
        &mut self,
        an: &mut HostNav<T>,
        t_s: f64,
        table: &TableAngle<T>,
        aided: bool,
    ) {
        self.take_aux(an);
        let sol = an.solution(table);
        let c_b_n = quat_to_dcm(&sol.q_b_n).map(|x| x.to_f64());
        let v_n = sol.v_n.map(|x| x.to_f64());
        let v_b = c_b_n.transpose() * v_n;
        // The rate against the inertial frame: the earth's part (7e-5
        // rad/s) moves the lever's velocity by 1e-4 m/s, far inside the
        // road's.
        let w_b = an.w_ib_b().map(|x| x.to_f64());
        let rate = w_b.norm();
        if self.x_b.is_none() && aided {
            self.start(an, t_s, &v_b, rate, &c_b_n, &v_n, &sol.sigma_v_mps);
        }
        let Some(x_b) = self.x_b else { return };
        if t_s < self.next_s {
            return;
        }
        self.next_s = t_s + NHC_EVERY_S;
        let down_b = c_b_n.transpose() * Vector3::z();
        let mut m = self.constraints(&x_b, &v_b, &w_b, &down_b);
        let odo = self.odometer_at(t_s, &x_b, &v_b);
        m.extend(odo);
        if m.is_empty() {
            self.report.off += 1;
            return;
        }
        let m: Vec<BaseVelocity<T>> = m.iter().map(lit).collect();
        if let Ok(r) = an.update_base_velocity(table, &m) {
            self.count(&r, odo.is_some(), m.len());
        }
        self.take_aux(an);
        self.report_state(an);
    }

    /// Reads the axis off the filter's velocity in `b` on a straight
    /// stretch with fixes, and starts the host states.
    #[allow(clippy::too_many_arguments)]
    fn start<T: Real>(
        &mut self,
        an: &mut HostNav<T>,
        t_s: f64,
        v_b: &Vector3<f64>,
        rate: f64,
        c_b_n: &nalgebra::Matrix3<f64>,
        v_n: &Vector3<f64>,
        sigma_v: &[T; 3],
    ) {
        let speed = v_b.norm();
        let sv = sigma_v.iter().map(|x| x.to_f64()).fold(0.0, f64::max);
        if speed < FORWARD_MIN_SPEED_MPS || rate > FORWARD_MAX_RATE_RADPS || sv > 0.05 * speed {
            return;
        }
        let x_b = v_b / speed;
        let [e1, e2] = across(&x_b);
        // 0 = e . (v_b + dv_b) - a s (module docs): a = (row . dx + w) / s,
        // w the cross velocity's own (the road's) error.
        let c = c_b_n.map(T::lit);
        let vn = v_n.map(T::lit);
        let mut ok = true;
        for (k, e) in [(AUX_YAW, e1), (AUX_PITCH, e2)] {
            let (row, _) =
                velocity_b_row::<T, { crate::aided::HOST_M }>(&e.map(T::lit), T::zero(), &c, &vn);
            let row = row / T::lit(speed);
            ok &= an
                .kf
                .set_aux_as(k, &row, NHC_SIGMA_MPS / speed, 0.0)
                .is_ok();
        }
        ok &= an.kf.set_aux(AUX_SCALE, ODOMETER_SCALE_SIGMA, 0.0).is_ok();
        ok &= an
            .kf
            .set_aux(AUX_AHEAD, NHC_LEVER_PRIOR_SIGMA_M, 0.0)
            .is_ok();
        ok &= an
            .kf
            .set_aux(AUX_SLIP, NHC_SLIP_PRIOR_SIGMA_RAD_PER_MPS2, 0.0)
            .is_ok();
        if ok {
            self.x_b = Some(x_b);
            self.report.found_at_s = Some(t_s);
            self.next_s = t_s;
        }
    }

    /// The two cross velocities of the rear axle as its slip's, where they
    /// hold: the IMU's read the lever's `L e . (w_b x x)` and the slip's
    /// `-k s^2 r e . y` (module docs), `w_b` the base's rate, rad/s,
    /// `down_b` the local down in `b` (unit), `y` the level axis across
    /// `x` (right of it).
    fn constraints(
        &self,
        x_b: &Vector3<f64>,
        v_b: &Vector3<f64>,
        w_b: &Vector3<f64>,
        down_b: &Vector3<f64>,
    ) -> Vec<BaseVelocity<f64>> {
        let speed = x_b.dot(v_b);
        let [e1, e2] = across(x_b);
        let slip_sigma = NHC_SLIP_UNMODELLED_RAD_PER_MPS2;
        let Some(sigma) = nhc_sigma_mps(speed, w_b.norm(), 0.0, slip_sigma) else {
            return vec![];
        };
        let swing = w_b.cross(x_b);
        // The axle's slide per unit compliance, m/s per rad/(m/s^2).
        let y = down_b.cross(x_b);
        let slide = y.try_normalize(0.5).unwrap_or_default() * (speed * speed * w_b.dot(down_b));
        [(AUX_YAW, e1), (AUX_PITCH, e2)]
            .into_iter()
            .map(|(k, e)| {
                let (g, h) = (e.dot(&swing), e.dot(&slide));
                let mut aux = [0.0; AUX_MAX];
                for (i, v) in [(k, -speed), (AUX_AHEAD, -g), (AUX_SLIP, h)] {
                    if let Some(a) = aux.get_mut(i) {
                        *a = v;
                    }
                }
                BaseVelocity {
                    aux,
                    ..BaseVelocity::plain(e, self.ahead_m * g - self.slip * h, sigma)
                }
            })
            .collect()
    }

    /// The odometer's sample nearest `t_s` (within
    /// [`ODOMETER_MAX_AGE_S`]) as a measurement of the forward speed.
    fn odometer_at(
        &mut self,
        t_s: f64,
        x_b: &Vector3<f64>,
        v_b: &Vector3<f64>,
    ) -> Option<BaseVelocity<f64>> {
        let rows = &self.odometer;
        while rows.get(self.next_odo + 1).is_some_and(|r| r.t_s <= t_s) {
            self.next_odo += 1;
        }
        let near = [self.next_odo, self.next_odo + 1]
            .iter()
            .filter_map(|i| rows.get(*i))
            .min_by(|a, b| (a.t_s - t_s).abs().total_cmp(&(b.t_s - t_s).abs()))?;
        if (near.t_s - t_s).abs() > ODOMETER_MAX_AGE_S || !near.speed_mps.is_finite() {
            return None;
        }
        let gain = 1.0 + self.scale;
        let [e1, e2] = across(x_b);
        let mut aux = [0.0; AUX_MAX];
        for (k, v) in [
            (AUX_YAW, gain * e1.dot(v_b)),
            (AUX_PITCH, gain * e2.dot(v_b)),
            (AUX_SCALE, x_b.dot(v_b)),
        ] {
            if let Some(a) = aux.get_mut(k) {
                *a = v;
            }
        }
        let sigma = near
            .sigma_mps
            .filter(|s| *s > 0.0)
            .unwrap_or(ODOMETER_SIGMA_MPS);
        Some(BaseVelocity {
            gain,
            aux,
            ..BaseVelocity::plain(*x_b, near.speed_mps, sigma)
        })
    }

    /// The filter's corrections of the host states, into the axis and the
    /// scale.
    fn take_aux<T: Real>(&mut self, an: &mut HostNav<T>) {
        let d = an.kf.take_aux().map(|x| x.to_f64());
        let Some(x_b) = self.x_b else { return };
        let [e1, e2] = across(&x_b);
        let [a, c, k, l, q] = [AUX_YAW, AUX_PITCH, AUX_SCALE, AUX_AHEAD, AUX_SLIP].map(|i| d[i]);
        let x = x_b + e1 * a + e2 * c;
        if x.iter().all(|v| v.is_finite())
            && x.norm() > 0.5
            && [k, l, q].iter().all(|v| v.is_finite())
        {
            self.x_b = Some(x.normalize());
            self.scale += k;
            self.ahead_m += l;
            self.slip += q;
        }
    }

    fn count<T: Real>(&mut self, r: &core_nav::eskf::UpdateReport<T>, odo: bool, n: usize) {
        let nhc = n - usize::from(odo);
        if nhc > 0 {
            self.report.updates += 1;
        }
        self.report.rejected += u32::from(r.rejected);
        if let (true, Some(o)) = (odo, self.report.odometer.as_mut()) {
            o.updates += 1;
            // The odometer is the last measurement: its bit in the mask.
            if r.rejected_mask & (1 << nhc) != 0 {
                o.rejected += 1;
            }
        }
    }

    fn report_state<T: Real>(&mut self, an: &HostNav<T>) {
        let Some(x) = self.x_b else { return };
        let sig = |k: usize| an.kf.sigma(core_nav::eskf::N + k).to_f64();
        self.report.forward = Some(ForwardReport {
            yaw_deg: x.y.atan2(x.x).to_degrees(),
            pitch_deg: (-x.z).clamp(-1.0, 1.0).asin().to_degrees(),
            sigma_yaw_deg: sig(AUX_YAW).to_degrees(),
            sigma_pitch_deg: sig(AUX_PITCH).to_degrees(),
            imu_ahead_m: self.ahead_m,
            sigma_imu_ahead_m: sig(AUX_AHEAD),
            rear_slip_deg_per_g: (self.slip * G0_MPS2).to_degrees(),
            sigma_rear_slip_deg_per_g: (sig(AUX_SLIP) * G0_MPS2).to_degrees(),
        });
        if let Some(o) = self.report.odometer.as_mut() {
            o.scale = self.scale;
            o.sigma_scale = sig(AUX_SCALE);
        }
    }
}

fn lit<T: Real>(m: &BaseVelocity<f64>) -> BaseVelocity<T> {
    BaseVelocity {
        e_b: m.e_b.map(T::lit),
        value_mps: T::lit(m.value_mps),
        sigma_mps: T::lit(m.sigma_mps),
        gain: T::lit(m.gain),
        aux: m.aux.map(T::lit),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aided::HOST_M;
    use core_nav::eskf::N;
    use nalgebra::Matrix3;

    /// The rear axle moves exactly along the true axis `x + a e1 + c e2`
    /// (no filter error: `b` is `n`) while the car turns, the IMU 0.6 m
    /// further ahead of it than the aid's prior, the odometer reads `1 + k`
    /// times the axle's speed: each measurement's innovation is its row
    /// times the host states' true errors, to second order.
    #[test]
    fn the_rows_carry_the_axis_s_the_scale_s_the_lever_s_and_the_slip_s_errors_with_their_signs() {
        let x = Vector3::new(0.9, -0.3, 0.1).normalize();
        let [e1, e2] = across(&x);
        let (a, c, k, s, dl, dq) = (2e-3, -1e-3, 0.01, 15.0, 0.6, -2e-3);
        let w_b = Vector3::new(0.01, -0.02, 0.15);
        let x_true = (x + e1 * a + e2 * c).normalize();
        // `b` is `n`: down is `b`'s z; the axle slides left in this right
        // turn by the true compliance times s^2 r.
        let down = Vector3::z();
        let y = down.cross(&x_true).normalize();
        let slide = -(NHC_SLIP_RAD_PER_MPS2 + dq) * s * s * w_b.z * y;
        let v_b = x_true * s + w_b.cross(&x_true) * (NHC_LEVER_M + dl) + slide;
        let mut aid = VehicleAid::new(vec![OdometerRow {
            t_s: 1.0,
            speed_mps: (1.0 + k) * s,
            sigma_mps: None,
        }]);
        let mut m = aid.constraints(&x, &v_b, &w_b, &down);
        m.extend(aid.odometer_at(1.0, &x, &v_b));
        assert_eq!(m.len(), 3);
        let mut dx = nalgebra::SVector::<f64, HOST_M>::zeros();
        for (i, e) in [
            (AUX_YAW, a),
            (AUX_PITCH, c),
            (AUX_SCALE, k),
            (AUX_AHEAD, dl),
            (AUX_SLIP, dq),
        ] {
            dx[N + i] = e;
        }
        for bv in &m {
            let (h, z) = bv.row::<HOST_M>(&Matrix3::identity(), &v_b);
            // Second order: s a^2 ~ 6e-5 m/s, k a s ~ 3e-4, and the lever
            // swung about the estimated axis, not the true: L |w| a ~ 6e-4.
            assert!(
                (z - h.dot(&dx)).abs() < 1.5e-3,
                "{bv:?}: {z} vs {}",
                h.dot(&dx)
            );
            assert!(z.abs() > 1e-2, "{z}: the error is seen");
        }
    }
}

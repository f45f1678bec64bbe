//! `navigate --gnss --vehicle car`: the land vehicle's constraints
//! ([`core_nav::vehicle`]) made between the navigator's steps. The forward
//! axis is found from the first straight driving with fixes
//! ([`ForwardFinder`]); from then on, every [`NHC_EVERY_S`] while the car
//! moves and does not turn hard, its two cross velocities are measured as
//! zero (through outages too: that is what they are for). A recording's
//! `odometer.csv` is not used: its tyres' scale error (about 1 %, 0.15
//! m/s at 15 m/s) is one constant that updates repeated as if white
//! would average away, and the filter has no state for it yet (on the
//! comma2k19 minute, the speeds so used turned 15 s outages ending at 6.5
//! and 0.9 m into 12.3 m each).

use core_nav::aided::AidedNav;
use core_nav::attitude::quat_to_dcm;
use core_nav::real::Real;
use core_nav::table::TableAngle;
use core_nav::vehicle::{across, nhc_sigma_mps, Forward, ForwardFinder, NHC_EVERY_S};
use nalgebra::Vector3;
use serde::Serialize;

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

/// What the constraints did over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct VehicleReport {
    /// The forward axis found (`None`: never 20 s of straight driving
    /// with fixes, so no constraint was made).
    pub forward: Option<ForwardReport>,
    /// When it was found, s.
    pub found_at_s: Option<f64>,
    /// Constraint updates made (two components each).
    pub updates: u32,
    /// Components the gate refused.
    pub rejected: u32,
    /// Updates due but not made: standing, creeping or turning hard.
    pub off: u32,
    /// The recording has an `odometer.csv`, not used (module docs).
    pub odometer_unused: bool,
}

/// The forward axis in `b`, in degrees.
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
    /// Seconds of straight driving it was found from.
    pub samples: u32,
}

impl From<Forward> for ForwardReport {
    fn from(f: Forward) -> Self {
        Self {
            yaw_deg: f.yaw_rad.to_degrees(),
            pitch_deg: f.pitch_rad.to_degrees(),
            sigma_yaw_deg: f.sigma_yaw_rad.to_degrees(),
            sigma_pitch_deg: f.sigma_pitch_rad.to_degrees(),
            samples: f.samples,
        }
    }
}

/// The constraints' state through a run.
#[derive(Clone, Debug, Default)]
pub struct VehicleAid {
    finder: ForwardFinder,
    forward: Option<Forward>,
    next_s: f64,
    /// What was done.
    pub report: VehicleReport,
}

impl VehicleAid {
    /// After the navigator's step at `t_s` (the table at `table`):
    /// `aided` when a fix was used within the last two seconds (the
    /// finder learns only then).
    pub fn after_step<T: Real>(
        &mut self,
        an: &mut AidedNav<T>,
        t_s: f64,
        table: &TableAngle<T>,
        aided: bool,
    ) {
        let sol = an.solution(table);
        let c_b_n = quat_to_dcm(&sol.q_b_n).map(|x| x.to_f64());
        let v_b = c_b_n.transpose() * sol.v_n.map(|x| x.to_f64());
        let rate = an.w_ib_b().map(|x| x.to_f64()).norm();
        if self.forward.is_none() && aided {
            let sv = sol
                .sigma_v_mps
                .iter()
                .map(|x| x.to_f64())
                .fold(0.0, f64::max);
            let se = [
                sol.sigma_euler_rad[2].to_f64(),
                sol.sigma_euler_rad[1].to_f64(),
            ];
            self.finder.offer(t_s, &v_b, rate, sv, se);
            self.forward = self.finder.forward();
            if let Some(f) = self.forward {
                self.report.forward = Some(f.into());
                self.report.found_at_s = Some(t_s);
                self.next_s = t_s;
            }
        }
        let Some(f) = self.forward else { return };
        if t_s < self.next_s {
            return;
        }
        self.next_s = t_s + NHC_EVERY_S;
        let speed = v_b.norm();
        let x_b = Vector3::from(f.x_b).map(T::lit);
        let [lat, vert] = across(&x_b);
        let mut m = vec![];
        for (e, axis) in [(lat, f.sigma_yaw_rad), (vert, f.sigma_pitch_rad)] {
            if let Some(s) = nhc_sigma_mps(speed, rate, axis) {
                m.push((e, T::zero(), T::lit(s)));
            }
        }
        if m.is_empty() {
            self.report.off += 1;
            return;
        }
        if let Ok(r) = an.update_base_velocity(table, &m) {
            self.report.updates += 1;
            self.report.rejected += u32::from(r.rejected);
        }
    }
}

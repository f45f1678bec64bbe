//! The main job (`rins demo`): the board's run simulated (its ICM-42688-P on
//! a z table at 30.53 N: 60 s still and 60 s turning for the power-up
//! calibration, then 5 min of f32 navigation as on the MCU) beside the same
//! sensor on a still table (the conventional twin, its bias from the first
//! minute), and the errors of both.

use crate::calibrate::{self, Method};
use crate::nav::{self, NavOptions, StaticErrors, TrajRow};
use crate::report;
use anyhow::{anyhow, Context, Result};
use core_nav::calib::{Checks, GyroCalibration, PhaseAccumulator};
use core_nav::scheme::Scheme;
use core_nav::table::{Axis, TableAngle};
use hal_sim::imu::ImuSpec;
use hal_sim::sim::{simulate, SimConfig};
use recording::Recording;
use std::path::Path;

/// Still phase of the power-up calibration, s.
pub const STATIC_S: f64 = 60.0;
/// Whole run: calibration (still + turning) and 5 min of navigation, s.
pub const DURATION_S: f64 = 420.0;
/// Navigation starts here (after the calibration), s.
pub const NAV_START_S: f64 = 120.0;

/// Both runs and what came of them.
pub struct Demo {
    /// The rotary run's recording.
    pub rotary: Recording,
    /// The conventional twin's recording (table still).
    pub conventional: Recording,
    /// The rotary run's power-up calibration.
    pub calibration: calibrate::Calibration,
    /// Trajectories (navigation from `NAV_START_S`).
    pub rows_rotary: Vec<TrajRow>,
    /// See `rows_rotary`.
    pub rows_conventional: Vec<TrajRow>,
    /// Errors against the static truth.
    pub errors_rotary: StaticErrors,
    /// See `errors_rotary`.
    pub errors_conventional: StaticErrors,
}

/// Earth-aware bias from the first `t_s` seconds of a static recording.
pub fn static_bias(rec: &Recording, t_s: f64) -> Result<GyroCalibration> {
    let mut acc = PhaseAccumulator::new(0.0, rec.meta.axis);
    let angle = TableAngle::from_rad_f64(rec.table.first().map_or(0.0, |r| r.angle_rad));
    for r in rec.imu.iter().take_while(|r| r.t_s < t_s) {
        acc.push(
            (r.t_s * 1e6).round() as u64,
            &r.gyro_radps.into(),
            &r.accel_mps2.into(),
            angle,
        )
        .map_err(|e| anyhow!("{e}"))?;
    }
    let checks = Checks {
        gravity_mps2: calibrate::checks_of(rec).gravity_mps2,
        ..Checks::default()
    };
    let p = acc
        .finish(&checks, 1.0 / rec.meta.imu_rate_hz)
        .map_err(|e| anyhow!("{e}"))?;
    Ok(GyroCalibration {
        bias: p.mean_w - calibrate::earth_of(rec).seen(&p),
        axis: rec.meta.axis,
        ..GyroCalibration::default()
    })
}

/// Runs the demo at table rate `rate_dps` (deg/s) with `seed`;
/// `progress` gets the fraction done.
///
/// # Errors
/// A simulation, calibration or navigation failure.
pub fn run(rate_dps: f64, seed: u64, progress: &mut dyn FnMut(f64)) -> Result<Demo> {
    let mut cfg = SimConfig::new(ImuSpec::icm42688(), Axis::Z, DURATION_S);
    cfg.scheme = Scheme::Continuous {
        rate: rate_dps.to_radians(),
    };
    cfg.static_s = STATIC_S;
    cfg.seed = seed;
    let rotary = simulate(&cfg, &mut |f| progress(0.3 * f))?;
    let mut twin = cfg.clone();
    twin.scheme = Scheme::Still;
    let conventional = simulate(&twin, &mut |f| progress(0.3 + 0.3 * f))?;
    progress(0.6);
    let calibration = calibrate::calibrate(
        &rotary,
        (0.0, NAV_START_S),
        Method::Earth,
        Some(rate_dps.to_radians()),
    )?;
    let conv_cal = static_bias(&conventional, STATIC_S)?;
    let run = |rec: &Recording, c: GyroCalibration| -> Result<Vec<TrajRow>> {
        let o = NavOptions {
            start_s: NAV_START_S,
            end_s: Some(DURATION_S),
            calibration: Some(c),
            f32: true,
            hold_height: false,
            base: None,
            gimbals: None,
        };
        nav::navigate(rec, &o, &mut |_| {})
    };
    let rows_rotary = run(&rotary, calibration.gyro)?;
    progress(0.8);
    let rows_conventional = run(&conventional, conv_cal)?;
    progress(1.0);
    let base = [0.0; 3];
    Ok(Demo {
        errors_rotary: nav::static_errors(&rows_rotary, base),
        errors_conventional: nav::static_errors(&rows_conventional, base),
        rotary,
        conventional,
        calibration,
        rows_rotary,
        rows_conventional,
    })
}

impl Demo {
    /// The errors as a table for a person.
    pub fn table(&self) -> String {
        use std::fmt::Write;
        let mut o = String::new();
        let _ = writeln!(o, "5 min of navigation (f32, as on the MCU), errors:");
        let _ = writeln!(
            o,
            "{:<14} {:>12} {:>12} {:>10} {:>10} {:>10}",
            "", "final pos", "RMS pos", "RMS vel", "RMS tilt", "RMS hdg"
        );
        for (name, e) in [
            ("conventional", &self.errors_conventional),
            ("rotary", &self.errors_rotary),
        ] {
            let _ = writeln!(
                o,
                "{name:<14} {:>10.1} m {:>10.1} m {:>6.3} m/s {:>6.4} deg {:>6.4} deg",
                e.h_pos_end_m,
                e.h_pos_rms_m,
                e.h_vel_rms_mps,
                e.roll_rms_deg.hypot(e.pitch_rms_deg),
                e.heading_rms_deg
            );
        }
        let _ = writeln!(
            o,
            "rotation cuts the final position error {:.1}x",
            self.errors_conventional.h_pos_end_m / self.errors_rotary.h_pos_end_m.max(1e-9)
        );
        o
    }

    /// Writes the plots (SVG and PNG), both trajectories, the calibration
    /// and both recordings into `dir`; returns the files written.
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn write(&self, dir: &Path) -> Result<Vec<std::path::PathBuf>> {
        let mut out = vec![];
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let charts = report::nav_charts(
            &[
                ("conventional", &self.rows_conventional),
                ("rotary", &self.rows_rotary),
            ],
            [0.0; 3],
        );
        for chart in charts {
            out.extend(chart.write(dir)?);
        }
        for (name, text) in [
            (
                "trajectory_rotary.csv",
                nav::trajectory_csv(&self.rows_rotary),
            ),
            (
                "trajectory_conventional.csv",
                nav::trajectory_csv(&self.rows_conventional),
            ),
            (
                "calibration.json",
                serde_json::to_string_pretty(&calibrate::to_json(&self.calibration))?,
            ),
        ] {
            let p = dir.join(name);
            std::fs::write(&p, text).with_context(|| format!("writing {}", p.display()))?;
            out.push(p);
        }
        for (name, rec) in [
            ("recording_rotary", &self.rotary),
            ("recording_conventional", &self.conventional),
        ] {
            let d = dir.join(name);
            if d.exists() {
                std::fs::remove_dir_all(&d)
                    .with_context(|| format!("replacing {}", d.display()))?;
            }
            rec.write(&d).map_err(|e| anyhow!("{e}"))?;
            out.push(d);
        }
        Ok(out)
    }
}

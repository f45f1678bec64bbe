//! Navigates a simulated static run with an ideal IMU, in f32 (as on the
//! MCU) and in f64 (the host twin), and prints how far each drifts.
//!
//! `cargo run --release -p core-nav --example static_nav [-- MINUTES [RATE_DPS]]`
//!
//! With `RATE_DPS` the table turns about z at that rate (the rotary case).

use core_nav::attitude::{euler_to_quat, quat_to_euler, rotate, Euler};
use core_nav::earth::{earth_rate_n, normal_gravity, GeoPoint};
use core_nav::real::{wrap_pi, Real};
use core_nav::strapdown::{ImuSample, Strapdown, StrapdownConfig};
use core_nav::table::{q_b_n, q_s_b, Axis};
use nalgebra::{Quaternion, Vector3};

/// Ideal IMU on a static base (heading 30 deg) with the table turning about z.
fn ideal(t_us: u64, rate: f64, base: &Quaternion<f64>, lat: f64, g: f64) -> ImuSample<f64> {
    let t = t_us as f64 * 1e-6;
    let q_s_n = base * q_s_b(Axis::Z, rate * t);
    let q_n_s = q_s_n.conjugate();
    let w_ie_n = earth_rate_n(lat.sin(), lat.cos());
    ImuSample {
        t_us,
        w_is_s: rotate(&q_n_s, &w_ie_n) + Vector3::z() * rate,
        f_s: rotate(&q_n_s, &Vector3::new(0.0, 0.0, -g)),
    }
}

fn run<T: Real>(minutes: f64, rate: f64) -> Result<(f64, f64, f64), core_nav::NavError> {
    let site = GeoPoint::from_deg(30.53, 114.36, 20.0);
    let base = euler_to_quat(&Euler::<f64>::from_deg(0.0, 0.0, 30.0));
    let g = normal_gravity(site.lat_rad.sin().powi(2), site.height_m);
    let cast = |s: ImuSample<f64>| ImuSample::<T> {
        t_us: s.t_us,
        w_is_s: s.w_is_s.map(T::lit),
        f_s: s.f_s.map(T::lit),
    };
    let q0 = Quaternion::from(base.coords.map(T::lit));
    let first = cast(ideal(0, rate, &base, site.lat_rad, g));
    let mut nav = Strapdown::new(
        StrapdownConfig::default(),
        site,
        Vector3::zeros(),
        q0,
        &first,
    )?;
    let n = (minutes * 6000.0) as u64;
    for k in 1..=n {
        nav.step(&cast(ideal(k * 10_000, rate, &base, site.lat_rad, g)))?;
    }
    let s = nav.state();
    let theta = wrap_pi(rate * n as f64 * 0.01);
    let q = q_b_n(&s.q_s_n, Axis::Z, T::lit(theta));
    let e = quat_to_euler(&Quaternion::from(q.coords.map(|x| x.to_f64())));
    let h = (s.p_n.x.to_f64().powi(2) + s.p_n.y.to_f64().powi(2)).sqrt();
    Ok((
        h,
        s.v_n.norm().to_f64(),
        (e.heading.to_degrees() - 30.0) * 3600.0,
    ))
}

fn main() -> Result<(), core_nav::NavError> {
    let mut args = std::env::args().skip(1);
    let minutes: f64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(60.0);
    let rate_dps: f64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(0.0);
    println!(
        "ideal IMU, static base at 30.53 N, table {rate_dps} deg/s about z, {minutes} min at 100 Hz"
    );
    println!(
        "{:>5} {:>14} {:>14} {:>18}",
        "type", "horiz pos [m]", "|vel| [m/s]", "heading err [\"]"
    );
    let (h, v, a) = run::<f64>(minutes, rate_dps.to_radians())?;
    println!("{:>5} {h:>14.3e} {v:>14.3e} {a:>18.4}", "f64");
    let (h, v, a) = run::<f32>(minutes, rate_dps.to_radians())?;
    println!("{:>5} {h:>14.3e} {v:>14.3e} {a:>18.4}", "f32");
    Ok(())
}

//! Measures dual-axis sequences against rotary-best (README numbers).
use rins::reproduce::{mean, run_one, Plan};
fn main() {
    let spec =
        hal_sim::imu::ImuSpec::by_name(&std::env::args().nth(1).unwrap_or_else(|| "nav440".into()))
            .expect("imu");
    for rate in [30.0, 100.0] {
        for (name, plan) in [
            ("best", Plan::Best),
            ("dual-8", Plan::DualAxis { positions: 8 }),
            ("dual-16", Plan::DualAxis { positions: 16 }),
            ("floor", Plan::NoiseFloor),
        ] {
            let v: Vec<_> = (0..8)
                .map(|s| run_one(&spec, plan, rate, 500 + s).expect("run"))
                .collect();
            let m = mean(&v);
            println!("{name:>8} {rate:>5}: pos {:7.1} m  vel {:.3} m/s  roll {:.4}  pitch {:.4}  heading {:.4} deg", m.h_pos_rms_m, m.h_vel_rms_mps, m.roll_rms_deg, m.pitch_rms_deg, m.heading_rms_deg);
        }
    }
}

//! The simulated noise has the statistics it claims.

use core_nav::allan::oadev;
use core_nav::scheme::Scheme;
use core_nav::table::Axis;
use hal_sim::imu::{ImuSpec, TriadModel, TriadSpec};
use hal_sim::rng::Rng;
use hal_sim::sim::{simulate, SimConfig};
use hal_sim::world::EncoderSpec;

#[test]
fn white_noise_recovers_arw_and_vrw_by_allan() {
    // 30 min static, only white noise. At tau = 1 s (m = 100) the overlapping
    // ADEV of white noise has ~1800 independent clusters: relative standard
    // deviation ~ 1/sqrt(2 * 1800) * 1.3 (overlap gain) ~ 2 %; 5 % is 2.5 sigma
    // per channel (the seed is fixed, so the test is deterministic).
    let arw = 0.3f64.to_radians() / 60.0; // 0.3 deg/sqrt(h)
    let vrw = 0.05 / 60.0; // 0.05 m/s/sqrt(h)
    let mut cfg = SimConfig::new(ImuSpec::ideal(), Axis::Z, 1800.0);
    cfg.ideal = true;
    cfg.set_effect("gyro_arw", arw).unwrap();
    cfg.set_effect("accel_vrw", vrw).unwrap();
    let rec = simulate(&cfg, &mut |_| {}).unwrap();
    for ch in 0..6 {
        let y = rec.channel(ch);
        let want = if ch < 3 { arw } else { vrw };
        let a = oadev(&y, 0.01, 100).unwrap();
        let n = a.adev * a.tau_s.sqrt();
        println!(
            "channel {ch}: N = {n:.4e}, set {want:.4e}, ratio {:.4}",
            n / want
        );
        assert!((n / want - 1.0).abs() < 0.05, "channel {ch}: {n} vs {want}");
    }
}

#[test]
fn gauss_markov_recovers_sigma_and_tau() {
    // 100 h at 1 Hz, 3 axes, tau = 50 s: N_eff = T / (2 tau) = 3600 per
    // axis. Pooled variance: relative sd sqrt(2 / 10800) = 1.4 % -> sigma to
    // 0.7 %; bound 4 %. Lag-tau autocorrelation e^-1 with sd ~0.01 ->
    // tau to ~2.7 %; bound 12 %.
    let (sigma, tau) = (1e-4, 50.0);
    let spec = TriadSpec {
        bias_instability: sigma,
        bi_tau_s: tau,
        ..TriadSpec::default()
    };
    let mut rng = Rng::new(42, 7);
    let mut m = TriadModel::realise(&spec, &mut rng);
    let n = 360_000;
    let mut xs = [
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    ];
    for _ in 0..n {
        m.advance(1.0, &mut rng);
        for (i, x) in xs.iter_mut().enumerate() {
            x.push(m.gm[i]);
        }
    }
    let (mut var, mut cov, mut cnt) = (0.0, 0.0, 0.0);
    let lag = tau as usize;
    for x in &xs {
        let mean = x.iter().sum::<f64>() / n as f64;
        var += x.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
        cov += (0..n - lag)
            .map(|i| (x[i] - mean) * (x[i + lag] - mean))
            .sum::<f64>();
        cnt += n as f64;
    }
    let s_hat = (var / cnt).sqrt();
    let rho = cov / var;
    let tau_hat = -(lag as f64) / rho.ln();
    println!("GM: sigma {s_hat:.4e} (set {sigma:.1e}), tau {tau_hat:.1} s (set {tau})");
    assert!((s_hat / sigma - 1.0).abs() < 0.04);
    assert!((tau_hat / tau - 1.0).abs() < 0.12);
}

#[test]
fn encoder_quantisation_within_one_count() {
    let e = EncoderSpec::default();
    let lsb = core::f64::consts::TAU / f64::from(e.counts_per_rev);
    let mut rng = Rng::new(3, 0);
    for _ in 0..100_000 {
        let theta = (rng.uniform() - 0.5) * 2000.0;
        let err = theta - e.count(theta) as f64 * lsb;
        assert!(
            (0.0..lsb).contains(&err),
            "theta {theta}: error {err} rad, count {lsb}"
        );
    }
    // Through the simulator (servo-driven table at 30 deg/s): every encoder
    // angle in the recording is a whole number of counts.
    let mut cfg = SimConfig::new(ImuSpec::ideal(), Axis::Z, 30.0);
    cfg.scheme = Scheme::Continuous {
        rate: 30f64.to_radians(),
    };
    let rec = simulate(&cfg, &mut |_| {}).unwrap();
    for r in &rec.table {
        let counts = r.angle_rad / lsb;
        assert!(
            (counts - counts.round()).abs() < 1e-6,
            "encoder angles are whole counts"
        );
    }
}

#[test]
fn same_seed_bit_identical_other_seed_not() {
    let run = |seed| {
        let mut cfg = SimConfig::new(ImuSpec::nav440(), Axis::Z, 20.0);
        cfg.scheme = Scheme::Continuous { rate: 0.5 };
        cfg.seed = seed;
        cfg.set_effect("jitter", 1e-4).unwrap();
        let r = simulate(&cfg, &mut |_| {}).unwrap();
        (r.imu_text(), r.table_text())
    };
    assert_eq!(run(5), run(5));
    assert_ne!(run(5).0, run(6).0);
}

#[test]
fn flicker_bank_gives_a_flat_allan_floor() {
    // The bank's Allan deviation stays within 25 % of 0.62 sigma from
    // tau_c / 3 to 30 tau_c (a single GM process falls by 3x over that span).
    let (sigma, tau) = (1e-4, 10.0);
    let spec = TriadSpec {
        bias_instability: sigma,
        bi_tau_s: tau,
        flicker: true,
        ..TriadSpec::default()
    };
    let mut rng = Rng::new(9, 7);
    let mut m = TriadModel::realise(&spec, &mut rng);
    let dt = 0.5;
    let y: Vec<f64> = (0..400_000)
        .map(|_| {
            m.advance(dt, &mut rng);
            m.gm[0]
        })
        .collect();
    for tau_avg in [tau / 3.0, tau, 3.0 * tau, 10.0 * tau, 30.0 * tau] {
        let a = oadev(&y, dt, (tau_avg / dt).round() as usize).unwrap().adev;
        println!("flicker: tau {tau_avg:>6.1} s adev/sigma {:.3}", a / sigma);
        assert!(
            (a / (0.62 * sigma) - 1.0).abs() < 0.25,
            "tau {tau_avg}: {}",
            a / sigma
        );
    }
}

//! The Monte Carlo's unit (issue 13's host goal: 1,000 five-minute rotary
//! runs in under 10 s on 2 cores): one run is the paper's timeline, 60 s
//! still and 60 s turning at 30 deg/s for the calibration, then 5 min of
//! navigation at the rate (`rins::reproduce::run_one`: simulate in
//! hal-sim, calibrate, navigate; in memory, no files). Two benchmarks:
//! one run, and 20 runs on 2 threads (10 each), whose time x 50 is the
//! 1,000-run figure on this machine's 2 cores.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use hal_sim::imu::ImuSpec;
use rins::reproduce::{run_one, Plan};

fn one(seed: u64) -> f64 {
    run_one(&ImuSpec::nav440(), Plan::Best, 30.0, seed).map_or(f64::NAN, |e| e.heading_rms_deg)
}

fn montecarlo(c: &mut Criterion) {
    c.bench_function("rotary_run_5min_simulate_calibrate_navigate", |b| {
        let mut seed = 0;
        b.iter(|| {
            seed += 1;
            black_box(one(seed))
        })
    });
    c.bench_function("rotary_runs_20_on_2_threads", |b| {
        b.iter(|| {
            std::thread::scope(|s| {
                let h: Vec<_> = (0..2u64)
                    .map(|t| {
                        s.spawn(move || (0..10u64).map(|k| one(100 + 10 * t + k)).sum::<f64>())
                    })
                    .collect();
                black_box(
                    h.into_iter()
                        .map(|h| h.join().unwrap_or(f64::NAN))
                        .sum::<f64>(),
                )
            })
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = montecarlo
}
criterion_main!(benches);

//! The Monte Carlo's unit (issue 13's host goal: 1,000 five-minute rotary
//! runs in under 10 s on 2 cores): one run is the paper's timeline, 60 s
//! still and 60 s turning at 30 deg/s for the calibration, then 5 min of
//! navigation at the rate (`rins::reproduce::run_one`: simulate in
//! hal-sim, calibrate, navigate; in memory, no files). Two benchmarks:
//! one run on one core, whose throughput line is the runs per second per
//! core, and 20 runs on 2 threads (10 each, rayon as the studies run
//! them), whose time x 50 is the 1,000-run figure on this machine's 2
//! cores (throughput: runs per second on both).

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use hal_sim::imu::ImuSpec;
use rayon::prelude::*;
use rins::reproduce::{run_one, Plan};

fn one(seed: u64) -> f64 {
    run_one(&ImuSpec::nav440(), Plan::Best, 30.0, seed).map_or(f64::NAN, |e| e.heading_rms_deg)
}

fn montecarlo(c: &mut Criterion) {
    rins::memory::keep_freed_memory(); // as the rins binary does
    let mut g = c.benchmark_group("montecarlo");
    g.throughput(Throughput::Elements(1));
    g.bench_function("rotary_run_5min_simulate_calibrate_navigate", |b| {
        let mut seed = 0;
        b.iter(|| {
            seed += 1;
            black_box(one(seed))
        })
    });
    g.throughput(Throughput::Elements(20));
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build();
    if let Ok(pool) = pool {
        g.bench_function("rotary_runs_20_on_2_threads", |b| {
            b.iter(|| {
                pool.install(|| black_box((100..120u64).into_par_iter().map(one).sum::<f64>()))
            })
        });
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = montecarlo
}
criterion_main!(benches);

//! `rins diagnose` on a 1 h recording at 100 Hz (issue 22's goal: under
//! 1 s on 2 cores): a NAV440-grade run with bias instability,
//! quantisation and the default table, reciprocating about z, a lever arm
//! hidden in it. Criterion's throughput line is hours of data a second
//! (its inverse: the time per hour of data).

use core_nav::table::Axis;
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use hal_sim::sim::simulate;
use rins::diagnose::{run, Options};

fn diagnose_1h(c: &mut Criterion) {
    rins::memory::keep_freed_memory(); // as the rins binary does
    let mut cfg = rins::study::background(
        &rins::study::grade("nav440", None).expect("grade"),
        Axis::Z,
        true,
        7,
    );
    cfg.duration_s = 3600.0;
    let _ = cfg.set_effect("lever_arm", 0.02);
    let Ok(rec) = simulate(&cfg, &mut |_| {}) else {
        return;
    };
    assert!(rec.imu.len() >= 360_000);
    let mut g = c.benchmark_group("diagnose");
    // One element = one hour of data.
    g.throughput(Throughput::Elements(1));
    g.bench_function("diagnose_1h_100hz", |b| {
        b.iter(|| run(black_box(&rec), "bench", &Options::default()).map(|d| d.findings.len()))
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = diagnose_1h
}
criterion_main!(benches);

//! Overlapping ADEV of 1e6 samples at every octave tau (the goal:
//! well under a second), and the noise fit.

use core_nav::allan::{fit_noise, oadev, octave_factors};
use criterion::{black_box, criterion_group, criterion_main, Criterion};

fn allan(c: &mut Criterion) {
    // A deterministic pseudo-random sequence (LCG), no extra dependency.
    let mut s: u64 = 0x2545_F491_4F6C_DD1D;
    let y: Vec<f64> = (0..1_000_000)
        .map(|_| {
            s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect();
    c.bench_function("oadev_1e6_octaves_and_fit", |b| {
        b.iter(|| {
            let pts: Vec<_> = octave_factors(y.len(), 10)
                .filter_map(|m| oadev(black_box(&y), 0.01, m))
                .collect();
            fit_noise(&pts)
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = allan
}
criterion_main!(benches);

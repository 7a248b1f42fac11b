//! Time to compute the paper-grid epd_g1 table (100 x 1000), all threads.
//! Run: `cargo bench --bench epd_g1` (RAYON_NUM_THREADS=1 for one thread).

use criterion::{criterion_group, criterion_main, Criterion};
use twoscale::progress::Progress;
use twoscale::tables::epd::{compute_g1, g1_axes};
use twoscale::tables::Preset;

fn paper_epd_g1(c: &mut Criterion) {
    let axes = g1_axes(Preset::Paper);
    let mut group = c.benchmark_group("epd_g1");
    group.sample_size(10);
    group.bench_function("paper_100x1000", |b| b.iter(|| compute_g1(&axes, Progress { quiet: true })));
    group.finish();
}

criterion_group!(benches, paper_epd_g1);
criterion_main!(benches);

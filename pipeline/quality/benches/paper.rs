//! Time to compute the paper-grid tables, all threads.
//! Run: `make bench` (RAYON_NUM_THREADS=1 for one thread).

use criterion::{criterion_group, criterion_main, Criterion};
use twoscale_generate::progress::Progress;
use twoscale_generate::tables::epd::{compute_g1, g1_axes};
use twoscale_generate::tables::{kcorr, zh, BuildOptions, Preset};

fn paper_epd_g1(c: &mut Criterion) {
    let axes = g1_axes(Preset::Paper);
    let mut group = c.benchmark_group("epd_g1");
    group.sample_size(10);
    group.bench_function("paper_100x1000", |b| b.iter(|| compute_g1(&axes, Progress { quiet: true })));
    group.finish();
}

fn paper_kcorr_renorm(c: &mut Criterion) {
    let mut group = c.benchmark_group("kcorr_renorm");
    group.sample_size(10);
    group.bench_function("paper_100x100x100", |b| b.iter(|| kcorr::compute(Preset::Paper, Progress { quiet: true })));
    group.finish();
}

/// The whole paper zh_convolution build (coefficients, synthesis, fits and
/// the error budget); filter with `cargo bench --bench paper -- zh`.
fn paper_zh_convolution(c: &mut Criterion) {
    let mut group = c.benchmark_group("zh_convolution");
    group.sample_size(10);
    let options = BuildOptions { progress: Progress { quiet: true }, ..Default::default() };
    group.bench_function("paper_43x11x25x10_L100", |b| {
        b.iter(|| zh::ZH_CONVOLUTION.build(Preset::Paper, &options).unwrap())
    });
    group.finish();
}

criterion_group!(benches, paper_epd_g1, paper_kcorr_renorm, paper_zh_convolution);
criterion_main!(benches);

//! Cost of one zh_lobe lookup as a renderer makes it: the shipped decoding
//! (control variates) against exp of the plainly interpolated ln C.
//! Run: `make bench` (or `cargo bench -p twoscale-quality --bench lookup`).

use criterion::{criterion_group, criterion_main, Criterion};
use ndarray::ArrayD;
use twoscale::accuracy::random_points;
use twoscale_quality::bench::zh_lobe::plain_lobe;
use twoscale::tables::zh_lobe::{grid, table_lobe, SIZES};

fn zh_lobe_lookup(c: &mut Criterion) {
    // The shipped grid; the cost does not depend on the stored values.
    let axes = grid(SIZES);
    let values = ArrayD::<f32>::zeros(axes.iter().map(|a| a.len()).collect::<Vec<_>>());
    let points: Vec<(Vec<f64>, f64)> = random_points(&axes[..4], 1000, 7)
        .into_iter()
        .enumerate()
        .map(|(i, p)| (p, std::f64::consts::FRAC_PI_2 * (i % 997) as f64 / 996.0))
        .collect();
    let mut group = c.benchmark_group("zh_lobe_lookup_1000_points");
    group.bench_function("control_variates", |b| b.iter(|| points.iter().map(|(p, th)| table_lobe(&axes, &values, p, *th)).sum::<f64>()));
    group.bench_function("plain", |b| b.iter(|| points.iter().map(|(p, th)| plain_lobe(&axes, &values, p, *th)).sum::<f64>()));
    group.finish();
}

criterion_group!(benches, zh_lobe_lookup);
criterion_main!(benches);
